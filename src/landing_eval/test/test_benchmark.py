"""Benchmark bookkeeping (ROS-free): expectations, statistics, bad files."""
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
from landing_eval import benchmark  # noqa: E402


def test_expectations():
    ok = {"outcome": "landed_on_pad", "touchdown_error_m": 0.05, "decisions": []}
    assert benchmark.check_expectations({}, ok) == (True, "")
    assert benchmark.check_expectations({"max_touchdown_error_m": 0.03}, ok)[1] == "touchdown error 0.050 m > 0.030 m"
    emergency = {"outcome": "emergency_landed", "decisions": [{"condition": "drone_battery", "flag": 1,
                                                               "action": "emergency_landing"}],
                 "emergency_position": [1.0, 2.0], "touchdown": {"position": [1.3, 2.4, 0.06]}}
    expect = {"outcome": ["emergency_landed"], "no_pad_landing": True, "emergency_position_within_m": 1.0,
              "decisions_include": [{"condition": "drone_battery", "action": "emergency_landing"}]}
    assert benchmark.check_expectations(expect, emergency) == (True, "")
    passed, why = benchmark.check_expectations(expect, dict(ok, decisions=[]))
    assert not passed and "outcome landed_on_pad" in why and "no decision matching" in why
    assert "although a no-go" in why


def test_a_landing_with_an_exception_in_a_nodes_callback_does_not_pass():
    landed = {"outcome": "landed_on_pad", "touchdown_error_m": 0.05, "decisions": [], "callback_errors": {
        "/platform_tracking": {"count": 618, "first": "bad callback: <bound method ...>\nTraceback (most recent call "
                                                      "last):\n  ...\nIndexError: list index out of range\n"}}}
    passed, why = benchmark.check_expectations({}, landed)
    assert not passed
    assert why == "exception(s) in callbacks: /platform_tracking 618 times (IndexError: list index out of range)"
    assert benchmark.check_expectations({}, dict(landed, callback_errors={})) == (True, "")


def test_summary_groups_and_lists_every_miss():
    rows = [
        {"name": "a", "vehicle": "summit_xl", "path": "circle", "speed_mps": 1.0, "outcome": "landed_on_pad",
         "passed": True, "touchdown_error_m": 0.04, "time_to_land_s": 30.0, "decisions": 0, "real_time_factor": 5.0},
        {"name": "b", "vehicle": "car", "path": "straight", "speed_mps": 15.0, "outcome": "landed_off_pad",
         "passed": False, "touchdown_error_m": None, "time_to_land_s": 40.0, "decisions": 1, "real_time_factor": 4.0,
         "error": "outcome landed_off_pad, expected landed_on_pad"},
        {"name": "c", "outcome": "error", "passed": False, "error": "c.yaml: field 'name' is required"},
    ]
    text = benchmark.summarize(rows)
    assert "| **all** | 1/3 | 1 | 0.040 |" in text
    assert "| vehicle = car | 0/1 |" in text and "| band = car > 10 m/s |" in text
    assert "- `b`: landed_off_pad (outcome landed_off_pad" in text
    assert "- `c`: error (c.yaml: field 'name' is required)" in text


def test_a_list_names_scenario_files_relative_to_itself_and_the_shipped_scope_list_names_existing_ones(tmp_path):
    (tmp_path / "sets").mkdir()
    listing = tmp_path / "sets" / "some.txt"
    listing.write_text("# a comment\n\na.yaml  # the first\n../b.yaml\n")
    assert benchmark.collect([str(listing)]) == [str(tmp_path / "sets" / "a.yaml"), str(tmp_path / "sets" / "../b.yaml")]
    scope = os.path.join(os.path.dirname(__file__), "..", "..", "..", "scenarios", "target_scope.txt")
    files = benchmark.collect([scope])
    assert len(files) >= 80 and all(os.path.isfile(f) for f in files)


