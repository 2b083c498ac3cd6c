"""The ``gst-landmark`` command.

Each top-level command is added by an ``add_<name>_parser(subparsers)``
function listed in ``COMMANDS``.  That function creates its parser(s) and
calls ``set_defaults(handler=...)``; a handler takes the parsed arguments
and returns the exit status.  Handlers report bad input by raising
``CliError`` (or ``PaletteError``); ``main`` prints it and returns 1.
Usage errors exit with status 2, as argparse does.
"""

import argparse
import dataclasses
import json
import os
import sys

import cv2
import numpy as np

from .. import __version__
from .. import paletteaudit
from .. import reference
from ..palette import (MAX_REFERENCES, Palette, PaletteError,
                       default_palette, default_palette_text,
                       learn_from_images, learn_from_mask, load_palette,
                       parse_shading, save_palette)
from .common import PROG, CliError, add_actions


class _Parser(argparse.ArgumentParser):
    # Every usage error reads "gst-landmark: error: ...", whichever
    # subcommand's parser found it.
    def error(self, message):
        self.print_usage(sys.stderr)
        self.exit(2, f"{PROG}: error: {message}\n")


# ---------------------------------------------------------------------------
# Shared helpers


def _split_list(text):
    """"red, green" -> ["red", "green"]; None stays None."""
    if text is None:
        return None
    return [item.strip() for item in text.split(",")]


def _read_image(path, flags=cv2.IMREAD_COLOR):
    """Read an image (default 8-bit BGR) or raise CliError."""
    if not os.path.isfile(path):
        raise CliError(f"{path}: no such file")
    image = cv2.imread(path, flags)
    if image is None:
        raise CliError(f"{path}: cannot read as an image")
    return image


def _read_mask(path):
    """Read a class-index mask as a single-channel integer image."""
    mask = _read_image(path, cv2.IMREAD_UNCHANGED)
    if mask.ndim == 3:
        colour = mask[:, :, :3]
        # A grey mask saved as RGB is fine; real colours are not indices.
        if mask.shape[2] == 4 or not (
                np.array_equal(colour[:, :, 0], colour[:, :, 1])
                and np.array_equal(colour[:, :, 0], colour[:, :, 2])):
            raise CliError(
                f"{path}: the mask must be a single-channel image of class "
                f"indices (0 = ignore, 1..K); save it as 8-bit greyscale "
                f"(indexed-colour PNGs are read as colours)")
        mask = colour[:, :, 0]
    if not np.issubdtype(mask.dtype, np.integer):
        raise CliError(f"{path}: the mask must hold integer class "
                       f"indices, got {mask.dtype}")
    return mask


def format_palette_table(palette):
    """The classes as a text table: name, L*, a*, b*, role, sRGB hex."""
    srgb = reference.lab_to_srgb8(palette.lab_array())
    width = max([4] + [len(name) for name in palette.names])
    lines = [f"{'name':<{width}}  {'L*':>7}  {'a*':>7}  {'b*':>7}  "
             f"{'role':<10}  sRGB"]
    for cls, rgb in zip(palette.classes, srgb):
        lightness, a_star, b_star = cls.lab
        hex_colour = "#{:02X}{:02X}{:02X}".format(*rgb)
        lines.append(f"{cls.name:<{width}}  {lightness:7.2f}  "
                     f"{a_star:7.2f}  {b_star:7.2f}  "
                     f"{cls.role:<10}  {hex_colour}")
        for ref in cls.references:
            lines.append(f"{'':<{width}}  {ref[0]:7.2f}  {ref[1]:7.2f}  "
                         f"{ref[2]:7.2f}  reference")
    return "\n".join(lines)


# ---------------------------------------------------------------------------
# gst-landmark palette ...


