"""gst-landmark regress: per-field tolerances, readable report, status."""

import json

import pytest

from gstlandmark.commands import cli
from gstlandmark.devtools import regress


def write(path, frames):
    path.write_text("".join(json.dumps(f) + "\n" for f in frames))
    return str(path)


GOLDEN = [
    {"frame": 0, "pts": 0, "detections": [
        {"id": 0, "class": "red", "bbox": [1, 2, 3, 4],
         "range": {"range": 1.5, "bearing": 0.25, "method": "ground"}}]},
    {"frame": 1, "pts": 33333333, "detections": [],
     "pose": {"x": 1.0, "y": 2.0, "heading": 0.5}},
]


def changed(**edits):
    frames = json.loads(json.dumps(GOLDEN))
    for path, value in edits.items():
        frame, *keys = path.split("/")
        target = frames[int(frame)]
        for k in keys[:-1]:
            target = target[int(k)] if k.isdigit() else target[k]
        last = keys[-1]
        if value is KeyError:
            del target[last]
        else:
            target[int(last) if last.isdigit() else last] = value
    return frames


def run(tmp_path, result, *extra):
    g = write(tmp_path / "golden.jsonl", GOLDEN)
    r = write(tmp_path / "result.jsonl", result)
    return cli.main(["regress", r, g, *extra])


def test_identical_files_pass(tmp_path, capsys):
    assert run(tmp_path, GOLDEN) == 0
    assert "same as" in capsys.readouterr().out


@pytest.mark.parametrize("edits, fragment", [
    ({"0/detections/0/range/range": 1.5001}, "detections[0].range.range"),
    ({"0/detections/0/class": "blue"}, '"blue" vs golden "red"'),
    ({"0/detections/0/bbox/2": 4}, "detections[0].bbox[2]"),
    ({"1/pose": KeyError}, "pose: null vs golden"),
    ({"1/pose/solver": "nls"}, "not in golden"),
    ({"0/detections": []}, "length differs"),
    ({"1/pts": 33333334}, "frame 1: pts"),
])
def test_each_kind_of_change_is_reported(tmp_path, capsys, edits, fragment):
    assert run(tmp_path, changed(**edits)) == 1
    out = capsys.readouterr().out
    assert fragment in out
    assert "differences in 1 frames" in out


def test_tolerances_by_name_and_path(tmp_path):
    result = changed(**{"0/detections/0/range/range": 1.5004,
                        "1/pose/x": 1.02})
    assert run(tmp_path, result) == 1
    assert run(tmp_path, result, "--tol", "range=0.001",
               "--tol", "pose.x=0.05") == 0
    # the path form applies to that path only
    assert run(tmp_path, result, "--tol", "detections.range.range=0.001",
               "--tol", "pose.y=0.05") == 1


def test_ignore_and_frame_count(tmp_path, capsys):
    assert run(tmp_path, changed(**{"1/pts": 5}), "--ignore", "pts") == 0
    assert run(tmp_path, GOLDEN[:1]) == 1
    assert "frame count differs" in capsys.readouterr().out


def test_bad_input_is_status_2(tmp_path, capsys):
    g = write(tmp_path / "golden.jsonl", GOLDEN)
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"frame": 0}\n{"frame": \n')
    assert cli.main(["regress", str(bad), g]) == 2
    assert "bad.jsonl:2: not JSON" in capsys.readouterr().err
    assert cli.main(["regress", str(tmp_path / "none.jsonl"), g]) == 2
    with pytest.raises(regress.RegressError):
        regress.parse_tolerances(["range=-1"])
