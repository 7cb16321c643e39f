"""The shared data model: plan files, schema "flank-plan/1".

Every planner writes this JSON; verification, Blender and the exports read
it.  Fields (more are welcome, none may be removed or change meaning):

    schema        "flank-plan/1"
    method        planner name, e.g. "single-flank-cone"
    length_unit   "mm" | "R"  (every length below, including errors)
    rotor
      to_world      4x4 row-major, rotor frame -> input model frame
      v0            axial advance per radian (> 0, 1e-6..1e6 times outer_radius); pitch = 2 pi v0
      handedness    "right" | "left"  (Bizzarri, Bo & Bartoň Eq. (1))
      profile       [[x, y], ...] closed transverse section z = 0 of the whole rotor, CCW, >= 720 points
      flanks        [[i_start, i_end], ...] inclusive profile index ranges, i_start < i_end,
                    indices taken modulo len(profile) (a flank may run through index 0)
      outer_radius  float: the profile's largest radius (within 1e-3 of it)
      extent        optional: the finite rotor in the rotor frame, {"z_range": [z0, z1] axial extent of the
                    helical body, "shafts": [{"z_range": [a, b], "radius": r}, ...] coaxial cylinders
                    (journals, stubs) beyond it}; written by the planners when the rotor is known (a mesh's
                    analysis or a built-in); plans without it stay valid
    target_flanks  [int, ...] indices into rotor.flanks
    tool           {"kind": "cone" | "revolved" | "disc" | "paraboloid", ...shape parameters...}
    strips         [{axis_start, axis_end (rotor frame, inscribed-sphere centres, start = tip end),
                     radii [r_0..r_m] at m+1 equally spaced axis points (cone: 2),
                     shank_start, shank_end, shank_radius (>= 0; 0: none), flank, reported_max_error,
                     reported_min_error (max not below min), collision,
                     tool        optional: the strip's own tool, same form as the plan's ``tool`` (a
                                 plan milling with several tools; without it the strip uses the
                                 plan's ``tool``, which is then the first of them),
                     optional exact shapes instead of the inscribed spheres of "radii":
                       meridian    [[h, R], ...] revolved polyline, h from axis_start towards
                                   axis_end strictly increasing, R >= 0 (formed disc cutters)
                       paraboloid  {a, b}: the lens |h| <= b + a rho^2 (a < 0 < b) centred
                                   at axis_start (Doğrusadık)}, ...]
    summary        {max_error, min_error, elapsed_s}
    tolerance      optional: the error tolerance the plan was made for (> 0, at most outer_radius)

Every coordinate of a rotor plan (profile, strips) lies within 1e6 times the outer radius of the origin.  A
cone tool gives alpha, r1c and r2c together or none of them.  Number fields hold JSON numbers: a string such as
"0.05" is refused, not read as a number.

Free-form plans (Rajain et al. 2023, method "freeform-g1-cone") have ``surface`` instead of ``rotor``:

    surface        {kind: "mesh", vertices [[x, y, z], ...], faces [[i, j, k], ...]} in the input
                   model's coordinates (within 1e12, some face of positive area); the tool is on the side
                   the face normals point to; every strip point lies within 1e6 surface sizes of it
    target_flanks  [] (optional)
    tool           {kind: "cone", r1, r2, length, engagement, shank_radius, shank_length}
    strips         [{rulings [[axis_start, axis_end], ...] one pair per time sample (sphere
                     centres, start = tip end), radii [r1_sphere, r2_sphere], axis_start/axis_end
                     (= the first ruling), shank_*, collision, reported_max/min_error (Eq. (19)),
                     columns, kink_to_next_deg, axis_lengths, ...}, ...]
    summary        adds max_kink_deg, mean_kink_deg (and the initial values), kink_floor_deg and
                     error_bound_at_kink (kink_bound: the least max kink any plan within this
                     max |error| can have, the least max |error| at this max kink; null
                     without a section across 3+ guiding curves)

Rotor frame: helical axis = z through the origin; the rotor surface is the
union over t of S_t(profile).  A strip's tool is fixed in the rotor frame
while the rotor screws.  Errors are signed: positive = material left
(undercut), negative = overcut.
"""
import json
import math

import numpy as np

from ..collector import collector_paused
from .files import atomic_write
from .json_pieces import dumps_in_pieces, lists_to_array

