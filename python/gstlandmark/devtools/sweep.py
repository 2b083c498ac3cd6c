"""``gst-landmark sweep``: the default chain over many random variants of
the synthetic world, measured against the exact truth.

For each scenario (default range-sweep, path and distractors) and each
variant number 1..N (``synth --variant``): render the variant once
(cached under ``out/sweep/``), learn its palette from its colour chart
the documented way (``gst-landmark palette learn chart.png --mask
chart-mask.png``, docs/palette.md), run

    filesrc ! avidemux ! jpegdec ! videoconvert ! labsegment palette=P !
    blobroundness ! ipmrange calibration=camera.yml map=map.json !
    trilaterate map=map.json ! landmarklog

with every other property at its default, and score the log:

- a truth landmark is *required* when it has at least ``--min-pixels``
  (113) visible pixels, is not cut by the image border and at most
  ``--max-occluded`` (20 %) of it is hidden;
- a detection counts when ``evaluate.detection_accepted`` says so; it
  matches a visible truth landmark of its class whose centroid lies
  within ``max(--match-px, 0.25 x the landmark's equivalent diameter)``
  (nearest pairs first, one to one);
- precision = matched / counted detections (those matching a landmark
  that is not required are left out, as in ``evaluate``); recall =
  required landmarks matched / required landmarks;
- identity = matched detections that ``trilaterate`` assigned to the
  right map landmark / matched detections it assigned (the share
  assigned is reported too);
- range error: |range - truth| / truth of matched detections, median;
- pose error (position, metres) median and p95 and pose coverage, over
  the frames with three or more required landmarks: frames with a pose /
  such frames.

Odd variant numbers are the held-out half, even ones the tuning half;
the report gives each half and both together (``--half`` runs one).
Writes ``report.json`` and ``report.md`` in the output folder.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..commands import evaluate as E
from .benchkit import run_command

DEFAULT_SCENARIOS = ("range-sweep", "path", "distractors")
DEFAULT_VARIANTS = 20
DEFAULT_FRAMES = 40
DEFAULT_OUT = os.path.join("out", "sweep")
MIN_PIXELS = 113.0
MAX_OCCLUDED = 0.2
MATCH_PX = 4.0
# a centroid may sit this share of a big landmark's diameter off (a
# ball's shaded side, a disc cut by the JPEG blocks)
MATCH_DIAMETER_SHARE = 0.25
HALVES = ("tune", "held-out", "all")


def half_of(number: int) -> str:
    """Odd variants are held out; even ones are for tuning."""
    return "held-out" if number % 2 else "tune"


def variant_numbers(count: int, half: str = "all",
                    first: int = 1) -> List[int]:
    """Variant numbers first..first+count-1 of ``half``."""
    if half not in HALVES:
        raise ValueError(f"half must be one of {', '.join(HALVES)}, got "
                         f"{half!r}")
    numbers = range(first, first + count)
    return [n for n in numbers if half == "all" or half_of(n) == half]


# -- scoring ------------------------------------------------------------------

def required(mark: Dict[str, Any], min_pixels: float = MIN_PIXELS,
             max_occluded: float = MAX_OCCLUDED) -> bool:
    """Whether a truth landmark must be found: big enough, whole in the
    image, at most ``max_occluded`` hidden."""
    if mark.get("pixels", 0) < min_pixels or mark.get("cut", False):
        return False
    if "occluded_fraction" in mark:
        return mark["occluded_fraction"] <= max_occluded
    return not mark.get("occluded", False)


# A marker class taught within this Delta E of a floor or background class
# cannot be told from it by colour (noise and compression spread a flat
# colour by several Delta E; taught markers lie 45 or more from the floor
# otherwise): its landmarks are not required (the issue's "orange ball on
# an orange floor"), and the report names them.
FLOOR_COLOUR_DE = 15.0


def floor_coloured_classes(palette_path: str,
                           limit: float = FLOOR_COLOUR_DE) -> List[str]:
    """Marker classes of a learned palette whose colour (any reference)
    lies within ``limit`` of a non-marker class's."""
    with open(palette_path, encoding="utf-8") as f:
        classes = json.load(f)["classes"]

    def refs(c):
        return c.get("references") or [c["lab"]]

    background = [r for c in classes if not c.get("marker", True)
                  for r in refs(c)]
    return [c["name"] for c in classes if c.get("marker", True) and any(
        math.dist(r, b) < limit for r in refs(c) for b in background)]


