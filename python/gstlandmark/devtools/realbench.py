"""``gst-landmark bench real``: the real-footage benchmark of issue 29 on
the RoboCup MSL frames (``../shared/data/msl`` beside the source tree;
docs/evaluate.md).

For each folder:

1. the teaching image is the first image in sorted (file name) order
   that has a clear ball: a ``ball`` box at least 30 px wide that the
   border does not cut (no edge within a pixel of the image's) and that
   overlaps no other annotated box (a ball behind a leg or at a robot's
   foot shows the leg or the robot inside its box);
2. the palette is taught from it the documented way (``palette learn
   --mask`` with its defaults: ``gstlandmark.palette.learn_from_mask``,
   references ``auto``, the ``untaught`` class): that ball painted as the
   ellipse inscribed in its box (class ``ball``, marker), the image's
   other balls and a 2-px ring around every ball left unlabelled, the
   rest of the image one background class (``background``);
3. the folder is scored by ``gst-landmark evaluate`` (the default chain,
   ``labsegment palette=P ! blobroundness``, annotation class ``ball`` as
   marker ``ball``) with the teaching image left out.

The split was fixed before anything was tuned: tuning folders
20190606/r4, 20220715/r7, 20240222/r12; held-out folders 20190606/r2,
20240222/r14, 20240222/r15. The table gives each folder and the totals of
both sets.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
from typing import Any, Dict, List, Optional

import cv2
import numpy as np

from ..commands import evalimages as E
from ..commands.common import CliError, add_json_option
from ..palette import learn_from_mask, load_palette, save_palette
from . import sourcetree

DATA = os.path.normpath(os.path.join(sourcetree.ROOT, os.pardir, "shared",
                                     "data", "msl"))
TUNING = ("20190606/r4", "20220715/r7", "20240222/r12")
HELD_OUT = ("20190606/r2", "20240222/r14", "20240222/r15")
BALL = "ball"
BACKGROUND = "background"
MIN_TEACHING_WIDTH = 30.0   # px, the teaching ball's box
RING_PX = 2                 # unlabelled ring around each painted ball


def _overlap(a, b) -> bool:
    return (abs(a.cx - b.cx) * 2 < a.w + b.w and
            abs(a.cy - b.cy) * 2 < a.h + b.h)


def teaching_image(items: List[E.Item]):
    """(item, image, the clear ball, every ball box; in pixels) of the
    first item (sorted order, as image_items gives them) with a clear
    ball: an uncut ball box at least MIN_TEACHING_WIDTH wide overlapping
    no other box; or None."""
    for item in items:
        if not any(t.name == BALL and t.w > 0 for t in item.truth):
            continue
        image = E.read_image(item.path)
        height, width = image.shape[:2]
        boxes = [t.scaled(width, height) for t in item.truth]
        balls = [b for b in boxes if b.name == BALL]
        for b in balls:
            if (b.w >= MIN_TEACHING_WIDTH and not b.cut(width, height) and
                    not any(o is not b and _overlap(b, o) for o in boxes)):
                return item, image, b, balls
    return None


def teaching_mask(shape, taught, balls=()) -> np.ndarray:
    """uint8 mask: 1 inside the ellipse inscribed in the taught ball's box
    (a pixel whose centre lies inside), 0 inside the other balls' and on
    a RING_PX ring around every ball, 2 everywhere else."""
    height, width = shape[:2]
    v, u = np.mgrid[0:height, 0:width]

    def inside(b):
        return (((u + 0.5 - b.cx) / (b.w / 2)) ** 2 +
                ((v + 0.5 - b.cy) / (b.h / 2)) ** 2) <= 1.0

    ball = inside(taught)
    any_ball = ball.copy()
    for b in balls:
        any_ball |= inside(b)
    kernel = cv2.getStructuringElement(
        cv2.MORPH_ELLIPSE, (2 * RING_PX + 1, 2 * RING_PX + 1))
    near = cv2.dilate(any_ball.astype(np.uint8), kernel).astype(bool)
    mask = np.full((height, width), 2, np.uint8)
    mask[near] = 0
    mask[ball] = 1
    return mask


def teach(image, taught, balls, path: str, source: str):
    """Learns and writes the folder's palette; returns it."""
    palette = learn_from_mask(image, teaching_mask(image.shape, taught,
                                                   balls),
                              names=[BALL, BACKGROUND], markers=[BALL],
                              references="auto", untaught_class="untaught")
    save_palette(palette, path,
                 description="Taught by 'gst-landmark bench real': the "
                             "clear ball of one image painted, the rest "
                             "background.", **{"learned-from": source})
    return palette


def palette_name(folder: str) -> str:
    return folder.replace("/", "-") + ".json"


