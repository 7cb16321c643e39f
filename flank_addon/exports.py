"""Exports of a flank-plan/1 plan: APT-style CL data, the error profile as CSV, strip envelopes as meshes.

CL data (:func:`cl_data`)
-------------------------
In a plan every strip's tool is fixed in the rotor frame while the rotor screws by S_t (:mod:`screw`:
turn by hand*t about z, advance v0*t).  A machine does it the other way round, so the CL file gives,
per step k (t_k = t_0 + k dt, k = 0..N):

* ``GOTO/x,y,z,i,j,k``: the tool tip point P_k and the unit tool axis a_k (tip -> shank) in the
  *rotor (workpiece) frame*, i.e. the tool pose relative to the rotor body:
  P_k = S_{-t_k}(T), a_k = Rz(-hand t_k) a, where T, a are the plan's tool tip and axis;
* a trailing APT comment ``$$ A=<deg> FEED=<len>``: the rotor rotation angle
  A_k = hand * t_k in degrees (about the rotor axis z, counter-clockwise positive, not wrapped) and the
  axial feed of that step v0 * (t_k - t_{k-1}) (0 on the first step of a strip).

A post-processor for a rotary-axis machine turns the rotor to A_k (Rz(A_k)); the tool tip is then at
Rz(A_k) P_k = T - v0 t_k e_z and its axis at a: fixed x, y and direction, the tool feeding along the
rotor axis by -FEED per step.  Steps: the tip's rotor-frame z runs from Z1 down to Z0 (``z_range``,
default one lead [0, 2 pi v0]) in N equal steps, so FEED = (Z1 - Z0) / N.

Tool tip T on the axis (a = unit(axis_end - axis_start)):
  cone tool (plan tool kind "cone"): the tip circle centre x1c = axis_start - r1c tan(alpha) a
  (s000 Eq. 2); meridian strips: axis_start + h_0 a (first meridian row); paraboloid strips:
  axis_start - b a (the lens' lower apex); otherwise axis_start - radii[0] a (the bottom of the tip
  sphere).

Free-form plans (s003, ``surface`` of kind mesh): one ``GOTO`` per ruling in the input model's
frame, no rotor angle or feed (the tool itself moves); the tip T is the centre of the tool's tip
circle, s = -(r1 dr / L) along the axis from the tip sphere centre (a cone touching the spheres
r(s) = r1 + s dr touches each along a circle set back by r dr / L), after stepping back over the
part of the tool that does not cut (engagement < 1).  The error CSV lists the envelope points with
their exact signed distance to the surface; strip meshes are the envelopes of Eqs. (5)-(6).

Strip meshes (:func:`strip_mesh`)
---------------------------------
The envelope of one strip's tool under the relative motion of the CL steps: the tool's side is a
surface of revolution (meridian (h, R(h)) about the axis); its characteristic points under the screw
are where the surface normal is orthogonal to the screw velocity (for the inscribed-sphere form of
s001: c = m + r n with n . V(m) = 0 and n . a = -dr/dl), swept by S_{-t} over the CL time range.
"""
import math

import numpy as np

from .screw import hand_sign, screw_motion

__all__ = ["cl_data", "cl_steps", "strip_tip", "error_profile_csv", "strip_mesh", "write_strip_meshes"]

DEFAULT_STEPS = 360


def _unit(v):
    v = np.asarray(v, float)
    n = float(np.linalg.norm(v))
    if not (math.isfinite(n) and n > 0):
        raise ValueError(f"strip axis has zero length ({v.tolist()})")
    return v / n


def _get_strip(plan, strip):
    strips = plan["strips"]
    try:
        k = int(strip)
    except (TypeError, ValueError):
        raise ValueError(f"strip {strip!r} is not an integer") from None
    if not 0 <= k < len(strips):
        raise ValueError(f"strip {k} does not exist: the plan has strips 0..{len(strips) - 1}"
                         if strips else "the plan has no strips")
    return k, strips[k]


