"""mavros_adapter node: the stack's side of a PX4 quadrotor behind MAVROS (the real one, or the simulator emulating
it, drone_model px4_quad). The logic is ardrone_moves.mavros_offboard; this is its ROS shell.

In: ``mavros/state``, ``mavros/extended_state``, ``mavros/local_position/pose`` and ``velocity_local``,
``mavros/battery``, ``mavros/imu/data``; the stack's ``velocity_cmd`` (Twist, heading frame, m/s and rad/s),
``ardrone/takeoff`` and ``ardrone/land`` (std_msgs/Empty, as the tracker sends them to any drone) and ``~resume``
(Empty: ask for OFFBOARD again after a takeover).
Out: ``mavros/setpoint_raw/local`` (PositionTarget: ENU velocity and yaw rate) at ``~setpoint_rate`` while the
adapter commands; the services ``mavros/set_mode`` and ``mavros/cmd/arming`` (called in their own threads, so that
the loop never waits on them); ``~status`` (String, latched: the phase and the last decision); and what the stack's
nodes read of a drone: ``drone/navdata`` (landing_msgs/Navdata), ``ardrone/imu`` (the IMU, in the stack's frame),
``ardrone/sonar_height`` and ``ardrone/altimeter`` (from the local height: this airframe has no range finder, and the
local frame's origin is the take-off point on the pad).
"""
import math
import sys
import threading

import rospy
from geometry_msgs.msg import PoseStamped, Twist, TwistStamped
from landing_msgs.msg import Altimeter, Navdata
from landing_runtime.geometry import euler_from_quaternion
from landing_runtime.lockstep import LockstepAcker
from landing_runtime.rospy_node import NodeHandles, direct_publisher, run_node, spin_at
from mavros_msgs.msg import ExtendedState, PositionTarget, State
from mavros_msgs.srv import CommandBool, SetMode
from sensor_msgs.msg import BatteryState, Imu, Range
from std_msgs.msg import Empty, String

from .mavros_offboard import IN_AIR, LANDING, ON_GROUND, TAKEOFF, OffboardAdapter

NAVDATA_STATE = {ON_GROUND: Navdata.STATE_LANDED, TAKEOFF: Navdata.STATE_TAKING_OFF, IN_AIR: Navdata.STATE_FLYING,
                 LANDING: Navdata.STATE_LANDING}
HEIGHT_RANGE = (0.02, 40.0)  # what ardrone/sonar_height reports of the local height [m]
NODE_KEYS = ("setpoint_rate", "takeoff_altitude", "service_timeout_s")


class SettingsError(ValueError):
    pass


def read_settings():
    values = rospy.get_param("~")
    missing = [key for key in NODE_KEYS if key not in values]
    if missing:
        raise SettingsError("mavros_adapter: missing parameter(s) %s: load config/mavros_adapter.yaml (see "
                            "launch/mavros_adapter.launch)" % ", ".join("~" + key for key in missing))
    if not 2.5 <= float(values["setpoint_rate"]) <= 100.0:
        raise SettingsError("mavros_adapter: ~setpoint_rate %r must be in [2.5, 100] Hz (PX4 wants more than 2 Hz)"
                            % (values["setpoint_rate"],))
    return values


