"""Named scenarios: a world, a camera path and a frame count each.

``build_scenario(name, seed, frames, size, robot, variant, **overrides)``
returns ``(scene, frames)``; the overrides are listed in ``OVERRIDES``.

Two robots: ``seed`` (the default), a small robot's 54-degree webcam
0.2 m above the floor tilted 18 degrees down, with 10 cm discs and 8 cm
balls; and ``comfortable``, the wide-angle camera half a metre up with
30 cm discs each scenario had before (its figures are the ones the
regression clips and the demo were made with).  ``variant`` (a dict from
``variants.draw_variant``) replaces the robot's camera, marker sizes,
floor, light, photometry, layout and path.
"""

import dataclasses
import json
import math

import numpy as np

from .. import reference

from .camera import Camera, Pose, wrap_angle
from .floors import FLOOR_NAMES
from .world import (Distractor, Effects, Landmark, Obstacle, Scene,
                    Segment, Walls, load_map, marker_palette)

CAMERA_KEYS = ("hfov_deg", "fx", "fy", "cx", "cy", "height_m", "tilt_deg",
               "roll_deg")
EFFECT_KEYS = tuple(Effects().__dict__)
OVERRIDES = CAMERA_KEYS + EFFECT_KEYS + (
    "fps", "floor", "walls", "palette", "supersample", "map", "poses",
    "pose", "obstacles")


# -- camera paths ------------------------------------------------------------

class Static:
    """The robot stands still."""

    def __init__(self, x=0.0, y=0.0, heading=0.0):
        self.start = Pose(x, y, heading)

    def pose(self, t):
        return self.start

    def to_json(self):
        return {"type": "static", **self.start.to_json()}


class Loop:
    """A closed smooth curve driven at constant speed, heading along the
    tangent (counter-clockwise): x = cx + a cos s - c cos 3s,
    y = cy + b sin s + c sin 3s (c > 0 squares it off), one lap per
    ``period_s``."""

    def __init__(self, centre, a, b, c, period_s, phase=0.0):
        self.centre = tuple(centre)
        self.a, self.b, self.c, self.period_s = a, b, c, period_s
        # where on the lap the clip starts, a fraction of a lap
        self.phase = float(phase)
        # arc length along s, for constant speed
        s = np.linspace(0.0, 2.0 * math.pi, 4097)
        x, y = self._xy(s)
        steps = np.hypot(np.diff(x), np.diff(y))
        self._s = s
        self._arc = np.concatenate([[0.0], np.cumsum(steps)])
        self.length = float(self._arc[-1])

    def _xy(self, s):
        return (self.centre[0] + self.a * np.cos(s) - self.c * np.cos(3 * s),
                self.centre[1] + self.b * np.sin(s) + self.c * np.sin(3 * s))

    def point(self, s):
        """(x, y, heading) at curve parameter s."""
        x, y = self._xy(s)
        dx = -self.a * math.sin(s) + 3 * self.c * math.sin(3 * s)
        dy = self.b * math.cos(s) + 3 * self.c * math.cos(3 * s)
        return float(x), float(y), math.atan2(dy, dx)

    def pose(self, t):
        lap = (t / self.period_s + self.phase) % 1.0
        s = float(np.interp(lap * self.length, self._arc, self._s))
        x, y, heading = self.point(s)
        return Pose(x, y, wrap_angle(heading))

    def to_json(self):
        extra = {"phase": self.phase} if self.phase else {}
        return {"type": "loop", "centre": list(self.centre), "a": self.a,
                "b": self.b, "c": self.c, "period_s": self.period_s,
                **extra,
                "length_m": round(self.length, 4),
                "speed_m_s": round(self.length / self.period_s, 4)}


class Sweep:
    """Creep forward along ``heading`` at ``speed`` m/s while the heading
    swings by +-``amplitude`` rad with ``period_s``."""

    def __init__(self, x, y, heading, speed, amplitude, period_s):
        self.x, self.y, self.heading = x, y, heading
        self.speed, self.amplitude, self.period_s = speed, amplitude, \
            period_s

    def pose(self, t):
        return Pose(self.x + self.speed * t * math.cos(self.heading),
                    self.y + self.speed * t * math.sin(self.heading),
                    wrap_angle(self.heading + self.amplitude * math.sin(
                        2 * math.pi * t / self.period_s)))

    def to_json(self):
        return {"type": "sweep", "x": self.x, "y": self.y,
                "heading": self.heading, "speed": self.speed,
                "amplitude": self.amplitude, "period_s": self.period_s}


