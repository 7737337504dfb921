"""A Ray node on this machine, started and stopped by its process id: for the tests and the scaling
measurements of ``benchmark --ray`` (a cluster of real machines is started with ``ray start``, see the
README).

``ray start --block`` leads a process group of its own with every process of the node (GCS, raylet,
workers); stopping it signals that group, never Ray processes by name as ``ray stop`` does, which would also
stop another run's cluster on the same machine. Every port is a free one, so runs side by side do not
collide.

    with RayNode(num_cpus=2) as head, RayNode(num_cpus=2, address=head.address):
        ...  # rosrun landing_eval benchmark ... --ray <head.address>
"""
import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time

from .isolated_ros import free_port

START_TIMEOUT_S = 120.0  # ray start normally takes 3-5 s; a loaded machine more [s]
STOP_TIMEOUT_S = 5.0     # SIGTERM to the node's process group, then SIGKILL after this long [s]: GCS and
                         # raylet may take longer to stop on SIGTERM, and a test node keeps nothing worth it
WORKER_PORTS = 40        # ports a node's workers may listen on [-]


_handed_out = set()  # ports given to a node of this process: a node's ports are not bound until it runs


def _ports(count):
    """``count`` consecutive free ports that no other node of this process has been given (Ray refuses a
    port used by two of its components, and a second node's worker ports must not overlap the first's)."""
    for _ in range(100):
        base = free_port()
        candidates = range(base, base + count)
        if _handed_out.intersection(candidates):
            continue
        try:
            for port in candidates:
                with socket.socket() as sock:
                    sock.bind(("127.0.0.1", port))
        except OSError:
            continue
        _handed_out.update(candidates)
        return base
    raise RuntimeError("no %d free consecutive TCP ports for a Ray node" % count)


class RayNode:
    """``ray start --block`` of a head (``address`` None) or of a node joining the head at ``address``."""

    def __init__(self, num_cpus, address=None, temp_dir=None, log_path=None):
        self.num_cpus, self.head_address = num_cpus, address
        self.owns_temp_dir = temp_dir is None
        # Ray's socket paths must stay short (108 bytes): a short directory under /tmp.
        self.temp_dir = temp_dir or tempfile.mkdtemp(prefix="ray", dir="/tmp")
        self.log_path = log_path or os.path.join(self.temp_dir, "ray_start.log")
        self.port = _ports(1) if address is None else None
        self.address = "127.0.0.1:%d" % self.port if address is None else address
        self.process, self.process_returncode = None, None

    def command(self):
        low = _ports(WORKER_PORTS + 1)
        ports = ["--node-manager-port", str(_ports(1)), "--object-manager-port", str(_ports(1)),
                 "--min-worker-port", str(low), "--max-worker-port", str(low + WORKER_PORTS),
                 "--metrics-export-port", str(_ports(1)), "--runtime-env-agent-port", str(_ports(1)),
                 "--dashboard-agent-grpc-port", str(_ports(1)), "--dashboard-agent-listen-port", str(_ports(1))]
        role = ["--head", "--port", str(self.port),
                "--include-dashboard", "false", "--temp-dir", self.temp_dir] if self.head_address is None \
            else ["--address", self.head_address]
        return ["ray", "start", "--block", "--node-ip-address", "127.0.0.1", "--num-cpus", str(self.num_cpus),
                "--disable-usage-stats"] + role + ports

    def start(self):
        env = dict(os.environ, RAY_USAGE_STATS_ENABLED="0")
        env.pop("RAY_ADDRESS", None)
        self._log = open(self.log_path, "w")
        self.process = subprocess.Popen(self.command(), stdout=self._log, stderr=subprocess.STDOUT,
                                        stdin=subprocess.DEVNULL, env=env, start_new_session=True)
        deadline = time.monotonic() + START_TIMEOUT_S
        while True:
            with open(self.log_path) as stream:
                if "Ray runtime started" in stream.read():
                    return self
            if self.process.poll() is not None or time.monotonic() > deadline:
                with open(self.log_path) as stream:
                    last = (stream.read().strip().splitlines() or ["(no output)"])[-1]
                exited = self.process.poll() is not None
                self.stop()
                if exited:
                    raise RuntimeError("ray start exited with code %s: %s" % (self.process_returncode, last))
                raise TimeoutError("ray start did not report a running node within %.0f s: %s"
                                   % (START_TIMEOUT_S, last))
            time.sleep(0.2)

    def pids(self):
        """Every live process of this node: its process group (ray start, GCS, raylet, workers)."""
        found = []
        for entry in os.listdir("/proc"):
            if entry.isdigit():
                try:
                    with open("/proc/%s/stat" % entry) as stream:
                        fields = stream.read().rsplit(")", 1)[1].split()
                except OSError:  # gone meanwhile
                    continue
                state, pgid = fields[0], int(fields[2])
                if pgid == self.process.pid and state != "Z":
                    found.append(int(entry))
        return found

    def stop(self):
        if self.process is None:
            return
        if self.process.poll() is None:
            try:
                os.killpg(self.process.pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
        deadline = time.monotonic() + STOP_TIMEOUT_S
        while self.pids() and time.monotonic() < deadline:
            time.sleep(0.2)
        if self.pids():
            try:
                os.killpg(self.process.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        try:
            self.process_returncode = self.process.wait(timeout=30.0)  # after SIGKILL
        except subprocess.TimeoutExpired:
            pass
        self._log.close()
        if self.owns_temp_dir:
            shutil.rmtree(self.temp_dir, ignore_errors=True)
        self.process = None

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()
        return False
