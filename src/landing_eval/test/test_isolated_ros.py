"""The graph-connection check run_scenario waits on before it starts the physics: the pure part, the same
check against a real master with a publisher that connects late, and the second chance for a subscriber
whose first connection attempt failed."""
import subprocess
import sys
import time

import pytest
from landing_eval.isolated_ros import graph_unconnected, reconnect_subscribers, unconnected_subscriptions

pytestmark = pytest.mark.slow  # a ROS master, a terminal or minutes: make test, not make check

STATE = ([("/clock", ["/sim"]), ("/cmd", ["/tracker", "/joystick"])],
         [("/clock", ["/tracker", "/rec"]), ("/cmd", ["/sim"]), ("/nobody_publishes", ["/rec"])], [])


def test_every_subscription_connected_to_every_publisher_is_nothing_missing():
    outbound = {"/sim": {("/clock", "/tracker"), ("/clock", "/rec")},
                "/tracker": {("/cmd", "/sim")}, "/joystick": {("/cmd", "/sim")}}
    assert unconnected_subscriptions(STATE, outbound) == []


def test_a_subscriber_not_yet_connected_to_one_of_two_publishers_is_missing():
    outbound = {"/sim": {("/clock", "/tracker"), ("/clock", "/rec")}, "/tracker": {("/cmd", "/sim")}}
    assert unconnected_subscriptions(STATE, outbound) == [("/cmd", "/joystick", "/sim")]


def test_a_publisher_that_did_not_answer_counts_as_connected_to_nobody():
    outbound = {"/tracker": {("/cmd", "/sim")}, "/joystick": {("/cmd", "/sim")}}
    assert sorted(unconnected_subscriptions(STATE, outbound)) == [("/clock", "/sim", "/rec"),
                                                                  ("/clock", "/sim", "/tracker")]


NODE = """
import rospy
from std_msgs.msg import String
rospy.init_node("%s")
%s
rospy.spin()
"""
TALKER = NODE % ("late_talker", 'publisher = rospy.Publisher("chatter", String, queue_size=1)')
LISTENER = NODE % ("listener", 'rospy.Subscriber("chatter", String, lambda m: None)')


def test_a_real_subscriber_is_missing_until_the_publisher_connected_it(ros_master):
    proxy, env = ros_master
    talker = subprocess.Popen([sys.executable, "-c", TALKER], env=env, start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while "/chatter" not in {t for t, _ in proxy.getSystemState()[0]}:
            assert time.monotonic() < deadline, "the talker never advertised"
            time.sleep(0.05)
        # A subscription registered with the master but whose node never connects: missing.
        proxy.registerSubscriber("/chatter", "std_msgs/String", "http://127.0.0.1:1/")
        assert ("/chatter", "/late_talker", "/test") in graph_unconnected(proxy)
        proxy.unregisterSubscriber("/chatter", "http://127.0.0.1:1/")
        # A real subscriber: connected within the deadline, then nothing is missing on /chatter.
        listener = subprocess.Popen([sys.executable, "-c", LISTENER], env=env, start_new_session=True)
        try:
            while [m for m in graph_unconnected(proxy) if m[0] == "/chatter"] or \
                    "/listener" not in dict(proxy.getSystemState()[1]).get("/chatter", []):
                assert time.monotonic() < deadline, "the listener never connected: %s" % graph_unconnected(proxy)
                time.sleep(0.05)
        finally:
            listener.terminate()
            listener.wait(timeout=30)
    finally:
        talker.terminate()
        talker.wait(timeout=30)


# A talker whose node refuses the first requestTopic (as a publisher busy or not yet ready may fail it),
# and says so on the parameter server.
REFUSING_TALKER = """
import rospy
import rospy.impl.masterslave as masterslave
from std_msgs.msg import String
accept = masterslave.ROSHandler.requestTopic
def refuse_once(self, caller_id, topic, protocols):
    if not rospy.has_param("/refused"):
        rospy.set_param("/refused", caller_id)
        return -1, "refused once", 0
    return accept(self, caller_id, topic, protocols)
masterslave.ROSHandler.requestTopic = refuse_once
rospy.init_node("refusing_talker")
publisher = rospy.Publisher("chatter", String, queue_size=1)
rospy.spin()
"""


def test_a_subscriber_whose_first_attempt_failed_connects_once_sent_its_publishers_again(ros_master):
    proxy, env = ros_master
    processes = [subprocess.Popen([sys.executable, "-c", REFUSING_TALKER], env=env, start_new_session=True)]
    try:
        deadline = time.monotonic() + 60
        while "/chatter" not in {t for t, _ in proxy.getSystemState()[0]}:
            assert time.monotonic() < deadline, "the talker never advertised"
            time.sleep(0.05)
        processes.append(subprocess.Popen([sys.executable, "-c", LISTENER], env=env, start_new_session=True))
        while not proxy.hasParam("/refused"):
            assert time.monotonic() < deadline, "the listener never asked the talker for the topic"
            time.sleep(0.05)
        missing = [m for m in graph_unconnected(proxy) if m[0] == "/chatter"]
        assert missing == [("/chatter", "/refusing_talker", "/listener")]  # rospy does not try again by itself
        assert reconnect_subscribers(proxy, missing) == [("/chatter", "/listener")]
        while [m for m in graph_unconnected(proxy) if m[0] == "/chatter"]:
            assert time.monotonic() < deadline, "the listener did not connect on the second chance"
            time.sleep(0.05)
    finally:
        for process in processes:
            process.terminate()
            process.wait(timeout=30)


def _wait_until(condition, what, timeout=60.0):
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, what
        time.sleep(0.05)


def test_the_isolated_core_runs_master_and_rosout_survives_its_master_and_stops_on_sigint(tmp_path):
    import os
    import signal

    import rosgraph
    from landing_eval import processes
    from landing_eval.isolated_ros import IsolatedCore
    with IsolatedCore(str(tmp_path / "core.log")) as core:
        core.wait_for_master(timeout=60.0)
        master = rosgraph.Master("/test", master_uri=core.master_uri)
        _wait_until(lambda: "/rosout" in dict(master.getSystemState()[1]).get("/rosout", []),
                    "rosout did not subscribe to /rosout")
        nodes = processes.nodes_below([core.process.pid])
        assert set(nodes) == {"master", "rosout"}  # both in the core's process tree (faults find them there)
        os.kill(nodes["master"], signal.SIGKILL)  # as the fault kill_node master does: rosout stays, the core too
        _wait_until(lambda: "master" not in processes.nodes_below([core.process.pid]), "the master did not die")
        assert core.alive() and "rosout" in processes.nodes_below([core.process.pid])
        core.interrupt()
        core.process.wait(timeout=30.0)  # (a bounded wait: SIGKILL after ros_core.STOP_WAIT_S)
    assert core.process.returncode == 0
    assert not any(os.path.exists("/proc/%d" % pid) and processes.usage(pid) for pid in nodes.values())