class Keyframes:
    """Scripted poses, one per frame, linearly interpolated in between."""

    def __init__(self, poses, fps):
        if not poses:
            raise ValueError("no poses")
        self.poses = [p if isinstance(p, Pose) else Pose(*p) for p in poses]
        self.fps = fps

    def pose(self, t):
        f = min(max(t * self.fps, 0.0), len(self.poses) - 1)
        i = min(int(math.floor(f)), len(self.poses) - 1)
        j = min(i + 1, len(self.poses) - 1)
        a, b, k = self.poses[i], self.poses[j], f - i
        turn = wrap_angle(b.heading - a.heading)
        return Pose(a.x + k * (b.x - a.x), a.y + k * (b.y - a.y),
                    wrap_angle(a.heading + k * turn))

    def to_json(self):
        return {"type": "keyframes", "fps": self.fps,
                "poses": [p.to_json() for p in self.poses]}


def load_poses(path):
    """Poses from a JSON list or JSON-lines file of {"x", "y", "heading"}
    (heading in radians)."""
    with open(path, encoding="utf-8") as f:
        text = f.read()
    try:
        items = json.loads(text)
        if isinstance(items, dict):
            items = items.get("poses", [items])
    except json.JSONDecodeError:
        items = [json.loads(line) for line in text.splitlines()
                 if line.strip()]
    poses = []
    for i, item in enumerate(items):
        if isinstance(item, dict) and "robot" in item:
            item = item["robot"]       # a truth.jsonl line works too
        try:
            poses.append(Pose(float(item["x"]), float(item["y"]),
                              float(item["heading"])))
        except (KeyError, TypeError, ValueError):
            raise ValueError(f"{path}: pose {i}: expected an object with "
                             f"\"x\", \"y\", \"heading\"") from None
    return poses


# -- helpers -------------------------------------------------------------

def _colours(palette):
    # scenarios pick colours by index, so any marker palette works
    return palette.names


def _polar(r, bearing_deg):
    """World point at range r and bearing from a robot at the origin
    facing +x."""
    a = math.radians(bearing_deg)
    return r * math.cos(a), r * math.sin(a)


def _field_walls(scene, spec, margin=1.0):
    """Walls from an override: True = around everything, plus margin."""
    if spec is None or spec is False:
        return None
    if isinstance(spec, Walls):
        return spec
    xs = [lm.x for lm in scene.landmarks] + [0.0]
    ys = [lm.y for lm in scene.landmarks] + [0.0]
    return Walls(min(xs) - margin, min(ys) - margin, max(xs) + margin,
                 max(ys) + margin)


# -- robots ------------------------------------------------------------------

# The seed's robot: a 640x480 webcam with a 54-degree horizontal field of
# view, 0.2 m above the floor, tilted 18 degrees down (it sees the floor
# from 0.25 m), with 10 cm discs and 8 cm balls.  A 10 cm disc covers
# 113 px out to about 1.7 m, an 8 cm ball out to about 4 m.
SEED_CAMERA = {"hfov_deg": 54.0, "height_m": 0.2, "tilt_deg": 18.0}
SEED_DISC_D, SEED_BALL_D = 0.10, 0.08
ROBOTS = ("seed", "comfortable")
DEFAULT_ROBOT = "seed"


def _sizes(ctx, disc, ball):
    """Disc and ball diameters: the variant's, the seed robot's, or the
    scenario's own (comfortable)."""
    variant = ctx["variant"]
    if variant is not None:
        return variant["markers"]["disc_d"], variant["markers"]["ball_d"]
    if ctx["robot"] == "seed":
        return SEED_DISC_D, SEED_BALL_D
    return disc, ball


def _layout(ctx):
    """The variant's layout parameters, or None."""
    variant = ctx["variant"]
    return None if variant is None else variant["layout"]


# -- scenarios ---------------------------------------------------------------

