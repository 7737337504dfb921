"""The graph floor (landing_bench.graph_floor): its topology arithmetic, ROS-free; its two null nodes against a real
master, under a stand-in simulator that ticks the clock and sends an IMU (they must publish at their rates and
acknowledge what they are told to, and a topology noted from them must give them back); and bench_floor with the
real simulator."""
import json
import os
import subprocess
import sys
import time

import pytest

from landing_bench import bus_stats, graph_floor
from landing_bench.graph_floor import NodeShape

pytestmark = pytest.mark.slow  # a ROS master, a terminal or minutes: make test, not make check

STATE = ([["/clock", ["/mujoco_sim"]], ["/imu", ["/mujoco_sim"]], ["/odom", ["/estimator"]],
          ["/rosout", ["/estimator", "/tracker"]], ["/lockstep_ack", ["/estimator"]], ["/state", ["/tracker"]],
          ["/cmd", ["/tracker"]]],
         [["/clock", ["/estimator", "/tracker", "/recorder"]], ["/imu", ["/estimator", "/recorder"]],
          ["/odom", ["/tracker", "/recorder"]], ["/cmd", ["/mujoco_sim", "/recorder"]],
          ["/lockstep_ack", ["/mujoco_sim"]], ["/rosout", ["/rosout"]]],
         [])
TYPES = {"/clock": "rosgraph_msgs/Clock", "/imu": "sensor_msgs/Imu", "/odom": "nav_msgs/Odometry",
         "/cmd": "geometry_msgs/Twist", "/state": "std_msgs/String", "/rosout": "rosgraph_msgs/Log",
         "/lockstep_ack": "landing_msgs/LockstepAck"}
RATES = {("/mujoco_sim", "/imu"): 50.0, ("/estimator", "/odom"): 49.96, ("/tracker", "/cmd"): 30.0,
         ("/tracker", "/state"): 0.2, ("/estimator", "/rosout"): 3.0}


def _topology():
    return graph_floor.topology(STATE, TYPES, {"/estimator": "rospy", "/tracker": "rospy", "/recorder": "roscpp",
                                               "/mujoco_sim": "rospy", "/ghost": "rospy"},
                                RATES, [("/estimator", "/imu", 0.0), ("/tracker", "/clock", 1 / 30),
                                        ("/tracker", "/clock", 1 / 30)])


def test_a_topology_keeps_each_nodes_own_topics_and_leaves_out_what_every_node_does_by_itself():
    nodes = _topology()
    assert sorted(nodes) == ["/estimator", "/ghost", "/recorder", "/tracker"]  # not the simulator
    estimator, tracker, recorder = nodes["/estimator"], nodes["/tracker"], nodes["/recorder"]
    assert estimator.subscribes == [{"topic": "/imu", "type": "sensor_msgs/Imu"}]  # /clock: every node's own
    assert estimator.publishes == [{"topic": "/odom", "type": "nav_msgs/Odometry", "rate_hz": 49.96}]  # no /rosout
    assert estimator.acks == [{"input": "/imu", "period": 0.0, "rate_hz": 50.0}]  # its input's rate: it is driven by it
    assert tracker.publishes == [{"topic": "/cmd", "type": "geometry_msgs/Twist", "rate_hz": 30.0}]  # /state: < 1 Hz
    assert tracker.acks == [{"input": "/clock", "period": 1 / 30}]  # heard many times, noted once
    assert recorder.client == "roscpp" and [s["topic"] for s in recorder.subscribes] == ["/cmd", "/imu", "/odom"]
    assert nodes["/ghost"].subscribes == nodes["/ghost"].publishes == []


def test_merged_nodes_receive_a_topic_once_and_keep_every_publication_and_the_fastest_timer():
    nodes = _topology()
    nodes["/recorder"].acks.append({"input": "/clock", "period": 0.1})
    merged = graph_floor.merge(nodes, ["/tracker", "/recorder", "/estimator"], "/manager")
    assert sorted(merged) == ["/ghost", "/manager"]
    manager = merged["/manager"]
    assert manager.client == "roscpp"
    assert sorted(s["topic"] for s in manager.subscribes) == ["/cmd", "/imu", "/odom"]
    assert sorted(p["topic"] for p in manager.publishes) == ["/cmd", "/odom"]
    assert manager.acks == [{"input": "/imu", "period": 0.0, "rate_hz": 50.0}, {"input": "/clock", "period": 1 / 30}]
    assert list(graph_floor.merge(_topology(), ["all"], "/one")) == ["/one"]
    with pytest.raises(ValueError, match="no node /nobody in the topology"):
        graph_floor.merge(_topology(), ["/nobody"], "/x")


