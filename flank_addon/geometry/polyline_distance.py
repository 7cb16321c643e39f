"""Exact distances from planar points to a long open polyline.

Two exact searches, both returning the minimum over *all* edges of the same per-edge distance (the foot on each
edge clipped to it):

- a box hierarchy: the edges are grouped into runs of ``FANOUT`` consecutive edges, the runs into runs of
  ``FANOUT`` runs, and so on; every group carries the bounding box of its vertices and one of its vertices.  The
  distance to the polyline lies between the box distance of the nearest box and the distance to any vertex, so
  a search that goes down level by level, all queries at once, keeps only the groups whose box is nearer than
  the best vertex seen so far.  Its work does not grow for queries far from a dense curve, unlike the k nearest
  vertices of a kd-tree.
- a window on a graph: where the first coordinate never decreases along the polyline (a meridian R(h) with its
  end faces), every edge whose h-range misses [h - b, h + b] is farther than b from the query.  With an upper
  bound b from a point known to lie on the polyline (the vertical foot, or the edge nearest to a neighbouring
  query: a hint), the edges inside the window are measured directly; rows whose window holds too many edges go
  to the hierarchy.

:meth:`PolylineDistance.signed_minimum` goes further for queries that come in groups (the time samples of one
helix): only the group's least signed distance matters, so a query whose signed distance provably exceeds the
group's best upper bound is dropped as soon as the bounds show it.
"""
import numpy as np

from .runs import run_starts, segment_min

FANOUT = 8
WINDOW_TOTAL = 32768       # most edges the h-windows of one call measure; the widest rows beyond go to the hierarchy


