"""GStreamer's analytics metadata beside ours (GStreamer >= 1.24,
docs/metadata.md): the stock objectdetectionoverlay draws our detections
on the markers, Python reads the relation meta (boxes, classes, tracking,
segmentation), and it survives tee, queue, videoconvert and videoscale.
Skipped when the build did not find gstreamer-analytics-1.0."""

import math
import os

import numpy as np
import pytest

from gstlandmark import meta, pipeline

import shippedclip as C
from test_blobroundness import COLOURS, antialiased, ellipse
from test_meta_transforms import run_branches

Gst = pipeline.Gst


def _build_has_analytics():
    Gst.init(None)
    factory = Gst.ElementFactory.find("labsegment")
    plugin = factory.get_plugin() if factory else None
    root = os.environ.get("LANDMARK_BUILD_ROOT")
    if not root and plugin is not None:   # plugins/landmark/libgst*.so
        root = os.path.dirname(os.path.dirname(os.path.dirname(
            os.path.realpath(plugin.get_filename()))))
    try:
        with open(os.path.join(root or "", "config.h")) as f:
            return "#define HAVE_GST_ANALYTICS 1" in f.read()
    except OSError:
        return False


if not _build_has_analytics():
    pytest.skip("built without gstreamer-analytics-1.0 (GStreamer < 1.24 or "
                "no libgstreamer-plugins-bad1.0-dev): no analytics metadata",
                allow_module_level=True)
if meta.GstAnalytics is None:
    pytest.skip("no GstAnalytics typelib (gir1.2-gst-plugins-bad-1.0)",
                allow_module_level=True)

ORIENTED = hasattr(meta.GstAnalytics.ODMtd, "get_oriented_location")
W, H = 320, 240
CAPS = f"video/x-raw,format=RGB,width={W},height={H},framerate=30/1"
# (class, centre, full axes, angle in degrees): two slanted discs
MARKERS = [("red", (90.0, 110.0), (70.0, 34.0), 25.0),
           ("blue", (225.0, 130.0), (56.0, 40.0), -40.0)]


def marker_frame():
    return antialiased(W, H, [(COLOURS[name], ellipse(c[0], c[1], a, b, ang))
                              for name, c, (a, b), ang in MARKERS])


def expected_boxes(centre, axes, angle_deg):
    """Where a marker's box may be drawn, as (cx, cy, half w, half h,
    turn): on >= 1.26 the ellipse's axes turned by its angle, or the
    upright box around that (objectdetectionoverlay 1.26.2 draws the
    latter); on 1.24 the ellipse's upright bounding box."""
    (cx, cy), (a, b) = centre, axes
    t = math.radians(angle_deg)
    c, s = abs(math.cos(t)), abs(math.sin(t))
    if ORIENTED:
        return [(cx, cy, a / 2, b / 2, t),
                (cx, cy, a / 2 * c + b / 2 * s, a / 2 * s + b / 2 * c, 0.0)]
    return [(cx, cy, math.hypot(a / 2 * c, b / 2 * s),
             math.hypot(a / 2 * s, b / 2 * c), 0.0)]


def outline_drawn(drawn, box):
    """Whether pixels are drawn all round a box's outline."""
    cx, cy, hw, hh, t = box
    for s in np.linspace(-0.9, 0.9, 7):
        for u, v in ((s * hw, -hh), (s * hw, hh), (-hw, s * hh),
                     (hw, s * hh)):
            x0 = int(round(cx + u * math.cos(t) - v * math.sin(t)))
            y0 = int(round(cy + u * math.sin(t) + v * math.cos(t)))
            if not drawn[max(0, y0 - 2):y0 + 3, max(0, x0 - 2):x0 + 3].any():
                return False
    return True


def edge_distance(xs, ys, box):
    """Distance of points to the outline of a (turned) rectangle."""
    cx, cy, hw, hh, t = box
    u = (xs - cx) * math.cos(t) + (ys - cy) * math.sin(t)
    v = -(xs - cx) * math.sin(t) + (ys - cy) * math.cos(t)
    du, dv = np.abs(u) - hw, np.abs(v) - hh
    outside = np.hypot(np.maximum(du, 0), np.maximum(dv, 0))
    inside = np.minimum(-du, -dv)
    return np.where((du > 0) | (dv > 0), outside, inside)


def rgb(buf):
    ok, info = buf.map(Gst.MapFlags.READ)
    assert ok
    try:
        return np.frombuffer(info.data, np.uint8,
                             count=W * H * 3).reshape(H, W, 3).copy()
    finally:
        buf.unmap(info)


