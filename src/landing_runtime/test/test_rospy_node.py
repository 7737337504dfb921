"""landing_runtime.rospy_node against a real master: the node accepts a burst of connections while its accept
thread is stuck, and SIGINT ends spin() and a sleep on a sim clock that has stopped. How soon they end is
measured in run_scenario's shut-down (nodes gone 0.25 s after the interrupt instead of 0.5 s), not timed here."""
import signal
import socket
import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow  # a ROS master, a terminal or minutes: make test, not make check

NODE = """
import rospy
from std_msgs.msg import String
from rospy.impl import tcpros_base
from landing_runtime.rospy_node import init_node, spin
init_node("burst_listener")
rospy.Publisher("chatter", String, queue_size=1)
print("port %d" % tcpros_base.init_tcpros_server().get_address()[1], flush=True)
{wait}
print("returned", flush=True)
"""
SPIN = NODE.format(wait="spin()")
# /use_sim_time is set and nobody publishes /clock: time stands still, as after the simulator exits.
SIM_TIME_SLEEP = NODE.format(wait="""
try:
    rospy.Rate(10).sleep()
except rospy.ROSInterruptException:
    pass""")


def start(code, env):
    node = subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE, text=True,
                            start_new_session=True)
    line = node.stdout.readline()
    assert line.startswith("port "), "the node did not start: %r" % line
    return node, int(line.split()[1])


def stop(node):
    node.send_signal(signal.SIGINT)
    out, _ = node.communicate(timeout=30)
    return node.returncode, out


def test_a_burst_of_connections_is_accepted_while_the_accept_thread_waits_for_a_header(ros_master):
    _, env = ros_master
    node, port = start(SPIN, env)
    sockets = []
    try:
        # rospy reads each connection's header in its one accept thread: a client that sends none holds
        # it, and every later connection waits in the kernel's backlog (rospy's own: 5).
        sockets.append(socket.create_connection(("127.0.0.1", port), timeout=10))
        for _ in range(30):
            sockets.append(socket.create_connection(("127.0.0.1", port), timeout=10))
    finally:
        for s in sockets:
            s.close()
        code, out = stop(node)
    assert len(sockets) == 31
    assert code == 0 and "returned" in out


def test_sigint_ends_a_sleep_on_a_stopped_sim_clock(ros_master):
    proxy, env = ros_master
    proxy.setParam("/use_sim_time", True)
    node, _ = start(SIM_TIME_SLEEP, env)
    code, out = stop(node)
    assert code == 0 and "returned" in out


# Publishes on many topics, each with a subscriber (itself), as fast as it can, as the simulator does at full
# speed: a stop closes the publishers one after the other before is_shutdown() turns true, and a publish meets a
# closed one. {guard} is the loop's context ("contextlib.nullcontext()" = without it).
PUBLISHING_NODE = NODE.format(wait="""
import contextlib
from landing_runtime.rospy_node import direct_publisher, ended_by_shutdown
import time
fast = [direct_publisher("fast%d" % i, String) for i in range(40)]
listeners = [rospy.Subscriber("fast%d" % i, String, lambda _: None) for i in range(40)]  # connections to close
while not all(publisher.get_num_connections() for publisher in fast):
    time.sleep(0.05)
print("publishing", flush=True)
with {guard}:
    while not rospy.is_shutdown():
        for publisher in fast:
            publisher.publish(String(data="x" * 100))""")


