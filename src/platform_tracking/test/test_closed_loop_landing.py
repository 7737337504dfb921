"""Closed loop in the real physics without vision (see closed_loop_landing.py): the estimator on the
simulator's sensors and the state machine flying the drone take off from the moving pad, track it
and land back on it. The pad prediction is a stand-in for the vision + Kalman pipeline (true pad
plus 3 cm noise, 50 ms latency). Each flight is ~30 s of sim time, a few seconds of wall time."""
import numpy as np
import pytest

pytest.importorskip("mujoco")
from closed_loop_landing import run_landing  # noqa: E402

SURFACE_PAD = 1
LIMIT = 0.15  # touchdown error limit of this package [m] (the product's 'on the pad' is 0.25 m)


def assert_landed_on_pad(result):
    assert result["landed"], "no touchdown; final state %s; log: %s" % (result["final_state"], result["log"])
    assert result["surface"] == SURFACE_PAD and not result["crashed"], result
    assert result["pad_error"] < LIMIT, result["pad_error"]
    assert result["final_state"] == "LANDED"


def states_visited(result):
    return [line.split(" -> ")[1].split(" ")[0] for _, line in result["log"] if " -> " in line]


@pytest.mark.parametrize("vehicle,path,speed", [("summit_xl", "straight", 1.0), ("summit_xl", "circle", 2.0),
                                                ("car", "straight", 15.0)])
def test_takes_off_tracks_and_lands_on_the_moving_pad(vehicle, path, speed):
    result = run_landing(vehicle, path, speed, radius=10.0, seed=0)
    assert_landed_on_pad(result)
    assert states_visited(result) == ["TAKING_OFF", "TRACKING", "LANDING", "LANDED"]
    assert result["impact_speed"] < 1.0


def test_the_estimator_stays_accurate_in_flight_without_ground_truth():
    """Where the drone is (GPS-limited), and above all how it moves over a camera latency: the pad is placed with
    the published position and tracked against it. Publishing the GPS corrections over 3 s instead of 0.3 s costs
    a few centimetres of the first (rms 0.10 -> 0.13 m here) and a third of the second (std 0.012 -> 0.008 m)."""
    result = run_landing("summit_xl", "circle", 2.0, seed=1)
    records = result["records"]
    flying = records["t"] > 5.0
    error = records["estimate"][flying] - records["drone"][flying]
    assert np.sqrt(np.mean(np.hypot(error[:, 0], error[:, 1]) ** 2)) < 0.15
    assert np.abs(error[:, 2]).max() < 0.1
    t = records["t"][flying]
    earlier = np.stack([np.interp(t[t > t[0] + 0.2] - 0.2, t, error[:, i]) for i in (0, 1)], axis=1)
    change = error[t > t[0] + 0.2, :2] - earlier
    assert change.std(axis=0).max() < 0.009


def test_a_lost_pad_is_relocated_and_the_landing_completes():
    result = run_landing("summit_xl", "straight", 1.0, seed=2, blackouts=[(8.0, 10.5)])
    visited = states_visited(result)
    assert visited[:4] == ["TAKING_OFF", "TRACKING", "RELOCATING", "TRACKING"]
    assert_landed_on_pad(result)


def test_the_truth_anchored_stand_in_lands_too():
    """The stand-in built literally from the true pad position: the controller then also carries the
    estimator's absolute (GPS-limited) error, which the vision's own anchoring removes."""
    result = run_landing("summit_xl", "straight", 1.0, seed=0, anchor="truth")
    assert_landed_on_pad(result)
