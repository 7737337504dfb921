"""What the recorder's rostests share: a sim clock of their own, the recorder's process, waits on conditions."""
import errno
import fcntl
import os
import struct
import termios
import threading
import time
import xmlrpc.client

import rosgraph
import rospy
from rosgraph_msgs.msg import Clock

SIM_START_S = 1000.0  # far from wall time (1.7e9 s): a receipt time from the wall clock cannot pass for sim time
WAIT_S = 60.0         # generous: a loaded 2-core machine


def wait_for(condition, what, timeout_s=WAIT_S, poll_s=0.02):
    """Polls ``condition`` (wall time) until it is true; fails the test after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError("timed out after %.0f s waiting for %s" % (timeout_s, what))
        time.sleep(poll_s)


class SimClock:
    """/clock from SIM_START_S on, advancing 10 ms each 10 ms of wall time once started."""

    def __init__(self):
        self.publisher = rospy.Publisher("/clock", Clock, queue_size=10)
        self.lock = threading.Lock()
        self.now_s = SIM_START_S  # the last one published
        self.running = False
        self.thread = threading.Thread(target=self._run, daemon=True)

    def start(self):
        self.running = True
        self.thread.start()

    def now(self):
        with self.lock:
            return rospy.Time.from_sec(self.now_s)

    def _run(self):
        while self.running and not rospy.is_shutdown():
            with self.lock:
                stamp = rospy.Time.from_sec(self.now_s)
            self.publisher.publish(Clock(clock=stamp))
            with self.lock:
                self.now_s += 0.01
            time.sleep(0.01)


def master():
    return rosgraph.Master(rospy.get_name())


def subscribers_of(topic):
    for name, nodes in master().getSystemState()[1]:
        if name == topic:
            return set(nodes)
    return set()


def node_pid(node):
    uri = master().lookupNode(node)
    code, _, pid = xmlrpc.client.ServerProxy(uri).getPid(rospy.get_name())
    assert code == 1, "%s did not tell its pid" % node
    return pid


def process_gone(pid):
    try:
        os.kill(pid, 0)
    except OSError as error:
        return error.errno == errno.ESRCH
    # a zombie (roslaunch has not reaped it yet) is gone too
    with open("/proc/%d/stat" % pid) as f:
        return f.read().rsplit(")", 1)[1].split()[0] == "Z"


def _receive_queues():
    """{(local port, remote port): bytes received and not read yet} of this machine's TCP sockets."""
    queues = {}
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        if not os.path.exists(table):
            continue
        with open(table) as f:
            next(f)
            for line in f:
                fields = line.split()
                local_port = int(fields[1].rsplit(":", 1)[1], 16)
                remote_port = int(fields[2].rsplit(":", 1)[1], 16)
                queues[(local_port, remote_port)] = int(fields[4].split(":")[1], 16)
    return queues


def delivered(publishers):
    """Whether every message these (synchronous, queue_size=None) publishers sent has been read by its
    subscribers' processes: nothing left unsent on this side, nothing unread on the other."""
    queues = _receive_queues()
    for publisher in publishers:
        for connection in publisher.impl.connections:
            sock = connection.socket
            if sock is None:
                continue
            unsent = struct.unpack("i", fcntl.ioctl(sock.fileno(), termios.TIOCOUTQ, b"\0\0\0\0"))[0]
            local_port, peer_port = sock.getsockname()[1], sock.getpeername()[1]
            if unsent or queues.get((peer_port, local_port), 0):
                return False
    return True


def wait_delivered(publishers, what):
    # twice in a row 50 ms apart: a message between the two checks shows in the second
    seen = [False]

    def twice():
        now = delivered(publishers)
        result = now and seen[0]
        seen[0] = now
        return result
    wait_for(twice, what, poll_s=0.05)

