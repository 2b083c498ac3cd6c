"""Whole-chain benchmark: ``gst-landmark bench chain``.

Prints numbers; it is not a timed test.  For each frame size it

1. renders a few frames of the synthetic ``path`` scenario
   (``synth.build_scenario`` + ``synth.render_frame``: perspective floor,
   walls, discs and balls, noise; fixed seed) at poses spread round the
   loop, packs them as BGRx and writes the scene's palette and map;
2. runs ``tests/bench/chain-bench`` pinned to one core (``taskset -c``)
   on ``labsegment ! blobroundness ! ipmrange ! trilaterate`` with the
   scene's palette, camera and map (no decode), then again with
   ``landmarkoverlay`` behind it: each element's own time per frame from
   pad probes, the chain's, poses produced, a memcpy of one frame, and at
   640x480 the steady-state VmRSS over 10,000 frames;
3. times the same chain written the plain Python way (``python_chain``:
   the reference segmentation, OpenCV blobs and ellipses, numpy ray-floor
   ranging, a numpy least-squares pose) on the same frames, same core;
4. prints the table and the issue's targets at 640x480: chain at most
   1.5 ms per frame, at least 20x faster than Python, within 15x of the
   frame copy.
"""

import itertools
import json
import math
import os
import subprocess
import sys
import tempfile
import time

import cv2
import numpy as np

from .. import reference
from ..commands.common import size_type
from .benchkit import (BenchError, OneCore, add_build_dir_option,
                       add_report_options, bench_environment, pin_prefix,
                       write_json)
from .benchkit import find_build_dir as find_program_build_dir

CHAIN_EXE = os.path.join("tests", "bench", "chain-bench")
PEER_EXE = os.path.join("tests", "bench", "peer-bench")
DEFAULT_SIZES = ((640, 480), (1920, 1080))
DEFAULT_FRAMES = 1000
DEFAULT_DISTINCT = 8
DEFAULT_PY_ITERATIONS = 24
DEFAULT_RSS_FRAMES = 10000
ELEMENTS = ("labsegment", "blobroundness", "ipmrange", "trilaterate")

# The targets (one core, 640x480).
TARGET_SIZE = (640, 480)
TARGET_MS = 1.5
TARGET_SPEEDUP = 20.0
TARGET_COPY_RATIO = 15.0
# issue 18: the chain at least this many times faster than the hand-written
# OpenCV C++ program (tests/bench/peer-bench.cpp)
TARGET_PEER_RATIO = 6.0

# The plain chain's blob filters (blobroundness's defaults).
MIN_AREA = 100
MIN_ELLIPSE_FIT = 0.92
MAX_ASPECT = 10.0


# ---------------------------------------------------------------------------
# Frames


class Scenario:
    """Frames of the path scenario at one size, with what the chain needs."""

    def __init__(self, width, height, distinct, out_dir, seed=0):
        from .. import synth
        from ..synth.world import palette_json

        self.width, self.height = width, height
        self.scene, n_frames = synth.build_scenario(
            "path", seed=seed, size=(width, height), frames=300,
            robot="comfortable")
        cam = self.scene.camera
        self.camera = cam
        period = self.scene.trajectory.period_s
        self.poses, self.bgrx = [], []
        for i in range(distinct):
            t = period * (i + 0.5) / distinct
            frame = int(round(t * self.scene.fps))
            pose = self.scene.trajectory.pose(t)
            rgb, _truth, _mask = synth.render_frame(
                self.scene, pose, t=t, frame=frame, frames_total=n_frames)
            bgrx = np.full((height, width, 4), 255, np.uint8)
            bgrx[..., :3] = rgb[..., ::-1]
            self.bgrx.append(bgrx)
            self.poses.append(pose)
        self.palette = self.scene.scene_palette()
        self.map = self.scene.map_json()
        tag = f"{width}x{height}"
        self.raw_path = os.path.join(out_dir, f"{tag}.BGRx.raw")
        self.palette_path = os.path.join(out_dir, f"{tag}.palette.json")
        self.map_path = os.path.join(out_dir, f"{tag}.map.json")
        with open(self.raw_path, "wb") as f:
            for frame in self.bgrx:
                f.write(frame.tobytes())
        with open(self.palette_path, "w") as f:
            json.dump(palette_json(self.palette), f, indent=2)
        with open(self.map_path, "w") as f:
            json.dump(self.map, f, indent=2)

    def chain_launch(self):
        cam = self.camera
        return (f"labsegment palette={self.palette_path} min-class-pixels=0 "
                f"! blobroundness ! ipmrange camera-height={cam.height_m} "
                f"tilt={cam.tilt_deg} hfov={cam.hfov_deg:.6f} "
                f"map={self.map_path} ! trilaterate map={self.map_path}")

    def overlay_launch(self):
        return self.chain_launch() + f" ! landmarkoverlay map={self.map_path}"


