"""Every transition of the take-off / tracking / landing state machine, the landing gate, re-tries,
the lost target and force_land, on hand-made inputs (no physics)."""
import math

import numpy as np
import pytest

from platform_tracking.controller import DroneState, PadPrediction
from platform_tracking.params import TrackingParams
from platform_tracking.state_machine import Inputs, Nav, State, TrackingStateMachine

P = TrackingParams()
PAD_Z = 0.497


def z_at(height):
    """base_link altitude for a feet height ``height`` above the pad."""
    return height + PAD_Z + P.foot_clearance


def drone(x=0.0, y=0.0, height=4.0, vx=0.0, vy=0.0, yaw=0.0, sonar=None):
    return DroneState(np.array([x, y, z_at(height)]), np.array([vx, vy, 0.0]), yaw, sonar)


def pad(t, x=0.0, y=0.0, vx=0.0, vy=0.0, age=0.05):
    """A prediction stamped ``age`` s before ``t`` whose pad is at (x, y) *at t*."""
    stamp = t - age
    start = np.array([x - vx * age, y - vy * age, PAD_Z])
    velocity = np.array([vx, vy, 0.0])
    times = [stamp + 0.1 * k for k in range(21)]
    return PadPrediction(stamp, start, velocity, times, [start + velocity * (tk - stamp) for tk in times])


class Flight:
    """Drives a state machine step by step at 30 Hz."""

    def __init__(self, **params):
        self.lines = []
        self.sm = TrackingStateMachine(TrackingParams(**params), logger=self.lines.append)
        self.t = 0.0
        self.out = None

    def step(self, dt=1.0 / 30.0, **kw):
        self.t += dt
        kw.setdefault("navdata_state", Nav.HOVERING)
        kw.setdefault("vision_age", 0.03)  # the camera sees the pad unless a test says otherwise
        self.out = self.sm.step(Inputs(self.t, **kw))
        return self.out

    def run(self, seconds, make=None, **kw):
        """Steps for ``seconds``; ``make(t)`` may return extra inputs per step."""
        outs = []
        end = self.t + seconds
        while self.t < end - 1e-9:
            extra = dict(kw)
            if make is not None:
                extra.update(make(self.t + 1.0 / 30.0))
            outs.append(self.step(**extra))
        return outs

    @property
    def state(self):
        return self.sm.state


def tracking_flight(**params):
    """A flight brought to TRACKING at the nominal height above a still pad."""
    f = Flight(**params)
    f.step(drone=drone(height=0.02, sonar=0.02), navdata_state=Nav.LANDED, takeoff=True)
    f.step(drone=drone(height=4.0), pad=pad(f.t + 1 / 30), navdata_state=Nav.FLYING)
    assert f.state == State.TRACKING
    return f


def landing_flight(height=2.0, **params):
    f = tracking_flight(**params)
    f.step(drone=drone(height=height), pad=pad(f.t + 1 / 30), land=True)
    assert f.state == State.LANDING
    return f


def fresh(x=0.0, y=0.0, vx=0.0, vy=0.0, **drone_kw):
    """Input maker: drone as given, fresh prediction of a pad at (x, y)."""
    return lambda t: {"drone": drone(**drone_kw), "pad": pad(t, x, y, vx, vy)}


# ----- LANDED --------------------------------------------------------------------------------------
def test_landed_commands_nothing_and_logs_transitions_as_a_arrow_b_with_reason():
    f = Flight()
    out = f.step(drone=drone(height=0.02), navdata_state=Nav.LANDED)
    assert out.state == State.LANDED and out.command is None and not out.send_takeoff
    f.step(drone=drone(height=0.02), navdata_state=Nav.LANDED, takeoff=True)
    assert f.lines == ["LANDED -> TAKING_OFF (take-off requested)"]


def test_landed_to_taking_off_sends_takeoff_and_climbs_at_one_metre_per_second():
    f = Flight()
    out = f.step(drone=drone(height=0.02, sonar=0.02), navdata_state=Nav.LANDED, takeoff=True)
    assert out.state == State.TAKING_OFF and out.send_takeoff
    assert out.command.vz == pytest.approx(P.takeoff_climb_rate)
    out = f.step(drone=drone(height=0.5), navdata_state=Nav.TAKING_OFF)
    assert not out.send_takeoff and out.command.vz == pytest.approx(1.0)


def test_takeoff_when_already_airborne_does_not_send_takeoff():
    f = Flight()
    out = f.step(drone=drone(height=1.0), navdata_state=Nav.HOVERING, takeoff=True)
    assert out.state == State.TAKING_OFF and not out.send_takeoff
    assert "already airborne" in f.lines[-1]


def test_takeoff_waits_for_the_state_estimate():
    f = Flight()
    out = f.step(drone=None, navdata_state=Nav.LANDED, takeoff=True)
    assert out.state == State.LANDED and not out.send_takeoff
    out = f.step(drone=drone(height=0.02), navdata_state=Nav.LANDED)
    assert out.state == State.TAKING_OFF and out.send_takeoff


def test_land_request_while_landed_is_ignored():
    f = Flight()
    out = f.step(drone=drone(height=0.02), navdata_state=Nav.LANDED, land=True)
    assert out.state == State.LANDED and not out.send_land and not f.sm.land_pending


# ----- TAKING_OFF ----------------------------------------------------------------------------------
def test_taking_off_gives_up_when_the_drone_never_leaves_the_ground():
    f = Flight()
    f.step(drone=drone(height=0.02), navdata_state=Nav.LANDED, takeoff=True)
    f.run(P.takeoff_timeout - 0.1, drone=drone(height=0.02), navdata_state=Nav.LANDED)
    assert f.state == State.TAKING_OFF
    f.run(0.2, drone=drone(height=0.02), navdata_state=Nav.LANDED)
    assert f.state == State.LANDED and "not acknowledged" in f.lines[-1]


