"""Operator console state and commands, ROS-free: what the thesis' Start and Flight Management menus
showed (figures 3.1-3.5), as data the terminal view renders and tests inspect."""
import enum
import math

COMMANDS = {  # key -> command published on operator/command (None: handled by the console itself)
    "s": "start", "l": "landing", "m": "manual", "e": "emergency", "c": "continue", "a": "ack",
    "t": "takeoff", "q": "quit", "h": "help",
}
OPERATOR_COMMANDS = ("landing", "manual", "emergency", "continue", "ack", "takeoff", "quit")
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
    __slots__ = ("key", "label", "text", "alarm", "note")

    def __init__(self, key, label, text, alarm, note):
        self.key, self.label, self.text, self.alarm, self.note = key, label, text, alarm, note


class ConsoleModel:
    """Everything the console shows. ``ranges`` maps a condition to (low, high) for local
    highlighting; the supervisor's decisions add the flag and the reason."""

    def __init__(self, ranges=None):
        self.ranges = dict(ranges or {})
        self.screen = Screen.START
        self.values = {}
        self.sensors = {}                  # name -> alive
        self.flight_speed = None           # measured ground speed of the drone [m/s]
        self.mode, self.tracker_state = "idle", None
        self.warning = None                # pending supervisor warning (dict)
        self.emergency_position = None
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
        flag = decision.get("flag")
        self.note("t=%.1f %s%s: %s (%s)" % (
            float(decision.get("t") or 0.0), condition, " [flag #%s]" % flag if flag else "",
            decision.get("action", "?"), decision.get("reason", "")))

    def on_warning(self, warning):
        self.warning = warning if warning and warning.get("id") is not None else None

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
                return None, "Flight Management opened: the drone takes off by itself after 30 s without a choice"
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
                decision = self.last_decision.get("sensors") or self._decision_for_prefix("sensor")
                rows.append(Row(key, label, text, bool(missing), self._describe(decision)))
                continue
            value = self.values.get(key)
            text, alarm = self._format(key, value, unit)
            if key == "drone_speed" and self.flight_speed is not None:
                text += " (flying %.1f m/s)" % self.flight_speed
            decision = self.last_decision.get(key)
            if decision is not None and decision.get("action") in ALARM_ACTIONS:
                alarm = True
            rows.append(Row(key, label, text, alarm, self._describe(decision)))
        return rows

    def _decision_for_prefix(self, prefix):
        for condition, decision in self.last_decision.items():
            if condition.startswith(prefix):
                return decision
        return None

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
        return ["m Manual Mode", "l Landing Mode", "e Emergency Mode", "q Quit"]

    def title(self):
        if self.screen == Screen.START:
            return "Start"
        titles = {"landing": "Landing Mode", "manual": "Manual Control", "emergency": "Emergency Mode"}
        return "Flight Management" + (" - " + titles[self.mode] if self.mode in titles else "")
