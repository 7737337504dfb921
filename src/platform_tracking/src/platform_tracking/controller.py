"""Horizontal tracking controller and the types it works on, ROS-free.

The velocity command is built in ``world`` and rotated into the *heading frame* at the very end
(``ardrone/cmd_vel``: linear.x forward, linear.y left of the drone's yaw-only frame):

    v_cmd = v_ff + (1 - w) ki * integral(e) + K e   (capped)
    e     = pad(t) - drone(t) + L * (v_pad(t) - v_drone)
    v_ff  = v_pad(t + T_v + w T_f) - w v_pad(t)

- ``w``: how much the drone's own velocity follows the vehicle under it (its firmware's optical flow over
  the vehicle, drone_estimator.flow_surface; 0 in the ideal world). The drone flies its command plus w times the
  vehicle's velocity (as its firmware's flow blended it in, over ``T_f``, flow_time_lead): at w = 1 the
  command is relative to the pad. The feed-forward then keeps only its lead, the change of the pad's
  velocity over T_v + T_f (the drone's velocity loop lags a ramp as much relative to the pad as over the
  ground: without it a back-and-forth's 1 m/s^2 ramps kept the drone 0.3 m off the pad), and the
  integral (what the drone falls short by in absolute flight: drag, wind) is the firmware's business.
  The integral is kept, not learnt, while w > 0.1: learnt there it held an estimate's bias, and turned
  round with the travel frame at a back-and-forth's reversal it pushed the drone off the pad.

- ``K``: ``along_track_gain`` on the error along the pad's travel (its changes of speed, which the prediction
  learns late), at most ``along_track_gain_latency`` over the measured camera latency, and over a pad as fast as
  ``along_track_gain_max_pad_speed`` only as far as the flow sees the pad (a fast car's drag leaves the drone too
  little acceleration for it in absolute flight); ``position_gain`` across it (turns, where a high gain overshoots)
  and before the pad ever moved.
- ``pad(t)`` comes from the *predicted* path (kalman_prediction_path); the prediction is ``age``
  seconds old when it arrives, so it is read at the current time, not at its stamp: that is the
  pipeline latency compensation.
- ``L`` (lookahead) compares where pad and drone will be a little later at their present velocities:
  a damping term on the relative velocity. (Reading the pad ``L`` ahead on its curved path instead
  would add a steady inward pull of a L^2 / 2 on every turn.)
- ``v_ff``: the pad's velocity ``T_v`` ahead (``velocity_lead``, the drone's velocity-loop response
  time), read off the predicted path, so that on a circle the drone turns with the pad instead of
  lagging behind it (a car on a 50 m circle at 10 m/s would otherwise pull it 0.7 m outwards). Without
  a path, the velocity is advanced by an acceleration measured from successive predictions.
"""
import bisect
import collections
import dataclasses
from typing import Optional, Sequence

import numpy as np
from drone_estimator.estimator import world_to_heading
from landing_runtime.geometry import yaw_from_quaternion

from .params import TrackingParams


@dataclasses.dataclass
class VelocityCommand:
    """cmd_vel in the heading frame: forward, left, climb [m/s]; yaw rate [rad/s]."""
    vx: float = 0.0
    vy: float = 0.0
    vz: float = 0.0
    yaw_rate: float = 0.0


@dataclasses.dataclass
class DroneState:
    """The drone's own estimate (never ground truth): world position and velocity, yaw, and the
    sonar range from the feet to the surface below (None when invalid or out of range)."""
    position: np.ndarray
    velocity: np.ndarray
    yaw: float
    sonar_height: Optional[float] = None
    # Where the bottom camera's axis meets a level surface, relative to the drone, per metre of height below
    # it (world x, y) [m/m]: the drone's tilt. None: straight down.
    view_shift: Optional[np.ndarray] = None

    @classmethod
    def from_attitude(cls, position, velocity, quaternion, sonar_height=None):
        """The state of an estimate whose attitude is the unit quaternion (w, x, y, z): its yaw, and its view
        shift from where the camera axis (the body's -z) meets a level surface; tilted beyond 60 deg, no view."""
        w, x, y, z = quaternion
        body_z = (2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y))
        view_shift = -np.array(body_z[:2]) / body_z[2] if body_z[2] > 0.5 else None
        return cls(np.asarray(position, dtype=float), np.asarray(velocity, dtype=float),
                   yaw_from_quaternion(w, x, y, z), sonar_height, view_shift)

    def viewing(self, height):
        """The state placed where the camera looks at ``height`` [m] below: flying that over the pad puts the
        pad in the middle of the image. At a car's speed the drone leans about 18 deg into the air stream,
        which turns the view centre 1.3 m away from below it at 4 m."""
        if self.view_shift is None:
            return self
        shifted = self.position.copy()
        shifted[:2] += max(0.0, height) * np.asarray(self.view_shift, dtype=float)
        return dataclasses.replace(self, position=shifted)

    def moved(self, dt):
        """The state ``dt`` seconds later at constant velocity: an estimate stamped a few samples ago
        is compared with the pad predicted for now, and at car speed every 10 ms is 15 cm."""
        return dataclasses.replace(self, position=self.position + self.velocity * dt)


