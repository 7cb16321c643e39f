"""Initial tool axes of Rajain et al. 2023 from the guiding curves: rails (Eq. (7)), the m-grid (Eqs. (8)-(10)),
ruling samples (Eq. (11)) and the rigidity defect of the start (Remark 2, Fig. 11).

Input are the base points of :func:`guiding.guiding_curves`: per guiding curve g_i the points
g_(i,j) with unit surface normals n_(i,j) and column ids j, and the strips (Remark 3: strip i
holds the columns present on both g_i and g_(i+1), so strips differ in length).

* Eq. (7): the tool tip's sphere centre a_(i,j) = g_(i,j) + r1 n_(i,j) rides on g_i, the base's
  b_(i,j) = g_(i+1,j) + r2 n_(i+1,j) on g_(i+1); the axis of strip i at column j is a-b.
* Eqs. (8)-(9): at an inner curve, a_(i+1,j) and b_(i,j) lie on the same surface normal, so their
  mean m_(i+1,j) = g_(i+1,j) + (r1 + r2)/2 n_(i+1,j); the boundary definitions (9) give the same
  formula on g_1 and g_(M+1).  Hence the m-grid is the offset of *all* base points by the mean
  radius, one point per (curve, column), including columns that only one neighbouring strip uses.
* Eq. (10) recovers a and b from m: a_(i,j) = m_(i,j) - dr/2 n_(i,j),
  b_(i,j) = m_(i+1,j) + dr/2 n_(i+1,j), dr = r2 - r1.
* Eq. (11): K samples y^k = (1 - s_k) a + s_k b with radii r^k = (1 - s_k) r1 + s_k r2,
  s_k = (k - 1)/(K - 1).
* Remark 2: these axes are not rigid; the lengths |b - a| against L are reported.  On a plane with
  the curves d = sqrt(L^2 - dr^2) apart they are exactly L.
"""
from dataclasses import dataclass
from typing import List

import numpy as np


@dataclass
class StripRulings:
    """Initial axes of one strip: columns (N_i,), a (N_i, 3) tip centres, b (N_i, 3) base centres
    (Eq. (7)), and the axis lengths |b - a| (N_i,)."""
    index: int
    columns: np.ndarray
    a: np.ndarray
    b: np.ndarray
    lengths: np.ndarray


@dataclass
class InitialRulings:
    """All strips' initial axes, the m-grid per guiding curve (points (N, 3) aligned with that
    curve's base points and columns), and the tool (r1, r2, L)."""
    strips: List[StripRulings]
    m: List[np.ndarray]
    r1: float
    r2: float
    L: float

    def length_defect(self):
        """(min, max) of |b - a| - L over all rulings (Remark 2, Fig. 11), or (0, 0) if none."""
        d = np.concatenate([s.lengths for s in self.strips]) - self.L if self.strips else np.zeros(0)
        return (float(d.min()), float(d.max())) if len(d) else (0.0, 0.0)


def rail_points(g_lower, n_lower, g_upper, n_upper, r1, r2):
    """Eq. (7): a = g_i + r1 n_i, b = g_(i+1) + r2 n_(i+1); all arrays (N, 3) -> (a, b)."""
    return np.asarray(g_lower) + r1 * np.asarray(n_lower), np.asarray(g_upper) + r2 * np.asarray(n_upper)


def m_points(g, n, r1, r2):
    """Eqs. (8)-(9): m = g + (r1 + r2)/2 n for base points g (N, 3) with unit normals n (N, 3)."""
    return np.asarray(g) + 0.5 * (r1 + r2) * np.asarray(n)


def rails_from_m(m_lower, n_lower, m_upper, n_upper, r1, r2):
    """Eq. (10): a = m_i - dr/2 n_i, b = m_(i+1) + dr/2 n_(i+1), dr = r2 - r1; arrays (N, 3)."""
    h = 0.5 * (r2 - r1)
    return np.asarray(m_lower) - h * np.asarray(n_lower), np.asarray(m_upper) + h * np.asarray(n_upper)


def ruling_samples(a, b, r1, r2, K):
    """Eq. (11): sample points y (N, K, 3) on the axes a-b (a, b (N, 3)) and radii r (K,)."""
    K = int(K)
    if K < 2:
        raise ValueError(f"K = {K} ruling samples is below the minimum 2")
    s = np.linspace(0.0, 1.0, K)
    y = (1 - s)[None, :, None] * np.asarray(a)[:, None, :] + s[None, :, None] * np.asarray(b)[:, None, :]
    return y, (1 - s) * r1 + s * r2


def initial_rulings(bases, strips, r1, r2, L):
    """Initial axes of all strips (Eq. (7)) and the m-grid (Eqs. (8)-(9)) from the base points and
    strips of :func:`guiding.base_points`; returns :class:`InitialRulings`."""
    r1, r2, L = float(r1), float(r2), float(L)
    for name, v in (("r1", r1), ("r2", r2)):
        if not (np.isfinite(v) and v >= 0):
            raise ValueError(f"{name} = {v!r} must be a finite number >= 0")
    if not (np.isfinite(L) and L > abs(r2 - r1)):
        raise ValueError(f"axis length L = {L!r} must be finite and exceed |r2 - r1| = {abs(r2 - r1)}")
    out = []
    for st in strips:
        lo, hi = bases[st.index], bases[st.index + 1]
        a, b = rail_points(lo.points[st.lower], lo.normals[st.lower], hi.points[st.upper], hi.normals[st.upper],
                           r1, r2)
        out.append(StripRulings(st.index, st.columns, a, b, np.linalg.norm(b - a, axis=1)))
    return InitialRulings(out, [m_points(bc.points, bc.normals, r1, r2) for bc in bases], r1, r2, L)