def match_gate(mark: Dict[str, Any], match_px: float = MATCH_PX) -> float:
    """Largest centroid distance of a match with this landmark."""
    diameter = 2.0 * math.sqrt(max(mark.get("pixels", 0.0), 0.0) / math.pi)
    return max(match_px, MATCH_DIAMETER_SHARE * diameter)


def match_detections(dets: Sequence[Dict[str, Any]],
                     marks: Sequence[Dict[str, Any]],
                     match_px: float = MATCH_PX) -> List[Tuple[int, int]]:
    """One-to-one (detection, truth) pairs of the same class within each
    landmark's gate, nearest first."""
    return E.match_frame(dets, marks, match_px,
                         gate=lambda m: match_gate(m, match_px))


def score(results: Sequence[Dict[str, Any]],
          truth: Sequence[Dict[str, Any]], min_pixels: float = MIN_PIXELS,
          max_occluded: float = MAX_OCCLUDED,
          match_px: float = MATCH_PX,
          excluded: Sequence[str] = ()) -> Dict[str, Any]:
    """The raw tallies of one clip (see ``summarise``); landmarks of the
    ``excluded`` classes are never required."""
    t = {"frames": 0, "tp": 0, "fp": 0, "fn": 0, "assigned": 0,
         "right_id": 0, "range_rel": [], "pose_frames": 0,
         "posed_frames": 0, "position_m": [], "heading_deg": []}
    truth_by_frame = {f["frame"]: f for f in truth}
    for res in results:
        frame = truth_by_frame.get(res.get("frame"))
        if frame is None:
            continue
        t["frames"] += 1
        dets = [d for d in res.get("detections", [])
                if E.detection_accepted(d)]
        marks = frame.get("landmarks", [])
        need = [required(m, min_pixels, max_occluded)
                and m["class"] not in excluded for m in marks]
        pairs = match_detections(dets, marks, match_px)
        matched_d = {i for i, _ in pairs}
        matched_t = {j for _, j in pairs}
        for i, j in pairs:
            if not need[j]:
                continue        # found one it need not find
            t["tp"] += 1
            mark, det = marks[j], dets[i]
            match = det.get("match") or {}
            if match.get("matched"):
                t["assigned"] += 1
                if match.get("landmark-id") == mark["id"]:
                    t["right_id"] += 1
            rng = det.get("range") or {}
            if "range" in rng and mark.get("range"):
                t["range_rel"].append(
                    abs(rng["range"] - mark["range"]) / mark["range"])
        t["fp"] += sum(1 for i in range(len(dets)) if i not in matched_d)
        t["fn"] += sum(1 for j, n in enumerate(need)
                       if n and j not in matched_t)
        if sum(need) >= 3 and "robot" in frame:
            t["pose_frames"] += 1
            pose = res.get("pose")
            if pose is not None:
                robot = frame["robot"]
                t["posed_frames"] += 1
                t["position_m"].append(math.hypot(
                    pose["x"] - robot["x"], pose["y"] - robot["y"]))
                t["heading_deg"].append(abs(math.degrees(E.wrap_angle(
                    pose["heading"] - robot["heading"]))))
    return t


def merge(tallies: Sequence[Dict[str, Any]]) -> Dict[str, Any]:
    out = {"frames": 0, "tp": 0, "fp": 0, "fn": 0, "assigned": 0,
           "right_id": 0, "range_rel": [], "pose_frames": 0,
           "posed_frames": 0, "position_m": [], "heading_deg": []}
    for t in tallies:
        for key, value in t.items():
            out[key] = out[key] + value
    return out


def _ratio(num: int, den: int) -> Optional[float]:
    return num / den if den else None


