"""Checks of incoming messages shared by the nodes' ROS wrappers, ROS-free.

A driver or a bug can publish garbage on any topic: NaN, inf, values no vehicle reaches, stamps from
another time, frames of another tree, unknown words. A wrapper asks these functions what is wrong with
a message (None: nothing) and drops it with ``RejectionLog.reject``, which logs each kind of problem on
each topic once per ``period_s`` with what was wrong and how many more were dropped meanwhile, so a
flood of garbage neither floods the log nor hides a new kind of problem.

    log = RejectionLog(rospy.logwarn)
    problem = numbers_problem(position=(p.x, p.y, p.z), limit=MAX_POSITION_M) or \\
        stamp_problem(msg.header.stamp.to_sec(), rospy.get_time())
    if problem:
        return log.reject("ardrone/gps/odom", problem)

Each problem is ``(kind, detail)``: ``kind`` is one of KINDS (the throttle's key), ``detail`` says what
was wrong in words.
"""
import math
import threading
import time

# Limits of a plausible value: beyond them a number is garbage whatever the scenario.
MAX_POSITION_M = 1e5     # farther from the world origin than any vehicle drives in a day (25 m/s for an hour: 90 km)
MAX_ALTITUDE_M = 1e4     # above ground, and below it, for any altitude or height [m]
MAX_SPEED_MPS = 100.0    # beyond the car's 25 m/s and the drone's 20 m/s, for any velocity [m/s]
MAX_RATE_RADPS = 100.0   # angular rates [rad/s]
MAX_ACCEL_MPS2 = 1e3     # accelerations, specific forces [m/s^2]
# Stamps: a message is about the recent past. Later than the node's clock by more than MAX_FUTURE_S it comes
# from the future (the clock of /clock ticks at 60 Hz: a message may be stamped a tick ahead of a subscriber's
# clock); older than MAX_AGE_S it is from another time (the harsh profile's links deliver within 0.3 s; a
# node restarts its filters when time jumps back by a second). landing_runtime/input_check.h has the same limits.
MAX_FUTURE_S = 0.5
MAX_AGE_S = 2.0

KINDS = ("non-finite", "out of range", "stamp from the future", "stamp from the past", "wrong frame", "empty",
         "malformed", "unknown value", "repeated")


def numbers_problem(limit=math.inf, **named):
    """(kind, detail) for the first named number (or sequence of numbers) that is not finite or beyond
    +-``limit``, else None. ``numbers_problem(limit=MAX_SPEED_MPS, velocity=(v.x, v.y, v.z))``."""
    for name, values in named.items():
        sequence = values if isinstance(values, (list, tuple)) else (values,)
        for index, value in enumerate(sequence):
            try:
                number = float(value)
            except (TypeError, ValueError):
                return "malformed", "%s is %r, not a number" % (_label(name, values, index), value)
            if not math.isfinite(number):
                return "non-finite", "%s is %s" % (_label(name, values, index), number)
            if abs(number) > limit:
                return "out of range", "%s = %.3g is beyond +-%g" % (_label(name, values, index), number, limit)
    return None


def _label(name, values, index):
    """How numbers_problem names a value: ``name`` alone, or ``name[index]`` in a sequence."""
    return "%s[%d]" % (name, index) if isinstance(values, (list, tuple)) else name


def stamp_problem(stamp, now, max_age=MAX_AGE_S, max_future=MAX_FUTURE_S):
    """(kind, detail) when a header stamp [s] is too far from the node's clock ``now`` [s], else None. A zero
    stamp means "now" by the convention of these nodes and passes; so does everything before the clock runs."""
    if stamp == 0.0 or now <= 0.0:
        return None
    if not math.isfinite(stamp):
        return "non-finite", "stamp is %s" % stamp
    if stamp > now + max_future:
        return "stamp from the future", "stamped %.3f s, %.2f s after the clock (%.3f s)" % (stamp, stamp - now, now)
    if stamp < now - max_age:
        return "stamp from the past", "stamped %.3f s, %.2f s before the clock (%.3f s)" % (stamp, now - stamp, now)
    return None


def frame_problem(frame_id, expected, empty_ok=True):
    """(kind, detail) when ``frame_id`` is not one of ``expected`` (a name or a tuple of names; a leading '/' is
    ignored; empty passes when ``empty_ok``), else None."""
    names = (expected,) if isinstance(expected, str) else tuple(expected)
    frame = frame_id[1:] if frame_id.startswith("/") else frame_id
    if frame in names or (empty_ok and frame == ""):
        return None
    return "wrong frame", "frame '%s', expected %s" % (frame_id[:60], " or ".join("'%s'" % n for n in names))


def choice_problem(value, allowed, what="value"):
    """(kind, detail) when ``value`` is not one of ``allowed``, else None."""
    if value in allowed:
        return None
    return "unknown value", "%s %r, expected one of %s" % (what, value[:60] if isinstance(value, str) else value,
                                                          ", ".join(map(str, allowed)))


def first_problem(*problems):
    """The first of several checks' results that is a problem, else None (all are evaluated: keep them cheap)."""
    return next((p for p in problems if p), None)


class RejectionLog:
    """Logs dropped messages once per (topic, kind) every ``period_s`` of ``clock()`` (the node's clock: sim time
    under the simulator, as rospy's and roscpp's throttled logging), with the detail of the first one and the
    number dropped since the last line. ``warn(text)`` writes the line (rospy.logwarn); thread-safe."""

    def __init__(self, warn, period_s=5.0, clock=time.monotonic):
        self.warn, self.period_s, self.clock = warn, period_s, clock
        self._lock = threading.Lock()
        self._last = {}     # (topic, kind) -> wall time of the last line
        self._dropped = {}  # (topic, kind) -> messages dropped since then
        self.counts = {}    # (topic, kind) -> messages dropped in all

    def reject(self, topic, problem):
        """Drop a message on ``topic`` for ``problem`` ((kind, detail), as the checks return); returns None so a
        callback can ``return log.reject(...)``."""
        kind, detail = problem
        key = (topic, kind)
        now = self.clock()
        with self._lock:
            self.counts[key] = self.counts.get(key, 0) + 1
            last = self._last.get(key)
            if last is not None and 0.0 <= now - last < self.period_s:  # (a clock gone back logs at once)
                self._dropped[key] = self._dropped.get(key, 0) + 1
                return None
            more = self._dropped.pop(key, 0)
            self._last[key] = now
        self.warn("rejected input on %s [%s]: %s%s" % (
            topic, kind, detail, "; %d more like it in the last %.0f s" % (more, now - last) if more else ""))
        return None


class RosRejectionLog(RejectionLog):
    """RejectionLog that writes with rospy.logwarn and names topics as the node resolves them."""

    def __init__(self, period_s=5.0):
        import rospy
        # rospy's functions are looked up at each call (tests replace them)
        super().__init__(lambda text: rospy.logwarn(text), period_s, clock=lambda: rospy.get_time())
        self._rospy = rospy

    def reject(self, topic, problem):
        return super().reject(self._rospy.resolve_name(topic), problem)
