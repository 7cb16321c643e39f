"""Exact foot points and signed distances to a triangle mesh (Rajain et al. 2023 Eqs. (13), (19)).

Rajain et al. 2023 measures the tool against the reference surface Phi through foot points: the closest point
y_perp of a point y on Phi, its tangent plane, and the distance |y - y_perp| with a sign.  Phi is a
triangle mesh here, so the foot point is the exact closest point over all triangles.

* Candidates: a cKDTree over the vertices gives the ``k`` nearest vertices; the triangles around
  them are projected exactly (Ericson's region test, vectorised).  For query points near a fair
  mesh this already finds the closest triangle; ``exact=True`` then certifies every result: any
  triangle that could be closer has a centroid within d + R_max of the query (R_max = the largest
  centroid-to-corner distance), and all of those are tested.
* Sign: positive on the side the face normals point to (the tool's side, air), negative inside
  the material.  The sign uses the angle-weighted pseudo-normal of the feature the foot point
  lies on (face, edge or vertex), which is correct on closed meshes and on the interior of open
  patches (Baerentzen and Aanaes 2005).
* ``off_surface``: the point lies beyond the border of an open mesh (its foot is on a border edge or
  vertex and it is more than 10 deg off that feature's normal), where "distance to the surface" is
  distance to the patch's edge, not an error of the tool.
* ``gradient``: the unit vector (y - y_perp) / |y - y_perp| times the sign, i.e. the gradient of
  the signed distance, which is what the optimiser's analytic Jacobians need.
"""
import itertools
import math
import os
import threading

import numpy as np
from scipy.spatial import cKDTree

from .runs import ranks_in_runs
from .triangles import areas_normals, corner_cross, corners_angles

FACE, EDGE, VERTEX = 0, 1, 2


SLIVER = 1e-2     # a triangle lower than this fraction of its longest edge is a sliver (see closest_on_triangles)


def sliver_rows(A, B, C):
    """Whether each triangle ABC (n, 3 each) is a sliver: twice its area at most SLIVER x its longest edge squared
    (so every triangle of no area is one, a single point too)."""
    ab, ac, bc = B - A, C - A, C - B
    cross = np.cross(ab, ac)
    longest = np.maximum(np.maximum((ab * ab).sum(1), (ac * ac).sum(1)), (bc * bc).sum(1))
    return np.sqrt((cross * cross).sum(1)) <= SLIVER * longest


