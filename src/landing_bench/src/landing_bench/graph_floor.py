"""The closed loop's floor: how fast the real simulator runs inside a graph of the same shape as the landing
graph whose nodes do nothing but exchange the same messages.

    rosrun landing_bench bench_floor TOPOLOGY.json [--realism PROFILE] [--sim-seconds S] [--merge NODE,...|all]
                                                  [--jobs N] [--json]

``bench_loop`` notes the landing graph's topology in flight (topology.json in its run directory: every node's
subscriptions, its publications with their rates per sim second, its lock-step acknowledgements and its client
library, from the master, the nodes' getBusStats and /lockstep_ack). ``bench_floor`` starts the simulator as
``bench_sim`` does (sim.launch at full speed, the drone on its pad) and beside it one null node per node of that
topology, under the same name and client library (``null_node``, rospy, or ``null_node_cpp``, roscpp): it
subscribes to the same topics (a rospy one deserialising them, as a Python node must), publishes default
messages of the same types at the same rates and acknowledges the same inputs, so the simulator's lock-step
gate waits for it as for the real node. No node computes anything, so what the floor costs beyond the simulator
alone is the transport of the graph's messages: the real-time factor the landing graph could reach if its nodes'
own work cost nothing. Publications below one message per sim second (latched states, one-off commands such as
a take-off) are left out: they cost nothing and would change the world. ``--merge`` runs some nodes (or all) as one
roscpp process, as nodelets of one manager would: what a change of the graph's shape would gain, before it is
built. ``--jobs N`` runs N floors side by side after one alone: the most ``benchmark --jobs N`` could gain with this
graph, whatever its nodes do.
"""
import argparse
import dataclasses
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
import xmlrpc.client
from typing import Dict, List

from landing_eval import processes

from . import bus_stats
from .bus_stats import SIMULATOR, client_of, publish_rates

# What every node does by itself under sim time, and what the floor sets up on its own: rospy and roscpp subscribe
# to /clock and publish /rosout; lock-step acknowledgements come from each node's ``acks``.
IMPLICIT_SUBSCRIPTIONS = ("/clock",)
IMPLICIT_PUBLICATIONS = ("/rosout", "/lockstep_ack")
ACK_TOPIC = "/lockstep_ack"
MIN_RATE_HZ = 1.0  # publications below this many messages per sim second are left out [1/sim s]
NOT_NULLED = (SIMULATOR, "/rosout", "master")  # the simulator is the real one; the core's own nodes stay


@dataclasses.dataclass
class NodeShape:
    """What one node of the graph subscribes to, publishes and acknowledges: the floor's null node of that name does
    the same, and nothing else."""
    name: str
    client: str  # "rospy" or "roscpp": the client library of the real node, and so of its null node
    subscribes: List[Dict[str, str]]  # [{"topic", "type"}]
    publishes: List[Dict]  # [{"topic", "type", "rate_hz"}] (rate in messages per sim second)
    acks: List[Dict]  # [{"input", "period"}]: period 0, each message of topic ``input`` (which comes at "rate_hz"
    # per sim second); else a timer step [sim s]

    def driver(self):
        """What makes the null node publish, as the real node does: {"timer_hz": its lock-step timer's rate (0: none),
        "input": else the first input it acknowledges ("": none), "hz": how often either comes [per sim s]}; a node with
        neither ticks at its fastest publication's rate."""
        timer = next((a for a in self.acks if a["period"] > 0), None)
        if timer is not None:
            return {"timer_hz": 1.0 / timer["period"], "input": "", "hz": 1.0 / timer["period"]}
        first_input = next((a for a in self.acks if a["period"] <= 0), None)
        if first_input is not None:
            return {"timer_hz": 0.0, "input": first_input["input"], "hz": first_input.get("rate_hz", 0.0)}
        fastest = max((p["rate_hz"] for p in self.publishes), default=0.0)
        return {"timer_hz": fastest, "input": "", "hz": fastest}

    def null_spec(self, serialized):
        """The node's ~null_spec parameter: its topics with, for each publication, the type's MD5 sum and
        definition and a default message serialised (``serialized``: {type: (md5sum, definition, bytes)}), and its
        driver()."""
        publishes = []
        for pub in self.publishes:
            md5sum, definition, data = serialized[pub["type"]]
            publishes.append(dict(pub, md5sum=md5sum, definition=definition, data=xmlrpc.client.Binary(data)))
        return {"subscribes": self.subscribes, "publishes": publishes, "acks": self.acks, "driver": self.driver()}


