"""landmarkoverlay on the shipped synthetic clip: detections made by hand
from the clip's ground truth (region-of-interest metas with landmark-blob,
landmark-range and landmark-match parameters, as the detector elements
will write them), labels from labsegment. The overlay's output is compared
with the same frames without it: pixels change on each detection's
outline and in the class inset, nowhere inside the detections, and not at
all when every part is switched off.

(Python cannot write a custom meta's fields, so the pose line and the
mini-map are tested from C, in tests/check/elements/landmarkoverlay.c.)
The floor boundary is tested behind the real floorboundary, on its
ray-cast box frame: red on the rows the floor meta gives."""

import json
import math
import os

import numpy as np
import pytest

import gi

gi.require_version("Gst", "1.0")
gi.require_version("GstVideo", "1.0")
from gi.repository import Gst, GstVideo  # noqa: E402

from gstlandmark.gicompat import caps_structure  # noqa: E402

CLIP = os.path.join(os.path.dirname(__file__), "..", "files", "clips",
                    "path-small")
N_FRAMES = 45
TIMEOUT = 20 * Gst.SECOND
ALL_OFF = ("show-detections=false show-pose=false show-histogram=false "
           "show-indicators=false show-minimap=false")


@pytest.fixture(scope="module")
def clip(gst):
    """The first frames of the clip as BGR arrays, with their truth."""
    desc = (f"filesrc location={CLIP}/clip.avi ! avidemux ! jpegdec ! "
            "videoconvert ! video/x-raw,format=BGR ! "
            "appsink name=sink sync=false")
    pipe = Gst.parse_launch(desc)
    sink = pipe.get_by_name("sink")
    pipe.set_state(Gst.State.PLAYING)
    frames = []
    try:
        while len(frames) < N_FRAMES:
            sample = sink.emit("try-pull-sample", TIMEOUT)
            assert sample is not None, "clip did not decode"
            caps = caps_structure(sample.get_caps())
            w, h = caps.get_value("width"), caps.get_value("height")
            info = GstVideo.VideoInfo.new_from_caps(sample.get_caps())
            buf = sample.get_buffer()
            ok, m = buf.map(Gst.MapFlags.READ)
            assert ok
            rows = np.frombuffer(m.data, np.uint8).reshape(h, info.stride[0])
            frames.append(rows[:, :w * 3].reshape(h, w, 3).copy())
            buf.unmap(m)
    finally:
        pipe.set_state(Gst.State.NULL)
    with open(os.path.join(CLIP, "truth.jsonl")) as f:
        truth = [json.loads(line) for line in f][:N_FRAMES]
    return frames, truth


def visible(truth_frame):
    """Landmarks whole in view and large enough to draw around."""
    return [lm for lm in truth_frame["landmarks"]
            if not lm["cut"] and not lm["occluded"] and lm["pixels"] >= 60]


def disc(lm):
    """The detection made for a landmark: a circle around its centre,
    somewhat larger than the marker (markers are small at 320x240):
    (cx, cy, r)."""
    return (lm["u_centre"], lm["v_centre"],
            max(16.0, 1.5 * math.sqrt(lm["pixels"] / math.pi)))


def add_detections(buf, lms):
    for lm in lms:
        cx, cy, r = disc(lm)
        x0, y0 = max(0, math.floor(cx - r)), max(0, math.floor(cy - r))
        roi = GstVideo.buffer_add_video_region_of_interest_meta(
            buf, lm["class"], x0, y0, math.ceil(2 * r) + 1,
            math.ceil(2 * r) + 1)
        roi.add_param(Gst.Structure.new_from_string(
            f"landmark-blob, class=(string){lm['class']}, "
            f"ellipse-x=(double){cx}, ellipse-y=(double){cy}, "
            f"ellipse-major=(double){2 * r}, ellipse-minor=(double){2 * r}, "
            "ellipse-angle=(double)0.0, roundness=(double)0.9, "
            "kept=(boolean)true, frame-width=(uint)320, "
            "frame-height=(uint)240"))
        roi.add_param(Gst.Structure.new_from_string(
            f"landmark-range, range=(double){lm['range']}, "
            f"bearing=(double){lm['bearing']}, method=(string)ground"))
        roi.add_param(Gst.Structure.new_from_string(
            "landmark-match, matched=(boolean)true, "
            f"landmark-id=(string){lm['id']}"))


