"""Web operator station, ROS-free parts: message validation, the pad mapping to thesis Tables 3.1/3.2,
Manual Control per page, the access rule, the translation of ROS messages into what the page shows, and the
aiohttp server itself on a loopback port (commands, errors, 401, Origin, slow pages)."""
import asyncio
import json
import math
import os
import sys
import threading

import pytest
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "src"))
from ardrone_moves.keyboard import KeyboardConfig  # noqa: E402
from ardrone_moves.mapping import STOP, JoystickConfig  # noqa: E402
from interface.conditions import load_table  # noqa: E402
from interface.console_model import ConsoleModel, panel_keys  # noqa: E402
from interface.station_auth import Access, host_name, is_loopback  # noqa: E402
from interface.station_manual import ManualControl  # noqa: E402
from interface.station_model import StationModel, translate_odometry, translate_path, translate_point  # noqa: E402
from interface.station_protocol import BadMessage, parse, standard_to_joy  # noqa: E402

PACKAGE = os.path.join(HERE, "..")
ARDRONE_MOVES_CONFIG = os.path.join(HERE, "..", "..", "ardrone_moves", "config")
WEB = os.path.join(PACKAGE, "web")


def config(name):
    with open(os.path.join(ARDRONE_MOVES_CONFIG, name)) as stream:
        return yaml.safe_load(stream)


# ----- what a page may send ---------------------------------------------------------------------------------
def test_commands_are_a_fixed_list():
    assert parse('{"type": "command", "name": "landing", "id": 3}') == {"type": "command", "name": "landing"}
    with pytest.raises(BadMessage, match="unknown command 'rm -rf': expected one of start, landing"):
        parse('{"type": "command", "name": "rm -rf"}')
    with pytest.raises(BadMessage, match="unknown message type 'shell'"):
        parse('{"type": "shell", "name": "ls"}')
    with pytest.raises(BadMessage, match="not JSON"):
        parse("landing")
    with pytest.raises(BadMessage, match="expected a JSON object"):
        parse("[1, 2]")
    with pytest.raises(BadMessage, match="refused: at most 4096"):
        parse(json.dumps({"type": "command", "name": "x" * 5000}))


def test_conditions_are_validated_like_the_supervisor_reads_them():
    assert parse('{"type": "set", "name": "drone_battery", "value": "10"}') == {
        "type": "set", "name": "drone_battery", "value": 10.0}
    assert parse('{"type": "set", "name": "temp", "value": -5}')["value"] == -5.0
    with pytest.raises(BadMessage, match=r"drone_battery = 150 is outside 0..100 %"):
        parse('{"type": "set", "name": "drone_battery", "value": 150}')
    with pytest.raises(BadMessage, match="must be a finite number"):
        parse('{"type": "set", "name": "wind_speed", "value": NaN}')
    with pytest.raises(BadMessage, match="must be a number in 0..60 m/s, got 'abc'"):
        parse('{"type": "set", "name": "wind_speed", "value": "abc"}')
    with pytest.raises(BadMessage, match="unknown condition 'use_sim_time'"):
        parse('{"type": "set", "name": "use_sim_time", "value": 0}')


def test_keys_and_pads_are_checked():
    assert parse('{"type": "key", "key": "i"}')["key"] == "i"
    with pytest.raises(BadMessage, match="not a teleop key"):
        parse('{"type": "key", "key": "x"}')
    joy = parse(json.dumps({"type": "joy", "axes": [0, 2.0, 0, 0], "buttons": [0] * 17}))
    assert joy["axes"][1] == 1.0  # clipped to the stick's travel
    with pytest.raises(BadMessage, match="is the pad's mapping 'standard'"):
        parse(json.dumps({"type": "joy", "axes": [0, 0], "buttons": [0] * 4}))
    with pytest.raises(BadMessage, match="button 3 must be a finite number"):
        parse(json.dumps({"type": "joy", "axes": [0] * 4, "buttons": [0, 0, 0, "x"] + [0] * 13}))


def test_gamepad_standard_layout_becomes_the_thesis_tables():
    buttons = [0.0] * 17
    buttons[0] = 1.0   # the standard layout's bottom face button: Cross (X)
    buttons[4] = 1.0   # L1
    buttons[16] = 1.0  # PS
    axes, joy_buttons = standard_to_joy([-1.0, -1.0, 0.5, 0.0], buttons)
    # Table 3.1: 0 Square, 1 X, 2 Circle, 3 Triangle, 4 L1, ... 12 PS, 13 Touch Pad
    assert joy_buttons == [0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 1, 0]
    # Table 3.2: Left X, Left Y, Right X, Right Y, L2, R2, Touch Pad X/Y; stick left and up read +1
    assert axes == [1.0, 1.0, -0.5, 0.0, 1.0, 1.0, 0.0, 0.0]


