"""The main job's demo end to end, small."""

import json

import cv2

from gstlandmark.commands import demo
from gstlandmark.landmarklog import read_jsonl


def test_demo_writes_outputs(gst, tmp_path):
    out = tmp_path / "demo"
    summary = demo.run_demo(str(out), width=320, height=240, frames=45,
                            clips_dir=str(tmp_path / "clips"))
    assert summary["frames"] == 45
    for name in ("palette.json", "overlay.avi", "log.jsonl", "preview.png",
                 "trajectory.png", "accuracy.json", "summary.json"):
        assert (out / name).stat().st_size > 0, name
    assert json.loads((out / "summary.json").read_text()) == summary
    assert cv2.imread(str(out / "preview.png")).shape == (240, 320, 3)
    assert cv2.imread(str(out / "trajectory.png")) is not None
    log = read_jsonl(str(out / "log.jsonl"))
    assert [f["frame"] for f in log] == list(range(45))
    # the chain finds landmarks and solves poses on the synthetic path
    assert sum(len(f["detections"]) for f in log) > 0
    assert summary["frames_with_pose"] > 0
    accuracy = json.loads((out / "accuracy.json").read_text())
    assert accuracy["frames"] == 45
    # the cached clip is reused, not rendered again
    again = demo.run_demo(str(out), width=320, height=240, frames=45,
                          clips_dir=str(tmp_path / "clips"))
    assert again["clip_s"] < summary["clip_s"]
