"""Test tooling every package's tests share (rostests and pytest alike).

    from landing_runtime.testing import wait_for
    wait_for(lambda: messages, "a message on /topic", timeout=60)
"""
import sys
import time


def _ros_state():
    """(shut down?, ROS time: sim time under /use_sim_time) of this process's rospy node, or (False, None)."""
    rospy = sys.modules.get("rospy")
    if rospy is None or not rospy.core.is_initialized():
        return False, None
    return rospy.is_shutdown(), rospy.get_time()


def wait_for(condition, what, timeout, poll=0.02, process=None):
    """Returns the first true value of ``condition()``, polled every ``poll`` wall seconds. Fails with an
    AssertionError that names ``what``: after ``timeout`` wall seconds, as soon as this process's rospy node
    shuts down, or as soon as ``process`` (a subprocess.Popen the condition depends on) has exited."""
    deadline = time.monotonic() + timeout
    while True:
        value = condition()
        if value:
            return value
        shut_down, sim_time = _ros_state()
        at = "" if sim_time is None else " (ROS time %.2f)" % sim_time
        if shut_down:
            raise AssertionError("ROS shut down while waiting for %s%s" % (what, at))
        if process is not None and process.poll() is not None:
            raise AssertionError("%s exited (code %s) while waiting for %s" % (process.args, process.returncode, what))
        if time.monotonic() > deadline:
            raise AssertionError("timed out after %.0f s (wall) waiting for %s%s" % (timeout, what, at))
        time.sleep(poll)


def resend_until(send, condition, what, timeout, period_s=0.2):
    """Calls ``send()`` at once and again every ``period_s`` wall seconds until ``condition()`` is true, and returns
    that value; fails as ``wait_for`` does. For a message whose result depends on others sent on other
    connections, which it may overtake."""
    last_sent = [-float("inf")]

    def sent_and_met():
        if time.monotonic() - last_sent[0] > period_s:
            send()
            last_sent[0] = time.monotonic()
        return condition()
    return wait_for(sent_and_met, what, timeout)


def node_pid(node):
    """The process id of the ROS node ``node`` (e.g. "/supervisor"), asked of the node itself; None when it is not
    registered or does not answer."""
    import xmlrpc.client

    import rosgraph
    import rosnode
    import rospy
    try:
        uri = rosnode.get_api_uri(rosgraph.Master(rospy.get_name()), node, skip_cache=True)
        code, _message, pid = xmlrpc.client.ServerProxy(uri).getPid(rospy.get_name())
    except Exception:  # not registered (again) yet, or gone
        return None
    return pid if code == 1 else None


def crash_and_wait_for_respawn(node, timeout):
    """SIGKILL ``node``'s process (nothing tidied, as a crash) and wait until its launch has respawned it and the new
    process is registered. Returns the new process id."""
    import os
    import signal
    old = node_pid(node)
    if old is None:
        raise AssertionError("%s is not running: nothing to crash" % node)
    os.kill(old, signal.SIGKILL)

    def respawned():
        pid = node_pid(node)
        return pid if pid not in (None, old) else None
    return wait_for(respawned, "the respawned %s" % node, timeout)


def yaml_key_comments(path):
    """{top-level key: its comment} of a parameter file, a comment's indented continuation lines included: what
    the tests read to check that every key says its meaning and [unit]."""
    import re
    comments, key = {}, None
    with open(path) as stream:
        for line in stream:
            match = re.match(r"^([a-z_]+):", line)
            if match:
                key = match.group(1)
                comments[key] = line.partition("#")[2].strip()
            elif key and re.match(r"^\s+#", line):
                comments[key] += " " + line.strip().lstrip("#").strip()
            else:
                key = None
    return comments
