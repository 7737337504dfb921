"""The operator console driven as a person would: keys through a pseudo-terminal, and as a script would:
--commands with no terminal; both against a real roscore, checked on operator/command."""
import functools
import os
import pty
import signal
import socket
import subprocess
import sys

import pytest
from landing_runtime import testing

pytestmark = pytest.mark.slow  # a ROS master, a terminal or minutes: make test, not make check

HERE = os.path.dirname(os.path.abspath(__file__))
PACKAGE = os.path.dirname(HERE)
CONSOLE = os.path.join(PACKAGE, "scripts", "console")
TIMEOUT = 60.0  # [s] generous: Python + rospy start slowly on a loaded 2-core machine


def free_port():
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


wait_for = functools.partial(testing.wait_for, timeout=TIMEOUT)


def stop(process):
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGINT)
        try:
            process.wait(timeout=TIMEOUT)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()


class Lines:
    """Non-blocking reader of a file descriptor into one growing text."""

    def __init__(self, fd):
        self.fd, self.text = fd, ""
        os.set_blocking(fd, False)

    def read(self):
        try:
            while True:
                chunk = os.read(self.fd, 65536)
                if not chunk:
                    break
                self.text += chunk.decode(errors="replace")
        except (BlockingIOError, OSError):
            pass
        return self.text


