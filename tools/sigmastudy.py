"""``python tools/sigmastudy.py``: how well ``ipmrange``'s
``range-sigma`` and ``bearing-sigma`` describe its real errors on rendered
clips (docs/ranging.md, "Uncertainty").

For each sweep clip (``gst-landmark sweep``'s cache, ``out/sweep/clips``:
``SCENARIO-vN-fFRAMES-RENDERER/``) of the chosen half (odd variants are held
out, even ones tune; docs/synth.md): learn the palette from the clip's chart,
run the sweep's default chain (``sweep.chain``) with the ``ipmrange``
properties given by ``--set``, pair every accepted detection with the
rendered truth (``sweep.match_detections``) and tabulate, per detection, the
range error (``range`` - true range) and the bearing error against the
sigmas, binned by apparent diameter (pixels across: the equivalent diameter
of the truth's visible pixels), by true range, by image row and column, and
by whether the border cuts the landmark or a fifth or more of it is hidden.

Per bin: the count, the median and p95 of the absolute error, the median
sigma, the RMS of error / sigma (1 when the sigmas are right) and the share
within two sigma (95 % for Gaussian errors).  ``--json`` writes every
detection's record for further study.
"""

from __future__ import annotations

import argparse
import glob
import json
import math
import os
import re
import sys
from typing import Any, Dict, Iterable, List, Optional, Sequence

import numpy as np

from gstlandmark.devtools import sweep as S
from gstlandmark.commands import evaluate as E

DIAMETER_BINS = (0, 12, 20, 30, 45, 70, 1e9)
RANGE_BINS = (0, 0.5, 1, 1.5, 2, 3, 1e9)
CLIP_NAME = re.compile(r"^(?P<scenario>.+)-v(?P<n>\d+)-f\d+-\w+$")


def clip_folders(clips_dir: str, half: str, scenarios: Sequence[str],
                 renderer: Optional[str] = None) -> List[Dict[str, Any]]:
    """The cached clips of ``half`` (``tune``, ``held-out``, ``all``), one
    per scenario and variant (the given renderer digest, else the newest
    folder)."""
    found: Dict[Any, Dict[str, Any]] = {}
    for folder in sorted(glob.glob(os.path.join(clips_dir, "*"))):
        m = CLIP_NAME.match(os.path.basename(folder))
        if not m or not os.path.exists(os.path.join(folder, "truth.jsonl")):
            continue
        if renderer and not folder.endswith("-" + renderer):
            continue
        sc, n = m.group("scenario"), int(m.group("n"))
        if sc not in scenarios or (half != "all" and S.half_of(n) != half):
            continue
        key = (sc, n)
        if key not in found or os.path.getmtime(folder) > \
                os.path.getmtime(found[key]["folder"]):
            found[key] = {"scenario": sc, "variant": n, "folder": folder}
    return [found[k] for k in sorted(found)]


def run_clip(clip: Dict[str, Any], run_dir: str,
             settings: Sequence[str]) -> str:
    """The sweep's chain on one clip, ``ipmrange`` given ``settings``
    (``name=value``); returns the log's path."""
    from gstlandmark.commands.runner import run_launch
    os.makedirs(run_dir, exist_ok=True)
    palette = S.learn_palette(clip["folder"],
                              os.path.join(run_dir, "palette.json"))
    log = os.path.join(run_dir, "log.jsonl")
    launch = S.chain(clip["folder"], palette, log)
    extra = " ".join(settings)
    if extra:
        launch = launch.replace("ipmrange ", f"ipmrange {extra} ", 1)
    run_launch(launch)
    return log


