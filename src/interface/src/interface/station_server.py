"""HTTP and WebSocket server of the web operator station (aiohttp), ROS-free.

One page (``static_dir``: index.html, station.js, station.css; nothing from a CDN), one WebSocket per page
at ``/ws``. A ticker builds the model's state once per tick (``rate_hz``) and every client's sender
pushes the newest state, the decisions it has not had and the newest camera frame (binary JPEG): a slow
client skips ticks instead of queueing them, and one that takes longer than ``send_timeout_s`` to take a
message is dropped, so no client can make the station buffer without bound or slow the others. What a
client sends is validated by station_protocol and handed to ``actions``.

``actions`` has: command(name), set_condition(name, value), manual(client_id, message) -> (ok, text), and
client_closed(client_id), watchers(count). ``camera.latest()`` -> (sequence number, JPEG bytes or None).
``model`` is a StationModel guarded by ``lock`` (the ROS callbacks write it from their threads).
"""
import asyncio
import itertools
import json
import logging
import os

from aiohttp import WSMsgType, web

from .station_auth import COOKIE, HEADER, Access
from .station_protocol import MAX_MESSAGE_BYTES, BadMessage, parse

LOG = logging.getLogger("interface.station")
SECURITY_HEADERS = {
    # everything comes from the station itself: no CDN, no inline script, no framing by other sites
    "Content-Security-Policy": "default-src 'self'; img-src 'self' blob: data:; connect-src 'self'; "
                               "frame-ancestors 'none'",
    "X-Content-Type-Options": "nosniff",
    "Cache-Control": "no-cache",
}
STATIC_FILES = {"station.js": "application/javascript", "station.css": "text/css", "index.html": "text/html"}


def _request_id(text):
    """The page's number of a request, echoed in the reply so it can match them (None if there is none)."""
    try:
        request_id = json.loads(text).get("id") if len(text) <= MAX_MESSAGE_BYTES else None
    except (ValueError, AttributeError):
        return None
    return request_id if isinstance(request_id, (int, str)) and not isinstance(request_id, bool) else None