def test_a_null_node_is_driven_as_its_node_by_its_timer_else_its_first_input_else_its_fastest_publication():
    nodes = _topology()
    assert nodes["/tracker"].driver() == {"timer_hz": pytest.approx(30.0), "input": "", "hz": pytest.approx(30.0)}
    assert nodes["/estimator"].driver() == {"timer_hz": 0.0, "input": "/imu", "hz": 50.0}
    assert nodes["/recorder"].driver() == {"timer_hz": 0.0, "input": "", "hz": 0.0}  # publishes nothing: no timer
    nodes["/recorder"].publishes = [{"topic": "/a", "type": "std_msgs/String", "rate_hz": 5.0},
                                    {"topic": "/b", "type": "std_msgs/String", "rate_hz": 20.0}]
    assert nodes["/recorder"].driver() == {"timer_hz": 20.0, "input": "", "hz": 20.0}
    merged = graph_floor.merge(_topology(), ["/estimator", "/tracker"], "/both")["/both"]
    assert merged.driver()["timer_hz"] == pytest.approx(30.0)  # the timer, not the input


def test_publish_rates_follow_each_topics_oldest_connection():
    first = {"/sim": {"/clock": (2, 100, 60), "/imu": (1, 50, 50)}}
    second = {"/sim": {"/clock": (3, 340, 180), "/imu": (1, 150, 150)}, "/new": {"/x": (1, 20, 20)}}
    assert bus_stats.publish_rates(first, second, sim_seconds=2.0) == {("/sim", "/clock"): 60.0,
                                                                     ("/sim", "/imu"): 50.0, ("/new", "/x"): 10.0}
    assert bus_stats.sim_seconds({"/mujoco_sim": {"/clock": (3, 340, 180)}}, clock_hz=60.0) == 3.0


def test_acknowledgements_are_read_from_rostopic_echo_csv():
    csv = ("%time,field.node,field.input,field.stamp,field.period\n"
           "1,/tracker,/clock,33000000,33333333\n1,/estimator,/ardrone/imu,20000000,0\nbroken line\n"
           "1,/x,/clock,0,not a number\n")
    assert graph_floor.parse_acks(csv) == [("/tracker", "/clock", 0.033333333), ("/estimator", "/ardrone/imu", 0.0)]
    assert graph_floor.parse_acks("") == [] and graph_floor.parse_acks("%time,field.other\n1,2\n") == []


def test_a_saved_topology_loads_back_and_a_bad_file_says_what_it_should_be(tmp_path):
    path = str(tmp_path / "topology.json")
    graph_floor.save(_topology(), path)
    assert graph_floor.load(path) == _topology()
    (tmp_path / "bad.json").write_text("[1, 2]")
    with pytest.raises(ValueError, match="not a graph topology .*bench_loop writes one per run as topology.json"):
        graph_floor.load(str(tmp_path / "bad.json"))
    with pytest.raises(ValueError, match="not a graph topology"):
        graph_floor.load(str(tmp_path / "missing.json"))


def test_fidelity_names_the_publications_off_their_rate_among_those_that_went_over_the_network():
    nodes = _topology()
    published = {("/estimator", "/odom"): 40.0, ("/tracker", "/cmd"): 29.0}
    assert graph_floor.fidelity(nodes, published) == [("/estimator", "/odom", 49.96, 40.0)]
    assert graph_floor.fidelity(nodes, {}) == []  # (intra-process only: nothing to check)


