"""Mesh -> rotor: helical axis, v0, handedness, transverse profile and flanks.

Kinematic fit in the manner of Pottmann & Randrup (1998): a helical surface
is invariant under a one-parameter screw motion, so the velocity field
v(p) = cbar + c x p of that motion is tangent to the surface everywhere:

    v(p_f) . n_f = cbar . n_f + c . (p_f x n_f) = 0     for every face f.

With |c| = 1 this is a smallest-eigenvalue problem in R^6 (solved on the
3x3 Schur complement after eliminating cbar).  The motion gives the axis
direction d = c, the axis point c x cbar and the signed parameter
k = c . cbar: |k| = v0 and sign(k) is the handedness (Bizzarri, Bo & Bartoň Eq. (1): right
turns +t about d while advancing +v0 t along d).  Planar end faces and
other non-helical parts (k != 0 is impossible for them) are removed by
iterative trimming; coaxial shaft cylinders fit every coaxial screw and
do no harm.

The profile is taken from the *vertices* (exact surface samples) screwed
back into the plane z = 0 of the rotor frame, ordered along a
connectivity-based slice of the mesh at mid body, so triangle sag does not
enter the profile.
"""
import copy
import os
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from .profile import ProfileError, SplineProfile, signed_area
from .rows import unique_rows
from .screw import MIN_PITCH_RATIO, hand_name, rotate2d, screw_to_plane
from .triangles import face_cross as _face_cross

RESIDUAL_THRESHOLD = 1e-3   # RMS distance of the helical vertices from the fitted surface, in outer radii
TANGENCY_THRESHOLD = 0.05   # RMS sin(angle between screw velocity and vertex normal): gross pre-check
MIN_HELICAL_AREA = 0.3      # fraction of the mesh area that must be helical
MIN_EIGEN_SEPARATION = 1e3  # second / first eigenvalue of the screw fit; below: motion not unique
MIN_AXIAL_NORMAL = 0.03     # RMS axial component of the fitting faces' normals; below: no face fixes the pitch
FACE_PITCH_AGREEMENT = 0.3  # the faces' own advance k within this fraction of the fitted one
FACE_TANGENCY = 0.3         # sine of the angle a face normal may make with the normal plane of the screw
END_FACE_AXIAL = 0.99       # faces whose normal's axial component is above this are end faces, not flank


class NotHelicalError(ValueError):
    """The mesh is not (mostly) a helical surface; the message quotes the measured value and the limit."""


@dataclass
class RotorAnalysis:
    axis_point: np.ndarray       # (3,) model frame, on the axis at the rotor-frame origin
    axis_direction: np.ndarray   # (3,) unit
    v0: float                    # axial advance per radian, model units
    handedness: str
    residual: float              # RMS distance of helical vertices from the fitted surface / outer radius
    threshold: float
    to_world: np.ndarray         # (4, 4) rotor frame -> model frame (rigid)
    profile: np.ndarray          # (K, 2) CCW transverse profile at z = 0 of the rotor frame
    flanks: list                 # [[i_start, i_end], ...] inclusive, indices modulo K
    outer_radius: float
    lobes: int
    helical_area_fraction: float
    body_z: tuple                # axial extent of the helical body in the rotor frame
    tangency_residual: float = 0.0   # RMS sin(angle) between screw velocity and vertex normals
    surface: object = field(repr=False, default=None)
    mesh_repairs: dict = field(default_factory=dict)   # what :func:`weld_mesh` merged, dropped or found
    shafts: list = field(default_factory=list)   # [{"z_range": [a, b], "radius": r}] beyond the body (rotor frame)
    content_key: str = None      # SHA-256 of the mesh, options and code it was made from (see analyze_mesh)

    def to_record(self):
        """Everything the analysis holds, as JSON-able values (floats round-trip exactly through JSON), with the
        content key of the mesh it was made from: :func:`analyze_mesh` (``known=``) takes it back instead of
        analysing that same mesh again."""
        return {"record": "flank-rotor-analysis/1", "key": self.content_key,
                "axis_point": self.axis_point.tolist(), "axis_direction": self.axis_direction.tolist(),
                "v0": float(self.v0), "handedness": self.handedness, "residual": float(self.residual),
                "threshold": float(self.threshold), "tangency_residual": float(self.tangency_residual),
                "to_world": np.asarray(self.to_world, float).tolist(),
                "profile": np.asarray(self.profile, float).tolist(),
                "flanks": [[int(i), int(j)] for i, j in self.flanks], "outer_radius": float(self.outer_radius),
                "lobes": int(self.lobes), "helical_area_fraction": float(self.helical_area_fraction),
                "body_z": [float(z) for z in self.body_z], "mesh_repairs": dict(self.mesh_repairs),
                "shafts": [dict(sh) for sh in self.shafts]}

    @classmethod
    def from_record(cls, rec):
        """The analysis of a :meth:`to_record` dict (its surface made again from the profile)."""
        from .helical_surface import shared_surface

        if not isinstance(rec, dict) or rec.get("record") != "flank-rotor-analysis/1":
            raise ValueError("not a rotor analysis record (flank-rotor-analysis/1)")
        prof = np.array(rec["profile"], float)
        a = cls(axis_point=np.array(rec["axis_point"], float), axis_direction=np.array(rec["axis_direction"], float),
                v0=rec["v0"], handedness=rec["handedness"], residual=rec["residual"], threshold=rec["threshold"],
                tangency_residual=rec["tangency_residual"], to_world=np.array(rec["to_world"], float), profile=prof,
                flanks=[list(f) for f in rec["flanks"]], outer_radius=rec["outer_radius"], lobes=rec["lobes"],
                helical_area_fraction=rec["helical_area_fraction"], body_z=tuple(rec["body_z"]),
                mesh_repairs=dict(rec["mesh_repairs"]), shafts=[dict(sh) for sh in rec["shafts"]],
                content_key=rec.get("key"))
        a.surface = shared_surface(SplineProfile(prof), a.v0, a.handedness)
        return a

    def extent(self):
        """The finite rotor in its rotor frame, as flank-plan/1's optional ``rotor.extent``: the helical
        body's z range (:attr:`body_z`) and the coaxial shafts beyond its end faces (:func:`shaft_cylinders`)."""
        return {"z_range": [float(self.body_z[0]), float(self.body_z[1])],
                "shafts": [{"z_range": list(s["z_range"]), "radius": s["radius"]} for s in self.shafts]}

    def flank_ranges(self):
        """The flanks' profile parameter ranges (u_start, u_end) on :attr:`surface`'s profile."""
        from .flank_feet import flank_u_ranges
        return flank_u_ranges(self.surface.profile, [(int(i), int(j)) for i, j in self.flanks])

    def to_dict(self):
        return {
            "axis_point": self.axis_point.tolist(),
            "axis_direction": self.axis_direction.tolist(),
            "v0": self.v0,
            "pitch": 2 * np.pi * self.v0,
            "handedness": self.handedness,
            "residual": self.residual,
            "residual_threshold": self.threshold,
            "residual_unit": "outer radius",
            "tangency_residual": self.tangency_residual,
            "to_world": self.to_world.tolist(),
            "outer_radius": self.outer_radius,
            "lobes": self.lobes,
            "flanks": self.flanks,
            "flank_count": len(self.flanks),
            "mesh_repairs": dict(self.mesh_repairs),
            "helical_area_fraction": self.helical_area_fraction,
            "body_z": list(self.body_z),
            "shafts": [dict(s) for s in self.shafts],
            "profile_points": len(self.profile),
        }

    def to_rotor_frame(self, points):
        inv = np.linalg.inv(self.to_world)
        p = np.asarray(points, float)
        return p @ inv[:3, :3].T + inv[:3, 3]

    def vertex_curvature(self, verts):
        """Gaussian curvature and class (+1 elliptic, 0 parabolic, -1 hyperbolic) at mesh vertices.

        Vertices are screwed into z = 0 and matched to the nearest profile
        parameter; off-surface vertices (caps, shafts) get their nearest
        profile point's values.
        """
        prof = self.surface.profile
        n = max(4096, 8 * len(self.profile))
        us = prof.params(n)
        tree = cKDTree(prof.eval(us))
        q0 = screw_to_plane(self.to_rotor_frame(verts), self.v0, self.handedness)
        _, idx = tree.query(q0)
        K = self.surface.curvatures(us)["K"][idx]
        cls = self.surface.classify(us)[idx]
        return K, cls


