"""``gst-landmark evaluate RESULT.jsonl truth.jsonl``: accuracy of a
``landmarklog`` file against the ground truth of a synthetic clip.

- Detections: a detection matches a visible truth landmark of its class
  when its centroid lies within ``--match-px`` pixels of the landmark's
  pixel centroid (nearest pairs first, one to one). Truth landmarks
  smaller than ``--min-pixels`` are neither required nor held against a
  detection that finds them; so are landmarks cut by the image border
  (``--require-cut`` requires them too): their blobs are not whole discs.
  Precision and recall per class, and by distance band of the truth
  range.
- Range and bearing of matched detections that carry ``landmark-range``:
  error statistics (median, p95, max) by distance band.
- Pose, on frames that have one: position and heading error statistics,
  overall and by solver, by the number of landmarks the truth shows
  (``--visible-px``: at least that many pixels, as ``synth`` counts them)
  and by the number of landmarks the pose used; how many frames with that
  many landmarks visible got a pose.
- Free floor, when the log has ``floor`` (``floorboundary``) and the
  truth has ``floor`` (a scene with walls or ``--obstacles``): every bin
  the element saw against the truth's free range (capped at the element's
  ``max-range``): the share within 3 % or 3 cm, the relative errors, and
  obstacles reported where the floor is free or missed where it is not.
- SLAM (``landmarkslam``), when the log carries the landmark map
  (``landmark_map``; or ``--map-estimate`` names the map it wrote) and
  the true map is known (``--map``, default ``map.json`` beside the
  truth): the estimated map's confirmed landmarks paired with the true
  ones (same class, nearest after the best rigid alignment, one to one,
  within ``--map-gate``), duplicated, spurious and missed landmarks, the
  position error per landmark and RMS after the alignment, and without
  it when the map was anchored (an estimated id is a true id); the
  absolute trajectory error (positions after the best rigid alignment of
  the path, none when anchored) and heading error, also over the frames
  bridged on fewer than 3 landmarks; the NEES of the pose
  (3 dof) and of the landmarks at the end (2 dof) against the two-sided
  95 % chi-square intervals, in the estimator's frame (the first pose
  placed on the true first pose, or the map's when anchored).
- ``--plot OUT.png``: a top-down trajectory plot (truth against estimate,
  with the map's landmarks), drawn with OpenCV.
"""

from __future__ import annotations

import json
import math
import os
import sys
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..landmarklog import LogError, read_jsonl
from ..landmarkmap import read_map
from ..trajectory import (CHI2_95, Rigid2D, align_rigid, associate_map,
                          nearest_first, nees, nees_summary, pose_transform,
                          wrap_angle)
from .common import add_json_option
from .evalimages import add_image_options
from .evalimages import handle as evaluate_images

DEFAULT_BANDS = (0.0, 1.0, 2.0, 3.0, 4.0, 5.0)


@dataclass
class Counts:
    tp: int = 0
    fp: int = 0
    fn: int = 0

    @property
    def precision(self) -> Optional[float]:
        n = self.tp + self.fp
        return self.tp / n if n else None

    @property
    def recall(self) -> Optional[float]:
        n = self.tp + self.fn
        return self.tp / n if n else None

    def as_dict(self) -> Dict[str, Any]:
        return {"tp": self.tp, "fp": self.fp, "fn": self.fn,
                "precision": self.precision, "recall": self.recall}


@dataclass
class Evaluation:
    frames: int = 0
    by_class: Dict[str, Counts] = field(default_factory=dict)
    by_band: Dict[str, Counts] = field(default_factory=dict)
    range_errors: List[Tuple[float, float, float]] = field(
        default_factory=list)       # (truth range, range error, bearing err)
    pose_errors: List[Tuple[str, float, float]] = field(
        default_factory=list)       # (solver, position err, heading err)
    frames_with_pose: int = 0
    # one per truth frame: visible landmarks, and the pose when there is one
    pose_rows: List[Dict[str, Any]] = field(default_factory=list)
    # one per seen bearing bin: (reported range, true free range capped
    # at max-range, state, true free range, max-range)
    floor_bins: List[Tuple[float, float, int, float, float]] = field(
        default_factory=list)


def band_name(value: Optional[float], bands: Sequence[float]) -> str:
    if value is None:
        return "unknown"
    for lo, hi in zip(bands, bands[1:]):
        if lo <= value < hi:
            return f"{lo:g}-{hi:g} m"
    return f">={bands[-1]:g} m" if value >= bands[-1] else f"<{bands[0]:g} m"


# landmark-match reasons that mean the map's consensus rejected it
REJECTED_MATCH_REASONS = ("outlier", "outside-gate")


