"""Reliability, for real (issue 16): missions in a row in one session, nodes killed mid-flight, garbage on every
input, a run whose processes are all SIGKILLed, a run whose simulator dies, and the network kept on loopback.
Short versions of `rosrun landing_eval soak / fuzz / crash_table` (their long versions are benchmark commands)."""
import json
import os
import re
import signal
import subprocess
import sys
import time

import pytest
import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path[:0] = [os.path.join(ROOT, "src", "landing_eval", "src"), os.path.join(ROOT, "src", "flight_analysis", "src")]
from flight_analysis.analysis_bag import read_bag  # noqa: E402
from landing_eval import processes  # noqa: E402
from landing_eval.isolated_ros import IsolatedCore, IsolatedLaunch, IsolatedProcess  # noqa: E402
from landing_eval.recorders import RECORDER, recorder_command  # noqa: E402

RELIABILITY = os.path.join(ROOT, "scenarios", "reliability")
SAFE = ("landed_on_pad", "emergency_landed", "timeout")  # on the pad, an emergency landing, or still flying
TIMEOUT_S = 900  # a whole run on a loaded 2-core machine, with margin


def run_scenario(path, out, *extra):
    run = subprocess.run(["rosrun", "landing_eval", "run_scenario", str(path), "--out", str(out)] + list(extra),
                         capture_output=True, text=True, timeout=TIMEOUT_S, stdin=subprocess.DEVNULL)
    with open(os.path.join(str(out), "result.json")) as stream:
        return run, json.load(stream)


def scenario_file(tmp_path, base, **changes):
    with open(base) as stream:
        data = yaml.safe_load(stream)
    data.update(changes)
    path = tmp_path / (data["name"] + ".yaml")
    path.write_text(yaml.safe_dump(data))
    return path


def test_three_missions_in_a_row_land_on_the_pad_with_flat_memory_and_loopback_only(tmp_path):
    out = tmp_path / "soak"
    # A bag per 30 s of sim time, as the long soak records (rosbag's index memory is freed at each new bag).
    run = subprocess.run(["rosrun", "landing_eval", "soak", "--scenario", os.path.join(RELIABILITY, "soak_3_missions.yaml"),
                          "--out", str(out), "--bag-split-s", "30"], capture_output=True, text=True, timeout=TIMEOUT_S,
                         stdin=subprocess.DEVNULL)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    result = json.loads((out / "result.json").read_text())
    missions = result["missions"]
    assert [m["outcome"] for m in missions] == ["landed_on_pad"] * 3, missions
    assert missions[1]["conditions"]["wind_speed"] == 3.0  # the conditions changed between missions
    assert all(m["time_to_land_s"] < 60.0 for m in missions)
    assert result["node_deaths"] == []
    table = result["resources"]["table"]
    assert {"mujoco_sim", "platform_detection", "prediction_kalman_node", "drone_estimator", "platform_tracking",
            "supervisor", "emergency", "cmd_vel_mux", "summit_moves", "flight_recorder", "master"} <= set(table)
    assert all(row["rss_growth_pct"] < 10.0 for row in table.values()), table
    assert "| 3 | control_battery 70" in (out / "soak.md").read_text()
    # The bags follow one another without a gap and hold the whole session.
    bags = result["bags"]
    assert [os.path.basename(b) for b in bags] == ["flight_%d.bag" % i for i in range(len(bags))] and len(bags) >= 3
    parts = [read_bag(bag, ["/drone/navdata"]) for bag in bags]
    # (a bag's times are receive times in float seconds: at the split the next may start a nanosecond earlier)
    assert all(-0.01 < later.start_s - earlier.end_s < 0.5 for earlier, later in zip(parts, parts[1:])), \
        [(p.start_s, p.end_s) for p in parts]
    assert parts[-1].end_s >= result["sim_time_s"] - 2.0
    # Security: every process of the graph listens on loopback only (env.sh's and run_scenario's default).
    listening = result["listening"]
    assert set(listening) >= set(table) and all(listening.values())
    assert all(processes.is_loopback(address) for addresses in listening.values() for address in addresses), listening


