#!/usr/bin/env python3
"""TEST STAND-IN for uav_vision + ped_traj_pred (not vision): publishes kalman_prediction_path,
kalman_platform_odom and (for its stamp: when the pad was seen) platform/current_platform_position_in_ardrone
from the simulator's ground-truth pad, with noise and latency, so the tracking nodes can be exercised
alone. For tests only: ground truth must never feed
the flying system outside a test.

Like uav_vision, it anchors the pad's world position on the drone's own estimate:
pad = ardrone/odom_estimate + (true pad - true drone) + noise.
Parameters (private): ~noise [m] 0.03, ~latency [s] 0.03 (about one camera frame, as the detector under lock-step), ~rate_hz 30, ~path_time [s] 2, ~time_step [s] 0.1.
"""
import bisect
import collections

import numpy as np
import rospy
from geometry_msgs.msg import PointStamped, PoseStamped
from landing_runtime.lockstep import LockstepAcker
from nav_msgs.msg import Odometry, Path


class StandIn:
    def __init__(self):
        self.noise = rospy.get_param("~noise", 0.03)
        self.latency = rospy.get_param("~latency", 0.03)
        self.path_time = rospy.get_param("~path_time", 2.0)
        self.time_step = rospy.get_param("~time_step", 0.1)
        self.rng = np.random.default_rng(rospy.get_param("~seed", 0))
        # Recent poses by stamp: ground truth may arrive in bursts, so the pad and the drone are paired
        # at the same stamp, never the latest of each.
        self.pad_history = collections.OrderedDict()        # stamp -> true pad position
        self.truth_history, self.estimate_history = {}, {}  # stamp -> true / estimated drone position
        self.queue = collections.deque()
        self.last_sampled = None
        self.pub_path = rospy.Publisher("kalman_prediction_path", Path, queue_size=5)
        self.pub_odom = rospy.Publisher("kalman_platform_odom", Odometry, queue_size=5)
        self.pub_seen = rospy.Publisher("platform/current_platform_position_in_ardrone", PointStamped, queue_size=5)
        rospy.Subscriber("groundtruth/landing_pad", PoseStamped, self.on_pad, queue_size=50, tcp_nodelay=True)
        rospy.Subscriber("ardrone/ground_truth/state", Odometry, self.on_truth, queue_size=50, tcp_nodelay=True)
        rospy.Subscriber("ardrone/odom_estimate", Odometry, self.on_estimate, queue_size=50, tcp_nodelay=True)

    @staticmethod
    def _xyz(point):
        return np.array([point.x, point.y, point.z])

    @staticmethod
    def _remember(history, msg, position, keep=100):
        history[round(msg.header.stamp.to_sec(), 3)] = position
        while len(history) > keep:
            history.pop(next(iter(history)))

    def on_pad(self, msg):
        self._remember(self.pad_history, msg, self._xyz(msg.pose.position))

    def on_truth(self, msg):
        self._remember(self.truth_history, msg, self._xyz(msg.pose.pose.position))

    def on_estimate(self, msg):
        self._remember(self.estimate_history, msg, self._xyz(msg.pose.pose.position), keep=300)

    def sample(self):
        t = rospy.get_time()
        pads = dict(list(self.pad_history.items()))  # copies: the callbacks add to them meanwhile
        estimates = dict(list(self.estimate_history.items()))
        # Pad and drone ground truth come from the same simulator step; the estimate (IMU rate) nearest to
        # it, for the newest such step the estimate has reached.
        estimate_stamps = sorted(estimates)
        stamp = estimate_stamp = None
        for candidate in sorted((s for s in pads if s in self.truth_history), reverse=True):
            i = bisect.bisect_left(estimate_stamps, candidate)
            near = [e for e in estimate_stamps[max(0, i - 1):i + 1] if abs(e - candidate) <= 0.015]
            if near:
                stamp, estimate_stamp = candidate, near[-1]
                break
        if stamp is not None and stamp != self.last_sampled:
            self.last_sampled = stamp
            pad = pads[stamp]
            old_stamp = min(s for s in pads if s >= stamp - 0.1)
            velocity = (pad - pads[old_stamp]) / max(1e-3, stamp - old_stamp)
            velocity[2] = 0.0
            relative = pad - self.truth_history[stamp] + self.rng.normal(0.0, self.noise, 3)
            self.queue.append((t + self.latency, stamp, estimates[estimate_stamp] + relative, velocity, relative))
        while self.queue and self.queue[0][0] <= t:
            _, stamp, seen, velocity, relative = self.queue.popleft()
            self.publish(stamp, seen, velocity, relative)

    def publish(self, stamp, position, velocity, relative):
        detection = PointStamped()
        detection.header.stamp, detection.header.frame_id = rospy.Time.from_sec(stamp), "ardrone/base_link"
        detection.point.x, detection.point.y, detection.point.z = relative  # world-aligned: only the stamp is used
        self.pub_seen.publish(detection)
        odom = Odometry()
        odom.header.stamp, odom.header.frame_id = rospy.Time.from_sec(stamp), "world"
        odom.pose.pose.position.x, odom.pose.pose.position.y, odom.pose.pose.position.z = position
        odom.pose.pose.orientation.w = 1.0
        odom.twist.twist.linear.x, odom.twist.twist.linear.y, odom.twist.twist.linear.z = velocity
        path = Path()
        path.header = odom.header
        for k in range(int(round(self.path_time / self.time_step)) + 1):
            pose = PoseStamped()
            pose.header.frame_id = "world"
            pose.header.stamp = rospy.Time.from_sec(stamp + k * self.time_step)
            pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = position + velocity * k * self.time_step
            pose.pose.orientation.w = 1.0
            path.poses.append(pose)
        self.pub_odom.publish(odom)
        self.pub_path.publish(path)


def main():
    rospy.init_node("pipeline_stand_in")
    node = StandIn()
    while not rospy.is_shutdown() and rospy.get_time() == 0.0:
        rospy.sleep(0.01)
    rate_hz = rospy.get_param("~rate_hz", 30.0)
    rate = rospy.Rate(rate_hz)
    # Like the vision it stands in for, it holds the simulator back rather than fall behind it.
    lockstep = LockstepAcker(period=1.0 / rate_hz)
    while not rospy.is_shutdown():
        node.sample()
        lockstep.ack(rospy.Time.now())
        try:
            rate.sleep()
        except (rospy.ROSTimeMovedBackwardsException, rospy.ROSInterruptException):
            break


if __name__ == "__main__":
    main()
