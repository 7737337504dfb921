"""Condition table (config/conditions.yaml) and the supervisor's own measurements (ROS-free)."""
import os
import sys

import pytest
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "src"))
from interface.conditions import (MISSING, PENDING, ConditionTableError, evaluate, load_table, parse_table,  # noqa: E402
                                  read_value)
from interface.supervisor import Flight  # noqa: E402
from interface.supervisor_measures import PlatformSpeed, SensorWatchdog, TargetLostTimer, flight_from_navdata  # noqa: E402

TABLE_PATH = os.path.join(HERE, "..", "config", "conditions.yaml")


@pytest.fixture
def table():
    return load_table(TABLE_PATH)


def shipped():
    with open(TABLE_PATH) as stream:
        return yaml.safe_load(stream)


# ----- the shipped table --------------------------------------------------------------------------------
def test_shipped_table_has_the_thesis_defaults(table):
    assert table.row("wind_critical").thresholds == {"at_or_above": 12.0} and table.row("wind_critical").flag == 1
    assert table.row("drone_battery_critical").thresholds == {"at_or_below": 10.0}
    assert table.row("drone_battery_critical").flag == 1
    assert table.row("drone_battery_landing").thresholds == {"below": 40.0}
    assert table.row("drone_battery_landing").blocks_landing
    assert table.row("platform_too_fast").thresholds["above"] == pytest.approx(0.85 * table.drone_max_horizontal_speed)
    assert table.sensor_timeout_s == 1.0
    assert table.params() == ["wind_speed", "drone_battery", "temp", "control_battery", "drone_speed"]


def test_thesis_flight_management_defaults_are_not_adverse(table):
    defaults = {"wind_speed": 0.6, "drone_speed": 8, "control_battery": 50, "drone_battery": 80, "temp": 15,
                "platform_speed": 0.0, "target_lost_s": 0.0, "camera_silence_s": 0.0, "imu_silence_s": 0.0,
                "odometry_silence_s": 0.0, "sonar_silence_s": 0.0}
    assert [row.name for row in table if evaluate(row, defaults[row.source]).present] == []


def test_every_reason_of_the_issue_has_a_row(table):
    reasons = {row.reason for row in table if row.blocks_landing}
    assert {"weather", "platform_too_fast", "target_lost", "battery", "sensor_missing"} <= reasons
    assert {row.flag for row in table} == {1, 2, 3}


def test_every_row_line_of_the_shipped_file_is_documented():
    with open(TABLE_PATH) as stream:
        text = stream.read()
    header = text.split("conditions:\n", 1)[0]
    for key in ("param:", "measure:", "unit:", "valid:", "below / at_or_below / above / at_or_above",
                "flag:", "blocks_landing:", "reason:", "message:"):
        assert key in header, "the header of conditions.yaml must explain %r" % key


# ----- malformed files -----------------------------------------------------------------------------------
def write(tmp_path, data):
    path = tmp_path / "conditions.yaml"
    path.write_text(data if isinstance(data, str) else yaml.safe_dump(data))
    return str(path)


@pytest.mark.parametrize("edit, message", [
    (lambda d: d["conditions"]["wind_critical"].pop("flag"), "key 'conditions.wind_critical.flag' is missing"),
    (lambda d: d["conditions"]["wind_critical"].update(flag=4),
     "key 'conditions.wind_critical.flag' must be 1, 2 or 3"),
    (lambda d: d["conditions"]["wind_critical"].update(at_or_above="high"),
     "key 'conditions.wind_critical.at_or_above' must be a finite number"),
    (lambda d: d["conditions"]["wind_critical"].update(colour="red"),
     "key 'conditions.wind_critical.colour' is not known"),
    (lambda d: d["conditions"]["temp_cold"].update(at_or_below=3.0), "two lower thresholds"),
    (lambda d: d["conditions"]["target_lost"].update(measure="vibes"),
     "key 'conditions.target_lost.measure' must be one of"),
    (lambda d: d["conditions"]["target_lost"].update(param="x"), "exactly one of 'param'"),
    (lambda d: d["conditions"]["temp_cold"].pop("below"), "key 'conditions.temp_cold' needs a threshold"),
    (lambda d: d["conditions"]["temp_cold"].update(valid=[5, 1]), "key 'conditions.temp_cold.valid'"),
    (lambda d: d["conditions"]["temp_cold"].update(reason="mood"), "key 'conditions.temp_cold.reason' must be one of"),
    (lambda d: d["conditions"]["temp_cold"].update(blocks_landing="yes"), "'conditions.temp_cold.blocks_landing'"),
    (lambda d: d.pop("conditions"), "key 'conditions' is missing"),
    (lambda d: d.update(sensor_timeout="1"), "key 'sensor_timeout' is not known"),
])
def test_malformed_table_names_the_file_and_the_key(tmp_path, edit, message):
    data = shipped()
    edit(data)
    path = write(tmp_path, data)
    with pytest.raises(ConditionTableError) as err:
        load_table(path)
    assert str(err.value).startswith(path + ":") and message in str(err.value)


