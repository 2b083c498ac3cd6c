"""Colour palettes: load, validate, save and learn them.

A palette file is JSON::

    {"classes": [{"name": "red", "lab": [41.25, 43.0, 32.0],
                  "role": "marker"}, ...]}

with CIE L*a*b* values (L* 0..100).  A class's role is "marker" (a landmark
colour), "floor" or "background" (anything else: walls, furniture); the
older "marker": true / false means marker / background.  A class may list several reference
colours in "references" (a ball's lit and shaded sides); a pixel takes the
class of its nearest reference.  The C++ labsegment element applies
exactly the same validation rules as ``parse_palette``; keep them in step.
"""

from dataclasses import dataclass
from typing import Optional
import importlib.resources
import json
import math
import re
import sys

import cv2
import numpy as np

from gstlandmark import reference

MAX_CLASSES = 64
MAX_NAME_LENGTH = 32
# Reference colours a class may list (the element's kMaxReferencesPerClass).
MAX_REFERENCES = 32
# Light factors a class's "shading" may give (the element's kMinShade,
# kMaxShade): six stops either way.
MIN_SHADE = 1.0 / 64
MAX_SHADE = 64.0
CLASS_KEYS = ("name", "lab", "references", "shading", "marker", "role")
# What a class is for, in the file's spelling (docs/palette.md, "Roles").
ROLES = ("marker", "floor", "background")
_NAME_RE = re.compile(r"[A-Za-z0-9_.-]+")
# Decimals written for L*a*b* values: far below any visible difference.
LAB_DECIMALS = 4

# Learning several references per class (docs/palette.md, "Several
# reference colours"): k grows from 1 while each step keeps these.
AUTO_MAX_REFERENCES = 4
# every cluster holds at least this share of the class's pixels
MIN_REFERENCE_SHARE = 0.10
# the mean squared distance to the nearest reference at least halves: a
# round blob of colour noise (a Gaussian in 2 or 3 of L*, a*, b*) loses at
# most 32 % when split, two distinct tones or a shading gradient 75 % or
# more
MAX_SPREAD_RATIO = 0.5
# and the RMS distance falls by at least one just-noticeable difference
# (Delta E 2.3): noise along one axis only (loses 64 %) or quantisation
# steps of a flat region never count as tones
MIN_SPREAD_GAIN = 2.3
# A background or floor class is the whole scene around the markers (a
# carpet, its lines, robots, walls, people): with "auto" it gets references
# until less than UNTAUGHT_MIN_SHARE of its pixels lie farther than
# UNTAUGHT_MIN_DISTANCE from all of them (every colour of the scene that
# would make a class of its own if untaught has one), up to this many; one
# mean for a scene of many colours sits near none of them, and whatever
# lies nearer a marker's colour than that mean becomes the marker
SCENE_MAX_REFERENCES = 16
# pixels clustered per class (a fixed-seed sample of larger regions)
KMEANS_SAMPLE = 20000
# an extra reference nearer than this to a reference of another class
# tells the classes apart by less than two just-noticeable differences
# (Delta E 2 x 2.3) and is dropped: the black unlit side that balls of
# every colour share
MIN_REFERENCE_SEPARATION = 4.6
# an extra reference may take at most this share of another class's taught
# pixels from that class (pixels the palette without it labels right):
# backgrounds fill most of a frame, so a shaded-red reference that reaches
# into the dark planks of a wooden floor costs more than it gains
MAX_STOLEN_SHARE = 0.005
# pixels this close (Chebyshev, px) to a taught region are left out of the
# untaught scene: a region's edge pixels mix its colour with its
# neighbour's
UNTAUGHT_MARGIN = 2
# with rectangles, the rest of the image starts this share of a
# rectangle's longer side away from it (``rect_margin``)
RECT_MARGIN_SHARE = 0.25
# untaught pixels farther than this from every taught reference are a
# colour of the scene that no class has: about four just-noticeable
# differences (Delta E 2.3), more than twice the separation at which rule 5
# calls two references one colour
UNTAUGHT_MIN_DISTANCE = 10.0
# ... and make a class of their own when they cover at least this share of
# the teaching image; fewer are specks, highlights and mixed edge pixels
UNTAUGHT_MIN_SHARE = 0.01


class PaletteError(ValueError):
    """A palette that cannot be read, is invalid or cannot be learned."""


def _role_of(marker, role, where):
    """The role from "role" and the older "marker" flag (either may be
    None); both given must agree."""
    if role is None:
        return "background" if marker is False else "marker"
    if role not in ROLES:
        raise PaletteError(f"{where}: \"role\" must be \"marker\", "
                           f"\"floor\" or \"background\", got "
                           f"{_show(role)}")
    if marker is not None and marker != (role == "marker"):
        raise PaletteError(f"{where}: \"marker\": "
                           f"{'true' if marker else 'false'} contradicts "
                           f"\"role\": {json.dumps(role)}")
    return role


@dataclass(frozen=True)
class PaletteClass:
    """One class.  ``lab`` is its colour (false-colour output, reported
    sRGB) and its only reference when ``references`` is empty.  ``role``:
    "marker", "floor" or "background"; ``marker`` is ``role ==
    "marker"``.  Give either (unset: a marker) or both in agreement."""
    name: str
    lab: tuple[float, float, float]
    marker: Optional[bool] = None
    references: tuple[tuple[float, float, float], ...] = ()
    role: Optional[str] = None
    # light factors [darkest, lightest] its references stand for
    shading: tuple[float, float] = (1.0, 1.0)

    def __post_init__(self):
        role = _role_of(self.marker, self.role, f"class {self.name!r}")
        object.__setattr__(self, "role", role)
        object.__setattr__(self, "marker", role == "marker")

    @property
    def reference_labs(self):
        """The colours this class is classified by."""
        return self.references or (self.lab,)