SCHEMA = "flank-plan/1"
TOOL_KINDS = ("cone", "revolved", "disc", "paraboloid")
LENGTH_UNITS = ("mm", "R")
MIN_PROFILE_POINTS = 720


class PlanError(ValueError):
    """A plan file violates flank-plan/1; the message names the field."""


def _is_int(x):
    return isinstance(x, int) and not isinstance(x, bool)


# a rotor plan's lengths relative to its outer radius: the lead (v0) and every coordinate (profile, strips) must
# lie within these factors, or the plan is of no rotor (and the screw arithmetic would overflow)
RELATIVE_RANGE = (1e-6, 1e6)
# how closely a rotor plan's outer_radius must be its profile's largest radius (the planners write it so exactly)
OUTER_RADIUS_TOL = 1e-3
# the largest coordinate of a free-form plan's surface, in its own unit: beyond it the distance queries overflow
MAX_MESH_COORDINATE = 1e12


def _is_num(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _numbers(x, name, rows=None):
    """A plan field of JSON numbers (a number, or lists of them) as a float array; :class:`PlanError` naming the
    field for strings, booleans, nulls or ragged lists (``np.asarray(x, float)`` alone took "0.05" for 0.05, and
    a post then failed on it).  ``rows``: :func:`.json_pieces.lists_to_array` for long lists of rows."""
    try:
        a = np.asarray(x) if rows is None else rows(x)
    except (ValueError, TypeError):
        raise PlanError(f"{name} must hold numbers in lists of equal lengths") from None
    if a.dtype.kind not in "iuf":
        raise PlanError(f"{name} must hold numbers only, got {_sample(x)!r}")
    return a.astype(float)


def _sample(x):
    """A short look at a field's value for a message: the first non-number in it, else its start."""
    stack = [x]
    while stack:
        v = stack.pop(0)
        if isinstance(v, list):
            stack[:0] = v
        elif not (isinstance(v, (int, float)) and not isinstance(v, bool)):
            return v
    return str(x)[:80]


def _vec(x, n, name):
    a = _numbers(x, name)
    if a.shape != (n,) or not np.isfinite(a).all():
        raise PlanError(f"{name} must be {n} finite numbers, got {x!r}")
    return a


def rotor_section(profile, v0, handedness, flanks, to_world=None, n_profile=2048):
    """Build the ``rotor`` section from a profile (Profile object or (K, 2) points).

    ``flanks`` are index ranges into the given points, or, for a Profile
    object, parameter ranges (u_start, u_end) which are converted to index
    ranges of the uniform resampling.
    """
    if hasattr(profile, "eval"):
        n = max(n_profile, MIN_PROFILE_POINTS)
        per = profile.period
        pts = profile.sample(n)
        idx = [[int(round(a / per * n)), int(round(b / per * n))] for a, b in flanks]
    else:
        pts = np.asarray(profile, float)
        idx = [[int(a), int(b)] for a, b in flanks]
    T = np.eye(4) if to_world is None else np.asarray(to_world, float)
    return {
        "to_world": T.tolist(),
        "v0": float(v0),
        "handedness": handedness,
        "profile": pts.tolist(),
        "flanks": idx,
        "outer_radius": float(np.max(np.linalg.norm(pts, axis=1))),
    }


def rotor_extent(z_range, shafts=()):
    """The optional ``rotor.extent`` field: body z range (z0 < z1) and coaxial shafts
    [(z_a, z_b, radius), ...] or [{"z_range": [a, b], "radius": r}, ...] in the plan's length unit."""
    out = []
    for sh in shafts:
        if isinstance(sh, dict):
            (a, b), r = sh["z_range"], sh["radius"]
        else:
            a, b, r = sh
        out.append({"z_range": [float(a), float(b)], "radius": float(r)})
    ext = {"z_range": [float(z_range[0]), float(z_range[1])], "shafts": out}
    _check_extent(ext)
    return ext


def scaled_extent(extent, k):
    """A ``rotor.extent`` with every length multiplied by ``k`` (its other keys as they are)."""
    out = dict(extent, z_range=[z * k for z in extent["z_range"]])
    if "shafts" in extent:
        out["shafts"] = [dict(sh, z_range=[z * k for z in sh["z_range"]], radius=sh["radius"] * k)
                         for sh in extent["shafts"]]
    return out


def _check_extent(ext, outer_radius=None):
    """A rotor's ``extent``: its body's z range and its shafts; with ``outer_radius`` (a plan's), every value
    within :data:`RELATIVE_RANGE` of it."""
    if not isinstance(ext, dict):
        raise PlanError(f"rotor.extent must be an object, got {ext!r}")
    zr = ext.get("z_range")
    if not (isinstance(zr, list) and len(zr) == 2 and all(_is_num(z) for z in zr) and zr[0] < zr[1]):
        raise PlanError(f"rotor.extent.z_range must be [z0, z1] with z0 < z1, got {zr!r}")
    shafts = ext.get("shafts", [])
    if not isinstance(shafts, list):
        raise PlanError(f"rotor.extent.shafts must be a list, got {shafts!r}")
    for k, sh in enumerate(shafts):
        zs = sh.get("z_range") if isinstance(sh, dict) else None
        if not (isinstance(zs, list) and len(zs) == 2 and all(_is_num(z) for z in zs) and zs[0] < zs[1]):
            raise PlanError(f"rotor.extent.shafts[{k}].z_range must be [a, b] with a < b, got {zs!r}")
        if not (_is_num(sh.get("radius")) and sh["radius"] > 0):
            raise PlanError(f"rotor.extent.shafts[{k}].radius must be a number > 0, got {sh.get('radius')!r}")
    if outer_radius is not None:
        reach = max([abs(z) for z in zr] + [abs(z) for sh in shafts for z in sh["z_range"]]
                    + [sh["radius"] for sh in shafts])
        if reach > RELATIVE_RANGE[1] * outer_radius:
            raise PlanError(f"rotor.extent reaches {reach:.6g}, over {RELATIVE_RANGE[1]:g} times rotor.outer_radius "
                            f"{outer_radius!r}")


def new_plan(method, rotor, tool, length_unit="R", target_flanks=(), strips=(), elapsed_s=0.0):
    plan = {
        "schema": SCHEMA,
        "method": method,
        "length_unit": length_unit,
        "rotor": rotor,
        "target_flanks": [int(i) for i in target_flanks],
        "tool": dict(tool),
        "strips": [dict(s) for s in strips],
    }
    plan["summary"] = summarize(plan["strips"], elapsed_s)
    validate_plan(plan)
    return plan


def summarize(strips, elapsed_s):
    if strips:
        mx = max(float(s["reported_max_error"]) for s in strips)
        mn = min(float(s["reported_min_error"]) for s in strips)
    else:
        mx = mn = 0.0
    return {"max_error": mx, "min_error": mn, "elapsed_s": float(elapsed_s)}


def validate_plan(plan):
    """Raise :class:`PlanError` naming the first field that breaks flank-plan/1; return the plan."""
    try:
        return _validate(plan)
    except (TypeError, AttributeError, ValueError) as e:
        if isinstance(e, PlanError):
            raise
        raise PlanError(f"malformed plan: {e}") from None


def _validate(plan):
    if not isinstance(plan, dict):
        raise PlanError("plan must be a JSON object")
    if plan.get("schema") != SCHEMA:
        raise PlanError(f"schema must be {SCHEMA!r}, got {plan.get('schema')!r}")
    if plan.get("surface") is not None:
        return _validate_mesh_plan(plan)
    for key in ("method", "length_unit", "rotor", "target_flanks", "tool", "strips", "summary"):
        if key not in plan:
            raise PlanError(f"missing field {key!r}")
    for key in ("rotor", "tool", "summary"):
        if not isinstance(plan[key], dict):
            raise PlanError(f"{key} must be an object")
    if not isinstance(plan["strips"], list) or not isinstance(plan["target_flanks"], list):
        raise PlanError("strips and target_flanks must be lists")
    if not isinstance(plan["method"], str) or not plan["method"]:
        raise PlanError(f"method must be a non-empty string, got {plan['method']!r}")
    if plan["length_unit"] not in LENGTH_UNITS:
        raise PlanError(f"length_unit must be one of {LENGTH_UNITS}, got {plan['length_unit']!r}")
    rotor = plan["rotor"]
    for key in ("to_world", "v0", "handedness", "profile", "flanks", "outer_radius"):
        if key not in rotor:
            raise PlanError(f"missing field rotor.{key}")
    T = _numbers(rotor["to_world"], "rotor.to_world")
    if T.shape != (4, 4) or not np.isfinite(T).all():
        raise PlanError(f"rotor.to_world must be a 4x4 matrix, got shape {T.shape}")
    if not np.allclose(T[3], [0, 0, 0, 1]):
        raise PlanError(f"rotor.to_world last row must be [0, 0, 0, 1], got {T[3].tolist()}")
    A = T[:3, :3]
    s = np.cbrt(np.linalg.det(A)) if np.linalg.det(A) > 0 else 0.0
    if s <= 0 or not np.allclose(A.T @ A, s * s * np.eye(3), atol=1e-9 * max(1.0, s * s)):
        raise PlanError("rotor.to_world must be a proper rigid motion (optionally uniformly scaled)")
    v0 = rotor["v0"]
    if not (_is_num(v0) and v0 > 0):
        raise PlanError(f"rotor.v0 must be a number > 0, got {v0!r}")
    if rotor["handedness"] not in ("right", "left"):
        raise PlanError(f"rotor.handedness must be 'right' or 'left', got {rotor['handedness']!r}")
    if not (_is_num(rotor["outer_radius"]) and rotor["outer_radius"] > 0):
        raise PlanError(f"rotor.outer_radius must be a number > 0, got {rotor['outer_radius']!r}")
    L = float(rotor["outer_radius"])
    if not RELATIVE_RANGE[0] <= v0 / L <= RELATIVE_RANGE[1]:
        raise PlanError(f"rotor.v0 {v0!r} must be within {RELATIVE_RANGE[0]:g}..{RELATIVE_RANGE[1]:g} times "
                        f"rotor.outer_radius {L!r} (a screw of that lead is no rotor)")
    if rotor.get("extent") is not None:
        _check_extent(rotor["extent"], L)
    prof = _numbers(rotor["profile"], "rotor.profile")
    if prof.ndim != 2 or prof.shape[1] != 2 or not np.isfinite(prof).all():
        raise PlanError("rotor.profile must be a list of finite [x, y] pairs")
    if len(prof) < MIN_PROFILE_POINTS:
        raise PlanError(f"rotor.profile has {len(prof)} points, at least {MIN_PROFILE_POINTS} are required")
    if np.abs(prof).max() > RELATIVE_RANGE[1] * L:
        raise PlanError(f"rotor.profile reaches {np.abs(prof).max():.6g}, over {RELATIVE_RANGE[1]:g} times "
                        f"rotor.outer_radius {L!r}")
    x, y = prof[:, 0], prof[:, 1]
    if np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) <= 0:
        raise PlanError("rotor.profile must be counter-clockwise")
    reach = float(np.hypot(x, y).max())
    if abs(reach - L) > OUTER_RADIUS_TOL * L:
        # every length the posts and checks scale by the outer radius: a mismatch would cut another rotor
        raise PlanError(f"rotor.outer_radius {L!r} is not the profile's largest radius {reach:.9g} (within "
                        f"{OUTER_RADIUS_TOL:g} of it)")
    n = len(prof)
    for k, fl in enumerate(rotor["flanks"]):
        if len(fl) != 2 or not all(_is_int(i) for i in fl):
            raise PlanError(f"rotor.flanks[{k}] must be two integers, got {fl!r}")
        a, b = fl
        if not (0 <= a < n and a < b <= a + n):
            raise PlanError(f"rotor.flanks[{k}] = {fl} must satisfy 0 <= start < {n} and start < end <= start + {n}")
    nf = len(rotor["flanks"])
    for i in plan["target_flanks"]:
        if not (_is_int(i) and 0 <= i < nf):
            raise PlanError(f"target_flanks entry {i!r} is not a flank index (0..{nf - 1})")
    _check_tool(plan["tool"], "tool")
    for k, st in enumerate(plan["strips"]):
        _check_strip_axes(k, st, L, 0.0, f"rotor.outer_radius {L!r}", "the rotor axis's origin")
        axis = np.subtract(st["axis_end"], st["axis_start"])
        radii = _numbers(st.get("radii", []), f"strips[{k}].radii")
        if radii.ndim != 1 or len(radii) < 2 or not np.isfinite(radii).all() or (radii < 0).any():
            raise PlanError(f"strips[{k}].radii must hold >= 2 non-negative radii")
        if not radii.max() > 0:
            raise PlanError(f"strips[{k}].radii are all 0: a tool of no thickness")
        length = float(np.linalg.norm(axis))
        if st.get("meridian") is None and radii.max() < 1e-3 * length:
            raise PlanError(f"strips[{k}]: the tool is {length / radii.max():.3g} times as long as its largest "
                            "radius (at most 1000): a needle, not a milling tool")
        if radii.max() > RELATIVE_RANGE[1] * L:
            raise PlanError(f"strips[{k}].radii reach {radii.max():.6g}, over {RELATIVE_RANGE[1]:g} times "
                            f"rotor.outer_radius {L!r}")
        if not np.any(axis) and (st.get("meridian") is not None or np.ptp(radii) > 0):
            raise PlanError(f"strips[{k}]: axis_start and axis_end coincide, yet the tool's radius varies along "
                            "its axis (only a ball may have a zero-length axis)")
        if st.get("meridian") is not None:
            mer = _numbers(st["meridian"], f"strips[{k}].meridian")
            if (mer.ndim != 2 or mer.shape[1] != 2 or len(mer) < 2 or not np.isfinite(mer).all()
                    or (np.diff(mer[:, 0]) <= 0).any() or (mer[:, 1] < 0).any()):
                raise PlanError(f"strips[{k}].meridian must be >= 2 finite [h, R] rows, h strictly "
                                "increasing, R >= 0")
            if not mer[:, 1].max() > 0:
                raise PlanError(f"strips[{k}].meridian has no radius above 0: a tool of no thickness")
        if st.get("paraboloid") is not None:
            par = st["paraboloid"]
            if not (isinstance(par, dict) and _is_num(par.get("a")) and _is_num(par.get("b"))
                    and par["a"] < 0 < par["b"]):
                raise PlanError(f"strips[{k}].paraboloid must be {{a, b}} with a < 0 < b, got {par!r}")
        _check_strip_numbers(k, st)
        if not _is_int(st.get("flank")) or not 0 <= st["flank"] < nf:
            raise PlanError(f"strips[{k}].flank must be a flank index (0..{nf - 1})")
        if not isinstance(st.get("collision"), bool):
            raise PlanError(f"strips[{k}].collision must be true or false")
        if st.get("tool") is not None:
            _check_tool(st["tool"], f"strips[{k}].tool")
    for key in ("max_error", "min_error", "elapsed_s"):
        if not _is_num(plan["summary"].get(key)):
            raise PlanError(f"summary.{key} must be a number")
    _check_error_order(plan["summary"])
    tol = plan.get("tolerance")
    if tol is not None and not (_is_num(tol) and 0 < tol <= L):
        raise PlanError(f"tolerance must be a finite number > 0 and at most rotor.outer_radius {L!r} (in the plan's "
                        f"length unit), got {tol!r}")
    return plan


