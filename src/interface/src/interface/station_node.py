"""station node: the web operator station (thin ROS wrapper of station_model / station_server).

In:  supervisor/{mode,decisions,warning,flight_management}, platform_tracking/{state,target},
     emergency/position, ardrone/odom_estimate (the drone's own estimate), summit_xl/gps/odom (the
     vehicle's report), kalman_platform_odom, kalman_prediction_path, ardrone/sonar_height,
     ardrone/altimeter, the sensor topics (alive or not), the condition parameters (every second, as
     the thesis' Flight Management), and camera (platform_detection/debug_image: the bottom camera with
     the detection drawn), subscribed only while a page is open.
Out: operator/command (std_msgs/String), the condition parameters (as rosparam set), and Manual Control:
     ardrone/cmd_vel (remapped to manual/cmd_vel), ardrone/takeoff, ardrone/land.
Serves http://HOST:PORT/ (~host, ~port); writes the URL to ~url. A non-loopback host needs the token it
prints. Everything it reads is what a real ground station would have: no ground truth. Garbage on an input
(text that is not a JSON object, unknown modes or tracker states) is dropped with a throttled warning; non-finite
numbers are shown as unknown (station_model), never sent to a page.
"""
import asyncio
import json
import threading
import time

import rospy
from ardrone_moves.node import DroneCommands
from geometry_msgs.msg import PointStamped
from landing_runtime.message_constants import message_constants
from landing_runtime.input_check import (MAX_ALTITUDE_M, MAX_POSITION_M, MAX_SPEED_MPS, RosRejectionLog, choice_problem,
                                      first_problem, frame_problem, numbers_problem, stamp_problem)
from landing_msgs.msg import Altimeter, PositionXYCommand, PreflightStatus, SupervisorMode, TrackerState
from landing_runtime.rospy_node import init_node
from nav_msgs.msg import Odometry, Path
from sensor_msgs.msg import Range
from std_msgs.msg import Float64, String

from .conditions import ConditionTableError, load_table
from .console import SENSOR_TOPICS, SENSOR_TIMEOUT_S
from .console_model import PANEL, ConsoleModel, panel_keys
from .station_auth import Access
from .station_manual import ManualControl
from .station_model import StationModel, translate_odometry, translate_path, translate_point
from .station_protocol import CONDITIONS
from .station_server import StationServer

MODES = message_constants(SupervisorMode)
MAX_CAMERA_LATENCY_S = 10.0  # a camera latency beyond this is garbage, not a link [s]
TRACKER_STATES = message_constants(TrackerState)


def _header_problem(msg, frame="world"):
    """A stamp from another time, or (``frame`` not None) a frame other than the world."""
    return first_problem(stamp_problem(msg.header.stamp.to_sec(), rospy.get_time()),
                         frame_problem(msg.header.frame_id, frame) if frame else None)


def _odometry_problem(msg):
    p, v = msg.pose.pose.position, msg.twist.twist.linear
    return _header_problem(msg) or numbers_problem(MAX_POSITION_M, position=(p.x, p.y, p.z)) or \
        numbers_problem(MAX_SPEED_MPS, velocity=(v.x, v.y))


def _strict_json(text):
    """A JSON object from ``text``: ValueError for anything else (NaN and Infinity included: a page cannot read them)."""
    def no_constants(name):
        raise ValueError("%s is not JSON" % name)
    value = json.loads(text, parse_constant=no_constants) if text else {}
    if not isinstance(value, dict):
        raise ValueError("a JSON %s, not an object" % type(value).__name__)
    return value

NODE_PARAMS = {  # private parameter: (type, lowest, highest); config/station.yaml
    "port": (int, 0, 65535),
    "state_rate_hz": (float, 1.0, 60.0),
    "camera_fps": (float, 1.0, 60.0),
    "jpeg_quality": (int, 10, 100),
    "send_timeout_s": (float, 0.5, 60.0),
    "max_clients": (int, 1, 100),
    "manual_rate_hz": (float, 5.0, 100.0),
    "manual_stale_s": (float, 0.1, 5.0),
    "quit_delay_s": (float, 0.0, 10.0),
}


class StartupError(RuntimeError):
    pass


