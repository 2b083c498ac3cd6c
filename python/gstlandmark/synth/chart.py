"""A colour chart: every class of the scene palette in one picture.

Frame 0 rarely shows every landmark colour, and a scene that changes
floors shows one floor at a time, so a palette learned from frame 0 alone
misses classes.  ``render_chart`` lays one disc of every marker colour on
the floor in front of the camera, one ball of every class the scene has
balls or coded-marker bands of (the scene's ball diameter, lit by the
scene's light: a flat disc cannot teach a ball's lit and shaded sides, nor
a beacon's), a square swatch of every
other floor texture among them and, when the scene has walls, a wall
behind them; it renders that with the scene's camera, frame 0's floor,
exposure, white balance, vignetting and noise, and returns a class mask
(values as ``mask0.png``: k = class k of the scene palette) that marks only
pixels wholly of one class, for ``gst-landmark palette learn --mask``.
"""

import math
import statistics

import numpy as np

from .camera import Pose
from .floors import srgb8_to_linear
from .render import FLOOR, Renderer, renderer
from .scenarios import Static
from .world import Landmark, Scene, Walls

# The chart's robot stands at the origin facing +x.
CHART_POSE = Pose(0.0, 0.0, 0.0)
# Items fill this fraction of their grid cell (width and height).
FILL = 0.65
# The chart starts where the floor is this near (metres), or as near as
# the camera sees it.
FAR_LIMIT = 3.0


def _floor_distance(camera, v):
    """Forward floor distance seen at image row ``v`` on the centre
    column from CHART_POSE, or None above the horizon."""
    rot, centre = camera.world_to_camera(CHART_POSE)
    d = camera.pixel_directions([camera.cx], [v])[0] @ rot
    if d[2] >= -1e-9:
        return None
    t = -centre[2] / d[2]
    return float(t * d[0]), float(t * d[1])


def _floor_rows(camera):
    """First image row (from the top) whose centre ray meets the floor
    within FAR_LIMIT (or at all), and the bottom row."""
    h = camera.height
    first = None
    for v in np.linspace(0.0, h - 1.0, 4 * h):
        hit = _floor_distance(camera, v)
        if hit is None or hit[0] <= 0:
            continue
        if first is None:
            first = float(v)
        if hit[0] <= FAR_LIMIT:
            return float(v), h - 1.0
    if first is None or first > 0.8 * h:
        raise ValueError("the camera sees too little floor for a colour "
                         "chart")
    return first, h - 1.0


def _back_project(camera, u, v):
    """World floor point (x, y) seen at pixel (u, v), and the camera
    depth and the ray's elevation below the horizon there."""
    rot, centre = camera.world_to_camera(CHART_POSE)
    cam_dir = camera.pixel_directions([u], [v])[0]
    d = cam_dir @ rot
    if d[2] >= -1e-9:
        return None
    t = -centre[2] / d[2]
    depth = t * cam_dir[2]
    sin_elev = -d[2] / np.linalg.norm(d)
    return centre[0] + t * d[0], centre[1] + t * d[1], depth, sin_elev


def _projected_size(camera, x, y, r):
    """Width and height in pixels of the image of a floor disc."""
    a = np.linspace(0.0, 2.0 * math.pi, 64, endpoint=False)
    pts = np.stack([x + r * np.cos(a), y + r * np.sin(a),
                    np.zeros_like(a)], axis=1)
    uv, _ = camera.project(pts, CHART_POSE)
    return np.ptp(uv[:, 0]), np.ptp(uv[:, 1])


