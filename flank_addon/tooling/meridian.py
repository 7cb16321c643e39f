"""Tool outlines: the meridian of a revolving tool, the curve (radius, height) whose turn about the tool axis
is the tool's surface.

Two forms serve two users:

- outlines (:func:`cone_outline`): closed polylines (radius, height) from the top pole to the tip pole, with
  the shank, for building a tool's mesh of revolution (Blender previews and results);
- samples (:func:`sphere_chain_samples`, :func:`polyline_samples`, :func:`paraboloid_samples`): n points
  (h, R) of the cutting side with unit tangents (dh, dR), for the characteristic curves of the tool under a
  screw motion (the envelope strips of ``exports.strip_mesh``).

A conical tool's side touches the spheres r(l) = r1 + l (r2 - r1) / L inscribed along its axis (Bizzarri, Bo &
Bartoň, Eq. (2); Bizzarri & Bartoň 2021, Section 3): with sin(a) = (r2 - r1) / L the side circle of the sphere at
height l has radius r(l) cos(a) and lies at height l - r(l) sin(a).
"""
import math

import numpy as np


def cone_outline(r_tip, r_top, z_tip, z_top, shank_radius=0.0, shank_length=0.0):
    """(K, 2) outline (radius, height) of a truncated cone (tip circle of radius ``r_tip`` at height ``z_tip``,
    top circle ``r_top`` at ``z_top``) and, if both are positive, a cylindrical shank of ``shank_radius`` and
    ``shank_length`` on its top; from the top pole to the tip pole, without repeated points (a repeated ring
    would make degenerate faces)."""
    pts = []
    if shank_radius > 0.0 and shank_length > 0.0:
        pts += [(0.0, z_top + shank_length), (shank_radius, z_top + shank_length), (shank_radius, z_top)]
    else:
        pts += [(0.0, z_top)]
    pts += [(r_top, z_top), (r_tip, z_tip), (0.0, z_tip)]
    out = [pts[0]]
    for p in pts[1:]:
        if abs(p[0] - out[-1][0]) > 1e-12 or abs(p[1] - out[-1][1]) > 1e-12:
            out.append(p)
    return np.array(out, dtype=np.float64)


def cone_tool_outline(tool):
    """Outline of a :class:`.cone.ConeTool` and its shank in the tool's frame: origin at the centre of the tip
    sphere x1S, z along the axis, the tip circle c1 at z = -r1c tan(alpha) (Bizzarri, Bo & Bartoň, Eq. (2))."""
    z1 = -tool.r1c * math.tan(tool.alpha)
    return cone_outline(tool.r1c, tool.r2c, z1, z1 + tool.h, tool.shank_radius, tool.shank_length)


def sphere_cone_outline(r1, r2, L, below=0.0, shank_radius=0.0, shank_length=0.0):
    """Outline (:func:`cone_outline`) of the cone touching the spheres of radii r1 (centre at height 0) and r2
    (centre at height L), continued ``below`` the first sphere's centre (the part that does not cut, Fig. 18
    of Rajain et al. 2023), with its shank beyond the top."""
    sa = (r2 - r1) / L
    ca = math.sqrt(max(1.0 - sa * sa, 0.0))
    r0 = r1 - sa * below                       # radius of the tip sphere of the whole tool
    return cone_outline(max(r0, 0.0) * ca, r2 * ca, -below - r0 * sa, L - r2 * sa, shank_radius, shank_length)


def sphere_chain_samples(radii, L, n):
    """Side of a chain of sphere frustums (inscribed spheres of ``radii`` equally spaced over L):
    n samples (h, R, unit tangent dh, dR) of the outer boundary R(h) = max over the frustums."""
    r = np.asarray(radii, float)
    m = len(r) - 1
    ell = np.linspace(0.0, L, m + 1)
    sb = np.diff(r) / (L / m)
    if np.any(np.abs(sb) >= 1):
        raise ValueError("strip radii change faster than the axis length: no tangent cone")
    cb = np.sqrt(1 - sb * sb)
    ha, hb = ell[:-1] - r[:-1] * sb, ell[1:] - r[1:] * sb           # tangency points of each cone piece
    h = np.linspace(ha[0], hb[-1], n)
    H = h[:, None]
    # candidates: cone lines (n, m) and sphere arcs (n, m + 1)
    Rl = np.where((H >= ha - 1e-12) & (H <= hb + 1e-12), r[:-1] * cb + (H - ha) * sb / cb, -np.inf)
    dh_ = H - ell
    Rs = np.sqrt(np.maximum(r * r - dh_ ** 2, 0.0))
    Rs = np.where(np.abs(dh_) < r, Rs, -np.inf)
    cand = np.concatenate([Rl, Rs], axis=1)
    j = np.argmax(cand, axis=1)
    R = cand[np.arange(n), j]
    line = j < m
    jl, js = np.minimum(j, m - 1), np.maximum(j - m, 0)
    dh = np.where(line, cb[jl], R / np.maximum(r[js], 1e-300))
    dR = np.where(line, sb[jl], -(h - ell[js]) / np.maximum(r[js], 1e-300))
    return h, R, dh, dR


def polyline_samples(mer, n):
    """n samples (h, R, dh, dR) equally spaced along a meridian polyline ``mer`` (M, 2) of (h, R) rows."""
    mer = np.asarray(mer, float)
    seg = np.diff(mer, axis=0)
    ln = np.linalg.norm(seg, axis=1)
    cum = np.r_[0.0, np.cumsum(ln)]
    s = np.linspace(0.0, cum[-1], n)
    k = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(seg) - 1)
    w = (s - cum[k]) / np.maximum(ln[k], 1e-300)
    p = mer[k] + w[:, None] * seg[k]
    tang = seg[k] / np.maximum(ln[k], 1e-300)[:, None]
    return p[:, 0], p[:, 1], tang[:, 0], tang[:, 1]


def paraboloid_samples(a, b, n):
    """The lens |h| <= b + a rho^2: lower half h = -(b + a rho^2) with rho 0 -> rho_e, upper half back."""
    rho_e = math.sqrt(-b / a)
    k = n // 2
    rho = np.linspace(0.0, rho_e, k)
    lo = (-(b + a * rho * rho), rho, -2 * a * rho, np.ones(k))
    rr = rho[::-1]
    hi = (b + a * rr * rr, rr, -2 * a * rr, -np.ones(k))
    h, R, dh, dR = (np.r_[x, y] for x, y in zip(lo, hi))
    nt = np.hypot(dh, dR)
    return h, R, dh / nt, dR / nt
