"""The warm graph's pure parts: the parameter tree a reset sets, which launches can share a graph, the time origin
read from the simulator's reply (the graph itself is flown in tests/test_warm_graph.py)."""
import os

import pytest

from landing_eval import warm_graph
from landing_eval.runner import launch_arguments
from landing_eval import scenario as scenario_mod

SCENARIO = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "scenarios",
                        "summit_circle_1ms.yaml")


class _Param:
    def __init__(self, value):
        self.value = value


class _Config:
    def __init__(self, params):
        self.params = {key: _Param(value) for key, value in params.items()}


def test_parameter_tree_replaces_everything_but_what_roslaunch_wrote_itself():
    config = _Config({"/use_sim_time": True, "/supervisor/answer_timeout_s": 15.0, "/mujoco_sim/camera/rate": 30.0})
    tree = warm_graph.parameter_tree(config, {"run_id": "abc", "roslaunch": {"uris": {"host": "http://x"}}})
    assert tree == {"run_id": "abc", "roslaunch": {"uris": {"host": "http://x"}}, "use_sim_time": True,
                    "supervisor": {"answer_timeout_s": 15.0}, "mujoco_sim": {"camera": {"rate": 30.0}}}


def test_time_origin_is_read_from_the_reply_and_its_absence_is_an_error():
    reply = "world reset: seed 3, vehicle summit_xl, realism realistic; its time 0 is ROS time 41.204 s, held until"
    assert warm_graph.time_origin(reply) == pytest.approx(41.204)
    with pytest.raises(warm_graph.ResetError, match="names no time origin"):
        warm_graph.time_origin("world reset")


def _launch(path, **changes):
    s = scenario_mod.load(path)
    for section, key, value in changes.get("items", []):
        s[section][key] = value
    return ["interface", "scenario.launch", "landing_stack:=true", "supervisor:=true"] + launch_arguments(s)


def test_scenarios_that_differ_in_parameters_share_a_graph_and_other_nodes_do_not():
    base = warm_graph.launch_config(_launch(SCENARIO))
    other_world = warm_graph.launch_config(_launch(SCENARIO, items=[("platform", "speed_mps", 3.0),
                                                                    ("platform", "vehicle", "car")]))
    assert warm_graph.node_signature(base) == warm_graph.node_signature(other_world)
    assert other_world.params["/summit_moves/speed"].value == 3.0
    with_station = warm_graph.launch_config(_launch(SCENARIO) + ["station:=true"])
    assert warm_graph.node_signature(base) != warm_graph.node_signature(with_station)
    assert "/mujoco_sim" in warm_graph.node_names(base) and "/supervisor" in warm_graph.node_names(base)


def test_a_process_never_starts_a_second_graph(tmp_path):
    graph = warm_graph.WarmGraph(str(tmp_path))
    config = warm_graph.launch_config(_launch(SCENARIO))

    def fails(_stack, _log_dir):
        raise RuntimeError("no master")
    with pytest.raises(RuntimeError, match="no master"):
        graph.start(config, fails)
    with pytest.raises(warm_graph.GraphMismatch, match="gone"):
        graph.check_fits(config)
    with pytest.raises(warm_graph.GraphMismatch, match="one graph only"):
        graph.start(config, fails)
