"""The pre-flight check (ROS-free): every item passes on healthy inputs, and each missing one blocks alone."""
import pytest

from interface.preflight import PreflightCheck

SETTINGS = {"window_s": 2.0, "topics": {"drone/navdata": 20.0, "ardrone/imu": 20.0},
            "fix_topics": ["ardrone/gps/fix"], "camera_info_topic": "ardrone/bottom/camera_info",
            "camera_status_topic": "ardrone_adapter/status", "min_battery_percent": 50.0, "max_link_latency_s": 0.25}


def healthy(now=10.0, skip=()):
    check = PreflightCheck(SETTINGS)
    for topic in SETTINGS["topics"]:
        if topic not in skip:
            for i in range(100):
                check.arrived(topic, now - 2.0 + i * 0.02)
    if "fix" not in skip:
        check.fix("ardrone/gps/fix", 0)
    if "calibration" not in skip:
        check.calibration(180.0, [-0.2, 0.04, 0.0, 0.0, 0.0])
    if "camera" not in skip:
        check.camera_selection("bottom camera: selected; altd unit: not yet checked (in flight)")
    if "navdata" not in skip:
        for _ in range(10):
            check.navdata(87.0, 0.05)
    return check


def failed(check, now=10.0):
    return [item.name for item in check.items(now) if not item.ok]


def test_healthy_inputs_pass_every_item():
    assert failed(healthy()) == []


@pytest.mark.parametrize("skip, item", [
    ("drone/navdata", "drone/navdata alive"), ("ardrone/imu", "ardrone/imu alive"), ("fix", "ardrone/gps/fix fix"),
    ("calibration", "camera calibrated"), ("camera", "bottom camera selected")])
def test_each_missing_input_blocks_alone_and_says_what_to_do(skip, item):
    check = healthy(skip=(skip,))
    assert item in failed(check)
    line = [i for i in check.items(10.0) if i.name == item][0].line()
    assert " -- " in line  # what is wrong -- what to do


def test_a_slow_topic_a_lost_fix_an_uncalibrated_camera_a_low_battery_and_a_slow_link_each_block():
    check = healthy()
    check.fix("ardrone/gps/fix", -1)
    check.calibration(0.0, [])
    for _ in range(50):
        check.navdata(30.0, 0.6)
    assert set(failed(check)) == {"ardrone/gps/fix fix", "camera calibrated", "battery", "link latency"}
    assert set(failed(check, now=13.0)) >= {"drone/navdata alive", "ardrone/imu alive"}  # silent for 3 s
    assert "30 % < 50 %" in [i for i in check.items(10.0) if i.name == "battery"][0].problem


def test_the_camera_selection_item_is_left_out_for_a_drone_without_one():
    check = PreflightCheck(dict(SETTINGS, camera_status_topic=""))
    assert "bottom camera selected" not in [item.name for item in check.items(0.0)]