def test_taking_off_sends_the_take_off_again_while_the_drone_stays_on_the_ground():
    f = Flight()
    first = f.step(drone=drone(height=0.02), navdata_state=Nav.LANDED, takeoff=True)
    outs = f.run(P.takeoff_timeout - 0.1, drone=drone(height=0.02), navdata_state=Nav.LANDED)
    resent = [o for o in outs if o.send_takeoff]
    assert first.send_takeoff and len(resent) == int(P.takeoff_timeout / P.takeoff_resend_interval - 1e-9)
    assert any("sending it again" in line for line in f.lines)
    # Once the drone answers, nothing more is sent.
    outs = f.run(1.5, drone=drone(height=0.3), navdata_state=Nav.TAKING_OFF)
    assert not any(o.send_takeoff for o in outs) and f.state == State.TAKING_OFF


def test_taking_off_tracks_the_pad_horizontally_while_climbing():
    f = Flight()
    f.step(drone=drone(height=0.02), navdata_state=Nav.LANDED, takeoff=True)
    out = f.step(drone=drone(height=1.0, vx=2.0), pad=pad(f.t + 1 / 30, vx=2.0), navdata_state=Nav.TAKING_OFF)
    assert out.state == State.TAKING_OFF
    assert out.command.vx == pytest.approx(2.0, abs=0.1) and out.command.vz == pytest.approx(1.0)


def test_taking_off_to_tracking_at_the_nominal_height_with_the_pad_in_sight():
    f = Flight()
    f.step(drone=drone(height=0.02), navdata_state=Nav.LANDED, takeoff=True)
    out = f.step(drone=drone(height=3.5), pad=pad(f.t + 1 / 30), navdata_state=Nav.FLYING)
    assert out.state == State.TAKING_OFF
    out = f.step(drone=drone(height=3.95), pad=pad(f.t + 1 / 30), navdata_state=Nav.FLYING)
    assert out.state == State.TRACKING and "nominal height" in f.lines[-1]


def test_taking_off_to_relocating_at_the_nominal_height_without_a_prediction():
    f = Flight()
    f.step(drone=drone(height=0.02, sonar=0.02), navdata_state=Nav.LANDED, takeoff=True)
    out = f.step(drone=drone(height=4.0), navdata_state=Nav.FLYING)
    assert out.state == State.RELOCATING and "no fresh pad prediction" in f.lines[-1]


def test_takeoff_height_reference_is_the_surface_it_took_off_from_until_the_pad_is_seen():
    """On the car (pad 1.72 m) the configured Summit XL pad height must not end the climb early."""
    f = Flight()
    car_pad = 1.72
    on_pad = DroneState(np.array([0.0, 0.0, car_pad + 0.065 + 0.02]), np.zeros(3), 0.0, 0.02)
    f.step(drone=on_pad, navdata_state=Nav.LANDED, takeoff=True)
    at = lambda h: DroneState(np.array([0.0, 0.0, car_pad + 0.065 + h]), np.zeros(3), 0.0, None)  # noqa: E731
    assert f.step(drone=at(3.0), navdata_state=Nav.FLYING).state == State.TAKING_OFF
    assert f.step(drone=at(4.0), navdata_state=Nav.FLYING).state == State.RELOCATING


# ----- TRACKING ------------------------------------------------------------------------------------
def test_tracking_holds_the_nominal_height():
    f = tracking_flight()
    assert f.step(drone=drone(height=3.0), pad=pad(f.t + 1 / 30)).command.vz > 0.5
    assert f.step(drone=drone(height=5.0), pad=pad(f.t + 1 / 30)).command.vz < -0.5
    assert f.step(drone=drone(height=4.0), pad=pad(f.t + 1 / 30)).command.vz == 0.0


def test_tracking_climbs_for_a_wider_view_while_the_pad_stays_unseen_and_comes_back_once_it_is_seen():
    """The prediction rests on GPS: 4-6 m off in harsh, the pad outside a 4 m view for good."""
    f = tracking_flight()
    early = f.step(drone=drone(height=4.0), pad=pad(f.t + 1 / 30), vision_age=P.search_climb_after - 0.1)
    assert early.command.vz == 0.0
    out = f.step(drone=drone(height=4.0), pad=pad(f.t + 1 / 30), vision_age=P.search_climb_after + 0.1)
    assert out.command.vz > 0.5 and f.state == State.TRACKING
    assert f.lines[-1] == "TRACKING: pad not seen for %.1f s: climbing to %.1f m for a wider view" % (
        P.search_climb_after + 0.1, P.relocate_height)
    logged = len(f.lines)
    f.run(1.0, make=fresh(height=5.0), vision_age=P.search_climb_after + 1.0)
    assert f.out.command.vz > 0.5 and len(f.lines) == logged  # logged once
    assert f.step(drone=drone(height=P.relocate_height), pad=pad(f.t + 1 / 30),
                  vision_age=P.search_climb_after + 2.0).command.vz == 0.0  # holds the wider view
    assert f.step(drone=drone(height=P.relocate_height), pad=pad(f.t + 1 / 30)).command.vz < -0.5  # seen: back down
    never = tracking_flight()
    assert never.step(drone=drone(height=4.0), pad=pad(never.t + 1 / 30), vision_age=None).command.vz > 0.5
    assert "pad not seen for ever" in never.lines[-1]


def test_tracking_closes_an_along_track_gap_more_gently_the_later_the_camera_sees():
    """The camera latency of the inputs reaches the controller: a pad 0.3 m ahead along its travel (+x, at the
    drone's own 1 m/s) is closed at along_track_gain in realistic's 0.1 s, at along_track_gain_latency / 0.2 in
    harsh's 0.2 s."""
    commands = {}
    for latency in (0.1, 0.2):
        f = tracking_flight()
        commands[latency] = f.step(drone=drone(vx=1.0), pad=pad(f.t + 1 / 30, x=0.3, vx=1.0),
                                   camera_latency=latency).command.vx
    gain_drop = P.along_track_gain - P.along_track_gain_latency / 0.2
    assert gain_drop > 0.5
    assert commands[0.1] - commands[0.2] == pytest.approx(gain_drop * 0.3, abs=0.02)


