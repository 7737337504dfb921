"""The vehicle's report to the stack (summit_xl/gps/odom) from its real interfaces, without ROS.

A real Summit XL (or car) tells the stack where it is through three drivers, none of which speaks the stack's
local frame:
  fix   sensor_msgs/NavSatFix        its GPS receiver (e.g. nmea_navsat_driver): latitude, longitude, altitude
  vel   geometry_msgs/TwistStamped   the receiver's velocity, ENU (linear.x east, linear.y north)
  odom  nav_msgs/Odometry            its controller's odometry (Robotnik's robotnik_base_control/odom): the pose in
                                     the controller's odom frame, the twist in the base frame (linear.x forward
                                     speed, angular.z yaw rate)
This module fuses them into the one nav_msgs/Odometry the stack reads (ped_traj_pred's pad filter, the tracker's
estimator, the supervisor, the operator station), with the conventions of the simulator's former ready-made report:

  header.frame_id   the local ENU world frame;  child_frame_id the vehicle's base frame; stamp = the fix's stamp
  pose.position     the fix in ENU around the datum; variance UNKNOWN_VARIANCE (1e6) when there is no usable fix
                    (NO_FIX, NaN, no datum, a datum of another site): the rest of the report still holds
  pose.orientation  the vehicle's heading (yaw about up, from east), from the odometry
  twist.linear      the vehicle's ENU velocity [m/s]: the receiver's when fresh, else the odometry's speed along its
                    heading (NOT the base frame REP 105 would use: the stack's consumers read it as world velocity)
  twist.angular.z   the yaw rate [rad/s], from the odometry
  covariances       6x6 row-major, diagonal: x, y, z of the position, then the heading variance on the three
                    rotational entries; the velocity's variance on the three linear entries, the yaw rate's on the
                    three angular ones. A quantity not measured is a finite 0 with UNKNOWN_VARIANCE, never a NaN.

A report is only made when its velocity is known (the supervisor and the estimator take the velocity whatever its
variance): without a fresh `vel` and without the odometry there is no report, and the reason says so.

Everything here takes plain numbers or duck-typed messages (anything with a NavSatFix's attribute names), so that
it runs and is tested without a ROS master; node_vehicle_report.py is the rospy shell around it.
"""
import bisect
import collections
import math
from dataclasses import dataclass

from navsat_local.enu import ConversionSettings, fix_problem, position_covariance

UNKNOWN_VARIANCE = 1e6  # the stack's "not measured" covariance entry (ped_traj_pred's kUnknownVariance)
PAIR_TOLERANCE_S = 1e-3  # a vel stamped this close to a fix is the same epoch's [s]


class SettingsError(ValueError):
    """A setting is missing or out of range: the node cannot start."""


@dataclass(frozen=True)
class ReportSettings:
    """The node's tuning, as in config/vehicle_report.yaml (units in the names)."""
    gps_velocity_std_mps: float = 0.1
    vel_max_age_s: float = 0.5
    vel_wait_s: float = 0.1
    odom_max_age_s: float = 0.25
    odom_buffer_s: float = 2.0
    odom_yaw_offset_deg: float = 0.0
    heading_std_deg_if_unknown: float = 2.0
    yaw_rate_std_if_unknown: float = 0.02
    speed_std_if_unknown: float = 0.1
    unknown_horizontal_std_m: float = 5.0
    unknown_vertical_std_m: float = 10.0
    min_position_std_m: float = 0.01
    max_distance_from_datum_m: float = 50000.0

    POSITIVE = ("gps_velocity_std_mps", "vel_max_age_s", "odom_max_age_s", "odom_buffer_s",
                "heading_std_deg_if_unknown", "yaw_rate_std_if_unknown", "speed_std_if_unknown",
                "unknown_horizontal_std_m", "unknown_vertical_std_m", "min_position_std_m",
                "max_distance_from_datum_m")

    def __post_init__(self):
        for name in self.__dataclass_fields__:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise SettingsError("~%s must be a finite number, got %r" % (name, value))
            if name in self.POSITIVE and value <= 0.0:
                raise SettingsError("~%s must be positive, got %r" % (name, value))
        if self.vel_wait_s < 0.0:
            raise SettingsError("~vel_wait_s must be >= 0, got %r" % (self.vel_wait_s,))
        if not -360.0 <= self.odom_yaw_offset_deg <= 360.0:
            raise SettingsError("~odom_yaw_offset_deg must be within [-360, 360], got %r" % (self.odom_yaw_offset_deg,))
        if self.odom_buffer_s < self.odom_max_age_s:
            raise SettingsError("~odom_buffer_s (%g) must be at least ~odom_max_age_s (%g)"
                                % (self.odom_buffer_s, self.odom_max_age_s))

    @classmethod
    def from_mapping(cls, values):
        """ReportSettings from a parameter mapping: every field must be there (SettingsError names a missing one)."""
        missing = [name for name in cls.__dataclass_fields__ if name not in values]
        if missing:
            raise SettingsError("required parameter(s) %s not set (see summit_moves/config/vehicle_report.yaml)"
                                % ", ".join("~" + name for name in missing))
        return cls(**{name: values[name] for name in cls.__dataclass_fields__})

    def conversion(self):
        """navsat_local's settings for the position covariance of a fix."""
        return ConversionSettings(unknown_horizontal_std_m=self.unknown_horizontal_std_m,
                                  unknown_vertical_std_m=self.unknown_vertical_std_m,
                                  min_position_std_m=self.min_position_std_m)


