"""The scoring of a finished flight (flight_analysis.scoring, SPEC section 7), ROS-free."""
import os
import sys
from types import SimpleNamespace

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
from flight_analysis import scoring  # noqa: E402


def touchdown(surface, crashed=False, pad_error=0.05):
    return SimpleNamespace(surface=surface, crashed=crashed, pad_error=pad_error)


def test_outcomes():
    pad, ground = scoring.SURFACE_PAD, scoring.SURFACE_GROUND
    assert scoring.outcome(None, None, False) == ("timeout", None)
    assert scoring.outcome(touchdown(pad, crashed=True), 0.1, False) == ("crashed", None)
    assert scoring.outcome(touchdown(pad, pad_error=0.08), 0.09, False) == ("landed_on_pad", 0.08)
    assert scoring.outcome(touchdown(pad, pad_error=0.2), 0.3, False) == ("landed_off_pad", None)  # slid off
    assert scoring.outcome(touchdown(ground), None, True) == ("emergency_landed", None)
    assert scoring.outcome(touchdown(ground), None, False) == ("landed_off_pad", None)
    assert scoring.outcome(touchdown(scoring.SURFACE_VEHICLE), None, False) == ("landed_off_pad", None)