def test_tracking_flies_the_cameras_view_centre_over_the_pad_while_the_pad_is_unseen():
    """Tilted 18 deg (body z towards +x, as into a car's air stream), the camera looks 1.3 m behind the drone at
    4 m: while the pad is unseen the command moves the drone forward of the predicted pad until the view is on
    it; with the pad seen the drone itself goes above it."""
    tilt = np.array([-math.tan(math.radians(18.0)), 0.0])  # view shift per metre of height

    def tilted(t):
        state = drone(height=4.0)
        state.view_shift = tilt
        return {"drone": state, "pad": pad(t)}
    seen = tracking_flight()
    seen.run(1.0, make=tilted)
    assert abs(seen.out.command.vx) < 0.05  # above the pad: nothing to do
    unseen = tracking_flight()
    outs = unseen.run(1.0, make=tilted, vision_age=None)
    assert unseen.state == State.TRACKING
    assert outs[-1].command.vx > 0.5  # forward, yaw 0: towards where the camera sees the pad
    assert outs[0].command.vx > 0.5  # never seen at all counts as unseen
    late = tracking_flight(search_view_after=5.0)  # seen 1 s ago: within search_view_after, the drone above it
    late.run(1.0, make=tilted, vision_age=1.0)
    assert abs(late.out.command.vx) < 0.05


def test_tracking_to_relocating_when_the_prediction_is_older_than_lost_timeout():
    f = tracking_flight()
    last = pad(f.t)
    f.run(P.lost_timeout - 0.1, drone=drone(), pad=last)
    assert f.state == State.TRACKING
    f.run(0.2, drone=drone(), pad=last)
    assert f.state == State.RELOCATING and "target lost" in f.lines[-1]


def test_tracking_to_landing_after_min_tracking_time_once_settled():
    f = tracking_flight()
    f.run(P.min_tracking_time - 0.2, make=fresh(x=0.1))
    assert f.state == State.TRACKING
    f.run(0.4, make=fresh(x=0.1))
    assert f.state == State.LANDING and "tracked" in f.lines[-1]


def test_tracking_does_not_land_while_the_error_is_large():
    f = tracking_flight()
    f.run(P.min_tracking_time + 5.0, make=fresh(x=P.settle_error + 0.1))
    assert f.state == State.TRACKING
    f.run(P.settle_time - 0.1, make=fresh(x=0.0))
    assert f.state == State.TRACKING  # settled, but not for settle_time yet
    f.run(0.2, make=fresh(x=0.0))
    assert f.state == State.LANDING


def test_tracking_without_auto_land_waits_for_the_land_request():
    f = tracking_flight(auto_land=False)
    f.run(P.min_tracking_time + 5.0, make=fresh())
    assert f.state == State.TRACKING
    f.step(drone=drone(), pad=pad(f.t + 1 / 30), land=True)
    assert f.state == State.LANDING and "land requested" in f.lines[-1]


def test_land_request_waits_while_landing_is_not_allowed():
    f = tracking_flight(auto_land=False)
    f.step(drone=drone(), pad=pad(f.t + 1 / 30), land=True, landing_allowed=False)
    f.run(2.0, make=fresh(), landing_allowed=False)
    assert f.state == State.TRACKING
    assert sum("not allowed" in line for line in f.lines) == 1  # said once, not at 30 Hz
    f.step(drone=drone(), pad=pad(f.t + 1 / 30), landing_allowed=True)
    assert f.state == State.LANDING


def test_land_request_during_take_off_lands_as_soon_as_tracking_starts():
    f = Flight()
    f.step(drone=drone(height=0.02), navdata_state=Nav.LANDED, takeoff=True)
    f.step(drone=drone(height=1.0), pad=pad(f.t + 1 / 30), navdata_state=Nav.FLYING, land=True)
    f.step(drone=drone(height=4.0), pad=pad(f.t + 1 / 30), navdata_state=Nav.FLYING)
    assert f.lines[-2:] == ["TAKING_OFF -> TRACKING (nominal height 4.0 m reached, pad in sight)",
                            "TRACKING -> LANDING (land requested)"]


# ----- RELOCATING ----------------------------------------------------------------------------------
def test_relocating_climbs_and_follows_the_last_prediction_then_waits_at_its_end():
    f = tracking_flight()
    last = pad(f.t, x=0.0, vx=2.0, age=0.0)     # path reaches 2 s ahead: x = 4 m
    f.run(P.lost_timeout + 0.1, drone=drone(), pad=last)
    assert f.state == State.RELOCATING
    out = f.step(drone=drone(x=1.0, height=4.0), pad=last)
    assert out.command.vz > 0.5                 # up to relocate_height for a wider view
    assert out.command.vx > 1.5                 # still following the prediction's motion
    f.run(2.0, drone=drone(x=4.0, height=P.relocate_height), pad=last)
    out = f.step(drone=drone(x=4.0, height=P.relocate_height), pad=last)
    assert out.command.vx == pytest.approx(0.0, abs=0.05) and out.command.vz == 0.0  # at the end: wait


def test_relocating_with_nothing_ever_seen_hovers_in_place():
    f = Flight()
    f.step(drone=drone(height=0.02), navdata_state=Nav.LANDED, takeoff=True)
    out = f.step(drone=drone(x=5.0, height=4.0), navdata_state=Nav.FLYING)
    assert out.state == State.RELOCATING
    assert (out.command.vx, out.command.vy) == (0.0, 0.0) and out.command.vz > 0.0


def test_relocating_to_tracking_needs_a_prediction_younger_than_found_max_age():
    f = tracking_flight()
    f.run(P.lost_timeout + 0.1, drone=drone(), pad=pad(f.t))
    assert f.state == State.RELOCATING
    f.step(drone=drone(), pad=pad(f.t + 1 / 30, age=P.found_max_age + 0.1))
    assert f.state == State.RELOCATING
    f.step(drone=drone(), pad=pad(f.t + 1 / 30, age=0.05))
    assert f.state == State.TRACKING and "pad seen again" in f.lines[-1]


def test_lost_target_during_landing_relocates():
    f = landing_flight()
    last = pad(f.t)
    f.run(P.lost_timeout + 0.1, drone=drone(height=2.0), pad=last)
    assert f.state == State.RELOCATING and "lost during the descent" in f.lines[-1]


# ----- LANDING -------------------------------------------------------------------------------------
def test_landing_descends_at_the_landing_rate_while_the_error_is_small():
    f = landing_flight()
    out = f.step(drone=drone(height=2.0), pad=pad(f.t + 1 / 30, x=0.1))
    assert out.command.vz == pytest.approx(-P.landing_descent_rate)


