"""Free floor around the robot: per bearing bin, the distance from the
camera's floor point to the nearest wall or obstacle footprint inside the
bin (exact over the bin's wedge, not sampled)."""

import math

import numpy as np


def rectangle_edges(x, y, size_x, size_y, angle):
    """The 4 edges (4, 2, 2) of a rectangle centred at (x, y), sides
    size_x and size_y along its axes turned by angle (radians)."""
    c, s = math.cos(angle), math.sin(angle)
    hx, hy = size_x / 2.0, size_y / 2.0
    corners = np.array([(x + c * px - s * py, y + s * px + c * py)
                        for px, py in ((-hx, -hy), (hx, -hy), (hx, hy),
                                       (-hx, hy))])
    return np.stack([corners, np.roll(corners, -1, axis=0)], axis=1)


def circle_edges(x, y, radius, count=32):
    """A circle as the edges (count, 2, 2) of its circumscribed polygon
    (whose nearest points lie on the circle)."""
    a = np.arange(count) * 2 * math.pi / count
    r = radius / math.cos(math.pi / count)
    corners = np.stack([x + r * np.cos(a), y + r * np.sin(a)], 1)
    return np.stack([corners, np.roll(corners, -1, axis=0)], axis=1)


def free_ranges(x, y, heading, segments, bins=360):
    """Per bin k (centred on bearing 2 pi k / bins, left positive, as
    floorboundary's ROP), the distance from (x, y) to the nearest point of
    the segments (S, 2, 2) whose bearing lies in the bin; inf: none."""
    segs = np.asarray(segments, np.float64).reshape(-1, 2, 2)
    if len(segs) == 0:
        return np.full(bins, np.inf)
    c, s = math.cos(heading), math.sin(heading)
    rel = segs - np.array([x, y])
    # into the robot frame: x forward, y left
    p = np.stack([c * rel[..., 0] + s * rel[..., 1],
                  -s * rel[..., 0] + c * rel[..., 1]], axis=-1)
    p0 = p[None, :, 0, :]                       # (1, S, 2)
    e = (p[:, 1, :] - p[:, 0, :])[None]         # (1, S, 2)
    width = 2 * math.pi / bins
    centre = np.arange(bins) * width
    a0, a1 = centre - width / 2, centre + width / 2
    u0 = np.stack([np.cos(a0), np.sin(a0)], -1)[:, None, :]   # (B, 1, 2)
    u1 = np.stack([np.cos(a1), np.sin(a1)], -1)[:, None, :]

    def cross(a, b):
        return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]

    t0 = np.zeros((bins, len(segs)))
    t1 = np.ones((bins, len(segs)))
    # left of the ray at a0: cross(u0, P(t)) >= 0; right of a1:
    # cross(P(t), u1) >= 0; each is f + t g >= 0
    for f, g in ((cross(u0, p0), cross(u0, e)),
                 (cross(p0, u1), cross(e, u1))):
        with np.errstate(divide="ignore", invalid="ignore"):
            root = -f / g
        t0 = np.where(g > 0, np.maximum(t0, root), t0)
        t1 = np.where(g < 0, np.minimum(t1, root), t1)
        # parallel to the ray: all in or all out
        t1 = np.where((g == 0) & (f < 0), -1.0, t1)
    ee = np.einsum("...i,...i", e, e)
    with np.errstate(divide="ignore", invalid="ignore"):
        tstar = -np.einsum("...i,...i", p0, e) / ee
    tstar = np.clip(np.nan_to_num(tstar), t0, t1)
    pts = p0 + tstar[..., None] * e
    d = np.hypot(pts[..., 0], pts[..., 1])
    d = np.where(t0 <= t1, d, np.inf)
    return d.min(axis=1)
