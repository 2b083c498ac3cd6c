"""landmarkslam writes its map on request while playing (the write-map
action signal, docs/landmarkslam.md): the file holds the confirmed
landmarks of the frame the estimate had reached, is replaced atomically
(a reader never sees half a file), and a path that cannot be written is a
warning naming it while the estimate goes on to EOS. On the shipped
synthetic clip (tests/files/clips/path-small, 45 frames), without a map.
Also landmarkoverlay behind it: the mini-map shows the estimate with no
map file set."""

import json
import os
import threading
import time

import pytest

from gstlandmark import meta, pipeline
from gstlandmark.gicompat import caps_structure
from gstlandmark.commands import calibrate

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
CLIP = os.path.join(ROOT, "tests", "files", "clips", "path-small")
FRAMES = 45
TIMEOUT_S = 60
# the frame the pipeline is held at while the application asks for the map
HOLD_AT = 40


@pytest.fixture(scope="module")
def camera(tmp_path_factory):
    return str(calibrate.scene_camera_file(
        os.path.join(CLIP, "scene.json"),
        tmp_path_factory.mktemp("camera") / "camera.yml"))


def chain(camera, slam, tail="fakesink name=sink"):
    return (f"filesrc location={CLIP}/clip.avi ! decodebin ! videoconvert ! "
            f"labsegment palette={CLIP}/palette.json min-class-pixels=50 ! "
            f"blobroundness min-area=30 ! ipmrange calibration={camera} "
            f"map={CLIP}/map.json ! {slam} ! {tail}")


class Held:
    """Runs a launch line, holding the streaming thread after landmarkslam
    at frame HOLD_AT (a blocking pad probe) until release(); records the
    map meta of every frame and the bus's warnings."""

    def __init__(self, desc):
        pipeline.init()
        Gst = self.Gst = pipeline.Gst
        self.pipe = Gst.parse_launch(desc)
        self.slam = self.pipe.get_by_name("slam")
        self.maps, self.poses = [], 0
        self.held, self.go = threading.Event(), threading.Event()

        def probe(pad, info):
            buf = info.get_buffer()
            self.maps.append(meta.landmark_map(buf))
            self.poses += meta.pose(buf) is not None
            if len(self.maps) == HOLD_AT:
                self.held.set()
                self.go.wait(TIMEOUT_S)
            return Gst.PadProbeReturn.OK
        self.slam.get_static_pad("src").add_probe(Gst.PadProbeType.BUFFER,
                                                  probe)
        self.pipe.set_state(Gst.State.PLAYING)
        assert self.held.wait(TIMEOUT_S), "the clip did not reach the hold"

    def release_and_finish(self):
        """Lets the stream go on to EOS; returns the warnings posted."""
        Gst = self.Gst
        self.go.set()
        warnings = []
        bus = self.pipe.get_bus()
        try:
            while True:
                msg = bus.timed_pop_filtered(
                    TIMEOUT_S * Gst.SECOND, Gst.MessageType.EOS |
                    Gst.MessageType.ERROR | Gst.MessageType.WARNING)
                assert msg is not None, "no EOS"
                if msg.type == Gst.MessageType.ERROR:
                    pytest.fail(msg.parse_error()[0].message)
                if msg.type == Gst.MessageType.WARNING:
                    err, dbg = msg.parse_warning()
                    warnings.append((msg.src, err, dbg))
                if msg.type == Gst.MessageType.EOS:
                    return warnings
        finally:
            self.pipe.set_state(Gst.State.NULL)


def confirmed(landmarks):
    return {m.id: (m.x, m.y) for m in landmarks if m.confirmed}


def written(path):
    with open(path) as f:
        return {lm["id"]: (lm["x"], lm["y"]) for lm in json.load(f)[
            "landmarks"]}


def test_write_map_while_playing(gst, camera, tmp_path):
    at_eos = tmp_path / "eos.json"
    now = tmp_path / "now.json"
    run = Held(chain(camera, f"landmarkslam name=slam map-out={at_eos}"))
    assert run.pipe.get_state(0)[1] == gst.State.PLAYING
    # the element is held after frame HOLD_AT: the map is that frame's
    assert run.slam.emit("write-map", str(now)) is True
    want = confirmed(run.maps[-1])
    assert want, "no confirmed landmark by the hold: a weak test"
    got = written(now)
    assert got.keys() == want.keys()
    for k, (x, y) in want.items():
        assert got[k] == pytest.approx((x, y), abs=1e-6)
    # without a path: map-out, now
    assert run.slam.emit("write-map", None) is True
    assert written(at_eos) == got
    assert run.release_and_finish() == []
    # and again at EOS, with the landmarks of the last frame
    assert written(at_eos).keys() == confirmed(run.maps[-1]).keys()
    assert len(run.maps) == FRAMES
    # nothing but the maps in the folder: the temporary files were renamed
    assert sorted(os.listdir(tmp_path)) == ["eos.json", "now.json"]


def test_a_reader_never_sees_half_a_map(gst, camera, tmp_path):
    """The map rewritten 300 times while another thread reads it as fast
    as it can: every read is a whole map (written to a temporary file and
    renamed over it)."""
    out = tmp_path / "map.json"
    run = Held(chain(camera, "landmarkslam name=slam"))
    assert run.slam.emit("write-map", str(out)) is True
    stop, reads, bad = threading.Event(), [0], []

    def reader():
        while not stop.is_set():
            text = out.read_text()
            reads[0] += 1
            try:
                assert len(json.loads(text)["landmarks"]) > 0
            except (ValueError, KeyError, AssertionError):
                bad.append(text)
    t = threading.Thread(target=reader)
    t.start()
    try:
        for _ in range(300):
            assert run.slam.emit("write-map", str(out)) is True
    finally:
        stop.set()
        t.join()
        run.release_and_finish()
    assert reads[0] > 50 and not bad, (reads[0], bad[:1])


