"""Closed planar (transverse) profiles of helical surfaces.

A profile is a closed curve in the plane z = 0, counter-clockwise, with the
rotor solid on its left.  It is parametrised by ``u`` in [0, period) (close
to arc length) and evaluated with derivatives so that foot-point Newton
iterations and curvature formulas get exact p, p', p''.

Two kinds: :class:`SplineProfile` (closed periodic cubic spline through
points, Hu, Zhou & Li 2025 style point data) and :class:`SegmentProfile` (exact lines and
circular arcs, e.g. the Nilson profile of Bizzarri & Bartoň 2021 Ex. 3.3).
"""
import csv
import hashlib
import math
import sys
import threading

import numpy as np

from .runs import ranks_in_runs


class ProfileError(ValueError):
    """Invalid profile input; the message names the offending value."""


class Profile:
    period = 1.0

    def eval(self, u, der=0):  # pragma: no cover - interface
        raise NotImplementedError

    def wrap(self, u):
        return np.mod(u, self.period)

    def sample(self, n):
        """(n, 2) points at n equally spaced parameters."""
        u = np.arange(n) * (self.period / n)
        return self.eval(u)

    def params(self, n):
        return np.arange(n) * (self.period / n)

    def eval_all(self, u):
        """(p, p', p'') at parameters u in one call."""
        return self.eval(u), self.eval(u, 1), self.eval(u, 2)

    def outer_radius(self, n=4096):
        return float(np.max(np.linalg.norm(self.sample(n), axis=1)))

    def outward_normal(self, u):
        d = self.eval(u, 1)
        n = np.stack([d[..., 1], -d[..., 0]], axis=-1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)

    def curvature(self, u):
        """Signed curvature (positive where the CCW profile turns left = convex)."""
        d1, d2 = self.eval(u, 1), self.eval(u, 2)
        cr = d1[..., 0] * d2[..., 1] - d1[..., 1] * d2[..., 0]
        return cr / np.linalg.norm(d1, axis=-1) ** 3

    def polygon(self, n=2048):
        return self.sample(n)


class _NeedsPivoting(Exception):
    pass


def _tridiagonal(dl, d, du, b):
    """x with A x = b for the tridiagonal A (sub-diagonal dl, diagonal d, super-diagonal du), b (m, k): the
    elimination with partial pivoting and the back substitution of LAPACK's dgtsv, step by step (rows i and
    i + 1 change places where |d_i| < |dl_i|, which fills in a second super-diagonal), so that the result is
    the one scipy's solve_banded gets from LAPACK; :class:`_NeedsPivoting` for a zero pivot (a singular
    system, which scipy reports in its own words)."""
    d, dl, du = [float(v) for v in d], [float(v) for v in dl], [float(v) for v in du]
    cols = [[float(v) for v in b[:, j]] for j in range(b.shape[1])]
    m = len(d)
    for i in range(m - 1):
        if abs(d[i]) >= abs(dl[i]):
            if d[i] == 0.0:
                raise _NeedsPivoting
            fact = dl[i] / d[i]
            d[i + 1] = d[i + 1] - fact * du[i]
            for c in cols:
                c[i + 1] = c[i + 1] - fact * c[i]
            dl[i] = 0.0
        elif dl[i] == dl[i]:                       # row interchange (dl[i] is not NaN)
            fact = d[i] / dl[i]
            d[i] = dl[i]
            temp = d[i + 1]
            d[i + 1] = du[i] - fact * temp
            if i < m - 2:
                dl[i] = du[i + 1]
                du[i + 1] = -fact * dl[i]
            du[i] = temp
            for c in cols:
                temp = c[i]
                c[i] = c[i + 1]
                c[i + 1] = temp - fact * c[i + 1]
        else:
            raise _NeedsPivoting
    if d[m - 1] == 0.0:
        raise _NeedsPivoting
    for c in cols:
        c[m - 1] = c[m - 1] / d[m - 1]
        if m > 1:
            c[m - 2] = (c[m - 2] - du[m - 2] * c[m - 1]) / d[m - 2]
        for i in range(m - 3, -1, -1):
            c[i] = (c[i] - du[i] * c[i + 1] - dl[i] * c[i + 2]) / d[i]
    return np.array(cols).T


