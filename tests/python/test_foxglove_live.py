"""gst-landmark run --foxglove: the chain on the shipped clip served live
over the Foxglove WebSocket protocol; a client of the `websockets`
library subscribes to every channel and decodes the ROS 2 messages with
mcap-ros2-support's decoder. The poses are checked against the run's own
log, the images against its overlay video and its input, frame for frame
(the detections' frame index ties a stamp to a log line); clients that
speak another subprotocol or send garbage leave the server serving."""

import json
import math
import re
import struct
import subprocess
import sys
import time

import cv2
import numpy as np
import pytest

from gstlandmark import rosmessages

from shippedclip import CLIP_DIR, CLIP_FRAMES, write_project

websockets = pytest.importorskip("websockets")
from websockets.sync.client import connect  # noqa: E402

pytest.importorskip("foxglove")

# the protocol's v1 under its current name (foxglove-sdk >= 0.14 and the
# Foxglove app) and its first name; clients offer both
SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]
MESSAGE_DATA = 0x01


def start_run(tmp_path, *extra):
    """The chain on the clip with --foxglove on a free port, waiting for a
    client; returns (process, ws URL)."""
    project = write_project(tmp_path)
    cmd = [sys.executable, "-m", "gstlandmark.commands.cli", "run", "file",
           "--input", f"{CLIP_DIR}/clip.avi", "--config", project,
           "--out", str(tmp_path / "run"), "--no-progress",
           "--foxglove", "0", "--foxglove-wait", *extra]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    seen = []
    while time.monotonic() < deadline:
        line = proc.stderr.readline()
        if not line:
            break
        seen.append(line)
        found = re.search(r"ws://127\.0\.0\.1:(\d+)", line)
        if found:
            return proc, f"ws://127.0.0.1:{found.group(1)}"
    proc.kill()
    raise AssertionError("no server address: " + "".join(seen))


def bad_clients(url):
    """A client offering another subprotocol is refused at the handshake;
    one that sends garbage text and binary frames is dropped or ignored."""
    from websockets.exceptions import InvalidStatus, WebSocketException
    with pytest.raises(InvalidStatus):
        connect(url, subprotocols=["not.foxglove"], open_timeout=5)
    with connect(url, subprotocols=SUBPROTOCOLS, open_timeout=5) as ws:
        assert json.loads(ws.recv(timeout=5))["op"] == "serverInfo"
        try:
            ws.send("{not json")
            ws.send(json.dumps({"op": "subscribe", "subscriptions": "x"}))
            ws.send(b"\xff" * 64)
            ws.send(b"")
        except WebSocketException:
            pass    # the server may drop the client at once


def live_messages(url):
    """{topic: [(log time, decoded message)]} until the server closes,
    and the advertised channels."""
    from mcap_ros2._dynamic import generate_dynamic
    from websockets.exceptions import ConnectionClosed
    channels, decoders, received = {}, {}, {}
    with connect(url, subprotocols=SUBPROTOCOLS, open_timeout=5,
                 max_size=None) as ws:
        assert ws.subprotocol in SUBPROTOCOLS
        info = json.loads(ws.recv(timeout=5))
        assert info["op"] == "serverInfo" and info["name"] == "gst-landmark"
        while not channels:
            msg = ws.recv(timeout=5)
            if isinstance(msg, str) and json.loads(msg)["op"] == "advertise":
                for ch in json.loads(msg)["channels"]:
                    channels[ch["id"]] = ch
        ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": cid, "channelId": cid} for cid in channels]}))
        for ch in channels.values():
            decoders[ch["id"]] = generate_dynamic(
                ch["schemaName"], ch["schema"])[ch["schemaName"]]
        try:
            while True:
                msg = ws.recv(timeout=30)
                if not isinstance(msg, bytes) or msg[0] != MESSAGE_DATA:
                    continue
                _, sub, log_time = struct.unpack_from("<BIQ", msg)
                topic = channels[sub]["topic"]
                received.setdefault(topic, []).append(
                    (log_time, decoders[sub](msg[13:])))
        except ConnectionClosed:
            pass
    return channels, received


def stamp_ns(msg):
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def video(path):
    cap = cv2.VideoCapture(path)
    frames = []
    while True:
        ok, frame = cap.read()
        if not ok:
            return frames
        frames.append(frame)


@pytest.fixture(scope="module")
def live_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("foxglove")
    proc, url = start_run(tmp)
    try:
        bad_clients(url)
        channels, received = live_messages(url)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err
    log = [json.loads(x) for x in
           (tmp / "run" / "log.jsonl").read_text().splitlines()]
    return tmp / "run", channels, received, log