def test_unreadable_file_names_the_file(tmp_path):
    with pytest.raises(ConditionTableError, match="cannot read the condition table"):
        load_table(str(tmp_path / "nope.yaml"))
    with pytest.raises(ConditionTableError, match="not valid YAML"):
        load_table(write(tmp_path, "conditions: [unclosed"))


def test_parse_table_accepts_a_minimal_row():
    table = parse_table({"conditions": {"gale": {"param": "/wind_speed", "unit": "m/s", "valid": [0, 50],
                                                 "above": 20, "flag": 1, "blocks_landing": True,
                                                 "reason": "weather", "message": "gale"}}})
    assert table.row("gale").param == "wind_speed" and table.params() == ["wind_speed"]


# ----- a drone model's limits over the table ----------------------------------------------------------------
DRONE_MODELS_DIR = os.path.join(HERE, "..", "config", "drone_models")
DRONE_ROWS = ("platform_too_fast", "wind_strong", "drone_speed_high")


@pytest.mark.parametrize("model", ["ardrone2", "px4_quad", "velocity_quad"])
def test_every_drone_model_sets_its_envelope_and_comments_each_key(model):
    path = os.path.join(DRONE_MODELS_DIR, model + ".yaml")
    table = load_table(TABLE_PATH, path)
    assert table.path == "%s + %s" % (TABLE_PATH, path)
    with open(path) as stream:
        data = yaml.safe_load(stream)
    assert set(data["conditions"]) == set(DRONE_ROWS)
    for name in DRONE_ROWS:  # the drone's threshold, the row's flag and reason
        assert table.row(name).thresholds == {k: v for k, v in data["conditions"][name].items() if k != "message"}
        assert table.row(name).flag == load_table(TABLE_PATH).row(name).flag
    with open(path) as stream:  # every value says its meaning and unit
        assert all("#" in line for line in stream if line.strip() and not line.lstrip().startswith("#")
                   and not line.rstrip().endswith(":") and "message:" not in line)


def test_the_ardrone_refuses_what_the_simulated_quad_still_lands_in():
    ardrone = load_table(TABLE_PATH, os.path.join(DRONE_MODELS_DIR, "ardrone2.yaml"))
    quad = load_table(TABLE_PATH, os.path.join(DRONE_MODELS_DIR, "velocity_quad.yaml"))
    assert evaluate(ardrone.row("platform_too_fast"), 4.0).present and \
        not evaluate(quad.row("platform_too_fast"), 4.0).present
    assert evaluate(ardrone.row("wind_strong"), 8.0).present and not evaluate(quad.row("wind_strong"), 8.0).present
    assert "AR.Drone" in ardrone.row("platform_too_fast").message
    assert ardrone.drone_max_horizontal_speed < quad.drone_max_horizontal_speed
    # its start-up drone_speed is one it can fly, so the warning does not greet every AR.Drone flight
    assert not evaluate(ardrone.row("drone_speed_high"), ardrone.initial_conditions["drone_speed"]).present


@pytest.mark.parametrize("drone, message", [
    ({"conditions": {"hurricane": {"above": 1.0}}}, "key 'conditions.hurricane' names no row of"),
    ({"conditions": {"wind_strong": {"flag": 1}}}, "key 'conditions.wind_strong' may set only"),
    ({"top_speed": 3.0}, "key 'top_speed' is not known"),
    ({"conditions": {"wind_strong": {"at_or_above": "windy"}}}, "'conditions.wind_strong.at_or_above' must be a finite"),
    ([1, 2], "must be a mapping"),
    ({"initial_conditions": {"drone_speed": "fast"}}, "key 'initial_conditions' must map condition parameters"),
])
def test_a_malformed_drone_model_names_its_file_and_key(tmp_path, drone, message):
    path = tmp_path / "drone.yaml"
    path.write_text(yaml.safe_dump(drone))
    with pytest.raises(ConditionTableError) as err:
        load_table(TABLE_PATH, str(path))
    assert str(path) in str(err.value) and message in str(err.value)


def test_a_missing_drone_model_file_is_named():
    with pytest.raises(ConditionTableError, match="nope.yaml: cannot read the drone model's limits"):
        load_table(TABLE_PATH, "/tmp/nope.yaml")


# ----- reading values --------------------------------------------------------------------------------------
@pytest.mark.parametrize("raw, expected", [
    ("abc", "parameter /drone_battery is 'abc', not a number"),
    (float("nan"), "parameter /drone_battery is nan, not a finite number"),
    (float("inf"), "not a finite number"),
    (-5, "parameter /drone_battery is -5 %, impossible (valid 0..100)"),
    (150, "parameter /drone_battery is 150 %, impossible (valid 0..100)"),
    (MISSING, "parameter /drone_battery is not set"),
    ({}, "parameter /drone_battery is not set"),
    (False, "is False, not a number"),
    ([80], "is [80], not a number"),
])
def test_unreadable_values_say_what_is_wrong_and_what_to_do(table, raw, expected):
    row = table.row("drone_battery_critical")
    value, problem = read_value(raw, row)
    assert value is None and expected in problem and "rosparam set /drone_battery <number>" in problem
    evaluation = evaluate(row, raw)
    assert evaluation.present and evaluation.unreadable and evaluation.detail.endswith("treated as unsafe")


