"""The checks every node wrapper applies to its inputs, and the throttled log of what it dropped (ROS-free)."""
import math

from landing_runtime.input_check import (MAX_POSITION_M, RejectionLog, choice_problem, frame_problem, numbers_problem,
                                      stamp_problem)


def test_numbers_name_the_first_bad_one_and_what_is_wrong():
    assert numbers_problem(MAX_POSITION_M, position=(1.0, 2.0, 3.0)) is None
    assert numbers_problem(10.0, position=(1.0, math.nan, 3.0)) == ("non-finite", "position[1] is nan")
    assert numbers_problem(10.0, speed=-math.inf) == ("non-finite", "speed is -inf")
    assert numbers_problem(10.0, v=(1.0, 1e30)) == ("out of range", "v[1] = 1e+30 is beyond +-10")
    assert numbers_problem(10.0, v=("a",))[0] == "malformed"


def test_stamps_from_another_time_are_named_a_zero_stamp_is_now():
    assert stamp_problem(99.9, 100.0) is None and stamp_problem(0.0, 100.0) is None
    assert stamp_problem(500.0, 0.0) is None  # the clock does not run yet
    kind, detail = stamp_problem(130.0, 100.0)
    assert kind == "stamp from the future" and "30.00 s after the clock" in detail
    assert stamp_problem(97.0, 100.0)[0] == "stamp from the past"
    assert stamp_problem(math.nan, 100.0)[0] == "non-finite"


def test_frames_and_words():
    assert frame_problem("/world", "world") is None and frame_problem("", "world") is None
    assert frame_problem("", "world", empty_ok=False)[0] == "wrong frame"
    assert frame_problem("map", ("world", "odom")) == ("wrong frame", "frame 'map', expected 'world' or 'odom'")
    assert choice_problem("takeoff", ("takeoff", "land")) is None
    assert choice_problem("x" * 500, ("takeoff",), "command")[1].startswith("command '" + "x" * 59)


def test_each_kind_on_each_topic_is_logged_once_per_period_with_the_count_of_the_rest():
    lines, now = [], [0.0]
    log = RejectionLog(lines.append, period_s=5.0, clock=lambda: now[0])
    for _ in range(10):
        log.reject("/imu", ("non-finite", "orientation.w is nan"))
    log.reject("/imu", ("stamp from the past", "stamped 1 s"))      # another kind: its own line
    log.reject("/gps", ("non-finite", "position[0] is nan"))        # another topic: its own line
    assert lines == ["rejected input on /imu [non-finite]: orientation.w is nan",
                     "rejected input on /imu [stamp from the past]: stamped 1 s",
                     "rejected input on /gps [non-finite]: position[0] is nan"]
    now[0] = 6.0
    log.reject("/imu", ("non-finite", "orientation.x is inf"))
    assert lines[-1] == "rejected input on /imu [non-finite]: orientation.x is inf; 9 more like it in the last 6 s"
    assert log.counts[("/imu", "non-finite")] == 11