def test_landing_stops_descending_while_the_error_or_relative_speed_is_too_large():
    f = landing_flight()
    out = f.step(drone=drone(height=2.0), pad=pad(f.t + 1 / 30, x=0.8))   # descend < 0.8 < hold
    assert out.command.vz == 0.0 and f.state == State.LANDING
    out = f.step(drone=drone(height=2.0, vx=-1.0), pad=pad(f.t + 1 / 30))   # closing at 1 m/s
    assert out.command.vz == 0.0


def test_the_error_that_still_lets_the_drone_descend_grows_with_its_height():
    """Higher up the camera's view is wider: an error that holds the drone at 1 m does not stop its descent at 3 m."""
    error = P.descend_max_error + P.descend_error_per_metre * 1.0
    for height, expected in ((3.0, -P.landing_descent_rate), (1.0, 0.0)):
        f = landing_flight(height=height)
        out = f.step(drone=drone(height=height), pad=pad(f.t + 1 / 30, x=error))
        assert f.state == State.LANDING and out.command.vz == pytest.approx(expected), height


def test_a_landing_hold_keeps_the_lowest_height_since_the_last_climb_against_the_firmwares_drift():
    """Holding is a height hold on the measured height, not a zero climb rate: the firmware holds its own altitude
    estimate, which drifts with its accelerometer's bias. Short descents between holds do not reset it upwards."""
    f = landing_flight()
    out = f.step(drone=drone(height=2.0), pad=pad(f.t + 1 / 30, x=0.8))   # outside the descent cone: hold at 2.0 m
    assert out.command.vz == 0.0
    out = f.step(drone=drone(height=2.3), pad=pad(f.t + 1 / 30, x=0.8))   # the drone rose 0.3 m meanwhile
    assert out.command.vz == pytest.approx(-0.3 * P.height_gain)
    out = f.step(drone=drone(height=1.9), pad=pad(f.t + 1 / 30, x=0.8))   # lower: held there from now on
    assert out.command.vz == 0.0
    out = f.step(drone=drone(height=2.2), pad=pad(f.t + 1 / 30))            # on target: a short descent...
    assert out.command.vz == pytest.approx(-P.landing_descent_rate)
    out = f.step(drone=drone(height=2.2), pad=pad(f.t + 1 / 30, x=0.8))   # ...and the hold is still at 1.9 m
    assert out.command.vz == pytest.approx(-0.3 * P.height_gain)
    out = f.step(drone=drone(height=1.0), pad=pad(f.t + 1 / 30, x=P.hold_max_error + P.hold_error_per_metre + 0.1))
    assert out.command.vz == pytest.approx(P.retry_climb_rate)              # a deliberate climb...
    out = f.step(drone=drone(height=1.6), pad=pad(f.t + 1 / 30, x=0.8))   # ...and the hold begins where it ended
    assert out.command.vz == 0.0


def test_landing_descends_on_through_the_flows_blend_over_a_fast_vehicle():
    """Where the drone's own velocity half follows the vehicle (flow weight 0.1-0.9) over a car, an error that
    would hold the height elsewhere does not: holding there only lets it grow."""
    for weight, speed, expected in ((0.5, 15.0, -P.blend_descent_rate), (0.0, 15.0, 0.0), (0.5, 2.0, 0.0)):
        f = landing_flight(height=2.5)
        t = f.t + 1 / 30  # the drone 0.9 m behind the pad: outside the descent cone, inside the climbing one
        out = f.step(drone=drone(x=speed * t - 0.9, height=2.5, vx=speed), pad=pad(t, x=speed * t, vx=speed),
                     flow_weight=weight)
        assert f.state == State.LANDING, (weight, speed)
        assert out.command.vz == pytest.approx(expected), (weight, speed)


def test_landing_climbs_while_the_error_is_too_large_for_its_height_then_descends_again():
    f = landing_flight(height=1.0)
    limit = P.hold_max_error + P.hold_error_per_metre * 1.0    # the narrower view lower down
    out = f.step(drone=drone(height=1.0), pad=pad(f.t + 1 / 30, x=limit + 0.05))
    assert f.state == State.LANDING and out.command.vz == pytest.approx(P.retry_climb_rate)
    assert "climbing to keep the pad in view" in f.lines[-1]
    out = f.step(drone=drone(height=3.0), pad=pad(f.t + 1 / 30, x=limit + 0.05))   # higher up it is in view
    assert out.command.vz == 0.0
    out = f.step(drone=drone(height=1.0), pad=pad(f.t + 1 / 30, x=0.0))
    assert out.command.vz == pytest.approx(-P.landing_descent_rate)


def test_landing_climbs_for_a_wider_view_when_the_camera_has_lost_the_pad():
    f = landing_flight(height=1.0)
    out = f.step(drone=drone(height=1.0), pad=pad(f.t + 1 / 30), vision_age=P.vision_timeout + 0.1)
    assert out.command.vz == pytest.approx(P.retry_climb_rate) and "pad not seen" in f.lines[-1]
    out = f.step(drone=drone(height=P.retry_height + 0.5), pad=pad(f.t + 1 / 30), vision_age=None)
    assert out.command.vz == 0.0   # high enough: hold
    assert sum("pad not seen" in line for line in f.lines) == 1   # said once per loss
    out = f.step(drone=drone(height=1.0), pad=pad(f.t + 1 / 30), vision_age=0.03)
    assert out.command.vz == pytest.approx(-P.landing_descent_rate)


def test_landing_back_to_tracking_when_the_error_exceeds_abort_error():
    """...and lands again as soon as the error has settled: the pad's track goes on, min_tracking_time does not
    start again (in harsh each re-try waited 10 s more)."""
    f = tracking_flight()
    f.run(P.min_tracking_time + P.settle_time + 0.2, make=fresh(height=4.0))
    assert f.state == State.LANDING
    f.step(drone=drone(height=2.0), pad=pad(f.t + 1 / 30, x=P.abort_error + 0.1))
    assert f.state == State.TRACKING and "abort_error" in f.lines[-1]
    f.run(P.settle_time + 0.2, make=fresh(height=4.0))
    assert f.state == State.LANDING


