"""cmd_vel_mux node: forwards manual/cmd_vel, emergency/cmd_vel or platform_tracking/cmd_vel to
ardrone/cmd_vel at ``~rate_hz`` (sim time) according to supervisor/mode; see interface.cmd_vel_mux."""
import sys

import rospy
from geometry_msgs.msg import Twist
from landing_msgs.lockstep import LockstepAcker
from landing_msgs.rospy_node import run_node, spin_at
from std_msgs.msg import String

from .cmd_vel_mux import CommandSelector

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
        self.pub = rospy.Publisher("ardrone/cmd_vel", Twist, queue_size=1)
        self.pub_selected = rospy.Publisher("cmd_vel_mux/selected", String, queue_size=1, latch=True)
        for name, topic in TOPICS.items():
            rospy.Subscriber(topic, Twist, self._input(name), queue_size=1)
        rospy.Subscriber("supervisor/mode", String, self._on_mode, queue_size=5)
        self.pub_selected.publish(String(data="none"))
        self.lockstep = LockstepAcker(period=1.0 / self.rate_hz)

    def _input(self, name):
        def callback(msg):
            self.selector.on_input(name, rospy.get_time(), msg)
        return callback

    def _on_mode(self, msg):
        complaint = self.selector.set_mode(msg.data)
        if complaint:
            rospy.logwarn("cmd_vel_mux: %s", complaint)

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

    def spin(self):
        spin_at(self.rate_hz, self.tick)


def main():
    return run_node("cmd_vel_mux", MuxNode, startup_errors=(ValueError,))


if __name__ == "__main__":
    sys.exit(main())