def records(results: Iterable[Dict[str, Any]],
            truth: Sequence[Dict[str, Any]]) -> List[Dict[str, Any]]:
    """One record per accepted, ranged detection paired with a truth
    landmark."""
    out = []
    by_frame = {f["frame"]: f for f in truth}
    for res in results:
        frame = by_frame.get(res.get("frame"))
        if frame is None:
            continue
        dets = [d for d in res.get("detections", [])
                if E.detection_accepted(d)]
        marks = frame.get("landmarks", [])
        for i, j in S.match_detections(dets, marks):
            rng, mark = dets[i].get("range") or {}, marks[j]
            if "range" not in rng or "range-sigma" not in rng:
                continue
            blob = dets[i].get("blob", {})
            out.append({
                "frame": res["frame"], "id": mark["id"],
                "kind": mark.get("kind"),
                "diameter_px": 2 * math.sqrt(max(mark["pixels"], 0) /
                                             math.pi),
                "major_px": blob.get("ellipse-major"),
                "minor_px": blob.get("ellipse-minor"),
                "u": mark["u"], "v": mark["v"],
                "width": res.get("width"), "height": res.get("height"),
                "cut": bool(mark.get("cut")),
                "occluded": mark.get("occluded_fraction", 0.0) > 0.2,
                "range_true": mark["range"],
                "range_error": rng["range"] - mark["range"],
                "range_sigma": rng["range-sigma"],
                "bearing_error": E.wrap_angle(rng["bearing"] -
                                              mark["bearing"]),
                "bearing_sigma": rng["bearing-sigma"],
                "disagreement": (rng["range-size"] - rng["range-ground"]
                                 if "range-size" in rng else None),
            })
    return out


def bin_stats(recs: Sequence[Dict[str, Any]]) -> Dict[str, Any]:
    """Error and normalised-error figures of a group of records."""
    if not recs:
        return {"n": 0}
    re_ = np.array([r["range_error"] for r in recs])
    rs = np.array([r["range_sigma"] for r in recs])
    be = np.array([r["bearing_error"] for r in recs])
    bs = np.array([r["bearing_sigma"] for r in recs])
    zr, zb = re_ / rs, be / bs
    return {
        "n": len(recs),
        "range_err_p50": float(np.median(np.abs(re_))),
        "range_err_p95": float(np.quantile(np.abs(re_), 0.95)),
        "range_sigma_p50": float(np.median(rs)),
        "range_z_rms": float(np.sqrt(np.mean(zr ** 2))),
        "range_within_2": float(np.mean(np.abs(zr) <= 2)),
        "bearing_err_p50": float(np.median(np.abs(be))),
        "bearing_err_p95": float(np.quantile(np.abs(be), 0.95)),
        "bearing_sigma_p50": float(np.median(bs)),
        "bearing_z_rms": float(np.sqrt(np.mean(zb ** 2))),
        "bearing_within_2": float(np.mean(np.abs(zb) <= 2)),
    }


def _bin(value: float, edges: Sequence[float]) -> str:
    for lo, hi in zip(edges, edges[1:]):
        if lo <= value < hi:
            return f"{lo:g}-{hi:g}" if hi < 1e8 else f">={lo:g}"
    return "?"


def _position(r: Dict[str, Any]) -> str:
    w, h = r.get("width") or 640, r.get("height") or 480
    row = ("top", "middle", "bottom")[min(2, int(3 * r["v"] / h))]
    col = "side" if abs(r["u"] - (w - 1) / 2) > w / 4 else "centre"
    return f"{row} {col}"


def group(recs: Sequence[Dict[str, Any]], key) -> Dict[str, Dict]:
    groups: Dict[str, List[Dict[str, Any]]] = {}
    for r in recs:
        groups.setdefault(key(r), []).append(r)
    return {k: bin_stats(v) for k, v in sorted(groups.items())}


def whole(r: Dict[str, Any]) -> bool:
    return not r["cut"] and not r["occluded"]


def study(recs: Sequence[Dict[str, Any]]) -> Dict[str, Any]:
    """Every table of the study."""
    w = [r for r in recs if whole(r)]
    return {
        "all": bin_stats(recs),
        "state": group(recs, lambda r: "cut" if r["cut"] else
                       ("occluded" if r["occluded"] else "whole")),
        "diameter_px (whole)": group(w, lambda r: _bin(r["diameter_px"],
                                                       DIAMETER_BINS)),
        "range_m (whole)": group(w, lambda r: _bin(r["range_true"],
                                                   RANGE_BINS)),
        "position (whole)": group(w, _position),
        "kind (whole)": group(w, lambda r: r["kind"] or "?"),
    }


def _mm(x): return f"{1000 * x:.2f}"


