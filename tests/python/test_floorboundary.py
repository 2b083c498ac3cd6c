"""floorboundary through labsegment: on a ray-cast colour frame (a grey
floor, a white box standing on it and a red disc lying on it, seen by the
pinhole camera of docs/conventions.md written out here with numpy), and on
the shipped synthetic clip against its walls and true poses."""

import json
import math
import os

import numpy as np

from gstlandmark import meta, pipeline

import shippedclip

W, H = 640, 480
CAM_H, TILT, HFOV = 0.3, 25.0, 60.0
F = (W / 2) / math.tan(math.radians(HFOV / 2))
CX, CY = (W - 1) / 2, (H - 1) / 2
GREY, WHITE, RED = (0x80, 0x80, 0x80), (0xEB, 0xEB, 0xEB), (0xFF, 0x00, 0x00)

# the box's front face at x = 1.37 m, from y = -0.45 to 0.05 m (left
# positive), 0.4 m tall and 0.5 m deep; the disc (0.15 m radius) at
# (0.9, 0.45) on the floor
BOX = dict(x0=1.37, y0=-0.45, y1=0.05, top=0.4, depth=0.5)
DISC = dict(x=0.9, y=0.45, r=0.15)


def rays():
    """Robot-frame ray of every pixel centre: (H, W, 3)."""
    t = math.radians(TILT)
    u, v = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    xn, yn = (u - CX) / F, (v - CY) / F
    d = np.empty((H, W, 3))
    d[..., 0] = -math.sin(t) * yn + math.cos(t)
    d[..., 1] = -xn
    d[..., 2] = -math.cos(t) * yn - math.sin(t)
    return d


def render(noise_rng=None, box_colour=WHITE):
    """RGB frame and the label of each pixel (0 floor, 1 box, 2 disc)."""
    d = rays()
    with np.errstate(divide="ignore", invalid="ignore"):
        t_floor = np.where(d[..., 2] < 0, CAM_H / -d[..., 2], np.inf)
        t_face = np.where(d[..., 0] > 0, BOX["x0"] / d[..., 0], np.inf)
        t_top = np.where(d[..., 2] < 0, (BOX["top"] - CAM_H) / d[..., 2],
                         np.inf)
    fy, fz = t_face * d[..., 1], CAM_H + t_face * d[..., 2]
    face = ((t_face < t_floor) & (fy >= BOX["y0"]) & (fy <= BOX["y1"]) &
            (fz >= 0) & (fz <= BOX["top"]))
    tx, ty = t_top * d[..., 0], t_top * d[..., 1]
    top = ((t_top < t_floor) & (tx >= BOX["x0"]) &
           (tx <= BOX["x0"] + BOX["depth"]) & (ty >= BOX["y0"]) &
           (ty <= BOX["y1"]))
    gx, gy = t_floor * d[..., 0], t_floor * d[..., 1]
    disc = np.hypot(gx - DISC["x"], gy - DISC["y"]) <= DISC["r"]
    label = np.zeros((H, W), np.uint8)
    label[disc] = 2
    label[face | top] = 1
    rgb = np.empty((H, W, 3), np.float64)
    rgb[:] = GREY
    rgb[label == 1] = box_colour
    rgb[label == 2] = RED
    if noise_rng is not None:
        rgb += noise_rng.normal(0, 4, rgb.shape)
    return np.clip(rgb, 0, 255).astype(np.uint8), label


CHAIN = ("labsegment min-class-pixels=0 ! floorboundary floor-classes=grey "
         "camera-height=0.3 tilt=25 hfov=60 max-range=4")


