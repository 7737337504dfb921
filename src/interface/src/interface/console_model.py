"""Operator console state and commands, ROS-free: what the thesis' Start and Flight Management menus
showed (figures 3.1-3.5), as data the terminal view and the web station render and tests inspect."""
import enum
import math

from landing_msgs.msg import TrackerState

LANDED = TrackerState.LANDED  # the tracker's state on the pad (or wherever it touched down)

COMMANDS = {  # key -> command published on operator/command (None: handled by the console itself)
    "s": "start", "l": "landing", "m": "manual", "e": "emergency", "c": "continue", "a": "ack",
    "t": "takeoff", "q": "quit", "h": "help",
}
OPERATOR_COMMANDS = ("start", "landing", "manual", "emergency", "continue", "ack", "takeoff", "quit")
# In Manual Control the keys fly the drone (ardrone_moves' teleop keys); these capitals stay the console's.
MANUAL_CONSOLE_KEYS = {"C": "continue", "Q": "quit"}
# Panel row of each measured condition of config/conditions.yaml (parameters have their own row).
MEASURE_ROWS = {"camera_silence_s": "sensors", "imu_silence_s": "sensors", "odometry_silence_s": "sensors",
                "sonar_silence_s": "sensors", "platform_speed": "drone_speed"}
PANEL = (  # (key, label, unit) of the Flight Management panel, in the thesis' order
    ("wind_speed", "Wind speed", "m/s"),
    ("drone_speed", "Drone speed", "m/s"),
    ("sensors", "Sensors", ""),
    ("control_battery", "Controller battery charge", "%"),
    ("drone_battery", "Drone battery charge", "%"),
    ("temp", "Temperature", "deg C"),
)
ALARM_ACTIONS = ("warn", "recheck", "no_go", "emergency_landing")


class Screen(enum.Enum):
    START = "Start"
    FLIGHT_MANAGEMENT = "Flight Management"
    CLOSED = "closed"


class Row:
    __slots__ = ("key", "label", "text", "alarm", "note", "flag")

    def __init__(self, key, label, text, alarm, note, flag=None):
        self.key, self.label, self.text, self.alarm, self.note = key, label, text, alarm, note
        self.flag = flag  # the supervisor's flag (1, 2, 3) of a present condition on this row, else None

    def as_dict(self):
        return {name: getattr(self, name) for name in self.__slots__}


def panel_keys(table):
    """Condition name -> panel row key, from a conditions.ConditionTable (rows without a panel row left out)."""
    keys = {}
    panel = {key for key, _, _ in PANEL}
    for row in table:
        key = row.param if row.param is not None else MEASURE_ROWS.get(row.measure)
        if key in panel:
            keys[row.name] = key
    return keys