def format_table(title: str, rows: Dict[str, Dict[str, Any]]) -> str:
    lines = [f"### {title}", "",
             "| bin | n | range err p50 / p95 (mm) | range sigma p50 (mm) | "
             "range err/sigma RMS | within 2 sigma | bearing err p50 / p95 "
             "(mrad) | bearing sigma p50 (mrad) | bearing err/sigma RMS | "
             "within 2 sigma |", "|---" * 10 + "|"]
    for name, s in rows.items():
        if not s.get("n"):
            continue
        lines.append(
            f"| {name} | {s['n']} | {_mm(s['range_err_p50'])} / "
            f"{_mm(s['range_err_p95'])} | {_mm(s['range_sigma_p50'])} | "
            f"{s['range_z_rms']:.2f} | {100 * s['range_within_2']:.1f} % | "
            f"{_mm(s['bearing_err_p50'])} / {_mm(s['bearing_err_p95'])} | "
            f"{_mm(s['bearing_sigma_p50'])} | {s['bearing_z_rms']:.2f} | "
            f"{100 * s['bearing_within_2']:.1f} % |")
    return "\n".join(lines) + "\n"


def format_report(rep: Dict[str, Any], per_clip: Dict[str, Dict]) -> str:
    parts = [format_table("every paired detection", {"all": rep["all"]})]
    for key, rows in rep.items():
        if key != "all":
            parts.append(format_table(key, rows))
    parts.append(format_table("per clip (whole landmarks)", per_clip))
    return "\n".join(parts)


def main(argv: Optional[Sequence[str]] = None) -> int:
    p = argparse.ArgumentParser(
        prog="python tools/sigmastudy.py",
        description=__doc__.split("\n\n")[0])
    p.add_argument("--clips", default=os.path.join(S.DEFAULT_OUT, "clips"),
                   help="folder of the sweep's rendered clips")
    p.add_argument("--renderer", help="renderer digest of the clips to use "
                   "(default: the newest folder per variant)")
    p.add_argument("--half", choices=S.HALVES, default="tune")
    p.add_argument("--scenario", action="append",
                   help="repeatable; default range-sweep, path, distractors")
    p.add_argument("--out", default=os.path.join("out", "sigmastudy"))
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="an ipmrange property for the runs (repeatable)")
    p.add_argument("--reuse", action="store_true",
                   help="read the logs of an earlier run in --out")
    p.add_argument("--json", help="write every record here")
    args = p.parse_args(argv)
    from gstlandmark.landmarklog import read_jsonl
    clips = clip_folders(args.clips, args.half,
                         args.scenario or S.DEFAULT_SCENARIOS, args.renderer)
    if not clips:
        print(f"no clips of the {args.half} half under {args.clips}",
              file=sys.stderr)
        return 1
    recs: List[Dict[str, Any]] = []
    per_clip = {}
    tallies = []
    for clip in clips:
        name = f"{clip['scenario']}-v{clip['variant']}"
        run_dir = os.path.join(args.out, "runs", name)
        log = os.path.join(run_dir, "log.jsonl")
        if not (args.reuse and os.path.exists(log)):
            log = run_clip(clip, run_dir, args.set)
        results = read_jsonl(log)
        truth = read_jsonl(os.path.join(clip["folder"], "truth.jsonl"))
        got = records(results, truth)
        tallies.append(S.score(results, truth))
        for r in got:
            r["clip"] = name
        per_clip[name] = bin_stats([r for r in got if whole(r)])
        recs.extend(got)
    rep = study(recs)
    pose = S.summarise(S.merge(tallies))
    text = format_report(rep, per_clip) + (
        "\ntrilaterate's position error over the frames with three or more "
        f"required landmarks: median {_mm(pose['position_median_m'] or 0)} "
        f"mm, p95 {_mm(pose['position_p95_m'] or 0)} mm, pose on "
        f"{100 * (pose['pose_coverage'] or 0):.1f} % of "
        f"{pose['pose_frames']} frames\n")
    print(text)
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, f"report-{args.half}.md"), "w",
              encoding="utf-8") as f:
        f.write(text)
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(recs, f)
    return 0


if __name__ == "__main__":
    sys.exit(main())
