"""navsat_local: a GPS receiver's fixes -> nav_msgs/Odometry in a local ENU world frame (see enu.py).

  fix   sensor_msgs/NavSatFix        the receiver's position (e.g. nmea_navsat_driver)
  vel   geometry_msgs/TwistStamped   its ENU velocity, optional
  odom  nav_msgs/Odometry            one per valid fix, stamped with the fix's stamp, in ~world_frame
  ~status  std_msgs/String, latched  "ok" | "no fix: <reason>" | "waiting for datum" | "waiting for fix"

Only message stamps set times here (no rospy.Time.now()), so it runs the same under sim time and bag replay.
"""
import collections
import sys
import threading

import rospy
from geometry_msgs.msg import TwistStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import NavSatFix
from std_msgs.msg import String

from navsat_local.enu import (DEFAULT_SHARED_DATUM_PARAM, ConversionSettings, DatumError, LocalFrame,
                              VelocitySample, datum_from_fix, fill_odometry, fix_problem, local_odometry,
                              parse_datum, resolve_datum)

EXIT_BAD_PARAMETERS = 2
WARN_PERIOD_S = 5.0
DATUM_AGREEMENT_M = 0.01  # two datums closer than this are the same one (float round trips through the server)


class ParameterError(ValueError):
    """A required parameter is missing or malformed."""


def load_settings():
    """ConversionSettings from the private parameters (defaults where absent); ParameterError if one is bad."""
    defaults = ConversionSettings()
    values = {name: rospy.get_param("~" + name, getattr(defaults, name))
              for name in ConversionSettings.__dataclass_fields__}
    try:
        return ConversionSettings(**values)
    except ValueError as err:
        raise ParameterError(str(err)) from None


def required_string(name):
    value = rospy.get_param("~" + name, None)
    if not isinstance(value, str) or not value:
        raise ParameterError("~%s is required: a frame name (e.g. ardrone/base_link), got %r" % (name, value))
    return value


class NavSatLocal:
    def __init__(self, settings, world_frame, child_frame, datum_choice, shared_param):
        self.settings = settings
        self.world_frame = world_frame
        self.child_frame = child_frame
        self.shared_param = shared_param
        self.frame = LocalFrame.around(datum_choice.datum) if datum_choice.datum is not None else None
        # In first-fix mode another converter may store its datum between our read and our write of the shared
        # parameter (the server has no compare-and-set): the next fix reads it back once to catch that.
        self.check_shared_datum_on_next_fix = False
        self.lock = threading.Lock()
        self.velocity = None  # the latest VelocitySample
        self.warned_no_vel = False
        self.dropped = collections.Counter()  # reason -> fixes dropped for it
        self.published = 0
        self.status_text = None
        self.status_pub = rospy.Publisher("~status", String, queue_size=1, latch=True)
        self.odom_pub = rospy.Publisher("odom", Odometry, queue_size=10)
        if self.frame is None:
            self.set_status("waiting for datum")
        else:
            rospy.loginfo("navsat_local: datum %s (from %s)", self.frame.datum, datum_choice.source)
            self.set_status("waiting for fix")
        rospy.Subscriber("vel", TwistStamped, self.on_vel, queue_size=10)
        rospy.Subscriber("fix", NavSatFix, self.on_fix, queue_size=10)
        rospy.on_shutdown(self.log_summary)

    def set_status(self, text):
        if text != self.status_text:  # latched, so only a change is worth a message
            self.status_text = text
            self.status_pub.publish(String(data=text))

    def on_vel(self, msg):
        linear = msg.twist.linear
        with self.lock:
            self.velocity = VelocitySample(msg.header.stamp.to_sec(), linear.x, linear.y, linear.z)

    def on_fix(self, fix):
        problem = fix_problem(fix)
        if problem:
            return self.drop(problem)
        if self.frame is None:
            if not self.adopt_datum(fix):
                return
        elif self.check_shared_datum_on_next_fix:
            self.follow_shared_datum()
        with self.lock:
            velocity = self.velocity
        local = local_odometry(self.frame, fix, velocity, self.settings)
        self.note_velocity(local)
        self.odom_pub.publish(fill_odometry(Odometry(), local, fix.header.stamp, self.world_frame,
                                            self.child_frame))
        self.published += 1
        self.set_status("ok")

    def drop(self, reason):
        self.dropped[reason] += 1
        rospy.logwarn_throttle(WARN_PERIOD_S, "navsat_local: dropped a fix on %s: %s (%d dropped so far)",
                               rospy.resolve_name("fix"), reason, sum(self.dropped.values()))
        self.set_status("no fix: %s" % reason)

    def note_velocity(self, local):
        if local.velocity_known:
            return
        with self.lock:
            never_received = self.velocity is None
        if never_received:
            # `vel` is optional: say so once, not at every fix.
            if not self.warned_no_vel:
                rospy.loginfo("navsat_local: nothing on %s yet: velocity published as unknown (variance 1e6)",
                              rospy.resolve_name("vel"))
                self.warned_no_vel = True
        else:
            rospy.logwarn_throttle(WARN_PERIOD_S, "navsat_local: velocity unknown: %s",
                                   ", ".join(local.notes))

    def adopt_datum(self, fix):
        """First-fix mode: the shared datum if another converter stored one meanwhile, else this fix's, stored
        for the others. False when the shared one is malformed (nothing is published then)."""
        shared = rospy.get_param(self.shared_param, None)
        if shared is not None:
            try:
                datum = parse_datum(shared, self.shared_param)
            except DatumError as err:
                rospy.logerr_throttle(WARN_PERIOD_S, "navsat_local: %s; fix it or delete it", err)
                self.set_status("waiting for datum")
                return False
            source = self.shared_param
        else:
            datum = datum_from_fix(fix)
            rospy.set_param(self.shared_param, datum.as_param())
            self.check_shared_datum_on_next_fix = True
            source = "the first valid fix, stored in %s" % self.shared_param
        self.frame = LocalFrame.around(datum)
        rospy.loginfo("navsat_local: datum %s (from %s)", datum, source)
        return True

    def follow_shared_datum(self):
        self.check_shared_datum_on_next_fix = False
        try:
            shared = parse_datum(rospy.get_param(self.shared_param, None), self.shared_param)
        except DatumError:
            return  # deleted or spoiled after we stored it: ours stands
        if self.frame.distance_to(shared) > DATUM_AGREEMENT_M:
            rospy.logerr("navsat_local: another converter stored its datum in %s at the same time; following "
                         "it (%s) so both share one frame: the odometry jumps once", self.shared_param, shared)
            self.frame = LocalFrame.around(shared)

    def log_summary(self):
        dropped = ", ".join("%d x %s" % (n, reason) for reason, n in self.dropped.most_common()) or "none"
        rospy.loginfo("navsat_local: %d odometry messages published; fixes dropped: %s", self.published, dropped)


