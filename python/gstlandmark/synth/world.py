"""The synthetic world: landmarks, distractors, floor, walls, effects and
the scene palette that names every colour in it."""

from dataclasses import dataclass, field, replace
import math
from typing import List, Optional, Sequence, Tuple

import numpy as np

from .. import reference
from ..landmarkmap import CODED_KINDS, check_band_classes, parse_map, \
    read_map
from ..palette import (Palette, PaletteClass, default_palette,
                                 load_palette, parse_palette)

from .camera import Camera
from .floors import FLOORS, FloorTexture

KINDS = ("disc", "ball") + CODED_KINDS
SHAPES = ("square", "stripe", "triangle", "speck")


def _present(frames, frame):
    """Whether ``frame`` lies in one of the inclusive [first, last]
    intervals (None = always)."""
    if frames is None or frame is None:
        return True
    return any(first <= frame <= last for first, last in frames)


@dataclass
class Landmark:
    """A map landmark.  ``z`` defaults to 0 for a disc and the radius for
    a ball; ``frames`` lists inclusive [first, last] frame intervals in
    which it exists (None: always).

    A coded marker (``kind`` beacon, post or cone; docs/beacons.md) stands
    upright on the floor: ``cls`` is its code, its band classes joined by
    "/" top first (``"pink/yellow"``), ``x, y`` its axis, ``z`` its
    base's height (default 0), ``diameter`` the cylinder's or the cone's
    base, ``height`` metres, ``band_heights`` metres top first (default:
    equal bands)."""

    id: str
    cls: str
    x: float
    y: float
    diameter: float
    kind: str = "disc"
    z: Optional[float] = None
    frames: Optional[Sequence[Tuple[int, int]]] = None
    height: Optional[float] = None
    band_heights: Optional[Sequence[float]] = None

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"landmark {self.id}: kind must be one of "
                             f"{KINDS}, got {self.kind!r}")
        if not self.diameter > 0:
            raise ValueError(f"landmark {self.id}: diameter must be > 0")
        if self.z is None:
            self.z = (self.diameter / 2.0 if self.kind == "ball" else 0.0)
        if self.coded:
            # the map's own rules, and its equal bands by default
            marker = parse_map({"landmarks": [self.to_map()]})[0]
            self.band_heights = tuple(marker["band_heights"])

    @property
    def coded(self):
        return self.kind in CODED_KINDS

    @property
    def bands(self):
        """A coded marker's band classes, top first."""
        return tuple(self.cls.split("/")) if self.coded else ()

    @property
    def radius(self):
        return self.diameter / 2.0

    def present(self, frame):
        return _present(self.frames, frame)

    def to_map(self):
        out = {"id": self.id, "class": self.cls, "x": round(self.x, 6),
               "y": round(self.y, 6), "z": round(self.z, 6),
               "diameter": round(self.diameter, 6), "kind": self.kind}
        if self.coded:
            del out["class"]
            out["height"] = (round(self.height, 6) if self.height is not None
                             else None)
            out["bands"] = list(self.bands)
            if self.band_heights is not None:
                out["band-heights"] = [round(h, 6)
                                       for h in self.band_heights]
        return out


@dataclass
class Distractor:
    """A flat, non-landmark patch of a palette colour on the floor:
    ``square`` (side ``size``), ``stripe`` (``size`` long, ``width``
    wide), ``triangle`` (equilateral, side ``size``) or ``speck`` (a tiny
    disc of diameter ``size``); ``angle`` in radians."""

    cls: str
    shape: str
    x: float
    y: float
    size: float
    width: Optional[float] = None
    angle: float = 0.0
    frames: Optional[Sequence[Tuple[int, int]]] = None

    def __post_init__(self):
        if self.shape not in SHAPES:
            raise ValueError(f"distractor shape must be one of {SHAPES}, "
                             f"got {self.shape!r}")

    def present(self, frame):
        return _present(self.frames, frame)

    def polygon(self):
        """Counter-clockwise world vertices (N, 2); None for a speck."""
        if self.shape == "speck":
            return None
        if self.shape == "square":
            half = self.size / 2.0
            local = [(-half, -half), (half, -half), (half, half),
                     (-half, half)]
        elif self.shape == "stripe":
            hl, hw = self.size / 2.0, (self.width or self.size / 8) / 2.0
            local = [(-hl, -hw), (hl, -hw), (hl, hw), (-hl, hw)]
        else:
            r = self.size / math.sqrt(3.0)
            local = [(r * math.cos(a), r * math.sin(a))
                     for a in (0.0, 2 * math.pi / 3, 4 * math.pi / 3)]
        c, s = math.cos(self.angle), math.sin(self.angle)
        return np.array([(self.x + c * px - s * py, self.y + s * px + c * py)
                         for px, py in local])

    def to_json(self):
        out = {"class": self.cls, "shape": self.shape,
               "x": round(self.x, 6), "y": round(self.y, 6),
               "size": round(self.size, 6), "angle": round(self.angle, 6)}
        if self.shape == "stripe":
            out["width"] = round(self.width or self.size / 8, 6)
        if self.frames is not None:
            out["frames"] = [list(f) for f in self.frames]
        return out


