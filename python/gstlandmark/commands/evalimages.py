"""``gst-landmark evaluate FOLDER|VIDEO``: the chain on real pictures,
scored against box annotations in darknet/YOLO form (docs/evaluate.md).

- Truth: one ``.txt`` per image beside it (for a video, one
  ``frame_NNNNNN.txt`` per annotated frame, N from 0, in ``--labels``),
  each line ``class cx cy w h`` with the box's centre and size normalised
  to [0, 1]; the class names from ``--names`` (default: the first
  ``obj.names`` in the input's folder or one of its parents), one a line,
  line k naming class k.
- The chain: ``labsegment palette=P ! blobroundness`` (plus ``ipmrange
  calibration=C`` with ``--camera-file``), every property at its default
  (``blobroundness keep-rejected=true``, which only adds the rejected
  blobs to the metadata so that misses can be studied); ``--set
  element.property=value`` for experiments. Images run through ONE
  pipeline per folder (appsrc pushing the decoded frames, new caps when
  the size changes).
- Classes: ``--class NAME=MARKER`` maps an annotation class to a marker
  class of the palette (default: the annotation classes whose name is a
  marker class). Other annotation classes are not scored; accepted
  detections of marker classes nothing maps to are counted apart.
- Matching: an accepted detection (``Detection.rejected()`` is None) of a
  mapped marker class is a true positive when its centre lies inside a
  not yet matched truth box of that class, nearest box centre first; any
  other accepted detection of a mapped class is a false detection.
- Report: recall by truth box width (< 12, 12-30, > 30 px, all) and false
  detections per image, per folder (each sub-folder apart) and overall,
  as a table and with ``-o`` as JSON with every image's boxes and
  detections, the rejected ones with their reason.
"""

from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass
from typing import Any, Dict, Iterable, Iterator, List, Optional, Sequence

from ..trajectory import nearest_first
from .common import CliError

IMAGE_EXTENSIONS = (".jpg", ".jpeg", ".png")
NAMES_FILE = "obj.names"
# box width bands, pixels: (name, lowest, highest), a width w in the band
# when lowest <= w < highest; 30 itself is in 12-30
BANDS = (("<12", 0.0, 12.0), ("12-30", 12.0, 30.0), (">30", 30.0, math.inf))
BAND_NAMES = tuple(name for name, _, _ in BANDS) + ("all",)
CHAIN_ELEMENTS = ("labsegment", "blobroundness", "ipmrange")


class AnnotationError(CliError):
    """Bad input: a file (and line) that cannot be used."""


def band_of(width_px: float) -> str:
    if width_px < 12.0:
        return "<12"
    return "12-30" if width_px <= 30.0 else ">30"


# -- truth ------------------------------------------------------------------

@dataclass
class TruthBox:
    """An annotated box in pixels (continuous image coordinates: pixel
    (i, j) covers [i, i + 1] x [j, j + 1])."""
    name: str           # annotation class name
    cx: float
    cy: float
    w: float
    h: float
    line: int = 0       # line of its annotation file

    def contains(self, u: float, v: float) -> bool:
        """Whether a point in pixel-centre coordinates (the blob
        centroid's: pixel i's centre is i) lies inside the box."""
        return (abs(u + 0.5 - self.cx) <= self.w / 2
                and abs(v + 0.5 - self.cy) <= self.h / 2)

    def cut(self, width: int, height: int) -> bool:
        """Whether the box reaches within a pixel of the image's border."""
        return (self.cx - self.w / 2 < 1 or self.cy - self.h / 2 < 1
                or self.cx + self.w / 2 > width - 1
                or self.cy + self.h / 2 > height - 1)

    @property
    def band(self) -> str:
        return band_of(self.w)

    def scaled(self, width: int, height: int) -> "TruthBox":
        """A normalised box (as annotation files hold it) in pixels of a
        ``width`` x ``height`` image."""
        return TruthBox(self.name, self.cx * width, self.cy * height,
                        self.w * width, self.h * height, self.line)


