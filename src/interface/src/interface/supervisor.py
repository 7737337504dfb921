"""Supervisor of adverse conditions, ROS-free (thesis chapters 2.1-2.3, figure 2.1).

It turns condition readings and operator commands into modes and decisions:

- the flags of the condition table: #1 emergency landing at once; #2 warn and go on; #3 keep
  checking, and after ``recheck_count`` (3) re-checks land on the ground if the condition is still
  there, else go on;
- go/no-go of the landing on the pad, with its reasons; a no-go during the landing mission is a
  warning the operator must answer (manual / emergency / continue) within ``answer_timeout_s``,
  else the drone lands on the ground (thesis 2.1);
- the Flight Management idle for ``idle_takeoff_s`` (30 s) without a choice: take off by itself. With
  ``wait_for_start`` the time counts from the operator's ``start`` (the UI opened Flight Management,
  thesis 3.2.1-3.3.1), else from the first tick (no UI: scenarios, tests);
- the end of the landing mission: on the pad ("Landing performed successfully", thesis figure 3.4) or
  not, judged by ``touchdown_judge`` from the drone's own evidence;
- an unreadable condition value counts as the adverse condition (unknown is unsafe).

Every decision is a record ``{t, condition, flag, action, reason, value}``; every mode change goes
through ``_transition``, which logs ``A -> B (reason)``. The ROS node (supervisor_node) only feeds
readings and commands in and publishes what comes out.
"""
import enum
import math

from .conditions import MISSING, PENDING, evaluate


class Mode(enum.Enum):
    IDLE = "idle"            # on the pad, Flight Management open, no choice yet
    LANDING = "landing"      # the landing mission: take off, track, land on the pad (tracker in charge)
    MANUAL = "manual"        # the operator flies (keyboard / joystick)
    EMERGENCY = "emergency"  # the emergency module lands on the ground and reports the coordinates
    LANDED = "landed"        # mission over, on the ground or on the pad
    QUIT = "quit"            # the operator closed everything


class Flight(enum.Enum):
    UNKNOWN = "unknown"
    LANDED = "landed"        # motors off, on some surface (landed or crashed)
    AIRBORNE = "airborne"    # taking off, flying, hovering or landing


OPERATOR_COMMANDS = ("start", "landing", "takeoff", "manual", "emergency", "continue", "ack", "quit")
WARNING_OPTIONS = ["manual", "emergency", "continue"]
REASON_TEXT = {"weather": "weather", "battery": "battery", "controller_battery": "controller battery",
               "drone_speed": "drone speed", "platform_too_fast": "platform too fast for the drone",
               "target_lost": "target lost", "sensor_missing": "sensor missing"}
# What the tracker is told when a mode starts (platform_tracking/command, latched: a restarted tracker reads the
# last one, so "hold" once the mission is over keeps it from taking off again).
TRACKER_COMMAND = {Mode.LANDING: "takeoff", Mode.MANUAL: "hold", Mode.EMERGENCY: "hold", Mode.LANDED: "hold"}


class SettingsError(ValueError):
    """A supervisor setting is missing or out of range; the message names it."""


