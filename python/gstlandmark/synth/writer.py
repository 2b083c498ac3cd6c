"""Write a rendered scenario: the MJPEG clip (through GStreamer), the
ground truth, the scene description, the map and the class masks."""

import json
import os
import sys
import time

import cv2
import numpy as np

from ..palette import save_palette

from .chart import render_chart
from .odometry import OdometryErrors, scene_odometry, write_odometry
from .render import render_frame
from .scenarios import Static, build_scenario
from .world import palette_json


def _stride(width):
    # GStreamer's default row stride for packed RGB: a multiple of 4.
    return (width * 3 + 3) // 4 * 4


def _packed(rgb):
    """Frame bytes in GStreamer's default RGB layout."""
    h, w, _ = rgb.shape
    stride = _stride(w)
    if stride == w * 3:
        return rgb.tobytes()
    out = np.zeros((h, stride), np.uint8)
    out[:, :w * 3] = rgb.reshape(h, w * 3)
    return out.tobytes()


def raw_caps(width, height, fps):
    return (f"video/x-raw,format=RGB,width={width},height={height},"
            f"framerate={fps}/1")


class ClipWriter:
    """appsrc ! videoconvert ! jpegenc quality=Q ! avimux ! filesink.
    Encoding runs in GStreamer's threads while the next frame renders."""

    def __init__(self, path, width, height, fps, quality):
        from .. import pipeline
        pipeline.init()
        self.Gst = Gst = pipeline.Gst
        self.error_type = pipeline.PipelineError
        self.fps = fps
        frame_bytes = _stride(width) * height
        self.pipe = Gst.parse_launch(
            f"appsrc name=src format=time block=true "
            f"max-bytes={4 * frame_bytes} "
            f"caps={raw_caps(width, height, fps)} ! videoconvert ! "
            f"jpegenc quality={int(quality)} ! avimux ! filesink name=sink")
        self.pipe.get_by_name("sink").set_property("location", str(path))
        self.src = self.pipe.get_by_name("src")
        self.bus = self.pipe.get_bus()
        self.pipe.set_state(Gst.State.PLAYING)

    def _check(self, timeout_ns=0):
        Gst = self.Gst
        msg = self.bus.timed_pop_filtered(
            timeout_ns, Gst.MessageType.EOS | Gst.MessageType.ERROR)
        if msg is not None and msg.type == Gst.MessageType.ERROR:
            err, dbg = msg.parse_error()
            self.pipe.set_state(Gst.State.NULL)
            raise self.error_type(f"clip encoding failed: {err.message} "
                                  f"({dbg})")
        return msg

    def push(self, rgb, index):
        Gst = self.Gst
        buf = Gst.Buffer.new_wrapped(_packed(rgb))
        buf.pts = index * Gst.SECOND // self.fps
        buf.duration = (index + 1) * Gst.SECOND // self.fps - buf.pts
        ret = self.src.emit("push-buffer", buf)
        if ret != Gst.FlowReturn.OK:
            self._check()
            raise self.error_type(f"clip encoding stopped: {ret}")
        self._check()

    def close(self):
        Gst = self.Gst
        self.src.emit("end-of-stream")
        try:
            if self._check(120 * Gst.SECOND) is None:
                raise self.error_type("clip encoding did not finish")
        finally:
            self.pipe.set_state(Gst.State.NULL)

    def abort(self):
        self.pipe.set_state(self.Gst.State.NULL)


class Progress:
    """A one-line text progress bar on stderr with frames/s and ETA."""

    def __init__(self, total, enabled, label="", stream=None):
        self.total, self.enabled, self.label = total, enabled, label
        self.stream = stream or sys.stderr
        self.start = time.perf_counter()
        self.last = 0.0

    def update(self, done):
        if not self.enabled:
            return
        now = time.perf_counter()
        if done < self.total and now - self.last < 0.25:
            return
        self.last = now
        elapsed = now - self.start
        rate = done / elapsed if elapsed > 0 else 0.0
        eta = (self.total - done) / rate if rate > 0 else 0.0
        width = 30
        filled = int(width * done / max(self.total, 1))
        self.stream.write(
            f"\r{self.label} [{'#' * filled}{'.' * (width - filled)}] "
            f"{done}/{self.total} {rate:5.1f} frames/s "
            f"ETA {int(eta) // 60}:{int(eta) % 60:02d} ")
        self.stream.flush()

    def close(self):
        if self.enabled:
            self.stream.write("\n")
            self.stream.flush()


def _write_png(path, rgb):
    if not cv2.imwrite(str(path), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)):
        raise OSError(f"{path}: cannot write")


def _write_mask(path, mask):
    if not cv2.imwrite(str(path), mask):
        raise OSError(f"{path}: cannot write")


# A landmark counts as visible in the visibility histogram with at least
# this many visible pixels.
VISIBLE_MIN_PIXELS = 150


