"""The tracker's thin ROS node; all logic lives in state_machine.py and controller.py (ROS-free). The drone's own
estimate (ardrone/odom_estimate, ardrone/flow_unseen_velocity) comes from the package drone_estimator.

platform_tracking ardrone/odom_estimate, kalman_prediction_path, kalman_platform_odom, drone/navdata,
                 ardrone/sonar_height, ardrone/flow_unseen_velocity, platform/current_platform_position_in_ardrone
                 (only when it arrives: the pad was seen) and ..._in_world (the pad relative to the drone, carried on
                 by the flow: drone_estimator.relative), landing_allowed (std_msgs/Bool, default true) and the
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

Restart and reset: respawned after a crash, the tracker starts again from the latched platform_tracking/command and
the drone's navdata state (nothing else is kept). It offers ``~reset`` (std_srvs/Trigger,
landing_runtime.rospy_node.ResettableNode) for the next scenario of a warm graph: the parameters are read again as
at start-up (a bad one refuses the reset, naming it; the node goes on as it was) and the node starts over as a
fresh one: LANDED with no request pending (``autostart`` takes off again), its latched platform_tracking/state
LANDED again and no camera_latency latched until it measures one.

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
from drone_estimator.estimator import StateHistory
from drone_estimator.flow_surface import WeightForecast
from drone_estimator.pad_inputs import ESTIMATE_EXTRAPOLATION, ESTIMATE_HISTORY, pad_odometry, world_fix
from drone_estimator.relative import RelativeTrack
from geometry_msgs.msg import PointStamped, Twist, Vector3Stamped
from landing_msgs.msg import Navdata, PreflightStatus
from landing_runtime.input_check import (MAX_ALTITUDE_M, MAX_POSITION_M, MAX_SPEED_MPS, RosRejectionLog,
                                         choice_problem, numbers_problem, stamp_problem)
from landing_runtime.lockstep import LockstepAcker
from landing_runtime.message_check import WORLD_FRAME, header_problem, odometry_problem, sonar_problem, stamp_of
from landing_runtime.message_constants import message_constants
from landing_runtime.params import ParamError, load_params
from landing_runtime.rospy_node import NodeHandles, direct_publisher, run_node
from nav_msgs.msg import Odometry, Path
from sensor_msgs.msg import Range
from std_msgs.msg import Bool, Empty, Float64, String

from .camera_latency import CameraLatency
from .controller import DroneState, PadPrediction
from .params import TrackingParams
from .state_machine import Inputs, State, TrackingStateMachine

WARN_PERIOD = 5.0          # throttle of repeated input warnings [s]
CONFIG = "platform_tracking/config/"  # where the shipped parameter file is, for the messages naming a bad one
ESTIMATE_MAX_AGE = 0.5     # an odom_estimate older than this counts as no estimate [s]
DELAY_SAMPLES = 15         # detections whose arrival-minus-capture median is the camera latency [-]
LATENCY_PERIOD = 1.0       # how often that latency is published on platform_tracking/camera_latency [s of sim time]
COMMANDS = ("takeoff", "land", "force_land", "hold")
BODY_FRAME = "ardrone/base_link"  # the drone's body frame (docs/conventions.md): sonar and relative pad positions


NAVDATA_STATES = message_constants(Navdata, "STATE_")  # the navdata state codes the message defines
NO_PREFLIGHT = "no pre-flight check heard (start interface's preflight node)"


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
        self.params = load_params(TrackingParams, check=True, see=CONFIG)
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
        # With require_preflight, a take-off waits for the pre-flight check's word (none heard: it waits too).
        self.preflight_blocks = NO_PREFLIGHT if self.params.require_preflight else None
        self.preflight_heard_at = None  # when its latest verdict arrived (sim time)
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
        subscribe("drone/navdata", Navdata, self.on_navdata, queue_size=5, tcp_nodelay=True)
        subscribe("ardrone/flow_unseen_velocity", Vector3Stamped, self.on_unseen, queue_size=5, tcp_nodelay=True)
        subscribe("ardrone/sonar_height", Range, self.on_sonar, queue_size=5, tcp_nodelay=True)
        subscribe("landing_allowed", Bool, self.on_landing_allowed, queue_size=5)
        if self.params.require_preflight:
            subscribe("preflight/status", PreflightStatus, self.on_preflight, queue_size=1)
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
            header_problem(msg, (WORLD_FRAME,))
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
        less that estimate, the pad relative to the drone then (drone_estimator.relative)."""
        fix = world_fix(msg, self.rejections)
        if fix:
            with self.lock:
                drone = self._estimate_at(fix[0])
                if drone is not None:
                    self.relative.add_fix(fix[0], fix[1] - drone[0])

    def on_path(self, msg):
        problem = header_problem(msg, (WORLD_FRAME,))
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
            return self.rejections.reject("drone/navdata", problem)
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

    def on_preflight(self, msg):
        problem = header_problem(msg, ("",))
        if problem:
            return self.rejections.reject("preflight/status", problem)
        with self.lock:
            self.preflight_heard_at = rospy.get_time()
            self.preflight_blocks = None if msg.ready else "; ".join(
                line for line in msg.items if not line.endswith(": ok")) or "not ready"

    def _takeoff_blocked(self, t):
        """Why a take-off must wait for the pre-flight check (None: it may go): its latest verdict, unless that
        is older than preflight_max_age (the check's node died: its last word no longer holds)."""
        if not self.params.require_preflight:
            return None
        if self.preflight_heard_at is None:
            return NO_PREFLIGHT
        age = t - self.preflight_heard_at
        if age > self.params.preflight_max_age:
            return "the pre-flight check's latest verdict is %.1f s old (is interface's preflight node running?)" % age
        return self.preflight_blocks

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
                            takeoff_blocked=self._takeoff_blocked(t),
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
