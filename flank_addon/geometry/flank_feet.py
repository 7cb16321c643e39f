"""Exact foot points on one flank of a helical surface, restricted to the flank's profile range.

A flank is the part {S_t(p(u), 0): u_start <= u <= u_end, t real} of a helical surface (the profile arc
between two corners, screwed about the axis).  The planners measure distances to single flanks: the
double-flank tool axis (Bizzarri & Bartoň 2021, Eq. (2) and end of Section 4.2) and the conical poses of
single-flank milling.  The reduction of :mod:`.helical_surface` makes every query planar.
"""
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .helical_surface import exact_tree, shifted_newton_step
from .screw import screw_to_plane

# the guard's approximate query (:meth:`FlankFeet._guard_seeds`): its answers depend on this and on the tree
GUARD_EPS = 2.0
# samples per leaf of the cold seeds' exact trees (:meth:`FlankFeet._exact_seeds`): any size gives the same answers
SEED_TREE_LEAFSIZE = 64

@dataclass
class Feet:
    """Foot points of N query points on one flank (restricted to its parameter range)."""
    u: np.ndarray          # (N,) profile parameter in [u_start, u_end]
    t: np.ndarray          # (N,) screw parameter: foot = S_t(p(u), 0)
    point: np.ndarray      # (N, 3)
    distance: np.ndarray   # (N,) unsigned distance
    direction: np.ndarray  # (N, 3) unit (query - foot) / distance = gradient of the distance
    interior: np.ndarray   # (N,) bool: foot strictly inside the parameter range
    tau: np.ndarray        # (N,) reduced screw parameter (query screwed into z = 0)


