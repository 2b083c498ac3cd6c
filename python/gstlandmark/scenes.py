"""Generated camera frames for demos and benchmarks until the synthetic
world with exact ground truth (``gst-landmark synth``) replaces them."""

import cv2
import numpy as np

from gstlandmark import reference
from gstlandmark.palette import default_palette

MARKER_NAMES = ("red", "green", "yellow", "pink", "blue")
SEED = 20240611


def _marker_colours(palette):
    """sRGB (R, G, B) uint8 of the palette's marker discs, by name."""
    srgb = reference.lab_to_srgb8(palette.lab_array())
    return {name: srgb[palette.index(name)]
            for name in MARKER_NAMES if name in palette.names}


def floor_scene(width, height, index=0, seed=SEED, palette=None,
                camera_shift=None):
    """One synthetic camera frame of a floor with coloured discs.

    Returns uint8 (height, width, 3) in R, G, B order.  The camera looks
    down at a floor of planks (a wood tone blended with grey) lit unevenly;
    flat discs in the palette's marker colours lie on it and appear as
    ellipses.  ``index`` moves the camera a little and changes the noise,
    so consecutive indices give distinct but similar frames;
    ``camera_shift`` = (sideways, forwards) in metres sets the camera's
    offset instead.  Geometry is
    relative to the frame size: every size shows the same scene.
    """
    palette = palette or default_palette()
    rng = np.random.default_rng(seed)        # the scene: fixed per seed
    frame_rng = np.random.default_rng((seed, index))   # per-frame noise

    # Pinhole camera 1 m above the floor, horizon above the top edge.
    focal = 0.9 * width
    cx = width / 2.0
    horizon = -0.35 * height
    cam_h = 1.0
    shift_x = 0.03 * index          # metres: the camera drifts sideways
    shift_z = 0.05 * index          # and forwards between frames
    if camera_shift is not None:
        shift_x, shift_z = camera_shift

    ys, xs = np.mgrid[0:height, 0:width].astype(np.float64)
    depth = focal * cam_h / (ys - horizon)           # Z of each floor point
    floor_x = (xs - cx) * depth / focal + shift_x     # X of each floor point
    floor_z = depth + shift_z

    # Planks 15 cm wide along Z, each with its own tone and grain phase.
    n_planks = 64
    plank = np.floor(floor_x / 0.15).astype(np.int64) % n_planks
    tone = rng.uniform(0.85, 1.12, n_planks)[plank]
    phase = rng.uniform(0, 2 * np.pi, n_planks)[plank]
    grain = 1.0 + 0.05 * np.sin(38.0 * floor_z
                                + 2.5 * np.sin(3.0 * floor_x + phase)
                                + phase)
    seams = np.abs(floor_x / 0.15 - np.round(floor_x / 0.15)) * 0.15
    seam = np.where(seams < 0.004, 0.75, 1.0)

    wood = np.array([150.0, 112.0, 78.0])
    grey = np.array([128.0, 126.0, 122.0])
    # More wood to the left, more grey (worn/painted) to the right.
    mix = np.clip(0.75 - 0.5 * xs / width, 0.0, 1.0)[..., None]
    base = mix * wood + (1.0 - mix) * grey

    # Uneven light: brighter near the camera and towards a window on the
    # right, a soft vignette.
    light = (0.78 + 0.22 * np.exp(-(depth - 1.0) / 4.0)
             + 0.10 * (xs / width))
    r2 = ((xs - cx) / width) ** 2 + ((ys - height / 2.0) / height) ** 2
    light = light * (1.0 - 0.35 * r2)

    shade = (tone * grain * seam * light)[..., None]
    image = base * shade

    # Discs of radius 12 cm on the floor.  Draw far ones first.
    colours = _marker_colours(palette)
    discs = []
    for name in MARKER_NAMES:
        if name not in colours:
            continue
        for _ in range(2 if name in ("red", "blue") else 1):
            disc_z = rng.uniform(1.0, 4.0)
            half_width = 0.85 * (width / 2.0) * disc_z / focal
            disc_x = rng.uniform(-half_width, half_width)
            discs.append((disc_z, disc_x, name))
    discs.sort(reverse=True)
    radius = 0.12
    sub = 16                        # cv2 sub-pixel shift 4 bits
    for disc_z, disc_x, name in discs:
        z = disc_z - shift_z
        if z <= 0.3:
            continue
        u = cx + focal * (disc_x - shift_x) / z
        v = horizon + focal * cam_h / z
        a = focal * radius / z
        b = a * cam_h / z
        # The disc is lit like the floor under it.
        vi = int(np.clip(v, 0, height - 1))
        ui = int(np.clip(u, 0, width - 1))
        colour = colours[name].astype(np.float64) * min(light[vi, ui] * 1.05,
                                                        1.0)
        cv2.ellipse(image, (int(round(u * sub)), int(round(v * sub))),
                    (max(int(round(a * sub)), sub),
                     max(int(round(b * sub)), sub)),
                    0, 0, 360, colour.tolist(), -1, cv2.LINE_AA, 4)

    # A little lens blur, then sensor noise.
    sigma = 0.6 * max(width / 640.0, 1.0)
    image = cv2.GaussianBlur(image, (0, 0), sigma)
    image = image + frame_rng.normal(0.0, 2.0, image.shape)
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)
