"""The processes of one run, ROS-free: which process is which node (found in the process tree of the run's
roslaunch by its ``__name:=`` argument, so it works without the ROS master and never touches another run's
nodes), their memory and CPU time from /proc, and the crashes roslaunch reported in its log."""
import os
import re

CLOCK_TICKS = os.sysconf("SC_CLK_TCK")
PAGE_KB = os.sysconf("SC_PAGE_SIZE") // 1024


def _read(path):
    try:
        with open(path, "rb") as stream:
            return stream.read()
    except OSError:  # the process is gone (or never was)
        return None


def children_map():
    """{parent pid: [child pids]} of every process now."""
    children = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        stat = _read("/proc/%s/stat" % entry)
        if stat is None:
            continue
        # "pid (comm) state ppid ...": comm may hold spaces and parentheses; the last ')' ends it.
        fields = stat[stat.rindex(b")") + 2:].split()
        children.setdefault(int(fields[1]), []).append(int(entry))
    return children


def descendants(pid, children=None):
    """Every process below ``pid`` (not ``pid`` itself)."""
    children = children_map() if children is None else children
    found, todo = [], list(children.get(pid, []))
    while todo:
        child = todo.pop()
        found.append(child)
        todo.extend(children.get(child, []))
    return found


def command_line(pid):
    raw = _read("/proc/%d/cmdline" % pid)
    return [] if raw is None else [part.decode(errors="replace") for part in raw.split(b"\0") if part]


def node_name_of(cmdline):
    """The ROS node name a command line gives its process (``__name:=NAME``), the master as 'master', or None."""
    for arg in cmdline:
        if arg.startswith("__name:="):
            return arg[len("__name:="):]
    if any(os.path.basename(arg) == "rosmaster" for arg in cmdline[:2]):
        return "master"
    return None


def nodes_below(pids):
    """{node name: pid} of the ROS nodes (and the master) among the processes below ``pids`` (and ``pids``
    themselves). A rosrun wrapper and the node it starts share the name: the deepest process, the node's own,
    wins."""
    children = children_map()
    found = {}
    for root in pids:
        for pid in [root] + descendants(root, children):
            name = node_name_of(command_line(pid))
            if name is not None and (name not in found or pid in descendants(found[name], children)):
                found[name] = pid
    return found


def usage(pid):
    """(resident memory [MB], CPU time user + system [s]) of ``pid``, or None when it is gone."""
    stat = _read("/proc/%d/stat" % pid)
    statm = _read("/proc/%d/statm" % pid)
    if stat is None or statm is None:
        return None
    fields = stat[stat.rindex(b")") + 2:].split()
    cpu_s = (int(fields[11]) + int(fields[12])) / CLOCK_TICKS  # utime, stime (fields 14 and 15 of stat)
    rss_mb = int(statm.split()[1]) * PAGE_KB / 1024.0
    return rss_mb, cpu_s


class ResourceLog:
    """Samples of every node's memory and CPU time at named moments (start, after each mission, end), and the
    table of the first sample after warm-up against the last."""

    def __init__(self):
        self.samples = []  # [{"label", "wall_s", "sim_s", "nodes": {name: {"pid", "rss_mb", "cpu_s"}}}]

    def sample(self, label, wall_s, sim_s, nodes):
        """``nodes``: {name: pid} now (nodes_below)."""
        entry = {"label": label, "wall_s": round(wall_s, 2), "sim_s": round(sim_s, 2), "nodes": {}}
        for name, pid in sorted(nodes.items()):
            measured = usage(pid)
            if measured is not None:
                entry["nodes"][name] = {"pid": pid, "rss_mb": round(measured[0], 2), "cpu_s": round(measured[1], 2)}
        self.samples.append(entry)
        return entry

    def table(self, baseline=0):
        """Per node: RSS and CPU share (of one core, over the interval before the sample) at the sample
        ``baseline`` and at the last one, the RSS growth between them, and whether its pid changed (it died
        and was restarted). Needs two samples after the baseline for the CPU shares."""
        if len(self.samples) < baseline + 2:
            return {}
        first, last = self.samples[baseline], self.samples[-1]
        rows = {}
        for name in sorted(set(first["nodes"]) | set(last["nodes"])):
            a, b = first["nodes"].get(name), last["nodes"].get(name)
            row = {"rss_start_mb": a and a["rss_mb"], "rss_end_mb": b and b["rss_mb"],
                   "rss_growth_pct": round(100.0 * (b["rss_mb"] - a["rss_mb"]) / a["rss_mb"], 1)
                   if a and b and a["rss_mb"] > 0 else None,
                   "cpu_start_pct": self._cpu_share(name, baseline + 1),
                   "cpu_end_pct": self._cpu_share(name, len(self.samples) - 1),
                   "restarted": bool(a and b and a["pid"] != b["pid"])}
            rows[name] = row
        return rows

    def _cpu_share(self, name, index):
        """CPU use of ``name`` between samples index-1 and index, in % of one core (None if unknown)."""
        if index < 1 or index >= len(self.samples):
            return None
        a, b = self.samples[index - 1]["nodes"].get(name), self.samples[index]["nodes"].get(name)
        wall = self.samples[index]["wall_s"] - self.samples[index - 1]["wall_s"]
        if not a or not b or a["pid"] != b["pid"] or wall <= 0:
            return None
        return round(100.0 * (b["cpu_s"] - a["cpu_s"]) / wall, 1)


