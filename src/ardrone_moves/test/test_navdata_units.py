"""Navdata raw fields -> SI, their validation, and the altd unit check (ROS-free)."""
import math
import os
import random
from types import SimpleNamespace

import pytest
import yaml

from ardrone_moves.navdata_units import (AGREES, INCONSISTENT, OTHER_UNIT, AltdUnitCheck, GRAVITY, NavdataLimits,
                                         altd_scale, convert_fields, convert_navdata)


def raw_navdata(**overrides):
    """A hovering AR.Drone as ardrone_autonomy reports it."""
    fields = dict(vx=1200.0, vy=-300.0, vz=150.0, rotX=2.0, rotY=-5.0, rotZ=90.0, altd=1500, ax=0.05, ay=-0.1,
                  az=1.0, batteryPercent=76.0, state=3, pressure=101000, tm=12345678.0)
    fields.update(overrides)
    return fields


def test_every_field_reaches_si():
    navdata, problem = convert_navdata(SimpleNamespace(**raw_navdata()), altd_unit="mm", stamp=42.5)
    assert problem is None
    assert navdata.velocity_heading == pytest.approx((1.2, -0.3)) and navdata.climb == pytest.approx(0.15)
    assert navdata.speed == pytest.approx(math.hypot(1.2, 0.3))
    assert (navdata.roll, navdata.pitch, navdata.yaw) == pytest.approx((math.radians(2), math.radians(-5), math.pi / 2))
    assert navdata.height == pytest.approx(1.5)
    assert navdata.acceleration == pytest.approx((0.05 * GRAVITY, -0.1 * GRAVITY, GRAVITY))
    assert navdata.battery == 76.0 and navdata.state == 3 and navdata.state_name == "flying" and navdata.airborne
    assert navdata.pressure == 101000.0 and navdata.stamp == 42.5


def test_altd_unit_sets_the_height_scale():
    assert convert_fields(**raw_navdata(altd=150), altd_unit="cm").navdata.height == pytest.approx(1.5)
    assert convert_fields(**raw_navdata(altd=1500), altd_unit="mm").navdata.height == pytest.approx(1.5)
    with pytest.raises(ValueError, match="altd_unit"):
        altd_scale("m")


def test_plain_numbers_and_dicts_work_and_tm_is_the_fallback_stamp():
    navdata, problem = convert_fields(**raw_navdata(), altd_unit="mm")
    assert problem is None and navdata.stamp == pytest.approx(12.345678)
    assert convert_navdata(raw_navdata(), "mm").navdata == navdata


def test_states_and_missing_barometer():
    assert not convert_fields(**raw_navdata(state=2), altd_unit="mm").navdata.airborne
    for state in (3, 4, 7):
        assert convert_fields(**raw_navdata(state=state), altd_unit="mm").navdata.airborne
    assert convert_fields(**raw_navdata(pressure=0), altd_unit="mm").navdata.pressure is None


@pytest.mark.parametrize("field, value, words", [
    ("vx", float("nan"), "'vx'"), ("rotY", float("inf"), "'rotY'"), ("altd", None, "'altd'"),
    ("vx", 40000.0, "horizontal speed"), ("vy", -31000.0, "horizontal speed"), ("vz", 12000.0, "climb"),
    ("rotX", 400.0, "rotX"), ("altd", -20, "altd"), ("altd", 200000, "altd_unit"), ("az", 30.0, "az"),
    ("batteryPercent", 120.0, "batteryPercent"), ("state", 12, "state"), ("state", 3.5, "state"),
    ("pressure", 500, "pressure")])
def test_invalid_values_are_named_not_raised(field, value, words):
    navdata, problem = convert_fields(**raw_navdata(**{field: value}), altd_unit="mm")
    assert navdata is None and words in problem


def test_missing_field_and_custom_limits():
    fields = raw_navdata()
    del fields["pressure"]
    assert "'pressure'" in convert_navdata(fields, "mm").problem
    assert "horizontal speed" in convert_fields(**raw_navdata(), altd_unit="mm",
                                                limits=NavdataLimits(max_speed=1.0)).problem


