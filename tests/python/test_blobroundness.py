"""blobroundness after labsegment: drawn colour frames (shapes known
exactly), and a short rendered distractor clip scored against its ground
truth with gstlandmark.commands.evaluate."""

import json
import math

import cv2
import numpy as np
import pytest

from gstlandmark import meta, pipeline
from gstlandmark.commands.evaluate import evaluate, summary
from gstlandmark.landmarklog import read_jsonl

# exact sRGB colours of the built-in palette (docs: default-palette.json)
GREY = (128, 128, 128)
PINK = (255, 105, 180)
BLUE = (30, 80, 200)
COLOURS = {"red": (200, 40, 40), "green": (60, 190, 70),
           "yellow": (230, 220, 60), "pink": PINK, "blue": BLUE}

BLOB_FIELDS = {
    "class": str, "area": float, "perimeter": float, "roundness": float,
    "centroid-x": float, "centroid-y": float, "equivalent-diameter": float,
    "ellipse-x": float, "ellipse-y": float, "ellipse-major": float,
    "ellipse-minor": float, "ellipse-angle": float, "ellipse-fit": float,
    "ellipse-fit-threshold": float, "kept": bool, "frame-width": int,
    "frame-height": int,
}


def antialiased(width, height, shapes, ss=4):
    """RGB frame on grey; each shape (colour, draw(mask, scale)) drawn at
    ss x ss supersampling and averaged, like a rendered frame's edges."""
    big = np.zeros((height * ss, width * ss, 3), np.float64)
    big[:] = GREY
    for colour, draw in shapes:
        mask = np.zeros((height * ss, width * ss), np.uint8)
        draw(mask, ss)
        big[mask > 0] = colour
    small = big.reshape(height, ss, width, ss, 3).mean(axis=(1, 3))
    return np.clip(np.rint(small), 0, 255).astype(np.uint8)


def ellipse(cx, cy, a, b, angle_deg):
    """Filled ellipse, full axes a, b, centre in pixel-centre coordinates
    (pixel (u, v) of the frame covers [u-0.5, u+0.5]: at ss x ss the
    centre is at (cx + 0.5) * ss - 0.5)."""
    def draw(mask, ss):
        shift = 4
        c = (int(round(((cx + 0.5) * ss - 0.5) * (1 << shift))),
             int(round(((cy + 0.5) * ss - 0.5) * (1 << shift))))
        axes = (int(round(a * ss / 2 * (1 << shift))),
                int(round(b * ss / 2 * (1 << shift))))
        cv2.ellipse(mask, c, axes, angle_deg, 0, 360, 255, -1, cv2.LINE_8,
                    shift)
    return draw


def polygon(points):
    def draw(mask, ss):
        pts = np.array([[((x + 0.5) * ss - 0.5) * 16,
                         ((y + 0.5) * ss - 0.5) * 16] for x, y in points],
                       np.int32)
        cv2.fillPoly(mask, [pts], 255, cv2.LINE_8, 4)
    return draw


def rotated_rect(cx, cy, w, h, angle_deg):
    a = math.radians(angle_deg)
    c, s = math.cos(a), math.sin(a)
    pts = [(cx + c * x - s * y, cy + s * x + c * y)
           for x, y in ((-w / 2, -h / 2), (w / 2, -h / 2), (w / 2, h / 2),
                        (-w / 2, h / 2))]
    return polygon(pts)


def triangle(cx, cy, side, angle_deg):
    r = side / math.sqrt(3)
    a = math.radians(angle_deg)
    return polygon([(cx + r * math.cos(a + k * 2 * math.pi / 3),
                     cy + r * math.sin(a + k * 2 * math.pi / 3))
                    for k in range(3)])


