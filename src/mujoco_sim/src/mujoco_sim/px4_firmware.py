"""A PX4 quadrotor as it behaves behind MAVROS, ROS-free (drone_model: px4_quad).

What a companion computer meets when it flies a PX4 multicopter through MAVROS, the inconvenient parts included:

- OFFBOARD is granted only while set-points stream: the last one younger than ``offboard_stream_period_s`` (0.5 s:
  faster than 2 Hz) and the one before it no further apart. Asked for without the stream, the switch is refused; the
  request itself was sent all the same (MAVROS's set_mode answers mode_sent = true), and only ``mavros/state`` shows
  that the mode did not change.
- When the stream stops for ``offboard_loss_timeout_s`` (PX4's COM_OF_LOSS_T) in OFFBOARD, the commander leaves it
  for its failsafe: hold (AUTO.LOITER) and, ``offboard_loss_hold_s`` later, land (AUTO.LAND). It never goes back to
  OFFBOARD by itself.
- Arming is refused unless the vehicle is on the ground, its position estimate is valid (for the modes that need
  one), the battery is above ``arm_min_battery``, and in OFFBOARD the stream is alive. Disarming is refused in the
  air. Armed on the ground and never taken off, it disarms itself after ``disarm_preflight_s`` (COM_DISARM_PRFLT);
  landed, after ``disarm_after_land_s`` (COM_DISARM_LAND).
- Take-off: CommandTOL take-off or mode AUTO.TAKEOFF climbs to ``takeoff_altitude`` (MIS_TAKEOFF_ALT) once armed,
  then holds (AUTO.LOITER). In OFFBOARD, a climb set-point faster than ``takeoff_trigger_speed`` lifts off.
  Landing: CommandTOL land or AUTO.LAND descends at ``land_speed`` where it is; the land detector reports the
  touchdown ``land_detector_s`` after the contact (any mode: a descent set-point onto the pad lands too).
- A pilot (the RC mode switch, or any ground station's set_mode) may switch the mode at any time: that is the
  manual takeover, and OFFBOARD set-points are then ignored. POSCTL and AUTO.LOITER hold the position, ALTCTL,
  STABILIZED and MANUAL hold the altitude and level (sticks centred: the drone drifts with the wind).
- Failsafes also land the vehicle on a battery at or below ``battery_land_percent`` and when the position estimate
  has had no GPS for ``position_loss_timeout_s`` in a mode that needs it (POSCTL falls back to ALTCTL).
- The velocity loop (PX4's multicopter position controller, its parameter names in config/sim.yaml) flies on the
  vehicle's own estimate (Px4Estimator: IMU dead reckoning pulled to GPS position and velocity and the barometer)
  when the realism profile says firmware_on_estimate.

Classes: Setpoint (a validated offboard set-point), OffboardStream, Px4Commander (modes, arming, failsafes, land
detector: time is passed in), Px4Estimator, Px4Firmware (the flight controller, an Autopilot).
"""
import logging
import math

import numpy as np

from .autopilot import Autopilot, FlightMode, body_axes, wrap_angle

LOG = logging.getLogger("mujoco_sim.px4_firmware")

# Modes as MAVROS names them (mavros_msgs/State.mode for PX4).
MANUAL, STABILIZED, ACRO, RATTITUDE = "MANUAL", "STABILIZED", "ACRO", "RATTITUDE"
ALTCTL, POSCTL, OFFBOARD = "ALTCTL", "POSCTL", "OFFBOARD"
AUTO_LOITER, AUTO_TAKEOFF, AUTO_LAND, AUTO_RTL = "AUTO.LOITER", "AUTO.TAKEOFF", "AUTO.LAND", "AUTO.RTL"
AUTO_MISSION, AUTO_RTGS, AUTO_READY = "AUTO.MISSION", "AUTO.RTGS", "AUTO.READY"
AUTO_FOLLOW_TARGET, AUTO_PRECLAND = "AUTO.FOLLOW_TARGET", "AUTO.PRECLAND"
# Names MAVROS knows for PX4 (set_mode answers mode_sent = false for any other).
KNOWN_MODES = (MANUAL, ACRO, ALTCTL, POSCTL, OFFBOARD, STABILIZED, RATTITUDE, AUTO_MISSION, AUTO_LOITER, AUTO_RTL,
               AUTO_LAND, AUTO_RTGS, AUTO_READY, AUTO_TAKEOFF, AUTO_FOLLOW_TARGET, AUTO_PRECLAND)
