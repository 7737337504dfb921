"""How fast the closed loop runs against the simulator alone, per realism profile, and where the CPU goes.

    rosrun landing_bench bench_loop scenarios/summit_circle_1ms.yaml --out DIR [--profiles ideal,realistic,harsh] [--repeat N]

For each profile, one after the other on this machine: the simulator alone at full speed with a camera
subscriber (`bench_sim`), then the whole landing graph on the scenario (`run_scenario`), which samples the
CPU time of each of its nodes from /proc and notes the graph's topology in flight (topology.json); then the scenario
three times on one warm graph as `benchmark --warm` flies a sweep, each after the first on the reset graph; then the
graph floor (`bench_floor` of that topology: the simulator beside null nodes that only exchange the graph's messages,
the most this graph's transport allows). Prints each real-time factor, their ratios, the fixed per-scenario
overhead (start-up and shut-down, from result.json's wall_phases_s) of a fresh graph and of a reset one, and
the CPU seconds per sim second of each node (on a loaded machine this moves less than the wall-clock
figures); with --profile, py-spy's hottest functions of each Python node. Compare profiles only within one
run of this command (machines and their load differ).
"""
import argparse
import collections
import json
import os
import re
import statistics
import subprocess
import sys
import threading
import time

from landing_eval import processes

from . import bus_stats

PROFILES = ("ideal", "realistic", "harsh")


def node_cpu_per_sim_second(result):
    """{node: CPU seconds per sim second} over the flight, from result.json's resource samples (taken in the run's
    own process tree: other runs on the machine, with the same node names, are not counted)."""
    samples = (result.get("resources") or {}).get("samples") or []
    if len(samples) < 2 or samples[-1]["sim_s"] <= samples[0]["sim_s"]:
        return {}
    first, last = samples[0], samples[-1]
    sim = last["sim_s"] - first["sim_s"]
    return {name: (node["cpu_s"] - first["nodes"][name]["cpu_s"]) / sim for name, node in last["nodes"].items()
            if name in first["nodes"] and first["nodes"][name]["pid"] == node["pid"]}


def cpu_bound(cpu_per_sim_second, loop_rtf, cores):
    """(how many of the ``cores`` the graph kept busy in flight, the real-time factor its CPU per sim second
    allows at most on them with perfect overlap), or (None, None) without the figures. When the first comes
    close to ``cores`` the loop is bound by its CPU, not by waits: only less CPU makes it faster."""
    total = sum(cpu_per_sim_second.values())
    if total <= 0.0 or not loop_rtf:
        return None, None
    return total * loop_rtf, cores / total


def parallel_gain_bound(busy, cores):
    """The most ``cores`` runs side by side (benchmark --jobs) can gain in throughput over one at a time, when one
    run keeps ``busy`` cores busy: only the cores it leaves idle can take more work [x]."""
    return min(float(cores), cores / busy)


def simulator_stats(bag):
    """The simulator's own accounting at the end of the closed-loop run: the last /sim_stats in the bag, or {}."""
    try:
        import rosbag
        with rosbag.Bag(bag) as recorded:
            last = None
            for _, msg, _ in recorded.read_messages(topics=["/sim_stats"]):
                last = msg
        return json.loads(last.data) if last is not None else {}
    except Exception:  # no bag, or no stats in it: the figures are only missing
        return {}


def simulator_shares(stats):
    """The shares of the simulator's wall time spent in physics, rendering, publishing and waiting for the graph
    (lock-step), from its /sim_stats."""
    return {k[:-len("_share")]: v for k, v in stats.items() if k.endswith("_share")}


STEPPING_CPU = ("physics", "publish", "stepping", "process")


def stepping_cpu(stats):
    """CPU seconds per sim second of the simulator's stepping thread in physics, in publishing, in all, and of its
    whole process, from its /sim_stats ({} from a simulator that does not report them)."""
    return {k: stats["cpu_%s_per_sim_s" % k] for k in STEPPING_CPU if "cpu_%s_per_sim_s" % k in stats}