# A stand-in simulator (named as the real one, so that the census reads its clock): /clock at 60 Hz and an IMU at
# 50 Hz of sim time, at about 4x real time, once both null nodes listen; it counts what they publish and acknowledge.
STAND_IN = r"""
import json, sys, time
import rospy
from geometry_msgs.msg import PointStamped
from landing_msgs.msg import LockstepAck
from landing_runtime.rospy_node import direct_publisher
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu
from std_msgs.msg import String
rospy.init_node("mujoco_sim", disable_signals=True)
clock, imu = direct_publisher("/clock", Clock), direct_publisher("/ardrone/imu", Imu)
heard = {"py": 0, "cpp": 0, "acks": {}}
out_py = rospy.Subscriber("/out_py", String, lambda m: heard.__setitem__("py", heard["py"] + 1))
out_cpp = rospy.Subscriber("/out_cpp", PointStamped, lambda m: heard.__setitem__("cpp", heard["cpp"] + 1))
def on_ack(m):
    key = "%s %s %.3f" % (m.node, m.input, m.period.to_sec())
    heard["acks"].setdefault(key, []).append(m.stamp.to_sec())
acks = rospy.Subscriber("/lockstep_ack", LockstepAck, on_ack)
deadline = time.monotonic() + 90
# Both null nodes listen and are heard, and the test says go (its own listener of the acknowledgements is up).
while imu.get_num_connections() < 2 or clock.get_num_connections() < 2 or out_py.get_num_connections() < 1 or \
        out_cpp.get_num_connections() < 1 or acks.get_num_connections() < 2 or not rospy.has_param("/go"):
    assert time.monotonic() < deadline, "the null nodes did not connect"
    time.sleep(0.05)
counted_from, sim_seconds, sent = 2.0, float(sys.argv[1]), []
for tick in range(1, int(sim_seconds * 60) + 1):
    t = tick / 60.0
    if tick == int(counted_from * 60):
        heard.update(py=0, cpp=0)
    clock.publish(Clock(clock=rospy.Time.from_sec(t)))
    if len(sent) < tick * 50 // 60:  # 50 Hz on the 60 Hz tick
        message = Imu()
        message.header.stamp = rospy.Time.from_sec(t)
        imu.publish(message)
        sent.append(t)
    time.sleep(1 / 240.0)
time.sleep(1.0)
print(json.dumps(dict(heard, imu=sent, span=sim_seconds - counted_from)))
"""


def _null_nodes():
    py = NodeShape("/null_py", "rospy", [{"topic": "/ardrone/imu", "type": "sensor_msgs/Imu"}],
                  [{"topic": "/out_py", "type": "std_msgs/String", "rate_hz": 25.0}],
                  [{"input": "/ardrone/imu", "period": 0.0, "rate_hz": 50.0}])
    cpp = NodeShape("/null_cpp", "roscpp", [{"topic": "/out_py", "type": "std_msgs/String"},
                                           {"topic": "/ardrone/imu", "type": "sensor_msgs/Imu"}],
                   [{"topic": "/out_cpp", "type": "geometry_msgs/PointStamped", "rate_hz": 20.0}],
                   [{"input": "/clock", "period": 0.05}])
    return {node.name: node for node in (py, cpp)}


