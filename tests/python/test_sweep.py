"""gst-landmark sweep: scoring against hand-made truth with known
answers, the halves, and a real sweep over two tiny variants."""

import json
import math

import pytest

from gstlandmark.commands import cli
from gstlandmark.devtools import sweep as S


def mark(id_, cls, u, v, pixels=400.0, cut=False, occluded=0.0,
         rng=1.0):
    return {"id": id_, "class": cls, "u": u, "v": v, "pixels": pixels,
            "cut": cut, "occluded_fraction": occluded, "range": rng}


def det(cls, u, v, landmark=None, rng=None, **extra):
    d = {"id": 0, "class": cls, "bbox": [int(u) - 5, int(v) - 5, 11, 11],
         "blob": {"centroid-x": u, "centroid-y": v, "kept": True}}
    if landmark is not None:
        d["match"] = {"matched": True, "landmark-id": landmark}
    if rng is not None:
        d["range"] = {"range": rng, "bearing": 0.0}
    d.update(extra)
    return d


def test_required_landmarks():
    assert S.required(mark("A", "red", 0, 0, pixels=113))
    assert not S.required(mark("A", "red", 0, 0, pixels=112.9))
    assert not S.required(mark("A", "red", 0, 0, cut=True))
    assert S.required(mark("A", "red", 0, 0, occluded=0.2))
    assert not S.required(mark("A", "red", 0, 0, occluded=0.21))
    # older truth without the fraction: the flag decides
    old = {"class": "red", "pixels": 500, "cut": False, "occluded": True}
    assert not S.required(old)


def test_match_gate_follows_the_landmark_size():
    assert S.match_gate(mark("A", "red", 0, 0, pixels=100)) == 4.0
    big = mark("A", "red", 0, 0, pixels=math.pi * 40 ** 2)   # 80 px across
    assert S.match_gate(big) == pytest.approx(20.0)


TRUTH = [
    {"frame": 0, "robot": {"x": 0.0, "y": 0.0, "heading": 0.0},
     "landmarks": [mark("L1", "red", 100, 100, rng=1.0),
                   mark("L2", "blue", 200, 100, rng=2.0),
                   mark("L3", "green", 300, 100, rng=3.0),
                   mark("L4", "red", 400, 100, pixels=50)]},   # too small
    {"frame": 1, "robot": {"x": 1.0, "y": 0.0, "heading": 0.0},
     "landmarks": [mark("L1", "red", 100, 100),
                   mark("L2", "blue", 200, 100, cut=True),
                   mark("L3", "green", 300, 100)]},
]
RESULTS = [
    {"frame": 0, "detections": [
        det("red", 101, 100, "L1", rng=1.01),
        det("blue", 200, 102, "L3", rng=2.0),        # wrong identity
        det("green", 300, 100, rng=3.06),            # not assigned
        det("red", 400, 100),                        # small one: ignored
        det("pink", 50, 50),                         # false positive
        det("pink", 60, 60, accepted=False)],        # vetoed: ignored
     "pose": {"x": 0.03, "y": 0.04, "heading": 0.01}},
    {"frame": 1, "detections": [det("red", 100, 100, "L1"),
                                det("blue", 200, 100, "L2")],
     "pose": {"x": 1.0, "y": 0.0, "heading": 0.0}},
]


def test_score_known_answers():
    s = S.summarise(S.score(RESULTS, TRUTH))
    assert (s["tp"], s["fp"], s["fn"]) == (4, 1, 1)
    assert s["precision"] == pytest.approx(4 / 5)
    assert s["recall"] == pytest.approx(4 / 5)
    # of 4 matches 3 were assigned, 2 to the right landmark
    assert s["assigned"] == pytest.approx(3 / 4)
    assert s["identity"] == pytest.approx(2 / 3)
    assert s["range_n"] == 3
    assert s["range_rel_median"] == pytest.approx(0.01)
    # frame 0 has three required landmarks and a pose 5 cm off; frame 1
    # has two (one is cut): not counted
    assert s["pose_frames"] == 1 and s["pose_coverage"] == 1.0
    assert s["position_median_m"] == pytest.approx(0.05)