# The modes this emulation flies; the other known ones are refused.
FLOWN_MODES = (MANUAL, STABILIZED, ALTCTL, POSCTL, OFFBOARD, AUTO_LOITER, AUTO_TAKEOFF, AUTO_LAND)
PILOT_MODES = (MANUAL, STABILIZED, ALTCTL, POSCTL)        # what an RC mode switch selects
NEEDS_POSITION = (POSCTL, OFFBOARD, AUTO_LOITER, AUTO_TAKEOFF)
HOLDS_POSITION = (POSCTL, AUTO_LOITER)
HOLDS_ALTITUDE_ONLY = (MANUAL, STABILIZED, ALTCTL)
# The heartbeat's base-mode flags that MAVROS turns into State.guided and State.manual_input.
GUIDED_MODES = (POSCTL, OFFBOARD, AUTO_LOITER, AUTO_TAKEOFF, AUTO_LAND)
MANUAL_INPUT_MODES = (MANUAL, STABILIZED, ALTCTL, POSCTL)

# MAV_RESULT of a COMMAND_ACK (mavros_msgs CommandBool / CommandTOL ``result``).
ACCEPTED, TEMPORARILY_REJECTED, DENIED, UNSUPPORTED, FAILED = 0, 1, 2, 3, 4
# mavros_msgs/ExtendedState landed_state.
LANDED_UNDEFINED, ON_GROUND, IN_AIR, TAKEOFF, LANDING = 0, 1, 2, 3, 4
# MAV_STATE (State.system_status).
MAV_STATE_STANDBY, MAV_STATE_ACTIVE, MAV_STATE_CRITICAL, MAV_STATE_EMERGENCY = 3, 4, 5, 6

# PositionTarget coordinate_frame and type_mask bits (mavros_msgs/PositionTarget).
FRAME_LOCAL_NED, FRAME_LOCAL_OFFSET_NED, FRAME_BODY_NED, FRAME_BODY_OFFSET_NED = 1, 7, 8, 9
IGNORE_PX, IGNORE_PY, IGNORE_PZ, IGNORE_VX, IGNORE_VY, IGNORE_VZ = 1, 2, 4, 8, 16, 32
IGNORE_AFX, IGNORE_AFY, IGNORE_AFZ, FORCE, IGNORE_YAW, IGNORE_YAW_RATE = 64, 128, 256, 512, 1024, 2048
IGNORE_POSITION = IGNORE_PX | IGNORE_PY | IGNORE_PZ
IGNORE_VELOCITY = IGNORE_VX | IGNORE_VY | IGNORE_VZ
IGNORE_ACCELERATION = IGNORE_AFX | IGNORE_AFY | IGNORE_AFZ

FAILSAFE_OFFBOARD_LOSS, FAILSAFE_POSITION_LOSS, FAILSAFE_BATTERY = "offboard loss", "position loss", "battery"
GRAVITY = 9.81


