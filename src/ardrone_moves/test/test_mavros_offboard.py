"""ROS-free tests of the MAVROS adapter's core (ardrone_moves.mavros_offboard): every transition of its state
machine, the refusals and the timeouts, the set-points' frame and mask."""
import logging
import math
import os

import pytest
import yaml

from ardrone_moves.mavros_offboard import (IN_AIR, LANDING, ON_GROUND, TAKEOFF, VELOCITY_YAW_RATE_MASK,
                                           OffboardAdapter, Phase, VelocitySetpoint, heading_to_enu,
                                           validated_parameters)

CONFIG = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "config", "mavros_adapter.yaml")
with open(CONFIG) as _stream:
    PARAMS = yaml.safe_load(_stream)


class Mavros:
    """Feeds an adapter what MAVROS would say, and answers its requests like a cooperative PX4."""

    def __init__(self, adapter, now=0.0):
        self.a, self.now = adapter, now
        self.connected, self.armed, self.mode = True, False, "POSCTL"
        self.landed_state, self.z, self.yaw = ON_GROUND, 0.0, 0.0
        self.requests = []
        self.outputs = []

    def state(self):
        self.a.on_state(self.connected, self.armed, self.mode, self.now)

    def tick(self, seconds=0.0, dt=0.05, answer=True):
        """Advance ``seconds`` in steps of dt: state at every step (as if 20 Hz), position, tick; answer requests."""
        end = self.now + seconds
        while True:
            self.state()
            self.a.on_extended_state(self.landed_state, self.now)
            self.a.on_local_position((0.0, 0.0, self.z), self.yaw, self.now, velocity=(0.0, 0.0, 0.0))
            out = self.a.tick(self.now)
            self.outputs.append(out)
            for request in out.requests:
                self.requests.append(request)
                if answer:
                    self.answer(request)
            if self.now >= end - 1e-9:
                return out
            self.now += dt

    def answer(self, request):
        name, value = request
        if name == "set_mode":
            self.a.on_mode_sent(True, self.now)
            self.mode = value
        else:
            self.a.on_arming_answer(value, True, 0, self.now)
            self.armed = value


def adapter(**overrides):
    return OffboardAdapter(dict(PARAMS, **overrides))


def idle():
    a = adapter()
    m = Mavros(a)
    m.tick()
    assert a.phase == Phase.IDLE
    return a, m


def flying():
    a, m = idle()
    assert a.request_takeoff(m.now) is None
    m.tick(PARAMS["stream_before_offboard_s"] + 0.1)
    assert a.phase == Phase.TAKING_OFF
    m.landed_state = TAKEOFF
    m.z = PARAMS["takeoff_height"]
    m.tick()
    m.landed_state = IN_AIR
    m.tick()
    assert a.phase == Phase.FLYING
    return a, m


def last_transition(a):
    return [text for _, text, _ in a.events if " -> " in text][-1]


# ----- parameters and frames ----------------------------------------------------------------------------------------
def test_the_shipped_parameters_validate_and_every_key_has_a_unit():
    assert set(validated_parameters(PARAMS)) == set(PARAMS) - {"setpoint_rate", "service_timeout_s"}  # (the node's)
    with open(CONFIG) as stream:
        text = stream.read()
    for key in PARAMS:
        line = next(line for line in text.splitlines() if line.startswith(key + ":"))
        assert "#" in line, key
    assert text.count("[") >= len(PARAMS)


@pytest.mark.parametrize("key, value, match", [("takeoff_height", float("nan"), "outside"),
                                               ("mode_attempts", 1.5, "whole number"),
                                               ("land_speed", True, "not a number"),
                                               ("land_battery", 50.0, "must not exceed")])
def test_bad_parameters_are_named(key, value, match):
    with pytest.raises(ValueError, match=match):
        validated_parameters(dict(PARAMS, **{key: value}))
    with pytest.raises(ValueError, match="missing"):
        validated_parameters({k: v for k, v in PARAMS.items() if k != "land_speed"})


