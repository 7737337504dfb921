"""The horizontal controller: heading-frame sign conventions, latency compensation, feed-forward,
integral, limits; and the predicted-path interpolation it reads."""
import math

import numpy as np
import pytest

from platform_tracking.controller import (DroneState, PadPrediction, TrackingController, climb_rate_towards,
                                          clamp_norm)
from platform_tracking.params import TrackingParams

NO_LEAD = TrackingParams(lookahead=0.0, integral_gain=0.0, acceleration_feedforward=0.0)


def drone(x=0.0, y=0.0, vx=0.0, vy=0.0, yaw=0.0):
    return DroneState(np.array([x, y, 4.5]), np.array([vx, vy, 0.0]), yaw)


def still_pad(x, y, stamp=0.0, vx=0.0, vy=0.0):
    return PadPrediction(stamp, (x, y, 0.5), (vx, vy, 0.0))


def heading_command(params, drone_state, pad, t=0.0):
    controller = TrackingController(params)
    world = controller.world_velocity(t, drone_state, pad)
    return TrackingController.to_heading_frame(world, drone_state.yaw)


def test_pad_ahead_in_world_x_with_zero_yaw_is_forward():
    vx, vy = heading_command(NO_LEAD, drone(), still_pad(1.0, 0.0))
    assert vx == pytest.approx(NO_LEAD.position_gain) and vy == pytest.approx(0.0)


def test_pad_to_the_left_in_world_y_with_zero_yaw_is_positive_linear_y():
    vx, vy = heading_command(NO_LEAD, drone(), still_pad(0.0, 1.0))
    assert vx == pytest.approx(0.0) and vy == pytest.approx(NO_LEAD.position_gain)


def test_heading_frame_follows_the_drone_yaw():
    # Facing +y (yaw 90 deg): a pad at world +y is straight ahead, one at world +x is to the right.
    vx, vy = heading_command(NO_LEAD, drone(yaw=math.pi / 2), still_pad(0.0, 1.0))
    assert vx == pytest.approx(NO_LEAD.position_gain) and vy == pytest.approx(0.0, abs=1e-12)
    vx, vy = heading_command(NO_LEAD, drone(yaw=math.pi / 2), still_pad(1.0, 0.0))
    assert vx == pytest.approx(0.0, abs=1e-12) and vy == pytest.approx(-NO_LEAD.position_gain)
    # Facing -x: a pad at world +x is behind.
    vx, vy = heading_command(NO_LEAD, drone(yaw=math.pi), still_pad(1.0, 0.0))
    assert vx == pytest.approx(-NO_LEAD.position_gain)


def test_pad_velocity_is_fed_forward_in_the_heading_frame():
    vx, vy = heading_command(NO_LEAD, drone(vx=2.0), still_pad(0.0, 0.0, vx=2.0))
    assert (vx, vy) == pytest.approx((2.0, 0.0))
    vx, vy = heading_command(NO_LEAD, drone(vx=2.0, yaw=math.pi / 2), still_pad(0.0, 0.0, vx=2.0))
    assert (vx, vy) == pytest.approx((0.0, -2.0), abs=1e-12)  # world +x is to the right when facing +y


def test_latency_is_compensated_by_reading_the_prediction_at_the_current_time():
    # Measured 0.5 s ago at x=0, moving at 2 m/s: the pad is at x=1 now; the drone there has no error.
    pad = still_pad(0.0, 0.0, stamp=10.0, vx=2.0)
    controller = TrackingController(NO_LEAD)
    error, relative = controller.errors(10.5, drone(x=1.0, vx=2.0), pad)
    assert error == pytest.approx((0.0, 0.0)) and relative == pytest.approx((0.0, 0.0))
    assert controller.world_velocity(10.5, drone(x=1.0, vx=2.0), pad) == pytest.approx((2.0, 0.0))


def test_lookahead_damps_the_closing_speed():
    params = TrackingParams(integral_gain=0.0, acceleration_feedforward=0.0, lookahead=0.5)
    closing = TrackingController(params).world_velocity(0.0, drone(vx=1.0), still_pad(1.0, 0.0))
    assert closing[0] == pytest.approx(params.position_gain * (1.0 - 0.5 * 1.0))


def test_the_lookahead_follows_the_predicted_path_not_a_straight_line():
    times = [0.0, 0.5, 1.0]
    pad = PadPrediction(0.0, (0.0, 0.0, 0.5), (1.0, 0.0, 0.0), times, [(0, 0, 0.5), (0.5, 0.2, 0.5), (1.0, 0.8, 0.5)])
    params = TrackingParams(integral_gain=0.0, acceleration_feedforward=0.0, lookahead=0.5)
    command = TrackingController(params).world_velocity(0.0, drone(vx=1.0), pad)
    assert command[1] == pytest.approx(params.position_gain * 0.2)  # turning left ahead


