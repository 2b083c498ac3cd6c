"""The main job's demo: the synthetic robot's camera clip through the
whole chain, with a palette learned from the clip's colour chart.

The clip (``gst-landmark synth path``) is rendered on first run and kept
under ``out/clips``. Writes, in the output folder:

- ``palette.json``: the palette learned from the clip's chart frame;
- ``overlay.avi``: the clip with detections, ranges, pose, histogram and
  mini-map drawn by ``landmarkoverlay``;
- ``log.jsonl``: ``landmarklog``'s line per frame;
- ``trajectory.png``: estimated poses against the true path;
- ``accuracy.json``: ``gst-landmark evaluate`` against the clip's truth;
- ``preview.png``: one overlay frame;
- ``summary.json``: frames, time per frame, pose and accuracy figures.
"""

from __future__ import annotations

import json
import os
import time
from typing import Dict

import cv2
import numpy as np

from .. import pipeline
from ..landmarklog import read_jsonl
from ..gicompat import caps_structure
from ..landmarkmap import read_map
from ..synth.writer import clip_files

Gst = pipeline.Gst


def _buffer_rgb(buf, caps):
    s = caps_structure(caps)
    w, h = s.get_value("width"), s.get_value("height")
    with buf.map(Gst.MapFlags.READ) as m:
        stride = len(m.data) // h
        arr = np.frombuffer(m.data, np.uint8).reshape(h, stride)
        return arr[:, :w * 3].reshape(h, w, 3).copy()


def renderer_version() -> str:
    """A digest of the renderer's source: a cached clip is reused only if
    the renderer that made it is the one installed."""
    import hashlib
    from .. import synth
    digest = hashlib.sha1()
    folder = os.path.dirname(synth.__file__)
    for name in sorted(os.listdir(folder)):
        if name.endswith(".py"):
            with open(os.path.join(folder, name), "rb") as f:
                digest.update(f.read())
    return digest.hexdigest()[:10]


def synthetic_clip(folder: str, width: int, height: int,
                   frames: int = None, seed: int = 0,
                   robot: str = "seed") -> str:
    """The ``path`` scenario rendered into ``folder`` once, reused after."""
    from .. import synth
    if not os.path.exists(clip_files(folder)["scene"]):
        synth.render_scenario("path", folder, seed=seed, frames=frames,
                              size=(width, height), robot=robot)
    return folder


def learn_chart_palette(folder: str, out: str) -> str:
    """Learns a palette from the clip's colour chart frame, as a user
    learns one from their own camera."""
    from .. import palette as pal
    files = clip_files(folder)
    with open(files["scene"]) as f:
        classes = json.load(f)["palette"]["classes"]
    image = cv2.imread(files["chart"])
    mask = cv2.imread(files["chart_mask"], cv2.IMREAD_UNCHANGED)
    learned = pal.learn_from_mask(
        image, mask, names=[c["name"] for c in classes],
        markers=[c["name"] for c in classes if c.get("marker", True)])
    pal.save_palette(learned, out, **{"learned-from": "chart.png"})
    return out


def chain_description(folder: str, palette: str, log: str,
                      video: str) -> str:
    """The whole chain on the clip in ``folder``, with the scene's camera
    file and map (as a user would with their calibrated camera) and every
    other property at its default but trilaterate's EKF."""
    files = clip_files(folder)
    map_file = files["map"]
    return (
        f"filesrc location={files['clip']} ! decodebin ! videoconvert ! "
        "video/x-raw,format=RGB ! "
        f"labsegment palette={palette} ! blobroundness ! "
        f"ipmrange calibration={files['camera']} map={map_file} ! "
        f"trilaterate map={map_file} filter=ekf ! "
        f"landmarklog location={log} ! "
        f"landmarkoverlay name=overlay map={map_file} ! videoconvert ! "
        f"jpegenc quality=90 ! avimux ! filesink location={video}")


def run_chain(description: str, preview_frame: int) -> Dict:
    """Runs the chain to EOS; returns the frame count, the wall time and
    the overlay's output at ``preview_frame``."""
    pipeline.init()
    pipe = Gst.parse_launch(description)
    stats: Dict = {"frames": 0}

    def on_frame(pad, info):
        if stats["frames"] == preview_frame:
            stats["preview"] = _buffer_rgb(info.get_buffer(),
                                           pad.get_current_caps())
        stats["frames"] += 1
        return Gst.PadProbeReturn.OK

    pipe.get_by_name("overlay").get_static_pad("src").add_probe(
        Gst.PadProbeType.BUFFER, on_frame)
    t0 = time.perf_counter()
    pipe.set_state(Gst.State.PLAYING)
    try:
        pipeline.wait_eos(pipe, 120, "the demo's chain")
    finally:
        pipe.set_state(Gst.State.NULL)
    stats["seconds"] = time.perf_counter() - t0
    return stats


