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
        self.unmix_rows = [tuple(float(v) for v in row) for row in np.linalg.inv(mix)]
        self.inertia_tuple = tuple(float(v) for v in self.inertia)
        self.motor_thrust = np.zeros(len(rotors))
        self.mode = FlightMode.LANDED
        self._reset_loops()

    # ----- modes ---------------------------------------------------------------------------
    def _reset_loops(self):
        self.velocity_integral = [0.0, 0.0, 0.0]
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
        self.takeoff_target_z = z + self.takeoff_height
        self.set_mode(FlightMode.TAKING_OFF, "take-off command")
        return True

    @property
    def takeoff_height(self):
        """How far above the flown height a take-off climbs [m]."""
        return self.p["takeoff_height"]

    def land(self):
        """Descend at the landing speed until touchdown; horizontal commands still apply."""
        if self.mode in (FlightMode.FLYING, FlightMode.TAKING_OFF):
            self.set_mode(FlightMode.LANDING, "land command")
            return True
        return False

    def shift_altitude_reference(self, step):
        """The height it flies on jumped by ``step`` [m] (a new surface under the sonar): move the altitude
        hold and the take-off target with it, so the drone stays where it is."""
        if self.z_ref is not None:
            self.z_ref += step
        if self.takeoff_target_z is not None:
            self.takeoff_target_z += step

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
        # Plain floats on purpose: this runs 250 times per sim second and numpy's per-call overhead on
        # 3-vectors cost more than the whole physics step.
        p = self.p
        r1, r2, r3, yaw = body_axes(quat)
        z = float(position[2])
        vx, vy, vz = (float(v) for v in velocity)

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
        set_x, set_y = c * command.vx - s * command.vy, s * command.vx + c * command.vy
        speed = math.hypot(set_x, set_y)
        if speed > p["max_horizontal_speed"]:
            set_x, set_y = (v * p["max_horizontal_speed"] / speed for v in (set_x, set_y))

        # Vertical: altitude hold around a reference that the climb rate moves.
        if self.z_ref is None or self.mode != FlightMode.FLYING or abs(command.vz) > 1e-3:
            self.z_ref = z
        set_z = climb + p["altitude_gain"] * (self.z_ref - z)

        error = (set_x - vx, set_y - vy, set_z - vz)
        # The integral is for wind and drag: it integrates the error clipped to +-0.5 m/s, so that a step
        # command's large error does not wind it up. (Skipping large errors instead integrated only the
        # small-error side of a back-and-forth: a 1.1 m/s^2 bias against the other direction.)
        limit = p["velocity_integral_limit"]
        self.velocity_integral = [max(-limit, min(limit, i + max(-0.5, min(0.5, e)) * dt))
                                  for i, e in zip(self.velocity_integral, error)]
        ki = p["velocity_integral_gain"]
        accel = (p["velocity_gain"] * error[0] + ki * self.velocity_integral[0],
                 p["velocity_gain"] * error[1] + ki * self.velocity_integral[1],
                 p["vertical_velocity_gain"] * error[2] + ki * self.velocity_integral[2])

        # Thrust vector with the tilt limit: horizontal part may use at most tan(max_tilt) of the vertical.
        m = self.mass
        fx, fy, fz = m * accel[0], m * accel[1], max(m * (accel[2] + 9.81), 0.2 * m * 9.81)
        max_horizontal = fz * math.tan(math.radians(p["max_tilt_deg"]))
        horizontal = math.hypot(fx, fy)
        if horizontal > max_horizontal:
            fx, fy = fx * max_horizontal / horizontal, fy * max_horizontal / horizontal

        yaw_rate = max(-p["max_yaw_rate"], min(p["max_yaw_rate"], command.yaw_rate))
        return self._attitude_thrusts(dt, fx, fy, fz, yaw, yaw_rate, r1, r2, r3, omega)

    def _attitude_thrusts(self, dt, fx, fy, fz, yaw, yaw_rate, r1, r2, r3, omega):
        """Rotor thrusts that turn the body's z axis along the force (fx, fy, fz) [N, world frame], give it that
        force's component along the body z axis, and turn the heading at ``yaw_rate`` [rad/s]. ``yaw`` is the
        present heading, r1..r3 the columns of the body rotation."""
        p = self.p
        # Yaw reference follows the commanded rate, kept near the actual yaw to avoid wind-up.
        if self.yaw_ref is None:
            self.yaw_ref = yaw
        self.yaw_ref = yaw + max(-0.5, min(0.5, wrap_angle(self.yaw_ref + yaw_rate * dt - yaw)))

        # Geometric attitude control (Lee et al.): desired body z along the thrust vector. The desired body x
        # lies in the vertical plane of the yaw reference (y_c x d3, as PX4 builds it), so that the heading, the
        # yaw of the yaw-pitch-roll angles the AR.Drone's firmware holds, stays put whatever the tilt. Lee's own
        # choice (b1c projected onto the tilted plane) turned the heading by about -pitch x roll: at 15 m/s,
        # rolling for a 2 m/s side step swung it +-0.1 rad, and a heading-frame command sent a link's delay
        # earlier then pointed 1.5 m/s off across the road.
        norm = math.sqrt(fx * fx + fy * fy + fz * fz)
        d3 = (fx / norm, fy / norm, fz / norm)
        y_c = (-math.sin(self.yaw_ref), math.cos(self.yaw_ref), 0.0)
        d1 = _cross(y_c, d3)
        n1 = math.sqrt(_dot(d1, d1))
        d1 = (d1[0] / n1, d1[1] / n1, d1[2] / n1)
        d2 = _cross(d3, d1)
        # e_R = vee(Rd^T R - R^T Rd) / 2, written out entry by entry.
        e_rot = (0.5 * (_dot(d3, r2) - _dot(r3, d2)), 0.5 * (_dot(d1, r3) - _dot(r1, d3)),
                 0.5 * (_dot(d2, r1) - _dot(r2, d1)))
        wx, wy, wz = (float(v) for v in omega)
        e_rate = (wx, wy, wz - yaw_rate)
        ix, iy, iz = self.inertia_tuple
        gyroscopic = _cross((wx, wy, wz), (ix * wx, iy * wy, iz * wz))
        ka, kr = p["attitude_gain"], p["rate_gain"]
        torque = [inertia * (-ka * er - kr * ew) + g
                  for inertia, er, ew, g in zip(self.inertia_tuple, e_rot, e_rate, gyroscopic)]

        thrust = fx * r3[0] + fy * r3[1] + fz * r3[2]
        thrust = max(0.0, min(thrust, self.max_rotor_thrust * len(self.motor_thrust)))
        wrench = (thrust, torque[0], torque[1], torque[2])
        return np.array([max(0.0, min(self.max_rotor_thrust, sum(a * b for a, b in zip(row, wrench))))
                         for row in self.unmix_rows])


def body_axes(quat):
    """Columns of the body rotation (world <- body) of the unit quaternion ``quat`` (w, x, y, z), and the yaw,
    in plain floats: the control loops run at every physics step."""
    w, x, y, z_q = (float(v) for v in quat)
    r1 = (1 - 2 * (y * y + z_q * z_q), 2 * (x * y + w * z_q), 2 * (x * z_q - w * y))
    r2 = (2 * (x * y - w * z_q), 1 - 2 * (x * x + z_q * z_q), 2 * (y * z_q + w * x))
    r3 = (2 * (x * z_q + w * y), 2 * (y * z_q - w * x), 1 - 2 * (x * x + y * y))
    yaw = math.atan2(r1[1], r1[0])
    return r1, r2, r3, yaw


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
