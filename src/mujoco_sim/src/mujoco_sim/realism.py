"""How close the simulated world comes to a real AR.Drone 2.0 on a real vehicle outdoors, ROS-free.

Three profiles (config/sim.yaml, ``realism/table``: one row per key, one column per profile):
``ideal`` is today's perfect world (no latency, white noise only, firmware flying on true state, even
light, perfect lens), ``realistic`` what the real drone gives outdoors, ``harsh`` about twice the trouble.
A scenario picks a profile by name or a mapping ``{profile: NAME, key: value, ...}`` that overrides
single keys. ``resolve`` turns either into the values in force, with errors that name the source, the
key and what is expected.

The stochastic models every effect draws from are here too, each with its own seeded generator:
``DelayLine`` (latency with jitter, in order, with losses), ``GaussMarkov`` (slowly drifting errors),
``RandomWalk`` (biases), ``Dropouts`` (short outages at random times).
"""
import collections
import math
import os

import numpy as np

from .config import ConfigError, Param

F, B = float, bool

# Every key of a profile: its type, range and unit. The meaning and the reason for each profile's value
# are the comments of config/sim.yaml (and the README's table).
SCHEMA = {
    # camera (bottom, 320x240, H.264 over Wi-Fi)
    "camera_latency_s": Param(F, 0.0, 2.0, "s"),
    "camera_latency_jitter_s": Param(F, 0.0, 1.0, "s"),
    "camera_drop_rate": Param(F, 0.0, 1.0),
    "camera_exposure_s": Param(F, 0.0, 0.1, "s"),
    "lens_k1": Param(F, -1.0, 1.0),
    "lens_k2": Param(F, -1.0, 1.0),
    "lens_p1": Param(F, -0.1, 0.1),
    "lens_p2": Param(F, -0.1, 0.1),
    "lens_k3": Param(F, -1.0, 1.0),
    "pixel_noise_std": Param(F, 0.0, 0.5),
    "exposure_gain_std": Param(F, 0.0, 1.0),
    "exposure_time_constant_s": Param(F, 0.1, 600.0, "s"),
    # light
    "shadows": Param(B),
    "sun_elevation_deg": Param(F, 5.0, 90.0, "deg"),
    "sun_elevation_spread_deg": Param(F, 0.0, 60.0, "deg"),
    "sun_azimuth_deg": Param(F, -360.0, 360.0, "deg"),
    "sun_azimuth_spread_deg": Param(F, 0.0, 180.0, "deg"),
    "sun_intensity": Param(F, 0.0, 1.0),
    "ambient_light": Param(F, 0.0, 1.0),
    # IMU and the attitude estimate (navdata)
    "gyro_bias_initial_std": Param(F, 0.0, 1.0, "rad/s"),
    "gyro_bias_walk": Param(F, 0.0, 0.1, "rad/s/sqrt(s)"),
    "accel_bias_initial_std": Param(F, 0.0, 2.0, "m/s^2"),
    "accel_bias_walk": Param(F, 0.0, 0.5, "m/s^2/sqrt(s)"),
    "yaw_drift_rate_std": Param(F, 0.0, 0.1, "rad/s"),
    "yaw_drift_walk": Param(F, 0.0, 0.1, "rad/sqrt(s)"),
    # navdata link (navdata and IMU come over Wi-Fi)
    "navdata_rate_hz": Param(F, 1.0, 200.0, "Hz"),
    "navdata_latency_s": Param(F, 0.0, 1.0, "s"),
    "navdata_latency_jitter_s": Param(F, 0.0, 0.5, "s"),
    "navdata_drop_rate": Param(F, 0.0, 1.0),
    # command link (UDP AT commands)
    "command_latency_s": Param(F, 0.0, 1.0, "s"),
    "command_latency_jitter_s": Param(F, 0.0, 0.5, "s"),
    "command_loss_rate": Param(F, 0.0, 1.0),
    # GPS of the drone and of the vehicle (independent receivers)
    "gps_error_std": Param(F, 0.0, 20.0, "m"),
    "gps_error_time_constant_s": Param(F, 1.0, 3600.0, "s"),
    "gps_latency_s": Param(F, 0.0, 2.0, "s"),
    "gps_dropouts_per_min": Param(F, 0.0, 60.0, "1/min"),
    "gps_dropout_duration_s": Param(F, 0.0, 60.0, "s"),
    # sonar
    "sonar_outlier_rate": Param(F, 0.0, 1.0),
    # on-board firmware
    "firmware_on_estimate": Param(B),
    "flow_surface_coupling": Param(B),
    "flow_scale_error_std": Param(F, 0.0, 0.5),
}
PROFILES = ("ideal", "realistic", "harsh")
DEFAULT_PROFILE = "realistic"


def shipped_profiles():
    """The profile table of the package's config/sim.yaml, validated: {profile: {key: value}}."""
    from .config import load_yaml
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "config", "sim.yaml")
    section = load_yaml(os.path.normpath(path)).get("realism") or {}
    return validate_table(section.get("table"), section.get("profiles"), path)