def test_bad_scenario_file_is_an_error_row_not_a_success(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nplatform: {speed_mps: fast}\n")
    specs, rows = benchmark.plan([str(bad)], 2, str(tmp_path))
    assert specs == [] and [r["run"] for r in rows] == [1, 2]
    assert all(r["outcome"] == "error" and not r["passed"] and "speed_mps" in r["error"] for r in rows)
    assert benchmark.collect([str(tmp_path)]) == [str(bad)]


SCENARIO = """name: %s
seed: 3
time_limit_s: 30
platform: {vehicle: summit_xl, path: circle, speed_mps: 1.0, radius_m: 10.0}
"""


def test_plan_repeats_each_scenario_into_runs_of_their_own(tmp_path):
    (tmp_path / "a.yaml").write_text(SCENARIO % "alpha")
    specs, bad = benchmark.plan([str(tmp_path / "a.yaml")], 3, str(tmp_path / "out"))
    assert bad == [] and [s["row"]["run"] for s in specs] == [1, 2, 3]
    assert [os.path.basename(s["out_dir"]) for s in specs] == ["alpha", "alpha.run2", "alpha.run3"]
    assert all(s["wall_timeout"] == 300.0 and "seed: 3" in s["scenario_text"] for s in specs)


def test_two_files_with_one_scenario_name_are_refused(tmp_path):
    for f in ("a.yaml", "b.yaml"):
        (tmp_path / f).write_text(SCENARIO % "same")
    with pytest.raises(ValueError, match="both name their scenario 'same'"):
        benchmark.plan(benchmark.collect([str(tmp_path)]), 1, str(tmp_path / "out"))


def test_a_failed_run_is_an_error_row_and_a_result_is_checked_against_expect(tmp_path):
    (tmp_path / "a.yaml").write_text(SCENARIO % "alpha")
    spec = benchmark.plan([str(tmp_path / "a.yaml")], 1, str(tmp_path))[0][0]
    row = benchmark.row_of(spec, {"result": None, "node": "n1", "failure": "run_scenario exited with 3"})
    assert row["outcome"] == "error" and not row["passed"] and row["node"] == "n1"
    row = benchmark.row_of(spec, {"result": {"outcome": "timeout", "decisions": [{}]}, "node": "n2"})
    assert row["outcome"] == "timeout" and not row["passed"] and "expected landed_on_pad" in row["error"]
    row = benchmark.row_of(spec, {"result": {"outcome": "landed_on_pad", "touchdown_error_m": 0.05}, "node": "n2"})
    assert row["passed"] and row["touchdown_error_m"] == 0.05 and row["run"] == 1


def test_spread_reports_each_repeated_scenario():
    rows = [{"name": "a", "run": r, "outcome": "landed_on_pad", "passed": True, "touchdown_error_m": e,
             "time_to_land_s": t} for r, e, t in ((1, 0.026, 30.0), (2, 0.015, 32.5), (3, 0.020, 31.0))]
    rows.append({"name": "b", "run": 1, "outcome": "timeout", "passed": False})
    text = benchmark.spread(rows)
    assert "| a | 3 | 3 | landed_on_pad x3 | 0.015 | 0.020 | 0.026 | 0.006 | 30.0-32.5 |" in text
    assert "| b |" not in text
    assert benchmark.spread(rows[3:]) == ""


def test_provenance_names_the_commit_and_the_command(monkeypatch):
    monkeypatch.setattr(sys, "argv", ["benchmark", "scenarios", "--out", "/tmp/x y"])
    commit, command = benchmark.provenance()
    assert commit != "unknown" and len(commit.split("-")[0]) >= 7
    assert command == "rosrun landing_eval benchmark scenarios --out '/tmp/x y'"


def test_percentile():
    assert benchmark.percentile([1, 2, 3, 4, 5], 0.5) == 3
    assert benchmark.percentile([0.0, 1.0], 0.95) == 0.95
    assert benchmark.percentile([], 0.5) is None


def test_readme_block_is_replaced(tmp_path):
    readme = tmp_path / "README.md"
    readme.write_text("intro\n<!-- bench:start -->\nold\n<!-- bench:end -->\nafter\n")
    benchmark.update_readme(str(readme), "3 scenarios at commit `abc`", "| table |")
    text = readme.read_text()
    assert "old" not in text and "| table |" in text and "3 scenarios at commit `abc`" in text
    assert text.endswith("<!-- bench:end -->\nafter\n")


def test_realism_replaces_each_scenarios_profile_and_reaches_the_run_and_the_summary(tmp_path):
    (tmp_path / "a.yaml").write_text(SCENARIO % "alpha" + "realism: {profile: harsh, camera_latency_s: 0.2}\n")
    (tmp_path / "b.yaml").write_text(SCENARIO % "beta")
    files = benchmark.collect([str(tmp_path)])
    specs, _ = benchmark.plan(files, 1, str(tmp_path / "out"))
    assert [(s["row"]["realism"], s["realism"]) for s in specs] == [("harsh", None), ("realistic", None)]
    specs, _ = benchmark.plan(files, 1, str(tmp_path / "out"), realism="ideal")
    assert [(s["row"]["realism"], s["realism"]) for s in specs] == [("ideal", "ideal"), ("ideal", "ideal")]
    rows = [dict(s["row"], outcome="landed_on_pad", passed=True, touchdown_error_m=0.05) for s in specs]
    assert "| realism = ideal | 2/2 |" in benchmark.summarize(rows)


def test_several_realism_profiles_run_each_scenario_in_each_under_its_own_name(tmp_path):
    (tmp_path / "a.yaml").write_text(SCENARIO % "alpha")
    specs, _ = benchmark.plan([str(tmp_path / "a.yaml")], 2, str(tmp_path / "out"), realism=["ideal", "harsh"])
    assert [(s["row"]["name"], s["row"]["run"], s["realism"]) for s in specs] == [
        ("alpha@ideal", 1, "ideal"), ("alpha@ideal", 2, "ideal"), ("alpha@harsh", 1, "harsh"),
        ("alpha@harsh", 2, "harsh")]
    assert [os.path.basename(s["out_dir"]) for s in specs] == ["alpha@ideal", "alpha@ideal.run2", "alpha@harsh",
                                                               "alpha@harsh.run2"]
    rows = [dict(s["row"], outcome="landed_on_pad", passed=True, touchdown_error_m=0.1, time_to_land_s=t)
            for s, t in zip(specs, (20.0, 30.0, 40.0, 50.0))]
    text = benchmark.summarize(rows)
    assert "| realism = harsh | 2/2 | 2 | 0.100 | 0.100 | 0.100 | 45.0 |" in text
    with pytest.raises(SystemExit) as exit_info:  # argparse's usage error, before anything runs
        benchmark.main(["--realism", "ideal,sunny", "--out", str(tmp_path / "o"), str(tmp_path)])
    assert exit_info.value.code == 2 and not (tmp_path / "o").exists()