class Setpoint:
    """One offboard set-point as the firmware keeps it: ``kind`` "velocity" (``vector`` m/s) or "position" (``vector``
    m in the local frame), in the local ENU frame or, with ``body``, the heading frame (x forward, y left, z up);
    ``yaw`` [rad, ENU] or ``yaw_rate`` [rad/s, counter-clockwise]: one of them, or neither (hold the heading)."""

    __slots__ = ("kind", "vector", "body", "yaw", "yaw_rate")

    def __init__(self, kind, vector, body=False, yaw=None, yaw_rate=None):
        self.kind, self.vector, self.body, self.yaw, self.yaw_rate = kind, tuple(vector), body, yaw, yaw_rate

    @classmethod
    def velocity(cls, vx, vy, vz, yaw_rate=0.0, body=False):
        """A velocity set-point (ENU local, or the heading frame with ``body``) and yaw rate, as from
        setpoint_velocity/cmd_vel_unstamped; (None, why) when a value is not finite."""
        return cls._checked(cls("velocity", (vx, vy, vz), body=body, yaw_rate=yaw_rate))

    @classmethod
    def from_position_target(cls, coordinate_frame, type_mask, position, velocity, yaw, yaw_rate):
        """The set-point of a mavros_msgs/PositionTarget (its frame, mask, position, velocity, yaw, yaw rate), or
        (None, why) for what PX4 would not fly here: unknown frame, acceleration or force set-points, NaN."""
        if coordinate_frame not in (FRAME_LOCAL_NED, FRAME_LOCAL_OFFSET_NED, FRAME_BODY_NED, FRAME_BODY_OFFSET_NED):
            return None, "coordinate_frame %r is not a local or body frame (1, 7, 8, 9)" % (coordinate_frame,)
        body = coordinate_frame in (FRAME_BODY_NED, FRAME_BODY_OFFSET_NED)
        uses_position = (type_mask & IGNORE_POSITION) != IGNORE_POSITION
        uses_velocity = (type_mask & IGNORE_VELOCITY) != IGNORE_VELOCITY
        uses_acceleration = (type_mask & IGNORE_ACCELERATION) != IGNORE_ACCELERATION
        if uses_acceleration or type_mask & FORCE:
            return None, "type_mask %d asks for an acceleration or force set-point (not emulated)" % type_mask
        if uses_position == uses_velocity:
            return None, ("type_mask %d uses %s: send position or velocity (e.g. 1479 = velocity and yaw rate)"
                          % (type_mask, "both position and velocity" if uses_position else "neither position nor "
                                                                                          "velocity"))
        if uses_position and (type_mask & IGNORE_POSITION):
            return None, "type_mask %d ignores only some position axes (not emulated)" % type_mask
        if uses_velocity and (type_mask & IGNORE_VELOCITY):
            return None, "type_mask %d ignores only some velocity axes (not emulated)" % type_mask
        if uses_position and body:
            return None, "position set-points in a body frame are not emulated: use FRAME_LOCAL_NED (1)"
        use_yaw, use_rate = not type_mask & IGNORE_YAW, not type_mask & IGNORE_YAW_RATE
        setpoint = cls("position" if uses_position else "velocity", position if uses_position else velocity,
                       body=body, yaw=yaw if use_yaw else None,
                       yaw_rate=yaw_rate if (use_rate and not use_yaw) else None)
        return cls._checked(setpoint)

    @staticmethod
    def _checked(setpoint):
        values = list(setpoint.vector) + [v for v in (setpoint.yaw, setpoint.yaw_rate) if v is not None]
        for value in values:
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                return None, "non-finite set-point value %r: the set-point is ignored" % (value,)
        setpoint.vector = tuple(float(v) for v in setpoint.vector)
        return setpoint, None

    @property
    def climb(self):
        """Upward speed asked for [m/s] (velocity set-points only, else 0)."""
        return self.vector[2] if self.kind == "velocity" else 0.0

    def __repr__(self):
        return "Setpoint(%s %s%s, yaw=%r, yaw_rate=%r)" % (self.kind, self.vector, " body" if self.body else "",
                                                           self.yaw, self.yaw_rate)


class OffboardStream:
    """When the offboard set-points came: PX4's offboard signal."""

    def __init__(self, period_s, loss_timeout_s):
        self.period_s, self.loss_timeout_s = float(period_s), float(loss_timeout_s)
        self.last = self.previous = None  # times of the last two set-points [s]
        self.count = 0

    def received(self, now):
        self.previous, self.last = self.last, now
        self.count += 1

    def alive(self, now):
        """Streaming faster than 1/period_s: the last two set-points are each within period_s of the next moment."""
        return self.last is not None and self.previous is not None and \
            now - self.last <= self.period_s + 1e-9 and self.last - self.previous <= self.period_s + 1e-9

    def lost(self, now):
        return self.last is None or now - self.last > self.loss_timeout_s + 1e-9


class VehicleStatus:
    """What the commander needs of the rest of the vehicle at a tick."""

    __slots__ = ("on_ground", "crashed", "position_valid", "battery", "airborne_control")

    def __init__(self, on_ground=True, crashed=False, position_valid=True, battery=100.0, airborne_control=False):
        self.on_ground, self.crashed, self.position_valid = on_ground, crashed, position_valid
        self.battery, self.airborne_control = battery, airborne_control