def _periodic_coefficients(x, y):
    """Coefficients (4, n - 1, k) of scipy's CubicSpline(x, y, bc_type='periodic') (y[0] == y[-1], n >= 5),
    computed with its own steps: slopes, the condensed periodic system solved twice, its last unknown, the
    Hermite coefficients.  The same numbers without importing scipy.interpolate (about 0.3 s)."""
    n = len(x)
    dx = np.diff(x)
    dxr = dx.reshape([dx.shape[0]] + [1] * (y.ndim - 1))
    slope = np.diff(y, axis=0) / dxr
    A = np.zeros((3, n))
    b = np.empty((n,) + y.shape[1:], dtype=y.dtype)
    A[1, 1:-1] = 2 * (dx[:-1] + dx[1:])
    A[0, 2:] = dx[:-1]
    A[-1, :-2] = dx[1:]
    b[1:-1] = 3 * (dxr[1:] * slope[:-1] + dxr[:-1] * slope[1:])
    A = A[:, 0:-1]
    A[1, 0] = 2 * (dx[-1] + dx[0])
    A[0, 1] = dx[-1]
    b = b[:-1]
    a_m1_0, a_m1_m2, a_m1_m1, a_m2_m1, a_0_m1 = dx[-2], dx[-1], 2 * (dx[-1] + dx[-2]), dx[-3], dx[0]
    b[0] = 3 * (dxr[0] * slope[-1] + dxr[-1] * slope[0])
    b[-1] = 3 * (dxr[-1] * slope[-2] + dxr[-2] * slope[-1])
    Ac = A[:, :-1]
    b1 = b[:-1]
    b2 = np.zeros_like(b1)
    b2[0] = -a_0_m1
    b2[-1] = -a_m2_m1
    m = b1.shape[0]
    # both right-hand sides in one elimination (each column's arithmetic is its own)
    k = b1.reshape(m, -1).shape[1]
    both = _tridiagonal(Ac[2, :-1], Ac[1, :], Ac[0, 1:], np.concatenate([b1.reshape(m, -1), b2.reshape(m, -1)], axis=1))
    s1, s2 = both[:, :k].reshape(b1.shape), both[:, k:].reshape(b2.shape)
    s_m1 = ((b[-1] - a_m1_0 * s1[0] - a_m1_m2 * s1[-1]) / (a_m1_m1 + a_m1_0 * s2[0] + a_m1_m2 * s2[-1]))
    s = np.empty((n,) + y.shape[1:], dtype=y.dtype)
    s[:-2] = s1 + s_m1 * s2
    s[-2] = s_m1
    s[-1] = s[0]
    t = (s[:-1] + s[1:] - 2 * slope) / dxr
    return np.stack((t / dxr, (slope - s[:-1]) / dxr - t, s[:-1], y[:-1]))


