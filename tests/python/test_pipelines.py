"""Every shipped pipelines/*.pipeline runs to EOS.

- Pipelines of labsegment alone run on a clip generated here (12 frames
  at 160x120) with the built-in palette.
- Full-chain pipelines (they use ${MAP}) run on the shipped synthetic clip
  tests/files/clips/path-small (45 frames, 320x240) with its palette and
  map, and a camera file written here from its scene.json with
  ``calibrate.write_camera_file``; their outputs are checked.
- Live pipelines: no camera and no display exist here, so
  ``v4l2src device=${DEVICE}`` becomes a finite ``videotestsrc`` (followed
  by ``jpegenc`` where the camera gives image/jpeg) and ``autovideosink``
  a ``fakesink``; the rest of the line runs as shipped.
- network-send/network-receive run together on 127.0.0.1 and a free port.
"""

import json
import os
import re
import socket
import subprocess
import time

import numpy as np
import pytest

from gstlandmark import pipeline
from gstlandmark.gicompat import caps_structure
from gstlandmark.commands import calibrate
from gstlandmark.devtools import bench, goldens

from mqttbroker import (Broker, Subscriber, make_certificates,
                        needs_mosquitto, wait_for)

Gst = pipeline.Gst
PIPELINE_DIR = os.path.join(goldens.ROOT, "pipelines")
FILES = sorted(f for f in os.listdir(PIPELINE_DIR) if f.endswith(".pipeline"))
NETWORK = ("network-send.pipeline", "network-receive.pipeline")
PUBLISH = "publish.pipeline"
SINGLE = [f for f in FILES if f not in NETWORK and f != PUBLISH]
CLIP_FRAMES = 12
CHAIN_CLIP_DIR = os.path.join(goldens.ROOT, "tests", "files", "clips",
                              "path-small")
CHAIN_CLIP_FRAMES = 45
LIVE_FRAMES = 10


def video_info(path):
    """(frames, width, height) of a video file, decoded."""
    n = [0]
    size = [0, 0]

    def count(pad, buf):
        if n[0] == 0:
            s = caps_structure(pad.get_current_caps())
            size[:] = [s.get_value("width"), s.get_value("height")]
        n[0] += 1

    pipeline.run_to_eos(f"filesrc location={path} ! decodebin ! "
                        "fakesink name=sink", 30, count)
    return n[0], size[0], size[1]


def count_frames(path):
    return video_info(path)[0]


def without_devices(desc, frames):
    """The launch line with a finite test source for the camera (and
    jpegenc when the camera's caps are image/jpeg) and no display."""
    desc = re.sub(r"v4l2src\s+device=\$\{DEVICE\}(?=\s*!\s*image/jpeg)",
                  f"videotestsrc num-buffers={frames} ! jpegenc", desc)
    desc = re.sub(r"v4l2src\s+device=\$\{DEVICE\}",
                  f"videotestsrc num-buffers={frames}", desc)
    return desc.replace("autovideosink", "fakesink")


def header(path):
    with open(path) as f:
        return "".join(ln for ln in f if ln.lstrip().startswith("#"))


def variables_of(desc):
    return set(re.findall(r"\$\{([A-Z_]+)\}", desc))


@pytest.fixture(scope="module")
def chain_vars(tmp_path_factory):
    """Palette, map and camera file of the shipped synthetic clip: the
    camera file is what `gst-landmark calibrate floor` writes for the
    synthetic camera (intrinsics plus mounting)."""
    path = calibrate.scene_camera_file(
        os.path.join(CHAIN_CLIP_DIR, "scene.json"),
        tmp_path_factory.mktemp("camera") / "camera.yml")
    calibrate.read_camera_file(path)        # a valid camera file
    return {"PALETTE": os.path.join(CHAIN_CLIP_DIR, "palette.json"),
            "MAP": os.path.join(CHAIN_CLIP_DIR, "map.json"),
            "CAMERA": path}


def run_old(name, desc, tmp_path):
    """Pipelines of labsegment alone, as they were always tested."""
    clip = tmp_path / "input.avi"
    bench.write_clip(str(clip), 160, 120, CLIP_FRAMES)
    out_ext = ".jsonl" if "landmarklog location=${OUTPUT}" in desc else ".avi"
    output = tmp_path / f"output{out_ext}"
    desc = without_devices(desc, 10)
    run_file = tmp_path / name
    run_file.write_text(desc + "\n")
    palette = os.path.join(goldens.ROOT, "python", "gstlandmark", "data",
                           "default-palette.json")
    goldens.run_pipeline_file(str(run_file), {"INPUT": clip,
                                              "OUTPUT": output,
                                              "PALETTE": palette})
    expected = CLIP_FRAMES if "${INPUT}" in desc else 100
    for out in tmp_path.glob("*.avi"):
        if out.name != "input.avi":
            assert count_frames(str(out)) == expected, out
    if out_ext == ".jsonl":
        assert len(output.read_text().splitlines()) == expected


