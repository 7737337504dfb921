"""What a manual control in an operator UI sends (ROS wrapper shared by the console and the web station):
the same topics as ardrone_moves' teleop nodes. ``ardrone/cmd_vel`` is remapped to ``manual/cmd_vel`` in
start.launch, behind cmd_vel_mux; operator commands go out on the UI's own operator/command publisher."""
import rospy
from ardrone_moves.mapping import EMERGENCY, LAND, MANUAL, TAKEOFF
from geometry_msgs.msg import Twist
from std_msgs.msg import Empty, String


class ManualOutputs:
    def __init__(self, operator_publisher):
        self.operator = operator_publisher
        self.cmd_vel = rospy.Publisher("ardrone/cmd_vel", Twist, queue_size=1)
        self.takeoff = rospy.Publisher("ardrone/takeoff", Empty, queue_size=1)
        self.land = rospy.Publisher("ardrone/land", Empty, queue_size=1)

    def send(self, command):
        """An ardrone_moves VelocityCommand."""
        msg = Twist()
        msg.linear.x, msg.linear.y, msg.linear.z = command.forward, command.left, command.climb
        msg.angular.z = command.yaw_rate
        self.cmd_vel.publish(msg)

    def act(self, actions):
        """One-shot actions of the teleop: take off, land where it is, emergency, manual."""
        for action in actions:
            if action == TAKEOFF:
                self.takeoff.publish(Empty())
            elif action == LAND:
                self.land.publish(Empty())
            elif action in (EMERGENCY, MANUAL):
                self.operator.publish(String(data=action))
