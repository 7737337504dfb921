"""The ROS-free parts of the reliability tooling: missions and their outcome, the run's processes and their
memory, roslaunch's account of crashes, the fuzzer's garbage and its summary, the new scenario fields and
expectations."""
import json
import os
import re
import subprocess
import sys
import time
from types import SimpleNamespace

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
from landing_eval import benchmark, missions, processes, recorders, scenario  # noqa: E402


def touchdown(t, surface=1, crashed=False, pad_error=0.05):
    return SimpleNamespace(surface=surface, crashed=crashed, pad_error=pad_error,
                           header=SimpleNamespace(stamp=SimpleNamespace(to_sec=lambda: t)))


def test_each_mission_is_scored_and_the_run_has_its_worst_outcome():
    log = missions.MissionLog()
    log.start(0.0)
    log.finish(touchdown(30.0), 0.04)
    log.start(40.0, {"wind_speed": 3.0}, battery_swapped=True)
    log.emergency()
    log.finish(touchdown(70.0, surface=2), None)
    log.start(80.0)
    log.abandon("timeout")
    outcomes = [r["outcome"] for r in log.records]
    assert outcomes == ["landed_on_pad", "emergency_landed", "timeout"]
    assert log.records[0]["time_to_land_s"] == 30.0 and log.records[1]["battery_swapped"]
    assert missions.worst(outcomes) == "timeout"
    assert missions.worst(["landed_on_pad", "crashed", "aborted"]) == "crashed"


def test_the_next_mission_cycles_the_conditions_and_swaps_a_low_battery():
    plan = {"conditions": [{"wind_speed": 1.0, "gust_mps": 0.5}, {"temp": 20.0}], "battery_swap_below": 50.0}
    assert missions.next_mission_settings(plan, 1, 80.0) == ({"wind_speed": 1.0, "wind_gust": 0.5}, False)
    assert missions.next_mission_settings(plan, 2, 45.0) == ({"temp": 20.0, "drone_battery": 100.0}, True)
    assert missions.next_mission_settings(plan, 3, "abc")[1]  # unreadable: swapped


def test_the_nodes_of_a_process_tree_are_found_by_their_ros_names_with_memory_and_cpu():
    # The child says when its interpreter is up: measured before that, it is a bare exec'd process of < 1 MB.
    child = subprocess.Popen([sys.executable, "-c", "import time; print('up', flush=True); time.sleep(60)",
                              "__name:=fake_node"], stdout=subprocess.PIPE)
    try:
        assert child.stdout.readline() == b"up\n"  # ends at the line or at EOF if the child died
        deadline = time.monotonic() + 10
        while "fake_node" not in processes.nodes_below([os.getpid()]):
            assert time.monotonic() < deadline
            time.sleep(0.05)
        assert processes.nodes_below([os.getpid()])["fake_node"] == child.pid
        rss_mb, cpu_s = processes.usage(child.pid)
        assert 1.0 < rss_mb < 500.0 and cpu_s >= 0.0
    finally:
        child.kill()
        child.wait()
    assert processes.usage(child.pid) is None


def test_the_resource_table_compares_the_warm_start_with_the_end():
    log = processes.ResourceLog()
    log.samples = [{"label": l, "wall_s": w, "sim_s": w, "nodes": {"a": {"pid": p, "rss_mb": r, "cpu_s": c}}}
                   for l, w, p, r, c in (("start", 0, 1, 50.0, 0.0), ("mission 1", 10, 1, 100.0, 2.0),
                                         ("mission 2", 20, 1, 105.0, 3.0), ("mission 3", 30, 2, 104.0, 0.5))]
    row = log.table(baseline=1)["a"]
    assert row["rss_start_mb"] == 100.0 and row["rss_growth_pct"] == 4.0
    assert row["cpu_start_pct"] == 10.0 and row["cpu_end_pct"] is None and row["restarted"]


LAUNCH_LOG = """
[supervisor-8] process has died [pid 123, exit code -9, cmd /x/supervisor __name:=supervisor].
log file: /x.log
[supervisor-8] restarting process
================================================================================REQUIRED process [mujoco_sim-2] has died!
process has died [pid 456, exit code -9, cmd /x/sim_node __name:=mujoco_sim].
"""


def test_roslaunch_s_account_of_crashes():
    assert processes.deaths_in_launch_log(LAUNCH_LOG) == [
        {"node": "supervisor", "pid": 123, "exit_code": -9, "required": False, "respawned": True},
        {"node": "mujoco_sim", "pid": 456, "exit_code": -9, "required": True, "respawned": False}]


def write(tmp_path, text):
    path = tmp_path / "s.yaml"
    path.write_text(text)
    return str(path)


def test_missions_fuzz_and_kill_signals_validate(tmp_path):
    s = scenario.load(write(tmp_path, "name: a\nmissions: {count: 3, conditions: [{wind_speed: 2}]}\n"
                                      "fuzz: {duration_s: 30}\nevents: [{at_s: 5, fault: kill_node, name: master}]\n"))
    assert s["missions"] == {"count": 3, "pause_s": 10.0, "battery_swap_below": 50.0,
                             "conditions": [{"wind_speed": 2.0}]}
    assert s["fuzz"]["duration_s"] == 30.0 and s["fuzz"]["period_s"] == 1.0
    assert s["events"][0]["signal"] == "KILL"
    for text, message in (("missions: {pause_s: 1}", "missions.count': required"),
                          ("missions: {count: 2, conditions: [{wind: 1}]}", "unknown field(s) wind"),
                          ("fuzz: {period_s: 0}", "fuzz.period_s'"),
                          ("events: [{at_s: 1, fault: kill_node, name: x, signal: HUP}]", "signal'"),
                          ("events: [{at_s: 1, fault: camera_blackout, signal: KILL}]", "only kill_node"),
                          ("expect: {outcome: vanished}", "expect.outcome")):
        with pytest.raises(scenario.ScenarioError, match=re.escape(message)):
            scenario.load(write(tmp_path, "name: a\n" + text + "\n"))


