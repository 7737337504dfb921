"""The pad relative to the drone, carried on by the flow between the camera's fixes (relative.py)."""
import numpy as np
import pytest

from drone_estimator.relative import RelativeTrack


def test_over_the_pad_the_flow_alone_carries_the_relative_position_whatever_the_vehicle_does():
    """The vehicle brakes from 3 m/s at 1 m/s^2 while the drone, flying on, keeps 3 m/s: the flow over the pad
    (weight 1) measures the drone's velocity relative to it, and the relative position follows without any
    estimate of the pad's velocity (a wrong one is given: it does not matter at weight 1)."""
    track = RelativeTrack(fix_gain=0.5, max_age=1.0)
    dt = 0.04
    track.add_motion(0.0, (0.0, 0.0), 1.0, (3.0, 0.0))
    track.add_fix(0.0, (0.1, -0.05))
    for k in range(1, 21):  # 0.8 s
        t = k * dt
        pad_v, drone_v = 3.0 - 1.0 * t, 3.0
        track.add_motion(t, (drone_v - pad_v, 0.0), 1.0, (3.0, 0.0))
    truth = np.array([0.1 - 0.8 ** 2 / 2.0, -0.05])
    position, rate = track.at(0.8)
    assert position == pytest.approx(truth, abs=0.005)
    assert rate == pytest.approx((-0.8, 0.0), abs=0.01)
    assert truth[0] < -0.15   # the pad fell 0.3 m behind: what the world route would learn late


def test_while_the_vehicle_speeds_up_the_firmwares_lag_behind_it_is_added_back():
    """The firmware's velocity estimate lags the vehicle's acceleration by its flow's response time: over the pad
    (weight 1) at 1 m/s^2 it reads the drone 0.17 m/s faster relative to the pad than it is."""
    flow_lag, acceleration = 0.17, np.array([1.0, 0.0])
    track = RelativeTrack(fix_gain=0.5, max_age=1.0, flow_lag=flow_lag)
    lagless = RelativeTrack(fix_gain=0.5, max_age=1.0)
    pad_v, drone_v = 2.0, 1.8   # the drone 0.2 m/s behind the pad
    for t in (0.0, 0.05):
        for each in (track, lagless):
            each.add_fix(0.0, (0.05, 0.0))
            each.add_motion(t, (drone_v - pad_v + flow_lag * acceleration[0], 0.0), 1.0, (pad_v, 0.0), acceleration)
    assert track.at(0.05)[1] == pytest.approx((0.2, 0.0))
    assert lagless.at(0.05)[1] == pytest.approx((0.2 - flow_lag, 0.0))


def test_off_the_pad_the_part_of_the_pads_velocity_the_flow_does_not_see_comes_from_the_prediction():
    track = RelativeTrack(fix_gain=0.5, max_age=1.0)
    track.add_fix(0.0, (0.0, 0.0))
    for k in range(11):  # the pad at 2 m/s, the drone at 1.5 m/s, the flow half on the pad (w = 0.5)
        track.add_motion(0.05 * k, (1.5 - 0.5 * 2.0, 0.0), 0.5, (2.0, 0.0))
    position, rate = track.at(0.5)
    assert rate == pytest.approx((0.5, 0.0))
    assert position == pytest.approx((0.25, 0.0), abs=1e-9)


def test_a_late_fix_pulls_the_track_at_its_own_capture_time_and_the_motion_since_is_added_again():
    track = RelativeTrack(fix_gain=0.5, max_age=1.0)
    track.add_fix(0.0, (0.0, 0.0))
    for k in range(11):
        track.add_motion(0.05 * k, (-1.0, 0.0), 1.0, (0.0, 0.0))  # the pad draws ahead at 1 m/s
    # Taken at 0.2 s, when the track said 0.2 m, the camera saw 0.3 m: half of the difference is taken, and the
    # 0.3 s of motion since is added on top.
    track.add_fix(0.2, (0.3, 0.0))
    position, _ = track.at(0.5)
    assert position == pytest.approx((0.25 + 0.3, 0.0), abs=1e-9)


def test_without_a_fix_for_max_age_there_is_no_relative_track_and_time_going_back_starts_afresh():
    track = RelativeTrack(fix_gain=0.5, max_age=1.0)
    assert track.at(0.0) is None
    track.add_fix(0.0, (0.1, 0.0))
    track.add_motion(0.0, (0.0, 0.0), 1.0, (0.0, 0.0))
    assert track.at(0.9) is not None
    assert track.at(1.1) is None
    track.add_motion(-5.0, (0.0, 0.0), 1.0, (0.0, 0.0))  # a new simulation
    assert track.at(-5.0) is None


def test_fixes_without_any_flow_sample_each_replace_the_last_and_give_no_track():
    # The ideal world has no flow on the link: the tracker's callback raised on every fix after the first.
    track = RelativeTrack(fix_gain=0.5, max_age=1.0)
    track.add_fix(0.0, (0.1, 0.0))
    track.add_fix(0.1, (0.3, 0.0))
    assert track.anchor[1] == pytest.approx((0.3, 0.0))
    assert track.at(0.1) is None
    track.add_motion(0.1, (0.0, 0.0), 1.0, (0.0, 0.0))
    position, _ = track.at(0.1)
    assert position == pytest.approx((0.3, 0.0))
