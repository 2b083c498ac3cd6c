"""labsegment against the Python reference (numpy + OpenCV float L*a*b*)
on random and natural-looking frames in every accepted format."""

import os
import zlib

import numpy as np
import pytest

from gstlandmark import meta, palette, pipeline, reference

import frames as F

SIZES = [(64, 48), (63, 47), (1, 1), (5, 3)]


def seed_of(*names):
    """A seed fixed by the test's parameters: zlib.crc32 is the same in
    every process (hash() of a string is salted per process)."""
    return zlib.crc32(" ".join(names).encode())


def run(element, payloads, caps):
    return pipeline.process_frames(element, payloads, caps)


def agreement(got, want, what):
    """Fraction of equal labels; prints where they differ."""
    equal = got == want
    frac = equal.mean() if equal.size else 1.0
    if not equal.all():
        ys, xs = np.nonzero(~equal)
        print(f"{what}: {len(ys)} of {equal.size} labels differ, e.g. at "
              f"{list(zip(ys[:5].tolist(), xs[:5].tolist()))}: element "
              f"{got[ys[:5], xs[:5]].tolist()} reference "
              f"{want[ys[:5], xs[:5]].tolist()}")
    return frac


def check_meta(lm, seg, pal, width, height, min_class_pixels):
    assert (lm.width, lm.height, lm.stride) == (width, height, width)
    assert lm.class_names == pal.names
    assert [c.marker for c in lm.classes] == [c.marker for c in pal.classes]
    assert lm.min_class_pixels == min_class_pixels
    got_counts = np.array([c.count for c in lm.classes])
    # counts come from the same per-pixel decisions, so they agree as well
    # as the labels do
    assert np.abs(got_counts - seg.counts).sum() <= max(
        2, 0.001 * width * height)
    labelled = np.array([c.labelled for c in lm.classes])
    assert labelled.tolist() == [int((lm.plane == k + 1).sum())
                                 for k in range(len(pal.names))]
    assert lm.unclassified == int((lm.plane == 0).sum())


@pytest.mark.parametrize("fmt", list(F.PACKED_ORDER))
@pytest.mark.parametrize("kind", ["random", "natural"])
def test_packed_rgb_agrees_with_reference(gst, fmt, kind):
    rng = np.random.default_rng(seed_of(fmt, kind))
    pal = palette.default_palette()
    total = equal = 0
    for width, height in SIZES:
        caps = F.caps_string(fmt, width, height)
        info = F.video_info(caps)
        make = F.random_rgb if kind == "random" else F.natural_rgb
        images = [make(rng, height, width) for _ in range(2)]
        payloads = [F.pack_rgb(img, fmt, info, rng) for img in images]
        for mcp in (0, 40):
            out = run(f"labsegment min-class-pixels={mcp}", payloads, caps)
            assert len(out) == len(images)
            for img, buf, payload in zip(images, out, payloads):
                # video passes through untouched
                with buf.map(pipeline.Gst.MapFlags.READ) as m:
                    assert bytes(m.data) == payload
                lm = meta.labels(buf)
                seg = reference.segment_rgb(img, pal, min_class_pixels=mcp)
                frac = agreement(lm.plane, seg.labels, f"{fmt} {width}x"
                                 f"{height} mcp={mcp}")
                total += lm.plane.size
                equal += frac * lm.plane.size
                check_meta(lm, seg, pal, width, height, mcp)
    assert equal / total >= 0.999


@pytest.mark.parametrize("fmt", F.YUV_FORMATS)
@pytest.mark.parametrize("colorimetry", list(F.COLORIMETRY))
@pytest.mark.parametrize("kind", ["random", "natural"])
def test_yuv_agrees_with_reference(gst, fmt, colorimetry, kind):
    rng = np.random.default_rng(seed_of(fmt, colorimetry, kind))
    pal = palette.default_palette()
    matrix, full_range = F.COLORIMETRY[colorimetry]
    total = equal = 0
    for width, height in SIZES:
        caps = F.caps_string(fmt, width, height, colorimetry)
        info = F.video_info(caps)
        payloads = []
        for _ in range(2):
            if kind == "random":
                payloads.append(F.random_yuv(rng, fmt, info)[0])
            else:
                payloads.append(F.rgb_to_yuv_bytes(
                    F.natural_rgb(rng, height, width), fmt, info))
        out = run("labsegment min-class-pixels=20", payloads, caps)
        for payload, buf in zip(payloads, out):
            comps = F.yuv_components(np.frombuffer(payload, np.uint8), fmt,
                                     info)
            rgb = F.yuv_to_rgb_float(comps, matrix, full_range)
            seg = reference.classify(reference.rgb_to_lab(rgb),
                                     pal.lab_array(), min_class_pixels=20)
            lm = meta.labels(buf)
            frac = agreement(lm.plane, seg.labels,
                             f"{fmt} {colorimetry} {width}x{height}")
            total += lm.plane.size
            equal += frac * lm.plane.size
            check_meta(lm, seg, pal, width, height, 20)
    assert equal / total >= 0.999