def stops_of_a_fast_publisher(env, guard, attempts=3):
    """(exit status, output) of each of ``attempts`` publishing nodes stopped by SIGINT."""
    results = []
    for _ in range(attempts):
        node = subprocess.Popen([sys.executable, "-c", PUBLISHING_NODE.replace("{guard}", guard)], env=env,
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
        assert node.stdout.readline().startswith("port ")
        assert node.stdout.readline() == "publishing\n"
        results.append(stop(node))
    return results


def test_a_stop_in_the_middle_of_a_publish_ends_the_loop_quietly(ros_master):
    _, env = ros_master
    stops = stops_of_a_fast_publisher(env, "ended_by_shutdown()")
    assert all(code == 0 and "returned" in out and "Traceback" not in out for code, out in stops), stops
    # Without it, the same stop ends with rospy's "publish() to a closed topic" in some of the attempts.
    unguarded = stops_of_a_fast_publisher(env, "contextlib.nullcontext()")
    assert any("closed" in out for _, out in unguarded), unguarded


TICKING_NODE = """
import sys
from landing_runtime.rospy_node import run_node, spin_at

class Node:
    def __init__(self):
        if "{fail}":
            raise ValueError("parameter ~rate_hz is missing")
        self.ticks = 0
    def tick(self):
        self.ticks += 1
        print("tick %d" % self.ticks, flush=True)
    def spin(self):
        spin_at(50.0, self.tick)

sys.exit(run_node("ticking", Node, startup_errors=(ValueError,)))
"""


def test_run_node_ticks_the_node_until_sigint_and_exits_0(ros_master):
    _, env = ros_master
    node = subprocess.Popen([sys.executable, "-c", TICKING_NODE.format(fail="")], env=env, stdout=subprocess.PIPE,
                            text=True, start_new_session=True)
    lines = [node.stdout.readline() for _ in range(3)]
    assert lines == ["tick 1\n", "tick 2\n", "tick 3\n"], lines
    code, _ = stop(node)
    assert code == 0


def test_run_node_turns_a_startup_error_into_a_fatal_message_and_exit_status_2(ros_master):
    _, env = ros_master
    result = subprocess.run([sys.executable, "-c", TICKING_NODE.format(fail="yes")], env=env, capture_output=True,
                            text=True, timeout=120)
    assert result.returncode == 2
    assert "parameter ~rate_hz is missing" in result.stdout + result.stderr


# Ends with exit_promptly while rospy is still up and its last line is still in stdout's buffer (a pipe).
PROMPT_EXIT = NODE.format(wait="""
from landing_runtime.rospy_node import exit_promptly
print("last words")
exit_promptly(3)""")


def test_exit_promptly_shuts_rospy_down_flushes_and_exits_with_the_status(ros_master):
    proxy, env = ros_master
    node = subprocess.Popen([sys.executable, "-c", PROMPT_EXIT], env=env, stdout=subprocess.PIPE, text=True,
                            start_new_session=True)
    assert node.stdout.readline().startswith("port ")
    assert node.wait(timeout=60) == 3
    assert "last words" in node.stdout.read()  # flushed before the process ended (communicate() would skip
    # what readline() buffered)
    # rospy shut down first: the node unregistered its publisher (registered before "port") from the master.
    assert "/burst_listener" not in dict(proxy.getSystemState()[0]).get("/chatter", [])


DIRECT = """
import socket, time
import rospy
from std_msgs.msg import String
from landing_runtime.rospy_node import direct_publisher, init_node
init_node("direct_talker")
publisher = direct_publisher("chatter", String)
assert publisher.impl.queue_size is None  # written in the publishing thread: no QueuedConnection
deadline = time.monotonic() + 60
while publisher.get_num_connections() == 0:
    assert time.monotonic() < deadline, "no subscriber connected"
    time.sleep(0.05)
sock = publisher.impl.connections[0].socket
print("nodelay %d" % sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY), flush=True)
while not rospy.is_shutdown():
    publisher.publish(String(data="hello"))
    time.sleep(0.05)
"""


def test_a_direct_publisher_sends_without_nagle_to_a_subscriber_that_did_not_ask(ros_master):
    _, env = ros_master
    talker = subprocess.Popen([sys.executable, "-c", DIRECT], env=env, stdout=subprocess.PIPE, text=True,
                              start_new_session=True)
    # rostopic's subscription, like rospy's own /clock one, does not ask for TCP_NODELAY.
    listener = subprocess.run(["rostopic", "echo", "-n", "1", "/chatter/data"], env=env, capture_output=True,
                              text=True, timeout=120)
    try:
        assert listener.stdout.split()[0].strip('"') == "hello", listener.stdout + listener.stderr
        assert talker.stdout.readline().strip() == "nodelay 1"
    finally:
        stop(talker)
