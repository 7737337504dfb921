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
- Barometric altimeter (20 Hz, 0.1 m) and navdata ``vz``: a filter along z that also learns the bias of
  ``vz`` (the firmware's climb estimate; ``VerticalFilter``). GPS altitude is a weak extra measurement.
  The sonar (1 cm, but to whatever surface is below: pad, vehicle or ground)
  corrects z only while it agrees with the estimate to within ``sonar_ground_gate``, i.e. while it
  can only be seeing the ground; over the pad it disagrees by the pad height and is ignored here (the
  tracker uses it directly as height above the pad).

Each sensor call carries its own time stamp; the filter predicts to that time with the last flow
velocity (zero-order hold) before using it, so message rates and arrival order may vary. A GPS fix
arrives 0.2-0.4 s after it was taken (receiver and link): it is compared with the estimate of that
instant (a short history), and the difference corrects the present state.

Over the moving vehicle the flow measures the drone's motion relative to the vehicle (the firmware's
optical flow follows what the camera sees, flow_surface.py): the part of the vehicle's velocity it takes
off is added back. The velocity is the vehicle's own report (its GPS/odometry: independent of this
estimate), turned on by its yaw rate over the report's age; the pad's predicted position
(kalman_platform_odom) places the vehicle in the view. Not the pad filter's velocity: that is made of
vision fixes placed with this very estimate, and over the pad, where the flow no longer sees the ground,
an error of the one became an error of the other (0.6 m/s within a second of descent in a test flight).
"""
import bisect
import collections
import dataclasses
import math

import numpy as np
from landing_runtime.geometry import turned_about_world_z, yaw_from_quaternion

from .flow_surface import rotation_of
from .relative import RelativeTrack

from .params import EstimatorParams

HISTORY_SPAN = 1.5  # seconds of past estimates kept for late GPS fixes [s]
PAD_MAX_AGE = 1.0   # a pad state older than this is not used to correct the flow [s]
SONAR_MAX_AGE = 0.2  # a sonar height older than this does not give the height above the pad [s]
SONAR_PAD_GATE = 0.25  # ...nor one further than this from the estimated height above the pad (the Summit XL's pad is
                       # 0.5 m above the ground: an echo from the ground must not pass) [m]
RIDING_MIN_SPEED = 2.0  # resting, the drone rides the vehicle when the vehicle is at least this fast... [m/s]
RIDING_MAX_MISMATCH = 1.0  # ...and its GPS velocity within this of the vehicle's: then it sits on the pad [m/s]


def heading_to_world(vx, vy, yaw):
    """Heading-frame (forward, left) vector -> world (x, y)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return c * vx - s * vy, s * vx + c * vy


def world_to_heading(vx, vy, yaw):
    """World (x, y) vector -> heading frame (forward, left)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return c * vx + s * vy, -s * vx + c * vy


class VerticalFilter:
    """Kalman filter of the altitude with state [p, b]: ``b`` the bias of the navdata's vertical velocity.

    The firmware's climb rate is its accelerometer integrated and pulled towards the sonar: a bias of the
    accelerometer, a sonar reading two surfaces by turns or a take-off's transient left it 0.3-0.5 m/s off for
    seconds (harsh), and integrated unchecked that put this estimate 1-3 m above the drone. The barometer and
    the sonar over the ground measure ``p``; the bias follows from their disagreement with the climb rate.

        p' = v - b   (v the navdata's climb rate)   or   p' = v   (a velocity without that bias: GPS, at rest)
        b' = noise (``q_bias``)

    On plain floats: for a 2x2 filter they are cheaper than numpy's arrays."""

    def __init__(self, q_position, velocity_std, q_bias, bias_std):
        self.q_position, self.velocity_std, self.q_bias, self.bias_std = q_position, velocity_std, q_bias, bias_std
        self.p = self.bias = 0.0
        self.var = self.cov = self.bias_var = 0.0  # P = [[var, cov], [cov, bias_var]]
        self.initialised = False

    def reset(self, position, variance):
        """A new altitude of ``variance``; the bias kept, uncertain again (a reset means the estimate was wrong)."""
        self.p, self.var, self.cov, self.bias_var = position, variance, 0.0, self.bias_std ** 2
        self.initialised = True

    def predict(self, dt, velocity, biased):
        """Move on by ``velocity`` [m/s], already less the bias when ``biased`` (the navdata's climb rate)."""
        if dt <= 0.0 or not self.initialised:
            return
        self.p += velocity * dt
        if biased:  # F = [[1, -dt], [0, 1]]
            self.var += -2.0 * dt * self.cov + dt * dt * self.bias_var
            self.cov -= dt * self.bias_var
        self.var += self.q_position * dt + (self.velocity_std * dt) ** 2
        self.bias_var += self.q_bias * dt

    def innovation(self, measured):
        """(innovation, its variance without the measurement noise)."""
        return measured - self.p, self.var

    def update(self, measured, variance):
        s = self.var + variance
        gain_p, gain_b = self.var / s, self.cov / s
        innovation = measured - self.p
        self.p += gain_p * innovation
        self.bias += gain_b * innovation
        self.bias_var -= gain_b * self.cov
        self.cov -= gain_p * self.cov
        self.var -= gain_p * self.var

    def position_at(self, dt, velocity):
        return self.p + velocity * dt


