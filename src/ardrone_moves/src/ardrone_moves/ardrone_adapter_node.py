"""ardrone_adapter node: the stack's side of the real AR.Drone 2.0 driver (ardrone_autonomy), or of the
simulator emulating it.

Commands: the stack's velocity commands (``velocity_cmd``, geometry_msgs/Twist in m/s and rad/s, heading
frame) become the driver's normalised tilt/climb/yaw-rate ``cmd_vel`` through ``velocity_loop`` on each
navdata, at most at ``~command_rate``; a velocity command older than ``~command_timeout`` counts as zero, and
a zero command over a slow drone hands over to the firmware's own hover (all six components zero).
Data: ``ardrone/navdata`` (ardrone_autonomy/Navdata, the driver's units) becomes what the stack's nodes read:
``drone/navdata`` (landing_msgs/Navdata, SI units), ``ardrone/sonar_height`` (sensor_msgs/Range, from altd)
and ``ardrone/altimeter`` (landing_msgs/Altimeter, from the barometer's pressure).
Start-up: the bottom camera is selected through ``ardrone/setcamchannel`` and its frames
(``ardrone/bottom/camera_info``) must follow; altd's unit is checked against the barometer in flight.
``~status`` (std_msgs/String, latched) says where both stand, for the pre-flight check.
"""
import math
import sys
import threading

import rospy
from ardrone_autonomy.msg import Navdata as DriverNavdata
from ardrone_autonomy.srv import CamSelect
from geometry_msgs.msg import Twist
from landing_msgs.msg import Altimeter, Navdata
from landing_runtime.input_check import MAX_RATE_RADPS, MAX_SPEED_MPS, RosRejectionLog, numbers_problem
from landing_runtime.lockstep import LockstepAcker
from landing_runtime.rospy_node import NodeHandles, direct_publisher, run_node
from sensor_msgs.msg import CameraInfo, Range
from std_msgs.msg import String

from .camera_select import BottomCameraSelect
from .navdata_units import AGREES, AltdUnitCheck, convert_navdata, pressure_altitude
from .velocity_loop import HOVER, CommandRate, TiltVelocityLoop, validated_parameters

BOTTOM_CHANNEL = 1          # ardrone/setcamchannel: 0 front, 1 bottom (AR.Drone 2.0)
SONAR_FIELD_OF_VIEW = 0.7   # the AR.Drone's ultrasound cone, about 40 deg [rad]
SONAR_RANGE = (0.02, 6.0)   # what altd covers: its ultrasound and, above, the barometer [m]
ADAPTER_KEYS = ("command_rate", "command_timeout", "takeoff_altitude", "altd_unit", "altd_check_samples",
                "camera_service_timeout", "camera_frame_timeout", "camera_select_attempts", "select_bottom_camera")


class SettingsError(ValueError):
    pass


def read_settings():
    """The private parameters (config/ardrone_adapter.yaml); a missing one stops the node naming it."""
    values = rospy.get_param("~")
    missing = [key for key in ADAPTER_KEYS if key not in values]
    if missing:
        raise SettingsError("ardrone_adapter: missing parameter(s) %s: load config/ardrone_adapter.yaml (see "
                            "launch/ardrone_adapter.launch)" % ", ".join("~" + key for key in missing))
    try:
        loop = validated_parameters(values)
    except ValueError as error:
        raise SettingsError("ardrone_adapter: %s" % error)
    if values["altd_unit"] not in ("mm", "cm"):
        raise SettingsError("ardrone_adapter: ~altd_unit must be mm or cm, got %r" % (values["altd_unit"],))
    if not values["command_timeout"] > 0:
        raise SettingsError("ardrone_adapter: ~command_timeout must be > 0 s, got %r" % (values["command_timeout"],))
    return loop, values