def test_floor_coloured_classes_are_not_required(tmp_path):
    # red taught 6 Delta E from the floor (a red floor), blue far from it
    pal = tmp_path / "palette.json"
    pal.write_text(json.dumps({"classes": [
        {"name": "red", "lab": [45.0, 60.0, 40.0], "marker": True},
        {"name": "blue", "lab": [35.0, 10.0, -50.0], "marker": True},
        {"name": "green", "lab": [60.0, -50.0, 40.0], "marker": True,
         "references": [[60.0, -50.0, 40.0], [70.0, 8.0, 6.0]]},
        {"name": "floor", "lab": [47.0, 56.0, 37.0], "marker": False},
        {"name": "wall", "lab": [70.0, 0.0, 0.0], "marker": False}]}))
    # green: its second reference is 10 from the wall
    assert S.floor_coloured_classes(str(pal)) == ["red", "green"]
    s = S.summarise(S.score(RESULTS, TRUTH, excluded=["red"]))
    # the red landmarks are no longer required: L1 twice found, not counted
    assert (s["tp"], s["fp"], s["fn"]) == (2, 1, 1)


def test_halves():
    assert S.variant_numbers(6) == [1, 2, 3, 4, 5, 6]
    assert S.variant_numbers(6, "held-out") == [1, 3, 5]
    assert S.variant_numbers(6, "tune") == [2, 4, 6]
    assert S.variant_numbers(3, "tune", first=7) == [8]
    with pytest.raises(ValueError):
        S.variant_numbers(3, "both")


def test_report_pools_each_half():
    rows = []
    for n, tp in ((1, 3), (2, 1), (3, 5)):
        tallies = S.score([], [])
        tallies.update(tp=tp, fn=1, frames=1)
        rows.append({"scenario": "path", "variant": n,
                     "half": S.half_of(n), "seconds": 1.0,
                     "tallies": tallies, **S.summarise(tallies)})
    rows.append({"scenario": "path", "variant": 4, "half": "tune",
                 "error": "RuntimeError: broken", "seconds": 0.5})
    rep = S.report(rows)
    held = rep["halves"]["held-out"]["all"]
    assert (held["tp"], held["fn"]) == (8, 2)
    assert rep["halves"]["tune"]["all"]["recall"] == pytest.approx(0.5)
    assert rep["halves"]["all"]["all"]["tp"] == 9
    assert len(rep["errors"]) == 1
    md = S.format_markdown(rep)
    assert "error: RuntimeError: broken" in md


def test_sweep_on_two_tiny_variants(tmp_path, capsys):
    out = tmp_path / "sweep"
    # both clips rendered side by side, each by its own process
    status = cli.main(["sweep", "--scenario", "distractors", "--variants",
                       "2", "--frames", "3", "--jobs", "2", "--out",
                       str(out)])
    printed = capsys.readouterr().out
    rep = json.loads((out / "report.json").read_text())
    assert [r.get("error") for r in rep["rows"]] == [None, None], \
        rep["rows"]
    assert status == 0
    assert [(r["variant"], r["half"]) for r in rep["rows"]] == [
        (1, "held-out"), (2, "tune")]
    assert set(rep["halves"]) == {"tune", "held-out", "all"}
    for r in rep["rows"]:
        assert r["frames"] == 3 and r["render_s"] > 0
        for key in ("precision", "recall"):
            assert r[key] is None or 0.0 <= r[key] <= 1.0
        # the variant's own camera was drawn and used
        scene = json.loads(next((out / "clips").glob(
            f"distractors-v{r['variant']}-*")).joinpath(
                "scene.json").read_text())
        assert scene["notes"]["variant"]["number"] == r["variant"]
        assert r["drawn"]["camera"] == scene["notes"]["variant"]["camera"]
        log = out / "runs" / f"distractors-v{r['variant']}" / "log.jsonl"
        assert len(log.read_text().splitlines()) == 3
    md = (out / "report.md").read_text()
    assert "| distractors | 1 | held-out |" in md
    assert "| distractors | 2 | tune |" in md
    assert "| all | 1 clips | held-out |" in md
    assert "| all | 1 clips | tune |" in md
    assert "| all | 2 clips | all |" in md
    assert md in printed
    # a second run reuses the rendered clips
    cli.main(["sweep", "--scenario", "distractors", "--variants", "2",
              "--half", "tune", "--frames", "3", "--out", str(out)])
    again = json.loads((out / "report.json").read_text())
    assert [r["variant"] for r in again["rows"]] == [2]
    assert again["rows"][0]["render_s"] == 0.0
    assert set(again["halves"]) == {"tune", "all"}
