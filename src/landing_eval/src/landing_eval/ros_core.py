"""The ROS master and rosout of one run, as `roscore -p PORT` starts them, without roscore's own roslaunch.

    python -m landing_eval.ros_core PORT

roscore is a roslaunch of roscore.xml: before its master listens it imports roslaunch and runs `rosversion`
twice (two more Python processes) for two parameters nobody here reads; stopping it stops rosout and the
master one after the other, polling each every 0.1 s. On a loaded 2-core machine that was 1-6 s of every
run's start-up. Here the master starts at once and rosout as soon as the master answers; both are children
of this process (one process tree; each child in a process group of its own, so that IsolatedCore's SIGINT
reaches this process, which ends rosout and the master with SIGTERM). A
rosout that dies is started again (roscore's respawn="true"); a master that dies stays dead, as with
roscore (the graph flies on over its connections). This process ends when both have ended.
"""
import os
import signal
import subprocess
import sys
import time
import uuid
import xmlrpc.client

from .isolated_ros import signal_on_parent_death

MASTER_WAIT_S = 60.0  # the master answering at most this long after its start, else this process gives up [s]
STOP_WAIT_S = 10.0    # after SIGTERM, each child has this long to end before SIGKILL [s]


def rosout_executable():
    """rosout's binary: PREFIX/lib/rosout/rosout for the prefixes of the workspace, then Debian's /usr."""
    prefixes = [p for p in os.environ.get("CMAKE_PREFIX_PATH", "").split(":") if p] + ["/usr", "/opt/ros/noetic"]
    for prefix in prefixes:
        path = os.path.join(prefix, "lib", "rosout", "rosout")
        if os.access(path, os.X_OK):
            return path
    raise FileNotFoundError("no rosout binary under %s (Debian's package: ros-base-dev)" % ", ".join(prefixes))


def _child(command):
    """``command`` in a process group of its own (a SIGINT to this one's group does not reach it: they are stopped
    in order), ended by SIGINT when this process ends, however it ends."""
    def prepare():
        os.setpgid(0, 0)
        signal_on_parent_death(signal.SIGINT)
    return subprocess.Popen(command, stdin=subprocess.DEVNULL, preexec_fn=prepare)


def wait_for_master(uri, master, timeout=MASTER_WAIT_S):
    proxy = xmlrpc.client.ServerProxy(uri)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and master.poll() is None:
        try:
            proxy.getPid("/ros_core")
            return True
        except OSError:  # not listening yet
            time.sleep(0.02)
    return False


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1 or not argv[0].isdigit():
        print("usage: python -m landing_eval.ros_core PORT", file=sys.stderr)
        return 2
    port = int(argv[0])
    children, stopping, waiting, signalled = {}, [], [], set()

    def stop(_signum=None, _frame=None):
        if not stopping:
            stopping.append(time.monotonic())
        if waiting:
            raise _Stop()
    signal.signal(signal.SIGINT, stop)
    signal.signal(signal.SIGTERM, stop)
    master = _child(["rosmaster", "--core", "-p", str(port), "-w", "3"])
    children[master.pid] = master
    uri = "http://%s:%d/" % (os.environ.get("ROS_IP", "127.0.0.1"), port)
    if wait_for_master(uri, master):
        # roscore's run id: a `roslaunch --wait` (IsolatedLaunch against this master) waits for it.
        xmlrpc.client.ServerProxy(uri).setParam("/ros_core", "/run_id", str(uuid.uuid1()))
        print("ROS_MASTER_URI=%s" % uri, flush=True)  # (as roscore says it)
    else:
        print("ros_core: the master did not answer on port %d within %.0f s" % (port, MASTER_WAIT_S), file=sys.stderr)
        stop()
    rosout_command = [rosout_executable(), "__name:=rosout"]
    rosout = None
    if not stopping:
        rosout = _child(rosout_command)
        children[rosout.pid] = rosout
    while children:
        for pid, child in list(children.items()):
            if child.poll() is not None:
                del children[pid]
                if child is rosout and not stopping:
                    print("ros_core: rosout ended with code %s; starting it again" % child.returncode, file=sys.stderr)
                    rosout = _child(rosout_command)
                    children[rosout.pid] = rosout
        if not children:
            break
        if stopping:
            # SIGTERM, which neither handles: both end at once. After SIGINT rosout unregistered from the master
            # (0.25 s) and the master then stopped its XML-RPC server (0.15 s), for nothing: the run is over and
            # neither keeps anything (rosout writes each line to rosout.log as it comes). Bounded: SIGKILL
            # STOP_WAIT_S after the signal.
            for child in (rosout, master):
                if child is not None and child.pid in children and child.pid not in signalled:
                    signalled.add(child.pid)
                    _signal(child, signal.SIGTERM)
            if time.monotonic() - stopping[0] > STOP_WAIT_S:
                for child in children.values():
                    _signal(child, signal.SIGKILL)
            time.sleep(0.01)
        else:
            try:
                waiting.append(True)
                os.waitid(os.P_ALL, 0, os.WEXITED | os.WNOWAIT)  # until a child ends, or a signal to stop
            except _Stop:
                pass
            finally:
                waiting.clear()
    return 0


class _Stop(Exception):
    """Raised by the signal handler to end the wait for a child."""


def _signal(child, signum):
    try:
        child.send_signal(signum)
    except ProcessLookupError:
        pass


if __name__ == "__main__":
    sys.exit(main())
