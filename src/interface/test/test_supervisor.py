"""Decision library of the supervisor (ROS-free): flags, re-checks, go/no-go, warnings, take-off, bad values."""
import json
import math
import os
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "src"))
from interface.conditions import MISSING, PENDING, load_table  # noqa: E402
from interface.supervisor import Flight, Mode, Settings, SettingsError, Supervisor  # noqa: E402
from interface.supervisor_measures import TouchdownJudge  # noqa: E402

TABLE_PATH = os.path.join(HERE, "..", "config", "conditions.yaml")
# Thesis Flight Management defaults (Appendix 3) plus healthy measurements: nothing adverse.
NOMINAL = {"wind_speed": 0.6, "drone_speed": 8, "control_battery": 50, "drone_battery": 80, "temp": 15,
           "platform_speed": 1.0, "target_lost_s": 0.0, "camera_silence_s": 0.03, "imu_silence_s": 0.01,
           "odometry_silence_s": 0.2, "sonar_silence_s": 0.04}
SETTINGS = Settings(answer_timeout_s=15.0, idle_takeoff_s=30.0, recheck_interval_s=2.0, recheck_count=3)


class Harness:
    """A supervisor with the shipped table, driven at 10 Hz like the node."""

    def __init__(self, settings=SETTINGS):
        self.log = []
        self.sup = Supervisor(load_table(TABLE_PATH), settings, log=lambda level, text: self.log.append(text))
        self.readings = dict(NOMINAL)
        self.flight = Flight.LANDED
        self.t = 0.0
        self.decisions, self.tracker = [], []

    def collect(self):
        decisions, commands = self.sup.take_outputs()
        self.decisions += [d.as_dict() for d in decisions]
        self.tracker += commands
        return [d.as_dict() for d in decisions]

    def tick(self, **changes):
        self.readings.update(changes)
        self.sup.tick(self.t, self.readings, self.flight)
        return self.collect()

    def run(self, seconds, **changes):
        """Advance ``seconds`` of sim time at 10 Hz; returns the decisions made meanwhile."""
        self.readings.update(changes)
        out = []
        end = self.t + seconds
        while self.t < end - 1e-9:
            self.t = round(self.t + 0.1, 6)
            out += self.tick()
        return out

    def command(self, word):
        result = self.sup.command(self.t, word)
        self.collect()
        return result

    def airborne_mission(self):
        """Start the landing mission and climb: mode landing, airborne."""
        self.tick()
        assert self.command("landing")[0]
        self.flight = Flight.AIRBORNE
        self.run(1.0)
        assert self.sup.mode is Mode.LANDING
        self.decisions.clear()
        self.tracker.clear()
        return self


def actions(decisions, condition=None):
    return [d["action"] for d in decisions if condition is None or d["condition"] == condition]


@pytest.fixture
def h():
    return Harness()


@pytest.fixture
def flying():
    return Harness().airborne_mission()


# ----- decision records -----------------------------------------------------------------------------
def test_every_decision_is_a_complete_json_record(flying):
    flying.run(0.5, drone_battery=float("nan"))
    assert flying.decisions
    for decision in flying.decisions:
        assert set(decision) == {"t", "condition", "flag", "action", "reason", "value"}
        json.loads(json.dumps(decision, allow_nan=False))  # strict JSON: no bare NaN


def test_mode_changes_are_logged_as_a_to_b_with_reason(h):
    h.tick()
    h.command("landing")
    assert "supervisor mode: idle -> landing (operator: landing)" in h.log
    h.command("manual")
    assert "supervisor mode: landing -> manual (operator: manual)" in h.log


# ----- Flag #1 ---------------------------------------------------------------------------------------
def test_flag1_battery_10_percent_starts_the_emergency_landing_in_the_same_tick(flying):
    decisions = flying.tick(drone_battery=10)
    assert flying.sup.mode is Mode.EMERGENCY
    first = decisions[0]
    assert (first["condition"], first["flag"], first["action"]) == ("drone_battery_critical", 1, "emergency_landing")
    assert first["t"] == flying.t and first["value"] == 10.0
    assert flying.tracker == ["hold"]
    assert flying.sup.landing_allowed is False


def test_flag1_critical_wind_12_mps(flying):
    flying.tick(wind_speed=12.0)
    assert flying.sup.mode is Mode.EMERGENCY
    assert ("wind_critical", "emergency_landing") in [(d["condition"], d["action"]) for d in flying.decisions]