def detection_accepted(det: Dict[str, Any]) -> bool:
    """Whether a landmarklog detection counts as a detection.

    When the chain decides (``accepted`` present), its word holds;
    otherwise a blob that ``blobroundness`` did not keep is a rejected
    candidate.  Either way a range that ``ipmrange`` did not keep, or a
    match that ``trilaterate`` rejected as an outlier or outside its
    gate, rejects it."""
    if "accepted" in det:
        if not det.get("accepted"):
            return False
    elif not det.get("blob", {}).get("kept", True):
        return False
    rng = det.get("range")
    if isinstance(rng, dict) and rng.get("kept") is False:
        return False
    match = det.get("match")
    if isinstance(match, dict) and \
            match.get("reason") in REJECTED_MATCH_REASONS:
        return False
    return True


def detection_centre(det: Dict[str, Any]) -> Tuple[float, float]:
    """Where the chain places the landmark in the image: the blob's
    centroid, or for a blob accepted as part of a ball by its rim
    (shape-evidence arc) that ball's circle, which ranging uses too."""
    blob = det.get("blob", {})
    if blob.get("shape-evidence") == "arc" and "ellipse-x" in blob:
        return blob["ellipse-x"], blob["ellipse-y"]
    if "centroid-x" in blob and "centroid-y" in blob:
        return blob["centroid-x"], blob["centroid-y"]
    x, y, w, h = det["bbox"]
    # bbox covers pixels x..x+w-1: its centre in pixel-centre coordinates
    return x + (w - 1) / 2.0, y + (h - 1) / 2.0


def match_frame(dets: Sequence[Dict[str, Any]],
                truth: Sequence[Dict[str, Any]], match_px: float,
                gate=None) -> List[Tuple[int, int]]:
    """One-to-one pairs (detection index, truth index) of the same class
    within match_px (or ``gate(truth landmark)`` pixels), nearest first."""
    pairs = []
    for i, d in enumerate(dets):
        du, dv = detection_centre(d)
        for j, t in enumerate(truth):
            if t["class"] != d.get("class"):
                continue
            dist = math.hypot(du - t["u"], dv - t["v"])
            if dist <= (gate(t) if gate else match_px):
                pairs.append((dist, i, j))
    return nearest_first(pairs)


def required(mark: Dict[str, Any], min_pixels: float,
             require_cut: bool) -> bool:
    """Whether a visible truth landmark must be found."""
    return (mark.get("pixels", 0) >= min_pixels
            and (require_cut or not mark.get("cut", False)))


def visible_group(n: int) -> str:
    return "3+" if n >= 3 else str(n)


def evaluate(results: List[Dict[str, Any]], truth: List[Dict[str, Any]],
             match_px: float = 4.0, min_pixels: float = 20.0,
             bands: Sequence[float] = DEFAULT_BANDS,
             require_cut: bool = False,
             visible_px: float = 150.0) -> Evaluation:
    ev = Evaluation()
    truth_by_frame = {t["frame"]: t for t in truth}
    for res in results:
        t = truth_by_frame.get(res.get("frame"))
        if t is None:
            continue
        ev.frames += 1
        # the chain's verdict (landmarklog "accepted"); older logs: blob
        dets = [d for d in res.get("detections", [])
                if detection_accepted(d)]
        marks = t.get("landmarks", [])
        pairs = match_frame(dets, marks, match_px)
        matched_d = {i for i, _ in pairs}
        matched_t = {j for _, j in pairs}

        def count(cls, rng, kind):
            for key, table in ((cls, ev.by_class),
                               (band_name(rng, bands), ev.by_band)):
                c = table.setdefault(key, Counts())
                setattr(c, kind, getattr(c, kind) + 1)

        for i, j in pairs:
            mark = marks[j]
            if not required(mark, min_pixels, require_cut):
                continue   # found a landmark it need not find
            count(mark["class"], mark.get("range"), "tp")
            rng = dets[i].get("range", {})
            if "range" in rng and "range" in mark:
                ev.range_errors.append((
                    mark["range"], rng["range"] - mark["range"],
                    wrap_angle(rng.get("bearing", math.nan) -
                               mark.get("bearing", math.nan))))
        for i, d in enumerate(dets):
            if i not in matched_d:
                count(d["class"], d.get("range", {}).get("range"), "fp")
        for j, mark in enumerate(marks):
            if j not in matched_t and required(mark, min_pixels,
                                               require_cut):
                count(mark["class"], mark.get("range"), "fn")

        floor, free = res.get("floor"), t.get("floor")
        if floor and free and floor.get("bearing-bins") == \
                free.get("bearing-bins"):
            max_range = float(floor.get("max-range", math.inf))
            for got, state, want in zip(floor.get("range", []),
                                        floor.get("state", []),
                                        free.get("free-range", [])):
                if state == 0 or got is None:
                    continue        # not seen
                want = math.inf if want is None else float(want)
                ev.floor_bins.append((float(got), min(want, max_range),
                                      int(state), want, max_range))

        pose = res.get("pose")
        if "robot" in t:
            robot = t["robot"]
            row: Dict[str, Any] = {
                "frame": t["frame"], "truth": robot,
                "visible": sum(1 for m in marks
                               if m.get("pixels", 0) >= visible_px)}
            if pose is not None:
                row.update(
                    pose=pose, solver=str(pose.get("solver", "")),
                    used=int(pose.get("n-landmarks", 0)),
                    position=math.hypot(pose["x"] - robot["x"],
                                        pose["y"] - robot["y"]),
                    heading=wrap_angle(pose["heading"] - robot["heading"]))
            ev.pose_rows.append(row)
        if pose is not None and "robot" in t:
            ev.frames_with_pose += 1
            ev.pose_errors.append((row["solver"], row["position"],
                                   row["heading"]))
    return ev


