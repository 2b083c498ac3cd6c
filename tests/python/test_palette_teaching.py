"""Teaching that cannot go silently wrong: ``palette learn --rect`` learns
the rest of the image, several images teach one palette, and ``palette
learn`` and ``palette check`` warn when the palette labels a scene wrongly
(docs/palette.md, "The rest of the image" and "Checking a palette").

Every scene is drawn here from known L*a*b* colours; the expectations come
from those colours and the scene's geometry, not from the learner."""

import json

import cv2
import numpy as np
import pytest

from gstlandmark import paletteaudit, reference
from gstlandmark.commands import cli
from gstlandmark.palette import (PaletteError, learn_from_images,
                                 learn_from_rects, load_palette)

# A dark red disc on a light grey floor under a dark blue wall.  The wall
# is nearer the red than the floor in L*a*b*, so a palette that knows only
# the red and the floor labels the wall red.
RED = (35.0, 50.0, 30.0)
FLOOR = (85.0, 0.0, 0.0)
WALL = (20.0, 25.0, -25.0)
HEIGHT, WIDTH = 120, 160
WALL_ROWS = 48
DISC = (80, 84, 15)         # centre x, y and radius in pixels
DISC_RECT = "red:72,76,16,16"   # inside the disc
FLOOR_RECT = "floor:0,100,60,20"


def lab_to_bgr(lab):
    return reference.lab_to_srgb8(np.array([lab], np.float64))[0][::-1]


def draw_scene(red=RED, wall=WALL, seed=1, noise=1.0):
    """The BGR scene (1-sigma noise) and the masks of wall and disc."""
    yy, xx = np.mgrid[:HEIGHT, :WIDTH]
    wall_mask = yy < WALL_ROWS
    disc = (xx - DISC[0]) ** 2 + (yy - DISC[1]) ** 2 <= DISC[2] ** 2
    image = np.empty((HEIGHT, WIDTH, 3), np.float64)
    image[:] = lab_to_bgr(FLOOR)
    image[wall_mask] = lab_to_bgr(wall)
    image[disc] = lab_to_bgr(red)
    rng = np.random.default_rng(seed)
    image = np.clip(np.rint(image + rng.normal(0, noise, image.shape)), 0,
                    255).astype(np.uint8)
    return image, wall_mask, disc


def rect(text):
    name, numbers = text.split(":")
    return (name, *(int(v) for v in numbers.split(",")))


def labels_of(palette, image):
    return paletteaudit.classify(palette, image)


def lab_of(image):
    return reference.rgb_to_lab(np.ascontiguousarray(image[:, :, ::-1]))


def test_scene_is_what_the_tests_need():
    # the wall's nearest taught colour is the red, not the floor
    assert np.linalg.norm(np.subtract(WALL, RED)) < \
        np.linalg.norm(np.subtract(WALL, FLOOR))


def test_rect_learns_the_wall_as_the_rest():
    """With --rect on the disc and the floor alone, the wall becomes the
    untaught background class and is not labelled red; without it, it
    is."""
    image, wall, disc = draw_scene()
    rects = [rect(DISC_RECT), rect(FLOOR_RECT)]
    without = learn_from_rects(image, rects, background=["floor"])
    labels = labels_of(without, image)
    assert without.names == ["red", "floor"]
    assert (labels[wall] == 1).mean() > 0.99       # the wall is red
    learned = learn_from_rects(image, rects, background=["floor"],
                               untaught_class="untaught")
    assert learned.names == ["red", "floor", "untaught"]
    assert learned.classes[2].role == "background"
    np.testing.assert_allclose(learned.classes[2].lab,
                               lab_of(image)[wall].mean(axis=0), atol=0.01)
    labels = labels_of(learned, image)
    assert (labels[wall] == 3).mean() > 0.99
    assert (labels[disc] == 1).mean() > 0.99
    assert (labels[~wall & ~disc] == 2).mean() > 0.99


