"""gst-landmark fleet with two publishing robots on a real mosquitto
broker: the fleet file holds, for each robot, the latest pose and the
whole path as each robot's own landmarklog recorded them, its last
detections and its status."""

import asyncio
import json
import os
import re
import signal
import subprocess
import sys
import time

import pytest

from gi.repository import Gst

from gstlandmark.commands import calibrate
from gstlandmark.commands.fleet import FleetState

from mqttbroker import MOSQUITTO, Broker, needs_mosquitto, wait_for
from shippedclip import CLIP_DIR
from webpages import (check_loopback_guard,
                      check_self_contained, check_token_required)


@pytest.fixture(scope="module")
def camera_file(tmp_path_factory):
    path = calibrate.scene_camera_file(
        os.path.join(CLIP_DIR, "scene.json"),
        tmp_path_factory.mktemp("camera") / "camera.yml")
    return path


def chain(port, robot, log, camera_file, ekf):
    mp = os.path.join(CLIP_DIR, "map.json")
    return (f"filesrc location={CLIP_DIR}/clip.avi ! decodebin ! "
            "videoconvert ! labsegment palette="
            f"{CLIP_DIR}/palette.json min-class-pixels=50 ! "
            "blobroundness min-area=30 ! "
            f"ipmrange calibration={camera_file} map={mp} ! "
            f"trilaterate map={mp} filter={'ekf' if ekf else 'none'} ! "
            f"landmarklog location={log} ! "
            f"landmarkpublish port={port} robot={robot} ! fakesink")


def fleet_process(port, out, *extra):
    """`gst-landmark fleet` on the broker's port writing out every 0.2 s,
    its stderr piped."""
    return subprocess.Popen(
        [sys.executable, "-m", "gstlandmark.commands.cli", "fleet", "--port",
         str(port), "-o", str(out), "--write-every", "0.2", *extra],
        stderr=subprocess.PIPE, text=True)


@needs_mosquitto
def test_two_robots(gst, tmp_path, camera_file):
    broker = Broker(tmp_path).start()
    out = tmp_path / "fleet.json"
    fleet = fleet_process(broker.port, out, "--path-every", "0")
    try:
        assert wait_for(out.exists, 10), "the fleet wrote nothing"
        # two robots at once (different filters give different paths)
        pipes = [Gst.parse_launch(chain(broker.port, name,
                                        tmp_path / f"{name}.jsonl",
                                        camera_file, ekf))
                 for name, ekf in (("r1", True), ("r2", False))]
        for p in pipes:
            p.set_state(Gst.State.PLAYING)
        try:
            for p in pipes:
                msg = p.get_bus().timed_pop_filtered(
                    60 * Gst.SECOND,
                    Gst.MessageType.EOS | Gst.MessageType.ERROR)
                assert msg and msg.type == Gst.MessageType.EOS
        finally:
            for p in pipes:
                p.set_state(Gst.State.NULL)

        def both_offline():
            try:
                robots = json.loads(out.read_text())["robots"]
            except (ValueError, OSError):
                return False
            return all(robots.get(r, {}).get("status") == "offline"
                       for r in ("r1", "r2"))
        assert wait_for(both_offline, 10)
        fleet.send_signal(signal.SIGINT)
        assert fleet.wait(10) == 0, fleet.stderr.read()
    finally:
        if fleet.poll() is None:
            fleet.kill()
            fleet.wait()
        broker.stop()

    robots = json.loads(out.read_text())["robots"]
    assert sorted(robots) == ["r1", "r2"]
    paths = {}
    for name in ("r1", "r2"):
        lines = [json.loads(x) for x in
                 (tmp_path / f"{name}.jsonl").read_text().splitlines()]
        with_pose = [x for x in lines if "pose" in x]
        r = robots[name]
        assert r["frames"] == len(lines) == 45
        assert r["last-frame"] == 44
        assert r["status"] == "offline"
        assert r["detections"] == lines[-1]["detections"]
        last = with_pose[-1]
        assert r["pose"]["frame"] == last["frame"]
        assert {k: r["pose"][k] for k in last["pose"]} == last["pose"]
        assert [p[:3] for p in r["path"]] == [
            [x["pose"]["x"], x["pose"]["y"], x["pose"]["heading"]]
            for x in with_pose]
        paths[name] = r["path"]
    assert [p[:2] for p in paths["r1"]] != [p[:2] for p in paths["r2"]]