class Px4Commander:
    """PX4's commander as a companion computer meets it: the mode, arming, the offboard signal, failsafes and the
    land detector. ``params``: the validated ``px4_quad`` section. Every input carries the time [s]; ``tick`` runs the
    timers. ``events`` keeps (time, text) of what it decided, newest last (what PX4 would say in its STATUSTEXTs)."""

    def __init__(self, params, now=0.0):
        self.p = params
        self.stream = OffboardStream(params["offboard_stream_period_s"], params["offboard_loss_timeout_s"])
        self.setpoint = None               # the last valid offboard set-point
        self.mode = params["initial_mode"]
        self.armed = False
        self.armed_at = None
        self.flown_since_armed = False
        self.landed = True                 # the land detector
        self.contact_since = now           # ground contact began [s] (None in the air)
        self.landed_since = now
        self.failsafe = None               # FAILSAFE_* while a failsafe holds the mode
        self.failsafe_since = None
        self.position_valid = True
        self.battery = 100.0
        self.events = []

    # ----- reporting ---------------------------------------------------------------------------
    def _event(self, now, text, level=logging.INFO):
        self.events.append((now, text))
        del self.events[:-50]
        LOG.log(level, "t=%.2f s: %s", now, text)

    @property
    def guided(self):
        return self.mode in GUIDED_MODES

    @property
    def manual_input(self):
        return self.mode in MANUAL_INPUT_MODES

    @property
    def system_status(self):
        if self.battery <= self.p["battery_land_percent"]:
            return MAV_STATE_EMERGENCY
        if self.failsafe is not None:
            return MAV_STATE_CRITICAL
        return MAV_STATE_ACTIVE if self.armed else MAV_STATE_STANDBY

    def _set_mode(self, mode, now, why, failsafe=None):
        if mode != self.mode or failsafe != self.failsafe:
            self._event(now, "mode %s -> %s (%s)" % (self.mode, mode, why),
                        logging.WARNING if failsafe else logging.INFO)
        self.mode = mode
        self.failsafe = failsafe
        self.failsafe_since = now if failsafe else None

    # ----- inputs ------------------------------------------------------------------------------
    def receive_setpoint(self, setpoint, now):
        """A valid offboard set-point reached the autopilot (any mode: it also feeds the signal OFFBOARD needs)."""
        self.setpoint = setpoint
        self.stream.received(now)

    def request_mode(self, mode, now, source="ground station"):
        """A mode request (MAVROS set_mode, or the pilot's RC switch with ``source`` "pilot"): True when the mode is
        now ``mode``, else False with the refusal logged (MAVROS does not hear of it: watch ``mode``)."""
        problem = self.mode_problem(mode, now)
        if problem:
            self._event(now, "%s's request for %s refused: %s" % (source, mode, problem), logging.WARNING)
            return False
        if self.failsafe is not None:
            self._set_mode(mode, now, "%s's request ends the %s failsafe" % (source, self.failsafe))
        elif mode != self.mode:
            self._set_mode(mode, now, "%s's request" % source)
        return True

    def mode_problem(self, mode, now):
        """Why ``mode`` cannot be entered now, or None."""
        if mode not in KNOWN_MODES:
            return "unknown mode"
        if mode not in FLOWN_MODES:
            return "not emulated"
        if mode == OFFBOARD and not self.stream.alive(now):
            return ("no offboard signal: stream set-points faster than %g Hz first"
                    % (1.0 / self.p["offboard_stream_period_s"]))
        if mode in NEEDS_POSITION and not self.position_valid:
            return "no valid position estimate"
        if mode == AUTO_TAKEOFF and not self.landed:
            return "already in the air"
        return None

    def request_arm(self, arm, now):
        """MAVROS cmd/arming: (MAV_RESULT, reason). Arming needs the conditions of the module docstring; disarming
        needs the ground."""
        if not arm:
            if not self.armed:
                return ACCEPTED, "already disarmed"
            if not self.landed:
                self._event(now, "disarming refused: not landed", logging.WARNING)
                return DENIED, "not landed"
            self._disarm(now, "disarm command")
            return ACCEPTED, "disarmed"
        if self.armed:
            return ACCEPTED, "already armed"
        problem = None
        if not self.landed:
            problem = "not on the ground"
        elif self.battery < self.p["arm_min_battery"]:
            problem = "battery %.0f %% below %.0f %%" % (self.battery, self.p["arm_min_battery"])
        elif self.mode in NEEDS_POSITION and not self.position_valid:
            problem = "no valid position estimate for %s" % self.mode
        elif self.mode == OFFBOARD and not self.stream.alive(now):
            problem = "no offboard signal"
        elif self.mode == AUTO_LAND:
            problem = "mode AUTO.LAND"
        if problem:
            self._event(now, "arming refused: %s" % problem, logging.WARNING)
            return TEMPORARILY_REJECTED, problem
        self.armed, self.armed_at, self.flown_since_armed = True, now, False
        self._event(now, "armed in %s" % self.mode)
        return ACCEPTED, "armed"

    def request_takeoff(self, now):
        """MAVROS cmd/takeoff: switch to AUTO.TAKEOFF (it climbs once armed)."""
        problem = self.mode_problem(AUTO_TAKEOFF, now)
        if problem:
            self._event(now, "take-off refused: %s" % problem, logging.WARNING)
            return TEMPORARILY_REJECTED, problem
        self._set_mode(AUTO_TAKEOFF, now, "take-off command")
        return ACCEPTED, "taking off" if self.armed else "AUTO.TAKEOFF: arm to climb"

    def request_land(self, now):
        """MAVROS cmd/land: AUTO.LAND where it is."""
        self._set_mode(AUTO_LAND, now, "land command")
        return ACCEPTED, "landing"

    def takeoff_complete(self, now):
        if self.mode == AUTO_TAKEOFF:
            self._set_mode(AUTO_LOITER, now, "take-off altitude reached")

    def start_in_air(self, now):
        """The world started with the vehicle flying: armed, holding."""
        self.armed, self.armed_at, self.flown_since_armed = True, now, True
        self.landed, self.contact_since, self.landed_since = False, None, None
        if self.mode not in HOLDS_POSITION:
            self.mode = AUTO_LOITER

    def _disarm(self, now, why):
        self.armed, self.armed_at = False, None
        self._event(now, "disarmed (%s)" % why)

    # ----- timers ------------------------------------------------------------------------------
    def tick(self, now, status):
        """Run the land detector, the auto-disarm and the failsafes at ``now`` with the vehicle's ``status``."""
        self.position_valid, self.battery = status.position_valid, status.battery
        self._land_detector(now, status)
        self._auto_disarm(now)
        self._failsafes(now)

    def _land_detector(self, now, status):
        if status.on_ground or status.crashed:
            if self.contact_since is None:
                self.contact_since = now
            if not self.landed and (status.crashed or now - self.contact_since >= self.p["land_detector_s"]):
                self.landed, self.landed_since = True, now
                self._event(now, "land detected")
        else:
            self.contact_since = None
            if self.landed and status.airborne_control:
                self.landed, self.landed_since = False, None
                if self.armed:
                    self.flown_since_armed = True
                self._event(now, "takeoff detected")

    def _auto_disarm(self, now):
        if not (self.armed and self.landed):
            return
        since = max(self.armed_at, self.landed_since)
        limit = self.p["disarm_after_land_s"] if self.flown_since_armed else self.p["disarm_preflight_s"]
        if now - since >= limit:
            self._disarm(now, "auto-disarm: %s for %.1f s" % ("landed" if self.flown_since_armed else
                                                             "armed on the ground without a take-off", limit))

    def _failsafes(self, now):
        p = self.p
        if self.mode == OFFBOARD and self.stream.lost(now):
            self._set_mode(AUTO_LOITER, now, "offboard signal lost for more than %.2f s: hold"
                           % p["offboard_loss_timeout_s"], failsafe=FAILSAFE_OFFBOARD_LOSS)
        elif self.failsafe == FAILSAFE_OFFBOARD_LOSS and self.mode == AUTO_LOITER and \
                now - self.failsafe_since >= p["offboard_loss_hold_s"]:
            self._set_mode(AUTO_LAND, now, "offboard signal still lost after %.1f s of hold: land"
                           % p["offboard_loss_hold_s"], failsafe=FAILSAFE_OFFBOARD_LOSS)
        if not self.position_valid and self.mode in NEEDS_POSITION and not self.landed:
            fallback = ALTCTL if self.mode == POSCTL else AUTO_LAND
            self._set_mode(fallback, now, "position estimate lost", failsafe=FAILSAFE_POSITION_LOSS)
        if self.battery <= p["battery_land_percent"] and self.mode != AUTO_LAND and not self.landed and \
                self.failsafe != FAILSAFE_BATTERY:
            self._set_mode(AUTO_LAND, now, "battery %.0f %% at or below %.0f %%: land"
                           % (self.battery, p["battery_land_percent"]), failsafe=FAILSAFE_BATTERY)


