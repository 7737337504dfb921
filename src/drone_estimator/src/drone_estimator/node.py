"""The estimator's thin ROS node; all logic lives in estimator.py (ROS-free).

drone_estimator  ardrone/imu, drone/navdata, ardrone/gps/odom, ardrone/altimeter, ardrone/sonar_height
                 (and, with ~flow_surface/enabled, kalman_platform_odom, vehicle/gps/odom and
                 platform/current_platform_position_in_world: where the flow sees the vehicle)
                 -> ardrone/odom_estimate (nav_msgs/Odometry in `world`, child ardrone/base_link, at the
                 IMU rate; twist.linear is the WORLD-frame velocity, as on ardrone/gps/odom and the
                 ground truth; twist.angular the body rates from the IMU), and ardrone/flow_unseen_velocity
                 (geometry_msgs/Vector3Stamped, world: the vehicle's velocity the flow does not see, at
                 the navdata rate; flow_surface.py).

Restart and reset: respawned after a crash, the estimator starts again from the next GPS fix (nothing else is kept).
It offers ``~reset`` (std_srvs/Trigger, landing_runtime.rospy_node.ResettableNode) for the next scenario of a warm
graph: the parameters are read again as at start-up (a bad one refuses the reset, naming it; the node goes on as it
was) and the node starts over as a fresh one, without a fix.

Inputs that are garbage (non-finite or implausible values, stamps from another time, frames of another tree)
are dropped with a warning naming the topic and what was wrong, once per topic and kind of problem every
WARN_PERIOD (landing_runtime.input_check).
"""
import math
import threading

import numpy as np
import rospy
from geometry_msgs.msg import PointStamped, Vector3Stamped
from landing_msgs.msg import Altimeter, Navdata
from landing_runtime.input_check import MAX_ALTITUDE_M, MAX_POSITION_M, MAX_SPEED_MPS, RosRejectionLog, numbers_problem
from landing_runtime.lockstep import LockstepAcker
from landing_runtime.message_check import WORLD_FRAME, header_problem, sonar_problem, stamp_of
from landing_runtime.params import ParamError, load_params
from landing_runtime.rospy_node import NodeHandles, direct_publisher, run_node
from nav_msgs.msg import Odometry
from sensor_msgs.msg import Imu, Range

from .estimator import DroneEstimator, StateHistory
from .flow_surface import FlowSurface
from .pad_inputs import ESTIMATE_EXTRAPOLATION, ESTIMATE_HISTORY, pad_odometry, world_fix
from .params import EstimatorParams, FlowSurfaceParams

WARN_PERIOD = 5.0          # throttle of repeated input warnings [s]
CONFIG = "drone_estimator/config/"  # where the shipped parameter files are, for the messages naming a bad one
# The navdata states in which the drone flies (DroneEstimator.flow's ``airborne``: not resting on its pad).
AIRBORNE_NAV = (Navdata.STATE_FLYING, Navdata.STATE_HOVERING, Navdata.STATE_TAKING_OFF, Navdata.STATE_GOTO_HOVER,
                Navdata.STATE_LANDING, Navdata.STATE_LOOPING)


def finite(*values):
    return all(math.isfinite(v) for v in values)


def load_flow_surface():
    """The drone's flow model over the vehicle, from ~flow_surface (config/flow_surface_<vehicle>.yaml)."""
    return FlowSurface(load_params(FlowSurfaceParams, check=True, namespace="~flow_surface", see=CONFIG))


