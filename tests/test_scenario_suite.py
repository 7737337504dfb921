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


def test_stress_sets_are_the_readme_figures_and_stay_out_of_the_suite():
    stress = os.path.join(SUITE, "stress")
    sets = {name: [scenario.load(f) for f in benchmark.collect([os.path.join(stress, name)])]
            for name in sorted(os.listdir(stress))}
    assert {name: len(items) for name, items in sets.items()} == {"short_sweep": 8, "square_stop_and_go_3ms": 24,
                                                                  "wind_5ms": 30, "realism_compare": 20, "car_15ms": 12,
                                                                  "ardrone2": 31}
    compare = sets["realism_compare"]
    assert {s["platform"]["path"] for s in compare} == set(scenario.PATHS)
    assert {s["platform"]["speed_mps"] for s in compare if s["platform"]["vehicle"] == "car"} == {5.0, 10.0, 15.0}
    seeded = sets["square_stop_and_go_3ms"]
    assert sorted(s["seed"] for s in seeded) == sorted(list(range(1001, 1013)) * 2)
    assert {(s["platform"]["path"], s["platform"]["speed_mps"]) for s in seeded} == {("square", 3.0),
                                                                                     ("stop_and_go", 3.0)}
    wind = sets["wind_5ms"]
    assert {s["conditions"]["wind_speed"] for s in wind} == {5.0}
    assert {s["platform"]["path"] for s in wind} == set(scenario.PATHS) - {"straight"}
    assert {s["platform"]["speed_mps"] for s in wind} == {2.0, 3.0}
    car = sets["car_15ms"]
    assert {(s["platform"]["vehicle"], s["platform"]["path"], s["platform"]["speed_mps"]) for s in car} == \
        {("car", "straight", 15.0)}
    assert sorted(e["at_s"] for s in car for e in s["events"] if e.get("operator") == "landing") == [0] * 6 + [6.0] * 6
    ardrone = sets["ardrone2"]
    assert {s["drone"]["model"] for s in ardrone} == {"ardrone2"}
    by_name = {s["name"]: s for s in (scenario.load(f) for f in benchmark.collect([SUITE]))}
    assert all(s["seed"] == by_name[s["name"]]["seed"] for s in ardrone)  # the suite's own runs, flown by ardrone2
    # make bench reads scenarios/ itself: none of these is in the suite
    assert not [f for f in benchmark.collect([SUITE]) if os.sep + "stress" + os.sep in f]
