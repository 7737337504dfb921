"""Emergency module, ROS-free (thesis chapter 3.5): land on the ground below the drone and report where.

When activated it first makes sure it is not above the vehicle: the pad seen by the vision close below
the drone, or a surface below that stands higher than the ground (sonar range vs barometric altitude),
means the vehicle is underneath, so it flies away from the pad until the ground is below. Then it
sends the land command (the drone descends while still obeying horizontal commands, so it keeps
dodging if the vehicle drives underneath). From activation until the operator acknowledges, it reports
the drone's position from its own estimate (ardrone/odom_estimate, else the GPS-like odometry; never
ground truth) every ``report_period_s``; on the ground the reported position is the mean of the fixes
since touchdown, which shrinks the 0.3 m GPS noise.
"""
import collections
import enum
import math
import statistics

from .supervisor import Flight

FEET_BELOW_BASE_LINK = 0.065  # the sonar measures from the landing feet, 0.065 m below base_link [m]
SOURCES = ("odom_estimate", "gps")  # own position estimates, preferred first


class Phase(enum.Enum):
    INACTIVE = "inactive"
    CLEARING = "clearing"      # moving away from the vehicle below
    DESCENDING = "descending"  # land command sent
    ON_GROUND = "on_ground"    # touched down; reporting until acknowledged


class SettingsError(ValueError):
    """An emergency setting is missing or out of range; the message names it."""


class EmergencySettings:
    SPEC = {  # name: (default, lowest, highest)
        "clear_speed_mps": (1.0, 0.1, 5.0),        # speed when moving away from the vehicle [m/s]
        "clear_distance_m": (1.5, 0.5, 10.0),      # pad centre at least this far (horizontally) = clear [m]
        "clear_hold_s": (0.5, 0.0, 10.0),          # clear for this long before landing [s]
        "max_clearing_s": (15.0, 1.0, 120.0),      # give up clearing after this long and land anyway [s]
        "elevated_surface_m": (0.25, 0.05, 5.0),   # surface below higher than this above the ground = vehicle [m]
        "surface_samples": (5, 1, 50),             # sonar samples whose median decides the surface height [-]
        "surface_timeout_s": (0.5, 0.05, 10.0),    # sonar/altimeter older than this say nothing [s]
        "pad_timeout_s": (0.5, 0.05, 10.0),        # pad detection older than this says nothing [s]
        "pad_memory_s": (5.0, 0.0, 60.0),          # the last seen pad direction is used this long to move away [s]
        "report_period_s": (1.0, 0.1, 60.0),       # emergency/position period [s]
        "estimate_timeout_s": (1.0, 0.1, 60.0),    # a position estimate older than this is stale [s]
        "land_retry_s": (1.0, 0.1, 60.0),          # land command repeated this often until touchdown [s]
        "settle_s": (0.5, 0.0, 10.0),              # fixes from this long after touchdown are averaged [s]
    }

    def __init__(self, **values):
        for name, (default, _, _) in self.SPEC.items():
            setattr(self, name, values.get(name, default))

    @classmethod
    def from_mapping(cls, values, where="emergency parameters"):
        checked = {}
        for name, (default, low, high) in cls.SPEC.items():
            if name not in values:
                raise SettingsError("%s: required parameter '%s' is missing" % (where, name))
            value = values[name]
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not low <= value <= high or \
                    (isinstance(default, int) and not float(value).is_integer()):
                raise SettingsError("%s: parameter '%s' must be a%s number in %g..%g, got %r" % (
                    where, name, "n integer" if isinstance(default, int) else "", low, high, value))
            checked[name] = type(default)(value)
        return cls(**checked)


class Output:
    __slots__ = ("phase", "cmd", "land", "report")

    def __init__(self, phase, cmd=None, land=False, report=None):
        self.phase = phase
        self.cmd = cmd        # (vx, vy) heading-frame velocity to command, or None (send nothing)
        self.land = land      # send the land command now
        self.report = report  # (x, y, source) to publish on emergency/position, or None


def _log(level, text):
    import logging
    logging.getLogger("interface.emergency").log(logging.WARNING if level == "warn" else logging.INFO, text)