def test_state_keeps_a_bounded_path_and_skips_retained_copies():
    s = FleetState(path_length=3)
    for i in range(5):
        pose = {"x": float(i), "y": 0.0, "heading": 0.1}
        body = {"robot": "a", "frame": i, "wall-time": 100.0 + i,
                "pose": pose, "detections": []}
        s.handle("landmark/a/frame", json.dumps(body).encode())
        # the retained pose of the same frame adds nothing
        s.handle("landmark/a/pose", json.dumps(
            {"robot": "a", "frame": i, "wall-time": 100.0 + i,
             "pose": pose}).encode())
    s.handle("landmark/a/frame", b"not json")
    s.handle("other/a/frame", b"{}")
    snap = s.snapshot()
    a = snap["robots"]["a"]
    assert [p[0] for p in a["path"]] == [2.0, 3.0, 4.0]
    assert a["frames"] == 5 and a["pose"]["x"] == 4.0
    assert snap["bad-messages"] == 1


def test_state_thins_the_path_by_the_robots_clock():
    """At 10 poses a second with --path-every 0.5 a point every fifth
    pose; the latest pose is always the newest, kept in the path or not;
    frame number gaps and repeats are counted."""
    s = FleetState(path_every=0.5)
    for i in list(range(23)) + [30, 30]:
        body = {"robot": "a", "frame": i, "wall-time": 100.0 + i / 10,
                "pose": {"x": float(i), "y": 0.0, "heading": 0.0},
                "detections": []}
        s.handle("landmark/a/frame", json.dumps(body).encode())
    a = s.snapshot()["robots"]["a"]
    assert [p[0] for p in a["path"]] == [0.0, 5.0, 10.0, 15.0, 20.0, 30.0]
    assert a["pose"]["x"] == 30.0 and a["frames"] == 25
    assert a["missed-frames"] == 7 and a["out-of-sequence"] == 1


def test_unreachable_broker_is_a_clear_error(tmp_path):
    from mqttbroker import free_port
    port = free_port()
    started = time.monotonic()
    done = subprocess.run(
        [sys.executable, "-m", "gstlandmark.commands.cli", "fleet", "--port",
         str(port), "-o", str(tmp_path / "f.json"), "--duration", "1",
         "--broker-wait", "1.5"],
        capture_output=True, text=True, timeout=30)
    assert done.returncode == 1
    assert f"waiting for the broker at 127.0.0.1:{port} (not reachable: " \
        f"Connection refused)" in done.stderr
    assert f"cannot reach the broker at 127.0.0.1:{port}" in done.stderr
    assert "(waited 1.5 s)" in done.stderr
    assert time.monotonic() - started >= 1.5
    assert not (tmp_path / "f.json").exists()


@needs_mosquitto
def test_tls_failure_is_an_error_at_once(tmp_path):
    """A broker whose certificate another CA signed: an error at once,
    not a wait for a broker that is up."""
    from mqttbroker import make_certificates
    ca, cert, key = make_certificates(tmp_path, "broker")
    other_ca, _, _ = make_certificates(tmp_path, "other")
    broker = Broker(tmp_path, tls=(ca, cert, key)).start()
    try:
        started = time.monotonic()
        done = subprocess.run(
            [sys.executable, "-m", "gstlandmark.commands.cli", "fleet",
             "--port", str(broker.port), "--tls-ca-file", other_ca,
             "-o", str(tmp_path / "f.json")],
            capture_output=True, text=True, timeout=30)
    finally:
        broker.stop()
    assert done.returncode == 1, done.stderr
    assert done.stderr.startswith(
        f"gst-landmark: error: TLS with the broker at 127.0.0.1:"
        f"{broker.port} failed: "), done.stderr
    assert "CERTIFICATE_VERIFY_FAILED" in done.stderr
    assert "waiting" not in done.stderr
    assert time.monotonic() - started < 10
    assert not (tmp_path / "f.json").exists()


