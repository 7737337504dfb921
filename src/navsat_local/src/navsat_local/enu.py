"""GPS fixes -> local ENU odometry around a datum, without ROS (node.py is the rospy shell around this).

Everything here takes plain numbers or duck-typed messages (anything with a NavSatFix's or an Odometry's
attribute names), so it runs and is tested without a ROS master or rospy.
"""
import math
from collections import namedtuple
from dataclasses import dataclass

import pymap3d

# The stack's "not measured" covariance entry (mujoco_sim's UNKNOWN_VARIANCE, ped_traj_pred's kUnknownVariance):
# consumers compare against it, so an unknown quantity is a finite 0 with this variance, never a NaN.
UNKNOWN_VARIANCE = 1e6

# sensor_msgs/NavSatStatus and sensor_msgs/NavSatFix constants, repeated so this module needs no ROS.
STATUS_NO_FIX = -1
COVARIANCE_TYPE_UNKNOWN = 0
COVARIANCE_TYPE_APPROXIMATED = 1
COVARIANCE_TYPE_DIAGONAL_KNOWN = 2
COVARIANCE_TYPE_KNOWN = 3

DEFAULT_SHARED_DATUM_PARAM = "/navsat_datum"

_WGS84 = pymap3d.Ellipsoid.from_name("wgs84")


class DatumError(ValueError):
    """No datum can be chosen, or a datum parameter is malformed: the node cannot start."""


# ---------------------------------------------------------------------------------------------- geodesy


def _finite_number(value, name):
    # bool is an int to Python, but a `lat: true` in a YAML file is a mistake, not the number 1.
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError("%s %r is not a number" % (name, value))
    if not math.isfinite(value):
        raise ValueError("%s %s is not a finite number" % (name, value))
    return float(value)


def validate_geodetic(lat_deg, lon_deg, alt_m):
    """(lat, lon, alt) as floats; ValueError naming the first that is not finite or out of range."""
    lat = _finite_number(lat_deg, "latitude")
    lon = _finite_number(lon_deg, "longitude")
    alt = _finite_number(alt_m, "altitude")
    if not -90.0 <= lat <= 90.0:
        raise ValueError("latitude %s deg is outside [-90, 90]" % lat)
    if not -180.0 <= lon <= 180.0:
        raise ValueError("longitude %s deg is outside [-180, 180]" % lon)
    return lat, lon, alt


class Datum(namedtuple("Datum", "lat_deg lon_deg alt_m")):
    """The origin of the local ENU frame: WGS84 latitude and longitude [deg], ellipsoidal altitude [m]."""
    __slots__ = ()

    def as_param(self):
        """The mapping stored in ~datum and the shared /navsat_datum parameter."""
        return {"lat": self.lat_deg, "lon": self.lon_deg, "alt": self.alt_m}

    def __str__(self):
        return "lat %.8f deg, lon %.8f deg, alt %.3f m" % self


def parse_datum(value, param_name):
    """A Datum from a parameter's value ({lat, lon, alt}); DatumError naming ``param_name`` if malformed."""
    if not isinstance(value, dict) or not {"lat", "lon", "alt"} <= set(value):
        raise DatumError("%s must be a mapping {lat: deg, lon: deg, alt: m}, got %r" % (param_name, value))
    try:
        return Datum(*validate_geodetic(value["lat"], value["lon"], value["alt"]))
    except ValueError as err:
        raise DatumError("%s: %s" % (param_name, err)) from None


class LocalFrame:
    """East-north-up metres around a datum on the WGS84 ellipsoid."""

    def __init__(self, datum_lat_deg, datum_lon_deg, datum_alt_m):
        try:
            self.datum = Datum(*validate_geodetic(datum_lat_deg, datum_lon_deg, datum_alt_m))
        except ValueError as err:
            raise ValueError("datum: %s" % err) from None

    @classmethod
    def around(cls, datum):
        return cls(*datum)

    def to_enu(self, lat_deg, lon_deg, alt_m):
        """(east, north, up) [m] of a geodetic point; ValueError if the point is not finite or out of range."""
        lat, lon, alt = validate_geodetic(lat_deg, lon_deg, alt_m)
        east, north, up = pymap3d.geodetic2enu(lat, lon, alt, *self.datum, ell=_WGS84, deg=True)
        return float(east), float(north), float(up)

    def to_geodetic(self, east_m, north_m, up_m):
        """(lat [deg], lon [deg], alt [m]) of a local point; ValueError if a coordinate is not finite."""
        east, north, up = (_finite_number(v, name) for v, name in ((east_m, "east"), (north_m, "north"), (up_m, "up")))
        lat, lon, alt = pymap3d.enu2geodetic(east, north, up, *self.datum, ell=_WGS84, deg=True)
        return float(lat), float(lon), float(alt)

    def distance_to(self, other_datum):
        """Straight-line distance [m] from this frame's origin to another datum (do two converters agree?)."""
        return math.sqrt(sum(c * c for c in self.to_enu(*other_datum)))


# ---------------------------------------------------------------------------------------------- datum choice


