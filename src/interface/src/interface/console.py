"""Operator console (replaces the thesis' Tk menus): a live Flight Management panel in the terminal,
commands by key, by stdin line or by argument; every action goes out on operator/command. In Manual
Control the keys fly the drone as ardrone_moves' keyboard teleop does (the terminal is the console's,
so the teleop runs inside it), publishing ardrone/cmd_vel (remapped to manual/cmd_vel in start.launch)."""
import argparse
import json
import math
import os
import select
import sys
import termios
import threading
import time
import tty

from .console_model import MANUAL_CONSOLE_KEYS, PANEL, ConsoleModel, Screen, panel_keys

SENSOR_TOPICS = {"camera": "ardrone/bottom/camera_info", "imu": "ardrone/imu", "odometry": "ardrone/gps/odom",
                 "sonar": "ardrone/sonar_height"}
SENSOR_TIMEOUT_S = 1.0  # a sensor silent for longer (sim time) is shown as missing
SCRIPT_LISTENER_WAIT_S = 30.0  # how long a scripted command waits for the supervisor to listen (wall time) [s]


def _answer_text(warning, sim_time):
    """What the operator must do about a warning: answer before its deadline, or nothing (Flag #2)."""
    options = "/".join(warning.get("options") or [])
    deadline = warning.get("deadline")
    if deadline is None:
        return "the flight goes on" + (" (you may answer %s)" % options if options else "")
    return "answer %s within %.0f s, else emergency landing" % (options, max(0.0, float(deadline) - sim_time))


def render_plain(model, sim_time):
    """The panel as plain text lines (for pipes, logs and tests)."""
    lines = ["== %s ==  t=%.1f s  mode=%s  tracker=%s" % (model.title(), sim_time, model.mode, model.tracker_state)]
    for row in model.rows():
        lines.append("%s %-26s %-28s %s" % ("!" if row.alarm else " ", row.label, row.text, row.note))
    countdown = model.auto_takeoff_in(sim_time)
    if countdown is not None:
        lines.append("auto take-off in %.0f s without a choice" % countdown)
    lines += model.landing_lines()
    if model.warning:
        lines.append("WARNING: %s -> %s" % (model.warning.get("message", ""), _answer_text(model.warning, sim_time)))
    if model.emergency_position is not None:
        lines.append("EMERGENCY: drone at x=%.2f m, y=%.2f m (press a to acknowledge)" % model.emergency_position)
    lines.append("actions: " + " | ".join(model.actions()))
    return lines


def render_rich(model, sim_time):
    from rich.console import Group
    from rich.panel import Panel
    from rich.table import Table
    from rich.text import Text
    table = Table(show_header=False, box=None, expand=True)
    table.add_column(width=28)
    table.add_column(width=30)
    table.add_column()
    for row in model.rows():
        style = "bold white on red" if row.alarm else ""
        table.add_row(row.label, Text(row.text, style=style), Text(row.note, style="yellow"))
    parts = [table]
    countdown = model.auto_takeoff_in(sim_time)
    if countdown is not None:
        parts.append(Text("auto take-off in %.0f s without a choice" % countdown, style="bold cyan"))
    landing = model.landing_lines()
    if landing:
        parts.append(Text(landing[0]))
        if len(landing) > 1:
            parts.append(Text(landing[1], style="bold green" if "successfully" in landing[1] else "bold yellow"))
    if model.warning:
        parts.append(Panel(Text("%s\n%s" % (model.warning.get("message", ""), _answer_text(model.warning, sim_time)),
                                style="bold yellow"), title="WARNING"))
    if model.emergency_position is not None:
        parts.append(Panel(Text("drone coordinates: x = %.2f m, y = %.2f m" % model.emergency_position,
                                style="bold red"), title="Emergency Mode"))
    parts.append(Text("\n".join(model.log[-5:]), style="dim"))
    parts.append(Text("   ".join(model.actions()), style="bold cyan"))
    subtitle = "t = %.1f s   mode: %s   tracker: %s" % (sim_time, model.mode, model.tracker_state or "-")
    return Panel(Group(*parts), title=model.title(), subtitle=subtitle)


