#!/usr/bin/env python3
"""rostest: the drone takes off from the moving Summit XL and lands back on the pad within 15 cm."""
import time
import unittest

import rospy
import rostest
from landing_msgs.msg import Touchdown
from std_msgs.msg import String

WALL_TIMEOUT = 400.0  # a loaded 2-core machine may run the graph below real time


class LandingTest(unittest.TestCase):
    def test_lands_on_the_moving_pad(self):
        rospy.init_node("landing_rostest")
        seen = {"states": [], "touchdown": None}
        rospy.Subscriber("platform_tracking/state", String, lambda m: seen["states"].append(m.data))
        rospy.Subscriber("ardrone/touchdown", Touchdown, lambda m: seen.update(touchdown=m))
        deadline = time.monotonic() + WALL_TIMEOUT
        while seen["touchdown"] is None and time.monotonic() < deadline and not rospy.is_shutdown():
            time.sleep(0.05)
        touchdown = seen["touchdown"]
        self.assertIsNotNone(touchdown, "no touchdown within %.0f s wall (states %s)" % (WALL_TIMEOUT, seen["states"]))
        rospy.loginfo("touchdown at t=%.1f s, %.3f m from the pad centre, states %s",
                      touchdown.header.stamp.to_sec(), touchdown.pad_error, seen["states"])
        self.assertEqual(touchdown.surface, Touchdown.SURFACE_PAD)
        self.assertFalse(touchdown.crashed)
        self.assertLess(touchdown.pad_error, 0.15)
        for state in ("TAKING_OFF", "TRACKING", "LANDING"):
            self.assertIn(state, seen["states"])


if __name__ == "__main__":
    rostest.rosrun("interface", "landing_rostest", LandingTest)
