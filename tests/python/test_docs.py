"""The documentation cannot drift from the code: every element's page lists
every property with the default and range gst-inspect-1.0 shows, and names
the metadata the element reads and writes; the pages link up; the C
embedding example (docs/examples/read-metadata.c) builds, runs on the shipped
clip and agrees with the Python embedding API."""

import json
import os
import re
import subprocess

import pytest

from gi.repository import GObject

from gstlandmark import pipeline
from gstlandmark.gicompat import enum_class

SOURCE_ROOT = os.environ.get(
    "LANDMARK_SOURCE_ROOT",
    os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(
        __file__)))))
BUILD_ROOT = os.environ.get("LANDMARK_BUILD_ROOT",
                            os.path.join(SOURCE_ROOT, "build"))
DOCS = os.path.join(SOURCE_ROOT, "docs")
CLIP = os.path.join(SOURCE_ROOT, "tests", "files", "clips", "path-small")

ELEMENTS = ["labsegment", "blobroundness", "beacondetect", "ipmrange",
            "trilaterate",
            "landmarkoverlay", "landmarklog", "landmarkpublish",
            "floorboundary", "birdseye", "landmarkslam"]
SKIP = {"name", "parent", "qos"}

# What each element reads and writes (docs/metadata.md); each entry is a set
# of acceptable spellings, one of which the element's page must contain.
METADATA = {
    "labsegment": [{"GstLandmarkLabelsMeta"}],
    "blobroundness": [{"GstLandmarkLabelsMeta"},
                      {"GstVideoRegionOfInterestMeta"}, {"landmark-blob"}],
    "beacondetect": [{"GstLandmarkLabelsMeta"},
                     {"GstVideoRegionOfInterestMeta"}, {"landmark-blob"}],
    "ipmrange": [{"landmark-blob", "blobroundness"}, {"landmark-range"}],
    "trilaterate": [{"landmark-range"}, {"GstLandmarkPoseMeta"},
                    {"landmark-match"}],
    "landmarkoverlay": [{"GstLandmarkLabelsMeta"},
                        {"GstVideoRegionOfInterestMeta", "region-of-interest"},
                        {"GstLandmarkPoseMeta"}],
    "landmarklog": [{"GstLandmarkLabelsMeta"},
                    {"GstVideoRegionOfInterestMeta", "region-of-interest"},
                    {"GstLandmarkPoseMeta"}],
    "landmarkpublish": [{"landmarklog"}],
    "floorboundary": [{"GstLandmarkLabelsMeta"}, {"GstLandmarkFloorMeta"}],
    "birdseye": [{"GstLandmarkFloorMeta", "GstLandmarkPoseMeta"}],
    "landmarkslam": [{"landmark-range"}, {"GstLandmarkPoseMeta"}],
}

SYMBOLS = {"G_MAXUINT": 4294967295.0, "G_MAXINT": 2147483647.0,
           "G_MAXDOUBLE": 1.7976931348623157e308, "G_MAXUINT64": 2.0 ** 64 - 1,
           "G_MAXINT64": 2.0 ** 63 - 1, "G_MININT": -2147483648.0}
NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


def read(name):
    with open(os.path.join(DOCS, name), encoding="utf-8") as f:
        return f.read()


def property_table(text):
    """Rows of the first table under '## Properties': {name: {column: cell}}.
    A row may name several properties (`a`, `b`) only if they share every
    cell; the tables here use one row per property."""
    m = re.search(r"^## Properties\s*$", text, re.M)
    assert m, "no '## Properties' section"
    lines = text[m.end():].split("\n")
    start = next(i for i, l in enumerate(lines) if l.startswith("|"))
    rows = []
    for line in lines[start:]:
        if not line.startswith("|"):
            break
        rows.append([c.strip() for c in line.strip().strip("|").split("|")])
    header = [h.lower() for h in rows[0]]
    assert header[0] == "property", header
    assert "default" in header and "range" in header, (
        f"the properties table needs 'default' and 'range' columns: {header}")
    table = {}
    for row in rows[2:]:
        cells = dict(zip(header, row))
        for name in re.findall(r"`([a-z0-9-]+)`", row[0]):
            assert name not in table, f"{name} listed twice"
            table[name] = cells
    return table


def value(token):
    return SYMBOLS[token] if token in SYMBOLS else float(token)


def close(a, b):
    return abs(a - b) <= 1e-9 * max(1.0, abs(a), abs(b))