def test_box_disc_and_free_floor(gst, tmp_path):
    rgb, truth = render(np.random.default_rng(3))
    log = tmp_path / "log.jsonl"
    out = pipeline.process_frames(
        f"{CHAIN} ! landmarklog location={log}", [rgb],
        f"video/x-raw,format=RGB,width={W},height={H},framerate=30/1")
    fm = meta.floor(out[0])
    assert fm is not None
    assert (fm.width, fm.height, fm.bearing_bins) == (W, H, 360)

    bearings = np.arctan2(fm.boundary_y, fm.boundary_x)
    b0 = math.atan2(BOX["y0"], BOX["x0"])
    b1 = math.atan2(BOX["y1"], BOX["x0"])
    inside = (bearings > b0 + 0.01) & (bearings < b1 - 0.01)
    assert inside.sum() > 150
    assert (fm.boundary_state[inside] == 2).all()
    # the front face's foot at each column's bearing: x0 / cos(bearing);
    # the boundary is a pixel edge, within half a pixel (0.43 % here)
    want = BOX["x0"] / np.cos(bearings[inside])
    got = np.hypot(fm.boundary_x[inside], fm.boundary_y[inside])
    rel = np.abs(got - want) / want
    print(f"box columns: {inside.sum()}, range error max {rel.max():.4%}, "
          f"median {np.median(rel):.4%}")
    assert rel.max() < 0.006

    # every bin between the box's edges reports it, at its range
    for k in range(fm.bearing_bins):
        b = fm.bin_bearing(k)
        if b0 + 0.01 < b < b1 - 0.01:
            assert fm.state_name(k) == "obstacle"
            lo = BOX["x0"] / math.cos(max(0.0, abs(b) - fm.bin_width / 2))
            hi = BOX["x0"] / math.cos(abs(b) + fm.bin_width / 2)
            assert lo * 0.994 <= fm.rop_range[k] <= hi * 1.006, k

    # the disc lies on the floor: not an obstacle, but reported
    bd = math.atan2(DISC["y"], DISC["x"])
    k = fm.bin_of(bd)
    assert fm.state_name(k) == "free" and fm.rop_range[k] == 4.0
    near_edge = math.hypot(DISC["x"], DISC["y"]) - DISC["r"]
    assert abs(fm.rop_marker_range[k] - near_edge) < 0.02
    # bins that do not see the floor, behind the robot
    assert fm.state_name(fm.bin_of(math.pi)) == "not-seen"
    assert fm.nearest_range is not None
    assert abs(fm.nearest_range - BOX["x0"]) < 0.01

    line = json.loads(log.read_text().splitlines()[0])
    floor = line["floor"]
    assert floor["bearing-bins"] == 360
    assert np.allclose(floor["range"], fm.rop_range)
    assert floor["state"] == fm.rop_state.tolist()
    assert [m is None for m in floor["marker-range"]] == \
        (fm.rop_marker_range < 0).tolist()


def test_ball_with_markers_obstacles(gst):
    """The same disc counted as an obstacle (a field of landmark balls)."""
    rgb, _ = render()
    out = pipeline.process_frames(
        CHAIN + " markers=obstacles", [rgb],
        f"video/x-raw,format=RGB,width={W},height={H},framerate=30/1")
    fm = meta.floor(out[0])
    k = fm.bin_of(math.atan2(DISC["y"], DISC["x"]))
    assert fm.state_name(k) == "obstacle"
    near_edge = math.hypot(DISC["x"], DISC["y"]) - DISC["r"]
    assert abs(fm.rop_range[k] - near_edge) < 0.02


def test_ball_ranged_by_ipmrange_stands(gst):
    """A red ball (radius 0.1 m, resting 1.1 m ahead and 0.2 m left),
    ray-cast: floorboundary alone walks over its pixels (markers=floor),
    after ipmrange (told it is a ball) the bins it covers end at its
    circle's nearest point in each bin, d - r towards its centre."""
    bx, by, br = 1.1, 0.2, 0.1
    d = rays()
    # the sphere |C + t d - P| = r, C = (0, 0, h), P = (bx, by, r)
    o = np.array([-bx, -by, CAM_H - br])
    qb = 2 * (d @ o)
    qc = o @ o - br * br
    disc = qb * qb - 4 * (d * d).sum(-1) * qc
    ball = disc >= 0
    rgb = np.empty((H, W, 3), np.uint8)
    rgb[:] = GREY
    rgb[ball] = RED
    caps = f"video/x-raw,format=RGB,width={W},height={H},framerate=30/1"
    camera = "camera-height=0.3 tilt=25 hfov=60"
    ranged = CHAIN.replace(
        "labsegment min-class-pixels=0 !",
        f"labsegment min-class-pixels=0 ! blobroundness ! ipmrange {camera} "
        f"marker-kind=ball marker-diameter={2 * br} marker-height={br} !")
    centre = math.hypot(bx, by)
    k = None
    for chain in (CHAIN, ranged):
        fm = meta.floor(pipeline.process_frames(chain, [rgb], caps)[0])
        k = fm.bin_of(math.atan2(by, bx))
        if chain == CHAIN:
            assert fm.state_name(k) == "free", fm.state_name(k)
            continue
        assert fm.state_name(k) == "obstacle"
        print(f"ball bin {k}: {fm.rop_range[k]:.4f} m, bulge "
              f"{centre - br:.4f} m")
        assert abs(fm.rop_range[k] - (centre - br)) < 0.01
        half = math.asin(br / centre)
        covered = [j for j in range(fm.bearing_bins)
                   if fm.state_name(j) == "obstacle"]
        assert covered and all(
            abs(math.remainder(fm.bin_bearing(j) - math.atan2(by, bx),
                               2 * math.pi)) < half + fm.bin_width
            for j in covered), covered
        assert len(covered) >= 2 * math.degrees(half) - 1


