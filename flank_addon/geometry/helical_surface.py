"""Helical surfaces: evaluation, exact global foot points, curvature, inside test.

The surface is X = {S_t(p(u), 0)} for a closed transverse profile p (see
:mod:`profile`) and the screw S_t of Bizzarri, Bo & Bartoň Eq. (1).  Because S_t maps X onto
itself, the distance from a query q to X equals the distance from
q' = S_{-z_q/v0}(q), which lies in the plane z = 0.  Writing q0 for the 2D
point of q', every foot-point problem becomes the 2-parameter problem

    f(u, tau) = |R(h tau) p(u) - q0|^2 + v0^2 tau^2          (*)

(h = +1 right-handed, -1 left-handed), i.e. a function of the planar point
q0 alone.  We solve (*) by safeguarded Newton with exact derivatives of p.
Global correctness comes from a per-surface table of *global* minimisers on
a grid of q0 nodes (built once by a dense tau scan, a Newton polish and
propagation between neighbouring nodes); a query starts Newton from the
feet of the four corners of its grid cell and keeps the best.  Different
corners carry different basins exactly where the global foot jumps (the
cut locus), so near-ties are resolved there.  Hu, Zhou & Li 2025 §3.2 shows why a local
minimum is not good enough: it cost 0.1275 mm there.
"""
import hashlib
import threading
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .profile import points_in_polygon
from .screw import hand_name, hand_sign, screw_motion, screw_to_plane, screwed


@dataclass
class FootPoints:
    """Foot points of N queries: parameters, 3D points, signed distance (+ outside), unit outward normal."""
    u: np.ndarray          # (N,) profile parameter
    t: np.ndarray          # (N,) screw parameter: foot = S_t(p(u), 0)
    point: np.ndarray      # (N, 3)
    distance: np.ndarray   # (N,) signed: > 0 outside the solid, < 0 inside
    normal: np.ndarray     # (N, 3) unit outward normal of X at the foot


def _J(v):
    """Rotate 2D vectors by +90 degrees."""
    return np.stack([-v[..., 1], v[..., 0]], axis=-1)


def _keep_better(best, sel, cand):
    """Where candidate minima (u, tau, f) at rows ``sel`` beat ``best`` (u, tau, f arrays), take them."""
    u, tau, f = best
    u1, t1, f1 = cand
    better = f1 < f[sel]
    idx = sel[better]
    u[idx], tau[idx], f[idx] = u1[better], t1[better], f1[better]


def shifted_newton_step(gu, gt, huu, hut, htt):
    """Newton step (du, dt) of a 2-variable minimisation, the Hessian shifted to be positive
    definite (its smallest eigenvalue raised to 1e-8 of its scale); also returns that scale."""
    tr, det = huu + htt, huu * htt - hut ** 2
    lam_min = 0.5 * (tr - np.sqrt(np.maximum(tr * tr - 4 * det, 0.0)))
    scale = np.maximum(np.abs(huu) + np.abs(htt), 1e-30)
    shift = np.where(lam_min < 1e-8 * scale, 1e-8 * scale - lam_min, 0.0)
    a, b, c = huu + shift, hut, htt + shift
    det = a * c - b * b
    return -(c * gu - b * gt) / det, -(a * gt - b * gu) / det, scale


def exact_tree(points, leafsize=16):
    """A kd-tree for exact nearest-sample queries of the seed tables.  Midpoint splits and uncompacted node
    boxes: the samples lie on regular grids (profile parameters, screw parameters), where this tree builds in
    half the time of scipy's default tree and answers the planners' queries, most of which lie off the table,
    1.3-2.5x faster.  An exact query finds the same nearest samples in either tree, whatever its leaf size;
    an approximate one (``eps`` > 0) may not."""
    return cKDTree(points, leafsize=leafsize, balanced_tree=False, compact_nodes=False)


