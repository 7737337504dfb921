#!/usr/bin/env python3
"""A recorder killed outright (SIGKILL) leaves NAME.bag.active; rosbag's reindex gets back every message of its
complete chunks (all but the last few at 1 kB chunks), which rosbags then reads."""
import glob
import os
import shutil
import signal
import sys
import time
import unittest

import rosbag
import rospy
import rostest
from rosbags.rosbag1 import Reader
from sensor_msgs.msg import Imu
from std_msgs.msg import String

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from recorder_test_support import SimClock, node_pid, process_gone, subscribers_of, wait_delivered, wait_for  # noqa

MESSAGES = 200
IMU, LATCHED = "/killed_test/imu", "/killed_test/latched"
# An Imu record is about 380 bytes: a 1 kB chunk holds 3; the open one is lost, and so is at most one more
# whose compressed bytes were still in the file's buffer.
MOST_LOST = 8


class KilledRecorderTest(unittest.TestCase):
    def setUp(self):
        rospy.init_node("killed_test")
        prefix = rospy.get_param("~bag_prefix")
        self.bag = prefix + "_killed.bag"
        self.reindexed = prefix + "_reindexed.bag"
        self.clock = SimClock()
        self.clock.start()

    def tearDown(self):
        self.clock.running = False
        for path in glob.glob(glob.escape(self.bag) + "*") + glob.glob(glob.escape(self.reindexed) + "*"):
            os.remove(path)

    def test_the_complete_chunks_of_a_killed_recorder_are_read_back(self):
        imu = rospy.Publisher(IMU, Imu, queue_size=None)
        latched = rospy.Publisher(LATCHED, String, queue_size=None, latch=True)
        latched.publish(String(data="latched"))
        for topic in (IMU, LATCHED):
            wait_for(lambda: "/flight_recorder" in subscribers_of(topic), "the recorder to subscribe to " + topic)
        for publisher in (imu, latched):  # registered at the master is not yet connected
            wait_for(lambda: publisher.get_num_connections() == 1,
                     "the recorder to connect to " + publisher.resolved_name)
        pid = node_pid("/flight_recorder")
        active = self.bag + ".active"
        wait_for(lambda: os.path.exists(active), "the recorder to open its bag")
        for i in range(MESSAGES):
            message = Imu()
            message.angular_velocity.x = i  # its number (rospy sets header.seq itself)
            message.header.stamp = self.clock.now()
            imu.publish(message)
            time.sleep(0.005)  # the publishing rate
        wait_delivered([imu, latched], "the recorder to read every message")
        sizes = [-1]

        def written():  # the file has not grown for 0.4 s
            sizes.append(os.path.getsize(active))
            return len(sizes) > 3 and sizes[-1] == sizes[-2] == sizes[-3]
        wait_for(written, "the recorder to write what it read", poll_s=0.2)

        os.kill(pid, signal.SIGKILL)
        wait_for(lambda: process_gone(pid), "the killed recorder to be gone")
        self.assertTrue(os.path.exists(active))
        self.assertFalse(os.path.exists(self.bag))

        shutil.copy(active, self.reindexed)
        with rosbag.Bag(self.reindexed, "a", allow_unindexed=True) as bag:
            for _ in bag.reindex():
                pass
        with rosbag.Bag(self.reindexed) as bag:
            sequence = [int(m.angular_velocity.x) for _, m, _ in bag.read_messages(topics=[IMU])]
            latched_count = bag.get_message_count(topic_filters=[LATCHED])
        rospy.loginfo("%d of %d messages back after a SIGKILL", len(sequence), MESSAGES)
        self.assertEqual(latched_count, 1)
        self.assertGreaterEqual(len(sequence), MESSAGES - MOST_LOST)
        self.assertEqual(sequence, list(range(len(sequence))))  # the first ones, none missing between

        with Reader(self.reindexed) as reader:
            counts = {c.topic: c.msgcount for c in reader.connections}
        self.assertEqual(counts, {IMU: len(sequence), LATCHED: 1})


if __name__ == "__main__":
    rostest.rosrun("flight_recorder", "recorder_killed", KilledRecorderTest)
