"""gst-landmark floormap: a straight wall seen from two poses, written as
landmarklog lines with the Radial Obstacle Profile computed analytically
(each bin the nearest wall point over its span, as floorboundary
reports it). The grid must have the wall's cells occupied, the floor
between the robots and the wall free, and everything outside the two
views, and behind the wall, unknown."""

import json
import math

import cv2
import numpy as np
import pytest

from gstlandmark.commands import cli, floormap

import shippedclip

WALL_X = 2.02            # the wall: the line x = 2.02 m of the map frame
HALF_FOV = math.radians(30)
BINS, MAX_RANGE, RES = 360, 4.0, 0.05
BW = 2 * math.pi / BINS
POSES = [(0.0, 0.0, 0.0), (0.3, 1.2, math.radians(-20))]
EXTENT = (-1.0, -2.0, 3.0, 3.0)


def rop(px, py, heading):
    """Per bin: range and state code, the nearest wall point over the
    bin's span of bearings; bins not wholly inside the view not seen."""
    ranges, states = [0.0] * BINS, [0] * BINS
    for k in range(BINS):
        b = math.remainder(k * BW, 2 * math.pi)
        if abs(b) + BW / 2 > HALF_FOV:
            continue
        lo, hi = heading + b - BW / 2, heading + b + BW / 2
        nearest = 0.0 if lo <= 0.0 <= hi else min(abs(lo), abs(hi))
        d = (WALL_X - px) / math.cos(nearest)
        if d >= MAX_RANGE:
            ranges[k], states[k] = MAX_RANGE, 1
        else:
            ranges[k], states[k] = d, 2
    return ranges, states


def write_log(path):
    lines = []
    for i, (x, y, h) in enumerate(POSES):
        r, s = rop(x, y, h)
        floor = {"bearing-bins": BINS, "bin-width": BW,
                 "max-range": MAX_RANGE, "range": r, "state": s,
                 "marker-range": [None] * BINS}
        lines.append({"frame": 2 * i, "floor": floor,
                      "pose": {"x": x, "y": y, "heading": h}})
        # the same view without a pose, and a frame without a profile
        lines.append({"frame": 2 * i + 1, "floor": floor})
    lines.append({"frame": 9, "pose": {"x": 0, "y": 0, "heading": 0}})
    path.write_text("".join(json.dumps(v) + "\n" for v in lines))


def in_view(cx, cy, margin):
    """Cells whose centre is inside some pose's view, `margin` radians
    inside its edges, and in front of the wall."""
    inside = np.zeros(cx.shape, bool)
    for x, y, h in POSES:
        b = np.arctan2(cy - y, cx - x) - h
        b = np.angle(np.exp(1j * b))
        inside |= (np.abs(b) < HALF_FOV - margin) & (np.hypot(cx - x, cy - y)
                                                      > RES)
    return inside


def test_wall_from_two_poses(tmp_path):
    log = tmp_path / "run.jsonl"
    write_log(log)
    png = tmp_path / "map.png"
    assert cli.main([
        "floormap", str(log), "--out", str(png), "--resolution", str(RES),
        "--extent", *map(str, EXTENT)]) == 0
    meta = json.loads((tmp_path / "map.json").read_text())
    assert meta["resolution"] == RES
    assert meta["origin"] == pytest.approx([-1.0, -2.0])
    assert (meta["width"], meta["height"]) == (80, 100)
    assert meta["frames"] == 2
    assert meta["skipped"] == {"no pose": 2, "no floor": 1}
    img = cv2.imread(str(png), cv2.IMREAD_UNCHANGED)
    assert img.shape == (100, 80) and img.dtype == np.uint8
    grid = img[::-1]                         # row 0 at y = -2
    xs = -1.0 + (np.arange(80) + 0.5) * RES
    ys = -2.0 + (np.arange(100) + 0.5) * RES
    cx, cy = np.meshgrid(xs, ys)
    occ, free = grid == floormap.OCCUPIED, grid == floormap.FREE
    unknown = grid == floormap.UNKNOWN
    assert (occ | free | unknown).all()

    # the wall's column (centre 2.025 m) over the union of the views: the
    # first pose sees y up to +-2.02 - 0 tan 30 = +-1.166, the second
    # y = 1.2 + 1.72 tan(-50..10 deg) = -0.85..1.50
    col = int((WALL_X - -1.0) / RES)
    seen_y = (ys > -1.166 + 2 * RES) & (ys < 1.50 - 2 * RES)
    wall = occ[seen_y, col]
    print(f"wall cells occupied {wall.sum()}/{len(wall)}, occupied cells "
          f"{occ.sum()}, free {free.sum()}, unknown {unknown.sum()}")
    assert wall.all()
    # nothing occupied more than a cell and a half from the wall
    assert not (occ & (np.abs(cx - WALL_X) > 1.5 * RES)).any()
    # the floor in front of the wall, inside a view by a bin: free
    front = in_view(cx, cy, BW) & (cx < WALL_X - 2 * RES)
    print(f"free in front of the wall {free[front].sum()}/{front.sum()}")
    assert front.sum() > 1000
    assert free[front].all()
    # outside both views (by a bin), and behind the wall: unknown (the
    # cells at the robots themselves, bearing undefined, left out)
    at_robot = np.zeros(cx.shape, bool)
    for x, y, _ in POSES:
        at_robot |= np.hypot(cx - x, cy - y) < 2 * RES
    outside = (~in_view(cx, cy, -BW) | (cx > WALL_X + 2 * RES)) & ~at_robot
    print(f"unknown outside {unknown[outside].sum()}/{outside.sum()}")
    assert unknown[outside].all()


