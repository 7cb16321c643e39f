"""Global collision of a conical tool and its cylindrical shank with the whole rotor (Bizzarri, Bo & Bartoň §5.5).

Bizzarri, Bo & Bartoň samples the tool axis and compares foot-point distances with the inscribed-sphere radii.  Here
the test is exact for the helical motion, by screw invariance: the infinite rotor solid B is
invariant under its own screw motion S_t (Bizzarri, Bo & Bartoň Eq. (1)), so a tool fixed in the rotor frame meets
S_t(B) at some instant t iff it meets B at t = 0.  B is the set of points whose screwed image in the
plane z = 0 lies inside the profile polygon.

Two complementary checks, both on all lobes:

1. Rotor surface into the tool (exact along every helix).  Every boundary point of B lies on the
   helix of a profile point p, and D(p) = min_t sd_part(S_t(p)) (:func:`sweep.helical_distance`) is
   the signed distance of that helix to a tool part.  D(p) < 0 means the helix enters the part, by
   depth -D(p) (the deepest point of the helix inside the part, measured from the part's surface);
   it is reported at S_t*(p).  Tool parts: the truncated cone T with flat ends at its circles c1, c2
   (Bizzarri, Bo & Bartoň Eqs. (2)-(5); ``model="spheres"`` uses the hull of the inscribed spheres S1, S2 instead, the
   solid a flank-plan/1 cone strip and :mod:`verify` use) and the flat-ended shank cylinder that
   continues the axis beyond c2.
2. Tool inside the rotor without the rotor surface entering it (the tool buried in the material,
   or entering a finite rotor through an end face): tool surface samples are screwed into z = 0
   and tested against the profile polygon (and the z range).

Tolerance: on the target flank(s) the cone is meant to touch; its penetration there up to
``tolerance`` is contact, not collision.  Anything else (the cone on other flanks, the shank
anywhere) collides when it penetrates by more than ``clearance`` (default: numerical zero).

Finite rotor: with a fixed tool, the rotor body z in [z0, z1] (at t = 0) screwed over the pass
t in [t_start, t_end] occupies the infinite body clipped to the slab Z0 = z0 + v0 t_start <= z <=
z1 + v0 t_end = Z1; pass ``z_range=(Z0, Z1)``.  Then check 1 uses max(sd_part, sd_slab) (exact sign,
depth counted inside the slab only) and check 2 also finds the tool entering through an end face.

Flanks and lobes follow :func:`rotors.builtin_rotor`: flank 2k runs from tip k to bottom k, flank
2k + 1 from bottom k to tip k + 1; valley k = flanks 2k, 2k + 1; lobe k = flanks 2k - 1, 2k (the
lobe around tip k).
"""
import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from ..geometry.screw import screw_motion, screw_to_plane
from .sweep import CylinderPart, FrustumPart, RevolvingTool, _sphere_chain, helical_distance, tool_distances


# ============================================================================ flat-ended cone
def _per_row(v, q, vec):
    v = np.asarray(v, float)
    if v.ndim == (2 if vec else 1) and q.ndim == 3:
        v = v[:, None]
    return v


def _seg_dist(h, rho, a, b):
    """Distance of 2D points (h, rho) to the segment a-b (a, b: (..., 2) broadcastable)."""
    ex, ey = b[0] - a[0], b[1] - a[1]
    wx, wy = h - a[0], rho - a[1]
    ee = ex * ex + ey * ey
    u = np.clip((wx * ex + wy * ey) / np.where(ee > 0, ee, 1.0), 0.0, 1.0)
    return np.hypot(wx - u * ex, wy - u * ey)


def sd_flat_cone(q, c1, c2, r1, r2):
    """Signed distance from points q (..., 3) to the truncated cone with flat ends: circle centres
    c1, c2 and radii r1, r2 (single or per row of q, as :func:`sweep.sd_sphere_frustum`).

    In the meridian half-plane (h along c1 -> c2, rho from the axis) the solid is the trapezoid
    0 <= h <= H, rho <= r1 + (r2 - r1) h / H; its boundary there is the tip face, the side and the
    top face (the axis is not boundary), so the distance is exact inside and outside."""
    q = np.asarray(q, float)
    c1, c2 = _per_row(c1, q, True), _per_row(c2, q, True)
    r1, r2 = _per_row(r1, q, False), _per_row(r2, q, False)
    axis = c2 - c1
    H = np.sqrt(np.einsum("...i,...i->...", axis, axis))
    w = q - c1
    h = np.einsum("...i,...i->...", w, axis) / H
    rho = np.sqrt(np.maximum(np.einsum("...i,...i->...", w, w) - h * h, 0.0))
    z = np.zeros_like(H)
    d = np.minimum(np.minimum(_seg_dist(h, rho, (z, z), (z, r1 + z)),
                              _seg_dist(h, rho, (z, r1 + z), (H, r2 + z))),
                   _seg_dist(h, rho, (H, r2 + z), (H, z)))
    inside = (h >= 0) & (h <= H) & (rho <= r1 + (r2 - r1) * h / H)
    return np.where(inside, -d, d)


