"""The console's web server (aiohttp): the page, the MJPEG stream, the
per-frame results over a WebSocket, and the JSON API for control, tuning
and teaching. See docs/console.md for every route.

Secure by default: a token (when set) is checked on every request,
WebSockets included, with a constant-time compare; on loopback without a
token the Host header must name loopback (no DNS rebinding); a request
from a page of another origin is refused; POST bodies must be JSON and
small.
"""

from __future__ import annotations

import asyncio
import collections
import importlib.resources
import json
import os
from typing import Any, Dict, List, Optional

from aiohttp import web

from ... import webguard
from ...webguard import LOOPBACK_NAMES, is_loopback  # noqa: F401
from .engine import ConsoleError, Engine

MAX_BODY = 16 * 1024
BOUNDARY = "landmarkframe"
CLIENT_QUEUE = 4        # results waiting per browser before old ones drop

ENGINE = web.AppKey("engine", Engine) if hasattr(web, "AppKey") else "engine"


def static_dir() -> str:
    return str(importlib.resources.files("gstlandmark.commands.console")
               / "static")


def _error(status: int, text: str) -> web.Response:
    return web.json_response({"error": text}, status=status)


def cookie_name(request: web.Request) -> str:
    # cookies are per host, not per port: one name per console
    return f"landmark-console-{request.url.port}"