class Profiler:
    """py-spy on every Python node of one run (found below the run's process by its ``__name:=``), from the
    moment it appears until it exits; each node's samples as collapsed stacks in DIR/profile/NODE.txt."""

    def __init__(self, root_pid, out_dir, rate_hz=100):
        self.root_pid, self.dir, self.rate_hz = root_pid, os.path.join(out_dir, "profile"), rate_hz
        self.spies, self.running = {}, True
        self.py_spy = os.path.join(os.path.dirname(sys.executable), "py-spy")
        self.thread = threading.Thread(target=self._attach, daemon=True)

    def start(self):
        if not os.path.isfile(self.py_spy):
            print("bench_loop: %s is missing (make build installs it): no profile" % self.py_spy, file=sys.stderr)
            return self
        os.makedirs(self.dir, exist_ok=True)
        self.thread.start()
        return self

    def _attach(self):
        while self.running:
            for name, pid in processes.nodes_below([self.root_pid]).items():
                if name not in self.spies and _is_python(pid):
                    self.spies[name] = subprocess.Popen(
                        [self.py_spy, "record", "--pid", str(pid), "--rate", str(self.rate_hz), "--format", "raw",
                         "--output", os.path.join(self.dir, name.strip("/") + ".txt")],
                        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL)
            time.sleep(0.2)

    def stop(self, timeout=30.0):
        """Waits for the profiles to be written (py-spy writes when its process ends)."""
        self.running = False
        if self.thread.is_alive():
            self.thread.join(timeout=5.0)
        for spy in self.spies.values():
            try:
                spy.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                spy.kill()
                spy.wait()
        return hot_functions(self.dir) if self.spies else {}


def _is_python(pid):
    return os.path.basename((processes.command_line(pid) or [""])[0]).startswith("python")


def hot_functions(profile_dir, top=8):
    """{node: [(share of its samples, function (file:line)), ...]} by own time (the innermost frame), busiest
    first; idle frames (waits, sleeps, select) are counted as idle, not as functions."""
    hot = {}
    for entry in sorted(os.listdir(profile_dir)):
        own, total = collections.Counter(), 0
        with open(os.path.join(profile_dir, entry)) as stream:
            for line in stream:
                stack, _, count = line.rstrip().rpartition(" ")
                if not count.isdigit() or not stack.strip():  # (a sample py-spy could not read)
                    continue
                frame = stack.split(";")[-1]
                total += int(count)
                own["(idle)" if IDLE.search(frame) else frame] += int(count)
        hot[entry[:-4]] = [(n / total, frame) for frame, n in own.most_common(top)] if total else []
    return hot


# Frames of a thread that waits (py-spy samples a thread blocked in a system call as active): rospy's receiving
# threads wait in recv_buff, its servers in socket.accept.
IDLE = re.compile(r"^(wait|_wait_for_tstate_lock|sleep|select|poll|accept|recv_into|readinto|recv|recv_buff|_recv_loop|"
                  r"spin|epoll|socket\.accept|SocketIO\.readinto)\b|threading.py|selectors.py|socket.py.*\breadinto")