def closest_on_triangles(P, A, B, C, sliver=None):
    """Closest points on triangles ABC to points P, all (n, 3); returns (points (n, 3),
    barycentric (n, 3)).  Region tests of Ericson, Real-Time Collision Detection 5.1.5.

    Those tests decide between regions by the signs of differences of products; on a sliver (a very obtuse or
    thin triangle) a point near its long edge can land in the far corner's region by rounding (a point on the
    edge of a triangle 1e-7 of its length high came out up to 0.3 of that length away).  Slivers (``sliver``
    (n,) bool, default :func:`sliver_rows`; False: none) are measured as their plane inside the three edges
    instead."""
    px, py, pz = P[:, 0], P[:, 1], P[:, 2]
    ax, ay, az = A[:, 0], A[:, 1], A[:, 2]
    bx, by, bz = B[:, 0], B[:, 1], B[:, 2]
    cx, cy, cz = C[:, 0], C[:, 1], C[:, 2]
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    pbx, pby, pbz = px - bx, py - by, pz - bz
    d3 = abx * pbx + aby * pby + abz * pbz
    d4 = acx * pbx + acy * pby + acz * pbz
    cpx, cpy, cpz = px - cx, py - cy, pz - cz
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    n = len(P)
    # the first region that holds, in Ericson's order: vertex A, vertex B, edge AB, vertex C, edge AC,
    # edge BC, inside
    with np.errstate(divide="ignore", invalid="ignore"):
        conds = [(d1 <= 0) & (d2 <= 0), (d3 >= 0) & (d4 <= d3), (vc <= 0) & (d1 >= 0) & (d3 <= 0),
                 (d6 >= 0) & (d5 <= d6), (vb <= 0) & (d2 >= 0) & (d6 <= 0),
                 (va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0)]
        region = np.select(conds, np.arange(6), 6)
        u, v, w = np.zeros(n), np.zeros(n), np.zeros(n)
        m = region == 0
        u[m] = 1.0
        m = region == 1
        v[m] = 1.0
        m = np.flatnonzero(region == 2)
        if len(m):
            t = d1[m] / (d1[m] - d3[m])
            u[m], v[m] = 1 - t, t
        m = region == 3
        w[m] = 1.0
        m = np.flatnonzero(region == 4)
        if len(m):
            t = d2[m] / (d2[m] - d6[m])
            u[m], w[m] = 1 - t, t
        m = np.flatnonzero(region == 5)
        if len(m):
            t = (d4[m] - d3[m]) / ((d4[m] - d3[m]) + (d5[m] - d6[m]))
            v[m], w[m] = 1 - t, t
        m = np.flatnonzero(region == 6)
        if len(m):
            den = va[m] + vb[m] + vc[m]
            vv, ww = vb[m] / den, vc[m] / den
            u[m], v[m], w[m] = 1 - vv - ww, vv, ww
    Q = np.empty((n, 3))
    Q[:, 0] = u * ax + v * bx + w * cx
    Q[:, 1] = u * ay + v * by + w * cy
    Q[:, 2] = u * az + v * bz + w * cz
    bary = np.stack([u, v, w], axis=1)
    # slivers, and triangles of no area (repeated or collinear corners: 0 / 0 above), are measured again
    thin = () if sliver is False else np.flatnonzero(sliver_rows(A, B, C) if sliver is None else sliver)
    if len(thin):
        Q[thin], bary[thin] = _closest_on_sliver(P[thin], A[thin], B[thin], C[thin])
    return Q, bary


def _closest_on_sliver(P, A, B, C):
    """Closest points and barycentric coordinates on slivers ABC: the nearest of the three edges' closest points
    and, where the projection onto the plane falls inside (by the signs of the three sub-areas), the point of
    the triangle with the projection's barycentric coordinates.  Both are points of the triangle, measured
    directly: a sliver's computed normal may be poor (its cross product is small), which may cost accuracy
    inside, but never gives a point nearer than the triangle."""
    Q, bary = _closest_on_edges(P, A, B, C)
    n = np.cross(B - A, C - A)
    with np.errstate(divide="ignore", invalid="ignore"):
        n = n / np.sqrt((n * n).sum(1))[:, None]
        X = P - ((P - A) * n).sum(1)[:, None] * n
        areas = np.stack([(np.cross(B - X, C - X) * n).sum(1), (np.cross(C - X, A - X) * n).sum(1),
                          (np.cross(A - X, B - X) * n).sum(1)], axis=1)
        total = areas.sum(1)
        inside = np.flatnonzero(np.all(areas >= 0, axis=1) & (total > 0))
    if len(inside):
        w = areas[inside] / total[inside, None]
        Y = w[:, 0:1] * A[inside] + w[:, 1:2] * B[inside] + w[:, 2:3] * C[inside]
        nearer = ((P[inside] - Y) ** 2).sum(1) < ((P[inside] - Q[inside]) ** 2).sum(1)
        Q[inside[nearer]], bary[inside[nearer]] = Y[nearer], w[nearer]
    return Q, bary


def _closest_on_edges(P, A, B, C):
    """Closest points on the edges AB, BC, CA of triangles (all (n, 3)) and their barycentric coordinates."""
    corners = (A, B, C)
    best_d2 = np.full(len(P), np.inf)
    Q, bary = np.zeros((len(P), 3)), np.zeros((len(P), 3))
    for i, j in ((0, 1), (1, 2), (2, 0)):
        X, D = corners[i], corners[j] - corners[i]
        L2 = (D * D).sum(1)
        t = np.clip(((P - X) * D).sum(1) / np.where(L2 > 0, L2, 1.0), 0.0, 1.0)
        q = X + t[:, None] * D
        d2 = ((P - q) ** 2).sum(1)
        nearer = d2 < best_d2
        best_d2[nearer], Q[nearer] = d2[nearer], q[nearer]
        bary[nearer] = 0.0
        bary[nearer, i], bary[nearer, j] = 1.0 - t[nearer], t[nearer]
    return Q, bary