def weld_mesh(verts, faces):
    """Merge vertices at exactly the same position (an STL stores every triangle with its own three)
    and drop faces that collapse or have no area; count edges shared by more than two faces.

    verts (N, 3), faces (M, 3) -> (verts (N', 3), faces (M', 3), repairs dict with
    ``merged_vertices``, ``dropped_faces`` and ``nonmanifold_edges``)."""
    return _weld(verts, faces)[:3]


def _weld(verts, faces):
    """:func:`weld_mesh`, and the kept faces' edge cross products (for :func:`vertex_normals`)."""
    _check_triangles(verts, faces)
    v, inverse = unique_rows(verts)
    f = inverse.reshape(-1)[faces]
    cr = _face_cross(v, f)
    keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2]) & (np.linalg.norm(cr, axis=1) > 0)
    if not keep.all():
        f, cr = f[keep], cr[keep]
    a = np.ascontiguousarray(f.T)
    b = np.roll(a, -1, axis=0)                    # the edges (0, 1), (1, 2), (2, 0) of every face
    edges = np.sort((np.minimum(a, b) * np.int64(len(v)) + np.maximum(a, b)).ravel(), kind="stable")  # a key each
    # an edge of more than two faces: a key equal to the one two places on; counted once per edge
    crowded = edges[2:][edges[2:] == edges[:-2]]
    nonmanifold = int(np.count_nonzero(crowded[1:] != crowded[:-1]) + (len(crowded) > 0))
    return v, f, {"merged_vertices": int(len(verts) - len(v)), "dropped_faces": int((~keep).sum()),
                  "nonmanifold_edges": nonmanifold}, cr


def _check_triangles(verts, faces):
    verts, faces = np.asarray(verts), np.asarray(faces)
    if verts.ndim != 2 or verts.shape[1] != 3 or faces.ndim != 2 or faces.shape[1] != 3:
        raise ValueError(f"a triangle mesh needs vertices (N, 3) and faces (M, 3), got {verts.shape} and "
                         f"{faces.shape}")


def vertex_normals(verts, faces, face_cross=None):
    """Area-weighted vertex normals and vertex areas (a third of the incident triangle areas).

    A vertex sits symmetrically inside its fan of triangles, so chord
    errors of long triangles cancel to first order; face normals at
    centroids would bias the pitch by ~0.1 % on meshes with coarse axial
    rings.  ``face_cross``: the faces' edge cross products, where the caller has them.
    """
    _check_triangles(verts, faces)
    v = np.asarray(verts, float)
    f = np.asarray(faces, int)
    cr = _face_cross(v, f) if face_cross is None else face_cross
    area = np.linalg.norm(cr, axis=1) / 2
    idx = f.ravel()
    n = len(v)
    vn = np.stack([np.bincount(idx, np.repeat(cr[:, c], 3), minlength=n) for c in range(3)], -1)
    va = np.bincount(idx, np.repeat(area / 3, 3), minlength=n)
    ln = np.linalg.norm(vn, axis=1)
    ok = ln > 0
    vn[ok] /= ln[ok, None]
    va[~ok] = 0.0
    return vn, va


def axis_screw_velocity(points, d, a, k):
    """The velocity k d + d x (x - a) of the screw motion (unit axis d through a, advance k per radian) at
    points x (N, 3): ``k * d + np.cross(d, points - a)`` bit for bit (the same products and differences, in
    2/3 of the time; the mesh analysis asks for it at every vertex 15 times)."""
    q, kd = points - a, k * d
    vel = np.empty_like(q)
    vel[:, 0] = kd[0] + (d[1] * q[:, 2] - d[2] * q[:, 1])
    vel[:, 1] = kd[1] + (d[2] * q[:, 0] - d[0] * q[:, 2])
    vel[:, 2] = kd[2] + (d[0] * q[:, 1] - d[1] * q[:, 0])
    return vel