def test_channels_are_the_recordings(live_run):
    _, channels, received, log = live_run
    advertised = {ch["topic"]: ch for ch in channels.values()}
    expected = {rosmessages.POSE_TOPIC: rosmessages.POSE_TYPE,
                rosmessages.IMAGE_TOPIC: rosmessages.IMAGE_TYPE,
                rosmessages.CAMERA_IMAGE_TOPIC: rosmessages.IMAGE_TYPE,
                rosmessages.DETECTIONS_TOPIC: rosmessages.DETECTIONS_TYPE,
                rosmessages.TF_TOPIC: rosmessages.TF_TYPE,
                rosmessages.TF_STATIC_TOPIC: rosmessages.TF_TYPE,
                rosmessages.CAMERA_INFO_TOPIC: rosmessages.CAMERA_INFO_TYPE,
                rosmessages.PATH_TOPIC: rosmessages.PATH_TYPE,
                rosmessages.MAP_TOPIC: rosmessages.MAP_TYPE}
    assert {t: ch["schemaName"] for t, ch in advertised.items()} == expected
    assert {ch["encoding"] for ch in channels.values()} == {"cdr"}
    assert {ch["schemaEncoding"] for ch in channels.values()} == {"ros2msg"}
    assert len(log) == CLIP_FRAMES
    # every frame arrived (the run waited for the subscription)
    frames = [m.frame for _, m in received[rosmessages.DETECTIONS_TOPIC]]
    assert frames == list(range(CLIP_FRAMES))
    assert len(received[rosmessages.POSE_TOPIC]) == \
        sum("pose" in x for x in log)


def test_poses_are_the_logs(live_run):
    _, _, received, log = live_run
    frame_of = {stamp_ns(m): m.frame
                for _, m in received[rosmessages.DETECTIONS_TOPIC]}
    poses = received[rosmessages.POSE_TOPIC]
    assert len(poses) >= 40
    for log_time, msg in poses:
        assert log_time == stamp_ns(msg)
        want = log[frame_of[stamp_ns(msg)]]["pose"]
        p = msg.pose.pose
        assert p.position.x == pytest.approx(want["x"], abs=1e-9)
        assert p.position.y == pytest.approx(want["y"], abs=1e-9)
        heading = 2 * math.atan2(p.orientation.z, p.orientation.w)
        assert math.remainder(heading - want["heading"], 2 * math.pi) == \
            pytest.approx(0.0, abs=1e-9)
        assert msg.header.frame_id == "map"
    # the stamps are the wall clock of the run plus the frames' times
    t0 = stamp_ns(poses[0][1]) - log[frame_of[stamp_ns(poses[0][1])]]["pts"]
    assert abs(t0 / 1e9 - time.time()) < 600
    for _, msg in poses:
        assert stamp_ns(msg) - t0 == log[frame_of[stamp_ns(msg)]]["pts"]


@pytest.mark.parametrize("topic,source", [
    (rosmessages.IMAGE_TOPIC, "overlay"), (rosmessages.CAMERA_IMAGE_TOPIC, "input")])
def test_images_are_the_runs_frames(live_run, topic, source):
    out, _, received, log = live_run
    frame_of = {stamp_ns(m): m.frame
                for _, m in received[rosmessages.DETECTIONS_TOPIC]}
    frames = video(str(out / "overlay.avi") if source == "overlay"
                   else f"{CLIP_DIR}/clip.avi")
    assert len(frames) == CLIP_FRAMES
    images = received[topic]
    assert len(images) == CLIP_FRAMES
    for _, msg in images:
        assert msg.format == "jpeg"
        got = cv2.imdecode(np.frombuffer(bytes(msg.data), np.uint8),
                           cv2.IMREAD_COLOR)
        index = frame_of[stamp_ns(msg)]
        assert got.shape[:2] == (log[index]["height"], log[index]["width"])
        # the JPEG of the same frame (overlay.avi is MJPEG too)
        assert np.abs(got.astype(int) - frames[index].astype(int)).mean() \
            < 3.0
    if source == "overlay":
        # the overlay differs from the camera: it is not the input again
        first = cv2.imdecode(np.frombuffer(bytes(images[0][1].data),
                                           np.uint8), cv2.IMREAD_COLOR)
        camera = video(f"{CLIP_DIR}/clip.avi")[frame_of[stamp_ns(
            images[0][1])]]
        assert np.abs(first.astype(int) - camera.astype(int)).mean() > 0.5


def test_other_address_needs_the_explicit_flag(tmp_path):
    cmd = [sys.executable, "-m", "gstlandmark.commands.cli", "run", "file",
           "--input", f"{CLIP_DIR}/clip.avi", "--out", str(tmp_path),
           "--foxglove", "0", "--foxglove-host", "0.0.0.0"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    assert done.returncode != 0
    assert "--foxglove-host 0.0.0.0: not a loopback address" in done.stderr
    assert "--foxglove-expose" in done.stderr
    assert not (tmp_path / "log.jsonl").exists()


def test_bad_port_is_refused(tmp_path):
    cmd = [sys.executable, "-m", "gstlandmark.commands.cli", "run", "file",
           "--input", f"{CLIP_DIR}/clip.avi", "--out", str(tmp_path),
           "--foxglove", "70000"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    assert done.returncode != 0
    assert "--foxglove 70000: a port is 0..65535" in done.stderr
