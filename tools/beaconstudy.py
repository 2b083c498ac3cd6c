"""``python tools/beaconstudy.py``: how well ``beacondetect`` names coded
beacons on rendered clips (docs/beacondetect.md, "Measured").

For each variant N of the chosen half (odd N are held out, even N tune, as
in docs/synth.md), the synthetic world's random variant N (camera, floor,
light, photometry: ``synth.variants.draw_variant("custom", N)``) sees a
field of 20 beacons of 2 bands, every ordered pair of the 5 marker colours
once, scattered around the robot (ranges 0.5-3.5 m, diameters and heights
drawn per variant) from ``--frames`` random headings. The palette is learned
from the clip's chart as a user would (``sweep.learn_palette``), the clip
runs through ``labsegment ! beacondetect map=...``, and every rendered beacon
is scored:

- eligible: at least ``--min-height`` px tall (its truth box), not cut by
  the frame, less than 5 % hidden;
- named: a kept detection with its code whose box centre lies in its box;
- wrong: a kept detection of another code whose box centre lies in it.

Identity is named / (named + wrong) over eligible beacons; recall named /
eligible; false names are kept detections whose centre lies in no rendered
beacon of their code. The floor contact point (``axis-base-x/y``) is
compared with the truth's ``u_front, v_front``, and ``ipmrange``'s ranges of the named
beacons (``range-ground``, ``range-size``, the fused ``range``, with the
variant's camera file) with the truth's range and bearing of the axis;
and, on frames with 3 or more eligible beacons, ``trilaterate``'s pose from
the beacons alone against the truth's.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys

import numpy as np

from gstlandmark import pipeline
from gstlandmark.devtools.sweep import learn_palette
from gstlandmark.synth import Landmark
from gstlandmark.synth.writer import render_scenario

COLOURS = ("red", "green", "yellow", "pink", "blue")


# diameter and height ranges, metres, per kind
SIZES = {"beacon": ((0.06, 0.14), (0.14, 0.32)),
         "cone": ((0.15, 0.30), (0.20, 0.40)),
         "post": ((0.03, 0.05), (0.30, 0.60))}


def layout(n, kind="beacon"):
    """The 20 markers of variant n and its poses' seed."""
    rng = np.random.default_rng([n, 33])
    (d0, d1), (h0, h1) = SIZES[kind]
    diameter = float(rng.uniform(d0, d1))
    height = float(rng.uniform(h0, h1))
    codes = [f"{a}/{b}" for a in COLOURS for b in COLOURS if a != b]
    placed = []
    for k, code in enumerate(codes):
        for _ in range(1000):
            r = float(rng.uniform(0.5, 3.5))
            a = float(rng.uniform(-math.pi, math.pi))
            x, y = r * math.cos(a), r * math.sin(a)
            if all(math.hypot(x - p.x, y - p.y) > 0.45 for p in placed):
                break
        placed.append(Landmark(f"B{k + 1}", code, x, y, diameter,
                               kind=kind, height=height))
    return placed, rng


def render(n, frames, out, kind="beacon"):
    folder = os.path.join(out, f"v{n}-f{frames}" + (
        "" if kind == "beacon" else f"-{kind}"))
    if not os.path.exists(os.path.join(folder, "truth.jsonl")):
        beacons, rng = layout(n, kind)
        poses = [(float(rng.uniform(-0.1, 0.1)), float(rng.uniform(-0.1, 0.1)),
                  float(rng.uniform(-math.pi, math.pi)))
                 for _ in range(frames)]
        render_scenario("custom", folder, frames=frames, variant=n,
                        map=beacons, poses=poses, progress=False,
                        odometry=False)
    return folder


def frames_of(clip):
    import cv2
    cap = cv2.VideoCapture(clip)
    while True:
        ok, frame = cap.read()
        if not ok:
            break
        yield frame


def inside(box, u, v, margin=1.0):
    return (box[0] - margin <= u <= box[2] + margin and
            box[1] - margin <= v <= box[3] + margin)


def empty():
    return dict(eligible=0, named=0, wrong=0, false=0, partial=0,
                base_err=[], height_err=[], ground=[], size=[], fused=[],
                bearing=[], z=[], pose_frames=0, posed=0, pose_err=[])


