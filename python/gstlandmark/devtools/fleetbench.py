"""``gst-landmark bench fleet``: many robots publishing to one broker,
``gst-landmark fleet`` following them; prints whether the fleet keeps up
(every frame message received, how late) and whether its memory stays
flat (docs/fleet.md).

1. starts a mosquitto broker on 127.0.0.1 at a free port with its own
   configuration (persistence off, bounded queues and memory);
2. runs the shipped clip (tests/files/clips/path-small) through the whole
   chain once with ``landmarkpublish`` and keeps the frame and pose
   messages that arrive: the real messages, a few KB each;
3. starts ``gst-landmark fleet`` as its own process, as a user would;
4. simulates N robots with N paho-mqtt clients driven by one thread of
   this process: each sends what landmarkpublish sends at R frames per
   second (the captured messages in turn, with the robot's name, frame
   number, running time and the wall-time of sending; the retained pose
   of every frame with a pose; retained online/offline status and the
   last will), staggered so the load is even;
5. samples the fleet process's resident memory every second, and at the
   end compares the messages each robot had acknowledged by the broker
   with what the fleet counted for it.

Why paho clients and not N landmarkpublish elements: a message is made
by the chain from the metadata of a real frame; 50 chains at 30 frames/s
do not run on 2 cores, and 50 landmarkpublish elements fed by appsrc
would send messages without detections or pose, not the few-KB messages
of a real robot. Replaying the chain's own messages gives the broker and
the fleet the real bytes at the full rate.
"""

from __future__ import annotations

import json
import os
import pwd
import selectors
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from typing import Any, Callable, Dict, List, Optional

from .. import plugin
from .benchkit import BenchError, add_build_dir_option, add_report_options
from .sourcetree import ROOT

DEFAULT_ROBOTS = 50
DEFAULT_RATE = 30.0
DEFAULT_SECONDS = 60.0
DEFAULT_WINDOW = 40.0
# Over the window the fleet legitimately grows by the path points it
# keeps (2 per second per robot by default, about 100 bytes each: 0.4 MB
# for 50 robots in 40 s); the rest of 4 MiB is allocator noise. Keeping
# 64 bytes per message received (3,000 a second here) would add 7.7 MB.
DEFAULT_RSS_BOUND_MIB = 4.0
PREFIX = "landmark"
# The broker's bounds for each client. A QoS 1 subscriber gets at most
# max_inflight messages before it acknowledges them: mosquitto's default
# of 20 holds a subscriber on a busy machine to 20 messages per round
# trip, below the 3,000 a second of 50 robots (docs/fleet.md has both
# runs). The queue holds 10 s of those 3,000 messages a second: the pause
# a subscriber may take before the broker drops its oldest messages.
DEFAULT_MAX_INFLIGHT = 1000
DEFAULT_MAX_QUEUED = 30000


# ---------------------------------------------------------------------------
# The broker


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_mosquitto(command, port, timeout_s=5.0):
    """Starts mosquitto (``command``) and waits until it listens on
    127.0.0.1:``port``; BenchError with its message when it exits first
    or does not listen in time."""
    proc = subprocess.Popen(command, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise BenchError("mosquitto exited: " +
                             proc.stderr.read().decode())
        try:
            with socket.create_connection(("127.0.0.1", port),
                                          timeout=0.2):
                return proc
        except OSError:
            time.sleep(0.02)
    stop_mosquitto(proc)
    raise BenchError(f"mosquitto not listening on {port}")


def stop_mosquitto(proc):
    """Stops a broker ``start_mosquitto`` started (None: nothing to do)."""
    if proc and proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=5)


