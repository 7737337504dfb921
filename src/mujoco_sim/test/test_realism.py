"""ROS-free tests of the realism profiles and of each stochastic model's statistics."""
import math
import os

import numpy as np
import pytest

from mujoco_sim import realism
from mujoco_sim.config import ConfigError
from mujoco_sim.realism import DelayLine, Dropouts, GaussMarkov, RandomWalk
from mujoco_sim.schema import load_sim_config

PKG = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
CONFIG = os.path.join(PKG, "config", "sim.yaml")


def rng(seed=1):
    return np.random.default_rng(seed)


# ----- profiles ------------------------------------------------------------------------------------
def test_the_default_profile_is_realistic_and_every_key_has_a_value_in_every_profile():
    config = load_sim_config(CONFIG)
    assert config["realism"]["profile"] == "realistic"
    table = config["realism"]["profiles"]
    assert set(table) == {"ideal", "realistic", "harsh"}
    for values in table.values():
        assert set(values) == set(realism.SCHEMA)


def test_ideal_is_the_perfect_world_and_harsh_is_worse_than_realistic():
    table = load_sim_config(CONFIG)["realism"]["profiles"]
    ideal, real, harsh = table["ideal"], table["realistic"], table["harsh"]
    for key in ("camera_latency_s", "camera_drop_rate", "navdata_latency_s", "command_latency_s", "command_loss_rate",
                "gps_error_std", "gps_latency_s", "sonar_outlier_rate", "gyro_bias_walk", "pixel_noise_std"):
        assert ideal[key] == 0.0, key
        assert 0.0 < real[key] <= harsh[key], key
    assert not ideal["firmware_on_estimate"] and not ideal["shadows"] and not any(
        ideal[k] for k in ("lens_k1", "lens_k2", "lens_p1", "lens_p2"))
    assert real["firmware_on_estimate"] and real["flow_surface_coupling"] and real["shadows"]


def test_a_scenario_picks_a_profile_by_name_or_overrides_single_keys():
    table = load_sim_config(CONFIG)["realism"]["profiles"]
    name, values = realism.resolve(table, "harsh", "test")
    assert name == "harsh" and values == table["harsh"]
    name, values = realism.resolve(table, {"camera_latency_s": 0.15, "camera_drop_rate": 0.1}, "test")
    assert name == "realistic" and values["camera_latency_s"] == 0.15 and values["camera_drop_rate"] == 0.1
    assert values["gps_error_std"] == table["realistic"]["gps_error_std"]
    assert realism.resolve(table, None, "test")[0] == "realistic"


@pytest.mark.parametrize("selection, message", [
    ({"camera_latncy_s": 0.1}, r"s.yaml: field 'realism': unknown realism key 'camera_latncy_s' \(known: profile, "),
    ({"camera_latency_s": -0.1}, r"realism key 'camera_latency_s': got -0.1, expected a number in \[0, 2\] s"),
    ({"camera_drop_rate": 1.5}, r"realism key 'camera_drop_rate': got 1.5, expected a number in \[0, 1\]"),
    ({"shadows": "yes"}, r"realism key 'shadows': got 'yes', expected true or false"),
    ("sunny", r"unknown realism profile 'sunny' \(expected one of ideal, realistic, harsh\)"),
    ([1, 2], r"expected a profile name \(ideal \| realistic \| harsh\) or a mapping"),
])
def test_bad_realism_input_names_the_source_the_key_and_what_is_expected(selection, message):
    table = load_sim_config(CONFIG)["realism"]["profiles"]
    with pytest.raises(ConfigError, match=message):
        realism.resolve(table, selection, "s.yaml: field 'realism'")


def test_the_profile_table_in_the_yaml_is_checked_too(tmp_path):
    text = open(CONFIG).read().replace("camera_drop_rate: [0.0, 0.05, 0.10]", "camera_drop_rate: [0.0, 0.05]")
    path = tmp_path / "sim.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=r"'realism/table/camera_drop_rate': expected a list of 3 values"):
        load_sim_config(str(path))
    with pytest.raises(ConfigError, match=r"realism key 'navdata_latency_s': got -1.0"):
        load_sim_config(CONFIG, {"realism": {"overrides": {"navdata_latency_s": -1.0}}})


