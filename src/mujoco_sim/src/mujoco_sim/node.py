"""ROS wrapper of the simulator: parameters in, commands in, /clock, sensors, ground truth and tf out.

All stamps are sim time computed here (this node is the clock source), so it never waits on /clock.
What the drone sends (camera frames; navdata with the IMU and sonar; GPS; and the vehicle's GPS) is
stamped when it is measured and published once its link's latency has passed, or never if the link
loses it (the realism profile, realism.py); the resolved profile is on ~realism_in_force.
"""
import copy
import json
import math
import os
import queue
import sys
import threading
import time

import rosgraph
import rospy
import tf2_ros
from geometry_msgs.msg import PoseStamped, TransformStamped, Twist
from landing_runtime.geometry import euler_from_quaternion
from landing_runtime.input_check import RosRejectionLog
from landing_msgs.msg import Altimeter, LockstepAck, Navdata, Touchdown
from landing_runtime.rospy_node import ended_by_shutdown, init_node, without_nagle
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from rospy.impl.paramserver import get_param_server_cache
from sensor_msgs.msg import CameraInfo, Image, Imu, JointState, Range
from std_msgs.msg import Empty, Header, String
from std_srvs.srv import Trigger, TriggerResponse
from tf2_msgs.msg import TFMessage

from .ardrone_driver_node import EmulatedArdroneDriver
from .gps_receiver import GpsReceiver
from .autopilot import FlightMode
from .config import ConfigError
from .frame_renderer import DeliveredFrames
from .lockstep import LockstepGate
from .schema import SIM_SCHEMA, validate_sim_config
from .schedule import Schedule
from .scheduling import fifo_priority, stepping_priority, thread_cpu_and_wait
from .simulator import SONAR_FIELD_OF_VIEW_RAD, Simulator
from .vehicle_odometry import VehicleOdometry

NAVDATA_STATE = {FlightMode.LANDED: Navdata.STATE_LANDED, FlightMode.TAKING_OFF: Navdata.STATE_TAKING_OFF,
                 FlightMode.FLYING: Navdata.STATE_FLYING, FlightMode.LANDING: Navdata.STATE_LANDING,
                 FlightMode.CRASHED: Navdata.STATE_CRASHED}
_NOTHING = object()
RESET_TIMEOUT_S = 60.0  # how long a reset_world caller waits for the loop to take it (wall) [s]
WHEEL_JOINTS = ["summit_xl_front_left_wheel_joint", "summit_xl_front_right_wheel_joint",
                "summit_xl_back_left_wheel_joint", "summit_xl_back_right_wheel_joint"]
# Global condition parameters (thesis names) that change the simulated world, with their checks.
CONDITION_PARAMS = {name: SIM_SCHEMA["conditions"][name] for name in
                    ("wind_speed", "wind_direction_deg", "wind_gust", "temp", "drone_battery")}


def _quaternion_msg(target, quat_wxyz):
    target.w, target.x, target.y, target.z = (float(v) for v in quat_wxyz)


def _yaw_quaternion(yaw):
    return (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))


