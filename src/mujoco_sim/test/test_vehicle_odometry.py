"""The vehicle controller's emulated odometry (robotnik_base_control/odom), without ROS."""
import math

import numpy as np
import pytest

from mujoco_sim.vehicle_odometry import VehicleOdometry


def no_noise(_std):
    return 0.0


def test_dead_reckons_a_circle_in_an_enu_aligned_frame():
    odometry = VehicleOdometry(no_noise, 0.05, math.radians(2.0), 0.02)
    speed, rate, dt = 1.0, 0.1, 0.02
    for i in range(int(2 * math.pi / rate / dt) + 1):  # one full circle of radius 10 m, at 50 Hz
        t = i * dt
        yaw = math.pi / 2 + rate * t  # starts heading north
        reading = odometry.measure(t, yaw, (speed * math.cos(yaw), speed * math.sin(yaw)), rate)
    assert reading.position == pytest.approx((0.0, 0.0), abs=0.05)  # back where it started
    assert reading.forward_speed == pytest.approx(speed)
    assert reading.yaw_rate == pytest.approx(rate)
    assert math.cos(reading.yaw - (math.pi / 2 + rate * t)) == pytest.approx(1.0)


def test_a_quarter_turn_ends_where_the_world_says():
    odometry = VehicleOdometry(no_noise, 0.0, 0.0, 0.001)
    speed, rate, dt = 2.0, 0.2, 0.02
    for i in range(int(round(math.pi / 2 / rate / dt)) + 1):  # heading east, turning left: radius 10 m
        t = i * dt
        yaw = rate * t
        reading = odometry.measure(t, yaw, (speed * math.cos(yaw), speed * math.sin(yaw)), rate)
    assert reading.position == pytest.approx((10.0, 10.0), abs=0.02)


def test_covariances_state_the_noise_and_the_drift_grows():
    odometry = VehicleOdometry(no_noise, 0.05, math.radians(2.0), 0.02)
    first = odometry.measure(0.0, 0.0, (1.0, 0.0), 0.0)
    later = odometry.measure(1.0, 0.0, (1.0, 0.0), 0.0)
    assert first.pose_covariance[35] == pytest.approx(math.radians(2.0) ** 2)
    assert first.twist_covariance[0] == pytest.approx(0.05 ** 2)
    assert first.twist_covariance[35] == pytest.approx(0.02 ** 2)
    assert later.pose_covariance[0] > first.pose_covariance[0] > 0.0
    assert all(v == 0.0 for i, v in enumerate(later.pose_covariance + later.twist_covariance) if i % 36 % 7)


def test_noise_has_the_configured_spread():
    rng = np.random.default_rng(3)
    odometry = VehicleOdometry(lambda std: rng.normal(0.0, std) if std > 0 else 0.0, 0.05, math.radians(2.0), 0.02)
    readings = [odometry.measure(i * 0.02, 0.3, (math.cos(0.3), math.sin(0.3)), 0.0) for i in range(4000)]
    assert np.std([r.forward_speed for r in readings]) == pytest.approx(0.05, rel=0.1)
    assert np.std([r.yaw for r in readings]) == pytest.approx(math.radians(2.0), rel=0.1)
    assert np.std([r.yaw_rate for r in readings]) == pytest.approx(0.02, rel=0.1)
