"""The main job's demo end to end, small."""

import json

import cv2

from gstlandmark import demo


def test_demo_writes_outputs(gst, tmp_path):
    summary = demo.run_demo(str(tmp_path), width=160, height=120, frames=8)
    assert summary["frames"] == 8
    for name in ("input.avi", "labels.avi", "preview.png", "summary.json"):
        assert (tmp_path / name).stat().st_size > 0, name
    assert json.loads((tmp_path / "summary.json").read_text()) == summary
    preview = cv2.imread(str(tmp_path / "preview.png"))
    assert preview.shape == (120, 320, 3)
    # every pixel accounted for, and the discs' colours found
    assert abs(sum(summary["class_share"].values()) - 1.0) < 1e-3
    assert sum(summary["class_share"].get(c, 0) for c in
               ("red", "green", "yellow", "pink", "blue")) > 0.005