def test_rect_rest_leaves_a_margin_around_each_rectangle():
    """The rest starts a quarter of a rectangle's longer side away: a box
    drawn inside a ball leaves its rim out of the rest, so a rim of
    another colour (a shaded rim nobody taught) makes no class of its
    own when it lies within that margin, and does beyond it."""
    from gstlandmark.palette import rect_margin, UNTAUGHT_MIN_SHARE
    assert rect_margin(16, 16) == 4 and rect_margin(2, 3) == 2
    image = np.full((HEIGHT, WIDTH, 3), lab_to_bgr(FLOOR), np.uint8)

    def learn(ring):
        img = image.copy()
        # a 40x40 red square, a ring of the wall's colour `ring` px wide
        # around it, taught by a box 2 px inside the square
        img[40 - ring:80 + ring, 40 - ring:80 + ring] = lab_to_bgr(WALL)
        img[40:80, 40:80] = lab_to_bgr(RED)
        return learn_from_rects(img, [("red", 42, 42, 36, 36),
                                      ("floor", 0, 110, 160, 10)],
                                untaught_class="untaught")
    # margin 9: a ring of 7 px lies inside it, one of 20 px does not (and
    # what lies beyond covers more than the share)
    assert rect_margin(36, 36) == 9
    assert learn(7).names == ["red", "floor"]
    assert 4 * 60 * 11 / (HEIGHT * WIDTH) > UNTAUGHT_MIN_SHARE
    assert learn(20).names == ["red", "floor", "untaught"]


def test_rest_that_would_take_a_taught_class_is_dropped():
    """The floor is taught with a dark patch (10 % of its rectangle) that
    is nearer the wall's colour than the floor's mean: the wall's colour,
    learned from the rest, would take those floor pixels, so no untaught
    class is learned, as with --mask."""
    image, wall, _ = draw_scene()
    patch = (47.0, 15.0, -15.0)
    # nearer the floor than the red (taught, the patch is floor), nearer
    # the wall than the floor's mean (with the patch in it)
    floor_mean = 0.9 * np.array(FLOOR) + 0.1 * np.array(patch)
    assert np.linalg.norm(np.subtract(patch, floor_mean)) < \
        np.linalg.norm(np.subtract(patch, RED))
    assert np.linalg.norm(np.subtract(patch, WALL)) < \
        np.linalg.norm(np.subtract(patch, floor_mean))
    image[100:102, 0:60] = lab_to_bgr(patch)  # 2 of the rectangle's 20 rows
    learned = learn_from_rects(image, [rect(DISC_RECT), rect(FLOOR_RECT)],
                               untaught_class="untaught")
    assert learned.names == ["red", "floor"]
    # the patch outside the rectangle changes nothing
    image, _, _ = draw_scene()
    image[110:112, 100:160] = lab_to_bgr(patch)
    assert learn_from_rects(image, [rect(DISC_RECT), rect(FLOOR_RECT)],
                            untaught_class="untaught").names == \
        ["red", "floor", "untaught"]


def test_several_images_pool_their_pixels():
    """Two images, the red lit in one and darker in the other: the red
    class's mean is the pixel-weighted mean of both discs' rectangles, its
    two references one near each tone; the floor's rectangles pool too;
    the wall only the second image shows is the rest of both."""
    dark_red = (25.0, 40.0, 22.0)
    first, _, _ = draw_scene(wall=FLOOR, seed=2)
    second, wall, _ = draw_scene(red=dark_red, seed=3)
    rects = [rect(DISC_RECT), rect(FLOOR_RECT)]
    palette = learn_from_images([(first, rects), (second, rects)],
                                background=["floor"], references="auto",
                                untaught_class="untaught")
    assert palette.names == ["red", "floor", "untaught"]
    x, y, w, h = rects[0][1:]
    pooled = np.vstack([lab_of(img)[y:y + h, x:x + w].reshape(-1, 3)
                        for img in (first, second)])
    np.testing.assert_allclose(palette.classes[0].lab, pooled.mean(axis=0),
                               atol=0.01)
    refs = np.array(palette.classes[0].references)
    assert len(refs) == 2
    for tone in (RED, dark_red):
        assert np.linalg.norm(refs - tone, axis=1).min() < 1.5
    np.testing.assert_allclose(palette.classes[2].lab,
                               lab_of(second)[wall].mean(axis=0), atol=0.01)
    # a class only the second image teaches comes after the first's
    palette = learn_from_images([(first, rects[1:]), (second, rects)])
    assert palette.names == ["floor", "red"]
    with pytest.raises(PaletteError, match="^b.png: rectangle red:150,"):
        learn_from_images([(first, rects), (second, [("red", 150, 0, 20, 5)])],
                          sources=["a.png", "b.png"])


