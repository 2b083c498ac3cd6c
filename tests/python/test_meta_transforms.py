"""The labels meta through queue, tee, videoconvert and videoscale: copied
where the pixels keep their places, resampled by nearest neighbour where
the frame changes size."""

import numpy as np
import pytest

from gstlandmark import meta, pipeline

import frames as F

Gst = pipeline.Gst


def run_branches(img, caps, branches, timeout_s=20):
    """appsrc ! labsegment ! tee, with one appsink per branch; returns the
    buffer each branch received."""
    desc = (f"appsrc name=src format=time caps={caps} ! "
            "labsegment min-class-pixels=0 ! tee name=t ")
    for name, chain in branches.items():
        desc += (f"t. ! queue ! {chain} ! appsink name={name} sync=false ")
    pipe = Gst.parse_launch(desc)
    pipe.set_state(Gst.State.PLAYING)
    try:
        buf = Gst.Buffer.new_wrapped(img.tobytes())
        buf.pts = 0
        pipe.get_by_name("src").emit("push-buffer", buf)
        pipe.get_by_name("src").emit("end-of-stream")
        out = {}
        for name in branches:
            sample = pipe.get_by_name(name).emit(
                "try-pull-sample", timeout_s * Gst.SECOND)
            assert sample is not None, f"branch {name} produced nothing"
            out[name] = sample.get_buffer()
        return out
    finally:
        pipe.set_state(Gst.State.NULL)


def nearest_resample(plane, out_w, out_h):
    """Independent statement of the contract: each output pixel takes the
    input label under its centre."""
    h, w = plane.shape
    ys = ((2 * np.arange(out_h) + 1) * h) // (2 * out_h)
    xs = ((2 * np.arange(out_w) + 1) * w) // (2 * out_w)
    return plane[ys][:, xs]


@pytest.mark.parametrize("out_size", [(40, 30), (161, 119), (320, 240),
                                      (7, 3), (80, 61)])
def test_videoscale_resamples_labels(gst, out_size):
    rng = np.random.default_rng(1)
    img = F.natural_rgb(rng, 61, 80)
    caps = F.caps_string("RGB", 80, 61)
    out_w, out_h = out_size
    bufs = run_branches(img, caps, {
        "same": "identity",
        "scaled": f"videoscale ! video/x-raw,width={out_w},height={out_h}",
    })
    src = meta.labels(bufs["same"])
    scaled = meta.labels(bufs["scaled"])
    assert scaled is not None, "videoscale dropped the labels meta"
    assert (scaled.width, scaled.height, scaled.stride) == (out_w, out_h,
                                                            out_w)
    assert scaled.plane.shape == (out_h, out_w)
    np.testing.assert_array_equal(scaled.plane,
                                  nearest_resample(src.plane, out_w, out_h))
    # counts describe the analysed frame, which stays recorded
    assert (scaled.analysis_width, scaled.analysis_height) == (80, 61)
    assert [c.count for c in scaled.classes] == [c.count
                                                 for c in src.classes]


def test_copies_keep_labels(gst):
    rng = np.random.default_rng(2)
    img = F.natural_rgb(rng, 48, 64)
    caps = F.caps_string("RGB", 64, 48)
    bufs = run_branches(img, caps, {
        "plain": "identity",
        "queued": "queue ! queue",
        "converted": "videoconvert ! video/x-raw,format=I420",
        "converted_back": "videoconvert ! video/x-raw,format=NV12 ! "
                          "videoconvert ! video/x-raw,format=BGRx",
    })
    ref = meta.labels(bufs["plain"])
    assert ref is not None
    for name, buf in bufs.items():
        lm = meta.labels(buf)
        assert lm is not None, f"{name}: labels meta lost"
        np.testing.assert_array_equal(lm.plane, ref.plane, err_msg=name)
        assert lm.class_names == ref.class_names
        assert [c.count for c in lm.classes] == [c.count
                                                 for c in ref.classes]


def test_videoscale_then_videoconvert(gst):
    """A common display chain: scale down, then convert for the sink."""
    img = F.natural_rgb(np.random.default_rng(4), 120, 160)
    caps = F.caps_string("BGRx", 160, 120)
    bgrx = np.zeros((120, 160, 4), np.uint8)
    bgrx[..., 0], bgrx[..., 1], bgrx[..., 2] = img[..., 2], img[..., 1], \
        img[..., 0]
    bufs = run_branches(bgrx, caps, {
        "same": "identity",
        "chain": "videoscale ! video/x-raw,width=80,height=60 ! "
                 "videoconvert ! video/x-raw,format=I420",
    })
    np.testing.assert_array_equal(
        meta.labels(bufs["chain"]).plane,
        nearest_resample(meta.labels(bufs["same"]).plane, 80, 60))
