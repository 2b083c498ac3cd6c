"""File-based regression: each shipped clip through its shipped pipeline
(the whole chain) gives the golden landmarklog output within the
documented accuracy (docs/regression.md), and the golden itself agrees
with the clip's ground truth."""

import os

import numpy as np
import pytest

from gstlandmark.commands import calibrate, evaluate as E
from gstlandmark.devtools import goldens, regress

GOLDEN = goldens.GOLDENS[0]


@pytest.mark.parametrize("golden", goldens.GOLDENS, ids=lambda g: g.name)
def test_pipeline_output_equals_golden(gst, golden, tmp_path):
    _, clip, expected = golden.paths()
    assert os.path.isfile(clip), f"shipped clip missing: {clip}"
    out = tmp_path / "result.jsonl"
    goldens.produce(golden, str(out))
    diffs = regress.compare_files(str(out), expected, goldens.tolerances())
    assert not diffs, "\n".join(str(d) for d in diffs[:20])


@pytest.mark.parametrize("golden", goldens.GOLDENS, ids=lambda g: g.name)
def test_golden_agrees_with_truth(golden):
    """The golden is the chain's own output: it is kept only while it
    agrees with the renderer's exact truth as well as docs/pipelines.md
    says the chain does on this clip (three times each figure): a pose on
    44 of 45 frames, median position error 3 mm (9 mm), 6 mm at worst
    on the frames with three landmarks (18 mm), worst 0.63 m (1.9 m) on
    the frames bridged on one, no false detection, 98 of 99 landmarks
    found (a miss rate of 1 %: 3 %)."""
    _, clip, expected = golden.paths()
    truth = regress.read_jsonl(os.path.join(os.path.dirname(clip),
                                            "truth.jsonl"))
    s = E.summary(E.evaluate(regress.read_jsonl(expected), truth))
    assert s["frames"] == len(truth) == 45
    assert s["pose"]["frames_with_pose"] >= 44
    position = s["pose"]["all"]["position_m"]
    assert position["median"] <= 3 * 0.003, position
    assert position["max"] <= 3 * 0.63, position
    three = s["pose"]["lsq"]["position_m"]
    assert three["max"] <= 3 * 0.006, three
    det = s["detection"]["all"]
    assert det["fp"] == 0, det
    assert det["tp"] + det["fn"] == 99 and det["recall"] >= 1 - 3 * 0.01


def test_golden_camera_is_the_clips_camera(tmp_path):
    """The shipped camera file is what `calibrate floor` writes for the
    clip's synthetic camera (scene.json)."""
    _, clip, golden = GOLDEN.paths()
    fresh = calibrate.scene_camera_file(
        os.path.join(os.path.dirname(clip), "scene.json"),
        tmp_path / "camera.yml")
    shipped = goldens.variables(GOLDEN, "unused")["CAMERA"]
    assert os.path.dirname(shipped) == os.path.dirname(golden)
    with open(shipped) as a, open(fresh) as b:
        assert a.read() == b.read()


def changed_run(golden, tmp_path, old, new, camera=None):
    """The golden's pipeline with `old` replaced by `new` (and another
    camera file), compared with the golden."""
    pipeline_file, _, expected = golden.paths()
    line = goldens.launch_line(pipeline_file)
    assert old in line
    changed = tmp_path / "changed.pipeline"
    changed.write_text(line.replace(old, new) + "\n")
    out = tmp_path / "result.jsonl"
    variables = goldens.variables(golden, str(out))
    if camera is not None:
        variables["CAMERA"] = camera
    goldens.run_pipeline_file(str(changed), variables)
    return regress.compare_files(str(out), expected, goldens.tolerances())


def paths_of(diffs):
    return {regress._strip_indices(d.path) for d in diffs}


def test_a_changed_segmentation_is_caught(gst, tmp_path):
    """The dominant-colour rule off: the labels themselves change, not
    only the property's copy in the metadata and the log."""
    diffs = changed_run(GOLDEN, tmp_path, "min-class-pixels=50",
                        "min-class-pixels=0")
    paths = paths_of(diffs)
    assert "labels.labelled" in paths, sorted(paths)[:20]
    assert "labels.active" in paths, sorted(paths)[:20]


def test_a_changed_filter_is_caught(gst, tmp_path):
    """trilaterate without its EKF: the poses move by more than the
    tolerance (the one-landmark frames by decimetres)."""
    diffs = changed_run(GOLDEN, tmp_path, "filter=ekf", "filter=none")
    moved = [d for d in diffs if d.path in ("pose.x", "pose.y")]
    assert moved, sorted(paths_of(diffs))[:20]


def test_a_small_ranging_change_is_caught(gst, tmp_path):
    """A camera tilted 0.1 degrees more than the truth moves the ranges
    of this clip (2-5 m, 7-14 degrees below the horizon) by about 1 %:
    more than the 0.3 % tolerance, caught in the ranges themselves."""
    with open(goldens.variables(GOLDEN, "unused")["CAMERA"]) as f:
        text = f.read()
    assert "\ntilt_deg: 20.\n" in text
    camera = tmp_path / "tilted.yml"
    camera.write_text(text.replace("\ntilt_deg: 20.\n",
                                   "\ntilt_deg: 20.1\n"))
    diffs = changed_run(GOLDEN, tmp_path, "ipmrange", "ipmrange",
                        camera=str(camera))
    ranged = [d for d in diffs if d.path.endswith(".range.range")]
    assert ranged, sorted(paths_of(diffs))[:20]
    rel = np.array([abs(d.result - d.golden) / d.golden for d in ranged])
    print(f"ranges moved: median {100 * np.median(rel):.2f} %")
    assert np.median(rel) > 3 * 0.0010
