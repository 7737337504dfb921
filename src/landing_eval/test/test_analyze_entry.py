"""`analyze`, landing_eval's entry point of the flight analysis (flight_analysis.analyze): the script and
`python -m landing_eval.analyze` in a clean environment (nothing sourced, no master, no ROS modules imported), and
the scenario beside the bag (run_scenario's result.json) read through landing_eval.scenario."""
import json
import os
import shutil
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", "..", ".."))
SCRIPT = os.path.join(ROOT, "src", "landing_eval", "scripts", "analyze")
FIXTURE = os.path.join(ROOT, "src", "flight_analysis", "test", "data", "sim_flight.bag")  # a simulator run's bag
SCENARIO = os.path.join(ROOT, "scenarios", "adverse_wind_11_clears.yaml")  # wind_speed set to 11 then 3 m/s
SUBPROCESS_TIMEOUT = 300  # generous: the machine may be loaded

pytest.importorskip("rosbags")


def clean_env(tmp_path):
    return {"PATH": "/usr/bin:/bin", "HOME": str(tmp_path), "LANG": "C.UTF-8", "MPLCONFIGDIR": str(tmp_path / "mpl")}


def metrics(out):
    with open(os.path.join(out, "metrics.json")) as stream:
        return json.load(stream)


def test_python_dash_m_works_in_a_clean_environment_without_ros(tmp_path):
    """From any directory: the venv finds both packages through the .pth file `make build` writes."""
    out = str(tmp_path / "out")
    result = subprocess.run([sys.executable, "-m", "landing_eval.analyze", FIXTURE, "--out", out, "--no-plots"],
                            cwd=str(tmp_path), env=clean_env(tmp_path), capture_output=True, text=True,
                            timeout=SUBPROCESS_TIMEOUT)
    assert result.returncode == 0, result.stderr
    assert "landed_on_pad" in result.stdout and metrics(out)["outcome"] == "landed_on_pad"
    code = ("import sys, landing_eval.analyze as a; a.analyze(sys.argv[1], sys.argv[2], plots=False); "
            "bad = [m for m in sys.modules if m.split('.')[0] in ('rospy', 'rosbag', 'roslib', 'genpy', 'rosgraph')]; "
            "print('ROS modules:', bad); sys.exit(1 if bad else 0)")
    result = subprocess.run([sys.executable, "-c", code, FIXTURE, str(tmp_path / "out2")], cwd=str(tmp_path),
                            env=clean_env(tmp_path), capture_output=True, text=True, timeout=SUBPROCESS_TIMEOUT)
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_script_finds_its_packages_in_a_clean_environment(tmp_path):
    out = str(tmp_path / "out")
    result = subprocess.run([sys.executable, SCRIPT, FIXTURE, "--out", out, "--no-plots"], cwd=str(tmp_path),
                            env=clean_env(tmp_path), capture_output=True, text=True, timeout=SUBPROCESS_TIMEOUT)
    assert result.returncode == 0, result.stderr
    assert os.path.isfile(os.path.join(out, "metrics.json")) and not os.path.exists(os.path.join(out, "top_view.png"))


def test_bad_input_exits_2_through_the_entry_point(tmp_path):
    result = subprocess.run([sys.executable, SCRIPT, str(tmp_path / "missing.bag"), "--out", str(tmp_path / "out")],
                            capture_output=True, text=True, timeout=SUBPROCESS_TIMEOUT)
    assert result.returncode == 2 and "analyze:" in result.stderr


def test_the_scenario_beside_the_bag_gives_the_wind(tmp_path):
    """run_scenario writes result.json beside the bag; its scenario's wind is read through landing_eval.scenario
    (which needs mujoco_sim's realism profiles: a sourced workspace). flight_analysis alone reads no scenario."""
    pytest.importorskip("mujoco_sim")
    from flight_analysis import analyze as analysis
    from landing_eval import analyze
    bag = str(tmp_path / "flight.bag")
    shutil.copy(FIXTURE, bag)
    with open(str(tmp_path / "result.json"), "w") as stream:
        json.dump({"scenario": SCENARIO}, stream)
    m = analyze.analyze(bag, str(tmp_path / "out"), plots=False)
    assert m["max_wind_mps"] == pytest.approx(11.0)
    assert "scenario event" in m["wind"]["sources"] and "scenario conditions" in m["wind"]["sources"]
    alone = analysis.analyze(bag, str(tmp_path / "alone"), plots=False)
    assert not alone["wind"] or not any(s.startswith("scenario") for s in alone["wind"]["sources"])
