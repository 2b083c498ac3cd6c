"""Warnings that a palette will label a scene wrongly.

``palette learn`` and ``palette check`` print these (docs/palette.md,
"Checking a palette"): a taught box that holds two colours, taught pixels
that the palette gives another class, classes whose references lie within
a class's own spread of each other, and, on an image, a marker class that
covers a large or non-round part of it.  Every finding names the class and
the number it was judged by.
"""

from dataclasses import dataclass
import json

import cv2
import numpy as np

from gstlandmark import palette as pal
from gstlandmark import reference

# a marker is a small thing in the scene: a marker class taking more than
# this share of an image is labelling something else (a wall, a floor)
MARKER_MAX_SHARE = 0.05
# connected blobs of a marker class of at least this share of the image
# (about a 35 px disc at 608x800) are looked at for their shape, the
# largest BLOBS_LOOKED_AT of them
LARGE_BLOB_SHARE = 0.002
BLOBS_LOOKED_AT = 3
# a large blob filling less than this share of its enclosing circle is not
# a ball or a disc: a digitised disc fills 0.9 or more, a disc seen at a
# slant of axis ratio 0.5 or a ball half of which is shaded away 0.5, a
# bar of 1 by 3.6 or a line less (a disc on the floor seen flatter than
# axis ratio 0.25 warns too)
MIN_BLOB_FILL = 0.25
# more than this share of a class's taught pixels labelled another class
MAX_TAUGHT_CONFUSED = 0.05
# two classes whose nearest references are closer than this many times a
# class's spread (the RMS Delta E of its taught pixels to its nearest
# reference) overlap: for pixels spread evenly in L*, a* and b* about their
# reference, more than about MAX_TAUGHT_CONFUSED of them lie nearer the
# other class (half the distance is the spread, 1.7 sigma along the line)
OVERLAP_SPREADS = 2.0
# a taught rectangle holds two colours when its pixels split (2-means in
# L*a*b*) into clusters whose smaller one holds at least this share
TWO_COLOUR_MIN_SHARE = 0.15
# ... whose centres are at least this far apart (Delta E) ...
TWO_COLOUR_MIN_DISTANCE = 15.0
# ... and whose chromaticities differ by at least this much once shading is
# taken out: shading scales (L* + 16, a*, b*) by one factor (the cube root
# of the light's), so the darker centre is scaled up to the lighter one's
# L* before their a*, b* are compared; a ball's lit and shaded sides stay
# close, a ball and the floor in its box's corners do not
TWO_COLOUR_MIN_CHROMA_DISTANCE = 15.0


@dataclass(frozen=True)
class Finding:
    """One warning: ``kind`` ("covers", "shape", "overlap",
    "two-colours"), the class ``name``, the ``value`` it was judged by and
    the ``text`` printed."""
    kind: str
    name: str
    value: float
    text: str


def classify(palette, image_bgr):
    """The label plane of an 8-bit BGR image, every pixel to the class of
    its nearest reference (labsegment with min-class-pixels=0)."""
    rgb = np.ascontiguousarray(np.asarray(image_bgr)[:, :, ::-1])
    return reference.segment_rgb(rgb, palette, min_class_pixels=0).labels


def class_shares(palette, labels):
    """Per class in label order, the share of the image it takes."""
    counts = np.bincount(labels.ravel(), minlength=len(palette) + 1)
    return counts[1:len(palette) + 1] / max(labels.size, 1)


def blob_fills(mask, min_pixels, count=BLOBS_LOOKED_AT):
    """The largest ``count`` 8-connected blobs of a bool mask of at least
    ``min_pixels`` pixels: [(pixels, fill, (x, y, w, h))], largest first;
    fill is the blob's area over that of its enclosing circle."""
    n, cc, stats, _ = cv2.connectedComponentsWithStats(
        mask.astype(np.uint8), connectivity=8)
    big = [i for i in range(1, n) if stats[i, cv2.CC_STAT_AREA] >= min_pixels]
    big.sort(key=lambda i: -stats[i, cv2.CC_STAT_AREA])
    blobs = []
    for i in big[:count]:
        x, y, w, h, area = (int(v) for v in stats[i])
        ys, xs = np.nonzero(cc[y:y + h, x:x + w] == i)
        points = np.stack([xs + x, ys + y], axis=1).astype(np.float32)
        _, radius = cv2.minEnclosingCircle(points)
        # pixels are unit squares: the circle through their centres is
        # half a pixel short of their outline
        fill = area / (np.pi * (radius + 0.5) ** 2)
        blobs.append((area, float(fill), (x, y, w, h)))
    return blobs