@pytest.mark.parametrize("use_lightness", [True, False])
@pytest.mark.parametrize("max_distance", [1000.0, 15.0])
def test_settings_agree_with_reference(gst, use_lightness, max_distance):
    rng = np.random.default_rng(5)
    pal = palette.default_palette()
    images = [F.natural_rgb(rng, 120, 160), F.random_rgb(rng, 120, 160)]
    caps = F.caps_string("RGB", 160, 120)
    element = (f"labsegment use-lightness={str(use_lightness).lower()} "
               f"max-distance={max_distance}")
    out = run(element, images, caps)
    for img, buf in zip(images, out):
        seg = reference.segment_rgb(img, pal, use_lightness=use_lightness,
                                    max_distance=max_distance)
        lm = meta.labels(buf)
        assert agreement(lm.plane, seg.labels, element) >= 0.999
        assert lm.use_lightness == use_lightness
        assert lm.max_distance == max_distance


def test_dominant_rule_changes_labels(gst):
    """A few pink-ish pixels in a red/grey frame: present with the rule
    off, handed to their nearest dominant class with it on."""
    img = np.zeros((100, 100, 3), np.uint8)
    img[:, :50] = (200, 40, 40)
    img[:, 50:] = (128, 128, 128)
    img[10:15, 60:65] = (240, 100, 170)           # 25 pink pixels
    caps = F.caps_string("RGB", 100, 100)
    off, on = (run(f"labsegment min-class-pixels={m}", [img], caps)[0]
               for m in (0, 26))
    pink = palette.default_palette().index("pink") + 1
    lm_off, lm_on = meta.labels(off), meta.labels(on)
    assert (lm_off.plane[10:15, 60:65] == pink).all()
    assert not (lm_on.plane == pink).any()
    assert lm_on.class_by_name("pink").count == 25
    assert not lm_on.class_by_name("pink").active
    seg = reference.segment_rgb(img, palette.default_palette(),
                                min_class_pixels=26)
    assert (lm_on.plane == seg.labels).all()


def test_plane_outlives_buffer_and_pool(gst):
    """The numpy plane is a view of the label buffer: it stays valid and
    unchanged after its video buffer is gone and later frames reuse the
    element's pool."""
    colours = [(200, 40, 40), (128, 128, 128), (235, 235, 235)]
    imgs = [np.full((30, 40, 3), colours[i % 3], np.uint8)
            for i in range(12)]
    caps = F.caps_string("RGB", 40, 30)
    out = run("labsegment min-class-pixels=0", imgs, caps)
    planes = [meta.labels(b).plane for b in out]
    del out
    run("labsegment min-class-pixels=0", imgs[::-1], caps)
    expect = [1, 7, 6] * 4
    assert [int(p[0, 0]) for p in planes] == expect
    assert all((p == p[0, 0]).all() for p in planes)
    assert not planes[0].flags.writeable


def test_histogram_messages(gst):
    img = F.natural_rgb(np.random.default_rng(3), 48, 64)
    caps = F.caps_string("RGB", 64, 48)
    Gst = pipeline.Gst
    pipe = Gst.parse_launch(
        f"appsrc name=src format=time caps={caps} ! labsegment "
        "post-messages=true min-class-pixels=100 ! fakesink")
    src = pipe.get_by_name("src")
    bus = pipe.get_bus()
    pipe.set_state(Gst.State.PLAYING)
    try:
        for i in range(3):
            buf = Gst.Buffer.new_wrapped(img.tobytes())
            buf.pts = i * Gst.SECOND
            src.emit("push-buffer", buf)
        src.emit("end-of-stream")
        msgs = []
        while True:
            msg = bus.timed_pop_filtered(
                10 * Gst.SECOND, Gst.MessageType.ELEMENT |
                Gst.MessageType.EOS | Gst.MessageType.ERROR)
            assert msg is not None and msg.type != Gst.MessageType.ERROR
            if msg.type == Gst.MessageType.EOS:
                break
            msgs.append(msg.get_structure())
    finally:
        pipe.set_state(Gst.State.NULL)
    seg = reference.segment_rgb(img, palette.default_palette(),
                                min_class_pixels=100)
    assert [m.get_name() for m in msgs] == ["landmark-histogram"] * 3
    assert [m.get_value("timestamp") for m in msgs] == [
        i * Gst.SECOND for i in range(3)]
    for m in msgs:
        counts = m.get_value("class-counts")
        assert [counts[i] for i in range(len(counts))] == seg.counts.tolist()
        active = m.get_value("class-active")
        assert [bool(active[i]) for i in range(len(active))] == \
            seg.active.tolist()
        assert m.get_value("min-class-pixels") == 100


