"""navsat_local.enu without ROS: geodesy, fix checks, covariances, velocity, datum choice, odometry filling."""
import math
import random
from types import SimpleNamespace

import pytest

from navsat_local.enu import (COVARIANCE_TYPE_APPROXIMATED, COVARIANCE_TYPE_DIAGONAL_KNOWN, COVARIANCE_TYPE_KNOWN,
                              COVARIANCE_TYPE_UNKNOWN, STATUS_NO_FIX, UNKNOWN_VARIANCE, ConversionSettings, Datum,
                              DatumError, LocalFrame, VelocitySample, datum_from_fix, embed_covariance,
                              fill_odometry, fix_problem, local_odometry, parse_datum, position_covariance,
                              resolve_datum, validate_geodetic, velocity_estimate)

TALLINN = (59.4, 24.7, 30.0)
SETTINGS = ConversionSettings()


def make_fix(lat=59.4, lon=24.7, alt=30.0, status=0, stamp_s=100.25, covariance=(0.0,) * 9,
             covariance_type=COVARIANCE_TYPE_UNKNOWN):
    """A NavSatFix look-alike (the fields navsat_local reads)."""
    secs = int(stamp_s)
    stamp = SimpleNamespace(secs=secs, nsecs=int(round((stamp_s - secs) * 1e9)))
    return SimpleNamespace(header=SimpleNamespace(stamp=stamp), status=SimpleNamespace(status=status),
                           latitude=lat, longitude=lon, altitude=alt, position_covariance=list(covariance),
                           position_covariance_type=covariance_type)


def make_odometry():
    """A nav_msgs/Odometry look-alike, every field at its message default."""
    def vector(**extra):
        return SimpleNamespace(x=0.0, y=0.0, z=0.0, **extra)
    return SimpleNamespace(
        header=SimpleNamespace(stamp=None, frame_id=""), child_frame_id="",
        pose=SimpleNamespace(pose=SimpleNamespace(position=vector(), orientation=vector(w=0.0)), covariance=[0.0] * 36),
        twist=SimpleNamespace(twist=SimpleNamespace(linear=vector(), angular=vector()), covariance=[0.0] * 36))


# ---------------------------------------------------------------------------------------------- geodesy


def test_a_thousandth_of_a_degree_north_at_the_equator_is_110_6_m_north():
    east, north, up = LocalFrame(0.0, 0.0, 0.0).to_enu(0.001, 0.0, 0.0)
    assert north == pytest.approx(110.574, abs=0.01)  # WGS84 meridian arc at the equator
    assert east == pytest.approx(0.0, abs=1e-9)
    assert up == pytest.approx(0.0, abs=0.01)  # the tangent plane drops below the ellipsoid by ~1 mm there


def test_100_m_east_in_tallinn_comes_back_within_a_millimetre():
    frame = LocalFrame(*TALLINN)
    lat, lon, alt = frame.to_geodetic(100.0, 0.0, 0.0)
    # 100 m along the parallel of 59.4 N: prime vertical radius N times cos(lat) per radian of longitude
    a, e2 = 6378137.0, 0.00669437999014
    prime_vertical = a / math.sqrt(1.0 - e2 * math.sin(math.radians(59.4)) ** 2)
    assert lon - 24.7 == pytest.approx(math.degrees(100.0 / (prime_vertical * math.cos(math.radians(59.4)))),
                                       rel=1e-4)
    assert lat == pytest.approx(59.4, abs=1e-6)
    east, north, up = frame.to_enu(lat, lon, alt)
    assert (east, north, up) == pytest.approx((100.0, 0.0, 0.0), abs=1e-3)


def test_altitude_above_the_datum_is_up():
    east, north, up = LocalFrame(*TALLINN).to_enu(59.4, 24.7, 42.5)
    assert up == pytest.approx(12.5, abs=1e-6)
    assert (east, north) == pytest.approx((0.0, 0.0), abs=1e-6)


@pytest.mark.parametrize("datum", [(0.0, 0.0, 0.0), TALLINN, (-33.9, 151.2, 50.0), (89.9, -179.99, 0.0),
                                   (-45.0, 179.99, -20.0)])
def test_round_trips_within_a_millimetre(datum):
    frame = LocalFrame(*datum)
    rng = random.Random(7)
    for _ in range(20):
        local = (rng.uniform(-5000, 5000), rng.uniform(-5000, 5000), rng.uniform(-100, 500))
        assert frame.to_enu(*frame.to_geodetic(*local)) == pytest.approx(local, abs=1e-3)


