"""``gst-landmark run``: a shipped pipeline file (or a launch string) on a
file or a camera, with the project's palette, map and camera file.

The variables of the pipeline files (docs/pipelines.md) come from a
project config file (``--config``), from ``--input`` (INPUT for a file,
DEVICE for /dev/video*), from ``--out`` (OUTPUT, LOG) and from ``--set
VAR=VALUE``, in that order (later ones win). The run shows a progress
bar on file inputs, stops cleanly on Ctrl-C (EOS through the pipeline so
the video and the log are complete; a second Ctrl-C aborts) and writes,
in the output folder: ``overlay.avi``, ``log.jsonl``, ``trajectory.png``
(when the log has poses), ``summary.json`` and, with ``--truth``,
``accuracy.json``. See docs/run.md.
"""

from __future__ import annotations

import json
import math
import os
import re
import signal
import sys
import time
from collections import Counter
from typing import Any, Dict, List, Optional, Sequence, Tuple

from .. import pipeline, pipelinefile
from ..landmarklog import LogError, read_jsonl
from ..landmarkmap import MapError, read_map
from .common import PROG, CliError, camera_and_map
from .foxglovelive import add_foxglove_arguments, foxglove_options

Gst = pipeline.Gst

DEFAULT_PIPELINE = "file"
DEFAULT_OUT = "out/run"
VIDEO_NAME = "overlay.avi"
LOG_NAME = "log.jsonl"
PLOT_NAME = "trajectory.png"
SUMMARY_NAME = "summary.json"
ACCURACY_NAME = "accuracy.json"

# project config keys that name files, relative to the config file
CONFIG_FILES = {"palette": "PALETTE", "map": "MAP", "camera": "CAMERA"}

_VAR = re.compile(r"\$\{([A-Za-z_][A-Za-z0-9_]*)\}")
_NAME = re.compile(r"^[A-Za-z0-9_.-]+$")
# characters that make a value need quoting in a launch line
_UNSAFE = re.compile(r"[\s!\"'=,;()\[\]{}\\]")


def pipelines_dir() -> str:
    return pipelinefile.pipelines_dir()


def pipeline_names() -> List[str]:
    """The shipped pipeline files, without ``.pipeline``."""
    return pipelinefile.names()


def resolve_pipeline(spec: str) -> Tuple[str, str]:
    """``(label, launch line)`` for a pipeline name, a .pipeline file or a
    launch string (anything with a ``!`` or a space)."""
    if spec.endswith(".pipeline") and os.path.isfile(spec):
        try:
            return os.path.basename(spec)[:-len(".pipeline")], \
                pipelinefile.launch_line(spec)
        except ValueError as err:
            raise CliError(str(err)) from None
    if _NAME.match(spec):
        path = os.path.join(pipelines_dir(), spec + ".pipeline")
        if not os.path.isfile(path):
            raise CliError(f"unknown pipeline {spec!r}; shipped pipelines: "
                           f"{', '.join(pipeline_names()) or 'none found'} "
                           f"(or give a launch string)")
        try:
            return spec, pipelinefile.launch_line(path)
        except ValueError as err:
            raise CliError(str(err)) from None
    return "launch string", spec


def read_config(path: str) -> Dict[str, str]:
    """Pipeline variables from a project config file: ``palette``, ``map``
    and ``camera`` are file paths relative to the config file; any other
    string or number value sets the variable of its upper-cased key."""
    try:
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
    except OSError as err:
        raise CliError(f"{path}: {err.strerror or err}") from None
    except json.JSONDecodeError as err:
        raise CliError(f"{path}: not JSON: {err.msg} (line {err.lineno})"
                       ) from None
    if not isinstance(data, dict):
        raise CliError(f"{path}: a JSON object expected")
    base = os.path.dirname(os.path.abspath(path))
    variables = {}
    for key, value in data.items():
        if value is None or isinstance(value, (dict, list, bool)):
            continue
        value = str(value)
        if key.lower() in CONFIG_FILES:
            value = os.path.normpath(os.path.join(base,
                                                  os.path.expanduser(value)))
            variables[CONFIG_FILES[key.lower()]] = value
        else:
            variables[key.upper()] = value
    return variables


