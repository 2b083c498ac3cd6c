"""``python tools/mapreuse.py``: does the map ``landmarkslam``
writes serve ``trilaterate`` as well as the true map (docs/landmarkslam.md,
"The written map on a third loop")?

Per clip: render three loops of the ``path`` field (900 frames; the
default field, or ``--variant N`` with the seed camera as the Accuracy
commands give it), run ``landmarkslam map-out=...`` on the first two loops
(600 frames) with and without the synthetic odometry log, then run
``trilaterate filter=ekf`` over all 900 frames once with the written map and
once with the true one, and compare the position error on the third loop
(frames 600-899). The written map's frame is the first pose's
(``landmarkslam`` without anchors), so its poses are brought into the
truth's frame by the rigid transform that best fits the written landmarks
to the true ones (each paired with the nearest true landmark of its class
within 0.5 m, starting from the first true pose; spurious ones left out).
``ipmrange`` reads the same map as ``trilaterate`` (the marker sizes of the
written map are those ``ipmrange`` named while mapping).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from gstlandmark import pipeline
from gstlandmark.landmarklog import read_jsonl
from gstlandmark.synth import render_scenario

FRAMES, MAPPED = 900, 600
SEED_CAMERA = {"hfov_deg": 54.0, "height_m": 0.2, "tilt_deg": 18.0}


def chain_head(clip: str, palette: Optional[str] = None) -> str:
    """The Accuracy chain up to blobroundness on the clip, with its
    palette (the renderer's) or ``palette``."""
    palette = palette or f"{clip}/palette.json"
    return (f"filesrc location={clip}/clip.avi ! avidemux ! jpegdec ! "
            f"videoconvert ! labsegment palette={palette} "
            "min-class-pixels=50 ! blobroundness min-area=30")


def run_clip(clip: str, out: str) -> None:
    """The SLAM runs (odometry and none) and the three trilaterate runs."""
    head = chain_head(clip)
    camera = f"calibration={clip}/camera.yml"
    for mode in ("odometry", "none"):
        odo = f" odometry={clip}/odometry.jsonl" if mode == "odometry" else ""
        built = os.path.join(out, f"built-{mode}.json")
        pipeline.run_to_eos(
            f"{head} ! identity eos-after={MAPPED} ! ipmrange {camera} "
            f"map={clip}/map.json ! landmarkslam map-out={built}{odo} ! "
            f"fakesink", timeout_s=600)
    for name, map_file in (("true", f"{clip}/map.json"),
                           ("odometry", f"{out}/built-odometry.json"),
                           ("none", f"{out}/built-none.json")):
        pipeline.run_to_eos(
            f"{head} ! ipmrange {camera} map={map_file} ! trilaterate "
            f"map={map_file} filter=ekf ! landmarklog "
            f"location={out}/trilaterate-{name}.jsonl ! fakesink",
            timeout_s=600)


def fit_map(built: Sequence[Dict[str, Any]], true: Sequence[Dict[str, Any]],
            first_pose: Dict[str, float]
            ) -> Tuple[np.ndarray, np.ndarray, float, int]:
    """Rotation, translation (written frame -> truth), RMS of the paired
    landmarks after the fit, and how many were paired."""
    c, s = math.cos(first_pose["heading"]), math.sin(first_pose["heading"])
    rot = np.array([[c, -s], [s, c]])
    shift = np.array([first_pose["x"], first_pose["y"]])
    pairs: List[Tuple[np.ndarray, np.ndarray]] = []
    for _ in range(10):
        pairs = []
        for b in built:
            p = np.array([b["x"], b["y"]])
            q = rot @ p + shift
            same = [np.array([m["x"], m["y"]]) for m in true
                    if m["class"] == b["class"]]
            if not same:
                continue
            m = min(same, key=lambda t: float(np.linalg.norm(t - q)))
            if np.linalg.norm(m - q) <= 0.5:
                pairs.append((p, m))
        if len(pairs) < 2:
            break
        P = np.array([p for p, _ in pairs])
        Q = np.array([q for _, q in pairs])
        mp, mq = P.mean(0), Q.mean(0)
        u, _, vt = np.linalg.svd((P - mp).T @ (Q - mq))
        d = np.diag([1.0, float(np.sign(np.linalg.det(vt.T @ u.T)))])
        rot = vt.T @ d @ u.T
        shift = mq - rot @ mp
    rms = math.sqrt(float(np.mean([np.sum((rot @ p + shift - q) ** 2)
                                   for p, q in pairs]))) if pairs else math.nan
    return rot, shift, rms, len(pairs)


def third_loop_errors(log: str, truth: Dict[int, Dict[str, Any]],
                      rot: np.ndarray, shift: np.ndarray
                      ) -> Tuple[int, np.ndarray]:
    """Frames of the third loop, and the position errors of those with a
    pose."""
    errors, frames = [], 0
    for r in read_jsonl(log):
        if r["frame"] < MAPPED:
            continue
        frames += 1
        if "pose" not in r:
            continue
        q = rot @ np.array([r["pose"]["x"], r["pose"]["y"]]) + shift
        t = truth[r["frame"]]["robot"]
        errors.append(math.hypot(q[0] - t["x"], q[1] - t["y"]))
    return frames, np.array(errors)


def score(clip: str, out: str) -> Dict[str, Any]:
    truth = {t["frame"]: t for t in read_jsonl(f"{clip}/truth.jsonl")}
    with open(f"{clip}/map.json") as f:
        true_map = json.load(f)["landmarks"]
    rows: Dict[str, Any] = {}
    eye, zero = np.eye(2), np.zeros(2)
    frames, err = third_loop_errors(f"{out}/trilaterate-true.jsonl", truth,
                                    eye, zero)
    rows["true"] = {"landmarks": len(true_map), "frames": frames,
                    "with_pose": len(err),
                    "median_m": float(np.median(err)),
                    "p95_m": float(np.percentile(err, 95))}
    for mode in ("odometry", "none"):
        with open(f"{out}/built-{mode}.json") as f:
            built = json.load(f)["landmarks"]
        rot, shift, rms, paired = fit_map(built, true_map,
                                          truth[min(truth)]["robot"])
        frames, err = third_loop_errors(f"{out}/trilaterate-{mode}.jsonl",
                                        truth, rot, shift)
        rows[mode] = {"landmarks": len(built), "paired": paired,
                      "fit_rms_m": rms, "frames": frames,
                      "with_pose": len(err),
                      "median_m": float(np.median(err)) if len(err) else None,
                      "p95_m": float(np.percentile(err, 95))
                      if len(err) else None}
    return rows


def main(argv: Optional[Sequence[str]] = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python tools/mapreuse.py",
        description=__doc__.split("\n\n")[0])
    ap.add_argument("--variant", type=int, action="append", default=[],
                    help="a variant of the path field with the seed camera "
                    "(repeatable); none: the default field")
    ap.add_argument("--out", default="out/mapreuse")
    ap.add_argument("--json", help="write the figures here")
    args = ap.parse_args(argv)
    results = {}
    for variant in args.variant or [None]:
        name = "default" if variant is None else f"v{variant}"
        clip = os.path.join(args.out, name, "clip")
        if not os.path.exists(os.path.join(clip, "truth.jsonl")):
            extra = {} if variant is None else dict(SEED_CAMERA)
            render_scenario("path", clip, frames=FRAMES, variant=variant,
                            progress=False, **extra)
        run_clip(clip, os.path.join(args.out, name))
        rows = results[name] = score(clip, os.path.join(args.out, name))
        t = rows["true"]
        print(f"{name}: true map: pose on {t['with_pose']}/{t['frames']} "
              f"third-loop frames, median {100 * t['median_m']:.2f} cm, p95 "
              f"{100 * t['p95_m']:.2f} cm")
        for mode in ("odometry", "none"):
            r = rows[mode]
            if r["median_m"] is None:
                print(f"  written ({mode}): no pose")
                continue
            print(f"  written ({mode}): {r['landmarks']} landmarks "
                  f"({r['paired']} paired, fit RMS "
                  f"{100 * r['fit_rms_m']:.2f} cm); pose on "
                  f"{r['with_pose']}/{r['frames']}, median "
                  f"{100 * r['median_m']:.2f} cm (true map "
                  f"{100 * (r['median_m'] - t['median_m']):+.2f}), p95 "
                  f"{100 * r['p95_m']:.2f} cm")
        sys.stdout.flush()
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
