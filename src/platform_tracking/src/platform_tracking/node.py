"""The two thin ROS nodes of this package; all logic lives in estimator.py and state_machine.py.

drone_estimator  ardrone/imu, ardrone/navdata, ardrone/gps/odom, ardrone/altimeter, ardrone/sonar_height
                 (and, with ~flow_surface/enabled, kalman_platform_odom, vehicle/gps/odom and
                 platform/current_platform_position_in_world: where the flow sees the vehicle)
                 -> ardrone/odom_estimate (nav_msgs/Odometry in `world`, child ardrone/base_link, at the
                 IMU rate; twist.linear is the WORLD-frame velocity, as on ardrone/gps/odom and the
                 ground truth; twist.angular the body rates from the IMU), and ardrone/flow_unseen_velocity
                 (geometry_msgs/Vector3Stamped, world: the vehicle's velocity the flow does not see, at
                 the navdata rate; flow_surface.py).

platform_tracking ardrone/odom_estimate, kalman_prediction_path, kalman_platform_odom, ardrone/navdata,
                 ardrone/sonar_height, ardrone/flow_unseen_velocity, platform/current_platform_position_in_ardrone
                 (only when it arrives: the pad was seen) and ..._in_world (the pad relative to the drone, carried on
                 by the flow: relative.py), landing_allowed (std_msgs/Bool, default true) and the
                 operator requests -> ardrone/cmd_vel at rate_hz (sim time), ardrone/takeoff and
                 ardrone/land as one-shot actions, platform_tracking/state (std_msgs/String, latched,
                 on every change), platform_tracking/target (geometry_msgs/PointStamped, world: where the
                 pad is believed to be at each step, for rviz and the flight analysis).

Operator requests: platform_tracking/command (std_msgs/String: takeoff | land | force_land | hold; hold
forgets a pending take-off or land request: the supervisor sends it when another module has the drone or
the mission is over, so a restarted tracker that reads the latched command does not take off again) is the
unambiguous way. The thesis topics work too: ardrone/force_land (Empty); ardrone/takeoff and
ardrone/land (Empty) from anyone but this node (messages whose publisher is this node, i.e. its own
actions, are recognised by the connection header and ignored). Note that the drone itself also obeys
ardrone/takeoff and ardrone/land: an operator's ardrone/land makes it descend at once, and the
tracker then follows the pad down (state LANDING, committed) rather than starting its own approach;
use platform_tracking/command "land" for the gated landing on the pad.

Restart and reset: respawned after a crash, the estimator starts again from the next GPS fix and the tracker from
the latched platform_tracking/command and the drone's navdata state (nothing else is kept). Both offer ``~reset``
(std_srvs/Trigger, landing_runtime.rospy_node.ResettableNode) for the next scenario of a warm graph: the parameters are
read again as at start-up (a bad one refuses the reset, naming it; the node goes on as it was) and the node starts
over as a fresh one: the estimator without a fix, the tracker LANDED with no request pending (``autostart`` takes
off again), its latched platform_tracking/state LANDED again and no camera_latency latched until it measures one.

Inputs that are garbage (non-finite or implausible values, stamps from another time, frames of another tree,
unknown words) are dropped with a warning naming the topic and what was wrong, once per topic and kind of
problem every WARN_PERIOD (landing_runtime.input_check).
"""
import collections
import dataclasses
import math
import threading

import numpy as np
import rospy
from geometry_msgs.msg import PointStamped, Twist, Vector3Stamped
from landing_runtime.input_check import (MAX_ALTITUDE_M, MAX_POSITION_M, MAX_SPEED_MPS, RosRejectionLog, choice_problem,
                                      first_problem, frame_problem, numbers_problem, stamp_problem)
from landing_runtime.lockstep import LockstepAcker
from landing_msgs.msg import Altimeter, Navdata
from landing_runtime.rospy_node import NodeHandles, direct_publisher, run_node
from nav_msgs.msg import Odometry, Path
from sensor_msgs.msg import Imu, Range
from std_msgs.msg import Bool, Empty, Float64, String

