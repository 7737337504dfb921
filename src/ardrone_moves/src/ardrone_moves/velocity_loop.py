"""Velocity commands (m/s, rad/s) -> the AR.Drone's normalised cmd_vel (tilt fractions), ROS-free.

The real AR.Drone 2.0 driver (ardrone_autonomy) takes tilt, not velocity: linear.x/linear.y are the
pitch/roll reference as fractions of the driver parameter euler_angle_max, linear.z the climb rate as
a fraction of control_vz_max (mm/s), angular.z the yaw rate as a fraction of control_yaw. So the
horizontal velocity loop runs here, on navdata:

    desired acceleration = PI(velocity error) + drag * v_desired + feed-forward(d v_desired / dt)
    tilt = atan(acceleration / g)   (pitch nose-down for +x forward, roll to the left for +y left)

The measured velocity is predicted from the measured attitude to the moment the new command acts
(navdata age + command transit + publishing wait): a tilted drone keeps accelerating meanwhile, and
acting on that instead of on stale velocity buys phase margin (less overshoot).

Conventions (REP 103, as ardrone_autonomy publishes navdata): x forward, y left, z up; the measured
roll is positive with the right side down (it accelerates the drone to the right, -y), the measured
pitch positive with the nose down (it accelerates the drone forward, +x).
"""
import math
from dataclasses import dataclass
from typing import Optional, Tuple

GRAVITY = 9.80665  # [m/s^2]

# The driver treats |component| < 1e-6 as zero (teleop_twist.cpp, _EPS) when it decides to hover.
# Anything below this margin counts as zero for us too, so "not hovering" is never mistaken for it.
DRIVER_ZERO = 1e-5
# angular.x is not flown by the driver: any value >= its 1e-6 threshold only clears the firmware's
# hover flag. A flying command whose four components are all ~0 carries this so the firmware does not
# silently switch to its own optical-flow hover (which, over the moving pad, follows the pad).
HOVER_BLOCKER = 1e-3

# Parameter name -> (low, high) inclusive range; the unit is in config/ardrone_adapter.yaml.
PARAMETER_RANGES = {
    "euler_angle_max": (0.01, 0.52),        # firmware range of euler_angle_max [rad]
    "control_vz_max": (200.0, 2000.0),      # firmware range of control_vz_max [mm/s]
    "control_yaw": (0.7, 6.11),             # firmware range of control_yaw [rad/s]
    "velocity_p_gain": (0.0, 10.0),         # [1/s]
    "velocity_i_gain": (0.0, 10.0),         # [1/s^2]
    "integral_limit": (0.0, 5.0),           # [m/s^2]
    "integral_error_limit": (0.05, 10.0),   # [m/s]
    "velocity_feedforward_gain": (0.0, 2.0),  # [-]
    "feedforward_time_constant": (0.01, 2.0),  # [s]
    "linear_drag": (0.0, 3.0),              # [1/s]
    "prediction_horizon": (0.0, 0.5),       # [s]
    "max_dt": (0.01, 1.0),                  # [s]
    "hover_command_speed": (0.0, 0.5),      # [m/s]
    "hover_command_climb": (0.0, 0.5),      # [m/s]
    "hover_command_yaw_rate": (0.0, 0.5),   # [rad/s]
    "hover_enter_speed": (0.0, 2.0),        # [m/s]
    "hover_exit_speed": (0.0, 3.0),         # [m/s]
}
BOOLEAN_PARAMETERS = ("auto_hover",)

# LoopResult.mode
FLYING, AUTO_HOVER, GROUNDED, REJECTED = "flying", "auto_hover", "grounded", "rejected"


@dataclass(frozen=True)
class TiltCommand:
    """The six components of the driver's cmd_vel, each in [-1, 1] (angular.x/y only gate hover)."""
    linear_x: float = 0.0   # pitch reference / euler_angle_max, + = nose down = forward
    linear_y: float = 0.0   # roll reference / euler_angle_max, + = tilt left = fly left
    linear_z: float = 0.0   # climb rate / control_vz_max, + = up
    angular_x: float = 0.0  # hover gate only
    angular_y: float = 0.0  # hover gate only
    angular_z: float = 0.0  # yaw rate / control_yaw, + = counter-clockwise

    def is_hover(self):
        """True when the driver will hand control to the firmware's own hover."""
        return all(abs(value) < 1e-6 for value in self.as_tuple())

    def as_tuple(self):
        return (self.linear_x, self.linear_y, self.linear_z, self.angular_x, self.angular_y, self.angular_z)


HOVER = TiltCommand()


@dataclass(frozen=True)
class LoopResult:
    """One step of the loop. command is None only for REJECTED input (then publish HOVER)."""
    command: Optional[TiltCommand]
    mode: str                 # FLYING, AUTO_HOVER, GROUNDED or REJECTED
    reason: str = ""          # why the input was rejected, or why the mode was chosen
    saturated: bool = False   # the horizontal tilt was scaled down to euler_angle_max
    acceleration: Tuple[float, float] = (0.0, 0.0)  # desired horizontal acceleration [m/s^2]


