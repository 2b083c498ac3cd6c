"""``python tools/odometrydraws.py``: ``landmarkslam``'s
accuracy and pose NEES with odometry over several draws of the odometry log
(docs/landmarkslam.md, "Over five odometry draws").

One odometry log says little about the pose NEES: its share inside the
95 % band moves by several points from one draw of the slip to the next.
Per clip (a ``path`` clip ``gst-landmark synth`` rendered; ``--variant N``
for a variant rendered with the seed camera, as the Accuracy commands
give it): rebuild its scene (checked against its ``scene.json``), write
``--draws`` odometry logs with synth's default errors, camera frame,
odometry seeds 0, 1, ... (0 is the log synth wrote beside a clip made
with its default odometry options and scenario seed 0, as the Accuracy
clips are),
run the Accuracy chain with each (``landmarkslam odometry=...``, no map
anchor) and score it as ``gst-landmark evaluate`` does; print the median
and range over the draws.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
from typing import Any, Dict, List, Optional, Sequence

import numpy as np

from gstlandmark import pipeline
from gstlandmark.commands.evaluate import slam_evaluation
from gstlandmark.landmarklog import read_jsonl
from gstlandmark.landmarkmap import read_map
from gstlandmark.synth.odometry import OdometryErrors, scene_odometry, write_odometry
from gstlandmark.synth.scenarios import build_scenario
from gstlandmark.synth.variants import draw_variant
from mapreuse import SEED_CAMERA, chain_head


def rebuild_scene(clip: str, variant: Optional[int]):
    """The clip's scene as synth built it; ValueError when its path is not
    the one ``scene.json`` records (another seed, variant or camera)."""
    with open(os.path.join(clip, "scene.json"), encoding="utf-8") as f:
        stored = json.load(f)
    extra = ({} if variant is None else
             {"variant": draw_variant("path", variant), **SEED_CAMERA})
    scene, frames = build_scenario("path", seed=stored["seed"],
                                   frames=stored["frames"], **extra)
    rebuilt = scene.trajectory.to_json()
    for key, value in stored["trajectory"].items():
        same = (abs(rebuilt[key] - value) < 1e-3
                if isinstance(value, float) else rebuilt[key] == value)
        if not same:
            raise ValueError(f"{clip}/scene.json: trajectory {key} is "
                             f"{value!r}, the rebuilt scene's "
                             f"{rebuilt[key]!r}: wrong --variant?")
    return scene, frames


def run_draw(clip: str, palette: str, odometry: str, out: str,
             slam_properties: Sequence[str] = ()) -> Dict[str, Any]:
    """The Accuracy chain with one odometry log (``landmarkslam`` with
    ``slam_properties`` too, ``name=value`` each); its ``slam`` scores."""
    os.makedirs(out, exist_ok=True)
    log = os.path.join(out, "log.jsonl")
    pipeline.run_to_eos(
        f"{chain_head(clip, palette)} ! ipmrange "
        f"calibration={clip}/camera.yml map={clip}/map.json ! "
        f"landmarkslam map-out={out}/built.json odometry={odometry} "
        f"{' '.join(slam_properties)} ! "
        f"landmarklog location={log} ! fakesink", timeout_s=900)
    slam = slam_evaluation(read_jsonl(log),
                           read_jsonl(os.path.join(clip, "truth.jsonl")),
                           read_map(os.path.join(clip, "map.json")))
    with open(os.path.join(out, "eval.json"), "w", encoding="utf-8") as f:
        json.dump({"slam": slam}, f, indent=2)
    return slam


def scores(slam: Dict[str, Any]) -> Dict[str, float]:
    """The figures of the table: pose NEES inside (%) and mean, ATE median
    and landmark RMS (cm), duplicated and spurious landmarks."""
    nees, lm = slam["nees"]["pose"], slam["map"]
    return {"inside": 100 * nees["inside"], "mean": nees["mean"],
            "ate": 100 * slam["trajectory"]["position_m"]["median"],
            "rms": 100 * lm["aligned"].get("rms", float("nan")),
            "duplicated": len(lm["duplicated"]),
            "spurious": len(lm["spurious"])}


# the accuracy target of docs/landmarkslam.md (cm) and the NEES one (%)
TARGET_RMS_CM, TARGET_ATE_CM, TARGET_INSIDE = 3.0, 2.0, 90.0

HEADER = ("| clip | pose NEES inside: median draw (min..max) | mean pose "
          "NEES: median (min..max) | ATE median: median (min..max) | landmark "
          "RMS: median (min..max) | duplicated, spurious (most in one "
          "draw) | NEES >= 90 % on the median draw | accuracy target "
          "(draws) |")


def summary_row(name: str, draws: Sequence[Dict[str, float]]) -> str:
    """The row of docs/landmarkslam.md's table: median (min..max) over the
    draws, the most duplicated / spurious of any draw, the NEES target on
    the median draw and the draws that meet the accuracy target."""
    col = {k: np.array([d[k] for d in draws]) for k in draws[0]}

    def spread(key: str, unit: str = "") -> str:
        v = col[key]
        return (f"{np.median(v):.2f} ({v.min():.2f}..{v.max():.2f})"
                f"{unit}")
    inside = col["inside"]
    accurate = sum(d["rms"] <= TARGET_RMS_CM and d["ate"] <= TARGET_ATE_CM
                   and d["duplicated"] == 0 and d["spurious"] == 0
                   for d in draws)
    median = float(np.median(inside))
    return (f"| {name} | {median:.1f} % ({inside.min():.1f}.."
            f"{inside.max():.1f}) | {spread('mean')} | "
            f"{spread('ate', ' cm')} | {spread('rms', ' cm')} | "
            f"{int(col['duplicated'].max())}, "
            f"{int(col['spurious'].max())} | "
            f"{'met' if median >= TARGET_INSIDE else 'not met'} | "
            f"{accurate} of {len(draws)} |")


def parse_args(argv: Optional[List[str]] = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        prog="python tools/odometrydraws.py",
        description=__doc__.split("\n\n")[1].replace("``", ""))
    p.add_argument("clip", help="folder synth wrote (clip.avi, scene.json, "
                                "truth.jsonl, map.json, camera.yml)")
    p.add_argument("--variant", type=int, metavar="N",
                   help="the clip is --variant N with the seed camera")
    p.add_argument("--draws", type=int, default=5, metavar="K",
                   help="odometry logs, seeds 0..K-1 (default 5)")
    p.add_argument("--palette", metavar="FILE",
                   help="palette for labsegment (default: the clip's "
                        "palette.json, the renderer's)")
    p.add_argument("--out", required=True, metavar="DIR",
                   help="logs, runs and their eval.json")
    p.add_argument("--slam", action="append", default=[],
                   metavar="NAME=VALUE",
                   help="a landmarkslam property for every draw, e.g. "
                        "odometry-slip-adapt=false (repeatable)")
    args = p.parse_args(argv)
    for prop in args.slam:
        if not re.fullmatch(r"[a-z][a-z0-9-]*=[^\s!]+", prop):
            p.error(f"--slam {prop!r}: give NAME=VALUE, a landmarkslam "
                    "property and a value without spaces or '!'")
    if args.draws < 1:
        p.error(f"--draws must be >= 1, got {args.draws}")
    if args.variant is not None and args.variant < 0:
        p.error(f"--variant must be >= 0, got {args.variant}")
    return args


def main(argv: Optional[List[str]] = None) -> int:
    args = parse_args(argv)
    palette = args.palette or os.path.join(args.clip, "palette.json")
    try:
        scene, frames = rebuild_scene(args.clip, args.variant)
    except (OSError, ValueError, KeyError) as err:
        print(f"odometrydraws: {err}", file=sys.stderr)
        return 2
    os.makedirs(args.out, exist_ok=True)
    draws = []
    for seed in range(args.draws):
        odometry = os.path.join(args.out, f"odometry-{seed}.jsonl")
        write_odometry(odometry, scene_odometry(scene, frames,
                                                OdometryErrors(), seed=seed))
        d = scores(run_draw(args.clip, palette, odometry,
                            os.path.join(args.out, f"draw-{seed}"),
                            args.slam))
        print(f"draw {seed}: pose NEES inside {d['inside']:.1f} %, mean "
              f"{d['mean']:.2f}, ATE median {d['ate']:.2f} cm, landmark "
              f"RMS {d['rms']:.2f} cm, duplicated {d['duplicated']}, "
              f"spurious {d['spurious']}", flush=True)
        draws.append(d)
    print(HEADER)
    print(summary_row(args.clip, draws))
    return 0


if __name__ == "__main__":
    sys.exit(main())