RANGES = (0.3, 0.4, 0.5, 0.6, 0.8, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0)
# the seed robot sees markers from 0.3 to about 4 m
SEED_RANGES = RANGES[:-1]
BEARINGS = (-20, -10, 0, 10, 20)
# Markers of a size a robot sees across a room (the path scenario's), and
# a camera that sees both the floor 0.22 m ahead of its foot and the far
# end: half a metre up, wide-angle, tilted 34 degrees down. Discs are
# found from 0.4 m (at 0.3 m a 0.30 m disc reaches under the bottom row)
# to 4 m, balls from 0.3 to 5 m.
DISC_D, BALL_D = 0.30, 0.20
RANGE_CAMERA = {"hfov_deg": 80.0, "height_m": 0.5, "tilt_deg": 34.0}


def _camera_and_notes(ctx, comfortable_camera, purpose):
    """The scenario's camera (``comfortable_camera`` for the comfortable
    robot, the seed's otherwise) and the start of its notes."""
    camera = dict(comfortable_camera if ctx["robot"] == "comfortable"
                  else SEED_CAMERA)
    return camera, {"purpose": purpose, "camera_defaults": dict(camera)}


def _range_sweep(ctx):
    """One landmark per frame: discs then balls at ranges 0.3..5 m and
    bearings -20..20 degrees; static camera."""
    colours = _colours(ctx["palette"])
    disc_d, ball_d = _sizes(ctx, DISC_D, BALL_D)
    ranges = RANGES if ctx["robot"] == "comfortable" else SEED_RANGES
    bearings = BEARINGS
    layout = _layout(ctx)
    if layout is not None:
        ranges = [round(r * (1.0 + j), 4)
                  for r, j in zip(ranges, layout["range_jitter"])]
        bearings = [b + layout["bearing_shift_deg"] for b in BEARINGS]
    items = [(kind, r, b) for kind in ("disc", "ball") for r in ranges
             for b in bearings]
    frames = ctx["frames"] or len(items)
    # a short clip still spans the whole sweep
    if frames < len(items):
        chosen = np.unique(np.linspace(0, len(items) - 1, frames)
                           .round().astype(int))
        order = [items[i] for i in chosen]
    else:
        order = items
    intervals = {}
    for f in range(frames):
        intervals.setdefault(f % len(order), []).append((f, f))
    landmarks = []
    for i, (kind, r, b) in enumerate(order):
        x, y = _polar(r, b)
        landmarks.append(Landmark(
            id=f"{kind}_{r:.2f}m_{b:+g}deg", cls=colours[i % len(colours)],
            x=x, y=y, diameter=disc_d if kind == "disc" else ball_d,
            kind=kind, frames=intervals.get(i, [])))
    camera, notes = _camera_and_notes(
        ctx, RANGE_CAMERA,
        "ranging accuracy by distance: one disc or ball per frame")
    notes.update(disc_diameter_m=disc_d, ball_diameter_m=ball_d)
    return dict(landmarks=landmarks, floor="grey", trajectory=Static(),
                camera=camera, notes=notes), frames


# The path scenario is the benchmark for positioning from landmarks, so
# its camera is a small robot's: a wide-angle camera half a metre up,
# looking a little down, and landmarks large enough for it to see from
# across the field.
PATH_CAMERA = {"hfov_deg": 80.0, "height_m": 0.5, "tilt_deg": 20.0}
PATH_DISC_D, PATH_BALL_D = 0.30, 0.20
# Landmarks around the field's edge, at least 0.4 m from the loop and
# 0.7 m from each other, placed by a search so that three or more show
# (each >= 150 px) in most frames at the default camera, a few one or
# two: (x, y), colour index, kind.  Colours 0, 1 and 2 are used twice,
# each pair far apart, so data association needs the geometry.
PATH_PLAN = [((5.40, 3.55), 0, "disc"), ((2.95, 5.30), 1, "disc"),
             ((1.20, 4.00), 2, "disc"), ((0.40, 4.00), 3, "ball"),
             ((0.70, 2.55), 4, "disc"), ((2.85, 0.95), 0, "disc"),
             ((4.80, 2.00), 1, "disc"), ((5.50, 1.95), 2, "ball")]


# The seed robot's camera sees a narrow cone (54 degrees) and its 10 cm
# discs cover 113 px only out to 1.7 m, so its field is smaller (2.5 m)
# and denser: 16 landmarks around the walls, each colour three or four
# times, in plan units of a 6 m field: three or more landmarks of 113 px
# or more, whole, in about a third of the frames.
SEED_FIELD_M = 2.5
FIELD_M = 6.0
SEED_PATH_PLAN = [
    ((x, y), i % 5, "ball" if i % 3 == 2 else "disc")
    for i, (x, y) in enumerate(
        [p for y in (0.9, 2.0, 3.0, 4.0, 5.1) for p in ((0.5, y), (5.5, y))]
        + [p for x in (1.8, 3.0, 4.2) for p in ((x, 0.6), (x, 5.4))])]


