"""benchmark: many scenarios in parallel (each run_scenario under its own master), a progress bar,
results.csv and summary.md with success rates and error statistics grouped by vehicle, path and speed.

A scenario whose file is bad, whose run fails or whose `expect:` block is not met is counted as such,
never as a success."""
import argparse
import concurrent.futures
import csv
import json
import math
import os
import subprocess
import sys
import time

from . import scenario as scenario_mod

CSV_FIELDS = ("name", "file", "vehicle", "path", "speed_mps", "wind_speed", "outcome", "expected", "passed",
              "touchdown_error_m", "time_to_land_s", "decisions", "emergency_position", "sim_time_s", "wall_time_s",
              "real_time_factor", "error")


def collect(paths):
    """Scenario files from files and directories (sorted, *.yaml / *.yml)."""
    found = []
    for path in paths:
        if os.path.isdir(path):
            found += sorted(os.path.join(path, f) for f in os.listdir(path) if f.endswith((".yaml", ".yml")))
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
    return not problems, "; ".join(problems)


def run_one(path, out_root, wall_timeout):
    """Run one scenario in a subprocess; always returns a row (errors included)."""
    row = {"file": path, "name": os.path.splitext(os.path.basename(path))[0], "passed": False}
    try:
        s = scenario_mod.load(path)
    except scenario_mod.ScenarioError as err:
        row.update(outcome="error", error=str(err))
        return row
    row.update(name=s["name"], vehicle=s["platform"]["vehicle"], path=s["platform"]["path"],
               speed_mps=s["platform"]["speed_mps"], wind_speed=s["conditions"]["wind_speed"],
               expected=json.dumps(s["expect"].get("outcome", "landed_on_pad")))
    out_dir = os.path.join(out_root, s["name"])
    command = [sys.executable, "-m", "landing_eval.runner_cli", path, "--out", out_dir]
    if wall_timeout:
        command += ["--wall-timeout", str(wall_timeout)]
    with open(os.path.join(out_root, s["name"] + ".log"), "w") as log:
        proc = subprocess.run(command, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
    result_file = os.path.join(out_dir, "result.json")
    if proc.returncode != 0 or not os.path.isfile(result_file):
        row.update(outcome="error", error="run_scenario exited with %d; see %s.log" % (proc.returncode, s["name"]))
        return row
    with open(result_file) as stream:
        result = json.load(stream)
    passed, why = check_expectations(s["expect"], result)
    row.update({k: result.get(k) for k in ("outcome", "touchdown_error_m", "time_to_land_s", "sim_time_s",
                                           "wall_time_s", "real_time_factor", "emergency_position")})
    row["decisions"] = len(result.get("decisions") or [])
    row["passed"] = passed and not result.get("error")
    row["error"] = result.get("error") or why
    return row


def percentile(values, q):
    values = sorted(values)
    if not values:
        return None
    index = (len(values) - 1) * q
    low, high = int(math.floor(index)), int(math.ceil(index))
    return values[low] + (values[high] - values[low]) * (index - low)


def summarize(rows, groups=("vehicle", "path", "band")):
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
                "-" if not times else "%.1f" % (sum(times) / len(times)),
                "%d" % sum(r.get("decisions") or 0 for r in subset),
                "-" if not rtf else "%.1f" % (sum(rtf) / len(rtf)),
                "%d" % sum(r.get("outcome") == "error" for r in subset)]
    header = ["group", "passed", "on pad", "error mean [m]", "error p95 [m]", "error max [m]", "time to land [s]",
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


def write_outputs(rows, out_dir, elapsed):
    with open(os.path.join(out_dir, "results.csv"), "w", newline="") as stream:
        writer = csv.DictWriter(stream, fieldnames=CSV_FIELDS, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    summary = summarize(rows)
    with open(os.path.join(out_dir, "summary.md"), "w") as stream:
        stream.write("# Benchmark summary\n\n%d scenarios in %.0f s wall (%s)\n\n%s\n" % (
            len(rows), elapsed, time.strftime("%Y-%m-%d %H:%M"), summary))
    return summary


README_START, README_END = "<!-- bench:start -->", "<!-- bench:end -->"


def update_readme(readme, summary, elapsed, count):
    """Replace the block between the bench markers of ``readme`` with this run's table."""
    import platform
    with open(readme) as stream:
        text = stream.read()
    if README_START not in text or README_END not in text:
        raise ValueError("%s has no %s ... %s block to replace" % (readme, README_START, README_END))
    block = "%s\n%d scenarios of `scenarios/` on %s (%s, %d cores), %.0f min wall with `--jobs 2`:\n\n%s\n%s" % (
        README_START, count, time.strftime("%Y-%m-%d"), platform.machine(), os.cpu_count(), elapsed / 60.0,
        summary, README_END)
    head, rest = text.split(README_START, 1)
    with open(readme, "w") as stream:
        stream.write(head + block + rest.split(README_END, 1)[1])


def main(argv=None):
    parser = argparse.ArgumentParser(description="Run many landing scenarios in parallel and summarise them.")
    parser.add_argument("scenarios", nargs="+", help="scenario files or directories of them")
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument("--jobs", type=int, default=2, help="scenarios run at once (each has its own master)")
    parser.add_argument("--wall-timeout", type=float, default=None, help="wall-clock limit per scenario [s]")
    parser.add_argument("--readme", default=None, help="README whose bench block gets this run's table")
    args = parser.parse_args(argv)
    files = collect(args.scenarios)
    if not files:
        print("benchmark: no scenario files in %s" % " ".join(args.scenarios), file=sys.stderr)
        return 2
    os.makedirs(args.out, exist_ok=True)
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
    rows, start = [], time.monotonic()
    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  transient=False) as progress:
        task = progress.add_task("scenarios", total=len(files))
        with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
            futures = [pool.submit(run_one, f, args.out, args.wall_timeout) for f in files]
            for future in concurrent.futures.as_completed(futures):
                row = future.result()
                rows.append(row)
                progress.update(task, advance=1, description="%s: %s" % (row["name"], row.get("outcome")))
    rows.sort(key=lambda r: r["name"])
    elapsed = time.monotonic() - start
    summary = write_outputs(rows, args.out, elapsed)
    if args.readme:
        update_readme(args.readme, summary, elapsed, len(rows))
    print(summary)
    print("results: %s, %s" % (os.path.join(args.out, "results.csv"), os.path.join(args.out, "summary.md")))
    return 0 if all(r["passed"] for r in rows) else 1