@dataclass
class Palette:
    classes: list[PaletteClass]

    def __len__(self):
        return len(self.classes)

    @property
    def names(self):
        """Class names in label order (label k + 1 is names[k])."""
        return [c.name for c in self.classes]

    @property
    def markers(self):
        """Names of the marker classes (the others are background)."""
        return [c.name for c in self.classes if c.marker]

    @property
    def background(self):
        """Names of the non-marker classes (floor and background)."""
        return [c.name for c in self.classes if not c.marker]

    @property
    def floor(self):
        """Names of the classes whose role is floor."""
        return [c.name for c in self.classes if c.role == "floor"]

    def marker_mask(self):
        """bool (K,): True where the class is a marker."""
        return np.array([c.marker for c in self.classes], dtype=bool)

    def lab_array(self):
        """float64 (K, 3) reference colours in label order."""
        return np.array([c.lab for c in self.classes],
                        dtype=np.float64).reshape(-1, 3)

    def reference_arrays(self):
        """float64 (R, 3) reference colours of all classes in label order,
        and int (R,) the class index of each: what
        ``reference.classify`` takes with ``ref_class``."""
        refs = [lab for c in self.classes for lab in c.reference_labs]
        owner = [k for k, c in enumerate(self.classes)
                 for _ in c.reference_labs]
        return (np.array(refs, dtype=np.float64).reshape(-1, 3),
                np.array(owner, dtype=np.int64))

    def shading_arrays(self):
        """float64 (R, 2, 3): each reference's shading segment (its colour
        under its class's least and most light), in reference_arrays'
        order; None when no class has shading."""
        if all(c.shading == (1.0, 1.0) for c in self.classes):
            return None
        ends = [[lab_under_light(lab, c.shading[0]),
                 lab_under_light(lab, c.shading[1])]
                for c in self.classes for lab in c.reference_labs]
        return np.array(ends, dtype=np.float64).reshape(-1, 2, 3)

    @property
    def has_references(self):
        """True if any class lists its own reference colours."""
        return any(c.references for c in self.classes)

    def index(self, name):
        """Class index of ``name`` (its label is index + 1)."""
        return self.names.index(name)


def _json_type(value):
    """The JSON name of a Python value's type, for messages."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, (int, float)):
        return "number"
    if isinstance(value, str):
        return "string"
    if isinstance(value, (list, tuple)):
        return "array"
    if isinstance(value, dict):
        return "object"
    return type(value).__name__


def _show(value):
    """Format a bad value for a message: 120.0 as 120, strings quoted."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and math.isfinite(value) \
            and value.is_integer():
        return str(int(value))
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    return _json_type(value)


def _is_number(value):
    # JSON true/false arrive as bool, which is an int subclass.
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def valid_class_name(name):
    """Whether ``name`` may name a class: 1 to 32 of A-Z a-z 0-9 _ . -
    (so a coded marker's code, its bands joined by "/", reads back)."""
    return (isinstance(name, str) and 0 < len(name) <= MAX_NAME_LENGTH
            and _NAME_RE.fullmatch(name) is not None)


def _parse_lab(lab, what):
    """A colour [L*, a*, b*] as floats; ``what`` starts the messages."""
    if not isinstance(lab, (list, tuple)) or len(lab) != 3:
        got = (f"{len(lab)} values" if isinstance(lab, (list, tuple))
               else _json_type(lab))
        raise PaletteError(f"{what} must be an array of 3 numbers "
                           f"[L*, a*, b*], got {got}")
    for i, value in enumerate(lab):
        if not _is_number(value):
            raise PaletteError(f"{what}[{i}] must be a number, "
                               f"got {_json_type(value)}")
        # A huge JSON integer is finite but does not fit a float.
        if isinstance(value, float) and not math.isfinite(value):
            raise PaletteError(f"{what}[{i}] must be finite, got "
                               f"{_show(value)}")
    lightness, a_star, b_star = lab
    if not 0 <= lightness <= 100:
        raise PaletteError(f"{what} L* must be within 0..100, "
                           f"got {_show(lightness)}")
    for label, value in (("a*", a_star), ("b*", b_star)):
        if not -128 <= value <= 128:
            raise PaletteError(f"{what} {label} must be within "
                               f"-128..128, got {_show(value)}")
    return (float(lightness), float(a_star), float(b_star))


