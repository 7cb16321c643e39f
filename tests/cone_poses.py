"""Cone poses for the strip-cover and collision tests, built here (not by the single-flank planner):
a cone tangent to a helical flank at a profile point, its ruling along an asymptotic direction."""
import numpy as np

from flank_addon.tooling.cone import ConePose


def surface_frame(S, u):
    """Point, unit outward normal and the tangents x_u, x_t of the helical surface at (u, t = 0)."""
    p, p1, p2 = (S.profile.eval(np.asarray(u, float), k) for k in range(3))
    h, v0 = S.hand, S.v0
    J = lambda v: np.array([-v[1], v[0]])
    xu = np.r_[p1, 0.0]
    xt = np.r_[h * J(p), v0]
    xuu, xut, xtt = np.r_[p2, 0.0], np.r_[h * J(p1), 0.0], np.r_[-p, 0.0]
    n = np.cross(xu, xt)
    n /= np.linalg.norm(n)
    return np.r_[p, 0.0], n, xu, xt, (xuu @ n, xut @ n, xtt @ n)


def asymptotic_directions(S, u):
    """Unit tangent directions of zero normal curvature at (u, 0) (two on a hyperbolic point)."""
    q, n, xu, xt, (L, M, N) = surface_frame(S, u)
    disc = M * M - L * N
    if disc <= 0:
        raise ValueError(f"u = {u}: not a hyperbolic point")
    out = []
    for sg in (1.0, -1.0):
        if abs(N) > 1e-12:
            a, b = 1.0, (-M + sg * np.sqrt(disc)) / N
        else:
            a, b = (-N / (2 * M), 1.0) if sg > 0 else (1.0, 0.0)
        w = a * xu + b * xt
        out.append(w / np.linalg.norm(w))
    return out


def tangent_pose(S, tool, u, direction, lift=0.0):
    """Cone touching the flank at profile parameter u along the tangent ``direction`` (flipped to
    point away from the helical axis, so the shank leaves the valley), raised by ``lift`` along the
    normal.  Tip sphere centre = foot + (r1S + lift) n, axis = cos(alpha) d + sin(alpha) n."""
    q, n, *_ = surface_frame(S, u)
    d = np.asarray(direction, float)
    if d[:2] @ q[:2] < 0:
        d = -d
    a = np.cos(tool.alpha) * d + np.sin(tool.alpha) * n
    return ConePose(tool, q + (tool.r1s + lift) * n, a)


def lifted_poses(S, tool, flank_range, us, which=0, eps=1e-4, rounds=3):
    """Asymptotic-direction tangent poses at parameters ``us``, each lifted along its normal until it
    no longer overcuts the flank by more than ``eps`` (uses strip_cover.covered_intervals)."""
    from flank_addon.methods.single_flank.strip_cover import covered_intervals

    dirs = [asymptotic_directions(S, u)[which] for u in us]
    lifts = np.zeros(len(us))
    for _ in range(rounds):
        poses = [tangent_pose(S, tool, u, d, l) for u, d, l in zip(us, dirs, lifts)]
        c = covered_intervals(poses, S, flank_range, eps, eps, n=300, search=0.05)
        over = np.array([pc.max_overcut for pc in c.poses])
        if not (over > 0.5 * eps).any():
            break
        lifts += np.where(over > 0.5 * eps, np.minimum(over, 0.05), 0.0)
    return poses