class SimNode:
    def __init__(self):
        # ROS time of the world's time 0 [s]: 0 until a reset_world, which starts a new world where ROS time
        # stands (ROS time never runs backwards; the world's own time, and everything seeded, starts afresh).
        self.time_origin = 0.0
        self.model_file, self.viewer_requested, self.wait_for_start, self.cfg = self._read_parameters()
        # Woken by the start signal and by a reset_world request (the physics may be held for either).
        self.wake = threading.Event()
        self.start_received = False
        self.reset_requests = queue.SimpleQueue()
        self.rejections = RosRejectionLog()  # garbage on the inputs: what was wrong, once per topic and kind
        self.conditions = {}
        self.rejected = {}  # condition -> the operator's invalid value, left in place and ignored
        self.lockstep_subscriber = None
        self.scheduling_noted = _NOTHING  # the stepping thread's scheduling, as last logged (_note_scheduling)
        self._build_world()
        self._init_publishers()
        self._announce_world()
        self._init_subscribers()
        rospy.Service("~reset_world", Trigger, self._on_reset_world)

    @staticmethod
    def _read_parameters():
        """(model file, viewer, wait_for_start, validated configuration) from the private parameters."""
        private = rospy.get_param("~", {})
        model_file = private.pop("model_file", None)
        if not model_file:
            raise ConfigError("sim_node: required parameter '~model_file' (path of the MJCF world) is not set")
        viewer = bool(private.pop("viewer", False))
        # A scenario runner starts the physics only once the whole graph (recorder included) listens.
        wait_for_start = bool(private.pop("wait_for_start", False))
        private.pop("realism_in_force", None)  # ours, written below (a reset reads the parameters again)
        return model_file, viewer, wait_for_start, validate_sim_config(
            private, "sim_node private parameters (%s)" % rospy.get_name())

    def _build_world(self, sim=None):
        """The world of the parameters in force (``sim``, or a Simulator of them), at its time 0: what a fresh start
        builds."""
        self.sim = sim or Simulator(self.cfg, self.model_file, self.cfg["vehicle"], self.cfg["seed"])
        self.actions = queue.SimpleQueue()
        lockstep = self.cfg["lockstep"]
        self.lockstep = LockstepGate(lockstep["max_lead_s"], lockstep["stale_after_wall_s"], log=rospy.loginfo) \
            if lockstep["enabled"] else None
        self._init_conditions()
        rates = self.cfg["rates"]
        self.schedules = {name: Schedule(rates[name + "_hz"]) for name in (
            "clock", "ground_truth", "sonar", "altimeter", "gps", "joint_states", "tf", "conditions")}
        realism = self.cfg["realism"]["values"]
        self.schedules["imu"] = Schedule(realism["navdata_rate_hz"])
        self.schedules["navdata"] = Schedule(realism["navdata_rate_hz"])
        # Links of what the drone sends, in the order they are released within a step.
        self.links = (self.sim.navdata_link, self.sim.gps_link, self.sim.camera_link)
        rospy.set_param("~realism_in_force", dict(realism, profile=self.cfg["realism"]["profile"]))
        rospy.loginfo("realism profile %s: %s", self.cfg["realism"]["profile"], json.dumps(realism))
        self.schedules["camera"] = Schedule(self.cfg["camera"]["rate_hz"])
        self.schedules["vehicle_gps"] = Schedule(self.sim.vehicle_cfg["gps_rate_hz"])
        self.schedules["vehicle_odom"] = Schedule(self.sim.vehicle_cfg["odom_rate_hz"])
        n = self.cfg["noise"]
        self.vehicle_odometry = VehicleOdometry(lambda std: self.sim._noise("vehicle_odom", std), n["vehicle_speed_std"],
                                                math.radians(n["vehicle_heading_std_deg"]), n["vehicle_yaw_rate_std"])
        self.schedules["stats"] = Schedule(0.2)
        self.next_scheduled = 0.0  # the earliest time a schedule is due [sim s]
        self.viewer_schedule = Schedule(30.0)
        self.last_touchdown = None
        self.delivered_frames = DeliveredFrames()
        self.timing = {"physics": 0.0, "render": 0.0, "publish": 0.0, "pacing": 0.0, "lockstep": 0.0}
        # CPU time of the stepping thread (its own, whatever else the machine runs) in the physics step and in
        # publishing, and of the whole process [s]: the publishing part is what the graph's subscribers cost it.
        self.cpu = {"physics": 0.0, "publish": 0.0}
        self.cpu_start = (time.thread_time(), time.process_time())

    def _now(self):
        """ROS time of the world's present [s]."""
        return self.time_origin + self.sim.time

    def _init_conditions(self):
        """Start from the global parameters where they are set and valid, else publish ours."""
        start = self.cfg["conditions"]
        if self.conditions and _master_param("/drone_battery") == self.battery_written:
            # A reset: the parameter holds our mirror of the drained battery, not an operator's level.
            rospy.set_param("/drone_battery", self.start_battery)
        for name, spec in CONDITION_PARAMS.items():
            value = start[name]
            raw = _condition_anew(name)
            if raw is not _NOTHING:
                value = self._checked_condition(name, raw, value)
            self.conditions[name] = value
            rospy.set_param("/" + name, value)
        self._apply_conditions()
        self.battery_written = self.start_battery = self.conditions["drone_battery"]
        self.rejected.clear()

    def _checked_condition(self, name, raw, fallback):
        try:
            return CONDITION_PARAMS[name].check(raw, "parameter /%s" % name)
        except ConfigError as err:
            rospy.logwarn("rejected %s; the simulated world keeps %s. Set a valid value with e.g. "
                          "'rosparam set /%s %s'.", err, fallback, name, fallback)
            return fallback

    def _apply_conditions(self):
        c = self.conditions
        self.sim.set_conditions(wind_speed=c["wind_speed"], wind_direction_deg=c["wind_direction_deg"],
                                gust_mps=c["wind_gust"], temp=c["temp"], battery=c["drone_battery"])

    def _init_publishers(self):
        # Small messages are written synchronously: rospy's queued publishers hand every message to a
        # writer thread per connection, and that hand-off costs more than the socket write itself. None of them
        # waits for Nagle's algorithm (without_nagle): rospy's and roscpp's own /clock subscriptions do not ask for
        # TCP_NODELAY, and a tick then waited for the ACK of the one before (delayed by up to 40 ms).
        def pub(topic, kind, size=None, latch=False):
            return without_nagle(rospy.Publisher(topic, kind, queue_size=size, latch=latch))
        self.pub_clock = pub("/clock", Clock)
        self.pub_image = pub("ardrone/bottom/image_raw", Image, 2)
        self.pub_info = pub("ardrone/bottom/camera_info", CameraInfo)
        # drone_model px4_quad: MAVROS's topics and services instead of ardrone/* (mavros_driver_node); its IMU is
        # mavros/imu/data.
        self.mavros = _emulated_mavros(self, pub) if self.sim.px4 else None
        self.pub_imu = None if self.sim.px4 else pub("ardrone/imu", Imu)
        # The AR.Drone's driver (drone_model ardrone2) has navdata of its own: the stack's adapter makes the sonar
        # height, the altimeter and drone/navdata of it. The velocity-commanded drone speaks the stack's types.
        self.ardrone_driver = EmulatedArdroneDriver(self, pub) if self.sim.ardrone else None
        own = not (self.sim.ardrone or self.sim.px4)  # the velocity-commanded drone's own topics
        self.pub_sonar = pub("ardrone/sonar_height", Range) if own else None
        self.pub_altimeter = pub("ardrone/altimeter", Altimeter) if own else None
        self.pub_gt_altitude = pub("ardrone/groundtruth_altitude", Altimeter)
        self.pub_gt_state = pub("ardrone/ground_truth/state", Odometry)
        # The drone's GPS: the AR.Drone carries a receiver of its own (its driver publishes none), which reports as a
        # receiver's driver does (nmea_navsat_driver: NavSatFix and an ENU TwistStamped); the velocity-commanded drone
        # speaks the stack's local odometry.
        self.gps_receiver = GpsReceiver(pub, "ardrone/gps", "ardrone/base_link") if self.sim.ardrone else None
        self.pub_gps = pub("ardrone/gps/odom", Odometry) if own else None
        self.pub_navdata = pub("drone/navdata", Navdata) if own else None
        self.pub_touchdown = pub("ardrone/touchdown", Touchdown, 10, latch=True)
        self.pub_gt_drone = pub("groundtruth/ardrone", PoseStamped)
        self.pub_gt_summit = pub("groundtruth/summit", PoseStamped)
        self.pub_gt_pad = pub("groundtruth/landing_pad", PoseStamped)
        self.pub_joints = pub("summit_xl/joint_states", JointState)
        # The vehicle as its real drivers report it: a GPS receiver (NavSatFix and ENU TwistStamped, through the GPS
        # link) and its controller's odometry (Robotnik's robotnik_base_control/odom, wired on board: no link). The
        # stack's summit_moves/vehicle_report makes summit_xl/gps/odom of them.
        self.vehicle_gps_receiver = GpsReceiver(pub, "summit_xl/gps", "summit_xl/base_link")
        self.pub_vehicle_odom = pub("robotnik_base_control/odom", Odometry)
        self.pub_stats = pub("sim_stats", String, 1, latch=True)
        self.pub_tf = pub("/tf", TFMessage)  # (tf2_ros.TransformBroadcaster's publisher is a queued one)
        self.static_tf = tf2_ros.StaticTransformBroadcaster()
        self.ground_truth_messages = {
            "state": Odometry(header=Header(frame_id="world"), child_frame_id="ardrone/base_link"),
            "drone": PoseStamped(header=Header(frame_id="world")), "vehicle": PoseStamped(header=Header(frame_id="world")),
            "pad": PoseStamped(header=Header(frame_id="world"))}
        self.tf_message = TFMessage(transforms=[
            self._transform("world", "ardrone/base_link", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0), None),
            self._transform("world", "summit_xl/base_link", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0), None)])

    def _announce_world(self):
        """The world's fixed transforms (latched) and its camera's calibration."""
        camera_position, _ = self.sim.camera_pose_in_body()
        pad_offset = self.sim.pad_offset_in_vehicle()
        self.static_tf.sendTransform([
            self._transform("ardrone/base_link", "ardrone/bottom_camera", camera_position,
                            (0.0, math.sqrt(0.5), -math.sqrt(0.5), 0.0), 0.0),
            self._transform("summit_xl/base_link", "landing_pad", pad_offset, (1.0, 0.0, 0.0, 0.0), 0.0)])
        width, height, fx, fy, cx, cy = self.sim.camera_intrinsics()
        self.camera_info = CameraInfo(width=width, height=height, distortion_model="plumb_bob",
                                      D=self.sim.camera_distortion(), K=[fx, 0, cx, 0, fy, cy, 0, 0, 1],
                                      R=[1, 0, 0, 0, 1, 0, 0, 0, 1], P=[fx, 0, cx, 0, 0, fy, cy, 0, 0, 0, 1, 0])
        self.camera_info.header.frame_id = "ardrone/bottom_camera"

    def _init_subscribers(self):
        if not (self.sim.ardrone or self.sim.px4):  # (the AR.Drone's driver takes cmd_vel: EmulatedArdroneDriver)
            rospy.Subscriber("ardrone/cmd_vel", Twist, self._on_cmd_vel, queue_size=1, tcp_nodelay=True)
        rospy.Subscriber("robotnik_base_control/cmd_vel", Twist, self._on_vehicle_cmd, queue_size=1)
        if not self.sim.px4:  # (PX4 takes off and lands through MAVROS's services)
            rospy.Subscriber("ardrone/takeoff", Empty, lambda _: self.actions.put(self.sim.takeoff), queue_size=5)
            rospy.Subscriber("ardrone/land", Empty, lambda _: self.actions.put(self.sim.land), queue_size=5)
        rospy.Subscriber("ardrone/reset", Empty, lambda _: self.actions.put(self.sim.reset), queue_size=5)
        rospy.Subscriber("mujoco_sim/start", Empty, self._on_start, queue_size=1)
        rospy.Subscriber("mujoco_sim/hold", Empty, self._on_hold, queue_size=1)
        rospy.Subscriber("mujoco_sim/fault", String, self._on_fault, queue_size=10)
        self._listen_to_acknowledgements()

    def _listen_to_acknowledgements(self):
        """Subscribe to lockstep_ack while the gate is enabled (the acknowledging nodes publish at their rate)."""
        if self.lockstep is not None and self.lockstep_subscriber is None:
            self.lockstep_subscriber = rospy.Subscriber("lockstep_ack", LockstepAck, self._on_lockstep_ack,
                                                        queue_size=100, tcp_nodelay=True)
        elif self.lockstep is None and self.lockstep_subscriber is not None:
            self.lockstep_subscriber.unregister()
            self.lockstep_subscriber = None

    def _on_start(self, _msg):
        self.start_received = True
        self.wake.set()

    def _on_hold(self, _msg):
        """mujoco_sim/hold (with wait_for_start): hold the physics and the clock after the present step, until the
        next mujoco_sim/start. A warm graph's runner holds the world once a flight is over, so that the graph stops
        working while the flight's recorder stops (docs/warm_graph.md)."""
        if self.wait_for_start:
            self.start_received = False

    def _on_reset_world(self, _request):
        """~reset_world (std_srvs/Trigger): served by the loop between two physics steps; the caller waits."""
        request = {"done": threading.Event(), "success": False, "message": ""}
        self.reset_requests.put(request)
        self.wake.set()
        if not request["done"].wait(RESET_TIMEOUT_S):
            return TriggerResponse(success=False, message="the simulator's loop did not take the reset within %.0f s "
                                                          "(wall); see its log" % RESET_TIMEOUT_S)
        return TriggerResponse(success=request["success"], message=request["message"])

    def _serve_reset_requests(self, stopping=False):
        """Reset the world for every pending reset_world request (one reset serves them all); refuse them when the
        node is ``stopping``."""
        requests = []
        while not self.reset_requests.empty():
            requests.append(self.reset_requests.get())
        if not requests:
            return
        if stopping:
            success, message = False, "the world was not reset: the simulator is stopping"
        else:
            try:
                success, message = True, self._reset_world()
            except ConfigError as err:
                success, message = False, "the world was not reset (it goes on as it was): %s" % err
                rospy.logerr(message)
        for request in requests:
            request.update(success=success, message=message)
            request["done"].set()

    def _reset_world(self):
        """Rebuild the world from the parameters as they are now, as a fresh start would; ROS time goes on from
        here. With wait_for_start the physics is then held for the next start signal. Returns what was done."""
        # A bad parameter or model file raises here, before anything has changed.
        model_file, viewer, wait_for_start, cfg = self._read_parameters()
        sim = Simulator(cfg, model_file, cfg["vehicle"], cfg["seed"])
        origin = self._now()
        self.sim.close()
        self.model_file, self.viewer_requested, self.wait_for_start, self.cfg = model_file, viewer, wait_for_start, cfg
        self.time_origin = origin
        self.start_received = False
        self._build_world(sim)
        self._announce_world()
        self._listen_to_acknowledgements()
        message = "world reset: seed %d, vehicle %s, realism %s; its time 0 is ROS time %.3f s%s" % (
            cfg["seed"], cfg["vehicle"], cfg["realism"]["profile"], origin,
            ", held until mujoco_sim/start" if wait_for_start else "")
        rospy.loginfo(message)
        return message

    def _on_lockstep_ack(self, msg):
        # An acknowledgement holds the physics: only a node's own, about a time that has been, with a sane period.
        sender = (getattr(msg, "_connection_header", None) or {}).get("callerid")
        stamp, period = msg.stamp.to_sec(), msg.period.to_sec()
        if sender is not None and msg.node != sender:
            problem = ("malformed", "node %r acknowledged as %r" % (sender, msg.node[:60]))
        elif not 0.0 <= period <= 10.0:
            problem = ("out of range", "period %.3g s outside 0..10 s" % period)
        elif stamp > self._now() + 1.0:
            problem = ("stamp from the future", "stamp %.3f s, sim time %.3f s" % (stamp, self._now()))
        else:
            gate = self.lockstep  # (None once a reset has disabled it, until this subscriber is gone)
            return gate.acknowledge(msg.node, msg.input, stamp, period) if gate is not None else None
        self.rejections.reject("lockstep_ack", problem)

    def _on_cmd_vel(self, msg):
        problem = self.sim.set_velocity_command(msg.linear.x, msg.linear.y, msg.linear.z, msg.angular.z)
        if problem:
            self.rejections.reject("ardrone/cmd_vel", ("non-finite" if "non-finite" in problem else "out of range",
                                                       "%s: the drone holds its position; send finite velocities in "
                                                       "m/s and rad/s" % problem))

    def _on_fault(self, msg):
        """JSON {"fault": "camera_blackout" | "detection_false_target", "duration_s": seconds}."""
        try:
            request = json.loads(msg.data)
            fault, duration = request["fault"], float(request.get("duration_s", 2.0))
            if not math.isfinite(duration) or duration < 0:
                raise ValueError("duration_s must be a non-negative number")
        except (ValueError, KeyError, TypeError) as err:
            rospy.logwarn("ignored mujoco_sim/fault %r: %s; expected JSON like "
                          '{"fault": "camera_blackout", "duration_s": 2.0}', msg.data, err)
            return
        self.actions.put(lambda: self.sim.inject_fault(fault, duration) or rospy.logwarn(
            "ignored unknown fault %r; known: %s", fault, ", ".join(self.sim.FAULTS)))

    def _on_vehicle_cmd(self, msg):
        problem = self.sim.set_vehicle_command(msg.linear.x, msg.angular.z)
        if problem:
            self.rejections.reject("robotnik_base_control/cmd_vel", (
                "non-finite" if "non-finite" in problem else "out of range",
                "%s: the vehicle stops; send finite speeds in m/s and rad/s" % problem))

    # ----- loop ----------------------------------------------------------------------------------
    def _wait_for_start_signal(self):
        """Hold the physics until the start signal (with wait_for_start), or a reset_world request."""
        if self.wait_for_start and not self.start_received:
            rospy.loginfo("waiting for std_msgs/Empty on mujoco_sim/start before stepping the physics")
        # Hold the clock 1 ms past the world's time 0, not at 0: nodes such as rosbag record wait for a non-zero
        # time before they subscribe. The first physics step is 4 ms, so time never runs backwards.
        waiting_clock = Clock(clock=rospy.Time.from_sec(self._now() + 0.001))
        while self.wait_for_start and not self.start_received and self.reset_requests.empty() and \
                not rospy.is_shutdown():
            self.pub_clock.publish(waiting_clock)
            self.wake.wait(0.1)
            self.wake.clear()

    def spin(self, max_sim_time=None):
        # (a stop that closes the publishers mid-publish printed a traceback at one stop in three)
        try:
            with ended_by_shutdown():
                while not rospy.is_shutdown():
                    if self.cfg["camera"]["enabled"]:
                        # Now that the node is in the graph, while the rest of the graph starts (not at the first
                        # frame of the flight, nor before this node has advertised its topics).
                        self.sim.open_camera()
                    self._wait_for_start_signal()
                    if self.reset_requests.empty() and not self._step_and_publish(max_sim_time):
                        break
                    self._serve_reset_requests()
        finally:
            self.sim.close()
            self._serve_reset_requests(stopping=True)

    def _step_and_publish(self, max_sim_time):
        """Step and publish until rospy shuts down or sim time reaches ``max_sim_time`` (False), or a reset_world
        request or a hold comes (True)."""
        rtf = self.cfg["real_time_factor"]
        wall_start, sim_start = time.monotonic(), self.sim.time
        viewer = self._open_viewer() if self.viewer_requested else None
        rospy.loginfo("simulating %s (seed %d) at %s", self.model_file, self.cfg["seed"],
                      "%gx real time" % rtf if rtf > 0 else "full speed")
        self.wall_start, self.sim_start = wall_start, sim_start
        self.stepping_sched_start = thread_cpu_and_wait()
        self.cpu = {"physics": 0.0, "publish": 0.0}  # (over the same span as the real-time factor)
        self.cpu_start = (time.thread_time(), time.process_time())
        try:
            priority, why_not = stepping_priority(self.cfg["lockstep"]["realtime_priority"], self.lockstep is not None,
                                                  rtf, os.cpu_count() or 1)
            camera = [tid for tid in (self.sim.camera_thread_id(),) if tid is not None]
            with fifo_priority(priority, other_threads=camera) as refused:
                self._note_scheduling(priority, why_not or refused)
                return self._step_until_stopped(rtf, wall_start, sim_start, max_sim_time, viewer)
        finally:
            if viewer is not None:
                viewer.close()

    def _note_scheduling(self, priority, why_not):
        if why_not != self.scheduling_noted:  # once, and again when it changes (a reset's parameters)
            self.scheduling_noted = why_not
            rospy.loginfo("stepping and rendering at %s", "SCHED_FIFO priority %d" % priority if why_not is None
                          else "normal priority: " + why_not)

    def _step_until_stopped(self, rtf, wall_start, sim_start, max_sim_time, viewer):
        """The loop of _step_and_publish (same returns)."""
        while not rospy.is_shutdown():
            if not self.reset_requests.empty() or (self.wait_for_start and not self.start_received):
                return True
            while not self.actions.empty():
                self.actions.get()()
            if self.lockstep is not None:
                self._wait_for_lagging_nodes()
            t0, c0 = time.perf_counter(), time.thread_time()
            self.sim.step()
            t1, c1 = time.perf_counter(), time.thread_time()
            self.timing["physics"] += t1 - t0
            self.cpu["physics"] += c1 - c0
            self._publish_due(self.sim.time)
            self.timing["publish"] += time.perf_counter() - t1
            self.cpu["publish"] += time.thread_time() - c1
            if rtf > 0:
                ahead = (self.sim.time - sim_start) / rtf - (time.monotonic() - wall_start)
                if ahead > 0.002:
                    time.sleep(ahead)
                    self.timing["pacing"] += ahead
            if viewer is not None and self.viewer_schedule.due(self.sim.time):
                viewer.sync()
            if max_sim_time is not None and self.sim.time >= max_sim_time:
                return False
        return False

    def _wait_for_lagging_nodes(self):
        """Lock-step: hold sim time while a node that acknowledges its work lags too far behind."""
        next_time = self._now() + self.sim.dt
        blocker = self.lockstep.blocker(next_time, time.monotonic())
        if blocker is None:
            return
        t0 = time.perf_counter()
        while blocker is not None and not rospy.is_shutdown():
            self.lockstep.acknowledged.clear()
            self.lockstep.acknowledged.wait(0.005)
            blocker = self.lockstep.blocker(next_time, time.monotonic())
        self.timing["lockstep"] += time.perf_counter() - t0

    def _open_viewer(self):
        try:
            import mujoco.viewer
            return mujoco.viewer.launch_passive(self.sim.model, self.sim.data)
        except Exception as err:  # no display, no GLFW: stay headless rather than die
            rospy.logwarn("viewer unavailable (%s); running headless", err)
            return None

    def _publish_due(self, t):
        # Most 4 ms steps publish nothing of their own (the rates are 5-60 Hz): they only release what the links
        # deliver.
        due = self._publish_measured(t) if t + 1e-9 >= self.next_scheduled else None
        if self.ardrone_driver is not None:
            self.ardrone_driver.step(t)
        if self.mavros is not None:
            self.mavros.step(t)
        for link in self.links:
            if link.pending:
                for publish in link.due(t):
                    publish()
        self.timing["render"] += self.delivered_frames.publish_ready(wait=False)
        if due is not None:
            self._publish_states(*due)
        if self.sim.touchdown is not None and self.sim.touchdown is not self.last_touchdown:
            self.last_touchdown = self.sim.touchdown
            self._publish_touchdown(self.sim.touchdown)

    def _publish_measured(self, t):
        """What the rates make due at ``t``, up to the sensors measured now (sent through their links), which go
        before the links release their earlier messages; returns (what is due, the stamp) for _publish_states."""
        due = {name: s.due(t) for name, s in self.schedules.items()}
        self.next_scheduled = min(s.next for s in self.schedules.values())
        stamp = rospy.Time.from_sec(self.time_origin + t)
        if due["clock"]:
            self.timing["render"] += self.delivered_frames.publish_ready(wait=True)  # before ROS time moves on
            self.pub_clock.publish(Clock(clock=stamp))
            rospy.rostime._set_rostime(stamp)  # this node is the clock: it does not listen to /clock
        if due["conditions"]:
            try:
                self._sync_conditions()
            except OSError as err:  # the master is gone: the world goes on with the conditions it has
                rospy.logwarn_throttle(30.0, "cannot read the condition parameters (%s): the ROS master is "
                                             "unreachable; keeping the conditions in force" % err)
        if due["camera"] and self.cfg["camera"]["enabled"] and not self.sim.camera_blacked_out() and \
                (not self.sim.ardrone or (self.sim.camera_channel.bottom_streaming and
                                          not self.sim.link_lost())) and \
                (self.pub_image.get_num_connections() or self.pub_info.get_num_connections()) and \
                not self.sim.camera_frame_lost():
            self._capture_camera(stamp)
        if due["imu"] and self.pub_imu is not None and self.pub_imu.get_num_connections() and \
                not (self.sim.ardrone and self.sim.link_lost()):
            self._send(self.sim.navdata_link, self._imu_message(stamp), self.pub_imu)
        if due["sonar"] and self.pub_sonar is not None and self.pub_sonar.get_num_connections():
            self._send(self.sim.navdata_link, self._sonar_message(stamp), self.pub_sonar)
        if due["altimeter"]:
            self._publish_altimeter(stamp)
        if due["ground_truth"]:
            self._publish_ground_truth(stamp)
        if due["gps"] and self.gps_receiver is not None:
            if not self.sim.link_lost():  # (its data rides the link)
                for message, publisher in self.gps_receiver.messages(self.sim.gps(), stamp):
                    self._send(self.sim.gps_link, message, publisher)
        elif due["gps"] and self.pub_gps is not None and self.pub_gps.get_num_connections():
            self._send(self.sim.gps_link, self._gps_message(stamp), self.pub_gps)
        if due["vehicle_gps"] and (self.vehicle_gps_receiver.pub_fix.get_num_connections() or
                                   self.vehicle_gps_receiver.pub_vel.get_num_connections()):
            position, _, (vx, vy), _ = self.sim.vehicle_gps()  # (None in a dropout: the receiver says NO_FIX)
            fix = None if position is None else ((position[0], position[1], 0.0), (vx, vy, 0.0))
            for message, publisher in self.vehicle_gps_receiver.messages(fix, stamp):
                self._send(self.sim.gps_link, message, publisher)
        if due["vehicle_odom"]:  # (every tick, subscribed or not: the odometry dead-reckons its pose)
            self.pub_vehicle_odom.publish(self._vehicle_odom_message(stamp))
        if due["navdata"] and self.pub_navdata is not None:
            self._send(self.sim.navdata_link, self._navdata_message(stamp), self.pub_navdata)
        return due, stamp

    def _publish_states(self, due, stamp):
        """The rest of what is due, after the links' releases: joint states, tf, statistics."""
        if due["joint_states"] and self.pub_joints.get_num_connections():
            self.pub_joints.publish(JointState(
                header=self._header(stamp, ""), name=WHEEL_JOINTS,
                position=[float(a) for a in self.sim.wheel_angles], velocity=[], effort=[]))
        if due["tf"]:
            self._publish_tf(stamp)
        if due["stats"]:
            self._publish_stats()

    def _published(self, publisher, stamp):
        if self.lockstep is not None:
            self.lockstep.published(publisher.resolved_name, stamp.to_sec(), self._now())

    def _send(self, link, message, publisher):
        """Publish ``message`` once ``link`` delivers it (None: nothing was measured, e.g. a GPS dropout; a
        message the link loses is never published)."""
        if message is None or (link.loss > 0.0 and link.lost_next()):
            return

        def publish():
            publisher.publish(message)
            self._published(publisher, message.header.stamp)
        link.push(self.sim.time, publish)

    @staticmethod
    def _header(stamp, frame):
        return Header(stamp=stamp, frame_id=frame)

    def _sync_conditions(self):
        """Read the global condition parameters; mirror the battery level back to /drone_battery."""
        changed = False
        for name in CONDITION_PARAMS:
            try:
                raw = rospy.get_param_cached("/" + name)  # pushed by the master: no XML-RPC per poll
                if raw == {}:
                    raise KeyError(name)
            except KeyError:
                rospy.logwarn_throttle(10.0, "parameter /%s was deleted; keeping %s and restoring it" % (
                    name, self.conditions[name]))
                rospy.set_param("/" + name, self.conditions[name])
                if name == "drone_battery":
                    self.battery_written = self.conditions[name]
                continue
            if name == "drone_battery" and raw == self.battery_written:
                continue  # our own mirror, not an operator's change
            if raw == self.rejected.get(name, _NOTHING):
                continue  # already warned; the bad value stays visible to the supervisor (unsafe case)
            if name == "drone_battery" and _master_param("/drone_battery") == self.battery_written:
                # An operator's value, but the master holds our mirror: it was written over between the
                # mirror's check and its write (the parameter server has no compare-and-set). Put it back:
                # the supervisor must see it.
                rospy.set_param("/drone_battery", raw)
            if raw != self.conditions[name]:
                value = self._checked_condition(name, raw, self.conditions[name])
                if value != self.conditions[name]:
                    rospy.loginfo("condition /%s: %s -> %s", name, self.conditions[name], value)
                    self.conditions[name] = value
                    changed = True
                    self.rejected.pop(name, None)
                    if name == "drone_battery":
                        self.battery_written = raw  # the operator's value on the master: mirror over it
                elif raw != value:
                    self.rejected[name] = raw
        if changed:
            self._apply_conditions()
        level = round(self.sim.battery.level, 1)
        self.conditions["drone_battery"] = level
        # Mirror the level, unless the operator's last value was rejected: overwriting it would hide the
        # bad input from the supervisor, which must treat an unreadable battery as the unsafe case.
        if level != self.battery_written and "drone_battery" not in self.rejected:
            # The cache may not hold an operator's value set a moment ago: ask the master itself, so the
            # mirror never overwrites it (the next poll then reads it as an operator's change).
            if _master_param("/drone_battery") == self.battery_written:
                rospy.set_param("/drone_battery", level)
                self.battery_written = level

    def _capture_camera(self, stamp):
        """Capture the frame now (its capture time is its stamp); it is rendered in the camera's thread and
        published once the link has delivered it and it is developed (DeliveredFrames)."""
        t0 = time.perf_counter()
        frame = self.sim.capture_camera()
        self.timing["render"] += time.perf_counter() - t0
        info = copy.copy(self.camera_info)
        info.header = self._header(stamp, self.camera_info.header.frame_id)

        def publish(image):
            msg = Image(header=self._header(stamp, "ardrone/bottom_camera"), height=image.shape[0],
                        width=image.shape[1], encoding="rgb8", is_bigendian=0, step=image.shape[1] * 3,
                        data=image.tobytes())
            self.pub_image.publish(msg)
            self._published(self.pub_image, stamp)
            self.pub_info.publish(info)
        self.sim.camera_link.push(self.sim.time, lambda: self.delivered_frames.add(frame, publish))

    def _imu_message(self, stamp):
        quat, gyro, accel = self.sim.imu()
        msg = Imu(header=self._header(stamp, "ardrone/base_link"))
        _quaternion_msg(msg.orientation, quat)
        msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z = (float(v) for v in gyro)
        msg.linear_acceleration.x, msg.linear_acceleration.y, msg.linear_acceleration.z = (float(v) for v in accel)
        n = self.cfg["noise"]
        msg.orientation_covariance = _diag(math.radians(n["imu_orientation_std_deg"]) ** 2)
        msg.angular_velocity_covariance = _diag(n["imu_gyro_std"] ** 2)
        msg.linear_acceleration_covariance = _diag(n["imu_accel_std"] ** 2)
        return msg

    def _sonar_message(self, stamp):
        s = self.cfg["sensors"]
        return Range(header=self._header(stamp, "ardrone/base_link"), radiation_type=Range.ULTRASOUND,
                     field_of_view=SONAR_FIELD_OF_VIEW_RAD, min_range=s["sonar_min_range"], max_range=s["sonar_max_range"],
                     range=self.sim.sonar())

    def _publish_altimeter(self, stamp):
        altitude, pressure = self.sim.altimeter()
        if self.pub_altimeter is not None and self.pub_altimeter.get_num_connections():
            self.pub_altimeter.publish(Altimeter(header=self._header(stamp, "world"), altitude=altitude,
                                                 pressure=pressure, qnh=1013.25))
        if self.pub_gt_altitude.get_num_connections():
            z = float(self.sim.drone_pose()[0][2])
            self.pub_gt_altitude.publish(Altimeter(header=self._header(stamp, "world"), altitude=z,
                                                   pressure=1013.25 * (1.0 - 2.25577e-5 * z) ** 5.25588, qnh=1013.25))

    def _publish_ground_truth(self, stamp):
        # One message object per topic, filled anew each time: these publishers write synchronously, so a message
        # is on every subscriber's socket before it is filled again (building them was a third of the cost).
        position, quat = self.sim.drone_pose()
        velocity, omega = self.sim.drone_velocity()
        messages = self.ground_truth_messages
        if self.pub_gt_state.get_num_connections():
            odom = messages["state"]
            odom.header.stamp = stamp
            _fill_pose(odom.pose.pose, position, quat)
            _fill_vector(odom.twist.twist.linear, velocity)  # world frame, as Gazebo's p3d plugin
            _fill_vector(odom.twist.twist.angular, omega)
            self.pub_gt_state.publish(odom)
        if self.pub_gt_drone.get_num_connections():
            msg = messages["drone"]
            msg.header.stamp = stamp
            _fill_pose(msg.pose, position, quat)
            self.pub_gt_drone.publish(msg)
        x, y, yaw = self.sim.vehicle_pose()
        if self.pub_gt_summit.get_num_connections():
            msg = messages["vehicle"]
            msg.header.stamp = stamp
            _fill_pose(msg.pose, (x, y, 0.0), _yaw_quaternion(yaw))
            self.pub_gt_summit.publish(msg)
        if self.pub_gt_pad.get_num_connections():
            msg = messages["pad"]
            msg.header.stamp = stamp
            _fill_pose(msg.pose, self.sim.pad_position(), _yaw_quaternion(yaw))
            self.pub_gt_pad.publish(msg)

    def _gps_message(self, stamp):
        fix = self.sim.gps()
        if fix is None:
            return None  # a dropout
        position, velocity = fix
        odom = Odometry(header=self._header(stamp, "world"), child_frame_id="ardrone/base_link")
        _fill_pose(odom.pose.pose, position, (1.0, 0.0, 0.0, 0.0))
        _fill_vector(odom.twist.twist.linear, velocity)
        n = self.cfg["noise"]
        odom.pose.covariance = _diag6(n["gps_position_std"] ** 2, 1e6)
        odom.twist.covariance = _diag6(n["gps_velocity_std"] ** 2, 1e6)
        return odom

    def _vehicle_odom_message(self, stamp):
        """robotnik_base_control/odom: the pose in summit_xl/odom (yaw aligned with ENU), the twist in the base frame
        (vehicle_odometry.py)."""
        _, _, yaw = self.sim.vehicle_pose()
        vx, vy, yaw_rate = self.sim.vehicle_velocity()
        reading = self.vehicle_odometry.measure(self.sim.time, yaw, (vx, vy), yaw_rate)
        odom = Odometry(header=self._header(stamp, "summit_xl/odom"), child_frame_id="summit_xl/base_link")
        _fill_pose(odom.pose.pose, (reading.position[0], reading.position[1], 0.0), _yaw_quaternion(reading.yaw))
        odom.twist.twist.linear.x = reading.forward_speed
        odom.twist.twist.angular.z = reading.yaw_rate
        odom.pose.covariance = reading.pose_covariance
        odom.twist.covariance = reading.twist_covariance
        return odom

    def _navdata_message(self, stamp):
        sim = self.sim
        _, quat = sim.drone_pose()
        roll, pitch, yaw = (math.degrees(angle) for angle in euler_from_quaternion(*quat))
        vx, vy, vz = sim.flow_velocity()
        sonar = sim.sonar()
        state = NAVDATA_STATE[sim.autopilot.mode]
        if state == Navdata.STATE_FLYING and abs(vx) < 0.1 and abs(vy) < 0.1 and sim.command.vx == sim.command.vy == 0:
            state = Navdata.STATE_HOVERING
        return Navdata(
            header=self._header(stamp, "ardrone/base_link"), state=state, battery_percent=sim.battery.level,
            altitude=sonar if math.isfinite(sonar) else -1.0, vx=vx, vy=vy, vz=vz, rot_x=roll, rot_y=pitch,
            rot_z=yaw, motor_thrust=float(sim.autopilot.motor_thrust.sum()) / sim.max_total_thrust)

    def _publish_tf(self, stamp):
        if not self.pub_tf.get_num_connections():
            return
        position, quat = self.sim.drone_pose()
        x, y, yaw = self.sim.vehicle_pose()
        drone, vehicle = self.tf_message.transforms  # (filled anew, as the ground truth)
        _fill_transform(drone, position, quat, stamp)
        _fill_transform(vehicle, (x, y, 0.0), _yaw_quaternion(yaw), stamp)
        self.pub_tf.publish(self.tf_message)

    def _publish_touchdown(self, touchdown):
        msg = Touchdown(header=self._header(rospy.Time.from_sec(self.time_origin + touchdown.time), "world"), surface=touchdown.surface,
                        crashed=touchdown.crashed, impact_speed=touchdown.impact_speed, tilt_deg=touchdown.tilt_deg,
                        pad_error=touchdown.pad_error)
        _fill_vector(msg.position, touchdown.position)
        self.pub_touchdown.publish(msg)
        (rospy.logwarn if touchdown.crashed else rospy.loginfo)(touchdown.describe())

    def _publish_stats(self):
        wall = time.monotonic() - self.wall_start
        sim_elapsed = self.sim.time - self.sim_start
        stats = {"sim_time": round(self._now(), 3), "wall_time": round(wall, 3),
                 "real_time_factor": round(sim_elapsed / wall, 3) if wall > 0 else 0.0}
        stats.update({"%s_share" % k: round(v / wall, 3) if wall > 0 else 0.0 for k, v in self.timing.items()})
        # The camera thread's CPU beside the loop above (rendering and developing frames; "render" is the time
        # the loop spent capturing them and waiting for them).
        stats["camera_thread_share"] = round(self.sim.camera_thread_seconds() / wall, 3) if wall > 0 else 0.0
        # This (the stepping) thread on a core, and runnable but waiting for one: on a busy machine the second
        # is what the other processes take from the loop's critical path.
        now, start = thread_cpu_and_wait(), self.stepping_sched_start
        if now is not None and start is not None and wall > 0:
            stats["stepping_on_core_share"] = round((now[0] - start[0]) / wall, 3)
            stats["stepping_waiting_for_core_share"] = round((now[1] - start[1]) / wall, 3)
        if sim_elapsed > 0:
            thread_start, process_start = self.cpu_start
            stats.update({"cpu_physics_per_sim_s": round(self.cpu["physics"] / sim_elapsed, 4),
                          "cpu_publish_per_sim_s": round(self.cpu["publish"] / sim_elapsed, 4),
                          "cpu_stepping_per_sim_s": round((time.thread_time() - thread_start) / sim_elapsed, 4),
                          "cpu_process_per_sim_s": round((time.process_time() - process_start) / sim_elapsed, 4)})
        self.pub_stats.publish(String(data=json.dumps(stats)))

    @staticmethod
    def _transform(parent, child, position, quat_wxyz, stamp):
        msg = TransformStamped()
        msg.header.stamp = stamp if stamp else rospy.Time(0)
        msg.header.frame_id, msg.child_frame_id = parent, child
        _fill_vector(msg.transform.translation, position)
        _quaternion_msg(msg.transform.rotation, quat_wxyz)
        return msg