def stats(values: Sequence[float]) -> Dict[str, Any]:
    a = np.abs(np.asarray([v for v in values if not math.isnan(v)], float))
    if a.size == 0:
        return {"n": 0}
    return {"n": int(a.size), "median": float(np.median(a)),
            "p95": float(np.percentile(a, 95)), "max": float(a.max())}


def summary(ev: Evaluation, bands: Sequence[float] = DEFAULT_BANDS
            ) -> Dict[str, Any]:
    ranges: Dict[str, Dict[str, Any]] = {}
    keys = sorted({band_name(r, bands) for r, _, _ in ev.range_errors})
    for key in keys:
        sel = [(r, e, b) for r, e, b in ev.range_errors
               if band_name(r, bands) == key]
        ranges[key] = {
            "range_m": stats([e for _, e, _ in sel]),
            "range_rel": stats([e / r for r, e, _ in sel if r > 0]),
            "bearing_deg": stats([math.degrees(b) for _, _, b in sel]),
        }
    poses: Dict[str, Dict[str, Any]] = {}
    solvers = sorted({s for s, _, _ in ev.pose_errors})
    for solver in ["all"] + solvers:
        sel = [(p, h) for s, p, h in ev.pose_errors
               if solver in ("all", s)]
        poses[solver] = {"position_m": stats([p for p, _ in sel]),
                         "heading_deg": stats([math.degrees(h)
                                               for _, h in sel])}
    by_visible: Dict[str, Dict[str, Any]] = {}
    by_used: Dict[str, Dict[str, Any]] = {}
    for key in ("3+", "2", "1", "0"):
        rows = [r for r in ev.pose_rows
                if visible_group(r["visible"]) == key]
        if not rows:
            continue
        posed = [r for r in rows if "pose" in r]
        by_visible[key] = {
            "frames": len(rows), "with_pose": len(posed),
            "position_m": stats([r["position"] for r in posed]),
            "heading_deg": stats([math.degrees(r["heading"])
                                  for r in posed])}
    for key in ("3+", "2", "1", "0"):
        posed = [r for r in ev.pose_rows
                 if "pose" in r and visible_group(r["used"]) == key]
        if posed:
            by_used[key] = {
                "position_m": stats([r["position"] for r in posed]),
                "heading_deg": stats([math.degrees(r["heading"])
                                      for r in posed])}
    total = Counts()
    for c in ev.by_class.values():
        total.tp, total.fp, total.fn = (total.tp + c.tp, total.fp + c.fp,
                                        total.fn + c.fn)
    out_floor: Dict[str, Any] = {}
    if ev.floor_bins:
        def tol(want):
            return max(0.03 * want, 0.03)
        ok = [abs(g - w) <= tol(w) for g, w, _, _, _ in ev.floor_bins]
        out_floor = {
            "bins": len(ev.floor_bins),
            "within_3pct_or_3cm": sum(ok) / len(ok),
            "error_rel": stats([(g - w) / w for g, w, _, _, _
                                in ev.floor_bins if w > 0]),
            # an obstacle where the floor is free to max-range, and free
            # floor reported beyond a true obstacle
            "false_obstacles": sum(1 for g, w, st, raw, mr in ev.floor_bins
                                   if st == 2 and raw > mr + tol(mr)),
            "missed_obstacles": sum(1 for g, w, st, raw, mr in ev.floor_bins
                                    if st != 2 and g - w > tol(w)),
        }
    return {
        "frames": ev.frames,
        **({"floor": out_floor} if out_floor else {}),
        "detection": {"all": total.as_dict(),
                      "by_class": {k: v.as_dict()
                                   for k, v in sorted(ev.by_class.items())},
                      "by_band": {k: v.as_dict()
                                  for k, v in sorted(ev.by_band.items())}},
        "range": ranges,
        "pose": {"frames_with_pose": ev.frames_with_pose, **poses},
        "pose_by_visible": by_visible,
        "pose_by_used": by_used,
    }


def _pct(x: Optional[float]) -> str:
    return "   -  " if x is None else f"{100 * x:6.2f}"