@needs_mosquitto
def test_waits_for_a_broker_started_late(tmp_path):
    """The fleet starts first, says it waits, and follows the robot once a
    real mosquitto comes up on its port."""
    import paho.mqtt.client as mqtt
    broker = Broker(tmp_path)       # its port chosen, not started
    fleet_file = tmp_path / "f.json"
    proc = fleet_process(broker.port, fleet_file, "--duration", "2")
    pub = None
    try:
        line = proc.stderr.readline()
        assert f"waiting for the broker at 127.0.0.1:{broker.port} (not " \
            f"reachable: Connection refused)" in line
        time.sleep(1.5)             # a retry or two against nothing
        assert proc.poll() is None and not fleet_file.exists()
        broker.start()
        pub = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id="pub",
                          protocol=mqtt.MQTTv311)
        pub.connect("127.0.0.1", broker.port)
        pub.loop_start()
        pub.publish("landmark/late/pose", json.dumps(
            {"robot": "late", "frame": 3, "wall-time": 10.0,
             "pose": {"x": 1.5, "y": -2.0, "heading": 0.25}}),
            qos=1, retain=True).wait_for_publish(5)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
        if pub is not None:
            pub.disconnect()
            pub.loop_stop()
        if broker.proc is not None:
            broker.stop()
    assert proc.returncode == 0, err
    assert f"the broker at 127.0.0.1:{broker.port} is up" in err
    assert "1 robot\n" in err
    late = json.loads(fleet_file.read_text())["robots"]["late"]
    assert late["pose"]["x"] == 1.5 and late["pose"]["frame"] == 3


@needs_mosquitto
def test_load_ten_robots(gst):
    """10 robots x 30 frames/s for 10 s (`gst-landmark bench fleet`, the
    short run): the fleet receives every frame message the broker
    acknowledged, once and in order, within half a second, and its memory
    does not grow over the last 6 s."""
    from gstlandmark.devtools import fleetbench
    r = fleetbench.run_fleet_bench(robots=10, rate=30, seconds=10,
                                   window_s=6)
    assert r["sent"] == 10 * 30 * 10
    assert r["acked"] == r["received"] == r["sent"]
    assert all(x["received"] == x["sent"] == 300 for x in r["per-robot"])
    assert r["missed"] == r["out-of-sequence"] == 0
    assert r["offline"] == 10
    assert r["delay"]["messages"] == r["sent"]
    assert r["delay"]["p95"] < 0.5 and r["delay"]["max"] < 2.0
    # the chain's real messages: a few KB with detections and a pose
    assert 2000 < r["frame-message-bytes"] < 8000
    assert r["sample-frames-with-pose"] >= 40
    assert len(r["rss"]) >= 9 and r["rss-window-s"] >= 5
    # 10 robots add 2 path points a second, about 130 bytes each: 16 KB
    # in 6 s; a leak of 64 bytes per message received (600 a second with
    # the pose messages) would add 230 KB
    assert r["rss-growth-bytes"] < 1 << 20
    assert fleetbench.failures(r, 1 << 20, 2.0) == []


def test_load_failures_are_reported():
    """The bench's verdict names each way a fleet can fall short."""
    from gstlandmark.devtools import fleetbench
    good = {"sent": 6, "acked": 6, "received": 6, "missed": 0,
            "out-of-sequence": 0, "offline": 2, "robots": 2,
            "per-robot": [{"robot": "a", "sent": 3, "received": 3},
                          {"robot": "b", "sent": 3, "received": 3}],
            "delay": {"max": 0.01}, "rss-growth-bytes": 1000,
            "rss-window-s": 40}
    assert fleetbench.failures(good, 4 << 20, 2.0) == []
    lost = dict(good, received=5, missed=1)
    lost["per-robot"] = [{"robot": "a", "sent": 3, "received": 2},
                         {"robot": "b", "sent": 3, "received": 3}]
    text = " ".join(fleetbench.failures(lost, 4 << 20, 2.0))
    assert "a: sent 3, the fleet received 2" in text
    assert "received 5 of 6" in text and "1 frames missed" in text
    late = dict(good, delay={"max": 3.5})
    assert "arrived 3.5 s after" in fleetbench.failures(late, 4 << 20,
                                                        2.0)[0]
    grown = dict(good, **{"rss-growth-bytes": 5 << 20})
    assert "memory grew by 5242880 bytes over the last 40 s" in \
        fleetbench.failures(grown, 4 << 20, 2.0)[0]