def test_second_segmentation_replaces_first(gst):
    """Two labsegments in a row: readers see the last one's labels."""
    root = os.environ.get("LANDMARK_SOURCE_ROOT",
                          os.path.join(os.path.dirname(__file__), "..", ".."))
    custom = os.path.join(root, "tests", "files", "palettes",
                          "good-custom.json")
    img = F.natural_rgb(np.random.default_rng(8), 30, 40)
    caps = F.caps_string("RGB", 40, 30)
    out = run(f"labsegment min-class-pixels=0 ! labsegment palette={custom} "
              "min-class-pixels=0", [img], caps)
    lm = meta.labels(out[0])
    custom_pal = palette.load_palette(custom)
    assert lm.class_names == custom_pal.names
    seg = reference.segment_rgb(img, custom_pal, min_class_pixels=0)
    np.testing.assert_array_equal(lm.plane, seg.labels)


@pytest.mark.parametrize("rare", ["nearest", "unlabelled"])
@pytest.mark.parametrize("kind", ["random", "natural"])
def test_rare_classes_agree_with_reference(gst, rare, kind):
    rng = np.random.default_rng(17)
    pal = palette.default_palette()
    make = F.random_rgb if kind == "random" else F.natural_rgb
    images = [make(rng, 96, 128) for _ in range(3)]
    caps = F.caps_string("BGR", 128, 96)
    info = F.video_info(caps)
    payloads = [F.pack_rgb(img, "BGR", info, rng) for img in images]
    out = run(f"labsegment min-class-pixels=1200 rare-classes={rare}",
              payloads, caps)
    for img, buf in zip(images, out):
        seg = reference.segment_rgb(img, pal, min_class_pixels=1200,
                                    rare_classes=rare)
        lm = meta.labels(buf)
        assert not seg.active.all(), "the frame must have rare classes"
        assert agreement(lm.plane, seg.labels, rare) >= 0.999
        check_meta(lm, seg, pal, 128, 96, 1200)


def test_palette_set_again_is_read_again(gst, tmp_path):
    """Setting `palette` while playing reads the file again even when the
    name is the same, so an edited palette takes effect without a restart;
    the frames in between keep the palette read before."""
    from gi.repository import GstVideo
    root = os.environ.get("LANDMARK_SOURCE_ROOT",
                          os.path.join(os.path.dirname(__file__), "..", ".."))
    files = os.path.join(root, "tests", "files", "palettes")
    first = palette.load_palette(os.path.join(files, "good-custom.json"))
    second = palette.load_palette(os.path.join(files, "good-alt.json"))
    assert first.names != second.names
    path = tmp_path / "palette.json"
    path.write_text(open(os.path.join(files, "good-custom.json")).read())

    caps = F.caps_string("RGB", 40, 30)
    info = GstVideo.VideoInfo.new_from_caps(gst.Caps.from_string(caps))
    img = F.natural_rgb(np.random.default_rng(9), 30, 40)
    pipe = gst.parse_launch(
        f"appsrc name=src format=time caps={caps} ! labsegment name=seg "
        f"palette={path} min-class-pixels=0 ! appsink name=sink sync=false")
    src, sink = pipe.get_by_name("src"), pipe.get_by_name("sink")
    seg = pipe.get_by_name("seg")

    def names_of_next_frame():
        src.emit("push-buffer", gst.Buffer.new_wrapped(
            pipeline.frame_bytes(img, info)))
        sample = sink.emit("try-pull-sample", 10 * gst.SECOND)
        assert sample is not None
        return meta.labels(sample.get_buffer()).class_names

    pipe.set_state(gst.State.PLAYING)
    try:
        assert names_of_next_frame() == first.names
        # the file changes, but nobody said so: the palette read stays
        path.write_text(open(os.path.join(files, "good-alt.json")).read())
        assert names_of_next_frame() == first.names
        seg.set_property("palette", str(path))
        assert names_of_next_frame() == second.names
    finally:
        pipe.set_state(gst.State.NULL)


