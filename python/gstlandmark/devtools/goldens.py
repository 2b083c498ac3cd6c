"""Regression goldens: each shipped clip run through a shipped pipeline
file, its ``landmarklog`` output kept as the expected result.

``python -m gstlandmark.devtools.goldens refresh`` rewrites them (scripts/
refresh-goldens.sh); tests/python/test_regression.py checks them.
"""

from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass
from typing import List

from .. import pipeline
from .sourcetree import ROOT

Gst = pipeline.Gst


@dataclass
class Golden:
    name: str
    pipeline_file: str      # in pipelines/
    clip: str               # in tests/files/clips/
    golden: str             # in tests/golden/

    def paths(self):
        return (os.path.join(ROOT, "pipelines", self.pipeline_file),
                os.path.join(ROOT, "tests", "files", "clips", self.clip),
                os.path.join(ROOT, "tests", "golden", self.golden))


GOLDENS: List[Golden] = [
    Golden("regression", "regression.pipeline", "path-small/clip.avi",
           "regression.jsonl"),
]


def launch_line(pipeline_file: str) -> str:
    with open(pipeline_file) as f:
        lines = [ln.strip() for ln in f
                 if ln.strip() and not ln.lstrip().startswith("#")]
    if len(lines) != 1:
        raise ValueError(f"{pipeline_file}: one launch line expected")
    return lines[0]


def run_pipeline_file(pipeline_file: str, variables: dict,
                      timeout_s: float = 120) -> None:
    """Runs a pipelines/*.pipeline file to EOS with ${VAR} substituted."""
    desc = launch_line(pipeline_file)
    for name, value in variables.items():
        desc = desc.replace("${" + name + "}", str(value))
    if "${" in desc:
        raise ValueError(f"{pipeline_file}: unset variable in {desc}")
    pipeline.init()
    pipe = Gst.parse_launch(desc)
    pipe.set_state(Gst.State.PLAYING)
    try:
        msg = pipe.get_bus().timed_pop_filtered(
            int(timeout_s * Gst.SECOND),
            Gst.MessageType.EOS | Gst.MessageType.ERROR)
        if msg is None:
            raise pipeline.PipelineError(f"no EOS after {timeout_s} s")
        if msg.type == Gst.MessageType.ERROR:
            err, dbg = msg.parse_error()
            raise pipeline.PipelineError(f"{err.message} ({dbg})")
    finally:
        pipe.set_state(Gst.State.NULL)


def variables(g: Golden, output: str) -> dict:
    """The pipeline variables for a golden: its clip, the palette and map
    shipped beside the clip, the camera file shipped beside the golden
    (NAME-camera.yml, the clip's scene camera as `calibrate floor` writes
    it) and the output file."""
    _, clip, golden = g.paths()
    clip_dir = os.path.dirname(clip)
    return {"INPUT": clip, "OUTPUT": output,
            "PALETTE": os.path.join(clip_dir, "palette.json"),
            "MAP": os.path.join(clip_dir, "map.json"),
            "CAMERA": os.path.join(os.path.dirname(golden),
                                   f"{g.name}-camera.yml")}


def tolerances() -> "regress.Tolerances":
    """How far a result may move from its golden, from the documented
    accuracy of the chain (three times each figure): poses 12 mm and
    0.054 degrees (docs/pipelines.md: median position error 4 mm on the
    shipped clip; docs/positioning.md: median heading error 0.018
    degrees), bearings 0.036 degrees (docs/ranging.md: worst band median
    0.012 degrees), every other number 0.3 % (docs/ranging.md: p95 range
    error 0.10 %). Integers (pixel counts, boxes, timestamps), strings and
    booleans stay exact, but for frame durations: 1 ns (the clip's 1/30 s
    is 33333334 ns from GStreamer 1.22's avidemux, 33333333 from 1.26's)."""
    from . import regress
    return regress.Tolerances(
        absolute={"pose.x": 0.012, "pose.y": 0.012,
                  "pose.heading": math.radians(3 * 0.018),
                  "bearing": math.radians(3 * 0.012), "duration": 1},
        default_abs=1e-9, default_rel=3 * 0.0010)


def produce(g: Golden, output: str) -> None:
    run_pipeline_file(g.paths()[0], variables(g, output))


def refresh() -> int:
    from ..commands import calibrate
    for g in GOLDENS:
        target = g.paths()[2]
        os.makedirs(os.path.dirname(target), exist_ok=True)
        # the camera file the pipeline reads: the clip's true camera
        calibrate.scene_camera_file(
            os.path.join(os.path.dirname(g.paths()[1]), "scene.json"),
            variables(g, target)["CAMERA"])
        produce(g, target)
        with open(target) as f:
            n = sum(1 for _ in f)
        print(f"{g.name}: wrote {target} ({n} frames)")
    return 0


if __name__ == "__main__":
    if sys.argv[1:] != ["refresh"]:
        sys.exit("usage: python -m gstlandmark.devtools.goldens refresh")
    sys.exit(refresh())
