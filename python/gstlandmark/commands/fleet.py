"""``gst-landmark fleet``: subscribes to what ``landmarkpublish`` sends
from every robot and keeps, per robot, the latest pose, the path (a point
every ``path_every`` seconds, the last ``path_length`` of them), the latest
detections, the status, and the frames missed and how late they arrive;
writes them to a JSON file, replaced whole every ``write_every`` seconds
and at the end (docs/fleet.md).

Topics (docs/fleet.md): ``<prefix>/<robot>/frame`` (every frame),
``<prefix>/<robot>/pose`` (retained latest pose),
``<prefix>/<robot>/status`` (retained online/offline). The robot's name
is the topic level after the prefix.
"""

from __future__ import annotations

import json
import math
import os
import signal
import ssl
import sys
import threading
import time
from collections import deque
from typing import Any, Dict, Optional

from .common import PROG, CliError, add_token_option

DEFAULT_PATH_LENGTH = 1200
DEFAULT_PATH_EVERY = 0.5
# how often a fleet started before its broker tries again
BROKER_RETRY_S = 1.0


class DelayHistogram:
    """How late frame messages arrive: arrival time minus the robot's
    ``wall-time``, in buckets 2 % wide from 0.1 ms to 104 s, so the
    memory is fixed however long the fleet runs; percentiles are good to
    2 %, the maximum is exact."""

    LOW_S, RATIO, BUCKETS = 1e-4, 1.02, 700

    def __init__(self):
        self.counts = [0] * (self.BUCKETS + 2)  # [0]: below LOW_S
        self.count = 0
        self.max = None
        self._log_ratio = math.log(self.RATIO)

    def add(self, delay_s: float) -> None:
        if delay_s < self.LOW_S:
            i = 0       # includes negative delays (clocks apart)
        else:
            i = min(self.BUCKETS + 1, 1 + int(
                math.log(delay_s / self.LOW_S) / self._log_ratio))
        self.counts[i] += 1
        self.count += 1
        if self.max is None or delay_s > self.max:
            self.max = delay_s

    def quantile(self, q: float) -> Optional[float]:
        """The upper edge of the bucket holding the q-quantile."""
        if not self.count:
            return None
        rank = q * self.count
        seen = 0
        for i, n in enumerate(self.counts):
            seen += n
            if seen >= rank and n:
                if i == self.BUCKETS + 1:
                    return self.max     # beyond the last bucket
                return min(self.LOW_S * self.RATIO ** i, self.max)
        return self.max

    def summary(self) -> Dict[str, Any]:
        return {"messages": self.count, "p50": self.quantile(0.5),
                "p95": self.quantile(0.95), "max": self.max}