class ConsoleNode:
    def __init__(self, model, plain, teleop=None):
        import rospy
        from geometry_msgs.msg import PointStamped
        from landing_msgs.msg import Navdata, PositionXYCommand, PreflightStatus
        from nav_msgs.msg import Odometry
        from sensor_msgs.msg import Range
        from std_msgs.msg import Float64, String
        self.rospy, self.model, self.plain = rospy, model, plain
        self.teleop = teleop  # ardrone_moves KeyboardTeleop for Manual Control, or None
        self.lock = threading.Lock()
        self.last_seen = {}
        # synchronous (no queue): a command is on the wire when publish returns, even if we quit next
        self.publisher = rospy.Publisher("operator/command", String, queue_size=None)
        self.supervisor_heard = threading.Event()  # supervisor/mode (latched) received: the supervisor is up
        self.listeners_given_up = False
        rospy.Subscriber("supervisor/mode", String, self._on_mode)
        rospy.Subscriber("platform_tracking/state", String, lambda m: self._set(tracker_state=m.data))
        rospy.Subscriber("supervisor/decisions", String, self._on_decision)
        rospy.Subscriber("supervisor/warning", String, self._on_warning)
        rospy.Subscriber("emergency/position", PositionXYCommand,
                         lambda m: self._set(emergency_position=(m.x, m.y)))
        rospy.Subscriber("drone/navdata", Navdata, self._on_navdata)
        rospy.Subscriber("preflight/status", PreflightStatus, self._on_preflight)
        # One subscription per topic: rospy shares one per topic and process, and its first message class wins
        # (an AnyMsg one made first handed the height's callback undecoded messages). The sonar's own callback
        # also marks it seen.
        rospy.Subscriber(SENSOR_TOPICS["sonar"], Range, self._on_sonar, queue_size=1)
        for name, topic in SENSOR_TOPICS.items():
            if name != "sonar":
                rospy.Subscriber(topic, rospy.AnyMsg, self._seen(name), queue_size=1)
        rospy.Subscriber("ardrone/odom_estimate", Odometry, self._on_odometry, queue_size=1)
        rospy.Subscriber("supervisor/flight_management", String, self._on_flight_management)
        rospy.Subscriber("platform_tracking/target", PointStamped,
                         lambda m: self._set(target_xy=(m.point.x, m.point.y)), queue_size=1)
        rospy.Subscriber("platform_tracking/camera_latency", Float64, lambda m: self._set(
            camera_latency=m.data if math.isfinite(m.data) and m.data >= 0.0 else None), queue_size=1)
        if teleop is not None:
            from ardrone_moves.node import DroneCommands
            self.drone_commands = DroneCommands("console", self.publisher)

    def _on_preflight(self, msg):
        with self.lock:
            self.model.on_preflight(msg.ready, msg.items)

    def _set(self, **values):
        with self.lock:
            for key, value in values.items():
                setattr(self.model, key, value)

    def _on_mode(self, msg):
        self._set(mode=msg.data)
        self.supervisor_heard.set()

    def _seen(self, name):
        def callback(_):
            self.last_seen[name] = self.rospy.get_time()
        return callback

    def _on_sonar(self, msg):
        self.last_seen["sonar"] = self.rospy.get_time()
        self._set(height=msg.range)

    def _on_decision(self, msg):
        try:
            decision = json.loads(msg.data)
        except ValueError:
            return
        with self.lock:
            self.model.on_decision(decision)

    def _on_warning(self, msg):
        try:
            warning = json.loads(msg.data) if msg.data else None
        except ValueError:
            warning = None
        with self.lock:
            self.model.on_warning(warning)

    def _on_flight_management(self, msg):
        try:
            state = json.loads(msg.data)
        except ValueError:
            return
        with self.lock:
            self.model.on_flight_management(state)

    def _on_navdata(self, msg):
        with self.lock:
            self.model.flight_speed = math.hypot(msg.vx, msg.vy)

    def _on_odometry(self, msg):
        v, p = msg.twist.twist.linear, msg.pose.pose.position
        with self.lock:
            self.model.flight_speed = math.hypot(v.x, v.y)
            self.model.drone_xy = (p.x, p.y)

    def refresh(self):
        """Read the condition parameters (cached, pushed by the master) and the sensor ages."""
        now = self.rospy.get_time()
        with self.lock:
            for key, _, _ in PANEL:
                if key == "sensors":
                    continue
                try:
                    value = self.rospy.get_param_cached("/" + key)
                    self.model.set_value(key, None if value == {} else value)
                except KeyError:
                    self.model.set_value(key, None)
            for name in SENSOR_TOPICS:
                seen = self.last_seen.get(name)
                self.model.set_sensor(name, seen is not None and now - seen <= SENSOR_TIMEOUT_S)
        return now

    def wait_for_listeners(self, timeout_s=SCRIPT_LISTENER_WAIT_S):
        """Wait (wall time) before a scripted command until the supervisor is up (heard on supervisor/mode) and
        every subscriber of operator/command the master lists is connected: sent before, the command would be
        lost (a script's sim-time waits may end before a slow supervisor has subscribed). After timeout_s it
        warns and lets this and every later command go out without waiting."""
        from landing_runtime.rospy_node import unconnected_subscribers
        if self.listeners_given_up:
            return
        deadline = time.monotonic() + timeout_s
        unconnected = None
        while True:
            if self.supervisor_heard.is_set():
                try:
                    unconnected = unconnected_subscribers(self.publisher)
                except Exception:  # master busy or gone: do not block the console on it
                    return
                if not unconnected:
                    return
            if time.monotonic() > deadline:
                break
            time.sleep(0.05)
        self.listeners_given_up = True
        if unconnected is None:
            missing = "nothing on %s in %.0f s: is the supervisor running?" % (
                self.rospy.resolve_name("supervisor/mode"), timeout_s)
        else:
            missing = "%d subscribers of %s not connected after %.0f s." % (
                unconnected, self.publisher.resolved_name, timeout_s)
        self.rospy.logwarn("console: %s Sending the scripted commands anyway, some may be lost.", missing)

    def key(self, key):
        """One key typed in the terminal: in Manual Control the teleop's, else the console's."""
        with self.lock:
            flying = self.teleop is not None and self.model.mode == "manual" and \
                self.model.screen == Screen.FLIGHT_MANAGEMENT and key not in MANUAL_CONSOLE_KEYS
            if flying:
                result = self.teleop.press(key, time.monotonic())
        if not flying:
            return self.command(key)
        self.drone_commands.act(result.actions)
        if result.message:
            with self.lock:
                self.model.note(result.message.strip().splitlines()[0] if key not in ("h", "?") else
                                " ".join(result.message.split()))
        return None

    def fly(self, stop, rate_hz):
        """Publish the teleop's command at ``rate_hz`` (wall clock: it is about a human's keys)."""
        period = 1.0 / rate_hz
        while not stop.is_set() and not self.rospy.is_shutdown():
            with self.lock:
                command = self.teleop.tick(time.monotonic())
            if command is not None:
                self.drone_commands.send(command)
            stop.wait(period)

    def command(self, text):
        from std_msgs.msg import String
        with self.lock:
            command, reply = self.model.handle(text)
        if command:
            self.publisher.publish(String(data=command))
        if reply:
            with self.lock:
                self.model.note(reply)
            if self.plain:
                print(reply, flush=True)
        return command


