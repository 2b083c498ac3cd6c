"""The odometry log gst-landmark synth writes beside the truth
(synth/odometry.py, docs/synth.md): integrated here by composing the
robot-frame steps independently of the module, it gives back the true
path when every error is 0; a scale error s lengthens the path by
exactly 1 + s; a heading drift of d degrees per metre turns it by d times
the length; the slip is a random walk over the distance, its spread
after a straight drive the closed form's at 30 and at 100 steps a second,
and follows the seed; the turning centre's log composes to the path
behind the camera."""

import json
import math

import numpy as np
import pytest

from gstlandmark.commands import cli
from gstlandmark.synth.odometry import (OdometryErrors, frame_time,
                                        no_errors, odometry_steps,
                                        scene_odometry)
from gstlandmark.synth.scenarios import Offset, build_scenario
from gstlandmark.synth.variants import draw_variant

FRAMES = 600  # two loops of the path scenario at 30 frames/s


@pytest.fixture(scope="module")
def path_scene():
    scene, n = build_scenario("path", seed=3, frames=FRAMES)
    return scene, n


def integrate(start, steps):
    """Compose robot-frame steps from a start pose: the poses after each."""
    x, y, h = start
    out = []
    for s in steps:
        c, sn = math.cos(h), math.sin(h)
        x += c * s["dx"] - sn * s["dy"]
        y += sn * s["dx"] + c * s["dy"]
        h += s["dheading"]
        out.append((x, y, h))
    return out


def true_poses(scene, n):
    return [scene.trajectory.pose(i / scene.fps) for i in range(n)]


