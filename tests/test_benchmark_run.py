"""One short benchmark run, for real: `rosrun landing_eval benchmark` on a small directory with a thesis
scenario (battery 10 % in flight: emergency landing with coordinates), in the ideal and the realistic world, and a
file with a typo. Each run gets its own master and simulator; the bad file must come out as an error row, never a
success; no node may raise in a callback (rospy logs it and goes on: the ideal world's tracker once did, unseen)."""
import csv
import json
import os
import subprocess

import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
WALL_TIMEOUT_S = 600  # whole run; a loaded 2-core machine needs about 1 min


def test_short_benchmark_run_scores_the_good_scenario_and_marks_the_bad_one(tmp_path):
    suite = tmp_path / "suite"
    suite.mkdir()
    with open(os.path.join(ROOT, "scenarios", "adverse_battery_10_in_flight.yaml")) as stream:
        good = yaml.safe_load(stream)
    # the same thesis test, made short: the battery drops soon after take-off
    good.update(name="short_battery_10", time_limit_s=40.0)
    good["events"] = [{"at_s": 0, "operator": "landing"}, {"at_s": 6.0, "set_param": "drone_battery", "value": 10}]
    (suite / "short_battery_10.yaml").write_text(yaml.safe_dump(good))
    (suite / "typo.yaml").write_text("name: typo\nplatfrom: {vehicle: summit_xl}\n")

    out = tmp_path / "out"
    run = subprocess.run(["rosrun", "landing_eval", "benchmark", str(suite), "--out", str(out), "--jobs", "2",
                          "--realism", "ideal,realistic"],
                         capture_output=True, text=True, timeout=WALL_TIMEOUT_S, stdin=subprocess.DEVNULL)
    assert run.returncode == 1, "one scenario is bad, so the benchmark must fail:\n" + run.stdout + run.stderr

    with open(out / "results.csv") as stream:
        rows = {row["name"]: row for row in csv.DictReader(stream)}
    assert set(rows) == {name + "@" + profile for name in ("short_battery_10", "typo")
                         for profile in ("ideal", "realistic")}, rows
    for profile in ("ideal", "realistic"):
        bad_row = rows["typo@" + profile]
        assert bad_row["outcome"] == "error" and bad_row["passed"] == "False"
        assert "typo.yaml" in bad_row["error"] and "platfrom" in bad_row["error"], bad_row["error"]
        good_row = rows["short_battery_10@" + profile]
        assert good_row["outcome"] == "emergency_landed", good_row
        assert good_row["passed"] == "True", good_row
        assert float(good_row["real_time_factor"]) > 0
        result = json.loads((out / ("short_battery_10@" + profile) / "result.json").read_text())
        assert result["callback_errors"] == {}, result["callback_errors"]

    summary = (out / "summary.md").read_text()
    assert "| **all** | 2/4 |" in summary, summary
    assert "- `typo@ideal`: error" in summary
    run_dir = out / "short_battery_10@realistic"
    bags = [run_dir / name for name in os.listdir(run_dir) if name.endswith(".bag")]
    assert len(bags) == 1
    # The bag holds the flight from its first sim-second (its connections once came up seconds late).
    first = first_recorded(bags[0], {"/groundtruth/ardrone", "/drone/navdata", "/ardrone/odom_estimate", "/tf"})
    assert len(first) == 4 and max(first.values()) < 0.5, first


def first_recorded(bag, topics):
    """{topic: sim time [s] of its first message in ``bag``}."""
    from rosbags.highlevel import AnyReader
    first = {}
    with AnyReader([bag]) as reader:
        connections = [c for c in reader.connections if c.topic in topics]
        for connection, stamp, _ in reader.messages(connections=connections):
            first.setdefault(connection.topic, stamp * 1e-9)
    return first
