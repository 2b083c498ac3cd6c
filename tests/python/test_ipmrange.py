"""ipmrange on the synthetic range sweep: range and bearing against the
exact truth (gstlandmark.evaluate), discs and balls from 0.3 to 4 m.

Targets (issue 5): median range error <= 1 %, p95 <= 2 %, bearing median
<= 0.3 degrees, with the pinhole model and the true camera."""

import json
import math
import os

import numpy as np
import pytest

from gstlandmark import cli, evaluate as E
from gstlandmark.regress import read_jsonl

MAX_RANGE = 4.0
MARKERS = {
    "disc": "marker-kind=disc marker-height=0 marker-diameter=0.1",
    "ball": "marker-kind=ball marker-height=0.0325 marker-diameter=0.065",
}


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("range-sweep")
    assert cli.main(["synth", "range-sweep", "--out", str(out)]) == 0
    return out


def camera_props(scene):
    cam = scene["camera"]
    return (f"camera-height={cam['height_m']} tilt={cam['tilt_deg']} "
            f"roll={cam['roll_deg']} fx={cam['fx']} fy={cam['fy']} "
            f"cx={cam['cx']} cy={cam['cy']}")


def run(Gst, desc, timeout_s=120):
    pipe = Gst.parse_launch(desc)
    bus = pipe.get_bus()
    pipe.set_state(Gst.State.PLAYING)
    try:
        msg = bus.timed_pop_filtered(
            timeout_s * Gst.SECOND,
            Gst.MessageType.ERROR | Gst.MessageType.EOS)
        assert msg is not None, f"timeout: {desc}"
        if msg.type == Gst.MessageType.ERROR:
            err, dbg = msg.parse_error()
            raise AssertionError(f"{err.message}: {dbg}")
    finally:
        pipe.set_state(Gst.State.NULL)


def range_run(Gst, sweep, kind, method, log):
    scene = json.loads((sweep / "scene.json").read_text())
    run(Gst, f"filesrc location={sweep / 'clip.avi'} ! avidemux ! jpegdec ! "
        f"videoconvert ! labsegment palette={sweep / 'palette.json'} "
        f"min-class-pixels=0 ! blobroundness ! ipmrange "
        f"{camera_props(scene)} {MARKERS[kind]} range-method={method} ! "
        f"landmarklog location={log} ! fakesink")
    return read_jsonl(str(log))


def errors(results, truth, kind):
    only = [dict(t, landmarks=[m for m in t["landmarks"]
                               if m["kind"] == kind
                               and m["range"] <= MAX_RANGE + 1e-9])
            for t in truth]
    ev = E.evaluate(results, only)
    rel = np.abs([e / r for r, e, _ in ev.range_errors])
    bearing = np.abs([math.degrees(b) for _, _, b in ev.range_errors])
    return rel, bearing, ev


@pytest.mark.parametrize("kind", ["disc", "ball"])
@pytest.mark.parametrize("method", ["ground", "fused"])
def test_range_sweep_accuracy(gst, sweep, tmp_path, kind, method):
    results = range_run(gst, sweep, kind, method, tmp_path / "log.jsonl")
    truth = read_jsonl(str(sweep / "truth.jsonl"))
    rel, bearing, ev = errors(results, truth, kind)
    print(f"\n{kind} {method}: n={rel.size} range median "
          f"{100 * np.median(rel):.2f}% p95 "
          f"{100 * np.percentile(rel, 95):.2f}% bearing median "
          f"{np.median(bearing):.3f} deg p95 "
          f"{np.percentile(bearing, 95):.3f} deg")
    # discs beyond about 2 m and balls beyond about 3 m are not detected by
    # blobroundness's defaults; what is detected is measured
    assert rel.size >= (35 if kind == "disc" else 50)
    assert np.median(rel) <= 0.01
    assert np.percentile(rel, 95) <= 0.02
    assert np.median(bearing) <= 0.3
    # every detection has a landmark-range, finite and non-negative
    for res in results:
        for det in res.get("detections", []):
            rng = det.get("range")
            assert rng is not None
            if rng.get("no-floor"):
                assert "range" not in rng
            else:
                assert rng["range"] >= 0 and math.isfinite(rng["range"])
                assert rng["method"] in ("ground", "fused")
                assert abs(math.hypot(rng["ground-x"], rng["ground-y"]) -
                           rng["range"]) < 1e-9


def test_size_range_is_reported(gst, sweep, tmp_path):
    results = range_run(gst, sweep, "ball", "size", tmp_path / "log.jsonl")
    truth = read_jsonl(str(sweep / "truth.jsonl"))
    rel, _, _ = errors(results, truth, "ball")
    assert rel.size >= 50
    assert np.median(rel) <= 0.02
    methods = {d["range"]["method"] for r in results
               for d in r.get("detections", []) if "range" in d}
    assert methods == {"size"}
