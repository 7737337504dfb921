#!/usr/bin/env python3
"""rostest of the MAVROS adapter (ardrone_moves.mavros_adapter_node) flying the simulator's emulated PX4 behind MAVROS.
The tests run in order and share one flight."""
import functools
import math
import unittest

import rospy
import rostest
from geometry_msgs.msg import PoseStamped, Twist
from landing_msgs.msg import Navdata
from landing_runtime import testing
from mavros_msgs.msg import ExtendedState, PositionTarget, State
from std_msgs.msg import Empty, String

WALL_TIMEOUT = 120.0
wait_for = functools.partial(testing.wait_for, timeout=WALL_TIMEOUT)


class MavrosAdapterTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_mavros_adapter")
        cls.status, cls.state, cls.extended, cls.pose, cls.setpoints, cls.navdata = [], [], [], [], [], []
        rospy.Subscriber("/mavros_adapter/status", String, lambda m: cls.status.append(m.data), queue_size=50)
        rospy.Subscriber("/mavros/state", State, cls.state.append, queue_size=50)
        rospy.Subscriber("/mavros/extended_state", ExtendedState, cls.extended.append, queue_size=50)
        rospy.Subscriber("/mavros/local_position/pose", PoseStamped, cls.pose.append, queue_size=50)
        rospy.Subscriber("/mavros/setpoint_raw/local", PositionTarget, cls.setpoints.append, queue_size=50)
        rospy.Subscriber("/drone/navdata", Navdata, cls.navdata.append, queue_size=50)
        cls.takeoff = rospy.Publisher("/ardrone/takeoff", Empty, queue_size=1)
        cls.land = rospy.Publisher("/ardrone/land", Empty, queue_size=1)
        cls.resume = rospy.Publisher("/mavros_adapter/resume", Empty, queue_size=1)
        cls.pilot = rospy.Publisher("/mujoco_sim/pilot_mode", String, queue_size=1)
        cls.velocity = rospy.Publisher("/ardrone/cmd_vel", Twist, queue_size=1)
        wait_for(lambda: cls.status and cls.status[-1].startswith("idle") and cls.pose,
                 "the adapter idle with a local position")

    def phase(self, name, what):
        wait_for(lambda: self.status[-1].startswith(name), what)

    def send(self, forward=0.0, left=0.0, up=0.0, seconds=1.0):
        end = rospy.get_time() + seconds
        command = Twist()
        command.linear.x, command.linear.y, command.linear.z = forward, left, up
        while rospy.get_time() < end:
            self.velocity.publish(command)
            rospy.rostime.wallsleep(0.02)

    def test_1_take_off_streams_offboard_arms_and_climbs(self):
        wait_for(lambda: self.takeoff.get_num_connections(), "the adapter on ardrone/takeoff")
        self.takeoff.publish(Empty())
        self.phase("flying", "the adapter flying after its take-off")
        self.assertEqual(self.state[-1].mode, "OFFBOARD")
        self.assertTrue(self.state[-1].armed)
        self.assertGreater(self.pose[-1].pose.position.z, 3.8)
        sp = self.setpoints[-1]
        self.assertEqual((sp.coordinate_frame, sp.type_mask), (1, 1479))
        self.assertEqual(self.navdata[-1].state, Navdata.STATE_FLYING)
        self.assertGreater(self.navdata[-1].altitude, 3.8)

    def test_2_heading_frame_commands_are_flown(self):
        self.send(forward=2.0, seconds=3.0)
        sp = self.setpoints[-1]
        self.assertAlmostEqual(math.hypot(sp.velocity.x, sp.velocity.y), 2.0, delta=0.05)
        self.assertAlmostEqual(self.navdata[-1].vx, 2.0, delta=0.4)   # forward, heading frame

    def test_3_a_pilots_takeover_stops_the_commands_and_resume_takes_back(self):
        self.pilot.publish(String(data="POSCTL"))
        self.phase("manual", "the adapter stepping back for the pilot")
        count = len(self.setpoints)
        self.send(forward=2.0, seconds=1.0)
        self.assertEqual(len(self.setpoints), count, "set-points while the pilot flies")
        self.resume.publish(Empty())
        self.phase("flying", "flying again after the resume")
        self.assertEqual(self.state[-1].mode, "OFFBOARD")

    def test_4_land_descends_and_disarms_on_the_touchdown(self):
        self.land.publish(Empty())
        self.phase("landing", "the landing")
        # (the set-point in flight when the phase changed may still be the hover's: wait for the descent's)
        wait_for(lambda: self.setpoints[-1].velocity.z < 0.0, "a descending set-point")
        self.phase("landed", "landed and disarmed")
        self.assertEqual(self.extended[-1].landed_state, ExtendedState.LANDED_STATE_ON_GROUND)
        wait_for(lambda: not self.state[-1].armed, "disarmed in mavros/state")
        self.assertTrue(any("disarming" in s for s in self.status))


if __name__ == "__main__":
    rostest.rosrun("ardrone_moves", "mavros_adapter", MavrosAdapterTest)