# ---------------------------------------------------------------------------------------------- inputs


def _finite(*values):
    return all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in values)


def _stated_variance(value):
    """A driver's variance as given: None when not filled (0, negative, not finite), UNKNOWN when it says unknown."""
    if not _finite(value) or value <= 0.0:
        return None
    return min(float(value), UNKNOWN_VARIANCE)


def wrap_angle(angle):
    return math.atan2(math.sin(angle), math.cos(angle))


def yaw_of_quaternion(x, y, z, w):
    """Yaw [rad] (rotation about z, ZYX convention) of a quaternion; ValueError if it is not finite or zero."""
    if not _finite(x, y, z, w):
        raise ValueError("orientation is not finite")
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if norm < 1e-6:
        raise ValueError("orientation is a zero quaternion")
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


VelocitySample = collections.namedtuple("VelocitySample", "stamp_s east_mps north_mps")
VelocitySample.__doc__ = """A receiver's `vel` (TwistStamped, ENU) in plain numbers."""

OdomSample = collections.namedtuple("OdomSample", "stamp_s heading_rad heading_var speed_x speed_y speed_var "
                                                  "yaw_rate yaw_rate_var")
OdomSample.__doc__ = """The controller's odometry in the stack's terms: the heading in ENU [rad] and its variance,
the base-frame velocity (forward, left) [m/s] and its variance, the yaw rate [rad/s] and its variance."""


def velocity_sample(stamp_s, east, north):
    """A VelocitySample, or ValueError saying what is wrong with the message."""
    if not _finite(stamp_s) or stamp_s <= 0.0:
        raise ValueError("vel header.stamp is zero")
    if not _finite(east, north):
        raise ValueError("vel twist.linear is not finite (%r, %r)" % (east, north))
    return VelocitySample(float(stamp_s), float(east), float(north))


def odom_sample(stamp_s, orientation_xyzw, pose_covariance, linear_xy, angular_z, twist_covariance, settings):
    """An OdomSample from a nav_msgs/Odometry's fields, or ValueError saying what is wrong with them.

    The pose's yaw is the heading in the odometry's frame; ~odom_yaw_offset_deg turns it into ENU (0: the odom
    frame's x points east, as the Summit XL's IMU-fused odometry gives it and the simulator emulates). A variance the
    driver did not fill (0) takes the configured default; one it states as unknown (>= 1e6) makes that part unknown.
    """
    if not _finite(stamp_s) or stamp_s <= 0.0:
        raise ValueError("odometry header.stamp is zero")
    yaw = yaw_of_quaternion(*orientation_xyzw)
    if not _finite(*linear_xy):
        raise ValueError("odometry twist.linear is not finite (%r, %r)" % tuple(linear_xy))
    if not _finite(angular_z):
        raise ValueError("odometry twist.angular.z is not finite (%r)" % (angular_z,))
    if len(pose_covariance) != 36 or len(twist_covariance) != 36:
        raise ValueError("odometry covariances are not 6x6")
    heading_var = _stated_variance(pose_covariance[35])
    speed_var = _stated_variance(twist_covariance[0])
    yaw_rate_var = _stated_variance(twist_covariance[35])
    return OdomSample(
        float(stamp_s), wrap_angle(yaw + math.radians(settings.odom_yaw_offset_deg)),
        math.radians(settings.heading_std_deg_if_unknown) ** 2 if heading_var is None else heading_var,
        float(linear_xy[0]), float(linear_xy[1]),
        settings.speed_std_if_unknown ** 2 if speed_var is None else speed_var,
        float(angular_z), settings.yaw_rate_std_if_unknown ** 2 if yaw_rate_var is None else yaw_rate_var)


# ---------------------------------------------------------------------------------------------- the report


Report = collections.namedtuple("Report", "stamp stamp_s position pose_covariance heading velocity twist_covariance "
                                          "yaw_rate notes")
Report.__doc__ = """One summit_xl/gps/odom in plain numbers: the fix's stamp (as it came, and in seconds), ENU
position [m] (0s when unknown), 6x6 covariances, heading [rad], ENU velocity [m/s], yaw rate [rad/s], and notes on what
was unknown and why (empty when all known)."""


