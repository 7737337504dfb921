#!/usr/bin/env python3
"""flight_recorder's record in a launch with /use_sim_time, as the project runs it: two recorders (one bag, and
one split every 2 s of sim time) of the topics this test publishes (one latched, one not matching the regex)
on the sim clock this test publishes. Stopped with SIGINT and SIGTERM, their bags are checked with the Python
rosbag API and with rosbags."""
import glob
import os
import signal
import sys
import time
import unittest

import rosbag
import rospy
import rostest
from geometry_msgs.msg import Twist
from rosbags.rosbag1 import Reader
from sensor_msgs.msg import Imu
from std_msgs.msg import String

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from recorder_test_support import (SIM_START_S, SimClock, master, node_pid, process_gone, subscribers_of,  # noqa: E402
                                   wait_delivered, wait_for)

ROUNDS = 150          # messages on each recorded topic
ROUND_WALL_S = 0.03   # 4.5 s of sim time: the split recorder writes 3 bags of 2 s
SPLIT_S = 2.0
IMU, TWIST, LATCHED, IGNORED = ("/recorder_test/imu", "/recorder_test/twist", "/recorder_test/latched",
                                "/recorder_test/ignored")
RECORDERS = ("/flight_recorder", "/flight_recorder_split")


class RecorderTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("recorder_test")
        prefix = rospy.get_param("~bag_prefix")
        cls.bag = prefix + "_flight.bag"
        cls.split_stem = prefix + "_split"
        cls.clock = SimClock()
        # queue_size=None: published synchronously, so that delivery can be checked on the sockets
        imu = rospy.Publisher(IMU, Imu, queue_size=None)
        twist = rospy.Publisher(TWIST, Twist, queue_size=None)
        latched = rospy.Publisher(LATCHED, String, queue_size=None, latch=True)
        ignored = rospy.Publisher(IGNORED, String, queue_size=None)
        latched.publish(String(data="latched before the recorders subscribed"))

        for recorder in RECORDERS:
            for topic in (IMU, TWIST, LATCHED):
                wait_for(lambda: recorder in subscribers_of(topic), "%s to subscribe to %s" % (recorder, topic))
        # registered at the master is not yet connected: a message published before would be lost
        for publisher in (imu, twist, latched):
            wait_for(lambda: publisher.get_num_connections() == len(RECORDERS),
                     "both recorders to connect to " + publisher.resolved_name)
        cls.pids = {recorder: node_pid(recorder) for recorder in RECORDERS}
        cls.written_before_clock = glob.glob(prefix + "*")

        cls.clock.start()
        wait_for(lambda: os.path.exists(cls.bag + ".active") and os.path.exists(cls.split_stem + "_0.bag.active"),
                 "the recorders to open their bags once the clock is valid")
        cls.first_stamp = cls.clock.now()
        for i in range(ROUNDS):
            message = Imu()
            message.angular_velocity.x = i  # its number (rospy sets header.seq itself)
            message.header.stamp = cls.clock.now()
            imu.publish(message)
            twist.publish(Twist())
            ignored.publish(String(data="not recorded"))
            time.sleep(ROUND_WALL_S)  # the publishing rate
        cls.last_stamp = cls.clock.now()
        wait_delivered([imu, twist, latched], "the recorders to read every message")

        cls.stop_wall_s = {}
        for recorder, sig in zip(RECORDERS, (signal.SIGINT, signal.SIGTERM)):
            began = time.monotonic()
            os.kill(cls.pids[recorder], sig)
            wait_for(lambda: process_gone(cls.pids[recorder]), "%s to exit after %s" % (recorder, sig.name),
                     poll_s=0.002)
            cls.stop_wall_s[recorder] = time.monotonic() - began
        cls.split_bags = sorted(glob.glob(glob.escape(cls.split_stem) + "_*.bag*"),
                                key=lambda p: int(p[len(cls.split_stem) + 1:].split(".")[0]))
        state = master().getSystemState()  # (publications, subscriptions, services) once both have exited
        kinds = ("published", "subscribed", "service")
        cls.left_registered = sorted({(kind, name) for kind, entries in zip(kinds, state)
                                      for name, nodes in entries for node in nodes if node in RECORDERS})
        cls.clock.running = False
        rospy.loginfo("stop wall times: %s", cls.stop_wall_s)

    @classmethod
    def tearDownClass(cls):
        for path in glob.glob(glob.escape(cls.bag) + "*") + glob.glob(glob.escape(cls.split_stem) + "_*"):
            os.remove(path)

    def test_nothing_is_written_before_the_clock_is_valid(self):
        self.assertEqual(self.written_before_clock, [])

    def test_a_clean_stop_renames_the_active_bags_promptly(self):
        self.assertTrue(os.path.exists(self.bag))
        self.assertFalse(os.path.exists(self.bag + ".active"))
        self.assertGreaterEqual(len(self.split_bags), 2, self.split_bags)
        for index, path in enumerate(self.split_bags):
            self.assertEqual(path, "%s_%d.bag" % (self.split_stem, index))
        for recorder, wall_s in self.stop_wall_s.items():
            self.assertLess(wall_s, 1.0, "%s took %.3f s to stop" % (recorder, wall_s))  # 0.01 s when not loaded

    def test_a_stopped_recorder_leaves_nothing_registered_at_the_master(self):
        # roscpp's own /clock subscription and /rosout publication too: a warm graph's next recorder has the
        # same name and waits until the previous one is gone from the master.
        self.assertEqual(self.left_registered, [])

    def test_counts_and_types_per_topic(self):
        with rosbag.Bag(self.bag) as bag:
            topics = bag.get_type_and_topic_info().topics
        self.assertEqual({t: (i.msg_type, i.message_count) for t, i in topics.items()}, {
            IMU: ("sensor_msgs/Imu", ROUNDS), TWIST: ("geometry_msgs/Twist", ROUNDS),
            LATCHED: ("std_msgs/String", 1)})

    def test_messages_in_order_with_the_latched_one(self):
        with rosbag.Bag(self.bag) as bag:
            latched = [m.data for _, m, _ in bag.read_messages(topics=[LATCHED])]
            sequence = [int(m.angular_velocity.x) for _, m, _ in bag.read_messages(topics=[IMU])]
        self.assertEqual(latched, ["latched before the recorders subscribed"])
        self.assertEqual(sequence, list(range(ROUNDS)))

    def test_receipt_times_are_sim_times(self):
        with rosbag.Bag(self.bag) as bag:
            for topic, message, receipt in bag.read_messages():
                self.assertGreaterEqual(receipt.to_sec(), SIM_START_S, topic)
                self.assertLessEqual(receipt, self.last_stamp + rospy.Duration(5.0), topic)
                if topic == IMU:  # received after it was sent (on the clock the recorder had heard by then)
                    delay_s = (receipt - message.header.stamp).to_sec()
                    self.assertGreater(delay_s, -0.5, topic)
                    self.assertLess(delay_s, 5.0, topic)

    def test_split_bags_hold_every_message_in_2_s_of_sim_time_each(self):
        counts, previous_end = {}, None
        for index, path in enumerate(self.split_bags):
            with rosbag.Bag(path) as bag:
                for topic, info in bag.get_type_and_topic_info().topics.items():
                    counts[topic] = counts.get(topic, 0) + info.message_count
                times = [t.to_sec() for _, _, t in bag.read_messages()]
                latched = bag.get_message_count(topic_filters=[LATCHED])
            self.assertEqual(latched, 1 if index == 0 else 0, path)  # as rosbag record without --repeat-latched
            if times:
                # a little more when the bag was started by the idle check while older messages were queued
                self.assertLessEqual(max(times) - min(times), SPLIT_S + 0.5, path)
                if previous_end is not None:
                    self.assertGreaterEqual(min(times), previous_end, path)
                previous_end = max(times)
        self.assertEqual(counts, {IMU: ROUNDS, TWIST: ROUNDS, LATCHED: 1})

    def test_rosbags_reads_the_publishers_connection_headers(self):
        with Reader(self.bag) as reader:
            counts = {c.topic: c.msgcount for c in reader.connections}
            headers = {c.topic: (c.msgtype, c.ext.callerid, c.ext.latching) for c in reader.connections}
            self.assertEqual(sum(1 for _ in reader.messages()), 2 * ROUNDS + 1)
        self.assertEqual(counts, {IMU: ROUNDS, TWIST: ROUNDS, LATCHED: 1})
        self.assertEqual(headers[LATCHED], ("std_msgs/msg/String", rospy.get_name(), 1))
        self.assertEqual(headers[IMU], ("sensor_msgs/msg/Imu", rospy.get_name(), 0))


if __name__ == "__main__":
    rostest.rosrun("flight_recorder", "recorder", RecorderTest)
