"""Live latency and file throughput of the shipped pipelines:
``gst-landmark bench latency`` and ``gst-landmark bench file``.

Prints numbers; it is not a timed test.

``bench latency`` runs ``pipelines/camera.pipeline`` (YUY2) and
``pipelines/camera-mjpeg.pipeline`` (JPEG decode included) as shipped, with
a live source at 30 frames/s standing in for the camera and a ``fakesink
sync=true`` for the window:

- ``testsrc``: ``videotestsrc is-live=true`` (for the MJPEG line followed by
  ``jpegenc``, so that ``jpegdec`` decodes real JPEG); its bars hold no
  landmark, so the frames carry no pose;
- ``scene``: one rendered frame of the synthetic path scenario (the same
  frames as ``bench chain``), repeated by ``imagefreeze is-live=true``; the
  chain finds its landmarks and trilaterate attaches a pose.

Pad probes give, per frame, the running time at which it reaches the sink
(with trilaterate's pose meta when it has one) minus its capture running
time (its PTS through the segment): the glass-to-pose latency. Also the
time it leaves trilaterate, the time the stand-in's ``jpegenc`` took (a
real MJPEG camera encodes before it timestamps) and the latency the
pipeline reports (GST_QUERY_LATENCY).

``bench file`` records an MJPEG AVI of synthetic frames with
``multifilesrc ! pngdec ! videoconvert ! jpegenc ! avimux`` and times
``pipelines/file.pipeline`` on it (decode, chain, landmarklog, overlay,
JPEG encode, avimux, filesink: sync=false, as a file sink is) against
``jpegdec`` alone on the same file (the floor) and decode plus the chain
into ``fakesink`` (``pipelines/regression.pipeline``).
"""

import os
import re
import resource
import sys
import tempfile
import time

import cv2
import numpy as np

from .. import pipeline, pipelinefile
from ..commands.common import size_type
from .benchkit import BenchError, add_report_options, write_json

Gst = pipeline.Gst

FPS = 30
LIVE_PIPELINES = ("camera", "camera-mjpeg")
SOURCES = ("testsrc", "scene")
DEFAULT_LIVE_SIZES = ((640, 480), (1280, 720))
DEFAULT_LIVE_FRAMES = 300
DEFAULT_WARMUP = 30
DEFAULT_FILE_SIZES = ((640, 480), (1920, 1080))
DEFAULT_FILE_FRAMES = 300
DEFAULT_RUNS = 3
DISTINCT = 8
SINK_NAME = "glass"
STANDIN_ENCODER = "standin"

# Where the shipped live lines name the camera, and what stands in for it.
CAMERA_JPEG = re.compile(
    r"v4l2src\s+device=\$\{DEVICE\}\s*!\s*image/jpeg,width=\d+,height=\d+")
CAMERA_RAW = re.compile(
    r"v4l2src\s+device=\$\{DEVICE\}\s*!\s*"
    r"video/x-raw,format=(\w+),width=\d+,height=\d+")


# ---------------------------------------------------------------------------
# Files: palette, map, camera and frames of the path scenario


class SceneFiles:
    """Frames of the synthetic path scenario at one size (PNG), with the
    palette, map and camera file the shipped lines take as variables."""

    def __init__(self, width, height, out_dir, distinct=1):
        from ..synth.writer import write_camera_yaml
        from .chainbench import Scenario
        os.makedirs(out_dir, exist_ok=True)
        scen = Scenario(width, height, distinct, out_dir)
        tag = f"{width}x{height}"
        self.camera_path = os.path.join(out_dir, f"{tag}.camera.yml")
        write_camera_yaml(scen.camera, self.camera_path)
        self.png_pattern = os.path.join(out_dir, f"{tag}.frame%d.png")
        for k, bgrx in enumerate(scen.bgrx):
            cv2.imwrite(self.png_pattern % k, bgrx[..., :3])
        self.width, self.height, self.distinct = width, height, distinct
        self.variables = {"PALETTE": scen.palette_path,
                          "MAP": scen.map_path,
                          "CAMERA": self.camera_path}


def substitute(desc, variables, where):
    """``desc`` with its ${VAR} replaced; BenchError naming ``where`` when
    one is left."""
    for name, value in variables.items():
        desc = desc.replace("${" + name + "}", str(value))
    left = re.findall(r"\$\{(\w+)\}", desc)
    if left:
        raise BenchError(f"{where}: no value for ${{{left[0]}}}")
    return desc


