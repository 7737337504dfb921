"""The quadrotor's on-board flight controller, ROS-free.

Takes velocity commands like hector_quadrotor / the AR.Drone (``linear.x``/``linear.y`` in the heading
frame, ``linear.z`` climb rate, ``angular.z`` yaw rate) and turns them into four rotor thrusts through
a cascade: velocity loop (with altitude hold when the climb rate is zero) -> thrust vector with a tilt
limit -> geometric attitude loop -> rotor mixing -> first-order motor lag.
"""
import enum
import logging
import math

import numpy as np

LOG = logging.getLogger("mujoco_sim.autopilot")


class FlightMode(enum.Enum):
    LANDED = "landed"
    TAKING_OFF = "taking_off"
    FLYING = "flying"
    LANDING = "landing"
    CRASHED = "crashed"


class VelocityCommand:
    """A validated velocity command: heading-frame forward/left speed, climb rate, yaw rate."""

    __slots__ = ("vx", "vy", "vz", "yaw_rate")

    def __init__(self, vx=0.0, vy=0.0, vz=0.0, yaw_rate=0.0):
        self.vx, self.vy, self.vz, self.yaw_rate = vx, vy, vz, yaw_rate

    @staticmethod
    def problem(values, limit=100.0):
        """Why these raw numbers are not a usable command, or None if they are."""
        for value in values:
            if not math.isfinite(value):
                return "non-finite value %r" % value
            if abs(value) > limit:
                return "absurd value %g (limit %g)" % (value, limit)
        return None


HOLD = VelocityCommand()


def quat_to_matrix(q):
    """Rotation matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def yaw_of(rotation):
    return math.atan2(rotation[1, 0], rotation[0, 0])


def cross(a, b):
    """3-vector cross product; numpy.cross costs ~25 us per call, which matters at 500 Hz."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def wrap_angle(angle):
    return (angle + math.pi) % (2 * math.pi) - math.pi


