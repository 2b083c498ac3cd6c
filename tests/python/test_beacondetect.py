"""beacondetect against rendered truth (docs/beacondetect.md): coded beacons
straight ahead of the seed robot's camera, a field of every 2-band code of
the five marker colours, a code the map lacks, a map without coded
markers."""

import json
import math

import cv2
import numpy as np
import pytest
from gi.repository import Gst

from gstlandmark import pipeline
from gstlandmark.synth import Camera, Effects, Landmark, Pose, Scene, \
    render_frame
from gstlandmark.synth.world import palette_json

SEED_CAMERA = dict(hfov_deg=54, height_m=0.2, tilt_deg=18)


def run(scene, pose, tmp_path, map_landmarks=None, extra="", after=""):
    """Renders one frame and runs labsegment (the scene's palette) and
    beacondetect (the map of map_landmarks, else the scene's) on it, then
    the chain ``after`` (MAP: that map file)."""
    rgb, truth, _ = render_frame(scene, pose, frame=0)
    pal = tmp_path / "palette.json"
    pal.write_text(json.dumps(palette_json(scene.scene_palette())))
    map_file = tmp_path / "map.json"
    doc = scene.map_json() if map_landmarks is None else Scene(
        landmarks=map_landmarks).map_json()
    map_file.write_text(json.dumps(doc))
    (res,) = pipeline.frames_through(
        f"labsegment palette={pal} ! beacondetect map={map_file} {extra}"
        + (" ! " + after.replace("MAP", str(map_file)) if after else ""),
        [cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)])
    return res.detections, truth


def centre_in(det, box, margin=1.0):
    x, y, w, h = det.bbox
    u, v = x + (w - 1) / 2, y + (h - 1) / 2
    return (box[0] - margin <= u <= box[2] + margin and
            box[1] - margin <= v <= box[3] + margin)


@pytest.mark.parametrize("rng_m", [0.8, 1.2, 2.0])
def test_beacon_straight_ahead(rng_m, tmp_path):
    """Named by its code, its floor contact point (the bottom of the lowest
    band on the axis) within 1.5 px of the projection of the base's nearest
    point, its height within 2 px of the truth box's (measured on random
    variants: 0.43 px and 0.9 px median, docs/beacondetect.md)."""
    lm = Landmark("B1", "pink/yellow", rng_m, 0.0, 0.10, kind="beacon",
                  height=0.16)
    other = Landmark("B2", "yellow/pink", rng_m, 1.0, 0.10, kind="beacon",
                     height=0.16)
    scene = Scene(camera=Camera(640, 480, **SEED_CAMERA),
                  landmarks=[lm, other],
                  effects=Effects(noise_sigma=1.0, ball_shading=0.3))
    dets, truth = run(scene, Pose(0.0, 0.0, 0.0), tmp_path)
    (mark,) = [m for m in truth["landmarks"] if m["id"] == "B1"]
    (det,) = [d for d in dets if centre_in(d, mark["box"])]
    b = det.blob
    assert det.class_name == "pink/yellow" and b["code"] == "pink/yellow"
    assert b["kind"] == "beacon" and b["kept"] is True
    assert b["bands"] == "pink/yellow"
    assert math.hypot(b["axis-base-x"] - mark["u_front"],
                      b["axis-base-y"] - mark["v_front"]) < 1.5, (b, mark)
    box_h = mark["box"][3] - mark["box"][1]
    assert abs(b["height-px"] - box_h) < 2.0, (b["height-px"], box_h)
    assert abs(b["axis-angle"]) < math.radians(3)
    # straight ahead: the axis's foot on the image's middle column
    assert abs(b["axis-base-x"] - 319.5) < 1.0


