"""gstlandmark.landmarkmap, the one Python reader of map files, against
the elements' own reader: trilaterate given the same file must accept what
it accepts and refuse what it refuses, for the same reason."""

import json
import os

import pytest

from gstlandmark.landmarkmap import MapError, check_band_classes, read_map

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


def coded(**changes):
    """L1 a disc, L2 a beacon (pink over yellow) with these changes."""
    beacon = {"class": None, "kind": "beacon", "height": 0.3,
              "bands": ["pink", "yellow"]}
    beacon.update(changes)
    return two(**beacon)


def beacons(*codes):
    """L1 a disc, then a beacon per code (L2, L3, ...)."""
    marks = [lm()]
    for i, code in enumerate(codes):
        marks.append({"id": f"L{i + 2}", "kind": "beacon", "x": 1.0 + i,
                      "y": 0.0, "diameter": 0.1, "height": 0.3,
                      "bands": code.split("/")})
    return {"landmarks": marks}


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
    # coded markers (docs/beacons.md)
    ("valid-beacon", json.dumps(coded()), None),
    ("valid-beacon-band-heights",
     json.dumps(coded(**{"band-heights": [0.1, 0.2]})), None),
    ("valid-post-one-band", json.dumps(coded(kind="post", diameter=0.03,
                                             bands=["blue"])), None),
    ("valid-cone-stripes", json.dumps(coded(
        kind="cone", bands=["yellow", "blue", "yellow"])), None),
    ("beacon-one-band", json.dumps(coded(bands=["pink"])),
     'landmarks[1] ("L2"): "bands" must hold 2 to 3 class names for a '
     'beacon, got 1'),
    ("post-four-bands", json.dumps(coded(kind="post",
                                         bands=["a", "b", "c", "d"])),
     'landmarks[1] ("L2"): "bands" must hold 1 to 3 class names for a '
     'post, got 4'),
    ("cone-no-bands", json.dumps(coded(kind="cone", bands=None)),
     'landmarks[1] ("L2"): "bands" must be an array of class names, top '
     'first'),
    ("band-not-a-name", json.dumps(coded(bands=["pink", "a/b"])),
     'landmarks[1] ("L2"): "bands"[1] must be a class name'),
    ("band-heights-count", json.dumps(coded(**{"band-heights": [0.3]})),
     'landmarks[1] ("L2"): "band-heights" must hold one positive number '
     '(metres) per band, 2 here'),
    ("band-heights-sum", json.dumps(coded(**{"band-heights": [0.1, 0.1]})),
     'landmarks[1] ("L2"): "band-heights" must sum to "height" (0.3 m), '
     'got 0.2 m'),
    ("band-height-zero", json.dumps(coded(**{"band-heights": [0.3, 0]})),
     'landmarks[1] ("L2"): "band-heights" must hold one positive number'),
    ("beacon-no-height", json.dumps(coded(height=None)),
     'landmarks[1] ("L2"): "height" must be a positive number (metres)'),
    ("beacon-negative-height", json.dumps(coded(height=-0.3)),
     'landmarks[1] ("L2"): "height" must be a positive number (metres)'),
    ("beacon-no-diameter", json.dumps(coded(diameter=None)),
     'landmarks[1] ("L2"): "diameter" must be a positive number (metres)'),
    ("beacon-zero-diameter", json.dumps(coded(diameter=0)),
     'landmarks[1] ("L2"): "diameter" must be a positive number (metres)'),
    ("beacon-with-class", json.dumps(coded(**{"class": "pink"})),
     'landmarks[1] ("L2"): a beacon has no "class": its classes are its '
     '"bands"'),
    ("duplicate-code", json.dumps(beacons("pink/yellow", "yellow/pink",
                                          "pink/yellow")),
     'landmarks[3] ("L4"): "bands" give the code pink/yellow of landmark '
     '"L2" too: each coded marker needs a code of its own'),
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


def test_coded_markers_read_with_their_code(tmp_path):
    path = tmp_path / "map.json"
    path.write_text(json.dumps(coded(**{"band-heights": [0.1, 0.2]})))
    disc, beacon = read_map(str(path))
    assert disc["kind"] == "disc" and "code" not in disc
    assert beacon == {"id": "L2", "class": "pink/yellow", "kind": "beacon",
                      "x": 3.0, "y": 2.0, "z": None, "diameter": 0.2,
                      "height": 0.3, "bands": ["pink", "yellow"],
                      "band_heights": [0.1, 0.2], "code": "pink/yellow"}
    path.write_text(json.dumps(coded(kind="cone",
                                     bands=["yellow", "blue", "yellow"])))
    cone = read_map(str(path))[1]
    assert cone["code"] == "yellow/blue/yellow"
    assert cone["band_heights"] == pytest.approx([0.1, 0.1, 0.1])


def test_a_band_the_palette_lacks_is_named(tmp_path):
    path = tmp_path / "map.json"
    path.write_text(json.dumps(beacons("pink/yellow", "yellow/purple")))
    landmarks = read_map(str(path))
    check_band_classes(landmarks, ["red", "pink", "yellow", "purple"],
                       str(path))
    with pytest.raises(MapError) as err:
        check_band_classes(landmarks, ["red", "pink", "yellow", "blue"],
                           str(path))
    assert str(err.value) == (
        f'{path}: landmarks[2] ("L3"): "bands"[1] purple is not a class of '
        f'the palette (red, pink, yellow, blue)')


def test_a_map_of_coded_markers_alone_is_read_by_trilaterate(gst,
                                                             tmp_path):
    """trilaterate positions from coded markers too (beacondetect names
    them by their code, docs/beacons.md): a map of them alone starts."""
    path = tmp_path / "map.json"
    marks = beacons("pink/yellow", "yellow/pink")["landmarks"][1:]
    path.write_text(json.dumps({"landmarks": marks}))
    assert len(read_map(str(path))) == 2
    assert element_error(gst, str(path)) is None
