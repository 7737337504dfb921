#!/usr/bin/env python3
"""rostest of drone_estimator as drone_estimator.launch starts it: its parameters are the shipped files (the
vehicle's flow surface, switched on by flow_coupling), the vehicle's report comes on the remapped topic, and fed
the drone's sensors at rest (IMU, navdata, altimeter, GPS) it publishes ardrone/odom_estimate at the GPS fix and
ardrone/flow_unseen_velocity. ~reset starts it over from the next fix; a bad parameter refuses the reset, naming it
and where the shipped files are. The test owns /clock (sim time, from 100 s on)."""
import os
import threading
import unittest

import rosgraph
import rospkg
import rospy
import rostest
import yaml
from geometry_msgs.msg import Vector3Stamped
from landing_msgs.msg import Altimeter, Navdata
from landing_runtime import testing
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu
from std_srvs.srv import Trigger

NODE = "/drone_estimator"
WALL_TIMEOUT = 60.0
START = 100.0        # the clock's first time [s]
STEP = 0.01          # clock step, one every wall STEP [s]
P1, P2 = (3.0, 4.0, 0.5), (-20.0, 10.0, 0.5)  # where the GPS puts the drone: before and after the reset [m]


class World:
    """The clock and the drone's sensors at rest at ``gps``: IMU (100 Hz), navdata (50 Hz), altimeter (20 Hz) and
    GPS (5 Hz)."""

    def __init__(self):
        self.gps = P1
        self.clock = rospy.Publisher("/clock", Clock, queue_size=10)
        self.pub_imu = rospy.Publisher("ardrone/imu", Imu, queue_size=10)
        self.pub_nav = rospy.Publisher("drone/navdata", Navdata, queue_size=10)
        self.pub_altimeter = rospy.Publisher("ardrone/altimeter", Altimeter, queue_size=10)
        self.pub_gps = rospy.Publisher("ardrone/gps/odom", Odometry, queue_size=10)
        self.stop = threading.Event()
        threading.Thread(target=self._run, daemon=True).start()

    def _run(self):
        step = 0
        while not self.stop.wait(STEP) and not rospy.is_shutdown():
            now = rospy.Time.from_sec(START + step * STEP)
            self.clock.publish(Clock(clock=now))
            imu = Imu()
            imu.header.stamp, imu.header.frame_id = now, "ardrone/base_link"
            imu.orientation.w, imu.linear_acceleration.z = 1.0, 9.81
            self.pub_imu.publish(imu)
            if step % 2 == 0:
                nav = Navdata(state=Navdata.STATE_LANDED)
                nav.header.stamp = now
                self.pub_nav.publish(nav)
            if step % 5 == 0:
                altimeter = Altimeter(altitude=self.gps[2])
                altimeter.header.stamp = now
                self.pub_altimeter.publish(altimeter)
            if step % 20 == 0:
                gps = Odometry()
                gps.header.stamp, gps.header.frame_id = now, "world"
                position = gps.pose.pose.position
                position.x, position.y, position.z = self.gps
                gps.pose.pose.orientation.w = 1.0
                self.pub_gps.publish(gps)
            step += 1


class EstimatorLaunchTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_drone_estimator_launch")
        cls.estimates, cls.unseen = [], []
        rospy.Subscriber("ardrone/odom_estimate", Odometry, cls.estimates.append, queue_size=200)
        rospy.Subscriber("ardrone/flow_unseen_velocity", Vector3Stamped, cls.unseen.append, queue_size=200)
        cls.world = World()
        rospy.wait_for_service(NODE + "/reset", timeout=WALL_TIMEOUT)

    @classmethod
    def tearDownClass(cls):
        cls.world.stop.set()

    def wait_for(self, condition, what):
        return testing.wait_for(condition, what, WALL_TIMEOUT)

    @staticmethod
    def offset(estimate, where):
        p = estimate.pose.pose.position
        return max(abs(p.x - where[0]), abs(p.y - where[1]), abs(p.z - where[2]))

    def test_1_the_shipped_parameters_are_loaded(self):
        config = os.path.join(rospkg.RosPack().get_path("drone_estimator"), "config")
        with open(os.path.join(config, "estimator.yaml")) as stream:
            shipped = yaml.safe_load(stream)
        with open(os.path.join(config, "flow_surface_car.yaml")) as stream:
            shipped["flow_surface"] = dict(yaml.safe_load(stream), enabled=True)  # flow_coupling's default
        self.assertEqual(rospy.get_param(NODE), shipped)

    def test_2_its_topics_are_wired_as_the_launch_file_says(self):
        def subscribed():
            topics = dict(rosgraph.Master("/test").getSystemState()[1])
            return {t for t, nodes in topics.items() if NODE in nodes}
        wanted = {"/ardrone/imu", "/drone/navdata", "/ardrone/gps/odom", "/ardrone/altimeter", "/ardrone/sonar_height",
                  "/kalman_platform_odom", "/platform/current_platform_position_in_world", "/test_vehicle/gps/odom"}
        self.wait_for(lambda: wanted <= subscribed(), "the estimator's subscriptions %s" % sorted(wanted))
        self.assertNotIn("/vehicle/gps/odom", subscribed())

    def test_3_it_estimates_at_the_fix_and_publishes_what_the_flow_does_not_see(self):
        self.wait_for(lambda: self.estimates, "an estimate")
        estimate = self.estimates[-1]
        self.assertEqual((estimate.header.frame_id, estimate.child_frame_id), ("world", "ardrone/base_link"))
        self.assertLess(self.offset(estimate, P1), 0.01)
        self.wait_for(lambda: self.unseen, "ardrone/flow_unseen_velocity (the flow surface is on)")
        self.assertEqual(self.unseen[-1].header.frame_id, "world")

    def test_4_a_reset_starts_it_over_from_the_next_fix(self):
        self.wait_for(lambda: self.estimates, "an estimate")
        self.world.gps = P2  # 25 m away: a running estimate would gate that fix
        response = rospy.ServiceProxy(NODE + "/reset", Trigger)()
        self.assertTrue(response.success, response.message)
        reset_at = rospy.get_time()
        self.wait_for(lambda: [m for m in self.estimates if m.header.stamp.to_sec() > reset_at + 0.5],
                      "estimates after the reset")
        after = [m for m in self.estimates if m.header.stamp.to_sec() > reset_at + 0.5]
        self.assertLess(max(self.offset(m, P2) for m in after), 0.01)

    def test_5_a_bad_parameter_refuses_the_reset_naming_it(self):
        key = NODE + "/flow_surface/coverage_low"
        shipped = rospy.get_param(key)
        try:
            rospy.set_param(key, 0.9)  # above coverage_high
            response = rospy.ServiceProxy(NODE + "/reset", Trigger)()
        finally:
            rospy.set_param(key, shipped)
        self.assertFalse(response.success)
        for words in ("not reset", "coverage_low", "drone_estimator/config/"):
            self.assertIn(words, response.message)
        checked_at = rospy.get_time()
        self.wait_for(lambda: [m for m in self.estimates if m.header.stamp.to_sec() > checked_at], "estimates")


if __name__ == "__main__":
    rostest.rosrun("drone_estimator", "drone_estimator_launch", EstimatorLaunchTest)