class ConsoleModel:
    """Everything the console shows. ``ranges`` maps a condition to (low, high) for local
    highlighting; the supervisor's decisions add the flag and the reason."""

    def __init__(self, ranges=None, condition_keys=None):
        """``ranges``: condition -> (low, high) for local highlighting; ``condition_keys``: the supervisor's
        condition names -> panel row (see panel_keys), so its decisions colour the right row."""
        self.ranges = dict(ranges or {})
        self.condition_keys = dict(condition_keys or {})
        self.screen = Screen.START
        self.values = {}
        self.sensors = {}                  # name -> alive
        self.flight_speed = None           # measured ground speed of the drone [m/s]
        self.mode, self.tracker_state = "idle", None
        self.warning = None                # pending supervisor warning (dict)
        self.emergency_position = None
        self.flight_management = {}        # supervisor/flight_management: {"open", "auto_takeoff_at"}
        self.landing_result = None         # the reason of the landing mission's end ("Landing performed ...")
        self.drone_xy = None               # the drone's own position estimate (ardrone/odom_estimate) [m]
        self.target_xy = None              # where the tracker aims (platform_tracking/target) [m]
        self.height = None                 # sonar: feet above the surface below (the pad when over it) [m]
        self.camera_latency = None         # the camera link's delay as the tracker measures it [s]
        self.preflight = None              # (ready, the items' lines) of preflight/status; None: no check runs
        self.last_decision = {}            # condition -> latest decision
        self.log = []                      # recent messages, newest last

    # ----- inputs -----------------------------------------------------------------------------
    def set_value(self, key, value):
        self.values[key] = value

    def set_sensor(self, name, alive):
        self.sensors[name] = alive

    def on_decision(self, decision):
        condition = decision.get("condition") or "general"
        self.last_decision[condition] = decision
        if condition == "flight" and decision.get("action") == "landed":
            self.landing_result = decision.get("reason")
        elif condition == "operator" and decision.get("action") in ("landing", "takeoff", "continue"):
            self.landing_result = None
        flag = decision.get("flag")
        self.note("t=%.1f %s%s: %s (%s)" % (
            float(decision.get("t") or 0.0), condition, " [flag #%s]" % flag if flag else "",
            decision.get("action", "?"), decision.get("reason", "")))

    def on_flight_management(self, state):
        self.flight_management = dict(state or {})
        if self.flight_management.get("open") and self.screen == Screen.START:
            self.screen = Screen.FLIGHT_MANAGEMENT  # opened elsewhere (another operator UI)

    def auto_takeoff_in(self, sim_time):
        """Seconds left until the drone takes off by itself, or None when no auto take-off is pending."""
        at = self.flight_management.get("auto_takeoff_at")
        return None if at is None or self.screen != Screen.FLIGHT_MANAGEMENT else max(0.0, at - sim_time)

    def on_warning(self, warning):
        self.warning = warning if warning and warning.get("id") is not None else None

    def tracking_error(self):
        """Horizontal distance between the drone and the pad position the tracker aims at [m], or None."""
        if self.drone_xy is None or self.target_xy is None or self.mode != "landing":
            return None
        return math.hypot(self.target_xy[0] - self.drone_xy[0], self.target_xy[1] - self.drone_xy[1])

    def landing_lines(self):
        """The Landing menu (thesis figure 3.4): tracker state, error, height, the camera link's delay, then the
        result."""
        if self.mode not in ("landing", "landed"):
            return []
        error, height, delay = self.tracking_error(), self.height, self.camera_latency
        lines = ["tracker %s   error %s   height %s   camera delay %s" % (
            self.tracker_state or "-", "-" if error is None else "%.2f m" % error,
            "-" if height is None else "%.2f m" % height, "-" if delay is None else "%.2f s" % delay)]
        if self.landing_result:
            lines.append(self.landing_result)
        return lines

    def note(self, text):
        self.log.append(text)
        del self.log[:-8]

    # ----- commands ---------------------------------------------------------------------------
    def handle(self, text):
        """Command typed (key or word) -> (command to publish on operator/command or None, reply)."""
        word = text.strip().lower()
        if not word:
            return None, None
        command = COMMANDS.get(word, word)
        if command == "help":
            return None, self.help()
        if command == "start":
            if self.screen == Screen.START:
                self.screen = Screen.FLIGHT_MANAGEMENT
                return "start", "Flight Management opened: without a choice the drone takes off by itself"
            return None, "already started"
        if command not in OPERATOR_COMMANDS:
            return None, "unknown command %r; %s" % (text.strip(), self.help())
        if self.screen == Screen.START and command != "quit":
            return None, "press s (Start) first, or q to quit"
        if command == "quit":
            self.screen = Screen.CLOSED
        if command in ("manual", "emergency", "continue") and self.warning is not None:
            self.note("answered the warning: %s" % command)
        return command, "sent: %s" % command

    @staticmethod
    def help():
        return "keys: " + ", ".join("%s=%s" % (k, v) for k, v in COMMANDS.items())

    # ----- what to show -----------------------------------------------------------------------
    def rows(self):
        rows = []
        for key, label, unit in PANEL:
            if key == "sensors":
                missing = sorted(name for name, alive in self.sensors.items() if not alive)
                text = "unknown" if not self.sensors else ("missing: " + ", ".join(missing) if missing else "available")
                alarm = bool(missing)
            else:
                text, alarm = self._format(key, self.values.get(key), unit)
                if key == "drone_speed" and self.flight_speed is not None and self.tracker_state != LANDED:
                    text += " (flying %.1f m/s)" % self.flight_speed  # (landed on the moving pad, it moves with it)
            decision = self._present_decision(key)
            rows.append(Row(key, label, text, alarm or decision is not None, self._describe(decision),
                            decision.get("flag") if decision else None))
        if self.preflight is not None:
            rows.append(self._preflight_row())
        return rows

    def on_preflight(self, ready, items):
        self.preflight = (bool(ready), list(items))

    def _preflight_row(self):
        """The pre-flight check: ready, or what blocks the take-off and what to do (the first failed item)."""
        ready, items = self.preflight
        failed = [line for line in items if not line.endswith(": ok")]
        if ready:
            return Row("preflight", "Pre-flight check", "ready (%d items)" % len(items), False, "")
        names = ", ".join(line.split(":", 1)[0] for line in failed) or "not ready"
        return Row("preflight", "Pre-flight check", "take-off blocked: " + names, True,
                   failed[0].split(": ", 1)[1] if failed else "", 1)

    def _present_decision(self, key):
        """The supervisor's latest decision on a condition of this row that is still present (the most
        severe first: flag #1, then #3, then #2), or None."""
        present = [d for condition, d in self.last_decision.items()
                   if self.condition_keys.get(condition, condition) == key and d.get("action") in ALARM_ACTIONS]
        severity = {1: 0, 3: 1, 2: 2}
        return min(present, key=lambda d: severity.get(d.get("flag"), 3)) if present else None

    def _format(self, key, value, unit):
        if value is None:
            return "unreadable", True
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            return "%r (unreadable)" % (value,), True
        low, high = self.ranges.get(key, (-math.inf, math.inf))
        text = ("%.1f %s" % (value, unit)).strip()
        return text, not (low <= value <= high)

    @staticmethod
    def _describe(decision):
        if not decision or decision.get("action") not in ALARM_ACTIONS:
            return ""
        flag = decision.get("flag")
        return "%s%s: %s" % ("flag #%s, " % flag if flag else "", decision.get("action"), decision.get("reason", ""))

    def actions(self):
        if self.screen == Screen.START:
            return ["s Start", "q Quit"]
        if self.mode == "emergency":
            return ["m Manual Mode", "c Continue", "a Acknowledge", "q Quit"]
        if self.mode == "manual":
            return ["teleop keys fly (i/,/j/l, t/b up/down, a/d yaw, k stop, T take off, L land, h help)",
                    "C Landing Mode", "E Emergency Mode", "Q Quit"]
        return ["m Manual Mode", "l Landing Mode", "e Emergency Mode", "q Quit"]

    def title(self):
        if self.screen == Screen.START:
            return "Start"
        titles = {"landing": "Landing Mode", "manual": "Manual Control", "emergency": "Emergency Mode"}
        return "Flight Management" + (" - " + titles[self.mode] if self.mode in titles else "")
