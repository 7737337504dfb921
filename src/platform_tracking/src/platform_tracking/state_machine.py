"""Take-off / tracking / landing state machine (thesis 3.3.1), ROS-free.

States and what the drone does in each (heights are above the pad, measured from the feet):

- LANDED: nothing is commanded (another module or the operator may fly the drone).
- TAKING_OFF: ``ardrone/takeoff`` is sent, then the drone climbs at ``takeoff_climb_rate`` to
  ``nominal_height`` while it already follows the pad horizontally whenever a prediction is fresh.
- TRACKING: PID on the predicted pad position at ``nominal_height`` (see controller.py); with the pad unseen
  for ``search_climb_after`` (or never seen) at ``relocate_height`` instead, for a wider view.
- LANDING: descends at ``landing_descent_rate`` while tracking, but only while the horizontal error
  and the relative velocity are small; it holds its height while they are not, and climbs while the
  error is so large for its height that the pad could leave the (narrower, lower down) view, or
  while the camera has not seen the pad for ``vision_timeout`` (up to ``retry_height``). At
  ``commit_height`` and below (waiting at ``gate_height`` if need be) it commits to the touchdown once
  error (now, and at the touchdown at the present relative velocity) and relative speed have stayed inside
  the gate, with the pad seen within ``gate_vision_age``
  and its speed steady, for ``gate_ready_time``: it then descends at ``final_descent_rate``, still tracking, and
  sends ``ardrone/land`` at ``land_height`` (the drone settles by itself, still obeying the horizontal
  command); an error above ``commit_abort_error`` before that, now or ``commit_abort_lookahead`` later at
  the present relative velocity, calls the touchdown off, as does losing sight of the pad above
  ``blind_height``. A touchdown called off with the pad in view waits at ``gate_height`` for the gate again
  (``abort_to_gate``); a gate not met within ``gate_timeout``, or a touchdown called off with the pad out
  of view, climbs back to ``retry_height`` to re-try.
- RELOCATING: the pad has not been seen for ``lost_timeout``: climb to ``relocate_height`` for a
  wider view and fly to the last predicted position (following the prediction for as long as it
  reaches, then holding there); hover in place when nothing was ever predicted.
- FORCE_LANDING: ``force_land``: ``ardrone/land`` at once, no tracking, hold position.

Every state change goes through ``_transition``, which logs ``A -> B (reason)``. Events inside a
state (touchdown committed, re-try started, a request refused) are logged by ``_event``.
"""
import dataclasses
import enum
import math
from typing import List, Optional

import numpy as np

from .controller import (DroneState, PadPrediction, TrackingController, VelocityCommand, climb_rate_towards,
                         hold_position_command)
from .params import TrackingParams


class State(enum.Enum):
    LANDED = "LANDED"
    TAKING_OFF = "TAKING_OFF"
    TRACKING = "TRACKING"
    LANDING = "LANDING"
    RELOCATING = "RELOCATING"
    FORCE_LANDING = "FORCE_LANDING"


class Nav(enum.IntEnum):
    """landing_msgs/Navdata states (mirrored here to keep this module ROS-free)."""
    UNKNOWN = 0
    INITED = 1
    LANDED = 2
    FLYING = 3
    HOVERING = 4
    TEST = 5
    TAKING_OFF = 6
    GOTO_HOVER = 7
    LANDING = 8
    LOOPING = 9
    CRASHED = 10


AIRBORNE_NAV = (Nav.FLYING, Nav.HOVERING, Nav.TAKING_OFF, Nav.GOTO_HOVER, Nav.LANDING, Nav.LOOPING)


@dataclasses.dataclass
class Inputs:
    """Everything one step needs. ``drone`` is None until the estimator is ready; ``pad`` is the
    latest prediction (None if there never was one: its age tells whether it is fresh); the
    requests are one-shot (true on the step they arrive)."""
    time: float
    drone: Optional[DroneState] = None
    pad: Optional[PadPrediction] = None
    navdata_state: Optional[int] = None
    takeoff: bool = False
    land: bool = False
    force_land: bool = False
    landing_allowed: bool = True
    takeoff_blocked: Optional[str] = None   # why the pre-flight check holds the take-off; None: it may go
    vision_age: Optional[float] = None      # time since the latest pad detection arrived [s]; None: never
    flow_weight: float = 0.0                # how much the drone's own velocity follows the vehicle under it (0 the
                                            # ground .. 1 the vehicle; ardrone/flow_unseen_velocity,
                                            # drone_estimator.flow_surface)
    camera_latency: float = 0.0             # how late the pad's detections arrive after their image [s]
    relative: Optional[tuple] = None        # (position, rate) of the pad relative to the drone (world x, y) carried
                                            # by the flow since the latest fix (drone_estimator.relative)
                                            # [m, m/s]; None: none


