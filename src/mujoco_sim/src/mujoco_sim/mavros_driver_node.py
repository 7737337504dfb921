"""The ROS side of MAVROS as the simulator emulates it for a PX4 quadrotor (drone_model px4_quad): MAVROS's topics
and services under ``mavros/``, with MAVROS's types, frames and units, at the rates PX4 streams them, so that the
stack talks to the simulator as to a real PX4 behind MAVROS.

Publishes (ENU local frame ``map`` with its origin where the estimate started; body frame ``base_link``, FLU):
``mavros/state`` (mavros_msgs/State, at each heartbeat; ``connected`` false once no heartbeat came for
connection_timeout_s), ``mavros/extended_state`` (landed state), ``mavros/local_position/pose`` (PoseStamped) and
``velocity_local`` (TwistStamped), ``mavros/global_position/global`` (NavSatFix, only while the position estimate is
valid, as PX4 sends GLOBAL_POSITION_INT), ``mavros/imu/data`` (Imu), ``mavros/battery`` (BatteryState). All of it
rides the telemetry link (the realism profile's navdata latency and losses) and is stamped when the autopilot sent it.
Subscribes ``mavros/setpoint_raw/local`` (mavros_msgs/PositionTarget) and
``mavros/setpoint_velocity/cmd_vel_unstamped`` (Twist, ENU local frame, angular.z the yaw rate); serves
``mavros/cmd/arming`` (CommandBool), ``mavros/set_mode`` (SetMode: mode_sent only says the request went out),
``mavros/cmd/takeoff`` and ``mavros/cmd/land`` (CommandTOL). The pilot's RC mode switch is
``mujoco_sim/pilot_mode`` (std_msgs/String, a mode name) and the scenario fault ``pilot_takeover``.
"""
import math
import threading

import rospy
from geometry_msgs.msg import PoseStamped, Twist, TwistStamped
from mavros_msgs.msg import ExtendedState, PositionTarget, State
from mavros_msgs.srv import CommandBool, CommandBoolResponse, CommandTOL, CommandTOLResponse, SetMode, SetModeResponse
from navsat_local.enu import LocalFrame, parse_datum
from sensor_msgs.msg import BatteryState, Imu, NavSatFix, NavSatStatus
from std_msgs.msg import Header, String

from .config import ConfigError
from .px4_firmware import KNOWN_MODES, PILOT_MODES, Setpoint
from .schedule import Schedule

DATUM_PARAM = "/navsat_datum"
LOCAL_FRAME, BODY_FRAME = "map", "base_link"  # MAVROS's default frame ids
VTOL_STATE_MC = 3
CELLS, CELL_FULL_V, CELL_EMPTY_V = 4, 4.2, 3.5  # a 4S LiPo: what the voltage says of the charge
EPH_M, EPV_M = 1.0, 1.5                      # the estimate's position accuracy as the fix's covariance reports it [m]


