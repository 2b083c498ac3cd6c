"""Plain numpy/OpenCV reference of the labsegment element.

This module defines what the C++ ``labsegment`` element must compute; its
tests compare the element's output with these functions.  It is written to
be read, not to be fast, and doubles as the "plain Python" speed baseline.

Pipeline for one frame:

1. convert the frame to float sRGB in [0, 1] (``yuv_to_rgb_float`` and the
   per-format helpers for I420, NV12 and YUY2; 8-bit RGB is divided by 255),
2. convert to CIE L*a*b* (D65) with OpenCV's float conversion
   (``rgb_to_lab``),
3. classify every pixel by the nearest reference colour with the seed's
   dominant-colour rule (``classify``).
"""

from dataclasses import dataclass

import cv2
import numpy as np

# Luma coefficients (Kr, Kb) of the supported YCbCr matrices.
YUV_MATRICES = {
    "bt601": (0.299, 0.114),
    "bt709": (0.2126, 0.0722),
    "bt2020": (0.2627, 0.0593),
}


@dataclass
class Segmentation:
    """Result of ``classify`` for one frame.

    labels        uint8 (H, W): 0 = unclassified, k + 1 = class k.
    counts        int64 (K,): pixels whose nearest class over *all* classes
                  is k within max_distance (the per-frame class histogram).
    active        bool (K,): classes that passed the dominant-colour rule.
    label_counts  int64 (K,): pixels finally labelled k + 1.
    unclassified  pixels finally labelled 0.
    """

    labels: np.ndarray
    counts: np.ndarray
    active: np.ndarray
    label_counts: np.ndarray
    unclassified: int


def rgb_to_lab(rgb):
    """Convert an (H, W, 3) sRGB image in R, G, B order to float32 L*a*b*.

    uint8 input is scaled by 1/255; float input must already be in [0, 1].
    L* is 0..100.  This is exactly the conversion the element uses.
    """
    rgb = np.asarray(rgb)
    if rgb.ndim != 3 or rgb.shape[2] != 3:
        raise ValueError(f"expected an (H, W, 3) image, got {rgb.shape}")
    if rgb.dtype == np.uint8:
        rgb_float = rgb.astype(np.float32) / 255.0
    elif np.issubdtype(rgb.dtype, np.floating):
        rgb_float = rgb.astype(np.float32)
    else:
        raise ValueError(f"expected uint8 or float RGB, got {rgb.dtype}")
    # cvtColor needs a contiguous buffer.
    rgb_float = np.ascontiguousarray(rgb_float)
    return cv2.cvtColor(rgb_float, cv2.COLOR_RGB2Lab)


def lab_to_srgb8(lab):
    """Convert L*a*b* colours (..., 3) to 8-bit sRGB (..., 3), R, G, B order.

    Out-of-gamut colours are clipped.  Used to draw each class in its own
    colour.
    """
    lab = np.asarray(lab, dtype=np.float32)
    flat = np.ascontiguousarray(lab.reshape(1, -1, 3))
    rgb = cv2.cvtColor(flat, cv2.COLOR_Lab2RGB)
    rgb = np.clip(rgb, 0.0, 1.0)
    return np.rint(rgb * 255.0).astype(np.uint8).reshape(lab.shape)