def shipped_line(name):
    path = os.path.join(pipelinefile.pipelines_dir(),
                        name + pipelinefile.SUFFIX)
    try:
        return path, pipelinefile.launch_line(path)
    except ValueError as err:
        raise BenchError(str(err)) from None


# ---------------------------------------------------------------------------
# Live latency


def stand_in_source(source, files, frames):
    """A live source of ``frames`` frames at 30 frames/s."""
    if source == "testsrc":
        return f"videotestsrc is-live=true num-buffers={frames}"
    if source == "scene":
        return (f"filesrc location={files.png_pattern % 0} ! pngdec ! "
                f"videoconvert ! imagefreeze is-live=true "
                f"num-buffers={frames}")
    raise BenchError(f"unknown source {source!r} (one of "
                     f"{', '.join(SOURCES)})")


def live_launch(name, source, files, frames):
    """The shipped live pipeline ``name`` with the stand-in camera at the
    files' size and a synchronised fakesink named ``glass`` for the
    window."""
    path, desc = shipped_line(name)
    src = stand_in_source(source, files, frames)
    size = f"width={files.width},height={files.height},framerate={FPS}/1"
    desc, n_jpeg = CAMERA_JPEG.subn(
        f"{src} ! video/x-raw,{size} ! jpegenc name={STANDIN_ENCODER} ! "
        f"image/jpeg,{size}", desc)
    desc, n_raw = CAMERA_RAW.subn(
        lambda m: f"{src} ! video/x-raw,format={m.group(1)},{size}", desc)
    if n_jpeg + n_raw != 1 or "autovideosink" not in desc:
        raise BenchError(f"{path}: expected one v4l2src camera and an "
                         f"autovideosink")
    desc = desc.replace("autovideosink",
                        f"fakesink name={SINK_NAME} sync=true")
    return substitute(desc, files.variables, path)


def _elements_of(pipe, factory):
    found = []
    it = pipe.iterate_recurse()
    while True:
        res, elem = it.next()
        if res != Gst.IteratorResult.OK:
            return found
        if elem.get_factory().get_name() == factory:
            found.append(elem)


class _Stamps:
    """Running time at which each frame (by capture running time) passed
    a pad."""

    def __init__(self, pad, on_buffer=None):
        self.times = {}
        self.on_buffer = on_buffer
        pad.add_probe(Gst.PadProbeType.BUFFER, self._probe)

    def _probe(self, pad, info):
        elem = pad.get_parent_element()
        clock = elem.get_clock()
        if clock is None:
            return Gst.PadProbeReturn.OK
        now = clock.get_time() - elem.get_base_time()
        buf = info.get_buffer()
        event = pad.get_sticky_event(Gst.EventType.SEGMENT, 0)
        capture = event.parse_segment().to_running_time(Gst.Format.TIME,
                                                        buf.pts)
        self.times[capture] = now
        if self.on_buffer is not None:
            self.on_buffer(capture, buf)
        return Gst.PadProbeReturn.OK


def measure_live(desc, warmup, timeout_s=120.0):
    """Runs a live launch line to EOS; per frame after ``warmup``: the
    latency at the sink, on leaving trilaterate and of the stand-in's
    encoder (seconds), which frames had a pose; and the reported
    latency."""
    from .. import meta
    pipeline.init()
    pipe = Gst.parse_launch(desc)
    poses = set()
    sink = _Stamps(pipe.get_by_name(SINK_NAME).get_static_pad("sink"),
                   lambda capture, buf: meta.pose(buf) is not None
                   and poses.add(capture))
    tri = [_Stamps(e.get_static_pad("src"))
           for e in _elements_of(pipe, "trilaterate")]
    enc = pipe.get_by_name(STANDIN_ENCODER)
    enc = _Stamps(enc.get_static_pad("src")) if enc is not None else None
    src = [_Stamps(e.get_static_pad("src"))
           for factory in ("videotestsrc", "imagefreeze")
           for e in _elements_of(pipe, factory)]
    reported = None
    if pipe.set_state(Gst.State.PLAYING) == Gst.StateChangeReturn.FAILURE:
        pipe.set_state(Gst.State.NULL)
        raise BenchError(f"could not start: {desc}")
    try:
        pipe.get_state(10 * Gst.SECOND)
        query = Gst.Query.new_latency()
        if pipe.query(query):
            live, lo, hi = query.parse_latency()
            reported = {"live": bool(live), "min": lo / Gst.SECOND,
                        "max": None if hi == Gst.CLOCK_TIME_NONE
                        else hi / Gst.SECOND}
        pipeline.wait_eos(pipe, timeout_s, desc)
    except pipeline.PipelineError as err:
        raise BenchError(str(err)) from None
    finally:
        pipe.set_state(Gst.State.NULL)
    frames = sorted(sink.times)[warmup:]
    if not frames:
        raise BenchError(f"no frame reached the sink after {warmup} "
                         f"warm-up frames: {desc}")

    def delays(stamps, since=None):
        start = since.times if since else {c: c for c in frames}
        return np.array([stamps.times[c] - start[c] for c in frames
                         if c in stamps.times and c in start]) / Gst.SECOND

    # where the camera's frame enters: after the stand-in's encoder
    entry = enc or (src[0] if src else None)
    first = min(sink.times)
    return {"frames": len(frames),
            "poses": sum(1 for c in frames if c in poses),
            "sink": delays(sink),
            "trilaterate": delays(tri[0]) if tri else None,
            "encode": delays(enc) if enc else None,
            "source": delays(src[0]) if src else None,
            "host": delays(sink, entry) if entry else None,
            "first_frame": (sink.times[first] - first) / Gst.SECOND,
            "reported": reported}