def run(chain, frames, truth=None):
    """Pushes the frames through appsrc ! chain ! appsink, with the
    truth's detections attached when given; returns BGR arrays."""
    h, w, _ = frames[0].shape
    caps = f"video/x-raw,format=BGR,width={w},height={h},framerate=30/1"
    pipe = Gst.parse_launch(
        f"appsrc name=src format=time caps={caps} ! {chain} ! "
        "appsink name=sink sync=false")
    src, sink = pipe.get_by_name("src"), pipe.get_by_name("sink")
    stride = GstVideo.VideoInfo.new_from_caps(
        Gst.Caps.from_string(caps)).stride[0]
    out = []
    pipe.set_state(Gst.State.PLAYING)
    try:
        for i, img in enumerate(frames):
            rows = np.zeros((h, stride), np.uint8)
            rows[:, :w * 3] = img.reshape(h, w * 3)
            buf = Gst.Buffer.new_wrapped(rows.tobytes())
            buf.pts = i * Gst.SECOND // 30
            if truth is not None:
                add_detections(buf, visible(truth[i]))
            src.emit("push-buffer", buf)
        src.emit("end-of-stream")
        for _ in frames:
            sample = sink.emit("try-pull-sample", TIMEOUT)
            if sample is None:
                msg = pipe.get_bus().pop_filtered(Gst.MessageType.ERROR)
                detail = msg.parse_error()[0].message if msg else "timeout"
                pytest.fail(f"{chain}: {detail}")
            b = sample.get_buffer()
            ok, m = b.map(Gst.MapFlags.READ)
            data = np.frombuffer(m.data, np.uint8).reshape(h, stride)
            out.append(data[:, :w * 3].reshape(h, w, 3).copy())
            b.unmap(m)
    finally:
        pipe.set_state(Gst.State.NULL)
    return out


def segment():
    return f"labsegment palette={CLIP}/palette.json min-class-pixels=60"


def test_registered(gst):
    factory = Gst.ElementFactory.find("landmarkoverlay")
    assert factory is not None
    assert factory.get_metadata("klass") == "Filter/Effect/Video"
    e = factory.create(None)
    for name in ("show-detections", "show-rejected", "show-pose",
                 "show-histogram", "show-indicators", "show-minimap",
                 "show-boundary", "show-free-space"):
        assert e.get_property(name) is True, name
    assert e.get_property("map") is None
    assert e.get_property("text-scale") == 1.0
    caps = factory.get_static_pad_templates()[0].get_caps()
    formats = caps_structure(caps).get_value("format")
    assert set(formats) == {"RGB", "BGR", "RGBx", "BGRx", "xRGB", "xBGR",
                            "RGBA", "BGRA", "I420", "NV12", "YUY2"}


def test_draws_at_each_detection(gst, clip):
    frames, truth = clip
    ref = run(segment(), frames, truth)
    got = run(f"{segment()} ! landmarkoverlay show-histogram=false "
              "show-indicators=false", frames, truth)
    seen = alone = 0
    for i, (a, b) in enumerate(zip(ref, got)):
        changed = (a != b).any(axis=2)
        h, w = changed.shape
        yy, xx = np.mgrid[0:h, 0:w]
        for lm in visible(truth[i]):
            cx, cy, r = disc(lm)
            seen += 1
            t = np.linspace(0, 2 * math.pi, 48, endpoint=False)
            ox = np.rint(cx + r * np.cos(t)).astype(int)
            oy = np.rint(cy + r * np.sin(t)).astype(int)
            inside = (ox >= 0) & (ox < w) & (oy >= 0) & (oy < h)
            on_outline = changed[oy[inside], ox[inside]].mean()
            assert on_outline >= 0.8, (i, lm["id"], on_outline)
            # inside the disc, away from the outline and the centre mark,
            # unless another detection's label may lie there
            if any(o is not lm and math.hypot(disc(o)[0] - cx,
                                              disc(o)[1] - cy) < 120
                   for o in visible(truth[i])):
                continue
            alone += 1
            dist = np.hypot(xx - cx, yy - cy)
            ring = (dist < 0.6 * r) & (dist > 6)
            assert not changed[ring].any(), (i, lm["id"])
    assert seen >= 40 and alone >= 10, (seen, alone)


