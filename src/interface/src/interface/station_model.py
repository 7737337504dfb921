"""What the web operator station shows, ROS-free: the console's model (the thesis' menus, condition rows,
warning, emergency report) plus the live picture: the map (drone, vehicle, pad track, Kalman prediction,
emergency position), the plots of the last minute and the decision log.

``translate_*`` turn ROS messages (any object with the same fields) into the plain values the model
takes; the node only subscribes and forwards. ``state()`` is one JSON-ready snapshot for the page,
``history()`` what a page that just connected needs to draw the last minute at once."""
import collections
import math

from .console_model import ConsoleModel
from .station_protocol import CONDITIONS


# ----- message translation ------------------------------------------------------------------------------
def yaw_of(q):
    """Heading [rad] of a geometry_msgs/Quaternion (rotation about z of an ENU pose)."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def translate_odometry(msg):
    """nav_msgs/Odometry -> {x, y, z, yaw, speed} (world frame, speed horizontal [m/s])."""
    p, v = msg.pose.pose.position, msg.twist.twist.linear
    return {"x": p.x, "y": p.y, "z": p.z, "yaw": yaw_of(msg.pose.pose.orientation), "speed": math.hypot(v.x, v.y)}


def translate_path(msg, max_points=60):
    """nav_msgs/Path -> [[x, y], ...], at most ``max_points`` evenly picked (first and last kept)."""
    poses = msg.poses
    if len(poses) > max_points:
        step = (len(poses) - 1) / (max_points - 1)
        poses = [poses[round(i * step)] for i in range(max_points)]
    return [[p.pose.position.x, p.pose.position.y] for p in poses]


def translate_point(msg):
    """geometry_msgs/PointStamped or a PositionXYCommand -> (x, y)."""
    point = getattr(msg, "point", msg)
    return point.x, point.y


def _finite(value):
    return value if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) else None


def _rounded(value, digits=3):
    value = _finite(value)
    return None if value is None else round(value, digits)


def _pose(pose, *keys):
    return None if pose is None else {k: _rounded(pose[k]) for k in keys}


class StationModel:
    def __init__(self, console=None, history_s=60.0, sample_period_s=0.1, trail_period_s=0.2, decisions_kept=200):
        self.console = console or ConsoleModel()
        self.history_s, self.sample_period_s, self.trail_period_s = history_s, sample_period_s, trail_period_s
        self.t = 0.0
        self.drone = self.vehicle = None   # translate_odometry dicts: the drone's own estimate, the vehicle's GPS
        self.pad = None                    # Kalman filter's pad position now (x, y)
        self.prediction = []               # kalman_prediction_path as [[x, y], ...]
        self.altitude = None               # barometric altitude above the ground [m]
        self.emergency_acknowledged = False
        self.decisions = collections.deque(maxlen=decisions_kept)  # (seq, decision)
        self.decision_seq = 0
        self.plot = collections.deque()    # [t, altitude, height, error]
        self.pad_trail = collections.deque()    # [t, x, y]
        self.drone_trail = collections.deque()  # [t, x, y]

    # ----- inputs ------------------------------------------------------------------------------------
    def on_time(self, t):
        if t + 1.0 < self.t:  # the simulation restarted: the minute shown belongs to another flight
            for history in (self.plot, self.pad_trail, self.drone_trail):
                history.clear()
        self.t = t

    def on_drone(self, odometry):
        self.drone = odometry
        self.console.drone_xy = (odometry["x"], odometry["y"])
        self.console.flight_speed = odometry["speed"]

    def on_decision(self, decision):
        self.decision_seq += 1
        self.decisions.append((self.decision_seq, decision))
        self.console.on_decision(decision)
        if decision.get("action") == "ack":
            self.emergency_acknowledged = True
        elif decision.get("action") == "emergency_landing":
            self.emergency_acknowledged = False

    def sample(self):
        """Add the present values to the plots and trails (at their periods) and forget what is older
        than ``history_s``; call it at least as often as ``sample_period_s``."""
        t = self.t
        if not self.plot or t - self.plot[-1][0] >= self.sample_period_s - 1e-9:
            self.plot.append([round(t, 2), _rounded(self.altitude), _rounded(self.console.height),
                              _rounded(self.console.tracking_error())])
        if self.pad is not None and (not self.pad_trail or t - self.pad_trail[-1][0] >= self.trail_period_s - 1e-9):
            self.pad_trail.append([round(t, 2), _rounded(self.pad[0]), _rounded(self.pad[1])])
        if self.drone is not None and (not self.drone_trail or
                                       t - self.drone_trail[-1][0] >= self.trail_period_s - 1e-9):
            self.drone_trail.append([round(t, 2), _rounded(self.drone["x"]), _rounded(self.drone["y"])])
        for history in (self.plot, self.pad_trail, self.drone_trail):
            while history and history[0][0] < t - self.history_s:
                history.popleft()

    # ----- outputs -----------------------------------------------------------------------------------
    def screen(self):
        """Which of the thesis' menus the page shows."""
        mode = self.console.mode
        if mode == "quit":
            return "quit"
        if mode in ("landing", "landed"):
            return "landing"
        if mode in ("manual", "emergency"):
            return mode
        return "flight_management" if self.console.flight_management.get("open") else "start"

    def warning(self):
        """The question the operator must answer, with the time left (None: the flight goes on anyway)."""
        warning = self.console.warning
        if not warning:
            return None
        deadline = warning.get("deadline")
        return {"id": warning.get("id"), "message": warning.get("message", ""),
                "options": list(warning.get("options") or []),
                "time_left": None if deadline is None else round(max(0.0, float(deadline) - self.t), 1)}

    def state(self):
        console = self.console
        emergency = None
        if console.emergency_position is not None:
            emergency = {"x": _rounded(console.emergency_position[0], 2), "y": _rounded(console.emergency_position[1], 2),
                         "acknowledged": self.emergency_acknowledged}
        countdown = console.auto_takeoff_in(self.t) if self.screen() == "flight_management" else None
        return {
            "type": "state", "t": round(self.t, 2), "screen": self.screen(), "mode": console.mode,
            "tracker": console.tracker_state, "rows": [row.as_dict() for row in console.rows()],
            "conditions": {name: _finite(console.values.get(name)) for name in CONDITIONS},
            "countdown": None if countdown is None else round(countdown, 1),
            "warning": self.warning(), "emergency": emergency,
            "landing": {"error": _rounded(console.tracking_error()), "height": _rounded(console.height),
                        "camera_latency": _rounded(console.camera_latency, 3), "result": console.landing_result},
            "drone": _pose(self.drone, "x", "y", "z", "yaw", "speed"),
            "vehicle": _pose(self.vehicle, "x", "y", "yaw"),
            "pad": None if self.pad is None else [_rounded(self.pad[0]), _rounded(self.pad[1])],
            "prediction": [[_rounded(x), _rounded(y)] for x, y in self.prediction],
            "sample": self.plot[-1] if self.plot else None,
            "decision_seq": self.decision_seq,
        }

    def decisions_since(self, seq, limit=50):
        """Decisions newer than ``seq``, oldest first, at most ``limit`` (the newest)."""
        items = [dict(decision, seq=s) for s, decision in self.decisions if s > seq]
        return items[-limit:]

    def history(self):
        return {"type": "history", "plot": list(self.plot), "pad_trail": list(self.pad_trail),
                "drone_trail": list(self.drone_trail), "decisions": self.decisions_since(0),
                "history_s": self.history_s, "conditions": {name: {"low": low, "high": high, "unit": unit,
                                                                    "label": label}
                                                             for name, (low, high, unit, label) in CONDITIONS.items()}}
