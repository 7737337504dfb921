"""The stack's side of a PX4 quadrotor behind MAVROS, ROS-free: take-off, OFFBOARD, velocity set-points, landing and
the watch over the autopilot's mode (drone_model px4_quad).

The state machine (``Phase``) is driven by what MAVROS reports (``on_state``, ``on_extended_state``,
``on_local_position``, ``on_battery``), by the stack (``on_velocity_command``, ``request_takeoff``, ``request_land``,
``request_resume``) and by the answers of MAVROS's services (``on_mode_sent``, ``on_arming_answer``,
``on_service_error``); ``tick(now)`` runs the timers and returns what to do now: the set-point to publish (or None:
command nothing) and the service requests to make. Every change of phase goes through ``_transition``, which logs
``A -> B (reason)`` and keeps it in ``events`` for the console and the decisions.

As PX4 wants it: the set-points stream first (``stream_before_offboard_s``), then OFFBOARD is asked for and confirmed
by ``mavros/state``, then the vehicle is armed and climbs at ``takeoff_speed`` to ``takeoff_height`` above the take-off
point (the local frame's origin). Velocity set-points go out on ``mavros/setpoint_raw/local`` in the local ENU frame
(``FRAME_LOCAL_NED``: MAVROS converts ENU to NED itself) with ``VELOCITY_YAW_RATE_MASK``; the stack's commands come in
the heading frame (x forward, y left) and are turned by the vehicle's yaw. The landing descends at ``land_speed`` while
the stack's horizontal commands keep tracking, and disarms once ``mavros/extended_state`` reports the vehicle on the
ground. When the mode leaves OFFBOARD without our asking, the adapter stops commanding: a pilot's mode (POSCTL,
ALTCTL, STABILIZED, MANUAL, ...) is a manual takeover (MANUAL), an automatic one (AUTO.LOITER, AUTO.LAND, AUTO.RTL)
PX4's failsafe (FAILSAFE); ``request_resume`` asks for OFFBOARD again.
"""
import enum
import logging
import math
from dataclasses import dataclass, field
from typing import List, Optional, Tuple

LOG = logging.getLogger("ardrone_moves.mavros_offboard")

# mavros_msgs/PositionTarget
FRAME_LOCAL_NED = 1
IGNORE_PX, IGNORE_PY, IGNORE_PZ, IGNORE_AFX, IGNORE_AFY, IGNORE_AFZ, IGNORE_YAW = 1, 2, 4, 64, 128, 256, 1024
VELOCITY_YAW_RATE_MASK = IGNORE_PX | IGNORE_PY | IGNORE_PZ | IGNORE_AFX | IGNORE_AFY | IGNORE_AFZ | IGNORE_YAW  # 1479
# mavros_msgs/ExtendedState landed_state
LANDED_UNDEFINED, ON_GROUND, IN_AIR, TAKEOFF, LANDING = 0, 1, 2, 3, 4
# mavros_msgs/CommandBool result (MAV_RESULT)
MAV_RESULTS = {0: "accepted", 1: "temporarily rejected", 2: "denied", 3: "unsupported", 4: "failed"}
OFFBOARD = "OFFBOARD"
AUTOMATIC_MODES = ("AUTO.LOITER", "AUTO.LAND", "AUTO.RTL", "AUTO.MISSION", "AUTO.TAKEOFF", "AUTO.RTGS",
                   "AUTO.PRECLAND", "AUTO.FOLLOW_TARGET", "AUTO.READY")


class Phase(enum.Enum):
    DISCONNECTED = "disconnected"          # no mavros/state, or MAVROS says not connected
    IDLE = "idle"                          # connected, on the ground: waiting for a take-off request
    STREAMING = "streaming"                # take-off asked: set-points stream before OFFBOARD is asked for
    ENTERING_OFFBOARD = "entering_offboard"  # set_mode OFFBOARD sent: waiting for mavros/state to show it
    ARMING = "arming"                      # cmd/arming sent: waiting for mavros/state to show it armed
    TAKING_OFF = "taking_off"              # climbing to takeoff_height
    FLYING = "flying"                      # OFFBOARD: the stack's velocity commands are flown
    LANDING = "landing"                    # descending at land_speed, still tracking
    DISARMING = "disarming"                # on the ground (extended_state): disarming
    LANDED = "landed"                      # on the ground, disarmed, after a flight
    MANUAL = "manual"                      # a pilot's mode took the vehicle: we command nothing
    FAILSAFE = "failsafe"                  # the autopilot left OFFBOARD on its own: we command nothing


