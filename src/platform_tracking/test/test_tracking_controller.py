"""The horizontal controller: heading-frame sign conventions, latency compensation, feed-forward,
integral, limits; and the predicted-path interpolation it reads."""
import math

import numpy as np
import pytest

from platform_tracking.controller import (DroneState, PadPrediction, TrackingController, climb_rate_towards,
                                          clamp_norm)
from platform_tracking.params import TrackingParams

NO_LEAD = TrackingParams(lookahead=0.0, integral_gain=0.0, velocity_lead=0.0)


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
    params = TrackingParams(integral_gain=0.0, velocity_lead=0.0, lookahead=0.5)
    closing = TrackingController(params).world_velocity(0.0, drone(vx=1.0), still_pad(1.0, 0.0))
    assert closing[0] == pytest.approx(params.position_gain * (1.0 - 0.5 * 1.0))


def test_along_the_pad_travel_the_error_has_its_own_gain_across_the_position_gain():
    params = TrackingParams(lookahead=0.0, integral_gain=0.0, velocity_lead=0.0, flow_time_lead=0.0,
                            acceleration_window=0.0, position_gain=1.0, along_track_gain=2.5)
    controller = TrackingController(params)
    # The pad travels along +y at 3 m/s, 0.2 m ahead of the drone and 0.1 m beside it (world +x).
    # Low over the vehicle (the drone's flow follows it alone, w = 1) the feed-forward is only the lead (0 here).
    command = controller.world_velocity(0.0, drone(vy=3.0), still_pad(0.1, 0.2, vy=3.0), flow_weight=1.0)
    assert command == pytest.approx((1.0 * 0.1, 2.5 * 0.2))
    # Stopped, it keeps the axis it travelled along.
    command = controller.world_velocity(0.1, drone(), still_pad(0.1, 0.2, stamp=0.1), flow_weight=1.0)
    assert command == pytest.approx((1.0 * 0.1, 2.5 * 0.2))
    # With the flow on the ground (w = 0) too.
    command = controller.world_velocity(0.2, drone(), still_pad(0.1, 0.2, stamp=0.2))
    assert command == pytest.approx((1.0 * 0.1, 2.5 * 0.2))


def test_the_along_track_gain_falls_as_the_camera_latency_grows():
    params = TrackingParams(lookahead=0.0, integral_gain=0.0, velocity_lead=0.0, flow_time_lead=0.0,
                            acceleration_window=0.0, position_gain=1.0, along_track_gain=2.5,
                            along_track_gain_latency=0.25)
    controller = TrackingController(params)
    controller.world_velocity(0.0, drone(vy=3.0), still_pad(0.1, 0.2, vy=3.0), flow_weight=1.0)  # travel: +y

    def along(t, latency):
        return controller.world_velocity(t, drone(), still_pad(0.1, 0.2, stamp=t), flow_weight=1.0,
                                         camera_latency=latency)[1] / 0.2
    assert along(0.1, 0.0) == pytest.approx(2.5)    # unknown (no detection yet): the configured gain
    assert along(0.2, 0.05) == pytest.approx(2.5)   # 0.25 / 0.05 = 5 would be more: capped by the gain
    assert along(0.3, 0.2) == pytest.approx(1.25)   # harsh's link: 0.25 / 0.2
    assert along(0.4, 1.0) == pytest.approx(1.0)    # never below the gain across the travel


def test_high_over_a_fast_car_the_along_track_gain_is_the_one_across():
    params = TrackingParams(lookahead=0.0, integral_gain=0.0, velocity_lead=0.0, flow_time_lead=0.0,
                            acceleration_window=0.0, position_gain=1.0, along_track_gain=2.5,
                            along_track_gain_max_pad_speed=8.0)
    controller = TrackingController(params)

    def along(t, speed, weight=0.0):
        pad = still_pad(0.0, 0.2, vy=speed, stamp=t)
        command = controller.world_velocity(t, drone(vy=speed), pad, flow_weight=weight)[1]
        return (command - (1.0 - weight) * speed) / 0.2  # over the pad the feed-forward is (1 - w) of its speed
    assert along(0.0, 3.0) == pytest.approx(2.5)       # a Summit XL's pace
    assert along(0.1, 15.0) == pytest.approx(1.0)      # a car's, seen from 4 m (the flow on the road)
    assert along(0.2, 15.0, 1.0) == pytest.approx(2.5)  # low over its pad, the flow on the pad


