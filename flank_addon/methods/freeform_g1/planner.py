"""G1-continuous multi-strip flank milling of a free-form mesh with a conical tool (Rajain et al. 2023 §4-§7).

Pipeline of :func:`plan_freeform`:

1. Guiding curves and base points (:mod:`.guiding`, Rajain et al. 2023 §5) from a guiding direction (one tangent
   vector at a central point, or a vector field), spaced d = sqrt(L^2 - dr^2) apart.
2. Initial rails and m-grid (:mod:`.initial_rulings`, Eqs. (7)-(10)).
3. The optimisation of Eq. (18) over the m-grid (and optionally r1, r2, L, §7.2) with
   ``scipy.optimize.least_squares`` (trust region, sparse LSMR) and an analytic sparse Jacobian.
   Each term of Eq. (18) is written as residuals whose squares sum to that term:

   * rigidity, Eq. (12): (|b - a|^2 - L^2) / L0^2 per ruling;
   * approximation, Eq. (13): (sd(y^k) - r^k) / L0 per ruling sample of Eq. (11), sd = signed
     distance to the mesh through the exact foot point (:mod:`.mesh_distance`); its gradient is
     the unit normal at the foot point, which is the tangent-plane model of Eq. (13);
   * G1: by default n_i - n_(i+1), the unit envelope normals (Eq. (6)) of two neighbouring strips at
     each column they share (its length is the kink angle in radians); ``g1_term='paper'`` uses
     Eqs. (15)-(16), cos theta^1 - cos theta^2 of the axes against the surface normal, which on a
     curved surface can vanish while the envelopes still meet at tens of degrees;
   * proximity to the start, Eq. (17): (m - m_ini) / L0;
   * fairness in time, Eq. (14): the tangential part (I - n n^T)(m_(j+1) - 2 m_j + m_(j-1)) / L0
     along every guiding curve.  The paper takes the whole second difference; its normal part is
     the normal curvature of the surface along the curve, which the approximation term already
     fixes, so the full term only pulls the tool off curved surfaces (on a cylinder patch it cost
     1e-4 of the patch size where the plan can be exact) and lets the grid shrink along the curves;
     the tangential part keeps what the term is for: even spacing and no sideways wobble;

   each block scaled by sqrt(w / count) with the paper's counts.  Dividing lengths by the tool's
   axis length L0 makes the terms dimensionless, so the weights mean the same in mm, inches or
   metres (the paper's weights were chosen for millimetre data with L of 1-3 mm, where L0 ~ 1).
   The unit normals n_(i,j) of Eq. (10) are held fixed during one solve and re-taken from the foot
   points of the m-grid for the next (``rounds``).
4. Envelopes of the general motion (Eqs. (5)-(6)) on cubic-spline rails, the branch facing the
   surface; envelope points are coloured by their exact signed distance to the mesh (+ = material
   left); the error of Eq. (19) per strip; kink angles between neighbouring envelopes along their
   shared guiding curve; the rigidity histogram (Fig. 11); collision of the tool part outside the
   engaged cone and of the extended axis (shank) with the surface as a post-check (Fig. 4).

All points are in the input mesh's coordinates; the tool is on the side the face normals point to.
"""
import itertools
import math
import time

import numpy as np
import scipy.sparse as sp
from scipy.interpolate import CubicSpline
from scipy.optimize import least_squares

from . import guiding as _guiding
from .initial_rulings import initial_rulings
from ...collector import collector_paused
from ...geometry.mesh_distance import TriangleMesh
from ...geometry.runs import segment_argmin
from ...io.json_pieces import lists_to_array, rows_to_tuples
from ...progress import reporter, substage

METHOD = "freeform-g1-cone"
# w1 rigid, w2 approx, w3 G1, w4 proximity, w5 fair.  w1 = 1, w4 = 1e-4 as Remark 4; G1 at 1/100 of the
# approximation: the measured kink is the envelopes' own, and lowering it costs accuracy fast (README);
# fairness 1e-3: base points on a faceted mesh are not evenly spaced in angle, and 1e-2 already moved an
# exact cylinder plan by 1.3e-6 of its size (1e-3: 1.1e-7)
DEFAULT_WEIGHTS = (1.0, 1.0, 0.01, 1e-4, 1e-3)
# the solve's gradient tolerance for a tool of axis length 1 (least_squares' gtol is GTOL / L0)
GTOL = 1e-10
WEIGHT_NAMES = ("rigid", "approx", "g1", "proximity", "fair")


# ============================================================================ layout
class Layout:
    """Index bookkeeping of the m-grid: one row per base point of every guiding curve.

    offsets (M + 2,) into the stacked points; per strip the global rows of its a-side (curve i)
    and b-side (curve i + 1) points; the G1 pairs (strip i, row in it, strip i + 1, row in it) of
    columns shared across an inner curve; the fairness triples along each curve piece."""

    def __init__(self, bases, strips):
        sizes = [len(b.points) for b in bases]
        self.offsets = np.r_[0, np.cumsum(sizes)].astype(np.int64)
        self.n_points = int(self.offsets[-1])
        self.strip_a = [self.offsets[s.index] + s.lower for s in strips]
        self.strip_b = [self.offsets[s.index + 1] + s.upper for s in strips]
        self.strip_columns = [s.columns for s in strips]
        starts = np.r_[0, np.cumsum([len(x) for x in self.strip_a])].astype(np.int64)
        self.ruling_start = starts
        self.n_rulings = int(starts[-1])
        self.ga = np.concatenate(self.strip_a) if strips else np.zeros(0, np.int64)
        self.gb = np.concatenate(self.strip_b) if strips else np.zeros(0, np.int64)
        g1 = []                                          # (ruling of strip i, ruling of strip i + 1)
        for i in range(len(strips) - 1):
            common, p, q = np.intersect1d(strips[i].columns, strips[i + 1].columns, return_indices=True)
            g1.append(np.c_[starts[i] + p, starts[i + 1] + q])
        self.g1_pairs = np.concatenate(g1) if g1 else np.zeros((0, 2), np.int64)
        fair = []
        for ci, b in enumerate(bases):
            n = len(b.points)
            if n < 3:
                continue
            j = np.arange(1, n - 1)
            ok = (b.piece[j - 1] == b.piece[j]) & (b.piece[j + 1] == b.piece[j])
            j = j[ok] + self.offsets[ci]
            fair.append(np.c_[j - 1, j, j + 1])
        self.fair = np.concatenate(fair) if fair else np.zeros((0, 3), np.int64)


class SparsePattern:
    """CSR assembly of a Jacobian whose (row, column) entries are the same at every evaluation.

    ``scipy.sparse.csr_matrix((vals, (rows, cols)))`` sorts the entries of every row and adds up repeated
    (row, column) pairs each time; with the pattern fixed only the values change, so the order of that sort
    (it compares the columns only, so it does not depend on the values) is found once, and each evaluation
    gathers and adds the values in that same order.  The matrices are the same, bit for bit, as scipy's
    (the optimiser's path depends on every last bit of them); only where two NaNs are added may the sign or
    payload of the NaN differ."""

    def __init__(self, rows, cols, shape):
        self.rows, self.cols, self.shape = rows.copy(), cols.copy(), tuple(shape)
        n = len(rows)
        # scipy's own conversion on the entry numbers 0 .. n - 1 (exact in float64) shows where each entry goes
        order = np.argsort(rows, kind="stable")                 # by row, in input order within a row
        count = np.bincount(rows, minlength=shape[0])
        index_dtype = sp.csr_matrix((np.zeros(n), (rows, cols)), shape=shape).indices.dtype
        indptr = np.zeros(shape[0] + 1, index_dtype)
        np.cumsum(count, out=indptr[1:])
        probe = sp.csr_matrix((order.astype(float), cols[order].astype(index_dtype), indptr), shape=shape)
        probe.sort_indices()
        perm = probe.data.astype(np.int64)
        r, c = rows[perm], cols[perm]
        new = np.r_[True, (r[1:] != r[:-1]) | (c[1:] != c[:-1])] if n else np.zeros(0, bool)
        start = np.flatnonzero(new)
        group = np.cumsum(new) - 1
        rank = np.arange(n) - start[group]
        # repeated pairs are added left to right: the first, then the second, ...
        self.first = perm[start]
        self.repeats = [(group[rank == k], perm[rank == k]) for k in range(1, int(rank.max(initial=0)) + 1)]
        self.indices = c[start].astype(index_dtype)
        self.indptr = np.zeros(shape[0] + 1, index_dtype)
        np.cumsum(np.bincount(r[start], minlength=shape[0]), out=self.indptr[1:])

    def matches(self, rows, cols, shape):
        return (tuple(shape) == self.shape and np.array_equal(rows, self.rows)
                and np.array_equal(cols, self.cols))

    def matrix(self, vals):
        data = vals[self.first]
        for group, entries in self.repeats:
            data[group] += vals[entries]
        J = sp.csr_matrix((data, self.indices.copy(), self.indptr.copy()), shape=self.shape)
        J.has_sorted_indices = True
        J.has_canonical_format = True
        return J