@dataclasses.dataclass
class Outputs:
    """``command`` is None when nothing should be published (LANDED); ``send_takeoff`` and
    ``send_land`` are one-shot actions; ``log`` the lines logged during the step."""
    state: State
    command: Optional[VelocityCommand] = None
    send_takeoff: bool = False
    send_land: bool = False
    log: List[str] = dataclasses.field(default_factory=list)
    error: Optional[float] = None            # horizontal distance drone - pad now [m]
    height: Optional[float] = None           # height above the pad (feet) used for control [m]
    target: Optional[np.ndarray] = None      # where the pad is believed to be now, world (x, y, z) [m]


class TrackingStateMachine:
    def __init__(self, params: TrackingParams = TrackingParams(), logger=None):
        self.p = params.check()
        self.logger = logger or (lambda line: None)
        self.controller = TrackingController(params)
        self._vision_age = None  # of the current step: since the latest detection [s]; None: never
        self._flow_weight = 0.0  # of the current step: how much the drone's own velocity follows the vehicle
        self._camera_latency = 0.0  # of the current step: how late detections arrive after their image [s]
        self.state = State.LANDED
        self.entered = 0.0                       # time the current state was entered
        self.tracked_since = 0.0                 # time the pad's track began (TRACKING entered, not from LANDING)
        self.takeoff_pending = False
        self.land_pending = False
        self.last_pad: Optional[PadPrediction] = None
        # TRACKING
        self.settled_since = None
        self.refusal_logged = False
        self.searching_logged = False
        # LANDING
        self.committed = False
        self.land_sent_at = None
        self.retrying = False
        self.climbing = False
        self.blind_since_logged = False
        self.held_height = None                  # height a LANDING hold keeps: the lowest since the last climb
        self.retries = 0
        # TAKING_OFF
        self.takeoff_resends = 0
        self.at_gate_since = None
        self.ready_since = None
        # FORCE_LANDING
        self.saw_landing_nav = False
        # Height of the surface the drone took off from (the pad, normally): the height reference
        # until a prediction gives the pad's own height.
        self.takeoff_surface_z = None
        self._out = None
        self.steady_view_shift = None            # the drone's view shift averaged over aim_lean_time [m/m]
        self.lean_time = None

    def hold(self):
        """Forget a pending take-off or land request (another module has the drone, or the mission is over);
        the state itself carries on."""
        self.takeoff_pending = self.land_pending = False

    # ----- bookkeeping ---------------------------------------------------------------------------
    def _transition(self, new_state, reason, t):
        """The one place where the state changes."""
        line = "%s -> %s (%s)" % (self.state.value, new_state.value, reason)
        if new_state == State.TRACKING and self.state != State.LANDING:
            self.tracked_since = t  # a landing called off goes on with the track it had
        self.state = new_state
        self.entered = t
        self.settled_since = None
        self.refusal_logged = False
        self.searching_logged = False
        self.committed = False
        self.land_sent_at = None
        self.takeoff_resends = 0
        self.retrying = False
        self.climbing = False
        self.blind_since_logged = False
        self.held_height = None
        self.at_gate_since = None
        self.ready_since = None
        self.saw_landing_nav = False
        if new_state == State.RELOCATING:
            self.controller.reset()  # the integral belongs to the track that was lost
        if new_state == State.TAKING_OFF:
            self.takeoff_pending = False
        if new_state in (State.LANDING, State.LANDED, State.FORCE_LANDING):
            self.land_pending = False
        if new_state == State.LANDED:
            self.takeoff_pending = False
            self.retries = 0
        self._log(line)

    def _event(self, text):
        self._log("%s: %s" % (self.state.value, text))

    def _log(self, line):
        self._out.log.append(line)
        self.logger(line)

    def _send_land(self, t):
        self._out.send_land = True
        self.land_sent_at = t

    # ----- helpers -------------------------------------------------------------------------------
    def _fresh(self, pad, t, max_age):
        return pad is not None and pad.age(t) <= max_age

    def _height(self, drone, pad, t):
        """Height of the feet above the pad: the sonar where it can only be seeing the pad (the drone
        is right above it and the reading agrees with the estimate), else the estimated altitude
        minus the pad's height (from the prediction, else the configured one)."""
        p = self.p
        if pad is not None:
            pad_z = pad.position_at(t)[2]
        else:
            pad_z = self.takeoff_surface_z if self.takeoff_surface_z is not None else p.fallback_pad_height
        estimated = drone.position[2] - pad_z - p.foot_clearance
        sonar = drone.sonar_height
        if pad is not None and sonar is not None and math.isfinite(sonar):
            offset = pad.position_at(t)[:2] - drone.position[:2]
            if math.hypot(*offset) < p.sonar_pad_radius and abs(sonar - estimated) < p.sonar_consistency:
                return sonar
        return estimated

    def _command(self, world_xy, vz, yaw):
        vx, vy = TrackingController.to_heading_frame(world_xy, yaw)
        return VelocityCommand(vx, vy, vz, 0.0)

    def _flown(self, t, drone, pad, searching=True):
        """The point of the drone the tracker flies over the pad. The pad not seen: the camera's view centre (the
        prediction, GPS alone and metres off after a while, may have the drone right above the pad while the tilted
        camera looks elsewhere). Over a fast vehicle: the view centre as it would be at no more than aim_height, so
        that the camera keeps the pad's centre in view low down, where the drone, leaning 18 deg into a car's air
        stream, looks 0.11 m behind itself at the gate; the lead shrinks to nothing at the touchdown."""
        if pad is None:
            return drone
        if searching and self._searching() and not self.committed:
            return drone.viewing(self._height(drone, pad, t))
        if self.state in (State.TRACKING, State.LANDING) and self.steady_view_shift is not None and \
                float(np.hypot(*pad.velocity[:2])) >= self.p.blend_min_pad_speed:
            # The lean's steady part: the instantaneous one grows with each acceleration, and a lead that followed
            # it fed the acceleration back (the car at 10 m/s swung 0.3 m along the road at 4 m).
            lead = min(self._height(drone, pad, t), self.p.aim_height) * self.steady_view_shift
            return dataclasses.replace(drone, position=drone.position + np.array([lead[0], lead[1], 0.0]))
        return drone

    def _follow_lean(self, t, drone):
        """Averages the drone's view shift (its lean) over aim_lean_time."""
        if drone is None or drone.view_shift is None:
            return
        shift = np.asarray(drone.view_shift, dtype=float)
        if self.steady_view_shift is None or self.lean_time is None or t < self.lean_time:
            self.steady_view_shift = shift
        else:
            blend = 1.0 - math.exp(-(t - self.lean_time) / self.p.aim_lean_time)
            self.steady_view_shift = self.steady_view_shift + blend * (shift - self.steady_view_shift)
        self.lean_time = t

    def _errors(self, t, drone, pad):
        """(error, relative velocity) that the state decisions go by: of the point flown over a fast vehicle (see
        _flown), but not of the view searched with, which swings with every lean (in a corner at 3 m/s, 3.3 m at
        4 m, which called a landing off)."""
        return self.controller.errors(t, self._flown(t, drone, pad, searching=False), pad)

    def _tracking_xy(self, t, drone, pad, accumulate=True):
        return self.controller.world_velocity(t, self._flown(t, drone, pad), pad, accumulate=accumulate,
                                             flow_weight=self._flow_weight, camera_latency=self._camera_latency)

    def _searching(self):
        """True while the pad has not been seen for search_view_after (or ever), tracking or descending."""
        return self._unseen_for(self.p.search_view_after) and self.state in (
            State.TRACKING, State.LANDING, State.RELOCATING)

    def _unseen_for(self, seconds):
        """The pad not seen for more than ``seconds`` at this step, or never."""
        return self._vision_age is None or self._vision_age > seconds

    # ----- the step ------------------------------------------------------------------------------
    def step(self, inputs: Inputs) -> Outputs:
        self._out = Outputs(state=self.state)
        t = inputs.time
        self._flow_weight = inputs.flow_weight
        self._camera_latency = inputs.camera_latency
        self._vision_age = inputs.vision_age
        self._follow_lean(t, inputs.drone)
        if inputs.pad is not None:
            self.last_pad = self._relative_pad(inputs)
        if inputs.takeoff:
            self.takeoff_pending = True
        if inputs.land:
            self.land_pending = True
        nav = inputs.navdata_state
        airborne_nav = nav in AIRBORNE_NAV

        # Rules that hold in every state, by priority.
        if inputs.force_land:
            if self.state not in (State.LANDED, State.FORCE_LANDING) or airborne_nav:
                self._transition(State.FORCE_LANDING, "force_land requested", t)
                self._send_land(t)
            else:
                self._event("force_land ignored: already on the ground")
        if nav == Nav.CRASHED and self.state != State.LANDED:
            self._transition(State.LANDED, "navdata reports CRASHED", t)

        handler = {State.LANDED: self._landed, State.TAKING_OFF: self._taking_off, State.TRACKING: self._tracking,
                   State.LANDING: self._landing, State.RELOCATING: self._relocating,
                   State.FORCE_LANDING: self._force_landing}[self.state]
        if self.state != State.LANDED and inputs.drone is None:
            # No estimate (estimator silent or not ready): never fly blind; hold where it is.
            self._out.command = VelocityCommand()
            if self.state == State.FORCE_LANDING:
                self._force_landing(inputs)
        else:
            handler(inputs)
        if self.state == State.LANDED:
            self._out.command = None
        elif self.last_pad is not None and self.last_pad.age(t) <= self.p.lost_timeout + 2.0:
            self._out.target = self.last_pad.position_at(t)
        self._out.state = self.state
        return self._out

    # ----- states --------------------------------------------------------------------------------
    def _landed(self, inp):
        t = inp.time
        if inp.land and not self.takeoff_pending:
            self.land_pending = False  # nothing to land
        if not self.takeoff_pending:
            return
        if inp.drone is None:
            if inp.takeoff:
                self._event("take-off waits for the state estimate")
            return
        if inp.takeoff_blocked is not None:
            if inp.takeoff:
                self._event("take-off waits for the pre-flight check: %s" % inp.takeoff_blocked)
            return
        if inp.navdata_state in AIRBORNE_NAV:
            self._transition(State.TAKING_OFF, "take-off requested; the drone is already airborne", t)
        else:
            sonar = inp.drone.sonar_height
            if sonar is not None and math.isfinite(sonar) and sonar < 0.3:
                self.takeoff_surface_z = float(inp.drone.position[2]) - self.p.foot_clearance - sonar
            self._transition(State.TAKING_OFF, "take-off requested", t)
            self._out.send_takeoff = True
        self._taking_off(inp)

    def _external_landing(self, inp):
        """The drone reports LANDING although we did not send land: someone else did (operator on
        ardrone/land, supervisor). Keep tracking horizontally while it descends."""
        if inp.navdata_state == Nav.LANDING and self.state != State.LANDING:
            self._transition(State.LANDING, "navdata reports LANDING: an external land command", inp.time)
            self.committed = True
            self.land_sent_at = inp.time
            return True
        return False

    def _touched_down(self, inp):
        if inp.navdata_state == Nav.LANDED and inp.time - self.entered > 0.0:
            self._transition(State.LANDED, "touchdown: navdata reports LANDED", inp.time)
            return True
        return False

    def _taking_off(self, inp):
        p, t, drone = self.p, inp.time, inp.drone
        if inp.navdata_state == Nav.LANDED or inp.navdata_state is None:
            if t - self.entered > p.takeoff_timeout:
                self._transition(State.LANDED, "take-off not acknowledged within %.1f s" % p.takeoff_timeout, t)
                return
            # A command can be lost (a connection still being set up, a radio link): ask again.
            sent_at = self.entered + p.takeoff_resend_interval * self.takeoff_resends
            if inp.navdata_state == Nav.LANDED and t - sent_at >= p.takeoff_resend_interval:
                self.takeoff_resends += 1
                self._event("take-off not acknowledged within %.1f s: sending it again" % p.takeoff_resend_interval)
                self._out.send_takeoff = True
        elif self._external_landing(inp):
            return self._landing(inp)
        pad = self.last_pad
        fresh = self._fresh(pad, t, p.lost_timeout)
        height = self._height(drone, pad, t)
        self._out.height = height
        xy = self._tracking_xy(t, drone, pad) if fresh else np.zeros(2)
        if fresh:
            self._out.error = float(np.hypot(*self._errors(t, drone, pad)[0]))
        airborne = inp.navdata_state in AIRBORNE_NAV
        if airborne and height >= p.nominal_height - 0.1:
            if fresh:
                self._transition(State.TRACKING, "nominal height %.1f m reached, pad in sight" % p.nominal_height, t)
                return self._tracking(inp)
            self._transition(State.RELOCATING, "nominal height %.1f m reached, no fresh pad prediction"
                             % p.nominal_height, t)
            return self._relocating(inp)
        self._out.command = self._command(xy, p.takeoff_climb_rate, drone.yaw)

    def _tracking(self, inp):
        p, t, drone, pad = self.p, inp.time, inp.drone, self.last_pad
        if self._touched_down(inp) or self._external_landing(inp):
            return self._landing(inp) if self.state == State.LANDING else None
        if not self._fresh(pad, t, p.lost_timeout):
            reason = "no pad prediction" if pad is None else "pad prediction %.1f s old" % pad.age(t)
            self._transition(State.RELOCATING, "target lost: %s" % reason, t)
            return self._relocating(inp)
        error, _ = self._errors(t, drone, pad)
        distance = float(np.hypot(*error))
        self._out.error = distance
        if distance < p.settle_error:
            self.settled_since = t if self.settled_since is None else self.settled_since
        else:
            self.settled_since = None
        settled = self.settled_since is not None and t - self.settled_since >= p.settle_time
        auto = p.auto_land and t - self.tracked_since >= p.min_tracking_time and settled
        if self.land_pending or auto:
            if inp.landing_allowed:
                why = "land requested" if self.land_pending else "tracked %.0f s, error below %.2f m for %.1f s" % (
                    t - self.tracked_since, p.settle_error, p.settle_time)
                self._transition(State.LANDING, why, t)
                return self._landing(inp)
            if not self.refusal_logged:
                self._event("ready to land but landing is not allowed (supervisor); keep tracking")
                self.refusal_logged = True
        height = self._height(drone, pad, t)
        self._out.height = height
        vz = climb_rate_towards(height, p.relocate_height if self._out_of_view(inp) else p.nominal_height, p)
        self._out.command = self._command(self._tracking_xy(t, drone, pad), vz, drone.yaw)

    def _out_of_view(self, inp):
        """Tracking: the pad unseen for search_climb_after (or never): the prediction may be off by more than
        the view (logged once each time)."""
        unseen = self._unseen_for(self.p.search_climb_after)
        if unseen and not self.searching_logged:
            self._event("pad not seen for %s: climbing to %.1f m for a wider view" % (
                "ever" if inp.vision_age is None else "%.1f s" % inp.vision_age, self.p.relocate_height))
        self.searching_logged = unseen
        return unseen

    def _landing(self, inp):
        p, t, drone, pad = self.p, inp.time, inp.drone, self.last_pad
        if self._touched_down(inp):
            return
        if self.land_sent_at is not None:
            return self._final_descent(inp)
        if self._external_landing(inp):
            return self._final_descent(inp)
        if self.committed and pad is not None and pad.age(t) <= p.lost_timeout + 2.0:
            # The last half second: the camera loses the pad this close, the prediction carries on.
            error, relative_velocity = self._errors(t, drone, pad)
            height = self._height(drone, pad, t)
            self._out.error, self._out.height = float(np.hypot(*error)), height
            error_ahead = float(np.hypot(*(error + p.commit_abort_lookahead * relative_velocity)))
            return self._fast_descent(inp, self._out.error, error_ahead, height)
        if not self._fresh(pad, t, p.lost_timeout):
            self._transition(State.RELOCATING, "target lost during the descent", t)
            return self._relocating(inp)
        if not inp.landing_allowed:
            self._transition(State.TRACKING, "landing no longer allowed (supervisor)", t)
            return self._tracking(inp)
        error, relative_velocity = self._errors(t, drone, pad)
        distance, relative_speed = float(np.hypot(*error)), float(np.hypot(*relative_velocity))
        height = self._height(drone, pad, t)
        # Lower down the view is narrower: the error that risks losing the pad from view shrinks with height.
        climb_error = p.hold_max_error + p.hold_error_per_metre * height
        # Higher up the view holds more than abort_error: there the landing is given up only where it would
        # otherwise climb (above 2.9 m, so, it holds its height instead). In harsh, on a square at 3 m/s in wind,
        # each corner aborted a landing at 3.5 m, and each abort cost 13-20 s of settling.
        abort_error = max(p.abort_error, climb_error)
        if distance > abort_error:
            self._transition(State.TRACKING, "error %.2f m > abort_error %.2f m at %.2f m: back to nominal height to "
                             "re-try" % (distance, abort_error, height), t)
            return self._tracking(inp)
        self._out.error, self._out.height = distance, height
        # The prediction coasts through missed frames, but it cannot know that the vehicle brakes or turns
        # meanwhile: low down, only a pad seen right now is good enough to go lower.
        seen = self._seen_within(inp, pad, p.vision_timeout)
        if not seen and not self.blind_since_logged:
            self._event("pad not seen for %s: %s" % (
                "ever" if inp.vision_age is None else "%.2f s" % inp.vision_age,
                "climbing for a wider view" if height < p.retry_height else "holding the height"))
        self.blind_since_logged = not seen
        # A vehicle that brakes stops doing so abruptly (at rest), and a touchdown during that jolt misses:
        # wait while its speed changes faster than gate_max_speed_change (turning is fine), or while the
        # prediction sees that change end before the touchdown (a stop within the final descent). A ramp
        # the drone keeps up with (the Summit XL's 1 m/s^2) passes.
        speed_change = pad.speed_change_at(t)
        descent_time = p.commit_height / p.final_descent_rate
        steady = abs(speed_change) <= p.gate_max_speed_change and \
            abs(pad.speed_change_at(t + descent_time) - speed_change) <= p.gate_max_speed_change_change
        # Where the drone will be over the pad at the touchdown if nothing changes: a drone drifting off the pad
        # at 0.2 m/s (behind a Summit XL's ramp) commits with 0.08 m of error and touches down 0.18 m off.
        error_at_touchdown = float(np.hypot(*(error + relative_velocity * height / p.final_descent_rate)))
        on_target = max(distance, error_at_touchdown) + self._blind_drift(inp, pad) < p.gate_error and \
            relative_speed < p.gate_relative_speed and self._seen_within(inp, pad, p.gate_vision_age)
        in_gate = on_target and steady
        at_gate = height <= p.gate_height + 0.05
        # The touchdown may start from commit_height down, without stopping: already descending, the drone
        # spends less time below the height where the camera loses the pad.
        may_commit = height <= p.commit_height + 0.05
        descend_error = p.descend_max_error + p.descend_error_per_metre * max(0.0, height - p.gate_height)

        if self.retrying:
            if height >= p.retry_height - 0.05:
                self.retrying = False
                self._event("re-try %d: at %.2f m, descending again" % (self.retries, height))
        elif may_commit:
            self.ready_since = (t if self.ready_since is None else self.ready_since) if in_gate else None
            if self.ready_since is not None and t - self.ready_since >= p.gate_ready_time:
                self.committed = True
                self._event("touchdown committed: descending at %.1f m/s (height %.2f m, error %.3f m, relative "
                            "speed %.2f m/s)" % (p.final_descent_rate, height, distance, relative_speed))
                return self._fast_descent(inp, distance, distance, height)
            if at_gate:
                # The gate timeout is for a drone that cannot keep on target, not for waiting out a
                # vehicle's change of speed while it does.
                self.at_gate_since = t if self.at_gate_since is None or (on_target and not steady) \
                    else self.at_gate_since
                if t - self.at_gate_since > p.gate_timeout:
                    self._start_retry("not inside the touchdown gate for %.1f s (error %.2f m, relative speed "
                                      "%.2f m/s)" % (p.gate_timeout, distance, relative_speed), height)
        else:
            self.at_gate_since = self.ready_since = None

        climbing = not self.retrying and seen and distance > climb_error
        if climbing and not self.climbing:
            self._event("error %.2f m > %.2f m at %.2f m: climbing to keep the pad in view" % (
                distance, climb_error, height))
        self.climbing = climbing
        # A hold keeps the lowest height reached since the last deliberate climb. A zero climb rate would leave the
        # height to the firmware's own altitude estimate, whose accelerometer bias let the drone rise 0.1-0.25 m/s
        # in harsh; and a hold that began afresh after each short descent ratcheted it up by what it drifted.
        deliberate_climb = self.retrying or climbing or (not seen and height < p.retry_height)
        self.held_height = None if deliberate_climb else \
            height if self.held_height is None else min(self.held_height, height)
        if deliberate_climb:
            vz = p.retry_climb_rate
        elif not seen:
            vz = self._hold_height(height)
        elif distance <= descend_error and relative_speed <= p.descend_max_relative_speed and not at_gate:
            vz = -p.landing_descent_rate if height > p.gate_height + 0.1 else \
                climb_rate_towards(height, p.gate_height, p, limit=p.landing_descent_rate)
        elif at_gate:
            vz = climb_rate_towards(height, p.gate_height, p, limit=p.landing_descent_rate)
        elif self._in_flow_blend(inp, pad, t):
            # Where the drone's flow half sees the vehicle, its velocity swings with every change of what the
            # camera covers (tilt, position): at a car's speed by metres per second. Holding there only makes
            # the error grow; below, the flow sees the vehicle alone and the drone flies relative to it.
            vz = -p.blend_descent_rate
        else:
            vz = self._hold_height(height)  # outside the descent cone: hold, let the tracking catch up
        self._out.command = self._command(self._tracking_xy(t, drone, pad), vz, drone.yaw)

    def _hold_height(self, height):
        """Climb rate back to the held height."""
        return climb_rate_towards(height, self.held_height, self.p, limit=self.p.landing_descent_rate)

    def _seen_within(self, inp, pad, max_age):
        """The pad seen at most ``max_age`` ago; over a fast vehicle whose texture the drone's flow follows alone
        (weight above blend_weight_high) at most locked_vision_age ago: there the firmware holds the drone on the
        pad by itself, while the camera, tilted into the air stream, loses the pad's centre before the gate."""
        if inp.vision_age is None:
            return False
        locked = inp.flow_weight >= self.p.blend_weight_high and pad is not None and \
            float(np.hypot(*pad.velocity[:2])) >= self.p.blend_min_pad_speed
        return inp.vision_age <= (max(max_age, self.p.locked_vision_age) if locked else max_age)

    def _relative_pad(self, inp):
        """The prediction, placed by the relative track where the drone's flow sees the pad's texture alone (weight
        above blend_weight_high): there its navdata velocity is relative to the pad, whatever the vehicle does."""
        pad, drone = inp.pad, inp.drone
        if inp.relative is None or drone is None or inp.flow_weight < self.p.blend_weight_high:
            return pad
        position, rate = inp.relative
        return pad.moved_to(inp.time, drone.position[:2] + position, drone.velocity[:2] + rate)

    def _blind_drift(self, inp, pad):
        """How far the prediction may have drifted from the pad since it was last seen (beyond gate_vision_age):
        over a fast vehicle a detection up to locked_vision_age old passes the gate, and in harsh the estimate of
        the drone relative to a car at 15 m/s drifted 0.15 m in such a second (one touchdown 0.22 m off)."""
        if inp.vision_age is None:
            return 0.0
        speed = float(np.hypot(*pad.velocity[:2]))
        return self.p.blind_drift_per_speed * speed * max(0.0, inp.vision_age - self.p.gate_vision_age)

    def _in_flow_blend(self, inp, pad, t):
        """The drone's flow follows the vehicle and the ground at once, over a fast vehicle."""
        return self.p.blend_weight_low < inp.flow_weight < self.p.blend_weight_high and \
            float(np.hypot(*pad.velocity[:2])) >= self.p.blend_min_pad_speed

    def _start_retry(self, reason, height, climb=True):
        """A new attempt at the gate: after a climb to retry_height, or (``climb`` False) from where the drone is."""
        self.retrying = climb
        self.committed = False
        self.retries += 1
        self.at_gate_since = self.ready_since = None
        if climb:
            self._event("re-try %d: %s; climbing from %.2f m to %.2f m" % (self.retries, reason, height,
                                                                           self.p.retry_height))
        else:
            self._event("touchdown %d called off: %s; back to the gate at %.2f m" % (self.retries, reason,
                                                                                   self.p.gate_height))

    def _fast_descent(self, inp, distance, distance_ahead, height):
        """Committed: the last few decimetres at final_descent_rate while tracking, so the pad has little
        time to move unseen; ardrone/land at land_height. Until then a growing error still calls it off: the
        error now, or the error commit_abort_lookahead from now at the present relative velocity (a pad that
        starts braking or turning during the descent is already drawing away), and so does the pad unseen
        above blind_height. Called off, the drone waits at the gate (abort_to_gate, the pad in view) or
        climbs to retry_height."""
        p, t = self.p, inp.time
        # The camera loses the pad's centre marker only in the last decimetres; unseen higher up, the pad has
        # left the narrow view (it brakes or turns while the prediction does not know yet).
        unseen = not self._seen_within(inp, self.last_pad, p.gate_vision_age)
        reason = None
        if height < p.commit_abort_min_height:
            pass  # too late to stop above the pad: calling it off would only tilt the drone as it lands
        elif max(distance, distance_ahead) > p.commit_abort_error:
            reason = "error %.2f m (%.2f m in %.2f s) > commit_abort_error %.2f m during the final descent" % (
                distance, distance_ahead, p.commit_abort_lookahead, p.commit_abort_error)
        elif unseen and height > p.blind_height:
            reason = "pad not seen at %.2f m, above blind_height %.2f m, during the final descent" % (
                height, p.blind_height)
        if reason is not None:
            in_view = inp.vision_age is not None and inp.vision_age <= p.vision_timeout  # lost only briefly
            self._start_retry(reason, height, climb=not (p.abort_to_gate and in_view))
            self._out.command = self._command(self._tracking_xy(t, inp.drone, self.last_pad), p.retry_climb_rate,
                                              inp.drone.yaw)
            return
        if height <= p.land_height:
            self._send_land(t)
            self._event("ardrone/land sent at %.2f m (error %.3f m)" % (height, distance))
            return self._final_descent(inp)
        self._out.command = self._command(self._tracking_xy(t, inp.drone, self.last_pad), -p.final_descent_rate,
                                          inp.drone.yaw)

    def _final_descent(self, inp):
        """Land sent: the drone descends by itself; keep the horizontal tracking, from the last
        prediction extrapolated if the camera no longer sees the pad this close."""
        p, t, drone, pad = self.p, inp.time, inp.drone, self.last_pad
        if inp.navdata_state not in (Nav.LANDING, Nav.LANDED) and self.land_sent_at is not None \
                and t - self.land_sent_at > p.land_ack_timeout:
            self._event("land not acknowledged within %.1f s: sending it again" % p.land_ack_timeout)
            self._send_land(t)
        if pad is not None and pad.age(t) <= p.lost_timeout + 2.0:
            xy = self._tracking_xy(t, drone, pad, accumulate=False)
            self._out.error = float(np.hypot(*self._errors(t, drone, pad)[0]))
        else:
            xy = np.zeros(2)
        self._out.command = self._command(xy, 0.0, drone.yaw)

    def _relocating(self, inp):
        p, t, drone, pad = self.p, inp.time, inp.drone, self.last_pad
        if self._touched_down(inp) or self._external_landing(inp):
            return self._landing(inp) if self.state == State.LANDING else None
        if self._fresh(pad, t, p.found_max_age):
            self._transition(State.TRACKING, "pad seen again (prediction %.2f s old)" % pad.age(t), t)
            return self._tracking(inp)
        height = self._height(drone, pad, t)
        self._out.height = height
        vz = climb_rate_towards(height, p.relocate_height, p)
        if pad is None:
            xy = np.zeros(2)  # nothing known: hover in place
        else:
            # Follow the last prediction as far as it reaches, then wait at its end.
            until = min(t, pad.horizon)
            feed = pad.velocity[:2] if t < pad.horizon else np.zeros(2)
            xy = hold_position_command(drone, pad.position_at(until)[:2], p, feed)
        self._out.command = self._command(xy, vz, drone.yaw)

    def _force_landing(self, inp):
        t = inp.time
        if inp.navdata_state == Nav.LANDING:
            self.saw_landing_nav = True
        # LANDED counts once the drone was seen landing (or after the ack time): right after a
        # take-off command the navdata may still say LANDED although the drone is about to lift off.
        if inp.navdata_state == Nav.LANDED and (self.saw_landing_nav or t - self.entered > self.p.land_ack_timeout):
            self._transition(State.LANDED, "forced landing complete: navdata reports LANDED", t)
            return
        if inp.navdata_state not in (Nav.LANDING, Nav.LANDED) and self.land_sent_at is not None \
                and t - self.land_sent_at > self.p.land_ack_timeout:
            self._event("land not acknowledged within %.1f s: sending it again" % self.p.land_ack_timeout)
            self._send_land(t)
        self._out.command = VelocityCommand()  # land where it is: no horizontal motion