def _ms(x):
    return None if x is None else round(1000.0 * float(x), 3)


def summarise_live(runs):
    """One row from several runs of one configuration: median of the run
    medians (and their range), median of the run p95s, the largest
    max, and the other columns' medians."""
    med = [float(np.median(r["sink"])) for r in runs]
    p95 = [float(np.percentile(r["sink"], 95)) for r in runs]

    def part(key):
        vals = [float(np.median(r[key])) for r in runs
                if r[key] is not None and len(r[key])]
        return _ms(np.median(vals)) if vals else None

    rep = runs[0]["reported"]
    return {"median_ms": _ms(np.median(med)),
            "run_medians_ms": [_ms(m) for m in med],
            "p95_ms": _ms(np.median(p95)),
            "max_ms": _ms(max(float(r["sink"].max()) for r in runs)),
            "source_ms": part("source"),
            "host_ms": part("host"),
            "trilaterate_ms": part("trilaterate"),
            "standin_encode_ms": part("encode"),
            "first_frame_ms": _ms(np.median([r["first_frame"]
                                             for r in runs])),
            "frames": sum(r["frames"] for r in runs),
            "poses": sum(r["poses"] for r in runs),
            "reported_ms": None if rep is None else _ms(rep["min"])}


def bench_latency(sizes, sources, pipelines, frames, warmup, runs,
                  out_dir, progress=None):
    """Rows of the latency table (see the module doc)."""
    rows = []
    for width, height in sizes:
        files = SceneFiles(width, height,
                           os.path.join(out_dir, f"{width}x{height}"))
        configs = [(name, src) for name in pipelines for src in sources]
        results = {c: [] for c in configs}
        for run in range(runs):         # configurations alternate
            for name, src in configs:
                if progress:
                    progress(f"{name} {width}x{height} {src}, run "
                             f"{run + 1}/{runs}")
                results[(name, src)].append(measure_live(
                    live_launch(name, src, files, frames + warmup), warmup))
        for (name, src), res in results.items():
            rows.append({"pipeline": name, "size": f"{width}x{height}",
                         "source": src, **summarise_live(res)})
    return rows


LIVE_COLUMNS = (("median_ms", "median"), ("p95_ms", "p95"),
                ("max_ms", "max"), ("source_ms", "at src"),
                ("trilaterate_ms", "at tri"), ("host_ms", "in->sink"),
                ("standin_encode_ms", "enc"), ("first_frame_ms", "first"),
                ("reported_ms", "reported"))


def _cell(value):
    return "-" if value is None else f"{value:.2f}"


def print_latency(rows, load):
    print(f"glass-to-pose latency, ms (live source {FPS} frames/s; load "
          f"average {load[0]} before, {load[1]} after)")
    print(f"{'pipeline':13s} {'size':>9s} {'source':7s} "
          + " ".join(f"{title:>8s}" for _, title in LIVE_COLUMNS)
          + "   poses/frames")
    for r in rows:
        print(f"{r['pipeline']:13s} {r['size']:>9s} {r['source']:7s} "
              + " ".join(f"{_cell(r[key]):>8s}" for key, _ in LIVE_COLUMNS)
              + f"   {r['poses']}/{r['frames']}")
    print("median/p95: medians over the runs; max: over all runs; at src, "
          "at tri, enc: medians on leaving the stand-in source, trilaterate, "
          "the stand-in's jpegenc; in->sink: median from leaving the "
          "stand-in (its jpegenc for MJPEG) to the sink; first: the first "
          "frame; reported: the "
          "pipeline's minimum latency (GST_QUERY_LATENCY)")


