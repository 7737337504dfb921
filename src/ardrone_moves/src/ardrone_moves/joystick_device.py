"""Reader of the Linux joystick API (/dev/input/jsN), ROS-free.

The kernel delivers 8-byte ``struct js_event`` records (linux/joystick.h): u32 time [ms], s16 value,
u8 type (0x01 button, 0x02 axis, ORed with 0x80 for the synthetic events that describe the state
at open time), u8 number. ``JoystickReader`` turns them into axes in [-1, 1] and buttons in {0, 1}
and survives a missing or unplugged device: it reports why and keeps trying to reopen it.
"""
import errno
import os
import select
import struct
import time
from dataclasses import dataclass

EVENT_FORMAT = "=IhBB"  # native byte order, standard sizes: exactly the kernel's struct js_event
EVENT_SIZE = struct.calcsize(EVENT_FORMAT)
EVENT_BUTTON = 0x01
EVENT_AXIS = 0x02
EVENT_INIT = 0x80
AXIS_FULL_SCALE = 32767.0
READ_CHUNK = EVENT_SIZE * 64  # a PS4 pad at full tilt sends a few hundred events/s: drain them in few reads


@dataclass(frozen=True)
class JsEvent:
    time_ms: int
    value: int
    kind: int       # EVENT_BUTTON or EVENT_AXIS (init flag removed)
    number: int     # button or axis index
    initial: bool   # synthetic event sent on open: the state at that moment, not a change


def encode_event(kind, number, value, time_ms=0, initial=False):
    """The bytes the kernel would deliver for one event (tests and the FIFO rostest write these)."""
    return struct.pack(EVENT_FORMAT, time_ms & 0xFFFFFFFF, value, kind | (EVENT_INIT if initial else 0), number)


def decode_events(data):
    """Whole records in ``data`` as JsEvents, plus the bytes of an incomplete trailing record."""
    whole = len(data) - len(data) % EVENT_SIZE
    events = []
    for time_ms, value, raw_kind, number in struct.iter_unpack(EVENT_FORMAT, data[:whole]):
        events.append(JsEvent(time_ms, value, raw_kind & ~EVENT_INIT, number, bool(raw_kind & EVENT_INIT)))
    return events, bytes(data[whole:])


def axis_fraction(value):
    """Raw s16 axis value as a fraction of full travel in [-1, 1] (-32768 is clipped to -1)."""
    return max(-1.0, min(1.0, value / AXIS_FULL_SCALE))


class JoystickState:
    """Latest value of every axis and button seen so far; arrays grow to the highest index seen."""

    def __init__(self):
        self.axes = []      # Linux sign convention: stick right and stick down are positive
        self.buttons = []

    def apply(self, event):
        """Updates the state; True if a value changed. Events of unknown kind are ignored."""
        if event.kind == EVENT_AXIS:
            values, new = self.axes, axis_fraction(event.value)
        elif event.kind == EVENT_BUTTON:
            values, new = self.buttons, 1 if event.value else 0
        else:
            return False
        grew = len(values) <= event.number
        if grew:
            values.extend([type(new)(0)] * (event.number + 1 - len(values)))
        changed = grew or values[event.number] != new
        values[event.number] = new
        return changed

    def joy_axes(self):
        """Axes in the convention of ROS joy_node: sign flipped so that stick up and stick left are +1."""
        return [0.0 - value for value in self.axes]  # 0.0 - x, not -x: no -0.0 in the messages


def _open_error(path, err):
    if err.errno in (errno.ENOENT, errno.ENODEV, errno.ENXIO):
        return "no joystick at %s: plug it in or set ~device" % path
    if err.errno == errno.EACCES:
        return "cannot open %s: permission denied (add the user to the 'input' group)" % path
    return "cannot open %s: %s" % (path, err.strerror or err)


class JoystickReader:
    """A joystick device kept open across unplugs; never raises for device trouble.

    ``poll`` waits up to ``timeout`` s for events. ``connected`` is true once events arrived from
    the currently open device; otherwise ``error`` says why there is no joystick. A device that
    cannot be opened or goes away (ENODEV, end of file) is retried every ``retry_period`` s."""

    def __init__(self, path, retry_period=1.0, clock=time.monotonic):
        self.path, self.retry_period, self._clock = path, float(retry_period), clock
        self.state = JoystickState()
        self.connected = False
        self.error = None
        self._fd = None
        self._pending = b""
        self._next_open = clock()

    def poll(self, timeout):
        """Reads what the device sent within ``timeout`` s; True if the state changed or just appeared."""
        if self._fd is None and not self._try_open(timeout):
            return False
        try:
            ready, _, _ = select.select([self._fd], [], [], max(0.0, timeout))
            if not ready:
                return False
            data = os.read(self._fd, READ_CHUNK)
        except OSError as err:
            reason = "no such device" if err.errno == errno.ENODEV else (err.strerror or str(err))
            self._lose("joystick at %s was unplugged (%s); waiting for it to come back" % (self.path, reason))
            return False
        if not data:
            self._lose("joystick at %s was unplugged (end of file); waiting for it to come back" % self.path)
            return False
        events, self._pending = decode_events(self._pending + data)
        changed = False
        for event in events:
            changed = self.state.apply(event) or changed
        if events and not self.connected:
            self.connected, self.error, changed = True, None, True
        return changed

    def close(self):
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
        self.connected = False

    def _try_open(self, timeout):
        now = self._clock()
        if now < self._next_open:
            time.sleep(min(max(0.0, timeout), self._next_open - now))  # nothing to read until the next attempt
            return False
        try:
            # O_NONBLOCK: open must not wait for a writer when the "device" is a FIFO (tests)
            self._fd = os.open(self.path, os.O_RDONLY | os.O_NONBLOCK)
        except OSError as err:
            self._lose(_open_error(self.path, err))
            return False
        self.state, self._pending = JoystickState(), b""  # a re-plugged pad may differ; its init events refill this
        return True

    def _lose(self, reason):
        self.close()
        self.error = reason
        self._next_open = self._clock() + self.retry_period