class FlankFeet:
    """Exact foot points on one flank {S_t(p(u), 0): u_start <= u <= u_end, t real} of a helical surface.

    The reduction of :mod:`helical_surface` makes every query planar (q0 = the query screwed into
    z = 0); the minimum of f(u, tau) over the strip u in [u_start, u_end] is found by projected
    Newton: a full (Hessian-shifted) Newton step where the foot is interior, a step in tau alone
    where u sits on a bound and the gradient pushes outwards, backtracking so f never increases.
    Seeds: the k nearest samples of a dense (u, tau) table of the flank around z = 0 plus any warm
    start the caller passes (e.g. the previous optimisation step); the best result is kept.
    """

    def __init__(self, surface, u_start, u_end, n_u=None, reach=None):
        if not u_start < u_end <= u_start + surface.profile.period + 1e-12:
            raise ValueError(f"flank range must satisfy u_start < u_end <= u_start + period, "
                             f"got ({u_start}, {u_end})")
        self.surface = surface
        self.lo, self.hi = float(u_start), float(u_end)
        R = surface.outer_radius
        self.eps_u = 1e-7 * (self.hi - self.lo)
        reach = 1.5 * R if reach is None else float(reach)
        n_u = n_u or 160
        us = np.linspace(self.lo, self.hi, n_u)
        # |tau| <= d / v0 for a foot at distance d; queries of interest are within ``reach``
        tmax = reach / surface.v0
        dt = 0.01 * R / max(R, surface.v0)
        n_t = int(min(max(9, 2 * tmax / dt + 1), 241))
        ts = np.linspace(-tmax, tmax, n_t)
        U, T = np.meshgrid(us, ts, indexing="ij")
        self._points = surface.evaluate(U.ravel(), T.ravel())
        self._U, self._T = U.ravel(), T.ravel()
        # the two kd-trees of the table, each made when first asked (a flank whose feet only ever start cold,
        # such as the untrimmed flanks of a double-flank tool, never needs the guard's)
        self._guard_tree = None             # the warm starts' guard: its approximate answers depend on the tree
        self._exact_tree = None             # the cold seeds' exact queries (:func:`exact_tree`)
        self._last_guard = {}               # row count -> (points, answers) of the latest guard query

    def _exact_seeds(self, Q, k):
        """Indices (len(Q), k) of the k nearest table samples of the planar points Q (exact).  Leaves of 64
        samples: on the planners' cold-seed queries (most rows off the flank, often far) the tree builds about 17%
        faster than with scipy's 16 and answers 22-26% faster, the same samples (bench/bench_seed_trees.py)."""
        if self._exact_tree is None:
            self._exact_tree = exact_tree(self._points, leafsize=SEED_TREE_LEAFSIZE)
        _, idx = self._exact_tree.query(Q, k=k, workers=_workers(len(Q)))
        return idx.reshape(len(Q), -1)

    def _guard_seeds(self, Q):
        """Index of a rough nearest table sample of each planar point Q (approximate, ``eps`` = 2: on a plan's
        guard queries 8x cheaper than the exact query of the same tree, 1.2x cheaper than the midpoint tree's).
        Its answers depend on the tree and the point only, so a query that repeats the latest one with as many
        rows, bit for bit (an optimiser asking again at a point it has tried), takes that one's answers."""
        last = self._last_guard.get(len(Q))
        if last is not None and np.array_equal(last[0], Q):
            return last[1]
        if self._guard_tree is None:
            self._guard_tree = cKDTree(self._points)
        _, idx = self._guard_tree.query(Q, k=1, eps=GUARD_EPS, workers=_workers(len(Q)))
        self._last_guard[len(Q)] = (Q.copy(), idx)      # one tuple: a reader in another thread sees both or neither
        return idx

    @classmethod
    def of(cls, surface, u_start, u_end, n_u=None, reach=None):
        """``FlankFeet(surface, u_start, u_end, n_u, reach)``, made once per surface: the seed table (0.13 s
        on a built-in rotor) is kept on the surface with the other lazy tables, so the next plan of the
        same flank reuses it (its table never changes after it is made; its trees and the guard's latest answers
        are caches of it)."""
        key = (float(u_start), float(u_end), n_u, None if reach is None else float(reach))
        made = surface.__dict__.setdefault("_flank_feet", {})
        feet = made.get(key)
        if feet is None:
            feet = made[key] = cls(surface, u_start, u_end, n_u=n_u, reach=reach)
        return feet

    def _newton(self, u, tau, q0, iters=40):
        return _newton_rows(self.surface, u, tau, q0, self.lo, self.hi, self.hi - self.lo, iters)

    def __call__(self, points, warm=None, k=2):
        """Feet of 3D points (N, 3); ``warm`` = (u, tau) of a previous solve (same queries) as an extra seed."""
        return FlankFeet.many([self], points, [warm], k)[0]

    @staticmethod
    def many(solvers, points, warms, k=2):
        """``[solver(p, warm) for solver, p, warm in zip(solvers, points, warms)]`` for solvers on one surface
        (``points``: one (N, 3) array for all, or a list with one per solver), their Newton runs done together
        (every row's iterations are its own, so the feet are the same)."""
        m = len(solvers)
        if isinstance(points, (list, tuple)):
            pts = [np.atleast_2d(np.asarray(p, float)) for p in points]
        else:
            pts = [np.atleast_2d(np.asarray(points, float))] * m
        s = solvers[0].surface
        if any(fs.surface is not s for fs in solvers):
            return [FlankFeet.many([fs], [p], [w], k)[0] for fs, p, w in zip(solvers, pts, warms)]
        sizes = np.array([len(p) for p in pts])
        off = np.concatenate([[0], np.cumsum(sizes)])
        q = np.concatenate(pts)
        q0 = screw_to_plane(q, s.v0, s.hand)
        Q = np.zeros((len(q0), 3))          # the planar points in z = 0, for the seed tables
        Q[:, :2] = q0
        lo = np.repeat([fs.lo for fs in solvers], sizes)
        hi = np.repeat([fs.hi for fs in solvers], sizes)
        span = np.repeat([fs.hi - fs.lo for fs in solvers], sizes)
        u, tau, f = np.empty(len(q)), np.empty(len(q)), np.empty(len(q))
        warm_j = [j for j, w in enumerate(warms) if w is not None]
        cold_j = [j for j, w in enumerate(warms) if w is None]
        if warm_j:
            # the warm start carries the basin.  Guard against a jump to another basin: a rough table
            # seed (approximate nearest neighbour, :meth:`_guard_seeds`) that is already
            # nearer than the warm foot starts a second Newton run for that query only
            rows = np.concatenate([np.arange(off[j], off[j + 1]) for j in warm_j])
            wu = np.concatenate([np.asarray(warms[j][0], float) for j in warm_j])
            wt = np.concatenate([np.asarray(warms[j][1], float) for j in warm_j])
            u[rows], tau[rows], f[rows] = _newton_rows(s, wu, wt, q0[rows], lo[rows], hi[rows], span[rows])
            su, st = np.empty(len(q)), np.empty(len(q))
            for j in warm_j:
                r = slice(off[j], off[j + 1])
                idx = solvers[j]._guard_seeds(Q[r])
                su[r], st[r] = solvers[j]._U[idx], solvers[j]._T[idx]
            su, st = su[rows], st[rows]
            fs_ = s._f_and_derivs(su, st, q0[rows], order=0)
            jump = np.flatnonzero(fs_ < f[rows])
            if len(jump):
                r = rows[jump]
                ju, jt, jf = _newton_rows(s, su[jump], st[jump], q0[r], lo[r], hi[r], span[r])
                better = jf < f[r]
                b = r[better]
                u[b], tau[b], f[b] = ju[better], jt[better], jf[better]
        if cold_j:
            # every query's k nearest table samples as seeds, all in one Newton run, then the best per query
            seeds, kks = [], []
            for j in cold_j:
                fs = solvers[j]
                idx = fs._exact_seeds(Q[off[j]:off[j + 1]], k)
                kks.append(idx.shape[1])
                rows_j = np.tile(np.arange(off[j], off[j + 1]), idx.shape[1])      # seed-major, as idx.T
                seeds.append((rows_j, fs._U[idx.T.ravel()], fs._T[idx.T.ravel()]))
            rr = np.concatenate([x[0] for x in seeds])
            U, T, F = _newton_rows(s, np.concatenate([x[1] for x in seeds]), np.concatenate([x[2] for x in seeds]),
                                   q0[rr], lo[rr], hi[rr], span[rr])
            o = 0
            for j, kk in zip(cold_j, kks):
                n = sizes[j]
                Fj = F[o:o + kk * n].reshape(kk, -1)
                jm = np.argmin(Fj, axis=0)
                sel = o + jm * n + np.arange(n)
                u[off[j]:off[j + 1]], tau[off[j]:off[j + 1]], f[off[j]:off[j + 1]] = U[sel], T[sel], F[sel]
                o += kk * n
        t = tau + q[:, 2] / s.v0
        foot, normal = s.point_and_normal(u, t)
        diff = q - foot
        d = np.linalg.norm(diff, axis=1)
        direction = diff / np.maximum(d, 1e-300)[:, None]
        # a query inside the rotor solid has no business in a tool axis: it never counts as interior
        outside = np.einsum("ij,ij->i", diff, normal) > 0
        eps = np.repeat([fs.eps_u for fs in solvers], sizes)
        interior = (u > lo + eps) & (u < hi - eps) & outside
        out = []
        for j in range(m):
            r = slice(off[j], off[j + 1])
            out.append(Feet(u=u[r], t=t[r], point=foot[r], distance=d[r], direction=direction[r],
                            interior=interior[r], tau=tau[r]))
        return out


