"""Values the supervisor measures itself, ROS-free: sensor silence, platform speed, time the target has
been lost, and the drone's flight state from the navdata state code."""
import collections
import math

from .conditions import MISSING
from .supervisor import Flight

# landing_msgs/Navdata state codes (ardrone_autonomy's numbering).
NAVDATA_LANDED, NAVDATA_CRASHED = 2, 10
NAVDATA_AIRBORNE = (3, 4, 6, 7, 8, 9)  # flying, hovering, taking off, go-to-hover, landing, looping


def flight_from_navdata(state):
    if state in (NAVDATA_LANDED, NAVDATA_CRASHED):
        return Flight.LANDED
    if state in NAVDATA_AIRBORNE:
        return Flight.AIRBORNE
    return Flight.UNKNOWN


class SensorWatchdog:
    """Sim seconds since each sensor topic last published. A sensor never heard of counts from the
    moment the watchdog started, so a topic that never comes is reported missing after the timeout."""

    def __init__(self, names):
        self.last = {name: None for name in names}
        self.start = None

    def seen(self, name, t):
        self.last[name] = t

    def silence(self, name, t):
        if self.start is None:
            self.start = t
        last = self.last[name]
        return max(0.0, t - (self.start if last is None else last))


class PlatformSpeed:
    """Ground speed of the pad: the Kalman filter's estimate while it is fresh, else the vehicle's own
    GPS velocity averaged over ``window_s`` (its 0.1 m/s noise would otherwise flicker a threshold)."""

    def __init__(self, filtered_timeout_s=1.0, window_s=1.0, gps_timeout_s=1.0):
        self.filtered_timeout_s, self.window_s, self.gps_timeout_s = filtered_timeout_s, window_s, gps_timeout_s
        self.filtered = None  # (t, speed)
        self.gps = collections.deque()

    def on_filtered(self, t, vx, vy):
        self.filtered = (t, math.hypot(vx, vy))

    def on_gps(self, t, vx, vy):
        self.gps.append((t, math.hypot(vx, vy)))
        while self.gps and self.gps[0][0] < t - self.window_s:
            self.gps.popleft()

    def value(self, t):
        if self.filtered is not None and t - self.filtered[0] <= self.filtered_timeout_s:
            return self.filtered[1]
        if self.gps and t - self.gps[-1][0] <= self.gps_timeout_s:
            recent = [speed for stamp, speed in self.gps if stamp >= t - self.window_s] or [self.gps[-1][1]]
            return sum(recent) / len(recent)
        return MISSING

    def source(self, t):
        if self.filtered is not None and t - self.filtered[0] <= self.filtered_timeout_s:
            return "kalman_platform_odom"
        return "summit_xl/gps/odom" if self.gps and t - self.gps[-1][0] <= self.gps_timeout_s else None


class TargetLostTimer:
    """How long the tracker has been searching for the pad (its state is ``lost_state``, RELOCATING)."""

    def __init__(self, lost_state="RELOCATING"):
        self.lost_state, self.lost_since = lost_state, None

    def on_state(self, t, state):
        if state == self.lost_state:
            if self.lost_since is None:
                self.lost_since = t
        else:
            self.lost_since = None

    def value(self, t):
        return 0.0 if self.lost_since is None else max(0.0, t - self.lost_since)
