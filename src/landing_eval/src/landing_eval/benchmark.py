"""benchmark: many scenarios in parallel (each run_scenario under its own master), a progress bar,
results.csv and summary.md with success rates and error statistics grouped by vehicle, path and speed.

A scenario whose file is bad, whose run fails or whose `expect:` block is not met is counted as such,
never as a success."""
import argparse
import json
import math
import os
import shlex
import signal
import subprocess
import sys
import time

from . import run_pool
from .runner import wall_limits
from . import scenario as scenario_mod
from .results_store import CSV_FIELDS, ResultsFile, ResultsFileError  # noqa: F401 (CSV_FIELDS: the columns)


def collect(paths):
    """Scenario files from files, directories (sorted, *.yaml / *.yml) and lists (*.txt: a scenario file a line,
    relative to the list; blank lines and # comments skipped)."""
    found = []
    for path in paths:
        if os.path.isdir(path):
            found += sorted(os.path.join(path, f) for f in os.listdir(path) if f.endswith((".yaml", ".yml")))
        elif path.endswith(".txt"):
            with open(path) as stream:
                lines = (line.split("#", 1)[0].strip() for line in stream)
                found += [os.path.join(os.path.dirname(path), line) for line in lines if line]
        else:
            found.append(path)
    return found


def speed_band(vehicle, speed):
    if vehicle == "car":
        return "car <= 10 m/s" if speed <= 10 else "car > 10 m/s"
    return "summit <= 1 m/s" if speed <= 1.0 else "summit 1-3 m/s"


def check_expectations(expect, result):
    """(passed, why-not) of a run against the scenario's `expect:` block. With no block, a landing on
    the pad is what is expected."""
    outcome = result.get("outcome")
    wanted = expect.get("outcome", "landed_on_pad")
    wanted = wanted if isinstance(wanted, list) else [wanted]
    problems = []
    if outcome not in wanted:
        problems.append("outcome %s, expected %s" % (outcome, " or ".join(wanted)))
    limit = expect.get("max_touchdown_error_m")
    error = result.get("touchdown_error_m")
    if limit is not None and error is not None and error > limit:
        problems.append("touchdown error %.3f m > %.3f m" % (error, limit))
    decisions = result.get("decisions") or []
    for needed in expect.get("decisions_include", []) or []:
        if not any(all(d.get(k) == v for k, v in needed.items()) for d in decisions):
            problems.append("no decision matching %s" % json.dumps(needed, sort_keys=True))
    if expect.get("no_pad_landing") and outcome == "landed_on_pad":
        problems.append("landed on the pad although a no-go condition held")
    if expect.get("emergency_position_within_m") is not None:
        position, truth = result.get("emergency_position"), (result.get("touchdown") or {}).get("position")
        if position is None or truth is None:
            problems.append("no emergency position reported")
        elif math.hypot(position[0] - truth[0], position[1] - truth[1]) > expect["emergency_position_within_m"]:
            problems.append("emergency position %.2f m from the landing point" % math.hypot(
                position[0] - truth[0], position[1] - truth[1]))
    needed = expect.get("min_missions_on_pad")
    if needed is not None and (result.get("missions_on_pad") or 0) < needed:
        problems.append("%s of %d missions on the pad, expected at least %d" % (
            result.get("missions_on_pad") or 0, len(result.get("missions") or []), needed))
    if expect.get("no_node_deaths"):
        killed = {fault.get("name") for fault in result.get("faults") or []}
        deaths = [d for d in result.get("node_deaths") or [] if d.get("node") not in killed]
        if deaths:
            problems.append("node(s) died: %s" % ", ".join("%s (exit code %s)" % (d["node"], d["exit_code"])
                                                          for d in deaths))
    errors = result.get("callback_errors") or {}
    if errors:  # a node lived on past an exception, and lost what its callback was doing: a bug, whatever the outcome
        problems.append("exception(s) in callbacks: %s" % ", ".join(
            "%s %d times (%s)" % (node, e["count"], e["first"].strip().splitlines()[-1])
            for node, e in sorted(errors.items())))
    return not problems, "; ".join(problems)