# ---------------------------------------------------------------------------
# The chain the plain Python way


class PythonChain:
    """labsegment ! blobroundness ! ipmrange ! trilaterate as a user would
    write it with OpenCV and numpy (the reference segmentation, completed)."""

    def __init__(self, palette, landmarks, camera):
        self.palette = palette
        self.markers = [(k + 1, c.name) for k, c in
                        enumerate(palette.classes) if c.marker]
        self.by_class = {}
        for lm in landmarks:
            z = lm.get("z", 0.0)
            if lm.get("kind") == "ball" and not z:
                z = lm.get("diameter", 0.0) / 2.0
            self.by_class.setdefault(lm["class"], []).append(
                (lm["id"], float(lm["x"]), float(lm["y"]), float(z)))
        self.k_inv = np.linalg.inv(camera.matrix)
        t = math.radians(camera.tilt_deg)
        # columns: camera x_c, y_c, z_c axes in the robot frame
        self.cam_to_robot = np.array([[0.0, -math.sin(t), math.cos(t)],
                                      [-1.0, 0.0, 0.0],
                                      [0.0, -math.cos(t), -math.sin(t)]])
        self.height_m = camera.height_m

    def blobs(self, labels):
        """(class, u, v) of every round-enough blob."""
        found = []
        for value, name in self.markers:
            mask = (labels == value).astype(np.uint8)
            n, comp, stats, _ = cv2.connectedComponentsWithStats(
                mask, connectivity=8)
            for j in range(1, n):
                x, y, w, h, area = stats[j]
                if area < MIN_AREA:
                    continue
                blob = (comp[y:y + h, x:x + w] == j).astype(np.uint8)
                contours, _ = cv2.findContours(blob, cv2.RETR_EXTERNAL,
                                               cv2.CHAIN_APPROX_NONE)
                contour = max(contours, key=cv2.contourArea)
                if len(contour) < 5:
                    continue
                (ex, ey), (d1, d2), _ = cv2.fitEllipse(contour)
                major, minor = max(d1, d2), min(d1, d2)
                if minor <= 0 or major / minor > MAX_ASPECT:
                    continue
                ellipse_area = math.pi * major * minor / 4.0
                fit = min(area, ellipse_area) / max(area, ellipse_area)
                if fit < MIN_ELLIPSE_FIT:
                    continue
                found.append((name, x + ex, y + ey))
        return found

    def ground(self, name, u, v):
        """Robot-frame (x, y) where the pixel's ray meets the marker's
        plane, or None."""
        cands = self.by_class.get(name)
        if not cands:
            return None
        z = cands[0][3]
        ray = self.cam_to_robot @ (self.k_inv @ np.array([u, v, 1.0]))
        if ray[2] >= -1e-9:
            return None
        s = (z - self.height_m) / ray[2]
        return ray[0] * s, ray[1] * s

    @staticmethod
    def _rigid(obs, ref):
        """Closed-form 2-D rigid fit ref ~ R obs + t: (x, y, heading)."""
        mo, mr = obs.mean(axis=0), ref.mean(axis=0)
        a, b = obs - mo, ref - mr
        heading = math.atan2(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]),
                             np.sum(a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1]))
        c, s = math.cos(heading), math.sin(heading)
        t = mr - np.array([[c, -s], [s, c]]) @ mo
        return np.array([t[0], t[1], heading])

    @staticmethod
    def _gauss_newton(pose, obs, ref, sigma, iterations=5):
        """Weighted least squares of R(h) obs + (x, y) - ref."""
        w = 1.0 / sigma
        for _ in range(iterations):
            c, s = math.cos(pose[2]), math.sin(pose[2])
            pred = obs @ np.array([[c, s], [-s, c]]) + pose[:2]
            r = ((pred - ref) * w[:, None]).ravel()
            jac = np.zeros((len(obs), 2, 3))
            jac[:, 0, 0] = jac[:, 1, 1] = 1.0
            jac[:, 0, 2] = -s * obs[:, 0] - c * obs[:, 1]
            jac[:, 1, 2] = c * obs[:, 0] - s * obs[:, 1]
            jac = (jac * w[:, None, None]).reshape(-1, 3)
            step = np.linalg.lstsq(jac, -r, rcond=None)[0]
            pose = pose + step
            if np.max(np.abs(step)) < 1e-9:
                break
        c, s = math.cos(pose[2]), math.sin(pose[2])
        pred = obs @ np.array([[c, s], [-s, c]]) + pose[:2]
        return pose, float(np.sum(((pred - ref) * w[:, None]) ** 2))

    def pose(self, detections):
        """Least-squares pose from (class, gx, gy) detections, trying every
        assignment of repeated colours; None with fewer than two."""
        dets = [d for d in detections if d[0] in self.by_class]
        if len(dets) < 2:
            return None
        obs = np.array([[d[1], d[2]] for d in dets])
        sigma = 0.01 + 0.02 * np.hypot(obs[:, 0], obs[:, 1])
        best = None
        for combo in itertools.product(*[self.by_class[d[0]] for d in dets]):
            ids = [c[0] for c in combo]
            if len(set(ids)) != len(ids):
                continue
            ref = np.array([[c[1], c[2]] for c in combo])
            pose, cost = self._gauss_newton(self._rigid(obs, ref), obs, ref,
                                            sigma)
            if best is None or cost < best[1]:
                best = (pose, cost)
        return None if best is None else best[0]

    def __call__(self, bgrx):
        rgb = bgrx[..., 2::-1]
        seg = reference.segment_rgb(rgb, self.palette, min_class_pixels=0)
        detections = []
        for name, u, v in self.blobs(seg.labels):
            g = self.ground(name, u, v)
            if g is not None:
                detections.append((name, g[0], g[1]))
        return detections, self.pose(detections)