def grid(camera, count, walls, ball_row=False):
    """Grid cells for ``count`` items on the floor in view: their centre
    pixels (u, v), the cell width and height in pixels, and the forward
    distance of the chart's back wall (None without walls).  With
    ``ball_row`` the top row of cells is left free (for balls) and the
    cells start one row lower."""
    top, bottom = _floor_rows(camera)
    wall_x = None
    if walls:
        # the back wall's foot a quarter of the way down the floor
        foot = top + 0.25 * (bottom - top)
        wall_x = _floor_distance(camera, foot)[0]
        top = foot + 0.04 * camera.height
    height = bottom - top
    width = float(camera.width)
    cols = max(1, int(math.ceil(math.sqrt(count * width / height))))
    rows = int(math.ceil(count / cols))
    cols = int(math.ceil(count / rows))
    cell_w, cell_h = width / cols, height / (rows + ball_row)
    centres = []
    for k in range(count):
        row, col = divmod(k, cols)
        row += ball_row
        centres.append(((col + 0.5) * cell_w - 0.5,
                        top + (row + 0.5) * cell_h))
    return centres, (cell_w, cell_h), wall_x


def fit_disc(camera, u, v, cell_size):
    """The floor disc (x, y, radius) seen at pixel (u, v) whose image
    fills FILL of a cell of ``cell_size`` (width, height) pixels."""
    cell_w, cell_h = cell_size
    hit = _back_project(camera, u, v)
    if hit is None:
        raise ValueError("colour chart: a cell above the horizon")
    x, y, depth, sin_elev = hit
    # first guess: the projected disc is about 2 r f / depth wide and
    # that times sin(elevation) high; then fit its real outline
    r = 0.5 * FILL * min(cell_w * depth / camera.fx,
                         cell_h * depth / (camera.fy
                                           * max(sin_elev, 1e-3)))
    for _ in range(3):
        w, h = _projected_size(camera, x, y, r)
        if not (np.isfinite(w) and np.isfinite(h) and w > 0 < h):
            r *= 0.5          # part of it behind the camera
            continue
        r *= min(FILL * cell_w / w, FILL * cell_h / h)
    return float(x), float(y), float(r)


def layout(camera, count, walls):
    """Grid cells for ``count`` items on the floor in view: a list of
    (x, y, radius) world discs, and the forward distance of the chart's
    back wall (None without walls)."""
    centres, cell_size, wall_x = grid(camera, count, walls)
    return [fit_disc(camera, u, v, cell_size) for u, v in centres], wall_x


def ball_classes(scene):
    """(class, diameter) of one chart ball per marker class the scene has
    balls or coded-marker bands of, in palette order; the diameter is one
    the class's balls (else its coded markers) have (the median one). A
    band on an upright cylinder or cone is shaded as a ball's side is,
    which a flat disc cannot teach (docs/beacons.md)."""
    out = []
    for name in scene.palette.names:
        sizes = sorted(lm.diameter for lm in scene.landmarks
                       if lm.kind == "ball" and lm.cls == name) or sorted(
            lm.diameter for lm in scene.landmarks
            if lm.coded and name in lm.bands)
        if sizes:
            out.append((name, statistics.median_low(sizes)))
    return out


def _ball_at(camera, u, v, radius):
    """Centre (x, y) of a ball of ``radius`` standing on the floor point
    seen at pixel (u, v), and its image diameter in pixels (infinite when
    it is too near to fit in view).  None above the horizon."""
    hit = _back_project(camera, u, v)
    if hit is None:
        return None
    x, y = hit[0], hit[1]
    _, depth = camera.project(np.array([[x, y, radius]]), CHART_POSE)
    depth = float(depth[0])
    size = 2.0 * camera.fx * radius / depth if depth > 2.0 * radius \
        else math.inf
    return x, y, size


def _push_back(camera, x, y, radius, target):
    """Move a ball at (x, y) straight away from the camera until its image
    is about ``target`` pixels wide (its top nearer the horizon, over the
    far floor)."""
    _, centre = camera.world_to_camera(CHART_POSE)
    for _ in range(6):
        _, depth = camera.project(np.array([[x, y, radius]]), CHART_POSE)
        # a ball nearer than its own diameter: at least double the way
        scale = (2.0 * camera.fx * radius / float(depth[0]) / target
                 if depth[0] > 2.0 * radius else 2.0)
        x = centre[0] + (x - centre[0]) * scale
        y = centre[1] + (y - centre[1]) * scale
    return x, y


