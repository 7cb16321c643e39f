"""Independent references for the core tests (dense brute force, analytic test profiles)."""
import numpy as np
from scipy.spatial import cKDTree

from flank_addon.geometry.profile import Arc, Line, SegmentProfile, SplineProfile
from flank_addon.geometry.screw import screw_motion, screw_to_plane


def wavy_profile(lobes=4, r0=0.72, amp=0.22, n=480):
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    r = r0 + amp * np.cos(lobes * th)
    return SplineProfile(np.c_[r * np.cos(th), r * np.sin(th)])


def half_disk_profile(radius=1.0):
    """Line through the axis (generates a helicoid) closed by a half circle (generates a cylinder)."""
    return SegmentProfile([Line((-radius, 0.0), (radius, 0.0)), Arc((0.0, 0.0), radius, 0.0, np.pi)])


def brute_force_distance(surface, points, n_u=3000, n_t=1200):
    """Unsigned distance by dense sampling of the surface around each query's own helix.

    Queries are screwed into z = 0 first (exact), then compared against
    n_u x n_t surface samples with |t| covering every reachable sheet.
    """
    q = np.atleast_2d(points)
    q0 = np.c_[screw_to_plane(q, surface.v0, surface.hand), np.zeros(len(q))]
    u = surface.profile.params(n_u)
    p = surface.profile.eval(u)
    # the t = 0 slice bounds the distance, so sheets with |t| v0 beyond it cannot be nearer
    d_plane, _ = cKDTree(p).query(q0[:, :2])
    tmax = np.max(d_plane) / surface.v0
    t = np.linspace(-tmax, tmax, n_t)
    p3 = np.c_[p, np.zeros(len(p))]
    best = np.full(len(q), np.inf)
    for chunk in np.array_split(t, 8):
        pts = screw_motion(p3[:, None, :], chunk[None, :], surface.v0, surface.hand).reshape(-1, 3)
        d, _ = cKDTree(pts).query(q0)
        best = np.minimum(best, d)
    return best


def cylinder_mesh(radius, z0, z1, n=96, rings=4):
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    zs = np.linspace(z0, z1, rings)
    v = np.stack([np.tile(radius * np.cos(th), rings), np.tile(radius * np.sin(th), rings), np.repeat(zs, n)], -1)
    i = np.arange(rings - 1)[:, None] * n
    j = np.arange(n)[None, :]
    a, b = i + j, i + (j + 1) % n
    f = np.concatenate([np.stack([a, b, b + n], -1).reshape(-1, 3), np.stack([a, b + n, a + n], -1).reshape(-1, 3)])
    return v, f


def cad_like(rotor, n_profile=6000, n_axial=60):
    """Rotor body with end faces plus shaft cylinders at both ends, as CAD exports carry."""
    v, f = rotor.mesh(n_profile=n_profile, n_axial=n_axial)
    parts = [(v, f)]
    R = rotor.profile.outer_radius()
    for z0, z1 in ((-0.8 * R, 0.0), (rotor.length, rotor.length + 1.2 * R)):
        parts.append(cylinder_mesh(0.35 * R, z0, z1))
    verts, faces, off = [], [], 0
    for pv, pf in parts:
        verts.append(pv)
        faces.append(pf + off)
        off += len(pv)
    return np.vstack(verts), np.vstack(faces)


def profile_hausdorff(analysis, rotor, to_model):
    """Hausdorff distance between the analysed profile and the true one.

    The true profile (rotor frame, z = 0) is moved into the model by
    ``to_model``, then into the analysis' rotor frame and screwed into its
    plane z = 0, so axis, pitch and profile errors all count.
    """
    from flank_addon.geometry.rotor_analysis import _order_along

    u = rotor.profile.params(20000)
    truth = to_model(np.c_[rotor.profile.eval(u), np.zeros(len(u))])
    q0 = screw_to_plane(analysis.to_rotor_frame(truth), analysis.v0, analysis.handedness)
    est = analysis.surface.profile.eval(analysis.surface.profile.params(40000))
    return max(_order_along(est, q0)[2].max(), _order_along(q0, est)[2].max())


def irregular_mesh(rotor, n_points=100000, seed=0):
    """Helical side of a rotor as a CAD-like irregular tessellation: random exact surface samples
    triangulated (Delaunay) in the (u, t) parameter rectangle, seam vertices merged."""
    from scipy.spatial import Delaunay

    surf = rotor.surface()
    per = rotor.profile.period
    T = rotor.length / rotor.v0
    rng = np.random.default_rng(seed)
    uv = np.c_[rng.uniform(0, per, n_points), rng.uniform(0, T, n_points)]
    ub, tb = np.linspace(0, per, 2000), np.linspace(0, T, 200)
    uv = np.vstack([uv, np.c_[ub, np.zeros_like(ub)], np.c_[ub, np.full_like(ub, T)],
                    np.c_[np.zeros_like(tb), tb], np.c_[np.full_like(tb, per), tb]])
    tri = Delaunay(uv / [per / 8, T]).simplices
    v = surf.evaluate(uv[:, 0], uv[:, 1])
    _, first, inv = np.unique(np.round(v / 1e-9).astype(np.int64), axis=0, return_index=True,
                              return_inverse=True)
    return v[first], inv.ravel()[tri]
