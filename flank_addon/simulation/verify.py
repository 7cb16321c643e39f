"""Verify a flank-plan/1 file by the independent sweep simulation (:mod:`sweep`).

For every design point of the target flanks: the signed deviation of the simulated machined surface
(positive = material left, negative = overcut, +inf = no tool reaches it within the search range).
Over the whole rotor profile (all lobes): gouges, i.e. points the swept tools or shanks reach more
than the tolerance below the design surface.  Reported errors of the planners are not used.
"""
import math
import time
from dataclasses import dataclass

import numpy as np

from ..io.plan import validate_plan
from ..geometry.profile import SplineProfile
from .sweep import first_least, machined_deviation, strip_owners, strip_solids, tool_distances


def _ranges(mask):
    """Inclusive [start, end] index runs where mask is true."""
    idx = np.flatnonzero(mask)
    if not len(idx):
        return []
    breaks = np.flatnonzero(np.diff(idx) > 1)
    starts = np.r_[idx[0], idx[breaks + 1]]
    ends = np.r_[idx[breaks], idx[-1]]
    return [[int(a), int(b)] for a, b in zip(starts, ends)]


def _min_distance(tools, q, v0, hand, cutoff, tie=0.0):
    """min over tools of min(D, cutoff) and the tool attaining it, the first of tools within ``tie`` of each
    other (cutoff lets the time windows cull)."""
    d = tool_distances(tools, q, v0, hand, cutoff)
    return d.min(axis=0), first_least(d, tie)


@dataclass
class SweptTargets:
    """A plan's strips swept past the rotor's profile points (:func:`sweep_targets`).  Per profile point
    (n,): ``deviation`` signed (+ material left, - overcut; +inf beyond the search range, NaN where not
    simulated), ``owner`` the strip that forms the machined surface there (-1: none), ``least`` its
    distance; ``target`` and ``flank_of`` the target flanks' points and their flank numbers (-1 elsewhere).
    ``tools`` are the distinct solids, ``first`` the strip each one stands for (:func:`sweep.strip_solids`)."""
    profile: np.ndarray
    normals: np.ndarray
    target: np.ndarray
    flank_of: np.ndarray
    deviation: np.ndarray
    owner: np.ndarray
    least: np.ndarray
    tools: list
    first: np.ndarray


def profile_normals(rotor):
    """A plan's rotor profile (n, 2) and its outward unit normals (n, 2) at the points, from the profile's
    periodic spline; a profile that is not a CCW point list without repeated points is refused."""
    prof = np.asarray(rotor["profile"], float)
    spline = SplineProfile(prof)
    if len(spline.points) != len(prof) or not np.allclose(spline.points, prof):
        raise ValueError("rotor.profile must be a CCW point list without repeated points")
    return prof, spline.outward_normal(spline.knots[:-1])


def sweep_targets(plan, search=None, all_points=False, progress=None):
    """The sweep simulation of a plan's strips on the target flanks' points (every profile point with
    ``all_points``), all strips in one sweep: a point looks only at the strips that can reach it, a strip
    that repeats an earlier one is measured once, and each point goes to the first strip within 1e-12 R of
    the least distance (two strips that sweep the same surface give distances equal up to rounding).
    ``search``: how far from the profile a deviation is sought (default 0.1 R, at most R; beyond it +inf, except
    inside the swept region, :func:`.sweep.machined_deviation`).
    ``verify`` and the double-flank planner's simulated errors both ask it, so they report the same
    numbers.  Returns :class:`SweptTargets`."""
    rotor = plan["rotor"]
    prof, normals = profile_normals(rotor)
    n = len(prof)
    v0, hand = float(rotor["v0"]), rotor["handedness"]
    outer = float(rotor["outer_radius"])
    search = checked_length(search, 0.1 * outer, "search range", most=outer)
    tools, first = strip_solids(plan["strips"])
    target = np.zeros(n, bool)
    flank_of = np.full(n, -1)
    for f in plan["target_flanks"]:
        a, b = rotor["flanks"][f]
        idx = np.arange(a, b + 1) % n
        target[idx] = True
        flank_of[idx] = f
    deviation = np.full(n, np.nan)
    tie = 1e-12 * float(rotor["outer_radius"])
    owner, least = np.full(n, -1), np.full(n, np.inf)
    ti = np.flatnonzero(target)
    if tools and all_points:
        deviation, owner, least = machined_deviation(tools, prof, normals, v0, hand, max_deviation=search,
                                                     progress=progress, owner_tie=tie)
    elif tools and len(ti):
        deviation[ti], owner[ti], least[ti] = machined_deviation(
            tools, prof[ti], normals[ti], v0, hand, max_deviation=search, progress=progress, owner_tie=tie)
    return SweptTargets(profile=prof, normals=normals, target=target, flank_of=flank_of, deviation=deviation,
                        owner=strip_owners(owner, first), least=least, tools=tools, first=first)