def _quantile(values: Sequence[float], q: float) -> Optional[float]:
    return float(np.percentile(values, q)) if len(values) else None


def summarise(t: Dict[str, Any]) -> Dict[str, Any]:
    """Precision, recall, identity, range and pose figures of tallies."""
    return {
        "frames": t["frames"],
        "tp": t["tp"], "fp": t["fp"], "fn": t["fn"],
        "precision": _ratio(t["tp"], t["tp"] + t["fp"]),
        "recall": _ratio(t["tp"], t["tp"] + t["fn"]),
        "identity": _ratio(t["right_id"], t["assigned"]),
        "assigned": _ratio(t["assigned"], t["tp"]),
        "range_rel_median": _quantile(t["range_rel"], 50),
        "range_n": len(t["range_rel"]),
        "pose_frames": t["pose_frames"],
        "pose_coverage": _ratio(t["posed_frames"], t["pose_frames"]),
        "position_median_m": _quantile(t["position_m"], 50),
        "position_p95_m": _quantile(t["position_m"], 95),
        "heading_median_deg": _quantile(t["heading_deg"], 50),
    }


# -- rendering and running ----------------------------------------------------

def renderer_version() -> str:
    """A digest of the renderer's source (a cached clip is reused only
    when the renderer that made it is the one installed)."""
    from ..commands.demo import renderer_version as version
    return version()


def clip_folder(out_dir: str, scenario: str, number: int,
                frames: int) -> str:
    return os.path.join(out_dir, "clips", f"{scenario}-v{number}-"
                        f"f{frames}-{renderer_version()}")


def render_variant(folder: str, scenario: str, number: int,
                   frames: int) -> float:
    """Render variant ``number`` into ``folder`` unless it is there;
    returns the seconds spent."""
    if os.path.exists(os.path.join(folder, "scene.json")):
        return 0.0
    from ..synth import render_scenario
    t0 = time.perf_counter()
    partial = folder + ".partial"
    render_scenario(scenario, partial, frames=frames, variant=number,
                    progress=False)
    if os.path.exists(folder):
        import shutil
        shutil.rmtree(folder)
    os.replace(partial, folder)
    return time.perf_counter() - t0


def render_in_parallel(out_dir: str, pairs: Sequence[Tuple[str, int]],
                       frames: int, jobs: int, stream=None
                       ) -> Dict[Tuple[str, int], float]:
    """Render the clips not yet cached, ``jobs`` at a time, each by
    ``gst-landmark synth`` in a process of its own; returns the seconds
    each took (a failed one is left for ``run_variant`` to report)."""
    import shutil
    from concurrent.futures import ThreadPoolExecutor

    todo = [(sc, n) for sc, n in pairs if not os.path.exists(
        os.path.join(clip_folder(out_dir, sc, n, frames), "scene.json"))]

    def render(pair):
        sc, n = pair
        folder = clip_folder(out_dir, sc, n, frames)
        partial = folder + ".partial"
        t0 = time.perf_counter()
        done = run_command(["synth", sc, "--variant", str(n), "--frames",
                            str(frames), "--out", partial, "--no-progress"])
        if done.returncode == 0:
            if os.path.exists(folder):
                shutil.rmtree(folder)
            os.replace(partial, folder)
        if stream is not None:
            print(f"rendered {sc} v{n}"
                  + ("" if done.returncode == 0 else " (failed)"),
                  file=stream, flush=True)
        return pair, time.perf_counter() - t0

    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        return dict(pool.map(render, todo))


def learn_palette(folder: str, out: str) -> str:
    """``gst-landmark palette learn`` on the clip's chart, as docs/palette.md
    shows a user."""
    with open(os.path.join(folder, "scene.json"), encoding="utf-8") as f:
        classes = json.load(f)["palette"]["classes"]
    names = [c["name"] for c in classes]
    markers = [c["name"] for c in classes if c.get("marker", True)]
    done = run_command(["palette", "learn",
                        os.path.join(folder, "chart.png"), "--mask",
                        os.path.join(folder, "chart-mask.png"), "--names",
                        ",".join(names), "--markers", ",".join(markers),
                        "-o", out])
    if done.returncode != 0:
        raise RuntimeError(f"palette learn failed: {done.stderr.strip()}")
    return out