@pytest.mark.parametrize("part", [0, 1, 2])
def test_every_code_in_a_row_is_named(part, tmp_path):
    """Every ordered pair of the five colours, seven beacons a frame in a
    row across the view at 1.0 and 1.5 m; the map holds all 20 codes.
    Each one in full view and >= 20 px tall is named by its code, and no
    detection carries a code where no beacon of that code is."""
    colours = ("red", "green", "yellow", "pink", "blue")
    codes = [f"{a}/{b}" for a in colours for b in colours if a != b]
    beacons = []
    for k, code in enumerate(codes):
        a = 0.33 - 0.11 * (k % 7) if k // 7 == part else 3.0 + 0.1 * k
        r = 1.0 + 0.5 * (k % 2)
        beacons.append(Landmark(f"B{k + 1}", code, r * math.cos(a),
                                r * math.sin(a), 0.08, kind="beacon",
                                height=0.18))
    scene = Scene(camera=Camera(640, 480, **SEED_CAMERA), landmarks=beacons,
                  effects=Effects(noise_sigma=1.5, ball_shading=0.3))
    dets, truth = run(scene, Pose(0.0, 0.0, 0.0), tmp_path)
    marks = [m for m in truth["landmarks"] if m.get("code")]
    eligible = [m for m in marks if not m["cut"] and
                m["occluded_fraction"] < 0.05 and
                m["box"][3] - m["box"][1] >= 20]
    assert len(eligible) >= 6, len(eligible)
    kept = [d for d in dets if d.blob.get("kept")]
    for m in eligible:
        assert any(d.class_name == m["code"] and centre_in(d, m["box"])
                   for d in kept), (m["code"], m["box"])
    for d in kept:
        assert any(m["code"] == d.class_name and centre_in(d, m["box"])
                   for m in marks), (d.class_name, d.bbox)


def test_a_code_the_map_lacks_is_not_named(tmp_path):
    """yellow/pink in view, the map holds pink/yellow only: no kept
    detection; with keep-rejected the chain is attached as reading no
    code."""
    seen = Landmark("B2", "yellow/pink", 1.2, 0.0, 0.1, kind="beacon",
                    height=0.16)
    mapped = Landmark("B1", "pink/yellow", 3.0, 2.0, 0.1, kind="beacon",
                      height=0.16)
    scene = Scene(camera=Camera(640, 480, **SEED_CAMERA), landmarks=[seen],
                  effects=Effects(noise_sigma=1.0))
    dets, _ = run(scene, Pose(0.0, 0.0, 0.0), tmp_path, [mapped])
    assert [d for d in dets if d.blob.get("kept")] == []
    dets, _ = run(scene, Pose(0.0, 0.0, 0.0), tmp_path, [mapped],
                  "keep-rejected=true")
    assert any(d.class_name == "yellow/pink" and
               d.blob["reject-reason"] == "code" for d in dets), dets


def test_a_cut_beacon_is_a_candidate(tmp_path):
    """So close that the frame's top row cuts it below its top band: the
    lower band alone is kept as a candidate naming the code it may be.
    Both bands in view, the top one cut, and the map holding a longer code
    that goes on above: a candidate of both codes."""
    lm = Landmark("B1", "pink/yellow", 0.45, 0.0, 0.1, kind="beacon",
                  height=0.4, band_heights=(0.1, 0.3))
    scene = Scene(camera=Camera(640, 480, **SEED_CAMERA), landmarks=[lm],
                  effects=Effects(noise_sigma=1.0))
    log = tmp_path / "log.jsonl"
    dets, truth = run(scene, Pose(0.0, 0.0, 0.0), tmp_path,
                      after=f"landmarklog location={log}")
    assert truth["landmarks"][0]["cut"]
    assert truth["landmarks"][0]["bands"][0]["box"] is None
    (line,) = [json.loads(x) for x in log.read_text().splitlines()
               if '"detections"' in x]
    (logged,) = line["detections"]
    assert (logged["accepted"], logged["rejected-by"],
            logged["reject-reason"]) == (False, "beacondetect", "partial")
    (det,) = dets
    assert det.class_name == "yellow"
    assert det.blob["kept"] is False
    assert det.blob["reject-reason"] == "partial"
    assert det.blob["candidate-codes"] == ["pink/yellow"]
    assert det.rejected() == ("beacondetect", "partial")

    lm = Landmark("B1", "pink/yellow", 0.45, 0.0, 0.1, kind="beacon",
                  height=0.3)
    longer = Landmark("B2", "blue/pink/yellow", 3.0, 3.0, 0.1,
                      kind="beacon", height=0.3)
    scene = Scene(camera=Camera(640, 480, **SEED_CAMERA), landmarks=[lm],
                  effects=Effects(noise_sigma=1.0))
    dets, truth = run(scene, Pose(0.0, 0.0, 0.0), tmp_path, [lm, longer])
    assert truth["landmarks"][0]["bands"][0]["box"][1] < 0
    (det,) = dets
    assert det.class_name == "pink/yellow" and "code" not in det.blob
    assert det.blob["reject-reason"] == "partial"
    assert sorted(det.blob["candidate-codes"]) == ["blue/pink/yellow",
                                                   "pink/yellow"]
    # without the longer code in the map, the cut beacon is named
    dets, _ = run(scene, Pose(0.0, 0.0, 0.0), tmp_path, [lm])
    (det,) = dets
    assert det.blob["code"] == "pink/yellow" and det.blob["kept"] is True


