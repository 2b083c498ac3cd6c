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
    with open(os.path.join(CLIP_DIR, "scene.json")) as f:
        cam = json.load(f)["camera"]
    camera = {
        calibrate.K_WIDTH: cam["width"], calibrate.K_HEIGHT: cam["height"],
        calibrate.K_MATRIX: [[cam["fx"], 0.0, cam["cx"]],
                             [0.0, cam["fy"], cam["cy"]],
                             [0.0, 0.0, 1.0]],
        "dist": [0.0] * 5,
    }
    mounting = calibrate.FloorResult(cam["height_m"], cam["tilt_deg"],
                                     cam["roll_deg"], 0.0, (0.0, 0.0))
    path = str(tmp_path_factory.mktemp("camera") / "camera.yml")
    calibrate.write_camera_file(path, calibrate.floor_fields(camera,
                                                             mounting))
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
         str(broker.port), "-o", str(out), "--write-every", "0.2"],
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


def test_unreachable_broker_is_a_clear_error(tmp_path):
    from mqttbroker import free_port
    port = free_port()
    done = subprocess.run(
        [sys.executable, "-m", "gstlandmark.cli", "fleet", "--port",
         str(port), "-o", str(tmp_path / "f.json"), "--duration", "1"],
        capture_output=True, text=True, timeout=30)
    assert done.returncode == 1
    assert f"cannot reach the broker at 127.0.0.1:{port}" in done.stderr
