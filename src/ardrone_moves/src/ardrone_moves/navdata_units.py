"""ardrone_autonomy/Navdata raw fields -> SI units, their sanity check, and the altd unit check (ROS-free).

The driver publishes REP 103 axes (x forward, y left, z up; angles positive counter-clockwise about
the axis, so roll > 0 is right side down and pitch > 0 is nose down) in mixed units: mm/s, degrees,
g, and altd whose unit is ambiguous (the message file says cm, the driver's documentation mm), hence
the parameter ``altd_unit`` and AltdUnitCheck to confirm it in flight.
"""
import math
from dataclasses import dataclass
from typing import NamedTuple, Optional, Tuple

GRAVITY = 9.80665  # [m/s^2 per g]
ALTD_UNITS = {"mm": 0.001, "cm": 0.01}  # altd_unit -> metres per altd count

STATE_NAMES = {0: "unknown", 1: "inited", 2: "landed", 3: "flying", 4: "hovering", 5: "test",
               6: "taking off", 7: "go-to-fix-point", 8: "landing", 9: "looping"}
AIRBORNE_STATES = frozenset((3, 4, 7))  # states in which the velocity loop may fly the drone

RAW_FIELDS = ("vx", "vy", "vz", "rotX", "rotY", "rotZ", "altd", "ax", "ay", "az", "batteryPercent", "state",
              "pressure", "tm")


@dataclass(frozen=True)
class NavdataLimits:
    """Beyond these a value is a broken packet or a wrong unit, not flight."""
    max_speed: float = 30.0          # |horizontal velocity| [m/s]; the drone flies < 12 m/s
    max_climb: float = 10.0          # |climb| [m/s]
    max_angle_deg: float = 360.0     # |rotX|, |rotY|, |rotZ| [deg]
    max_height: float = 100.0        # height from altd [m]; its sensors reach a few metres
    max_acceleration_g: float = 16.0  # |ax|, |ay|, |az| [g]
    min_pressure: float = 30000.0    # [Pa] (0 means "no barometer" and is allowed)
    max_pressure: float = 120000.0   # [Pa]


@dataclass(frozen=True)
class NavdataSI:
    """One navdata message in SI units, heading frame (forward, left, up)."""
    velocity_heading: Tuple[float, float]  # forward, left [m/s]
    climb: float                           # [m/s], + = up
    roll: float                            # [rad], + = right side down
    pitch: float                           # [rad], + = nose down
    yaw: float                             # [rad], + = counter-clockwise
    height: float                          # above the surface below [m]
    acceleration: Tuple[float, float, float]  # forward, left, up [m/s^2]
    battery: float                         # [percent]
    state: int                             # see STATE_NAMES
    pressure: Optional[float]              # [Pa]; None when the drone has no barometer (reads 0)
    stamp: float                           # [s]

    @property
    def state_name(self):
        return STATE_NAMES.get(self.state, "code %d" % self.state)

    @property
    def airborne(self):
        return self.state in AIRBORNE_STATES

    @property
    def speed(self):
        return math.hypot(*self.velocity_heading)


class Conversion(NamedTuple):
    """navdata is None exactly when problem names what is wrong."""
    navdata: Optional[NavdataSI]
    problem: Optional[str]


def altd_scale(altd_unit):
    """Metres per altd count; ValueError naming the parameter for anything but 'mm' or 'cm'."""
    if altd_unit not in ALTD_UNITS:
        raise ValueError("parameter 'altd_unit' = %r must be 'mm' or 'cm'" % (altd_unit,))
    return ALTD_UNITS[altd_unit]


