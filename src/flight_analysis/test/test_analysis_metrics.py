"""Flight-analysis metrics (flight_analysis.analysis_metrics), ROS-free, with answers worked out by hand."""
import json
import math
import os
import sys
from types import SimpleNamespace

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
from flight_analysis import analysis_metrics as M  # noqa: E402


def line(t, x0=0.0, vx=0.0, y=0.0, z=0.0):
    t = np.asarray(t, dtype=float)
    return M.make_track(t, x=x0 + vx * t, y=np.full(t.shape, y), z=np.full(t.shape, z))


def test_interp_is_nan_outside_the_track_and_across_long_gaps():
    track = M.make_track([0.0, 1.0, 2.0, 5.0], x=[0.0, 1.0, 2.0, 5.0])
    out = M.interp(track, "x", [-0.1, 0.0, 0.5, 2.0, 3.0, 5.0, 5.1], max_gap=1.5)
    assert out[1] == 0.0 and out[2] == pytest.approx(0.5) and out[3] == 2.0 and out[5] == 5.0
    assert np.isnan(out[0]) and np.isnan(out[4]) and np.isnan(out[6])  # before, in the 3 s gap, after


def test_make_track_sorts_and_drops_duplicate_stamps():
    track = M.make_track([2.0, 1.0, 1.0, 3.0], x=[20.0, 10.0, 11.0, 30.0])
    assert list(track["t"]) == [1.0, 2.0, 3.0]
    assert list(track["x"]) == [11.0, 20.0, 30.0]


def test_constant_offset_gives_mae_and_rmse_equal_to_the_offset():
    t = np.arange(0, 30.0001, 0.01)                       # 100 Hz ground truth
    pad = line(t, vx=1.0)
    drone = M.make_track(t, x=pad["x"] + 0.3, y=pad["y"] + 0.4, z=pad["z"] + 3)   # 0.5 m horizontally
    _, errors, stats = M.tracking_error(drone, pad, windows=[(5.0, 25.0)])
    assert stats["mae_m"] == pytest.approx(0.5) and stats["rmse_m"] == pytest.approx(0.5)
    assert stats["samples"] == 400                        # 20 s at 20 Hz, window [5, 25) half-open
    assert stats["from_s"] == pytest.approx(5.0) and stats["to_s"] == pytest.approx(24.95)


def test_linearly_growing_error_has_the_hand_computed_mae_and_rmse():
    # Error e(t) = 0.2 t over t in [0, 10] s sampled on the 20 Hz grid: e_k = 2k/200, k = 0..200.
    # MAE = mean(e_k) = 1.0; RMSE^2 = (4/200^2) * sum(k^2)/201 = 4 * 200*201*401/6 / (40000*201) = 401/300.
    t = np.arange(0, 10.0001, 0.05)
    pad = line(t)
    drone = M.make_track(t, x=0.2 * t, y=np.zeros_like(t), z=np.ones_like(t))
    _, _, stats = M.tracking_error(drone, pad)
    assert stats["mae_m"] == pytest.approx(1.0, abs=1e-4)
    assert stats["rmse_m"] == pytest.approx(math.sqrt(401 / 300), abs=1e-4)
    assert stats["max_m"] == pytest.approx(2.0)


def test_the_average_is_over_time_not_over_messages():
    # Drone samples are dense while the error is 0 and sparse while it is 1 m: a per-message mean would
    # say ~0.1, the time average says 0.5.
    t_dense = np.arange(0, 5.0, 0.01)
    t_sparse = np.arange(5.0, 10.0001, 0.25)
    t = np.concatenate([t_dense, t_sparse])
    x = np.where(t < 5.0, 0.0, 1.0)
    drone = M.make_track(t, x=x, y=np.zeros_like(t), z=np.zeros_like(t))
    pad = line(np.arange(0, 10.0001, 0.01))
    _, _, stats = M.tracking_error(drone, pad, windows=[(0.0, 4.99), (5.0, 10.0)])
    assert stats["mae_m"] == pytest.approx(0.5, abs=0.01)


def test_timeline_merges_repeats_and_windows_pick_tracking_and_landing():
    segments = M.timeline([0, 1, 2, 3, 10, 12, 20], ["LANDED", "TAKING_OFF", "TAKING_OFF", "TRACKING", "LANDING",
                                                     "LANDING", "LANDED"], end_s=25.0)
    assert [(s["state"], s["start_s"], s["end_s"]) for s in segments] == [
        ("LANDED", 0, 1), ("TAKING_OFF", 1, 3), ("TRACKING", 3, 10), ("LANDING", 10, 20), ("LANDED", 20, 25)]
    assert M.windows_of(segments, M.TRACKING_STATES) == [(3, 20)]
    refined = M.timeline([0, 5, 8], ["TRACKING", "TRACKING_CLOSE", "LANDED"], end_s=9.0)
    assert M.windows_of(refined, M.TRACKING_STATES) == [(0, 8)]
    assert segments[1]["duration_s"] == 2


@pytest.mark.parametrize("text,expected", [("TRACKING", "TRACKING"), ("taking off", "TAKING_OFF"),
                                           ("Taking-Off", "TAKING_OFF"), ('{"state": "landing", "x": 1}', "LANDING"),
                                           ("", "UNKNOWN")])
def test_state_names_are_normalised(text, expected):
    assert M.normalize_state(text) == expected


def test_vision_errors_compare_at_the_same_stamps():
    t = np.arange(0, 10.0001, 0.02)
    pad = line(t, vx=2.0)
    stamps = np.array([1.0, 2.5, 7.25, 12.0])            # the last one is after the ground truth ends
    seen = M.make_track(stamps, x=2.0 * stamps + 0.1, y=np.full(4, 0.0), z=np.zeros(4))
    errors = M.sample_errors(seen, pad)
    assert errors[:3] == pytest.approx([0.1, 0.1, 0.1])
    assert np.isnan(errors[3])
    assert M.error_stats(errors)["samples"] == 3


