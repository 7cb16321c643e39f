"""Independent machining simulation of revolving tools on a helical relative motion.

Plan convention (flank-plan/1): a strip's tool is fixed in the rotor frame while the rotor screws by
S_t (Bizzarri, Bo & Bartoň Eq. (1)).  A rotor point x is removed iff its helix S_t(x) enters the tool for some t, so

    D(x) = min_t  sd_tool(S_t(x))

is the signed distance to the swept (removed) region: exact outside it (D is then the Euclidean
distance from x to the union of S_{-t}(tool)), negative inside.  The machined surface is the zero
set of D; on a design point p with outward normal n the deviation is the root lambda* of
D(p + lambda n) = 0: positive = material left, negative = overcut.  Nothing here uses a planner's
own error formula: only the tool solid and the motion.

A tool is a union of solids of revolution ("parts"), each with its own axis; the distance to a part
reduces to a 2D distance in its meridian half-plane (h along the axis, rho from it):

- :class:`FrustumPart`   convex hull of two spheres on the axis (flank-plan/1 "radii": inscribed
                         spheres at equally spaced axis points give a chain of these);
- :class:`CylinderPart`  flat-ended cylinder (the shank);
- :class:`MeridianPart`  any meridian rho = R(h) given as a polyline (formed disc cutters, custom tools);
- :class:`ParaboloidPart` the lens |h| <= b + a rho^2 of Doğrusadık Eq. (1), exact.

Speed: only times t at which the helix of x comes near the tool can matter.  Every part is covered by
bounding spheres; the helix stays on its cylinder of radius |x_xy|, so the times it passes within
E of a sphere are an axial window intersected with an angular window, both closed-form.  Sampling
happens only inside those windows, and points whose helix never comes within the caller's cutoff
of the tool cost nothing.
"""
import numpy as np
from ..geometry.angles import atan2
from ..geometry.polyline_distance import PolylineDistance
from ..geometry.runs import ranks_in_runs, segment_argmin, segment_min
from ..geometry.screw import hand_sign, screw_motion

GOLDEN = 0.5 * (3.0 - np.sqrt(5.0))


def _axial(q, origin, axis):
    """(h, rho): coordinates of points q (..., 3) along a unit axis through origin and away from it.  (h is
    summed here, not by ``w @ axis``: that goes to BLAS, whose threads then spin on the other core after every
    call -- in a two-paths verify, 0.4 s of CPU taken from whatever else runs there, Blender included.)"""
    w = np.asarray(q, float) - origin
    h = w[..., 0] * axis[0] + w[..., 1] * axis[1] + w[..., 2] * axis[2]
    rho = np.sqrt(np.maximum(np.einsum("...i,...i->...", w, w) - h * h, 0.0))
    return h, rho


def _unit(v, what):
    v = np.asarray(v, float)
    n = float(np.linalg.norm(v))
    if not n > 0:
        raise ValueError(f"{what} has zero length")
    return v / n, n


def _sphere_chain(p0, p1, radius_at, piece):
    """Bounding spheres for a solid around the segment p0-p1: centres (M, 3) and radii (M,)."""
    L = float(np.linalg.norm(np.subtract(p1, p0)))
    m = max(1, int(np.ceil(L / max(piece, 1e-12))))
    s = (np.arange(m) + 0.5) / m
    centres = (1 - s)[:, None] * np.asarray(p0, float) + s[:, None] * np.asarray(p1, float)
    half = 0.5 * L / m
    r = np.asarray([radius_at(si, 0.5 / m) for si in s], float)
    return centres, np.sqrt(r * r + half * half)


def _rows(v, q, vec):
    """Broadcast a per-row parameter (rows along axis 0 of q) against q (N, 3) or (N, n, 3)."""
    v = np.asarray(v, float)
    lead = v.ndim - (1 if vec else 0)          # 0: one value for all rows, 1: per row
    if lead == 1 and q.ndim == 3:
        v = v[:, None]
    return v


def sd_sphere_frustum(q, c1, r1, c2, r2):
    """Signed distance from points q (..., 3) to the convex hull of two spheres (exact outside).

    Parameters are either single (c (3,), r scalar) or per row of q (c (N, 3), r (N,))."""
    q = np.asarray(q, float)
    c1, c2 = _rows(c1, q, True), _rows(c2, q, True)
    r1, r2 = _rows(r1, q, False), _rows(r2, q, False)
    return _sd_frustum_framed(q, c1, r1, r2, *_frustum_frame(c1, r1, c2, r2))


def _sd_frustum_framed(q, c1, r1, r2, axis, L, contained, Ls, nx, ny):
    """:func:`sd_sphere_frustum` from the q-independent terms of :func:`_frustum_frame`."""
    cap1, cap2, d = _frustum_pieces(*_axial_h_rho(q, c1, axis, Ls), r1, r2, L, nx, ny)
    return np.where(contained, np.where(r2 >= r1, cap2, cap1), d)


def _frustum_frame(c1, r1, c2, r2):
    """The q-independent quantities of :func:`sd_sphere_frustum`: axis c2 - c1, its length L, whether one
    sphere contains the other, the divisor Ls (1 where contained) and the unit normal (nx, ny) of the
    tangent line in the (h, rho) half-plane."""
    axis = c2 - c1
    L = np.sqrt(np.einsum("...i,...i->...", axis, axis))
    contained = L <= np.abs(r2 - r1)           # one sphere contains the other
    Ls = np.where(contained, 1.0, L)
    nx = np.where(contained, 0.0, (r1 - r2) / Ls)
    ny = np.sqrt(1.0 - nx * nx)
    return axis, L, contained, Ls, nx, ny


def _axial_h_rho(q, c, axis, Ls):
    """Axial coordinate h (along ``axis`` / Ls from c) and distance rho from the axis of points q."""
    w = q - c
    h = np.einsum("...i,...i->...", w, axis) / Ls
    rho = np.sqrt(np.maximum(np.einsum("...i,...i->...", w, w) - h * h, 0.0))
    return h, rho


def _frustum_pieces(h, rho, r1, r2, L, nx, ny):
    """Distances to the two spherical caps and the signed distance of the frustum (not contained case)."""
    tau = (h - r1 * nx) * ny - (rho - r1 * ny) * nx     # position along the tangent line from T1
    line = h * nx + rho * ny - r1
    cap1 = np.hypot(h, rho) - r1
    cap2 = np.hypot(h - L, rho) - r2
    d = np.where(tau < 0, cap1, np.where(tau > L * ny, cap2, line))
    return cap1, cap2, d


def sd_cylinder(q, s0, s1, radius):
    """Signed distance from points q (..., 3) to a flat-ended cylinder from s0 to s1 (single or
    per-row parameters as in :func:`sd_sphere_frustum`)."""
    q = np.asarray(q, float)
    s0, s1, radius = _rows(s0, q, True), _rows(s1, q, True), _rows(radius, q, False)
    axis = s1 - s0
    L = np.sqrt(np.einsum("...i,...i->...", axis, axis))
    return _sd_cylinder_framed(q, s0, radius, axis, L)


def _sd_cylinder_framed(q, s0, radius, axis, L):
    """:func:`sd_cylinder` from its q-independent terms: the axis s1 - s0 and its length L."""
    h, rho = _axial_h_rho(q, s0, axis, L)
    dx = rho - radius
    dy = np.maximum(-h, h - L)
    return np.minimum(np.maximum(dx, dy), 0.0) + np.hypot(np.maximum(dx, 0.0), np.maximum(dy, 0.0))


class FrustumPart:
    """Convex hull of the spheres (c1, r1) and (c2, r2)."""

    def __init__(self, c1, r1, c2, r2):
        self.c1, self.c2 = np.asarray(c1, float), np.asarray(c2, float)
        self.r1, self.r2 = float(r1), float(r2)
        rmax = max(self.r1, self.r2)
        self.feature = max(min(self.r1, self.r2), 1e-3 * max(rmax, np.linalg.norm(self.c2 - self.c1)))
        # the chain runs over the end caps too: a helix may pass through a cap only
        u = self.c2 - self.c1
        n = float(np.linalg.norm(u))
        u = u / n if n > 0 else np.array([0.0, 0.0, 1.0])
        self.bounds = _sphere_chain(self.c1 - self.r1 * u, self.c2 + self.r2 * u, lambda s, ds: rmax,
                                    max(rmax, 1e-9))

    stack_fields = ("c1", "r1", "c2", "r2")
    sd_rows = staticmethod(sd_sphere_frustum)

    @staticmethod
    def prepare_rows(c1, r1, c2, r2):
        """Per-row parameters (c (N, 3), r (N,)) with the q-independent terms of :func:`sd_sphere_frustum`."""
        return (c1, r1, r2) + _frustum_frame(c1, r1, c2, r2)

    @staticmethod
    def sd_prepared(q, prepared):
        """:func:`sd_sphere_frustum` of points q (N, 3) or (N, n, 3) by :meth:`prepare_rows` (the same numbers)."""
        if q.ndim == 3:
            prepared = tuple(v[:, None] for v in prepared)
        return _sd_frustum_framed(q, *prepared)

    def signed_distance(self, q):
        """:func:`sd_sphere_frustum` of this part (the same numbers), its q-independent terms made once: the
        sweep evaluates a part many times on a few points each, where numpy's per-call cost dominates."""
        frame = self.__dict__.get("_frame")
        if frame is None:
            axis, L, contained, Ls, nx, ny = _frustum_frame(self.c1, self.r1, self.c2, self.r2)
            frame = self._frame = (axis, float(L), bool(contained), float(Ls), float(nx), float(ny))
        axis, L, contained, Ls, nx, ny = frame
        h, rho = _axial_h_rho(np.asarray(q, float), self.c1, axis, Ls)
        if contained:
            return np.hypot(h - L, rho) - self.r2 if self.r2 >= self.r1 else np.hypot(h, rho) - self.r1
        return _frustum_pieces(h, rho, self.r1, self.r2, L, nx, ny)[2]