def format_report(s: Dict[str, Any]) -> str:
    lines = [f"frames evaluated: {s['frames']}", "",
             "detections        tp     fp     fn  precision%  recall%"]
    det = s["detection"]
    for name, c in list(det["by_class"].items()) + [("all", det["all"])] + \
            [(f"band {k}", v) for k, v in det["by_band"].items()]:
        lines.append(f"{name:14s} {c['tp']:5d}  {c['fp']:5d}  {c['fn']:5d}"
                     f"     {_pct(c['precision'])}   {_pct(c['recall'])}")
    if s["range"]:
        lines += ["", "range (matched)   n   |err| m median  p95    max   "
                  "rel% median  p95   bearing deg median  p95    max"]
        for band, r in s["range"].items():
            m, rel, b = r["range_m"], r["range_rel"], r["bearing_deg"]
            lines.append(
                f"{band:14s} {m['n']:4d}   {m['median']:.4f}  {m['p95']:.4f}"
                f" {m['max']:.4f}   {100 * rel.get('median', 0):6.2f} "
                f"{100 * rel.get('p95', 0):6.2f}"
                f"     {b.get('median', math.nan):7.3f} "
                f"{b.get('p95', math.nan):7.3f} {b.get('max', math.nan):7.3f}")
    pose = s["pose"]
    if pose["frames_with_pose"]:
        lines += ["", f"pose: {pose['frames_with_pose']} of {s['frames']} "
                  "frames", "solver            n   position m median  p95   "
                  "max    heading deg median  p95    max"]
        for solver, p in pose.items():
            if solver == "frames_with_pose":
                continue
            pm, h = p["position_m"], p["heading_deg"]
            if pm["n"]:
                lines.append(
                    f"{solver:14s} {pm['n']:4d}   {pm['median']:.4f} "
                    f"{pm['p95']:.4f} {pm['max']:.4f}   {h['median']:7.3f} "
                    f"{h['p95']:7.3f} {h['max']:7.3f}")
    for title, key, first in (
            ("landmarks visible", "pose_by_visible", "frames  posed  "),
            ("landmarks used", "pose_by_used", "")):
        table = s.get(key) or {}
        if not table:
            continue
        lines += ["", f"pose by {title:17s} {first}n   position m median  "
                  "p95    max    heading deg median  p95    max"]
        for group, p in table.items():
            pm, h = p["position_m"], p["heading_deg"]
            head = f"{group:>4s}" + " " * 22
            if first:
                head = (f"{group:>4s}" + " " * 18 +
                        f"{p['frames']:6d} {p['with_pose']:6d}  ")
            if pm["n"]:
                lines.append(
                    f"{head}{pm['n']:4d}   {pm['median']:.4f} "
                    f"{pm['p95']:.4f} {pm['max']:.4f}   {h['median']:7.3f} "
                    f"{h['p95']:7.3f} {h['max']:7.3f}")
            else:
                lines.append(f"{head}   0")
    fl = s.get("floor")
    if fl:
        e = fl["error_rel"]
        lines += ["", f"free floor: {fl['bins']} seen bearing bins, "
                  f"{100 * fl['within_3pct_or_3cm']:.1f} % within 3 % or "
                  f"3 cm; |error| rel% median "
                  f"{100 * e.get('median', 0):.2f} p95 "
                  f"{100 * e.get('p95', 0):.2f} max "
                  f"{100 * e.get('max', 0):.2f}; false obstacles "
                  f"{fl['false_obstacles']}, missed obstacles "
                  f"{fl['missed_obstacles']}"]
    return "\n".join(lines)


# -- SLAM: map error, trajectory error, consistency --------------------------

def estimated_map(results: Sequence[Dict[str, Any]]
                  ) -> Optional[List[Dict[str, Any]]]:
    """The last ``landmark_map`` of a landmarklog file (landmarkslam's map
    meta at the end of the run) as landmarks with ``id``, ``class``,
    ``x``, ``y``, ``covariance`` (4, row-major), ``confirmed``; None when
    the log has none."""
    for res in reversed(results):
        f = res.get("landmark_map")
        if f is None:
            continue
        cov = f.get("covariance") or []
        return [{"id": f["ids"][i], "class": f["classes"][i],
                 "x": float(f["x"][i]), "y": float(f["y"][i]),
                 "covariance": (list(cov[4 * i:4 * i + 4])
                                if len(cov) >= 4 * i + 4 else None),
                 "confirmed": bool(f["confirmed"][i])
                 if "confirmed" in f else True}
                for i in range(len(f["ids"]))]
    return None


def map_file_estimate(path: str) -> List[Dict[str, Any]]:
    """The map landmarkslam wrote with ``map-out`` (all confirmed), with
    the ``covariance`` it keeps as an extra key."""
    marks = read_map(path)
    with open(path, encoding="utf-8") as f:
        extra = {e.get("id"): e for e in json.load(f)["landmarks"]}
    return [dict(lm, confirmed=True,
                 covariance=extra[lm["id"]].get("covariance"))
            for lm in marks]


