"""What a single-flank plan leaves: the verified share of the flank within tolerance and the uncovered ranges,
each with its reason (from what the planner tried there) and, where the geometry proves it, the bound that no
tool of the catalogue can do better (:mod:`.reach`).

Covered fraction: the sweep simulation (:func:`simulation.verify.verify_plan`) gives the signed machined
deviation at every profile point of the target flank (the plan's rotor profile); a point is within tolerance
when -overcut_tolerance <= deviation <= tolerance.  Each point stands for half of each profile edge next to
it (arc length), so ``covered_fraction`` is the share of the flank profile's arc length within tolerance.
The planner's own estimate (its 500-sample interval model) is not used.
"""
import numpy as np

# categories of what the planner found at a seed of an uncovered range, worst first
COLLIDES, HELD_OFF, OVERCUTS, LEAVES, NO_POSE, COVERS = "collides", "held off", "overcuts", "leaves", "no pose", "covers"
UNREACHABLE = "unreachable"       # the bound of :mod:`.reach` excludes the tool's tip sphere at the seed


def flank_points(plan, flank):
    """(indices (P,) into the plan profile, parameters u (P,), arc length (P,) from the flank start, arc
    weights (P,)) of the plan's flank ``flank`` (inclusive index range, may wrap)."""
    rot = plan["rotor"]
    prof = np.asarray(rot["profile"], float)
    n = len(prof)
    a, b = rot["flanks"][flank]
    raw = np.arange(a, b + 1)
    idx = raw % n
    P = prof[idx]
    seg = np.linalg.norm(np.diff(P, axis=0), axis=1)
    arc = np.r_[0.0, np.cumsum(seg)]
    w = 0.5 * (np.r_[seg, 0.0] + np.r_[0.0, seg])
    return idx, raw.astype(float), arc, w


def verified_coverage(plan, ver, flank, tolerance, overcut_tolerance, period=None):
    """Covered fraction and uncovered runs of flank ``flank`` from a verification ``ver`` of ``plan``.

    Returns (fraction, runs): runs are dicts with ``index_range`` (plan profile indices, inclusive),
    ``u_range`` (profile parameters, when ``period`` (the profile's parameter period) is given: index i is
    parameter i period / n), ``arc_range`` (from the flank start, each end half an edge out), ``length``,
    ``max_deviation`` / ``min_deviation`` (finite ones; None if none) and ``kind``: "material" (more than the
    tolerance left), "overcut" (deeper than the overcut tolerance) or "unreached" (no tool within the
    simulation's search range)."""
    idx, raw, arc, w = flank_points(plan, flank)
    n = len(plan["rotor"]["profile"])
    dev = np.full(n, np.nan)
    for i, _, _, d in ver["deviation_profile"]:
        dev[i] = np.inf if d is None else d
    d = dev[idx]
    ok = np.isfinite(d) & (d <= tolerance) & (d >= -overcut_tolerance)
    total = float(w.sum())
    frac = float(w[ok].sum() / total) if total > 0 else 0.0
    runs = []
    bad = np.flatnonzero(~ok)
    if len(bad):
        br = np.flatnonzero(np.diff(bad) > 1)
        for s, e in zip(np.r_[bad[0], bad[br + 1]], np.r_[bad[br], bad[-1]]):
            dd = d[s:e + 1]
            fin = dd[np.isfinite(dd)]
            lo = arc[s] - (0.5 * (arc[s] - arc[s - 1]) if s > 0 else 0.0)
            hi = arc[e] + (0.5 * (arc[e + 1] - arc[e]) if e + 1 < len(arc) else 0.0)
            kind = "overcut" if len(fin) and fin.min() < -overcut_tolerance else (
                "material" if len(fin) else "unreached")
            run = {"index_range": [int(raw[s]), int(raw[e])], "arc_range": [float(lo), float(hi)],
                   "length": float(hi - lo), "max_deviation": float(fin.max()) if len(fin) else None,
                   "min_deviation": float(fin.min()) if len(fin) else None, "kind": kind}
            if period is not None:
                run["u_range"] = [float(raw[s] * period / n), float(raw[e] * period / n)]
            runs.append(run)
    return frac, runs


def flank_relation(f, target):
    """How flank ``f`` relates to the target flank (flank 2k and 2k + 1 form valley k)."""
    if f == target:
        return "its own flank"
    if f // 2 == target // 2:
        return "the opposite flank"
    return f"flank {f}"


def flank_index(u, flank_ranges, period):
    """Index of the flank holding profile parameter u (modulo the period), or -1."""
    for k, (a, b) in enumerate(flank_ranges):
        w = (float(u) - a) % period
        if w <= (b - a) + 1e-12 * period:
            return k
    return -1


