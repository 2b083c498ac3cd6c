"""Random variants of a scenario: cameras, light, floors, marker sizes,
photometry, layout and path that nobody tuned for.

``draw_variant(scenario, n)`` draws, deterministically from ``n`` and the
scenario's name, every parameter within ``RANGES`` and returns it as a
JSON-able dict that ``scenarios.build_scenario(..., variant=...)`` applies
and ``scene.json`` records (``notes.variant``).

The tilt is not drawn freely: a camera tilted up sees no floor and one
tilted steeply sees only its feet.  It is drawn as the floor range seen
at the image centre, then kept, where the field of view allows, between
a tilt whose top row reaches ``FAR_M`` and one whose bottom row sees the
floor ``NEAR_M`` away (when both cannot hold, halfway between them).

The path's field and the distractor field scale with how far the
variant's discs stay large enough to count (``disc_reach``).
"""

import math
import zlib

import numpy as np

from .floors import FLOOR_NAMES

# The documented range of every drawn value (inclusive).
RANGES = {
    "height_m": (0.14, 0.5),
    "hfov_deg": (45.0, 80.0),
    "centre_range_m": (0.5, 1.3),
    "roll_deg": (-2.0, 2.0),
    "forward_offset_m": (0.0, 0.15),
    "light_azimuth_deg": (0.0, 360.0),
    "light_elevation_deg": (25.0, 85.0),
    "ball_shading": (0.3, 0.8),       # 1 - ambient light share
    "disc_d": (0.08, 0.30),
    "ball_d": (0.08, 0.30),           # and at most 1.5 x camera height
    "gain": (0.6, 1.4),
    "exposure_drift_stops": (0.0, 0.25),
    "drift_period_s": (4.0, 12.0),
    "wb_gain": (0.92, 1.08),          # red and blue, +-8 %
    "wb_drift": (0.0, 0.03),
    "vignette": (0.0, 0.4),
    "noise_sigma": (0.5, 3.0),
    "jpeg_quality": (70, 95),
    "shutter": (0.2, 0.6),
    "field_m": (2.0, 6.0),
    "range_scale": (0.6, 1.5),
    "distractor_scale": (0.7, 2.0),
}
MOTION_BLUR = (0, 0, 3)               # sub-frames; a third are blurred
NEAR_M, FAR_M = 0.45, 4.0
ASPECT = 480.0 / 640.0                 # vertical / horizontal image size
# A landmark counts (is required of the detector) from this many pixels.
REQUIRED_PIXELS = 113.0
PLAN_SIZE = 16                         # landmarks of the path scenario


def disc_reach(fx, disc_d, height_m, pixels=REQUIRED_PIXELS):
    """Range (m) out to which a floor disc of ``disc_d`` covers
    ``pixels``: its image is an ellipse about f d / r wide and h / r of
    that tall, so the area is pi/4 f^2 d^2 h / r^3."""
    return (math.pi / 4 * fx * fx * disc_d * disc_d * height_m
            / pixels) ** (1.0 / 3.0)


def choose_tilt(height_m, hfov_deg, centre_range_m, aspect=ASPECT):
    """Tilt (degrees) that puts the floor at ``centre_range_m`` on the
    image centre, kept where possible so that the top row reaches FAR_M
    and the bottom row sees the floor NEAR_M away."""
    half_v = math.degrees(math.atan(
        math.tan(math.radians(hfov_deg) / 2) * aspect))
    tilt = math.degrees(math.atan2(height_m, centre_range_m))
    most = math.degrees(math.atan2(height_m, FAR_M)) + half_v
    least = math.degrees(math.atan2(height_m, NEAR_M)) - half_v
    if least > most:
        return 0.5 * (least + most)
    return min(max(tilt, least), most)


def _seed(scenario, n):
    return [int(n), zlib.crc32(scenario.encode("utf-8"))]