def _parse_rect(text):
    """argparse type for --rect NAME:X,Y,W,H."""
    name, sep, numbers = text.rpartition(":")
    parts = numbers.split(",")
    try:
        if not sep or not name or len(parts) != 4:
            raise ValueError
        x, y, w, h = (int(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected NAME:X,Y,W,H, got {text!r}") from None
    if w <= 0 or h <= 0:
        raise argparse.ArgumentTypeError(
            f"width and height must be positive in {text!r}")
    return (name, x, y, w, h)


def _parse_references(text):
    """argparse type for --references N|auto."""
    if text == "auto":
        return text
    try:
        count = int(text)
    except ValueError:
        count = 0
    if not 1 <= count <= MAX_REFERENCES:
        raise argparse.ArgumentTypeError(
            f"expected auto or 1 to {MAX_REFERENCES}, got {text!r}")
    return count


class _ImageAction(argparse.Action):
    """--image FILE: one more teaching image; the --rect options after it
    are its rectangles."""
    def __call__(self, parser, namespace, value, option_string=None):
        setattr(namespace, self.dest,
                list(getattr(namespace, self.dest) or []) + [value])


class _RectAction(argparse.Action):
    """--rect NAME:X,Y,W,H, kept with the teaching image it follows: 0
    for IMAGE, i for the i-th --image."""
    def __call__(self, parser, namespace, value, option_string=None):
        image = len(getattr(namespace, "extra_images", None) or [])
        setattr(namespace, self.dest,
                list(getattr(namespace, self.dest) or []) + [(image, value)])


def _rect_groups(args):
    """[(image path, [rect, ...]), ...] from IMAGE, --image and --rect;
    an image without a rectangle is a usage error naming it."""
    paths = [args.image, *(args.extra_images or [])]
    groups = [(path, [r for i, r in args.rect if i == k])
              for k, path in enumerate(paths)]
    for k, (path, rects) in enumerate(groups):
        if not rects:
            where = "IMAGE" if k == 0 else "--image"
            args.parser.error(f"{where} {path}: no --rect follows it (give "
                              f"each image its rectangles after it)")
    return groups


def _print_findings(findings, file):
    for finding in findings:
        print(f"warning: {finding.text}", file=file)


def _parse_shading(text):
    try:
        values = tuple(float(v) for v in text.split(","))
        return parse_shading(list(values), "--shading")
    except (ValueError, PaletteError) as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def _palette_learn(args):
    extra = {}
    if args.mask is not None:
        if args.background is not None:
            args.parser.error("--background goes with --rect; with --mask "
                              "use --markers")
        if args.extra_images:
            args.parser.error("--image goes with --rect: several images are "
                              "taught by rectangles")
        image = _read_image(args.image)
        mask = _read_mask(args.mask)
        palette = learn_from_mask(image, mask, names=_split_list(args.names),
                                  markers=_split_list(args.markers),
                                  allow_missing=args.allow_missing,
                                  references=args.references,
                                  floor=_split_list(args.floor),
                                  untaught_class=None
                                  if args.untaught == "none"
                                  else args.untaught)
        description = (f"Learned by '{PROG} palette learn' from the class "
                       f"mask {args.mask}.")
        findings = []
        sources = args.image
    else:
        if (args.names is not None or args.markers is not None
                or args.allow_missing):
            args.parser.error("--names, --markers and --allow-missing go "
                              "with --mask; with --rect use --background")
        groups = _rect_groups(args)
        images = [_read_image(path) for path, _ in groups]
        palette = learn_from_images(
            [(image, rects) for image, (_, rects) in zip(images, groups)],
            background=_split_list(args.background),
            references=args.references, floor=_split_list(args.floor),
            untaught_class=None if args.untaught == "none"
            else args.untaught,
            sources=[path for path, _ in groups])
        count = sum(len(rects) for _, rects in groups)
        description = (f"Learned by '{PROG} palette learn' from {count} "
                       f"rectangle(s)"
                       + (f" in {len(groups)} images." if len(groups) > 1
                          else "."))
        findings, extra["spread"] = paletteaudit.teaching_findings(
            palette, [(path, reference.rgb_to_lab(
                np.ascontiguousarray(image[:, :, ::-1])), rects)
                for image, (path, rects) in zip(images, groups)])
        sources = args.image if len(groups) == 1 else \
            [path for path, _ in groups]
    if args.shading is not None:
        palette = Palette([dataclasses.replace(c, shading=args.shading)
                           if c.marker else c for c in palette.classes])
    try:
        save_palette(palette, args.output, description=description,
                     **{"learned-from": sources}, **extra)
    except OSError as err:
        raise CliError(f"{args.output}: cannot write: "
                       f"{err.strerror or err}") from None
    print(format_palette_table(palette))
    print(f"wrote {args.output}")
    _print_findings(findings, sys.stderr)
    if args.untaught != "none" and args.untaught in palette.names \
            and not palette.floor:
        left_out = "what the mask left out" if args.mask is not None \
            else "the image outside the rectangles"
        print(f"note: no --floor class: floorboundary takes every class "
              f"that is not a marker as floor, {args.untaught!r} "
              f"({left_out}) included; name the floor with --floor",
              file=sys.stderr)
    return 0


def _read_spreads(path):
    """The "spread" object ``palette learn`` writes at the top level of a
    palette ({} when there is none)."""
    try:
        with open(path, "rb") as f:
            spreads = json.loads(f.read().decode("utf-8")).get("spread")
    except (OSError, ValueError, AttributeError):
        return {}
    return spreads if isinstance(spreads, dict) else {}


def _palette_check(args):
    palette = load_palette(args.file)
    print(f"{args.file}: valid, {len(palette)} classes "
          f"({len(palette.markers)} markers)")
    print(format_palette_table(palette))
    images = [(path, _read_image(path)) for path in args.images]
    findings = paletteaudit.reference_overlaps(palette,
                                               _read_spreads(args.file))
    for path, image in images:
        labels = paletteaudit.classify(palette, image)
        shares = paletteaudit.class_shares(palette, labels)
        print(f"{path}: " + ", ".join(
            f"{name} {100 * share:.2f} %"
            for name, share in zip(palette.names, shares)))
        findings += paletteaudit.image_findings(palette, labels, path)
    _print_findings(findings, sys.stdout)
    if findings:
        print(f"{len(findings)} warning(s)")
    return 1 if findings and args.strict else 0


def _palette_show_default(args):
    default_palette()  # validate before showing it
    sys.stdout.write(default_palette_text())
    return 0


def add_palette_parser(subparsers):
    parser = subparsers.add_parser(
        "palette", help="learn, check and show colour palettes",
        description="Learn, check and show colour palettes.")
    actions = add_actions(parser)

    learn = actions.add_parser(
        "learn", help="learn a palette from an image",
        description="Learn a palette: each class gets the mean L*a*b* of "
                    "its pixels, marked either by a class-index mask or by "
                    "rectangles, and as many reference colours as its "
                    "pixels show tones (a ball lit and shaded).")
    learn.add_argument("--allow-missing", action="store_true",
                       help="with --mask: leave out classes with no pixels "
                            "(with a warning) instead of failing")
    learn.add_argument("image", metavar="IMAGE", help="the example image")
    learn.add_argument("--image", dest="extra_images", metavar="FILE",
                       action=_ImageAction,
                       help="with --rect: one more example image, taught by "
                            "the --rect options that follow it (repeatable; "
                            "each class's pixels are pooled over the "
                            "images)")
    source = learn.add_mutually_exclusive_group(required=True)
    source.add_argument("--mask", metavar="MASK",
                        help="greyscale image of class indices: 0 = ignore, "
                             "k = class k (1..K)")
    source.add_argument("--rect", metavar="NAME:X,Y,W,H", action=_RectAction,
                        type=_parse_rect,
                        help="pixels of class NAME in the image it follows "
                             "(repeatable; rectangles of one name are "
                             "pooled)")
    class_lists = {
        "--names": "with --mask: class names in index order (default "
                   "class1..classK)",
        "--markers": "with --mask: the marker classes (default all)",
        "--background": "with --rect: the non-marker classes",
        "--floor": "the floor classes (role floor: what floorboundary "
                   "takes as floor); not markers",
    }
    for flag, text in class_lists.items():
        learn.add_argument(flag, metavar="N1,N2,...", help=text)
    learn.add_argument("--references", metavar="N|auto",
                       type=_parse_references, default="auto",
                       help="reference colours per class: auto (default: "
                            "k-means in L*a*b*, adding one while it halves "
                            "the spread, up to 4; docs/palette.md) or N")
    learn.add_argument("--shading", metavar="DARKEST,LIGHTEST",
                       type=_parse_shading, default=None,
                       help="marker classes stand for their colours from "
                            "DARKEST to LIGHTEST times the light they were "
                            "taught in, e.g. 0.25,1.5 (docs/palette.md, "
                            "\"Shading\"; default: the taught colours)")
    learn.add_argument("--untaught", metavar="NAME|none", default="untaught",
                       help="a background class of this name learned from "
                            "the rest of the image (outside the mask's "
                            "classes, or the rectangles and a margin around "
                            "them) where it is far from every taught colour "
                            "(the sky, walls), when that covers 1 %% of the "
                            "image (default: untaught); none: no such class")
    learn.add_argument("-o", "--output", metavar="OUT.json", required=True,
                       help="palette file to write")
    learn.set_defaults(handler=_palette_learn, parser=learn)

    check = actions.add_parser(
        "check", help="validate a palette file and list its classes",
        description="Validate a palette file and list its classes; with "
                    "images, classify each and print the share of it every "
                    "class takes, with warnings where the palette labels "
                    "it wrongly (docs/palette.md, \"Checking a palette\").")
    check.add_argument("file", metavar="FILE")
    check.add_argument("images", metavar="IMAGE", nargs="*",
                       help="images to classify with the palette")
    check.add_argument("--strict", action="store_true",
                       help="exit with status 1 when there is a warning "
                            "(default: 0, the warnings printed)")
    check.set_defaults(handler=_palette_check, parser=check)

    show = actions.add_parser(
        "show-default", help="print the built-in default palette",
        description="Print the built-in default palette as JSON.")
    show.set_defaults(handler=_palette_show_default, parser=show)


# ---------------------------------------------------------------------------
# Command registry and entry point

def _lazy(module, function):
    """A command from another module (``commands.X`` or ``devtools.X``),
    imported by name when the parser is built (keeps ``import
    gstlandmark.commands.cli`` free of GStreamer)."""
    def add(subparsers):
        import importlib
        getattr(importlib.import_module(f"gstlandmark.{module}"),
                function)(subparsers)
    return add


# To add a command, write add_<name>_parser(subparsers) and list it here.
COMMANDS = [
    add_palette_parser,
    _lazy("commands.demo", "add_demo_parser"),
    _lazy("devtools.bench", "add_bench_parser"),
    _lazy("devtools.regress", "add_regress_parser"),
    _lazy("commands.evaluate", "add_evaluate_parser"),
    _lazy("commands.synth", "add_synth_parser"),
    _lazy("commands.calibrate", "add_calibrate_parser"),
    _lazy("commands.runner", "add_run_parser"),
    _lazy("devtools.soak", "add_soak_parser"),
    _lazy("commands.record", "add_record_parser"),
    _lazy("commands.fleet", "add_fleet_parser"),
    _lazy("devtools.sweep", "add_sweep_parser"),
    _lazy("devtools.mcapview", "add_mcapview_parser"),
    _lazy("commands.console", "add_console_parser"),
    _lazy("commands.floormap", "add_floormap_parser"),
]


def build_parser():
    parser = _Parser(prog=PROG,
                     description="Colour landmark localisation tools.")
    parser.add_argument("--version", action="version",
                        version=f"%(prog)s {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND",
                                       required=True)
    for add_parser in COMMANDS:
        add_parser(subparsers)
    return parser


def main(argv=None):
    """Run the command line ``argv`` (default sys.argv[1:]); return the
    exit status."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        return args.handler(args)
    except SystemExit as exc:
        # argparse exits for --help and usage errors; report its status.
        if exc.code is None or isinstance(exc.code, int):
            return exc.code or 0
        print(exc.code, file=sys.stderr)
        return 1
    except (CliError, PaletteError) as err:
        print(f"{PROG}: error: {err}", file=sys.stderr)
        return getattr(err, "status", 1)


if __name__ == "__main__":
    sys.exit(main())
