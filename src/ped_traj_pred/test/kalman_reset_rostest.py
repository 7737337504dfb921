#!/usr/bin/env python3
"""rostest of prediction_kalman_node's ~reset (std_srvs/Trigger), the node alone as users launch it.

This script owns /clock (use_sim_time is true) and moves it itself. A reset must leave the node as a fresh one:
nothing published until it is fed again (the coasting track is gone), and the first output of a new track equal
to the fresh node's for the same detection. Parameters changed before a reset are in force after it (a new
initial velocity std, a new output topic); a bad or missing parameter refuses the reset, naming it, and the node
goes on as it was. Waits are on conditions with wall timeouts: the node's timer ticks are seen on its
lockstep_ack, its fixes in its log.
"""
import functools
import threading
import unittest

import rospy
import rostest
from geometry_msgs.msg import PointStamped
from landing_msgs.msg import LockstepAck
from nav_msgs.msg import Odometry, Path
from rosgraph_msgs.msg import Clock, Log
from std_srvs.srv import Trigger
from landing_runtime import testing

NODE = "/prediction_kalman_node"
PAD = (3.0, -2.0, 0.497)       # where every new track starts [m]
START_TIME = 100.0             # first sim time [s]
STEP = 0.05                    # clock step while a track is built or coasts [s]
NEW_ODOM_TOPIC = "/kalman_platform_odom_after_reset"
WALL_TIMEOUT = 60.0            # [s]

wait_for = functools.partial(testing.wait_for, timeout=WALL_TIMEOUT)


class KalmanResetTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("kalman_reset_rostest")
        cls.lock = threading.Lock()
        cls.paths, cls.odoms, cls.new_odoms, cls.acks, cls.logs = [], [], [], [], []
        rospy.Subscriber("/kalman_prediction_path", Path, cls._append(cls.paths), queue_size=1000)
        rospy.Subscriber("/kalman_platform_odom", Odometry, cls._append(cls.odoms), queue_size=1000)
        cls.new_odom_sub = rospy.Subscriber(NEW_ODOM_TOPIC, Odometry, cls._append(cls.new_odoms), queue_size=1000)
        rospy.Subscriber("/lockstep_ack", LockstepAck,
                         lambda m: cls._append(cls.acks)(m.stamp.to_sec()) if m.node == NODE else None,
                         queue_size=1000)
        rospy.Subscriber("/rosout", Log, lambda m: cls._append(cls.logs)(m.msg) if m.name == NODE else None,
                         queue_size=1000)
        cls.clock_pub = rospy.Publisher("/clock", Clock, queue_size=10)
        cls.detection_pub = rospy.Publisher("/platform/current_platform_position_in_world", PointStamped,
                                            queue_size=100)
        wait_for(lambda: cls.clock_pub.get_num_connections() > 0 and cls.detection_pub.get_num_connections() > 0,
                 "the node to subscribe to /clock and the detections")
        rospy.wait_for_service(NODE + "/reset", timeout=WALL_TIMEOUT)
        cls.reset_service = rospy.ServiceProxy(NODE + "/reset", Trigger)
        cls.sim_time = 0.0

    @classmethod
    def _append(cls, target):
        def callback(msg):
            with cls.lock:
                target.append(msg)
        return callback

    def stamped(self, messages, after, before=float("inf")):
        with self.lock:
            return [m for m in messages if after < m.header.stamp.to_sec() < before]

    def advance(self, t):
        self.__class__.sim_time = t
        self.clock_pub.publish(Clock(clock=rospy.Time.from_sec(t)))

    def jump_and_settle(self, t):
        """The clock to ``t`` (a jump of several timer periods) and the node's timer tick at ``t`` done: every
        tick before ran before it (one callback queue)."""
        self.advance(t)
        wait_for(lambda: any(abs(stamp - t) < 1e-6 for stamp in list(self.acks)), "the node's timer tick at %.2f s" % t)

    def detect(self, t, position):
        msg = PointStamped()
        msg.header.stamp, msg.header.frame_id = rospy.Time.from_sec(t), "world"
        msg.point.x, msg.point.y, msg.point.z = position
        self.detection_pub.publish(msg)

    def first_output(self, t0, odoms):
        """The first odometry of a new track from one detection of PAD at ``t0``, 0.1 s later: independent of
        the timer's phase, as the clock jumps there in one step."""
        self.jump_and_settle(t0)
        logs_before = len(self.logs)
        self.detect(t0, PAD)
        started = "t = %.3f s" % t0
        wait_for(lambda: any("Pad track started" in log and started in log for log in self.logs[logs_before:]),
                 "a new track started by the detection at %.2f s" % t0)
        self.advance(t0 + 0.1)
        found = wait_for(lambda: self.stamped(odoms, t0 + 0.1 - 1e-6, t0 + 0.1 + 1e-6),
                         "the new track's odometry at %.2f s" % (t0 + 0.1))
        return found[0]

    def build_track(self, t_from, duration):
        """Detections of the pad moving along +x at 1 m/s; returns the last stamp."""
        t = t_from
        for k in range(1, int(round(duration / STEP)) + 1):
            t = t_from + k * STEP
            self.advance(t)
            self.detect(t, (PAD[0] + (t - t_from), PAD[1], PAD[2]))
        wait_for(lambda: [m for m in self.stamped(self.odoms, t - 1e-6) if m.twist.twist.linear.x > 0.5],
                 "odometry of a moving track at %.2f s" % t)
        return t

    def reset(self):
        response = self.reset_service()
        return response.success, response.message

    def assertSameOutput(self, expected, actual):
        for name in ("x", "y", "z"):
            self.assertAlmostEqual(getattr(actual.pose.pose.position, name),
                                   getattr(expected.pose.pose.position, name), delta=1e-6)
            self.assertAlmostEqual(getattr(actual.twist.twist.linear, name),
                                   getattr(expected.twist.twist.linear, name), delta=1e-6)
        for i in (0, 7, 14):
            self.assertAlmostEqual(actual.pose.covariance[i], expected.pose.covariance[i],
                                   delta=1e-6 * abs(expected.pose.covariance[i]))
        for i in (0, 1, 6, 7, 35):
            self.assertAlmostEqual(actual.twist.covariance[i], expected.twist.covariance[i],
                                   delta=1e-6 * abs(expected.twist.covariance[i]) + 1e-12)

    def test_1_reset_leaves_a_fresh_track(self):
        self.jump_and_settle(START_TIME)
        fresh = self.first_output(START_TIME + 0.5, self.odoms)
        self.assertGreater(fresh.twist.covariance[0], 90.0)  # initial_velocity_std 10 m/s
        t_last = self.build_track(START_TIME + 0.6, 2.0)

        success, message = self.reset()
        self.assertTrue(success, message)
        self.assertEqual(message, NODE + " reset")
        t_reset = self.sim_time
        wait_for(lambda: any(log == NODE + " reset" for log in self.logs), "the node's log of the reset")

        # The old track would coast (and be published) for max_coast_time; a fresh node publishes nothing.
        coast_time = rospy.get_param(NODE + "/max_coast_time")
        t = t_reset
        while t < t_last + 0.5 * coast_time:
            t += STEP
            self.advance(t)
        t_new = t + 0.5
        after = self.first_output(t_new, self.odoms)  # all earlier odometry has arrived (one connection)
        for messages, name in ((self.paths, "path"), (self.odoms, "odometry")):
            stamps = [m.header.stamp.to_sec() for m in self.stamped(messages, t_reset + 1e-6, t_new - 1e-6)]
            self.assertEqual(stamps, [], "%s published after the reset at %.2f s before any new detection" %
                             (name, t_reset))
        # The detection at PAD started a new track (first_output waited for it); its first output is the fresh
        # node's, though the old track had been at PAD + 2 m, moving.
        self.assertSameOutput(fresh, after)

    def test_2_changed_parameters_are_in_force_after_a_reset(self):
        rospy.set_param(NODE + "/initial_velocity_std", 5.0)
        rospy.set_param(NODE + "/odom_topic", NEW_ODOM_TOPIC)
        success, message = self.reset()
        self.assertTrue(success, message)
        t_reset = self.sim_time
        wait_for(lambda: self.new_odom_sub.get_num_connections() > 0, "the node to publish " + NEW_ODOM_TOPIC)
        odom = self.first_output(self.sim_time + 0.5, self.new_odoms)
        self.assertLess(odom.twist.covariance[0], 30.0)  # 5 m/s std: 25 m^2/s^2 and a little process noise
        self.assertGreater(odom.twist.covariance[0], 20.0)
        self.assertEqual(self.stamped(self.odoms, t_reset + 1e-6), [], "odometry still on the old topic")

    def test_3_bad_parameter_refuses_the_reset_and_the_node_goes_on(self):
        # The track of test 2 is alive: a refused reset must keep it, a successful one would drop it.
        rospy.set_param(NODE + "/pub_freq", -1.0)
        success, message = self.reset()
        self.assertFalse(success)
        self.assertIn(NODE + "/pub_freq", message)
        self.assertIn("must be > 0", message)
        rospy.set_param(NODE + "/pub_freq", 20.0)
        rospy.delete_param(NODE + "/time_step")
        success, message = self.reset()
        self.assertFalse(success)
        self.assertIn(NODE + "/time_step", message)
        self.assertIn("missing", message)
        rospy.set_param(NODE + "/odom_topic", "bad topic name")
        rospy.set_param(NODE + "/time_step", 0.1)
        success, message = self.reset()
        self.assertFalse(success)
        self.assertIn(NODE + "/odom_topic", message)
        wait_for(lambda: any("not reset" in log for log in self.logs), "the node's log of a refused reset")

        # Still the track of test 2 on the topic of test 2, with its settings.
        t = self.sim_time + 0.5
        self.jump_and_settle(t)
        odom = wait_for(lambda: self.stamped(self.new_odoms, t - 1e-6), "odometry of the kept track")[0]
        self.assertAlmostEqual(odom.pose.pose.position.x, PAD[0], delta=0.5)

        # As launched again, for whatever runs next.
        rospy.set_param(NODE + "/odom_topic", "kalman_platform_odom")
        rospy.set_param(NODE + "/initial_velocity_std", 10.0)
        success, message = self.reset()
        self.assertTrue(success, message)


if __name__ == "__main__":
    rostest.rosrun("ped_traj_pred", "kalman_reset", KalmanResetTest)
