#!/usr/bin/env python3
"""rostest of the simulator's emulated ardrone_autonomy (drone_model ardrone2), from the outside."""
import functools
import math
import unittest

import rosgraph
import rospy
import rostest
from ardrone_autonomy.msg import Navdata
from ardrone_autonomy.srv import CamSelect
from geometry_msgs.msg import Twist
from landing_runtime import testing
from sensor_msgs.msg import CameraInfo, Image
from std_msgs.msg import Empty

WALL_TIMEOUT = 120.0
wait_for = functools.partial(testing.wait_for, timeout=WALL_TIMEOUT)
# The real driver's md5sums (ardrone_autonomy, as its generated code publishes them).
NAVDATA_MD5 = "e1169f766234363125ac62c9a3f87eeb"
CAMSELECT_MD5 = "bbeb5212f8ee1d6da7ff0d1169124280"


class ArdroneDriverTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_ardrone_driver")
        cls.navdata, cls.frames = [], []
        rospy.Subscriber("/ardrone/navdata", Navdata, cls.navdata.append, queue_size=200)
        rospy.Subscriber("/ardrone/bottom/image_raw", Image, lambda m: cls.frames.append(m.header.stamp.to_sec()),
                         queue_size=5, buff_size=2 ** 24)
        cls.cmd = rospy.Publisher("/cmd_vel", Twist, queue_size=1)
        cls.takeoff = rospy.Publisher("/ardrone/takeoff", Empty, queue_size=1, latch=True)
        wait_for(lambda: cls.navdata, "the first ardrone/navdata")

    def sim_sleep(self, seconds):
        end = rospy.get_time() + seconds
        wait_for(lambda: rospy.get_time() >= end, "%.1f s of sim time" % seconds)

    def test_1_the_topics_carry_the_real_drivers_types(self):
        master = rosgraph.Master("/test_ardrone_driver")
        types = dict(master.getTopicTypes())
        self.assertEqual(types["/ardrone/navdata"], "ardrone_autonomy/Navdata")
        self.assertEqual(Navdata._md5sum, NAVDATA_MD5)
        self.assertEqual(CamSelect._md5sum, CAMSELECT_MD5)
        self.assertNotIn("/drone/navdata", types)  # the stack's own status is the adapter's, not the driver's
        self.assertNotIn("/ardrone/sonar_height", types)
        subscribed = {topic for topic, _nodes in master.getSystemState()[1]}
        self.assertIn("/cmd_vel", subscribed)
        self.assertNotIn("/ardrone/cmd_vel", subscribed)

    def test_2_navdata_in_the_drivers_units_and_rate(self):
        count, start = len(self.navdata), rospy.get_time()
        self.sim_sleep(2.0)
        rate = (len(self.navdata) - count) / (rospy.get_time() - start)
        self.assertTrue(40.0 <= rate <= 55.0, "navdata at %.1f Hz, expected the driver's looprate 50 Hz" % rate)
        last = self.navdata[-1]
        self.assertEqual(last.state, 2)  # landed
        self.assertTrue(0 <= last.altd < 100, "altd %r mm at rest on the pad" % last.altd)
        self.assertAlmostEqual(last.az, 1.0, delta=0.1)  # g
        self.assertTrue(90000 < last.pressure < 110000, "pressure %r Pa" % last.pressure)

    def test_3_no_bottom_frames_until_the_bottom_camera_is_selected(self):
        self.sim_sleep(1.0)
        self.assertEqual(self.frames, [], "bottom frames while the front camera streams")
        rospy.wait_for_service("/ardrone/setcamchannel", timeout=WALL_TIMEOUT)
        self.assertTrue(rospy.ServiceProxy("/ardrone/setcamchannel", CamSelect)(channel=1).result)
        asked = rospy.get_time()
        wait_for(lambda: len(self.frames) >= 10, "bottom frames after setcamchannel 1")
        self.assertGreater(self.frames[0], asked, "a frame captured before the switch")

    def test_4_takeoff_and_tilt_commands(self):
        self.takeoff.publish(Empty())
        wait_for(lambda: self.navdata[-1].state == 4, "hovering after the firmware's own take-off")
        self.assertAlmostEqual(self.navdata[-1].altd, 900, delta=150)  # mm
        end = rospy.get_time() + 2.0
        forward = Twist()
        forward.linear.x = 0.5
        while rospy.get_time() < end:
            self.cmd.publish(forward)
            self.sim_sleep(0.05)
        last = self.navdata[-1]
        self.assertIn(last.state, (3, 7))  # flying on commands
        self.assertGreater(last.rotY, 3.0, "forward tilt (nose down) in degrees")
        self.assertGreater(last.vx, 500.0, "forward velocity in mm/s")
        count = len(self.navdata)
        self.cmd.publish(Twist())  # all six zero: the firmware hovers
        wait_for(lambda: len(self.navdata) > count + 100 and self.navdata[-1].state == 4 and
                 math.hypot(self.navdata[-1].vx, self.navdata[-1].vy) < 300.0, "hovering on an all-zero cmd_vel")


if __name__ == "__main__":
    rostest.rosrun("mujoco_sim", "ardrone_driver", ArdroneDriverTest)
