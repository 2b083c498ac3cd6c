"""``gst-landmark floormap``: the free floor seen along a run, accumulated
into an occupancy grid of the map frame (docs/floormap.md).

It reads a landmarklog file (JSON Lines): every frame that has both
floorboundary's ``floor`` profile and a ``pose`` (trilaterate) turns its
Radial Obstacle Profile by the heading and places it at the pose; each
cell of the grid within ``max-range`` of the robot then takes one update
from the bin its centre falls in (an inverse sensor model, so no cell
between two rays is missed):

- nearer than the bin's range less one cell: seen free;
- an ``obstacle`` bin, within one cell of its range: seen occupied;
- ``not-seen`` bins, cells beyond, and frames without a pose: no update.

Updates add log-odds (+0.85 occupied, -0.4 free, clamped to [-2, 3.5],
the values OctoMap uses for p_hit 0.7 and p_miss 0.4), so a cell seen
free from one pose and occupied from another ends occupied after two
hits against four misses or fewer. The grid is written as a PNG (free
254, occupied 0, unknown 205, north up: the top row is the largest y)
and a JSON file with its scale, origin and size.

A tool over the log rather than a mode of floorboundary: mapping needs
the pose, which comes from elements that may sit after floorboundary in
the chain, or from a later run; the element stays one frame in, one
frame out, and a recorded run can be mapped again at another scale.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from typing import Iterable, List, Optional, Tuple

import numpy as np

FREE, OCCUPIED, UNKNOWN = 254, 0, 205
L_HIT, L_MISS, L_MIN, L_MAX = 0.85, -0.4, -2.0, 3.5

STATE_NOT_SEEN, STATE_FREE, STATE_OBSTACLE, STATE_VIEW_EDGE = 0, 1, 2, 3
MAX_CELLS = 4000 * 4000


class FloorMapError(ValueError):
    """A log or setting that cannot make a map; the message names it."""


@dataclass
class Scan:
    """One frame's profile and pose, map frame."""
    x: float
    y: float
    heading: float          # radians, counter-clockwise from +x
    bin_width: float        # radians; bin k is centred on k * bin_width
    max_range: float
    ranges: np.ndarray      # metres per bin
    states: np.ndarray      # codes per bin


@dataclass
class Grid:
    """Log-odds per cell; cell (row, col) covers
    [x0 + col res, x0 + (col + 1) res) x [y0 + row res, ...) (row 0 at the
    bottom, the smallest y)."""
    resolution: float
    x0: float
    y0: float
    logodds: np.ndarray
    seen: np.ndarray
    frames: int = 0
    skipped: int = 0
    skipped_reasons: dict = field(default_factory=dict)

    @property
    def height(self) -> int:
        return self.logodds.shape[0]

    @property
    def width(self) -> int:
        return self.logodds.shape[1]

    def cell_centres(self) -> Tuple[np.ndarray, np.ndarray]:
        """x of each column's centre, y of each row's centre."""
        res = self.resolution
        return (self.x0 + (np.arange(self.width) + 0.5) * res,
                self.y0 + (np.arange(self.height) + 0.5) * res)

    def states(self) -> np.ndarray:
        """FREE / OCCUPIED / UNKNOWN per cell, row 0 at the bottom."""
        out = np.full(self.logodds.shape, UNKNOWN, np.uint8)
        out[self.seen & (self.logodds < 0)] = FREE
        out[self.seen & (self.logodds > 0)] = OCCUPIED
        return out

    def add(self, scan: Scan) -> None:
        res = self.resolution
        # the cells within max-range of the robot
        c0 = max(0, int(math.floor((scan.x - scan.max_range - self.x0) / res)))
        c1 = min(self.width,
                 int(math.ceil((scan.x + scan.max_range - self.x0) / res)) + 1)
        r0 = max(0, int(math.floor((scan.y - scan.max_range - self.y0) / res)))
        r1 = min(self.height,
                 int(math.ceil((scan.y + scan.max_range - self.y0) / res)) + 1)
        if c0 >= c1 or r0 >= r1:
            return
        xs = self.x0 + (np.arange(c0, c1) + 0.5) * res - scan.x
        ys = self.y0 + (np.arange(r0, r1) + 0.5) * res - scan.y
        dx, dy = np.meshgrid(xs, ys)
        d = np.hypot(dx, dy)
        bearing = np.arctan2(dy, dx) - scan.heading
        n = len(scan.ranges)
        k = np.rint(bearing / scan.bin_width).astype(np.int64) % n
        r = scan.ranges[k]
        s = scan.states[k]
        seen = (s != STATE_NOT_SEEN) & (d <= scan.max_range)
        free = seen & (d <= r - res)
        occ = seen & (s == STATE_OBSTACLE) & (np.abs(d - r) < res)
        lo = self.logodds[r0:r1, c0:c1]
        lo += np.where(free, L_MISS, 0.0) + np.where(occ, L_HIT, 0.0)
        np.clip(lo, L_MIN, L_MAX, out=lo)
        self.seen[r0:r1, c0:c1] |= free | occ
        self.frames += 1