class FleetState:
    """What is known of every robot; fed one message at a time
    (thread-safe), read as JSON text or a dict.

    Path points are kept as JSON text made once when they arrive: writing
    the file every second then costs a join, not the formatting of every
    number again (50 robots' full paths would take seconds to format)."""

    def __init__(self, prefix: str = "landmark",
                 path_length: int = DEFAULT_PATH_LENGTH,
                 path_every: float = DEFAULT_PATH_EVERY):
        self.prefix = prefix.rstrip("/")
        self.path_length = path_length
        self.path_every = path_every
        self.robots: Dict[str, Dict[str, Any]] = {}
        self.paths: Dict[str, deque] = {}
        self.bad_messages = 0
        self.delay = DelayHistogram()
        self.lock = threading.Lock()
        self.version = 0            # counts changes: the map pushes on one
        self.path_total: Dict[str, int] = {}    # points ever added

    def _robot(self, name: str) -> Dict[str, Any]:
        r = self.robots.get(name)
        if r is None:
            r = {"status": None, "frames": 0, "last-frame": None,
                 "missed-frames": 0, "out-of-sequence": 0, "delay": None,
                 "pose": None, "detections": [], "last-wall-time": None,
                 "path-wall-time": None}
            self.robots[name] = r
            self.paths[name] = deque(maxlen=self.path_length)
            self.path_total[name] = 0
        return r

    def _pose(self, name: str, r: Dict[str, Any],
              msg: Dict[str, Any]) -> bool:
        """Keeps the pose; False when it was kept already."""
        pose = msg.get("pose")
        wall = msg.get("wall-time")
        if not isinstance(pose, dict) or not isinstance(wall, (int, float)):
            return True
        last = r["pose"]["wall-time"] if r["pose"] else None
        if last is not None and wall <= last:
            return False    # the pose message of a frame already seen
        r["pose"] = dict(pose, frame=msg.get("frame"), **{"wall-time": wall})
        if last is None or wall - r["path-wall-time"] >= self.path_every:
            r["path-wall-time"] = wall
            self.paths[name].append(json.dumps(
                [pose.get("x"), pose.get("y"), pose.get("heading"), wall]))
            self.path_total[name] += 1
        return True

    def _frame(self, r: Dict[str, Any], msg: Dict[str, Any]) -> None:
        frame, last = msg.get("frame"), r["last-frame"]
        if isinstance(frame, int) and isinstance(last, int):
            if frame > last + 1:
                r["missed-frames"] += frame - last - 1
            elif frame <= last:
                # sent again (QoS 1 after a lost acknowledgement) or the
                # robot's pipeline started again from frame 0
                r["out-of-sequence"] += 1
        r["frames"] += 1
        r["last-frame"] = frame
        wall = msg.get("wall-time")
        r["last-wall-time"] = wall
        if isinstance(wall, (int, float)):
            r["delay"] = time.time() - wall
            self.delay.add(r["delay"])
        r["detections"] = msg.get("detections", [])

    def handle(self, topic: str, payload: bytes) -> bool:
        """Takes one message in; True when it was a pose message that
        repeated the pose of a frame message already handled."""
        parts = topic.split("/")
        head = self.prefix.split("/")
        if len(parts) != len(head) + 2 or parts[:len(head)] != head:
            return False
        name, kind = parts[len(head)], parts[len(head) + 1]
        try:
            msg = json.loads(payload)
        except ValueError:
            msg = None
        with self.lock:
            if not isinstance(msg, dict):
                self.bad_messages += 1
                return False
            r = self._robot(name)
            self.version += 1
            if kind == "frame":
                self._frame(r, msg)
                self._pose(name, r, msg)
            elif kind == "pose":
                kept = self._pose(name, r, msg)
                return r["frames"] > 0 and not kept
            elif kind == "status":
                r["status"] = msg.get("status")
        return False

    def snapshot_text(self) -> str:
        """The fleet as JSON text: one robot per line."""
        with self.lock:
            lines = []
            for name, r in sorted(self.robots.items()):
                fields = {k: v for k, v in r.items()
                          if k != "path-wall-time"}
                text = json.dumps(fields)
                lines.append(f"{json.dumps(name)}: {text[:-1]}, \"path\": ["
                             + ", ".join(self.paths[name]) + "]}")
            head = json.dumps({"wall-time": time.time(),
                               "bad-messages": self.bad_messages,
                               "delay": self.delay.summary()})
        return (head[:-1] + ', "robots": {\n' + ",\n".join(lines)
                + "\n}}\n")

    def view_text(self, seen: Dict[str, int]) -> str:
        """The fleet for the live map, as JSON text: each robot's fields
        without its detections, and only the path points added since
        ``seen`` (robot: points ever added, as this call left it; updated
        here), so a browser is sent each point once."""
        skip = ("path-wall-time", "detections")
        with self.lock:
            lines = []
            for name, r in sorted(self.robots.items()):
                fields = {k: v for k, v in r.items() if k not in skip}
                total, path = self.path_total[name], self.paths[name]
                new = min(len(path), total - seen.get(name, 0))
                seen[name] = total
                fields["path-total"] = total
                text = json.dumps(fields)
                points = [path[i] for i in range(len(path) - new, len(path))]
                lines.append(f"{json.dumps(name)}: {text[:-1]}, "
                             f"\"path-new\": [" + ", ".join(points) + "]}")
            head = json.dumps({"type": "fleet", "wall-time": time.time(),
                               "path-length": self.path_length,
                               "bad-messages": self.bad_messages,
                               "delay": self.delay.summary()})
        return head[:-1] + ', "robots": {' + ", ".join(lines) + "}}"

    def snapshot(self) -> Dict[str, Any]:
        return json.loads(self.snapshot_text())


def write_json(path: str, text: str) -> None:
    """Replaces the file whole: a reader never sees half of it."""
    tmp = f"{path}.{os.getpid()}.tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
    os.replace(tmp, path)


