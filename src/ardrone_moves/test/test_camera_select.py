"""Bottom camera selection at start-up (ROS-free state machine)."""
import os

import pytest
import yaml

from ardrone_moves.camera_select import BOTTOM_CHANNEL, BottomCameraSelect


def run(select, events, until, step=0.1):
    """Drive the node's loop: events maps a time to the driver's behaviour at that request."""
    now = 0.0
    while now <= until:
        if select.request_due:
            select.request_sent(now)
            answer = events.get(select.attempts, ("ok", None))
            if answer[0] in ("ok", "refuse"):
                select.service_answered(answer[0] == "ok", now + 0.05)
            if answer[1] is not None:
                select.frame_arrived(now + answer[1])
        status = select.tick(now)
        if status != "waiting":
            return status, now
        now = round(now + step, 6)
    return select.report(), now


def test_first_frame_after_an_accepted_request_selects_the_bottom_camera():
    select = BottomCameraSelect()
    assert select.request_due and select.channel == BOTTOM_CHANNEL == 1
    select.request_sent(0.0)
    assert not select.request_due and select.tick(1.0) == "waiting"
    select.service_answered(True, 0.1)
    select.frame_arrived(0.8)
    assert select.tick(0.9) == "selected" and select.attempts == 1


def test_no_frame_in_time_retries_then_succeeds():
    select = BottomCameraSelect(frame_timeout=3.0, max_attempts=3)
    status, when = run(select, {1: ("ok", None), 2: ("ok", 1.0)}, until=20.0)
    assert status == "selected" and select.attempts == 2 and 3.0 <= when < 5.0


def test_frames_never_arrive_fails_after_all_attempts_with_advice():
    select = BottomCameraSelect(frame_timeout=3.0, max_attempts=3)
    status, when = run(select, {}, until=30.0)
    assert status.startswith("failed: no frame on ardrone/bottom/image_raw within 3.0 s")
    assert "attempt 3 of 3" in status and "video" in status and select.attempts == 3
    assert 9.0 <= when <= 10.0  # three times the 3 s frame timeout, plus the polling
    select.frame_arrived(when + 1.0)  # too late: a failure is final until restart()
    assert select.tick(when + 1.0).startswith("failed")


def test_service_refusal_is_retried_then_reported():
    select = BottomCameraSelect(max_attempts=2)
    status, _ = run(select, {1: ("refuse", None), 2: ("refuse", None)}, until=10.0)
    assert status.startswith("failed: the driver refused") and "ardrone/setcamchannel" in status
    select.restart()
    assert select.request_due and select.tick(0.0) == "waiting"
    assert run(select, {1: ("refuse", None), 2: ("ok", 0.5)}, until=10.0)[0] == "selected"


def test_unanswered_service_times_out_and_a_late_answer_is_ignored():
    select = BottomCameraSelect(service_timeout=2.0, max_attempts=1)
    select.request_sent(0.0)
    assert select.tick(1.9) == "waiting"
    status = select.tick(2.0)
    assert status.startswith("failed: no answer from ardrone/setcamchannel") and "is running" in status
    select.service_answered(True, 2.5)
    assert select.tick(3.0) == status


def test_a_frame_proves_the_selection_even_when_the_answer_is_lost():
    select = BottomCameraSelect()
    select.frame_arrived(0.0)  # before any request: says nothing about our request
    assert select.tick(0.0) == "waiting"
    select.request_sent(1.0)
    select.frame_arrived(1.5)
    assert select.tick(1.6) == "selected"


def test_parameters_are_checked():
    with pytest.raises(ValueError, match="camera_frame_timeout"):
        BottomCameraSelect(frame_timeout=0.0)
    with pytest.raises(ValueError, match="camera_service_timeout"):
        BottomCameraSelect(service_timeout=-1.0)
    for attempts in (0, 1.5, None, float("nan")):
        with pytest.raises(ValueError, match="camera_select_attempts"):
            BottomCameraSelect(max_attempts=attempts)
    with pytest.raises(ValueError, match="camera_frame_timeout"):
        BottomCameraSelect(frame_timeout=float("inf"))


def test_shipped_config_values_are_accepted():
    config = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "config", "ardrone_adapter.yaml")
    with open(config) as stream:
        params = yaml.safe_load(stream)
    select = BottomCameraSelect(frame_timeout=params["camera_frame_timeout"],
                                service_timeout=params["camera_service_timeout"],
                                max_attempts=params["camera_select_attempts"])
    assert (select.frame_timeout, select.max_attempts) == (3.0, 3)
