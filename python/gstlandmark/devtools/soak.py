"""``gst-landmark soak``: many frames through the whole chain, watching
the process's memory.

The frames are the shipped synthetic clip (tests/files/clips/path-small,
45 frames of the robot driving past landmarks), decoded once, scaled to
``--size`` and pushed again and again from an ``appsrc`` with running
timestamps, so that every frame really has detections, ranges, matches
and (on 44 of 45 frames) a pose::

    appsrc ! labsegment ! blobroundness ! ipmrange ! trilaterate !
        landmarkoverlay ! landmarklog ! fakesink

The pipeline runs in this process; its resident set size (VmRSS of
/proc/self/status) is sampled every ``--every`` frames. Samples before the
end of ``--warmup`` frames are excluded (caches, pools, malloc arenas and
the log's line buffer settle there); ``growth`` is the largest sample after
the warm-up minus the sample at its end. After EOS the log is read back:
one valid JSON line per frame, frames 0, 1, 2, ... with the pushed
timestamps in order. The result is printed as JSON; the exit status is 1
when the growth exceeds ``--max-growth-kb`` (1024) or a frame is missing
from the log or the sink.
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import tempfile
import time
from typing import Any, Dict, List, Optional

from .. import pipeline
from ..commands.common import add_json_option, size_type
from ..synth.writer import clip_files
from .benchkit import write_json
from .sourcetree import ROOT, missing

Gst = pipeline.Gst

CLIP_DIR = os.path.join(ROOT, "tests", "files", "clips",
                        "path-small")
DEFAULT_FRAMES = 100000
DEFAULT_SIZE = (320, 240)
DEFAULT_EVERY = 1000
DEFAULT_MAX_GROWTH_KB = 1024
FPS = 30


def frame_pts(i: int) -> int:
    """Timestamp of frame ``i`` at 30 frames/s, nanoseconds (computed per
    frame so that it does not drift by a nanosecond a frame)."""
    return i * Gst.SECOND // FPS


def rss_kb(pid: Optional[int] = None) -> int:
    """Resident set size of a process (default: this one), KiB."""
    path = f"/proc/{pid or 'self'}/status"
    with open(path) as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    raise RuntimeError(f"{path}: no VmRSS")


def clip_frames(width: int, height: int,
                clip_dir: str = CLIP_DIR) -> List[bytes]:
    """Every frame of ``clip_dir``/clip.avi as packed RGB bytes (default
    GStreamer stride) at ``width`` x ``height``."""
    clip = clip_files(clip_dir)["clip"]
    if not os.path.isfile(clip):
        raise pipeline.PipelineError(missing(clip))
    pipeline.init()
    pipe = Gst.parse_launch(
        f'filesrc location="{clip}" ! '
        "decodebin ! videoconvert ! videoscale ! "
        f"video/x-raw,format=RGB,width={width},height={height} ! "
        "appsink name=sink sync=false")
    sink = pipe.get_by_name("sink")
    frames: List[bytes] = []
    pipe.set_state(Gst.State.PLAYING)
    try:
        while True:
            sample = sink.emit("try-pull-sample", 30 * Gst.SECOND)
            if sample is None:
                break
            buf = sample.get_buffer()
            frames.append(buf.extract_dup(0, buf.get_size()))
        msg = pipe.get_bus().pop_filtered(Gst.MessageType.ERROR)
        if msg is not None or not sink.get_property("eos"):
            raise pipeline.PipelineError(f"{clip_dir}: clip not decoded")
    finally:
        pipe.set_state(Gst.State.NULL)
    return frames


def chain(log: str, clip_dir: str = CLIP_DIR, flush_every: int = 0) -> str:
    """The whole chain with the clip's palette, map and true camera (the
    settings of pipelines/file.pipeline), ending in landmarklog (named
    ``log``). Bus messages are off: an application that does not read
    them would see its bus queue grow, which is not what is measured
    here."""
    files = clip_files(clip_dir)
    with open(files["scene"]) as f:
        cam = json.load(f)["camera"]
    map_file = files["map"]
    return (
        f"labsegment palette={files['palette']} min-class-pixels=50 ! "
        "blobroundness min-area=30 ! "
        f"ipmrange camera-height={cam['height_m']} tilt={cam['tilt_deg']} "
        f"hfov={cam['hfov_deg']} map={map_file} ! "
        f"trilaterate map={map_file} filter=ekf post-messages=false ! "
        f"landmarkoverlay map={map_file} ! "
        f"landmarklog name=log location={log} flush-every={flush_every}")


def check_log(path: str, frames: int,
              exact_pts: bool = True) -> Dict[str, Any]:
    """Reads a landmarklog file line by line: counts lines, poses and
    detections, and lists what is wrong (a line that is not JSON, frame
    numbers out of order, timestamps other than ``frame_pts(i)`` (or, not
    ``exact_pts``, not increasing), an incomplete last line, a line count
    other than ``frames``)."""
    problems: List[str] = []
    lines = poses = detections = 0
    last = b"\n"
    previous = -1
    with open(path, "rb") as f:
        for raw in f:
            last = raw
            try:
                line = json.loads(raw)
            except ValueError:
                problems.append(f"line {lines + 1} is not JSON")
                lines += 1
                continue
            got = line.get("pts", -1)
            want = frame_pts(lines) if exact_pts else max(got, previous + 1)
            previous = got
            if line.get("frame") != lines or got != want:
                if len(problems) < 10:
                    problems.append(
                        f"line {lines + 1}: frame {line.get('frame')} pts "
                        f"{line.get('pts')}, expected {lines} and {want}")
            poses += "pose" in line
            detections += len(line.get("detections", ()))
            lines += 1
    if not last.endswith(b"\n"):
        problems.append("the last line is incomplete")
    if lines != frames:
        problems.append(f"{lines} log lines for {frames} frames")
    return {"lines": lines, "poses": poses, "detections": detections,
            "problems": problems}


def run_soak(frames: int = DEFAULT_FRAMES, size=DEFAULT_SIZE,
             every: int = DEFAULT_EVERY, warmup: Optional[int] = None,
             max_growth_kb: int = DEFAULT_MAX_GROWTH_KB,
             log: Optional[str] = None, progress=None,
             prepare=None) -> Dict[str, Any]:
    """Runs the soak; returns the report (``ok`` says whether it passed).
    ``log`` defaults to a temporary file removed afterwards; ``prepare``,
    if given, is called with the pipeline before it starts (the tests use
    it to check that a leak is seen)."""
    if warmup is None:
        warmup = frames // 10
    if not 0 <= warmup < frames:
        raise ValueError("the warm-up must be shorter than the run")
    args = (frames, size, every, warmup, max_growth_kb)
    if log is not None:
        return _soak(*args, log, progress, prepare)
    tmp = tempfile.mkdtemp(prefix="gst-landmark-soak-")
    try:
        return _soak(*args, os.path.join(tmp, "log.jsonl"), progress,
                     prepare)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _soak(frames, size, every, warmup, max_growth_kb, log, progress,
          prepare) -> Dict[str, Any]:
    width, height = size
    pipeline.init()
    templates = [Gst.Buffer.new_wrapped(data)
                 for data in clip_frames(width, height)]
    caps = (f"video/x-raw,format=RGB,width={width},height={height},"
            f"framerate={FPS}/1")
    # block=true, max-buffers: the push loop waits for the chain, so the
    # frame count of a sample is the chain's within a few frames
    try:
        pipe = Gst.parse_launch(
            f"appsrc name=src format=time block=true max-buffers=4 "
            f"caps={caps} ! {chain(log)} ! fakesink name=sink sync=false")
    except Exception as err:    # GLib.Error: an element is missing
        raise pipeline.PipelineError(
            f"cannot build the pipeline: {getattr(err, 'message', err)}"
        ) from None
    src, sink = pipe.get_by_name("src"), pipe.get_by_name("sink")
    bus = pipe.get_bus()
    if prepare is not None:
        prepare(pipe)
    samples: List[List[int]] = []
    error = None

    def drain_bus():
        # nothing but state changes and the like is expected; reading the
        # bus keeps its queue from growing during the run
        while True:
            msg = bus.pop()
            if msg is None:
                return None
            if msg.type == Gst.MessageType.ERROR:
                err, dbg = msg.parse_error()
                return f"{msg.src.get_name()}: {err.message} ({dbg})"

    t0 = time.perf_counter()
    try:
        if pipe.set_state(Gst.State.PLAYING) == \
                Gst.StateChangeReturn.FAILURE:
            raise pipeline.PipelineError(drain_bus() or "could not start")
        for i in range(frames):
            # a new buffer on the template's memory shares its pixels; the
            # overlay's drawing gets its own copy (shared memory is never
            # written). Not Buffer.copy(): gst-python 1.26 holds extra
            # references to the copy, which then refuses a timestamp.
            template = templates[i % len(templates)]
            buf = Gst.Buffer.new()
            for k in range(template.n_memory()):
                buf.append_memory(template.get_memory(k))
            buf.pts = frame_pts(i)
            buf.duration = frame_pts(i + 1) - buf.pts
            if src.emit("push-buffer", buf) != Gst.FlowReturn.OK:
                error = drain_bus() or f"push-buffer failed at frame {i}"
                break
            del buf
            if (i + 1) % every == 0:
                samples.append([i + 1, rss_kb()])
                error = drain_bus()
                if error:
                    break
                if progress is not None:
                    progress(i + 1, frames, samples[-1][1])
        if error is None:
            src.emit("end-of-stream")
            msg = bus.timed_pop_filtered(
                120 * Gst.SECOND, Gst.MessageType.EOS | Gst.MessageType.ERROR)
            if msg is None:
                error = "no EOS within 120 s"
            elif msg.type == Gst.MessageType.ERROR:
                err, dbg = msg.parse_error()
                error = f"{msg.src.get_name()}: {err.message} ({dbg})"
        seconds = time.perf_counter() - t0
        samples.append([frames, rss_kb()])      # after EOS, still PLAYING
        rendered = sink.get_property("stats").get_value("rendered")
    finally:
        pipe.set_state(Gst.State.NULL)

    logged = check_log(log, frames)
    log_bytes = os.path.getsize(log)

    after = [kb for n, kb in samples if n >= warmup]
    at_warmup = next((kb for n, kb in samples if n >= warmup), None)
    growth = max(after) - at_warmup if after else None
    failures = list(logged["problems"])
    if error:
        failures.insert(0, error)
    if rendered != frames:
        failures.append(f"{rendered} frames reached the sink, not {frames}")
    if growth is None:
        failures.append("no RSS sample after the warm-up")
    elif growth > max_growth_kb:
        failures.append(f"RSS grew by {growth} KiB after the warm-up "
                        f"(limit {max_growth_kb} KiB)")
    return {
        "frames": frames, "size": f"{width}x{height}",
        "seconds": round(seconds, 2),
        "fps": round(frames / seconds, 1) if seconds > 0 else None,
        "warmup_frames": warmup, "sample_every": every,
        "rss_start_kb": samples[0][1] if samples else None,
        "rss_warmup_kb": at_warmup, "rss_max_kb": max(after, default=None),
        "rss_end_kb": samples[-1][1] if samples else None,
        "growth_kb": growth, "max_growth_kb": max_growth_kb,
        "sink_frames": rendered, "log_lines": logged["lines"],
        "log_bytes": log_bytes, "poses": logged["poses"],
        "detections": logged["detections"],
        "ok": not failures, "failures": failures, "samples": samples,
    }


def add_soak_parser(subparsers):
    p = subparsers.add_parser(
        "soak", help="many frames through the whole chain, watching memory",
        description=__doc__.split("\n\n")[0] + " See the module's "
        "documentation (gstlandmark/soak.py) for the pipeline and checks.")
    p.add_argument("--frames", type=int, default=DEFAULT_FRAMES,
                   help="frames to push (default %(default)s)")
    p.add_argument("--size", type=size_type, default="%dx%d" % DEFAULT_SIZE,
                   help="WIDTHxHEIGHT (default %(default)s)")
    p.add_argument("--every", type=int, default=DEFAULT_EVERY,
                   help="sample the RSS every N frames (default "
                        "%(default)s)")
    p.add_argument("--warmup", type=int,
                   help="frames excluded from the growth (default: a "
                        "tenth of --frames)")
    p.add_argument("--max-growth-kb", type=int,
                   default=DEFAULT_MAX_GROWTH_KB,
                   help="largest allowed RSS growth after the warm-up, KiB "
                        "(default %(default)s)")
    p.add_argument("--log", help="keep landmarklog's file here (default: a "
                                 "temporary file, removed)")
    add_json_option(p, "the report, with every RSS sample,")
    p.set_defaults(handler=_handle, parser=p)


def _handle(args) -> int:
    if args.frames <= 0 or args.every <= 0:
        args.parser.error("--frames and --every must be positive")
    if args.warmup is not None and not 0 <= args.warmup < args.frames:
        args.parser.error("--warmup must be below --frames")

    def progress(done, total, kb):
        if sys.stderr.isatty():
            sys.stderr.write(f"\r{done}/{total} frames, RSS {kb} KiB ")
            sys.stderr.flush()

    try:
        report = run_soak(args.frames, args.size, args.every, args.warmup,
                          args.max_growth_kb, args.log, progress)
    except pipeline.PipelineError as err:
        print(f"gst-landmark: error: {err}", file=sys.stderr)
        return 1
    if sys.stderr.isatty():
        sys.stderr.write("\n")
    write_json(args.json, report)
    shown = {k: v for k, v in report.items() if k != "samples"}
    print(json.dumps(shown, indent=2))
    return 0 if report["ok"] else 1
