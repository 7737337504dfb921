"""The reliability figures (docs/reliability.md): each command runs its scenarios with run_scenario, prints a
table and writes it as Markdown (and JSON) into --out.

    rosrun landing_eval soak --out DIR            # 30 missions in one session: outcomes, per-node memory and CPU
    rosrun landing_eval fuzz --out DIR            # 10 min of garbage on every input: deaths, outcomes, rejections
    rosrun landing_eval crash_table --out DIR     # every node killed mid-flight: outcome, time to publishing again

Each exits non-zero when its target is missed (a mission off the pad or a node's memory growing 10 % or more;
a node death or an unsafe outcome under garbage; a crash scenario missing its expected outcome)."""
import argparse
import glob
import json
import os
import statistics
import sys
import time

import yaml

from . import benchmark
from . import recorders
from . import run_pool
from . import runner
from . import scenario as scenario_mod

WORKSPACE = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", ".."))
SCENARIOS = os.path.join(WORKSPACE, "scenarios")
MEMORY_GROWTH_TARGET_PCT = 10.0
UNSAFE = ("crashed", "landed_off_pad")
CRASHES_START, CRASHES_END = "<!-- crashes:start -->", "<!-- crashes:end -->"


def _scenario_copy(path, out_dir, change):
    """The scenario at ``path`` with ``change(data)`` applied, written into ``out_dir`` (the run's own record)."""
    with open(path) as stream:
        data = yaml.safe_load(stream)
    change(data)
    os.makedirs(out_dir, exist_ok=True)
    copy = os.path.join(out_dir, "scenario.yaml")
    with open(copy, "w") as stream:
        yaml.safe_dump(data, stream, sort_keys=False)
    return copy


def _run(command, path, out_dir, **kwargs):
    """runner.run(path, out_dir, **kwargs), stopped by SIGTERM as by Ctrl-C: (result, interrupted). An interrupted
    run still wrote its result.json (the missions flown so far): its report is written too."""
    runner.stop_on_sigterm()
    try:
        return runner.run(path, out_dir, **kwargs), False
    except KeyboardInterrupt as err:
        try:
            with open(os.path.join(out_dir, "result.json")) as stream:
                result = json.load(stream)
        except (OSError, ValueError):
            raise err from None
        print("%s: interrupted (%s); the report covers what was flown" % (command, err or "Ctrl-C"), file=sys.stderr)
        return result, True


def _fmt(value, pattern="%.3f"):
    return "-" if value is None else pattern % value


def _write(out_dir, name, text, data):
    with open(os.path.join(out_dir, name + ".md"), "w") as stream:
        stream.write(text + "\n")
    with open(os.path.join(out_dir, name + ".json"), "w") as stream:
        json.dump(data, stream, indent=1)


def resource_table(result):
    rows = result.get("resources", {}).get("table", {})
    lines = ["| node | RSS start [MB] | RSS end [MB] | growth | CPU start [% of a core] | CPU end [% of a core] |",
             "|---|---|---|---|---|---|"]
    for node, row in sorted(rows.items()):
        lines.append("| %s | %s | %s | %s | %s | %s |" % (
            node, _fmt(row["rss_start_mb"], "%.1f"), _fmt(row["rss_end_mb"], "%.1f"),
            _fmt(row["rss_growth_pct"], "%+.1f %%"), _fmt(row["cpu_start_pct"], "%.1f"),
            _fmt(row["cpu_end_pct"], "%.1f")))
    return "\n".join(lines)


def deaths(result):
    killed = {fault.get("name") for fault in result.get("faults") or []}
    return [d for d in result.get("node_deaths") or [] if d["node"] not in killed]


