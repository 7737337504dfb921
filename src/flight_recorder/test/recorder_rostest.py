#!/usr/bin/env python3
"""rostest of the flight recorder under sim time (recorder.test): what it records and with which receipt times,
its splits, a latched topic, a clean stop on SIGINT and SIGTERM, what a SIGKILL leaves, and bad command lines.

The test is the clock: it publishes /clock itself, so that the receipt times the bag holds are known."""
import os
import shutil
import signal
import subprocess
import tempfile
import unittest
import xmlrpc.client

import rosbag
import rosgraph
import roslib.packages
import rospy
import rostest
from geometry_msgs.msg import PoseStamped, TransformStamped
from landing_msgs.testing import wait_for
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

TIMEOUT = 60.0  # wall seconds any wait may take on a loaded machine
REGEX = "/(ardrone/imu|groundtruth/.*|tf|tf_static)"
OPTIONS = ["--lz4", "--chunksize=32", "-e", REGEX]
RECORDED = ("/ardrone/imu", "/groundtruth/ardrone", "/tf")


class Clockwork:
    """/clock from this test: sim time moves only when the test steps it."""

    def __init__(self):
        self.publisher = rospy.Publisher("/clock", Clock, queue_size=10, latch=True)
        self.now = 1.0
        self.publish()

    def publish(self):
        self.publisher.publish(Clock(clock=rospy.Time.from_sec(self.now)))
        wait_for(lambda: abs(rospy.get_time() - self.now) < 1e-6, "the test's own clock at %.3f" % self.now, TIMEOUT)

    def step(self, seconds):
        self.now = round(self.now + seconds, 6)
        self.publish()


class RecorderTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_flight_recorder")
        cls.clock = Clockwork()
        cls.record = roslib.packages.find_node("flight_recorder", "record")[0]
        cls.publishers = {
            "/ardrone/imu": rospy.Publisher("/ardrone/imu", Imu, queue_size=1000),
            "/groundtruth/ardrone": rospy.Publisher("/groundtruth/ardrone", PoseStamped, queue_size=1000),
            "/tf": rospy.Publisher("/tf", TFMessage, queue_size=1000),
            "/not/recorded": rospy.Publisher("/not/recorded", String, queue_size=1000)}
        cls.static = rospy.Publisher("/tf_static", TFMessage, queue_size=1, latch=True)
        cls.static.publish(TFMessage(transforms=[TransformStamped(child_frame_id="landing_pad")]))

    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="flight_recorder_test_")

    def tearDown(self):
        shutil.rmtree(self.dir, ignore_errors=True)

    def start(self, *options, name="flight.bag"):
        process = subprocess.Popen([self.record, "--output-name=" + os.path.join(self.dir, name)] + list(options) +
                                   OPTIONS + ["__name:=flight_recorder"], stderr=subprocess.PIPE, text=True)
        self.addCleanup(lambda: process.poll() is None and (process.kill(), process.wait()))
        # (asked of the recorder: this test's publishers still count the previous recorder's connections a while)
        wait_for(lambda: self.connected() >= set(RECORDED) | {"/tf_static"}, "the recorder on every recorded topic",
                 TIMEOUT, process=process)
        # Its side of a connection may be up before this side's: probe until every topic gets through, and count
        # from there.
        def through():
            self.send_round()
            received = self.received()
            return received if all(received.get(t, 0) for t in RECORDED) else None
        self.baseline = wait_for(through, "a first message through on every topic", TIMEOUT, poll=0.05,
                                 process=process)
        return process

    def recorder(self):
        uri = rosgraph.Master(rospy.get_name()).lookupNode("/flight_recorder")
        return xmlrpc.client.ServerProxy(uri)

    def connected(self):
        """Topics the recorder receives over a connection now (its getBusInfo: [id, peer, direction, transport,
        topic, connected, ...] per connection)."""
        try:
            info = self.recorder().getBusInfo(rospy.get_name())
        except Exception:  # not registered yet, or the previous recorder's address
            return set()
        connections = info[2] if isinstance(info[0], int) else info
        return {c[4] for c in connections if c[2] == "i" and c[5]}

    def publish(self, count, step_s=0.01):
        """``count`` messages on each topic, one round per clock step; returns the sim times of the rounds."""
        times = []
        for _ in range(count):
            self.clock.step(step_s)
            times.append(self.clock.now)
            self.send_round()
        return times

    def send_round(self):
        self.publishers["/ardrone/imu"].publish(Imu())
        self.publishers["/groundtruth/ardrone"].publish(PoseStamped())
        self.publishers["/tf"].publish(TFMessage(transforms=[TransformStamped()]))
        self.publishers["/not/recorded"].publish(String(data="x"))

    def stop(self, process, how=signal.SIGINT):
        process.send_signal(how)
        try:
            code = process.wait(timeout=TIMEOUT)
        except subprocess.TimeoutExpired:
            self.fail("the recorder did not stop within %.0f s of %s" % (TIMEOUT, how))
        return code, process.stderr.read()

    def counts(self, path):
        with rosbag.Bag(path) as bag:
            info = bag.get_type_and_topic_info().topics
            return {topic: value.message_count for topic, value in info.items()}, \
                [(topic, t.to_sec()) for topic, _, t in bag.read_messages()]

    def received(self):
        """{topic: messages} the recorder's connections have received (its getBusStats: roscpp answers
        [publications, subscriptions, services], a subscription's connection [id, bytes, messages, drops, ...])."""
        try:
            stats = self.recorder().getBusStats(rospy.get_name())
        except Exception:  # not registered yet
            return {}
        subscriptions = stats[2][1] if isinstance(stats[0], int) else stats[1]
        return {topic: sum(c[2] for c in connections) for topic, connections in subscriptions}

    def stop_after_delivery(self, process, count, how=signal.SIGINT):
        """Stop the recorder once its connections have received the ``count`` messages of each recorded topic (what
        it received before the signal goes into the bag before it closes)."""
        wait_for(lambda: all(self.received().get(t, 0) >= self.baseline[t] + count for t in RECORDED),
                 "the recorder receiving %d messages on each of %s" % (count, ", ".join(RECORDED)), TIMEOUT,
                 process=process)
        return self.stop(process, how)

    def test_1_records_the_wanted_topics_with_their_receipt_sim_times(self):
        process = self.start()
        times = self.publish(50)
        code, errors = self.stop_after_delivery(process, 50)
        self.assertEqual(code, 0, errors)
        path = os.path.join(self.dir, "flight.bag")
        self.assertTrue(os.path.isfile(path), "no %s after SIGINT (%s)" % (path, os.listdir(self.dir)))
        self.assertFalse(os.path.exists(path + ".active"))
        counts, records = self.counts(path)
        self.assertEqual(counts, dict({t: self.baseline[t] + 50 for t in RECORDED}, **{"/tf_static": 1}))
        received = [t for topic, t in records if topic != "/tf_static"][-150:]  # (the probes came before)
        self.assertGreaterEqual(min(received), times[0] - 0.01 - 1e-6)  # (a message may arrive before its tick)
        self.assertLessEqual(max(received), times[-1] + 1e-6)
        self.assertGreater(len(set(received)), 10, "receipt times are the sim clock's, which moved")
        with rosbag.Bag(path) as bag:
            types = {t: v.msg_type for t, v in bag.get_type_and_topic_info().topics.items()}
        self.assertEqual(types["/ardrone/imu"], "sensor_msgs/Imu")
        self.assertEqual(types["/tf_static"], "tf2_msgs/TFMessage")

    def test_2_splits_by_sim_time(self):
        process = self.start("--split", "--duration=1")
        self.publish(35, step_s=0.1)  # 3.5 s of sim time: 4 bags
        code, errors = self.stop_after_delivery(process, 35)
        self.assertEqual(code, 0, errors)
        bags = sorted(f for f in os.listdir(self.dir))
        self.assertEqual(bags, ["flight_0.bag", "flight_1.bag", "flight_2.bag", "flight_3.bag"])
        total = sum(self.counts(os.path.join(self.dir, b))[0].get("/ardrone/imu", 0) for b in bags)
        self.assertEqual(total, self.baseline["/ardrone/imu"] + 35)
        for b in bags:
            _, records = self.counts(os.path.join(self.dir, b))
            times = [t for _, t in records]
            if times:
                self.assertLessEqual(max(times) - min(times), 1.0 + 1e-6, b)

    def test_3_sigterm_closes_the_bag_too(self):
        process = self.start()
        self.publish(10)
        code, errors = self.stop_after_delivery(process, 10, signal.SIGTERM)
        self.assertEqual(code, 0, errors)
        counts, _ = self.counts(os.path.join(self.dir, "flight.bag"))
        self.assertEqual(counts["/ardrone/imu"], self.baseline["/ardrone/imu"] + 10)

    def test_4_a_killed_recorder_leaves_its_complete_chunks(self):
        process = self.start()
        self.publish(600)  # Imu, PoseStamped and TFMessage: about 0.4 MB, some 12 chunks of 32 kB (uncompressed)
        wait_for(lambda: all(self.received().get(t, 0) >= self.baseline[t] + 600 for t in RECORDED),
                 "the recorder receiving it all",
                 TIMEOUT, process=process)
        process.kill()
        process.wait(timeout=TIMEOUT)
        active = os.path.join(self.dir, "flight.bag.active")
        self.assertTrue(os.path.isfile(active), os.listdir(self.dir))
        repaired = os.path.join(self.dir, "repaired.bag")
        shutil.copy(active, repaired)
        with rosbag.Bag(repaired, "a", allow_unindexed=True) as bag:
            for _ in bag.reindex():
                pass
        counts, _ = self.counts(repaired)
        # All but the last chunk (32 kB: about 50 rounds) and what stdio still held.
        self.assertGreater(counts.get("/ardrone/imu", 0), self.baseline["/ardrone/imu"] + 500)

    def test_5_a_bad_command_line_is_refused_with_the_reason(self):
        bad = subprocess.run([self.record, "--size=10", "/tf"], capture_output=True, text=True, timeout=TIMEOUT)
        self.assertEqual(bad.returncode, 2)
        self.assertIn("unknown option '--size=10'", bad.stderr)
        self.assertIn("usage:", bad.stderr)
        nowhere = subprocess.run([self.record, "--output-name=/nonexistent/dir/x.bag", "/tf", "__name:=bad_recorder"],
                                 capture_output=True, text=True, timeout=TIMEOUT)
        self.assertEqual(nowhere.returncode, 1)
        self.assertIn("cannot open the bag", nowhere.stderr)


if __name__ == "__main__":
    rostest.rosrun("flight_recorder", "recorder", RecorderTest)