def convert_fields(vx, vy, vz, rotX, rotY, rotZ, altd, ax, ay, az, batteryPercent, state, pressure, tm,
                   altd_unit, stamp=None, limits=NavdataLimits()):
    """Raw navdata numbers -> Conversion. ``stamp`` [s] defaults to the drone clock tm [us]."""
    scale = altd_scale(altd_unit)
    raw = dict(vx=vx, vy=vy, vz=vz, rotX=rotX, rotY=rotY, rotZ=rotZ, altd=altd, ax=ax, ay=ay, az=az,
               batteryPercent=batteryPercent, state=state, pressure=pressure, tm=tm)
    numbers = {}
    for name, value in raw.items():
        try:
            numbers[name] = float(value)
        except (TypeError, ValueError):
            return Conversion(None, "navdata field '%s' = %r is not a number" % (name, value))
        if not math.isfinite(numbers[name]):
            return Conversion(None, "navdata field '%s' = %r is not finite" % (name, value))
    if stamp is None:
        stamp = numbers["tm"] * 1e-6
    try:
        stamp = float(stamp)
    except (TypeError, ValueError):
        return Conversion(None, "stamp %r is not a number" % (stamp,))
    if not math.isfinite(stamp):
        return Conversion(None, "stamp %r is not finite" % (stamp,))
    problem = _range_problem(numbers, scale, limits)
    if problem:
        return Conversion(None, problem)
    n = numbers
    return Conversion(NavdataSI(
        velocity_heading=(n["vx"] / 1000.0, n["vy"] / 1000.0), climb=n["vz"] / 1000.0,
        roll=math.radians(n["rotX"]), pitch=math.radians(n["rotY"]), yaw=math.radians(n["rotZ"]),
        height=n["altd"] * scale,
        acceleration=(n["ax"] * GRAVITY, n["ay"] * GRAVITY, n["az"] * GRAVITY),
        battery=n["batteryPercent"], state=int(n["state"]),
        pressure=n["pressure"] if n["pressure"] != 0.0 else None, stamp=stamp), None)


def pressure_altitude(pressure, reference_pressure):
    """Height [m] above where the barometer read ``reference_pressure`` [Pa], from ``pressure`` [Pa]: the
    international standard atmosphere's barometric formula (good to about 1 % over the few metres flown)."""
    return 44330.77 * (1.0 - (pressure / reference_pressure) ** 0.190263)


def convert_navdata(message, altd_unit, stamp=None, limits=NavdataLimits()):
    """A Navdata message (or any object / dict with its field names) -> Conversion.

    ``stamp`` [s]: pass header.stamp.to_sec() from the node; the drone clock tm is only a fallback
    (float32 microseconds lose precision after ~17 s)."""
    values = {}
    for name in RAW_FIELDS:
        if isinstance(message, dict):
            present, value = name in message, message.get(name)
        else:
            present, value = hasattr(message, name), getattr(message, name, None)
        if not present:
            return Conversion(None, "navdata field '%s' is missing" % name)
        values[name] = value
    return convert_fields(altd_unit=altd_unit, stamp=stamp, limits=limits, **values)


def _range_problem(n, scale, limits):
    speed = math.hypot(n["vx"], n["vy"]) / 1000.0
    if speed > limits.max_speed:
        return "horizontal speed %.1f m/s (vx %g, vy %g mm/s) exceeds %g m/s" % (speed, n["vx"], n["vy"],
                                                                                 limits.max_speed)
    if abs(n["vz"]) / 1000.0 > limits.max_climb:
        return "climb %.1f m/s (vz %g mm/s) exceeds %g m/s" % (n["vz"] / 1000.0, n["vz"], limits.max_climb)
    for name in ("rotX", "rotY", "rotZ"):
        if abs(n[name]) > limits.max_angle_deg:
            return "%s = %g deg exceeds %g deg" % (name, n[name], limits.max_angle_deg)
    height = n["altd"] * scale
    if not 0.0 <= height <= limits.max_height:
        return "altd = %g gives height %.2f m outside [0, %g] m (is altd_unit right?)" % (n["altd"], height,
                                                                                         limits.max_height)
    for name in ("ax", "ay", "az"):
        if abs(n[name]) > limits.max_acceleration_g:
            return "%s = %g g exceeds %g g" % (name, n[name], limits.max_acceleration_g)
    if not 0.0 <= n["batteryPercent"] <= 100.0:
        return "batteryPercent = %g outside [0, 100]" % n["batteryPercent"]
    if n["state"] != int(n["state"]) or int(n["state"]) not in STATE_NAMES:
        return "state = %g is not a known flight state code (0..9)" % n["state"]
    if n["pressure"] != 0.0 and not limits.min_pressure <= n["pressure"] <= limits.max_pressure:
        return "pressure = %g Pa outside [%g, %g] Pa" % (n["pressure"], limits.min_pressure, limits.max_pressure)
    return None


# AltdUnitCheck outcomes
AGREES, OTHER_UNIT, INCONSISTENT = "agrees", "other_unit", "inconsistent"


@dataclass(frozen=True)
class AltdVerdict:
    outcome: str        # AGREES, OTHER_UNIT or INCONSISTENT
    unit: Optional[str]  # the unit the data fit (None when INCONSISTENT)
    ratio: float        # median of altd * configured scale / reference height
    fraction: float     # share of the counted samples that fit ``unit`` (or the better unit)
    samples: int
    message: str        # what was found and which parameter to set


