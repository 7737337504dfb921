"""Values the supervisor measures itself, ROS-free: sensor silence, platform speed, time the target has
been lost, and the drone's flight state from the navdata state code."""
import collections
import math
import statistics

from .conditions import MISSING, PENDING
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
    moment the watchdog started, so a topic that never comes is reported missing after the timeout;
    or, once its publisher has connected, from that moment: on a loaded machine the connection may come
    later than the sensor's first messages, and a sensor that is there must not be called missing."""

    def __init__(self, names):
        self.last = {name: None for name in names}
        self.connected_at = {name: None for name in names}
        self.start = None

    def seen(self, name, t):
        self.last[name] = t

    def connected(self, name, t):
        """The topic's first publisher connected at ``t``."""
        if self.connected_at[name] is None:
            self.connected_at[name] = t

    def silence(self, name, t):
        if self.start is None:
            self.start = t
        last = self.last[name]
        if last is None:
            last = max(self.start, self.connected_at[name] or self.start)
        return max(0.0, t - last)


class PlatformSpeed:
    """Ground speed of the pad: the vehicle's own reported GPS velocity while it is fresh, else the
    Kalman filter's estimate; each averaged over ``window_s``. The vehicle's report comes first because
    the filter's estimate jumps while it acquires or loses the pad (a 15 m/s car read as 24 m/s), and
    a single jump must not call the landing off. Until the first report has had ``gps_timeout_s`` to
    arrive after the first question, the speed is PENDING rather than missing."""

    SOURCES = (("gps", "summit_xl/gps/odom"), ("filtered", "kalman_platform_odom"))

    def __init__(self, filtered_timeout_s=1.0, window_s=1.0, gps_timeout_s=1.0):
        self.window_s = window_s
        self.timeouts = {"filtered": filtered_timeout_s, "gps": gps_timeout_s}
        self.samples = {"filtered": collections.deque(), "gps": collections.deque()}
        self.first_asked = None

    def _add(self, kind, t, vx, vy):
        samples = self.samples[kind]
        samples.append((t, math.hypot(vx, vy)))
        while samples and samples[0][0] < t - self.window_s:
            samples.popleft()

    def on_filtered(self, t, vx, vy):
        self._add("filtered", t, vx, vy)

    def on_gps(self, t, vx, vy):
        self._add("gps", t, vx, vy)

    def _fresh(self, t):
        for kind, topic in self.SOURCES:
            samples = self.samples[kind]
            if samples and t - samples[-1][0] <= self.timeouts[kind]:
                return kind, topic
        return None, None

    def value(self, t):
        kind, _ = self._fresh(t)
        if kind is None:
            self.first_asked = t if self.first_asked is None else self.first_asked
            never = not any(self.samples.values())
            return PENDING if never and t - self.first_asked <= self.timeouts["gps"] else MISSING
        samples = self.samples[kind]
        recent = [speed for stamp, speed in samples if stamp >= t - self.window_s] or [samples[-1][1]]
        return sum(recent) / len(recent)

    def source(self, t):
        return self._fresh(t)[1]


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


class TouchdownJudge:
    """Did the landing mission end on the pad? From the drone's own evidence, never ground truth: the
    tracker was in its own landing (not forced down, not searching) when it touched down, and the camera
    saw the pad centre within ``max_offset_m`` of the drone shortly before (``max_age_s``; the pad leaves
    the view in the last few decimetres): the median of the detections of that last ``max_age_s``, for a
    few centimetres above the pad the camera sees a fragment of it, which the detector may complete on the
    wrong side (a realistic soak: 0.68 m while the drone came to rest 0.045 m from the centre). Called as
    ``judge(t)`` -> (on the pad, why)."""

    def __init__(self, max_age_s, max_offset_m, landing_state="LANDING", landed_state="LANDED"):
        self.max_age_s, self.max_offset_m = max_age_s, max_offset_m
        self.landing_state, self.landed_state = landing_state, landed_state
        self.detections = collections.deque()  # (t, offset): pad centre's distance from the drone [m]
        self.state_before = None       # the tracker's last state before LANDED

    def on_detection(self, t, x, y):
        if self.detections and t < self.detections[-1][0]:
            self.detections.clear()  # time went back
        self.detections.append((t, math.hypot(x, y)))
        while self.detections[0][0] < t - self.max_age_s:
            self.detections.popleft()

    def on_tracker_state(self, state):
        if state != self.landed_state:
            self.state_before = state

    def __call__(self, t):
        if self.state_before != self.landing_state:
            return False, "the tracker was in %s, not in its own landing on the pad" % (self.state_before or "no state")
        if not self.detections:
            return False, "the camera never saw the pad"
        age = t - self.detections[-1][0]
        if age > self.max_age_s:
            return False, "the pad was last seen %.1f s before the touchdown" % age
        recent = [offset for seen, offset in self.detections if seen >= t - self.max_age_s]
        offset = statistics.median(recent)
        if offset > self.max_offset_m:
            return False, "the pad centre was %.2f m away in the last %.1f s (median of %d detections)" % (
                offset, self.max_age_s, len(recent))
        return True, "on the pad, %.2f m from its centre in the last %.1f s (median of %d detections, the latest " \
            "%.1f s before the touchdown)" % (offset, self.max_age_s, len(recent), age)
