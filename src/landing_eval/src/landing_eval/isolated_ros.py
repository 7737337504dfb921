"""Run a launch file under its own ROS master on a free port, so several runs can coexist; run more
processes against that master; and check that every subscription in its graph is connected (and ask a
subscriber that gave up on a publisher to try again)."""
import ctypes
import os
import random
import signal
import socket
import subprocess
import sys
import time
import xmlrpc.client

_PR_SET_PDEATHSIG = 1  # prctl option (linux/prctl.h)


def signal_on_parent_death(signum):
    """In a child about to exec (preexec_fn): have the kernel send ``signum`` when the thread that started it
    ends, however that ends (a SIGKILL too), so that nothing outlives the process that was to stop it.
    Kept across exec. Also restores SIGINT's default action and unblocks SIGINT and SIGTERM, which a Ray
    worker blocks and ignores and a child inherits."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})
    if ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, int(signum)) != 0:
        raise OSError(ctypes.get_errno(), "prctl(PR_SET_PDEATHSIG) failed")


def free_port(low=20000):
    """A free TCP port below the kernel's ephemeral range. A port the kernel hands out (bind to 0) can be
    handed to another process's socket again before roslaunch binds it: with two runs side by side and
    dozens of nodes opening sockets, the master then failed with 'Address already in use'."""
    try:
        with open("/proc/sys/net/ipv4/ip_local_port_range") as stream:
            high = int(stream.read().split()[0])
    except (OSError, ValueError, IndexError):
        high = 32768
    for _ in range(100):
        port = random.randrange(low, max(low + 1, high))
        with socket.socket() as sock:
            try:
                sock.bind(("127.0.0.1", port))
            except OSError:
                continue
        return port
    raise RuntimeError("no free TCP port in %d-%d for a ROS master" % (low, high))


def unconnected_subscriptions(system_state, outbound):
    """(topic, publisher, subscriber) for each subscription the master lists whose publisher has not
    connected to the subscriber yet. ``system_state``: the master's getSystemState() (publishers,
    subscribers, services); ``outbound``: {publisher node: {(topic, subscriber node), ...}}, the
    connections each publisher reports (getBusInfo)."""
    publishers = dict(system_state[0])
    missing = []
    for topic, subscribers in system_state[1]:
        for publisher in publishers.get(topic, []):
            connected = outbound.get(publisher, set())
            missing.extend((topic, publisher, s) for s in subscribers if (topic, s) not in connected)
    return missing


class _TimeoutTransport(xmlrpc.client.Transport):
    """XML-RPC over HTTP with a socket timeout: a node that hangs must not hang its caller."""

    def __init__(self, timeout):
        super().__init__()
        self.timeout = timeout

    def make_connection(self, host):
        connection = super().make_connection(host)
        connection.timeout = self.timeout
        return connection


def node_api(uri, timeout):
    """The XML-RPC API of the node at ``uri``, giving up after ``timeout`` wall seconds."""
    return xmlrpc.client.ServerProxy(uri, transport=_TimeoutTransport(timeout))


def _node_api(master, node, timeout):
    return node_api(master.lookupNode(node), timeout)


def graph_unconnected(master, timeout=2.0):
    """unconnected_subscriptions() of the graph behind ``master`` (a rosgraph.Master), asking every
    publishing node for its connections. A node that does not answer counts as connected to nobody."""
    state = master.getSystemState()
    outbound = {}
    for node in {n for _, nodes in state[0] for n in nodes}:
        try:
            _, _, connections = _node_api(master, node, timeout).getBusInfo("/graph_check")
        except Exception:  # gone or not answering yet: checked again on the next poll
            continue
        # Entries: (id, destination, direction, transport, topic, ...); a publisher's are outbound ('o').
        outbound[node] = {(c[4], c[1]) for c in connections if c[2] in ("o", "b")}
    return unconnected_subscriptions(state, outbound)


def reconnect_subscribers(master, missing, timeout=2.0):
    """Send each subscriber of ``missing`` (graph_unconnected's tuples) its topic's publishers again, as the
    master does when they change (publisherUpdate). A rospy subscriber tries a new publisher once: if that
    requestTopic fails, it never connects (one run in about 100 started without the tracker's cmd_vel
    reaching the mux). Returns the (topic, subscriber) pairs that took the update."""
    publishers = dict(master.getSystemState()[0])
    sent = []
    for topic, subscriber in sorted({(topic, subscriber) for topic, _, subscriber in missing}):
        try:
            uris = [master.lookupNode(node) for node in publishers.get(topic, [])]
            _node_api(master, subscriber, timeout).publisherUpdate("/master", topic, uris)
        except Exception:  # gone, or not answering: the next check finds it again
            continue
        sent.append((topic, subscriber))
    return sent


LOOPBACK_SHIM = "liblanding_loopback_bind.so"


def loopback_environment(env):
    """``env`` for a graph that listens on loopback only: ROS_IP=127.0.0.1 (the master, rospy, roscpp's TCPROS) and
    the preloaded shim that keeps roscpp's XML-RPC server there too (landing_msgs/src/loopback_bind.c), found on
    LD_LIBRARY_PATH (the built workspace's devel/lib)."""
    env = dict(env, ROS_IP="127.0.0.1", LANDING_ROS_LOOPBACK="1")
    env.pop("ROS_HOSTNAME", None)
    for directory in env.get("LD_LIBRARY_PATH", "").split(":"):
        shim = os.path.join(directory, LOOPBACK_SHIM)
        if directory and os.path.isfile(shim):
            preload = [p for p in env.get("LD_PRELOAD", "").split(":") if p and os.path.basename(p) != LOOPBACK_SHIM]
            env["LD_PRELOAD"] = ":".join([shim] + preload)
            break
    return env


class IsolatedProcess:
    """``command`` run against the master at ``master_uri``, in a new process group, its output in
    ``log_path``. Use as a context manager (from the thread that lives as long as the process should: it
    gets SIGINT when that thread ends, e.g. a runner SIGKILLed with the Ray worker that ran it): leaving it
    interrupts the process (SIGINT, as Ctrl-C) and waits. ``env``: variables added to its environment."""

    def __init__(self, command, log_path, master_uri, env=None):
        self.command, self.log_path, self.master_uri = list(command), log_path, master_uri
        self.extra_env = dict(env or {})
        self.process, self.interrupted = None, False
        self.exited_at = None  # time.monotonic() when leaving the context found the process ended

    def __enter__(self):
        env = loopback_environment(dict(os.environ, ROS_MASTER_URI=self.master_uri, **self.extra_env))
        self._log = open(self.log_path, "w")
        self.process = subprocess.Popen(self.command, env=env, stdout=self._log, stderr=subprocess.STDOUT,
                                        stdin=subprocess.DEVNULL, start_new_session=True,
                                        preexec_fn=lambda: signal_on_parent_death(signal.SIGINT))
        return self

    def alive(self):
        return self.process is not None and self.process.poll() is None

    def interrupt(self):
        """SIGINT without waiting: several processes then stop side by side; leaving the context waits."""
        if self.alive() and not self.interrupted:
            os.killpg(self.process.pid, signal.SIGINT)
            self.interrupted = True

    def __exit__(self, *exc):
        if self.process is not None and self.process.poll() is None:
            self.interrupt()
            try:
                self.process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(self.process.pid, signal.SIGKILL)
                self.process.wait()
        self.exited_at = time.monotonic()
        self._log.close()
        return False


class IsolatedLaunch(IsolatedProcess):
    """``roslaunch -p PORT`` of ``launch_args`` (package, file, arg:=value...) under its own master on a
    free port, so several runs can coexist. ``master_uri`` is what clients in this process must use (set
    ``os.environ['ROS_MASTER_URI']`` before ``rospy.init_node``). Given the ``port`` of a master (IsolatedCore),
    roslaunch waits for that master (--wait: it may be started together with it, its imports and parsing then
    overlap the master's start) and never starts one of its own."""

    def __init__(self, launch_args, log_path, port=None):
        own_master = port is None
        self.port = port or free_port()
        # A node exits within about a second of SIGINT. One that hangs (rospy runs its shutdown inside the
        # signal handler and can deadlock on a lock the interrupted thread holds: the simulator did, 1 run
        # in 10, before it handled the signal itself) would cost roslaunch's default 15 s + 2 s.
        # --skip-log-check: roslaunch would add up the size of ~/.ros/log at every start (0.1 s, more as it grows).
        command = ["roslaunch", "-p", str(self.port), "--screen", "--sigint-timeout=3", "--sigterm-timeout=1",
                   "--skip-log-check"] + ([] if own_master else ["--wait"])
        super().__init__(command + list(launch_args), log_path, "http://127.0.0.1:%d" % self.port)

    def wait_for_master(self, timeout=60.0):
        import rosgraph
        deadline = time.monotonic() + timeout
        master = rosgraph.Master("/isolated_launch", master_uri=self.master_uri)
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RuntimeError("roslaunch exited with code %s; see %s" % (self.process.returncode, self.log_path))
            try:
                master.getPid()
                return
            except Exception:  # master not up yet
                time.sleep(0.05)
        raise TimeoutError("no ROS master on port %d after %.0f s; see %s" % (self.port, timeout, self.log_path))


class IsolatedCore(IsolatedLaunch):
    """The master and rosout on a free port (landing_eval.ros_core: what ``roscore -p PORT`` starts, started
    faster) in a process tree of its own. A launch run against it (IsolatedLaunch with the same port) then does
    not own the master: roslaunch ends its whole graph when a master it started dies, whereas nodes whose master
    dies go on over their connections."""

    def __init__(self, log_path, port=None):
        super().__init__([], log_path, port)
        self.command = [sys.executable, "-m", "landing_eval.ros_core", str(self.port)]