class CylinderPart:
    """Flat-ended cylinder from s0 to s1 (a shank)."""

    def __init__(self, s0, s1, radius):
        self.s0, self.s1, self.radius = np.asarray(s0, float), np.asarray(s1, float), float(radius)
        _unit(self.s1 - self.s0, "shank axis")
        self.feature = self.radius
        self.bounds = _sphere_chain(self.s0, self.s1, lambda s, ds: self.radius, self.radius)

    stack_fields = ("s0", "s1", "radius")
    sd_rows = staticmethod(sd_cylinder)

    @staticmethod
    def prepare_rows(s0, s1, radius):
        """Per-row parameters with the q-independent terms of :func:`sd_cylinder`."""
        axis = s1 - s0
        return s0, radius, axis, np.sqrt(np.einsum("...i,...i->...", axis, axis))

    @staticmethod
    def sd_prepared(q, prepared):
        """:func:`sd_cylinder` of points q (N, 3) or (N, n, 3) by :meth:`prepare_rows` (the same numbers)."""
        if q.ndim == 3:
            prepared = tuple(v[:, None] for v in prepared)
        return _sd_cylinder_framed(q, *prepared)

    def signed_distance(self, q):
        """:func:`sd_cylinder` of this part (the same numbers), its axis and length made once."""
        frame = self.__dict__.get("_frame")
        if frame is None:
            frame = self._frame = self.prepare_rows(self.s0, self.s1, self.radius)
        return _sd_cylinder_framed(np.asarray(q, float), *frame)

    def axis_frame(self):
        return self.s0, _unit(self.s1 - self.s0, "shank axis")[0]

    def sd_plane(self, h, rho, hint=None):
        """(sd, None) from meridian-plane coordinates (h from s0 along the axis, rho from it)."""
        L = float(np.linalg.norm(self.s1 - self.s0))
        dx = rho - self.radius
        dy = np.maximum(-h, h - L)
        return np.minimum(np.maximum(dx, dy), 0.0) + np.hypot(np.maximum(dx, 0.0), np.maximum(dy, 0.0)), None


