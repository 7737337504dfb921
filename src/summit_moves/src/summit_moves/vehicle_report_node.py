"""vehicle_report: the rospy shell around summit_moves.vehicle_report (the fusion and its conventions are there).

  fix     sensor_msgs/NavSatFix        in   the vehicle's GPS receiver (launch: summit_xl/gps/fix)
  vel     geometry_msgs/TwistStamped   in   its ENU velocity (launch: summit_xl/gps/vel); optional
  odom    nav_msgs/Odometry            in   the vehicle controller's odometry (launch: robotnik_base_control/odom)
  report  nav_msgs/Odometry            out  one per fix, stamped with it, in ~world_frame (launch: summit_xl/gps/odom)
  ~status std_msgs/String, latched     out  "ok" | "degraded: <what is unknown>" | "no report: <why>"

Only message stamps set the report's time; the receipt time (ROS time, sim time under the simulator) only bounds how
long a fix waits for its velocity. ``~reset`` (std_srvs/Trigger, a warm graph between scenarios) starts afresh from the
parameters as they are then (landing_runtime.rospy_node.ResettableNode).
"""
import threading

import rospy
from geometry_msgs.msg import TwistStamped
from landing_runtime.lockstep import LockstepAcker
from landing_runtime.rospy_node import NodeHandles, direct_publisher, run_node
from nav_msgs.msg import Odometry
from navsat_local.enu import (DatumError, LocalFrame, datum_from_fix, fix_problem,
                              parse_datum, resolve_datum)
from sensor_msgs.msg import NavSatFix
from std_msgs.msg import String

from .vehicle_report import (ReportSettings, SettingsError, VehicleReporter, fill_odometry, odom_sample,
                             velocity_sample)

WARN_PERIOD_S = 5.0
TICK_RATE_HZ = 50.0         # how often a fix waiting for its velocity is looked at [Hz]
DATUM_AGREEMENT_M = 0.01    # two datums closer than this are the same one


class StartupError(RuntimeError):
    """A missing or bad parameter; the message names it."""


def _required(name, kind, what):
    if not rospy.has_param("~" + name):
        raise StartupError("vehicle_report: required parameter '~%s' (%s) is not set; see "
                           "summit_moves/config/vehicle_report.yaml" % (name, what))
    value = rospy.get_param("~" + name)
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        value = float(value)
    if not isinstance(value, kind) or (kind is str and not value) or (kind is float and not value > 0.0):
        raise StartupError("vehicle_report: parameter '~%s' must be %s, got %r" % (name, what, value))
    return value


class Throttled:
    """One warning per kind every WARN_PERIOD_S of ROS time, with the count of the ones it stood for."""

    def __init__(self):
        self.last, self.count = {}, {}

    def warn(self, kind, text):
        now = rospy.get_time()
        self.count[kind] = self.count.get(kind, 0) + 1
        if now - self.last.get(kind, -1e9) >= WARN_PERIOD_S or now < self.last[kind]:
            self.last[kind] = now
            rospy.logwarn("vehicle_report: %s (%d time(s) since the last such warning)", text, self.count[kind])
            self.count[kind] = 0