def _parse_class(entry, index, source):
    where = f"{source}: classes[{index}]"
    if not isinstance(entry, dict):
        raise PaletteError(f"{where}: must be an object, got "
                           f"{_json_type(entry)}")
    name = entry.get("name")
    if valid_class_name(name):
        where += f" ({json.dumps(name)})"

    for key in entry:
        if key not in CLASS_KEYS:
            raise PaletteError(f"{where}: unknown key {json.dumps(key)} "
                               f"(allowed: \"name\", \"lab\", "
                               f"\"references\", \"shading\", \"marker\", "
                               f"\"role\")")

    if "name" not in entry:
        raise PaletteError(f"{where}: missing \"name\"")
    if not isinstance(name, str):
        raise PaletteError(f"{where}: \"name\" must be a string, got "
                           f"{_json_type(name)}")
    if not name:
        raise PaletteError(f"{where}: \"name\" must not be empty")
    if len(name) > MAX_NAME_LENGTH:
        raise PaletteError(f"{where}: \"name\" must be at most "
                           f"{MAX_NAME_LENGTH} characters, got {len(name)}")
    if not valid_class_name(name):
        raise PaletteError(f"{where}: \"name\" {json.dumps(name)} may only "
                           f"contain A-Z a-z 0-9 _ . -")

    if "lab" not in entry:
        raise PaletteError(f"{where}: missing \"lab\"")
    lab = _parse_lab(entry["lab"], f"{where}: \"lab\"")

    references = ()
    if "references" in entry:
        refs = entry["references"]
        if not isinstance(refs, (list, tuple)):
            raise PaletteError(f"{where}: \"references\" must be an array "
                               f"of [L*, a*, b*] arrays, got "
                               f"{_json_type(refs)}")
        if not 1 <= len(refs) <= MAX_REFERENCES:
            raise PaletteError(f"{where}: \"references\" must hold 1 to "
                               f"{MAX_REFERENCES} colours, got {len(refs)}")
        references = tuple(
            _parse_lab(ref, f"{where}: \"references\"[{i}]")
            for i, ref in enumerate(refs))

    shading = (1.0, 1.0)
    if "shading" in entry:
        shading = parse_shading(entry["shading"], f"{where}: \"shading\"")

    # given as null is wrong, as the C reader says (absent is fine)
    marker = entry.get("marker")
    if "marker" in entry and not isinstance(marker, bool):
        raise PaletteError(f"{where}: \"marker\" must be true or false, "
                           f"got {_show(marker)}")
    role = entry.get("role")
    if "role" in entry and not isinstance(role, str):
        raise PaletteError(f"{where}: \"role\" must be \"marker\", "
                           f"\"floor\" or \"background\", got {_show(role)}")
    role = _role_of(marker, role, where)

    return PaletteClass(name=name, lab=lab, role=role,
                        references=references, shading=shading)


def parse_shading(value, what):
    """[darkest, lightest] light factors (docs/palette.md, "Shading")."""
    if (not isinstance(value, (list, tuple)) or len(value) != 2 or
            not all(_is_number(v) for v in value) or
            not MIN_SHADE <= value[0] <= 1.0 <= value[1] <= MAX_SHADE):
        raise PaletteError(f"{what} must be [darkest, lightest] light "
                           f"factors, 1/64 <= darkest <= 1 <= lightest <= "
                           f"64, got {_show(value)}")
    return (float(value[0]), float(value[1]))


def lab_under_light(lab, k):
    """(..., 3) L*a*b* of a surface under k times the light it shows:
    L* + 16, a* and b* scale by the cube root of k (exact where L* follows
    the cube root, L* > 8), L* kept within 0..100; as the element's
    lab_under_light."""
    lab = np.asarray(lab, dtype=np.float64)
    base = lab[..., 0] + 16.0
    s = np.clip(np.cbrt(k), 16.0 / base, 116.0 / base)
    return np.stack([base * s - 16.0, lab[..., 1] * s, lab[..., 2] * s],
                    axis=-1)


def parse_palette(obj, source="<palette>"):
    """Validate a decoded JSON object and return a ``Palette``.

    ``source`` starts every error message (a file name, usually).
    """
    if not isinstance(obj, dict):
        raise PaletteError(f"{source}: top level must be an object with a "
                           f"\"classes\" array, got {_json_type(obj)}")
    if "classes" not in obj:
        raise PaletteError(f"{source}: missing \"classes\"")
    entries = obj["classes"]
    if not isinstance(entries, (list, tuple)):
        raise PaletteError(f"{source}: \"classes\" must be an array, got "
                           f"{_json_type(entries)}")
    if not entries:
        raise PaletteError(f"{source}: \"classes\" is empty: a palette "
                           f"needs at least one class")
    if len(entries) > MAX_CLASSES:
        raise PaletteError(f"{source}: \"classes\" has {len(entries)} "
                           f"entries, at most {MAX_CLASSES} are allowed")

    classes = []
    first_index = {}
    for index, entry in enumerate(entries):
        cls = _parse_class(entry, index, source)
        if cls.name in first_index:
            raise PaletteError(
                f"{source}: classes[{index}] ({json.dumps(cls.name)}): "
                f"duplicate name, already used by "
                f"classes[{first_index[cls.name]}]")
        first_index[cls.name] = index
        classes.append(cls)
    return Palette(classes)


def parse_palette_text(text, source="<palette>"):
    """Decode JSON text and validate it as a palette."""
    try:
        obj = json.loads(text)
    except json.JSONDecodeError as err:
        raise PaletteError(f"{source}: not valid JSON: {err.msg} at line "
                           f"{err.lineno}, column {err.colno}") from None
    return parse_palette(obj, source)


def load_palette(path):
    """Read and validate a palette file."""
    source = str(path)
    try:
        with open(path, "rb") as f:
            data = f.read()
    except FileNotFoundError:
        raise PaletteError(f"{source}: no such file") from None
    except IsADirectoryError:
        raise PaletteError(f"{source}: is a directory, not a palette "
                           f"file") from None
    except OSError as err:
        raise PaletteError(f"{source}: cannot read: "
                           f"{err.strerror or err}") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise PaletteError(f"{source}: not valid UTF-8 (byte "
                           f"{err.start})") from None
    return parse_palette_text(text, source)