class Broker:
    """mosquitto on 127.0.0.1 only, anonymous clients (nothing leaves the
    machine), persistence off; a queue of at most ``max_queued`` messages
    per client that is behind, ``max_inflight`` unacknowledged, and a memory
    limit, so a fleet that cannot keep up loses messages (the bench sees
    it) instead of the broker growing."""

    def __init__(self, directory: str, max_queued: int = DEFAULT_MAX_QUEUED,
                 max_inflight: int = DEFAULT_MAX_INFLIGHT,
                 memory_limit: int = 512 << 20):
        exe = shutil.which("mosquitto") or "/usr/sbin/mosquitto"
        if not os.access(exe, os.X_OK):
            raise BenchError("mosquitto not found (Debian: apt-get install "
                             "mosquitto; scripts/test.sh installs it)")
        self.exe = exe
        self.dir = directory
        self.port = free_port()
        self.conf = os.path.join(directory, "mosquitto.conf")
        self.log = os.path.join(directory, "mosquitto.log")
        self.settings = {"max_queued_messages": max_queued,
                         "max_inflight_messages": max_inflight,
                         "memory_limit": memory_limit}
        self.proc: Optional[subprocess.Popen] = None

    def start(self, timeout_s: float = 5.0) -> "Broker":
        # as ourselves: as root mosquitto would switch to its own user,
        # who may not read this directory
        lines = [f"user {pwd.getpwuid(os.getuid()).pw_name}",
                 f"listener {self.port} 127.0.0.1", "persistence false",
                 "allow_anonymous true", f"log_dest file {self.log}",
                 "log_type error", "log_type warning"]
        lines += [f"{k} {v}" for k, v in self.settings.items()]
        with open(self.conf, "w") as f:
            f.write("\n".join(lines) + "\n")
        self.proc = start_mosquitto([self.exe, "-c", self.conf], self.port,
                                    timeout_s)
        return self

    def stop(self) -> None:
        stop_mosquitto(self.proc)
        self.proc = None


# ---------------------------------------------------------------------------
# Real messages from the chain


def _plugin_env(build_dir: Optional[str]) -> Dict[str, str]:
    """Our build's plugin first when a build directory is known (else the
    environment's, as under ``meson test``)."""
    env = dict(os.environ)
    if build_dir is None:
        build_dir = plugin.find_build_dir("plugins")
    if build_dir is not None:
        plugins = os.path.abspath(os.path.join(build_dir, "plugins"))
        if not os.path.isdir(plugins):
            raise BenchError(f"{plugins}: no such directory (build the "
                             f"project first)")
        old = env.get("GST_PLUGIN_PATH")
        env["GST_PLUGIN_PATH"] = plugins + (os.pathsep + old if old else "")
    return env


