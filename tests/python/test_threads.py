"""n-threads on labsegment and blobroundness: a frame cut into horizontal
slices on several threads gives exactly what one thread gives (labels,
histograms, the dominant-colour rule, the false-colour view, blobs), and
the worker threads follow the property while playing."""

import json
import os
import zlib

import cv2
import numpy as np
import pytest

from gstlandmark import meta, palette, pipeline

import frames as F

# odd heights, so that slices (cut at even rows) end in an odd last row;
# at 4 threads a 45-row frame is 16 slices of 2 or 4 rows
SIZES = [(67, 45), (130, 77), (9, 3)]
THREADS = (2, 3, 4)


def seed_of(*names):
    return zlib.crc32(" ".join(str(n) for n in names).encode())


def payloads_for(fmt, width, height, rng):
    """Two random frames and one floor-like frame in fmt's layout."""
    caps = F.caps_string(fmt, width, height)
    info = F.video_info(caps)
    images = [F.random_rgb(rng, height, width),
              F.random_rgb(rng, height, width),
              F.natural_rgb(rng, height, width)]
    if fmt in F.PACKED_ORDER:
        return caps, [F.pack_rgb(img, fmt, info, rng) for img in images]
    return caps, [F.rgb_to_yuv_bytes(img, fmt, info) for img in images]


def labsegment_results(buffers):
    """Everything labsegment produced per buffer: the video bytes (the
    false-colour view), the plane and the histogram fields."""
    out = []
    for buf in buffers:
        with buf.map(pipeline.Gst.MapFlags.READ) as m:
            video = bytes(m.data)
        lm = meta.labels(buf)
        out.append({
            "video": video,
            "plane": lm.plane.tobytes(),
            "counts": [c.count for c in lm.classes],
            "active": [c.active for c in lm.classes],
            "labelled": [c.labelled for c in lm.classes],
            "unclassified": lm.unclassified,
        })
    return out


@pytest.mark.parametrize("rare", ["nearest", "unlabelled"])
@pytest.mark.parametrize("fmt", F.ALL_FORMATS)
def test_labsegment_threads_identical(gst, fmt, rare):
    rng = np.random.default_rng(seed_of(fmt, rare))
    demoted_seen = False
    for width, height in SIZES:
        caps, payloads = payloads_for(fmt, width, height, rng)
        # about one class in three below the threshold on random frames
        mcp = width * height // 12
        element = (f"labsegment output=labels min-class-pixels={mcp} "
                   f"rare-classes={rare}")
        one = labsegment_results(pipeline.process_frames(
            f"{element} n-threads=1", payloads, caps))
        assert len(one) == len(payloads)
        for r in one:
            # the rule demoted a class that had pixels: its pass is covered
            demoted_seen |= any(c > 0 and not a
                                for c, a in zip(r["counts"], r["active"]))
        for n in THREADS:
            many = labsegment_results(pipeline.process_frames(
                f"{element} n-threads={n}", payloads, caps))
            for i, (a, b) in enumerate(zip(one, many)):
                for key in a:
                    assert a[key] == b[key], (
                        f"{fmt} {width}x{height} frame {i} n-threads={n}: "
                        f"{key} differs from one thread")
    assert demoted_seen


def palette_of(n, tmp_path):
    """A palette of n classes: the default one's first n (7 at most), then
    grey levels."""
    classes = json.loads(palette.default_palette_text())["classes"][:n]
    for i in range(len(classes), n):
        classes.append({"name": f"grey{i}", "lab": [5.0 + 90.0 * i / n,
                                                    0.0, 0.0],
                        "role": "floor"})
    path = tmp_path / f"palette{n}.json"
    path.write_text(json.dumps({"classes": classes}))
    return path


# 4 and 7 classes: the packed 4-byte gathers count the labels as they go
# (nibble counters, half of them or all used); 12: they count afterwards
# (two AVX2 passes)
@pytest.mark.parametrize("classes", [4, 7, 12])
@pytest.mark.parametrize("fmt", F.ALL_FORMATS)
def test_simd_levels_identical(gst, fmt, classes, monkeypatch, tmp_path):
    """The AVX2 gathers and class histogram, the scalar table loads of
    4-byte pixels at the AVX2 level (16 pixels a step, counted 32 at a
    time), the SSE2 histogram and the SSE2 YUV keys against the scalar loops
    (LANDMARK_SIMD, read when caps are set), on widths with a vector part
    (32 pixels a gather step) and a tail."""
    rng = np.random.default_rng(seed_of(fmt, "scalar", classes))
    pal = palette_of(classes, tmp_path)
    # 320x64: 640 steps of 32 pixels, past the 15 after which the
    # gathers' 4-bit counters must be summed
    for width, height in SIZES + [(320, 64)]:
        caps, payloads = payloads_for(fmt, width, height, rng)
        element = (f"labsegment output=labels palette={pal} "
                   f"min-class-pixels={width}")
        results = {}
        for level in ("none", "sse2", "avx2-gather", "best"):
            monkeypatch.setenv("LANDMARK_SIMD", level)
            results[level] = labsegment_results(pipeline.process_frames(
                element, payloads, caps))
        monkeypatch.delenv("LANDMARK_SIMD")
        assert results["sse2"] == results["none"], f"{fmt} {width}x{height}"
        assert results["avx2-gather"] == results["none"], \
            f"{fmt} {width}x{height}"
        assert results["best"] == results["none"], f"{fmt} {width}x{height}"


