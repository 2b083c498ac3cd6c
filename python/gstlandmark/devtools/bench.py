"""Benchmark of the labsegment element: ``gst-landmark bench labsegment``.

This prints numbers; it is not a timed test.  For each frame size and
format it

1. draws a few synthetic floor scenes (wood/grey floor seen in perspective,
   coloured discs of the palette's marker colours, mild blur and noise; a
   fixed seed, so every run sees the same pixels),
2. packs them as raw frames with GStreamer's default strides,
3. runs the C program ``tests/bench/labsegment-bench`` from the build tree,
   pinned to one core with ``taskset``: it pushes the frames through a
   GstHarness running ``labsegment`` and times each push + pull, then times
   a plain memcpy of a frame of the same size (the memory-bound floor), and
   dumps the label plane of each distinct frame,
4. times the Python reference (``reference.rgb_to_lab`` + ``classify``,
   starting from the same raw frame, the way a user would write it) on the
   same core,
5. reports the medians, the speed-ups, the targets (at most 0.6 ms per
   640x480 frame; at least 30 times faster than the Python reference) and
   the fraction of pixels where the element's labels equal the reference's.
"""

from dataclasses import asdict, dataclass, field
import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time

import cv2
import numpy as np

from .. import reference
from ..commands.common import (CliError, add_actions, add_json_option,
                               size_type)
from ..palette import default_palette
from .benchkit import (BenchError, OneCore, add_build_dir_option,
                       add_report_options, bench_environment, pin_prefix,
                       write_json)
from .benchkit import find_build_dir as find_program_build_dir

DEFAULT_SIZES = ((640, 480), (1920, 1080))
DEFAULT_FORMATS = ("BGRx", "YUY2")
SUPPORTED_FORMATS = ("BGRx", "YUY2")
DEFAULT_FRAMES = 500
DEFAULT_ITERATIONS = 3
DEFAULT_DISTINCT = 3
DEFAULT_WARMUP = 10

# The targets.
TARGET_MS = 0.6
TARGET_SIZE = (640, 480)
TARGET_SPEEDUP = 30.0

BENCH_EXE = os.path.join("tests", "bench", "labsegment-bench")


# ---------------------------------------------------------------------------
# Raw frame packing (GStreamer's default strides)


def _round_up_4(n):
    return (n + 3) & ~3


