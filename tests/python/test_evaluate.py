"""gst-landmark evaluate against hand-made truth with known answers."""

import json
import math

import numpy as np
import pytest

from gstlandmark.commands import cli, evaluate as E


def mark(cls, u, v, rng, bearing=0.0, pixels=100, id_="L"):
    return {"id": id_, "class": cls, "u": u, "v": v, "pixels": pixels,
            "range": rng, "bearing": bearing}


def det(cls, u, v, rng=None, bearing=None, kept=True):
    d = {"id": 0, "class": cls, "bbox": [int(u) - 5, int(v) - 5, 11, 11],
         "blob": {"centroid-x": u, "centroid-y": v, "kept": kept}}
    if rng is not None:
        d["range"] = {"range": rng, "bearing": bearing}
    return d


TRUTH = [
    {"frame": 0, "robot": {"x": 0.0, "y": 0.0, "heading": 0.0},
     "landmarks": [mark("red", 100, 100, 1.0, 0.1),
                   mark("blue", 200, 100, 2.5, -0.2),
                   mark("red", 300, 50, 4.5, 0.0, pixels=5)]},   # too small
    {"frame": 1, "robot": {"x": 1.0, "y": 2.0, "heading": 3.0},
     "landmarks": [mark("red", 110, 100, 1.2, 0.0)]},
]
RESULTS = [
    {"frame": 0, "detections": [
        det("red", 101, 100.5, 1.02, 0.1 + math.radians(0.5)),  # match
        det("blue", 200, 108, 2.5, -0.2),     # 8 px away: no match -> FP
        det("red", 300, 50, 4.4, 0.0),        # finds a too-small landmark
        det("green", 10, 10, kept=False)]},   # rejected: ignored
    {"frame": 1, "detections": [det("red", 110, 102, 1.14, 0.0)],
     "pose": {"x": 1.03, "y": 1.96, "heading": 3.0 + math.radians(2),
              "solver": "nls"}},
]


def test_counts_precision_recall():
    ev = E.evaluate(RESULTS, TRUTH, match_px=4.0, min_pixels=20)
    assert (ev.by_class["red"].tp, ev.by_class["red"].fp,
            ev.by_class["red"].fn) == (2, 0, 0)
    assert (ev.by_class["blue"].tp, ev.by_class["blue"].fp,
            ev.by_class["blue"].fn) == (0, 1, 1)
    assert "green" not in ev.by_class
    s = E.summary(ev)
    assert s["detection"]["all"]["precision"] == pytest.approx(2 / 3)
    assert s["detection"]["all"]["recall"] == pytest.approx(2 / 3)
    assert s["detection"]["by_band"]["1-2 m"]["tp"] == 2
    assert s["detection"]["by_band"]["2-3 m"]["fn"] == 1


def test_range_bearing_and_pose_errors():
    s = E.summary(E.evaluate(RESULTS, TRUTH))
    r = s["range"]["1-2 m"]
    assert r["range_m"]["n"] == 2
    assert r["range_m"]["median"] == pytest.approx((0.02 + 0.06) / 2)
    assert r["range_m"]["max"] == pytest.approx(0.06)
    assert r["range_rel"]["max"] == pytest.approx(0.05)
    assert r["bearing_deg"]["max"] == pytest.approx(0.5)
    pose = s["pose"]
    assert pose["frames_with_pose"] == 1
    assert pose["all"]["position_m"]["median"] == pytest.approx(0.05)
    assert pose["nls"]["heading_deg"]["max"] == pytest.approx(2.0)


def test_cut_landmarks_are_required_only_on_request():
    truth = [{"frame": 0, "landmarks": [
        dict(mark("red", 10, 10, 1.0), cut=True),
        dict(mark("blue", 50, 50, 1.0), cut=True)]}]
    res = [{"frame": 0, "detections": [det("red", 10, 10)]}]
    ev = E.evaluate(res, truth)
    # neither required nor held against the detection that finds one
    assert ev.by_class == {}
    ev = E.evaluate(res, truth, require_cut=True)
    assert ev.by_class["red"].tp == 1 and ev.by_class["blue"].fn == 1


def test_heading_error_wraps():
    truth = [{"frame": 0, "robot": {"x": 0, "y": 0, "heading": math.pi - 0.01},
              "landmarks": []}]
    res = [{"frame": 0, "detections": [],
            "pose": {"x": 0, "y": 0, "heading": -math.pi + 0.01}}]
    s = E.summary(E.evaluate(res, truth))
    assert s["pose"]["all"]["heading_deg"]["max"] == pytest.approx(
        math.degrees(0.02))