def visibility(counts, min_pixels=VISIBLE_MIN_PIXELS):
    """The histogram of frames by the number of landmarks visible with at
    least ``min_pixels`` pixels, from per-frame counts."""
    counts = np.asarray(counts, dtype=np.int64)
    hist = np.bincount(counts, minlength=1) if counts.size else \
        np.zeros(1, np.int64)
    frames = int(counts.size)
    three = int((counts >= 3).sum())
    return {"min_pixels": min_pixels,
            "frames_by_landmarks": {str(k): int(n)
                                    for k, n in enumerate(hist)},
            "three_or_more": three,
            "fraction_three_or_more": round(three / frames, 4)
            if frames else 0.0}


def format_visibility(vis):
    """One line: frames by landmarks visible."""
    parts = ", ".join(f"{k}: {n}"
                      for k, n in vis["frames_by_landmarks"].items())
    return (f"frames by landmarks visible with >= {vis['min_pixels']} px: "
            f"{parts} (3 or more: {vis['three_or_more']}, "
            f"{100 * vis['fraction_three_or_more']:.0f} %)")


def scene_json(scene, frames):
    """The scene description written to scene.json."""
    out = {
        "scenario": scene.scenario,
        "seed": scene.seed,
        "fps": scene.fps,
        "frames": frames,
        "camera": scene.camera.to_json(),
        "floor": (scene.floor if not scene.segments
                  else [s.to_json() for s in scene.segments]),
        "walls": scene.walls.to_json() if scene.walls else None,
        "effects": scene.effects.to_json(),
        "supersample": scene.supersample,
        "sky_colour_srgb": list(scene.sky_colour),
        **({"light": [round(float(v), 6) for v in scene.light]}
           if scene.light is not None else {}),
        "palette": palette_json(scene.scene_palette()),
        "map": scene.map_json(),
        "distractors": [d.to_json() for d in scene.distractors],
        "obstacles": [o.to_json() for o in scene.obstacles],
        "trajectory": (scene.trajectory.to_json()
                       if scene.trajectory is not None else None),
    }
    if scene.notes:
        out["notes"] = scene.notes
    presence = {lm.id: [list(f) for f in lm.frames]
                for lm in scene.landmarks if lm.frames is not None}
    if presence:
        # landmarks that exist only in some frames (range-sweep)
        out["landmark_frames"] = presence
    return out


# The files write_outputs writes in a clip folder, by what they hold (the
# clip and odometry.jsonl unless left out); scene.json names them so too.
CLIP_FILES = {"truth": "truth.jsonl", "scene": "scene.json",
              "map": "map.json", "palette": "palette.json",
              "camera": "camera.yml", "mask0": "mask0.png",
              "frame0": "frame0.png", "chart": "chart.png",
              "chart_mask": "chart-mask.png", "clip": "clip.avi",
              "odometry": "odometry.jsonl"}


def clip_files(folder):
    """{what: path} of the files of a clip rendered into ``folder``
    (``CLIP_FILES``): what a chain run on the clip reads."""
    return {what: os.path.join(folder, name)
            for what, name in CLIP_FILES.items()}