@needs_mosquitto
def test_retained_pose_of_a_quiet_robot_then_frames_only(tmp_path):
    """A fleet started late gets the retained pose of a robot that no
    longer sends, and live poses sent without frames; once a live pose
    repeats its frame message, it takes poses from the frame messages
    alone (the pose topic is left), losing none."""
    import paho.mqtt.client as mqtt
    from gstlandmark.commands.fleet import Fleet
    broker = Broker(tmp_path).start()
    pub = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id="pub",
                      protocol=mqtt.MQTTv311)
    pub.connect("127.0.0.1", broker.port)
    pub.loop_start()
    fleet = None
    try:
        def pose(i):
            return {"x": 1.0 + i, "y": 2.0, "heading": 0.5}
        pub.publish("landmark/quiet/pose", json.dumps(
            {"robot": "quiet", "frame": 7, "wall-time": 50.0,
             "pose": pose(0)}), qos=1, retain=True).wait_for_publish(5)
        fleet = Fleet(port=broker.port, path_every=0).start()
        assert wait_for(lambda: "quiet" in fleet.state.robots, 5)
        # live poses without frames (a bridge that forwards poses only)
        # keep the pose topic
        for i in range(3):
            pub.publish("landmark/bridged/pose", json.dumps(
                {"robot": "bridged", "frame": i, "wall-time": 60.0 + i,
                 "pose": pose(i)}), qos=1, retain=True)
        assert wait_for(lambda: (fleet.state.robots.get("bridged", {})
                                 .get("pose") or {}).get("frame") == 2, 5)
        assert not fleet.live_poses
        for i in range(20):
            body = {"robot": "live", "frame": i, "wall-time": 100.0 + i,
                    "pose": pose(i), "detections": []}
            pub.publish("landmark/live/frame", json.dumps(body), qos=1)
            pub.publish("landmark/live/pose", json.dumps(
                {k: body[k] for k in ("robot", "frame", "wall-time",
                                      "pose")}), qos=1, retain=True)
        assert wait_for(
            lambda: fleet.state.robots.get("live", {}).get("frames") == 20,
            10)
        assert fleet.live_poses
        snap = fleet.state.snapshot()
    finally:
        if fleet:
            fleet.stop()
        pub.disconnect()
        pub.loop_stop()
        broker.stop()
    quiet, live = snap["robots"]["quiet"], snap["robots"]["live"]
    assert quiet["pose"]["x"] == 1.0 and quiet["pose"]["frame"] == 7
    assert quiet["frames"] == 0 and quiet["path"] == [[1.0, 2.0, 0.5, 50.0]]
    assert [p[0] for p in snap["robots"]["bridged"]["path"]] == [1, 2, 3]
    assert [p[0] for p in live["path"]] == [1.0 + i for i in range(20)]
    assert live["pose"]["frame"] == 19 and live["missed-frames"] == 0


def test_delay_percentiles_against_numpy():
    """The fleet's fixed histogram gives the delay percentiles to 2 %
    (numpy's on the same values as the reference) and the exact maximum;
    clocks apart (negative delays) and delays beyond 100 s are counted."""
    import numpy as np
    from gstlandmark.commands.fleet import DelayHistogram
    rng = np.random.default_rng(3)
    values = np.exp(rng.normal(np.log(0.004), 1.5, 20000))
    h = DelayHistogram()
    for v in values:
        h.add(float(v))
    for q in (0.5, 0.95):
        ref = float(np.quantile(values, q, method="inverted_cdf"))
        assert ref <= h.quantile(q) <= ref * 1.0201, (q, ref)
    assert h.summary()["max"] == float(values.max())
    assert h.summary()["messages"] == 20000
    h.add(-0.5)
    h.add(250.0)
    assert h.count == 20002 and h.max == 250.0
    assert h.quantile(1.0) == 250.0
    assert DelayHistogram().quantile(0.5) is None


# ---------------------------------------------------------------------------
# the live map (gst-landmark fleet --http)

MAP_TOKEN = "fleet-map-token-for-the-test"


