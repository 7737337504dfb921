"""landing_runtime.geometry against rotations built by hand (axis-angle products)."""
import math

import pytest

from landing_runtime.geometry import euler_from_quaternion, yaw_from_quaternion


def about(axis, angle):
    s = math.sin(angle / 2.0)
    return (math.cos(angle / 2.0),) + tuple(s * a for a in axis)


def product(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return (w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2)


@pytest.mark.parametrize("yaw", [0.0, 0.3, -2.5, math.pi - 1e-6])
def test_yaw_of_a_rotation_about_z(yaw):
    assert yaw_from_quaternion(*about((0, 0, 1), yaw)) == pytest.approx(yaw)


def test_roll_pitch_yaw_of_a_z_y_x_rotation():
    roll, pitch, yaw = 0.2, -0.4, 1.9
    q = product(product(about((0, 0, 1), yaw), about((0, 1, 0), pitch)), about((1, 0, 0), roll))
    assert euler_from_quaternion(*q) == pytest.approx((roll, pitch, yaw))
    # tilting does not change the heading
    assert yaw_from_quaternion(*q) == pytest.approx(yaw)
