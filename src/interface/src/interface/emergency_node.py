"""emergency node: thin ROS wrapper of interface.emergency.EmergencyLanding (thesis chapter 3.5).

Engages when supervisor/mode is ``emergency`` (or at once with ``~engage: immediately``, the thesis'
emergency.launch on its own). Publishes emergency/cmd_vel (forwarded by cmd_vel_mux), ardrone/land,
emergency/position (landing_msgs/PositionXYCommand, from ardrone/odom_estimate, else ardrone/gps/odom)
every ``~report_period_s`` until ``ack`` on operator/command, and emergency/state (latched phase).

Restarted after a crash (respawn in emergency.launch) it reads the latched supervisor/mode and carries on: in
emergency mode it lands (or, on the ground already, reports the coordinates again until acknowledged).
Garbage on an input is dropped with a throttled warning saying what was wrong.
"""
import sys
import threading

import rospy
from geometry_msgs.msg import PointStamped, Twist
from landing_runtime.message_constants import message_constants
from landing_runtime.input_check import (MAX_ALTITUDE_M, MAX_POSITION_M, RosRejectionLog, choice_problem, first_problem,
                                      frame_problem, numbers_problem, stamp_problem)
from landing_runtime.lockstep import LockstepAcker
from landing_msgs.msg import Altimeter, Navdata, PositionXYCommand, SupervisorMode
from landing_runtime.rospy_node import NodeHandles, direct_publisher, run_node
from nav_msgs.msg import Odometry
from sensor_msgs.msg import Range
from std_msgs.msg import Empty, String

from .emergency import EmergencyLanding, EmergencySettings, Phase, SettingsError
from .supervisor import OPERATOR_COMMANDS
from .supervisor_measures import flight_from_navdata

ENGAGE = ("on_mode", "immediately")
MODES = message_constants(SupervisorMode)
NAVDATA_STATES = message_constants(Navdata, "STATE_")
WORLD_FRAME, BODY_FRAME = "world", "ardrone/base_link"  # docs/conventions.md


def _header_problem(msg, frame=None):
    return first_problem(stamp_problem(msg.header.stamp.to_sec(), rospy.get_time()),
                         frame_problem(msg.header.frame_id, frame) if frame else None)


