"""``gst-landmark bench ranging``: the numbers of docs/ranging.md.

- The seed's angle-linear model against the exact pinhole model across the
  image: the seed's b, d and w are what a tape on the floor measures for
  the same camera (the floor points of the bottom row's centre, of the
  optical axis and of the centre row's last column), and both models run
  in ``ipmrange`` on detections placed at a grid of pixels.
- Range error by distance for the ground, size and fused methods, discs
  and balls, on the synthetic range sweep (``gst-landmark synth
  range-sweep``, its own camera), and a plot of it drawn with OpenCV.
"""

import json
import math
import os
import tempfile

import cv2
import numpy as np

BANDS = ((0.3, 0.5), (0.5, 1.0), (1.0, 2.0), (2.0, 3.0), (3.0, 4.0))
MAX_RANGE = 4.0
ROWS = (479, 420, 360, 300, 239.5, 160, 80, 20)
COLUMNS = (319.5, 400, 480, 560, 639)
METHODS = ("ground", "size", "fused")


def _gst():
    import gi
    gi.require_version("Gst", "1.0")
    gi.require_version("GstVideo", "1.0")
    from gi.repository import Gst, GstVideo
    from .. import pipeline
    pipeline.init()
    return Gst, GstVideo


def element_ranges(props, uv, size=(640, 480), at_ready=None):
    """landmark-range dicts of detections at pixel centroids ``uv``
    (no ellipse), through ``appsrc ! ipmrange props ! appsink``;
    ``at_ready()`` runs once the pipeline is READY."""
    Gst, GstVideo = _gst()
    from .. import meta
    w, h = size
    caps = f"video/x-raw,format=GRAY8,width={w},height={h},framerate=30/1"
    pipe = Gst.parse_launch(f"appsrc name=src format=time caps={caps} ! "
                            f"ipmrange {props} ! appsink name=sink "
                            f"sync=false")
    src, sink = pipe.get_by_name("src"), pipe.get_by_name("sink")
    buf = Gst.Buffer.new_wrapped(bytes(((w + 3) // 4 * 4) * h))
    buf.pts = 0
    for i, (u, v) in enumerate(uv):
        u, v = float(u), float(v)
        roi = GstVideo.buffer_add_video_region_of_interest_meta(
            buf, "red", max(0, int(u) - 2), max(0, int(v) - 2), 5, 5)
        roi.id = i
        roi.add_param(Gst.Structure.new_from_string(
            f"landmark-blob, class=(string)red, centroid-x=(double){u!r}, "
            f"centroid-y=(double){v!r}, frame-width=(uint){w}, "
            f"frame-height=(uint){h}"))
    if at_ready:
        if pipe.set_state(Gst.State.READY) != Gst.StateChangeReturn.SUCCESS:
            raise RuntimeError(f"ipmrange {props}: did not reach READY")
        at_ready()
    pipe.set_state(Gst.State.PLAYING)
    try:
        src.emit("push-buffer", buf)
        src.emit("end-of-stream")
        sample = sink.emit("try-pull-sample", 10 * Gst.SECOND)
        if sample is None:
            msg = pipe.get_bus().pop_filtered(Gst.MessageType.ERROR)
            detail = msg.parse_error()[0].message if msg else "no output"
            raise RuntimeError(f"ipmrange {props}: {detail}")
        return [d.range for d in meta.detections(sample.get_buffer())]
    finally:
        pipe.set_state(Gst.State.NULL)


def seed_vs_exact(height=0.5, tilt_deg=34.0, hfov_deg=80.0, size=(640, 480),
                  rows=ROWS, columns=COLUMNS):
    """(seed parameters, table rows): for each pixel of the grid the exact
    floor range and the seed model's error, metres and percent."""
    w, h = size
    exact = (f"camera-height={height} tilt={tilt_deg} hfov={hfov_deg}")
    tape = element_ranges(exact, [((w - 1) / 2, h - 1),
                                  ((w - 1) / 2, (h - 1) / 2),
                                  (w - 1, (h - 1) / 2)], size)
    b = tape[0]["ground-x"]
    d = tape[1]["ground-x"] - b
    half = abs(tape[2]["ground-y"])
    seed = (f"model=seed camera-height={height} blind-distance={b!r} "
            f"view-depth={d!r} half-width={half!r}")
    grid = [(u, v) for v in rows for u in columns]
    ex = element_ranges(exact, grid, size)
    sd = element_ranges(seed, grid, size)
    table = []
    for (u, v), e, s in zip(grid, ex, sd):
        if e.get("no-floor") or s.get("no-floor"):
            table.append((u, v, None, None, None, None))
            continue
        err = math.hypot(s["ground-x"] - e["ground-x"],
                         s["ground-y"] - e["ground-y"])
        table.append((u, v, e["range"], s["range"] - e["range"], err,
                      100.0 * err / e["range"]))
    return {"b": b, "d": d, "w": half}, table


def run_sweep(out_dir):
    """Renders the range sweep into out_dir and runs ipmrange with each
    method on discs and balls; returns {(kind, method): (dist, rel)}."""
    Gst, _ = _gst()
    from ..commands import evaluate as E
    from ..landmarklog import read_jsonl
    from .benchkit import run_command
    if not os.path.exists(os.path.join(out_dir, "clip.avi")):
        done = run_command(["synth", "range-sweep", "--out", out_dir,
                            "--robot", "comfortable", "--no-progress"])
        if done.returncode != 0:
            raise RuntimeError(
                f"synth range-sweep failed: {done.stderr.strip()}")
    scene = json.load(open(os.path.join(out_dir, "scene.json")))
    cam = scene["camera"]
    camera = (f"camera-height={cam['height_m']} tilt={cam['tilt_deg']} "
              f"roll={cam['roll_deg']} fx={cam['fx']} fy={cam['fy']} "
              f"cx={cam['cx']} cy={cam['cy']}")
    truth = read_jsonl(os.path.join(out_dir, "truth.jsonl"))
    out = {}
    for kind in ("disc", "ball"):
        dia = scene["notes"][f"{kind}_diameter_m"]
        z = 0.0 if kind == "disc" else dia / 2
        only = [dict(t, landmarks=[m for m in t["landmarks"]
                                   if m["kind"] == kind
                                   and m["range"] <= MAX_RANGE + 1e-9])
                for t in truth]
        for method in METHODS:
            log = os.path.join(out_dir, f"{kind}-{method}.jsonl")
            desc = (f"filesrc location={out_dir}/clip.avi ! avidemux ! "
                    f"jpegdec ! videoconvert ! labsegment "
                    f"palette={out_dir}/palette.json min-class-pixels=0 ! "
                    f"blobroundness ! ipmrange {camera} marker-kind={kind} "
                    f"marker-height={z} marker-diameter={dia} "
                    f"range-method={method} ! landmarklog location={log} ! "
                    f"fakesink")
            pipe = Gst.parse_launch(desc)
            pipe.set_state(Gst.State.PLAYING)
            msg = pipe.get_bus().timed_pop_filtered(
                120 * Gst.SECOND, Gst.MessageType.ERROR | Gst.MessageType.EOS)
            pipe.set_state(Gst.State.NULL)
            if msg is None or msg.type == Gst.MessageType.ERROR:
                raise RuntimeError(f"pipeline failed: {desc}")
            ev = E.evaluate(read_jsonl(log), only)
            dist = np.array([r for r, _, _ in ev.range_errors])
            rel = np.array([e / r for r, e, _ in ev.range_errors])
            bearing = np.array([b for _, _, b in ev.range_errors])
            out[(kind, method)] = (dist, rel, bearing)
    return out, scene


def band_stats(dist, rel, bearing, lo, hi):
    sel = (dist >= lo - 1e-9) & ((dist < hi - 1e-9) if hi < MAX_RANGE
                                 else (dist <= hi + 1e-9))
    if not sel.any():
        return 0, None, None, None
    a = np.abs(rel[sel]) * 100
    return (int(sel.sum()), float(np.median(a)), float(np.percentile(a, 95)),
            float(np.median(np.degrees(np.abs(bearing[sel])))))


def draw_plot(results, path, width=900, height=560):
    """Median |range error| (%) against distance, one line per method and
    marker kind (discs: circles, balls: squares)."""
    img = np.full((height, width, 3), 255, np.uint8)
    left, right, top, bottom = 80, 170, 40, 60
    x0, x1, y_max = 0.0, MAX_RANGE + 0.2, 3.0

    def px(d, e):
        x = left + (d - x0) / (x1 - x0) * (width - left - right)
        y = height - bottom - min(e, y_max) / y_max * (height - top - bottom)
        return int(round(x)), int(round(y))

    font = cv2.FONT_HERSHEY_SIMPLEX
    for e in np.arange(0.0, y_max + 1e-9, 0.5):
        cv2.line(img, px(x0, e), px(x1, e), (225, 225, 225), 1)
        cv2.putText(img, f"{e:.1f}%", (px(x0, e)[0] - 62, px(x0, e)[1] + 5),
                    font, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
    for d in np.arange(0.0, MAX_RANGE + 1e-9, 0.5):
        cv2.line(img, px(d, 0), px(d, y_max), (225, 225, 225), 1)
        cv2.putText(img, f"{d:.1f}", (px(d, 0)[0] - 12, px(d, 0)[1] + 20),
                    font, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
    cv2.rectangle(img, px(x0, y_max), px(x1, 0), (0, 0, 0), 1)
    cv2.putText(img, "distance (m)", (width // 2 - 80, height - 15), font,
                0.55, (0, 0, 0), 1, cv2.LINE_AA)
    cv2.putText(img, "ipmrange: median |range error| on the range sweep "
                "(clipped at 3%)", (left, 25), font, 0.55, (0, 0, 0), 1,
                cv2.LINE_AA)
    colours = {"ground": (200, 90, 20), "size": (30, 30, 210),
               "fused": (40, 160, 40)}
    legend_y = top + 10
    for kind in ("disc", "ball"):
        for method in METHODS:
            dist, rel, _ = results[(kind, method)]
            ranges = sorted(set(np.round(dist, 3)))
            pts = [px(r, 100 * float(np.median(np.abs(
                rel[np.isclose(dist, r)])))) for r in ranges]
            col = colours[method]
            thick = 2 if kind == "disc" else 1
            for a, b in zip(pts, pts[1:]):
                cv2.line(img, a, b, col, thick, cv2.LINE_AA)
            for p in pts:
                if kind == "disc":
                    cv2.circle(img, p, 4, col, -1, cv2.LINE_AA)
                else:
                    cv2.rectangle(img, (p[0] - 3, p[1] - 3),
                                  (p[0] + 3, p[1] + 3), col, 1)
            lx = width - right + 15
            cv2.line(img, (lx, legend_y), (lx + 25, legend_y), col, thick)
            if kind == "disc":
                cv2.circle(img, (lx + 12, legend_y), 4, col, -1)
            else:
                cv2.rectangle(img, (lx + 9, legend_y - 3),
                              (lx + 15, legend_y + 3), col, 1)
            cv2.putText(img, f"{kind} {method}", (lx + 32, legend_y + 5),
                        font, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
            legend_y += 22
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    cv2.imwrite(path, img)


def _fmt(v, spec):
    return "-" if v is None else format(v, spec)


def report(seed_params, table, results, scene):
    lines = []
    cam = scene["camera"]
    lines.append(f"## Range sweep (camera {cam['width']}x{cam['height']}, "
                 f"hfov {cam['hfov_deg']:g}, h {cam['height_m']:g} m, tilt "
                 f"{cam['tilt_deg']:g}; discs "
                 f"{scene['notes']['disc_diameter_m']:g} m, balls "
                 f"{scene['notes']['ball_diameter_m']:g} m)")
    lines.append("")
    lines.append("| markers | method | band (m) | n | range median | "
                 "range p95 | bearing median |")
    lines.append("|---|---|---|---|---|---|---|")
    for kind in ("disc", "ball"):
        for method in METHODS:
            dist, rel, bearing = results[(kind, method)]
            for lo, hi in BANDS + ((0.3, MAX_RANGE),):
                n, med, p95, bmed = band_stats(dist, rel, bearing, lo, hi)
                name = f"{lo:g}-{hi:g}" if (lo, hi) != (0.3, MAX_RANGE) \
                    else "**all 0.3-4**"
                lines.append(f"| {kind}s | {method} | {name} | {n} | "
                             f"{_fmt(med, '.2f')} % | {_fmt(p95, '.2f')} % | "
                             f"{_fmt(bmed, '.3f')} deg |")
    lines.append("")
    lines.append(f"## Seed model against the exact pinhole model (h 0.5 m, "
                 f"tilt 34, hfov 80, 640x480; tape values b "
                 f"{seed_params['b']:.4f} m, d {seed_params['d']:.4f} m, w "
                 f"{seed_params['w']:.4f} m)")
    lines.append("")
    lines.append("| row v | column u | exact range (m) | seed range error "
                 "(m) | seed position error (m) | (% of range) |")
    lines.append("|---|---|---|---|---|---|")
    for u, v, r, dr, err, pct in table:
        lines.append(f"| {v:g} | {u:g} | {_fmt(r, '.3f')} | "
                     f"{_fmt(dr, '+.4f')} | {_fmt(err, '.4f')} | "
                     f"{_fmt(pct, '.2f')} |")
    return "\n".join(lines)


def _handle(args):
    seed_params, table = seed_vs_exact()
    if args.sweep_dir:
        os.makedirs(args.sweep_dir, exist_ok=True)
        results, scene = run_sweep(args.sweep_dir)
    else:
        with tempfile.TemporaryDirectory() as tmp:
            results, scene = run_sweep(tmp)
    print(report(seed_params, table, results, scene))
    if args.plot:
        draw_plot(results, args.plot)
        print(f"\nplot: {args.plot}")
    return 0


def add_ranging_bench_parser(subparsers):
    """Adds ``ranging`` to the ``bench`` command's actions."""
    parser = subparsers.add_parser(
        "ranging", help="ipmrange accuracy: seed vs exact model, "
                              "range error by distance (docs/ranging.md)",
        description="""Print the tables of docs/ranging.md: the seed
            model's error against the exact pinhole model across the image,
            and ipmrange's range error by distance on the synthetic range
            sweep (ground, size, fused; discs and balls). Needs the plugin
            (GST_PLUGIN_PATH).""")
    parser.add_argument("--plot", metavar="PNG",
                        help="also draw the range error by distance")
    parser.add_argument("--sweep-dir", metavar="DIR",
                        help="render the sweep here (reused when it "
                             "exists) instead of a temporary directory")
    parser.set_defaults(handler=_handle)
