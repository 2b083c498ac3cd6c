"""The access rules the project's web pages share (the console, the fleet
map): a token (when set) checked on every request, WebSockets included,
with a constant-time compare, from an ``Authorization: Bearer`` header,
the address (``?token=``, the first page load) or the HttpOnly cookie
that load set; on loopback without a token the Host header must name
loopback (no DNS rebinding); a request from a page of another origin is
refused. Also the pages' shared middleware, routes and WebSocket loop."""

from __future__ import annotations

import asyncio
import hmac
import ipaddress
import os
import secrets
from typing import Callable, Optional, Tuple

from aiohttp import WSMsgType, web

LOOPBACK_NAMES = {"localhost", "127.0.0.1", "::1"}
MIN_TOKEN = 16


def is_loopback(host: str) -> bool:
    if host in LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def host_name(host_header: str) -> str:
    """The host part of a Host header value (no port, no brackets)."""
    if host_header.startswith("["):
        return host_header[1:].split("]", 1)[0]
    return host_header.rsplit(":", 1)[0] if host_header.count(":") == 1 \
        else host_header


def choose_token(listen: str, token: Optional[str]) -> Optional[str]:
    """The token to require: the one given, or a random one off loopback;
    ValueError for one too short to be a secret."""
    if token is None and not is_loopback(listen):
        token = secrets.token_urlsafe(24)
    if token is not None and len(token) < MIN_TOKEN:
        raise ValueError(f"--token must be at least {MIN_TOKEN} characters")
    return token


def error(status: int, text: str) -> web.Response:
    return web.json_response({"error": text}, status=status)


def check(request: web.Request, token: Optional[str], loopback: bool,
          cookie: str) -> Tuple[Optional[web.Response], bool]:
    """(the refusal, or None; whether the token came in the address, so
    the response should set the cookie ``cookie``)."""
    from_query = False
    if token is not None:
        given = request.headers.get("Authorization", "")
        if given.startswith("Bearer "):
            given = given[7:]
        elif "token" in request.query:
            given, from_query = request.query["token"], True
        else:
            given = request.cookies.get(cookie, "")
        if not hmac.compare_digest(given.encode(), token.encode()):
            return error(401, "missing or wrong token: open the address "
                         "printed at start (it ends in ?token=...)"), False
    elif loopback and not is_loopback(host_name(request.host)):
        return error(403, f"Host {request.host!r} is not loopback"), False
    origin = request.headers.get("Origin")
    if origin is not None and origin.split("://", 1)[-1] != request.host:
        return error(403, f"requests from {origin} are not accepted"), False
    return None, from_query


def remember(response: web.StreamResponse, cookie: str,
             token: str) -> None:
    """Sets the cookie that carries the token to the page's own files and
    socket (HttpOnly: the page's scripts never see it)."""
    if not response.prepared:
        response.set_cookie(cookie, token, httponly=True, samesite="Strict")


def middleware(token: Optional[str], loopback: bool,
               cookie_of: Callable[[web.Request], str],
               refuse: Optional[Callable[[web.Request],
                                         Optional[web.Response]]] = None,
               bad_input: Tuple[type, ...] = ()):
    """The aiohttp middleware of a page: ``check`` every request (then
    ``refuse``, the page's own rule, when given), the cookie set when the
    token came in the address, errors as JSON: HTTP errors with their
    status, the exceptions ``bad_input`` names as 400."""
    @web.middleware
    async def guard(request: web.Request, handler):
        cookie = cookie_of(request)
        refused, from_query = check(request, token, loopback, cookie)
        if refused is None and refuse is not None:
            refused = refuse(request)
        if refused is not None:
            return refused
        try:
            response = await handler(request)
        except bad_input as err:
            return error(400, str(err))
        except web.HTTPException as err:
            if err.status < 400:
                raise
            return error(err.status, err.text or err.reason)
        if from_query:
            remember(response, cookie, token)
        return response
    return guard


async def serve_socket(ws: web.WebSocketResponse, send) -> None:
    """A page's WebSocket: runs ``send()`` (the server's pushes) while
    reading ``ws`` until the browser closes it or it fails, then stops the
    pushes."""
    sender = asyncio.ensure_future(send())
    try:
        async for msg in ws:
            if msg.type == WSMsgType.ERROR:
                break
    finally:
        sender.cancel()


def add_page_routes(app: web.Application, root: str, websocket) -> None:
    """The routes every page has: ``/`` (``root``'s index.html, never
    cached, so a new version shows at once), ``/static/`` (the files of
    ``root``) and ``/ws`` (``websocket``, the page's socket)."""
    async def index(request):
        return web.FileResponse(os.path.join(root, "index.html"),
                                headers={"Cache-Control": "no-store"})

    app.router.add_get("/", index)
    app.router.add_static("/static/", root)
    app.router.add_get("/ws", websocket)