def validated_parameters(params):
    """Copy of the loop's keys from ``params``; ValueError naming the key when one is missing or off."""
    values = {}
    for name, (low, high) in PARAMETER_RANGES.items():
        if name not in params:
            raise ValueError("parameter '%s' is missing (see config/ardrone_adapter.yaml)" % name)
        raw = params[name]
        try:
            if isinstance(raw, bool):
                raise TypeError("a boolean")
            value = float(raw)
        except (TypeError, ValueError) as err:
            raise ValueError("parameter '%s' = %r is not a number (%s)" % (name, raw, err))
        if not low <= value <= high:  # also false for NaN
            raise ValueError("parameter '%s' = %r is outside [%g, %g]" % (name, raw, low, high))
        values[name] = value
    for name in BOOLEAN_PARAMETERS:
        if name not in params:
            raise ValueError("parameter '%s' is missing (see config/ardrone_adapter.yaml)" % name)
        if not isinstance(params[name], bool):
            raise ValueError("parameter '%s' = %r must be true or false" % (name, params[name]))
        values[name] = params[name]
    if values["hover_exit_speed"] < values["hover_enter_speed"]:
        raise ValueError("parameter 'hover_exit_speed' = %g must be >= hover_enter_speed = %g"
                         % (values["hover_exit_speed"], values["hover_enter_speed"]))
    return values


def _clip(value, limit=1.0):
    return max(-limit, min(limit, value))


def _zero_if_tiny(value):
    return 0.0 if abs(value) < DRIVER_ZERO else value + 0.0  # + 0.0: no -0.0 on the wire