class HorizontalFilter:
    """Kalman filter of the horizontal position with state [x, y, b_forward, b_left, a, c].

    The drone reports its velocity in its heading frame: its firmware's optical flow, scaled by the
    height it measures (a scale error of a few per cent), with a small bias from the camera and its
    mounting (they turn with the drone). To the world it is turned with the IMU's yaw, which drifts (no
    magnetometer in the loop). Together:

        p' = R(yaw) (a f + c J f - b) + u,   J f = (-f_left, f_forward)

    where ``a`` = cos(drift) / scale and ``c`` = -sin(drift) / scale (a turn and a scaling of the flow, linear
    in the state), ``b`` the bias and ``u`` the part of the vehicle's velocity the flow did not see (over the
    vehicle, flow_surface.py). b, a and c are random walks; the GPS velocity against the flow measures
    them while the drone moves (at a hover a and c are unobservable, and matter as little), GPS fixes
    measure p."""

    def __init__(self, q_position, q_bias, velocity_std, initial_bias_std, q_scale=0.0, initial_scale_std=0.0):
        self.q_position, self.q_bias, self.velocity_std = q_position, q_bias, velocity_std
        self.initial_bias_std = initial_bias_std
        self.q_scale, self.initial_scale_std = q_scale, initial_scale_std
        self.x = np.zeros(6)
        self.P = np.zeros((6, 6))
        self.initialised = False

    def reset(self, position_xy, variance):
        self.x = np.array([position_xy[0], position_xy[1], 0.0, 0.0, 1.0, 0.0])
        self.P = np.diag([variance, variance, self.initial_bias_std ** 2, self.initial_bias_std ** 2,
                          self.initial_scale_std ** 2, self.initial_scale_std ** 2])
        self.initialised = True

    @property
    def bias(self):
        return self.x[2:4]

    @property
    def scale_and_turn(self):
        """(a, c): the flow's correction; a = 1, c = 0 for an exact flow and yaw."""
        return self.x[4], self.x[5]

    @property
    def turn(self):
        """What the IMU's yaw is short of the true heading by, as the flow's correction (a, c) has it [rad]:
        a = cos(drift) / scale, c = -sin(drift) / scale, and the heading is the reported yaw minus the drift."""
        return math.atan2(self.x[5], self.x[4]) if self.initialised else 0.0

    def reanchor(self, position_xy, variance):
        """A new position (``variance`` per axis) that keeps the flow's bias, scale and turn: they describe the
        sensors, not where the drone is, and the turn is what corrects the heading the drone is flown with."""
        self.x[:2] = position_xy[:2]
        self.P[:2, :] = 0.0
        self.P[:, :2] = 0.0
        self.P[0, 0] = self.P[1, 1] = variance

    @staticmethod
    def _rotation(yaw):
        c, s = math.cos(yaw), math.sin(yaw)
        return np.array([[c, -s], [s, c]])

    def _velocity_jacobian(self, flow_heading, yaw):
        """d(world velocity) / d(state): zero for the position, -R for the bias, R f and R J f for a, c."""
        rotation = self._rotation(yaw)
        f = np.array(flow_heading[:2], dtype=float)
        jacobian = np.zeros((2, 6))
        jacobian[:, 2:4] = -rotation
        jacobian[:, 4] = rotation @ f
        jacobian[:, 5] = rotation @ np.array([-f[1], f[0]])
        return jacobian

    def world_velocity(self, flow_heading, yaw, unseen=(0.0, 0.0)):
        """World velocity from a heading-frame flow reading: scaled and turned by (a, c), bias removed, plus
        the velocity the flow did not see."""
        f0, f1 = flow_heading[0], flow_heading[1]
        a, c = self.x[4], self.x[5]
        forward, left = a * f0 - c * f1 - self.x[2], a * f1 + c * f0 - self.x[3]
        vx, vy = heading_to_world(forward, left, yaw)
        return np.array([vx + unseen[0], vy + unseen[1]])

    def predict_flow(self, dt, flow_heading, yaw, unseen=(0.0, 0.0)):
        if dt <= 0.0 or not self.initialised:
            return
        self.x[:2] += self.world_velocity(flow_heading, yaw, unseen) * dt
        F = np.eye(6)
        F[0:2, :] += dt * self._velocity_jacobian(flow_heading, yaw)
        self._propagate(F, dt)

    def predict_world(self, dt, velocity_world):
        """Dead reckoning on a velocity that is not the flow (GPS velocity, or zero): no bias in it."""
        if dt <= 0.0 or not self.initialised:
            return
        self.x[:2] += np.asarray(velocity_world[:2]) * dt
        self._propagate(np.eye(6), dt)

    def _propagate(self, F, dt):
        q = self.q_position * dt + (self.velocity_std * dt) ** 2
        self.P = F @ self.P @ F.T + np.diag([q, q, self.q_bias * dt, self.q_bias * dt,
                                             self.q_scale * dt, self.q_scale * dt])

    def update_velocity(self, velocity_world, flow_heading, yaw, variance, unseen=(0.0, 0.0)):
        """GPS velocity against the flow: measures the flow's bias, scale and turn. ``variance`` covers
        both sensors' noise."""
        innovation = np.asarray(velocity_world[:2]) - self.world_velocity(flow_heading, yaw, unseen)
        H = self._velocity_jacobian(flow_heading, yaw)
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

    def update(self, position_xy, variance, calibrate=True):
        """A position fix. With ``calibrate`` False it places the drone but teaches the flow's bias, scale and turn
        nothing: their gain is zeroed and the covariance kept consistent with that (a "consider" update)."""
        innovation = np.asarray(position_xy[:2]) - self.x[:2]
        S = self.P[:2, :2] + variance * np.eye(2)
        gain = self.P[:, :2] @ np.linalg.inv(S)
        if calibrate:
            self.P = self.P - gain @ self.P[:2, :]
        else:
            gain[2:, :] = 0.0
            observed = np.eye(6)[:2]
            kept = np.eye(6) - gain @ observed
            self.P = kept @ self.P @ kept.T + variance * gain @ gain.T  # Joseph form: right for any gain
        self.x += gain @ innovation
        self.P = 0.5 * (self.P + self.P.T)