class Settings:
    """Timing of the decisions (config/supervisor.yaml)."""

    SPEC = {  # name: (type, lowest, highest)
        "answer_timeout_s": (float, 1.0, 3600.0),
        "idle_takeoff_s": (float, 1.0, 3600.0),
        "recheck_interval_s": (float, 0.1, 600.0),
        "recheck_count": (int, 1, 100),
    }

    def __init__(self, answer_timeout_s=15.0, idle_takeoff_s=30.0, recheck_interval_s=2.0, recheck_count=3,
                 wait_for_start=False):
        self.answer_timeout_s, self.idle_takeoff_s = answer_timeout_s, idle_takeoff_s
        self.recheck_interval_s, self.recheck_count = recheck_interval_s, recheck_count
        self.wait_for_start = wait_for_start  # the idle take-off timer runs from the operator's "start"

    @classmethod
    def from_mapping(cls, values, where="supervisor parameters"):
        """Validated settings; SettingsError names the missing or bad key."""
        checked = {}
        for name, (kind, low, high) in cls.SPEC.items():
            if name not in values:
                raise SettingsError("%s: required parameter '%s' is missing" % (where, name))
            value = values[name]
            if isinstance(value, bool) or not isinstance(value, (int, float)) or \
                    (kind is int and not float(value).is_integer()) or not math.isfinite(value):
                raise SettingsError("%s: parameter '%s' must be %s, got %r"
                                    % (where, name, "an integer" if kind is int else "a number", value))
            if not low <= value <= high:
                raise SettingsError("%s: parameter '%s' = %g is outside %g..%g" % (where, name, value, low, high))
            checked[name] = kind(value)
        if "wait_for_start" not in values:
            raise SettingsError("%s: required parameter 'wait_for_start' is missing" % where)
        if not isinstance(values["wait_for_start"], bool):
            raise SettingsError("%s: parameter 'wait_for_start' must be true or false, got %r"
                                % (where, values["wait_for_start"]))
        checked["wait_for_start"] = values["wait_for_start"]
        return cls(**checked)


class Decision:
    __slots__ = ("t", "condition", "flag", "action", "reason", "value")

    def __init__(self, t, condition, flag, action, reason, value=None):
        self.t, self.condition, self.flag = t, condition, flag
        self.action, self.reason, self.value = action, reason, value

    def as_dict(self):
        return {"t": round(self.t, 3), "condition": self.condition, "flag": self.flag, "action": self.action,
                "reason": self.reason, "value": self.value}

    def __repr__(self):
        return "Decision(%s)" % self.as_dict()


class RowState:
    """What the supervisor remembers about one condition row."""

    __slots__ = ("present", "since", "evaluation", "checks_done", "next_check", "deadline", "acknowledged")

    def __init__(self):
        self.reset()

    def reset(self):
        self.present, self.since, self.evaluation = False, None, None
        self.checks_done, self.next_check = 0, None   # Flag #3 re-checks
        self.deadline = None                          # answer deadline of a no-go during the mission
        self.acknowledged = False                     # the operator chose to go on despite it


def _default_log(level, text):
    import logging
    logging.getLogger("interface.supervisor").log(
        {"info": logging.INFO, "warn": logging.WARNING, "error": logging.ERROR}[level], text)