def checked_length(value, default, name, most=None):
    """A verification's length setting as a float (``default`` when None): a finite number > 0, at most ``most``
    when given, else ValueError naming it."""
    if value is None:
        return float(default)
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} {value!r} must be a finite number > 0 (in the plan's length unit)")
    if most is not None and v > most:
        raise ValueError(f"{name} {value!r} is above the rotor's outer radius {most:g}, its limit")
    return v


def checked_tolerance(tolerance, default, most=None):
    """A verification's tolerance as a float (``default`` when None): a finite number > 0 (a NaN would count no
    gouge at all, a negative one every point), at most ``most`` when given."""
    return checked_length(tolerance, default, "tolerance", most)


def verify_plan(plan, tolerance=None, search=None, all_points=False, progress=None):
    """Simulate a plan; return a JSON-ready dict (see module doc and README).

    With ``all_points`` the deviation is also simulated on every profile point (all lobes, not only
    the target flanks) and returned as ``deviation_all`` (None where no tool reaches within
    ``search``): what the Blender operator paints on the rotor.  ``progress``: None or
    ``progress(fraction, message)``; returning False cancels (:class:`progress.Cancelled`)."""
    from ..progress import reporter

    report = reporter(progress)
    report(0.0, "reading the plan")
    validate_plan(plan)
    t0 = time.perf_counter()
    rotor = plan["rotor"]
    v0, hand = float(rotor["v0"]), rotor["handedness"]
    outer = float(rotor["outer_radius"])
    tol = checked_tolerance(tolerance, 1e-3 * outer, most=outer)
    strips = plan["strips"]
    swept = sweep_targets(plan, search, all_points=all_points, progress=reporter(progress, 0.02, 0.8))
    prof, normals, target, flank_of = swept.profile, swept.normals, swept.target, swept.flank_of
    tools, first, owner_at, least_at = swept.tools, swept.first, swept.owner, swept.least
    n, tie, ti = len(prof), 1e-12 * outer, np.flatnonzero(target)
    deviation = swept.deviation
    if tools and all_points:
        dev_all = deviation.copy()
        deviation[~target] = np.nan
    # gouges anywhere on the rotor: the swept region reaches tol below the design surface
    report(0.8, "gouges")
    gouges = []
    if tools:
        below = np.c_[prof - tol * normals, np.zeros(n)]
        d_all, which = _min_distance(tools, below, v0, hand, 0.0, tie)
        which = first[which]
        hit = np.flatnonzero(d_all < 0)
        if len(hit):  # tool or shank: only the few gouged points need the distinction (and the bare tools)
            tool_only, _ = strip_solids(strips, with_shank=False)
            d_tool, _ = _min_distance(tool_only, below[hit], v0, hand, 0.0)
        for j, i in enumerate(hit):
            gouges.append({"index": int(i), "x": float(prof[i, 0]), "y": float(prof[i, 1]),
                           "strip": int(which[i]), "by": "tool" if d_tool[j] < 0 else "shank",
                           "target": bool(target[i])})

    # per strip: where it forms the machined surface (the simulation met it there), and its errors there
    report(0.9, "strips")
    per_strip = []
    ok = target & np.isfinite(deviation)
    own = np.where(ok & (least_at < tol), owner_at, -1)
    for k, s in enumerate(strips):
        mine = own == k
        dev = deviation[mine]
        per_strip.append({
            "strip": k, "flank": s["flank"], "covered_ranges": _ranges(mine),
            "max_error": float(dev.max()) if len(dev) else None,
            "min_error": float(dev.min()) if len(dev) else None,
            "gouge_points": sum(1 for g in gouges if g["strip"] == k),
            "collision": any(g["strip"] == k and not g["target"] for g in gouges),
            "reported_max_error": s["reported_max_error"], "reported_min_error": s["reported_min_error"],
        })
        if isinstance(s.get("tool"), dict):          # a plan with several tools: which one milled here
            per_strip[-1]["tool"] = s["tool"].get("name", s["tool"].get("kind"))

    flanks = []
    for f in plan["target_flanks"]:
        m = flank_of == f
        dev = deviation[m]
        fin = dev[np.isfinite(dev)]
        flanks.append({
            "flank": f,
            "max_undercut": float(max(fin.max(), 0.0)) if len(fin) else None,
            "max_overcut": float(min(fin.min(), 0.0)) if len(fin) else None,
            "uncovered_ranges": _ranges(m & ~(deviation <= tol)),
        })
    fin = deviation[target & np.isfinite(deviation)]
    out = {
        "schema": "flank-verify/1",
        "length_unit": plan["length_unit"],
        "tolerance": tol,
        "max_undercut": float(max(fin.max(), 0.0)) if len(fin) else None,
        "max_overcut": float(min(fin.min(), 0.0)) if len(fin) else None,
        "gouge_points": gouges,
        "flanks": flanks,
        "strips": per_strip,
        "deviation_profile": [[int(i), float(prof[i, 0]), float(prof[i, 1]),
                               float(deviation[i]) if np.isfinite(deviation[i]) else None] for i in ti],
        "elapsed_s": time.perf_counter() - t0,
    }
    if all_points:
        if not tools:
            dev_all = np.full(n, np.inf)
        out["deviation_all"] = [float(d) if np.isfinite(d) else None for d in dev_all]
    return out


# RGBA of the deviation classes, shared by Blender and the pictures
DEVIATION_COLORS = {
    "gouge": (0.85, 0.10, 0.10, 1.0),      # cut deeper than the tolerance
    "ok": (0.15, 0.70, 0.25, 1.0),         # within +- tolerance
    "stock": (0.15, 0.35, 0.90, 1.0),      # material left beyond the tolerance
    "untouched": (0.60, 0.60, 0.60, 1.0),  # no tool within the search range
}


def deviation_colors(deviation, tolerance):
    """(N, 4) RGBA for signed deviations (N,): red gouge < -tol, green within tol, blue stock > tol,
    grey where not reached (nan or inf).  Inside each band the shade deepens with |deviation|."""
    d = np.asarray(deviation, float)
    tol = float(tolerance)
    rgba = np.empty(d.shape + (4,))
    rgba[:] = DEVIATION_COLORS["untouched"]
    fin = np.isfinite(d)
    for key, m in (("gouge", fin & (d < -tol)), ("ok", fin & (np.abs(d) <= tol)), ("stock", fin & (d > tol))):
        rgba[m] = DEVIATION_COLORS[key]
    # shade: 1 at the band edge, 0.55 at 10x tolerance and beyond
    depth = np.clip((np.abs(np.nan_to_num(d, posinf=0.0, neginf=0.0)) / tol - 1.0) / 9.0, 0.0, 1.0)
    shade = np.where(fin & (np.abs(np.nan_to_num(d)) > tol), 1.0 - 0.45 * depth, 1.0)
    rgba[..., :3] *= shade[..., None]
    return rgba


def values_on_rotor(plan, points, values):
    """Transfer per-profile-point ``values`` (n,) to 3D points (N, 3) in the plan's rotor frame:
    each point is screwed along its helix into z = 0 and takes the nearest profile point's value
    (the deviation of a helical motion is the same along every helix)."""
    from scipy.spatial import cKDTree

    from ..geometry.screw import screw_to_plane

    r = plan["rotor"]
    xy = screw_to_plane(np.asarray(points, float), float(r["v0"]), r["handedness"])
    _, idx = cKDTree(np.asarray(r["profile"], float)).query(xy)
    return np.asarray(values, float)[idx]


def world_to_rotor(plan, points_world):
    """Plan-model frame points (N, 3) -> rotor frame (inverse of rotor.to_world)."""
    T = np.asarray(plan["rotor"]["to_world"], float)
    inv = np.linalg.inv(T)
    p = np.asarray(points_world, float)
    return p @ inv[:3, :3].T + inv[:3, 3]