def capture_messages(port: int, directory: str,
                     build_dir: Optional[str] = None,
                     timeout_s: float = 60.0) -> List[Dict[str, Any]]:
    """Runs the shipped clip through the chain with landmarkpublish and
    returns what arrived: [{"frame": msg, "pose": msg or None}] per frame,
    in order."""
    import paho.mqtt.client as mqtt

    from ..commands import calibrate
    clip = os.path.join(ROOT, "tests", "files", "clips",
                        "path-small")
    if not os.path.isdir(clip):
        raise BenchError(f"{clip}: no such directory (the bench runs from "
                         f"the source tree)")
    with open(os.path.join(clip, "scene.json")) as f:
        cam = json.load(f)["camera"]
    camera = {calibrate.K_WIDTH: cam["width"],
              calibrate.K_HEIGHT: cam["height"],
              calibrate.K_MATRIX: [[cam["fx"], 0.0, cam["cx"]],
                                   [0.0, cam["fy"], cam["cy"]],
                                   [0.0, 0.0, 1.0]],
              "dist": [0.0] * 5}
    mounting = calibrate.FloorResult(cam["height_m"], cam["tilt_deg"],
                                     cam["roll_deg"], 0.0, (0.0, 0.0))
    camera_file = os.path.join(directory, "camera.yml")
    calibrate.write_camera_file(camera_file,
                                calibrate.floor_fields(camera, mounting))
    mp = os.path.join(clip, "map.json")
    launch = (f"filesrc location={clip}/clip.avi ! decodebin ! videoconvert "
              f"! labsegment palette={clip}/palette.json min-class-pixels=50"
              f" ! blobroundness min-area=30 ! ipmrange "
              f"calibration={camera_file} map={mp} ! trilaterate map={mp} "
              f"filter=ekf ! landmarkpublish port={port} robot=capture ! "
              f"fakesink")
    got: List[tuple] = []
    subscribed = threading.Event()
    client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2,
                         client_id=f"fleet-bench-capture-{os.getpid()}",
                         protocol=mqtt.MQTTv311)
    client.on_subscribe = lambda *a: subscribed.set()
    client.on_message = lambda c, u, m: m.payload and got.append(
        (m.topic, json.loads(m.payload)))
    client.connect("127.0.0.1", port)
    client.loop_start()
    try:
        client.subscribe([(f"{PREFIX}/capture/frame", 1),
                          (f"{PREFIX}/capture/pose", 1)])
        if not subscribed.wait(5):
            raise BenchError("no SUBACK from the bench's broker")
        done = subprocess.run(["gst-launch-1.0", "-q", *launch.split()],
                              env=_plugin_env(build_dir),
                              capture_output=True, text=True,
                              timeout=timeout_s)
        if done.returncode != 0:
            raise BenchError(f"the chain with landmarkpublish failed: "
                             f"{done.stderr.strip()}")
        time.sleep(0.5)     # the last acknowledgements
        # the capture's retained pose and status go: the fleet must not
        # see a robot "capture"
        for kind in ("pose", "status"):
            client.publish(f"{PREFIX}/capture/{kind}", b"", qos=1,
                           retain=True).wait_for_publish(5)
    finally:
        client.disconnect()
        client.loop_stop()
    frames: List[Dict[str, Any]] = []
    for topic, msg in got:
        if topic.endswith("/frame"):
            frames.append({"frame": msg, "pose": None})
        elif frames and msg.get("frame") == frames[-1]["frame"]["frame"]:
            frames[-1]["pose"] = msg
    if not frames or not any(f["pose"] for f in frames):
        raise BenchError(f"the chain sent {len(frames)} frame messages and "
                         f"no pose: is landmarkpublish built?")
    return frames


# ---------------------------------------------------------------------------
# The robots


