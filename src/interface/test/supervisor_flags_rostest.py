#!/usr/bin/env python3
"""rostest (real simulator), one flight: auto take-off after 30 s without a choice; a Flag #2 condition
warns and the flight goes on; a Flag #3 condition that clears before the third re-check lets the flight
go on; one that persists ends in the emergency landing on the ground."""
import unittest

import rospy
import rostest
from landing_msgs.msg import Touchdown

from supervisor_rostest_common import REACTION_LIMIT, Harness

ANSWER_TIMEOUT_S = 15.0   # config/supervisor.yaml
RECHECK_INTERVAL_S = 2.0


class FlagsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.h = Harness("supervisor_flags_rostest")

    def test_1_auto_take_off_after_30_s_without_a_choice(self):
        h = self.h
        d = h.wait_decision("idle", "takeoff", 0.0, "the auto take-off decision")
        announced = h.wait_for(lambda: h.auto_takeoff_at, "the countdown on supervisor/flight_management")
        # 30 s from the supervisor's first tick: t=0 when it is up before the simulator's clock runs, later
        # when it starts late (a loaded machine), but not after it was up (1 s: this node's clock may trail).
        self.assertGreaterEqual(announced, 30.0)
        self.assertLessEqual(announced - 30.0, h.up_at + 1.0)
        self.assertGreaterEqual(d["t"], announced - 0.001)  # announced in ms
        self.assertLess(d["t"], announced + 1.0)
        h.take_off_when_told()
        self.assertEqual(h.mode, "landing")
        self.assertTrue(h.landing_allowed)

    def test_2_flag2_warns_and_the_flight_goes_on(self):
        h = self.h
        t0 = h.set_condition("temp", 0.0)
        d = h.wait_decision("temp_cold", "warn", t0)
        self.assertEqual(d["flag"], 2)
        rospy.loginfo("flag #2 (temp 0): warning %.3f s after the change", d["t"] - t0)
        self.assertLess(d["t"] - t0, REACTION_LIMIT)
        h.wait_for(lambda: h.warning and "temp_cold" in h.warning.get("conditions", []), "supervisor/warning")
        self.assertIsNone(h.warning["deadline"])
        h.sim_wait(ANSWER_TIMEOUT_S + 3.0, while_true=lambda: h.mode == "landing" and h.airborne(),
                   what="mode landing, drone flying")
        self.assertTrue(h.landing_allowed)
        t1 = h.set_condition("temp", 15.0)
        h.wait_decision("temp_cold", "cleared", t1)
        h.wait_for(lambda: h.warning == {}, "the warning withdrawn")

    def test_3_flag3_cleared_before_the_third_check_goes_on(self):
        h = self.h
        t0 = h.set_condition("wind_speed", 11.0)
        d = h.wait_decision("wind_strong", "recheck", t0)
        self.assertEqual(d["flag"], 3)
        self.assertLess(d["t"] - t0, REACTION_LIMIT)
        h.wait_for(lambda: h.landing_allowed is False, "landing_allowed false (strong wind)")
        h.wait_for(lambda: len(h.decisions_of("wind_strong", t0)) >= 2, "re-check 1/3")
        t1 = h.set_condition("wind_speed", 2.0)
        go_on = h.wait_decision("wind_strong", "continue", t1)
        rospy.loginfo("flag #3: first check %.3f s after the change, 'continue' %.3f s after it cleared",
                      d["t"] - t0, go_on["t"] - t1)
        self.assertLess(go_on["t"] - t1, REACTION_LIMIT)
        self.assertIn("cleared after 1 of 3 re-checks", go_on["reason"])
        h.sim_wait(3 * RECHECK_INTERVAL_S + 2.0, while_true=lambda: h.mode == "landing", what="mode landing")
        self.assertTrue(h.landing_allowed)
        self.assertIsNone(h.decision("wind_strong", "emergency_landing", t0))

    def test_4_flag3_persisting_ends_in_the_emergency_landing(self):
        h = self.h
        t0 = h.set_condition("wind_speed", 11.0)
        first = h.wait_decision("wind_strong", "recheck", t0)
        final = h.wait_decision("wind_strong", "emergency_landing", t0)
        actions = [d["action"] for d in h.decisions_of("wind_strong", t0)]
        self.assertEqual(actions, ["recheck", "recheck", "recheck", "emergency_landing"])
        self.assertAlmostEqual(final["t"] - first["t"], 3 * RECHECK_INTERVAL_S, delta=0.25)
        h.wait_for(lambda: h.mode == "emergency", "supervisor/mode emergency")
        h.wait_for(lambda: h.touchdown is not None and h.touchdown.header.stamp.to_sec() > t0, "the touchdown")
        self.assertEqual(h.touchdown.surface, Touchdown.SURFACE_GROUND)
        rospy.loginfo("flag #3: first check %.3f s after the change, emergency landing %.2f s after it",
                      first["t"] - t0, final["t"] - first["t"])
        h.set_condition("wind_speed", 0.0)


if __name__ == "__main__":
    rostest.rosrun("interface", "supervisor_flags", FlagsTest)