def parse_set(items: Sequence[str]) -> Dict[str, str]:
    variables = {}
    for item in items or ():
        name, sep, value = item.partition("=")
        if not sep or not re.match(r"^[A-Za-z_][A-Za-z0-9_]*$", name):
            raise CliError(f"--set expects VAR=VALUE, got {item!r}")
        variables[name.upper()] = value
    return variables


def quote(value: str) -> str:
    """A value as one token of a launch line."""
    if value and not _UNSAFE.search(value):
        return value
    return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'


def needed(launch: str) -> List[str]:
    seen: List[str] = []
    for name in _VAR.findall(launch):
        if name not in seen:
            seen.append(name)
    return seen


def substitute(label: str, launch: str, variables: Dict[str, str]) -> str:
    for name in needed(launch):
        if name not in variables:
            if name in ("INPUT", "DEVICE"):
                how = "give --input"
            else:
                how = f"set it in --config or --set {name}=..."
            raise CliError(f"pipeline '{label}' needs {name}: {how}")
    return _VAR.sub(lambda m: quote(variables[m.group(1)]), launch)


# ---------------------------------------------------------------------------
# Running


class Progress:
    """A one-line progress bar on stderr: percent, frames, frames/s."""

    WIDTH = 30

    def __init__(self, stream=None):
        self.stream = stream or sys.stderr
        self.shown = False

    def show(self, fraction: Optional[float], frames: int, fps: float):
        if fraction is None and frames == 0:
            return      # nothing known yet
        if fraction is None:
            bar, pct = "?" * self.WIDTH, "   ?"
        else:
            fraction = min(max(fraction, 0.0), 1.0)
            done = int(round(fraction * self.WIDTH))
            bar = "#" * done + "-" * (self.WIDTH - done)
            pct = f"{100 * fraction:3.0f}%"
        self.stream.write(f"\r[{bar}] {pct}  {frames} frames  "
                          f"{fps:6.1f} frames/s ")
        self.stream.flush()
        self.shown = True

    def close(self):
        if self.shown:
            self.stream.write("\n")
            self.stream.flush()
            self.shown = False


def _count_element(pipe):
    """The element whose output buffers count the frames: landmarklog,
    else labsegment, else None."""
    found = pipeline.elements_by_factory(pipe)
    return found.get("landmarklog") or found.get("labsegment")


