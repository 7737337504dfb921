"""flight_analysis.analyze end to end: bags written here with the rosbags writer (known answers), a damaged and a
truncated copy, bad input, and the command run in a clean environment (no ROS sourced, no master)."""
import glob
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
SRC = os.path.normpath(os.path.join(HERE, "..", "src"))
MSG_DIR = os.path.normpath(os.path.join(HERE, "..", "..", "landing_msgs", "msg"))
FIXTURE = os.path.join(HERE, "data", "sim_flight.bag")
sys.path.insert(0, SRC)

pytest.importorskip("rosbags")
from rosbags.rosbag1 import Writer  # noqa: E402
from rosbags.typesys import Stores, get_types_from_msg, get_typestore  # noqa: E402

from flight_analysis import analyze  # noqa: E402
from flight_analysis.analysis_bag import BagError, read_bag  # noqa: E402

SUBPROCESS_TIMEOUT = 300  # generous: the machine may be loaded


# ----------------------------------------------------------------------------------------------------
# A synthetic 30 s flight with hand-computable answers.
#   pad: x = 1 m/s * t, y = 0, z = 0.5; ground truth at 50 Hz
#   drone: on the pad until 2 s; offset (0.3, 0.4) = 0.5 m from the pad while TRACKING [4, 24) s;
#          offset (0.06, 0.08) = 0.1 m while LANDING [24, 26) s and after the touchdown at 26 s
#   takeoff command at 1.5 s; navdata LANDED until 2 s; battery 90 % - 0.1 %/s
#   vision (10 Hz, 4-26 s): pad + (0.1, 0)           -> 0.1 m error
#   Kalman path (10 Hz, 4-26 s): 11 poses to +1 s, last = true pad + (0, 0.2) -> 0.2 m at the horizon
#   supervisor: one JSON decision (wind_strong, value 7.5 m/s)

def store_with_landing_msgs(extra=None):
    store = get_typestore(Stores.ROS1_NOETIC)
    types = {}
    for path in sorted(glob.glob(os.path.join(MSG_DIR, "*.msg"))):
        name = "landing_msgs/msg/%s" % os.path.splitext(os.path.basename(path))[0]
        with open(path) as stream:
            types.update(get_types_from_msg(stream.read(), name))
    types.update(extra or {})
    store.register(types)
    return store


def stamp(store, t):
    sec = int(math.floor(t))
    return store.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=int(round((t - sec) * 1e9)))


def header(store, t, frame="world"):
    return store.types["std_msgs/msg/Header"](seq=0, stamp=stamp(store, t), frame_id=frame)


def pose_stamped(store, t, x, y, z):
    T = store.types
    return T["geometry_msgs/msg/PoseStamped"](
        header=header(store, t), pose=T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=x, y=y, z=z),
            orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))


def drone_offset(t):
    if t < 4.0:
        return 0.0, 0.0
    return (0.3, 0.4) if t < 24.0 else (0.06, 0.08)