# What docs/pipelines.md says the full chain (trilaterate filter=ekf)
# does on the shipped clip, against its truth.jsonl: a pose on 44 of 45
# frames, median position error 3 mm, worst about 0.6 m (frames bridged on
# one landmark through a turn). The checks allow three times each error.
TRILATERATE_ON_CLIP = {"posed": 44, "median_m": 3 * 0.003, "max_m": 3 * 0.63}


def check_log(path, posed_min, median_m, max_m):
    lines = [json.loads(ln) for ln in path.read_text().splitlines()]
    assert len(lines) == CHAIN_CLIP_FRAMES
    assert [ln["frame"] for ln in lines] == list(range(CHAIN_CLIP_FRAMES))
    posed = [ln for ln in lines if ln.get("pose")]
    assert len(posed) >= posed_min, len(posed)
    with open(os.path.join(CHAIN_CLIP_DIR, "truth.jsonl")) as f:
        truth = {t["frame"]: t["robot"] for t in map(json.loads, f)}
    errors = sorted(((ln["pose"]["x"] - truth[ln["frame"]]["x"]) ** 2 +
                     (ln["pose"]["y"] - truth[ln["frame"]]["y"]) ** 2) ** 0.5
                    for ln in posed)
    print(f"{path.name}: {len(posed)} posed, median "
          f"{1000 * errors[len(errors) // 2]:.1f} mm, max "
          f"{1000 * errors[-1]:.1f} mm")
    assert errors[len(errors) // 2] <= median_m, errors
    assert errors[-1] <= max_m, errors


def camera_from_clip(desc):
    """A live line fed by the shipped clip, scaled to the camera's caps,
    instead of the camera (JPEG-encoded again where the camera gives
    MJPEG), and logging instead of showing: the rest of the line runs as
    shipped, on frames with a known truth (ipmrange scales the camera
    file's 320x240 intrinsics to the frame)."""
    scaled = ("filesrc location=${INPUT} ! decodebin ! videoconvert ! "
              "videoscale ! video/x-raw,width=640,height=480")
    desc, n = re.subn(r"v4l2src\s+device=\$\{DEVICE\}(?=\s*!\s*image/jpeg)",
                      scaled + " ! jpegenc", desc)
    if not n:
        desc, n = re.subn(r"v4l2src\s+device=\$\{DEVICE\}",
                          scaled + " ! videoconvert", desc)
    assert n == 1, desc
    assert "width=640,height=480" in desc.split("labsegment")[0], desc
    desc, n = re.subn(r"!\s*videoconvert\s*!\s*autovideosink\s*$",
                      "! landmarklog location=${LOG} ! fakesink", desc)
    assert n == 1, desc
    return desc


def rgb_frames(desc):
    """The frames a launch line gives, as RGB arrays."""
    frames = []
    for r in pipeline.iterate(desc + " ! videoconvert ! "
                              "video/x-raw,format=RGB", keep_buffers=True):
        ok, info = r.buffer.map(Gst.MapFlags.READ)
        assert ok
        rows = np.frombuffer(info.data, np.uint8).reshape(r.height, -1)
        frames.append(rows[:, :3 * r.width].reshape(r.height, r.width, 3)
                      .copy())
        r.buffer.unmap(info)
    return frames


# The dashboard's bird's-eye tile against the same chain and birdseye run
# alone on the same frames: mean absolute difference per frame (MJPEG at
# quality 85 costs 0.53 levels at most on the shipped clip without the
# drawings; the check allows three times).
BIRDSEYE_TILE_MAX_MEAN_DIFF = 3 * 0.53
BIRDSEYE_DRAW = "draw=boundary+landmarks+robot"


def check_birdseye_tile(variables):
    """The top right tile of the dashboard is the floor seen from above
    with the chain's results drawn on it: birdseye after the same chain on
    the same 640x480 frames, and black below it."""
    dashboard = goldens.launch_line(os.path.join(PIPELINE_DIR,
                                                 "dashboard.pipeline"))
    assert BIRDSEYE_DRAW in dashboard
    tiles = rgb_frames(f"filesrc location={variables['OUTPUT']} ! "
                       "decodebin")
    scaled = (f"filesrc location={variables['INPUT']} ! decodebin ! "
              "videoconvert ! videoscale ! video/x-raw,width=640,height=480")
    birdseye = (f"videoconvert ! birdseye calibration={variables['CAMERA']} "
                "pixels-per-metre=120 forward=4 side=2")
    alone = rgb_frames(
        f"{scaled} ! labsegment palette={variables['PALETTE']} "
        f"min-class-pixels=50 ! floorboundary "
        f"calibration={variables['CAMERA']} ! blobroundness min-area=30 ! "
        f"ipmrange calibration={variables['CAMERA']} map={variables['MAP']} "
        f"! trilaterate map={variables['MAP']} filter=ekf ! {birdseye} "
        f"map={variables['MAP']} {BIRDSEYE_DRAW}")
    plain = rgb_frames(f"{scaled} ! {birdseye}")
    assert len(tiles) == len(alone) == len(plain) == CHAIN_CLIP_FRAMES
    assert alone[0].shape == (480, 480, 3)
    worst = 0.0
    for dash, want, remap in zip(tiles, alone, plain):
        # the floor fills much of the view: a blank tile would pass else
        assert (remap.max(axis=2) > 16).mean() > 0.3
        # the robot: a white triangle standing on the camera's floor
        # point, output pixel (239.5, 479.5), pointing up
        assert want[474, 239:241].min() > 230
        assert remap[474, 239:241].max() < 200
        diff = np.abs(dash[:480, 1280:].astype(int) - want.astype(int))
        worst = max(worst, float(diff.mean()))
        assert dash[480:, 1280:].max() < 24     # nothing below it
    print(f"bird's-eye tile: worst mean difference {worst:.2f}")
    assert worst <= BIRDSEYE_TILE_MAX_MEAN_DIFF


@pytest.mark.parametrize("name", SINGLE)
def test_pipeline_runs(gst, name, tmp_path, monkeypatch, chain_vars):
    monkeypatch.chdir(tmp_path)
    path = os.path.join(PIPELINE_DIR, name)
    desc = goldens.launch_line(path)
    if "${MAP}" not in desc:
        run_old(name, desc, tmp_path)
        return
    if "${DEVICE}" in desc:
        desc = camera_from_clip(desc)
    # regression.pipeline writes its log to OUTPUT
    log_only = "landmarklog location=${OUTPUT}" in desc
    variables = dict(chain_vars,
                     INPUT=os.path.join(CHAIN_CLIP_DIR, "clip.avi"),
                     OUTPUT=tmp_path / ("log.jsonl" if log_only
                                        else "output.avi"),
                     LOG=tmp_path / "log.jsonl")
    run_file = tmp_path / name
    run_file.write_text(desc + "\n")
    goldens.run_pipeline_file(str(run_file), variables, timeout_s=60)
    if "${OUTPUT}" in desc and not log_only:
        frames, width, height = video_info(str(variables["OUTPUT"]))
        assert frames == CHAIN_CLIP_FRAMES
        if name == "dashboard.pipeline":
            assert (width, height) == (1760, 960)
            check_birdseye_tile(variables)
        else:
            assert (width, height) == (320, 240)
    if "landmarkslam" in desc:
        # landmarkslam waits for two landmarks in view before its first
        # pose (frames 0-16 of this clip see one): 28 of 45 when written;
        # docs/pipelines.md: path error median 1.5 mm, worst 6.2 mm
        check_log(variables["LOG"], posed_min=28, median_m=3 * 0.0015,
                  max_m=3 * 0.0062)
    elif "${LOG}" in desc or log_only:
        check_log(variables["LOG"], posed_min=TRILATERATE_ON_CLIP["posed"],
                  median_m=TRILATERATE_ON_CLIP["median_m"],
                  max_m=TRILATERATE_ON_CLIP["max_m"])


def free_udp_port():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_network_pair(gst, tmp_path, chain_vars):
    """The receiver gets the sender's frames over UDP on 127.0.0.1."""
    send = goldens.launch_line(os.path.join(PIPELINE_DIR, NETWORK[0]))
    receive = goldens.launch_line(os.path.join(PIPELINE_DIR, NETWORK[1]))
    assert "host=127.0.0.1" in send and "port=${PORT}" in send
    frames = 30
    port = free_udp_port()
    rx = Gst.parse_launch(
        receive.replace("${PORT}", str(port))
        .replace("autovideosink", "fakesink name=sink sync=false"))
    got = []

    def probe(pad, info):
        s = caps_structure(pad.get_current_caps())
        got.append((s.get_value("width"), s.get_value("height")))
        return Gst.PadProbeReturn.OK

    rx.get_by_name("sink").get_static_pad("sink").add_probe(
        Gst.PadProbeType.BUFFER, probe)
    try:
        assert rx.set_state(Gst.State.PLAYING) != \
            Gst.StateChangeReturn.FAILURE
        run_file = tmp_path / NETWORK[0]
        run_file.write_text(without_devices(send, frames) + "\n")
        goldens.run_pipeline_file(str(run_file), dict(chain_vars, PORT=port),
                                  timeout_s=30)
        deadline = time.monotonic() + 5
        while len(got) < frames and time.monotonic() < deadline:
            msg = rx.get_bus().timed_pop_filtered(
                50 * Gst.MSECOND, Gst.MessageType.ERROR)
            assert msg is None, msg.parse_error()
    finally:
        rx.set_state(Gst.State.NULL)
    # loopback loses nothing in practice; allow a few late frames
    assert len(got) >= frames - 5, len(got)
    assert set(got) == {(640, 480)}


def test_every_file_is_tested():
    assert set(FILES) == set(SINGLE) | set(NETWORK) | {PUBLISH}
    for name in NETWORK + (PUBLISH,):
        assert name in FILES


@pytest.mark.parametrize("name", FILES)
def test_documented(name):
    """Each file says what it does and names every variable it uses; the
    full-chain files are in docs/pipelines.md's table with their
    variables."""
    path = os.path.join(PIPELINE_DIR, name)
    desc = goldens.launch_line(path)
    text = header(path)
    assert text.strip(), f"{name}: no comment"
    for var in variables_of(desc):
        assert var in text, f"{name}: {var} not explained in its comment"
    if "${MAP}" in desc or name in NETWORK:
        with open(os.path.join(goldens.ROOT, "docs", "pipelines.md")) as f:
            rows = [ln for ln in f if ln.startswith(f"| `{name}`")]
        assert len(rows) == 1, f"{name}: not in docs/pipelines.md"
        for var in variables_of(desc):
            assert var in rows[0], f"{name}: {var} not in docs/pipelines.md"


@needs_mosquitto
def test_publish_pipeline(gst, tmp_path, chain_vars):
    """publish.pipeline with a finite test source for the camera sends
    every frame, in order, over TLS to a broker the test starts with
    certificates made here, and the robot's online and offline status."""
    desc = goldens.launch_line(os.path.join(PIPELINE_DIR, PUBLISH))
    assert "tls-ca-file=${BROKER_CA}" in desc
    ca, cert, key = make_certificates(tmp_path, "publish")
    broker = Broker(tmp_path, tls=(ca, cert, key)).start()
    try:
        sub = Subscriber(broker, ca=ca)
        try:
            run_file = tmp_path / PUBLISH
            run_file.write_text(without_devices(desc, LIVE_FRAMES) + "\n")
            goldens.run_pipeline_file(
                str(run_file), dict(chain_vars, HOST="127.0.0.1",
                                    PORT=broker.port, BROKER_CA=ca,
                                    ROBOT="r7"), timeout_s=60)
            assert wait_for(lambda: any(
                t == "landmark/r7/status" and b'"offline"' in p
                for t, p, _ in sub.take()), 10)
        finally:
            sub.close()
    finally:
        broker.stop()
    got = sub.take()
    frames = [json.loads(p) for t, p, _ in got if t == "landmark/r7/frame"]
    assert [f["frame"] for f in frames] == list(range(LIVE_FRAMES))
    with open(chain_vars["PALETTE"]) as f:
        names = [c["name"] for c in json.load(f)["classes"]]
    for f in frames:
        assert f["robot"] == "r7"
        assert (f["width"], f["height"]) == (640, 480)
        assert f["labels"]["classes"] == names
        # the histogram of every pixel of the frame went out
        assert sum(f["labels"]["counts"]) == 640 * 480
    statuses = [json.loads(p)["status"] for t, p, _ in got
                if t == "landmark/r7/status"]
    assert statuses == ["online", "offline"]


def test_plain_gst_launch(gst, tmp_path, chain_vars):
    """file.pipeline with plain gst-launch-1.0, the way docs/pipelines.md
    says (the shell substitutes the variables)."""
    env = dict(os.environ, INPUT=os.path.join(CHAIN_CLIP_DIR, "clip.avi"),
               OUTPUT=str(tmp_path / "overlay.avi"),
               LOG=str(tmp_path / "log.jsonl"), **chain_vars)
    path = os.path.join(PIPELINE_DIR, "file.pipeline")
    cmd = f"eval \"gst-launch-1.0 -q -e $(grep -v '^#' {path})\""
    res = subprocess.run(["bash", "-c", cmd], env=env, timeout=60,
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    assert count_frames(str(tmp_path / "overlay.avi")) == CHAIN_CLIP_FRAMES
    assert len((tmp_path / "log.jsonl").read_text().splitlines()) == \
        CHAIN_CLIP_FRAMES