def _rot(v, c, s):
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def transverse_from_meridian(meridian_rz, v0, handedness="right"):
    """Transverse profile (N, 2) of the helical surface swept by a meridian (N, 2) of (r, z) points.

    The meridian lies in the half plane y = 0, x = r >= 0.  Screwing each
    point by t = -z / v0 (Bizzarri, Bo & Bartoň Eq. (1)) moves it into z = 0 without leaving
    the surface.
    """
    m = np.asarray(meridian_rz, dtype=float)
    if m.ndim != 2 or m.shape[1] != 2 or not np.isfinite(m).all():
        raise ValueError("meridian must be finite (r, z) pairs, shape (N, 2)")
    if (m[:, 0] < 0).any():
        i = int(np.flatnonzero(m[:, 0] < 0)[0])
        raise ValueError(f"meridian radius must be >= 0, row {i + 1} has r = {m[i, 0]}")
    p3 = np.c_[m[:, 0], np.zeros(len(m)), m[:, 1]]
    return screw_to_plane(p3, v0, handedness)


class HelicalSurface:
    """Helical surface of a closed transverse profile; rotor solid = inside of the profile."""

    def __init__(self, profile, v0, handedness="right"):
        if not (np.isfinite(v0) and v0 > 0):
            raise ValueError(f"v0 (axial advance per radian) must be > 0, got {v0}")
        self.profile = profile
        self.v0 = float(v0)
        self.hand = hand_sign(handedness)
        self.handedness = hand_name(self.hand)
        self.outer_radius = profile.outer_radius()
        self._table = None
        self._polygon = None
        self._slab_tree = None
        self._slab_reach = 0.06 * self.outer_radius

    @classmethod
    def from_meridian(cls, meridian_rz, v0, handedness="right"):
        """Helical surface generated by a closed meridian curve (points (r, z) in the plane y = 0).

        Bizzarri, Bo & Bartoň §3.1 / Doğrusadık: the surface is the same set whether it is swept by a
        transverse profile or by a meridian; each meridian point (r, 0, z) is
        screwed along its own helix into z = 0 (:func:`transverse_from_meridian`).
        """
        from .profile import SplineProfile

        pts = transverse_from_meridian(meridian_rz, v0, handedness)
        return cls(SplineProfile(pts), v0, handedness)

    # ------------------------------------------------------------------ evaluation
    # how far a picked point (a flank or valley asked for by a point) may lie from the surface, in outer radii:
    # a point in the middle of a valley's opening lies well within it, a point in another unit or frame does not
    PICK_LIMIT = 0.5

    def nearest_section_param(self, point, samples=8192):
        """(u, distance): the profile parameter nearest to a 3D point (rotor frame) in the transverse section
        (the point screwed into z = 0, against ``samples`` points of the profile) and its distance there."""
        q0 = screw_to_plane(np.asarray(point, float).reshape(1, 3), self.v0, self.hand)[0]
        prof = self.profile
        us = prof.params(samples)
        d = np.linalg.norm(prof.eval(us) - q0, axis=1)
        j = int(np.argmin(d))
        return us[j], float(d[j])

    def section_distance(self, point, samples=8192):
        """Distance of a 3D point (rotor frame) from the surface measured in the transverse section (to the
        profile's sampling, :meth:`nearest_section_param`)."""
        return self.nearest_section_param(point, samples)[1]

    def evaluate(self, u, t):
        u, t, p, _, c, s = self._at(u, t)
        return screwed(p[..., 0], p[..., 1], 0.0, t, c, s, self.v0)

    def normal(self, u, t):
        """Unit outward normal x_u x x_t (outward for a CCW profile, either handedness)."""
        _, _, p, dp, c, s = self._at(u, t, tangent=True)
        return self._turned_normal(p, dp, c, s)

    def point_and_normal(self, u, t):
        """(:meth:`evaluate`, :meth:`normal`) at the same parameters, the same numbers: the profile point, its tangent
        and the turn are made once for both; the foot points ask for both at every call, on a few hundred rows,
        where this takes 2/3 of the time."""
        u, t, p, dp, c, s = self._at(u, t, tangent=True)
        return screwed(p[..., 0], p[..., 1], 0.0, t, c, s, self.v0), self._turned_normal(p, dp, c, s)

    def _at(self, u, t, tangent=False):
        """(u, t broadcast, p(u), p'(u) if ``tangent`` else None, cos and sin of the turn h t).  The point and the
        tangent come from one interval search where the profile can (:meth:`SplineProfile.eval_and_tangent`)."""
        u, t = np.broadcast_arrays(np.asarray(u, float), np.asarray(t, float))
        both = getattr(self.profile, "eval_and_tangent", None) if tangent else None
        if both is not None:
            p, dp = both(u)
        else:
            p = self.profile.eval(u)
            dp = self.profile.eval(u, 1) if tangent else None
        return u, t, p, dp, np.cos(self.hand * t), np.sin(self.hand * t)

    def _turned_normal(self, p, dp, c, s):
        """The normal at (u, t) from the profile point p = p(u), its tangent dp = p'(u) and the turn's cosine c and
        sine s: the normal at t = 0 turned, written into its array."""
        n0 = self._normal_at_t0(p, dp)
        normal = np.empty(n0.shape)
        nx, ny = n0[..., 0], n0[..., 1]
        normal[..., 0], normal[..., 1], normal[..., 2] = c * nx - s * ny, s * nx + c * ny, n0[..., 2]
        return normal

    def _normal_at_t0(self, p, dp):
        h, v0 = self.hand, self.v0
        # x_u = (p', 0), x_t = (h J p, v0)
        n = np.stack([dp[..., 1] * v0, -dp[..., 0] * v0, h * (dp[..., 0] * p[..., 0] + dp[..., 1] * p[..., 1])], -1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)

    def mesh(self, n_u=720, n_t=64, z0=0.0, z1=1.0):
        """Open helical sheet between planes z0 and z1 as (verts (n_u*n_t, 3), faces (M, 3))."""
        u = self.profile.params(n_u)
        p = self.profile.eval(u)
        zs = np.linspace(z0, z1, n_t)
        p3 = np.concatenate([p, np.zeros((n_u, 1))], axis=1)
        verts = screw_motion(p3[None, :, :], (zs / self.v0)[:, None], self.v0, self.hand).reshape(-1, 3)
        i = np.arange(n_t - 1)[:, None] * n_u
        j = np.arange(n_u)[None, :]
        a = i + j
        b = i + (j + 1) % n_u
        c, d = a + n_u, b + n_u
        faces = np.concatenate([np.stack([a, b, d], -1).reshape(-1, 3), np.stack([a, d, c], -1).reshape(-1, 3)])
        return verts, faces

    # ------------------------------------------------------------------ reduced problem (*)
    def _f_and_derivs(self, u, tau, q0, order=2):
        if hasattr(self.profile, "eval_xy"):
            return self._f_and_derivs_xy(u, tau, q0, order)
        h, v0 = self.hand, self.v0
        c, s = np.cos(h * tau), np.sin(h * tau)
        if order == 0:
            d = _rot(self.profile.eval(u), c, s) - q0
            return np.einsum("...i,...i->...", d, d) + (v0 * tau) ** 2
        p0, p1, p2 = self.profile.eval_all(u)
        P = _rot(p0, c, s)
        d = P - q0
        f = np.einsum("...i,...i->...", d, d) + (v0 * tau) ** 2
        P1 = _rot(p1, c, s)
        JP = h * _J(P)
        gu = 2 * np.einsum("...i,...i->...", d, P1)
        gt = 2 * np.einsum("...i,...i->...", d, JP) + 2 * v0 ** 2 * tau
        P2 = _rot(p2, c, s)
        huu = 2 * (np.einsum("...i,...i->...", P1, P1) + np.einsum("...i,...i->...", d, P2))
        hut = 2 * (np.einsum("...i,...i->...", JP, P1) + np.einsum("...i,...i->...", d, h * _J(P1)))
        htt = 2 * (np.einsum("...i,...i->...", P, P) - np.einsum("...i,...i->...", d, P)) + 2 * v0 ** 2
        return f, gu, gt, huu, hut, htt

    def _f_and_derivs_xy(self, u, tau, q0, order=2):
        """:meth:`_f_and_derivs` on coordinate arrays (profiles with ``eval_xy``): the same numbers."""
        h, v0 = self.hand, self.v0
        ht = h * tau
        c, s = np.cos(ht), np.sin(ht)
        qx, qy = q0[..., 0], q0[..., 1]
        if order == 0:
            px, py = self.profile.eval_xy(u)
            dx = c * px - s * py - qx
            dy = s * px + c * py - qy
            return dx * dx + dy * dy + (v0 * tau) ** 2
        px, py, p1x, p1y, p2x, p2y = self.profile.eval_all_xy(u)
        Px, Py = c * px - s * py, s * px + c * py
        dx, dy = Px - qx, Py - qy
        f = dx * dx + dy * dy + (v0 * tau) ** 2
        P1x, P1y = c * p1x - s * p1y, s * p1x + c * p1y
        # h * v for the handedness h = +-1 is exact: +-v (the products h * -v of the formula, fewer numpy calls)
        JPx, JPy = (-Py, Px) if h > 0 else (Py, -Px)
        JP1x, JP1y = (-P1y, P1x) if h > 0 else (P1y, -P1x)
        gu = 2 * (dx * P1x + dy * P1y)
        gt = 2 * (dx * JPx + dy * JPy) + 2 * v0 ** 2 * tau
        P2x, P2y = c * p2x - s * p2y, s * p2x + c * p2y
        huu = 2 * ((P1x * P1x + P1y * P1y) + (dx * P2x + dy * P2y))
        hut = 2 * ((JPx * P1x + JPy * P1y) + (dx * JP1x + dy * JP1y))
        htt = 2 * ((Px * Px + Py * Py) - (dx * Px + dy * Py)) + 2 * v0 ** 2
        return f, gu, gt, huu, hut, htt

    def _newton(self, u, tau, q0, iters=40, step_tol=1e-10):
        """Safeguarded Newton on (*): Hessian shifted to be positive definite, backtracking so f never increases."""
        u = np.array(u, float)
        tau = np.array(tau, float)
        q0 = np.asarray(q0, float)
        per = self.profile.period
        step_cap = 0.25 * per
        active = np.ones(u.shape, bool)
        # the first iteration sets every point's f from its full evaluation: a value at the start is never read
        f = np.empty(u.shape) if iters > 0 else self._f_and_derivs(u, tau, q0, order=0)
        for _ in range(iters):
            if not active.any():
                break
            ia = np.flatnonzero(active)
            ua, ta, qa = u[ia], tau[ia], q0[ia]
            fa, gu, gt, huu, hut, htt = self._f_and_derivs(ua, ta, qa)
            du, dt, scale = shifted_newton_step(gu, gt, huu, hut, htt)
            # keep steps inside a trust region: a quarter of the profile, a quarter turn
            norm = np.maximum(np.abs(du) / step_cap, np.abs(dt) / (np.pi / 2))
            k = 1.0 / np.maximum(norm, 1.0)
            du, dt = du * k, dt * k
            # accept within roundoff of f, otherwise converged points would backtrack forever
            f_tol = fa + 1e-14 * (np.einsum("ij,ij->i", qa, qa) + self.outer_radius ** 2)
            alpha = np.ones_like(du)
            accepted = np.zeros(du.shape, bool)
            f_new = fa.copy()
            for _ls in range(12):
                todo = ~accepted
                if not todo.any():
                    break
                cand = self._f_and_derivs(ua[todo] + alpha[todo] * du[todo], ta[todo] + alpha[todo] * dt[todo],
                                          qa[todo], order=0)
                ok = cand <= f_tol[todo]
                idx = np.flatnonzero(todo)
                accepted[idx[ok]] = True
                f_new[idx[ok]] = cand[ok]
                alpha[idx[~ok]] *= 0.5
            alpha = np.where(accepted, alpha, 0.0)
            nu = np.mod(ua + alpha * du, per)
            nt = ta + alpha * dt
            u[ia], tau[ia], f[ia] = nu, nt, f_new
            # Newton converges quadratically: once a full step is below 1e-9 the error is ~1e-18
            small = (np.abs(alpha * du) <= step_tol * per) & (np.abs(alpha * dt) <= step_tol) & (alpha == 1)
            active[ia[small | ~accepted]] = False
        return u, tau, f

    # ------------------------------------------------------------------ global seeds
    def _scan_global(self, q0, n_tau_per_rad=30, max_seeds=4):
        """Robust global foot for planar points q0 (M, 2): dense tau scan + Newton (used for the table)."""
        prof = self.profile
        n_s = max(2048, int(prof.period / (0.004 * self.outer_radius)))
        us = prof.params(n_s)
        tree = exact_tree(prof.eval(us))
        d_plane, _ = tree.query(q0)
        # |tau| > d_plane / v0 cannot beat the tau = 0 slice
        node_tmax = d_plane / self.v0
        tmax = float(np.max(node_tmax)) + 1e-9
        n_tau = max(9, int(2 * tmax * n_tau_per_rad) | 1)
        taus = np.linspace(-tmax, tmax, n_tau)
        dtau = taus[1] - taus[0]
        M = len(q0)
        F = np.full((M, n_tau), np.inf)
        U = np.zeros((M, n_tau), int)
        for j, tj in enumerate(taus):
            live = np.flatnonzero(node_tmax + dtau >= abs(tj))  # other slices cannot hold the minimum
            if not len(live):
                continue
            q_rot = _rot(q0[live], np.cos(-self.hand * tj), np.sin(-self.hand * tj))
            dj, ij = tree.query(q_rot, workers=-1)
            F[live, j] = dj ** 2 + (self.v0 * tj) ** 2
            U[live, j] = ij
        # local minima of the slice-minimum function F(tau) are the candidate basins
        Fp = np.pad(F, ((0, 0), (1, 1)), constant_values=np.inf)
        is_min = (F <= Fp[:, :-2]) & (F <= Fp[:, 2:]) & np.isfinite(F)
        Fm = np.where(is_min, F, np.inf)
        order = np.argsort(Fm, axis=1)[:, :max_seeds]
        best_u = np.zeros(M)
        best_t = np.zeros(M)
        best_f = np.full(M, np.inf)
        rows = np.arange(M)
        for k in range(order.shape[1]):
            j = order[:, k]
            valid = np.isfinite(Fm[rows, j])
            if not valid.any():
                continue
            _keep_better((best_u, best_t, best_f), np.flatnonzero(valid),
                         self._newton(us[U[rows, j]][valid], taus[j][valid], q0[valid]))
        return best_u, best_t, best_f

    def _build_table(self, n=121):
        """Global feet on an n x n grid of planar nodes covering the rotor disk (plus margin)."""
        half = 1.5 * self.outer_radius
        xs = np.linspace(-half, half, n)
        X, Y = np.meshgrid(xs, xs, indexing="ij")
        nodes = np.stack([X.ravel(), Y.ravel()], -1)
        U, T, F = self._scan_global(nodes)
        U, T, F = U.reshape(n, n), T.reshape(n, n), F.reshape(n, n)
        # propagation: a neighbour's foot is a seed too (repairs nodes whose scan missed a basin)
        for _ in range(3):
            changed = 0
            for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (-1, -1), (1, -1), (-1, 1)):
                su = np.roll(np.roll(U, di, 0), dj, 1)
                st = np.roll(np.roll(T, di, 0), dj, 1)
                u1, t1, f1 = self._newton(su.ravel(), st.ravel(), nodes)
                f1 = f1.reshape(n, n)
                better = f1 < F * (1 - 1e-12) - 1e-300
                changed += int(better.sum())
                U = np.where(better, u1.reshape(n, n), U)
                T = np.where(better, t1.reshape(n, n), T)
                F = np.where(better, f1, F)
            if not changed:
                break
        self._table = (xs, U, T)

    def _seeds(self, q0):
        """Four seeds (N, 4) per planar query from the corners of its table cell."""
        if self._table is None:
            self._build_table()
        xs, U, T = self._table
        n = len(xs)
        h = xs[1] - xs[0]
        fi = (q0 - xs[0]) / h
        i = np.clip(np.floor(fi[:, 0]).astype(int), 0, n - 2)
        j = np.clip(np.floor(fi[:, 1]).astype(int), 0, n - 2)
        su = np.stack([U[i, j], U[i + 1, j], U[i, j + 1], U[i + 1, j + 1]], -1)
        st = np.stack([T[i, j], T[i + 1, j], T[i, j + 1], T[i + 1, j + 1]], -1)
        outside = (fi < 0).any(axis=1) | (fi > n - 1).any(axis=1)
        return su, st, outside

    def _slab(self):
        """KD-tree of surface samples with |tau| <= slab reach / v0 (built once)."""
        if self._slab_tree is None:
            h = 0.003 * self.outer_radius
            us = self.profile.params(max(2048, int(self.profile.period / h)))
            tmax = self._slab_reach / self.v0
            dt = h / np.sqrt(self.outer_radius ** 2 + self.v0 ** 2)
            ts = np.linspace(-tmax, tmax, max(3, int(2 * tmax / dt) + 1))
            U, T = np.meshgrid(us, ts, indexing="ij")
            pts = self.evaluate(U.ravel(), T.ravel())
            self._slab_tree = (exact_tree(pts), U.ravel(), T.ravel(), us[1] - us[0], ts[1] - ts[0])
        return self._slab_tree

    # ------------------------------------------------------------------ public queries
    def foot_points(self, points):
        """Exact global foot points of 3D points (N, 3) on the (infinite) helical surface."""
        q = np.atleast_2d(np.asarray(points, dtype=float))
        if not np.isfinite(q).all():
            raise ValueError("foot_points: query points contain NaN or inf")
        q0 = screw_to_plane(q, self.v0, self.hand)
        su, st, outside = self._seeds(q0)
        per = self.profile.period
        # corners in one basin give (almost) the same foot: one Newton run suffices there
        du = np.abs(su - su[:, :1])
        du = np.minimum(du, per - du)
        spread = (du.max(axis=1) > 0.02 * per) | (np.abs(st - st[:, :1]).max(axis=1) > 0.05)
        u, tau, f = self._newton(su[:, 0], st[:, 0], q0)
        multi = np.flatnonzero(spread)
        if len(multi):
            for k in range(1, 4):
                _keep_better((u, tau, f), multi, self._newton(su[multi, k], st[multi, k], q0[multi]))
        # near the surface, basins can be thinner than a table cell (thin lobe tips).  Feet of such
        # queries lie in a thin slab |tau| <= d / v0, so the nearest of a few dense samples of that
        # slab is a reliable extra seed (and a cheap KD-tree query, the samples being close)
        near = np.flatnonzero(f < self._slab_reach ** 2)
        if len(near):
            tree, su_s, st_s, h_u, h_t = self._slab()
            _, js = tree.query(np.c_[q0[near], np.zeros(len(near))], k=3)
            for j in js.T:
                # seeds inside the basin already found add nothing; Newton only on the others
                du = np.abs(su_s[j] - u[near])
                du = np.minimum(du, per - du)
                fresh = (du > 3 * h_u) | (np.abs(st_s[j] - tau[near]) > 3 * h_t)
                if not fresh.any():
                    continue
                sel = near[fresh]
                _keep_better((u, tau, f), sel, self._newton(su_s[j][fresh], st_s[j][fresh], q0[sel]))
        far = np.flatnonzero(outside)
        if len(far):  # beyond the table: fall back to the robust scan
            _keep_better((u, tau, f), far, self._scan_global(q0[far]))
        t = tau + q[:, 2] / self.v0
        foot, nrm = self.point_and_normal(u, t)
        dist = np.sqrt(np.maximum(f, 0.0))
        side = np.einsum("ij,ij->i", q - foot, nrm)
        sign = np.where(side < 0, -1.0, 1.0)
        return FootPoints(u=u, t=t, point=foot, distance=sign * dist, normal=nrm)

    def signed_distance(self, points):
        return self.foot_points(points).distance

    def contains(self, points, n_poly=4096):
        """Point-in-rotor-solid: screw back to z = 0, then a 2D point-in-polygon test."""
        if self._polygon is None or len(self._polygon) != n_poly:
            self._polygon = self.profile.polygon(n_poly)
        q0 = screw_to_plane(np.atleast_2d(np.asarray(points, float)), self.v0, self.hand)
        return points_in_polygon(q0, self._polygon)

    # ------------------------------------------------------------------ curvature
    def fundamental_forms(self, u):
        """Tangents x_u, x_t (..., 3), unit outward normal n and the coefficients (E, F, G) and
        (L, M, N) of the first and second fundamental forms at the profile points (u, t = 0).

        II is taken with the outward normal: it is negative in directions in which X bends away from
        the air side (convex), positive where it bends towards it (concave)."""
        u = np.asarray(u, float)
        h, v0 = self.hand, self.v0
        p, p1, p2 = (self.profile.eval(u, k) for k in range(3))
        z = np.zeros(u.shape + (1,))
        xu = np.concatenate([p1, z], -1)
        xt = np.concatenate([h * _J(p), np.full(u.shape + (1,), v0)], -1)
        xuu = np.concatenate([p2, z], -1)
        xut = np.concatenate([h * _J(p1), z], -1)
        xtt = np.concatenate([-p, z], -1)
        n = self._normal_at_t0(p, p1)
        dot = lambda a, b: np.einsum("...i,...i->...", a, b)  # noqa: E731
        first = (dot(xu, xu), dot(xu, xt), dot(xt, xt))
        second = (dot(xuu, n), dot(xut, n), dot(xtt, n))
        return xu, xt, n, first, second

    def curvatures(self, u):
        """Principal (k1 >= k2), Gaussian K and mean H curvature at profile parameters u.

        Screw-invariant, so they depend on u only.  Sign convention: outward
        normal; on a convex lobe tip both principal curvatures are negative.
        """
        _, _, _, (E, F, G), (L, M, N) = self.fundamental_forms(u)
        W = E * G - F * F
        K = (L * N - M * M) / W
        H = (E * N - 2 * F * M + G * L) / (2 * W)
        disc = np.sqrt(np.maximum(H * H - K, 0.0))
        return {"k1": H + disc, "k2": H - disc, "K": K, "H": H}

    def principal_directions(self, u):
        """Unit principal directions (e1, e2) (..., 3) of k1 >= k2 at (u, t = 0), e1 x e2 = n.

        e1 solves (II - k1 I) v = 0 in the (x_u, x_t) basis (the longer of the two row solutions);
        at umbilics, where every direction is principal, e1 is the profile tangent."""
        xu, xt, n, (E, F, G), (L, M, N) = self.fundamental_forms(u)
        k1 = self.curvatures(u)["k1"]
        va = np.stack([M - k1 * F, -(L - k1 * E)], -1)
        vb = np.stack([N - k1 * G, -(M - k1 * F)], -1)
        use_a = np.linalg.norm(va, axis=-1) >= np.linalg.norm(vb, axis=-1)
        v = np.where(use_a[..., None], va, vb)
        e1 = v[..., :1] * xu + v[..., 1:] * xt
        ln = np.linalg.norm(e1, axis=-1, keepdims=True)
        scale = np.abs(E) + np.abs(G) + np.abs(L) + np.abs(N)
        umb = ln[..., 0] <= 1e-12 * scale[...]
        e1 = np.where(umb[..., None], xu, e1)
        e1 = e1 / np.linalg.norm(e1, axis=-1, keepdims=True)
        return e1, np.cross(n, e1)

    def classify(self, u, rel_tol=1e-3):
        """+1 elliptic (K > 0), 0 parabolic, -1 hyperbolic (K < 0), Bizzarri, Bo & Bartoň Fig. 3.

        Parabolic means |K| R^2 < rel_tol: cylindrical pieces (arcs centred on
        the axis) have K = 0 exactly, and a profile fitted to mesh vertices
        carries curvature noise far above 1e-6 / R^2 there.
        """
        K = self.curvatures(u)["K"]
        tol = rel_tol / self.outer_radius ** 2
        return np.where(K > tol, 1, np.where(K < -tol, -1, 0))


