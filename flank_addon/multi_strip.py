"""Multi-strip single-flank milling of one helical flank with a given cone, to a tolerance
(s000 §5-6: optimised candidate strips, envelope coverage, minimum strip set, global collisions).

Pipeline of :func:`plan_single_flank`:

1. candidates: for profile parameters of the flank, the §5.1 seeds of :mod:`single_flank` (line
   contact at hyperbolic points, tangential contact elsewhere), optimised by Phi1 (Eq. 25) or Phi3
   (Eq. 31), by default in the hard non-overcutting mode (Eq. 30 style);
2. global collision (§5.5, :mod:`collision`): tool and shank against every lobe of the rotor;
   colliding candidates are dropped and listed with where they collide;
3. coverage (:mod:`strip_cover`): the flank interval each candidate's envelope holds within
   [-eps_over, eps], a minimum-cardinality interval cover, new seeds in the gaps (s000 §6.1) until
   the flank is covered or the rounds run out; what stays uncovered is reported as ranges;
4. the plan (flank-plan/1) of the chosen strips, simulated with the :mod:`verify` engine so the
   reported errors are the machined ones, and the kink angles at the junctions of neighbouring
   strips (s000 §7, s003's G1 idea).
"""
import math
import time
from dataclasses import dataclass, field

import numpy as np

from .cone import ConeTool
from .single_flank import PoseEvaluator, candidate_strips, initial_positions, single_flank_plan


@dataclass
class SingleFlankResult:
    """plan: flank-plan/1 dict; strips: the chosen :class:`single_flank.CandidateStrip` in flank
    order; candidates: every optimised candidate (collision-free or not); collisions: per colliding
    candidate {"u", "collisions": [...]}; uncovered: flank parameter ranges outside the tolerance
    band; junctions: per neighbouring pair the kink angles (degrees) where their envelopes meet;
    deviation: (u (N,), deviation (N,)) of the chosen strips along the flank profile (s000 Fig. 11c);
    verify: the sweep simulation of the plan (:func:`verify.verify_plan`); timings in seconds."""
    plan: dict
    strips: list
    candidates: list
    collisions: list
    uncovered: list
    junctions: list
    deviation: tuple
    verify: dict
    rounds: list
    timings: dict = field(default_factory=dict)

    @property
    def complete(self):
        return not self.uncovered


def _flank_index_ranges(surface, flank_ranges, n):
    per = surface.profile.period
    return [(int(round(a / per * n)), int(round(b / per * n))) for a, b in flank_ranges]


