"""Angles of a rotation quaternion, ROS-free (plain math), shared by the simulator, the drone estimator
and whatever else needs a heading: one definition instead of one per package. The C++ nodes use
tf2::getYaw."""
import math


def euler_from_quaternion(w, x, y, z):
    """(roll, pitch, yaw) [rad] of the unit quaternion (w, x, y, z), Z-Y-X order (yaw about world z, then
    pitch, then roll), as tf's euler_from_quaternion(..., 'sxyz'); pitch is clamped at +-90 deg."""
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    return roll, pitch, yaw_from_quaternion(w, x, y, z)


def yaw_from_quaternion(w, x, y, z):
    """Heading [rad] of the unit quaternion (w, x, y, z): the rotation about world z."""
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def turned_about_world_z(quaternion, angle):
    """The unit quaternion (w, x, y, z) turned by ``angle`` [rad] about world z (its yaw grows by ``angle``,
    its roll and pitch stay)."""
    w, x, y, z = quaternion
    c, s = math.cos(angle / 2.0), math.sin(angle / 2.0)
    return (c * w - s * z, c * x - s * y, c * y + s * x, c * z + s * w)
