"""ROS-free tests of drone_model px4_quad: PX4's offboard rules as a companion computer meets them (the commander:
modes, arming, the offboard signal, failsafes, land detector), the set-points it takes, and short flights of the
emulated quadrotor in the ideal world unless a test says otherwise."""
import math
import os
import re

import pytest

from mujoco_sim.autopilot import FlightMode
from mujoco_sim.config import ConfigError
from mujoco_sim.px4_firmware import (ACCEPTED, ALTCTL, AUTO_LAND, AUTO_LOITER, AUTO_RTL, AUTO_TAKEOFF,
                                     DENIED, FAILSAFE_BATTERY, FAILSAFE_OFFBOARD_LOSS, FAILSAFE_POSITION_LOSS,
                                     IN_AIR, LANDING, MANUAL, MAV_STATE_ACTIVE, MAV_STATE_CRITICAL,
                                     MAV_STATE_STANDBY, OFFBOARD, ON_GROUND, POSCTL, STABILIZED, TAKEOFF,
                                     TEMPORARILY_REJECTED, OffboardStream, Px4Commander, Setpoint, VehicleStatus)
from mujoco_sim.schema import load_sim_config
from mujoco_sim.simulator import SURFACE_PAD, Simulator

PKG = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
CONFIG = os.path.join(PKG, "config", "sim.yaml")
PARAMS = load_sim_config(CONFIG, {"drone_model": "px4_quad"})["px4_quad"]
VELOCITY_AND_YAW_RATE = 1479  # IGNORE_PX|PY|PZ|AFX|AFY|AFZ|YAW: velocity and yaw rate, as offboard code sends
GROUND = VehicleStatus(on_ground=True)
AIR = VehicleStatus(on_ground=False, airborne_control=True)


def hover():
    return Setpoint.velocity(0.0, 0.0, 0.0)[0]


def streaming(commander, start, seconds, period=0.05):
    """Set-points every ``period`` from ``start`` for ``seconds``; returns the time after the last one."""
    t = start
    while t < start + seconds - 1e-9:
        commander.receive_setpoint(hover(), t)
        t += period
    return t - period


def in_offboard(commander, now=1.0):
    t = streaming(commander, now, 0.5)
    assert commander.request_mode(OFFBOARD, t)
    return t


def flying(commander, now=0.0):
    """Armed and in the air in OFFBOARD at the returned time."""
    t = in_offboard(commander, now + 0.1)
    assert commander.request_arm(True, t)[0] == ACCEPTED
    commander.tick(t, AIR)
    assert not commander.landed
    return t


# ----- set-points ------------------------------------------------------------------------------------------
def test_a_velocity_and_yaw_rate_position_target_is_taken_in_the_local_enu_frame():
    sp, problem = Setpoint.from_position_target(1, VELOCITY_AND_YAW_RATE, (9.0, 9.0, 9.0), (1.0, -2.0, 0.5),
                                                0.7, 0.3)
    assert problem is None
    assert (sp.kind, sp.vector, sp.body, sp.yaw, sp.yaw_rate) == ("velocity", (1.0, -2.0, 0.5), False, None, 0.3)
    sp, _ = Setpoint.from_position_target(8, VELOCITY_AND_YAW_RATE, (0, 0, 0), (1.0, 0.0, 0.0), 0.0, 0.0)
    assert sp.body
    sp, _ = Setpoint.from_position_target(1, 0b100111111000, (1.0, 2.0, 3.0), (0, 0, 0), 1.2, 0.0)
    assert (sp.kind, sp.vector, sp.yaw, sp.yaw_rate) == ("position", (1.0, 2.0, 3.0), 1.2, None)


@pytest.mark.parametrize("frame, mask, velocity, why", [
    (0, VELOCITY_AND_YAW_RATE, (1, 0, 0), "coordinate_frame"),            # global frames are not local ones
    (1, 0b110000111111, (1, 0, 0), "acceleration"),                       # acceleration set-point
    (1, VELOCITY_AND_YAW_RATE | 512, (1, 0, 0), "acceleration or force"),  # FORCE
    (1, 0b110111111111, (1, 0, 0), "neither"),                            # nothing to fly
    (1, 0b110111000000, (1, 0, 0), "both"),                               # position and velocity at once
    (1, VELOCITY_AND_YAW_RATE | 8, (1, 0, 0), "some velocity axes"),
    (1, VELOCITY_AND_YAW_RATE, (float("nan"), 0, 0), "non-finite"),
    (8, 0b110111111000, (0, 0, 0), "body frame"),                         # a body-frame position
])
def test_set_points_px4_would_not_fly_here_are_refused_with_the_reason(frame, mask, velocity, why):
    sp, problem = Setpoint.from_position_target(frame, mask, (1.0, 2.0, 3.0), velocity, 0.0, 0.0)
    assert sp is None and why in problem