def test_class_inset(gst, clip):
    """With the labels meta of labsegment: the class inset at the top left
    (without any metadata nothing changes: test_no_metadata_no_change)."""
    frames, truth = clip
    ref = run(segment(), frames)
    got = run(f"{segment()} ! landmarkoverlay", frames)
    for i, (a, b) in enumerate(zip(ref, got)):
        changed = (a != b).any(axis=2)
        h, w = changed.shape
        assert changed[:h // 4, :w // 4].mean() > 0.5, i
        assert not changed[h // 2:].any(), i


def test_every_part_off_is_byte_identical(gst, clip):
    frames, truth = clip
    ref = run(segment(), frames, truth)
    got = run(f"{segment()} ! landmarkoverlay {ALL_OFF}", frames, truth)
    for a, b in zip(ref, got):
        assert np.array_equal(a, b)


def test_no_metadata_no_change(gst, clip):
    frames, _ = clip
    got = run("landmarkoverlay", frames[:3])
    for a, b in zip(frames, got):
        assert np.array_equal(a, b)


def test_floor_boundary_behind_floorboundary(gst):
    from gstlandmark import meta, pipeline
    from test_floorboundary import CHAIN, H, W, render

    rgb, _ = render()
    caps = f"video/x-raw,format=RGB,width={W},height={H},framerate=30/1"
    drawn, plain = (pipeline.process_frames(
        f"{CHAIN} ! landmarkoverlay show-histogram=false "
        f"show-indicators=false show-minimap=false show-boundary={on}",
        [rgb], caps)[0] for on in ("true", "false"))
    fm = meta.floor(drawn)
    assert fm is not None and (fm.width, fm.height) == (W, H)

    def pixels(buf):
        ok, m = buf.map(Gst.MapFlags.READ)
        assert ok
        a = np.frombuffer(m.data, np.uint8)[:W * H * 3].reshape(H, W, 3)
        a = a.copy()
        buf.unmap(m)
        return a

    out, ref = pixels(drawn), pixels(plain)
    assert np.array_equal(ref, rgb)
    red = np.all(np.abs(out.astype(int) - (255, 40, 40)) <= 12, axis=2)
    # on each box column the boundary is the pixel edge between rows
    # k - 1 and k (row = k - 0.5): one of the two is red
    box = np.flatnonzero(fm.boundary_state == 2)
    assert len(box) > 150
    hits = 0
    for c in box[2:-2]:
        k = int(round(fm.boundary_row[c] + 0.5))
        hits += bool(red[k - 1:k + 1, c].any())
    print(f"box columns {len(box)}, red on the boundary in {hits}")
    assert hits == len(box) - 4
    # red only on the line: within 3 rows of the span of the boundary rows
    # of the obstacle columns within two of its own (where the line joins
    # two columns at different rows, and the line's width)
    edge = np.where(fm.boundary_state == 2, fm.boundary_row, np.nan)
    pad = np.pad(edge, 2, constant_values=np.nan)
    near = np.stack([pad[i:i + W] for i in range(5)])
    with np.errstate(all="ignore"):
        lo = np.nanmin(np.where(np.isnan(near), np.inf, near), axis=0)
        hi = np.nanmax(np.where(np.isnan(near), -np.inf, near), axis=0)
    ys, xs = np.nonzero(red)
    assert len(ys) > 0
    assert np.all((ys >= lo[xs] - 3) & (ys <= hi[xs] + 3))