def plan_single_flank(surface, flank_ranges, flank, tool, tolerance, overcut_tolerance=None, n_seeds=18,
                      objective="phi1", mode="hard", max_rounds=4, n_profile=2048, n_cover=500,
                      to_world=None, length_unit="R", check_collisions=True, z_range=None):
    """Plan strips of the cone ``tool`` (:class:`cone.ConeTool`) on flank index ``flank`` so the
    machined flank stays within [-overcut_tolerance, tolerance] of the design (signed, + = stock).

    surface: :class:`HelicalSurface`; flank_ranges: the rotor's flank parameter ranges
    (``Rotor.flanks`` or ``RotorAnalysis`` flanks); n_seeds: first-round seeds (uniform along the
    flank profile); objective 'phi1' | 'phi3'; mode 'hard' (no overcut along the axis) | 'weighted'
    (w = 100, Remark 5.1); overcut_tolerance defaults to 1e-6 R.  Returns :class:`SingleFlankResult`."""
    from .collision import check_collisions as collide
    from .strip_cover import adaptive_cover, junction_kinks
    from .verify import verify_plan

    t0 = time.perf_counter()
    if not isinstance(tool, ConeTool):
        raise ValueError(f"tool must be a ConeTool, got {type(tool).__name__}")
    R = float(surface.outer_radius)
    tol = float(tolerance)
    if not (math.isfinite(tol) and 0 < tol < 0.5 * R):
        raise ValueError(f"tolerance {tolerance} is outside the limits (0, {0.5 * R:g}) (half the outer radius)")
    eps_over = 1e-6 * R if overcut_tolerance is None else float(overcut_tolerance)
    if not (math.isfinite(eps_over) and 0 <= eps_over < 0.5 * R):
        raise ValueError(f"overcut tolerance {overcut_tolerance} is outside the limits [0, {0.5 * R:g})")
    if not 0 <= int(flank) < len(flank_ranges):
        raise ValueError(f"flank {flank} does not exist: the rotor has flanks 0..{len(flank_ranges) - 1}")
    if not 1 <= int(n_seeds) <= 400:
        raise ValueError(f"seeds {n_seeds} is outside the limits 1..400")
    if objective not in ("phi1", "phi3"):
        raise ValueError(f"objective {objective!r} is not one of phi1, phi3")
    if mode not in ("hard", "weighted"):
        raise ValueError(f"mode {mode!r} is not one of hard, weighted")
    flank = int(flank)
    u_range = tuple(float(v) for v in flank_ranges[flank])
    ev = PoseEvaluator(surface, u_range, tool)
    prof_pts = surface.profile.sample(n_profile)
    idx_ranges = _flank_index_ranges(surface, flank_ranges, n_profile)
    timings = {"candidates": 0.0, "collision": 0.0}
    all_cands, collisions = [], []

    def make_candidates(us):
        ts = time.perf_counter()
        per = initial_positions(surface, u_range, tool, u=np.asarray(us, float), feet=ev.feet)
        seeds = [c[0] for c in per if c]
        cands = candidate_strips(surface, u_range, tool, seeds=seeds, objective=objective, mode=mode,
                                 evaluator=ev, flank=flank) if seeds else []
        timings["candidates"] += time.perf_counter() - ts
        if not cands:
            return []
        ts = time.perf_counter()
        ok = [True] * len(cands)
        if check_collisions:
            reps = collide([c.pose for c in cands], prof_pts, surface.v0, surface.handedness, idx_ranges,
                           target_flanks=(flank,), tolerance=eps_over, z_range=z_range, model="spheres")
            for j, (c, rep) in enumerate(zip(cands, reps)):
                if rep.collides:
                    ok[j] = False
                    collisions.append({"u": float(c.seed.u), "collisions": rep.collisions})
        timings["collision"] += time.perf_counter() - ts
        all_cands.extend(cands)
        out = []
        for c, good in zip(cands, ok):
            if good:
                c.pose.candidate = c          # the cover hands poses back: keep the way to the strip
                out.append(c.pose)
        return out

    us0 = np.linspace(u_range[0], u_range[1], int(n_seeds) + 2)[1:-1]
    ts = time.perf_counter()
    cover = adaptive_cover(make_candidates, surface, u_range, tol, eps_over, seeds=list(us0),
                           max_rounds=max_rounds, n=n_cover)
    timings["cover"] = time.perf_counter() - ts - timings["candidates"] - timings["collision"]
    # flank order: by the start of each chosen pose's first covered interval
    order = sorted(range(len(cover.poses)),
                   key=lambda i: min((iv[0] for iv in cover.intervals[i]), default=math.inf))
    chosen = [cover.poses[i].candidate for i in order]
    uncovered = [tuple(map(float, g)) for g in cover.gaps] + [tuple(map(float, g)) for g in cover.uncovered]

    ts = time.perf_counter()
    junctions = []
    for a, b in zip(chosen[:-1], chosen[1:]):
        js = junction_kinks(a.pose, b.pose, surface, u_range, n=n_cover, samples=cover.samples)
        junctions.append([{"u": float(j.u), "kink_deg": float(j.kink_deg)} for j in js])
    timings["junctions"] = time.perf_counter() - ts

    plan = single_flank_plan(surface, flank_ranges, flank, chosen, tool, to_world=to_world,
                             length_unit=length_unit, n_profile=n_profile,
                             method=f"single-flank-cone-{objective}-{mode}")
    plan["tolerance"] = tol
    plan["overcut_tolerance"] = eps_over
    ts = time.perf_counter()
    ver = verify_plan(plan, tolerance=eps_over)
    timings["verify"] = time.perf_counter() - ts
    # reported errors = the simulated ones (per strip where it forms the machined surface)
    for st, vs in zip(plan["strips"], ver["strips"]):
        if vs["max_error"] is not None:
            st["reported_max_error"], st["reported_min_error"] = vs["max_error"], vs["min_error"]
        st["collision"] = bool(vs["collision"])
    from .plan import summarize
    timings["total"] = time.perf_counter() - t0
    plan["summary"] = summarize(plan["strips"], timings["total"])
    fin = ver["max_undercut"], ver["max_overcut"]
    if fin[0] is not None:
        plan["summary"]["max_error"], plan["summary"]["min_error"] = fin[0], fin[1]
    plan["summary"]["uncovered_ranges"] = [list(g) for g in uncovered]
    plan["summary"]["junction_kinks_deg"] = [[j["kink_deg"] for j in js] for js in junctions]
    return SingleFlankResult(plan=plan, strips=chosen, candidates=all_cands, collisions=collisions,
                             uncovered=uncovered, junctions=junctions,
                             deviation=(cover.samples.u, cover.deviation), verify=ver, rounds=cover.rounds,
                             timings=timings)