def marker_frame(rng, width, height):
    """Marker-coloured ellipses of every size on grey, many of them tall
    enough to cross several slice borders, some touching each other and
    the frame edge, and speckle noise of marker colours."""
    img = np.full((height, width, 3), 128, np.uint8)
    colours = [(200, 40, 40), (60, 190, 70), (230, 220, 60),
               (255, 105, 180), (30, 80, 200)]
    for _ in range(40):
        c = colours[rng.integers(len(colours))]
        centre = (int(rng.integers(-5, width + 5)),
                  int(rng.integers(-5, height + 5)))
        axes = (int(rng.integers(1, 30)), int(rng.integers(1, 40)))
        cv2.ellipse(img, centre, axes, float(rng.uniform(0, 180)), 0, 360,
                    c, -1)
    speckle = rng.random((height, width)) < 0.01
    img[speckle] = np.array(colours)[rng.integers(len(colours),
                                                  size=speckle.sum())]
    return img


def blob_results(buffers):
    return [[(d.class_name, d.bbox, d.blob) for d in meta.detections(buf)]
            for buf in buffers]


def test_blobroundness_threads_identical(gst):
    rng = np.random.default_rng(seed_of("blobroundness"))
    width, height = 241, 181
    caps = F.caps_string("RGB", width, height)
    images = [marker_frame(rng, width, height) for _ in range(4)]
    chain = ("labsegment min-class-pixels=0 ! blobroundness min-area=1 "
             "keep-rejected=true")
    one = blob_results(pipeline.process_frames(f"{chain} n-threads=1",
                                               images, caps))
    assert all(len(blobs) >= 20 for blobs in one)
    # blobs that cross slice borders (4 threads: 16 slices of 11-12 rows)
    tall = sum(1 for blobs in one for _, bbox, _ in blobs if bbox[3] > 24)
    assert tall >= 20
    for n in THREADS:
        many = blob_results(pipeline.process_frames(f"{chain} n-threads={n}",
                                                    images, caps))
        assert many == one, f"n-threads={n} finds other blobs"


def thread_count():
    """The process's worker threads (core/support/workerpool.h names them)."""
    n = 0
    for task in os.listdir("/proc/self/task"):
        try:
            with open(f"/proc/self/task/{task}/comm") as f:
                n += f.read().strip() == "landmark-worker"
        except FileNotFoundError:   # a thread that ended meanwhile
            pass
    return n


def workers_after_one_frame(element, width, height):
    """Worker threads while element has just processed one BGRx frame."""
    Gst = pipeline.Gst
    caps = F.caps_string("BGRx", width, height)
    pipe = Gst.parse_launch(
        f"appsrc name=src format=time caps={caps} ! {element} ! "
        "appsink name=sink sync=false")
    src, sink = pipe.get_by_name("src"), pipe.get_by_name("sink")
    pipe.set_state(Gst.State.PLAYING)
    try:
        src.emit("push-buffer",
                 Gst.Buffer.new_wrapped(bytes(width * 4 * height)))
        assert sink.emit("try-pull-sample", 10 * Gst.SECOND) is not None
        return thread_count()
    finally:
        pipe.set_state(Gst.State.NULL)


def test_default_uses_every_core_from_1080p(gst):
    cores = min(len(os.sched_getaffinity(0)), 64)
    assert workers_after_one_frame("labsegment", 1920, 1080) == cores - 1
    assert workers_after_one_frame("labsegment", 1920, 1078) == 0
    assert workers_after_one_frame(
        "labsegment min-class-pixels=0 ! blobroundness n-threads=0",
        1920, 1080) == 2 * (cores - 1)


def test_workers_follow_the_property_while_playing(gst):
    """The pool is resized at the next frame after n-threads changes, and
    0 (auto) starts no worker below 1920x1080."""
    Gst = pipeline.Gst
    width, height = 64, 31
    caps = F.caps_string("BGRx", width, height)
    pipe = Gst.parse_launch(
        f"appsrc name=src format=time caps={caps} ! labsegment name=seg "
        "n-threads=3 ! appsink name=sink sync=false")
    src, sink, seg = (pipe.get_by_name(n) for n in ("src", "sink", "seg"))
    assert seg.get_property("n-threads") == 3
    frame = bytes(width * 4 * height)

    def one_frame():
        src.emit("push-buffer", Gst.Buffer.new_wrapped(frame))
        assert sink.emit("try-pull-sample", 10 * Gst.SECOND) is not None
        return thread_count()

    pipe.set_state(Gst.State.PLAYING)
    try:
        assert one_frame() == 2
        assert one_frame() == 2             # no thread per frame
        seg.set_property("n-threads", 1)
        assert one_frame() == 0
        seg.set_property("n-threads", 4)
        assert one_frame() == 3
        seg.set_property("n-threads", 0)
        assert one_frame() == 0
    finally:
        pipe.set_state(Gst.State.NULL)
    assert thread_count() == 0              # stopped with the element