def strip_tip(plan, strip):
    """(T (3,), a (3,), offset) of strip index ``strip``: tool tip point, unit axis (tip -> shank) in the
    rotor frame and the tip's signed offset along a from axis_start (see module doc)."""
    _, s = _get_strip(plan, strip)
    p0 = np.asarray(s["axis_start"], float)
    a = _unit(np.subtract(s["axis_end"], p0))
    tool = plan.get("tool", {})
    if s.get("meridian") is not None:
        off = float(np.asarray(s["meridian"], float)[0, 0])
    elif s.get("paraboloid") is not None:
        off = -float(s["paraboloid"]["b"])
    elif tool.get("kind") == "cone" and "alpha" in tool and "r1c" in tool:
        off = -float(tool["r1c"]) * math.tan(float(tool["alpha"]))
    else:
        off = -float(s["radii"][0])
    return p0 + off * a, a, off


def _z_range(plan, z_range):
    v0 = float(plan["rotor"]["v0"])
    if z_range is None:
        return 0.0, 2.0 * math.pi * v0
    z0, z1 = (float(z) for z in z_range)
    if not (math.isfinite(z0) and math.isfinite(z1) and z1 > z0):
        raise ValueError(f"z range {z0:g},{z1:g} must be finite with Z0 < Z1")
    return z0, z1


def _steps(steps):
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or not 1 <= steps <= 1_000_000:
        raise ValueError(f"steps {steps!r} is outside the limits 1..1000000")
    return int(steps)


def cl_steps(plan, strip, steps=DEFAULT_STEPS, z_range=None):
    """The CL steps of one strip as arrays: dict with t (N+1,), tip (N+1, 3), axis (N+1, 3) in the rotor
    frame, angle_deg (N+1,) = hand t in degrees, feed (N+1,) = v0 dt (0 first)."""
    steps = _steps(steps)
    z0, z1 = _z_range(plan, z_range)
    rot = plan["rotor"]
    v0, hand = float(rot["v0"]), hand_sign(rot["handedness"])
    T, a, off = strip_tip(plan, strip)
    t = (T[2] - z1) / v0 + np.arange(steps + 1) * ((z1 - z0) / (steps * v0))
    tip = screw_motion(np.broadcast_to(T, (len(t), 3)), -t, v0, hand)
    axis = screw_motion(np.broadcast_to(a, (len(t), 3)), -t, 0.0, hand)   # rotation only
    feed = np.r_[0.0, v0 * np.diff(t)]
    return {"t": t, "tip": tip, "axis": axis, "angle_deg": np.degrees(hand * t), "feed": feed,
            "tip_offset": off, "z_range": (z0, z1)}


def _fmt(x):
    return f"{float(x):.10f}".rstrip("0").rstrip(".") if abs(x) < 1e6 else f"{float(x):.10g}"


def _tool_text(tool):
    return " ".join(f"{k}={_fmt(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else v}"
                    for k, v in tool.items())


def _is_mesh_plan(plan):
    return plan.get("surface") is not None


def freeform_cl_poses(plan, k):
    """Tool tip points (N, 3) and unit axes (N, 3) of a free-form plan's strip k, one per ruling."""
    st = plan["strips"][k]
    R = np.asarray(st["rulings"], float)
    a, b = R[:, 0], R[:, 1]
    L_e = np.linalg.norm(b - a, axis=1)
    if not (L_e > 0).all():
        raise ValueError(f"strip {k}: a ruling has zero length")
    u = (b - a) / L_e[:, None]
    tool = plan.get("tool", {})
    r1e, r2 = float(st["radii"][0]), float(st["radii"][-1])
    L_full = float(tool.get("length", float(np.mean(L_e))))
    r1 = float(tool.get("r1", r1e))
    back = L_full - L_e                                # the tool part before the engaged cone
    slope = (r2 - r1) / L_full                         # sin of the cone's half angle
    tip_sphere = a - back[:, None] * u
    return tip_sphere - (r1 * slope) * u, u


