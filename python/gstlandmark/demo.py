"""The main job's demo: the synthetic robot's camera clip through the
chain, with a palette learned from the clip's colour chart.

The clip (``gst-landmark synth path``) is rendered on first run and kept
under ``out/clips``. Writes, in the output folder:

- ``palette.json``: the palette learned from the clip's chart frame;
- ``labels.avi``: the false-colour segmentation (``labsegment
  output=labels``), the seed's figure 3.6 as video;
- ``log.jsonl``: ``landmarklog``'s line per frame;
- ``preview.png``: one frame and its segmentation side by side;
- ``summary.json``: frames, ms per frame, and the share of each class.
"""

from __future__ import annotations

import json
import os
import time
from typing import Dict, List

import cv2
import numpy as np

from . import meta, pipeline
from .scenes import floor_scene

Gst = pipeline.Gst


def write_clip(path: str, width: int, height: int, frames: int,
               fps: int = 30) -> None:
    """Renders the generated floor scene to an MJPEG AVI file."""
    pipeline.init()
    caps = (f"video/x-raw,format=RGB,width={width},height={height},"
            f"framerate={fps}/1")
    pipe = Gst.parse_launch(
        f"appsrc name=src format=time caps={caps} ! videoconvert ! "
        f"jpegenc quality=92 ! avimux ! filesink location={path}")
    src = pipe.get_by_name("src")
    pipe.set_state(Gst.State.PLAYING)
    try:
        for i in range(frames):
            # glide forwards and sideways and back, keeping discs in view
            phase = 2 * np.pi * i / max(frames, 1)
            shift = (0.25 * np.sin(phase), 0.45 * (1 - np.cos(phase)))
            buf = Gst.Buffer.new_wrapped(floor_scene(
                width, height, index=i, camera_shift=shift).tobytes())
            buf.pts = i * Gst.SECOND // fps
            buf.duration = Gst.SECOND // fps
            src.emit("push-buffer", buf)
        src.emit("end-of-stream")
        _wait_eos(pipe)
    finally:
        pipe.set_state(Gst.State.NULL)


def segment_clip(clip: str, out_video: str, preview_frame: int,
                 palette: str = None, log: str = None) -> Dict:
    """Runs ``labsegment output=labels`` (and ``landmarklog`` when ``log``
    is given) over a clip; returns statistics and the preview frame's
    input and output images."""
    pipeline.init()
    props = f" palette={palette}" if palette else ""
    logger = f"landmarklog location={log} ! " if log else ""
    pipe = Gst.parse_launch(
        f"filesrc location={clip} ! decodebin ! videoconvert ! "
        f"video/x-raw,format=RGB ! labsegment name=seg output=labels{props} "
        f"! {logger}videoconvert ! jpegenc quality=92 ! avimux ! "
        f"filesink location={out_video}")
    stats: Dict = {"frames": 0, "class_pixels": {}, "ms": []}
    preview: Dict = {}
    seg = pipe.get_by_name("seg")
    entered: List[float] = []

    # Probes around the element: its own time per frame, the labels meta,
    # and the preview frame before and after (it draws in place).
    def on_enter(pad, info):
        if stats["frames"] == preview_frame:
            preview["input"] = _buffer_rgb(info.get_buffer(),
                                           pad.get_current_caps())
        entered.append(time.perf_counter())
        return Gst.PadProbeReturn.OK

    def on_leave(pad, info):
        stats["ms"].append((time.perf_counter() - entered.pop(0)) * 1e3)
        buf = info.get_buffer()
        lm = meta.labels(buf)
        for c in lm.classes:
            stats["class_pixels"][c.name] = (
                stats["class_pixels"].get(c.name, 0) + c.labelled)
        stats["class_pixels"]["(none)"] = (
            stats["class_pixels"].get("(none)", 0) + lm.unclassified)
        if stats["frames"] == preview_frame:
            preview["labels"] = _buffer_rgb(buf, pad.get_current_caps())
        stats["frames"] += 1
        return Gst.PadProbeReturn.OK

    seg.get_static_pad("sink").add_probe(Gst.PadProbeType.BUFFER, on_enter)
    seg.get_static_pad("src").add_probe(Gst.PadProbeType.BUFFER, on_leave)
    pipe.set_state(Gst.State.PLAYING)
    try:
        _wait_eos(pipe)
    finally:
        pipe.set_state(Gst.State.NULL)
    return {"stats": stats, "preview": preview}


def _buffer_rgb(buf, caps):
    s = caps.get_structure(0)
    w, h = s.get_value("width"), s.get_value("height")
    with buf.map(Gst.MapFlags.READ) as m:
        stride = len(m.data) // h
        arr = np.frombuffer(m.data, np.uint8).reshape(h, stride)
        return arr[:, :w * 3].reshape(h, w, 3).copy()