def test_set_points_are_enu_velocity_and_yaw_rate_in_the_local_frame():
    frame, mask, velocity, yaw_rate = VelocitySetpoint(1.0, 2.0, 3.0, 0.5).position_target_fields()
    assert (frame, mask, velocity, yaw_rate) == (1, 1479, (1.0, 2.0, 3.0), 0.5)
    assert mask == VELOCITY_YAW_RATE_MASK
    east, north = heading_to_enu(1.0, 0.0, math.pi / 2)     # forward, heading north
    assert (east, north) == pytest.approx((0.0, 1.0))
    east, north = heading_to_enu(0.0, 1.0, 0.0)             # left, heading east
    assert (east, north) == pytest.approx((0.0, 1.0))


# ----- connection -----------------------------------------------------------------------------------------------------
def test_disconnected_until_mavros_state_then_idle_on_the_ground():
    a = adapter()
    assert a.phase == Phase.DISCONNECTED and a.tick(0.0).setpoint is None
    a.on_state(False, False, "", 0.1)
    assert a.phase == Phase.DISCONNECTED
    a.on_state(True, False, "POSCTL", 0.2)
    assert a.phase == Phase.IDLE and last_transition(a) == "disconnected -> idle (connected, disarmed (mode POSCTL))"


def test_a_lost_heartbeat_or_a_silent_mavros_disconnects_and_a_reconnection_resumes():
    a, m = flying()
    m.connected = False
    m.tick()
    assert a.phase == Phase.DISCONNECTED and a.tick(m.now).setpoint is None
    m.connected = True
    m.tick()
    assert a.phase == Phase.FLYING and "connected in OFFBOARD in the air" in last_transition(a)
    a.tick(m.now + PARAMS["state_timeout_s"] + 0.1)
    assert a.phase == Phase.DISCONNECTED and "no mavros/state" in last_transition(a)


@pytest.mark.parametrize("armed, mode, landed, phase", [(True, "POSCTL", IN_AIR, Phase.MANUAL),
                                                        (True, "AUTO.LOITER", IN_AIR, Phase.FAILSAFE),
                                                        (True, "POSCTL", ON_GROUND, Phase.IDLE)])
def test_connecting_to_a_vehicle_someone_else_flies(armed, mode, landed, phase):
    a = adapter()
    a.on_extended_state(landed, 0.0)
    a.on_state(True, armed, mode, 0.1)
    assert a.phase == phase


# ----- take-off ----------------------------------------------------------------------------------------------------
def test_take_off_streams_first_then_offboard_then_arming_then_the_climb():
    a, m = idle()
    assert a.request_takeoff(m.now) is None
    assert a.phase == Phase.STREAMING
    out = m.tick(PARAMS["stream_before_offboard_s"] - 0.1)
    assert out.setpoint == VelocitySetpoint(0.0, 0.0, 0.0, 0.0) and m.requests == []   # streaming, nothing asked
    m.tick(0.2)
    assert m.requests == [("set_mode", "OFFBOARD"), ("arming", True)]
    assert a.phase == Phase.TAKING_OFF
    transitions = [text.split(" (")[0] for _, text, _ in a.events if " -> " in text]
    assert transitions[-4:] == ["idle -> streaming", "streaming -> entering_offboard", "entering_offboard -> arming",
                                "arming -> taking_off"]
    out = m.tick()
    assert out.setpoint.vz == pytest.approx(PARAMS["takeoff_speed"]) and out.setpoint.vx == 0.0
    m.z = PARAMS["takeoff_height"] - 0.5
    assert m.tick().setpoint.vz == pytest.approx(0.5)     # slowing into the height
    m.z = PARAMS["takeoff_height"] - 0.09
    m.tick()
    assert a.phase == Phase.FLYING