def test_higher_up_the_landing_holds_instead_of_aborting_while_the_error_is_within_the_climbs_limit():
    f = tracking_flight()
    f.run(P.min_tracking_time + P.settle_time + 0.2, make=fresh(height=4.0))
    assert f.state == State.LANDING
    height = 4.0
    assert P.abort_error + 0.1 < P.hold_max_error + P.hold_error_per_metre * height
    out = f.step(drone=drone(height=height), pad=pad(f.t + 1 / 30, x=P.abort_error + 0.1))
    assert f.state == State.LANDING and out.command.vz >= 0.0


def test_decisions_go_by_the_drone_not_by_the_view_it_searches_with():
    """The pad unseen for longer than search_view_after: the tracker flies the camera's view centre over it, but
    the errors that decide (here: calling the landing off) are the drone's. Leaning 20 deg in a corner at 4 m the
    view is 1.5 m away, and such an error called a landing off."""
    f = landing_flight(height=4.0)
    state = drone(height=4.0)
    state.view_shift = np.array([-0.37, 0.0])
    out = f.step(drone=state, pad=pad(f.t + 1 / 30, x=0.2), vision_age=P.search_view_after + 0.1)
    assert f.state == State.LANDING and out.error == pytest.approx(0.2, abs=0.01)
    assert out.command.vx > 1.0  # flying the view (1.68 m short of the pad), not the drone (0.2 m)


def test_landing_back_to_tracking_when_the_supervisor_withdraws_permission():
    f = landing_flight()
    f.step(drone=drone(height=2.0), pad=pad(f.t + 1 / 30), landing_allowed=False)
    assert f.state == State.TRACKING and "no longer allowed" in f.lines[-1]


def test_landing_stops_at_the_gate_height_instead_of_descending_blindly():
    f = landing_flight(height=P.gate_height + 0.02)
    out = f.step(drone=drone(height=P.gate_height + 0.02), pad=pad(f.t + 1 / 30, x=0.15))
    assert out.command.vz == 0.0 and not out.send_land  # 0.15 m: outside the gate


def test_touchdown_is_committed_only_after_gate_ready_time_inside_the_gate():
    f = landing_flight(height=P.gate_height)
    f.run(P.gate_ready_time - 0.05, make=fresh(x=0.05, height=P.gate_height))
    assert not f.sm.committed
    outs = f.run(0.2, make=fresh(x=0.05, height=P.gate_height))
    assert f.state == State.LANDING and f.sm.committed and "touchdown committed" in f.lines[-1]
    assert outs[-1].command.vz == pytest.approx(-P.final_descent_rate) and not any(o.send_land for o in outs)


def test_touchdown_may_be_committed_while_still_descending_from_commit_height():
    f = landing_flight(height=P.commit_height)
    outs = f.run(P.gate_ready_time + 0.1, make=fresh(x=0.02, height=P.commit_height - 0.05))
    assert f.sm.committed and outs[-1].command.vz == pytest.approx(-P.final_descent_rate)
    g = landing_flight(height=P.commit_height + 0.2)
    g.run(1.0, make=fresh(x=0.02, height=P.commit_height + 0.2))
    assert not g.sm.committed


def test_below_the_blend_over_a_fast_vehicle_an_older_detection_still_counts_for_the_gate():
    """At the gate over a car at 15 m/s with the drone's flow locked on the pad's texture (weight 0.95) the
    tilted camera has lost the pad's centre 0.5 s ago: the touchdown is committed all the same. Over the ground
    (weight 0) or a slow vehicle the same detection age stops it (the drone climbs for a wider view)."""
    height = P.gate_height
    for weight, speed, commits in ((0.95, 15.0, True), (0.0, 15.0, False), (0.95, 2.0, False)):
        f = landing_flight(height=height)

        def riding(t, speed=speed):
            return {"drone": drone(x=speed * t + 0.02, height=height, vx=speed),
                    "pad": pad(t, x=speed * t, vx=speed)}
        outs = f.run(P.gate_ready_time + 0.1, make=riding, flow_weight=weight, vision_age=0.5)
        assert f.sm.committed == commits, (weight, speed)
        if not commits:
            assert outs[-1].command.vz > 0.0, (weight, speed)


def test_over_a_fast_vehicle_the_gate_counts_what_the_prediction_may_have_drifted_since_the_pad_was_seen():
    """Locked over a car at 15 m/s, 0.03 m off: with the pad seen 0.3 s ago the touchdown is committed; 0.65 s ago
    (a harsh flight once touched down 0.22 m off so), the drift it may hold (blind_drift_per_speed x 15 m/s x 0.55 s)
    puts the error over gate_error and the drone waits at the gate."""
    height = P.gate_height
    for vision_age, commits in ((0.3, True), (0.65, False)):
        f = landing_flight(height=height)

        def riding(t):
            return {"drone": drone(x=15.0 * t + 0.03, height=height, vx=15.0), "pad": pad(t, x=15.0 * t, vx=15.0)}
        f.run(P.gate_ready_time + 0.1, make=riding, flow_weight=0.95, vision_age=vision_age)
        assert f.sm.committed == commits, vision_age
    assert 0.03 + P.blind_drift_per_speed * 15.0 * (0.65 - P.gate_vision_age) > P.gate_error