class Robots:
    """N MQTT clients in one thread (paho's loop driven by a selector, no
    thread per client), each publishing as landmarkpublish does."""

    def __init__(self, port: int, names: List[str],
                 samples: List[Dict[str, Any]], qos: int = 1):
        import paho.mqtt.client as mqtt
        self.samples = samples
        self.qos = qos
        self.names = names
        self.clients = []
        self.connected = 0
        self.sent = {n: 0 for n in names}         # frame messages
        self.acked = {n: 0 for n in names}        # ... acknowledged
        self.pending: Dict[tuple, str] = {}       # (client, mid) -> robot
        self.payload_bytes = 0
        self.late_s = 0.0           # worst lateness against the schedule
        self.client_ids = {n: f"fleet-bench-{n}-{os.getpid()}"
                           for n in names}
        for name in names:
            c = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2,
                            client_id=self.client_ids[name],
                            protocol=mqtt.MQTTv311, userdata=name)
            c.max_queued_messages_set(0)
            c.will_set(f"{PREFIX}/{name}/status", json.dumps(
                {"robot": name, "status": "offline"}), qos=1, retain=True)
            c.on_connect = self._on_connect
            c.on_publish = self._on_publish
            self.clients.append(c)
        self.port = port

    def _on_connect(self, client, name, flags, reason_code, properties):
        if not reason_code.is_failure:
            self.connected += 1

    def _on_publish(self, client, name, mid, reason_code, properties):
        if self.pending.pop((id(client), mid), None) is not None:
            self.acked[name] += 1

    def _pump(self, sel, timeout_s: float) -> None:
        for key, _ in sel.select(max(0.0, timeout_s)):
            key.data.loop_read()
        for c in self.clients:
            if c.want_write():
                c.loop_write()

    def _status(self, status: str) -> None:
        for name, c in zip(self.names, self.clients):
            c.publish(f"{PREFIX}/{name}/status", json.dumps(
                {"robot": name, "client-id": self.client_ids[name],
                 "status": status, "wall-time": time.time()}),
                qos=1, retain=True)

    def run(self, rate: float, seconds: float,
            drain_s: float = 30.0) -> Dict[str, Any]:
        sel = selectors.DefaultSelector()
        for c in self.clients:
            c.connect("127.0.0.1", self.port, keepalive=30)
            sel.register(c.socket(), selectors.EVENT_READ, c)
        deadline = time.monotonic() + 10
        while self.connected < len(self.clients):
            if time.monotonic() > deadline:
                raise BenchError(f"{self.connected} of {len(self.clients)} "
                                 f"robots connected")
            self._pump(sel, 0.05)
        self._status("online")
        n = len(self.clients)
        per_robot = int(round(rate * seconds))
        total = per_robot * n
        slot_s = 1.0 / rate / n     # staggered: an even load
        period_ns = int(1e9 / rate)
        t0 = time.monotonic() + 0.1
        start_wall = time.time()
        slot = 0
        misc_at = t0 + 1
        while slot < total:
            now = time.monotonic()
            while slot < total and t0 + slot * slot_s <= now:
                self.late_s = max(self.late_s, now - (t0 + slot * slot_s))
                self._publish(slot % n, slot // n, period_ns)
                slot += 1
            if now >= misc_at:
                for c in self.clients:
                    c.loop_misc()
                misc_at = now + 1
            self._pump(sel, min(0.05, t0 + slot * slot_s - now))
        publish_end = time.monotonic()
        deadline = publish_end + drain_s
        while self.pending and time.monotonic() < deadline:
            self._pump(sel, 0.05)
        self._status("offline")
        for _ in range(20):
            self._pump(sel, 0.01)
        for c in self.clients:
            c.disconnect()
            self._pump(sel, 0)
        sel.close()
        return {"start-wall-time": start_wall,
                "publish-seconds": publish_end - t0,
                "frames-per-robot": per_robot}

    def _publish(self, i: int, k: int, period_ns: int) -> None:
        name, c = self.names[i], self.clients[i]
        sample = self.samples[k % len(self.samples)]
        wall = time.time()
        msg = dict(sample["frame"], robot=name, frame=k,
                   pts=k * period_ns, **{"running-time": k * period_ns,
                                         "wall-time": wall})
        payload = json.dumps(msg)
        info = c.publish(f"{PREFIX}/{name}/frame", payload, qos=self.qos)
        self.sent[name] += 1
        self.payload_bytes += len(payload)
        if self.qos == 0:
            self.acked[name] += 1
        else:
            self.pending[(id(c), info.mid)] = name
        if sample["pose"] is not None:
            pose = dict(sample["pose"], robot=name, frame=k,
                        **{"running-time": k * period_ns,
                           "wall-time": wall})
            c.publish(f"{PREFIX}/{name}/pose", json.dumps(pose),
                      qos=self.qos, retain=True)


# ---------------------------------------------------------------------------
# The fleet process


def _rss_bytes(pid: int) -> Optional[int]:
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        return None
    return None


def _cpu_seconds(pid: int) -> Optional[float]:
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf(
            "SC_CLK_TCK")
    except (OSError, IndexError, ValueError):
        return None


def _read_fleet(path: str) -> Optional[Dict[str, Any]]:
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def run_fleet_bench(robots: int = DEFAULT_ROBOTS, rate: float = DEFAULT_RATE,
                    seconds: float = DEFAULT_SECONDS, qos: int = 1,
                    window_s: float = DEFAULT_WINDOW,
                    build_dir: Optional[str] = None,
                    keep_dir: Optional[str] = None,
                    max_inflight: int = DEFAULT_MAX_INFLIGHT,
                    max_queued: int = DEFAULT_MAX_QUEUED,
                    progress: Callable[[str], None] = lambda s: None
                    ) -> Dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="fleet-bench-") as tmp:
        work = keep_dir or tmp
        os.makedirs(work, exist_ok=True)
        broker = Broker(tmp, max_queued, max_inflight).start()
        fleet = None
        try:
            progress("capturing the chain's messages (shipped clip)")
            samples = capture_messages(broker.port, tmp, build_dir)
            with open(os.path.join(work, "sample-messages.jsonl"), "w") as f:
                for s in samples:
                    f.write(json.dumps(s["frame"]) + "\n")
            out = os.path.join(work, "fleet.json")
            if os.path.exists(out):
                os.remove(out)
            fleet = subprocess.Popen(
                [sys.executable, "-m", "gstlandmark.commands.cli",
                 "fleet", "--port",
                 str(broker.port), "-o", out],
                stderr=subprocess.PIPE, text=True)
            deadline = time.monotonic() + 30
            while not os.path.exists(out):
                if fleet.poll() is not None or time.monotonic() > deadline:
                    raise BenchError("gst-landmark fleet did not start: " +
                                     (fleet.stderr.read() if fleet.poll()
                                      is not None else "no file in 30 s"))
                time.sleep(0.05)
            names = [f"r{i:03d}" for i in range(robots)]
            sim = Robots(broker.port, names, samples, qos)
            rss: List[tuple] = []
            stop = threading.Event()

            def sample_rss():
                t0 = time.monotonic()
                while not stop.is_set():
                    value = _rss_bytes(fleet.pid)
                    if value is not None:
                        rss.append((time.monotonic() - t0, value))
                    stop.wait(1.0)
            sampler = threading.Thread(target=sample_rss, daemon=True)
            cpu0 = _cpu_seconds(fleet.pid)
            broker_cpu0 = _cpu_seconds(broker.proc.pid)
            load0 = os.getloadavg()[0]
            sampler.start()
            progress(f"{robots} robots x {rate:g} frames/s for {seconds:g} s"
                     f" (QoS {qos})")
            timing = sim.run(rate, seconds)
            stop.set()
            sampler.join()
            cpu1 = _cpu_seconds(fleet.pid)
            broker_cpu1 = _cpu_seconds(broker.proc.pid)
            load1 = os.getloadavg()[0]
            sent = sum(sim.sent.values())

            def caught_up():
                snap = _read_fleet(out)
                return snap is not None and sum(
                    r["frames"] for r in snap["robots"].values()) >= sent
            deadline = time.monotonic() + 15
            while not caught_up() and time.monotonic() < deadline:
                time.sleep(0.2)
            fleet.send_signal(signal.SIGINT)
            try:
                fleet.wait(15)
            except subprocess.TimeoutExpired:
                fleet.kill()
                fleet.wait()
            if fleet.returncode != 0:
                raise BenchError(f"gst-landmark fleet ended with status "
                                 f"{fleet.returncode}: "
                                 f"{fleet.stderr.read()}")
            snap = _read_fleet(out)
        finally:
            if fleet is not None and fleet.poll() is None:
                fleet.kill()
                fleet.wait()
            broker.stop()
    robots_seen = snap["robots"]
    per_robot = [{"robot": n, "sent": sim.sent[n], "acked": sim.acked[n],
                  "received": robots_seen.get(n, {}).get("frames", 0),
                  "missed": robots_seen.get(n, {}).get("missed-frames", 0),
                  "out-of-sequence": robots_seen.get(n, {}).get(
                      "out-of-sequence", 0),
                  "status": robots_seen.get(n, {}).get("status")}
                 for n in names]
    # memory over the last window of the publishing time
    end_t = rss[-1][0] if rss else 0.0
    in_window = [v for t, v in rss if t >= end_t - window_s]
    frames_sent = sum(r["sent"] for r in per_robot)
    return {
        "robots": robots, "rate": rate, "seconds": seconds, "qos": qos,
        "publish-seconds": timing["publish-seconds"],
        "robots-worst-lateness-s": sim.late_s,
        "frame-message-bytes": sim.payload_bytes / max(1, frames_sent),
        "sample-frames": len(samples),
        "sample-frames-with-pose": sum(1 for s in samples if s["pose"]),
        "sent": frames_sent,
        "acked": sum(r["acked"] for r in per_robot),
        "received": sum(r["received"] for r in per_robot),
        "missed": sum(r["missed"] for r in per_robot),
        "out-of-sequence": sum(r["out-of-sequence"] for r in per_robot),
        "offline": sum(1 for r in per_robot if r["status"] == "offline"),
        "per-robot": per_robot,
        "delay": snap["delay"],
        "fleet-cpu-percent": (None if cpu0 is None or cpu1 is None else
                              100 * (cpu1 - cpu0) /
                              timing["publish-seconds"]),
        "broker-cpu-percent": (None if broker_cpu0 is None or broker_cpu1
                               is None else 100 * (broker_cpu1 - broker_cpu0)
                               / timing["publish-seconds"]),
        "load-average": [load0, load1],
        "rss": rss,
        "rss-window-s": min(window_s, end_t),
        "rss-growth-bytes": (in_window[-1] - in_window[0]
                             if in_window else None),
        "rss-window-range-bytes": (max(in_window) - min(in_window)
                                   if in_window else None),
        "broker": broker.settings,
        "cores": os.cpu_count(),
    }