def test_a_pad_that_never_moved_has_no_travel_axis_and_one_gain():
    params = TrackingParams(lookahead=0.0, integral_gain=0.0, velocity_lead=0.0, position_gain=1.0,
                            along_track_gain=2.5)
    # Even low over the vehicle (w = 1).
    command = TrackingController(params).world_velocity(0.0, drone(), still_pad(0.3, 0.4), flow_weight=1.0)
    assert command == pytest.approx((0.3, 0.4))


def circle_prediction(t0, speed=3.0, radius=10.0, horizon=2.0):
    """The pad on a counter-clockwise circle around (0, radius), at (0, 0) heading +x at ``t0``."""
    omega = speed / radius
    times = [t0 + 0.1 * k for k in range(int(round(horizon / 0.1)) + 1)]
    positions = [(radius * math.sin(omega * (tk - t0)), radius * (1 - math.cos(omega * (tk - t0))), 0.5)
                 for tk in times]
    return PadPrediction(t0, positions[0], (speed, 0.0, 0.0), times, positions)


def test_on_a_circle_the_lookahead_does_not_pull_the_drone_inwards():
    """Reading the pad ``L`` ahead on its curved path would add a steady inward pull of a L^2 / 2."""
    params = TrackingParams(integral_gain=0.0, velocity_lead=0.0, lookahead=0.5)
    pad = circle_prediction(0.0)
    command = TrackingController(params).world_velocity(0.0, drone(vx=3.0), pad)
    assert command[1] == pytest.approx(0.0, abs=1e-6)


def test_the_feed_forward_is_the_pad_velocity_velocity_lead_ahead_on_the_path():
    params = TrackingParams(integral_gain=0.0, lookahead=0.0, velocity_lead=0.5)
    command = TrackingController(params).world_velocity(0.0, drone(vx=3.0), circle_prediction(0.0))
    turned = 0.3 * 0.5  # omega * lead
    assert command == pytest.approx((3.0 * math.cos(turned), 3.0 * math.sin(turned)), abs=0.01)


def test_integral_accumulates_is_clamped_and_frozen_on_request():
    params = TrackingParams(lookahead=0.0, velocity_lead=0.0, integral_gain=1.0, integral_speed_limit=0.3)
    controller = TrackingController(params)
    for k in range(60):
        command = controller.world_velocity(k * 0.1, drone(), still_pad(0.1, 0.0, stamp=k * 0.1))
    assert command[0] == pytest.approx(params.position_gain * 0.1 + 0.3)
    frozen = controller.integral.copy()
    controller.world_velocity(6.1, drone(), still_pad(-0.1, 0.0, stamp=6.1), accumulate=False)
    assert controller.integral == pytest.approx(frozen)
    controller.reset()
    assert controller.integral == pytest.approx((0.0, 0.0))


def accelerating_prediction(t0, x0, v0, acceleration, horizon=2.0):
    times = [t0 + 0.1 * k for k in range(int(round(horizon / 0.1)) + 1)]
    positions = [(x0 + v0 * (tk - t0) + 0.5 * acceleration * (tk - t0) ** 2, 0.0, 0.5) for tk in times]
    return PadPrediction(t0, positions[0], (v0, 0.0, 0.0), times, positions)


def test_integral_is_frozen_while_the_pad_speeds_up_or_brakes():
    params = TrackingParams(lookahead=0.0, velocity_lead=0.0, integral_gain=1.0)
    controller = TrackingController(params)
    for k in range(30):  # pad 0.5 m ahead, speeding up at 3 m/s^2
        t = k * 0.05
        controller.world_velocity(t, drone(), accelerating_prediction(t, 0.5, 1.0 + 3.0 * t, 3.0))
    assert controller.integral == pytest.approx((0.0, 0.0))


