#!/usr/bin/env python3
"""rostest of the simulator node: topics, rates (in sim time), tf, conditions, take-off and landing."""
import functools
import math
import unittest

import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import Twist
from landing_msgs.msg import Altimeter, Navdata, Touchdown
from nav_msgs.msg import Odometry
from sensor_msgs.msg import CameraInfo, Image, Imu, JointState, NavSatFix, Range
from std_msgs.msg import Empty
from landing_runtime import testing

WALL_TIMEOUT = 120.0
RATES = {  # topic: (type, expected rate in sim time [Hz])
    "/ardrone/imu": (Imu, 50.0), "/ardrone/bottom/image_raw": (Image, 30.0),
    "/ardrone/bottom/camera_info": (CameraInfo, 30.0), "/ardrone/sonar_height": (Range, 25.0),
    "/ardrone/altimeter": (Altimeter, 20.0), "/drone/navdata": (Navdata, 50.0),
    "/ardrone/gps/odom": (Odometry, 5.0), "/ardrone/ground_truth/state": (Odometry, 50.0),
    "/summit_xl/joint_states": (JointState, 50.0),
    # the vehicle's real interfaces: its GPS receiver (a NO_FIX in a dropout, without vel) and its controller's odometry
    "/summit_xl/gps/fix": (NavSatFix, 5.0), "/robotnik_base_control/odom": (Odometry, 50.0),
}


wait_for = functools.partial(testing.wait_for, timeout=WALL_TIMEOUT)


class SimNodeTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_sim_node")
        cls.stamps = {topic: [] for topic in RATES}
        cls.delays = {}  # topic: arrival (sim time) minus stamp, per message
        cls.latest = {}
        for topic, (kind, _) in RATES.items():
            rospy.Subscriber(topic, kind, cls._recorder(topic), queue_size=500, buff_size=2 ** 24)
        rospy.Subscriber("/ardrone/touchdown", Touchdown, lambda m: cls.latest.update(touchdown=m))
        cls.cmd = rospy.Publisher("/ardrone/cmd_vel", Twist, queue_size=1)
        cls.takeoff = rospy.Publisher("/ardrone/takeoff", Empty, queue_size=1, latch=True)
        cls.land = rospy.Publisher("/ardrone/land", Empty, queue_size=1, latch=True)
        cls.tf_buffer = tf2_ros.Buffer()
        cls.tf_listener = tf2_ros.TransformListener(cls.tf_buffer)
        wait_for(lambda: all(cls.stamps[t] for t in RATES), "every topic's first message")

    @classmethod
    def _recorder(cls, topic):
        def record(msg):
            cls.stamps[topic].append(msg.header.stamp.to_sec())
            cls.delays.setdefault(topic, []).append(rospy.get_time() - msg.header.stamp.to_sec())
            cls.latest[topic] = msg
        return record

    def sim_sleep(self, seconds):
        end = rospy.get_time() + seconds
        wait_for(lambda: rospy.get_time() >= end, "%.1f s of sim time" % seconds)

    def fly(self, seconds, vx=0.0, vy=0.0, vz=0.0):
        end = rospy.get_time() + seconds
        while rospy.get_time() < end:
            msg = Twist()
            msg.linear.x, msg.linear.y, msg.linear.z = vx, vy, vz
            self.cmd.publish(msg)
            self.sim_sleep(0.05)

    def state(self):
        return self.latest["/drone/navdata"].state

    def truth(self):
        return self.latest["/ardrone/ground_truth/state"].pose.pose.position

    def test_1_rates_in_sim_time(self):
        start = rospy.get_time()
        self.sim_sleep(4.0)
        end = rospy.get_time()
        for topic, (_, expected) in RATES.items():
            stamps = [t for t in self.stamps[topic] if start + 0.5 <= t <= end - 0.5]
            measured = (len(stamps) - 1) / (stamps[-1] - stamps[0])
            self.assertAlmostEqual(measured, expected, delta=0.2 * expected, msg=topic)

    def test_2_camera_and_tf(self):
        image = self.latest["/ardrone/bottom/image_raw"]
        self.assertEqual((image.width, image.height, image.encoding), (320, 240, "rgb8"))
        info = self.latest["/ardrone/bottom/camera_info"]
        self.assertAlmostEqual(info.K[0], 256.0, delta=1.0)
        for child in ("ardrone/base_link", "ardrone/bottom_camera", "summit_xl/base_link", "landing_pad"):
            transform = self.tf_buffer.lookup_transform("world", child, rospy.Time(0), rospy.Duration(30.0))
            self.assertTrue(math.isfinite(transform.transform.translation.z), child)
        pad = self.tf_buffer.lookup_transform("world", "landing_pad", rospy.Time(0), rospy.Duration(5.0))
        self.assertAlmostEqual(pad.transform.translation.z, 0.497, delta=0.01)
        # camera looks down: its optical z axis maps to world -z
        cam = self.tf_buffer.lookup_transform("world", "ardrone/bottom_camera", rospy.Time(0), rospy.Duration(5.0))
        q = cam.transform.rotation
        z_axis_world_z = 1 - 2 * (q.x * q.x + q.y * q.y)
        self.assertLess(z_axis_world_z, -0.95)

    def test_3_conditions_change_the_world_and_bad_values_are_rejected(self):
        rospy.set_param("/drone_battery", 55.0)
        wait_for(lambda: abs(self.latest["/drone/navdata"].battery_percent - 55.0) < 1.0, "battery set to 55 %")
        # A bad value is refused by the world but left where the operator put it (the supervisor must see it).
        rospy.set_param("/drone_battery", 150)
        self.sim_sleep(1.0)
        self.assertEqual(rospy.get_param("/drone_battery"), 150)
        self.assertLess(self.latest["/drone/navdata"].battery_percent, 56.0)
        rospy.set_param("/drone_battery", 60.0)
        wait_for(lambda: abs(self.latest["/drone/navdata"].battery_percent - 60.0) < 1.0, "battery set to 60 %")
        rospy.set_param("/wind_speed", -5.0)
        self.sim_sleep(1.0)
        self.assertEqual(rospy.get_param("/wind_speed"), -5.0)

    def test_4_takeoff_hover_reject_nan_and_land_on_the_pad(self):
        self.assertEqual(self.state(), Navdata.STATE_LANDED)
        self.takeoff.publish(Empty())
        wait_for(lambda: self.state() in (Navdata.STATE_FLYING, Navdata.STATE_HOVERING), "take-off to finish")
        self.assertGreater(self.truth().z, 1.4)
        self.fly(1.0, vz=0.5)
        self.fly(1.0)
        before = self.truth()
        nan = Twist()
        nan.linear.x = float("nan")
        end = rospy.get_time() + 2.0
        while rospy.get_time() < end:
            self.cmd.publish(nan)
            self.sim_sleep(0.05)
        after = self.truth()
        self.assertLess(math.dist((before.x, before.y, before.z), (after.x, after.y, after.z)), 0.2)
        self.land.publish(Empty())
        wait_for(lambda: "touchdown" in self.latest, "touchdown")
        touchdown = self.latest["touchdown"]
        self.assertEqual(touchdown.surface, Touchdown.SURFACE_PAD)
        self.assertFalse(touchdown.crashed)
        self.assertLess(touchdown.pad_error, 0.25)
        wait_for(lambda: self.state() == Navdata.STATE_LANDED, "navdata to report landed")


    def test_5_frames_are_stamped_when_taken_and_arrive_late_by_the_link_latency(self):
        """The realism profile in force (realistic by default): a camera frame's stamp is its capture time and
        it arrives after the camera link's latency; navdata likewise after its own."""
        realism = rospy.get_param("/mujoco_sim/realism_in_force")
        for topic, key in (("/ardrone/bottom/image_raw", "camera"), ("/drone/navdata", "navdata")):
            latency, jitter = realism[key + "_latency_s"], realism[key + "_latency_jitter_s"]
            delays = self.delays[topic][20:]
            self.assertGreater(len(delays), 50, topic)
            median = sorted(delays)[len(delays) // 2]
            early = sum(d < latency - 3 * jitter - 0.02 for d in delays) / len(delays)
            rospy.loginfo("%s: %d messages, median %.3f s after their stamp (latency %.3f s, jitter %.3f s), %.1f %% "
                          "early", topic, len(delays), median, latency, jitter, 100 * early)
            # The test node's clock is its own reading of /clock (60 Hz, its own thread): it lags the simulator's
            # now and then, so single arrivals may look early.
            self.assertGreater(median, latency - 0.01, topic)
            self.assertLess(median, latency + jitter + 0.04, topic)
            self.assertLess(early, 0.05, topic)
        info = self.latest["/ardrone/bottom/camera_info"]
        self.assertAlmostEqual(info.D[0], realism["lens_k1"], places=6)  # plumb_bob: k1 k2 p1 p2 k3


if __name__ == "__main__":
    rostest.rosrun("mujoco_sim", "test_sim_node", SimNodeTest)
