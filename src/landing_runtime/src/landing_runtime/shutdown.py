"""Ctrl-C and SIGTERM for rospy nodes, without rospy's deadlock.

rospy's own handler runs the whole shutdown (closing every connection) inside the signal handler, in the
thread it interrupted. If that thread was publishing, it holds the connection's lock, and the close
waits for it forever: the simulator hung so 1 run in 10, the supervisor once, until roslaunch
SIGKILLed them. Here the handler only starts a thread that shuts rospy down; the interrupted thread
carries on, releases its lock, and the shutdown completes.

    rospy.init_node("name", disable_signals=True)
    shutdown_on_signals()
"""
import signal
import threading

import rospy


def shutdown_on_signals(signals=(signal.SIGINT, signal.SIGTERM)):
    """Install the handlers (call from the main thread, after rospy.init_node(..., disable_signals=True))."""
    def handler(signum, _frame):
        reason = "signal %s" % signal.Signals(signum).name
        threading.Thread(target=rospy.signal_shutdown, args=(reason,), daemon=True).start()
    for signum in signals:
        signal.signal(signum, handler)
