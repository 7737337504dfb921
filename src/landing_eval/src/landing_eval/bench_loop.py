"""How fast the closed loop runs against the simulator alone, per realism profile, and where the CPU goes.

    rosrun landing_eval bench_loop scenarios/summit_circle_1ms.yaml --out DIR [--profiles ideal,realistic,harsh]

For each profile, one after the other on this machine: the simulator alone at full speed with a camera
subscriber (`bench_sim`), then the whole landing graph on the scenario (`run_scenario`), while the CPU
time of every node is sampled from /proc. Prints each real-time factor, their ratio, the fixed
per-scenario overhead (start-up and shut-down, from result.json's wall_phases_s) and the CPU per node;
compare profiles only within one run of this command (machines and their load differ).
"""
import argparse
import json
import os
import subprocess
import sys
import threading
import time

PROFILES = ("ideal", "realistic", "harsh")


class NodeCpu(threading.Thread):
    """Samples the CPU time of every ROS node process (a `__name:=` argument) until stopped; keeps the last."""

    def __init__(self, period=0.5):
        super().__init__(daemon=True)
        self.period, self.cpu, self.running = period, {}, True

    def run(self):
        while self.running:
            for pid in os.listdir("/proc"):
                if not pid.isdigit():
                    continue
                try:
                    with open("/proc/%s/cmdline" % pid, "rb") as stream:
                        args = stream.read().split(b"\0")
                    with open("/proc/%s/stat" % pid) as stream:
                        fields = stream.read().rsplit(")", 1)[1].split()
                except OSError:
                    continue
                name = next((a[8:].decode() for a in args if a.startswith(b"__name:=")), None)
                if name:
                    self.cpu[name] = (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
            time.sleep(self.period)

    def stop(self):
        self.running = False
        self.join(timeout=5.0)


def measure(scenario, out, profile, sim_seconds, timeout):
    sim = subprocess.run(["rosrun", "landing_eval", "bench_sim", "--json", "--realism", profile,
                          "--sim-seconds", str(sim_seconds), "--timeout", str(timeout)],
                         capture_output=True, text=True, timeout=timeout + 60, stdin=subprocess.DEVNULL)
    lines = [line for line in sim.stdout.splitlines() if line.startswith("{")]
    alone = json.loads(lines[-1]) if lines else {}
    sampler = NodeCpu()
    sampler.start()
    run_dir = os.path.join(out, profile)
    loop = subprocess.run(["rosrun", "landing_eval", "run_scenario", scenario, "--out", run_dir, "--realism", profile,
                           "--wall-timeout", str(timeout)], capture_output=True, text=True, timeout=timeout + 120,
                          stdin=subprocess.DEVNULL)
    sampler.stop()
    try:
        with open(os.path.join(run_dir, "result.json")) as stream:
            result = json.load(stream)
    except (OSError, ValueError):
        result = {"error": (loop.stdout + loop.stderr)[-500:]}
    return {"profile": profile, "sim_alone_rtf": alone.get("real_time_factor"), "render_share": alone.get("render_share"),
            "loop_rtf": result.get("real_time_factor"), "outcome": result.get("outcome"),
            "phases": result.get("wall_phases_s", {}), "cpu": sampler.cpu, "error": result.get("error")}


def report(rows):
    print("| profile | simulator alone RTF | closed loop RTF | loop / alone | start-up [s] | shut-down [s] | outcome |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        ratio = r["loop_rtf"] / r["sim_alone_rtf"] if r["loop_rtf"] and r["sim_alone_rtf"] else None
        print("| %s | %s | %s | %s | %s | %s | %s |" % (
            r["profile"], _f(r["sim_alone_rtf"]), _f(r["loop_rtf"]), _f(ratio), _f(r["phases"].get("start_up")),
            _f(r["phases"].get("shut_down")), r["outcome"]))
    base = next((r for r in rows if r["profile"] == "ideal" and r["loop_rtf"]), None)
    for r in rows:
        if base and r is not base and r["loop_rtf"]:
            print("closed loop RTF %s / ideal: %.2f (the realism's cost: %.0f %% of the ideal loop's speed)" % (
                r["profile"], r["loop_rtf"] / base["loop_rtf"], 100 * (1 - r["loop_rtf"] / base["loop_rtf"])))
    print("\nCPU seconds per node over the closed-loop run:")
    names = sorted({n for r in rows for n in r["cpu"]}, key=lambda n: -max(r["cpu"].get(n, 0) for r in rows))
    print("| node | " + " | ".join(r["profile"] for r in rows) + " |")
    print("|---|" + "---|" * len(rows))
    for name in names:
        print("| %s | %s |" % (name, " | ".join(_f(r["cpu"].get(name)) for r in rows)))


def _f(value):
    return "-" if value is None else "%.2f" % value


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenario", help="scenario YAML file")
    parser.add_argument("--out", required=True, help="output directory (a run directory per profile)")
    parser.add_argument("--profiles", default="ideal,realistic", help="comma-separated realism profiles")
    parser.add_argument("--sim-seconds", type=float, default=60.0, help="sim time of the simulator-alone run [s]")
    parser.add_argument("--timeout", type=float, default=900.0, help="wall-clock limit of each run [s]")
    args = parser.parse_args(argv)
    profiles = [p for p in args.profiles.split(",") if p]
    unknown = [p for p in profiles if p not in PROFILES]
    if unknown:
        print("bench_loop: unknown profile(s) %s (known: %s)" % (", ".join(unknown), ", ".join(PROFILES)), file=sys.stderr)
        return 2
    os.makedirs(args.out, exist_ok=True)
    rows = [measure(args.scenario, args.out, p, args.sim_seconds, args.timeout) for p in profiles]
    with open(os.path.join(args.out, "bench_loop.json"), "w") as stream:
        json.dump(rows, stream, indent=2)
    report(rows)
    return 0 if all(r["loop_rtf"] for r in rows) else 1
