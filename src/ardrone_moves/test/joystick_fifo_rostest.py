#!/usr/bin/env python3
"""rostest: js_event records written into a FIFO (the joystick node's ~device) drive ardrone/cmd_vel,
take-off, land and operator/command through joystick + ardrone_joystick; unplug and re-plug."""
import functools
import os
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import Twist
from sensor_msgs.msg import Joy
from std_msgs.msg import Empty, String

from ardrone_moves.joystick_device import EVENT_AXIS, EVENT_BUTTON, encode_event
from landing_runtime import testing

TIMEOUT = 60.0      # generous: the machine may be loaded
FULL = 32767
AXES, BUTTONS = 8, 14  # PS4 pad (Tables 3.1, 3.2)


wait_for = functools.partial(testing.wait_for, timeout=TIMEOUT)


class Recorder:
    def __init__(self, topic, kind):
        self.lock, self.messages = threading.Lock(), []
        self.subscriber = rospy.Subscriber(topic, kind, self._record, queue_size=1000)

    def _record(self, msg):
        with self.lock:
            self.messages.append(msg)

    def since(self, index):
        with self.lock:
            return list(self.messages[index:])

    def count(self):
        with self.lock:
            return len(self.messages)


class JoystickFifoTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("joystick_fifo_test")
        cls.params = rospy.get_param("~")
        cls.path = cls.params["device"]
        cls.cmd_vel = Recorder("/ardrone/cmd_vel", Twist)
        cls.takeoff = Recorder("/ardrone/takeoff", Empty)
        cls.land = Recorder("/ardrone/land", Empty)
        cls.operator = Recorder("/operator/command", String)
        cls.joy = Recorder("/joy", Joy)
        if os.path.exists(cls.path):
            os.unlink(cls.path)
        os.mkfifo(cls.path)
        cls.fd = None
        for recorder in (cls.cmd_vel, cls.takeoff, cls.land, cls.operator, cls.joy):
            wait_for(lambda: recorder.subscriber.get_num_connections() > 0,
                     "a publisher on " + recorder.subscriber.resolved_name)

    @classmethod
    def tearDownClass(cls):
        cls.unplug()
        os.unlink(cls.path)

    @classmethod
    def plug_in(cls):
        # O_RDWR: never waits for the node to open its end, and keeps the data buffered until it does
        cls.fd = os.open(cls.path, os.O_RDWR)
        cls.write([(EVENT_BUTTON, n, 0) for n in range(BUTTONS)] + [(EVENT_AXIS, n, 0) for n in range(AXES)],
                  initial=True)

    @classmethod
    def unplug(cls):
        if cls.fd is not None:
            os.close(cls.fd)
            cls.fd = None

    @classmethod
    def write(cls, events, initial=False):
        os.write(cls.fd, b"".join(encode_event(kind, number, value, initial=initial) for kind, number, value in events))

    def button(self, name, pressed):
        self.write([(EVENT_BUTTON, self.params["button_" + name], int(pressed))])

    def stick(self, name, up_or_left):
        """Deflection as the operator sees it (+1 = up or left); the kernel reports up/left negative."""
        self.write([(EVENT_AXIS, self.params["axis_" + name], -int(round(up_or_left * FULL)))])

    def wait_joy(self, what, condition):
        start = self.joy.count()
        wait_for(lambda: any(condition(m) for m in self.joy.since(start)), "joy with " + what)

    def wait_cmd(self, what, condition, start):
        wait_for(lambda: any(condition(m) for m in self.cmd_vel.since(start)), "cmd_vel with " + what)
        return next(m for m in self.cmd_vel.since(start) if condition(m))

    def wait_plugged(self):
        self.plug_in()
        self.wait_joy("the pad's 8 axes and 14 buttons", lambda m: len(m.axes) == AXES and len(m.buttons) == BUTTONS)

    def test_1_sticks_deadman_buttons(self):
        self.wait_plugged()
        max_forward, dead_zone = self.params["max_forward_speed"], self.params["dead_zone"]

        # dead-man held, right stick fully up: full forward speed, and the operator takes over
        start, ops = self.cmd_vel.count(), self.operator.count()
        self.button("deadman", True)
        self.stick("forward", 1.0)
        self.wait_cmd("full forward", lambda m: abs(m.linear.x - max_forward) < 1e-6, start)
        wait_for(lambda: [m.data for m in self.operator.since(ops)] == ["manual"], "operator/command 'manual'")

        # half up: the command follows the stick (dead zone rescaled), and left stick climbs
        start = self.cmd_vel.count()
        self.stick("forward", 0.5)
        self.stick("climb", 1.0)
        expected = (0.5 - dead_zone) / (1.0 - dead_zone) * max_forward
        self.wait_cmd("half forward and climbing", lambda m: abs(m.linear.x - expected) < 1e-3
                      and abs(m.linear.z - self.params["max_climb_rate"]) < 1e-6, start)

        # dead-man released with the stick still up: a zero command, then nothing but zeros
        start = self.cmd_vel.count()
        self.button("deadman", False)
        self.wait_cmd("zero after the release", is_zero, start)
        self.stick("forward", -1.0)
        lands = self.land.count()
        self.button("land", True)       # the land press is processed after the stick move
        wait_for(lambda: self.land.count() > lands, "ardrone/land on X")
        self.button("land", False)
        since_release = self.cmd_vel.since(start)
        first_zero = next(i for i, m in enumerate(since_release) if is_zero(m))  # earlier ones were in flight
        self.assertTrue(all(is_zero(m) for m in since_release[first_zero:]), since_release)

        # take-off on Triangle, once per press
        takeoffs = self.takeoff.count()
        self.button("takeoff", True)
        wait_for(lambda: self.takeoff.count() > takeoffs, "ardrone/takeoff on Triangle")
        self.button("takeoff", False)

        # emergency on Circle goes to the supervisor
        ops = self.operator.count()
        self.button("emergency", True)
        wait_for(lambda: "emergency" in [m.data for m in self.operator.since(ops)], "operator/command 'emergency'")
        self.button("emergency", False)
        self.assertEqual(self.takeoff.count(), takeoffs + 1)

    def test_2_unplug_stops_the_drone_and_replug_resumes(self):
        if self.fd is None:
            self.wait_plugged()
        start = self.cmd_vel.count()
        self.button("deadman", True)
        self.stick("left", 1.0)
        self.wait_cmd("full left", lambda m: abs(m.linear.y - self.params["max_left_speed"]) < 1e-6, start)

        start = self.cmd_vel.count()
        self.unplug()   # the node reads end of file: it stops publishing joy, joy goes stale
        self.wait_cmd("zero once the stick is gone", is_zero, start)
        joys = self.joy.count()
        stale_at = time.monotonic()
        wait_for(lambda: time.monotonic() - stale_at > 2 * self.params["stale_timeout"],
                 "a quiet moment")  # the observation window of a negative check, not a synchronisation
        self.assertEqual(self.joy.count(), joys, "joy published while unplugged")
        self.assertTrue(is_zero(self.cmd_vel.since(start)[-1]))

        start = self.cmd_vel.count()
        self.wait_plugged()          # re-plugged with every button released
        self.button("deadman", True)
        self.stick("yaw", -1.0)      # left stick right: yaw clockwise
        self.wait_cmd("yaw right after re-plugging",
                      lambda m: abs(m.angular.z + self.params["max_yaw_rate"]) < 1e-6, start)
        self.button("deadman", False)


def is_zero(msg):
    return not any((msg.linear.x, msg.linear.y, msg.linear.z, msg.angular.x, msg.angular.y, msg.angular.z))


if __name__ == "__main__":
    rostest.rosrun("ardrone_moves", "joystick_fifo", JoystickFifoTest)