def _path(ctx):
    """Landmarks around a square walled field (8 in 6 m for the
    comfortable robot, 16 in 2.5 m for the seed's); the robot drives a
    smooth 10 s elliptical loop (0.63 x 0.33 of the field)
    counter-clockwise."""
    colours = _colours(ctx["palette"])
    disc_d, ball_d = _sizes(ctx, PATH_DISC_D, PATH_BALL_D)
    layout = _layout(ctx)
    if ctx["robot"] == "comfortable" and layout is None:
        field_m = FIELD_M
        loop = Loop((3.0, 3.0), 1.9, 1.0, 0.0, period_s=10.0)
        plan = PATH_PLAN
        walls = Walls()
    else:
        field_m = SEED_FIELD_M if layout is None else layout["field_m"]
        k = field_m / FIELD_M
        half = field_m / 2.0
        a, b, c = 1.9 * k, 1.0 * k, 0.0
        turn, mirror = 0, False
        jitter = [(0.0, 0.0)] * len(SEED_PATH_PLAN)
        if layout is not None:
            a *= layout["loop_a"]
            b *= layout["loop_b"]
            c = layout["loop_c"] * k
            turn, mirror = layout["plan_turn"], layout["plan_mirror"]
            jitter = layout["plan_jitter"]
        loop = Loop((half, half), a, b, c, period_s=10.0,
                    phase=0.0 if layout is None else layout["loop_phase"])
        plan = []
        for ((x, y), colour, kind), (jx, jy) in zip(SEED_PATH_PLAN,
                                                    jitter):
            # the plan about the field's centre: quarter turns, a mirror
            dx, dy = x - 3.0, y - 3.0
            if mirror:
                dy = -dy
            for _ in range(turn % 4):
                dx, dy = -dy, dx
            plan.append(((round(half + k * (dx + jx), 4),
                          round(half + k * (dy + jy), 4)), colour, kind))
        walls = Walls(0.0, 0.0, field_m, field_m,
                      height=max(0.25, 0.5 * k))
    landmarks = [
        Landmark(id=f"L{i + 1}", cls=colours[colour % len(colours)],
                 x=x, y=y, diameter=disc_d if kind == "disc"
                 else ball_d, kind=kind)
        for i, ((x, y), colour, kind) in enumerate(plan)]
    camera, notes = _camera_and_notes(
        ctx, PATH_CAMERA,
        "benchmark of positioning from landmarks: most frames show three "
        "or more landmarks, the others one or two")
    notes.update({
        "camera_why": "a small robot's wide-angle camera, 0.5 m up and "
                      "tilted 20 degrees down, sees the floor from 0.4 m "
                      "to the far side of the field"
        if ctx["robot"] == "comfortable" else
        "the seed's robot: a 54-degree webcam 0.2 m up, tilted 18 "
        "degrees down, sees the floor from 0.25 m",
        "disc_diameter_m": disc_d,
        "ball_diameter_m": ball_d,
        "layout": "landmarks near the walls, the loop inside them; "
                  "colours used twice are far apart",
    })
    if plan is not PATH_PLAN:
        notes["layout"] = ("landmarks near the walls, the loop inside "
                           "them; each colour three or four times")
    if field_m != FIELD_M:
        notes["field_m"] = field_m
    return dict(landmarks=landmarks, floor="grey", walls=walls,
                trajectory=loop, camera=camera,
                notes=notes), ctx["frames"] or 300


def _few_landmarks(colours, disc_d=0.12, ball_d=0.07):
    spots = [(0.75, 18, "disc"), (0.85, -14, "disc"), (1.15, 2, "disc"),
             (1.5, 16, "disc"), (1.6, -15, "disc"), (1.05, 25, "ball")]
    out = []
    for i, (r, b, kind) in enumerate(spots):
        x, y = _polar(r, b)
        out.append(Landmark(id=f"L{i + 1}", cls=colours[i % len(colours)],
                            x=x, y=y, diameter=disc_d if kind == "disc"
                            else ball_d, kind=kind))
    return out