def _check_strip_numbers(k, st):
    """A strip's shank radius (>= 0: a negative one dropped the shank from every check) and its reported errors
    (finite, max not below min)."""
    for key in ("shank_radius", "reported_max_error", "reported_min_error"):
        if not _is_num(st.get(key)):
            raise PlanError(f"strips[{k}].{key} must be a finite number")
    if st["shank_radius"] < 0:
        raise PlanError(f"strips[{k}].shank_radius must be >= 0 (0: no shank), got {st['shank_radius']!r}")
    if st["reported_max_error"] < st["reported_min_error"]:
        raise PlanError(f"strips[{k}].reported_max_error {st['reported_max_error']!r} is below "
                        f"reported_min_error {st['reported_min_error']!r}")


def _check_error_order(summary):
    if summary["max_error"] < summary["min_error"]:
        raise PlanError(f"summary.max_error {summary['max_error']!r} is below summary.min_error "
                        f"{summary['min_error']!r}")


def _check_tool(tool, name):
    """A ``tool`` object: its kind, and for a cone its shape numbers (alpha in (0, pi/2), 0 <= r1c < r2c)."""
    if not isinstance(tool, dict) or tool.get("kind") not in TOOL_KINDS:
        got = tool.get("kind") if isinstance(tool, dict) else tool
        raise PlanError(f"{name}.kind must be one of {TOOL_KINDS}, got {got!r}")
    shape_keys = [k for k in ("alpha", "r1c", "r2c") if tool.get(k) is not None]
    if tool["kind"] == "cone" and 0 < len(shape_keys) < 3:
        raise PlanError(f"{name} gives {', '.join(shape_keys)} but not all of alpha, r1c and r2c: a cone's shape "
                        "needs the three together (or none, where the strips' radii give it)")
    if tool["kind"] == "cone" and len(shape_keys) == 3:
        a, r1, r2 = tool["alpha"], tool["r1c"], tool["r2c"]
        if not (_is_num(a) and 0 < a < 0.5 * math.pi and _is_num(r1) and _is_num(r2) and 0 <= r1 < r2):
            raise PlanError(f"{name} must have 0 < alpha < pi/2 and 0 <= r1c < r2c, got alpha {a!r}, r1c {r1!r}, "
                            f"r2c {r2!r}")
    if "name" in tool and not isinstance(tool["name"], str):
        raise PlanError(f"{name}.name must be a string, got {tool['name']!r}")
    # the shape numbers the posts, feeds and clearance checks read (a null counts as absent, as in older plans)
    for key, least, strict in _TOOL_NUMBERS:
        v = tool.get(key)
        if v is None:
            continue
        if not _is_num(v) or v < least or (strict and v == least):
            raise PlanError(f"{name}.{key} must be a finite number {'>' if strict else '>='} {least:g}, got {v!r}")
        if key in _TOOL_MOST and v > _TOOL_MOST[key]:
            raise PlanError(f"{name}.{key} must be at most {_TOOL_MOST[key]:g}, got {v!r}")


