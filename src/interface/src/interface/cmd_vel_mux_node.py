"""cmd_vel_mux node: forwards manual/cmd_vel, emergency/cmd_vel or platform_tracking/cmd_vel to
ardrone/cmd_vel at ``~rate_hz`` (sim time) according to supervisor/mode; see interface.cmd_vel_mux.

Garbage is dropped with a throttled warning saying what was wrong: a command with a non-finite or implausible
velocity never reaches the drone (its input counts as silent), and an unknown mode leaves the last valid one in
force (the supervisor publishes its mode only when it changes). Restarted after a crash (respawn in
supervisor.launch), it reads the latched supervisor/mode again."""
import sys

import rospy
from geometry_msgs.msg import Twist
from landing_runtime.input_check import MAX_RATE_RADPS, MAX_SPEED_MPS, RosRejectionLog, numbers_problem
from landing_runtime.lockstep import LockstepAcker
from landing_runtime.rospy_node import NodeHandles, direct_publisher, run_node
from std_msgs.msg import String

from .cmd_vel_mux import ALLOWED, CommandSelector

TOPICS = {"manual": "manual/cmd_vel", "emergency": "emergency/cmd_vel", "tracking": "platform_tracking/cmd_vel"}


def _positive_param(name, default):
    value = rospy.get_param("~" + name, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
        raise ValueError("cmd_vel_mux: parameter '~%s' must be a positive number, got %r" % (name, value))
    return float(value)


class MuxNode:
    def __init__(self):
        self.rate_hz = _positive_param("rate_hz", 30.0)
        self.selector = CommandSelector(_positive_param("input_timeout_s", 0.5))
        self.selected = None
        self.rejections = RosRejectionLog()
        self.handles = NodeHandles()
        self.pub = direct_publisher("ardrone/cmd_vel", Twist)
        self.pub_selected = self.handles.latched(
            rospy.Publisher("cmd_vel_mux/selected", String, queue_size=1, latch=True))
        for name, topic in TOPICS.items():
            self.handles.subscriber(topic, Twist, self._input(name), queue_size=1)
        self.handles.subscriber("supervisor/mode", String, self._on_mode, queue_size=5)
        self.pub_selected.publish(String(data="none"))
        self.lockstep = LockstepAcker(period=1.0 / self.rate_hz)

    def _input(self, name):
        def callback(msg):
            problem = numbers_problem(MAX_SPEED_MPS, linear=(msg.linear.x, msg.linear.y, msg.linear.z)) or \
                numbers_problem(MAX_RATE_RADPS, angular=(msg.angular.x, msg.angular.y, msg.angular.z))
            if problem:
                return self.rejections.reject(TOPICS[name], problem)
            self.selector.on_input(name, rospy.get_time(), msg)
        return callback

    def _on_mode(self, msg):
        if msg.data not in ALLOWED:
            return self.rejections.reject("supervisor/mode", (
                "unknown value", "mode %r, expected one of %s; the mode stays %s" % (
                    msg.data[:60], ", ".join(m for m in ALLOWED if m), self.selector.mode)))
        self.selector.set_mode(msg.data)

    def tick(self):
        now = rospy.Time.now()
        choice = self.selector.select(now.to_sec())
        name = choice[0] if choice else None
        if name != self.selected:
            rospy.loginfo("cmd_vel_mux: ardrone/cmd_vel %s (mode %s)",
                          "from " + TOPICS[name] if name else "silent: no live input", self.selector.mode)
            self.pub_selected.publish(String(data=name or "none"))
            self.selected = name
        if choice:
            self.pub.publish(choice[1])
        self.lockstep.ack(now)

def main():
    return run_node("cmd_vel_mux", MuxNode, startup_errors=(ValueError,), resettable=True)


if __name__ == "__main__":
    sys.exit(main())
