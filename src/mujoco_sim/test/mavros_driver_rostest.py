#!/usr/bin/env python3
"""rostest of the simulator's emulated PX4 behind MAVROS (drone_model px4_quad), from the outside: the offboard rules
as a companion computer meets them. The tests run in order and share one flight."""
import functools
import threading
import unittest

import rosgraph
import rospy
import rostest
from geometry_msgs.msg import PoseStamped, TwistStamped
from landing_runtime import testing
from mavros_msgs.msg import ExtendedState, PositionTarget, State
from mavros_msgs.srv import CommandBool, CommandTOL, SetMode
from sensor_msgs.msg import BatteryState, Imu, NavSatFix
from std_msgs.msg import String

WALL_TIMEOUT = 120.0
wait_for = functools.partial(testing.wait_for, timeout=WALL_TIMEOUT)
# MAVROS 1.x's md5sums (mavros_msgs, as its generated code carries them).
MD5 = {State: "65cd0a9fff993b062b91e354554ec7e9", ExtendedState: "ae780b1800fe17b917369d21b90058bd",
       PositionTarget: "dedb0081aaf8cb20209737746bb49117", CommandBool: "e09abbb4e5bae6b558e5010966eb6e9e",
       SetMode: "e4f18fa93379f9ff1780d270ce110203", CommandTOL: "93ff4eaa9907f58c0e7a909cddce23e2"}
VELOCITY_AND_YAW_RATE = (PositionTarget.IGNORE_PX | PositionTarget.IGNORE_PY | PositionTarget.IGNORE_PZ |
                         PositionTarget.IGNORE_AFX | PositionTarget.IGNORE_AFY | PositionTarget.IGNORE_AFZ |
                         PositionTarget.IGNORE_YAW)
ON_GROUND, IN_AIR = ExtendedState.LANDED_STATE_ON_GROUND, ExtendedState.LANDED_STATE_IN_AIR


class Streamer:
    """Publishes a velocity set-point on mavros/setpoint_raw/local at 20 Hz of wall time while ``on``."""

    def __init__(self):
        self.pub = rospy.Publisher("/mavros/setpoint_raw/local", PositionTarget, queue_size=5)
        self.velocity = (0.0, 0.0, 0.0)
        self.on = False
        threading.Thread(target=self._run, daemon=True).start()

    def _run(self):
        while not rospy.is_shutdown():
            if self.on:
                msg = PositionTarget(coordinate_frame=PositionTarget.FRAME_LOCAL_NED, type_mask=VELOCITY_AND_YAW_RATE)
                msg.header.stamp = rospy.Time.now()
                msg.velocity.x, msg.velocity.y, msg.velocity.z = self.velocity
                self.pub.publish(msg)
            rospy.rostime.wallsleep(0.05)


class MavrosDriverTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_mavros_driver")
        cls.state, cls.extended, cls.pose = [], [], []
        rospy.Subscriber("/mavros/state", State, cls.state.append, queue_size=50)
        rospy.Subscriber("/mavros/extended_state", ExtendedState, cls.extended.append, queue_size=50)
        rospy.Subscriber("/mavros/local_position/pose", PoseStamped, cls.pose.append, queue_size=100)
        cls.pilot = rospy.Publisher("/mujoco_sim/pilot_mode", String, queue_size=1)
        cls.stream = Streamer()
        for name in ("/mavros/cmd/arming", "/mavros/set_mode", "/mavros/cmd/takeoff", "/mavros/cmd/land"):
            rospy.wait_for_service(name, timeout=WALL_TIMEOUT)
        cls.arming = rospy.ServiceProxy("/mavros/cmd/arming", CommandBool)
        cls.set_mode = rospy.ServiceProxy("/mavros/set_mode", SetMode)
        wait_for(lambda: cls.state and cls.pose and cls.extended, "the first mavros/state, pose and extended_state")

    def mode_becomes(self, mode, what):
        wait_for(lambda: self.state[-1].mode == mode, what)

    def sim_sleep(self, seconds):
        end = rospy.get_time() + seconds
        wait_for(lambda: rospy.get_time() >= end, "%.1f s of sim time" % seconds)

    def height(self):
        return self.pose[-1].pose.position.z

    def test_1_the_topics_and_services_carry_mavros_types(self):
        master = rosgraph.Master("/test_mavros_driver")
        types = dict(master.getTopicTypes())
        expected = {"/mavros/state": "mavros_msgs/State", "/mavros/extended_state": "mavros_msgs/ExtendedState",
                    "/mavros/local_position/pose": "geometry_msgs/PoseStamped",
                    "/mavros/local_position/velocity_local": "geometry_msgs/TwistStamped",
                    "/mavros/global_position/global": "sensor_msgs/NavSatFix", "/mavros/imu/data": "sensor_msgs/Imu",
                    "/mavros/battery": "sensor_msgs/BatteryState"}
        for topic, kind in expected.items():
            self.assertEqual(types.get(topic), kind, topic)
        for kind, md5 in MD5.items():
            self.assertEqual(kind._md5sum, md5, kind._type)
        subscribed = {topic for topic, _nodes in master.getSystemState()[1]}
        self.assertIn("/mavros/setpoint_raw/local", subscribed)
        self.assertIn("/mavros/setpoint_velocity/cmd_vel_unstamped", subscribed)
        for absent in ("/ardrone/cmd_vel", "/ardrone/takeoff", "/cmd_vel"):
            self.assertNotIn(absent, subscribed)   # PX4 takes nothing of the AR.Drone's
        self.assertNotIn("/ardrone/navdata", types)
        for msg_type, topic in ((TwistStamped, "velocity_local"), (NavSatFix, "global"), (Imu, "data"),
                                (BatteryState, "battery")):
            name = {"velocity_local": "/mavros/local_position/velocity_local", "global": "/mavros/global_position/global",
                    "data": "/mavros/imu/data", "battery": "/mavros/battery"}[topic]
            rospy.wait_for_message(name, msg_type, timeout=WALL_TIMEOUT)
        state = self.state[-1]
        self.assertTrue(state.connected)
        self.assertFalse(state.armed)
        self.assertEqual(state.mode, State.MODE_PX4_POSITION)      # where the pilot's switch stands
        self.assertEqual(self.extended[-1].landed_state, ON_GROUND)

    def test_2_no_offboard_without_the_stream(self):
        answer = self.set_mode(base_mode=0, custom_mode="OFFBOARD")
        self.assertTrue(answer.mode_sent)                          # sent: MAVROS cannot know PX4's answer
        self.assertFalse(self.set_mode(base_mode=0, custom_mode="NO_SUCH_MODE").mode_sent)
        count = len(self.state)
        wait_for(lambda: len(self.state) >= count + 2, "two more heartbeats")
        self.assertEqual(self.state[-1].mode, "POSCTL")

    def test_3_offboard_once_set_points_stream_then_arming_and_a_take_off(self):
        self.stream.on = True
        self.sim_sleep(1.0)
        self.assertTrue(self.set_mode(base_mode=0, custom_mode="OFFBOARD").mode_sent)
        self.mode_becomes("OFFBOARD", "OFFBOARD once set-points stream")
        self.assertTrue(self.state[-1].guided)
        answer = self.arming(value=True)
        self.assertTrue(answer.success, answer)
        wait_for(lambda: self.state[-1].armed, "armed in mavros/state")
        start = self.height()
        self.stream.velocity = (0.0, 0.0, 1.0)
        wait_for(lambda: self.height() > start + 2.5, "the climb")
        self.stream.velocity = (0.0, 0.0, 0.0)
        self.assertEqual(self.extended[-1].landed_state, IN_AIR)
        self.assertFalse(self.arming(value=False).success)            # no disarming in the air

    def test_4_the_pilot_takes_over_by_switching_the_mode(self):
        self.stream.velocity = (2.0, 0.0, 0.0)
        self.pilot.publish(String(data="POSCTL"))
        self.mode_becomes("POSCTL", "the pilot's POSCTL")
        here = self.pose[-1].pose.position.x
        self.sim_sleep(2.0)
        self.assertLess(abs(self.pose[-1].pose.position.x - here), 0.5, "the set-points still flew the drone")
        self.assertTrue(self.state[-1].manual_input)
        self.stream.velocity = (0.0, 0.0, 0.0)
        self.assertTrue(self.set_mode(base_mode=0, custom_mode="OFFBOARD").mode_sent)   # handed back
        self.mode_becomes("OFFBOARD", "OFFBOARD again")

    def test_5_failsafe_when_the_stream_stops_hold_then_land_then_disarm(self):
        self.stream.on = False
        self.mode_becomes("AUTO.LOITER", "the offboard-loss failsafe's hold")
        self.assertEqual(self.state[-1].system_status, 5)           # MAV_STATE_CRITICAL
        self.mode_becomes("AUTO.LAND", "the failsafe's landing after the hold")
        wait_for(lambda: self.extended[-1].landed_state == ON_GROUND, "the land detector")
        wait_for(lambda: not self.state[-1].armed, "the auto-disarm after landing")


if __name__ == "__main__":
    rostest.rosrun("mujoco_sim", "mavros_driver", MavrosDriverTest)