def image_findings(palette, labels, source="image"):
    """Warnings about an image's labels: a marker class taking more than
    MARKER_MAX_SHARE of it, or whose large blobs fill less than
    MIN_BLOB_FILL of their enclosing circle."""
    findings = []
    shares = class_shares(palette, labels)
    min_pixels = max(1, int(LARGE_BLOB_SHARE * labels.size))
    for k, cls in enumerate(palette.classes):
        if not cls.marker:
            continue
        name = json.dumps(cls.name)
        if shares[k] > MARKER_MAX_SHARE:
            findings.append(Finding(
                "covers", cls.name, float(shares[k]),
                f"{source}: marker class {name} covers "
                f"{100 * shares[k]:.2f} % of the image (a marker should "
                f"take less than {100 * MARKER_MAX_SHARE:.0f} %): it labels "
                f"something else of its colour; teach that as a background "
                f"class, or let the untaught class learn it"))
        for area, fill, (x, y, w, h) in blob_fills(labels == k + 1,
                                                    min_pixels):
            if fill < MIN_BLOB_FILL:
                findings.append(Finding(
                    "shape", cls.name, fill,
                    f"{source}: marker class {name} has a blob of {area} "
                    f"pixels at {x},{y},{w},{h} that fills {fill:.2f} of "
                    f"its enclosing circle (a disc fills 0.9, less than "
                    f"{MIN_BLOB_FILL:.2f} is no ball or disc): a wall, "
                    f"line or robot of its colour; teach it as a "
                    f"background class"))
    return findings


def _nearest_owner(pixels, palette):
    """Class index of each (N, 3) L*a*b* pixel, as labsegment gives it
    (every reference, shading segments included; no dominant rule)."""
    refs, owner = palette.reference_arrays()
    lab = np.asarray(pixels, dtype=np.float32).reshape(-1, 1, 3)
    labels = reference.classify(lab, refs, ref_class=owner,
                                min_class_pixels=0,
                                shading=palette.shading_arrays()).labels
    return labels.reshape(-1).astype(np.int64) - 1


def class_spread(pixels, cls):
    """RMS Delta E of a class's (N, 3) pixels to its nearest reference."""
    refs = np.asarray(cls.reference_labs, dtype=np.float64)
    d2 = ((pixels[:, None, :] - refs[None, :, :]) ** 2).sum(axis=2)
    return float(np.sqrt(d2.min(axis=1).mean()))


def taught_confusions(palette, class_pixels):
    """Warnings for classes of which more than MAX_TAUGHT_CONFUSED of the
    taught pixels (``class_pixels``: name -> (N, 3) L*a*b*) take another
    class, naming that class."""
    findings = []
    for name, pixels in class_pixels.items():
        if name not in palette.names or not len(pixels):
            continue
        k = palette.index(name)
        owner = _nearest_owner(pal.sample_pixels(pixels, 0), palette)
        wrong = np.bincount(owner, minlength=len(palette)) / len(owner)
        wrong[k] = 0.0
        other = int(np.argmax(wrong))
        if wrong[other] > MAX_TAUGHT_CONFUSED:
            findings.append(Finding(
                "overlap", name, float(wrong[other]),
                f"classes {json.dumps(name)} and "
                f"{json.dumps(palette.names[other])} overlap: "
                f"{100 * wrong[other]:.1f} % of the pixels taught as "
                f"{json.dumps(name)} are labelled "
                f"{json.dumps(palette.names[other])}; teach them on "
                f"regions that hold only their colour, or merge them"))
    return findings