def _workers(n):
    """Threads of a kd-tree query of n points (every query is independent: the same answer on any count)."""
    return -1 if n >= 2048 else 1


def _newton_rows(s, u, tau, q0, lo, hi, span, iters=40):
    """Projected Newton of :class:`FlankFeet` on surface s for rows with bounds lo <= u <= hi (scalars or per
    row, span = hi - lo): a full (Hessian-shifted) Newton step where the foot is interior, a step in tau alone
    where u sits on a bound and the gradient pushes outwards, backtracking so f never increases.  Every row
    iterates on its own."""
    u = np.clip(np.array(u, float), lo, hi)
    tau = np.array(tau, float)
    n = len(u)
    lo = np.broadcast_to(np.asarray(lo, float), (n,))
    hi = np.broadcast_to(np.asarray(hi, float), (n,))
    span = np.broadcast_to(np.asarray(span, float), (n,))
    # the first iteration sets every row's f from its full evaluation: a value at the start would never be read
    f = np.empty(n) if iters > 0 else s._f_and_derivs(u, tau, q0, order=0)
    # the line search accepts within roundoff of f (converged rows would backtrack forever otherwise)
    f_slack = 1e-14 * (np.einsum("ij,ij->i", q0, q0) + s.outer_radius ** 2)
    active = np.ones(n, bool)
    for _ in range(iters):
        ia = np.flatnonzero(active)
        if not len(ia):
            break
        ua, ta = u[ia], tau[ia]
        if len(ia) == n:            # every row: the read-only inputs need no copies
            qa, la, ha, sa, fs = q0, lo, hi, span, f_slack
        else:
            qa, la, ha, sa, fs = q0[ia], lo[ia], hi[ia], span[ia], f_slack[ia]
        fa, gu, gt, huu, hut, htt = s._f_and_derivs(ua, ta, qa)
        du, dt, scale = shifted_newton_step(gu, gt, huu, hut, htt)
        # on a bound with the gradient pointing out of the box: move in tau only
        pinned = ((ua <= la) & (gu > 0)) | ((ua >= ha) & (gu < 0))
        t_only = -gt / np.maximum(htt, 1e-8 * scale)
        du = np.where(pinned, 0.0, du)
        dt = np.where(pinned, t_only, dt)
        norm = np.maximum(np.abs(du) / (0.25 * sa), np.abs(dt) / (np.pi / 2))
        k = 1.0 / np.maximum(norm, 1.0)
        du, dt = du * k, dt * k
        f_tol = fa + fs
        # the full step first, for every row at once (most rows take it)
        cu = np.clip(ua + du, la, ha)
        ct = ta + dt
        cf = s._f_and_derivs(cu, ct, qa, order=0)
        accepted = cf <= f_tol
        f_new = np.where(accepted, cf, fa)
        nu, nt = np.where(accepted, cu, ua), np.where(accepted, ct, ta)
        alpha = np.where(accepted, 1.0, 0.5)
        for _ls in range(13):
            todo = np.flatnonzero(~accepted)
            if not len(todo):
                break
            cu = np.clip(ua[todo] + alpha[todo] * du[todo], la[todo], ha[todo])
            ct = ta[todo] + alpha[todo] * dt[todo]
            cf = s._f_and_derivs(cu, ct, qa[todo], order=0)
            ok = cf <= f_tol[todo]
            good = todo[ok]
            accepted[good] = True
            f_new[good], nu[good], nt[good] = cf[ok], cu[ok], ct[ok]
            alpha[todo[~ok]] *= 0.5
        step_u, step_t = np.abs(nu - ua), np.abs(nt - ta)
        u[ia], tau[ia], f[ia] = nu, nt, np.minimum(f_new, fa)
        small = (step_u <= 1e-11 * sa) & (step_t <= 1e-11)
        active[ia[small | ~accepted]] = False
    return u, tau, f


def flank_u_ranges(profile, flanks):
    """Flank parameter ranges (u_start, u_end): pass through (u, u) pairs of floats, or convert
    inclusive index ranges [i, j] into a SplineProfile's knots (j may exceed the point count: wrap)."""
    out = []
    for a, b in flanks:
        if isinstance(a, (int, np.integer)) and isinstance(b, (int, np.integer)) and hasattr(profile, "knots"):
            n = len(profile.knots) - 1
            ua = profile.knots[a % n] + profile.period * (a // n)
            ub = profile.knots[b % n] + profile.period * (b // n)
            out.append((float(ua), float(ub)))
        else:
            out.append((float(a), float(b)))
    return out
