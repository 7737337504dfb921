"""Shared harness of the supervisor / emergency rostests with the real simulator.

It watches the supervisor's and the emergency module's outputs, stands in for the tracker (take-off and
a few velocity commands on platform_tracking/cmd_vel, forwarded by cmd_vel_mux in the landing mode) and
waits on conditions in sim time, each with a generous wall-clock timeout. Nothing here sleeps to
synchronise: every wait polls a condition.
"""
import functools
import json
import math
import threading
import time

import rospy
from geometry_msgs.msg import PoseStamped, Twist
from landing_msgs.msg import Navdata, PositionXYCommand, Touchdown
from std_msgs.msg import Bool, Empty, String
from landing_runtime import testing

WALL_TIMEOUT = 120.0   # per wait [wall s]; the simulator may run slower than its real-time factor
REACTION_LIMIT = 1.0   # a condition change must be acted on within this [sim s]
AIRBORNE = (Navdata.STATE_FLYING, Navdata.STATE_HOVERING, Navdata.STATE_TAKING_OFF, Navdata.STATE_LANDING)


CLOCK_SKEW_S = 0.05  # two /clock periods [s]


class Harness:
    def __init__(self, name):
        rospy.init_node(name)
        self.lock = threading.Lock()
        self.decisions, self.positions, self.tracker_commands, self.land_times = [], [], [], []
        self.navdata_log = []        # (sim time, state)
        self.mode, self.warning, self.landing_allowed, self.emergency_state = None, None, None, None
        self.auto_takeoff_at = None  # the first countdown end announced on supervisor/flight_management [sim s]
        self.navdata, self.truth, self.touchdown = None, None, None
        self.tracker_twist = None    # what the stand-in tracker publishes, None = silent
        sub = rospy.Subscriber
        sub("/supervisor/decisions", String, self._on_decision, queue_size=100)
        sub("/supervisor/mode", String, lambda m: setattr(self, "mode", m.data))
        sub("/supervisor/flight_management", String, self._on_flight_management, queue_size=10)
        sub("/supervisor/warning", String, lambda m: setattr(self, "warning", json.loads(m.data)))
        sub("/landing_allowed", Bool, lambda m: setattr(self, "landing_allowed", m.data))
        sub("/emergency/state", String, lambda m: setattr(self, "emergency_state", m.data))
        sub("/emergency/position", PositionXYCommand, self._on_position, queue_size=20)
        sub("/platform_tracking/command", String, lambda m: self.tracker_commands.append(m.data), queue_size=10)
        sub("/ardrone/land", Empty, lambda _: self.land_times.append(rospy.get_time()), queue_size=10)
        sub("/drone/navdata", Navdata, self._on_navdata, queue_size=10)
        sub("/groundtruth/ardrone", PoseStamped, lambda m: setattr(self, "truth", m.pose.position), queue_size=1)
        sub("/ardrone/touchdown", Touchdown, lambda m: setattr(self, "touchdown", m), queue_size=5)
        self.operator = rospy.Publisher("/operator/command", String, queue_size=10)
        self.takeoff_pub = rospy.Publisher("/ardrone/takeoff", Empty, queue_size=1)
        self.tracker_pub = rospy.Publisher("/platform_tracking/cmd_vel", Twist, queue_size=1)
        threading.Thread(target=self._stand_in_tracker, daemon=True).start()
        self.wait_for(lambda: rospy.get_time() > 0.5 and self.mode is not None and self.navdata is not None,
                      "the simulator clock, supervisor/mode and drone/navdata")
        self.wait_for(lambda: self.operator.get_num_connections() >= 2, "supervisor and emergency on operator/command")
        # a take-off published before the simulator has connected would be lost
        self.wait_for(lambda: self.takeoff_pub.get_num_connections() >= 1, "the simulator on /ardrone/takeoff")
        self.up_at = rospy.get_time()  # the supervisor was up (its latched mode heard) by this sim time

    # ----- inputs ------------------------------------------------------------------------------------
    def _on_decision(self, msg):
        with self.lock:
            self.decisions.append(json.loads(msg.data))

    def _on_flight_management(self, msg):
        announced = json.loads(msg.data).get("auto_takeoff_at")
        if self.auto_takeoff_at is None and announced is not None:
            self.auto_takeoff_at = announced

    def _on_position(self, msg):
        with self.lock:
            self.positions.append((rospy.get_time(), msg.x, msg.y))

    def _on_navdata(self, msg):
        self.navdata = msg
        if not self.navdata_log or self.navdata_log[-1][1] != msg.state:
            self.navdata_log.append((msg.header.stamp.to_sec(), msg.state))

    def _stand_in_tracker(self):
        while not rospy.is_shutdown():
            twist = self.tracker_twist
            if twist is not None:
                try:
                    self.tracker_pub.publish(twist)
                except rospy.ROSException:  # the test is over and rospy closed the topic
                    return
            time.sleep(0.02)  # a publishing cadence, not a synchronisation

    # ----- waiting ------------------------------------------------------------------------------------
    wait_for = staticmethod(functools.partial(testing.wait_for, timeout=WALL_TIMEOUT))

    def sim_wait(self, seconds, while_true=None, what=""):
        """Let ``seconds`` of sim time pass; with ``while_true``, fail as soon as it stops holding."""
        end = rospy.get_time() + seconds

        def done():
            if while_true is not None and not while_true():
                raise AssertionError("%s stopped holding at sim t=%.2f" % (what, rospy.get_time()))
            return rospy.get_time() >= end
        self.wait_for(done, "%.1f s of sim time" % seconds)

    def decision(self, condition=None, action=None, after=0.0):
        # Each node receives /clock on its own; the supervisor's stamp may trail ours by a tick or two.
        after -= CLOCK_SKEW_S
        with self.lock:
            for d in self.decisions:
                if d["t"] >= after and (condition is None or d["condition"] == condition) and \
                        (action is None or d["action"] == action):
                    return d
        return None

    def wait_decision(self, condition, action, after, what=None):
        self.wait_for(lambda: self.decision(condition, action, after) is not None,
                      what or "decision %s %s after t=%.2f" % (condition, action, after))
        return self.decision(condition, action, after)

    def decisions_of(self, condition, after=0.0):
        with self.lock:
            return [d for d in self.decisions if d["condition"] == condition and d["t"] >= after]

    # ----- flying ----------------------------------------------------------------------------------------
    def command(self, word):
        self.operator.publish(String(data=word))

    def set_condition(self, name, value):
        """Set a condition parameter; returns the sim time just before the change."""
        t = rospy.get_time()
        rospy.set_param("/" + name, value)
        return t

    def fly(self, seconds, vx=0.0, vy=0.0, vz=0.0):
        twist = Twist()
        twist.linear.x, twist.linear.y, twist.linear.z = vx, vy, vz
        self.tracker_twist = twist
        self.sim_wait(seconds)
        self.tracker_twist = Twist()  # hold

    def take_off_when_told(self, climb_s=1.5):
        """Play the tracker: on platform_tracking/command 'takeoff', take off and climb."""
        self.wait_for(lambda: "takeoff" in self.tracker_commands, "platform_tracking/command 'takeoff'")
        self.wait_for(lambda: self.mode == "landing", "supervisor/mode landing")
        self.takeoff_pub.publish(Empty())
        self.wait_for(lambda: self.navdata.state in (Navdata.STATE_FLYING, Navdata.STATE_HOVERING),
                      "the drone flying after the take-off")
        self.fly(climb_s, vz=1.0)

    def airborne(self):
        return self.navdata is not None and self.navdata.state in AIRBORNE

    def navdata_state_since(self, state, t):
        """Sim time the drone first reported ``state`` at or after ``t`` (None if not yet)."""
        for stamp, s in list(self.navdata_log):
            if s == state and stamp >= t:
                return stamp
        return None

    def horizontal_error(self, position):
        return math.hypot(position[1] - self.truth.x, position[2] - self.truth.y)