def _wait_eos(pipe, timeout_s=120):
    bus = pipe.get_bus()
    msg = bus.timed_pop_filtered(timeout_s * Gst.SECOND,
                                 Gst.MessageType.EOS | Gst.MessageType.ERROR)
    if msg is None:
        raise pipeline.PipelineError("pipeline did not finish in time")
    if msg.type == Gst.MessageType.ERROR:
        err, dbg = msg.parse_error()
        raise pipeline.PipelineError(f"{err.message} ({dbg})")


def synthetic_clip(folder: str, width: int, height: int,
                   frames: int = None, seed: int = 0) -> str:
    """The ``path`` scenario rendered into ``folder`` once, reused after."""
    from . import synth
    done = os.path.join(folder, "scene.json")
    if not os.path.exists(done):
        synth.render_scenario("path", folder, seed=seed, frames=frames,
                              size=(width, height))
    return folder


def learn_chart_palette(folder: str, out: str) -> str:
    """Learns a palette from the clip's colour chart frame, as a user
    learns one from their own camera."""
    from . import palette as pal
    with open(os.path.join(folder, "scene.json")) as f:
        classes = json.load(f)["palette"]["classes"]
    image = cv2.imread(os.path.join(folder, "chart.png"))
    mask = cv2.imread(os.path.join(folder, "chart-mask.png"),
                      cv2.IMREAD_UNCHANGED)
    learned = pal.learn_from_mask(
        image, mask, names=[c["name"] for c in classes],
        markers=[c["name"] for c in classes if c.get("marker", True)])
    pal.save_palette(learned, out, **{"learned-from": "chart.png"})
    return out


def run_demo(out_dir: str, width: int = 640, height: int = 480,
             frames: int = None, palette: str = None,
             clips_dir: str = "out/clips") -> Dict:
    os.makedirs(out_dir, exist_ok=True)
    t0 = time.perf_counter()
    folder = synthetic_clip(
        os.path.join(clips_dir, f"path-{width}x{height}-"
                                f"{frames or 'all'}"), width, height, frames)
    clip = os.path.join(folder, "clip.avi")
    if palette is None:
        palette = learn_chart_palette(folder,
                                      os.path.join(out_dir, "palette.json"))
    with open(os.path.join(folder, "scene.json")) as f:
        n_frames = json.load(f)["frames"]
    labels = os.path.join(out_dir, "labels.avi")
    log = os.path.join(out_dir, "log.jsonl")
    t1 = time.perf_counter()
    result = segment_clip(clip, labels, preview_frame=n_frames // 4,
                          palette=palette, log=log)
    t2 = time.perf_counter()
    stats = result["stats"]
    preview = np.hstack([result["preview"]["input"],
                         result["preview"]["labels"]])
    cv2.imwrite(os.path.join(out_dir, "preview.png"),
                cv2.cvtColor(preview, cv2.COLOR_RGB2BGR))
    total = sum(stats["class_pixels"].values()) or 1
    summary = {
        "input": clip,
        "truth": os.path.join(folder, "truth.jsonl"),
        "palette": palette,
        "labels_video": labels,
        "log": log,
        "frames": stats["frames"],
        "size": [width, height],
        "labsegment_ms_per_frame_median": float(np.median(stats["ms"])),
        "clip_s": round(t1 - t0, 2),
        "segment_s": round(t2 - t1, 2),
        "class_share": {k: round(v / total, 4)
                        for k, v in stats["class_pixels"].items()},
    }
    with open(os.path.join(out_dir, "summary.json"), "w") as f:
        json.dump(summary, f, indent=2)
    return summary


def add_demo_parser(subparsers):
    p = subparsers.add_parser(
        "demo", help="segment a generated floor clip (the main job)",
        description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default="out/demo", help="output folder")
    p.add_argument("--frames", type=int,
                   help="frames of the clip (default: the whole path)")
    p.add_argument("--size", default="640x480", help="WIDTHxHEIGHT")
    p.add_argument("--palette", help="palette JSON (default: built-in)")
    p.set_defaults(handler=_handle, parser=p)


def _handle(args) -> int:
    try:
        width, height = (int(v) for v in args.size.lower().split("x"))
    except ValueError:
        args.parser.error(f"--size must be WIDTHxHEIGHT, got {args.size!r}")
    summary = run_demo(args.out, width, height, args.frames, args.palette)
    print(f"{summary['frames']} frames of {width}x{height}: "
          f"labsegment {summary['labsegment_ms_per_frame_median']:.2f} ms "
          "per frame (median, incl. probe overhead)")
    for name, share in sorted(summary["class_share"].items(),
                              key=lambda kv: -kv[1]):
        print(f"  {name:10s} {100 * share:6.2f} %")
    print(f"wrote {args.out}/: palette.json, labels.avi, log.jsonl, "
          "preview.png, summary.json (clip: "
          f"{os.path.dirname(summary['input'])})")
    return 0