def test_thresholds_inclusive_and_exclusive(table):
    critical, landing = table.row("drone_battery_critical"), table.row("drone_battery_landing")
    assert evaluate(critical, 10).present and not evaluate(critical, 10.1).present
    assert evaluate(landing, 39.99).present and not evaluate(landing, 40).present
    assert evaluate(table.row("wind_critical"), 12.0).present and not evaluate(table.row("wind_critical"), 11.9).present
    out_of_range = table.row("temp_out_of_range")
    assert evaluate(out_of_range, -10.5).present and evaluate(out_of_range, 41).present
    assert not evaluate(out_of_range, 15).present
    assert evaluate(table.row("drone_battery_critical"), 10).detail == "drone_battery 10 % <= 10 %"


def test_measured_value_missing_is_unsafe(table):
    evaluation = evaluate(table.row("platform_too_fast"), MISSING)
    assert evaluation.present and "measured platform_speed is not set" in evaluation.detail


def test_measured_value_pending_is_neither_safe_nor_unsafe(table):
    evaluation = evaluate(table.row("platform_too_fast"), PENDING)
    assert not evaluation.present and "not measured yet" in evaluation.detail


def test_platform_speed_never_reported_becomes_missing_after_the_start_up_grace():
    speed = PlatformSpeed(filtered_timeout_s=1.0, window_s=1.0, gps_timeout_s=1.0)
    assert speed.value(5.0) is PENDING
    assert speed.value(5.9) is PENDING
    assert speed.value(6.1) is MISSING


# ----- the supervisor node's measurements ------------------------------------------------------------------
def test_sensor_watchdog_counts_from_start_and_from_the_last_message():
    watchdog = SensorWatchdog(["camera", "imu"])
    assert watchdog.silence("camera", 10.0) == 0.0
    watchdog.seen("imu", 10.5)
    assert watchdog.silence("camera", 11.5) == pytest.approx(1.5)   # never heard of: since the start
    assert watchdog.silence("imu", 11.5) == pytest.approx(1.0)


def test_sensor_watchdog_counts_a_late_connection_from_when_it_connected():
    watchdog = SensorWatchdog(["gps"])
    assert watchdog.silence("gps", 0.0) == 0.0
    watchdog.connected("gps", 1.2)           # the publisher connected late: its first fixes were lost
    assert watchdog.silence("gps", 1.5) == pytest.approx(0.3)
    watchdog.connected("gps", 5.0)           # a reconnection does not reset it: only the first counts
    assert watchdog.silence("gps", 6.0) == pytest.approx(4.8)
    watchdog.seen("gps", 6.0)
    assert watchdog.silence("gps", 6.5) == pytest.approx(0.5)


def test_platform_speed_prefers_the_vehicle_report_then_falls_back_to_the_kalman_filter():
    speed = PlatformSpeed(filtered_timeout_s=1.0, window_s=1.0)
    assert speed.value(0.0) is PENDING       # start-up: the first report has not had time to come
    for i in range(6):
        speed.on_gps(i * 0.2, 3.0 + (0.1 if i % 2 else -0.1), 4.0)
    speed.on_filtered(1.0, 0.0, 24.0)        # a jump of the filter while it acquires the pad
    assert speed.value(1.0) == pytest.approx(5.0, abs=0.05) and speed.source(1.0) == "summit_xl/gps/odom"
    for i in range(6):                       # the vehicle's report stops: the filter, averaged
        speed.on_filtered(1.5 + i * 0.2, 0.0, 12.0 + (1.0 if i % 2 else -1.0))
    assert speed.value(2.5) == pytest.approx(12.0, abs=0.2) and speed.source(2.5) == "kalman_platform_odom"
    assert speed.value(3.6) is MISSING      # neither source is fresh any more


def test_target_lost_timer_counts_the_relocating_time():
    timer = TargetLostTimer("RELOCATING")
    timer.on_state(1.0, "TRACKING")
    assert timer.value(2.0) == 0.0
    timer.on_state(2.0, "RELOCATING")
    timer.on_state(3.0, "RELOCATING")
    assert timer.value(7.5) == pytest.approx(5.5)
    timer.on_state(8.0, "TRACKING")
    assert timer.value(9.0) == 0.0


def test_flight_from_navdata_state():
    assert flight_from_navdata(2) is Flight.LANDED and flight_from_navdata(10) is Flight.LANDED
    assert all(flight_from_navdata(s) is Flight.AIRBORNE for s in (3, 4, 6, 8))
    assert flight_from_navdata(0) is Flight.UNKNOWN