def test_integral_accumulates_is_clamped_and_frozen_on_request():
    params = TrackingParams(lookahead=0.0, acceleration_feedforward=0.0, integral_gain=1.0, integral_speed_limit=0.3)
    controller = TrackingController(params)
    for k in range(60):
        command = controller.world_velocity(k * 0.1, drone(), still_pad(0.1, 0.0, stamp=k * 0.1))
    assert command[0] == pytest.approx(params.position_gain * 0.1 + 0.3)
    frozen = controller.integral.copy()
    controller.world_velocity(6.1, drone(), still_pad(-0.1, 0.0, stamp=6.1), accumulate=False)
    assert controller.integral == pytest.approx(frozen)
    controller.reset()
    assert controller.integral == pytest.approx((0.0, 0.0))


def test_integral_is_frozen_while_the_pad_accelerates():
    params = TrackingParams(lookahead=0.0, acceleration_feedforward=0.0, integral_gain=1.0)
    controller = TrackingController(params)
    integrals = []
    for k in range(30):  # pad accelerating at 3 m/s^2
        t = k * 0.05
        controller.world_velocity(t, drone(), still_pad(0.5, 0.0, stamp=t, vx=3.0 * t))
        integrals.append(controller.integral.copy())
    assert controller.acceleration[0] == pytest.approx(3.0)
    # Only the first samples, before the acceleration is measured over half a window, integrate.
    assert integrals[-1] == pytest.approx(integrals[10])


def test_acceleration_is_fed_forward_on_a_turn():
    params = TrackingParams(lookahead=0.0, integral_gain=0.0, acceleration_feedforward=0.5)
    controller = TrackingController(params)
    for k in range(21):  # velocity turning from +x towards +y: acceleration (0, 0.4) m/s^2
        t = k * 0.05
        command = controller.world_velocity(t, drone(vx=2.0), still_pad(0.0, 0.0, stamp=t, vx=2.0, vy=0.4 * t))
    assert command[1] == pytest.approx(0.4 * 1.0 + 0.4 * 0.5, abs=1e-6)


def test_commands_are_capped():
    params = TrackingParams(lookahead=0.0, integral_gain=0.0, max_correction_speed=2.0, max_horizontal_speed=5.0)
    controller = TrackingController(params)
    assert np.hypot(*controller.world_velocity(0.0, drone(), still_pad(30.0, 0.0))) == pytest.approx(2.0)
    assert np.hypot(*controller.world_velocity(0.1, drone(), still_pad(30.0, 0.0, stamp=0.1, vx=10.0))) \
        == pytest.approx(5.0)
    assert clamp_norm(np.array([3.0, 4.0]), 0.0) == pytest.approx((0.0, 0.0))


def test_climb_rate_sign_limit_and_deadband():
    p = TrackingParams()
    assert climb_rate_towards(2.0, 4.0, p) == pytest.approx(p.max_climb_rate)
    assert climb_rate_towards(4.3, 4.0, p) == pytest.approx(-0.3 * p.height_gain)
    assert climb_rate_towards(4.02, 4.0, p) == 0.0


def test_predicted_path_interpolation_and_extrapolation():
    pad = PadPrediction(1.0, (0.0, 0.0, 0.5), (1.0, 0.0, 0.0), [1.0, 2.0], [(0.0, 0.0, 0.5), (2.0, 0.0, 0.5)])
    assert pad.position_at(1.5)[0] == pytest.approx(1.0)   # along the path (2 m/s there)
    assert pad.position_at(3.0)[0] == pytest.approx(3.0)   # beyond: last point + velocity
    assert pad.position_at(0.5)[0] == pytest.approx(-0.5)  # before: first point - velocity
    assert pad.horizon == 2.0 and pad.age(1.25) == pytest.approx(0.25)
    bare = PadPrediction(1.0, (1.0, 2.0, 0.5), (0.0, 1.0, 0.0))
    assert bare.position_at(2.0) == pytest.approx((1.0, 3.0, 0.5))


def test_malformed_paths_are_rejected():
    with pytest.raises(ValueError, match="2 times but 1 positions"):
        PadPrediction(0.0, (0, 0, 0), (0, 0, 0), [0.0, 1.0], [(0, 0, 0)])
    with pytest.raises(ValueError, match="must not decrease"):
        PadPrediction(0.0, (0, 0, 0), (0, 0, 0), [1.0, 0.0], [(0, 0, 0), (1, 0, 0)])


def test_a_drone_state_is_moved_to_the_time_it_is_compared_at():
    state = DroneState(np.array([1.0, 2.0, 3.0]), np.array([10.0, -5.0, 0.5]), 0.3, sonar_height=1.0)
    later = state.moved(0.05)
    assert later.position == pytest.approx([1.5, 1.75, 3.025])
    assert later.velocity is state.velocity and later.yaw == 0.3 and later.sonar_height == 1.0
    assert state.position == pytest.approx([1.0, 2.0, 3.0])  # the original is left alone