def test_cli_prints_and_writes_json(tmp_path, capsys):
    r, t = tmp_path / "r.jsonl", tmp_path / "t.jsonl"
    r.write_text("".join(json.dumps(x) + "\n" for x in RESULTS))
    t.write_text("".join(json.dumps(x) + "\n" for x in TRUTH))
    out = tmp_path / "eval.json"
    assert cli.main(["evaluate", str(r), str(t), "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "red" in text and "precision" in text and "pose: 1 of 2" in text
    assert json.loads(out.read_text())["frames"] == 2
    assert cli.main(["evaluate", str(tmp_path / "none"), str(t)]) == 2


# -- which detections count ---------------------------------------------------

@pytest.mark.parametrize("detection, counts", [
    # today's chain: blobroundness's kept decides
    ({"blob": {"kept": True}}, True),
    ({"blob": {"kept": False}}, False),
    ({}, True),
    # the chain's own decision wins over the blob's when present
    ({"accepted": True, "blob": {"kept": False}}, True),
    ({"accepted": False, "blob": {"kept": True}}, False),
    ({"accepted": None}, False),
    # a later element's rejection
    ({"blob": {"kept": True}, "range": {"range": 1.0, "kept": False}},
     False),
    ({"blob": {"kept": True}, "range": {"range": 1.0, "kept": True}}, True),
    ({"blob": {"kept": True}, "range": {"range": 1.0}}, True),
    ({"accepted": True, "match": {"matched": False, "reason": "outlier"}},
     False),
    ({"blob": {"kept": True},
      "match": {"matched": False, "reason": "outside-gate"}}, False),
    ({"blob": {"kept": True},
      "match": {"matched": False, "reason": "no-landmark-of-class"}},
     True),
    ({"blob": {"kept": True}, "match": {"matched": True,
                                        "landmark-id": "L1"}}, True),
])
def test_detection_accepted(detection, counts):
    assert E.detection_accepted(detection) is counts


def test_evaluate_counts_only_accepted_detections():
    truth = [{"frame": 0, "landmarks": [mark("red", 100, 100, 1.0)]}]
    found = det("red", 100, 100)
    vetoed = dict(det("red", 100, 100), accepted=False)
    outlier = dict(det("red", 100, 100),
                   match={"matched": False, "reason": "outlier"})
    for dets, tp, fn in (([found], 1, 0), ([vetoed], 0, 1),
                         ([outlier], 0, 1), ([vetoed, found], 1, 0)):
        s = E.summary(E.evaluate([{"frame": 0, "detections": dets}],
                                 truth))["detection"]["all"]
        assert (s["tp"], s["fp"], s["fn"]) == (tp, 0, fn), dets


def test_a_ball_found_by_its_rim_is_where_its_circle_is():
    """A blob accepted as part of a ball (shape-evidence arc) is placed at
    the ball's circle, as ranging places it, not at the centroid of the
    part that got the class: the lit top of a 40 px ball lies 12 px above
    the ball's centre."""
    truth = [{"frame": 0, "landmarks": [mark("red", 100, 100, 1.0)]}]
    lit_top = det("red", 100, 88)
    rim = dict(lit_top, blob=dict(lit_top["blob"], **{
        "shape-evidence": "arc", "ellipse-x": 100.5, "ellipse-y": 99.5}))
    for d, tp in ((lit_top, 0), (rim, 1)):
        s = E.summary(E.evaluate([{"frame": 0, "detections": [d]}],
                                 truth))["detection"]["all"]
        assert (s["tp"], s["fp"], s["fn"]) == (tp, 1 - tp, 1 - tp), d


# -- SLAM: map error, trajectory error, consistency ---------------------------

from gstlandmark import trajectory as T  # noqa: E402

# a field with repeated colours: three reds, two greens, two blues
TRUE_MAP = [{"id": f"L{k}", "class": c, "x": x, "y": y}
            for k, (c, x, y) in enumerate([
                ("red", 0.0, 0.0), ("red", 1.5, 0.2), ("red", 0.4, 2.0),
                ("green", 2.0, 2.1), ("green", -0.5, 1.0),
                ("blue", 1.0, -0.8), ("blue", 2.4, 1.0)], 1)]
ANGLE, SHIFT = math.radians(30), (0.7, -1.2)


def moved(x, y, angle=ANGLE, shift=SHIFT):
    c, s = math.cos(angle), math.sin(angle)
    return c * x - s * y + shift[0], s * x + c * y + shift[1]


def log_map(marks, cov=(1e-4, 0, 0, 1e-4), confirmed=True):
    return {"ids": [m["id"] for m in marks],
            "classes": [m["class"] for m in marks],
            "x": [m["x"] for m in marks], "y": [m["y"] for m in marks],
            "covariance": [v for _ in marks for v in cov],
            "confirmed": [confirmed] * len(marks),
            "views": [3] * len(marks)}


def circle_truth(n=40):
    """A robot driving a 1 m circle, heading along the path."""
    return [{"frame": k, "robot": {"x": math.cos(2 * math.pi * k / n),
                                   "y": math.sin(2 * math.pi * k / n),
                                   "heading": T.wrap_angle(
                                       2 * math.pi * k / n + math.pi / 2)},
             "landmarks": []} for k in range(n)]


def estimate_of(truth, est_map, angle=ANGLE, shift=SHIFT):
    """The truth's poses seen in a frame turned by angle and shifted."""
    out = []
    for t in truth:
        r = t["robot"]
        x, y = moved(r["x"], r["y"], angle, shift)
        out.append({"frame": t["frame"], "detections": [],
                    "pose": {"x": x, "y": y, "heading": T.wrap_angle(
                        r["heading"] + angle)},
                    "landmark_map": log_map(est_map)})
    return out


def test_align_rigid_recovers_a_known_transform():
    pts = np.array([[m["x"], m["y"]] for m in TRUE_MAP])
    turned = np.array([moved(x, y) for x, y in pts])
    tf = T.align_rigid(turned, pts)
    assert math.degrees(tf.angle) == pytest.approx(-30.0, abs=1e-9)
    assert np.allclose(tf.apply(turned), pts, atol=1e-12)
    back = tf.inverse()
    assert np.allclose(back.apply(pts), turned, atol=1e-12)
    # a mirror image is not a rotation: the best rotation leaves an error
    mirrored = pts * [1, -1]
    assert not np.allclose(T.align_rigid(mirrored, pts).apply(mirrored), pts,
                           atol=0.1)


def test_rotated_shifted_map_zero_error_after_alignment():
    est = [dict(m, id=f"S{k}", x=moved(m["x"], m["y"])[0],
                y=moved(m["x"], m["y"])[1])
           for k, m in enumerate(TRUE_MAP, 1)]
    truth = circle_truth()
    s = E.slam_evaluation(estimate_of(truth, est), truth, TRUE_MAP)
    assert s["anchored"] is False
    m = s["map"]
    assert (m["paired"], m["duplicated"], m["spurious"], m["missed"]) == \
        (7, [], [], [])
    assert {lm["id"]: lm["true_id"] for lm in m["landmarks"]} == \
        {f"S{k}": f"L{k}" for k in range(1, 8)}
    assert m["aligned"]["rms"] == pytest.approx(0.0, abs=1e-9)
    assert m["aligned"]["transform"]["angle_deg"] == pytest.approx(-30.0)
    tr = s["trajectory"]
    assert tr["frames"] == 40 and tr["aligned"]
    assert tr["position_m"]["rms"] == pytest.approx(0.0, abs=1e-9)
    assert tr["heading_deg"]["max"] == pytest.approx(0.0, abs=1e-9)
    # no path to start from: the map alone is searched
    s = E.slam_evaluation([{"frame": 0, "detections": [],
                            "landmark_map": log_map(est)}], truth, TRUE_MAP)
    assert s["trajectory"]["frames"] == 0
    assert (s["map"]["paired"], s["map"]["duplicated"]) == (7, [])
    assert s["map"]["aligned"]["rms"] == pytest.approx(0.0, abs=1e-9)


def test_anchored_map_error_without_alignment_is_exact():
    """Kept ids: the map frame is the truth's, nothing is aligned away. A
    small turn (5 degrees about the origin) leaves each landmark off by
    2 r sin(2.5 degrees), r its distance from the origin."""
    angle = math.radians(5)
    est = [dict(m, x=moved(m["x"], m["y"], angle, (0, 0))[0],
                y=moved(m["x"], m["y"], angle, (0, 0))[1]) for m in TRUE_MAP]
    truth = circle_truth()
    s = E.slam_evaluation(estimate_of(truth, est, angle, (0, 0)), truth,
                          TRUE_MAP)
    assert s["anchored"] is True
    want = [2 * math.hypot(m["x"], m["y"]) * math.sin(angle / 2)
            for m in TRUE_MAP]
    got = {lm["true_id"]: lm["error_unaligned_m"]
           for lm in s["map"]["landmarks"]}
    assert [got[m["id"]] for m in TRUE_MAP] == pytest.approx(want)
    assert s["map"]["unaligned"]["rms"] == pytest.approx(
        math.sqrt(np.mean(np.square(want))))
    assert s["map"]["aligned"]["rms"] == pytest.approx(0.0, abs=1e-9)
    # the path, not aligned either: every pose 2 sin(2.5 deg) m off on the
    # unit circle, heading 5 degrees off
    tr = s["trajectory"]
    assert not tr["aligned"]
    assert tr["position_m"]["median"] == pytest.approx(
        2 * math.sin(angle / 2))
    assert tr["heading_deg"]["max"] == pytest.approx(5.0)


def test_frames_bridged_on_few_landmarks():
    """Poses paired with fewer than 3 landmarks are scored apart: on an
    anchored map (no alignment), 10 of 40 frames with one landmark, each
    1..10 cm off along x: their p95 is that of 1..10 cm, 9.55 cm; the
    others, exact, do not dilute it."""
    truth = circle_truth()
    res = estimate_of(truth, TRUE_MAP, 0.0, (0, 0))
    for k, line in enumerate(res):
        line["pose"]["n-landmarks"] = 4
        if k >= 30:
            line["pose"]["n-landmarks"] = 1
            line["pose"]["x"] += 0.01 * (k - 29)
    s = E.slam_evaluation(res, truth, TRUE_MAP)
    assert s["anchored"] is True
    few = s["trajectory"]["few_landmarks"]
    assert few["below"] == 3 and few["frames"] == 10
    assert few["position_m"]["p95"] == pytest.approx(0.0955)
    assert few["position_m"]["max"] == pytest.approx(0.10)
    assert s["trajectory"]["position_m"]["median"] == pytest.approx(0.0)
    assert "10 frames bridged on fewer than 3 landmarks" in \
        E.format_slam(s)


def test_duplicated_spurious_and_missed_landmarks():
    est = [dict(m, id=f"S{k}") for k, m in enumerate(TRUE_MAP[:6], 1)]
    est.append(dict(TRUE_MAP[0], id="copy", x=0.06))   # L1 twice
    est.append(dict(TRUE_MAP[0], id="ghost", x=5.0, y=5.0))   # nothing
    est = [dict(m, x=moved(m["x"], m["y"])[0], y=moved(m["x"], m["y"])[1])
           for m in est]
    truth = circle_truth()
    truth[3]["landmarks"] = [{"id": "L7", "pixels": 300}]   # L7 was seen
    s = E.slam_evaluation(estimate_of(truth, est), truth, TRUE_MAP)
    m = s["map"]
    assert m["paired"] == 6 and m["estimated"] == 8
    assert m["duplicated"] == ["copy"] and m["spurious"] == ["ghost"]
    assert m["missed"] == ["L7"] and m["missed_seen"] == ["L7"]
    assert m["aligned"]["rms"] == pytest.approx(0.0, abs=1e-9)


def test_tentative_landmarks_are_not_scored():
    truth = circle_truth(4)
    res = estimate_of(truth, TRUE_MAP, 0.0, (0, 0))
    res[-1]["landmark_map"] = log_map(TRUE_MAP, confirmed=False)
    s = E.slam_evaluation(res, truth, TRUE_MAP)
    assert (s["map"]["estimated"], s["map"]["tentative"]) == (0, 7)
    assert len(s["map"]["missed"]) == 7
    assert E.slam_evaluation([{"frame": 0, "detections": []}], truth,
                             TRUE_MAP) is None


def test_nees_of_a_known_gaussian_sample():
    """Errors drawn from the covariance the estimator states: the NEES is
    chi-square(3), mean 3, inside the two-sided 95 % interval 95 % of the
    time; drawn twice as wide, the mean is 12."""
    rng = np.random.default_rng(7)
    a = rng.normal(size=(3, 3))
    cov = a @ a.T + 0.1 * np.eye(3)
    errs = rng.multivariate_normal(np.zeros(3), cov, size=4000)
    values = [T.nees(e, cov) for e in errs]
    s = T.nees_summary(values, 3)
    assert s["mean"] == pytest.approx(3.0, abs=0.15)
    assert s["inside"] == pytest.approx(0.95, abs=0.015)
    assert s["below_one_sided"] == pytest.approx(0.95, abs=0.015)
    wide = T.nees_summary([T.nees(2 * e, cov) for e in errs], 3)
    assert wide["mean"] == pytest.approx(12.0, abs=0.6)
    assert wide["inside"] < 0.6
    assert T.nees([1.0, 0.0, 0.0], np.zeros((3, 3))) is None


def test_pose_and_landmark_nees_in_the_first_pose_frame():
    """An estimator whose first pose is its origin, with errors drawn from
    the covariances it states: pose and landmark NEES near their dof."""
    rng = np.random.default_rng(3)
    truth = circle_truth(400)
    first = truth[0]["robot"]
    to_est = T.pose_transform(first, {"x": 0.0, "y": 0.0, "heading": 0.0})
    sd = np.array([0.02, 0.03, 0.01])
    res = []
    for t in truth:
        r = t["robot"]
        (x, y), = to_est.apply([r["x"], r["y"]])
        e = rng.normal(size=3) * sd if t["frame"] else np.zeros(3)
        res.append({"frame": t["frame"], "detections": [], "pose": {
            "x": x + e[0], "y": y + e[1],
            "heading": T.wrap_angle(r["heading"] + to_est.angle + e[2]),
            "covariance": list(np.diag(sd ** 2).ravel()
                               if t["frame"] else np.zeros(9))}})
    marks = []
    for k in range(60):
        (x, y), = to_est.apply([0.1 * k, 3.0])
        marks.append({"id": f"S{k}", "class": "red",
                      "x": x + rng.normal() * 0.01,
                      "y": y + rng.normal() * 0.02})
    res[-1]["landmark_map"] = log_map(marks, cov=(1e-4, 0, 0, 4e-4))
    true_map = [{"id": f"L{k}", "class": "red", "x": 0.1 * k, "y": 3.0}
                for k in range(60)]
    s = E.slam_evaluation(res, truth, true_map, gate=0.05)
    pose = s["nees"]["pose"]
    assert s["nees"]["frame"] == "first pose"
    assert pose["not_computed"] == 1 and pose["n"] == 399
    assert pose["mean"] == pytest.approx(3.0, abs=0.4)
    assert pose["inside"] == pytest.approx(0.95, abs=0.04)
    lm = s["nees"]["landmarks"]
    assert lm["n"] == 60
    assert lm["mean"] == pytest.approx(2.0, abs=0.6)


def test_cli_reports_slam(tmp_path, capsys):
    est = [dict(m, id=f"S{k}", x=moved(m["x"], m["y"])[0],
                y=moved(m["x"], m["y"])[1])
           for k, m in enumerate(TRUE_MAP, 1)]
    truth = circle_truth()
    r, t = tmp_path / "r.jsonl", tmp_path / "t.jsonl"
    r.write_text("".join(json.dumps(x) + "\n"
                         for x in estimate_of(truth, est)))
    t.write_text("".join(json.dumps(x) + "\n" for x in truth))
    (tmp_path / "map.json").write_text(json.dumps({"landmarks": TRUE_MAP}))
    out = tmp_path / "eval.json"
    assert cli.main(["evaluate", str(r), str(t), "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "SLAM (no anchor)" in text and "duplicated 0" in text
    s = json.loads(out.read_text())["slam"]
    assert s["map"]["paired"] == 7 and s["trajectory"]["frames"] == 40
    # the map written at EOS instead of the log's map meta
    lines = estimate_of(truth, est)
    for line in lines:
        del line["landmark_map"]
    r.write_text("".join(json.dumps(x) + "\n" for x in lines))
    built = tmp_path / "built.json"
    built.write_text(json.dumps({"landmarks": [
        dict(m, covariance=[1e-4, 0, 0, 1e-4]) for m in est]}))
    assert cli.main(["evaluate", str(r), str(t)]) == 0
    assert "SLAM" not in capsys.readouterr().out
    assert cli.main(["evaluate", str(r), str(t), "--json", str(out),
                     "--map-estimate", str(built)]) == 0
    s = json.loads(out.read_text())["slam"]
    assert s["map"]["paired"] == 7 and s["nees"]["landmarks"]["n"] == 7
    assert cli.main(["evaluate", str(r), str(t), "--map-estimate",
                     str(tmp_path / "none.json")]) == 2
    assert "none.json" in capsys.readouterr().err