class EstimatorNode:
    """drone_estimator, driven by its callbacks alone; a ~reset replaces it with a new one (ResettableNode)."""

    def __init__(self):
        self.params = load_params(EstimatorParams, exclude=("flow_surface",), see=CONFIG)
        self.surface = load_flow_surface()
        self.handles = NodeHandles()  # its subscribers, let go of at a reset
        self.lock = threading.Lock()
        self.estimator = self._new_estimator()
        self.rejections = RosRejectionLog(WARN_PERIOD)  # garbage: what was wrong, once per topic and kind
        self.clock = 0.0  # the latest clock seen by _at
        self.publisher = direct_publisher("ardrone/odom_estimate", Odometry)
        self.pub_unseen = direct_publisher("ardrone/flow_unseen_velocity", Vector3Stamped)
        self.lockstep = LockstepAcker("ardrone/imu")
        # tcp_nodelay throughout the control loop: Nagle's algorithm would deliver sensor messages in bursts.
        self.handles.subscriber("ardrone/imu", Imu, self.on_imu, queue_size=20, tcp_nodelay=True)
        self.handles.subscriber("drone/navdata", Navdata, self.on_navdata, queue_size=20, tcp_nodelay=True)
        self.handles.subscriber("ardrone/gps/odom", Odometry, self.on_gps, queue_size=5, tcp_nodelay=True)
        self.handles.subscriber("ardrone/altimeter", Altimeter, self.on_altimeter, queue_size=5, tcp_nodelay=True)
        self.handles.subscriber("ardrone/sonar_height", Range, self.on_sonar, queue_size=5, tcp_nodelay=True)
        self.published = StateHistory(ESTIMATE_HISTORY, keep=2)  # odom_estimate's xy, to take it off the fixes
        if self.surface.enabled:
            self.handles.subscriber("kalman_platform_odom", Odometry, self.on_pad, queue_size=5, tcp_nodelay=True)
            self.handles.subscriber("vehicle/gps/odom", Odometry, self.on_vehicle, queue_size=5, tcp_nodelay=True)
            self.handles.subscriber("platform/current_platform_position_in_world", PointStamped, self.on_world_fix,
                                    queue_size=5, tcp_nodelay=True)

    def _new_estimator(self):
        return DroneEstimator(self.params, log=lambda line: rospy.loginfo("drone_estimator: %s", line),
                              surface=self.surface)

    def on_pad(self, msg):
        pad = pad_odometry(msg, self.rejections)
        if pad:
            with self.lock:
                self.estimator.pad(*pad)

    def on_world_fix(self, msg):
        """The camera's fix of the pad, placed in the world with the published estimate at its image's capture time:
        less that estimate, the pad relative to the drone then."""
        fix = world_fix(msg, self.rejections)
        if fix:
            with self.lock:
                drone = self.published.at(fix[0], max_extrapolation=ESTIMATE_EXTRAPOLATION)
                if drone is not None:
                    self.estimator.pad_fix(fix[0], fix[1] - drone[0])

    def on_vehicle(self, msg):
        v, w = msg.twist.twist.linear, msg.twist.twist.angular.z
        if not finite(v.x, v.y) or not msg.twist.covariance[0] > 0.0:
            return self.rejections.reject("vehicle/gps/odom", ("non-finite" if not finite(v.x, v.y) else "malformed",
                                                               "no finite velocity with a variance"))
        problem = header_problem(msg, (WORLD_FRAME,)) or numbers_problem(MAX_SPEED_MPS, velocity=(v.x, v.y))
        if problem:
            return self.rejections.reject("vehicle/gps/odom", problem)
        with self.lock:
            self.estimator.vehicle(stamp_of(msg), (v.x, v.y), w if math.isfinite(w) else 0.0)

    def _at(self, t):
        """Called with the lock held before using a measurement stamped ``t``: restarts the filter when the
        clock jumped back (a new simulation, a bag loop). The clock, not the stamp: a message stamped from
        another time is garbage (dropped by the callbacks), not a reason to forget the estimate."""
        now = rospy.get_time()
        if now < self.clock - 1.0 and self.estimator.time is not None:
            rospy.logwarn("drone_estimator: time jumped back from %.2f to %.2f s; restarting the estimate",
                          self.clock, now)
            self.estimator = self._new_estimator()
        self.clock = now

    def on_imu(self, msg):
        q = msg.orientation
        if not finite(q.w, q.x, q.y, q.z):
            return self.rejections.reject("ardrone/imu", ("non-finite", "non-finite orientation"))
        problem = header_problem(msg, (self.params.child_frame_id,))
        if problem:
            return self.rejections.reject("ardrone/imu", problem)
        t = stamp_of(msg)
        with self.lock:
            self._at(t)
            a = msg.linear_acceleration
            if not self.estimator.imu(t, (q.w, q.x, q.y, q.z), (a.x, a.y, a.z)):
                return self.rejections.reject("ardrone/imu", ("non-finite", "orientation is not a unit quaternion"))
            estimate = self.estimator.estimate(t)
        if estimate is not None:
            self.publish(msg, estimate)
        self.lockstep.ack(msg.header.stamp)

    def on_navdata(self, msg):
        problem = numbers_problem(MAX_SPEED_MPS, velocity=(msg.vx, msg.vy, msg.vz)) or header_problem(msg)
        if problem:
            return self.rejections.reject("drone/navdata", problem)
        t = stamp_of(msg)
        with self.lock:
            self._at(t)
            self.estimator.flow(t, msg.vx, msg.vy, msg.vz, airborne=msg.state in AIRBORNE_NAV)
            unseen, weight = self.estimator.unseen_velocity[1], self.estimator.flow_weight
        if self.surface.enabled:
            correction = Vector3Stamped()
            correction.header.stamp, correction.header.frame_id = msg.header.stamp, self.params.frame_id
            correction.vector.x, correction.vector.y = float(unseen[0]), float(unseen[1])
            correction.vector.z = float(weight)  # the weight itself: 0 the flow sees the ground, 1 the vehicle
            self.pub_unseen.publish(correction)

    def on_gps(self, msg):
        p, v = msg.pose.pose.position, msg.twist.twist.linear
        if not finite(p.x, p.y, p.z):
            return self.rejections.reject("ardrone/gps/odom", ("non-finite", "non-finite position"))
        problem = header_problem(msg, (WORLD_FRAME,)) or numbers_problem(MAX_POSITION_M, position=(p.x, p.y, p.z))
        if problem:
            return self.rejections.reject("ardrone/gps/odom", problem)
        # A fix without a velocity (NaN) is still a fix; an implausible velocity makes the whole fix suspect.
        velocity = (v.x, v.y, v.z) if finite(v.x, v.y, v.z) else None
        if velocity is not None and numbers_problem(MAX_SPEED_MPS, velocity=velocity):
            return self.rejections.reject("ardrone/gps/odom", numbers_problem(MAX_SPEED_MPS, velocity=velocity))
        t = stamp_of(msg)
        with self.lock:
            self._at(t)
            self.estimator.gps(t, (p.x, p.y, p.z), velocity)

    def on_altimeter(self, msg):
        problem = numbers_problem(MAX_ALTITUDE_M, altitude=msg.altitude) or header_problem(msg)
        if problem:
            return self.rejections.reject("ardrone/altimeter", problem)
        t = stamp_of(msg)
        with self.lock:
            self._at(t)
            self.estimator.altimeter(t, msg.altitude)

    def on_sonar(self, msg):
        problem = sonar_problem(msg, self.params.child_frame_id)
        if problem:
            return self.rejections.reject("ardrone/sonar_height", problem)
        t = stamp_of(msg)
        with self.lock:
            self._at(t)
            self.estimator.sonar(t, msg.range)  # +inf (no echo) is valid and simply unused

    def publish(self, imu, estimate):
        odom = Odometry()
        odom.header.stamp = rospy.Time.from_sec(estimate.time)
        odom.header.frame_id = self.params.frame_id
        odom.child_frame_id = self.params.child_frame_id
        position = odom.pose.pose.position
        position.x, position.y, position.z = (float(v) for v in estimate.position)
        orientation = odom.pose.pose.orientation
        orientation.w, orientation.x, orientation.y, orientation.z = estimate.orientation
        velocity = odom.twist.twist.linear
        velocity.x, velocity.y, velocity.z = (float(v) for v in estimate.velocity)
        odom.twist.twist.angular = imu.angular_velocity
        covariance = [0.0] * 36
        for i, variance in enumerate(estimate.position_variance):
            covariance[i * 7] = float(variance)
        for i in range(3, 6):
            covariance[i * 7] = max(imu.orientation_covariance[0], 1e-6)
        odom.pose.covariance = covariance
        velocity_variance = self.params.flow_velocity_std ** 2
        odom.twist.covariance = [velocity_variance if i in (0, 7, 14) else 0.0 for i in range(36)]
        self.publisher.publish(odom)
        if self.surface.enabled:  # only the flow over the vehicle needs the fixes taken back to the drone
            with self.lock:
                self.published.add(estimate.time, np.array(estimate.position[:2], dtype=float),
                                   np.array(estimate.velocity[:2], dtype=float))


def estimator_main():
    return run_node("drone_estimator", EstimatorNode, startup_errors=(ParamError,), resettable=True)
