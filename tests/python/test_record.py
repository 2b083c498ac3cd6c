"""gst-landmark record: the MCAP file is read back with the mcap reader and
the ROS 2 decoder of mcap-ros2-support; every channel, its schema and its
message count are checked against landmarklog's lines and the overlay
video of the same run."""

import json
import math
import os
import subprocess
import sys

import cv2
import numpy as np
import pytest

from gstlandmark.commands import record
from gstlandmark.commands.common import CliError

from shippedclip import CLIP_DIR, CLIP_FRAMES, write_project


@pytest.fixture(scope="module")
def project(tmp_path_factory):
    return write_project(tmp_path_factory.mktemp("project"))


@pytest.fixture(scope="module")
def chain_run(project, tmp_path_factory):
    """The chain on the clip through `gst-landmark run` (its log and
    overlay video), and `gst-landmark record --input` of the same clip."""
    out = tmp_path_factory.mktemp("run")
    env = dict(os.environ)
    cmd = [sys.executable, "-m", "gstlandmark.commands.cli"]
    subprocess.run(cmd + ["run", "--input", f"{CLIP_DIR}/clip.avi",
                          "--config", project, "--out", str(out),
                          "--no-progress"],
                   check=True, env=env, capture_output=True, timeout=120)
    mcap_path = out / "chain.mcap"
    done = subprocess.run(cmd + ["record", "--input", f"{CLIP_DIR}/clip.avi",
                                 "--config", project, "-o", str(mcap_path)],
                          env=env, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    return out, mcap_path, done.stdout


def read_mcap(path):
    """{topic: [(schema name, schema encoding, message encoding, log time,
    decoded)]} through the reader and the ROS 2 decoder."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    out = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        header = reader.get_header()
        summary = reader.get_summary()
        for schema, channel, message, decoded in \
                reader.iter_decoded_messages(
                    topics=[record.IMAGE_TOPIC, record.POSE_TOPIC]):
            out.setdefault(channel.topic, []).append(
                (schema.name, schema.encoding, channel.message_encoding,
                 message.log_time, decoded))
    with open(path, "rb") as f:
        reader = make_reader(f)
        for schema, channel, message in reader.iter_messages(
                topics=[record.DETECTIONS_TOPIC]):
            out.setdefault(channel.topic, []).append(
                (schema.name, schema.encoding, channel.message_encoding,
                 message.log_time, json.loads(message.data)))
    return header, summary, out


def test_every_channel_and_count(chain_run):
    out, mcap_path, stdout = chain_run
    log = [json.loads(x) for x in
           (out / "log.jsonl").read_text().splitlines()]
    assert len(log) == CLIP_FRAMES
    with_pose = [x for x in log if "pose" in x]
    assert len(with_pose) >= 40

    header, summary, topics = read_mcap(mcap_path)
    assert header.profile == "ros2"
    assert sorted(c.topic for c in summary.channels.values()) == sorted(
        [record.IMAGE_TOPIC, record.POSE_TOPIC, record.DETECTIONS_TOPIC])
    counts = summary.statistics.channel_message_counts
    by_topic = {summary.channels[i].topic: n for i, n in counts.items()}
    assert by_topic == {record.IMAGE_TOPIC: CLIP_FRAMES,
                        record.POSE_TOPIC: len(with_pose),
                        record.DETECTIONS_TOPIC: CLIP_FRAMES}
    assert f"{record.POSE_TOPIC}: {len(with_pose)} messages" in stdout

    images = topics[record.IMAGE_TOPIC]
    assert {(s, e, m) for s, e, m, _, _ in images} == {
        ("sensor_msgs/msg/CompressedImage", "ros2msg", "cdr")}
    # the images are the overlay video's frames, in order, at the log's
    # times
    cap = cv2.VideoCapture(str(out / "overlay.avi"))
    for (_, _, _, t, msg), line in zip(images, log):
        assert t == line["pts"]
        assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == t
        assert msg.header.frame_id == "camera" and msg.format == "jpeg"
        ok, frame = cap.read()
        assert ok
        got = cv2.imdecode(np.frombuffer(bytes(msg.data), np.uint8),
                           cv2.IMREAD_COLOR)
        assert got.shape == frame.shape == (line["height"], line["width"], 3)
        # JPEG at quality 90 of a decoded MJPEG frame: close, not equal
        assert np.abs(got.astype(int) - frame.astype(int)).mean() < 3.0
    cap.release()

    poses = topics[record.POSE_TOPIC]
    assert {(s, e, m) for s, e, m, _, _ in poses} == {
        ("geometry_msgs/msg/PoseWithCovarianceStamped", "ros2msg", "cdr")}
    for (_, _, _, t, msg), line in zip(poses, with_pose):
        p = line["pose"]
        assert t == line["pts"] and msg.header.frame_id == "map"
        pos, q = msg.pose.pose.position, msg.pose.pose.orientation
        assert (pos.x, pos.y, pos.z) == (p["x"], p["y"], 0.0)
        yaw = math.atan2(2 * (q.w * q.z + q.x * q.y),
                         1 - 2 * (q.y * q.y + q.z * q.z))
        assert abs(math.remainder(yaw - p["heading"], 2 * math.pi)) < 1e-12
        cov = list(msg.pose.covariance)
        c3 = p["covariance"]
        for i, a in enumerate([0, 1, 5]):
            for j, b in enumerate([0, 1, 5]):
                assert cov[a * 6 + b] == c3[i * 3 + j]
        assert cov[2 * 6 + 2] == 0.0

    dets = topics[record.DETECTIONS_TOPIC]
    assert {(s, e, m) for s, e, m, _, _ in dets} == {
        ("gst_landmark/Detections", "jsonschema", "json")}
    for (_, _, _, t, msg), line in zip(dets, log):
        assert msg == {"frame": line["frame"], "pts": line["pts"],
                       "detections": line["detections"]}
    assert sum(len(m["detections"]) for *_, m in dets) > 0
    schema = next(s for s in summary.schemas.values()
                  if s.name == "gst_landmark/Detections")
    assert json.loads(schema.data)["required"] == ["frame", "detections"]


def test_convert_log_and_video(chain_run, tmp_path):
    """--log and --video give the same file content as --input."""
    out, mcap_path, _ = chain_run
    converted = tmp_path / "converted.mcap"
    counts = record.record(str(converted), log=str(out / "log.jsonl"),
                           video=str(out / "overlay.avi"),
                           stream=open(os.devnull, "w"))
    _, _, a = read_mcap(mcap_path)
    _, _, b = read_mcap(converted)
    assert {k: len(v) for k, v in a.items()} == {
        k: len(v) for k, v in b.items()} == counts
    assert [m for *_, m in a[record.DETECTIONS_TOPIC]] == \
        [m for *_, m in b[record.DETECTIONS_TOPIC]]


def test_log_only_has_no_image_channel(chain_run, tmp_path):
    out, _, _ = chain_run
    path = tmp_path / "noimages.mcap"
    counts = record.record(str(path), log=str(out / "log.jsonl"),
                           start_ns=1_700_000_000 * 10**9,
                           stream=open(os.devnull, "w"))
    assert counts[record.IMAGE_TOPIC] == 0
    _, summary, topics = read_mcap(path)
    assert record.IMAGE_TOPIC not in topics
    first = topics[record.DETECTIONS_TOPIC][0]
    assert first[3] == 1_700_000_000 * 10**9


def test_video_and_log_of_different_runs_are_refused(chain_run, tmp_path):
    out, _, _ = chain_run
    short_log = tmp_path / "short.jsonl"
    short_log.write_text("\n".join(
        (out / "log.jsonl").read_text().splitlines()[:10]) + "\n")
    target = tmp_path / "bad.mcap"
    with pytest.raises(CliError, match="more frames than the log's 10"):
        record.record(str(target), log=str(short_log),
                      video=str(out / "overlay.avi"),
                      stream=open(os.devnull, "w"))
    assert not target.exists() and not (tmp_path / "bad.mcap.part").exists()


def test_bad_log_line_is_named(tmp_path):
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"frame": 0, "detections": []}\nnot json\n')
    with pytest.raises(CliError, match=r"bad.jsonl:2: not JSON"):
        record.record(str(tmp_path / "x.mcap"), log=str(bad),
                      stream=open(os.devnull, "w"))


def test_floor_profile_as_laser_scan(tmp_path):
    # four bins (ahead, left, behind, right): an obstacle 1.5 m ahead,
    # free to the left, not seen behind, free to the image's edge right
    log = tmp_path / "floor.jsonl"
    floor = {"bearing-bins": 4, "bin-width": math.pi / 2, "max-range": 5.0,
             "range": [1.5, 5.0, 0.0, 2.0], "state": [2, 1, 0, 3],
             "marker-range": [None, None, None, None]}
    log.write_text(json.dumps({"frame": 0, "pts": 0, "detections": [],
                               "floor": floor}) + "\n" +
                   json.dumps({"frame": 1, "pts": 33333333,
                               "detections": []}) + "\n")
    path = tmp_path / "floor.mcap"
    counts = record.record(str(path), log=str(log),
                           stream=open(os.devnull, "w"))
    assert counts[record.SCAN_TOPIC] == 1
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        (schema, channel, _, scan), = reader.iter_decoded_messages(
            topics=[record.SCAN_TOPIC])
    assert schema.name == "sensor_msgs/msg/LaserScan"
    assert scan.header.frame_id == "base_link"
    assert scan.angle_min == 0.0
    assert scan.angle_increment == pytest.approx(math.pi / 2)
    assert scan.range_max == 5.0
    r = list(scan.ranges)
    assert r[0] == pytest.approx(1.5) and r[1] == math.inf
    assert math.isnan(r[2]) and math.isnan(r[3])