# ----- soak -------------------------------------------------------------------------------------------
def soak_report(result):
    missions = result.get("missions") or []
    lines = ["| mission | conditions set | battery swapped | outcome | touchdown error [m] | take-off to touchdown [s] |",
             "|---|---|---|---|---|---|"]
    for m in missions:
        conditions = ", ".join("%s %g" % (k, v) for k, v in sorted((m.get("conditions") or {}).items())
                               if k != "drone_battery") or "-"
        lines.append("| %d | %s | %s | %s | %s | %s |" % (m["mission"], conditions, "yes" if m.get("battery_swapped") else
                                                          "no", m["outcome"], _fmt(m.get("touchdown_error_m")),
                                                          _fmt(m.get("time_to_land_s"), "%.1f")))
    on_pad = sum(m["outcome"] == "landed_on_pad" for m in missions)
    errors = [m["touchdown_error_m"] for m in missions if m.get("touchdown_error_m") is not None]
    table = result.get("resources", {}).get("table", {})
    growth = [row["rss_growth_pct"] for row in table.values() if row["rss_growth_pct"] is not None]
    samples = result.get("resources", {}).get("samples", [])
    head = ("%d of %d missions on the pad (%d planned) in %.0f s of sim time (%.0f s wall); touchdown error mean "
            "%s m, max %s m; memory growth of the nodes from the end of mission 1 to the end: at most %s; "
            "node deaths: %d" % (on_pad, len(missions), result.get("missions_planned", len(missions)),
                                 result.get("sim_time_s") or 0.0, result.get("wall_time_s") or 0.0,
                                 _fmt(statistics.mean(errors) if errors else None),
                                 _fmt(max(errors) if errors else None), _fmt(max(growth) if growth else None, "%+.1f %%"),
                                 len(deaths(result))))
    cold = ""
    if len(samples) > 1:
        first, last = samples[0]["nodes"], samples[-1]["nodes"]
        cold = "\n\nFrom the release of the physics (before mission 1) to the end: " + ", ".join(
            "%s %.1f -> %.1f MB" % (n, first[n]["rss_mb"], last[n]["rss_mb"]) for n in sorted(first) if n in last)
    return "%s\n\n%s\n\n%s%s" % (head, "\n".join(lines), resource_table(result), cold)


def soak_main(argv=None):
    parser = argparse.ArgumentParser(description="Missions in a row in one session: per mission outcome and error, "
                                                 "per node memory (RSS) and CPU at the start and the end.")
    parser.add_argument("--scenario", default=os.path.join(SCENARIOS, "reliability", "soak_30_missions.yaml"),
                        help="scenario with a missions: block (default: %(default)s)")
    parser.add_argument("--missions", type=int, default=None, help="missions in a row (default: the scenario's)")
    parser.add_argument("--out", required=True, help="output directory (result.json, bag, soak.md, soak.json)")
    parser.add_argument("--realism", choices=("ideal", "realistic", "harsh"), default=None,
                        help="realism profile (default: the scenario's)")
    parser.add_argument("--bag-split-s", type=float, default=None,
                        help="a new bag every this many seconds of sim time (default: %d for a run over %.0f s, "
                             "else one bag)" % (recorders.RECORDER_SPLIT_S, recorders.LONG_RUN_S))
    args = parser.parse_args(argv)

    def change(data):
        if args.missions:
            data["missions"]["count"] = args.missions
            pause = data["missions"].get("pause_s", 10.0)
            data["time_limit_s"] = min(86400.0, max(data["time_limit_s"] * args.missions / 30.0,
                                                    args.missions * (pause + 90.0)))
    try:
        path = _scenario_copy(args.scenario, args.out, change)
        result, interrupted = _run("soak", path, args.out, realism=args.realism, split_s=args.bag_split_s)
    except (scenario_mod.ScenarioError, OSError, KeyError) as err:
        print("soak: %s" % err, file=sys.stderr)
        return 2
    result["missions_planned"] = scenario_mod.load(path)["missions"]["count"]
    text = soak_report(result)
    _write(args.out, "soak", text, {k: result.get(k) for k in ("missions", "resources", "node_deaths", "sim_time_s",
                                                                 "wall_time_s", "outcome", "error")})
    print(text)
    table = result.get("resources", {}).get("table", {})
    met = result.get("missions_on_pad", 0) == result["missions_planned"] and not deaths(result) and all(
        row["rss_growth_pct"] is not None and row["rss_growth_pct"] < MEMORY_GROWTH_TARGET_PCT for row in table.values())
    return 130 if interrupted else 0 if met else 1