class EmulatedMavros:
    """``node``: the SimNode (its simulator, action queue, publisher factory, links, lock-step bookkeeping)."""

    def __init__(self, node, make_publisher):
        self.node = node
        self.p = node.cfg["px4_quad"]
        if not rospy.has_param(DATUM_PARAM):
            raise ConfigError("the parameter %s (the world's geodetic origin) is not set: sim.launch loads it from "
                              "config/datum.yaml" % DATUM_PARAM)
        try:
            self.datum = parse_datum(rospy.get_param(DATUM_PARAM), DATUM_PARAM)
            self.geodetic = LocalFrame.around(self.datum)
        except ValueError as err:
            raise ConfigError("%s (sim.launch loads it from config/datum.yaml)" % err) from None
        pub = make_publisher
        self.pub_state = pub("mavros/state", State)
        self.pub_extended = pub("mavros/extended_state", ExtendedState)
        self.pub_pose = pub("mavros/local_position/pose", PoseStamped)
        self.pub_velocity = pub("mavros/local_position/velocity_local", TwistStamped)
        self.pub_global = pub("mavros/global_position/global", NavSatFix)
        self.pub_imu = pub("mavros/imu/data", Imu)
        self.pub_battery = pub("mavros/battery", BatteryState)
        rospy.Subscriber("mavros/setpoint_raw/local", PositionTarget, self._on_position_target, queue_size=5,
                         tcp_nodelay=True)
        rospy.Subscriber("mavros/setpoint_velocity/cmd_vel_unstamped", Twist, self._on_cmd_vel, queue_size=5,
                         tcp_nodelay=True)
        rospy.Subscriber("mujoco_sim/pilot_mode", String, self._on_pilot_mode, queue_size=5)
        rospy.Service("mavros/cmd/arming", CommandBool, self._on_arming)
        rospy.Service("mavros/set_mode", SetMode, self._on_set_mode)
        rospy.Service("mavros/cmd/takeoff", CommandTOL, self._on_takeoff)
        rospy.Service("mavros/cmd/land", CommandTOL, self._on_land)
        self._world = None
        self._new_world()

    @property
    def sim(self):
        return self.node.sim  # a reset of the world builds a new one

    def _new_world(self):
        p = self.p
        self._world = self.sim
        self.schedules = {name: Schedule(p[name + "_hz"]) for name in (
            "heartbeat", "extended_state", "local_position", "global_position", "imu", "battery")}
        self.last_heartbeat = None   # sim time a heartbeat last reached MAVROS [s]
        self.connected = False

    # ----- inputs: set-points, commands, the pilot ---------------------------------------------------------
    def _on_position_target(self, msg):
        setpoint, problem = Setpoint.from_position_target(
            msg.coordinate_frame, msg.type_mask, (msg.position.x, msg.position.y, msg.position.z),
            (msg.velocity.x, msg.velocity.y, msg.velocity.z), msg.yaw, msg.yaw_rate)
        self._setpoint("mavros/setpoint_raw/local", setpoint, problem)

    def _on_cmd_vel(self, msg):
        setpoint, problem = Setpoint.velocity(msg.linear.x, msg.linear.y, msg.linear.z, msg.angular.z)
        self._setpoint("mavros/setpoint_velocity/cmd_vel_unstamped", setpoint, problem)

    def _setpoint(self, topic, setpoint, problem):
        if problem:
            self.node.rejections.reject(topic, ("refused", "%s (PX4 keeps the previous set-point; the offboard signal "
                                                           "counts only the good ones)" % problem))
            return
        self.node.actions.put(lambda: self.sim.px4_world.send_setpoint(setpoint))

    def _on_pilot_mode(self, msg):
        mode = msg.data.strip().upper()
        if mode not in PILOT_MODES and mode != "OFFBOARD":
            rospy.logwarn("mujoco_sim/pilot_mode %r ignored: an RC mode switch selects %s (or OFFBOARD)", msg.data,
                          ", ".join(PILOT_MODES))
            return
        self.node.actions.put(lambda: self.sim.px4_world.pilot_mode(mode))

    def _on_set_mode(self, request):
        mode = request.custom_mode.strip().upper()
        if not mode:
            rospy.logwarn("mavros/set_mode: base_mode %d without custom_mode: base modes are not emulated; the mode "
                          "stays", request.base_mode)
            return SetModeResponse(mode_sent=True)
        if mode not in KNOWN_MODES:
            rospy.logwarn("mavros/set_mode: unknown PX4 mode %r (known: %s)", request.custom_mode, ", ".join(KNOWN_MODES))
            return SetModeResponse(mode_sent=False)
        # SET_MODE has no acknowledgement: MAVROS answers once it is sent; mavros/state tells whether PX4 switched.
        self.node.actions.put(lambda: self.sim.px4_world.send_command(
            lambda commander, now: commander.request_mode(mode, now, source="set_mode")))
        return SetModeResponse(mode_sent=True)

    def _on_arming(self, request):
        value = bool(request.value)
        result, _ = self._command(lambda commander, now: commander.request_arm(value, now),
                                  "arming" if value else "disarming")
        return CommandBoolResponse(success=result == 0, result=result)

    def _on_takeoff(self, request):
        height = None
        if math.isfinite(request.altitude) and request.altitude != 0.0:
            height = request.altitude - self._home_altitude()   # AMSL -> above the take-off point

        def takeoff(commander, now):
            self.sim.autopilot.requested_takeoff_height = height if height is not None and height > 0.5 else None
            return commander.request_takeoff(now)
        result, _ = self._command(takeoff, "take-off")
        return CommandTOLResponse(success=result == 0, result=result)

    def _on_land(self, _request):
        result, _ = self._command(lambda commander, now: commander.request_land(now), "land")
        return CommandTOLResponse(success=result == 0, result=result)

    def _command(self, action, name):
        """Send a COMMAND_LONG and wait for its acknowledgement: (MAV_RESULT, reason); no acknowledgement within
        command_timeout_s fails the service call, as MAVROS's does."""
        answered, answer = threading.Event(), []

        def reply(result):
            answer.append(result)
            answered.set()
        self.node.actions.put(lambda: self.sim.px4_world.send_command(action, reply))
        if not answered.wait(self.p["command_timeout_s"]):
            raise rospy.ServiceException("mavros: %s: no COMMAND_ACK from the autopilot within %.1f s"
                                         % (name, self.p["command_timeout_s"]))
        result, reason = answer[0]
        (rospy.loginfo if result == 0 else rospy.logwarn)("mavros: %s: result %d (%s)", name, result, reason)
        return result, reason

    def _home_altitude(self):
        """Altitude of the local frame's origin above the datum's reference [m] (the take-off point)."""
        origin = self.sim.px4_world.origin
        return float(self.datum[2]) + (float(origin[2]) if origin is not None else 0.0)

    # ----- outputs, at every physics step -----------------------------------------------------------------------
    def step(self, now):
        if self.sim is not self._world:
            self._new_world()
        s, sim = self.schedules, self.sim
        stamp = rospy.Time.from_sec(self.node.time_origin + now)
        lost = sim.link_lost()
        link = sim.navdata_link
        if s["heartbeat"].due(now) and not lost:
            self._send(link, self._state_message(stamp), self.pub_state, heartbeat=True)
        if self.connected and self.last_heartbeat is not None and \
                now - self.last_heartbeat > self.p["connection_timeout_s"]:
            self.connected = False
            rospy.logwarn("mavros: no heartbeat for %.1f s: connection lost", self.p["connection_timeout_s"])
            self.pub_state.publish(State(header=Header(stamp=stamp), connected=False, mode="", system_status=0))
        if s["extended_state"].due(now) and not lost:
            self._send(link, ExtendedState(header=Header(stamp=stamp), vtol_state=VTOL_STATE_MC,
                                           landed_state=sim.px4_world.landed_state), self.pub_extended)
        if s["local_position"].due(now) and not lost:
            for message, publisher in self._local_position_messages(stamp):
                self._send(link, message, publisher)
        if s["global_position"].due(now) and not lost:
            self._send(link, self._global_message(stamp), self.pub_global)
        if s["imu"].due(now) and not lost and self.pub_imu.get_num_connections():
            self._send(link, self._imu_message(stamp), self.pub_imu)
        if s["battery"].due(now) and not lost:
            self._send(link, self._battery_message(stamp), self.pub_battery)

    def _send(self, link, message, publisher, heartbeat=False):
        if message is None or (link.loss > 0.0 and link.lost_next()):
            return
        node = self.node

        def publish():
            if heartbeat:
                self.last_heartbeat, self.connected = self.sim.time, True
            publisher.publish(message)
            node._published(publisher, message.header.stamp)
        link.push(self.sim.time, publish)

    def _state_message(self, stamp):
        mode, armed, guided, manual_input, system_status = self.sim.px4_world.connected_modes
        return State(header=Header(stamp=stamp), connected=True, armed=armed, guided=guided,
                     manual_input=manual_input, mode=mode, system_status=system_status)

    def _orientation(self):
        quat, gyro, accel = self.sim.imu()  # the attitude estimate, the gyro and the accelerometer as PX4 has them
        return quat, gyro, accel

    def _local_position_messages(self, stamp):
        position, velocity, _valid = self.sim.px4_world.local_position()
        quat, gyro, _ = self._orientation()
        pose = PoseStamped(header=Header(stamp=stamp, frame_id=LOCAL_FRAME))
        pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = (float(v) for v in position)
        o = pose.pose.orientation
        o.w, o.x, o.y, o.z = (float(v) for v in quat)
        twist = TwistStamped(header=Header(stamp=stamp, frame_id=LOCAL_FRAME))
        twist.twist.linear.x, twist.twist.linear.y, twist.twist.linear.z = (float(v) for v in velocity)
        twist.twist.angular.x, twist.twist.angular.y, twist.twist.angular.z = (float(v) for v in gyro)
        return [(pose, self.pub_pose), (twist, self.pub_velocity)]

    def _global_message(self, stamp):
        position, _, valid = self.sim.px4_world.estimate()
        if not valid:
            return None  # PX4 sends no global position without a valid estimate
        lat, lon, alt = self.geodetic.to_geodetic(float(position[0]), float(position[1]), float(position[2]))
        return NavSatFix(header=Header(stamp=stamp, frame_id=BODY_FRAME),
                         status=NavSatStatus(status=NavSatStatus.STATUS_FIX, service=NavSatStatus.SERVICE_GPS),
                         latitude=lat, longitude=lon, altitude=alt,
                         position_covariance=[EPH_M ** 2, 0, 0, 0, EPH_M ** 2, 0, 0, 0, EPV_M ** 2],
                         position_covariance_type=NavSatFix.COVARIANCE_TYPE_APPROXIMATED)

    def _imu_message(self, stamp):
        quat, gyro, accel = self._orientation()
        msg = Imu(header=Header(stamp=stamp, frame_id=BODY_FRAME))
        msg.orientation.w, msg.orientation.x, msg.orientation.y, msg.orientation.z = (float(v) for v in quat)
        msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z = (float(v) for v in gyro)
        msg.linear_acceleration.x, msg.linear_acceleration.y, msg.linear_acceleration.z = (float(v) for v in accel)
        n = self.node.cfg["noise"]
        msg.orientation_covariance = _diag(math.radians(n["imu_orientation_std_deg"]) ** 2)
        msg.angular_velocity_covariance = _diag(n["imu_gyro_std"] ** 2)
        msg.linear_acceleration_covariance = _diag(n["imu_accel_std"] ** 2)
        return msg

    def _battery_message(self, stamp):
        level = max(0.0, min(100.0, float(self.sim.battery.level)))
        cell = CELL_EMPTY_V + (CELL_FULL_V - CELL_EMPTY_V) * level / 100.0
        return BatteryState(header=Header(stamp=stamp, frame_id=BODY_FRAME), voltage=CELLS * cell,
                            current=float("nan"), charge=float("nan"), capacity=float("nan"),
                            design_capacity=float("nan"), percentage=level / 100.0,
                            power_supply_status=BatteryState.POWER_SUPPLY_STATUS_DISCHARGING,
                            power_supply_health=BatteryState.POWER_SUPPLY_HEALTH_UNKNOWN,
                            power_supply_technology=BatteryState.POWER_SUPPLY_TECHNOLOGY_LIPO, present=True,
                            cell_voltage=[cell] * CELLS)


def _diag(value):
    return [value, 0.0, 0.0, 0.0, value, 0.0, 0.0, 0.0, value]