def default_stride(fmt, width):
    """Row stride in bytes that gst_video_info_set_format gives."""
    if fmt == "BGRx":
        return width * 4
    if fmt == "YUY2":
        return _round_up_4(((width + 1) // 2) * 4)
    raise BenchError(f"unsupported format {fmt}")


def default_colorimetry(fmt, height):
    """The YCbCr matrix GStreamer assumes for this format and size
    (gst_video_info_set_format: BT.601 up to 576 lines, else BT.709);
    None for RGB formats."""
    if fmt == "BGRx":
        return None
    return "bt601" if height <= 576 else "bt709"


def rgb_to_yuy2(rgb, matrix="bt601"):
    """Pack (H, W, 3) 8-bit R'G'B' as YUY2 bytes (H, stride), limited range.

    Chroma of each horizontal pixel pair is the mean of the two.
    """
    kr, kb = reference.YUV_MATRICES[matrix]
    kg = 1.0 - kr - kb
    height, width = rgb.shape[:2]
    src = rgb.astype(np.float64) / 255.0
    if width % 2:
        src = np.concatenate([src, src[:, -1:]], axis=1)
    r, g, b = src[..., 0], src[..., 1], src[..., 2]
    luma = kr * r + kg * g + kb * b
    cb = (b - luma) / (2.0 * (1.0 - kb))
    cr = (r - luma) / (2.0 * (1.0 - kr))
    cb = 0.5 * (cb[:, 0::2] + cb[:, 1::2])
    cr = 0.5 * (cr[:, 0::2] + cr[:, 1::2])

    def q(x):
        return np.clip(np.rint(x), 0, 255).astype(np.uint8)

    y8 = q(16.0 + 219.0 * luma)
    pairs = y8.shape[1] // 2
    out = np.zeros((height, default_stride("YUY2", width)), np.uint8)
    packed = out[:, :4 * pairs].reshape(height, pairs, 4)
    packed[..., 0] = y8[:, 0::2]
    packed[..., 1] = q(128.0 + 224.0 * cb)
    packed[..., 2] = y8[:, 1::2]
    packed[..., 3] = q(128.0 + 224.0 * cr)
    return out


def pack_frame(rgb, fmt, matrix=None):
    """Raw bytes (H, stride) of an (H, W, 3) RGB frame in format fmt."""
    height, width = rgb.shape[:2]
    if fmt == "BGRx":
        out = np.full((height, width, 4), 255, np.uint8)
        out[..., :3] = rgb[..., ::-1]
        return out.reshape(height, width * 4)
    if fmt == "YUY2":
        return rgb_to_yuy2(rgb, matrix or "bt601")
    raise BenchError(f"unsupported format {fmt}")


def reference_segment(raw, fmt, width, height, palette_lab, matrix=None):
    """The Python reference on one raw frame, the plain user way."""
    if fmt == "BGRx":
        bgrx = raw.reshape(height, -1)[:, :width * 4].reshape(height,
                                                              width, 4)
        lab = reference.rgb_to_lab(bgrx[..., 2::-1])
    elif fmt == "YUY2":
        pairs = (width + 1) // 2
        packed = raw.reshape(height, -1)[:, :4 * pairs]
        rgb = reference.yuy2_to_rgb_float(packed, width,
                                          matrix=matrix or "bt601")
        lab = reference.rgb_to_lab(rgb)
    else:
        raise BenchError(f"unsupported format {fmt}")
    return reference.classify(lab, palette_lab)


# ---------------------------------------------------------------------------
# Generated floor scenes (the frames the labsegment benchmark times)


MARKER_NAMES = ("red", "green", "yellow", "pink", "blue")
SEED = 20240611


def _marker_colours(palette):
    """sRGB (R, G, B) uint8 of the palette's marker discs, by name."""
    srgb = reference.lab_to_srgb8(palette.lab_array())
    return {name: srgb[palette.index(name)]
            for name in MARKER_NAMES if name in palette.names}


def floor_scene(width, height, index=0, seed=SEED, palette=None,
                camera_shift=None):
    """One synthetic camera frame of a floor with coloured discs.

    Returns uint8 (height, width, 3) in R, G, B order.  The camera looks
    down at a floor of planks (a wood tone blended with grey) lit unevenly;
    flat discs in the palette's marker colours lie on it and appear as
    ellipses.  ``index`` moves the camera a little and changes the noise,
    so consecutive indices give distinct but similar frames;
    ``camera_shift`` = (sideways, forwards) in metres sets the camera's
    offset instead.  Geometry is
    relative to the frame size: every size shows the same scene.
    """
    palette = palette or default_palette()
    rng = np.random.default_rng(seed)        # the scene: fixed per seed
    frame_rng = np.random.default_rng((seed, index))   # per-frame noise

    # Pinhole camera 1 m above the floor, horizon above the top edge.
    focal = 0.9 * width
    cx = width / 2.0
    horizon = -0.35 * height
    cam_h = 1.0
    shift_x = 0.03 * index          # metres: the camera drifts sideways
    shift_z = 0.05 * index          # and forwards between frames
    if camera_shift is not None:
        shift_x, shift_z = camera_shift

    ys, xs = np.mgrid[0:height, 0:width].astype(np.float64)
    depth = focal * cam_h / (ys - horizon)           # Z of each floor point
    floor_x = (xs - cx) * depth / focal + shift_x     # X of each floor point
    floor_z = depth + shift_z

    # Planks 15 cm wide along Z, each with its own tone and grain phase.
    n_planks = 64
    plank = np.floor(floor_x / 0.15).astype(np.int64) % n_planks
    tone = rng.uniform(0.85, 1.12, n_planks)[plank]
    phase = rng.uniform(0, 2 * np.pi, n_planks)[plank]
    grain = 1.0 + 0.05 * np.sin(38.0 * floor_z
                                + 2.5 * np.sin(3.0 * floor_x + phase)
                                + phase)
    seams = np.abs(floor_x / 0.15 - np.round(floor_x / 0.15)) * 0.15
    seam = np.where(seams < 0.004, 0.75, 1.0)

    wood = np.array([150.0, 112.0, 78.0])
    grey = np.array([128.0, 126.0, 122.0])
    # More wood to the left, more grey (worn/painted) to the right.
    mix = np.clip(0.75 - 0.5 * xs / width, 0.0, 1.0)[..., None]
    base = mix * wood + (1.0 - mix) * grey

    # Uneven light: brighter near the camera and towards a window on the
    # right, a soft vignette.
    light = (0.78 + 0.22 * np.exp(-(depth - 1.0) / 4.0)
             + 0.10 * (xs / width))
    r2 = ((xs - cx) / width) ** 2 + ((ys - height / 2.0) / height) ** 2
    light = light * (1.0 - 0.35 * r2)

    shade = (tone * grain * seam * light)[..., None]
    image = base * shade

    # Discs of radius 12 cm on the floor.  Draw far ones first.
    colours = _marker_colours(palette)
    discs = []
    for name in MARKER_NAMES:
        if name not in colours:
            continue
        for _ in range(2 if name in ("red", "blue") else 1):
            disc_z = rng.uniform(1.0, 4.0)
            half_width = 0.85 * (width / 2.0) * disc_z / focal
            disc_x = rng.uniform(-half_width, half_width)
            discs.append((disc_z, disc_x, name))
    discs.sort(reverse=True)
    radius = 0.12
    sub = 16                        # cv2 sub-pixel shift 4 bits
    for disc_z, disc_x, name in discs:
        z = disc_z - shift_z
        if z <= 0.3:
            continue
        u = cx + focal * (disc_x - shift_x) / z
        v = horizon + focal * cam_h / z
        a = focal * radius / z
        b = a * cam_h / z
        # The disc is lit like the floor under it.
        vi = int(np.clip(v, 0, height - 1))
        ui = int(np.clip(u, 0, width - 1))
        colour = colours[name].astype(np.float64) * min(light[vi, ui] * 1.05,
                                                        1.0)
        cv2.ellipse(image, (int(round(u * sub)), int(round(v * sub))),
                    (max(int(round(a * sub)), sub),
                     max(int(round(b * sub)), sub)),
                    0, 0, 360, colour.tolist(), -1, cv2.LINE_AA, 4)

    # A little lens blur, then sensor noise.
    sigma = 0.6 * max(width / 640.0, 1.0)
    image = cv2.GaussianBlur(image, (0, 0), sigma)
    image = image + frame_rng.normal(0.0, 2.0, image.shape)
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def write_clip(path: str, width: int, height: int, frames: int,
               fps: int = 30) -> None:
    """Renders the generated floor scene to an MJPEG AVI file."""
    from .. import pipeline
    Gst = pipeline.Gst
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
        pipeline.wait_eos(pipe, 120, path)
    finally:
        pipe.set_state(Gst.State.NULL)


# ---------------------------------------------------------------------------
# Running the C bench


def find_build_dir(build_dir=None):
    """The meson build directory holding the bench program."""
    return find_program_build_dir(BENCH_EXE, build_dir)


def run_c_bench(build_dir, raw_path, fmt, width, height, frames, warmup,
                colorimetry=None, dump_path=None, cpu=0,
                launch="labsegment"):
    """Run labsegment-bench once; returns {name: result dict}."""
    cmd = pin_prefix(cpu) + [
        os.path.join(build_dir, BENCH_EXE), "--input", raw_path,
        "--format", fmt, "--width", str(width), "--height", str(height),
        "--frames", str(frames), "--warmup", str(warmup),
        "--launch", launch]
    if colorimetry:
        cmd += ["--colorimetry", colorimetry]
    if dump_path:
        cmd += ["--dump-labels", dump_path]
    proc = subprocess.run(cmd, env=bench_environment(build_dir),
                          capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise BenchError(f"labsegment-bench failed (status "
                         f"{proc.returncode}): {proc.stderr.strip()}")
    results = {}
    for line in proc.stdout.splitlines():
        line = line.strip()
        if line.startswith("{"):
            item = json.loads(line)
            results[item["name"]] = item
    if "labsegment" not in results or "copy" not in results:
        raise BenchError(f"labsegment-bench printed no timings: "
                         f"{proc.stdout!r} {proc.stderr!r}")
    plugin = results["labsegment"].get("plugin_file", "")
    if not os.path.realpath(plugin).startswith(
            os.path.realpath(build_dir) + os.sep):
        raise BenchError(f"labsegment was loaded from {plugin!r}, not from "
                         f"the build tree {build_dir}")
    return results


# ---------------------------------------------------------------------------
# The benchmark


@dataclass
class BenchRow:
    width: int
    height: int
    format: str
    colorimetry: str
    frames: int
    element_median_ms: float
    element_p10_ms: float
    element_p90_ms: float
    element_mean_ms: float
    copy_median_ms: float
    copy_p90_ms: float
    python_median_ms: float
    python_runs: int
    speedup: float
    copy_ratio: float
    agreement: float
    differing_pixels: int
    meets_time_target: bool = None
    meets_speedup_target: bool = None
    python_all_ms: list = field(default_factory=list)

    @property
    def size(self):
        return f"{self.width}x{self.height}"


def _time_reference(raws, fmt, width, height, palette_lab, matrix,
                    iterations, cpu):
    """Labels of each distinct frame and the per-call times (ms) of the
    Python reference: every distinct frame once, then round again until
    ``iterations`` calls."""
    labels, times = [], []
    calls = max(iterations, len(raws))
    with OneCore(cpu):
        for i in range(calls):
            raw = raws[i % len(raws)]
            t0 = time.perf_counter()
            seg = reference_segment(raw, fmt, width, height, palette_lab,
                                    matrix)
            times.append((time.perf_counter() - t0) * 1e3)
            if i < len(raws):
                labels.append(seg.labels)
    return labels, times


def run_labsegment_bench(build_dir=None, sizes=DEFAULT_SIZES,
                         formats=DEFAULT_FORMATS, frames=DEFAULT_FRAMES,
                         iterations=DEFAULT_ITERATIONS,
                         distinct=DEFAULT_DISTINCT, warmup=DEFAULT_WARMUP,
                         cpu=0, progress=None):
    """Run the benchmark; returns a list of BenchRow.

    sizes       (width, height) pairs.
    formats     GStreamer format names (BGRx, YUY2).
    frames      timed frames per C run (element and copy each).
    iterations  Python reference calls per size and format (at least one
                per distinct frame is made anyway, for the agreement).
    distinct    distinct synthetic frames the C bench cycles through.
    cpu         core to pin to (None: no pinning).
    progress    callable(str) for progress lines, or None.
    """
    build_dir = find_build_dir(build_dir)
    for fmt in formats:
        if fmt not in SUPPORTED_FORMATS:
            raise BenchError(f"format {fmt}: expected one of "
                             f"{', '.join(SUPPORTED_FORMATS)}")
    if frames < 1 or iterations < 1 or distinct < 1:
        raise BenchError("frames, iterations and distinct must be >= 1")
    if cpu is not None and hasattr(os, "sched_getaffinity") \
            and cpu not in os.sched_getaffinity(0):
        raise BenchError(f"cannot run on core {cpu}: allowed cores are "
                         f"{sorted(os.sched_getaffinity(0))}")
    palette_lab = default_palette().lab_array()
    say = progress or (lambda text: None)

    rows = []
    with tempfile.TemporaryDirectory(prefix="labsegment-bench-") as tmp:
        for width, height in sizes:
            say(f"drawing {distinct} frames of {width}x{height}")
            scenes = [floor_scene(width, height, i) for i in range(distinct)]
            for fmt in formats:
                matrix = default_colorimetry(fmt, height)
                raws = [pack_frame(rgb, fmt, matrix) for rgb in scenes]
                raw_path = os.path.join(tmp, f"{width}x{height}.{fmt}.raw")
                dump_path = raw_path + ".labels"
                with open(raw_path, "wb") as out:
                    for raw in raws:
                        out.write(raw.tobytes())
                say(f"{width}x{height} {fmt}: element and copy, "
                    f"{frames} frames")
                res = run_c_bench(build_dir, raw_path, fmt, width, height,
                                  frames, max(warmup, distinct),
                                  colorimetry=matrix, dump_path=dump_path,
                                  cpu=cpu)
                say(f"{width}x{height} {fmt}: Python reference, "
                    f"{max(iterations, distinct)} calls")
                ref_labels, ref_ms = _time_reference(
                    raws, fmt, width, height, palette_lab, matrix,
                    iterations, cpu)

                dumped = np.fromfile(dump_path, np.uint8)
                expected = np.stack(ref_labels)
                if dumped.size != expected.size:
                    raise BenchError(f"label dump holds {dumped.size} "
                                     f"bytes, expected {expected.size}")
                differing = int(np.count_nonzero(
                    dumped != expected.reshape(-1)))

                el, cp = res["labsegment"], res["copy"]
                py_ms = float(np.median(ref_ms))
                row = BenchRow(
                    width=width, height=height, format=fmt,
                    colorimetry=matrix or "",
                    frames=el["frames"],
                    element_median_ms=el["median_ms"],
                    element_p10_ms=el["p10_ms"],
                    element_p90_ms=el["p90_ms"],
                    element_mean_ms=el["mean_ms"],
                    copy_median_ms=cp["median_ms"],
                    copy_p90_ms=cp["p90_ms"],
                    python_median_ms=py_ms,
                    python_runs=len(ref_ms),
                    speedup=py_ms / el["median_ms"],
                    copy_ratio=el["median_ms"] / cp["median_ms"],
                    agreement=1.0 - differing / expected.size,
                    differing_pixels=differing,
                    python_all_ms=[round(t, 3) for t in ref_ms])
                if (width, height) == TARGET_SIZE:
                    row.meets_time_target = el["median_ms"] <= TARGET_MS
                row.meets_speedup_target = row.speedup >= TARGET_SPEEDUP
                rows.append(row)
    return rows


def _verdict(ok):
    return "-" if ok is None else ("yes" if ok else "NO")


def format_table(rows):
    """The results as a text table, one row per size and format."""
    header = ("size", "format", "element ms (p90)", "copy ms", "python ms",
              "speed-up", "elem/copy", "agree %",
              f"<={TARGET_MS}ms", f">={TARGET_SPEEDUP:g}x")
    lines = []
    for r in rows:
        lines.append((
            r.size, r.format,
            f"{r.element_median_ms:.3f} ({r.element_p90_ms:.3f})",
            f"{r.copy_median_ms:.3f}", f"{r.python_median_ms:.1f}",
            f"{r.speedup:.0f}x", f"{r.copy_ratio:.1f}x",
            f"{100.0 * r.agreement:.4f}",
            _verdict(r.meets_time_target),
            _verdict(r.meets_speedup_target)))
    widths = [max(len(str(c)) for c in col)
              for col in zip(header, *lines)]

    def fmt(cells):
        return "  ".join(f"{c:<{w}}" if i < 2 else f"{c:>{w}}"
                         for i, (c, w) in enumerate(zip(cells, widths)))

    out = [fmt(header), fmt(["-" * w for w in widths])]
    out += [fmt(cells) for cells in lines]
    return "\n".join(out)


def _machine():
    model = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return model


# ---------------------------------------------------------------------------
# Command line


def _bench_labsegment(args):
    sizes = args.size or list(DEFAULT_SIZES)
    formats = args.format or list(DEFAULT_FORMATS)
    cpu = None if args.cpu < 0 else args.cpu
    build_dir = find_build_dir(args.build_dir)
    pinned = pin_prefix(cpu)
    if cpu is None:
        pinning = "not pinned"
    elif pinned:
        pinning = f"pinned to core {cpu}"
    else:
        pinning = f"Python on core {cpu}, C bench not pinned (no taskset)"
    print(f"labsegment benchmark on {_machine()}; {pinning}; "
          f"{args.frames} timed frames per run, medians", flush=True)

    def progress(text):
        if not args.quiet:
            print(f"  {text}", file=sys.stderr, flush=True)

    rows = run_labsegment_bench(build_dir, sizes, formats, args.frames,
                                args.iterations, distinct=args.distinct,
                                warmup=args.warmup, cpu=cpu,
                                progress=progress)
    print(format_table(rows))
    print(f"targets: element median <= {TARGET_MS} ms per "
          f"{TARGET_SIZE[0]}x{TARGET_SIZE[1]} frame; >= "
          f"{TARGET_SPEEDUP:g}x the Python reference "
          f"(reference.rgb_to_lab + classify, one core). 'agree' = pixels "
          f"whose element label equals the reference label.")
    if args.json:
        doc = {"machine": _machine(), "cpu": cpu,
               "targets": {"max_ms": TARGET_MS, "size": list(TARGET_SIZE),
                           "min_speedup": TARGET_SPEEDUP},
               "rows": [dict(asdict(r), size=r.size) for r in rows]}
        with open(args.json, "w", encoding="utf-8") as out:
            json.dump(doc, out, indent=2)
            out.write("\n")
        print(f"wrote {args.json}")
    return 0


def _handle(args):
    try:
        return _bench_labsegment(args)
    except BenchError as err:
        raise CliError(str(err)) from None


def quantisation_agreement(bits_list=(4, 5, 6, 7), seed=1):
    """Fraction of pixels whose label is unchanged when components are
    quantised to ``bits`` (bin centres), per frame kind."""
    palette = default_palette()
    rng = np.random.default_rng(seed)
    kinds = {
        "floor scene 640x480": [floor_scene(640, 480, index=i)
                                for i in range(3)],
        "uniform random 320x240": [
            rng.integers(0, 256, (240, 320, 3), dtype=np.uint8)
            for _ in range(3)],
    }
    exact = {k: [reference.segment_rgb(img, palette,
                                       min_class_pixels=0).labels
                 for img in imgs] for k, imgs in kinds.items()}
    rows = []
    for bits in bits_list:
        step = 1 << (8 - bits)
        row = {"bits": bits}
        for kind, imgs in kinds.items():
            equal = total = 0
            for img, want in zip(imgs, exact[kind]):
                q = (img // step) * step + step // 2
                got = reference.segment_rgb(q.astype(np.uint8), palette,
                                            min_class_pixels=0).labels
                equal += int((got == want).sum())
                total += want.size
            row[kind] = equal / total
        rows.append(row)
    return rows


def _handle_quantisation(args):
    rows = quantisation_agreement()
    kinds = [k for k in rows[0] if k != "bits"]
    print("bits/component  " + "  ".join(f"{k:>24s}" for k in kinds))
    for row in rows:
        print(f"{row['bits']:14d}  " + "  ".join(
            f"{100 * row[k]:23.3f}%" for k in kinds))
    print("agreement with the exact 8-bit classification (built-in palette, "
          "dominant-colour rule off)")
    return 0


def segmentation_accuracy(out_dir, scenarios=("backgrounds", "distractors"),
                          seed=0, frames=None, size=(640, 480),
                          settings=None, min_class_pixels=500):
    """Per-class pixel precision and recall of labsegment against the
    renderer's per-pixel truth, for each setting.

    Each scenario is rendered once (clip.avi and a mask per frame); the
    clip, JPEG and all, goes through ``labsegment`` with the scene's own
    palette (the colours the renderer painted) under every setting.
    Returns {setting: {class: {"tp", "fp", "fn", "precision", "recall"}}}
    over marker classes, plus "all".
    """
    import cv2 as _cv2
    from .. import pipeline, synth
    rule = f"min-class-pixels={min_class_pixels}"
    settings = settings or {
        "rule, nearest": f"{rule} rare-classes=nearest",
        "rule, unlabelled": f"{rule} rare-classes=unlabelled",
        "no rule": "min-class-pixels=0",
        "rule, L* off": f"{rule} rare-classes=nearest use-lightness=false",
        "no rule, L* off": "min-class-pixels=0 use-lightness=false",
    }
    totals = {name: {} for name in settings}
    for scenario in scenarios:
        folder = os.path.join(out_dir, scenario)
        synth.render_scenario(scenario, folder, seed=seed, frames=frames,
                              size=size, masks="all", progress=False,
                              robot="comfortable")
        with open(os.path.join(folder, "scene.json")) as f:
            scene = json.load(f)
        classes = scene["palette"]["classes"]
        names = [c["name"] for c in classes]
        markers = [c["name"] for c in classes if c.get("marker", True)]
        palette_file = os.path.join(folder, "palette.json")
        clip = os.path.join(folder, "clip.avi")
        for name, props in settings.items():
            chain = f"labsegment palette={palette_file} {props}"
            for r in pipeline.run_file(clip, chain):
                truth = _cv2.imread(os.path.join(
                    folder, "masks", f"{r.frame:06d}.png"),
                    _cv2.IMREAD_UNCHANGED)
                got = r.labels.plane
                for k, cls in enumerate(names, 1):
                    if cls not in markers:
                        continue
                    t, g = truth == k, got == k
                    c = totals[name].setdefault(cls, [0, 0, 0])
                    c[0] += int((t & g).sum())
                    c[1] += int((~t & g).sum())
                    c[2] += int((t & ~g).sum())
    out = {}
    for name, per_class in totals.items():
        rows = {}
        all_ = [0, 0, 0]
        for cls, (tp, fp, fn) in sorted(per_class.items()):
            rows[cls] = _prf(tp, fp, fn)
            all_ = [all_[0] + tp, all_[1] + fp, all_[2] + fn]
        rows["all"] = _prf(*all_)
        out[name] = rows
    return out


def _prf(tp, fp, fn):
    return {"tp": tp, "fp": fp, "fn": fn,
            "precision": tp / (tp + fp) if tp + fp else None,
            "recall": tp / (tp + fn) if tp + fn else None}


def _handle_segmentation(args):
    args.scenario = args.scenario or ["backgrounds", "distractors"]
    out_dir = args.out or tempfile.mkdtemp(prefix="landmark-seg-")
    result = segmentation_accuracy(out_dir, scenarios=args.scenario,
                                   seed=args.seed, frames=args.frames)
    classes = sorted({c for rows in result.values() for c in rows},
                     key=lambda c: (c == "all", c))
    header = "class     " + "".join(f"  {name:>22s}" for name in result)
    print("pixel precision / recall (%) of marker classes against the "
          f"rendered truth; scenarios: {', '.join(args.scenario)}")
    print(header)
    for cls in classes:
        cells = []
        for rows in result.values():
            r = rows.get(cls)
            if r is None or r["precision"] is None or r["recall"] is None:
                cells.append(f"  {'-':>22s}")
            else:
                cells.append(f"  {100 * r['precision']:10.2f} /"
                             f"{100 * r['recall']:9.2f}")
        print(f"{cls:10s}" + "".join(cells))
    write_json(args.json, result)
    return 0


def add_bench_parser(subparsers):
    """Add ``bench labsegment`` to the gst-landmark command line."""
    parser = subparsers.add_parser(
        "bench", help="benchmarks (print numbers)",
        description="Benchmarks of the elements; they print numbers.")
    actions = add_actions(parser, dest="bench", metavar="BENCH")
    lab = actions.add_parser(
        "labsegment", help="labsegment per-frame time vs frame copy and "
                           "the Python reference",
        description="Time labsegment per frame on one core (median of many "
                    "frames) beside a plain frame copy and the Python "
                    "reference, on synthetic floor scenes; check the "
                    "targets and the agreement of the labels.")
    add_build_dir_option(lab)
    lab.add_argument("--iterations", type=int, default=DEFAULT_ITERATIONS,
                     metavar="N",
                     help=f"Python reference calls per size and format "
                          f"(default {DEFAULT_ITERATIONS}; at least one per "
                          f"distinct frame)")
    lab.add_argument("--frames", type=int, default=DEFAULT_FRAMES,
                     metavar="N",
                     help=f"timed element frames per size and format "
                          f"(default {DEFAULT_FRAMES})")
    lab.add_argument("--distinct", type=int, default=DEFAULT_DISTINCT,
                     metavar="N",
                     help=f"distinct synthetic frames cycled through "
                          f"(default {DEFAULT_DISTINCT})")
    lab.add_argument("--warmup", type=int, default=DEFAULT_WARMUP,
                     metavar="N", help="untimed frames first (default "
                                       f"{DEFAULT_WARMUP})")
    lab.add_argument("--size", type=size_type, action="append",
                     metavar="WxH",
                     help="frame size (repeatable; default 640x480 and "
                          "1920x1080)")
    lab.add_argument("--format", action="append",
                     choices=SUPPORTED_FORMATS,
                     help="video format (repeatable; default BGRx and YUY2)")
    lab.add_argument("--cpu", type=int, default=0, metavar="CORE",
                     help="core to pin to (default 0; -1: no pinning)")
    add_report_options(lab)
    lab.set_defaults(handler=_handle)

    quant = actions.add_parser(
        "quantisation", help="what quantising colours before classifying "
                             "would cost in agreement",
        description="Agreement with the exact classification when each "
                    "8-bit component is first quantised to fewer bits (the "
                    "usual way to shrink a colour lookup table); labsegment "
                    "does not quantise.")
    quant.set_defaults(handler=_handle_quantisation)

    seg = actions.add_parser(
        "segmentation", help="labsegment's per-class pixel precision and "
                             "recall on rendered scenes",
        description="""Render synthetic scenarios with a truth mask per
            frame and measure labsegment's per-class pixel precision and
            recall, with the dominant-colour rule and lightness on and
            off.""")
    seg.add_argument("--scenario", action="append",
                     help="synth scenario (repeatable; default backgrounds "
                          "and distractors)")
    seg.add_argument("--frames", type=int, help="frames per scenario")
    seg.add_argument("--seed", type=int, default=0)
    seg.add_argument("--out", help="keep the renders in this folder")
    add_json_option(seg)
    seg.set_defaults(handler=_handle_segmentation, scenario=None)

    from .ranging_bench import add_ranging_bench_parser
    add_ranging_bench_parser(actions)
    from .chainbench import add_chain_bench_parser
    add_chain_bench_parser(actions)
    from .fleetbench import add_fleet_bench_parser
    add_fleet_bench_parser(actions)
    from .latencybench import add_latency_bench_parsers
    add_latency_bench_parsers(actions)
    from .realbench import add_real_bench_parser
    add_real_bench_parser(actions)
    return parser


def main_cli(argv=None):
    """``python -m gstlandmark.devtools.bench labsegment ...``: the same as
    ``gst-landmark bench labsegment ...``."""
    parser = argparse.ArgumentParser(prog="gst-landmark")
    subparsers = parser.add_subparsers(dest="command", required=True)
    add_bench_parser(subparsers)
    args = parser.parse_args(["bench"] + list(
        sys.argv[1:] if argv is None else argv))
    try:
        return _bench_labsegment(args)
    except BenchError as err:
        print(f"gst-landmark: error: {err}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main_cli())