SCENE = [
    # (name, colour, draw, is a landmark, centre)
    ("disc", BLUE, ellipse(100.3, 90.6, 40, 40, 0), True, (100.3, 90.6)),
    ("slanted disc", PINK, ellipse(250.2, 70.4, 64, 16, 12), True,
     (250.2, 70.4)),
    ("square", COLOURS["green"], rotated_rect(80, 190, 36, 36, 17), False,
     (80, 190)),
    ("slanted square", COLOURS["yellow"], rotated_rect(250, 180, 60, 14, -8),
     False, (250, 180)),
    ("stripe", COLOURS["red"], rotated_rect(170, 215, 120, 6, 3), False,
     (170, 215)),
    ("triangle", COLOURS["red"], triangle(160, 140, 40, 30), False,
     (160, 140)),
    ("ring", PINK, None, False, (40, 60)),
]


def scene_frame():
    shapes = [(colour, draw) for _, colour, draw, _, _ in SCENE if draw]

    def ring(mask, ss):
        c = (int(40.5 * ss - 0.5), int(60.5 * ss - 0.5))
        cv2.circle(mask, c, 22 * ss, 255, -1)
        cv2.circle(mask, c, 11 * ss, 0, -1)
    shapes.append((PINK, ring))
    return antialiased(321, 241, shapes)


CAPS = "video/x-raw,format=RGB,width=321,height=241,framerate=30/1"


def nearest(dets, centre):
    return min(dets, key=lambda d: math.hypot(
        d.blob["centroid-x"] - centre[0], d.blob["centroid-y"] - centre[1]))


def test_drawn_scene(gst):
    frame = scene_frame()
    out = pipeline.process_frames(
        "labsegment min-class-pixels=0 ! blobroundness", [frame] * 3, CAPS)
    for buf in out:
        dets = meta.detections(buf)
        assert [d.id for d in dets] == list(range(len(dets)))
        # near misses travel on for ipmrange's size test, rejected
        near = [d for d in dets if d.blob.get("shape-marginal")]
        assert all(not d.blob["kept"] for d in near)
        dets = [d for d in dets if d not in near]
        found = {name: nearest(dets, c) for name, _, _, landmark, c in SCENE
                 if landmark}
        assert len(dets) == 2, [(d.class_name, d.blob) for d in dets]
        assert found["disc"].class_name == "blue"
        assert found["slanted disc"].class_name == "pink"
        for name, _, _, landmark, centre in SCENE:
            if not landmark:
                continue
            blob = found[name].blob
            assert set(blob) == set(BLOB_FIELDS)
            for key, kind in BLOB_FIELDS.items():
                assert isinstance(blob[key], kind), key
            assert blob["kept"] is True
            assert math.hypot(blob["centroid-x"] - centre[0],
                              blob["centroid-y"] - centre[1]) < 0.3
            assert (blob["frame-width"], blob["frame-height"]) == (321, 241)
        disc = found["disc"].blob
        assert abs(disc["equivalent-diameter"] - 40) < 1
        assert disc["roundness"] > 0.9
        slanted = found["slanted disc"].blob
        assert abs(slanted["ellipse-major"] - 64) < 1
        assert abs(slanted["ellipse-minor"] - 16) < 1
        assert abs(slanted["ellipse-angle"] - math.radians(12)) < 0.03
        assert slanted["roundness"] < 0.85     # not a circle in the image


def test_rejected_shapes_and_reasons(gst):
    frame = scene_frame()
    for shape, reason in (("circle", "roundness"),
                          ("ellipse", "ellipse-fit")):
        (buf,) = pipeline.process_frames(
            f"labsegment min-class-pixels=0 ! blobroundness shape={shape} "
            "keep-rejected=true min-area=50", [frame], CAPS)
        dets = meta.detections(buf)
        for name, _, _, landmark, centre in SCENE:
            blob = nearest(dets, centre).blob
            if landmark and shape == "ellipse":
                assert blob["kept"], name
            elif not landmark:
                assert not blob["kept"], (name, shape, blob)
                assert blob["reject-reason"] in (reason, "aspect"), name
        # the slanted disc is no circle in the image
        if shape == "circle":
            assert not nearest(dets, SCENE[1][4]).blob["kept"]


def _cpu_has_avx2():
    try:
        with open("/proc/cpuinfo") as f:
            return any(line.startswith("flags") and " avx2" in line
                       for line in f)
    except OSError:
        return False


