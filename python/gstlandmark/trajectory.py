"""Map and trajectory accuracy in 2-D: the best rigid alignment of two
point sets, the association of an estimated landmark map with the true
one, and the normalised estimation error squared (NEES) against the
chi-square bounds.

- ``align_rigid(src, dst)``: rotation ``R`` and translation ``t``
  minimising ``sum |R src_i + t - dst_i|^2`` (Umeyama / Kabsch without
  scale, closed form from the SVD of the cross-covariance, reflections
  excluded).
- ``associate_map(est, true, ...)``: each estimated landmark paired with
  the nearest true landmark of its class after alignment, one to one,
  nearest first, within a gate; the others are duplicates (their true
  landmark already taken by a nearer estimate) or spurious (no true
  landmark of the class within the gate), and true landmarks left
  unpaired are missed.
- ``nees(error, covariance)``: ``e^T P^-1 e``; the two-sided 95 %
  intervals of chi-square in ``CHI2_95``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

# two-sided 95 % intervals of chi-square (2.5 % and 97.5 % quantiles) by
# degrees of freedom, and the one-sided 95 % bound
CHI2_95 = {2: (0.0506, 7.378), 3: (0.216, 9.348)}
CHI2_95_ONE_SIDED = {2: 5.991, 3: 7.815}


@dataclass
class Rigid2D:
    """``p -> R p + t`` with ``R`` the rotation by ``angle``."""
    angle: float = 0.0
    tx: float = 0.0
    ty: float = 0.0

    @property
    def rotation(self) -> np.ndarray:
        c, s = math.cos(self.angle), math.sin(self.angle)
        return np.array([[c, -s], [s, c]])

    def apply(self, points) -> np.ndarray:
        p = np.asarray(points, float).reshape(-1, 2)
        return p @ self.rotation.T + np.array([self.tx, self.ty])

    def inverse(self) -> "Rigid2D":
        c, s = math.cos(self.angle), math.sin(self.angle)
        return Rigid2D(-self.angle, -(c * self.tx + s * self.ty),
                       -(-s * self.tx + c * self.ty))


def wrap_angle(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def align_rigid(src, dst) -> Rigid2D:
    """The rigid transform (no scale) taking ``src`` onto ``dst`` in the
    least-squares sense; identity for no points, a pure translation for
    one."""
    a = np.asarray(src, float).reshape(-1, 2)
    b = np.asarray(dst, float).reshape(-1, 2)
    if a.shape != b.shape:
        raise ValueError(f"align_rigid: {len(a)} points against {len(b)}")
    if len(a) == 0:
        return Rigid2D()
    ma, mb = a.mean(axis=0), b.mean(axis=0)
    if len(a) == 1:
        return Rigid2D(0.0, *(mb - ma))
    u, _, vt = np.linalg.svd((b - mb).T @ (a - ma))
    d = np.diag([1.0, np.sign(np.linalg.det(u @ vt)) or 1.0])
    r = u @ d @ vt
    t = mb - r @ ma
    return Rigid2D(math.atan2(r[1, 0], r[0, 0]), float(t[0]), float(t[1]))


def pose_transform(est: Dict[str, float], truth: Dict[str, float]
                   ) -> Rigid2D:
    """The transform placing the estimated pose on the true one (the
    frame of an estimator whose first pose is its origin)."""
    angle = wrap_angle(truth["heading"] - est["heading"])
    c, s = math.cos(angle), math.sin(angle)
    return Rigid2D(angle, truth["x"] - (c * est["x"] - s * est["y"]),
                   truth["y"] - (s * est["x"] + c * est["y"]))


@dataclass
class MapMatch:
    """Estimated landmarks paired with true ones (indices), in the frame of
    ``transform`` (estimate -> truth)."""
    transform: Rigid2D
    pairs: List[Tuple[int, int]] = field(default_factory=list)
    duplicated: List[int] = field(default_factory=list)
    spurious: List[int] = field(default_factory=list)
    missed: List[int] = field(default_factory=list)


def nearest_first(candidates: Sequence[Tuple[float, int, int]]
                  ) -> List[Tuple[int, int]]:
    """One-to-one pairs ``(i, j)`` from ``(distance, i, j)`` candidates,
    nearest first."""
    used_i, used_j, out = set(), set(), []
    for _, i, j in sorted(candidates):
        if i not in used_i and j not in used_j:
            used_i.add(i)
            used_j.add(j)
            out.append((i, j))
    return out


def _pair(est_xy, est_cls, true_xy, true_cls, gate):
    """Nearest-first one-to-one pairs of the same class within gate, and
    the unpaired estimates split into duplicated and spurious."""
    cand = []
    for i, (p, c) in enumerate(zip(est_xy, est_cls)):
        for j, (q, d) in enumerate(zip(true_xy, true_cls)):
            if c == d:
                dist = float(np.hypot(*(p - q)))
                if dist <= gate:
                    cand.append((dist, i, j))
    pairs = nearest_first(cand)
    used_e = {i for i, _ in pairs}
    near = {i for _, i, _ in cand}
    dup = [i for i in range(len(est_xy)) if i not in used_e and i in near]
    spur = [i for i in range(len(est_xy)) if i not in used_e and i not in near]
    return sorted(pairs), dup, spur


def _pair_cost(pairs, est_xy, true_xy, tf):
    if not pairs:
        return 0.0
    a = tf.apply([est_xy[i] for i, _ in pairs])
    b = np.array([true_xy[j] for _, j in pairs])
    return float(((a - b) ** 2).sum())


MAX_CANDIDATES = 20000


def _search(e, est_cls, t, true_cls, gate, best):
    """Every pair of estimated landmarks put on a pair of true ones of the
    same classes and spacing: the transform that brings the most estimated
    landmarks within the gate of a true one of their class (at most
    MAX_CANDIDATES tried), if it pairs more than ``best``."""
    same = np.array([[c == d for d in true_cls] for c in est_cls], bool)
    top = None
    tried = 0
    for i in range(len(e)):
        for k in range(i + 1, len(e)):
            de = float(np.hypot(*(e[k] - e[i])))
            if de < gate:
                continue
            for j in np.flatnonzero(same[i]):
                for m in np.flatnonzero(same[k]):
                    if m == j or abs(float(np.hypot(*(t[m] - t[j]))) - de) \
                            > gate:
                        continue
                    tf = align_rigid(e[[i, k]], t[[j, m]])
                    d = np.hypot(*(tf.apply(e)[:, None, :] - t[None]).T).T
                    d[~same] = np.inf
                    near = d.min(axis=1)
                    key = (-int((near <= gate).sum()),
                           float(np.square(near[near <= gate]).sum()))
                    if top is None or key < top[0]:
                        top = (key, tf)
                    tried += 1
                    if tried >= MAX_CANDIDATES:
                        break
                if tried >= MAX_CANDIDATES:
                    break
    if top is None:
        return best
    pairs, _, _ = _pair(top[1].apply(e), est_cls, t, true_cls, gate)
    key = (-len(pairs), _pair_cost(pairs, e, t, top[1]))
    return (key, top[1], pairs) if key < best[0] else best


def associate_map(est_xy, est_cls: Sequence[str], true_xy,
                  true_cls: Sequence[str], gate: float = 0.3,
                  initial: Optional[Rigid2D] = None,
                  align: bool = True) -> MapMatch:
    """Pair an estimated map with the true one.

    With ``align``, the transform is searched: ``initial`` (e.g. the
    trajectory's alignment) when it pairs at least half the estimated
    landmarks; otherwise also every pair of estimated landmarks put on a
    pair of true ones of the same classes and spacing (within the gate),
    the candidate pairing the most landmarks (then the least squared
    error) kept. The transform is then refined by alternating pairing and
    ``align_rigid`` until the pairs no longer change. Without ``align``
    the estimate is taken as it is (``initial`` or identity)."""
    e = np.asarray(est_xy, float).reshape(-1, 2)
    t = np.asarray(true_xy, float).reshape(-1, 2)
    start = initial or Rigid2D()
    pairs, _, _ = _pair(start.apply(e), est_cls, t, true_cls, gate)
    best = ((-len(pairs), _pair_cost(pairs, e, t, start)), start, pairs)
    if align and len(pairs) < max(2, len(e) // 2):
        best = _search(e, est_cls, t, true_cls, gate, best)
    tf, pairs = best[1], best[2]
    if align:
        for _ in range(20):
            if len(pairs) == 0:
                break
            tf = align_rigid(e[[i for i, _ in pairs]],
                             t[[j for _, j in pairs]])
            again, _, _ = _pair(tf.apply(e), est_cls, t, true_cls, gate)
            if again == pairs:
                break
            pairs = again
    pairs, dup, spur = _pair(tf.apply(e), est_cls, t, true_cls, gate)
    paired_t = {j for _, j in pairs}
    return MapMatch(tf, pairs, dup, spur,
                    [j for j in range(len(t)) if j not in paired_t])


def nees(error, covariance) -> Optional[float]:
    """``e^T P^-1 e``, or None when ``P`` is not positive definite (a
    pose or an anchor the estimator holds exact)."""
    e = np.asarray(error, float).ravel()
    p = np.asarray(covariance, float).reshape(e.size, e.size)
    p = 0.5 * (p + p.T)
    try:
        chol = np.linalg.cholesky(p)
    except np.linalg.LinAlgError:
        return None
    if np.min(np.diag(chol)) <= 1e-12 * max(1.0, float(np.max(np.abs(p)))):
        return None
    z = np.linalg.solve(chol, e)
    return float(z @ z)


def nees_summary(values: Sequence[Optional[float]], dof: int
                 ) -> Dict[str, Any]:
    """Share of the NEES values inside the two-sided 95 % interval of
    chi-square(dof) (and below the one-sided bound), their mean; the
    values that could not be computed are counted apart."""
    v = np.asarray([x for x in values if x is not None], float)
    lo, hi = CHI2_95[dof]
    out: Dict[str, Any] = {"n": int(v.size),
                           "not_computed": len(values) - int(v.size),
                           "dof": dof, "bounds": [lo, hi],
                           "one_sided_bound": CHI2_95_ONE_SIDED[dof]}
    if v.size:
        out.update(mean=float(v.mean()), median=float(np.median(v)),
                   inside=float(np.mean((v >= lo) & (v <= hi))),
                   below_one_sided=float(np.mean(
                       v <= CHI2_95_ONE_SIDED[dof])))
    return out