class PeriodicCubic:
    """The coefficients ``c`` (4, n - 1, 2) of the periodic cubic spline through closed points (n, 2) at knots
    (n,), as scipy's CubicSpline(knots, closed, bc_type='periodic') has them: by scipy where scipy.interpolate
    is already imported (its LAPACK elimination: 1.3 against 10 ms for 4,097 knots, 3.4 against 58 ms for
    20,000), where the system is singular, the input not finite or shorter than 5 points (scipy's own errors);
    otherwise by the same steps here, without the import (about 0.25 s)."""

    def __init__(self, knots, closed):
        knots, closed = np.asarray(knots, float), np.asarray(closed, float)
        # a plan's profile is splined again by every step that reads the plan (its simulated errors, verify):
        # the coefficients of the last few inputs are kept, by their exact numbers
        key = hashlib.sha1(repr((knots.shape, closed.shape)).encode() + knots.tobytes() + closed.tobytes()).digest()
        with _COEFFICIENTS_LOCK:
            c = _COEFFICIENTS.get(key)
        if c is None:
            # ours only where scipy would accept the input: finite, increasing knots, closed finite points (else
            # scipy's own error), and only where every coefficient came out finite (overflowing slopes: scipy's)
            ours = ("scipy.interpolate" not in sys.modules and len(knots) >= 5 and np.all(np.isfinite(knots))
                    and np.all(np.isfinite(closed)) and np.all(np.diff(knots) > 0)
                    and np.array_equal(closed[0], closed[-1]))
            if ours:
                try:
                    with np.errstate(all="ignore"):
                        c = _periodic_coefficients(knots, closed)
                    if not np.all(np.isfinite(c)):
                        c = None
                except _NeedsPivoting:
                    pass
            if c is None:
                from scipy.interpolate import CubicSpline

                c = np.asarray(CubicSpline(knots, closed, bc_type="periodic").c)
            c.setflags(write=False)
        with _COEFFICIENTS_LOCK:          # a planner's worker thread and Blender's own may spline at once
            _COEFFICIENTS.pop(key, None)
            _COEFFICIENTS[key] = c
            while len(_COEFFICIENTS) > 8:
                _COEFFICIENTS.pop(next(iter(_COEFFICIENTS)))
        self.c = c


_COEFFICIENTS = {}      # digest of (knots, points) -> read-only coefficients, the most recent last
_COEFFICIENTS_LOCK = threading.Lock()