class BusCensus:
    """How many messages the run's graph delivers per sim second, topic by topic: every node's own counts (the
    getBusStats every rospy and roscpp node answers over XML-RPC), read when the simulator's /clock has run
    ``after_sim_s`` and again ``span_sim_s`` later (in flight for a scenario such as summit_circle_1ms); the sim
    seconds from the /clock messages the simulator sent to each subscriber. With ``topology_path``, the graph's
    topology is written there too (landing_bench.graph_floor: what bench_floor builds its null graph of)."""

    def __init__(self, root_pid, after_sim_s=6.0, span_sim_s=6.0, timeout_s=600.0, topology_path=None):
        self.root_pid, self.after_sim_s, self.span_sim_s = root_pid, after_sim_s, span_sim_s
        self.timeout_s, self.topology_path = timeout_s, topology_path
        self.rows, self.error = [], None
        self.running = True
        self.thread = threading.Thread(target=self._run, daemon=True)

    def start(self):
        self.thread.start()
        return self

    def _snapshot_at(self, uris, clock_hz, sim_s, deadline):
        """A snapshot once the simulator's clock has reached ``sim_s``, or None when the run ends first."""
        while self.running and time.monotonic() < deadline:
            snapshot = bus_stats.snapshot(uris)
            if bus_stats.SIMULATOR not in snapshot:
                return None
            if bus_stats.sim_seconds(snapshot, clock_hz) >= sim_s:
                return snapshot
            time.sleep(0.1)
        return None

    def _run(self):
        try:
            import rosgraph
            deadline = time.monotonic() + self.timeout_s
            master = simulator = None
            while simulator is None and self.running and time.monotonic() < deadline:
                nodes = processes.nodes_below([self.root_pid])
                command = processes.command_line(nodes["master"]) if "master" in nodes else []
                port = command[command.index("-p") + 1] if "-p" in command[:-1] else None
                if port is not None:
                    master = rosgraph.Master("/bench_loop", master_uri="http://127.0.0.1:%s/" % port)
                    try:
                        clock_hz = master.getParam("/mujoco_sim/rates/clock_hz")
                        simulator = master.lookupNode(bus_stats.SIMULATOR)
                    except Exception:  # not up yet
                        pass
                time.sleep(0.2)
            if simulator is None:
                self.error = "no simulator found at a master below the run"
                return
            from . import graph_floor
            # The lock-step acknowledgements are heard before the census (the listener's own connections would
            # count in it).
            acks = graph_floor.AckListener(master.master_uri) if self.topology_path else None
            try:
                first = self._snapshot_at({bus_stats.SIMULATOR: simulator}, clock_hz, self.after_sim_s, deadline)
            finally:
                heard = acks.stop() if acks else []
            publishers = master.getSystemState()[0]
            uris = {node: master.lookupNode(node) for node in {n for _, names in publishers for n in names}}
            first = first and bus_stats.snapshot(uris)
            second = first and self._snapshot_at(
                uris, clock_hz, bus_stats.sim_seconds(first, clock_hz) + self.span_sim_s, deadline)
            if not second:
                self.error = "the flight ended before %.0f s of sim time" % (self.after_sim_s + self.span_sim_s)
                return
            sim_seconds = bus_stats.sim_seconds(second, clock_hz) - bus_stats.sim_seconds(first, clock_hz)
            self.rows = bus_stats.deliveries_per_sim_second(first, second, sim_seconds)
            if self.topology_path and not heard:
                self.error = "no lock-step acknowledgement heard in flight: no topology for the graph floor"
            elif self.topology_path:
                graph_floor.save(graph_floor.capture(master, uris, first, second, sim_seconds, heard),
                                 self.topology_path)
        except Exception as err:  # the census is a diagnostic: the benchmark goes on without it
            self.error = "%s: %s" % (type(err).__name__, err)

    def stop(self, timeout=30.0):
        self.running = False
        self.thread.join(timeout)
        return {"rows": self.rows, "error": self.error}


def measure_warm(scenario, out, profile, timeout, runs=3):
    """The scenario flown ``runs`` times by one warm worker (run_pool.WarmWorker) as in a warm sweep: the first on a
    fresh graph, each next one on the same graph after its reset, started while the previous run's recorder stops.
    Returns the last run's figures (as measure's), the first's start-up, and what the sweep spent between the last
    two flights (from the release of the one before to the release of the last, less the flight)."""
    from landing_eval.run_pool import WarmWorker
    warm_dir = os.path.join(out, "warm")
    worker = WarmWorker(sys.executable, warm_dir)
    specs = [{"python": sys.executable, "file": scenario, "out_dir": os.path.join(warm_dir, "run_%d" % index),
              "realism": profile, "log": os.path.join(warm_dir, "worker.log"), "wall_timeout": timeout}
             for index in range(1, runs + 1)]
    try:
        outcomes = worker.run_all(specs)
    finally:
        worker.close()
    missing = {"error": "the warm worker did not fly it; see %s" % os.path.join(warm_dir, "worker.log")}
    results = [((outcome or {}).get("result") or missing) for outcome in outcomes]
    first, before, last = results[0], results[-2], results[-1]
    between = None
    try:
        between = last["graph"]["released_at_s"] - before["graph"]["released_at_s"] - before["wall_phases_s"]["flight"]
    except (KeyError, TypeError):
        pass
    return {"loop_rtf": last.get("real_time_factor"), "outcome": last.get("outcome"),
            "phases": last.get("wall_phases_s", {}), "steps": last.get("wall_steps_s", {}),
            "reset": (last.get("graph") or {}).get("warm"), "error": last.get("error"),
            "first_start_up": first.get("wall_phases_s", {}).get("start_up"), "between_flights": between}


def measure_floor(topology, profile, sim_seconds, timeout):
    """bench_floor of the ``topology`` a closed-loop run noted: {"rtf", "cpu" {process: CPU s per sim s}, "misses"
    (publications off their rate), "error"}."""
    from . import graph_floor
    if not os.path.isfile(topology):
        return {"error": "no topology of the graph was noted in flight"}
    try:
        figures = graph_floor.floor_figures(graph_floor.start_floor(
            graph_floor.command(topology, profile, sim_seconds, timeout)), timeout + 60)
    except RuntimeError as err:
        return {"error": str(err)}
    return {"rtf": figures["real_time_factor"], "cpu": figures["cpu"], "misses": figures["rate_misses"],
            "error": None}


