#!/usr/bin/env python3
"""rostest of the ardrone_adapter node, the test playing the driver's side with the driver's own types."""
import functools
import math
import unittest

import rospy
import rostest
from ardrone_autonomy.msg import Navdata as DriverNavdata
from ardrone_autonomy.srv import CamSelect, CamSelectResponse
from geometry_msgs.msg import Twist
from landing_msgs.msg import Altimeter, Navdata
from landing_runtime import testing
from sensor_msgs.msg import CameraInfo, Range
from std_msgs.msg import String

wait_for = functools.partial(testing.wait_for, timeout=60.0)
PAD_PRESSURE = 101300  # [Pa] at rest on the pad


class AdapterTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_ardrone_adapter")
        cls.got = {"navdata": [], "sonar": [], "altimeter": [], "cmd": [], "status": []}
        rospy.Subscriber("/drone/navdata", Navdata, cls.got["navdata"].append)
        rospy.Subscriber("/ardrone/sonar_height", Range, cls.got["sonar"].append)
        rospy.Subscriber("/ardrone/altimeter", Altimeter, cls.got["altimeter"].append)
        rospy.Subscriber("/cmd_vel", Twist, cls.got["cmd"].append)
        rospy.Subscriber("/ardrone_adapter/status", String, lambda m: cls.got["status"].append(m.data))
        cls.driver_navdata = rospy.Publisher("/ardrone/navdata", DriverNavdata, queue_size=10)
        cls.camera_info = rospy.Publisher("/ardrone/bottom/camera_info", CameraInfo, queue_size=1)
        cls.velocity = rospy.Publisher("/ardrone/cmd_vel", Twist, queue_size=1)
        cls.channels = []
        rospy.Service("/ardrone/setcamchannel", CamSelect, cls._on_setcamchannel)
        wait_for(lambda: cls.driver_navdata.get_num_connections() and cls.velocity.get_num_connections(),
                 "the adapter subscribed to ardrone/navdata (the driver's type) and ardrone/cmd_vel")

    @classmethod
    def _on_setcamchannel(cls, request):
        cls.channels.append(request.channel)
        return CamSelectResponse(result=True)

    def send_navdata(self, state=2, altd=0, vx=0.0, vy=0.0, rot_x=0.0, rot_y=0.0, pressure=PAD_PRESSURE, count=1):
        for _ in range(count):
            msg = DriverNavdata(state=state, altd=altd, vx=vx, vy=vy, rotX=rot_x, rotY=rot_y, az=1.0,
                                pressure=pressure, batteryPercent=87.0, motor1=128, motor2=128, motor3=128,
                                motor4=128)
            msg.header.stamp = rospy.Time.now()
            self.driver_navdata.publish(msg)
            rospy.sleep(0.02)  # the driver's 50 Hz

    def test_1_the_bottom_camera_is_selected_and_its_frames_checked(self):
        wait_for(lambda: self.channels == [1], "setcamchannel 1 (bottom)")
        info = CameraInfo(width=320, height=240, K=[180, 0, 160, 0, 180, 120, 0, 0, 1])
        wait_for(lambda: self.camera_info.publish(info) or any("bottom camera: selected" in s for s in
                                                                self.got["status"]), "the status 'selected'")

    def test_2_navdata_in_si_units(self):
        self.send_navdata(state=2, altd=0, count=3)  # at rest: the barometer's zero
        count = len(self.got["navdata"])
        self.send_navdata(state=3, altd=1500, vx=1200.0, vy=-300.0, rot_y=5.0, pressure=PAD_PRESSURE - 12)
        wait_for(lambda: len(self.got["navdata"]) > count and self.got["altimeter"], "the converted navdata")
        nav = self.got["navdata"][-1]
        self.assertAlmostEqual(nav.altitude, 1.5, places=3)  # altd in mm (altd_unit)
        self.assertAlmostEqual(nav.vx, 1.2, places=3)
        self.assertAlmostEqual(nav.vy, -0.3, places=3)
        self.assertAlmostEqual(nav.rot_y, 5.0, places=3)
        self.assertEqual(nav.state, Navdata.STATE_FLYING)
        self.assertAlmostEqual(self.got["sonar"][-1].range, 1.5, places=3)
        # The take-off point's altitude (the Summit XL's pad, 0.562 m) plus about 1 m for 12 Pa.
        self.assertAlmostEqual(self.got["altimeter"][-1].altitude, 0.562 + 1.0, delta=0.1)

    def test_3_velocity_commands_become_normalised_tilts(self):
        forward = Twist()
        forward.linear.x = 1.0
        wait_for(lambda: self.velocity.publish(forward) or self.send_navdata(state=3, altd=2000) or
                 (self.got["cmd"] and self.got["cmd"][-1].linear.x > 0.05), "a forward tilt for 1 m/s forward")
        command = self.got["cmd"][-1]
        self.assertTrue(all(abs(v) <= 1.0 for v in (command.linear.x, command.linear.y, command.linear.z,
                                                      command.angular.z)))

    def test_4_a_non_finite_velocity_command_never_reaches_the_drone(self):
        bad = Twist()
        bad.linear.x = float("nan")
        count = len(self.got["cmd"])
        for _ in range(20):  # 0.5 s: the last good command goes stale, and only a hover may follow
            self.velocity.publish(bad)
            self.send_navdata(state=3, altd=2000, count=1)
        wait_for(lambda: len(self.got["cmd"]) > count + 5, "commands after the bad input")
        for command in self.got["cmd"][count:]:
            self.assertTrue(all(math.isfinite(v) for v in (command.linear.x, command.linear.y, command.linear.z)))
        self.send_navdata(state=3, altd=2000, count=30)  # 0.6 s > command_timeout: the drone holds
        self.assertLess(abs(self.got["cmd"][-1].linear.x), 0.05)

    def test_5_malformed_navdata_is_dropped(self):
        count = len(self.got["navdata"])
        self.send_navdata(state=3, altd=2000, vx=float("inf"))
        self.send_navdata(state=3, altd=2000, vx=100.0)
        wait_for(lambda: len(self.got["navdata"]) > count, "the good navdata after the bad one")
        self.assertTrue(all(math.isfinite(n.vx) for n in self.got["navdata"][count:]))
        self.assertAlmostEqual(self.got["navdata"][-1].vx, 0.1, places=3)

    def test_6_an_altd_in_the_other_unit_is_named_with_the_parameter_to_set(self):
        # 2 m up by the barometer (24 Pa), altd 200: centimetres, while the adapter reads millimetres.
        self.send_navdata(state=3, altd=200, pressure=PAD_PRESSURE - 24, count=30)
        wait_for(lambda: any("altd_unit: cm" in s for s in self.got["status"]), "the altd unit check's verdict")


if __name__ == "__main__":
    rostest.rosrun("ardrone_moves", "ardrone_adapter", AdapterTest)
