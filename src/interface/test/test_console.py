"""Operator console model and plain rendering (ROS-free)."""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
from interface.console import render_plain  # noqa: E402
from interface.conditions import load_table  # noqa: E402
from interface.console_model import ConsoleModel, Screen, panel_keys  # noqa: E402

TABLE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "config", "conditions.yaml")


def started(**kwargs):
    model = ConsoleModel(**kwargs)
    assert model.handle("s") == ("start", "Flight Management opened: without a choice the drone takes off by itself")
    return model


def test_start_menu_then_flight_management():
    model = ConsoleModel()
    assert model.screen == Screen.START and model.title() == "Start"
    command, reply = model.handle("landing")
    assert command is None and "press s (Start) first" in reply
    model.handle("start")
    assert model.screen == Screen.FLIGHT_MANAGEMENT
    assert model.handle("l") == ("landing", "sent: landing")
    assert model.handle("manual")[0] == "manual"
    assert model.handle("e")[0] == "emergency"
    assert model.handle("q")[0] == "quit" and model.screen == Screen.CLOSED


def test_unknown_command_says_what_is_available():
    command, reply = started().handle("fly away")
    assert command is None and "unknown command 'fly away'" in reply and "l=landing" in reply


def test_panel_highlights_out_of_range_and_unreadable_values_and_missing_sensors():
    model = started(ranges={"drone_battery": (40.0, 100.0), "wind_speed": (0.0, 12.0)})
    model.set_value("wind_speed", 4.0)
    model.set_value("drone_battery", 10.0)
    model.set_value("temp", "abc")
    model.set_sensor("camera", True)
    model.set_sensor("imu", False)
    rows = {row.key: row for row in model.rows()}
    assert not rows["wind_speed"].alarm and rows["wind_speed"].text == "4.0 m/s"
    assert rows["drone_battery"].alarm
    assert rows["temp"].alarm and "unreadable" in rows["temp"].text
    assert rows["sensors"].alarm and rows["sensors"].text == "missing: imu"
    assert rows["control_battery"].text == "unreadable"


def test_supervisor_decisions_show_flag_and_reason():
    model = started()
    model.set_value("wind_speed", 13.0)
    model.on_decision({"t": 12.5, "condition": "wind_speed", "flag": 1, "action": "emergency_landing",
                       "reason": "wind 13.0 m/s above the 12 m/s limit"})
    row = {row.key: row for row in model.rows()}["wind_speed"]
    assert row.alarm and row.note == "flag #1, emergency_landing: wind 13.0 m/s above the 12 m/s limit"
    assert "t=12.5 wind_speed [flag #1]: emergency_landing" in model.log[-1]


def test_warning_and_emergency_position_are_rendered_with_countdown():
    model = started()
    model.mode = "emergency"
    model.on_warning({"id": 3, "message": "wind gusts", "options": ["manual", "emergency", "continue"],
                      "deadline": 40.0})
    model.emergency_position = (12.34, -5.5)
    text = "\n".join(render_plain(model, 30.0))
    assert "WARNING: wind gusts -> answer manual/emergency/continue within 10 s" in text
    assert "x=12.34 m, y=-5.50 m" in text
    assert "Emergency Mode" in text and "a Acknowledge" in text
    model.on_warning({"id": 4, "message": "cold", "options": ["continue"], "deadline": None})
    assert "WARNING: cold -> the flight goes on" in "\n".join(render_plain(model, 30.0))
    model.on_warning({})
    assert model.warning is None