def default_palette_text():
    """The built-in default palette file, as text."""
    files = importlib.resources.files("gstlandmark")
    return (files / "data" / "default-palette.json").read_text("utf-8")


def default_palette():
    """The built-in default palette (the one the element embeds)."""
    return parse_palette_text(default_palette_text(),
                              "<default palette>")


def palette_to_json(palette, **extra_top_level):
    """A JSON-ready dict: the extra top-level keys first, then "classes".

    Keys that are not Python identifiers (such as "learned-from") can be
    passed as ``**{"learned-from": path}``.
    """
    if "classes" in extra_top_level:
        raise ValueError("\"classes\" is written from the palette itself")
    obj = dict(extra_top_level)
    obj["classes"] = [_class_to_json(c) for c in palette.classes]
    return obj


def _class_to_json(cls):
    entry = {"name": cls.name,
             "lab": [round(float(v), LAB_DECIMALS) for v in cls.lab]}
    if cls.references:
        entry["references"] = [[round(float(v), LAB_DECIMALS) for v in ref]
                               for ref in cls.references]
    # the flag too, for readers of the older form
    if cls.shading != (1.0, 1.0):
        entry["shading"] = [float(v) for v in cls.shading]
    entry["marker"] = bool(cls.marker)
    entry["role"] = cls.role
    return entry


def _format_json(obj):
    """Indented JSON with one class per line, like the shipped palette."""
    lines = ["{"]
    items = list(obj.items())
    for i, (key, value) in enumerate(items):
        comma = "," if i < len(items) - 1 else ""
        if key == "classes":
            lines.append(f"  {json.dumps(key)}: [")
            for j, entry in enumerate(value):
                sep = "," if j < len(value) - 1 else ""
                lines.append(f"    {json.dumps(entry)}{sep}")
            lines.append(f"  ]{comma}")
        else:
            lines.append(f"  {json.dumps(key)}: {json.dumps(value)}{comma}")
    lines.append("}")
    return "\n".join(lines) + "\n"


def save_palette(palette, path, **extra):
    """Validate ``palette`` and write it to ``path`` as JSON."""
    obj = palette_to_json(palette, **extra)
    # Never write a file the loader (or the element) would refuse.
    parse_palette(obj, str(path))
    with open(path, "w", encoding="utf-8") as f:
        f.write(_format_json(obj))


def _check_image(image):
    image = np.asarray(image)
    if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
        raise PaletteError(f"expected an 8-bit 3-channel BGR image, got "
                           f"{image.dtype} {image.shape}")
    return image


def _image_lab(image_bgr):
    """Lab of a BGR image, computed exactly as the reference does."""
    rgb = np.ascontiguousarray(image_bgr[:, :, ::-1])
    return reference.rgb_to_lab(rgb)


def _class_roles(names, markers, background, floor=None):
    """Role per name, from a list of markers or of backgrounds and a list
    of floor classes: the floor classes are floor; then the markers are
    markers and the rest background, or the backgrounds background and
    the rest markers (neither list: every other class a marker)."""
    if markers is not None and background is not None:
        raise PaletteError("give either markers or background, not both")
    floor = list(floor or ())
    for name in [*floor, *(markers or ()), *(background or ())]:
        if name not in names:
            raise PaletteError(f"{json.dumps(name)} is not one of the "
                               f"classes ({', '.join(names)})")
    for listed, what in ((markers, "a marker"), (background, "background")):
        both = [n for n in floor if n in (listed or ())]
        if both:
            raise PaletteError(f"{json.dumps(both[0])} is given as floor "
                               f"and as {what}")
    roles = []
    for name in names:
        if name in floor:
            roles.append("floor")
        elif markers is not None:
            roles.append("marker" if name in markers else "background")
        else:
            roles.append("background" if name in (background or ())
                         else "marker")
    return roles


def _check_references(references):
    """``references`` option: "auto" or a count 1..MAX_REFERENCES."""
    if references == "auto":
        return references
    if (isinstance(references, bool) or not isinstance(references, int)
            or not 1 <= references <= MAX_REFERENCES):
        raise PaletteError(f"references must be \"auto\" or 1 to "
                           f"{MAX_REFERENCES}, got {references!r}")
    return references


def kmeans(pixels, k, seed):
    """k-means of (N, 3) float32 pixels: (mean squared distance to the
    nearest centre, labels (N,), centres (k, 3) float64)."""
    cv2.setRNGSeed(seed)
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100,
                1e-4)
    compactness, labels, centres = cv2.kmeans(
        pixels, k, None, criteria, 4, cv2.KMEANS_PP_CENTERS)
    return (compactness / len(pixels), labels.ravel(),
            centres.astype(np.float64))


def sample_pixels(pixels, seed):
    """At most KMEANS_SAMPLE of the pixels, chosen with a fixed seed."""
    if len(pixels) <= KMEANS_SAMPLE:
        return pixels
    rng = np.random.default_rng(seed)
    return pixels[rng.choice(len(pixels), KMEANS_SAMPLE, replace=False)]