def test_flag1_also_ends_manual_control(flying):
    flying.command("manual")
    flying.tick(drone_battery=9.0)
    assert flying.sup.mode is Mode.EMERGENCY


def test_flag1_on_the_pad_refuses_the_take_off_instead(h):
    h.tick(drone_battery=10)
    assert h.sup.mode is Mode.IDLE
    assert "no_go" in actions(h.decisions, "drone_battery_critical")
    accepted, message = h.command("landing")
    assert not accepted and "battery" in message and h.sup.mode is Mode.IDLE


def test_landing_chosen_before_the_first_reading_waits_for_it(h):
    # the operator's "landing" at t=0 reaches the node before its first condition check
    accepted, message = h.command("landing")
    assert accepted and "waits for the first reading" in message and h.sup.mode is Mode.IDLE
    h.tick(wind_speed=13.0)
    assert h.sup.mode is Mode.IDLE and "takeoff" not in h.tracker
    assert h.decisions[-1]["condition"] == "takeoff" and h.decisions[-1]["action"] == "no_go"


def test_landing_chosen_before_the_first_reading_starts_once_it_is_clear(h):
    h.command("landing")
    h.tick()
    assert h.sup.mode is Mode.LANDING and h.tracker == ["takeoff"]


def test_landing_chosen_while_a_measurement_is_pending_waits_for_it(h):
    # the vehicle's first speed report has not arrived yet at t=0
    h.tick(platform_speed=PENDING)
    accepted, message = h.command("landing")
    assert accepted and "waits for the first reading" in message and h.sup.mode is Mode.IDLE
    assert not actions(h.decisions, "takeoff")
    h.run(0.2, platform_speed=PENDING)
    assert h.sup.mode is Mode.IDLE
    h.run(0.1, platform_speed=1.0)
    assert h.sup.mode is Mode.LANDING and h.tracker == ["takeoff"]


def test_flag1_while_hovering_without_a_mission_lands(h):
    h.flight = Flight.AIRBORNE   # a scenario may start the drone in the air
    h.tick()
    h.tick(drone_battery=10)
    assert h.sup.mode is Mode.EMERGENCY


# ----- Flag #2 ---------------------------------------------------------------------------------------
def test_flag2_warns_and_the_flight_goes_on(flying):
    flying.tick(temp=0.0)
    assert actions(flying.decisions, "temp_cold") == ["warn"]
    warning = flying.sup.warning
    assert warning["conditions"] == ["temp_cold"] and warning["deadline"] is None
    assert warning["options"] == ["manual", "emergency", "continue"] and warning["default"] == "continue"
    flying.run(60.0)
    assert flying.sup.mode is Mode.LANDING and flying.sup.landing_allowed
    assert "emergency_landing" not in actions(flying.decisions)


# ----- Flag #3 ---------------------------------------------------------------------------------------
def test_flag3_three_rechecks_then_emergency_landing(flying):
    start = flying.t
    flying.run(0.1, wind_speed=11.0)
    wind = [d for d in flying.decisions if d["condition"] == "wind_strong"]
    assert [d["action"] for d in wind] == ["recheck"] and wind[0]["flag"] == 3
    flying.run(5.85)
    wind = [d for d in flying.decisions if d["condition"] == "wind_strong"]
    assert [d["action"] for d in wind] == ["recheck", "recheck", "recheck"]  # detection, checks 1/3 and 2/3
    assert flying.sup.mode is Mode.LANDING
    flying.run(0.2)
    wind = [d for d in flying.decisions if d["condition"] == "wind_strong"]
    assert wind[-1]["action"] == "emergency_landing" and "3 re-checks" in wind[-1]["reason"]
    assert wind[-1]["t"] == pytest.approx(start + 0.1 + 6.0, abs=0.11)
    assert flying.sup.mode is Mode.EMERGENCY


def test_flag3_cleared_before_the_third_check_goes_on(flying):
    flying.run(0.1, wind_speed=11.0)
    flying.run(4.5)                       # re-checks 1 and 2 found it
    decisions = flying.run(0.1, wind_speed=3.0)
    assert actions(decisions, "wind_strong") == ["continue"]
    assert "cleared after 2 of 3 re-checks" in decisions[0]["reason"]
    flying.run(30.0)
    assert flying.sup.mode is Mode.LANDING and flying.sup.landing_allowed