def reference_overlaps(palette, spreads):
    """Warnings for pairs of classes whose nearest references are closer
    than OVERLAP_SPREADS times one class's spread (``spreads``: name ->
    RMS Delta E of its taught pixels, as ``palette learn`` writes them):
    a good share of that class's pixels then fall on the other's side."""
    findings = []
    for a in palette.classes:
        spread = spreads.get(a.name)
        if not isinstance(spread, (int, float)) or isinstance(spread, bool):
            continue
        refs_a = np.asarray(a.reference_labs, dtype=np.float64)
        for b in palette.classes:
            if b.name == a.name:
                continue
            refs_b = np.asarray(b.reference_labs, dtype=np.float64)
            d = float(np.sqrt(((refs_a[:, None] - refs_b[None]) ** 2)
                              .sum(axis=2).min()))
            if d < OVERLAP_SPREADS * spread:
                findings.append(Finding(
                    "overlap", a.name, d,
                    f"classes {json.dumps(a.name)} and {json.dumps(b.name)} "
                    f"overlap: their references are Delta E {d:.1f} apart, "
                    f"less than {OVERLAP_SPREADS:g} times the spread of "
                    f"{json.dumps(a.name)}'s taught pixels ({spread:.1f}): "
                    f"some of its pixels take {json.dumps(b.name)}; teach "
                    f"them on regions that hold only their colour, or "
                    f"merge them"))
    return findings


def two_colours(pixels):
    """Whether (N, 3) L*a*b* pixels are two colours rather than the tones
    of one: None, or (share of the smaller cluster, the two centres
    largest first, their Delta E, their chromatic distance with shading
    taken out)."""
    pixels = np.asarray(pixels, dtype=np.float64).reshape(-1, 3)
    data = np.ascontiguousarray(pal.sample_pixels(pixels, 0), dtype=np.float32)
    if len(np.unique(data, axis=0)) < 2:
        return None
    _, labels, centres = pal.kmeans(data, 2, 0)
    counts = np.bincount(labels, minlength=2)
    order = np.argsort(-counts)
    centres = centres[order]
    share = counts[order[1]] / len(data)
    distance = float(np.linalg.norm(centres[0] - centres[1]))
    light, dark = sorted(centres, key=lambda c: -c[0])
    scale = (light[0] + 16.0) / max(dark[0] + 16.0, 1e-6)
    chroma = float(np.linalg.norm(light[1:] - scale * dark[1:]))
    if (share >= TWO_COLOUR_MIN_SHARE and distance >= TWO_COLOUR_MIN_DISTANCE
            and chroma >= TWO_COLOUR_MIN_CHROMA_DISTANCE):
        return share, centres, distance, chroma
    return None


def rect_findings(lab, rects, source=None):
    """Warnings for the rectangles ``[(name, x, y, w, h)]`` of one teaching
    image (``lab``: its L*a*b*) that hold two colours."""
    findings = []
    where = f"{source}: " if source else ""
    for name, x, y, w, h in rects:
        split = two_colours(lab[y:y + h, x:x + w].reshape(-1, 3))
        if split is None:
            continue
        share, centres, distance, chroma = split
        big, small = (", ".join(f"{v:.0f}" for v in c) for c in centres)
        findings.append(Finding(
            "two-colours", name, float(share),
            f"{where}rectangle {name}:{x},{y},{w},{h} holds two colours: "
            f"{100 * (1 - share):.0f} % near L*a*b* ({big}) and "
            f"{100 * share:.0f} % near ({small}), Delta E {distance:.0f} "
            f"apart (not one colour lit and shaded); draw a tighter box "
            f"inside the object, or teach it with --mask"))
    return findings


def teaching_findings(palette, views):
    """Warnings about a palette learned from rectangles and the class
    spreads to record with it.  ``views``: per teaching image, (its name,
    its L*a*b*, its rectangles).  Returns (findings, spreads: name -> RMS
    Delta E of the class's taught pixels to its nearest reference)."""
    findings = []
    pooled = {}
    for source, lab, rects in views:
        findings += rect_findings(lab, rects, source)
        for name, mask in pal.check_rects(lab.shape, rects, source).items():
            pooled.setdefault(name, []).append(lab[mask])
    class_pixels = {name: np.vstack(p).astype(np.float64)
                    for name, p in pooled.items()}
    findings += taught_confusions(palette, class_pixels)
    spreads = {name: round(class_spread(pal.sample_pixels(pixels, 0),
                                        palette.classes[palette.index(name)]),
                           2)
               for name, pixels in class_pixels.items()
               if name in palette.names}
    return findings, spreads