def assemble(pattern, vals, rows, cols, shape):
    """CSR matrix of the entries (vals, (rows, cols)), repeated pairs added, through ``pattern`` (a
    :class:`SparsePattern` or None) when it holds the same entries; returns (matrix, the pattern used)."""
    if pattern is None or not pattern.matches(rows, cols, shape):
        pattern = SparsePattern(rows, cols, shape)
    return pattern.matrix(vals), pattern


# ============================================================================ rails
def rails(m, normals, layout, r1, r2):
    """Eq. (10): tip and base sphere centres a, b (R, 3) of every ruling from the m-grid (P, 3)."""
    h = 0.5 * (r2 - r1)
    return m[layout.ga] - h * normals[layout.ga], m[layout.gb] + h * normals[layout.gb]


def rail_derivative_matrix(tau):
    """(N, N) matrix D with D @ rail = the time derivative, at the knots tau (N,), of the natural
    cubic spline through the rail points (linear in them); N = 2: the chord."""
    N = len(tau)
    if N >= 3:
        return CubicSpline(tau, np.eye(N), bc_type="natural")(tau, 1)
    d = 1.0 / (tau[1] - tau[0])
    return np.array([[-d, d], [-d, d]])


def envelope_normal(ys, yt, dr, side):
    """Unit envelope normals (n, 3) of Eq. (6) for axis derivative ys (n, 3) and motion derivative yt
    (n, 3) of the sphere centre, radius slope dr; the branch with n . side > 0 (towards the tool
    from the surface).  Returns (n, valid)."""
    E, F, G = (ys * ys).sum(1), (ys * yt).sum(1), (yt * yt).sum(1)
    den = E * G - F * F
    disc = (E - dr * dr) * G - F * F
    valid = (disc >= 0) & (den > 0)
    root = np.sqrt(np.maximum(disc, 0.0))
    cr = np.cross(ys, yt)
    base = dr * (G[:, None] * ys - F[:, None] * yt)
    safe = np.where(den > 0, den, 1.0)[:, None]
    n_p, n_m = (base + cr * root[:, None]) / safe, (base - cr * root[:, None]) / safe
    n = np.where(((n_p * side).sum(1) >= (n_m * side).sum(1))[:, None], n_p, n_m)
    return n, valid


def _samples(K):
    return np.linspace(0.0, 1.0, int(K))