def test_disc_rim_walked_over_after_blobroundness(gst):
    """The disc ringed by a rim of the box's colour one pixel wide (a
    blend of disc and floor labelled neither): alone, floorboundary ends
    the columns at the rim's tips; after blobroundness it walks over every
    pixel near an accepted disc's ellipse."""
    rgb, label = render()
    disc = label == 2
    near = np.zeros_like(disc)
    for dv in (-1, 0, 1):
        for du in (-1, 0, 1):
            near |= np.roll(np.roll(disc, dv, 0), du, 1)
    rgb[near & ~disc & (label == 0)] = WHITE
    caps = f"video/x-raw,format=RGB,width={W},height={H},framerate=30/1"
    bd = math.atan2(DISC["y"], DISC["x"])
    half = math.asin(DISC["r"] / math.hypot(DISC["x"], DISC["y"]))
    ended = {}
    for chain in (CHAIN, CHAIN.replace("labsegment min-class-pixels=0 !",
                                       "labsegment min-class-pixels=0 ! "
                                       "blobroundness !")):
        fm = meta.floor(pipeline.process_frames(chain, [rgb], caps)[0])
        bearings = np.arctan2(fm.boundary_y, fm.boundary_x)
        at_disc = np.abs(bearings - bd) < half + 0.02
        ended[chain] = int((fm.boundary_state[at_disc] == 2).sum())
    print(ended)
    assert list(ended.values())[0] > 0
    assert list(ended.values())[1] == 0


CLIP_DIR = shippedclip.CLIP_DIR


def field_distance(walls, x, y, heading):
    """Distance from (x, y) along heading to the square field's walls."""
    c, s = math.cos(heading), math.sin(heading)
    ds = []
    if c > 1e-9:
        ds.append((walls["x1"] - x) / c)
    if c < -1e-9:
        ds.append((walls["x0"] - x) / c)
    if s > 1e-9:
        ds.append((walls["y1"] - y) / s)
    if s < -1e-9:
        ds.append((walls["y0"] - y) / s)
    return min(ds)


def test_rendered_walls_of_the_path_clip(gst, tmp_path):
    """The shipped synthetic clip (45 frames, 320x240, a walled 6 m field,
    discs on the floor) with its scene camera: every seen bin against the
    nearest wall over the bin's bearings from the true pose."""
    scene = shippedclip.scene()
    cam, walls = scene["camera"], scene["walls"]
    truth = shippedclip.true_poses()
    log = tmp_path / "log.jsonl"
    max_range = 4.0
    desc = (
        f"filesrc location={os.path.join(CLIP_DIR, 'clip.avi')} ! "
        "decodebin ! videoconvert ! labsegment palette="
        f"{os.path.join(CLIP_DIR, 'palette.json')} ! floorboundary "
        f"floor-classes=floor camera-height={cam['height_m']} "
        f"tilt={cam['tilt_deg']} roll={cam['roll_deg']} fx={cam['fx']} "
        f"fy={cam['fy']} cx={cam['cx']} cy={cam['cy']} "
        f"max-range={max_range} ! landmarklog location={log} ! fakesink")
    pipeline.run_to_eos(desc)
    lines = [json.loads(ln) for ln in log.read_text().splitlines()]
    assert len(lines) == 45
    errors, ok = [], 0
    for ln in lines:
        fl, robot = ln["floor"], truth[ln["frame"]]
        width = fl["bin-width"]
        for k, state in enumerate(fl["state"]):
            if state == 0:
                continue
            b = k * width
            want = min(field_distance(walls, robot["x"], robot["y"],
                                      robot["heading"] + b + o * width)
                       for o in np.linspace(-0.5, 0.5, 11))
            want = min(want, max_range)
            got = fl["range"][k]
            errors.append(abs(got - want) / want)
            ok += abs(got - want) <= max(0.03 * want, 0.03)
            # no disc on the floor is ever an obstacle: walls only
            assert state != 2 or want < max_range * 1.03, (ln["frame"], k)
    share = ok / len(errors)
    print(f"{len(errors)} seen bins: {share:.1%} within 3 % or 3 cm; "
          f"median {np.median(errors):.2%}, p95 "
          f"{np.percentile(errors, 95):.2%}")
    assert len(errors) > 3000
    assert share >= 0.95