def _emulated_mavros(node, make_publisher):
    from .mavros_driver_node import EmulatedMavros  # (mavros_msgs is needed only where px4_quad flies)
    return EmulatedMavros(node, make_publisher)


def _condition_anew(name):
    """The condition parameter /``name`` as the master holds it now (_NOTHING when unset), and cached again from
    there. rospy.get_param answers from rospy's cache once _sync_conditions has cached the key, and the master's push
    of a new value lags (about 60 ms): at a warm graph's reset the cache still held the previous scenario's wind,
    which was then written back over the runner's new value."""
    key = rospy.resolve_name("/" + name)
    try:
        get_param_server_cache().delete(key)
    except KeyError:  # not cached yet
        pass
    try:
        value = rospy.get_param_cached(key)  # (subscribes again: the master's value, pushed from here on)
    except KeyError:
        return _NOTHING
    return _NOTHING if value == {} else value


def _master_param(key):
    """``key``'s value on the master, or None. (rospy.get_param answers from rospy's cache once the key is
    cached by get_param_cached, which may lag behind the master.) None too when the master cannot be reached
    (dead, or not answering on a loaded machine): the world goes on, the mirror waits for the next poll."""
    try:
        return rosgraph.Master(rospy.get_name()).getParam(key)
    except (rosgraph.MasterException, OSError) as err:
        if isinstance(err, OSError):
            rospy.logwarn_throttle(5.0, "mujoco_sim: the master did not answer for %s: %s" % (key, err))
        return None