def _diagonal6(linear, angular):
    matrix = [0.0] * 36
    for i, variance in enumerate(tuple(linear) + tuple(angular)):
        matrix[7 * i] = variance
    return matrix


def _position(frame, fix, settings):
    """(ENU position, its three variances, note or None) of a fix; the note says why the position is unknown."""
    unknown = ((0.0, 0.0, 0.0), (UNKNOWN_VARIANCE,) * 3)
    problem = fix_problem(fix)
    if problem:
        return unknown + ("fix: %s" % problem,)
    if frame is None:
        return unknown + ("no datum for the local frame (waiting for /navsat_datum)",)
    position = frame.to_enu(fix.latitude, fix.longitude, fix.altitude)
    distance = math.hypot(position[0], position[1])
    if distance > settings.max_distance_from_datum_m:
        return unknown + ("fix is %.1f km from the datum (%s), more than max_distance_from_datum_m: a datum of "
                          "another site?" % (distance / 1000.0, frame.datum),)
    covariance, _ = position_covariance(fix.position_covariance, fix.position_covariance_type,
                                        settings.conversion())
    return position, (covariance[0], covariance[4], covariance[8]), None


def make_report(frame, fix, velocity, odometry, settings):
    """(Report, None) for a NavSatFix ``fix`` with the epoch's `vel` sample and the odometry sample nearest the
    fix (either may be None), in the LocalFrame ``frame`` (None: no datum yet); (None, reason) when no honest
    report can be made (a zero stamp, or no velocity from either source)."""
    stamp = fix.header.stamp
    if stamp.secs == 0 and stamp.nsecs == 0:
        return None, "fix header.stamp is zero: the report could not be placed in time"
    stamp_s = stamp.secs + stamp.nsecs * 1e-9
    notes = []
    position, position_vars, note = _position(frame, fix, settings)
    if note:
        notes.append("position unknown: " + note)

    if odometry is not None and abs(odometry.stamp_s - stamp_s) > settings.odom_max_age_s:
        notes.append("heading and yaw rate unknown: the odometry nearest the fix is %.2f s from it (max %.2f s)"
                     % (abs(odometry.stamp_s - stamp_s), settings.odom_max_age_s))
        odometry = None
    elif odometry is None:
        notes.append("heading and yaw rate unknown: no odometry")
    if odometry is not None and odometry.heading_var < UNKNOWN_VARIANCE:
        heading, heading_var = odometry.heading_rad, odometry.heading_var
    else:
        heading, heading_var = 0.0, UNKNOWN_VARIANCE
    if odometry is not None and odometry.yaw_rate_var < UNKNOWN_VARIANCE:
        yaw_rate, yaw_rate_var = odometry.yaw_rate, odometry.yaw_rate_var
    else:
        yaw_rate, yaw_rate_var = 0.0, UNKNOWN_VARIANCE

    gps_velocity_note = None
    if velocity is None:
        gps_velocity_note = "no vel"
    elif abs(velocity.stamp_s - stamp_s) > settings.vel_max_age_s:
        gps_velocity_note = "vel is %.2f s from the fix (max %.2f s)" % (abs(velocity.stamp_s - stamp_s),
                                                                        settings.vel_max_age_s)
    if gps_velocity_note is None:
        ground_velocity = (velocity.east_mps, velocity.north_mps)
        velocity_var = settings.gps_velocity_std_mps ** 2
    elif heading_var < UNKNOWN_VARIANCE and odometry.speed_var < UNKNOWN_VARIANCE:
        # The odometry's base-frame velocity turned by its heading: the heading's error moves it sideways.
        c, s = math.cos(heading), math.sin(heading)
        ground_velocity = (c * odometry.speed_x - s * odometry.speed_y, s * odometry.speed_x + c * odometry.speed_y)
        speed_sq = odometry.speed_x ** 2 + odometry.speed_y ** 2
        velocity_var = odometry.speed_var + speed_sq * heading_var
    else:
        return None, "velocity unknown: %s and no odometry with a heading and a speed" % gps_velocity_note
    return Report(stamp, stamp_s, position, _diagonal6(position_vars, (heading_var,) * 3), heading,
                  ground_velocity, _diagonal6((velocity_var,) * 3, (yaw_rate_var,) * 3), yaw_rate,
                  tuple(notes)), None


# ---------------------------------------------------------------------------------------------- the fusion