class VehicleReportNode:
    rate_hz = TICK_RATE_HZ

    def __init__(self):
        private = rospy.get_param("~", {})
        try:
            self.settings = ReportSettings.from_mapping(private)
        except SettingsError as err:
            raise StartupError("vehicle_report: %s" % err) from None
        self.world_frame = _required("world_frame", str, "the report's frame, e.g. world")
        self.child_frame = _required("child_frame", str, "the vehicle's base frame, e.g. summit_xl/base_link")
        self.shared_param = rospy.resolve_name(_required("shared_datum_param", str, "a parameter name"))
        self.from_first_fix = _required("datum_from_first_fix", bool, "true or false")
        self.datum_check_s = _required("datum_check_s", float, "a positive number of seconds")
        self.lock = threading.Lock()
        self.warnings = Throttled()
        self.reporter = VehicleReporter(self.settings, self._initial_frame())
        self.next_datum_check = 0.0
        self.status_text = None
        self.handles = NodeHandles()
        self.status_pub = self.handles.latched(rospy.Publisher("~status", String, queue_size=1, latch=True))
        self.report_pub = direct_publisher("report", Odometry)
        self.lockstep = LockstepAcker("fix")
        self._set_status("waiting for fix")
        self.handles.subscriber("odom", Odometry, self._on_odom, queue_size=50, tcp_nodelay=True)
        self.handles.subscriber("vel", TwistStamped, self._on_vel, queue_size=10, tcp_nodelay=True)
        self.handles.subscriber("fix", NavSatFix, self._on_fix, queue_size=10, tcp_nodelay=True)
        rospy.loginfo("vehicle_report: %s + %s + %s -> %s", rospy.resolve_name("fix"), rospy.resolve_name("vel"),
                      rospy.resolve_name("odom"), rospy.resolve_name("report"))

    # --- datum
    def _initial_frame(self):
        """The frame of ~datum or the shared datum; None (a warning) while there is none yet."""
        private = rospy.get_param("~datum", None)
        shared = rospy.get_param(self.shared_param, None)
        try:
            choice = resolve_datum(private, shared, self.from_first_fix, self.shared_param)
        except DatumError as err:
            if private is not None:
                raise StartupError("vehicle_report: %s" % err) from None  # our own ~datum is malformed: fix it
            rospy.logwarn("vehicle_report: %s. Until then every report has its position unknown.", err)
            self.datum_source = self.shared_param
            return None
        self.datum_source = choice.source
        if choice.datum is None:
            rospy.loginfo("vehicle_report: the datum will be the first valid fix")
            return None
        rospy.loginfo("vehicle_report: datum %s (from %s)", choice.datum, choice.source)
        return LocalFrame.around(choice.datum)

    def _check_shared_datum(self):
        """Follow the shared datum: it appears late, or it changed (a stale frame would misplace every fix)."""
        if self.datum_source == "~datum":
            return
        value = rospy.get_param(self.shared_param, None)
        if value is None:
            if self.reporter.frame is None and not self.from_first_fix:
                self.warnings.warn("datum", "no datum: %s is not set, so the position is reported unknown"
                                   % self.shared_param)
            return
        try:
            datum = parse_datum(value, self.shared_param)
        except DatumError as err:
            self.warnings.warn("datum", "%s; %s" % (err, "keeping the datum in use" if self.reporter.frame else
                                                          "the position is reported unknown"))
            return
        frame = self.reporter.frame
        if frame is None or frame.distance_to(datum) > DATUM_AGREEMENT_M:
            if frame is not None:
                rospy.logwarn("vehicle_report: %s changed to %s, %.1f m from the datum in use: following it",
                              self.shared_param, datum, frame.distance_to(datum))
            else:
                rospy.loginfo("vehicle_report: datum %s (from %s)", datum, self.shared_param)
            with self.lock:
                self.reporter.frame = LocalFrame.around(datum)

    def _adopt_first_fix(self, fix):
        if self.reporter.frame is not None or not self.from_first_fix or fix_problem(fix):
            return
        shared = rospy.get_param(self.shared_param, None)
        if shared is None:
            datum = datum_from_fix(fix)
            rospy.set_param(self.shared_param, datum.as_param())
            rospy.loginfo("vehicle_report: datum %s (the first valid fix, stored in %s)", datum, self.shared_param)
            self.reporter.frame = LocalFrame.around(datum)
        # else: another converter stored its datum meanwhile; the next datum check takes it

    # --- inputs
    def _on_odom(self, msg):
        p, t = msg.pose, msg.twist
        q = p.pose.orientation
        try:
            sample = odom_sample(msg.header.stamp.to_sec(), (q.x, q.y, q.z, q.w), p.covariance,
                                 (t.twist.linear.x, t.twist.linear.y), t.twist.angular.z, t.covariance, self.settings)
        except ValueError as err:
            return self.warnings.warn("odom", "dropped an odometry message on %s: %s"
                                      % (rospy.resolve_name("odom"), err))
        with self.lock:
            self.reporter.add_odometry(sample)

    def _on_vel(self, msg):
        try:
            sample = velocity_sample(msg.header.stamp.to_sec(), msg.twist.linear.x, msg.twist.linear.y)
        except ValueError as err:
            return self.warnings.warn("vel", "dropped a velocity on %s: %s" % (rospy.resolve_name("vel"), err))
        with self.lock:
            released = self.reporter.add_velocity(sample)
        self._publish(released)

    def _on_fix(self, fix):
        with self.lock:
            self._adopt_first_fix(fix)
            released = self.reporter.add_fix(fix, rospy.get_time())
        self._publish(released)
        self.lockstep.ack(fix.header.stamp)

    def tick(self):
        """At rate_hz of ROS time: release a fix that waited long enough for its velocity; read the datum again."""
        now = rospy.get_time()
        with self.lock:
            released = self.reporter.flush(now)
        self._publish(released)
        if now >= self.next_datum_check or now < self.next_datum_check - self.datum_check_s:
            self.next_datum_check = now + self.datum_check_s
            self._check_shared_datum()

    # --- output
    def _publish(self, released):
        for report, reason in released:
            if report is None:
                self.warnings.warn(reason.split(":")[0], "no report on %s for the fix on %s: %s" % (
                    rospy.resolve_name("report"), rospy.resolve_name("fix"), reason))
                self._set_status("no report: %s" % reason)
                continue
            self.report_pub.publish(fill_odometry(Odometry(), report, report.stamp,
                                                  self.world_frame, self.child_frame))
            for note in report.notes:  # (named with the input, so that a bad fix is traced to its receiver)
                self.warnings.warn(note.split(":")[0], "%s (the fix on %s)" % (note, rospy.resolve_name("fix")))
            self._set_status("degraded: %s" % "; ".join(report.notes) if report.notes else "ok")

    def _set_status(self, text):
        if text != self.status_text:  # latched: only a change is worth a message
            self.status_text = text
            self.status_pub.publish(String(data=text))


def main():
    return run_node("vehicle_report", VehicleReportNode, startup_errors=(StartupError,), resettable=True)