@pytest.mark.skipif(not _cpu_has_avx2(),
                    reason="the processor has no AVX2: best is SSE2")
def test_avx2_run_search_matches_sse2(gst, monkeypatch):
    """The run search's AVX2 path (the default where the processor has it)
    finds the blobs the SSE2 path finds (LANDMARK_SIMD=sse2), on a width
    that is no multiple of its 32-pixel steps, with discs cut by the last
    column and the last row and one only one pixel into the frame."""
    width, height = 161, 53
    frame = antialiased(width, height, [
        (BLUE, ellipse(150, 20, 30, 30, 0)),           # cut by the last column
        (PINK, ellipse(60, 47, 24, 24, 0)),            # cut by the last row
        (BLUE, ellipse(100, 10, 20, 12, 30)),
        (PINK, ellipse(12, 30, 14, 14, 0))])
    frame[:, -1] = BLUE                    # a stripe in the last column only
    frame[-1, 100] = PINK
    caps = (f"video/x-raw,format=RGB,width={width},height={height},"
            "framerate=30/1")
    chain = ("labsegment min-class-pixels=0 ! blobroundness min-area=1 "
             "keep-rejected=true")
    found = {}
    for level in ("sse2", "best"):
        monkeypatch.setenv("LANDMARK_SIMD", level)
        (buf,) = pipeline.process_frames(chain, [frame], caps)
        found[level] = sorted((d.class_name, d.bbox, d.blob["area"])
                              for d in meta.detections(buf))
    monkeypatch.delenv("LANDMARK_SIMD")
    assert found["best"] == found["sse2"]
    boxes = [bbox for _, bbox, _ in found["best"]]
    # the blobs reach the last column and the last row
    assert any(x + w == width for x, _, w, _ in boxes)
    assert any(y + h == height for _, y, _, h in boxes)
    assert ("pink", (100, height - 1, 1, 1), 1.0) in found["best"]


@pytest.fixture(scope="module")
def distractor_clip(tmp_path_factory, gst):
    from gstlandmark.synth import render_scenario
    out = tmp_path_factory.mktemp("distractors")
    # the scenario (seed 0), its first 12 frames
    render_scenario("distractors", str(out), seed=0, frames=12,
                    progress=False, robot="comfortable")
    return out


def run_clip(clip, props, log, ranged=False):
    """blobroundness alone, or with ipmrange (the scene's camera and map)
    adding the size evidence."""
    ranging = ""
    if ranged:
        with open(clip / "scene.json") as f:
            cam = json.load(f)["camera"]
        ranging = (f"ipmrange camera-height={cam['height_m']} "
                   f"tilt={cam['tilt_deg']} hfov={cam['hfov_deg']} "
                   f"map={clip / 'map.json'} ! ")
    desc = (f"filesrc location={clip / 'clip.avi'} ! avidemux ! jpegdec ! "
            "videoconvert ! video/x-raw,format=BGR ! "
            f"labsegment palette={clip / 'palette.json'} "
            f"min-class-pixels=0 ! blobroundness {props} ! {ranging}"
            f"landmarklog location={log} ! fakesink")
    _run(desc)
    return summary(evaluate(read_jsonl(str(log)),
                            read_jsonl(str(clip / "truth.jsonl")),
                            min_pixels=113))


def _run(desc, timeout_s=60):
    pipeline.run_to_eos(desc, timeout_s)