class ArdroneAdapter:
    def __init__(self):
        loop_params, self.settings = read_settings()
        self.loop = TiltVelocityLoop(loop_params)
        self.command_rate = CommandRate(float(self.settings["command_rate"]))
        self.altd_check = AltdUnitCheck(self.settings["altd_unit"],
                                        samples_needed=int(self.settings["altd_check_samples"]))
        self.altd_verdict = None
        self.camera = BottomCameraSelect(frame_timeout=float(self.settings["camera_frame_timeout"]),
                                         service_timeout=float(self.settings["camera_service_timeout"]),
                                         max_attempts=int(self.settings["camera_select_attempts"]))
        self.camera_status = "not requested" if not self.settings["select_bottom_camera"] else "waiting"
        self.rejections = RosRejectionLog()
        self.lock = threading.Lock()
        self.velocity = None            # (stamp [s], Twist) of the last valid velocity command
        self.previous_stamp = None      # of the last navdata used by the loop [s]
        self.ground_pressure = None     # [Pa] at rest before the first take-off: the barometer's zero
        self.status = None

        self.handles = NodeHandles()
        self.pub_cmd = direct_publisher("cmd_vel", Twist)
        self.pub_navdata = direct_publisher("drone/navdata", Navdata)
        self.pub_sonar = direct_publisher("ardrone/sonar_height", Range)
        self.pub_altimeter = direct_publisher("ardrone/altimeter", Altimeter)
        self.pub_status = self.handles.latched(rospy.Publisher("~status", String, queue_size=1, latch=True))
        self.set_camera = rospy.ServiceProxy("ardrone/setcamchannel", CamSelect)
        self.handles.subscriber("velocity_cmd", Twist, self.on_velocity, queue_size=1, tcp_nodelay=True)
        self.handles.subscriber("ardrone/navdata", DriverNavdata, self.on_navdata, queue_size=5, tcp_nodelay=True)
        self.handles.subscriber("ardrone/bottom/camera_info", CameraInfo, self.on_camera_info, queue_size=1)
        self.lockstep = LockstepAcker("ardrone/navdata")
        self._publish_status()

    # ----- inputs ------------------------------------------------------------------------------------
    def on_velocity(self, msg):
        problem = numbers_problem(MAX_SPEED_MPS, linear=(msg.linear.x, msg.linear.y, msg.linear.z)) or \
            numbers_problem(MAX_RATE_RADPS, angular=(msg.angular.x, msg.angular.y, msg.angular.z))
        if problem:
            return self.rejections.reject("velocity_cmd", problem)
        with self.lock:
            self.velocity = (rospy.get_time(), msg)

    def on_camera_info(self, _msg):
        with self.lock:
            self.camera.frame_arrived(rospy.get_time())

    def on_navdata(self, msg):
        stamp = msg.header.stamp.to_sec()
        conversion = convert_navdata(msg, self.settings["altd_unit"], stamp=stamp)
        if conversion.problem:
            self.rejections.reject("ardrone/navdata", ("malformed navdata", conversion.problem))
        else:
            motor_share = (msg.motor1 + msg.motor2 + msg.motor3 + msg.motor4) / (4.0 * 255.0)
            self._publish_measurements(msg.header, conversion.navdata, motor_share)
            self._check_altd(msg.altd, conversion.navdata)
            self._command(conversion.navdata)
        self.lockstep.ack(msg.header.stamp)

    # ----- outputs -----------------------------------------------------------------------------------
    def _publish_measurements(self, header, nav, motor_share):
        self.pub_navdata.publish(Navdata(
            header=header, state=min(nav.state, 255), battery_percent=nav.battery, altitude=nav.height,
            vx=nav.velocity_heading[0], vy=nav.velocity_heading[1], vz=nav.climb, rot_x=math.degrees(nav.roll),
            rot_y=math.degrees(nav.pitch), rot_z=math.degrees(nav.yaw), motor_thrust=motor_share))
        in_range = SONAR_RANGE[0] <= nav.height <= SONAR_RANGE[1]
        self.pub_sonar.publish(Range(header=header, radiation_type=Range.ULTRASOUND, field_of_view=SONAR_FIELD_OF_VIEW,
                                     min_range=SONAR_RANGE[0], max_range=SONAR_RANGE[1],
                                     range=nav.height if in_range else math.inf))
        if nav.pressure is None:
            return
        if self.ground_pressure is None:
            if nav.airborne or nav.state == 6:
                return  # it took off before the adapter heard it at rest: no zero for the barometer
            self.ground_pressure = nav.pressure  # once: later landings (on the ground, say) keep this reference
        # The stack's altimeter is the altitude of base_link above the ground: the take-off point's plus the rise.
        self.pub_altimeter.publish(Altimeter(
            header=rospy.Header(stamp=header.stamp, frame_id="world"),
            altitude=self.settings["takeoff_altitude"] + pressure_altitude(nav.pressure, self.ground_pressure),
            pressure=nav.pressure / 100.0, qnh=self.ground_pressure / 100.0))

    def _check_altd(self, altd_raw, nav):
        if self.altd_verdict is not None or not nav.airborne or nav.pressure is None or self.ground_pressure is None:
            return
        # The reference is the barometer's rise above the take-off point: over the pad, the height above the pad, as
        # altd; over the ground the two differ by the pad's height, which the check's factor-of-2 tolerance absorbs.
        verdict = self.altd_check.add(altd_raw, pressure_altitude(nav.pressure, self.ground_pressure))
        if verdict is not None:
            self.altd_verdict = verdict
            log = rospy.loginfo if verdict.outcome == AGREES else rospy.logerr
            log("ardrone_adapter: altd unit check: %s", verdict.message)
            self._publish_status()

    def _command(self, nav):
        now = rospy.get_time()
        with self.lock:
            velocity = self.velocity
        fresh = velocity is not None and now - velocity[0] <= self.settings["command_timeout"]
        twist = velocity[1] if fresh else Twist()
        dt = nav.stamp - self.previous_stamp if self.previous_stamp is not None else 0.02
        if dt <= 0.0:
            return  # the same navdata again (the driver repeats the newest at its loop rate)
        self.previous_stamp = nav.stamp
        result = self.loop.update(twist.linear.x, twist.linear.y, twist.linear.z, twist.angular.z,
                                  nav.velocity_heading[0], nav.velocity_heading[1], nav.roll, nav.pitch, dt,
                                  airborne=nav.airborne)
        command = result.command
        if command is None:
            self.rejections.reject("cmd_vel", ("no command", result.reason))
            command = HOVER
        if self.command_rate.due(nav.stamp):
            out = Twist()
            (out.linear.x, out.linear.y, out.linear.z,
             out.angular.x, out.angular.y, out.angular.z) = command.as_tuple()
            self.pub_cmd.publish(out)

    def _publish_status(self):
        altd = "altd unit: %s" % (self.altd_verdict.message if self.altd_verdict else "not yet checked (in flight)")
        status = "bottom camera: %s; %s" % (self.camera_status, altd)
        if status != self.status:
            self.status = status
            self.pub_status.publish(String(data=status))

    # ----- the bottom camera's selection -------------------------------------------------------------
    def tick(self):
        if not self.settings["select_bottom_camera"]:
            return
        now = rospy.get_time()
        with self.lock:
            due = self.camera.request_due
            if due:
                self.camera.request_sent(now)
        if due:
            threading.Thread(target=self._request_bottom_camera, daemon=True).start()
        with self.lock:
            state = self.camera.tick(rospy.get_time())
        if state != self.camera_status:
            self.camera_status = state
            (rospy.logerr if state.startswith("failed") else rospy.loginfo)("ardrone_adapter: bottom camera %s", state)
            self._publish_status()

    def _request_bottom_camera(self):
        try:
            self.set_camera.wait_for_service(timeout=self.settings["camera_service_timeout"])
            ok = bool(self.set_camera(channel=BOTTOM_CHANNEL).result)
        except (rospy.ROSException, rospy.ServiceException) as error:
            rospy.logwarn("ardrone_adapter: ardrone/setcamchannel: %s", error)
            ok = False
        with self.lock:
            self.camera.service_answered(ok, rospy.get_time())

    def spin(self):
        rate = rospy.Rate(5.0)
        while not rospy.is_shutdown():
            self.tick()
            try:
                rate.sleep()
            except rospy.ROSInterruptException:
                break


def main():
    return run_node("ardrone_adapter", ArdroneAdapter, startup_errors=(SettingsError,))


if __name__ == "__main__":
    sys.exit(main())
