#!/usr/bin/env python3
"""rostest of the platform_detection node's ~reset (std_srvs/Trigger), the node alone, fed by this test
(wall-clock time, as node_inputs_rostest.py whose synthetic frames and messages it uses).

After a reset the node is a fresh one: a frame whose sensors it had before the reset is dropped for want of
camera_info, then of an IMU attitude, then of a height, as a fresh node drops it, and detected once they come
again. A parameter changed before a reset is in force after it (the base frame of the relative fixes); a bad or
missing one refuses the reset, naming it, and the node goes on with its settings and histories."""
import functools
import unittest

import rospy
import rostest
from geometry_msgs.msg import PointStamped
from landing_msgs.msg import Altimeter
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import CameraInfo, Image, Imu, Range
from std_srvs.srv import Trigger
from landing_runtime import testing
from node_inputs_rostest import CAMERA_HEIGHT, PAD_TOP, camera_info, image_msg, pad_image

NODE = "/platform_detection"
IMAGE_TOPIC = "/ardrone/bottom/image_raw"
NEW_BASE = "ardrone/base_link_after_reset"
WALL_TIMEOUT = 60.0
RESEND_PERIOD = 0.2  # messages travel on separate connections: what depends on several is sent again [s]
# Stamps of a frame and its sensors this far ahead of the clock: the node still takes them (0.5 s at most,
# landing_runtime/input_check.h) and they stay fresh enough (2 s) for the checks after a reset [s].
AHEAD = 0.3

wait_for = functools.partial(testing.wait_for, timeout=WALL_TIMEOUT)


class NodeResetTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("node_reset_test")
        cls.points, cls.warnings, cls.infos = [], [], []
        rospy.Subscriber("/platform/current_platform_position_in_ardrone", PointStamped, cls.points.append)
        rospy.Subscriber("/rosout", Log, cls._on_log, queue_size=100)
        cls.pub = {
            "image": rospy.Publisher(IMAGE_TOPIC, Image, queue_size=5),
            "info": rospy.Publisher("/ardrone/bottom/camera_info", CameraInfo, queue_size=5),
            "imu": rospy.Publisher("/ardrone/imu", Imu, queue_size=5),
            "sonar": rospy.Publisher("/ardrone/sonar_height", Range, queue_size=5),
            "altimeter": rospy.Publisher("/ardrone/altimeter", Altimeter, queue_size=5),
            "odom": rospy.Publisher("/ardrone/odom_estimate", Odometry, queue_size=5),
        }
        for pub in cls.pub.values():
            wait_for(lambda p=pub: p.get_num_connections() > 0, "platform_detection to subscribe to " + pub.name)
        rospy.wait_for_service(NODE + "/reset", timeout=WALL_TIMEOUT)
        cls.reset_service = rospy.ServiceProxy(NODE + "/reset", Trigger)
        cls.launched = {key: rospy.get_param(NODE + "/" + key)
                        for key in ("frames/base", "timing/odom_timeout", "shape/min_area_px")}

    @classmethod
    def _on_log(cls, msg):
        if msg.name != NODE:
            return
        (cls.warnings if msg.level >= Log.WARN else cls.infos).append(msg.msg)

    def reset(self):
        response = self.reset_service()
        return response.success, response.message

    def publish(self, stamp, info=False, imu=False, height=False, base=None):
        if info:
            self.pub["info"].publish(camera_info(stamp))
        if imu:
            msg = Imu()
            msg.header.stamp, msg.header.frame_id = stamp, base or self.launched["frames/base"]
            msg.orientation.w = 1.0
            self.pub["imu"].publish(msg)
        if height:
            sonar = Range(range=CAMERA_HEIGHT - 0.03, min_range=0.02, max_range=6.0)
            sonar.header.stamp = stamp
            self.pub["sonar"].publish(sonar)
            altimeter = Altimeter(altitude=CAMERA_HEIGHT + 0.035 + PAD_TOP)
            altimeter.header.stamp = stamp
            self.pub["altimeter"].publish(altimeter)

    def resend_frame_until(self, stamp, condition, what):
        frame = image_msg(stamp, pad_image())
        return testing.resend_until(lambda: self.pub["image"].publish(frame), condition, what, WALL_TIMEOUT,
                                    RESEND_PERIOD)

    def detect(self, stamp):
        """The pad position of a frame stamped ``stamp``, published after this call."""
        start = len(self.points)
        return self.resend_frame_until(
            stamp, lambda: [p for p in self.points[start:] if p.header.stamp == stamp],
            "the pad position of the frame stamped %.3f" % stamp.to_sec())[0]

    def expect_dropped(self, stamp, *words):
        """The frame stamped ``stamp`` is dropped with a warning containing ``words`` (and not detected)."""
        start, points = len(self.warnings), len(self.points)

        def detected():
            return [p for p in self.points[points:] if p.header.stamp == stamp]
        # A detection ends the wait at once: the node still had what it should have forgotten.
        self.resend_frame_until(stamp, lambda: detected() or any(all(w in m for w in words)
                                                                 for m in self.warnings[start:]),
                                "a warning with %s for the frame" % (words,))
        self.assertEqual(detected(), [], "the frame was detected: the node still had what it should have forgotten")

    def test_1_reset_empties_every_history(self):
        stamp = rospy.Time.now() + rospy.Duration(AHEAD)
        self.publish(stamp, info=True, imu=True, height=True)
        self.detect(stamp)  # the node holds camera_info and the readings of `stamp`

        success, message = self.reset()
        self.assertTrue(success, message)
        self.assertEqual(message, NODE + " reset")
        wait_for(lambda: any(m.startswith(NODE + " reset") for m in self.infos), "the node's log of the reset")

        # As a fresh node: the same frame lacks, in turn, the camera's calibration, the attitude, the height.
        self.expect_dropped(stamp, IMAGE_TOPIC, "no valid /ardrone/bottom/camera_info yet")
        self.publish(stamp, info=True)
        self.expect_dropped(stamp, IMAGE_TOPIC, "no /ardrone/imu within")
        self.publish(stamp, imu=True)
        self.expect_dropped(stamp, IMAGE_TOPIC, "no /ardrone/sonar_height or /ardrone/altimeter within")
        self.publish(stamp, height=True)
        point = self.detect(stamp)
        self.assertEqual(point.header.frame_id, self.launched["frames/base"])
        self.assertAlmostEqual(point.point.z, -(CAMERA_HEIGHT + 0.035), delta=0.02)

    def test_2_changed_parameter_is_in_force_after_a_reset(self):
        rospy.set_param(NODE + "/frames/base", NEW_BASE)
        success, message = self.reset()
        self.assertTrue(success, message)
        stamp = rospy.Time.now() + rospy.Duration(AHEAD)
        self.publish(stamp, info=True, imu=True, height=True, base=NEW_BASE)
        self.assertEqual(self.detect(stamp).header.frame_id, NEW_BASE)

    def test_3_bad_parameter_refuses_the_reset_and_the_node_goes_on(self):
        stamp = rospy.Time.now() + rospy.Duration(AHEAD)
        self.publish(stamp, info=True, imu=True, height=True, base=NEW_BASE)
        self.detect(stamp)

        rospy.set_param(NODE + "/timing/odom_timeout", -1.0)
        success, message = self.reset()
        self.assertFalse(success)
        self.assertIn(NODE + "/timing/odom_timeout", message)
        self.assertIn("must be a positive number", message)
        rospy.set_param(NODE + "/timing/odom_timeout", self.launched["timing/odom_timeout"])
        rospy.delete_param(NODE + "/shape/min_area_px")
        success, message = self.reset()
        self.assertFalse(success)
        self.assertIn(NODE + "/shape/min_area_px", message)
        self.assertIn("missing", message)
        wait_for(lambda: any("not reset" in m and "min_area_px" in m for m in self.warnings),
                 "the node's log of the refused reset")

        # As it was: the frame is detected again from the readings it had, in the base frame of test 2.
        self.assertEqual(self.detect(stamp).header.frame_id, NEW_BASE)

        # As launched again, for whatever runs next.
        rospy.set_param(NODE + "/shape/min_area_px", self.launched["shape/min_area_px"])
        rospy.set_param(NODE + "/frames/base", self.launched["frames/base"])
        success, message = self.reset()
        self.assertTrue(success, message)


if __name__ == "__main__":
    rostest.rosrun("uav_vision", "node_reset_rostest", NodeResetTest)
