"""Emergency module core (ROS-free): clear of the vehicle, land, report the own estimate until ack."""
import math
import os
import sys

import pytest
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "src"))
from interface.emergency import (EmergencyLanding, EmergencySettings, Phase,  # noqa: E402
                                 SettingsError)
from interface.supervisor import Flight  # noqa: E402


class Drone:
    """A drone hovering at ``altitude`` over the ground (or over a pad ``pad_height`` high), fed to the core."""

    def __init__(self, settings=None, altitude=3.0):
        self.em = EmergencyLanding(settings or EmergencySettings(), log=lambda level, text: None)
        self.t, self.altitude, self.x, self.y = 0.0, altitude, 5.0, -2.0
        self.surface = 0.0       # height of what is below
        self.pad = None          # pad centre in base_link, when the vision sees it
        self.flight = Flight.AIRBORNE
        self.outputs = []
        self.feed()

    def feed(self):
        self.em.on_flight(self.t, self.flight)
        self.em.on_altitude(self.t, self.altitude)
        self.em.on_sonar(self.t, self.altitude - 0.065 - self.surface)
        self.em.on_estimate(self.t, "gps", self.x, self.y)
        if self.pad is not None:
            self.em.on_pad(self.t, *self.pad)

    def run(self, seconds, move=True):
        """Step the core every 0.04 s (the sonar's rate); returns this call's outputs."""
        first = len(self.outputs)
        end = self.t + seconds
        while self.t < end - 1e-9:
            self.t = round(self.t + 0.04, 6)
            self.feed()
            out = self.em.step(self.t)
            self.outputs.append((self.t, out))
            if move and out.cmd is not None and self.pad is not None:
                self.pad = (self.pad[0] - out.cmd[0] * 0.04, self.pad[1] - out.cmd[1] * 0.04)
                if math.hypot(*self.pad) > 1.0:
                    self.surface = 0.0  # beyond the vehicle's edge: the sonar sees the ground
        return [o for _, o in self.outputs[first:]]


def test_settings_file_is_complete_and_checked():
    with open(os.path.join(HERE, "..", "config", "emergency.yaml")) as stream:
        values = yaml.safe_load(stream)
    settings = EmergencySettings.from_mapping(values)
    assert settings.report_period_s == 1.0 and settings.surface_samples == 5
    del values["clear_distance_m"]
    with pytest.raises(SettingsError, match="'clear_distance_m' is missing"):
        EmergencySettings.from_mapping(values)
    with pytest.raises(SettingsError, match="'surface_samples' must be an integer number"):
        EmergencySettings.from_mapping(dict(values, clear_distance_m=1.5, surface_samples=2.5))


def test_ground_below_lands_at_once_and_reports_every_second():
    d = Drone()
    d.em.activate(d.t, "test")
    assert d.em.phase is Phase.DESCENDING
    outs = d.run(3.0)
    assert outs[0].land and outs[0].cmd == (0.0, 0.0)
    reports = [(t, o.report) for t, o in d.outputs if o.report]
    assert [round(t, 2) for t, _ in reports] == [0.04, 1.0, 2.0, 3.0]  # 1 Hz from the activation
    assert reports[0][1][:2] == (5.0, -2.0) and reports[0][1][2] == "gps"
    lands = [t for t, o in d.outputs if o.land]
    assert [round(t, 2) for t in lands] == [0.04, 1.04, 2.04]  # repeated each second until touchdown


def test_pad_below_moves_away_from_it_then_lands():
    d = Drone()
    d.surface, d.pad = 0.497, (0.3, 0.1)     # over the Summit XL's pad, pad slightly ahead
    d.run(0.2)
    d.em.activate(d.t, "test")
    assert d.em.phase is Phase.CLEARING
    first = d.run(0.04)[0]
    assert first.cmd[0] < 0 and first.cmd[1] < 0 and not first.land     # away from the pad
    assert math.hypot(*first.cmd) == pytest.approx(1.0)
    d.run(5.0)
    assert d.em.phase is Phase.DESCENDING
    assert math.hypot(*d.pad) >= 1.5
    assert any(o.land for _, o in d.outputs)


def test_elevated_surface_alone_means_vehicle_below():
    d = Drone()
    d.surface = 1.72                          # the car's roof, pad not seen
    d.feed()
    d.run(0.2, move=False)
    below, why = d.em.vehicle_below(d.t)
    assert below and "1.7" in why
    d.em.activate(d.t, "test")
    out = d.run(0.04, move=False)[-1]
    assert d.em.phase is Phase.CLEARING and out.cmd == (0.0, 1.0)   # pad never seen: sideways


def test_gives_up_clearing_after_max_clearing_s():
    d = Drone(EmergencySettings(max_clearing_s=3.0))
    d.surface = 0.497
    d.run(0.2)
    d.em.activate(d.t, "test")
    d.run(2.9, move=False)
    assert d.em.phase is Phase.CLEARING
    d.run(0.2, move=False)
    assert d.em.phase is Phase.DESCENDING


def test_on_the_ground_reports_the_mean_of_the_fixes_until_ack():
    d = Drone()
    d.em.activate(d.t, "test")
    d.run(1.0)
    d.flight = Flight.LANDED
    noise = [0.3, -0.3, 0.2, -0.2, 0.1, -0.1] * 10
    for i, n in enumerate(noise):
        d.x, d.y = 5.0 + n, -2.0 - n
        d.run(0.2)
    assert d.em.phase is Phase.ON_GROUND
    last = [o.report for _, o in d.outputs if o.report][-1]
    assert last[0] == pytest.approx(5.0, abs=0.05) and last[1] == pytest.approx(-2.0, abs=0.05)
    assert "mean of" in last[2]
    assert all(o.cmd is None for _, o in d.outputs[-5:])     # nothing commanded on the ground
    assert d.em.acknowledge(d.t)
    d.run(3.0)
    assert not any(o.report for t, o in d.outputs if t > d.t - 3.0)


def test_own_estimate_preferred_to_gps_and_stale_estimates_said_so():
    d = Drone()
    d.em.on_estimate(d.t, "odom_estimate", 4.0, -1.0)
    assert d.em.position(d.t) == (4.0, -1.0, "odom_estimate")
    d.em.on_estimate(d.t + 1.0, "gps", 5.1, -2.1)
    assert d.em.position(d.t + 1.5) == (5.1, -2.1, "gps")   # odom_estimate stale: the GPS-like odometry
    empty = EmergencyLanding(EmergencySettings())
    assert empty.position(0.0) is None
    empty.on_estimate(0.0, "gps", 1.0, 2.0)
    assert empty.position(5.0)[2] == "gps, stale by 5.0 s"


def test_activation_on_the_ground_only_reports():
    d = Drone()
    d.flight = Flight.LANDED
    d.feed()
    d.em.activate(d.t, "operator on the pad")
    outs = d.run(1.0)
    assert d.em.phase is Phase.ON_GROUND and not any(o.land or o.cmd for o in outs)
    assert any(o.report for o in outs)


def test_deactivated_it_commands_and_reports_nothing():
    d = Drone()
    d.em.activate(d.t, "test")
    d.run(0.5)
    d.em.deactivate(d.t, "operator took manual control")
    outs = d.run(2.0)
    assert not any(o.cmd or o.land or o.report for o in outs)
