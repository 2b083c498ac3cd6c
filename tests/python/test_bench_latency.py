"""``gst-landmark bench latency`` and ``bench file`` run the shipped
pipelines on a few frames and print sane numbers.

Not timed tests: the numbers are only bounded loosely (a live frame
reaches the sink after its capture and within a second; a pose on the
rendered scene, none on the test bars).
"""

import json

import pytest

from gstlandmark.commands import cli
from gstlandmark.devtools import latencybench

FRAMES = 8


@pytest.fixture(scope="module")
def latency(gst, tmp_path_factory):
    out = tmp_path_factory.mktemp("latency")
    report = out / "latency.json"
    assert cli.main(["bench", "latency", "--size", "640x480", "--frames",
                     str(FRAMES), "--warmup", "2", "--runs", "1", "--out",
                     str(out / "files"), "--json", str(report), "-q"]) == 0
    return json.loads(report.read_text())


def test_latency_rows_cover_both_live_pipelines_and_sources(latency):
    got = {(r["pipeline"], r["source"]) for r in latency["rows"]}
    assert got == {(p, s) for p in latencybench.LIVE_PIPELINES
                   for s in latencybench.SOURCES}
    assert all(r["size"] == "640x480" and r["frames"] == FRAMES
               for r in latency["rows"])
    assert len(latency["load_average"]) == 2


def test_latency_is_after_capture_and_under_a_second(latency):
    for r in latency["rows"]:
        assert 0 < r["median_ms"] <= r["p95_ms"] <= r["max_ms"] < 1000, r
        # the frame leaves the source, then trilaterate, then reaches the
        # sink
        assert 0 <= r["source_ms"] <= r["trilaterate_ms"] <= r["max_ms"], r
        assert r["reported_ms"] > 0, r
        # from where the camera's frame enters the pipeline: part of it
        assert 0 < r["host_ms"] <= r["median_ms"], r
        if r["pipeline"] == "camera-mjpeg":
            assert 0 < r["standin_encode_ms"] <= r["trilaterate_ms"], r
        else:
            assert r["standin_encode_ms"] is None, r


def test_poses_only_where_the_frames_show_landmarks(latency):
    for r in latency["rows"]:
        if r["source"] == "scene":
            assert r["poses"] == FRAMES, r
        else:
            assert r["poses"] == 0, r


def test_latency_table_is_printed(gst, tmp_path, capsys):
    assert cli.main(["bench", "latency", "--size", "160x120", "--frames",
                     "3", "--warmup", "1", "--runs", "1", "--source",
                     "testsrc", "--pipeline", "camera", "--out",
                     str(tmp_path), "-q"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("glass-to-pose latency, ms")
    row = [ln for ln in out if ln.startswith("camera ")]
    assert len(row) == 1 and "160x120 testsrc" in row[0]
    assert row[0].split()[-1] == "0/3"


def test_stand_in_replaces_only_the_camera_and_the_window(tmp_path):
    files = type("Files", (), {"width": 320, "height": 240,
                               "png_pattern": "f%d.png",
                               "variables": {"PALETTE": "p.json",
                                             "MAP": "m.json",
                                             "CAMERA": "c.yml"}})()
    mjpeg = latencybench.live_launch("camera-mjpeg", "testsrc", files, 5)
    assert mjpeg.startswith(
        "videotestsrc is-live=true num-buffers=5 ! video/x-raw,width=320,"
        "height=240,framerate=30/1 ! jpegenc name=standin ! image/jpeg,")
    assert "! jpegdec ! videoconvert ! labsegment palette=p.json" in mjpeg
    assert mjpeg.endswith("! fakesink name=glass sync=true")
    yuy2 = latencybench.live_launch("camera", "scene", files, 5)
    assert ("imagefreeze is-live=true num-buffers=5 ! video/x-raw,"
            "format=YUY2,width=320,height=240,framerate=30/1 ! labsegment"
            in yuy2)
    assert "calibration=c.yml map=m.json" in yuy2
    assert "v4l2src" not in yuy2 + mjpeg and "${" not in yuy2 + mjpeg


def test_file_throughput_against_the_decoder_alone(gst, tmp_path, capsys):
    report = tmp_path / "file.json"
    assert cli.main(["bench", "file", "--size", "160x120", "--frames", "10",
                     "--runs", "1", "--out", str(tmp_path / "files"),
                     "--json", str(report), "-q"]) == 0
    rows = json.loads(report.read_text())["rows"]
    assert [r["pipeline"] for r in rows] == [
        "jpegdec alone", "regression.pipeline", "file.pipeline"]
    for r in rows:
        assert r["frames"] == 10 and r["fps"] > 0 and r["cpu_ms_per_frame"] > 0
        assert r["fps_range"][0] <= r["fps"] <= r["fps_range"][1]
    # file.pipeline wrote its log and overlay for every frame
    log = tmp_path / "files" / "160x120" / "log.jsonl"
    assert len(log.read_text().splitlines()) == 10
    assert "MJPEG AVI throughput" in capsys.readouterr().out