def test_over_a_fast_vehicle_the_tracker_flies_the_cameras_view_over_the_pad_below_aim_height():
    """Leaning into a car's air stream the camera looks 0.32 m behind the drone per metre of height. At the gate
    over a car at 15 m/s the drone right above the pad is 0.11 m short of where its camera sees the pad's centre;
    0.11 m ahead it is on target and commits. Higher up the lead is that of aim_height; over a slow vehicle none."""
    shift = np.array([-0.32, 0.0])

    def leaning(x, height, vx):
        state = drone(x=x, height=height, vx=vx)
        state.view_shift = shift
        return state

    for height, speed, lead in ((P.gate_height, 15.0, 0.32 * P.gate_height), (2.0, 15.0, 0.32 * P.aim_height),
                                (P.gate_height, 2.0, 0.0)):
        f = landing_flight(height=height)
        t = f.t + 1 / 30
        out = f.step(drone=leaning(speed * t, height, speed), pad=pad(t, x=speed * t, vx=speed), flow_weight=0.95)
        assert out.error == pytest.approx(lead if speed > P.blend_min_pad_speed else 0.0, abs=0.01), (height, speed)
    f = landing_flight(height=P.gate_height)

    def ahead(t):
        return {"drone": leaning(15.0 * t + 0.32 * P.gate_height, P.gate_height, 15.0),
                "pad": pad(t, x=15.0 * t, vx=15.0)}
    f.run(P.gate_ready_time + 0.1, make=ahead, flow_weight=0.95)
    assert f.sm.committed
    # The lead follows the steady lean, not each acceleration's: leaning twice as far for 0.1 s moves it by 5 %.
    f = landing_flight(height=2.0)
    state = leaning(0.0, 2.0, 15.0)
    f.run(3.0, make=lambda t: {"drone": state, "pad": pad(t, vx=15.0)}, flow_weight=0.95)
    state = leaning(0.0, 2.0, 15.0)
    state.view_shift = 2.0 * shift
    outs = f.run(0.1, make=lambda t: {"drone": state, "pad": pad(t, vx=15.0)}, flow_weight=0.95)
    assert outs[-1].error == pytest.approx(0.32 * P.aim_height, rel=0.06)


def test_where_the_flow_sees_the_pad_alone_the_relative_track_places_the_pad():
    """The world-frame prediction has the pad right below the drone, the relative track (carried by the flow since
    the latest fix) 0.3 m ahead of it: with the flow's weight at 0.95 the tracker believes the track and flies
    towards it; at 0.5 (the flow also sees the ground) it keeps to the prediction."""
    for weight, expected in ((0.95, 0.3), (0.5, 0.0)):
        f = landing_flight(height=1.0)
        out = f.step(drone=drone(height=1.0, vx=1.0), pad=pad(f.t + 1 / 30, vx=1.0), flow_weight=weight,
                     relative=(np.array([0.3, 0.0]), np.array([0.0, 0.0])))
        assert out.error == pytest.approx(expected, abs=1e-6), weight
        if expected:
            assert out.command.vx > 0.3


def test_ardrone_land_is_sent_at_land_height_during_the_final_descent():
    f = landing_flight(height=P.gate_height)
    f.run(P.gate_ready_time + 0.1, make=fresh(height=P.gate_height))
    out = f.step(drone=drone(height=0.2), pad=pad(f.t + 1 / 30))
    assert not out.send_land and out.command.vz == pytest.approx(-P.final_descent_rate)
    out = f.step(drone=drone(height=P.land_height - 0.01), pad=pad(f.t + 1 / 30))
    assert out.send_land and out.command.vz == 0.0 and "ardrone/land sent" in f.lines[-1]


def test_final_descent_is_called_off_when_the_error_grows():
    f = landing_flight(height=P.gate_height)
    f.run(P.gate_ready_time + 0.1, make=fresh(height=P.gate_height))
    out = f.step(drone=drone(height=0.25), pad=pad(f.t + 1 / 30, x=P.commit_abort_error + 0.05))
    assert not out.send_land and out.command.vz == pytest.approx(P.retry_climb_rate)
    assert "commit_abort_error" in f.lines[-1] and not f.sm.committed


def test_final_descent_is_not_called_off_once_too_low_to_stop_above_the_pad():
    f = landing_flight(height=P.gate_height)
    f.run(P.gate_ready_time + 0.1, make=fresh(height=P.gate_height))
    low = 0.5 * (P.land_height + P.commit_abort_min_height)
    out = f.step(drone=drone(height=low), pad=pad(f.t + 1 / 30, x=P.commit_abort_error + 0.05))
    assert f.sm.committed and out.command.vz == pytest.approx(-P.final_descent_rate)
    assert out.command.vx > 0.0  # still tracking the pad that draws away


def test_final_descent_is_called_off_when_the_pad_draws_away_though_the_error_is_still_small():
    f = landing_flight(height=P.gate_height)
    f.run(P.gate_ready_time + 0.1, make=fresh(height=P.gate_height))
    error, speed = 0.1, 0.5  # the pad has begun to brake: inside commit_abort_error, growing at 0.5 m/s
    assert error < P.commit_abort_error < error + speed * P.commit_abort_lookahead
    out = f.step(drone=drone(height=0.25, vx=speed), pad=pad(f.t + 1 / 30, x=-error))
    assert not out.send_land and out.command.vz == pytest.approx(P.retry_climb_rate)
    assert "commit_abort_error" in f.lines[-1] and not f.sm.committed
    g = landing_flight(height=P.gate_height)
    g.run(P.gate_ready_time + 0.1, make=fresh(height=P.gate_height))
    out = g.step(drone=drone(height=0.25, vx=-0.2), pad=pad(g.t + 1 / 30, x=-error))  # closing in: carries on
    assert g.sm.committed and out.command.vz == pytest.approx(-P.final_descent_rate)


def test_a_touchdown_called_off_with_the_pad_in_view_waits_at_the_gate_and_commits_again():
    f = landing_flight(height=P.gate_height)
    f.run(P.gate_ready_time + 0.1, make=fresh(height=P.gate_height))
    f.step(drone=drone(height=0.25), pad=pad(f.t + 1 / 30, x=P.commit_abort_error + 0.05))
    assert "back to the gate" in f.lines[-1] and not f.sm.committed and not f.sm.retrying
    out = f.step(drone=drone(height=0.25), pad=pad(f.t + 1 / 30, x=P.commit_abort_error + 0.05))
    assert 0.0 < out.command.vz <= P.landing_descent_rate  # up to the gate height, not to retry_height
    f.run(P.gate_ready_time + 0.1, make=fresh(height=0.25))  # on target again: committed from where it is
    assert f.sm.committed and "touchdown committed" in f.lines[-1]
    g = landing_flight(height=P.gate_height, abort_to_gate=False)
    g.run(P.gate_ready_time + 0.1, make=fresh(height=P.gate_height))
    g.step(drone=drone(height=0.25), pad=pad(g.t + 1 / 30, x=P.commit_abort_error + 0.05))
    assert g.sm.retrying and "climbing from 0.25 m to %.2f m" % P.retry_height in g.lines[-1]