def check_property(pspec, cells):
    """Problems with one documented property, as strings."""
    problems = []
    t = pspec.value_type
    default = cells["default"].replace("`", "").strip()
    rng = cells["range"].replace("`", "").strip()
    name = pspec.name
    if t.is_a(GObject.TYPE_ENUM):
        enum = enum_class(t)
        nick = enum(int(pspec.default_value)).value_nick
        if default.split()[:1] != [nick]:
            problems.append(f"{name}: default {default!r}, element: {nick}")
        nicks = [v.value_nick for v in enum.__enum_values__.values()]
        missing = [n for n in nicks if n not in cells["type"] + cells.get(
            "meaning", "")]
        if missing:
            problems.append(f"{name}: values {missing} not documented")
    elif t.is_a(GObject.TYPE_FLAGS):
        # the default as its flags' nicks joined by '+' ('none': 0)
        values = enum_class(t).__flags_values__
        bits = int(pspec.default_value)
        want = "+".join(v.first_value_nick for k, v in sorted(values.items())
                        if k and bits & k == k) or "none"
        if default.split()[:1] != [want]:
            problems.append(f"{name}: default {default!r}, element: {want}")
        missing = [v.first_value_nick for v in values.values()
                   if v.first_value_nick not in cells["type"] +
                   cells.get("meaning", "")]
        if missing:
            problems.append(f"{name}: values {missing} not documented")
    elif t == GObject.TYPE_BOOLEAN:
        want = "true" if pspec.default_value else "false"
        if default.split()[:1] != [want]:
            problems.append(f"{name}: default {default!r}, element: {want}")
    elif t == GObject.TYPE_STRING:
        want = pspec.default_value
        first = default.split(":")[0].split()[:1]
        if want is None:
            if first not in (["none"], ["unset"], ["null"]):
                problems.append(f"{name}: default {default!r}, element: null")
        elif want not in default:
            problems.append(f"{name}: default {default!r}, element: {want}")
    elif hasattr(pspec, "minimum"):
        m = re.match(NUMBER, default)
        if not m or not close(float(m.group(0)), float(pspec.default_value)):
            problems.append(f"{name}: default {default!r}, element: "
                            f"{pspec.default_value}")
        m = re.fullmatch(rf"({NUMBER}|G_M[A-Z0-9]+)\s*\.\.\s*"
                         rf"({NUMBER}|G_M[A-Z0-9]+)", rng)
        if not m:
            problems.append(f"{name}: range {rng!r} is not 'MIN..MAX'")
        elif not (close(value(m.group(1)), float(pspec.minimum)) and
                  close(value(m.group(2)), float(pspec.maximum))):
            problems.append(f"{name}: range {rng!r}, element: "
                            f"{pspec.minimum}..{pspec.maximum}")
    else:
        problems.append(f"{name}: type {t.name} not handled by this test")
    return problems


@pytest.mark.parametrize("element", ELEMENTS)
def test_property_table_matches_element(gst, element):
    factory = gst.ElementFactory.find(element)
    assert factory is not None, element
    el = factory.create(None)
    specs = {p.name: p for p in el.list_properties() if p.name not in SKIP}
    table = property_table(read(f"{element}.md"))
    assert sorted(set(specs) - set(table)) == [], "undocumented properties"
    assert sorted(set(table) - set(specs)) == [], "documented, not present"
    problems = [p for n, s in specs.items() for p in
                check_property(s, table[n])]
    assert problems == []


@pytest.mark.parametrize("element", ELEMENTS)
def test_page_names_metadata_read_and_written(element):
    text = read(f"{element}.md")
    missing = [sorted(alts) for alts in METADATA[element]
               if not any(a in text for a in alts)]
    assert missing == []


def test_index_links_every_page_and_the_dashboard():
    index = read("index.md")
    assert "images/dashboard.jpg" in index
    pages = sorted(f for f in os.listdir(DOCS)
                   if f.endswith(".md") and f != "index.md")
    assert [p for p in pages if f"({p})" not in index] == []
    for target in re.findall(r"\]\(([^)#]+)", index):
        if "://" not in target:
            assert os.path.exists(os.path.join(DOCS, target)), target


@pytest.mark.parametrize("page", ["index.md", "tutorial.md", "embedding.md",
                                  "slam.md"])
def test_relative_links_resolve(page):
    for target in re.findall(r"\]\(([^)#\s]+)", read(page)):
        if "://" not in target:
            assert os.path.exists(os.path.join(DOCS, target)), target


def test_tutorial_commands_exist():
    """Each `gst-landmark A [B]` in the tutorial is a real subcommand."""
    import shutil
    exe = os.path.join(SOURCE_ROOT, ".venv", "bin", "gst-landmark")
    exe = exe if os.path.exists(exe) else shutil.which("gst-landmark")
    if exe is None:
        pytest.skip("gst-landmark not installed")
    blocks = "\n".join(re.findall(r"^```\n(.*?)^```", read("tutorial.md"),
                                   re.S | re.M))
    seen = set(re.findall(r"gst-landmark ((?:[a-z]+)(?: [a-z]+)?)", blocks))
    assert seen
    for cmd in sorted(seen):
        words = cmd.split()
        r = subprocess.run([exe] + words + ["--help"], capture_output=True,
                           text=True, timeout=30)
        if r.returncode != 0 and len(words) == 2:
            # the second word was an argument, not a subcommand
            r = subprocess.run([exe, words[0], "--help"],
                               capture_output=True, text=True, timeout=30)
        assert r.returncode == 0, (cmd, r.stderr)


