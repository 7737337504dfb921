"""The shipped scenario suite: generated files are current, every file validates, the suite covers SPEC."""
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "src", "landing_eval", "src"))
from landing_eval import benchmark, scenario  # noqa: E402

SUITE = os.path.join(ROOT, "scenarios")


def test_committed_suite_matches_its_generator():
    result = subprocess.run([sys.executable, os.path.join(SUITE, "generate.py"), "--check"],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr


def test_every_scenario_validates_and_names_are_unique():
    loaded = [scenario.load(f) for f in benchmark.collect([SUITE])]
    names = [s["name"] for s in loaded]
    assert len(names) == len(set(names))
    paths = {s["platform"]["path"] for s in loaded if s["platform"]["vehicle"] == "summit_xl"}
    assert paths == set(scenario.PATHS)
    car_speeds = {s["platform"]["speed_mps"] for s in loaded if s["platform"]["vehicle"] == "car"}
    assert {5.0, 10.0, 15.0} <= car_speeds
    assert any(s["drone"]["start"] != "on_pad" for s in loaded)
    assert any(e.get("fault") == "camera_blackout" for s in loaded for e in s["events"])
    assert any(e.get("fault") == "detection_false_target" for s in loaded for e in s["events"])