def topology(system_state, topic_types, clients, publish_rates, acks, not_nulled=NOT_NULLED):
    """{node: NodeShape} of the graph behind a master: ``system_state`` its getSystemState() (publishers,
    subscribers, services), ``topic_types`` {topic: type}, ``clients`` {node: 'rospy' | 'roscpp'} (a node missing
    from it is left out), ``publish_rates`` {(node, topic): messages per sim second}, ``acks`` [(node, input,
    period [sim s])] as heard on /lockstep_ack. The nodes in ``not_nulled`` are left out."""
    nodes = {name: NodeShape(name, client, [], [], []) for name, client in clients.items() if name not in not_nulled}
    for topic, names in system_state[1]:
        for name in names:
            if name in nodes and topic not in IMPLICIT_SUBSCRIPTIONS and topic in topic_types:
                nodes[name].subscribes.append({"topic": topic, "type": topic_types[topic]})
    for topic, names in system_state[0]:
        for name in names:
            rate = publish_rates.get((name, topic), 0.0)
            if name in nodes and topic not in IMPLICIT_PUBLICATIONS and topic in topic_types and rate >= MIN_RATE_HZ:
                nodes[name].publishes.append({"topic": topic, "type": topic_types[topic], "rate_hz": round(rate, 2)})
    topic_rates = {}
    for (_, topic), rate in publish_rates.items():
        topic_rates[topic] = max(rate, topic_rates.get(topic, 0.0))
    for name, input_topic, period in sorted(set(acks)):
        if name in nodes:
            ack = {"input": input_topic, "period": period}
            if period <= 0:  # a null node publishes on this input's messages: at the rate they come
                ack["rate_hz"] = round(topic_rates.get(input_topic, 0.0), 2)
            nodes[name].acks.append(ack)
    for node in nodes.values():
        node.subscribes.sort(key=lambda s: s["topic"])
        node.publishes.sort(key=lambda p: p["topic"])
    return nodes


def parse_acks(csv_text):
    """[(node, input, period [s])] from ``rostopic echo -p /lockstep_ack``'s CSV lines (header first)."""
    lines = [line for line in csv_text.splitlines() if line.strip()]
    if not lines:
        return []
    header = lines[0].lstrip("%").split(",")
    try:
        node, input_topic, period = (header.index("field." + name) for name in ("node", "input", "period"))
    except ValueError:
        return []
    acks = []
    for line in lines[1:]:
        fields = line.split(",")
        if len(fields) == len(header) and fields[period].isdigit():
            acks.append((fields[node], fields[input_topic], int(fields[period]) / 1e9))  # a Duration in nanoseconds
    return acks


def save(nodes, path):
    with open(path, "w") as stream:
        json.dump({name: dataclasses.asdict(node) for name, node in sorted(nodes.items())}, stream, indent=1)


def load(path):
    """{node: NodeShape} from a topology.json written by save()."""
    try:
        with open(path) as stream:
            raw = json.load(stream)
        return {name: NodeShape(**fields) for name, fields in raw.items()}
    except (OSError, ValueError, TypeError, AttributeError) as err:
        raise ValueError("%s is not a graph topology (bench_loop writes one per run as topology.json): %s"
                         % (path, err))


class AckListener:
    """The lock-step acknowledgements sent in the graph behind ``master_uri`` from now until stop(), heard by
    ``rostopic echo`` (a node of its own: this process may have none, or one of another master)."""

    def __init__(self, master_uri):
        self.process = subprocess.Popen(["rostopic", "echo", "-p", ACK_TOPIC], stdout=subprocess.PIPE,
                                        stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL, text=True,
                                        env=dict(os.environ, ROS_MASTER_URI=master_uri))

    def stop(self, timeout=10.0):
        """[(node, input, period [s])] heard."""
        self.process.send_signal(signal.SIGINT)
        try:
            output, _ = self.process.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.process.kill()
            output, _ = self.process.communicate()
        return parse_acks(output)