def error_stats(values: Sequence[float]) -> Dict[str, Any]:
    """Median, p95, RMS and max of absolute errors."""
    a = np.abs(np.asarray(values, float))
    if a.size == 0:
        return {"n": 0}
    return {"n": int(a.size), "median": float(np.median(a)),
            "p95": float(np.percentile(a, 95)),
            "rms": float(np.sqrt(np.mean(a ** 2))), "max": float(a.max())}


def _transform_dict(tf: Rigid2D) -> Dict[str, float]:
    return {"angle_deg": math.degrees(tf.angle), "x": tf.tx, "y": tf.ty}


# A pose paired with fewer landmarks than this has no fix of its own.
FIX_LANDMARKS = 3


def slam_evaluation(results: Sequence[Dict[str, Any]],
                    truth: Sequence[Dict[str, Any]],
                    true_map: Sequence[Dict[str, Any]] = (),
                    est_map: Optional[List[Dict[str, Any]]] = None,
                    anchored: Optional[bool] = None,
                    gate: float = 0.3, min_pixels: float = 20.0
                    ) -> Optional[Dict[str, Any]]:
    """Map error, absolute trajectory error and NEES of a SLAM run (see
    the module's description); None when there is no estimated map."""
    if est_map is None:
        est_map = estimated_map(results)
    if est_map is None:
        return None
    true_ids = {lm["id"] for lm in true_map}
    if anchored is None:
        anchored = any(lm["id"] in true_ids for lm in est_map)
    robots = {t["frame"]: t["robot"] for t in truth if "robot" in t}
    rows = [(res["pose"], robots[res["frame"]]) for res in results
            if res.get("pose") is not None and res.get("frame") in robots]
    out: Dict[str, Any] = {"anchored": anchored}

    # trajectory: the best rigid alignment of the path, none when anchored
    est_xy = np.array([[p["x"], p["y"]] for p, _ in rows]).reshape(-1, 2)
    true_xy = np.array([[r["x"], r["y"]] for _, r in rows]).reshape(-1, 2)
    path_tf = Rigid2D() if anchored else align_rigid(est_xy, true_xy)
    moved = path_tf.apply(est_xy)
    pos_err = np.hypot(*(moved - true_xy).T) if len(rows) else np.zeros(0)
    # frames the estimator bridged on fewer landmarks than a fix needs:
    # its motion model or odometry carried the pose
    few = [k for k, (p, _) in enumerate(rows)
           if int(p.get("n-landmarks", 0)) < FIX_LANDMARKS]
    out["trajectory"] = {
        "frames": len(rows), "aligned": not anchored,
        "transform": _transform_dict(path_tf),
        "position_m": error_stats(pos_err),
        "heading_deg": error_stats([math.degrees(wrap_angle(
            p["heading"] + path_tf.angle - r["heading"])) for p, r in rows]),
        "few_landmarks": {"below": FIX_LANDMARKS, "frames": len(few),
                          "position_m": error_stats(pos_err[few])}}

    # the estimator's frame: the map's when anchored, else its first pose
    # is its origin (docs/landmarkslam.md), so put it on the true first pose
    frame_tf = Rigid2D() if anchored or not rows else \
        pose_transform(rows[0][0], rows[0][1])
    to_est = frame_tf.inverse()
    pose_nees = []
    for p, r in rows:
        cov = p.get("covariance")
        if not cov or len(cov) != 9:
            pose_nees.append(None)
            continue
        q = to_est.apply([r["x"], r["y"]])[0]
        err = [p["x"] - q[0], p["y"] - q[1],
               wrap_angle(p["heading"] - (r["heading"] - frame_tf.angle))]
        pose_nees.append(nees(err, cov))
    out["nees"] = {"frame": "map" if anchored else "first pose",
                   "pose": nees_summary(pose_nees, 3)}

    confirmed = [lm for lm in est_map if lm.get("confirmed", True)]
    out["map"] = {"estimated": len(confirmed),
                  "tentative": len(est_map) - len(confirmed),
                  "true": len(true_map)}
    if not true_map:
        return out
    seen = {m.get("id") for t in truth for m in t.get("landmarks", [])
            if m.get("pixels", 0) >= min_pixels}
    e_xy = [[lm["x"], lm["y"]] for lm in confirmed]
    e_cls = [lm["class"] for lm in confirmed]
    t_xy = np.array([[lm["x"], lm["y"]] for lm in true_map])
    t_cls = [lm["class"] for lm in true_map]
    match = associate_map(e_xy, e_cls, t_xy, t_cls, gate,
                          initial=path_tf if rows else None)
    aligned = match.transform.apply(e_xy) if e_xy else np.zeros((0, 2))
    plain = None
    if anchored:
        plain = associate_map(e_xy, e_cls, t_xy, t_cls, gate, align=False)
    plain_err = {i: float(np.hypot(*(np.asarray(e_xy[i]) - t_xy[j])))
                 for i, j in (plain.pairs if plain else [])}
    marks, lm_nees = [], []
    for i, j in match.pairs:
        lm = confirmed[i]
        entry = {"id": lm["id"], "true_id": true_map[j]["id"],
                 "class": lm["class"],
                 "error_m": float(np.hypot(*(aligned[i] - t_xy[j])))}
        if i in plain_err:
            entry["error_unaligned_m"] = plain_err[i]
        cov = lm.get("covariance")
        if cov and len(cov) == 4:
            q = to_est.apply(t_xy[j])[0]
            entry["nees"] = nees([lm["x"] - q[0], lm["y"] - q[1]], cov)
            lm_nees.append(entry["nees"])
        marks.append(entry)

    def ids(indices, source):
        return [source[k]["id"] for k in indices]

    out["map"].update({
        "seen": len(seen & true_ids), "paired": len(match.pairs),
        "duplicated": ids(match.duplicated, confirmed),
        "spurious": ids(match.spurious, confirmed),
        "missed": ids(match.missed, true_map),
        "missed_seen": [true_map[j]["id"] for j in match.missed
                        if true_map[j]["id"] in seen],
        "aligned": dict(error_stats([m["error_m"] for m in marks]),
                        transform=_transform_dict(match.transform)),
        "landmarks": marks})
    if plain is not None:
        out["map"]["unaligned"] = error_stats(list(plain_err.values()))
    out["nees"]["landmarks"] = nees_summary(lm_nees, 2)
    return out