# ============================================================================ objective
class Objective:
    """Residuals and sparse Jacobian of Eq. (18) for least_squares.

    x = [m (P * 3), L?, r1?, r2?].  ``free`` names the tool variables among 'L', 'r1', 'r2'."""

    def __init__(self, mesh, layout, normals, m_ini, r1, r2, L, K, weights, free=(), report=None,
                 g1_term="envelope", m_start=None, scale=None):
        if g1_term not in ("envelope", "paper"):
            raise ValueError(f"g1_term must be 'envelope' or 'paper', got {g1_term!r}")
        self.g1_term = g1_term
        self.mesh, self.lay, self.nrm = mesh, layout, np.asarray(normals, float)
        self.m_ini = np.asarray(m_ini, float)
        self.tool0 = {"r1": float(r1), "r2": float(r2), "L": float(L)}
        self.free = tuple(k for k in ("L", "r1", "r2") if k in free)
        self.K = int(K)
        self.s = _samples(K)
        # length that makes the terms dimensionless: the tool's axis length, or 1 (the paper's literal
        # terms in the document's unit, weight_units='length')
        self.L0 = float(L) if scale is None else float(scale)
        w = np.asarray(weights, float)
        R, P = layout.n_rulings, layout.n_points
        npair, nfair = len(layout.g1_pairs), len(layout.fair)
        # paper's normalisations: 1/(NM), 1/(3NMK), 1/(N(M-1)), 1/(3N(M+1)), 1/(3(N-2)(M+1))
        self.c = np.sqrt(np.maximum(w, 0) / np.maximum([R, 3 * R * self.K, max(npair, 1), 3 * P, 3 * max(nfair, 1)],
                                                       1))
        self.report = report
        self.n_eval = 0
        self._cache = (None, None)
        self._pattern = None                  # the Jacobian's entries (see SparsePattern)
        # time derivative of the rails at the rulings: the natural cubic spline's, a linear map of the
        # rail points for the time parameters of the start (held for this solve)
        a0, b0 = rails(np.asarray(m_ini if m_start is None else m_start, float), self.nrm, layout, r1, r2)
        blocks = []
        for k in range(len(layout.strip_a)):
            sl = slice(layout.ruling_start[k], layout.ruling_start[k + 1])
            blocks.append(sp.csr_matrix(rail_derivative_matrix(_time_params(a0[sl], b0[sl]))))
        self.D = sp.block_diag(blocks, format="csr") if blocks else sp.csr_matrix((0, 0))
        # the rows of D at the G1 pairs' lower (+1) and upper (-1) rulings, the same at every evaluation
        self.D_pairs = {}
        for sgn, idx in ((1.0, layout.g1_pairs[:, 0]), (-1.0, layout.g1_pairs[:, 1])):
            rows_of_d = self.D[idx]
            self.D_pairs[sgn] = (rows_of_d, rows_of_d.tocoo())

    # -------------------------------------------------------------- packing
    def pack(self, m, tool=None):
        tool = tool or self.tool0
        return np.r_[np.asarray(m, float).ravel(), [tool[k] for k in self.free]]

    def unpack(self, x):
        P = self.lay.n_points
        m = x[:3 * P].reshape(P, 3)
        tool = dict(self.tool0)
        for i, k in enumerate(self.free):
            tool[k] = float(x[3 * P + i])
        return m, tool

    # -------------------------------------------------------------- evaluation
    def _evaluate(self, x):
        if self._cache[0] is not None and np.array_equal(self._cache[0], x):
            return self._cache[1]
        self.n_eval += 1
        if self.report is not None:
            self.report(min(self.n_eval / 60.0, 0.99), f"optimising (evaluation {self.n_eval})")
        lay, nrm, L0, s = self.lay, self.nrm, self.L0, self.s
        m, tool = self.unpack(x)
        r1, r2, L = tool["r1"], tool["r2"], tool["L"]
        P, R, K = lay.n_points, lay.n_rulings, self.K
        nv = 3 * P + len(self.free)
        col_of = {k: 3 * P + i for i, k in enumerate(self.free)}
        na, nb = nrm[lay.ga], nrm[lay.gb]
        a, b = rails(m, nrm, lay, r1, r2)
        v = b - a
        res, rows, cols, vals = [], [], [], []
        row0 = 0

        def add(r, c, val):
            rows.append(np.asarray(r, np.int64).ravel()), cols.append(np.asarray(c, np.int64).ravel())
            vals.append(np.asarray(val, float).ravel())

        def xyz(g):                       # (n,) point rows -> (n, 3) variable columns
            return 3 * g[:, None] + np.arange(3)[None, :]

        # derivative of a and b with respect to r1 and r2 (Eq. (10), h = (r2 - r1) / 2)
        da = {"r1": 0.5 * na, "r2": -0.5 * na}
        db = {"r1": -0.5 * nb, "r2": 0.5 * nb}

        # ---- rigidity, Eq. (12)
        c1 = self.c[0]
        vv = (v * v).sum(1)
        res.append(c1 * (vv - L * L) / L0 ** 2)
        r_ = row0 + np.arange(R)
        g = c1 * 2 * v / L0 ** 2
        add(np.repeat(r_, 3), xyz(lay.gb), g), add(np.repeat(r_, 3), xyz(lay.ga), -g)
        if "L" in col_of:
            add(r_, np.full(R, col_of["L"]), np.full(R, -c1 * 2 * L / L0 ** 2))
        for k in ("r1", "r2"):
            if k in col_of:
                add(r_, np.full(R, col_of[k]), (g * (db[k] - da[k])).sum(1))
        row0 += R

        # ---- approximation, Eqs. (11), (13)
        c2 = self.c[1]
        y = (1 - s)[None, :, None] * a[:, None, :] + s[None, :, None] * b[:, None, :]      # (R, K, 3)
        rk = (1 - s) * r1 + s * r2
        fp = self.mesh.foot_points(y.reshape(-1, 3))
        # Eq. (13) literally: distance to the tangent plane at the foot point.  Inside the mesh it is
        # the signed distance; beyond a boundary edge it extends the surface by that plane instead of
        # pulling the tool off the patch towards the edge.
        grad = fp["normal"].reshape(R, K, 3)
        sd = ((y - fp["foot"].reshape(R, K, 3)) * grad).sum(2)
        res.append((c2 * (sd - rk[None, :]) / L0).ravel())
        r_ = row0 + np.arange(R * K).reshape(R, K)
        ga_cols = np.broadcast_to(xyz(lay.ga)[:, None, :], (R, K, 3))
        gb_cols = np.broadcast_to(xyz(lay.gb)[:, None, :], (R, K, 3))
        rr = np.broadcast_to(r_[:, :, None], (R, K, 3))
        add(rr, ga_cols, c2 / L0 * (1 - s)[None, :, None] * grad)
        add(rr, gb_cols, c2 / L0 * s[None, :, None] * grad)
        for k, dr in (("r1", 1 - s), ("r2", s)):
            if k in col_of:
                dy = (1 - s)[None, :, None] * da[k][:, None, :] + s[None, :, None] * db[k][:, None, :]
                add(r_, np.full(R * K, col_of[k]), c2 / L0 * ((grad * dy).sum(2) - dr[None, :]))
        row0 += R * K

        # ---- G1: envelope normals at the shared boundary, or the paper's Eqs. (15)-(16)
        c3 = self.c[2]
        pr = lay.g1_pairs
        if len(pr) and self.g1_term == "envelope":
            row0 = self._g1_envelope(a, b, na, nb, r2 - r1, c3, row0, res, add, xyz, col_of, da, db)
        elif len(pr):
            i1, i2 = pr[:, 0], pr[:, 1]
            n_common = nb[i1]                                  # normal at the shared base point
            v1, v2 = v[i1], v[i2]
            l1, l2 = np.linalg.norm(v1, axis=1), np.linalg.norm(v2, axis=1)
            cos1 = (n_common * v1).sum(1) / l1
            cos2 = (n_common * v2).sum(1) / l2
            res.append(c3 * (cos1 - cos2))
            d1 = (n_common - cos1[:, None] * v1 / l1[:, None]) / l1[:, None]      # d cos / d v
            d2 = (n_common - cos2[:, None] * v2 / l2[:, None]) / l2[:, None]
            r_ = np.repeat(row0 + np.arange(len(pr)), 3)
            add(r_, xyz(lay.gb[i1]), c3 * d1), add(r_, xyz(lay.ga[i1]), -c3 * d1)
            add(r_, xyz(lay.gb[i2]), -c3 * d2), add(r_, xyz(lay.ga[i2]), c3 * d2)
            for k in ("r1", "r2"):
                if k in col_of:
                    dv1, dv2 = db[k][i1] - da[k][i1], db[k][i2] - da[k][i2]
                    add(row0 + np.arange(len(pr)), np.full(len(pr), col_of[k]),
                        c3 * ((d1 * dv1).sum(1) - (d2 * dv2).sum(1)))
            row0 += len(pr)

        # ---- proximity to the start, Eq. (17)
        c4 = self.c[3]
        res.append((c4 * (m - self.m_ini) / L0).ravel())
        add(row0 + np.arange(3 * P), np.arange(3 * P), np.full(3 * P, c4 / L0))
        row0 += 3 * P

        # ---- fairness in time, Eq. (14)
        c5 = self.c[4]
        tr = lay.fair
        if len(tr):
            # tangential part (I - n n^T) of the second difference: its normal part is the surface's
            # own normal curvature along the curve, which Eq. (13) already prescribes
            nm = nrm[tr[:, 1]]
            proj = np.eye(3)[None, :, :] - nm[:, :, None] * nm[:, None, :]             # (T, 3, 3)
            d2m = m[tr[:, 2]] - 2 * m[tr[:, 1]] + m[tr[:, 0]]
            res.append((c5 * np.einsum("tij,tj->ti", proj, d2m) / L0).ravel())
            r_ = np.repeat(row0 + np.arange(3 * len(tr)), 3)                            # row (t, i), col j
            for j, coef in ((0, 1.0), (1, -2.0), (2, 1.0)):
                cols_ = np.repeat(xyz(tr[:, j])[:, None, :], 3, axis=1)                 # (T, 3, 3)
                add(r_, cols_, coef * c5 / L0 * proj)
            row0 += 3 * len(tr)

        f = np.concatenate(res)
        J, self._pattern = assemble(self._pattern, np.concatenate(vals), np.concatenate(rows), np.concatenate(cols),
                                    (row0, nv))
        self._cache = (x.copy(), (f, J))
        return f, J

    def _g1_envelope(self, a, b, na, nb, dr, c3, row0, res, add, xyz, col_of, da, db):
        """G1 residuals n_i(s = 1) - n_(i+1)(s = 0): the unit envelope normals (Eq. (6)) of two
        neighbouring strips where they meet, at each shared column; |residual| ~ the kink angle.

        The normal n of Eq. (6) solves n . y_s = dr, n . y_t = 0, |n| = 1, so with
        M = [y_s; y_t; n] its derivatives are dn/dy_s = -M^-1 e1 n^T, dn/dy_t = -M^-1 e2 n^T."""
        lay, D = self.lay, self.D
        i1, i2 = lay.g1_pairs[:, 0], lay.g1_pairs[:, 1]
        side = nb[i1]
        dB, dA = D @ b, D @ a
        out = []
        for idx, ys, yt, sgn in ((i1, b[i1] - a[i1], dB[i1], 1.0), (i2, b[i2] - a[i2], dA[i2], -1.0)):
            # where (E - dr^2) G - F^2 < 0 there is no envelope; the root is clamped to 0 so the
            # residual stays continuous there (zeroing it would let the optimiser hide kinks in it)
            n, _ = envelope_normal(ys, yt, dr, side)
            ok = np.isfinite(n).all(1)
            M = np.stack([ys, yt, np.where(ok[:, None], n, side)], axis=1)
            det = np.linalg.det(M)
            ok &= np.abs(det) > 1e-12 * (np.linalg.norm(ys, axis=1) ** 2 * np.linalg.norm(yt, axis=1) + 1e-300)
            Minv = np.linalg.inv(np.where(ok[:, None, None], M, np.eye(3)))
            Js = -Minv[:, :, 0, None] * n[:, None, :]                  # (P, 3, 3) dn/dy_s
            Jt = -Minv[:, :, 1, None] * n[:, None, :]                  # dn/dy_t
            Js[~ok], Jt[~ok] = 0.0, 0.0
            Jdr = np.where(ok[:, None], Minv[:, :, 0], 0.0)            # dn/d(dr): n . y_s = dr
            out.append((idx, n, ok, Js, Jt, sgn, Jdr))
        (_, n1, ok1, _, _, _, _), (_, n2, ok2, _, _, _, _) = out
        good = ok1 & ok2
        P = len(i1)
        res.append((c3 * np.where(good[:, None], n1 - n2, 0.0)).ravel())
        rows3 = row0 + 3 * np.arange(P)[:, None] + np.arange(3)[None, :]           # (P, 3)
        g = good.astype(float)[:, None, None]
        for idx, n, ok, Js, Jt, sgn, Jdr in out:
            Js, Jt, Jdr = sgn * c3 * Js * g, sgn * c3 * Jt * g, sgn * c3 * Jdr * g[:, :, 0]
            # y_s = b - a of this ruling
            rr = np.repeat(rows3[:, :, None], 3, axis=2)
            add(rr, np.repeat(xyz(lay.gb[idx])[:, None, :], 3, axis=1), Js)
            add(rr, np.repeat(xyz(lay.ga[idx])[:, None, :], 3, axis=1), -Js)
            # y_t = D rail: b for the lower strip's base end (sgn +), a for the upper strip's tip end
            Didx, Dsub = self.D_pairs[sgn]
            rail = lay.gb if sgn > 0 else lay.ga
            coef = Dsub.data[:, None, None] * Jt[Dsub.row]                         # (nnz, 3, 3)
            add(np.repeat(rows3[Dsub.row][:, :, None], 3, axis=2),
                np.repeat(xyz(rail[Dsub.col])[:, None, :], 3, axis=1), coef)
            for k in ("r1", "r2"):
                if k in col_of:
                    dys = db[k][idx] - da[k][idx]
                    drail = (db if sgn > 0 else da)[k]
                    dyt = Didx @ drail
                    add(rows3, np.full(rows3.shape, col_of[k]),
                        np.einsum("pij,pj->pi", Js, dys) + np.einsum("pij,pj->pi", Jt, dyt)
                        + (Jdr if k == "r2" else -Jdr))
        return row0 + 3 * P

    def fun(self, x):
        return self._evaluate(x)[0]

    def jac(self, x):
        return self._evaluate(x)[1]

    def terms(self, x):
        """The five terms of Eq. (18) (unweighted, with the paper's normalisations) at x."""
        f, _ = self._evaluate(x)
        lay = self.lay
        n_g1 = (3 if self.g1_term == "envelope" else 1) * len(lay.g1_pairs)
        sizes = [lay.n_rulings, lay.n_rulings * self.K, n_g1, 3 * lay.n_points, 3 * len(lay.fair)]
        counts = [lay.n_rulings, 3 * lay.n_rulings * self.K, max(len(lay.g1_pairs), 1), 3 * lay.n_points,
                  3 * max(len(lay.fair), 1)]
        out, o = {}, 0
        for name, c, n, cnt in zip(WEIGHT_NAMES, self.c, sizes, counts):
            block = f[o:o + n]
            # block = c e with c^2 = w / count: the paper's term (1/count) sum e^2 = sum block^2 / w
            out[name] = float((block ** 2).sum() / (c * c * cnt)) if c > 0 and n else 0.0
            o += n
        return out


