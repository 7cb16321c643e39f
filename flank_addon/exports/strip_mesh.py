"""Envelope strips of a plan as triangle meshes.

Strip meshes (:func:`strip_mesh`)
---------------------------------
The envelope of one strip's tool under the relative motion of the CL steps: the tool's side is a
surface of revolution (meridian (h, R(h)) about the axis); its characteristic points under the screw
are where the surface normal is orthogonal to the screw velocity (for the inscribed-sphere form of
Bizzarri & Bartoň 2021: c = m + r n with n . V(m) = 0 and n . a = -dr/dl), swept by S_{-t} over the CL time range.
"""
import numpy as np

from ..geometry.screw import hand_sign, screw_motion, screw_velocity
from ..io.plan import is_mesh_plan
from ..tooling.meridian import paraboloid_samples, polyline_samples, sphere_chain_samples
from .cl_data import _get_strip, _unit, cl_steps


def characteristic(p0, a, h, R, dh, dR, v0, hand):
    """Characteristic points of a surface of revolution (axis p0 + h a, meridian samples (h, R) with
    unit tangents (dh, dR)) under the screw motion: (c (2, n, 3) for the two branches, real (n,))."""
    a = _unit(a)
    m = np.asarray(p0, float) + np.asarray(h, float)[:, None] * a
    V = screw_velocity(m, v0, hand)
    va = V @ a
    Vp = V - va[:, None] * a
    axz = np.cross(a, [0.0, 0.0, 1.0])
    W = dh[:, None] * Vp - (hand * R * dR)[:, None] * axz
    wn = np.linalg.norm(W, axis=1)
    cth = dR * va / np.maximum(wn, 1e-300)
    real = (wn > 1e-12) & (np.abs(cth) <= 1.0)
    cth = np.clip(cth, -1.0, 1.0)
    sth = np.sqrt(1.0 - cth * cth)
    e1 = W / np.maximum(wn, 1e-300)[:, None]
    e2 = np.cross(a, e1)
    c = np.stack([m + R[:, None] * (cth[:, None] * e1 + sg * sth[:, None] * e2) for sg in (1.0, -1.0)])
    return c, real