@pytest.fixture(scope="module")
def ros_env(tmp_path_factory):
    logs = tmp_path_factory.mktemp("ros")
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI="http://127.0.0.1:%d" % port, ROS_HOSTNAME="127.0.0.1",
               ROS_LOG_DIR=str(logs), PYTHONPATH=os.pathsep.join(
                   [os.path.join(PACKAGE, "src")] + [p for p in [os.environ.get("PYTHONPATH")] if p]))
    env.pop("ROS_IP", None)
    core = subprocess.Popen(["roscore", "-p", str(port)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL, start_new_session=True)
    try:
        import rosgraph
        master = rosgraph.Master("/console_test", master_uri=env["ROS_MASTER_URI"])

        def up():
            try:
                return master.getPid() > 0
            except Exception:  # not listening yet
                return False
        wait_for(up, "roscore on port %d" % port)
        yield env
    finally:
        stop(core)


# A supervisor stand-in: its latched mode tells a console script that the supervisor is up (console.py
# wait_for_listeners), and what reaches operator/command is printed, one line per command. A typed subscriber:
# rostopic echo would wait for a publisher to learn the type, and miss the first ones.
COMMAND_LISTENER = """
import rospy
from std_msgs.msg import String
rospy.init_node("command_listener", anonymous=True)
rospy.Subscriber("/operator/command", String, lambda m: print(m.data, flush=True))
mode = rospy.Publisher("/supervisor/mode", String, queue_size=1, latch=True)
mode.publish(String(data="idle"))
rospy.spin()
"""


def start_command_listener(ros_env):
    """The stand-in's process and a reader of what it printed."""
    echo = subprocess.Popen([sys.executable, "-c", COMMAND_LISTENER], env=ros_env, stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL, start_new_session=True)
    return echo, Lines(echo.stdout.fileno())


@pytest.fixture
def operator_commands(ros_env):
    """What reaches operator/command, one line per command."""
    echo, reader = start_command_listener(ros_env)
    yield reader
    stop(echo)


@pytest.mark.needs_pty
def test_keys_in_a_terminal_open_flight_management_and_choose_the_landing_mode(ros_env, operator_commands):
    master, slave = pty.openpty()
    env = dict(ros_env, TERM="xterm-256color", COLUMNS="120", LINES="40")
    console = subprocess.Popen([sys.executable, CONSOLE], env=env, stdin=slave, stdout=slave, stderr=slave,
                               start_new_session=True)
    os.close(slave)
    screen = Lines(master)
    try:
        wait_for(lambda: "Start" in screen.read() and "Quit" in screen.text, "the Start menu on the terminal")
        os.write(master, b"l")
        wait_for(lambda: "press s (Start) first" in screen.read(), "the console to ask for Start first")
        os.write(master, b"s")
        wait_for(lambda: "Flight Management" in screen.read(), "the Flight Management panel")
        wait_for(lambda: "Drone battery charge" in screen.read(), "the condition rows")
        # the listener may still be connecting: repeat the key until it hears one
        wait_for(lambda: (os.write(master, b"l"), screen.read(), "landing" in operator_commands.read())[2],
                 "operator/command landing after the key l")
        os.write(master, b"lq")  # typed quickly: both keys arrive in one read
        # keep draining the terminal: a full pty buffer would block the console's last redraw
        wait_for(lambda: (screen.read(), console.poll() is not None)[1], "the console to close on q")
        assert console.returncode == 0
        wait_for(lambda: "quit" in operator_commands.read(), "operator/command quit after the key q")
    finally:
        stop(console)
        os.close(master)


def test_commands_as_arguments_without_a_terminal(ros_env, operator_commands):
    wait_for(lambda: subprocess.run(["rostopic", "info", "/operator/command"], env=ros_env,
                                    capture_output=True, text=True).stdout.count("command_listener") > 0,
             "the listener to subscribe")
    result = subprocess.run([sys.executable, CONSOLE, "--plain", "--commands", "start;emergency;dance;quit"],
                            env=dict(ros_env, CONSOLE_NO_STDIN="1"), stdin=subprocess.DEVNULL, capture_output=True,
                            text=True, timeout=TIMEOUT)
    assert result.returncode == 0, result.stderr
    assert "unknown command 'dance'" in result.stdout
    wait_for(lambda: "emergency" in operator_commands.read() and "quit" in operator_commands.text,
             "emergency and quit on operator/command")
    assert "dance" not in operator_commands.text


def test_scripted_commands_wait_for_a_supervisor_that_starts_later(ros_env):
    """Sent before the supervisor has subscribed, a scripted command was lost (the flight_management_timer rostest
    timed out waiting for its Start when the supervisor came up late): the console now waits for it."""
    console = subprocess.Popen([sys.executable, CONSOLE, "--plain", "--commands", "start;quit"],
                               env=dict(ros_env, CONSOLE_NO_STDIN="1"), stdin=subprocess.DEVNULL,
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, start_new_session=True)
    echo = None
    try:
        screen = Lines(console.stdout.fileno())
        wait_for(lambda: "actions:" in screen.read(), "the console's panel, with no supervisor yet")
        echo, commands = start_command_listener(ros_env)
        wait_for(lambda: (screen.read(), console.poll() is not None)[1], "the console to quit once heard")
        assert console.returncode == 0, screen.text[-2000:]
        wait_for(lambda: "quit" in commands.read(), "operator/command quit")
        assert commands.text.split() == ["start", "quit"]
    finally:
        stop(console)
        if echo is not None:
            stop(echo)


# The supervisor in the landing mode (latched) and the sonar at 20 Hz (wall time: no /use_sim_time here).
LANDING_AND_SONAR = """
import rospy
from sensor_msgs.msg import Range
from std_msgs.msg import String
rospy.init_node("landing_and_sonar")
mode = rospy.Publisher("/supervisor/mode", String, queue_size=1, latch=True)
mode.publish(String(data="landing"))
sonar = rospy.Publisher("/ardrone/sonar_height", Range, queue_size=1)
rate = rospy.Rate(20)
while not rospy.is_shutdown():
    sonar.publish(Range(range=1.23))
    rate.sleep()
"""


def test_the_landing_menu_shows_the_sonar_height_and_the_sonar_as_seen(ros_env):
    """The console watches the sonar's arrival and shows its height. Both once subscribed the same topic, the
    watch (AnyMsg) first: rospy shares one subscription per topic and process, so the height's callback got
    undecoded messages and failed on each one (a 'bad callback' traceback 25 times a second)."""
    talker = subprocess.Popen([sys.executable, "-c", LANDING_AND_SONAR], env=ros_env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL, start_new_session=True)
    try:
        result = subprocess.run([sys.executable, CONSOLE, "--plain", "--commands", "wait 4;quit"],
                                env=dict(ros_env, CONSOLE_NO_STDIN="1"), stdin=subprocess.DEVNULL,
                                capture_output=True, text=True, timeout=TIMEOUT)
    finally:
        stop(talker)
    assert result.returncode == 0, result.stderr
    assert "height 1.23 m" in result.stdout, result.stdout[-2000:]
    assert "bad callback" not in result.stdout + result.stderr, (result.stdout + result.stderr)[-2000:]


@pytest.mark.needs_pty
def test_manual_control_keys_fly_the_drone_as_the_teleop(ros_env):
    """start.launch's Manual Control by keyboard: with the teleop's parameters (~keyboard) and the supervisor in
    manual mode, the console's keys become ardrone/cmd_vel (remapped to manual/cmd_vel there)."""
    import yaml
    with open(os.path.join(PACKAGE, "..", "ardrone_moves", "config", "keyboard.yaml")) as stream:
        keyboard = yaml.safe_load(stream)
    subprocess.run(["rosparam", "set", "/operator_console/keyboard", yaml.safe_dump(keyboard, default_flow_style=True)],
                   env=ros_env, check=True, timeout=TIMEOUT)
    # a stand-in for the supervisor (latched mode: manual) and a listener of the velocity commands
    script = ("import rospy; from std_msgs.msg import String; from geometry_msgs.msg import Twist; "
              "rospy.init_node('manual_stand_in', anonymous=True); "
              "mode = rospy.Publisher('/supervisor/mode', String, queue_size=1, latch=True); "
              "mode.publish(String(data='manual')); "
              "rospy.Subscriber('/ardrone/cmd_vel', Twist, lambda m: print('cmd %.2f %.2f' % (m.linear.x, m.linear.y), "
              "flush=True)); rospy.spin()")
    stand_in = subprocess.Popen([sys.executable, "-c", script], env=ros_env, stdout=subprocess.PIPE,
                                stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL, start_new_session=True)
    heard = Lines(stand_in.stdout.fileno())
    master, slave = pty.openpty()
    env = dict(ros_env, TERM="xterm-256color", COLUMNS="120", LINES="40")
    console = subprocess.Popen([sys.executable, CONSOLE], env=env, stdin=slave, stdout=slave, stderr=slave,
                               start_new_session=True)
    os.close(slave)
    screen = Lines(master)
    try:
        wait_for(lambda: "Start" in screen.read() and "Quit" in screen.text, "the Start menu on the terminal")
        wait_for(lambda: (os.write(master, b"s"), "Manual Control" in screen.read() and "teleop keys fly" in screen.text)[1],
                 "the Manual Control menu with the teleop keys after s (Start)")
        # hold i (forward) as a terminal's key repeat would, until the listener hears it
        wait_for(lambda: (os.write(master, b"i"), screen.read(), "cmd 0.50 0.00" in heard.read())[2],
                 "ardrone/cmd_vel forward 0.5 m/s after the key i")
        wait_for(lambda: (screen.read(), "cmd 0.00 0.00" in heard.read())[1], "the stop once the key is released")
        os.write(master, b"Q")
        wait_for(lambda: (screen.read(), console.poll() is not None)[1], "the console to close on Q")
    finally:
        stop(console)
        stop(stand_in)
        os.close(master)