def test_unwritable_path_is_a_warning_and_the_estimate_goes_on(gst, camera,
                                                              tmp_path):
    bad = tmp_path / "no-such-folder" / "map.json"
    at_eos = tmp_path / "eos.json"
    run = Held(chain(camera, f"landmarkslam name=slam map-out={at_eos}"))
    assert run.slam.emit("write-map", str(bad)) is False
    assert not bad.parent.exists()
    warnings = run.release_and_finish()
    assert len(warnings) == 1, warnings
    src, err, dbg = warnings[0]
    assert src.get_name() == "slam"
    assert err.matches(gst.ResourceError.quark(),
                       gst.ResourceError.OPEN_WRITE)
    assert str(bad) in err.message
    # every frame went through, with its map; the map was written at EOS
    assert len(run.maps) == FRAMES and all(m is not None for m in run.maps)
    assert run.poses >= 28    # as in test_pipelines: no pose before frame 17
    assert written(at_eos).keys() == confirmed(run.maps[-1]).keys()


def test_no_path_anywhere_is_a_warning(gst, camera):
    run = Held(chain(camera, "landmarkslam name=slam"))
    assert run.slam.emit("write-map", None) is False
    assert run.slam.emit("write-map", "") is False
    warnings = run.release_and_finish()
    assert len(warnings) == 2
    assert all("map-out" in err.message for _, err, _ in warnings)


def last_frame(desc):
    """The last frame reaching the sink, as an RGB array."""
    import numpy as np
    out = {}

    def keep(pad, buf):
        caps = caps_structure(pad.get_current_caps())
        w, h = caps.get_value("width"), caps.get_value("height")
        ok, m = buf.map(pipeline.Gst.MapFlags.READ)
        rows = np.frombuffer(m.data, np.uint8)[:h * w * 3]
        out["rgb"] = rows.reshape(h, w, 3).copy()
        buf.unmap(m)
    pipeline.run_to_eos(desc, TIMEOUT_S, keep)
    return out["rgb"]


OVERLAY = ("landmarkoverlay show-detections=false show-rejected=false "
           "show-pose=false show-histogram=false show-indicators=false "
           "show-boundary=false {} ! videoconvert ! "
           "video/x-raw,format=RGB,width=320,height=240 ! "
           "fakesink name=sink")


def test_overlay_draws_the_estimate_without_a_map_file(gst, camera):
    """Behind landmarkslam, with no map property, the mini-map is drawn
    (only in its top-right inset); behind trilaterate, which writes a pose
    but no map meta, it is not."""
    import numpy as np
    slam = "landmarkslam name=slam"
    plain = last_frame(chain(camera, slam, OVERLAY.format(
        "show-minimap=false")))
    drawn = last_frame(chain(camera, slam, OVERLAY.format("")))
    changed = np.any(drawn != plain, axis=2)
    ys, xs = np.nonzero(changed)
    assert len(ys) > 1000, len(ys)
    # the inset: 170 g square at the top right, g = 0.5 at 320x240
    assert xs.min() >= 320 - 4 - 85 and ys.max() < 4 + 85 + 1
    tri = f"trilaterate map={CLIP}/map.json"
    assert np.array_equal(
        last_frame(chain(camera, tri, OVERLAY.format(""))),
        last_frame(chain(camera, tri, OVERLAY.format("show-minimap=false"))))


def test_write_map_from_another_thread_while_frames_flow(gst, camera,
                                                         tmp_path):
    """Free running: a thread asks for the map to map-out as fast as it
    can while the stream goes to EOS. Nothing blocks, and the file left is
    the last frame's map, not an older snapshot written after it."""
    at_eos = tmp_path / "eos.json"
    pipeline.init()
    Gst = pipeline.Gst
    pipe = Gst.parse_launch(chain(
        camera, f"landmarkslam name=slam map-out={at_eos} "
        "post-messages=true", "fakesink name=sink sync=false"))
    slam = pipe.get_by_name("slam")
    maps = []
    stop, asked = threading.Event(), [0]

    def on_buffer(pad, info):
        maps.append(meta.landmark_map(info.get_buffer()))
        # the first frames wait for a few requests each, so the writes race
        # the stream however the machine's load schedules the two threads
        deadline = time.monotonic() + TIMEOUT_S
        while (len(maps) <= 5 and asked[0] < 3 * len(maps)
               and time.monotonic() < deadline):
            time.sleep(0.001)
        return Gst.PadProbeReturn.OK
    pipe.get_by_name("sink").get_static_pad("sink").add_probe(
        Gst.PadProbeType.BUFFER, on_buffer)

    def ask():
        while not stop.is_set():
            slam.emit("write-map", None)
            asked[0] += 1
    t = threading.Thread(target=ask)
    pipe.set_state(Gst.State.PLAYING)
    t.start()
    try:
        msg = pipe.get_bus().timed_pop_filtered(
            TIMEOUT_S * Gst.SECOND, Gst.MessageType.EOS |
            Gst.MessageType.ERROR)
        assert msg is not None, "blocked: no EOS"
        assert msg.type == Gst.MessageType.EOS, msg.parse_error()
    finally:
        stop.set()
        t.join(TIMEOUT_S)
        pipe.set_state(Gst.State.NULL)
    assert not t.is_alive() and asked[0] > 10, asked
    assert len(maps) == FRAMES
    # the writes raced the stream; the file is the newest estimate
    assert written(at_eos).keys() == confirmed(maps[-1]).keys()
