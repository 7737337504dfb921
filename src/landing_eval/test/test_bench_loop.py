"""bench_loop's arithmetic (ROS-free): CPU per sim second from the run's resource samples, and the bound it sets."""
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
from landing_eval.bench_loop import cpu_bound, node_cpu_per_sim_second, parallel_gain_bound  # noqa: E402


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