class FlatConePart:
    """Truncated cone with flat end faces (Bizzarri, Bo & Bartoň §3.2's T): circles (c1, r1) and (c2, r2)."""

    stack_fields = ("c1", "c2", "r1", "r2")
    sd_rows = staticmethod(sd_flat_cone)

    def __init__(self, c1, c2, r1, r2):
        self.c1, self.c2 = np.asarray(c1, float), np.asarray(c2, float)
        self.r1, self.r2 = float(r1), float(r2)
        rmax = max(self.r1, self.r2)
        self.feature = max(min(self.r1, self.r2), 1e-3 * max(rmax, np.linalg.norm(self.c2 - self.c1)))
        self.bounds = _sphere_chain(self.c1, self.c2, lambda s, ds: rmax, max(rmax, 1e-9))

    def signed_distance(self, q):
        return sd_flat_cone(q, self.c1, self.c2, self.r1, self.r2)


class _SlabTool(RevolvingTool):
    """A tool intersected with the slab z0 <= z <= z1 (signed distance max(sd, sd_slab): exact sign)."""

    def __init__(self, parts, z0, z1):
        super().__init__(parts)
        self.z0, self.z1 = float(z0), float(z1)

    def signed_distance(self, q):
        q = np.asarray(q, float)
        return np.maximum(super().signed_distance(q), np.maximum(self.z0 - q[..., 2], q[..., 2] - self.z1))


# ============================================================================ tool parts of a pose
def pose_parts(pose, model="cone"):
    """{"cone": part, "shank": part or None} of a :class:`cone.ConePose`.

    model "cone": the flat-ended truncated cone between c1 and c2 (x_ic = x_iS - r_ic tan(alpha) a,
    Bizzarri, Bo & Bartoň Eq. (2)); "spheres": the hull of the boundary inscribed spheres (the plan strip's solid)."""
    t, a = pose.tool, pose.axis
    c1 = pose.tip - t.c1_offset * a
    c2 = pose.top - t.r2c * math.tan(t.alpha) * a
    if model == "cone":
        cone = FlatConePart(c1, c2, t.r1c, t.r2c)
    elif model == "spheres":
        from .sweep import cap_safe
        cone = cap_safe(RevolvingTool([FrustumPart(pose.tip, t.r1s, pose.top, t.r2s)])).parts[0]
    else:
        raise ValueError(f"model {model!r} is not 'cone' or 'spheres'")
    sh = pose.shank
    shank = CylinderPart(sh[0], sh[1], sh[2]) if sh is not None else None
    return {"cone": cone, "shank": shank}


def _part_tool(part, z_range):
    return RevolvingTool([part]) if z_range is None else _SlabTool([part], *z_range)


def sample_part_surface(part, spacing):
    """Points (M, 3) on the surface of a FlatConePart / FrustumPart / CylinderPart, about
    ``spacing`` apart (side, and the end faces of flat-ended parts)."""
    if isinstance(part, FlatConePart):
        c1, c2, r1, r2 = part.c1, part.c2, part.r1, part.r2
        faces = True
    elif isinstance(part, CylinderPart):
        c1, c2, r1, r2 = part.s0, part.s1, part.radius, part.radius
        faces = True
    elif isinstance(part, FrustumPart):     # side of the sphere hull, approximated by its spheres' band
        c1, c2, r1, r2 = part.c1, part.c2, part.r1, part.r2
        faces = False
    else:
        raise TypeError(f"cannot sample {type(part).__name__}")
    axis = c2 - c1
    H = float(np.linalg.norm(axis))
    a = axis / H
    e1 = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    pts = []
    if faces:
        nh = max(2, int(math.ceil(H / spacing)) + 1)
        for h in np.linspace(0.0, H, nh):
            r = r1 + (r2 - r1) * h / H
            m = max(6, int(math.ceil(2 * math.pi * r / spacing)))
            th = np.linspace(0, 2 * math.pi, m, endpoint=False)
            pts.append(c1 + h * a + r * (np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2))
        for c, R in ((c1, r1), (c2, r2)):
            for rr in np.arange(spacing, R, spacing):
                m = max(6, int(math.ceil(2 * math.pi * rr / spacing)))
                th = np.linspace(0, 2 * math.pi, m, endpoint=False)
                pts.append(c + rr * (np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2))
            pts.append(c[None])
    else:     # sphere hull: meridian = tangent line + caps; sample the meridian by arc length
        sa = (r2 - r1) / H
        ca = math.sqrt(max(0.0, 1 - sa * sa))
        mer = []
        for ang in np.linspace(math.pi, 0.5 * math.pi + math.asin(sa), 12):     # tip cap
            mer.append((r1 * math.cos(ang) - 0.0, r1 * math.sin(ang)))
        n_line = max(2, int(math.ceil(H * ca / spacing)) + 1)
        p0 = np.array([-r1 * sa, r1 * ca])
        p1 = np.array([H - r2 * sa, r2 * ca])
        mer += [tuple(p0 + s * (p1 - p0)) for s in np.linspace(0, 1, n_line)]
        for ang in np.linspace(0.5 * math.pi + math.asin(sa), 0.0, 12):         # top cap
            mer.append((H + r2 * math.cos(ang), r2 * math.sin(ang)))
        for h, r in mer:
            m = max(6, int(math.ceil(2 * math.pi * r / spacing)))
            th = np.linspace(0, 2 * math.pi, m, endpoint=False)
            pts.append(c1 + h * a + r * (np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2))
    return np.vstack(pts)