class MeridianPart:
    """Solid of revolution {h0 <= h <= h1, rho <= R(h)}, R piecewise linear through ``meridian``.

    Args:
        origin, direction: axis point (h = 0) and axis direction.
        meridian: (K, 2) rows (h, R) with h strictly increasing and R >= 0 (e.g. the axial profile
            (Z_u, R_u) of a formed disc cutter, Hu, Zhou & Li 2025).
    The 2D distance is exact: the minimum over all edges of the boundary (end face, meridian, end face), found
    by :class:`geometry.polyline_distance.PolylineDistance` (a window in h from the point straight across in
    rho, or from the previous query's nearest edge, on this graph; else a hierarchy of edge runs).  The sign is
    the exact test rho <= R(h).  Time samples of a helix are pruned by a grid of exact signed distances (the
    signed distance is 1-Lipschitz) and by the hierarchy's bounds before any is measured exactly.
    """

    # Long edges are split to about the typical edge length (``spacing``; a long-standing layout of the
    # boundary: every distance is the same without it).
    MAX_BOUNDARY_VERTICES = 20000
    expensive = True     # worth pruning time samples before measuring them exactly

    def __init__(self, origin, direction, meridian, spacing=None):
        m = np.asarray(meridian, float)
        if m.ndim != 2 or m.shape[1] != 2 or len(m) < 2 or not np.isfinite(m).all():
            raise ValueError("meridian must be (K >= 2, 2) finite (h, R) rows")
        if np.any(np.diff(m[:, 0]) <= 0):
            raise ValueError("meridian h values must increase strictly")
        if np.any(m[:, 1] < 0):
            raise ValueError(f"meridian radii must be >= 0, got min {m[:, 1].min():.6g}")
        self.origin = np.asarray(origin, float)
        self.axis, _ = _unit(direction, "meridian axis")
        self.meridian = m
        self._mh, self._mr = m[:, 0].copy(), m[:, 1].copy()
        h0, h1 = m[0, 0], m[-1, 0]
        # the boundary in the half-plane: end face, meridian, end face (the axis is not boundary)
        ring = np.vstack([[h0, 0.0], m, [h1, 0.0]])
        extent = max(h1 - h0, m[:, 1].max())
        seg = np.diff(ring, axis=0)
        seg_len = np.linalg.norm(seg, axis=1)
        # long edges are split to about the typical edge length
        typical = 2.0 * float(np.median(seg_len[seg_len > 0]))
        self.spacing = float(spacing) if spacing else max(min(extent / 400.0, typical),
                                                          float(seg_len.sum()) / self.MAX_BOUNDARY_VERTICES)
        # each edge of positive length split into ceil(l / spacing) equal pieces (j / count of the way along)
        live = np.flatnonzero(seg_len > 0)
        count = np.maximum(1, np.ceil(seg_len[live] / self.spacing).astype(int))
        which = np.repeat(live, count)
        j = ranks_in_runs(count)
        frac = j * np.repeat(1.0 / count, count)
        self.boundary = np.vstack([ring[which] + frac[:, None] * seg[which], ring[-1:]])    # open polyline
        self.polyline = PolylineDistance(self.boundary)
        self.golden_iters = 30
        # time sampling must resolve the thinner parts of the tool a helix can pass through; the
        # radius at the lowest 5 % of the axis (not the minimum, which a rounded or pointed end
        # would drive to zero) sets the step
        hh = np.linspace(h0, h1, 4001)
        rr = np.interp(hh, m[:, 0], m[:, 1])
        r_small = max(float(np.quantile(rr, 0.05)), 1e-3 * extent)
        self.feature = float(np.clip(0.5 * r_small, 1e-3 * extent, max(0.25 * (h1 - h0), 1e-3 * extent)))
        rr = np.maximum(np.maximum(rr, np.r_[rr[1:], rr[-1]]), np.r_[rr[0], rr[:-1]])   # upper envelope

        def radius_over(s, ds):
            sel = (hh >= h0 + (s - ds) * (h1 - h0) - 1e-12) & (hh <= h0 + (s + ds) * (h1 - h0) + 1e-12)
            return float(rr[sel].max()) + (h1 - h0) / 4000.0    # grid spacing covers the slope
        self.bounds = _sphere_chain(self.origin + h0 * self.axis, self.origin + h1 * self.axis,
                                    radius_over, max(0.1 * float(m[:, 1].max()), 1e-9))

    def radius_at(self, h):
        return np.interp(h, self._mh, self._mr, left=-1.0, right=-1.0)

    def _plane(self, q):
        """(p (N, 2), inside (N,), ub (N,)): meridian-plane coordinates of rows q (..., 3), the exact test
        rho <= R(h), and an upper bound of the distance (to the boundary point straight across in rho)."""
        h, rho = _axial(q, self.origin, self.axis)
        p = np.c_[h.ravel(), rho.ravel()]
        R = self.radius_at(p[:, 0])
        inside = p[:, 1] <= R
        ub = np.where(R >= 0, np.abs(p[:, 1] - R), np.inf)
        return p, inside, ub

    def signed_distance(self, q, hint=None):
        d, _ = self.signed_distance_hinted(q, hint)
        return d

    def axis_frame(self):
        return self.origin, self.axis

    def sd_plane(self, h, rho, hint=None, window=None):
        """(sd, edge) from meridian-plane coordinates (h, rho) (N,), as :meth:`signed_distance_hinted`;
        ``window`` = (rows, edges) of :meth:`PolylineDistance.fixed_windows` for rows known to have their
        nearest edge there."""
        R = self.radius_at(h)
        if window is not None and window[1] is not None and len(window[0]):
            rows, win = window
            rest = np.ones(len(h), bool)
            rest[rows] = False
            best, edge = np.empty(len(h)), np.empty(len(h), int)
            best[rows], edge[rows] = self.polyline.window_distance(h[rows], rho[rows], win)
            if rest.any():
                ub = np.where(R[rest] >= 0, np.abs(rho[rest] - R[rest]), np.inf)
                best[rest], edge[rest] = self.polyline.distance_xy(h[rest], rho[rest], ub=ub,
                                                                    hint=None if hint is None else hint[rest])
        else:
            ub = np.where(R >= 0, np.abs(rho - R), np.inf)
            best, edge = self.polyline.distance_xy(h, rho, ub=ub, hint=hint)
        return np.where(rho <= R, -best, best), edge

    def signed_distance_hinted(self, q, hint=None):
        """(sd, edge): signed distances of rows q (..., 3) and a boundary edge nearest to each; ``hint`` (rows,)
        edges near the answer (e.g. those of a neighbouring query) speed up the search."""
        p, inside, ub = self._plane(q)
        best, edge = self.polyline.distance(p, ub=ub, hint=hint)
        return np.where(inside, -best, best).reshape(np.shape(q)[:-1]), edge

    def signed_distance_pruned(self, q, group, thr):
        """(sd, exact) of rows q (N, 3) in sorted groups, exact where a row can hold its group's least signed
        distance (``thr`` per group: an upper bound of it, lowered in place); elsewhere a lower bound above it,
        exact False."""
        p, inside, ub = self._plane(q)
        lo, hi = self._grid_bounds(p)
        np.minimum(thr, segment_min(np.minimum(np.where(inside, 0.0, ub), hi), group, len(thr)), out=thr)
        slack = 1e-12 * self.polyline.scale
        cand = np.flatnonzero(lo <= thr[group] + slack)
        out, exact = lo, np.zeros(len(p), bool)
        if len(cand):
            out[cand], exact[cand] = self.polyline.signed_minimum(p[cand], inside[cand], group[cand], thr,
                                                                  ub=ub[cand])
        return out, exact

    GRID = 128      # nodes along the longer side of the signed-distance grid of :meth:`_grid_bounds`

    def _grid_bounds(self, p):
        """Lower and upper bounds of the signed distances of meridian-plane points p (N, 2) from the exact
        signed distances at the corners of their cell of a grid around the tool (the signed distance is
        1-Lipschitz); -inf / +inf outside the grid.  A node's distance is measured the first time a cell of
        it is asked for: the helices of one plan only pass through a small part of the grid (about a sixth
        of it in a verify), and a node far from a dense meridian is the most expensive query there is."""
        grid = getattr(self, "_grid", None)
        if grid is None:
            B = self.boundary
            lo, hi = B.min(axis=0), B.max(axis=0)
            margin = 0.25 * float((hi - lo).max())
            lo = np.array([lo[0] - margin, 0.0])
            hi = hi + margin
            g = float((hi - lo).max()) / self.GRID
            n = np.maximum(np.ceil((hi - lo) / g).astype(int), 1) + 1
            # flat, row-major (h, rho); this call keeps its own handle: a second thread that set up the grid at the
            # same time replaces self._grid, and the nodes this call measures must land where it reads them
            grid = self._grid = (lo, g, n, np.full(int(n[0] * n[1]), np.nan))
        lo, g, n, sd = grid
        f = (p - lo) / g
        i = np.floor(f).astype(int)
        ok = (i[:, 0] >= 0) & (i[:, 1] >= 0) & (i[:, 0] < n[0] - 1) & (i[:, 1] < n[1] - 1)
        low = np.full(len(p), -np.inf)
        high = np.full(len(p), np.inf)
        rows = np.flatnonzero(ok)
        if len(rows):
            fr = f[rows] - i[rows]
            base = i[rows, 0] * n[1] + i[rows, 1]
            corners = [base + (a * n[1] + b) for a in (0, 1) for b in (0, 1)]
            self._measure_nodes(grid, np.concatenate(corners))
            lb = np.full(len(rows), -np.inf)
            ub = np.full(len(rows), np.inf)
            for (a, b), at in zip(((0, 0), (0, 1), (1, 0), (1, 1)), corners):
                r = g * np.hypot(fr[:, 0] - a, fr[:, 1] - b) * (1 + 1e-12)
                v = sd[at]
                lb = np.maximum(lb, v - r)
                ub = np.minimum(ub, v + r)
            slack = 1e-12 * self.polyline.scale
            low[rows], high[rows] = lb - slack, ub + slack
        return low, high

    def _measure_nodes(self, grid, flat):
        """Exact signed distances of the nodes ``flat`` (flat indices) of ``grid`` not measured yet."""
        lo, g, n, sd = grid
        missing = np.isnan(sd[flat])
        if not missing.any():
            return
        want = np.zeros(len(sd), bool)
        want[flat[missing]] = True
        todo = np.flatnonzero(want)
        nodes = np.c_[lo[0] + g * (todo // n[1]).astype(float), lo[1] + g * (todo % n[1]).astype(float)]
        d, _ = self.polyline.distance(nodes)
        sd[todo] = np.where(nodes[:, 1] <= self.radius_at(nodes[:, 0]), -d, d)


class ParaboloidPart:
    """Doğrusadık Eq. (1) tool: the lens |h| <= b + a rho^2 (a < 0 < b), centre on the axis at ``centre``.

    The 2D distance to the parabola arc h = b + a u^2, u in [0, rho_e] solves the foot-point cubic
    2 a^2 u^3 + (1 + 2 a (b - |h|)) u - rho = 0 in closed form (all real roots, plus the arc ends).
    """

    def __init__(self, centre, direction, a, b):
        if not (a < 0 < b):
            raise ValueError(f"paraboloid needs a < 0 < b, got a = {a}, b = {b}")
        self.centre = np.asarray(centre, float)
        self.axis, _ = _unit(direction, "paraboloid axis")
        self.a, self.b = float(a), float(b)
        self.rho_e = float(np.sqrt(-b / a))
        self.golden_iters = 30                     # the equator is a sharp edge
        self.feature = 0.5 * min(self.rho_e, self.b)
        rb = float(np.hypot(self.rho_e, self.b))
        self.bounds = (self.centre[None, :], np.array([rb]))

    def _arc_distance(self, H, rho):
        a, b = self.a, self.b
        # depressed cubic u^3 + P u + Q = 0
        P = (1 + 2 * a * (b - H)) / (2 * a * a)
        Q = -rho / (2 * a * a)
        cands = [np.zeros_like(H), np.full_like(H, self.rho_e)]
        disc = (Q / 2) ** 2 + (P / 3) ** 3
        with np.errstate(invalid="ignore"):
            sq = np.sqrt(np.maximum(disc, 0.0))
            cardano = np.cbrt(-Q / 2 + sq) + np.cbrt(-Q / 2 - sq)
            cands.append(np.where(disc >= 0, cardano, np.nan))
            r = np.sqrt(np.maximum(-P / 3, 0.0))
            arg = np.clip(-Q / (2 * np.maximum(r, 1e-100) ** 3), -1.0, 1.0)
            th = np.arccos(arg) / 3
            for k in range(3):
                cands.append(np.where(disc < 0, 2 * r * np.cos(th - 2 * np.pi * k / 3), np.nan))
        best = np.full_like(H, np.inf)
        for u in cands:
            u = np.clip(np.nan_to_num(u, nan=0.0), 0.0, self.rho_e)
            for _ in range(2):   # Newton polish of the stationarity condition (clipped to the arc)
                g = 2 * a * a * u ** 3 + (1 + 2 * a * (b - H)) * u - rho
                dg = 6 * a * a * u ** 2 + (1 + 2 * a * (b - H))
                u = np.clip(np.where(np.abs(dg) > 1e-14, u - g / np.where(dg == 0, 1, dg), u), 0.0, self.rho_e)
            best = np.minimum(best, np.hypot(u - rho, b + a * u * u - H))
        return best

    def signed_distance(self, q):
        h, rho = _axial(q, self.centre, self.axis)
        H = np.abs(h)
        d = self._arc_distance(H, rho)
        inside = (H <= self.b + self.a * rho * rho) & (rho <= self.rho_e)
        return np.where(inside, -d, d)


class RevolvingTool:
    """A union of revolving parts, fixed in the rotor frame (one strip's tool, optionally with shank)."""

    def __init__(self, parts):
        self.parts = list(parts)
        if not self.parts:
            raise ValueError("a tool needs at least one part")
        self.bound_centres = np.vstack([p.bounds[0] for p in self.parts])
        self.bound_radii = np.concatenate([p.bounds[1] for p in self.parts])
        self.feature = min(p.feature for p in self.parts)
        # a sharp edge makes D(x) kinked in t near the edge's trace; parabolic polish cannot
        # converge there, golden section must shrink the bracket further (~1e-9 instead of ~1e-5)
        self.golden_iters = max(getattr(p, "golden_iters", 12) for p in self.parts)
        self.expensive = any(getattr(p, "expensive", False) for p in self.parts)
        self.z_range = (float((self.bound_centres[:, 2] - self.bound_radii).min()),
                        float((self.bound_centres[:, 2] + self.bound_radii).max()))

    def signed_distance(self, q):
        d = self.parts[0].signed_distance(q)
        for p in self.parts[1:]:
            d = np.minimum(d, p.signed_distance(q))
        return d

    def signed_distance_pruned(self, q, group, thr):
        """(sd, exact) for rows q (N, 3) in sorted groups of which only each group's least signed distance is
        wanted (``thr`` (per group) an upper bound of it, lowered in place): exact wherever a row can attain
        its group's minimum; elsewhere a lower bound of the row's signed distance above it (exact False)."""
        cheap = [p for p in self.parts if not getattr(p, "expensive", False)]
        d = np.full(len(q), np.inf)
        for p in cheap:
            d = np.minimum(d, p.signed_distance(q))
        exact = np.ones(len(q), bool)
        np.minimum(thr, segment_min(d, group, len(thr)), out=thr)
        for p in self.parts:
            if getattr(p, "expensive", False):
                dp, ok = p.signed_distance_pruned(q, group, thr)
                # a row this part left out lies above thr there; where a cheap part is at most thr it is exact
                exact &= ok | (d <= thr[group])
                d = np.minimum(d, dp)
        return d, exact

    def tracker(self, x=None, v0=None, handedness="right"):
        """This tool for a sequence of calls on the same rows, each near the last (a per-row search that
        moves a little each step): each call starts from the previous call's nearest boundary edges.  With
        points x (N, 3) and the screw (v0, handedness), :meth:`_Tracked.at` gives the signed distances of
        S_t(x) directly."""
        return _Tracked(self, x, v0, handedness)

    def coaxial(self):
        """(origin, unit axis, [(sign, offset)] per part) when every part is a solid of revolution about one
        common axis line (a part's h = sign (h - offset)), else None."""
        if not hasattr(self, "_coaxial"):
            self._coaxial = None
            if all(hasattr(p, "axis_frame") and hasattr(p, "sd_plane") for p in self.parts):
                o, a = (np.asarray(v, float) for v in self.parts[0].axis_frame())
                frames, ok = [], True
                for p in self.parts:
                    op, ap = (np.asarray(v, float) for v in p.axis_frame())
                    sign = float(np.sign(ap @ a))
                    w = op - o
                    off = float(w @ a)
                    scale = 1.0 + float(np.abs(o).max()) + float(np.abs(op).max())
                    if (np.linalg.norm(np.cross(ap, a)) > 1e-12 or sign == 0
                            or np.linalg.norm(w - off * a) > 1e-12 * scale):
                        ok = False
                        break
                    frames.append((sign, off))
                if ok:
                    self._coaxial = (o, a, frames)
        return self._coaxial

    def lower_bound(self, q):
        """A lower bound of signed_distance (q (..., 3)): distance to the nearest bounding sphere."""
        d = np.full(np.shape(q)[:-1], np.inf)
        for c, r in zip(self.bound_centres, self.bound_radii):
            d = np.minimum(d, np.linalg.norm(q - c, axis=-1) - r)
        return d

    def time_windows(self, x, v0, handedness, margin):
        """See :func:`time_windows` (this tool's bounding spheres)."""
        return time_windows(x, self.bound_centres, self.bound_radii, v0, handedness, margin)

    def rows(self, idx):
        return self


class _Tracked:
    """:meth:`RevolvingTool.tracker`: exact signed distances, each row's search started from its last answer."""

    def __init__(self, tool, x=None, v0=None, handedness="right"):
        self.tool = tool
        self.hints = {}
        self.last = {}           # part -> (h, |sd|) of the last query of each row
        self.windows = {}        # part -> fixed edge windows (rows, edges) of :meth:`narrow`
        self.frame = tool.coaxial() if x is not None else None
        if self.frame is not None:
            o, a, _ = self.frame
            x = np.asarray(x, float)
            self.x, self.y, self.z = x[:, 0] - 0.0, x[:, 1] - 0.0, x[:, 2] - o[2]
            self.v0, self.hand = float(v0), hand_sign(handedness)
        self.screw = (x, v0, handedness)

    def signed_distance(self, q):
        d = None
        for j, p in enumerate(self.tool.parts):
            if hasattr(p, "signed_distance_hinted"):
                dj, self.hints[j] = p.signed_distance_hinted(q, self.hints.get(j))
            else:
                dj = p.signed_distance(q)
            d = dj if d is None else np.minimum(d, dj)
        return d

    def at(self, t):
        """Signed distances of S_t(x) (one t per row)."""
        if self.frame is None:
            x, v0, hand = self.screw
            return self.signed_distance(screw_motion(x, t, v0, hand))
        o, a, frames = self.frame
        ang = self.hand * t
        c, s = np.cos(ang), np.sin(ang)
        wx = c * self.x - s * self.y - o[0]
        wy = s * self.x + c * self.y - o[1]
        wz = self.z + self.v0 * t
        h = wx * a[0] + wy * a[1] + wz * a[2]
        rho = np.sqrt(np.maximum(wx * wx + wy * wy + wz * wz - h * h, 0.0))
        d = None
        for j, (p, (sign, off)) in enumerate(zip(self.tool.parts, frames)):
            hj = sign * (h - off)
            if j in self.windows:
                dj, self.hints[j] = p.sd_plane(hj, rho, self.hints.get(j), window=self.windows[j])
            else:
                dj, self.hints[j] = p.sd_plane(hj, rho, self.hints.get(j))
            if self.hints[j] is not None:
                self.last[j] = (hj, np.abs(dj))
            d = dj if d is None else np.minimum(d, dj)
        return d

    def narrow(self, reach):
        """Every later query of a row lies within ``reach`` (per row) of its last one: its nearest meridian edge
        then lies within the last distance plus twice that of the last query (in h on the meridian graph), so
        each row's search is fixed to those few edges (rows with more keep the general search)."""
        if self.frame is None:
            return
        for j, p in enumerate(self.tool.parts):
            if j in self.last and hasattr(p, "polyline"):
                h_last, d_last = self.last[j]
                win = p.polyline.fixed_windows(h_last, d_last + 2.0 * reach)
                if win is not None:
                    self.windows[j] = win


def time_windows(x, centres, radii, v0, handedness, margin):
    """Hull [t_lo, t_hi] of the times at which S_t(x) is within ``margin`` (scalar or (N,)) of a
    bounding sphere; (t_lo, t_hi, hit) with hit False where it never is (then D(x) > margin).

    x: (N, 3); spheres: centres (M, 3) and radii (M,) shared by all points, or per point (N, M, 3)
    and (N, M) (radius -inf for padding).  The helix of x stays on the cylinder of radius |x_xy|:
    it can be within E of a sphere only inside the axial window |z(t) - c_z| <= E and the angular
    window where the planar distance to c_xy is <= E, both closed-form.
    """
    h = hand_sign(handedness)
    c = np.asarray(centres, float)
    c = c[None] if c.ndim == 2 else c                           # (1 or N, M, 3)
    rb = np.asarray(radii, float)
    rb = rb[None] if rb.ndim == 1 else rb
    E = rb + np.reshape(margin, (-1, 1))                        # (N or 1, M)
    with np.errstate(invalid="ignore"):
        zw_lo = (c[..., 2] - E - x[:, 2:3]) / v0                # (N, M) axial window
        zw_hi = (c[..., 2] + E - x[:, 2:3]) / v0
    rx = np.hypot(x[:, 0], x[:, 1])[:, None]
    rc = np.hypot(c[..., 0], c[..., 1])
    prod = 2 * rx * rc
    with np.errstate(divide="ignore", invalid="ignore"):
        kappa = np.where(prod > 1e-300, (rx * rx + rc * rc - E * E) / prod,
                         np.where(np.abs(rx - rc) <= E, -2.0, 2.0))
    alpha = np.arccos(np.clip(kappa, -1.0, 1.0))               # angular half-width
    full = kappa <= -1.0
    # centre times of the angular window: psi = theta + h t hits the sphere's angle
    tc = h * (atan2(c[..., 1], c[..., 0]) - atan2(x[:, 1], x[:, 0])[:, None])
    two_pi = 2 * np.pi
    with np.errstate(invalid="ignore"):
        k_lo = np.ceil((zw_lo - tc - alpha) / two_pi)
        k_hi = np.floor((zw_hi - tc + alpha) / two_pi)
        lo = np.where(full, zw_lo, np.maximum(zw_lo, tc + two_pi * k_lo - alpha))
        hi = np.where(full, zw_hi, np.minimum(zw_hi, tc + two_pi * k_hi + alpha))
        ok = (E >= 0) & (kappa <= 1.0) & (full | (k_lo <= k_hi)) & (lo <= hi)
    t_lo = np.where(ok, lo, np.inf).min(axis=1)
    t_hi = np.where(ok, hi, -np.inf).max(axis=1)
    return t_lo, t_hi, ok.any(axis=1)


class StackedTools:
    """Several tools with the same layout of frustum/cylinder parts, evaluated together: every row
    of a query carries the index of its tool, so one numpy pass serves all strips of a plan."""

    def __init__(self, tools):
        self.tools = list(tools)
        first = self.tools[0]
        self.kinds = [type(p) for p in first.parts]
        self.fields = [{f: np.stack([np.asarray(getattr(t.parts[j], f), float) for t in self.tools])
                        for f in kind.stack_fields} for j, kind in enumerate(self.kinds)]
        M = max(len(t.bound_radii) for t in self.tools)
        self.centres = np.zeros((len(self.tools), M, 3))
        self.radii = np.full((len(self.tools), M), -np.inf)
        for k, t in enumerate(self.tools):
            self.centres[k, :len(t.bound_radii)] = t.bound_centres
            self.radii[k, :len(t.bound_radii)] = t.bound_radii
        self.feature = min(t.feature for t in self.tools)
        self.golden_iters = max(t.golden_iters for t in self.tools)
        self.z_range = (min(t.z_range[0] for t in self.tools), max(t.z_range[1] for t in self.tools))

    @staticmethod
    def compatible(tools):
        kinds = [tuple(type(p) for p in t.parts) for t in tools]
        return (len(set(kinds)) == 1 and len(tools) > 1
                and all(hasattr(k, "stack_fields") for k in kinds[0]))

    def rows(self, which):
        return _StackedRows(self, np.asarray(which))


class _StackedRows:
    """A view of :class:`StackedTools` whose query rows belong to tools ``which`` (N,)."""

    def __init__(self, stack, which):
        self.stack, self.which = stack, which
        self.feature, self.golden_iters, self.z_range = stack.feature, stack.golden_iters, stack.z_range

    def rows(self, idx):
        view = _StackedRows(self.stack, self.which[idx])
        parts = self.__dict__.get("_parts")
        if parts is not None:           # the rows' parameters, prepared already: gathered, not made again
            view._parts = [(sd, tuple(v[idx] for v in prepared)) for sd, prepared in parts]
        return view

    def time_windows(self, x, v0, handedness, margin):
        return time_windows(x, self.stack.centres[self.which], self.stack.radii[self.which], v0,
                            handedness, margin)

    def prepared(self):
        """Each part's (distance function, per-row parameters); a search calls the distance ~20 times on the
        same rows: their parameters are gathered (and, where the part can, its q-independent terms computed)
        once.  Views of these rows (:meth:`rows`) made afterwards gather them from here (the same numbers: every
        term is computed row by row)."""
        parts = self.__dict__.get("_parts")
        if parts is None:
            parts = self._parts = []
            for kind, fields in zip(self.stack.kinds, self.stack.fields):
                rows = tuple(fields[f][self.which] for f in kind.stack_fields)
                parts.append((kind.sd_prepared, kind.prepare_rows(*rows)) if hasattr(kind, "prepare_rows")
                             else (lambda q, rows, kind=kind: kind.sd_rows(q, *rows), rows))
        return parts

    def signed_distance(self, q):
        parts = self.prepared()
        q = np.asarray(q, float)
        d = None
        for sd, prepared in parts:
            dj = sd(q, prepared)
            d = dj if d is None else np.minimum(d, dj)
        return d


def tool_distances(tools, points, v0, handedness, cutoff, mask=None):
    """(K, N) min(D_k(x_i), cutoff_i) for tools k and points x_i (N, 3); pairs where ``mask`` (K, N)
    is False are not computed (left at cutoff).  Tools of one layout are evaluated together."""
    K, N = len(tools), len(points)
    cutoff = np.broadcast_to(np.asarray(cutoff, float), (N,))
    out = np.broadcast_to(cutoff, (K, N)).copy()
    mask = np.ones((K, N), bool) if mask is None else mask
    if StackedTools.compatible(tools):
        kk, ii = np.nonzero(mask)
        if len(kk):
            stack = StackedTools(tools)
            out[kk, ii] = helical_distance(stack.rows(kk), points[ii], v0, handedness, cutoff=cutoff[ii],
                                           times=False)[0]
        return out
    for k, t in enumerate(tools):
        ii = np.flatnonzero(mask[k])
        if len(ii):
            out[k, ii] = helical_distance(t, points[ii], v0, handedness, cutoff=cutoff[ii], times=False)[0]
    return out


class StripTool(RevolvingTool):
    """flank-plan/1 strip tool: inscribed spheres of ``radii`` at equally spaced points from
    axis_start to axis_end (a chain of sphere frustums), plus an optional flat-ended shank."""

    def __init__(self, axis_start, axis_end, radii, shank_start=None, shank_end=None, shank_radius=0.0,
                 extra_parts=()):
        radii = np.asarray(radii, float)
        if radii.ndim != 1 or len(radii) < 2 or (radii < 0).any():
            raise ValueError(f"tool radii must be >= 2 non-negative values, got {radii.tolist()!r}")
        s = np.linspace(0.0, 1.0, len(radii))[:, None]
        centres = (1 - s) * np.asarray(axis_start, float) + s * np.asarray(axis_end, float)
        parts = list(extra_parts) or [FrustumPart(centres[k], radii[k], centres[k + 1], radii[k + 1])
                                      for k in range(len(radii) - 1)]
        if shank_start is not None and shank_radius > 0 and np.linalg.norm(
                np.subtract(shank_end, shank_start)) > 0:
            parts.append(CylinderPart(shank_start, shank_end, shank_radius))
        super().__init__(parts)

    @classmethod
    def from_strip(cls, strip, with_shank=True):
        """The solid of a flank-plan/1 strip.  Optional shape fields take precedence over ``radii``:
        ``meridian`` [[h, R], ...] (h from axis_start towards axis_end) or ``paraboloid`` {a, b}
        (lens centred at axis_start, axis towards axis_end)."""
        extra = []
        p0, p1 = np.asarray(strip["axis_start"], float), np.asarray(strip["axis_end"], float)
        if strip.get("meridian") is not None:
            extra = [MeridianPart(p0, p1 - p0, strip["meridian"])]
        elif strip.get("paraboloid") is not None:
            extra = [ParaboloidPart(p0, p1 - p0, strip["paraboloid"]["a"], strip["paraboloid"]["b"])]
        shank = (strip.get("shank_start"), strip.get("shank_end"), strip.get("shank_radius", 0.0)) \
            if with_shank else (None, None, 0.0)
        return cls(p0, p1, strip["radii"], *shank, extra_parts=extra)


def strip_solids(strips, with_shank=True):
    """The solids of a plan's strips (:meth:`StripTool.from_strip`), each distinct one once: a strip whose
    solid is built from the same numbers as an earlier strip's (a two-paths plan that fell back to the
    double-flank axis used twice) shares that strip's solid, so the sweep measures it once.
    -> (tools, first): tools[g] the solid of group g; first (G,) int the index of its first strip, which owns
    every point the group forms (:func:`first_least` gives it to the first of equal strips)."""
    tools, first, seen = [], [], {}
    for k, s in enumerate(strips):
        key = solid_key(s, with_shank)
        if key not in seen:
            seen[key] = len(tools)
            tools.append(StripTool.from_strip(s, with_shank=with_shank))
            first.append(k)
    return tools, np.array(first, int)


def strip_owners(owner, first):
    """Owners (N,) of machined points as indices of the solids of :func:`strip_solids` (-1: none) -> as indices of
    the strips (the first strip of each solid's group; -1 stays)."""
    owner = np.asarray(owner)
    return np.where(owner >= 0, first[np.maximum(owner, 0)], -1) if len(first) else owner


def solid_key(strip, with_shank=True):
    """What :meth:`StripTool.from_strip` builds a strip's solid from, as a key equal for two strips exactly when
    those numbers are (other fields, such as notes in a paraboloid's dict, play no part)."""
    par = strip.get("paraboloid")
    values = [strip.get("axis_start"), strip.get("axis_end"), strip.get("radii"), strip.get("meridian"),
              None if par is None else (par["a"], par["b"])]
    if with_shank:
        values += [strip.get("shank_start"), strip.get("shank_end"), strip.get("shank_radius")]
    return tuple(None if v is None else (np.shape(v), np.asarray(v, float).tobytes()) for v in values)


def helical_distance(tool, points, v0, handedness="right", step=None, iters=None, polish=4, cutoff=np.inf,
                     times=True):
    """min(D(x), cutoff) with D(x) = min_t sd_tool(S_t(x)) for 3D points (N, 3): (D, t*).

    Only the times inside the tool's window (:meth:`RevolvingTool.time_windows`) are searched: they
    are sampled densely (points move at most ``step`` between samples) and the best sample is
    polished on its neighbouring interval by ``iters`` golden-section steps (default: the tool's
    ``golden_iters``), then ``polish`` parabolic-interpolation steps; so is every other sampled minimum
    whose interval could hold a lower value.  Points whose helix never comes
    within ``cutoff`` (scalar or (N,)) of the tool get exactly ``cutoff`` (a lower bound of D), t* = nan;
    points whose time samples already prove D >= cutoff get ``cutoff`` too, t* = their least sample's time
    (with ``times`` False: nan, and such points are told apart from the others with fewer samples measured, where
    the tool's distance is cheap).
    """
    x = np.atleast_2d(np.asarray(points, float))
    N = len(x)
    cutoff = np.broadcast_to(np.asarray(cutoff, float), (N,))
    out_d = cutoff.copy()
    out_t = np.full(N, np.nan)
    if not np.isfinite(cutoff).all():
        z0, z1 = tool.z_range
        t_lo, t_hi, hit = (z0 - x[:, 2]) / v0, (z1 - x[:, 2]) / v0, np.ones(N, bool)
    else:
        t_lo, t_hi, hit = tool.time_windows(x, v0, handedness, np.maximum(cutoff, 0.0))
    idx = np.flatnonzero(hit)
    if not len(idx):
        return out_d, out_t
    x, t_lo, t_hi = x[idx], t_lo[idx], t_hi[idx]
    tool = tool.rows(idx)
    speed = np.sqrt(np.einsum("ij,ij->i", x[:, :2], x[:, :2]) + v0 * v0)
    if step is None:
        step = 0.25 * tool.feature
    if iters is None:
        iters = tool.golden_iters
    n = int(np.clip(np.max((t_hi - t_lo) * speed / step), 8, 4000)) + 1
    s = np.linspace(0.0, 1.0, n)
    span = t_hi - t_lo

    def time_of(r, c):
        """The time of sample c of row r (what ``t_lo[:, None] + span[:, None] * s[None, :]`` holds there)."""
        return t_lo[r] + span[r] * s[c]

    rows = np.arange(len(x))
    arc = speed * span / (n - 1)
    # a point whose least sample is this far above the cutoff answers the cutoff (``settled`` below)
    cap = None if times else cutoff[idx] + 0.5 * arc * (1.0 + 1e-9) + 2e-12 * (1.0 + np.abs(cutoff[idx]) + arc)
    if not getattr(tool, "expensive", False):
        # every sample the search below can look at is measured, the others are not
        samples = _near_least_samples(tool, x, time_of, n, v0, handedness, cap)
    else:
        T = time_of(rows[:, None], np.arange(n)[None, :])
        Q = screw_motion(x[:, None, :], T, v0, handedness)
        if hasattr(tool, "signed_distance_pruned"):
            # only each point's least sample and its two neighbours (the bracket of the search below) are
            # needed: samples whose distance provably lies above the point's least value are never measured
            D = _least_samples(tool, Q)
            k = np.argmin(D, axis=1)
            for j in (np.maximum(k - 1, 0), np.minimum(k + 1, n - 1)):
                need = ~np.isfinite(D[rows, j])
                if need.any():
                    D[rows[need], j[need]] = tool.signed_distance(Q[rows[need], j[need]])
        else:
            # bounding spheres give a cheap lower bound; a sample whose bound exceeds the exact value
            # at the most promising sample can never be the minimum, so it is not evaluated exactly
            lb = tool.lower_bound(Q)
            upper = tool.signed_distance(Q[rows, np.argmin(lb, axis=1)])
            todo = lb <= upper[:, None]
            D = np.full(lb.shape, np.inf)
            D[todo] = tool.signed_distance(Q[todo])
        r, c = np.nonzero(~(D == np.inf))              # (NaN rows too, as np.argmin sees them)
        samples = _Samples(r, c, D[r, c], n)
    k, best = samples.least(len(x))
    best_t = time_of(rows, k)
    # a time between two samples puts the point within half the arc between them (speed * dt / 2) of a
    # sample, and D is 1-Lipschitz: rows whose least sample lies that far above the cutoff can only answer
    # the cutoff, so they skip the search (their t* stays at the least sample)
    settled = best - 0.5 * arc * (1.0 + 1e-9) - 1e-12 * (1.0 + np.abs(best)) >= cutoff[idx]
    if cap is not None:
        settled |= best >= cap          # (implied: left explicit, as the samples were pruned against cap)
    if settled.any():
        out_d[idx[settled]] = cutoff[idx[settled]]
        out_t[idx[settled]] = best_t[settled] if times else np.nan
        keep = np.flatnonzero(~settled)
        if not len(keep):
            return out_d, out_t
        idx, x, k, best_t, best, speed, arc, t_lo, span = (idx[keep], x[keep], k[keep], best_t[keep], best[keep],
                                                            speed[keep], arc[keep], t_lo[keep], span[keep])
        samples = samples.rows(keep)
        tool = tool.rows(keep)
        rows = np.arange(len(x))
    lo_j, hi_j = np.maximum(k - 1, 0), np.minimum(k + 1, n - 1)
    fm, tm = _refine_bracket(tool, x, v0, handedness, time_of(rows, lo_j), time_of(rows, hi_j),
                             samples.at(rows, lo_j), samples.at(rows, hi_j), iters, polish, speed)
    better = fm < best
    best, best_t = np.where(better, fm, best), np.where(better, tm, best_t)
    # another basin of the samples may hold a lower value between its samples than the least sample's basin:
    # two minima of the distance along the helix that differ by less than the samples resolve (the sampled
    # values of a smooth minimum sit above it by up to a quarter of the rise to their higher neighbour, those
    # of a kink by up to half of it).  Every other sampled minimum that could be lower is refined too.
    # (Sampled minima next to a sample that was never measured are left alone: it was pruned because it cannot
    # come near the least value.)  Such a minimum lies within half a sample's arc of the best (D is
    # 1-Lipschitz): only the samples within a whole arc of it are looked at.
    r, c, mid = samples.r, samples.c, samples.v
    with np.errstate(invalid="ignore"):
        near = (c >= 1) & (c <= n - 2) & (mid <= best[r] + arc[r] * (1.0 + 1e-9) + 1e-12 * (1.0 + np.abs(best[r])))
    rr, jj, mid = r[near], c[near], mid[near]
    left, right = samples.at(rr, jj - 1), samples.at(rr, jj + 1)
    with np.errstate(invalid="ignore"):
        maybe = (np.isfinite(left) & np.isfinite(right) & (mid <= left) & (mid < right)
                 & (mid - 0.5 * np.maximum(left - mid, right - mid) <= best[rr]))
    inner = (k > 0) & (k < n - 1)
    maybe &= ~(inner[rr] & (jj == k[rr]))                  # the least sample's own basin, refined above
    rr, jj, mid, left, right = rr[maybe], jj[maybe], mid[maybe], left[maybe], right[maybe]
    if len(rr):
        fm2, tm2 = _refine_bracket(tool.rows(rr), x[rr], v0, handedness, time_of(rr, jj - 1), time_of(rr, jj + 1),
                                   left, right, iters, polish, speed[rr])
        fm2, tm2 = np.minimum(fm2, mid), np.where(fm2 < mid, tm2, time_of(rr, jj))
        order = np.lexsort((fm2, rr))             # per row, its least second basin first
        first = np.r_[True, rr[order][1:] != rr[order][:-1]]
        r2, f2, t2 = rr[order][first], fm2[order][first], tm2[order][first]
        lower = f2 < best[r2]
        best[r2[lower]], best_t[r2[lower]] = f2[lower], t2[lower]
    out_d[idx] = np.minimum(best, cutoff[idx])
    out_t[idx] = best_t
    return out_d, out_t


def _refine_bracket(tool, x, v0, handedness, a, b, fa, fb, iters, polish, speed):
    """Least distance of each row's helix on its time bracket [a, b] (values fa, fb at the ends): ``iters``
    golden-section steps, then ``polish`` steps of successive parabolic interpolation (the distance along
    the helix is C1 near a minimum outside the tool, so this converges fast where golden section would need
    ~20 more evaluations for the same accuracy).  Returns (value, time) per row."""
    ft = tool.tracker(x, v0, handedness) if hasattr(tool, "tracker") else None

    def f(t):
        if ft is not None:
            return ft.at(t)
        return tool.signed_distance(screw_motion(x, t, v0, handedness))

    # golden-section search on [a, b] (vectorised over the points), endpoint values tracked
    c = a + GOLDEN * (b - a)
    d = b - GOLDEN * (b - a)
    fc, fd = f(c), f(d)
    for it in range(iters):
        left = fc <= fd
        b, fb = np.where(left, d, b), np.where(left, fd, fb)
        a, fa = np.where(left, a, c), np.where(left, fa, fc)
        new_c = a + GOLDEN * (b - a)
        new_d = b - GOLDEN * (b - a)
        c_next = np.where(left, new_c, d)
        d_next = np.where(left, c, new_d)
        f_eval = f(np.where(left, new_c, new_d))
        fc, fd = np.where(left, f_eval, fd), np.where(left, fc, f_eval)
        c, d = c_next, d_next
        if ft is not None and it in (5, 12):
            # every later time lies in [a, b], which holds the last one: the helix moves at most speed (b - a)
            ft.narrow(speed * (b - a) * (1 + 1e-9))
    X = np.stack([a, c, d, b], axis=1)
    F = np.stack([fa, fc, fd, fb], axis=1)
    r = np.arange(len(X))
    for _ in range(polish):
        j = np.clip(np.argmin(F, axis=1), 1, X.shape[1] - 2)
        x0, x1, x2 = X[r, j - 1], X[r, j], X[r, j + 1]
        f0, f1, f2 = F[r, j - 1], F[r, j], F[r, j + 1]
        num = (x1 - x0) ** 2 * (f1 - f2) - (x1 - x2) ** 2 * (f1 - f0)
        den = (x1 - x0) * (f1 - f2) - (x1 - x2) * (f1 - f0)
        with np.errstate(divide="ignore", invalid="ignore"):
            u = x1 - 0.5 * num / den
        bad = ~np.isfinite(u) | (u <= x0) | (u >= x2) | (u == x1)
        # fall back to bisecting the larger side
        u = np.where(bad, np.where(x2 - x1 > x1 - x0, 0.5 * (x1 + x2), 0.5 * (x0 + x1)), u)
        fu = f(u)
        X = np.concatenate([X, u[:, None]], axis=1)
        F = np.concatenate([F, fu[:, None]], axis=1)
        order = np.argsort(X, axis=1)
        X, F = X[r[:, None], order], F[r[:, None], order]
    jm = np.argmin(F, axis=1)
    return F[r, jm], X[r, jm]


class _Samples:
    """The measured time samples of N helices: rows r, columns c (sorted by row, then column), values v; every
    other sample counts as +inf."""

    def __init__(self, r, c, v, n):
        self.r, self.c, self.v, self.n = r, c, v, n

    def at(self, r, c):
        """Values of the samples (r, c), +inf where not measured."""
        key = self.r * self.n + self.c
        want = np.asarray(r) * self.n + np.asarray(c)
        pos = np.minimum(np.searchsorted(key, want), max(len(key) - 1, 0))
        found = (key[pos] == want) if len(key) else np.zeros(np.shape(want), bool)
        return np.where(found, self.v[pos] if len(key) else np.inf, np.inf)

    def least(self, N):
        """(column, value) of each row's least sample, as ``np.argmin`` of the rows with +inf elsewhere picks it
        (the first of equal values; the first NaN where there is one; column 0 and +inf for a row without any)."""
        k, best = np.zeros(N, int), np.full(N, np.inf)
        pos = segment_argmin(self.v, self.r, N)             # the samples are in column order within a row
        has = pos >= 0
        k[has], best[has] = self.c[pos[has]], self.v[pos[has]]
        return k, best

    def rows(self, keep):
        """The samples of rows ``keep`` (sorted), renumbered 0, 1, ..."""
        new = np.full(max(int(self.r.max(initial=-1)), int(np.max(keep, initial=-1))) + 1, -1)
        new[keep] = np.arange(len(keep))
        sel = new[self.r] >= 0
        return _Samples(new[self.r[sel]], self.c[sel], self.v[sel], self.n)


def _near_least_samples(tool, x, time_of, n, v0, handedness, cap=None):
    """The time samples of N helices (points x (N, 3); sample c of row r at ``time_of(r, c)``, n per row, equally
    spaced) that :func:`helical_distance` looks at after sampling, measured (:class:`_Samples`): every sample
    within half a chord of its row's least value.  (The search looks at the least sample, and at every sampled
    minimum within half the rise to its higher neighbour of the least, with those neighbours; the distance is
    1-Lipschitz and neighbouring samples lie a chord c apart, so such a minimum lies within c / 2 of the least.)

    Coarse to fine, for tools whose distance is cheap: samples 64, 16, 4, then 1 apart.  Between two measured
    samples j < k with values a and b, no sample lies below (a + b - (k - j) c) / 2, so only the gaps where that
    is within the margin of the row's best value are cut further.  The neighbours of a sample within the margin
    are measured too: a gap that ends at a sample of value a has b <= a + (k - j) c at its other end, so its
    bound is at most a, and it is cut down to single steps.  A point moves a quarter of the tool's smallest
    radius between samples, up to 4,001 of them per helix: a cone with a sharp tip had all of them measured,
    2.2 s of a verify.

    ``cap`` (N,) or None: where a row's least value is at least its cap, only that is needed (the caller answers
    its cutoff there); the gaps are then cut only where they can hold a value below the cap."""
    N = len(x)
    every = np.arange(N)
    first = screw_motion(x, time_of(every, 0), v0, handedness)
    chord = (np.linalg.norm(screw_motion(x, time_of(every, min(1, n - 1)), v0, handedness) - first, axis=1)
             * (1 + 1e-12) + 1e-15)
    scale = 1.0 + float(np.abs(x).max()) + abs(v0) * float(max(np.abs(time_of(every, 0)).max(),
                                                                 np.abs(time_of(every, n - 1)).max()))
    margin = 0.5 * chord * (1 + 1e-9) + 1e-12 * scale
    best = np.full(N, np.inf)
    measured = []
    if hasattr(tool, "prepared"):
        tool.prepared()                 # once for the N rows; each batch of samples gathers from them

    def measure(ri, ci):
        """Measure the samples (ri, ci), ri sorted; their values."""
        v = tool.rows(ri).signed_distance(screw_motion(x[ri], time_of(ri, ci), v0, handedness)) if len(ri) \
            else np.zeros(0)
        measured.append((ri, ci, v))
        np.minimum(best, segment_min(v, ri, N), out=best)
        return v

    stride = max([s for s in (64, 16, 4) if 4 * s <= n], default=1)
    cols = np.unique(np.r_[np.arange(0, n, stride), n - 1])
    r = np.repeat(every, len(cols))
    c = np.tile(cols, N)
    v = measure(r, c)
    # gaps between consecutive measured samples of a row: (row, left, right, left value, right value)
    last = np.r_[c[1:] <= c[:-1], True]                     # a row's last sample starts no gap
    g = np.flatnonzero(~last)
    gr, gl, gh, gvl, gvh = r[g], c[g], c[g + 1], v[g], v[g + 1]
    while stride > 1:
        stride //= 4
        low = 0.5 * (gvl + gvh - (gh - gl) * chord[gr])
        limit = best if cap is None else np.minimum(best, cap)
        keep = (gh - gl > 1) & (low <= limit[gr] + margin[gr])
        gr, gl, gh, gvl, gvh = gr[keep], gl[keep], gh[keep], gvl[keep], gvh[keep]
        # cut each gap at every stride-th sample inside it
        cuts = (gh - gl - 1) // stride
        at = np.repeat(gl, cuts) + stride * (ranks_in_runs(cuts) + 1)
        ri = np.repeat(gr, cuts)
        vi = measure(ri, at)
        # the finer gaps: each old gap's ends with its cuts between them, in order
        ends_c = np.concatenate([gl, at, gh])
        ends_r = np.concatenate([gr, ri, gr])
        ends_v = np.concatenate([gvl, vi, gvh])
        seq = np.concatenate([np.arange(len(gl)), np.repeat(np.arange(len(gl)), cuts), np.arange(len(gl))])
        order = np.lexsort((ends_c, seq))
        ends_c, ends_r, ends_v, seq = ends_c[order], ends_r[order], ends_v[order], seq[order]
        inner = np.flatnonzero(seq[1:] == seq[:-1])
        gr, gl, gh, gvl, gvh = ends_r[inner], ends_c[inner], ends_c[inner + 1], ends_v[inner], ends_v[inner + 1]
    r, c, v = (np.concatenate(a) for a in zip(*measured))
    order = np.lexsort((c, r))
    return _Samples(r[order], c[order], v[order], n)


def _least_samples(tool, Q, strides=(16, 4, 1)):
    """Signed distances of the time samples Q (N, n, 3) of N helices, exact wherever a sample can hold its
    helix's least value, +inf elsewhere.  Coarse to fine: samples ``strides[0]`` apart first; screw motion
    moves the samples of a helix equally far apart (the chord c of one step), and the distance is 1-Lipschitz,
    so a sample j steps from one with a lower bound L (or an exact value) lies at least L - j c away: only
    samples whose bound does not exceed the helix's best upper bound so far are searched at the next stride."""
    N, n = Q.shape[:2]
    rows = np.arange(N)
    chord = np.linalg.norm(Q[:, min(1, n - 1)] - Q[:, 0], axis=1) * (1 + 1e-12) + 1e-15
    thr = np.full(N, np.inf)
    lower = np.full((N, n), -np.inf)        # lower bound of each sample's signed distance (exact where known)
    exact = np.zeros((N, n), bool)
    done = np.zeros(n, bool)
    slack = 1e-12 * (1.0 + float(np.abs(Q).max()))
    for stride in strides:
        cols = np.zeros(n, bool)
        cols[::stride] = True
        cols[n - 1] = True
        cols &= ~done
        if done.any():
            # bound each new sample from the nearest known samples on either side
            known = np.flatnonzero(done)
            c = np.flatnonzero(cols)
            j_left = known[np.clip(np.searchsorted(known, c) - 1, 0, len(known) - 1)]
            j_right = known[np.clip(np.searchsorted(known, c), 0, len(known) - 1)]
            bound = np.maximum(lower[:, j_left] - np.abs(c - j_left) * chord[:, None],
                               lower[:, j_right] - np.abs(j_right - c) * chord[:, None])
            lower[:, c] = bound
            want = np.zeros((N, n), bool)
            want[:, c] = bound <= thr[:, None] + slack
        else:
            want = np.broadcast_to(cols, (N, n)).copy()
        done |= cols
        ri, ci = np.nonzero(want)
        if not len(ri):
            continue
        d, ok = tool.signed_distance_pruned(Q[ri, ci], ri, thr)
        lower[ri, ci] = d
        exact[ri, ci] = ok
    return np.where(exact, lower, np.inf)


def false_position(lo, hi, f_lo, f_hi):
    """Regula-falsi points of the brackets [lo, hi] with values f_lo, f_hi (arrays); the midpoint
    where the secant is flat or leaves the bracket."""
    m = np.where(f_hi != f_lo, hi - f_hi * (hi - lo) / np.where(f_hi != f_lo, f_hi - f_lo, 1.0), 0.5 * (lo + hi))
    return np.where((m - lo) * (m - hi) < 0, m, 0.5 * (lo + hi))


def illinois_update(lo, f_lo, hi, f_hi, m, f_m, side):
    """One Illinois bracket update with the new point m, f_m (hi is always replaced by m; lo keeps the
    sign change, its value halved when it is kept twice in a row).  side (1 / -1 / 0) remembers the
    last move.  Returns the new (lo, f_lo, hi, f_hi, side)."""
    same_hi = np.sign(f_m) == np.sign(f_hi)
    lo_new = np.where(same_hi, lo, hi)
    f_lo_new = np.where(same_hi, np.where(side == 1, 0.5 * f_lo, f_lo), f_hi)
    return lo_new, f_lo_new, m, f_m, np.where(same_hi, 1, -1)


def illinois_roots(D, lo, hi, f_lo, f_hi, found, tol, slack, cutoff, report=None):
    """Illinois (modified regula falsi) on brackets [lo, hi] of D along each row's normal, only for rows
    ``found`` with a sign change and not yet narrower than ``tol``.  D(lam, idx, bound) evaluates the
    rows idx at lam with a distance cutoff; the cutoff passed is |f_hi| + bracket width + ``slack``
    (f_hi is never halved, so it bounds the distance), capped at ``cutoff``.  The arrays are updated
    in place; returns the root estimate per row (meaningful where ``found``).  A row also stops when the
    secant through its bracket puts the root within tol / 2 of hi: regula falsi moves one end at a time, so
    the bracket itself would need further steps to shrink below ``tol`` around a root already found."""
    side = np.zeros(len(lo))
    n_found = max(int(found.sum()), 1)
    for _ in range(100):
        near_hi = np.abs(f_hi) * np.abs(hi - lo) <= 0.5 * tol * np.abs(f_lo - f_hi)
        idx = np.flatnonzero(found & (np.abs(hi - lo) > tol) & (f_hi != 0) & ~near_hi)
        if not len(idx):
            break
        if report is not None:
            report(1.0 - len(idx) / n_found, "surface crossings ({} points left)".format(len(idx)))
        l, fl, h, fh = lo[idx], f_lo[idx], hi[idx], f_hi[idx]
        bound = np.minimum(np.abs(fh) + np.abs(h - l) + slack, cutoff)
        if len(idx) <= FEW_CROSSINGS:
            # (the open crossings only ever become fewer: Illinois and its ``side`` are not used again)
            lo[idx], f_lo[idx], hi[idx], f_hi[idx] = _split_brackets(D, idx, l, fl, h, fh, bound)
            continue
        m = false_position(l, h, fl, fh)
        fm = D(m, idx, bound)
        lo[idx], f_lo[idx], hi[idx], f_hi[idx], side[idx] = illinois_update(l, fl, h, fh, m, fm, side[idx])
    root = np.where(np.abs(f_hi) <= np.abs(f_lo), hi, lo)
    return np.where(f_lo == 0, lo, root)


# the crossings still open when this few remain are the slow ones (a kink of D at the surface, where the secant
# steps only halve the bracket), and a call of D on a few points costs about as much as on one: each bracket is
# cut into several parts per call instead
FEW_CROSSINGS = 4
SPLIT_POINTS = 16


def _split_brackets(D, idx, l, fl, h, fh, bound):
    """Brackets [l, h] (values fl, fh of opposite signs) of the rows idx cut by one call of D on about
    ``SPLIT_POINTS`` points in all: into equal parts, and at the regula-falsi point (so that a crossing where D
    is smooth is found as fast as by the secant alone).  The part next to l whose far end first leaves l's sign
    is kept (the crossing nearest to l).  Returns the new (l, fl, h, fh)."""
    n = len(idx)
    m = max(2, SPLIT_POINTS // n - 2)
    frac = np.arange(1, m + 1) / (m + 1)
    fp = false_position(l, h, fl, fh)
    cuts = np.c_[l[:, None] + (h - l)[:, None] * frac, fp]
    order = np.argsort(np.c_[np.broadcast_to(frac, (n, m)), (fp - l) / (h - l)], axis=1, kind="stable")
    r = np.arange(n)
    lam = cuts[r[:, None], order]                        # from l towards h
    fv = D(lam.ravel(), np.repeat(idx, m + 1), np.repeat(bound, m + 1)).reshape(n, m + 1)
    L, F = np.c_[l, lam, h], np.c_[fl, fv, fh]
    j = np.argmax(np.sign(F[:, 1:]) != np.sign(F[:, :1]), axis=1)     # fh always differs from fl
    return L[r, j], F[r, j], L[r, j + 1], F[r, j + 1]


def first_least(d, tie):
    """Per column of d (K, N): the first row whose value is within ``tie`` of the column's least, or the row of
    the least where no other comes that close (NaN columns: argmin's row).  Two strips that sweep the same
    surface (one tool used twice on one axis) give values equal up to rounding, and the rounding of a long
    sum differs from run to run with the memory layout: the first row wins, so the owner of a point is the
    same every time."""
    d = np.asarray(d, float)
    owner = np.argmin(d, axis=0)
    low = d[owner, np.arange(d.shape[1])]
    with np.errstate(invalid="ignore"):
        near = d <= low + tie
    return np.where(near.any(axis=0), np.argmax(near, axis=0), owner)


def helical_reach(points, directions, radius, v0, handedness="right", most=16.0):
    """How far each ray x + l d may go without crossing the boundary of a helically invariant solid (the swept
    region of a screw motion) when x lies at distance ``radius`` from that boundary: points (N, 3), unit
    directions (N, 3), radius (N,) >= 0.  Returns l (N,) with radius <= l <= ``most`` * radius.

    The distance to such a solid is the same at every point S_s x of x's helix, so no boundary point lies
    within ``radius`` of that helix.  The ray stays in that tube further than in the ball about x alone where
    it has a component along the helix: with u = dS_s x / ds at s = 0 and sigma = (d . u) / |u|^2,

        |x + l d - S_{sigma l} x| <= l |d - sigma u| + r (theta^2 / 2 + |theta|^3 / 6),  theta = sigma l,

    (r the distance of x from the axis; the remainder bounds sin and cos by their Taylor terms), and the right
    side grows with l, so every point of the ray up to the l where it equals ``radius`` is in the tube.  A
    march by spheres alone creeps up to a surface that a helix crosses obliquely (each step a fixed fraction of
    the rest); this one reaches it in a step or two.
    """
    h = hand_sign(handedness)
    x, y = points[:, 0], points[:, 1]
    ux, uy = -h * y, h * x
    uu = ux * ux + uy * uy + v0 * v0
    du = directions[:, 0] * ux + directions[:, 1] * uy + directions[:, 2] * v0
    sigma = du / uu
    a = np.sqrt(np.maximum(1.0 - du * du / uu, 0.0))
    r = np.sqrt(x * x + y * y)
    # l0 (at most ``most`` radii) bounds l from above (the remainder only shortens it), so the remainder at l0 is
    # a safe excess
    l0 = radius / np.maximum(a, 1.0 / most)
    excess = r * (0.5 * sigma * sigma * l0 + np.abs(sigma) ** 3 * l0 * l0 / 6.0)
    reach = radius / (a + excess + 1e-300)
    return np.clip(reach, radius, l0)


def machined_deviation(tools, points, normals, v0, handedness="right", max_deviation=None, tol=1e-12,
                       progress=None, owner_tie=None):
    """Signed deviation of design points from the simulated machined surface, along their normals.

    Args:
        tools: list of :class:`RevolvingTool` (all strips of a plan).
        points, normals: (N, 2) transverse profile points (plane z = 0) and unit outward normals, or
            (N, 3) points anywhere with 3D unit normals (e.g. an axial section).
        max_deviation: search limit; points with no machined surface within it get +inf (uncut), except points
            inside the swept region, whose search goes on over the points' whole radius (an overcut deeper than
            the limit is still an overcut; -inf if even that range ends inside).
        progress: None or ``progress(fraction, message)`` (:mod:`progress`; returning False cancels).
        owner_tie: None, or a tie width: then also which tool forms each machined point, as
            :func:`first_least` with that tie picks it from the tools' distances at the point.
    Returns:
        (N,) deviation: > 0 material left, < 0 overcut, +inf not reached by any tool.  With ``owner_tie``:
        (deviation, owner, distance), owner (N,) the tool (-1 where the deviation is +inf) and distance (N,)
        the least D of the tools at the machined point (+inf there too).  Every root is a point where D was
        evaluated, so both come from that evaluation: a tool left out of it (or cut off at its bound) lies
        farther than the bound, and the bound exceeds the least value by at least 1e-9 of the points' size,
        so it could not have been within the tie.
    """
    from ..progress import reporter

    report = reporter(progress)
    report(0.0, "distances to the tools")
    points = np.asarray(points, float)
    normals = np.asarray(normals, float)
    if points.shape[1] == 2:
        p = np.c_[points, np.zeros(len(points))]
        n = np.c_[normals, np.zeros(len(points))]
    else:
        p, n = points, normals
    if max_deviation is None:
        max_deviation = 0.25 * float(np.max(np.linalg.norm(p[:, :2], axis=1)))
    scale = float(np.max(np.abs(p)))
    # lambda never leaves [-max_deviation, max_deviation], so distances beyond ``cutoff`` only need
    # to be known as "at least cutoff" (safe sphere-tracing steps); that lets the time windows cull
    cutoff = max_deviation + 1e-6 * scale

    # D is 1-Lipschitz along the ray, so a tool farther than the search range at lambda = 0 can
    # never form the surface within it: each point only looks at its candidate tools
    # (first with a small cutoff: most design points lie close to the machined surface, and a
    # capped value is still a valid lower bound; only points far from every tool need the full one)
    near = min(1e-3 * scale, cutoff)
    d_tools = tool_distances(tools, p, v0, handedness, near)
    far = np.flatnonzero(d_tools.min(axis=0) >= near)
    if len(far) and near < cutoff:
        d_tools[:, far] = tool_distances(tools, p[far], v0, handedness, cutoff)
    relevant = d_tools < cutoff
    # (rows, lambda, owner, least D) of every evaluation, when the owners are wanted
    evaluated = [] if owner_tie is None else [(np.arange(len(p)), np.zeros(len(p)), first_least(d_tools, owner_tie),
                                               d_tools.min(axis=0))]

    def D(lam, idx, bound):
        """min over tools of min(D(p + lam n), bound); bound must not exceed ``cutoff``.  Callers pass a
        bound that |D| provably stays below (1-Lipschitz along the ray), so results stay exact while
        the time windows shrink with it; tool k cannot come within bound if d_k(0) - |lam| > bound."""
        q = p[idx] + lam[:, None] * n[idx]
        mask = relevant[:, idx] & (d_tools[:, idx] - np.abs(lam) < bound)
        d = tool_distances(tools, q, v0, handedness, bound, mask)
        least = d.min(axis=0)
        if owner_tie is not None:
            evaluated.append((idx, lam, first_least(d, owner_tie), least))
        return least

    d0 = np.min(d_tools, axis=0)
    # sphere tracing: outside the swept region D is the exact distance, so a step of D cannot jump
    # over the first crossing (a brief pass through the region included); the extra 1e-9 lets the
    # march cross the surface instead of creeping up to it.  Inside, march outwards the same way.  The
    # region is helically invariant, so the step goes as far as the ray stays within D of the point's
    # helix (:func:`helical_reach`), not only within its ball.
    lo = np.zeros(len(p))
    f_lo = d0.copy()
    hi = lo.copy()
    f_hi = d0.copy()
    direction = np.where(d0 >= 0, 1.0, -1.0)
    active = (d0 != 0) & relevant.any(axis=0)
    ran_out = np.zeros(len(p), bool)        # the march reached the end of the range without crossing
    n_active = max(int(active.sum()), 1)
    for _ in range(400):
        idx = np.flatnonzero(active)
        if not len(idx):
            break
        report(0.1 + 0.6 * (1.0 - len(idx) / n_active), "marching to the surface ({} points left)".format(len(idx)))
        ray = direction[idx, None] * n[idx]
        reach = helical_reach(p[idx] + lo[idx, None] * n[idx], ray, np.abs(f_lo[idx]), v0, handedness)
        step = direction[idx] * (reach + 1e-9 * scale)
        lam = lo[idx] + step
        out = np.abs(lam) > max_deviation
        lam = np.clip(lam, -max_deviation, max_deviation)
        f_new = D(lam, idx, np.minimum(np.abs(f_lo[idx]) + np.abs(lam - lo[idx]) + 1e-9 * scale, cutoff))
        crossed = np.sign(f_new) != np.sign(f_lo[idx])
        hi[idx], f_hi[idx] = lam, f_new
        keep = ~crossed & ~out
        lo[idx[keep]], f_lo[idx[keep]] = lam[keep], f_new[keep]
        ran_out[idx[out & ~crossed]] = True
        active[idx[crossed | out]] = False
    found = (np.sign(f_hi) != np.sign(f_lo)) | (f_lo == 0)
    root = illinois_roots(D, lo, hi, f_lo, f_hi, found, tol, 1e-9 * scale, cutoff,
                          report=None if progress is None else reporter(progress, 0.7, 1.0))
    report(1.0, "deviation")
    deviation = np.where(found, root, np.inf)
    owners = None if owner_tie is None else _owners_at(deviation, evaluated, len(p))
    # a point inside the swept region still inside at the end of the range is overcut deeper than the range, not
    # uncut: search those again over the rotor's whole radius (none in a plan that overcuts less than the range)
    deep = np.flatnonzero(~found & (direction < 0) & ran_out)
    if len(deep):
        whole = float(np.max(np.linalg.norm(p[:, :2], axis=1)))
        if whole > max_deviation:
            again = machined_deviation(tools, p[deep], n[deep], v0, handedness, max_deviation=whole, tol=tol,
                                       owner_tie=owner_tie)
            if owner_tie is None:
                deviation[deep] = again
            else:
                deviation[deep] = again[0]
                owners[0][deep], owners[1][deep] = again[1], again[2]
        # still inside over the whole radius: an overcut deeper than any search, never "uncut"
        deviation[deep] = np.where(np.isinf(deviation[deep]), -np.inf, deviation[deep])
    if owner_tie is None:
        return deviation
    return (deviation,) + owners


def _owners_at(deviation, evaluated, n):
    """(owner, distance) at each row's root, from the evaluations (rows, lambda, owner, least D) of D: a finite
    root is one of the lambdas evaluated on its row (where one was evaluated twice, either will do: the same
    point, the same tools)."""
    rows, lam, who, least = (np.concatenate(column) for column in zip(*evaluated))
    at_root = np.isfinite(deviation[rows]) & (lam == deviation[rows])
    owner = np.full(n, -1)
    distance = np.full(n, np.inf)
    owner[rows[at_root]] = who[at_root]
    distance[rows[at_root]] = least[at_root]
    if np.isinf(distance[np.isfinite(deviation)]).any():
        raise RuntimeError("a root of the machined surface was never evaluated")
    return owner, distance


def cap_safe(tool):
    """The same tool with bounding spheres that also cover the spherical end caps of its
    :class:`sweep.FrustumPart` pieces.  sweep.FrustumPart bounds only the segment c1-c2 (radius
    sqrt(rmax^2 + half^2)), so a helix passing only through the cap beyond c1 or c2 (up to r1 / r2
    past the centres) is culled by the time windows whenever a finite cutoff is used, and
    helical_distance then returns the cutoff instead of a negative distance."""
    parts = []
    for p in tool.parts:
        if isinstance(p, FrustumPart):
            q = FrustumPart(p.c1, p.r1, p.c2, p.r2)
            d = q.c2 - q.c1
            L = float(np.linalg.norm(d))
            u = d / L if L > 0 else np.array([0.0, 0.0, 1.0])
            rmax = max(q.r1, q.r2)
            q.bounds = _sphere_chain(q.c1 - q.r1 * u, q.c2 + q.r2 * u, lambda s, ds: rmax, max(rmax, 1e-9))
            p = q
        parts.append(p)
    return RevolvingTool(parts)


def tool_of(pose, with_shank=False):
    """The revolving tool of a :class:`cone.ConePose` or of a flank-plan/1 strip dict (end caps
    bounded, :func:`cap_safe`)."""
    strip = pose if isinstance(pose, dict) else pose.strip(0)
    return cap_safe(StripTool.from_strip(strip, with_shank=with_shank))