COMMANDING = (Phase.STREAMING, Phase.ENTERING_OFFBOARD, Phase.ARMING, Phase.TAKING_OFF, Phase.FLYING, Phase.LANDING,
              Phase.DISARMING)
IN_OFFBOARD = (Phase.TAKING_OFF, Phase.FLYING, Phase.LANDING, Phase.DISARMING)
AIRBORNE = (Phase.TAKING_OFF, Phase.FLYING, Phase.LANDING)

# Parameter name -> (low, high) inclusive; meanings and units in config/mavros_adapter.yaml.
PARAMETER_RANGES = {
    "stream_before_offboard_s": (0.5, 10.0),
    "mode_timeout_s": (0.5, 30.0),
    "mode_attempts": (1, 10),
    "arm_timeout_s": (0.5, 30.0),
    "takeoff_height": (0.5, 50.0),
    "takeoff_speed": (0.3, 3.0),
    "takeoff_slowdown_gain": (0.1, 10.0),
    "takeoff_timeout_s": (1.0, 120.0),
    "land_speed": (0.1, 2.0),
    "disarm_retry_s": (0.1, 10.0),
    "command_timeout_s": (0.05, 5.0),
    "state_timeout_s": (0.5, 60.0),
    "position_timeout_s": (0.1, 10.0),
    "max_speed": (0.5, 40.0),
    "max_climb": (0.1, 10.0),
    "max_yaw_rate": (0.1, 10.0),
    "takeoff_min_battery": (0.0, 100.0),
    "land_battery": (0.0, 100.0),
}
INTEGER_PARAMETERS = ("mode_attempts",)


def validated_parameters(params):
    """A copy of the adapter's keys from ``params``; ValueError naming the key when one is missing or off."""
    values = {}
    for name, (low, high) in PARAMETER_RANGES.items():
        if name not in params:
            raise ValueError("parameter '%s' is missing (see config/mavros_adapter.yaml)" % name)
        raw = params[name]
        if isinstance(raw, bool) or not isinstance(raw, (int, float)):
            raise ValueError("parameter '%s' = %r is not a number" % (name, raw))
        if name in INTEGER_PARAMETERS and raw != int(raw):
            raise ValueError("parameter '%s' = %r must be a whole number" % (name, raw))
        if not low <= raw <= high:  # (also false for NaN)
            raise ValueError("parameter '%s' = %r is outside [%g, %g]" % (name, raw, low, high))
        values[name] = int(raw) if name in INTEGER_PARAMETERS else float(raw)
    if values["land_battery"] > values["takeoff_min_battery"]:
        raise ValueError("parameter 'land_battery' = %g must not exceed 'takeoff_min_battery' = %g"
                         % (values["land_battery"], values["takeoff_min_battery"]))
    return values


@dataclass(frozen=True)
class VelocitySetpoint:
    """What goes out on mavros/setpoint_raw/local: ENU velocity [m/s] and yaw rate [rad/s, counter-clockwise]."""
    vx: float
    vy: float
    vz: float
    yaw_rate: float = 0.0

    def position_target_fields(self):
        """(coordinate_frame, type_mask, velocity (x, y, z), yaw_rate) of the mavros_msgs/PositionTarget."""
        return FRAME_LOCAL_NED, VELOCITY_YAW_RATE_MASK, (self.vx, self.vy, self.vz), self.yaw_rate


@dataclass
class Output:
    """What ``tick`` asks for: the set-point to publish now (None: publish nothing) and service requests, each
    ("set_mode", mode) or ("arming", bool)."""
    setpoint: Optional[VelocitySetpoint]
    requests: List[Tuple[str, object]] = field(default_factory=list)


def heading_to_enu(forward, left, yaw):
    """A heading-frame horizontal velocity (x forward, y left) in the ENU frame, for heading ``yaw`` [rad, ENU]."""
    c, s = math.cos(yaw), math.sin(yaw)
    return c * forward - s * left, s * forward + c * left


def _finite(*values):
    return all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in values)