def make_app(engine: Engine, token: Optional[str] = None,
             loopback: bool = True) -> web.Application:
    """The application. ``token``: required on every request when set;
    ``loopback``: the server listens on loopback only (then the Host
    header must be a loopback name)."""

    def json_posts_only(request):
        if request.method == "POST" and request.content_type != \
                "application/json":
            return _error(415, "POST bodies must be application/json")
        return None

    # the checks the fleet map shares (webguard)
    guard = webguard.middleware(token, loopback, cookie_name,
                                refuse=json_posts_only,
                                bad_input=(ConsoleError,))
    app = web.Application(middlewares=[guard], client_max_size=MAX_BODY)
    app[ENGINE] = engine
    sockets: set = set()
    root = static_dir()

    async def body(request: web.Request) -> Dict[str, Any]:
        try:
            data = await request.json()
        except json.JSONDecodeError as err:
            raise ConsoleError(f"malformed JSON: {err.msg} at line "
                               f"{err.lineno}, column {err.colno}") from None
        except UnicodeDecodeError:
            raise ConsoleError("malformed JSON: not UTF-8") from None
        if not isinstance(data, dict):
            raise ConsoleError("the body must be a JSON object")
        return data

    def state() -> Dict[str, Any]:
        return {"type": "state", "state": engine.state,
                "error": engine.error, "tunables": engine.tunables(),
                "palette": engine.palette_json(),
                "landmarks": engine.landmarks, "path": engine.path,
                "duration": engine.duration(),
                "source": engine.source_id,
                "log": os.path.basename(engine.log_path),
                "can_undo": bool(engine.undo_stack),
                "teaching": {"boxes": len(engine.teaching.lessons),
                             "frames": len(engine.teaching.frames()),
                             "beside": engine.teaching.base.names,
                             "warnings": engine.teach_warnings}}

    def broadcast_state() -> None:
        engine._notify(state())

    async def api_state(request):
        return web.json_response(state())

    async def api_control(request):
        data = await body(request)
        action = data.get("action")
        if action == "start":
            await engine.start()
        elif action == "pause":
            await engine.pause()
        elif action == "stop":
            await engine.stop()
        elif action == "step":
            await engine.step()
        else:
            raise ConsoleError(f"action must be start, pause, step or stop, "
                               f"got "
                               f"{json.dumps(action)}")
        broadcast_state()
        return web.json_response({"state": engine.state})

    async def api_tune(request):
        data = await body(request)
        items = data.get("changes", [data] if "element" in data else None)
        if not isinstance(items, list) or not items:
            raise ConsoleError("expected {\"element\", \"property\", "
                               "\"value\"} or {\"changes\": [...]}")
        changes = []
        for item in items:
            if not isinstance(item, dict) or not {"element", "property",
                                                  "value"} <= set(item):
                raise ConsoleError("each change needs element, property "
                                   "and value")
            changes.append((item["element"], item["property"],
                            item["value"]))
        applied = engine.tune(changes)
        broadcast_state()
        return web.json_response({"applied": applied})

    async def api_sources(request):
        return web.json_response({
            "current": engine.source_id,
            "sources": [{"id": k, "label": v["label"]}
                        for k, v in engine.sources().items()]})

    async def api_source(request):
        data = await body(request)
        await engine.set_source(data.get("id"))
        broadcast_state()
        return web.json_response({"current": engine.source_id,
                                  "state": engine.state})

    async def api_seek(request):
        data = await body(request)
        if "seconds" not in data:
            raise ConsoleError("seek: missing seconds")
        engine.seek(data["seconds"])
        broadcast_state()
        return web.json_response({"seconds": data["seconds"]})

    async def api_save_config(request):
        path = engine.save_config()
        return web.json_response({"saved": os.path.basename(path)})

    async def api_teach(request):
        data = await body(request)
        missing = [k for k in ("class", "x", "y", "w", "h") if k not in data]
        if missing:
            raise ConsoleError(f"teach: missing {', '.join(missing)}")
        entry = engine.teach(data["class"], data["x"], data["y"], data["w"],
                             data["h"], data.get("marker"),
                             frame_id=data.get("frame"),
                             role=data.get("role"))
        broadcast_state()
        return web.json_response({"class": entry,
                                  "warnings": engine.teach_warnings})

    async def api_class(request):
        data = await body(request)
        reply = engine.edit_class(data.get("class"), data.get("action"),
                                  data.get("to"))
        broadcast_state()
        return web.json_response(reply)

    async def api_statistics(request):
        data = await body(request)
        missing = [k for k in ("x", "y", "w", "h") if k not in data]
        if missing:
            raise ConsoleError(f"statistics: missing {', '.join(missing)}")
        return web.json_response(engine.box_statistics(
            data.get("frame"), data["x"], data["y"], data["w"], data["h"]))

    async def api_new_palette(request):
        await body(request)
        engine.new_palette()
        broadcast_state()
        return web.json_response({"boxes": 0})

    async def api_freeze(request):
        await body(request)
        return web.json_response(engine.freeze())

    async def frozen(request):
        try:
            frame_id = int(request.query.get("frame", ""))
        except ValueError:
            raise ConsoleError("frozen.jpg?frame=ID: the id freeze "
                               "returned") from None
        return web.Response(body=engine.frozen_jpeg(frame_id),
                            content_type="image/jpeg",
                            headers={"Cache-Control": "no-store"})

    async def api_undo(request):
        engine.undo()
        broadcast_state()
        return web.json_response({"palette": engine.palette_json()})

    async def api_save_palette(request):
        path = engine.save_palette()
        return web.json_response({"saved": os.path.basename(path)})

    async def download_log(request):
        """This run's log so far, streamed from the file (never read
        into memory)."""
        if not os.path.isfile(engine.log_path):
            raise ConsoleError("no log yet: start the pipeline")
        name = os.path.basename(engine.log_path)
        return web.FileResponse(engine.log_path, headers={
            "Content-Type": "application/x-ndjson",
            "Content-Disposition": f"attachment; filename={name}"})

    async def download_snapshot(request):
        data = engine.views["overlay"].data
        if data is None:
            raise ConsoleError("no frame yet: start the pipeline")
        return web.Response(body=data, content_type="image/jpeg",
                            headers={"Content-Disposition":
                                     "attachment; filename=snapshot.jpg"})

    async def download_palette(request):
        return web.Response(
            text=json.dumps(engine.palette_json(), indent=2) + "\n",
            content_type="application/json",
            headers={"Content-Disposition":
                     "attachment; filename=palette.json"})

    async def download_map(request):
        if not engine.map_path:
            raise ConsoleError("no map: start the console with --map")
        return web.FileResponse(engine.map_path, headers={
            "Content-Type": "application/json",
            "Content-Disposition": "attachment; filename=map.json"})

    async def stream(request):
        """MJPEG: one JPEG part per frame of a view (``?view=overlay``,
        the default, ``labels``, or ``binary`` with ``class=NAME``),
        newest first (a slow client skips frames, it never delays
        others)."""
        name, view = engine.class_view(request.query.get("view", "overlay"),
                                       request.query.get("class"))
        response = web.StreamResponse(headers={
            "Content-Type":
                f"multipart/x-mixed-replace; boundary={BOUNDARY}",
            "Cache-Control": "no-store"})
        await response.prepare(request)
        seq = 0         # the newest frame at once, then each new one
        view.readers += 1
        if name != "overlay":
            engine.labels_now(name)     # paused: no new frame would make it
        try:
            # A browser shows a part once the next part's headers have
            # come: so each part's data is followed at once by the
            # boundary and the next part's headers (its type only: its
            # length and time are not known yet). ?timing=1 (for tools,
            # a browser shows it a frame late): each part's own headers
            # with Content-Length, X-Timestamp and X-Pts.
            timing = request.query.get("timing") == "1"
            head = (f"--{BOUNDARY}\r\nContent-Type: image/jpeg\r\n"
                    "\r\n").encode()
            if not timing:
                await response.write(head)
            while True:
                seq, data, stamp, pts = await view.next(seq)
                if not timing:
                    await response.write(data + b"\r\n" + head)
                    continue
                # X-Timestamp: wall time the JPEG was ready; X-Pts: the
                # frame's (matches "pts" on the WebSocket)
                await response.write(
                    f"--{BOUNDARY}\r\nContent-Type: image/jpeg\r\n"
                    f"Content-Length: {len(data)}\r\n"
                    f"X-Timestamp: {stamp:.6f}\r\n"
                    f"X-Pts: {pts if pts is not None else ''}\r\n"
                    "\r\n".encode()
                    + data + b"\r\n")
        except (ConnectionError, RuntimeError, EOFError):
            pass        # the browser went away, or the server stops
        finally:
            view.readers -= 1
        return response

    async def websocket(request):
        # the page sends nothing on its socket: refuse anything large
        ws = web.WebSocketResponse(heartbeat=20, max_msg_size=4096)
        await ws.prepare(request)
        # frames may be dropped for a slow browser (the newest are
        # kept), state changes and errors never are
        frames: collections.deque = collections.deque(maxlen=CLIENT_QUEUE)
        others: List[Dict[str, Any]] = []
        wake = asyncio.Event()

        def listener(message):
            if message["type"] == "frame":
                frames.append(message)
            else:
                others.append(message)
            wake.set()

        async def send():
            try:
                await ws.send_json(state())
                while True:
                    await wake.wait()
                    wake.clear()
                    while others or frames:
                        message = others.pop(0) if others else \
                            frames.popleft()
                        await ws.send_json(message)
            except (ConnectionError, RuntimeError):
                pass    # the browser went away; the reader ends too

        engine.listeners.append(listener)
        sockets.add(ws)
        try:
            await webguard.serve_socket(ws, send)
        finally:
            engine.listeners.remove(listener)
            sockets.discard(ws)
        return ws

    async def on_shutdown(app):
        for view in engine.views.values():
            view.close()
        for ws in list(sockets):
            await ws.close()
        await engine.close()

    app.on_shutdown.append(on_shutdown)
    webguard.add_page_routes(app, root, websocket)
    app.router.add_get("/stream.mjpg", stream)
    app.router.add_get("/api/state", api_state)
    app.router.add_post("/api/control", api_control)
    app.router.add_post("/api/tune", api_tune)
    app.router.add_post("/api/seek", api_seek)
    app.router.add_get("/api/sources", api_sources)
    app.router.add_post("/api/source", api_source)
    app.router.add_post("/api/save-config", api_save_config)
    app.router.add_post("/api/teach", api_teach)
    app.router.add_post("/api/undo", api_undo)
    app.router.add_post("/api/new-palette", api_new_palette)
    app.router.add_post("/api/class", api_class)
    app.router.add_post("/api/statistics", api_statistics)
    app.router.add_post("/api/freeze", api_freeze)
    app.router.add_get("/frozen.jpg", frozen)
    app.router.add_post("/api/save-palette", api_save_palette)
    app.router.add_get("/download/log.jsonl", download_log)
    app.router.add_get("/download/snapshot.jpg", download_snapshot)
    app.router.add_get("/download/palette.json", download_palette)
    app.router.add_get("/download/map.json", download_map)
    return app