def test_exact_log_integrates_to_the_true_path(path_scene):
    scene, n = path_scene
    steps = scene_odometry(scene, n, no_errors())
    truth = true_poses(scene, n)
    assert len(steps) == n - 1
    # stamped with the later frame's stream time, as its buffer's pts
    assert [s["t"] for s in steps] == [
        (i * 1_000_000_000 // scene.fps) / 1e9 for i in range(1, n)]
    t0 = truth[0]
    for (x, y, h), t in zip(integrate((t0.x, t0.y, t0.heading), steps),
                            truth[1:]):
        assert abs(x - t.x) < 1e-9 and abs(y - t.y) < 1e-9
        assert abs(math.remainder(h - t.heading, 2 * math.pi)) < 1e-9


def test_own_rate_integrates_to_the_true_path(path_scene):
    """At 100 Hz the steps fall between frames; each reading still
    composes to the true pose at its own time."""
    scene, n = path_scene
    steps = scene_odometry(scene, n, no_errors(rate_hz=100.0))
    end = (n - 1) / scene.fps
    assert len(steps) == math.floor(end * 100)
    times = [s["t"] for s in steps]
    assert times == [k / 100 for k in range(1, len(steps) + 1)]
    assert times[-1] <= end < times[-1] + 0.01
    t0 = scene.trajectory.pose(0.0)
    for (x, y, h), t in zip(integrate((t0.x, t0.y, t0.heading), steps),
                            times):
        p = scene.trajectory.pose(t)
        assert abs(x - p.x) < 1e-9 and abs(y - p.y) < 1e-9
        assert abs(math.remainder(h - p.heading, 2 * math.pi)) < 1e-9
    with pytest.raises(ValueError, match="--odometry-rate"):
        scene_odometry(scene, n, no_errors(rate_hz=0.0))


def path_length(steps):
    return sum(math.hypot(s["dx"], s["dy"]) for s in steps)


def test_scale_error_lengthens_the_path(path_scene):
    scene, n = path_scene
    loop = scene.trajectory
    # the loop's own arc length, times the laps driven (not the steps)
    true_length = loop.length * ((n - 1) / scene.fps) / loop.period_s
    assert path_length(scene_odometry(scene, n, no_errors())) == \
        pytest.approx(true_length, rel=1e-4)
    for s in (0.02, -0.05):
        steps = scene_odometry(scene, n, no_errors(scale=s))
        assert path_length(steps) == pytest.approx((1 + s) * true_length,
                                                   rel=1e-4)


def test_straight_line_scale_is_exact():
    class Line:
        def __init__(self, t):
            self.x, self.y, self.heading = 0.3 * t, 0.0, 0.0
    times = [i / 30 for i in range(31)]
    steps = odometry_steps([Line(t) for t in times], times,
                           no_errors(scale=0.02))
    assert path_length(steps) == pytest.approx(1.02 * 0.3, abs=1e-12)
    assert integrate((0, 0, 0), steps)[-1] == pytest.approx(
        (1.02 * 0.3, 0.0, 0.0), abs=1e-12)


def test_heading_drift_per_metre(path_scene):
    scene, n = path_scene
    exact = scene_odometry(scene, n, no_errors())
    drifted = scene_odometry(scene, n, no_errors(drift_deg_per_m=1.0))
    turned = sum(s["dheading"] for s in drifted) - \
        sum(s["dheading"] for s in exact)
    assert turned == pytest.approx(math.radians(1.0) * path_length(exact),
                                   rel=1e-9)
    # the translation is untouched
    assert [s["dx"] for s in drifted] == [s["dx"] for s in exact]


class Line:
    """A straight drive along x at 0.5 m/s."""
    def __init__(self, t):
        self.x, self.y, self.heading = 0.5 * t, 0.0, 0.0


def test_slip_is_a_random_walk_over_distance():
    """A straight drive of 2 m, 300 seeds, at 30 and at 100 steps a
    second: the composed end pose's spread is the closed form's whatever
    the rate (along: slip sqrt(L); across: slip^2 L plus the heading's
    random walk integrated, heading_slip^2 L^3 / 3; heading: heading_slip
    sqrt(L)). A per-step slip proportional to the step would spread
    sqrt(30 / 100) = 0.55 times as much at 100 Hz."""
    slip, heading_slip, length, runs = 0.004, 0.003, 2.0, 300
    errors = no_errors(slip=slip, heading_slip=heading_slip,
                       turn_slip=0.01)
    exact = (slip * math.sqrt(length),
             math.sqrt(slip ** 2 * length + heading_slip ** 2 *
                       length ** 3 / 3),
             heading_slip * math.sqrt(length))
    spread = {}
    for rate in (30, 100):
        n = int(round(length / 0.5 * rate))
        times = [k / rate for k in range(n + 1)]
        poses = [Line(t) for t in times]
        ends = np.array([integrate((0, 0, 0), odometry_steps(
            poses, times, errors, seed=s))[-1] for s in range(runs)])
        ends[:, 0] -= length
        spread[rate] = np.sqrt(np.mean(ends ** 2, axis=0))
        # 300 runs: a sigma's sampling error is about 4 %
        assert spread[rate] == pytest.approx(exact, rel=0.15), rate
    assert spread[100] == pytest.approx(spread[30], rel=0.2)


def test_turn_slip_per_radian():
    """A turn in place of one revolution at 30 steps a second: the heading
    spreads as turn_slip sqrt(2 pi) (200 seeds, within 15 %), and the
    position not at all."""
    class Spin:
        def __init__(self, t):
            self.x, self.y, self.heading = 0.0, 0.0, 0.5 * t
    times = [k / 30 for k in range(int(round(2 * math.pi / 0.5 * 30)) + 1)]
    poses = [Spin(t) for t in times]
    errors = no_errors(slip=0.004, turn_slip=0.01)
    ends = np.array([integrate((0, 0, 0), odometry_steps(
        poses, times, errors, seed=s))[-1] for s in range(200)])
    turned = poses[-1].heading
    assert np.sqrt(np.mean((ends[:, 2] - turned) ** 2)) == pytest.approx(
        0.01 * math.sqrt(turned), rel=0.15)
    assert np.abs(ends[:, :2]).max() < 1e-12


def test_slip_follows_the_seed(path_scene):
    scene, n = path_scene
    noisy = scene_odometry(scene, n, no_errors(slip=0.01))
    exact = scene_odometry(scene, n, no_errors())
    assert [s["dx"] for s in noisy] != [s["dx"] for s in exact]
    # the scene's seed fixes the draws: the same again, another differs
    assert scene_odometry(scene, n, no_errors(slip=0.01)) == noisy
    scene.seed += 1
    try:
        other = scene_odometry(scene, n, no_errors(slip=0.01))
    finally:
        scene.seed -= 1
    assert [s["dx"] for s in other] != [s["dx"] for s in noisy]
    # an odometry seed of its own: another draw on the same scene, the
    # same again with the same seed, given as argument or in the errors
    drawn = scene_odometry(scene, n, no_errors(slip=0.01), seed=7)
    assert [s["dx"] for s in drawn] != [s["dx"] for s in noisy]
    assert scene_odometry(scene, n, no_errors(slip=0.01, seed=7)) == drawn
    assert scene_odometry(scene, n, no_errors(slip=0.01),
                          seed=scene.seed) == noisy


def test_variants_of_one_seed_slip_apart():
    """The variants of one scenario seed (as the Accuracy clips are) draw
    their slip apart: the heading's normalised slip per step, N(0, 1)
    draws, differs between two variants and is the same for one variant
    built again; a scene without a variant draws as before."""
    def normalised(number):
        scene, n = build_scenario("path", seed=0, frames=90,
                                  variant=draw_variant("path", number),
                                  hfov_deg=54.0, height_m=0.2,
                                  tilt_deg=18.0)
        assert scene.notes["variant"]["number"] == number
        noisy = scene_odometry(scene, n, no_errors(heading_slip=0.01))
        exact = scene_odometry(scene, n, no_errors())
        return [(a["dheading"] - b["dheading"])
                / (0.01 * math.sqrt(math.hypot(b["dx"], b["dy"])))
                for a, b in zip(noisy, exact) if b["dx"] > 1e-4]
    one, two = normalised(1), normalised(2)
    assert len(one) > 50 and len(two) > 50
    assert normalised(1) == pytest.approx(one, abs=1e-9)
    # independent draws: not the same sequence, not correlated
    k = min(len(one), len(two))
    assert abs(np.corrcoef(one[:k], two[:k])[0, 1]) < 0.4
    scene, n = build_scenario("path", seed=0, frames=90)
    poses = true_poses(scene, n)
    times = [frame_time(i, scene.fps) for i in range(n)]
    # variant 0 is a variant too, not the scene without one
    assert odometry_steps(poses, times, no_errors(slip=0.01), seed=0,
                          variant=0) != \
        odometry_steps(poses, times, no_errors(slip=0.01), seed=0)
    assert scene_odometry(scene, n, no_errors(slip=0.01)) == \
        odometry_steps(true_poses(scene, n),
                       [frame_time(i, scene.fps) for i in range(n)],
                       no_errors(slip=0.01), seed=0)


def test_turning_centre_log(path_scene):
    """With the camera 0.12 m ahead of the turning centre, the
    turning-centre log composes to the inner path (not the camera's, which
    swings out on the turns); without an offset it is the camera's log."""
    scene, n = path_scene
    camera = scene_odometry(scene, n, no_errors())
    assert scene_odometry(scene, n, no_errors(frame="turning-centre")) \
        == camera
    inner = scene.trajectory
    scene.trajectory = Offset(inner, 0.12)
    try:
        steps = scene_odometry(scene, n, no_errors(frame="turning-centre"))
        swung = scene_odometry(scene, n, no_errors())
    finally:
        scene.trajectory = inner
    t0 = inner.pose(0.0)
    for (x, y, h), i in zip(integrate((t0.x, t0.y, t0.heading), steps),
                            range(1, n)):
        p = inner.pose(i / scene.fps)
        assert abs(x - p.x) < 1e-9 and abs(y - p.y) < 1e-9
    # the camera's own log differs by the swing: a few mm a step
    assert max(abs(a["dy"] - b["dy"]) for a, b in zip(steps, swung)) > 1e-3
    with pytest.raises(ValueError, match="--odometry-frame"):
        scene_odometry(scene, n, no_errors(frame="axle"))


def test_frame_time_matches_the_truth_pts():
    assert frame_time(1, 30) == 33333333 / 1e9
    assert frame_time(0, 25) == 0.0


def read_lines(path):
    return [json.loads(x) for x in path.read_text().splitlines()]


def test_cli_writes_the_log_and_its_options(tmp_path, capsys):
    args = ["synth", "path", "--frames", "4", "--size", "96x72",
            "--no-progress", "--out"]
    assert cli.main(args + [str(tmp_path / "a"),
                            "--odometry-scale", "0", "--odometry-drift",
                            "0", "--odometry-slip", "0",
                            "--odometry-heading-slip", "0",
                            "--odometry-turn-slip", "0"]) == 0
    assert "odometry.jsonl" in capsys.readouterr().out
    exact = read_lines(tmp_path / "a" / "odometry.jsonl")
    truth = read_lines(tmp_path / "a" / "truth.jsonl")
    assert [s["t"] for s in exact] == [t["pts"] / 1e9 for t in truth[1:]]
    scene = json.loads((tmp_path / "a" / "scene.json").read_text())
    assert scene["odometry"] == {"file": "odometry.jsonl", "scale": 0.0,
                                 "drift_deg_per_m": 0.0,
                                 "slip_m_per_sqrt_m": 0.0,
                                 "heading_slip_rad_per_sqrt_m": 0.0,
                                 "turn_slip_rad_per_sqrt_rad": 0.0,
                                 "rate_hz": None, "frame": "camera"}
    # the default: 2 % scale, 1 degree per metre, slip 1.1 mm per sqrt(m)
    assert cli.main(args + [str(tmp_path / "b")]) == 0
    default = read_lines(tmp_path / "b" / "odometry.jsonl")
    assert path_length(default) == pytest.approx(1.02 * path_length(exact),
                                                 rel=0.01)
    assert cli.main(args + [str(tmp_path / "c"), "--no-odometry"]) == 0
    assert not (tmp_path / "c" / "odometry.jsonl").exists()
    assert json.loads((tmp_path / "c" / "scene.json").read_text())[
        "odometry"] is None
    capsys.readouterr()
    assert cli.main(args + [str(tmp_path / "d"), "--odometry-scale",
                            "-1.5"]) == 1
    assert "--odometry-scale" in capsys.readouterr().err
    assert cli.main(args + [str(tmp_path / "e"), "--odometry-slip",
                            "-0.1"]) == 1
    assert "--odometry-slip" in capsys.readouterr().err
    assert not (tmp_path / "d" / "truth.jsonl").exists()


def test_cli_odometry_seed(tmp_path, capsys):
    """--odometry-seed draws another log for the same clip: the truth is
    the same, the log another, recorded in scene.json; a negative seed
    is refused, naming the option."""
    args = ["synth", "path", "--frames", "6", "--size", "96x72",
            "--no-progress", "--out"]
    assert cli.main(args + [str(tmp_path / "a")]) == 0
    assert cli.main(args + [str(tmp_path / "b"), "--odometry-seed",
                            "5"]) == 0
    assert (tmp_path / "a" / "truth.jsonl").read_text() == \
        (tmp_path / "b" / "truth.jsonl").read_text()
    first = read_lines(tmp_path / "a" / "odometry.jsonl")
    other = read_lines(tmp_path / "b" / "odometry.jsonl")
    assert [s["t"] for s in first] == [s["t"] for s in other]
    assert [s["dx"] for s in first] != [s["dx"] for s in other]
    scene, n = build_scenario("path", seed=0, frames=6)
    assert other == scene_odometry(scene, n, OdometryErrors(), seed=5)
    assert json.loads((tmp_path / "b" / "scene.json").read_text())[
        "odometry"]["seed"] == 5
    assert "seed" not in json.loads(
        (tmp_path / "a" / "scene.json").read_text())["odometry"]
    capsys.readouterr()
    assert cli.main(args + [str(tmp_path / "c"), "--odometry-seed",
                            "-1"]) == 1
    assert "--odometry-seed" in capsys.readouterr().err
    # from the API: a numpy integer is a seed, a boolean is not
    assert scene_odometry(scene, n, OdometryErrors(seed=np.int64(5))) == \
        other
    with pytest.raises(ValueError, match="--odometry-seed"):
        OdometryErrors(seed=True).check()