def prune_stealing_references(class_refs, class_pixels, seed=0,
                              untaught=None, markers=None):
    """Drop extra references that take pixels their class was not taught.

    ``class_refs``: per class, (k, 3) references (k = 1: its mean);
    ``class_pixels``: per class, its taught (N, 3) L*a*b* pixels (a class
    left with one reference is classified by its mean).  While
    an extra reference (one of k > 1) is the nearest reference of more
    than MAX_STOLEN_SHARE of some other class's pixels whose next nearest
    reference is of their own class, the worst such reference is dropped.
    ``untaught``: (M, 3) pixels of the teaching image in no class (the
    rest of the scene) and ``markers``: per class, whether it is a marker;
    an extra reference of a marker class that is the nearest reference of
    more than MAX_STOLEN_SHARE of them, where the next nearest reference
    is of another class, counts the same: a marker is a small thing in the
    scene, so a tone of it that claims part of what surrounds it (the dark
    sky beside a ball's shaded side) is the scene's colour, not the
    marker's.  A reference of a non-marker class stays while the share
    of its own class it keeps from a marker (pixels whose next nearest
    reference is a marker's) is at least the share it takes.
    """
    refs = [np.asarray(r, dtype=np.float64).reshape(-1, 3).copy()
            for r in class_refs]
    pixels_all = [np.asarray(p, dtype=np.float64).reshape(-1, 3)
                  for p in class_pixels]
    means = [p.mean(axis=0, keepdims=True) for p in pixels_all]
    samples = [(k, sample_pixels(p, seed)) for k, p in enumerate(pixels_all)]
    if untaught is not None and len(untaught) and markers is not None \
            and any(markers):
        rest = np.asarray(untaught, dtype=np.float64).reshape(-1, 3)
        samples.append((-1, sample_pixels(rest, seed)))
    is_marker = np.array([bool(m) for m in markers]) \
        if markers is not None else np.zeros(len(refs), dtype=bool)
    while any(len(r) > 1 for r in refs):
        flat = np.vstack(refs)
        owner = np.repeat(np.arange(len(refs)), [len(r) for r in refs])
        slot = np.concatenate([np.arange(len(r)) for r in refs])
        stolen = np.zeros(len(flat))
        saved = np.zeros(len(flat))
        for k, pixels in samples:
            d2 = ((pixels[:, None, :] - flat[None, :, :]) ** 2).sum(axis=2)
            two = np.argsort(d2, axis=1, kind="stable")[:, :2]
            if k >= 0:
                taken = (owner[two[:, 0]] != k) & (owner[two[:, 1]] == k)
                # a scene reference's own pixels that a marker would take
                # without it
                kept = (owner[two[:, 0]] == k) & ~is_marker[k] & \
                    is_marker[owner[two[:, 1]]]
                saved += np.bincount(two[kept, 0], minlength=len(flat)) \
                    / len(pixels)
            else:
                taken = is_marker[owner[two[:, 0]]] & \
                    (owner[two[:, 0]] != owner[two[:, 1]])
            share = np.bincount(two[taken, 0], minlength=len(flat)) \
                / len(pixels)
            stolen = np.maximum(stolen, share)
        stolen[[len(refs[k]) == 1 for k in owner]] = 0.0
        # a scene reference stays while it keeps more of its class from a
        # marker than it takes of the marker, in shares of each: dropped,
        # its pixels would be the marker's false detections
        stolen[saved >= stolen] = 0.0
        worst = int(np.argmax(stolen))
        if stolen[worst] <= MAX_STOLEN_SHARE:
            break
        k = owner[worst]
        refs[k] = np.delete(refs[k], slot[worst], axis=0)
        if len(refs[k]) == 1:
            refs[k] = means[k]
    return refs


def prune_shared_references(class_refs, class_means):
    """Drop learned references that do not tell the classes apart.

    ``class_refs``: per class, (k, 3) references (k = 1: its mean);
    ``class_means``: per class, the mean of its pixels.  Every extra
    reference of a class (one of k > 1) that lies within
    MIN_REFERENCE_SEPARATION of a reference of another class is dropped,
    all of them at once (a colour several classes claim belongs to none of
    them), until none is left; a class left with one reference is
    classified by its mean.  Returns the kept references per class.
    """
    refs = [np.asarray(r, dtype=np.float64).reshape(-1, 3).copy()
            for r in class_refs]
    while True:
        flat = np.vstack(refs)
        owner = np.repeat(np.arange(len(refs)), [len(r) for r in refs])
        dist = np.linalg.norm(flat[:, None, :] - flat[None, :, :], axis=2)
        dist[owner[:, None] == owner[None, :]] = np.inf
        close = dist.min(axis=1) < MIN_REFERENCE_SEPARATION
        drop = close & np.array([len(refs[k]) > 1 for k in owner])
        if not drop.any():
            return refs
        keep = ~drop
        for k in range(len(refs)):
            mine = keep[owner == k]
            if mine.sum() > 1:
                refs[k] = refs[k][mine]
            elif not mine.all():
                refs[k] = np.asarray(class_means[k],
                                     dtype=np.float64).reshape(1, 3)


