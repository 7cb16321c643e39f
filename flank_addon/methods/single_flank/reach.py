"""Where no tool of a given smallest radius can mill a flank within tolerance: a bound proven from the geometry.

The tool model of the plans and of the sweep simulation is the union of the cone's inscribed spheres
(Bizzarri, Bo & Bartoň Eqs. (2), (9)), radii from r1S (tip) to r2S.  Every point of its surface lies on one of
these spheres, and a sphere of radius r' >= r1S through a point q contains the sphere of radius r1S
internally tangent to it at q.  Hence if the machined surface passes through q (within the tolerance band,
|q - p| <= tol, p the design point), some ball B(c, r1S) of the tool has q on its boundary at some instant of
the screw motion, and since the rotor is invariant under its own screw the ball must stay out of the rotor
at that instant too (up to the allowed overcut eps_over on the target flank; a deeper entry is a gouge or a
collision): dist(c, rotor) >= r1S - eps_over with |c - q| = r1S.  Distance is 1-Lipschitz, so

    dist(c, rotor) <= g(p, r1S) + tol,     g(p, r) = max over unit w of dist(p + r w, rotor),

and a point p with  g(p, r1S) < r1S - tol - eps_over  cannot be milled within the tolerance by any such tool:
every tool ball that comes within tol of p enters the rotor by at least r1S - tol - g(p, r1S).  g(p, r) - r
never grows with r (g grows at most as fast as r), so the statement for the smallest r1S of a catalogue holds
for every tool of it.

Here dist is the signed distance (negative inside the rotor: a ball centred in the material is worse still).
An upper bound of g is computed rigorously: outside the rotor, dist(x, rotor) <= the distance from x to a
finite set of exact surface points (any surface point bounds the distance from above; the set is the flank's
neighbourhood, screwed copies of the profile in steps of at most ``h``); a point the fine profile polygon
(screwed into z = 0) holds is inside the rotor or within the polygon's sagitta of its surface, so its
distance is at most that sagitta; and over the sphere of directions by branch and
bound on the cells of a cubed sphere: for a cell of angular radius theta around w_c, every direction in it
gives a point within 2 r sin(theta / 2) of p + r w_c, so dist <= dist(p + r w_c) + 2 r sin(theta / 2).  Cells
whose bound reaches the threshold are split (the gnomonic cells are geodesically convex, so theta is
attained at a corner) until every bound is below it (proven) or a centre value itself reaches it (no proof
is possible with this point set).
"""
import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree


@dataclass
class RoomBound:
    """Per profile parameter u: ``g_up`` an upper bound of g(p, r) (module doc), ``proven`` whether
    g_up < r - slack (no tool ball of radius r comes within the tolerance of p without entering the rotor),
    ``depth``: the proven least entry r - slack - g_up (0 where not proven)."""
    u: np.ndarray
    radius: float
    slack: float
    g_up: np.ndarray
    proven: np.ndarray
    depth: np.ndarray


_FACES = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)


def _axes_table():
    n = _FACES
    a = np.where(np.abs(n[:, 1:2]) < 0.5, [[0.0, 1.0, 0.0]], [[0.0, 0.0, 1.0]])
    e1 = np.cross(a, n)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return n, e1, np.cross(n, e1)


_N, _E1, _E2 = _axes_table()


def _directions(f, x, y):
    """Unit directions of the gnomonic points (x, y) of cube faces f (arrays of one length)."""
    v = _N[f] + np.asarray(x)[:, None] * _E1[f] + np.asarray(y)[:, None] * _E2[f]
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _cells(f, x0, x1, y0, y1):
    """Centre directions (k, 3) and angular radii (k,) of gnomonic cells [x0, x1] x [y0, y1] of faces f."""
    c = _directions(f, 0.5 * (x0 + x1), 0.5 * (y0 + y1))
    th = np.zeros(len(c))
    for xs, ys in ((x0, y0), (x0, y1), (x1, y0), (x1, y1)):
        d = _directions(f, xs, ys)
        th = np.maximum(th, np.arccos(np.clip(np.einsum("ij,ij->i", c, d), -1.0, 1.0)))
    return c, th


def _signed_upper(tree, solid, sag, surface, x):
    """An upper bound of the signed distance (positive outside) from points x (N, 3) to the rotor."""
    from ...geometry.screw import screw_to_plane

    d, _ = tree.query(x)
    inside = solid.contains(screw_to_plane(x, surface.v0, surface.hand))
    return np.where(inside, sag, d)


def _fine_solid(surface, h):
    """The profile polygon at spacing <= h / 2 and a bound of its distance from the profile (twice the
    largest sagitta measured at the edges' midpoints)."""
    from ...simulation.collision import ProfileSolid

    prof = surface.profile
    n = int(min(200000, max(4096, math.ceil(_profile_length(prof) / (0.5 * h)))))
    n = 1 << int(math.ceil(math.log2(n)))            # powers of two: the polygons are cached per surface
    cache = surface.__dict__.setdefault("_reach_polygons", {})
    if n in cache:
        return cache[n]
    u = np.arange(n) * (prof.period / n)
    P = prof.eval(u)
    mid = prof.eval(u + 0.5 * prof.period / n)
    sag = float(np.max(np.linalg.norm(mid - 0.5 * (P + np.roll(P, -1, axis=0)), axis=1)))
    cache[n] = (ProfileSolid(P), 2.0 * sag)
    return cache[n]