def test_take_off_from_a_moving_vehicle_keeps_its_speed_or_flies_the_stacks_command():
    a, m = idle()
    a.request_takeoff(m.now)
    m.answer = lambda request: (a.on_mode_sent(True, m.now), setattr(m, "mode", "OFFBOARD")) \
        if request[0] == "set_mode" else None            # (the arming answer is held back)
    m.tick(PARAMS["stream_before_offboard_s"] + 0.1)
    assert a.phase == Phase.ARMING
    a.on_local_position((0.0, 0.0, 0.0), 0.0, m.now, velocity=(12.0, 1.0, 0.0))   # on the car at 12 m/s
    a.on_state(True, True, "OFFBOARD", m.now)
    sp = a.tick(m.now).setpoint
    assert a.phase == Phase.TAKING_OFF and (sp.vx, sp.vy) == (12.0, 1.0) and sp.vz > 0
    a.on_velocity_command(10.0, 0.0, 0.0, 0.0, m.now)   # the tracker's command wins, turned to ENU
    a.on_local_position((0.0, 0.0, 1.0), math.pi / 2, m.now)
    sp = a.tick(m.now).setpoint
    assert (sp.vx, sp.vy) == pytest.approx((0.0, 10.0)) and sp.vz > 0


@pytest.mark.parametrize("setup, why", [
    (lambda a, m: setattr(a, "position_time", None), "no local position"),
    (lambda a, m: a.on_battery(30.0, m.now), "battery 30 % below 40 %"),
])
def test_take_off_refusals(setup, why):
    a, m = idle()
    setup(a, m)
    assert why in a.request_takeoff(m.now)
    assert a.phase == Phase.IDLE and "take-off refused" in a.events[-1][1]
    a2, _ = flying()
    assert "not on the ground and idle" in a2.request_takeoff(0.0)


def test_offboard_refused_by_the_autopilot_is_asked_again_then_given_up():
    a, m = idle()
    a.request_takeoff(m.now)
    m.answer = lambda request: a.on_mode_sent(True, m.now)   # sent, but PX4 stays in POSCTL
    m.tick(PARAMS["stream_before_offboard_s"] + PARAMS["mode_timeout_s"] * PARAMS["mode_attempts"] + 0.2)
    assert m.requests == [("set_mode", "OFFBOARD")] * PARAMS["mode_attempts"]
    assert a.phase == Phase.IDLE and "OFFBOARD refused by the autopilot" in last_transition(a)
    assert m.tick().setpoint is None                        # it stopped streaming


def test_arming_refused_or_unconfirmed_gives_the_take_off_up():
    a, m = idle()
    a.request_takeoff(m.now)

    def refuse(request):
        if request[0] == "set_mode":
            a.on_mode_sent(True, m.now)
            m.mode = "OFFBOARD"
        else:
            a.on_arming_answer(True, False, 1, m.now)
    m.answer = refuse
    m.tick(PARAMS["stream_before_offboard_s"] + 0.2)
    assert a.phase == Phase.IDLE
    assert last_transition(a) == "arming -> idle (arming refused by the autopilot: result 1 (temporarily rejected))"
    a, m = idle()
    a.request_takeoff(m.now)
    m.answer = lambda request: (a.on_mode_sent(True, m.now), setattr(m, "mode", "OFFBOARD")) \
        if request[0] == "set_mode" else a.on_arming_answer(True, True, 0, m.now)  # accepted, never armed
    m.tick(PARAMS["stream_before_offboard_s"] + PARAMS["arm_timeout_s"] + 0.3)
    assert a.phase == Phase.IDLE and "arming not confirmed" in last_transition(a)
    a, m = idle()
    a.request_takeoff(m.now)
    m.answer = lambda request: (a.on_mode_sent(True, m.now), setattr(m, "mode", "OFFBOARD")) \
        if request[0] == "set_mode" else a.on_service_error("arming", "no COMMAND_ACK", m.now)
    m.tick(PARAMS["stream_before_offboard_s"] + 0.2)
    assert a.phase == Phase.IDLE and "arming failed: no COMMAND_ACK" in last_transition(a)


def test_a_pilots_mode_during_the_arming_stops_the_take_off():
    a, m = idle()
    a.request_takeoff(m.now)
    m.answer = lambda request: (a.on_mode_sent(True, m.now), setattr(m, "mode", "OFFBOARD")) \
        if request[0] == "set_mode" else None
    m.tick(PARAMS["stream_before_offboard_s"] + 0.1)
    assert a.phase == Phase.ARMING
    m.mode = "POSCTL"
    m.tick()
    assert a.phase == Phase.IDLE and "before the take-off" in last_transition(a)


