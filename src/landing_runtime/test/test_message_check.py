"""Checks of whole rospy messages against the node's clock (landing_runtime.message_check)."""
import math

import pytest

rospy = pytest.importorskip("rospy")
from nav_msgs.msg import Odometry  # noqa: E402
from sensor_msgs.msg import Range  # noqa: E402

from landing_runtime.message_check import odometry_problem, sonar_problem, stamp_of  # noqa: E402


@pytest.fixture(autouse=True)
def clock(monkeypatch):
    monkeypatch.setattr(rospy, "get_time", lambda: 10.0)


def odometry(frame="world", stamp=10.0, x=0.0, vx=0.0):
    msg = Odometry()
    msg.header.frame_id, msg.header.stamp = frame, rospy.Time.from_sec(stamp)
    msg.pose.pose.position.x, msg.twist.twist.linear.x = x, vx
    return msg


def test_an_odometry_in_the_world_now_with_plausible_numbers_passes():
    assert odometry_problem(odometry()) is None
    assert odometry_problem(odometry(frame="ardrone/base_link"))[0] == "wrong frame"
    assert odometry_problem(odometry(stamp=500.0))[0] == "stamp from the future"
    assert odometry_problem(odometry(x=1e30))[0] == "out of range"
    assert odometry_problem(odometry(vx=math.nan))[0] == "non-finite"


def test_a_sonar_range_may_be_inf_not_nan_or_negative_and_is_in_the_body_frame():
    msg = Range(range=math.inf)
    msg.header.frame_id, msg.header.stamp = "ardrone/base_link", rospy.Time.from_sec(10.0)
    assert sonar_problem(msg, "ardrone/base_link") is None
    assert sonar_problem(msg, "other")[0] == "wrong frame"
    msg.range = -1.0
    assert sonar_problem(msg, "ardrone/base_link") == ("out of range", "range is -1.0")
    msg.range = math.nan
    assert sonar_problem(msg, "ardrone/base_link")[0] == "non-finite"


def test_an_empty_stamp_is_now():
    assert stamp_of(odometry(stamp=0.0)) == 10.0 and stamp_of(odometry(stamp=9.5)) == 9.5