def failures(result: Dict[str, Any], rss_bound_bytes: float,
             max_delay_s: float) -> List[str]:
    """What the fleet did not do: every frame message acknowledged by the
    broker received once and in order, none late beyond max_delay_s,
    memory growth over the window under the bound."""
    out = []
    if result["acked"] != result["sent"]:
        out.append(f"the broker acknowledged {result['acked']} of "
                   f"{result['sent']} frame messages")
    for r in result["per-robot"]:
        if r["received"] != r["sent"]:
            out.append(f"{r['robot']}: sent {r['sent']}, the fleet received"
                       f" {r['received']}")
            break
    if result["received"] != result["sent"]:
        out.append(f"received {result['received']} of {result['sent']} "
                   f"frame messages")
    if result["missed"] or result["out-of-sequence"]:
        out.append(f"{result['missed']} frames missed, "
                   f"{result['out-of-sequence']} out of sequence")
    if result["offline"] != result["robots"]:
        out.append(f"{result['offline']} of {result['robots']} robots "
                   f"seen offline at the end")
    if result["delay"]["max"] is None or result["delay"]["max"] > max_delay_s:
        out.append(f"a frame message arrived {result['delay']['max']} s "
                   f"after it was sent (bound {max_delay_s:g} s)")
    growth = result["rss-growth-bytes"]
    if growth is None or growth > rss_bound_bytes:
        out.append(f"the fleet's memory grew by {growth} bytes over the "
                   f"last {result['rss-window-s']:.0f} s (bound "
                   f"{rss_bound_bytes / 2**20:g} MiB)")
    return out