class EmergencyNode:
    def __init__(self):
        private = rospy.get_param("~", {})
        where = "emergency (%s, config/emergency.yaml)" % rospy.get_name()
        self.settings = EmergencySettings.from_mapping(private, where)
        self.engage = private.get("engage", "on_mode")
        if self.engage not in ENGAGE:
            raise SettingsError("%s: parameter '~engage' must be one of %s, got %r" % (where, ", ".join(ENGAGE),
                                                                                        self.engage))
        self.rate_hz = private.get("rate_hz", 10.0)
        if isinstance(self.rate_hz, bool) or not isinstance(self.rate_hz, (int, float)) or not 1 <= self.rate_hz <= 100:
            raise SettingsError("%s: parameter '~rate_hz' must be a number in 1..100, got %r" % (where, self.rate_hz))
        self.core = EmergencyLanding(self.settings, log=self._log)
        self.lock = threading.Lock()  # subscriber threads feed the core, the loop steps it
        self.mode = None
        self.pending = []  # mode changes and acks, applied in the loop in arrival order

        self.pub_cmd = direct_publisher("emergency/cmd_vel", Twist)
        self.pub_land = rospy.Publisher("ardrone/land", Empty, queue_size=1)
        self.pub_position = rospy.Publisher("emergency/position", PositionXYCommand, queue_size=5)
        self.handles = NodeHandles()
        self.pub_state = self.handles.latched(rospy.Publisher("emergency/state", String, queue_size=1, latch=True))
        self.pub_state.publish(String(data=Phase.INACTIVE.value))
        self.state_sent = Phase.INACTIVE
        self.lockstep = LockstepAcker(period=1.0 / self.rate_hz)

        self.rejections = RosRejectionLog()
        checked = self._checked
        self.handles.subscriber("supervisor/mode", String, checked(
            "supervisor/mode", lambda m: choice_problem(m.data, MODES, "mode"),
            lambda m: self.pending.append(("mode", m.data))), queue_size=5)
        self.handles.subscriber("operator/command", String, checked(
            "operator/command", lambda m: choice_problem(m.data.strip().lower(), OPERATOR_COMMANDS, "command"),
            self._on_operator), queue_size=10, commands=True)
        position_problem = lambda m: _header_problem(m, WORLD_FRAME) or numbers_problem(  # noqa: E731
            MAX_POSITION_M, position=(m.pose.pose.position.x, m.pose.pose.position.y))
        self.handles.subscriber("ardrone/odom_estimate", Odometry, checked(
            "ardrone/odom_estimate", position_problem, self._estimate("odom_estimate")), queue_size=1)
        self.handles.subscriber("ardrone/gps/odom", Odometry, checked(
            "ardrone/gps/odom", position_problem, self._estimate("gps")), queue_size=1)
        self.handles.subscriber("platform/current_platform_position_in_ardrone", PointStamped, checked(
            "platform/current_platform_position_in_ardrone",
            lambda m: _header_problem(m, BODY_FRAME) or numbers_problem(MAX_ALTITUDE_M, point=(m.point.x, m.point.y)),
            lambda m: self.core.on_pad(rospy.get_time(), m.point.x, m.point.y)), queue_size=1)
        self.handles.subscriber("ardrone/altimeter", Altimeter, checked(
            "ardrone/altimeter", lambda m: _header_problem(m) or numbers_problem(MAX_ALTITUDE_M, altitude=m.altitude),
            lambda m: self.core.on_altitude(rospy.get_time(), m.altitude)), queue_size=1)
        self.handles.subscriber("ardrone/sonar_height", Range, checked(
            "ardrone/sonar_height", lambda m: _header_problem(m, BODY_FRAME) or (
                ("out of range", "range is %s" % m.range) if not m.range >= 0.0 else None),  # +inf: no echo
            lambda m: self.core.on_sonar(rospy.get_time(), m.range)), queue_size=1)
        self.handles.subscriber("drone/navdata", Navdata, checked(
            "drone/navdata", lambda m: choice_problem(m.state, NAVDATA_STATES, "state") or _header_problem(m),
            lambda m: self.core.on_flight(rospy.get_time(), flight_from_navdata(m.state))), queue_size=1)

    def _checked(self, topic, problem_of, callback):
        """A subscriber callback that drops a message ``problem_of`` finds fault with, else runs ``callback``
        under the lock."""
        def locked(msg):
            problem = problem_of(msg)
            if problem:
                return self.rejections.reject(topic, problem)
            with self.lock:
                callback(msg)
        return locked

    @staticmethod
    def _log(level, text):
        (rospy.logwarn if level == "warn" else rospy.loginfo)(text)

    def _estimate(self, source):
        def callback(msg):
            p = msg.pose.pose.position
            self.core.on_estimate(rospy.get_time(), source, p.x, p.y)
        return callback

    def _on_operator(self, msg):
        if msg.data.strip().lower() == "ack":
            self.pending.append(("ack", None))

    def _apply_pending(self, t):
        while self.pending:
            kind, value = self.pending.pop(0)
            if kind == "ack":
                self.core.acknowledge(t)
            elif value != self.mode:
                self.mode = value
                if value == SupervisorMode.EMERGENCY:
                    self.core.activate(t, "supervisor mode emergency")
                elif self.engage == "on_mode":
                    self.core.deactivate(t, "supervisor mode %s" % value)

    def tick(self):
        now = rospy.Time.now()
        with self.lock:
            self._tick(now.to_sec())
        self.lockstep.ack(now)

    def _tick(self, t):
        self._apply_pending(t)
        if self.engage == "immediately" and self.core.phase is Phase.INACTIVE and not self.core.acknowledged:
            self.core.activate(t, "emergency.launch started on its own")
        out = self.core.step(t)
        if out.land:
            self.pub_land.publish(Empty())
        if out.cmd is not None:
            cmd = Twist()
            cmd.linear.x, cmd.linear.y = out.cmd
            self.pub_cmd.publish(cmd)
        if out.report is not None:
            x, y, source = out.report
            self.pub_position.publish(PositionXYCommand(x=x, y=y))
            rospy.loginfo_throttle(5.0, "emergency: drone at x=%.2f m, y=%.2f m (%s); send 'ack' on "
                                   "operator/command to stop the report" % (x, y, source))
        elif self.core.phase is not Phase.INACTIVE and not self.core.acknowledged and self.core.position(t) is None:
            rospy.logwarn_throttle(5.0, "emergency: no position estimate (neither ardrone/odom_estimate nor "
                                   "ardrone/gps/odom): cannot report the coordinates")
        if out.phase is not self.state_sent:
            self.pub_state.publish(String(data=out.phase.value))
            self.state_sent = out.phase

def main():
    return run_node("emergency", EmergencyNode, startup_errors=(SettingsError,), resettable=True)


if __name__ == "__main__":
    sys.exit(main())
