#!/usr/bin/env python3
"""rostest (real simulator): the operator orders the emergency landing from the console topic while the
drone hovers above the pad. The emergency module moves clear of the vehicle, lands on the ground and
reports the drone's own estimated position within 5 m of the truth (as good as its GPS: a metre of
drifting error per axis in the realistic world)."""
import unittest

import rospy
import rostest
from landing_msgs.msg import Touchdown

from supervisor_rostest_common import REACTION_LIMIT, Harness


class OperatorEmergencyTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.h = Harness("supervisor_operator_emergency_rostest")

    def test_operator_emergency_above_the_pad_lands_beside_the_vehicle(self):
        h = self.h
        h.command("landing")
        h.take_off_when_told(climb_s=1.0)
        h.sim_wait(1.0)  # the sonar sees the pad below
        t0 = rospy.get_time()
        h.command("emergency")
        d = h.wait_decision("operator", "emergency_landing", t0)
        h.wait_for(lambda: h.mode == "emergency", "supervisor/mode emergency")
        h.wait_for(lambda: h.emergency_state == "clearing", "emergency/state clearing (the pad is below)")
        self.assertLess(d["t"] - t0, REACTION_LIMIT)
        h.wait_for(lambda: h.emergency_state in ("descending", "on_ground"), "emergency/state descending")
        h.wait_for(lambda: h.touchdown is not None and h.touchdown.header.stamp.to_sec() > t0, "the touchdown")
        self.assertEqual(h.touchdown.surface, Touchdown.SURFACE_GROUND, "did not land on the ground")
        self.assertFalse(h.touchdown.crashed)
        t_down = h.touchdown.header.stamp.to_sec()
        h.wait_for(lambda: sum(1 for t, _, _ in h.positions if t > t_down + 2.0) >= 2,
                   "emergency/position after the touchdown")
        error = h.horizontal_error(h.positions[-1])
        rospy.loginfo("operator emergency: decision after %.3f s; landed %.2f m from the pad centre; reported "
                      "position %.3f m from the truth", d["t"] - t0, (h.truth.x ** 2 + h.truth.y ** 2) ** 0.5, error)
        self.assertLess(error, 5.0)
        h.command("ack")
        h.wait_for(lambda: h.mode == "landed", "supervisor/mode landed after the ack")


if __name__ == "__main__":
    rostest.rosrun("interface", "supervisor_operator_emergency", OperatorEmergencyTest)
