"""What a browser may send to the web operator station, ROS-free: every message is validated here and
either becomes an action for the node or an error that says what is wrong and what to send instead.

Messages are JSON objects with a ``type``:

- ``{"type": "command", "name": "landing"}``: an operator command (``COMMANDS``) for operator/command;
- ``{"type": "set", "name": "drone_battery", "value": 10}``: a condition parameter (``CONDITIONS``), the
  same as ``rosparam set /drone_battery 10``;
- ``{"type": "key", "key": "i"}``: a key of ardrone_moves' keyboard teleop (Manual Control);
- ``{"type": "joy", "axes": [...], "buttons": [...]}``: a pad in the browser's Gamepad API "standard"
  layout (a PS4 pad, or the on-screen sticks), turned into the thesis' Tables 3.1/3.2 numbering here.
"""
import json
import math

from ardrone_moves.keyboard import ACTION_KEYS, FASTER, MOTION_KEYS, SLOWER, STOP_KEYS

COMMANDS = ("start", "landing", "manual", "emergency", "continue", "ack", "takeoff", "quit")
# Condition parameters the page may set: name -> (lowest, highest, unit, label). The ranges are what the
# simulator and the supervisor accept as readable values (mujoco_sim's schema, config/conditions.yaml).
CONDITIONS = {
    "wind_speed": (0.0, 60.0, "m/s", "Wind speed"),
    "wind_direction_deg": (-360.0, 360.0, "deg", "Wind direction (blowing towards, from +x)"),
    "wind_gust": (0.0, 30.0, "m/s", "Gusts"),
    "drone_speed": (0.0, 60.0, "m/s", "Drone speed"),
    "control_battery": (0.0, 100.0, "%", "Controller battery"),
    "drone_battery": (0.0, 100.0, "%", "Drone battery"),
    "temp": (-60.0, 70.0, "deg C", "Temperature"),
}
KEYS = tuple(MOTION_KEYS) + STOP_KEYS + (FASTER, SLOWER) + tuple(ACTION_KEYS)
MAX_MESSAGE_BYTES = 4096     # a client message is small; anything larger is refused unread
MAX_PAD_ENTRIES = 32         # axes or buttons of one pad

# Gamepad API "standard" layout -> thesis Table 3.1 (buttons) / 3.2 (axes), ds4drv numbering.
STANDARD_TO_TABLE_3_1 = (2, 0, 1, 3, 4, 5, 6, 7, 8, 9, 10, 11, 16, 17)  # Square, X, Circle, Triangle, L1 ... Touch Pad
TABLE_3_2_AXES = 8           # Left X, Left Y, Right X, Right Y, L2, R2, Touch Pad X, Touch Pad Y


class BadMessage(ValueError):
    """What is wrong with a client message and what to send instead."""


def parse(text):
    """A client's text frame -> a validated message dict; BadMessage otherwise."""
    if len(text) > MAX_MESSAGE_BYTES:
        raise BadMessage("message of %d bytes refused: at most %d" % (len(text), MAX_MESSAGE_BYTES))
    try:
        message = json.loads(text)
    except ValueError as err:
        raise BadMessage("not JSON (%s): send an object such as {\"type\": \"command\", \"name\": \"landing\"}"
                         % err)
    if not isinstance(message, dict):
        raise BadMessage("expected a JSON object with a 'type', got %s" % type(message).__name__)
    kind = message.get("type")
    checker = {"command": _command, "set": _set, "key": _key, "joy": _joy}.get(kind)
    if checker is None:
        raise BadMessage("unknown message type %r: expected command, set, key or joy" % (kind,))
    return checker(message)


def _command(message):
    name = message.get("name")
    if name not in COMMANDS:
        raise BadMessage("unknown command %r: expected one of %s" % (name, ", ".join(COMMANDS)))
    return {"type": "command", "name": name}


def _number(value, what):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise BadMessage("%s must be a finite number, got %r" % (what, value))
    return float(value)


def _set(message):
    name = message.get("name")
    if name not in CONDITIONS:
        raise BadMessage("unknown condition %r: the page may set %s" % (name, ", ".join(CONDITIONS)))
    low, high, unit, _ = CONDITIONS[name]
    value = message.get("value")
    if isinstance(value, str):
        try:
            value = float(value.strip())
        except ValueError:
            raise BadMessage("%s must be a number in %g..%g %s, got %r" % (name, low, high, unit, message["value"]))
    value = _number(value, name)
    if not low <= value <= high:
        raise BadMessage("%s = %g is outside %g..%g %s" % (name, value, low, high, unit))
    return {"type": "set", "name": name, "value": value}


def _key(message):
    key = message.get("key")
    if key not in KEYS:
        raise BadMessage("key %r is not a teleop key: %s" % (key, " ".join(repr(k) for k in KEYS)))
    return {"type": "key", "key": key}


def _joy(message):
    axes, buttons = message.get("axes"), message.get("buttons")
    if not isinstance(axes, list) or not isinstance(buttons, list):
        raise BadMessage("joy needs 'axes' and 'buttons' lists (Gamepad API standard layout)")
    if len(axes) > MAX_PAD_ENTRIES or len(buttons) > MAX_PAD_ENTRIES:
        raise BadMessage("joy has %d axes and %d buttons: at most %d each" % (len(axes), len(buttons), MAX_PAD_ENTRIES))
    if len(axes) < 4 or len(buttons) < 12:
        raise BadMessage("joy has %d axes and %d buttons: the standard layout has at least 4 and 12 (is the "
                         "pad's mapping 'standard'?)" % (len(axes), len(buttons)))
    axes = [max(-1.0, min(1.0, _number(v, "axis %d" % i))) for i, v in enumerate(axes)]
    buttons = [max(0.0, min(1.0, _number(v, "button %d" % i))) for i, v in enumerate(buttons)]
    return {"type": "joy", "axes": axes, "buttons": buttons}


def standard_to_joy(axes, buttons):
    """Gamepad API standard layout -> (axes, buttons) as sensor_msgs/Joy numbers them in thesis Tables 3.1
    and 3.2, in the ROS joy convention (stick left and up +1; a trigger +1 released, -1 pressed), ready for
    ardrone_moves' PS4 mapping (config/ps4.yaml)."""
    def button(index):
        return buttons[index] if index < len(buttons) else 0.0
    joy_buttons = [1 if button(index) >= 0.5 else 0 for index in STANDARD_TO_TABLE_3_1]
    sticks = [-axes[i] + 0.0 for i in range(4)]  # standard: right and down are +1
    triggers = [1.0 - 2.0 * button(6), 1.0 - 2.0 * button(7)]
    return sticks + triggers + [0.0] * (TABLE_3_2_AXES - 6), joy_buttons
