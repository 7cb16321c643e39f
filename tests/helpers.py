"""Independent references for the core tests (dense brute force, analytic test profiles)."""
import numpy as np
from scipy.spatial import cKDTree

from flank_addon.profile import Arc, Line, SegmentProfile, SplineProfile
from flank_addon.screw import screw_motion, screw_to_plane


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
