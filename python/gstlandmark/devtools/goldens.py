"""Regression goldens: each shipped clip run through a shipped pipeline
file, its ``landmarklog`` output kept as the expected result.

``python -m gstlandmark.devtools.goldens refresh`` rewrites them (scripts/
refresh-goldens.sh); tests/python/test_regression.py checks them.
"""

from __future__ import annotations

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
    """The pipeline variables for a golden: its clip, the palette shipped
    beside the clip, and the output file."""
    _, clip, _ = g.paths()
    return {"INPUT": clip, "OUTPUT": output,
            "PALETTE": os.path.join(os.path.dirname(clip), "palette.json")}


def produce(g: Golden, output: str) -> None:
    run_pipeline_file(g.paths()[0], variables(g, output))


def refresh() -> int:
    for g in GOLDENS:
        target = g.paths()[2]
        os.makedirs(os.path.dirname(target), exist_ok=True)
        produce(g, target)
        with open(target) as f:
            n = sum(1 for _ in f)
        print(f"{g.name}: wrote {target} ({n} frames)")
    return 0


if __name__ == "__main__":
    if sys.argv[1:] != ["refresh"]:
        sys.exit("usage: python -m gstlandmark.devtools.goldens refresh")
    sys.exit(refresh())
