#!/usr/bin/env python3
"""rostest: the estimator and tracker nodes fly the simulated drone from the pad of the moving Summit
XL back onto it, commanded through platform_tracking/command. Waits are on sim-time conditions; the
wall clock only bounds them."""
import functools
import math
import unittest

import rospy
import rostest
from landing_msgs.msg import Touchdown
from nav_msgs.msg import Odometry
from std_msgs.msg import Float64, String
from landing_runtime import testing

WALL_TIMEOUT = 300.0


wait_for = functools.partial(testing.wait_for, timeout=WALL_TIMEOUT)


class FlightTest(unittest.TestCase):
    def test_take_off_track_and_land_on_the_moving_pad(self):
        rospy.init_node("test_platform_tracking")
        states, estimates, truth, touchdowns = [], [], {}, []
        rospy.Subscriber("platform_tracking/state", String, lambda m: states.append(m.data))
        rospy.Subscriber("ardrone/odom_estimate", Odometry, estimates.append, queue_size=200)
        rospy.Subscriber("ardrone/ground_truth/state", Odometry,
                         lambda m: truth.update({round(m.header.stamp.to_sec(), 3): m.pose.pose.position}),
                         queue_size=200)
        rospy.Subscriber("ardrone/touchdown", Touchdown, touchdowns.append)
        latencies = []
        rospy.Subscriber("platform_tracking/camera_latency", Float64, lambda m: latencies.append(m.data))
        command = rospy.Publisher("platform_tracking/command", String, queue_size=1, latch=True)
        wait_for(lambda: states and estimates and truth and rospy.get_time() > 1.0,
                 "the tracker state, the estimate and 1 s of sim time")
        self.assertEqual(states[0], "LANDED")
        command.publish(String(data="takeoff"))
        wait_for(lambda: touchdowns and "LANDED" in states[1:], "the touchdown")

        self.assertEqual(states, ["LANDED", "TAKING_OFF", "TRACKING", "LANDING", "LANDED"])
        touchdown = touchdowns[-1]
        self.assertEqual(touchdown.surface, Touchdown.SURFACE_PAD)
        self.assertFalse(touchdown.crashed)
        self.assertLess(touchdown.pad_error, 0.15)
        # The estimate: in world, at the IMU rate, close to the ground truth.
        self.assertEqual(estimates[-1].header.frame_id, "world")
        self.assertEqual(estimates[-1].child_frame_id, "ardrone/base_link")
        stamps = [m.header.stamp.to_sec() for m in estimates]
        span = stamps[-1] - stamps[0]
        self.assertGreater(len(stamps) / span, 0.8 * rospy.get_param("/mujoco_sim/realism_in_force/navdata_rate_hz"))
        # Horizontal error of the estimate against the ground truth of the same instant, over the flight.
        errors = [math.hypot(m.pose.pose.position.x - truth[k].x, m.pose.pose.position.y - truth[k].y)
                  for m in estimates for k in [round(m.header.stamp.to_sec(), 3)] if k in truth]
        self.assertGreater(len(errors), 0.3 * len(estimates))
        self.assertLess(math.sqrt(sum(e * e for e in errors) / len(errors)), 0.2)
        self.assertLess(max(errors), 0.5)
        # The camera latency it measured (sim time at receipt minus the detection's stamp): the stand-in's
        # detections arrive ~latency late, plus up to two of its 30 Hz ticks (its next tick, and the newest pose it
        # can pair being up to a tick old), plus as far as lock-step lets the simulator run ahead of the nodes (on
        # a loaded machine it does). The median of the last five, so that one sample at a burst's edge does not
        # decide.
        latency = rospy.get_param("/pipeline_stand_in/latency")
        lead = rospy.get_param("/mujoco_sim/lockstep/max_lead_s")
        self.assertGreater(len(latencies), 5)
        measured = sorted(latencies[-5:])[2]
        self.assertTrue(latency - 0.005 <= measured <= latency + 2.0 / 30.0 + lead, latencies[-5:])


if __name__ == "__main__":
    rostest.rosrun("platform_tracking", "platform_tracking_flight", FlightTest)
