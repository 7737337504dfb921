"""The vehicle's report (summit_xl/gps/odom) from NavSatFix + vel + the controller's odometry, without ROS."""
import math
import os
import sys
from types import SimpleNamespace

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "src"))
sys.path.insert(0, os.path.join(HERE, "..", "..", "navsat_local", "src"))
from navsat_local.enu import LocalFrame  # noqa: E402
from summit_moves.vehicle_report import (UNKNOWN_VARIANCE, ReportSettings, SettingsError,  # noqa: E402
                                         VehicleReporter, fill_odometry, make_report, odom_sample,
                                         velocity_sample, yaw_of_quaternion)

DATUM = (59.395, 24.664, 35.0)
FRAME = LocalFrame(*DATUM)
SETTINGS = ReportSettings()


def stamp(t):
    secs = int(math.floor(t))
    return SimpleNamespace(secs=secs, nsecs=int(round((t - secs) * 1e9)))


def fix_at(t, east, north, status=0, covariance=(6.25, 0, 0, 0, 6.25, 0, 0, 0, 25.0), covariance_type=2):
    lat, lon, alt = FRAME.to_geodetic(east, north, 0.0)
    return SimpleNamespace(header=SimpleNamespace(stamp=stamp(t)), status=SimpleNamespace(status=status),
                           latitude=lat, longitude=lon, altitude=alt, position_covariance=list(covariance),
                           position_covariance_type=covariance_type)


def no_fix_at(t):
    return SimpleNamespace(header=SimpleNamespace(stamp=stamp(t)), status=SimpleNamespace(status=-1),
                           latitude=0.0, longitude=0.0, altitude=0.0, position_covariance=[0.0] * 9,
                           position_covariance_type=0)


def yaw_q(yaw):
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


def diag6(linear, angular):
    cov = [0.0] * 36
    for i in range(3):
        cov[7 * i], cov[7 * (i + 3)] = linear, angular
    return cov


def odom_at(t, yaw, speed, yaw_rate, heading_std_deg=2.0, speed_std=0.05, yaw_rate_std=0.02, settings=SETTINGS):
    return odom_sample(t, yaw_q(yaw), diag6(1e-4, math.radians(heading_std_deg) ** 2), (speed, 0.0), yaw_rate,
                       diag6(speed_std ** 2, yaw_rate_std ** 2), settings)


# ---------------------------------------------------------------------------------------------- make_report


def test_full_report_has_the_simulators_former_meaning():
    report, reason = make_report(FRAME, fix_at(10.0, 12.0, -3.0), velocity_sample(10.0, 1.0, 0.5),
                                 odom_at(10.0, math.radians(30), 1.1, 0.1), SETTINGS)
    assert reason is None and report.notes == ()
    assert report.stamp_s == pytest.approx(10.0)
    assert report.position[:2] == pytest.approx((12.0, -3.0), abs=1e-6)
    assert report.pose_covariance[0] == report.pose_covariance[7] == pytest.approx(6.25)
    assert report.pose_covariance[14] == pytest.approx(25.0)
    assert report.pose_covariance[35] == pytest.approx(math.radians(2.0) ** 2)
    assert report.heading == pytest.approx(math.radians(30))
    assert report.velocity == pytest.approx((1.0, 0.5))  # the receiver's, world frame
    assert report.twist_covariance[0] == report.twist_covariance[7] == pytest.approx(0.01)
    assert report.yaw_rate == pytest.approx(0.1)
    assert report.twist_covariance[35] == pytest.approx(0.02 ** 2)
    assert all(report.pose_covariance[i] == 0.0 for i in range(36) if i % 7)  # diagonal


def test_no_fix_gives_unknown_position_and_the_odometrys_velocity():
    report, reason = make_report(FRAME, no_fix_at(5.0), None, odom_at(5.0, math.pi / 2, 2.0, 0.0), SETTINGS)
    assert reason is None
    assert report.position == (0.0, 0.0, 0.0)
    assert report.pose_covariance[0] == report.pose_covariance[7] == UNKNOWN_VARIANCE
    assert any("NO_FIX" in note for note in report.notes)
    assert report.velocity == pytest.approx((0.0, 2.0), abs=1e-9)  # forward speed along the heading (north)
    # speed variance plus the sideways error the heading's error makes
    assert report.twist_covariance[0] == pytest.approx(0.05 ** 2 + 4.0 * math.radians(2.0) ** 2)
    assert report.heading == pytest.approx(math.pi / 2)


