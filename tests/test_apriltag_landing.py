"""The closed-loop landing on the AprilTag pad (issue 44): run_scenario flies the straight Summit XL scenario with
`pad: apriltag` in the realistic world, the red false target and the foreign pad (other tag ids) beside the vehicle
for most of the flight; the detector on libapriltag (uav_vision's detector: apriltag) must bring the drone down on
the pad."""
import json
import os
import subprocess

import pytest
import yaml

pytestmark = pytest.mark.slow

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
WALL_TIMEOUT_S = 600  # one flight of about 25 sim seconds; a loaded 2-core machine needs 1-2 min


def test_the_drone_lands_on_the_apriltag_pad_beside_a_foreign_pad_and_a_red_target(tmp_path):
    with open(os.path.join(ROOT, "scenarios", "false_target_straight_1ms.yaml")) as stream:
        scenario = yaml.safe_load(stream)
    scenario.update(name="apriltag_false_target_straight_1ms", pad="apriltag", time_limit_s=90.0)
    path = tmp_path / "apriltag.yaml"
    path.write_text(yaml.safe_dump(scenario))
    out = tmp_path / "out"
    run = subprocess.run(["rosrun", "landing_eval", "run_scenario", str(path), "--out", str(out)],
                         capture_output=True, text=True, timeout=WALL_TIMEOUT_S, stdin=subprocess.DEVNULL)
    result = json.loads((out / "result.json").read_text())
    assert result["pad"] == "apriltag"
    assert result["outcome"] == "landed_on_pad", run.stdout[-2000:] + run.stderr[-2000:]
    assert result["touchdown_error_m"] < 0.25

    import rosbag
    with rosbag.Bag(result["bag"]) as bag:
        detections = [m for _, m, _ in bag.read_messages(topics=["/platform/current_platform_position_in_ardrone"])]
        headings = [m for _, m, _ in bag.read_messages(topics=["/platform/current_indicator_position_in_ardrone"])]
    # The pad's topics as with the red square: its centre and its heading point, in base_link.
    assert len(detections) > 100 and len(headings) > 100
    assert all(m.header.frame_id == "ardrone/base_link" for m in detections[:50])
