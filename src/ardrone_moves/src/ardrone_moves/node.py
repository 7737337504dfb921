"""ROS wrappers of the manual control core: the joystick, ardrone_joystick and keyboard_teleop nodes.

Topic names are relative; the launch files wire them. Freshness of the stick and key repeat are
measured on the wall clock: they are about a human and a device, not about simulated time.
"""
import sys
import threading
import time

import rospy
from geometry_msgs.msg import Twist
from sensor_msgs.msg import Joy
from std_msgs.msg import Empty, String

from .joystick_device import JoystickReader
from .keyboard import KeyboardConfig, KeyboardTeleop
from .mapping import (EMERGENCY, LAND, MANUAL, TAKEOFF, ConfigError, JoystickConfig, JoystickTeleop, MissingParameter,
                      required)
from .terminal import TerminalKeys

LOOP_PERIOD = 0.05  # [s] wall-clock period of the staleness check
ERROR_REMINDER_PERIOD = 10.0  # [s] an unchanged device error is repeated this often


def _fatal(node, message):
    rospy.logfatal("%s: %s", node, message)
    sys.exit(2)


def _config(node, build, yaml_name):
    """build(private parameters) or logfatal naming the missing/bad parameter, exit 2."""
    try:
        return build(rospy.get_param("~", {}))
    except MissingParameter as err:
        _fatal(node, "required parameter '~%s' is not set (see ardrone_moves/config/%s)" % (err.name, yaml_name))
    except ConfigError as err:
        _fatal(node, "%s (see ardrone_moves/config/%s)" % (err, yaml_name))


def _required(node, name, kind, yaml_name):
    return _config(node, lambda params: required(params, name, kind), yaml_name)


class DroneCommands:
    """The outputs of a manual control, shared by the joystick, the keyboard and the operator UIs (console, web
    station: their ``ardrone/cmd_vel`` is remapped behind cmd_vel_mux in start.launch). ``operator``: the UI's
    own operator/command publisher, else one of its own."""

    def __init__(self, node, operator=None):
        self.node = node
        self.cmd_vel = rospy.Publisher("ardrone/cmd_vel", Twist, queue_size=1)
        self.takeoff = rospy.Publisher("ardrone/takeoff", Empty, queue_size=1)
        self.land = rospy.Publisher("ardrone/land", Empty, queue_size=1)
        self.operator = operator or rospy.Publisher("operator/command", String, queue_size=10)

    def send(self, command):
        msg = Twist()
        msg.linear.x, msg.linear.y, msg.linear.z = command.forward, command.left, command.climb
        msg.angular.z = command.yaw_rate
        self.cmd_vel.publish(msg)

    def act(self, actions):
        for action in actions:
            if action == TAKEOFF:
                self.takeoff.publish(Empty())
            elif action == LAND:
                self.land.publish(Empty())
            elif action in (EMERGENCY, MANUAL):
                self.operator.publish(String(data=action))
            rospy.loginfo("%s: %s", self.node, action)


def joystick_main():
    """Publishes the pad's state on `joy` (sensor_msgs/Joy): on change and every 1/rate_hz s."""
    node = "joystick"
    rospy.init_node(node)
    device = _required(node, "device", str, "joystick.yaml")
    rate_hz = _required(node, "rate_hz", float, "joystick.yaml")
    coalesce = _required(node, "coalesce_interval", float, "joystick.yaml")
    retry_period = _required(node, "retry_period", float, "joystick.yaml")
    if not rate_hz > 0.0:
        _fatal(node, "parameter '~rate_hz' = %g must be > 0" % rate_hz)
    reader = JoystickReader(device, retry_period)
    publisher = rospy.Publisher("joy", Joy, queue_size=1)
    period, last_publish, dirty, was_connected = 1.0 / rate_hz, 0.0, False, False
    logged_error, logged_at = None, 0.0
    rospy.loginfo("%s: reading %s, publishing joy at %.0f Hz", node, device, rate_hz)
    try:
        while not rospy.is_shutdown():
            now = time.monotonic()
            due = last_publish + (coalesce if dirty else period)
            dirty = reader.poll(min(due - now, LOOP_PERIOD)) or dirty
            if not reader.connected:
                dirty, was_connected = False, False
                now = time.monotonic()
                if reader.error != logged_error or now - logged_at > ERROR_REMINDER_PERIOD:
                    rospy.logerr("%s: %s", node, reader.error)  # a new reason at once, an old one now and then
                    logged_error, logged_at = reader.error, now
                continue  # publish nothing: consumers see the stick is gone
            if not was_connected:
                rospy.loginfo("%s: joystick at %s: %d axes, %d buttons", node, device,
                              len(reader.state.axes), len(reader.state.buttons))
                was_connected, logged_error = True, None
            now = time.monotonic()
            if now >= last_publish + (coalesce if dirty else period):
                msg = Joy(axes=reader.state.joy_axes(), buttons=list(reader.state.buttons))
                msg.header.stamp = rospy.Time.now()
                publisher.publish(msg)
                last_publish, dirty = now, False
    finally:
        reader.close()


