"""Tests of gstlandmark.palette and the ``gst-landmark palette`` command."""

import json
import math
import os

import cv2
import numpy as np
import pytest

from gstlandmark import reference
from gstlandmark.commands import cli
from gstlandmark.palette import (Palette, PaletteClass, PaletteError,
                                 default_palette, learn_from_mask,
                                 learn_from_rects, load_palette,
                                 palette_to_json, parse_palette,
                                 save_palette)

# Published L*a*b* (D65) of some sRGB colours, keyed by BGR (OpenCV order).
KNOWN_LAB = {
    (0, 0, 255): (53.24, 80.09, 67.20),        # red
    (0, 255, 0): (87.73, -86.18, 83.18),       # green
    (255, 0, 0): (32.30, 79.19, -107.86),      # blue
    (255, 255, 255): (100.0, 0.0, 0.0),        # white
    (128, 128, 128): (53.59, 0.0, 0.0),        # grey
}
RED, GREEN, BLUE, WHITE, GREY = KNOWN_LAB


def good_class(name="red", lab=(50.0, 40.0, 30.0), **extra):
    entry = {"name": name, "lab": list(lab)}
    entry.update(extra)
    return entry


def write_json(path, obj):
    path.write_text(json.dumps(obj), encoding="utf-8")
    return path


# ---------------------------------------------------------------------------
# The default palette


def test_default_palette_classes():
    palette = default_palette()
    assert palette.names == ["red", "green", "yellow", "pink", "blue",
                             "white", "grey"]
    assert palette.markers == ["red", "green", "yellow", "pink", "blue"]
    assert palette.background == ["white", "grey"]
    assert palette.floor == ["white", "grey"]
    assert palette.marker_mask().tolist() == [True] * 5 + [False] * 2
    lab = palette.lab_array()
    assert lab.dtype == np.float64 and lab.shape == (7, 3)
    np.testing.assert_allclose(lab[0], [41.25, 43.0, 32.0])
    assert palette.index("grey") == 6


def test_default_palette_matches_the_package_file():
    from importlib.resources import files
    text = (files("gstlandmark") / "data" / "default-palette.json") \
        .read_text("utf-8")
    obj = json.loads(text)
    assert [c["name"] for c in obj["classes"]] == default_palette().names


# ---------------------------------------------------------------------------
# Validation: one failing case per rule, loaded from "palette.json".

FIVE = ["red", "green", "yellow", "pink", "blue"]


def five_with(index, entry):
    """Five good classes with classes[index] replaced by ``entry``."""
    classes = [good_class(n) for n in FIVE]
    classes[index] = entry
    return {"classes": classes}


BAD_PALETTES = [
    ([good_class()], "top level must be an object"),
    ({"colours": [good_class()]}, 'missing "classes"'),
    ({"classes": {"red": [1, 2, 3]}}, '"classes" must be an array'),
    ({"classes": []}, '"classes" is empty'),
    ({"classes": [good_class(f"c{i}") for i in range(65)]},
     '"classes" has 65 entries, at most 64'),
    (five_with(1, "green"), "classes[1]: must be an object"),
    (five_with(2, good_class("yellow", colour="y")),
     'classes[2] ("yellow"): unknown key "colour"'),
    (five_with(2, good_class("yellow", Marker=True)),
     'classes[2] ("yellow"): unknown key "Marker"'),
    (five_with(3, {"lab": [50, 0, 0]}), 'classes[3]: missing "name"'),
    (five_with(3, good_class(7)), 'classes[3]: "name" must be a string'),
    (five_with(3, good_class("")), '"name" must not be empty'),
    (five_with(3, good_class("x" * 33)),
     '"name" must be at most 32 characters, got 33'),
    (five_with(3, good_class("light red")), "may only contain"),
    (five_with(3, good_class("r\u00f8d")), "may only contain"),
    (five_with(3, good_class("red/2")), "may only contain"),
    (five_with(4, good_class("red")),
     'classes[4] ("red"): duplicate name, already used by classes[0]'),
    (five_with(2, {"name": "yellow"}), 'classes[2] ("yellow"): missing "lab"'),
    (five_with(2, good_class("yellow", lab=[50, 0])),
     '"lab" must be an array of 3 numbers [L*, a*, b*], got 2 values'),
    (five_with(2, good_class("yellow", lab=[50, 0, 0, 1])), "got 4 values"),
    (five_with(2, {"name": "yellow", "lab": "50 0 0"}),
     '"lab" must be an array of 3 numbers [L*, a*, b*], got string'),
    (five_with(2, good_class("yellow", lab=[50, True, 0])),
     '"lab"[1] must be a number, got boolean'),
    (five_with(2, good_class("yellow", lab=[50, 0, "0"])),
     '"lab"[2] must be a number, got string'),
    (five_with(2, good_class("yellow", lab=[50, None, 0])),
     '"lab"[1] must be a number, got null'),
    (five_with(2, good_class("yellow", lab=[float("nan"), 0, 0])),
     '"lab"[0] must be finite, got nan'),
    (five_with(2, good_class("yellow", lab=[50, float("inf"), 0])),
     '"lab"[1] must be finite, got inf'),
    (five_with(3, good_class("pink", lab=[120, 0, 0])),
     'classes[3] ("pink"): "lab" L* must be within 0..100, got 120'),
    (five_with(3, good_class("pink", lab=[-0.5, 0, 0])),
     '"lab" L* must be within 0..100, got -0.5'),
    (five_with(3, good_class("pink", lab=[100.5, 0, 0])),
     '"lab" L* must be within 0..100, got 100.5'),
    (five_with(3, good_class("pink", lab=[50, -128.5, 0])),
     '"lab" a* must be within -128..128, got -128.5'),
    (five_with(3, good_class("pink", lab=[50, 128.5, 0])),
     '"lab" a* must be within -128..128, got 128.5'),
    (five_with(3, good_class("pink", lab=[50, 0, -129])),
     '"lab" b* must be within -128..128, got -129'),
    (five_with(3, good_class("pink", lab=[50, 0, 10 ** 400])),
     '"lab" b* must be within -128..128'),
    (five_with(0, good_class("red", marker="yes")),
     'classes[0] ("red"): "marker" must be true or false, got "yes"'),
    (five_with(0, good_class("red", marker=1)),
     '"marker" must be true or false, got 1'),
    # several reference colours per class
    (five_with(2, good_class("yellow", references=[[90, -10, 80],
                                                   [50, "5", 50]])),
     'classes[2] ("yellow"): "references"[1][1] must be a number, '
     'got string'),
    (five_with(2, good_class("yellow", references=[[90, -10, 80],
                                                   [50, 5]])),
     'classes[2] ("yellow"): "references"[1] must be an array of 3 '
     'numbers [L*, a*, b*], got 2 values'),
    (five_with(2, good_class("yellow", references=[[50, 0, 0]] * 33)),
     'classes[2] ("yellow"): "references" must hold 1 to 32 colours, got 33'),
    (five_with(2, good_class("yellow", references=[])),
     'classes[2] ("yellow"): "references" must hold 1 to 32 colours, got 0'),
    (five_with(2, good_class("yellow", references=[50, 0, 0])),
     'classes[2] ("yellow"): "references"[0] must be an array of 3 '
     'numbers [L*, a*, b*], got number'),
    (five_with(2, good_class("yellow", references={"lit": [50, 0, 0]})),
     'classes[2] ("yellow"): "references" must be an array of [L*, a*, b*] '
     'arrays, got object'),
    (five_with(2, good_class("yellow", references=[[101, 0, 0]])),
     'classes[2] ("yellow"): "references"[0] L* must be within 0..100, '
     'got 101'),
    (five_with(2, good_class("yellow", references=[[50, 0, 0],
                                                   [50, -130, 0]])),
     'classes[2] ("yellow"): "references"[1] a* must be within -128..128, '
     'got -130'),
    (five_with(2, good_class("yellow", references=[[50, float("nan"), 0]])),
     '"references"[0][1] must be finite, got nan'),
]


