"""landmarkslam's odometry slip properties (docs/landmarkslam.md,
"Properties"): with no detections the pose is carried by the odometry
file alone, so its stated covariance is the slip the properties state,
added up over the run, and can be checked exactly:

- turning in place, the heading variance is odometry-turn-slip^2 times the
  angle turned (nothing else moves it: no distance, so neither the scale
  error nor the drift per metre adds any);
- driving straight, the heading variance is the drift prior's
  (0.05 rad/m times the distance, squared) plus odometry-heading-slip^2
  times the distance, and odometry-slip adds 2 slip^2 times the distance
  to the trace of the position covariance (along and across);
- a value set while playing applies from the next frames on."""

import json

import numpy as np

from gstlandmark import meta

FRAMES = 60
DRIFT_PRIOR = 0.05     # SlamOptions odo_drift_sigma, rad per m


def run(gst, tmp_path, step, props, change=None):
    """Pose and covariance per frame of a run of FRAMES frames with no
    detections and the odometry increment `step` (dx, dheading) per frame;
    `change` = (frame, {property: value}) set while playing."""
    odo = tmp_path / "odometry.jsonl"
    odo.write_text("".join(json.dumps({"t": k / 30, "dx": step[0], "dy": 0.0,
                                       "dheading": step[1]}) + "\n"
                           for k in range(1, FRAMES + 2)))
    caps = "video/x-raw,width=64,height=48,framerate=30/1"
    settings = " ".join(f"{k}={v}" for k, v in props.items())
    pipe = gst.parse_launch(f"videotestsrc num-buffers={FRAMES} ! {caps} ! "
                            f"landmarkslam name=s odometry={odo} {settings} "
                            f"! fakesink name=sink sync=false")
    slam = pipe.get_by_name("s")
    poses = []

    def before(pad, info):
        if change is not None and len(poses) == change[0]:
            for name, value in change[1].items():
                slam.set_property(name, value)
        return gst.PadProbeReturn.OK

    def after(pad, info):
        p = meta.pose(info.get_buffer())
        poses.append((p.x, p.y, p.heading,
                      np.array(p.fields["covariance"]).reshape(3, 3)))
        return gst.PadProbeReturn.OK

    slam.get_static_pad("sink").add_probe(gst.PadProbeType.BUFFER, before)
    pipe.get_by_name("sink").get_static_pad("sink").add_probe(
        gst.PadProbeType.BUFFER, after)
    bus = pipe.get_bus()
    try:
        pipe.set_state(gst.State.PLAYING)
        msg = bus.timed_pop_filtered(30 * gst.SECOND, gst.MessageType.EOS |
                                     gst.MessageType.ERROR)
        assert msg is not None and msg.type == gst.MessageType.EOS, \
            msg and msg.parse_error()
    finally:
        pipe.set_state(gst.State.NULL)
    assert len(poses) == FRAMES
    return poses


def test_defaults(gst):
    s = gst.ElementFactory.make("landmarkslam")
    for name in ("odometry-slip", "odometry-heading-slip",
                 "odometry-turn-slip"):
        assert s.get_property(name) == 0.002, name
    assert s.get_property("odometry-slip-adapt") is True
    # learnt upward only unless told otherwise; the floor's range
    assert s.get_property("odometry-slip-scale-min") == 1.0
    spec = s.find_property("odometry-slip-scale-min")
    assert (spec.minimum, spec.maximum) == (0.25, 1.0)


def test_turn_slip_in_place(gst, tmp_path):
    for turn in (0.001, 0.004):
        poses = run(gst, tmp_path, (0.0, 0.02), {"odometry-turn-slip": turn,
                                                 "odometry-slip": 0.5,
                                                 "odometry-heading-slip": 0.5})
        x, y, heading, cov = poses[-1]
        assert 0.5 < heading < 1.5, heading
        assert x == y == 0 and cov[0, 0] == cov[1, 1] == 0, poses[-1]
        assert np.isclose(cov[2, 2], turn ** 2 * heading, rtol=1e-6), \
            (cov[2, 2], turn ** 2 * heading)


def test_slip_driving_straight(gst, tmp_path):
    trace = {}
    for slip, heading_slip in ((0.001, 0.001), (0.004, 0.001),
                               (0.001, 0.004)):
        poses = run(gst, tmp_path, (0.01, 0.0), {
            "odometry-slip": slip, "odometry-heading-slip": heading_slip,
            "odometry-turn-slip": 0.5})
        x, y, heading, cov = poses[-1]
        assert 0.4 < x < 0.7 and y == heading == 0, poses[-1]
        expected = (DRIFT_PRIOR * x) ** 2 + heading_slip ** 2 * x
        assert np.isclose(cov[2, 2], expected, rtol=1e-6), (cov, expected)
        trace[slip, heading_slip] = cov[0, 0] + cov[1, 1], x
    # the translation slip alone: the same run but for odometry-slip
    (t4, d), (t1, _) = trace[0.004, 0.001], trace[0.001, 0.001]
    assert np.isclose(t4 - t1, 2 * (0.004 ** 2 - 0.001 ** 2) * d,
                      rtol=1e-6), (t4 - t1, d)
    # and the heading slip reaches the position (across the path)
    assert trace[0.001, 0.004][0] > t1


def test_set_while_playing(gst, tmp_path):
    poses = run(gst, tmp_path, (0.0, 0.02), {"odometry-turn-slip": 0.001},
                change=(30, {"odometry-turn-slip": 0.003}))
    heading = np.array([p[2] for p in poses])
    var = np.array([p[3][2, 2] for p in poses])
    # turn-slip^2 per radian, on the frames that turned (a frame's interval
    # may hold no increment of the file)
    turned = np.diff(heading) > 0
    rate = np.diff(var)[turned] / np.diff(heading)[turned]
    early, late = rate[:turned[:29].sum()], rate[turned[:32].sum():]
    assert len(early) > 10 and len(late) > 10, turned
    assert np.allclose(early, 0.001 ** 2, rtol=1e-6), rate
    assert np.allclose(late, 0.003 ** 2, rtol=1e-6), rate
