"""Keyboard map (teleop_twist_keyboard style), speed steps, limits and key-repeat timeout (ROS-free)."""
import math
import os

import pytest
import yaml

from ardrone_moves.keyboard import MOTION_KEYS, KeyboardConfig, KeyboardTeleop
from ardrone_moves.mapping import EMERGENCY, LAND, MANUAL, STOP, TAKEOFF, ConfigError, MissingParameter

KEYBOARD_YAML = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "config", "keyboard.yaml")


def params():
    with open(KEYBOARD_YAML) as stream:
        return yaml.safe_load(stream)


@pytest.fixture
def teleop():
    return KeyboardTeleop(KeyboardConfig.from_dict(params()))


def test_every_key_of_the_yaml_is_commented():
    with open(KEYBOARD_YAML) as stream:
        for line in stream:
            if line.strip() and not line.lstrip().startswith("#"):
                assert "#" in line, "uncommented key: " + line


@pytest.mark.parametrize("key, forward, left, climb, yaw", [
    ("i", 1, 0, 0, 0), (",", -1, 0, 0, 0), ("j", 0, 1, 0, 0), ("l", 0, -1, 0, 0),
    ("u", 1, 1, 0, 0), ("o", 1, -1, 0, 0), ("m", -1, 1, 0, 0), (".", -1, -1, 0, 0),
    ("t", 0, 0, 1, 0), ("b", 0, 0, -1, 0), ("a", 0, 0, 0, 1), ("d", 0, 0, 0, -1)])
def test_motion_keys(teleop, key, forward, left, climb, yaw):
    teleop.press(key, 0.0)
    command = teleop.tick(0.1)
    assert (math.copysign(1, command.forward) if command.forward else 0) == forward
    assert (math.copysign(1, command.left) if command.left else 0) == left
    assert command.climb == pytest.approx(climb * 0.5) and command.yaw_rate == pytest.approx(yaw * 0.5)
    assert math.hypot(command.forward, command.left) == pytest.approx(0.5 if forward or left else 0.0)


def test_first_motion_claims_manual_and_stop_keys_stop_once(teleop):
    assert teleop.press("i", 0.0).actions == (MANUAL,)
    assert teleop.press("i", 0.05).actions == ()     # key repeat: still the same take-over
    assert teleop.tick(0.1).forward == 0.5
    for stop_key in (" ", "k"):
        teleop.press("j", 0.2)
        assert teleop.press(stop_key, 0.3).message == "stop"
        assert teleop.tick(0.3) == STOP and teleop.tick(0.4) is None
    assert teleop.press("j", 0.5).actions == (MANUAL,)  # after a stop it is a new take-over


def test_no_key_for_the_timeout_stops(teleop):
    teleop.press("i", 10.0)
    assert teleop.tick(10.5).forward == 0.5          # exactly the timeout: still flying
    teleop.press("i", 10.5)
    assert teleop.tick(10.9).forward == 0.5
    assert teleop.tick(11.01) == STOP
    assert teleop.tick(11.1) is None


def test_unknown_keys_stop_and_line_ends_are_ignored(teleop):
    teleop.press("i", 0.0)
    assert teleop.press("\n", 0.0).actions == () and teleop.tick(0.1).forward == 0.5
    assert "unknown key 'x'" in teleop.press("x", 0.1).message
    assert teleop.tick(0.2) == STOP


def test_actions_are_capitals(teleop):
    assert teleop.press("T", 0.0).actions == (TAKEOFF,)
    assert teleop.press("L", 0.0).actions == (LAND,)
    assert teleop.press("E", 0.0).actions == (EMERGENCY,)
    assert teleop.press("l", 0.0).actions == (MANUAL,)   # lower case l flies right, it does not land


def test_speed_steps_respect_the_limits(teleop):
    assert teleop.press("q", 0.0).message == "speed 0.55 m/s, yaw rate 0.55 rad/s"
    teleop.press("z", 0.0)
    assert teleop.speed == pytest.approx(0.5)
    for _ in range(50):
        teleop.press("q", 0.0)
    assert teleop.speed == 2.0 and teleop.yaw_rate == 1.5
    teleop.press("t", 0.0)
    assert teleop.tick(0.0).climb == 0.8                 # climb capped separately
    teleop.press(",", 0.0)
    assert teleop.tick(0.0).forward == -2.0


def test_help_lists_every_key(teleop):
    text = teleop.press("h", 0.0).message
    for key in list(MOTION_KEYS) + ["q/z", "T", "L", "E", "space"]:
        assert key in text


def test_missing_or_bad_parameters_are_named():
    values = params()
    del values["key_timeout"]
    with pytest.raises(MissingParameter) as err:
        KeyboardConfig.from_dict(values)
    assert err.value.name == "key_timeout"
    values = params()
    values["speed_step"] = 0.9
    with pytest.raises(ConfigError, match="speed_step"):
        KeyboardConfig.from_dict(values)