def test_distractor_clip(distractor_clip, tmp_path):
    # the default shape test follows blob size and lets the size evidence
    # (ipmrange) decide the rest; the fixed 0.92 alone decides too
    ellipse = run_clip(distractor_clip, "", tmp_path / "ellipse.jsonl",
                       ranged=True)
    fixed = run_clip(distractor_clip, "min-ellipse-fit=0.92",
                     tmp_path / "fixed.jsonl")
    assert fixed["detection"]["all"]["fp"] == 0
    circle = run_clip(distractor_clip, "shape=circle",
                      tmp_path / "circle.jsonl")
    det = ellipse["detection"]
    print("ellipse:", {k: (v["tp"], v["fp"], v["fn"])
                       for k, v in det["by_class"].items()})
    print("circle:", {k: (v["tp"], v["fp"], v["fn"])
                      for k, v in circle["detection"]["by_class"].items()})
    # no false detection among the squares, stripes, triangles, specks
    assert det["all"]["fp"] == 0
    assert det["all"]["recall"] >= 0.95
    # the seed's circle test misses the discs lying on the floor
    assert circle["detection"]["all"]["recall"] < det["all"]["recall"]


def test_thin_blobs_are_marginal(gst):
    """Bands 1 to 5 px thick and 110 px long (100 pixels and more: a
    smaller blob must fit as a large marker does), of a marker's colour: up
    to 3 px (moment-ellipse minor axis 4 sqrt(t^2 / 12) < 4 px) they may be
    the blend along an edge between two other colours, rejected `thin` and
    passed on as marginal for ipmrange and the map; the 5 px band and a
    14 px disc are judged by the shape test."""
    shapes = [(COLOURS["yellow"], rotated_rect(60, 20 + 30 * k, 110, t, 0))
              for k, t in enumerate((1, 2, 3, 5))]
    shapes.append((COLOURS["yellow"], ellipse(200, 60, 14, 14, 0)))
    frame = antialiased(321, 241, shapes)
    (buf,) = pipeline.process_frames(
        "labsegment min-class-pixels=0 ! blobroundness keep-rejected=true "
        "min-area=20", [frame], CAPS)
    dets = meta.detections(buf)
    for k, t in enumerate((1, 2, 3, 5)):
        blob = nearest(dets, (60, 20 + 30 * k)).blob
        # 4 sqrt(t^2 / 12), plus the antialiased rows
        assert (blob["ellipse-minor"] < 4) == (t <= 3), (t, blob)
        if t <= 3:
            assert blob["reject-reason"] == "thin", (t, blob)
            assert blob["shape-marginal"] is True
        else:
            assert blob.get("reject-reason") != "thin", (t, blob)
    assert nearest(dets, (200, 60)).blob["kept"] is True


def test_small_blobs_need_a_large_markers_fit(gst):
    """Blobs under 100 pixels are mostly outline: with min-area=40 (the
    default 100 keeps none) a 10 px disc (about 85 pixels) is kept by its
    shape; a 2:1 rectangle of that area (fit about 0.85), which the
    size-dependent threshold (about 0.83 for its ellipse) would keep, must
    fit as a large marker does (0.92): it is rejected and passed on only
    as a marginal shape, for ipmrange's size and the map to decide; a
    square (about 0.79) is rejected outright; a 6 px disc (about 28
    pixels) is under min-area."""
    shapes = [(COLOURS["yellow"], ellipse(40, 40, 10, 10, 0)),
              (COLOURS["yellow"], rotated_rect(100, 40, 9, 9, 17)),
              (COLOURS["yellow"], rotated_rect(160, 40, 12.5, 6.3, 30)),
              (COLOURS["yellow"], ellipse(220, 40, 6, 6, 0))]
    frame = antialiased(321, 241, shapes)
    (buf,) = pipeline.process_frames(
        "labsegment min-class-pixels=0 ! blobroundness keep-rejected=true "
        "min-area=40", [frame], CAPS)
    dets = meta.detections(buf)
    disc, square, rect, speck = (nearest(dets, (x, 40)).blob
                                 for x in (40, 100, 160, 220))
    assert disc["kept"] is True and 60 < disc["area"] < 100, disc
    for blob in (square, rect):
        assert 60 < blob["area"] < 100, blob
        assert blob["kept"] is False, blob
        assert blob["reject-reason"] == "ellipse-fit", blob
        assert blob["ellipse-fit-threshold"] == pytest.approx(0.92), blob
    assert rect["shape-marginal"] is True, rect
    assert not square.get("shape-marginal"), square
    assert speck["kept"] is False and speck["reject-reason"] == "area"
