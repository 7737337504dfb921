"""Drives the vehicle along a scripted path by publishing summit_xl_control/cmd_vel in sim time."""
import sys

import rospy
from geometry_msgs.msg import Twist
from landing_msgs.lockstep import LockstepAcker
from landing_msgs.rospy_node import init_node
from std_msgs.msg import Empty

from .paths import Path, PathError


def _required(name):
    if not rospy.has_param(name):
        rospy.logfatal("summit_moves: required parameter '%s' is not set (see summit_moves/config/path.yaml)", name)
        sys.exit(2)
    return rospy.get_param(name)


def main():
    init_node("summit_moves")
    try:
        path = Path(_required("~path"), float(_required("~speed")), float(_required("~radius")), int(_required("~seed")))
    except (PathError, ValueError, TypeError) as err:
        rospy.logfatal("summit_moves: bad path parameters: %s", err)
        sys.exit(2)
    rate_hz, start_delay = float(_required("~rate_hz")), float(_required("~start_delay"))
    wait_for_takeoff = bool(_required("~start_on_takeoff"))
    publisher = rospy.Publisher("summit_xl_control/cmd_vel", Twist, queue_size=1)
    started = {"flag": not wait_for_takeoff}
    rospy.Subscriber("ardrone/takeoff", Empty, lambda _: started.update(flag=True), queue_size=1)
    while not rospy.is_shutdown() and rospy.get_time() == 0.0:
        rospy.sleep(0.01)  # wait for the first /clock
    rate = rospy.Rate(rate_hz)
    lockstep = LockstepAcker(period=1.0 / rate_hz)
    start_time = None
    rospy.loginfo("summit_moves: %s path at %.2f m/s (radius %.1f m)", path.kind, path.speed, path.radius)
    while not rospy.is_shutdown():
        stamp = rospy.Time.now()
        now = stamp.to_sec()
        if started["flag"] and start_time is None:
            start_time = now + start_delay
        speed, yaw_rate = path.command(now - start_time) if start_time is not None else (0.0, 0.0)
        msg = Twist()
        msg.linear.x, msg.angular.z = speed, yaw_rate
        publisher.publish(msg)
        lockstep.ack(stamp)
        try:
            rate.sleep()
        except rospy.ROSTimeMovedBackwardsException:
            start_time = None
        except rospy.ROSInterruptException:
            break
