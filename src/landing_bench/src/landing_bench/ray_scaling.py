"""ray_scaling: the same sweep run locally and as Ray tasks on Ray nodes started on this machine, timed.

    rosrun landing_bench ray_scaling scenarios/stress/short_sweep --out /tmp/scaling [--configs local,ray,ray1,ray1+1]
    rosrun landing_bench ray_scaling scenarios/stress/short_sweep --out /tmp/jobs --configs local1,local2
    rosrun landing_bench ray_scaling scenarios/stress/short_sweep --out /tmp/warm --configs local1,warm1,local2,warm2

Configurations: ``local`` (benchmark --jobs CPUS), ``localN`` (benchmark --jobs N), ``warmN`` (benchmark --jobs N
--warm: each job's graph reset between its runs), ``ray`` (one Ray node with CPUS CPUs), ``rayA+B`` (a head with A
CPUs and a second node, a separate ``ray start --address`` process, with B). Each is a whole
``rosrun landing_eval benchmark`` command, timed from start to exit (connecting to Ray included), with its
results in OUT/CONFIG. Prints a table: wall time, runs passed, and where the runs went. On one machine a
second node adds no cores: ``ray1+1`` against ``ray1`` shows that tasks spread over the nodes and that a
node's CPUs are used as they come, ``ray2+2`` that oversubscribing the cores does not help. With several
configurations, each one's throughput (runs per wall hour) is also given against the first one's."""
import argparse
import collections
import csv
import os
import subprocess
import sys
import time

from landing_eval.ray_local import RayNode


def sweep(scenarios, out, extra):
    start = time.monotonic()
    with open(out + ".log", "w") as log:
        code = subprocess.run(["rosrun", "landing_eval", "benchmark"] + scenarios + ["--out", out] + extra,
                              stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL).returncode
    wall = time.monotonic() - start
    rows = []
    if os.path.isfile(os.path.join(out, "results.csv")):
        with open(os.path.join(out, "results.csv"), newline="") as stream:
            rows = list(csv.DictReader(stream))
    return code, wall, rows


def run_config(config, scenarios, out_root, cpus):
    out = os.path.join(out_root, config.replace("+", "_"))
    if config.startswith("local"):
        return sweep(scenarios, out, ["--jobs", config[5:] or str(cpus)])
    if config.startswith("warm"):
        return sweep(scenarios, out, ["--jobs", config[4:], "--warm"])
    sizes = [int(n) for n in config[3:].split("+")] if config[3:] else [cpus]
    with RayNode(num_cpus=sizes[0]) as head:
        nodes = [RayNode(num_cpus=n, address=head.address) for n in sizes[1:]]
        try:
            for node in nodes:
                node.start()
            return sweep(scenarios, out, ["--ray", head.address])
        finally:
            for node in nodes:
                node.stop()


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scenarios", nargs="+", help="scenario files or directories")
    parser.add_argument("--out", required=True, help="output directory (a subdirectory per configuration)")
    parser.add_argument("--cpus", type=int, default=2, help="CPUs of 'local' (--jobs) and of 'ray' [-]")
    parser.add_argument("--configs", default="local,ray,ray1,ray1+1", help="comma-separated configurations")
    args = parser.parse_args(argv)
    configs = [c.strip() for c in args.configs.split(",") if c.strip()]
    for config in configs:
        if config not in ("local", "ray") and not (config.startswith("local") and config[5:].isdigit()) and not (
                config.startswith("warm") and config[4:].isdigit()) and not (
                config.startswith("ray") and all(p.isdigit() for p in config[3:].split("+"))):
            parser.error("unknown configuration %r (local, localN, warmN, ray, rayA+B...)" % config)
    os.makedirs(args.out, exist_ok=True)
    lines = ["| configuration | wall [s] | passed | exit | runs per node | throughput against the first |",
             "|---|---|---|---|---|---|"]
    first_rate = None
    for config in configs:
        code, wall, rows = run_config(config, args.scenarios, args.out, args.cpus)
        per_node = collections.Counter(r.get("node") or "-" for r in rows)
        label = "local --jobs %s" % (config[5:] or args.cpus) if config.startswith("local") else \
            "local --jobs %s --warm" % config[4:] if config.startswith("warm") else \
            "Ray, %s CPU" % (config[3:] or str(args.cpus)).replace("+", " + ")
        rate = len(rows) / wall if wall > 0 else 0.0  # runs per wall second
        first_rate = rate if first_rate is None else first_rate
        lines.append("| %s | %.1f | %d/%d | %d | %s | %s |" % (
            label, wall, sum(r["passed"] == "True" for r in rows), len(rows), code,
            ", ".join("%s: %d" % item for item in sorted(per_node.items())),
            "%.2fx" % (rate / first_rate) if first_rate else "-"))
        print(lines[-1], flush=True)
    print("\n".join(["", "%s on %d cores:" % (" ".join(args.scenarios), os.cpu_count())] + lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