def serve_map(state, check, **kwargs):
    """Runs ``check(client)`` against the map's app on a real port."""
    from aiohttp.test_utils import TestClient, TestServer
    from gstlandmark.commands import fleetweb

    async def main():
        app = fleetweb.make_app(state, **kwargs)
        async with TestClient(TestServer(app)) as client:
            await asyncio.wait_for(check(client), 30)
    asyncio.run(main())


def test_map_page_and_static_files_have_no_external_urls():
    async def check(client):
        html = await check_self_contained(
            client, ("static/fleet.js", "static/fleet.css"),
            "/static/../fleet.py")
        assert "<canvas" in html
    serve_map(FleetState(), check)


def publish_robot(broker, name):
    import paho.mqtt.client as mqtt
    c = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2,
                    client_id=f"sim-{name}-{os.getpid()}",
                    protocol=mqtt.MQTTv311)
    c.connect("127.0.0.1", broker.port)
    c.loop_start()
    return c


def test_map_shows_two_simulated_robots_live(tmp_path):
    """Two robots publish status and frames with poses through a real
    broker; the map's WebSocket carries the map's landmarks, each
    robot's latest pose (with its covariance), every path point once, the
    frames missed and the status, at most every push_every seconds."""
    if MOSQUITTO is None:
        pytest.skip("the mosquitto broker is not installed")
    from gstlandmark.commands import fleetweb
    from gstlandmark.commands.fleet import Fleet
    broker = Broker(tmp_path).start()
    fleet = Fleet(port=broker.port, path_every=0).start()
    map_path = os.path.join(CLIP_DIR, "map.json")
    with open(map_path) as f:
        map_ids = [m["id"] for m in json.load(f)["landmarks"]]
    cov = [0.04, 0.01, 0.0, 0.01, 0.09, 0.0, 0.0, 0.0, 0.01]
    sent = {"r1": [], "r2": []}
    robots = {n: publish_robot(broker, n) for n in sent}

    def send(name, frame, wall):
        pose = {"x": 1.0 + 0.1 * frame, "y": 2.0 if name == "r1" else 4.0,
                "heading": 0.05 * frame}
        if name == "r1":
            pose["covariance"] = cov
        sent[name].append([pose["x"], pose["y"], pose["heading"], wall])
        body = {"robot": name, "frame": frame, "wall-time": wall,
                "pose": pose, "detections": []}
        robots[name].publish(f"landmark/{name}/frame", json.dumps(body),
                             qos=1).wait_for_publish(5)

    async def check(client):
        for name, c in robots.items():
            c.publish(f"landmark/{name}/status", json.dumps(
                {"robot": name, "status": "online"}), qos=1,
                retain=True).wait_for_publish(5)
        async with client.ws_connect("/ws") as ws:
            first = await ws.receive_json()
            assert first["type"] == "map"
            assert [m["id"] for m in first["landmarks"]] == map_ids
            got = {n: [] for n in sent}
            last = {}
            stamps = []
            loop = asyncio.get_running_loop()
            frame = 0

            async def publish_while_reading():
                nonlocal frame
                for frame in range(20):
                    wall = time.time()
                    # r2 skips frames 5..7: three frames missed
                    for name in sent:
                        if name == "r1" or not 5 <= frame <= 7:
                            await loop.run_in_executor(
                                None, send, name, frame, wall)
                    await asyncio.sleep(0.05)
            publisher = asyncio.ensure_future(publish_while_reading())
            while True:
                msg = await ws.receive_json()
                assert msg["type"] == "fleet"
                stamps.append(loop.time())
                for name, r in msg["robots"].items():
                    got[name] += r["path-new"]
                    last[name] = r
                if publisher.done() and all(
                        len(got[n]) == len(sent[n]) for n in sent):
                    break
            await publisher
            for name in sent:
                # every point once, in order, as sent
                assert got[name] == sent[name]
                x, y, h, wall = sent[name][-1]
                pose = last[name]["pose"]
                assert (pose["x"], pose["y"], pose["heading"]) == (x, y, h)
                assert last[name]["status"] == "online"
                assert "detections" not in last[name]
            assert last["r1"]["pose"]["covariance"] == cov
            assert last["r1"]["missed-frames"] == 0
            assert last["r2"]["missed-frames"] == 3
            gaps = [b - a for a, b in zip(stamps, stamps[1:])]
            assert min(gaps) >= 0.2, gaps       # push_every 0.25
            # a robot going offline shows at the next push
            robots["r2"].publish("landmark/r2/status", json.dumps(
                {"robot": "r2", "status": "offline"}), qos=1,
                retain=True).wait_for_publish(5)
            while True:
                msg = await ws.receive_json()
                if msg["robots"]["r2"]["status"] == "offline":
                    assert msg["robots"]["r2"]["path-new"] == []
                    break
    try:
        serve_map(fleet.state, check,
                  landmarks=fleetweb.read_landmarks(map_path))
    finally:
        for c in robots.values():
            c.disconnect()
            c.loop_stop()
        fleet.stop()
        broker.stop()