def run(data: str, folders, palette_dir: str, sets=(),
        progress=print) -> Dict[str, Any]:
    """Teaches and scores each folder; returns the report (with
    ``complete`` false and what was scored when interrupted or failing)."""
    names_path = os.path.join(data, E.NAMES_FILE)
    out: Dict[str, Any] = {
        "data": data, "tuning": list(TUNING), "held_out": list(HELD_OUT),
        "teaching_rule": (f"first image in sorted order with a clear "
                          f"{BALL} (uncut, >= {MIN_TEACHING_WIDTH:g} px "
                          f"wide, overlapping no other box); it painted as "
                          f"its inscribed ellipse, other {BALL}s and a "
                          f"{RING_PX}-px ring unlabelled, the rest "
                          f"{BACKGROUND}"),
        "set": list(sets), "complete": False, "folders": []}
    try:
        for folder in folders:
            root = os.path.join(data, folder)
            if not os.path.isdir(root):
                raise CliError(f"{root}: no such folder")
            items = E.image_items(E.list_images(root).get(".", []), data,
                                  E.read_names(names_path))
            chosen = teaching_image(items)
            if chosen is None:
                raise CliError(f"{root}: no image with a clear {BALL} "
                               f"(uncut, >= {MIN_TEACHING_WIDTH:g} px, "
                               f"overlapping no other box) to teach on")
            item, image, clear, balls = chosen
            palette_path = os.path.join(palette_dir, palette_name(folder))
            if os.path.isfile(palette_path):
                palette = load_palette(palette_path)
                taught = False
            else:
                palette = teach(image, clear, balls, palette_path, item.path)
                taught = True
            setup = E.make_setup(root, names_path, palette_path, (), None,
                                 sets)
            images: List[Dict[str, Any]] = []
            entry = {"folder": folder,
                     "set": "tuning" if folder in TUNING else
                            "held-out" if folder in HELD_OUT else "other",
                     "teaching_image": item.label, "palette": palette_path,
                     "palette_taught": taught,
                     "palette_classes": palette.names,
                     "mapping": setup.mapping, "images": images}
            out["folders"].append(entry)
            progress(f"{folder}: taught on {os.path.basename(item.path)} "
                     f"(its ball of {clear.w:.0f} px of {len(balls)}); "
                     f"{'taught' if taught else 'reused'} {palette_path}")
            rest = [i for i in items if i.path != item.path]
            E.score_items(setup, rest, E.image_frames(rest), images)
        out["complete"] = True
    except KeyboardInterrupt:
        out["error"] = "interrupted"
    except (CliError, E.AnnotationError) as err:
        out["error"] = str(err)
    finally:
        for entry in out["folders"]:
            entry["summary"] = E.summarise(entry["images"])
        out["totals"] = totals(out["folders"])
    return out


def totals(entries) -> Dict[str, Any]:
    groups = {"tuning": [], "held-out": [], "all": []}
    for entry in entries:
        groups["all"] += entry["images"]
        if entry["set"] in groups:
            groups[entry["set"]] += entry["images"]
    return {name: E.summarise(images) for name, images in groups.items()}


def format_report(out: Dict[str, Any]) -> str:
    rows = [(f"{e['folder']} ({e['set']})", e["summary"])
            for e in out["folders"]]
    rows += [(f"total {name}", s) for name, s in out["totals"].items()]
    return E.format_table(rows)


def _handle(args) -> int:
    folders = args.folder or list(TUNING + HELD_OUT)
    if not os.path.isdir(args.data):
        raise CliError(f"{args.data}: no such folder (the MSL frames; "
                       f"--data names them)")
    with tempfile.TemporaryDirectory(prefix="realbench-") as tmp:
        palette_dir = args.palette_dir or tmp
        os.makedirs(palette_dir, exist_ok=True)
        out = run(args.data, folders, palette_dir, args.sets,
                  progress=lambda text: print(text, file=sys.stderr))
    print(format_report(out))
    if args.json:
        try:
            with open(args.json, "w") as f:
                json.dump(out, f, indent=1)
        except OSError as err:
            raise CliError(f"{args.json}: cannot write: "
                           f"{err.strerror or err}") from None
        print(f"wrote {args.json}")
    if not out["complete"]:
        print(f"gst-landmark: error: {out['error']}; what was scored is "
              f"reported above", file=sys.stderr)
        return 130 if out["error"] == "interrupted" else 1
    return 0


def add_real_bench_parser(actions, data: Optional[str] = None) -> None:
    p = actions.add_parser(
        "real", help="ball recall and false detections on the real MSL "
                     "frames (tuning and held-out folders)",
        description=__doc__.split("\n\n")[0].replace("``", ""))
    p.add_argument("--data", default=data or DATA, metavar="DIR",
                   help=f"the MSL frames (default {DATA})")
    p.add_argument("--folder", action="append", metavar="F",
                   help="score only this folder of the set (repeatable; "
                        "default the six: tuning " + ", ".join(TUNING) +
                        "; held-out " + ", ".join(HELD_OUT) + ")")
    p.add_argument("--palette-dir", metavar="DIR",
                   help="write each folder's palette here, or reuse the "
                        "one already there (default: a temporary folder)")
    p.add_argument("--set", dest="sets", action="append", default=[],
                   metavar="ELEMENT.PROPERTY=VALUE",
                   help="passed to evaluate's chain (repeatable)")
    add_json_option(p, "the report, every image's boxes and detections,",
                    dash_o=True)
    p.set_defaults(handler=_handle)