def test_no_coded_marker_in_the_map_attaches_nothing(tmp_path):
    beacon = Landmark("B1", "pink/yellow", 1.2, 0.0, 0.1, kind="beacon",
                      height=0.16)
    disc = Landmark("L1", "pink", 1.0, 0.5, 0.1)
    scene = Scene(camera=Camera(640, 480, **SEED_CAMERA), landmarks=[beacon],
                  effects=Effects(noise_sigma=1.0))
    dets, _ = run(scene, Pose(0.0, 0.0, 0.0), tmp_path, [disc])
    assert dets == []


def camera_props(cam):
    return (f"camera-height={cam.height_m} tilt={cam.tilt_deg} "
            f"hfov={cam.hfov_deg}")


@pytest.mark.parametrize("method", ["ground", "size", "fused"])
def test_beacons_ranged_from_floor_contact_and_height(method, tmp_path):
    """ipmrange after beacondetect ranges each named beacon from its floor
    contact point (ground), its height seen and the map's (size), or both;
    against the rendered truth of the axis, within 3 % (about 3x the
    medians measured on held-out variants: 0.3 %, 1.0 %, 0.3 %), the
    bearing within 0.3 degrees, and the sigma is not below a third of the
    error."""
    cam = Camera(640, 480, **SEED_CAMERA)
    beacons = [Landmark("B1", "pink/yellow", 1.0, 0.0, 0.1, kind="beacon",
                        height=0.2),
               Landmark("B2", "blue/red", 1.6, 0.45, 0.1, kind="beacon",
                        height=0.2, band_heights=(0.08, 0.12)),
               Landmark("C1", "yellow/blue", 2.2, -0.6, 0.2, kind="cone",
                        height=0.3)]
    scene = Scene(camera=cam, landmarks=beacons,
                  effects=Effects(noise_sigma=1.0, ball_shading=0.3))
    dets, truth = run(scene, Pose(0.0, 0.0, 0.0), tmp_path, after=(
        f"ipmrange {camera_props(cam)} map=MAP range-method={method}"))
    marks = {m["code"]: m for m in truth["landmarks"]}
    named = [d for d in dets if d.blob.get("kept")]
    assert sorted(d.class_name for d in named) == sorted(marks)
    for d in named:
        m, r = marks[d.class_name], d.range
        assert r["method"] == method and r["kept"] is True
        err = r["range"] - m["range"]
        assert abs(err) < 0.03 * m["range"], (d.class_name, r, m["range"])
        assert abs(r["range-sigma"]) * 3 > abs(err), (d.class_name, r)
        assert abs(math.degrees(r["bearing"] - m["bearing"])) < 0.3
        assert r["marker-kind"] == m["kind"]
        assert r["range-ground"] > 0 and "range-size" in r


def test_a_code_the_ipmrange_map_lacks_is_ranged_on_the_floor(tmp_path):
    """Without the marker's size (ipmrange given no map) the range is that
    of its base's nearest point: a radius short, no size range."""
    cam = Camera(640, 480, **SEED_CAMERA)
    lm = Landmark("B1", "pink/yellow", 1.2, 0.0, 0.1, kind="beacon",
                  height=0.2)
    scene = Scene(camera=cam, landmarks=[lm], effects=Effects(noise_sigma=1))
    dets, truth = run(scene, Pose(0.0, 0.0, 0.0), tmp_path,
                      after=f"ipmrange {camera_props(cam)}")
    (det,) = dets
    r = det.range
    assert "range-size" not in r and "marker-kind" not in r
    assert abs(r["range"] - (1.2 - 0.05)) < 0.02, r