def capture(master, uris, first, second, sim_seconds, acks):
    """The topology of the running graph behind ``master`` (a rosgraph.Master): ``uris`` {node: XML-RPC URI} of its
    publishers, ``first`` and ``second`` two census snapshots ``sim_seconds`` apart (bench_loop.BusCensus), ``acks``
    what an AckListener heard."""
    clients = {}
    state = master.getSystemState()
    for node in set(uris) | {n for _, names in state[1] for n in names}:
        if node in NOT_NULLED:
            continue
        try:
            uri = uris.get(node) or master.lookupNode(node)
            clients[node] = client_of(bus_stats.node_api(uri).getBusStats("/bench_loop"))
        except Exception:  # gone: not part of the floor
            pass
    return topology(state, dict(master.getTopicTypes()), clients, publish_rates(first, second, sim_seconds), acks)


def default_messages(types):
    """{type: (md5sum, definition, serialised default message)} of the message ``types``."""
    import io
    import roslib.message
    serialized = {}
    for type_name in sorted(set(types)):
        message_class = roslib.message.get_message_class(type_name)
        if message_class is None:
            raise ValueError("message type %s is not built in this workspace" % type_name)
        buffer = io.BytesIO()
        message_class().serialize(buffer)
        serialized[type_name] = (message_class._md5sum, message_class._full_text, buffer.getvalue())
    return serialized


def null_node_command(node):
    if node.client == "roscpp":
        return ["rosrun", "landing_bench", "null_node_cpp", "__name:=" + node.name.lstrip("/")]
    return [sys.executable, "-m", "landing_bench.null_node", "__name:=" + node.name.lstrip("/")]


def run(nodes, realism="realistic", sim_seconds=30.0, timeout=300.0, vehicle="summit_xl"):
    """The simulator in a floor of ``nodes`` ({} for none), from the release of its physics for ``sim_seconds``
    (rounded up to its statistics' period, 5 s): {"stats": its last /sim_stats, "cpu": {process: CPU s per sim s},
    "published": {(node, topic): messages per sim s of the null nodes, as they published them}, "log": the log
    directory}."""
    import rosgraph
    from landing_eval.isolated_ros import IsolatedLaunch, IsolatedProcess, graph_unconnected
    log_dir = tempfile.mkdtemp(prefix="bench_floor_")
    launch = ["mujoco_sim", "sim.launch", "real_time_factor:=0", "output:=log", "realism:=%s" % realism,
              "vehicle:=%s" % vehicle, "wait_for_start:=true"]
    deadline = time.monotonic() + timeout
    serialized = default_messages(p["type"] for node in nodes.values() for p in node.publishes)
    with IsolatedLaunch(launch, os.path.join(log_dir, "launch.log")) as sim:
        sim.wait_for_master(timeout=min(60.0, timeout))
        master = rosgraph.Master("/bench_floor", master_uri=sim.master_uri)
        for node in nodes.values():
            master.setParam(node.name + "/null_spec", node.null_spec(serialized))
        started = []
        try:
            for node in nodes.values():
                log = os.path.join(log_dir, node.name.strip("/").replace("/", "_") + ".log")
                started.append(IsolatedProcess(null_node_command(node), log, sim.master_uri).__enter__())
            _wait(lambda: _registered(master, nodes) and not graph_unconnected(master), deadline,
                  "the floor's nodes did not all connect", log_dir, started + [sim])
            figures = _fly(sim, master, nodes, sim_seconds, deadline, log_dir, started)
        finally:
            for process in started:
                process.interrupt()
            for process in started:
                process.__exit__(None, None, None)
    return dict(figures, log=log_dir)


def _registered(master, nodes):
    state = master.getSystemState()
    present = {n for kind in state[:2] for _, names in kind for n in names}
    return SIMULATOR in present and all(name in present for name in nodes)


def _wait(condition, deadline, what, log_dir, watched, poll_s=0.05):
    while not condition():
        dead = [p for p in watched if not p.alive()]
        if dead:
            raise RuntimeError("%s: %s exited; see %s" % (what, " ".join(dead[0].command[:3]), log_dir))
        if time.monotonic() > deadline:
            raise TimeoutError("%s before the time limit; see the logs in %s" % (what, log_dir))
        time.sleep(poll_s)