class AltdUnitCheck:
    """Is altd_unit right? Compares altd with a height from an independent source.

    Each counted sample gives the ratio altd * configured scale / reference. With the right unit it
    is ~1, with the other unit ~10 or ~0.1. Decided once ``samples_needed`` samples are in: a unit
    wins when at least ``min_fraction`` of the ratios lie within ``tolerance_factor`` of its value,
    so noise and a few outliers (pad edge, sonar dropouts) do not matter."""

    def __init__(self, configured_unit, samples_needed=20, min_reference=0.3, max_reference=5.0,
                 tolerance_factor=2.0, min_fraction=0.6):
        self.configured_unit = configured_unit
        self._scale = altd_scale(configured_unit)
        self.other_unit = "cm" if configured_unit == "mm" else "mm"
        if int(samples_needed) < 1:
            raise ValueError("samples_needed = %r must be >= 1" % samples_needed)
        if not 0.0 < min_reference < max_reference:
            raise ValueError("need 0 < min_reference (%r) < max_reference (%r)" % (min_reference, max_reference))
        if not 1.0 < tolerance_factor < math.sqrt(10.0):  # wider would let both units claim a sample
            raise ValueError("tolerance_factor = %r must be in (1, 3.16)" % tolerance_factor)
        if not 0.5 < min_fraction <= 1.0:
            raise ValueError("min_fraction = %r must be in (0.5, 1]" % min_fraction)
        self.samples_needed = int(samples_needed)
        self.min_reference, self.max_reference = float(min_reference), float(max_reference)
        self._log_tolerance = math.log10(tolerance_factor)
        self.min_fraction = float(min_fraction)
        self._log_ratios = []
        self.verdict = None

    def add(self, altd_raw, reference_height):
        """One pair; returns the AltdVerdict once decided (and from then on), else None.

        Pairs whose reference is outside [min_reference, max_reference] or not finite are skipped:
        near the ground the sensors disagree by offsets, high up the ultrasound altd is out of range."""
        if self.verdict is not None:
            return self.verdict
        try:
            altd_raw, reference_height = float(altd_raw), float(reference_height)
        except (TypeError, ValueError):
            return None
        if not (math.isfinite(altd_raw) and math.isfinite(reference_height)):
            return None
        if not self.min_reference <= reference_height <= self.max_reference:
            return None
        # altd <= 0 with the drone clearly up fits no unit: it counts, as a sample matching nothing.
        ratio = altd_raw * self._scale / reference_height
        self._log_ratios.append(math.log10(ratio) if ratio > 0.0 else -math.inf)
        if len(self._log_ratios) >= self.samples_needed:
            self.verdict = self._decide()
        return self.verdict

    def _decide(self):
        count = len(self._log_ratios)
        ordered = sorted(self._log_ratios)
        median_log = ordered[count // 2] if count % 2 else 0.5 * (ordered[count // 2 - 1] + ordered[count // 2])
        median_ratio = 10.0 ** median_log if math.isfinite(median_log) else 0.0
        # Data in the other unit read, with the configured scale, this many decades off.
        other_log = math.log10(self._scale / ALTD_UNITS[self.other_unit])
        fits_configured = sum(abs(r) <= self._log_tolerance for r in self._log_ratios) / count
        fits_other = sum(abs(r - other_log) <= self._log_tolerance for r in self._log_ratios) / count
        if fits_configured >= self.min_fraction:
            return AltdVerdict(AGREES, self.configured_unit, median_ratio, fits_configured, count,
                               "altd agrees with altd_unit: %s (median altd/reference %.2f, %d%% of %d samples fit)"
                               % (self.configured_unit, median_ratio, round(100 * fits_configured), count))
        if fits_other >= self.min_fraction:
            return AltdVerdict(OTHER_UNIT, self.other_unit, median_ratio, fits_other, count,
                               "altd is in %s, not the configured %s (read as %s it is %.2fx the reference height "
                               "in %d%% of %d samples): set the parameter altd_unit: %s"
                               % (self.other_unit, self.configured_unit, self.configured_unit, median_ratio,
                                  round(100 * fits_other), count, self.other_unit))
        return AltdVerdict(INCONSISTENT, None, median_ratio, max(fits_configured, fits_other), count,
                           "altd fits neither mm nor cm (median altd/reference %.2f with altd_unit: %s; only %d%% of "
                           "%d samples fit %s, %d%% fit %s): keep altd_unit unconfirmed, check the reference "
                           "height source and the altd field, and repeat the check"
                           % (median_ratio, self.configured_unit, round(100 * fits_configured), count,
                              self.configured_unit, round(100 * fits_other), self.other_unit))

    def reset(self):
        self._log_ratios = []
        self.verdict = None