@pytest.fixture
def scene_files(tmp_path):
    files = {}
    for name, kw in (("lit", {"wall": FLOOR, "seed": 2}),
                     ("dark", {"red": (25.0, 40.0, 22.0), "seed": 3})):
        files[name] = tmp_path / f"{name}.png"
        assert cv2.imwrite(str(files[name]), draw_scene(**kw)[0])
    return files


def run(capsys, *args):
    capsys.readouterr()
    status = cli.main([str(a) for a in args])
    out = capsys.readouterr()
    return status, out.out, out.err


def test_cli_several_images(tmp_path, scene_files, capsys):
    out = tmp_path / "p.json"
    status, _, err = run(capsys, "palette", "learn", scene_files["lit"],
                         "--rect", DISC_RECT, "--rect", FLOOR_RECT,
                         "--image", scene_files["dark"], "--rect", DISC_RECT,
                         "--rect", FLOOR_RECT, "--floor", "floor", "-o", out)
    assert status == 0, err
    obj = json.loads(out.read_text())
    assert obj["learned-from"] == [str(scene_files["lit"]),
                                   str(scene_files["dark"])]
    assert set(obj["spread"]) == {"red", "floor"}
    images = [(cv2.imread(str(scene_files[k])), [rect(DISC_RECT),
                                                 rect(FLOOR_RECT)])
              for k in ("lit", "dark")]
    expected = learn_from_images(images, floor=["floor"],
                                 references="auto",
                                 untaught_class="untaught")
    assert load_palette(out) .classes == [
        type(c)(c.name, tuple(round(v, 4) for v in c.lab), role=c.role,
                references=tuple(tuple(round(v, 4) for v in r)
                                 for r in c.references))
        for c in expected.classes]
    # an image without rectangles is a usage error naming it
    status, _, err = run(capsys, "palette", "learn", scene_files["lit"],
                         "--rect", DISC_RECT, "--image", scene_files["dark"],
                         "-o", out)
    assert status == 2
    assert f"--image {scene_files['dark']}: no --rect follows it" in err
    status, _, err = run(capsys, "palette", "learn", scene_files["lit"],
                         "--image", scene_files["dark"], "--rect", DISC_RECT,
                         "-o", out)
    assert status == 2 and f"IMAGE {scene_files['lit']}: no --rect" in err
    status, _, err = run(capsys, "palette", "learn", scene_files["lit"],
                         "--mask", scene_files["lit"], "--image",
                         scene_files["dark"], "-o", out)
    assert status == 2 and "--image goes with --rect" in err


def test_cli_bad_input_names_the_file_and_value(tmp_path, scene_files,
                                                capsys):
    out = tmp_path / "p.json"
    missing = tmp_path / "missing.png"
    status, _, err = run(capsys, "palette", "learn", scene_files["lit"],
                         "--rect", DISC_RECT, "--image", missing, "--rect",
                         DISC_RECT, "-o", out)
    assert status == 1 and f"{missing}: no such file" in err
    status, _, err = run(capsys, "palette", "learn", scene_files["lit"],
                         "--rect", DISC_RECT, "--image", scene_files["dark"],
                         "--rect", "red:150,110,20,20", "-o", out)
    assert status == 1
    assert (f"{scene_files['dark']}: rectangle red:150,110,20,20 does not "
            f"fit inside the 160x120 image") in err
    assert not out.exists()
    status, _, err = run(capsys, "palette", "learn", scene_files["lit"],
                         "--rect", "red:1,2,3", "-o", out)
    assert status == 2 and "expected NAME:X,Y,W,H, got 'red:1,2,3'" in err
    status, _, _ = run(capsys, "palette", "learn", scene_files["lit"],
                       "--rect", DISC_RECT, "--rect", FLOOR_RECT, "-o", out)
    assert status == 0
    status, _, err = run(capsys, "palette", "check", out, missing)
    assert status == 1 and f"{missing}: no such file" in err