def _backgrounds(ctx):
    """The same landmarks over every floor in turn, then an exposure and
    white-balance ramp; auto exposure / white balance partly on."""
    colours = _colours(ctx["palette"])
    frames = ctx["frames"] or 96
    seg = max(1, int(round(frames / 12)))
    segments = [Segment(k * seg, name) for k, name in enumerate(FLOOR_NAMES)]
    segments.append(Segment(len(FLOOR_NAMES) * seg, "grey",
                            exposure_stops=(-1.0, 0.8),
                            wb_gains=((0.8, 1.25), (1.25, 0.8))))
    return dict(landmarks=_few_landmarks(colours,
                                         *_sizes(ctx, 0.12, 0.07)),
                segments=segments,
                floor=FLOOR_NAMES[0], trajectory=Static(),
                effects=dict(auto_exposure=0.5, auto_wb=0.3)), frames


def _scatter(rng, count, occupied, radius_of, region):
    """Up to ``count`` random non-overlapping spots in ``region`` (range
    and bearing limits), clear of the circles in ``occupied``."""
    r0, r1, half_angle = region
    out = []
    for _ in range(count * 40):
        if len(out) == count:
            break
        radius = radius_of()
        # uniform in range: near ground is as busy as far ground
        r = rng.uniform(r0, r1)
        x, y = _polar(r, rng.uniform(-half_angle, half_angle))
        if all(math.hypot(x - ox, y - oy) > radius + orad + 0.03
               for ox, oy, orad in occupied):
            occupied.append((x, y, radius))
            out.append((x, y, radius))
    return out


def _distractors(ctx):
    """Landmarks among non-round patches of the same colours and specks."""
    colours = _colours(ctx["palette"])
    layout = _layout(ctx)
    rng = np.random.default_rng(
        [ctx["seed"], 4242] if layout is None
        else [ctx["seed"], 4242, layout["seed"]])
    frames = ctx["frames"] or 60
    spots = [(0.8, 17, "disc"), (1.1, -15, "disc"), (1.7, 16, "disc"),
             (2.1, -17, "disc"), (2.6, 2, "disc"), (1.3, 2, "ball")]
    disc_d, ball_d = _sizes(ctx, 0.12, 0.07)
    region = (0.35, 3.5, 45.0)
    size_scale = 1.0
    if layout is not None or ctx["robot"] != "comfortable":
        # the seed's camera sees less far: the field three quarters as
        # deep; a variant's also follows its marker size
        depth = 0.75 if layout is None else layout["range_scale"]
        shift = 0.0 if layout is None else layout["bearing_shift_deg"]
        spots = [(round(r * depth, 4), b + shift, kind)
                 for r, b, kind in spots]
        region = (0.28, round(3.5 * depth, 4), 45.0)
        if layout is not None:
            size_scale = layout["distractor_scale"]
    landmarks = []
    occupied = []
    for i, (r, b, kind) in enumerate(spots):
        x, y = _polar(r, b)
        d = disc_d if kind == "disc" else ball_d
        landmarks.append(Landmark(id=f"L{i + 1}",
                                  cls=colours[i % len(colours)], x=x, y=y,
                                  diameter=d, kind=kind))
        occupied.append((x, y, d / 2))
    distractors = []
    k = size_scale
    shapes = (("square", 14, lambda: k * rng.uniform(0.05, 0.14)),
              ("stripe", 10, lambda: k * rng.uniform(0.15, 0.45)),
              ("triangle", 12, lambda: k * rng.uniform(0.06, 0.15)),
              ("speck", 50, lambda: k * rng.uniform(0.004, 0.015)))
    for shape, count, size_of in shapes:
        sizes = []

        def radius_of():
            sizes.append(size_of())
            # the shape's circumscribed radius
            return sizes[-1] * (0.5 if shape in ("stripe", "speck")
                                else 0.71)
        spots = _scatter(rng, count, occupied, radius_of, region)
        for x, y, radius in spots:
            size = radius / (0.5 if shape in ("stripe", "speck") else 0.71)
            distractors.append(Distractor(
                cls=colours[int(rng.integers(len(colours)))], shape=shape,
                x=x, y=y, size=size,
                width=k * rng.uniform(0.015, 0.04) if shape == "stripe"
                else None,
                angle=rng.uniform(0, 2 * math.pi)))
    return dict(landmarks=landmarks, distractors=distractors, floor="grey",
                trajectory=Sweep(0.0, 0.0, 0.0, 0.0, 0.2,
                                 max(frames, 2) / ctx["fps"])), frames


