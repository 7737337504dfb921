"""Open-loop vehicle paths, ROS-free: each maps sim time to a (speed [m/s], yaw rate [rad/s]) command.

The simulator limits acceleration, so the step changes below become realistic ramps.
"""
import math

import numpy as np

PATHS = ("straight", "circle", "figure8", "back_and_forth", "square", "stop_and_go", "random")


class PathError(ValueError):
    pass


class Path:
    """``speed`` [m/s] and ``radius`` [m] as in the scenario file; ``seed`` for the random path."""

    def __init__(self, kind, speed, radius=10.0, seed=0):
        if kind not in PATHS:
            raise PathError("unknown path '%s'; expected one of %s" % (kind, ", ".join(PATHS)))
        if not (math.isfinite(speed) and 0.0 <= speed <= 40.0):
            raise PathError("speed %r m/s is outside [0, 40]" % speed)
        if not (math.isfinite(radius) and radius > 0.0):
            raise PathError("radius %r m must be a positive number" % radius)
        self.kind, self.speed, self.radius = kind, speed, radius
        self._random_segments = self._make_random_segments(seed) if kind == "random" else None

    def command(self, t):
        """(speed, yaw_rate) at ``t`` seconds after the start."""
        v, r = self.speed, self.radius
        if t < 0.0 or v == 0.0:
            return 0.0, 0.0
        if self.kind == "straight":
            return v, 0.0
        if self.kind == "circle":
            return v, v / r
        if self.kind == "figure8":
            loop = 2.0 * math.pi * r / v
            return v, (v / r) if (t % (2 * loop)) < loop else -(v / r)
        if self.kind == "back_and_forth":
            leg = 2.0 * r / v  # drive 2*radius forward, then the same back
            return (v if (t % (2 * leg)) < leg else -v), 0.0
        if self.kind == "square":
            return self._square(t)
        if self.kind == "stop_and_go":
            return (v if (t % 8.0) < 5.0 else 0.0), 0.0
        return self._random(t)

    def _square(self, t):
        """Sides of 2*radius joined by quarter turns of radius 0.2*radius."""
        v, side, corner = self.speed, 2.0 * self.radius, 0.2 * self.radius
        straight_time, turn_time = side / v, (math.pi / 2) * corner / v
        phase = t % (straight_time + turn_time)
        return (v, 0.0) if phase < straight_time else (v, v / corner)

    def _make_random_segments(self, seed):
        rng = np.random.default_rng(seed)
        segments, t = [], 0.0
        while t < 3600.0:
            duration = rng.uniform(3.0, 6.0)
            segments.append((t, rng.uniform(0.6, 1.0), rng.uniform(-1.0, 1.0)))
            t += duration
        return segments

    def _random(self, t):
        """Piecewise-constant speed (60-100 % of nominal) and curvature (up to 1/radius)."""
        index = 0
        for i, (start, _, _) in enumerate(self._random_segments):
            if start > t:
                break
            index = i
        _, speed_scale, curvature = self._random_segments[index]
        speed = self.speed * speed_scale
        return speed, speed * curvature / self.radius
