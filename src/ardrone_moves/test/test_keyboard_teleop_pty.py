"""keyboard_teleop driven through a pseudo-terminal (and through a pipe) against a real roscore.

The node runs from the source tree with the parameters of config/keyboard.yaml; a probe process
(topic_probe.py) reports what it publishes. Every wait is on a condition with a generous timeout."""
import functools
import json
import os
import signal
import socket
import subprocess
import sys
import termios
import threading
import time

import pytest
from landing_runtime import testing

pytestmark = pytest.mark.slow  # a ROS master, a terminal or minutes: make test, not make check

HERE = os.path.dirname(os.path.abspath(__file__))
PACKAGE = os.path.dirname(HERE)
TIMEOUT = 60.0  # [s] generous: a loaded 2-core machine starts Python + rospy slowly
SPEED = 0.5     # config/keyboard.yaml initial speed [m/s]


def free_port():
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


wait_for = functools.partial(testing.wait_for, timeout=TIMEOUT)


def stop(process, sig=signal.SIGINT):
    if process.poll() is None:
        os.killpg(process.pid, sig)
        try:
            process.wait(timeout=TIMEOUT)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()


@pytest.fixture(scope="module")
def ros_env(tmp_path_factory):
    """A roscore of our own on a free port; the environment that reaches it."""
    logs = tmp_path_factory.mktemp("ros")
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI="http://127.0.0.1:%d" % port, ROS_HOSTNAME="127.0.0.1",
               ROS_LOG_DIR=str(logs), PYTHONPATH=os.pathsep.join(
                   [os.path.join(PACKAGE, "src")] + [p for p in [os.environ.get("PYTHONPATH")] if p]))
    env.pop("ROS_IP", None)
    with open(logs / "roscore.log", "w") as log:
        core = subprocess.Popen(["roscore", "-p", str(port)], env=env, stdout=log, stderr=subprocess.STDOUT,
                                stdin=subprocess.DEVNULL, start_new_session=True)
    try:
        import rosgraph
        master = rosgraph.Master("/keyboard_test", master_uri=env["ROS_MASTER_URI"])

        def master_up():
            try:
                return master.getPid() > 0
            except Exception:  # not listening yet
                return False
        wait_for(master_up, "roscore on port %d" % port, process=core)
        subprocess.run(["rosparam", "load", os.path.join(PACKAGE, "config", "keyboard.yaml"), "/keyboard_teleop"],
                       env=env, check=True, timeout=TIMEOUT)
        yield env
    finally:
        stop(core)


class Lines:
    """Collects a stream's lines in a background thread; ``wait`` for one that matches."""

    def __init__(self, stream, parse=lambda line: line):
        self.items, self.lock = [], threading.Lock()
        self._stream, self._parse = stream, parse
        threading.Thread(target=self._pump, daemon=True).start()

    def _pump(self):
        try:
            for line in iter(self._stream.readline, ""):
                with self.lock:
                    self.items.append(self._parse(line))
        except OSError:  # EIO: a pty's master reads this once the node has closed the terminal
            pass
        finally:
            self._stream.close()

    def snapshot(self, start=0):
        with self.lock:
            return list(self.items[start:])

    def count(self):
        with self.lock:
            return len(self.items)


@pytest.fixture
def probe(ros_env):
    process = subprocess.Popen([sys.executable, os.path.join(HERE, "topic_probe.py")], env=ros_env,
                               stdout=subprocess.PIPE, text=True, start_new_session=True)
    process.records = Lines(process.stdout, json.loads)
    yield process
    stop(process)


def topic(name):
    return lambda record: record.get("topic") == name


def wait_record(probe, what, condition, start=0, process=None):
    return wait_for(lambda: next((r for r in probe.records.snapshot(start) if condition(r)), None), what,
                    process=process)


def wait_connected(probe, process):
    wait_record(probe, "keyboard_teleop's publishers to reach the probe",
                lambda r: "connections" in r and all(r["connections"].values()), process=process)


def spawn_keyboard(ros_env, **streams):
    return subprocess.Popen([sys.executable, os.path.join(PACKAGE, "scripts", "keyboard_teleop"),
                             "__name:=keyboard_teleop"], env=ros_env, start_new_session=True, **streams)