class Supervisor:
    def __init__(self, table, settings, log=None, touchdown_judge=None):
        """``touchdown_judge(t)`` -> (on the pad: bool, why: str), asked when the landing mission ends."""
        self.table, self.settings = table, settings
        self.log = log or _default_log
        self.touchdown_judge = touchdown_judge
        self.mode = Mode.IDLE
        self.flight = Flight.UNKNOWN
        self.states = {row.name: RowState() for row in table}
        self.landing_allowed = False
        self.warning = {}
        self.emergency_acknowledged = False
        self._airborne_in_mode = False
        self._idle_since = None          # the idle take-off timer runs from here (sim s)
        self._flight_management_open = not settings.wait_for_start
        self._started = False            # the operator's "start" came (the idle timer runs from it)
        self._operator_chose = False
        self._auto_takeoff_announced = False
        self._reported_nogo = None       # row names of the last go/no-go decision of the landing
        self._reported_takeoff_nogo = None
        self._warning_rows, self._warning_id = None, 0
        self._decisions, self._tracker_commands = [], []
        self._waiting_commands = []      # operator commands held until every condition has been read once
        self._conditions_known = False   # a tick has run and no measurement was still pending
        self._resend_tracker_command = False  # restored after a crash: tell the tracker again once the flight is known
        self._restored_acknowledged = set()   # rows the operator had acknowledged before the crash

    # ----- recovery after a crash -----------------------------------------------------------------------
    def snapshot(self):
        """What a restarted supervisor needs to carry on where this one stopped (the node keeps it on the
        parameter server, which outlives the node)."""
        return {"mode": self.mode.value, "emergency_acknowledged": self.emergency_acknowledged,
                "operator_chose": self._operator_chose, "started": self._started,
                "flight_management_open": self._flight_management_open, "idle_since": self._idle_since,
                "auto_takeoff_announced": self._auto_takeoff_announced, "airborne_in_mode": self._airborne_in_mode,
                "acknowledged": sorted(name for name, state in self.states.items()
                                       if state.present and state.acknowledged)}

    def restore(self, t, snapshot):
        """Carry on from the snapshot() of a supervisor that died. The conditions are read afresh: one present
        now is armed again (its re-checks and answer deadline start over) unless the operator had acknowledged
        it. The tracker is told the mode's command again once the flight state is known."""
        self.mode = Mode(snapshot["mode"])
        self.emergency_acknowledged = bool(snapshot["emergency_acknowledged"])
        self._operator_chose, self._started = bool(snapshot["operator_chose"]), bool(snapshot["started"])
        self._flight_management_open = bool(snapshot["flight_management_open"])
        self._idle_since = snapshot["idle_since"]
        self._auto_takeoff_announced = bool(snapshot["auto_takeoff_announced"])
        self._airborne_in_mode = bool(snapshot["airborne_in_mode"])
        self._restored_acknowledged = set(snapshot.get("acknowledged", []))
        self._resend_tracker_command = True
        self._decide(t, "supervisor", None, "recovered", "restarted after a crash: carrying on in mode %s"
                     % self.mode.value, snapshot)

    # ----- outputs ---------------------------------------------------------------------------------
    def take_outputs(self):
        """(decisions, tracker commands) produced since the last call."""
        out = (self._decisions, self._tracker_commands)
        self._decisions, self._tracker_commands = [], []
        return out

    def _decide(self, t, condition, flag, action, reason, value=None):
        decision = Decision(t, condition, flag, action, reason, value)
        self._decisions.append(decision)
        level = "warn" if action in ("emergency_landing", "no_go", "recheck", "warn", "ignored") else "info"
        self.log(level, "t=%.2f %s%s: %s (%s)" % (t, condition, " [flag #%d]" % flag if flag else "", action, reason))
        return decision

    def _decide_row(self, t, state, action, reason):
        evaluation = state.evaluation
        row = evaluation.row
        return self._decide(t, row.name, row.flag, action, reason, evaluation.json_value())

    # ----- the one place where the mode changes ------------------------------------------------------
    def _transition(self, t, new_mode, reason):
        old = self.mode
        if new_mode is old:
            return
        self.log("warn" if new_mode is Mode.EMERGENCY else "info",
                 "supervisor mode: %s -> %s (%s)" % (old.value, new_mode.value, reason))
        self.mode = new_mode
        self._airborne_in_mode = self.flight is Flight.AIRBORNE
        if new_mode is Mode.EMERGENCY:
            self.emergency_acknowledged = False
        if new_mode is Mode.QUIT:
            # Quitting in the air: the tracker lands where it is rather than leaving the drone hovering.
            self._tracker_commands.append("force_land" if self.flight is not Flight.LANDED else "hold")
        elif new_mode in TRACKER_COMMAND:
            self._tracker_commands.append(TRACKER_COMMAND[new_mode])
        if new_mode in (Mode.LANDING, Mode.MANUAL):
            # Conditions already present now matter for the new mode (e.g. a Flag #3 starts its re-checks).
            for row in self.table:
                state = self.states[row.name]
                if state.present and not state.acknowledged:
                    self._arm(t, state)
                    if self.mode is not new_mode:
                        break

    # ----- periodic evaluation -----------------------------------------------------------------------
    def tick(self, t, readings, flight=Flight.UNKNOWN):
        """Evaluate every condition at sim time ``t``. ``readings``: source name -> raw value (the
        parameter as read, or a measurement; MISSING when absent); ``flight``: Flight."""
        if self._idle_since is None and self._flight_management_open:
            self._idle_since = t
        self._tell_tracker_again(flight)
        self._follow_flight(t, flight)
        for row in self.table:
            state = self.states[row.name]
            evaluation = evaluate(row, readings.get(row.source, MISSING))
            was_present = state.present
            if evaluation.present and not was_present:
                state.reset()
                state.present, state.since, state.evaluation = True, t, evaluation
                if row.name in self._restored_acknowledged:
                    state.acknowledged = True  # the operator's answer from before the crash still holds
                else:
                    self._arm(t, state)
            elif was_present and not evaluation.present:
                self._clear(t, state, evaluation)
            elif evaluation.present:
                became_unreadable = evaluation.unreadable and not state.evaluation.unreadable
                state.evaluation = evaluation
                if became_unreadable:  # same occurrence, but the operator must learn the value is unreadable
                    self._decide_row(t, state, "warn", "%s (%s)" % (row.message, evaluation.detail))
                self._follow_up(t, state)
            else:
                state.evaluation = evaluation
        self._restored_acknowledged = set()
        self._conditions_known = not any(raw is PENDING for raw in readings.values())
        if self._conditions_known:
            waiting, self._waiting_commands = self._waiting_commands, []
            for word in waiting:
                self.command(t, word)
        self._auto_takeoff(t)
        self._update_landing_allowed(t)
        self._update_warning()

    def _tell_tracker_again(self, flight):
        """After a restore: the mode's tracker command again (a tracker restarted meanwhile reads it), but no
        take-off for a mission whose drone has already come down (the touchdown is judged next)."""
        if not self._resend_tracker_command or flight is Flight.UNKNOWN:
            return
        self._resend_tracker_command = False
        command = TRACKER_COMMAND.get(self.mode)
        if self.mode is Mode.LANDING and flight is Flight.LANDED and self._airborne_in_mode:
            command = None
        if self.mode is Mode.QUIT:
            command = "hold"
        if command:
            self._tracker_commands.append(command)

    def _arm(self, t, state):
        """React to a condition that is present in the current mode (it just appeared, or the mode changed)."""
        row, detail = state.evaluation.row, state.evaluation.detail
        what = "%s (%s)" % (row.message, detail)
        if self.mode is Mode.LANDING:
            if row.flag == 1:
                self._decide_row(t, state, "emergency_landing", what)
                self._transition(t, Mode.EMERGENCY, "flag #1: %s" % row.name)
                return
            if row.blocks_landing:
                state.deadline = t + self.settings.answer_timeout_s
            if row.flag == 2:
                answer = ", answer within %g s" % self.settings.answer_timeout_s if row.blocks_landing else ""
                self._decide_row(t, state, "warn", what + "; the flight goes on" + answer)
            else:
                state.checks_done, state.next_check = 0, t + self.settings.recheck_interval_s
                self._decide_row(t, state, "recheck", "%s; re-check 1/%d at t=%.1f s" % (
                    what, self.settings.recheck_count, state.next_check))
        elif self.mode is Mode.MANUAL or (self.mode in (Mode.IDLE, Mode.LANDED) and self.flight is Flight.AIRBORNE):
            # A drone in the air lands on a Flag #1 whoever flies it (thesis 2.3: "even if the operator
            # doesn't choose this option"); the rest is the operator's call.
            if row.flag == 1:
                self._decide_row(t, state, "emergency_landing", what)
                self._transition(t, Mode.EMERGENCY, "flag #1: %s" % row.name)
            else:
                self._decide_row(t, state, "warn", what + "; %s: the operator decides" % (
                    "manual control" if self.mode is Mode.MANUAL else "hovering without a mission"))
        elif self.mode in (Mode.IDLE, Mode.LANDED):
            if self._blocks_takeoff(row):
                self._decide_row(t, state, "no_go", what + "; no take-off while it lasts")
            else:
                self._decide_row(t, state, "warn", what)
        elif self.mode is Mode.EMERGENCY:
            self._decide_row(t, state, "warn", what + "; the emergency landing goes on")
        else:
            self._decide_row(t, state, "warn", what + "; the supervisor has quit")

    def _follow_up(self, t, state):
        """A present condition: Flag #3 re-checks and the answer deadline (autonomous flight only)."""
        if self.mode is not Mode.LANDING or state.acknowledged:
            return
        row = state.evaluation.row
        if state.next_check is not None and t >= state.next_check:
            state.checks_done += 1
            count = self.settings.recheck_count
            if state.checks_done >= count:
                state.next_check = None
                self._decide_row(t, state, "emergency_landing", "%s (%s): still present after %d re-checks" % (
                    row.message, state.evaluation.detail, count))
                self._transition(t, Mode.EMERGENCY, "flag #3: %s persists" % row.name)
                return
            state.next_check += self.settings.recheck_interval_s
            self._decide_row(t, state, "recheck", "still present at re-check %d/%d (%s); next at t=%.1f s" % (
                state.checks_done, count, state.evaluation.detail, state.next_check))
        if state.deadline is not None and t >= state.deadline:
            state.deadline = None
            self._decide_row(t, state, "emergency_landing", "%s (%s): no answer to the warning within %g s" % (
                row.message, state.evaluation.detail, self.settings.answer_timeout_s))
            self._transition(t, Mode.EMERGENCY, "warning about %s not answered" % row.name)

    def _clear(self, t, state, evaluation):
        row = evaluation.row
        rechecking = self.mode is Mode.LANDING and state.next_check is not None and not state.acknowledged
        state.evaluation = evaluation
        if rechecking:
            self._decide_row(t, state, "continue", "cleared after %d of %d re-checks (%s): go on" % (
                state.checks_done, self.settings.recheck_count, evaluation.detail))
        else:
            self._decide_row(t, state, "cleared", "no longer present (%s)" % evaluation.detail)
        state.reset()
        state.evaluation = evaluation

    @staticmethod
    def _blocks_takeoff(row):
        # Taking off is pointless when landing back is no-go, or when the flight would soon end on
        # the ground anyway (Flag #1 at once, Flag #3 after its re-checks).
        return row.blocks_landing or row.flag in (1, 3)

    def _present(self, predicate=lambda row, state: True):
        return [(row, self.states[row.name]) for row in self.table
                if self.states[row.name].present and predicate(row, self.states[row.name])]

    @staticmethod
    def _reasons(pairs):
        return "; ".join("%s: %s (%s)" % (REASON_TEXT[row.reason], row.name, state.evaluation.detail)
                         for row, state in pairs)

    # ----- go / no-go of the landing on the pad ---------------------------------------------------------
    def no_go(self):
        """Present conditions that forbid a landing on the pad."""
        return self._present(lambda row, state: row.blocks_landing or row.flag == 1)

    def _update_landing_allowed(self, t):
        blocking = self.no_go()
        self.landing_allowed = self.mode is Mode.LANDING and not blocking
        if self.mode is not Mode.LANDING:
            self._reported_nogo = None
            return
        names = tuple(row.name for row, _ in blocking)
        if names == self._reported_nogo:
            return
        self._reported_nogo = names
        if blocking:
            self._decide(t, "landing", None, "no_go", "landing on the pad not possible: " + self._reasons(blocking),
                         list(names))
        else:
            self._decide(t, "landing", None, "go", "no adverse condition: landing on the pad allowed", [])

    # ----- the warning the operator answers -------------------------------------------------------------
    def _update_warning(self):
        if self.mode not in (Mode.LANDING, Mode.MANUAL):
            self.warning, self._warning_rows = {}, None
            return
        pairs = self._present(lambda row, state: not state.acknowledged)
        if not pairs:
            self.warning, self._warning_rows = {}, None
            return
        names = tuple(row.name for row, _ in pairs)
        if names != self._warning_rows:
            self._warning_rows = names
            self._warning_id += 1
        deadlines = [state.deadline for _, state in pairs if state.deadline is not None]
        deadline = min(deadlines) if deadlines and self.mode is Mode.LANDING else None
        message = "; ".join("%s (%s)" % (row.message, state.evaluation.detail) for row, state in pairs)
        if deadline is not None:
            message += ". Landing on the pad is not possible: answer manual, emergency or continue, " \
                       "else the drone lands on the ground"
        else:
            message += ". The flight goes on"
        self.warning = {"id": self._warning_id, "message": message, "options": list(WARNING_OPTIONS),
                        "deadline": None if deadline is None else round(deadline, 3),
                        "default": "emergency" if deadline is not None else "continue", "conditions": list(names)}

    # ----- take-off -----------------------------------------------------------------------------------
    def flight_management(self):
        """What the operator's Flight Management shows: open yet, and when the drone takes off by itself
        (sim s; None when no auto take-off is pending)."""
        pending = self.mode is Mode.IDLE and not self._operator_chose and self._idle_since is not None
        return {"open": self._flight_management_open,
                "auto_takeoff_at": round(self._idle_since + self.settings.idle_takeoff_s, 3) if pending else None}

    def _auto_takeoff(self, t):
        if self.mode is not Mode.IDLE or self._operator_chose or self._idle_since is None:
            return
        if t - self._idle_since < self.settings.idle_takeoff_s:
            return
        if not self._auto_takeoff_announced:
            self._auto_takeoff_announced = True
            self._decide(t, "idle", None, "takeoff", "no choice in the Flight Management for %g s: taking off by "
                         "itself" % self.settings.idle_takeoff_s)
        self._start_mission(t, "auto take-off after %g s idle" % self.settings.idle_takeoff_s)

    def _start_mission(self, t, why):
        """Take off for the landing mission unless a condition forbids it; returns (started, message)."""
        blockers = self._present(lambda row, state: self._blocks_takeoff(row))
        if blockers:
            names = tuple(row.name for row, _ in blockers)
            message = "take-off refused: " + self._reasons(blockers)
            if names != self._reported_takeoff_nogo:
                self._reported_takeoff_nogo = names
                self._decide(t, "takeoff", None, "no_go", message, list(names))
            return False, message
        self._reported_takeoff_nogo = None
        self._transition(t, Mode.LANDING, why)
        return True, "landing mission started (%s)" % why

    # ----- flight state -----------------------------------------------------------------------------------
    def _follow_flight(self, t, flight):
        self.flight = flight
        if flight is Flight.AIRBORNE:
            self._airborne_in_mode = True
            return
        if flight is not Flight.LANDED:
            return
        if self.mode is Mode.LANDING and self._airborne_in_mode:
            on_pad, why = self.touchdown_judge(t) if self.touchdown_judge else (None, "no evidence of the surface")
            if on_pad:
                reason = "Landing performed successfully: " + why
            else:
                reason = "touchdown: the landing mission is over, %s" % (
                    "not on the pad: " + why if on_pad is False else why)
            self._decide(t, "flight", None, "landed", reason, {"on_pad": on_pad})
            self._transition(t, Mode.LANDED, "touchdown after the landing mission")
        elif self.mode is Mode.EMERGENCY and self.emergency_acknowledged:
            self._transition(t, Mode.LANDED, "emergency landing done and acknowledged")

    # ----- operator ------------------------------------------------------------------------------------
    def _acknowledge_all(self):
        for state in self.states.values():
            if state.present:
                state.acknowledged, state.next_check, state.deadline = True, None, None

    def command(self, t, word):
        """An operator command (operator/command or a Trigger service); returns (accepted, message)."""
        word = (word or "").strip().lower()
        if word not in OPERATOR_COMMANDS:
            message = "unknown operator command %r; expected one of %s" % (word, ", ".join(OPERATOR_COMMANDS))
            self._decide(t, "operator", None, "ignored", message, word)
            return False, message
        if self.mode is Mode.QUIT:
            message = "ignored %r: the supervisor has quit; restart the launch to fly again" % word
            self._decide(t, "operator", None, "ignored", message, word)
            return False, message
        if not self._conditions_known:
            # not everything evaluated yet: a "go" now would ignore a condition that is already there
            self._waiting_commands.append(word)
            return True, "%r waits for the first reading of the conditions" % word
        if self.mode is Mode.IDLE and word not in ("ack", "start"):
            self._operator_chose = True
        accepted, message = getattr(self, "_on_" + word)(t)
        self._update_landing_allowed(t)
        self._update_warning()
        return accepted, message

    def _on_start(self, t):
        if self._started:
            return self._ignored(t, "start", "Flight Management is already open")
        self._started = self._flight_management_open = True
        if self.mode is Mode.IDLE and not self._operator_chose:
            self._idle_since = t
            why = "the drone takes off by itself at t=%.1f s without a choice" % (t + self.settings.idle_takeoff_s)
        else:
            why = "the flight is already under way (mode %s)" % self.mode.value
        self._decide(t, "operator", None, "start", "operator opened the Flight Management: " + why, "start")
        return True, "Flight Management opened: " + why

    def _ignored(self, t, word, why):
        # The message starts with "ignored": the node takes a word repeated soon after as a stuck publisher.
        message = "ignored %r in mode %s: %s" % (word, self.mode.value, why)
        self._decide(t, "operator", None, "ignored", message, word)
        return False, message

    def _on_landing(self, t, word="landing"):
        if self.mode in (Mode.IDLE, Mode.LANDED):
            self._decide(t, "operator", None, "landing", "operator chose the landing mode", word)
            return self._start_mission(t, "operator: %s" % word)
        if self.mode in (Mode.MANUAL, Mode.EMERGENCY):
            self._decide(t, "operator", None, "landing", "operator handed the drone back to the landing mission",
                         word)
            self._transition(t, Mode.LANDING, "operator: %s" % word)
            return True, "back to the landing mission"
        return self._ignored(t, word, "already in the landing mission")

    def _on_takeoff(self, t):
        return self._on_landing(t, "takeoff")

    def _on_manual(self, t):
        if self.mode is Mode.MANUAL:
            return self._ignored(t, "manual", "already in manual control")
        self._acknowledge_all()
        self._decide(t, "operator", None, "manual", "operator took manual control", "manual")
        self._transition(t, Mode.MANUAL, "operator: manual")
        return True, "manual control"

    def _on_emergency(self, t):
        if self.mode is Mode.EMERGENCY:
            return self._ignored(t, "emergency", "the emergency landing is already under way")
        self._acknowledge_all()
        self._decide(t, "operator", None, "emergency_landing", "operator ordered the emergency landing",
                     "emergency")
        self._transition(t, Mode.EMERGENCY, "operator: emergency")
        return True, "emergency landing"

    def _on_continue(self, t):
        if self.mode is Mode.LANDING:
            if not self.warning:
                return self._ignored(t, "continue", "no warning to answer")
            warning_id = self.warning.get("id")
            self._acknowledge_all()
            blocking = self.no_go()
            reason = "operator answered warning %s: continue" % warning_id
            if blocking:
                reason += "; landing on the pad stays no-go while: " + self._reasons(blocking)
            self._decide(t, "operator", None, "continue", reason, "continue")
            return True, reason
        if self.mode in (Mode.MANUAL, Mode.EMERGENCY):
            self._acknowledge_all()
            self._decide(t, "operator", None, "continue", "operator: continue the flight autonomously", "continue")
            self._transition(t, Mode.LANDING, "operator: continue")
            return True, "continuing the landing mission"
        return self._ignored(t, "continue", "nothing to continue; send 'landing' to start the mission")

    def _on_ack(self, t):
        if self.mode is not Mode.EMERGENCY:
            return self._ignored(t, "ack", "no emergency report to acknowledge")
        if self.emergency_acknowledged:
            return self._ignored(t, "ack", "already acknowledged")
        self.emergency_acknowledged = True
        self._decide(t, "operator", None, "ack", "operator acknowledged the emergency report", "ack")
        if self.flight is Flight.LANDED:
            self._transition(t, Mode.LANDED, "emergency landing done and acknowledged")
        return True, "emergency report acknowledged"

    def _on_quit(self, t):
        self._decide(t, "operator", None, "quit", "operator quit", "quit")
        self._transition(t, Mode.QUIT, "operator: quit")
        return True, "quit"