class PolylineDistance:
    """Exact unsigned distances to the open polyline through ``points`` (K >= 2, 2), no edge of zero length."""

    def __init__(self, points):
        B = np.ascontiguousarray(points, float)
        if B.ndim != 2 or B.shape[1] != 2 or len(B) < 2:
            raise ValueError("a polyline needs (K >= 2, 2) points")
        self.points = B
        ne = len(B) - 1
        self.n_edges = ne
        self.scale = float(np.ptp(B, axis=0).max()) + float(np.abs(B).max())
        self.ax, self.ay = B[:-1, 0].copy(), B[:-1, 1].copy()
        self.ex, self.ey = np.diff(B[:, 0]), np.diff(B[:, 1])
        self.ee = self.ex * self.ex + self.ey * self.ey
        self.h = B[:, 0].copy()
        self.monotone = bool(np.all(self.ex >= 0))
        # levels, finest (runs of FANOUT edges) first: per run its chord (first to last vertex: start x, y,
        # vector x, y, squared length), the largest distance of its vertices from the chord (the run lies in the
        # convex hull of its vertices, and the distance to a segment is convex, so every point of the run is
        # that close to the chord) and its middle vertex
        self.levels = []
        size = FANOUT
        X, Y = B[:, 0].copy(), B[:, 1].copy()
        while True:
            starts = np.arange(0, ne, size)
            ends = np.minimum(starts + size, ne)            # last vertex index of each run
            m = len(starts)
            ax, ay = X[starts], Y[starts]
            cx, cy = X[ends] - ax, Y[ends] - ay
            cc = np.maximum(cx * cx + cy * cy, 1e-300)
            # every vertex against the chord of its run (the runs are consecutive: repeat, not gather; the last
            # vertex belongs to the last run)
            counts = np.full(m, size)
            counts[-1] = ne + 1 - size * (m - 1)
            ox, oy, ocx, ocy = (np.repeat(v, counts) for v in (ax, ay, cx, cy))
            wx, wy = X - ox, Y - oy
            u = np.clip((wx * ocx + wy * ocy) / np.repeat(cc, counts), 0.0, 1.0)
            dx, dy = wx - u * ocx, wy - u * ocy
            off = np.sqrt(dx * dx + dy * dy)
            fat = np.maximum.reduceat(off, starts)      # (a run's last vertex, the next one's first, is on its chord)
            mid = np.minimum(starts + size // 2, ne)
            self.levels.append((ax, ay, cx, cy, cc, fat * (1 + 1e-9), X[mid], Y[mid]))
            if m <= FANOUT:
                break
            size *= FANOUT

    def _edges(self, px, py, e):
        """Squared distances from points to edges e (same shape)."""
        wx, wy = px - self.ax[e], py - self.ay[e]
        ex, ey = self.ex[e], self.ey[e]
        u = np.clip((wx * ex + wy * ey) / self.ee[e], 0.0, 1.0)
        dx, dy = wx - u * ex, wy - u * ey
        return dx * dx + dy * dy

    def _search(self, px, py, ub=None, group=None, thr=None, inside=None):
        """(d, exact, edge, lower) by the hierarchy for points (px, py) (N,); ``ub`` optional upper bounds of d.
        With ``group`` (sorted (N,)) and ``thr`` (per group, lowered in place), rows whose signed distance
        (negative where ``inside``) provably exceeds their group's least upper bound are dropped (d = +inf, exact
        False, ``lower`` a lower bound of their signed distance above the threshold)."""
        N = len(px)
        slack = 1e-12 * self.scale
        top = len(self.levels) - 1
        n_top = len(self.levels[top][0])
        pr = np.repeat(np.arange(N), n_top)
        pc = np.tile(np.arange(n_top), N)
        ub2 = np.full(N, np.inf) if ub is None else np.square(ub)
        alive = np.ones(N, bool)
        lower = np.full(N, -np.inf)
        for lev in range(top, -1, -1):
            sx, sy, cx, cy, cc, fat, rx, ry = self.levels[lev]
            qx, qy = px[pr], py[pr]
            wx, wy = qx - sx[pc], qy - sy[pc]
            vx, vy = cx[pc], cy[pc]
            u = np.clip((wx * vx + wy * vy) / cc[pc], 0.0, 1.0)
            gx, gy = wx - u * vx, wy - u * vy
            lb = np.maximum(np.sqrt(gx * gx + gy * gy) - fat[pc], 0.0)
            lb2 = lb * lb
            wx, wy = qx - rx[pc], qy - ry[pc]
            starts = run_starts(pr)
            keys = pr[starts]
            if len(pr):
                ub2[keys] = np.minimum(ub2[keys], np.minimum.reduceat(wx * wx + wy * wy, starts))
            ubs = np.sqrt(ub2)
            keep = lb2 <= np.square(ubs + slack)[pr]
            if group is not None:
                lb_row = np.full(N, np.inf)
                if len(pr):
                    lb_row[keys] = np.sqrt(np.minimum.reduceat(np.where(keep, lb2, np.inf), starts))
                sd_lo = np.where(inside, -ubs, lb_row)
                sd_hi = np.where(inside, -lb_row, ubs)
                has = np.isfinite(lb_row)
                np.minimum(thr, segment_min(sd_hi[has], group[has], len(thr)), out=thr)
                dead = alive & ~(sd_lo <= thr[group] + slack)
                lower[dead] = sd_lo[dead]
                alive &= ~dead
                keep &= alive[pr]
            pr, pc = pr[keep], pc[keep]
            n_next = len(self.levels[lev - 1][0]) if lev else self.n_edges
            child = (pc[:, None] * FANOUT + np.arange(FANOUT)).ravel()
            pr = np.repeat(pr, FANOUT)
            if len(child) and child.max() >= n_next:
                ok = child < n_next
                child, pr = child[ok], pr[ok]
            pc = child
        d2 = self._edges(px[pr], py[pr], pc)
        d = np.full(N, np.inf)
        edge = np.zeros(N, int)
        if len(pr):
            starts = run_starts(pr)
            m = np.minimum.reduceat(d2, starts)
            d[pr[starts]] = np.sqrt(m)
            hit = d2 == np.repeat(m, np.diff(np.append(starts, len(pr))))
            edge[pr[hit]] = pc[hit]
        return d, alive & np.isfinite(d), edge, lower

    def _window(self, px, py, ub):
        """Rows whose h-windows [h - ub, h + ub] hold at most WINDOW_TOTAL edges together (the narrowest
        first): (rows, d, edge), exact there."""
        lo = px - ub * (1 + 1e-12) - 1e-12 * self.scale
        hi = px + ub * (1 + 1e-12) + 1e-12 * self.scale
        i0 = np.maximum(np.searchsorted(self.h, lo, side="left") - 1, 0)
        i1 = np.minimum(np.searchsorted(self.h, hi, side="right"), self.n_edges)
        cnt = np.maximum(i1 - i0, 1)
        cnt = np.where(np.isfinite(ub), cnt, self.n_edges + 1)
        rows = np.flatnonzero(cnt <= self.n_edges)
        if cnt[rows].sum() > WINDOW_TOTAL:
            order = rows[np.argsort(cnt[rows], kind="stable")]
            rows = np.sort(order[:int(np.searchsorted(np.cumsum(cnt[order]), WINDOW_TOTAL, side="right"))])
        if not len(rows):
            return rows, np.zeros(0), np.zeros(0, int)
        c = cnt[rows]
        first = np.cumsum(c) - c
        row_of = np.repeat(np.arange(len(rows)), c)
        e = np.repeat(i0[rows] - first, c) + np.arange(int(c.sum()))
        d2 = self._edges(px[rows][row_of], py[rows][row_of], e)
        m = np.minimum.reduceat(d2, first)
        hit = np.flatnonzero(d2 == np.repeat(m, c))
        edge = np.empty(len(rows), int)
        edge[row_of[hit]] = e[hit]
        return rows, np.sqrt(m), edge

    def distance(self, p, ub=None, hint=None, batch=20000):
        """(d, edge): exact distances of points p (N, 2) to the polyline and an edge attaining each.  ``ub``
        (N,): optional upper bounds of d; ``hint`` (N,): optional edge indices near each row's nearest edge
        (e.g. from a neighbouring query), which only change how fast the answer is found."""
        p = np.asarray(p, float).reshape(-1, 2)
        return self.distance_xy(p[:, 0].copy(), p[:, 1].copy(), ub, hint, batch)

    def distance_xy(self, px, py, ub=None, hint=None, batch=20000):
        """:meth:`distance` of the points (px, py) (N,)."""
        N = len(px)
        ub = np.full(N, np.inf) if ub is None else np.array(ub, float)
        if hint is not None:
            hint = np.clip(np.asarray(hint, int), 0, self.n_edges - 1)
            ub = np.minimum(ub, np.sqrt(self._edges(px, py, hint)))
        d = np.empty(N)
        edge = np.empty(N, int)
        todo = np.arange(N)
        if self.monotone:
            rows, dw, ew = self._window(px, py, ub)
            d[rows], edge[rows] = dw, ew
            if len(rows):
                rest = np.ones(N, bool)
                rest[rows] = False
                todo = np.flatnonzero(rest)
        for s in range(0, len(todo), batch):
            r = todo[s:s + batch]
            dr, _, er, _ = self._search(px[r], py[r], ub[r])
            d[r], edge[r] = dr, er
        return d, edge

    def fixed_windows(self, px, r, kmax=64):
        """Edges of the h-windows [px - r, px + r] (monotone polylines), for a sequence of searches that stay
        within r of these centres: (rows whose window holds at most ``kmax`` edges, their gathered edges as
        :meth:`window_distance` takes them), or None where the polyline is not a graph."""
        if not self.monotone:
            return None
        lo = px - r * (1 + 1e-12) - 1e-12 * self.scale
        hi = px + r * (1 + 1e-12) + 1e-12 * self.scale
        i0 = np.maximum(np.searchsorted(self.h, lo, side="left") - 1, 0)
        i1 = np.minimum(np.searchsorted(self.h, hi, side="right"), self.n_edges)
        cnt = np.maximum(i1 - i0, 1)
        rows = np.flatnonzero((cnt <= kmax) & np.isfinite(r))
        if not len(rows):
            return rows, None
        K = int(cnt[rows].max())
        e = np.minimum(i0[rows, None] + np.arange(K), np.maximum(i1[rows, None] - 1, i0[rows, None]))
        return rows, (e, self.ax[e], self.ay[e], self.ex[e], self.ey[e], self.ee[e])

    @staticmethod
    def window_distance(px, py, win):
        """(d, edge) of points (px, py) (rows of a :meth:`fixed_windows` result) over their window's edges: the
        same per-edge arithmetic as every other search here."""
        e, ax, ay, ex, ey, ee = win
        wx, wy = px[:, None] - ax, py[:, None] - ay
        u = np.clip((wx * ex + wy * ey) / ee, 0.0, 1.0)
        dx, dy = wx - u * ex, wy - u * ey
        d2 = dx * dx + dy * dy
        j = np.argmin(d2, axis=1)
        r = np.arange(len(j))
        return np.sqrt(d2[r, j]), e[r, j]

    def signed_minimum(self, p, inside, group, thr, ub=None, batch=20000):
        """Signed distances s = -d where ``inside``, +d elsewhere, of points p (N, 2) that come in groups
        (``group`` (N,), sorted) of which only each group's least s is wanted: (s, exact).  ``thr`` (per group)
        is an upper bound of that least value (+inf if none is known); it is lowered in place as the search
        finds better bounds.  ``ub`` (N,): optional upper bounds of the rows' unsigned distances.  Rows whose s
        provably exceeds the group's least value get a lower bound of s above it instead, with exact False;
        every row that can attain its group's minimum is exact."""
        p = np.asarray(p, float).reshape(-1, 2)
        group = np.asarray(group)
        N = len(p)
        ub = np.full(N, np.inf) if ub is None else np.asarray(ub, float)
        out = np.full(N, np.inf)
        exact = np.zeros(N, bool)
        s = 0
        while s < N:            # batches end where a group ends, so a group is searched together
            e = min(s + batch, N)
            if e < N and group[e] == group[e - 1]:
                e = int(np.searchsorted(group, group[e - 1], side="left"))
                if e <= s:
                    e = int(np.searchsorted(group, group[s], side="right"))
            d, ok, _, lower = self._search(p[s:e, 0].copy(), p[s:e, 1].copy(), ub[s:e], group[s:e], thr,
                                           inside[s:e])
            out[s:e] = np.where(ok, np.where(inside[s:e], -d, d), lower)
            exact[s:e] = ok
            s = e
        return out, exact
