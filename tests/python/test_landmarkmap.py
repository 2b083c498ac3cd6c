"""gstlandmark.landmarkmap, the one Python reader of map files, against
the elements' own reader: trilaterate given the same file must accept what
it accepts and refuse what it refuses, for the same reason."""

import json
import os

import pytest

from gstlandmark.landmarkmap import MapError, read_map

SOURCE_ROOT = os.environ.get(
    "LANDMARK_SOURCE_ROOT",
    os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..")))
CLIP_MAP = os.path.join(SOURCE_ROOT, "tests", "files", "clips", "path-small",
                        "map.json")


def lm(**changes):
    entry = {"id": "L1", "class": "red", "x": 1.0, "y": 2.0,
             "diameter": 0.2}
    entry.update(changes)
    return {k: v for k, v in entry.items() if v is not None}


def two(**changes):
    second = dict({"id": "L2", "x": 3.0}, **changes)
    return {"landmarks": [lm(), lm(**second)]}


# (case, map text, what the error says after the file name; None: valid)
CASES = [
    ("valid", json.dumps(two()), None),
    ("valid-ball-z", json.dumps(two(kind="ball", z=0.1)), None),
    ("valid-no-diameter", json.dumps(two(diameter=None)), None),
    ("not-json", '{"landmarks": [', "not valid JSON"),
    ("wrong-type", '{"landmarks": {}}', '"landmarks" must be an array'),
    ("empty", '{"landmarks": []}', '"landmarks" is empty'),
    ("entry-not-object", '{"landmarks": [3]}',
     "landmarks[0]: must be an object"),
    ("no-id", json.dumps({"landmarks": [lm(id=None)]}),
     'landmarks[0]: "id" must be a non-empty string'),
    ("no-class", json.dumps(two(**{"class": None})),
     'landmarks[1] ("L2"): "class" must be a non-empty string'),
    ("x-string", json.dumps(two(x="1.0")),
     'landmarks[1] ("L2"): "x" must be a finite number (metres)'),
    ("x-huge", json.dumps(two(x=1e9)),
     'landmarks[1] ("L2"): "x" must be within -10000..10000'),
    ("diameter-zero", json.dumps(two(diameter=0)),
     'landmarks[1] ("L2"): "diameter" must be a positive number'),
    ("diameter-huge", json.dumps(two(diameter=500)),
     'landmarks[1] ("L2"): "diameter" must be at most 100'),
    ("kind-cube", json.dumps(two(kind="cube")),
     'landmarks[1] ("L2"): "kind" must be "disc" or "ball"'),
    ("duplicate-id", json.dumps(two(id="L1")),
     'landmarks[1] ("L1"): duplicate id'),
    ("too-many", json.dumps({"landmarks": [lm(id=f"L{i}")
                                           for i in range(257)]}),
     "257 landmarks; at most 256 are supported"),
]


def element_error(Gst, path):
    """trilaterate's error for the map file ``path`` (None: accepted)."""
    pipe = Gst.parse_launch(f"videotestsrc num-buffers=1 ! "
                            f"trilaterate map=\"{path}\" ! fakesink")
    bus = pipe.get_bus()
    try:
        pipe.set_state(Gst.State.PLAYING)
        msg = bus.timed_pop_filtered(
            10 * Gst.SECOND, Gst.MessageType.ERROR | Gst.MessageType.EOS)
        assert msg is not None, "trilaterate neither failed nor ended"
        if msg.type == Gst.MessageType.EOS:
            return None
        return msg.parse_error()[1]
    finally:
        pipe.set_state(Gst.State.NULL)


@pytest.mark.parametrize("case, text, why", CASES,
                         ids=[c[0] for c in CASES])
def test_the_reader_agrees_with_the_elements(gst, tmp_path, case, text,
                                             why):
    path = tmp_path / "map.json"
    path.write_text(text)
    element = element_error(gst, str(path))
    if why is None:
        assert element is None
        landmarks = read_map(str(path))
        assert [m["id"] for m in landmarks] == ["L1", "L2"]
        return
    with pytest.raises(MapError) as err:
        read_map(str(path))
    assert str(err.value).startswith(f"{path}: {why}")
    assert element is not None and why in element


def test_the_shipped_map_reads_as_written():
    with open(CLIP_MAP) as f:
        raw = json.load(f)["landmarks"]
    landmarks = read_map(CLIP_MAP)
    assert len(landmarks) == len(raw) > 0
    for got, want in zip(landmarks, raw):
        assert (got["id"], got["class"], got["x"], got["y"],
                got["diameter"]) == (want["id"], want["class"], want["x"],
                                     want["y"], want["diameter"])
        assert got["kind"] == want.get("kind", "disc")


def test_a_missing_file_is_named(tmp_path):
    missing = tmp_path / "none.json"
    with pytest.raises(MapError, match=f"^{missing}: No such file"):
        read_map(str(missing))