def read_lines(path: str, what: str = "") -> List[str]:
    """The lines of a text file; AnnotationError naming it when it cannot
    be read."""
    try:
        with open(path, encoding="utf-8") as f:
            return f.read().splitlines()
    except (OSError, UnicodeDecodeError) as err:
        raise AnnotationError(f"{path}: {what}cannot read: "
                              f"{getattr(err, 'strerror', None) or err}"
                              ) from None


def read_names(path: str) -> List[str]:
    """The class names of a darknet ``.names`` file, one a line."""
    names = [line.strip() for line in read_lines(path)]
    while names and not names[-1]:
        names.pop()
    for k, name in enumerate(names):
        if not name:
            raise AnnotationError(f"{path}:{k + 1}: empty class name")
    if not names:
        raise AnnotationError(f"{path}: no class names")
    return names


def find_names(folder: str) -> Optional[str]:
    """The first obj.names in ``folder`` or one of its parents."""
    folder = os.path.abspath(folder)
    while True:
        candidate = os.path.join(folder, NAMES_FILE)
        if os.path.isfile(candidate):
            return candidate
        parent = os.path.dirname(folder)
        if parent == folder:
            return None
        folder = parent


def read_yolo(path: str, names: Sequence[str]) -> List[TruthBox]:
    """The boxes of one darknet/YOLO annotation file, normalised as
    written (``TruthBox.scaled`` puts them in pixels). A bad line raises
    AnnotationError naming the file and the line."""
    boxes = []
    lines = read_lines(path)
    for number, text in enumerate(lines, 1):
        fields = text.split()
        if not fields:
            continue
        where = f"{path}:{number}"
        if len(fields) != 5:
            raise AnnotationError(f"{where}: expected 'class cx cy w h', got "
                                  f"{len(fields)} fields: {text.strip()!r}")
        try:
            index = int(fields[0])
            cx, cy, w, h = (float(v) for v in fields[1:])
        except ValueError:
            raise AnnotationError(f"{where}: not a class index and four "
                                  f"numbers: {text.strip()!r}") from None
        if not 0 <= index < len(names):
            raise AnnotationError(f"{where}: class {index} is not in the "
                                  f"class names (0..{len(names) - 1})")
        if not all(0.0 <= v <= 1.0 for v in (cx, cy, w, h)):
            raise AnnotationError(f"{where}: cx cy w h must be normalised to "
                                  f"[0, 1]: {text.strip()!r}")
        if w <= 0.0 or h <= 0.0:
            raise AnnotationError(f"{where}: the box has no width or "
                                  f"height: {text.strip()!r}")
        boxes.append(TruthBox(names[index], cx, cy, w, h, number))
    return boxes


def annotation_path(image_path: str) -> str:
    return os.path.splitext(image_path)[0] + ".txt"


# -- what is scored -----------------------------------------------------------

def list_images(root: str) -> Dict[str, List[str]]:
    """{folder relative to root ("." for root itself): its image paths in
    sorted order}, every sub-folder apart, folders in sorted order."""
    if not os.path.isdir(root):
        raise AnnotationError(f"{root}: no such folder")
    groups: Dict[str, List[str]] = {}
    for folder, dirs, files in os.walk(root):
        dirs.sort()
        images = sorted(f for f in files
                        if f.lower().endswith(IMAGE_EXTENSIONS))
        if images:
            rel = os.path.relpath(folder, root)
            groups[rel] = [os.path.join(folder, f) for f in images]
    return dict(sorted(groups.items()))


