"""What a single-flank plan covers and what it leaves, as the Blender Results panel and the residual mesh on the
rotor show it (no Blender).

Shares are of the target flank's profile arc length (0 at the flank's first profile point, 1 at its last),
from the verify engine's simulation (:func:`simulation.verify.verify_plan`): a profile point is within the
tolerance band when -overcut_tolerance <= deviation <= tolerance; the strip forming the machined surface there
is the engine's owner (``strips[k].covered_ranges``).  Each point stands for half of each profile edge next to
it, as in the plan's ``summary.covered_fraction``.

* :func:`strip_shares`: per strip, the first and last share where it forms the machined flank within the band,
  and its share of the flank;
* :func:`residual_rows`: the plan's ``summary.uncovered`` ranges as shares of the flank, with their kind,
  length and reason;
* :func:`residual_patches`: the flank surface over each uncovered range, swept along the rotor body and lifted
  off the flank by a small offset: a mesh that marks the residual on the rotor.
"""
import math

import numpy as np


def flank_arc(plan, flank):
    """(profile indices (P,), arc length (P,) from the flank start, point weights (P,)) of the plan's flank
    ``flank`` (an inclusive index range of the plan's profile that may wrap)."""
    prof = np.asarray(plan["rotor"]["profile"], float)
    n = len(prof)
    a, b = (int(v) for v in plan["rotor"]["flanks"][int(flank)])
    idx = np.arange(a, b + 1) % n
    seg = np.linalg.norm(np.diff(prof[idx], axis=0), axis=1)
    arc = np.r_[0.0, np.cumsum(seg)]
    w = 0.5 * (np.r_[seg, 0.0] + np.r_[0.0, seg])
    return idx, arc, w


def _deviation(plan, verification):
    dev = np.full(len(plan["rotor"]["profile"]), np.nan)
    for i, _, _, d in verification["deviation_profile"]:
        dev[int(i)] = np.inf if d is None else float(d)
    return dev


def strip_shares(plan, verification, flank, tolerance, overcut_tolerance):
    """Per strip of ``plan``: None where it forms none of flank ``flank`` within the tolerance band, else
    (first, last, share): the shares of the flank's arc length at its first and last profile point there and
    the share of the flank it machines within the band (``verification``: :func:`verify_plan` of the plan;
    tolerances in the plan's length unit)."""
    idx, arc, w = flank_arc(plan, flank)
    total = float(arc[-1]) if len(arc) and arc[-1] > 0 else 1.0
    wsum = float(w.sum()) if w.sum() > 0 else 1.0
    dev = _deviation(plan, verification)[idx]
    ok = np.isfinite(dev) & (dev <= float(tolerance)) & (dev >= -float(overcut_tolerance))
    owner = np.full(len(plan["rotor"]["profile"]), -1)
    for k, st in enumerate(verification.get("strips", [])):
        for a, b in st.get("covered_ranges", []):
            owner[int(a):int(b) + 1] = k
    own = owner[idx]
    out = []
    for k in range(len(plan["strips"])):
        mine = np.flatnonzero(ok & (own == k))
        if not len(mine):
            out.append(None)
            continue
        out.append((float(arc[mine[0]] / total), float(arc[mine[-1]] / total), float(w[mine].sum() / wsum)))
    return out


def residual_rows(plan, flank):
    """The plan's ``summary.uncovered`` ranges of flank ``flank`` for display: dicts with ``start`` / ``end``
    (shares of the flank's arc length), ``u_range`` (profile parameters), ``index_range``, ``kind``,
    ``length`` (plan units), ``max_deviation`` / ``min_deviation`` (plan units or None), ``reason`` (text,
    lengths in the plan's unit) and ``proven`` (the bound that no tool of the catalogue does better holds)."""
    unc = (plan.get("summary") or {}).get("uncovered") or []
    if not unc:
        return []
    _, arc, _ = flank_arc(plan, flank)
    total = float(arc[-1]) if len(arc) and arc[-1] > 0 else 1.0
    rows = []
    for ru in unc:
        a, b = (float(v) for v in ru.get("arc_range", (0.0, 0.0)))
        rows.append(dict(start=min(max(a / total, 0.0), 1.0), end=min(max(b / total, 0.0), 1.0),
                         u_range=[float(v) for v in ru.get("u_range", (math.nan, math.nan))],
                         index_range=[int(v) for v in ru.get("index_range", (0, 0))],
                         kind=str(ru.get("kind", "material")), length=float(ru.get("length", b - a)),
                         max_deviation=ru.get("max_deviation"), min_deviation=ru.get("min_deviation"),
                         reason=str(ru.get("reason", "")),
                         proven=bool((ru.get("bound") or {}).get("proven", False))))
    return rows


def residual_u_ranges(rows, period, n_profile, u_range):
    """The profile parameter range each residual row marks: its profile points widened by half a profile step
    on each side (a range of one point is still a visible band), clipped to the flank's ``u_range``."""
    half = 0.5 * float(period) / int(n_profile)
    lo, hi = (float(v) for v in u_range)
    out = []
    for r in rows:
        a, b = r["u_range"]
        if not (math.isfinite(a) and math.isfinite(b)):
            out.append(None)
            continue
        out.append((max(lo, min(a, b) - half), min(hi, max(a, b) + half)))
    return out


def residual_patches(surface, u_ranges, z_range, offset, n_z=24, u_step=None):
    """A mesh of the flank surface of ``surface`` (:class:`HelicalSurface`, rotor frame) over each parameter range
    in ``u_ranges`` (None entries are skipped), swept along the rotor axis over ``z_range`` in ``n_z`` rings and
    lifted off the flank by ``offset`` along its outward normal.  ``u_step``: the largest parameter step across a
    range (default 1/200 of the profile's period).  Returns (verts (V, 3), triangles (F, 3) int, range index per
    vertex (V,) int)."""
    from ..geometry.screw import screw_motion

    prof = surface.profile
    step = float(u_step) if u_step is not None else float(prof.period) / 200.0
    z0, z1 = (float(v) for v in z_range)
    ts = np.linspace(z0, z1, max(2, int(n_z))) / float(surface.v0)
    verts, faces, which = [], [], []
    base = 0
    for k, ur in enumerate(u_ranges):
        if ur is None:
            continue
        a, b = ur
        m = max(2, int(math.ceil((b - a) / step)) + 1)
        u = np.linspace(a, b, m)
        xy = prof.eval(u) + float(offset) * prof.outward_normal(u)
        V = screw_motion(np.c_[xy, np.zeros(m)][:, None, :], ts[None, :], surface.v0, surface.hand)   # (m, n_t, 3)
        nt = len(ts)
        q = base + np.arange(m - 1)[:, None] * nt + np.arange(nt - 1)[None, :]
        faces.append(np.concatenate([np.stack([q, q + nt, q + nt + 1], -1).reshape(-1, 3),
                                     np.stack([q, q + nt + 1, q + 1], -1).reshape(-1, 3)]))
        verts.append(V.reshape(-1, 3))
        which.append(np.full(m * nt, k))
        base += m * nt
    if not verts:
        return np.zeros((0, 3)), np.zeros((0, 3), int), np.zeros(0, int)
    return np.concatenate(verts), np.concatenate(faces).astype(int), np.concatenate(which).astype(int)