class TiltVelocityLoop:
    """Heading-frame velocity commands -> normalised AR.Drone tilt/climb/yaw commands.

    Call update() once per navdata message. Not thread-safe: one caller (the navdata callback)."""

    def __init__(self, params):
        self.params = validated_parameters(params)
        self._integral = [0.0, 0.0]  # integral term, already times the I gain [m/s^2]
        self._previous_desired = None  # (forward, left) of the last step, for the feed-forward
        self._feedforward = [0.0, 0.0]  # filtered d(v_desired)/dt times the gain [m/s^2]
        self._hovering = False

    @property
    def hovering(self):
        """True while the firmware's own hover has been handed control."""
        return self._hovering

    @property
    def integral(self):
        """The integral term (forward, left) [m/s^2]: the loop's estimate of minus wind and drag error."""
        return tuple(self._integral)

    def reset(self):
        """Forget the integral and the feed-forward history (after hover, landing or a data gap)."""
        self._integral = [0.0, 0.0]
        self._previous_desired = None
        self._feedforward = [0.0, 0.0]

    def update(self, forward, left, climb, yaw_rate, measured_forward, measured_left, roll, pitch, dt,
               airborne=True):
        """Desired forward/left [m/s], climb [m/s], yaw_rate [rad/s, CCW +]; measured heading-frame
        velocity [m/s] and attitude [rad] from navdata; dt [s] since the previous update.
        ``airborne`` False (landed, taking off, landing) resets the loop and returns HOVER."""
        inputs = (("forward", forward), ("left", left), ("climb", climb), ("yaw_rate", yaw_rate),
                  ("measured_forward", measured_forward), ("measured_left", measured_left), ("roll", roll),
                  ("pitch", pitch), ("dt", dt))
        for name, value in inputs:
            try:
                finite = math.isfinite(value)
            except TypeError:
                finite = False
            if not finite:
                return LoopResult(None, REJECTED, "input '%s' = %r is not a finite number: send hover" % (name, value))
        if dt <= 0.0:
            return LoopResult(None, REJECTED, "input 'dt' = %r must be > 0 (repeated or reordered navdata)" % dt)
        p = self.params
        if not airborne:
            self.reset()
            self._hovering = False
            return LoopResult(HOVER, GROUNDED, "not airborne: loop reset")
        if dt > p["max_dt"]:
            # A navdata gap: the integral and the feed-forward derivative would be built on a stale step.
            self.reset()
            dt = p["max_dt"]

        if p["auto_hover"] and self._wants_hover(forward, left, climb, yaw_rate, measured_forward, measured_left):
            if not self._hovering:
                self.reset()
            self._hovering = True
            self._previous_desired = (float(forward), float(left))  # so leaving hover still sees the step
            return LoopResult(HOVER, AUTO_HOVER, "zero command, small speed: firmware hover")
        self._hovering = False

        velocity = self._predicted_velocity(measured_forward, measured_left, roll, pitch)
        desired = (float(forward), float(left))
        error = (desired[0] - velocity[0], desired[1] - velocity[1])
        self._update_feedforward(desired, dt)
        base = [p["velocity_p_gain"] * error[axis] + p["linear_drag"] * desired[axis] + self._feedforward[axis]
                for axis in (0, 1)]
        # The integral is for wind and drag: it integrates the error clipped to integral_error_limit, so that a
        # large error (a step, the tracker catching up) does not wind it up and overshoot once it is made up.
        limit = p["integral_error_limit"]
        candidate = [_clip(self._integral[axis] + p["velocity_i_gain"] * _clip(error[axis], limit) * dt,
                           p["integral_limit"]) for axis in (0, 1)]
        acceleration = [base[axis] + candidate[axis] for axis in (0, 1)]
        tilt, saturated = self._tilt_fractions(acceleration)
        if saturated:
            # Anti-windup: while the tilt is at its limit, an axis whose error pushes further into the
            # limit keeps its old integral; an error pulling back out may still unwind it.
            for axis in (0, 1):
                if error[axis] * acceleration[axis] > 0.0:
                    candidate[axis] = self._integral[axis]
            acceleration = [base[axis] + candidate[axis] for axis in (0, 1)]
            tilt, saturated = self._tilt_fractions(acceleration)
        self._integral = candidate

        command = TiltCommand(
            linear_x=_zero_if_tiny(tilt[0]), linear_y=_zero_if_tiny(tilt[1]),
            linear_z=_zero_if_tiny(_clip(climb * 1000.0 / p["control_vz_max"])),  # m/s against mm/s
            angular_z=_zero_if_tiny(_clip(yaw_rate / p["control_yaw"])))
        if command.is_hover():
            command = TiltCommand(angular_x=HOVER_BLOCKER)  # see HOVER_BLOCKER: stay on our loop
        return LoopResult(command, FLYING, "", saturated, (acceleration[0], acceleration[1]))

    def _wants_hover(self, forward, left, climb, yaw_rate, measured_forward, measured_left):
        p = self.params
        zero_command = (math.hypot(forward, left) <= p["hover_command_speed"]
                        and abs(climb) <= p["hover_command_climb"] and abs(yaw_rate) <= p["hover_command_yaw_rate"])
        # Hysteresis: enter only when slow, stay until clearly moving, so the hand-over does not chatter.
        speed_limit = p["hover_exit_speed"] if self._hovering else p["hover_enter_speed"]
        return zero_command and math.hypot(measured_forward, measured_left) <= speed_limit

    def _predicted_velocity(self, measured_forward, measured_left, roll, pitch):
        """The velocity when the command acts: the measurement plus what the measured tilt adds meanwhile.

        The model is g*tan(tilt) - drag*v + disturbance; the integral is the loop's estimate of minus
        the disturbance (wind, drag error), so the prediction is unbiased in steady flight."""
        p = self.params
        horizon, drag = p["prediction_horizon"], p["linear_drag"]
        accel_forward = GRAVITY * math.tan(pitch) - drag * measured_forward - self._integral[0]
        # roll > 0 (right side down) accelerates the drone to the right, -y
        accel_left = -GRAVITY * math.tan(roll) - drag * measured_left - self._integral[1]
        return measured_forward + accel_forward * horizon, measured_left + accel_left * horizon

    def _update_feedforward(self, desired, dt):
        p = self.params
        if self._previous_desired is not None and p["velocity_feedforward_gain"] > 0.0:
            smoothing = dt / (p["feedforward_time_constant"] + dt)  # first-order filter: a step is no spike
            for axis in (0, 1):
                rate = (desired[axis] - self._previous_desired[axis]) / dt
                target = p["velocity_feedforward_gain"] * rate
                self._feedforward[axis] += smoothing * (target - self._feedforward[axis])
        self._previous_desired = desired

    def _tilt_fractions(self, acceleration):
        """Acceleration -> (pitch, roll) as fractions of euler_angle_max; scaled together to keep direction."""
        limit = self.params["euler_angle_max"]
        tilt = [math.atan(acceleration[axis] / GRAVITY) / limit for axis in (0, 1)]
        largest = max(abs(tilt[0]), abs(tilt[1]))
        if largest > 1.0:
            return [tilt[0] / largest, tilt[1] / largest], True
        return tilt, False


class CommandRate:
    """When to publish cmd_vel: a fixed rate, so a command lost on Wi-Fi is replaced within one period.

    Drift-free while on time; after a stall it sends once and restarts the schedule (no burst of
    catch-up messages). A clock that jumps backwards (simulation reset) restarts it too."""

    def __init__(self, rate_hz):
        rate_hz = float(rate_hz)
        if not 1.0 <= rate_hz <= 200.0:
            raise ValueError("parameter 'command_rate' = %r must be in [1, 200] Hz" % rate_hz)
        self.period = 1.0 / rate_hz
        self._next_time = None

    def due(self, now):
        """True when a command should go out at ``now`` [s]; each True books the next slot."""
        if self._next_time is None or now < self._next_time - self.period:
            self._next_time = now + self.period
            return True
        if now < self._next_time:
            return False
        self._next_time += self.period
        if self._next_time <= now:  # more than a whole period late: skip the missed slots
            self._next_time = now + self.period
        return True