class StateHistory:
    """(time, position, velocity) samples of the last ``span`` seconds, oldest first, for placing a late
    measurement at its own instant. At least ``keep`` samples stay however old; a sample earlier than the latest
    (the clock went back) starts the history afresh."""

    def __init__(self, span, keep=0):
        self.span, self.keep = span, keep
        self.samples = collections.deque()

    def clear(self):
        self.samples.clear()

    def add(self, t, position, velocity):
        if self.samples and t < self.samples[-1][0]:
            self.samples.clear()
        self.samples.append((t, position, velocity))
        while len(self.samples) > self.keep and self.samples[0][0] < t - self.span:
            self.samples.popleft()

    def at(self, t, max_extrapolation=0.0):
        """(position, velocity) at ``t``: interpolated between the samples around it; outside them the nearest end
        carried on with its velocity if it is at most ``max_extrapolation`` [s] away; else None."""
        if not self.samples:
            return None
        times = [sample[0] for sample in self.samples]
        i = bisect.bisect_left(times, t)
        if 0 < i < len(times):
            (t0, p0, v0), (t1, p1, v1) = self.samples[i - 1], self.samples[i]
            f = (t - t0) / (t1 - t0) if t1 > t0 else 1.0
            return p0 + f * (p1 - p0), v0 + f * (v1 - v0)
        near_t, position, velocity = self.samples[0] if i == 0 else self.samples[-1]
        if abs(near_t - t) > max_extrapolation:
            return None
        return position + velocity * (t - near_t), velocity