def cluster_references(pixels_lab, references="auto", seed=0, scene=False):
    """Reference colours of one class from its (N, 3) L*a*b* pixels.

    ``references`` is a count, or "auto": k grows from 1 (the mean) to at
    most AUTO_MAX_REFERENCES while the k-means step to k clusters
    (OpenCV, fixed seed) gives every cluster at least MIN_REFERENCE_SHARE
    of the pixels, cuts the mean squared distance of a pixel to its
    nearest reference to at most MAX_SPREAD_RATIO of what k - 1 clusters
    left, and cuts the RMS distance by at least MIN_SPREAD_GAIN.  Returns float64 (k, 3) centres, the
    largest cluster first.  ``scene``: the class is a background or floor
    (``cluster_scene_references`` for "auto").
    """
    references = _check_references(references)
    pixels = np.asarray(pixels_lab, dtype=np.float64).reshape(-1, 3)
    mean = pixels.mean(axis=0)
    if references == 1:
        return mean[None, :]
    data = np.ascontiguousarray(sample_pixels(pixels, seed), dtype=np.float32)
    distinct = len(np.unique(data, axis=0))

    def ordered(labels, centres):
        counts = np.bincount(labels, minlength=len(centres))
        order = np.lexsort((centres[:, 0], -counts))
        return centres[order]

    if references == "auto" and scene:
        return cluster_scene_references(data, distinct, seed, ordered)
    if references != "auto":
        if distinct < references:
            raise PaletteError(f"{distinct} distinct colours cannot give "
                               f"{references} references")
        _, labels, centres = kmeans(data, references, seed)
        return ordered(labels, centres)

    best = mean[None, :]
    spread = float(np.mean(np.sum((data - mean) ** 2, axis=1)))
    for k in range(2, min(AUTO_MAX_REFERENCES, distinct) + 1):
        new_spread, labels, centres = kmeans(data, k, seed)
        shares = np.bincount(labels, minlength=k) / len(data)
        if (shares.min() < MIN_REFERENCE_SHARE
                or new_spread > MAX_SPREAD_RATIO * spread
                or np.sqrt(spread) - np.sqrt(new_spread) < MIN_SPREAD_GAIN):
            break
        best, spread = ordered(labels, centres), new_spread
    return best


def _rest_near_masks(masks):
    """The pixels of no class's region and at least UNTAUGHT_MARGIN pixels
    away from every region, as a bool mask (the rest of a teaching image
    taught by a class mask)."""
    taught = np.zeros(masks[0].shape, dtype=np.uint8)
    for mask in masks:
        taught |= mask.astype(np.uint8)
    size = 2 * UNTAUGHT_MARGIN + 1
    return cv2.dilate(taught, np.ones((size, size), np.uint8)) == 0


def rect_margin(w, h):
    """Pixels around a rectangle left out of the rest of the image: a box
    drawn by hand or by an annotator seldom holds all of its object (the
    ball's rim, its shadow), so a quarter of the box's longer side, at least
    UNTAUGHT_MARGIN."""
    return max(UNTAUGHT_MARGIN, int(math.ceil(RECT_MARGIN_SHARE * max(w, h))))


def _rest_of_rects(shape, rects):
    """The rest of an image taught by rectangles: the pixels outside every
    rectangle grown by its ``rect_margin``, as a bool mask."""
    height, width = shape[:2]
    rest = np.ones((height, width), dtype=bool)
    for _, x, y, w, h in rects:
        m = rect_margin(w, h)
        rest[max(0, y - m):y + h + m, max(0, x - m):x + w + m] = False
    return rest


def _split_untaught(pixels, taught):
    """The rest's pixels (N, 3) split into those within
    UNTAUGHT_MIN_DISTANCE of a reference of ``taught`` and those farther
    from all of them."""
    refs = np.vstack([r for _, r in taught])
    near = np.zeros(len(pixels), dtype=bool)
    for start in range(0, len(pixels), 65536):
        chunk = pixels[start:start + 65536]
        d2 = ((chunk[:, None, :] - refs[None, :, :]) ** 2).sum(axis=2)
        near[start:start + 65536] = \
            d2.min(axis=1) <= UNTAUGHT_MIN_DISTANCE ** 2
    return pixels[near], pixels[~near]


def cluster_scene_references(data, distinct, seed, ordered):
    """References of a background class from its sampled float32 pixels:
    k grows from 1 until less than UNTAUGHT_MIN_SHARE of the pixels lie
    farther than UNTAUGHT_MIN_DISTANCE from every reference, up to
    SCENE_MAX_REFERENCES (and the distinct colours there are);
    ``ordered`` sorts the centres."""
    def uncovered(centres):
        d2 = ((data[:, None, :] - centres[None, :, :]) ** 2).sum(axis=2)
        return np.mean(d2.min(axis=1) > UNTAUGHT_MIN_DISTANCE ** 2)

    best = data.mean(axis=0, dtype=np.float64)[None, :]
    k = 1
    while uncovered(best) >= UNTAUGHT_MIN_SHARE and \
            k < min(SCENE_MAX_REFERENCES, distinct):
        k += 1
        _, labels, centres = kmeans(data, k, seed)
        best = ordered(labels, centres)
    return best


def _rest_pixels(views):
    """The pixels of the rest of every teaching image, pooled, (N, 3)."""
    return np.vstack([lab[rest] for lab, _, rest in views]) \
        .astype(np.float64)


def _refs_taking_no_taught_pixels(refs, taught, seed):
    """The references of the untaught class that are the nearest reference
    of at most MAX_STOLEN_SHARE of every taught class's pixels that the
    taught references alone give their own class: what the mask left out
    must not take what it taught (a carpet's dark fibres beyond Delta E 10
    of the carpet's mean are still carpet)."""
    refs = np.asarray(refs, dtype=np.float64).reshape(-1, 3)
    own = np.vstack([r for _, r in taught])
    owner = np.repeat(np.arange(len(taught)), [len(r) for _, r in taught])
    keep = np.ones(len(refs), dtype=bool)
    for k, (pixels, _) in enumerate(taught):
        sample = sample_pixels(pixels, seed)
        d_own = ((sample[:, None, :] - own[None, :, :]) ** 2).sum(axis=2)
        right = owner[d_own.argmin(axis=1)] == k
        d_new = ((sample[:, None, :] - refs[None, :, :]) ** 2).sum(axis=2)
        taken = right[:, None] & (d_new < d_own.min(axis=1)[:, None])
        keep &= taken.mean(axis=0) <= MAX_STOLEN_SHARE
    return refs[keep]