def test_flag3_recheck_interval_and_count_are_settings():
    h = Harness(Settings(answer_timeout_s=100.0, idle_takeoff_s=30.0, recheck_interval_s=0.5, recheck_count=5))
    h.airborne_mission()
    h.run(0.1, camera_silence_s=3.0)
    h.run(2.3)
    assert h.sup.mode is Mode.LANDING
    assert actions(h.decisions, "camera_missing") == ["recheck"] * 5  # detection + re-checks 1..4 of 5
    h.run(0.3)
    assert h.sup.mode is Mode.EMERGENCY
    final = [d for d in h.decisions if d["condition"] == "camera_missing"][-1]
    assert final["action"] == "emergency_landing" and "5 re-checks" in final["reason"]


# ----- go / no-go with reasons -------------------------------------------------------------------------
@pytest.mark.parametrize("change, row, reason_text", [
    ({"wind_speed": 11.0}, "wind_strong", "weather"),
    ({"platform_speed": 18.0}, "platform_too_fast", "platform too fast for the drone"),
    ({"target_lost_s": 6.0}, "target_lost", "target lost"),
    ({"drone_battery": 39.0}, "drone_battery_landing", "battery"),
    ({"camera_silence_s": 1.5}, "camera_missing", "sensor missing"),
    ({"imu_silence_s": 1.5}, "imu_missing", "sensor missing"),
    ({"odometry_silence_s": 8.5}, "odometry_missing", "sensor missing"),
    ({"sonar_silence_s": 1.5}, "sonar_missing", "sensor missing"),
])
def test_no_go_during_the_landing_says_why_and_go_when_it_clears(flying, change, row, reason_text):
    assert flying.sup.landing_allowed
    flying.tick(**change)
    assert not flying.sup.landing_allowed
    landing = [d for d in flying.decisions if d["condition"] == "landing"]
    assert landing[-1]["action"] == "no_go"
    assert landing[-1]["reason"].startswith("landing on the pad not possible: %s: %s" % (reason_text, row))
    assert landing[-1]["value"] == [row]
    flying.tick(**{key: NOMINAL[key] for key in change})
    assert flying.sup.landing_allowed and flying.decisions[-1]["action"] == "go"


def test_no_go_before_the_take_off_says_why(h):
    h.tick(platform_speed=20.0)
    accepted, message = h.command("landing")
    assert not accepted and h.sup.mode is Mode.IDLE
    assert message == "take-off refused: platform too fast for the drone: platform_too_fast " \
                      "(platform_speed 20 m/s > 17 m/s)"
    assert h.decisions[-1]["action"] == "no_go" and h.decisions[-1]["condition"] == "takeoff"


def test_landing_is_only_allowed_in_the_landing_mission(h):
    h.tick()
    assert not h.sup.landing_allowed
    h.command("landing")
    assert h.sup.landing_allowed
    h.command("manual")
    assert not h.sup.landing_allowed


def test_battery_40_percent_is_enough_for_the_landing(flying):
    flying.tick(drone_battery=40.0)
    assert flying.sup.landing_allowed
    flying.tick(drone_battery=39.9)
    assert not flying.sup.landing_allowed


# ----- the warning the operator answers -----------------------------------------------------------------
def test_unanswered_no_go_warning_lands_on_the_ground_after_the_answer_timeout(flying):
    start = flying.t + 0.1
    flying.run(0.1, platform_speed=19.0)
    warning = flying.sup.warning
    assert warning["deadline"] == pytest.approx(start + 15.0) and warning["default"] == "emergency"
    flying.run(14.8)
    assert flying.sup.mode is Mode.LANDING
    flying.run(0.2)
    assert flying.sup.mode is Mode.EMERGENCY
    final = [d for d in flying.decisions if d["action"] == "emergency_landing"]
    assert len(final) == 1 and final[0]["condition"] == "platform_too_fast"
    assert "no answer to the warning within 15 s" in final[0]["reason"]
    assert flying.sup.warning == {}


def test_answer_continue_keeps_flying_but_not_landing(flying):
    flying.run(0.1, target_lost_s=6.0)
    accepted, message = flying.command("continue")
    assert accepted and "landing on the pad stays no-go" in message
    assert flying.sup.warning == {}
    flying.run(30.0)
    assert flying.sup.mode is Mode.LANDING and not flying.sup.landing_allowed
    flying.run(0.1, target_lost_s=0.0)
    assert flying.sup.landing_allowed