def read_excludes(paths: Iterable[str]) -> List[str]:
    """Real paths of the images to leave out: each argument an image, or
    a list file of images (one a line, relative to the list's folder;
    blank lines and lines starting with # ignored)."""
    out = []
    for path in paths:
        if path.lower().endswith(IMAGE_EXTENSIONS):
            if not os.path.isfile(path):
                raise AnnotationError(f"{path}: --exclude: no such image")
            out.append(os.path.realpath(path))
            continue
        lines = read_lines(path, "--exclude: ")
        for number, line in enumerate(lines, 1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            image = os.path.join(os.path.dirname(path), line)
            if not os.path.isfile(image):
                raise AnnotationError(f"{path}:{number}: no such image: "
                                      f"{line}")
            out.append(os.path.realpath(image))
    return out


def class_mapping(pairs: Sequence[str], names: Sequence[str],
                  markers: Sequence[str], names_path: str = NAMES_FILE
                  ) -> Dict[str, str]:
    """{annotation class: palette marker class} from ``NAME=MARKER``
    texts, or by equal names when there are none."""
    if not pairs:
        mapping = {n: n for n in names if n in markers}
        if not mapping:
            raise CliError(
                f"no class of {names_path} ({', '.join(names)}) is a marker "
                f"class of the palette ({', '.join(markers) or 'none'}); "
                f"map them with --class NAME=MARKER")
        return mapping
    mapping = {}
    for text in pairs:
        name, sep, marker = text.partition("=")
        name, marker = name.strip(), marker.strip()
        # the first problem found, in this order, is the one reported
        problems = (
            (not sep or not name or not marker,
             f"--class: expected NAME=MARKER, got {text!r}"),
            (name not in names, f"--class {text}: {name!r} is not a class "
             f"of {names_path} ({', '.join(names)})"),
            (marker not in markers, f"--class {text}: {marker!r} is not a "
             f"marker class of the palette ({', '.join(markers)})"),
            (mapping.get(name, marker) != marker,
             f"--class: {name!r} mapped twice"),
            (marker in mapping.values() and mapping.get(name) != marker,
             f"--class: {marker!r} is mapped from two annotation classes"))
        for bad, why in problems:
            if bad:
                raise CliError(why)
        mapping[name] = marker
    return mapping


def parse_sets(texts: Sequence[str]) -> List[tuple]:
    """``element.property=value`` texts as (element, property, value)."""
    out = []
    for text in texts:
        target, sep, value = text.partition("=")
        element, dot, prop = target.partition(".")
        if not sep or not dot or not element or not prop:
            raise CliError(f"--set: expected element.property=value, got "
                           f"{text!r}")
        out.append((element.strip(), prop.strip(), value.strip()))
    return out


# -- scoring one image --------------------------------------------------------

def detection_record(d) -> Dict[str, Any]:
    """A ``meta.Detection`` as plain data: class, centre (the blob's
    sub-pixel centroid, pixel-centre coordinates), bbox, area, and the
    stage and reason that rejected it (None when accepted)."""
    blob = d.blob
    x, y, w, h = d.bbox
    centre = (blob.get("centroid-x", x + (w - 1) / 2.0),
              blob.get("centroid-y", y + (h - 1) / 2.0))
    rejected = d.rejected()
    rec = {"class": d.class_name, "centre": [round(float(c), 2)
                                             for c in centre],
           "bbox": [int(x), int(y), int(w), int(h)],
           "area": blob.get("area")}
    if rejected is not None:
        rec["rejected_by"], rec["reason"] = rejected
    if blob.get("shape-evidence"):
        rec["shape_evidence"] = blob["shape-evidence"]
        rec["arc"] = {key: round(float(blob[f"arc-{key}"]), 3)
                      for key in ("coverage", "fill")
                      if f"arc-{key}" in blob}
    rec["ellipse_fit"] = round(float(blob.get("ellipse-fit", 0)), 3)
    return rec


def score_image(truth: Sequence[TruthBox], detections: Sequence[Dict],
                mapping: Dict[str, str], width: int,
                height: int) -> Dict[str, Any]:
    """One image's truth boxes (of mapped classes only) against its
    detection records: each accepted detection of a mapped marker class
    matched to the nearest-centred not yet matched box of its class that
    holds its centre. Rejected detections are kept for study when they
    are of a mapped class, with the box that holds their centre."""
    boxes = [t for t in truth if t.name in mapping]
    mapped = set(mapping.values())
    accepted = [d for d in detections
                if "rejected_by" not in d and d["class"] in mapped]
    rejected = [d for d in detections
                if "rejected_by" in d and d["class"] in mapped]
    candidates = []
    for i, d in enumerate(accepted):
        u, v = d["centre"]
        for j, t in enumerate(boxes):
            if mapping[t.name] == d["class"] and t.contains(u, v):
                candidates.append((math.hypot(u + 0.5 - t.cx,
                                              v + 0.5 - t.cy), i, j))
    pairs = dict(nearest_first(candidates))
    found = {j: i for i, j in pairs.items()}

    def inside(d):
        u, v = d["centre"]
        return next((j for j, t in enumerate(boxes)
                     if mapping[t.name] == d["class"] and t.contains(u, v)),
                    None)

    return {
        "width": width, "height": height,
        "truth": [{"class": t.name, "marker": mapping[t.name],
                   "line": t.line,
                   "box": [round(t.cx, 2), round(t.cy, 2), round(t.w, 2),
                           round(t.h, 2)],
                   "band": t.band, "cut": t.cut(width, height),
                   "found": j in found, "detection": found.get(j)}
                  for j, t in enumerate(boxes)],
        "detections": [dict(d, matched=pairs.get(i)) for i, d in
                       enumerate(accepted)],
        "false": sum(1 for i in range(len(accepted)) if i not in pairs),
        "rejected": [dict(d, inside=inside(d)) for d in rejected],
        "unmapped": sum(1 for d in detections if "rejected_by" not in d
                        and d["class"] not in mapped),
    }


def summarise(images: Sequence[Dict[str, Any]]) -> Dict[str, Any]:
    """Recall by box width band and false detections per image over
    scored images."""
    bands = {name: {"found": 0, "total": 0} for name in BAND_NAMES}
    false = unmapped = 0
    for img in images:
        for t in img["truth"]:
            for key in (t["band"], "all"):
                bands[key]["total"] += 1
                bands[key]["found"] += t["found"]
        false += img["false"]
        unmapped += img["unmapped"]
    for b in bands.values():
        b["recall"] = b["found"] / b["total"] if b["total"] else None
    return {"images": len(images), "recall": bands, "false": false,
            "false_per_image": false / len(images) if images else None,
            "unmapped_detections": unmapped}


# -- running the chain ------------------------------------------------------

def chain_description(camera_file: Optional[str]) -> str:
    return ("labsegment name=labsegment ! blobroundness name=blobroundness"
            + (" ! ipmrange name=ipmrange" if camera_file else ""))


def configure_chain(pipe, palette: Optional[str], camera_file: Optional[str],
                    sets: Sequence[tuple]) -> None:
    """The chain's properties: palette, calibration, keep-rejected, then
    the ``--set`` ones (an unknown element or property is an error)."""
    from gi.repository import Gst
    settings = [("blobroundness", "keep-rejected", "true")]
    if palette:
        settings.append(("labsegment", "palette", palette))
    if camera_file:
        settings.append(("ipmrange", "calibration", camera_file))
    for element, prop, value in list(settings) + list(sets):
        el = pipe.get_by_name(element)
        if el is None:
            raise CliError(f"--set {element}.{prop}: no element {element!r} "
                           f"in the chain ({chain_elements(pipe)})")
        if el.find_property(prop) is None:
            raise CliError(f"--set {element}.{prop}: {element} has no "
                           f"property {prop!r}")
        Gst.util_set_object_arg(el, prop, value)


def chain_elements(pipe) -> str:
    return ", ".join(n for n in CHAIN_ELEMENTS if pipe.get_by_name(n))


@dataclass
class Item:
    """One picture to score: where it comes from and its truth."""
    label: str                  # the file (or video#frame) in reports
    truth: List[TruthBox]
    path: str = ""              # image file; "" for a video frame
    frame: int = -1             # video frame index


def run_items(items: Sequence[Item], frames: Iterable, palette, camera_file,
              sets, mapping) -> Iterator[Dict[str, Any]]:
    """Scores ``items`` with ``frames`` (their decoded BGR pictures, in the
    same order) run through one pipeline; yields each image's record."""
    from .. import pipeline
    results = pipeline.frames_through(
        chain_description(camera_file), frames,
        configure=lambda pipe: configure_chain(pipe, palette, camera_file,
                                               sets))
    try:
        for item, res in zip(items, results):
            dets = [detection_record(d) for d in res.detections]
            truth = [t.scaled(res.width, res.height) for t in item.truth]
            rec = score_image(truth, dets, mapping, res.width, res.height)
            yield {"file": item.label, **rec}
    finally:
        results.close()


def read_image(path: str):
    import cv2
    image = cv2.imread(path, cv2.IMREAD_COLOR)
    if image is None:
        raise AnnotationError(f"{path}: cannot read as an image")
    return image


def image_items(paths: Sequence[str], root: str, names: Sequence[str],
                unannotated: str = "empty") -> List[Item]:
    """The images of one folder with their truth, read now so that a bad
    annotation fails before anything runs. An image without a ``.txt``
    shows nothing (darknet's rule, ``unannotated="empty"``), is left out
    (``"skip"``) or is an error (``"error"``)."""
    items = []
    for path in paths:
        txt = annotation_path(path)
        if not os.path.isfile(txt):
            if unannotated == "skip":
                continue
            if unannotated == "error":
                raise AnnotationError(f"{path}: no annotation file {txt}")
        boxes = read_yolo(txt, names) if os.path.isfile(txt) else []
        items.append(Item(os.path.relpath(path, root), boxes, path=path))
    return items


VIDEO_LABEL = "frame_{:06d}.txt"


def video_items(video: str, labels: str,
                names: Sequence[str]) -> List[Item]:
    """The annotated frames of a video: ``labels/frame_NNNNNN.txt`` for
    frame N (from 0), in frame order."""
    if not os.path.isfile(video):
        raise AnnotationError(f"{video}: no such file")
    if not os.path.isdir(labels):
        raise AnnotationError(f"{labels}: no such folder (the annotations "
                              f"of {video}; --labels names it)")
    frames = []
    for name in sorted(os.listdir(labels)):
        stem, ext = os.path.splitext(name)
        if ext == ".txt" and stem.startswith("frame_") and \
                stem[6:].isdigit():
            frames.append(int(stem[6:]))
    if not frames:
        raise AnnotationError(f"{labels}: no frame_NNNNNN.txt annotations")
    base = os.path.basename(video)
    return [Item(f"{base}#{n}",
                 read_yolo(os.path.join(labels, VIDEO_LABEL.format(n)),
                           names), frame=n) for n in sorted(frames)]


def video_frames(video: str, items: Sequence[Item]) -> Iterator:
    """The decoded frames (OpenCV) of the annotated items, in order."""
    import cv2
    cap = cv2.VideoCapture(video)
    if not cap.isOpened():
        raise AnnotationError(f"{video}: cannot open as a video")
    try:
        n = 0
        for item in items:
            while True:
                ok, frame = cap.read()
                if not ok:
                    raise AnnotationError(
                        f"{video}: frame {item.frame} is annotated but the "
                        f"video ends after {n} frames")
                n += 1
                if n - 1 == item.frame:
                    yield frame
                    break
    finally:
        cap.release()


def image_frames(items: Sequence[Item]) -> Iterator:
    for item in items:
        yield read_image(item.path)


@dataclass
class Setup:
    """What every folder is scored with."""
    names_path: str
    names: List[str]
    mapping: Dict[str, str]
    markers: List[str]
    palette: Optional[str] = None
    camera_file: Optional[str] = None
    sets: Sequence[tuple] = ()

    @property
    def chain(self) -> str:
        return chain_description(self.camera_file)


def make_setup(start: str, names_path: Optional[str] = None,
               palette: Optional[str] = None, classes: Sequence[str] = (),
               camera_file: Optional[str] = None,
               sets: Sequence[str] = ()) -> Setup:
    """Class names (``names_path`` or the obj.names found from ``start``
    up), the palette's markers and the class mapping."""
    from ..palette import default_palette, load_palette
    if names_path is None:
        names_path = find_names(start)
        if names_path is None:
            raise CliError(f"{start}: no {NAMES_FILE} in it or a parent "
                           f"folder; give the class names with --names")
    names = read_names(names_path)
    pal = load_palette(palette) if palette else default_palette()
    if camera_file and not os.path.isfile(camera_file):
        raise CliError(f"{camera_file}: --camera-file: no such file")
    return Setup(names_path, names,
                 class_mapping(classes, names, pal.markers, names_path),
                 pal.markers, palette, camera_file, parse_sets(sets))


def score_items(setup: Setup, items: Sequence[Item], frames: Iterable,
                into: List[Dict[str, Any]],
                palette: Optional[str] = None) -> None:
    """Runs ``items`` (one folder) through one pipeline, appending each
    image's record to ``into`` as it is scored (what was scored stays
    there when something fails). ``palette`` overrides the setup's."""
    for rec in run_items(items, frames, palette or setup.palette,
                         setup.camera_file, setup.sets, setup.mapping):
        into.append(rec)


def report(setup: Setup, folders: Sequence[tuple], source: str,
           complete: bool = True, error: Optional[str] = None,
           **extra) -> Dict[str, Any]:
    """The JSON report: ``folders`` is [(name, image records)]."""
    everything = [img for _, images in folders for img in images]
    return {
        "input": source, "names": setup.names_path,
        "palette": setup.palette or "built-in", "chain": setup.chain,
        "set": [f"{e}.{p}={v}" for e, p, v in setup.sets],
        "mapping": setup.mapping,
        "unmapped_markers": [m for m in setup.markers
                             if m not in setup.mapping.values()],
        "complete": complete, **({"error": error} if error else {}),
        **extra,
        "overall": summarise(everything),
        "folders": [{"folder": name, "summary": summarise(images),
                     "images": images}
                    for name, images in folders],
    }


def format_cell(band: Dict[str, Any]) -> str:
    pct = "   -" if band["recall"] is None else \
        f"{100 * band['recall']:3.0f}%"
    return f"{band['found']:>4}/{band['total']:<4} {pct}"


def format_table(rows: Sequence[tuple]) -> str:
    """rows: [(name, summarise(...))] as a text table."""
    width = max([6] + [len(name) for name, _ in rows])
    head = (f"{'folder':<{width}}  images  " +
            "  ".join(f"{b + ' px' if b != 'all' else 'all':^14}"
                      for b in BAND_NAMES) + "   false  false/image")
    lines = [head]
    for name, s in rows:
        fpi = "-" if s["false_per_image"] is None else \
            f"{s['false_per_image']:.2f}"
        lines.append(f"{name:<{width}}  {s['images']:>6}  " +
                     "  ".join(format_cell(s["recall"][b])
                               for b in BAND_NAMES) +
                     f"  {s['false']:>6}  {fpi:>11}")
    return "\n".join(lines)


def describe_mapping(setup: Setup) -> str:
    text = ", ".join(f"{a} -> {m}" for a, m in setup.mapping.items())
    rest = [m for m in setup.markers if m not in setup.mapping.values()]
    return (f"classes scored (annotation -> palette marker): {text}"
            + (f"; markers not mapped (their detections counted apart, not "
               f"false): {', '.join(rest)}" if rest else ""))


def write_report(path: Optional[str], data: Dict[str, Any]) -> None:
    import json
    if not path:
        return
    try:
        with open(path, "w") as f:
            json.dump(data, f, indent=1)
    except OSError as err:
        raise CliError(f"{path}: cannot write: {err.strerror or err}"
                       ) from None


def add_image_options(p) -> None:
    """The options of ``evaluate FOLDER|VIDEO``."""
    g = p.add_argument_group(
        "a folder of images or a video against darknet/YOLO boxes "
        "(docs/evaluate.md)")
    options = (
        ("--palette", dict(metavar="FILE", help="labsegment's palette "
                           "(default: built-in)")),
        ("--names", dict(metavar="FILE", help="class names, one a line "
                         "(default: an obj.names in the folder or a "
                         "parent)")),
        ("--class", dict(dest="classes", action="append", default=[],
                         metavar="NAME=MARKER",
                         help="score annotation class NAME as palette "
                              "marker class MARKER (repeatable; default: "
                              "the annotation classes named like a marker "
                              "class)")),
        ("--camera-file", dict(metavar="FILE", help="add ipmrange "
                               "calibration=FILE to the chain")),
        ("--set", dict(dest="sets", action="append", default=[],
                       metavar="ELEMENT.PROPERTY=VALUE",
                       help="a property of the chain's labsegment, "
                            "blobroundness or ipmrange (repeatable)")),
        ("--exclude", dict(action="append", default=[], metavar="FILE",
                           help="leave out this image, or the images a "
                                "list file names one a line (repeatable)")),
        ("--unannotated", dict(choices=("empty", "skip", "error"),
                               default="empty",
                               help="an image without a .txt: shows "
                                    "nothing (default, darknet's rule), "
                                    "left out, or an error")),
        ("--labels", dict(metavar="DIR",
                          help="a video's annotations, frame_NNNNNN.txt "
                               "for frame N from 0 (default: the video's "
                               "path without its extension)")))
    for flag, kwargs in options:
        g.add_argument(flag, **kwargs)


def collect(source: str, setup: Setup, excludes: Sequence[str] = (),
            unannotated: str = "empty", labels: Optional[str] = None):
    """[(folder name, items, frames)] of a folder of images (every
    sub-folder apart) or of a video, truth read and checked."""
    if os.path.isdir(source):
        left_out = set(read_excludes(excludes))
        out = []
        for folder, paths in list_images(source).items():
            paths = [p for p in paths if os.path.realpath(p) not in left_out]
            items = image_items(paths, source, setup.names, unannotated)
            if items:
                name = os.path.basename(os.path.abspath(source)) \
                    if folder == "." else folder
                out.append((name, items, image_frames(items)))
        if not out:
            raise AnnotationError(f"{source}: no images to score")
        return out
    if not os.path.exists(source):
        raise AnnotationError(f"{source}: no such folder or file")
    items = video_items(source, labels or os.path.splitext(source)[0],
                        setup.names)
    return [(os.path.basename(source), items, video_frames(source, items))]


def handle(args) -> int:
    """``gst-landmark evaluate FOLDER|VIDEO``."""
    from ..pipeline import PipelineError
    source = args.result
    if not os.path.exists(source):
        raise AnnotationError(f"{source}: no such folder or file")
    start = source
    if not os.path.isdir(source):
        labels = args.labels or os.path.splitext(source)[0]
        start = labels if os.path.isdir(labels) else \
            os.path.dirname(os.path.abspath(source))
    setup = make_setup(start, args.names, args.palette, args.classes,
                       args.camera_file, args.sets)
    groups = collect(source, setup, args.exclude, args.unannotated,
                     args.labels)
    print(describe_mapping(setup))
    folders: List[tuple] = []
    status, error = 0, None
    try:
        for name, items, frames in groups:
            images: List[Dict[str, Any]] = []
            folders.append((name, images))
            score_items(setup, items, frames, images)
    except KeyboardInterrupt:
        status, error = 130, "interrupted"
    except (AnnotationError, PipelineError) as err:
        status, error = 1, str(err)
    data = report(setup, folders, source, complete=status == 0, error=error,
                  excluded=sorted(read_excludes(args.exclude)))
    rows = [(f["folder"], f["summary"]) for f in data["folders"]]
    print(format_table(rows + [("overall", data["overall"])]))
    write_report(args.json, data)
    if args.json:
        print(f"wrote {args.json}")
    if error:
        print(f"gst-landmark: error: {error}" + (
            "; what was scored before is reported above" if folders else ""),
            file=sys.stderr)
    return status