DatumChoice = namedtuple("DatumChoice", "datum source")
DatumChoice.__doc__ = """The datum to use (None: take it from the first valid fix) and where it came from."""


def resolve_datum(private_datum, shared_datum, from_first_fix, shared_param=DEFAULT_SHARED_DATUM_PARAM):
    """Which datum a converter uses, by the first rule that applies:

    1. ``~datum`` (``private_datum``) when given: this converter's own, explicit choice;
    2. else the shared parameter (``shared_datum``, read from ``shared_param``), so the drone's and the
       vehicle's converters share one frame;
    3. else, only with ``~datum_from_first_fix`` true, DatumChoice(None, "first fix"): the caller takes the
       first valid fix and stores it in ``shared_param`` for the other converters;
    4. else DatumError saying which parameters would do.
    Absent parameters are None; a malformed one raises DatumError naming it.
    """
    if private_datum is not None:
        return DatumChoice(parse_datum(private_datum, "~datum"), "~datum")
    if shared_datum is not None:
        return DatumChoice(parse_datum(shared_datum, shared_param), shared_param)
    if from_first_fix:
        return DatumChoice(None, "first fix")
    raise DatumError(
        "no datum for the local frame: set ~datum {lat: deg, lon: deg, alt: m} on this node, or the shared %s "
        "parameter (same keys) for all converters, or ~datum_from_first_fix: true to take it from the first "
        "valid fix" % shared_param)


def datum_from_fix(fix):
    """The datum a first valid fix gives (call fix_problem first)."""
    return Datum(*validate_geodetic(fix.latitude, fix.longitude, fix.altitude))


# ---------------------------------------------------------------------------------------------- fixes


def fix_problem(fix):
    """Why a NavSatFix (or anything with its fields) is unusable, or None when it can be converted.

    An unknown covariance type is no problem (position_covariance falls back to the defaults for it)."""
    status = fix.status.status
    if status == STATUS_NO_FIX:
        return "status NO_FIX (-1)"
    if status < STATUS_NO_FIX:
        return "status %d is not a NavSatStatus value" % status
    stamp = fix.header.stamp
    if stamp.secs == 0 and stamp.nsecs == 0:
        # The odometry takes the fix's stamp and the velocity is matched by stamps: a zero one matches nothing.
        return "header.stamp is zero"
    try:
        validate_geodetic(fix.latitude, fix.longitude, fix.altitude)
    except ValueError as err:
        return str(err)
    return None