def _palette_from_masks(views, names, roles, allow_missing=False,
                        references=1, seed=0, untaught_class=None):
    """Mean Lab of each class's pixels (and its reference colours, see
    ``cluster_references``) -> validated Palette.  ``views``: per teaching
    image, (its L*a*b*, a bool mask per class, a bool mask of the rest of
    the image); the pixels of a class, and those of the rest, are pooled
    over the images.  Classes with no pixels are an error, or with
    ``allow_missing`` are left out (with a warning on stderr naming them).
    ``untaught_class``: the name of a background class learned from the
    rest's pixels far from every taught colour, when they cover
    UNTAUGHT_MIN_SHARE of the images (None: no such class)."""
    references = _check_references(references)
    entries = []
    missing = []
    taught = []
    area = sum(lab.shape[0] * lab.shape[1] for lab, _, _ in views)
    for k, (name, role) in enumerate(zip(names, roles)):
        if not any(masks[k].any() for _, masks, _ in views):
            if not allow_missing:
                raise PaletteError(f"class {json.dumps(name)} has no "
                                   f"pixels")
            missing.append(name)
            continue
        # Mean in float64 over the float32 Lab pixels; clip L* so float
        # rounding at pure white or black cannot fail validation.
        pixels = np.vstack([lab[masks[k]] for lab, masks, _ in views]) \
            .astype(np.float64)
        mean = pixels.mean(axis=0)
        mean[0] = min(max(mean[0], 0.0), 100.0)
        entries.append({"name": name, "lab": [float(v) for v in mean],
                        "role": role})
        try:
            refs = cluster_references(pixels, references, seed,
                                      scene=role != "marker")
        except PaletteError as err:
            raise PaletteError(f"class {json.dumps(name)}: {err}") from None
        taught.append((pixels, mean[None, :] if len(refs) == 1 else refs))
    untaught = None
    if untaught_class is not None and taught:
        if untaught_class in names:
            raise PaletteError(
                f"the class for untaught colours, "
                f"{json.dumps(untaught_class)}, is also a taught class: "
                f"name it otherwise")
        untaught, far = _split_untaught(_rest_pixels(views), taught)
        if len(far) >= UNTAUGHT_MIN_SHARE * area \
                and len(entries) < MAX_CLASSES:
            mean = far.mean(axis=0)
            mean[0] = min(max(mean[0], 0.0), 100.0)
            entries.append({"name": untaught_class,
                            "lab": [float(v) for v in mean],
                            "role": "background"})
            refs = _refs_taking_no_taught_pixels(
                mean[None, :] if references == 1 else
                cluster_references(far, references, seed, scene=True),
                taught, seed)
            if len(refs):
                entries[-1]["lab"] = [float(v) for v in
                                      (mean if len(refs) > 1 else refs[0])]
                taught.append((far, refs))
            else:
                entries.pop()
    if references == "auto" and len(taught) > 1:
        if untaught is None:
            untaught = _rest_pixels(views)
        kept = prune_stealing_references(
            prune_shared_references([r for _, r in taught],
                                    [p.mean(axis=0) for p, _ in taught]),
            [p for p, _ in taught], seed, untaught=untaught,
            markers=[entry["role"] == "marker" for entry in entries])
    else:
        kept = [r for _, r in taught]
    for entry, refs in zip(entries, kept):
        if len(refs) > 1:
            refs[:, 0] = np.clip(refs[:, 0], 0.0, 100.0)
            entry["references"] = [[float(v) for v in r] for r in refs]
    if missing:
        listed = ", ".join(json.dumps(n) for n in missing)
        if not entries:
            raise PaletteError(f"no class has any pixels ({listed})")
        print(f"warning: no pixels of class(es) {listed}: left out of the "
              f"palette", file=sys.stderr)
    return parse_palette({"classes": entries}, "<learned palette>")


