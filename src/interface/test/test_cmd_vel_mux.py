"""Command selection of cmd_vel_mux (ROS-free): mode, priority, staleness."""
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
from interface.cmd_vel_mux import CommandSelector  # noqa: E402


@pytest.fixture
def mux():
    return CommandSelector(timeout_s=0.5)


def test_nothing_is_forwarded_without_a_live_input(mux):
    assert mux.select(1.0) is None
    mux.on_input("tracking", 1.0, "track")
    assert mux.select(1.5) == ("tracking", "track")
    assert mux.select(1.51) is None  # older than 0.5 s


def test_without_a_supervisor_the_priority_is_manual_emergency_tracking(mux):
    mux.on_input("tracking", 1.0, "track")
    mux.on_input("emergency", 1.0, "em")
    assert mux.select(1.1)[0] == "emergency"
    mux.on_input("manual", 1.0, "joy")
    assert mux.select(1.1)[0] == "manual"


@pytest.mark.parametrize("mode, expected", [
    ("landing", "tracking"), ("emergency", "emergency"), ("manual", None), ("idle", None), ("landed", None),
    ("quit", None)])
def test_the_mode_says_who_may_drive(mux, mode, expected):
    assert mux.set_mode(mode) is None
    mux.on_input("tracking", 1.0, "track")
    mux.on_input("emergency", 1.0, "em")
    choice = mux.select(1.2)
    assert (choice[0] if choice else None) == expected


@pytest.mark.parametrize("mode", ["landing", "emergency", "manual", "idle", "landed", "quit"])
def test_a_live_manual_command_always_wins(mux, mode):
    mux.set_mode(mode)
    mux.on_input("tracking", 1.0, "track")
    mux.on_input("emergency", 1.0, "em")
    mux.on_input("manual", 1.0, "joy")
    assert mux.select(1.2) == ("manual", "joy")
    assert mux.select(1.6) != ("manual", "joy")  # dead-man released: manual goes stale


def test_unknown_mode_is_reported_and_only_manual_drives(mux):
    assert "unknown supervisor mode 'dance'" in mux.set_mode("dance")
    mux.on_input("tracking", 1.0, "track")
    assert mux.select(1.1) is None


def test_bad_input_name_and_timeout(mux):
    with pytest.raises(KeyError, match="unknown input 'joystick'"):
        mux.on_input("joystick", 0.0, None)
    with pytest.raises(ValueError):
        CommandSelector(timeout_s=0.0)