# ---------------------------------------------------------------------------
# The C example


def chain():
    pal = os.path.join(CLIP, "palette.json")
    mp = os.path.join(CLIP, "map.json")
    with open(os.path.join(CLIP, "scene.json")) as f:
        cam = json.load(f)["camera"]
    return cam, (f"labsegment palette=\"{pal}\" min-class-pixels=50 ! "
                 f"blobroundness min-area=30 ! "
                 f"ipmrange camera-height={cam['height_m']:g} "
                 f"tilt={cam['tilt_deg']:g} hfov={cam['hfov_deg']:g} "
                 f"map=\"{mp}\" ! trilaterate map=\"{mp}\"")


def parse_output(text):
    frames = []
    for line in text.splitlines():
        w = line.split()
        if w[0] == "frame":
            kv = dict(x.split("=", 1) for x in w[5:] if "=" in x)
            frames.append({"pose": None if w[5] == "none" else kv,
                           "dets": []})
        elif w[0] == "det":
            kv = dict(x.split("=", 1) for x in w[2:])
            frames[-1]["dets"].append(kv)
    return frames


@pytest.fixture(scope="module")
def read_metadata():
    exe = os.path.join(BUILD_ROOT, "docs", "examples", "read-metadata")
    assert os.path.exists(exe), f"{exe} not built (meson compile -C build)"
    return exe


def run_c(exe, args):
    env = dict(os.environ)
    env["GST_PLUGIN_PATH"] = os.path.join(BUILD_ROOT, "plugins")
    r = subprocess.run([exe] + args, capture_output=True, text=True,
                       env=env, timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.rstrip().endswith("frames 45"), r.stdout[-200:]
    return parse_output(r.stdout)


def compare(c_frames, py):
    assert len(c_frames) == len(py) == 45
    for cf, r in zip(c_frames, py):
        assert (cf["pose"] is None) == (r.pose is None), r.frame
        if r.pose is not None:
            assert float(cf["pose"]["x"]) == pytest.approx(r.pose.x, abs=1e-4)
            assert float(cf["pose"]["y"]) == pytest.approx(r.pose.y, abs=1e-4)
            assert float(cf["pose"]["heading"]) == pytest.approx(
                r.pose.heading, abs=1e-4)
            assert int(cf["pose"]["n"]) == r.pose.fields["n-landmarks"]
        assert len(cf["dets"]) == len(r.detections), r.frame
        for cd, d in zip(cf["dets"], r.detections):
            assert cd["class"] == d.class_name
            if "range" in d.range:
                assert float(cd["range"]) == pytest.approx(d.range["range"],
                                                           abs=1e-4)
            else:
                assert cd["range"] == "none"
    return sum(cf["pose"] is not None for cf in c_frames)


@pytest.fixture(scope="module")
def python_run(gst):
    _, ch = chain()
    return list(pipeline.run_file(os.path.join(CLIP, "clip.avi"), ch))


def test_c_example_agrees_with_python(read_metadata, python_run):
    cam, _ = chain()
    c_frames = run_c(read_metadata, [
        "-p", os.path.join(CLIP, "palette.json"),
        "-m", os.path.join(CLIP, "map.json"),
        "-H", str(cam["height_m"]), "-t", str(cam["tilt_deg"]),
        "-f", str(cam["hfov_deg"]), os.path.join(CLIP, "clip.avi")])
    n_poses = compare(c_frames, python_run)
    assert n_poses >= 30
    assert sum(len(f["dets"]) for f in c_frames) >= 45
    for cf, r in zip(c_frames, python_run):
        for cd, d in zip(cf["dets"], r.detections):
            assert cd["bbox"] == ",".join(str(v) for v in d.bbox)


def test_c_example_falls_back_to_detections_meta(read_metadata, python_run):
    """After videoconvert the region-of-interest metas lose their parameter
    structures; the example reads the ranges from GstLandmarkDetectionsMeta."""
    _, ch = chain()
    launch = (pipeline.file_pipeline(os.path.join(CLIP, "clip.avi"), ch)
              .replace(" ! appsink", " ! videoconvert ! "
                       "video/x-raw,format=BGRx ! appsink"))
    env_frames = run_c(read_metadata, ["-l", launch])
    compare(env_frames, python_run)
    srcs = {d.get("src") for f in env_frames for d in f["dets"]}
    assert srcs == {"custom"}
