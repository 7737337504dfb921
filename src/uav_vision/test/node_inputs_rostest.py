#!/usr/bin/env python3
"""rostest of the platform_detection node alone, fed by this test: a synthetic frame gives the expected
pad position; bad inputs (empty or odd-sized image, wrong encoding, zero focal length, malformed lens
distortion, NaN IMU, sonar, altimeter, odometry) are dropped with a warning naming the topic and the node
keeps working; a distorted frame is undistorted with camera_info's D; a frame that arrives late is
measured with the sonar and barometer readings of its capture time; the debug image comes when
subscribed; a missing parameter stops the node with a message naming it."""
import functools
import os
import subprocess
import unittest

import cv2
import numpy as np
import rospy
import rostest
from geometry_msgs.msg import PointStamped
from landing_msgs.msg import Altimeter
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import CameraInfo, Image, Imu, Range
from landing_runtime import testing

WALL_TIMEOUT = 60.0
FX = 256.0
SIDE_PX = 100                      # the pad's side in the synthetic image
CAMERA_HEIGHT = FX * 1.0 / SIDE_PX  # camera height above the pad that makes a 1 m pad 100 px wide [m]
PAD_TOP = 0.497


wait_for = functools.partial(testing.wait_for, timeout=WALL_TIMEOUT)
resend_until = functools.partial(testing.resend_until, timeout=WALL_TIMEOUT)


def pad_image(width=320, height=240, right=20, down=0):
    """Grey ground with a red 1 m pad centred ``right`` px right of the image centre, ``down`` px below, rgb8."""
    image = np.full((height, width, 3), (110, 112, 108), np.uint8)
    cx, cy = (width - 1) / 2.0 + right, (height - 1) / 2.0 + down
    x0, y0 = int(round(cx - SIDE_PX / 2 + 0.5)), int(round(cy - SIDE_PX / 2 + 0.5))
    image[y0:y0 + SIDE_PX, x0:x0 + SIDE_PX] = (217, 38, 38)
    return image


def image_msg(stamp, array=None, encoding="rgb8", width=None, height=None, step=None, data=None):
    msg = Image()
    msg.header.stamp, msg.header.frame_id = stamp, "ardrone/bottom_camera"
    if array is not None:
        msg.height, msg.width = array.shape[:2]
        msg.step, msg.data = array.shape[1] * array.shape[2], array.tobytes()
    msg.encoding = encoding
    if width is not None:
        msg.width = width
    if height is not None:
        msg.height = height
    if step is not None:
        msg.step = step
    if data is not None:
        msg.data = data
    return msg


# A wide-angle lens (the simulator's harsh profile): plumb_bob k1, k2, p1, p2, k3.
LENS = [-0.30, 0.08, 0.002, -0.002, 0.0]


def distorted(image, distortion, fx=FX):
    """``image`` as a lens with ``distortion`` would have taken it: each pixel fetched from its ideal place."""
    height, width = image.shape[:2]
    camera = np.array([[fx, 0, 159.5], [0, fx, 119.5], [0, 0, 1]])
    u, v = np.meshgrid(np.arange(width, dtype=np.float32), np.arange(height, dtype=np.float32))
    pixels = np.stack([u.ravel(), v.ravel()], axis=1).reshape(-1, 1, 2)
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-9)
    ideal = cv2.undistortPointsIter(pixels, camera, np.array(distortion), None, camera, criteria)
    ideal = ideal.reshape(height, width, 2)
    return cv2.remap(image, ideal[..., 0].astype(np.float32), ideal[..., 1].astype(np.float32), cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_REPLICATE)


def camera_info(stamp, fx=FX, model="plumb_bob", distortion=(0.0,) * 5):
    msg = CameraInfo(width=320, height=240, distortion_model=model, D=list(distortion),
                     K=[fx, 0, 159.5, 0, fx, 119.5, 0, 0, 1], R=[1, 0, 0, 0, 1, 0, 0, 0, 1],
                     P=[fx, 0, 159.5, 0, 0, fx, 119.5, 0, 0, 0, 1, 0])
    msg.header.stamp, msg.header.frame_id = stamp, "ardrone/bottom_camera"
    return msg


class NodeInputsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("node_inputs_test")
        cls.points = []
        cls.world_points = []
        cls.warnings = []
        cls.info_chasers = 0  # camera_info messages sent to prove the one before arrived (camera_info_arrived)
        rospy.Subscriber("/platform/current_platform_position_in_ardrone", PointStamped, cls.points.append)
        rospy.Subscriber("/platform/current_platform_position_in_world", PointStamped, cls.world_points.append)
        rospy.Subscriber("/rosout", Log, lambda m: cls.warnings.append(m.msg) if m.level >= Log.WARN else None,
                         queue_size=100)
        cls.pub = {
            "image": rospy.Publisher("/ardrone/bottom/image_raw", Image, queue_size=5),
            "info": rospy.Publisher("/ardrone/bottom/camera_info", CameraInfo, queue_size=5),
            "imu": rospy.Publisher("/ardrone/imu", Imu, queue_size=5),
            "sonar": rospy.Publisher("/ardrone/sonar_height", Range, queue_size=5),
            "altimeter": rospy.Publisher("/ardrone/altimeter", Altimeter, queue_size=5),
            "odom": rospy.Publisher("/ardrone/odom_estimate", Odometry, queue_size=5),
        }
        for name, pub in cls.pub.items():
            wait_for(lambda p=pub: p.get_num_connections() > 0, "platform_detection to subscribe to " + pub.name)

    def publish_sensors(self, stamp, imu_quat=(1.0, 0.0, 0.0, 0.0), sonar=CAMERA_HEIGHT - 0.03,
                        altitude=CAMERA_HEIGHT + 0.035 + PAD_TOP, fx=FX, distortion=(0.0,) * 5, info=True):
        if info:
            self.pub["info"].publish(camera_info(stamp, fx, distortion=distortion))
        imu = Imu()
        imu.header.stamp, imu.header.frame_id = stamp, "ardrone/base_link"
        imu.orientation.w, imu.orientation.x, imu.orientation.y, imu.orientation.z = imu_quat
        self.pub["imu"].publish(imu)
        rng = Range(range=sonar, min_range=0.02, max_range=6.0)
        rng.header.stamp = stamp
        self.pub["sonar"].publish(rng)
        alt = Altimeter(altitude=altitude)
        alt.header.stamp = stamp
        self.pub["altimeter"].publish(alt)

    def detect_once(self, image=None, distortion=(0.0,) * 5, stamp=None, publish_sensors=True, info=True,
                    accept=lambda point: True, what="the pad position of a good frame"):
        """A good frame with good sensors (``info`` False: all but camera_info): returns the first published pad
        position of its stamp that ``accept`` takes. The frame is sent again until it comes, as the sensor
        messages travel on other connections and may arrive later. A camera_info sent is known to have arrived
        before the frame (a frame would otherwise be measured with the lens of the one before)."""
        stamp = stamp or rospy.Time.now()
        if publish_sensors:
            self.publish_sensors(stamp, distortion=distortion, info=info)
            if info:
                self.camera_info_arrived()
        frame = image_msg(stamp, pad_image() if image is None else image)

        def first_accepted():
            return next((p for p in self.points if p.header.stamp == stamp and accept(p)), None)
        resend_until(lambda: self.pub["image"].publish(frame), lambda: first_accepted() is not None, what)
        return first_accepted()

    def camera_info_arrived(self):
        """Proves that the camera_info sent last has arrived: one sent after it on the same connection, with a
        negative focal length of its own, is dropped with a warning naming that focal length."""
        type(self).info_chasers += 1
        fx = -float(type(self).info_chasers)
        self.expect_warning(self.pub["info"], camera_info(rospy.Time.now(), fx=fx), "camera_info: dropped",
                            "(fx=%g," % fx)

    def expect_warning(self, publisher, message, *words):
        """Publish a bad ``message`` and wait for the warning it causes. Only warnings that arrive after it was
        sent count, and ``words`` name its own problem: a warning logged before (by this test or an earlier
        one, e.g. 'no /ardrone/odom_estimate within ...' while no odometry came) cannot pass the check."""
        start = len(self.warnings)
        # Sent again meanwhile: a warning of the same call site within warn_period of the one before is throttled
        # (two bad messages in one millisecond give one warning).
        resend_until(lambda: publisher.publish(message),
                     lambda: any(all(w in m for w in words) for m in self.warnings[start:]),
                     "a warning with %s after the bad message" % (words,))

    def test_1_good_frame_gives_the_pad_position(self):
        point = self.detect_once()
        self.assertEqual(point.header.frame_id, "ardrone/base_link")
        # 20 px right of the centre = 20/256 * height to the drone's right (-y); straight below otherwise.
        self.assertAlmostEqual(point.point.x, 0.0, delta=0.01)
        self.assertAlmostEqual(point.point.y, -20.0 / FX * CAMERA_HEIGHT, delta=0.01)
        self.assertAlmostEqual(point.point.z, -(CAMERA_HEIGHT + 0.035), delta=0.02)

    def test_2_bad_images_are_dropped_with_a_warning(self):
        stamp, image = rospy.Time.now(), self.pub["image"]
        self.expect_warning(image, image_msg(stamp, encoding="rgb8", width=0, height=0, step=0, data=b""),
                            "/ardrone/bottom/image_raw: dropped a 0x0 frame", "does not fit")
        self.expect_warning(image, image_msg(stamp, np.zeros((240, 320, 1), np.uint8), encoding="mono8"),
                            "/ardrone/bottom/image_raw: dropped a frame with encoding 'mono8'")
        self.expect_warning(image, image_msg(stamp, pad_image(321, 240)),
                            "/ardrone/bottom/image_raw: dropped a 321x240 frame")
        self.expect_warning(image, image_msg(stamp, pad_image(), data=b"\x00" * 100),
                            "/ardrone/bottom/image_raw: dropped a 320x240 frame", "data size (100) does not fit")
        self.detect_once()

    def test_3_bad_sensor_messages_are_dropped_with_a_warning(self):
        stamp = rospy.Time.now()
        self.expect_warning(self.pub["info"], camera_info(stamp, fx=0.0), "/ardrone/bottom/camera_info: dropped",
                            "focal length must be positive (fx=0")
        imu = Imu()
        imu.header.stamp = stamp
        imu.orientation.w = float("nan")
        self.expect_warning(self.pub["imu"], imu,
                            "/ardrone/imu: dropped a message without a valid orientation quaternion")
        self.expect_warning(self.pub["sonar"], Range(range=float("nan")),
                            "/ardrone/sonar_height: dropped an invalid range nan")
        self.expect_warning(self.pub["altimeter"], Altimeter(altitude=float("nan")),
                            "/ardrone/altimeter: dropped a non-finite altitude")
        odom = Odometry()
        odom.header.frame_id = "world"
        odom.pose.pose.position.x = float("nan")
        self.expect_warning(self.pub["odom"], odom, "/ardrone/odom_estimate: dropped a non-finite position")
        # Only the bad ones were dropped: the last good camera_info still serves.
        self.detect_once()

    def test_4_frame_without_attitude_is_dropped_with_a_warning(self):
        # 0.3 s ahead: beyond the IMU history (imu_max_offset 0.05 s), within what a clock may be ahead
        # (landing_runtime/input_check.h: 0.5 s; a stamp further off is dropped for that before)
        stamp = rospy.Time.now()
        self.expect_warning(self.pub["image"], image_msg(stamp + rospy.Duration(0.3), pad_image()),
                            "/ardrone/bottom/image_raw: no /ardrone/imu within")

    def test_5_debug_image_only_for_subscribers(self):
        debug = []
        subscriber = rospy.Subscriber("/platform_detection/debug_image", Image, debug.append, queue_size=2)
        wait_for(lambda: subscriber.get_num_connections() > 0, "the debug image connection")
        self.detect_once()
        wait_for(lambda: debug, "a debug image")
        self.assertEqual((debug[-1].width, debug[-1].height, debug[-1].encoding), (320, 240, "rgb8"))
        subscriber.unregister()

    def test_6_malformed_lens_distortion_is_dropped_saying_what_is_wrong(self):
        stamp = rospy.Time.now()
        info = self.pub["info"]
        self.expect_warning(info, camera_info(stamp, distortion=LENS[:4]), "camera_info", "plumb_bob needs 5",
                            "D has 4")
        self.expect_warning(info, camera_info(stamp, distortion=[-0.3, float("nan"), 0.0, 0.0, 0.0]), "camera_info",
                            "D[1] is not a finite number")
        self.expect_warning(info, camera_info(stamp, model="equidistant", distortion=[0.1, 0.0, 0.0, 0.0]),
                            "camera_info", "'equidistant' is not supported")
        # Only the bad ones were dropped: the last good camera_info still serves.
        self.detect_once(info=False)

    def test_7_distorted_frame_is_undistorted_with_camera_info_d(self):
        # The pad off towards a corner, where the lens bends it by about 3 px (3 cm at this height).
        right, down = 90, 50
        image = distorted(pad_image(right=right, down=down), LENS)
        point = self.detect_once(image, distortion=LENS)
        self.assertAlmostEqual(point.point.x, -down / FX * CAMERA_HEIGHT, delta=0.01)
        self.assertAlmostEqual(point.point.y, -right / FX * CAMERA_HEIGHT, delta=0.01)
        # Taken for a perfect lens, the same frame puts the pad centimetres off.
        ignored = self.detect_once(image)
        self.assertGreater(abs(ignored.point.y - point.point.y) + abs(ignored.point.x - point.point.x), 0.02)

    def test_8_late_frame_takes_the_sonar_and_barometer_of_its_capture_time(self):
        # The frame was taken at `taken`; by the time it arrives the drone has climbed 0.3 m.
        taken = rospy.Time.now()
        self.publish_sensors(taken - rospy.Duration(0.04))
        self.publish_sensors(taken)
        for offset in (0.15, 0.19):
            self.publish_sensors(taken + rospy.Duration(offset), sonar=CAMERA_HEIGHT - 0.03 + 0.3,
                                 altitude=CAMERA_HEIGHT + 0.035 + PAD_TOP + 0.3)
        # A frame taken after the climb measured with the new height proves the new readings have arrived (a
        # frame that overtook them on its own connection is measured with the ones before: sent again) ...
        climbed_y = -20.0 / FX * (CAMERA_HEIGHT + 0.3)
        self.detect_once(stamp=taken + rospy.Duration(0.19), publish_sensors=False,
                         accept=lambda p: abs(p.point.y - climbed_y) < 0.004,
                         what="a frame taken after the climb measured with the new height")
        # ... and the late frame is measured with the height of its own time.
        point = self.detect_once(stamp=taken, publish_sensors=False)
        self.assertAlmostEqual(point.point.y, -20.0 / FX * CAMERA_HEIGHT, delta=0.004)
        self.assertAlmostEqual(point.point.z, -(CAMERA_HEIGHT + 0.035), delta=0.02)

    def test_91_the_world_fix_is_turned_by_the_heading_the_estimate_corrected(self):
        """The IMU says yaw 0; the drone estimator, having learnt the IMU's yaw drift, publishes heading +90 deg
        at the same stamp. The pad 20 px right of the image centre is to the drone's right: along world -y by the
        IMU, along world +x by the corrected heading, which the world fix follows."""
        offsets = {}
        # Each message travels on its own connection, so the order they arrive in is the test's to prove:
        # - an odometry that comes before its stamp's IMU reading is stored without the heading correction (the
        #   estimate's heading minus the IMU's yaw): the frame's fix relative to the drone, which needs that
        #   reading, comes first;
        # - a frame that comes before its own odometry is placed with the nearest estimate within odom_timeout:
        #   the turns' stamps lie further apart than that, so such a frame gets the relative position only (and
        #   is sent again), never the other turn's heading.
        apart = rospy.Duration(rospy.get_param("/platform_detection/timing/odom_timeout") + 0.1)
        previous = None
        for turn in (0.0, np.pi / 2):
            if previous is not None:
                wait_for(lambda: rospy.Time.now() > previous + apart, "the clock to pass the odometry timeout")
            stamp = previous = rospy.Time.now()
            self.detect_once(stamp=stamp)
            odom = Odometry()
            odom.header.stamp, odom.header.frame_id = stamp, "world"
            odom.pose.pose.position.x, odom.pose.pose.position.y, odom.pose.pose.position.z = 1.0, 2.0, 3.0
            odom.pose.pose.orientation.w, odom.pose.pose.orientation.z = np.cos(turn / 2), np.sin(turn / 2)

            frame = image_msg(stamp, pad_image())

            def send(odom=odom, frame=frame):
                self.pub["odom"].publish(odom)
                self.pub["image"].publish(frame)
            # Sent again: a frame that came before the odometry is published relative to the drone only.
            resend_until(send, lambda stamp=stamp: any(p.header.stamp == stamp for p in self.world_points),
                         "the world fix of the frame")
            point = next(p for p in self.world_points if p.header.stamp == stamp)
            offsets[turn] = (point.point.x - 1.0, point.point.y - 2.0)
        right = 20.0 / FX * CAMERA_HEIGHT
        self.assertAlmostEqual(offsets[0.0][0], 0.0, delta=0.01)
        self.assertAlmostEqual(offsets[0.0][1], -right, delta=0.01)
        self.assertAlmostEqual(offsets[np.pi / 2][0], right, delta=0.01)
        self.assertAlmostEqual(offsets[np.pi / 2][1], 0.0, delta=0.01)

    def test_9_missing_parameter_stops_the_node_naming_it(self):
        result = subprocess.run(["rosrun", "uav_vision", "platform_detection", "__name:=unconfigured_detection"],
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=WALL_TIMEOUT,
                                env=dict(os.environ))
        output = result.stdout.decode(errors="replace")
        self.assertNotEqual(result.returncode, 0, output)
        self.assertIn("/unconfigured_detection/height_landing_platform", output)
        self.assertIn("missing", output)


if __name__ == "__main__":
    rostest.rosrun("uav_vision", "node_inputs_rostest", NodeInputsTest)
