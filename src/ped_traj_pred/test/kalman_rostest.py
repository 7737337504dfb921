#!/usr/bin/env python3
"""rostest of prediction_kalman_node alone.

This script owns /clock (use_sim_time is true) and publishes noisy detections of a pad driving a 10 m
circle at 3 m/s, 30 Hz, paced at real time. It checks the predicted path 1 s ahead against the true
future position, that a NaN detection does not kill the node, that the node stops publishing once
the detections have been gone for longer than the coast time, and that the vehicle's GPS keeps the
track alive without vision. Waits are on conditions, with wall
timeouts; the driver's pacing is the only sleep.
"""
import functools
import math
import random
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import PointStamped
from nav_msgs.msg import Odometry, Path
from rosgraph_msgs.msg import Clock, Log
from landing_runtime import testing
from landing_runtime.rospy_node import without_nagle

NODE = "/prediction_kalman_node"
RADIUS, SPEED, PAD_HEIGHT = 10.0, 3.0, 0.497  # [m], [m/s], [m]
CAMERA_RATE = 30.0       # [Hz]
NOISE_STD = 0.03         # [m] per axis
GPS_RATE = 5.0           # [Hz]
GPS_NOISE_STD = 0.3      # [m] per axis
START_TIME = 100.0       # first sim time [s]
WARMUP = 5.0             # no scoring before the filter has converged [s]
SCORED = 10.0            # scored span of sim time [s]
WALL_TIMEOUT = 120.0     # [s]


def pad_position(t):
    """True pad centre at sim time t: counter-clockwise circle through the origin, heading +x at START_TIME."""
    angle = SPEED / RADIUS * (t - START_TIME)
    return RADIUS * math.sin(angle), RADIUS * (1.0 - math.cos(angle)), PAD_HEIGHT


def pad_velocity(t):
    angle = SPEED / RADIUS * (t - START_TIME)
    return SPEED * math.cos(angle), SPEED * math.sin(angle)


wait_for = functools.partial(testing.wait_for, timeout=WALL_TIMEOUT)


def percentile(values, fraction):
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, int(math.ceil(fraction * len(ordered))) - 1))]


class Driver(threading.Thread):
    """Advances /clock by one camera period at a time and publishes the detection of that instant."""

    def __init__(self):
        super().__init__(daemon=True)
        # Without Nagle's algorithm (the node's own /clock subscription does not ask for TCP_NODELAY): a tick held
        # back for a delayed ACK could reach the node after the detection of the next instant (a path stamped
        # before the detections resumed, in test_3).
        self.clock_pub = without_nagle(rospy.Publisher("/clock", Clock, queue_size=10))
        self.detection_pub = rospy.Publisher("/platform/current_platform_position_in_world", PointStamped,
                                             queue_size=100, tcp_nodelay=True)
        self.gps_pub = rospy.Publisher("/summit_xl/gps/odom", Odometry, queue_size=10)
        self.lock = threading.Lock()
        self.sim_time = START_TIME
        self.detecting = True
        self.gps = False             # also publish vehicle GPS fixes at GPS_RATE
        self.frame = 0
        self.nan_pending = False
        self.nan_sent_at = None
        self.last_detection = None   # stamp of the last detection published or being published [s]
        self.first_after_resume = None
        self.rng = random.Random(7)

    def now(self):
        with self.lock:
            return self.sim_time

    def run(self):
        period = 1.0 / CAMERA_RATE
        next_wall = time.monotonic()
        while not rospy.is_shutdown():
            with self.lock:
                t = self.sim_time = self.sim_time + period
                detecting, send_nan, gps = self.detecting, self.nan_pending, self.gps
                self.nan_pending = False
                self.frame += 1
                if detecting:  # noted under the lock that decided it: a test that stops detections sees it
                    if send_nan:
                        self.nan_sent_at = t
                    if self.first_after_resume is None and self.last_detection is not None and \
                            t - self.last_detection > 1.5 / CAMERA_RATE:
                        self.first_after_resume = t
                    self.last_detection = t
            try:
                if gps and self.frame % int(round(CAMERA_RATE / GPS_RATE)) == 0:
                    self.publish_gps(t)
                self.publish(t, detecting, send_nan)
            except rospy.ROSException:  # shutting down
                return
            next_wall += period  # real-time pacing of the simulated world, not a synchronisation
            time.sleep(max(0.0, next_wall - time.monotonic()))

    def publish_gps(self, t):
        msg = Odometry()
        msg.header.stamp = rospy.Time.from_sec(t)
        msg.header.frame_id = "world"
        msg.child_frame_id = "summit_xl/base_link"
        x, y, _ = pad_position(t)
        msg.pose.pose.position.x = x + self.rng.gauss(0.0, GPS_NOISE_STD)
        msg.pose.pose.position.y = y + self.rng.gauss(0.0, GPS_NOISE_STD)
        msg.pose.pose.orientation.w = 1.0
        self.gps_pub.publish(msg)

    def publish(self, t, detecting, send_nan):
        self.clock_pub.publish(Clock(clock=rospy.Time.from_sec(t)))
        if not detecting:
            return
        msg = PointStamped()
        msg.header.stamp = rospy.Time.from_sec(t)
        msg.header.frame_id = "world"
        x, y, z = pad_position(t)
        msg.point.x = x + self.rng.gauss(0.0, NOISE_STD)
        msg.point.y = y + self.rng.gauss(0.0, NOISE_STD)
        msg.point.z = z + self.rng.gauss(0.0, NOISE_STD)
        if send_nan:
            msg.point.x = float("nan")
        self.detection_pub.publish(msg)


class KalmanPredictionTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("kalman_rostest")
        cls.lock = threading.Lock()
        cls.paths, cls.odoms, cls.logs = [], [], []
        rospy.Subscriber("/kalman_prediction_path", Path, cls._append(cls.paths), queue_size=1000)
        rospy.Subscriber("/kalman_platform_odom", Odometry, cls._append(cls.odoms), queue_size=1000)
        rospy.Subscriber("/rosout", Log, cls._append(cls.logs), queue_size=1000)
        cls.driver = Driver()
        wait_for(lambda: cls.driver.detection_pub.get_num_connections() > 0 and
                 cls.driver.clock_pub.get_num_connections() > 0, "the node to subscribe to /clock and detections")
        cls.coast_time = rospy.get_param(NODE + "/max_coast_time")
        cls.time_step = rospy.get_param(NODE + "/time_step")
        cls.path_time = rospy.get_param(NODE + "/path_time")
        cls.driver.start()

    @classmethod
    def _append(cls, target):
        def callback(msg):
            with cls.lock:
                target.append(msg)
        return callback

    def received(self, messages, since=-1.0):
        with self.lock:
            return [m for m in messages if m.header.stamp.to_sec() >= since]

    def test_1_path_predicts_the_pad_one_second_ahead(self):
        begin, end = START_TIME + WARMUP, START_TIME + WARMUP + SCORED
        wait_for(lambda: self.received(self.paths, end), "paths up to t = %.0f s" % end)
        horizon_index = int(round(1.0 / self.time_step))
        errors = []
        for path in self.received(self.paths, begin):
            t0 = path.header.stamp.to_sec()
            if t0 > end:
                break
            self.assertEqual(path.header.frame_id, "world")
            self.assertEqual(len(path.poses), int(round(self.path_time / self.time_step)) + 1)
            pose = path.poses[horizon_index]
            t1 = pose.header.stamp.to_sec()
            self.assertAlmostEqual(t1, t0 + 1.0, delta=1e-6)
            x, y, z = pad_position(t1)
            p = pose.pose.position
            errors.append(math.sqrt((p.x - x) ** 2 + (p.y - y) ** 2 + (p.z - z) ** 2))
        self.assertGreater(len(errors), 0.8 * SCORED * rospy.get_param(NODE + "/pub_freq"))
        rospy.loginfo("1 s-ahead error over %d paths: median %.3f, p95 %.3f, max %.3f m", len(errors),
                      percentile(errors, 0.5), percentile(errors, 0.95), max(errors))
        self.assertLess(percentile(errors, 0.95), 0.20)
        self.assertLess(max(errors), 0.30)

        wait_for(lambda: self.received(self.odoms, end), "odometry up to t = %.0f s" % end)
        odom = self.received(self.odoms, end)[0]
        t = odom.header.stamp.to_sec()
        x, y, z = pad_position(t)
        vx, vy = pad_velocity(t)
        self.assertEqual(odom.header.frame_id, "world")
        position, velocity = odom.pose.pose.position, odom.twist.twist.linear
        self.assertLess(math.hypot(position.x - x, position.y - y), 0.05)
        self.assertLess(math.hypot(velocity.x - vx, velocity.y - vy), 0.15)
        self.assertAlmostEqual(odom.twist.twist.angular.z, SPEED / RADIUS, delta=0.05)
        for i in (0, 7, 14):  # x, y, z variances
            self.assertGreater(odom.pose.covariance[i], 0.0)
            self.assertLess(odom.pose.covariance[i], 0.03 ** 2)
        self.assertGreater(odom.twist.covariance[0], 0.0)

    def test_2_nan_detection_is_dropped_and_the_node_keeps_running(self):
        with self.driver.lock:
            self.driver.nan_pending = True
        wait_for(lambda: self.driver.nan_sent_at is not None, "the NaN detection to be sent")
        t_nan = self.driver.nan_sent_at
        wait_for(lambda: self.received(self.paths, t_nan + 2.0), "paths 2 s after the NaN detection")
        wait_for(lambda: any(log.name == NODE and "NaN" in log.msg and
                             "platform/current_platform_position_in_world" in log.msg for log in self.logs),
                 "the node's warning naming the topic")
        for path in self.received(self.paths, t_nan):
            pose = path.poses[int(round(1.0 / self.time_step))]
            x, y, _ = pad_position(pose.header.stamp.to_sec())
            self.assertLess(math.hypot(pose.pose.position.x - x, pose.pose.position.y - y), 0.30)

    def test_3_stops_publishing_after_the_coast_time_and_resumes(self):
        with self.driver.lock:
            self.driver.detecting = False
        t_stop = self.driver.last_detection
        # Coasting: paths keep coming through a gap shorter than the coast time.
        wait_for(lambda: self.received(self.paths, t_stop + self.coast_time - 0.5), "paths while coasting")
        silent_until = t_stop + self.coast_time + 3.0
        wait_for(lambda: self.driver.now() >= silent_until, "sim time %.1f s" % silent_until)
        with self.driver.lock:
            self.driver.detecting = True
        wait_for(lambda: self.driver.first_after_resume is not None, "detections to resume")
        t_resume = self.driver.first_after_resume
        # Everything the node published before the track restarted has arrived once a path stamped after
        # the restart has (one connection, in order).
        wait_for(lambda: self.received(self.paths, t_resume), "paths after the detections resumed")
        last_allowed = t_stop + self.coast_time + 1e-3
        for messages, name in ((self.paths, "path"), (self.odoms, "odometry")):
            # 1 ms of slack: a path stamped on the tick the detections resumed is not late.
            late = [m.header.stamp.to_sec() for m in self.received(messages, last_allowed)
                    if m.header.stamp.to_sec() < t_resume - 1e-3]
            self.assertEqual(late, [], "%s published while the track was lost (lost after %.3f s)" % (name, last_allowed))
        wait_for(lambda: any(log.name == NODE and "lost" in log.msg for log in self.logs), "the node's log of the loss")

    def test_4_vehicle_gps_keeps_the_track_without_vision(self):
        wait_for(lambda: self.driver.gps_pub.get_num_connections() > 0, "the node to subscribe to the GPS")
        with self.driver.lock:
            self.driver.gps = True
        t_gps = self.driver.now()
        wait_for(lambda: self.driver.now() > t_gps + 2.0, "2 s of GPS alongside vision")
        with self.driver.lock:
            self.driver.detecting = False
        t_stop = self.driver.last_detection
        until = t_stop + self.coast_time + 3.0
        wait_for(lambda: self.received(self.paths, until), "paths %.1f s after vision stopped" % (until - t_stop))
        for path in self.received(self.paths, t_stop + 1.0):  # GPS only: 0.3 m noise at 5 Hz
            t0 = path.header.stamp.to_sec()
            x, y, _ = pad_position(t0)
            now = path.poses[0].pose.position
            self.assertLess(math.hypot(now.x - x, now.y - y), 0.8, "at t = %.2f s" % t0)
        with self.driver.lock:
            self.driver.gps, self.driver.detecting = False, True


if __name__ == "__main__":
    rostest.rosrun("ped_traj_pred", "kalman_prediction", KalmanPredictionTest)