class MavrosAdapter:
    def __init__(self):
        self.settings = read_settings()
        try:
            self.core = OffboardAdapter(self.settings, now=rospy.get_time())
        except ValueError as error:
            raise SettingsError("mavros_adapter: %s" % error)
        self.lock = threading.Lock()
        self.reported = 0                 # events of the core already logged
        self.status = None
        self.battery = None
        self.handles = NodeHandles()
        self.pub_setpoint = direct_publisher("mavros/setpoint_raw/local", PositionTarget)
        self.pub_navdata = direct_publisher("drone/navdata", Navdata)
        self.pub_imu = direct_publisher("ardrone/imu", Imu)
        self.pub_sonar = direct_publisher("ardrone/sonar_height", Range)
        self.pub_altimeter = direct_publisher("ardrone/altimeter", Altimeter)
        self.pub_status = self.handles.latched(rospy.Publisher("~status", String, queue_size=1, latch=True))
        self.set_mode = rospy.ServiceProxy("mavros/set_mode", SetMode)
        self.arming = rospy.ServiceProxy("mavros/cmd/arming", CommandBool)
        sub = self.handles.subscriber
        sub("mavros/state", State, self.on_state, queue_size=5)
        sub("mavros/extended_state", ExtendedState, self.on_extended_state, queue_size=5)
        sub("mavros/local_position/pose", PoseStamped, self.on_pose, queue_size=5, tcp_nodelay=True)
        sub("mavros/local_position/velocity_local", TwistStamped, self.on_velocity, queue_size=5, tcp_nodelay=True)
        sub("mavros/battery", BatteryState, self.on_battery, queue_size=5)
        sub("mavros/imu/data", Imu, self.on_imu, queue_size=5, tcp_nodelay=True)
        sub("velocity_cmd", Twist, self.on_velocity_cmd, queue_size=1, tcp_nodelay=True)
        sub("ardrone/takeoff", Empty, lambda _: self._request("take-off", self.core.request_takeoff), queue_size=5)
        sub("ardrone/land", Empty, lambda _: self._request("landing", self.core.request_land), queue_size=5)
        sub("~resume", Empty, lambda _: self._request("resume", self.core.request_resume), queue_size=5)
        self.velocity = None
        self.lockstep = LockstepAcker("mavros/local_position/pose")
        self._publish_status()

    # ----- MAVROS in -------------------------------------------------------------------------------------------
    def on_state(self, msg):
        with self.lock:
            self.core.on_state(msg.connected, msg.armed, msg.mode, rospy.get_time())

    def on_extended_state(self, msg):
        with self.lock:
            self.core.on_extended_state(msg.landed_state, rospy.get_time())

    def on_velocity(self, msg):
        v = msg.twist.linear
        self.velocity = (v.x, v.y, v.z)

    def on_battery(self, msg):
        percent = msg.percentage * 100.0 if math.isfinite(msg.percentage) else float("nan")
        self.battery = percent
        with self.lock:
            self.core.on_battery(percent, rospy.get_time())

    def on_imu(self, msg):
        msg.header.frame_id = "ardrone/base_link"
        self.pub_imu.publish(msg)

    def on_pose(self, msg):
        p, q = msg.pose.position, msg.pose.orientation
        roll, pitch, yaw = euler_from_quaternion(q.w, q.x, q.y, q.z)
        with self.lock:
            self.core.on_local_position((p.x, p.y, p.z), yaw, rospy.get_time(), velocity=self.velocity)
        self._publish_measurements(msg.header, p.z, roll, pitch, yaw)
        self.lockstep.ack(msg.header.stamp)

    # ----- the stack in --------------------------------------------------------------------------------------------
    def on_velocity_cmd(self, msg):
        with self.lock:
            ok = self.core.on_velocity_command(msg.linear.x, msg.linear.y, msg.linear.z, msg.angular.z,
                                               rospy.get_time())
        if not ok:
            rospy.logwarn_throttle(5.0, "mavros_adapter: a non-finite velocity command was refused (the last good "
                                        "one stays until it is %.1f s old)" % self.settings["command_timeout_s"])

    def _request(self, what, call):
        with self.lock:
            problem = call(rospy.get_time())
        if problem:
            rospy.logwarn("mavros_adapter: %s refused: %s", what, problem)
        self._report()

    # ----- out -------------------------------------------------------------------------------------------------------
    def _publish_measurements(self, header, height, roll, pitch, yaw):
        vx = vy = vz = 0.0
        if self.velocity is not None:
            east, north, vz = self.velocity
            c, s = math.cos(yaw), math.sin(yaw)
            vx, vy = c * east + s * north, -s * east + c * north
        with self.lock:
            state = NAVDATA_STATE.get(self.core.reported_landed_state(), Navdata.STATE_UNKNOWN)
        self.pub_navdata.publish(Navdata(
            header=header, state=state, battery_percent=self.battery if self.battery is not None else float("nan"),
            altitude=height, vx=vx, vy=vy, vz=vz, rot_x=math.degrees(roll), rot_y=math.degrees(pitch),
            rot_z=math.degrees(yaw), motor_thrust=0.0))
        in_range = HEIGHT_RANGE[0] <= height <= HEIGHT_RANGE[1]
        self.pub_sonar.publish(Range(header=rospy.Header(stamp=header.stamp, frame_id="ardrone/base_link"),
                                     radiation_type=Range.INFRARED, field_of_view=0.05, min_range=HEIGHT_RANGE[0],
                                     max_range=HEIGHT_RANGE[1], range=height if in_range else math.inf))
        self.pub_altimeter.publish(Altimeter(header=rospy.Header(stamp=header.stamp, frame_id="world"),
                                             altitude=self.settings["takeoff_altitude"] + height,
                                             pressure=float("nan"), qnh=float("nan")))

    def tick(self):
        now = rospy.get_time()
        with self.lock:
            out = self.core.tick(now)
        if out.setpoint is not None:
            frame, mask, (x, y, z), yaw_rate = out.setpoint.position_target_fields()
            msg = PositionTarget(coordinate_frame=frame, type_mask=mask, yaw_rate=yaw_rate)
            msg.header.stamp = rospy.Time.now()
            msg.velocity.x, msg.velocity.y, msg.velocity.z = x, y, z
            self.pub_setpoint.publish(msg)
        for request in out.requests:
            threading.Thread(target=self._call, args=request, daemon=True).start()
        self._report()

    def _call(self, name, value):
        timeout = self.settings["service_timeout_s"]
        try:
            if name == "set_mode":
                self.set_mode.wait_for_service(timeout=timeout)
                answer = self.set_mode(base_mode=0, custom_mode=value)
                with self.lock:
                    self.core.on_mode_sent(answer.mode_sent, rospy.get_time())
            else:
                self.arming.wait_for_service(timeout=timeout)
                answer = self.arming(value=value)
                with self.lock:
                    self.core.on_arming_answer(value, answer.success, answer.result, rospy.get_time())
        except (rospy.ROSException, rospy.ServiceException) as error:
            with self.lock:
                self.core.on_service_error(name, str(error), rospy.get_time())

    def _report(self):
        with self.lock:
            new = min(self.core.event_count - self.reported, len(self.core.events))
            events = self.core.events[len(self.core.events) - new:]
            self.reported = self.core.event_count
        for _, text, level in events[-20:]:
            {10: rospy.logdebug, 20: rospy.loginfo, 30: rospy.logwarn}.get(level, rospy.logerr)("mavros_adapter: %s",
                                                                                                text)
        if events:
            self._publish_status()

    def _publish_status(self):
        with self.lock:
            phase, last = self.core.phase.value, (self.core.events[-1][1] if self.core.events else "")
        status = "%s%s" % (phase, ": " + last if last else "")
        if status != self.status:
            self.status = status
            self.pub_status.publish(String(data=status))

    def spin(self):
        spin_at(float(self.settings["setpoint_rate"]), self.tick)


def main():
    return run_node("mavros_adapter", MavrosAdapter, startup_errors=(SettingsError,))


if __name__ == "__main__":
    sys.exit(main())
