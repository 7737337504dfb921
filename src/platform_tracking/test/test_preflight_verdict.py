"""The tracker holds a take-off on the pre-flight check's word, and only on a recent one: a verdict older than
preflight_max_age (the check's node died or hangs) blocks like no verdict at all."""
import types

import pytest

pytest.importorskip("rospy")
from platform_tracking.node import NO_PREFLIGHT, TrackingNode  # noqa: E402
from platform_tracking.params import TrackingParams  # noqa: E402


def _node(heard_at, blocks, require=True):
    return types.SimpleNamespace(params=TrackingParams(require_preflight=require, preflight_max_age=3.0),
                                 preflight_heard_at=heard_at, preflight_blocks=blocks)


def blocked(node, t):
    return TrackingNode._takeoff_blocked(node, t)


def test_no_verdict_blocks_and_a_recent_one_decides():
    assert blocked(_node(None, NO_PREFLIGHT), 10.0) == NO_PREFLIGHT
    assert blocked(_node(9.5, None), 10.0) is None                                 # ready, 0.5 s ago
    assert blocked(_node(9.5, "camera: no frames"), 10.0) == "camera: no frames"   # not ready


def test_a_ready_verdict_from_a_dead_check_no_longer_lets_the_drone_go():
    reason = blocked(_node(5.0, None), 10.0)
    assert reason is not None and "5.0 s old" in reason and "preflight node" in reason


def test_without_require_preflight_nothing_blocks():
    assert blocked(_node(None, None, require=False), 10.0) is None