def test_prediction_error_is_taken_at_the_predicted_stamp():
    t = np.arange(0, 20.0001, 0.02)
    pad = line(t, vx=1.0)
    made = np.array([1.0, 2.0, 3.0, 19.5])
    horizon = 2.0
    predictions = {"t": made, "t_h": made + horizon, "x_h": made + horizon + 0.3, "y_h": np.zeros(4) + 0.4,
                   "t0": made, "x0": made.copy(), "y0": np.zeros(4)}
    at_h, horizons, now = M.prediction_errors(predictions, pad)
    assert at_h[:3] == pytest.approx([0.5, 0.5, 0.5])
    assert np.isnan(at_h[3])                              # its horizon (21.5 s) is past the ground truth
    assert list(horizons) == [2.0] * 4
    assert now == pytest.approx([0, 0, 0, 0])


def test_relative_vision_error_uses_the_true_attitude():
    # Drone at the origin yawed +90 deg (x forward = world north); pad 2 m east = 2 m to the drone's right,
    # i.e. body (0, -2). A measurement of (0.1, -2.0) is 0.1 m off.
    t = np.arange(0, 1.0001, 0.1)
    n, s = len(t), math.sqrt(0.5)
    drone = M.make_track(t, x=np.zeros(n), y=np.zeros(n), z=np.full(n, 3.0), qx=np.zeros(n), qy=np.zeros(n),
                         qz=np.full(n, s), qw=np.full(n, s))
    pad = M.make_track(t, x=np.full(n, 2.0), y=np.zeros(n), z=np.full(n, 0.5))
    seen = M.make_track([0.5], x=[0.1], y=[-2.0], z=[-2.5])
    assert M.relative_vision_errors(seen, drone, pad) == pytest.approx([0.1])


def test_takeoff_time_is_the_earlier_of_command_and_navdata():
    nav_t = np.array([0.0, 1.0, 2.0, 3.0])
    nav_state = np.array([2, 2, 6, 3])
    assert M.takeoff_time([2.5], nav_t, nav_state) == (2.0, "navdata left LANDED")
    assert M.takeoff_time([1.5], nav_t, nav_state) == (1.5, "first /ardrone/takeoff command")
    # started in the air: no LANDED sample, no command -> the first fallback that exists
    assert M.takeoff_time([], nav_t, np.array([3, 3, 3, 3]), [(None, "a"), (0.7, "b")]) == (0.7, "b")
    assert M.takeoff_time([], None, None) == (None, None)


def test_battery_separates_drain_from_a_level_set_by_hand():
    t = np.arange(6.0)
    level = np.array([80.0, 79.9, 79.8, 10.0, 9.9, 9.8])
    b = M.battery(t, level)
    assert b["used_pct"] == pytest.approx(0.4)
    assert b["start_pct"] == 80.0 and b["end_pct"] == 9.8
    assert b["level_set"] == [{"t": 3.0, "from_pct": 79.8, "to_pct": 10.0}]


def test_decisions_from_json_text_objects_and_garbage():
    text = json.dumps({"t": 12.34567, "condition": "wind_strong", "flag": 2, "action": "warn", "reason": "wind",
                       "value": 9.0})
    d = M.parse_decision(text, bag_t=13.0)
    assert d == {"t": 12.346, "condition": "wind_strong", "flag": 2, "action": "warn", "reason": "wind", "value": 9.0}
    message = SimpleNamespace(t=5.0, condition="drone_battery", flag=1, action="emergency_landing",
                              reason="battery 10 %")
    d = M.parse_decision(message, bag_t=5.5)
    assert d["action"] == "emergency_landing" and d["t"] == 5.0 and d["value"] is None
    d = M.parse_decision("not json", bag_t=7.0)
    assert d["t"] == 7.0 and d["reason"] == "not json"


def test_wind_is_the_largest_value_from_any_source():
    decisions = [{"t": 1.0, "condition": "wind_strong", "value": 8.0},
                 {"t": 2.0, "condition": "wind_direction", "value": 270.0},
                 {"t": 3.0, "condition": "drone_battery", "value": 50.0}]
    logs = [(4.0, "condition /wind_speed: 8.0 -> 13.5"), (5.0, "something else")]
    scenario = {"conditions": {"wind_speed": 2.0}, "events": [{"at_s": 6, "set_param": "wind_speed", "value": 11}]}
    winds = M.wind_speeds(decisions, logs, scenario)
    assert max(w for _, w, _ in winds) == 13.5
    assert sorted(w for _, w, _ in winds) == [2.0, 8.0, 8.0, 11.0, 13.5]


@pytest.mark.parametrize("surface,crashed,pad_error,resting,emergency,expected", [
    (1, False, 0.1, 0.12, False, ("landed_on_pad", 0.1)),
    (1, False, 0.2, 0.4, False, ("landed_off_pad", None)),   # slid off the tolerance after touchdown
    (1, True, 0.1, None, False, ("crashed", None)),
    (2, False, 3.0, None, True, ("emergency_landed", None)),
    (2, False, 3.0, None, False, ("landed_off_pad", None)),
])
def test_outcome_follows_the_scoring_rules(surface, crashed, pad_error, resting, emergency, expected):
    td = SimpleNamespace(surface=surface, crashed=crashed, pad_error=pad_error)
    assert M.outcome(td, resting, emergency) == expected
    assert M.outcome(None, None, False) == ("timeout", None)


def test_error_stats_of_nothing_is_none():
    assert M.error_stats([]) is None
    assert M.error_stats([np.nan, np.nan]) is None