class InertialVelocity:
    """The horizontal world velocity carried by the accelerometer between readings of a reference velocity
    (the flow's, corrected), pulled towards each reading with a gain that falls as the reading's uncertainty
    grows: a complementary filter. Over a fast vehicle the flow's velocity swings by the vehicle's speed times
    every error of the weight (flow_surface.py): 0.1 of it is 1.5 m/s at 15 m/s. There the accelerometer
    (biased by a few cm/s^2, i.e. a few cm/s over the second of a descent) carries the velocity instead."""

    MAX_STEP = 0.2  # a gap longer than this between accelerations is not integrated across, nor trusted [s]
    HISTORY = 0.5   # how far back a reading may be compared with the velocity of its instant [s]

    def __init__(self, gain, reference_std):
        self.gain, self.reference_std = gain, reference_std
        self.velocity = None       # world (x, y) [m/s]
        self.accelerated = None    # time of the last acceleration
        self.corrected = None      # time of the last reading
        self.trust = 1.0           # the last reading's share of the gain (0: accelerometer alone, 1: the reading)
        self.history = collections.deque()  # (time, velocity) after each acceleration, the last HISTORY seconds

    def velocity_at(self, t):
        """The velocity at ``t``: the last one integrated up to then (the present one for a later ``t``)."""
        for stamp, velocity in reversed(self.history):
            if stamp <= t + 1e-9:
                return velocity
        return self.velocity

    def fresh(self, t):
        """True while accelerations arrive: without them the velocity is the reading's."""
        return self.velocity is not None and self.accelerated is not None and t - self.accelerated <= self.MAX_STEP

    def accelerate(self, t, acceleration_xy):
        """Integrates a world horizontal acceleration [m/s^2] measured at ``t``."""
        dt = None if self.accelerated is None else t - self.accelerated
        if dt is not None and dt <= 0.0:
            return
        if self.velocity is not None and dt is not None and dt <= self.MAX_STEP:
            self.velocity = self.velocity + np.asarray(acceleration_xy, dtype=float) * dt
            self.history.append((t, self.velocity))
            while self.history and self.history[0][0] < t - self.HISTORY:
                self.history.popleft()
        self.accelerated = t

    def correct(self, t, reference_xy, reference_std):
        """Pulls the velocity towards a reference reading [m/s] whose uncertainty ``reference_std`` [m/s] adds to
        the reference's usual one (``self.reference_std``); returns the velocity."""
        reference = np.asarray(reference_xy, dtype=float)
        floor = self.reference_std ** 2
        self.trust = floor / (floor + reference_std ** 2)
        if not self.fresh(t) or self.corrected is None:
            self.velocity = reference
            self.history.clear()
        else:
            # A reading is compared with the velocity of its own instant: navdata arrives a link's delay after the
            # IMU has carried the velocity on (harsh: a sample later), and pulling today's velocity towards an older
            # reading put 0.05 s of lag into it, and 0.1 s into the position, in which the pad is placed.
            dt = min(self.MAX_STEP, max(0.0, t - self.corrected))
            step = (1.0 - math.exp(-self.gain * self.trust * dt)) * (reference - self.velocity_at(t))
            self.velocity = self.velocity + step
            self.history = collections.deque((stamp, velocity + step) for stamp, velocity in self.history)
        self.corrected = max(t, self.corrected) if self.corrected is not None else t
        return self.velocity_at(t)


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

    def __init__(self, params: EstimatorParams = EstimatorParams(), log=None, surface=None):
        self.p = params
        self.log = log or (lambda message: None)
        self.surface = surface           # FlowSurface, or None: the flow is over the ground
        self.pad_state = None            # (time, position, velocity) of the pad, world frame
        self.vehicle_report = None       # (time, velocity xy, yaw rate) the vehicle reported
        self.last_sonar_height = None    # (time, base_link above the surface the sonar sees) [s, m]
        self.orientations = collections.deque()  # (time, orientation) of the last second of IMU messages
        self.unseen_velocity = (None, np.zeros(2))  # (time, world xy) of the vehicle's velocity the flow did not see
        self.modelled_unseen = (None, np.zeros(2))  # ...as the weight's model has it (flow_surface.py)
        self.flow_weight = 0.0           # how much the flow follows the vehicle (0 ground .. 1 vehicle): over a fast
        #                                  vehicle as the accelerometer measures it, else the model's [-]
        self.modelled_weight = 0.0       # the model's, blended in as the firmware blends each flow reading [-]
        self.flow_weight_spread = 0.0    # how much the weight changes within weight_position_std of the estimate [-]
        self.rest_offset = None          # the estimate minus the pad filter's position while it rode the pad (xy) [m]
        # Where the pad is relative to the drone by the camera's fixes, carried on by the flow (_view_position).
        self.relative = RelativeTrack(params.relative_fix_gain, params.relative_max_age) \
            if surface is not None and surface.enabled else None
        self.pad_unseen = np.zeros(2)    # the pad filter's velocity as the flow does not see it (w v_pad, blended) [m/s]
        self.inertial = InertialVelocity(params.inertial_gain, params.inertial_reference_std) \
            if params.inertial_gain > 0.0 else None
        self.history = StateHistory(HISTORY_SPAN)  # (time, position, velocity) after each prediction
        self.horizontal = HorizontalFilter(params.position_process_noise, params.flow_bias_process_noise,
                                           params.flow_velocity_std, params.initial_flow_bias_std,
                                           params.flow_scale_process_noise, params.initial_flow_scale_std)
        self.vertical = VerticalFilter(params.altitude_process_noise, params.flow_velocity_std,
                                       params.climb_bias_process_noise, params.initial_climb_bias_std)
        self.altimeter_rejections = 0    # barometric altitudes rejected in a row
        self.time = None                 # time the filters are at
        self.orientation = None          # last IMU orientation (w, x, y, z)
        self.yaw = 0.0
        self.tilt_cos = 1.0              # cosine of the tilt: body z . world z
        self.flow_heading = None         # last flow reading (forward, left, up) and its time
        self.flow_time = None
        self.gps_velocity = None         # fallback when the flow stops, world frame, and its time
        self.gps_velocity_time = None
        self.gps_rejections = 0
        self.airborne = True             # the navdata's state: a drone resting on its pad learns nothing of its flow
        # Part of the latest corrections not yet passed on to the published position (see estimate()).
        self.pending_correction = np.zeros(3)
        self.counters = {"gps_used": 0, "gps_rejected": 0, "gps_reanchored": 0, "sonar_used": 0,
                         "altimeter_rejected": 0, "altimeter_reanchored": 0, "flow_over_vehicle": 0,
                         "gps_velocity_landed": 0}

    # ----- state ---------------------------------------------------------------------------------
    @property
    def ready(self):
        """True once attitude, a horizontal fix and a height are known."""
        return self.orientation is not None and self.horizontal.initialised and self.vertical.initialised

    def _flow_fresh(self, t):
        return self.flow_heading is not None and t - self.flow_time <= self.p.flow_timeout \
            and self._resting_velocity(t) is None

    def _resting_velocity(self, t):
        """Resting (the navdata says landed): riding the pad (``rest_offset``), the vehicle's reported velocity; else
        the GPS velocity while it is fresh; else None. On its pad the drone rides the vehicle while its flow, seeing
        the pad, reads a few cm/s whatever the vehicle does. In a GPS dropout on a car speeding up to 15 m/s the last
        GPS velocity, held, was 1.8 m/s short: the estimate fell off the pad, and so did the weight's model (see
        _anchored_position)."""
        if self.airborne:
            return None
        vehicle_velocity = self._vehicle_velocity(t) if self.rest_offset is not None else None
        if vehicle_velocity is not None:
            return np.array([vehicle_velocity[0], vehicle_velocity[1], 0.0])
        if self.gps_velocity is not None and t - self.gps_velocity_time <= self.p.resting_gps_timeout:
            return np.array(self.gps_velocity, dtype=float)
        return None

    def _velocity(self, t):
        """World velocity (x, y, z) the motion model integrates at ``t`` (``_motion``)."""
        return self._motion(t)[0]

    def _motion(self, t):
        """(world velocity (x, y, z) the motion model integrates at ``t``, whether its climb rate is the navdata's
        and so carries its bias): resting, ``_resting_velocity``; flying, the flow while it is fresh, else the last
        GPS velocity while that is fresh, else none (the position then holds while its variance grows)."""
        resting = self._resting_velocity(t)
        if resting is not None:
            return resting, False
        if self._flow_fresh(t):
            vx, vy = self.horizontal.world_velocity(self.flow_heading, self.yaw, self._unseen_now())
            return np.array([vx, vy, self.flow_heading[2] - self.vertical.bias]), True
        if self.gps_velocity is not None and t - self.gps_velocity_time <= self.p.flow_timeout:
            return np.array(self.gps_velocity, dtype=float), False
        return np.zeros(3), False

    def _unseen_now(self):
        """What the motion model adds to the flow's velocity now: over the vehicle the part of its velocity the
        flow did not see, and with the accelerometer also how the velocity changed since the latest reading (the
        IMU comes at the navdata's rate and less late: a held reading lagged by half a sample and more)."""
        if self.inertial is not None and self.flow_heading is not None and self.inertial.fresh(self.time) and \
                self.unseen_velocity[0] is not None:
            return self.inertial.velocity - self.horizontal.world_velocity(self.flow_heading, self.yaw)
        return self.unseen_velocity[1]

    def _advance(self, t):
        if self.time is None:
            self.time = t
            return
        dt = t - self.time
        if dt <= 0.0:
            return  # a late message is used as if taken now: its age is below one sample period
        velocity, climb_from_navdata = self._motion(self.time)
        if self._flow_fresh(self.time):
            self.horizontal.predict_flow(dt, self.flow_heading, self.yaw, self._unseen_now())
        else:
            self.horizontal.predict_world(dt, velocity)
        self.vertical.predict(dt, velocity[2], biased=climb_from_navdata)
        self.pending_correction = self._correction_left(dt)
        self.time = t
        if self.ready:
            self.history.add(t, self._position_now(), self._velocity(t))

    def _position_now(self):
        return np.array([self.horizontal.x[0], self.horizontal.x[1], self.vertical.p])

    def _past(self, t):
        """(position, velocity) of the filter at an earlier time ``t``, interpolated in the history; the
        present ones when ``t`` is not in the past or the history does not reach back (then a fix is used as
        if taken now)."""
        past = self.history.at(t) if self.time is not None and t < self.time else None
        return past if past is not None else (self._position_now(), self._velocity(self.time))

    def _correction_left(self, dt):
        """The part of the pending correction not yet published ``dt`` from now. A measurement update moves the
        filter state at once; the published position takes that step over correction_smoothing_time, so a
        consumer differentiating it sees no jump, and horizontally no faster than correction_max_speed: the first
        GPS fix after a dropout moved the filter 1.5 m, and the pad's position, placed from the camera with the
        published one, stayed where it was, so the pad seemed to leap away from the drone (harsh)."""
        smoothing = self.p.correction_smoothing_time
        left = self.pending_correction * (math.exp(-dt / smoothing) if smoothing > 0.0 else 0.0)
        passed = self.pending_correction[:2] - left[:2]
        distance, limit = float(np.hypot(*passed)), self.p.correction_max_speed * dt
        if distance > limit:
            left[:2] = self.pending_correction[:2] - passed * (limit / distance)
        return left

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
        position -= self._correction_left(max(0.0, dt))
        variance = np.array([self.horizontal.P[0, 0], self.horizontal.P[1, 1], self.vertical.var])
        # The heading corrected by the yaw drift the flow's turn has learnt: the tracker turns its commands into
        # the drone's heading frame with it (in harsh the IMU's yaw was 0.07 rad off after a minute: 0.7 m/s
        # across the road at 10 m/s).
        turn = self.horizontal.turn
        return Estimate(t, position, velocity, turned_about_world_z(self.orientation, turn),
                        math.atan2(math.sin(self.yaw + turn), math.cos(self.yaw + turn)), variance)

    # ----- sensors -------------------------------------------------------------------------------
    def imu(self, t, orientation_wxyz, specific_force=None):
        """IMU orientation, world <- body, as (w, x, y, z), and optionally the accelerometer's specific force
        (body frame, gravity included) [m/s^2]."""
        w, x, y, z = orientation_wxyz
        norm = math.sqrt(w * w + x * x + y * y + z * z)
        if not norm > 0.5:  # also false for NaN
            return False
        w, x, y, z = w / norm, x / norm, y / norm, z / norm
        self._advance(t)
        self.orientation = (w, x, y, z)
        self.orientations.append((t, self.orientation))
        while self.orientations and self.orientations[0][0] < t - HISTORY_SPAN:
            self.orientations.popleft()
        self.yaw = yaw_from_quaternion(w, x, y, z)
        self.tilt_cos = 1.0 - 2.0 * (x * x + y * y)
        if self.inertial is not None and specific_force is not None and all(map(math.isfinite, specific_force)):
            acceleration = rotation_of(w, x, y, z) @ np.asarray(specific_force, dtype=float)
            # Turned like the flow by the yaw's drift the horizontal filter has learnt (its a, c).
            self.inertial.accelerate(t, heading_to_world(acceleration[0], acceleration[1], self.horizontal.turn))
        return True

    def flow(self, t, vx_heading, vy_heading, vz, airborne=True):
        """Navdata velocity: forward/left in the drone's heading frame, vertical [m/s]. Over the vehicle, the
        part of the vehicle's velocity the flow did not see is kept beside it (``unseen_velocity``).
        ``airborne``: the navdata's state says the drone flies (not landed on its pad)."""
        self._advance(t)
        if self.airborne and not airborne:
            self.rest_offset = None  # a new rest: whether it is on the pad is judged afresh
        self.airborne = airborne
        modelled = self._unseen_velocity(t)
        self.modelled_unseen = (t, modelled)
        self.flow_heading = (vx_heading, vy_heading, vz)
        self.flow_time = t
        seen = self.horizontal.world_velocity(self.flow_heading, self.yaw)
        if self.relative is not None and self.pad_state is not None and abs(t - self.pad_state[0]) <= PAD_MAX_AGE:
            # d/dt (pad - drone) = v_pad - (seen + w v_pad): where the flow sees the pad alone, the pad's velocity
            # cancels, whatever its error (relative.py).
            self.relative.add_rate(t, self.pad_state[2][:2] - self.pad_unseen - seen)
        unseen = modelled
        if self.inertial is not None:
            vehicle_velocity = self._vehicle_velocity(t)
            speed = 0.0 if vehicle_velocity is None else float(np.hypot(*vehicle_velocity))
            resting = self._resting_velocity(t)
            reference = seen + modelled if resting is None else resting[:2]
            velocity = self.inertial.correct(t, reference, self.flow_weight_spread * speed)
            if self.inertial.fresh(t):
                unseen = velocity - seen  # what the accelerometer says the flow did not see
                if speed >= self.p.measured_weight_min_speed:
                    # The weight the firmware's velocity follows, as measured: over a fast vehicle a model's
                    # error of 0.1 is 1.5 m/s of command at 15 m/s; the measurement's noise is the flow's / speed.
                    self.flow_weight = float(np.clip(unseen @ vehicle_velocity / speed ** 2, 0.0, 1.0))
        self.unseen_velocity = (t, unseen)
        return True

    def pad(self, t, position, velocity):
        """The pad's predicted state at ``t``: world position [m] and velocity [m/s]."""
        self.pad_state = (t, np.asarray(position, dtype=float), np.asarray(velocity, dtype=float))

    def pad_fix(self, t, relative_xy):
        """The camera's fix of the pad at its image's capture time ``t``: the pad minus the drone as published then
        (world x, y) [m]."""
        if self.relative is not None:
            self.relative.add_fix(t, relative_xy)

    def vehicle(self, t, velocity_xy, yaw_rate=0.0):
        """The vehicle's own report at ``t``: world velocity [m/s] and yaw rate [rad/s]."""
        self.vehicle_report = (t, np.asarray(velocity_xy[:2], dtype=float), yaw_rate)

    def _vehicle_velocity(self, t):
        """The vehicle's velocity at ``t``: its latest report turned by its yaw rate since (a turn is what
        changes it fastest), else the pad filter's; None without either."""
        if self.vehicle_report is not None and abs(t - self.vehicle_report[0]) <= PAD_MAX_AGE:
            report_t, velocity, yaw_rate = self.vehicle_report
            turn = yaw_rate * (t - report_t)
            c, s = math.cos(turn), math.sin(turn)
            return np.array([c * velocity[0] - s * velocity[1], s * velocity[0] + c * velocity[1]])
        if self.pad_state is not None:
            return self.pad_state[2][:2]
        return None

    def _unseen_velocity(self, t):
        """The vehicle's velocity the flow does not see at ``t`` (world x, y): w v_vehicle (flow_surface.py),
        blended in over the firmware's response time as the firmware blends each flow reading into its
        estimate (its accelerometer carries the fast part). Zero away from the vehicle or without a pad."""
        last_t, last = self.modelled_unseen
        target, weight, spread, pad_target = np.zeros(2), 0.0, 0.0, np.zeros(2)
        if self.surface is not None and self.surface.enabled and self.pad_state is not None and self.ready:
            pad_t, pad_position, pad_velocity = self.pad_state
            vehicle_velocity = self._vehicle_velocity(t)
            if abs(t - pad_t) <= PAD_MAX_AGE and vehicle_velocity is not None:
                pad_now = pad_position + pad_velocity * (t - pad_t)
                position, orientation = self._view_position(pad_now, t, vehicle_velocity), self._orientation_at(t)
                weight = self.surface.weight(position, orientation, pad_now, vehicle_velocity)
                if weight <= 0.0 and self.airborne:
                    self.rest_offset = None  # the view has left the vehicle: the anchor is spent
                target, pad_target = weight * vehicle_velocity, weight * pad_velocity[:2]
                if self.inertial is not None:
                    # The height above the pad comes from the sonar (centimetres), the rest from GPS and vision.
                    steps = self.p.weight_position_std * np.diag([1.0, 1.0, 0.25])
                    spread = max(abs(self.surface.weight(position + offset, orientation, pad_now, vehicle_velocity)
                                     - weight) for offset in np.vstack([steps, -steps]))
        # Held, decaying over spread_hold_time: near the band the weight's model can flip between 0 and 1 from
        # one position error to the next, and one step of full trust would pull in the whole error at once.
        # The blended weight still moving towards the instantaneous one is as uncertain.
        spread = max(spread, abs(self.modelled_weight - weight))
        if last_t is not None and t > last_t:
            spread = max(spread, self.flow_weight_spread * math.exp(-(t - last_t) / self.p.spread_hold_time))
        self.flow_weight_spread = spread
        if weight > 0.0:
            self.counters["flow_over_vehicle"] += 1
        if last_t is None or t <= last_t or self.surface is None:
            self.modelled_weight = self.flow_weight = weight
            self.pad_unseen = pad_target
            return target
        blend = 1.0 - math.exp(-(t - last_t) / self.surface.p.flow_time_constant)
        self.modelled_weight += blend * (weight - self.modelled_weight)
        self.pad_unseen = self.pad_unseen + blend * (pad_target - self.pad_unseen)
        self.flow_weight = self.modelled_weight
        return last + blend * (target - last)

    def _orientation_at(self, t):
        """The IMU orientation at ``t``: the last one not after it. The IMU and navdata arrive on their own
        threads, and at a car's speed the view of the vehicle turns with the drone's pitch within 0.1 s."""
        turn = self.horizontal.turn  # the yaw drift learnt, as in estimate()
        for stamp, orientation in reversed(self.orientations):
            if stamp <= t + 1e-9:
                return turned_about_world_z(orientation, turn)
        return turned_about_world_z(self.orientation, turn)

    def _view_position(self, pad_position, t, vehicle_velocity):
        """The drone's position for the view of the vehicle: below measured_weight_min_speed, where the weight is the
        model's alone, the pad's less where the camera's fixes, carried on by the flow, have the pad relative to the
        drone; else (no fix for relative_max_age, a faster vehicle) ``_anchored_position``. The estimate and the
        pad filter each move by their own velocity, the estimate's over the pad by the vehicle's report: low over a
        Summit XL speeding up they drifted 0.2 m apart within 0.1 s of the camera losing the pad's centre, the weight
        went down with it, and so did the velocity the estimate adds back, which drew them further apart."""
        position = self._anchored_position(pad_position, t, vehicle_velocity)
        if self.relative is not None and float(np.hypot(*vehicle_velocity)) < self.p.measured_weight_min_speed:
            relative = self.relative.at(t)
            if relative is not None:
                position[:2] = pad_position[:2] - relative[0]
        return position

    def _anchored_position(self, pad_position, t, vehicle_velocity):
        """The drone's position for the view of the vehicle (``_position_over``), anchored to the pad from a rest
        on it: riding the pad, the drone is over its centre, whatever the estimate and the pad filter say. Before
        the camera sees the whole pad those two are GPS positions with their own metre-level drifts; in harsh
        they put a drone lifting off a car at 15 m/s 0.6 m beside the pad, the weight's model said the flow saw the
        road while it saw the pad, and the estimate fell 7 m behind within 0.6 s. The anchor keeps the offset
        they had at rest until the view leaves the vehicle (above about 1.5 m over the car's pad, before the pad
        filter takes the camera's fixes, which are placed with this estimate)."""
        position = self._position_over(pad_position, t)
        if not self.airborne:
            # Riding is latched for the rest: a drone at rest cannot leave its pad, and its GPS velocity lags the
            # vehicle's by 0.2-0.4 s (1 m/s on a car speeding up).
            resting = self._resting_velocity(t)
            riding = self.rest_offset is not None or (
                resting is not None and float(np.hypot(*vehicle_velocity)) >= RIDING_MIN_SPEED and
                float(np.hypot(*(resting[:2] - vehicle_velocity))) <= RIDING_MAX_MISMATCH)
            if riding:
                self.rest_offset = position[:2] - pad_position[:2]
        if self.rest_offset is not None:
            position[:2] -= self.rest_offset
        return position

    def _position_over(self, pad_position, t):
        """The drone's position for the view of the vehicle: the estimate, its height above the pad taken from
        the sonar when that sees the pad or the vehicle (it measures the height the view depends on to a
        centimetre; the estimate's altitude minus the pad filter's height was 0.2 m off at a car's speed,
        which at the vehicle's edge of the view is 0.2 in the weight, 3 m/s at 15 m/s)."""
        position = self.estimate(t).position.copy()
        if self.last_sonar_height is not None and abs(t - self.last_sonar_height[0]) <= SONAR_MAX_AGE:
            sonar_height = self.last_sonar_height[1]
            if abs(position[2] - pad_position[2] - sonar_height) < SONAR_PAD_GATE:
                position[2] = pad_position[2] + sonar_height
        return position

    def gps(self, t, position, velocity=None):
        """GPS fix taken at ``t``: world position [m] and optionally world velocity [m/s]; returns whether it
        was used. A fix older than the filter is compared with the estimate of its instant: what differs
        corrects the present state (position and velocity moved on by the filter's own motion since)."""
        self._advance(t)
        then_position, then_velocity = self._past(t)
        now_position, now_velocity = self._position_now(), self._velocity(self.time)
        position = np.asarray(position, dtype=float) + (now_position - then_position)[:len(position)]
        if velocity is not None:
            velocity = np.asarray(velocity, dtype=float) + (now_velocity - then_velocity)[:len(velocity)]
            self.gps_velocity, self.gps_velocity_time = tuple(velocity), max(t, self.time)
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
            self.horizontal.reanchor(position, variance)
            self.pending_correction[:2] = 0.0  # a re-anchoring is a real jump: publish it as one
        else:
            before = self.horizontal.x[:2].copy()
            self.horizontal.update(position, variance, calibrate=self.airborne)
            self.pending_correction[:2] += self.horizontal.x[:2] - before
        self.gps_rejections = 0
        self.counters["gps_used"] += 1
        # Resting on the pad the flow reads a few cm/s whatever the vehicle does: the flow's bias, scale and turn
        # are learnt in flight only (position fixes too leave them alone above; riding a circling vehicle for
        # 200 s between missions, the fixes had turned the learnt turn by 25 deg through its correlation with
        # the position).
        if velocity is not None and self.p.use_gps_velocity and not self.airborne:
            self.counters["gps_velocity_landed"] += 1
        elif velocity is not None and self.p.use_gps_velocity and self._flow_fresh(t):
            before = self.horizontal.x[:2].copy()
            self.horizontal.update_velocity(velocity, self.flow_heading, self.yaw,
                                            self.p.gps_velocity_std ** 2 + self.p.flow_velocity_std ** 2,
                                            self.unseen_velocity[1])
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
            # One wild altitude must not yank the estimate; many in a row mean the estimate is wrong (rejected for
            # good, an estimate once stayed 1-3 m above the drone while the barometer was right: harsh).
            self.altimeter_rejections += 1
            self.counters["altimeter_rejected"] += 1
            if self.altimeter_rejections < self.p.altimeter_max_rejections:
                return False
            self.log("%d barometric altitudes in a row disagree with the estimate by %.2f m; re-anchoring to them"
                     % (self.altimeter_rejections, innovation))
            self.counters["altimeter_reanchored"] += 1
            self.vertical.reset(altitude, variance)
            self.pending_correction[2] = 0.0  # a real jump: published as one
        else:
            self._update_vertical(altitude, variance)
        self.altimeter_rejections = 0
        return True

    def sonar(self, t, distance):
        """Sonar range from the feet to the first surface below [m]. Corrects z only where that
        surface can only be the ground; returns whether it was used."""
        if not (math.isfinite(distance) and 0.0 < distance < self.p.sonar_max_range) or not self.vertical.initialised:
            return False
        self._advance(t)
        height = (distance + self.p.foot_clearance) * max(0.5, self.tilt_cos)  # base_link above that surface
        self.last_sonar_height = (t, height)
        if abs(height - self.vertical.p) > self.p.sonar_ground_gate:
            return False
        self._update_vertical(height, self.p.sonar_std ** 2)
        self.counters["sonar_used"] += 1
        return True