def test_a_nan_yaw_rate_refuses_a_twist_set_point():
    assert Setpoint.velocity(1.0, 0.0, 0.0, float("inf"))[0] is None


# ----- the offboard signal ------------------------------------------------------------------------------------
def test_the_offboard_signal_needs_two_set_points_less_than_half_a_second_apart_and_recent():
    stream = OffboardStream(0.5, 1.0)
    assert not stream.alive(0.0) and stream.lost(0.0)
    stream.received(0.0)
    assert not stream.alive(0.0)          # one set-point is no stream
    stream.received(0.6)
    assert not stream.alive(0.6)          # 1.7 Hz is too slow
    stream.received(1.0)
    assert stream.alive(1.0) and stream.alive(1.5) and not stream.alive(1.51)
    assert not stream.lost(2.0) and stream.lost(2.01)


def test_offboard_is_refused_without_the_stream_and_the_mode_stays():
    c = Px4Commander(PARAMS)
    assert c.mode == POSCTL
    assert not c.request_mode(OFFBOARD, 1.0)
    assert c.mode == POSCTL and "no offboard signal" in c.events[-1][1]
    c.receive_setpoint(hover(), 1.0)
    assert not c.request_mode(OFFBOARD, 1.1)       # a single set-point
    c.receive_setpoint(hover(), 1.8)
    assert not c.request_mode(OFFBOARD, 1.8)       # slower than 2 Hz
    c.receive_setpoint(hover(), 2.0)
    assert not c.request_mode(OFFBOARD, 2.6)       # it stopped 0.6 s ago
    assert c.request_mode(OFFBOARD, 2.3)
    assert c.mode == OFFBOARD and c.guided and not c.manual_input


def test_offboard_lost_holds_then_lands_and_never_comes_back_by_itself():
    c = Px4Commander(PARAMS)
    t = flying(c)
    c.tick(t + 1.0, AIR)
    assert c.mode == OFFBOARD                       # COM_OF_LOSS_T not over yet
    c.tick(t + 1.01, AIR)
    assert (c.mode, c.failsafe, c.system_status) == (AUTO_LOITER, FAILSAFE_OFFBOARD_LOSS, MAV_STATE_CRITICAL)
    later = streaming(c, t + 2.0, 1.0)              # the stream resumes: PX4 stays in its failsafe...
    c.tick(later, AIR)
    assert c.mode == AUTO_LOITER
    c.tick(t + 1.01 + PARAMS["offboard_loss_hold_s"] - 0.01, AIR)
    assert c.mode == AUTO_LOITER
    c.tick(t + 1.01 + PARAMS["offboard_loss_hold_s"], AIR)   # ...and lands after the hold unless asked otherwise
    assert (c.mode, c.failsafe) == (AUTO_LAND, FAILSAFE_OFFBOARD_LOSS)


def test_a_mode_request_ends_the_offboard_failsafe():
    c = Px4Commander(PARAMS)
    t = flying(c)
    c.tick(t + 1.5, AIR)
    assert c.failsafe == FAILSAFE_OFFBOARD_LOSS
    later = streaming(c, t + 2.0, 0.5)
    assert c.request_mode(OFFBOARD, later)
    assert (c.mode, c.failsafe, c.system_status) == (OFFBOARD, None, MAV_STATE_ACTIVE)