def surface_normals_at(mesh, points, side=1.0):
    """Unit normals (n, 3) of the surface at the foot points of ``points`` (n, 3), pointing to the
    points' side when they are off the surface (the gradient of the distance)."""
    fp = mesh.foot_points(points)
    return fp["gradient"]


def optimize(mesh, layout, m_ini, normals, r1, r2, L, K=30, weights=DEFAULT_WEIGHTS, free=(), rounds=1,
             max_nfev=100, report=None, g1_term="envelope", tangents=None, scale=None):
    """Minimise Eq. (18) starting from the m-grid ``m_ini`` (P, 3) with surface normals ``normals``
    (P, 3).

    ``tangents`` (P, 3), the guiding curves' unit tangents at the base points: when given, each
    m-grid point moves only in the normal plane of its guiding curve (2 unknowns: across the curve
    in the tangent plane, and along the surface normal) instead of freely (3 unknowns, the
    paper's).  Sliding along the curves only re-times the motion, but the objective barely sees it
    (Eq. (17) has weight 1e-4), and on curved surfaces the G1 term then drags whole rulings along
    the curves, off the patch where the tangent-plane model of Eq. (13) is flat; without the slide
    the result stays on the surface the user gave.
    Returns dict(m, normals, tool, terms_initial, terms, nfev, status)."""
    m = np.asarray(m_ini, float).copy()
    nrm = np.asarray(normals, float).copy()
    tool = {"r1": float(r1), "r2": float(r2), "L": float(L)}
    first, nfev, status = None, 0, 0
    P = layout.n_points
    for rnd in range(max(1, int(rounds))):
        rep = None if report is None else substage(report, rnd / rounds, (rnd + 1) / rounds)
        obj = Objective(mesh, layout, nrm, m_ini, tool["r1"], tool["r2"], tool["L"], K, weights, free, rep,
                        g1_term, m_start=m, scale=scale)
        x0 = obj.pack(m, tool)
        if first is None:
            first = obj.terms(x0)
        nt = len(obj.free)
        if tangents is not None:
            t = np.asarray(tangents, float)
            across = np.cross(nrm, t)
            across /= np.maximum(np.linalg.norm(across, axis=1, keepdims=True), 1e-300)
            # x = x0 + B z: z = (across, normal) offsets per point, then the tool variables
            rows = np.r_[(3 * np.arange(P)[:, None] + np.arange(3)).ravel(), (3 * np.arange(P)[:, None] + np.arange(3)).ravel(),
                         3 * P + np.arange(nt)]
            cols = np.r_[np.repeat(2 * np.arange(P), 3), np.repeat(2 * np.arange(P) + 1, 3), 2 * P + np.arange(nt)]
            vals = np.r_[across.ravel(), nrm.ravel(), np.ones(nt)]
            B = sp.csr_matrix((vals, (rows, cols)), shape=(3 * P + nt, 2 * P + nt))
            z0 = np.r_[np.zeros(2 * P), x0[3 * P:]]
            base = np.r_[x0[:3 * P], np.zeros(nt)]

            def to_x(z, B=B, base=base):
                return base + B @ z

            fun = (lambda z, to_x=to_x, obj=obj: obj.fun(to_x(z)))
            jac = (lambda z, to_x=to_x, obj=obj, B=B: obj.jac(to_x(z)) @ B)
            start, tool_at = z0, 2 * P
        else:
            to_x = (lambda z: z)
            fun, jac, start, tool_at = obj.fun, obj.jac, x0, 3 * P
        lo = np.full(len(start), -np.inf)
        hi = np.full(len(start), np.inf)
        for i, k in enumerate(obj.free):
            lo[tool_at + i] = 0.0 if k != "L" else 1e-9 * tool["L"]
        # the residuals are dimensionless and the unknowns lengths, so the gradient scales as 1 / L0; scipy's
        # gtol test reads the gradient unscaled (x_scale does not enter it), and a fixed gtol stopped a plan in
        # metres after a few evaluations while the same plan in millimetres ran on: gtol in units of 1 / L0
        sol = least_squares(fun, start, jac=jac, method="trf", tr_solver="lsmr", x_scale="jac",
                            bounds=(lo, hi) if obj.free else (-np.inf, np.inf), max_nfev=max_nfev,
                            xtol=1e-10, ftol=1e-10, gtol=GTOL / obj.L0)
        nfev += sol.nfev
        status = sol.status
        x = to_x(sol.x)
        m, tool = obj.unpack(x)
        last_terms = obj.terms(x)
        if rnd + 1 < rounds:
            # Eq. (10)'s normals for the next solve: the surface normals at the m-grid's new foot
            # points (the rails of the result use the normals they were optimised with)
            nrm = surface_normals_at(mesh, m)
    return {"m": m, "normals": nrm, "tool": tool, "terms_initial": first, "terms": last_terms, "nfev": nfev,
            "status": int(status)}


# ============================================================================ envelopes (Eqs. (5)-(6))
def _time_params(a, b):
    """Time parameters of a strip's rulings: uniform in [0, 1] (the paper's pseudo-time t).

    The base points are evenly spaced along the guiding curves (step h), so uniform knots follow
    the motion; unlike chord-length knots they do not move while the optimiser moves the rulings,
    so the rails' derivative map (:func:`rail_derivative_matrix`) is the same in the optimiser
    and in every later evaluation of the plan."""
    return np.linspace(0.0, 1.0, len(a))


def envelope(a, b, r1, r2, n_s=9, n_t=None, side_hint=None):
    """Envelope of the conical tool along a strip's rulings (Eqs. (5)-(6)).

    a, b (N, 3) rulings (tip, base sphere centres) in time order; the rails are C2 cubic splines.
    Returns dict(points (n_t, n_s, 3), normals (n_t, n_s, 3) unit envelope normals (pointing from
    the envelope into the tool), s (n_s,), t (n_t,), valid (n_t, n_s) bool) for the branch whose
    normal agrees with ``side_hint`` (n_t, 3) (e.g. surface normals along the strip; the branch
    facing the surface).  Where (E - dr^2) G - F^2 < 0 the motion has no real envelope (valid False)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    N = len(a)
    if N < 2:
        raise ValueError(f"a strip needs at least 2 rulings, got {N}")
    tau = _time_params(a, b)
    n_t = max(2 * N - 1, 2) if n_t is None else int(n_t)
    t = np.linspace(0.0, 1.0, n_t)
    if N >= 3:
        sa, sb = CubicSpline(tau, a, bc_type="natural"), CubicSpline(tau, b, bc_type="natural")
        A, B, dA, dB = sa(t), sb(t), sa(t, 1), sb(t, 1)
    else:
        A = a[0] + t[:, None] * (a[1] - a[0])
        B = b[0] + t[:, None] * (b[1] - b[0])
        dA, dB = np.broadcast_to(a[1] - a[0], A.shape), np.broadcast_to(b[1] - b[0], B.shape)
    s = np.linspace(0.0, 1.0, int(n_s))
    y = (1 - s)[None, :, None] * A[:, None, :] + s[None, :, None] * B[:, None, :]
    ys = np.broadcast_to((B - A)[:, None, :], y.shape)
    yt = (1 - s)[None, :, None] * dA[:, None, :] + s[None, :, None] * dB[:, None, :]
    if side_hint is None:
        side = np.cross(B - A, dA + dB)
    else:
        side = np.asarray(side_hint, float)
    # the branch whose normal points to the tool from the surface side: n . side > 0
    n, valid = envelope_normal(ys.reshape(-1, 3), yt.reshape(-1, 3), r2 - r1,
                               np.repeat(side, len(s), axis=0))
    n, valid = n.reshape(y.shape), valid.reshape(y.shape[:2])
    r = (1 - s) * r1 + s * r2
    x = y - r[None, :, None] * n
    return {"points": x, "normals": n, "axis_points": y, "s": s, "t": t, "valid": valid}


# ============================================================================ evaluation of a plan
def strip_rulings(plan_strip):
    """(a (N, 3), b (N, 3)) of a plan strip's ``rulings``."""
    R = np.asarray(plan_strip["rulings"], float)
    return R[:, 0, :], R[:, 1, :]