def run_demo(out_dir: str, width: int = 640, height: int = 480,
             frames: int = None, palette: str = None,
             clips_dir: str = "out/clips", robot: str = "seed") -> Dict:
    from . import evaluate
    os.makedirs(out_dir, exist_ok=True)
    t0 = time.perf_counter()
    folder = synthetic_clip(
        os.path.join(clips_dir, f"path-{robot}-{width}x{height}-"
                                f"{frames or 'all'}-{renderer_version()}"),
        width, height, frames, robot=robot)
    if palette is None:
        palette = learn_chart_palette(folder,
                                      os.path.join(out_dir, "palette.json"))
    files = clip_files(folder)
    with open(files["scene"]) as f:
        n_frames = json.load(f)["frames"]
    video = os.path.join(out_dir, "overlay.avi")
    log = os.path.join(out_dir, "log.jsonl")
    t1 = time.perf_counter()
    stats = run_chain(chain_description(folder, palette, log, video),
                      preview_frame=n_frames // 4)
    cv2.imwrite(os.path.join(out_dir, "preview.png"),
                cv2.cvtColor(stats["preview"], cv2.COLOR_RGB2BGR))

    truth = files["truth"]
    results = read_jsonl(log)
    ev = evaluate.evaluate(results, read_jsonl(truth), min_pixels=113)
    accuracy = evaluate.summary(ev)
    with open(os.path.join(out_dir, "accuracy.json"), "w") as f:
        json.dump(accuracy, f, indent=2)
    landmarks = read_map(files["map"])
    evaluate.plot_trajectory(ev, os.path.join(out_dir, "trajectory.png"),
                             landmarks)
    pose = accuracy["pose"].get("all", {}).get("position_m", {})
    heading = accuracy["pose"].get("all", {}).get("heading_deg", {})
    summary = {
        "clip": files["clip"],
        "truth": truth,
        "palette": palette,
        "overlay_video": video,
        "log": log,
        "frames": stats["frames"],
        "size": [width, height],
        "ms_per_frame": round(1000 * stats["seconds"] /
                              max(stats["frames"], 1), 2),
        "clip_s": round(t1 - t0, 2),
        "chain_s": round(stats["seconds"], 2),
        "frames_with_pose": accuracy["pose"]["frames_with_pose"],
        "position_error_m": pose,
        "heading_error_deg": heading,
        "detection": accuracy["detection"]["all"],
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
    p.add_argument("--palette", help="palette JSON (default: learned from "
                   "the clip's colour chart)")
    p.add_argument("--robot", choices=("seed", "comfortable"), default="seed",
                   help="the synthetic robot (gst-landmark synth --robot; "
                        "default: the seed's small robot)")
    p.set_defaults(handler=_handle, parser=p)


def _handle(args) -> int:
    try:
        width, height = (int(v) for v in args.size.lower().split("x"))
    except ValueError:
        args.parser.error(f"--size must be WIDTHxHEIGHT, got {args.size!r}")
    s = run_demo(args.out, width, height, args.frames, args.palette,
                 robot=args.robot)
    pos, head, det = (s["position_error_m"], s["heading_error_deg"],
                      s["detection"])
    print(f"{s['frames']} frames of {width}x{height} through labsegment ! "
          "blobroundness ! ipmrange ! trilaterate ! landmarklog ! "
          f"landmarkoverlay: {s['ms_per_frame']} ms per frame with decoding "
          "and encoding")
    print(f"detections: precision {100 * (det['precision'] or 0):.1f} %, "
          f"recall {100 * (det['recall'] or 0):.1f} %")
    if pos.get("n"):
        print(f"pose on {s['frames_with_pose']} frames: position error "
              f"median {100 * pos['median']:.1f} cm, p95 "
              f"{100 * pos['p95']:.1f} cm; heading error median "
              f"{head['median']:.2f} deg")
    print(f"wrote {args.out}/: overlay.avi, log.jsonl, trajectory.png, "
          "accuracy.json, preview.png, palette.json, summary.json")
    return 0