def chain(folder: str, palette: str, log: str) -> str:
    """The default chain on the variant's clip, camera file and map."""
    from ..commands.runner import quote
    from ..synth.writer import clip_files
    files = clip_files(folder)
    map_file = files["map"]
    return (f"filesrc location={quote(files['clip'])} ! avidemux ! jpegdec ! "
            f"videoconvert ! labsegment palette={quote(palette)} ! "
            f"blobroundness ! ipmrange calibration={quote(files['camera'])} "
            f"map={quote(map_file)} ! trilaterate map={quote(map_file)} ! "
            f"landmarklog location={quote(log)} ! fakesink")


def run_variant(out_dir: str, scenario: str, number: int, frames: int,
                min_pixels: float = MIN_PIXELS,
                max_occluded: float = MAX_OCCLUDED) -> Dict[str, Any]:
    """Render (or reuse), learn the palette, run the chain, score."""
    from ..commands.runner import run_launch
    from ..landmarklog import read_jsonl
    row: Dict[str, Any] = {"scenario": scenario, "variant": number,
                           "half": half_of(number)}
    folder = clip_folder(out_dir, scenario, number, frames)
    t0 = time.perf_counter()
    try:
        row["render_s"] = round(render_variant(folder, scenario, number,
                                               frames), 2)
        run_dir = os.path.join(out_dir, "runs", f"{scenario}-v{number}")
        os.makedirs(run_dir, exist_ok=True)
        palette = learn_palette(folder, os.path.join(run_dir,
                                                     "palette.json"))
        log = os.path.join(run_dir, "log.jsonl")
        t1 = time.perf_counter()
        run_launch(chain(folder, palette, log))
        row["chain_s"] = round(time.perf_counter() - t1, 2)
        row["excluded"] = floor_coloured_classes(palette)
        tallies = score(read_jsonl(log),
                        read_jsonl(os.path.join(folder, "truth.jsonl")),
                        min_pixels, max_occluded,
                        excluded=row["excluded"])
    except Exception as err:      # one broken variant must not stop all
        row["error"] = f"{type(err).__name__}: {err}"
        row["seconds"] = round(time.perf_counter() - t0, 2)
        return row
    row["seconds"] = round(time.perf_counter() - t0, 2)
    with open(os.path.join(folder, "scene.json"), encoding="utf-8") as f:
        variant = json.load(f)["notes"]["variant"]
    row["drawn"] = {"camera": variant["camera"], "floor": variant["floor"],
                    "markers": variant["markers"],
                    "jpeg_quality": variant["effects"]["jpeg_quality"],
                    "motion_blur": variant["effects"]["motion_blur"]}
    row["tallies"] = tallies
    row.update(summarise(tallies))
    return row


def report(rows: Sequence[Dict[str, Any]]) -> Dict[str, Any]:
    """Per-variant rows plus each half and overall, by scenario and for
    all scenarios."""
    good = [r for r in rows if "tallies" in r]
    groups: Dict[str, Dict[str, Any]] = {}
    scenarios = sorted({r["scenario"] for r in good})
    for half in ("tune", "held-out", "all"):
        sel = [r for r in good if half == "all" or r["half"] == half]
        if not sel:
            continue
        entry = {"all": summarise(merge([r["tallies"] for r in sel])),
                 "variants": len(sel)}
        for sc in scenarios:
            part = [r for r in sel if r["scenario"] == sc]
            if part:
                entry[sc] = summarise(merge([r["tallies"] for r in part]))
        groups[half] = entry
    out_rows = [{k: v for k, v in r.items() if k != "tallies"}
                for r in rows]
    def mean(key):
        values = [r.get(key, 0.0) for r in good]
        return round(float(np.mean(values)), 2) if values else None
    return {"rows": out_rows, "halves": groups,
            "errors": [r for r in out_rows if "error" in r],
            "seconds_per_variant": mean("seconds"),
            "render_seconds_per_variant": mean("render_s"),
            "chain_seconds_per_variant": mean("chain_s")}