def test_a_committed_descent_that_loses_the_pad_above_blind_height_is_called_off():
    f = landing_flight(height=P.commit_height)
    f.run(P.gate_ready_time + 0.1, make=fresh(height=P.commit_height - 0.05))
    assert f.sm.committed
    out = f.step(drone=drone(height=P.blind_height + 0.1), pad=pad(f.t + 1 / 30), vision_age=P.gate_vision_age + 0.05)
    assert "blind_height" in f.lines[-1] and not f.sm.committed and out.command.vz > 0.0
    g = landing_flight(height=P.commit_height)
    g.run(P.gate_ready_time + 0.1, make=fresh(height=P.commit_height - 0.05))
    out = g.step(drone=drone(height=P.blind_height - 0.1), pad=pad(g.t + 1 / 30), vision_age=0.5)
    assert g.sm.committed and out.command.vz == pytest.approx(-P.final_descent_rate)  # the expected blind end


def test_touchdown_is_not_committed_without_a_fresh_detection():
    f = landing_flight(height=P.gate_height)
    f.run(1.0, make=fresh(height=P.gate_height), vision_age=P.gate_vision_age + 0.05)
    assert not f.sm.committed


def at_the_gate_along_x(x_after, speed_at_stamp, drone_speed):
    """``make(t)`` for Flight.run: the pad ``x_after(dt)`` along x ``dt`` s after t on a prediction stamped
    0.05 s before t, the drone above it at the gate height, flying at ``drone_speed``."""
    def make(t):
        stamp = t - 0.05
        times = [stamp + 0.1 * k for k in range(21)]
        positions = [np.array([x_after(tk - t), 0.0, PAD_Z]) for tk in times]
        prediction = PadPrediction(stamp, positions[0], np.array([speed_at_stamp, 0.0, 0.0]), times, positions)
        return {"drone": drone(height=P.gate_height, vx=drone_speed), "pad": prediction}
    return make


def test_touchdown_waits_while_the_pad_brakes_hard_without_timing_out():
    # A car braking at 3 m/s^2 from 6 m/s, the drone on the pad's current position and speed
    braking = at_the_gate_along_x(lambda dt: 6.0 * dt - 1.5 * dt ** 2, 6.15, 6.0)
    f = landing_flight(height=P.gate_height)
    f.run(P.gate_timeout + 1.0, make=braking)
    assert not f.sm.committed and not f.sm.retrying   # waiting, not giving up
    f.run(P.gate_ready_time + 0.1, make=fresh(height=P.gate_height))
    assert f.sm.committed


def test_touchdown_is_committed_on_a_summit_speed_ramp():
    # The Summit XL speeding up at 1 m/s^2 (back and forth at 3 m/s never runs at a steady speed), the
    # drone keeping up with it: inside the gate.
    ramp = at_the_gate_along_x(lambda dt: 1.0 * dt + 0.5 * dt ** 2, 0.95, 1.0)
    f = landing_flight(height=P.gate_height)
    f.run(P.gate_ready_time + 0.1, make=ramp)
    assert f.sm.committed


def test_touchdown_is_not_committed_into_a_stop_the_prediction_sees_coming():
    # The Summit XL braking at 1 m/s^2 from 0.5 m/s: at rest 0.5 s later, within the final descent.
    moving = lambda dt: min(max(dt, 0.0), 0.5)  # noqa: E731
    stopping = at_the_gate_along_x(lambda dt: 0.5 * moving(dt) - 0.5 * moving(dt) ** 2, 0.5, 0.5)
    f = landing_flight(height=P.gate_height)
    f.run(1.0, make=stopping)
    assert not f.sm.committed


def test_touchdown_is_not_committed_while_the_relative_speed_is_large():
    f = landing_flight(height=P.gate_height)
    outs = f.run(1.0, make=fresh(x=0.02, vx=0.5, height=P.gate_height))   # pad 0.5 m/s faster than the drone
    assert not any(o.send_land for o in outs)


def test_touchdown_is_not_committed_while_the_drone_drifts_off_the_pad_it_is_still_over():
    # 0.07 m off and 0.2 m/s apart (under gate_relative_speed): from the gate, the touchdown comes
    # gate_height / final_descent_rate later, by when the gap has grown past gate_error.
    drift = 0.2
    assert 0.07 + drift * P.gate_height / P.final_descent_rate > P.gate_error
    drifting_off = landing_flight(height=P.gate_height)
    drifting_off.run(1.0, make=fresh(x=0.07, vx=drift, height=P.gate_height))
    assert not drifting_off.sm.committed
    closing_in = landing_flight(height=P.gate_height)
    closing_in.run(1.0, make=fresh(x=0.07, vx=-drift, height=P.gate_height))
    assert closing_in.sm.committed


def test_gate_timeout_starts_a_retry():
    f = landing_flight(height=P.gate_height)
    f.run(P.gate_timeout + 0.1, make=fresh(x=0.15, height=P.gate_height))
    assert "not inside the touchdown gate" in f.lines[-1]
    assert f.step(drone=drone(height=P.gate_height), pad=pad(f.t + 1 / 30)).command.vz == \
        pytest.approx(P.retry_climb_rate)


def committed_flight():
    """Committed and down to land_height: ardrone/land sent."""
    f = landing_flight(height=P.gate_height)
    f.run(P.gate_ready_time + 0.1, make=fresh(height=P.gate_height))
    assert f.sm.committed
    assert f.step(drone=drone(height=P.land_height - 0.02), pad=pad(f.t + 1 / 30)).send_land
    return f


def test_committed_descent_keeps_tracking_horizontally_and_ignores_a_stale_prediction():
    f = tracking_flight(auto_land=False)
    moving = lambda t: {"drone": drone(x=t, height=P.gate_height, vx=1.0), "pad": pad(t, x=t, vx=1.0)}  # noqa: E731
    f.run(1.0, make=moving)
    f.step(land=True, **moving(f.t + 1 / 30))
    f.run(P.gate_ready_time + 0.2, make=moving)
    assert f.sm.committed
    last = pad(f.t, x=f.t, vx=1.0, age=0.0)  # the camera loses the pad this close: the prediction ages
    outs = f.run(1.5, make=lambda t: {"drone": drone(x=t, height=0.2, vx=1.0), "pad": last}, vision_age=None)
    assert f.state == State.LANDING                      # no relocating while committed
    assert outs[-1].command.vx == pytest.approx(1.0, abs=0.1)
    assert outs[-1].command.vz == pytest.approx(-P.final_descent_rate)