def _cm(st: Dict[str, Any], key: str) -> str:
    return f"{100 * st[key]:.2f}" if st.get("n") else "-"


def format_slam(s: Dict[str, Any]) -> str:
    tr = s["trajectory"]
    lines = ["", f"SLAM ({'anchored map' if s['anchored'] else 'no anchor'})"
             f": trajectory over {tr['frames']} frames with a pose, "
             + ("after the best rigid alignment" if tr["aligned"]
                else "as estimated (no alignment)")]
    pm, hd = tr["position_m"], tr["heading_deg"]
    if pm.get("n"):
        lines.append(f"  ATE cm median {_cm(pm, 'median')} p95 "
                     f"{_cm(pm, 'p95')} RMS {_cm(pm, 'rms')} max "
                     f"{_cm(pm, 'max')}; heading deg median "
                     f"{hd['median']:.3f} p95 {hd['p95']:.3f} max "
                     f"{hd['max']:.3f}")
    few = tr.get("few_landmarks")
    if few and few["frames"]:
        fm = few["position_m"]
        lines.append(f"  {few['frames']} frames bridged on fewer than "
                     f"{few['below']} landmarks: ATE cm median "
                     f"{_cm(fm, 'median')} p95 {_cm(fm, 'p95')} max "
                     f"{_cm(fm, 'max')}")
    m = s["map"]
    lines.append(f"  map: {m['estimated']} confirmed ({m['tentative']} "
                 f"tentative), {m['true']} true")
    if "paired" in m:
        al = m["aligned"]
        lines.append(
            f"  paired {m['paired']}, duplicated {len(m['duplicated'])} "
            f"{m['duplicated'] or ''}, spurious {len(m['spurious'])} "
            f"{m['spurious'] or ''}, missed {len(m['missed'])} (of them "
            f"seen {len(m['missed_seen'])} {m['missed_seen'] or ''})")
        lines.append(f"  landmark error cm after alignment: RMS "
                     f"{_cm(al, 'rms')} median {_cm(al, 'median')} max "
                     f"{_cm(al, 'max')}")
        if "unaligned" in m:
            un = m["unaligned"]
            lines.append(f"  landmark error cm without alignment: RMS "
                         f"{_cm(un, 'rms')} median {_cm(un, 'median')} max "
                         f"{_cm(un, 'max')}")
        for lm in m["landmarks"]:
            extra = "" if lm.get("nees") is None else \
                f"  NEES {lm['nees']:.2f}"
            lines.append(f"    {lm['id']:>6s} -> {lm['true_id']:<6s} "
                         f"{lm['class']:8s} {100 * lm['error_m']:6.2f} cm"
                         + extra)
    for key, dof in (("pose", 3), ("landmarks", 2)):
        n = s["nees"].get(key)
        if not n or not n["n"]:
            continue
        lo, hi = CHI2_95[dof]
        lines.append(
            f"  NEES {key} ({dof} dof, {s['nees']['frame']} frame): "
            f"{n['n']} values, mean {n['mean']:.2f}, "
            f"{100 * n['inside']:.1f} % inside [{lo:g}, {hi:g}], "
            f"{100 * n['below_one_sided']:.1f} % <= "
            f"{n['one_sided_bound']:g}"
            + (f" ({n['not_computed']} without a covariance)"
               if n["not_computed"] else ""))
    return "\n".join(lines)