# ----- arming -------------------------------------------------------------------------------------------------
def test_arming_is_refused_unless_the_conditions_hold():
    c = Px4Commander(PARAMS)
    c.tick(0.0, VehicleStatus(position_valid=False))
    assert c.request_arm(True, 0.1) == (TEMPORARILY_REJECTED, "no valid position estimate for POSCTL")
    assert c.request_mode(ALTCTL, 0.1) and c.request_arm(True, 0.2)[0] == ACCEPTED  # ALTCTL needs no position
    c = Px4Commander(PARAMS)
    c.tick(0.0, VehicleStatus(battery=6.0))
    result, why = c.request_arm(True, 0.1)
    assert result == TEMPORARILY_REJECTED and "battery" in why
    c = Px4Commander(PARAMS)
    t = in_offboard(c)
    assert c.request_arm(True, t + 0.6) == (TEMPORARILY_REJECTED, "no offboard signal")  # the stream stopped
    c = Px4Commander(PARAMS)
    c.request_land(0.0)
    assert c.request_arm(True, 0.1)[0] == TEMPORARILY_REJECTED
    c = Px4Commander(PARAMS)
    assert c.request_arm(True, 0.1) == (ACCEPTED, "armed")
    assert (c.armed, c.system_status) == (True, MAV_STATE_ACTIVE)
    assert c.request_arm(True, 0.2) == (ACCEPTED, "already armed")


def test_disarming_is_refused_in_the_air_and_taken_on_the_ground():
    c = Px4Commander(PARAMS)
    t = flying(c)
    assert c.request_arm(False, t) == (DENIED, "not landed")
    assert c.armed
    c.tick(t + 0.1, GROUND)
    assert c.request_arm(False, t + 0.2)[0] == DENIED           # touched down, not yet detected
    t = streaming(c, t, 1.2)                                    # (the stream goes on: no failsafe)
    c.tick(t, GROUND)
    assert c.landed and c.request_arm(False, t) == (ACCEPTED, "disarmed")
    assert (c.armed, c.system_status) == (False, MAV_STATE_STANDBY)


def test_armed_on_the_ground_it_disarms_itself():
    c = Px4Commander(PARAMS)
    c.request_arm(True, 1.0)
    c.tick(1.0 + PARAMS["disarm_preflight_s"] - 0.01, GROUND)
    assert c.armed
    c.tick(1.0 + PARAMS["disarm_preflight_s"], GROUND)
    assert not c.armed and "auto-disarm" in c.events[-1][1]
    c = Px4Commander(PARAMS)
    t = flying(c)
    c.tick(t + 1.0, GROUND)                               # touchdown
    detected = t + 1.0 + PARAMS["land_detector_s"]
    c.tick(detected, GROUND)
    c.tick(detected + PARAMS["disarm_after_land_s"] - 0.01, GROUND)
    assert c.armed
    c.tick(detected + PARAMS["disarm_after_land_s"], GROUND)
    assert not c.armed


# ----- take-off, landing, the land detector ----------------------------------------------------------------------
def test_take_off_and_land_commands_switch_the_mode():
    c = Px4Commander(PARAMS)
    assert c.request_takeoff(0.5) == (ACCEPTED, "AUTO.TAKEOFF: arm to climb")
    assert c.mode == AUTO_TAKEOFF and c.guided
    c.takeoff_complete(3.0)
    assert c.mode == AUTO_LOITER
    assert c.request_land(4.0) == (ACCEPTED, "landing") and c.mode == AUTO_LAND
    c = Px4Commander(PARAMS)
    flying(c)
    assert c.request_takeoff(2.0)[0] == TEMPORARILY_REJECTED      # in the air
    c = Px4Commander(PARAMS)
    c.tick(0.0, VehicleStatus(position_valid=False))
    assert c.request_takeoff(0.1) == (TEMPORARILY_REJECTED, "no valid position estimate")


def test_the_land_detector_reports_the_ground_a_while_after_the_contact():
    c = Px4Commander(PARAMS)
    assert c.landed
    t = flying(c)
    assert not c.landed and c.flown_since_armed
    c.tick(t + 2.0, GROUND)
    assert not c.landed
    c.tick(t + 2.0 + PARAMS["land_detector_s"], GROUND)
    assert c.landed
    c.tick(t + 4.0, VehicleStatus(on_ground=False, crashed=True))  # a crash is on the ground at once
    assert c.landed


