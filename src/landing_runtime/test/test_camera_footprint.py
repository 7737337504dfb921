"""The share of a downward camera's view a rectangle covers (landing_runtime.camera_footprint)."""
import math

import pytest

from landing_runtime import camera_footprint as cf

LEVEL = ((0.0, -1.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 0.0, -1.0))  # world <- optical for a level camera, yaw 0


def footprint(height, x=0.0, y=0.0, hfov=64.0, aspect=4.0 / 3.0, rotation=LEVEL):
    return cf.footprint((x, y, height), rotation, cf.corner_rays(hfov, aspect), 0.0)


def test_a_level_camera_sees_a_rectangle_of_its_field_of_view():
    corners = footprint(2.0)
    xs, ys = [c[0] for c in corners], [c[1] for c in corners]
    half_width = 2.0 * math.tan(math.radians(32.0))  # across the image (world y for a level camera)
    assert max(ys) == pytest.approx(half_width) and min(ys) == pytest.approx(-half_width)
    assert max(xs) == pytest.approx(half_width * 0.75)


def test_coverage_is_the_area_share_inside_the_rectangle():
    corners = footprint(2.0)  # 2.5 x 1.87 m
    assert cf.coverage(corners, (0.0, 0.0), 0.0, (-10, 10, -10, 10)) == pytest.approx(1.0)
    assert cf.coverage(corners, (0.0, 0.0), 0.0, (0, 10, -10, 10)) == pytest.approx(0.5)
    assert cf.coverage(corners, (0.0, 0.0), 0.0, (5, 10, -10, 10)) == 0.0
    # A 1 m pad straight below at 2 m: 1 / (2.5 * 1.87) of the view.
    area = 4 * 2.0 * math.tan(math.radians(32.0)) * 2.0 * math.tan(math.radians(32.0)) * 0.75
    assert cf.coverage(corners, (0.0, 0.0), 0.0, (-0.5, 0.5, -0.5, 0.5)) == pytest.approx(1.0 / area, rel=1e-6)
    # Turned by 90 degrees, a long rectangle covers a different share of the view.
    long = (-2.0, 2.0, -0.3, 0.3)
    assert cf.coverage(corners, (0.0, 0.0), 0.0, long) != pytest.approx(
        cf.coverage(corners, (0.0, 0.0), math.pi / 2, long))


def test_a_camera_at_or_below_the_plane_or_looking_up_has_no_footprint():
    assert cf.footprint((0.0, 0.0, 0.0), LEVEL, cf.corner_rays(64.0, 4 / 3), 0.5) is None
    up = tuple(tuple(-v for v in row) for row in LEVEL)
    assert cf.footprint((0.0, 0.0, 2.0), up, cf.corner_rays(64.0, 4 / 3), 0.0) is None


def test_the_weight_is_a_smooth_step_between_its_bounds():
    assert cf.surface_weight(0.2, 0.4, 0.7) == 0.0
    assert cf.surface_weight(0.8, 0.4, 0.7) == 1.0
    assert cf.surface_weight(0.55, 0.4, 0.7) == pytest.approx(0.5)
    assert 0.0 < cf.surface_weight(0.45, 0.4, 0.7) < 0.5
