"""Trails of the drone and the platform for rviz: nav_msgs/Path of the last seconds of poses.

Display only: the trails come from ground truth so an operator sees what really happened next to what
the estimators believe (the Kalman prediction, the drone's own odometry)."""
import sys


class Trail:
    """Positions kept for ``seconds``, at most one per ``spacing`` metres (ROS-free)."""

    def __init__(self, seconds, spacing):
        self.seconds, self.spacing, self.points = seconds, spacing, []

    def add(self, t, x, y, z):
        if self.points:
            _, lx, ly, lz = self.points[-1]
            if t < self.points[-1][0]:
                self.points.clear()  # sim time went backwards: a reset
            elif (x - lx) ** 2 + (y - ly) ** 2 + (z - lz) ** 2 < self.spacing ** 2:
                return False
        self.points.append((t, x, y, z))
        while self.points and self.points[0][0] < t - self.seconds:
            self.points.pop(0)
        return True


def main():
    import rospy
    from geometry_msgs.msg import PoseStamped
    from nav_msgs.msg import Path
    from landing_runtime.rospy_node import init_node, spin
    init_node("trails")
    try:
        seconds, spacing = float(rospy.get_param("~seconds")), float(rospy.get_param("~spacing"))
    except KeyError as err:
        rospy.logfatal("trails: required parameter %s is not set (seconds [s], spacing [m])", err)
        sys.exit(2)
    sources = {"groundtruth/ardrone": "trails/drone", "groundtruth/landing_pad": "trails/platform"}
    for source, target in sources.items():
        trail, publisher = Trail(seconds, spacing), rospy.Publisher(target, Path, queue_size=1, latch=True)

        def on_pose(msg, trail=trail, publisher=publisher):
            p = msg.pose.position
            if trail.add(msg.header.stamp.to_sec(), p.x, p.y, p.z):
                path = Path()
                path.header.frame_id, path.header.stamp = "world", msg.header.stamp
                for t, x, y, z in trail.points:
                    pose = PoseStamped()
                    pose.header.frame_id, pose.header.stamp = "world", rospy.Time.from_sec(t)
                    pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = x, y, z
                    pose.pose.orientation.w = 1.0
                    path.poses.append(pose)
                publisher.publish(path)
        rospy.Subscriber(source, PoseStamped, on_pose, queue_size=5)
    spin()
