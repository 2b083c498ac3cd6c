"""The main job's demo end to end, small."""

import json

import cv2

from gstlandmark import demo, regress


def test_demo_writes_outputs(gst, tmp_path):
    out = tmp_path / "demo"
    summary = demo.run_demo(str(out), width=160, height=120, frames=10,
                            clips_dir=str(tmp_path / "clips"))
    assert summary["frames"] == 10
    for name in ("palette.json", "labels.avi", "log.jsonl", "preview.png",
                 "summary.json"):
        assert (out / name).stat().st_size > 0, name
    assert json.loads((out / "summary.json").read_text()) == summary
    assert cv2.imread(str(out / "preview.png")).shape == (120, 320, 3)
    log = regress.read_jsonl(str(out / "log.jsonl"))
    assert [f["frame"] for f in log] == list(range(10))
    # every pixel accounted for, and landmark colours found
    assert abs(sum(summary["class_share"].values()) - 1.0) < 1e-3
    learned = json.loads((out / "palette.json").read_text())["classes"]
    markers = [c["name"] for c in learned if c["marker"]]
    assert sum(summary["class_share"].get(c, 0) for c in markers) > 0.002
    # the cached clip is reused, not rendered again
    again = demo.run_demo(str(out), width=160, height=120, frames=10,
                          clips_dir=str(tmp_path / "clips"))
    assert again["clip_s"] < summary["clip_s"]
