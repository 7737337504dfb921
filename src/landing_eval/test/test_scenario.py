"""Scenario validation (ROS-free); the scoring of a flight is tested in flight_analysis (test_scoring.py)."""
import os
import sys

import pytest
import yaml

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
from landing_eval import scenario  # noqa: E402

SPEC_EXAMPLE = """
name: car_straight_10ms
seed: 7
time_limit_s: 180
platform: {vehicle: car, path: straight, speed_mps: 10.0, radius_m: 10.0}
drone: {start: on_pad}
conditions: {wind_speed: 2.0, wind_direction_deg: 90, gust_mps: 1.0, drone_battery: 80, control_battery: 50, temp: 15}
sensors: {camera_noise: 0.0, camera_fps: 30}
events:
  - {at_s: 25, fault: camera_blackout, duration_s: 2.0}
  - {at_s: 0, operator: landing}
  - {at_s: 20, set_param: drone_battery, value: 10}
"""


def write(tmp_path, text, name="s.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def test_the_spec_example_loads_with_events_sorted(tmp_path):
    s = scenario.load(write(tmp_path, SPEC_EXAMPLE))
    assert s["platform"] == {"vehicle": "car", "path": "straight", "speed_mps": 10.0, "radius_m": 10.0}
    assert s["conditions"]["wind_gust"] == 1.0 and s["seed"] == 7
    assert [e["at_s"] for e in s["events"]] == [0.0, 20.0, 25.0]
    assert s["events"][2] == {"at_s": 25.0, "fault": "camera_blackout", "duration_s": 2.0}


def test_minimal_scenario_gets_documented_defaults(tmp_path):
    s = scenario.load(write(tmp_path, "name: minimal\n"))
    assert s["platform"]["vehicle"] == "summit_xl" and s["drone"]["start"] == "on_pad"
    assert s["time_limit_s"] == 180.0 and s["events"] == [] and s["sensors"]["camera_fps"] == 30.0


def test_start_away_from_the_pad(tmp_path):
    s = scenario.load(write(tmp_path, "name: far\ndrone: {start: {x: -30.0, y: 5.0, z: 6.0}}\n"))
    assert s["drone"]["start"] == {"x": -30.0, "y": 5.0, "z": 6.0}


@pytest.mark.parametrize("text, message", [
    ("seed: 1\n", "field 'name' is required"),
    ("name: a\nplatform: {vehicle: bus}\n", "field 'platform.vehicle': expected one of summit_xl, car, got 'bus'"),
    ("name: a\nplatform: {speed_mps: fast}\n", "field 'platform.speed_mps': expected a number, got 'fast'"),
    ("name: a\nplatform: {vehicle: summit_xl, speed_mps: 10}\n", "platform.speed_mps': expected a value in [0, 3]"),
    ("name: a\nplatfrom: {}\n", "unknown field(s) platfrom"),
    ("name: a\nconditions: {wind: 3}\n", "unknown field(s) wind"),
    ("name: a\nevents: [{at_s: 1, operator: dance}]\n", "events[0].operator'"),
    ("name: a\nevents: [{operator: landing}]\n", "events[0].at_s': required"),
    ("name: a\nevents: [{at_s: 1, operator: landing, fault: kill_node}]\n", "exactly one of"),
    ("name: a\nevents: [{at_s: 1, fault: kill_node}]\n", "kill_node needs the node's name"),
    ("name: a\ndrone: {start: {x: 1, y: 2}}\n", "with x, y and z"),
    ("name: a\nexpect: {outcome: flew_away}\n", "field 'expect.outcome'"),
    ("name: [unclosed\n", "not valid YAML"),
])
def test_bad_fields_name_the_file_the_field_and_the_expectation(tmp_path, text, message):
    path = write(tmp_path, text)
    with pytest.raises(scenario.ScenarioError) as err:
        scenario.load(path)
    assert path in str(err.value) and message in str(err.value)


def test_missing_file():
    with pytest.raises(scenario.ScenarioError, match="nope.yaml: scenario file not found"):
        scenario.load("/tmp/nope.yaml")


def test_launch_arguments_carry_every_condition_of_the_scenario(tmp_path):
    from landing_eval import runner
    text = SPEC_EXAMPLE.replace("temp: 15}", "temp: 15, drone_speed: 18.0}")
    args = dict(a.split(":=", 1) for a in runner.launch_arguments(scenario.load(write(tmp_path, text))))
    assert args["vehicle"] == "car" and args["speed"] == "10.0" and args["seed"] == "7"
    assert args["wind_speed"] == "2.0" and args["wind_gust"] == "1.0" and args["drone_speed"] == "18.0"
    assert "drone_speed" not in dict(a.split(":=", 1) for a in runner.launch_arguments(
        scenario.load(write(tmp_path, SPEC_EXAMPLE, "plain.yaml"))))


def test_px4_quad_is_a_drone_model_and_pilot_takeover_a_fault_of_it_only():
    s = scenario.validate({"name": "p", "platform": {"vehicle": "car", "speed_mps": 10.0},
                           "drone": {"model": "px4_quad"},
                           "events": [{"at_s": 30, "fault": "pilot_takeover"}]}, "f.yaml")
    assert s["drone"]["model"] == "px4_quad" and s["events"][0]["fault"] == "pilot_takeover"
    assert scenario.validate({"name": "c", "platform": {"vehicle": "car"}}, "f.yaml")["drone"]["model"] == \
        "velocity_quad"                                          # the car's default is unchanged
    with pytest.raises(scenario.ScenarioError, match="pilot_takeover needs drone: {model: px4_quad}"):
        scenario.validate({"name": "v", "events": [{"at_s": 3, "fault": "pilot_takeover"}]}, "f.yaml")
