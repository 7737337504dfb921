"""PS4 joystick -> drone commands (thesis Tables 3.1 and 3.2), ROS-free.

Mode 2 sticks: the left stick climbs (up/down) and yaws (left/right), the right stick flies forward
(up/down) and sideways (left/right). Axes follow the ROS joy_node convention (stick up and stick
left are +1), so with no inversion every command follows REP 103: forward, left, up and
counter-clockwise are positive. Motion needs the dead-man button held; buttons act on the press.
"""
from dataclasses import dataclass

import yaml

TAKEOFF, LAND, EMERGENCY, MANUAL = "takeoff", "land", "emergency", "manual"
AXES = ("forward", "left", "climb", "yaw")
SPEED_LIMITS = {"forward": "max_forward_speed", "left": "max_left_speed", "climb": "max_climb_rate",
                "yaw": "max_yaw_rate"}
ACTION_BUTTONS = (("emergency", EMERGENCY), ("land", LAND), ("takeoff", TAKEOFF))  # emergency first if pressed together
BUTTONS = ("deadman",) + tuple(name for name, _ in ACTION_BUTTONS)


@dataclass(frozen=True)
class VelocityCommand:
    """What geometry_msgs/Twist on ardrone/cmd_vel carries (heading frame)."""
    forward: float = 0.0   # linear.x [m/s]
    left: float = 0.0      # linear.y [m/s]
    climb: float = 0.0     # linear.z [m/s]
    yaw_rate: float = 0.0  # angular.z, counter-clockwise [rad/s]

    def is_zero(self):
        return not (self.forward or self.left or self.climb or self.yaw_rate)


STOP = VelocityCommand()


class ConfigError(ValueError):
    pass


class MissingParameter(ConfigError):
    def __init__(self, name):
        super().__init__("required parameter '%s' is not set" % name)
        self.name = name


def required(params, name, kind):
    """params[name] converted by ``kind``; MissingParameter or ConfigError naming the key otherwise."""
    if name not in params:
        raise MissingParameter(name)
    try:
        if kind is bool and not isinstance(params[name], bool):
            raise TypeError("not true/false")
        return kind(params[name])
    except (TypeError, ValueError) as err:
        raise ConfigError("parameter '%s' = %r is not a valid %s (%s)" % (name, params[name], kind.__name__, err))


@dataclass(frozen=True)
class JoystickConfig:
    axis_index: dict     # command axis name -> index into Joy.axes
    invert: dict         # command axis name -> flip its sign
    max_speed: dict      # command axis name -> command at full deflection [m/s or rad/s]
    button_index: dict   # deadman/takeoff/land/emergency -> index into Joy.buttons
    dead_zone: float     # fraction of full travel ignored around the centre

    @classmethod
    def from_dict(cls, params):
        """From the flat keys of config/ps4.yaml (the node's private parameters)."""
        config = cls(
            axis_index={name: required(params, "axis_" + name, int) for name in AXES},
            invert={name: required(params, "invert_" + name, bool) for name in AXES},
            max_speed={name: required(params, SPEED_LIMITS[name], float) for name in AXES},
            button_index={name: required(params, "button_" + name, int) for name in BUTTONS},
            dead_zone=required(params, "dead_zone", float))
        if not 0.0 <= config.dead_zone < 1.0:
            raise ConfigError("parameter 'dead_zone' = %g must be in [0, 1)" % config.dead_zone)
        for name, limit in config.max_speed.items():
            if not limit >= 0.0:
                raise ConfigError("parameter '%s' = %g must be >= 0" % (SPEED_LIMITS[name], limit))
        for key, index in list(config.axis_index.items()) + list(config.button_index.items()):
            if index < 0:
                raise ConfigError("index of '%s' = %d must be >= 0" % (key, index))
        return config


def load_joystick_config(path):
    with open(path) as stream:
        return JoystickConfig.from_dict(yaml.safe_load(stream) or {})


def apply_dead_zone(value, dead_zone):
    """0 inside the dead zone, then rescaled so the command still grows smoothly from 0 to 1."""
    value = max(-1.0, min(1.0, float(value)))
    if abs(value) <= dead_zone:
        return 0.0
    magnitude = (abs(value) - dead_zone) / (1.0 - dead_zone)
    return magnitude if value > 0 else -magnitude


class JoystickTeleop:
    """Joy state -> (command to publish or None, one-shot actions).

    With the dead-man held every Joy message yields a command (centred sticks = hover). On release
    one STOP is returned, then None: the joystick falls silent so another module may command the
    drone. MANUAL is emitted once when a stick moves with the dead-man held (the operator takes
    over). The first message after start or ``lost`` only sets the button baseline: a button that is
    already down when the stick (re)appears does not fire."""

    def __init__(self, config):
        self.config = config
        self._previous_buttons = None
        self._commanding = False   # published a command since the dead-man went down
        self._engaged = False      # MANUAL already sent for this hold of the dead-man

    def update(self, axes, buttons):
        self._check_sizes(axes, buttons)
        pressed = {name: bool(buttons[index]) for name, index in self.config.button_index.items()}
        actions = []
        if self._previous_buttons is not None:
            actions = [action for name, action in ACTION_BUTTONS
                       if pressed[name] and not self._previous_buttons[name]]
        self._previous_buttons = pressed
        if not pressed["deadman"]:
            self._engaged = False
            if self._commanding:
                self._commanding = False
                return STOP, actions
            return None, actions
        command = self.command_from_sticks(axes)
        if not self._engaged and not command.is_zero():
            self._engaged = True
            actions.append(MANUAL)
        self._commanding = True
        return command, actions

    def lost(self):
        """The Joy stream went stale (stick unplugged): STOP if it was commanding, else None."""
        was_commanding = self._commanding
        self._previous_buttons, self._commanding, self._engaged = None, False, False
        return STOP if was_commanding else None

    def command_from_sticks(self, axes):
        values = {}
        for name in AXES:
            value = apply_dead_zone(axes[self.config.axis_index[name]], self.config.dead_zone)
            if self.config.invert[name]:
                value = -value
            values[name] = value * self.config.max_speed[name] + 0.0  # + 0.0: no -0.0
        return VelocityCommand(values["forward"], values["left"], values["climb"], values["yaw"])

    def _check_sizes(self, axes, buttons):
        for name, index in self.config.axis_index.items():
            if index >= len(axes):
                raise ConfigError("joy has %d axes but axis_%s is %d: check the pad or config/ps4.yaml"
                                  % (len(axes), name, index))
        for name, index in self.config.button_index.items():
            if index >= len(buttons):
                raise ConfigError("joy has %d buttons but button_%s is %d: check the pad or config/ps4.yaml"
                                  % (len(buttons), name, index))