# roslaunch's lines about a node that ended: "[supervisor-8] process has died [pid 123, exit code -9, cmd ...]",
# "[supervisor-8] restarting process", and for a required node "REQUIRED process [mujoco_sim-2] has died!" followed
# by "process has died [pid 456, exit code -9, cmd ...]".
_DIED = re.compile(r"(?:\[([\w/.-]+?)-\d+\] )?process has died \[pid (\d+), exit code (-?\d+)")
_REQUIRED = re.compile(r"REQUIRED process \[([\w/.-]+?)(?:-\d+)?\] has died")
_RESPAWN = re.compile(r"\[([\w/.-]+?)-\d+\] restarting process")


def deaths_in_launch_log(text):
    """[{"node", "pid", "exit_code", "required", "respawned"}] of every node roslaunch saw die, in order."""
    deaths, required = [], None
    for line in text.splitlines():
        match = _REQUIRED.search(line)
        if match:
            required = match.group(1)
            continue
        match = _DIED.search(line)
        if match:
            name = match.group(1) or required
            deaths.append({"node": name, "pid": int(match.group(2)), "exit_code": int(match.group(3)),
                           "required": match.group(1) is None and required is not None, "respawned": False})
            required = None
            continue
        match = _RESPAWN.search(line)
        if match:
            for death in reversed(deaths):
                if death["node"] == match.group(1):
                    death["respawned"] = True
                    break
    return deaths


def _listening_inodes():
    """{socket inode: "address:port"} of every listening TCP socket (IPv4 and IPv6) on this machine."""
    found = {}
    for path, width in (("/proc/net/tcp", 8), ("/proc/net/tcp6", 32)):
        raw = _read(path)
        for line in (raw or b"").decode().splitlines()[1:]:
            fields = line.split()
            if len(fields) < 10 or fields[3] != "0A":  # 0A: LISTEN
                continue
            address, port = fields[1].split(":")
            found[fields[9]] = "%s:%d" % (_address(address, width), int(port, 16))
    return found


def _address(hex_address, width):
    """The text of an address as /proc/net/tcp{,6} writes it (little-endian 32-bit words)."""
    import ipaddress
    words = [hex_address[i:i + 8] for i in range(0, width, 8)]
    raw = b"".join(bytes.fromhex(word)[::-1] for word in words)
    address = ipaddress.ip_address(raw)
    return str(address.ipv4_mapped or address) if address.version == 6 else str(address)


def listening_of(pids):
    """{key: the TCP addresses ("address:port") process pid listens on} for ``pids`` ({key: pid}), the machine's
    sockets read once (/proc/net/tcp lists every socket of every run on the machine)."""
    inodes = _listening_inodes()
    return {key: _listening(pid, inodes) for key, pid in pids.items()}


def _listening(pid, inodes):
    """The TCP addresses ("address:port") process ``pid`` listens on; ``inodes``: _listening_inodes()."""
    addresses = []
    try:
        for fd in os.listdir("/proc/%d/fd" % pid):
            try:
                target = os.readlink("/proc/%d/fd/%s" % (pid, fd))
            except OSError:
                continue
            if target.startswith("socket:[") and target[8:-1] in inodes:
                addresses.append(inodes[target[8:-1]])
    except OSError:
        pass
    return sorted(set(addresses))


def is_loopback(address):
    """Whether "address:port" is on the loopback interface."""
    import ipaddress
    host = address.rsplit(":", 1)[0]
    return ipaddress.ip_address(host).is_loopback