class SplineProfile(Profile):
    """Closed periodic cubic spline through points (N, 2), chord-length parameter."""

    def __init__(self, points, validate=True):
        pts = np.asarray(points, dtype=float)
        if validate:
            pts = validate_profile_points(pts)
        self.points = pts
        closed = np.vstack([pts, pts[:1]])
        seg = np.linalg.norm(np.diff(closed, axis=0), axis=1)
        self.knots = np.concatenate([[0.0], np.cumsum(seg)])
        # the inner knots: searchsorted(inner, u, "right") is clip(searchsorted(knots, u, "right") - 1, 0, n - 2)
        # for every u (the first knot is never above a u of the period, the last one never below it, and the
        # ends clip to the end intervals) in one numpy call instead of three
        self._inner_knots = np.ascontiguousarray(self.knots[1:-1])
        self.period = float(self.knots[-1])
        self._spline = PeriodicCubic(self.knots, closed)
        c = self._spline.c
        # the derivatives' coefficients as scipy's PPoly.derivative makes them (falling factorials)
        self._d = [c, c[:-1] * np.array([3.0, 2.0, 1.0])[:, None, None], c[:-2] * np.array([6.0, 2.0])[:, None, None]]
        # per interval, for x then y: c0, c1, c2, c3 and the derivatives' 3 c0, 2 c1, 6 c0 in one row, so that
        # eval_xy / eval_all_xy gather their coefficients in one indexing (the foot-point Newton calls them on a
        # few points at a time, where every numpy call counts); the products are the ones they would form
        self._all_xy = np.ascontiguousarray(np.concatenate(
            [np.stack([c[0][:, j], c[1][:, j], c[2][:, j], c[3][:, j], 3 * c[0][:, j], 2 * c[1][:, j], 6 * c[0][:, j]],
                      axis=1) for j in (0, 1)], axis=1))
        # per interval: the point's c0..c3 and the tangent's 3 c0, 2 c1 (as ``_d`` has them), (n - 1, 6, 2), for
        # :meth:`eval_and_tangent`
        self._point_tangent = np.ascontiguousarray(np.stack([c[0], c[1], c[2], c[3], self._d[1][0], self._d[1][1]],
                                                            axis=1))

    def eval(self, u, der=0):
        """Points (der 0) or derivatives (der 1, 2) at parameters u (...): (..., 2); the polynomial of u's
        interval summed by powers of the offset, as scipy's PPoly evaluates it (the same numbers)."""
        i, s = self._interval(u)
        c = self._d[der]
        s = s[..., None]
        if der == 0:
            s2 = s * s
            return c[3][i] + c[2][i] * s + c[1][i] * s2 + c[0][i] * (s2 * s)
        if der == 1:
            return c[2][i] + c[1][i] * s + c[0][i] * (s * s)
        return c[1][i] + c[0][i] * s

    def eval_and_tangent(self, u):
        """(:meth:`eval` (u), :meth:`eval` (u, 1)): the same numbers, from one interval search and one gather of the
        coefficients (a foot point's position and normal need both, on a few hundred points per call)."""
        i, s = self._interval(u)
        g = self._point_tangent.take(i, axis=0)
        s = s[..., None]
        s2 = s * s
        p = g[..., 3, :] + g[..., 2, :] * s + g[..., 1, :] * s2 + g[..., 0, :] * (s2 * s)
        return p, g[..., 2, :] + g[..., 5, :] * s + g[..., 4, :] * s2

    def eval_all(self, u):
        # one interval search for value and both derivatives (hot path of foot-point Newton)
        u = np.mod(np.asarray(u, dtype=float), self.period)
        i = np.searchsorted(self._inner_knots, u, side="right")
        x = (u - self.knots[i])[..., None]
        c0, c1, c2, c3 = (self._spline.c[k][i] for k in range(4))
        p = ((c0 * x + c1) * x + c2) * x + c3
        p1 = (3 * c0 * x + 2 * c1) * x + c2
        p2 = 6 * c0 * x + 2 * c1
        return p, p1, p2

    def _interval(self, u, wrap_end=True):
        """(interval, offset) of parameters u.  With ``wrap_end`` a parameter the modulo rounds up to the
        period itself counts as 0 (scipy's periodic PPoly takes it modulo the period once more)."""
        u = np.mod(np.asarray(u, dtype=float), self.period)
        if wrap_end:
            u = np.mod(u, self.period)
        i = np.searchsorted(self._inner_knots, u, side="right")
        return i, u - self.knots[i]

    def eval_xy(self, u):
        """(x, y) of :meth:`eval` (the same numbers: the piecewise polynomial summed by powers, as scipy's
        PPoly does), without the (..., 2) array."""
        i, s = self._interval(u)
        s2 = s * s
        s3 = s2 * s
        g = self._all_xy.take(i, axis=0)   # c0..c3 of x in columns 0..3, of y in 7..10 (see __init__); take
        # gathers rows 3-4x faster than fancy indexing does in numpy 1.26
        x = g[..., 3] + g[..., 2] * s + g[..., 1] * s2 + g[..., 0] * s3
        y = g[..., 10] + g[..., 9] * s + g[..., 8] * s2 + g[..., 7] * s3
        return x, y

    def eval_all_xy(self, u):
        """The components of :meth:`eval_all` (the same numbers): (x, y, x', y', x'', y'')."""
        i, s = self._interval(u, wrap_end=False)
        return self._components_xy(self._all_xy.take(i, axis=0), s)

    @staticmethod
    def _components_xy(g, s):
        """(x, y, x', y', x'', y'') from the coefficient rows g of the parameters' intervals and the offsets s."""
        out = []
        for k in (0, 7):
            c0, c1, c2, c3, c0_3, c1_2, c0_6 = (g[..., k + j] for j in range(7))
            out.append((((c0 * s + c1) * s + c2) * s + c3, (c0_3 * s + c1_2) * s + c2, c0_6 * s + c1_2))
        (x, dx, ddx), (y, dy, ddy) = out
        return x, y, dx, dy, ddx, ddy

    def node_param(self, i):
        return self.knots[np.asarray(i)]


class Line:
    def __init__(self, p0, p1):
        self.p0 = np.asarray(p0, float)
        self.p1 = np.asarray(p1, float)
        self.length = float(np.linalg.norm(self.p1 - self.p0))
        if self.length <= 0:
            raise ProfileError("line segment of zero length")
        self.dir = (self.p1 - self.p0) / self.length

    def eval(self, s, der):
        s = s[..., None]
        if der == 0:
            return self.p0 + s * self.dir
        if der == 1:
            return np.broadcast_to(self.dir, s.shape[:-1] + (2,)).copy()
        return np.zeros(s.shape[:-1] + (2,))

    def end(self):
        return self.p1


