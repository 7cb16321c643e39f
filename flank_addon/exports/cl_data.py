"""APT-style CL data of a flank-plan/1 plan.

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
  (Bizzarri, Bo & Bartoň Eq. 2); meridian strips: axis_start + h_0 a (first meridian row); paraboloid strips:
  axis_start - b a (the lens' lower apex); otherwise axis_start - radii[0] a (the bottom of the tip
  sphere).  A strip with its own ``tool`` (a plan with several tools) uses that one.

Several tools: the header lists them (``$$ tool n: ...``, numbered in the order the strips first use them) and
``LOADTL/n`` with ``CUTTER/d,0,0,0,taper,0,h`` (tip diameter, taper angle in degrees, flute length) precedes the
first strip of each tool and every change of tool.

Free-form plans (Rajain et al. 2023, ``surface`` of kind mesh): one ``GOTO`` per ruling in the input model's
frame, no rotor angle or feed (the tool itself moves); the tip T is the centre of the tool's tip
circle, s = -(r1 dr / L) along the axis from the tip sphere centre (a cone touching the spheres
r(s) = r1 + s dr touches each along a circle set back by r dr / L), after stepping back over the
part of the tool that does not cut (engagement < 1).  The error CSV lists the envelope points with
their exact signed distance to the surface; strip meshes are the envelopes of Eqs. (5)-(6).
"""
import math

import numpy as np

from ..geometry.screw import hand_sign, screw_motion
from ..io.plan import is_mesh_plan, plan_tools, strip_tool

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
    k, s = _get_strip(plan, strip)
    p0 = np.asarray(s["axis_start"], float)
    a = _unit(np.subtract(s["axis_end"], p0))
    tool = strip_tool(plan, k)
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
    R, unit = float(plan["rotor"]["outer_radius"]), plan.get("length_unit", "")
    extent = plan["rotor"].get("extent")
    if extent is not None:
        # a tool tip that never comes within an outer radius of the body's ends cuts air only
        lo, hi = (float(z) for z in extent["z_range"])
        if z1 < lo - R or z0 > hi + R:
            raise ValueError(f"z range {z0:g},{z1:g} misses the rotor: its body spans z = {lo:g} .. {hi:g} {unit} "
                             f"(outer radius {R:g}); the tool tip's range must come within an outer radius of it")
    if max(abs(z0), abs(z1)) > 1e4 * R:      # with the body's extent or not: a range of no rotor
        raise ValueError(f"z range {z0:g},{z1:g} reaches beyond 1e4 x the outer radius {R:g} {unit}")
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
    if is_mesh_plan(plan):
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
    # several tools (strips with their own): LOADTL/CUTTER where the tool changes, numbered by first use
    multi = any(isinstance(st.get("tool"), dict) for st in plan["strips"])
    number = {}
    if multi:
        for n, (t, used) in enumerate(plan_tools(plan), 1):
            number.update({k: (n, t) for k in used})
            out.append(f"$$ tool {n}: {_tool_text(t)}; strips {','.join(map(str, used))}")
    current = None
    for k in ks:
        s = plan["strips"][k]
        st = cl_steps(plan, k, steps, (z0, z1))
        if multi and number[k][0] != current:
            current, t = number[k]
            out.append(f"LOADTL/{current}")
            if t.get("kind") == "cone" and all(t.get(k) is not None for k in ("r1c", "alpha")):
                # APT CUTTER/d,r,e,f,a,b,h: tip diameter, no corner radius, taper angle (deg), flute length
                out.append("CUTTER/%s,0,0,0,%s,0,%s" % (_fmt(2 * float(t["r1c"])), _fmt(math.degrees(float(t["alpha"]))),
                                                         _fmt(float(t.get("h", 0.0)))))
            out.append(f"$$ tool {current}: {t.get('name', t.get('kind', 'tool'))}")
        out.append(f"$$ STRIP {k} flank {s.get('flank')} reported error max {_fmt(s['reported_max_error'])} "
                   f"min {_fmt(s['reported_min_error'])} collision {bool(s.get('collision', False))}")
        out.append(f"$$ tip = axis_start + {_fmt(st['tip_offset'])} * axis; hand {hand:+d}")
        for p, a, ang, f in zip(st["tip"], st["axis"], st["angle_deg"], st["feed"]):
            out.append("GOTO/%s,%s,%s,%s,%s,%s $$ A=%s FEED=%s" % (*(_fmt(x) for x in p), *(_fmt(x) for x in a),
                                                                   _fmt(ang), _fmt(f)))
    out.append("FINI")
    return "\n".join(out) + "\n"