class VehicleReporter:
    """The inputs as they come (any order, any thread-free caller), the reports as they are ready.

    ``add_odometry`` and ``add_velocity`` take samples (odom_sample, velocity_sample); ``add_fix`` takes a
    NavSatFix-like message and the receipt time ``now_s`` (the caller's clock). A fix is reported with the `vel`
    of its own epoch: a receiver that stamps its fix and its velocity alike (the simulator's, or any that sends both
    from one solution) may deliver the velocity just after the fix, so such a fix waits for it up to
    ``vel_wait_s`` (``flush(now_s)`` releases it then; so do the next `vel` and the next fix). A receiver whose
    stamps differ (nmea_navsat_driver stamps each sentence on arrival) gets the latest `vel` at once.
    Each add_* and flush returns a list of (Report or None, reason or None) for the fixes it released."""

    def __init__(self, settings, frame=None):
        self.settings = settings
        self.frame = frame
        self.odometry = collections.deque()   # OdomSample, in stamp order, within odom_buffer_s of the newest
        self.velocities = collections.deque(maxlen=16)
        self.pending = None                   # (fix, receipt time) waiting for its epoch's vel
        self.paired_stamps = False            # the receiver stamps a fix and its vel alike

    # --- inputs
    def add_odometry(self, sample):
        if self.odometry and sample.stamp_s < self.odometry[-1].stamp_s - self.settings.odom_buffer_s:
            self.odometry.clear()  # time went back (a new simulation, a bag looped): the old samples are another run's
        stamps = [s.stamp_s for s in self.odometry]
        self.odometry.insert(bisect.bisect_right(stamps, sample.stamp_s), sample)
        newest = self.odometry[-1].stamp_s
        while self.odometry and self.odometry[0].stamp_s < newest - self.settings.odom_buffer_s:
            self.odometry.popleft()
        return []

    def add_velocity(self, sample):
        self.velocities.append(sample)
        if self.pending is not None and self._same_epoch(self.pending[0], sample):
            self.paired_stamps = True
            return [self._release()]
        return []

    def add_fix(self, fix, now_s):
        released = [self._release()] if self.pending is not None else []
        if self.settings.vel_wait_s > 0.0 and self.paired_stamps and self._epoch_velocity(fix) is None and \
                fix_problem(fix) is None:
            self.pending = (fix, now_s)
            return released
        if self._epoch_velocity(fix) is not None:
            self.paired_stamps = True
        return released + [self._report(fix)]

    def flush(self, now_s):
        """Release a fix that has waited ``vel_wait_s`` for its velocity (then the latest `vel` is used)."""
        if self.pending is not None and now_s - self.pending[1] >= self.settings.vel_wait_s:
            return [self._release()]
        return []

    # --- internals
    @staticmethod
    def _stamp_s(fix):
        return fix.header.stamp.secs + fix.header.stamp.nsecs * 1e-9

    def _same_epoch(self, fix, sample):
        return abs(sample.stamp_s - self._stamp_s(fix)) <= PAIR_TOLERANCE_S

    def _epoch_velocity(self, fix):
        return next((v for v in reversed(self.velocities) if self._same_epoch(fix, v)), None)

    def _release(self):
        fix, _ = self.pending
        self.pending = None
        return self._report(fix)

    def _nearest_odometry(self, stamp_s):
        if not self.odometry:
            return None
        stamps = [s.stamp_s for s in self.odometry]
        i = bisect.bisect_left(stamps, stamp_s)
        candidates = [self.odometry[j] for j in (i - 1, i) if 0 <= j < len(self.odometry)]
        return min(candidates, key=lambda s: abs(s.stamp_s - stamp_s))

    def _report(self, fix):
        stamp_s = self._stamp_s(fix)
        velocity = self._epoch_velocity(fix)
        if velocity is None and self.velocities and not self.paired_stamps:
            # (a receiver that pairs its stamps gave no velocity this epoch, e.g. with no fix: the odometry's then)
            velocity = min(self.velocities, key=lambda v: abs(v.stamp_s - stamp_s))
        return make_report(self.frame, fix, velocity, self._nearest_odometry(stamp_s), self.settings)


def fill_odometry(odom, report, stamp, world_frame, child_frame):
    """Write ``report`` into a nav_msgs/Odometry (or anything shaped like one) stamped ``stamp``; returns it."""
    odom.header.stamp = stamp
    odom.header.frame_id = world_frame
    odom.child_frame_id = child_frame
    p = odom.pose.pose.position
    p.x, p.y, p.z = report.position
    q = odom.pose.pose.orientation
    q.x, q.y, q.z, q.w = 0.0, 0.0, math.sin(report.heading / 2.0), math.cos(report.heading / 2.0)
    odom.pose.covariance = list(report.pose_covariance)
    linear, angular = odom.twist.twist.linear, odom.twist.twist.angular
    linear.x, linear.y, linear.z = report.velocity[0], report.velocity[1], 0.0
    angular.x, angular.y, angular.z = 0.0, 0.0, report.yaw_rate
    odom.twist.covariance = list(report.twist_covariance)
    return odom
