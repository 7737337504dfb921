"""PS4 map (config/ps4.yaml): sticks, dead zone, limits, dead-man, button edges (ROS-free)."""
import os

import pytest
import yaml

from ardrone_moves.mapping import (EMERGENCY, LAND, MANUAL, STOP, TAKEOFF, ConfigError, JoystickConfig, JoystickTeleop,
                                   MissingParameter, VelocityCommand, apply_dead_zone, load_joystick_config)

PS4_YAML = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "config", "ps4.yaml")
SQUARE, CROSS, CIRCLE, TRIANGLE, L1 = 0, 1, 2, 3, 4  # Table 3.1
LEFT_X, LEFT_Y, RIGHT_X, RIGHT_Y = 0, 1, 2, 3       # Table 3.2


@pytest.fixture
def config():
    return load_joystick_config(PS4_YAML)


def joy(*held, **sticks):
    axes = [0.0] * 8
    for name, value in sticks.items():
        axes[globals()[name.upper()]] = value
    return axes, [1 if n in held else 0 for n in range(14)]


def test_shipped_map_is_the_documented_one(config):
    assert config.button_index == {"deadman": L1, "takeoff": TRIANGLE, "land": CROSS, "emergency": CIRCLE}
    assert config.axis_index == {"yaw": LEFT_X, "climb": LEFT_Y, "left": RIGHT_X, "forward": RIGHT_Y}
    assert not any(config.invert.values()) and 0.0 < config.dead_zone < 0.5


def test_every_key_of_the_yaml_is_commented():
    with open(PS4_YAML) as stream:
        for line in stream:
            if line.strip() and not line.lstrip().startswith("#"):
                assert "#" in line, "uncommented key: " + line


def test_mode2_sticks_follow_rep103_at_full_deflection(config):
    teleop = JoystickTeleop(config)
    command, _ = teleop.update(*joy(L1, right_y=1.0, right_x=1.0, left_y=-1.0, left_x=1.0))
    assert command == VelocityCommand(forward=config.max_speed["forward"], left=config.max_speed["left"],
                                      climb=-config.max_speed["climb"], yaw_rate=config.max_speed["yaw"])


def test_dead_zone_is_ignored_and_the_rest_rescaled():
    assert apply_dead_zone(0.05, 0.1) == 0.0 and apply_dead_zone(-0.1, 0.1) == 0.0
    assert apply_dead_zone(0.55, 0.1) == pytest.approx(0.5) and apply_dead_zone(-1.0, 0.1) == -1.0
    assert apply_dead_zone(1.7, 0.1) == 1.0  # out-of-range inputs are clipped, never exceed the limit


def test_inversion_flips_one_axis(config):
    params = yaml.safe_load(open(PS4_YAML))
    params["invert_forward"] = True
    command, _ = JoystickTeleop(JoystickConfig.from_dict(params)).update(*joy(L1, right_y=1.0))
    assert command.forward == -config.max_speed["forward"]


def test_nothing_moves_without_the_deadman_and_release_stops_once(config):
    teleop = JoystickTeleop(config)
    assert teleop.update(*joy(right_y=1.0)) == (None, [])          # stick alone: silence
    command, actions = teleop.update(*joy(L1, right_y=1.0))
    assert command.forward > 0 and actions == [MANUAL]            # the operator takes over
    command, actions = teleop.update(*joy(L1, right_y=0.5))
    assert 0 < command.forward < config.max_speed["forward"] and actions == []  # MANUAL once per hold
    assert teleop.update(*joy(right_y=0.5)) == (STOP, [])         # released: one zero command
    assert teleop.update(*joy(right_y=0.5)) == (None, [])         # then silence


def test_deadman_with_centred_sticks_hovers_without_claiming_manual(config):
    teleop = JoystickTeleop(config)
    assert teleop.update(*joy(L1)) == (STOP, [])
    assert teleop.update(*joy(L1, left_y=0.05)) == (STOP, [])     # inside the dead zone
    assert teleop.update(*joy(L1, left_y=0.5))[1] == [MANUAL]


def test_buttons_fire_on_the_press_only(config):
    teleop = JoystickTeleop(config)
    teleop.update(*joy())
    assert teleop.update(*joy(TRIANGLE)) == (None, [TAKEOFF])
    assert teleop.update(*joy(TRIANGLE)) == (None, [])            # held: no repeat
    assert teleop.update(*joy()) == (None, [])
    assert teleop.update(*joy(CROSS, CIRCLE))[1] == [EMERGENCY, LAND]
    assert teleop.update(*joy(SQUARE))[1] == []                    # unmapped button


def test_a_button_held_when_the_stick_appears_does_not_fire(config):
    teleop = JoystickTeleop(config)
    assert teleop.update(*joy(TRIANGLE)) == (None, [])
    teleop.update(*joy())
    assert teleop.update(*joy(TRIANGLE))[1] == [TAKEOFF]
    assert teleop.lost() is None                                   # was not flying: nothing to stop
    assert teleop.update(*joy(TRIANGLE))[1] == []                  # new baseline after the loss


def test_losing_the_stick_while_flying_stops_once(config):
    teleop = JoystickTeleop(config)
    teleop.update(*joy(L1, right_x=1.0))
    assert teleop.lost() == STOP and teleop.lost() is None


def test_joy_smaller_than_the_map_is_a_clear_error(config):
    with pytest.raises(ConfigError, match="joy has 2 axes but axis_forward is 3"):
        JoystickTeleop(config).update([0.0, 0.0], [0] * 14)
    with pytest.raises(ConfigError, match="joy has 4 buttons but button_deadman is 4"):
        JoystickTeleop(config).update([0.0] * 8, [0] * 4)


def test_missing_or_bad_parameters_are_named():
    params = yaml.safe_load(open(PS4_YAML))
    del params["button_deadman"]
    with pytest.raises(MissingParameter) as err:
        JoystickConfig.from_dict(params)
    assert err.value.name == "button_deadman"
    params = yaml.safe_load(open(PS4_YAML))
    params["dead_zone"] = 1.0
    with pytest.raises(ConfigError, match="dead_zone"):
        JoystickConfig.from_dict(params)
    params["dead_zone"], params["axis_yaw"] = 0.1, "left"
    with pytest.raises(ConfigError, match="axis_yaw"):
        JoystickConfig.from_dict(params)
    params["axis_yaw"], params["invert_yaw"] = 0, "no"
    with pytest.raises(ConfigError, match="invert_yaw"):
        JoystickConfig.from_dict(params)