def fill(check, pairs):
    verdict = None
    for altd, reference in pairs:
        verdict = check.add(altd, reference)
    return verdict


def noisy_flight(altd_per_metre, samples=40, seed=1, outliers=0):
    """(altd, reference) pairs between 0.5 and 3 m, 5 % noise on each, some wild outliers."""
    rng = random.Random(seed)
    pairs = []
    for index in range(samples):
        height = 0.5 + 2.5 * index / samples
        reference = height * (1.0 + rng.gauss(0.0, 0.05))
        altd = round(height * altd_per_metre * (1.0 + rng.gauss(0.0, 0.05)))
        if index < outliers:
            altd = rng.choice([0, altd * 7, altd // 4])
        pairs.append((altd, reference))
    rng.shuffle(pairs)
    return pairs


def test_altd_in_the_configured_unit_agrees_despite_noise_and_outliers():
    verdict = fill(AltdUnitCheck("mm", samples_needed=20), noisy_flight(1000.0, outliers=4))
    assert verdict.outcome == AGREES and verdict.unit == "mm" and verdict.ratio == pytest.approx(1.0, abs=0.1)
    assert "agrees with altd_unit: mm" in verdict.message


@pytest.mark.parametrize("configured, altd_per_metre, right", [("mm", 100.0, "cm"), ("cm", 1000.0, "mm")])
def test_altd_ten_times_off_names_the_parameter_to_set(configured, altd_per_metre, right):
    verdict = fill(AltdUnitCheck(configured), noisy_flight(altd_per_metre, outliers=3))
    assert verdict.outcome == OTHER_UNIT and verdict.unit == right
    assert "set the parameter altd_unit: %s" % right in verdict.message
    assert verdict.ratio == pytest.approx(10.0 if configured == "cm" else 0.1, rel=0.15)


def test_inconsistent_altd_fits_neither_unit():
    rng = random.Random(7)
    pairs = [(rng.uniform(50, 5000), rng.uniform(0.5, 3.0)) for _ in range(30)]  # unrelated to the height
    verdict = fill(AltdUnitCheck("mm", samples_needed=30), pairs)
    assert verdict.outcome == INCONSISTENT and verdict.unit is None and "fits neither mm nor cm" in verdict.message
    scaled_wrong = fill(AltdUnitCheck("mm"), noisy_flight(3000.0))  # a factor 3: neither unit
    assert scaled_wrong.outcome == INCONSISTENT


def test_only_references_between_0_3_and_5_m_count_and_the_verdict_sticks():
    check = AltdUnitCheck("mm", samples_needed=3)
    for reference in (0.1, 0.29, 5.5, 40.0, float("nan")):
        assert check.add(100.0, reference) is None  # would be 10x off: must not count
    assert check.add(1000, 1.0) is None and check.add(2000, 2.0) is None
    verdict = check.add(300, 0.3)
    assert verdict.outcome == AGREES and verdict.samples == 3
    assert check.add(10, 1.0) is verdict
    check.reset()
    assert check.verdict is None


def test_altd_check_parameters_are_validated():
    with pytest.raises(ValueError, match="altd_unit"):
        AltdUnitCheck("inch")
    with pytest.raises(ValueError, match="tolerance_factor"):
        AltdUnitCheck("mm", tolerance_factor=4.0)
    with pytest.raises(ValueError, match="samples_needed"):
        AltdUnitCheck("mm", samples_needed=0)


def test_shipped_config_values_are_accepted():
    config = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "config", "ardrone_adapter.yaml")
    with open(config) as stream:
        params = yaml.safe_load(stream)
    check = AltdUnitCheck(params["altd_unit"], samples_needed=params["altd_check_samples"])
    assert check.configured_unit in ("mm", "cm") and check.samples_needed == 20


def test_pressure_altitude_is_zero_at_the_reference_and_about_8_m_per_hpa_near_sea_level():
    from ardrone_moves.navdata_units import pressure_altitude
    assert pressure_altitude(101325.0, 101325.0) == 0.0
    assert 8.0 < pressure_altitude(101325.0 - 100.0, 101325.0) < 8.6
    assert pressure_altitude(101325.0 + 100.0, 101325.0) < 0.0