def corner_prediction(t0, turn_at, speed=3.0, radius=2.0):
    """The pad along +x at ``speed`` from (0, 0) at ``t0``, turning left on a ``radius`` circle from ``turn_at``."""
    def position(tk):
        if tk <= turn_at:
            return (speed * (tk - t0), 0.0, 0.5)
        angle = speed / radius * (tk - turn_at)
        return (speed * (turn_at - t0) + radius * math.sin(angle), radius * (1.0 - math.cos(angle)), 0.5)
    times = [t0 + 0.1 * k for k in range(21)]
    return PadPrediction(t0, position(t0), (speed, 0.0, 0.0), times, [position(tk) for tk in times])


def test_integral_is_frozen_while_the_pad_turns_in():
    """Entering a turn (the corner of a square) the error is a transient, like a braking."""
    params = TrackingParams(lookahead=0.0, velocity_lead=0.0, integral_gain=1.0, integral_turn_settle_time=0.0)
    controller = TrackingController(params)
    for k in range(10):  # the corner 0.5 s .. 0.05 s ahead, the drone 0.3 m behind the pad
        t = k * 0.05
        controller.world_velocity(t, drone(x=-0.3, vx=3.0), corner_prediction(t, turn_at=0.5))
    assert controller.integral == pytest.approx((0.0, 0.0))
    far = corner_prediction(0.0, turn_at=1.8)  # the corner 0.8 s ahead: the same error is integrated
    controller.world_velocity(1.0, drone(x=2.7, vx=3.0), far)
    controller.world_velocity(1.05, drone(x=2.85, vx=3.0), far)
    assert controller.integral[0] > 0.0


def test_the_integral_is_kept_along_and_across_the_pads_travel():
    """On a circle the drone's shortfall is steady along and across the pad's travel, not in the world."""
    params = TrackingParams(lookahead=0.0, velocity_lead=0.0, integral_gain=1.0)
    controller = TrackingController(params)
    speed, radius = 3.0, 10.0
    for k in range(100):  # 10 s on the circle, the drone 0.2 m outside it the whole time
        t = k * 0.1
        angle = speed / radius * t
        centre = np.array([0.0, radius])
        pad_xy = centre + radius * np.array([math.sin(angle), -math.cos(angle)])
        outward = (pad_xy - centre) / radius
        times = [t + 0.1 * j for j in range(21)]
        path = [(*(centre + radius * np.array([math.sin(speed / radius * tk), -math.cos(speed / radius * tk)])),
                 0.5) for tk in times]
        velocity = speed * np.array([math.cos(angle), math.sin(angle)])
        pad = PadPrediction(t, path[0], (*velocity, 0.0), times, path)
        controller.world_velocity(t, drone(*(pad_xy + 0.2 * outward), *velocity), pad)
    # All of it across the travel, pointing inwards (left of +x travel is +y): 0.2 m for 10 s.
    assert controller.integral == pytest.approx((0.0, 2.0), abs=0.05)


def test_after_a_corner_the_integral_waits_integral_turn_settle_time_but_not_after_a_reversal():
    """The drone overshoots as the pad leaves a corner: a transient, not a deficit to integrate (on a
    square at 3 m/s it kept the drone 0.13 m beside the pad along the next side)."""
    params = TrackingParams(lookahead=0.0, velocity_lead=0.0, integral_gain=1.0, integral_turn_settle_time=1.0)
    controller = TrackingController(params)
    for k in range(10):  # in the corner's onset: no integration
        t = k * 0.05
        controller.world_velocity(t, drone(x=-0.3, vx=3.0), corner_prediction(t, turn_at=0.5))
    straight = corner_prediction(0.0, turn_at=100.0)  # then a straight: the drone 0.3 m to its right
    t = 0.5
    while t < 0.5 + params.integral_turn_settle_time - 0.1:
        controller.world_velocity(t, drone(x=3.0 * t, y=-0.3, vx=3.0), straight)
        t += 0.05
    assert controller.integral == pytest.approx((0.0, 0.0))
    while t < 0.5 + params.integral_turn_settle_time + 0.5:
        controller.world_velocity(t, drone(x=3.0 * t, y=-0.3, vx=3.0), straight)
        t += 0.05
    assert controller.integral[1] > 0.05  # then it integrates the error across the travel
    # Back and forth: the pad pulls away backwards at 3 m/s^2 (no integration), then runs steadily at
    # -3 m/s, the drone 0.3 m short of it: integrated at once, not integral_turn_settle_time later.
    reversing = TrackingController(params)
    for k in range(20):
        t = k * 0.05
        reversing.world_velocity(t, drone(x=-1.5 * t * t + 0.3),
                                 accelerating_prediction(t, -1.5 * t * t, -3.0 * t, -3.0))
    assert reversing.integral == pytest.approx((0.0, 0.0))
    for k in range(20, 30):
        t = k * 0.05
        reversing.world_velocity(t, drone(x=-1.5 - 3.0 * (t - 1.0) + 0.3, vx=-3.0),
                                 accelerating_prediction(t, -1.5 - 3.0 * (t - 1.0), -3.0, 0.0))
    assert reversing.integral[0] == pytest.approx(0.3 * 0.45, abs=0.03)  # along the travel: 0.3 m for 0.45 s