def manual():
    return ManualControl(KeyboardConfig.from_dict(config("keyboard.yaml")), JoystickConfig.from_dict(config("ps4.yaml")),
                         stale_s=0.5)


def pad(l1=False, right_y=0.0, triangle=False):
    buttons = [0.0] * 17
    buttons[4], buttons[3] = float(l1), float(triangle)
    return [0.0, 0.0, 0.0, right_y], buttons


def test_manual_control_needs_the_dead_man_and_stops_once_on_release_or_silence():
    control = manual()
    assert control.joy(*pad(l1=False, right_y=-1.0), now=0.0) == (None, [])  # sticks without L1: nothing
    command, actions = control.joy(*pad(l1=True, right_y=-1.0), now=0.05)   # L1 + right stick up
    assert command.forward == pytest.approx(1.5) and actions == ["manual"]
    assert control.joy(*pad(l1=False), now=0.1) == (STOP, [])
    assert control.joy(*pad(l1=False), now=0.15) == (None, [])
    assert control.joy(*pad(triangle=True), now=0.2) == (None, ["takeoff"])  # Triangle: take off, no dead-man
    control.joy(*pad(l1=True, right_y=-0.5), now=0.3)
    assert control.tick(0.5) == []
    assert control.tick(0.9) == [STOP]          # the page fell silent while flying
    assert control.tick(1.5) == []


def test_manual_keys_as_the_teleop_and_a_closing_page_stops_the_drone():
    control = manual()
    actions, _ = control.key("i", 0.0)
    assert actions == ("manual",)
    [command] = control.tick(0.1)
    assert command.forward == pytest.approx(0.5) and command.left == 0.0
    assert control.close(0.2) == [STOP]
    assert manual().close(0.0) == []


# ----- who may connect ---------------------------------------------------------------------------------------
def test_loopback_needs_no_token_but_a_loopback_host_header():
    access = Access("127.0.0.1")
    assert access.token is None
    assert access.check("127.0.0.1:8080") is None and access.check("localhost:8080") is None
    status, reason = access.check("evil.example:8080")
    assert status == 403 and "loopback only" in reason
    assert is_loopback("::1") and is_loopback("127.0.0.2") and not is_loopback("0.0.0.0")
    assert host_name("[::1]:8080") == "::1" and host_name("localhost") == "localhost"


def test_any_other_host_needs_the_token():
    access = Access("0.0.0.0", token="s3cret-token")
    status, reason = access.check("192.0.2.7:8080")
    assert status == 401 and "?token=TOKEN" in reason
    assert access.check("192.0.2.7:8080", query_token="wrong") is not None
    assert access.check("192.0.2.7:8080", query_token="s3cret-token") is None
    assert access.check("127.0.0.1:8080", header_token="s3cret-token") is None
    assert access.check("x", authorization="Bearer s3cret-token") is None
    assert access.check("x", cookie_token="s3cret-token") is None
    assert len(Access("0.0.0.0").token) >= 24


def test_websocket_origin_must_be_the_station_itself():
    assert Access.origin_allowed("http://127.0.0.1:8080", "127.0.0.1:8080")
    assert not Access.origin_allowed("http://evil.example", "127.0.0.1:8080")
    assert not Access.origin_allowed("http://127.0.0.1:9999", "127.0.0.1:8080")
    assert not Access.origin_allowed(None, "127.0.0.1:8080")


# ----- message translation and the page's state ---------------------------------------------------------------
def test_ros_messages_translate_to_map_values():
    from geometry_msgs.msg import PointStamped, PoseStamped
    from landing_msgs.msg import PositionXYCommand
    from nav_msgs.msg import Odometry, Path
    odometry = Odometry()
    odometry.pose.pose.position.x, odometry.pose.pose.position.y, odometry.pose.pose.position.z = 1.0, 2.0, 3.0
    odometry.pose.pose.orientation.z = math.sin(math.pi / 4)   # 90 deg about z
    odometry.pose.pose.orientation.w = math.cos(math.pi / 4)
    odometry.twist.twist.linear.x, odometry.twist.twist.linear.y = 3.0, 4.0
    drone = translate_odometry(odometry)
    assert drone["x"] == 1.0 and drone["z"] == 3.0 and drone["speed"] == 5.0
    assert drone["yaw"] == pytest.approx(math.pi / 2)
    path = Path()
    for i in range(101):
        pose = PoseStamped()
        pose.pose.position.x, pose.pose.position.y = 0.1 * i, -0.1 * i
        path.poses.append(pose)
    points = translate_path(path, max_points=60)
    assert len(points) == 60 and points[0] == [0.0, 0.0] and points[-1] == pytest.approx([10.0, -10.0])
    assert translate_path(Path()) == []
    point = PointStamped()
    point.point.x, point.point.y = 4.0, 5.0
    assert translate_point(point) == (4.0, 5.0)
    assert translate_point(PositionXYCommand(x=1.5, y=-2.5)) == (1.5, -2.5)