def test_one_pose_is_not_the_other(tmp_path):
    """Turning the robot turns the map: the second pose alone leaves the
    wall below y = -0.85 unseen."""
    log = tmp_path / "run.jsonl"
    r, s = rop(*POSES[1])
    log.write_text(json.dumps({
        "floor": {"bearing-bins": BINS, "bin-width": BW,
                  "max-range": MAX_RANGE, "range": r, "state": s},
        "pose": dict(zip(("x", "y", "heading"), POSES[1]))}) + "\n")
    grid, _ = floormap.map_log(str(log), str(tmp_path / "m.png"), RES,
                               EXTENT)
    st = grid.states()
    col = int((WALL_X - -1.0) / RES)
    _, ys = grid.cell_centres()
    assert (st[(ys > -0.75) & (ys < 1.4), col] == floormap.OCCUPIED).all()
    assert (st[ys < -0.95, col] == floormap.UNKNOWN).all()


@pytest.mark.parametrize("content, message", [
    ("{\"frame\": 0}\n", "no frame has both 'floor' and 'pose'"),
    ("not json\n", "run.jsonl:1: not JSON"),
    (json.dumps({"floor": {"range": [1.0]}, "pose": {"x": 0}}) + "\n",
     "run.jsonl:1: 'floor' or 'pose' lacks a field"),
])
def test_bad_logs(tmp_path, capsys, content, message):
    log = tmp_path / "run.jsonl"
    log.write_text(content)
    assert cli.main(["floormap", str(log), "--out",
                     str(tmp_path / "m.png")]) == 1
    assert message in capsys.readouterr().err


def test_missing_log(tmp_path, capsys):
    assert cli.main(["floormap", str(tmp_path / "none.jsonl")]) == 1
    assert "none.jsonl: cannot read the log" in capsys.readouterr().err


def test_path_clip_with_true_poses(gst, tmp_path):
    """floorboundary on the shipped synthetic clip (a walled 6 m field),
    its log given the clip's true poses: the occupied cells are the walls,
    the free cells inside the field."""
    import os
    from gstlandmark import pipeline
    clip = shippedclip.CLIP_DIR
    scene = shippedclip.scene()
    cam, walls = scene["camera"], scene["walls"]
    truth = shippedclip.true_poses()
    log = tmp_path / "log.jsonl"
    pipeline.run_to_eos(
        f"filesrc location={os.path.join(clip, 'clip.avi')} ! decodebin ! "
        f"videoconvert ! labsegment palette={os.path.join(clip, 'palette.json')}"
        f" ! floorboundary floor-classes=floor camera-height={cam['height_m']} "
        f"tilt={cam['tilt_deg']} roll={cam['roll_deg']} fx={cam['fx']} "
        f"fy={cam['fy']} cx={cam['cx']} cy={cam['cy']} max-range=4 ! "
        f"landmarklog location={log} ! fakesink")
    lines = [json.loads(ln) for ln in log.read_text().splitlines()]
    for ln in lines:
        r = truth[ln["frame"]]
        ln["pose"] = {"x": r["x"], "y": r["y"], "heading": r["heading"]}
    log.write_text("".join(json.dumps(ln) + "\n" for ln in lines))
    grid, _ = floormap.map_log(str(log), str(tmp_path / "m.png"), RES)
    assert grid.frames == len(lines) == 45
    st = grid.states()
    xs, ys = grid.cell_centres()
    cx, cy = np.meshgrid(xs, ys)
    to_wall = np.minimum.reduce([np.abs(cx - walls["x0"]),
                                 np.abs(cx - walls["x1"]),
                                 np.abs(cy - walls["y0"]),
                                 np.abs(cy - walls["y1"])])
    inside = ((cx > walls["x0"]) & (cx < walls["x1"]) & (cy > walls["y0"]) &
              (cy < walls["y1"]))
    occ, free = st == floormap.OCCUPIED, st == floormap.FREE
    near = (to_wall[occ] <= 1.5 * RES).mean()
    print(f"occupied {occ.sum()} cells, {near:.1%} within 1.5 cells of a "
          f"wall; free {free.sum()}, {(free & inside).sum()} inside the "
          f"field; median |d| occupied {np.median(to_wall[occ]):.3f} m")
    print("occupied cells' distance to a wall, percentiles 50/90/95/99/100:",
          np.round(np.percentile(to_wall[occ], [50, 90, 95, 99, 100]), 3))
    # a bin takes the nearest wall point over its span, so on a wall seen
    # at a grazing angle the whole bin's cells are marked at that range,
    # in front of the wall: a tail of cells off the wall
    assert occ.sum() > 100
    assert near >= 0.85
    assert np.median(to_wall[occ]) <= RES
    assert np.percentile(to_wall[occ], 90) <= 2 * RES
    assert to_wall[occ].max() <= 0.5
    assert not (free & ~inside & (to_wall > RES)).any()