def write_outputs(scene, frames, out_dir, progress=None, frames_png=None,
                  raw=None, masks="first", clip=True, odometry=True):
    """Render ``frames`` frames of ``scene`` into ``out_dir``; return a
    summary dict.  ``frames_png``: folder for lossless PNG frames;
    ``raw``: file for raw RGB frames; ``masks``: "first" or "all";
    ``progress``: None = only when stderr is a terminal; ``odometry``:
    the ``odometry.OdometryErrors`` of the odometry log, True for the
    defaults, False for no log."""
    if odometry is True:
        odometry = OdometryErrors()
    if odometry:
        odometry.check()
    if masks not in ("first", "all"):
        raise ValueError(f"masks must be 'first' or 'all', got {masks!r}")
    os.makedirs(out_dir, exist_ok=True)
    cam = scene.camera
    width, height = cam.width, cam.height
    if progress is None:
        progress = sys.stderr.isatty()
    bar = Progress(frames, progress, f"synth {scene.scenario}")
    files = clip_files(out_dir)
    if not clip:
        del files["clip"]
    if not odometry:
        del files["odometry"]
    if frames_png:
        os.makedirs(frames_png, exist_ok=True)
        files["frames_png"] = frames_png
    if masks == "all":
        os.makedirs(os.path.join(out_dir, "masks"), exist_ok=True)
        files["masks"] = os.path.join(out_dir, "masks")
    if raw:
        files["raw"] = raw

    trajectory = scene.trajectory or Static()
    start = time.perf_counter()
    writer = (ClipWriter(files["clip"], width, height, scene.fps,
                         scene.effects.jpeg_quality) if clip else None)
    raw_file = open(raw, "wb") if raw else None
    visible = 0
    per_frame = []
    try:
        with open(files["truth"], "w", encoding="utf-8") as truth_file:
            for i in range(frames):
                t = i / scene.fps
                pose = trajectory.pose(t)
                rgb, truth, mask = render_frame(scene, pose, t=t, frame=i,
                                                frames_total=frames)
                if writer is not None:
                    writer.push(rgb, i)
                truth_file.write(json.dumps(truth) + "\n")
                visible += len(truth["landmarks"])
                per_frame.append(sum(
                    1 for e in truth["landmarks"]
                    if e["pixels"] >= VISIBLE_MIN_PIXELS))
                if i == 0:
                    _write_png(files["frame0"], rgb)
                    _write_mask(files["mask0"], mask)
                if masks == "all":
                    _write_mask(os.path.join(files["masks"],
                                             f"{i:06d}.png"), mask)
                if frames_png:
                    _write_png(os.path.join(frames_png, f"{i:06d}.png"),
                               rgb)
                if raw_file is not None:
                    raw_file.write(_packed(rgb))
                bar.update(i + 1)
        if writer is not None:
            writer.close()
            writer = None
    finally:
        if writer is not None:
            writer.abort()
        if raw_file is not None:
            raw_file.close()
        bar.close()
    seconds = time.perf_counter() - start

    # every palette class in one picture, for palette learn
    try:
        chart_rgb, chart_mask, chart_info = render_chart(scene, frames)
    except ValueError as err:
        # a camera that sees (almost) no floor: the clip is still good
        print(f"warning: no colour chart: {err}", file=sys.stderr)
        chart_info = None
        del files["chart"], files["chart_mask"]
    else:
        _write_png(files["chart"], chart_rgb)
        _write_mask(files["chart_mask"], chart_mask)

    description = scene_json(scene, frames)
    vis = visibility(per_frame)
    description["visibility"] = vis
    description["chart"] = (
        {"file": CLIP_FILES["chart"], "mask": CLIP_FILES["chart_mask"],
         **chart_info}
        if chart_info is not None else None)
    description["clip"] = ({"file": CLIP_FILES["clip"],
                            "format": "MJPEG in AVI",
                            "jpeg_quality": scene.effects.jpeg_quality}
                           if clip else None)
    if raw:
        description["raw"] = {"file": raw,
                              "caps": raw_caps(width, height, scene.fps),
                              "stride": _stride(width)}
    if frames_png:
        description["frames_png"] = frames_png
    description["masks"] = "masks/%06d.png" if masks == "all" else None
    description["render_seconds"] = round(seconds, 3)
    description["odometry"] = (
        {"file": CLIP_FILES["odometry"], **odometry.to_json()} if odometry
        else None)
    with open(files["scene"], "w", encoding="utf-8") as f:
        json.dump(description, f, indent=2)
        f.write("\n")
    with open(files["map"], "w", encoding="utf-8") as f:
        json.dump(scene.map_json(), f, indent=2)
        f.write("\n")
    if odometry:
        write_odometry(files["odometry"],
                       scene_odometry(scene, frames, odometry))
    # the true camera as a camera file (docs/calibration.md), for
    # ipmrange calibration=...
    write_camera_yaml(scene.camera, files["camera"])
    # the scene palette as a palette file, for labsegment palette=...
    save_palette(scene.scene_palette(), files["palette"],
                 description=f"Scene palette of gst-landmark synth "
                             f"{scene.scenario} (seed {scene.seed}): "
                             f"marker colours, then floor and wall "
                             f"classes; mask value k is class k.")
    return {"scenario": scene.scenario, "out_dir": out_dir,
            "frames": frames, "size": [width, height],
            "seconds": round(seconds, 3),
            "frames_per_second": round(frames / seconds, 3)
            if seconds > 0 else None,
            "landmark_sightings": visible, "visibility": vis,
            "files": files}


def write_camera_yaml(camera, path):
    """The camera as an OpenCV FileStorage camera file: intrinsics, no
    distortion, and the mounting (height, tilt, roll)."""
    from ..camerafile import write_camera_file
    write_camera_file(path, {
        "image_width": camera.width, "image_height": camera.height,
        "camera_matrix": camera.matrix,
        "distortion_coefficients": np.zeros((1, 5)),
        "camera_height": float(camera.height_m),
        "tilt_deg": float(camera.tilt_deg),
        "roll_deg": float(camera.roll_deg)})


def render_scenario(name, out_dir, seed=0, frames=None, size=(640, 480),
                    progress=None, frames_png=None, raw=None,
                    masks="first", clip=True, robot=None, variant=None,
                    odometry=True, **overrides):
    """Build the named scenario and write it to ``out_dir``; return the
    summary (see ``write_outputs``).  ``robot``: "seed" (default) or
    "comfortable"; ``variant``: a variant number (``variants``) or a
    drawn variant dict; ``odometry``: see ``write_outputs``;
    ``overrides``: see ``scenarios.OVERRIDES``."""
    from .scenarios import DEFAULT_ROBOT
    from .variants import draw_variant
    if variant is not None and not isinstance(variant, dict):
        variant = draw_variant(name, int(variant))
    scene, n = build_scenario(name, seed=seed, frames=frames, size=size,
                              robot=robot or DEFAULT_ROBOT, variant=variant,
                              **overrides)
    return write_outputs(scene, n, out_dir, progress=progress,
                         frames_png=frames_png, raw=raw, masks=masks,
                         clip=clip, odometry=odometry)