class StationServer:
    def __init__(self, model, lock, actions, access, static_dir, camera=None, rate_hz=20.0, send_timeout_s=5.0,
                 max_clients=20, heartbeat_s=10.0, clock=None):
        if not os.path.isfile(os.path.join(static_dir, "index.html")):
            raise FileNotFoundError("no index.html in %s: set ~static_dir to interface's web/ folder" % static_dir)
        self.model, self.lock, self.actions, self.access = model, lock, actions, access
        self.static_dir, self.camera = static_dir, camera
        self.period, self.send_timeout_s, self.max_clients = 1.0 / rate_hz, send_timeout_s, max_clients
        self.heartbeat_s, self.clock = heartbeat_s, clock  # clock(): sim time now, for countdowns and plots
        self.clients = {}                 # id -> WebSocketResponse
        self.ids = itertools.count(1)
        self.state_text, self.tick = None, 0
        self.ticked = None                # asyncio.Condition, created in the loop
        self.stats = {"ticks": 0, "messages_in": 0, "refused": 0, "dropped_slow": 0}
        self.app = web.Application(middlewares=[self._guard])
        self.app.add_routes([web.get("/", self._index), web.get("/static/{name}", self._static),
                             web.get("/api/state", self._api_state), web.get("/ws", self._websocket)])
        self.runner, self.addresses = None, []

    # ----- life cycle ----------------------------------------------------------------------------------
    async def start(self, host, port):
        self.ticked = asyncio.Condition()
        self.runner = web.AppRunner(self.app, access_log=None, handle_signals=False)
        await self.runner.setup()
        site = web.TCPSite(self.runner, host, port, shutdown_timeout=1.0)
        await site.start()
        self.addresses = self.runner.addresses
        self._ticker = asyncio.ensure_future(self._tick_loop())
        return self.addresses

    async def stop(self):
        self._ticker.cancel()
        for ws in list(self.clients.values()):
            await ws.close(code=1001, message=b"station stopping")
        await self.runner.cleanup()

    # ----- access ----------------------------------------------------------------------------------------
    @web.middleware
    async def _guard(self, request, handler):
        refusal = self.access.check(request.host, query_token=request.query.get("token"),
                                    header_token=request.headers.get(HEADER),
                                    authorization=request.headers.get("Authorization"),
                                    cookie_token=request.cookies.get(COOKIE))
        if refusal is not None:
            self.stats["refused"] += 1
            status, reason = refusal
            return web.Response(status=status, text=reason + "\n", headers=SECURITY_HEADERS)
        response = await handler(request)
        if self.access.token and request.query.get("token"):
            response.set_cookie(COOKIE, self.access.token, httponly=True, samesite="Strict")
        return response

    # ----- pages -------------------------------------------------------------------------------------------
    async def _index(self, request):
        return self._file("index.html")

    async def _static(self, request):
        name = request.match_info["name"]
        if name not in STATIC_FILES:
            raise web.HTTPNotFound(text="no such file: %s (the station serves %s)" % (name, ", ".join(STATIC_FILES)))
        return self._file(name)

    def _file(self, name):
        with open(os.path.join(self.static_dir, name), "rb") as stream:
            return web.Response(body=stream.read(), content_type=STATIC_FILES[name], headers=SECURITY_HEADERS)

    async def _api_state(self, request):
        with self.lock:
            state = self.model.state()
        return web.json_response(state, headers=SECURITY_HEADERS)

    # ----- live data -----------------------------------------------------------------------------------------
    async def _tick_loop(self):
        loop = asyncio.get_running_loop()
        next_tick = loop.time()
        while True:
            now = self.clock() if self.clock else None
            with self.lock:
                if now is not None:
                    self.model.on_time(now)
                self.model.sample()
                self.state_text = json.dumps(self.model.state(), separators=(",", ":")) if self.clients else None
            self.tick += 1
            self.stats["ticks"] += 1
            async with self.ticked:
                self.ticked.notify_all()
            next_tick = max(next_tick + self.period, loop.time())
            await asyncio.sleep(next_tick - loop.time())

    async def _websocket(self, request):
        if not Access.origin_allowed(request.headers.get("Origin"), request.host):
            self.stats["refused"] += 1
            return web.Response(status=403, text="WebSocket refused: Origin %r is not this station's page\n"
                                % request.headers.get("Origin"), headers=SECURITY_HEADERS)
        if len(self.clients) >= self.max_clients:
            return web.Response(status=503, text="the station already serves %d pages; close one\n"
                                % self.max_clients, headers=SECURITY_HEADERS)
        ws = web.WebSocketResponse(heartbeat=self.heartbeat_s, max_msg_size=MAX_MESSAGE_BYTES)
        await ws.prepare(request)
        client = next(self.ids)
        self.clients[client] = ws
        self.actions.watchers(len(self.clients))
        LOG.info("station: page %d connected from %s (%d open)", client, request.remote, len(self.clients))
        sender = asyncio.ensure_future(self._send_loop(client, ws))
        try:
            async for message in ws:
                if message.type == WSMsgType.TEXT:
                    self.stats["messages_in"] += 1
                    reply = self._handle(client, message.data)
                    if reply is not None:
                        await self._send(ws, ws.send_str(json.dumps(reply)))
                elif message.type == WSMsgType.ERROR:
                    break
        finally:
            sender.cancel()
            del self.clients[client]
            self.actions.client_closed(client)
            self.actions.watchers(len(self.clients))
            LOG.info("station: page %d closed (%d open)", client, len(self.clients))
        return ws

    def _handle(self, client, text):
        request_id = _request_id(text)
        try:
            message = parse(text)
            kind = message["type"]
            if kind == "command":
                ok, reply = self.actions.command(message["name"])
            elif kind == "set":
                ok, reply = self.actions.set_condition(message["name"], message["value"])
            else:
                ok, reply = self.actions.manual(client, message)
                if ok and reply is None:
                    return None  # sticks and keys stream at 10-20 Hz: no reply unless something to say
        except BadMessage as err:
            ok, reply = False, str(err)
        return {"type": "reply", "id": request_id, "ok": ok, "message": reply}

    async def _send(self, ws, sending):
        """Await one send, at most send_timeout_s: a client that does not read is closed."""
        try:
            await asyncio.wait_for(sending, self.send_timeout_s)
            return True
        except (asyncio.TimeoutError, ConnectionError, RuntimeError):
            self.stats["dropped_slow"] += 1
            await ws.close(code=1008, message=b"too slow")
            return False

    async def _send_loop(self, client, ws):
        with self.lock:
            history = json.dumps(self.model.history(), separators=(",", ":"))
            seq = self.model.decision_seq
        if not await self._send(ws, ws.send_str(history)):
            return
        sent_tick, frame_seq = -1, 0
        while not ws.closed:
            async with self.ticked:
                await self.ticked.wait_for(lambda: self.tick != sent_tick)
            sent_tick = self.tick
            state = self.state_text
            if state is None:
                continue
            with self.lock:
                decisions = self.model.decisions_since(seq)
            if decisions:
                seq = decisions[-1]["seq"]
            if not await self._send(ws, ws.send_str(state)):
                return
            if decisions and not await self._send(ws, ws.send_str(json.dumps({"type": "decisions",
                                                                                "items": decisions}))):
                return
            if self.camera is not None:
                latest_seq, jpeg = self.camera.latest()
                if jpeg is not None and latest_seq != frame_seq:
                    frame_seq = latest_seq
                    if not await self._send(ws, ws.send_bytes(jpeg)):
                        return
