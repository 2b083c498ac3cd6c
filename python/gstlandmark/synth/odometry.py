"""A wheel-odometry log from the true path, with the errors real wheel
odometry has, in the JSON-lines format ``landmarkslam odometry=`` reads
(docs/landmarkslam.md, "Odometry file").

Each line is the robot-frame motion between two consecutive frames,
stamped with the later frame's stream time (or, at a ``rate_hz`` of its
own, between two encoder readings, which then fall between frames as a
real robot's do): ``dx`` forward and ``dy``
left in metres, ``dheading`` counter-clockwise in radians, in the robot
frame at the start of the step.  The motion is the camera's floor point's
(``frame`` "camera"), or that of the turning centre the camera is
``camera_forward_m`` ahead of (``frame`` "turning-centre", what a
differential drive's wheel odometry reports; the same as the camera's for
a trajectory without an offset).  Errors, each optional:

- **scale**: every step's translation is ``1 + scale`` times the true one
  (wheel radius or encoder resolution off);
- **heading drift**: ``drift`` radians are added per metre travelled
  (one wheel slightly larger than the other);
- **slip**: random walks over the distance driven and the angle turned,
  so that the spread after a given path does not depend on how often the
  encoders are read: per step of length ``L`` turning ``dth``, the
  translation gains ``N(0, slip^2 L)`` metres along the step and as much
  across it, the heading ``N(0, turn_slip^2 |dth| + heading_slip^2 L)``
  radians; drawn from a generator seeded by the scenario's seed, so a
  clip and its log are reproducible, or by a seed of the odometry's own
  (``seed``, ``--odometry-seed``): other draws of the same errors on the
  same clip.  A variant's number is mixed in too, so that the variants
  of one seed (the Accuracy clips) do not all slip alike.
"""

import json
import math
import numbers
from dataclasses import dataclass
from typing import Optional

import numpy as np

# Added to the scenario seed so the odometry's random stream is its own
# and does not shift when the scene draws more numbers.
SEED_STREAM = 0x0D0

# What the odometry reports the motion of (docs/synth.md).
FRAMES = ("camera", "turning-centre")


@dataclass
class OdometryErrors:
    """The error model; the defaults are those of docs/synth.md."""
    scale: float = 0.02          # relative translation error
    drift_deg_per_m: float = 1.0  # heading drift, degrees per metre
    slip: float = 0.0011         # m per sqrt(m), along and across
    heading_slip: float = 0.0011  # rad per sqrt(m) driven
    turn_slip: float = 0.0018    # rad per sqrt(rad) turned
    rate_hz: Optional[float] = None  # None: one step per frame
    frame: str = "camera"        # or "turning-centre"
    seed: Optional[int] = None   # None: the scenario's seed

    def check(self):
        """ValueError naming the option when a value is out of range."""
        for name, value in (("scale", self.scale),
                            ("drift", self.drift_deg_per_m),
                            ("slip", self.slip),
                            ("heading-slip", self.heading_slip),
                            ("turn-slip", self.turn_slip)):
            if not math.isfinite(value):
                raise ValueError(f"--odometry-{name} must be finite, got "
                                 f"{value!r}")
        if self.scale <= -1:
            raise ValueError(f"--odometry-scale must be > -1 (a fraction: "
                             f"0.02 is 2 %), got {self.scale!r}")
        for name, value in (("slip", self.slip),
                            ("heading-slip", self.heading_slip),
                            ("turn-slip", self.turn_slip)):
            if value < 0:
                raise ValueError(f"--odometry-{name} must be >= 0, got "
                                 f"{value!r}")
        if self.rate_hz is not None and not (
                math.isfinite(self.rate_hz) and self.rate_hz > 0):
            raise ValueError(f"--odometry-rate must be a positive number "
                             f"of Hz, got {self.rate_hz!r}")
        if self.frame not in FRAMES:
            raise ValueError(f"--odometry-frame must be one of "
                             f"{', '.join(FRAMES)}, got {self.frame!r}")
        if self.seed is not None and not (
                isinstance(self.seed, numbers.Integral)
                and not isinstance(self.seed, bool) and self.seed >= 0):
            raise ValueError(f"--odometry-seed must be an integer >= 0, "
                             f"got {self.seed!r}")

    def to_json(self):
        out = {"scale": self.scale, "drift_deg_per_m": self.drift_deg_per_m,
               "slip_m_per_sqrt_m": self.slip,
               "heading_slip_rad_per_sqrt_m": self.heading_slip,
               "turn_slip_rad_per_sqrt_rad": self.turn_slip,
               "rate_hz": self.rate_hz, "frame": self.frame}
        # only when set, so the scene.json of a default clip is as before
        if self.seed is not None:
            out["seed"] = int(self.seed)
        return out


