"""The pad's two inputs that both the estimator's node and the tracker's read, checked: the pad filter's odometry
(kalman_platform_odom) and the camera's fix of the pad in the world (platform/current_platform_position_in_world);
and how long the drone's published estimate is kept to place such a fix at its image's capture time (with
estimator.StateHistory: the fix less the estimate then is the pad relative to the drone then)."""
import numpy as np
from landing_runtime.input_check import MAX_POSITION_M, numbers_problem
from landing_runtime.message_check import WORLD_FRAME, header_problem, odometry_problem, stamp_of

ESTIMATE_HISTORY = 2.0     # how far back the estimate is kept, to place a fix at its image's capture time [s]
ESTIMATE_EXTRAPOLATION = 0.1  # a fix this far outside that history is placed with its nearest estimate [s]


def pad_odometry(msg, rejections):
    """(stamp, position, velocity) of the Kalman filter's pad odometry, or None after logging why it was dropped."""
    problem = odometry_problem(msg)
    if problem:
        rejections.reject("kalman_platform_odom", problem)
        return None
    p, v = msg.pose.pose.position, msg.twist.twist.linear
    return stamp_of(msg), (p.x, p.y, p.z), (v.x, v.y, v.z)


def world_fix(msg, rejections):
    """(stamp, world xy) of the camera's fix of the pad (platform/current_platform_position_in_world), or None after
    logging why it was dropped."""
    p = msg.point
    problem = numbers_problem(MAX_POSITION_M, point=(p.x, p.y, p.z)) or header_problem(msg, (WORLD_FRAME,))
    if problem:
        return rejections.reject("platform/current_platform_position_in_world", problem)
    return stamp_of(msg), np.array([p.x, p.y])