def _params():
    private = rospy.get_param("~", {})
    where = "station (%s, config/station.yaml)" % rospy.get_name()
    values = {}
    for name, (kind, low, high) in NODE_PARAMS.items():
        value = private.get(name)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not low <= value <= high or \
                (kind is int and not float(value).is_integer()):
            raise StartupError("%s: required parameter '~%s' must be %s in %g..%g, got %r"
                               % (where, name, "an integer" if kind is int else "a number", low, high, value))
        values[name] = kind(value)
    for name in ("host", "static_dir", "conditions_file"):
        if not isinstance(private.get(name), str) or not private[name]:
            raise StartupError("%s: required parameter '~%s' (text) is missing" % (where, name))
        values[name] = private[name]
    token = private.get("token", "")
    if not isinstance(token, str) or (token and len(token) < 16):
        raise StartupError("%s: parameter '~token' must be empty (a new token at every start) or a text of at least "
                           "16 characters" % where)
    values["token"] = token or None
    for name, yaml_name in (("keyboard", "keyboard.yaml"), ("ps4", "ps4.yaml")):
        if not isinstance(private.get(name), dict):
            raise StartupError("%s: required parameters '~%s/...' are missing (load ardrone_moves/config/%s)"
                               % (where, name, yaml_name))
        values[name] = private[name]
    return values


class Camera:
    """Latest camera frame as JPEG, encoded at most ``fps`` times a second and only while a page watches.
    The raw message is kept undecoded (rospy.AnyMsg): only the frames that are sent are deserialised."""

    def __init__(self, topic, fps, quality):
        self.topic, self.period, self.quality = topic, 1.0 / fps, quality
        self.lock = threading.Lock()
        self.raw, self.raw_seq, self.encoded_seq = None, 0, 0
        self.jpeg, self.seq = None, 0
        self.subscriber = None
        self.frames_encoded = 0

    def watch(self, watching):
        with self.lock:
            if watching and self.subscriber is None:
                self.subscriber = rospy.Subscriber(self.topic, rospy.AnyMsg, self._on_frame, queue_size=1,
                                                   buff_size=2 ** 20)
            elif not watching and self.subscriber is not None:
                self.subscriber.unregister()
                self.subscriber, self.raw, self.jpeg = None, None, None

    def _on_frame(self, msg):
        with self.lock:
            self.raw, self.raw_seq = msg._buff, self.raw_seq + 1

    def latest(self):
        return self.seq, self.jpeg

    def run(self):
        import cv2
        from cv_bridge import CvBridge
        from sensor_msgs.msg import Image
        bridge = CvBridge()
        while not rospy.is_shutdown():
            started = time.monotonic()
            with self.lock:
                raw, raw_seq = self.raw, self.raw_seq
            if raw is not None and raw_seq != self.encoded_seq:
                self.encoded_seq = raw_seq
                try:
                    image = bridge.imgmsg_to_cv2(Image().deserialize(raw), desired_encoding="bgr8")
                    ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, self.quality])
                except Exception as err:  # a frame cv_bridge cannot read: say so, keep the last good one
                    rospy.logwarn_throttle(10.0, "station: camera frame not shown: %s" % err)
                    ok = False
                if ok:
                    self.jpeg, self.seq = data.tobytes(), self.seq + 1
                    self.frames_encoded += 1
            time.sleep(max(0.0, self.period - (time.monotonic() - started)))