def format_result(result: Dict[str, Any]) -> str:
    d = result["delay"]

    def ms(x):
        return "-" if x is None else f"{1000 * x:.1f} ms"
    mib = 2 ** 20
    rss = [v for _, v in result["rss"]]
    lines = [
        f"robots {result['robots']} x {result['rate']:g} frames/s for "
        f"{result['seconds']:g} s, QoS {result['qos']}: frame message "
        f"{result['frame-message-bytes']:.0f} bytes on average (the "
        f"chain's messages of the shipped clip, "
        f"{result['sample-frames-with-pose']} of "
        f"{result['sample-frames']} with a pose, each also sent as the "
        f"retained pose message)",
        f"published in {result['publish-seconds']:.1f} s "
        f"({result['sent'] / result['publish-seconds']:.0f} frame "
        f"messages/s; robots at most "
        f"{1000 * result['robots-worst-lateness-s']:.1f} ms behind their "
        f"schedule)",
        f"frame messages: sent {result['sent']}, acknowledged by the broker "
        f"{result['acked']}, received by the fleet {result['received']}, "
        f"missed {result['missed']}, out of sequence "
        f"{result['out-of-sequence']}; robots offline at the end "
        f"{result['offline']}",
        f"delay (send to the fleet's handling): p50 {ms(d['p50'])}, "
        f"p95 {ms(d['p95'])}, max {ms(d['max'])} over {d['messages']} "
        f"messages",
    ]
    if result["fleet-cpu-percent"] is not None:
        lines.append(f"CPU: fleet process {result['fleet-cpu-percent']:.0f}%"
                     f", mosquitto {result['broker-cpu-percent']:.0f}% of "
                     f"one core; machine: {result['cores']} cores, load "
                     f"average {result['load-average'][0]:.1f} at the "
                     f"start, {result['load-average'][1]:.1f} at the end")
    if rss:
        lines.append(
            f"fleet RSS: {rss[0] / mib:.1f} MiB at the start, "
            f"{max(rss) / mib:.1f} MiB at most, {rss[-1] / mib:.1f} MiB at "
            f"the end; over the last {result['rss-window-s']:.0f} s "
            f"growth {result['rss-growth-bytes'] / mib:+.2f} MiB, range "
            f"{result['rss-window-range-bytes'] / mib:.2f} MiB "
            f"({len(rss)} samples, one a second)")
    return "\n".join(lines)