# -- formatting ---------------------------------------------------------------

def _pct(x: Optional[float]) -> str:
    return "-" if x is None else f"{100 * x:.1f}"


def _cm(x: Optional[float]) -> str:
    return "-" if x is None else f"{100 * x:.1f}"


def _fig(x: Optional[float], digits: int = 2) -> str:
    return "-" if x is None else f"{x:.{digits}f}"


HEADER = ("| scenario | variant | half | precision % | recall % | "
          "identity % | range err % (median) | pose err cm (median / p95) "
          "| pose coverage % | required | s |")
RULE = "|" + "---|" * 11


def _line(name: str, variant: str, half: str, s: Dict[str, Any],
          seconds: Any = "") -> str:
    required_n = s["tp"] + s["fn"]
    rel = s["range_rel_median"]
    return (f"| {name} | {variant} | {half} | {_pct(s['precision'])} | "
            f"{_pct(s['recall'])} | {_pct(s['identity'])} | "
            f"{_fig(None if rel is None else 100 * rel)} | "
            f"{_cm(s['position_median_m'])} / {_cm(s['position_p95_m'])} "
            f"| {_pct(s['pose_coverage'])} ({s['pose_frames']}) | "
            f"{required_n} | {seconds} |")


def format_markdown(rep: Dict[str, Any]) -> str:
    lines = ["Per variant", "", HEADER, RULE]
    for r in rep["rows"]:
        if "error" in r:
            lines.append(f"| {r['scenario']} | {r['variant']} | "
                         f"{r['half']} | error: {r['error']} |" +
                         " |" * 7)
            continue
        lines.append(_line(r["scenario"], str(r["variant"]), r["half"], r,
                           r["seconds"]))
    excluded = [f"{r['scenario']} {r['variant']}: "
                f"{', '.join(r['excluded'])}"
                for r in rep["rows"] if r.get("excluded")]
    if excluded:
        lines += ["", "Not required (taught within Delta E "
                  f"{FLOOR_COLOUR_DE:g} of the floor or background): "
                  + "; ".join(excluded)]
    lines += ["", "Halves (held-out = odd variants, tune = even)", "",
              HEADER, RULE]
    for half, entry in rep["halves"].items():
        for name, s in entry.items():
            if name == "variants":
                continue
            lines.append(_line(name, f"{entry['variants']} clips"
                               if name == "all" else "", half, s))
    if rep.get("seconds_per_variant") is not None:
        lines += ["", f"wall time per variant: "
                  f"{rep['seconds_per_variant']} s, of which rendering "
                  f"{rep['render_seconds_per_variant']} s (0 for a cached "
                  f"clip) and the chain {rep['chain_seconds_per_variant']}"
                  f" s"]
    return "\n".join(lines) + "\n"


# -- command ------------------------------------------------------------------

