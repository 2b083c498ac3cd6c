"""``gst-landmark fleet``: subscribes to what ``landmarkpublish`` sends
from every robot and keeps, per robot, the latest pose, the path (the
last ``path_length`` poses), the latest detections and the status; writes
them to a JSON file, replaced whole every ``write_every`` seconds and at
the end.

Topics (docs/landmarkpublish.md): ``<prefix>/<robot>/frame`` (every
frame), ``<prefix>/<robot>/pose`` (retained latest pose),
``<prefix>/<robot>/status`` (retained online/offline). The robot's name
is the topic level after the prefix.
"""

from __future__ import annotations

import json
import os
import signal
import sys
import threading
import time
from collections import deque
from typing import Any, Dict, Optional

from .cli import PROG, CliError

DEFAULT_PATH_LENGTH = 10000


class FleetState:
    """What is known of every robot; fed one message at a time
    (thread-safe), read as a JSON-ready dict."""

    def __init__(self, prefix: str = "landmark",
                 path_length: int = DEFAULT_PATH_LENGTH):
        self.prefix = prefix.rstrip("/")
        self.path_length = path_length
        self.robots: Dict[str, Dict[str, Any]] = {}
        self.bad_messages = 0
        self.lock = threading.Lock()

    def _robot(self, name: str) -> Dict[str, Any]:
        r = self.robots.get(name)
        if r is None:
            r = {"status": None, "frames": 0, "last-frame": None,
                 "pose": None, "path": deque(maxlen=self.path_length),
                 "detections": [], "last-wall-time": None}
            self.robots[name] = r
        return r

    def _pose(self, r: Dict[str, Any], msg: Dict[str, Any]) -> None:
        pose = msg.get("pose")
        wall = msg.get("wall-time")
        if not isinstance(pose, dict) or not isinstance(wall, (int, float)):
            return
        last = r["path"][-1][3] if r["path"] else None
        if last is not None and wall <= last:
            return          # the retained copy of a pose already kept
        r["pose"] = dict(pose, frame=msg.get("frame"), **{"wall-time": wall})
        r["path"].append([pose.get("x"), pose.get("y"), pose.get("heading"),
                          wall])

    def handle(self, topic: str, payload: bytes) -> None:
        parts = topic.split("/")
        head = self.prefix.split("/")
        if len(parts) != len(head) + 2 or parts[:len(head)] != head:
            return
        name, kind = parts[len(head)], parts[len(head) + 1]
        try:
            msg = json.loads(payload)
        except ValueError:
            msg = None
        with self.lock:
            if not isinstance(msg, dict):
                self.bad_messages += 1
                return
            r = self._robot(name)
            if kind == "frame":
                r["frames"] += 1
                r["last-frame"] = msg.get("frame")
                r["last-wall-time"] = msg.get("wall-time")
                r["detections"] = msg.get("detections", [])
                self._pose(r, msg)
            elif kind == "pose":
                self._pose(r, msg)
            elif kind == "status":
                r["status"] = msg.get("status")

    def snapshot(self) -> Dict[str, Any]:
        with self.lock:
            robots = {}
            for name, r in sorted(self.robots.items()):
                robots[name] = dict(r, path=list(r["path"]))
            return {"wall-time": time.time(), "robots": robots,
                    "bad-messages": self.bad_messages}


def write_json(path: str, data: Dict[str, Any]) -> None:
    """Replaces the file whole: a reader never sees half of it."""
    tmp = f"{path}.{os.getpid()}.tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(data, f, indent=1)
        f.write("\n")
    os.replace(tmp, path)