class Arc:
    """Circular arc from angle a0 sweeping by ``sweep`` (signed, radians)."""

    def __init__(self, center, radius, a0, sweep):
        if radius <= 0:
            raise ProfileError(f"arc radius must be > 0, got {radius}")
        self.c = np.asarray(center, float)
        self.r = float(radius)
        self.a0 = float(a0)
        self.sweep = float(sweep)
        self.sgn = 1.0 if sweep > 0 else -1.0
        self.length = abs(self.sweep) * self.r

    def eval(self, s, der):
        a = self.a0 + self.sgn * s / self.r
        ca, sa = np.cos(a), np.sin(a)
        if der == 0:
            return self.c + self.r * np.stack([ca, sa], -1)
        if der == 1:
            return self.sgn * np.stack([-sa, ca], -1)
        return -np.stack([ca, sa], -1) / self.r

    def start(self):
        return self.c + self.r * np.array([math.cos(self.a0), math.sin(self.a0)])

    def end(self):
        a = self.a0 + self.sweep
        return self.c + self.r * np.array([math.cos(a), math.sin(a)])


class SegmentProfile(Profile):
    """Exact profile made of :class:`Line` and :class:`Arc` pieces, arc-length parametrised."""

    def __init__(self, segments, close_tol=1e-9):
        self.segments = list(segments)
        lengths = np.array([s.length for s in self.segments])
        self.breaks = np.concatenate([[0.0], np.cumsum(lengths)])
        self.period = float(self.breaks[-1])
        for a, b in zip(self.segments, self.segments[1:] + self.segments[:1]):
            start = b.start() if isinstance(b, Arc) else b.p0
            gap = float(np.linalg.norm(a.end() - start))
            if gap > close_tol * max(1.0, self.period):
                raise ProfileError(f"segments do not join: gap {gap:.3g} > {close_tol:g}")

    def eval(self, u, der=0):
        u = np.mod(np.asarray(u, dtype=float), self.period)
        idx = np.clip(np.searchsorted(self.breaks, u, side="right") - 1, 0, len(self.segments) - 1)
        out = np.empty(u.shape + (2,))
        for k, seg in enumerate(self.segments):
            m = idx == k
            if np.any(m):
                out[m] = seg.eval(u[m] - self.breaks[k], der)
        return out


# --------------------------------------------------------------------------- validation