@pytest.mark.needs_pty
def test_keys_typed_in_a_terminal_fly_the_drone_and_the_terminal_is_restored(ros_env, probe):
    master, terminal = os.openpty()
    original_mode = termios.tcgetattr(terminal)
    node = spawn_keyboard(ros_env, stdin=terminal, stdout=terminal, stderr=terminal)
    screen = Lines(os.fdopen(master, "r", errors="replace"))  # also drains the pty so the node never blocks
    try:
        wait_for(lambda: any("Reading from the keyboard" in line for line in screen.snapshot()), "the help text",
                 process=node)
        wait_for(lambda: not termios.tcgetattr(terminal)[3] & termios.ECHO, "the terminal in no-echo mode",
                 process=node)
        wait_connected(probe, node)

        def hold(key, what, condition):
            """Types the key again and again, as terminal key repeat does, until the probe sees the condition."""
            start = probe.records.count()
            deadline = time.monotonic() + TIMEOUT
            while not any(condition(r) for r in probe.records.snapshot(start)):
                assert node.poll() is None and time.monotonic() < deadline, "no " + what
                os.write(master, key.encode())
                time.sleep(0.1)  # key-repeat interval of a terminal, not a synchronisation
            return start

        def press(key, what, condition):
            start = probe.records.count()
            os.write(master, key.encode())
            return wait_record(probe, what, condition, start, node)

        start = hold("i", "forward at the initial speed",
                     lambda r: r.get("topic") == "cmd_vel" and r["linear"] == [SPEED, 0.0, 0.0])
        wait_record(probe, "operator/command 'manual'", lambda r: r.get("data") == "manual", start, node)
        # key released: after the key-repeat timeout one zero command
        wait_record(probe, "a zero command after the key timeout",
                    lambda r: r.get("topic") == "cmd_vel" and r["linear"] == [0.0, 0.0, 0.0], start, node)
        press("T", "ardrone/takeoff on T", topic("takeoff"))
        press("L", "ardrone/land on L", topic("land"))
        press("E", "operator/command 'emergency' on E", lambda r: r.get("data") == "emergency")
        os.write(master, b"q")  # 10 % faster: no topic to wait on, the next hold checks it
        hold("a", "yaw left at 0.55 rad/s",
             lambda r: r.get("topic") == "cmd_vel" and abs(r["yaw_rate"] - 0.55) < 1e-6)
        press(" ", "a zero command on space",
              lambda r: r.get("topic") == "cmd_vel" and r["linear"] == [0.0, 0.0, 0.0] and r["yaw_rate"] == 0.0)
    finally:
        stop(node)
    assert node.returncode == 0
    assert termios.tcgetattr(terminal) == original_mode  # echo and line editing are back
    os.close(terminal)


def test_keys_piped_on_stdin_are_read_line_by_line(ros_env, probe):
    node = spawn_keyboard(ros_env, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        wait_connected(probe, node)
        start = probe.records.count()
        node.stdin.write(b"T\n")
        node.stdin.flush()
        wait_record(probe, "ardrone/takeoff from the pipe", topic("takeoff"), start, node)
        node.stdin.write(b"j\n")
        node.stdin.close()  # end of input: the node keeps running and the key timeout stops the motion
        wait_record(probe, "left at the initial speed", lambda r: r.get("topic") == "cmd_vel"
                    and r["linear"] == [0.0, SPEED, 0.0], start, node)
        wait_record(probe, "a zero command after the key timeout", lambda r: r.get("topic") == "cmd_vel"
                    and r["linear"] == [0.0, 0.0, 0.0], start, node)
        assert node.poll() is None
    finally:
        stop(node)
    assert node.returncode == 0


def test_missing_parameter_is_fatal_and_named(ros_env):
    result = subprocess.run([sys.executable, os.path.join(PACKAGE, "scripts", "keyboard_teleop"),
                             "__name:=keyboard_teleop_unconfigured"], env=ros_env, stdin=subprocess.DEVNULL,
                            capture_output=True, text=True, timeout=TIMEOUT)
    assert result.returncode != 0
    assert "required parameter '~" in result.stderr + result.stdout and "keyboard.yaml" in result.stderr + result.stdout