def test_rows_are_coloured_by_the_flag_of_the_supervisors_conditions_and_cleared_again():
    keys = panel_keys(load_table(TABLE))
    assert keys["wind_strong"] == keys["wind_critical"] == "wind_speed"
    assert keys["camera_missing"] == "sensors" and keys["platform_too_fast"] == "drone_speed"
    assert "target_lost" not in keys
    model = started(condition_keys=keys)
    model.set_value("wind_speed", 13.0)
    model.on_decision({"t": 1.0, "condition": "wind_strong", "flag": 3, "action": "recheck", "reason": "strong"})
    model.on_decision({"t": 1.0, "condition": "wind_critical", "flag": 1, "action": "emergency_landing",
                       "reason": "critical"})
    row = {row.key: row for row in model.rows()}["wind_speed"]
    assert row.alarm and row.flag == 1 and row.note == "flag #1, emergency_landing: critical"  # the worst first
    model.on_decision({"t": 2.0, "condition": "wind_critical", "flag": 1, "action": "cleared", "reason": "ok"})
    assert {row.key: row for row in model.rows()}["wind_speed"].flag == 3
    model.on_decision({"t": 3.0, "condition": "camera_missing", "flag": 3, "action": "recheck", "reason": "silent"})
    sensors = {row.key: row for row in model.rows()}["sensors"]
    assert sensors.flag == 3 and sensors.note == "flag #3, recheck: silent"


def test_countdown_to_the_auto_take_off_and_the_landing_menu():
    model = started()
    model.on_flight_management({"open": True, "auto_takeoff_at": 57.0})
    assert model.auto_takeoff_in(40.0) == 17.0
    assert "auto take-off in 17 s without a choice" in render_plain(model, 40.0)
    model.on_flight_management({"open": True, "auto_takeoff_at": None})
    assert model.auto_takeoff_in(40.0) is None
    model.mode, model.tracker_state = "landing", "LANDING"
    model.drone_xy, model.target_xy, model.height = (1.0, 2.0), (1.3, 2.4), 0.8
    assert model.landing_lines() == ["tracker LANDING   error 0.50 m   height 0.80 m   camera delay -"]
    model.camera_latency = 0.104
    assert model.landing_lines() == ["tracker LANDING   error 0.50 m   height 0.80 m   camera delay 0.10 s"]
    model.on_decision({"t": 22.1, "condition": "flight", "action": "landed", "flag": None,
                       "reason": "Landing performed successfully: on the pad, 0.08 m from its centre"})
    model.mode, model.tracker_state = "landed", "LANDED"
    lines = render_plain(model, 23.0)
    assert "Landing performed successfully: on the pad, 0.08 m from its centre" in lines


def test_flight_management_opened_by_another_ui_leaves_the_start_menu():
    model = ConsoleModel()
    model.on_flight_management({"open": True, "auto_takeoff_at": 30.0})
    assert model.screen == Screen.FLIGHT_MANAGEMENT


def test_the_preflight_row_says_what_blocks_the_take_off_and_what_to_do():
    from interface.console_model import ConsoleModel
    model = ConsoleModel()
    assert "preflight" not in [row.key for row in model.rows()]  # no check runs: no row
    model.on_preflight(False, ["drone/navdata alive: ok",
                               "camera calibrated: no camera_info yet -- calibrate the bottom camera"])
    row = [row for row in model.rows() if row.key == "preflight"][0]
    assert row.alarm and row.text == "take-off blocked: camera calibrated" and "calibrate the bottom camera" in row.note
    model.on_preflight(True, ["drone/navdata alive: ok", "camera calibrated: ok"])
    row = [row for row in model.rows() if row.key == "preflight"][0]
    assert not row.alarm and row.text == "ready (2 items)"


def test_a_drone_resting_on_the_moving_pad_is_not_said_to_be_flying():
    from interface.console_model import ConsoleModel
    model = ConsoleModel()
    model.values["drone_speed"] = 8.0
    model.flight_speed, model.tracker_state = 1.1, "TRACKING"
    assert "(flying 1.1 m/s)" in [row.text for row in model.rows() if row.key == "drone_speed"][0]
    model.tracker_state = "LANDED"  # on the pad of a vehicle driving at 1.1 m/s
    assert "flying" not in [row.text for row in model.rows() if row.key == "drone_speed"][0]