def run_sweep(out_dir: str = DEFAULT_OUT,
              scenarios: Sequence[str] = DEFAULT_SCENARIOS,
              variants: int = DEFAULT_VARIANTS, half: str = "all",
              frames: int = DEFAULT_FRAMES, first: int = 1,
              min_pixels: float = MIN_PIXELS,
              max_occluded: float = MAX_OCCLUDED,
              stream=None, jobs: int = 1) -> Dict[str, Any]:
    """Run the sweep; print a line per variant on ``stream``; write
    report.json and report.md in ``out_dir``; return the report.
    ``jobs`` > 1 renders the missing clips that many at a time first."""
    stream = stream or sys.stdout
    numbers = variant_numbers(variants, half, first)
    os.makedirs(out_dir, exist_ok=True)
    rendered: Dict[Tuple[str, int], float] = {}
    if jobs > 1:
        rendered = render_in_parallel(
            out_dir, [(sc, n) for sc in scenarios for n in numbers],
            frames, jobs, stream)
    rows = []
    total = len(numbers) * len(scenarios)
    for scenario in scenarios:
        for number in numbers:
            row = run_variant(out_dir, scenario, number, frames,
                              min_pixels, max_occluded)
            if (scenario, number) in rendered and "error" not in row:
                # the time it took in the parallel stage
                row["render_s"] = round(rendered[scenario, number], 2)
                row["seconds"] = round(row["seconds"] + row["render_s"],
                                       2)
            rows.append(row)
            if "error" in row:
                text = f"error: {row['error']}"
            else:
                text = (f"precision {_pct(row['precision'])} recall "
                        f"{_pct(row['recall'])} identity "
                        f"{_pct(row['identity'])} pose coverage "
                        f"{_pct(row['pose_coverage'])}")
            print(f"[{len(rows)}/{total}] {scenario} v{number} "
                  f"({row['half']}): {text} ({row['seconds']} s)",
                  file=stream, flush=True)
    rep = report(rows)
    rep["settings"] = {"scenarios": list(scenarios), "variants": numbers,
                       "frames": frames, "min_pixels": min_pixels,
                       "max_occluded": max_occluded, "half": half}
    with open(os.path.join(out_dir, "report.json"), "w",
              encoding="utf-8") as f:
        json.dump(rep, f, indent=2)
    md = format_markdown(rep)
    with open(os.path.join(out_dir, "report.md"), "w",
              encoding="utf-8") as f:
        f.write(md)
    return rep


def _positive_int(text):
    import argparse
    try:
        value = int(text)
        if value < 1:
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a whole number >= 1, got {text!r}") from None
    return value


def add_sweep_parser(subparsers):
    import argparse
    from ..synth.scenarios import SCENARIOS
    p = subparsers.add_parser(
        "sweep", help="the default chain over random synthetic variants",
        description=__doc__.split("\n\n")[0].replace("``", ""),
        epilog="Odd variant numbers are held out, even ones are for "
               "tuning. See docs/synth.md.",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scenario", action="append", dest="scenarios",
                   choices=[s for s in SCENARIOS if s != "custom"],
                   help="repeatable (default: range-sweep, path, "
                        "distractors)")
    p.add_argument("--variants", type=_positive_int,
                   default=DEFAULT_VARIANTS, metavar="N",
                   help=f"variants 1..N of each scenario (default "
                        f"{DEFAULT_VARIANTS})")
    p.add_argument("--first", type=_positive_int, default=1, metavar="K",
                   help="start at variant K (default 1)")
    p.add_argument("--half", choices=HALVES, default="all",
                   help="tune (even variants), held-out (odd) or all "
                        "(default)")
    p.add_argument("--frames", type=_positive_int, default=DEFAULT_FRAMES,
                   metavar="N", help=f"frames per clip (default "
                                     f"{DEFAULT_FRAMES})")
    p.add_argument("--min-pixels", type=float, default=MIN_PIXELS,
                   help=f"pixels a landmark needs to be required "
                        f"(default {MIN_PIXELS:g})")
    p.add_argument("--max-occluded", type=float, default=MAX_OCCLUDED,
                   help=f"largest hidden share of a required landmark "
                        f"(default {MAX_OCCLUDED:g})")
    p.add_argument("--jobs", type=_positive_int, default=1, metavar="N",
                   help="render the missing clips N at a time, each in a "
                        "process of its own (default 1)")
    p.add_argument("--out", default=DEFAULT_OUT, metavar="DIR",
                   help=f"clips, logs and the report (default "
                        f"{DEFAULT_OUT})")
    p.set_defaults(handler=_handle, parser=p)


def _handle(args) -> int:
    rep = run_sweep(args.out, tuple(args.scenarios or DEFAULT_SCENARIOS),
                    args.variants, args.half, args.frames, args.first,
                    args.min_pixels, args.max_occluded,
                    jobs=args.jobs)
    print()
    print(format_markdown(rep), end="")
    print(f"wrote {os.path.join(args.out, 'report.json')} and "
          f"{os.path.join(args.out, 'report.md')}")
    return 1 if rep["errors"] else 0