def no_errors(**kw):
    """Odometry without any error (exact), or with only those of ``kw``."""
    return OdometryErrors(**{"scale": 0.0, "drift_deg_per_m": 0.0,
                             "slip": 0.0, "heading_slip": 0.0,
                             "turn_slip": 0.0, **kw})


def relative_motion(a, b):
    """The motion from pose ``a`` to pose ``b`` (``x, y, heading``) in
    ``a``'s robot frame: (dx forward, dy left, dheading wrapped)."""
    c, s = math.cos(a.heading), math.sin(a.heading)
    wx, wy = b.x - a.x, b.y - a.y
    return (c * wx + s * wy, -s * wx + c * wy,
            math.remainder(b.heading - a.heading, 2 * math.pi))


def odometry_steps(poses, times, errors=None, seed=0, variant=None):
    """One increment per pair of consecutive ``poses`` (objects with
    ``x``, ``y``, ``heading``), stamped with the later of ``times``
    (seconds), with ``errors`` (``OdometryErrors``; default: none); the
    slip drawn from ``seed`` and, when given, a ``variant`` number."""
    errors = errors or no_errors()
    errors.check()
    rng = np.random.default_rng(
        (int(seed), SEED_STREAM) if variant is None
        # + 1: a trailing 0 would seed as if left out (variant 0 as none)
        else (int(seed), SEED_STREAM, int(variant) + 1))
    drift = math.radians(errors.drift_deg_per_m)
    noisy = errors.slip > 0 or errors.heading_slip > 0 or \
        errors.turn_slip > 0
    steps = []
    for a, b, t in zip(poses, poses[1:], times[1:]):
        dx, dy, dh = relative_motion(a, b)
        dist = math.hypot(dx, dy)
        along, across, turn = (rng.standard_normal(3) if noisy
                               else (0.0, 0.0, 0.0))
        # slip: sigma^2 per metre (per radian turned), whatever the rate
        along *= errors.slip * math.sqrt(dist)
        across *= errors.slip * math.sqrt(dist)
        turn *= math.sqrt(errors.turn_slip ** 2 * abs(dh)
                          + errors.heading_slip ** 2 * dist)
        ux, uy = (dx / dist, dy / dist) if dist > 0 else (1.0, 0.0)
        k = 1.0 + errors.scale
        steps.append({"t": t,
                      "dx": dx * k + along * ux - across * uy,
                      "dy": dy * k + along * uy + across * ux,
                      "dheading": dh + drift * dist + turn})
    return steps


def frame_time(frame, fps):
    """A frame's stream time in seconds, as its buffer's pts (truth.jsonl
    ``pts``) gives it to the elements."""
    return (int(frame) * 1_000_000_000 // int(fps)) / 1e9


def scene_odometry(scene, frames, errors=None, seed=None):
    """The odometry steps of ``frames`` frames of ``scene``'s path (the
    poses the renderer used, or with ``errors.frame`` "turning-centre"
    those of the turning centre behind the camera): one per frame, or at
    ``errors.rate_hz`` from 0 to the last frame's time.  Seeded by
    ``seed``, else ``errors.seed``, else the scene's seed, with a
    variant's number mixed in."""
    from .scenarios import Offset, Static
    trajectory = scene.trajectory or Static()
    if errors is not None:
        errors.check()
        if errors.frame == "turning-centre" and isinstance(trajectory,
                                                           Offset):
            trajectory = trajectory.inner
    rate = errors.rate_hz if errors is not None else None
    if rate is None:
        times = [frame_time(i, scene.fps) for i in range(frames)]
        poses = [trajectory.pose(i / scene.fps) for i in range(frames)]
    else:
        end = (frames - 1) / scene.fps
        times = [k / rate for k in range(int(math.floor(end * rate)) + 1)]
        poses = [trajectory.pose(t) for t in times]
    if seed is None:
        seed = errors.seed if errors is not None and \
            errors.seed is not None else scene.seed
    variant = ((scene.notes or {}).get("variant") or {}).get("number")
    return odometry_steps(poses, times, errors, seed=seed, variant=variant)


def write_odometry(path, steps):
    """Write the steps as JSON lines (full float precision)."""
    with open(path, "w", encoding="utf-8") as f:
        for step in steps:
            f.write(json.dumps(step) + "\n")