def learn_from_mask(image_bgr_uint8, mask_uint8, names=None, markers=None,
                    allow_missing=False, references=1, floor=None,
                    untaught_class=None):
    """Learn a palette from an image and a mask of class indices.

    Mask value 0 is ignored, value k (1..K) marks pixels of class k.  Names
    default to "class1".."classK" (K = largest mask value) or are given;
    ``markers`` lists the names of the marker classes (default: all but
    the floor), ``floor`` those of the floor classes (role floor; the
    classes in neither list are background).  Each class gets the mean L*a*b* of its pixels.  A class with no pixels
    is an error unless ``allow_missing`` is true: then it is left out of
    the palette (the others keep their order) and a warning on stderr
    names it.  ``references``: reference colours per class, a count or
    "auto" (``cluster_references``); 1 keeps the mean alone.
    ``untaught_class``: name of a background class learned from the
    pixels of no class (mask 0) farther than UNTAUGHT_MIN_DISTANCE from
    every taught colour, when they are at least UNTAUGHT_MIN_SHARE of the
    image: the sky or walls the mask left out, which would otherwise go
    to whichever class is least far (None: no such class).
    """
    image = _check_image(image_bgr_uint8)
    mask = np.asarray(mask_uint8)
    if mask.ndim == 3 and mask.shape[2] == 1:
        mask = mask[:, :, 0]
    if mask.ndim != 2 or not np.issubdtype(mask.dtype, np.integer):
        raise PaletteError(f"the mask must be a single-channel integer "
                           f"image, got {mask.dtype} {mask.shape}")
    if mask.shape != image.shape[:2]:
        raise PaletteError(
            f"the mask is {mask.shape[1]}x{mask.shape[0]} but the image is "
            f"{image.shape[1]}x{image.shape[0]}")
    if mask.size and mask.min() < 0:
        raise PaletteError("the mask has negative values")

    top = int(mask.max()) if mask.size else 0
    if names is None:
        if top == 0:
            raise PaletteError("the mask has no class pixels (all 0)")
        names = [f"class{k}" for k in range(1, top + 1)]
    else:
        names = list(names)
        if top > len(names):
            raise PaletteError(f"the mask has class index {top} but "
                               f"there are only {len(names)} class names")
    if len(names) > MAX_CLASSES:
        raise PaletteError(f"{len(names)} classes, at most {MAX_CLASSES} "
                           f"are allowed")
    roles = _class_roles(names, markers, None, floor)
    masks = [mask == k for k in range(1, len(names) + 1)]
    return _palette_from_masks([(_image_lab(image), masks,
                                 _rest_near_masks(masks))], names, roles,
                               allow_missing=allow_missing,
                               references=references,
                               untaught_class=untaught_class)


def learn_from_rects(image_bgr_uint8, rects, markers=None, background=None,
                     references=1, floor=None, untaught_class=None):
    """Learn a palette from rectangles ``[(name, x, y, w, h), ...]``.

    Several rectangles may share a name; their pixels are pooled.  Classes
    are in order of first appearance.  ``markers`` or ``background`` lists
    which names are markers or background (default: all markers), and
    ``floor`` the floor classes (role floor).  ``references`` as for
    ``learn_from_mask``.  ``untaught_class``: name of a background class
    learned from the rest of the image (outside every rectangle grown by
    ``rect_margin``) as ``learn_from_mask`` does (None: no such class).
    """
    return learn_from_images([(image_bgr_uint8, rects)], markers=markers,
                             background=background, references=references,
                             floor=floor, untaught_class=untaught_class)


def check_rects(shape, rects, source=None):
    """Check rectangles ``[(name, x, y, w, h), ...]`` against an image of
    ``shape`` and return, per class name in order of first appearance, its
    bool mask; a rectangle that does not fit or that overlaps one of
    another class is a PaletteError naming it (and ``source``, the image)."""
    height, width = shape[:2]
    names = []
    class_masks = {}
    owner = np.full((height, width), -1, dtype=np.int64)
    where = f"{source}: " if source is not None else ""
    for name, x, y, w, h in rects:
        what = f"{where}rectangle {name}:{x},{y},{w},{h}"
        if w <= 0 or h <= 0:
            raise PaletteError(f"{what}: width and height must be positive")
        if x < 0 or y < 0 or x + w > width or y + h > height:
            raise PaletteError(f"{what} does not fit inside the "
                               f"{width}x{height} image")
        if name not in class_masks:
            names.append(name)
            class_masks[name] = np.zeros((height, width), dtype=bool)
        index = names.index(name)
        # A pixel claimed by two classes has no defined colour.
        clash = owner[y:y + h, x:x + w]
        others = np.unique(clash[(clash >= 0) & (clash != index)])
        if others.size:
            raise PaletteError(f"{what} overlaps a rectangle of "
                               f"{json.dumps(names[others[0]])}")
        clash[...] = index
        class_masks[name][y:y + h, x:x + w] = True
    return class_masks


def learn_from_images(taught, markers=None, background=None, references=1,
                      floor=None, untaught_class=None, sources=None):
    """Learn one palette from several images taught by rectangles.

    ``taught``: ``[(image_bgr_uint8, [(name, x, y, w, h), ...]), ...]``;
    the pixels of a class are pooled over all its rectangles in all the
    images before its references are clustered, and so is the rest of every
    image for ``untaught_class``.  Classes are in order of first
    appearance; ``sources`` (one name per image, e.g. its file) starts the
    messages about an image's rectangles.  The other options as for
    ``learn_from_rects``.
    """
    names = []
    per_image = []
    for i, (image, rects) in enumerate(taught):
        image = _check_image(image)
        source = sources[i] if sources is not None else \
            (f"image {i + 1}" if len(taught) > 1 else None)
        masks = check_rects(image.shape, rects, source)
        names += [name for name in masks if name not in names]
        per_image.append((image, rects, masks))
    if not names:
        raise PaletteError("no rectangles given")
    if len(names) > MAX_CLASSES:
        raise PaletteError(f"{len(names)} classes, at most {MAX_CLASSES} "
                           f"are allowed")
    roles = _class_roles(names, markers, background, floor)
    views = []
    for image, rects, masks in per_image:
        empty = np.zeros(image.shape[:2], dtype=bool)
        views.append((_image_lab(image),
                      [masks.get(name, empty) for name in names],
                      _rest_of_rects(image.shape, rects)))
    return _palette_from_masks(views, names, roles, references=references,
                               untaught_class=untaught_class)