def _handle(args) -> int:
    if args.robots < 1 or args.rate <= 0 or args.seconds <= 0:
        print("gst-landmark: error: --robots, --rate and --seconds must be "
              "positive", file=sys.stderr)
        return 1

    def progress(text):
        if not args.quiet:
            print(f"[bench fleet] {text}", file=sys.stderr, flush=True)
    try:
        result = run_fleet_bench(args.robots, args.rate, args.seconds,
                                 args.qos, args.window, args.build_dir,
                                 args.keep, args.max_inflight,
                                 args.max_queued, progress)
    except BenchError as err:
        print(f"gst-landmark: error: {err}", file=sys.stderr)
        return 1
    print(format_result(result))
    bad = failures(result, args.rss_bound * 2 ** 20, args.max_delay)
    for line in bad:
        print(f"FAIL: {line}")
    if not bad:
        print(f"PASS: every frame message received once and in order, "
              f"memory growth under {args.rss_bound:g} MiB over the last "
              f"{result['rss-window-s']:.0f} s")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=1)
    return 1 if bad else 0


def add_fleet_bench_parser(actions):
    """Add ``bench fleet`` under ``gst-landmark bench``."""
    p = actions.add_parser(
        "fleet", help="many robots on one broker: does gst-landmark fleet "
                      "keep up, is its memory flat",
        description="Simulate --robots robots sending the chain's real "
                    "messages at --rate frames/s to a mosquitto broker on "
                    "127.0.0.1 started here, with gst-landmark fleet "
                    "following them; print messages sent and received, "
                    "the delay percentiles and the fleet's memory, and "
                    "fail when a message is lost or memory grows.")
    p.add_argument("--robots", type=int, default=DEFAULT_ROBOTS)
    p.add_argument("--rate", type=float, default=DEFAULT_RATE,
                   help="frames per second per robot (default %(default)s)")
    p.add_argument("--seconds", type=float, default=DEFAULT_SECONDS)
    p.add_argument("--qos", type=int, choices=(0, 1, 2), default=1)
    p.add_argument("--window", type=float, default=DEFAULT_WINDOW,
                   metavar="S", help="memory growth measured over the last "
                                     "S seconds (default %(default)s)")
    p.add_argument("--rss-bound", type=float, default=DEFAULT_RSS_BOUND_MIB,
                   metavar="MIB", help="largest growth allowed (default "
                                       "%(default)s MiB)")
    p.add_argument("--max-delay", type=float, default=2.0, metavar="S",
                   help="latest a message may arrive (default %(default)s "
                        "s)")
    p.add_argument("--max-inflight", type=int, default=DEFAULT_MAX_INFLIGHT,
                   metavar="N", help="the broker's max_inflight_messages "
                                     "(default %(default)s; mosquitto's "
                                     "own default is 20)")
    p.add_argument("--max-queued", type=int, default=DEFAULT_MAX_QUEUED,
                   metavar="N", help="the broker's max_queued_messages "
                                     "(default %(default)s; mosquitto's "
                                     "own default is 1000)")
    add_build_dir_option(p, "the source tree's build/, or GST_PLUGIN_PATH")
    p.add_argument("--keep", metavar="DIR",
                   help="keep fleet.json and the captured messages here")
    add_report_options(p)
    p.set_defaults(handler=_handle)