def draw_variant(scenario, n):
    """Variant ``n`` (an integer >= 0) of ``scenario``: a dict of every
    drawn parameter (see the module docstring and RANGES)."""
    if int(n) != n or n < 0:
        raise ValueError(f"variant must be a whole number >= 0, got {n!r}")
    rng = np.random.default_rng(_seed(scenario, n))

    def uniform(key):
        lo, hi = RANGES[key]
        return float(rng.uniform(lo, hi))

    # Every value is drawn in the same order whatever the scenario, so a
    # variant number means the same camera in every scenario.
    height = uniform("height_m")
    hfov = uniform("hfov_deg")
    centre_range = uniform("centre_range_m")
    roll = uniform("roll_deg")
    offset = uniform("forward_offset_m")
    azimuth = uniform("light_azimuth_deg")
    elevation = uniform("light_elevation_deg")
    shading = uniform("ball_shading")
    floor = FLOOR_NAMES[int(rng.integers(len(FLOOR_NAMES)))]
    disc_d = uniform("disc_d")
    lo, hi = RANGES["ball_d"]
    ball_d = float(rng.uniform(lo, min(hi, 1.5 * height)))
    gain = uniform("gain")
    drift = uniform("exposure_drift_stops")
    period = uniform("drift_period_s")
    wb = (uniform("wb_gain"), uniform("wb_gain"))
    wb_drift = uniform("wb_drift")
    vignette = uniform("vignette")
    noise = uniform("noise_sigma")
    lo, hi = RANGES["jpeg_quality"]
    quality = int(rng.integers(lo, hi + 1))
    blur = int(MOTION_BLUR[int(rng.integers(len(MOTION_BLUR)))])
    shutter = uniform("shutter")
    layout_seed = int(rng.integers(1 << 31))
    field_jitter = float(rng.uniform(0.85, 1.15))
    loop = [float(v) for v in rng.uniform(0.85, 1.15, 2)]
    loop_c = float(rng.uniform(0.0, 0.25))
    turn = int(rng.integers(4))
    mirror = bool(rng.integers(2))
    plan_jitter = [[round(float(v), 4) for v in rng.uniform(-0.15, 0.15, 2)]
                   for _ in range(PLAN_SIZE)]
    range_jitter = [round(float(v), 4)
                    for v in rng.uniform(-0.04, 0.04, 13)]
    bearing_shift = round(float(rng.uniform(-3.0, 3.0)), 1)
    # a short clip starts anywhere on the lap
    loop_phase = round(float(rng.uniform(0.0, 1.0)), 4)

    tilt = choose_tilt(height, hfov, centre_range)
    fx = 320.0 / math.tan(math.radians(hfov) / 2)
    reach = disc_reach(fx, disc_d, height)
    az, el = math.radians(azimuth), math.radians(elevation)

    def clip(key, value):
        lo, hi = RANGES[key]
        return min(max(value, lo), hi)

    r = lambda v, k=4: round(float(v), k)   # noqa: E731
    return {
        "number": int(n),
        "scenario": scenario,
        "camera": {"hfov_deg": r(hfov), "height_m": r(height),
                   "tilt_deg": r(tilt), "roll_deg": r(roll)},
        "centre_range_m": r(centre_range),
        "disc_reach_m": r(reach),
        "forward_offset_m": r(offset),
        "light": {"azimuth_deg": r(azimuth, 2),
                  "elevation_deg": r(elevation, 2),
                  "direction": [r(math.cos(el) * math.cos(az), 6),
                                r(math.cos(el) * math.sin(az), 6),
                                r(math.sin(el), 6)],
                  "ambient": r(1.0 - shading)},
        "floor": floor,
        "markers": {"disc_d": r(disc_d), "ball_d": r(ball_d)},
        "gain": r(gain),
        "white_balance": [r(wb[0]), r(wb[1])],
        "effects": {
            "ball_shading": r(shading),
            "exposure_stops": r(math.log2(gain)),
            "exposure_drift_stops": r(drift),
            "drift_period_s": r(period, 2),
            "wb_drift": r(wb_drift),
            "vignette": r(vignette),
            "noise_sigma": r(noise, 3),
            "jpeg_quality": quality,
            "motion_blur": blur,
            "shutter": r(shutter, 3),
        },
        "layout": {
            "seed": layout_seed,
            "field_m": r(clip("field_m", 1.45 * reach * field_jitter), 3),
            "loop_a": r(loop[0]), "loop_b": r(loop[1]), "loop_c": r(loop_c),
            "loop_phase": loop_phase,
            "plan_turn": turn, "plan_mirror": mirror,
            "plan_jitter": plan_jitter,
            "range_jitter": range_jitter,
            "bearing_shift_deg": bearing_shift,
            "range_scale": r(clip("range_scale", 0.75 * reach / 1.76)),
            "distractor_scale": r(clip("distractor_scale", disc_d / 0.12)),
        },
    }
