#!/usr/bin/env python3
"""rostest of ~reset (landing_runtime.rospy_node.ResettableNode) on cmd_vel_mux and emergency: a reset node starts
afresh from its parameters as they are then (its initial latched outputs again, a new rate), takes the latched
inputs at once as a fresh node does, and a bad parameter is refused while the node goes on."""
import threading
import unittest

import rospy
import rostest
from geometry_msgs.msg import Twist
from landing_runtime import testing
from std_msgs.msg import String
from std_srvs.srv import Trigger

WALL_TIMEOUT = 120.0


class NodeResetTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_node_reset")
        cls.selected, cls.emergency_state, cls.commands = [], [], []
        rospy.Subscriber("/cmd_vel_mux/selected", String, lambda m: cls.selected.append(m.data))
        rospy.Subscriber("/emergency/state", String, lambda m: cls.emergency_state.append(m.data))
        rospy.Subscriber("/ardrone/cmd_vel", Twist, lambda m: cls.commands.append(rospy.get_time()), queue_size=100)
        cls.mode = rospy.Publisher("/supervisor/mode", String, queue_size=1, latch=True)
        cls.tracking = rospy.Publisher("/platform_tracking/cmd_vel", Twist, queue_size=1)
        cls.stop = threading.Event()
        threading.Thread(target=cls._track, daemon=True).start()
        for name in ("cmd_vel_mux", "emergency"):
            rospy.wait_for_service("/%s/reset" % name, timeout=WALL_TIMEOUT)

    @classmethod
    def tearDownClass(cls):
        cls.stop.set()

    @classmethod
    def _track(cls):
        """The tracker's velocity command, 20 times a wall second."""
        while not cls.stop.wait(0.05):
            cls.tracking.publish(Twist())

    @staticmethod
    def reset(name):
        return rospy.ServiceProxy("/%s/reset" % name, Trigger)()

    def wait_for(self, condition, what):
        testing.wait_for(condition, what, WALL_TIMEOUT)

    def rate(self, seconds=2.0):
        """ardrone/cmd_vel messages per sim second over the next ``seconds`` of sim time."""
        start = rospy.get_time()
        self.wait_for(lambda: rospy.get_time() >= start + seconds, "%.0f s of sim time" % seconds)
        return sum(1 for t in self.commands if start < t <= start + seconds) / seconds

    def test_1_a_reset_mux_starts_afresh_at_its_new_rate_and_takes_the_latched_mode(self):
        self.mode.publish(String(data="landing"))
        self.wait_for(lambda: self.selected and self.selected[-1] == "tracking", "the mux forwarding the tracker")
        self.assertAlmostEqual(self.rate(), 30.0, delta=3.0)
        rospy.set_param("/cmd_vel_mux/rate_hz", 15.0)
        before = len(self.selected)
        response = self.reset("cmd_vel_mux")
        self.assertTrue(response.success, response.message)
        # The new node announces "none" as a fresh one does, then forwards the tracker again: it was handed the
        # latched mode at once.
        self.wait_for(lambda: self.selected[before:] == ["none", "tracking"], "none, then tracking again")
        self.assertAlmostEqual(self.rate(), 15.0, delta=2.0)

    def test_2_a_bad_parameter_is_refused_and_the_node_goes_on(self):
        rospy.set_param("/cmd_vel_mux/rate_hz", -1.0)
        try:
            response = self.reset("cmd_vel_mux")
        finally:
            rospy.set_param("/cmd_vel_mux/rate_hz", 15.0)
        self.assertFalse(response.success)
        self.assertIn("rate_hz", response.message)
        self.assertIn("not reset", response.message)
        self.assertAlmostEqual(self.rate(), 15.0, delta=2.0)

    def test_3_a_reset_emergency_module_starts_inactive_and_takes_the_latched_mode(self):
        self.mode.publish(String(data="emergency"))
        self.wait_for(lambda: self.emergency_state and self.emergency_state[-1] != "inactive", "the module engaged")
        engaged = self.emergency_state[-1]
        before = len(self.emergency_state)
        response = self.reset("emergency")
        self.assertTrue(response.success, response.message)
        # A first tick before the new object's first navdata does not know the drone is down yet: it lands
        # (descending), and the next navdata puts it on the ground.
        self.wait_for(lambda: self.emergency_state[before:][:1] == ["inactive"] and
                      engaged in self.emergency_state[before + 1:before + 3], "inactive, then %s again" % engaged)
        self.assertIn(self.emergency_state[before + 1], (engaged, "descending"))


if __name__ == "__main__":
    rostest.rosrun("interface", "node_reset", NodeResetTest)