def test_a_soak_stopped_by_sigterm_reports_the_missions_it_flew_and_leaves_nothing_running(tmp_path):
    # (a soak started in the background of a script ignores Ctrl-C: SIGTERM is how it is stopped, and it ended
    # at once without result.json or soak.md)
    out, log = tmp_path / "soak", tmp_path / "soak.log"
    with open(log, "w") as stream:
        soak = subprocess.Popen(["rosrun", "landing_eval", "soak", "--scenario",
                                 os.path.join(RELIABILITY, "soak_3_missions.yaml"), "--out", str(out)],
                                stdout=stream, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, start_new_session=True,
                                env=dict(os.environ, PYTHONUNBUFFERED="1"))  # its lines in the log as they come
    try:
        deadline = time.monotonic() + TIMEOUT_S
        while "mission 2 at t=" not in log.read_text():
            assert time.monotonic() < deadline and soak.poll() is None, log.read_text()[-3000:]
            time.sleep(0.5)
        os.kill(soak.pid, signal.SIGTERM)
        assert soak.wait(timeout=120) == 130, log.read_text()[-3000:]
    finally:
        if soak.poll() is None:
            os.killpg(soak.pid, signal.SIGKILL)
    result = json.loads((out / "result.json").read_text())
    assert result["outcome"] == "aborted" and "SIGTERM" in result["error"]
    assert result["missions"][0]["outcome"] == "landed_on_pad"
    assert "| 1 | " in (out / "soak.md").read_text() and "interrupted" in log.read_text()
    assert not [pid for pid in processes.children_map() if str(out) in " ".join(processes.command_line(pid))]