@dataclass
class Walls:
    """Vertical walls on the border of the field [x0, x1] x [y0, y1]."""

    x0: float = 0.0
    y0: float = 0.0
    x1: float = 6.0
    y1: float = 6.0
    height: float = 0.5
    colour: Tuple[int, int, int] = (192, 186, 172)

    def to_json(self):
        return {"x0": self.x0, "y0": self.y0, "x1": self.x1, "y1": self.y1,
                "height": self.height, "colour_srgb": list(self.colour)}


@dataclass
class Obstacle:
    """A box standing on the floor: a footprint of ``size_x`` by ``size_y``
    metres centred at (``x``, ``y``), turned by ``angle`` (radians),
    ``height`` metres tall, of one sRGB ``colour``."""

    x: float
    y: float
    size_x: float
    size_y: float
    height: float = 0.3
    angle: float = 0.0
    colour: Tuple[int, int, int] = (150, 90, 60)

    def edges(self):
        """The footprint's 4 edges, (4, 2, 2) world metres."""
        from .freespace import rectangle_edges
        return rectangle_edges(self.x, self.y, self.size_x, self.size_y,
                               self.angle)

    def to_json(self):
        return {"x": round(self.x, 6), "y": round(self.y, 6),
                "size_x": round(self.size_x, 6),
                "size_y": round(self.size_y, 6),
                "height": round(self.height, 6),
                "angle": round(self.angle, 6),
                "colour_srgb": list(self.colour)}