def run_launch(launch: str, progress: Optional[Progress] = None,
               poll_s: float = 0.1, out=None,
               attach=None) -> Dict[str, Any]:
    """Runs ``launch`` to EOS; Ctrl-C sends EOS (a second one aborts).
    Returns frames (counted after landmarklog or labsegment), wall
    seconds, whether it was interrupted or aborted. Pipeline errors raise
    CliError. attach(pipe), when given, is called before the pipeline
    plays (the live Foxglove server's probes)."""
    out = out or sys.stderr
    pipeline.init()
    try:
        pipe = Gst.parse_launch(launch)
    except Exception as err:    # GLib.Error: no element, bad syntax
        raise CliError(f"cannot build the pipeline: "
                       f"{getattr(err, 'message', err)}") from None
    if attach is not None:
        attach(pipe)
    counter = {"frames": 0}
    element = _count_element(pipe)
    if element is not None:
        def on_buffer(pad, info):
            counter["frames"] += 1
            return Gst.PadProbeReturn.OK
        element.get_static_pad("src").add_probe(Gst.PadProbeType.BUFFER,
                                                on_buffer)
    interrupts = {"n": 0}

    def on_sigint(signum, frame):
        interrupts["n"] += 1

    previous = signal.signal(signal.SIGINT, on_sigint)
    bus = pipe.get_bus()
    state = {"interrupted": False, "aborted": False, "error": None}
    t0 = time.perf_counter()
    last_draw = 0.0
    try:
        if pipe.set_state(Gst.State.PLAYING) == \
                Gst.StateChangeReturn.FAILURE:
            msg = bus.pop_filtered(Gst.MessageType.ERROR)
            state["error"] = _error_text(msg) if msg else \
                "the pipeline could not start"
        eos_sent = False
        while state["error"] is None:
            if interrupts["n"] >= 2:
                state["aborted"] = True
                break
            if interrupts["n"] == 1 and not eos_sent:
                eos_sent = state["interrupted"] = True
                if progress is not None:
                    progress.close()
                print(f"{PROG}: interrupted: finishing the outputs "
                      f"(Ctrl-C again to abort)", file=out, flush=True)
                pipe.send_event(Gst.Event.new_eos())
            msg = bus.timed_pop_filtered(
                int(poll_s * Gst.SECOND),
                Gst.MessageType.EOS | Gst.MessageType.ERROR)
            now = time.perf_counter()
            if progress is not None and not eos_sent and \
                    (now - last_draw >= 0.25 or msg is not None):
                last_draw = now
                progress.show(_fraction(pipe), counter["frames"],
                              counter["frames"] / max(now - t0, 1e-9))
            if msg is None:
                continue
            if msg.type == Gst.MessageType.ERROR:
                state["error"] = _error_text(msg)
            break
    finally:
        seconds = time.perf_counter() - t0
        if progress is not None:
            progress.close()
        pipe.set_state(Gst.State.NULL)
        signal.signal(signal.SIGINT, previous)
    if state["error"] is not None:
        raise CliError(f"pipeline error: {state['error']}")
    return {"frames": counter["frames"], "seconds": seconds,
            "interrupted": state["interrupted"],
            "aborted": state["aborted"], "counted": element is not None}


def _error_text(msg) -> str:
    err, debug = msg.parse_error()
    source = msg.src.get_name() if msg.src is not None else "?"
    text = f"{source}: {err.message}"
    return f"{text} ({debug})" if debug else text


def _fraction(pipe) -> Optional[float]:
    ok_d, duration = pipe.query_duration(Gst.Format.TIME)
    ok_p, position = pipe.query_position(Gst.Format.TIME)
    if ok_d and ok_p and duration > 0 and position >= 0:
        return position / duration
    return None


# ---------------------------------------------------------------------------
# Outputs


def log_summary(results: List[Dict[str, Any]]) -> Dict[str, Any]:
    """Frames, kept detections per class, rejected blobs, frames with a
    pose and the solvers used, from landmarklog lines."""
    per_class: Counter = Counter()
    rejected = 0
    solvers: Counter = Counter()
    with_pose = 0
    for res in results:
        for det in res.get("detections") or []:
            # the chain's verdict where it gave one (a marginal shape
            # confirmed by its size and the map is accepted though its blob
            # is not kept)
            if det.get("accepted", det.get("blob", {}).get("kept", True)):
                per_class[str(det.get("class"))] += 1
            else:
                rejected += 1
        pose = res.get("pose")
        if pose is not None:
            with_pose += 1
            solvers[str(pose.get("solver", ""))] += 1
    return {"frames": len(results),
            "detections": dict(sorted(per_class.items())),
            "detections_total": sum(per_class.values()),
            "rejected_blobs": rejected,
            "frames_with_pose": with_pose,
            "pose_solvers": dict(sorted(solvers.items()))}