def recorder_preloads(root_pid, timeout_s=60.0):
    """Which of jemalloc and the loopback shim the flight recorder below ``root_pid`` has mapped, once it runs."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        pid = processes.nodes_below([root_pid]).get(RECORDER)
        program = processes.command_line(pid)[:1] if pid is not None else []
        if [os.path.basename(p) for p in program] == ["record"]:  # rosbag's C++ recorder, not a wrapper
            with open("/proc/%d/maps" % pid) as stream:
                maps = stream.read()
            # Read once the loader has mapped its libraries (the preloaded ones come before roscpp).
            if "libroscpp" in maps:
                return {lib for lib in ("libjemalloc", "liblanding_loopback_bind") if lib in maps}
        time.sleep(0.2)
    raise AssertionError("no flight recorder process after %.0f s" % timeout_s)


def test_both_flight_recorders_run_on_jemalloc_which_gives_back_the_memory_of_their_queues(tmp_path):
    # With glibc's allocator, what rosbag record queued while the machine was overloaded stayed in its memory
    # (22 -> 28 MB in a soak); record.launch (start.launch's) and run_scenario's recorder preload jemalloc.
    with IsolatedLaunch(["interface", "record.launch", "bag:=%s" % (tmp_path / "launch.bag")],
                        str(tmp_path / "launch.log")) as launch:
        launch.wait_for_master()
        # (and keeps the loopback shim that env.sh and the runs preload)
        assert recorder_preloads(launch.process.pid) == {"libjemalloc", "liblanding_loopback_bind"}, \
            (tmp_path / "launch.log").read_text()[-2000:]
    command, env = recorder_command(str(tmp_path / "run.bag"))
    with IsolatedCore(str(tmp_path / "core.log")) as core:
        core.wait_for_master()
        with IsolatedProcess(command, str(tmp_path / "run.log"), core.master_uri, env=env) as recorder:
            assert recorder_preloads(recorder.process.pid) == {"libjemalloc", "liblanding_loopback_bind"}, \
                (tmp_path / "run.log").read_text()[-2000:]


def test_garbage_on_every_input_kills_no_node_is_rejected_by_every_consumer_and_logged_throttled(tmp_path):
    out = tmp_path / "fuzz"
    run, result = run_scenario(os.path.join(RELIABILITY, "fuzz_short.yaml"), out)
    assert run.returncode == 0, run.stderr[-3000:]
    assert result["node_deaths"] == [] and not result["error"]
    assert result["callback_errors"] == {}, result["callback_errors"]  # rejected, never raised on
    assert all(m["outcome"] in SAFE for m in result["missions"]), result["missions"]
    fuzz = result["fuzz"]
    assert fuzz["sim_time_fuzzed_s"] > 30.0 and len(fuzz["bursts"]) >= 5
    topics = fuzz["topics"]
    assert len(topics) >= 25 and "/ardrone/bottom/image_raw" in topics and "/lockstep_ack" in topics
    garbled = {t: i for t, i in topics.items() if any(k != "burst" for k in i["sent"])}
    # Every node that reads a topic's content said, naming the topic, that it dropped garbage there.
    assert {t: i["never_rejected_by"] for t, i in garbled.items() if i["never_rejected_by"]} == {}
    assert {n for i in garbled.values() for n in i["rejected_by"]} >= {
        "/mujoco_sim", "/platform_detection", "/prediction_kalman_node", "/drone_estimator", "/platform_tracking",
        "/supervisor", "/emergency", "/cmd_vel_mux", "/station"}
    # ... once per kind of problem and topic every 5 s, not once per message.
    assert fuzz["unthrottled"] == []
    assert fuzz["warning_lines"] < fuzz["messages_sent"] / 2


def test_nodes_killed_mid_flight_come_back_and_the_drone_lands_on_the_pad(tmp_path):
    # realism: ideal - the expected outcome is a landing on the pad, which the realistic world does not give reliably yet
    kills = [{"at_s": 6.0, "fault": "kill_node", "name": "supervisor"},
             {"at_s": 8.0, "fault": "kill_node", "name": "cmd_vel_mux"},
             {"at_s": 10.0, "fault": "kill_node", "name": "flight_recorder"},
             {"at_s": 12.0, "fault": "kill_node", "name": "platform_tracking"}]
    path = scenario_file(tmp_path, os.path.join(ROOT, "scenarios", "fault_tracker_killed.yaml"),
                         name="four_kills", time_limit_s=100.0, events=[{"at_s": 0, "operator": "landing"}] + kills)
    run, result = run_scenario(path, tmp_path / "out")
    assert run.returncode == 0, run.stderr[-3000:]
    assert result["outcome"] == "landed_on_pad", (result["outcome"], result["error"])
    faults = {f["name"]: f for f in result["faults"]}
    assert set(faults) == {"supervisor", "cmd_vel_mux", "flight_recorder", "platform_tracking"}
    assert all(f["recovered_after_s"] is not None and f["error"] is None for f in faults.values()), faults
    assert any(d["action"] == "recovered" and d["value"]["mode"] == "landing" for d in result["decisions"])
    assert {d["node"] for d in result["node_deaths"]} == {"supervisor", "cmd_vel_mux", "platform_tracking"}
    assert result["callback_errors"] == {}, result["callback_errors"]  # the others took the restarts in their stride
    # The killed recorder's bag was reindexed and a new one records the rest: both read, together the whole flight.
    assert [os.path.basename(b) for b in result["bags"]] == ["flight.bag", "flight.2.bag"]
    first, second = read_bag(result["bags"][0], ["/drone/navdata"]), read_bag(result["bags"][1], ["/drone/navdata"])
    assert first.end_s >= 9.0 and second.start_s - first.end_s < 5.0 and second.end_s >= result["sim_time_s"] - 2.0


def test_a_dead_simulator_ends_the_run_at_once_with_the_reason_and_a_readable_bag(tmp_path):
    out = tmp_path / "bench"
    run = subprocess.run(["rosrun", "landing_eval", "benchmark", os.path.join(ROOT, "scenarios", "fault_simulator_killed.yaml"),
                          "--out", str(out)], capture_output=True, text=True, timeout=TIMEOUT_S, stdin=subprocess.DEVNULL)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]  # the expected outcome: aborted
    result = json.loads((out / "fault_simulator_killed" / "result.json").read_text())
    assert result["outcome"] == "aborted" and "required node mujoco_sim died" in result["error"]
    assert result["sim_time_s"] < 14.0 and result["wall_phases_s"]["shut_down"] < result["wall_limits_s"]["shut_down"]
    assert read_bag(result["bag"], ["/drone/navdata"]).end_s >= 11.0


def test_a_run_killed_with_sigkill_leaves_a_bag_the_analysis_reads_to_the_last_second(tmp_path):
    # realism: ideal - a plain landing flight; what matters is the bag of its killed processes
    out = tmp_path / "killed"
    path = scenario_file(tmp_path, os.path.join(ROOT, "scenarios", "fault_tracker_killed.yaml"), name="sigkilled",
                         events=[{"at_s": 0, "operator": "landing"}])
    runner = subprocess.Popen(["rosrun", "landing_eval", "run_scenario", str(path), "--out", str(out)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL,
                              start_new_session=True)
    try:
        deadline = time.monotonic() + TIMEOUT_S
        uri, t = None, 0.0
        while t < 10.0:  # sim seconds into the flight
            assert time.monotonic() < deadline and runner.poll() is None, "the run never got 10 s into its flight"
            time.sleep(0.5)
            if uri is None and (out / "core.log").is_file():
                found = re.search(r"ROS_MASTER_URI=(http://[\d.:]+)", (out / "core.log").read_text())
                uri = found.group(1) if found else None
            if uri and (out / "flight.bag.active").is_file():
                echo = subprocess.run(["rostopic", "echo", "-n1", "/clock/clock/secs"], capture_output=True, text=True,
                                      timeout=60, env=dict(os.environ, ROS_MASTER_URI=uri))
                t = float(echo.stdout.split()[0]) if echo.stdout.strip() else 0.0
        # All frozen first: a child outliving its parent for a moment would be told to stop cleanly (PDEATHSIG).
        everything = [runner.pid] + processes.descendants(runner.pid)
        for signum in (signal.SIGSTOP, signal.SIGKILL):
            for pid in everything:
                try:
                    os.kill(pid, signum)
                except ProcessLookupError:
                    pass
    finally:
        if runner.poll() is None:
            runner.kill()
        runner.wait()
    assert not (out / "result.json").exists() and (out / "flight.bag.active").is_file()
    contents = read_bag(str(out / "flight.bag.active"), ["/drone/navdata", "/groundtruth/ardrone"])
    assert contents.integrity["status"] == "recovered"
    assert contents.end_s >= t - 1.0, (contents.end_s, t)  # up to the last second before the kill
    analysis = subprocess.run([sys.executable, "-m", "landing_eval.analyze", str(out / "flight.bag.active"), "--out",
                               str(tmp_path / "report")], capture_output=True, text=True, timeout=600)
    assert analysis.returncode == 0, analysis.stderr[-2000:]


def test_the_simulator_stopped_while_it_publishes_ends_cleanly(tmp_path):
    # roslaunch's SIGINT closes the publishers between the loop's shut-down check and a publish: before, one stop in
    # three printed "publish() to a closed topic" with a traceback (35 of the 112 suite runs).
    for attempt in range(4):
        log = tmp_path / ("launch%d.log" % attempt)
        with IsolatedLaunch(["mujoco_sim", "sim.launch", "real_time_factor:=0"], str(log)) as launch:
            launch.wait_for_master()
            # Two reports of the simulator (one every 5 s of sim time): its loop steps and publishes at full speed.
            echo = subprocess.run(["rostopic", "echo", "-n", "2", "/sim_stats"], capture_output=True, text=True,
                                  timeout=120, stdin=subprocess.DEVNULL,
                                  env=dict(os.environ, ROS_MASTER_URI=launch.master_uri))
            assert echo.returncode == 0, echo.stderr[-2000:] + log.read_text()[-3000:]
        text = log.read_text()
        assert "Traceback" not in text and "has died" not in text, text[-3000:]


def test_env_sh_keeps_ros_on_loopback_unless_the_user_opens_it():
    def sourced(setup):
        script = "unset ROS_IP ROS_HOSTNAME LANDING_ROS_LOOPBACK LD_PRELOAD; %s source env.sh; " \
                 "echo \"$ROS_IP|${ROS_HOSTNAME:-}|$LANDING_ROS_LOOPBACK|${LD_PRELOAD:-}\"" % setup
        return subprocess.run(["bash", "-c", script], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    ip, hostname, loopback, preload = sourced("").split("|")
    assert ip == "127.0.0.1" and hostname == "" and loopback == "1" and preload.endswith("liblanding_loopback_bind.so")
    assert sourced("source env.sh;") == "|".join([ip, hostname, loopback, preload])  # sourcing twice changes nothing
    assert sourced("export ROS_IP=192.168.1.20;") == "192.168.1.20||0|"
    assert sourced("export ROS_HOSTNAME=drone.local;") == "|drone.local|0|"