def _srgb8_under_gain(lab, gain):
    """The 8-bit sRGB of an L*a*b* colour whose linear light is scaled by
    gain (the sRGB curve, IEC 61966-2-1)."""
    rgb = reference.lab_to_srgb8(np.array([lab], np.float64))[0] / 255.0
    lin = np.where(rgb <= 0.04045, rgb / 12.92,
                   ((rgb + 0.055) / 1.055) ** 2.4) * gain
    out = np.where(lin <= 0.0031308, 12.92 * lin,
                   1.055 * lin ** (1 / 2.4) - 0.055)
    return np.clip(np.rint(out * 255), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("fmt", ["RGB", "I420"])
def test_adapt_follows_exposure(gst, tmp_path, fmt):
    """A red disc on a grey floor, the palette red, maroon (red with half
    the light) and grey. The camera loses one stop over 20 frames: without
    adapt the disc becomes maroon; with it the gains follow the grey floor
    to about a half and the disc stays red, the meta saying by what gains."""
    red, grey = (50.0, 60.0, 45.0), (60.0, 0.0, 0.0)
    maroon = reference.rgb_to_lab(
        _srgb8_under_gain(red, 0.5)[None, None, :])[0, 0].tolist()
    pal_file = tmp_path / "p.json"
    palette.save_palette(palette.parse_palette({"classes": [
        {"name": "red", "lab": list(red), "role": "marker"},
        {"name": "maroon", "lab": maroon, "role": "marker"},
        {"name": "grey", "lab": list(grey), "role": "floor"}]}), pal_file)
    yy, xx = np.mgrid[:120, :160]
    disc = (yy - 60) ** 2 + (xx - 80) ** 2 < 30 ** 2
    frames = []
    for i in range(60):
        gain = 2.0 ** -min(1.0, i / 20)
        img = np.empty((120, 160, 3), np.uint8)
        img[:] = _srgb8_under_gain(grey, gain)
        img[disc] = _srgb8_under_gain(red, gain)
        frames.append(img)
    convert = "" if fmt == "RGB" else \
        f"videoconvert ! video/x-raw,format={fmt} ! "
    chain = f"{convert}labsegment palette={pal_file}"
    caps = F.caps_string("RGB", 160, 120)
    plain = run(chain, frames, caps)
    adapted = run(f"{chain} adapt=true", frames, caps)

    def centre(buf):
        return int(meta.labels(buf).plane[60, 80])

    def gains(buf):
        s = buf.get_custom_meta(meta.LABELS_META).get_structure()
        return None if not s.has_field("colour-gains") else \
            meta._values(s, "colour-gains")

    assert centre(plain[0]) == centre(adapted[0]) == 1
    assert centre(plain[-1]) == 2, "one stop darker, red is maroon"
    assert [centre(b) for b in adapted[35:]] == [1] * 25, \
        [centre(b) for b in adapted]
    assert gains(plain[-1]) is None
    assert all(abs(g - 0.5) < 0.05 for g in gains(adapted[-1])), \
        gains(adapted[-1])


def test_shading_agrees_with_reference(gst, tmp_path):
    """A palette whose classes stand for their colours under less and more
    light (docs/palette.md, "Shading"): the element labels as the
    reference's distance to each shading segment does, and a darker copy
    of a marker's colour keeps its class only with shading."""
    rng = np.random.default_rng(11)
    pal = palette.Palette(palette.default_palette().classes + [
        palette.PaletteClass(name="black", lab=(10.0, 0.0, 0.0),
                             role="background")])
    shaded = palette.Palette([
        palette.PaletteClass(name=c.name, lab=c.lab, role=c.role,
                             references=c.references,
                             shading=(0.125, 2.0) if c.marker else (1, 1))
        for c in pal.classes])
    path = tmp_path / "shaded.json"
    palette.save_palette(shaded, path)
    assert palette.load_palette(path).classes[0].shading == (0.125, 2.0)
    images = [F.natural_rgb(rng, 120, 160), F.random_rgb(rng, 120, 160)]
    caps = F.caps_string("RGB", 160, 120)
    element = f"labsegment palette={path}"
    for img, buf in zip(images, run(element, images, caps)):
        seg = reference.segment_rgb(img, shaded)
        assert agreement(meta.labels(buf).plane, seg.labels, element) >= 0.999
    # red under an eighth of its light: the plain palette calls it black,
    # the shaded one red
    red = pal.classes[pal.index("red")]
    dark = palette.lab_under_light(red.lab, 0.125)
    pixel = reference.lab_to_srgb8(dark[None, :])[0]
    frame = np.tile(pixel, (8, 8, 1)).astype(np.uint8)
    plain = reference.segment_rgb(frame, pal, min_class_pixels=0).labels
    with_shading = reference.segment_rgb(frame, shaded,
                                         min_class_pixels=0).labels
    assert (plain == pal.index("black") + 1).all()
    assert (with_shading == pal.index("red") + 1).all()