def test_null_nodes_publish_at_their_rates_acknowledge_and_a_topology_noted_from_them_gives_them_back(ros_master):
    from landing_eval.isolated_ros import graph_unconnected, loopback_environment
    proxy, env = ros_master
    env = loopback_environment(env)
    nodes = _null_nodes()
    serialized = graph_floor.default_messages(p["type"] for node in nodes.values() for p in node.publishes)
    proxy.setParam("/use_sim_time", True)
    for node in nodes.values():
        proxy.setParam(node.name + "/null_spec", node.null_spec(serialized))
    children = [subprocess.Popen(graph_floor.null_node_command(node), env=env, start_new_session=True,
                                 stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT) for node in nodes.values()]
    stand_in = subprocess.Popen([sys.executable, "-c", STAND_IN, "30"], env=env, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        every = {"/mujoco_sim", "/null_py", "/null_cpp"}
        while not every <= {n for _, names in proxy.getSystemState()[0] for n in names} or graph_unconnected(proxy):
            assert time.monotonic() < deadline and stand_in.poll() is None, "the graph did not connect"
            time.sleep(0.1)
        acks = graph_floor.AckListener(proxy.master_uri)
        while len(dict(proxy.getSystemState()[1]).get("/lockstep_ack", [])) < 2 or graph_unconnected(proxy):
            assert time.monotonic() < deadline and stand_in.poll() is None, "rostopic echo did not connect"
            time.sleep(0.1)
        proxy.setParam("/go", True)  # the stand-in's clock runs from here
        uris = {name: proxy.lookupNode(name) for name in ["/mujoco_sim", "/null_py", "/null_cpp"]}

        def snapshot_after(sim_s):
            while True:
                snapshot = bus_stats.snapshot(uris)
                if bus_stats.sim_seconds(snapshot, 60.0) >= sim_s:
                    return snapshot
                assert time.monotonic() < deadline and stand_in.poll() is None, "the stand-in did not reach %s" % sim_s
                time.sleep(0.05)
        first = snapshot_after(8.0)
        second = snapshot_after(20.0)
        span = bus_stats.sim_seconds(second, 60.0) - bus_stats.sim_seconds(first, 60.0)
        noted = graph_floor.capture(proxy, uris, first, second, span, acks.stop())
        out, err = stand_in.communicate(timeout=90)
    finally:
        for child in children + [stand_in]:
            if child.poll() is None:
                child.terminate()
            child.wait(timeout=30)
    assert stand_in.returncode == 0, err
    heard = json.loads(out.strip().splitlines()[-1])
    assert heard["py"] == pytest.approx(25.0 * heard["span"], rel=0.1)  # on the IMU's messages, half of them
    assert heard["cpp"] == pytest.approx(20.0 * heard["span"], rel=0.1)  # on its own 20 Hz timer of sim time
    imu_acks = heard["acks"]["/null_py /ardrone/imu 0.000"]
    assert imu_acks[-1] == pytest.approx(heard["imu"][-1])  # the last IMU message sent, acknowledged
    timer_acks = heard["acks"]["/null_cpp /clock 0.050"]
    assert len(timer_acks) == pytest.approx(20.0 * 30, rel=0.1) and timer_acks[-1] == pytest.approx(30.0, abs=0.06)
    # What a census notes of the null nodes is what they were made of.
    for name, node in nodes.items():
        assert noted[name].client == node.client
        assert noted[name].subscribes == sorted(node.subscribes, key=lambda s: s["topic"])
        assert [p["topic"] for p in noted[name].publishes] == [p["topic"] for p in node.publishes]
        assert noted[name].publishes[0]["rate_hz"] == pytest.approx(node.publishes[0]["rate_hz"], rel=0.1)
        assert [a["input"] for a in noted[name].acks] == [a["input"] for a in node.acks]


def test_a_null_node_without_its_spec_stops_with_a_clear_message(ros_master):
    from landing_eval.isolated_ros import loopback_environment
    _, env = ros_master
    for node in _null_nodes().values():
        run = subprocess.run(graph_floor.null_node_command(node) + ["__log:=/dev/null"], env=loopback_environment(env),
                             capture_output=True, text=True, timeout=60)
        assert run.returncode == 2
        assert "required parameter ~null_spec (set by landing_bench.graph_floor) is missing" in run.stdout + run.stderr


def test_bench_floor_runs_the_real_simulator_beside_null_nodes(tmp_path):
    nodes = _null_nodes()
    nodes["/null_py"].publishes[0]["topic"] = "/ardrone/odom_estimate"  # (a topic of the graph, of another type)
    nodes["/null_py"].publishes[0]["type"] = "nav_msgs/Odometry"
    nodes["/null_cpp"].subscribes[0] = {"topic": "/ardrone/odom_estimate", "type": "nav_msgs/Odometry"}
    topology = str(tmp_path / "topology.json")
    graph_floor.save(nodes, topology)
    run = subprocess.run(["rosrun", "landing_bench", "bench_floor", topology, "--realism", "ideal", "--sim-seconds",
                          "10", "--json", "--timeout", "240"], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    figures = json.loads(run.stdout.strip().splitlines()[-1])
    assert figures["real_time_factor"] > 0.0 and figures["stats"]["sim_time"] >= 10.0
    assert figures["rate_misses"] == []
    assert {"mujoco_sim", "null_py", "null_cpp"} <= set(figures["cpu"])
    bad = tmp_path / "bad.json"
    bad.write_text('{"/x": {"name": "/x"}}')  # (fields missing)
    run = subprocess.run(["rosrun", "landing_bench", "bench_floor", str(bad)], capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 1 and "is not a graph topology" in run.stderr
    run = subprocess.run(["rosrun", "landing_bench", "bench_floor", topology, "--jobs", "0"], capture_output=True,
                         text=True, timeout=120)
    assert run.returncode == 2 and "--jobs must be 1 or more" in run.stderr