def plan(files, repeat, out_root, realism=None):
    """(runs to make, rows of files that cannot be run). A run is a spec for run_pool.execute_run plus its
    row's scenario fields; with ``repeat`` > 1 each scenario is run that often (run 1, 2, ...). ``realism``
    (a profile name, or a list of them) replaces the profile every scenario asks for; with more than one,
    each scenario runs in each, named NAME@PROFILE."""
    profiles = realism if isinstance(realism, (list, tuple)) else [realism]
    specs, bad = [], []
    for profile in profiles:
        suffix = "@%s" % profile if len(profiles) > 1 else ""
        more_specs, more_bad = _plan_profile(files, repeat, out_root, profile, suffix)
        specs += more_specs
        bad += more_bad
    return specs, bad


def _plan_profile(files, repeat, out_root, realism, suffix):
    specs, bad, names = [], [], {}
    for path in files:
        name = os.path.splitext(os.path.basename(path))[0] + suffix
        try:
            s = scenario_mod.load(path, realism)
            with open(path) as stream:
                text = stream.read()
        except (scenario_mod.ScenarioError, OSError) as err:
            bad += [{"file": path, "name": name, "run": run, "passed": False, "outcome": "error", "error": str(err),
                     "decisions": 0} for run in range(1, repeat + 1)]
            continue
        if s["name"] in names:
            raise ValueError("%s and %s both name their scenario %r: their runs would overwrite each other's output"
                             % (names[s["name"]], path, s["name"]))
        names[s["name"]] = path
        row = {"file": path, "name": s["name"] + suffix, "vehicle": s["platform"]["vehicle"], "path": s["platform"]["path"],
               "speed_mps": s["platform"]["speed_mps"], "wind_speed": s["conditions"]["wind_speed"],
               "realism": s["realism"]["profile"], "expected": json.dumps(s["expect"].get("outcome", "landed_on_pad")),
               "passed": False}
        for run in range(1, repeat + 1):
            label = s["name"] + suffix if run == 1 else "%s%s.run%d" % (s["name"], suffix, run)
            specs.append({"python": sys.executable, "file": os.path.abspath(path), "scenario_text": text,
                          "out_dir": os.path.abspath(os.path.join(out_root, label)),
                          "log": os.path.abspath(os.path.join(out_root, label + ".log")),
                          "wall_timeout": wall_limits(s["time_limit_s"])["flight"], "realism": realism,
                          "row": dict(row, run=run), "expect": s["expect"]})
    return specs, bad


def row_of(spec, outcome):
    """The results row of a finished run (errors included: a run that failed is never a success)."""
    row = dict(spec["row"], node=outcome.get("node"))
    result = outcome.get("result")
    if result is None:
        row.update(outcome="error", error=outcome.get("failure") or "no result")
        return row
    passed, why = check_expectations(spec["expect"], result)
    row.update({k: result.get(k) for k in ("outcome", "touchdown_error_m", "time_to_land_s", "sim_time_s",
                                           "wall_time_s", "real_time_factor", "emergency_position")})
    row["decisions"] = len(result.get("decisions") or [])
    # An aborted run carries its reason as the error: it passes only where the scenario expects it to abort.
    row["passed"] = passed and (not result.get("error") or result.get("outcome") == "aborted")
    row["error"] = result.get("error") or why
    return row


def percentile(values, q):
    values = sorted(values)
    if not values:
        return None
    index = (len(values) - 1) * q
    low, high = int(math.floor(index)), int(math.ceil(index))
    return values[low] + (values[high] - values[low]) * (index - low)