from .camera_latency import CameraLatency
from .controller import DroneState, PadPrediction
from .estimator import DroneEstimator, StateHistory
from .flow_surface import FlowSurface, WeightForecast
from .relative import RelativeTrack
from .params import EstimatorParams, FlowSurfaceParams, ParamError, TrackingParams, from_mapping
from .state_machine import AIRBORNE_NAV, Inputs, State, TrackingStateMachine

WARN_PERIOD = 5.0          # throttle of repeated input warnings [s]
ESTIMATE_MAX_AGE = 0.5     # an odom_estimate older than this counts as no estimate [s]
ESTIMATE_HISTORY = 2.0     # how far back the estimate is kept, to place a fix at its image's capture time [s]
ESTIMATE_EXTRAPOLATION = 0.1  # a fix this far outside that history is placed with its nearest estimate [s]
DELAY_SAMPLES = 15         # detections whose arrival-minus-capture median is the camera latency [-]
LATENCY_PERIOD = 1.0       # how often that latency is published on platform_tracking/camera_latency [s of sim time]
WORLD_FRAMES = ("world", "/world", "")
COMMANDS = ("takeoff", "land", "force_land", "hold")
BODY_FRAME = "ardrone/base_link"  # the drone's body frame (docs/conventions.md): sonar and relative pad positions


NAVDATA_STATES = tuple(range(11))  # landing_msgs/Navdata state codes (state_machine.Nav)


def finite(*values):
    return all(math.isfinite(v) for v in values)


def header_problem(msg, frames=None):
    """A stamp too far from the clock, or (``frames``: the names allowed) a frame of another tree."""
    return first_problem(stamp_problem(msg.header.stamp.to_sec(), rospy.get_time()),
                         frame_problem(msg.header.frame_id, frames) if frames else None)


def odometry_problem(msg, frames=WORLD_FRAMES[:1], position_limit=MAX_POSITION_M):
    """What is wrong with an Odometry in the world: stamp, frame, a position or velocity no vehicle has."""
    p, v = msg.pose.pose.position, msg.twist.twist.linear
    return header_problem(msg, frames) or numbers_problem(position_limit, position=(p.x, p.y, p.z)) or \
        numbers_problem(MAX_SPEED_MPS, velocity=(v.x, v.y, v.z))


def load_params(cls, check=None, namespace="~", exclude=()):
    """The node's private parameters (or those of a sub-namespace) as ``cls``; a missing or bad one raises a
    ParamError naming it (fatal at start-up, a refused ~reset later: run_node). Sub-namespaces in ``exclude`` are
    another class's."""
    source = "%s parameters" % rospy.resolve_name(namespace)
    try:
        mapping = rospy.get_param(namespace, {})
        if isinstance(mapping, dict):
            mapping = {k: v for k, v in mapping.items() if k not in exclude}
        params = from_mapping(cls, mapping, source)
        return params.check(source) if check else params
    except ParamError as err:
        raise ParamError("%s (see platform_tracking/config/)" % err) from None


def sonar_problem(msg, base_frame):
    """A range that is NaN or negative (+inf is valid: no echo), a stamp from another time or a frame not the
    drone's body."""
    if math.isnan(msg.range) or msg.range < 0.0:
        return ("non-finite" if math.isnan(msg.range) else "out of range"), "range is %s" % msg.range
    return header_problem(msg, (base_frame,))


def stamp_of(msg):
    """Header stamp in seconds, the current time when the publisher left it empty."""
    stamp = msg.header.stamp.to_sec()
    return stamp if stamp > 0.0 else rospy.get_time()


def pad_odometry(msg, rejections):
    """(stamp, position, velocity) of the Kalman filter's pad odometry, or None after logging why it was dropped."""
    problem = odometry_problem(msg)
    if problem:
        rejections.reject("kalman_platform_odom", problem)
        return None
    p, v = msg.pose.pose.position, msg.twist.twist.linear
    return stamp_of(msg), (p.x, p.y, p.z), (v.x, v.y, v.z)


def world_fix(msg, rejections):
    """(stamp, world xy) of the camera's fix of the pad (platform/current_platform_position_in_world), or None after
    logging why it was dropped."""
    p = msg.point
    problem = numbers_problem(MAX_POSITION_M, point=(p.x, p.y, p.z)) or header_problem(msg, WORLD_FRAMES[:1])
    if problem:
        return rejections.reject("platform/current_platform_position_in_world", problem)
    return stamp_of(msg), np.array([p.x, p.y])