def test_pose_from_beacons_alone_and_a_mixed_map(tmp_path):
    """trilaterate names each beacon by its code from one view and solves
    the pose from them alone (measured on held-out variants: median 0.3
    cm, docs/beacons.md); with a disc in the map and in view too, the disc
    is matched by its class and a one-band pink post never takes the pink
    disc's detection."""
    cam = Camera(640, 480, **SEED_CAMERA)
    pose = Pose(0.3, -0.2, 0.25)

    def ahead(r, a):
        return (pose.x + r * math.cos(pose.heading + a),
                pose.y + r * math.sin(pose.heading + a))
    beacons = [Landmark("B1", "pink/yellow", *ahead(1.0, 0.3), 0.1,
                        kind="beacon", height=0.2),
               Landmark("B2", "blue/red", *ahead(1.5, 0.0), 0.1,
                        kind="beacon", height=0.2),
               Landmark("B3", "yellow/green", *ahead(1.2, -0.3), 0.1,
                        kind="beacon", height=0.2)]
    disc = Landmark("L1", "pink", *ahead(0.9, -0.05), 0.1)
    post = Landmark("P1", "pink", 5.0, 5.0, 0.04, kind="post", height=0.3)
    after = f"ipmrange {camera_props(cam)} map=MAP ! trilaterate map=MAP"

    def solve(seen, mapped, name):
        scene = Scene(camera=cam, landmarks=seen,
                      effects=Effects(noise_sigma=1.0, ball_shading=0.3))
        rgb, _, _ = render_frame(scene, pose, frame=0)
        pal = tmp_path / "palette.json"
        pal.write_text(json.dumps(palette_json(scene.scene_palette())))
        map_file = tmp_path / name
        map_file.write_text(json.dumps(Scene(landmarks=mapped).map_json()))
        (res,) = pipeline.frames_through(
            f"labsegment palette={pal} ! blobroundness ! beacondetect "
            f"map={map_file} ! " + after.replace("MAP", str(map_file)),
            [cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)])
        assert res.pose is not None
        err = math.hypot(res.pose.x - pose.x, res.pose.y - pose.y)
        assert err < 0.02, (res.pose.fields, pose)
        assert abs(res.pose.heading - pose.heading) < math.radians(1)
        return {d.class_name: (d.match.get("landmark-id"),
                               d.match.get("matched-by"))
                for d in res.detections if d.match.get("matched")}

    assert solve(beacons, beacons, "beacons.json") == {
        "pink/yellow": ("B1", "pose"), "blue/red": ("B2", "pose"),
        "yellow/green": ("B3", "pose")}
    got = solve(beacons + [disc], beacons + [disc, post], "mixed.json")
    assert {k: v[0] for k, v in got.items()} == {
        "pink/yellow": "B1", "blue/red": "B2", "yellow/green": "B3",
        "pink": "L1"}, got