def measure(scenario, out, profile, sim_seconds, timeout, py_spy=False, warm=True, label=None, floor=True):
    sim = subprocess.run(["rosrun", "landing_bench", "bench_sim", "--json", "--realism", profile,
                          "--sim-seconds", str(sim_seconds), "--timeout", str(timeout)],
                         capture_output=True, text=True, timeout=timeout + 60, stdin=subprocess.DEVNULL)
    lines = [line for line in sim.stdout.splitlines() if line.startswith("{")]
    alone = json.loads(lines[-1]) if lines else {}
    label = label or profile
    run_dir = os.path.join(out, label.replace(" #", "_"))
    os.makedirs(run_dir, exist_ok=True)
    with open(os.path.join(run_dir, "run_scenario.log"), "w") as log:
        loop = subprocess.Popen(["rosrun", "landing_eval", "run_scenario", scenario, "--out", run_dir, "--realism",
                                 profile, "--wall-timeout", str(timeout)], stdout=log, stderr=subprocess.STDOUT,
                                stdin=subprocess.DEVNULL)
        profiler = Profiler(loop.pid, run_dir).start() if py_spy else None
        census = BusCensus(loop.pid, timeout_s=timeout, topology_path=os.path.join(run_dir, "topology.json")).start()
        try:
            loop.wait(timeout=timeout + 300)
        except subprocess.TimeoutExpired:
            loop.kill()
            loop.wait()
        hot = profiler.stop() if profiler else {}
        deliveries = census.stop()
    try:
        with open(os.path.join(run_dir, "result.json")) as stream:
            result = json.load(stream)
    except (OSError, ValueError):
        result = {"error": "no result.json; see %s" % os.path.join(run_dir, "run_scenario.log")}
    stats = simulator_stats(result.get("bag") or "")
    return {"profile": profile, "label": label, "sim_alone_rtf": alone.get("real_time_factor"), "render_share": alone.get("render_share"),
            "sim_alone_cpu": stepping_cpu(alone), "sim_loop_cpu": stepping_cpu(stats), "deliveries": deliveries,
            "loop_rtf": result.get("real_time_factor"), "outcome": result.get("outcome"),
            "phases": result.get("wall_phases_s", {}), "cpu": node_cpu_per_sim_second(result), "hot": hot,
            "steps": result.get("wall_steps_s", {}), "simulator": simulator_shares(stats),
            "error": result.get("error"), "warm": measure_warm(scenario, run_dir, profile, timeout) if warm else None,
            "floor": measure_floor(os.path.join(run_dir, "topology.json"), profile, sim_seconds, timeout)
            if floor else None}



def _ratio(a, b):
    return a / b if a and b else None


