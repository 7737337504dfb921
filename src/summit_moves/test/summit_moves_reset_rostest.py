#!/usr/bin/env python3
"""rostest of summit_moves' ~reset: a reset node starts its path afresh from the parameters as they are then (it
waits for the take-off again, or starts at the reset), a bad parameter is refused while the path goes on, and its
~started_at follows the reset: a crash before the new path started starts afresh, one after it carries on."""
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import Twist
from landing_runtime import testing
from landing_runtime.rospy_node import without_nagle
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Empty
from std_srvs.srv import Trigger

WALL_TIMEOUT = 60.0
NODE = "/summit_moves"
CLOCK_START_S, CLOCK_STEP_S = 100.0, 0.01  # sim time from 100 s on, 0.01 s per 0.01 wall s
RATE_HZ = 20.0  # config/path.yaml
CLOCK_SKEW_S = 0.05  # how far the node's clock may be from this process's: each comes over its own connection [s]


class SummitMovesResetTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_summit_moves_reset")
        cls.commands = []  # (speed, yaw rate) as published
        cls.stop = threading.Event()
        cls.clock = without_nagle(rospy.Publisher("/clock", Clock, queue_size=1))  # no tick held for an ACK
        threading.Thread(target=cls._run_clock, daemon=True).start()
        rospy.Subscriber("/robotnik_base_control/cmd_vel", Twist,
                         lambda m: cls.commands.append((round(m.linear.x, 6), round(m.angular.z, 6))), queue_size=100)
        cls.takeoff = rospy.Publisher("/ardrone/takeoff", Empty, queue_size=1)
        rospy.wait_for_service(NODE + "/reset", timeout=WALL_TIMEOUT)
        # This process's own clock reaches it over a connection like any other: on a loaded machine it took seconds.
        testing.wait_for(lambda: rospy.get_time() >= CLOCK_START_S and cls.commands, "the clock and the node's first "
                         "command", WALL_TIMEOUT)

    @classmethod
    def tearDownClass(cls):
        cls.stop.set()

    @classmethod
    def _run_clock(cls):
        t = CLOCK_START_S
        while not cls.stop.is_set() and not rospy.is_shutdown():
            cls.clock.publish(Clock(clock=rospy.Time.from_sec(t)))
            t += CLOCK_STEP_S
            time.sleep(CLOCK_STEP_S)  # the clock's cadence, not a synchronisation

    def wait_for(self, condition, what):
        return testing.wait_for(condition, what, WALL_TIMEOUT)

    def next_commands(self, count, after=None):
        """The ``count`` commands published from now on (or from index ``after`` on)."""
        start = len(self.commands) if after is None else after
        self.wait_for(lambda: len(self.commands) >= start + count, "%d commands" % count)
        return self.commands[start:start + count]

    def steady(self, expected, seconds=1.0):
        """Waits for the command ``expected`` (commands of the previous object may still be on their way), then
        asserts the node keeps to it for ``seconds`` of sim time."""
        self.wait_for(lambda: self.commands[-1:] == [expected], "the command %s" % (expected,))
        self.assertEqual(set(self.next_commands(int(seconds * RATE_HZ))), {expected})

    def take_off(self):
        self.wait_for(lambda: self.takeoff.get_num_connections() > 0, "summit_moves on ardrone/takeoff")
        self.takeoff.publish(Empty())

    @staticmethod
    def reset():
        return rospy.ServiceProxy(NODE + "/reset", Trigger)()

    @staticmethod
    def started_at():
        return rospy.get_param(NODE + "/started_at", None)

    def crash(self):
        """Kills summit_moves (SIGKILL: nothing tidied); the launch respawns it. Returns the index of its first
        command after the respawn."""
        testing.crash_and_wait_for_respawn(NODE, WALL_TIMEOUT)
        return len(self.commands)  # the killed process publishes no more

    def test_1_a_reset_node_waits_for_the_takeoff_again_on_its_new_path(self):
        self.assertTrue(rospy.get_time() >= CLOCK_START_S)
        self.steady((0.0, 0.0))  # a fresh node: still, until the take-off
        self.take_off()
        self.steady((1.0, 0.1))  # circle at 1 m/s, radius 10 m
        self.assertIsNotNone(self.started_at())
        rospy.set_param(NODE + "/path", "straight")
        rospy.set_param(NODE + "/speed", 2.0)
        response = self.reset()
        self.assertTrue(response.success, response.message)
        self.assertIsNone(self.started_at(), "the previous path's start must be forgotten at once")
        self.steady((0.0, 0.0), seconds=2.0)  # as the fresh node: still, until the next take-off
        self.take_off()
        self.steady((2.0, 0.0))
        self.assertIsNotNone(self.started_at())

    def test_2_without_start_on_takeoff_the_path_starts_at_the_reset(self):
        rospy.set_param(NODE + "/start_on_takeoff", False)
        rospy.set_param(NODE + "/start_delay", 1.0)
        t_before = rospy.get_time()
        response = self.reset()
        t_after = rospy.get_time()
        self.assertTrue(response.success, response.message)
        self.wait_for(self.started_at, "~started_at of the new path")
        self.assertTrue(t_before + 1.0 - CLOCK_SKEW_S <= self.started_at()["time"] <=
                        t_after + 1.0 + 2.0 / RATE_HZ + CLOCK_SKEW_S,
                        (t_before, t_after, self.started_at()))
        self.steady((2.0, 0.0))

    def test_3_a_bad_parameter_is_refused_and_the_path_goes_on(self):
        started_at = self.started_at()
        for name, bad, words in (("speed", 100.0, ("speed", "not reset")), ("path", "zigzag", ("~path", "zigzag")),
                                 ("rate_hz", 0.0, ("~rate_hz",)), ("start_delay", "soon", ("~start_delay",))):
            good = rospy.get_param(NODE + "/" + name)
            rospy.set_param(NODE + "/" + name, bad)
            try:
                response = self.reset()
            finally:
                rospy.set_param(NODE + "/" + name, good)
            self.assertFalse(response.success, name)
            for word in words:
                self.assertIn(word, response.message)
        rospy.delete_param(NODE + "/radius")
        try:
            response = self.reset()
        finally:
            rospy.set_param(NODE + "/radius", 10.0)
        self.assertFalse(response.success)
        self.assertIn("~radius", response.message)
        self.assertEqual(self.started_at(), started_at)
        self.steady((2.0, 0.0))

    def test_4_a_crash_before_the_new_path_started_starts_afresh_and_one_after_carries_on(self):
        rospy.set_param(NODE + "/start_on_takeoff", True)
        rospy.set_param(NODE + "/path", "circle")
        response = self.reset()
        self.assertTrue(response.success, response.message)
        self.steady((0.0, 0.0))
        first = self.crash()
        self.assertEqual(set(self.next_commands(int(2.0 * RATE_HZ), after=first)), {(0.0, 0.0)},
                         "the respawned node must wait for the take-off, not resume the previous path")
        self.take_off()
        self.steady((2.0, 0.2))  # circle at 2 m/s, radius 10 m
        started_at = self.started_at()
        first = self.crash()
        self.assertEqual(set(self.next_commands(int(1.0 * RATE_HZ), after=first)), {(2.0, 0.2)},
                         "the respawned node must carry on along the path")
        self.assertEqual(self.started_at(), started_at)


if __name__ == "__main__":
    rostest.rosrun("summit_moves", "summit_moves_reset", SummitMovesResetTest)