def envelope_strip(candidate, surface, u_range, z_range=(0.0, 1.0), n_s=60, n_t=48, evaluator=None):
    """The envelope strip of one strip's cone (s000 Eqs. 11-14): the characteristic curve of the
    pose under the rotor's screw motion, swept over ``z_range`` (rotor frame).

    candidate: :class:`single_flank.CandidateStrip` (or anything with ``params`` and ``pose``).
    Returns (verts (K*n_t, 3), faces (F, 3) int, deviation (K*n_t,)): K <= n_s characteristic points
    where the characteristic is real, their signed distance to the flank (+ = material left, in the
    rotor's length unit; constant along each helix, so exact at every vertex)."""
    from .screw import screw_motion

    ev = evaluator or PoseEvaluator(surface, u_range, candidate.pose.tool)
    X = np.atleast_2d(candidate.params)
    s = np.linspace(0.0, 1.0, n_s)
    br = ev.branch(X)
    f, _, info = ev.char_distances(X, br, s, key=None)
    ok = info["real"][0]
    c, dev = info["points"][0][ok], f[0][ok]
    if len(c) < 2:
        return np.zeros((0, 3)), np.zeros((0, 3), int), np.zeros(0)
    ts = np.linspace(z_range[0], z_range[1], n_t) / surface.v0
    V = screw_motion(c[:, None, :], ts[None, :], surface.v0, surface.hand)
    K = len(c)
    q = np.arange(K - 1)[:, None] * n_t + np.arange(n_t - 1)[None, :]
    faces = np.concatenate([np.stack([q, q + n_t, q + n_t + 1], -1).reshape(-1, 3),
                            np.stack([q, q + n_t + 1, q + 1], -1).reshape(-1, 3)])
    return V.reshape(-1, 3), faces, np.repeat(dev, n_t)


def flank_of_point(surface, flank_ranges, point):
    """Index of the flank holding the profile point nearest to a 3D point (rotor frame): the point
    is screwed into z = 0 first (every flank is invariant under the screw)."""
    from .screw import screw_to_plane

    p = np.asarray(point, float).reshape(3)
    if not np.isfinite(p).all():
        raise ValueError(f"flank point {point} must be three finite numbers")
    q0 = screw_to_plane(p[None, :], surface.v0, surface.hand)[0]
    prof = surface.profile
    us = prof.params(8192)
    u = us[int(np.argmin(np.linalg.norm(prof.eval(us) - q0, axis=1)))]
    per = prof.period
    for i, (a, b) in enumerate(flank_ranges):
        if a <= u <= b or a <= u + per <= b or a <= u - per <= b:
            return i
    raise ValueError(f"flank point {point} is not near any flank of the rotor")
