"""gst-landmark synth: geometry self-test against cv2.projectPoints, the
ground truth's formulas, determinism, masks and the written outputs."""

import dataclasses
import json
import math

import cv2
import numpy as np
import pytest

from gstlandmark import reference
from gstlandmark.commands import cli
from gstlandmark.palette import (learn_from_mask, load_palette, parse_palette,
                                 palette_to_json)
from gstlandmark.synth import (Camera, Distractor, Effects, Landmark, Pose,
                               Scene, Walls, render_frame, render_scenario)
from gstlandmark.synth.scenarios import SCENARIOS

MARKERS = ("red", "green", "yellow", "pink", "blue")
SMALL = (160, 120)


# -- an independent camera model, written from docs/conventions.md -------

def conventions_rvec_tvec(pose, height, tilt_deg, roll_deg):
    """rvec, tvec of world points for cv2.projectPoints."""
    t, r = math.radians(tilt_deg), math.radians(roll_deg)
    x_c = np.array([0.0, -1.0, 0.0])
    y_c = np.array([-math.sin(t), 0.0, -math.cos(t)])
    z_c = np.array([math.cos(t), 0.0, -math.sin(t)])
    robot_to_cam = np.array([math.cos(r) * x_c + math.sin(r) * y_c,
                             -math.sin(r) * x_c + math.cos(r) * y_c, z_c])
    c, s = math.cos(pose.heading), math.sin(pose.heading)
    world_to_robot = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    rot = robot_to_cam @ world_to_robot
    centre = np.array([pose.x, pose.y, height])
    rvec, _ = cv2.Rodrigues(rot)
    return rvec, -rot @ centre


def project(points, pose, camera):
    rvec, tvec = conventions_rvec_tvec(pose, camera.height_m,
                                       camera.tilt_deg, camera.roll_deg)
    k = np.array([[camera.fx, 0, camera.cx], [0, camera.fy, camera.cy],
                  [0, 0, 1.0]])
    uv, _ = cv2.projectPoints(np.asarray(points, np.float64).reshape(-1, 3),
                              rvec, tvec, k, None)
    return uv.reshape(-1, 2)


