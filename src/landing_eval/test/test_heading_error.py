"""landing_eval.heading_error on bags written here with rosbag: the published and the IMU's yaw against the truth."""
import math

import pytest
import rosbag
import rospy
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import Imu

from landing_eval.heading_error import HeadingError, heading_errors, main


def quaternion(msg_orientation, yaw):
    msg_orientation.w, msg_orientation.z = math.cos(yaw / 2), math.sin(yaw / 2)


def write_bag(path, seconds=10.0, imu_offset=0.2, estimate_offset=0.01, with_imu=True):
    """The drone turning at 0.5 rad/s through +-pi (the unwrapping is tested too); the IMU ``imu_offset`` and the
    estimate ``estimate_offset`` [rad] off the truth."""
    with rosbag.Bag(path, "w") as bag:
        for k in range(int(seconds * 50)):
            t = k / 50.0
            stamp = rospy.Time.from_sec(100.0 + t)
            yaw = 3.0 + 0.5 * t
            truth, estimate, imu = PoseStamped(), Odometry(), Imu()
            for msg in (truth, estimate, imu):
                msg.header.stamp = stamp
            quaternion(truth.pose.orientation, yaw)
            quaternion(estimate.pose.pose.orientation, yaw + estimate_offset)
            quaternion(imu.orientation, yaw + imu_offset)
            bag.write("/groundtruth/ardrone", truth, stamp)
            bag.write("/ardrone/odom_estimate", estimate, stamp)
            if with_imu:
                bag.write("/ardrone/imu", imu, stamp)


def test_the_published_and_the_imus_yaw_against_the_truth(tmp_path, capsys):
    path = str(tmp_path / "flight_0.bag")
    write_bag(path)
    start, end, (mean, low, high), imu = heading_errors(path)
    assert (start, end) == pytest.approx((100.0, 109.98), abs=0.5)
    assert (mean, low, high) == pytest.approx([math.degrees(0.01)] * 3, abs=0.05)
    assert imu == pytest.approx(math.degrees(0.2), abs=0.05)
    assert main([path]) == 0
    assert "within +0.6..+0.6 deg" in capsys.readouterr().out


def test_a_bag_without_the_imu_or_that_does_not_exist_is_named_and_the_others_still_read(tmp_path, capsys):
    good, without_imu = str(tmp_path / "good.bag"), str(tmp_path / "no_imu.bag")
    write_bag(good)
    write_bag(without_imu, with_imu=False)
    with pytest.raises(HeadingError, match="no /ardrone/imu messages"):
        heading_errors(without_imu)
    with pytest.raises(HeadingError, match="cannot read .*missing.bag"):
        heading_errors(str(tmp_path / "missing.bag"))
    assert main([without_imu, good]) == 2
    captured = capsys.readouterr()
    assert "no_imu.bag has no /ardrone/imu" in captured.err
    assert "good.bag | 100-110" in captured.out