# ------------------------------------------------------------------------------------------------
def load_flow_surface():
    """The drone's flow model over the vehicle, from ~flow_surface (config/flow_surface_<vehicle>.yaml)."""
    return FlowSurface(load_params(FlowSurfaceParams, check=True, namespace="~flow_surface"))


class EstimatorNode:
    """drone_estimator, driven by its callbacks alone; a ~reset replaces it with a new one (ResettableNode)."""

    def __init__(self):
        self.params = load_params(EstimatorParams, exclude=("flow_surface",))
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
        self.handles.subscriber("ardrone/navdata", Navdata, self.on_navdata, queue_size=20, tcp_nodelay=True)
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
        problem = header_problem(msg, WORLD_FRAMES[:1]) or numbers_problem(MAX_SPEED_MPS, velocity=(v.x, v.y))
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
            return self.rejections.reject("ardrone/navdata", problem)
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
        problem = header_problem(msg, WORLD_FRAMES[:1]) or numbers_problem(MAX_POSITION_M, position=(p.x, p.y, p.z))
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


# ------------------------------------------------------------------------------------------------
def build_prediction(path, odom):
    """PadPrediction from the latest kalman_prediction_path ``(times, positions)`` and
    kalman_platform_odom ``(stamp, position, velocity)``: the path gives the positions and the odom
    the velocity; either alone when the other is missing, or the odom alone when the path is older
    than it by more than 0.2 s (the predictor stopped publishing paths). None when neither exists."""
    if path is not None and (odom is None or odom[0] <= path[0][0] + 0.2):
        times, positions = path
        if odom is not None and abs(odom[0] - times[0]) < 0.5:
            velocity = odom[2]
        elif len(times) > 1:
            velocity = [(b - a) / (times[1] - times[0]) for a, b in zip(positions[0], positions[1])]
        else:
            velocity = (0.0, 0.0, 0.0)
        return PadPrediction(times[0], positions[0], velocity, times, positions)
    if odom is not None:
        return PadPrediction(odom[0], odom[1], odom[2])
    return None


