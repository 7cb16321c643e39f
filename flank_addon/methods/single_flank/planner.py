"""Multi-strip single-flank milling of one helical flank with a given cone, to a tolerance
(Bizzarri, Bo & Bartoň §5-6: optimised candidate strips, envelope coverage, minimum strip set, global collisions).

Pipeline of :func:`plan_single_flank`:

1. candidates: for profile parameters of the flank, the §5.1 seeds of :mod:`.poses` (line
   contact at hyperbolic points, tangential contact elsewhere), optimised by Phi1 (Eq. 25) or Phi3
   (Eq. 31), by default in the hard non-overcutting mode (Eq. 30 style);
2. global collision (§5.5, :mod:`collision`): tool and shank against every lobe of the rotor;
   colliding candidates are dropped and listed with where they collide;
3. coverage (:mod:`.strip_cover`): the flank interval each candidate's envelope holds within
   [-eps_over, eps], a minimum-cardinality interval cover, new seeds in the gaps (Bizzarri, Bo & Bartoň §6.1) until
   the flank is covered or the rounds run out; what stays uncovered is reported as ranges;
4. the plan (flank-plan/1) of the chosen strips, simulated with the :mod:`verify` engine so the
   reported errors are the machined ones, and the kink angles at the junctions of neighbouring
   strips (Bizzarri, Bo & Bartoň §7, Rajain et al. 2023's G1 idea).
"""
import math
import time
from dataclasses import dataclass, field

import numpy as np

from ...tooling.cone import ConeTool
from ...progress import reporter
from .poses import PoseEvaluator, candidate_strips, initial_positions, single_flank_plan