# (field, least value, whether the least value itself is excluded) of the tools' shape numbers
_TOOL_NUMBERS = (("r1c", 0.0, False), ("r2c", 0.0, True), ("h", 0.0, True), ("shank_radius", 0.0, False),
                 ("shank_length", 0.0, False), ("max_diameter", 0.0, True), ("width", 0.0, True),
                 ("arbor_radius", 0.0, False), ("arbor_length", 0.0, False), ("centre_distance", 0.0, True),
                 ("swivel_deg", -90.0, False), ("rim", 0.0, True), ("r1", 0.0, False), ("r2", 0.0, True),
                 ("length", 0.0, True), ("engagement", 0.0, True))
# their largest values where one exists: a disc's swivel is an angle within a quarter turn, the engaged fraction
# of a free-form tool at most all of it
_TOOL_MOST = {"swivel_deg": 90.0, "engagement": 1.0}


def strip_tool(plan, k):
    """The tool of strip k: its own ``tool`` (plans with several tools) or the plan's."""
    st = plan["strips"][k]
    return st["tool"] if isinstance(st.get("tool"), dict) else plan.get("tool", {})


def plan_tools(plan):
    """The distinct tools of a plan in the order their strips first use them (the plan's tool when no strip
    carries its own): a list of (tool dict, [strip indices])."""
    out = []
    for k in range(len(plan.get("strips", []))):
        t = strip_tool(plan, k)
        for entry in out:
            if entry[0] == t:
                entry[1].append(k)
                break
        else:
            out.append((t, [k]))
    return out