def test_box_of_a_marker_colour(gst):
    """A red box: with markers=detections (after blobroundness) only the
    accepted disc is walked over and the box, no landmark shape, is an
    obstacle; with markers=floor the box would be walked over."""
    rgb, _ = render(box_colour=RED)
    caps = f"video/x-raw,format=RGB,width={W},height={H},framerate=30/1"
    chain = CHAIN.replace("labsegment min-class-pixels=0 !",
                          "labsegment min-class-pixels=0 ! blobroundness !")
    b0 = math.atan2(BOX["y0"], BOX["x0"])
    b1 = math.atan2(BOX["y1"], BOX["x0"])
    disc_near = math.hypot(DISC["x"], DISC["y"]) - DISC["r"]
    results = {}
    for mode in ("detections", "floor"):
        out = pipeline.process_frames(f"{chain} markers={mode}", [rgb], caps)
        fm = meta.floor(out[0])
        inside = [k for k in range(fm.bearing_bins)
                  if b0 + 0.01 < fm.bin_bearing(k) < b1 - 0.01]
        results[mode] = [fm.state_name(k) for k in inside]
        if mode == "detections":
            for k in inside:
                b = abs(fm.bin_bearing(k))
                lo = BOX["x0"] / math.cos(max(0.0, b - fm.bin_width / 2))
                hi = BOX["x0"] / math.cos(b + fm.bin_width / 2)
                assert lo * 0.994 <= fm.rop_range[k] <= hi * 1.006, k
            k = fm.bin_of(math.atan2(DISC["y"], DISC["x"]))
            assert fm.state_name(k) == "free"
            assert abs(fm.rop_marker_range[k] - disc_near) < 0.02
    assert set(results["detections"]) == {"obstacle"}
    assert "obstacle" not in results["floor"]


def test_free_ranges_exact_over_each_bin():
    """The synthetic truth's free range per bin is the nearest point of the
    walls and boxes inside the bin's wedge: against 201 rays per bin."""
    from gstlandmark.synth.freespace import free_ranges, rectangle_edges
    walls = np.array([[[0, 0], [6, 0]], [[6, 0], [6, 6]], [[6, 6], [0, 6]],
                      [[0, 6], [0, 0]]], float)
    segs = np.concatenate([walls, rectangle_edges(3.5, 3.2, 0.4, 0.6, 0.3)])
    x, y, heading = 2.0, 2.5, 0.4
    got = free_ranges(x, y, heading, segs, 360)

    def ray(b):
        dx, dy = math.cos(heading + b), math.sin(heading + b)
        best = math.inf
        for (ax, ay), (bx, by) in segs:
            ex, ey = bx - ax, by - ay
            den = dx * ey - dy * ex
            if abs(den) < 1e-12:
                continue
            t = ((ax - x) * ey - (ay - y) * ex) / den
            u = ((ax - x) * dy - (ay - y) * dx) / den
            if t > 0 and 0 <= u <= 1:
                best = min(best, t)
        return best

    width = 2 * math.pi / 360
    for k in range(0, 360, 7):
        sampled = min(ray(k * width + o * width)
                      for o in np.linspace(-0.5, 0.5, 201))
        assert got[k] <= sampled + 1e-9
        assert sampled - got[k] <= 1e-4 * sampled


