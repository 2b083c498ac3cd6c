"""gst-landmark evaluate against hand-made truth with known answers."""

import json
import math

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