def _read_keys(on_key, stop):
    """Single keys from a terminal in cbreak mode; the terminal is restored on exit."""
    fd = sys.stdin.fileno()
    saved = termios.tcgetattr(fd)
    try:
        tty.setcbreak(fd)
        while not stop.is_set():
            ready, _, _ = select.select([fd], [], [], 0.2)
            if ready:
                # os.read, not sys.stdin.read(1): keys typed quickly arrive together and the rest
                # would wait in Python's buffer where select() cannot see them
                for key in os.read(fd, 1024).decode(errors="replace"):
                    on_key(key)
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)


def _read_lines(on_line, stop):
    for line in sys.stdin:
        on_line(line)
        if stop.is_set():
            break


def _condition_keys():
    """The supervisor's condition names -> panel rows, from ~conditions_file (config/conditions.yaml)."""
    import rospy
    from .conditions import ConditionTableError, load_table
    path = rospy.get_param("~conditions_file", "")
    if not path:
        return {}
    try:
        return panel_keys(load_table(path))
    except ConditionTableError as err:
        rospy.logwarn("operator console: %s: the panel names the supervisor's conditions as they come" % err)
        return {}


def _keyboard_teleop():
    """ardrone_moves' keyboard teleop from ~keyboard (config/keyboard.yaml), or (None, None) without it."""
    import rospy
    params = rospy.get_param("~keyboard", None)
    if not params:
        return None, None
    from ardrone_moves.keyboard import KeyboardConfig, KeyboardTeleop
    from ardrone_moves.mapping import ConfigError, required
    try:
        return KeyboardTeleop(KeyboardConfig.from_dict(params)), required(params, "rate_hz", float)
    except ConfigError as err:
        rospy.logfatal("operator console: ~keyboard: %s (see ardrone_moves/config/keyboard.yaml)" % err)
        raise SystemExit(2)


