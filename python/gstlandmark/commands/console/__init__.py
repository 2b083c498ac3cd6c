"""``gst-landmark console``: the chain and a local web page to watch,
tune and teach it (docs/console.md)."""

from __future__ import annotations

import asyncio
import json
import secrets
import signal
import socket
import sys
from typing import Any, Dict, List, Optional

from ..common import PROG, CliError, add_token_option

DEFAULT_PORT = 8090
DEFAULT_OUT = "out/console"


def read_project(path: str) -> Dict[str, Any]:
    """Files and tuned properties from a project config (the format of
    ``gst-landmark run --config``, plus ``properties``)."""
    from .. import runner
    variables = runner.read_config(path)
    with open(path, encoding="utf-8") as f:
        data = json.load(f)
    properties = data.get("properties", {})
    if not isinstance(properties, dict) or not all(
            isinstance(v, dict) for v in properties.values()):
        raise CliError(f"{path}: \"properties\" must be an object of "
                       f"objects: {{\"labsegment\": {{\"min-class-pixels\": "
                       f"50}}}}")
    return {"palette": variables.get("PALETTE"), "map": variables.get("MAP"),
            "camera": variables.get("CAMERA"), "properties": properties}


def open_urls(host: str, port: int, token: Optional[str]) -> List[str]:
    """Addresses a browser can open for a server bound to ``host``: for
    the wildcard (0.0.0.0, ::), loopback first, then this machine's own
    addresses (a wildcard cannot be opened)."""
    hosts = [host]
    if host in ("0.0.0.0", "::", ""):
        hosts = ["127.0.0.1"]
        try:
            found = socket.getaddrinfo(socket.gethostname(), None,
                                       socket.AF_INET6 if host == "::"
                                       else socket.AF_INET)
        except OSError:
            found = []
        for *_, address in found:
            if address[0] not in hosts and \
                    not address[0].startswith(("127.", "::1", "fe80")):
                hosts.append(address[0])
    query = f"?token={token}" if token is not None else ""
    return [f"http://{f'[{h}]' if ':' in h else h}:{port}/{query}"
            for h in hosts]


async def serve(engine, host: str, port: int, token: Optional[str],
                ready=None) -> None:
    """Runs the server and the chain until SIGINT or SIGTERM."""
    from aiohttp import web
    from .server import is_loopback, make_app

    app = make_app(engine, token=token, loopback=is_loopback(host))
    runner_ = web.AppRunner(app, access_log=None)
    await runner_.setup()
    site = web.TCPSite(runner_, host, port)
    await site.start()
    try:
        await engine.start()
        bound = runner_.addresses[0][1] if runner_.addresses else port
        urls = open_urls(host, bound, token)
        url = urls[0]
        print(f"{PROG} console: {url}", flush=True)
        for other in urls[1:]:
            print(f"{PROG} console: also {other}", flush=True)
        if ready is not None:
            ready(url)
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        await stop.wait()
    finally:
        await runner_.cleanup()


def run(args) -> int:
    from .engine import ConsoleError, Engine, source_fragment
    from .server import is_loopback

    token = args.token
    if not is_loopback(args.listen) and token is None:
        token = secrets.token_urlsafe(24)
    if token is not None and len(token) < 16:
        raise CliError("--token must be at least 16 characters")
    project = read_project(args.config) if args.config else {}
    try:
        source = source_fragment(args.input, args.camera, args.testsrc)
        engine = Engine(
            source, args.out,
            palette_path=args.palette or project.get("palette"),
            map_path=args.map or project.get("map"),
            camera_path=args.camera_file or project.get("camera"),
            properties=project.get("properties"),
            loop_file=not args.no_loop)
    except ConsoleError as err:
        raise CliError(str(err)) from None
    try:
        asyncio.run(serve(engine, args.listen, args.port, token))
    except ConsoleError as err:
        raise CliError(str(err)) from None
    except OSError as err:
        raise CliError(f"cannot listen on {args.listen}:{args.port}: "
                       f"{err.strerror or err}") from None
    return 0


def add_console_parser(subparsers):
    p = subparsers.add_parser(
        "console", help="watch, tune and teach the chain from a browser",
        description="""Run the chain on a file, a camera or a test source
            and serve a web page with the live overlay video, the class
            histogram, lamps, ranges, pose and mini-map, controls to tune
            the elements while they run and to teach palette colours.
            Listens on 127.0.0.1 unless --listen says otherwise (then a
            token is required).""")
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--input", "-i", metavar="FILE",
                     help="video file (played in a loop)")
    src.add_argument("--camera", metavar="/dev/videoN", help="V4L2 camera")
    src.add_argument("--testsrc", action="store_true",
                     help="GStreamer's test pattern")
    p.add_argument("--palette", metavar="FILE", help="palette JSON")
    p.add_argument("--camera-file", metavar="FILE",
                   help="camera file (gst-landmark calibrate)")
    p.add_argument("--map", metavar="FILE",
                   help="landmark map JSON (adds trilaterate)")
    p.add_argument("--config", "-c", metavar="project.json",
                   help="project config: palette, map, camera (relative "
                        "to the file) and tuned properties; the options "
                        "above win")
    p.add_argument("--out", "-o", metavar="DIR", default=DEFAULT_OUT,
                   help="folder for the log, saved palettes and config "
                        "(default %(default)s)")
    p.add_argument("--listen", metavar="ADDR", default="127.0.0.1",
                   help="address to bind (default %(default)s; any "
                        "other than loopback requires a token)")
    p.add_argument("--port", type=int, default=DEFAULT_PORT,
                   help="TCP port (default %(default)s; 0: any free one)")
    add_token_option(p)
    p.add_argument("--no-loop", action="store_true",
                   help="stop at the end of a file instead of looping")
    p.set_defaults(handler=_handle, parser=p)


def _handle(args) -> int:
    try:
        return run(args)
    except CliError as err:
        print(f"{PROG}: error: {err}", file=sys.stderr)
        return err.status
