#!/usr/bin/env python3
"""rostest (real simulator, supervisor and console): the idle take-off timer runs from the operator's Start.
The console presses Start at sim t = 12 s; supervisor/flight_management shows the countdown from then, and
the drone takes off by itself 30 s later, not 30 s after launch."""
import json
import threading
import time
import unittest

import rospy
import rostest
from std_msgs.msg import String

IDLE_TAKEOFF_S = 30.0   # config/supervisor.yaml
START_AT_S = 12.0       # the console's --commands 'wait 12;start'
WALL_TIMEOUT = 120.0


class FlightManagementTimerTest(unittest.TestCase):
    def setUp(self):
        rospy.init_node("flight_management_timer_rostest")
        self.lock = threading.Lock()
        self.decisions, self.flight_management = [], []
        rospy.Subscriber("/supervisor/decisions", String, self._on_decision, queue_size=100)
        rospy.Subscriber("/supervisor/flight_management", String, self._on_flight_management, queue_size=10)

    def _on_decision(self, msg):
        with self.lock:
            self.decisions.append(json.loads(msg.data))

    def _on_flight_management(self, msg):
        with self.lock:
            self.flight_management.append((rospy.get_time(), json.loads(msg.data)))

    def decision(self, condition, action):
        with self.lock:
            return next((d for d in self.decisions if d["condition"] == condition and d["action"] == action), None)

    def wait_for(self, condition, what):
        deadline = time.monotonic() + WALL_TIMEOUT
        while not condition():
            if time.monotonic() > deadline:
                self.fail("timed out after %.0f s (wall) waiting for %s (sim t=%.2f)" % (WALL_TIMEOUT, what,
                                                                                        rospy.get_time()))
            time.sleep(0.01)

    def test_the_30_s_count_from_start(self):
        self.wait_for(lambda: self.flight_management, "supervisor/flight_management")
        self.assertEqual(self.flight_management[0][1], {"open": False, "auto_takeoff_at": None})
        start = None

        def started():
            nonlocal start
            start = self.decision("operator", "start")
            return start is not None
        self.wait_for(started, "the console's Start on operator/command")
        self.assertGreaterEqual(start["t"], START_AT_S)
        self.assertIn("takes off by itself at t=%.1f s" % (start["t"] + IDLE_TAKEOFF_S), start["reason"])
        self.wait_for(lambda: self.flight_management[-1][1]["open"], "Flight Management open")
        countdown = self.flight_management[-1][1]["auto_takeoff_at"]
        self.assertAlmostEqual(countdown, start["t"] + IDLE_TAKEOFF_S, delta=0.2)
        takeoff = None

        def took_off():
            nonlocal takeoff
            takeoff = self.decision("idle", "takeoff")
            return takeoff is not None
        self.wait_for(took_off, "the auto take-off")
        rospy.loginfo("Start at t=%.2f s, auto take-off at t=%.2f s", start["t"], takeoff["t"])
        # 1e-9: the supervisor compares t >= start + 30; t - start may round below 30 (54.05 - 24.05)
        self.assertGreaterEqual(takeoff["t"] - start["t"], IDLE_TAKEOFF_S - 1e-9)
        self.assertLess(takeoff["t"] - start["t"], IDLE_TAKEOFF_S + 0.5)   # supervisor ticks at 10 Hz
        self.assertGreater(takeoff["t"], IDLE_TAKEOFF_S + START_AT_S - 0.5)  # not 30 s after launch
        self.wait_for(lambda: self.flight_management[-1][1]["auto_takeoff_at"] is None, "the countdown gone")


if __name__ == "__main__":
    rostest.rosrun("interface", "flight_management_timer", FlightManagementTimerTest)