def _cl_data_mesh(plan, strip=None):
    ks = range(len(plan["strips"])) if strip is None else [_get_strip(plan, strip)[0]]
    unit = plan["length_unit"]
    summ = plan["summary"]
    out = ["$$ Flank Toolpath CL data (export of flank-plan/1, method %s)" % plan.get("method", "?"),
           "PARTNO/FLANK TOOLPATH",
           ("UNITS/MM" if unit == "mm" else f"$$ UNITS: {unit}"),
           f"$$ length unit {unit}",
           "$$ frame: the input model's frame (free-form surface); one GOTO per ruling of the plan",
           "$$ GOTO/x,y,z,i,j,k = tool tip (centre of the tip circle) and unit tool axis (tip -> shank)",
           f"$$ tool: {_tool_text(plan.get('tool', {}))}",
           f"$$ plan errors max {_fmt(summ['max_error'])} min {_fmt(summ['min_error'])}; kink max "
           f"{_fmt(summ.get('max_kink_deg', 0.0))} deg mean {_fmt(summ.get('mean_kink_deg', 0.0))} deg",
           "MULTAX/ON"]
    for k in ks:
        s = plan["strips"][k]
        tips, axes = freeform_cl_poses(plan, k)
        out.append(f"$$ STRIP {k} reported error max {_fmt(s['reported_max_error'])} "
                   f"min {_fmt(s['reported_min_error'])} collision {bool(s.get('collision', False))}")
        for p, a in zip(tips, axes):
            out.append("GOTO/%s,%s,%s,%s,%s,%s" % (*(_fmt(x) for x in p), *(_fmt(x) for x in a)))
    out.append("FINI")
    return "\n".join(out) + "\n"


def cl_data(plan, strip=None, steps=DEFAULT_STEPS, z_range=None):
    """APT-style CL text of all strips (``strip`` None) or one strip index (see the module doc)."""
    if _is_mesh_plan(plan):
        if z_range is not None:
            raise ValueError("a z range applies to rotor plans only (this is a free-form plan)")
        return _cl_data_mesh(plan, strip)
    rot = plan["rotor"]
    v0, hand = float(rot["v0"]), hand_sign(rot["handedness"])
    steps = _steps(steps)
    z0, z1 = _z_range(plan, z_range)
    ks = range(len(plan["strips"])) if strip is None else [_get_strip(plan, strip)[0]]
    unit = plan["length_unit"]
    tol = plan.get("tolerance")
    out = ["$$ Flank Toolpath CL data (export of flank-plan/1, method %s)" % plan.get("method", "?"),
           "PARTNO/FLANK TOOLPATH",
           ("UNITS/MM" if unit == "mm" else "$$ UNITS: R (lengths in the rotor's outer-radius unit)"),
           f"$$ length unit {unit}; angles in degrees",
           "$$ frame: rotor (workpiece) frame, rotor axis = z through the origin",
           "$$ GOTO/x,y,z,i,j,k = tool tip and unit tool axis (tip -> shank) relative to the rotor",
           "$$ A = rotor rotation angle about z (deg, CCW positive, unwrapped); turn the rotor by A and",
           "$$   the tip is at fixed x,y with z lowered by the accumulated FEED; FEED = axial feed of the step",
           f"$$ rotor: handedness {rot['handedness']}, v0 {_fmt(v0)} per rad, lead {_fmt(2 * math.pi * v0)}, "
           f"outer radius {_fmt(rot['outer_radius'])}",
           f"$$ tool: {_tool_text(plan.get('tool', {}))}",
           f"$$ tolerance: {_fmt(tol) if isinstance(tol, (int, float)) else 'n/a'}; plan errors max "
           f"{_fmt(plan['summary']['max_error'])} min {_fmt(plan['summary']['min_error'])}",
           f"$$ z range {_fmt(z0)},{_fmt(z1)} (tip z from Z1 down to Z0); steps {steps} per strip, "
           f"feed {_fmt((z1 - z0) / steps)} per step",
           "MULTAX/ON"]
    for k in ks:
        s = plan["strips"][k]
        st = cl_steps(plan, k, steps, (z0, z1))
        out.append(f"$$ STRIP {k} flank {s.get('flank')} reported error max {_fmt(s['reported_max_error'])} "
                   f"min {_fmt(s['reported_min_error'])} collision {bool(s.get('collision', False))}")
        out.append(f"$$ tip = axis_start + {_fmt(st['tip_offset'])} * axis; hand {hand:+d}")
        for p, a, ang, f in zip(st["tip"], st["axis"], st["angle_deg"], st["feed"]):
            out.append("GOTO/%s,%s,%s,%s,%s,%s $$ A=%s FEED=%s" % (*(_fmt(x) for x in p), *(_fmt(x) for x in a),
                                                                   _fmt(ang), _fmt(f)))
    out.append("FINI")
    return "\n".join(out) + "\n"


