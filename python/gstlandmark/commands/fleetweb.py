"""The live fleet map of ``gst-landmark fleet --http``: an aiohttp server
with one page (a canvas: every robot's pose, uncertainty, path and
status, the map's landmarks) and a WebSocket that pushes the fleet's
state as JSON when it changed, at most every ``push_every`` seconds
(docs/fleet.md). The access rules are the console's (webguard)."""

from __future__ import annotations

import asyncio
import importlib.resources
import json
import threading
from typing import Any, Dict, List, Optional

from aiohttp import web

from .. import webguard
from ..landmarkmap import read_map

DEFAULT_PUSH_EVERY = 0.25
IDLE_PUSH_S = 2.0       # pushed even unchanged: the page's ages move on
DEFAULT_DIAMETER = 0.2  # metres, drawn for a map entry without one


def static_dir() -> str:
    return str(importlib.resources.files("gstlandmark.commands") / "fleetmap")


def read_landmarks(path: str) -> List[Dict[str, Any]]:
    """The map file's landmarks (id, class, x, y, diameter) for the page;
    ValueError naming the file when it is not a landmark map."""
    return [{"id": m["id"], "class": m["class"], "x": m["x"], "y": m["y"],
             "diameter": m["diameter"] or DEFAULT_DIAMETER}
            for m in read_map(path)]


def cookie_name(request: web.Request) -> str:
    return f"landmark-fleet-{request.url.port}"


def make_app(state, token: Optional[str] = None,
             loopback: bool = True,
             landmarks: Optional[List[Dict[str, Any]]] = None,
             push_every: float = DEFAULT_PUSH_EVERY) -> web.Application:
    """``state``: the fleet.FleetState shown; ``token``: required on every
    request when set; ``loopback``: the server listens on loopback only
    (then Host must name loopback)."""
    guard = webguard.middleware(token, loopback, cookie_name)

    # nothing is posted: no body is read
    app = web.Application(middlewares=[guard], client_max_size=1024)
    root = static_dir()
    sockets: set = set()
    map_text = json.dumps({"type": "map", "landmarks": landmarks or []})

    async def api_fleet(request):
        return web.Response(text=state.view_text({}),
                            content_type="application/json")

    async def websocket(request):
        # the page sends nothing: refuse anything large
        ws = web.WebSocketResponse(heartbeat=20, max_msg_size=1024)
        await ws.prepare(request)
        sockets.add(ws)

        async def send():
            seen: Dict[str, int] = {}   # path points this browser has
            version, loop = None, asyncio.get_running_loop()
            last = 0.0
            try:
                await ws.send_str(map_text)
                while True:
                    now = loop.time()
                    if state.version != version or now - last > IDLE_PUSH_S:
                        version, last = state.version, now
                        await ws.send_str(state.view_text(seen))
                    await asyncio.sleep(push_every)
            except (ConnectionError, RuntimeError):
                pass    # the browser went away; the reader ends too

        try:
            await webguard.serve_socket(ws, send)
        finally:
            sockets.discard(ws)
        return ws

    async def on_shutdown(app):
        for ws in list(sockets):
            await ws.close()

    app.on_shutdown.append(on_shutdown)
    webguard.add_page_routes(app, root, websocket)
    app.router.add_get("/api/fleet", api_fleet)
    return app


def parse_address(text: str) -> tuple:
    """``[ADDR:]PORT`` (``[::1]:8091`` for IPv6) as (address, port);
    ValueError otherwise. Without an address: 127.0.0.1."""
    host, sep, port = text.rpartition(":")
    host = host[1:-1] if host.startswith("[") and host.endswith("]") \
        else host
    try:
        number = int(port)
    except ValueError:
        number = -1
    if not 0 <= number <= 65535 or (sep and not host):
        raise ValueError(f"--http {text!r}: expected [ADDR:]PORT, "
                         f"e.g. 8091 or 0.0.0.0:8091")
    return host or "127.0.0.1", number


class MapServer:
    """The server on its own thread and event loop, next to the fleet's
    MQTT thread and its file writes."""

    def __init__(self, state, host: str, port: int,
                 token: Optional[str] = None,
                 landmarks: Optional[List[Dict[str, Any]]] = None,
                 push_every: float = DEFAULT_PUSH_EVERY):
        self.app = make_app(state, token, webguard.is_loopback(host),
                            landmarks, push_every)
        self.host, self.port, self.token = host, port, token
        self.url: Optional[str] = None
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever,
                                       name="fleet-map", daemon=True)
        self.runner: Optional[web.AppRunner] = None

    async def _start(self) -> str:
        self.runner = web.AppRunner(self.app, access_log=None)
        await self.runner.setup()
        await web.TCPSite(self.runner, self.host, self.port).start()
        bound = self.runner.addresses[0][1]
        shown = f"[{self.host}]" if ":" in self.host else self.host
        url = f"http://{shown}:{bound}/"
        return url + (f"?token={self.token}" if self.token else "")

    def start(self) -> "MapServer":
        """Listening when it returns; OSError when the port is taken."""
        self.thread.start()
        try:
            self.url = asyncio.run_coroutine_threadsafe(
                self._start(), self.loop).result(10)
        except BaseException:
            self.stop()
            raise
        return self

    def stop(self) -> None:
        if self.runner is not None:
            asyncio.run_coroutine_threadsafe(
                self.runner.cleanup(), self.loop).result(10)
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(10)