# ----- fuzz -------------------------------------------------------------------------------------------
def fuzz_report(result):
    fuzz = result.get("fuzz") or {}
    missions = result.get("missions") or []
    outcomes = {}
    for m in missions:
        outcomes[m["outcome"]] = outcomes.get(m["outcome"], 0) + 1
    unsafe = [m for m in missions if m["outcome"] in UNSAFE]
    kinds = {}
    for info in fuzz.get("topics", {}).values():
        for kind, n in info["sent"].items():
            kinds[kind] = kinds.get(kind, 0) + n
    head = ("%.0f s of sim time under garbage (%d messages on %d topics, %d bursts at 10x); node deaths: %d; "
            "missions: %s; unsafe outcomes: %d; rejection lines logged: %d, of them not throttled: %d" % (
                fuzz.get("sim_time_fuzzed_s", 0.0), fuzz.get("messages_sent", 0), len(fuzz.get("topics", {})),
                len(fuzz.get("bursts", [])), len(deaths(result)),
                ", ".join("%d %s" % (n, o) for o, n in sorted(outcomes.items())) or "none",
                len(unsafe), fuzz.get("warning_lines", 0), len(fuzz.get("unthrottled", []))))
    lines = ["| topic | garbage sent | rejections logged by | subscribers that never logged one |", "|---|---|---|---|"]
    for topic, info in sorted(fuzz.get("topics", {}).items()):
        lines.append("| `%s` | %d | %s | %s |" % (topic, sum(info["sent"].values()),
                                                 ", ".join(info["rejected_by"]) or "-",
                                                 ", ".join(info["never_rejected_by"]) or "-"))
    sent = ", ".join("%s %d" % (k, n) for k, n in sorted(kinds.items(), key=lambda kv: -kv[1]))
    skipped = "; ".join("`%s` (%s)" % (t, why) for t, why in sorted(fuzz.get("skipped", {}).items()))
    return "%s\n\nGarbage by kind: %s.\n\nNot fuzzed: %s.\n\n%s" % (head, sent, skipped, "\n".join(lines))


def fuzz_main(argv=None):
    parser = argparse.ArgumentParser(description="Seeded garbage on every input topic of a flying graph while "
                                                 "missions go on: node deaths, outcomes, rejections logged.")
    parser.add_argument("--scenario", default=os.path.join(SCENARIOS, "reliability", "fuzz_10_minutes.yaml"),
                        help="scenario with a fuzz: block (default: %(default)s)")
    parser.add_argument("--minutes", type=float, default=None, help="sim minutes of garbage (default: the scenario's)")
    parser.add_argument("--seed", type=int, default=None, help="seed of the garbage (default: the scenario's)")
    parser.add_argument("--out", required=True, help="output directory (result.json, bag, fuzz.md, fuzz.json)")
    args = parser.parse_args(argv)

    def change(data):
        if args.minutes:
            data["fuzz"]["duration_s"] = args.minutes * 60.0
            data["time_limit_s"] = data["fuzz"]["start_s"] + args.minutes * 60.0
        if args.seed is not None:
            data["fuzz"]["seed"] = args.seed
    try:
        result, interrupted = _run("fuzz", _scenario_copy(args.scenario, args.out, change), args.out)
    except (scenario_mod.ScenarioError, OSError, KeyError) as err:
        print("fuzz: %s" % err, file=sys.stderr)
        return 2
    text = fuzz_report(result)
    _write(args.out, "fuzz_report", text, {k: result.get(k) for k in ("fuzz", "missions", "node_deaths", "outcome",
                                                                        "sim_time_s", "error")})
    print(text)
    unsafe = [m for m in result.get("missions") or [] if m["outcome"] in UNSAFE]
    return 130 if interrupted else 0 if not deaths(result) and not unsafe and result["outcome"] != "aborted" else 1


# ----- crash table ------------------------------------------------------------------------------------
def crash_rows(outcomes):
    """Per crash scenario (in file order): node, what happens, outcomes, expected, passed, mean recovery times."""
    rows = {}
    for spec, outcome in outcomes:
        result = outcome.get("result") or {}
        name = spec["row"]["name"]
        row = rows.setdefault(name, {"scenario": name, "node": None, "what": spec["description"],
                                     "expected": spec["expect"].get("outcome", "landed_on_pad"), "outcomes": [],
                                     "passed": 0, "runs": 0, "recovered_s": [], "recovered_wall_s": [],
                                     "not_recovered": 0})
        row["runs"] += 1
        row["outcomes"].append(result.get("outcome", "error"))
        passed, _ = benchmark.check_expectations(spec["expect"], result) if result else (False, "")
        row["passed"] += passed and (not result.get("error") or result.get("outcome") == "aborted")
        for fault in result.get("faults") or []:
            row["node"] = fault["name"]
            if fault.get("recovered_after_s") is not None:
                row["recovered_s"].append(fault["recovered_after_s"])
                row["recovered_wall_s"].append(fault["recovered_after_wall_s"])
            else:
                row["not_recovered"] += 1
        if row["node"] is None:
            row["node"] = next((e["name"] for e in spec.get("events", []) if e.get("fault") == "kill_node"), "?")
    return list(rows.values())