def main():
    rospy.init_node("navsat_local")
    try:
        settings = load_settings()
        world_frame = rospy.get_param("~world_frame", "world")
        child_frame = required_string("child_frame")
        shared_param = rospy.get_param("~shared_datum_param", DEFAULT_SHARED_DATUM_PARAM)
        if not isinstance(world_frame, str) or not world_frame:
            raise ParameterError("~world_frame must be a frame name, got %r" % (world_frame,))
        if not isinstance(shared_param, str) or not shared_param:
            raise ParameterError("~shared_datum_param must be a parameter name, got %r" % (shared_param,))
        from_first_fix = rospy.get_param("~datum_from_first_fix", False)
        if not isinstance(from_first_fix, bool):
            raise ParameterError("~datum_from_first_fix must be true or false, got %r" % (from_first_fix,))
        shared_param = rospy.resolve_name(shared_param)
        private_datum = rospy.get_param("~datum", None)
        shared_datum = rospy.get_param(shared_param, None)
        choice = resolve_datum(private_datum, shared_datum, from_first_fix, shared_param)
    except (ParameterError, DatumError) as err:
        rospy.logfatal("navsat_local: %s", err)
        sys.exit(EXIT_BAD_PARAMETERS)
    if choice.source == "~datum" and shared_datum is not None:
        warn_if_datums_differ(choice.datum, shared_datum, shared_param)
    NavSatLocal(settings, world_frame, child_frame, choice, shared_param)
    rospy.spin()


def warn_if_datums_differ(own, shared_value, shared_param):
    """An explicit ~datum wins, but one far from the shared datum puts this vehicle in another frame."""
    try:
        shared = parse_datum(shared_value, shared_param)
    except DatumError:
        return
    distance = LocalFrame.around(own).distance_to(shared)
    if distance > DATUM_AGREEMENT_M:
        rospy.logwarn("navsat_local: ~datum is %.3f m from %s: this odometry and that of converters using %s are in "
                      "different frames", distance, shared_param, shared_param)