def write_flight(path, duration=30.0, topics=None, decision_type=None, chunk_bytes=32 * 1024):
    """Writes the synthetic flight; ``topics`` limits which topics are written."""
    store = store_with_landing_msgs(decision_type)
    T = store.types
    writer = Writer(path)
    writer.set_compression(Writer.CompressionFormat.LZ4)
    writer.chunk_threshold = chunk_bytes
    writer.open()
    conns = {}

    def put(topic, msgtype, t, msg):
        if topics is not None and topic not in topics:
            return
        if topic not in conns:
            conns[topic] = writer.add_connection(topic, msgtype, typestore=store)
        writer.write(conns[topic], int(round(t * 1e9)), store.serialize_ros1(msg, msgtype))

    def string(text):
        return T["std_msgs/msg/String"](data=text)

    events = {0.5: ("/platform_tracking/state", "LANDED"), 2.0: ("/platform_tracking/state", "TAKING_OFF"),
              4.0: ("/platform_tracking/state", "TRACKING"), 24.0: ("/platform_tracking/state", "LANDING"),
              26.0: ("/platform_tracking/state", "LANDED")}
    for k in range(int(round(duration * 50))):
        t = k / 50.0
        if k % 25 == 0 and t in events:
            topic, text = events[t]
            put(topic, "std_msgs/msg/String", t, string(text))
        if k == 50:  # 1.0 s
            decision = {"t": 1.0, "condition": "wind_strong", "flag": 2, "action": "warn",
                        "reason": "strong wind: 7.5 m/s", "value": 7.5}
            if decision_type:
                put("/supervisor/decisions", "test_msgs/msg/Decision", t, T["test_msgs/msg/Decision"](
                    t=1.0, condition="wind_strong", flag=2, action="warn", reason="strong wind", value=7.5))
            else:
                put("/supervisor/decisions", "std_msgs/msg/String", t, string(json.dumps(decision)))
        if k == 75:  # 1.5 s
            put("/ardrone/takeoff", "std_msgs/msg/Empty", t, T["std_msgs/msg/Empty"]())
        pad_x = 1.0 * t
        dx, dy = drone_offset(t)
        z = 0.56 if t < 2.0 or t >= 26.0 else (0.56 + 1.2 * (t - 2.0) if t < 4.0 else (3.0 if t < 24.0 else 3.0 - 1.2 * (t - 24.0)))
        put("/groundtruth/landing_pad", "geometry_msgs/msg/PoseStamped", t, pose_stamped(store, t, pad_x, 0.0, 0.5))
        put("/groundtruth/ardrone", "geometry_msgs/msg/PoseStamped", t, pose_stamped(store, t, pad_x + dx, dy, z))
        state = 2 if t < 2.0 or t >= 26.0 else (6 if t < 4.0 else 3)
        put("/drone/navdata", "landing_msgs/msg/Navdata", t, T["landing_msgs/msg/Navdata"](
            header=header(store, t, "ardrone/base_link"), state=state, battery_percent=90.0 - 0.1 * t,
            altitude=z - 0.565, vx=0.0, vy=0.0, vz=0.0, rot_x=0.0, rot_y=0.0, rot_z=0.0, motor_thrust=0.5))
        if 4.0 <= t < 26.0 and k % 5 == 0:
            point = T["geometry_msgs/msg/Point"](x=pad_x + 0.1, y=0.0, z=0.5)
            put("/platform/current_platform_position_in_world", "geometry_msgs/msg/PointStamped", t,
                T["geometry_msgs/msg/PointStamped"](header=header(store, t), point=point))
            poses = [pose_stamped(store, t + 0.1 * i, pad_x + 0.1 * i, 0.2 if i == 10 else 0.0, 0.5) for i in range(11)]
            put("/kalman_prediction_path", "nav_msgs/msg/Path", t,
                T["nav_msgs/msg/Path"](header=header(store, t), poses=poses))
        if k == 1300:  # 26.0 s
            put("/ardrone/touchdown", "landing_msgs/msg/Touchdown", t, T["landing_msgs/msg/Touchdown"](
                header=header(store, t), surface=1, crashed=False, impact_speed=0.4, tilt_deg=1.0,
                position=T["geometry_msgs/msg/Point"](x=pad_x + 0.06, y=0.08, z=0.56), pad_error=0.1))
    writer.close()
    return path


@pytest.fixture(scope="module")
def flight(tmp_path_factory):
    return write_flight(str(tmp_path_factory.mktemp("bags") / "flight.bag"))


@pytest.fixture(scope="module")
def analyzed(flight, tmp_path_factory):
    out = str(tmp_path_factory.mktemp("out"))
    metrics = analyze.analyze(flight, out)
    return metrics, out


def load(out):
    with open(os.path.join(out, "metrics.json")) as stream:
        return json.load(stream)


# ----------------------------------------------------------------------------------------------------