def test_expectations_of_missions_deaths_and_an_aborted_run():
    result = {"outcome": "landed_on_pad", "missions_on_pad": 2, "missions": [{}, {}, {}], "decisions": [],
              "faults": [{"name": "supervisor"}],
              "node_deaths": [{"node": "supervisor", "exit_code": -9}, {"node": "platform_tracking", "exit_code": 1}]}
    passed, why = benchmark.check_expectations({"min_missions_on_pad": 3, "no_node_deaths": True}, result)
    assert not passed and "2 of 3 missions on the pad" in why and "platform_tracking (exit code 1)" in why
    assert "supervisor" not in why.split("died:")[1]  # killed by the scenario: not a death of its own
    aborted = {"outcome": "aborted", "error": "roslaunch ended", "decisions": []}
    spec = {"row": {"name": "x", "run": 1}, "expect": {"outcome": "aborted"}}
    assert benchmark.row_of(spec, {"result": aborted})["passed"]
    assert not benchmark.row_of(dict(spec, expect={}), {"result": aborted})["passed"]


rospy = pytest.importorskip("rospy")


def test_the_fuzzer_garbles_every_kind_of_message_it_meets_into_something_that_still_serialises():
    import io
    import random
    from geometry_msgs.msg import PoseStamped
    from landing_eval import fuzz
    from landing_msgs.msg import LockstepAck, Navdata
    from nav_msgs.msg import Odometry, Path
    from sensor_msgs.msg import Image, Imu
    from std_msgs.msg import Bool, String
    rng = random.Random(3)
    path = Path(poses=[PoseStamped(), PoseStamped()])
    expected = {Imu: {"nan", "inf", "huge", "wrong frame", "stamp from the past", "stamp from the future"},
                Image: {"zero size", "wrong encoding", "cut short", "huge dimensions"},
                Path: {"empty", "poses going back", "nan"}, Navdata: {"unknown state"}, String: {"text"},
                LockstepAck: {"another node's name", "negative period"}, Odometry: {"nan", "wrong frame"}}
    for cls, kinds in expected.items():
        seen = set()
        for _ in range(100):
            kind, msg = fuzz.garble(cls, path if cls is Path else None, rng, 100.0)
            msg.serialize(io.BytesIO())
            seen.add(kind.split(" in ")[0])
        assert kinds <= seen, (cls, seen)
    assert fuzz.garble(Bool, None, rng, 100.0) is None


def test_the_fuzz_summary_names_the_silent_subscribers_and_the_unthrottled_lines(tmp_path):
    from landing_eval import fuzz
    (tmp_path / fuzz.COUNTS_FILE).write_text(json.dumps({
        "topics": {"/ardrone/imu": {"type": "sensor_msgs/Imu", "sent": {"nan": 4, "burst": 20},
                                    "subscribers": ["/drone_estimator", "/platform_detection", "/supervisor"]},
                   "/landing_allowed": {"type": "std_msgs/Bool", "sent": {"burst": 10},
                                        "subscribers": ["/platform_tracking"]}},
        "skipped": {"/clock": "time"}, "bursts": [{}], "first_t": 3.0, "last_t": 40.0}))
    warnings = [(t, "/drone_estimator", "rejected input on /ardrone/imu [non-finite]: orientation.w is nan")
                for t in (0.0, 1.0, 2.0, 3.0)]  # four lines in 3 s: not throttled
    summary = fuzz.summary(str(tmp_path), warnings, {})
    imu = summary["topics"]["/ardrone/imu"]
    assert imu["rejected_by"] == ["/drone_estimator"]
    assert imu["never_rejected_by"] == ["/platform_detection"]  # the supervisor only watches arrivals
    assert summary["topics"]["/landing_allowed"]["never_rejected_by"] == []  # bursts only: nothing to reject
    assert summary["unthrottled"][0]["node"] == "/drone_estimator" and summary["sim_time_fuzzed_s"] == 37.0
    assert summary["messages_sent"] == 34


def test_the_bags_of_a_split_recording_are_found_in_their_order_with_the_names_they_have_once_repaired(tmp_path):
    for name in ("flight_0.bag", "flight_1.bag", "flight_10.bag", "flight_2.bag.active", "flight_x.bag", "flight.bag",
                 "flight.2_0.bag"):
        (tmp_path / name).write_bytes(b"")
    stem = str(tmp_path / "flight")
    assert recorders.split_bags(stem + ".bag") == [stem + "_0.bag", stem + "_1.bag", stem + "_2.bag", stem + "_10.bag"]
    assert recorders.split_bags(stem + ".2.bag") == [stem + ".2_0.bag"]
    assert recorders.split_bags(str(tmp_path / "none.bag")) == []