def time_python_chain(scen, iterations, cpu):
    """Per-frame times (ms) and results of the Python chain."""
    chain = PythonChain(scen.palette, scen.map["landmarks"], scen.camera)
    times, results = [], []
    calls = max(iterations, len(scen.bgrx))
    with OneCore(cpu):
        for i in range(calls):
            frame = scen.bgrx[i % len(scen.bgrx)]
            t0 = time.perf_counter()
            dets, pose = chain(frame)
            times.append((time.perf_counter() - t0) * 1e3)
            if i < len(scen.bgrx):
                results.append((dets, pose))
    return times, results


# ---------------------------------------------------------------------------
# The C bench


def find_build_dir(build_dir=None):
    return find_program_build_dir(CHAIN_EXE, build_dir)


def run_chain_bench(build_dir, scen, launch, label, frames, warmup, cpu,
                    rss_frames=0, copy=True):
    cmd = pin_prefix(cpu) + [
        os.path.join(build_dir, CHAIN_EXE), "--input", scen.raw_path,
        "--format", "BGRx", "--width", str(scen.width),
        "--height", str(scen.height), "--launch", launch, "--label", label,
        "--frames", str(frames), "--warmup", str(warmup)]
    if rss_frames:
        cmd += ["--rss-frames", str(rss_frames)]
    if not copy:
        cmd.append("--no-copy")
    proc = subprocess.run(cmd, env=bench_environment(build_dir),
                          capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise BenchError(f"chain-bench failed (status {proc.returncode}): "
                         f"{proc.stderr.strip()}")
    items = [json.loads(line) for line in proc.stdout.splitlines()
             if line.startswith("{")]
    chain = [i for i in items if i["type"] == "chain"]
    if not chain:
        raise BenchError(f"chain-bench printed no chain timing: "
                         f"{proc.stdout!r} {proc.stderr!r}")
    plugin = chain[0].get("plugin_file", "")
    if not os.path.realpath(plugin).startswith(
            os.path.realpath(build_dir) + os.sep):
        raise BenchError(f"the chain was loaded from {plugin!r}, not from "
                         f"the build tree {build_dir}")
    return items


def run_peer_bench(build_dir, scen, frames, warmup, cpu):
    """The hand-written OpenCV program on the same frames: its JSON line."""
    cam = scen.camera
    cmd = pin_prefix(cpu) + [
        os.path.join(build_dir, PEER_EXE), "--input", scen.raw_path,
        "--palette", scen.palette_path, "--width", str(scen.width),
        "--height", str(scen.height), "--frames", str(frames),
        "--warmup", str(warmup), "--camera-height", str(cam.height_m),
        "--tilt", str(cam.tilt_deg), "--hfov", f"{cam.hfov_deg:.6f}"]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise BenchError(f"peer-bench failed (status {proc.returncode}): "
                         f"{proc.stderr.strip()}")
    items = [json.loads(line) for line in proc.stdout.splitlines()
             if line.startswith("{")]
    if not items or items[0].get("type") != "peer":
        raise BenchError(f"peer-bench printed no timing: {proc.stdout!r}")
    return items[0]


# ---------------------------------------------------------------------------
# The benchmark


def _stat(times):
    return float(np.median(times)), float(np.percentile(times, 90))


def run_chain(build_dir=None, sizes=DEFAULT_SIZES, frames=DEFAULT_FRAMES,
              distinct=DEFAULT_DISTINCT, py_iterations=DEFAULT_PY_ITERATIONS,
              rss_frames=DEFAULT_RSS_FRAMES, cpu=0, progress=None):
    """Run everything; returns a dict of the numbers (see format_table)."""
    build_dir = find_build_dir(build_dir)
    say = progress or (lambda text: None)
    result = {"load_before": os.getloadavg(), "cpu": cpu, "sizes": []}
    with tempfile.TemporaryDirectory(prefix="chain-bench-") as tmp:
        for width, height in sizes:
            tag = f"{width}x{height}"
            say(f"{tag}: rendering {distinct} path frames")
            scen = Scenario(width, height, distinct, tmp)
            warmup = max(20, distinct)
            do_rss = rss_frames if (width, height) == TARGET_SIZE else 0
            say(f"{tag}: C chain, {frames} frames"
                + (f", then {do_rss} frames for RSS" if do_rss else ""))
            items = run_chain_bench(build_dir, scen, scen.chain_launch(),
                                    "chain", frames, warmup, cpu,
                                    rss_frames=do_rss)
            say(f"{tag}: C chain with landmarkoverlay, {frames} frames")
            items += run_chain_bench(build_dir, scen, scen.overlay_launch(),
                                     "chain+overlay", frames, warmup, cpu,
                                     copy=False)
            say(f"{tag}: hand-written OpenCV program, {frames} frames")
            peer = run_peer_bench(build_dir, scen, frames, warmup, cpu)
            iters = py_iterations if (width, height) == TARGET_SIZE \
                else max(distinct, py_iterations // 3)
            say(f"{tag}: Python chain, {max(iters, distinct)} calls")
            py_ms, py_res = time_python_chain(scen, iters, cpu)
            py_err = []
            for (dets, pose), truth in zip(py_res, scen.poses):
                if pose is not None:
                    py_err.append(math.hypot(pose[0] - truth.x,
                                             pose[1] - truth.y))
            rows = {}
            for it in items:
                if it["type"] == "element":
                    key = it["name"] if it["run"] == "chain" else \
                        (it["name"] if it["name"] == "landmarkoverlay"
                         else None)
                    if key:
                        rows[key] = (it["median_ms"], it["p90_ms"])
                elif it["type"] == "chain":
                    rows[it["run"]] = (it["median_ms"], it["p90_ms"])
                elif it["type"] == "copy":
                    rows["copy"] = (it["median_ms"], it["p90_ms"])
            rows["OpenCV program"] = (peer["median_ms"], peer["p90_ms"])
            rows["python chain"] = _stat(py_ms)
            chain_item = next(i for i in items if i["type"] == "chain"
                              and i["run"] == "chain")
            rss = next((i for i in items if i["type"] == "rss"), None)
            result["sizes"].append({
                "width": width, "height": height, "rows": rows,
                "c_frames": chain_item["frames"],
                "c_frames_with_pose": chain_item["frames_with_pose"],
                "c_detections": chain_item["detections"],
                "c_ranged": chain_item["ranged"],
                "peer_detections": peer["detections"],
                "peer_ranged": peer["ranged"],
                "python_calls": len(py_ms),
                "python_distinct_with_pose": len(py_err),
                "python_pose_error_m_median": (float(np.median(py_err))
                                               if py_err else None),
                "launch": chain_item["launch"],
                "rss": rss})
    result["load_after"] = os.getloadavg()
    return result


def _verdict(ok):
    return "yes" if ok else "NO"


def format_table(result):
    lines = [f"{'size':>9}  {'stage':<16} {'median ms':>10} {'p90 ms':>9}"
             f"  {'x copy':>7}  {'Python / this':>13}"]
    order = ("copy",) + ELEMENTS + ("chain", "landmarkoverlay",
                                    "chain+overlay", "OpenCV program",
                                    "python chain")
    for size in result["sizes"]:
        rows = size["rows"]
        tag = f"{size['width']}x{size['height']}"
        copy_ms = rows["copy"][0]
        py_ms = rows["python chain"][0]
        for name in order:
            if name not in rows:
                continue
            med, p90 = rows[name]
            versus = (f"{py_ms / med:13.1f}" if name in
                      ("chain", "chain+overlay", "OpenCV program")
                      else f"{'':13}")
            lines.append(f"{tag:>9}  {name:<16} {med:10.3f} {p90:9.3f}"
                         f"  {med / copy_ms:7.1f}  {versus}")
        lines.append(
            f"{tag:>9}  C chain: {size['c_frames_with_pose']}/"
            f"{size['c_frames']} frames with a pose, "
            f"{size['c_ranged'] / size['c_frames']:.2f} ranged detections "
            f"per frame; Python chain: pose on "
            f"{size['python_distinct_with_pose']} of the distinct frames"
            + (f", median position error "
               f"{size['python_pose_error_m_median']:.3f} m"
               if size["python_pose_error_m_median"] is not None else "")
            + f"; OpenCV program: {size['peer_ranged'] / size['c_frames']:.2f}"
            f" ranged detections per frame")
    for size in result["sizes"]:
        if (size["width"], size["height"]) != TARGET_SIZE:
            continue
        rows = size["rows"]
        chain = rows["chain"][0]
        speedup = rows["python chain"][0] / chain
        ratio = chain / rows["copy"][0]
        peer = rows["OpenCV program"][0] / chain
        lines.append(f"targets at 640x480, one core: chain {chain:.3f} ms "
                     f"<= {TARGET_MS} ms: {_verdict(chain <= TARGET_MS)}; "
                     f"{speedup:.1f}x Python >= {TARGET_SPEEDUP:.0f}x: "
                     f"{_verdict(speedup >= TARGET_SPEEDUP)}; {ratio:.1f}x "
                     f"copy <= {TARGET_COPY_RATIO:.0f}x: "
                     f"{_verdict(ratio <= TARGET_COPY_RATIO)}; "
                     f"{peer:.1f}x the OpenCV program >= "
                     f"{TARGET_PEER_RATIO:.0f}x: "
                     f"{_verdict(peer >= TARGET_PEER_RATIO)}")
        rss = size["rss"]
        if rss:
            lines.append(f"RSS at 640x480 over {rss['frames']} frames (after "
                         f"{rss['warmup']} warm-up, every {rss['every']}): "
                         f"{rss['first_kb']} -> {rss['last_kb']} kB "
                         f"(growth {rss['growth_kb']} kB, max "
                         f"{rss['max_kb']} kB, VmHWM {rss['vm_hwm_kb']} kB); "
                         f"samples {rss['samples_kb']}")
    lb, la = result["load_before"], result["load_after"]
    lines.append(f"load average before {lb[0]:.2f} {lb[1]:.2f} {lb[2]:.2f}, "
                 f"after {la[0]:.2f} {la[1]:.2f} {la[2]:.2f} "
                 f"({os.cpu_count()} cores); pinned to core {result['cpu']}")
    return "\n".join(lines)


def _handle_chain(args):
    cpu = None if args.cpu < 0 else args.cpu
    progress = None if args.quiet else (
        lambda text: print(text, file=sys.stderr, flush=True))
    try:
        result = run_chain(build_dir=args.build_dir,
                           sizes=args.size or DEFAULT_SIZES,
                           frames=args.frames, distinct=args.distinct,
                           py_iterations=args.iterations,
                           rss_frames=args.rss_frames, cpu=cpu,
                           progress=progress)
    except BenchError as err:
        print(f"gst-landmark: error: {err}", file=sys.stderr)
        return 1
    print(format_table(result))
    write_json(args.json, result)
    return 0


def add_chain_bench_parser(actions):
    """Add ``bench chain`` under ``gst-landmark bench``."""
    p = actions.add_parser(
        "chain", help="per-element and whole-chain time vs frame copy and "
                      "the Python chain; steady-state RSS",
        description="Time labsegment ! blobroundness ! ipmrange ! "
                    "trilaterate (and landmarkoverlay) per element and as a "
                    "chain on one core, on path-scenario frames, beside a "
                    "frame copy and the same chain in plain Python/OpenCV; "
                    "check the targets and the steady-state RSS.")
    add_build_dir_option(p)
    p.add_argument("--frames", type=int, default=DEFAULT_FRAMES, metavar="N",
                   help=f"timed C frames per run (default {DEFAULT_FRAMES})")
    p.add_argument("--distinct", type=int, default=DEFAULT_DISTINCT,
                   metavar="N", help="distinct rendered frames cycled "
                                     f"through (default {DEFAULT_DISTINCT})")
    p.add_argument("--iterations", type=int, default=DEFAULT_PY_ITERATIONS,
                   metavar="N", help="Python chain calls at 640x480 (a "
                                     "third at other sizes; default "
                                     f"{DEFAULT_PY_ITERATIONS})")
    p.add_argument("--rss-frames", type=int, default=DEFAULT_RSS_FRAMES,
                   metavar="N", help="frames of the 640x480 memory run "
                                     f"(default {DEFAULT_RSS_FRAMES}; 0: "
                                     "none)")
    p.add_argument("--size", type=size_type, action="append",
                   metavar="WxH", help="frame size (repeatable; default "
                                       "640x480 and 1920x1080)")
    p.add_argument("--cpu", type=int, default=0, metavar="CORE",
                   help="core to pin to (default 0; -1: no pinning)")
    add_report_options(p)
    p.set_defaults(handler=_handle_chain)
    return p