def test_the_synthetic_flight_gives_the_hand_computed_metrics(analyzed):
    _, out = analyzed
    m = load(out)
    assert m["outcome"] == "landed_on_pad" and m["landed_on_pad"] is True
    assert m["touchdown_error_m"] == pytest.approx(0.1, abs=1e-6)
    assert m["touchdown"]["surface"] == "pad" and m["touchdown"]["crashed"] is False
    assert m["touchdown"]["resting_pad_error_m"] == pytest.approx(0.1, abs=1e-6)
    assert m["time_to_land_s"] == pytest.approx(24.5)        # takeoff command 1.5 s -> touchdown 26 s
    assert m["time_to_land"]["from"] == "first /ardrone/takeoff command"
    te = m["tracking_error"]
    # 20 Hz grid over [4, 26): 400 points at 0.5 m (t < 24) and 40 at 0.1 m
    assert te["samples"] == 440
    assert te["mae_m"] == pytest.approx((400 * 0.5 + 40 * 0.1) / 440, abs=1e-4)
    assert te["rmse_m"] == pytest.approx(math.sqrt((400 * 0.25 + 40 * 0.01) / 440), abs=1e-4)
    assert te["by_state"]["TRACKING"]["mae_m"] == pytest.approx(0.5, abs=1e-4)
    assert te["by_state"]["LANDING"]["mae_m"] == pytest.approx(0.1, abs=1e-4)
    assert m["vision_error"]["mae_m"] == pytest.approx(0.1, abs=1e-6)
    assert m["vision_error"]["samples"] == 220
    pe = m["prediction_error"]
    assert pe["mae_m"] == pytest.approx(0.2, abs=1e-6) and pe["horizon_s"] == pytest.approx(1.0)
    assert pe["first_pose"]["mae_m"] == pytest.approx(0.0, abs=1e-6)
    assert [s["state"] for s in m["state_timeline"]] == ["LANDED", "TAKING_OFF", "TRACKING", "LANDING", "LANDED"]
    assert m["state_timeline"][2]["start_s"] == 4.0 and m["state_timeline"][2]["end_s"] == 24.0
    assert m["decisions"] == [{"t": 1.0, "condition": "wind_strong", "flag": 2, "action": "warn",
                               "reason": "strong wind: 7.5 m/s", "value": 7.5}]
    assert m["battery"]["start_pct"] == pytest.approx(90.0)
    assert m["battery_used_pct"] == pytest.approx(0.1 * 29.98, abs=1e-3)
    assert m["max_wind_mps"] == 7.5
    assert m["data"]["status"] == "ok" and m["data"]["problems"] == []
    # metrics whose topics were never recorded are null, with a note naming the topic
    assert m["kalman_odom_error"] is None and "/kalman_platform_odom" in m["notes"]["kalman_odom_error"]
    assert m["estimate_error"] is None and "/ardrone/odom_estimate" in m["notes"]["estimate_error"]


def test_every_output_is_written(analyzed):
    _, out = analyzed
    for name in ("metrics.json", "timeseries.csv", "top_view.png", "altitude.png", "errors.png", "report.md"):
        path = os.path.join(out, name)
        assert os.path.getsize(path) > 100, name
    with open(os.path.join(out, "timeseries.csv")) as stream:
        rows = stream.read().splitlines()
    assert rows[0].startswith("t_s,drone_x_m,drone_y_m,drone_z_m,pad_x_m")
    assert 590 <= len(rows) - 1 <= 601                    # 30 s at 20 Hz
    header = rows[0].split(",")
    row = dict(zip(header, rows[1 + 20 * 10].split(",")))  # t = 10 s
    assert float(row["t_s"]) == pytest.approx(10.0)
    assert float(row["tracking_error_m"]) == pytest.approx(0.5, abs=1e-3)
    assert row["tracker_state"] == "TRACKING" and row["navdata_state"] == "FLYING"
    with open(os.path.join(out, "report.md")) as stream:
        report = stream.read()
    assert "landed on the pad" in report and "![Top view](top_view.png)" in report


def test_the_fixture_from_a_simulator_run_reads_with_its_recorded_definitions(tmp_path):
    m = analyze.analyze(FIXTURE, str(tmp_path), plots=False)
    assert m["outcome"] == "landed_on_pad"
    assert m["touchdown_error_m"] == pytest.approx(0.0638, abs=1e-4)
    assert m["time_to_land_s"] == pytest.approx(104.24, abs=0.01)
    assert [s["state"] for s in m["state_timeline"]] == ["LANDED", "TAKING_OFF", "TRACKING", "LANDING", "LANDED"]
    assert 0.0 < m["tracking_error"]["mae_m"] < 0.25
    assert m["vision_error"]["samples"] > 100 and m["prediction_error"]["horizon_s"] == pytest.approx(2.0)
    # A bag of before the drivers' interfaces: the drone's status was /ardrone/navdata, read all the same.
    assert m["data"]["topics"]["/ardrone/navdata"] > 1000 and m["battery"] is not None


