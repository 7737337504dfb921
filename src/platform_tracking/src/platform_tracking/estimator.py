"""The drone's own pose and velocity in ``world``, ROS-free, from its on-board sensors only.

Ground truth never enters here (docs/conventions.md). The sensors and what each contributes:

- IMU orientation (50 Hz): attitude and yaw, used as measured (the AR.Drone's own attitude filter
  already fuses gyro and accelerometer; its noise is 0.2 deg).
- Optical-flow velocity from navdata (50 Hz, heading frame, 0.05 m/s): rotated to ``world`` with the
  IMU yaw and integrated into the horizontal position (dead reckoning: smooth, but it drifts).
- GPS position (5 Hz, 0.3 m per axis): pulls the integrated position back so it cannot drift. It is a
  Kalman measurement update of a [x, y, flow bias forward, flow bias left] filter, so a single fix
  moves the estimate by a centimetre or two instead of the 0.3 m of its noise.
- GPS velocity (5 Hz, 0.1 m/s): compared with the flow, it measures the flow's bias, so a biased flow
  is corrected instead of turning into a position error (differentiating the noisy positions for
  that would let their noise into the estimate).
- Barometric altimeter (20 Hz, 0.1 m) and navdata ``vz``: the same filter along z. GPS altitude is a
  weak extra measurement. The sonar (1 cm, but to whatever surface is below: pad, vehicle or ground)
  corrects z only while it agrees with the estimate to within ``sonar_ground_gate``, i.e. while it
  can only be seeing the ground; over the pad it disagrees by the pad height and is ignored here (the
  tracker uses it directly as height above the pad).

Each sensor call carries its own time stamp; the filter predicts to that time with the last flow
velocity (zero-order hold) before using it, so message rates and arrival order may vary.
"""
import dataclasses
import math

import numpy as np
from landing_msgs.geometry import yaw_from_quaternion

from .params import EstimatorParams


def heading_to_world(vx, vy, yaw):
    """Heading-frame (forward, left) vector -> world (x, y)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return c * vx - s * vy, s * vx + c * vy


def world_to_heading(vx, vy, yaw):
    """World (x, y) vector -> heading frame (forward, left)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return c * vx + s * vy, -s * vx + c * vy


class AxisFilter:
    """Kalman filter of one axis with state [position p]; the measured velocity is the input.

    Process noise per second: ``q_position`` (unmodelled errors) plus the integrated noise of the
    measured velocity."""

    def __init__(self, q_position, velocity_std):
        self.q_position, self.velocity_std = q_position, velocity_std
        self.p = 0.0
        self.var = 0.0
        self.initialised = False

    def reset(self, position, variance):
        self.p, self.var, self.initialised = position, variance, True

    def predict(self, dt, velocity):
        if dt <= 0.0 or not self.initialised:
            return
        self.p += velocity * dt
        self.var += self.q_position * dt + (self.velocity_std * dt) ** 2

    def innovation(self, measured):
        """(innovation, its variance without the measurement noise)."""
        return measured - self.p, self.var

    def update(self, measured, variance):
        gain = self.var / (self.var + variance)
        self.p += gain * (measured - self.p)
        self.var *= 1.0 - gain

    def position_at(self, dt, velocity):
        return self.p + velocity * dt