def report(rows):
    print("| profile | simulator alone RTF | graph floor RTF | closed loop RTF | floor / alone | loop / alone | "
          "loop / floor | start-up [s] | shut-down [s] | outcome |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        floor = (r.get("floor") or {}).get("rtf")
        print("| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
            r["label"], _f(r["sim_alone_rtf"]), _f(floor), _f(r["loop_rtf"]), _f(_ratio(floor, r["sim_alone_rtf"])),
            _f(_ratio(r["loop_rtf"], r["sim_alone_rtf"])), _f(_ratio(r["loop_rtf"], floor)),
            _f(r["phases"].get("start_up")), _f(r["phases"].get("shut_down")), r["outcome"]))
    print("(graph floor: the simulator beside null nodes that exchange the graph's messages and do no work, "
          "bench_floor: the most this graph's transport allows)")
    for r in rows:
        floor = r.get("floor") or {}
        if floor.get("error"):
            print("(no graph floor, %s: %s)" % (r["label"], floor["error"]))
        for node, topic, asked, got in floor.get("misses") or []:
            print("warning: graph floor, %s: %s published %s at %.1f per sim s, not %.1f" % (
                r["label"], node, topic, got, asked))
    for r in rows:
        w = r.get("warm")
        if w:
            floor = (r.get("floor") or {}).get("rtf")
            print("| %s, graph reset%s | | | %s | | %s | %s | %s | %s | %s |" % (
                r["label"], "" if w["reset"] else " (NOT: fresh)", _f(w["loop_rtf"]),
                _f(_ratio(w["loop_rtf"], r["sim_alone_rtf"])), _f(_ratio(w["loop_rtf"], floor)),
                _f(w["phases"].get("start_up")), _f(w["phases"].get("shut_down")), w["outcome"]))
    for r in rows:
        w = r.get("warm")
        fresh = _overhead(r["phases"])
        if w and fresh is not None and _overhead(w["phases"]) is not None:
            print("per-scenario overhead (start-up + shut-down), %s: fresh graph %.2f s, reset graph %.2f s (%.0f %% "
                  "less); in a warm sweep, between two flights (the recorder of one stopping beside the reset for the "
                  "next): %s s; the warm graph's own start-up, once per job: %s s" % (
                      r["label"], fresh, _overhead(w["phases"]), 100 * (1 - _overhead(w["phases"]) / fresh),
                      _f(w["between_flights"]), _f(w["first_start_up"])))
        if w and w.get("steps"):
            print("start-up and shut-down steps after a reset, %s (wall s from the start): %s" % (
                r["label"], ", ".join("%s %.2f" % (k, v) for k, v in w["steps"].items()
                                        if k not in ("flight", "clock_runs"))))
    for r in rows:
        if r.get("simulator"):
            print("simulator's wall time in the closed loop, %s: %s" % (r["label"], ", ".join(
                "%s %.0f %%" % (k, 100 * v) for k, v in r["simulator"].items())))
        alone, loop = r.get("sim_alone_cpu") or {}, r.get("sim_loop_cpu") or {}
        if all(k in alone and k in loop for k in STEPPING_CPU):
            print("simulator's CPU s per sim s, %s, alone -> in the closed loop: stepping thread %s (physics %s, "
                  "publishing %s), whole process %s; the graph's subscribers and acknowledgements cost it %s" % (
                      r["label"], _change(alone, loop, "stepping", 3), _change(alone, loop, "physics", 3),
                      _change(alone, loop, "publish", 3), _change(alone, loop, "process", 3),
                      _f(loop["process"] - alone["process"], 3)))
        if r.get("steps"):
            print("start-up and shut-down steps, %s (wall s from the start): %s" % (r["label"], ", ".join(
                "%s %.2f" % (k, v) for k, v in r["steps"].items() if k not in ("flight", "clock_runs"))))
    medians = {}
    for profile in dict.fromkeys(r["profile"] for r in rows):
        floors = sorted(_ratio((r.get("floor") or {}).get("rtf"), r["sim_alone_rtf"]) or 0.0 for r in rows
                        if r["profile"] == profile)
        if len(floors) > 1 and all(floors):
            print("%s, %d interleaved runs: floor / alone median %.2f (%.2f-%.2f)" % (
                profile, len(floors), statistics.median(floors), floors[0], floors[-1]))
        ratios = sorted(r["loop_rtf"] / r["sim_alone_rtf"] for r in rows
                        if r["profile"] == profile and r["loop_rtf"] and r["sim_alone_rtf"])
        loops = sorted(r["loop_rtf"] for r in rows if r["profile"] == profile and r["loop_rtf"])
        if loops:
            medians[profile] = statistics.median(loops)
        if len(ratios) > 1:
            print("%s, %d interleaved pairs: loop / alone median %.2f (%.2f-%.2f), closed loop RTF median %.2f "
                  "(%.2f-%.2f)" % (profile, len(ratios), statistics.median(ratios), ratios[0], ratios[-1],
                                   medians[profile], loops[0], loops[-1]))
    for profile, median in medians.items():
        if profile != "ideal" and "ideal" in medians:
            print("closed loop RTF %s / ideal: %.2f (the realism's cost: %.0f %% of the ideal loop's speed)" % (
                profile, median / medians["ideal"], 100 * (1 - median / medians["ideal"])))
    print("\nCPU seconds per sim second per node over the flight (this run's processes only):")
    names = sorted({n for r in rows for n in r["cpu"]}, key=lambda n: -max(r["cpu"].get(n, 0) for r in rows))
    print("| node | " + " | ".join(r["label"] for r in rows) + " |")
    print("|---|" + "---|" * len(rows))
    for name in names:
        print("| %s | %s |" % (name, " | ".join(_f(r["cpu"].get(name), 3) for r in rows)))
    print("| all | %s |" % " | ".join(_f(sum(r["cpu"].values()) if r["cpu"] else None, 3) for r in rows))
    floors = [r for r in rows if (r.get("floor") or {}).get("cpu")]
    if floors:
        print("\nthe same in the graph floor (null nodes: the messages' transport alone; the drone on its pad, as in the "
              "simulator-alone run):")
        names = sorted({n for r in floors for n in r["floor"]["cpu"]}, key=lambda n: -max(
            r["floor"]["cpu"].get(n, 0) for r in floors))
        print("| node | " + " | ".join(r["label"] for r in floors) + " |")
        print("|---|" + "---|" * len(floors))
        for name in names:
            print("| %s | %s |" % (name, " | ".join(_f(r["floor"]["cpu"].get(name), 3) for r in floors)))
        print("| all | %s |" % " | ".join(_f(sum(r["floor"]["cpu"].values()), 3) for r in floors))
    for r in rows:
        census = r.get("deliveries") or {}
        if census.get("rows"):
            total = sum(row[0] for row in census["rows"])
            print("\nmessages delivered per sim second in flight, %s: %.0f in all, %.0f of them by the simulator; the "
                  "busiest topics:" % (r["label"], total, sum(row[0] for row in census["rows"] if row[2] == "/mujoco_sim")))
            print("| topic | publisher | connections | per sim s |")
            print("|---|---|---|---|")
            for rate, topic, node, connections in census["rows"][:15]:
                print("| %s | %s | %d | %.0f |" % (topic, node, connections, rate))
        elif census.get("error"):
            print("(no census of the messages, %s: %s)" % (r["label"], census["error"]))
    cores = len(os.sched_getaffinity(0))
    for r in rows:
        busy, ceiling = cpu_bound(r["cpu"], r["loop_rtf"], cores)
        if busy is not None:
            print("%s: the graph kept %.2f of %d cores busy in flight; its CPU allows at most %.1fx here, and %d runs "
                  "side by side (benchmark --jobs %d) at most %.2fx the throughput of one at a time" % (
                      r["label"], busy, cores, ceiling, cores, cores, parallel_gain_bound(busy, cores)))
    for r in rows:
        for node, functions in sorted(r.get("hot", {}).items()):
            print("\npy-spy, %s, %s: own time by function (share of samples)" % (r["label"], node))
            for share, frame in functions:
                print("  %5.1f %%  %s" % (100 * share, frame))