def test_without_a_path_the_acceleration_is_fed_forward_on_a_turn():
    params = TrackingParams(lookahead=0.0, integral_gain=0.0, velocity_lead=0.5)
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


def test_a_state_from_an_attitude_has_its_yaw_and_sees_ahead_of_itself_when_pitched_nose_down():
    level = DroneState.from_attitude((1.0, 2.0, 4.0), (0.5, 0.0, 0.0), (math.cos(0.5), 0.0, 0.0, math.sin(0.5)))
    assert level.yaw == pytest.approx(1.0) and np.allclose(level.view_shift, 0.0)
    assert np.allclose(level.viewing(4.0).position, level.position)
    # Pitched 18 deg nose down (about body y) with yaw 0: the camera looks 4 * tan(18 deg) = 1.3 m behind.
    pitch = math.radians(18.0)
    leaning = DroneState.from_attitude((0.0, 0.0, 4.0), (10.0, 0.0, 0.0), (math.cos(pitch / 2), 0.0, math.sin(pitch / 2), 0.0))
    assert leaning.viewing(4.0).position[0] == pytest.approx(-4.0 * math.tan(pitch))
    upside_down = DroneState.from_attitude((0.0, 0.0, 4.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0))
    assert upside_down.view_shift is None


def test_a_prediction_moved_to_a_place_and_velocity_keeps_its_changes():
    """Moved so that at t it is 0.2 m further and 0.5 m/s faster along x: at t exactly there, 0.4 s later by the
    path's own change plus the moved velocity."""
    times = [0.0, 0.5, 1.0]
    path = [np.array([0.0, 0.0, 0.5]), np.array([1.0, 0.0, 0.5]), np.array([2.5, 0.0, 0.5])]
    pad = PadPrediction(0.0, path[0], np.array([2.0, 0.0, 0.0]), times, path)
    t = 0.25
    before = pad.position_at(t)
    moved = pad.moved_to(t, before[:2] + (0.2, 0.0), pad.path_velocity_at(t)[:2] + (0.5, 0.0))
    assert moved.position_at(t) == pytest.approx(before + (0.2, 0.0, 0.0))
    assert moved.position_at(t + 0.4) == pytest.approx(pad.position_at(t + 0.4) + (0.2 + 0.5 * 0.4, 0.0, 0.0))
    assert moved.position_at(t)[2] == pytest.approx(0.5)


def test_the_pads_acceleration_is_read_off_the_predicted_path():
    times = [0.1 * k for k in range(21)]
    speeding_up = PadPrediction(0.0, (0.0, 0.0, 0.5), (1.0, 0.0, 0.0), times,
                                [(1.0 * t + 0.5 * 0.8 * t ** 2, 0.0, 0.5) for t in times])
    assert speeding_up.acceleration_at(1.0)[:2] == pytest.approx((0.8, 0.0), abs=1e-6)
    assert speeding_up.acceleration_at(5.0) == pytest.approx((0.0, 0.0, 0.0))   # beyond the path