class HorizontalFilter:
    """Kalman filter of the horizontal position with state [x, y, bias_forward, bias_left].

    The optical flow measures the heading-frame velocity plus a slowly varying bias *in the heading
    frame* (it comes from the camera and its mounting, which turn with the drone), so the motion
    model is  p' = R(yaw) (flow - bias),  bias' = white noise. GPS fixes measure p."""

    def __init__(self, q_position, q_bias, velocity_std, initial_bias_std):
        self.q_position, self.q_bias, self.velocity_std = q_position, q_bias, velocity_std
        self.initial_bias_std = initial_bias_std
        self.x = np.zeros(4)
        self.P = np.zeros((4, 4))
        self.initialised = False

    def reset(self, position_xy, variance):
        self.x = np.array([position_xy[0], position_xy[1], 0.0, 0.0])
        self.P = np.diag([variance, variance, self.initial_bias_std ** 2, self.initial_bias_std ** 2])
        self.initialised = True

    @property
    def bias(self):
        return self.x[2:4]

    def world_velocity(self, flow_heading, yaw):
        """World velocity from a heading-frame flow reading, bias removed."""
        return np.array(heading_to_world(flow_heading[0] - self.x[2], flow_heading[1] - self.x[3], yaw))

    def predict_flow(self, dt, flow_heading, yaw):
        if dt <= 0.0 or not self.initialised:
            return
        c, s = math.cos(yaw), math.sin(yaw)
        self.x[:2] += self.world_velocity(flow_heading, yaw) * dt
        F = np.eye(4)
        F[0:2, 2:4] = -dt * np.array([[c, -s], [s, c]])
        self._propagate(F, dt)

    def predict_world(self, dt, velocity_world):
        """Dead reckoning on a velocity that is not the flow (GPS velocity, or zero): no bias in it."""
        if dt <= 0.0 or not self.initialised:
            return
        self.x[:2] += np.asarray(velocity_world[:2]) * dt
        self._propagate(np.eye(4), dt)

    def _propagate(self, F, dt):
        q = self.q_position * dt + (self.velocity_std * dt) ** 2
        self.P = F @ self.P @ F.T + np.diag([q, q, self.q_bias * dt, self.q_bias * dt])

    def update_velocity(self, velocity_world, flow_heading, yaw, variance):
        """GPS velocity against the flow: measures the flow bias. The predicted measurement is
        R(yaw) (flow - bias), so H = [0 | -R(yaw)]; ``variance`` covers both sensors' noise."""
        c, s = math.cos(yaw), math.sin(yaw)
        rotation = np.array([[c, -s], [s, c]])
        innovation = np.asarray(velocity_world[:2]) - self.world_velocity(flow_heading, yaw)
        H = np.zeros((2, 4))
        H[:, 2:4] = -rotation
        S = H @ self.P @ H.T + variance * np.eye(2)
        if float(innovation @ np.linalg.solve(S, innovation)) > 25.0:
            return False  # e.g. flow and fix taken across a hard acceleration
        gain = self.P @ H.T @ np.linalg.inv(S)
        self.x += gain @ innovation
        self.P = self.P - gain @ H @ self.P
        self.P = 0.5 * (self.P + self.P.T)
        return True

    def mahalanobis2(self, position_xy, variance):
        innovation = np.asarray(position_xy[:2]) - self.x[:2]
        S = self.P[:2, :2] + variance * np.eye(2)
        return float(innovation @ np.linalg.solve(S, innovation))

    def update(self, position_xy, variance):
        innovation = np.asarray(position_xy[:2]) - self.x[:2]
        S = self.P[:2, :2] + variance * np.eye(2)
        gain = self.P[:, :2] @ np.linalg.inv(S)
        self.x += gain @ innovation
        self.P = self.P - gain @ self.P[:2, :]
        self.P = 0.5 * (self.P + self.P.T)


@dataclasses.dataclass
class Estimate:
    """The estimate at ``time``: world position [m], world velocity [m/s], orientation (w, x, y, z),
    yaw [rad], position variances (x, y, z) [m^2]."""
    time: float
    position: np.ndarray
    velocity: np.ndarray
    orientation: tuple
    yaw: float
    position_variance: np.ndarray