def place_balls(camera, cells, cell_size, balls):
    """Give every (class, diameter) of ``balls`` the grid cell its ball
    fills most while fitting FILL of it.  ``cells`` are centre pixels (u,
    v).  Returns the balls' (x, y, diameter) in order and the indices of
    the cells left for the discs and swatches, or None when a ball fits no
    cell."""
    cell_w, cell_h = cell_size
    target = FILL * min(cell_w, cell_h)
    free = list(range(len(cells)))
    placed = []
    for _, diameter in balls:
        best = None
        for k in free:
            hit = _ball_at(camera, *cells[k], diameter / 2.0)
            if hit is not None and hit[2] <= target and (
                    best is None or hit[2] > best[0]):
                best = (hit[2], k, hit[0], hit[1])
        if best is None:
            return None
        _, k, x, y = best
        free.remove(k)
        placed.append((float(x), float(y), float(diameter)))
    return placed, free


def ball_row(camera, v, cell_h, balls):
    """Balls side by side across the free top row of a grid (``grid(...,
    ball_row=True)``, centred on image row ``v``), each one standing as
    far back as it must for its image to fill at most FILL of its share of
    the row.  Returns their (x, y, diameter)."""
    share = camera.width / len(balls)
    target = FILL * min(share, cell_h)
    placed = []
    for j, (_, diameter) in enumerate(balls):
        hit = _ball_at(camera, (j + 0.5) * share - 0.5, v, diameter / 2.0)
        if hit is None:
            raise ValueError("colour chart: no room for a ball")
        x, y, size = hit
        if size > target:
            x, y = _push_back(camera, x, y, diameter / 2.0, target)
        placed.append((float(x), float(y), float(diameter)))
    return placed