def load_average():
    """The 1-minute load average (what ``uptime`` shows first)."""
    return round(os.getloadavg()[0], 2)


def _report(args, default_sizes, prefix, run, show):
    """Runs a table's benchmark (``run(sizes, out_dir, progress)``) between
    two load readings, prints it (``show``) and writes the JSON."""
    out_dir = args.out or tempfile.mkdtemp(prefix=prefix)
    progress = None if args.quiet else (
        lambda line: print(line, file=sys.stderr))
    before = load_average()
    rows = run(args.size or list(default_sizes), out_dir, progress)
    load = (before, load_average())
    show(rows, load)
    write_json(args.json, {"load_average": load, "rows": rows})
    return 0


def _handle_latency(args):
    return _report(args, DEFAULT_LIVE_SIZES, "landmark-latency-",
                   lambda sizes, out_dir, progress: bench_latency(
                       sizes, args.source or list(SOURCES),
                       args.pipeline or list(LIVE_PIPELINES), args.frames,
                       args.warmup, args.runs, out_dir, progress),
                   print_latency)


# ---------------------------------------------------------------------------
# File throughput


def record_clip(files, frames, path):
    """An MJPEG AVI of ``frames`` frames cycling the files' PNG frames."""
    pipeline.init()
    desc = (f"multifilesrc location={files.png_pattern} index=0 "
            f"stop-index={files.distinct - 1} loop=true "
            f"num-buffers={frames} caps=image/png,framerate={FPS}/1 ! "
            f"pngdec ! videoconvert ! jpegenc ! avimux ! "
            f"filesink location={path}")
    try:
        pipeline.run_to_eos(desc, timeout_s=600)
    except pipeline.PipelineError as err:
        raise BenchError(f"recording {path}: {err}") from None
    return path


def time_to_eos(desc, count_factory, timeout_s=600.0):
    """Wall and process CPU seconds from PLAYING to EOS, the frames
    leaving the last element made by ``count_factory`` and when the first
    one did."""
    pipeline.init()
    pipe = Gst.parse_launch(desc)
    counted = _elements_of(pipe, count_factory)
    if not counted:
        raise BenchError(f"no {count_factory} in {desc}")
    n = [0]
    first = []

    def count(pad, info):
        if not first:
            first.append(time.perf_counter())
        n[0] += 1
        return Gst.PadProbeReturn.OK

    counted[-1].get_static_pad("src").add_probe(Gst.PadProbeType.BUFFER,
                                                count)
    cpu0 = resource.getrusage(resource.RUSAGE_SELF)
    t0 = time.perf_counter()
    pipe.set_state(Gst.State.PLAYING)
    try:
        pipeline.wait_eos(pipe, timeout_s, desc)
    except pipeline.PipelineError as err:
        raise BenchError(str(err)) from None
    finally:
        wall = time.perf_counter() - t0
        cpu1 = resource.getrusage(resource.RUSAGE_SELF)
        pipe.set_state(Gst.State.NULL)
    cpu = (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)
    return {"wall_s": wall, "cpu_s": cpu, "frames": n[0],
            "first_frame_s": first[0] - t0 if first else None}


def file_cases(clip, files, out_dir):
    """(name, launch line, element whose output is counted)."""
    variables = dict(files.variables, INPUT=clip,
                     LOG=os.path.join(out_dir, "log.jsonl"))
    cases = [("jpegdec alone",
              f"filesrc location={clip} ! avidemux ! jpegdec ! "
              f"fakesink sync=false", "jpegdec")]
    for name, output in (("regression", "regress.jsonl"),
                         ("file", "overlay.avi")):
        path, desc = shipped_line(name)
        variables["OUTPUT"] = os.path.join(out_dir, output)
        cases.append((f"{name}.pipeline", substitute(desc, variables, path),
                      "trilaterate"))
    return cases