@pytest.mark.parametrize("answer, mode", [("manual", Mode.MANUAL), ("emergency", Mode.EMERGENCY)])
def test_answer_manual_or_emergency(flying, answer, mode):
    flying.run(0.1, drone_battery=35.0)
    flying.command(answer)
    assert flying.sup.mode is mode
    assert flying.tracker[-1] == "hold"
    flying.run(30.0)
    assert flying.sup.mode is mode  # the answered warning has no deadline any more


def test_continue_after_an_emergency_does_not_bounce_back(flying):
    flying.tick(drone_battery=10)
    assert flying.sup.mode is Mode.EMERGENCY
    flying.command("continue")
    assert flying.sup.mode is Mode.LANDING and flying.tracker[-1] == "takeoff"
    flying.run(5.0)
    assert flying.sup.mode is Mode.LANDING
    flying.run(0.1, drone_battery=50)   # cleared ...
    flying.run(0.1, drone_battery=8)    # ... and back: a new occurrence
    assert flying.sup.mode is Mode.EMERGENCY


# ----- auto take-off --------------------------------------------------------------------------------------
def test_auto_take_off_after_30_s_without_a_choice(h):
    h.tick()
    h.run(29.8)
    assert h.sup.mode is Mode.IDLE and h.tracker == []
    h.run(0.3)
    assert h.sup.mode is Mode.LANDING and h.tracker == ["takeoff"]
    assert [d for d in h.decisions if d["condition"] == "idle"][0]["action"] == "takeoff"


def test_with_wait_for_start_the_30_s_run_from_the_operators_start():
    h = Harness(Settings(answer_timeout_s=15.0, idle_takeoff_s=30.0, recheck_interval_s=2.0, recheck_count=3,
                         wait_for_start=True))
    h.tick()
    assert h.sup.flight_management() == {"open": False, "auto_takeoff_at": None}
    h.run(27.0)   # the case: Start pressed at t = 27 s
    accepted, message = h.command("start")
    assert accepted and "takes off by itself at t=57.0 s" in message
    assert h.sup.flight_management() == {"open": True, "auto_takeoff_at": 57.0}
    h.run(29.8)
    assert h.sup.mode is Mode.IDLE and h.tracker == []
    h.run(0.3)
    assert h.sup.mode is Mode.LANDING and h.tracker == ["takeoff"]
    assert h.sup.flight_management() == {"open": True, "auto_takeoff_at": None}
    assert not h.command("start")[0]  # once only


def test_start_then_a_choice_cancels_the_countdown():
    h = Harness(Settings(answer_timeout_s=15.0, idle_takeoff_s=30.0, recheck_interval_s=2.0, recheck_count=3,
                         wait_for_start=True))
    h.tick()
    h.command("start")
    h.run(3.0)
    h.command("manual")
    assert h.sup.flight_management()["auto_takeoff_at"] is None
    h.run(40.0)
    assert h.sup.mode is Mode.MANUAL and "takeoff" not in h.tracker


def test_a_choice_cancels_the_auto_take_off(h):
    h.tick()
    h.run(5.0)
    h.command("manual")
    h.run(60.0)
    assert h.sup.mode is Mode.MANUAL and "takeoff" not in h.tracker


def test_auto_take_off_waits_while_no_go(h):
    h.tick(drone_battery=30.0)
    h.run(31.0)
    assert h.sup.mode is Mode.IDLE
    assert [d["action"] for d in h.decisions if d["condition"] == "takeoff"] == ["no_go"]  # said once
    h.run(0.2, drone_battery=60.0)
    assert h.sup.mode is Mode.LANDING


# ----- unreadable values are unsafe ---------------------------------------------------------------------------
@pytest.mark.parametrize("raw, says", [
    ("abc", "'abc', not a number"), (float("nan"), "not a finite number"), (-5, "impossible (valid 0..100)"),
    (150, "impossible (valid 0..100)"), (MISSING, "is not set"), ({}, "is not set"), (True, "not a number"),
])
def test_unreadable_battery_is_treated_as_critical(flying, raw, says):
    flying.tick(drone_battery=raw)
    assert flying.sup.mode is Mode.EMERGENCY
    first = flying.decisions[0]
    assert first["condition"] == "drone_battery_critical" and first["action"] == "emergency_landing"
    assert "parameter /drone_battery" in first["reason"] and says in first["reason"]
    assert "treated as unsafe" in first["reason"] and "rosparam set /drone_battery" in first["reason"]
    json.dumps(first, allow_nan=False)