def test_synthetic_boxes_against_the_truth(gst, tmp_path):
    """The seed robot's walled field with 10 random boxes (gst-landmark
    synth path --obstacles 10): every bin floorboundary sees against the
    truth's free range; no landmark disc reported as an obstacle."""
    from gstlandmark.commands import evaluate
    from gstlandmark.synth import render_scenario
    out = tmp_path / "clip"
    render_scenario("path", str(out), seed=1, frames=12, size=(320, 240),
                    obstacles=10, progress=False)
    with open(out / "scene.json") as f:
        scene = json.load(f)
    assert len(scene["obstacles"]) == 10
    log = tmp_path / "log.jsonl"
    pipeline.run_to_eos(
        f"filesrc location={out / 'clip.avi'} ! decodebin ! videoconvert ! "
        f"labsegment palette={out / 'palette.json'} ! floorboundary "
        f"floor-classes=floor calibration={out / 'camera.yml'} "
        f"max-range=4 ! landmarklog location={log} ! fakesink")
    results = [json.loads(ln) for ln in log.read_text().splitlines()]
    truth = [json.loads(ln) for ln in
             (out / "truth.jsonl").read_text().splitlines()]
    assert all(len(t["floor"]["free-range"]) == 360 for t in truth)
    s = evaluate.summary(evaluate.evaluate(results, truth))["floor"]
    print(s)
    assert s["bins"] > 300
    assert s["within_3pct_or_3cm"] >= 0.95
    assert s["false_obstacles"] == 0


def test_palette_roles_name_the_floor(gst, tmp_path):
    """floor-classes unset: the palette's floor classes are the floor, so
    a background class (the white box) ends it; a palette without roles
    makes every non-marker class floor and walks over the box."""
    rgb, _ = render(np.random.default_rng(3))
    caps = f"video/x-raw,format=RGB,width={W},height={H},framerate=30/1"
    lab = {"grey": [53.59, 0, 0], "white": [93.1, 0, 0],
           "red": [53.24, 80.09, 67.2]}
    bearing = math.atan2((BOX["y0"] + BOX["y1"]) / 2, BOX["x0"])
    ranges = {}
    for form, roles in (("roles", {"grey": "floor", "white": "background",
                                   "red": "marker"}),
                        ("flags", {"grey": False, "white": False,
                                   "red": True})):
        key = "role" if form == "roles" else "marker"
        palette = tmp_path / f"{form}.json"
        palette.write_text(json.dumps({"classes": [
            {"name": n, "lab": lab[n], key: roles[n]} for n in lab]}))
        out = pipeline.process_frames(
            f"labsegment palette={palette} min-class-pixels=0 ! "
            "floorboundary camera-height=0.3 tilt=25 hfov=60 max-range=4",
            [rgb], caps)
        labels = meta.labels(out[0])
        assert [c.role for c in labels.classes] == (
            ["floor", "background", "marker"] if form == "roles"
            else ["background", "background", "marker"])
        fm = meta.floor(out[0])
        k = fm.bin_of(bearing)
        ranges[form] = (fm.state_name(k), float(fm.rop_range[k]))
    state, rng = ranges["roles"]
    assert state == "obstacle" and abs(rng - BOX["x0"] / math.cos(bearing)) \
        < 0.01 * BOX["x0"], ranges
    # without roles the white box is floor: the walk goes past its face
    assert ranges["flags"][1] > BOX["x0"] + 0.1, ranges


def test_camera_info_file_as_the_properties(gst, tmp_path):
    """calibration= a ROS camera_info file (docs/calibration.md) holding
    the camera of the properties: the same floor, bin for bin."""
    info = tmp_path / "camera_info.yaml"
    info.write_text(
        f"image_width: {W}\nimage_height: {H}\ncamera_name: front\n"
        f"camera_matrix:\n  rows: 3\n  cols: 3\n"
        f"  data: [{F!r}, 0, {CX!r}, 0, {F!r}, {CY!r}, 0, 0, 1]\n"
        f"distortion_model: plumb_bob\ndistortion_coefficients:\n"
        f"  rows: 1\n  cols: 5\n  data: [0, 0, 0, 0, 0]\n"
        f"camera_height: {CAM_H}\ntilt_deg: {TILT}\n")
    rgb, _ = render(np.random.default_rng(3))
    caps = f"video/x-raw,format=RGB,width={W},height={H},framerate=30/1"
    floors = []
    for camera in ("camera-height=0.3 tilt=25 hfov=60",
                   f"calibration={info} camera-height=1 tilt=10"):
        out = pipeline.process_frames(
            f"labsegment min-class-pixels=0 ! floorboundary "
            f"floor-classes=grey {camera} max-range=4", [rgb], caps)
        floors.append(meta.floor(out[0]))
    a, b = floors
    assert (a.boundary_state == b.boundary_state).all()
    for key in ("boundary_x", "boundary_y", "rop_range"):
        np.testing.assert_allclose(getattr(b, key), getattr(a, key),
                                   rtol=0, atol=1e-9)
    assert (a.boundary_state == 2).sum() > 150
