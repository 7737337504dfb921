"""Linux joystick API decoding and a device that is missing, unplugged and plugged back (ROS-free)."""
import errno
import os
import struct

import pytest

from ardrone_moves import joystick_device
from ardrone_moves.joystick_device import (EVENT_AXIS, EVENT_BUTTON, JoystickReader, JoystickState, decode_events,
                                           encode_event)


def record(time_ms, value, raw_type, number):
    """A js_event exactly as the kernel lays it out (little-endian x86/ARM), independent of encode_event."""
    return struct.pack("<IhBB", time_ms, value, raw_type, number)


def pad_init_events(axes=8, buttons=14):
    """What the driver sends on open: one init event per button and per axis (all at rest)."""
    return b"".join([record(1000, 0, 0x81, n) for n in range(buttons)] + [record(1000, 0, 0x82, n) for n in range(axes)])


def test_decodes_real_records_and_keeps_a_partial_one():
    data = record(123456, -32767, 0x02, 3) + record(123460, 1, 0x01, 4) + record(5, 7, 0x81, 2)
    events, rest = decode_events(data + data[:5])
    assert rest == data[:5]
    assert [(e.time_ms, e.value, e.kind, e.number, e.initial) for e in events] == [
        (123456, -32767, EVENT_AXIS, 3, False), (123460, 1, EVENT_BUTTON, 4, False), (5, 7, EVENT_BUTTON, 2, True)]
    assert encode_event(EVENT_AXIS, 3, -32767, time_ms=123456) == data[:8]
    assert encode_event(EVENT_BUTTON, 2, 7, time_ms=5, initial=True) == data[16:24]


def test_state_scales_axes_and_normalises_buttons():
    state = JoystickState()
    for e in decode_events(pad_init_events(axes=4, buttons=3))[0]:
        state.apply(e)
    assert state.axes == [0.0] * 4 and state.buttons == [0] * 3
    events, _ = decode_events(record(1, 32767, 2, 0) + record(2, -32768, 2, 1) + record(3, 16384, 2, 2)
                              + record(4, 1, 1, 1) + record(5, 0x7F, 0x40, 0))
    changed = [state.apply(e) for e in events]
    assert changed == [True, True, True, True, False]  # unknown event type ignored
    assert state.axes[:2] == [1.0, -1.0] and state.axes[2] == pytest.approx(0.5, abs=1e-4)
    assert state.buttons == [0, 1, 0]
    assert not state.apply(decode_events(record(6, 1, 1, 1))[0][0])  # same value again: no change
    joy = state.joy_axes()  # joy_node convention: stick up/left (raw negative) reads +1
    assert joy[:2] == [-1.0, 1.0] and str(joy[3]) == "0.0"


def test_arrays_grow_to_the_highest_index_seen():
    state = JoystickState()
    state.apply(decode_events(record(0, 1, 1, 13))[0][0])
    assert state.buttons == [0] * 13 + [1] and state.axes == []


def test_missing_device_says_what_to_do_and_keeps_retrying(tmp_path):
    path = str(tmp_path / "js0")
    reader = JoystickReader(path, retry_period=0.0)
    assert reader.poll(0.0) is False and not reader.connected
    assert reader.error == "no joystick at %s: plug it in or set ~device" % path
    with open(path, "wb") as device:  # the pad appears: the next attempt finds it
        device.write(pad_init_events())
    assert reader.poll(1.0) is True and reader.connected and reader.error is None
    assert len(reader.state.axes) == 8 and len(reader.state.buttons) == 14


def test_retry_waits_for_the_retry_period(tmp_path):
    now = [100.0]
    reader = JoystickReader(str(tmp_path / "js0"), retry_period=5.0, clock=lambda: now[0])
    reader.poll(0.0)
    open(tmp_path / "js0", "wb").close()
    now[0] = 104.0
    assert not reader.poll(0.0) and "no joystick" in reader.error  # too early to try again
    now[0] = 105.0
    reader.poll(0.0)
    assert "unplugged (end of file)" in reader.error  # it did try: the empty file opened, then ended


def test_unplug_of_a_fifo_is_reported_then_the_pad_comes_back(tmp_path):
    path = str(tmp_path / "js0")
    os.mkfifo(path)
    reader = JoystickReader(path, retry_period=0.0)
    writer = os.open(path, os.O_RDWR)  # O_RDWR: no wait for the reader, and the data stays buffered
    try:
        os.write(writer, pad_init_events() + record(2000, -32767, 0x02, 3))
        assert reader.poll(5.0) and reader.connected
        assert reader.state.joy_axes()[3] == 1.0
    finally:
        os.close(writer)  # unplug: the reader now sees end of file
    assert reader.poll(5.0) is False
    assert not reader.connected and reader.error == (
        "joystick at %s was unplugged (end of file); waiting for it to come back" % path)
    for _ in range(3):  # no writer: reopening keeps failing quietly, never raising
        assert reader.poll(0.01) is False and not reader.connected
    writer = os.open(path, os.O_RDWR)
    try:
        os.write(writer, pad_init_events(axes=6))
        connected = False
        for _ in range(100):  # the reader may still hold an fd from before the writer came back
            if reader.poll(0.1) and reader.connected:
                connected = True
                break
        assert connected and len(reader.state.axes) == 6  # a fresh state, not the old pad's
    finally:
        os.close(writer)
        reader.close()


def test_enodev_while_reading_is_an_unplug_not_a_crash(tmp_path, monkeypatch):
    path = tmp_path / "js0"
    path.write_bytes(pad_init_events())
    reader = JoystickReader(str(path), retry_period=0.0)
    assert reader.poll(1.0) and reader.connected

    def unplugged(fd, size):
        raise OSError(errno.ENODEV, os.strerror(errno.ENODEV))
    monkeypatch.setattr(joystick_device.os, "read", unplugged)
    assert reader.poll(1.0) is False
    assert not reader.connected and "was unplugged (no such device)" in reader.error
    monkeypatch.undo()
    assert reader.poll(1.0) and reader.connected  # plugged back in


def test_permission_denied_is_explained(tmp_path):
    if os.geteuid() == 0:
        pytest.skip("root may open any file")
    path = tmp_path / "js0"
    path.write_bytes(b"")
    path.chmod(0)
    reader = JoystickReader(str(path))
    reader.poll(0.0)
    assert "permission denied" in reader.error
