#!/usr/bin/env python3
"""rostest of platform_detection in the simulator: take off from the pad, climb, hover and drift
sideways, and check the published pad position against the simulator's ground truth (allowed here,
for scoring). Stands in for the drone's position estimator by forwarding /ardrone/gps/odom to
/ardrone/odom_estimate, so that the world topic is exercised too."""
import functools
import bisect
import math
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import PointStamped, PoseStamped, Twist
from landing_msgs.msg import Navdata
from nav_msgs.msg import Odometry
from std_msgs.msg import Empty
from landing_runtime import testing

WALL_TIMEOUT = 120.0           # generous: the simulator shares two cores with the node and the test
RELATIVE_TOLERANCE = 0.15      # pad centre relative to the drone [m]
WORLD_TOLERANCE = 1.5          # world position: the stand-in estimate is a GPS with 0.3 m noise per axis [m]
STRIP_OFFSET = 0.36            # heading strip centre ahead of the pad centre [m]


wait_for = functools.partial(testing.wait_for, timeout=WALL_TIMEOUT)


def rotation(q):
    """Rotation matrix of a geometry_msgs Quaternion."""
    w, x, y, z = q.w, q.x, q.y, q.z
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def vector(p):
    return np.array([p.x, p.y, p.z])


class TruthHistory:
    """Ground-truth poses by stamp, to look up the one of a detection's frame."""

    def __init__(self):
        self.stamps, self.poses = [], []
        self.lock = threading.Lock()

    def add(self, msg):
        with self.lock:
            self.stamps.append(msg.header.stamp.to_sec())
            self.poses.append(msg.pose)

    def at(self, stamp, max_offset=0.015):
        with self.lock:
            i = bisect.bisect_left(self.stamps, stamp)
            best = min((j for j in (i - 1, i) if 0 <= j < len(self.stamps)),
                       key=lambda j: abs(self.stamps[j] - stamp), default=None)
            if best is None or abs(self.stamps[best] - stamp) > max_offset:
                return None
            return self.poses[best]


class PlatformDetectionTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_platform_detection")
        cls.drone, cls.pad = TruthHistory(), TruthHistory()
        cls.received = {"relative": [], "world": [], "indicator": []}
        cls.navdata = None
        rospy.Subscriber("/groundtruth/ardrone", PoseStamped, cls.drone.add, queue_size=200)
        rospy.Subscriber("/groundtruth/landing_pad", PoseStamped, cls.pad.add, queue_size=200)
        for key, topic in (("relative", "/platform/current_platform_position_in_ardrone"),
                           ("world", "/platform/current_platform_position_in_world"),
                           ("indicator", "/platform/current_indicator_position_in_ardrone")):
            rospy.Subscriber(topic, PointStamped, cls.received[key].append, queue_size=100)
        rospy.Subscriber("/drone/navdata", Navdata, lambda m: setattr(cls, "navdata", m), queue_size=1)
        # Stand-in for the drone's own position estimate (another package's job): the GPS as it is.
        cls.odom_estimate = rospy.Publisher("/ardrone/odom_estimate", Odometry, queue_size=5)
        rospy.Subscriber("/ardrone/gps/odom", Odometry, cls.odom_estimate.publish, queue_size=5)
        cls.cmd = rospy.Publisher("/ardrone/cmd_vel", Twist, queue_size=1)
        cls.takeoff = rospy.Publisher("/ardrone/takeoff", Empty, queue_size=1, latch=True)
        wait_for(lambda: cls.navdata is not None and cls.drone.stamps, "the simulator's first messages")

    def sim_sleep(self, seconds):
        end = rospy.get_time() + seconds
        wait_for(lambda: rospy.get_time() >= end, "%.1f s of sim time" % seconds)

    def fly(self, seconds, vx=0.0, vy=0.0, vz=0.0):
        """Sends the velocity command every 50 ms of sim time for `seconds` of sim time."""
        end = rospy.get_time() + seconds
        msg = Twist()
        msg.linear.x, msg.linear.y, msg.linear.z = vx, vy, vz
        while rospy.get_time() < end:
            self.cmd.publish(msg)
            self.sim_sleep(0.05)

    def truth_relative(self, stamp):
        """Pad centre and strip centre relative to the drone, in its body frame, at `stamp` (or None)."""
        drone, pad = self.drone.at(stamp), self.pad.at(stamp)
        if drone is None or pad is None:
            return None
        world_from_body = rotation(drone.orientation)
        pad_centre = vector(pad.position)
        strip = pad_centre + rotation(pad.orientation) @ np.array([STRIP_OFFSET, 0.0, 0.0])
        drone_position = vector(drone.position)
        return (world_from_body.T @ (pad_centre - drone_position), world_from_body.T @ (strip - drone_position),
                pad_centre)

    def check_window(self, start, end, what):
        """Every detection stamped in [start, end] against the truth; returns how many were checked."""
        errors = []
        for msg in [m for m in self.received["relative"] if start <= m.header.stamp.to_sec() <= end]:
            self.assertEqual(msg.header.frame_id, "ardrone/base_link")
            truth = self.truth_relative(msg.header.stamp.to_sec())
            if truth is None:
                continue
            error = np.linalg.norm(vector(msg.point) - truth[0])
            self.assertLess(error, RELATIVE_TOLERANCE, "%s at t=%.2f: detected %s, truth %s" % (
                what, msg.header.stamp.to_sec(), vector(msg.point).round(3), truth[0].round(3)))
            errors.append(error)
        if errors:
            print("%s: %d detections, pad centre error mean %.3f m, max %.3f m" % (
                what, len(errors), np.mean(errors), np.max(errors)))
        return len(errors)

    def test_detection_during_takeoff_hover_and_drift(self):
        self.takeoff.publish(Empty())
        wait_for(lambda: self.navdata.state in (Navdata.STATE_FLYING, Navdata.STATE_HOVERING), "take-off")
        self.fly(2.5, vz=0.5)  # about 2.7 m above the ground, the camera about 2.2 m above the pad
        start = rospy.get_time()
        self.fly(2.0)
        hover_end = rospy.get_time()
        wait_for(lambda: any(m.header.stamp.to_sec() >= hover_end - 0.2 for m in self.received["relative"]),
                 "a pad position from the hover")
        hovering = self.check_window(start, hover_end, "hover")
        self.assertGreaterEqual(hovering, 10, "too few detections while hovering over the pad")

        # Drift sideways: the pad moves off the image centre, the sonar onto the ground.
        self.fly(2.5, vy=0.4)
        drift_end = rospy.get_time()
        wait_for(lambda: any(m.header.stamp.to_sec() >= drift_end - 0.5 for m in self.received["relative"]),
                 "a pad position while drifting")
        drifting = self.check_window(hover_end, drift_end, "drift")
        self.assertGreaterEqual(drifting, 10, "too few detections while drifting")

        # Heading strip: published with the pad and at the strip's place.
        strips = [m for m in self.received["indicator"] if start <= m.header.stamp.to_sec() <= drift_end]
        self.assertGreaterEqual(len(strips), 10)
        for msg in strips:
            truth = self.truth_relative(msg.header.stamp.to_sec())
            if truth is not None:
                self.assertLess(np.linalg.norm(vector(msg.point) - truth[1]), RELATIVE_TOLERANCE)

        # World topic: the stand-in estimate plus the relative vector.
        world = [m for m in self.received["world"] if start <= m.header.stamp.to_sec() <= drift_end]
        self.assertGreaterEqual(len(world), 10, "the world topic was not published with a fresh odom_estimate")
        for msg in world:
            self.assertEqual(msg.header.frame_id, "world")
            truth = self.truth_relative(msg.header.stamp.to_sec())
            if truth is not None:
                error = math.dist((msg.point.x, msg.point.y, msg.point.z), truth[2])
                self.assertLess(error, WORLD_TOLERANCE, "world position %.2f m off" % error)


if __name__ == "__main__":
    rostest.rosrun("uav_vision", "platform_detection_rostest", PlatformDetectionTest)
