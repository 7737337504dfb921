"""Drives the vehicle along a scripted path by publishing summit_xl_control/cmd_vel in sim time.

Restarted after a crash (respawn in summit_moves.launch), it carries on along the same path from where the
vehicle was on it: the path's start time is kept in the private parameter ~started_at with ~launch_id (unique
to each roslaunch, kept across respawns)."""
import sys

import rospy
from geometry_msgs.msg import Twist
from landing_msgs.lockstep import LockstepAcker
from landing_msgs.rospy_node import direct_publisher, ended_by_shutdown, init_node
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
    publisher = direct_publisher("summit_xl_control/cmd_vel", Twist)
    started = {"flag": not wait_for_takeoff}
    launch_id = rospy.get_param("~launch_id", None)
    saved = rospy.get_param("~started_at", None)
    resumed_start = saved["time"] if isinstance(saved, dict) and launch_id is not None and \
        saved.get("launch_id") == launch_id and isinstance(saved.get("time"), (int, float)) else None
    rospy.Subscriber("ardrone/takeoff", Empty, lambda _: started.update(flag=True), queue_size=1)
    while not rospy.is_shutdown() and rospy.get_time() == 0.0:
        rospy.sleep(0.01)  # wait for the first /clock
    rate = rospy.Rate(rate_hz)
    lockstep = LockstepAcker(period=1.0 / rate_hz)
    start_time = resumed_start
    if resumed_start is not None:
        started["flag"] = True
        rospy.logwarn("summit_moves: restarted; carrying on along the path started at t=%.2f s", resumed_start)
    rospy.loginfo("summit_moves: %s path at %.2f m/s (radius %.1f m)", path.kind, path.speed, path.radius)
    with ended_by_shutdown():
        while not rospy.is_shutdown():
            stamp = rospy.Time.now()
            now = stamp.to_sec()
            if started["flag"] and start_time is None:
                start_time = now + start_delay
                try:
                    rospy.set_param("~started_at", {"time": start_time, "launch_id": launch_id})
                except Exception as err:  # the master is gone: a restart would start the path afresh
                    rospy.logwarn("summit_moves: cannot keep the path's start time for a restart: %s", err)
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