def test_the_datum_itself_is_the_origin():
    assert LocalFrame(*TALLINN).to_enu(*TALLINN) == pytest.approx((0.0, 0.0, 0.0), abs=1e-9)


@pytest.mark.parametrize("point, words", [
    ((90.5, 0.0, 0.0), "latitude 90.5 deg is outside [-90, 90]"),
    ((0.0, -180.5, 0.0), "longitude -180.5 deg is outside [-180, 180]"),
    ((float("nan"), 0.0, 0.0), "latitude nan is not a finite number"),
    ((0.0, 0.0, float("inf")), "altitude inf is not a finite number"),
    ((None, 0.0, 0.0), "latitude None is not a number"),
    ((True, 0.0, 0.0), "latitude True is not a number"),
])
def test_bad_geodetic_points_are_refused_by_name(point, words):
    with pytest.raises(ValueError, match=words.replace("[", r"\[").replace("]", r"\]")):
        validate_geodetic(*point)
    with pytest.raises(ValueError, match="^datum: "):
        LocalFrame(*point)
    with pytest.raises(ValueError):
        LocalFrame(*TALLINN).to_enu(*point)


def test_non_finite_local_points_are_refused():
    with pytest.raises(ValueError, match="north nan is not a finite number"):
        LocalFrame(*TALLINN).to_geodetic(0.0, float("nan"), 0.0)


def test_the_poles_and_the_antimeridian_are_valid_datums():
    LocalFrame(90.0, 180.0, 0.0)
    LocalFrame(-90.0, -180.0, 0.0)


def test_distance_between_datums():
    frame = LocalFrame(*TALLINN)
    other = Datum(*frame.to_geodetic(3.0, 4.0, 0.0))
    assert frame.distance_to(other) == pytest.approx(5.0, abs=1e-6)


# ---------------------------------------------------------------------------------------------- fixes


def test_a_good_fix_has_no_problem():
    assert fix_problem(make_fix()) is None
    assert fix_problem(make_fix(status=2)) is None  # GBAS-augmented
    assert fix_problem(make_fix(covariance_type=COVARIANCE_TYPE_UNKNOWN)) is None  # noted later, not refused


@pytest.mark.parametrize("fix, reason", [
    (make_fix(status=STATUS_NO_FIX), "status NO_FIX (-1)"),
    (make_fix(status=-3), "status -3 is not a NavSatStatus value"),
    (make_fix(lat=float("nan")), "latitude nan is not a finite number"),
    (make_fix(lon=float("nan")), "longitude nan is not a finite number"),
    (make_fix(alt=float("nan")), "altitude nan is not a finite number"),
    (make_fix(lat=95.0), "latitude 95.0 deg is outside [-90, 90]"),
    (make_fix(lon=200.0), "longitude 200.0 deg is outside [-180, 180]"),
    (make_fix(stamp_s=0.0), "header.stamp is zero"),
])
def test_an_unusable_fix_says_why(fix, reason):
    assert fix_problem(fix) == reason


def test_no_fix_is_reported_before_its_garbage_coordinates():
    assert fix_problem(make_fix(status=STATUS_NO_FIX, lat=float("nan"))) == "status NO_FIX (-1)"


def test_datum_from_a_fix():
    assert datum_from_fix(make_fix(lat=59.4, lon=24.7, alt=31.5)) == Datum(59.4, 24.7, 31.5)


# ---------------------------------------------------------------------------------------------- covariance


def test_unknown_covariance_gets_the_default_stds_and_a_note():
    matrix, note = position_covariance([0.0] * 9, COVARIANCE_TYPE_UNKNOWN, SETTINGS)
    assert matrix == [25.0, 0, 0, 0, 25.0, 0, 0, 0, 100.0]
    assert note == "covariance type unknown: default std used"


def test_a_known_covariance_carries_over_symmetrised():
    given = [4.0, 0.5, 0.1, 0.3, 9.0, 0.2, 0.1, 0.2, 16.0]
    matrix, note = position_covariance(given, COVARIANCE_TYPE_KNOWN, SETTINGS)
    assert note is None
    assert matrix == pytest.approx([4.0, 0.4, 0.1, 0.4, 9.0, 0.2, 0.1, 0.2, 16.0])
    assert position_covariance(given, COVARIANCE_TYPE_APPROXIMATED, SETTINGS)[0] == matrix