# ----- the pilot and the other modes -------------------------------------------------------------------------------
def test_the_pilot_takes_the_drone_by_switching_the_mode_away_from_offboard():
    c = Px4Commander(PARAMS)
    t = flying(c)
    assert c.request_mode(POSCTL, t + 0.01, source="pilot")
    assert c.mode == POSCTL and c.manual_input and "pilot" in c.events[-1][1]
    c.tick(t + 0.5, AIR)
    c.tick(t + 5.0, AIR)                                # the stream stopped: no failsafe outside OFFBOARD
    assert (c.mode, c.failsafe) == (POSCTL, None)
    assert not c.request_mode(OFFBOARD, t + 5.0, source="pilot")   # nor back to OFFBOARD without a stream


@pytest.mark.parametrize("mode, guided, manual", [(MANUAL, False, True), (STABILIZED, False, True),
                                                  (ALTCTL, False, True), (POSCTL, True, True),
                                                  (AUTO_LOITER, True, False), (AUTO_LAND, True, False)])
def test_the_heartbeats_guided_and_manual_input_flags(mode, guided, manual):
    c = Px4Commander(PARAMS)
    assert c.request_mode(mode, 0.1)
    assert (c.guided, c.manual_input) == (guided, manual)


@pytest.mark.parametrize("mode, why", [("FOO", "unknown mode"), (AUTO_RTL, "not emulated"), ("ACRO", "not emulated")])
def test_modes_it_cannot_fly_are_refused(mode, why):
    c = Px4Commander(PARAMS)
    assert not c.request_mode(mode, 0.1) and c.mode == POSCTL and why in c.events[-1][1]


def test_losing_the_position_estimate_falls_back_or_lands():
    c = Px4Commander(PARAMS)
    flying(c)
    c.request_mode(POSCTL, 1.0)
    c.tick(1.1, VehicleStatus(on_ground=False, airborne_control=True, position_valid=False))
    assert (c.mode, c.failsafe) == (ALTCTL, FAILSAFE_POSITION_LOSS)
    c = Px4Commander(PARAMS)
    t = flying(c)
    streaming(c, t, 0.5)
    c.tick(t + 0.45, VehicleStatus(on_ground=False, airborne_control=True, position_valid=False))
    assert (c.mode, c.failsafe) == (AUTO_LAND, FAILSAFE_POSITION_LOSS)


def test_an_empty_battery_lands():
    c = Px4Commander(PARAMS)
    t = flying(c)
    streaming(c, t, 0.5)
    c.tick(t + 0.45, VehicleStatus(on_ground=False, airborne_control=True, battery=PARAMS["battery_land_percent"]))
    assert (c.mode, c.failsafe) == (AUTO_LAND, FAILSAFE_BATTERY)


# ----- the configuration ------------------------------------------------------------------------------------------
def test_px4_quad_parameters_are_checked():
    with pytest.raises(ConfigError, match="px4_quad/inertia"):
        load_sim_config(CONFIG, {"drone_model": "px4_quad", "px4_quad": {"inertia": [0.02, 0.02]}})
    with pytest.raises(ConfigError, match="cannot lift"):
        load_sim_config(CONFIG, {"px4_quad": {"max_rotor_thrust": 4.0}})
    with pytest.raises(ConfigError, match="px4_quad/initial_mode"):
        load_sim_config(CONFIG, {"px4_quad": {"initial_mode": "OFFBOARD"}})


def test_every_px4_quad_key_is_commented_with_its_meaning_and_unit_in_sim_yaml():
    comments, key, inside = {}, None, False
    with open(CONFIG) as stream:
        for line in stream:
            if re.match(r"^px4_quad:", line):
                inside = True
            elif inside and re.match(r"^\S", line):
                break
            elif inside and re.match(r"^  ([a-z_0-9]+):", line):
                key = re.match(r"^  ([a-z_0-9]+):", line).group(1)
                comments[key] = line.partition("#")[2].strip()
            elif inside and key and re.match(r"^\s+#", line):
                comments[key] += " " + line.strip().lstrip("#").strip()
    assert set(comments) == set(PARAMS)
    unitless = [k for k, text in comments.items() if not re.search(r"\[[^\]]+\]$", text) or len(text) < 20]
    assert unitless == [], "keys without a meaning and a [unit] at the end of their comment"


# ----- flights -------------------------------------------------------------------------------------------------------
def make_sim(realism="ideal", seed=1, vehicle="summit_xl", **overrides):
    overrides.setdefault("realism", {"profile": realism})
    overrides["drone_model"] = "px4_quad"
    return Simulator(load_sim_config(CONFIG, overrides), os.path.join(PKG, "models", "world_%s.xml" % vehicle),
                     vehicle, seed)


