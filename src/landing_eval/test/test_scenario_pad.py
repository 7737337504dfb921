"""The scenario's pad (SPEC section 7: red_square | apriltag): validation, and the launch argument that picks the
simulator's pad and the detector."""
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
from landing_eval import runner, scenario  # noqa: E402


def write(tmp_path, text, name="s.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def launch_args(s):
    return dict(a.split(":=", 1) for a in runner.launch_arguments(s))


def test_the_pad_is_the_red_square_unless_the_scenario_names_another(tmp_path):
    s = scenario.load(write(tmp_path, "name: plain\n"))
    assert s["pad"] == "red_square"
    assert launch_args(s)["pad"] == "red_square"


def test_the_apriltag_pad_reaches_the_launch(tmp_path):
    s = scenario.load(write(tmp_path, "name: tags\npad: apriltag\nplatform: {vehicle: summit_xl, path: straight}\n"))
    assert s["pad"] == "apriltag"
    assert launch_args(s)["pad"] == "apriltag"


@pytest.mark.parametrize("value", ["aruco", "AprilTag", "{family: tag36h11}", "''", "1"])
def test_an_unknown_pad_is_refused_naming_the_file_the_field_and_the_choices(tmp_path, value):
    path = write(tmp_path, "name: a\npad: %s\n" % value)
    with pytest.raises(scenario.ScenarioError) as err:
        scenario.load(path)
    message = str(err.value)
    assert path in message and "field 'pad'" in message and "red_square, apriltag" in message


def test_the_scenario_simulator_and_launch_files_agree_on_the_pads():
    from mujoco_sim import pads
    assert scenario.PADS == pads.PADS
    here = os.path.dirname(os.path.abspath(__file__))
    launches = [os.path.join(here, "..", "..", "mujoco_sim", "launch", "sim.launch"),
                os.path.join(here, "..", "..", "uav_vision", "launch", "platform_detection.launch")]
    for launch in launches:
        with open(launch) as stream:
            text = stream.read()
        # The check that refuses an unknown pad names exactly these choices.
        assert "in ('red_square', 'apriltag')" in text, launch