def plot_estimates(results: List[Dict[str, Any]], out_png: str,
                   landmarks: Sequence[Dict[str, Any]] = (),
                   size_px: int = 900) -> None:
    """The trajectory plot without a truth file: top-down, the map's
    landmarks and the estimated poses (dots by solver joined by a grey
    line, a tick for the heading), metres with a 1 m grid."""
    import cv2
    import numpy as np
    from . import evaluate

    colours = dict(evaluate.CLASS_BGR)
    colours.update(evaluate.class_colours(results) or {})
    poses = [r["pose"] for r in results if r.get("pose") is not None]
    pts = [(p["x"], p["y"]) for p in poses]
    pts += [(lm["x"], lm["y"]) for lm in landmarks]
    if not pts:
        raise ValueError("nothing to plot: no poses and no map")
    x0 = min(p[0] for p in pts) - 0.5
    x1 = max(p[0] for p in pts) + 0.5
    y0 = min(p[1] for p in pts) - 0.5
    y1 = max(p[1] for p in pts) + 0.5
    scale = (size_px - 80) / max(x1 - x0, y1 - y0, 1e-6)
    width = int((x1 - x0) * scale) + 80
    height = int((y1 - y0) * scale) + 90
    img = np.full((height, width, 3), 255, np.uint8)

    def px(x, y):
        return (int(round(40 + (x - x0) * scale)),
                int(round(height - 50 - (y - y0) * scale)))

    font = cv2.FONT_HERSHEY_SIMPLEX
    grey = (225, 225, 225)
    for gx in range(math.ceil(x0), math.floor(x1) + 1):
        cv2.line(img, px(gx, y0), px(gx, y1), grey, 1)
        cv2.putText(img, str(gx), px(gx, y0), font, 0.4, (120, 120, 120))
    for gy in range(math.ceil(y0), math.floor(y1) + 1):
        cv2.line(img, px(x0, gy), px(x1, gy), grey, 1)
        cv2.putText(img, str(gy), px(x0, gy), font, 0.4, (120, 120, 120))
    for lm in landmarks:
        c = px(lm["x"], lm["y"])
        rad = max(4, int(round(lm.get("diameter", 0.2) / 2 * scale)))
        cv2.circle(img, c, rad, colours.get(lm.get("class"), (0, 0, 0)),
                   -1, cv2.LINE_AA)
        cv2.circle(img, c, rad, (0, 0, 0), 1, cv2.LINE_AA)
        cv2.putText(img, str(lm.get("id", "")), (c[0] + rad + 3, c[1] + 4),
                    font, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
    path = np.array([px(p["x"], p["y"]) for p in poses], np.int32)
    if len(path) > 1:
        cv2.polylines(img, [path.reshape(-1, 1, 2)], False, (170, 170, 170),
                      1, cv2.LINE_AA)
    for p in poses:
        col = evaluate.SOLVER_BGR.get(str(p.get("solver", "")), (0, 160, 0))
        c = px(p["x"], p["y"])
        heading = p.get("heading", 0.0)
        tip = px(p["x"] + 0.12 * math.cos(heading),
                 p["y"] + 0.12 * math.sin(heading))
        cv2.line(img, c, tip, col, 1, cv2.LINE_AA)
        cv2.circle(img, c, 3, col, -1, cv2.LINE_AA)
    cv2.putText(img, "estimated poses (no truth given), top-down, metres; "
                "the map's landmarks in class colour", (40, height - 15),
                font, 0.45, (90, 90, 90), 1, cv2.LINE_AA)
    if not cv2.imwrite(out_png, img):
        raise CliError(f"{out_png}: could not write the plot")


def _read_landmarks(map_path: Optional[str]) -> List[Dict[str, Any]]:
    if not map_path:
        return []
    try:
        return read_map(map_path)
    except MapError:
        return []  # the plot goes without; the elements reported the map


def _read_log(path: str) -> List[Dict[str, Any]]:
    try:
        return read_jsonl(path)
    except LogError as err:
        raise CliError(str(err)) from None


def format_summary(s: Dict[str, Any]) -> str:
    lines = [f"{s['frames']} frames through '{s['pipeline']}' in "
             f"{s['seconds']:.2f} s: {s['ms_per_frame']:.2f} ms per frame "
             f"(wall)"]
    if s.get("interrupted"):
        lines[0] += " (stopped by Ctrl-C)"
    if "detections" in s:
        per = ", ".join(f"{k} {v}" for k, v in s["detections"].items())
        lines.append(f"detections: {s['detections_total']}"
                     + (f" ({per})" if per else "")
                     + f"; rejected blobs {s['rejected_blobs']}")
        lines.append(f"frames with a pose: {s['frames_with_pose']} of "
                     f"{s['frames']}")
    written = [os.path.basename(p) for p in s["outputs"].values()]
    lines.append(f"wrote {s['out']}/: {', '.join(written)}")
    return "\n".join(lines)


def run(spec: str, input_path: Optional[str], config: Optional[str] = None,
        out_dir: str = DEFAULT_OUT, truth: Optional[str] = None,
        sets: Sequence[str] = (), progress: Optional[bool] = None,
        stream=None, foxglove: Optional[Dict[str, Any]] = None
        ) -> Tuple[int, Dict[str, Any]]:
    """The whole command; returns (exit status, summary). foxglove:
    {port, host, expose, wait} to serve the run live (foxglovelive)."""
    stream = stream or sys.stdout
    if foxglove is not None:
        from . import foxglovelive
        if not 0 <= foxglove["port"] <= 65535:
            raise CliError(f"--foxglove {foxglove['port']}: a port is "
                           f"0..65535 (0: any free one)")
        foxglovelive.check_host(foxglove["host"], foxglove["expose"])
    label, launch = resolve_pipeline(spec)
    variables: Dict[str, str] = {}
    if config is not None:
        variables.update(read_config(config))
    live = False
    if input_path is not None:
        if input_path.startswith("/dev/"):
            if not os.path.exists(input_path):
                raise CliError(f"{input_path}: no such device")
            variables["DEVICE"] = input_path
            live = True
        else:
            if not os.path.isfile(input_path):
                raise CliError(f"{input_path}: no such file")
            variables["INPUT"] = os.path.abspath(input_path)
    if truth is not None and not os.path.isfile(truth):
        raise CliError(f"{truth}: no such file")
    os.makedirs(out_dir, exist_ok=True)
    variables["OUTPUT"] = os.path.join(out_dir, VIDEO_NAME)
    variables["LOG"] = os.path.join(out_dir, LOG_NAME)
    variables.update(parse_set(sets))
    uses = set(needed(launch))
    if "DEVICE" in uses:
        live = True
    description = substitute(label, launch, variables)
    for name in ("OUTPUT", "LOG"):
        if name in uses:
            try:
                os.remove(variables[name])  # no stale output from before
            except OSError:
                pass

    if progress is None:
        progress = sys.stderr.isatty()
    bar = Progress() if progress and not live else None
    server = None
    if foxglove is not None:
        from . import foxglovelive
        camera, landmarks = camera_and_map(variables.get("CAMERA"),
                                           variables.get("MAP"))
        server = foxglovelive.LiveServer(
            foxglove["port"], foxglove["host"], camera, landmarks,
            wait=foxglove["wait"], pace=not live)
    try:
        stats = run_launch(description, bar,
                           attach=server.attach if server else None)
    finally:
        if server is not None:
            server.stop()
    if stats["aborted"]:
        print(f"{PROG}: aborted: the outputs may be incomplete",
              file=sys.stderr)
        return 130, {}

    outputs: Dict[str, str] = {}
    summary: Dict[str, Any] = {"pipeline": label, "launch": description}
    if "OUTPUT" in uses and os.path.isfile(variables["OUTPUT"]):
        outputs["video"] = variables["OUTPUT"]
    results = None
    if "LOG" in uses and os.path.isfile(variables["LOG"]):
        outputs["log"] = variables["LOG"]
        results = _read_log(variables["LOG"])
    frames = len(results) if results is not None else stats["frames"]
    summary.update(
        # ms per frame from the reported seconds, so the two agree
        frames=frames, seconds=round(stats["seconds"], 3),
        ms_per_frame=round(1000 * round(stats["seconds"], 3) /
                           max(frames, 1), 3),
        interrupted=stats["interrupted"])
    if results is not None:
        summary.update(log_summary(results))

    accuracy = None
    ev = None
    if truth is not None:
        if results is None:
            raise CliError("--truth needs the pipeline's log (LOG)")
        from . import evaluate
        ev = evaluate.evaluate(results, _read_log(truth))
        accuracy = evaluate.summary(ev)
        outputs["accuracy"] = os.path.join(out_dir, ACCURACY_NAME)
        with open(outputs["accuracy"], "w", encoding="utf-8") as f:
            json.dump(accuracy, f, indent=2)
        summary["accuracy"] = {
            "detection": accuracy["detection"]["all"],
            "position_m": accuracy["pose"].get("all", {}).get(
                "position_m", {}),
            "heading_deg": accuracy["pose"].get("all", {}).get(
                "heading_deg", {})}

    if results is not None and summary.get("frames_with_pose"):
        png = os.path.join(out_dir, PLOT_NAME)
        landmarks = _read_landmarks(variables.get("MAP"))
        from . import evaluate
        if ev is not None and ev.pose_rows:
            evaluate.plot_trajectory(ev, png, landmarks,
                                     evaluate.class_colours(results))
        else:
            plot_estimates(results, png, landmarks)
        outputs["plot"] = png

    outputs["summary"] = os.path.join(out_dir, SUMMARY_NAME)
    summary["out"] = out_dir
    summary["outputs"] = outputs
    with open(outputs["summary"], "w", encoding="utf-8") as f:
        json.dump(summary, f, indent=2)
    print(format_summary(summary), file=stream)
    if accuracy is not None:
        from . import evaluate
        print("", file=stream)
        print(evaluate.format_report(accuracy), file=stream)
    return 0, summary


def add_run_parser(subparsers):
    p = subparsers.add_parser(
        "run", help="run a pipeline on a file or a camera",
        description="Run a shipped pipeline (a name from pipelines/, "
                    "default 'file') or a launch string with ${VAR} "
                    "variables, on a video file or a V4L2 device, and write "
                    "the overlay video, the JSON-lines log, the trajectory "
                    "plot and a summary. Ctrl-C stops cleanly (a second "
                    "one aborts).")
    p.add_argument("pipeline", metavar="PIPELINE", nargs="?",
                   default=DEFAULT_PIPELINE,
                   help="pipeline name (%(default)s; one of "
                        f"{', '.join(pipeline_names())}), a .pipeline file "
                        "or a launch string")
    p.add_argument("--input", "-i", metavar="FILE|DEVICE",
                   help="video file (INPUT) or /dev/video* (DEVICE)")
    p.add_argument("--config", "-c", metavar="project.json",
                   help="project config: {\"palette\": ..., \"map\": ..., "
                        "\"camera\": ...}, paths relative to the file")
    p.add_argument("--out", "-o", metavar="DIR", default=DEFAULT_OUT,
                   help="output folder (default %(default)s)")
    p.add_argument("--truth", metavar="truth.jsonl",
                   help="ground truth: adds the accuracy report")
    p.add_argument("--set", metavar="VAR=VALUE", action="append",
                   default=[], dest="sets",
                   help="set a pipeline variable (repeatable)")
    bar = p.add_mutually_exclusive_group()
    bar.add_argument("--progress", action="store_true", default=None,
                     help="show the progress bar even when stderr is not a "
                          "terminal")
    bar.add_argument("--no-progress", action="store_false",
                     dest="progress", help="no progress bar")
    add_foxglove_arguments(p)
    p.set_defaults(handler=_handle, parser=p)


def _handle(args) -> int:
    # errors are reported here rather than by cli.main, so that they read
    # the same under `python -m gstlandmark.commands.cli`
    try:
        status, _ = run(args.pipeline, args.input, config=args.config,
                        out_dir=args.out, truth=args.truth, sets=args.sets,
                        progress=args.progress,
                        foxglove=foxglove_options(args))
    except CliError as err:
        print(f"{PROG}: error: {err}", file=sys.stderr)
        return err.status
    return status