def score(folder, palette, min_height, extra=""):
    with open(os.path.join(folder, "truth.jsonl"), encoding="utf-8") as f:
        truth = [json.loads(line) for line in f]
    map_file = os.path.join(folder, "map.json")
    chain = (f"labsegment palette={palette} ! beacondetect "
             f"map={map_file} {extra} ! ipmrange calibration="
             f"{os.path.join(folder, 'camera.yml')} map={map_file} "
             f"range-method=fused ! trilaterate map={map_file}")
    s = empty()
    for res, t in zip(pipeline.frames_through(
            chain, frames_of(os.path.join(folder, "clip.avi"))), truth):
        kept = [d for d in res.detections if d.blob.get("kept")]
        s["partial"] += sum(1 for d in res.detections
                            if d.blob.get("reject-reason") == "partial")
        marks = [m for m in t["landmarks"] if m.get("code")]
        whole = [m for m in marks if not m["cut"] and
                 m["occluded_fraction"] < 0.05 and
                 m["box"][3] - m["box"][1] >= min_height]
        if len(whole) >= 3:
            s["pose_frames"] += 1
            if res.pose is not None:
                s["posed"] += 1
                s["pose_err"].append(math.hypot(
                    res.pose.x - t["robot"]["x"], res.pose.y - t["robot"]["y"]))
        for d in kept:
            x, y, w, h = d.bbox
            cu, cv = x + (w - 1) / 2, y + (h - 1) / 2
            if not any(m["code"] == d.class_name and inside(m["box"], cu, cv)
                       for m in marks):
                s["false"] += 1
        for m in marks:
            box = m["box"]
            if m["cut"] or m["occluded_fraction"] >= 0.05 or \
                    box[3] - box[1] < min_height:
                continue
            s["eligible"] += 1
            hits = [d for d in kept if inside(
                box, d.bbox[0] + (d.bbox[2] - 1) / 2,
                d.bbox[1] + (d.bbox[3] - 1) / 2)]
            right = [d for d in hits if d.class_name == m["code"]]
            if right:
                s["named"] += 1
                b = right[0].blob
                s["base_err"].append(math.hypot(
                    b["axis-base-x"] - m["u_front"],
                    b["axis-base-y"] - m["v_front"]))
                s["height_err"].append(b["height-px"] - (box[3] - box[1]))
                r = right[0].range
                if "range" in r:
                    for key, field in (("ground", "range-ground"),
                                       ("size", "range-size"),
                                       ("fused", "range")):
                        if field in r:
                            s[key].append(r[field] / m["range"] - 1)
                    s["bearing"].append(r["bearing"] - m["bearing"])
                    s["z"].append((r["range"] - m["range"]) /
                                  r["range-sigma"])
            elif hits:
                s["wrong"] += 1
    return s


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--half", choices=("tune", "held-out"), required=True)
    ap.add_argument("--variants", type=int, default=8,
                    help="how many variants of the half (default 8)")
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--min-height", type=float, default=20.0)
    ap.add_argument("--set", default="", help="beacondetect properties")
    ap.add_argument("--kind", choices=sorted(SIZES), default="beacon",
                    help="the 20 markers' kind (default beacon)")
    ap.add_argument("--out", default="out/beaconstudy")
    args = ap.parse_args(argv)
    first = 2 if args.half == "tune" else 1
    total = empty()
    for n in range(first, first + 2 * args.variants, 2):
        folder = render(n, args.frames, args.out, args.kind)
        palette = learn_palette(folder, os.path.join(folder, "learned.json"))
        s = score(folder, palette, args.min_height, args.set)
        for k in total:
            total[k] += s[k]
        print(f"v{n}: eligible {s['eligible']} named {s['named']} wrong "
              f"{s['wrong']} false {s['false']} partial {s['partial']}",
              flush=True)
    e, named, wrong = total["eligible"], total["named"], total["wrong"]
    print(f"{args.half}: {e} eligible beacon views (>= {args.min_height} px "
          f"tall, uncut, < 5 % hidden)")
    print(f"  recall {100 * named / max(e, 1):.1f} % ({named}), identity "
          f"{100 * named / max(named + wrong, 1):.2f} % ({wrong} wrong), "
          f"false names {total['false']}, partial candidates "
          f"{total['partial']}")
    if total["base_err"]:
        print(f"  floor contact vs u/v_front: median "
              f"{np.median(total['base_err']):.2f} px, p95 "
              f"{np.percentile(total['base_err'], 95):.2f} px; height-px - "
              f"truth box height: median "
              f"{np.median(total['height_err']):.2f} px")
    for key in ("ground", "size", "fused"):
        err = np.abs(total[key])
        if len(err):
            print(f"  range {key}: {len(err)} named views, |error| median "
                  f"{100 * np.median(err):.2f} %, p95 "
                  f"{100 * np.percentile(err, 95):.2f} %")
    if total["bearing"]:
        b = np.degrees(np.abs(total["bearing"]))
        z = np.asarray(total["z"])
        print(f"  bearing |error| median {np.median(b):.3f} deg, p95 "
              f"{np.percentile(b, 95):.3f} deg; fused range error / "
              f"range-sigma: RMS {np.sqrt(np.mean(z * z)):.2f}, within 2 "
              f"sigma {100 * np.mean(np.abs(z) < 2):.1f} %")
    if total["pose_frames"]:
        err = np.asarray(total["pose_err"])
        print(f"  pose from beacons alone (trilaterate): {total['posed']} of "
              f"{total['pose_frames']} frames with 3+ beacons in view "
              f"({100 * total['posed'] / total['pose_frames']:.1f} %)"
              + (f", position error median {100 * np.median(err):.2f} cm, "
                 f"p95 {100 * np.percentile(err, 95):.2f} cm"
                 if len(err) else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
