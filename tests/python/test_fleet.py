"""gst-landmark fleet with two publishing robots on a real mosquitto
broker: the fleet file holds, for each robot, the latest pose and the
whole path as each robot's own landmarklog recorded them, its last
detections and its status."""

import json
import os
import signal
import subprocess
import sys

import pytest

from gi.repository import Gst

from gstlandmark import calibrate
from gstlandmark.fleet import FleetState

from mqttbroker import Broker, needs_mosquitto, wait_for

SOURCE_ROOT = os.environ.get(
    "LANDMARK_SOURCE_ROOT",
    os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(
        __file__)))))
CLIP_DIR = os.path.join(SOURCE_ROOT, "tests", "files", "clips", "path-small")


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


@needs_mosquitto
def test_two_robots(gst, tmp_path, camera_file):
    broker = Broker(tmp_path).start()
    out = tmp_path / "fleet.json"
    fleet = subprocess.Popen(
        [sys.executable, "-m", "gstlandmark.cli", "fleet", "--port",
         str(broker.port), "-o", str(out), "--write-every", "0.2",
         "--path-every", "0"],
        stderr=subprocess.PIPE, text=True)
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
    done = subprocess.run(
        [sys.executable, "-m", "gstlandmark.cli", "fleet", "--port",
         str(port), "-o", str(tmp_path / "f.json"), "--duration", "1"],
        capture_output=True, text=True, timeout=30)
    assert done.returncode == 1
    assert f"cannot reach the broker at 127.0.0.1:{port}" in done.stderr


@needs_mosquitto
def test_load_ten_robots(gst):
    """10 robots x 30 frames/s for 10 s (`gst-landmark bench fleet`, the
    short run): the fleet receives every frame message the broker
    acknowledged, once and in order, within half a second, and its memory
    does not grow over the last 6 s."""
    from gstlandmark import fleetbench
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
    from gstlandmark import fleetbench
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
    from gstlandmark.fleet import Fleet
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
    from gstlandmark.fleet import DelayHistogram
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