def test_committed_land_is_sent_again_when_not_acknowledged():
    f = committed_flight()
    outs = f.run(P.land_ack_timeout + 0.2, make=fresh(height=P.land_height - 0.02), navdata_state=Nav.FLYING)
    assert sum(o.send_land for o in outs) == 1 and "sending it again" in f.lines[-1]


def test_landing_to_landed_on_touchdown():
    f = committed_flight()
    f.step(drone=drone(height=0.1), pad=pad(f.t + 1 / 30), navdata_state=Nav.LANDING)
    out = f.step(drone=drone(height=0.0), pad=pad(f.t + 1 / 30), navdata_state=Nav.LANDED)
    assert out.state == State.LANDED and out.command is None
    assert f.lines[-1] == "LANDING -> LANDED (touchdown: navdata reports LANDED)"


def test_an_external_land_command_makes_the_tracker_follow_the_pad_down():
    f = tracking_flight()
    out = f.step(drone=drone(vx=1.0), pad=pad(f.t + 1 / 30, vx=1.0), navdata_state=Nav.LANDING)
    assert out.state == State.LANDING and f.sm.committed and not out.send_land
    assert out.command.vx == pytest.approx(1.0, abs=0.2)


# ----- FORCE_LANDING and failures ----------------------------------------------------------------
@pytest.mark.parametrize("start", ["taking_off", "tracking", "landing", "relocating"])
def test_force_land_lands_where_it_is_from_every_airborne_state(start):
    if start == "taking_off":
        f = Flight()
        f.step(drone=drone(height=0.02), navdata_state=Nav.LANDED, takeoff=True)
        f.step(drone=drone(height=1.0), navdata_state=Nav.TAKING_OFF)
    elif start == "tracking":
        f = tracking_flight()
    elif start == "landing":
        f = committed_flight()
    else:
        f = tracking_flight()
        f.run(P.lost_timeout + 0.1, drone=drone(), pad=pad(f.t))
    assert f.state.value == start.upper()
    out = f.step(drone=drone(height=1.0), pad=pad(f.t + 1 / 30, vx=3.0), force_land=True)
    assert out.state == State.FORCE_LANDING and out.send_land
    assert (out.command.vx, out.command.vy, out.command.vz) == (0.0, 0.0, 0.0)
    assert "force_land requested" in f.lines[-1]
    f.step(drone=drone(height=0.5), navdata_state=Nav.LANDING)
    out = f.step(drone=drone(height=0.0), navdata_state=Nav.LANDED)
    assert out.state == State.LANDED


def test_force_land_is_sent_again_until_acknowledged_and_ignored_on_the_ground():
    f = tracking_flight()
    f.step(drone=drone(), force_land=True)
    outs = f.run(P.land_ack_timeout + 0.2, drone=drone(), navdata_state=Nav.HOVERING)
    assert sum(o.send_land for o in outs) == 1
    g = Flight()
    out = g.step(drone=drone(height=0.02), navdata_state=Nav.LANDED, force_land=True)
    assert out.state == State.LANDED and not out.send_land and "ignored" in g.lines[-1]


def test_force_land_right_after_take_off_waits_for_the_drone_to_report_landing():
    f = Flight()
    f.step(drone=drone(height=0.02), navdata_state=Nav.LANDED, takeoff=True)
    f.step(drone=drone(height=0.02), navdata_state=Nav.LANDED, force_land=True)
    assert f.step(drone=drone(height=0.02), navdata_state=Nav.LANDED).state == State.FORCE_LANDING


def test_crash_reported_by_navdata_ends_in_landed():
    f = tracking_flight()
    out = f.step(drone=drone(), pad=pad(f.t + 1 / 30), navdata_state=Nav.CRASHED)
    assert out.state == State.LANDED and "CRASHED" in f.lines[-1]


def test_without_an_estimate_the_drone_hovers_and_keeps_its_state():
    f = tracking_flight()
    out = f.step(drone=None, pad=pad(f.t + 1 / 30, vx=2.0))
    assert out.state == State.TRACKING
    assert (out.command.vx, out.command.vy, out.command.vz) == (0.0, 0.0, 0.0)


def test_unknown_navdata_during_take_off_counts_as_not_acknowledged():
    f = Flight()
    f.step(drone=drone(height=0.02), navdata_state=Nav.LANDED, takeoff=True)
    f.run(P.takeoff_timeout + 0.1, drone=drone(height=0.02), navdata_state=None)
    assert f.state == State.LANDED


def test_sonar_is_the_height_above_the_pad_only_right_above_it():
    f = tracking_flight()
    out = f.step(drone=drone(height=4.0, sonar=3.8), pad=pad(f.t + 1 / 30))
    assert out.height == pytest.approx(3.8)
    out = f.step(drone=drone(x=1.0, height=4.0, sonar=4.45), pad=pad(f.t + 1 / 30))   # sees the ground
    assert out.height == pytest.approx(4.0)
    out = f.step(drone=drone(height=4.0, sonar=math.inf), pad=pad(f.t + 1 / 30))
    assert out.height == pytest.approx(4.0)



def test_the_take_off_waits_for_the_preflight_check_and_goes_once_it_passes():
    lines = []
    sm = TrackingStateMachine(P, logger=lines.append)
    on_pad = drone(height=0.0, sonar=0.02)
    blocked = "camera calibrated: no camera_info yet -- calibrate the bottom camera"
    out = sm.step(Inputs(0.0, on_pad, None, Nav.LANDED, takeoff=True, takeoff_blocked=blocked))
    assert sm.state == State.LANDED and not out.send_takeoff
    assert any("waits for the pre-flight check: camera calibrated" in line for line in lines)
    out = sm.step(Inputs(0.1, on_pad, None, Nav.LANDED, takeoff_blocked=blocked))
    assert sm.state == State.LANDED and not out.send_takeoff
    out = sm.step(Inputs(0.2, on_pad, None, Nav.LANDED))  # the check passes: the pending take-off goes
    assert sm.state == State.TAKING_OFF and out.send_takeoff
