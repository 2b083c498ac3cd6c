"""Synthetic camera views of the landmark world with exact ground truth.

No camera is needed: ``gst-landmark synth SCENARIO --out DIR`` renders a
robot's camera view of a flat floor with coloured discs and balls (and
coded markers: banded beacons and posts, striped cones) by exact ray
casting (numpy; 4 x 4 rays per pixel wherever an object or a
surface boundary may be) and writes, in DIR:

- ``clip.avi``: the frames as MJPEG in AVI (appsrc ! videoconvert !
  jpegenc ! avimux), optionally also lossless PNGs or raw RGB;
- ``truth.jsonl``: per frame ``{"frame", "pts", "robot": {"x", "y",
  "heading"}, "landmarks": [{"id", "class", "kind", "u", "v",
  "u_centre", "v_centre", "pixels", "range", "bearing", "ground_x",
  "ground_y", "cut", "occluded"}]}`` for every landmark with visible
  pixels (``u, v``: coverage-weighted centroid of the visible pixels;
  ``u_centre, v_centre``: projection of the 3-D centre, null behind the
  camera; a coded marker adds ``code``, its and each band's image
  ``box`` and the image of its floor contact, docs/synth.md);
- ``scene.json`` (camera, palette, map, floor, effects, ...), ``map.json``
  (docs/conventions.md), ``palette.json`` (the scene palette);
- ``odometry.jsonl``: wheel odometry from the true path with a scale
  error, heading drift and per-step slip (``odometry``), in the format
  ``landmarkslam odometry=`` reads;
- ``frame0.png`` and ``mask0.png`` (value k = class k of the scene
  palette, 0 = none), or ``masks/NNNNNN.png`` for every frame;
- ``chart.png`` and ``chart-mask.png``: a colour chart of every class of
  the scene palette (a disc of each marker colour, a square of each other
  floor, the wall behind) under frame 0's camera, floor and lighting; the
  mask marks the pixels wholly of one class, for ``gst-landmark palette
  learn --mask`` (``chart.render_chart``).

``scene.json`` also holds ``visibility``: the histogram of frames by the
number of landmarks visible with at least 150 pixels.

From Python::

    from gstlandmark import synth
    summary = synth.render_scenario("path", "out/path", seed=1)
    scene = synth.Scene(landmarks=[synth.Landmark("L1", "red", 1, 0, 0.1)])
    rgb, truth, mask = synth.render_frame(scene, synth.Pose(0, 0, 0))

Geometry follows docs/conventions.md exactly (``camera.Camera``).
"""

from .camera import Camera, Pose, ground_coordinates, wrap_angle
from .world import (Distractor, Effects, Landmark, Scene, Segment, Walls,
                    load_map, marker_palette)
from .render import render_frame

__all__ = ["Camera", "Pose", "Scene", "Landmark", "Distractor", "Walls",
           "Effects", "Segment", "render_frame", "render_scenario",
           "write_outputs", "build_scenario", "SCENARIOS",
           "ground_coordinates", "wrap_angle", "load_map",
           "marker_palette"]


def __getattr__(name):
    # The writer needs GStreamer: import it only when asked for.
    if name in ("render_scenario", "write_outputs"):
        from . import writer
        return getattr(writer, name)
    if name in ("build_scenario", "SCENARIOS"):
        from . import scenarios
        return getattr(scenarios, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