def station_model():
    return StationModel(ConsoleModel(condition_keys=panel_keys(load_table(os.path.join(PACKAGE, "config",
                                                                                         "conditions.yaml")))))


def test_state_follows_the_thesis_menus_and_counts_down():
    model = station_model()
    model.on_time(5.0)
    assert model.state()["screen"] == "start"
    model.console.on_flight_management({"open": True, "auto_takeoff_at": 35.0})
    model.on_time(12.0)
    state = model.state()
    assert state["screen"] == "flight_management" and state["countdown"] == 23.0
    model.console.mode = "landing"
    model.console.camera_latency = 0.1234
    model.console.warning = {"id": 2, "message": "strong wind", "options": ["manual", "emergency", "continue"],
                             "deadline": 20.0}
    state = model.state()
    assert state["screen"] == "landing" and state["countdown"] is None
    assert state["landing"]["camera_latency"] == 0.123
    assert state["warning"] == {"id": 2, "message": "strong wind", "options": ["manual", "emergency", "continue"],
                                "time_left": 8.0}
    model.on_decision({"t": 13.0, "condition": "drone_battery_critical", "flag": 1, "action": "emergency_landing",
                       "reason": "drone battery critical"})
    model.console.mode = "emergency"
    model.console.emergency_position = (3.14159, -2.0)
    state = model.state()
    assert state["screen"] == "emergency"
    assert state["emergency"] == {"x": 3.14, "y": -2.0, "acknowledged": False}
    battery = [row for row in state["rows"] if row["key"] == "drone_battery"][0]
    assert battery["flag"] == 1 and "drone battery critical" in battery["note"]
    model.on_decision({"t": 14.0, "condition": "operator", "flag": None, "action": "ack", "reason": "ack"})
    assert model.state()["emergency"]["acknowledged"] is True
    json.dumps(model.state(), allow_nan=False)  # what the page gets is plain JSON


def test_history_keeps_the_last_minute_and_decisions_are_numbered():
    model = station_model()
    model.altitude = 2.0
    for step in range(900):   # 90 s at 10 Hz
        model.on_time(step * 0.1)
        model.pad = (step * 0.1, 0.0)
        model.sample()
    history = model.history()
    assert history["plot"][0][0] >= 89.9 - 60.0 and history["plot"][-1][0] == pytest.approx(89.9)
    assert 590 <= len(history["plot"]) <= 601 and 295 <= len(history["pad_trail"]) <= 301
    for i in range(250):
        model.on_decision({"t": i, "condition": "c", "flag": None, "action": "warn", "reason": str(i)})
    assert [d["seq"] for d in model.decisions_since(248)] == [249, 250]
    assert len(model.decisions_since(0)) == 50 and model.decisions_since(0)[-1]["reason"] == "249"
    model.on_time(1.0)  # the simulation restarted
    assert model.history()["plot"] == []


# ----- the server on a loopback port -----------------------------------------------------------------------------
class Actions:
    """The node's side of the server, recording what the pages asked for."""

    def __init__(self):
        self.calls, self.watching = [], 0

    def command(self, name):
        self.calls.append(("command", name))
        return True, "sent: %s" % name

    def set_condition(self, name, value):
        self.calls.append(("set", name, value))
        return True, "/%s = %g" % (name, value)

    def manual(self, client, message):
        self.calls.append(("manual", message["type"]))
        return True, None

    def client_closed(self, client):
        self.calls.append(("closed", client))

    def watchers(self, count):
        self.watching = count


class Frames:
    def __init__(self, size=16):
        self.seq, self.padding = 0, b"\0" * size

    def latest(self):
        self.seq += 1
        return self.seq, b"\xff\xd8 jpeg %d" % self.seq + self.padding