def _edge_cases(ctx):
    """Cut by the border, very far, very near, one colour twice, a ball
    hiding part of a disc; the robot creeps forward and swings."""
    c = _colours(ctx["palette"])
    n = len(c)
    spec = [
        ("E1-twice-a", 0, 1.2, 0.0, 0.12, "disc"),
        ("E2-twice-b", 0, 2.0, 0.3, 0.12, "disc"),
        ("E3-occluder", 4, 0.9, -0.25, 0.08, "ball"),
        ("E4-occluded", 1, 1.02, -0.28, 0.14, "disc"),
        ("E5-far", 2, 7.0, 0.5, 0.2, "disc"),
        ("E6-far-ball", 3, 9.0, -0.8, 0.1, "ball"),
        ("E7-near", 3, 0.3, 0.05, 0.1, "disc"),
        ("E8-near-ball", 2, 0.42, -0.16, 0.065, "ball"),
        ("E9-edge", 1, 1.0, 0.62, 0.12, "disc"),
    ]
    if ctx["variant"] is not None:
        # a variant's markers, each case's size relative to the usual
        disc_d, ball_d = _sizes(ctx, 0.12, 0.08)
        spec = [(i, k, x, y, d * (disc_d / 0.12 if kind == "disc"
                                  else ball_d / 0.08), kind)
                for i, k, x, y, d, kind in spec]
    landmarks = [Landmark(id=i, cls=c[k % n], x=x, y=y, diameter=d,
                          kind=kind) for i, k, x, y, d, kind in spec]
    return dict(landmarks=landmarks, floor="grey",
                trajectory=Sweep(0.0, 0.0, 0.0, 0.1, 0.3, 3.0)), \
        ctx["frames"] or 90


def _custom(ctx):
    """Your map (``map``: file or list of Landmark) seen from scripted
    poses (``poses``: file or list) or one static ``pose``."""
    spec = ctx["overrides"].pop("map", None)
    if spec is None:
        raise ValueError("the custom scenario needs a map (--map FILE)")
    landmarks = (load_map(spec, ctx["palette"].names)
                 if isinstance(spec, str) else list(spec))
    poses = ctx["overrides"].pop("poses", None)
    pose = ctx["overrides"].pop("pose", None)
    if poses is not None:
        if isinstance(poses, str):
            poses = load_poses(poses)
        trajectory = Keyframes(poses, ctx["fps"])
        frames = ctx["frames"] or len(poses)
    else:
        trajectory = Static(*(pose or (0.0, 0.0, 0.0)))
        frames = ctx["frames"] or 30
    return dict(landmarks=landmarks, floor="grey",
                trajectory=trajectory), frames


SCENARIOS = {
    "range-sweep": _range_sweep,
    "path": _path,
    "backgrounds": _backgrounds,
    "distractors": _distractors,
    "edge-cases": _edge_cases,
    "custom": _custom,
}


class Offset:
    """A trajectory of the robot's turning centre with the camera
    ``forward`` metres ahead of it: poses are the camera's floor point
    (docs/conventions.md), which swings out on turns."""

    def __init__(self, inner, forward):
        self.inner, self.forward = inner, float(forward)
        self.period_s = getattr(inner, "period_s", None)

    def pose(self, t):
        p = self.inner.pose(t)
        return Pose(p.x + self.forward * math.cos(p.heading),
                    p.y + self.forward * math.sin(p.heading), p.heading)

    def to_json(self):
        return {**self.inner.to_json(), "camera_forward_m": self.forward}


# Boxes and walls keep at least this Delta E (CIE76: the Euclidean
# L*a*b* distance labsegment classifies by) from every colour of the floor
# and from every marker colour: the free floor is told from what stands on
# it by colour alone, so an obstacle of the floor's colour is not one.
OBSTACLE_MIN_DELTA_E = 25.0


def floor_colours_lab(scene):
    """(N, 3) L*a*b* of every colour the scene's floors are made of: each
    distinct texel colour of every floor texture (grout, plank joints,
    carpet fibres...) and each floor class's colour (the texture's
    mean)."""
    labs = []
    for name in scene.floor_names():
        tex = scene.floor_texture(name)
        texels = np.unique(tex.srgb8.reshape(-1, 3), axis=0)
        labs.append(reference.rgb_to_lab(texels.reshape(-1, 1, 3))
                    .reshape(-1, 3).astype(np.float64))
        labs.append(tex.mean_lab().reshape(1, 3))
    return np.concatenate(labs)