def _overhead(phases):
    if phases.get("start_up") is None or phases.get("shut_down") is None:
        return None
    return phases["start_up"] + phases["shut_down"]


def _change(before, after, key, digits):
    return "%s -> %s" % (_f(before.get(key), digits), _f(after.get(key), digits))


def _f(value, digits=2):
    return "-" if value is None else "%.*f" % (digits, value)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenario", help="scenario YAML file")
    parser.add_argument("--out", required=True, help="output directory (a run directory per profile)")
    parser.add_argument("--profiles", default="ideal,realistic", help="comma-separated realism profiles")
    parser.add_argument("--sim-seconds", type=float, default=60.0, help="sim time of the simulator-alone run [s]")
    parser.add_argument("--timeout", type=float, default=900.0, help="wall-clock limit of each run [s]")
    parser.add_argument("--no-warm", action="store_true", help="skip the runs on a warm graph")
    parser.add_argument("--no-floor", action="store_true", help="skip the graph floor (bench_floor of the topology "
                        "noted in flight)")
    parser.add_argument("--repeat", type=int, default=1, help="measure each profile this many times, the profiles "
                        "taking turns (alone, loop, alone, loop, ...), and print the medians: the machine's speed "
                        "drifts from one minute to the next")
    parser.add_argument("--profile", action="store_true", help="sample every Python node of the closed loop with "
                        "py-spy (slows the run: its RTF is not comparable) and print each one's hottest functions")
    args = parser.parse_args(argv)
    profiles = [p for p in args.profiles.split(",") if p]
    unknown = [p for p in profiles if p not in PROFILES]
    if unknown:
        print("bench_loop: unknown profile(s) %s (known: %s)" % (", ".join(unknown), ", ".join(PROFILES)), file=sys.stderr)
        return 2
    if args.repeat < 1:
        print("bench_loop: --repeat must be 1 or more, got %d" % args.repeat, file=sys.stderr)
        return 2
    os.makedirs(args.out, exist_ok=True)
    rows = [measure(args.scenario, args.out, p, args.sim_seconds, args.timeout, args.profile, not args.no_warm,
                    label=p if args.repeat == 1 else "%s #%d" % (p, k + 1), floor=not args.no_floor)
            for k in range(args.repeat) for p in profiles]
    with open(os.path.join(args.out, "bench_loop.json"), "w") as stream:
        json.dump(rows, stream, indent=2)
    report(rows)
    return 0 if all(r["loop_rtf"] and (not r["warm"] or r["warm"]["loop_rtf"]) for r in rows) else 1