@pytest.mark.parametrize("param", ["wind_speed", "temp", "control_battery"])
def test_any_unreadable_flag1_parameter_lands(flying, param):
    flying.tick(**{param: "abc"})
    assert flying.sup.mode is Mode.EMERGENCY


def test_unreadable_value_on_the_pad_is_a_no_go(h):
    h.tick(drone_battery="abc")
    assert not h.command("landing")[0]
    assert any("treated as unsafe" in d["reason"] for d in h.decisions if d["action"] == "no_go")


def test_unreadable_value_of_a_present_condition_is_still_reported(flying):
    flying.command("manual")
    flying.tick(temp=0.0)
    flying.tick(temp="cold")
    reasons = [d["reason"] for d in flying.decisions if d["condition"] == "temp_cold"]
    assert any("'cold', not a number" in r for r in reasons)


# ----- operator, flight state -------------------------------------------------------------------------------
def test_unknown_command_is_ignored_with_a_clear_message(h):
    accepted, message = h.command("fly away")
    assert not accepted and "expected one of start, landing, takeoff" in message
    assert h.decisions[-1]["action"] == "ignored"


def test_landing_mission_ends_landed_after_touchdown(flying):
    flying.flight = Flight.LANDED
    flying.tick()
    assert flying.sup.mode is Mode.LANDED and "landed" in actions(flying.decisions)


def judged(state_before, *detections, t=22.1):
    judge = TouchdownJudge(max_age_s=1.0, max_offset_m=0.5)
    for state in ("LANDED", "TAKING_OFF", "TRACKING", state_before, "LANDED"):
        judge.on_tracker_state(state)
    for detection in detections:
        judge.on_detection(*detection)
    return judge(t)


def test_touchdown_on_the_pad_is_told_from_the_tracker_state_and_the_last_detections():
    assert judged("LANDING", (21.7, 0.06, -0.05)) == (
        True, "on the pad, 0.08 m from its centre in the last 1.0 s (median of 1 detections, the latest 0.4 s before "
              "the touchdown)")
    assert judged("LANDING", (20.0, 0.06, -0.05)) == (False, "the pad was last seen 2.1 s before the touchdown")
    assert judged("LANDING", (21.7, 0.6, 0.1)) == (
        False, "the pad centre was 0.61 m away in the last 1.0 s (median of 1 detections)")
    assert judged("LANDING") == (False, "the camera never saw the pad")
    assert judged("FORCE_LANDING", (21.7, 0.0, 0.0))[0] is False


def test_a_stray_detection_in_the_last_centimetres_does_not_overturn_the_verdict():
    """A few centimetres above the pad the camera sees a fragment of it, which the detector may complete on the
    wrong side: in a realistic soak the last two detections put the centre 0.68 m away while the drone came to rest
    0.045 m from it."""
    approach = [(21.0 + 0.033 * i, 0.01, -0.05) for i in range(25)]
    stray = [(21.9, -0.68, 0.09), (21.93, -0.68, 0.10)]
    on_pad, why = judged("LANDING", *approach, *stray, t=22.0)
    assert on_pad and why.startswith("on the pad, 0.05 m from its centre")
    assert judged("LANDING", (21.5, 0.01, -0.05), *stray, t=22.0)[0] is False  # the stray ones are the majority
    earlier = [(t - 1.2, x, y) for t, x, y in approach]  # more than 1 s before the touchdown: they do not count
    assert judged("LANDING", *earlier, *stray, t=22.0)[0] is False


def test_landing_performed_successfully_only_on_the_pad(flying):
    verdict = [(True, "on the pad, 0.05 m from its centre")]
    flying.sup.touchdown_judge = lambda t: verdict[0]
    flying.flight = Flight.LANDED
    flying.tick()
    landed = [d for d in flying.decisions if d["action"] == "landed"][0]
    assert landed["reason"] == "Landing performed successfully: on the pad, 0.05 m from its centre"
    assert landed["value"] == {"on_pad": True}
    second = Harness().airborne_mission()
    second.sup.touchdown_judge = lambda t: (False, "the pad was last seen 3.0 s before the touchdown")
    second.flight = Flight.LANDED
    second.tick()
    landed = [d for d in second.decisions if d["action"] == "landed"][0]
    assert "successfully" not in landed["reason"] and "not on the pad: the pad was last seen" in landed["reason"]