def _obstacle_colours_to_avoid(scene):
    """L*a*b* colours no box or wall may come within
    OBSTACLE_MIN_DELTA_E of: the floor's and every marker's."""
    markers = [reference.rgb_to_lab(np.array(
        scene.marker_srgb8()[n], np.uint8).reshape(1, 1, 3)).reshape(1, 3)
        for n in scene.palette.names]
    return np.concatenate([floor_colours_lab(scene)] + markers)


def _clear_colour(rng, avoid):
    """A random sRGB colour at least OBSTACLE_MIN_DELTA_E from every
    colour of ``avoid``, or None when 1000 draws found none."""
    for _ in range(1000):
        colour = tuple(int(c) for c in rng.integers(0, 256, 3))
        lab = reference.rgb_to_lab(np.array(colour, np.uint8)
                                   .reshape(1, 1, 3)).reshape(3)
        if np.min(np.linalg.norm(avoid - lab, axis=1)) >= \
                OBSTACLE_MIN_DELTA_E:
            return colour
    return None


def clear_walls(scene, seed=0):
    """The scene's walls repainted, when their colour is within
    OBSTACLE_MIN_DELTA_E of the floor's or a marker's, in a random colour
    that is not (fixed seed); unchanged otherwise."""
    walls = scene.walls
    if walls is None:
        return None
    avoid = _obstacle_colours_to_avoid(scene)
    lab = reference.rgb_to_lab(np.array(walls.colour, np.uint8)
                               .reshape(1, 1, 3)).reshape(3)
    if np.min(np.linalg.norm(avoid - lab, axis=1)) >= OBSTACLE_MIN_DELTA_E:
        return walls
    colour = _clear_colour(np.random.default_rng([int(seed), 7178]), avoid)
    if colour is None:
        raise ValueError("no wall colour is Delta E "
                         f"{OBSTACLE_MIN_DELTA_E:g} from the floor's")
    return dataclasses.replace(walls, colour=colour)


def place_obstacles(scene, count, frames, seed=0):
    """``count`` boxes at random in the walled field (or around the
    landmarks): footprints 0.1-0.4 m, 0.1-0.4 m tall, any angle, any
    colour at least OBSTACLE_MIN_DELTA_E (CIE76) from every colour of the
    floor texture and every marker's; none within 0.25 m of the camera's
    path (every frame's pose) or of a landmark, nor overlapping
    another."""
    rng = np.random.default_rng([int(seed), 7177])
    if scene.walls is not None:
        w = scene.walls
        x0, y0, x1, y1 = w.x0, w.y0, w.x1, w.y1
    else:
        xs = [lm.x for lm in scene.landmarks] or [0.0]
        ys = [lm.y for lm in scene.landmarks] or [0.0]
        x0, y0, x1, y1 = min(xs) - 1, min(ys) - 1, max(xs) + 1, max(ys) + 1
    path = np.array([(p.x, p.y) for p in (
        scene.trajectory.pose(f / scene.fps) for f in range(frames))]) \
        if scene.trajectory is not None else np.zeros((0, 2))
    keep = [np.array([lm.x, lm.y, lm.radius]) for lm in scene.landmarks]
    avoid = _obstacle_colours_to_avoid(scene)
    out = []
    for _ in range(count * 200):
        if len(out) == count:
            break
        sx, sy = rng.uniform(0.1, 0.4, 2)
        half = math.hypot(sx, sy) / 2
        x = rng.uniform(x0 + half, x1 - half)
        y = rng.uniform(y0 + half, y1 - half)
        if len(path) and np.min(np.hypot(path[:, 0] - x,
                                         path[:, 1] - y)) < half + 0.25:
            continue
        if any(math.hypot(k[0] - x, k[1] - y) < half + k[2] + 0.25
               for k in keep):
            continue
        if any(math.hypot(o.x - x, o.y - y) < half + math.hypot(
                o.size_x, o.size_y) / 2 for o in out):
            continue
        colour = _clear_colour(rng, avoid)
        if colour is None:
            continue
        out.append(Obstacle(round(float(x), 4), round(float(y), 4),
                            round(float(sx), 4), round(float(sy), 4),
                            round(float(rng.uniform(0.1, 0.4)), 4),
                            round(float(rng.uniform(0, math.pi)), 4),
                            colour))
    return out