class PadPrediction:
    """What the predictor says about the pad: its ``position`` and ``velocity`` (world) at ``stamp``
    and the predicted path as (times, positions), each time absolute. Read it with ``position_at``."""

    def __init__(self, stamp, position, velocity, path_times: Sequence[float] = (), path_positions=()):
        self.stamp = float(stamp)
        self.position = np.asarray(position, dtype=float)
        self.velocity = np.asarray(velocity, dtype=float)
        self.path_times = [float(t) for t in path_times]
        self.path_positions = np.asarray(path_positions, dtype=float).reshape(-1, 3)
        if len(self.path_times) != len(self.path_positions):
            raise ValueError("path has %d times but %d positions" % (len(self.path_times), len(self.path_positions)))
        if any(b < a for a, b in zip(self.path_times, self.path_times[1:])):
            raise ValueError("path times must not decrease")

    def moved_to(self, t, position_xy, velocity_xy):
        """The prediction moved so that at ``t`` the pad is at ``position_xy`` moving at ``velocity_xy`` (world)
        [m, m/s]; before and after it changes as predicted (a relative track of the pad, drone_estimator.relative,
        placing it where the world-frame prediction has drifted from)."""
        shift = np.asarray(position_xy, dtype=float) - self.position_at(t)[:2]
        now_velocity = self.path_velocity_at(t)
        drift = np.asarray(velocity_xy, dtype=float) - (self.velocity if now_velocity is None else now_velocity)[:2]

        def moved(time, position):
            out = np.array(position, dtype=float)
            out[:2] += shift + drift * (time - t)
            return out
        velocity = self.velocity.copy()
        velocity[:2] += drift
        return PadPrediction(self.stamp, moved(self.stamp, self.position), velocity, self.path_times,
                             [moved(time, position) for time, position in zip(self.path_times, self.path_positions)])

    @property
    def horizon(self):
        """Last time the prediction covers."""
        return self.path_times[-1] if self.path_times else self.stamp

    def age(self, t):
        return t - self.stamp

    def path_velocity_at(self, t, half_span=0.05):
        """Velocity at ``t`` by a central difference along the predicted path (the predicted velocity at
        its start, blended into it over ``half_span``); None beyond the path's end."""
        times = self.path_times
        if len(times) < 2 or t + half_span > times[-1]:
            return None
        if t < times[0] + half_span:
            ahead = self.path_velocity_at(times[0] + half_span, half_span)
            w = max(0.0, t - times[0]) / half_span
            return (1.0 - w) * self.velocity + w * ahead
        return (self.position_at(t + half_span) - self.position_at(t - half_span)) / (2.0 * half_span)

    def acceleration_at(self, t, span=0.2):
        """The pad's acceleration (world) at ``t``: the change of the path's velocity across ``span`` [m/s^2];
        zero where the path does not reach."""
        v0, v1 = self.path_velocity_at(t - 0.5 * span), self.path_velocity_at(t + 0.5 * span)
        if v0 is None or v1 is None:
            return np.zeros(3)
        return (v1 - v0) / span

    def speed_change_at(self, t, span=0.3):
        """Rate of change of the pad's speed over the next ``span`` seconds of the path [m/s^2] (braking
        < 0); 0 where the path does not reach. Turning at constant speed does not count."""
        v0, v1 = self.path_velocity_at(t), self.path_velocity_at(t + span)
        if v0 is None or v1 is None:
            return 0.0
        return float(np.hypot(*v1[:2]) - np.hypot(*v0[:2])) / span

    def sideways_acceleration_at(self, t, span=0.3):
        """The pad's acceleration across its travel over the next ``span`` seconds of the path [m/s^2]
        (speed times turn rate, left > 0); 0 where the path does not reach or the pad is slow."""
        v0, v1 = self.path_velocity_at(t), self.path_velocity_at(t + span)
        if v0 is None or v1 is None or min(np.hypot(*v0[:2]), np.hypot(*v1[:2])) < 0.3:
            return 0.0
        turn = np.arctan2(v1[1], v1[0]) - np.arctan2(v0[1], v0[0])
        turn = (turn + np.pi) % (2.0 * np.pi) - np.pi
        return float(0.5 * (np.hypot(*v0[:2]) + np.hypot(*v1[:2])) * turn / span)

    def turn_change_at(self, t, span=0.3):
        """How much the sideways acceleration changes from now to ``span`` seconds later [m/s^2]: large
        on entering or leaving a turn, about 0 on a straight line or a steady circle."""
        return self.sideways_acceleration_at(t + span, span) - self.sideways_acceleration_at(t, span)

    def position_at(self, t):
        """Predicted pad position at time ``t``: interpolated along the path, extrapolated with the
        velocity before its start and beyond its end."""
        times = self.path_times
        if len(times) < 2 or t <= times[0]:
            anchor_t, anchor = (times[0], self.path_positions[0]) if times else (self.stamp, self.position)
            return anchor + self.velocity * (t - anchor_t)
        if t >= times[-1]:
            return self.path_positions[-1] + self.velocity * (t - times[-1])
        i = bisect.bisect_right(times, t)
        t0, t1 = times[i - 1], times[i]
        w = (t - t0) / (t1 - t0) if t1 > t0 else 0.0
        return (1.0 - w) * self.path_positions[i - 1] + w * self.path_positions[i]