@pytest.mark.parametrize("latitude", [float("nan"), float("inf"), 91.0])
def test_a_bad_fix_is_an_unknown_position_never_a_wrong_one(latitude):
    fix = fix_at(5.0, 1.0, 1.0)
    fix.latitude = latitude
    report, _ = make_report(FRAME, fix, velocity_sample(5.0, 1.0, 0.0), odom_at(5.0, 0.0, 1.0, 0.0), SETTINGS)
    assert report.pose_covariance[0] == UNKNOWN_VARIANCE and report.position == (0.0, 0.0, 0.0)
    assert all(math.isfinite(v) for v in report.position + tuple(report.velocity))


def test_no_datum_gives_unknown_position():
    report, _ = make_report(None, fix_at(5.0, 1.0, 1.0), velocity_sample(5.0, 1.0, 0.0), None, SETTINGS)
    assert report.pose_covariance[0] == UNKNOWN_VARIANCE
    assert any("datum" in note for note in report.notes)


def test_a_datum_of_another_site_gives_unknown_position():
    far = LocalFrame(48.0, 11.0, 500.0)  # Munich: the fix is in Estonia
    report, _ = make_report(far, fix_at(5.0, 1.0, 1.0), velocity_sample(5.0, 1.0, 0.0), None, SETTINGS)
    assert report.pose_covariance[0] == UNKNOWN_VARIANCE
    assert any("another site" in note for note in report.notes)


def test_a_zero_stamp_gives_no_report():
    report, reason = make_report(FRAME, fix_at(0.0, 1.0, 1.0), velocity_sample(1.0, 1.0, 0.0), None, SETTINGS)
    assert report is None and "stamp" in reason


def test_without_odometry_heading_and_yaw_rate_are_unknown():
    report, _ = make_report(FRAME, fix_at(5.0, 1.0, 1.0), velocity_sample(5.0, 1.0, 0.0), None, SETTINGS)
    assert report.pose_covariance[35] == report.twist_covariance[35] == UNKNOWN_VARIANCE
    assert report.heading == 0.0 and report.yaw_rate == 0.0
    assert report.velocity == pytest.approx((1.0, 0.0))
    assert any("no odometry" in note for note in report.notes)


def test_stale_odometry_is_not_used():
    report, _ = make_report(FRAME, fix_at(5.0, 1.0, 1.0), velocity_sample(5.0, 1.0, 0.0),
                            odom_at(4.0, 1.0, 1.0, 0.3), SETTINGS)
    assert report.pose_covariance[35] == UNKNOWN_VARIANCE and report.yaw_rate == 0.0
    assert any("from it" in note for note in report.notes)


def test_without_any_velocity_there_is_no_report():
    report, reason = make_report(FRAME, fix_at(5.0, 1.0, 1.0), None, None, SETTINGS)
    assert report is None and "velocity unknown" in reason
    report, reason = make_report(FRAME, fix_at(5.0, 1.0, 1.0), velocity_sample(3.0, 1.0, 0.0), None, SETTINGS)
    assert report is None and "from the fix" in reason


def test_stale_gps_velocity_falls_back_to_the_odometry():
    report, _ = make_report(FRAME, fix_at(5.0, 1.0, 1.0), velocity_sample(4.0, 9.0, 9.0),
                            odom_at(5.0, 0.0, 1.5, 0.0), SETTINGS)
    assert report.velocity == pytest.approx((1.5, 0.0))


def test_odom_yaw_offset_turns_the_odometry_into_enu():
    settings = ReportSettings(odom_yaw_offset_deg=90.0)
    report, _ = make_report(FRAME, no_fix_at(5.0), None, odom_at(5.0, 0.0, 1.0, 0.0, settings=settings), settings)
    assert report.heading == pytest.approx(math.pi / 2)
    assert report.velocity == pytest.approx((0.0, 1.0), abs=1e-9)


# ---------------------------------------------------------------------------------------------- odometry input


def test_odometry_variances_not_filled_take_the_defaults_and_unknown_ones_stay_unknown():
    sample = odom_sample(1.0, yaw_q(0.3), [0.0] * 36, (1.0, 0.0), 0.1, [0.0] * 36, SETTINGS)
    assert sample.heading_var == pytest.approx(math.radians(SETTINGS.heading_std_deg_if_unknown) ** 2)
    assert sample.speed_var == pytest.approx(SETTINGS.speed_std_if_unknown ** 2)
    assert sample.yaw_rate_var == pytest.approx(SETTINGS.yaw_rate_std_if_unknown ** 2)
    unknown = odom_sample(1.0, yaw_q(0.3), diag6(1.0, 1e9), (1.0, 0.0), 0.1, diag6(0.01, 1e6), SETTINGS)
    report, _ = make_report(FRAME, fix_at(1.0, 0.0, 0.0), velocity_sample(1.0, 1.0, 0.0), unknown, SETTINGS)
    assert report.pose_covariance[35] == UNKNOWN_VARIANCE and report.twist_covariance[35] == UNKNOWN_VARIANCE