def build_scenario(name, seed=0, frames=None, size=(640, 480),
                   robot=DEFAULT_ROBOT, variant=None, **overrides):
    """(Scene, frame count) of a named scenario with overrides.

    ``robot``: "seed" (default) or "comfortable" (see the module
    docstring); ``variant``: a dict from ``variants.draw_variant`` (its
    camera, sizes, floor, light, effects, layout and path; overrides
    still win)."""
    for what, value, known in (("scenario", name, SCENARIOS),
                               ("robot", robot, ROBOTS)):
        if value not in known:
            raise ValueError(f"unknown {what} {value!r}, expected one of "
                             f"{', '.join(known)}")
    unknown = set(overrides) - set(OVERRIDES)
    if unknown:
        raise ValueError(f"unknown override(s): {', '.join(sorted(unknown))}"
                         f" (known: {', '.join(OVERRIDES)})")
    overrides = {k: v for k, v in overrides.items() if v is not None}
    if frames is not None and frames < 1:
        raise ValueError("frames must be >= 1")
    width, height = size
    cam_args = {k: overrides.pop(k) for k in CAMERA_KEYS if k in overrides}
    palette = marker_palette(overrides.pop("palette", None))
    fps = int(overrides.pop("fps", 30))
    if fps < 1:
        raise ValueError("fps must be >= 1")
    ctx = {"seed": int(seed), "frames": frames, "palette": palette,
           "fps": fps, "overrides": overrides, "robot": robot,
           "variant": variant}
    parts, n_frames = SCENARIOS[name](ctx)
    # the robot's camera, the scenario's own, the variant's, then the
    # caller's settings
    base = dict(SEED_CAMERA) if robot == "seed" else {}
    base.update(parts.pop("camera", {}))
    if variant is not None:
        base = dict(variant["camera"])
    camera = Camera(width, height, **{**base, **cam_args})
    for key in ("map", "poses", "pose"):
        if key in overrides:
            raise ValueError(f"{key} only applies to the custom scenario")

    effects = Effects(**parts.pop("effects", {}))
    if variant is not None:
        for key, value in variant["effects"].items():
            setattr(effects, key, value)
        if isinstance(parts.get("trajectory"), (Loop, Sweep)):
            # the camera ahead of the turning centre swings out on turns
            parts["trajectory"] = Offset(parts["trajectory"],
                                         variant["forward_offset_m"])
        else:
            effects.motion_blur = 0      # a still camera blurs nothing
        if "segments" not in parts:
            red, blue = variant["white_balance"]
            parts["floor"] = variant["floor"]
            parts["segments"] = [Segment(0, variant["floor"], (0.0, 0.0),
                                         ((red, blue), (red, blue)))]
        parts["light"] = tuple(variant["light"]["direction"])
        notes = dict(parts.get("notes") or {})
        notes["variant"] = variant
        parts["notes"] = notes
    for key in EFFECT_KEYS:
        if key in overrides:
            setattr(effects, key, type(getattr(effects, key))(
                overrides.pop(key)))
    floor = overrides.pop("floor", None)
    if floor is not None:
        # one floor for the whole clip
        parts["floor"] = floor
        segments = parts.pop("segments", None)
        if segments:
            parts["segments"] = [Segment(s.from_frame, floor,
                                         s.exposure_stops, s.wb_gains)
                                 for s in segments]
    walls_spec = overrides.pop("walls", "default")
    n_obstacles = int(overrides.pop("obstacles", 0))
    if n_obstacles < 0:
        raise ValueError("obstacles must be >= 0")
    supersample = int(overrides.pop("supersample", 4))
    scene = Scene(camera=camera, palette=palette, fps=fps, seed=int(seed),
                  effects=effects, supersample=supersample, scenario=name,
                  **parts)
    if walls_spec != "default":
        if walls_spec is True and scene.walls is not None:
            pass
        else:
            scene = scene.with_(walls=_field_walls(scene, walls_spec))
    if n_obstacles:
        # walls the floor's colour would be floor: repainted in the
        # free-floor scenes only, so that scenes without boxes stay as
        # they were rendered
        scene = scene.with_(walls=clear_walls(scene, seed))
        scene = scene.with_(obstacles=place_obstacles(
            scene, n_obstacles, n_frames, seed))
    return scene, n_frames