def test_a_land_request_cancels_a_take_off_on_the_ground():
    a, m = idle()
    a.request_takeoff(m.now)
    assert a.request_land(m.now) is None and a.phase == Phase.IDLE


def test_a_slow_take_off_hands_over_to_the_stack_after_its_timeout():
    a, m = idle()
    a.request_takeoff(m.now)
    m.tick(PARAMS["stream_before_offboard_s"] + 0.1)
    m.tick(PARAMS["takeoff_timeout_s"])
    assert a.phase == Phase.FLYING and "not reached" in last_transition(a)


# ----- flying ---------------------------------------------------------------------------------------------------------
def test_flying_relays_the_stacks_heading_frame_commands_as_enu_set_points():
    a, m = flying()
    m.yaw = math.pi / 2       # heading north
    assert a.on_velocity_command(2.0, 1.0, -0.5, 0.2, m.now)
    sp = m.tick().setpoint
    assert (sp.vx, sp.vy, sp.vz, sp.yaw_rate) == pytest.approx((-1.0, 2.0, -0.5, 0.2))
    assert not a.on_velocity_command(float("nan"), 0.0, 0.0, 0.0, m.now)   # NaN: refused, the last one stays
    assert a.rejected_commands == 1
    assert m.tick().setpoint.vy == pytest.approx(2.0)
    m.tick(PARAMS["command_timeout_s"] + 0.05)
    assert m.tick().setpoint == VelocitySetpoint(0.0, 0.0, 0.0, 0.0)        # stale: hold
    a.on_velocity_command(30.0, 0.0, 5.0, 9.0, m.now)
    sp = m.tick().setpoint
    assert math.hypot(sp.vx, sp.vy) == pytest.approx(PARAMS["max_speed"])
    assert (sp.vz, sp.yaw_rate) == (PARAMS["max_climb"], PARAMS["max_yaw_rate"])


def test_non_finite_positions_are_ignored():
    a, m = flying()
    a.on_local_position((float("nan"), 0.0, 1.0), 0.0, m.now)
    assert a.position == (0.0, 0.0, PARAMS["takeoff_height"]) and "non-finite" in a.events[-1][1]


# ----- landing --------------------------------------------------------------------------------------------------------
def test_landing_descends_while_tracking_and_disarms_on_the_reported_touchdown():
    a, m = flying()
    assert a.request_land(m.now) is None and a.phase == Phase.LANDING
    a.on_velocity_command(1.5, 0.0, 0.0, 0.0, m.now)
    sp = m.tick().setpoint
    assert (sp.vx, sp.vz) == pytest.approx((1.5, -PARAMS["land_speed"]))
    m.landed_state = LANDING
    m.tick(1.0)
    assert a.phase == Phase.LANDING
    m.landed_state = ON_GROUND
    refusals = []
    m.answer = lambda request: (refusals.append(request), a.on_arming_answer(False, False, 2, m.now)) \
        if len(refusals) < 1 else (a.on_arming_answer(False, True, 0, m.now), setattr(m, "armed", False))
    m.tick()
    assert a.phase in (Phase.DISARMING, Phase.LANDED)
    assert m.requests[-1] == ("arming", False)
    m.tick(PARAMS["disarm_retry_s"] + 0.1)
    assert a.phase == Phase.LANDED and m.requests.count(("arming", False)) == 2
    assert m.tick().setpoint is None
    assert a.request_takeoff(m.now) is None                  # and again


def test_touching_down_in_flight_disarms_too():
    a, m = flying()
    m.landed_state = ON_GROUND
    m.tick(0.05)
    assert a.phase == Phase.LANDED and "touchdown" in [t for _, t, _ in a.events if " -> disarming" in t][-1]


def test_landing_is_refused_when_the_pilot_or_the_autopilot_has_the_vehicle():
    a, m = flying()
    m.mode = "POSCTL"
    m.tick()
    assert "pilot or the autopilot has the vehicle" in a.request_land(m.now)