def outline_world(lm, pose, camera, count=2000):
    """Boundary of a disc, or the silhouette circle of a ball."""
    a = np.linspace(0.0, 2 * math.pi, count, endpoint=False)
    centre = np.array([lm.x, lm.y, lm.z])
    if lm.kind == "disc":
        return centre + lm.radius * np.stack(
            [np.cos(a), np.sin(a), np.zeros_like(a)], axis=1)
    eye = np.array([pose.x, pose.y, camera.height_m])
    v = centre - eye
    dist = np.linalg.norm(v)
    n = v / dist
    e1 = np.cross(n, [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    q = centre - lm.radius ** 2 / dist * n
    rho = lm.radius * math.sqrt(1 - (lm.radius / dist) ** 2)
    return q + rho * (np.cos(a)[:, None] * e1 + np.sin(a)[:, None] * e2)


def polygon_centroid(p):
    x, y = p[:, 0], p[:, 1]
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    cross = x * y1 - x1 * y
    area = cross.sum() / 2
    return np.array([((x + x1) * cross).sum(),
                     ((y + y1) * cross).sum()]) / (6 * area)


def srgb_to_linear(c):
    c = np.asarray(c, np.float64) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def image_centroid(rgb, colour, floor, centre, half=30):
    """Coverage-weighted centroid measured on the rendered image itself:
    each pixel's coverage recovered from its colour in linear light."""
    u0 = max(int(centre[0]) - half, 0)
    v0 = max(int(centre[1]) - half, 0)
    win = srgb_to_linear(rgb[v0:int(centre[1]) + half,
                             u0:int(centre[0]) + half])
    col, bg = srgb_to_linear(colour), srgb_to_linear(floor)
    d = col - bg
    alpha = np.clip(((win - bg) @ d) / (d @ d), 0.0, 1.0)
    alpha[alpha < 0.02] = 0.0            # 8-bit rounding of the floor
    vv, uu = np.mgrid[0:alpha.shape[0], 0:alpha.shape[1]]
    total = alpha.sum()
    return np.array([(alpha * uu).sum() / total + u0,
                     (alpha * vv).sum() / total + v0])


def quiet_effects(**kw):
    return Effects(noise_sigma=0.0, ball_shading=0.0, **kw)


# -- geometry self-test --------------------------------------------------

@pytest.mark.parametrize("kind, diameter, roll", [
    ("disc", 0.04, 0.0), ("ball", 0.04, 0.0),
    ("disc", 0.04, 7.0), ("ball", 0.05, -5.0)])
def test_small_landmark_centroid_matches_project_points(kind, diameter,
                                                        roll):
    camera = Camera(640, 480, hfov_deg=60, height_m=0.3, tilt_deg=25,
                    roll_deg=roll)
    pose = Pose(0.7, -0.4, 0.6)
    # 1.6 m ahead, a little to the right
    a = pose.heading - 0.15
    lm = Landmark("L1", "blue", pose.x + 1.6 * math.cos(a),
                  pose.y + 1.6 * math.sin(a), diameter, kind=kind)
    scene = Scene(camera=camera, landmarks=[lm], effects=quiet_effects())
    rgb, truth, _ = render_frame(scene, pose, frame=0)
    (entry,) = truth["landmarks"]
    centre = project([[lm.x, lm.y, lm.z]], pose, camera)[0]
    area_centroid = polygon_centroid(
        project(outline_world(lm, pose, camera), pose, camera))
    rendered = np.array([entry["u"], entry["v"]])
    measured = image_centroid(rgb, scene.marker_srgb8()["blue"],
                              (128, 128, 128), centre)

    # the projective bias of so small an object is below 0.1 px
    assert np.abs(area_centroid - centre).max() < 0.1
    assert np.abs(rendered - centre).max() < 0.5
    assert np.abs(measured - centre).max() < 0.5
    # and it agrees with the exact area centroid far better than that
    assert np.abs(rendered - area_centroid).max() < 0.05
    assert np.abs(measured - area_centroid).max() < 0.1
    assert entry["u_centre"] == pytest.approx(centre[0], abs=1e-3)
    assert entry["v_centre"] == pytest.approx(centre[1], abs=1e-3)
    # visible area: the exact projected area within 3 % (4 x 4 samples)
    p = project(outline_world(lm, pose, camera), pose, camera)
    x, y = p[:, 0], p[:, 1]
    area = abs((x * np.roll(y, -1) - np.roll(x, -1) * y).sum()) / 2
    assert entry["pixels"] == pytest.approx(area, rel=0.03)
    assert not entry["cut"] and not entry["occluded"]


def test_large_near_landmarks_area_centroid():
    """Bigger, nearer objects: the rendered centroid is the exact area
    centroid of the projected outline, not the projected centre."""
    camera = Camera(640, 480, tilt_deg=30, roll_deg=3.0)
    pose = Pose(-1.0, 2.0, -2.0)
    lms = []
    for i, (r, b, kind, d) in enumerate([(0.6, 0.2, "disc", 0.12),
                                         (0.9, -0.25, "ball", 0.08),
                                         (1.4, 0.0, "disc", 0.15)]):
        lms.append(Landmark(f"L{i}", MARKERS[i],
                            pose.x + r * math.cos(pose.heading + b),
                            pose.y + r * math.sin(pose.heading + b), d,
                            kind=kind))
    scene = Scene(camera=camera, landmarks=lms, effects=quiet_effects())
    _, truth, _ = render_frame(scene, pose, frame=0)
    assert len(truth["landmarks"]) == 3
    for entry, lm in zip(truth["landmarks"], lms):
        expected = polygon_centroid(
            project(outline_world(lm, pose, camera), pose, camera))
        got = np.array([entry["u"], entry["v"]])
        assert np.abs(got - expected).max() < 0.05, entry["id"]


# -- truth values ----------------------------------------------------------

def test_range_bearing_follow_conventions(tmp_path):
    summary = render_scenario("path", str(tmp_path), frames=24, size=SMALL,
                              progress=False, robot="comfortable")
    assert summary["frames"] == 24
    landmarks = {lm["id"]: lm for lm in json.loads(
        (tmp_path / "map.json").read_text())["landmarks"]}
    seen = 0
    for line in (tmp_path / "truth.jsonl").read_text().splitlines():
        frame = json.loads(line)
        robot = frame["robot"]
        h = robot["heading"]
        assert -math.pi < h <= math.pi
        for entry in frame["landmarks"]:
            lm = landmarks[entry["id"]]
            dx, dy = lm["x"] - robot["x"], lm["y"] - robot["y"]
            gx = math.cos(h) * dx + math.sin(h) * dy
            gy = -math.sin(h) * dx + math.cos(h) * dy
            assert entry["ground_x"] == pytest.approx(gx, abs=2e-6)
            assert entry["ground_y"] == pytest.approx(gy, abs=2e-6)
            assert entry["range"] == pytest.approx(math.hypot(dx, dy),
                                                   abs=2e-6)
            bearing = math.atan2(dy, dx) - h
            bearing = math.atan2(math.sin(bearing), math.cos(bearing))
            assert entry["bearing"] == pytest.approx(bearing, abs=2e-6)
            assert entry["class"] == lm["class"]
            assert entry["kind"] == lm["kind"]
            seen += 1
    assert seen > 10


def test_straight_ahead_and_left():
    camera = Camera(640, 480)
    pose = Pose(2.0, 1.0, 1.0)
    ahead = Landmark("ahead", "red", 2.0 + 1.2 * math.cos(1.0),
                     1.0 + 1.2 * math.sin(1.0), 0.1)
    left = Landmark("left", "green", 2.0 + 1.0 * math.cos(1.3),
                    1.0 + 1.0 * math.sin(1.3), 0.1)
    right = Landmark("right", "blue", 2.0 + 0.9 * math.cos(0.75),
                     1.0 + 0.9 * math.sin(0.75), 0.07, kind="ball")
    scene = Scene(camera=camera, landmarks=[ahead, left, right],
                  effects=quiet_effects())
    _, truth, _ = render_frame(scene, pose, frame=0)
    got = {e["id"]: e for e in truth["landmarks"]}
    assert got["ahead"]["bearing"] == pytest.approx(0.0, abs=1e-6)
    assert got["ahead"]["u"] == pytest.approx(camera.cx, abs=0.01)
    assert got["ahead"]["u_centre"] == pytest.approx(camera.cx, abs=1e-3)
    assert got["left"]["bearing"] == pytest.approx(0.3, abs=1e-6)
    assert got["left"]["u"] < camera.cx - 50
    assert got["left"]["ground_y"] > 0
    assert got["right"]["bearing"] == pytest.approx(-0.25, abs=1e-6)
    assert got["right"]["u"] > camera.cx + 50
    assert got["ahead"]["range"] == pytest.approx(1.2, abs=1e-6)


def test_cut_and_occluded_flags():
    camera = Camera(640, 480)
    pose = Pose(0.0, 0.0, 0.0)
    # bearing 31 degrees: the disc straddles the left border (hfov 60)
    edge = Landmark("edge", "red", 1.0 * math.cos(0.54),
                    1.0 * math.sin(0.54), 0.12)
    inside = Landmark("inside", "green", 1.2, -0.1, 0.1)
    near = Landmark("near", "yellow", 0.28, 0.0, 0.1)   # bottom border
    ball = Landmark("ball", "blue", 0.9, 0.4, 0.08, kind="ball")
    hidden = Landmark("hidden", "pink", 1.02, 0.45, 0.14)
    scene = Scene(camera=camera, landmarks=[edge, inside, near, ball,
                                            hidden],
                  effects=quiet_effects())
    _, truth, _ = render_frame(scene, pose, frame=0)
    got = {e["id"]: e for e in truth["landmarks"]}
    assert got["edge"]["cut"] and got["edge"]["pixels"] > 0
    assert got["edge"]["u"] < 40
    assert got["near"]["cut"] and got["near"]["v"] > 420
    assert not got["inside"]["cut"] and not got["inside"]["occluded"]
    assert got["hidden"]["occluded"] and not got["hidden"]["cut"]
    assert not got["ball"]["occluded"]
    # what the ball hides is missing from the disc's visible area
    full = Scene(camera=camera, landmarks=[hidden], effects=quiet_effects())
    _, alone, _ = render_frame(full, pose, frame=0)
    assert got["hidden"]["pixels"] < 0.9 * alone["landmarks"][0]["pixels"]
    # a landmark out of view is not listed
    behind = Scene(camera=camera, landmarks=[
        Landmark("behind", "red", -1.0, 0.0, 0.1)], effects=quiet_effects())
    assert render_frame(behind, pose, frame=0)[1]["landmarks"] == []


# -- determinism -------------------------------------------------------------

def _scene(seed):
    return Scene(camera=Camera(*SMALL), seed=seed, floor="carpet",
                 landmarks=[Landmark("A", "red", 0.8, 0.1, 0.1),
                            Landmark("B", "blue", 1.1, -0.2, 0.07,
                                     kind="ball")])


def test_rendering_is_deterministic_for_a_seed():
    pose = Pose(0.0, 0.0, 0.05)
    a = render_frame(_scene(5), pose, frame=3)
    b = render_frame(_scene(5), pose, frame=3)
    c = render_frame(_scene(6), pose, frame=3)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[2], b[2])
    assert a[1] == b[1]
    assert not np.array_equal(a[0], c[0])
    # noise changes from frame to frame, the geometry does not
    d = render_frame(_scene(5), pose, frame=4)
    assert not np.array_equal(a[0], d[0])
    assert d[1]["landmarks"] == a[1]["landmarks"]


def test_scenario_outputs_are_deterministic(tmp_path):
    for name in ("one", "two"):
        render_scenario("distractors", str(tmp_path / name), seed=3,
                        frames=2, size=SMALL, progress=False,
                        robot="comfortable")
    for f in ("truth.jsonl", "map.json", "frame0.png", "mask0.png"):
        assert ((tmp_path / "one" / f).read_bytes()
                == (tmp_path / "two" / f).read_bytes()), f


# -- masks -------------------------------------------------------------------

def test_mask_labels_agree_with_rendered_colours(tmp_path):
    camera = Camera(320, 240)
    spots = [(0.6, 0.22), (0.75, -0.2), (0.95, 0.12), (1.1, -0.12),
             (1.3, 0.3)]
    lms = [Landmark(f"L{i}", name, x, y, 0.15)
           for i, (name, (x, y)) in enumerate(zip(MARKERS, spots))]
    scene = Scene(camera=camera, landmarks=lms, floor="tiles",
                  effects=quiet_effects())
    rgb, truth, mask = render_frame(scene, Pose(0.0, 0.0, 0.0), frame=0)
    palette = scene.scene_palette()
    assert palette.names == list(MARKERS) + ["floor"]
    assert palette.markers == list(MARKERS)
    assert set(np.unique(mask)) == set(range(1, len(palette) + 1))
    # interior pixels carry exactly the class colour
    srgb = scene.marker_srgb8()
    for k, name in enumerate(MARKERS, start=1):
        inner = cv2.erode((mask == k).astype(np.uint8), np.ones((3, 3)))
        assert inner.sum() > 20, name
        assert np.abs(rgb[inner > 0].astype(int)
                      - srgb[name]).max() <= 1, name
    # a palette learned from the frame and its mask comes back: exactly
    # from the interiors, roughly from the whole mask (edge pixels,
    # labelled by their majority class, blend with the floor)
    inner = np.zeros_like(mask)
    for k in range(1, len(palette) + 1):
        inner[cv2.erode((mask == k).astype(np.uint8),
                        np.ones((3, 3))) > 0] = k
    exact = learn_from_mask(rgb[:, :, ::-1], inner, names=palette.names)
    rough = learn_from_mask(rgb[:, :, ::-1], mask, names=palette.names)
    for a, b, want in zip(exact.classes, rough.classes, palette.classes):
        assert np.linalg.norm(np.subtract(a.lab, want.lab)) < 1.0, want.name
        assert np.linalg.norm(np.subtract(b.lab, want.lab)) < 8.0, want.name
    # nearly every labelled pixel is nearest to its own class colour
    lab = reference.rgb_to_lab(rgb).reshape(-1, 3)
    dist = np.linalg.norm(lab[:, None, :] - palette.lab_array()[None],
                          axis=2)
    nearest = dist.argmin(axis=1) + 1
    labels = mask.ravel()
    for k in range(1, len(palette) + 1):
        assert (nearest[labels == k] == k).mean() > 0.9, palette.names[k - 1]


def test_mask_of_balls_walls_and_distractors():
    camera = Camera(320, 240, tilt_deg=10)
    scene = Scene(
        camera=camera, floor="wood", walls=Walls(-1, -2, 3, 2),
        landmarks=[Landmark("ball", "pink", 1.0, 0.0, 0.1, kind="ball")],
        distractors=[Distractor("yellow", "square", 0.8, 0.3, 0.1),
                     Distractor("green", "stripe", 1.2, -0.4, 0.3, 0.03),
                     Distractor("blue", "triangle", 0.7, -0.25, 0.1)])
    rgb, truth, mask = render_frame(scene, Pose(0.0, 0.0, 0.0), frame=0)
    names = scene.scene_palette().names
    assert names[-2:] == ["floor", "wall"]
    (entry,) = truth["landmarks"]      # distractors are not landmarks
    u, v = int(round(entry["u"])), int(round(entry["v"]))
    assert mask[v, u] == names.index("pink") + 1
    for name in ("yellow", "green", "blue", "floor", "wall"):
        assert (mask == names.index(name) + 1).sum() > 30, name


# -- outputs -----------------------------------------------------------------

@pytest.mark.parametrize("name", [n for n in SCENARIOS if n != "custom"])
def test_scenario_writes_outputs(tmp_path, name):
    summary = render_scenario(name, str(tmp_path), frames=3, size=SMALL,
                              progress=False, robot="comfortable")
    assert summary["frames"] == 3
    scene = json.loads((tmp_path / "scene.json").read_text())
    assert scene["scenario"] == name and scene["frames"] == 3
    assert set(scene["camera"]) == {"width", "height", "fx", "fy", "cx",
                                    "cy", "hfov_deg", "height_m",
                                    "tilt_deg", "roll_deg"}
    # path and range-sweep have their own camera (a robot's wide-angle one)
    assert scene["camera"]["hfov_deg"] == pytest.approx(
        80.0 if name in ("path", "range-sweep") else 60.0)
    for key in ("fps", "seed", "floor", "effects", "palette", "map",
                "visibility", "chart"):
        assert key in scene
    assert sum(scene["visibility"]["frames_by_landmarks"].values()) == 3
    the_map = json.loads((tmp_path / "map.json").read_text())
    assert list(the_map) == ["landmarks"] and the_map == scene["map"]
    for lm in the_map["landmarks"]:
        assert set(lm) == {"id", "class", "x", "y", "z", "diameter",
                           "kind"}
    palette = load_palette(str(tmp_path / "palette.json"))
    assert palette_to_json(palette)["classes"] == \
        palette_to_json(parse_palette(scene["palette"]))["classes"]
    lines = (tmp_path / "truth.jsonl").read_text().splitlines()
    assert [json.loads(x)["frame"] for x in lines] == [0, 1, 2]
    assert json.loads(lines[1])["pts"] == 33333333
    mask = cv2.imread(str(tmp_path / "mask0.png"), cv2.IMREAD_UNCHANGED)
    assert mask.shape == (120, 160) and mask.dtype == np.uint8
    assert mask.max() <= len(scene["palette"]["classes"])
    # the colour chart shows every class of the scene palette
    chart = cv2.imread(str(tmp_path / "chart.png"))
    chart_mask = cv2.imread(str(tmp_path / "chart-mask.png"),
                            cv2.IMREAD_UNCHANGED)
    assert chart.shape == (120, 160, 3) and chart_mask.shape == (120, 160)
    n_classes = len(scene["palette"]["classes"])
    assert set(np.unique(chart_mask)) - {0} == set(range(1, n_classes + 1))
    frame0 = cv2.imread(str(tmp_path / "frame0.png"))
    cap = cv2.VideoCapture(str(tmp_path / "clip.avi"))
    ok, decoded = cap.read()
    assert ok and decoded.shape == frame0.shape
    assert np.abs(decoded.astype(int) - frame0).mean() < 4


def test_cli_custom_raw_png_and_masks(tmp_path):
    the_map = {"landmarks": [
        {"id": "A", "class": "red", "x": 1.0, "y": 0.0, "z": 0.0,
         "diameter": 0.1, "kind": "disc"},
        {"id": "B", "class": "yellow", "x": 1.3, "y": 0.3, "z": 0.035,
         "diameter": 0.07, "kind": "ball"}]}
    (tmp_path / "map.json").write_text(json.dumps(the_map))
    poses = [{"x": 0.0, "y": 0.0, "heading": 0.0},
             {"x": 0.05, "y": 0.0, "heading": 0.02}]
    (tmp_path / "poses.json").write_text(json.dumps(poses))
    out = tmp_path / "out"
    status = cli.main(["synth", "custom", "--robot", "comfortable",
                       "--out", str(out), "--map",
                       str(tmp_path / "map.json"), "--poses",
                       str(tmp_path / "poses.json"), "--size", "161x121",
                       "--raw", str(out / "clip.rgb"), "--frames-png",
                       str(out / "png"), "--masks", "all", "--floor",
                       "tiles", "--noise", "0", "--no-progress"])
    assert status == 0
    scene = json.loads((out / "scene.json").read_text())
    assert scene["frames"] == 2
    assert scene["raw"]["caps"] == ("video/x-raw,format=RGB,width=161,"
                                    "height=121,framerate=30/1")
    stride = scene["raw"]["stride"]
    assert stride == 484
    raw = (out / "clip.rgb").read_bytes()
    assert len(raw) == 2 * stride * 121
    first = np.frombuffer(raw[:stride * 121], np.uint8).reshape(121, stride)
    png = cv2.imread(str(out / "png" / "000000.png"))[:, :, ::-1]
    assert np.array_equal(first[:, :161 * 3].reshape(121, 161, 3), png)
    assert (out / "masks" / "000001.png").exists()
    truth = [json.loads(x) for x in
             (out / "truth.jsonl").read_text().splitlines()]
    assert truth[1]["robot"] == {"x": 0.05, "y": 0.0, "heading": 0.02}
    assert {e["id"] for e in truth[0]["landmarks"]} == {"A", "B"}
    assert json.loads((out / "map.json").read_text()) == the_map


def test_no_chart_when_the_camera_sees_no_floor(tmp_path, capsys):
    the_map = tmp_path / "map.json"
    the_map.write_text(json.dumps({"landmarks": [
        {"id": "A", "class": "red", "x": 1.0, "y": 0.0, "diameter": 0.1}]}))
    out = tmp_path / "out"
    # looking up: the clip and the truth are written, the chart is not
    status = cli.main(["synth", "custom", "--out", str(out), "--map",
                       str(the_map), "--frames", "1", "--size", "80x60",
                       "--tilt", "-40", "--no-progress"])
    assert status == 0
    captured = capsys.readouterr()
    assert "warning: no colour chart" in captured.err
    assert "chart.png" not in captured.out
    assert json.loads((out / "scene.json").read_text())["chart"] is None
    assert (out / "truth.jsonl").exists()
    assert not (out / "chart.png").exists()


def test_cli_rejects_bad_input(tmp_path, capsys):
    assert cli.main(["synth", "path", "--size", "big"]) == 2
    assert cli.main(["synth", "custom", "--out", str(tmp_path)]) == 2
    assert cli.main(["synth", "path", "--out", str(tmp_path), "--palette",
                     str(tmp_path / "missing.json")]) == 1
    assert "missing.json" in capsys.readouterr().err


def test_ball_across_the_camera_plane_is_bounded_correctly():
    """A big ball beside and below the camera, partly behind its plane:
    the tight pixel box used for supersampling loses nothing."""
    from gstlandmark.synth.render import Renderer
    camera = Camera(*SMALL)
    for x, y, r in ((-0.07, -0.05, 0.16), (-0.07, -0.1, 0.16),
                    (0.05, -0.1, 0.1)):
        lm = [Landmark("B", "red", x, y, 2 * r, kind="ball")]
        tight = Scene(camera=camera, landmarks=lm, effects=quiet_effects())
        full = Scene(camera=camera, landmarks=lm, effects=quiet_effects())
        everything = Renderer(full)
        everything._bbox = lambda o, rot, c: (0, SMALL[0] - 1,
                                              0, SMALL[1] - 1)
        full._cache[("renderer",)] = everything
        a = render_frame(tight, Pose(0, 0, 0), frame=0)
        b = render_frame(full, Pose(0, 0, 0), frame=0)
        assert a[1]["landmarks"] and a[1]["landmarks"][0]["cut"]
        assert np.array_equal(a[0], b[0]) and np.array_equal(a[2], b[2])
        assert a[1] == b[1]


def test_effects_change_pixels_not_truth():
    base = dict(camera=Camera(*SMALL), seed=1,
                landmarks=[Landmark("A", "red", 0.8, 0.1, 0.1),
                           Landmark("B", "blue", 1.1, -0.2, 0.07,
                                    kind="ball")])
    from gstlandmark.synth.scenarios import Sweep
    moving = Sweep(0.0, 0.0, 0.0, 0.5, 0.3, 1.0)
    plain = Scene(effects=quiet_effects(), trajectory=moving, **base)
    pose = moving.pose(0.2)
    ref = render_frame(plain, pose, t=0.2, frame=6)
    for effects in (quiet_effects(vignette=0.4),
                    quiet_effects(exposure_drift_stops=0.5, wb_drift=0.1),
                    quiet_effects(auto_exposure=0.7, auto_wb=0.5),
                    quiet_effects(motion_blur=3),
                    Effects(noise_sigma=3.0, ball_shading=1.0)):
        scene = Scene(effects=effects, trajectory=moving, **base)
        rgb, truth, mask = render_frame(scene, pose, t=0.2, frame=6)
        assert not np.array_equal(rgb, ref[0]), effects
        assert truth == ref[1] and np.array_equal(mask, ref[2]), effects
    with pytest.raises(ValueError):
        Scene(effects=Effects(jpeg_quality=101), **base)


# -- the path benchmark ------------------------------------------------------

@pytest.fixture(scope="module")
def path_clip(tmp_path_factory):
    """The path scenario as shipped: default seed, size and camera (the
    truth only; no clip)."""
    out = tmp_path_factory.mktemp("path")
    summary = render_scenario("path", str(out), progress=False, clip=False,
                              robot="comfortable")
    return out, summary


def test_path_shows_three_landmarks_in_most_frames(path_clip):
    out, summary = path_clip
    scene = json.loads((out / "scene.json").read_text())
    frames = [json.loads(x) for x in
              (out / "truth.jsonl").read_text().splitlines()]
    assert len(frames) == 300 and scene["fps"] == 30
    counts = [sum(1 for e in f["landmarks"] if e["pixels"] >= 150)
              for f in frames]
    hist = np.bincount(counts, minlength=5)
    # the histogram in scene.json (and the summary) is this one
    assert scene["visibility"] == summary["visibility"]
    assert scene["visibility"]["min_pixels"] == 150
    assert scene["visibility"]["frames_by_landmarks"] == {
        str(k): int(n) for k, n in enumerate(hist)}
    three = int((np.array(counts) >= 3).sum())
    assert scene["visibility"]["three_or_more"] == three
    # goals: three or more in over half the frames, and most others show
    # one or two (frames solved with one and with two are reported too)
    assert three >= 0.55 * 300, hist
    assert hist[0] <= 0.02 * 300, hist
    assert hist[1] >= 20 and hist[2] >= 5, hist
    assert hist[1] + hist[2] >= 0.9 * (300 - three), hist


def test_path_world_and_camera(path_clip):
    out, _ = path_clip
    scene = json.loads((out / "scene.json").read_text())
    cam = scene["camera"]
    assert (cam["width"], cam["height"]) == (640, 480)
    assert cam["hfov_deg"] == pytest.approx(80.0)
    assert cam["height_m"] == 0.5 and cam["tilt_deg"] == 20.0
    assert scene["notes"]["camera_defaults"] == {
        "hfov_deg": 80.0, "height_m": 0.5, "tilt_deg": 20.0}
    walls = scene["walls"]
    assert (walls["x0"], walls["y0"], walls["x1"], walls["y1"]) == \
        (0.0, 0.0, 6.0, 6.0)
    landmarks = scene["map"]["landmarks"]
    assert len(landmarks) == 8
    classes = [lm["class"] for lm in landmarks]
    assert max(classes.count(c) for c in classes) >= 2   # association
    kinds = [lm["kind"] for lm in landmarks]
    assert "ball" in kinds and "disc" in kinds
    for lm in landmarks:
        r = lm["diameter"] / 2
        assert r < lm["x"] < 6 - r and r < lm["y"] < 6 - r
        if lm["kind"] == "disc":
            assert 0.25 <= lm["diameter"] <= 0.35 and lm["z"] == 0
        else:
            assert 0.15 <= lm["diameter"] <= 0.25 and lm["z"] == r
    # a smooth path inside the field, heading along it, clear of the
    # landmarks
    poses = np.array([[f["robot"]["x"], f["robot"]["y"],
                       f["robot"]["heading"]] for f in
                      map(json.loads, (out / "truth.jsonl").read_text()
                          .splitlines())])
    assert (poses[:, :2] > 0.5).all() and (poses[:, :2] < 5.5).all()
    step = np.diff(poses[:, :2], axis=0)
    speed = np.hypot(step[:, 0], step[:, 1]) * 30
    assert speed.max() < 1.5 and speed.min() > 0.2
    along = np.arctan2(step[:, 1], step[:, 0])
    turn = np.angle(np.exp(1j * (along - poses[:-1, 2])))
    assert np.abs(turn).max() < 0.1
    turn_rate = np.angle(np.exp(1j * np.diff(poses[:, 2]))) * 30
    assert np.abs(turn_rate).max() < 3.0          # rad/s
    for lm in landmarks:
        gap = np.hypot(poses[:, 0] - lm["x"], poses[:, 1] - lm["y"])
        assert gap.min() > 0.35, lm["id"]


def test_path_camera_overrides_still_apply(tmp_path):
    from gstlandmark.synth import build_scenario
    scene, _ = build_scenario("path", frames=2, hfov_deg=60,
                              height_m=0.3, robot="comfortable")
    assert scene.camera.hfov_deg == pytest.approx(60.0)
    assert scene.camera.height_m == 0.3 and scene.camera.tilt_deg == 20.0
    scene, _ = build_scenario("path", frames=2, fx=500.0,
                              robot="comfortable")
    assert scene.camera.fx == 500.0


# -- the colour chart ---------------------------------------------------------

def _srgb_lab(rgb):
    return reference.rgb_to_lab(
        np.array(rgb, np.uint8).reshape(1, 1, 3)).reshape(3)


def test_chart_learns_every_class_by_the_cli(tmp_path, capsys):
    out = tmp_path / "path"
    render_scenario("path", str(out), frames=1, progress=False, clip=False,
                    noise_sigma=0.0, jpeg_quality=100, robot="comfortable")
    scene = json.loads((out / "scene.json").read_text())
    classes = scene["palette"]["classes"]
    names = [c["name"] for c in classes]
    markers = [c["name"] for c in classes if c["marker"]]
    # frame 0 does not show every class; the chart does
    mask0 = cv2.imread(str(out / "mask0.png"), cv2.IMREAD_UNCHANGED)
    assert len(set(np.unique(mask0)) - {0}) < len(names)
    chart_mask = cv2.imread(str(out / "chart-mask.png"),
                            cv2.IMREAD_UNCHANGED)
    pixels = np.bincount(chart_mask.ravel(), minlength=len(names) + 1)
    assert (pixels[1:] >= 1000).all(), pixels
    assert scene["chart"]["pixels"] == {
        n: int(pixels[k]) for k, n in enumerate(names, start=1)}
    learned_path = tmp_path / "learned.json"
    status = cli.main(["palette", "learn", str(out / "chart.png"),
                       "--mask", str(out / "chart-mask.png"),
                       "--names", ",".join(names), "--markers",
                       ",".join(markers), "-o", str(learned_path)])
    assert status == 0, capsys.readouterr().err
    learned = load_palette(str(learned_path))
    # and what the chart shows of no class (the sky above the walls) is a
    # background class of its own, last
    assert learned.names == names + ["untaught"]
    assert learned.markers == markers
    assert learned.classes[-1].role == "background"
    # each class comes back within 2 Delta E of the colour painted
    from gstlandmark.synth import build_scenario
    built, _ = build_scenario("path", robot="comfortable")
    srgb = built.marker_srgb8()
    want = {name: _srgb_lab(rgb) for name, rgb in srgb.items()}
    want["floor"] = _srgb_lab((128, 128, 128))
    want["wall"] = _srgb_lab(scene["walls"]["colour_srgb"])
    for cls in learned.classes[:-1]:
        # a ball's lit and shaded sides may be references of their own;
        # the flat colour painted is one of them
        delta = min(np.linalg.norm(np.subtract(ref, want[cls.name]))
                    for ref in cls.reference_labs)
        assert delta < 2.0, (cls.name, delta)


def test_chart_of_a_scene_with_many_floors():
    from gstlandmark.synth import build_scenario
    from gstlandmark.synth.chart import render_chart
    scene, n = build_scenario("backgrounds", size=(320, 240),
                              noise_sigma=0.0, auto_exposure=0.0,
                              auto_wb=0.0, robot="comfortable")
    # flat markers only: a ball adds shaded tones (tested below)
    scene = scene.with_(landmarks=[
        dataclasses.replace(lm, kind="disc", z=None)
        for lm in scene.landmarks])
    palette = scene.scene_palette()
    rgb, mask, info = render_chart(scene, n)
    assert len(palette.background) == 8          # one class per floor
    pixels = np.bincount(mask.ravel(), minlength=len(palette) + 1)
    assert (pixels[1:] >= 50).all(), pixels
    learned = learn_from_mask(rgb[:, :, ::-1], mask, names=palette.names,
                              markers=palette.markers)
    for got, ref in zip(learned.classes, palette.classes):
        delta = np.linalg.norm(np.subtract(got.lab, ref.lab))
        # plain colours exactly (up to 8-bit sRGB); a small square of a
        # texture roughly (the wood's planks differ in tone)
        textured = ref.name in ("floor-wood", "floor-carpet",
                                "floor-tiles")
        assert delta < (8.0 if textured else 1.0), (ref.name, delta)


def test_chart_has_frame0_lighting(tmp_path):
    """Auto exposure and white balance: the chart gets frame 0's gains,
    not gains of its own."""
    from gstlandmark.synth import build_scenario
    from gstlandmark.synth.chart import render_chart
    scene, n = build_scenario("path", size=SMALL, noise_sigma=0.0,
                              auto_exposure=1.0, auto_wb=0.6,
                              exposure_stops=-0.5, robot="comfortable")
    rgb0, _, mask0 = render_frame(scene, scene.trajectory.pose(0.0), t=0.0,
                                  frame=0, frames_total=n)
    rgb, mask, _ = render_chart(scene, n)
    floor = scene.scene_palette().names.index("floor") + 1
    kernel = np.ones((3, 3), np.uint8)

    def inside(m):
        # away from edges, where a pixel blends two surfaces
        return cv2.erode((m == floor).astype(np.uint8), kernel) > 0

    a = rgb0[inside(mask0)].reshape(-1, 3)
    b = rgb[inside(mask)].reshape(-1, 3)
    assert len(a) > 100 and len(b) > 100
    # the plain grey floor is one colour in both pictures
    assert np.ptp(a, axis=0).max() <= 1 and np.ptp(b, axis=0).max() <= 1
    assert np.abs(np.median(a, axis=0) - np.median(b, axis=0)).max() <= 1
    plain, _ = build_scenario("path", size=SMALL, noise_sigma=0.0,
                              robot="comfortable")
    rgb_plain, mask_plain, _ = render_chart(plain, n)
    c = rgb_plain[inside(mask_plain)].reshape(-1, 3)
    assert np.abs(np.median(a, axis=0) - np.median(c, axis=0)).max() > 5


@pytest.mark.parametrize("ball_d", [None, 0.45])
def test_chart_holds_a_ball_of_every_ball_class(ball_d):
    """A ball per class the scene has balls of, at the scene's diameter,
    its pixels in the mask of its class, lit on one side and shaded on
    the other; balls too big for a grid cell stand in a row at the back
    (0.45 m on the comfortable camera), never on one another."""
    from gstlandmark.synth import build_scenario
    from gstlandmark.synth.chart import CHART_POSE, render_chart
    scene, n = build_scenario("path", size=(320, 240), noise_sigma=0.0,
                              robot="comfortable")
    if ball_d is not None:
        scene = scene.with_(landmarks=[
            dataclasses.replace(lm, diameter=ball_d, z=None)
            if lm.kind == "ball" else lm for lm in scene.landmarks])
    sizes = {}
    for lm in scene.landmarks:
        if lm.kind == "ball":
            sizes.setdefault(lm.cls, set()).add(lm.diameter)
    assert len(sizes) >= 2 and all(len(d) == 1 for d in sizes.values())
    rgb, mask, info = render_chart(scene, n)
    balls = [i for i in info["items"] if i["shape"] == "ball"]
    assert sorted(b["class"] for b in balls) == sorted(sizes)
    names = scene.scene_palette().names
    cam = scene.camera
    lab = reference.rgb_to_lab(rgb[:, :, ::-1].copy())
    vv, uu = np.mgrid[0:cam.height, 0:cam.width]
    circles = []
    for b in balls:
        assert b["size"] == pytest.approx(sizes[b["class"]].pop(), abs=1e-4)
        r = b["size"] / 2.0
        uv, depth = cam.project(np.array([[b["x"], b["y"], r]]),
                                CHART_POSE)
        (u, v), radius = uv[0], cam.fx * r / depth[0]
        circles.append((u, v, radius))
        # well inside the silhouette: the ball, nothing else
        inner = (uu - u) ** 2 + (vv - v) ** 2 <= (0.7 * radius) ** 2
        assert inner.sum() >= 200, b
        assert (mask[inner] == names.index(b["class"]) + 1).all(), b
        # lit and shaded sides (ball_shading 0.5): L* spreads over the
        # ball's pure pixels (a flat disc without noise: under 1)
        outline = (uu - u) ** 2 + (vv - v) ** 2 <= radius ** 2
        lightness = lab[outline & (mask == names.index(b["class"]) + 1)][:, 0]
        spread = np.percentile(lightness, 95) - np.percentile(lightness, 5)
        assert spread > 4.0, (b, spread)
    for i, (u1, v1, r1) in enumerate(circles):
        for u2, v2, r2 in circles[i + 1:]:
            assert math.hypot(u1 - u2, v1 - v2) >= r1 + r2


# -- the seed's robot and random variants ------------------------------------

def polygon_area(p):
    x, y = p[:, 0], p[:, 1]
    return abs((x * np.roll(y, -1) - np.roll(x, -1) * y).sum()) / 2


@pytest.mark.parametrize("rng_m", [0.5, 1.0, 1.5])
def test_seed_robot_is_the_default_and_sizes_a_disc_as_a_pinhole(rng_m):
    from gstlandmark.synth import build_scenario
    lm = Landmark("L1", "red", rng_m, 0.0, 0.10)
    scene, frames = build_scenario("custom", map=[lm], pose=(0, 0, 0),
                                   frames=1)
    cam = scene.camera
    assert frames == 1
    assert (cam.width, cam.height) == (640, 480)
    assert cam.fx == pytest.approx(320 / math.tan(math.radians(27)))
    assert (cam.height_m, cam.tilt_deg, cam.roll_deg) == (0.2, 18.0, 0.0)
    scene = scene.with_(effects=quiet_effects())
    pose = Pose(0.0, 0.0, 0.0)
    _, truth, _ = render_frame(scene, pose, frame=0)
    (entry,) = truth["landmarks"]
    # the area of the disc's image, by cv2.projectPoints of its outline
    # from the conventions' camera
    outline = project(outline_world(lm, pose, cam), pose, cam)
    assert entry["pixels"] == pytest.approx(polygon_area(outline),
                                            rel=0.01)
    # and the pinhole's first-order figures: f d / depth wide, that times
    # the sine of the view's angle below the horizon tall
    depth = rng_m * math.cos(math.radians(18)) + 0.2 * math.sin(
        math.radians(18))
    width = cam.fx * 0.10 / depth
    height = width * math.sin(math.atan2(0.2, rng_m))
    assert np.ptp(outline[:, 0]) == pytest.approx(width, rel=0.02)
    assert np.ptp(outline[:, 1]) == pytest.approx(height, rel=0.1)
    assert entry["pixels"] == pytest.approx(math.pi / 4 * width * height,
                                            rel=0.1)
    assert not entry["cut"] and entry["occluded_fraction"] == 0.0


# -- coded markers: beacons, posts, cones (docs/beacons.md) ----------------

def band_boxes_by_pinhole(lm, pose, camera, count=3600):
    """Each band's image box [u0, v0, u1, v1], top first, from
    cv2.projectPoints of its edge circles: the points of each circle on
    the side facing the camera (a convex body hides nothing of its own
    surface that faces the camera), and the whole top circle of a
    cylinder seen from above it (its cap)."""
    a = np.linspace(0.0, 2 * math.pi, count, endpoint=False)
    ring = np.stack([np.cos(a), np.sin(a)], axis=1)
    eye = np.array([pose.x, pose.y, camera.height_m])
    cone = lm.kind == "cone"
    top = lm.z + lm.height
    edges = [top - sum(lm.band_heights[:k])
             for k in range(len(lm.band_heights) + 1)]
    boxes = []
    for k in range(len(lm.band_heights)):
        pts = []
        for z in (edges[k], edges[k + 1]):
            r = lm.radius * ((top - z) / lm.height if cone else 1.0)
            p = np.column_stack([lm.x + r * ring[:, 0],
                                 lm.y + r * ring[:, 1], np.full(count, z)])
            # outward normal of the side at each point of the circle
            n = np.column_stack([ring * (lm.height if cone else 1.0),
                                 np.full(count, lm.radius if cone else 0.0)])
            facing = ((eye - p) * n).sum(axis=1) >= 0
            if not cone and k == 0 and z == top and eye[2] > top:
                facing[:] = True
            pts.append(p[facing])
        uv = project(np.concatenate(pts), pose, camera)
        boxes.append(np.array([uv[:, 0].min(), uv[:, 1].min(),
                               uv[:, 0].max(), uv[:, 1].max()]))
    return boxes


def mask_box(mask, value, near):
    """[u0, v0, u1, v1] of the mask's pixels of ``value`` in the window
    ``near`` (u0, v0, u1, v1), as pixel edges."""
    u0, v0, u1, v1 = (int(round(x)) for x in near)
    win = mask[max(v0 - 3, 0):v1 + 4, max(u0 - 3, 0):u1 + 4] == value
    vv, uu = np.nonzero(win)
    return np.array([uu.min() + max(u0 - 3, 0) - 0.5,
                     vv.min() + max(v0 - 3, 0) - 0.5,
                     uu.max() + max(u0 - 3, 0) + 0.5,
                     vv.max() + max(v0 - 3, 0) + 0.5])


@pytest.mark.parametrize("rng_m, height", [(0.8, 0.16), (1.2, 0.16),
                                           (2.0, 0.25)])
def test_beacon_straight_ahead_has_the_pinholes_band_boxes(rng_m, height):
    """A beacon straight ahead at a known range, the seed robot's camera:
    the truth's band boxes and the rendered mask's are those of the
    pinhole projection of the band edges, within 1 px; the floor contact
    and the range are the axis's."""
    from gstlandmark.synth import build_scenario
    lm = Landmark("B1", "pink/yellow", rng_m, 0.0, 0.10, kind="beacon",
                  height=height, band_heights=(0.4 * height, 0.6 * height))
    scene, _ = build_scenario("custom", map=[lm], pose=(0, 0, 0), frames=1)
    scene = scene.with_(effects=quiet_effects())
    cam, pose = scene.camera, Pose(0.0, 0.0, 0.0)
    assert (cam.height_m, cam.tilt_deg) == (0.2, 18.0)
    _, truth, mask = render_frame(scene, pose, frame=0)
    (entry,) = truth["landmarks"]
    assert (entry["class"], entry["code"], entry["kind"]) == (
        "pink/yellow", "pink/yellow", "beacon")
    assert entry["range"] == pytest.approx(rng_m, abs=1e-6)
    assert entry["bearing"] == pytest.approx(0.0, abs=1e-6)
    assert not entry["cut"] and entry["occluded_fraction"] == 0.0
    expected = band_boxes_by_pinhole(lm, pose, cam)
    names = scene.scene_palette().names
    for band, want, cls in zip(entry["bands"], expected, lm.bands):
        assert band["class"] == cls
        got = np.array(band["box"])
        assert np.abs(got - want).max() < 1.0, (cls, got, want)
        drawn = mask_box(mask, names.index(cls) + 1, want)
        assert np.abs(drawn - want).max() < 1.0, (cls, drawn, want)
    whole = np.array([min(b[0] for b in expected),
                      min(b[1] for b in expected),
                      max(b[2] for b in expected),
                      max(b[3] for b in expected)])
    assert np.abs(np.array(entry["box"]) - whole).max() < 1.0
    # the floor contact: the axis's foot, and the base's nearest point,
    # the lowest point of the outline below the axis
    foot = project([[lm.x, lm.y, 0.0]], pose, cam)[0]
    front = project([[lm.x - lm.radius, lm.y, 0.0]], pose, cam)[0]
    assert (entry["u_base"], entry["v_base"]) == pytest.approx(
        tuple(foot), abs=1e-3)
    assert (entry["u_front"], entry["v_front"]) == pytest.approx(
        tuple(front), abs=1e-3)
    assert entry["box"][3] == pytest.approx(front[1], abs=0.5)
    # the bands stack: the top one's box above the bottom one's
    assert entry["bands"][0]["box"][1] < entry["bands"][1]["box"][1]
    assert entry["pixels"] == pytest.approx(
        sum(b["pixels"] for b in entry["bands"]), abs=1e-3)


def test_cone_and_post_off_axis_with_roll_have_the_pinholes_boxes():
    """A striped cone and a one-colour post to either side, the camera
    rolled: the band boxes are still the pinhole's within 1 px."""
    camera = Camera(640, 480, hfov_deg=60, height_m=0.3, tilt_deg=20,
                    roll_deg=6.0)
    pose = Pose(0.5, -0.3, 0.4)
    cone = Landmark("C1", "yellow/blue/yellow",
                    pose.x + 1.3 * math.cos(0.6), pose.y + 1.3 * math.sin(0.6),
                    0.2, kind="cone", height=0.3)
    post = Landmark("P1", "red", pose.x + 1.1 * math.cos(0.15),
                    pose.y + 1.1 * math.sin(0.15), 0.03, kind="post",
                    height=0.33)
    scene = Scene(camera=camera, landmarks=[cone, post],
                  effects=quiet_effects())
    _, truth, _ = render_frame(scene, pose, frame=0)
    got = {e["id"]: e for e in truth["landmarks"]}
    assert got["C1"]["code"] == "yellow/blue/yellow"
    assert got["P1"]["code"] == "red" and len(got["P1"]["bands"]) == 1
    assert not got["C1"]["cut"] and not got["P1"]["cut"]
    for lm in (cone, post):
        expected = band_boxes_by_pinhole(lm, pose, camera)
        for band, want in zip(got[lm.id]["bands"], expected):
            assert np.abs(np.array(band["box"]) - want).max() < 1.0, (
                lm.id, band, want)


def test_upright_markers_are_shaded_by_the_light():
    """The side facing the light is brighter, as on a ball."""
    camera = Camera(320, 240, hfov_deg=60, height_m=0.3, tilt_deg=15)
    lm = Landmark("B1", "pink/yellow", 1.0, 0.0, 0.3, kind="beacon",
                  height=0.3)
    lit = {}
    for name, light in (("left", (0.0, 1.0, 0.3)), ("right",
                                                    (0.0, -1.0, 0.3))):
        scene = Scene(camera=camera, landmarks=[lm], light=light,
                      effects=Effects(noise_sigma=0.0, ball_shading=0.8))
        rgb, truth, _ = render_frame(scene, Pose(0.0, 0.0, 0.0), frame=0)
        box = truth["landmarks"][0]["bands"][1]["box"]
        v = int((box[1] + box[3]) / 2)
        left = rgb[v, int(box[0]) + 4].astype(int).sum()
        right = rgb[v, int(box[2]) - 4].astype(int).sum()
        lit[name] = left - right
    # a light from the robot's left (+y) lights the image's left side
    assert lit["left"] > 40 and lit["right"] < -40


def test_coded_markers_in_the_map_and_the_palette(tmp_path):
    from gstlandmark.landmarkmap import MapError, parse_map
    from gstlandmark.synth import load_map
    lm = Landmark("B1", "pink/yellow", 1.0, 0.5, 0.1, kind="beacon",
                  height=0.3, band_heights=(0.1, 0.2))
    cone = Landmark("C1", "blue", 2.0, 0.0, 0.2, kind="cone", height=0.3)
    scene = Scene(landmarks=[lm, cone])
    (read, read_cone) = parse_map(scene.map_json())
    assert (read["code"], read["bands"], read["band_heights"],
            read["height"]) == ("pink/yellow", ["pink", "yellow"],
                                [0.1, 0.2], 0.3)
    assert read_cone["band_heights"] == [0.3]
    path = tmp_path / "map.json"
    path.write_text(json.dumps(scene.map_json()))
    again = load_map(str(path), scene.palette.names)
    assert [(m.cls, m.kind, tuple(m.band_heights)) for m in again] == [
        ("pink/yellow", "beacon", (0.1, 0.2)), ("blue", "cone", (0.3,))]
    # a band the palette lacks: the file, the landmark and the band
    with pytest.raises(MapError, match=r'map.json: landmarks\[0\] \("B1"\): '
                       r'"bands"\[1\] yellow is not a class of the palette'):
        load_map(str(path), ["pink", "blue"])
    with pytest.raises(ValueError, match="'purple' is not a marker"):
        Scene(landmarks=[Landmark("B2", "purple/pink", 0, 0, 0.1,
                                  kind="beacon", height=0.2)])
    # the map's rules hold for the synthetic world's markers too
    with pytest.raises(ValueError, match='"bands" must hold 2 to 3'):
        Landmark("B3", "pink", 0, 0, 0.1, kind="beacon", height=0.2)
    with pytest.raises(ValueError, match='"height" must be a positive'):
        Landmark("B4", "pink/blue", 0, 0, 0.1, kind="beacon")


def test_evaluate_counts_a_beacon_by_its_code():
    """A detection that carries the code matches the beacon's truth; a
    chain that reads no code misses it, under the code's name."""
    from gstlandmark.commands import evaluate
    lm = Landmark("B1", "pink/yellow", 1.2, 0.0, 0.1, kind="beacon",
                  height=0.16)
    scene = Scene(camera=Camera(640, 480, hfov_deg=54, height_m=0.2,
                                tilt_deg=18), landmarks=[lm],
                  effects=quiet_effects())
    _, truth, _ = render_frame(scene, Pose(0.0, 0.0, 0.0), frame=0)
    mark = truth["landmarks"][0]
    u0, v0, u1, v1 = mark["box"]
    found = {"frame": 0, "detections": [{
        "class": "pink/yellow", "accepted": True,
        "bbox": [round(u0 + 0.5), round(v0 + 0.5), round(u1 - u0),
                 round(v1 - v0)],
        "blob": {"centroid-x": mark["u"], "centroid-y": mark["v"]}}]}
    ev = evaluate.evaluate([found], [truth])
    assert ev.by_class["pink/yellow"].tp == 1
    ev = evaluate.evaluate([{"frame": 0, "detections": []}], [truth])
    assert ev.by_class["pink/yellow"].fn == 1


def test_seed_robot_scenarios_use_its_markers():
    from gstlandmark.synth import build_scenario
    for name in ("range-sweep", "path", "distractors", "backgrounds"):
        scene, _ = build_scenario(name, frames=2)
        assert scene.camera.hfov_deg == pytest.approx(54.0), name
        assert scene.camera.height_m == 0.2 and scene.camera.tilt_deg == 18
        sizes = {(lm.kind, lm.diameter) for lm in scene.landmarks}
        assert sizes <= {("disc", 0.10), ("ball", 0.08)}, (name, sizes)
    sweep, _ = build_scenario("range-sweep")
    ranges = [math.hypot(lm.x, lm.y) for lm in sweep.landmarks]
    assert min(ranges) == pytest.approx(0.3)
    assert max(ranges) == pytest.approx(4.0)
    comfortable, _ = build_scenario("range-sweep", robot="comfortable")
    assert comfortable.camera.height_m == 0.5
    assert max(math.hypot(lm.x, lm.y)
               for lm in comfortable.landmarks) == pytest.approx(5.0)
    with pytest.raises(ValueError, match="robot"):
        build_scenario("path", robot="tall")


def test_seed_path_shows_three_whole_landmarks_in_a_share_of_frames():
    from gstlandmark.synth import build_scenario
    scene, n = build_scenario("path", size=(320, 240), hfov_deg=54.0)
    assert n == 300 and len(scene.landmarks) == 16
    assert (scene.walls.x1, scene.walls.y1) == (2.5, 2.5)
    three = 0
    for i in range(0, 300, 10):
        pose = scene.trajectory.pose(i / 30)
        _, truth, _ = render_frame(scene, pose, t=i / 30, frame=i,
                                   frames_total=n)
        # a quarter of the pixels at half the size
        whole = [e for e in truth["landmarks"]
                 if 4 * e["pixels"] >= 113 and not e["cut"]]
        three += len(whole) >= 3
    assert three >= 6, three


def test_variants_are_deterministic_and_within_their_ranges():
    from gstlandmark.synth.floors import FLOOR_NAMES
    from gstlandmark.synth.variants import RANGES, draw_variant
    floors = set()
    for n in range(1, 41):
        v = draw_variant("path", n)
        assert v == draw_variant("path", n)
        assert json.loads(json.dumps(v)) == v            # JSON as is
        cam = v["camera"]

        def within(key, value, slack=1e-4):
            lo, hi = RANGES[key]
            assert lo - slack <= value <= hi + slack, (n, key, value)
        within("height_m", cam["height_m"])
        within("hfov_deg", cam["hfov_deg"])
        within("roll_deg", cam["roll_deg"])
        within("forward_offset_m", v["forward_offset_m"])
        within("disc_d", v["markers"]["disc_d"])
        within("ball_d", v["markers"]["ball_d"])
        assert v["markers"]["ball_d"] <= 1.5 * cam["height_m"] + 1e-4
        within("gain", v["gain"])
        assert 2 ** v["effects"]["exposure_stops"] == pytest.approx(
            v["gain"], abs=1e-3)
        for g in v["white_balance"]:
            within("wb_gain", g)
        for key in ("vignette", "noise_sigma", "jpeg_quality",
                    "exposure_drift_stops", "wb_drift", "shutter",
                    "ball_shading"):
            within(key, v["effects"][key])
        assert v["effects"]["motion_blur"] in (0, 3)
        within("light_elevation_deg", v["light"]["elevation_deg"])
        assert np.linalg.norm(v["light"]["direction"]) == pytest.approx(
            1.0, abs=1e-5)
        assert v["floor"] in FLOOR_NAMES
        floors.add(v["floor"])
        within("field_m", v["layout"]["field_m"])
        # the tilt lets the camera see the floor: the centre row looks
        # down, and the image spans from under 0.5 m to past 2.5 m
        half_v = math.degrees(math.atan(
            math.tan(math.radians(cam["hfov_deg"] / 2)) * 0.75))
        tilt = cam["tilt_deg"]
        assert 0 < tilt < 60
        near = cam["height_m"] / math.tan(math.radians(tilt + half_v))
        assert near < 0.55, (n, near)
        far_angle = tilt - half_v
        assert far_angle <= 0 or \
            cam["height_m"] / math.tan(math.radians(far_angle)) > 2.5
    # 40 draws see most floors, the red and orange ones included
    assert {"red", "orange"} <= floors and len(floors) >= 6
    assert draw_variant("path", 1) != draw_variant("path", 2)
    assert draw_variant("path", 1) != draw_variant("distractors", 1)
    with pytest.raises(ValueError):
        draw_variant("path", -1)


def test_variant_changes_the_scene_and_is_recorded(tmp_path):
    from gstlandmark.synth import build_scenario
    from gstlandmark.synth.variants import draw_variant
    v = draw_variant("distractors", 4)
    scene, _ = build_scenario("distractors", frames=2, variant=v)
    assert scene.camera.height_m == v["camera"]["height_m"]
    assert scene.camera.tilt_deg == v["camera"]["tilt_deg"]
    assert scene.floor_names() == [v["floor"]]
    assert scene.effects.jpeg_quality == v["effects"]["jpeg_quality"]
    assert tuple(scene.light) == tuple(v["light"]["direction"])
    assert {lm.diameter for lm in scene.landmarks} == set(
        v["markers"].values())
    # and it is not the default scene
    default, _ = build_scenario("distractors", frames=2)
    assert default.camera.height_m != scene.camera.height_m
    assert default.floor_names() != scene.floor_names()
    # overrides still win over the variant
    scene, _ = build_scenario("distractors", frames=2, variant=v,
                              height_m=0.33)
    assert scene.camera.height_m == 0.33
    # the CLI writes it, with a camera file, a chart and a palette that
    # the documented learning reads
    out = tmp_path / "v"
    assert cli.main(["synth", "path", "--variant", "6", "--frames", "2",
                     "--size", "160x120", "--out", str(out),
                     "--no-progress"]) == 0
    scene = json.loads((out / "scene.json").read_text())
    assert scene["notes"]["variant"] == json.loads(json.dumps(
        draw_variant("path", 6)))
    assert scene["camera"]["height_m"] == \
        scene["notes"]["variant"]["camera"]["height_m"]
    # the camera file's focal length is the pinhole one of the variant's
    # field of view over the 160 px width
    from gstlandmark.commands.calibrate import read_camera_file
    cam = read_camera_file(str(out / "camera.yml"))
    hfov = math.radians(draw_variant("path", 6)["camera"]["hfov_deg"])
    assert cam["camera_matrix"][0, 0] == pytest.approx(
        80 / math.tan(hfov / 2), rel=1e-6)
    # the rendered floor (the bottom rows, which a 20-40 degree tilt puts
    # on the floor) has the hue of the variant's floor: of the plain
    # floors' nominal colours its a*b* is nearest (exposure and gain move
    # L*, not the hue)
    from gstlandmark.synth.floors import FLOORS
    frame = cv2.imread(str(out / "frame0.png"))
    seen = np.median(reference.rgb_to_lab(np.ascontiguousarray(
        frame[-12:, :, ::-1])).reshape(-1, 3), axis=0)[1:]
    hue_gap = {name: np.linalg.norm(reference.rgb_to_lab(
        np.array([[rgb]], np.uint8))[0, 0, 1:] - seen)
        for name, (_, rgb) in FLOORS.items() if rgb is not None}
    assert min(hue_gap, key=hue_gap.get) == \
        draw_variant("path", 6)["floor"], hue_gap
    # the palette learned from the chart gives each class the hue of the
    # scene's class of that name: nearest in a*b* to it of all classes
    names = [c["name"] for c in scene["palette"]["classes"]]
    markers = [c["name"] for c in scene["palette"]["classes"]
               if c["marker"]]
    assert cli.main(["palette", "learn", str(out / "chart.png"), "--mask",
                     str(out / "chart-mask.png"), "--names",
                     ",".join(names), "--markers", ",".join(markers),
                     "-o", str(tmp_path / "learned.json")]) == 0
    nominal = {c["name"]: np.array(c["lab"][1:])
               for c in scene["palette"]["classes"]}
    learned = load_palette(str(tmp_path / "learned.json"))
    assert learned.names == names
    for cls in learned.classes:
        gaps = {n: np.linalg.norm(np.array(cls.lab[1:]) - ab)
                for n, ab in nominal.items()}
        assert min(gaps, key=gaps.get) == cls.name, (cls.name, gaps)


@pytest.mark.parametrize("name", ["range-sweep", "path", "distractors"])
def test_every_variant_has_a_chart_the_palette_learns_from(name):
    """Red and orange floors, cameras low and high: the chart shows every
    class of the scene palette and the documented learning reads it."""
    from gstlandmark.synth import build_scenario
    from gstlandmark.synth.chart import render_chart
    from gstlandmark.synth.variants import draw_variant
    for n in range(1, 9):
        scene, frames = build_scenario(name, frames=40,
                                       variant=draw_variant(name, n))
        rgb, mask, info = render_chart(scene, frames)
        assert min(info["pixels"].values()) >= 200, (n, info["pixels"])
        palette = scene.scene_palette()
        learned = learn_from_mask(rgb[:, :, ::-1].copy(), mask,
                                  names=palette.names,
                                  markers=palette.markers)
        assert learned.names == palette.names


def test_obstacles_and_walls_are_not_the_floors_colour():
    """100 variants of the walled field with 15 boxes: every box and the
    walls keep CIE76 Delta E >= 25 from every texel colour of the floor
    and from the floor class (the texture's mean), as docs/synth.md
    says; the test converts the colours to L*a*b* itself."""
    from gstlandmark.synth import scenarios
    from gstlandmark.synth.variants import draw_variant

    def lab(srgb8):
        rgb = np.asarray(srgb8, np.float32).reshape(-1, 1, 3) / 255
        return cv2.cvtColor(rgb, cv2.COLOR_RGB2Lab).reshape(-1, 3) \
            .astype(np.float64)

    assert scenarios.OBSTACLE_MIN_DELTA_E == 25.0
    floors, repainted, closest = set(), 0, math.inf
    for v in range(100):
        scene, _ = scenarios.build_scenario(
            "path", seed=v, frames=2, size=(64, 48),
            variant=draw_variant("path", v), obstacles=15)
        tex = scene.floor_texture(scene.floor)
        floor_lab = np.concatenate([
            lab(np.unique(tex.srgb8.reshape(-1, 3), axis=0)),
            np.asarray(scene.scene_palette().classes[
                scene.scene_palette().index("floor")].lab).reshape(1, 3)])
        colours = [ob.colour for ob in scene.obstacles] + [scene.walls.colour]
        for c in colours:
            de = np.min(np.linalg.norm(floor_lab - lab(c), axis=1))
            assert de >= 25.0, (v, scene.floor, c, de)
            closest = min(closest, de)
        assert len(scene.obstacles) >= 5
        floors.add(scene.floor)
        repainted += scene.walls.colour != (192, 186, 172)
    # every texture drawn, the walls repainted where they were the floor's
    assert floors == {"grey", "white", "dark", "wood", "carpet", "tiles",
                      "red", "orange"}
    assert 0 < repainted < 100
    assert closest < 30      # the rule binds: some colours come close