def _check_strip_axes(k, st, size=None, centre=0.0, size_words="", centre_words=""):
    """A strip's axis and shank points: present, three finite numbers each, and, with the plan's ``size`` (a
    rotor's outer radius, a surface's diagonal), within :data:`RELATIVE_RANGE` of it from ``centre`` (the words
    name them in the message)."""
    if not isinstance(st, dict):
        raise PlanError(f"strips[{k}] must be an object")
    for key in ("axis_start", "axis_end", "shank_start", "shank_end"):
        if key not in st:
            raise PlanError(f"missing field strips[{k}].{key}")
        p = _vec(st[key], 3, f"strips[{k}].{key}")
        if size is not None and np.abs(p - centre).max() > RELATIVE_RANGE[1] * size:
            raise PlanError(f"strips[{k}].{key} {st[key]!r} is over {RELATIVE_RANGE[1]:g} times {size_words} from "
                            f"{centre_words}")


def _validate_mesh_plan(plan):
    """A free-form (Rajain et al. 2023) plan: ``surface`` instead of ``rotor``; strips carry ``rulings``."""
    for key in ("method", "length_unit", "surface", "tool", "strips", "summary"):
        if key not in plan:
            raise PlanError(f"missing field {key!r}")
    if plan["length_unit"] not in LENGTH_UNITS:
        raise PlanError(f"length_unit must be one of {LENGTH_UNITS}, got {plan['length_unit']!r}")
    surf = plan["surface"]
    if not isinstance(surf, dict) or surf.get("kind") != "mesh":
        raise PlanError(f"surface.kind must be 'mesh', got {surf.get('kind') if isinstance(surf, dict) else surf!r}")
    V = _numbers(surf.get("vertices", []), "surface.vertices", rows=lists_to_array)
    F = lists_to_array(surf.get("faces", []))
    if V.ndim != 2 or V.shape[1] != 3 or len(V) < 3 or not np.isfinite(V).all():
        raise PlanError("surface.vertices must be >= 3 finite [x, y, z] rows")
    if np.abs(V).max() > MAX_MESH_COORDINATE:
        raise PlanError(f"surface.vertices reach {np.abs(V).max():.6g}, over {MAX_MESH_COORDINATE:g} in the "
                        "plan's length unit")
    if (F.ndim != 2 or F.shape[1] != 3 or len(F) < 1 or not np.issubdtype(F.dtype, np.integer)
            or F.min() < 0 or F.max() >= len(V)):
        raise PlanError(f"surface.faces must be >= 1 rows of 3 vertex indices in 0..{len(V) - 1}")
    size = float(np.linalg.norm(np.ptp(V, axis=0)))
    area = np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    if not (size > 0 and area.max() > 1e-12 * size * size):
        raise PlanError(f"surface.faces have no area (the largest is {0.5 * area.max():.3g} on a surface "
                        f"{size:.6g} across): no surface to verify against")
    _check_tool(plan["tool"], "tool")
    if not isinstance(plan["strips"], list) or not plan["strips"]:
        raise PlanError("strips must be a list of at least one strip")
    reach = RELATIVE_RANGE[1] * size        # the strips' points: within a million surface sizes of it
    centre = 0.5 * (V.min(axis=0) + V.max(axis=0))
    for k, st in enumerate(plan["strips"]):
        _check_strip_axes(k, st, size, centre, f"the surface's size {size:.6g}", "it")
        R = _numbers(st.get("rulings", []), f"strips[{k}].rulings")
        if R.ndim != 3 or R.shape[1:] != (2, 3) or len(R) < 2 or not np.isfinite(R).all():
            raise PlanError(f"strips[{k}].rulings must be >= 2 finite [axis_start, axis_end] pairs")
        if np.abs(R - centre).max() > reach:
            raise PlanError(f"strips[{k}].rulings reach {np.abs(R - centre).max():.6g} from the surface, over "
                            f"{RELATIVE_RANGE[1]:g} times its size {size:.6g}")
        radii = _numbers(st.get("radii", []), f"strips[{k}].radii")
        if radii.ndim != 1 or len(radii) != 2 or not np.isfinite(radii).all() or (radii < 0).any():
            raise PlanError(f"strips[{k}].radii must be [r1_sphere, r2_sphere], both >= 0")
        if not radii.max() > 0:
            raise PlanError(f"strips[{k}].radii are both 0: a tool of no thickness")
        _check_strip_numbers(k, st)
        if not isinstance(st.get("collision"), bool):
            raise PlanError(f"strips[{k}].collision must be true or false")
        cols = st.get("columns")
        if not (isinstance(cols, list) and len(cols) == len(R) and all(_is_int(c) and c >= 0 for c in cols)):
            raise PlanError(f"strips[{k}].columns must hold one guiding-curve index >= 0 per ruling ({len(R)})")
    summ = plan["summary"]
    if not isinstance(summ, dict):
        raise PlanError("summary must be an object")
    for key in ("max_error", "min_error", "elapsed_s", "max_kink_deg", "mean_kink_deg"):
        if not _is_num(summ.get(key)):
            raise PlanError(f"summary.{key} must be a number")
    _check_error_order(summ)
    return plan