@pytest.mark.parametrize("orientation, linear, angular, problem", [
    ((0.0, 0.0, 0.0, 0.0), (1.0, 0.0), 0.0, "zero quaternion"),
    ((0.0, 0.0, float("nan"), 1.0), (1.0, 0.0), 0.0, "orientation"),
    ((0.0, 0.0, 0.0, 1.0), (float("nan"), 0.0), 0.0, "linear"),
    ((0.0, 0.0, 0.0, 1.0), (1.0, 0.0), float("inf"), "angular"),
])
def test_bad_odometry_is_refused_with_its_reason(orientation, linear, angular, problem):
    with pytest.raises(ValueError, match=problem):
        odom_sample(1.0, orientation, [0.0] * 36, linear, angular, [0.0] * 36, SETTINGS)


def test_bad_velocity_is_refused():
    with pytest.raises(ValueError, match="not finite"):
        velocity_sample(1.0, float("nan"), 0.0)
    with pytest.raises(ValueError, match="stamp"):
        velocity_sample(0.0, 1.0, 0.0)


def test_yaw_of_a_non_unit_quaternion():
    x, y, z, w = (2.0 * c for c in yaw_q(-2.5))
    assert yaw_of_quaternion(x, y, z, w) == pytest.approx(-2.5)


# ---------------------------------------------------------------------------------------------- the fusion


def reports(released):
    assert all(reason is None for _, reason in released), released
    return [report for report, _ in released]


def test_each_fix_is_reported_with_the_nearest_odometry():
    reporter = VehicleReporter(SETTINGS, FRAME)
    for i in range(100):  # 50 Hz for 2 s, heading turning at 0.5 rad/s
        t = 8.0 + i * 0.02
        reporter.add_odometry(odom_at(t, 0.5 * (t - 8.0), 1.0, 0.5))
    reporter.add_velocity(velocity_sample(9.0, 0.1, 0.9))
    (report,) = reports(reporter.add_fix(fix_at(9.0, 3.0, 4.0), now_s=9.1))  # delivered 0.1 s late
    assert report.heading == pytest.approx(0.5)
    assert report.velocity == pytest.approx((0.1, 0.9))


def test_a_fix_waits_for_its_epochs_velocity_once_the_receiver_pairs_stamps():
    reporter = VehicleReporter(SETTINGS, FRAME)
    reporter.add_odometry(odom_at(1.0, 0.0, 1.0, 0.0))
    reporter.add_velocity(velocity_sample(1.0, 1.0, 0.0))
    assert len(reports(reporter.add_fix(fix_at(1.0, 0.0, 0.0), now_s=1.0))) == 1  # learns the pairing
    reporter.add_odometry(odom_at(1.2, 0.0, 1.0, 0.0))
    assert reporter.add_fix(fix_at(1.2, 0.2, 0.0), now_s=1.2) == []  # its vel is on the way
    (report,) = reports(reporter.add_velocity(velocity_sample(1.2, 1.2, 0.0)))
    assert report.velocity == pytest.approx((1.2, 0.0))
    # A vel lost on the way: the fix goes out after vel_wait_s with the odometry's velocity, not the previous vel.
    reporter.add_odometry(odom_at(1.4, 0.0, 1.4, 0.0))
    assert reporter.add_fix(fix_at(1.4, 0.4, 0.0), now_s=1.4) == []
    assert reporter.flush(1.45) == []
    (report,) = reports(reporter.flush(1.5))
    assert report.velocity == pytest.approx((1.4, 0.0))
    # A dropout's NO_FIX (no vel that epoch) is not held back.
    reporter.add_odometry(odom_at(1.6, 0.0, 1.6, 0.0))
    (report,) = reports(reporter.add_fix(no_fix_at(1.6), now_s=1.6))
    assert report.pose_covariance[0] == UNKNOWN_VARIANCE and report.velocity == pytest.approx((1.6, 0.0))