def _side_hint(mesh, a, b, n_t):
    """Surface normals along a strip (for the envelope branch), at n_t times."""
    tau = _time_params(a, b)
    mid = 0.5 * (a + b)
    nr = mesh.foot_points(mid)["normal"]
    t = np.linspace(0, 1, n_t)
    out = np.stack([np.interp(t, tau, nr[:, k]) for k in range(3)], axis=1)
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def strip_envelopes(mesh, strips_ab, r1, r2, n_s=9, n_t=None, exact=True):
    """Envelope (see :func:`envelope`) and the exact signed distance ``deviation`` (n_t, n_s) of its
    points to the mesh (+ = material left) for each strip's (a, b)."""
    out = []
    for a, b in strips_ab:
        nt = max(2 * len(a) - 1, 2) if n_t is None else n_t
        env = envelope(a, b, r1, r2, n_s, nt, _side_hint(mesh, a, b, nt))
        fp = mesh.foot_points(np.nan_to_num(env["points"]).reshape(-1, 3), exact=exact)
        dev = np.where(fp["off_surface"], np.nan, fp["distance"]).reshape(env["valid"].shape)
        env["deviation"] = np.where(env["valid"], dev, np.nan)
        out.append(env)
    return out


def ruling_errors(mesh, a, b, r1, r2, K=30, exact=True):
    """Eq. (19): sd(y^k) - r^k (N, K) for the ruling samples of a strip (+ = tool too far, material
    left); the paper's strip error is its maximum.  Samples beyond the border of the surface (the tool
    overhanging the patch, see TriangleMesh.foot_points) are NaN: there is nothing to machine."""
    s = _samples(K)
    y = (1 - s)[None, :, None] * a[:, None, :] + s[None, :, None] * b[:, None, :]
    fp = mesh.foot_points(y.reshape(-1, 3), exact=exact)
    sd = np.where(fp["off_surface"], np.nan, fp["distance"]).reshape(len(a), K)
    return sd - ((1 - s) * r1 + s * r2)[None, :]


def _rails_at(a, b, t):
    """Rails A, B (n, 3) and their time derivatives at times t (n,) on the strip's splines."""
    tau = _time_params(a, b)
    if len(a) >= 3:
        sa, sb = CubicSpline(tau, a, bc_type="natural"), CubicSpline(tau, b, bc_type="natural")
        return sa(t), sb(t), sa(t, 1), sb(t, 1)
    w = (t - tau[0]) / (tau[-1] - tau[0])
    da, db = (a[-1] - a[0]) / (tau[-1] - tau[0]), (b[-1] - b[0]) / (tau[-1] - tau[0])
    return (a[0] + w[:, None] * (a[-1] - a[0]), b[0] + w[:, None] * (b[-1] - b[0]),
            np.broadcast_to(da, (len(t), 3)), np.broadcast_to(db, (len(t), 3)))


def kinks_at_rulings(mesh, strips_ab, columns, r1, r2, sub=4):
    """Kink angles along every shared boundary: the angle between strip i's envelope normal at its
    base edge (s = 1) and strip i + 1's at its tip edge (s = 0), at every shared column and at
    ``sub`` - 1 times between consecutive shared columns (the rails' splines), so the figure covers
    the whole boundary and not only the times the optimiser sees.

    Returns a list (one per pair of neighbouring strips) of dict(points (k, 3) midpoints of the two
    edges, kink_deg (k,), columns (k,) the column id at rulings and interpolated between, at_ruling
    (k,) bool)."""
    out = []
    sub = max(1, int(sub))
    for i in range(len(strips_ab) - 1):
        (a1, b1), (a2, b2) = strips_ab[i], strips_ab[i + 1]
        common, p, q = np.intersect1d(columns[i], columns[i + 1], return_indices=True)
        if len(common) == 0:
            out.append({"points": np.zeros((0, 3)), "kink_deg": np.zeros(0), "columns": np.zeros(0),
                        "at_ruling": np.zeros(0, bool)})
            continue
        o = np.argsort(p)
        common, p, q = common[o], p[o], q[o]
        tau1, tau2 = _time_params(a1, b1), _time_params(a2, b2)
        t1, t2, col, at = [tau1[p]], [tau2[q]], [common.astype(float)], [np.ones(len(p), bool)]
        run = np.flatnonzero((np.diff(p) == 1) & (np.diff(q) == 1))     # neighbouring rulings in both strips
        for f in np.arange(1, sub) / sub:
            t1.append(tau1[p[run]] + f * (tau1[p[run] + 1] - tau1[p[run]]))
            t2.append(tau2[q[run]] + f * (tau2[q[run] + 1] - tau2[q[run]]))
            col.append(common[run] + f * (common[run + 1] - common[run]))
            at.append(np.zeros(len(run), bool))
        t1, t2, col, at = (np.concatenate(x) for x in (t1, t2, col, at))
        o = np.argsort(col, kind="stable")
        t1, t2, col, at = t1[o], t2[o], col[o], at[o]
        A1, B1, dA1, dB1 = _rails_at(a1, b1, t1)
        A2, B2, dA2, dB2 = _rails_at(a2, b2, t2)
        side = mesh.foot_points(0.5 * (B1 + A2))["normal"]
        n1, ok1 = envelope_normal(B1 - A1, dB1, r2 - r1, side)
        n2, ok2 = envelope_normal(B2 - A2, dA2, r2 - r1, side)
        c = np.clip((n1 * n2).sum(1), -1, 1)
        ok = ok1 & ok2
        pts = 0.5 * ((B1 - r2 * n1) + (A2 - r1 * n2))
        out.append({"points": pts[ok], "kink_deg": np.degrees(np.arccos(c))[ok], "columns": col[ok],
                    "at_ruling": at[ok]})
    return out


