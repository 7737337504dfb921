"""Which velocity command reaches the drone, ROS-free (docs/conventions.md, "Command selection").

Inputs: ``manual`` (manual/cmd_vel: keyboard or joystick, sent only while the dead-man is held),
``emergency`` (emergency/cmd_vel) and ``tracking`` (platform_tracking/cmd_vel). The supervisor's mode
says which modules may drive; among those the priority is manual > emergency > tracking, so a live
manual command always wins. An input older than ``timeout_s`` is ignored; with no live input nothing
is forwarded and the drone holds by itself.
"""
INPUTS = ("manual", "emergency", "tracking")
PRIORITY = INPUTS
# supervisor/mode (the words of landing_msgs/SupervisorMode: test_mode_words.py checks them) -> inputs allowed to
# drive. No mode yet (no supervisor in the graph): all of them.
ALLOWED = {
    None: ("manual", "emergency", "tracking"),
    "landing": ("manual", "tracking"),
    "emergency": ("manual", "emergency"),
    "manual": ("manual",),
    "idle": ("manual",),
    "landed": ("manual",),
    "quit": ("manual",),
}


class CommandSelector:
    def __init__(self, timeout_s=0.5):
        if not timeout_s > 0:
            raise ValueError("input timeout must be positive, got %r" % (timeout_s,))
        self.timeout_s = timeout_s
        self.mode = None
        self.latest = {}  # input -> (receipt time, command)

    def set_mode(self, mode):
        """Returns a complaint for an unknown mode (then only manual may drive), else None."""
        if mode in ALLOWED:
            self.mode = mode
            return None
        self.mode = "quit"
        return "unknown supervisor mode %r: only manual/cmd_vel is forwarded" % (mode,)

    def on_input(self, name, t, command):
        if name not in INPUTS:
            raise KeyError("unknown input %r; inputs are %s" % (name, ", ".join(INPUTS)))
        self.latest[name] = (t, command)

    def live(self, name, t):
        entry = self.latest.get(name)
        return entry is not None and 0.0 <= t - entry[0] <= self.timeout_s

    def select(self, t):
        """(input name, command) to forward at sim time ``t``, or None when no allowed input is live."""
        for name in PRIORITY:
            if name in ALLOWED[self.mode] and self.live(name, t):
                return name, self.latest[name][1]
        return None
