#!/usr/bin/env python3
"""rostest, thesis test of manual mode: with the Summit XL driving on, the operator takes off with
Triangle, holds L1 (manual control), and the drone follows the right stick forward and left; on
release it holds where it is while the vehicle drives away. Joystick events go into a FIFO read by
the real joystick node; the drone is the real simulator. Ground truth only scores the flight."""
import functools
import math
import os
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import Joy
from landing_msgs.msg import Navdata
from std_msgs.msg import String

from ardrone_moves.joystick_device import EVENT_AXIS, EVENT_BUTTON, encode_event
from landing_runtime import testing

WALL_TIMEOUT = 180.0  # per wait [wall s]: the simulator may run slower than asked on a loaded machine
FULL = 32767
AXES, BUTTONS = 8, 14  # PS4 pad (Tables 3.1, 3.2)
AIRBORNE = (Navdata.STATE_FLYING, Navdata.STATE_HOVERING)


class ManualJoystickTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("manual_joystick_test")
        cls.params = rospy.get_param("~")
        cls.lock = threading.Lock()
        cls.navdata, cls.drone, cls.mode, cls.joy = None, None, None, None
        cls.vehicle_log = []  # (sim time, x, y)
        rospy.Subscriber("/drone/navdata", Navdata, lambda m: setattr(cls, "navdata", m), queue_size=1)
        rospy.Subscriber("/groundtruth/ardrone", PoseStamped, lambda m: setattr(cls, "drone", m.pose.position),
                         queue_size=1)
        rospy.Subscriber("/groundtruth/summit", PoseStamped, cls._on_vehicle, queue_size=1)
        rospy.Subscriber("/supervisor/mode", String, lambda m: setattr(cls, "mode", m.data), queue_size=5)
        rospy.Subscriber("/joy", Joy, lambda m: setattr(cls, "joy", m), queue_size=5)
        path = cls.params["device"]
        if os.path.exists(path):
            os.unlink(path)
        os.mkfifo(path)
        # O_RDWR: does not wait for the joystick node to open its end; events stay buffered until it does
        cls.fd = os.open(path, os.O_RDWR)
        cls.write([(EVENT_BUTTON, n, 0) for n in range(BUTTONS)] + [(EVENT_AXIS, n, 0) for n in range(AXES)],
                  initial=True)
        cls.wait_for(lambda: cls.navdata is not None and cls.drone is not None and cls.mode is not None
                     and cls.joy is not None and rospy.get_time() > 0.5,
                     "the simulator, its ground truth, supervisor/mode and joy from the pad")

    @classmethod
    def tearDownClass(cls):
        os.close(cls.fd)
        os.unlink(cls.params["device"])

    @classmethod
    def _on_vehicle(cls, msg):
        with cls.lock:
            cls.vehicle_log.append((msg.header.stamp.to_sec(), msg.pose.position.x, msg.pose.position.y))

    wait_for = staticmethod(functools.partial(testing.wait_for, timeout=WALL_TIMEOUT))

    def wait_sim(self, seconds, what):
        end = rospy.get_time() + seconds
        self.wait_for(lambda: rospy.get_time() >= end, what)

    @classmethod
    def write(cls, events, initial=False):
        os.write(cls.fd, b"".join(encode_event(kind, number, value, initial=initial) for kind, number, value in events))

    def button(self, name, pressed):
        self.write([(EVENT_BUTTON, self.params["button_" + name], int(pressed))])

    def tap(self, name):
        """Press until joy shows the button down (a shorter tap is coalesced away, as by joy_node), release."""
        index = self.params["button_" + name]
        self.button(name, True)
        self.wait_for(lambda: self.joy.buttons[index] == 1, "joy with button %s down" % name)
        self.button(name, False)

    def stick(self, name, up_or_left):
        """Deflection as the operator sees it (+1 = up or left); the kernel reports up/left negative."""
        self.write([(EVENT_AXIS, self.params["axis_" + name], -int(round(up_or_left * FULL)))])

    def vehicle_travel(self, since):
        with self.lock:
            points = [(x, y) for t, x, y in self.vehicle_log if t >= since]
        return math.hypot(points[-1][0] - points[0][0], points[-1][1] - points[0][1]) if len(points) > 1 else 0.0

    def drone_xy(self):
        return self.drone.x, self.drone.y

    def test_manual_mode_follows_the_joystick_while_the_vehicle_drives_on(self):
        max_forward, max_left = self.params["max_forward_speed"], self.params["max_left_speed"]
        start_time = rospy.get_time()

        # Triangle: take off from the moving pad; pressed again, as an operator would, while the
        # joystick's publisher may still be connecting to the simulator
        def press_takeoff_until_airborne():
            if time.monotonic() > self.next_press:
                self.tap("takeoff")
                self.next_press = time.monotonic() + 5.0
            return self.navdata.state in AIRBORNE and self.drone.z > 0.8
        self.next_press = 0.0
        self.wait_for(press_takeoff_until_airborne, "the drone airborne after Triangle")

        # L1 held and right stick up: the operator takes over (operator/command manual -> supervisor
        # mode manual) and the drone flies forward at full speed, in its own heading frame
        before = self.drone_xy()
        self.button("deadman", True)
        self.stick("forward", 1.0)
        self.wait_for(lambda: self.mode == "manual", "supervisor/mode manual after L1 and the stick")
        self.wait_for(lambda: self.navdata.vx > 0.8 * max_forward, "navdata vx near %.1f m/s" % max_forward)
        self.wait_sim(2.0, "two seconds of forward flight")
        self.assertGreater(math.dist(before, self.drone_xy()), 2.0)

        # right stick left instead: the drone slides left
        self.stick("forward", 0.0)
        self.stick("left", 1.0)
        self.wait_for(lambda: self.navdata.vy > 0.8 * max_left and abs(self.navdata.vx) < 0.3 * max_forward,
                      "navdata vy near %.1f m/s with vx near 0" % max_left)

        # L1 released: the drone stops and holds, it does not follow the vehicle
        self.stick("left", 0.0)
        self.button("deadman", False)
        self.wait_for(lambda: math.hypot(self.navdata.vx, self.navdata.vy) < 0.2, "the drone to stop")
        held_at, held_time = self.drone_xy(), rospy.get_time()
        self.wait_sim(3.0, "three seconds of hover")
        self.assertLess(math.dist(held_at, self.drone_xy()), 0.5, "the drone drifted without a command")
        self.assertEqual(self.mode, "manual")

        # and all along the vehicle kept driving at its 1 m/s
        elapsed = rospy.get_time() - start_time
        self.assertGreater(self.vehicle_travel(start_time), 0.7 * elapsed,
                           "the vehicle should keep driving during manual control")
        self.assertGreater(self.vehicle_travel(held_time), 2.0)


if __name__ == "__main__":
    rostest.rosrun("interface", "manual_joystick", ManualJoystickTest)