def error_profile_csv(source, tolerance=None):
    """CSV text ``index,x,y,deviation`` per target-flank profile point (verify's ``deviation_profile``).

    ``source``: a :func:`verify.verify_plan` result, or a plan (then verified here with ``tolerance``,
    default the plan's ``tolerance`` field or verify's default).  An empty deviation field = no tool
    reaches the point within verify's search range."""
    if _is_mesh_plan(source):
        from .g1_multistrip import freeform_envelopes
        rows = ["strip,i_t,j_s,x,y,z,deviation"]
        for k, env in enumerate(freeform_envelopes(source)):
            ns = env["shape"][1]
            for idx, (p, d) in enumerate(zip(env["vertices"], env["deviation"])):
                rows.append(f"{k},{idx // ns},{idx % ns},{float(p[0])!r},{float(p[1])!r},{float(p[2])!r},"
                            f"{'' if not math.isfinite(d) else repr(float(d))}")
        return "\n".join(rows) + "\n"
    if "deviation_profile" not in source:
        from .verify import verify_plan
        tol = tolerance if tolerance is not None else source.get("tolerance")
        source = verify_plan(source, tolerance=tol)
    rows = ["index,x,y,deviation"]
    for i, x, y, d in source["deviation_profile"]:
        rows.append(f"{int(i)},{float(x)!r},{float(y)!r},{'' if d is None else repr(float(d))}")
    return "\n".join(rows) + "\n"


# --------------------------------------------------------------------------- strip envelopes

def _chain_meridian(radii, L, n):
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


def _polyline_meridian(mer, n):
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


def _paraboloid_meridian(a, b, n):
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


def characteristic(p0, a, h, R, dh, dR, v0, hand):
    """Characteristic points of a surface of revolution (axis p0 + h a, meridian samples (h, R) with
    unit tangents (dh, dR)) under the screw motion: (c (2, n, 3) for the two branches, real (n,))."""
    a = _unit(a)
    m = np.asarray(p0, float) + np.asarray(h, float)[:, None] * a
    V = np.c_[-hand * m[:, 1], hand * m[:, 0], np.full(len(m), v0)]
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
    from .screw import screw_to_plane
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
        h, R, dh, dR = _polyline_meridian(s["meridian"], n_s)
    elif s.get("paraboloid") is not None:
        h, R, dh, dR = _paraboloid_meridian(float(s["paraboloid"]["a"]), float(s["paraboloid"]["b"]), n_s)
    else:
        h, R, dh, dR = _chain_meridian(s["radii"], float(np.linalg.norm(axis)), n_s)
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


def write_strip_meshes(plan, prefix, fmt="stl", strip=None, z_range=None, **kw):
    """Write each strip's envelope (or one strip's) to PREFIX_<k>.stl|.ply; returns the paths."""
    from .mesh_io import write_ply, write_stl

    writer = {"stl": write_stl, "ply": write_ply}[fmt]
    ks = range(len(plan["strips"])) if strip is None else [_get_strip(plan, strip)[0]]
    paths = []
    if _is_mesh_plan(plan):
        if z_range is not None:
            raise ValueError("a z range applies to rotor plans only (this is a free-form plan)")
        from .g1_multistrip import freeform_envelopes
        envs = freeform_envelopes(plan)
        for k in ks:
            q = envs[k]["faces"]
            tri = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
            ok = np.isfinite(envs[k]["deviation"])[tri].all(1)
            path = f"{prefix}_{k}.{fmt}"
            writer(path, envs[k]["vertices"], tri[ok])
            paths.append(path)
        return paths
    for k in ks:
        v, f = strip_mesh(plan, k, z_range=z_range, **kw)
        if not len(f):
            raise ValueError(f"strip {k}: the tool has no real characteristic under the screw motion")
        path = f"{prefix}_{k}.{fmt}"
        writer(path, v, f)
        paths.append(path)
    return paths
