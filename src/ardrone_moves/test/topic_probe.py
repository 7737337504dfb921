#!/usr/bin/env python3
"""Prints what arrives on the drone's command topics as JSON lines, and its connection counts when
they change. Helper of test_keyboard_teleop_pty.py: a separate process, so that the pytest process
never calls rospy.init_node (other test modules share it)."""
import json
import threading
import time

import rospy
from geometry_msgs.msg import Twist
from std_msgs.msg import Empty, String


def main():
    rospy.init_node("topic_probe", anonymous=True)
    lock = threading.Lock()

    def emit(record):
        with lock:
            print(json.dumps(record), flush=True)

    subscribers = {
        "cmd_vel": rospy.Subscriber("/ardrone/cmd_vel", Twist, lambda m: emit(
            {"topic": "cmd_vel", "linear": [m.linear.x, m.linear.y, m.linear.z], "yaw_rate": m.angular.z})),
        "takeoff": rospy.Subscriber("/ardrone/takeoff", Empty, lambda m: emit({"topic": "takeoff"})),
        "land": rospy.Subscriber("/ardrone/land", Empty, lambda m: emit({"topic": "land"})),
        "operator": rospy.Subscriber("/operator/command", String, lambda m: emit({"topic": "operator",
                                                                                 "data": m.data})),
    }
    reported = None
    while not rospy.is_shutdown():
        counts = {name: subscriber.get_num_connections() for name, subscriber in subscribers.items()}
        if counts != reported:
            emit({"connections": counts})
            reported = counts
        time.sleep(0.05)


if __name__ == "__main__":
    main()