@dataclass
class Effects:
    """Camera effects; every one is off at 0 except the defaults noted.

    noise_sigma: Gaussian sensor noise, 8-bit units (default 1.5, mild).
    ball_shading: 0 flat .. 1 full Lambert shading of balls (default 0.5).
    exposure_stops: constant exposure offset.
    exposure_drift_stops, wb_drift: amplitudes of slow sinusoidal drifts
        of exposure (stops) and white balance (relative red/blue gain),
        period ``drift_period_s``.
    auto_exposure, auto_wb: strength 0..1 of a grey-world auto exposure
        and white balance (colours then shift with the floor, as in the
        seed's table 3.1).
    vignette: relative darkening at the image corners.
    motion_blur: number of sub-frame renders averaged (0 or 1: off) over
        ``shutter`` of the frame interval.
    jpeg_quality: quality of the MJPEG clip.
    """

    noise_sigma: float = 1.5
    ball_shading: float = 0.5
    exposure_stops: float = 0.0
    exposure_drift_stops: float = 0.0
    wb_drift: float = 0.0
    drift_period_s: float = 8.0
    auto_exposure: float = 0.0
    auto_wb: float = 0.0
    vignette: float = 0.0
    motion_blur: int = 0
    shutter: float = 0.5
    jpeg_quality: int = 90

    def validate(self):
        """Raise ValueError for values no camera could have."""
        if not 0 <= self.jpeg_quality <= 100:
            raise ValueError(f"jpeg quality must be within 0..100, got "
                             f"{self.jpeg_quality}")
        for name in ("noise_sigma", "ball_shading", "auto_exposure",
                     "auto_wb", "vignette", "shutter", "motion_blur",
                     "drift_period_s"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must not be negative")
        for name in ("ball_shading", "auto_exposure", "auto_wb",
                     "vignette", "shutter"):
            if getattr(self, name) > 1:
                raise ValueError(f"{name} must be within 0..1")
        return self

    def to_json(self):
        return dict(self.__dict__)


@dataclass
class Segment:
    """From ``from_frame`` on (until the next segment): this floor and an
    exposure / white-balance ramp from the first value to the second over
    the segment (``wb_gains``: red and blue gains)."""

    from_frame: int
    floor: str
    exposure_stops: Tuple[float, float] = (0.0, 0.0)
    wb_gains: Tuple[Tuple[float, float], Tuple[float, float]] = (
        (1.0, 1.0), (1.0, 1.0))

    def to_json(self):
        return {"from_frame": self.from_frame, "floor": self.floor,
                "exposure_stops": list(self.exposure_stops),
                "wb_gains": [list(g) for g in self.wb_gains]}


def marker_palette(palette=None):
    """The marker classes of ``palette`` (a Palette, a file name, or None
    for the built-in palette), as a Palette."""
    if palette is None:
        palette = default_palette()
    elif not isinstance(palette, Palette):
        palette = load_palette(palette)
    markers = [c for c in palette.classes if c.marker]
    if not markers:
        raise ValueError("the palette has no marker classes")
    return Palette(markers)


@dataclass
class Scene:
    """Everything needed to render frames.  ``palette`` holds the landmark
    colours (marker classes; default: the built-in palette's markers);
    ``scene_palette()`` adds the floor and wall classes."""

    camera: Camera = field(default_factory=Camera)
    landmarks: List[Landmark] = field(default_factory=list)
    distractors: List[Distractor] = field(default_factory=list)
    obstacles: List[Obstacle] = field(default_factory=list)
    floor: str = "grey"
    segments: Optional[List[Segment]] = None
    walls: Optional[Walls] = None
    effects: Effects = field(default_factory=Effects)
    palette: Palette = field(default_factory=marker_palette)
    fps: int = 30
    seed: int = 0
    trajectory: object = None
    supersample: int = 4
    sky_colour: Tuple[int, int, int] = (72, 76, 84)
    # direction towards the light that shades balls, world frame (None:
    # the renderer's default, from above and a little ahead)
    light: Optional[Tuple[float, float, float]] = None
    scenario: str = "custom"
    # what the scenario chose and why, for scene.json
    notes: Optional[dict] = None
    _cache: dict = field(default_factory=dict, init=False, repr=False,
                         compare=False)

    def __post_init__(self):
        ids = [lm.id for lm in self.landmarks]
        if len(set(ids)) != len(ids):
            raise ValueError("landmark ids must be unique")
        names = self.palette.names
        for item in list(self.landmarks) + list(self.distractors):
            for cls in getattr(item, "bands", ()) or (item.cls,):
                if cls not in names:
                    raise ValueError(f"class {cls!r} is not a marker of "
                                     f"the scene palette "
                                     f"({', '.join(names)})")
        for name in self.floor_names():
            if name not in FLOORS:
                raise ValueError(f"unknown floor {name!r}")
        if not 1 <= self.supersample <= 16:
            raise ValueError("supersample must be within 1..16")
        self.effects.validate()

    # -- per-frame schedule -------------------------------------------------

    def floor_names(self):
        """Floors in order of first use."""
        if not self.segments:
            return [self.floor]
        names = []
        for seg in self.segments:
            if seg.floor not in names:
                names.append(seg.floor)
        return names

    def segment_state(self, frame, frames_total=None):
        """(floor name, exposure stops, (red gain, blue gain)) at frame."""
        if not self.segments or frame is None:
            return self.floor, 0.0, (1.0, 1.0)
        segs = sorted(self.segments, key=lambda s: s.from_frame)
        index = 0
        for i, seg in enumerate(segs):
            if seg.from_frame <= frame:
                index = i
        seg = segs[index]
        end = (segs[index + 1].from_frame if index + 1 < len(segs)
               else frames_total)
        span = (end - seg.from_frame - 1) if end else 0
        f = (frame - seg.from_frame) / span if span and span > 0 else 0.0
        f = min(max(f, 0.0), 1.0)
        e0, e1 = seg.exposure_stops
        (r0, b0), (r1, b1) = seg.wb_gains
        return (seg.floor, e0 + f * (e1 - e0),
                (r0 + f * (r1 - r0), b0 + f * (b1 - b0)))

    # -- colours ------------------------------------------------------------

    def floor_texture(self, name):
        key = ("floor", name)
        if key not in self._cache:
            self._cache[key] = FloorTexture(name, self.seed)
        return self._cache[key]

    def floor_class_name(self, name):
        return "floor" if len(self.floor_names()) == 1 else f"floor-{name}"

    def scene_palette(self):
        """Markers, then one background class per floor texture ("floor",
        or "floor-<texture>" when the scene changes floors), then "wall"
        when walls are on.  Mask value k is class k - 1 of this palette."""
        key = ("palette",)
        if key in self._cache:
            return self._cache[key]
        classes = list(self.palette.classes)
        taken = set(self.palette.names)
        extra = []
        for name in self.floor_names():
            lab = self.floor_texture(name).mean_lab()
            extra.append((self.floor_class_name(name), lab))
        if self.walls is not None:
            lab = reference.rgb_to_lab(
                np.array(self.walls.colour, np.uint8).reshape(1, 1, 3))
            extra.append(("wall", lab.reshape(3).astype(np.float64)))
        for colour in self.obstacle_colours():
            lab = reference.rgb_to_lab(
                np.array(colour, np.uint8).reshape(1, 1, 3))
            extra.append((self.obstacle_class_name(colour),
                          lab.reshape(3).astype(np.float64)))
        for name, lab in extra:
            if name in taken:
                raise ValueError(f"the palette already has a class {name!r}")
            lab = (min(max(float(lab[0]), 0.0), 100.0), float(lab[1]),
                   float(lab[2]))
            classes.append(PaletteClass(name, lab, False))
        palette = Palette(classes)
        # the same rules as any palette file
        parse_palette({"classes": [
            {"name": c.name, "lab": list(c.lab), "marker": c.marker}
            for c in classes]}, "<scene palette>")
        self._cache[key] = palette
        return palette

    def obstacle_colours(self):
        """The obstacles' distinct colours, in order of first use."""
        out = []
        for ob in self.obstacles:
            if tuple(ob.colour) not in out:
                out.append(tuple(ob.colour))
        return out

    def obstacle_class_name(self, colour):
        """Class of an obstacle colour: "obstacle", or "obstacle-<k>"
        (from 1) when the obstacles have several colours."""
        colours = self.obstacle_colours()
        if len(colours) == 1:
            return "obstacle"
        return f"obstacle-{colours.index(tuple(colour)) + 1}"

    def floor_segments(self):
        """What ends the floor, as footprint edges (S, 2, 2): the walls
        and every obstacle."""
        segs = []
        w = self.walls
        if w is not None:
            corners = [(w.x0, w.y0), (w.x1, w.y0), (w.x1, w.y1),
                       (w.x0, w.y1)]
            segs += [(corners[i], corners[(i + 1) % 4]) for i in range(4)]
        out = np.array(segs, np.float64).reshape(-1, 2, 2)
        if self.obstacles:
            out = np.concatenate([out] + [ob.edges()
                                          for ob in self.obstacles])
        return out

    def marker_srgb8(self):
        """sRGB colour of each marker class, by name."""
        srgb = reference.lab_to_srgb8(self.palette.lab_array())
        return {name: tuple(int(v) for v in rgb)
                for name, rgb in zip(self.palette.names, srgb)}

    def map_json(self):
        return {"landmarks": [lm.to_map() for lm in self.landmarks]}

    def with_(self, **changes):
        """A copy with some fields changed (caches are not shared)."""
        return replace(self, **changes)


def palette_json(palette):
    return {"classes": [{"name": c.name,
                         "lab": [round(v, 4) for v in c.lab],
                         "marker": c.marker} for c in palette.classes]}


def load_map(path, classes=None):
    """Landmarks of a map file (docs/conventions.md, read by
    ``landmarkmap``); the synthetic world needs every diameter.
    ``classes``: the palette's names, which every band of a coded marker
    must be one of (MapError naming the file, the landmark and the
    band)."""
    marks = read_map(path)
    if classes is not None:
        check_band_classes(marks, classes, path)
    out = []
    for m in marks:
        if m["diameter"] is None:
            raise ValueError(f"{path}: landmark {m['id']}: the synthetic "
                             f"world needs its \"diameter\"")
        out.append(Landmark(id=m["id"], cls=m["class"], x=m["x"], y=m["y"],
                            diameter=m["diameter"], kind=m["kind"],
                            z=m["z"], height=m.get("height"),
                            band_heights=m.get("band_heights")))
    return out
