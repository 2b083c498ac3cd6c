"""Detections through queue, tee, videoconvert and videoscale: the boxes
scale with the frame, the landmark-* parameters (in the analysed frame's
coordinates, with its size) arrive whole."""

import numpy as np
import pytest

from gstlandmark import meta, pipeline

import frames as F

Gst = pipeline.Gst


def disc_frame(width, height):
    img = np.full((height, width, 3), 128, np.uint8)
    yy, xx = np.mgrid[0:height, 0:width]
    for (cx, cy, r, colour) in [(40, 30, 12, (200, 40, 40)),
                                (110, 70, 15, (40, 70, 200))]:
        img[(xx - cx) ** 2 + (yy - cy) ** 2 <= r * r] = colour
    return img


@pytest.mark.parametrize("chain, size", [
    ("queue ! tee ! queue", (160, 120)),
    ("videoconvert ! video/x-raw,format=I420", (160, 120)),
    ("videoscale ! video/x-raw,width=320,height=240", (320, 240)),
    ("videoscale ! video/x-raw,width=80,height=60 ! videoconvert ! "
     "video/x-raw,format=NV12", (80, 60)),
])
def test_detection_parameters_survive(gst, chain, size):
    img = disc_frame(160, 120)
    caps = F.caps_string("RGB", 160, 120)
    head = "labsegment min-class-pixels=0 ! blobroundness min-area=50"
    ref = meta.detections(pipeline.process_frames(head, [img], caps)[0])
    got = meta.detections(pipeline.process_frames(f"{head} ! {chain}",
                                                  [img], caps)[0])
    assert len(ref) == 2 and len(got) == 2
    sx, sy = size[0] / 160, size[1] / 120
    for r, g in zip(ref, got):
        assert g.class_name == r.class_name
        assert g.blob == r.blob, "landmark-blob lost or changed"
        assert g.blob["frame-width"] == 160
        # the box follows the frame (rounding of the scaler: 1 px)
        x, y, w, h = r.bbox
        assert abs(g.bbox[0] - x * sx) <= 1 and abs(g.bbox[1] - y * sy) <= 1
        assert abs(g.bbox[2] - w * sx) <= 1.5 and abs(g.bbox[3] - h * sy) <= 1.5


def test_landmarklog_after_a_scaler_has_the_parameters(gst, tmp_path):
    import json
    img = disc_frame(160, 120)
    caps = F.caps_string("RGB", 160, 120)
    log = tmp_path / "log.jsonl"
    pipeline.process_frames(
        "labsegment min-class-pixels=0 ! blobroundness min-area=50 ! "
        "videoscale ! video/x-raw,width=80,height=60 ! "
        f"landmarklog location={log}", [img], caps)
    line = json.loads(log.read_text().splitlines()[0])
    assert [d["blob"]["frame-width"] for d in line["detections"]] == [160,
                                                                       160]
    assert all(d["bbox"][2] <= 16 for d in line["detections"])