def face_advance(points, faces, face_cross, d, a, k, max_faces=20000):
    """What the faces' own normals say about the advance k of the screw (unit axis d through a).

    A helical surface's normal n obeys k (n . d) = -(d x (x - a)) . n, so only faces whose normals have
    an axial component fix k.  The vertex-normal fit cannot see that: at a prism's rims the vertex
    normals lean towards the end caps and give some k, while the prism's sides are tangent to every
    screw about the axis.  Over the faces tangent to the fitted screw (sine of the angle between the
    face normal and the screw velocity at the centroid at most ``FACE_TANGENCY``; at most ``max_faces``
    faces, evenly strided), returns the RMS axial component of their normals and the area-weighted
    least-squares k of that relation, or None when no face is tangent.  The bound is loose because a
    coarse mesh's face normals are off by its chord angle (0.08 to 0.17 on a 48 x 6 rotor mesh); end faces
    (normal within ``END_FACE_AXIAL`` of the axis) are left out, since on a short lead their sine, k /
    |velocity|, falls inside it.  On a screw rotor the two k agree to 25 % (short leads, lead = outer
    radius) or better; on a cylinder or prism only the sides remain, which are parallel to the axis.
    """
    stride = max(1, -(-len(faces) // max_faces))
    f, cr = faces[::stride], face_cross[::stride]
    length = np.linalg.norm(cr, axis=1)
    n = cr / length[:, None]
    turn = axis_screw_velocity((points[f[:, 0]] + points[f[:, 1]] + points[f[:, 2]]) / 3.0, d, a, 0.0)
    vel = turn + k * d
    sine = np.abs(np.einsum("ij,ij->i", vel, n)) / np.maximum(np.linalg.norm(vel, axis=1), 1e-300)
    # faces square to the axis are end faces: a screw surface's normal leans off the axis by k / |velocity|,
    # and end faces would pass the loose bound on a short lead (k / R = 0.16 at lead = R) and say k = 0
    fits = (sine <= FACE_TANGENCY) & (np.abs(n @ d) <= END_FACE_AXIAL)
    if not fits.any():
        return None
    axial, w = n[fits] @ d, length[fits]
    squares = float(np.sum(w * axial ** 2))
    rms = float(np.sqrt(squares / np.sum(w)))
    if squares <= 0.0:
        return rms, 0.0
    return rms, float(-np.sum(w * axial * np.einsum("ij,ij->i", turn[fits], n[fits])) / squares)


def _check_face_advance(advance, k, scale, quote):
    """Refuse a mesh whose faces do not fix the fitted advance k (:func:`face_advance`'s answer)."""
    if advance is None:
        raise NotHelicalError(f"not a helical surface: no face is tangent to the fitted screw motion (sine of the "
                              f"angle above {FACE_TANGENCY:g} everywhere; {quote})")
    axial, face_k = advance
    if axial < MIN_AXIAL_NORMAL:
        raise NotHelicalError(
            f"not a helical rotor: the faces that fit the screw motion are parallel to its axis (RMS axial "
            f"component of their normals {axial:.3g} < {MIN_AXIAL_NORMAL:g}), so every pitch fits them: "
            f"a cylinder or prism ({quote})")
    if not abs(face_k / k - 1.0) <= FACE_PITCH_AGREEMENT:
        raise NotHelicalError(
            f"not a helical rotor: the pitch is not determined; the faces' normals give v0 = "
            f"{abs(face_k) * scale:.3g}, the vertex normals v0 = {abs(k) * scale:.3g} (they must agree "
            f"within {FACE_PITCH_AGREEMENT:.0%}): a cylinder or prism? ({quote})")


def fit_screw_motion(points, normals, weights, moments=None):
    """Weighted least-squares screw motion tangent to the given surface elements.

    Returns (d, axis_point, k, eigenvalues) with |d| = 1 and k the signed
    advance per radian; points are assumed centred and scaled to ~1.  ``moments``:
    ``np.cross(points, normals)``, where the caller fits the same elements again with other weights.
    """
    m = np.cross(points, normals) if moments is None else moments
    w = weights / weights.sum()
    nw = normals * w[:, None]
    Mnn = nw.T @ normals
    Mnm = nw.T @ m
    Mmm = (m * w[:, None]).T @ m
    S = Mmm - Mnm.T @ np.linalg.pinv(Mnn) @ Mnm
    evals, evecs = np.linalg.eigh(S)
    c = evecs[:, 0]
    cbar = -np.linalg.pinv(Mnn) @ Mnm @ c
    k = float(c @ cbar)
    axis_point = np.cross(c, cbar)
    return c, axis_point, k, evals


def slice_loops(verts, faces, origin, normal):
    """Closed polylines of the mesh cut by a plane, chained by mesh connectivity."""
    v = np.asarray(verts, float)
    f = np.asarray(faces, int)
    s = (v - origin) @ normal
    s = np.where(s == 0, 1e-30, s)  # keep vertices off the plane
    sf = s[f]
    signs = np.sign(sf).sum(axis=1)
    fc = f[(signs != 3) & (signs != -3)]
    seg_keys, hits = [], []
    for e0, e1 in ((0, 1), (1, 2), (2, 0)):
        a, b = fc[:, e0], fc[:, e1]
        hits.append(np.sign(s[a]) != np.sign(s[b]))
        seg_keys.append(np.sort(np.stack([a, b], 1), axis=1))
    keys, hit = np.stack(seg_keys, 1), np.stack(hits, 1)  # (F, 3 edges, 2), (F, 3 edges)
    # a face the plane crosses has two cut edges: each face's pair of them, in edge order
    two = np.flatnonzero(hit.sum(axis=1) == 2)
    first, second = np.argmax(hit[two], axis=1), 2 - np.argmax(hit[two, ::-1], axis=1)
    pairs = zip(map(tuple, keys[two, first].tolist()), map(tuple, keys[two, second].tolist()))
    adj = {}
    for a, b in pairs:
        adj.setdefault(a, []).append(b)
        adj.setdefault(b, []).append(a)
    seen = set()
    loops = []
    for start in adj:
        if start in seen:
            continue
        loop = [start]
        seen.add(start)
        prev, cur = None, start
        while True:
            nxt = [n for n in adj[cur] if n != prev and n not in seen]
            if not nxt:
                break
            prev, cur = cur, nxt[0]
            seen.add(cur)
            loop.append(cur)
        if len(loop) >= 3:
            e = np.array(loop)
            sa, sb = s[e[:, 0]], s[e[:, 1]]
            t = sa / (sa - sb)
            loops.append(v[e[:, 0]] + t[:, None] * (v[e[:, 1]] - v[e[:, 0]]))
    return loops


def _frame(d, origin):
    ref = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = ref - (ref @ d) * d
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = e1, e2, d, origin
    return T


def _candidate_segments(loop2d, pts2d):
    """The segments (start a, vector, length) of a closed polyline and, per point, the 8 (or fewer) whose
    midpoints are nearest, with the distances to those midpoints: the candidates of its projection."""
    a = loop2d
    b = np.roll(loop2d, -1, axis=0)
    seg = b - a
    L = np.linalg.norm(seg, axis=1)
    tree = cKDTree(0.5 * (a + b))
    k = min(8, len(a))
    mid_d, cand = tree.query(pts2d, k=k, workers=-1 if len(pts2d) >= 4096 else 1)
    return a, seg, L, cand.reshape(len(pts2d), k), mid_d.reshape(len(pts2d), k)


def _projection(a, seg, L, i, pts2d):
    """(t, distance) of each point's projection onto its segment i (t in [0, 1] along it)."""
    t = np.clip(np.einsum("ij,ij->i", pts2d - a[i], seg[i]) / np.maximum(L[i] ** 2, 1e-300), 0, 1)
    proj = a[i] + t[:, None] * seg[i]
    return t, np.linalg.norm(pts2d - proj, axis=1)


def _nearest_projection(a, seg, L, cand, mid_d, pts2d):
    """(distance, segment, t) of each point's nearest projection onto its candidate segments (the first of the
    nearest on a tie, in the candidates' order).

    A segment lies within half its length of its midpoint, so a candidate whose midpoint is farther than
    that beyond the nearest projection so far cannot win; it is not projected (on a fine polyline most
    points need two or three projections, not eight).  The answer is the same: the margin, 1e-12 of the
    coordinates, covers the rounding of both distances many times over."""
    n = len(pts2d)
    best_d, best_i, best_t = np.full(n, np.inf), np.zeros(n, np.intp), np.zeros(n)
    size = float(np.fmax.reduce(np.abs(pts2d), axis=None, initial=0.0)) + float(
        np.fmax.reduce(np.abs(a), axis=None, initial=0.0))
    margin = 1e-12 * size
    # the margin is relative: it holds while squared lengths are normal floats (no underflow, no overflow)
    nonzero = L[L > 0]
    prune = size < 1e140 and (not len(nonzero) or float(nonzero.min()) > 1e-140)
    rows = np.arange(n)
    for j in range(cand.shape[1]):
        if j and prune:
            rows = np.flatnonzero(mid_d[:, j] - 0.5 * L[cand[:, j]] <= best_d + margin)
        i = cand[rows, j]
        t, dist = _projection(a, seg, L, i, pts2d[rows])
        better = dist < best_d[rows]
        won = rows[better]
        best_d[won], best_i[won], best_t[won] = dist[better], i[better], t[better]
    return best_d, best_i, best_t


def _order_along(loop2d, pts2d):
    """Arc-length parameter of each point's projection onto a closed polyline (and the polyline's length,
    and each point's distance): the nearest projection onto the 8 segments whose midpoints are nearest."""
    a, seg, L, cand, mid_d = _candidate_segments(loop2d, pts2d)
    cum = np.concatenate([[0.0], np.cumsum(L)])
    best_d, i, t = _nearest_projection(a, seg, L, cand, mid_d, pts2d)
    best_s = np.where(np.isfinite(best_d), cum[i] + t * L[i], 0.0)
    return best_s, cum[-1], best_d


def _within_of_polyline(loop2d, pts2d, tol):
    """``_order_along(loop2d, pts2d)[2] <= tol``, the same answer for every point, about twice as fast: that
    distance is the least over the candidate segments, so a point within ``tol`` of its nearest candidate
    needs no other; only the rest go through all of them."""
    a, seg, L, cand, mid_d = _candidate_segments(loop2d, pts2d)
    _, d0 = _projection(a, seg, L, cand[:, 0], pts2d)
    within = d0 <= tol
    rest = np.flatnonzero(~within)
    if len(rest):
        within[rest] = _nearest_projection(a, seg, L, cand[rest], mid_d[rest], pts2d[rest])[0] <= tol
    return within


def prominent_peaks(x, min_prominence):
    """Indices of the local maxima of x (N,) whose prominence is at least ``min_prominence``: what
    scipy.signal.find_peaks(x, prominence=min_prominence, plateau_size=1) returns (a flat top counts once,
    at its middle; the prominence is the peak's height above the higher of the lowest points on either side
    before a strictly higher sample), without importing scipy.signal (about 0.7 s)."""
    x = np.asarray(x, float)
    n = len(x)
    peaks = []
    i = 1
    while i < n - 1:
        if x[i - 1] < x[i]:
            j = i + 1
            while j < n - 1 and x[j] == x[i]:
                j += 1
            if x[j] < x[i]:
                peaks.append((i + j - 1) // 2)
                i = j
        i += 1
    keep = []
    for p in peaks:
        higher = np.flatnonzero(x[:p] > x[p])
        left_min = x[(higher[-1] + 1 if len(higher) else 0):p + 1].min()
        higher = np.flatnonzero(x[p + 1:] > x[p])
        right_min = x[p:(p + 1 + higher[0] if len(higher) else n)].min()
        if min_prominence <= x[p] - max(left_min, right_min):
            keep.append(p)
    return np.array(keep, dtype=np.intp)


def body_mask_all(keep, normals, d):
    """Vertices that fit the screw and are not on shafts (normals with an axial component)."""
    return keep & (np.abs(normals @ d) > 0.05)


def _refine_pitch(spline, verts_level, v0, hand, outer, n_use=20000):
    """1-D refinement of v0: exact surface vertices far from the profile level, screwed back with the
    right pitch, lie on the profile; minimise their mean squared distance to it (Brent).

    The vertex-normal fit leaves ~1e-5 relative pitch error on coarse meshes; positions of exact
    vertices pin it down far better because the error grows with the axial distance.
    """
    from scipy.optimize import minimize_scalar

    z = verts_level[:, 2]
    far = np.abs(z) > 0.25 * (np.ptp(z) if len(z) else 0.0)
    pts = verts_level[far]
    if len(pts) < 50:
        return v0
    if len(pts) > n_use:
        pts = pts[np.random.default_rng(0).choice(len(pts), n_use, replace=False)]
    poly = spline.sample(max(20000, 8 * len(spline.points)))
    tree = cKDTree(poly)

    def cost(x):
        # every point's nearest sample on its own: both cores give the same distances
        d, _ = tree.query(screw_to_plane(pts, x, hand), workers=-1 if len(pts) >= 4096 else 1)
        return float(np.mean(np.minimum(d, 0.01 * outer) ** 2))

    res = minimize_scalar(cost, bounds=(v0 * (1 - 2e-3), v0 * (1 + 2e-3)), method="bounded",
                          options={"xatol": 1e-11 * v0})
    return float(res.x) if res.fun <= cost(v0) else v0


def _profile_distances(spline, verts_level, v0, hand, n_use=50000):
    """Distances of helical vertices (level frame), screwed into the level plane, to the profile."""
    pts = verts_level
    if len(pts) > n_use:
        pts = pts[np.random.default_rng(1).choice(len(pts), n_use, replace=False)]
    poly = spline.sample(max(20000, 8 * len(spline.points)))
    _, _, dist = _order_along(poly, screw_to_plane(pts, v0, hand))
    return dist


def split_flanks(profile, min_prominence=0.05):
    """Lobe tips (radius maxima) and valley bottoms (radius minima) -> flank index ranges.

    Every valley between neighbouring lobes contributes two flanks: tip ->
    bottom and bottom -> next tip.  Ranges are inclusive index pairs
    [i_start, i_end] with i_start < i_end, indices taken modulo len(profile).
    """
    r = np.linalg.norm(profile, axis=1)
    n = len(r)
    span = float(r.max() - r.min())
    if span <= 1e-9 * r.max():
        return [], 0
    ext = np.concatenate([r, r, r])
    peaks = prominent_peaks(ext, min_prominence * span)
    tips = sorted({int(p) % n for p in peaks if n <= p < 2 * n})
    if len(tips) < 2:
        return [], len(tips)
    flanks = []
    for a, b in zip(tips, tips[1:] + [tips[0] + n]):
        seg = np.arange(a, b + 1)
        bottom = int(seg[np.argmin(r[seg % n])])
        flanks.append([a, bottom])
        flanks.append([bottom, b])
    return flanks, len(tips)


def body_extent(profile, points, v0, hand, interior, tol):
    """Axial extent (z0, z1) of the helical body: the z range of the vertices that lie on the helical surface.

    The screw fit trims the vertices of the end rings (their normals lean towards the end faces), so the
    fitted vertices' range ``interior`` stops short of the end faces; a vertex's position is exact, though,
    so every vertex within ``tol`` of the surface (screwed into z = 0, its distance to ``profile``) counts,
    as long as the candidates continue the interior range without a gap wider than 3x the widest gap
    inside it (a shaft vertex that happens to lie on the surface further out does not extend the body)."""
    p = np.asarray(points, float)
    poly = profile.sample(max(20000, 8 * len(profile.points)))
    z = np.sort(p[_within_of_polyline(poly, screw_to_plane(p, v0, hand), tol), 2])
    lo, hi = float(interior[0]), float(interior[1])
    inside = z[(z >= lo) & (z <= hi)]
    gap = 3.0 * float(np.max(np.diff(inside))) if len(inside) > 1 else 0.0
    gap = max(gap, 1e-6 * float(np.max(np.hypot(p[:, 0], p[:, 1]))))
    for k in range(np.searchsorted(z, lo) - 1, -1, -1):
        if lo - z[k] > gap:
            break
        lo = float(z[k])
    for k in range(np.searchsorted(z, hi, side="right"), len(z)):
        if z[k] - hi > gap:
            break
        hi = float(z[k])
    return lo, hi


def shaft_cylinders(points, z0, z1, tol):
    """Coaxial cylinders bounding the mesh beyond the helical body's end faces (journals, stubs, couplings).

    points: (N, 3) vertices in the rotor frame; z0 < z1: the body's extent.  Every vertex farther than
    ``tol`` beyond an end face belongs to that end's shaft; each end gives one cylinder from the farthest
    such vertex to the end face, with the largest distance from the axis as its radius (a stepped shaft is
    bounded by its largest step).  Returns [{"z_range": [a, b], "radius": r}, ...] (below z0, then above z1).
    """
    p = np.asarray(points, float)
    rho = np.hypot(p[:, 0], p[:, 1])
    out = []
    for side in (p[:, 2] < z0 - tol, p[:, 2] > z1 + tol):
        if not side.any() or not rho[side].max() > tol:
            continue
        z = p[side, 2]
        a, b = (float(z.min()), float(z0)) if z.max() < z0 else (float(z1), float(z.max()))
        out.append({"z_range": [a, b], "radius": float(rho[side].max())})
    return out


CACHE_SIZE = 4                     # analyses kept in memory, by the content of the mesh
_CACHE = {}                        # key -> RotorAnalysis (oldest first)
CACHE_DIR_ENV = "FLANK_CACHE_DIR"  # a directory: analyses are also kept there, one small .npz file each


def _cache_key(verts, faces, n_profile, threshold):
    """SHA-256 of the mesh's numbers, the options and the analysing code's own source."""
    import hashlib
    import os

    h = hashlib.sha256()
    here = os.path.dirname(os.path.abspath(__file__))
    for name in ("rotor_analysis.py", "profile.py", "rows.py", "screw.py", "helical_surface.py"):
        try:
            with open(os.path.join(here, name), "rb") as fh:
                h.update(fh.read())
        except OSError:
            return None
    h.update(np.ascontiguousarray(verts, np.float64).tobytes())
    h.update(np.ascontiguousarray(faces, np.int64).tobytes())
    h.update(repr((verts.shape, faces.shape, int(n_profile), float(threshold))).encode())
    return h.hexdigest()


def _to_npz(a, path):
    """The disk cache's file of an analysis: its :meth:`RotorAnalysis.to_record`, written whole or not at all."""
    import json
    import os

    tmp = path + ".tmp.npz"
    np.savez(tmp, record=np.array(json.dumps(a.to_record())))
    os.replace(tmp, path)


def _from_npz(path):
    import json

    with np.load(path) as z:
        return RotorAnalysis.from_record(json.loads(str(z["record"])))


def analyze_mesh(verts, faces, n_profile=2048, threshold=RESIDUAL_THRESHOLD, known=None, known_at=None,
                 progress=None):
    """Estimate the helical motion of a rotor mesh and extract its profile and flanks.

    Args:
        verts: (N, 3) vertex coordinates in any placement and unit.
        faces: (M, 3) triangle indices.
        n_profile: points of the resampled transverse profile (>= 720).
    Raises:
        NotHelicalError with the measured residual / ratio and its limit.

    The analysis of a mesh is kept by the SHA-256 of its numbers, the options and the analysing code (the
    last :data:`CACHE_SIZE` in memory; with the environment variable ``FLANK_CACHE_DIR`` naming a
    directory, also there across runs): the same mesh again returns an equal copy at once (a mesh hashes in
    about 1/50 of its analysis).  ``known``: a :meth:`RotorAnalysis.to_record` kept with the mesh (Blender
    stores it on the object); it is taken instead of analysing when its key is this mesh's, so a rotor
    analysed in an earlier session is not analysed again.  A record of another mesh (or of other options or
    code) is ignored.  ``known_at`` = (vertices, motion): the record was made from this mesh with these
    vertices (the same faces), and the 4 x 4 ``motion`` moves them to ``verts`` (a Blender object moved or
    turned since it was analysed).  When the record's key is theirs and the motion is rigid, the analysis is
    the record's moved with it, without analysing again: the record's rotor frame, profile and flank numbers,
    its placement composed with the motion.  (An analysis of the moved mesh would choose its frame anew: turned
    about the axis, or reversed for a rotor turned end for end.)  A motion that scales, shears or mirrors is not
    taken.  ``progress``: a report function
    ``(fraction, message)`` (``flank_addon.progress.reporter``) called between the analysis' stages; the
    ``Cancelled`` it raises stops the analysis, and nothing is kept.
    """
    verts = np.asarray(verts, float)
    faces = np.asarray(faces, int)
    key = _mesh_key(verts, faces, n_profile, threshold)
    found = _at_hand(verts, faces, key, n_profile, threshold, known, known_at)
    if found is not None:
        return found
    result = _analyze_mesh(verts, faces, n_profile, threshold, progress)
    if key is None:
        return result
    result.content_key = key
    _remember(key, result)
    path = _disk_path(key)
    if path is not None:
        try:
            os.makedirs(os.path.dirname(path), exist_ok=True)
            _to_npz(result, path)
        except OSError:
            pass
    return copy.deepcopy(result)


def analysis_at_hand(verts, faces, n_profile=2048, threshold=RESIDUAL_THRESHOLD, known=None, known_at=None):
    """What :func:`analyze_mesh` returns when it need not analyse, else None: the record moved with its mesh,
    the analysis in memory, the caller's record of this mesh, or the disk cache's.  A caller on a user interface's
    thread asks this first and, on None, runs :func:`analyze_mesh` where it cannot block (about a second for
    280,000 triangles against the hash's few tens of milliseconds)."""
    verts = np.asarray(verts, float)
    faces = np.asarray(faces, int)
    return _at_hand(verts, faces, _mesh_key(verts, faces, n_profile, threshold), n_profile, threshold, known,
                    known_at)


def _mesh_key(verts, faces, n_profile, threshold):
    if verts.ndim == 2 and faces.ndim == 2:
        return _cache_key(verts, faces, n_profile, threshold)
    return None


def _disk_path(key):
    """The disk cache's file of the analysis with ``key`` (None without ``FLANK_CACHE_DIR`` or a key)."""
    folder = os.environ.get(CACHE_DIR_ENV, "")
    return os.path.join(folder, "analysis-" + key + ".npz") if key is not None and folder else None


def _at_hand(verts, faces, key, n_profile, threshold, known, known_at):
    """:func:`analysis_at_hand` with the mesh's key already made."""
    if key is None:
        return None
    if isinstance(known, dict) and known_at is not None and known.get("key") != key:
        # the caller's record moved with its mesh stands for the analysis whatever else was made of this placement
        # (it keeps the record's rotor frame and flank numbers, where analysing the moved mesh would pick its own);
        # it is made again at each call (a hash and a profile spline) and never kept under this mesh's key, so
        # what memory and the disk cache hold stays the analysis of the mesh as it is
        moved = _moved_record(known, known_at, faces, n_profile, threshold)
        if moved is not None:
            moved.content_key = key
            return moved
    if key in _CACHE:
        return copy.deepcopy(_CACHE[key])
    # the analysis kept elsewhere: the caller's record of this mesh, else the disk cache (a damaged one: analyse)
    found = None
    if isinstance(known, dict) and known.get("key") == key:
        try:
            found = RotorAnalysis.from_record(known)
        except (KeyError, TypeError, ValueError):
            pass
    path = _disk_path(key)
    if found is None and path is not None and os.path.isfile(path):
        try:
            found = _from_npz(path)
        except (OSError, ValueError, KeyError, TypeError):
            pass
    if found is None:
        return None
    found.content_key = key
    _remember(key, found)
    return copy.deepcopy(found)


def rigid_motion(motion, tol=1e-6):
    """The 4 x 4 ``motion`` if it is a rotation and a translation, else None: its 3 x 3 part orthonormal within
    ``tol`` with determinant +1, its last row 0 0 0 1.  Returned with the nearest rotation in place of the 3 x 3
    part (a turn that went through single precision, as Blender's object matrices do, is orthonormal only to a few
    1e-7), so what it moves stays rigid."""
    m = np.array(motion, float)
    if m.shape != (4, 4) or not np.isfinite(m).all() or not np.array_equal(m[3], [0.0, 0.0, 0.0, 1.0]):
        return None
    rot = m[:3, :3]
    if np.abs(rot.T @ rot - np.eye(3)).max() > tol or np.linalg.det(rot) <= 0:
        return None
    u, _, vt = np.linalg.svd(rot)
    m[:3, :3] = u @ vt
    return m


def _moved_record(known, known_at, faces, n_profile, threshold):
    """The analysis of ``known`` moved by ``known_at``'s motion when the record is of its vertices (see
    :func:`analyze_mesh`), else None."""
    then, motion = known_at
    m = rigid_motion(motion)
    then = np.asarray(then, float)
    if m is None or then.ndim != 2 or then.shape[1] != 3:
        return None
    if _cache_key(then, faces, n_profile, threshold) != known.get("key"):
        return None
    try:
        a = RotorAnalysis.from_record(known)
    except (KeyError, TypeError, ValueError):
        return None
    # the rotor frame, the profile, the flanks and every length stay; only the placement in the model moves
    a.to_world = m @ np.asarray(a.to_world, float)
    a.axis_point = m[:3, :3] @ np.asarray(a.axis_point, float) + m[:3, 3]
    a.axis_direction = m[:3, :3] @ np.asarray(a.axis_direction, float)
    return a


def _remember(key, analysis):
    _CACHE.pop(key, None)
    _CACHE[key] = analysis
    while len(_CACHE) > CACHE_SIZE:
        _CACHE.pop(next(iter(_CACHE)))


def _analyze_mesh(verts, faces, n_profile, threshold, progress=None):
    """:func:`analyze_mesh` without its cache."""
    report = progress or (lambda fraction, message: None)
    if verts.ndim != 2 or verts.shape[1] != 3 or len(verts) < 4:
        raise NotHelicalError(f"mesh needs at least 4 vertices with 3 coordinates, got shape {verts.shape}")
    if faces.ndim != 2 or faces.shape[1] != 3 or len(faces) < 4:
        raise NotHelicalError(f"mesh needs triangles (M x 3) and at least 4 of them, got shape {faces.shape}")
    if not np.isfinite(verts).all():
        raise NotHelicalError("mesh vertices contain NaN or inf")
    if faces.min() < 0 or faces.max() >= len(verts):
        raise NotHelicalError(f"face indices must lie in 0 .. {len(verts) - 1}, got {faces.min()} .. {faces.max()}")
    report(0.0, "welding the mesh")
    verts, faces, repairs, face_cross = _weld(verts, faces)
    if len(faces) < 4:
        raise NotHelicalError(f"mesh has {len(faces)} triangles with an area after welding; at least 4 are needed")
    report(0.15, "vertex normals")
    normals, areas = vertex_normals(verts, faces, face_cross)
    if areas.sum() <= 0:
        raise NotHelicalError("mesh has no area")
    centre = np.average(verts, axis=0, weights=areas)
    scale = float(np.sqrt(np.average(np.sum((verts - centre) ** 2, axis=1), weights=areas)))
    P = (verts - centre) / scale
    valid = areas > 0
    weights = areas.copy()

    def residuals(d, a, k):
        vel = axis_screw_velocity(P, d, a, k)
        speed = np.linalg.norm(vel, axis=1)
        return np.abs(np.einsum("ij,ij->i", vel, normals)) / np.maximum(speed, 1e-300)

    # robust start: iteratively reweighted (Cauchy) so end faces cannot drag the first fit
    moments = np.cross(P, normals)
    Pv, nv, mv = P[valid], normals[valid], moments[valid]
    for it in range(12):
        report(0.2 + 0.02 * it, "screw motion")
        d, a, k, evals = fit_screw_motion(Pv, nv, weights[valid], mv)
        rel = residuals(d, a, k)
        sigma = max(float(np.median(rel[valid])), 1e-9)
        weights = areas / (1.0 + (rel / sigma) ** 2)
    keep = valid & (rel <= max(10 * sigma, 1e-6))
    for _ in range(8):
        report(0.44, "screw motion, trimmed")
        d, a, k, evals = fit_screw_motion(P[keep], normals[keep], areas[keep], moments[keep])
        rel = residuals(d, a, k)
        med = float(np.median(rel[keep]))
        new_keep = valid & (rel <= max(10 * med, 1e-6))
        if np.array_equal(new_keep, keep):
            break
        keep = new_keep
    total_area = float(areas.sum())
    frac = float(areas[keep].sum() / total_area)
    tangency = float(np.sqrt(np.average(rel[keep] ** 2, weights=areas[keep])))
    # normals of coarse or irregular tessellations are only good to a few degrees, so the tangency
    # test is a gross pre-check; the decisive residual below uses the (exact) vertex positions
    quote = f"tangency residual {tangency:.3g}, threshold {TANGENCY_THRESHOLD:.3g}"
    if tangency > TANGENCY_THRESHOLD:
        raise NotHelicalError(f"not a helical surface: {quote} (residual exceeds the threshold)")
    if frac < MIN_HELICAL_AREA:
        raise NotHelicalError(
            f"not a helical rotor: only {frac:.1%} of the surface area fits one screw motion "
            f"(needs at least {MIN_HELICAL_AREA:.0%}; {quote})")
    # spheres, cylinders and planes fit a whole family of motions: the second eigenvalue is then
    # as small as the first, while a helical rotor separates them by many orders of magnitude
    separation = float(evals[1] / max(evals[0], 1e-300))
    if separation < MIN_EIGEN_SEPARATION:
        raise NotHelicalError(
            f"not helical: the screw motion is not unique (eigenvalue separation {separation:.3g} "
            f"< {MIN_EIGEN_SEPARATION:g}; sphere, cylinder or plane?; {quote})")
    # what the faces say about the advance: judged after the positional residual, so that a coarse rotor mesh
    # is refused for its residual; a vanishing advance is a surface of revolution, refused below by name
    advance = (face_advance(P, faces, face_cross, d, a, k), k, scale, quote) if abs(k) > 1e-9 else None
    axis_point = centre + scale * a
    v0 = abs(k) * scale
    hand = 1 if k > 0 else -1
    if d[np.argmax(np.abs(d))] < 0:   # deterministic orientation; handedness is invariant
        d = -d
    # helical body: inlier vertices whose normals are not perpendicular to the axis (excludes shafts)
    body = keep & (np.abs(normals @ d) > 0.05)
    if not body.any():
        raise NotHelicalError(f"not a helical rotor: no face that fits the screw motion has a normal with an axial "
                              f"component above 0.05 (only shafts or planes; {quote})")
    zc = (verts[body] - axis_point) @ d
    z0, z1 = float(zc.min()), float(zc.max())
    origin = axis_point + z0 * d
    T = _frame(d, origin)
    Rinv = T[:3, :3].T

    def to_rotor(p):
        return (p - origin) @ Rinv.T

    # radius check on v0 (surfaces of revolution give k ~ 0)
    vr = to_rotor(verts[keep])
    outer = float(np.max(np.hypot(vr[:, 0], vr[:, 1])))
    if v0 < MIN_PITCH_RATIO * outer:
        flat = float(np.average(np.abs(normals[keep] @ d), weights=areas[keep])) > 0.999
        plane = ", here a plane (every normal along the axis)" if flat else " (disc, cone, sphere, ...)"
        raise NotHelicalError(
            f"not helical: v0 = {v0:.3g} is below {MIN_PITCH_RATIO:g} x outer radius ({outer:.3g}); "
            f"a turn about the axis alone maps the mesh onto itself: a surface of revolution{plane} ({quote})")
    report(0.45, "profile")
    # profile points: exact helical vertices nearest to one axial level at mid body, screwed into
    # z = 0.  The level is a vertex's own z, so a mesh built from rings contributes exactly one ring
    # (no pitch-error noise between copies of the same profile point).
    # (all vertices, not only the fit's inliers: the strict trim drops sharp-corner vertices)
    va = to_rotor(verts)
    zr = va[:, 2]
    zm = float(zr[np.argmin(np.abs(zr - 0.5 * (z1 - z0)))])
    dz = np.abs(zr - zm)
    ring = dz <= 1e-7 * outer   # tolerance: roundoff of rigid motions
    if ring.sum() >= 720:
        band = ring
    else:  # no ring structure: the vertices nearest to the level, merged below where they coincide
        need = min(len(dz), 8 * n_profile)
        band = dz <= max(np.partition(dz, need - 1)[need - 1], 1e-7 * outer)
    level = np.array([0.0, 0.0, zm])
    cloud = screw_to_plane(va[band] - level, v0, hand)   # in the plane of the level itself
    # ordering reference: slice of the mesh at that level, screwed into z = 0 as well
    loops = slice_loops(verts, faces, origin + (zm + 1e-4 * outer) * d, d)  # off the vertex level
    if not loops:
        raise NotHelicalError("mid-body slice of the mesh is empty")
    loops2 = [screw_to_plane(to_rotor(L) - level, v0, hand) for L in loops]
    ref = max(loops2, key=lambda L: abs(signed_area(L)))
    if signed_area(ref) < 0:
        ref = ref[::-1]
    s, perim, dist = _order_along(ref, cloud)
    near = dist < 0.02 * outer   # drop points of other loops (bores, etc.)
    s, cloud = s[near], cloud[near]
    order = np.argsort(s)
    s, cloud = s[order], cloud[order]
    # copies of one profile point coming from different axial levels differ only by the pitch
    # error (~1e-6 R); a spline through such near-duplicates zigzags, so merge each run of points
    # closer than 1e-4 R along the profile into its mean
    start = np.concatenate([[True], np.diff(s) > 1e-4 * outer])
    cluster = np.cumsum(start) - 1
    if s[-1] - s[0] > perim - 1e-4 * outer:   # the last run wraps onto the first
        cluster[cluster == cluster[-1]] = 0 if cluster[-1] > 0 else cluster[-1]
    counts = np.bincount(cluster)
    pts = np.stack([np.bincount(cluster, cloud[:, c]) for c in range(2)], -1)[counts > 0] / counts[counts > 0, None]
    try:
        spline = SplineProfile(pts)
    except ProfileError:
        if advance is not None:      # a prism's few profile points: say what the mesh is, if the faces tell
            _check_face_advance(*advance)
        raise
    report(0.7, "pitch and flanks")
    # pitch refinement: vertices far from the profile level must screw back onto the profile
    helical_verts = va[body_mask_all(keep, normals, d)] - level
    v0 = _refine_pitch(spline, helical_verts, v0, hand, outer)
    # decisive residual: how far the helical vertices are from the fitted helical surface
    deviation = _profile_distances(spline, helical_verts, v0, hand)
    residual = float(np.sqrt(np.mean(deviation ** 2)) / outer)
    if residual > threshold:
        raise NotHelicalError(
            f"not a helical surface: residual {residual:.3g} exceeds the threshold {threshold:.3g} "
            f"(RMS distance of the mesh vertices from the best screw surface, in outer radii; "
            f"max {deviation.max() / outer:.3g})")
    if advance is not None:
        _check_face_advance(*advance)
    # the rotor frame's profile is at z = 0: screw the level's profile there with the refined pitch
    spline = SplineProfile(rotate2d(pts, -hand * zm / v0))
    # resample uniformly, starting at the first lobe tip so flank ranges rarely wrap
    prof = spline.sample(n_profile)
    flanks, lobes = split_flanks(prof)
    if lobes >= 1 and flanks:
        start = flanks[0][0]
        prof = np.roll(prof, -start, axis=0)
        flanks = [[a - start, b - start] for a, b in flanks]
    final = SplineProfile(prof)
    report(0.8, "body and shafts")
    bz = body_extent(final, va, v0, hand, (0.0, z1 - z0), max(50.0 * residual, 2e-4) * outer)
    shafts = shaft_cylinders(va, bz[0], bz[1], 1e-6 * outer)
    # shared by equal rotors (the CLI and the operators plan on this surface; a report of the plan reuses it)
    from .helical_surface import shared_surface
    surface = shared_surface(final, v0, hand)
    return RotorAnalysis(axis_point=origin, axis_direction=d, v0=v0, handedness=hand_name(hand),
                         residual=residual, threshold=threshold, tangency_residual=tangency,
                         to_world=T, profile=prof, flanks=flanks,
                         outer_radius=float(np.max(np.linalg.norm(prof, axis=1))), lobes=lobes,
                         helical_area_fraction=frac, body_z=bz, surface=surface,
                         mesh_repairs=repairs, shafts=shafts)
