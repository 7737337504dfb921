"""What the drone's own velocity (navdata vx, vy) means over the moving vehicle, ROS-free.

The AR.Drone's firmware estimates its velocity with the optical flow of its bottom camera, and flies
its velocity loop on that estimate. The flow measures motion relative to what the camera sees: over
the ground the drone's velocity, over the vehicle its velocity relative to the vehicle, and in between
a blend by how much of the view the vehicle's top covers (weight 0..1, landing_runtime.camera_footprint).
So, with ``w`` that weight and ``v_pad`` the vehicle's velocity:

    navdata velocity = v_drone - w v_pad          (the estimator adds w v_pad back)
    the drone flies at = command + w v_pad         (the tracker takes w v_pad off its command)

The estimator works ``w`` and ``w v_pad`` out, the latter from the vehicle's own velocity report (never
from the pad filter, whose fixes it places itself), and publishes both (ardrone/flow_unseen_velocity).
The tracker scales its feed-forward (the predicted pad velocity) by 1 - w: at w = 1 its command is the
correction alone, relative to the pad, and no error of any absolute velocity (the report's noise and
delay, the estimate's) moves the drone off it. The weight comes from the drone's estimated pose (its
height from the sonar), the predicted pad and what the flow can follow on the vehicle (a rectangle around
the pad, config/flow_surface_<vehicle>.yaml: the pad itself): the stack knows its drone's firmware as a calibration would tell it,
not from the simulator.
"""
import collections
import math

import numpy as np
from landing_runtime import camera_footprint

from .params import FlowSurfaceParams

# Optical frame (x right, y down, z forward) of the bottom camera in the body frame (docs/conventions.md).
CAMERA_OPTICAL_IN_BODY = np.array([[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
MIN_HEADING_SPEED = 0.3  # below this the pad's direction of travel is not its heading [m/s]


def rotation_of(w, x, y, z):
    """World <- body rotation matrix of a unit quaternion."""
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


class FlowSurface:
    def __init__(self, params: FlowSurfaceParams):
        self.p = params
        self.rays = camera_footprint.corner_rays(params.camera_hfov_deg, params.image_aspect)
        self.rectangle = (params.top_x_min, params.top_x_max, params.top_y_min, params.top_y_max)
        self.pad_yaw = 0.0  # the vehicle's heading, kept while it stands still
        self._view = (None, None, None)  # (orientation, body z axis in the world, world <- optical) of the last call

    @property
    def enabled(self):
        return self.p.enabled

    def weight(self, drone_position, orientation_wxyz, pad_position, pad_velocity):
        """How much the flow follows the vehicle (0: the ground, 1: the vehicle)."""
        if not self.p.enabled:
            return 0.0
        if math.hypot(pad_velocity[0], pad_velocity[1]) > MIN_HEADING_SPEED:
            self.pad_yaw = math.atan2(pad_velocity[1], pad_velocity[0])
        body_z, world_from_optical = self._rotations(orientation_wxyz)
        camera = np.asarray(drone_position, dtype=float) - self.p.camera_below_base_link * body_z
        corners = camera_footprint.footprint(camera, world_from_optical, self.rays, pad_position[2])
        if corners is None:  # at the pad's height or below: resting on it (or beside the vehicle)
            c, s = math.cos(self.pad_yaw), math.sin(self.pad_yaw)
            dx, dy = drone_position[0] - pad_position[0], drone_position[1] - pad_position[1]
            x, y = c * dx + s * dy, -s * dx + c * dy
            r = self.rectangle
            share = 1.0 if r[0] <= x <= r[1] and r[2] <= y <= r[3] else 0.0
        else:
            share = camera_footprint.coverage(corners, pad_position[:2], self.pad_yaw, self.rectangle)
        return camera_footprint.surface_weight(share, self.p.coverage_low, self.p.coverage_high)

    def _rotations(self, orientation_wxyz):
        """(body z axis in the world, world <- optical rotation) of an orientation, kept for the next call: the
        estimator asks for the weight at seven positions with one orientation per navdata."""
        key = tuple(float(q) for q in orientation_wxyz)
        if key != self._view[0]:
            rotation = rotation_of(*orientation_wxyz)
            self._view = (key, rotation[:, 2], rotation @ CAMERA_OPTICAL_IN_BODY)
        return self._view[1], self._view[2]

    def seen_pad_velocity(self, drone_position, orientation_wxyz, pad_position, pad_velocity):
        """The part of the pad's velocity (world x, y) the flow takes off the drone's: w v_pad."""
        w = self.weight(drone_position, orientation_wxyz, pad_position, pad_velocity)
        return w * np.asarray(pad_velocity[:2], dtype=float)


class WeightForecast:
    """The flow's weight at a later instant: the latest, moved on along its slope over the last ``window``
    seconds (a straight-line fit). The weight the tracker reads is a navdata old and its command reaches the
    drone a link's delay later; descending over a car at 15 m/s the weight rose 0.2 in 0.1 s, and 0.1 of it
    is 1.5 m/s the command does not take off."""

    def __init__(self, window=0.1):
        self.window = window
        self.samples = collections.deque()  # (time, weight)

    def add(self, t, weight):
        if self.samples and t < self.samples[-1][0]:
            self.samples.clear()  # time went back
        self.samples.append((t, weight))
        while len(self.samples) > 2 and self.samples[0][0] < t - self.window:
            self.samples.popleft()

    def at(self, t):
        if not self.samples:
            return 0.0
        last_t, last = self.samples[-1]
        if len(self.samples) < 2:
            return last
        times = np.array([s[0] for s in self.samples])
        weights = np.array([s[1] for s in self.samples])
        span = times - times.mean()
        slope = float(span @ (weights - weights.mean()) / (span @ span)) if span @ span > 0.0 else 0.0
        return min(1.0, max(0.0, last + slope * (t - last_t)))