def test_a_diagonal_known_covariance_keeps_only_its_diagonal():
    matrix, note = position_covariance([4.0, 7.0, 7.0, 7.0, 9.0, 7.0, 7.0, 7.0, 16.0],
                                       COVARIANCE_TYPE_DIAGONAL_KNOWN, SETTINGS)
    assert (matrix, note) == ([4.0, 0, 0, 0, 9.0, 0, 0, 0, 16.0], None)


def test_reported_variances_are_raised_to_the_floor():
    matrix, _ = position_covariance([0.0] * 9, COVARIANCE_TYPE_KNOWN, ConversionSettings(min_position_std_m=0.02))
    assert matrix == pytest.approx([0.0004, 0, 0, 0, 0.0004, 0, 0, 0, 0.0004])


@pytest.mark.parametrize("given, covariance_type, words", [
    ([float("nan")] + [0.0] * 8, COVARIANCE_TYPE_KNOWN, "is not usable"),
    ([-1.0] + [0.0] * 8, COVARIANCE_TYPE_DIAGONAL_KNOWN, "is not usable"),
    ([1.0] * 9, 7, "covariance type 7 is not a NavSatFix value"),
])
def test_an_unusable_covariance_falls_back_to_the_defaults(given, covariance_type, words):
    matrix, note = position_covariance(given, covariance_type, SETTINGS)
    assert matrix == [25.0, 0, 0, 0, 25.0, 0, 0, 0, 100.0]
    assert words in note


def test_the_position_block_lands_in_the_pose_covariance():
    block = [float(v) for v in range(1, 10)]
    pose = embed_covariance(block)
    assert [pose[6 * r + c] for r in range(3) for c in range(3)] == block
    assert [pose[6 * i + i] for i in range(3, 6)] == [UNKNOWN_VARIANCE] * 3  # no orientation from a GPS
    assert sum(1 for v in pose if v) == 9 + 3


@pytest.mark.parametrize("name", ["unknown_horizontal_std_m", "min_position_std_m", "velocity_std_mps",
                                  "vel_max_age_s"])
@pytest.mark.parametrize("value", [0.0, -1.0, float("nan"), "1.0", True])
def test_settings_refuse_non_positive_numbers(name, value):
    with pytest.raises(ValueError, match="~%s must be a positive number" % name):
        ConversionSettings(**{name: value})


# ---------------------------------------------------------------------------------------------- velocity


def test_a_fresh_vel_is_the_velocity():
    estimate = velocity_estimate(VelocitySample(100.0, 1.5, -2.0, 0.3), 100.2, SETTINGS)
    assert estimate.known and estimate.note is None
    assert estimate.velocity == (1.5, -2.0, 0.0)  # NMEA has no vertical speed: its 0 is not a measurement
    assert estimate.variances == pytest.approx((0.04, 0.04, UNKNOWN_VARIANCE))


def test_a_vel_just_after_its_fix_counts():
    assert velocity_estimate(VelocitySample(101.0, 1.0, 0.0, 0.0), 100.0, SETTINGS).known


def test_vertical_velocity_when_the_receiver_measures_it():
    estimate = velocity_estimate(VelocitySample(100.0, 1.0, 2.0, -0.5), 100.0,
                                 ConversionSettings(velocity_has_vertical=True))
    assert estimate.velocity == (1.0, 2.0, -0.5)
    assert estimate.variances == pytest.approx((0.04, 0.04, 0.04))


@pytest.mark.parametrize("sample, note", [
    (None, "no vel received"),
    (VelocitySample(98.0, 1.0, 1.0, 0.0), "vel is 2.00 s from the fix (max 1.50 s)"),
    (VelocitySample(100.0, float("nan"), 1.0, 0.0), "vel is not finite"),
])
def test_without_a_usable_vel_the_velocity_is_unknown(sample, note):
    estimate = velocity_estimate(sample, 100.0, SETTINGS)
    assert not estimate.known
    assert estimate.note == note
    assert estimate.velocity == (0.0, 0.0, 0.0)  # finite: consumers reject NaN, and read the variance instead
    assert estimate.variances == (UNKNOWN_VARIANCE,) * 3


# ---------------------------------------------------------------------------------------------- datum choice