def _fill_vector(target, values):
    target.x, target.y, target.z = (float(v) for v in values)


def _fill_pose(pose, position, quat_wxyz):
    _fill_vector(pose.position, position)
    _quaternion_msg(pose.orientation, quat_wxyz)


def _fill_transform(transform, position, quat_wxyz, stamp):
    transform.header.stamp = stamp
    _fill_vector(transform.transform.translation, position)
    _quaternion_msg(transform.transform.rotation, quat_wxyz)


def _diag(value):
    return [value, 0.0, 0.0, 0.0, value, 0.0, 0.0, 0.0, value]


def _diag6(linear, angular):
    cov = [0.0] * 36
    for i in range(3):
        cov[i * 7] = linear
        cov[(i + 3) * 7] = angular
    return cov


def _stop_listening_to_own_clock():
    """rospy subscribes every node to /clock under /use_sim_time; receiving our own ticks back would
    only cost CPU, so the simulator sets its rospy time directly instead."""
    import rospy.impl.simtime as simtime
    if getattr(simtime, "_clock_sub", None) is not None:
        simtime._clock_sub.unregister()
        simtime._clock_sub = None


def main():
    import warnings
    warnings.filterwarnings("ignore", message=".*queue_size.*")  # synchronous publishing is on purpose
    init_node("mujoco_sim")  # rospy's own signal handler deadlocked here mid-publish (see landing_runtime.shutdown)
    _stop_listening_to_own_clock()
    try:
        node = SimNode()
    except ConfigError as err:
        rospy.logfatal("mujoco_sim cannot start: %s", err)
        sys.exit(2)
    node.spin()
