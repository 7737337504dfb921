"""The stack's compute budget as a companion computer would see it: scenarios flown at real time.

    rosrun landing_bench compute_budget scenarios/stress/ardrone2/summit_circle_1ms.yaml [MORE.yaml] --out DIR \
        [--readme README.md]

Each scenario flies, one after the other, with sim time paced at wall time and never held for a lagging node
(run_scenario --real-time), as on the real drone. Prints, and writes to DIR/<set>_<scenario>/compute_budget.json
(with --readme, a column per scenario into the README's budget block):
- the CPU seconds each node of the stack used per second of flight, from /proc over the flight (the simulator, the
  bag recorder, the vehicle's path driver and the ROS master/rosout are listed apart: on the real system they are the
  world, the log and the vehicle, not the drone's companion computer);
- the wall-clock latency from a camera frame's arrival to the first command to the drone it can have caused, p50 and
  p99, and of each step of the chain (landing_bench.frame_latency, measured by landing_bench.latency_probe);
- the real-time factor the flight kept (below 1: this machine could not keep up, and the figures are a loaded
  machine's).
Compare figures only within one machine and its load.
"""
import argparse
import json
import os
import subprocess
import sys

from landing_eval import runner
from landing_eval import scenario as scenario_mod

from .bench_loop import node_cpu_per_sim_second
from .frame_latency import STAGES

# Nodes of a simulated flight that are not the stack a companion computer runs.
NOT_THE_STACK = {"mujoco_sim": "simulator", "flight_recorder": "bag recorder", "summit_moves": "vehicle's path",
                 "master": "ROS master", "rosout": "ROS log"}
# The chain's topics (absolute: the probe's roles are remapped to them), and the drone's command topic per model.
CHAIN_TOPICS = {"image": "/ardrone/bottom/image_raw", "detection": "/platform/current_platform_position_in_ardrone",
                "estimate": "/kalman_platform_odom", "stack_command": "/platform_tracking/cmd_vel"}
DRONE_COMMAND = {"ardrone2": "/cmd_vel", "px4_quad": "/mavros/setpoint_raw/local", "velocity_quad": "/ardrone/cmd_vel"}
README_MARKERS = ("<!-- budget:start -->", "<!-- budget:end -->")


def probe_command(out_path, drone_model):
    if drone_model not in DRONE_COMMAND:
        raise ValueError("compute_budget: no command topic known for drone model %r (known: %s)"
                         % (drone_model, ", ".join(DRONE_COMMAND)))
    topics = dict(CHAIN_TOPICS, drone_command=DRONE_COMMAND[drone_model])
    return ["rosrun", "landing_bench", "latency_probe", "__name:=latency_probe", "_out:=%s" % out_path] + \
        ["%s:=%s" % (role, topic) for role, topic in topics.items()]


def budget(result, latency):
    """The figures of one real-time flight: its result.json and the probe's latency.json (None if it wrote none)."""
    cpu = node_cpu_per_sim_second(result)
    stack = {name: v for name, v in cpu.items() if name not in NOT_THE_STACK}
    return {"scenario": result["name"], "outcome": result["outcome"], "real_time_factor": result["real_time_factor"],
            "cpu_per_flight_s": {name: round(v, 4) for name, v in sorted(stack.items(), key=lambda kv: -kv[1])},
            "cpu_stack_total": round(sum(stack.values()), 4),
            "cpu_not_the_stack": {name: round(v, 4) for name, v in cpu.items() if name in NOT_THE_STACK},
            "latency": latency}


def render(figures):
    lines = ["%s: %s at real-time factor %s" % (figures["scenario"], figures["outcome"], figures["real_time_factor"]),
             "", "CPU per second of flight [s/s] (1.0 = one core busy)"]
    lines += ["  %-24s %6.3f" % (name, v) for name, v in figures["cpu_per_flight_s"].items()]
    lines.append("  %-24s %6.3f" % ("the stack in all", figures["cpu_stack_total"]))
    lines.append("  not the stack: " + ", ".join("%s %.3f (%s)" % (name, v, NOT_THE_STACK[name])
                                                 for name, v in figures["cpu_not_the_stack"].items()))
    latency = figures["latency"]
    if not latency or not latency.get("chains"):
        lines += ["", "frame -> command latency: no complete chain was heard (see latency_probe.log)"]
        return "\n".join(lines)
    lines += ["", "frame -> command latency, wall clock [ms] (%d frames heard, %d with the pad, %d chains)"
              % (latency["frames"], latency["detected"], latency["chains"]),
              "  %-34s %8s %8s" % ("step", "p50", "p99")]
    previous = "frame arrives"
    for stage in STAGES:
        lines.append("  %-34s %8.1f %8.1f" % ("%s -> %s" % (previous, stage), latency[stage]["p50_ms"],
                                              latency[stage]["p99_ms"]))
        previous = stage
    lines.append("  %-34s %8.1f %8.1f" % ("frame arrives -> drone_command", latency["total"]["p50_ms"],
                                          latency["total"]["p99_ms"]))
    return "\n".join(lines)