@dataclass(frozen=True)
class ConversionSettings:
    """The node's tuning, as in config/navsat_local.yaml (units in the names)."""
    unknown_horizontal_std_m: float = 5.0
    unknown_vertical_std_m: float = 10.0
    min_position_std_m: float = 0.01
    velocity_std_mps: float = 0.2
    velocity_has_vertical: bool = False
    vel_max_age_s: float = 1.5

    def __post_init__(self):
        for name in ("unknown_horizontal_std_m", "unknown_vertical_std_m", "min_position_std_m", "velocity_std_mps",
                     "vel_max_age_s"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                    or value <= 0.0:
                raise ValueError("~%s must be a positive number, got %r" % (name, value))
        if not isinstance(self.velocity_has_vertical, bool):
            raise ValueError("~velocity_has_vertical must be true or false, got %r" % (self.velocity_has_vertical,))


def _diagonal(variances):
    matrix = [0.0] * (len(variances) ** 2)
    for i, variance in enumerate(variances):
        matrix[i * (len(variances) + 1)] = variance
    return matrix


def position_covariance(fix_covariance, covariance_type, settings):
    """(ENU 3x3 row-major covariance [m^2], note or None) for a fix's position.

    NavSatFix's covariance is already ENU, so it carries over as it is, symmetrised, with each variance raised
    to the floor (a receiver claiming 0 would make a filter trust it without bound). An unknown type, or a
    "known" matrix with a non-finite or negative variance, gets the default standard deviations instead."""
    default = _diagonal((settings.unknown_horizontal_std_m ** 2, settings.unknown_horizontal_std_m ** 2,
                         settings.unknown_vertical_std_m ** 2))
    if covariance_type == COVARIANCE_TYPE_UNKNOWN:
        return default, "covariance type unknown: default std used"
    if covariance_type not in (COVARIANCE_TYPE_APPROXIMATED, COVARIANCE_TYPE_DIAGONAL_KNOWN, COVARIANCE_TYPE_KNOWN):
        return default, "covariance type %r is not a NavSatFix value: default std used" % (covariance_type,)
    given = [float(v) for v in fix_covariance]
    if len(given) != 9 or not all(math.isfinite(v) for v in given) or min(given[0], given[4], given[8]) < 0.0:
        return default, "position covariance %r is not usable: default std used" % (given,)
    if covariance_type == COVARIANCE_TYPE_DIAGONAL_KNOWN:
        # Only the diagonal is promised; whatever sits elsewhere is not to be trusted.
        matrix = _diagonal((given[0], given[4], given[8]))
    else:
        matrix = [(given[3 * r + c] + given[3 * c + r]) / 2.0 for r in range(3) for c in range(3)]
    floor = settings.min_position_std_m ** 2
    for i in (0, 4, 8):
        matrix[i] = max(matrix[i], floor)  # a larger diagonal keeps the matrix positive semi-definite
    return matrix, None


VelocitySample = namedtuple("VelocitySample", "stamp_s east_mps north_mps up_mps")
VelocitySample.__doc__ = """A `vel` message (geometry_msgs/TwistStamped, ENU linear velocity) in plain numbers."""

VelocityEstimate = namedtuple("VelocityEstimate", "velocity variances known note")
VelocityEstimate.__doc__ = """ENU velocity [m/s], its three variances [m^2/s^2], whether it was measured, and
why not (None when it was)."""


def velocity_estimate(sample, fix_stamp_s, settings):
    """The velocity to publish with a fix stamped ``fix_stamp_s``: the `vel` sample when one is within
    ``settings.vel_max_age_s`` of the fix (either side: a receiver may send its velocity just after the
    position of the same epoch) and finite, else zero with UNKNOWN_VARIANCE and a note saying why."""
    if sample is None:
        return VelocityEstimate((0.0, 0.0, 0.0), (UNKNOWN_VARIANCE,) * 3, False, "no vel received")
    age = abs(fix_stamp_s - sample.stamp_s)
    if not age <= settings.vel_max_age_s:
        return VelocityEstimate((0.0, 0.0, 0.0), (UNKNOWN_VARIANCE,) * 3, False,
                                "vel is %.2f s from the fix (max %.2f s)" % (age, settings.vel_max_age_s))
    vertical_known = settings.velocity_has_vertical
    measured = (sample.east_mps, sample.north_mps) + ((sample.up_mps,) if vertical_known else ())
    if not all(math.isfinite(v) for v in measured):
        return VelocityEstimate((0.0, 0.0, 0.0), (UNKNOWN_VARIANCE,) * 3, False, "vel is not finite")
    horizontal = settings.velocity_std_mps ** 2
    # An NMEA receiver's course and speed (RMC, VTG) have no vertical part: its 0 up is no measurement.
    up_variance = horizontal if vertical_known else UNKNOWN_VARIANCE
    up = sample.up_mps if vertical_known else 0.0
    return VelocityEstimate((float(sample.east_mps), float(sample.north_mps), float(up)),
                            (horizontal, horizontal, up_variance), True, None)


# ---------------------------------------------------------------------------------------------- odometry


LocalOdometry = namedtuple("LocalOdometry", "stamp_s position pose_covariance velocity twist_covariance "
                                            "velocity_known notes")
LocalOdometry.__doc__ = """What one nav_msgs/Odometry carries, in plain numbers: ENU position [m], 6x6 row-major
covariances, ENU velocity [m/s], whether the velocity was measured, and notes on what was assumed."""


def embed_covariance(block3x3, rotation_variance=UNKNOWN_VARIANCE):
    """A 6x6 row-major covariance with ``block3x3`` as its linear part and the rotational part unknown
    (a GPS measures neither orientation nor turn rate)."""
    matrix = [0.0] * 36
    for r in range(3):
        for c in range(3):
            matrix[6 * r + c] = block3x3[3 * r + c]
        matrix[6 * (r + 3) + r + 3] = rotation_variance
    return matrix


def local_odometry(frame, fix, velocity_sample, settings):
    """The LocalOdometry of a fix that passed fix_problem, with the latest `vel` sample (or None)."""
    stamp_s = fix.header.stamp.secs + fix.header.stamp.nsecs * 1e-9
    position = frame.to_enu(fix.latitude, fix.longitude, fix.altitude)
    covariance, covariance_note = position_covariance(fix.position_covariance, fix.position_covariance_type,
                                                      settings)
    velocity = velocity_estimate(velocity_sample, stamp_s, settings)
    notes = tuple(note for note in (covariance_note, velocity.note) if note)
    return LocalOdometry(stamp_s, position, embed_covariance(covariance), velocity.velocity,
                         embed_covariance(_diagonal(velocity.variances)), velocity.known, notes)


def fill_odometry(odom, local, stamp, world_frame, child_frame):
    """Write ``local`` into a nav_msgs/Odometry (or anything shaped like one) stamped ``stamp``.

    The twist is ENU in ``world_frame``, not in the child frame as REP 105 would have it: the receiver knows no
    heading to rotate it by, and the stack's consumers read it as world velocity. The orientation is identity
    with UNKNOWN_VARIANCE, since a fix says nothing about it."""
    odom.header.stamp = stamp
    odom.header.frame_id = world_frame
    odom.child_frame_id = child_frame
    position = odom.pose.pose.position
    position.x, position.y, position.z = local.position
    orientation = odom.pose.pose.orientation
    orientation.x, orientation.y, orientation.z, orientation.w = 0.0, 0.0, 0.0, 1.0
    odom.pose.covariance = list(local.pose_covariance)
    linear, angular = odom.twist.twist.linear, odom.twist.twist.angular
    linear.x, linear.y, linear.z = local.velocity
    angular.x, angular.y, angular.z = 0.0, 0.0, 0.0
    odom.twist.covariance = list(local.twist_covariance)
    return odom