# -- trajectory plot ---------------------------------------------------------

SOLVER_BGR = {"lsq": (200, 90, 20), "two": (0, 140, 255), "one": (40, 40, 220),
              "ekf": (150, 150, 150)}
CLASS_BGR = {"red": (47, 62, 169), "green": (112, 225, 133),
             "yellow": (98, 245, 228), "pink": (180, 105, 254),
             "blue": (200, 80, 30)}


def plot_trajectory(ev: Evaluation, out_png: str,
                    landmarks: Sequence[Dict[str, Any]] = (),
                    class_bgr: Optional[Dict[str, Tuple[int, int, int]]]
                    = None, size_px: int = 900) -> None:
    """Top-down plot: the map's landmarks, the true path (black line) and
    the estimated positions (dots coloured by solver, a short line for the
    heading), metres with a 1 m grid. Written as PNG with OpenCV."""
    import cv2

    colours = dict(CLASS_BGR)
    colours.update(class_bgr or {})
    pts = [(r["truth"]["x"], r["truth"]["y"]) for r in ev.pose_rows]
    pts += [(lm["x"], lm["y"]) for lm in landmarks]
    if not pts:
        raise ValueError("nothing to plot: no truth poses and no map")
    xs, ys = [p[0] for p in pts], [p[1] for p in pts]
    margin = 0.5
    x0, x1 = min(xs) - margin, max(xs) + margin
    y0, y1 = min(ys) - margin, max(ys) + margin
    scale = (size_px - 80) / max(x1 - x0, y1 - y0)
    width = int((x1 - x0) * scale) + 80
    height = int((y1 - y0) * scale) + 110
    img = np.full((height, width, 3), 255, np.uint8)

    def px(x: float, y: float) -> Tuple[int, int]:
        # world +y up on the image
        return (int(round(40 + (x - x0) * scale)),
                int(round(height - 70 - (y - y0) * scale)))

    font = cv2.FONT_HERSHEY_SIMPLEX
    for gx in range(math.ceil(x0), math.floor(x1) + 1):
        cv2.line(img, px(gx, y0), px(gx, y1), (225, 225, 225), 1)
        cv2.putText(img, f"{gx}", px(gx, y0), font, 0.4, (120, 120, 120), 1)
    for gy in range(math.ceil(y0), math.floor(y1) + 1):
        cv2.line(img, px(x0, gy), px(x1, gy), (225, 225, 225), 1)
        cv2.putText(img, f"{gy}", px(x0, gy), font, 0.4, (120, 120, 120), 1)
    for lm in landmarks:
        c = px(lm["x"], lm["y"])
        rad = max(4, int(round(lm.get("diameter", 0.2) / 2 * scale)))
        cv2.circle(img, c, rad, colours.get(lm.get("class"), (0, 0, 0)), -1,
                   cv2.LINE_AA)
        cv2.circle(img, c, rad, (0, 0, 0), 1, cv2.LINE_AA)
        cv2.putText(img, str(lm.get("id", "")), (c[0] + rad + 3, c[1] + 4),
                    font, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
    truth = np.array([px(r["truth"]["x"], r["truth"]["y"])
                      for r in ev.pose_rows], np.int32)
    if len(truth) > 1:
        cv2.polylines(img, [truth.reshape(-1, 1, 2)], False, (0, 0, 0), 2,
                      cv2.LINE_AA)
    for r in ev.pose_rows:
        if "pose" not in r:
            continue
        p = r["pose"]
        if not (x0 - 1 <= p["x"] <= x1 + 1 and y0 - 1 <= p["y"] <= y1 + 1):
            continue
        col = SOLVER_BGR.get(r["solver"], (0, 160, 0))
        c = px(p["x"], p["y"])
        tip = px(p["x"] + 0.12 * math.cos(p["heading"]),
                 p["y"] + 0.12 * math.sin(p["heading"]))
        cv2.line(img, c, tip, col, 1, cv2.LINE_AA)
        cv2.circle(img, c, 3, col, -1, cv2.LINE_AA)
    # legend
    y = height - 40
    x = 40
    cv2.line(img, (x, y), (x + 25, y), (0, 0, 0), 2)
    cv2.putText(img, "truth", (x + 30, y + 5), font, 0.5, (0, 0, 0), 1,
                cv2.LINE_AA)
    x += 100
    for name, col in SOLVER_BGR.items():
        cv2.circle(img, (x + 5, y), 4, col, -1, cv2.LINE_AA)
        cv2.putText(img, f"estimate ({name})", (x + 15, y + 5), font, 0.5,
                    (0, 0, 0), 1, cv2.LINE_AA)
        x += 170
    cv2.putText(img, "top-down, metres; the map's landmarks in class colour",
                (40, height - 15), font, 0.45, (90, 90, 90), 1, cv2.LINE_AA)
    if not cv2.imwrite(out_png, img):
        raise OSError(f"{out_png}: could not write the plot")


def class_colours(results: List[Dict[str, Any]]
                   ) -> Dict[str, Tuple[int, int, int]]:
    """Display colours of the classes, from a log line's labels."""
    for res in results:
        labels = res.get("labels") or {}
        names, rgb = labels.get("classes"), labels.get("rgb")
        if names and rgb and len(names) == len(rgb):
            return {n: ((c & 255), (c >> 8) & 255, (c >> 16) & 255)
                    for n, c in zip(names, rgb)}
    return {}


def add_evaluate_parser(subparsers):
    p = subparsers.add_parser(
        "evaluate", help="accuracy of a landmarklog file against truth",
        description=__doc__.split("\n\n")[0].replace("``", ""))
    p.add_argument("result", metavar="RESULT.jsonl|FOLDER|VIDEO",
                   help="landmarklog output (JSON Lines); or a folder of "
                        "images or a video with darknet/YOLO box "
                        "annotations, run through the chain and scored "
                        "(docs/evaluate.md)")
    p.add_argument("truth", nargs="?",
                   help="truth.jsonl of a synthetic clip (with a "
                        "landmarklog file)")
    p.add_argument("--match-px", type=float, default=4.0,
                   help="largest centroid distance of a match (default 4)")
    p.add_argument("--min-pixels", type=float, default=20.0,
                   help="smallest visible area a landmark must be found "
                        "at (default 20)")
    p.add_argument("--require-cut", action="store_true",
                   help="also require landmarks cut by the image border")
    p.add_argument("--visible-px", type=float, default=150.0,
                   help="pixels a truth landmark needs to count as visible "
                        "in the pose tables (default 150, as synth counts)")
    add_json_option(p, dash_o=True)
    p.add_argument("--plot", metavar="OUT.png",
                   help="write a top-down trajectory plot (truth vs "
                        "estimate, with the map's landmarks)")
    p.add_argument("--map", metavar="MAP.json",
                   help="the true landmark map, for the plot and the SLAM "
                        "map error (default: map.json beside the truth "
                        "file, when there is one)")
    p.add_argument("--map-estimate", metavar="MAP.json",
                   help="the map landmarkslam wrote (map-out), for a log "
                        "without landmark_map")
    p.add_argument("--map-gate", type=float, default=0.3, metavar="M",
                   help="farthest an estimated landmark may lie from its "
                        "true one after alignment to be paired (default "
                        "0.3 m)")
    anchor = p.add_mutually_exclusive_group()
    anchor.add_argument("--anchored", action="store_true", default=None,
                        help="the SLAM map was anchored (landmarkslam map=): "
                             "errors without alignment (default: when an "
                             "estimated landmark id is a true one)")
    anchor.add_argument("--not-anchored", action="store_false",
                        dest="anchored", help="the map frame is the first "
                                              "pose's: align")
    add_image_options(p)
    p.set_defaults(handler=_handle, parser=p)


def _handle(args) -> int:
    if args.truth is None:
        if args.result.endswith(".jsonl"):
            args.parser.error("a landmarklog file is evaluated against a "
                              "truth.jsonl: give both")
        return evaluate_images(args)
    try:
        results = read_jsonl(args.result)
        truth = read_jsonl(args.truth)
        ev = evaluate(results, truth,
                      args.match_px, args.min_pixels,
                      require_cut=args.require_cut,
                      visible_px=args.visible_px)
    except (LogError, KeyError) as err:
        print(f"gst-landmark: error: {err}", file=sys.stderr)
        return 2
    s = summary(ev)
    map_path = args.map
    if map_path is None:
        beside = os.path.join(os.path.dirname(args.truth), "map.json")
        map_path = beside if os.path.exists(beside) else None
    try:
        landmarks = read_map(map_path) if map_path else []
        slam = slam_evaluation(
            results, truth, landmarks,
            map_file_estimate(args.map_estimate) if args.map_estimate
            else None, args.anchored, args.map_gate, args.min_pixels)
    except (LogError, OSError, ValueError, KeyError, TypeError) as err:
        print(f"gst-landmark: error: {err}", file=sys.stderr)
        return 2
    if slam is not None:
        s["slam"] = slam
    print(format_report(s) + (format_slam(slam) if slam else ""))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(s, f, indent=2)
    if args.plot:
        try:
            plot_trajectory(ev, args.plot, landmarks,
                            class_colours(results))
        except (OSError, ValueError, KeyError, TypeError) as err:
            print(f"gst-landmark: error: {err}", file=sys.stderr)
            return 2
    return 0
