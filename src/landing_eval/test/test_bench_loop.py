"""bench_loop's arithmetic (ROS-free): CPU per sim second from the run's resource samples, and the bound it sets."""
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
from landing_eval.bench_loop import (cpu_bound, node_cpu_per_sim_second, parallel_gain_bound,  # noqa: E402
                                     simulator_shares, stepping_cpu)
from landing_eval.bus_stats import deliveries_per_sim_second, published_counts  # noqa: E402


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