def run(sim, seconds, setpoint=None, every=5, until=None):
    """Step ``seconds``, sending ``setpoint`` every ``every`` steps (20 ms: 50 Hz) unless it is None."""
    for i in range(int(round(seconds / sim.dt))):
        if setpoint is not None and i % every == 0:
            sim.px4_world.send_setpoint(setpoint)
        sim.step()
        if until is not None and until(sim):
            return True
    return False


def velocity(vx, vy, vz, yaw_rate=0.0):
    return Setpoint.velocity(vx, vy, vz, yaw_rate)[0]


def offboard_airborne(sim, height=3.0):
    """Stream, switch to OFFBOARD, arm, climb ``height`` m above the start."""
    run(sim, 0.3, velocity(0, 0, 0))
    commander = sim.px4_world.commander
    assert commander.request_mode(OFFBOARD, sim.time)
    assert commander.request_arm(True, sim.time)[0] == ACCEPTED
    start = sim.drone_pose()[0][2]
    assert run(sim, 10.0, velocity(0, 0, 1.5), until=lambda s: s.drone_pose()[0][2] > start + height)


def test_the_airframe_is_a_1_8_kg_quadrotor_that_hovers_on_its_thrust():
    sim = make_sim()
    assert sim.autopilot.mass == pytest.approx(1.8)
    assert sim.max_total_thrust == pytest.approx(36.0)
    assert sim.px4_world.local_position()[0] == pytest.approx([0.0, 0.0, 0.0], abs=1e-9)
    offboard_airborne(sim, 2.0)
    run(sim, 2.0, velocity(0, 0, 0))
    assert float(sim.autopilot.motor_thrust.sum()) == pytest.approx(1.8 * 9.81, rel=0.05)


def test_an_offboard_take_off_by_a_climb_set_point_and_the_landed_states_on_the_way():
    sim = make_sim()
    states = []
    run(sim, 0.3, velocity(0, 0, 0))
    c = sim.px4_world.commander
    assert c.request_mode(OFFBOARD, sim.time) and c.request_arm(True, sim.time)[0] == ACCEPTED
    run(sim, 1.0, velocity(0, 0, 0))
    assert sim.autopilot.mode == FlightMode.LANDED and sim.px4_world.landed_state == ON_GROUND  # armed, idle
    for _ in range(150):
        run(sim, 0.02, velocity(0, 0, 1.0))
        states.append(sim.px4_world.landed_state)
    assert states[0] == TAKEOFF and states[-1] == IN_AIR
    assert sim.drone_velocity()[0][2] == pytest.approx(1.0, abs=0.1)
    assert not c.landed and sim.touchdown is None


def test_velocity_set_points_are_flown_in_the_local_enu_frame_up_to_20_m_s():
    sim = make_sim(vehicle="car")
    offboard_airborne(sim, 3.0)
    run(sim, 6.0, velocity(0.0, 5.0, 0.0))         # north (world +y)
    v, _ = sim.drone_velocity()
    assert v[1] == pytest.approx(5.0, abs=0.2) and abs(v[0]) < 0.2
    run(sim, 10.0, velocity(20.0, 0.0, 0.0))        # east at 20 m/s
    v, _ = sim.drone_velocity()
    assert v[0] == pytest.approx(20.0, abs=0.6) and abs(v[2]) < 0.3


def test_a_body_frame_set_point_turns_with_the_heading():
    sim = make_sim()
    offboard_airborne(sim, 2.0)
    run(sim, 2.0, velocity(0, 0, 0, yaw_rate=math.pi / 4))   # about a quarter turn
    sp, _ = Setpoint.from_position_target(8, VELOCITY_AND_YAW_RATE, (0, 0, 0), (3.0, 0.0, 0.0), 0.0, 0.0)
    run(sim, 5.0, sp)
    w, x, y, z = sim.drone_pose()[1]
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    assert yaw == pytest.approx(math.pi / 2, abs=0.3)
    v, _ = sim.drone_velocity()
    assert v[0] == pytest.approx(3.0 * math.cos(yaw), abs=0.2) and v[1] == pytest.approx(3.0 * math.sin(yaw), abs=0.2)