def scans_from_log(path: str) -> Iterable[Tuple[int, Optional[Scan], str]]:
    """(line number, Scan or None, why skipped) per line of a landmarklog
    file."""
    try:
        f = open(path, encoding="utf-8")
    except OSError as exc:
        raise FloorMapError(f"{path}: cannot read the log: "
                            f"{exc.strerror}") from None
    with f:
        for i, line in enumerate(f, 1):
            if not line.strip():
                continue
            try:
                frame = json.loads(line)
            except json.JSONDecodeError as exc:
                raise FloorMapError(f"{path}:{i}: not JSON ({exc.msg})") \
                    from None
            floor, pose = frame.get("floor"), frame.get("pose")
            if not floor:
                yield i, None, "no floor"
                continue
            if not pose:
                yield i, None, "no pose"
                continue
            try:
                ranges = np.array([float(v) if v is not None else 0.0
                                   for v in floor["range"]])
                states = np.array(floor["state"], np.int64)
                scan = Scan(float(pose["x"]), float(pose["y"]),
                            float(pose["heading"]), float(floor["bin-width"]),
                            float(floor["max-range"]), ranges, states)
            except (KeyError, TypeError, ValueError) as exc:
                raise FloorMapError(
                    f"{path}:{i}: 'floor' or 'pose' lacks a field or has a "
                    f"wrong value ({exc!r})") from None
            if (len(ranges) != len(states) or not len(ranges) or
                    not scan.bin_width > 0 or not scan.max_range > 0 or
                    not all(map(math.isfinite,
                                (scan.x, scan.y, scan.heading)))):
                raise FloorMapError(f"{path}:{i}: 'floor' or 'pose' is "
                                    "inconsistent (bins, bin-width, "
                                    "max-range, finite pose)")
            yield i, scan, ""


def build(scans: List[Scan], resolution: float,
          extent: Optional[Tuple[float, float, float, float]] = None,
          skipped: Optional[dict] = None) -> Grid:
    """The grid of these scans. extent: (xmin, ymin, xmax, ymax) in
    metres; default: every pose's surroundings within its max-range."""
    if not resolution > 0:
        raise FloorMapError(f"Invalid resolution {resolution}: must be > 0 "
                            "(metres per cell).")
    if extent is None:
        if not scans:
            raise FloorMapError("No frame has both 'floor' and 'pose': "
                                "nothing to map (is floorboundary in the "
                                "chain, and trilaterate?).")
        extent = (min(s.x - s.max_range for s in scans),
                  min(s.y - s.max_range for s in scans),
                  max(s.x + s.max_range for s in scans),
                  max(s.y + s.max_range for s in scans))
    xmin, ymin, xmax, ymax = extent
    if not (xmax > xmin and ymax > ymin):
        raise FloorMapError(f"Invalid extent {extent}: needs xmin < xmax "
                            "and ymin < ymax.")
    # the origin on a multiple of the resolution, so maps of one place
    # line up
    x0 = math.floor(xmin / resolution) * resolution
    y0 = math.floor(ymin / resolution) * resolution
    w = int(math.ceil((xmax - x0) / resolution))
    h = int(math.ceil((ymax - y0) / resolution))
    if w * h > MAX_CELLS:
        raise FloorMapError(f"The map would have {w} x {h} cells (at most "
                            f"{MAX_CELLS}): use a coarser resolution or an "
                            "extent.")
    grid = Grid(resolution, x0, y0, np.zeros((h, w)),
                np.zeros((h, w), bool))
    for s in scans:
        grid.add(s)
    if skipped:
        grid.skipped = sum(skipped.values())
        grid.skipped_reasons = dict(skipped)
    return grid