def render_chart(scene, frames_total=None):
    """(rgb uint8 (H, W, 3), mask uint8 (H, W), info dict) of the scene's
    colour chart under frame 0's conditions.  ``info["pixels"]`` counts
    the masked pixels of every class."""
    names = scene.scene_palette().names
    markers = scene.palette.names
    floor0, stops0, wb0 = scene.segment_state(0, frames_total)
    # frame 0's exposure and white balance, auto ones included
    base = renderer(scene)
    trajectory = scene.trajectory or Static()
    lin0, _ = base.linear(trajectory.pose(0.0), 0.0, 0,
                          scene.floor_texture(floor0))
    gains = base.gains(lin0, 0.0, stops0, wb0)

    swatches = [f for f in scene.floor_names() if f != floor0]
    # a square of each obstacle colour too, flat on the floor
    boxes = scene.obstacle_colours()
    balls = ball_classes(scene)
    flat = len(markers) + len(swatches) + len(boxes)
    has_walls = scene.walls is not None
    centres, cell_size, wall_x = grid(scene.camera, flat + len(balls),
                                      has_walls)
    fitted = place_balls(scene.camera, centres, cell_size, balls)
    if fitted is None:
        # balls too big for a cell: a row of their own at the back
        centres, cell_size, wall_x = grid(scene.camera, flat, has_walls,
                                          ball_row=True)
        fitted = (ball_row(scene.camera, centres[0][1] - cell_size[1],
                           cell_size[1], balls), range(flat))
    placed, free = fitted
    if wall_x is not None and placed:
        # the back wall stands behind the balls
        wall_x = max([wall_x] + [x + d for x, _, d in placed])
    cells = [fit_disc(scene.camera, *centres[k], cell_size) for k in free]
    discs = [Landmark(f"chart-{name}", name, x, y, 2.0 * r)
             for name, (x, y, r) in zip(markers, cells)]
    discs += [Landmark(f"chart-{name}-ball", name, x, y, d, kind="ball")
              for (name, _), (x, y, d) in zip(balls, placed)]
    walls = None
    if scene.walls is not None:
        walls = Walls(-100.0, -100.0, wall_x, 100.0, scene.walls.height,
                      scene.walls.colour)
    chart = Scene(camera=scene.camera, landmarks=discs, floor=floor0,
                  walls=walls, effects=scene.effects, palette=scene.palette,
                  fps=scene.fps, seed=scene.seed,
                  supersample=scene.supersample, sky_colour=scene.sky_colour,
                  light=scene.light, scenario=f"{scene.scenario} chart")
    # the scene's own floor textures (same seed, already built)
    chart._cache[("floor", floor0)] = scene.floor_texture(floor0)
    tracer = Renderer(chart)
    lin, geo = tracer.trace(CHART_POSE, scene.floor_texture(floor0))

    # chart classes -> scene palette values; mixed pixels -> 0
    chart_names = chart.scene_palette().names
    remap = np.zeros(len(chart_names) + 1, np.uint8)
    for k, name in enumerate(chart_names, start=1):
        if name == "floor":
            name = scene.floor_class_name(floor0)
        remap[k] = names.index(name) + 1
    mask = remap[geo["mask"]]
    mask[~geo["pure"]] = 0

    if swatches or boxes:
        cam = scene.camera
        rot, centre = cam.world_to_camera(CHART_POSE)
        dirs = tracer.pix_dirs @ rot.astype(np.float32)
        t_floor, ids, _ = tracer._static_hits(dirs, centre)
        x = np.float32(centre[0]) + t_floor * dirs[:, 0]
        y = np.float32(centre[1]) + t_floor * dirs[:, 1]
        flat = mask.reshape(-1)
        floor_value = names.index(scene.floor_class_name(floor0)) + 1
        for name, (cx, cy, r) in zip(swatches, cells[len(markers):]):
            # a square of that floor, its pixels whole (hard edges)
            inside = ((ids == FLOOR) & (flat == floor_value)
                      & (np.abs(x - cx) <= r) & (np.abs(y - cy) <= r))
            sel = np.flatnonzero(inside)
            lin[sel] = tracer._floor_colour(
                scene.floor_texture(name), dirs[sel], t_floor[sel], centre,
                1.0)
            flat[sel] = names.index(scene.floor_class_name(name)) + 1
        for colour, (cx, cy, r) in zip(
                boxes, cells[len(markers) + len(swatches):]):
            inside = ((ids == FLOOR) & (flat == floor_value)
                      & (np.abs(x - cx) <= r) & (np.abs(y - cy) <= r))
            sel = np.flatnonzero(inside)
            lin[sel] = srgb8_to_linear(colour)
            flat[sel] = names.index(scene.obstacle_class_name(colour)) + 1
    rgb = base.finish(lin, gains, 0)
    counts = np.bincount(mask.ravel(), minlength=len(names) + 1)
    info = {"pose": CHART_POSE.to_json(), "floor": floor0,
            "wall_x": None if wall_x is None else round(wall_x, 4),
            "items": [{"class": name, "x": round(x, 4), "y": round(y, 4),
                       "size": round(2 * r, 4),
                       "shape": "disc" if name in markers else "square"}
                      for name, (x, y, r) in zip(
                          markers + [scene.floor_class_name(f)
                                     for f in swatches]
                          + [scene.obstacle_class_name(c) for c in boxes],
                          cells)]
            + [{"class": name, "x": round(x, 4), "y": round(y, 4),
                "size": round(d, 4), "shape": "ball"}
               for (name, _), (x, y, d) in zip(balls, placed)],
            "pixels": {name: int(counts[k])
                       for k, name in enumerate(names, start=1)}}
    missing = [name for name, n in info["pixels"].items() if n == 0]
    if missing:
        raise ValueError(f"colour chart: no pixels of {', '.join(missing)} "
                         f"(camera sees too little floor)")
    return rgb, mask, info
