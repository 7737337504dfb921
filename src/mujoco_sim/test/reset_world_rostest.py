#!/usr/bin/env python3
"""rostest of ~reset_world: a reset world flies as the fresh one did, ROS time goes on, parameters are read again;
and of mujoco_sim/hold: the world stands until the next start.

The drone starts hovering 2 m up in gusty wind (reset.test), with no command: everything it does then is seeded,
so two flights of the same world must publish the same messages at the same times after their time 0."""
import hashlib
import re
import unittest

import rospy
import rostest
from landing_runtime import testing
from landing_msgs.msg import Navdata
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Image, Imu, NavSatFix, Range
from std_msgs.msg import Empty
from std_srvs.srv import Trigger

WALL_TIMEOUT = 120.0
FLIGHT_S = 4.0  # world time each flight lasts before the next reset [s]
COMPARED_S = 3.5  # world time over which two flights are compared (messages still in their links are left out) [s]


def _position(pose):
    return (pose.position.x, pose.position.y, pose.position.z,
            pose.orientation.w, pose.orientation.x, pose.orientation.y, pose.orientation.z)


# topic: (type, what of a message two identical worlds must agree on)
CONTENT = {
    "/ardrone/imu": (Imu, lambda m: (m.orientation.x, m.orientation.y, m.angular_velocity.z, m.linear_acceleration.z)),
    "/drone/navdata": (Navdata, lambda m: (m.state, m.battery_percent, m.altitude, m.vx, m.vy, m.rot_z)),
    "/ardrone/sonar_height": (Range, lambda m: m.range),
    "/ardrone/gps/odom": (Odometry, lambda m: _position(m.pose.pose)),
    "/summit_xl/gps/fix": (NavSatFix, lambda m: (m.status.status, m.latitude, m.longitude)),
    "/robotnik_base_control/odom": (Odometry, lambda m: _position(m.pose.pose)),
    "/ardrone/ground_truth/state": (Odometry, lambda m: _position(m.pose.pose)),
    "/ardrone/bottom/image_raw": (Image, lambda m: hashlib.sha1(m.data).hexdigest()),
}
IMAGES = "/ardrone/bottom/image_raw"


class ResetWorldTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_reset_world")
        cls.received = {topic: [] for topic in CONTENT}  # (stamp, content) in arrival order
        cls.subscribers = [rospy.Subscriber(topic, kind, cls._recorder(topic, content), queue_size=1000,
                                            buff_size=2 ** 24) for topic, (kind, content) in CONTENT.items()]
        cls.clock = []
        cls.subscribers.append(rospy.Subscriber("/clock", Clock, lambda m: cls.clock.append(m.clock.to_sec())))
        cls.start = rospy.Publisher("/mujoco_sim/start", Empty, queue_size=1, latch=True)
        rospy.wait_for_service("/mujoco_sim/reset_world", timeout=WALL_TIMEOUT)
        cls.reset_service = rospy.ServiceProxy("/mujoco_sim/reset_world", Trigger)
        # The simulator publishes a topic only to subscribers: all must be connected before the first flight.
        testing.wait_for(lambda: all(s.get_num_connections() for s in cls.subscribers), "connections to the simulator",
                         WALL_TIMEOUT)
        cls.origin = 0.0  # ROS time of the held world's time 0 [s]
        cls.first_flight = cls.fly()

    @classmethod
    def _recorder(cls, topic, content):
        def record(msg):
            cls.received[topic].append((msg.header.stamp.to_sec(), content(msg)))
        return record

    @classmethod
    def reset(cls):
        """Call ~reset_world; a success gives the new world's time 0 in ROS time. Returns the response."""
        response = cls.reset_service()
        if response.success:
            cls.origin = float(re.search(r"ROS time ([0-9.]+) s", response.message).group(1))
        return response

    @classmethod
    def fly(cls):
        """Start the held world, let it fly FLIGHT_S and reset it (held again). Returns what it published in its
        first COMPARED_S, {topic: [(world time, content)]}."""
        origin = cls.origin
        cls.start.publish(Empty())
        ground_truth = cls.received["/ardrone/ground_truth/state"]
        testing.wait_for(lambda: ground_truth and ground_truth[-1][0] >= origin + FLIGHT_S,
                         "%.0f s of flight from ROS time %.3f" % (FLIGHT_S, origin), WALL_TIMEOUT)
        response = cls.reset()
        assert response.success, response.message
        # World times are multiples of the 4 ms physics step, compared as such; the last world may have published at
        # its last instant, which is this one's time 0.
        flight = {topic: [(round(stamp - origin, 3), content) for stamp, content in messages]
                  for topic, messages in cls.received.items()}
        return {topic: [(t, content) for t, content in messages if 0.0 < t <= COMPARED_S]
                for topic, messages in flight.items()}

    def assertSameFlight(self, flight, reference):
        for topic, messages in reference.items():
            self.assertGreater(len(messages), 5, "%s: too few messages to compare" % topic)
            if topic == IMAGES:
                # rospy's queued image publisher may drop a frame on a loaded machine: compare the frames both have.
                frames, reference_frames = dict(flight[topic]), dict(messages)
                common = frames.keys() & reference_frames.keys()
                self.assertGreater(len(common), len(messages) // 2, "too few frames in both flights")
                self.assertEqual({t: frames[t] for t in common}, {t: reference_frames[t] for t in common},
                                 "the frames differ after the reset")
            else:
                self.assertEqual(flight[topic], messages, "%s differs after the reset" % topic)

    def test_1_a_reset_world_flies_as_the_fresh_one_did(self):
        self.assertSameFlight(self.fly(), self.first_flight)

    def test_2_ros_time_never_runs_backwards(self):
        self.assertTrue(self.clock, "no /clock received")
        backwards = [(a, b) for a, b in zip(self.clock, self.clock[1:]) if b < a]
        self.assertEqual(backwards, [], "/clock ran backwards across a reset")

    def test_3_a_reset_reads_the_parameters_again(self):
        rospy.set_param("/mujoco_sim/seed", 7)
        self.assertTrue(self.reset().success)  # the held world, replaced by one of seed 7
        other = self.fly()
        self.assertNotEqual(other["/ardrone/imu"], self.first_flight["/ardrone/imu"], "another seed, other noise")
        rospy.set_param("/mujoco_sim/seed", 0)
        self.assertTrue(self.reset().success)
        self.assertSameFlight(self.fly(), self.first_flight)

    def test_4_a_bad_parameter_or_model_leaves_the_world_as_it_was(self):
        model_file = rospy.get_param("/mujoco_sim/model_file")
        for name, value, named in (("rates/clock_hz", -1.0, "clock_hz"),
                                   ("model_file", "/nonexistent/world.xml", "/nonexistent/world.xml: model file not found")):
            original = rospy.get_param("/mujoco_sim/" + name)
            rospy.set_param("/mujoco_sim/" + name, value)
            try:
                response = self.reset()
            finally:
                rospy.set_param("/mujoco_sim/" + name, original)
            self.assertFalse(response.success)
            self.assertIn("not reset", response.message)
            self.assertIn(named, response.message)
        self.assertEqual(rospy.get_param("/mujoco_sim/model_file"), model_file)
        self.assertSameFlight(self.fly(), self.first_flight)

    def test_5_a_hold_stops_the_world_until_the_next_start(self):
        origin, truth = self.origin, self.received["/ardrone/ground_truth/state"]
        hold = rospy.Publisher("/mujoco_sim/hold", Empty, queue_size=1)
        testing.wait_for(lambda: hold.get_num_connections(), "the simulator on mujoco_sim/hold", WALL_TIMEOUT)
        self.start.publish(Empty())
        testing.wait_for(lambda: truth and truth[-1][0] >= origin + 1.0, "1 s of flight", WALL_TIMEOUT)
        hold.publish(Empty())
        # Held: the simulator publishes its clock again and again, unchanged, and nothing later than it.
        ticks = len(self.clock)
        testing.wait_for(lambda: len(self.clock) >= ticks + 10 and len(set(self.clock[-5:])) == 1,
                         "the clock standing", WALL_TIMEOUT)
        held, ticks = self.clock[-1], len(self.clock)
        testing.wait_for(lambda: len(self.clock) >= ticks + 5, "5 more ticks of the held clock", WALL_TIMEOUT)
        self.assertEqual(set(self.clock[ticks:]), {held})
        self.assertLessEqual(truth[-1][0], held)
        self.start.publish(Empty())
        testing.wait_for(lambda: truth[-1][0] >= held + 0.5, "the flight going on after the start", WALL_TIMEOUT)
        self.assertTrue(self.reset().success)

    def test_6_a_reset_takes_the_conditions_set_just_before_it(self):
        # The simulator has the condition parameters cached (the master pushes changes, about 60 ms late): a reset
        # right after a runner set new ones must take the master's, not write the previous world's back over them.
        original = rospy.get_param("/wind_speed")
        rospy.set_param("/wind_speed", original + 2.0)
        try:
            self.assertTrue(self.reset().success)
            self.assertEqual(rospy.get_param("/wind_speed"), original + 2.0)
            self.fly()
            self.assertEqual(rospy.get_param("/wind_speed"), original + 2.0)
        finally:
            rospy.set_param("/wind_speed", original)
        self.assertTrue(self.reset().success)


if __name__ == "__main__":
    rostest.rosrun("mujoco_sim", "reset_world", ResetWorldTest)