def run_server(access, scenario, frames=None, **kwargs):
    from interface.station_server import StationServer
    aiohttp = pytest.importorskip("aiohttp")

    async def main():
        model, actions = station_model(), Actions()
        server = StationServer(model, threading.Lock(), actions, access, WEB, camera=frames or Frames(), rate_hz=20.0,
                               **kwargs)
        host, port = (await server.start("127.0.0.1", 0))[0][:2]
        try:
            async with aiohttp.ClientSession(cookie_jar=aiohttp.CookieJar(unsafe=True)) as session:
                return await asyncio.wait_for(scenario(session, "http://%s:%d" % (host, port), server, actions), 60)
        finally:
            await server.stop()
    return asyncio.run(main())


def test_server_serves_the_page_and_takes_commands_over_the_websocket():
    async def scenario(session, base, server, actions):
        async with session.get(base + "/") as response:
            assert response.status == 200 and "Flight Management" in await response.text()
            assert "default-src 'self'" in response.headers["Content-Security-Policy"]
        async with session.get(base + "/static/station.js") as response:
            assert response.status == 200
        from yarl import URL
        async with session.get(URL(base + "/static/..%2F..%2Fconfig%2Fstation.yaml", encoded=True)) as response:
            assert response.status == 404
        async with session.ws_connect(base + "/ws", headers={"Origin": base}) as ws:
            first = json.loads((await ws.receive()).data)
            assert first["type"] == "history" and "drone_battery" in first["conditions"]
            kinds = set()
            while not {"state", "frame"} <= kinds:
                message = await ws.receive()
                kinds.add("frame" if message.type.name == "BINARY" else json.loads(message.data)["type"])
            assert actions.watching == 1
            await ws.send_str(json.dumps({"type": "command", "name": "start", "id": 7}))
            await ws.send_str(json.dumps({"type": "command", "name": "self_destruct", "id": 8}))
            await ws.send_str(json.dumps({"type": "set", "name": "drone_battery", "value": 10, "id": 9}))
            await ws.send_str(json.dumps({"type": "key", "key": "i"}))
            replies = {}
            while len(replies) < 3:
                message = await ws.receive()
                if message.type.name == "TEXT" and json.loads(message.data)["type"] == "reply":
                    reply = json.loads(message.data)
                    replies[reply["id"]] = reply
        assert replies[7] == {"type": "reply", "id": 7, "ok": True, "message": "sent: start"}
        assert not replies[8]["ok"] and "unknown command 'self_destruct'" in replies[8]["message"]
        assert replies[9]["ok"]
        for _ in range(100):
            if ("closed", 1) in actions.calls:
                break
            await asyncio.sleep(0.05)
        assert actions.calls == [("command", "start"), ("set", "drone_battery", 10.0), ("manual", "key"), ("closed", 1)]
        assert actions.watching == 0
    run_server(Access("127.0.0.1"), scenario)


def test_server_refuses_without_token_and_foreign_origins():
    access = Access("0.0.0.0", token="tok-123")   # the rule for a non-loopback host; the test listens on loopback

    async def scenario(session, base, server, actions):
        async with session.get(base + "/") as response:
            assert response.status == 401 and "?token=TOKEN" in await response.text()
        async with session.get(base + "/api/state") as response:
            assert response.status == 401
        async with session.get(base + "/?token=tok-123") as response:
            assert response.status == 200
        async with session.get(base + "/static/station.css") as response:   # the cookie the page got
            assert response.status == 200
        async with session.get(base + "/api/state", headers={"X-Station-Token": "tok-123"}) as response:
            assert (await response.json())["screen"] == "start"
        async with session.get(base + "/ws", headers={"Origin": "http://evil.example", "Connection": "Upgrade",
                                                      "Upgrade": "websocket", "Sec-WebSocket-Version": "13",
                                                      "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ=="}) as response:
            assert response.status == 403
    run_server(access, scenario)


def test_a_page_that_does_not_read_is_dropped_and_the_others_go_on():
    async def scenario(session, base, server, actions):
        reader = await session.ws_connect(base + "/ws", headers={"Origin": base})
        # A client whose socket never drains (2 MB frames fill the socket buffers within a second or two):
        # the station must close it, not buffer for it.
        sleeper = await session.ws_connect(base + "/ws", headers={"Origin": base}, max_msg_size=0)
        transport = sleeper._response.connection.transport
        transport.pause_reading()
        states = 0
        while server.stats["dropped_slow"] == 0 or states < 20:
            message = await reader.receive()
            states += message.type.name == "TEXT"
            assert not reader.closed
        assert len(server.clients) == 1
        await reader.close()
        transport.resume_reading()  # so its close handshake need not wait for its own timeout
        await sleeper.close()
    run_server(Access("127.0.0.1"), scenario, frames=Frames(size=2000000), send_timeout_s=0.5)