def test_objectdetectionoverlay_draws_boxes_on_the_markers(gst):
    if Gst.ElementFactory.find("objectdetectionoverlay") is None:
        pytest.skip("no objectdetectionoverlay (gstreamer1.0-plugins-bad)")
    frame = marker_frame()
    out = pipeline.process_frames(
        "labsegment min-class-pixels=0 ! blobroundness ! videoconvert ! "
        "objectdetectionoverlay draw-labels=false ! videoconvert ! "
        f"video/x-raw,format=RGB,width={W},height={H}", [frame], CAPS)
    drawn = np.any(rgb(out[0]) != frame, axis=2)
    ys, xs = np.nonzero(drawn)
    assert len(xs) > 200, "objectdetectionoverlay drew nothing"
    for way in range(2 if ORIENTED else 1):
        boxes = [expected_boxes(c, axes, ang)[way]
                 for _, c, axes, ang in MARKERS]
        near = np.min([edge_distance(xs, ys, b) for b in boxes], axis=0)
        # every drawn pixel on an expected outline, every outline drawn
        if np.mean(near <= 3) > 0.97 and all(outline_drawn(drawn, b)
                                             for b in boxes):
            return
    pytest.fail(f"boxes drawn off the markers: {len(xs)} pixels, distance "
                f"to the outlines p50/p95 {np.percentile(near, [50, 95])}")


def test_relation_meta_read_from_python(gst):
    frame = marker_frame()
    buf = pipeline.process_frames(
        "labsegment min-class-pixels=0 ! blobroundness", [frame], CAPS)[0]
    objects = meta.analytics(buf)
    assert objects is not None
    assert sorted(o.class_name for o in objects) == ["blue", "red"]
    for o in objects:
        name, (cx, cy), (a, b), ang = next(m for m in MARKERS
                                           if m[0] == o.class_name)
        x, y, w, h = o.box
        assert abs(x + w / 2 - cx) <= 1 and abs(y + h / 2 - cy) <= 1
        if ORIENTED:
            assert abs(w - a) <= 2 and abs(h - b) <= 2, o
            turn = (o.rotation - math.radians(ang)) % math.pi
            assert min(turn, math.pi - turn) < 0.05, o
        assert 0.9 <= o.class_confidence <= 1.0
        assert o.tracking_id is None        # no trilaterate, no match
    if ORIENTED:
        plane, names = meta.analytics_segmentation(buf)
        np.testing.assert_array_equal(plane, meta.labels(buf).plane)
        assert names[0] == "unclassified"
        assert names[1:] == [c.name for c in meta.labels(buf).classes]


def tracking_id(landmark):
    """docs/metadata.md: a decimal landmark id as it is, any other by its
    64-bit FNV-1a hash."""
    if landmark.isdigit():
        return int(landmark)
    h = 14695981039346656037
    for byte in landmark.encode():
        h = ((h ^ byte) * 1099511628211) % (1 << 64)
    return h


def test_tracking_entries_name_the_matched_landmarks(gst):
    chain = (f"labsegment palette={C.CLIP_DIR}/palette.json ! blobroundness "
             f"! ipmrange {C.camera_props()} ! trilaterate "
             f"map={C.CLIP_DIR}/map.json")
    tracked = 0
    for r in pipeline.run_file(os.path.join(C.CLIP_DIR, "clip.avi"), chain,
                               keep_buffers=True):
        objects = meta.analytics(r.buffer)
        kept = [d for d in r.detections if d.params["landmark-blob"]["kept"]
                and d.params.get("landmark-range", {}).get("kept", True)
                and d.params.get("landmark-match", {}).get("matched")]
        for det in kept:
            landmark = det.params["landmark-match"]["landmark-id"]
            mine = [o for o in objects if o.class_name == det.class_name
                    and o.tracking_id is not None]
            assert mine, (r.frame, landmark)
            assert tracking_id(landmark) in [o.tracking_id for o in mine]
            tracked += 1
    assert tracked > 0, "no frame of the clip matched a landmark"


def test_relation_meta_survives_tee_queue_convert_and_scale(gst):
    bufs = run_branches(marker_frame(), CAPS, {
        "same": "blobroundness",
        "converted": "blobroundness ! videoconvert ! "
                     "video/x-raw,format=BGRx",
        "scaled": f"blobroundness ! videoscale ! "
                  f"video/x-raw,width={W // 2},height={H // 2}",
    })
    got = {name: sorted(meta.analytics(buf), key=lambda o: o.class_name)
           for name, buf in bufs.items()}
    same = got["same"]
    assert len(same) == 2
    assert got["converted"] == same
    scaled = got["scaled"]
    assert [o.class_name for o in scaled] == [o.class_name for o in same]
    for s, o in zip(scaled, same):
        assert all(abs(sv - ov / 2) <= 1 for sv, ov in zip(s.box, o.box)), \
            (s.box, o.box)
