"""The thin nodes without a ROS master: parameter errors are named, non-finite inputs are
dropped with a warning naming the topic, the node's own take-off/land messages are ignored, and the
prediction is assembled from the path and the pad odometry."""
import threading
import types

import pytest

rospy = pytest.importorskip("rospy")
from geometry_msgs.msg import PoseStamped  # noqa: E402
from nav_msgs.msg import Odometry, Path  # noqa: E402
from std_msgs.msg import Empty, String  # noqa: E402

from landing_runtime.input_check import RosRejectionLog  # noqa: E402
from landing_runtime.params import ParamError, load_params  # noqa: E402
from platform_tracking import node  # noqa: E402
from platform_tracking.params import TrackingParams  # noqa: E402


@pytest.fixture
def fake_ros(monkeypatch):
    """rospy's parameter, logging and time functions replaced by recorders."""
    log = {"fatal": [], "warn": [], "info": []}
    params = {}
    monkeypatch.setattr(rospy, "get_param", lambda name, default=None: dict(params) if name == "~" else default)
    monkeypatch.setattr(rospy, "get_name", lambda: "/platform_tracking")
    monkeypatch.setattr(rospy, "logfatal", lambda fmt, *a: log["fatal"].append(fmt % a))
    monkeypatch.setattr(rospy, "logwarn", lambda fmt, *a: log["warn"].append(fmt % a))
    monkeypatch.setattr(rospy, "logwarn_throttle", lambda period, text: log["warn"].append(text))
    monkeypatch.setattr(rospy, "loginfo", lambda fmt, *a: log["info"].append(fmt % a))
    monkeypatch.setattr(rospy, "get_time", lambda: 10.0)
    monkeypatch.setattr(rospy, "resolve_name", lambda name: "/" + name)
    return types.SimpleNamespace(log=log, params=params)


def test_a_missing_parameter_is_named(fake_ros):
    """(A ParamError: run_node makes it fatal at start-up, ResettableNode a refused ~reset.)"""
    import dataclasses
    fake_ros.params.update({f.name: f.default for f in dataclasses.fields(TrackingParams)})
    del fake_ros.params["lost_timeout"]
    missing = r"required parameter 'lost_timeout' is missing .*\(see platform_tracking/config/\)"
    with pytest.raises(ParamError, match=missing):
        load_params(TrackingParams, check=True, see=node.CONFIG)


def test_complete_parameters_load(fake_ros):
    import dataclasses
    fake_ros.params.update({f.name: f.default for f in dataclasses.fields(TrackingParams)})
    assert load_params(TrackingParams, check=True, see=node.CONFIG) == TrackingParams()


def bare_tracking_node():
    """A TrackingNode without publishers and subscribers (no master needed)."""
    n = node.TrackingNode.__new__(node.TrackingNode)
    n.lock = threading.Lock()
    n.requests, n.path, n.pad_odom, n.prediction, n.estimate = [], None, None, None, None
    n.rejections = RosRejectionLog()
    n.me = "/platform_tracking"
    return n


def pose(t, x):
    p = PoseStamped()
    p.header.stamp = rospy.Time.from_sec(t)
    p.pose.position.x = x
    return p


def test_non_finite_inputs_are_dropped_with_a_warning_naming_the_topic(fake_ros):
    n = bare_tracking_node()
    path = Path()
    path.header.frame_id = "world"
    path.poses = [pose(1.0, 0.0), pose(1.1, float("nan"))]
    n.on_path(path)
    assert n.path is None and "/kalman_prediction_path" in fake_ros.log["warn"][-1]
    odom = Odometry()
    odom.header.frame_id = "world"
    odom.twist.twist.linear.x = float("inf")
    n.on_pad_odom(odom)
    assert n.pad_odom is None and "/kalman_platform_odom" in fake_ros.log["warn"][-1]
    odom.twist.twist.linear.x = 0.0
    odom.pose.pose.orientation.w = float("nan")
    n.on_estimate(odom)
    assert n.estimate is None and "/ardrone/odom_estimate" in fake_ros.log["warn"][-1]


def test_a_path_in_another_frame_is_dropped(fake_ros):
    n = bare_tracking_node()
    path = Path()
    path.header.frame_id = "ardrone/base_link"
    path.poses = [pose(1.0, 0.0)]
    n.on_path(path)
    assert n.path is None and "expected 'world'" in fake_ros.log["warn"][-1]


def test_own_takeoff_and_land_messages_are_ignored_others_are_requests(fake_ros):
    n = bare_tracking_node()
    own = Empty()
    own._connection_header = {"callerid": "/platform_tracking"}
    n.on_thesis_request(own, "takeoff")
    assert n.requests == []
    other = Empty()
    other._connection_header = {"callerid": "/operator_console"}
    n.on_thesis_request(other, "land")
    assert n.requests == ["land"]


def test_operator_commands(fake_ros):
    n = bare_tracking_node()
    n.on_command(String(data="force_land"))
    n.on_command(String(data="Takeoff "))
    n.on_command(String(data="jump"))
    assert n.requests == ["force_land", "takeoff"]
    assert "/platform_tracking/command [unknown value]: command 'jump'" in fake_ros.log["warn"][-1]


def test_garbage_is_dropped_once_per_topic_and_kind_with_what_was_wrong(fake_ros):
    n = bare_tracking_node()
    for _ in range(5):
        n.on_command(String(data="jump"))
    odom = Odometry()
    odom.header.frame_id = "world"
    odom.header.stamp = rospy.Time.from_sec(500.0)  # the clock says 10 s
    n.on_pad_odom(odom)
    odom.header.stamp = rospy.Time.from_sec(10.0)
    odom.pose.pose.position.x = 1e30
    n.on_pad_odom(odom)
    assert n.pad_odom is None and n.requests == []
    assert len([w for w in fake_ros.log["warn"] if "command 'jump'" in w]) == 1
    assert any("/kalman_platform_odom [stamp from the future]" in w for w in fake_ros.log["warn"])
    assert any("/kalman_platform_odom [out of range]: position[0] = 1e+30" in w for w in fake_ros.log["warn"])


def test_a_hold_cancels_the_requests_before_it(fake_ros):
    n = bare_tracking_node()
    n.machine = node.TrackingStateMachine(TrackingParams())
    n.on_command(String(data="takeoff"))
    n.on_command(String(data="hold"))
    n.on_command(String(data="land"))
    n.machine.takeoff_pending = True  # a take-off the machine was still waiting to act on
    assert n._take_requests() == ["land"] and not n.machine.takeoff_pending and n.requests == []


def test_prediction_assembly_from_path_and_odometry():
    times, positions = [1.0, 1.1, 1.2], [(0.0, 0, 0.5), (0.1, 0, 0.5), (0.2, 0, 0.5)]
    from_path = node.build_prediction((times, positions), None)
    assert from_path.stamp == 1.0 and from_path.velocity[0] == pytest.approx(1.0)
    both = node.build_prediction((times, positions), (1.0, (0.0, 0, 0.5), (0.9, 0.0, 0.0)))
    assert both.velocity[0] == pytest.approx(0.9) and both.position_at(1.2)[0] == pytest.approx(0.2)
    odom_only = node.build_prediction((times, positions), (2.0, (1.0, 0, 0.5), (1.0, 0.0, 0.0)))
    assert odom_only.stamp == 2.0 and odom_only.path_times == []
    assert node.build_prediction(None, None) is None