def test_emergency_report_acknowledged_on_the_ground_ends_landed(flying):
    flying.command("emergency")
    flying.run(1.0)
    flying.flight = Flight.LANDED
    flying.run(1.0)
    assert flying.sup.mode is Mode.EMERGENCY  # still reporting until the operator acknowledges
    assert flying.command("ack")[0]
    assert flying.sup.mode is Mode.LANDED


def test_quit_in_the_air_lands_where_it_is(flying):
    flying.command("quit")
    assert flying.sup.mode is Mode.QUIT and flying.tracker[-1] == "force_land"
    assert not flying.command("landing")[0]


def test_manual_and_back_to_the_landing_mission(flying):
    flying.command("manual")
    assert flying.sup.mode is Mode.MANUAL and flying.tracker[-1] == "hold"
    flying.command("landing")
    assert flying.sup.mode is Mode.LANDING and flying.tracker[-1] == "takeoff"


# ----- settings --------------------------------------------------------------------------------------------
def test_settings_name_a_missing_or_bad_key():
    good = {"answer_timeout_s": 15.0, "idle_takeoff_s": 30.0, "recheck_interval_s": 2.0, "recheck_count": 3,
            "wait_for_start": True}
    assert Settings.from_mapping(good).recheck_count == 3
    with pytest.raises(SettingsError, match="'wait_for_start' must be true or false"):
        Settings.from_mapping(dict(good, wait_for_start="yes"))
    with pytest.raises(SettingsError, match="'idle_takeoff_s' is missing"):
        Settings.from_mapping({k: v for k, v in good.items() if k != "idle_takeoff_s"})
    with pytest.raises(SettingsError, match="'recheck_count' must be an integer"):
        Settings.from_mapping(dict(good, recheck_count=2.5))
    with pytest.raises(SettingsError, match="'answer_timeout_s' = -1 is outside"):
        Settings.from_mapping(dict(good, answer_timeout_s=-1))
    with pytest.raises(SettingsError, match="'answer_timeout_s' must be a number"):
        Settings.from_mapping(dict(good, answer_timeout_s=math.nan))


# ----- restart after a crash (the node keeps snapshot() on the master) ---------------------------------------
def restarted(before):
    """A fresh supervisor restored from ``before``'s snapshot, at ``before``'s time and readings."""
    after = Harness()
    after.t, after.readings, after.flight = before.t, dict(before.readings), before.flight
    snapshot = json.loads(json.dumps(before.sup.snapshot()))  # as stored: JSON
    after.sup.restore(after.t, snapshot)
    after.collect()
    return after


def test_a_restarted_supervisor_carries_on_in_its_mode_and_tells_the_tracker_again(flying):
    after = restarted(flying)
    assert after.sup.mode is Mode.LANDING
    assert actions(after.decisions) == ["recovered"] and after.tracker == []
    after.tick()  # the flight state is known: the tracker is told to carry on (a restarted tracker reads it)
    assert after.tracker == ["takeoff"] and after.sup.landing_allowed
    after.flight = Flight.LANDED  # the mission then ends as it would have
    after.run(0.2)
    assert after.sup.mode is Mode.LANDED and after.tracker[-1] == "hold"


def test_no_take_off_again_for_a_mission_whose_drone_came_down_meanwhile(flying):
    flying.flight = Flight.LANDED  # touched down while the supervisor was dead
    after = restarted(flying)
    after.tick()
    assert "takeoff" not in after.tracker and after.sup.mode is Mode.LANDED
    assert actions(after.decisions, "flight") == ["landed"]


def test_an_answered_warning_stays_answered_after_a_restart(flying):
    flying.run(0.5, drone_battery=35)  # below 40 %: no landing, a warning with a deadline
    flying.command("continue")
    after = restarted(flying)
    after.run(20.0)  # longer than the 15 s answer timeout: no emergency landing
    assert after.sup.mode is Mode.LANDING and "emergency_landing" not in actions(after.decisions)
    assert not after.sup.landing_allowed and not after.sup.warning


def test_an_unanswered_warning_is_raised_again_after_a_restart(flying):
    flying.run(0.5, drone_battery=35)
    after = restarted(flying)
    after.run(16.0)
    assert after.sup.mode is Mode.EMERGENCY


def test_the_end_of_a_mission_tells_the_tracker_to_hold(flying):
    flying.flight = Flight.LANDED
    flying.run(0.2)
    assert flying.sup.mode is Mode.LANDED and flying.tracker == ["hold"]
    assert flying.command("landing")[0] and flying.tracker == ["hold", "takeoff"]  # the next mission