def summarize_attempts(entries, tol, unit):
    """The reason one tool left a range, from its seed log entries there (:func:`explain_range`)."""
    if not entries:
        return {"status": "not tried", "text": "no seed of this tool fell here (the range is narrower than the "
                                               "spacing of its seeds, or it was given up after repeated tries)"}
    held = [e for e in entries if e["status"] == COVERS]
    entries = [e for e in entries if e["status"] != COVERS]
    if not entries:
        return {"status": COVERS, "text": f"the planner's flank samples next to it are held ({len(held)} seed(s)); "
                                          "the simulation finds the range between them"}
    cats = [e["status"] for e in entries]
    unr = [e for e in entries if e["status"] == UNREACHABLE]
    sel = [e for e in entries if e["status"] in (COLLIDES, HELD_OFF)]
    if len(sel) + len(unr) == len(entries):
        parts = sorted({(e.get("part") or "tool", e.get("relation") or "the rotor") for e in sel})
        out = {"status": COLLIDES, "parts": [list(x) for x in parts], "unreachable_seeds": len(unr)}
        txt = []
        if sel:
            depths = [e["depth"] for e in sel if e.get("depth") is not None]
            what = "; ".join(f"{p} with {r}" for p, r in parts)
            d = max(depths) if depths else None
            dmin = min(depths) if depths else None
            t = f"every pose of the tool that touches the flank here collides: {what}"
            if d is not None:
                t += (f", by at least {dmin:.3g} {unit} (the least entry over the orientations tried at each "
                      f"seed: {dmin:.3g}..{d:.3g})")
            out.update(depth_min=dmin, depth_max=d)
            txt.append(t)
        if unr:
            dmin = min(e["depth"] for e in unr)
            out.update(proven_depth_min=dmin)
            txt.append(f"at {len(unr)} of its seeds its tip sphere (radius {unr[0]['radius']:.3g} {unit}) is proven "
                       f"unable to come within the tolerance without entering the rotor (by at least {dmin:.3g} "
                       f"{unit})")
        out["text"] = "; ".join(txt)
        return out
    if all(c == OVERCUTS for c in cats):
        d = max(e.get("depth") or 0.0 for e in entries)
        return {"status": OVERCUTS, "depth_max": d,
                "text": f"the tool's strips here would overcut the flank by up to {d:.3g} {unit}"}
    if all(c == NO_POSE for c in cats):
        return {"status": NO_POSE, "text": "no pose of the tool touches the flank here with its tip nearer to the "
                                           "rotor axis than its shank (Bizzarri, Bo & Bartoň Eq. (24))"}
    left = [e["deviation"] for e in entries if e["status"] == LEAVES and e.get("deviation") is not None]
    if left:
        m = min(left)
        return {"status": LEAVES, "deviation_min": m,
                "text": f"the tool's strips leave more than the tolerance {tol:.3g} here (at least {m:.3g} {unit} "
                        "at the seeds)"}
    counts = {c: cats.count(c) for c in set(cats)}
    return {"status": "mixed", "counts": counts,
            "text": "the seeds here ended " + ", ".join(f"{v} x {k}" for k, v in sorted(counts.items()))}


def explain_range(run, logs, tool_names, tol, unit, margin, named=True):
    """Per tool (``tool_names``: {tool index: name} of the tools tried), why range ``run`` (a :func:`verified_coverage` run with ``u_range``) stayed uncovered, from the
    planner's seed logs (dicts with tool index, u, status, ...); the combined text."""
    a, b = run["u_range"]
    per_tool = []
    for ti, name in tool_names.items():
        ent = [e for e in logs if e["tool"] == ti and a - margin <= e["u"] <= b + margin]
        s = summarize_attempts(ent, tol, unit)
        s["tool"] = name
        s["seeds"] = len(ent)
        per_tool.append(s)
    tried = [s for s in per_tool if s["status"] not in ("not tried", COVERS)] or \
        [s for s in per_tool if s["status"] != "not tried"]
    if tried and all(s["status"] == COLLIDES for s in tried):
        rel = sorted({r for s in tried for _, r in s.get("parts", [])})
        who = "every tool tried" if len(tried) > 1 else (f"the tool ({tried[0]['tool']})" if named else "the tool")
        if rel:
            txt = f"{who} collides with {' and '.join(rel)} here"
        else:
            txt = f"{who} is proven unable to reach here"
        each = []
        for s in tried:
            bits = []
            if s.get("depth_min") is not None:
                bits.append(f"{', '.join(f'{p} with {r}' for p, r in s.get('parts', []))} by at least "
                            f"{s['depth_min']:.3g} {unit}")
            if s.get("unreachable_seeds"):
                bits.append(f"proven unreachable at {s['unreachable_seeds']} seed(s), by at least "
                            f"{s['proven_depth_min']:.3g} {unit}")
            each.append(f"{s['tool']}: {'; '.join(bits)}" if named else "; ".join(bits))
        if each:
            txt += " (" + "; ".join(each) + ")"
        return per_tool, txt
    if not tried:
        return per_tool, per_tool[0]["text"] if per_tool else "nothing was tried here"
    return per_tool, "; ".join(f"{s['tool']}: {s['text']}" if named else s["text"] for s in tried)