class Fleet:
    """The subscriber: paho-mqtt's network thread feeds a FleetState; it
    reconnects by itself and subscribes again on every connection."""

    def __init__(self, host: str = "127.0.0.1", port: int = 1883,
                 prefix: str = "landmark", username: Optional[str] = None,
                 password: Optional[str] = None,
                 tls_ca_file: Optional[str] = None,
                 path_length: int = DEFAULT_PATH_LENGTH,
                 path_every: float = DEFAULT_PATH_EVERY,
                 all_poses: bool = False):
        import paho.mqtt.client as mqtt
        self.state = FleetState(prefix, path_length, path_every)
        self.all_poses = all_poses
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
        self.pose_topic = topic + "pose"
        self.live_poses = False
        self.client.on_message = self._on_message

    def _on_connect(self, client, userdata, flags, reason_code, properties):
        if reason_code.is_failure:
            self.problem = (f"the broker at {self.host}:{self.port} refused "
                            f"the connection: {reason_code}")
            return
        self.problem = None
        self.live_poses = False
        client.subscribe(self.topics)

    def _on_message(self, client, userdata, m):
        repeat = self.state.handle(m.topic, m.payload)
        if (repeat and not m.retain and not self.live_poses
                and not self.all_poses):
            # A live pose message that repeats its frame message's pose:
            # robots send both, which doubles the messages to handle. The
            # retained poses of quiet robots came right after the
            # subscription, before anything live; from here on frames are
            # enough. (--all-poses keeps the topic, for feeds where some
            # robots send poses without frames.)
            self.live_poses = True
            client.unsubscribe(self.pose_topic)

    def start(self, timeout_s: float = 10.0,
              broker_wait_s: Optional[float] = 0.0,
              stream=None) -> "Fleet":
        """Connects and subscribes. broker_wait_s: how long to keep trying
        a broker that cannot be reached (not up yet), with one line on
        stream when it begins and one when it is up; None: until it is,
        0: not at all. A broker that refuses the connection is an error
        at once, as is a failed TLS handshake."""
        stream = stream or sys.stderr
        deadline = None if broker_wait_s is None \
            else time.monotonic() + broker_wait_s
        waiting = False
        while True:
            try:
                self.client.connect(self.host, self.port, keepalive=30)
                break
            except ssl.SSLError as err:
                # something answered but the TLS handshake failed (another
                # CA, not a TLS port): trying again would not help
                raise CliError(f"TLS with the broker at {self.host}:"
                               f"{self.port} failed: {err}") from None
            except OSError as err:
                left = None if deadline is None \
                    else deadline - time.monotonic()
                if left is not None and left <= 0:
                    waited = f" (waited {broker_wait_s:g} s)" \
                        if broker_wait_s else ""
                    raise CliError(f"cannot reach the broker at "
                                   f"{self.host}:{self.port}: {err}"
                                   f"{waited}") from None
                if not waiting:
                    waiting = True
                    print(f"{PROG} fleet: waiting for the broker at "
                          f"{self.host}:{self.port} (not reachable: "
                          f"{err.strerror or err}); trying every "
                          f"{BROKER_RETRY_S:g} s, Ctrl-C to stop",
                          file=stream, flush=True)
                time.sleep(BROKER_RETRY_S if left is None
                           else min(BROKER_RETRY_S, left))
        if waiting:
            print(f"{PROG} fleet: the broker at {self.host}:{self.port} is "
                  f"up", file=stream, flush=True)
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
        path_length=DEFAULT_PATH_LENGTH, path_every=DEFAULT_PATH_EVERY,
        all_poses=False, stream=None, http=None, token=None,
        map_path=None, broker_wait=None) -> int:
    """``output``: the fleet file (None: none); ``http``: ``[ADDR:]PORT``
    of the live map (None: none); ``broker_wait``: seconds to wait for a
    broker not up yet (None: until it is)."""
    stream = stream or sys.stderr
    if output is not None:
        out_dir = os.path.dirname(os.path.abspath(output))
        if not os.path.isdir(out_dir):
            raise CliError(f"{out_dir}: no such directory")
    web = None
    if http is not None:
        from .. import webguard
        from . import fleetweb
        try:
            listen, http_port = fleetweb.parse_address(http)
            token = webguard.choose_token(listen, token)
            landmarks = fleetweb.read_landmarks(map_path) if map_path \
                else None
        except ValueError as err:
            raise CliError(str(err)) from None
    elif map_path is not None or token is not None:
        raise CliError("--map and --token need --http")
    fleet = Fleet(host, port, prefix, username, password, tls_ca_file,
                  path_length, path_every, all_poses)
    try:
        fleet.start(broker_wait_s=broker_wait, stream=stream)
    except KeyboardInterrupt:
        print(f"{PROG} fleet: stopped before the broker at {host}:{port} "
              f"was up", file=stream)
        return 130
    if http is not None:
        try:
            web = fleetweb.MapServer(fleet.state, listen, http_port, token,
                                     landmarks).start()
        except OSError as err:
            fleet.stop()
            raise CliError(f"cannot listen on {http}: "
                           f"{err.strerror or err}") from None
    stop = threading.Event()
    previous = signal.signal(signal.SIGINT, lambda *a: stop.set())
    previous_term = signal.signal(signal.SIGTERM, lambda *a: stop.set())
    print(f"{PROG} fleet: listening on {host}:{port} ({prefix}/+/...)"
          + (f", writing {output}" if output else "")
          + (f", map at {web.url}" if web else ""), file=stream, flush=True)

    def write():
        if output is not None:
            write_json(output, fleet.state.snapshot_text())
    end = None if duration is None else time.monotonic() + duration
    # at once: the file's existence says the fleet is listening
    write()
    try:
        while not stop.is_set():
            wait = write_every
            if end is not None:
                wait = min(wait, max(0.0, end - time.monotonic()))
            stop.wait(wait)
            write()
            if end is not None and time.monotonic() >= end:
                break
    finally:
        signal.signal(signal.SIGINT, previous)
        signal.signal(signal.SIGTERM, previous_term)
        if web is not None:
            web.stop()
        fleet.stop()
    write()
    n = len(fleet.state.robots)
    print(f"{PROG} fleet: {n} robot{'' if n == 1 else 's'}", file=stream)
    return 0