# ---------------------------------------------------------------------------
# The warnings


def kinds(findings):
    return sorted((f.kind, f.name) for f in findings)


def test_check_shares_and_marker_warnings(tmp_path, capsys):
    """Without the rest, the red takes the wall: check says it covers 40 %
    of the image and that the band is no disc; with it, the red is the
    disc's share and check is silent."""
    image, wall, disc = draw_scene()
    path = tmp_path / "scene.png"
    assert cv2.imwrite(str(path), image)
    shares = {}
    for untaught in ("none", "untaught"):
        out = tmp_path / f"{untaught}.json"
        status, _, err = run(capsys, "palette", "learn", path, "--rect",
                             DISC_RECT, "--rect", FLOOR_RECT, "--floor",
                             "floor", "--untaught", untaught, "-o", out)
        assert status == 0 and "warning" not in err
        status, report, _ = run(capsys, "palette", "check", out, path)
        assert status == 0
        line = next(x for x in report.splitlines()
                    if x.startswith(f"{path}: red"))
        shares[untaught] = float(line.split()[2])
        shares[untaught, "warnings"] = [x for x in report.splitlines()
                                        if x.startswith("warning:")]
        shares[untaught, "strict"] = run(capsys, "palette", "check", out,
                                         path, "--strict")[0]
    red_with_wall = 100 * (wall.sum() + disc.sum()) / wall.size
    assert shares["none"] == pytest.approx(red_with_wall, abs=0.05)
    assert shares["untaught"] == pytest.approx(100 * disc.mean(), abs=0.05)
    # the wall's band, 160x48, fills 7680 / (pi 83.4^2) = 0.35 of its
    # circle: a blob the shape test lets pass, too large for a marker
    (covers,) = shares["none", "warnings"]
    assert f'marker class "red" covers {red_with_wall:.2f} % of' in covers
    assert shares["none", "strict"] == 1
    assert shares["untaught", "warnings"] == []
    assert shares["untaught", "strict"] == 0


def test_marker_blob_shape_and_share_thresholds():
    """A disc of 2 % of the image passes; a bar of the same area fills
    less than MIN_BLOB_FILL of its circle and is named; a disc of 8 % of
    the image covers too much."""
    from gstlandmark.palette import Palette, PaletteClass
    palette = Palette([PaletteClass("red", RED, role="marker"),
                       PaletteClass("floor", FLOOR, role="floor")])
    labels = np.full((100, 200), 2, np.uint8)
    yy, xx = np.mgrid[:100, :200]
    disc = (xx - 50) ** 2 + (yy - 50) ** 2 <= 11.3 ** 2
    labels[disc] = 1
    assert abs(disc.mean() - 0.02) < 0.001
    assert paletteaudit.image_findings(palette, labels) == []
    fill = paletteaudit.blob_fills(labels == 1, 10)[0][1]
    assert 0.9 < fill <= 1.0
    bar = labels.copy()
    bar[disc] = 2
    bar[10:14, 20:120] = 1                  # 400 px, 2 %
    (finding,) = paletteaudit.image_findings(palette, bar, "bar.png")
    assert finding.kind == "shape" and finding.name == "red"
    assert finding.value < paletteaudit.MIN_BLOB_FILL
    assert finding.text.startswith('bar.png: marker class "red" has a blob '
                                   'of 400 pixels at 20,10,100,4')
    big = labels.copy()
    big[(xx - 50) ** 2 + (yy - 50) ** 2 <= 22.6 ** 2] = 1
    assert kinds(paletteaudit.image_findings(palette, big)) == \
        [("covers", "red")]


