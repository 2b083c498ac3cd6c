"""Every shipped pipelines/*.pipeline runs to EOS (files generated here;
the live camera replaced by videotestsrc, since no camera exists here)."""

import os
import re

import pytest

from gstlandmark import demo, goldens, pipeline

Gst = pipeline.Gst
PIPELINE_DIR = os.path.join(goldens.ROOT, "pipelines")
FILES = sorted(f for f in os.listdir(PIPELINE_DIR) if f.endswith(".pipeline"))
CLIP_FRAMES = 12


def count_frames(path):
    pipe = Gst.parse_launch(f"filesrc location={path} ! decodebin ! "
                            "fakesink name=sink")
    n = [0]
    pipe.get_by_name("sink").get_static_pad("sink").add_probe(
        Gst.PadProbeType.BUFFER,
        lambda pad, info: (n.__setitem__(0, n[0] + 1),
                           Gst.PadProbeReturn.OK)[1])
    pipe.set_state(Gst.State.PLAYING)
    try:
        pipe.get_bus().timed_pop_filtered(
            30 * Gst.SECOND, Gst.MessageType.EOS | Gst.MessageType.ERROR)
    finally:
        pipe.set_state(Gst.State.NULL)
    return n[0]


@pytest.mark.parametrize("name", FILES)
def test_pipeline_runs(gst, name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = os.path.join(PIPELINE_DIR, name)
    desc = goldens.launch_line(path)
    clip = tmp_path / "input.avi"
    demo.write_clip(str(clip), 160, 120, CLIP_FRAMES)
    out_ext = ".jsonl" if "landmarklog location=${OUTPUT}" in desc else ".avi"
    output = tmp_path / f"output{out_ext}"
    # no camera and no display here: a test source with the camera's
    # caps, and a fakesink, keep the rest of the line as shipped
    desc = re.sub(r"v4l2src\s+device=\$\{DEVICE\}",
                  "videotestsrc num-buffers=10", desc)
    desc = desc.replace("autovideosink", "fakesink")
    run_file = tmp_path / name
    run_file.write_text(desc + "\n")
    palette = os.path.join(goldens.ROOT, "python", "gstlandmark", "data",
                           "default-palette.json")
    goldens.run_pipeline_file(str(run_file), {"INPUT": clip,
                                              "OUTPUT": output,
                                              "PALETTE": palette})
    expected = CLIP_FRAMES if "${INPUT}" in desc else 100
    for out in tmp_path.glob("*.avi"):
        if out.name != "input.avi":
            assert count_frames(str(out)) == expected, out
    if out_ext == ".jsonl":
        assert len(output.read_text().splitlines()) == expected