def summarize(rows, groups=("realism", "vehicle", "path", "band")):
    """Markdown summary: totals, then one table per grouping."""
    for row in rows:
        row["band"] = speed_band(row.get("vehicle"), row.get("speed_mps") or 0.0) if row.get("vehicle") else "-"

    def stats(subset):
        errors = [r["touchdown_error_m"] for r in subset if r.get("touchdown_error_m") is not None]
        times = [r["time_to_land_s"] for r in subset if r.get("time_to_land_s") is not None]
        rtf = [r["real_time_factor"] for r in subset if r.get("real_time_factor")]
        fmt = lambda v: "-" if v is None else "%.3f" % v  # noqa: E731
        return ["%d/%d" % (sum(r["passed"] for r in subset), len(subset)),
                "%d" % sum(r.get("outcome") == "landed_on_pad" for r in subset),
                fmt(sum(errors) / len(errors) if errors else None), fmt(percentile(errors, 0.95)),
                fmt(max(errors) if errors else None),
                "-" if not times else "%.1f" % percentile(times, 0.5),
                "%d" % sum(r.get("decisions") or 0 for r in subset),
                "-" if not rtf else "%.1f" % (sum(rtf) / len(rtf)),
                "%d" % sum(r.get("outcome") == "error" for r in subset)]
    header = ["group", "passed", "on pad", "error mean [m]", "error p95 [m]", "error max [m]", "time to land median [s]",
              "decisions", "RTF", "errors"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines.append("| **all** | " + " | ".join(stats(rows)) + " |")
    for key in groups:
        for value in sorted({str(r.get(key)) for r in rows}):
            subset = [r for r in rows if str(r.get(key)) == value]
            lines.append("| %s = %s | " % (key, value) + " | ".join(stats(subset)) + " |")
    misses = [r for r in rows if not r["passed"]]
    if misses:
        lines += ["", "Misses (every scenario that did not meet its expectation):", ""]
        lines += ["- `%s`: %s%s" % (r["name"], r.get("outcome"), " (%s)" % r["error"] if r.get("error") else "")
                  for r in misses]
    return "\n".join(lines)


def spread(rows):
    """Markdown table of the scenarios run more than once: outcomes and the spread of the error and the
    time to land over the runs (the closed loop is not bit-for-bit repeatable). Empty if none was."""
    by_name = {}
    for row in rows:
        by_name.setdefault(row["name"], []).append(row)
    repeated = {name: runs for name, runs in sorted(by_name.items()) if len(runs) > 1}
    if not repeated:
        return ""
    fmt = lambda v: "-" if v is None else "%.3f" % v  # noqa: E731
    lines = ["| scenario | runs | passed | outcomes | error min [m] | error mean [m] | error max [m] | error std [m] | "
             "time to land min-max [s] |", "|" + "---|" * 9]
    for name, runs in repeated.items():
        outcomes = {}
        for r in runs:
            outcomes[r.get("outcome")] = outcomes.get(r.get("outcome"), 0) + 1
        errors = [r["touchdown_error_m"] for r in runs if r.get("touchdown_error_m") is not None]
        times = [r["time_to_land_s"] for r in runs if r.get("time_to_land_s") is not None]
        mean = sum(errors) / len(errors) if errors else None
        std = math.sqrt(sum((e - mean) ** 2 for e in errors) / (len(errors) - 1)) if len(errors) > 1 else None
        lines.append("| %s | %d | %d | %s | %s | %s | %s | %s | %s |" % (
            name, len(runs), sum(r["passed"] for r in runs),
            ", ".join("%s x%d" % (o, n) for o, n in sorted(outcomes.items(), key=lambda i: str(i[0]))),
            fmt(min(errors) if errors else None), fmt(mean), fmt(max(errors) if errors else None), fmt(std),
            "-" if not times else "%.1f-%.1f" % (min(times), max(times))))
    return "\n".join(lines)


def provenance(command_name="rosrun landing_eval benchmark"):
    """(commit, command line) of this run: the short hash of the workspace's HEAD, '-dirty' with
    uncommitted changes to tracked files; the command as typed."""
    here = os.path.dirname(os.path.abspath(__file__))
    try:
        commit = subprocess.run(["git", "-C", here, "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                                timeout=30).stdout.strip() or "unknown"
        dirty = subprocess.run(["git", "-C", here, "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=30).stdout.strip()
    except (OSError, subprocess.TimeoutExpired):
        commit, dirty = "unknown", ""
    command = command_name + " " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    return commit + ("-dirty" if dirty else ""), command


def describe(rows, sources, elapsed, executor, resumed):
    """The line that heads a sweep's table: what ran, where, when, on which commit, with which command."""
    import platform
    commit, command = provenance()
    runs = "%d runs of %d scenarios" % (len(rows), len({r["name"] for r in rows})) \
        if len(rows) != len({r["name"] for r in rows}) else "%d scenarios" % len(rows)
    return "%s of %s on %s at commit `%s` (%s, %d cores, %s), %.0f min wall%s:\n`%s`" % (
        runs, ", ".join("`%s`" % s for s in sources), time.strftime("%Y-%m-%d"), commit, platform.machine(),
        os.cpu_count(), executor, elapsed / 60.0, " in this invocation (%d rows were kept from before)" % resumed
        if resumed else "", command)


def write_summary(rows, out_dir, heading):
    summary = summarize(rows)
    repeats = spread(rows)
    text = summary + ("\n\nSpread over the repeated runs:\n\n" + repeats if repeats else "")
    with open(os.path.join(out_dir, "summary.md"), "w") as stream:
        stream.write("# Benchmark summary\n\n%s\n\n%s\n" % (heading, text))
    return text


README_START, README_END = "<!-- bench:start -->", "<!-- bench:end -->"


def update_readme(readme, heading, text, markers=(README_START, README_END)):
    """Replace the block between the ``markers`` (the bench markers by default) of ``readme`` with this run's table."""
    start, end = markers
    with open(readme) as stream:
        content = stream.read()
    if start not in content or end not in content:
        raise ValueError("%s has no %s ... %s block to replace" % (readme, start, end))
    head, rest = content.split(start, 1)
    with open(readme, "w") as stream:
        stream.write("%s%s\n%s\n\n%s\n%s%s" % (head, start, heading, text, end, rest.split(end, 1)[1]))


def _interrupt_on_sigterm():
    def handler(signum, _frame):
        raise KeyboardInterrupt("signal %s" % signal.Signals(signum).name)
    signal.signal(signal.SIGTERM, handler)


def main(argv=None):
    parser = argparse.ArgumentParser(
        description="Run many landing scenarios (local processes or Ray tasks) and summarise them: results.csv "
                    "(a row per run, written as it finishes) and summary.md in --out.")
    parser.add_argument("scenarios", nargs="+", help="scenario files or directories of them (not searched recursively)")
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument("--jobs", type=int, default=2, help="runs at once on this machine (each has its own master)")
    parser.add_argument("--ray", metavar="auto|ADDRESS", default=None,
                        help="run each scenario as a task on a Ray cluster instead: 'auto' for the cluster this "
                             "machine belongs to, or the head's HOST:PORT; every node needs the workspace built at "
                             "this path")
    parser.add_argument("--cpus-per-scenario", type=float, default=1.0,
                        help="CPUs a Ray task reserves (default 1): Ray runs as many at once on a node as it has CPUs")
    parser.add_argument("--warm", action="store_true",
                        help="keep each job's graph between its runs and reset it (docs/warm_graph.md) instead of "
                             "starting one per run; a run that needs other nodes gets a graph of its own")
    parser.add_argument("--repeat", type=int, default=1, help="run each scenario this often and report the spread")
    parser.add_argument("--resume", action="store_true",
                        help="keep the rows of --out/results.csv and run only the runs it does not have yet")
    parser.add_argument("--wall-timeout", type=float, default=None,
                        help="wall-clock limit of one flight [s] (default: 4 x its time limit, at least 300 s)")
    parser.add_argument("--readme", default=None, help="README whose bench block gets this run's table")
    parser.add_argument("--realism", default=None, metavar="PROFILE[,PROFILE...]",
                        help="realism profile of every run (default: each scenario's, else realistic; the "
                             "scenario's single-key overrides still apply); several, comma-separated: each "
                             "scenario runs in each (NAME@PROFILE), side by side in the summary")
    args = parser.parse_args(argv)
    profiles = args.realism.split(",") if args.realism else [None]
    unknown = [p for p in profiles if p not in ("ideal", "realistic", "harsh")] if args.realism else []
    if unknown:
        parser.error("--realism: unknown profile(s) %s (ideal, realistic, harsh)" % ", ".join(unknown))
    if args.warm and args.ray:
        parser.error("--warm runs on this machine only; leave out --ray or --warm")
    if args.repeat < 1 or args.jobs < 1 or args.cpus_per_scenario <= 0:
        parser.error("--repeat and --jobs must be >= 1 and --cpus-per-scenario > 0")
    files = collect(args.scenarios)
    if not files:
        print("benchmark: no scenario files in %s" % " ".join(args.scenarios), file=sys.stderr)
        return 2
    os.makedirs(args.out, exist_ok=True)
    try:
        specs, bad = plan(files, args.repeat, args.out, profiles)
        results = ResultsFile(os.path.join(args.out, "results.csv"), resume=args.resume)
    except (ValueError, ResultsFileError) as err:
        print("benchmark: %s" % err, file=sys.stderr)
        return 2
    if args.wall_timeout:
        for spec in specs:
            spec["wall_timeout"] = args.wall_timeout
    kept = len(results.rows)
    for row in bad:
        results.append(row)
    todo = [spec for spec in specs if (spec["row"]["name"], spec["row"]["run"]) not in results.done]
    if args.resume:
        print("benchmark: %d runs already in %s, %d to run" % (kept, results.path, len(todo)))
    _interrupt_on_sigterm()
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
    start = time.monotonic()
    executor = "Ray cluster %s, %g CPU a run" % (args.ray, args.cpus_per_scenario) if args.ray else \
        "--jobs %d%s" % (args.jobs, ", warm graphs" if args.warm else "")
    # a run's longest wall time: with nothing finished for twice that, the cluster is taken as gone
    idle_timeout = 2 * max([s["wall_timeout"] + run_pool.START_STOP_MARGIN_S for s in todo] or [0])
    if args.ray:
        runs = run_pool.ray_runs(todo, args.ray, args.cpus_per_scenario, idle_timeout)
    elif args.warm:
        runs = run_pool.warm_local_runs(todo, args.jobs, os.path.join(args.out, "graphs"))
    else:
        runs = run_pool.local_runs(todo, args.jobs)
    try:
        with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                      transient=False) as progress:
            task = progress.add_task("scenarios", total=len(files) * args.repeat * len(profiles),
                                     completed=len(results.rows))
            for spec, outcome in runs:
                if outcome.get("interrupted"):
                    progress.console.print("%s was interrupted from outside: not counted (--resume runs it "
                                           "again)" % spec["row"]["name"])
                    continue
                row = row_of(spec, outcome)
                if results.append(row):
                    progress.update(task, advance=1, description="%s: %s" % (row["name"], row.get("outcome")))
    except KeyboardInterrupt:
        runs.close()
        results.close()
        print("benchmark: interrupted; %d of %d runs are in %s: --resume runs the rest"
              % (len(results.rows), len(files) * args.repeat * len(profiles), results.path), file=sys.stderr)
        return 130
    except (ConnectionError, TimeoutError) as err:
        results.close()
        print("benchmark: %s; %d runs are in %s: --resume runs the rest" % (err, len(results.rows), results.path),
              file=sys.stderr)
        return 3
    results.close()
    rows = sorted(results.rows, key=lambda r: (r["name"], r["run"]))
    heading = describe(rows, args.scenarios, time.monotonic() - start, executor, kept if args.resume else 0)
    text = write_summary(rows, args.out, heading)
    if args.readme:
        update_readme(args.readme, heading, text)
    print(text)
    print("results: %s, %s" % (results.path, os.path.join(args.out, "summary.md")))
    return 0 if all(r["passed"] for r in rows) else 1
