#!/usr/bin/env python3
"""rostest of ~reset (landing_runtime.rospy_node.ResettableNode) on drone_estimator and platform_tracking: the test
drives the clock (sim time, from 100 s on) and plays the drone's sensors, the camera and the operator.

A reset node starts as a fresh one: the estimator from the next GPS fix (not gating it against the previous
scenario's estimate), the tracker LANDED (its latched state LANDED again, no camera latency latched, no take-off
request left pending, no velocity commands), and its first outputs for the same inputs are a fresh node's. Changed
parameters are in force after a reset (a new take-off climb rate and tick rate, a new flow noise); a bad one refuses
the reset with a message naming it, and the node goes on as it was."""
import json
import subprocess
import sys
import threading
import unittest

import rospy
import rostest
from geometry_msgs.msg import PointStamped, Twist
from landing_runtime import testing
from landing_msgs.msg import Altimeter, Navdata
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu
from std_msgs.msg import Empty, Float64, String
from std_srvs.srv import Trigger

WALL_TIMEOUT = 60.0
START = 100.0        # the clock's first time: nodes must not rely on time being small [s]
STEP = 0.01          # clock step, one every wall STEP (real time) [s]
P1, P2 = (3.0, 4.0, 0.5), (-20.0, 10.0, 0.5)  # where the GPS puts the drone: first scenario, after the reset [m]
TRACKER, ESTIMATOR = "/platform_tracking", "/drone_estimator"


class World:
    """The clock and the drone's sensors: IMU (100 Hz), navdata (50 Hz), altimeter (20 Hz) and GPS (5 Hz) at rest at
    ``gps``, and while ``detections`` is set the camera's pad detections (33 Hz, 0.05 s late)."""

    def __init__(self):
        self.gps, self.nav_state, self.imu, self.detections = P1, Navdata.STATE_LANDED, True, False
        self.clock = rospy.Publisher("/clock", Clock, queue_size=10)
        self.pub_imu = rospy.Publisher("ardrone/imu", Imu, queue_size=10)
        self.pub_nav = rospy.Publisher("drone/navdata", Navdata, queue_size=10)
        self.pub_altimeter = rospy.Publisher("ardrone/altimeter", Altimeter, queue_size=10)
        self.pub_gps = rospy.Publisher("ardrone/gps/odom", Odometry, queue_size=10)
        self.pub_detection = rospy.Publisher("platform/current_platform_position_in_ardrone", PointStamped,
                                             queue_size=10)
        self.stop = threading.Event()
        threading.Thread(target=self._run, daemon=True).start()

    def _run(self):
        step = 0
        while not self.stop.wait(STEP) and not rospy.is_shutdown():
            now = rospy.Time.from_sec(START + step * STEP)
            self.clock.publish(Clock(clock=now))
            if self.imu:
                imu = Imu()
                imu.header.stamp, imu.header.frame_id = now, "ardrone/base_link"
                imu.orientation.w, imu.linear_acceleration.z = 1.0, 9.81
                self.pub_imu.publish(imu)
            if step % 2 == 0:
                nav = Navdata(state=self.nav_state)
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
            if self.detections and step % 3 == 0:
                detection = PointStamped()
                detection.header.stamp = now - rospy.Duration.from_sec(0.05)
                detection.header.frame_id = "ardrone/base_link"
                detection.point.z = -1.0
                self.pub_detection.publish(detection)
            step += 1


class NodeResetTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_platform_tracking_node_reset")
        cls.states, cls.takeoffs, cls.commands, cls.estimates, cls.latencies = [], [], [], [], []
        rospy.Subscriber("platform_tracking/state", String, lambda m: cls.states.append((rospy.get_time(), m.data)))
        rospy.Subscriber("ardrone/takeoff", Empty, lambda m: cls.takeoffs.append(rospy.get_time()))
        rospy.Subscriber("ardrone/cmd_vel", Twist, lambda m: cls.commands.append((rospy.get_time(), m)),
                         queue_size=100)
        rospy.Subscriber("ardrone/odom_estimate", Odometry, cls.estimates.append, queue_size=200)
        rospy.Subscriber("platform_tracking/camera_latency", Float64, lambda m: cls.latencies.append(m.data))
        # Latched, as the supervisor's: what the tracker's connection received last must not reach a reset tracker.
        cls.command = rospy.Publisher("platform_tracking/command", String, queue_size=10, latch=True)
        cls.world = World()
        for name in (TRACKER, ESTIMATOR):
            rospy.wait_for_service(name + "/reset", timeout=WALL_TIMEOUT)
        cls.shipped = {name: rospy.get_param(name) for name in (TRACKER, ESTIMATOR)}
        testing.wait_for(lambda: cls.command.get_num_connections() and rospy.get_time() > START,
                         "the tracker subscribed to platform_tracking/command, and the clock", WALL_TIMEOUT)

    @classmethod
    def tearDownClass(cls):
        cls.world.stop.set()

    # ----- helpers -------------------------------------------------------------------------------
    def wait_for(self, condition, what):
        return testing.wait_for(condition, what, WALL_TIMEOUT)

    def sim_wait(self, seconds):
        until = rospy.get_time() + seconds
        self.wait_for(lambda: rospy.get_time() >= until, "%.1f s of sim time" % seconds)

    def reset(self, node):
        # The supervisor, reset beside the tracker, forgets its latched command (a fresh one has none).
        self.command.impl.latch = None
        return rospy.ServiceProxy(node + "/reset", Trigger)()

    def reset_ok(self, node):
        response = self.reset(node)
        self.assertTrue(response.success, response.message)
        return rospy.get_time()

    def refused(self, node, name, value, *words):
        """A reset with the parameter ``name`` of ``node`` set to ``value`` (None: deleted): refused, its message
        naming ``words``; the parameter is put back."""
        key = "%s/%s" % (node, name)
        try:
            rospy.set_param(key, value) if value is not None else rospy.delete_param(key)
            response = self.reset(node)
        finally:
            rospy.set_param(key, self._shipped(node, name))
        self.assertFalse(response.success, "%s = %r was accepted" % (key, value))
        for word in ("not reset",) + words:
            self.assertIn(word, response.message)

    def _shipped(self, node, name):
        value = self.shipped[node]
        for part in name.split("/"):
            value = value[part]
        return value

    @staticmethod
    def latched(topic):
        """What a subscriber connecting now receives on ``topic`` (String or Float64) within 1 s of sim time. From
        another process: in this one a new subscriber is handed the last message of this process's own connection
        (rospy's subscriber-side latch), not what the publisher has latched."""
        probe = subprocess.run([sys.executable, __file__, "--latched", rospy.resolve_name(topic)],
                               capture_output=True, text=True, timeout=WALL_TIMEOUT, check=True)
        return json.loads(probe.stdout.strip().splitlines()[-1])

    def state(self):
        return self.states[-1][1] if self.states else None

    def take_off(self):
        """The tracker's first outputs for a take-off request from LANDED with the drone on the ground: its states, the
        take-off actions within 0.5 s of sim time, and its first velocity command."""
        self.assertEqual(self.state(), "LANDED")
        since, start = len(self.states), rospy.get_time()
        self.command.publish(String(data="takeoff"))
        self.wait_for(lambda: self.state() == "TAKING_OFF", "TAKING_OFF")
        entered = self.states[-1][0]
        self.sim_wait(0.5)
        first = next(m for t, m in self.commands if t >= entered)
        return {"states": [s for _t, s in self.states[since:]],
                "takeoffs": sum(1 for t in self.takeoffs if start < t <= entered + 0.5),
                "first command": (first.linear.x, first.linear.y, round(first.linear.z, 6), first.angular.z)}

    def assertTickRate(self, rate_hz, seconds=3.0):
        """The tracker ticks at ``rate_hz`` (its velocity commands counted over ``seconds`` of sim time), not at the
        shipped 30 Hz. Below it by up to 4 Hz: a timer more than two periods late skips its ticks (rospy.Rate), and
        on a loaded machine the tracker lags this test's wall-paced clock now and then."""
        start = rospy.get_time()
        self.sim_wait(seconds)
        measured = sum(1 for t, _m in self.commands if start < t <= start + seconds) / seconds
        self.assertLessEqual(measured, rate_hz + 0.5)
        self.assertGreaterEqual(measured, rate_hz - 4.0)

    def estimates_after(self, t):
        return [m for m in self.estimates if m.header.stamp.to_sec() > t]

    @staticmethod
    def offset(estimate, where):
        p = estimate.pose.pose.position
        return max(abs(p.x - where[0]), abs(p.y - where[1]), abs(p.z - where[2]))

    # ----- tests ---------------------------------------------------------------------------------
    def test_1_fresh_nodes(self):
        """What fresh nodes do: the reference for the reset ones. Then into a state no fresh node is in."""
        self.wait_for(lambda: self.estimates, "the first estimate")
        type(self).fresh_estimate = self.offset(self.estimates[0], P1)
        self.assertLess(self.fresh_estimate, 0.01)
        self.assertEqual([s for _t, s in self.states], ["LANDED"])
        self.assertEqual(self.latched("platform_tracking/camera_latency"), [])
        type(self).fresh_take_off = self.take_off()
        self.assertEqual(self.fresh_take_off, {"states": ["TAKING_OFF"], "takeoffs": 1,
                                               "first command": (0.0, 0.0, 1.0, 0.0)})
        # Airborne, climbing; the camera sees the pad: a camera latency is latched.
        self.world.nav_state, self.world.detections = Navdata.STATE_FLYING, True
        self.wait_for(lambda: self.latencies, "a camera latency")
        self.sim_wait(0.5)
        self.assertEqual(self.state(), "TAKING_OFF")

    def test_2_reset_nodes_start_afresh(self):
        self.assertEqual(self.state(), "TAKING_OFF")
        # The next scenario: the drone elsewhere, 25 m away (a running estimate would gate that fix), airborne
        # still, the pad out of view. (Its last latched command, "takeoff", must not reach the reset tracker.)
        self.world.detections, self.world.gps = False, P2
        reset_at = self.reset_ok(ESTIMATOR)
        states_before = len(self.states)
        tracker_reset_at = self.reset_ok(TRACKER)
        self.wait_for(lambda: [s for _t, s in self.states[states_before:]] == ["LANDED"], "LANDED again")
        self.assertEqual(self.latched("platform_tracking/state"), ["LANDED"])
        self.assertEqual(self.latched("platform_tracking/camera_latency"), [])
        # No command, no take-off, no other state: it does not carry on climbing.
        self.sim_wait(1.0)
        self.assertEqual([s for _t, s in self.states[states_before:]], ["LANDED"])
        self.assertEqual([t for t in self.takeoffs if t > tracker_reset_at], [])
        self.assertEqual([t for t, _m in self.commands if t > tracker_reset_at + 0.1], [])
        # The estimator took the first fix after the reset as a fresh one takes its first.
        after = self.estimates_after(reset_at + 0.05)
        self.assertTrue(after)
        self.assertAlmostEqual(self.offset(after[0], P2), self.fresh_estimate, delta=1e-3)
        self.assertLess(max(self.offset(m, P2) for m in after), 0.01)
        # Same first outputs as the fresh tracker, once the drone is on the ground again.
        self.world.nav_state = Navdata.STATE_LANDED
        self.sim_wait(0.5)
        self.assertEqual(self.take_off(), self.fresh_take_off)

    def test_3_a_pending_take_off_is_forgotten(self):
        self.reset_ok(TRACKER)
        self.wait_for(lambda: self.state() == "LANDED", "LANDED")
        # No estimate (the IMU silent): a take-off request waits for one.
        self.world.imu = False
        self.sim_wait(1.0)
        self.command.publish(String(data="takeoff"))
        self.sim_wait(0.5)
        self.assertEqual(self.state(), "LANDED")
        reset_at = self.reset_ok(TRACKER)
        self.world.imu = True
        self.wait_for(lambda: self.estimates_after(reset_at + 0.1), "estimates again")
        self.sim_wait(1.0)
        self.assertEqual(self.state(), "LANDED")
        self.assertEqual([t for t in self.takeoffs if t > reset_at], [])

    def test_4_changed_parameters_are_in_force_after_a_reset(self):
        self.assertAlmostEqual(self.estimates[-1].twist.covariance[0], 0.05 ** 2)
        rospy.set_param(TRACKER + "/takeoff_climb_rate", 0.6)
        rospy.set_param(TRACKER + "/rate_hz", 20.0)
        rospy.set_param(ESTIMATOR + "/flow_velocity_std", 0.2)
        reset_at = self.reset_ok(ESTIMATOR)
        self.reset_ok(TRACKER)
        self.wait_for(lambda: self.estimates_after(reset_at + 0.1), "estimates again")
        self.assertAlmostEqual(self.estimates[-1].twist.covariance[0], 0.2 ** 2)
        self.assertEqual(self.take_off()["first command"], (0.0, 0.0, 0.6, 0.0))
        self.world.nav_state = Navdata.STATE_FLYING  # climbing on, at the new rate
        self.assertTickRate(20.0)

    def test_5_a_bad_parameter_is_refused_and_the_node_goes_on(self):
        self.assertEqual(self.state(), "TAKING_OFF")
        states_before = len(self.states)
        self.shipped[TRACKER].update(takeoff_climb_rate=0.6, rate_hz=20.0)  # what the node now runs with
        self.shipped[ESTIMATOR].update(flow_velocity_std=0.2)
        self.refused(TRACKER, "takeoff_climb_rate", 99.0, "takeoff_climb_rate")
        self.refused(TRACKER, "gate_error", 0.3, "gate_error")  # above descend_max_error
        self.refused(TRACKER, "lost_timeout", None, "lost_timeout", "missing")
        self.refused(ESTIMATOR, "flow_velocity_std", -1.0, "flow_velocity_std")
        self.refused(ESTIMATOR, "flow_surface/coverage_low", 0.9, "coverage_low")  # above coverage_high
        # Both go on as they were: climbing at 0.6 m/s, 20 times a second, the state latched; the flow noise 0.2.
        self.assertEqual(self.latched("platform_tracking/state"), ["TAKING_OFF"])
        self.assertEqual(len(self.states), states_before)
        self.assertTickRate(20.0)
        self.assertAlmostEqual(self.commands[-1][1].linear.z, 0.6)
        checked_at = rospy.get_time()
        self.wait_for(lambda: self.estimates_after(checked_at), "estimates")
        self.assertAlmostEqual(self.estimates[-1].twist.covariance[0], 0.2 ** 2)


def print_latched(topic):
    """The probe of NodeResetTest.latched: prints, as JSON, the data received on ``topic`` within 1 s of sim time of
    connecting to its publisher."""
    rospy.init_node("latched_probe", anonymous=True)
    received = []
    data_class = Float64 if topic.endswith("camera_latency") else String
    subscriber = rospy.Subscriber(topic, data_class, lambda m: received.append(m.data))
    testing.wait_for(lambda: subscriber.get_num_connections() and rospy.get_time() > 0.0,
                     "a connection to %s" % topic, WALL_TIMEOUT)
    until = rospy.get_time() + 1.0
    testing.wait_for(lambda: rospy.get_time() >= until, "1 s of sim time", WALL_TIMEOUT)
    print(json.dumps(received))


if __name__ == "__main__" and sys.argv[1:2] == ["--latched"]:
    print_latched(sys.argv[2])
elif __name__ == "__main__":
    rostest.rosrun("platform_tracking", "platform_tracking_node_reset", NodeResetTest)
