"""A short soak (gstlandmark.devtools.soak, `gst-landmark soak`): the checks of
the 100,000-frame run of scripts/soak.sh on 3,000 frames.

Each soak runs in a fresh Python process, as the full run does: in this
test process, memory freed by earlier tests stays resident and would
absorb a leak without any growth of the RSS.

The growth bound is scaled to the length, not to the rate: the full run
allows 1 MiB over 90,000 frames after its warm-up (under 12 bytes a
frame); the same rate over this test's 2,000 measured frames would be
23 KiB, less than one step of the allocator (glibc grows a thread's heap
by 128 KiB or more at a time), so a clean run could fail. 256 KiB is two
such steps: it still catches any per-frame leak of 130 bytes or more (a
leaked buffer, meta, structure, cv::Mat header or log line), which
test_leak_is_seen shows with a deliberate 1 KiB a frame.
"""

import json
import os
import subprocess
import sys

from gstlandmark.commands import cli

FRAMES = 3000
WARMUP = 1000
MAX_GROWTH_KB = 256


def soak_process(args, timeout_s=120):
    res = subprocess.run([sys.executable, *args], capture_output=True,
                         text=True, timeout=timeout_s)
    return res.returncode, json.loads(res.stdout), res.stderr


def test_short_soak(gst):
    status, report, err = soak_process(
        ["-m", "gstlandmark.commands.cli", "soak", "--frames", str(FRAMES),
         "--every", "250", "--warmup", str(WARMUP),
         "--max-growth-kb", str(MAX_GROWTH_KB)])
    assert status == 0, (report["failures"], err)
    assert report["ok"]
    assert report["sink_frames"] == report["log_lines"] == FRAMES
    assert 0 <= report["growth_kb"] <= MAX_GROWTH_KB
    assert report["rss_max_kb"] - report["rss_warmup_kb"] == \
        report["growth_kb"]
    # the shipped clip really exercises the chain on every frame: a pose
    # on all but the very first frame, two detections a frame on average
    assert report["poses"] >= FRAMES - 1
    assert report["detections"] > 1.5 * FRAMES


LEAKING = f"""
import json
import os
from gstlandmark.devtools import soak
kept = []
def leak(pipe):
    def probe(pad, info):
        kept.append(bytearray(1024))
        return soak.Gst.PadProbeReturn.OK
    pipe.get_by_name("sink").get_static_pad("sink").add_probe(
        soak.Gst.PadProbeType.BUFFER, probe)
report = soak.run_soak(1500, every=100, warmup=500,
                       max_growth_kb={MAX_GROWTH_KB}, prepare=leak)
report["kept"] = len(kept)
print(json.dumps(report))
"""


def test_leak_is_seen(gst):
    """1 KiB kept per frame (a probe holding on to memory) over 1,000
    measured frames is reported as growth, and the run fails."""
    _, report, err = soak_process(["-c", LEAKING])
    assert report["kept"] == 1500
    assert not report["ok"]
    assert report["growth_kb"] > 700, report["samples"]
    assert report["failures"][0].startswith("RSS grew"), report["failures"]


def test_usage_errors(capsys):
    assert cli.main(["soak", "--size", "big"]) == 2
    assert cli.main(["soak", "--frames", "10", "--warmup", "10"]) == 2
    assert "--warmup must be below --frames" in capsys.readouterr().err


def test_without_the_source_tree_the_clip_is_named(tmp_path):
    """soak runs the shipped clip of the source tree: where there is none
    (an installed package elsewhere) it says which file and why."""
    env = dict(os.environ, LANDMARK_SOURCE_ROOT=str(tmp_path))
    res = subprocess.run(
        [sys.executable, "-m", "gstlandmark.commands.cli", "soak",
         "--frames", "20", "--every", "10", "--warmup", "10"],
        capture_output=True, text=True, timeout=60, env=env)
    assert res.returncode == 1
    assert f"{tmp_path}/tests/files/clips/path-small/clip.avi: not " \
        "found" in res.stderr
    assert "LANDMARK_SOURCE_ROOT" in res.stderr