def test_overlay_draws_the_box_and_the_log_writes_the_code(tmp_path):
    """landmarkoverlay draws a named beacon as the box of its bands (its
    corners, which an ellipse in that box would miss, are drawn on) labelled
    with its code; landmarklog writes `code`, `kind` and the axis."""
    cam = Camera(640, 480, **SEED_CAMERA)
    lm = Landmark("B1", "pink/yellow", 1.0, 0.0, 0.1, kind="beacon",
                  height=0.2)
    scene = Scene(camera=cam, landmarks=[lm], effects=Effects(noise_sigma=0))
    rgb, _, _ = render_frame(scene, Pose(0.0, 0.0, 0.0), frame=0)
    bgr = cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)
    pal = tmp_path / "palette.json"
    pal.write_text(json.dumps(palette_json(scene.scene_palette())))
    map_file = tmp_path / "map.json"
    map_file.write_text(json.dumps(scene.map_json()))
    log = tmp_path / "log.jsonl"
    (res,) = pipeline.frames_through(
        f"labsegment palette={pal} ! beacondetect map={map_file} ! "
        f"landmarklog location={log} ! landmarkoverlay show-pose=false "
        f"show-histogram=false show-indicators=false show-minimap=false ! "
        f"videoconvert ! video/x-raw,format=BGR", [bgr])
    (det,) = res.detections
    b = det.blob
    ok, out = res.buffer.map(Gst.MapFlags.READ)
    try:
        drawn = np.frombuffer(out.data, np.uint8).reshape(480, 640, 3)
        # the box's lower corners, 1 px inside (the label goes above it)
        for du in (-1, 1):
            u = int(round(b["ellipse-x"] + du * (b["ellipse-minor"] / 2 - 1)))
            v = int(round(b["ellipse-y"] + b["ellipse-major"] / 2 - 1))
            change = np.abs(drawn[v, u].astype(int) - bgr[v, u]).max()
            assert change > 60, (u, v, drawn[v, u], bgr[v, u])
    finally:
        res.buffer.unmap(out)
    (line,) = [json.loads(x) for x in log.read_text().splitlines()
               if '"detections"' in x]
    (logged,) = line["detections"]
    assert logged["class"] == "pink/yellow"
    assert logged["blob"]["code"] == "pink/yellow"
    assert logged["blob"]["kind"] == "beacon"
    assert "axis-base-y" in logged["blob"]


def test_landmarkslam_anchors_on_coded_markers(tmp_path):
    """landmarkslam with a map of beacons alone: each is an anchor found by
    its code, the pose follows the robot within 3 cm over 8 frames driving
    ahead, and its map (write-map, as map-out) holds the beacons as the map
    gave them (kind, bands, heights), which the map reader reads again."""
    from gstlandmark.landmarkmap import read_map
    cam = Camera(640, 480, **SEED_CAMERA)
    beacons = [Landmark("B1", "pink/yellow", 1.4, 0.35, 0.1, kind="beacon",
                        height=0.2),
               Landmark("B2", "blue/red", 1.8, 0.0, 0.1, kind="beacon",
                        height=0.2),
               Landmark("B3", "yellow/green", 1.5, -0.4, 0.1, kind="beacon",
                        height=0.2, band_heights=(0.08, 0.12))]
    scene = Scene(camera=cam, landmarks=beacons,
                  effects=Effects(noise_sigma=1.0, ball_shading=0.3))
    poses = [Pose(0.02 * k, 0.0, 0.0) for k in range(8)]
    frames = [cv2.cvtColor(render_frame(scene, p, frame=k)[0],
                           cv2.COLOR_RGB2BGR) for k, p in enumerate(poses)]
    pal = tmp_path / "palette.json"
    pal.write_text(json.dumps(palette_json(scene.scene_palette())))
    map_file = tmp_path / "map.json"
    map_file.write_text(json.dumps(scene.map_json()))
    out = tmp_path / "out.json"
    pipes = []
    results = []
    for res in pipeline.frames_through(
            f"labsegment palette={pal} ! beacondetect map={map_file} ! "
            f"ipmrange {camera_props(cam)} map={map_file} ! landmarkslam "
            f"name=slam map={map_file}", frames, configure=pipes.append):
        results.append(res)
        if len(results) == len(frames):
            slam = pipes[0].get_by_name("slam")
            assert slam.emit("write-map", str(out)) is True
    for res, p in zip(results[2:], poses[2:]):
        assert res.pose is not None
        assert math.hypot(res.pose.x - p.x, res.pose.y - p.y) < 0.03, (
            res.pose.fields, p)
        ids = {d.match.get("landmark-id") for d in res.detections
               if d.match.get("matched")}
        assert ids == {"B1", "B2", "B3"}, ids
    again = {m["id"]: m for m in read_map(str(out))}
    assert again["B3"]["code"] == "yellow/green"
    assert again["B3"]["band_heights"] == pytest.approx([0.08, 0.12])
    assert again["B1"]["kind"] == "beacon"