class StationNode:
    def __init__(self):
        self.params = p = _params()
        try:
            keys = panel_keys(load_table(p["conditions_file"]))
        except ConditionTableError as err:
            raise StartupError("station: %s" % err)
        from ardrone_moves.keyboard import KeyboardConfig
        from ardrone_moves.mapping import ConfigError, JoystickConfig
        try:
            self.keyboard_config = KeyboardConfig.from_dict(p["keyboard"])
            self.joystick_config = JoystickConfig.from_dict(p["ps4"])
        except ConfigError as err:
            raise StartupError("station: %s (see ardrone_moves/config/keyboard.yaml and ps4.yaml)" % err)
        self.lock = threading.Lock()
        self.model = StationModel(ConsoleModel(condition_keys=keys))
        self.last_seen = {}
        self.controls = {}   # page id -> ManualControl
        self.camera = Camera("camera", p["camera_fps"], p["jpeg_quality"])
        self.operator = rospy.Publisher("operator/command", String, queue_size=10)
        self.outputs = DroneCommands("station", self.operator)
        self.loop, self.stopping = None, None

        def setter(**fields):
            def callback(msg):
                with self.lock:
                    for name, convert in fields.items():
                        setattr(self.model.console, name, convert(msg))
            return callback

        self.rejections = RosRejectionLog()

        def word(topic, allowed, what, update):
            def callback(msg):
                problem = choice_problem(msg.data, allowed, what)
                if problem:
                    return self.rejections.reject(topic, problem)
                update(msg)
            return callback

        sub = rospy.Subscriber
        sub("supervisor/mode", String, word("supervisor/mode", MODES, "mode", setter(mode=lambda m: m.data)))
        sub("supervisor/decisions", String, self._json("supervisor/decisions", self.model.on_decision), queue_size=100)
        sub("supervisor/warning", String, self._json("supervisor/warning", self.model.console.on_warning))
        sub("preflight/status", PreflightStatus, self._checked(
            "preflight/status", lambda m: _header_problem(m, frame=("",)),
            lambda m: self.model.console.on_preflight(m.ready, m.items)))
        sub("supervisor/flight_management", String, self._json("supervisor/flight_management",
                                                                self.model.console.on_flight_management))
        sub("platform_tracking/state", String, word("platform_tracking/state", TRACKER_STATES, "tracker state",
                                                    setter(tracker_state=lambda m: m.data)))
        checked = self._checked
        sub("platform_tracking/target", PointStamped, checked(
            "platform_tracking/target", lambda m: _header_problem(m) or numbers_problem(
                MAX_POSITION_M, point=(m.point.x, m.point.y)), setter(target_xy=translate_point)), queue_size=1)
        sub("platform_tracking/camera_latency", Float64, checked(
            "platform_tracking/camera_latency", lambda m: numbers_problem(MAX_CAMERA_LATENCY_S, latency=m.data) or (
                ("out of range", "latency is %s s" % m.data) if m.data < 0.0 else None),
            setter(camera_latency=lambda m: m.data)), queue_size=1)
        sub("emergency/position", PositionXYCommand, checked(
            "emergency/position", lambda m: numbers_problem(MAX_POSITION_M, position=(m.x, m.y)),
            setter(emergency_position=translate_point)), queue_size=1)
        sub("ardrone/sonar_height", Range, checked(
            "ardrone/sonar_height", lambda m: _header_problem(m, None) or (
                ("out of range", "range is %s" % m.range) if not m.range >= 0.0 else None),  # +inf: no echo
            setter(height=lambda m: m.range)), queue_size=1)
        sub("ardrone/altimeter", Altimeter, checked(
            "ardrone/altimeter", lambda m: _header_problem(m, None) or numbers_problem(MAX_ALTITUDE_M, altitude=m.altitude),
            self._locked(lambda m: setattr(self.model, "altitude", m.altitude))), queue_size=1)
        sub("ardrone/odom_estimate", Odometry, checked(
            "ardrone/odom_estimate", _odometry_problem,
            self._locked(lambda m: self.model.on_drone(translate_odometry(m)))), queue_size=1)
        sub("summit_xl/gps/odom", Odometry, checked(
            "summit_xl/gps/odom", _odometry_problem,
            self._locked(lambda m: setattr(self.model, "vehicle", translate_odometry(m)))), queue_size=1)
        sub("kalman_platform_odom", Odometry, checked(
            "kalman_platform_odom", _odometry_problem,
            self._locked(lambda m: setattr(self.model, "pad", translate_point(m.pose.pose.position)))), queue_size=1)
        sub("kalman_prediction_path", Path, checked(
            "kalman_prediction_path", lambda m: _header_problem(m) or numbers_problem(
                MAX_POSITION_M, position=[c for p in m.poses for c in (p.pose.position.x, p.pose.position.y)]),
            self._locked(lambda m: setattr(self.model, "prediction", translate_path(m)))), queue_size=1)
        for name, topic in SENSOR_TOPICS.items():
            sub(topic, rospy.AnyMsg, self._seen(name), queue_size=1)

    # ----- inputs ------------------------------------------------------------------------------------
    def _locked(self, update):
        def callback(msg):
            with self.lock:
                update(msg)
        return callback

    def _checked(self, topic, problem_of, callback):
        """A subscriber callback that drops a message ``problem_of`` finds fault with, else runs ``callback``."""
        def checked(msg):
            problem = problem_of(msg)
            if problem:
                return self.rejections.reject(topic, problem)
            callback(msg)
        return checked

    def _json(self, topic, update):
        def callback(msg):
            try:
                value = _strict_json(msg.data)
            except ValueError as err:
                return self.rejections.reject(topic, ("malformed", "%s: %r" % (err, msg.data[:80])))
            with self.lock:
                update(value)
        return callback

    def _seen(self, name):
        def callback(_):
            self.last_seen[name] = rospy.get_time()
        return callback

    def refresh_conditions(self):
        """The condition parameters and sensor ages, every second (thesis: refreshlabel)."""
        now = rospy.get_time()
        names = sorted(set(CONDITIONS) | {key for key, _, _ in PANEL if key != "sensors"})
        values = {}
        for name in names:
            try:
                value = rospy.get_param_cached("/" + name)
                values[name] = None if value == {} else value
            except KeyError:
                values[name] = None
        with self.lock:
            self.model.on_time(now)
            for name, value in values.items():
                self.model.console.set_value(name, value)
            for name in SENSOR_TOPICS:
                seen = self.last_seen.get(name)
                self.model.console.set_sensor(name, seen is not None and now - seen <= SENSOR_TIMEOUT_S)

    # ----- actions of the pages (called in the server's event loop) ------------------------------------
    def command(self, name):
        self.operator.publish(String(data=name))
        if name == "quit":  # thesis: Quit closes the menus and ends every process of the launch
            threading.Timer(self.params["quit_delay_s"], rospy.signal_shutdown, args=("operator quit",)).start()
            return True, "sent: quit; the station and the launch stop"
        return True, "sent: %s" % name

    def set_condition(self, name, value):
        rospy.set_param("/" + name, value)
        self.refresh_conditions()
        return True, "/%s = %g (as rosparam set)" % (name, value)

    def manual(self, client, message):
        now = time.monotonic()
        with self.lock:
            control = self.controls.get(client)
            if control is None:
                control = self.controls[client] = ManualControl(self.keyboard_config, self.joystick_config,
                                                                self.params["manual_stale_s"])
            if message["type"] == "key":
                actions, text = control.key(message["key"], now)
                command = None
            else:
                command, actions = control.joy(message["axes"], message["buttons"], now)
                text = None
        self.outputs.act(actions)
        if command is not None:
            self.outputs.send(command)
        return True, (text.strip() if text else ("sent: %s" % ", ".join(actions) if actions else None))

    def client_closed(self, client):
        with self.lock:
            control = self.controls.pop(client, None)
            stops = control.close(time.monotonic()) if control is not None else []
        for stop in stops:
            self.outputs.send(stop)

    def watchers(self, count):
        self.camera.watch(count > 0)

    def fly(self):
        """Keyboard commands while a key is held, and a stop for a pad that fell silent (wall clock)."""
        period = 1.0 / self.params["manual_rate_hz"]
        while not rospy.is_shutdown():
            now = time.monotonic()
            with self.lock:
                commands = [c for control in self.controls.values() for c in control.tick(now)]
            for command in commands:
                self.outputs.send(command)
            time.sleep(period)

    def poll_conditions(self):
        while not rospy.is_shutdown():
            self.refresh_conditions()
            time.sleep(1.0)

    # ----- server ---------------------------------------------------------------------------------------------
    async def serve(self):
        p = self.params
        access = Access(p["host"], token=p["token"])
        server = StationServer(self.model, self.lock, self, access, p["static_dir"], camera=self.camera,
                               rate_hz=p["state_rate_hz"], send_timeout_s=p["send_timeout_s"],
                               max_clients=p["max_clients"], clock=rospy.get_time)
        self.loop, self.stopping = asyncio.get_running_loop(), asyncio.Event()
        rospy.core.add_shutdown_hook(lambda _reason: self.loop.call_soon_threadsafe(self.stopping.set))
        try:
            addresses = await server.start(p["host"], p["port"])
        except OSError as err:
            raise StartupError("station: cannot listen on %s:%d (%s); choose another with port:=N"
                               % (p["host"], p["port"], err))
        host, port = addresses[0][:2]
        shown_host = "[%s]" % host if ":" in host else host
        url = "http://%s:%d/" % ("127.0.0.1" if host in ("0.0.0.0", "::") else shown_host, port)
        rospy.set_param("~url", url)
        if access.token:
            rospy.set_param("~token_required", True)
            message = ("operator station: %s?token=%s  (listening on %s: every request needs this token, as "
                       "?token= or the X-Station-Token header)" % (url, access.token, p["host"]))
        else:
            message = "operator station: %s  (loopback only)" % url
        print(message, flush=True)  # the token goes to this terminal only, not to /rosout
        rospy.loginfo("operator station: %s%s" % (url, " (token printed on the screen)" if access.token else ""))
        for target in (self.camera.run, self.fly, self.poll_conditions):
            threading.Thread(target=target, daemon=True).start()
        await self.stopping.wait()
        await server.stop()


def main():
    init_node("station")
    try:
        node = StationNode()
        asyncio.run(node.serve())
    except StartupError as err:
        rospy.logfatal(str(err))
        return 2
    return 0