def add_fleet_parser(subparsers):
    p = subparsers.add_parser(
        "fleet", help="follow every robot's pose over MQTT",
        description="Subscribe to what landmarkpublish sends from every "
                    "robot and keep each robot's latest pose, path, "
                    "detections and status in a JSON file, replaced whole "
                    "every --write-every seconds. Ctrl-C (or --duration) "
                    "ends it after a last write.")
    p.add_argument("-o", "--output", metavar="FLEET.json",
                   help="the fleet file (needed unless --http is given)")
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
    p.add_argument("--broker-wait", type=float, metavar="S",
                   help="give up when the broker cannot be reached for S "
                        "seconds at start (default: wait until it is up, "
                        "trying every second; 0: do not wait)")
    p.add_argument("--duration", type=float, metavar="S",
                   help="stop after S seconds (default: until Ctrl-C)")
    p.add_argument("--write-every", type=float, default=1.0, metavar="S")
    p.add_argument("--path-length", type=int, default=DEFAULT_PATH_LENGTH,
                   metavar="N", help="path points kept per robot "
                                     "(default %(default)s)")
    p.add_argument("--path-every", type=float, default=DEFAULT_PATH_EVERY,
                   metavar="S",
                   help="least time between path points, by the robot's "
                        "wall-time (default %(default)s; 0: every pose)")
    p.add_argument("--all-poses", action="store_true",
                   help="keep every pose message (default: once a live "
                        "pose message repeats its frame message, poses come "
                        "from frame messages only)")
    p.add_argument("--http", metavar="[ADDR:]PORT",
                   help="serve the live fleet map on this address "
                        "(default address 127.0.0.1; any other than "
                        "loopback requires a token; port 0: any free one)")
    add_token_option(p, "the map's access token")
    p.add_argument("--map", metavar="MAP.json",
                   help="draw this landmark map's landmarks on the map")
    p.set_defaults(handler=_handle, parser=p)


def _handle(args) -> int:
    try:
        if args.write_every <= 0 or args.path_length < 1:
            raise CliError("--write-every and --path-length must be "
                           "positive")
        if args.path_every < 0:
            raise CliError("--path-every must be 0 or more")
        if args.broker_wait is not None and args.broker_wait < 0:
            raise CliError("--broker-wait must be 0 or more")
        if args.output is None and args.http is None:
            raise CliError("give -o FLEET.json, --http [ADDR:]PORT or both")
        return run(args.host, args.port, args.output, args.prefix,
                   args.username,
                   args.password or os.environ.get("LANDMARK_MQTT_PASSWORD"),
                   args.tls_ca_file, args.duration, args.write_every,
                   args.path_length, args.path_every, args.all_poses,
                   http=args.http, token=args.token, map_path=args.map,
                   broker_wait=args.broker_wait)
    except CliError as err:
        print(f"{PROG}: error: {err}", file=sys.stderr)
        return err.status