class EmergencyLanding:
    def __init__(self, settings, log=None):
        self.s = settings
        self.log = log or _log
        self.phase = Phase.INACTIVE
        self.acknowledged = False
        self.flight = Flight.UNKNOWN
        self.estimates = {}                   # source -> (t, x, y)
        self.ground_fixes = {source: [] for source in SOURCES}
        self.pad = None                       # (t, x, y) pad centre in base_link
        self.altitude = None                  # (t, altitude of base_link above the ground)
        self.surface = collections.deque(maxlen=settings.surface_samples)  # (t, height or None)
        self.phase_since = None
        self.clear_since = None
        self.land_sent = None
        self.touchdown = None
        self.next_report = None

    # ----- control -----------------------------------------------------------------------------------
    def _set_phase(self, t, phase, reason):
        if phase is not self.phase:
            self.log("warn" if phase is Phase.CLEARING else "info",
                     "emergency: %s -> %s (%s)" % (self.phase.value, phase.value, reason))
            self.phase, self.phase_since = phase, t

    def activate(self, t, reason):
        if self.phase is not Phase.INACTIVE:
            return
        self.acknowledged = False
        self.next_report, self.land_sent, self.clear_since, self.touchdown = t, None, None, None
        self.ground_fixes = {source: [] for source in SOURCES}
        if self.flight is Flight.LANDED:
            self._set_phase(t, Phase.ON_GROUND, reason + "; already on the ground")
            self.touchdown = t
            return
        below, why = self.vehicle_below(t)
        if below:
            self._set_phase(t, Phase.CLEARING, "%s; vehicle below (%s): moving clear first" % (reason, why))
        else:
            self._set_phase(t, Phase.DESCENDING, "%s; ground below: landing" % reason)

    def deactivate(self, t, reason):
        self._set_phase(t, Phase.INACTIVE, reason)

    def acknowledge(self, t):
        """The operator read the coordinates: stop reporting (the landing itself goes on)."""
        if self.phase is Phase.INACTIVE or self.acknowledged:
            return False
        self.acknowledged = True
        self.log("info", "emergency: report acknowledged by the operator at t=%.2f" % t)
        return True

    # ----- inputs ------------------------------------------------------------------------------------
    def on_flight(self, t, flight):
        self.flight = flight

    def on_estimate(self, t, source, x, y):
        if source not in SOURCES:
            raise KeyError("unknown position source %r; sources are %s" % (source, ", ".join(SOURCES)))
        if not (math.isfinite(x) and math.isfinite(y)):
            return
        self.estimates[source] = (t, x, y)
        if self.phase is Phase.ON_GROUND and t >= self.touchdown + self.s.settle_s:
            self.ground_fixes[source].append((x, y))

    def on_pad(self, t, x, y):
        """Pad centre relative to the drone (ardrone/base_link)."""
        if math.isfinite(x) and math.isfinite(y):
            self.pad = (t, x, y)

    def on_altitude(self, t, altitude):
        if math.isfinite(altitude):
            self.altitude = (t, altitude)

    def on_sonar(self, t, sonar_range):
        """Height above the ground of the surface below = altitude - feet - sonar range (None: out of range)."""
        if self.altitude is None or t - self.altitude[0] > self.s.surface_timeout_s:
            return
        height = None
        if math.isfinite(sonar_range):
            height = self.altitude[1] - FEET_BELOW_BASE_LINK - sonar_range
        self.surface.append((t, height))

    # ----- what is below ------------------------------------------------------------------------------
    def vehicle_below(self, t):
        """(True, why) when the pad or the vehicle is under the drone, else (False, why)."""
        if self.pad is not None and t - self.pad[0] <= self.s.pad_timeout_s:
            distance = math.hypot(self.pad[1], self.pad[2])
            if distance < self.s.clear_distance_m:
                return True, "pad seen %.2f m away" % distance
        heights = [h for stamp, h in self.surface if t - stamp <= self.s.surface_timeout_s and h is not None]
        if len(heights) >= max(1, (self.s.surface_samples + 1) // 2):
            height = statistics.median(heights)
            if height > self.s.elevated_surface_m:
                return True, "surface below %.2f m above the ground" % height
            return False, "surface below %.2f m above the ground" % height
        return False, "nothing seen below"

    def _away(self, t):
        """Heading-frame velocity away from the last seen pad; sideways (left) when it was never seen."""
        if self.pad is not None and t - self.pad[0] <= self.s.pad_memory_s:
            norm = math.hypot(self.pad[1], self.pad[2])
            if norm > 0.05:
                return (-self.pad[1] / norm * self.s.clear_speed_mps, -self.pad[2] / norm * self.s.clear_speed_mps)
        return (0.0, self.s.clear_speed_mps)

    # ----- position report ------------------------------------------------------------------------------
    def position(self, t):
        """(x, y, source) of the drone from its own estimate; None when there is none at all."""
        for source in SOURCES:
            estimate = self.estimates.get(source)
            if estimate is not None and t - estimate[0] <= self.s.estimate_timeout_s:
                fixes = self.ground_fixes[source] if self.phase is Phase.ON_GROUND else []
                if fixes:
                    return (sum(x for x, _ in fixes) / len(fixes), sum(y for _, y in fixes) / len(fixes),
                            "%s, mean of %d fixes on the ground" % (source, len(fixes)))
                return estimate[1], estimate[2], source
        stale = [(e[0], source) for source, e in self.estimates.items()]
        if stale:
            stamp, source = max(stale)
            estimate = self.estimates[source]
            return estimate[1], estimate[2], "%s, stale by %.1f s" % (source, t - stamp)
        return None

    # ----- periodic step ----------------------------------------------------------------------------------
    def step(self, t):
        if self.phase is Phase.INACTIVE:
            return Output(self.phase)
        out = Output(self.phase)
        if self.phase in (Phase.CLEARING, Phase.DESCENDING) and self.flight is Flight.LANDED:
            self.touchdown = t
            self._set_phase(t, Phase.ON_GROUND, "touchdown")
        if self.phase is Phase.CLEARING:
            below, why = self.vehicle_below(t)
            out.cmd = self._away(t)
            if below:
                self.clear_since = None
                if t - self.phase_since >= self.s.max_clearing_s:
                    self._set_phase(t, Phase.DESCENDING, "still not clear of the vehicle after %g s (%s): landing "
                                    "anyway" % (self.s.max_clearing_s, why))
            else:
                self.clear_since = t if self.clear_since is None else self.clear_since
                if t - self.clear_since >= self.s.clear_hold_s:
                    self._set_phase(t, Phase.DESCENDING, "clear of the vehicle (%s): landing on the ground" % why)
        if self.phase is Phase.DESCENDING:
            if self.land_sent is None or t - self.land_sent >= self.s.land_retry_s:
                out.land, self.land_sent = True, t
            below, _ = self.vehicle_below(t)
            out.cmd = self._away(t) if below else (0.0, 0.0)  # keep dodging a vehicle that drives underneath
        if self.phase is Phase.ON_GROUND:
            out.cmd = None
        if not self.acknowledged and self.next_report is not None and t >= self.next_report:
            out.report = self.position(t)
            self.next_report += self.s.report_period_s
            if self.next_report <= t:  # a late step: keep the period rather than catching up in a burst
                self.next_report = t + self.s.report_period_s
        out.phase = self.phase
        return out