def rows_as_tuples(plan, slice_rows=16384):
    """A free-form plan's surface rows (vertices and faces) as tuples instead of lists, in place; returns the plan.

    For a plan kept parsed for the session (Blender keeps the last runs'): Python's garbage collector stops
    tracking a tuple of numbers, but goes through every list at each full collection -- a 200,000-triangle
    surface is 300,000 lists, 35 ms of every full collection for as long as the plan is kept (4.5 ms as tuples).
    The plan's JSON text is the same (``json.dumps`` writes a tuple as an array).  Converted a slice at a time,
    as a worker does it while Blender's interface runs."""
    surf = plan.get("surface") if isinstance(plan, dict) else None
    if isinstance(surf, dict):
        for key in ("vertices", "faces"):
            rows = surf.get(key)
            if isinstance(rows, list):
                out = []
                for i in range(0, len(rows), slice_rows):
                    out.extend(map(tuple, rows[i:i + slice_rows]))
                surf[key] = out
    return plan


def parse_plan_text(text, loads=json.loads):
    """``validate_plan(loads(text))`` with its surface rows as tuples (:func:`rows_as_tuples`), Python's garbage
    collector paused meanwhile (:func:`..collector.collector_paused`): a plan to keep parsed for the session,
    read without setting off full collections.  ``loads``: e.g. :func:`.json_pieces.loads_in_pieces` in a
    worker while Blender's interface runs."""
    with collector_paused():
        return rows_as_tuples(validate_plan(loads(text)))