# ------------------------------------------------------------------------------ shared surfaces
_SHARED = {}              # a few recent surfaces by content: their lazy tables are built once per rotor
_SHARED_KEPT = 4
_SHARED_LOCK = threading.Lock()


def shared_surface(profile, v0, handedness="right"):
    """The :class:`HelicalSurface` of (profile, v0, handedness), the same object for the same content (the
    profile's points, class, v0 and hand equal to the last bit; the last four kept).  A surface builds its
    foot-point seed table (~0.5 s) on first use and only reads it afterwards, so a second plan, report or
    verification of the same rotor in one process starts from the table the first one built."""
    pts = getattr(profile, "points", None)
    if pts is None:
        return HelicalSurface(profile, v0, handedness)
    pts = np.ascontiguousarray(pts, dtype=float)
    key = (type(profile).__name__, pts.shape, hashlib.sha256(pts.tobytes()).hexdigest(), float(v0),
           hand_name(hand_sign(handedness)))
    with _SHARED_LOCK:
        surface = _SHARED.pop(key, None)
        if surface is None:
            surface = HelicalSurface(profile, v0, handedness)
        _SHARED[key] = surface                       # most recent last
        while len(_SHARED) > _SHARED_KEPT:
            _SHARED.pop(next(iter(_SHARED)))
    return surface