def shaded(lab, factor):
    """The colour ``lab`` under ``factor`` times the light (linear RGB
    scaled): the shaded side of a ball."""
    srgb = reference.lab_to_srgb8(np.array([lab]))[0] / 255.0
    linear = np.where(srgb <= 0.04045, srgb / 12.92,
                      ((srgb + 0.055) / 1.055) ** 2.4) * factor
    out = np.where(linear <= 0.0031308, linear * 12.92,
                   1.055 * linear ** (1 / 2.4) - 0.055)
    rgb = np.clip(np.rint(out * 255), 0, 255).astype(np.uint8)
    return reference.rgb_to_lab(rgb[None, None, :])[0, 0]


def test_two_colour_box_warning():
    """A box around the whole disc holds the floor in its corners (21 % of
    it): learn names the rectangle and the shares; a box inside the disc,
    and a box over a ball lit on 60 % and shaded on 40 % (one colour under
    two lights), are one colour each."""
    image, _, _ = draw_scene()
    lab = lab_of(image)
    x, y, r = DISC
    around = ("red", x - r, y - r, 2 * r + 1, 2 * r + 1)
    (finding,) = paletteaudit.rect_findings(lab, [around], "scene.png")
    assert finding.kind == "two-colours" and finding.name == "red"
    corners = 1 - np.pi * r ** 2 / (2 * r + 1) ** 2
    assert finding.value == pytest.approx(corners, abs=0.03)
    assert finding.text.startswith(
        f"scene.png: rectangle red:{x - r},{y - r},{2 * r + 1},{2 * r + 1} "
        f"holds two colours: {100 * (1 - finding.value):.0f} % near")
    assert paletteaudit.rect_findings(lab, [rect(DISC_RECT),
                                            rect(FLOOR_RECT)]) == []
    dark = shaded(RED, 0.3)
    assert np.linalg.norm(dark - np.array(RED)) > \
        paletteaudit.TWO_COLOUR_MIN_DISTANCE
    ball = np.zeros((40, 50, 3), np.uint8)
    ball[:24] = lab_to_bgr(RED)
    ball[24:] = reference.lab_to_srgb8(dark[None])[0][::-1]
    assert paletteaudit.rect_findings(lab_of(ball),
                                      [("red", 0, 0, 50, 40)]) == []
    # the same box with the floor in place of the shaded side is two
    ball[24:] = lab_to_bgr(FLOOR)
    assert kinds(paletteaudit.rect_findings(
        lab_of(ball), [("red", 0, 0, 50, 40)])) == [("two-colours", "red")]


def test_overlap_warnings(tmp_path, capsys):
    """Two classes taught on colours Delta E 4 apart with 3-sigma noise:
    learn says how many of one's taught pixels take the other, and check
    that their references lie within one's spread; the disc scene's red
    and floor are far apart and silent."""
    rng = np.random.default_rng(5)
    image = np.zeros((60, 120, 3), np.float64)
    image[:, :60] = lab_to_bgr(RED)
    image[:, 60:] = lab_to_bgr((38.0, 52.0, 32.0))
    image = np.clip(np.rint(image + rng.normal(0, 3.0, image.shape)), 0,
                    255).astype(np.uint8)
    path, out = tmp_path / "close.png", tmp_path / "close.json"
    assert cv2.imwrite(str(path), image)
    status, _, err = run(capsys, "palette", "learn", path, "--rect",
                         "red:0,0,60,60", "--rect", "orange:60,0,60,60",
                         "--references", "1", "-o", out)
    assert status == 0
    warnings = [x for x in err.splitlines() if x.startswith("warning:")]
    assert len(warnings) == 2
    for a, b in (("red", "orange"), ("orange", "red")):
        line = next(x for x in warnings if f'taught as "{a}"' in x)
        share = float(line.split(" % of")[0].split()[-1])
        assert share > 100 * paletteaudit.MAX_TAUGHT_CONFUSED
        assert f'labelled "{b}"' in line
    status, report, _ = run(capsys, "palette", "check", out, "--strict")
    assert status == 1
    spreads = json.loads(out.read_text())["spread"]
    lines = [x for x in report.splitlines()
             if x.startswith("warning:") and "overlap" in x]
    assert len(lines) == 2
    distance = np.linalg.norm(np.subtract(*load_palette(out).lab_array()))
    assert f"Delta E {distance:.1f} apart, less than 2 times the spread " \
        f"of \"red\"'s taught pixels ({spreads['red']:.1f})" in report
    # clean: the disc scene
    image, _, _ = draw_scene()
    palette = learn_from_rects(image, [rect(DISC_RECT), rect(FLOOR_RECT)])
    findings, spreads = paletteaudit.teaching_findings(
        palette, [("s", lab_of(image), [rect(DISC_RECT), rect(FLOOR_RECT)])])
    assert findings == []
    assert paletteaudit.reference_overlaps(palette, spreads) == []
    assert 0.5 < spreads["red"] < 3.0    # 1-sigma noise per channel