class Px4Estimator:
    """The vehicle's own position and velocity estimate (world frame), ROS-free: a complementary filter in the role
    of PX4's EKF2. The accelerometer (biased, noisy), rotated by the attitude, is integrated and pulled towards the
    GPS's position (horizontal) and velocity and the barometer's altitude; the accelerometer's bias is estimated from
    the velocity innovations. Without GPS for ``position_loss_timeout_s`` the position is no longer valid.
    ``params``: the validated ``px4_quad`` section (its ekf_* gains)."""

    def __init__(self, params):
        self.p = params
        self.position = None            # [m], world frame
        self.velocity = np.zeros(3)     # [m/s]
        self.accel_bias = np.zeros(3)   # [m/s^2], world frame
        self.last_gps = None            # when a GPS fix was last fused [s]
        self.baro_altitude = None       # the last barometric altitude [m]

    @property
    def ready(self):
        return self.position is not None

    def valid(self, now):
        return self.ready and self.last_gps is not None and now - self.last_gps <= self.p["position_loss_timeout_s"]

    def predict(self, dt, acceleration_world):
        """Integrate the measured acceleration (world frame, gravity removed) [m/s^2] over ``dt`` [s]."""
        if self.position is None:
            return
        a = np.asarray(acceleration_world, dtype=float) - self.accel_bias
        self.position += self.velocity * dt + 0.5 * a * dt * dt
        self.velocity += a * dt

    def gps(self, now, dt, position, velocity):
        """A GPS fix (world-frame position [m] and velocity [m/s]) ``dt`` [s] after the previous one."""
        position, velocity = np.asarray(position, dtype=float), np.asarray(velocity, dtype=float)
        if self.position is None:
            # Horizontally from the GPS, vertically from the barometer (the height reference, as EKF2's default).
            self.position, self.velocity = position.copy(), velocity.copy()
            if self.baro_altitude is not None:
                self.position[2] = self.baro_altitude
            self.last_gps = now
            return
        p = self.p
        gain_position = min(1.0, p["ekf_gps_position_gain"] * dt)
        gain_velocity = min(1.0, p["ekf_gps_velocity_gain"] * dt)
        innovation = velocity - self.velocity
        self.position[:2] += gain_position * (position[:2] - self.position[:2])
        self.velocity += gain_velocity * innovation
        self.accel_bias -= p["ekf_accel_bias_gain"] * dt * innovation
        self.last_gps = now

    def baro(self, dt, altitude):
        """A barometric altitude [m] (world z), ``dt`` [s] after the previous one."""
        self.baro_altitude = altitude
        if self.position is None:
            return
        innovation = altitude - self.position[2]
        self.position[2] += min(1.0, self.p["ekf_baro_gain"] * dt) * innovation
        self.velocity[2] += self.p["ekf_baro_climb_gain"] * dt * innovation


