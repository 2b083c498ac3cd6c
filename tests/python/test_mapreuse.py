"""tools/mapreuse.py's alignment of a written map to the true
one (docs/landmarkslam.md, "The written map on a third loop"): on a map
turned and shifted by a known transform, with repeated colours and a
spurious landmark."""

import math

import numpy as np

import mapreuse

TRUE = [{"class": c, "x": x, "y": y} for c, x, y in (
    ("red", 0.5, 0.4), ("red", 2.5, 0.6), ("green", 1.2, 2.2),
    ("green", 3.0, 2.8), ("blue", 0.2, 3.1), ("pink", 2.0, 1.5))]


def written(turn, shift, spurious=True):
    """The true map seen from the frame of a first pose (x, y, heading):
    world = R(turn) p + shift, so p = R(-turn) (world - shift)."""
    c, s = math.cos(-turn), math.sin(-turn)
    out = []
    for m in TRUE:
        dx, dy = m["x"] - shift[0], m["y"] - shift[1]
        out.append({"class": m["class"], "x": c * dx - s * dy,
                    "y": s * dx + c * dy})
    if spurious:
        out.append({"class": "red", "x": 5.0, "y": -4.0})
    return out


def test_fit_recovers_the_first_pose_frame():
    turn, shift = 0.7, (1.3, -0.4)
    # the first true pose is off by 5 cm and 2 degrees: the fit corrects it
    first = {"x": shift[0] + 0.05, "y": shift[1], "heading": turn + 0.035}
    rot, t, rms, paired = mapreuse.fit_map(written(turn, shift), TRUE, first)
    assert paired == len(TRUE)          # the spurious red left out
    assert rms < 1e-9
    assert math.isclose(math.atan2(rot[1, 0], rot[0, 0]), turn,
                        abs_tol=1e-9)
    assert np.allclose(t, shift, atol=1e-9)

