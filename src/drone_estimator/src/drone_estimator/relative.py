"""Where the pad is relative to the drone, carried on between the camera's fixes by the drone's own optical
flow, ROS-free.

Low over the pad the AR.Drone's flow sees the pad's texture and nothing else (its weight w, flow_surface.py, is
1): its navdata velocity then *is* the drone's velocity relative to the pad, measured a navdata's delay late,
whatever the vehicle does. The world-frame route (the pad filter's prediction minus the drone's estimate) has to
learn every braking and pull-away from the camera's fixes, 0.4-0.7 s late, and in the last half metre, where the
camera no longer sees the pad's centre, it drifted 0.15 m from the pad within a second (stop-and-go at 3 m/s: the
touchdowns that ended 0.25 m from the centre). So, with ``seen`` the flow's velocity (world frame) and ``v_pad``
the predicted pad velocity:

    d/dt (pad - drone) = v_pad - v_drone = (1 - w) v_pad - seen + w T_f a_pad
    (seen = v_drone - w v_pad + w T_f a_pad)

The last term: the firmware's velocity estimate follows its IMU, which feels the drone's accelerations but not the
vehicle's, and takes the flow in over ``T_f`` (``flow_lag``): while the vehicle speeds up at ``a_pad`` the estimate
lags its share of it by T_f a_pad (0.17 m/s on a Summit XL's 1 m/s^2 ramp, where touchdowns committed on a relative
speed of 0.02-0.06 m/s met one of 0.24-0.26 m/s and ended 0.17-0.19 m from the centre).

integrated from the latest fix of the pad relative to the drone (each fix pulls the track towards it by
``fix_gain``, at the fix's capture time, and the motion since is integrated again), for at most ``max_age`` after
it. At w = 1 no estimate of the pad's velocity enters at all.
"""
import bisect
import collections

import numpy as np


class RelativeTrack:
    """The pad's horizontal position relative to the drone (pad - drone, world axes) [m] and its rate [m/s]."""

    HISTORY = 2.0  # how long the flow's samples are kept: a fix arrives up to a camera latency late [s]

    def __init__(self, fix_gain, max_age, flow_lag=0.0):
        self.fix_gain, self.max_age, self.flow_lag = fix_gain, max_age, flow_lag
        # (time, rate of pad - drone, its x, its y) from each flow sample, oldest first (the rate's components as
        # floats too: _carried sums a hundred of them, and numpy's arithmetic on two-element arrays cost 5x more)
        self.motion = collections.deque()
        self.anchor = None                 # (time, relative position) of the latest fix, filtered

    def reset(self):
        self.motion.clear()
        self.anchor = None

    def add_motion(self, t, seen_xy, weight, pad_velocity_xy, pad_acceleration_xy=(0.0, 0.0)):
        """A flow sample at ``t``: its velocity (world x, y) [m/s], the flow's weight [-] and the pad's predicted
        velocity [m/s] and acceleration [m/s^2]. Samples going back in time start the track afresh (the clock jumped
        back)."""
        rate = (1.0 - weight) * np.asarray(pad_velocity_xy, dtype=float) - np.asarray(seen_xy, dtype=float) + \
            weight * self.flow_lag * np.asarray(pad_acceleration_xy, dtype=float)
        self.add_rate(t, rate)

    def add_rate(self, t, rate_xy):
        """The rate of pad - drone (world x, y) [m/s] at ``t``, worked out by the caller; going back in time starts the
        track afresh."""
        if self.motion and t < self.motion[-1][0]:
            self.reset()
        rate = np.asarray(rate_xy, dtype=float)
        self.motion.append((t, rate, float(rate[0]), float(rate[1])))
        while len(self.motion) > 2 and self.motion[0][0] < t - self.HISTORY:
            self.motion.popleft()

    def add_fix(self, t, relative_xy):
        """The camera's fix at its capture time ``t``: pad minus drone (world x, y) [m]."""
        relative = np.asarray(relative_xy, dtype=float)
        # Without a flow sample (no flow on the link yet, or none at all in the ideal world) there is nothing to
        # carry the previous fix on with: the new one replaces it.
        if self.anchor is None or not self.motion or t < self.anchor[0] or t - self.anchor[0] > self.max_age:
            self.anchor = (t, relative)
            return
        carried = self._carried(t)
        self.anchor = (t, carried + self.fix_gain * (relative - carried))

    def at(self, t):
        """(relative position, its rate) at ``t``, or None without a fix within max_age or a flow sample."""
        if self.anchor is None or not self.motion or t - self.anchor[0] > self.max_age or t < self.anchor[0]:
            return None
        return self._carried(t), self._rate_at(t)

    def _rate_at(self, t):
        times = [m[0] for m in self.motion]
        i = bisect.bisect_right(times, t)
        return self.motion[max(0, i - 1)][1]

    def _carried(self, t):
        """The anchor carried on to ``t`` by the flow's rates: between two samples their mean, after the last its
        own, before the first its own."""
        t0, anchor = self.anchor
        x, y = float(anchor[0]), float(anchor[1])
        samples = list(self.motion)
        first_t, _, first_x, first_y = samples[0]
        if t0 < first_t:
            span = min(first_t, t) - t0
            x, y = x + first_x * span, y + first_y * span
        # Only the pairs of samples that overlap t0..t add anything: from the first one ending after t0 (the anchor
        # is a fix a camera latency old; the history holds 2 s) to the last one starting before t.
        first = max(0, bisect.bisect_right([m[0] for m in samples], t0) - 1)
        for (ta, _, ax, ay), (tb, _, bx, by) in zip(samples[first:], samples[first + 1:]):
            if ta >= t:
                break
            start, end = max(ta, t0), min(tb, t)
            if end > start:
                x, y = x + 0.5 * (ax + bx) * (end - start), y + 0.5 * (ay + by) * (end - start)
        last_t, _, last_x, last_y = samples[-1]
        if t > max(last_t, t0):
            span = t - max(last_t, t0)
            x, y = x + last_x * span, y + last_y * span
        return np.array([x, y])