def ardrone_joystick_main():
    """joy -> ardrone/cmd_vel, ardrone/takeoff, ardrone/land, operator/command (PS4 map of ps4.yaml)."""
    node = "ardrone_joystick"
    rospy.init_node(node)
    teleop = JoystickTeleop(_config(node, JoystickConfig.from_dict, "ps4.yaml"))
    stale_timeout = _required(node, "stale_timeout", float, "ps4.yaml")
    outputs = DroneCommands(node)
    lock = threading.Lock()  # the subscriber thread and the staleness check share the teleop state
    last_joy = [None]

    def on_joy(msg):
        with lock:
            try:
                command, actions = teleop.update(msg.axes, msg.buttons)
            except ConfigError as err:
                rospy.logerr_throttle(5.0, "%s: %s" % (node, err))
                return
            if last_joy[0] is None:
                rospy.loginfo("%s: joy is alive", node)
            last_joy[0] = time.monotonic()
            outputs.act(actions)
            if command is not None:
                outputs.send(command)

    rospy.Subscriber("joy", Joy, on_joy, queue_size=10)
    rospy.loginfo("%s: waiting for joy; hold button %d (dead-man) to fly", node, teleop.config.button_index["deadman"])
    while not rospy.is_shutdown():
        time.sleep(LOOP_PERIOD)
        with lock:
            if last_joy[0] is not None and time.monotonic() - last_joy[0] > stale_timeout:
                last_joy[0] = None
                stop = teleop.lost()
                if stop is not None:
                    outputs.send(stop)
                rospy.logwarn("%s: no joy for %.1f s: the stick is gone%s", node, stale_timeout,
                              "; sent a zero cmd_vel and stopped publishing" if stop is not None else "")


def keyboard_teleop_main():
    """Keys from this terminal (or lines from stdin) -> the same topics as ardrone_joystick."""
    node = "keyboard_teleop"
    rospy.init_node(node)
    teleop = KeyboardTeleop(_config(node, KeyboardConfig.from_dict, "keyboard.yaml"))
    rate_hz = _required(node, "rate_hz", float, "keyboard.yaml")
    if not rate_hz > 0.0:
        _fatal(node, "parameter '~rate_hz' = %g must be > 0" % rate_hz)
    outputs = DroneCommands(node)
    with TerminalKeys(sys.stdin) as keys:
        print(teleop.help(), flush=True)
        print("publishing %s, %s, %s and %s" % tuple(p.resolved_name for p in (
            outputs.cmd_vel, outputs.takeoff, outputs.land, outputs.operator)), flush=True)
        if not keys.is_tty:
            print("stdin is not a terminal: reading keys from it line by line", flush=True)
        next_tick, told_end_of_input = time.monotonic(), False
        while not rospy.is_shutdown():
            for key in keys.read(next_tick - time.monotonic()):
                if key in ("\x03", "\x04"):  # Ctrl-C / Ctrl-D typed as characters
                    rospy.signal_shutdown("quit key")
                    break
                result = teleop.press(key, time.monotonic())
                outputs.act(result.actions)
                if result.message:
                    print(result.message, flush=True)
            if keys.closed and not told_end_of_input:
                print("end of input: no more keys (Ctrl-C to quit)", flush=True)
                told_end_of_input = True
            now = time.monotonic()
            if now >= next_tick:
                command = teleop.tick(now)
                if command is not None:
                    outputs.send(command)
                next_tick = max(next_tick + 1.0 / rate_hz, now)
