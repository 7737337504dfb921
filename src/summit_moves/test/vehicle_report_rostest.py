#!/usr/bin/env python3
"""rostest of vehicle_report: the real drivers' messages in (summit_xl/gps/fix, summit_xl/gps/vel,
robotnik_base_control/odom), the stack's summit_xl/gps/odom out; a NO_FIX and a silent odometry give an honest
report (unknown parts), never a wrong one."""
import math
import threading
import unittest

import rospy
import rostest
from geometry_msgs.msg import TwistStamped
from landing_runtime import testing
from nav_msgs.msg import Odometry
from navsat_local.enu import LocalFrame
from sensor_msgs.msg import NavSatFix, NavSatStatus
from std_msgs.msg import String
from std_srvs.srv import Trigger

WALL_TIMEOUT = 30.0
YAW, SPEED, YAW_RATE = math.radians(30.0), 2.0, 0.1
EAST, NORTH = 12.0, -7.0


def yaw_of(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


class VehicleReportTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_vehicle_report")
        cls.frame = LocalFrame.around(tuple(rospy.get_param("/navsat_datum")[k] for k in ("lat", "lon", "alt")))
        cls.reports, cls.status = [], []
        rospy.Subscriber("/summit_xl/gps/odom", Odometry, cls.reports.append, queue_size=100)
        rospy.Subscriber("/vehicle_report/status", String, lambda m: cls.status.append(m.data), queue_size=10)
        cls.fix_pub = rospy.Publisher("/summit_xl/gps/fix", NavSatFix, queue_size=10)
        cls.vel_pub = rospy.Publisher("/summit_xl/gps/vel", TwistStamped, queue_size=10)
        cls.odom_pub = rospy.Publisher("/robotnik_base_control/odom", Odometry, queue_size=10)
        cls.odometry_on = threading.Event()
        cls.odometry_on.set()
        cls.no_fix = threading.Event()
        threading.Thread(target=cls._drivers, daemon=True).start()

    @classmethod
    def _drivers(cls):
        """Robotnik's odometry at 50 Hz, the receiver's fix and velocity at 5 Hz (stamped alike)."""
        rate, tick = rospy.Rate(50.0), 0
        while not rospy.is_shutdown():
            now = rospy.Time.now()
            if cls.odometry_on.is_set():
                odom = Odometry()
                odom.header.stamp, odom.header.frame_id = now, "summit_xl/odom"
                odom.child_frame_id = "summit_xl/base_link"
                odom.pose.pose.orientation.z, odom.pose.pose.orientation.w = math.sin(YAW / 2), math.cos(YAW / 2)
                odom.twist.twist.linear.x, odom.twist.twist.angular.z = SPEED, YAW_RATE
                odom.pose.covariance[35] = math.radians(2.0) ** 2
                odom.twist.covariance[0], odom.twist.covariance[35] = 0.05 ** 2, 0.02 ** 2
                cls.odom_pub.publish(odom)
            if tick % 10 == 0:
                no_fix, vel = cls.no_fix.is_set(), None
                fix = NavSatFix()
                fix.header.stamp, fix.header.frame_id = now, "summit_xl/base_link"
                if no_fix:
                    fix.status.status = NavSatStatus.STATUS_NO_FIX
                else:
                    fix.latitude, fix.longitude, fix.altitude = cls.frame.to_geodetic(EAST, NORTH, 0.0)
                    fix.position_covariance = [6.25, 0, 0, 0, 6.25, 0, 0, 0, 25.0]
                    fix.position_covariance_type = NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN
                    vel = TwistStamped()
                    vel.header = fix.header
                    vel.twist.linear.x, vel.twist.linear.y = 1.5, 1.0
                cls.fix_pub.publish(fix)
                if vel is not None:
                    cls.vel_pub.publish(vel)
            tick += 1
            rate.sleep()

    def latest_after(self, t):
        return testing.wait_for(lambda: next((m for m in reversed(self.reports) if m.header.stamp.to_sec() > t), None),
                                "a report after t=%.2f" % t, WALL_TIMEOUT)

    def test_1_report_of_fix_velocity_and_odometry(self):
        msg = self.latest_after(rospy.get_time() + 0.5)
        self.assertEqual((msg.header.frame_id, msg.child_frame_id), ("world", "summit_xl/base_link"))
        p = msg.pose.pose.position
        self.assertAlmostEqual(p.x, EAST, delta=1e-3)
        self.assertAlmostEqual(p.y, NORTH, delta=1e-3)
        self.assertAlmostEqual(msg.pose.covariance[0], 6.25, delta=1e-6)
        self.assertAlmostEqual(yaw_of(msg.pose.pose.orientation), YAW, delta=1e-6)
        self.assertAlmostEqual(msg.pose.covariance[35], math.radians(2.0) ** 2, delta=1e-9)
        self.assertAlmostEqual(msg.twist.twist.linear.x, 1.5, delta=1e-9)  # the receiver's, ENU
        self.assertAlmostEqual(msg.twist.twist.linear.y, 1.0, delta=1e-9)
        self.assertAlmostEqual(msg.twist.twist.angular.z, YAW_RATE, delta=1e-9)
        testing.wait_for(lambda: self.status and self.status[-1] == "ok", "status ok", WALL_TIMEOUT)

    def test_2_no_fix_reports_unknown_position_and_the_odometrys_velocity(self):
        self.no_fix.set()
        try:
            msg = self.latest_after(rospy.get_time() + 0.5)
            self.assertEqual(msg.pose.covariance[0], 1e6)
            self.assertAlmostEqual(msg.twist.twist.linear.x, SPEED * math.cos(YAW), delta=1e-6)
            self.assertAlmostEqual(msg.twist.twist.linear.y, SPEED * math.sin(YAW), delta=1e-6)
            testing.wait_for(lambda: self.status and "NO_FIX" in self.status[-1], "status naming NO_FIX", WALL_TIMEOUT)
        finally:
            self.no_fix.clear()

    def test_3_silent_odometry_leaves_heading_and_yaw_rate_unknown(self):
        self.odometry_on.clear()
        try:
            msg = self.latest_after(rospy.get_time() + 1.0)
            self.assertEqual(msg.pose.covariance[35], 1e6)
            self.assertEqual(msg.twist.covariance[35], 1e6)
            self.assertAlmostEqual(msg.twist.twist.linear.x, 1.5, delta=1e-9)  # the receiver's velocity goes on
            self.assertLess(msg.pose.covariance[0], 1e6)
        finally:
            self.odometry_on.set()

    def test_4_reset_starts_afresh_and_reports_go_on(self):
        rospy.wait_for_service("/vehicle_report/reset", timeout=WALL_TIMEOUT)
        reply = rospy.ServiceProxy("/vehicle_report/reset", Trigger)()
        self.assertTrue(reply.success, reply.message)
        msg = self.latest_after(rospy.get_time() + 0.5)
        self.assertAlmostEqual(msg.pose.pose.position.x, EAST, delta=1e-3)
        self.assertAlmostEqual(yaw_of(msg.pose.pose.orientation), YAW, delta=1e-6)


if __name__ == "__main__":
    rostest.rosrun("summit_moves", "vehicle_report", VehicleReportTest)