def crash_table(rows):
    lines = ["| node killed (SIGKILL at t = 12 s) | what happens | outcome (expected) | runs as expected | kill to "
             "publishing again: sim s (wall s), mean |", "|---|---|---|---|---|"]
    for row in rows:
        outcomes = ", ".join(sorted(set(row["outcomes"])))
        if row["recovered_s"]:
            back = "%.1f (%.1f)" % (statistics.mean(row["recovered_s"]), statistics.mean(row["recovered_wall_s"]))
            back += "; %d runs not back" % row["not_recovered"] if row["not_recovered"] else ""
        else:
            back = "not restarted"
        lines.append("| `%s` | %s | %s (%s) | %d/%d | %s |" % (row["node"], row["what"], outcomes,
                                                              " or ".join(row["expected"]) if isinstance(
                                                                  row["expected"], list) else row["expected"],
                                                              row["passed"], row["runs"], back))
    return "\n".join(lines)


def crashes_main(argv=None):
    parser = argparse.ArgumentParser(description="Kill every node of the graph mid-flight (scenarios/fault_*_killed"
                                                 ".yaml): the outcome of each and the time until it publishes again.")
    parser.add_argument("scenarios", nargs="*", help="crash scenarios (default: scenarios/fault_*_killed.yaml)")
    parser.add_argument("--out", required=True, help="output directory (a directory per run, crashes.md/.json)")
    parser.add_argument("--repeat", type=int, default=1, help="runs of each scenario (the times are their mean)")
    parser.add_argument("--jobs", type=int, default=1, help="runs at once (1 keeps the timings undisturbed)")
    parser.add_argument("--readme", default=None, help="README whose crashes block gets this table")
    args = parser.parse_args(argv)
    files = args.scenarios or sorted(glob.glob(os.path.join(SCENARIOS, "fault_*_killed.yaml")))
    os.makedirs(args.out, exist_ok=True)
    try:
        specs, bad = benchmark.plan(files, args.repeat, args.out)
    except ValueError as err:
        print("crash_table: %s" % err, file=sys.stderr)
        return 2
    if bad:
        print("crash_table: %s" % "; ".join(row["error"] for row in bad), file=sys.stderr)
        return 2
    for spec in specs:
        s = scenario_mod.load(spec["file"])
        spec["description"], spec["events"] = s["description"], s["events"]
    outcomes = []
    for spec, outcome in run_pool.local_runs(specs, args.jobs):
        outcomes.append((spec, outcome))
        result = outcome.get("result") or {}
        print("%s: %s%s" % (spec["row"]["name"], result.get("outcome", "error"),
                            "" if not (result.get("error") or outcome.get("failure")) else
                            " (%s)" % (result.get("error") or outcome.get("failure"))), flush=True)
    order = {path: i for i, path in enumerate(os.path.abspath(f) for f in files)}
    outcomes.sort(key=lambda item: (order.get(item[0]["file"], 0), item[0]["row"]["run"]))
    rows = crash_rows(outcomes)
    text = crash_table(rows)
    commit, _ = benchmark.provenance()
    heading = "Measured on %s at commit `%s` (%d cores) with `rosrun landing_eval crash_table --out DIR --repeat %d`." % (
        time.strftime("%Y-%m-%d"), commit, os.cpu_count(), args.repeat)
    _write(args.out, "crashes", heading + "\n\n" + text, rows)
    if args.readme:
        with open(args.readme) as stream:
            content = stream.read()
        if CRASHES_START not in content or CRASHES_END not in content:
            print("crash_table: %s has no %s ... %s block" % (args.readme, CRASHES_START, CRASHES_END), file=sys.stderr)
            return 2
        head, rest = content.split(CRASHES_START, 1)
        with open(args.readme, "w") as stream:
            stream.write("%s%s\n%s\n\n%s\n%s%s" % (head, CRASHES_START, heading, text, CRASHES_END,
                                                   rest.split(CRASHES_END, 1)[1]))
    print(heading + "\n\n" + text)
    return 0 if all(row["passed"] == row["runs"] for row in rows) else 1