def signed_area(poly):
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def segments_intersect_count(poly):
    """Number of pairs of non-adjacent polygon edges that properly cross.

    Only edges whose midpoints are closer than the longest edge can cross,
    so candidate pairs come from a sweep over the midpoints' x (then their distance) instead of all N^2
    pairs.
    """
    a = np.asarray(poly, float)
    b = np.roll(a, -1, axis=0)
    n = len(a)
    seg = b - a
    reach = float(np.linalg.norm(seg, axis=1).max()) * (1 + 1e-9)
    mid = 0.5 * (a + b)
    order = np.argsort(mid[:, 0], kind="stable")
    xs = mid[order, 0]
    last = np.searchsorted(xs, xs + reach, side="right")
    count = last - np.arange(n) - 1
    if count.sum() == 0:
        return 0
    p = np.repeat(np.arange(n), count)
    q = p + 1 + ranks_in_runs(count)
    I, J = order[p], order[q]
    d = mid[I] - mid[J]
    near = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] <= reach * reach
    i, j = np.minimum(I, J)[near], np.maximum(I, J)[near]
    if len(i) == 0:
        return 0
    gap = np.abs(i - j)
    keep = (gap > 1) & (gap != n - 1)
    i, j = i[keep], j[keep]
    r, sv = seg[i], seg[j]
    qp = a[j] - a[i]
    rxs = r[:, 0] * sv[:, 1] - r[:, 1] * sv[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (qp[:, 0] * sv[:, 1] - qp[:, 1] * sv[:, 0]) / rxs
        w = (qp[:, 0] * r[:, 1] - qp[:, 1] * r[:, 0]) / rxs
    return int(np.count_nonzero((t > 0) & (t < 1) & (w > 0) & (w < 1)))


def validate_profile_points(points, name="profile"):
    """Check a closed point list; return it as CCW (N, 2) float array.

    Raises :class:`ProfileError` naming the problem: NaN/inf, too few
    points, duplicates, an open curve, self-intersection.
    """
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise ProfileError(f"{name}: expected N x 2 coordinates, got shape {pts.shape}")
    bad = ~np.isfinite(pts).all(axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ProfileError(f"{name}: row {i + 1} is not a finite number pair: {pts[i].tolist()}")
    if len(pts) < 8:
        raise ProfileError(f"{name}: {len(pts)} points, at least 8 are needed")
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    scale = float(np.ptp(pts, axis=0).max())
    if scale <= 0:
        raise ProfileError(f"{name}: all points coincide")
    dup = np.flatnonzero(seg <= 1e-12 * scale)
    if len(dup):
        raise ProfileError(f"{name}: rows {dup[0] + 1} and {dup[0] + 2} are duplicate points {pts[dup[0]].tolist()}")
    closing = float(np.linalg.norm(pts[-1] - pts[0]))
    if closing <= 1e-12 * scale:  # explicitly closed list: drop the repeated point
        pts = pts[:-1]
        seg = seg[:-1]
        closing = float(np.linalg.norm(pts[-1] - pts[0]))
    typical = float(np.median(seg))
    if closing > 20.0 * max(typical, float(seg.max()) / 2):
        raise ProfileError(
            f"{name}: curve is open: gap between last and first point {closing:.6g} "
            f"exceeds 20x the median spacing {typical:.6g}")
    crossings = segments_intersect_count(pts)
    if crossings:
        raise ProfileError(f"{name}: self-intersecting ({crossings} crossing edge pairs)")
    if signed_area(pts) < 0:
        pts = pts[::-1].copy()
    return pts


def load_profile_csv(path, unit_scale=1.0):
    """Read ``x,y`` rows (header optional) and return a validated :class:`SplineProfile`."""
    rows = []
    with open(path, newline="") as f:
        try:
            lines = list(csv.reader(f))
        except UnicodeDecodeError:
            raise ProfileError(f"{path}: not a text file (a profile is CSV text of x,y rows)") from None
        for k, row in enumerate(lines):
            if not row or row[0].strip().startswith("#"):
                continue
            try:
                vals = [float(v) for v in row[:2]]
            except ValueError:
                if k == 0 and not rows:
                    continue  # header
                raise ProfileError(f"{path}: line {k + 1} is not numeric: {row}") from None
            if len(vals) < 2:
                raise ProfileError(f"{path}: line {k + 1} has fewer than 2 columns")
            rows.append(vals)
    try:
        return SplineProfile(np.asarray(rows) * unit_scale)
    except ProfileError as e:
        raise ProfileError(f"{path}: {e}") from None


def points_in_polygon(xy, poly, chunk=4096):
    """Even-odd test of points (N, 2) against a closed polygon (M, 2) -> bool (N,)."""
    xy = np.asarray(xy, float)
    a = poly
    b = np.roll(poly, -1, axis=0)
    out = np.zeros(len(xy), bool)
    for s in range(0, len(xy), chunk):
        p = xy[s:s + chunk, None, :]
        cond = (a[None, :, 1] > p[..., 1]) != (b[None, :, 1] > p[..., 1])
        with np.errstate(divide="ignore", invalid="ignore"):
            xint = a[None, :, 0] + (p[..., 1] - a[None, :, 1]) * (b[None, :, 0] - a[None, :, 0]) / (
                b[None, :, 1] - a[None, :, 1])
        out[s:s + chunk] = (np.count_nonzero(cond & (p[..., 0] < xint), axis=1) % 2) == 1
    return out
