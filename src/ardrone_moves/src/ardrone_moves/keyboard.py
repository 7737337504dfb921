"""Keyboard -> drone commands in the style of teleop_twist_keyboard, ROS-free.

A motion key sets a direction; the command is that direction times the current speed and lasts
while the key keeps arriving (terminal key repeat): no key for ``key_timeout`` s stops the drone.
The keyboard needs no dead-man because releasing the key is the release.
"""
import math
from dataclasses import dataclass

from .mapping import EMERGENCY, LAND, MANUAL, STOP, TAKEOFF, ConfigError, VelocityCommand, required

DIAGONAL = math.sqrt(0.5)  # diagonal keys fly at the same ground speed as straight ones
# key: (forward, left, climb, yaw) as fractions of the current speed / yaw rate
MOTION_KEYS = {
    "u": (DIAGONAL, DIAGONAL, 0, 0), "i": (1, 0, 0, 0), "o": (DIAGONAL, -DIAGONAL, 0, 0),
    "j": (0, 1, 0, 0), "l": (0, -1, 0, 0),
    "m": (-DIAGONAL, DIAGONAL, 0, 0), ",": (-1, 0, 0, 0), ".": (-DIAGONAL, -DIAGONAL, 0, 0),
    "t": (0, 0, 1, 0), "b": (0, 0, -1, 0),
    "a": (0, 0, 0, 1), "d": (0, 0, 0, -1),
}
STOP_KEYS = (" ", "k")
FASTER, SLOWER = "q", "z"
ACTION_KEYS = {"T": TAKEOFF, "L": LAND, "E": EMERGENCY}  # capitals: a slip of the finger does not take off
HELP_KEYS = ("h", "?")
IGNORED_KEYS = ("\n", "\r")  # line ends when keys come from a pipe, one line per batch

HELP = """Reading from the keyboard
---------------------------
Fly (hold the key; no key for {timeout:.1f} s stops):
   u    i    o          t : up        a : yaw left
   j    k    l          b : down      d : yaw right
   m    ,    .
i/, forward/back, j/l left/right, u/o/m/. diagonals
space or k : stop (any other key stops too)
q/z : speed up/down by {step:.0%}
T : take off    L : land    E : emergency (operator/command)
h : this help   Ctrl-C : quit
"""


@dataclass(frozen=True)
class KeyboardConfig:
    speed: float           # initial horizontal speed [m/s]
    yaw_rate: float        # initial yaw rate [rad/s]
    max_speed: float       # horizontal speed limit [m/s]
    max_climb_rate: float  # climb/descent limit [m/s]
    max_yaw_rate: float    # yaw rate limit [rad/s]
    speed_step: float      # q multiplies, z divides the speeds by this factor (> 1)
    key_timeout: float     # no key for this long stops the drone [s]

    @classmethod
    def from_dict(cls, params):
        """From config/keyboard.yaml (the node's private parameters); errors name the key."""
        values = {name: required(params, name, float) for name in cls.__dataclass_fields__}
        for name, value in values.items():
            if not value > 0.0:
                raise ConfigError("parameter '%s' = %g must be > 0" % (name, value))
        if values["speed_step"] <= 1.0:
            raise ConfigError("parameter 'speed_step' = %g must be > 1" % values["speed_step"])
        return cls(**values)


@dataclass(frozen=True)
class KeyResult:
    actions: tuple = ()   # one-shot actions: TAKEOFF, LAND, EMERGENCY, MANUAL
    message: str = None   # what to tell the operator, if anything


class KeyboardTeleop:
    """``press(key, now)`` for every key read; ``tick(now)`` at the publishing rate returns the command
    to publish or None (silence, so another module may command the drone)."""

    def __init__(self, config):
        self.config = config
        self.speed = min(config.speed, config.max_speed)
        self.yaw_rate = min(config.yaw_rate, config.max_yaw_rate)
        self._direction = None        # active motion key's direction, None when stopped
        self._last_motion_key = None  # time of the last motion key [s]
        self._stop_due = False        # one STOP still to publish

    def press(self, key, now):
        if key in MOTION_KEYS:
            actions = () if self._direction is not None else (MANUAL,)  # a new motion = the operator takes over
            self._direction, self._last_motion_key = MOTION_KEYS[key], now
            return KeyResult(actions)
        if key in ACTION_KEYS:
            return KeyResult((ACTION_KEYS[key],))  # the node logs what it sent
        if key in (FASTER, SLOWER):
            factor = self.config.speed_step if key == FASTER else 1.0 / self.config.speed_step
            self.speed = min(self.speed * factor, self.config.max_speed)
            self.yaw_rate = min(self.yaw_rate * factor, self.config.max_yaw_rate)
            return KeyResult((), "speed %.2f m/s, yaw rate %.2f rad/s" % (self.speed, self.yaw_rate))
        if key in HELP_KEYS:
            return KeyResult((), self.help())
        if key in IGNORED_KEYS:
            return KeyResult()
        self._stop()  # space, k, and any unknown key: stopping is the safe reading of a stray key
        return KeyResult((), "stop" if key in STOP_KEYS else "stop (unknown key %r; h for help)" % key)

    def tick(self, now):
        if self._direction is not None and now - self._last_motion_key > self.config.key_timeout:
            self._stop()
        if self._direction is not None:
            return self.command()
        if self._stop_due:
            self._stop_due = False
            return STOP
        return None

    def command(self):
        forward, left, climb, yaw = self._direction
        climb_rate = min(self.speed, self.config.max_climb_rate)
        return VelocityCommand(forward * self.speed + 0.0, left * self.speed + 0.0,
                               climb * climb_rate + 0.0, yaw * self.yaw_rate + 0.0)

    def help(self):
        return HELP.format(timeout=self.config.key_timeout, step=self.config.speed_step - 1.0)

    def _stop(self):
        self._direction, self._stop_due = None, True