def validate_table(table, profiles, source):
    """config/sim.yaml's ``realism`` table -> {profile: {key: value}}; every key of SCHEMA once, one
    value per profile, each in range."""
    if list(profiles) != list(PROFILES):
        raise ConfigError("%s: 'realism/profiles' must be %s (the columns of the table), got %r" % (
            source, list(PROFILES), profiles))
    if not isinstance(table, dict):
        raise ConfigError("%s: 'realism/table' must be a mapping of key: [ideal, realistic, harsh]" % source)
    unknown = sorted(set(table) - set(SCHEMA))
    if unknown:
        raise ConfigError("%s: unknown realism key(s) %s in 'realism/table' (known: %s)" % (
            source, ", ".join(unknown), ", ".join(sorted(SCHEMA))))
    out = {name: {} for name in PROFILES}
    for key, spec in SCHEMA.items():
        row = table.get(key)
        where = "%s: 'realism/table/%s'" % (source, key)
        if not isinstance(row, list) or len(row) != len(PROFILES):
            raise ConfigError("%s: expected a list of %d values (%s), got %r" % (
                where, len(PROFILES), ", ".join(PROFILES), row))
        for name, value in zip(PROFILES, row):
            out[name][key] = spec.check(value, "%s (%s)" % (where, name))
    return out


def resolve(profiles, selection, source):
    """The realism values in force: ``selection`` is a profile name, or a mapping with an optional
    ``profile`` (default: realistic) and keys to override. Returns (profile name, {key: value})."""
    if isinstance(selection, str):
        selection = {"profile": selection}
    if selection is None:
        selection = {}
    if not isinstance(selection, dict):
        raise ConfigError("%s: expected a profile name (%s) or a mapping {profile: NAME, key: value}, got %r" % (
            source, " | ".join(PROFILES), selection))
    name = selection.get("profile", DEFAULT_PROFILE)
    if name not in PROFILES:
        raise ConfigError("%s: unknown realism profile %r (expected one of %s)" % (source, name, ", ".join(PROFILES)))
    values = dict(profiles[name])
    for key, value in selection.items():
        if key == "profile":
            continue
        if key not in SCHEMA:
            raise ConfigError("%s: unknown realism key '%s' (known: profile, %s)" % (
                source, key, ", ".join(sorted(SCHEMA))))
        values[key] = SCHEMA[key].check(value, "%s: realism key '%s'" % (source, key))
    return name, values


class DelayLine:
    """A link that delivers items late, in order, and loses some. ``latency`` mean [s], ``jitter`` its
    std [s] (a normal draw, never below zero), ``loss`` the chance an item never arrives. Items keep their
    order: one may not overtake an earlier one (a video stream and a serial link do not reorder)."""

    def __init__(self, rng, latency, jitter=0.0, loss=0.0):
        self.rng, self.latency, self.jitter, self.loss = rng, latency, jitter, loss
        self.pending = collections.deque()  # (release time, item)
        self.last_release = -math.inf
        self.sent = self.lost = 0

    @property
    def transparent(self):
        return self.latency <= 0.0 and self.jitter <= 0.0 and self.loss <= 0.0

    def lost_next(self):
        """Draw whether the next item is lost (before it is made: a lost camera frame is not rendered)."""
        self.sent += 1
        if self.loss > 0.0 and self.rng.random() < self.loss:
            self.lost += 1
            return True
        return False

    def push(self, now, item):
        """Send ``item`` at ``now``; returns its release time."""
        delay = self.latency + (self.jitter * self.rng.standard_normal() if self.jitter > 0.0 else 0.0)
        release = max(now + max(0.0, delay), self.last_release)
        self.last_release = release
        self.pending.append((release, item))
        return release

    def due(self, now):
        """Items whose release time has come, oldest first."""
        out = []
        while self.pending and self.pending[0][0] <= now + 1e-9:
            out.append(self.pending.popleft()[1])
        return out


class GaussMarkov:
    """First-order Gauss-Markov (Ornstein-Uhlenbeck) error per axis: stationary std ``std``, correlation
    time ``tau`` [s]; exact discretisation, so any step size gives the same statistics. Starts from a
    draw of the stationary distribution."""

    def __init__(self, rng, std, tau, dim=1):
        self.rng, self.std, self.tau = rng, std, tau
        self.value = std * rng.standard_normal(dim) if std > 0.0 else np.zeros(dim)

    def step(self, dt):
        if self.std <= 0.0 or dt <= 0.0:
            return self.value
        decay = math.exp(-dt / self.tau)
        self.value = decay * self.value + self.std * math.sqrt(1.0 - decay * decay) * self.rng.standard_normal(
            self.value.shape)
        return self.value


class RandomWalk:
    """A bias that starts at a normal draw of std ``initial_std`` and wanders as a random walk of density
    ``walk`` [unit/sqrt(s)]: after t seconds its spread has grown by walk * sqrt(t)."""

    def __init__(self, rng, initial_std, walk, dim=1):
        self.rng, self.walk = rng, walk
        self.value = initial_std * rng.standard_normal(dim) if initial_std > 0.0 else np.zeros(dim)

    def step(self, dt):
        if self.walk > 0.0 and dt > 0.0:
            self.value = self.value + self.walk * math.sqrt(dt) * self.rng.standard_normal(self.value.shape)
        return self.value


class Dropouts:
    """Outages that start at random (a Poisson process of ``per_minute`` starts a minute) and last
    ``duration`` seconds each."""

    def __init__(self, rng, per_minute, duration):
        self.rng, self.rate, self.duration = rng, per_minute / 60.0, duration
        self.until = -math.inf
        self.next_start = self._draw_next(0.0)

    def _draw_next(self, after):
        return after + self.rng.exponential(1.0 / self.rate) if self.rate > 0.0 and self.duration > 0.0 else math.inf

    def active(self, now):
        while now >= self.next_start:
            self.until = self.next_start + self.duration
            self.next_start = self._draw_next(self.until)
        return now < self.until
