"""Tests of gstlandmark.reference against independently written maths."""

import math

import numpy as np
import pytest

from gstlandmark import reference

# ---------------------------------------------------------------------------
# sRGB -> L*a*b* (D65), written out from the CIE / IEC 61966-2-1 formulas.

SRGB_TO_XYZ = np.array([
    [0.4124, 0.3576, 0.1805],
    [0.2126, 0.7152, 0.0722],
    [0.0193, 0.1192, 0.9505],
])
D65_WHITE = np.array([0.95047, 1.0, 1.08883])


def textbook_lab(rgb8):
    """L*a*b* of one 8-bit sRGB colour, in float64."""
    c = np.asarray(rgb8, dtype=np.float64) / 255.0
    linear = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    xyz = SRGB_TO_XYZ @ linear
    t = xyz / D65_WHITE
    delta = 6.0 / 29.0
    f = np.where(t > delta ** 3, np.cbrt(t),
                 t / (3.0 * delta ** 2) + 4.0 / 29.0)
    return np.array([116.0 * f[1] - 16.0,
                     500.0 * (f[0] - f[1]),
                     200.0 * (f[1] - f[2])])


def as_image(colours):
    """A 1 x N image of the given colours."""
    return np.asarray(colours, dtype=np.uint8).reshape(1, -1, 3)


@pytest.mark.parametrize("rgb, lab", [
    # Published L*a*b* (D65) of common sRGB colours.
    ((255, 0, 0), (53.24, 80.09, 67.20)),
    ((0, 255, 0), (87.73, -86.18, 83.18)),
    ((0, 0, 255), (32.30, 79.19, -107.86)),
    ((255, 255, 255), (100.0, 0.0, 0.0)),
    ((0, 0, 0), (0.0, 0.0, 0.0)),
    ((128, 128, 128), (53.59, 0.0, 0.0)),
])
def test_lab_of_known_colours(rgb, lab):
    got = reference.rgb_to_lab(as_image([rgb]))[0, 0]
    assert got.dtype == np.float32
    np.testing.assert_allclose(got, lab, atol=0.05)
    np.testing.assert_allclose(textbook_lab(rgb), lab, atol=0.05)


def test_lab_of_random_colours_matches_cie_formulas():
    rng = np.random.default_rng(12345)
    colours = rng.integers(0, 256, size=(3000, 3))
    got = reference.rgb_to_lab(as_image(colours))[0].astype(np.float64)
    want = np.array([textbook_lab(c) for c in colours])
    err = np.abs(got - want)
    # OpenCV's float sRGB->Lab interpolates tables: errors reach ~0.47 in
    # a*/b* for a few dark saturated colours (measured over all 2^24
    # colours), far below a visible difference; the mean stays small.
    assert err.max() < 0.5
    assert err.mean() < 0.12
    assert np.median(err) < 0.1


def test_rgb_to_lab_accepts_float_rgb():
    rng = np.random.default_rng(1)
    img = rng.integers(0, 256, size=(4, 5, 3)).astype(np.uint8)
    from_uint8 = reference.rgb_to_lab(img)
    from_float = reference.rgb_to_lab(img.astype(np.float64) / 255.0)
    assert from_float.shape == (4, 5, 3)
    np.testing.assert_allclose(from_float, from_uint8, atol=1e-5)


def test_rgb_to_lab_rejects_wrong_shape():
    with pytest.raises(ValueError):
        reference.rgb_to_lab(np.zeros((4, 5), np.uint8))


def test_lab_to_srgb8_round_trips_primaries():
    colours = [(255, 0, 0), (0, 255, 0), (0, 0, 255), (128, 128, 128)]
    lab = np.array([textbook_lab(c) for c in colours])
    np.testing.assert_array_equal(reference.lab_to_srgb8(lab), colours)


# ---------------------------------------------------------------------------
# YUV -> RGB, checked against a per-pixel loop over raw frame bytes.

KR_KB = {"bt601": (0.299, 0.114), "bt709": (0.2126, 0.0722),
         "bt2020": (0.2627, 0.0593)}