class OffboardAdapter:
    """``params``: validated_parameters' keys. Not thread-safe: one caller (the node holds a lock)."""

    def __init__(self, params, now=0.0):
        self.p = validated_parameters(params)
        self.phase = Phase.DISCONNECTED
        self.since = now                  # when the present phase began [s]
        self.events = []                  # (time, "A -> B (reason)" or a report, level), newest last (100 kept)
        self.event_count = 0              # events so far
        # What MAVROS reported last.
        self.connected = self.armed = False
        self.mode = ""
        self.state_time = None
        self.landed_state = LANDED_UNDEFINED
        self.seen_in_air = False          # the land detector said the vehicle left the ground this flight
        self.position = None              # local ENU [m]
        self.yaw = None                   # [rad], ENU
        self.velocity = None              # local ENU [m/s]
        self.position_time = None
        self.battery = None               # [%]
        # The stack's last velocity command: (time, forward, left, up, yaw_rate), heading frame.
        self.command = None
        # Requests in flight and their bookkeeping.
        self.pending = set()              # "set_mode" / "arming" asked, not answered yet
        self.attempts = 0
        self.asked_at = None
        self.resuming = False             # OFFBOARD asked again in the air (no arming, no take-off)
        self.takeoff_velocity = (0.0, 0.0)  # ENU horizontal velocity at lift-off, held without a stack command
        self.takeoff_base = 0.0           # local height the take-off started from [m]
        self.disarm_asked_at = None
        self._requests = []
        self.rejected_commands = 0

    # ----- reporting -----------------------------------------------------------------------------------
    def _event(self, now, text, level=logging.INFO):
        self.events.append((now, text, level))
        del self.events[:-100]
        self.event_count += 1
        LOG.log(level, "t=%.2f s: %s", now, text)

    def _transition(self, new, now, reason, level=logging.INFO):
        """The one place the phase changes: logs and keeps ``A -> B (reason)``."""
        if new == self.phase:
            return
        self._event(now, "%s -> %s (%s)" % (self.phase.value, new.value, reason), level)
        self.phase, self.since = new, now
        self.attempts, self.asked_at = 0, None
        if new != Phase.DISARMING:
            self.disarm_asked_at = None

    @property
    def commanding(self):
        return self.phase in COMMANDING

    def reported_landed_state(self):
        """What the stack's drone/navdata should say (as a landed_state): the land detector's, except that a take-off
        we are carrying out is TAKEOFF from the request on (as the AR.Drone reports it at once; PX4's detector says
        ON_GROUND until the motors lift it, seconds later, and the tracker gives a take-off up that it does not see
        acknowledged) and a landing we are carrying out is LANDING until the detector reports the ground."""
        if self.phase in (Phase.STREAMING, Phase.ENTERING_OFFBOARD, Phase.ARMING, Phase.TAKING_OFF) \
                and not self.resuming and self.landed_state != IN_AIR:
            return TAKEOFF
        if self.phase == Phase.LANDING and self.landed_state != ON_GROUND:
            return LANDING
        return self.landed_state

    # ----- what MAVROS reports ---------------------------------------------------------------------------
    def on_state(self, connected, armed, mode, now):
        """mavros/state."""
        was_armed = self.armed
        self.connected, self.armed, self.mode, self.state_time = bool(connected), bool(armed), str(mode), now
        if not self.connected:
            if self.phase != Phase.DISCONNECTED:
                self._transition(Phase.DISCONNECTED, now, "MAVROS lost the autopilot's heartbeat", logging.ERROR)
            return
        if self.phase == Phase.DISCONNECTED:
            self._reconnected(now)
            return
        if self.phase in (Phase.ENTERING_OFFBOARD, Phase.STREAMING) and self.mode == OFFBOARD and self.resuming:
            self._transition(Phase.FLYING, now, "OFFBOARD again: the stack flies")
            self.resuming = False
        elif self.phase == Phase.ENTERING_OFFBOARD and self.mode == OFFBOARD:
            if self.armed:
                self._transition(Phase.TAKING_OFF, now, "OFFBOARD, already armed")
                self._start_climb()
            else:
                self._transition(Phase.ARMING, now, "OFFBOARD confirmed: arming")
                self._ask(now, ("arming", True))
        elif self.phase == Phase.ARMING and self.armed:
            self._transition(Phase.TAKING_OFF, now, "armed: climbing to %.1f m" % self.p["takeoff_height"])
            self._start_climb()
        elif self.phase == Phase.ARMING and self.mode != OFFBOARD:
            self._transition(Phase.IDLE, now, "mode %s before the take-off: the take-off is off" % self.mode,
                             logging.WARNING)
        elif self.phase in IN_OFFBOARD and self.mode != OFFBOARD:
            self._offboard_left(now)
        elif self.phase in AIRBORNE and was_armed and not self.armed:
            self._transition(Phase.LANDED, now, "disarmed in the air (kill switch or the autopilot)", logging.ERROR)
        elif self.phase == Phase.DISARMING and not self.armed:
            self._transition(Phase.LANDED, now, "disarmed on the ground")
        elif self.phase in (Phase.MANUAL, Phase.FAILSAFE) and not self.armed:
            self._transition(Phase.LANDED, now, "disarmed after the %s" % (
                "pilot's flight" if self.phase == Phase.MANUAL else "failsafe"))

    def _reconnected(self, now):
        if not self.armed:
            self._transition(Phase.IDLE, now, "connected, disarmed (mode %s)" % self.mode)
        elif self.mode == OFFBOARD and self.landed_state != ON_GROUND:
            self._transition(Phase.FLYING, now, "connected in OFFBOARD in the air: the stack flies on")
        elif self.landed_state == ON_GROUND:
            self._transition(Phase.IDLE, now, "connected, armed on the ground (mode %s)" % self.mode, logging.WARNING)
        else:
            self._transition(self._who_has_it(self.mode), now, "connected in the air in %s: not ours" % self.mode,
                             logging.WARNING)

    @staticmethod
    def _who_has_it(mode):
        return Phase.FAILSAFE if mode in AUTOMATIC_MODES else Phase.MANUAL

    def _offboard_left(self, now):
        phase = self._who_has_it(self.mode)
        if phase == Phase.FAILSAFE:
            reason = "OFFBOARD lost: the autopilot switched to %s (its failsafe); commanding stops" % self.mode
        else:
            reason = "pilot takeover: mode %s; commanding stops" % self.mode
        self._transition(phase, now, reason, logging.ERROR if phase == Phase.FAILSAFE else logging.WARNING)
        self.resuming = False

    def on_extended_state(self, landed_state, now):
        """mavros/extended_state: the land detector."""
        self.landed_state = int(landed_state)
        if self.landed_state in (IN_AIR, TAKEOFF, LANDING):
            self.seen_in_air = True
        if self.landed_state == ON_GROUND and self.seen_in_air and self.phase in (Phase.FLYING, Phase.LANDING):
            self._transition(Phase.DISARMING, now, "touchdown: the land detector reports the ground")
            self._ask(now, ("arming", False))
            self.disarm_asked_at = now

    def on_local_position(self, position, yaw, now, velocity=None):
        """mavros/local_position/pose (and velocity_local): local ENU position [m], yaw [rad], velocity [m/s]."""
        if not _finite(*position) or not _finite(yaw) or (velocity is not None and not _finite(*velocity)):
            self._event(now, "non-finite local position ignored", logging.WARNING)
            return
        self.position, self.yaw, self.position_time = tuple(position), float(yaw), now
        if velocity is not None:
            self.velocity = tuple(velocity)
        if self.phase == Phase.TAKING_OFF and position[2] >= self.takeoff_base + self.p["takeoff_height"] - 0.1:
            self._transition(Phase.FLYING, now, "take-off height reached (%.1f m above the take-off point)"
                             % (position[2] - self.takeoff_base))

    def on_battery(self, percent, now):
        """mavros/battery, in percent."""
        if not _finite(percent):
            return
        self.battery = float(percent)
        if self.phase in (Phase.FLYING, Phase.TAKING_OFF) and self.battery <= self.p["land_battery"]:
            self._transition(Phase.LANDING, now, "battery %.0f %% at or below %.0f %%: landing"
                             % (self.battery, self.p["land_battery"]), logging.WARNING)

    # ----- what the stack asks ----------------------------------------------------------------------------
    def on_velocity_command(self, forward, left, up, yaw_rate, now):
        """The stack's velocity command (heading frame, m/s and rad/s). False (and ignored) when not finite."""
        if not _finite(forward, left, up, yaw_rate):
            self.rejected_commands += 1
            return False
        self.command = (now, float(forward), float(left), float(up), float(yaw_rate))
        return True

    def request_takeoff(self, now):
        """Take off (from IDLE or LANDED): returns None when started, else why not."""
        problem = self._takeoff_problem(now)
        if problem:
            self._event(now, "take-off refused: %s" % problem, logging.WARNING)
            return problem
        self.resuming = False
        self.takeoff_base = self.position[2]
        self.seen_in_air = False
        self._transition(Phase.STREAMING, now, "take-off requested: set-points stream before OFFBOARD")
        return None

    def _takeoff_problem(self, now):
        if self.phase not in (Phase.IDLE, Phase.LANDED):
            return "the adapter is %s, not on the ground and idle" % self.phase.value
        if not self._position_fresh(now):
            return "no local position from mavros/local_position/pose (the autopilot's estimate)"
        if self.battery is not None and self.battery < self.p["takeoff_min_battery"]:
            return "battery %.0f %% below %.0f %%" % (self.battery, self.p["takeoff_min_battery"])
        return None

    def request_land(self, now):
        """Land (descend while tracking, disarm on touchdown): None when started, else why not."""
        if self.phase in (Phase.FLYING, Phase.TAKING_OFF):
            self._transition(Phase.LANDING, now, "landing requested: descending at %.2f m/s while tracking"
                             % self.p["land_speed"])
            return None
        if self.phase == Phase.LANDING:
            return None
        if self.phase in (Phase.STREAMING, Phase.ENTERING_OFFBOARD, Phase.ARMING) and not self.resuming:
            self._transition(Phase.IDLE, now, "take-off cancelled by a landing request", logging.WARNING)
            return None
        problem = "the adapter is %s%s" % (self.phase.value, ": the pilot or the autopilot has the vehicle"
                                           if self.phase in (Phase.MANUAL, Phase.FAILSAFE) else "")
        self._event(now, "landing refused: %s" % problem, logging.WARNING)
        return problem

    def request_resume(self, now):
        """After a takeover or a failsafe, in the air: ask for OFFBOARD again (streaming first)."""
        if self.phase not in (Phase.MANUAL, Phase.FAILSAFE):
            problem = "the adapter is %s, not handed the vehicle back" % self.phase.value
        elif not self.armed or self.landed_state == ON_GROUND:
            problem = "not in the air (take off instead)"
        else:
            problem = None
        if problem:
            self._event(now, "resume refused: %s" % problem, logging.WARNING)
            return problem
        self.resuming = True
        self._transition(Phase.STREAMING, now, "resume requested: set-points stream, then OFFBOARD")
        return None

    # ----- service answers -------------------------------------------------------------------------------
    def on_mode_sent(self, mode_sent, now):
        self.pending.discard("set_mode")
        if not mode_sent:
            self._event(now, "set_mode OFFBOARD: MAVROS did not send it", logging.WARNING)

    def on_arming_answer(self, value, success, result, now):
        self.pending.discard("arming")
        if success:
            return
        what = "arming" if value else "disarming"
        reason = "%s refused by the autopilot: result %d (%s)" % (what, result, MAV_RESULTS.get(result, "?"))
        if value and self.phase == Phase.ARMING:
            self._transition(Phase.IDLE, now, reason, logging.ERROR)
        else:
            self._event(now, reason, logging.WARNING)

    def on_service_error(self, name, error, now):
        """A service call failed (no such service, no acknowledgement in time)."""
        self.pending.discard(name)
        reason = "%s failed: %s" % (name, error)
        if name == "arming" and self.phase == Phase.ARMING:
            self._transition(Phase.IDLE, now, reason, logging.ERROR)
        else:
            self._event(now, reason, logging.WARNING)

    # ----- the clock -----------------------------------------------------------------------------------------
    def tick(self, now):
        """Timers at ``now`` [s]; returns the Output for now."""
        p = self.p
        if self.phase != Phase.DISCONNECTED and (self.state_time is None or now - self.state_time > p["state_timeout_s"]):
            self._transition(Phase.DISCONNECTED, now, "no mavros/state for %.1f s" % p["state_timeout_s"],
                             logging.ERROR)
        phase, elapsed = self.phase, now - self.since
        if phase == Phase.STREAMING and elapsed >= p["stream_before_offboard_s"]:
            if self.mode == OFFBOARD and self.resuming:
                self._transition(Phase.FLYING, now, "already in OFFBOARD")
                self.resuming = False
            else:
                self._transition(Phase.ENTERING_OFFBOARD, now, "%.1f s of set-points: asking for OFFBOARD" % elapsed)
                self._ask(now, ("set_mode", OFFBOARD))
        elif phase == Phase.ENTERING_OFFBOARD and self.asked_at is not None and \
                now - self.asked_at >= p["mode_timeout_s"]:
            if self.attempts >= p["mode_attempts"]:
                back = Phase.IDLE if not self.resuming else self._who_has_it(self.mode)
                self.resuming = False
                self._transition(back, now, "OFFBOARD refused by the autopilot: still %s after %d requests (is the "
                                            "position estimate valid? do set-points reach it?)"
                                 % (self.mode, self.attempts), logging.ERROR)
            else:
                self._ask(now, ("set_mode", OFFBOARD))
        elif phase == Phase.ARMING and elapsed >= p["arm_timeout_s"] and "arming" not in self.pending:
            self._transition(Phase.IDLE, now, "arming not confirmed by mavros/state within %.1f s"
                             % p["arm_timeout_s"], logging.ERROR)
        elif phase == Phase.TAKING_OFF and elapsed >= p["takeoff_timeout_s"]:
            self._transition(Phase.FLYING, now, "take-off height not reached within %.0f s: the stack flies from "
                                                "here" % p["takeoff_timeout_s"], logging.WARNING)
        elif phase == Phase.DISARMING and self.armed and "arming" not in self.pending and \
                (self.disarm_asked_at is None or now - self.disarm_asked_at >= p["disarm_retry_s"]):
            self._ask(now, ("arming", False))
            self.disarm_asked_at = now
        requests, self._requests = self._requests, []
        return Output(self._setpoint(now) if self.commanding else None, requests)

    def _ask(self, now, request):
        name = request[0]
        if name in self.pending:
            return
        self.pending.add(name)
        self.attempts += 1
        self.asked_at = now
        self._requests.append(request)

    def _position_fresh(self, now):
        return self.position_time is not None and now - self.position_time <= self.p["position_timeout_s"]

    def _start_climb(self):
        if self.velocity is not None:
            self.takeoff_velocity = (self.velocity[0], self.velocity[1])

    def _stack_command(self, now):
        """(east, north, up, yaw_rate) of the stack's fresh command, or None."""
        if self.command is None or now - self.command[0] > self.p["command_timeout_s"] or self.yaw is None:
            return None
        _, forward, left, up, yaw_rate = self.command
        east, north = heading_to_enu(forward, left, self.yaw)
        return east, north, up, yaw_rate

    def _setpoint(self, now):
        p, phase = self.p, self.phase
        command = self._stack_command(now)
        if phase == Phase.TAKING_OFF:
            # Straight up, slowing into the height; horizontally what the stack asks, else the velocity at lift-off
            # (from a moving vehicle: keep its speed rather than brake to a stop over the road).
            height = self.position[2] - self.takeoff_base if self.position is not None else 0.0
            climb = min(p["takeoff_speed"], max(0.3, p["takeoff_slowdown_gain"] * (p["takeoff_height"] - height)))
            east, north = (command[0], command[1]) if command else self.takeoff_velocity
            return self._limited(east, north, climb, command[3] if command else 0.0)
        if phase == Phase.FLYING and command:
            return self._limited(*command)
        if phase == Phase.LANDING:
            east, north, yaw_rate = (command[0], command[1], command[3]) if command else (0.0, 0.0, 0.0)
            return self._limited(east, north, -p["land_speed"], yaw_rate)
        if phase == Phase.DISARMING:
            return VelocitySetpoint(0.0, 0.0, -p["land_speed"], 0.0)  # pressed on the pad until disarmed
        if phase in (Phase.STREAMING, Phase.ENTERING_OFFBOARD, Phase.ARMING) and command:
            east, north, _, yaw_rate = command   # on the ground (or resuming): horizontal only, no climb
            return self._limited(east, north, 0.0 if not self.resuming else command[2], yaw_rate)
        return VelocitySetpoint(0.0, 0.0, 0.0, 0.0)  # hover (no fresh command)

    def _limited(self, east, north, up, yaw_rate):
        p = self.p
        speed = math.hypot(east, north)
        if speed > p["max_speed"]:
            east, north = east * p["max_speed"] / speed, north * p["max_speed"] / speed
        up = max(-p["max_climb"], min(p["max_climb"], up))
        yaw_rate = max(-p["max_yaw_rate"], min(p["max_yaw_rate"], yaw_rate))
        return VelocitySetpoint(east + 0.0, north + 0.0, up + 0.0, yaw_rate + 0.0)