def _local_cloud(surface, points, reach, h):
    """Exact surface points of the rotor (all lobes) near the z = 0 points ``points`` (M, 3): every profile
    point within ``reach`` (plus the lateral sweep of the sections over the height reach) screwed over
    |z| <= reach, spaced at most ~h along the profile and between the sections."""
    prof = surface.profile
    v0, hand = surface.v0, surface.hand
    rho_max = float(surface.outer_radius)
    T = reach / v0
    per = prof.period
    # the profile finely, then the part within reach + rho_max T of some query point (2D)
    n_fine = int(min(400000, max(2000, math.ceil(_profile_length(prof) / (0.5 * h)))))
    u = np.arange(n_fine) * (per / n_fine)
    q = prof.eval(u)
    tree = cKDTree(points[:, :2])
    d, _ = tree.query(q)
    keep = d <= reach + rho_max * T + h
    q = q[keep]
    dt = h / math.hypot(rho_max, v0)
    ts = np.linspace(-T - dt, T + dt, int(math.ceil(2 * (T + dt) / dt)) + 1)
    c, s = np.cos(hand * ts), np.sin(hand * ts)
    X = c[:, None] * q[None, :, 0] - s[:, None] * q[None, :, 1]
    Y = s[:, None] * q[None, :, 0] + c[:, None] * q[None, :, 1]
    Z = np.broadcast_to((v0 * ts)[:, None], X.shape)
    return np.stack([X.ravel(), Y.ravel(), Z.ravel()], -1)


def _profile_length(prof):
    p = prof.sample(4096)
    return float(np.sum(np.linalg.norm(np.diff(np.vstack([p, p[:1]]), axis=0), axis=1)))



def room_bound(surface, u, radius, slack, h=None, m0=4, max_cells=200000, max_depth=9):
    """:class:`RoomBound` of the balls of ``radius`` (a tool's smallest sphere) at the profile parameters u
    (rotor ``surface``, all lobes), ``slack`` = tolerance + allowed overcut (module doc).  ``h``: spacing of
    the exact surface points (default radius / 15).  The branch and bound runs on all points at once: every
    cell whose bound reaches the threshold is split, level by level, until none is left (proven) or one of a
    point's centre values reaches it (that point is not provable); ``max_depth`` levels, ``max_cells`` cells."""
    u = np.atleast_1d(np.asarray(u, float))
    r = float(radius)
    if not (math.isfinite(r) and r > 0):
        raise ValueError(f"ball radius {radius!r} must be a finite number > 0")
    h = r / 15.0 if h is None else float(h)
    p = np.c_[surface.profile.eval(u), np.zeros(len(u))]
    thr = r - float(slack)
    M = len(u)
    g_up = np.full(M, np.inf)
    proven = np.zeros(M, bool)
    if thr <= 0 or not M:
        return RoomBound(u, r, float(slack), g_up, proven, np.zeros(M))
    cloud = _local_cloud(surface, p, 2.0 * r + 2.0 * h, h)
    tree = cKDTree(cloud)
    solid, sag = _fine_solid(surface, h)

    def bounds(pt, f, x0, x1, y0, y1):
        cdir, th = _cells(f, x0, x1, y0, y1)
        d = _signed_upper(tree, solid, sag, surface, p[pt] + r * cdir)
        return d, d + 2.0 * r * np.sin(0.5 * th)

    e = np.linspace(-1.0, 1.0, m0 + 1)
    X0, Y0 = (a.ravel() for a in np.meshgrid(e[:-1], e[:-1], indexing="ij"))
    step = e[1] - e[0]
    k0 = len(X0)
    pt = np.repeat(np.arange(M), 6 * k0)
    f = np.tile(np.repeat(np.arange(6), k0), M)
    x0, y0 = np.tile(X0, 6 * M), np.tile(Y0, 6 * M)
    x1, y1 = x0 + step, y0 + step
    alive = np.ones(M, bool)            # no centre value has reached the threshold yet
    best = np.full(M, -np.inf)          # largest bound among the cells kept below the threshold
    cells = len(pt)
    for depth in range(max_depth + 1):
        dc, b = bounds(pt, f, x0, x1, y0, y1)
        np.logical_and.at(alive, pt, dc < thr)
        keep = b < thr
        np.maximum.at(best, pt[keep], b[keep])
        split = ~keep & alive[pt]
        if not split.any() or depth == max_depth or cells > max_cells:
            np.maximum.at(best, pt[split], b[split])
            alive[np.unique(pt[split])] = False
            break
        pt, f, x0, x1, y0, y1 = (a[split] for a in (pt, f, x0, x1, y0, y1))
        xm, ym = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
        pt, f = np.repeat(pt, 4), np.repeat(f, 4)
        x0, x1 = np.stack([x0, xm, x0, xm], 1).ravel(), np.stack([xm, x1, xm, x1], 1).ravel()
        y0, y1 = np.stack([y0, y0, ym, ym], 1).ravel(), np.stack([ym, ym, y1, y1], 1).ravel()
        cells += len(pt)
    proven = alive & (best < thr)
    g_up = np.where(proven, best, np.maximum(best, thr))
    depth = np.where(proven, thr - g_up, 0.0)
    return RoomBound(u, r, float(slack), g_up, proven, depth)
