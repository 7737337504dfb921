"""ROS-free tests of the lock-step gate: who blocks the simulator, when, and when it gives up waiting."""
import pytest

from mujoco_sim.lockstep import LockstepGate

IMAGE = "/ardrone/bottom/image_raw"


def gate(**kwargs):
    lines = []
    return LockstepGate(kwargs.get("max_lead", 0.05), kwargs.get("stale_after_wall", 1.0), log=lines.append), lines


def test_nobody_acknowledges_nothing_blocks():
    g, _ = gate()
    g.published(IMAGE, 0.0)
    assert g.blocker(10.0, 0.0) is None
    assert not g.waits_for(IMAGE)


def test_timer_sender_may_lag_one_period_plus_the_lead():
    g, lines = gate()
    g.acknowledge("/tracker", "/clock", 1.0, period=1.0 / 30)
    assert "waiting for /tracker on /clock" in lines[0]
    assert g.blocker(1.0 + 1.0 / 30 + 0.05, 0.0) is None
    blocker = g.blocker(1.0 + 1.0 / 30 + 0.06, 0.0)
    assert blocker.node == "/tracker" and blocker.input == "/clock"
    assert blocker.lag == pytest.approx(0.06)
    g.acknowledge("/tracker", "/clock", 1.0 + 1.0 / 30, period=1.0 / 30)
    assert g.blocker(1.0 + 1.0 / 30 + 0.06, 0.0) is None


def test_topic_sender_blocks_only_on_an_old_unacknowledged_message():
    g, _ = gate()
    g.acknowledge("/detector", IMAGE, 0.0)
    assert g.waits_for(IMAGE)
    g.published(IMAGE, 1.0)
    assert g.blocker(1.05, 0.0) is None          # the frame is young: keep stepping
    assert g.blocker(1.06, 0.0).node == "/detector"
    g.acknowledge("/detector", IMAGE, 1.0)
    assert g.blocker(1.06, 0.0) is None
    # Nothing published (camera blackout): nothing to wait for however far time runs.
    assert g.blocker(30.0, 0.0) is None


def test_a_skipped_frame_is_covered_by_a_later_acknowledgement():
    g, _ = gate()
    g.acknowledge("/detector", IMAGE, 0.0)
    for stamp in (1.0, 1.033, 1.066):
        g.published(IMAGE, stamp)
    g.acknowledge("/detector", IMAGE, 1.066)  # queue of one: it only ever saw the newest frame
    assert g.blocker(1.2, 0.0) is None


def test_the_slowest_of_two_senders_on_one_topic_blocks():
    g, _ = gate()
    g.acknowledge("/fast", IMAGE, 0.0)
    g.acknowledge("/slow", IMAGE, 0.0)
    g.published(IMAGE, 1.0)
    g.acknowledge("/fast", IMAGE, 1.0)
    assert g.blocker(1.1, 0.0).node == "/slow"
    g.acknowledge("/slow", IMAGE, 1.0)
    assert g.blocker(1.1, 0.0) is None


def test_a_dead_sender_is_dropped_after_the_wall_timeout_and_comes_back_when_it_acknowledges():
    g, lines = gate(stale_after_wall=1.0)
    g.acknowledge("/detector", "/clock", 1.0, period=0.05)
    assert g.blocker(2.0, wall_time=100.0) is not None
    assert g.blocker(2.0, wall_time=100.9) is not None
    assert g.blocker(2.0, wall_time=101.1) is None  # given up
    assert "no longer waiting for it" in lines[-1]
    assert g.blocker(5.0, wall_time=102.0) is None
    g.acknowledge("/detector", "/clock", 5.0, period=0.05)  # respawned
    assert g.blocker(6.0, wall_time=103.0) is not None


def test_waiting_time_restarts_after_the_sender_catches_up():
    g, _ = gate(stale_after_wall=1.0)
    g.acknowledge("/tracker", "/clock", 1.0, period=0.05)
    assert g.blocker(1.2, wall_time=10.0) is not None
    g.acknowledge("/tracker", "/clock", 1.2, period=0.05)
    assert g.blocker(1.2, wall_time=10.8) is None
    assert g.blocker(1.4, wall_time=11.5) is not None  # blocked again: a new wait, not 1.5 s old
    assert g.blocker(1.4, wall_time=12.0) is not None


def test_invalid_settings_are_refused():
    with pytest.raises(ValueError):
        LockstepGate(0.0, 1.0)
    with pytest.raises(ValueError):
        LockstepGate(0.05, -1.0)