def write(grid: Grid, png_path: str) -> str:
    """Writes the PNG and, beside it, the JSON (same name, .json);
    returns the JSON's path."""
    import cv2
    img = grid.states()[::-1]            # north up
    if not cv2.imwrite(png_path, img):
        raise FloorMapError(f"{png_path}: cannot write the PNG (a .png "
                            "name in a writable folder?)")
    meta_path = os.path.splitext(png_path)[0] + ".json"
    meta = {
        "image": os.path.basename(png_path),
        "resolution": grid.resolution,
        "origin": [grid.x0, grid.y0],
        "width": grid.width,
        "height": grid.height,
        "frame": "map",
        "values": {"free": FREE, "occupied": OCCUPIED, "unknown": UNKNOWN},
        "frames": grid.frames,
        "skipped": grid.skipped_reasons,
        "cells": {"free": int((img == FREE).sum()),
                  "occupied": int((img == OCCUPIED).sum()),
                  "unknown": int((img == UNKNOWN).sum())},
    }
    with open(meta_path, "w", encoding="utf-8") as f:
        json.dump(meta, f, indent=2)
        f.write("\n")
    return meta_path


def map_log(log: str, out_png: str, resolution: float = 0.05,
            extent=None) -> Tuple[Grid, str]:
    scans, skipped = [], {}
    for _, scan, why in scans_from_log(log):
        if scan is None:
            skipped[why] = skipped.get(why, 0) + 1
        else:
            scans.append(scan)
    if not scans:
        raise FloorMapError(f"{log}: no frame has both 'floor' and 'pose' "
                            f"(skipped: {skipped or 'none'}); floorboundary "
                            "and trilaterate must be before landmarklog.")
    grid = build(scans, resolution, extent, skipped)
    return grid, write(grid, out_png)


def add_floormap_parser(subparsers):
    p = subparsers.add_parser(
        "floormap", help="occupancy grid of the floor seen along a run",
        description="Accumulates floorboundary's free-floor profile, placed "
                    "by the pose, over a landmarklog file into an occupancy "
                    "grid: a PNG (free 254, occupied 0, unknown 205, north "
                    "up) and a JSON beside it with resolution, origin and "
                    "size. See docs/floormap.md.")
    p.add_argument("log", help="landmarklog JSON Lines file")
    p.add_argument("--out", default="floormap.png", metavar="PNG",
                   help="the PNG; the JSON gets the same name with .json "
                        "(default floormap.png)")
    p.add_argument("--resolution", type=float, default=0.05, metavar="M",
                   help="metres per cell (default 0.05)")
    p.add_argument("--extent", type=float, nargs=4, default=None,
                   metavar=("XMIN", "YMIN", "XMAX", "YMAX"),
                   help="map-frame window, metres (default: every pose's "
                        "surroundings within max-range)")
    p.set_defaults(handler=_handle, parser=p)


def _handle(args) -> int:
    import sys
    try:
        grid, meta_path = map_log(args.log, args.out, args.resolution,
                                  tuple(args.extent) if args.extent else None)
    except FloorMapError as exc:
        print(f"gst-landmark floormap: {exc}", file=sys.stderr)
        return 1
    img = grid.states()
    print(f"{args.out}: {grid.width} x {grid.height} cells of "
          f"{grid.resolution:g} m from {grid.frames} frames "
          f"({grid.skipped} skipped); free {(img == FREE).sum()}, "
          f"occupied {(img == OCCUPIED).sum()}, unknown "
          f"{(img == UNKNOWN).sum()}; {meta_path}")
    return 0