def bench_file(sizes, frames, runs, out_dir, progress=None):
    """Rows of the throughput table (see the module doc)."""
    rows = []
    for width, height in sizes:
        folder = os.path.join(out_dir, f"{width}x{height}")
        files = SceneFiles(width, height, folder, distinct=DISTINCT)
        clip = record_clip(files, frames, os.path.join(folder, "clip.avi"))
        cases = file_cases(clip, files, folder)
        results = {name: [] for name, _, _ in cases}
        for run in range(runs):
            for name, desc, factory in cases:
                if progress:
                    progress(f"{name} {width}x{height}, run {run + 1}/"
                             f"{runs}")
                res = time_to_eos(desc, factory)
                if res["frames"] != frames:
                    raise BenchError(f"{name}: {res['frames']} of {frames} "
                                     f"frames")
                results[name].append(res)
        for name, res in results.items():
            fps = [r["frames"] / r["wall_s"] for r in res]
            cpu = [1000.0 * r["cpu_s"] / r["frames"] for r in res]
            rows.append({"pipeline": name, "size": f"{width}x{height}",
                         "frames": frames, "runs": len(res),
                         "fps": round(float(np.median(fps)), 1),
                         "fps_range": [round(min(fps), 1),
                                       round(max(fps), 1)],
                         "cpu_ms_per_frame": round(float(np.median(cpu)),
                                                   2),
                         "first_frame_ms": _ms(np.median(
                             [r["first_frame_s"] for r in res]))})
    return rows


def print_file(rows, load):
    print(f"MJPEG AVI throughput, frames per second from PLAYING to EOS "
          f"(load average {load[0]} before, {load[1]} after)")
    print(f"{'pipeline':20s} {'size':>9s} {'frames/s':>9s} "
          f"{'runs (min-max)':>16s} {'CPU ms/frame':>13s} "
          f"{'first ms':>9s}")
    for r in rows:
        lo, hi = r["fps_range"]
        print(f"{r['pipeline']:20s} {r['size']:>9s} {r['fps']:9.1f} "
              f"{f'{lo:.1f}-{hi:.1f}':>16s} {r['cpu_ms_per_frame']:13.2f} "
              f"{r['first_frame_ms']:9.1f}")
    print("frames/s: median over the runs; CPU: this process's user+system "
          "time per frame, all threads; first: from PLAYING to the first "
          "frame out of the decoder or trilaterate (median)")


def _handle_file(args):
    return _report(args, DEFAULT_FILE_SIZES, "landmark-file-",
                   lambda sizes, out_dir, progress: bench_file(
                       sizes, args.frames, args.runs, out_dir, progress),
                   print_file)


def _common_options(parser, frames):
    parser.add_argument("--size", type=size_type, action="append",
                        metavar="WxH", help="frame size (repeatable)")
    parser.add_argument("--frames", type=int, default=frames, metavar="N",
                        help=f"frames per run (default {frames})")
    parser.add_argument("--runs", type=int, default=DEFAULT_RUNS,
                        metavar="N", help=f"runs of each case, alternated "
                                          f"(default {DEFAULT_RUNS})")
    parser.add_argument("--out", metavar="DIR",
                        help="keep the frames, files and outputs here")
    add_report_options(parser)


LATENCY_HELP = "glass-to-pose latency of the live pipelines"
LATENCY_DESCRIPTION = (
    "Run pipelines/camera.pipeline and camera-mjpeg.pipeline with a live "
    "source standing in for the camera and time each frame from its "
    "capture to the sink (default sizes 640x480 and 1280x720).")
FILE_HELP = "frames per second of pipelines/file.pipeline on an MJPEG AVI"
FILE_DESCRIPTION = (
    "Record an MJPEG AVI of synthetic frames and time pipelines/"
    "file.pipeline on it against jpegdec alone (default sizes 640x480 and "
    "1920x1080).")


def add_latency_bench_parsers(actions):
    """``bench latency`` and ``bench file``."""
    lat = actions.add_parser("latency", help=LATENCY_HELP,
                             description=LATENCY_DESCRIPTION)
    _common_options(lat, DEFAULT_LIVE_FRAMES)
    lat.add_argument("--warmup", type=int, default=DEFAULT_WARMUP,
                     metavar="N", help=f"frames not counted first "
                                       f"(default {DEFAULT_WARMUP})")
    lat.add_argument("--source", action="append", choices=SOURCES,
                     help="stand-in camera (repeatable; default both)")
    lat.add_argument("--pipeline", action="append", choices=LIVE_PIPELINES,
                     help="shipped live pipeline (repeatable; default both)")
    lat.set_defaults(handler=_handle_latency)
    fil = actions.add_parser("file", help=FILE_HELP,
                             description=FILE_DESCRIPTION)
    _common_options(fil, DEFAULT_FILE_FRAMES)
    fil.set_defaults(handler=_handle_file)