def _fly(sim, master, nodes, sim_seconds, deadline, log_dir, started):
    import rospy
    from std_msgs.msg import Empty, String
    os.environ["ROS_MASTER_URI"] = sim.master_uri
    rospy.init_node("bench_floor", disable_signals=True)
    pids = processes.nodes_below([sim.process.pid] + [p.process.pid for p in started])
    pids.pop("master", None)
    uris = {name: master.lookupNode(name) for name in list(nodes) + [SIMULATOR]}
    clock_hz = master.getParam(SIMULATOR + "/rates/clock_hz")
    end = {}

    def on_stats(message):  # the CPU times when the simulator reports the span's end, not when we get round to it
        stats = json.loads(message.data)
        if not end and stats.get("sim_time", 0.0) >= sim_seconds:
            end.update(stats=stats, usage={name: processes.usage(pid) for name, pid in pids.items()})

    rospy.Subscriber("sim_stats", String, on_stats)
    start = rospy.Publisher("mujoco_sim/start", Empty, queue_size=1, latch=True)
    _wait(lambda: start.get_num_connections() > 0, deadline, "the simulator did not subscribe to its start",
          log_dir, started + [sim])
    usage = {name: processes.usage(pid) for name, pid in pids.items()}
    first = bus_stats.snapshot(uris, "/bench_floor")
    start.publish(Empty())
    _wait(lambda: end, deadline, "the simulator did not reach %.0f s of sim time" % sim_seconds, log_dir,
          started + [sim])
    second = bus_stats.snapshot(uris, "/bench_floor")
    rospy.signal_shutdown("floor measured")
    span = end["stats"]["sim_time"]
    cpu = {name: (end["usage"][name][1] - usage[name][1]) / span for name in pids if usage[name] and end["usage"][name]}
    published = bus_stats.publish_rates(first, second, bus_stats.sim_seconds(second, clock_hz) -
                                        bus_stats.sim_seconds(first, clock_hz))
    networked = set()  # roscpp lists a subscriber in its own process as a connection, but counts none of its messages
    for node in nodes:
        try:
            connections = bus_stats.node_api(uris[node]).getBusInfo("/bench_floor")[-1]
        except (OSError, xmlrpc.client.Error, IndexError, TypeError):  # gone: its rates are missing
            continue
        # Entries: (id, destination, direction, transport, topic, ...); a publisher's are outbound ('o').
        networked |= {(node, c[4]) for c in connections if c[2] in ("o", "b") and c[3] != "INTRAPROCESS"}
    return {"stats": end["stats"], "cpu": cpu,
            "published": {key: published.get(key, 0.0) for key in networked if key[0] in nodes}}


def merge(nodes, names, merged_name):
    """``nodes`` with the nodes ``names`` (or every node, for ["all"]) replaced by one roscpp node ``merged_name``,
    as if they ran in one process (nodelets of one manager): the union of their subscriptions (a topic is received
    once), all their publications (roscpp hands a message to a subscriber of the same process without the
    network), every input they acknowledge and the fastest of their timers. What a change of the graph's shape
    would gain, measured before it is built."""
    names = list(nodes) if list(names) == ["all"] else list(names)
    unknown = [name for name in names if name not in nodes]
    if unknown:
        raise ValueError("no node %s in the topology (it has %s)" % (", ".join(unknown), ", ".join(sorted(nodes))))
    merged = NodeShape(merged_name, "roscpp", [], [], [])
    timers = []
    for name in names:
        node = nodes[name]
        merged.subscribes += [s for s in node.subscribes if s not in merged.subscribes]
        merged.publishes += node.publishes
        merged.acks += [a for a in node.acks if a["period"] <= 0]
        timers += [a for a in node.acks if a["period"] > 0]
    if timers:
        merged.acks.append(min(timers, key=lambda a: a["period"]))
    rest = {name: node for name, node in nodes.items() if name not in names}
    return dict(rest, **{merged_name: merged})


def fidelity(nodes, published, tolerance=0.1):
    """[(node, topic, rate the topology asks for, rate published)] of the publications that missed their rate by
    more than ``tolerance`` (a share) in the floor, of those ``published`` ({(node, topic): rate} of the ones that
    went over the network): the floor then does not carry the graph's messages."""
    misses = []
    for node in nodes.values():
        for publication in node.publishes:
            if (node.name, publication["topic"]) not in published:
                continue
            got = published[(node.name, publication["topic"])]
            if abs(got - publication["rate_hz"]) > tolerance * publication["rate_hz"]:
                misses.append((node.name, publication["topic"], publication["rate_hz"], got))
    return misses


def command(topology, realism, sim_seconds, timeout, merges=()):
    """bench_floor's command line for one floor, its figures as one JSON line (floor_figures reads them)."""
    return ([sys.executable, "-m", "landing_bench.graph_floor", topology, "--json", "--realism", realism,
             "--sim-seconds", str(sim_seconds), "--timeout", str(timeout)] +
            [argument for group in merges for argument in ("--merge", group)])