def yuv_to_rgb_float(y, u, v, matrix="bt601", full_range=False):
    """Convert full-resolution 8-bit Y, U, V arrays (H, W) to float RGB.

    Chroma must already be upsampled to the luma size.  Returns float64
    (H, W, 3) R, G, B clipped to [0, 1]; ``rgb_to_lab`` turns it into the
    float32 the element feeds to OpenCV.
    """
    if matrix not in YUV_MATRICES:
        raise ValueError(f"unknown YUV matrix {matrix!r}, expected one of "
                         f"{', '.join(YUV_MATRICES)}")
    kr, kb = YUV_MATRICES[matrix]
    kg = 1.0 - kr - kb

    y = np.asarray(y, dtype=np.float64)
    u = np.asarray(u, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    if not y.shape == u.shape == v.shape:
        raise ValueError(f"Y, U, V shapes differ: {y.shape}, {u.shape}, "
                         f"{v.shape}")

    if full_range:
        luma = y / 255.0
        cb = (u - 128.0) / 255.0
        cr = (v - 128.0) / 255.0
    else:
        luma = (y - 16.0) / 219.0
        cb = (u - 128.0) / 224.0
        cr = (v - 128.0) / 224.0

    r = luma + 2.0 * (1.0 - kr) * cr
    g = (luma - (2.0 * kb * (1.0 - kb) / kg) * cb
         - (2.0 * kr * (1.0 - kr) / kg) * cr)
    b = luma + 2.0 * (1.0 - kb) * cb
    return np.clip(np.stack([r, g, b], axis=-1), 0.0, 1.0)


def _upsample_chroma(plane, height, width):
    """Repeat each chroma sample over its 2x2 block, cropped to H x W."""
    full = np.repeat(np.repeat(plane, 2, axis=0), 2, axis=1)
    return full[:height, :width]


def _chroma_shape(height, width):
    return ((height + 1) // 2, (width + 1) // 2)


def i420_planes_to_rgb_float(yplane, uplane, vplane, matrix="bt601",
                             full_range=False):
    """I420: Y (H, W), U and V (ceil(H/2), ceil(W/2)) -> float RGB."""
    yplane = np.asarray(yplane)
    height, width = yplane.shape
    expected = _chroma_shape(height, width)
    for name, plane in (("U", uplane), ("V", vplane)):
        if np.shape(plane) != expected:
            raise ValueError(f"{name} plane is {np.shape(plane)}, expected "
                             f"{expected} for a {width}x{height} frame")
    u = _upsample_chroma(np.asarray(uplane), height, width)
    v = _upsample_chroma(np.asarray(vplane), height, width)
    return yuv_to_rgb_float(yplane, u, v, matrix, full_range)


def nv12_to_rgb_float(yplane, uvplane, matrix="bt601", full_range=False):
    """NV12: Y (H, W), interleaved UV (ceil(H/2), ceil(W/2), 2) -> RGB.

    The UV plane may also be given as raw rows of 2 * ceil(W/2) bytes.
    """
    yplane = np.asarray(yplane)
    height, width = yplane.shape
    ch, cw = _chroma_shape(height, width)
    uvplane = np.asarray(uvplane)
    if uvplane.shape == (ch, 2 * cw):
        uvplane = uvplane.reshape(ch, cw, 2)
    if uvplane.shape != (ch, cw, 2):
        raise ValueError(f"UV plane is {uvplane.shape}, expected "
                         f"{(ch, cw, 2)} for a {width}x{height} frame")
    u = _upsample_chroma(uvplane[:, :, 0], height, width)
    v = _upsample_chroma(uvplane[:, :, 1], height, width)
    return yuv_to_rgb_float(yplane, u, v, matrix, full_range)


def yuy2_to_rgb_float(packed, width, matrix="bt601", full_range=False):
    """YUY2: packed rows Y0 U Y1 V ... -> float RGB of the given width.

    ``packed`` is (H, 2 * ceil(W/2), 2) (one luma byte and one chroma byte
    per pixel slot) or the raw (H, 4 * ceil(W/2)) bytes.  With an odd width
    the last luma slot of each row is padding.
    """
    packed = np.asarray(packed)
    pairs = (width + 1) // 2
    if packed.ndim == 2 and packed.shape[1] == 4 * pairs:
        packed = packed.reshape(packed.shape[0], 2 * pairs, 2)
    if packed.ndim != 3 or packed.shape[1:] != (2 * pairs, 2):
        raise ValueError(f"packed YUY2 is {packed.shape}, expected "
                         f"(H, {2 * pairs}, 2) for width {width}")
    y = packed[:, :width, 0]
    # Chroma bytes alternate U, V; each pair of pixels shares them.
    u = np.repeat(packed[:, 0::2, 1], 2, axis=1)[:, :width]
    v = np.repeat(packed[:, 1::2, 1], 2, axis=1)[:, :width]
    return yuv_to_rgb_float(y, u, v, matrix, full_range)


def classify(lab, palette_lab, min_class_pixels=100, max_distance=1000.0,
             use_lightness=True, rare_classes="unlabelled", ref_class=None,
             shading=None):
    """Label every pixel with its nearest palette class.

    lab          (H, W, 3) L*a*b* image (float32 as from ``rgb_to_lab``).
    palette_lab  (K, 3) reference colours, one per class; or with
                 ``ref_class``, (R, 3) reference colours of which
                 reference r belongs to class ref_class[r] (ascending class
                 indices): a pixel's class is that of its nearest
                 reference.
    min_class_pixels  dominant-colour rule: only classes with at least this
                 many pixels in the first pass take part in the final
                 labelling; 0 turns the rule off.
    max_distance pixels farther than this from their nearest class get 0.
    use_lightness False measures distance over a*, b* only.
    rare_classes where pixels whose first-pass class is not active go:
                 "nearest" (the nearest active class, the seed's rule) or
                 "unlabelled" (label 0).
    shading      optional (R, 2, 3): reference r stands for the segment
                 between shading[r, 0] and shading[r, 1] (its colour under
                 less and more light, ``Palette.shading_arrays``); the
                 distance to it is the distance to that segment (with
                 ``use_lightness``; without it the references count).
    """
    if rare_classes not in ("nearest", "unlabelled"):
        raise ValueError(f"rare_classes must be 'nearest' or 'unlabelled', "
                         f"got {rare_classes!r}")
    lab = np.asarray(lab, dtype=np.float32)
    if lab.ndim != 3 or lab.shape[2] != 3:
        raise ValueError(f"expected an (H, W, 3) Lab image, got {lab.shape}")
    refs = np.asarray(palette_lab, dtype=np.float64)
    if refs.ndim != 2 or refs.shape[1] != 3 or len(refs) == 0:
        raise ValueError(f"expected (K, 3) palette colours, got "
                         f"{refs.shape}")
    if ref_class is None:
        ref_class = np.arange(len(refs))
    ref_class = np.asarray(ref_class)
    if (ref_class.shape != (len(refs),)
            or not np.issubdtype(ref_class.dtype, np.integer)
            or ref_class.min() < 0 or np.any(np.diff(ref_class) < 0)):
        raise ValueError("ref_class must give an ascending class index "
                         "for each reference")
    num_classes = int(ref_class.max()) + 1
    if num_classes > 255:
        raise ValueError("at most 255 classes fit in a uint8 label")
    height, width = lab.shape[:2]

    # Distances are computed in float64 from the float32 Lab values.
    pixels = lab.reshape(-1, 3).astype(np.float64)
    channels = slice(0, 3) if use_lightness else slice(1, 3)
    pixels = pixels[:, channels]
    refs = refs[:, channels]

    # dist[i, k]: Euclidean distance of pixel i to the nearest reference
    # of class k.
    segments = None
    if shading is not None and use_lightness:
        segments = np.asarray(shading, dtype=np.float64).reshape(-1, 2, 3)
        if len(segments) != len(refs):
            raise ValueError("shading must give one segment per reference")
    dist = np.full((len(pixels), num_classes), np.inf)
    for r, k in enumerate(ref_class):
        if segments is None:
            diff = pixels - refs[r]
        else:
            start, along = segments[r, 0], segments[r, 1] - segments[r, 0]
            length2 = float(along @ along)
            t = np.zeros(len(pixels)) if length2 <= 0 else np.clip(
                (pixels - start) @ along / length2, 0.0, 1.0)
            diff = pixels - (start + t[:, None] * along)
        np.minimum(dist[:, k], np.sqrt(np.sum(diff * diff, axis=1)),
                   out=dist[:, k])

    # First pass over all classes: the per-frame class histogram.
    # argmin picks the lowest class index on ties.
    nearest = np.argmin(dist, axis=1)
    nearest_dist = dist[np.arange(len(pixels)), nearest]
    belongs = nearest_dist <= max_distance
    counts = np.bincount(nearest[belongs], minlength=num_classes)

    # Dominant-colour rule.
    if min_class_pixels == 0:
        active = np.ones(num_classes, dtype=bool)
    else:
        active = counts >= min_class_pixels

    # Final pass among active classes only.
    labels = np.zeros(len(pixels), dtype=np.uint8)
    if active.any():
        active_dist = np.where(active, dist, np.inf)
        final = np.argmin(active_dist, axis=1)
        final_dist = active_dist[np.arange(len(pixels)), final]
        keep = final_dist <= max_distance
        if rare_classes == "unlabelled":
            keep &= active[nearest]
        labels[keep] = final[keep] + 1
    labels = labels.reshape(height, width)

    label_counts = np.bincount(labels.ravel(), minlength=num_classes + 1)
    return Segmentation(
        labels=labels,
        counts=counts.astype(np.int64),
        active=active,
        label_counts=label_counts[1:].astype(np.int64),
        unclassified=int(label_counts[0]),
    )


def _palette_lab(palette):
    """Accept a Palette (anything with lab_array()) or a (K, 3) array."""
    if hasattr(palette, "lab_array"):
        return palette.lab_array()
    return np.asarray(palette, dtype=np.float64)


def segment_rgb(rgb, palette, **kwargs):
    """Convert an 8-bit RGB image to Lab and ``classify`` it.

    ``palette`` is a ``gstlandmark.palette.Palette`` (all references of
    each class count) or a (K, 3) array; keyword arguments go to
    ``classify``.
    """
    if hasattr(palette, "reference_arrays"):
        refs, ref_class = palette.reference_arrays()
        return classify(rgb_to_lab(rgb), refs, ref_class=ref_class,
                        shading=palette.shading_arrays(), **kwargs)
    return classify(rgb_to_lab(rgb), _palette_lab(palette), **kwargs)


def false_colour(labels, palette):
    """Draw a label image: class k + 1 in the sRGB of its reference colour,
    label 0 in black.  Returns (H, W, 3) uint8 R, G, B."""
    labels = np.asarray(labels)
    refs = _palette_lab(palette)
    if labels.size and labels.max() > len(refs):
        raise ValueError(f"label {labels.max()} but the palette has only "
                         f"{len(refs)} classes")
    table = np.zeros((len(refs) + 1, 3), dtype=np.uint8)
    table[1:] = lab_to_srgb8(refs)
    return table[labels]