def pixel_rgb(y, u, v, matrix, full_range):
    """One pixel, straight from the YCbCr definitions."""
    kr, kb = KR_KB[matrix]
    kg = 1 - kr - kb
    if full_range:
        yn, cb, cr = y / 255, (u - 128) / 255, (v - 128) / 255
    else:
        yn, cb, cr = (y - 16) / 219, (u - 128) / 224, (v - 128) / 224
    r = yn + 2 * (1 - kr) * cr
    b = yn + 2 * (1 - kb) * cb
    # G from Y = Kr R + Kg G + Kb B.
    g = (yn - kr * r - kb * b) / kg
    return [min(max(ch, 0.0), 1.0) for ch in (r, g, b)]


def loop_i420(buf, width, height, matrix, full_range):
    buf = [int(b) for b in buf]  # no uint8 wrap-around
    cw, ch = (width + 1) // 2, (height + 1) // 2
    u_off = width * height
    v_off = u_off + cw * ch
    out = np.zeros((height, width, 3))
    for row in range(height):
        for col in range(width):
            y = buf[row * width + col]
            c = (row // 2) * cw + col // 2
            out[row, col] = pixel_rgb(y, buf[u_off + c], buf[v_off + c],
                                      matrix, full_range)
    return out


def loop_nv12(buf, width, height, matrix, full_range):
    buf = [int(b) for b in buf]  # no uint8 wrap-around
    cw = (width + 1) // 2
    uv_off = width * height
    out = np.zeros((height, width, 3))
    for row in range(height):
        for col in range(width):
            y = buf[row * width + col]
            c = uv_off + (row // 2) * 2 * cw + 2 * (col // 2)
            out[row, col] = pixel_rgb(y, buf[c], buf[c + 1], matrix,
                                      full_range)
    return out


def loop_yuy2(buf, width, height, matrix, full_range):
    buf = [int(b) for b in buf]  # no uint8 wrap-around
    stride = 4 * ((width + 1) // 2)
    out = np.zeros((height, width, 3))
    for row in range(height):
        for col in range(width):
            macro = row * stride + 4 * (col // 2)
            y = buf[macro + 2 * (col % 2)]
            out[row, col] = pixel_rgb(y, buf[macro + 1], buf[macro + 3],
                                      matrix, full_range)
    return out


SIZES = [(1, 1), (2, 2), (5, 3), (7, 6), (8, 5), (6, 9)]
MODES = [(m, fr) for m in KR_KB for fr in (False, True)]


def random_bytes(n, seed):
    # Spread over all of 0..255 so out-of-range values get clipped too.
    return np.random.default_rng(seed).integers(0, 256, n).astype(np.uint8)


def random_420_frame(width, height, seed):
    """A random 4:2:0 frame (I420 or NV12: a full Y plane, then chroma of
    half the width and height rounded up): its bytes, the Y plane, the
    chroma bytes and the chroma width and height."""
    cw, ch = (width + 1) // 2, (height + 1) // 2
    buf = random_bytes(width * height + 2 * cw * ch, seed)
    return (buf, buf[:width * height].reshape(height, width),
            buf[width * height:], cw, ch)


@pytest.mark.parametrize("width, height", SIZES)
@pytest.mark.parametrize("matrix, full_range", MODES)
def test_i420_matches_pixel_loop(width, height, matrix, full_range):
    buf, yplane, chroma, cw, ch = random_420_frame(width, height,
                                                   width * 31 + height)
    uplane = chroma[:cw * ch].reshape(ch, cw)
    vplane = chroma[cw * ch:].reshape(ch, cw)
    got = reference.i420_planes_to_rgb_float(yplane, uplane, vplane,
                                             matrix=matrix,
                                             full_range=full_range)
    want = loop_i420(buf, width, height, matrix, full_range)
    assert got.shape == (height, width, 3)
    np.testing.assert_allclose(got, want, atol=1e-12)


@pytest.mark.parametrize("width, height", SIZES)
@pytest.mark.parametrize("matrix, full_range", MODES)
def test_nv12_matches_pixel_loop(width, height, matrix, full_range):
    buf, yplane, chroma, cw, ch = random_420_frame(width, height,
                                                   width * 17 + height)
    uvplane = chroma.reshape(ch, cw, 2)
    got = reference.nv12_to_rgb_float(yplane, uvplane, matrix=matrix,
                                      full_range=full_range)
    want = loop_nv12(buf, width, height, matrix, full_range)
    assert got.shape == (height, width, 3)
    np.testing.assert_allclose(got, want, atol=1e-12)
    # The same UV plane as raw rows of bytes.
    raw = reference.nv12_to_rgb_float(yplane, uvplane.reshape(ch, 2 * cw),
                                      matrix=matrix, full_range=full_range)
    np.testing.assert_array_equal(raw, got)


@pytest.mark.parametrize("width, height", SIZES)
@pytest.mark.parametrize("matrix, full_range", MODES)
def test_yuy2_matches_pixel_loop(width, height, matrix, full_range):
    pairs = (width + 1) // 2
    buf = random_bytes(height * 4 * pairs, width * 7 + height)
    packed = buf.reshape(height, 2 * pairs, 2)
    got = reference.yuy2_to_rgb_float(packed, width, matrix=matrix,
                                      full_range=full_range)
    want = loop_yuy2(buf, width, height, matrix, full_range)
    assert got.shape == (height, width, 3)
    np.testing.assert_allclose(got, want, atol=1e-12)
    raw = reference.yuy2_to_rgb_float(buf.reshape(height, 4 * pairs), width,
                                      matrix=matrix, full_range=full_range)
    np.testing.assert_array_equal(raw, got)


def test_yuv_known_values():
    y = np.array([[16, 235, 0, 255]])
    c = np.full_like(y, 128)
    limited = reference.yuv_to_rgb_float(y, c, c)
    np.testing.assert_allclose(limited[0, 0], [0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(limited[0, 1], [1, 1, 1], atol=1e-12)
    np.testing.assert_allclose(limited[0, 2], [0, 0, 0])  # clipped
    np.testing.assert_allclose(limited[0, 3], [1, 1, 1])  # clipped
    full = reference.yuv_to_rgb_float(y, c, c, full_range=True)
    np.testing.assert_allclose(full[0, 2], [0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(full[0, 3], [1, 1, 1], atol=1e-12)
    # BT.601 limited-range red: Y=81, Cb=90, Cr=240.
    red = reference.yuv_to_rgb_float([[81]], [[90]], [[240]])[0, 0]
    np.testing.assert_allclose(red, [1, 0, 0], atol=0.01)


def test_yuv_rejects_unknown_matrix_and_bad_planes():
    one = np.zeros((2, 2))
    with pytest.raises(ValueError, match="bt601"):
        reference.yuv_to_rgb_float(one, one, one, matrix="smpte240m")
    with pytest.raises(ValueError):
        reference.i420_planes_to_rgb_float(np.zeros((4, 4)),
                                           np.zeros((2, 2)),
                                           np.zeros((1, 2)))


# ---------------------------------------------------------------------------
# classify on hand-built Lab images.

PALETTE = np.array([
    [50.0, 0.0, 0.0],     # 0 grey
    [50.0, 40.0, 0.0],    # 1 reddish
    [50.0, 0.0, 40.0],    # 2 yellowish
])


def lab_image(pixels):
    return np.asarray(pixels, dtype=np.float32).reshape(1, -1, 3)


def test_nearest_class_wins():
    img = lab_image([[52, 1, -1], [48, 35, 3], [50, 2, 38], [50, 30, 0]])
    seg = reference.classify(img, PALETTE, min_class_pixels=0)
    assert seg.labels.dtype == np.uint8
    assert seg.labels.tolist() == [[1, 2, 3, 2]]


def test_ties_go_to_the_lowest_class_index():
    # Pixel 0 ties classes 1 and 2 (grey is farther); pixel 1 ties all
    # three; pixel 2 ties grey and class 1.
    img = lab_image([[50, 30, 30], [50, 20, 20], [50, 20, 0]])
    assert math.dist([50, 30, 30], PALETTE[1]) == \
        math.dist([50, 30, 30], PALETTE[2])
    seg = reference.classify(img, PALETTE, min_class_pixels=0)
    assert seg.labels.tolist() == [[2, 1, 1]]
    assert seg.counts.tolist() == [2, 1, 0]


def test_ties_among_active_classes_go_to_the_lowest_active_index():
    # The tied pixel counts for grey in the first pass, but grey is not
    # active, so it goes to the lowest active class of the tie.
    img = lab_image([[50, 20, 20]] + [[50, 40, 1]] * 3 + [[50, 1, 40]] * 3)
    seg = reference.classify(img, PALETTE, min_class_pixels=2,
                             rare_classes="nearest")
    assert seg.counts.tolist() == [1, 3, 3]
    assert seg.active.tolist() == [False, True, True]
    assert seg.labels.tolist() == [[2, 2, 2, 2, 3, 3, 3]]


def test_max_distance_is_inclusive():
    # 3-4-5 triangle: exactly 5 from grey.
    img = lab_image([[50, 3, -4], [50, 3.5, -4]])
    seg = reference.classify(img, PALETTE, min_class_pixels=0,
                             max_distance=5.0)
    assert seg.labels.tolist() == [[1, 0]]
    assert seg.counts.tolist() == [1, 0, 0]
    assert seg.unclassified == 1


def test_use_lightness_false_ignores_lightness():
    palette = np.array([[20.0, 10.0, 10.0], [80.0, 30.0, 30.0]])
    # Same a*, b* as class 0 but the lightness of class 1.
    img = lab_image([[80, 10, 10]])
    with_l = reference.classify(img, palette, min_class_pixels=0)
    without_l = reference.classify(img, palette, min_class_pixels=0,
                                   use_lightness=False)
    assert with_l.labels.tolist() == [[2]]
    assert without_l.labels.tolist() == [[1]]
    # Distance over a*, b* only is 0 here, so even a tiny limit keeps it.
    tight = reference.classify(img, palette, min_class_pixels=0,
                               use_lightness=False, max_distance=0.0)
    assert tight.labels.tolist() == [[1]]


def dominant_scene():
    """60 grey, 30 reddish, 10 pixels nearest to 'yellowish' that are
    closer to reddish than to grey."""
    grey = [[50, 1, 0]] * 60
    red = [[50, 39, 0]] * 30
    # Distances: yellowish 24.2, reddish 35.0, grey 37.2.
    odd = [[50, 22, 30]] * 10
    return lab_image(grey + red + odd)


def test_dominant_rule_moves_minor_class_to_nearest_active():
    seg = reference.classify(dominant_scene(), PALETTE, min_class_pixels=20,
                             rare_classes="nearest")
    assert seg.counts.tolist() == [60, 30, 10]
    assert seg.active.tolist() == [True, True, False]
    assert seg.label_counts.tolist() == [60, 40, 0]
    assert seg.unclassified == 0
    assert seg.labels[0, 90:].tolist() == [2] * 10


def test_dominant_rule_unlabels_minor_class_by_default():
    seg = reference.classify(dominant_scene(), PALETTE, min_class_pixels=20)
    assert seg.counts.tolist() == [60, 30, 10]
    assert seg.active.tolist() == [True, True, False]
    assert seg.label_counts.tolist() == [60, 30, 0]
    assert seg.unclassified == 10
    assert seg.labels[0, 90:].tolist() == [0] * 10
    with pytest.raises(ValueError):
        reference.classify(dominant_scene(), PALETTE, rare_classes="drop")


def test_dominant_threshold_is_inclusive():
    seg = reference.classify(dominant_scene(), PALETTE, min_class_pixels=10)
    assert seg.active.tolist() == [True, True, True]
    assert seg.labels[0, 90:].tolist() == [3] * 10


def test_min_class_pixels_zero_disables_the_rule():
    seg = reference.classify(dominant_scene(), PALETTE, min_class_pixels=0)
    assert seg.active.all()
    assert seg.label_counts.tolist() == [60, 30, 10]


def test_no_active_class_labels_everything_zero():
    seg = reference.classify(dominant_scene(), PALETTE, min_class_pixels=61)
    assert not seg.active.any()
    assert seg.counts.tolist() == [60, 30, 10]
    assert not seg.labels.any()
    assert seg.label_counts.tolist() == [0, 0, 0]
    assert seg.unclassified == 100


def test_reassigned_pixels_still_respect_max_distance():
    # The odd pixels are 24.2 from yellowish but 35.0 from reddish.
    seg = reference.classify(dominant_scene(), PALETTE, min_class_pixels=20,
                             max_distance=30.0, rare_classes="nearest")
    assert seg.counts.tolist() == [60, 30, 10]
    assert seg.label_counts.tolist() == [60, 30, 0]
    assert seg.unclassified == 10


def test_first_pass_counts_only_pixels_within_max_distance():
    far = [[50, 22, 30]] * 10
    near = [[50, 0, 39]] * 5
    seg = reference.classify(lab_image(far + near), PALETTE,
                             min_class_pixels=6, max_distance=10.0)
    # Far pixels are nearest to class 2 but beyond the limit.
    assert seg.counts.tolist() == [0, 0, 5]
    assert not seg.active.any()


def loop_classify(lab, palette, min_pixels, max_dist, use_l,
                  rare="unlabelled"):
    """The segmentation rule written pixel by pixel."""
    h, w, _ = lab.shape
    dims = [0, 1, 2] if use_l else [1, 2]
    k_count = len(palette)

    def dist(px, k):
        return math.sqrt(sum((float(px[d]) - palette[k][d]) ** 2
                             for d in dims))

    def nearest(px, allowed):
        best, best_d = None, None
        for k in allowed:
            d = dist(px, k)
            if best is None or d < best_d:
                best, best_d = k, d
        return best, best_d

    counts = [0] * k_count
    for row in range(h):
        for col in range(w):
            k, d = nearest(lab[row, col], range(k_count))
            if d <= max_dist:
                counts[k] += 1
    active = [min_pixels == 0 or c >= min_pixels for c in counts]
    allowed = [k for k in range(k_count) if active[k]]
    labels = np.zeros((h, w), dtype=int)
    for row in range(h):
        for col in range(w):
            first, _ = nearest(lab[row, col], range(k_count))
            if rare == "unlabelled" and not active[first]:
                continue
            if allowed:
                k, d = nearest(lab[row, col], allowed)
                if d <= max_dist:
                    labels[row, col] = k + 1
    return labels, counts, active


@pytest.mark.parametrize("rare", ["nearest", "unlabelled"])
@pytest.mark.parametrize("min_pixels, max_dist, use_l", [
    (0, 1000.0, True), (15, 1000.0, True), (15, 40.0, True),
    (40, 30.0, False), (0, 25.0, False),
])
def test_classify_matches_pixel_loop(min_pixels, max_dist, use_l, rare):
    rng = np.random.default_rng(min_pixels + int(max_dist))
    lab = np.stack([rng.uniform(0, 100, (9, 11)),
                    rng.uniform(-60, 60, (9, 11)),
                    rng.uniform(-60, 60, (9, 11))], axis=-1)
    lab = lab.astype(np.float32)
    palette = np.column_stack([rng.uniform(0, 100, 5),
                               rng.uniform(-60, 60, 5),
                               rng.uniform(-60, 60, 5)])
    seg = reference.classify(lab, palette, min_class_pixels=min_pixels,
                             max_distance=max_dist, use_lightness=use_l,
                             rare_classes=rare)
    labels, counts, active = loop_classify(lab, palette, min_pixels,
                                           max_dist, use_l, rare)
    np.testing.assert_array_equal(seg.labels, labels)
    assert seg.counts.tolist() == counts
    assert seg.active.tolist() == active
    # Counts are consistent with the label image.
    for k in range(len(palette)):
        assert seg.label_counts[k] == np.count_nonzero(labels == k + 1)
    assert seg.unclassified == np.count_nonzero(labels == 0)
    assert seg.label_counts.sum() + seg.unclassified == labels.size
    assert seg.counts.sum() <= labels.size
    if min_pixels == 0:
        assert seg.label_counts.tolist() == seg.counts.tolist()


def test_segment_rgb_and_false_colour():
    palette = np.array([textbook_lab((255, 0, 0)),
                        textbook_lab((0, 0, 255)),
                        textbook_lab((255, 255, 255))])
    rgb = as_image([(250, 5, 5)] * 3 + [(10, 10, 240)] * 2
                   + [(128, 128, 128)])
    seg = reference.segment_rgb(rgb, palette, min_class_pixels=2,
                                max_distance=30.0)
    # Grey is 46 from white: unclassified; white has no pixels: inactive.
    assert seg.labels.tolist() == [[1, 1, 1, 2, 2, 0]]
    assert seg.active.tolist() == [True, True, False]
    colours = reference.false_colour(seg.labels, palette)
    assert colours.dtype == np.uint8
    assert colours[0].tolist() == [[255, 0, 0]] * 3 + [[0, 0, 255]] * 2 \
        + [[0, 0, 0]]
    with pytest.raises(ValueError):
        reference.false_colour(np.array([[4]]), palette)
