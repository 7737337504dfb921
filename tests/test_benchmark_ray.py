"""The benchmark as a sweep, for real: three short scenarios run locally (interrupted after the first result,
then resumed) and as Ray tasks on a local Ray head with 2 CPUs, with the Ray worker of one run killed in
the middle of its flight. Each scenario must be counted exactly once, with the same outcome either way
(the closed loop is not bit-for-bit repeatable: outcomes are compared, not errors), and the killed run's
processes must be gone."""
import csv
import os
import signal
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "src", "landing_eval", "src"))
from landing_eval.ray_local import RayNode  # noqa: E402
from landing_runtime.testing import wait_for  # noqa: E402

SWEEP_TIMEOUT_S = 600  # one sweep of the three scenarios; about 30-60 s on a loaded 2-core machine
WAIT_S = 300           # for a condition inside a sweep (a row, a flight under way, processes gone)
SHORT = os.path.join(ROOT, "scenarios", "stress", "short_sweep")
# Three short runs with outcomes that do not hang on the last centimetre: an emergency landing, a no-go and
# a slow landing on the pad.
SUITE = [os.path.join(SHORT, name + ".yaml") for name in ("short_battery_10_a", "short_wind_13_a",
                                                          "short_straight_0.5ms_a")]
NAMES = {"short_battery_10_a", "short_wind_13_a", "short_straight_0.5ms_a"}


def benchmark(args, **kwargs):
    return subprocess.Popen(["rosrun", "landing_eval", "benchmark"] + SUITE + [str(a) for a in args],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, text=True,
                            start_new_session=True, **kwargs)


def finish(process):
    try:
        output, _ = process.communicate(timeout=SWEEP_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        output, _ = process.communicate()
        raise AssertionError("the sweep did not finish within %d s:\n%s" % (SWEEP_TIMEOUT_S, output))
    return process.returncode, output


def rows(out):
    path = os.path.join(str(out), "results.csv")
    if not os.path.isfile(path):
        return []
    with open(path, newline="") as stream:
        return [r for r in csv.DictReader(stream) if r.get("error") is not None]  # whole lines only


def outcomes(out):
    found = [(r["name"], r["outcome"]) for r in rows(out)]
    assert len(found) == len({name for name, _ in found}), "a scenario counted twice: %s" % found
    return dict(found)


def process_table():
    """{pid: (parent pid, command line)} of every process."""
    table = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open("/proc/%s/stat" % entry) as stream:
                    fields = stream.read().rsplit(")", 1)[1].split()
                with open("/proc/%s/cmdline" % entry, "rb") as stream:
                    command = stream.read().replace(b"\0", b" ").decode(errors="replace")
            except OSError:
                continue
            if fields[0] != "Z":
                table[int(entry)] = (int(fields[1]), command)
    return table


def descendants(pid, table):
    found, frontier = set(), {pid}
    while frontier:
        frontier = {p for p, (parent, _) in table.items() if parent in frontier} - found
        found |= frontier
    return found


@pytest.fixture(scope="module")
def local_sweep(tmp_path_factory):
    """The three scenarios run locally with --jobs 2, interrupted (SIGINT to the sweep's process group, as
    Ctrl-C does) once the first result is written, then resumed: (output directory, the first sweep's rows,
    the resumed sweep's output)."""
    out = tmp_path_factory.mktemp("local")
    first = benchmark(["--out", out, "--jobs", "2"])
    try:
        wait_for(lambda: rows(out) or first.poll() is not None, "the first result of the local sweep", WAIT_S,
                 poll=0.2)
    finally:
        if first.poll() is None:
            os.killpg(first.pid, signal.SIGINT)
    code, output = finish(first)
    kept = rows(out)
    assert code == 130 or len(kept) == 3, output  # interrupted, unless all three had finished at once
    code, resumed = finish(benchmark(["--out", out, "--jobs", "2", "--resume"]))
    assert code == 0, resumed
    return out, kept, resumed


def test_an_interrupted_sweep_keeps_its_results_and_resume_runs_only_the_rest(local_sweep):
    out, kept, resumed = local_sweep
    assert 1 <= len(kept) <= 3
    assert "%d runs already in" % len(kept) in resumed and "%d to run" % (3 - len(kept)) in resumed, resumed
    assert set(outcomes(out)) == NAMES
    for row in kept:  # the rows of the interrupted sweep are kept as they were, not run again
        assert next(r for r in rows(out) if r["name"] == row["name"]) == row
    summary = (out / "summary.md").read_text()
    assert "| **all** | 3/3 |" in summary and "rows were kept from before" in summary, summary


def test_ray_tasks_give_the_local_outcomes_even_when_a_worker_dies_mid_flight(local_sweep, tmp_path):
    out = tmp_path / "ray"
    with RayNode(num_cpus=2) as head:
        sweep = benchmark(["--out", out, "--ray", head.address])
        try:
            # A run in flight: its runner's flight recorder is writing; its parent is the Ray worker.
            def flying_run():
                table = process_table()
                for pid in descendants(head.process.pid, table):
                    command = table[pid][1]
                    if "landing_eval.runner_cli" in command:
                        run_dir = command.split("--out ")[1].split()[0]
                        if os.path.exists(os.path.join(run_dir, "flight.bag.active")):
                            return pid, table
                return None
            runner, table = wait_for(flying_run, "a run in flight on the Ray worker", WAIT_S, poll=0.2)
            worker = table[runner][0]
            assert table[worker][1].startswith("ray::"), table[worker][1]
            killed_tree = descendants(worker, table) | {worker}
            os.kill(worker, signal.SIGKILL)
            # The run's processes (runner, roslaunch and its nodes, recorder) stop with the worker.
            wait_for(lambda: not (killed_tree & set(process_table())), "the killed run's processes to stop", 120,
                     poll=0.2)
            code, output = finish(sweep)
        finally:
            if sweep.poll() is None:
                os.killpg(sweep.pid, signal.SIGKILL)
                sweep.wait()
    assert code == 0, output
    assert outcomes(out) == outcomes(local_sweep[0])
    assert all(r["node"] and ":" in r["node"] for r in rows(out))  # host:Ray node
    assert "| **all** | 3/3 |" in (out / "summary.md").read_text()