def table(all_figures):
    """A markdown table of several flights' budgets, a column per flight (the README's: the stack in all, its largest
    node, the simulator for scale, the whole chain's latency; per node and per step: compute_budget.json)."""
    heads = ["%s (%s)" % (f["scenario"], f["drone_model"]) for f in all_figures]

    def largest(f):
        name, value = max(f["cpu_per_flight_s"].items(), key=lambda kv: kv[1], default=("-", None))
        return "-" if value is None else "%.3f (`%s`)" % (value, name)

    def latency(f, stage):
        figures = ((f["latency"] or {}).get(stage) or {})
        return "-" if figures.get("p50_ms") is None else "%.0f / %.0f" % (figures["p50_ms"], figures["p99_ms"])
    rows = [["CPU per flight second, the stack [s/s]"] + ["**%.3f**" % f["cpu_stack_total"] for f in all_figures],
            ["... its largest node"] + [largest(f) for f in all_figures],
            ["... the simulator, for scale"] + ["%.3f" % f["cpu_not_the_stack"].get("mujoco_sim", float("nan"))
                                               for f in all_figures],
            ["frame -> drone command, p50 / p99 [ms]"] + ["**%s**" % latency(f, "total") for f in all_figures],
            ["real-time factor kept, outcome"] + ["%s, %s" % (f["real_time_factor"], f["outcome"])
                                                  for f in all_figures]]
    lines = ["| | " + " | ".join(heads) + " |", "|---" * (len(heads) + 1) + "|"]
    return "\n".join(lines + ["| " + " | ".join(r) + " |" for r in rows])


def fly(scenario_path, out_dir):
    """One scenario at real time with the probe beside it: its figures (budget()), or raises RuntimeError."""
    try:
        model = scenario_mod.load(scenario_path)["drone"]["model"]
        probe = probe_command(os.path.join(os.path.abspath(out_dir), "latency.json"), model)
    except (scenario_mod.ScenarioError, ValueError) as err:
        raise RuntimeError(str(err))
    result = runner.run(scenario_path, out_dir, real_time=True, companions={"latency_probe": probe})
    if result["outcome"] == "aborted":
        raise RuntimeError("%s: the flight aborted: %s (logs in %s)" % (scenario_path, result.get("error"), out_dir))
    try:
        with open(os.path.join(out_dir, "latency.json")) as stream:
            latency = json.load(stream)
    except (OSError, ValueError) as err:
        print("compute_budget: the latency probe left no figures (%s); see %s" % (
            err, os.path.join(out_dir, "latency_probe.log")), file=sys.stderr)
        latency = None
    figures = dict(budget(result, latency), drone_model=model)
    with open(os.path.join(out_dir, "compute_budget.json"), "w") as stream:
        json.dump(figures, stream, indent=1)
    return figures


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenarios", nargs="+",
                        help="scenario YAML files, flown one after the other (e.g. "
                             "scenarios/stress/ardrone2/summit_circle_1ms.yaml scenarios/summit_circle_1ms.yaml)")
    parser.add_argument("--out", required=True, help="output directory: a sub-directory per scenario (the run, "
                                                     "latency.json, compute_budget.json)")
    parser.add_argument("--readme", default=None, help="README whose budget block gets this run's table")
    args = parser.parse_args(argv)
    runner.stop_on_sigterm()
    all_figures = []
    for path in args.scenarios:
        name = os.path.splitext(os.path.basename(path))[0]
        out_dir = os.path.join(args.out, "%s_%s" % (os.path.basename(os.path.dirname(os.path.abspath(path))), name))
        if len(args.scenarios) == 1:
            try:
                figures = fly(path, out_dir)
            except RuntimeError as err:
                print("compute_budget: %s" % err, file=sys.stderr)
                return 3
        else:  # a process each: rospy joins one master per process, and every flight has a master of its own
            try:  # (bounded: the run's own wall limits, and a minute more)
                bound = runner.wall_limits(scenario_mod.load(path)["time_limit_s"])["total"] + 60.0
                status = subprocess.call([sys.executable, "-m", "landing_bench.compute_budget", path, "--out", args.out],
                                         stdout=subprocess.DEVNULL, timeout=bound)
            except scenario_mod.ScenarioError as err:
                print("compute_budget: %s" % err, file=sys.stderr)
                return 2
            except subprocess.TimeoutExpired:
                status = "killed after %.0f s" % bound
            try:
                with open(os.path.join(out_dir, "compute_budget.json")) as stream:
                    figures = json.load(stream)
            except (OSError, ValueError):
                print("compute_budget: %s left no figures (exit %s); see %s" % (path, status, out_dir),
                      file=sys.stderr)
                return 3
        print(render(figures) + "\n")
        all_figures.append(figures)
    if args.readme:
        from landing_eval.benchmark import provenance, update_readme
        import datetime
        import platform
        commit, command = provenance("rosrun landing_bench compute_budget")
        heading = "%s at commit `%s` (%s, %d cores): `%s`" % (
            datetime.date.today().isoformat(), commit, platform.machine(), os.cpu_count(), command)
        update_readme(args.readme, heading, table(all_figures), markers=README_MARKERS)
        print("compute_budget: the table is in %s" % args.readme)
    return 0


if __name__ == "__main__":
    sys.exit(main())