def main(argv=None):
    import rospy
    parser = argparse.ArgumentParser(description="Operator console of the landing system.")
    parser.add_argument("--commands", default="", help="commands to run first, separated by ';' "
                        "(e.g. 'start;landing'); 'wait N' waits N sim seconds")
    parser.add_argument("--plain", action="store_true", help="plain text output even on a terminal")
    parser.add_argument("--period", type=float, default=1.0, help="panel refresh period [s]")
    args = parser.parse_args(rospy.myargv(argv if argv is not None else sys.argv)[1:])
    rospy.init_node("operator_console", disable_signals=True)
    interactive = sys.stdin.isatty() and not args.plain
    model = ConsoleModel(ranges=rospy.get_param("~ranges", {}), condition_keys=_condition_keys())
    teleop, teleop_rate = _keyboard_teleop() if interactive else (None, None)
    node = ConsoleNode(model, plain=not interactive, teleop=teleop)
    stop = threading.Event()
    if teleop is not None:
        threading.Thread(target=node.fly, args=(stop, teleop_rate), daemon=True).start()

    def scripted_command(text):  # from --commands or piped lines: nobody watches whether it was heard
        node.wait_for_listeners()
        node.command(text)

    def run_script():
        for item in filter(None, (c.strip() for c in args.commands.split(";"))):
            if item.startswith("wait"):
                end = rospy.get_time() + float(item.split()[1])
                while rospy.get_time() < end and not stop.is_set():
                    time.sleep(0.05)
            else:
                scripted_command(item)
    threading.Thread(target=run_script, daemon=True).start()
    reader = threading.Thread(target=_read_keys if interactive else _read_lines,
                              args=(node.key if interactive else scripted_command, stop), daemon=True)
    if interactive or not os.environ.get("CONSOLE_NO_STDIN"):
        reader.start()
    try:
        if interactive:
            from rich.live import Live
            with Live(render_rich(model, node.refresh()), refresh_per_second=4, screen=True) as live:
                while model.screen != Screen.CLOSED and not rospy.is_shutdown():
                    time.sleep(args.period)
                    sim_time = node.refresh()
                    with node.lock:
                        live.update(render_rich(model, sim_time))
        else:
            last = None
            while model.screen != Screen.CLOSED and not rospy.is_shutdown():
                sim_time = node.refresh()
                with node.lock:
                    lines = render_plain(model, sim_time)
                if lines[1:] != last:  # print on change only, so logs stay readable
                    print("\n".join(lines), flush=True)
                    last = lines[1:]
                time.sleep(args.period)
    except KeyboardInterrupt:
        pass
    stop.set()
    rospy.signal_shutdown("console closed")
    return 0