def _profile_distance(plan, pts):
    """Distance of rotor-frame points (N, 3) to the rotor profile polygon's vertices (via the helix)."""
    from ..geometry.screw import screw_to_plane
    rot = plan["rotor"]
    q = screw_to_plane(pts, float(rot["v0"]), rot["handedness"])
    prof = np.asarray(rot["profile"], float)
    best = np.full(len(q), np.inf)
    for ch in np.array_split(np.arange(len(prof)), max(1, len(prof) // 512)):
        d = np.linalg.norm(q[:, None, :] - prof[None, ch, :], axis=-1).min(axis=1)
        best = np.minimum(best, d)
    return best


def strip_mesh(plan, strip, n_s=80, n_t=97, z_range=None, branch="auto"):
    """Envelope (verts (K, 3), faces (F, 3)) of strip index ``strip`` in the rotor frame, swept over the
    CL time range of ``z_range`` (see :func:`cl_steps`) with ``n_t`` time samples.

    branch: +1 / -1 (one side of the characteristic), "both", or "auto" (the branches lying on the
    rotor: the lower quartile of their distances to the rotor profile below a tenth of the mean tool
    radius, so both sides of a double-flank tool; if neither, the nearer).
    """
    k, s = _get_strip(plan, strip)
    if not (isinstance(n_s, (int, np.integer)) and 2 <= n_s <= 100_000) or \
            not (isinstance(n_t, (int, np.integer)) and 2 <= n_t <= 100_000):
        raise ValueError(f"mesh samples n_s = {n_s!r}, n_t = {n_t!r} must be integers in 2..100000")
    rot = plan["rotor"]
    v0, hand = float(rot["v0"]), hand_sign(rot["handedness"])
    p0 = np.asarray(s["axis_start"], float)
    axis = np.subtract(s["axis_end"], p0)
    a = _unit(axis)
    if s.get("meridian") is not None:
        h, R, dh, dR = polyline_samples(s["meridian"], n_s)
    elif s.get("paraboloid") is not None:
        h, R, dh, dR = paraboloid_samples(float(s["paraboloid"]["a"]), float(s["paraboloid"]["b"]), n_s)
    else:
        h, R, dh, dR = sphere_chain_samples(s["radii"], float(np.linalg.norm(axis)), n_s)
    c, real = characteristic(p0, a, h, R, dh, dR, v0, hand)
    if branch == "both":
        keep = [0, 1]
    elif branch in (1, -1):
        keep = [0 if branch == 1 else 1]
    elif branch == "auto":
        if not real.any():
            keep = []
        else:
            med = [float(np.quantile(_profile_distance(plan, c[b][real]), 0.25)) for b in (0, 1)]
            keep = [b for b in (0, 1) if med[b] <= 0.1 * float(np.mean(R))] or [int(np.argmin(med))]
    else:
        raise ValueError(f"branch {branch!r} is not one of auto, both, 1, -1")
    st_t = cl_steps(plan, k, n_t - 1, z_range)["t"]
    verts, faces, base = [], [], 0
    idx = np.flatnonzero(real)
    for b in keep:
        pts = c[b][idx]
        if len(pts) < 2:
            continue
        V = screw_motion(pts[:, None, :], -st_t[None, :], v0, hand)          # (K, n_t, 3)
        K = len(pts)
        q = np.arange(K - 1)[:, None] * n_t + np.arange(n_t - 1)[None, :]
        ok = np.diff(idx) == 1                                                # no faces across gaps
        q = q[ok]
        f = np.concatenate([np.stack([q, q + n_t, q + n_t + 1], -1).reshape(-1, 3),
                            np.stack([q, q + n_t + 1, q + 1], -1).reshape(-1, 3)])
        verts.append(V.reshape(-1, 3))
        faces.append(f + base)
        base += K * n_t
    if not verts:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    return np.concatenate(verts), np.concatenate(faces).astype(np.int64)


def strip_meshes(plan, strip=None, z_range=None, **kw):
    """Each strip's envelope (or one strip's) as a triangle mesh: [(k, vertices (N, 3), faces (M, 3))].  A
    free-form plan's envelopes leave out the triangles beyond the surface's border (NaN deviation)."""
    ks = range(len(plan["strips"])) if strip is None else [_get_strip(plan, strip)[0]]
    out = []
    if is_mesh_plan(plan):
        if z_range is not None:
            raise ValueError("a z range applies to rotor plans only (this is a free-form plan)")
        from ..methods.freeform_g1.planner import freeform_envelopes
        envs = freeform_envelopes(plan)
        for k in ks:
            q = envs[k]["faces"]
            tri = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
            ok = np.isfinite(envs[k]["deviation"])[tri].all(1)
            out.append((k, envs[k]["vertices"], tri[ok]))
        return out
    for k in ks:
        v, f = strip_mesh(plan, k, z_range=z_range, **kw)
        if not len(f):
            raise ValueError(f"strip {k}: the tool has no real characteristic under the screw motion")
        out.append((k, v, f))
    return out


def write_meshes(meshes, prefix, fmt="stl"):
    """Write meshes [(k, vertices, faces)] (:func:`strip_meshes`) to PREFIX_<k>.stl|.ply; returns the paths."""
    from ..io.files import atomic_write_all
    from ..io.mesh_files import ply_bytes, stl_bytes

    encode = {"stl": stl_bytes, "ply": ply_bytes}[fmt]
    items = [(f"{prefix}_{k}.{fmt}", encode(v, f)) for k, v, f in meshes]
    atomic_write_all(items)            # every file or none: a failure leaves the earlier set as it was
    return [path for path, _ in items]


def write_strip_meshes(plan, prefix, fmt="stl", strip=None, z_range=None, **kw):
    """Write each strip's envelope (or one strip's) to PREFIX_<k>.stl|.ply; returns the paths."""
    return write_meshes(strip_meshes(plan, strip=strip, z_range=z_range, **kw), prefix, fmt)