def test_a_low_battery_lands_by_itself():
    a, m = flying()
    a.on_battery(PARAMS["land_battery"], m.now)
    assert a.phase == Phase.LANDING and "battery" in last_transition(a)


# ----- mode monitoring and failsafes --------------------------------------------------------------------------------
def test_a_pilots_mode_is_a_manual_takeover_and_commanding_stops():
    a, m = flying()
    m.mode = "POSCTL"
    m.tick()
    assert a.phase == Phase.MANUAL
    assert last_transition(a) == "flying -> manual (pilot takeover: mode POSCTL; commanding stops)"
    assert a.events[-1][2] == logging.WARNING
    assert m.tick().setpoint is None


@pytest.mark.parametrize("mode", ["AUTO.LOITER", "AUTO.LAND", "AUTO.RTL"])
def test_offboard_lost_to_the_autopilots_failsafe_is_reported_and_commanding_stops(mode):
    a, m = flying()
    m.mode = mode
    m.tick()
    assert a.phase == Phase.FAILSAFE and "OFFBOARD lost" in last_transition(a)
    assert a.events[-1][2] == logging.ERROR
    assert m.tick().setpoint is None


def test_disarmed_in_the_air_is_reported():
    a, m = flying()
    m.armed = False
    m.tick()
    assert a.phase == Phase.LANDED and "disarmed in the air" in last_transition(a)


def test_after_a_takeover_resume_streams_first_then_asks_for_offboard_without_arming():
    a, m = flying()
    m.mode = "POSCTL"
    m.tick()
    before = len(m.requests)
    assert a.request_resume(m.now) is None and a.phase == Phase.STREAMING
    a.on_velocity_command(0.0, 0.0, 0.5, 0.0, m.now)
    assert m.tick().setpoint.vz == pytest.approx(0.5)     # in the air: the stack's climb goes out too
    m.tick(PARAMS["stream_before_offboard_s"] + 0.1)
    assert a.phase == Phase.FLYING and m.requests[before:] == [("set_mode", "OFFBOARD")]   # no arming


def test_resume_is_refused_unless_handed_back_in_the_air():
    a, m = flying()
    assert "not handed the vehicle back" in a.request_resume(m.now)
    m.mode = "AUTO.LAND"
    m.landed_state = ON_GROUND
    m.tick()
    assert "not in the air" in a.request_resume(m.now)


def test_a_failsafe_landing_ends_in_landed_once_disarmed():
    a, m = flying()
    m.mode = "AUTO.LAND"
    m.tick()
    m.landed_state, m.armed = ON_GROUND, False
    m.tick()
    assert a.phase == Phase.LANDED and "after the failsafe" in last_transition(a)


# ----- what the stack's navdata says --------------------------------------------------------------------------------
def test_the_reported_state_is_taking_off_from_the_request_and_landing_until_the_ground():
    a, m = idle()
    assert a.reported_landed_state() == ON_GROUND
    a.request_takeoff(m.now)
    assert a.reported_landed_state() == TAKEOFF              # acknowledged at once, motors still off
    m.tick(PARAMS["stream_before_offboard_s"] + 0.1)
    assert a.phase == Phase.TAKING_OFF and a.reported_landed_state() == TAKEOFF
    m.landed_state, m.z = IN_AIR, PARAMS["takeoff_height"]
    m.tick()
    assert a.phase == Phase.FLYING and a.reported_landed_state() == IN_AIR
    a.request_land(m.now)
    assert a.reported_landed_state() == LANDING              # the detector still says IN_AIR
    m.landed_state = ON_GROUND
    m.tick()
    assert a.reported_landed_state() == ON_GROUND


def test_the_reported_state_after_a_takeover_is_the_detectors():
    a, m = flying()
    m.mode = "POSCTL"
    m.tick()
    assert a.reported_landed_state() == IN_AIR
    a.request_resume(m.now)
    assert a.phase == Phase.STREAMING and a.reported_landed_state() == IN_AIR   # resuming in the air: no take-off
