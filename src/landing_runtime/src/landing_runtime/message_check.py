"""Checks of whole rospy messages against the node's ROS clock (sim time under the simulator): the header's stamp and
frame, an Odometry in the world, a sonar Range; and a message's stamp. Built on the ROS-free checks of
landing_runtime.input_check; each returns None or a problem ``(kind, detail)`` for ``RosRejectionLog.reject``.

    problem = odometry_problem(msg)
    if problem:
        return self.rejections.reject("kalman_platform_odom", problem)
"""
import math

import rospy

from landing_runtime.input_check import (MAX_POSITION_M, MAX_SPEED_MPS, first_problem, frame_problem,
                                         numbers_problem, stamp_problem)

WORLD_FRAME = "world"  # the frame every world position and velocity is in (docs/conventions.md)


def header_problem(msg, frames=None):
    """A stamp too far from the clock, or (``frames``: the names allowed) a frame of another tree."""
    return first_problem(stamp_problem(msg.header.stamp.to_sec(), rospy.get_time()),
                         frame_problem(msg.header.frame_id, frames) if frames else None)


def odometry_problem(msg, frames=(WORLD_FRAME,), position_limit=MAX_POSITION_M):
    """What is wrong with an Odometry in the world: stamp, frame, a position or velocity no vehicle has."""
    p, v = msg.pose.pose.position, msg.twist.twist.linear
    return header_problem(msg, frames) or numbers_problem(position_limit, position=(p.x, p.y, p.z)) or \
        numbers_problem(MAX_SPEED_MPS, velocity=(v.x, v.y, v.z))


def sonar_problem(msg, base_frame):
    """A range (sensor_msgs/Range) that is NaN or negative (+inf is valid: no echo), a stamp from another time or a
    frame not the drone's body ``base_frame``."""
    if math.isnan(msg.range) or msg.range < 0.0:
        return ("non-finite" if math.isnan(msg.range) else "out of range"), "range is %s" % msg.range
    return header_problem(msg, (base_frame,))


def stamp_of(msg):
    """Header stamp in seconds, the current time when the publisher left it empty."""
    stamp = msg.header.stamp.to_sec()
    return stamp if stamp > 0.0 else rospy.get_time()