class DroneEstimator:
    """Fuses the drone's sensors into an ``Estimate``; see the module docstring."""

    def __init__(self, params: EstimatorParams = EstimatorParams(), log=None):
        self.p = params
        self.log = log or (lambda message: None)
        self.horizontal = HorizontalFilter(params.position_process_noise, params.flow_bias_process_noise,
                                           params.flow_velocity_std, params.initial_flow_bias_std)
        self.vertical = AxisFilter(params.altitude_process_noise, params.flow_velocity_std)
        self.time = None                 # time the filters are at
        self.orientation = None          # last IMU orientation (w, x, y, z)
        self.yaw = 0.0
        self.tilt_cos = 1.0              # cosine of the tilt: body z . world z
        self.flow_heading = None         # last flow reading (forward, left, up) and its time
        self.flow_time = None
        self.gps_velocity = None         # fallback when the flow stops, world frame, and its time
        self.gps_velocity_time = None
        self.gps_rejections = 0
        # Part of the latest corrections not yet passed on to the published position (see estimate()).
        self.pending_correction = np.zeros(3)
        self.counters = {"gps_used": 0, "gps_rejected": 0, "gps_reanchored": 0, "sonar_used": 0,
                         "altimeter_rejected": 0}

    # ----- state ---------------------------------------------------------------------------------
    @property
    def ready(self):
        """True once attitude, a horizontal fix and a height are known."""
        return self.orientation is not None and self.horizontal.initialised and self.vertical.initialised

    def _flow_fresh(self, t):
        return self.flow_heading is not None and t - self.flow_time <= self.p.flow_timeout

    def _velocity(self, t):
        """World velocity (x, y, z) the motion model integrates at ``t``: the flow while it is
        fresh, else the last GPS velocity while that is fresh, else none (the position then holds
        while its variance grows)."""
        if self._flow_fresh(t):
            vx, vy = self.horizontal.world_velocity(self.flow_heading, self.yaw)
            return np.array([vx, vy, self.flow_heading[2]])
        if self.gps_velocity is not None and t - self.gps_velocity_time <= self.p.flow_timeout:
            return np.array(self.gps_velocity, dtype=float)
        return np.zeros(3)

    def _advance(self, t):
        if self.time is None:
            self.time = t
            return
        dt = t - self.time
        if dt <= 0.0:
            return  # a late message is used as if taken now: its age is below one sample period
        if self._flow_fresh(self.time):
            self.horizontal.predict_flow(dt, self.flow_heading, self.yaw)
        else:
            self.horizontal.predict_world(dt, self._velocity(self.time))
        self.vertical.predict(dt, self._velocity(self.time)[2])
        self.pending_correction *= math.exp(-dt / self.p.correction_smoothing_time) \
            if self.p.correction_smoothing_time > 0.0 else 0.0
        self.time = t

    def estimate(self, t=None):
        """The estimate moved to ``t`` (default: the latest measurement time) with the current velocity,
        also backwards: the sensors arrive on separate threads, so the filter may already be a sample
        ahead of the stamp asked for, and at 15 m/s a 10 ms mislabel is 15 cm. None before ``ready``."""
        if not self.ready:
            return None
        t = self.time if t is None else t
        dt = t - self.time
        velocity = self._velocity(self.time)
        position = np.array([self.horizontal.x[0] + velocity[0] * dt, self.horizontal.x[1] + velocity[1] * dt,
                             self.vertical.position_at(dt, velocity[2])])
        # A measurement update moves the filter state at once; the published position takes that
        # step over correction_smoothing_time, so a consumer differentiating it sees no jump.
        smoothing = self.p.correction_smoothing_time
        position -= self.pending_correction * (math.exp(-max(0.0, dt) / smoothing) if smoothing > 0.0 else 0.0)
        variance = np.array([self.horizontal.P[0, 0], self.horizontal.P[1, 1], self.vertical.var])
        return Estimate(t, position, velocity, tuple(self.orientation), self.yaw, variance)

    # ----- sensors -------------------------------------------------------------------------------
    def imu(self, t, orientation_wxyz):
        """IMU orientation, world <- body, as (w, x, y, z)."""
        w, x, y, z = orientation_wxyz
        norm = math.sqrt(w * w + x * x + y * y + z * z)
        if not norm > 0.5:  # also false for NaN
            return False
        w, x, y, z = w / norm, x / norm, y / norm, z / norm
        self._advance(t)
        self.orientation = (w, x, y, z)
        self.yaw = yaw_from_quaternion(w, x, y, z)
        self.tilt_cos = 1.0 - 2.0 * (x * x + y * y)
        return True

    def flow(self, t, vx_heading, vy_heading, vz):
        """Navdata optical-flow velocity: forward/left in the heading frame, vertical [m/s]."""
        self._advance(t)
        self.flow_heading = (vx_heading, vy_heading, vz)
        self.flow_time = t
        return True

    def gps(self, t, position, velocity=None):
        """GPS fix: world position [m] and optionally world velocity [m/s]; returns whether it was used."""
        self._advance(t)
        if velocity is not None:
            self.gps_velocity, self.gps_velocity_time = tuple(velocity), t
        variance = self.p.gps_position_std ** 2
        if not self.horizontal.initialised:
            self.horizontal.reset(position, variance)
            self.log("position initialised from the first GPS fix (%.2f, %.2f)" % (position[0], position[1]))
        elif self.horizontal.mahalanobis2(position, variance) > 2.0 * self.p.gps_gate_sigma ** 2:
            # One wild fix must not yank the estimate; many in a row mean the estimate is wrong.
            self.gps_rejections += 1
            self.counters["gps_rejected"] += 1
            if self.gps_rejections < self.p.gps_max_rejections:
                return False
            self.log("%d GPS fixes in a row disagree with the estimate; re-anchoring to GPS" % self.gps_rejections)
            self.counters["gps_reanchored"] += 1
            self.horizontal.reset(position, variance)
            self.pending_correction[:2] = 0.0  # a re-anchoring is a real jump: publish it as one
        else:
            before = self.horizontal.x[:2].copy()
            self.horizontal.update(position, variance)
            self.pending_correction[:2] += self.horizontal.x[:2] - before
        self.gps_rejections = 0
        self.counters["gps_used"] += 1
        if velocity is not None and self.p.use_gps_velocity and self._flow_fresh(t):
            before = self.horizontal.x[:2].copy()
            self.horizontal.update_velocity(velocity, self.flow_heading, self.yaw,
                                            self.p.gps_velocity_std ** 2 + self.p.flow_velocity_std ** 2)
            self.pending_correction[:2] += self.horizontal.x[:2] - before
        if self.p.use_gps_altitude and len(position) > 2:
            if not self.vertical.initialised:
                self.vertical.reset(position[2], variance)
            else:
                self._update_vertical(position[2], variance)
        return True

    def _update_vertical(self, measured, variance):
        before = self.vertical.p
        self.vertical.update(measured, variance)
        self.pending_correction[2] += self.vertical.p - before

    def altimeter(self, t, altitude):
        """Barometric altitude of base_link above the ground [m]; returns whether it was used."""
        self._advance(t)
        variance = self.p.altimeter_std ** 2
        if not self.vertical.initialised:
            self.vertical.reset(altitude, variance)
            return True
        innovation, prior = self.vertical.innovation(altitude)
        if innovation ** 2 > 25.0 * (prior + variance):
            self.counters["altimeter_rejected"] += 1
            return False
        self._update_vertical(altitude, variance)
        return True

    def sonar(self, t, distance):
        """Sonar range from the feet to the first surface below [m]. Corrects z only where that
        surface can only be the ground; returns whether it was used."""
        if not (math.isfinite(distance) and 0.0 < distance < self.p.sonar_max_range) or not self.vertical.initialised:
            return False
        self._advance(t)
        height = (distance + self.p.foot_clearance) * max(0.5, self.tilt_cos)  # base_link above that surface
        if abs(height - self.vertical.p) > self.p.sonar_ground_gate:
            return False
        self._update_vertical(height, self.p.sonar_std ** 2)
        self.counters["sonar_used"] += 1
        return True