class TrackingNode:
    """platform_tracking: ``tick()`` steps the state machine at ``rate_hz`` (sim time; ResettableNode drives it and
    replaces the object at a ~reset); the callbacks only store their inputs."""

    def __init__(self):
        self.params = load_params(TrackingParams, check=True)
        self.rate_hz = self.params.rate_hz
        self.lock = threading.Lock()
        self.rejections = RosRejectionLog(WARN_PERIOD)  # garbage: what was wrong, once per topic and kind
        self.machine = TrackingStateMachine(self.params,
                                            logger=lambda line: rospy.loginfo("platform_tracking: %s", line))
        self.estimate = None          # (stamp, DroneState without sonar)
        self.unseen = None            # (stamp, world xy, weight) of the vehicle's velocity the flow does not see
        self.flow_weight = WeightForecast()
        self.sonar = None             # median of the last three sonar ranges (a spurious echo is one of them), or None
        self.sonar_ranges = collections.deque(maxlen=3)
        self.navdata_state = None
        self.path = None              # (times, positions) of the latest kalman_prediction_path
        self.pad_odom = None          # (stamp, position, velocity) of the latest kalman_platform_odom
        self.prediction = None        # PadPrediction built from the two, cached until one changes
        self.requests = []            # operator requests since the last step, in arrival order
        self.landing_allowed = True
        self.seen_at = None           # when the latest pad detection arrived (sim time; its image is older)
        self.camera_latency = CameraLatency(DELAY_SAMPLES, LATENCY_PERIOD)  # of the detections' arrival
        # A latency due for platform_tracking/camera_latency, published by the next tick: a callback publishing it
        # while a reset builds the next object would latch the old scenario's value again.
        self.latency_due = None
        self.last_tick = None         # ROS time of the latest tick: a jump back starts the state machine over
        self.estimates = StateHistory(ESTIMATE_HISTORY, keep=2)  # odom_estimate's xy, to place fixes at their stamp
        self.relative = RelativeTrack(self.params.relative_fix_gain, self.params.relative_max_age,
                                      flow_lag=self.params.flow_time_lead)
        self.me = rospy.get_caller_id()
        self.lockstep = LockstepAcker(period=1.0 / self.params.rate_hz)

        self.pub_cmd = direct_publisher("ardrone/cmd_vel", Twist)
        self.pub_takeoff = rospy.Publisher("ardrone/takeoff", Empty, queue_size=1)
        self.pub_land = rospy.Publisher("ardrone/land", Empty, queue_size=1)
        self.handles = NodeHandles()  # its subscribers and latched publishers, let go of at a reset
        self.pub_state = self.handles.latched(rospy.Publisher("platform_tracking/state", String, queue_size=1,
                                                              latch=True))
        self.pub_target = direct_publisher("platform_tracking/target", PointStamped)
        # What the link costs, for the operator and the bag: the along-track gain is bounded by it.
        self.pub_latency = self.handles.latched(rospy.Publisher("platform_tracking/camera_latency", Float64,
                                                                queue_size=1, latch=True))
        subscribe = self.handles.subscriber
        subscribe("ardrone/odom_estimate", Odometry, self.on_estimate, queue_size=5, tcp_nodelay=True)
        subscribe("kalman_prediction_path", Path, self.on_path, queue_size=5, tcp_nodelay=True)
        subscribe("kalman_platform_odom", Odometry, self.on_pad_odom, queue_size=5, tcp_nodelay=True)
        subscribe("ardrone/navdata", Navdata, self.on_navdata, queue_size=5, tcp_nodelay=True)
        subscribe("ardrone/flow_unseen_velocity", Vector3Stamped, self.on_unseen, queue_size=5, tcp_nodelay=True)
        subscribe("ardrone/sonar_height", Range, self.on_sonar, queue_size=5, tcp_nodelay=True)
        subscribe("landing_allowed", Bool, self.on_landing_allowed, queue_size=5)
        subscribe("platform/current_platform_position_in_ardrone", PointStamped, self.on_detection, queue_size=5,
                  tcp_nodelay=True)
        subscribe("platform/current_platform_position_in_world", PointStamped, self.on_world_fix, queue_size=5,
                  tcp_nodelay=True)
        subscribe("platform_tracking/command", String, self.on_command, queue_size=10, commands=True)
        subscribe("ardrone/takeoff", Empty, lambda m: self.on_thesis_request(m, "takeoff"), queue_size=5)
        subscribe("ardrone/land", Empty, lambda m: self.on_thesis_request(m, "land"), queue_size=5)
        subscribe("ardrone/force_land", Empty, lambda m: self.on_thesis_request(m, "force_land"), queue_size=5)
        if self.params.autostart:
            with self.lock:
                self.requests.append("takeoff")  # taken by the first tick, once the clock runs
        self.pub_state.publish(String(data=self.machine.state.value))

    # ----- inputs ------------------------------------------------------------------------------
    def on_estimate(self, msg):
        p, v, q = msg.pose.pose.position, msg.twist.twist.linear, msg.pose.pose.orientation
        problem = odometry_problem(msg) or numbers_problem(1.5, orientation=(q.w, q.x, q.y, q.z))
        if problem:
            return self.rejections.reject("ardrone/odom_estimate", problem)
        state = DroneState.from_attitude((p.x, p.y, p.z), (v.x, v.y, v.z), (q.w, q.x, q.y, q.z))
        stamp = stamp_of(msg)
        with self.lock:
            self.estimate = (stamp, state)
            self.estimates.add(stamp, state.position[:2].copy(), state.velocity[:2].copy())

    def _estimate_at(self, t):
        """(position, velocity) of the drone's estimate at ``t`` (lock held), or None out of reach."""
        return self.estimates.at(t, max_extrapolation=ESTIMATE_EXTRAPOLATION)

    def on_unseen(self, msg):
        problem = numbers_problem(MAX_SPEED_MPS, vector=(msg.vector.x, msg.vector.y)) or \
            header_problem(msg, WORLD_FRAMES[:1])
        if problem:
            return self.rejections.reject("ardrone/flow_unseen_velocity", problem)
        with self.lock:
            self.unseen = (stamp_of(msg), np.array([msg.vector.x, msg.vector.y]),
                           float(msg.vector.z) if math.isfinite(msg.vector.z) else 0.0)
            self.flow_weight.add(self.unseen[0], self.unseen[2])
            # What the flow itself measured: the estimate's velocity less the part of the vehicle's it did not see.
            drone = self._estimate_at(self.unseen[0])
            if drone is not None:
                pad = self._pad_prediction()
                pad_velocity = np.zeros(2) if pad is None else pad.velocity[:2]
                # Only the flow's share of the vehicle's acceleration counts: none (and no path look-up) at weight 0.
                pad_acceleration = np.zeros(2) if pad is None or self.unseen[2] <= 0.0 else \
                    pad.acceleration_at(self.unseen[0])[:2]
                self.relative.add_motion(self.unseen[0], drone[1] - self.unseen[1], self.unseen[2], pad_velocity,
                                         pad_acceleration)

    def on_world_fix(self, msg):
        """The camera's fix of the pad in the world, placed with the drone's estimate at the image's capture time:
        less that estimate, the pad relative to the drone then (relative.py)."""
        fix = world_fix(msg, self.rejections)
        if fix:
            with self.lock:
                drone = self._estimate_at(fix[0])
                if drone is not None:
                    self.relative.add_fix(fix[0], fix[1] - drone[0])

    def on_path(self, msg):
        problem = header_problem(msg, WORLD_FRAMES[:1])
        if problem:
            return self.rejections.reject("kalman_prediction_path", problem)
        if not msg.poses:
            return self.rejections.reject("kalman_prediction_path", ("empty", "a path without poses"))
        positions = [(s.pose.position.x, s.pose.position.y, s.pose.position.z) for s in msg.poses]
        problem = numbers_problem(MAX_POSITION_M, position=[c for xyz in positions for c in xyz])
        if problem:
            return self.rejections.reject("kalman_prediction_path", problem)
        times = [s.header.stamp.to_sec() for s in msg.poses]
        if all(t == 0.0 for t in times):
            # Without per-pose times only the first pose (stamped with the message) can be used.
            rospy.logwarn_throttle(WARN_PERIOD * 6, "%s: poses are not stamped with their future times; "
                                   "using only the first" % rospy.resolve_name("kalman_prediction_path"))
            times, positions = [stamp_of(msg)], positions[:1]
        elif any(b <= a for a, b in zip(times, times[1:])) or \
                stamp_problem(times[0], rospy.get_time()):  # the first pose is now (conventions.md)
            # Which pose is when is unknown: using any would put the pad seconds away from where it is.
            return self.rejections.reject("kalman_prediction_path", (
                "malformed", "pose times %s are not now and on into the future" % ", ".join(
                    "%.2f" % t for t in times[:4])))
        with self.lock:
            self.path = (times, positions)
            self.prediction = None

    def on_pad_odom(self, msg):
        pad = pad_odometry(msg, self.rejections)
        if pad:
            with self.lock:
                self.pad_odom = pad
                self.prediction = None

    def on_navdata(self, msg):
        problem = choice_problem(msg.state, NAVDATA_STATES, "state") or header_problem(msg)
        if problem:
            return self.rejections.reject("ardrone/navdata", problem)
        with self.lock:
            self.navdata_state = int(msg.state)

    def on_sonar(self, msg):
        problem = sonar_problem(msg, BODY_FRAME)
        if problem:
            return self.rejections.reject("ardrone/sonar_height", problem)
        valid = math.isfinite(msg.range) and (msg.range < msg.max_range if msg.max_range > 0 else True)
        with self.lock:
            self.sonar_ranges.append(float(msg.range) if valid else math.inf)
            median = sorted(self.sonar_ranges)[len(self.sonar_ranges) // 2]
            self.sonar = median if math.isfinite(median) else None

    def on_detection(self, msg):
        # When it arrived, not when its image was taken: frames come 0.1-0.2 s late on a real link, and
        # "seen" means the camera is still finding the pad (the prediction makes up for the delay). Garbage is
        # no sighting.
        p = msg.point
        problem = numbers_problem(MAX_ALTITUDE_M, point=(p.x, p.y, p.z)) or header_problem(msg, (BODY_FRAME,))
        if problem:
            return self.rejections.reject("platform/current_platform_position_in_ardrone", problem)
        with self.lock:
            self.seen_at = rospy.get_time()
            self.camera_latency.add(self.seen_at, msg.header.stamp.to_sec())
            if self.camera_latency.report_due(self.seen_at):
                self.latency_due = self.camera_latency.value

    def on_landing_allowed(self, msg):
        with self.lock:
            if bool(msg.data) != self.landing_allowed:
                rospy.loginfo("platform_tracking: landing_allowed = %s", bool(msg.data))
            self.landing_allowed = bool(msg.data)

    def on_command(self, msg):
        command = msg.data.strip().lower()
        problem = choice_problem(command, COMMANDS, "command")
        if problem:
            return self.rejections.reject("platform_tracking/command", problem)
        with self.lock:
            self.requests.append(command)

    def on_thesis_request(self, msg, command):
        header = getattr(msg, "_connection_header", None) or {}
        if header.get("callerid") == self.me:
            return  # our own take-off/land action coming back
        with self.lock:
            self.requests.append(command)

    # ----- the step ----------------------------------------------------------------------------
    def _pad_prediction(self):
        if self.prediction is None:
            self.prediction = build_prediction(self.path, self.pad_odom)
        return self.prediction

    def _take_requests(self):
        """The operator requests since the last step (lock held), in order; a hold voids those before it and any
        take-off or land the state machine still had pending."""
        requests, self.requests = self.requests, []
        if "hold" in requests:
            self.machine.hold()
            requests = requests[len(requests) - requests[::-1].index("hold"):]
        return requests

    def tick(self):
        """One step at the present ROS time; a jump back in time (a new simulation, a bag loop) starts the state
        machine over first."""
        now = rospy.Time.now()
        if self.last_tick is not None and now < self.last_tick:
            self._start_over()
        self.last_tick = now
        self.step(now)

    def _start_over(self):
        rospy.logwarn("platform_tracking: time moved backwards; the state machine starts over")
        with self.lock:
            self.machine = TrackingStateMachine(self.params, self.machine.logger)
            self.estimate = self.path = self.pad_odom = self.prediction = None
            self.estimates.clear()
            self.relative.reset()
        self.pub_state.publish(String(data=State.LANDED.value))

    def step(self, now):
        t = now.to_sec()
        with self.lock:
            latency, self.latency_due = self.latency_due, None
            drone = None
            if self.estimate is not None and t - self.estimate[0] <= ESTIMATE_MAX_AGE:
                state = self.estimate[1]
                drone = dataclasses.replace(state, sonar_height=self.sonar).moved(t - self.estimate[0])
            fresh = self.unseen is not None and t - self.unseen[0] <= ESTIMATE_MAX_AGE
            # The weight when the command reaches the drone: a navdata old now, and a link's delay later.
            flow_weight = self.flow_weight.at(t + self.params.flow_weight_lead) if fresh else 0.0
            requests = self._take_requests()
            inputs = Inputs(t, drone, self._pad_prediction(), self.navdata_state,
                            takeoff="takeoff" in requests, land="land" in requests,
                            force_land="force_land" in requests, landing_allowed=self.landing_allowed,
                            vision_age=None if self.seen_at is None else t - self.seen_at, flow_weight=flow_weight,
                            camera_latency=self.camera_latency.value, relative=self.relative.at(t))
        if latency is not None:
            self.pub_latency.publish(Float64(data=latency))
        before = self.machine.state
        out = self.machine.step(inputs)
        if out.send_takeoff:
            self.pub_takeoff.publish(Empty())
        if out.send_land:
            self.pub_land.publish(Empty())
        if out.command is not None:
            command = out.command
            twist = Twist()
            twist.linear.x, twist.linear.y, twist.linear.z = command.vx, command.vy, command.vz
            twist.angular.z = command.yaw_rate
            self.pub_cmd.publish(twist)
        if out.state != before:
            self.pub_state.publish(String(data=out.state.value))
        if out.target is not None:
            target = PointStamped()
            target.header.stamp, target.header.frame_id = now, "world"
            target.point.x, target.point.y, target.point.z = (float(v) for v in out.target)
            self.pub_target.publish(target)
        self.lockstep.ack(now)


def tracking_main():
    return run_node("platform_tracking", TrackingNode, startup_errors=(ParamError,), resettable=True)