def test_descending_onto_the_pad_lands_and_the_land_detector_follows():
    sim = make_sim()
    offboard_airborne(sim, 1.5)
    c = sim.px4_world.commander
    assert run(sim, 10.0, velocity(0, 0, -0.5), until=lambda s: s.touchdown is not None)
    assert sim.touchdown.surface == SURFACE_PAD and not sim.touchdown.crashed
    touchdown = sim.time
    assert not c.landed and c.request_arm(False, sim.time)[0] == DENIED
    run(sim, PARAMS["land_detector_s"] + 0.1, velocity(0, 0, -0.5))
    assert c.landed and sim.px4_world.landed_state == ON_GROUND and sim.time - touchdown >= PARAMS["land_detector_s"]
    assert c.request_arm(False, sim.time) == (ACCEPTED, "disarmed")


def test_auto_takeoff_climbs_to_the_take_off_altitude_and_holds():
    sim = make_sim()
    run(sim, 0.2)
    c = sim.px4_world.commander
    assert c.request_takeoff(sim.time)[0] == ACCEPTED
    run(sim, 1.0)
    assert sim.autopilot.mode == FlightMode.LANDED          # not armed yet
    start = sim.drone_pose()[0][2]
    assert c.request_arm(True, sim.time)[0] == ACCEPTED
    states = set()
    assert run(sim, 8.0, until=lambda s: states.add(s.px4_world.landed_state) or c.mode == AUTO_LOITER)
    assert TAKEOFF in states
    assert sim.drone_pose()[0][2] - start == pytest.approx(PARAMS["takeoff_altitude"], abs=0.15)
    run(sim, 2.0)
    assert sim.drone_pose()[0][2] - start == pytest.approx(PARAMS["takeoff_altitude"], abs=0.15)


def test_the_pilot_takeover_holds_the_position_whatever_the_set_points_say():
    sim = make_sim()
    offboard_airborne(sim, 2.0)
    run(sim, 1.0, velocity(0, 0, 0))
    assert sim.inject_fault("pilot_takeover", 0.0)
    c = sim.px4_world.commander
    assert c.mode == POSCTL
    here = sim.drone_pose()[0].copy()
    run(sim, 3.0, velocity(3.0, 0.0, 0.0))
    assert c.mode == POSCTL
    assert abs(sim.drone_pose()[0][0] - here[0]) < 0.3


def test_the_set_points_stopping_mid_flight_hold_then_land_where_it_is():
    sim = make_sim()
    offboard_airborne(sim, 2.0)
    run(sim, 1.0, velocity(0, 0, 0))
    c = sim.px4_world.commander
    run(sim, 1.2)
    assert (c.mode, c.failsafe) == (AUTO_LOITER, FAILSAFE_OFFBOARD_LOSS)
    here = sim.drone_pose()[0].copy()
    run(sim, PARAMS["offboard_loss_hold_s"])
    assert c.mode == AUTO_LAND and sim.px4_world.landed_state == LANDING
    assert run(sim, 10.0, until=lambda s: s.touchdown is not None)
    assert math.hypot(*(sim.drone_pose()[0][:2] - here[:2])) < 0.3
    run(sim, PARAMS["land_detector_s"] + PARAMS["disarm_after_land_s"] + 0.1)
    assert not c.armed


def test_a_link_loss_stops_the_set_points_and_trips_the_failsafe():
    sim = make_sim()
    offboard_airborne(sim, 2.0)
    sim.inject_fault("link_loss", 2.0)
    run(sim, 1.2, velocity(0, 0, 0))
    assert sim.px4_world.commander.failsafe == FAILSAFE_OFFBOARD_LOSS
    assert sim.px4_world.setpoints_lost > 0


def test_realistic_the_velocity_loop_flies_on_its_estimate():
    sim = make_sim("realistic", seed=3, vehicle="car")
    offboard_airborne(sim, 3.0)
    errors = []
    for _ in range(40):
        run(sim, 0.1, velocity(8.0, 0.0, 0.0))
        estimate = sim.px4_world.estimate()[1]
        errors.append(abs(estimate[0] - sim.drone_velocity()[0][0]))
    assert max(errors[-20:]) < 0.4                    # the estimate is close, not perfect
    assert max(errors) > 0.005
    v, _ = sim.drone_velocity()
    assert v[0] == pytest.approx(8.0, abs=0.5)