class Autopilot:
    """Flight modes and the control cascade. ``params`` is the validated ``drone`` section of the
    simulator configuration; ``rotors`` the rotor positions (x, y) in the body frame with their
    reaction-torque coefficients, read from the model."""

    def __init__(self, params, mass, inertia, rotors, max_rotor_thrust):
        self.p = params
        self.mass = mass
        self.inertia = np.asarray(inertia, dtype=float)
        self.max_rotor_thrust = max_rotor_thrust
        # Rows: total thrust, roll torque, pitch torque, yaw torque produced by each rotor's thrust.
        mix = np.array([[1.0] * len(rotors),
                        [y for x, y, k in rotors],
                        [-x for x, y, k in rotors],
                        [k for x, y, k in rotors]])
        self.unmix = np.linalg.inv(mix)
        self.motor_thrust = np.zeros(len(rotors))
        self.mode = FlightMode.LANDED
        self._reset_loops()

    # ----- modes ---------------------------------------------------------------------------
    def _reset_loops(self):
        self.velocity_integral = np.zeros(3)
        self.z_ref = None
        self.yaw_ref = None
        self.takeoff_target_z = None

    def set_mode(self, mode, reason):
        if mode != self.mode:
            LOG.info("flight mode %s -> %s (%s)", self.mode.name, mode.name, reason)
            self.mode = mode

    def takeoff(self, z):
        """Start climbing from the current height ``z`` [m]; only from LANDED."""
        if self.mode != FlightMode.LANDED:
            return False
        self._reset_loops()
        self.takeoff_target_z = z + self.p["takeoff_height"]
        self.set_mode(FlightMode.TAKING_OFF, "take-off command")
        return True

    def land(self):
        """Descend at the landing speed until touchdown; horizontal commands still apply."""
        if self.mode in (FlightMode.FLYING, FlightMode.TAKING_OFF):
            self.set_mode(FlightMode.LANDING, "land command")
            return True
        return False

    def touched_down(self, crashed):
        self.motor_thrust[:] = 0.0
        self._reset_loops()
        if crashed:
            self.set_mode(FlightMode.CRASHED, "impact above the crash limits")
        else:
            self.set_mode(FlightMode.LANDED, "touchdown")

    def reset(self):
        self.motor_thrust[:] = 0.0
        self._reset_loops()
        self.set_mode(FlightMode.LANDED, "reset")

    @property
    def airborne_control(self):
        return self.mode in (FlightMode.TAKING_OFF, FlightMode.FLYING, FlightMode.LANDING)

    # ----- control ---------------------------------------------------------------------------
    def update(self, dt, position, velocity, quat, omega, command, power_available=True):
        """One control step. ``position``/``velocity`` world frame, ``quat`` (w,x,y,z), ``omega`` body
        rates. Returns the four rotor thrusts [N] after the motor lag."""
        if not self.airborne_control or not power_available:
            target = np.zeros_like(self.motor_thrust)
        else:
            target = self._thrusts(dt, position, velocity, quat, omega, command)
        lag = 1.0 - math.exp(-dt / self.p["motor_time_constant"])
        self.motor_thrust += (target - self.motor_thrust) * lag
        return self.motor_thrust

    def _thrusts(self, dt, position, velocity, quat, omega, command):
        p = self.p
        rotation = quat_to_matrix(quat)
        yaw = yaw_of(rotation)
        z = position[2]

        if self.mode == FlightMode.TAKING_OFF:
            climb = p["takeoff_speed"]
            if z >= self.takeoff_target_z - 0.05:
                self.set_mode(FlightMode.FLYING, "take-off height reached")
                self.z_ref = z
        elif self.mode == FlightMode.LANDING:
            climb = -p["land_speed"]
        else:
            climb = max(-p["max_vertical_speed"], min(p["max_vertical_speed"], command.vz))

        # Horizontal velocity set-point: heading frame -> world, capped at the maximum speed.
        c, s = math.cos(yaw), math.sin(yaw)
        v_set = np.array([c * command.vx - s * command.vy, s * command.vx + c * command.vy])
        speed = math.hypot(v_set[0], v_set[1])
        if speed > p["max_horizontal_speed"]:
            v_set *= p["max_horizontal_speed"] / speed

        # Vertical: altitude hold around a reference that the climb rate moves.
        if self.z_ref is None or self.mode != FlightMode.FLYING or abs(command.vz) > 1e-3:
            self.z_ref = z
        vz_set = climb + p["altitude_gain"] * (self.z_ref - z)

        error = np.array([v_set[0] - velocity[0], v_set[1] - velocity[1], vz_set - velocity[2]])
        # Integrate only near the set-point: the integral is for wind and drag, and integrating the
        # large errors of a step command would make it overshoot.
        self.velocity_integral += np.where(np.abs(error) < 0.5, error, 0.0) * dt
        limit = p["velocity_integral_limit"]
        self.velocity_integral = np.minimum(np.maximum(self.velocity_integral, -limit), limit)
        accel = p["velocity_gain"] * error + p["velocity_integral_gain"] * self.velocity_integral
        accel[2] = p["vertical_velocity_gain"] * error[2] + p["velocity_integral_gain"] * self.velocity_integral[2]

        # Thrust vector with the tilt limit: horizontal part may use at most tan(max_tilt) of the vertical.
        force = self.mass * (accel + np.array([0.0, 0.0, 9.81]))
        force[2] = max(force[2], 0.2 * self.mass * 9.81)
        max_horizontal = force[2] * math.tan(math.radians(p["max_tilt_deg"]))
        horizontal = math.hypot(force[0], force[1])
        if horizontal > max_horizontal:
            force[:2] *= max_horizontal / horizontal

        # Yaw reference follows the commanded rate, kept near the actual yaw to avoid wind-up.
        yaw_rate = max(-p["max_yaw_rate"], min(p["max_yaw_rate"], command.yaw_rate))
        if self.yaw_ref is None:
            self.yaw_ref = yaw
        self.yaw_ref = yaw + max(-0.5, min(0.5, wrap_angle(self.yaw_ref + yaw_rate * dt - yaw)))

        # Geometric attitude control (Lee et al.): desired body z along the thrust vector.
        b3 = force / np.linalg.norm(force)
        b1c = np.array([math.cos(self.yaw_ref), math.sin(self.yaw_ref), 0.0])
        b2 = cross(b3, b1c)
        b2 /= np.linalg.norm(b2)
        desired = np.column_stack((cross(b2, b3), b2, b3))
        e_matrix = desired.T @ rotation - rotation.T @ desired
        e_rot = 0.5 * np.array([e_matrix[2, 1], e_matrix[0, 2], e_matrix[1, 0]])
        e_rate = omega - np.array([0.0, 0.0, yaw_rate])
        torque = self.inertia * (-p["attitude_gain"] * e_rot - p["rate_gain"] * e_rate) \
            + cross(omega, self.inertia * omega)

        thrust = float(force @ rotation[:, 2])
        thrust = max(0.0, min(thrust, self.max_rotor_thrust * len(self.motor_thrust)))
        rotor = self.unmix @ np.array([thrust, torque[0], torque[1], torque[2]])
        return np.minimum(np.maximum(rotor, 0.0), self.max_rotor_thrust)