def is_mesh_plan(plan):
    """True for a free-form plan (``surface`` of kind mesh, Rajain et al. 2023) rather than a helical rotor plan."""
    return isinstance(plan, dict) and plan.get("surface") is not None


def plan_text(plan):
    """The JSON text of a plan: one line per top-level field and per strip.  Readable in a text editor and
    written by the json module's C encoder (an indented dump goes through its pure-Python encoder: about
    five times slower on a plan with a 20,000-triangle surface), in pieces (:func:`.json_pieces.dumps_in_pieces`:
    an export writes it in a worker while Blender's interface runs)."""
    def field(key, value):
        if key == "strips" and isinstance(value, list) and value:
            return "{}: [\n{}\n ]".format(json.dumps(key), ",\n".join("  " + dumps_in_pieces(s) for s in value))
        return "{}: {}".format(json.dumps(key), dumps_in_pieces(value))

    return "{\n" + ",\n".join(" " + field(k, v) for k, v in plan.items()) + "\n}\n"


def write_plan(path, plan):
    """Validate and write a plan atomically (:func:`.files.atomic_write`): the file is either the old one or the
    complete new one."""
    validate_plan(plan)
    atomic_write(path, plan_text(plan))


def read_plan(path):
    """The plan in a flank-plan file, validated (:class:`PlanError` naming the file where it is not one).  The
    garbage collector is paused while the text is parsed (:func:`..collector.collector_paused`): the rows of a
    plan are lists that all stay alive, and a collector running meanwhile only walks them again and again (on a
    1.1 MB two-paths plan: 37 collections, one of them full, 22 ms of the 48 ms a read took)."""
    try:
        with open(path, encoding="utf-8-sig") as f, collector_paused():      # a byte-order mark, as some editors write
            plan = json.load(f)
    except json.JSONDecodeError as e:
        raise PlanError(f"{path}: not valid JSON ({e})") from None
    except RecursionError:
        raise PlanError(f"{path}: its JSON nests too deeply to be a plan") from None
    except UnicodeDecodeError:
        raise PlanError(f"{path}: not a text file (a flank-plan is JSON text; is it a mesh or a program?)") from None
    return validate_plan(plan)


def plan_surface(plan):
    """HelicalSurface of the plan's rotor (rotor frame, plan units); the same object for the same rotor
    (:func:`..geometry.helical_surface.shared_surface`), so a second report of a rotor's plans reuses the
    foot-point table the first one built."""
    from ..geometry.helical_surface import shared_surface
    from ..geometry.profile import SplineProfile

    r = plan["rotor"]
    return shared_surface(SplineProfile(r["profile"]), r["v0"], r["handedness"])


def flank_points(plan, k):
    """(P, 2) profile points of flank k (inclusive range, indices modulo the profile length)."""
    prof = np.asarray(plan["rotor"]["profile"], float)
    a, b = plan["rotor"]["flanks"][k]
    return prof[np.arange(a, b + 1) % len(prof)]
