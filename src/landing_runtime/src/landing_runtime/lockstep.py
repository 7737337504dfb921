"""Lock-step acknowledgements to the simulator (see landing_msgs/LockstepAck), for Python nodes.

    ack = LockstepAcker("ardrone/imu")         # a topic: call ack(msg.header.stamp) once it is processed
    ack = LockstepAcker(period=1.0 / rate_hz)  # a timer-driven loop: call ack(rospy.Time.now()) each step

Outside the simulator nobody listens and the acknowledgements cost nothing (rospy publishes to no one).
"""
import rospy

from landing_msgs.msg import LockstepAck
from landing_runtime.rospy_node import direct_publisher

TOPIC = "lockstep_ack"
CLOCK_INPUT = "/clock"


class LockstepAcker:
    def __init__(self, input_topic=None, period=0.0):
        self.msg = LockstepAck(node=rospy.get_name(),
                               input=rospy.resolve_name(input_topic) if input_topic else CLOCK_INPUT,
                               period=rospy.Duration.from_sec(period))
        self.publisher = direct_publisher(TOPIC, LockstepAck)  # written at once: the simulator may be waiting for it

    def ack(self, stamp):
        """``stamp``: rospy.Time of the message processed (or of the timer step)."""
        if self.publisher.get_num_connections():
            self.msg.stamp = stamp
            self.publisher.publish(self.msg)
