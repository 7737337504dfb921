"""bench_loop's arithmetic (ROS-free): CPU per sim second from the run's resource samples, and the bound it sets."""
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
from landing_bench.bench_loop import (cpu_bound, node_cpu_per_sim_second, parallel_gain_bound,  # noqa: E402
                                     simulator_shares, stepping_cpu)
from landing_bench.bus_stats import deliveries_per_sim_second, published_counts  # noqa: E402


def _sample(sim_s, nodes):
    return {"sim_s": sim_s, "nodes": {name: {"pid": pid, "cpu_s": cpu} for name, (pid, cpu) in nodes.items()}}


def test_cpu_per_sim_second_counts_only_nodes_that_lived_through_the_flight():
    result = {"resources": {"samples": [
        _sample(1.0, {"sim": (10, 2.0), "tracker": (11, 1.0), "restarted": (12, 5.0)}),
        _sample(21.0, {"sim": (10, 8.0), "tracker": (11, 2.0), "restarted": (13, 0.5)})]}}
    assert node_cpu_per_sim_second(result) == pytest.approx({"sim": 0.3, "tracker": 0.05})
    assert node_cpu_per_sim_second({"resources": {"samples": result["resources"]["samples"][:1]}}) == {}


def test_a_loop_using_most_of_the_cores_is_bound_by_its_cpu():
    busy, ceiling = cpu_bound({"sim": 0.3, "rest": 0.3}, loop_rtf=2.9, cores=2)
    assert busy == pytest.approx(1.74) and ceiling == pytest.approx(2 / 0.6)
    assert cpu_bound({}, loop_rtf=2.9, cores=2) == (None, None)
    assert cpu_bound({"sim": 0.3}, loop_rtf=None, cores=2) == (None, None)


def test_runs_side_by_side_gain_only_the_cores_one_run_leaves_idle():
    assert parallel_gain_bound(busy=1.78, cores=2) == pytest.approx(2 / 1.78)
    assert parallel_gain_bound(busy=0.5, cores=2) == 2.0  # never more than one run a core


def test_published_counts_read_both_client_libraries_answers():
    rospy_answer = [1, "", [[["/clock", 7620, [[10, 7956, 635, True], [16, 7944, 634, True]]], ["/unheard", 0, []]],
                            [], []]]
    roscpp_answer = [[["/platform/pose", [[1, 17690, 17690, 290, 0], [3, 17690, 17690, 288, 0]]]], [], []]
    assert published_counts(rospy_answer) == {"/clock": (2, 1269, 635), "/unheard": (0, 0, 0)}
    assert published_counts(roscpp_answer) == {"/platform/pose": (2, 578, 290)}


def test_deliveries_per_sim_second_are_the_counts_growth_over_the_span():
    first = {"/sim": {"/clock": (2, 100, 50), "/imu": (1, 50, 50)}}
    second = {"/sim": {"/clock": (2, 340, 170), "/imu": (1, 150, 150)}, "/new": {"/x": (1, 20, 20)}}
    assert deliveries_per_sim_second(first, second, sim_seconds=2.0) == [
        (120.0, "/clock", "/sim", 2), (50.0, "/imu", "/sim", 1), (10.0, "/x", "/new", 1)]
    assert deliveries_per_sim_second(first, second, sim_seconds=0.0) == []


def test_the_simulators_cpu_figures_are_read_from_its_statistics():
    stats = {"physics_share": 0.2, "real_time_factor": 3.0, "cpu_physics_per_sim_s": 0.05, "cpu_publish_per_sim_s": 0.1,
             "cpu_stepping_per_sim_s": 0.16, "cpu_process_per_sim_s": 0.3}
    assert simulator_shares(stats) == {"physics": 0.2}
    assert stepping_cpu(stats) == {"physics": 0.05, "publish": 0.1, "stepping": 0.16, "process": 0.3}
    assert stepping_cpu({"physics_share": 0.2}) == {}


def test_the_report_tables_rows_have_as_many_columns_as_their_header(capsys):
    from landing_bench.bench_loop import report
    row = {"profile": "ideal", "label": "ideal", "sim_alone_rtf": 12.0, "loop_rtf": 4.8, "outcome": "landed_on_pad",
           "phases": {"start_up": 2.3, "shut_down": 0.6}, "steps": {}, "simulator": {}, "sim_alone_cpu": {},
           "sim_loop_cpu": {}, "cpu": {"sim": 0.15, "tracker": 0.03}, "hot": {}, "deliveries": {"rows": []},
           "floor": {"rtf": 6.0, "cpu": {"sim": 0.14}, "misses": [["/tracker", "/cmd", 30.0, 20.0]], "error": None},
           "warm": {"loop_rtf": 4.5, "reset": True, "phases": {"start_up": 0.4, "shut_down": 0.1},
                    "outcome": "landed_on_pad", "between_flights": 0.5, "first_start_up": 2.2, "steps": {}}}
    report([row])
    lines = capsys.readouterr().out.splitlines()
    table = [line for line in lines[:lines.index("|---|---|---|---|---|---|---|---|---|---|") + 3]]
    assert len({line.count("|") for line in table if line.startswith("| ideal") or line.startswith("| profile")}) == 1
    assert "| ideal | 12.00 | 6.00 | 4.80 | 0.50 | 0.40 | 0.80 | 2.30 | 0.60 | landed_on_pad |" in lines
    assert any(line.startswith("| ideal, graph reset |") and line.count("|") == 11 for line in lines)
    assert "warning: graph floor, ideal: /tracker published /cmd at 20.0 per sim s, not 30.0" in lines


def test_py_spys_frames_of_waiting_threads_count_as_idle(tmp_path):
    from landing_bench.bench_loop import hot_functions
    (tmp_path / "tracker.txt").write_text(
        "Thread._bootstrap (threading.py:995);recv_buff (rospy/impl/tcpros_base.py:106) 60\n"
        "main (node.py:9);socket.accept (socket.py:294) 10\n"
        "main (node.py:9);Tracker.tick (platform_tracking/node.py:427) 30\n")
    hot = hot_functions(str(tmp_path))["tracker"]
    assert hot[0] == (0.7, "(idle)") and hot[1] == (0.3, "Tracker.tick (platform_tracking/node.py:427)")