SHARED = {"lat": 59.39, "lon": 24.66, "alt": 33.0}
OWN = {"lat": 59.40, "lon": 24.70, "alt": 30.0}


def test_the_nodes_own_datum_wins():
    assert resolve_datum(OWN, SHARED, True) == (Datum(59.40, 24.70, 30.0), "~datum")


def test_the_shared_datum_comes_next():
    assert resolve_datum(None, SHARED, True) == (Datum(59.39, 24.66, 33.0), "/navsat_datum")
    assert resolve_datum(None, SHARED, False) == (Datum(59.39, 24.66, 33.0), "/navsat_datum")


def test_first_fix_mode_waits_for_a_fix():
    assert resolve_datum(None, None, True) == (None, "first fix")


def test_nothing_set_names_every_parameter_that_would_do():
    with pytest.raises(DatumError) as raised:
        resolve_datum(None, None, False, "/site/datum")
    message = str(raised.value)
    assert "~datum {lat: deg, lon: deg, alt: m}" in message
    assert "/site/datum" in message
    assert "~datum_from_first_fix: true" in message


@pytest.mark.parametrize("private, shared, words", [
    ({"lat": 59.4, "lon": 24.7}, None, "~datum must be a mapping {lat: deg, lon: deg, alt: m}"),
    ([59.4, 24.7, 30.0], None, "~datum must be a mapping"),
    ({"lat": 99.0, "lon": 24.7, "alt": 0.0}, None, "~datum: latitude 99.0 deg is outside"),
    (None, {"lat": "59.4", "lon": 24.7, "alt": 0.0}, "/navsat_datum: latitude '59.4' is not a number"),
])
def test_a_malformed_datum_is_named(private, shared, words):
    with pytest.raises(DatumError, match=words.replace("[", r"\[").replace("{", r"\{")):
        resolve_datum(private, shared, True)


def test_a_datum_goes_back_into_a_parameter_unchanged():
    datum = Datum(59.4, 24.7, 30.0)
    assert parse_datum(datum.as_param(), "/navsat_datum") == datum


# ---------------------------------------------------------------------------------------------- odometry


def test_a_fix_becomes_odometry():
    frame = LocalFrame(*TALLINN)
    lat, lon, alt = frame.to_geodetic(12.0, -7.0, 3.0)
    fix = make_fix(lat=lat, lon=lon, alt=alt, stamp_s=100.5, covariance=[1.0, 0, 0, 0, 2.0, 0, 0, 0, 3.0],
                   covariance_type=COVARIANCE_TYPE_DIAGONAL_KNOWN)
    local = local_odometry(frame, fix, VelocitySample(100.4, 0.5, 1.5, 0.0), SETTINGS)
    assert local.stamp_s == pytest.approx(100.5)
    assert local.position == pytest.approx((12.0, -7.0, 3.0), abs=1e-3)
    assert local.velocity_known and local.notes == ()

    stamp = object()  # whatever the node's message carries: handed through untouched
    odom = fill_odometry(make_odometry(), local, stamp, "world", "summit_xl/base_link")
    assert odom.header.stamp is stamp
    assert (odom.header.frame_id, odom.child_frame_id) == ("world", "summit_xl/base_link")
    p, q = odom.pose.pose.position, odom.pose.pose.orientation
    assert (p.x, p.y, p.z) == pytest.approx((12.0, -7.0, 3.0), abs=1e-3)
    assert (q.x, q.y, q.z, q.w) == (0.0, 0.0, 0.0, 1.0)
    assert [odom.pose.covariance[i] for i in (0, 7, 14, 21, 28, 35)] == [1.0, 2.0, 3.0] + [UNKNOWN_VARIANCE] * 3
    v = odom.twist.twist.linear
    assert (v.x, v.y, v.z) == (0.5, 1.5, 0.0)
    assert [odom.twist.covariance[i] for i in (0, 7, 14, 21)] == pytest.approx([0.04, 0.04, UNKNOWN_VARIANCE,
                                                                                UNKNOWN_VARIANCE])
    assert len(odom.pose.covariance) == len(odom.twist.covariance) == 36


def test_odometry_notes_what_it_assumed():
    local = local_odometry(LocalFrame(*TALLINN), make_fix(), None, SETTINGS)
    assert local.notes == ("covariance type unknown: default std used", "no vel received")
    assert not local.velocity_known
    assert local.pose_covariance[0] == 25.0 and local.twist_covariance[0] == UNKNOWN_VARIANCE