# A soccer scene: green carpet, white lines, black robots, a beige wall and
# a yellow-green ball.  The mean of everything but the ball is a green
# farther from the beige wall than the ball is: taught as one mean, the
# background leaves the wall to the ball.
CARPET = (55.0, -45.0, 30.0)
LINE = (95.0, -5.0, 5.0)
ROBOT = (12.0, 0.0, 0.0)
BEIGE_WALL = (80.0, 0.0, 30.0)
BALL = (80.0, -20.0, 60.0)


def draw_field(seed=3):
    """BGR field (1-sigma noise), the ball's mask and its teaching mask
    (1: the ball inside a 2-px ring, 0: the ring, 2: the rest)."""
    h, w = 120, 200
    yy, xx = np.mgrid[:h, :w]
    lab = np.empty((h, w, 3))
    lab[:] = CARPET
    lab[yy < 30] = BEIGE_WALL
    lab[(yy >= 60) & (yy < 64)] = LINE
    lab[(xx >= 20) & (xx < 60) & (yy >= 35) & (yy < 90)] = ROBOT
    ball = (xx - 130) ** 2 + (yy - 90) ** 2 <= 14 ** 2
    lab[ball] = BALL
    image = reference.lab_to_srgb8(lab.reshape(-1, 3)).reshape(h, w, 3)
    rng = np.random.default_rng(seed)
    image = np.clip(np.rint(image[:, :, ::-1] + rng.normal(0, 1.0,
                                                           image.shape)),
                    0, 255).astype(np.uint8)
    mask = np.full((h, w), 2, np.uint8)
    mask[(xx - 130) ** 2 + (yy - 90) ** 2 <= 16 ** 2] = 0
    mask[(xx - 130) ** 2 + (yy - 90) ** 2 <= 12 ** 2] = 1
    return image, ball, mask


def test_background_of_many_colours_gets_a_reference_for_each():
    """Taught with --mask (ball, and the rest as background) and auto
    references: the background is every colour of the scene, so it gets
    a reference near each (a single mean would leave the lines and the
    wall to the ball), and none of the scene is labelled ball."""
    from gstlandmark.palette import learn_from_mask
    image, ball, mask = draw_field()
    palette = learn_from_mask(image, mask, names=["ball", "background"],
                              markers=["ball"], references="auto")
    refs = np.array(palette.classes[1].reference_labs)
    for tone in (CARPET, LINE, ROBOT, BEIGE_WALL):
        assert np.sqrt(((refs - tone) ** 2).sum(axis=1)).min() < 5.0, tone
    labels = labels_of(palette, image)
    assert (labels[ball] == 1).mean() > 0.99
    # the ball's 2-px rim blends with the carpet; the rest of the scene
    # holds no ball pixel
    rim = cv2.dilate(ball.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    assert (labels[~rim] == 1).sum() == 0