def test_a_pending_fix_goes_out_when_the_next_one_comes():
    reporter = VehicleReporter(SETTINGS, FRAME)
    reporter.add_odometry(odom_at(1.0, 0.0, 1.0, 0.0))
    reporter.add_velocity(velocity_sample(1.0, 1.0, 0.0))
    reporter.add_fix(fix_at(1.0, 0.0, 0.0), now_s=1.0)
    reporter.add_odometry(odom_at(1.2, 0.0, 1.0, 0.0))
    assert reporter.add_fix(fix_at(1.2, 0.2, 0.0), now_s=1.2) == []
    reporter.add_velocity(velocity_sample(1.4, 1.0, 0.0))
    released = reports(reporter.add_fix(fix_at(1.4, 0.4, 0.0), now_s=1.4))
    assert [r.stamp_s for r in released] == pytest.approx([1.2, 1.4])


def test_a_receiver_with_unpaired_stamps_gets_the_latest_velocity_at_once():
    reporter = VehicleReporter(SETTINGS, FRAME)
    reporter.add_odometry(odom_at(2.0, 0.0, 1.0, 0.0))
    for k in range(3):
        reporter.add_velocity(velocity_sample(2.0 + k + 0.03, 2.0, 0.0))
        (report,) = reports(reporter.add_fix(fix_at(2.0 + k, 0.0, 0.0), now_s=2.0 + k))
        assert report.velocity == pytest.approx((2.0, 0.0))


def test_odometry_from_an_earlier_run_is_forgotten():
    reporter = VehicleReporter(SETTINGS, FRAME)
    reporter.add_odometry(odom_at(100.0, 1.0, 1.0, 0.0))
    reporter.add_odometry(odom_at(1.0, 0.0, 2.0, 0.0))
    assert [s.stamp_s for s in reporter.odometry] == [1.0]


def test_the_odometry_buffer_keeps_only_its_span():
    reporter = VehicleReporter(SETTINGS, FRAME)
    for i in range(500):
        reporter.add_odometry(odom_at(1.0 + i * 0.02, 0.0, 1.0, 0.0))
    span = reporter.odometry[-1].stamp_s - reporter.odometry[0].stamp_s
    assert span <= SETTINGS.odom_buffer_s + 1e-9 and len(reporter.odometry) <= 102


# ---------------------------------------------------------------------------------------------- settings, message


def test_settings_are_checked():
    with pytest.raises(SettingsError, match="gps_velocity_std_mps"):
        ReportSettings(gps_velocity_std_mps=0.0)
    with pytest.raises(SettingsError, match="odom_max_age_s"):
        ReportSettings(odom_max_age_s=float("nan"))
    with pytest.raises(SettingsError, match="odom_buffer_s"):
        ReportSettings(odom_buffer_s=0.1, odom_max_age_s=0.25)
    with pytest.raises(SettingsError, match="~vel_wait_s"):
        ReportSettings.from_mapping({"gps_velocity_std_mps": 0.1})


def test_the_shipped_config_has_every_setting_commented():
    import yaml
    path = os.path.join(HERE, "..", "config", "vehicle_report.yaml")
    with open(path) as stream:
        values = yaml.safe_load(stream)
    ReportSettings.from_mapping(values)
    sys.path.insert(0, os.path.join(HERE, "..", "..", "landing_runtime", "src"))
    from landing_runtime.testing import yaml_key_comments
    comments = yaml_key_comments(path)
    assert set(comments) == set(values)
    for key, comment in comments.items():
        assert "[" in comment and comment.endswith("]"), "%s: no meaning and [unit]: %r" % (key, comment)


def test_fill_odometry_writes_the_message():
    report, _ = make_report(FRAME, fix_at(10.0, 12.0, -3.0), velocity_sample(10.0, 1.0, 0.5),
                            odom_at(10.0, 1.0, 1.1, 0.1), SETTINGS)
    vector = lambda: SimpleNamespace(x=None, y=None, z=None)  # noqa: E731
    odom = SimpleNamespace(header=SimpleNamespace(stamp=None, frame_id=None), child_frame_id=None,
                           pose=SimpleNamespace(pose=SimpleNamespace(position=vector(),
                                                                     orientation=SimpleNamespace(x=0, y=0, z=0, w=0)),
                                                covariance=None),
                           twist=SimpleNamespace(twist=SimpleNamespace(linear=vector(), angular=vector()),
                                                 covariance=None))
    fill_odometry(odom, report, "STAMP", "world", "summit_xl/base_link")
    q = odom.pose.pose.orientation
    assert yaw_of_quaternion(q.x, q.y, q.z, q.w) == pytest.approx(1.0)
    assert (odom.header.frame_id, odom.child_frame_id) == ("world", "summit_xl/base_link")
    assert (odom.twist.twist.linear.x, odom.twist.twist.angular.z) == pytest.approx((1.0, 0.1))
    assert len(odom.pose.covariance) == len(odom.twist.covariance) == 36