def test_a_truncated_bag_is_read_as_far_as_it_goes(flight, tmp_path):
    half = str(tmp_path / "half.bag")
    with open(flight, "rb") as src, open(half, "wb") as dst:
        data = src.read()
        dst.write(data[:len(data) // 2])
    out = str(tmp_path / "out")
    result = run_cli([half, "--out", out])
    assert result.returncode == 0, result.stderr
    assert "truncated" in result.stderr and half in result.stderr
    m = load(out)
    data = m["data"]
    assert data["status"] == "recovered" and data["truncated"] is True
    assert any("truncated" in p for p in data["problems"])
    first, last = data["time_range_recovered_s"]
    assert first == pytest.approx(0.0) and 8.0 < last < 25.0   # roughly the first half of the 30 s
    assert m["tracking_error"] is not None and m["tracking_error"]["by_state"]["TRACKING"]["mae_m"] == pytest.approx(0.5, abs=1e-3)
    assert m["outcome"] is None and "touchdown" in m["notes"]["outcome"]   # the touchdown was in the lost half
    with open(os.path.join(out, "report.md")) as stream:
        assert "The bag is damaged" in stream.read()


def test_a_damaged_chunk_is_skipped_and_the_rest_is_read(flight, tmp_path):
    bad = str(tmp_path / "garbled.bag")
    with open(flight, "rb") as stream:
        data = bytearray(stream.read())
    start = int(len(data) * 0.4)
    data[start:start + 3000] = bytes((i * 37 + 11) % 256 for i in range(3000))
    with open(bad, "wb") as stream:
        stream.write(bytes(data))
    contents = read_bag(bad, analyze.TOPICS)
    assert contents.integrity["status"] == "recovered"
    assert contents.integrity["unreadable_regions"]
    # the end of the flight, after the damage, is still there
    assert [td.surface for _, td in contents.get("/ardrone/touchdown")] == [1]
    assert len(contents.get("/drone/navdata")) > 1000
    m = analyze.analyze(bad, str(tmp_path / "out"), plots=False)
    assert m["outcome"] == "landed_on_pad" and m["data"]["problems"]


def test_missing_topics_give_nulls_with_notes_not_a_crash(tmp_path):
    bag = write_flight(str(tmp_path / "nav_only.bag"), duration=10.0, topics={"/drone/navdata"})
    out = str(tmp_path / "out")
    m = analyze.analyze(bag, out)
    for key, topic in (("tracking_error", "/groundtruth/ardrone"), ("vision_error", "/platform/current_platform"),
                       ("prediction_error", "/kalman_prediction_path"), ("state_timeline", "/platform_tracking/state"),
                       ("decisions", "/supervisor/decisions")):
        assert m[key] is None and topic in m["notes"][key], key
    assert m["battery"] is not None and m["navdata_timeline"]
    assert m["max_wind_mps"] is None and "wind" in m["notes"]["max_wind_mps"]
    assert os.path.isfile(os.path.join(out, "errors.png"))
    # Missing ground truth is news; the emergency coordinates of a flight without an emergency landing are not.
    assert "/groundtruth/ardrone" in m["data"]["missing_topics"]
    assert "/emergency/position" not in m["data"]["missing_topics"]


def test_decisions_in_a_custom_message_type_are_accepted(tmp_path):
    definition = "float64 t\nstring condition\nuint8 flag\nstring action\nstring reason\nfloat64 value\n"
    extra = get_types_from_msg(definition, "test_msgs/msg/Decision")
    bag = write_flight(str(tmp_path / "custom.bag"), duration=3.0, decision_type=extra)
    m = analyze.analyze(bag, str(tmp_path / "out"), plots=False)
    assert m["decisions"][0]["action"] == "warn" and m["decisions"][0]["value"] == 7.5
    assert m["max_wind_mps"] == 7.5


@pytest.mark.parametrize("content,expected", [(None, "no such file"), (b"", "empty"),
                                              (b"hello, not a bag\n" * 10, "not a ROS 1 bag")])
def test_unusable_input_is_named_and_exits_non_zero(tmp_path, content, expected):
    path = str(tmp_path / "input.bag")
    if content is not None:
        with open(path, "wb") as stream:
            stream.write(content)
    with pytest.raises(BagError, match=expected):
        read_bag(path)
    result = run_cli([path, "--out", str(tmp_path / "out")])
    assert result.returncode == 2
    assert path in result.stderr and expected in result.stderr


def test_a_bag_cut_inside_its_header_has_nothing_usable(flight, tmp_path):
    path = str(tmp_path / "stub.bag")
    with open(flight, "rb") as src, open(path, "wb") as dst:
        dst.write(src.read(100))
    result = run_cli([path, "--out", str(tmp_path / "out")])
    assert result.returncode == 2 and "nothing usable" in result.stderr


# ----------------------------------------------------------------------------------------------------
# Clean environment: nothing sourced, no master, no ROS python modules.

def clean_env(tmp_path):
    return {"PATH": "/usr/bin:/bin", "HOME": str(tmp_path), "LANG": "C.UTF-8", "MPLCONFIGDIR": str(tmp_path / "mpl")}


def run_cli(args, cwd=None):
    """The command line of this package (landing_eval's `analyze` entry point is tested in landing_eval)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([SRC] + [p for p in [os.environ.get("PYTHONPATH")] if p]))
    return subprocess.run([sys.executable, "-m", "flight_analysis.analyze"] + args, capture_output=True, text=True,
                          timeout=SUBPROCESS_TIMEOUT, cwd=cwd, env=env)


def test_python_dash_m_works_in_a_clean_environment_without_ros(flight, tmp_path):
    """From any directory: the venv finds the package through the .pth file `make build` writes."""
    out = str(tmp_path / "out")
    result = subprocess.run([sys.executable, "-m", "flight_analysis.analyze", flight, "--out", out], cwd=str(tmp_path),
                            env=clean_env(tmp_path), capture_output=True, text=True, timeout=SUBPROCESS_TIMEOUT)
    assert result.returncode == 0, result.stderr
    assert "landed_on_pad" in result.stdout
    assert load(out)["outcome"] == "landed_on_pad"
    # and it never imports ROS
    code = ("import sys, flight_analysis.analyze as a; a.analyze(sys.argv[1], sys.argv[2], plots=False); "
            "bad = [m for m in sys.modules if m.split('.')[0] in ('rospy', 'rosbag', 'roslib', 'genpy', 'rosgraph')]; "
            "print('ROS modules:', bad); sys.exit(1 if bad else 0)")
    result = subprocess.run([sys.executable, "-c", code, flight, str(tmp_path / "out2")], cwd=str(tmp_path),
                            env=clean_env(tmp_path), capture_output=True, text=True, timeout=SUBPROCESS_TIMEOUT)
    assert result.returncode == 0, result.stdout + result.stderr


def test_reading_is_the_same_with_and_without_the_index(flight):
    """The recovery reader (no index) and rosbags (index) decode the same messages."""
    from flight_analysis.analysis_bag import _read_by_scanning
    indexed = read_bag(flight, analyze.TOPICS)
    scanned = _read_by_scanning(flight, set(analyze.TOPICS), "test", {}, {})
    assert set(indexed.messages) == set(scanned.messages)
    for topic in indexed.messages:
        a, b = indexed.messages[topic], scanned.messages[topic]
        assert len(a) == len(b), topic
        assert [t for t, _ in a] == pytest.approx([t for t, _ in b])
    pad_a = np.array([m.pose.position.x for _, m in indexed.get("/groundtruth/landing_pad")])
    pad_b = np.array([m.pose.position.x for _, m in scanned.get("/groundtruth/landing_pad")])
    assert np.array_equal(pad_a, pad_b)


def test_a_bag_without_any_time_series_still_gives_a_report(tmp_path):
    bag = write_flight(str(tmp_path / "decisions_only.bag"), duration=3.0, topics={"/supervisor/decisions"})
    out = str(tmp_path / "out")
    m = analyze.analyze(bag, out)
    assert m["decisions"][0]["condition"] == "wind_strong"
    assert m["tracking_error"] is None and m["battery"] is None and m["outcome"] is None
    assert os.path.isfile(os.path.join(out, "top_view.png")) and os.path.isfile(os.path.join(out, "report.md"))


def test_camera_frames_become_an_animated_gif(tmp_path):
    store = get_typestore(Stores.ROS1_NOETIC)
    T = store.types
    path = str(tmp_path / "camera.bag")
    with Writer(path) as writer:
        conn = writer.add_connection("/ardrone/bottom/image_raw", "sensor_msgs/msg/Image", typestore=store)
        for k in range(90):  # 3 s at 30 Hz: thinned to 2 Hz -> 6 frames
            t = k / 30.0
            image = np.zeros((24, 32, 3), dtype=np.uint8)
            image[:, :, 0] = (k * 3) % 256
            msg = T["sensor_msgs/msg/Image"](header=header(store, t, "ardrone/bottom_camera"), height=24, width=32,
                                             encoding="rgb8", is_bigendian=0, step=96, data=image.reshape(-1))
            writer.write(conn, int(round(t * 1e9)) + 1, store.serialize_ros1(msg, "sensor_msgs/msg/Image"))
    out = str(tmp_path / "out")
    m = analyze.analyze(path, out)
    assert "camera.gif" in m["outputs"]
    from PIL import Image
    with Image.open(os.path.join(out, "camera.gif")) as gif:
        assert gif.n_frames == 6 and gif.size == (32, 24)