@pytest.mark.parametrize("obj, fragment", BAD_PALETTES)
def test_invalid_palette_file(tmp_path, obj, fragment):
    path = write_json(tmp_path / "palette.json", obj)
    with pytest.raises(PaletteError) as info:
        load_palette(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ")
    assert fragment in message


def test_brief_example_message_exactly(tmp_path):
    path = write_json(tmp_path / "palette.json",
                      five_with(2, good_class("pink", lab=[120, 0, 0])))
    with pytest.raises(PaletteError) as info:
        load_palette(path)
    assert str(info.value) == (f'{path}: classes[2] ("pink"): "lab" L* must '
                               f'be within 0..100, got 120')


def test_parse_palette_names_its_source():
    with pytest.raises(PaletteError, match=r'^<palette>: "classes" is empty'):
        parse_palette({"classes": []})
    with pytest.raises(PaletteError, match=r"^mine: "):
        parse_palette({"classes": []}, source="mine")


def test_palette_error_is_a_value_error():
    assert issubclass(PaletteError, ValueError)


def test_valid_edge_cases(tmp_path):
    classes = [
        good_class("a" * 32, lab=(0, -128, 128)),
        good_class("B.b-b_9", lab=(100, 128, -128), marker=False),
        {"name": "c", "lab": [50, 1, 2]},
    ]
    classes += [good_class(f"x{i}") for i in range(61)]
    path = write_json(tmp_path / "palette.json",
                      {"description": "ignored", "learned-from": "x.png",
                       "version": 3, "classes": classes})
    palette = load_palette(path)
    assert len(palette) == 64
    first, second, third = palette.classes[:3]
    assert first == PaletteClass("a" * 32, (0.0, -128.0, 128.0), True)
    assert second.marker is False
    assert third.marker is True   # default
    assert all(isinstance(v, float) for v in third.lab)


def test_missing_file(tmp_path):
    path = tmp_path / "nope.json"
    with pytest.raises(PaletteError, match="nope.json: no such file"):
        load_palette(path)


def test_directory_is_not_a_palette(tmp_path):
    with pytest.raises(PaletteError, match="is a directory"):
        load_palette(tmp_path)


@pytest.mark.skipif(os.geteuid() == 0, reason="root can read any file")
def test_unreadable_file(tmp_path):
    path = write_json(tmp_path / "palette.json",
                      {"classes": [good_class()]})
    path.chmod(0)
    with pytest.raises(PaletteError, match="palette.json: cannot read"):
        load_palette(path)


def test_malformed_json_gives_line_and_column(tmp_path):
    path = tmp_path / "palette.json"
    path.write_text('{\n  "classes": [\n    {"name": "red",}\n  ]\n}\n')
    with pytest.raises(PaletteError) as info:
        load_palette(path)
    message = str(info.value)
    assert message.startswith(f"{path}: not valid JSON")
    # Python 3.11 points at the brace after the trailing comma, 3.13 at
    # the comma
    assert ("line 3, column 20" in message
            or "line 3, column 19" in message), message


def test_invalid_utf8(tmp_path):
    path = tmp_path / "palette.json"
    path.write_bytes(b'{"classes": [{"name": "r\xff"}]}')
    with pytest.raises(PaletteError, match="palette.json: not valid UTF-8"):
        load_palette(path)


# ---------------------------------------------------------------------------
# Saving


def test_save_and_load_round_trip(tmp_path):
    palette = Palette([PaletteClass("red", (41.25, 43.0, 32.0), True),
                       PaletteClass("floor", (60.123456, -1.5, 2.0), False)])
    path = tmp_path / "out.json"
    save_palette(palette, path, description="test",
                 **{"learned-from": "img.png"})
    obj = json.loads(path.read_text())
    assert list(obj) == ["description", "learned-from", "classes"]
    assert obj["learned-from"] == "img.png"
    assert obj["classes"][1] == {"name": "floor",
                                 "lab": [60.1235, -1.5, 2.0],
                                 "marker": False, "role": "background"}
    loaded = load_palette(path)
    assert loaded.names == palette.names
    assert loaded.markers == ["red"]
    np.testing.assert_allclose(loaded.lab_array(), palette.lab_array(),
                               atol=1e-4)


def test_references_load_and_round_trip(tmp_path):
    obj = {"classes": [
        good_class("yellow", (75, -5, 70),
                   references=[[90, -15, 80], [55.123456, 4, 55]]),
        good_class("grey", (53.58, 0, 0), marker=False)]}
    palette = load_palette(write_json(tmp_path / "p.json", obj))
    yellow, grey = palette.classes
    assert yellow.references == ((90.0, -15.0, 80.0), (55.123456, 4.0, 55.0))
    assert yellow.reference_labs == yellow.references
    assert grey.references == () and grey.reference_labs == (grey.lab,)
    assert palette.has_references
    refs, owner = palette.reference_arrays()
    np.testing.assert_array_equal(refs, [[90, -15, 80], [55.123456, 4, 55],
                                         [53.58, 0, 0]])
    assert owner.tolist() == [0, 0, 1]
    # lab stays the class colour
    np.testing.assert_array_equal(palette.lab_array(), [[75, -5, 70],
                                                        [53.58, 0, 0]])
    path = tmp_path / "out.json"
    save_palette(palette, path)
    saved = json.loads(path.read_text())["classes"]
    assert saved[0] == {"name": "yellow", "lab": [75.0, -5.0, 70.0],
                        "references": [[90.0, -15.0, 80.0],
                                       [55.1235, 4.0, 55.0]],
                        "marker": True, "role": "marker"}
    assert "references" not in saved[1]
    assert load_palette(path).classes[0].references[1] == (55.1235, 4.0,
                                                           55.0)


def test_palette_without_references_is_unchanged():
    """An old palette: one reference per class, the class colour."""
    palette = default_palette()
    assert not palette.has_references
    refs, owner = palette.reference_arrays()
    np.testing.assert_array_equal(refs, palette.lab_array())
    assert owner.tolist() == list(range(len(palette)))
    saved = palette_to_json(palette)["classes"]
    assert all(list(entry) == ["name", "lab", "marker", "role"]
               for entry in saved)


def test_palette_to_json_keeps_extra_keys():
    palette = default_palette()
    obj = palette_to_json(palette, description="d")
    assert obj["description"] == "d"
    assert parse_palette(obj).names == palette.names
    with pytest.raises(ValueError):
        palette_to_json(palette, classes=[])


def test_save_refuses_an_invalid_palette(tmp_path):
    palette = Palette([PaletteClass("red", (150.0, 0.0, 0.0), True)])
    path = tmp_path / "bad.json"
    with pytest.raises(PaletteError, match="L\\* must be within"):
        save_palette(palette, path)
    assert not path.exists()


# ---------------------------------------------------------------------------
# Learning


def synthetic_scene():
    """A 60x80 BGR image with known colours and a class-index mask.

    Class 1 (red) is an irregular blob, class 2 mixes blue and white
    pixels half and half, class 3 is grey.  Unmasked pixels include more
    red and green, which must not count.
    """
    image = np.zeros((60, 80, 3), np.uint8)
    image[:] = GREEN
    image[:, 60:] = RED
    mask = np.zeros((60, 80), np.uint8)
    yy, xx = np.mgrid[:60, :80]
    blob = (yy - 20) ** 2 + (xx - 20) ** 2 < 12 ** 2
    image[blob] = RED
    mask[blob] = 1
    image[40:50, 5:45:2] = BLUE
    image[40:50, 6:46:2] = WHITE
    mask[40:50, 5:45] = 2
    image[5:15, 40:55] = GREY
    mask[5:15, 40:55] = 3
    return image, mask


def test_learn_from_mask_recovers_known_colours():
    image, mask = synthetic_scene()
    palette = learn_from_mask(image, mask, names=["red", "mix", "grey"],
                              markers=["red", "mix"])
    assert palette.names == ["red", "mix", "grey"]
    assert palette.markers == ["red", "mix"]
    lab = palette.lab_array()
    np.testing.assert_allclose(lab[0], KNOWN_LAB[RED], atol=0.1)
    mix = (np.array(KNOWN_LAB[BLUE]) + np.array(KNOWN_LAB[WHITE])) / 2
    np.testing.assert_allclose(lab[1], mix, atol=0.1)
    np.testing.assert_allclose(lab[2], KNOWN_LAB[GREY], atol=0.1)


def test_learn_from_mask_uses_the_reference_conversion():
    rng = np.random.default_rng(3)
    image = rng.integers(0, 256, (20, 30, 3)).astype(np.uint8)
    mask = rng.integers(0, 3, (20, 30)).astype(np.uint8)
    palette = learn_from_mask(image, mask)
    lab = reference.rgb_to_lab(image[:, :, ::-1].copy()).astype(np.float64)
    for k in (1, 2):
        np.testing.assert_allclose(palette.lab_array()[k - 1],
                                   lab[mask == k].mean(axis=0), atol=1e-9)


def test_learn_from_mask_default_names_and_markers():
    image, mask = synthetic_scene()
    palette = learn_from_mask(image, mask)
    assert palette.names == ["class1", "class2", "class3"]
    assert palette.markers == palette.names


def test_learn_from_mask_errors():
    image, mask = synthetic_scene()
    with pytest.raises(PaletteError, match='class "b" has no pixels'):
        learn_from_mask(image, np.where(mask == 2, 0, mask),
                        names=["a", "b", "c"])
    with pytest.raises(PaletteError, match="mask is 80x59 but the image "
                                           "is 80x60"):
        learn_from_mask(image, mask[:59])
    with pytest.raises(PaletteError, match="class index 3 but there are "
                                           "only 2 class names"):
        learn_from_mask(image, mask, names=["a", "b"])
    with pytest.raises(PaletteError, match='"pink" is not one of'):
        learn_from_mask(image, mask, markers=["pink"])
    with pytest.raises(PaletteError, match="no class pixels"):
        learn_from_mask(image, np.zeros_like(mask))
    with pytest.raises(PaletteError, match="may only contain"):
        learn_from_mask(image, mask, names=["a", "b b", "c"])


def test_learn_from_mask_allow_missing_leaves_classes_out(capsys):
    image, mask = synthetic_scene()
    without_mix = np.where(mask == 2, 0, mask)
    palette = learn_from_mask(image, without_mix,
                              names=["red", "mix", "grey", "absent"],
                              markers=["red", "mix", "absent"],
                              allow_missing=True)
    # the others keep their order, colours and marker flags
    assert palette.names == ["red", "grey"]
    assert palette.markers == ["red"]
    np.testing.assert_allclose(palette.lab_array()[0], KNOWN_LAB[RED],
                               atol=0.1)
    np.testing.assert_allclose(palette.lab_array()[1], KNOWN_LAB[GREY],
                               atol=0.1)
    err = capsys.readouterr().err
    assert err.startswith("warning: ")
    assert '"mix"' in err and '"absent"' in err and '"red"' not in err
    # nothing missing: no warning, the same palette as without the option
    same = learn_from_mask(image, mask, names=["red", "mix", "grey"],
                           allow_missing=True)
    assert same == learn_from_mask(image, mask,
                                   names=["red", "mix", "grey"])
    assert capsys.readouterr().err == ""


def test_learn_from_mask_missing_class_is_an_error_by_default(capsys):
    image, mask = synthetic_scene()
    with pytest.raises(PaletteError, match='class "absent" has no pixels'):
        learn_from_mask(image, mask, names=["red", "mix", "grey", "absent"])
    # every class missing is an error even when allowed
    with pytest.raises(PaletteError, match="no class has any pixels"):
        learn_from_mask(image, np.zeros_like(mask), names=["a", "b"],
                        allow_missing=True)
    with pytest.raises(PaletteError, match="no class pixels"):
        learn_from_mask(image, np.zeros_like(mask), allow_missing=True)
    assert capsys.readouterr().err == ""


def test_learn_from_rects_pools_rectangles():
    image, _ = synthetic_scene()
    palette = learn_from_rects(
        image,
        [("grey", 40, 5, 15, 10), ("red", 60, 0, 20, 10),
         ("red", 15, 15, 10, 10), ("green", 0, 55, 50, 5)],
        background=["grey"])
    assert palette.names == ["grey", "red", "green"]
    assert palette.markers == ["red", "green"]
    assert palette.background == ["grey"]
    lab = palette.lab_array()
    np.testing.assert_allclose(lab[0], KNOWN_LAB[GREY], atol=0.1)
    np.testing.assert_allclose(lab[1], KNOWN_LAB[RED], atol=0.1)
    np.testing.assert_allclose(lab[2], KNOWN_LAB[GREEN], atol=0.1)


def test_learn_from_rects_counts_each_pixel_once():
    image = np.zeros((10, 10, 3), np.uint8)
    image[:, :5] = WHITE
    # Two overlapping rectangles of one class: the overlap (white) must not
    # weigh double, or the mean would lean towards white.
    palette = learn_from_rects(image, [("c", 0, 0, 10, 10),
                                       ("c", 0, 0, 5, 10)])
    np.testing.assert_allclose(palette.lab_array()[0], [50.0, 0.0, 0.0],
                               atol=0.01)


def test_learn_from_rects_errors():
    image, _ = synthetic_scene()
    with pytest.raises(PaletteError, match="does not fit inside the 80x60"):
        learn_from_rects(image, [("red", 70, 0, 20, 10)])
    with pytest.raises(PaletteError, match='overlaps a rectangle of "red"'):
        learn_from_rects(image, [("red", 0, 0, 10, 10),
                                 ("grey", 5, 5, 10, 10)])
    with pytest.raises(PaletteError, match="must be positive"):
        learn_from_rects(image, [("red", 0, 0, 0, 10)])
    with pytest.raises(PaletteError, match='"white" is not one of'):
        learn_from_rects(image, [("red", 0, 0, 5, 5)], background=["white"])
    with pytest.raises(PaletteError, match="no rectangles"):
        learn_from_rects(image, [])


# ---------------------------------------------------------------------------
# The command line, end to end


@pytest.fixture
def scene_files(tmp_path):
    image, mask = synthetic_scene()
    image_path = tmp_path / "scene.png"
    mask_path = tmp_path / "mask.png"
    assert cv2.imwrite(str(image_path), image)
    assert cv2.imwrite(str(mask_path), mask)
    return image_path, mask_path


def test_cli_learn_mask_check_load(tmp_path, scene_files, capsys):
    image_path, mask_path = scene_files
    out = tmp_path / "learned.json"
    status = cli.main(["palette", "learn", str(image_path), "--mask",
                       str(mask_path), "--names", "red,mix,grey",
                       "--markers", "red", "-o", str(out)])
    assert status == 0
    obj = json.loads(out.read_text())
    assert obj["learned-from"] == str(image_path)
    assert obj["description"]

    capsys.readouterr()
    assert cli.main(["palette", "check", str(out)]) == 0
    table = capsys.readouterr().out
    # the untaught green (the image's left part) is a class of its own;
    # the untaught red (its right part) is red's
    assert "4 classes" in table
    red_row = next(line for line in table.splitlines()
                   if line.startswith("red "))
    assert red_row.split() == ["red", "53.24", "80.09", "67.20", "marker",
                               "#FF0000"]
    grey_row = next(line for line in table.splitlines()
                    if line.startswith("grey "))
    assert grey_row.split()[4:] == ["background", "#808080"]

    palette = load_palette(out)
    assert palette.names == ["red", "mix", "grey", "untaught"]
    assert palette.markers == ["red"]
    np.testing.assert_allclose(palette.lab_array()[2], KNOWN_LAB[GREY],
                               atol=0.1)
    np.testing.assert_allclose(palette.lab_array()[3], KNOWN_LAB[GREEN],
                               atol=0.1)
    assert palette.classes[3].role == "background"
    assert cli.main(["palette", "learn", str(image_path), "--mask",
                     str(mask_path), "--names", "red,mix,grey", "--markers",
                     "red", "--untaught", "none", "-o", str(out)]) == 0
    assert load_palette(out).names == ["red", "mix", "grey"]
    # without --floor, floorboundary would take the untaught class as
    # floor: said once
    capsys.readouterr()
    assert cli.main(["palette", "learn", str(image_path), "--mask",
                     str(mask_path), "--names", "red,mix,grey", "--markers",
                     "red", "-o", str(out)]) == 0
    assert "'untaught' (what the mask left out) included" in \
        capsys.readouterr().err
    assert cli.main(["palette", "learn", str(image_path), "--mask",
                     str(mask_path), "--names", "red,mix,grey", "--markers",
                     "red", "--floor", "grey", "-o", str(out)]) == 0
    assert "note:" not in capsys.readouterr().err


def test_cli_learn_mask_allow_missing(tmp_path, scene_files, capsys):
    image_path, mask_path = scene_files
    out = tmp_path / "learned.json"
    args = ["palette", "learn", str(image_path), "--mask", str(mask_path),
            "--names", "red,mix,grey,absent", "--markers", "red,absent",
            "--untaught", "none",
            "-o", str(out)]
    # by default a class without pixels fails
    assert cli.main(args) == 1
    assert 'class "absent" has no pixels' in capsys.readouterr().err
    assert not out.exists()
    assert cli.main(args + ["--allow-missing"]) == 0
    assert '"absent"' in capsys.readouterr().err
    palette = load_palette(out)
    assert palette.names == ["red", "mix", "grey"]
    assert palette.markers == ["red"]


def test_cli_learn_rects(tmp_path, scene_files):
    image_path, _ = scene_files
    out = tmp_path / "rects.json"
    status = cli.main(["palette", "learn", str(image_path),
                       "--rect", "red:60,0,20,10", "--rect", "grey:40,5,15,10",
                       "--rect", "green:0,55,50,5", "--background", "grey",
                       "-o", str(out)])
    assert status == 0
    palette = load_palette(out)
    # the blue and white stripes no rectangle holds are the rest of the
    # image: a background class of their own, one reference each
    assert palette.names == ["red", "grey", "green", "untaught"]
    assert palette.markers == ["red", "green"]
    np.testing.assert_allclose(palette.lab_array()[1], KNOWN_LAB[GREY],
                               atol=0.1)
    untaught = sorted(palette.classes[3].references)
    np.testing.assert_allclose(untaught, [KNOWN_LAB[BLUE], KNOWN_LAB[WHITE]],
                               atol=0.1)
    assert cli.main(["palette", "learn", str(image_path),
                     "--rect", "red:60,0,20,10", "--rect", "grey:40,5,15,10",
                     "--rect", "green:0,55,50,5", "--background", "grey",
                     "--untaught", "none", "-o", str(out)]) == 0
    assert load_palette(out).names == ["red", "grey", "green"]


ROLE_CASES = [
    # (class entry keys beyond name and lab, role read)
    ({"role": "marker"}, "marker"),
    ({"role": "floor"}, "floor"),
    ({"role": "background"}, "background"),
    ({"role": "floor", "marker": False}, "floor"),
    ({"role": "marker", "marker": True}, "marker"),
    ({"marker": True}, "marker"),          # the older form, as before
    ({"marker": False}, "background"),
    ({}, "marker"),
]


@pytest.mark.parametrize("extra,role", ROLE_CASES)
def test_roles_read_and_round_trip(tmp_path, extra, role):
    obj = {"classes": [good_class("c", (50, 1, 2), **extra)]}
    cls = load_palette(write_json(tmp_path / "p.json", obj)).classes[0]
    assert cls.role == role and cls.marker == (role == "marker")
    save_palette(Palette([cls]), tmp_path / "out.json")
    saved = json.loads((tmp_path / "out.json").read_text())["classes"][0]
    assert saved["role"] == role and saved["marker"] == (role == "marker")
    assert load_palette(tmp_path / "out.json").classes[0] == cls


@pytest.mark.parametrize("extra,fragment", [
    ({"role": "floor", "marker": True},
     'classes[0] ("c"): "marker": true contradicts "role": "floor"'),
    ({"role": "background", "marker": True},
     'classes[0] ("c"): "marker": true contradicts "role": "background"'),
    ({"role": "marker", "marker": False},
     'classes[0] ("c"): "marker": false contradicts "role": "marker"'),
    ({"role": "wall"}, 'classes[0] ("c"): "role" must be "marker", "floor" '
                       'or "background", got "wall"'),
    ({"role": 1}, 'classes[0] ("c"): "role" must be "marker", "floor" or '
                  '"background"'),
    ({"role": None}, 'classes[0] ("c"): "role" must be "marker", "floor" '
                     'or "background"'),
    ({"marker": None}, 'classes[0] ("c"): "marker" must be true or false'),
])
def test_roles_that_contradict_or_are_unknown_fail(gst, tmp_path, extra,
                                                  fragment):
    """The loader and the element refuse the same files, naming the
    class."""
    from gstlandmark import pipeline
    path = write_json(tmp_path / "p.json",
                      {"classes": [good_class("c", (50, 1, 2), **extra)]})
    with pytest.raises(PaletteError) as err:
        load_palette(path)
    assert f"{path}: {fragment}" in str(err.value)
    with pytest.raises(pipeline.PipelineError) as err:
        pipeline.run_to_eos(f"videotestsrc num-buffers=1 ! labsegment "
                            f"palette={path} ! fakesink")
    # the element says the same, without the value
    assert f"{path}: {fragment.split(', got')[0]}" in str(err.value)


def test_palette_class_role_and_flag_agree():
    assert PaletteClass("a", (50, 0, 0)).role == "marker"
    assert PaletteClass("a", (50, 0, 0), False).role == "background"
    assert PaletteClass("a", (50, 0, 0), role="floor").marker is False
    with pytest.raises(PaletteError, match="contradicts"):
        PaletteClass("a", (50, 0, 0), True, role="floor")


def test_learn_floor_classes(tmp_path, scene_files):
    """--floor names the floor classes: with --markers the rest are
    background, with --background or neither list the rest markers."""
    image_path, mask_path = scene_files
    image, mask = synthetic_scene()
    pal = learn_from_mask(image, mask, names=["red", "mix", "grey"],
                          markers=["red"], floor=["grey"])
    assert [c.role for c in pal.classes] == ["marker", "background", "floor"]
    pal = learn_from_mask(image, mask, names=["red", "mix", "grey"],
                          floor=["grey"])
    assert [c.role for c in pal.classes] == ["marker", "marker", "floor"]
    with pytest.raises(PaletteError, match='"grey" is given as floor and '
                                           'as a marker'):
        learn_from_mask(image, mask, names=["red", "mix", "grey"],
                        markers=["red", "grey"], floor=["grey"])
    with pytest.raises(PaletteError, match='"wood" is not one of'):
        learn_from_mask(image, mask, names=["red", "mix", "grey"],
                        floor=["wood"])
    out = tmp_path / "rects.json"
    assert cli.main(["palette", "learn", str(image_path),
                     "--rect", "red:60,0,20,10", "--rect", "grey:40,5,15,10",
                     "--rect", "green:0,55,50,5", "--floor", "grey",
                     "-o", str(out)]) == 0
    pal = load_palette(out)
    assert pal.floor == ["grey"] and pal.markers == ["red", "green"]
    out = tmp_path / "mask.json"
    assert cli.main(["palette", "learn", str(image_path), "--mask",
                     str(mask_path), "--names", "red,mix,grey", "--markers",
                     "red", "--floor", "grey", "--untaught", "none", "-o",
                     str(out)]) == 0
    assert [c.role for c in load_palette(out).classes] == \
        ["marker", "background", "floor"]


def test_cli_show_default(capsys):
    assert cli.main(["palette", "show-default"]) == 0
    shown = parse_palette(json.loads(capsys.readouterr().out))
    assert shown == default_palette()


def test_cli_check_bad_file(tmp_path, capsys):
    path = write_json(tmp_path / "palette.json",
                      five_with(3, good_class("pink", lab=[120, 0, 0])))
    assert cli.main(["palette", "check", str(path)]) == 1
    err = capsys.readouterr().err
    assert err.startswith("gst-landmark: error: ")
    assert f'{path}: classes[3] ("pink"): "lab" L*' in err


@pytest.mark.parametrize("args", [
    [],
    ["palette"],
    ["palette", "frobnicate"],
    ["palette", "learn", "x.png", "-o", "o.json"],                # no source
    ["palette", "learn", "x.png", "--mask", "m.png"],             # no -o
    ["palette", "learn", "x.png", "--rect", "red:1,2,3", "-o", "o.json"],
    ["palette", "learn", "x.png", "--rect", "red:1,2,0,4", "-o", "o.json"],
    ["palette", "learn", "x.png", "--mask", "m.png", "--rect", "r:0,0,1,1",
     "-o", "o.json"],
])
def test_cli_usage_errors_exit_2(args, capsys):
    assert cli.main(args) == 2
    assert "gst-landmark: error:" in capsys.readouterr().err


def test_cli_option_mixups_exit_2(tmp_path, scene_files, capsys):
    image_path, mask_path = scene_files
    out = str(tmp_path / "o.json")
    assert cli.main(["palette", "learn", str(image_path), "--rect",
                     "red:0,0,5,5", "--names", "red", "-o", out]) == 2
    assert cli.main(["palette", "learn", str(image_path), "--mask",
                     str(mask_path), "--background", "grey", "-o",
                     out]) == 2
    assert not os.path.exists(out)


def test_cli_bad_input_exits_1(tmp_path, scene_files, capsys):
    image_path, mask_path = scene_files
    out = tmp_path / "o.json"

    def run(*args):
        capsys.readouterr()
        status = cli.main(["palette", "learn", *map(str, args), "-o",
                           str(out)])
        return status, capsys.readouterr().err

    status, err = run(tmp_path / "missing.png", "--mask", mask_path)
    assert status == 1 and "missing.png: no such file" in err

    garbage = tmp_path / "garbage.png"
    garbage.write_text("not an image")
    status, err = run(garbage, "--mask", mask_path)
    assert status == 1 and "cannot read as an image" in err

    small = tmp_path / "small.png"
    cv2.imwrite(str(small), np.zeros((10, 10), np.uint8))
    status, err = run(image_path, "--mask", small)
    assert status == 1 and "mask is 10x10 but the image is 80x60" in err

    empty = tmp_path / "empty.png"
    _, mask = synthetic_scene()
    cv2.imwrite(str(empty), np.where(mask == 2, 0, mask).astype(np.uint8))
    status, err = run(image_path, "--mask", empty, "--names", "a,b,c")
    assert status == 1 and 'class "b" has no pixels' in err

    colour_mask = tmp_path / "colour.png"
    cv2.imwrite(str(colour_mask), synthetic_scene()[0])
    status, err = run(image_path, "--mask", colour_mask)
    assert status == 1 and "single-channel" in err

    status, err = run(image_path, "--rect", "red:70,0,20,10")
    assert status == 1 and "does not fit" in err
    assert err.startswith("gst-landmark: error: ")
    assert not out.exists()


# ---------------------------------------------------------------------------
# Several references per class in the element


def test_element_classifies_by_every_reference(gst, tmp_path):
    """labsegment with a multi-reference palette labels each pixel with the
    class of its nearest reference, as the reference implementation does,
    on random colours and on the two tones of a class."""
    from gstlandmark import meta, pipeline
    import frames as F

    obj = {"classes": [
        good_class("red", (45, 50, 40),
                   references=[[45, 50, 40], [30, 40, 25]]),
        good_class("yellow", (72, -2, 68),
                   references=[[88, -8, 80], [55, 4, 55]]),
        good_class("blue", (38, 30, -67)),
        good_class("grey", (53.58, 0, 0), marker=False,
                   references=[[53.58, 0, 0], [85, 0, 0], [25, 0, 0]])]}
    path = write_json(tmp_path / "multi.json", obj)
    pal = load_palette(path)
    rng = np.random.default_rng(5)
    img = F.random_rgb(rng, 48, 64)
    tones = reference.lab_to_srgb8(np.array([[88, -8, 80], [55, 4, 55]]))
    img[0, :2] = tones
    caps = F.caps_string("RGB", 64, 48)
    out = pipeline.process_frames(
        f"labsegment palette={path} min-class-pixels=0", [img], caps)
    lm = meta.labels(out[0])
    seg = reference.segment_rgb(img, pal, min_class_pixels=0)
    np.testing.assert_array_equal(lm.plane, seg.labels)
    assert lm.plane[0, :2].tolist() == [2, 2]
    # every class is used, so the test covers references of each
    assert set(np.unique(lm.plane).tolist()) >= {1, 2, 3, 4}


def test_element_refuses_bad_references(gst, tmp_path):
    """A palette with a bad "references" fails labsegment's start with a
    message naming the file and the class."""
    from gstlandmark import pipeline
    Gst = pipeline.Gst
    path = write_json(tmp_path / "bad.json", five_with(
        2, good_class("yellow", references=[[50, 0, 0]] * 33)))
    pipe = Gst.parse_launch(f"videotestsrc num-buffers=1 ! labsegment "
                            f"palette={path} ! fakesink")
    try:
        pipe.set_state(Gst.State.PLAYING)
        msg = pipe.get_bus().timed_pop_filtered(
            10 * Gst.SECOND, Gst.MessageType.ERROR | Gst.MessageType.EOS)
        assert msg is not None and msg.type == Gst.MessageType.ERROR
        err, debug = msg.parse_error()
        assert str(path) in err.message
        assert (f'{path}: classes[2] ("yellow"): "references" must hold 1 '
                f'to 32 colours, got 33') in debug
    finally:
        pipe.set_state(Gst.State.NULL)


# ---------------------------------------------------------------------------
# Learning several references per class

LIT_YELLOW = (88.0, -8.0, 80.0)
SHADED_YELLOW = (55.0, 4.0, 55.0)
RED_LAB = (45.0, 50.0, 40.0)


def lab_to_bgr(lab):
    return reference.lab_to_srgb8(np.array([lab], np.float64))[0][::-1]


def two_tone_scene(seed=3, noise=2.0):
    """A 'ball' (mask 1) lit on its upper 60 % and shaded below, a red
    square (mask 2) and a grey floor (mask 3), 8-bit noise of ``noise``."""
    height, width = 120, 160
    image = np.zeros((height, width, 3), np.float64)
    mask = np.full((height, width), 3, np.uint8)
    image[:] = lab_to_bgr((53.58, 0.0, 0.0))
    yy, xx = np.mgrid[:height, :width]
    ball = (yy - 60) ** 2 + (xx - 50) ** 2 <= 40 ** 2
    image[ball & (yy < 68)] = lab_to_bgr(LIT_YELLOW)
    image[ball & (yy >= 68)] = lab_to_bgr(SHADED_YELLOW)
    mask[ball] = 1
    image[20:60, 110:150] = lab_to_bgr(RED_LAB)
    mask[20:60, 110:150] = 2
    rng = np.random.default_rng(seed)
    image += rng.normal(0.0, noise, image.shape)
    return np.clip(np.rint(image), 0, 255).astype(np.uint8), mask


def labels_of(palette_path, colours_lab):
    """labsegment's labels for the given L*a*b* colours (as 8-bit sRGB)."""
    from gstlandmark import meta, pipeline
    import frames as F
    rgb = reference.lab_to_srgb8(np.array(colours_lab, np.float64))
    img = np.ascontiguousarray(rgb[None, :, :])
    out = pipeline.process_frames(
        f"labsegment palette={palette_path} min-class-pixels=0", [img],
        F.caps_string("RGB", len(colours_lab), 1))
    return meta.labels(out[0]).plane[0].tolist()


def test_learn_two_tone_ball_gives_two_references(gst, tmp_path):
    image, mask = two_tone_scene()
    cv2.imwrite(str(tmp_path / "ball.png"), image)
    cv2.imwrite(str(tmp_path / "ball-mask.png"), mask)
    paths = {}
    for refs in ("auto", "1"):
        paths[refs] = tmp_path / f"palette-{refs}.json"
        assert cli.main(["palette", "learn", str(tmp_path / "ball.png"),
                         "--mask", str(tmp_path / "ball-mask.png"),
                         "--names", "yellow,red,grey", "--markers",
                         "yellow,red", "--references", refs,
                         "-o", str(paths[refs])]) == 0
    learned = load_palette(paths["auto"])
    yellow, red, grey = learned.classes
    # the ball: its two tones, the lit (larger) side first
    assert len(yellow.references) == 2
    np.testing.assert_allclose(yellow.references[0], LIT_YELLOW, atol=1.5)
    np.testing.assert_allclose(yellow.references[1], SHADED_YELLOW,
                               atol=1.5)
    # lab stays the mean of the region (60:40 of lit and shaded)
    assert SHADED_YELLOW[0] + 5 < yellow.lab[0] < LIT_YELLOW[0] - 5
    # uniform regions: one reference, written as before
    assert red.references == () and grey.references == ()
    np.testing.assert_allclose(red.lab, RED_LAB, atol=1.0)
    saved = json.loads(paths["auto"].read_text())["classes"]
    assert "references" not in saved[1] and "references" not in saved[2]
    assert not load_palette(paths["1"]).has_references

    # both tones are yellow; a colour 40 % of the way from the shaded tone
    # to red stays yellow with two references, and goes to red with the
    # one mean colour
    toward_red = tuple(s + 0.4 * (r - s)
                       for s, r in zip(SHADED_YELLOW, RED_LAB))
    colours = [LIT_YELLOW, SHADED_YELLOW, toward_red, RED_LAB]
    assert labels_of(paths["auto"], colours) == [1, 1, 1, 2]
    single = labels_of(paths["1"], colours)
    assert single[2] == 2 and single[3] == 2

    # the chain keeps the whole shaded ball as one round yellow blob
    from gstlandmark import meta, pipeline
    import frames as F
    h, w = image.shape[:2]
    out = pipeline.process_frames(
        f"labsegment palette={paths['auto']} ! blobroundness",
        [np.ascontiguousarray(image[..., ::-1])], F.caps_string("RGB", w, h))
    (ball,) = [d for d in meta.detections(out[0])
               if d.class_name == "yellow" and d.blob["kept"]]
    disc_area = math.pi * 40 ** 2
    assert abs(ball.blob["area"] - disc_area) < 0.03 * disc_area
    assert abs(ball.blob["centroid-y"] - 60) < 1, ball.blob


def test_learn_uniform_region_gives_one_reference():
    rng = np.random.default_rng(4)
    image = np.zeros((80, 80, 3), np.float64)
    image[:] = lab_to_bgr(RED_LAB)
    image += rng.normal(0.0, 3.0, image.shape)
    image = np.clip(np.rint(image), 0, 255).astype(np.uint8)
    mask = np.ones((80, 80), np.uint8)
    learned = learn_from_mask(image, mask, names=["red"], references="auto")
    assert learned.classes[0].references == ()
    np.testing.assert_allclose(learned.classes[0].lab, RED_LAB, atol=1.0)
    # asked for, the count is kept
    forced = learn_from_mask(image, mask, names=["red"], references=3)
    assert len(forced.classes[0].references) == 3


def test_learn_auto_rule_share_and_spread():
    """The rule itself: a second tone holding under 10 % of the region adds
    no reference; two tones at most a few Delta E apart add none; two tones
    far apart add one each; never more than 4."""
    from gstlandmark.palette import cluster_references
    rng = np.random.default_rng(6)

    def tones(centres, counts, sigma=1.5):
        return np.vstack([np.asarray(c) + rng.normal(0, sigma, (n, 3))
                          for c, n in zip(centres, counts)])

    assert len(cluster_references(
        tones([LIT_YELLOW, SHADED_YELLOW], [4700, 300]))) == 1
    assert len(cluster_references(
        tones([LIT_YELLOW, SHADED_YELLOW], [4000, 1000]))) == 2
    near = (LIT_YELLOW[0] - 3.0,) + LIT_YELLOW[1:]
    assert len(cluster_references(tones([LIT_YELLOW, near],
                                        [2500, 2500]))) == 1
    # six tones whose gaps halve: every split halves the spread, up to 4
    six = [(5 + 0.6 * x, 0.0, 0.0) for x in (0, 80, 120, 140, 150, 155)]
    got = cluster_references(tones(six, [1000] * 6, sigma=1.0))
    assert len(got) == 4
    # the same pixels give the same references
    pixels = tones([LIT_YELLOW, SHADED_YELLOW], [3000, 2000])
    np.testing.assert_array_equal(cluster_references(pixels),
                                  cluster_references(pixels))


def test_learn_references_option_errors(tmp_path, scene_files, capsys):
    image, _ = synthetic_scene()
    for bad in (0, 33, "two", True):
        with pytest.raises(PaletteError, match="references must be"):
            learn_from_mask(image, np.ones(image.shape[:2], np.uint8),
                            references=bad)
    flat = np.zeros((4, 4, 3), np.uint8)
    with pytest.raises(PaletteError, match='class "c": 1 distinct colours '
                                           'cannot give 2 references'):
        learn_from_mask(flat, np.ones((4, 4), np.uint8), names=["c"],
                        references=2)
    img_path, mask_path = scene_files
    for bad in ("0", "33", "many"):
        assert cli.main(["palette", "learn", str(img_path), "--mask",
                         str(mask_path), "--references", bad,
                         "-o", str(tmp_path / "x.json")]) == 2
        assert ("argument --references: expected auto or 1 to 32"
                in capsys.readouterr().err)
    assert not (tmp_path / "x.json").exists()


def test_old_palette_files_load_unchanged(gst):
    """Palettes written before "references" existed: one reference per
    class (its lab), and the element's labels are the single-reference
    computation's."""
    from gstlandmark import meta, pipeline
    import frames as F
    root = os.path.join(os.path.dirname(__file__), "..", "files", "palettes")
    rng = np.random.default_rng(9)
    img = F.random_rgb(rng, 24, 32)
    for name in ("good-custom.json", "good-alt.json", "lightness.json"):
        path = os.path.join(root, name)
        pal = load_palette(path)
        assert not pal.has_references
        refs, owner = pal.reference_arrays()
        np.testing.assert_array_equal(refs, pal.lab_array())
        out = pipeline.process_frames(
            f"labsegment palette={path} min-class-pixels=0", [img],
            F.caps_string("RGB", 32, 24))
        old = reference.classify(reference.rgb_to_lab(img), pal.lab_array(),
                                 min_class_pixels=0)
        np.testing.assert_array_equal(meta.labels(out[0]).plane, old.labels)


def test_learn_drops_references_classes_share():
    """Two balls, red and blue, each black on its unlit 40 %: the black
    tone is a reference of both, tells them apart by nothing and is
    dropped from both; the two-tone yellow keeps both its tones."""
    from gstlandmark.palette import (MIN_REFERENCE_SEPARATION,
                                     prune_shared_references)
    rng = np.random.default_rng(8)
    black = (2.0, 0.0, 0.0)
    parts = [(RED_LAB, 0), (black, 0), ((38.0, 30.0, -67.0), 1),
             ((2.5, 0.5, -0.5), 1), (LIT_YELLOW, 2), (SHADED_YELLOW, 2)]
    counts = [600, 400, 600, 400, 600, 400]
    image = np.vstack([np.tile(lab_to_bgr(lab), (n, 1))
                       for (lab, _), n in zip(parts, counts)])
    image = image.astype(np.float64) + rng.normal(0, 1.0, image.shape)
    image = np.clip(np.rint(image), 0, 255).astype(np.uint8)[:, None, :]
    mask = np.concatenate([np.full(n, k + 1, np.uint8)
                           for (_, k), n in zip(parts, counts)])[:, None]
    learned = learn_from_mask(image, mask, names=["red", "blue", "yellow"],
                              references="auto")
    red, blue, yellow = learned.classes
    assert red.references == () and blue.references == ()
    assert len(yellow.references) == 2
    # the rule alone: an extra reference near another class's goes, one
    # far from every other class stays, a class's last one always stays
    # (a class left with one reference is classified by its mean)
    kept = prune_shared_references(
        [np.array([[50.0, 40, 30], [2.0, 0, 0]]),
         np.array([[2.0 + MIN_REFERENCE_SEPARATION / 2, 0, 0]]),
         np.array([[80.0, -20, 60], [40.0, -10, 30]])],
        [(30.0, 25, 20), (2.0 + MIN_REFERENCE_SEPARATION / 2, 0, 0),
         (60.0, -15, 45)])
    assert [len(r) for r in kept] == [1, 1, 2]
    np.testing.assert_array_equal(kept[0], [[30.0, 25, 20]])
    np.testing.assert_array_equal(kept[2], [[80.0, -20, 60],
                                            [40.0, -10, 30]])


def test_learn_drops_references_that_take_another_class():
    """A red ball whose shaded side (40 %) has the colour of the dark planks
    that make 7 % of a wooden floor: a shaded-red reference would take
    those floor pixels, so red keeps one reference; the floor's planks are
    too few to be a tone of their own; yellow keeps both tones."""
    from gstlandmark.palette import MAX_STOLEN_SHARE
    rng = np.random.default_rng(10)
    plank, shaded_red = (25.0, 24.0, 19.0), (24.0, 26.0, 20.0)
    parts = [(RED_LAB, 1, 600), (shaded_red, 1, 400),
             ((50.0, 5.0, 10.0), 2, 1860), (plank, 2, 140),
             (LIT_YELLOW, 3, 600), (SHADED_YELLOW, 3, 400)]
    image = np.vstack([np.tile(lab_to_bgr(lab), (n, 1))
                       for lab, _, n in parts]).astype(np.float64)
    image = np.clip(np.rint(image + rng.normal(0, 1.0, image.shape)), 0,
                    255).astype(np.uint8)[:, None, :]
    mask = np.concatenate([np.full(n, k, np.uint8)
                           for _, k, n in parts])[:, None]
    learned = learn_from_mask(image, mask, names=["red", "floor", "yellow"],
                              markers=["red", "yellow"], references="auto")
    red, floor, yellow = learned.classes
    assert red.references == () and floor.references == ()
    assert len(yellow.references) == 2
    # on its own the red region has two tones: the drop is the rule's
    alone = learn_from_mask(image[mask[:, 0] == 1], mask[mask == 1][:, None],
                            names=["red"], references="auto")
    assert len(alone.classes[0].references) == 2
    assert 140 / 2000 > MAX_STOLEN_SHARE


def banded_scene(rng, rows, width=100):
    """Horizontal bands [(lab, mask value, rows), ...] of 1-sigma noisy
    colour, top to bottom: the BGR image and its class mask."""
    image = np.vstack([np.tile(lab_to_bgr(lab), (n, width, 1))
                       for lab, _, n in rows]).astype(np.float64)
    image = np.clip(np.rint(image + rng.normal(0, 1.0, image.shape)), 0,
                    255).astype(np.uint8)
    mask = np.vstack([np.full((n, width), k, np.uint8) for _, k, n in rows])
    return image, mask


def test_learn_drops_marker_references_that_take_the_untaught_scene():
    """A red ball lit on 60 % and shaded on 40 %, a floor, and above them a
    dark sky nobody taught (30 % of the image): the shaded-red reference
    would take the sky, which the palette without it gives the floor, so
    red keeps one reference. The same image with a white wall in place of
    the sky (nearest the floor, whatever red holds) keeps both tones."""
    from gstlandmark.palette import MAX_STOLEN_SHARE, UNTAUGHT_MARGIN
    rng = np.random.default_rng(11)
    shaded_red, floor, sky = (24.0, 26.0, 20.0), (50.0, 5.0, 10.0), \
        (22.0, 6.0, 3.0)
    # nearest reference of the sky: shaded red; next: the floor
    assert np.linalg.norm(np.subtract(sky, shaded_red)) < \
        np.linalg.norm(np.subtract(sky, floor)) < \
        np.linalg.norm(np.subtract(sky, RED_LAB))

    def learn(above):
        image, mask = banded_scene(rng, [(above, 0, 30), (RED_LAB, 1, 18),
                                         (shaded_red, 1, 12), (floor, 2, 40)])
        return learn_from_mask(image, mask, names=["red", "floor"],
                               markers=["red"], references="auto")

    assert learn(sky).classes[0].references == ()
    assert len(learn((95.0, 0.0, 2.0)).classes[0].references) == 2
    # the sky left after the margin is far above the share
    assert (30 - UNTAUGHT_MARGIN) / 100 > MAX_STOLEN_SHARE


def test_learn_untaught_class_takes_the_sky():
    """A red ball and a floor taught; the dark sky above them (30 % of the
    image) left out of the mask. With an untaught class the sky is a
    background class of its own and labelsegment's nearest-reference rule
    gives it that class, not red (its least far taught colour); the
    ball's two tones stay. Untaught pixels near a taught colour (more
    floor) or fewer than the share make no class; a taught class of the
    same name is an error."""
    from gstlandmark.palette import UNTAUGHT_MIN_DISTANCE, \
        UNTAUGHT_MIN_SHARE
    rng = np.random.default_rng(12)
    shaded_red, floor, sky = (24.0, 26.0, 20.0), (60.0, 5.0, 10.0), \
        (22.0, 0.0, -4.0)

    def scene(above, rows_above=30):
        return banded_scene(rng, [(above, 0, rows_above), (RED_LAB, 1, 18),
                                  (shaded_red, 1, 12), (floor, 2, 90)])

    def learn(image, mask, **kw):
        return learn_from_mask(image, mask, names=["red", "floor"],
                               markers=["red"], references="auto", **kw)

    image, mask = scene(sky)
    # without: rule 7 drops red's shaded tone, and the sky is floor
    without = learn(image, mask)
    assert without.names == ["red", "floor"]
    assert without.classes[0].references == ()
    learned = learn(image, mask, untaught_class="untaught")
    assert learned.names == ["red", "floor", "untaught"]
    assert learned.classes[2].role == "background"
    np.testing.assert_allclose(learned.lab_array()[2], sky, atol=1.5)
    assert len(learned.classes[0].references) == 2
    lab = reference.rgb_to_lab(image[:, :, ::-1])
    for palette, sky_class in ((without, 2), (learned, 3)):
        refs, owner = palette.reference_arrays()
        labels = reference.classify(lab, refs, min_class_pixels=0,
                                    ref_class=owner).labels
        assert (labels[:28] == sky_class).mean() > 0.99
        assert (labels[mask == 1] == 1).mean() > 0.99
    # the sky is far from every taught colour; more floor is not
    assert np.linalg.norm(np.subtract(sky, shaded_red)) > \
        UNTAUGHT_MIN_DISTANCE
    image, mask = scene((61.0, 5.0, 10.0))
    assert learn(image, mask, untaught_class="untaught").names == \
        ["red", "floor"]
    # under the share: 1 row of 100 left after the margin
    image, mask = scene(sky, rows_above=3)
    assert 100 / image.shape[0] / image.shape[1] < UNTAUGHT_MIN_SHARE
    assert learn(image, mask, untaught_class="untaught").names == \
        ["red", "floor"]
    with pytest.raises(PaletteError, match='"floor", is also a taught'):
        learn(image, mask, untaught_class="floor")


def test_untaught_class_takes_no_taught_pixels():
    """A floor taught with its dark fibres (8 % of it, Delta E 12 from the
    floor's mean, nearer the sky than the mean is) and an untaught dark sky
    above: the floor, a scene class, gets a reference for its fibres, so
    the sky's class is learned and takes none of them; with the floor's
    references cut to its mean (references=1) the sky's colour would take
    the fibres, and no untaught class is learned."""
    from gstlandmark.palette import MAX_STOLEN_SHARE
    rng = np.random.default_rng(13)
    floor, sky = (45.0, 0.0, 6.0), (26.0, 0.0, -4.0)
    dark = (34.0, 0.0, 0.0)

    def learn(references):
        image, mask = banded_scene(rng, [(sky, 0, 30), (RED_LAB, 1, 20),
                                         (floor, 2, 92), (dark, 2, 8)])
        palette = learn_from_mask(image, mask, names=["red", "floor"],
                                  markers=["red"], references=references,
                                  untaught_class="untaught")
        return palette, image[-8:]

    assert np.linalg.norm(np.subtract(dark, sky)) < \
        np.linalg.norm(np.subtract(dark, floor))
    assert 8 / 100 > MAX_STOLEN_SHARE
    palette, fibres = learn("auto")
    assert palette.names == ["red", "floor", "untaught"]
    labels = reference.segment_rgb(fibres[:, :, ::-1].copy(), palette,
                                   min_class_pixels=0).labels
    assert (labels == 2).mean() > 0.99
    assert learn(1)[0].names == ["red", "floor"]


def test_cli_check_lists_references(tmp_path, capsys):
    path = write_json(tmp_path / "p.json", {"classes": [
        good_class("yellow", (75, -5, 70),
                   references=[[90, -15, 80], [55, 4, 55]])]})
    assert cli.main(["palette", "check", str(path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    refs = [line.split() for line in lines if line.endswith("reference")]
    assert refs == [["90.00", "-15.00", "80.00", "reference"],
                    ["55.00", "4.00", "55.00", "reference"]]


def test_lab_under_light_is_the_colour_under_scaled_light():
    """lab_under_light against OpenCV's float conversion of the linear
    sRGB scaled by k (where L* stays above 8, the cube-root part)."""
    from gstlandmark.palette import lab_under_light
    rng = np.random.default_rng(5)
    for _ in range(50):
        srgb = rng.uniform(0.2, 0.9, 3)
        linear = np.where(srgb <= 0.04045, srgb / 12.92,
                          ((srgb + 0.055) / 1.055) ** 2.4)
        k = rng.uniform(0.2, 1.0 / linear.max())
        scaled = np.clip(k * linear, 0, 1)
        back = np.where(scaled <= 0.0031308, 12.92 * scaled,
                        1.055 * scaled ** (1 / 2.4) - 0.055)

        def lab(rgb):
            return cv2.cvtColor(np.float32([[rgb]]), cv2.COLOR_RGB2Lab)[0, 0]

        want = lab(back)
        if want[0] <= 8:
            continue
        # OpenCV's float conversion is within 0.55 of the CIE formulas
        np.testing.assert_allclose(lab_under_light(lab(srgb), k), want,
                                   atol=0.6)


def test_cli_learn_shading(tmp_path, scene_files, capsys):
    """--shading gives the marker classes the light range, and a bad range
    is refused naming the option."""
    img_path, mask_path = scene_files
    out = tmp_path / "p.json"
    assert cli.main(["palette", "learn", str(img_path), "--mask",
                     str(mask_path), "--shading", "0.25,1.5",
                     "-o", str(out)]) == 0
    learned = load_palette(out)
    for c in learned.classes:
        assert c.shading == ((0.25, 1.5) if c.marker else (1.0, 1.0))
    for bad in ("2,1", "0.25", "x,1"):
        assert cli.main(["palette", "learn", str(img_path), "--mask",
                         str(mask_path), "--shading", bad,
                         "-o", str(tmp_path / "x.json")]) == 2
        assert "--shading" in capsys.readouterr().err
