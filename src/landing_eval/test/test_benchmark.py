"""Benchmark bookkeeping (ROS-free): expectations, statistics, bad files."""
import os
import sys

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


def test_bad_scenario_file_is_an_error_row_not_a_success(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nplatform: {speed_mps: fast}\n")
    row = benchmark.run_one(str(bad), str(tmp_path), None)
    assert row["outcome"] == "error" and not row["passed"] and "speed_mps" in row["error"]
    assert benchmark.collect([str(tmp_path)]) == [str(bad)]


def test_percentile():
    assert benchmark.percentile([1, 2, 3, 4, 5], 0.5) == 3
    assert benchmark.percentile([0.0, 1.0], 0.95) == 0.95
    assert benchmark.percentile([], 0.5) is None


def test_readme_block_is_replaced(tmp_path):
    readme = tmp_path / "README.md"
    readme.write_text("intro\n<!-- bench:start -->\nold\n<!-- bench:end -->\nafter\n")
    benchmark.update_readme(str(readme), "| table |", 600.0, 3)
    text = readme.read_text()
    assert "old" not in text and "| table |" in text and "3 scenarios" in text and text.endswith("after\n")