# ============================================================================ profile bookkeeping
class ProfileSolid:
    """The rotor's transverse profile (K, 2) (CCW, closed) with its flanks as inclusive index ranges
    (modulo K, as in flank-plan/1): point-in-solid tests and which flank / valley / lobe an index is."""

    def __init__(self, profile_points, flanks=None):
        P = np.asarray(profile_points, float)
        if P.ndim != 2 or P.shape[1] != 2 or len(P) < 3:
            raise ValueError("profile points must be (K >= 3, 2)")
        self.points = P
        K = len(P)
        self.flank_of = np.full(K, -1)
        self.flanks = [tuple(int(x) for x in f) for f in (flanks or [])]
        for f, (a, b) in enumerate(self.flanks):
            self.flank_of[np.arange(a, b + 1) % K] = f
        self.n_flanks = len(self.flanks)
        self._tree = cKDTree(P)
        self._a, self._b = P, np.roll(P, -1, axis=0)

    def valley(self, f):
        return int(f // 2) if f >= 0 else -1

    def lobe(self, f):
        if f < 0 or self.n_flanks < 2:
            return -1
        return int(((f + 1) // 2) % max(1, self.n_flanks // 2))

    def _bins(self):
        """Edges registered in horizontal bins of the y range they span (for the ray test)."""
        if getattr(self, "_bin_edges", None) is None:
            a, b = self._a, self._b
            y0, y1 = float(self.points[:, 1].min()), float(self.points[:, 1].max())
            nb = max(1, len(self.points) // 4)
            h = (y1 - y0) / nb or 1.0
            lo = np.clip(np.floor((np.minimum(a[:, 1], b[:, 1]) - y0) / h).astype(int), 0, nb - 1)
            hi = np.clip(np.floor((np.maximum(a[:, 1], b[:, 1]) - y0) / h).astype(int), 0, nb - 1)
            lists = [[] for _ in range(nb)]
            for e, (l, u) in enumerate(zip(lo, hi)):
                for k in range(l, u + 1):
                    lists[k].append(e)
            M = max(1, max(len(x) for x in lists))
            table = np.full((nb, M), -1)
            for k, x in enumerate(lists):
                table[k, :len(x)] = x
            self._bin_edges, self._bin_y0, self._bin_h = table, y0, h
        return self._bin_edges, self._bin_y0, self._bin_h

    def contains(self, xy):
        """Even-odd point-in-polygon test of 2D points (N, 2): a ray towards +x, counting crossings
        only with the edges whose y range shares the point's bin."""
        xy = np.atleast_2d(np.asarray(xy, float))
        table, y0, h = self._bins()
        out = np.zeros(len(xy), bool)
        k = np.floor((xy[:, 1] - y0) / h).astype(int)
        ok = (k >= 0) & (k < len(table))
        kk = np.flatnonzero(ok)
        if not len(kk):
            return out
        e = table[k[kk]]                                   # (n, M) candidate edges, -1 padding
        valid = e >= 0
        e = np.where(valid, e, 0)
        a, b = self._a[e], self._b[e]
        px, py = xy[kk, 0][:, None], xy[kk, 1][:, None]
        cond = valid & ((a[..., 1] > py) != (b[..., 1] > py))
        with np.errstate(divide="ignore", invalid="ignore"):
            xint = a[..., 0] + (py - a[..., 1]) * (b[..., 0] - a[..., 0]) / (b[..., 1] - a[..., 1])
        out[kk] = (np.count_nonzero(cond & (px < xint), axis=1) % 2) == 1
        return out

    def nearest(self, xy, k=8):
        """(distance to the polygon, index of the nearest vertex) for 2D points (N, 2)."""
        xy = np.atleast_2d(np.asarray(xy, float))
        K = len(self.points)
        k = min(k, K)
        _, idx = self._tree.query(xy, k=k)
        idx = idx.reshape(len(xy), -1)
        best = np.full(len(xy), np.inf)
        for j in range(idx.shape[1]):
            for e in (idx[:, j], (idx[:, j] - 1) % K):
                a, b = self._a[e], self._b[e]
                ab = b - a
                u = np.clip(np.einsum("ij,ij->i", xy - a, ab) / np.einsum("ij,ij->i", ab, ab), 0, 1)
                best = np.minimum(best, np.linalg.norm(xy - a - u[:, None] * ab, axis=1))
        return best, idx[:, 0]


# ============================================================================ the check
@dataclass
class CollisionReport:
    """collides: any collision; collisions: list of dicts, one per (part, flank) and contiguous run
    of profile indices (check 1, ``source`` "surface") or per (part, flank) of buried tool samples
    (check 2, ``source`` "solid"), each with part ("cone" | "shank"), flank, valley, lobe, target,
    depth, point (3D, rotor frame), profile_index, index_range; min_clearance: smallest signed
    distance of the tool (with shank) to non-target rotor surface points, capped at the measuring
    range ``clearance_range``; elapsed_s."""
    collides: bool
    collisions: list = field(default_factory=list)
    min_clearance: float = math.inf
    elapsed_s: float = 0.0


def _cyclic_runs(idx, K):
    """Runs of consecutive indices (cyclic modulo K) in a sorted index array."""
    if not len(idx):
        return []
    br = np.flatnonzero(np.diff(idx) > 1)
    runs = [[int(a), int(b)] for a, b in zip(np.r_[idx[0], idx[br + 1]], np.r_[idx[br], idx[-1]])]
    if len(runs) > 1 and runs[0][0] == 0 and runs[-1][1] == K - 1:
        runs[0][0] = runs[-1][0]
        runs.pop()
    return runs


def check_collisions(poses, profile_points, v0, handedness, flanks=None, target_flanks=(), tolerance=0.0,
                     clearance=0.0, z_range=None, model="cone", spacing=None, clearance_range=None):
    """Global collision test of several poses against the whole rotor (see the module doc).

    Args:
        poses: :class:`cone.ConePose` list (one tool each, with its shank).
        profile_points: (K, 2) closed CCW transverse profile of the whole rotor (all lobes).
        v0, handedness: the rotor's screw motion (Bizzarri, Bo & Bartoň Eq. (1)).
        flanks: inclusive index ranges [(a, b), ...] (modulo K) naming the flanks; target_flanks: the
            indices of the flanks the cone mills (its contact there within ``tolerance`` is allowed).
        tolerance: allowed cone penetration into target flanks; clearance: any other penetration
            deeper than this is a collision (>= 0; default numerical zero, 1e-9 of the model size).
        z_range: (Z0, Z1) slab of the finite rotor over the pass (None: infinite rotor).
        model: "cone" (flat-ended truncated cone) or "spheres" (hull of the inscribed spheres).
        spacing: tool surface sample spacing of check 2 (default a quarter of the smallest radius).
        clearance_range: how far min_clearance is measured (default 0.02 of the profile radius).
    Returns: a list of :class:`CollisionReport`, one per pose.
    """
    t0 = time.perf_counter()
    solid = ProfileSolid(profile_points, flanks)
    P = solid.points
    K = len(P)
    P3 = np.c_[P, np.zeros(K)]
    Rmax = float(np.max(np.linalg.norm(P, axis=1)))
    noise = 1e-9 * Rmax
    clearance = max(float(clearance), noise)
    tolerance = max(float(tolerance), clearance)
    cr = 0.02 * Rmax if clearance_range is None else float(clearance_range)
    target = np.zeros(K, bool)
    for f in target_flanks:
        target[solid.flank_of == f] = True
    parts = [pose_parts(p, model) for p in poses]
    names = ("cone", "shank")
    # check 1: D(p) of every profile helix to every part (stacked over poses where possible)
    D = {}
    for name in names:
        which = [k for k, pp in enumerate(parts) if pp[name] is not None]
        Dn = np.full((len(poses), K), np.inf)
        if which:
            tools = [_part_tool(parts[k][name], z_range) for k in which]
            if z_range is None:
                Dn[which] = tool_distances(tools, P3, v0, handedness, max(cr, tolerance))
            else:
                for k, t in zip(which, tools):
                    Dn[k] = helical_distance(t, P3, v0, handedness, cutoff=max(cr, tolerance))[0]
        D[name] = Dn
    reports = []
    for k, pose in enumerate(poses):
        cols = []
        for name in names:
            if parts[k][name] is None:
                continue
            d = D[name][k]
            allowed = np.where(target & (name == "cone"), tolerance, clearance)
            bad = np.flatnonzero(-d > allowed)
            if not len(bad):
                continue
            tool = _part_tool(parts[k][name], z_range)
            for f in np.unique(solid.flank_of[bad]):
                sel = bad[solid.flank_of[bad] == f]
                for a, b in _cyclic_runs(np.sort(sel), K):
                    run = np.arange(a, b + 1 if b >= a else b + 1 + K) % K
                    i = int(run[np.argmin(d[run])])
                    _, tt = helical_distance(tool, P3[i:i + 1], v0, handedness, cutoff=max(cr, tolerance))
                    pt = screw_motion(P3[i], tt[0], v0, handedness)
                    cols.append({"part": name, "source": "surface", "flank": int(f), "valley": solid.valley(f),
                                 "lobe": solid.lobe(f), "target": bool(target[i]), "depth": float(-d[i]),
                                 "point": pt.tolist(), "profile_index": i, "index_range": [a, b]})
        # check 2: tool surface samples buried in the rotor (not seen by check 1)
        for name in names:
            part = parts[k][name]
            if part is None:
                continue
            sp = spacing if spacing is not None else 0.25 * max(part.feature, 1e-6 * Rmax)
            X = sample_part_surface(part, sp)
            inside = solid.contains(screw_to_plane(X, v0, handedness))
            if z_range is not None:
                inside &= (X[:, 2] >= z_range[0]) & (X[:, 2] <= z_range[1])
            if not inside.any():
                continue
            Xi = X[inside]
            dist, near = solid.nearest(screw_to_plane(Xi, v0, handedness))
            if z_range is not None:
                dist = np.minimum(dist, np.minimum(Xi[:, 2] - z_range[0], z_range[1] - Xi[:, 2]))
            fl = solid.flank_of[near]
            allowed = np.where(target[near] & (name == "cone"), tolerance, clearance)
            hit = dist > allowed
            seen = {(c["part"], c["flank"]) for c in cols}
            for f in np.unique(fl[hit]):
                if (name, int(f)) in seen:
                    continue
                m = np.flatnonzero(hit & (fl == f))
                j = m[np.argmax(dist[m])]
                cols.append({"part": name, "source": "solid", "flank": int(f), "valley": solid.valley(f),
                             "lobe": solid.lobe(f), "target": bool(target[near[j]]), "depth": float(dist[j]),
                             "point": Xi[j].tolist(), "profile_index": int(near[j]),
                             "index_range": [int(near[j]), int(near[j])]})
        free = ~target
        dmin = min((float(D[n][k][free].min()) for n in names if parts[k][n] is not None and free.any()),
                   default=math.inf)
        reports.append(CollisionReport(collides=bool(cols), collisions=cols, min_clearance=min(dmin, cr)))
    el = time.perf_counter() - t0
    for r in reports:
        r.elapsed_s = el / max(1, len(reports))
    return reports


def check_collision(pose, profile_points, v0, handedness, flanks=None, target_flanks=(), tolerance=0.0, **kw):
    """:func:`check_collisions` for one pose -> :class:`CollisionReport`."""
    return check_collisions([pose], profile_points, v0, handedness, flanks, target_flanks, tolerance, **kw)[0]


def rotor_profile(rotor, n=2048):
    """(points (n, 2), flank index ranges) of a :class:`rotors.Rotor` (its flank parameter ranges
    mapped onto n equally spaced profile parameters, as :func:`plan.rotor_section` does)."""
    per = rotor.profile.period
    pts = rotor.profile.sample(n)
    fl = [(int(round(a / per * n)), int(round(b / per * n))) for a, b in rotor.flanks]
    return pts, fl


def check_rotor_collisions(poses, rotor, target_flanks=(), tolerance=0.0, n_profile=2048, **kw):
    """:func:`check_collisions` against a :class:`rotors.Rotor` (all lobes, infinite unless z_range)."""
    pts, fl = rotor_profile(rotor, n_profile)
    return check_collisions(poses, pts, rotor.v0, rotor.handedness, fl, target_flanks, tolerance, **kw)