class Fleet:
    """The subscriber: paho-mqtt's network thread feeds a FleetState; it
    reconnects by itself and subscribes again on every connection."""

    def __init__(self, host: str = "127.0.0.1", port: int = 1883,
                 prefix: str = "landmark", username: Optional[str] = None,
                 password: Optional[str] = None,
                 tls_ca_file: Optional[str] = None,
                 path_length: int = DEFAULT_PATH_LENGTH):
        import paho.mqtt.client as mqtt
        self.state = FleetState(prefix, path_length)
        self.host, self.port = host, port
        self.subscribed = threading.Event()
        self.problem: Optional[str] = None
        self.client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2,
                                  client_id=f"gst-landmark-fleet-"
                                            f"{os.getpid()}",
                                  protocol=mqtt.MQTTv311)
        if username:
            self.client.username_pw_set(username, password)
        if tls_ca_file:
            if not os.path.isfile(tls_ca_file):
                raise CliError(f"{tls_ca_file}: no such file")
            self.client.tls_set(ca_certs=tls_ca_file)
        topic = f"{self.state.prefix}/+/"
        self.topics = [(topic + k, 1) for k in ("frame", "pose", "status")]
        self.client.on_connect = self._on_connect
        self.client.on_subscribe = lambda *a: self.subscribed.set()
        self.client.on_message = lambda c, u, m: self.state.handle(
            m.topic, m.payload)

    def _on_connect(self, client, userdata, flags, reason_code, properties):
        if reason_code.is_failure:
            self.problem = (f"the broker at {self.host}:{self.port} refused "
                            f"the connection: {reason_code}")
            return
        self.problem = None
        client.subscribe(self.topics)

    def start(self, timeout_s: float = 10.0) -> "Fleet":
        try:
            self.client.connect(self.host, self.port, keepalive=30)
        except OSError as err:
            raise CliError(f"cannot reach the broker at {self.host}:"
                           f"{self.port}: {err}") from None
        self.client.loop_start()
        # subscribed, not only connected: nothing sent after start() is
        # missed
        if not self.subscribed.wait(timeout_s):
            self.stop()
            raise CliError(self.problem or f"no answer from the broker at "
                           f"{self.host}:{self.port} in {timeout_s:g} s")
        return self

    def stop(self) -> None:
        self.client.disconnect()
        self.client.loop_stop()


def run(host, port, output, prefix="landmark", username=None, password=None,
        tls_ca_file=None, duration=None, write_every=1.0,
        path_length=DEFAULT_PATH_LENGTH, stream=None) -> int:
    stream = stream or sys.stderr
    out_dir = os.path.dirname(os.path.abspath(output))
    if not os.path.isdir(out_dir):
        raise CliError(f"{out_dir}: no such directory")
    fleet = Fleet(host, port, prefix, username, password, tls_ca_file,
                  path_length).start()
    stop = threading.Event()
    previous = signal.signal(signal.SIGINT, lambda *a: stop.set())
    previous_term = signal.signal(signal.SIGTERM, lambda *a: stop.set())
    print(f"{PROG} fleet: listening on {host}:{port} ({prefix}/+/...), "
          f"writing {output}", file=stream)
    end = None if duration is None else time.monotonic() + duration
    # at once: the file's existence says the fleet is listening
    write_json(output, fleet.state.snapshot())
    try:
        while not stop.is_set():
            wait = write_every
            if end is not None:
                wait = min(wait, max(0.0, end - time.monotonic()))
            stop.wait(wait)
            write_json(output, fleet.state.snapshot())
            if end is not None and time.monotonic() >= end:
                break
    finally:
        signal.signal(signal.SIGINT, previous)
        signal.signal(signal.SIGTERM, previous_term)
        fleet.stop()
    snap = fleet.state.snapshot()
    write_json(output, snap)
    print(f"{PROG} fleet: {len(snap['robots'])} robots", file=stream)
    return 0


def add_fleet_parser(subparsers):
    p = subparsers.add_parser(
        "fleet", help="follow every robot's pose over MQTT",
        description="Subscribe to what landmarkpublish sends from every "
                    "robot and keep each robot's latest pose, path, "
                    "detections and status in a JSON file, replaced whole "
                    "every --write-every seconds. Ctrl-C (or --duration) "
                    "ends it after a last write.")
    p.add_argument("-o", "--output", metavar="FLEET.json", required=True)
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--port", type=int, default=1883)
    p.add_argument("--prefix", default="landmark",
                   help="first topic levels, before the robot's name "
                        "(default %(default)s)")
    p.add_argument("--username")
    p.add_argument("--password",
                   help="password (or the environment variable "
                        "LANDMARK_MQTT_PASSWORD, kept out of process lists)")
    p.add_argument("--tls-ca-file", metavar="CA.pem",
                   help="TLS with this certificate authority")
    p.add_argument("--duration", type=float, metavar="S",
                   help="stop after S seconds (default: until Ctrl-C)")
    p.add_argument("--write-every", type=float, default=1.0, metavar="S")
    p.add_argument("--path-length", type=int, default=DEFAULT_PATH_LENGTH,
                   metavar="N", help="poses kept per robot (default "
                                     "%(default)s)")
    p.set_defaults(handler=_handle, parser=p)


def _handle(args) -> int:
    try:
        if args.write_every <= 0 or args.path_length < 1:
            raise CliError("--write-every and --path-length must be "
                           "positive")
        return run(args.host, args.port, args.output, args.prefix,
                   args.username,
                   args.password or os.environ.get("LANDMARK_MQTT_PASSWORD"),
                   args.tls_ca_file, args.duration, args.write_every,
                   args.path_length)
    except CliError as err:
        print(f"{PROG}: error: {err}", file=sys.stderr)
        return err.status