# ----- models --------------------------------------------------------------------------------------
def test_a_delay_line_delivers_late_by_its_latency_with_its_jitter():
    line = DelayLine(rng(), latency=0.1, jitter=0.015)
    delays = []
    for k in range(200000):  # 1 ms ticks, an item every 0.1 s
        t = k * 0.001
        if k % 100 == 0:
            line.push(t, t)
        delays += [t - sent for sent in line.due(t)]
    assert len(delays) > 1900
    assert np.mean(delays) == pytest.approx(0.1 + 0.0005, abs=0.002)
    assert np.std(delays) == pytest.approx(0.015, abs=0.002)
    assert min(delays) >= 0.0


def test_a_delay_line_never_reorders():
    line = DelayLine(rng(), latency=0.1, jitter=0.05)
    released = []
    for k in range(5000):
        line.push(k * 0.01, k)
        released += line.due(k * 0.01)
    assert released == sorted(released) and len(released) > 4900


def test_a_delay_line_loses_its_share_of_items():
    line = DelayLine(rng(2), latency=0.0, loss=0.05)
    lost = sum(line.lost_next() for _ in range(20000))
    assert lost / 20000 == pytest.approx(0.05, abs=0.005)
    assert DelayLine(rng(), 0.0).transparent and not line.transparent


def test_a_zero_latency_line_delivers_at_once():
    line = DelayLine(rng(), latency=0.0)
    line.push(1.0, "x")
    assert line.due(1.0) == ["x"]


def test_gauss_markov_error_has_its_variance_and_correlation_time():
    dt, tau, std = 0.2, 60.0, 1.0
    runs = [GaussMarkov(rng(seed), std, tau, 1) for seed in range(400)]
    start = np.array([g.value[0] for g in runs])
    for _ in range(int(tau / dt)):
        for g in runs:
            g.step(dt)
    end = np.array([g.value[0] for g in runs])
    assert np.std(start) == pytest.approx(std, rel=0.12)
    assert np.std(end) == pytest.approx(std, rel=0.12)             # stationary
    assert np.corrcoef(start, end)[0, 1] == pytest.approx(math.exp(-1.0), abs=0.1)  # e^-1 after tau


def test_a_random_walk_bias_grows_with_the_square_root_of_time():
    walks = [RandomWalk(rng(seed), 0.0, 0.002, 1) for seed in range(400)]
    for _ in range(100):
        for w in walks:
            w.step(1.0)
    assert np.std([w.value[0] for w in walks]) == pytest.approx(0.002 * math.sqrt(100.0), rel=0.12)
    assert np.std([RandomWalk(rng(s), 0.05, 0.0).value[0] for s in range(400)]) == pytest.approx(0.05, rel=0.12)


def test_dropouts_come_at_their_rate_and_last_their_duration():
    dropouts = Dropouts(rng(3), per_minute=0.5, duration=3.0)
    dt, span = 0.1, 3600.0 * 4
    down = sum(dropouts.active(k * dt) for k in range(int(span / dt))) * dt
    # Each outage of 3 s starts on average every 120 s (+3 s it lasts): 2.4 % of the time.
    assert down / span == pytest.approx(3.0 / 123.0, rel=0.2)
    assert not any(Dropouts(rng(), 0.0, 3.0).active(t) for t in range(100))


def test_the_readme_table_of_the_profiles_is_the_one_sim_yaml_makes():
    """The README's realism table is generated (`rosrun mujoco_sim realism_table --readme README.md`): a value
    or a reason changed in config/sim.yaml must be written into it too."""
    from mujoco_sim import realism_table
    readme = os.path.join(PKG, "..", "..", "README.md")
    text = open(readme).read()
    block = text[text.index(realism_table.START) + len(realism_table.START):text.index(realism_table.END)]
    assert block.strip() == realism_table.markdown(CONFIG).strip(), \
        "README.md's realism table is stale: run `rosrun mujoco_sim realism_table --readme README.md`"
    assert "| `camera_latency_s` | 0 | 0.1 | 0.2 |" in block