_POOL = {}
_POOL_LOCK = threading.Lock()
MEMO_ROWS = 50_000     # queries up to this many points are remembered for the next one (see TriangleMesh._candidates)


def _pool():
    """Two worker threads for blocks of foot-point queries, made on first use (and again in a forked child,
    which inherits the pool but not its threads)."""
    with _POOL_LOCK:
        if _POOL.get("pid") != os.getpid():
            from concurrent.futures import ThreadPoolExecutor

            _POOL.update(pid=os.getpid(), pool=ThreadPoolExecutor(max_workers=2, thread_name_prefix="foot-points"))
        return _POOL["pool"]


def _run_blocks(n, chunk, block, parallel):
    """block(slice) over n rows cut into blocks of at most ``chunk``; two threads share them if ``parallel``."""
    blocks = max(-(-n // chunk), 2 if parallel else 1)
    edges = [n * i // blocks for i in range(blocks + 1)]
    parts = [slice(edges[i], edges[i + 1]) for i in range(blocks)]
    if blocks == 1:
        block(parts[0])
    else:
        list(_pool().map(block, parts))


class TriangleMesh:
    """A triangle mesh prepared for foot-point queries.

    vertices (V, 3), faces (F, 3) int.  Degenerate (zero-area) faces are kept for distances but
    contribute nothing to the pseudo-normals."""

    def __init__(self, vertices, faces, k=4):
        V = np.ascontiguousarray(vertices, float)
        F = np.ascontiguousarray(faces, np.int64)
        if V.ndim != 2 or V.shape[1] != 3 or len(V) < 3 or not np.isfinite(V).all():
            raise ValueError(f"vertices must be (V >= 3, 3) finite numbers, got shape {V.shape}")
        if F.ndim != 2 or F.shape[1] != 3 or len(F) < 1 or F.min() < 0 or F.max() >= len(V):
            raise ValueError(f"faces must be (F >= 1, 3) vertex indices in 0..{len(V) - 1}")
        self.vertices, self.faces = V, F
        # the kd-tree holds the vertices of faces only: a vertex of no face has no candidates to offer
        used = np.unique(F)
        self._tree_vertices = None if len(used) == len(V) else used
        self.k = int(min(k, len(used)))
        corners = V.take(F, axis=0)                 # (F, 3, 3), gathered once for every per-face quantity below
        A, B, C = corners[:, 0], corners[:, 1], corners[:, 2]
        _, self.face_normals = areas_normals(corner_cross(A, B, C))
        self.centroids = (A + B + C) / 3
        corner = np.linalg.norm(np.stack([A, B, C]) - self.centroids, axis=2)
        self.face_radius = float(np.max(corner))
        self.face_radii = corner.max(axis=0) * (1 + 1e-12) + 1e-15 * float(np.abs(V).max())
        # the face's plane through its centroid, and how far its corners lie off it (zero up to the rounding of
        # the normal; what keeps the plane bound of _project a true bound for slivers).  The bound needs a unit
        # normal: where the cross product was too small for one (a zero-area face, or one so thin that its
        # squared length underflows), the normal is 0 and the bound is the centroid's sphere alone
        unit = self.face_normals.copy()
        unit[np.abs(np.linalg.norm(unit, axis=1) - 1.0) > 1e-12] = 0.0
        off_plane = np.abs(np.einsum("cfk,fk->cf", np.stack([A, B, C]) - self.centroids, unit))
        self.face_thickness = off_plane.max(axis=0) * (1 + 1e-12) + 1e-15 * float(np.abs(V).max())
        # one row per face of what a query gathers (one fancy index instead of eight: the gathers, not the
        # arithmetic, are what a candidate costs): centroid, unit normal, thickness, radius; and the corners
        self._face_rows = np.ascontiguousarray(np.c_[self.centroids, unit, self.face_thickness, self.face_radii])
        self._corner_rows = np.ascontiguousarray(np.c_[A, B, C])
        self._sliver = sliver_rows(A, B, C)
        self._any_sliver = bool(self._sliver.any())
        self._vtree = cKDTree(V if self._tree_vertices is None else V[used])
        self._near_memo = None            # the last query's nearest vertices and candidates, see _candidates
        self._near_lock = threading.Lock()
        self._ctree = None
        # vertex -> incident faces, padded with -1
        order = np.argsort(F.ravel(), kind="stable")
        vid = F.ravel()[order]
        counts = np.bincount(vid, minlength=len(V))
        width = int(counts.max())
        start = np.r_[0, np.cumsum(counts)[:-1]]
        slot = np.arange(len(vid)) - start[vid]
        self.vertex_faces = np.full((len(V), width), -1, np.int64)
        self.vertex_faces[vid, slot] = order // 3
        # angle-weighted pseudo-normals of vertices and (sum of the two faces') of edges
        ang = corners_angles(corners)
        vn = np.zeros_like(V)
        for c in range(3):
            np.add.at(vn, F[:, c], ang[:, c:c + 1] * self.face_normals)
        self.vertex_normals = vn / np.maximum(np.linalg.norm(vn, axis=1, keepdims=True), 1e-300)
        e = np.sort(np.c_[F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]].reshape(-1, 2), axis=1)
        key = e[:, 0] * len(V) + e[:, 1]
        uniq, inv = np.unique(key, return_inverse=True)
        en = np.zeros((len(uniq), 3))
        np.add.at(en, inv, np.repeat(self.face_normals, 3, axis=0))
        self._edge_keys = uniq
        self._edge_normals = en / np.maximum(np.linalg.norm(en, axis=1, keepdims=True), 1e-300)
        # border of an open mesh: edges of one face, and their vertices
        self._edge_border = np.bincount(inv, minlength=len(uniq)) == 1
        self.border_vertices = np.zeros(len(V), bool)
        be = uniq[self._edge_border]
        self.border_vertices[be // len(V)] = True
        self.border_vertices[be % len(V)] = True
        self.size = float(np.linalg.norm(V.max(0) - V.min(0)))
        self._coordinate_size = float(np.abs(V).max())

    # ------------------------------------------------------------------ queries
    def _exact(self, P, f):
        """Closest points, barycentric coordinates and squared distances of points P (m, 3) on faces f (m,)."""
        K = self._corner_rows.take(f, axis=0)      # take: a row gather 3x faster than fancy indexing
        Q, bary = closest_on_triangles(P, K[:, 0:3], K[:, 3:6], K[:, 6:9], self._any_sliver and self._sliver[f])
        return Q, bary, ((P - Q) ** 2).sum(1)

    def _project(self, P, cand, start=None, slack=None, moved=None):
        """Best of candidate faces cand (n, c) (-1 = none) for points P (n, 3): the least squared distance,
        the first candidate in a row's order among equals.  Returns foot (n, 3), barycentric coordinates
        (n, 3), face (n,), squared distance (n,), the column of the face (n,) and ``slack`` (n, c) (below).

        Candidates that cannot be the closest are not projected.  Split P - X for a point X of a face into its
        parts along the face's normal and in the face's plane: the first is at least |pd| - thickness (pd the
        distance of P from the plane through the centroid), the second at least |P' - c| - radius (P' the
        projection of P, c the centroid; the face lies within its radius of c).  A face whose bound exceeds
        ``reach``, the distance to the row's starting candidate (margins for rounding), is left out: near a
        smooth mesh about 3 of 16 candidates are projected.  The starting candidate is the nearest centroid,
        or the column ``start`` (n,) given.  Leaving out faces that cannot be the closest never changes the
        answer, the first least distance in the row's order.

        ``slack`` (n, c) out: a lower bound of how much farther each candidate is than the row's closest face
        (-inf where unknown): bound - reach, or for a projected face that is not a sliver its computed gap less
        a margin for rounding (:meth:`_gap_slack`).  Both the bound and the distance to a fixed face change by
        at most the move of P, so a row asked again at a point ``moved`` (n,) away from the last, starting from
        the face it found then, passes the last slack in: candidates whose slack exceeds twice the move are
        left out without a look, and the answer is that of a fresh query."""
        n, c = cand.shape
        valid = cand >= 0
        f = np.where(valid, cand, 0)
        at_row = np.arange(n)
        if start is None:
            g = self._face_rows.take(f, axis=0)
            wx, wy, wz = P[:, 0, None] - g[..., 0], P[:, 1, None] - g[..., 1], P[:, 2, None] - g[..., 2]
            w2 = wx * wx + wy * wy + wz * wz
            w2[~valid] = np.inf
            j0 = np.argmin(w2, axis=1)               # the nearest centroid: an upper bound to start from
        else:
            j0 = np.asarray(start)
            decay = (2.0 * moved * (1 + 1e-9) + 1e-12 * self.size)[:, None]
            look = valid & (slack <= decay)
            look[at_row, j0] = False                 # projected anyway
            li, lc = np.nonzero(look)
            g = self._face_rows.take(f[li, lc], axis=0)
            pl = P.take(li, axis=0)
            wx, wy, wz = pl[:, 0] - g[:, 0], pl[:, 1] - g[:, 1], pl[:, 2] - g[:, 2]
            w2 = wx * wx + wy * wy + wz * wz
        f0 = f[at_row, j0]
        Q0, bary0, d0 = self._exact(P, f0)
        ux, uy, uz = g[..., 3], g[..., 4], g[..., 5]
        pd = wx * ux + wy * uy + wz * uz
        qx, qy, qz = wx - pd * ux, wy - pd * uy, wz - pd * uz
        along = np.maximum(np.abs(pd) - g[..., 6], 0.0)
        across = np.maximum(np.sqrt(qx * qx + qy * qy + qz * qz) - g[..., 7], 0.0)
        r0 = np.sqrt(d0) * (1 + 1e-9) + 1e-12 * self.size
        lb2 = along * along + across * across
        if start is None:
            reach = r0[:, None] + 1e-13 * np.sqrt(w2)
            need = (lb2 <= reach * reach) & valid
            need[at_row, j0] = False                 # projected already
            slack_out = np.where(valid, np.sqrt(lb2) - reach, -np.inf)
            ri, ci = np.nonzero(need)
        else:
            reach = r0[li] + 1e-13 * np.sqrt(w2)
            slack_out = slack - decay
            slack_out[li, lc] = np.sqrt(lb2) - reach
            need = lb2 <= reach * reach
            ri, ci = li[need], lc[need]
        Pr, fr = P.take(ri, axis=0), f[ri, ci]
        Q, bary, dd = self._exact(Pr, fr)
        d2 = np.full((n, c), np.inf)
        d2[ri, ci] = dd
        d2[at_row, j0] = d0
        j = np.argmin(d2, axis=1)
        if len(ri):
            # a projected face's own distance is a far better bound than the plane-and-disc one: on a fine
            # mesh, the neighbours of the closest face are mostly within reach of the bound, never nearer
            self._gap_slack(slack_out, ri, ci, fr, dd, d2[at_row, j], Pr)
        if self._any_sliver:
            # every slack is measured against the row's closest face, the next query's start; a sliver's computed
            # distance can jump by more than the point moves (1e-10 for a move of 1e-15 on one 1e-9 high), so a
            # row whose closest face is a sliver looks at all its candidates next time
            slack_out[self._sliver[f[at_row, j]]] = -np.inf
        # (a NaN slack, from distances beyond the float range, would leave its face out for good)
        np.copyto(slack_out, -np.inf, where=np.isnan(slack_out))
        at = np.full((n, c), -1, np.int64)
        at[ri, ci] = np.arange(len(ri))
        k = at[at_row, j]
        first = k < 0                                # the row's starting face is its closest
        k = np.where(first, 0, k)
        if len(ri):
            Qb, bb = Q.take(k, axis=0), bary.take(k, axis=0)
            Qb[first], bb[first] = Q0[first], bary0[first]
        else:
            Qb, bb = Q0, bary0
        return Qb, bb, f[at_row, j], d2[at_row, j], j, slack_out

    def _gap_slack(self, slack, ri, ci, faces, dd, best, P):
        """Raise ``slack[ri, ci]`` of projected faces (squared distances dd) to their computed gap over the
        row's closest face (squared distance ``best`` (n,), the next query's start), less a margin.

        A remembered row leaves a face out while its slack exceeds twice the moves since (see :meth:`_project`),
        so the slack must stay below the true gap by more than the rounding of the distances of both faces, at
        this query and at the next: the margin is 1e-6 of the distances and of the face's size plus 1e-12 of
        the coordinates' size.  The rounding is far smaller: moving 200,000 random faces and points 1e3 and 1e5
        from the origin changed their computed distances by at most 3.4e-16 of the coordinates' size, on faces
        as thin as 1.1% of their longest edge (just thicker than a sliver).  Slivers (and faces of no area)
        keep the bound: their computed closest points may be far off (:func:`closest_on_triangles`)."""
        keep = ~self._sliver[faces]
        if not keep.any():
            return
        ri, ci, faces, P = ri[keep], ci[keep], faces[keep], P[keep]
        near = np.sqrt(best[ri])
        own = np.sqrt(dd[keep])
        noise = 1e-12 * (self.size + self._coordinate_size + np.abs(P).max(axis=1))
        gap = own - near - 1e-6 * (own + near + 2.0 * self.face_radii[faces]) - noise
        slack[ri, ci] = np.fmax(slack[ri, ci], gap)

    def _pseudo_normals(self, faces, bary):
        """Pseudo-normal of the feature (face / edge / vertex) a foot point lies on, and whether that
        feature is on the mesh's border."""
        tol = 1e-9
        on = bary > tol
        cnt = on.sum(1)
        out = self.face_normals.take(faces, axis=0)
        border = np.zeros(len(faces), bool)
        F = self.faces.take(faces, axis=0)
        vtx = cnt == 1
        if vtx.any():
            c = np.argmax(bary[vtx], axis=1)
            vid = F[vtx][np.arange(vtx.sum()), c]
            out[vtx] = self.vertex_normals[vid]
            border[vtx] = self.border_vertices[vid]
        edg = cnt == 2
        if edg.any():
            off = np.argmin(bary[edg], axis=1)            # the corner not on the edge
            Fe = F[edg]
            r = np.arange(edg.sum())
            p, q = Fe[r, (off + 1) % 3], Fe[r, (off + 2) % 3]
            key = np.minimum(p, q) * len(self.vertices) + np.maximum(p, q)
            e = np.searchsorted(self._edge_keys, key)
            out[edg] = self._edge_normals[e]
            border[edg] = self._edge_border[e]
        return out, border

    def foot_points(self, points, exact=False, chunk=4096):
        """Foot points of points (n, 3) on the mesh.

        Returns a dict: ``foot`` (n, 3), ``distance`` (n,) signed (+ on the normals' side),
        ``gradient`` (n, 3) unit gradient of the signed distance, ``normal`` (n, 3) pseudo-normal
        at the foot, ``face`` (n,).  exact=True certifies each foot against every triangle that
        could be closer (slower for points far from the mesh)."""
        P = np.asarray(points, float).reshape(-1, 3)
        if not np.isfinite(P).all():
            raise ValueError("foot_points: query points contain NaN or inf")
        n = len(P)
        foot, bary = np.empty((n, 3)), np.empty((n, 3))
        face, d2 = np.empty(n, np.int64), np.empty(n)
        with self._near_lock:          # the remembered candidates (see _candidates) belong to one query at a time
            try:
                self._closest(P, foot, bary, face, d2, chunk)
            except BaseException:
                self._near_memo = None        # a half-updated memory would mislead the next query
                raise
        if exact:
            self._certify(P, foot, bary, face, d2)
        diff = P - foot
        dist = np.sqrt(d2)
        pn, border = self._pseudo_normals(face, bary)
        sgn = np.where((diff * pn).sum(1) >= 0, 1.0, -1.0)
        grad = np.where(dist[:, None] > 1e-12 * max(self.size, 1e-300),
                        diff / np.where(dist > 0, dist, 1.0)[:, None] * sgn[:, None], pn)
        # beyond the border: the foot is on a border edge or vertex and the point is not above it
        # (more than 10 deg off the pseudo-normal), i.e. it projects outside the patch
        off = border & ((grad * pn).sum(1) < math.cos(math.radians(10.0)))
        return {"foot": foot, "distance": sgn * dist, "gradient": grad, "normal": pn, "face": face,
                "off_surface": off}

    def _nearest(self, P, k, workers=1):
        """Distances (m, k) and indices (m, k) of the k vertices (of faces) nearest to the points P (m, 3)."""
        d, i = self._vtree.query(P, k=k, workers=workers)
        d, i = np.reshape(d, (len(P), -1)), np.reshape(i, (len(P), -1))
        return d, (i if self._tree_vertices is None else self._tree_vertices[i])

    def _closest(self, P, foot, bary, face, d2, chunk):
        """Closest candidate faces of the points P (n, 3), into foot, bary, face, d2.  The caller holds
        ``_near_lock``.

        Every row is its own problem: blocks of rows give the same feet in any order, so a query with many new
        rows (each looks at all its candidates) is cut into blocks that two threads share (numpy and the
        kd-tree let go of the interpreter lock on arrays this long); rows that start from their last face (see
        :meth:`_candidates`) are cheap, and two threads would only wait for each other's many small steps."""
        n, k = len(P), self.k
        if n < 64 or n > MEMO_ROWS or k >= len(self._vtree.data):
            def block(r):
                cand = self._candidate_faces(self._nearest(P[r], k)[1])
                foot[r], bary[r], face[r], d2[r] = self._project(P[r], cand)[:4]

            _run_blocks(n, chunk, block, n >= 2048)
            return
        cand, start, slack, fresh = self._candidates(P, chunk)
        memo = self._near_memo
        moved = np.sqrt(((P - memo["last"]) ** 2).sum(1))

        def block(r):
            foot[r], bary[r], face[r], d2[r], start[r], slack[r] = self._project(
                P[r], cand[r], start=start[r], slack=slack[r], moved=moved[r])

        _run_blocks(n, chunk, block, fresh >= 2048)
        memo["last"][:] = P

    def _candidates(self, P, chunk):
        """Candidate faces of points P (n, 3) and where to start among them, for :meth:`_project`: the faces
        (n, c) around the ``k`` vertices nearest to each point (-1 padded, each row sorted), a starting column
        (n,) and the slack (n, c) of each candidate (-inf: look at it); and how many rows are new.  The
        caller holds ``_near_lock``.

        An optimiser asks for nearly the same points again and again, so each row remembers the point it was
        last queried at (q'), the distance d_k of its k-th and d_(k+1) of its next vertex, and its candidates.
        A point q within delta of q' has the same k nearest vertices while d_k + 2 delta < d_(k+1): every
        vertex of the set is within d_k + delta of q, every other at least d_(k+1) - delta away.  Such a row
        keeps its candidates, starts from the face it found last and passes on its slack.  The other rows ask
        the kd-tree again and start from their nearest centroid, looking at every candidate; a row whose k-th
        and next vertex are equally far asks for exactly k, as a query without the memory would (the set is
        what counts: its faces are sorted).  One query of up to :data:`MEMO_ROWS` points is remembered."""
        k, n = self.k, len(P)
        memo = self._near_memo
        if memo is not None and len(memo["ref"]) == n:
            delta = np.sqrt(((P - memo["ref"]) ** 2).sum(1))
            fresh = np.flatnonzero(~(memo["dk"] + 2.0 * delta < memo["dnext"] * (1 - 1e-9) - 1e-12 * self.size))
        else:
            memo = {"ref": P.copy(), "dk": np.empty(n), "dnext": np.empty(n), "cand": np.full((n, 0), -1, np.int64),
                    "last": P.copy(), "col": np.zeros(n, np.int64), "slack": np.full((n, 0), -np.inf)}
            fresh = np.arange(n)
        self._near_memo = None                 # until it is whole again
        for lo in range(0, len(fresh), chunk):
            rows = fresh[lo:lo + chunk]
            Pf = P[rows]
            d, i = self._nearest(Pf, k + 1, workers=-1 if len(rows) >= 2048 else 1)
            tie = np.flatnonzero(d[:, k - 1] == d[:, k])
            if len(tie):
                i[tie, :k] = self._nearest(Pf[tie], k)[1]
                d[tie, k] = d[tie, k - 1]            # never kept: the set is not unique there
            memo["ref"][rows], memo["dk"][rows], memo["dnext"][rows] = Pf, d[:, k - 1], d[:, k]
            cf = self._candidate_faces(i[:, :k])
            w = cf.shape[1]
            if w > memo["cand"].shape[1]:
                grown = np.full((n, w), -1, np.int64)
                grown[:, :memo["cand"].shape[1]] = memo["cand"]
                slack = np.full((n, w), -np.inf)
                slack[:, :memo["slack"].shape[1]] = memo["slack"]
                memo["cand"], memo["slack"] = grown, slack
            memo["cand"][rows] = -1
            memo["cand"][rows, :w] = cf
            memo["slack"][rows] = -np.inf
            # start from the nearest centroid
            c = self.centroids.take(np.where(cf >= 0, cf, 0), axis=0)
            w2 = ((Pf[:, None, :] - c) ** 2).sum(2)
            w2[cf < 0] = np.inf
            memo["col"][rows] = np.argmin(w2, axis=1)
        self._near_memo = memo
        return memo["cand"], memo["col"], memo["slack"], len(fresh)

    def _candidate_faces(self, vi):
        """The faces around the vertices vi (m, k) of each row, sorted, without repeats, packed left (-1 pads)."""
        cand = np.sort(self.vertex_faces[vi].reshape(len(vi), -1), axis=1)
        # drop repeated faces (shared by several of the k vertices) and pack the rest left
        dup = np.zeros(cand.shape, bool)
        dup[:, 1:] = cand[:, 1:] == cand[:, :-1]
        cand = np.where(dup, -1, cand)
        big = np.iinfo(np.int64).max
        cand = np.sort(np.where(cand < 0, big, cand), axis=1)
        width = int((cand < big).sum(1).max())
        return np.where(cand[:, :width] == big, -1, cand[:, :width])

    def _certify(self, P, foot, bary, face, d2):
        """Replace each foot (foot, bary, face, d2 of the points P, in place) by the closest point of any
        face that could be nearer: every face whose centroid is within the foot's distance plus the face's
        radius."""
        if self._ctree is None:
            self._ctree = cKDTree(self.centroids)
        radius = np.sqrt(d2) + self.face_radius * (1 + 1e-9) + 1e-12 * self.size
        lists = self._ctree.query_ball_point(P, radius)
        lens = np.fromiter(map(len, lists), np.int64, len(lists))
        flat = np.fromiter(itertools.chain.from_iterable(lists), np.int64, int(lens.sum()))
        offset = np.cumsum(lens) - lens
        todo = np.flatnonzero(lens > 0)
        todo = todo[np.argsort(lens[todo], kind="stable")]
        # batches of similar candidate counts, each a dense (n, c) array of <= ~200k pairs
        lo = 0
        while lo < len(todo):
            c = int(lens[todo[min(lo + 511, len(todo) - 1)]])
            idx = todo[lo:lo + max(1, min(512, 200_000 // max(c, 1)))]
            lo += len(idx)
            c = int(lens[idx].max())
            cand = np.full((len(idx), c), -1, np.int64)
            row = np.repeat(np.arange(len(idx)), lens[idx])
            col = ranks_in_runs(lens[idx])
            cand[row, col] = flat[np.repeat(offset[idx], lens[idx]) + col]
            Q, b, f, dd = self._project(P[idx], cand)[:4]
            better = dd < d2[idx]
            w = idx[better]
            foot[w], bary[w], face[w], d2[w] = Q[better], b[better], f[better], dd[better]

    def signed_distance(self, points, exact=False):
        """Signed distances (n,) of points (n, 3): + on the normals' side."""
        return self.foot_points(points, exact=exact)["distance"]
