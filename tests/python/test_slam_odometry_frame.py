"""landmarkslam with wheel odometry of the turning centre
(docs/landmarkslam.md, "The odometry's frame"): a rendered clip of the
path scenario whose camera is 0.15 m ahead of the turning centre (the
seed robot, 150 frames), with two logs of the same path, 2 % scale error
and 1 degree per metre of drift, no slip: the camera's motion and the
turning centre's (synth --odometry-frame). With camera-forward set to the
scene's 0.15 m, the turning centre's log gives the camera's path as the
camera's own log does; with camera-forward 0 (the turning centre's motion
taken for the camera's) the path is clearly worse."""

import json
import os

import numpy as np
import pytest

from gstlandmark.landmarklog import read_jsonl
from gstlandmark.synth.odometry import (no_errors, scene_odometry,
                                        write_odometry)
from gstlandmark.synth.scenarios import Offset, build_scenario
from gstlandmark.synth.writer import write_outputs
from test_slam import path_errors, run_chain, to_truth_frame

FRAMES = 150
FORWARD = 0.15


@pytest.fixture(scope="module")
def offset_clip(tmp_path_factory):
    out = tmp_path_factory.mktemp("slam-offset-clip")
    scene, n = build_scenario("path", seed=0, frames=FRAMES)
    scene.trajectory = Offset(scene.trajectory, FORWARD)
    write_outputs(scene, n, str(out), progress=False, odometry=False)
    for frame in ("camera", "turning-centre"):
        write_odometry(str(out / f"odometry-{frame}.jsonl"), scene_odometry(
            scene, n, no_errors(scale=0.02, drift_deg_per_m=1.0,
                                frame=frame)))
    return str(out)


def path_error(gst, clip, tmp_path, frame, forward):
    odo = os.path.join(clip, f"odometry-{frame}.jsonl")
    frames, _ = run_chain(gst, clip, f"landmarkslam odometry={odo} "
                          f"camera-forward={forward}",
                          str(tmp_path / f"{frame}-{forward}.jsonl"))
    truth = list(read_jsonl(os.path.join(clip, "truth.jsonl")))
    errs = path_errors(frames, truth, to_truth_frame(truth[0]["robot"],
                                                     frames[0]["pose"]))
    assert len(errs) == FRAMES
    return np.median(errs), np.percentile(errs, 95)


def test_turning_centre_odometry(gst, offset_clip, tmp_path):
    with open(os.path.join(offset_clip, "scene.json")) as f:
        forward = json.load(f)["trajectory"]["camera_forward_m"]
    assert forward == FORWARD
    camera = path_error(gst, offset_clip, tmp_path, "camera", 0)
    centre = path_error(gst, offset_clip, tmp_path, "turning-centre",
                        forward)
    wrong = path_error(gst, offset_clip, tmp_path, "turning-centre", 0)
    print(f"path error median, p95 (cm): camera's log {camera[0] * 100:.2f}"
          f", {camera[1] * 100:.2f}; turning centre's with camera-forward "
          f"{forward} {centre[0] * 100:.2f}, {centre[1] * 100:.2f}; with 0 "
          f"{wrong[0] * 100:.2f}, {wrong[1] * 100:.2f}")
    # measured (cm): camera's log 0.04, 0.07; turning centre's with 0.15
    # 0.03, 0.07; with 0 14.3, 15.8 (the swing of the camera on the turns
    # left out: the estimate follows the turning centre's path)
    for est in (camera, centre):
        assert est[0] < 0.0015 and est[1] < 0.0025, (camera, centre)
    assert abs(centre[0] - camera[0]) < 0.001, (centre, camera)
    assert wrong[0] > 0.05 and wrong[1] > 0.05, (wrong, centre)