def test_map_token_required_off_loopback():
    import aiohttp

    async def check(client):
        await check_token_required(
            client, MAP_TOKEN, ("/", "/static/fleet.js", "/api/fleet"))
        for query in ("", "?token=nope"):
            with pytest.raises(aiohttp.WSServerHandshakeError) as err:
                await client.ws_connect("/ws" + query)
            assert err.value.status == 401
        # the page's address sets the cookie its files and socket use
        r = await client.get("/?token=" + MAP_TOKEN)
        assert r.status == 200
        r = await client.get("/static/fleet.css")
        assert r.status == 200
        async with client.ws_connect("/ws") as ws:
            assert (await ws.receive_json())["type"] == "map"
            assert "a" in (await ws.receive_json())["robots"]

    state = FleetState()
    state.handle("landmark/a/status", b'{"status": "online"}')
    serve_map(state, check, token=MAP_TOKEN, loopback=False)


def test_map_on_loopback_refuses_other_hosts_and_origins():
    async def check(client):
        await check_loopback_guard(client, "/api/fleet")
    serve_map(FleetState(), check)


@pytest.mark.parametrize("args, message", [
    (["--http", "80x"], "expected [ADDR:]PORT"),
    (["--http", "0", "--map", "/nonexistent/map.json"],
     "/nonexistent/map.json"),
    (["--http", "0", "--token", "short"], "at least 16 characters"),
    (["-o", "fleet.json", "--map", os.path.join(CLIP_DIR, "map.json")],
     "need --http"),
    ([], "give -o FLEET.json, --http"),
])
def test_map_options_are_checked(args, message, capsys):
    from gstlandmark.commands import cli
    assert cli.main(["fleet", "--port", "1"] + args) != 0
    assert message in capsys.readouterr().err


def test_map_command_serves_the_map(tmp_path):
    """`gst-landmark fleet --http 0` prints the map's address and serves
    the fleet there; off loopback it makes a token and requires it."""
    if MOSQUITTO is None:
        pytest.skip("the mosquitto broker is not installed")
    import urllib.error
    import urllib.request
    broker = Broker(tmp_path).start()
    for listen in ("0", "0.0.0.0:0"):
        proc = subprocess.Popen(
            [sys.executable, "-m", "gstlandmark.commands.cli",
             "fleet", "--port",
             str(broker.port), "--http", listen],
            stderr=subprocess.PIPE, text=True)
        try:
            line = proc.stderr.readline()
            url = re.search(r"map at (\S+)", line).group(1)
            if listen == "0":
                assert url.startswith("http://127.0.0.1:")
                assert "token" not in url
            else:
                token = re.search(r"\?token=([\w-]+)$", url).group(1)
                assert len(token) >= 16
                port = re.search(r":(\d+)/", url).group(1)
                base = f"http://127.0.0.1:{port}/"
                with pytest.raises(urllib.error.HTTPError) as err:
                    urllib.request.urlopen(base + "api/fleet", timeout=5)
                assert err.value.code == 401
                url = base + "?token=" + token
            api = url.replace("/?", "/api/fleet?") if "?" in url \
                else url + "api/fleet"
            with urllib.request.urlopen(api, timeout=5) as r:
                assert json.load(r)["robots"] == {}
            proc.send_signal(signal.SIGINT)
            assert proc.wait(10) == 0
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    broker.stop()
