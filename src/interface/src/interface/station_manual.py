"""Manual Control from one browser page, ROS-free: ardrone_moves' keyboard teleop and PS4 mapping
(thesis Tables 3.1/3.2, dead-man L1) fed by the page's keys, on-screen sticks and Gamepad API pad.

Each page has its own ManualControl, so two pages cannot mix one dead-man with the other's sticks, and a
page that closes or falls silent (``stale_s``) sends one stop if it was flying, then nothing."""
from ardrone_moves.keyboard import KeyboardTeleop
from ardrone_moves.mapping import STOP, JoystickTeleop

from .station_protocol import standard_to_joy


class ManualControl:
    def __init__(self, keyboard_config, joystick_config, stale_s=0.5):
        self.keyboard = KeyboardTeleop(keyboard_config)
        self.joystick = JoystickTeleop(joystick_config)
        self.stale_s = stale_s
        self.last_joy = None   # wall time of the last pad message

    def key(self, key, now):
        """A teleop key -> (one-shot actions, message for the operator or None)."""
        result = self.keyboard.press(key, now)
        return result.actions, result.message

    def joy(self, axes, buttons, now):
        """A pad state in the Gamepad API standard layout -> (command or None, one-shot actions)."""
        self.last_joy = now
        joy_axes, joy_buttons = standard_to_joy(axes, buttons)
        return self.joystick.update(joy_axes, joy_buttons)

    def tick(self, now):
        """Commands due now: the keyboard's (while a key is held) and the pad's stop when it fell silent."""
        commands = []
        if self.last_joy is not None and now - self.last_joy > self.stale_s:
            self.last_joy = None
            stop = self.joystick.lost()
            if stop is not None:
                commands.append(stop)
        command = self.keyboard.tick(now)
        if command is not None:
            commands.append(command)
        return commands

    def close(self, now):
        """The page went away: one stop if its pad or keys were flying, else nothing."""
        self.last_joy = None
        stopping = self.joystick.lost() is not None
        if self.keyboard.tick(now) is not None:  # a key still held (or its stop not yet sent)
            self.keyboard.press(" ", now)
            stopping = True
        return [STOP] if stopping else []