@dataclass
class SingleFlankResult:
    """plan: flank-plan/1 dict; strips: the chosen :class:`.poses.CandidateStrip` in flank
    order; candidates: every optimised candidate (collision-free or not); collisions: per colliding
    candidate {"u", "collisions": [...]}; uncovered: flank parameter ranges outside the tolerance
    band; junctions: per neighbouring pair the kink angles (degrees) where their envelopes meet;
    deviation: (u (N,), deviation (N,)) of the chosen strips along the flank profile (Bizzarri, Bo & Bartoň Fig. 11c);
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


def _merge_ranges(ranges):
    """Union of closed parameter ranges, sorted, overlapping or touching ones merged."""
    out = []
    for a, b in sorted(ranges):
        if out and a <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], b))
        else:
            out.append((a, b))
    return out


def plan_single_flank(surface, flank_ranges, flank, tool, tolerance, overcut_tolerance=None, n_seeds=18,
                      objective="phi1", mode="hard", max_rounds=4, n_profile=2048, n_cover=500,
                      to_world=None, length_unit="R", check_collisions=True, z_range=None, g1=False,
                      g1_weight=1.0, g1_extra_strips=2, g1_target_deg=1.0, g1_rounds=2, optimizer=None,
                      progress=None):
    """Plan strips of the cone ``tool`` (:class:`cone.ConeTool`) on flank index ``flank`` so the
    machined flank stays within [-overcut_tolerance, tolerance] of the design (signed, + = stock).

    surface: :class:`HelicalSurface`; flank_ranges: the rotor's flank parameter ranges
    (``Rotor.flanks`` or ``RotorAnalysis`` flanks); n_seeds: first-round seeds (uniform along the
    flank profile); objective 'phi1' | 'phi3'; mode 'hard' (no overcut along the axis) | 'weighted'
    (w = 100, Remark 5.1); overcut_tolerance defaults to 1e-6 R.  z_range: the z slab the finite rotor
    occupies over the whole pass (None = an infinite rotor; a slab that is too short hides
    collisions, see :func:`collision.check_collisions`).  With ``g1`` (when the flank is covered):
    first the smoothest cover with at most ``g1_extra_strips`` more strips than the minimum is
    chosen (:func:`.strip_cover.smooth_cover`), seeding new candidates between neighbours whose
    junction kinks more than ``g1_target_deg`` for ``g1_rounds`` rounds, and kept if its largest
    exact kink is smaller; then the strips are re-optimised together with a tangency term at their
    junctions (:func:`refine_g1`), weight ``g1_weight`` reduced until the machined flank still meets
    the tolerance band (kept only then).
    ``optimizer``: replaces :func:`.poses.optimize_poses` (same signature; the benchmark passes
    the paper's gradient descent).  ``progress``: None or ``progress(fraction, message)``; returning
    False cancels (:class:`progress.Cancelled` is raised, nothing is returned).  Returns
    :class:`SingleFlankResult`."""
    from ...simulation.collision import check_collisions as collide
    from .strip_cover import adaptive_cover, junction_kinks_chain
    from ...simulation.verify import verify_plan

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
    if not 0 <= int(g1_extra_strips) <= 50:
        raise ValueError(f"g1 extra strips {g1_extra_strips} is outside the limits 0..50")
    flank = int(flank)
    report = reporter(progress)
    report(0.0, "preparing the flank")
    u_range = tuple(float(v) for v in flank_ranges[flank])
    ev = PoseEvaluator(surface, u_range, tool)
    prof_pts = surface.profile.sample(n_profile)
    idx_ranges = _flank_index_ranges(surface, flank_ranges, n_profile)
    timings = {"candidates": 0.0, "collision": 0.0}
    all_cands, collisions = [], []

    stage = {"calls": 0}
    cand_end = 0.6 if g1 else 0.75

    def make_candidates(us):
        # the cover asks at most max_rounds times (and the G1 stage g1_rounds more)
        k = stage["calls"]
        stage["calls"] += 1
        frac = 0.02 + (cand_end - 0.02) * min(k / max(1, max_rounds + (g1_rounds if g1 else 0)), 1.0)
        report(frac, f"optimising {len(us)} candidate strips (round {k + 1})")
        ts = time.perf_counter()
        per = initial_positions(surface, u_range, tool, u=np.asarray(us, float), feet=ev.feet)
        seeds = [c[0] for c in per if c]
        cands = candidate_strips(surface, u_range, tool, seeds=seeds, objective=objective, mode=mode,
                                 evaluator=ev, flank=flank, optimizer=optimizer) if seeds else []
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
    uncovered = _merge_ranges([tuple(map(float, g)) for g in list(cover.gaps) + list(cover.uncovered)])

    def kinks(strips, deviations=None):
        chain = junction_kinks_chain([c.pose for c in strips], surface, u_range, samples=cover.samples,
                                     deviations=deviations)
        return [[{"u": float(j.u), "kink_deg": float(j.kink_deg)} for j in js] for js in chain]

    report(cand_end, "junction kinks")
    ts = time.perf_counter()
    # the cover stage already has each chosen strip's deviation at the flank samples
    devs = np.array([cover.chosen_coverage[i].deviation for i in order]) if len(order) > 1 else None
    junctions = kinks(chosen, devs)
    timings["junctions"] = time.perf_counter() - ts
    g1_report = None
    selection = None
    if g1 and len(chosen) > 1:
        ts = time.perf_counter()
        chosen, junctions, selection = _smooth_selection(cover, chosen, junctions, make_candidates, surface,
                                                         u_range, tol, eps_over, int(g1_extra_strips),
                                                         float(g1_target_deg), int(g1_rounds), kinks)
        timings["g1_selection"] = time.perf_counter() - ts
    if g1 and len(chosen) > 1:
        report(0.7, "G1: tangency refinement")
        ts = time.perf_counter()
        chosen, junctions, g1_report = _apply_g1(chosen, junctions, ev, cover.samples, surface, tol, eps_over,
                                                 float(g1_weight), kinks)
        timings["g1"] = time.perf_counter() - ts

    plan = single_flank_plan(surface, flank_ranges, flank, chosen, tool, to_world=to_world,
                             length_unit=length_unit, n_profile=n_profile,
                             method=f"single-flank-cone-{objective}-{mode}")
    plan["tolerance"] = tol
    plan["overcut_tolerance"] = eps_over
    report(0.85, "verifying the plan (sweep simulation)")
    ts = time.perf_counter()
    ver = verify_plan(plan, tolerance=eps_over)
    timings["verify"] = time.perf_counter() - ts
    # reported errors = the simulated ones (per strip where it forms the machined surface)
    for st, vs in zip(plan["strips"], ver["strips"]):
        if vs["max_error"] is not None:
            st["reported_max_error"], st["reported_min_error"] = vs["max_error"], vs["min_error"]
        st["collision"] = bool(vs["collision"])
    from ...io.plan import summarize
    timings["total"] = time.perf_counter() - t0
    plan["summary"] = summarize(plan["strips"], timings["total"])
    fin = ver["max_undercut"], ver["max_overcut"]
    if fin[0] is not None:
        plan["summary"]["max_error"], plan["summary"]["min_error"] = fin[0], fin[1]
    plan["summary"]["uncovered_ranges"] = [list(g) for g in uncovered]
    plan["summary"]["junction_kinks_deg"] = [[j["kink_deg"] for j in js] for js in junctions]
    if g1_report is not None:
        g1_report["selection"] = selection
        plan["summary"]["g1"] = g1_report
    report(1.0, "done")
    return SingleFlankResult(plan=plan, strips=chosen, candidates=all_cands, collisions=collisions,
                             uncovered=uncovered, junctions=junctions,
                             deviation=(cover.samples.u, cover.deviation), verify=ver, rounds=cover.rounds,
                             timings=timings)


def envelope_strip(candidate, surface, u_range, z_range=(0.0, 1.0), n_s=60, n_t=48, evaluator=None):
    """The envelope strip of one strip's cone (Bizzarri, Bo & Bartoň Eqs. 11-14): the characteristic curve of the
    pose under the rotor's screw motion, swept over ``z_range`` (rotor frame).

    candidate: :class:`.poses.CandidateStrip` (or anything with ``params`` and ``pose``).
    Returns (verts (K*n_t, 3), faces (F, 3) int, deviation (K*n_t,)): K <= n_s characteristic points
    where the characteristic is real, their signed distance to the flank (+ = material left, in the
    rotor's length unit; constant along each helix, so exact at every vertex)."""
    from ...geometry.screw import screw_motion

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
    from ...geometry.screw import screw_to_plane

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


# ============================================================================ G1 junctions
def _smooth_selection(cover, chosen, junctions, make_candidates, surface, u_range, tol, eps_over, extra,
                      target_deg, rounds, kinks):
    """The G1 cover stage of :func:`plan_single_flank`: re-choose the strips from all candidates
    by :func:`.strip_cover.smooth_cover`; between neighbours whose estimated kink exceeds target_deg
    seed a new candidate half way (denser strips overlap more and meet flatter), up to ``rounds``
    times.  The new choice is kept if its largest exact kink is smaller than the minimum cover's.
    Returns (strips, junctions, report)."""
    from .strip_cover import covered_intervals, smooth_cover

    def worst(js):
        return max((j["kink_deg"] for jj in js for j in jj), default=0.0)

    poses = list(cover.candidates)
    coverage = list(cover.coverage)
    report = {"extra_strips_allowed": extra, "target_deg": target_deg, "strips_before": len(chosen),
              "max_kink_before_deg": worst(junctions), "seeded": 0, "kept": False}
    sel = None
    for r in range(rounds + 1):
        sel = smooth_cover(coverage, cover.samples, extra=extra)
        if sel is None or r == rounds:
            break
        seeds = []
        for a, b, k in zip(sel.chosen, sel.chosen[1:], sel.kinks):
            if k > target_deg:
                ua, ub = poses[a].candidate.seed.u, poses[b].candidate.seed.u
                if abs(ub - ua) > 1e-6 * abs(u_range[1] - u_range[0]):
                    seeds.append(0.5 * (ua + ub))
        if not seeds:
            break
        new = [p for p in make_candidates(np.asarray(seeds, float)) if p is not None]
        report["seeded"] += len(seeds)
        if not new:
            break
        cov = covered_intervals(new, surface, u_range, tol, eps_over, samples=cover.samples)
        poses += new
        coverage += cov.poses
    if sel is None:
        report["reason"] = "no admissible candidate"
        return chosen, junctions, report
    ks = list(dict.fromkeys(sel.chosen))                       # a pose may cover two pieces
    strips = [poses[k].candidate for k in ks]
    devs = np.array([coverage[k].deviation for k in ks])
    js = kinks(strips, devs) if len(strips) > 1 else []
    report.update(strips_after=len(strips), max_kink_after_deg=worst(js),
                  estimated_kinks_deg=[float(k) for k in sel.kinks])
    if worst(js) < report["max_kink_before_deg"]:
        report["kept"] = True
        return strips, js, report
    report.update(strips_after=len(chosen), max_kink_after_deg=report["max_kink_before_deg"])
    return chosen, junctions, report


def _apply_g1(chosen, junctions, ev, samples, surface, tol, eps_over, weight, kinks):
    """Try :func:`refine_g1` with ``weight``, then a quarter and a sixteenth of it; keep the first
    result whose strips together still hold in [-eps_over, tol] every flank sample they held before
    (and overcut nowhere) and lower the
    root-mean-square kink (the quantity the tangency term minimises; where the flank is curved
    across a narrow strip a cone cannot meet G1 and those kinks stay).  Returns (strips, junctions,
    report)."""
    from dataclasses import replace

    from .poses import params_pose
    from ...simulation.sweep import tool_of
    from .strip_cover import pose_deviations

    def worst(js):
        return max((j["kink_deg"] for jj in js for j in jj), default=0.0)

    def rms(js):
        k = [j["kink_deg"] for jj in js for j in jj]
        return float(np.sqrt(np.mean(np.square(k)))) if k else 0.0

    ju = [max(jj, key=lambda j: j["kink_deg"])["u"] if jj else None for jj in junctions]
    report = {"accepted": False, "weight": None, "max_kink_before_deg": worst(junctions),
              "max_kink_after_deg": worst(junctions), "rms_kink_before_deg": rms(junctions),
              "rms_kink_after_deg": rms(junctions), "tried": []}
    search = 0.05 * float(surface.outer_radius)

    def band(strips):
        dev = pose_deviations([tool_of(c.pose) for c in strips], samples.points, samples.normals, surface.v0,
                              surface.handedness, search).min(axis=0)
        return dev, (dev >= -eps_over) & (dev <= tol)

    _, held = band(chosen)          # what the strips hold now must stay held (an incomplete cover's gaps may stay)
    for w in (weight, weight / 4.0, weight / 16.0):
        X = refine_g1(chosen, ev, ju, weight=w)
        new = [replace(c, pose=params_pose(X[k], c.pose.tool), params=X[k].copy(),
                       errors=ev.axis_errors(X[k])) for k, c in enumerate(chosen)]
        dev, inside = band(new)
        ok = bool(np.all(inside[held]) and np.all(dev >= -eps_over))
        js = kinks(new)
        report["tried"].append({"weight": w, "within_tolerance": ok, "max_kink_deg": worst(js),
                                "rms_kink_deg": rms(js), "max_deviation": float(np.max(dev)),
                                "min_deviation": float(np.min(dev))})
        if ok and rms(js) < report["rms_kink_before_deg"]:
            report.update(accepted=True, weight=w, max_kink_after_deg=worst(js), rms_kink_after_deg=rms(js))
            return new, js, report
        if ok:
            break        # within tolerance but no smoother: a smaller weight will not help
    return chosen, junctions, report


def _junction_normals(ev, X, branch, s_star):
    """Unit envelope normals (M, K, 3) at the characteristic points of samples s_star (K,) of poses
    X (M, 4), screwed into the plane z = 0 (where all envelope sections are compared), and their
    derivatives (M, K, 3, 4) w.r.t. each pose's parameters.

    The characteristic point is c = m + r n on the sphere (m, r) of the sample, so n = (c - m) / r
    and dn/dx = (dc/dx - dm/dx) / r (c and dc/dx from PoseEvaluator.characteristic).  Screwing by
    t = -c_z / v0 turns n by hand * t about z."""
    from .poses import axis_and_jacobian

    X = np.atleast_2d(X)
    s = np.atleast_1d(np.asarray(s_star, float))
    c, dc, ok = ev.characteristic(X, np.atleast_1d(branch), s)
    m, Jm, _, _ = axis_and_jacobian(X, s, ev.L)
    r = ev.tool.radius(s)[None, :, None]
    n = (c - m) / r
    dn = (dc - Jm) / r[..., None]
    h = ev.surface.hand
    th = -h * c[..., 2] / ev.surface.v0                          # (M, K)
    dth = -h * dc[..., 2, :] / ev.surface.v0                     # (M, K, 4)
    ct, st = np.cos(th), np.sin(th)
    rn = np.stack([ct * n[..., 0] - st * n[..., 1], st * n[..., 0] + ct * n[..., 1], n[..., 2]], -1)
    drn = np.stack([ct[..., None] * dn[..., 0, :] - st[..., None] * dn[..., 1, :],
                    st[..., None] * dn[..., 0, :] + ct[..., None] * dn[..., 1, :], dn[..., 2, :]], -2)
    # d(R n)/dtheta = (-y', x', 0) of the turned normal
    turn = np.stack([-rn[..., 1], rn[..., 0], np.zeros_like(th)], -1)
    drn = drn + turn[..., None] * dth[..., None, :]
    return rn, drn, ok


def _junction_sample(ev, x, branch, u_j, n=201):
    """Characteristic sample s whose flank foot parameter is nearest u_j (linear in between)."""
    s = np.linspace(0.0, 1.0, n)
    f, _, info = ev.char_distances(np.atleast_2d(x), np.atleast_1d(branch), s, key=None)
    u = np.where(info["real"][0], info["u"][0], np.nan)
    if not np.isfinite(u).any():
        return None
    j = int(np.nanargmin(np.abs(u - u_j)))
    for k in (j - 1, j):
        if 0 <= k < n - 1 and np.isfinite(u[k]) and np.isfinite(u[k + 1]) and (u[k] - u_j) * (u[k + 1] - u_j) <= 0 \
                and u[k + 1] != u[k]:
            return float(s[k] + (s[k + 1] - s[k]) * (u_j - u[k]) / (u[k + 1] - u[k]))
    return float(s[j])


def refine_g1(candidates, ev, junction_u, weight=1.0, maxiter=40):
    """Rajain et al. 2023's G1 idea for helical strips: re-optimise the chosen poses together so neighbouring
    envelopes share their normal at each junction, while no sphere of any tool enters the flank
    (hard mode, e >= 0 at the axis samples) and every pose keeps its depth on the flank (the cover
    stays a cover, as in :func:`.poses.optimize_poses`).

        minimise  sum_k mean_i e_ki / R  +  weight * sum_j |n_j,a - n_j,b|^2

    n_j,a, n_j,b: the envelope normals of strips a = j, b = j + 1 at their junction j (flank
    parameter ``junction_u[j]``, its characteristic sample held fixed per solve), compared in
    z = 0 (|n_a - n_b| ~ the kink angle in radians).  Exact gradients throughout (foot-point
    normals, characteristic derivatives); SLSQP.  Returns the new parameter rows (M, 4)."""
    from scipy.optimize import minimize

    from .poses import mid_radius

    X0 = np.array([c.params for c in candidates], float)
    M = len(X0)
    R = float(ev.surface.outer_radius)
    br = ev.branch(X0)
    rho0 = mid_radius(X0, ev.L)[0]
    pairs = []
    for j, u_j in enumerate(junction_u):
        if u_j is None:
            continue
        sa = _junction_sample(ev, X0[j], br[j], u_j)
        sb = _junction_sample(ev, X0[j + 1], br[j + 1], u_j)
        if sa is not None and sb is not None:
            pairs.append((j, sa, sb))
    if not pairs:
        return X0
    cache = {}
    samples = {"s": np.linspace(0.0, 1.0, 33)}     # the exchange below adds whatever dips between
    s_j = np.array([v for _, sa, sb in pairs for v in (sa, sb)])

    def get(y):
        key = y.tobytes()
        if key not in cache:
            cache.clear()
            X = y.reshape(M, 4)
            e, de, _ = ev.distances(X, s=samples["s"], key=("g1", len(samples["s"])))
            n = e.shape[1]
            val = e.sum() / (n * R)
            grad = (de.sum(axis=1) / (n * R)).ravel()
            nrm, dnrm, _ = _junction_normals(ev, X, br, s_j)     # every pose at every junction sample
            for q, (j, sa, sb) in enumerate(pairs):
                na, dna = nrm[j, 2 * q], dnrm[j, 2 * q]
                nb, dnb = nrm[j + 1, 2 * q + 1], dnrm[j + 1, 2 * q + 1]
                d = na - nb
                val += weight * float(d @ d)
                grad[4 * j:4 * j + 4] += 2.0 * weight * (d @ dna)
                grad[4 * (j + 1):4 * (j + 1) + 4] -= 2.0 * weight * (d @ dnb)
            G = np.zeros((M * n, 4 * M))
            for k in range(M):
                G[k * n:(k + 1) * n, 4 * k:4 * k + 4] = de[k]
            cache[key] = (val, grad, e.ravel(), G)
        return cache[key]

    def anchor(y):
        r, g = mid_radius(y.reshape(M, 4), ev.L)
        J = np.zeros((M, 4 * M))
        for k in range(M):
            J[k, 4 * k:4 * k + 4] = g[k]
        return r - rho0, J

    y = X0.ravel()
    dense = np.linspace(0.0, 1.0, 2001)
    for _round in range(4):
        cache.clear()
        res = minimize(lambda y: get(y)[0], y, jac=lambda y: get(y)[1], method="SLSQP",
                       constraints=[{"type": "ineq", "fun": lambda y: get(y)[2], "jac": lambda y: get(y)[3]},
                                    {"type": "eq", "fun": lambda y: anchor(y)[0], "jac": lambda y: anchor(y)[1]}],
                       options={"maxiter": maxiter, "ftol": 1e-12})
        if not np.all(np.isfinite(res.x)):
            return X0
        y = res.x
        # exchange: the spheres between the samples must stay out of the flank too
        e, _, _ = ev.distances(y.reshape(M, 4), s=dense, key=None, jac=False)
        low = e < -1e-12 * R
        if not low.any():
            break
        # one new sample per run of dipping samples and pose: the deepest one
        dips = []
        for k in np.flatnonzero(low.any(axis=1)):
            m = np.r_[False, low[k], False].astype(np.int8)
            for a0, a1 in zip(np.flatnonzero(np.diff(m) == 1), np.flatnonzero(np.diff(m) == -1)):
                dips.append(dense[a0 + int(np.argmin(e[k, a0:a1]))])
        samples["s"] = np.unique(np.r_[samples["s"], dips])
    return y.reshape(M, 4)