def floor_figures(process, timeout):
    """The figures a bench_floor --json ``process`` (subprocess.Popen, text pipes) prints; RuntimeError naming why
    there are none (it failed, or did not end within ``timeout`` wall seconds)."""
    try:
        out, err = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        process.kill()
        process.communicate()
        raise RuntimeError("bench_floor did not end within %.0f s" % timeout)
    lines = [line for line in out.splitlines() if line.startswith("{")]
    if process.returncode != 0 or not lines:
        raise RuntimeError((err.strip().splitlines() or ["bench_floor exited with %d" % process.returncode])[-1])
    return json.loads(lines[-1])


def start_floor(floor_command):
    return subprocess.Popen(floor_command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            stdin=subprocess.DEVNULL)


def side_by_side(floor_command, jobs, timeout):
    """The floor alone, then ``jobs`` floors at once (each a bench_floor process of its own: rospy allows one node a
    process); prints each real-time factor and the throughput of the ``jobs`` against the one alone."""
    try:
        alone = floor_figures(start_floor(floor_command), timeout)["real_time_factor"]
        together = [floor_figures(p, timeout)["real_time_factor"]
                    for p in [start_floor(floor_command) for _ in range(jobs)]]
    except RuntimeError as err:
        print("bench_floor: %s" % err, file=sys.stderr)
        return 1
    print("one floor alone: %.2fx real time; %d side by side: %s; throughput %.2fx the one alone" % (
        alone, jobs, ", ".join("%.2fx" % rtf for rtf in together), sum(together) / alone))
    return 0


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("topology", help="topology.json of a bench_loop run (in its run directory)")
    parser.add_argument("--realism", choices=("ideal", "realistic", "harsh"), default="realistic",
                        help="realism profile of the simulated world")
    parser.add_argument("--sim-seconds", type=float, default=30.0, help="span of sim time to run [s]")
    parser.add_argument("--timeout", type=float, default=300.0, help="wall-clock limit [s]")
    parser.add_argument("--merge", action="append", default=[], metavar="NODE,NODE,...|all",
                        help="run these nodes as one roscpp process (what nodelets of one manager would gain); "
                        "may be given more than once")
    parser.add_argument("--jobs", type=int, default=1, help="with 2 or more: the floor alone, then this many floors "
                        "side by side, and their throughput against the one alone (what benchmark --jobs N can gain "
                        "at most with this graph)")
    parser.add_argument("--json", action="store_true", help="print the figures as one JSON line (for bench_loop)")
    args = parser.parse_args(argv)
    if args.jobs < 1:
        print("bench_floor: --jobs must be 1 or more, got %d" % args.jobs, file=sys.stderr)
        return 2
    if args.jobs > 1:
        return side_by_side(command(args.topology, args.realism, args.sim_seconds, args.timeout, args.merge),
                            args.jobs, args.timeout + 120)
    try:
        nodes = load(args.topology)
        for index, group in enumerate(args.merge):
            nodes = merge(nodes, [name for name in group.split(",") if name], "/merged_%d" % (index + 1))
        figures = run(nodes, args.realism, args.sim_seconds, args.timeout)
    except (ValueError, RuntimeError, TimeoutError) as err:
        print("bench_floor: %s" % err, file=sys.stderr)
        return 1
    stats, cpu = figures["stats"], figures["cpu"]
    misses = fidelity(nodes, figures["published"])
    if args.json:
        print(json.dumps({"real_time_factor": stats.get("real_time_factor"), "cpu": cpu, "nodes": len(nodes),
                          "stats": stats, "log": figures["log"], "rate_misses": misses}))
        return 0
    print("floor of %d null nodes beside the simulator (%s): %.2fx real time over %.0f s of sim time" % (
        len(nodes), args.realism, stats.get("real_time_factor", 0.0), stats.get("sim_time", 0.0)))
    print("CPU seconds per sim second: " + ", ".join("%s %.3f" % (name, value) for name, value in
                                                     sorted(cpu.items(), key=lambda item: -item[1])))
    print("all: %.3f" % sum(cpu.values()))
    for node, topic, asked, got in misses:
        print("warning: %s published %s at %.1f per sim s, not %.1f: the floor is not the graph's" % (
            node, topic, got, asked))
    return 0


if __name__ == "__main__":
    sys.exit(main())