def clamp_norm(vector, limit):
    """``vector`` (2-D) scaled down to at most ``limit`` long."""
    norm = float(np.hypot(vector[0], vector[1]))
    if norm <= limit:
        return vector
    return vector * (limit / norm) if limit > 0.0 else vector * 0.0


class TrackingController:
    """PID on the predicted pad position with velocity and acceleration feed-forward."""

    def __init__(self, params: TrackingParams):
        self.p = params
        # The integral lives in the pad's travel frame (along, across its velocity): what the drone falls
        # short by on a turn (drag, its own loop's lag) is constant there, while in the world it rotates.
        self.integral = np.zeros(2)
        self.travel_heading = 0.0     # direction of the pad's velocity, kept while it stands still [rad]
        self.travel_known = False     # the pad has moved since this controller was made: travel_heading holds
        self.turn_changed_at = None   # when the pad last entered or left a turn [s]
        self.last_time = None
        self.velocity_history = collections.deque()  # (stamp, pad velocity) of recent predictions
        self.acceleration = np.zeros(2)

    def reset(self):
        """Forget the integral (on entering a state where it would be stale)."""
        self.integral[:] = 0.0
        self.last_time = None
        self.turn_changed_at = None

    def errors(self, t, drone: DroneState, pad: PadPrediction):
        """(error now, relative velocity now): horizontal pad minus drone, world frame."""
        error = pad.position_at(t)[:2] - drone.position[:2]
        relative_velocity = self.pad_velocity(t, pad) - drone.velocity[:2]
        return error, relative_velocity

    def pad_velocity(self, t, pad, ahead=0.0):
        """Pad velocity at ``t + ahead``: from the predicted path where it reaches, else from the last
        prediction's velocity and the acceleration estimate. The acceleration is extrapolated no
        further than the window it was measured over: an old prediction must not turn into an
        ever-growing speed command."""
        self._observe(pad)
        on_path = pad.path_velocity_at(t + ahead)
        if on_path is not None:
            return on_path[:2]
        horizon = min(max(0.0, pad.age(t)), self.p.acceleration_window) + ahead
        return pad.velocity[:2] + self.acceleration * horizon

    def _observe(self, pad):
        """Acceleration of the pad from its predicted velocities ``acceleration_window`` apart: a
        difference over a long baseline, because the velocity of each prediction is noisy."""
        history = self.velocity_history
        if history and pad.stamp <= history[-1][0]:
            return
        if history and pad.stamp - history[-1][0] > self.p.lost_timeout:
            history.clear()  # a gap: the old velocities say nothing about now
        history.append((pad.stamp, pad.velocity[:2].copy()))
        window = self.p.acceleration_window
        while len(history) > 2 and pad.stamp - history[1][0] >= window:
            history.popleft()
        span = pad.stamp - history[0][0]
        if window > 0.0 and span >= 0.5 * window:
            self.acceleration = (history[-1][1] - history[0][1]) / span
        else:
            self.acceleration = np.zeros(2)

    def world_velocity(self, t, drone: DroneState, pad: PadPrediction, accumulate=True, flow_weight=0.0,
                       camera_latency=0.0):
        """Horizontal velocity command in the world frame, as the drone flies it (see the module docstring for
        ``flow_weight``; ``camera_latency``: how late detections arrive after their image). ``accumulate`` False
        freezes the integral (it still applies: at speed it holds what the drone's own velocity loop falls
        short by)."""
        p = self.p
        error, relative_velocity = self.errors(t, drone, pad)
        error = error + p.lookahead * relative_velocity
        dt = 0.0 if self.last_time is None else max(0.0, min(0.2, t - self.last_time))
        self.last_time = t
        # The integral is for steady deficits (drag, the drone's own velocity loop falling short at
        # speed, on a straight line or a steady turn); while the pad brakes, speeds up, turns in or out of
        # a turn the error is a transient and integrating it would only overshoot afterwards (on a square
        # at 3 m/s it kept the drone 0.3 m off the pad along every side).
        pad_velocity = self.pad_velocity(t, pad)
        if np.hypot(*pad_velocity) > 0.3:
            self.travel_heading = float(np.arctan2(pad_velocity[1], pad_velocity[0]))
            self.travel_known = True
        c, s = np.cos(self.travel_heading), np.sin(self.travel_heading)
        to_world = np.array([[c, -s], [s, c]])
        turn_change = abs(pad.turn_change_at(t)) > p.integral_max_pad_acceleration
        if turn_change:
            self.turn_changed_at = t
        # After a corner the drone overshoots across the pad's travel for about a second: a transient too.
        # (Not after a change of speed: on a reversal the travel frame turns round, and the integral that
        # holds against the wind must be re-learnt at once.)
        settled = self.turn_changed_at is None or t - self.turn_changed_at >= p.integral_turn_settle_time
        steady = settled and not turn_change and abs(pad.speed_change_at(t)) <= p.integral_max_pad_acceleration
        w = min(1.0, max(0.0, flow_weight))
        if accumulate and steady and flow_weight <= 0.1 and np.hypot(*error) < p.integral_error_limit and \
                p.integral_gain > 0.0:
            self.integral += to_world.T @ error * dt
            self.integral = clamp_norm(self.integral, p.integral_speed_limit / p.integral_gain)
        # Along the pad's travel the error comes from its changes of speed, which the prediction learns late
        # (a pull-away, a braking); across it from turns, where a higher gain overshoots the corner. How high the
        # gain may go depends on the delay in the loop, mostly the camera's.
        along_gain = self.along_track_gain(camera_latency, float(np.hypot(*pad_velocity)), w) if self.travel_known \
            else p.position_gain
        proportional = to_world @ (np.array([along_gain, p.position_gain]) * (to_world.T @ error))
        correction = clamp_norm(proportional + (1.0 - w) * p.integral_gain * (to_world @ self.integral),
                                p.max_correction_speed)
        feed = self.pad_velocity(t, pad, ahead=p.velocity_lead + w * p.flow_time_lead)
        if w > 0.0:
            feed = feed - w * pad_velocity
        return clamp_norm(feed + correction, p.max_horizontal_speed)

    def along_track_gain(self, camera_latency, pad_speed=0.0, flow_weight=0.0):
        """The gain along the pad's travel: a loop with a delay bears a gain up to about the inverse of that delay
        (``camera_latency``, 0 when not known yet). Flying over the ground (``flow_weight`` 0) above a pad as fast as
        ``along_track_gain_max_pad_speed`` the drone's velocity loop, its tilt half spent on the drag, saturates at
        more than ``position_gain``; low over the pad, where its flow follows the pad (weight 1), it keeps up."""
        p = self.p
        gain = p.along_track_gain if camera_latency <= 0.0 else \
            max(p.position_gain, min(p.along_track_gain, p.along_track_gain_latency / camera_latency))
        if pad_speed >= p.along_track_gain_max_pad_speed:
            gain = flow_weight * gain + (1.0 - flow_weight) * p.position_gain
        return gain

    @staticmethod
    def to_heading_frame(world_xy, yaw):
        return world_to_heading(float(world_xy[0]), float(world_xy[1]), yaw)


def hold_position_command(drone: DroneState, target_xy, params: TrackingParams, feed_forward_xy=(0.0, 0.0)):
    """World velocity towards a fixed point (with an optional feed-forward), capped."""
    error = np.asarray(target_xy[:2], dtype=float) - drone.position[:2]
    correction = clamp_norm(params.position_gain * error, params.max_correction_speed)
    return clamp_norm(np.asarray(feed_forward_xy, dtype=float) + correction, params.max_horizontal_speed)


def climb_rate_towards(height, target_height, params: TrackingParams, limit=None):
    """P control of the height above the pad, capped; zero inside a 3 cm band so the drone's own
    altitude hold takes over."""
    error = target_height - height
    if abs(error) < 0.03:
        return 0.0
    limit = params.max_climb_rate if limit is None else limit
    return max(-limit, min(limit, params.height_gain * error))