class Px4Firmware(Autopilot):
    """PX4's flight controller behind MAVROS. ``drone_params``: the ``drone`` section (attitude loop, motor lag);
    ``params``: the validated ``px4_quad`` section. The simulator feeds it set-points and commands (``commander``),
    calls ``tick(now, ...)`` before every ``update`` and passes world-frame positions; ``local_origin`` is the
    world position of the local frame's origin (where the estimate started)."""

    def __init__(self, drone_params, params, mass, inertia, rotors, max_rotor_thrust):
        super().__init__(drone_params, mass, inertia, rotors, max_rotor_thrust)
        self.q = params
        self.commander = Px4Commander(params)
        self.now = 0.0
        self.local_origin = np.zeros(3)
        self.takeoff_from_z = None     # flown height where the present take-off began [m]
        self.requested_takeoff_height = None  # a take-off command's own altitude above the take-off point [m]
        self.hold = None               # (x, y, z, yaw) the hold modes keep
        self._held_mode = None         # the commander's mode the hold point was taken for
        self.velocity_setpoint = (0.0, 0.0, 0.0)  # what the velocity loop was asked for last [m/s], world frame
        self._previous_velocity = None
        self._velocity_rate = [0.0, 0.0, 0.0]     # filtered derivative of the flown velocity [m/s^2]

    @property
    def takeoff_height(self):
        """How far above the take-off point AUTO.TAKEOFF climbs [m]: the take-off command's altitude, else
        takeoff_altitude (MIS_TAKEOFF_ALT)."""
        return self.requested_takeoff_height or self.q["takeoff_altitude"]

    # ----- what the simulator calls ---------------------------------------------------------------
    def tick(self, now, battery, position_valid):
        """Before each update: the commander's timers at ``now`` [s] with the battery [%] and the estimate's
        validity."""
        self.now = now
        status = VehicleStatus(on_ground=self.mode == FlightMode.LANDED, crashed=self.mode == FlightMode.CRASHED,
                               position_valid=position_valid, battery=battery,
                               airborne_control=self.mode in (FlightMode.TAKING_OFF, FlightMode.FLYING,
                                                             FlightMode.LANDING))
        self.commander.tick(now, status)

    def receive_setpoint(self, setpoint, now):
        self.commander.receive_setpoint(setpoint, now)

    @property
    def landed_state(self):
        """mavros_msgs/ExtendedState landed_state of the land detector."""
        if self.commander.landed:
            return ON_GROUND
        if self.mode == FlightMode.TAKING_OFF:
            return TAKEOFF
        if self.mode == FlightMode.LANDING:
            return LANDING
        return IN_AIR

    @property
    def climbing(self):
        """Asked to climb (a contact then is no landing)."""
        return self.mode == FlightMode.TAKING_OFF or self.velocity_setpoint[2] > 0.05

    def set_mode(self, mode, reason):
        if mode == FlightMode.FLYING and reason == "started in the air":
            self.commander.start_in_air(self.now)
        super().set_mode(mode, reason)

    def touched_down(self, crashed):
        super().touched_down(crashed)
        self.velocity_setpoint = (0.0, 0.0, 0.0)
        self.hold = None

    def reset(self):
        super().reset()
        self.commander = Px4Commander(self.q, self.now)
        self.hold, self._held_mode, self.takeoff_from_z = None, None, None
        self.velocity_setpoint = (0.0, 0.0, 0.0)

    # ----- control -----------------------------------------------------------------------------
    def update(self, dt, position, velocity, quat, omega, command=None, power_available=True):
        """As Autopilot.update; ``position`` and ``velocity`` are what the firmware flies on (world frame)."""
        self._flight_phase(position)
        return super().update(dt, position, velocity, quat, omega, command,
                              power_available and self.commander.armed)

    def _flight_phase(self, position):
        """Take-off, landing and their ends, from the commander's mode and what the flown height says."""
        c, mode, z = self.commander, self.mode, float(position[2])
        if mode == FlightMode.LANDED:
            if c.armed and self._wants_takeoff(z):
                self._reset_loops()
                self.takeoff_from_z = z
                self.hold = (float(position[0]), float(position[1]), z + self.takeoff_height, None)
                self._held_mode = c.mode
                self.set_mode(FlightMode.TAKING_OFF, "take-off in %s" % c.mode)
        elif mode == FlightMode.TAKING_OFF:
            if c.mode == AUTO_TAKEOFF:
                if z >= self.takeoff_from_z + self.takeoff_height - 0.1:
                    c.takeoff_complete(self.now)
                    self.set_mode(FlightMode.FLYING, "take-off altitude reached")
            elif c.mode == AUTO_LAND:
                self.set_mode(FlightMode.LANDING, "land command during the take-off")
            elif c.mode != OFFBOARD or z >= self.takeoff_from_z + self.q["takeoff_clear_height"]:
                self.set_mode(FlightMode.FLYING, "clear of the ground in %s" % c.mode)
        elif mode == FlightMode.FLYING and c.mode == AUTO_LAND:
            self.set_mode(FlightMode.LANDING, "AUTO.LAND")
        elif mode == FlightMode.LANDING and c.mode != AUTO_LAND:
            self.set_mode(FlightMode.FLYING, "landing left for %s" % c.mode)

    def _wants_takeoff(self, z):
        c = self.commander
        if c.mode == AUTO_TAKEOFF:
            return True
        if c.mode == OFFBOARD and c.setpoint is not None:
            sp = c.setpoint
            if sp.kind == "velocity":
                return sp.climb > self.q["takeoff_trigger_speed"]
            return sp.vector[2] + self.local_origin[2] > z + 0.2
        return False

    def _thrusts(self, dt, position, velocity, quat, omega, command):
        q, c = self.q, self.commander
        r1, r2, r3, yaw = body_axes(quat)
        x, y, z = (float(v) for v in position)
        vx, vy, vz = (float(v) for v in velocity)
        mode = c.mode
        if mode != self._held_mode or self.hold is None:
            # A new mode holds where the vehicle is now (the take-off keeps its own target).
            self.hold = (x, y, z, yaw)
            self._held_mode = mode
        hold_x, hold_y, hold_z, hold_yaw = self.hold
        if hold_yaw is None:
            hold_yaw = yaw
            self.hold = (hold_x, hold_y, hold_z, yaw)
        kxy, kz = q["position_gain_xy"], q["position_gain_z"]
        level = False     # horizontal: no velocity loop, level attitude (the pilot's centred sticks)
        yaw_rate = q["yaw_gain"] * wrap_angle(hold_yaw - yaw)
        if self.mode == FlightMode.TAKING_OFF and mode != OFFBOARD:
            # AUTO.TAKEOFF (or a pilot's mode during it): straight up to the take-off altitude, slowing into it.
            set_x, set_y = kxy * (hold_x - x), kxy * (hold_y - y)
            set_z = min(q["takeoff_speed"], max(0.3, kz * (hold_z - z)))
        elif mode == OFFBOARD and c.setpoint is not None:
            sp = c.setpoint
            if sp.kind == "velocity":
                set_x, set_y, set_z = sp.vector
                if sp.body:
                    cy, sy = math.cos(yaw), math.sin(yaw)
                    set_x, set_y = cy * set_x - sy * set_y, sy * set_x + cy * set_y
            else:
                origin = self.local_origin
                set_x = kxy * (sp.vector[0] + origin[0] - x)
                set_y = kxy * (sp.vector[1] + origin[1] - y)
                set_z = kz * (sp.vector[2] + origin[2] - z)
            if sp.yaw_rate is not None:
                yaw_rate = sp.yaw_rate
            elif sp.yaw is not None:
                yaw_rate = q["yaw_gain"] * wrap_angle(sp.yaw - yaw)
            else:
                yaw_rate = 0.0
        elif mode == AUTO_LAND or self.mode == FlightMode.LANDING:
            set_x, set_y, set_z = kxy * (hold_x - x), kxy * (hold_y - y), -q["land_speed"]
        elif mode in HOLDS_ALTITUDE_ONLY:
            level = True
            set_x, set_y, set_z = 0.0, 0.0, kz * (hold_z - z)
        else:  # POSCTL, AUTO.LOITER, AUTO.TAKEOFF in the air, OFFBOARD before the first set-point
            set_x, set_y, set_z = kxy * (hold_x - x), kxy * (hold_y - y), kz * (hold_z - z)
        if self.mode == FlightMode.LANDING and mode == AUTO_LAND:
            set_z = -q["land_speed"]

        # Limits of the position controller (MPC_XY_VEL_MAX, MPC_Z_VEL_MAX_UP/DN).
        speed = math.hypot(set_x, set_y)
        if speed > q["max_horizontal_speed"]:
            set_x, set_y = set_x * q["max_horizontal_speed"] / speed, set_y * q["max_horizontal_speed"] / speed
        set_z = max(-q["max_descent_speed"], min(q["max_climb_speed"], set_z))
        self.velocity_setpoint = (set_x, set_y, set_z)
        yaw_rate = max(-q["max_yaw_rate"], min(q["max_yaw_rate"], yaw_rate))

        # Velocity loop: PID to an acceleration (the D term on the velocity's rate, low-passed), then the thrust
        # vector with the tilt limit.
        if self._previous_velocity is not None and dt > 0.0:
            smoothing = dt / (q["velocity_derivative_time_constant"] + dt)
            for axis, (now_v, before) in enumerate(zip((vx, vy, vz), self._previous_velocity)):
                self._velocity_rate[axis] += smoothing * ((now_v - before) / dt - self._velocity_rate[axis])
        self._previous_velocity = (vx, vy, vz)
        error = (set_x - vx, set_y - vy, set_z - vz)
        integral, limit = self.velocity_integral, q["velocity_integral_limit"]
        gains = ((q["velocity_p_gain_xy"], q["velocity_i_gain_xy"], q["velocity_d_gain_xy"]),) * 2 + \
            ((q["velocity_p_gain_z"], q["velocity_i_gain_z"], q["velocity_d_gain_z"]),)
        accel = []
        for axis in range(3):
            kp, ki, kd = gains[axis]
            if level and axis < 2:
                integral[axis] = 0.0
                accel.append(0.0)
                continue
            integral[axis] = max(-limit, min(limit, integral[axis] + ki * error[axis] * dt))
            accel.append(kp * error[axis] + integral[axis] - kd * self._velocity_rate[axis])
        m = self.mass
        fx, fy, fz = m * accel[0], m * accel[1], max(m * (accel[2] + GRAVITY), 0.1 * m * GRAVITY)
        max_horizontal = fz * math.tan(math.radians(q["max_tilt_deg"]))
        horizontal = math.hypot(fx, fy)
        if horizontal > max_horizontal:
            # Saturated: the integral does not grow further into the limit (anti-windup).
            for axis in (0, 1):
                if error[axis] * accel[axis] > 0.0:
                    integral[axis] -= q["velocity_i_gain_xy"] * error[axis] * dt
            fx, fy = fx * max_horizontal / horizontal, fy * max_horizontal / horizontal
        return self._attitude_thrusts(dt, fx, fy, fz, yaw, yaw_rate, r1, r2, r3, omega)