def collision_check(mesh, a, b, tool, engaged, clearance=0.0):
    """Fig. 4 post-check per ruling: the tool's parts that should not touch the surface, i.e. the
    cone below the engaged part (tip side, when engagement < 1) and the shank along the extended
    axis beyond b, must keep their radii from the surface.  Returns a bool (N,) array, True =
    collides (some sample closer than its radius - clearance)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    u = b - a
    Le = np.linalg.norm(u, axis=1, keepdims=True)
    u = u / Le
    checks = []
    r1e, r2 = engaged["r1"], tool["r2"]
    r1 = tool["r1"]
    tip_len = tool["L"] - engaged["L"]
    if tip_len > 1e-12 * tool["L"]:
        s = np.linspace(0.0, 1.0, 6)[:-1]                   # tip .. start of the engaged part
        # distance below a along the axis, radius of the full cone there
        back = (1 - s) * tip_len
        pts = a[:, None, :] - back[None, :, None] * u[:, None, :]
        rad = r1 + s * (r1e - r1)
        checks.append((pts, np.broadcast_to(rad, pts.shape[:2])))
    sl, sr = tool.get("shank_length", 0.0), tool.get("shank_radius", r2)
    if sl > 0:
        s = np.linspace(0.0, 1.0, 9)[1:]
        pts = b[:, None, :] + (s * sl)[None, :, None] * u[:, None, :]
        checks.append((pts, np.full(pts.shape[:2], sr)))
    hit = np.zeros(len(a), bool)
    for pts, rad in checks:
        d = mesh.foot_points(pts.reshape(-1, 3))["distance"].reshape(rad.shape)
        hit |= (d < rad - clearance - 1e-9 * tool["L"]).any(1)
    return hit


# ============================================================================ the planner
def _nanext(fn, a):
    """max / min ignoring NaN (samples beyond the surface); 0.0 if there is none."""
    a = np.asarray(a, float)
    return float(fn(a)) if np.isfinite(a).any() else 0.0


def engaged_cone(r1, r2, L, engagement):
    """The engaged part of the tool (Fig. 18): the upper ``engagement`` fraction of the axis next to
    the base: (r1_e, r2, L_e)."""
    e = float(engagement)
    if not (math.isfinite(e) and 0.05 <= e <= 1.0):
        raise ValueError(f"tool engagement = {engagement!r} is outside the limits 0.05 .. 1 (fraction of the tool)")
    return r2 - e * (r2 - r1), r2, e * L


def _check_tool(r1, r2, L, shank_radius, shank_length):
    for name, v in (("r1", r1), ("r2", r2), ("L", L)):
        if not (isinstance(v, (int, float)) and math.isfinite(v)):
            raise ValueError(f"tool {name} = {v!r} must be a finite number")
    if r1 < 0 or r2 < 0:
        raise ValueError(f"tool radii r1 = {r1}, r2 = {r2} must be >= 0")
    if not L > abs(r2 - r1):
        raise ValueError(f"tool length L = {L} must exceed r2 - r1 = {r2 - r1} (otherwise no flank exists)")
    for name, v in (("shank radius", shank_radius), ("shank length", shank_length)):
        if not (math.isfinite(v) and v >= 0):
            raise ValueError(f"{name} = {v!r} must be a finite number >= 0")


def plan_freeform(vertices, faces, *, direction=None, point=None, field_vectors=None, r1, r2, L,
                  spacing=None, weights=None, n_ruling_samples=30, n_columns=20, engagement=1.0,
                  optimize_tool=(), rounds=1, max_nfev=100, shank_radius=None, shank_length=0.0, slide=False,
                  weight_units="tool", g1_term="envelope", flip_normals=False,
                  length_unit="mm", n_envelope_s=9, progress=None, guiding_options=None):
    """Plan G1 multi-strip flank milling of a triangle mesh (Rajain et al. 2023); returns a flank-plan/1 dict.

    vertices (V, 3), faces (F, 3): the surface, tool on the side its normals point to.
    direction (3,) at point (3,) (default: the mesh centre), or field_vectors (V or F, 3): the
    guiding direction (§3).  r1, r2 tip and base sphere radii (the paper assumes r1 <= r2 but its
    blisk example, Table 1, has r1 = 1 > r2 = 0.3; both work), L axis length (Eqs. (1)-(2)).
    spacing d (default sqrt(L_e^2 - (r2 - r1_e)^2) of the engaged cone), weights w1..w5 of Eq. (18)
    (default :data:`DEFAULT_WEIGHTS`), K = n_ruling_samples (Eq. (11)), N ~ n_columns rulings per
    strip (sets the base-point step h; None keeps the paper's 1/100 of the bounding box),
    engagement: fraction of the tool next to its base that cuts (Fig. 18), optimize_tool: any of
    'L', 'r1', 'r2' as variables (§7.2).  weight_units 'tool' divides every length in Eq. (18) by L
    (weights independent of the unit), 'length' keeps the paper's literal terms in the document's
    unit (so the paper's weights, chosen for millimetres, apply as printed to mm data).  g1_term
    'envelope' (default) compares the envelope normals where strips meet, 'paper' uses
    Eqs. (15)-(16).  flip_normals: the tool is on the side opposite to the face normals (the plan
    stores the flipped faces, so its surface has the tool on its normals' side).
    """
    from ...io.plan import SCHEMA, validate_plan
    t_start = time.perf_counter()
    report = reporter(progress)
    r1, r2, L = float(r1), float(r2), float(L)
    sr = r2 if shank_radius is None else float(shank_radius)
    _check_tool(r1, r2, L, sr, float(shank_length))
    w = np.asarray(DEFAULT_WEIGHTS if weights is None else weights, float)
    if w.shape != (5,) or not np.isfinite(w).all() or (w < 0).any():
        raise ValueError(f"weights must be 5 finite numbers >= 0 (w1 rigid, w2 approx, w3 G1, w4 proximity, "
                         f"w5 fair), got {weights!r}")
    if not w[1] > 0:
        raise ValueError(f"the approximation weight w2 = {w[1]:g} must be > 0: without it nothing in Eq. (18) "
                         f"holds the tool to the surface (weights {w.tolist()})")
    # only the weights' ratios set the optimum of Eq. (18); the solver's tolerances are absolute, so weights
    # 1e-12 or 1e300 times the defaults stopped at the start or overflowed.  Solved with the largest weight 1
    # (the defaults are so already: dividing by 1.0 changes no bit); the plan keeps the weights as given.
    w_solve = w / w.max()
    K = int(n_ruling_samples)
    if not 2 <= K <= 200:
        raise ValueError(f"samples per ruling K = {n_ruling_samples!r} is outside the limits 2 .. 200")
    bad = [k for k in optimize_tool if k not in ("L", "r1", "r2")]
    if bad:
        raise ValueError(f"optimize_tool may hold 'L', 'r1', 'r2', got {bad}")
    r1e, r2e, Le = engaged_cone(r1, r2, L, engagement)
    faces = np.asarray(faces)
    if flip_normals:                      # machine the other side: reverse every triangle
        faces = faces[:, ::-1]
    mesh = TriangleMesh(vertices, faces)
    report(0.0, "guiding curves")
    gopt = dict(guiding_options or {})
    if n_columns is not None:
        n_columns = int(n_columns)
        if not 2 <= n_columns <= 2000:
            raise ValueError(f"rulings per strip N = {n_columns} is outside the limits 2 .. 2000")
    gc = _guiding.guiding_curves(mesh.vertices, mesh.faces, direction=direction, point=point,
                                 field_vectors=field_vectors, r1=r1e, r2=r2e, L=Le, spacing=spacing, **gopt)
    if n_columns is not None and "step" not in gopt and gc.curves:
        lengths = [sum(pl.length for pl in c.polylines) for c in gc.curves]
        step = float(np.median(lengths)) / (n_columns - 1)
        first = gc
        for _ in range(4):          # the strips' own lengths set N; a few corrections of h reach it
            gc = _guiding.guiding_curves(mesh.vertices, mesh.faces, direction=direction, point=point,
                                         field_vectors=field_vectors, r1=r1e, r2=r2e, L=Le, spacing=spacing,
                                         step=step, reuse=first, **gopt)
            got = float(np.median([len(st.columns) for st in gc.strips])) if gc.strips else n_columns
            if abs(got - n_columns) < 1 or got < 2:
                break
            step *= ((got - 1) / (n_columns - 1)) ** (0.9 if got > n_columns else 1.1)
    strips = [s for s in gc.strips if len(s.columns) >= 2]
    if not strips:
        raise ValueError(f"no strip: the surface holds {len(gc.curves)} guiding curve(s) at spacing "
                         f"d = {gc.spacing:.6g}; at least 2 sharing 2 base points are needed (a smaller tool "
                         "or spacing, or a larger surface)")
    # keep the strips' order; renumber so that neighbours in the list are neighbours on the surface
    ini = initial_rulings(gc.bases, strips, r1e, r2e, Le)
    layout = Layout(gc.bases, strips)
    m0 = np.concatenate(ini.m)
    n0 = np.concatenate([bc.normals for bc in gc.bases])
    report(0.1, "optimising")
    t_opt = time.perf_counter()
    t0 = None if slide else np.concatenate([bc.tangents for bc in gc.bases])
    if weight_units not in ("tool", "length"):
        raise ValueError(f"weight_units must be 'tool' (terms divided by the axis length) or 'length' (the paper's "
                         f"terms in the document's unit), got {weight_units!r}")
    opt = optimize(mesh, layout, m0, n0, r1e, r2e, Le, K, w_solve, tuple(optimize_tool), rounds, max_nfev,
                   substage(report, 0.1, 0.85), g1_term=g1_term, tangents=t0,
                   scale=None if weight_units == "tool" else 1.0)
    t_opt = time.perf_counter() - t_opt
    tool_e = opt["tool"]
    report(0.85, "envelopes and errors")
    a_all, b_all = rails(opt["m"], opt["normals"], layout, tool_e["r1"], tool_e["r2"])
    a_ini, b_ini = rails(m0, n0, layout, r1e, r2e)
    out_strips, strips_ab, cols = [], [], []
    full_tool = {"r1": r1 + (tool_e["r1"] - r1e), "r2": tool_e["r2"], "L": tool_e["L"] / engagement,
                 "shank_radius": sr, "shank_length": float(shank_length)}
    engaged = {"r1": tool_e["r1"], "r2": tool_e["r2"], "L": tool_e["L"]}
    # every strip's rulings in one query each (rows are independent; large queries use both cores)
    err_all = ruling_errors(mesh, a_all, b_all, tool_e["r1"], tool_e["r2"], K)
    err_ini_all = ruling_errors(mesh, a_ini, b_ini, r1e, r2e, K)
    for k, st in enumerate(strips):
        sl = slice(layout.ruling_start[k], layout.ruling_start[k + 1])
        a, b = a_all[sl], b_all[sl]
        strips_ab.append((a, b))
        cols.append(st.columns)
        err, err_ini = err_all[sl], err_ini_all[sl]
        coll = collision_check(mesh, a, b, full_tool, engaged)
        u = (b - a) / np.linalg.norm(b - a, axis=1, keepdims=True)
        shank_end = b[0] + u[0] * max(float(shank_length), 0.0)
        out_strips.append({
            "axis_start": a[0].tolist(), "axis_end": b[0].tolist(),
            "rulings": np.stack([a, b], axis=1).tolist(),
            "radii": [tool_e["r1"], tool_e["r2"]],
            "columns": st.columns.tolist(),
            "guiding_curves": [int(st.index), int(st.index) + 1],
            "shank_start": b[0].tolist(), "shank_end": shank_end.tolist(), "shank_radius": sr,
            "flank": 0,
            "reported_max_error": _nanext(np.nanmax, err), "reported_min_error": _nanext(np.nanmin, err),
            "initial_max_error": _nanext(np.nanmax, err_ini), "initial_min_error": _nanext(np.nanmin, err_ini),
            "overhanging_samples": int(np.isnan(err).sum()),
            "axis_lengths": np.linalg.norm(b - a, axis=1).tolist(),
            "initial_axis_lengths": np.linalg.norm(b_ini[sl] - a_ini[sl], axis=1).tolist(),
            "collision": bool(coll.any()), "colliding_rulings": np.flatnonzero(coll).tolist(),
        })
    report(0.93, "kink angles")
    kinks = kinks_at_rulings(mesh, strips_ab, cols, tool_e["r1"], tool_e["r2"])
    ini_ab = [(a_ini[slice(layout.ruling_start[k], layout.ruling_start[k + 1])],
               b_ini[slice(layout.ruling_start[k], layout.ruling_start[k + 1])]) for k in range(len(strips))]
    kinks_ini = kinks_at_rulings(mesh, ini_ab, cols, r1e, r2e)
    allk = np.concatenate([k["kink_deg"] for k in kinks]) if kinks else np.zeros(0)
    allk_ini = np.concatenate([k["kink_deg"] for k in kinks_ini]) if kinks_ini else np.zeros(0)
    for k, kk in enumerate(kinks):
        out_strips[k]["kink_to_next_deg"] = kk["kink_deg"].tolist()
        out_strips[k]["kink_columns"] = kk["columns"].tolist()
    elapsed = time.perf_counter() - t_start
    lengths = np.concatenate([s["axis_lengths"] for s in out_strips])
    plan = {
        "schema": SCHEMA,
        "method": METHOD,
        "length_unit": length_unit,
        "surface": {"kind": "mesh", "vertices": rows_to_tuples(mesh.vertices), "faces": rows_to_tuples(mesh.faces),
                    "tool_side": "normals"},
        "target_flanks": [],
        "tool": {"kind": "cone", "r1": full_tool["r1"], "r2": full_tool["r2"], "length": full_tool["L"],
                 "engagement": float(engagement), "shank_radius": sr, "shank_length": float(shank_length)},
        "guiding": {
            "direction": None if direction is None else np.asarray(direction, float).tolist(),
            "point": None if point is None else np.asarray(point, float).tolist(),
            "field": field_vectors is not None, "spacing": float(gc.spacing), "step": float(gc.step),
            "curves": [[pl.points.tolist() for pl in c.polylines] for c in gc.curves],
        },
        "optimization": {
            "weights": dict(zip(WEIGHT_NAMES, w.tolist())), "samples_per_ruling": K,
            "free_tool_variables": list(optimize_tool), "rounds": int(rounds), "slide_along_curves": bool(slide),
            "weight_units": weight_units, "g1_term": g1_term, "evaluations": int(opt["nfev"]),
            "terms_initial": opt["terms_initial"], "terms": opt["terms"], "elapsed_s": t_opt,
            "n_variables": 3 * layout.n_points + len(optimize_tool),
        },
        "strips": out_strips,
    }
    err_max = max(s["reported_max_error"] for s in out_strips)
    err_min = min(s["reported_min_error"] for s in out_strips)
    plan["summary"] = {
        "max_error": float(err_max), "min_error": float(err_min), "elapsed_s": float(elapsed),
        "max_kink_deg": float(allk.max()) if len(allk) else 0.0,
        "mean_kink_deg": float(allk.mean()) if len(allk) else 0.0,
        "initial_max_kink_deg": float(allk_ini.max()) if len(allk_ini) else 0.0,
        "initial_mean_kink_deg": float(allk_ini.mean()) if len(allk_ini) else 0.0,
        "initial_max_error": float(max(s["initial_max_error"] for s in out_strips)),
        "initial_min_error": float(min(s["initial_min_error"] for s in out_strips)),
        "axis_length_range": [float(lengths.min()), float(lengths.max())],
        "strips": len(out_strips), "rulings": int(layout.n_rulings),
        "colliding_rulings": int(sum(len(s["colliding_rulings"]) for s in out_strips)),
        "overhanging_samples": int(sum(s["overhanging_samples"] for s in out_strips)),
        "samples": int(layout.n_rulings * K),
    }
    # how far any G1 weight could go on this surface with straight strips (Rajain et al. 2023 §7.2, kink_bound)
    from .kink_bound import plan_section_bounds
    bounds = plan_section_bounds(mesh_sections(mesh, gc.bases), plan["summary"]["max_kink_deg"],
                                 max(abs(float(err_max)), abs(float(err_min))))
    plan["summary"]["kink_floor_deg"] = bounds["kink_floor_deg"]
    plan["summary"]["error_bound_at_kink"] = bounds["error_bound"]
    report(1.0, "done")
    return validate_plan(plan)


def mesh_sections(mesh, bases, n_sections=3, per_strip=40):
    """Sections of the surface across the strips for :mod:`.kink_bound`: at up to ``n_sections``
    columns that every guiding curve holds (quartiles of them), the base points of all curves
    joined by ``per_strip`` foot points of their chords.  -> list of (y, z, n_junctions)."""
    from .kink_bound import section_graph
    if len(bases) < 3:
        return []
    common = bases[0].columns
    for bc in bases[1:]:
        common = np.intersect1d(common, bc.columns)
    if len(common) == 0:
        return []
    picks = np.unique(common[np.round(np.linspace(0.25, 0.75, n_sections) * (len(common) - 1)).astype(int)])
    t = np.linspace(0.0, 1.0, per_strip, endpoint=False)
    out = []
    for c in picks:
        g = np.array([bc.points[np.flatnonzero(bc.columns == c)[0]] for bc in bases])
        chord = (g[:-1, None, :] * (1 - t)[None, :, None] + g[1:, None, :] * t[None, :, None]).reshape(-1, 3)
        fp = mesh.foot_points(np.vstack([chord, g[-1:]]))
        sec = section_graph(fp["foot"], fp["normal"])
        if sec is not None:
            out.append((sec[0], sec[1], len(bases) - 2))
    return out


# ============================================================================ plan readers (Blender, exports)
def plan_mesh(plan):
    """TriangleMesh of a free-form plan's surface."""
    s = plan["surface"]
    return TriangleMesh(lists_to_array(s["vertices"], float), lists_to_array(s["faces"], np.int64))


def freeform_envelopes(plan, n_s=9, n_t=None, mesh=None):
    """Per strip: dict(vertices (n_t n_s, 3), faces (m, 4) quads, deviation (n,) signed exact
    distance to the surface, + = material left; NaN where the motion has no envelope or the point
    hangs over the surface's border (nothing to machine there), shape (n_t, n_s), normals (n, 3))."""
    mesh = plan_mesh(plan) if mesh is None else mesh
    out = []
    for st in plan["strips"]:
        a, b = strip_rulings(st)
        r1, r2 = st["radii"][0], st["radii"][-1]
        env = strip_envelopes(mesh, [(a, b)], r1, r2, n_s, n_t)[0]
        nt, ns = env["valid"].shape
        i, j = np.meshgrid(np.arange(nt - 1), np.arange(ns - 1), indexing="ij")
        v00 = (i * ns + j).ravel()
        quads = np.c_[v00, v00 + ns, v00 + ns + 1, v00 + 1]
        out.append({"vertices": env["points"].reshape(-1, 3), "faces": quads, "shape": (nt, ns),
                    "deviation": env["deviation"].ravel(), "normals": env["normals"].reshape(-1, 3)})
    return out


def freeform_kinks(plan, mesh=None):
    """Per shared boundary: dict(points (k, 3), kink_deg (k,), columns (k,))."""
    mesh = plan_mesh(plan) if mesh is None else mesh
    ab = [strip_rulings(st) for st in plan["strips"]]
    cols = [np.asarray(st["columns"], np.int64) for st in plan["strips"]]
    r1, r2 = plan["strips"][0]["radii"][0], plan["strips"][0]["radii"][-1]
    return kinks_at_rulings(mesh, ab, cols, r1, r2)


def sweep_deviation(plan, points=None, n_t=None, n_s=40, k=24, mesh=None):
    """Independent check by sweeping the tool: signed distance (n,) from surface points (default: the
    mesh vertices) to the union of all tool positions, + = material left, - = gouge.

    The tool at one instant is the union of the spheres of Eq. (2) along the axis; the motion is
    sampled at n_t instants per strip (default 4 per ruling) on the same spline rails as the
    envelopes, the axis at n_s points.  Each point's value is min |p - y| - r over all the spheres
    (:func:`least_sphere_values`, which asks the kd-tree for the nearest centres in one array first, k of
    them or as many as most points have within reach, up to 256, and lists the rest by ball where needed).
    Returns (deviation (n,), index of the closest strip (n,), inside (n,) True where the closest sphere
    is not on the border of the machined region (the first or last instant of a strip, the free tip end
    of the first strip or base end of the last)."""
    mesh = plan_mesh(plan) if mesh is None else mesh
    P = mesh.vertices if points is None else np.asarray(points, float)
    C, Rr, S, E = [], [], [], []
    s = np.linspace(0.0, 1.0, int(n_s))
    last = len(plan["strips"]) - 1
    for j, st in enumerate(plan["strips"]):
        a, b = strip_rulings(st)
        r1, r2 = float(st["radii"][0]), float(st["radii"][-1])
        nt = 4 * len(a) if n_t is None else int(n_t)
        t = np.linspace(0.0, 1.0, nt)
        tau = _time_params(a, b)
        if len(a) >= 3:
            A, B = CubicSpline(tau, a, bc_type="natural")(t), CubicSpline(tau, b, bc_type="natural")(t)
        else:
            A, B = a[0] + t[:, None] * (a[-1] - a[0]), b[0] + t[:, None] * (b[-1] - b[0])
        y = (1 - s)[None, :, None] * A[:, None, :] + s[None, :, None] * B[:, None, :]
        C.append(y.reshape(-1, 3))
        Rr.append(np.broadcast_to((1 - s) * r1 + s * r2, y.shape[:2]).ravel())
        S.append(np.full(y.shape[0] * y.shape[1], j))
        # sphere centres on the border of the machined region: first / last instant, and the free
        # ends of the outermost strips (tip of the first, base of the last)
        edge = np.zeros(y.shape[:2], bool)
        edge[[0, -1], :] = True
        if j == 0:
            edge[:, 0] = True
        if j == last:
            edge[:, -1] = True
        E.append(edge.ravel())
    C, Rr, S, E = np.concatenate(C), np.concatenate(Rr), np.concatenate(S), np.concatenate(E)
    out, idx = least_sphere_values(P, C, Rr, k)
    return out, S[idx], ~E[idx]


def least_sphere_values(P, C, Rr, k=24, cap=256):
    """min over the spheres (centres C (m, 3), radii Rr (m,)) of |p - c| - r for each point of P (n, 3), and the
    sphere that gives it (between equal values, the nearer centre; among centres listed past the nearest ones, the
    first in index order).

    The kd-tree's nearest centres come first, as one array: about as many as most points have within reach
    (:func:`_centres_to_ask`).  They need not hold the least value (a farther, bigger sphere can reach further):
    every centre within (the value so far + the largest radius) counts.  Where the last of the nearest centres
    already lies beyond that reach they held them all; the other rows list every centre within it."""
    from scipy.spatial import cKDTree

    tree = cKDTree(C)
    reach = Rr.max() + 1e-12
    kk = _centres_to_ask(tree, P, Rr, int(k), reach, cap=cap)
    d, i = _nearest_centres(tree, P, kk)
    val = d - Rr[i]
    best = np.argmin(val, axis=1)
    rows = np.arange(len(P))
    out, idx = val[rows, best], i[rows, best]
    if kk < len(C):
        rows = np.flatnonzero(~(d[:, -1] > out + reach))        # (written so that a NaN row is listed too)
        if len(rows):
            o, j = out[rows], idx[rows]
            with collector_paused():        # a list per point, all freed together: the collector would only walk them
                lists = tree.query_ball_point(P[rows], o + reach)
                _least_in_balls(P[rows], C, Rr, lists, kk, o, j)
                del lists
            out[rows], idx[rows] = o, j
    return out, idx


def _nearest_centres(tree, P, k):
    """Distances and indices (n, k) of the k centres nearest to each point of P (n, 3); 2-D also for k = 1, where
    the kd-tree answers with 1-D arrays."""
    d, i = tree.query(P, k=k)
    return np.atleast_2d(d.T).T, np.atleast_2d(i.T).T


def _centres_to_ask(tree, P, Rr, k, reach, sample=256, cap=256):
    """How many nearest sphere centres :func:`least_sphere_values` asks the kd-tree for at once: about as many as
    nineteen in twenty points have within their reach (measured on up to ``sample`` of them), at least
    min(k, ``cap``) (and 1) and at most ``cap`` (a row whose reach holds more centres gets a ball list: the
    count sets the cost, never the values).  Asking for the centres one by one in a ball list per point costs
    about twice as much per centre as the k nearest in one array, so most rows should need no list."""
    cap = max(int(cap), 1)
    n = min(tree.n, max(min(int(k), cap), 1))
    if len(P) == 0 or tree.n <= n:
        return n
    S = P[np.unique(np.linspace(0, len(P) - 1, min(len(P), sample)).astype(np.int64))]
    d, i = _nearest_centres(tree, S, n)
    counts = tree.query_ball_point(S, (d - Rr[i]).min(axis=1) + reach, return_length=True)
    return int(min(tree.n, cap, max(n, np.percentile(counts, 95))))


def _least_in_balls(P, C, Rr, lists, k, out, idx, chunk=1_000_000):
    """For each point P[n] whose ball list ``lists[n]`` (sorted centre indices) holds more than k centres: the
    least |P[n] - C[c]| - Rr[c] over them, written into out[n] and its centre into idx[n] where it is below
    out[n] (the first such centre in index order on ties).  The rows of all points are measured together, at
    most about ``chunk`` centres at a time, each row with the same numpy operations as one point at a time
    (so the same values); a Python loop over 10,000 surface vertices took most of the sweep check."""
    lens = np.fromiter(map(len, lists), np.int64, len(lists))
    many = np.flatnonzero(lens > k)
    ends = np.cumsum(lens[many])
    lo = 0
    while lo < len(many):
        hi = max(int(np.searchsorted(ends, (ends[lo - 1] if lo else 0) + chunk, side="right")), lo + 1)
        rows = many[lo:hi]
        counts = lens[rows]
        cand = np.fromiter(itertools.chain.from_iterable(lists[n] for n in rows), np.int64, int(counts.sum()))
        v = np.linalg.norm(C[cand] - P[np.repeat(rows, counts)], axis=1) - Rr[cand]
        # each row's first least (a row with a NaN picks it, and NaN is never below out: left alone)
        first = segment_argmin(v, np.repeat(np.arange(len(rows)), counts), len(rows))
        lower = v[first] < out[rows]
        out[rows[lower]], idx[rows[lower]] = v[first[lower]], cand[first[lower]]
        lo = hi


def verify_freeform(plan, tolerance=None):
    """Summary of a free-form plan checked three ways: Eq. (19) at the ruling samples, the exact
    distance of the envelope points (Eqs. (5)-(6)) to the surface, and the tool swept over the
    surface's vertices (:func:`sweep_deviation`; vertices whose closest tool sphere is on the border
    of the machined region are counted as not covered).  Lengths in the plan's unit; + = material left."""
    from ...simulation.verify import checked_tolerance

    tol = None if tolerance is None else checked_tolerance(tolerance, None)
    mesh = plan_mesh(plan)
    t0 = time.perf_counter()
    env = freeform_envelopes(plan, mesh=mesh)
    dev = np.concatenate([e["deviation"] for e in env])
    eq19 = []
    K = int(plan.get("optimization", {}).get("samples_per_ruling", 30))
    for st in plan["strips"]:
        a, b = strip_rulings(st)
        eq19.append(ruling_errors(mesh, a, b, st["radii"][0], st["radii"][-1], K))
    eq19 = np.concatenate([e.ravel() for e in eq19])
    sweep, _, covered = sweep_deviation(plan, mesh=mesh)
    kinks = freeform_kinks(plan, mesh=mesh)
    allk = np.concatenate([k["kink_deg"] for k in kinks]) if kinks else np.zeros(0)
    out = {
        "length_unit": plan["length_unit"],
        "eq19_max": _nanext(np.nanmax, eq19), "eq19_min": _nanext(np.nanmin, eq19),
        "eq19_samples_beyond_surface": int(np.isnan(eq19).sum()),
        "envelope_max": float(np.nanmax(dev)), "envelope_min": float(np.nanmin(dev)),
        "envelope_points": int(np.isfinite(dev).sum()), "envelope_without_real_points": int(np.isnan(dev).sum()),
        "sweep_min": float(sweep.min()), "sweep_max_covered": float(sweep[covered].max()) if covered.any() else None,
        "vertices": int(len(sweep)), "vertices_covered": int(covered.sum()),
        "max_kink_deg": float(allk.max()) if len(allk) else 0.0, "mean_kink_deg": float(allk.mean()) if len(allk) else 0.0,
    }
    if tol is not None:
        out["tolerance"] = float(tol)
        out["vertices_within_tolerance"] = int((np.abs(sweep[covered]) <= tol).sum())
    out["elapsed_s"] = time.perf_counter() - t0
    return out


def axis_length_histogram(plan, bins=8):
    """Fig. 11: counts of the initial and optimised axis lengths |b - a| over common bins.

    Returns dict(edges (bins + 1,), initial (bins,), optimised (bins,)), lengths in the plan's unit."""
    ini = np.concatenate([np.asarray(st.get("initial_axis_lengths", []), float) for st in plan["strips"]])
    opt = np.concatenate([np.asarray(st["axis_lengths"], float) for st in plan["strips"]])
    both = np.concatenate([ini, opt])
    lo, hi = float(both.min()), float(both.max())
    if hi - lo < 1e-12 * max(abs(hi), 1.0):
        lo, hi = lo - 0.5e-9 * max(abs(hi), 1.0), hi + 0.5e-9 * max(abs(hi), 1.0)
    edges = np.linspace(lo, hi, int(bins) + 1)
    return {"edges": edges, "initial": np.histogram(ini, edges)[0], "optimised": np.histogram(opt, edges)[0]}
