"""Multi-strip single-flank milling of one helical flank with given cones, to a tolerance
(Bizzarri, Bo & Bartoň §5-6: optimised candidate strips, envelope coverage, minimum strip set, global collisions).

Pipeline of :func:`plan_single_flank`, for each tool in turn (the largest first; a later tool only where the
earlier ones left the flank uncovered):

1. seeds (:func:`.poses.clear_seeds`): at profile parameters of the flank, the §5.1 seed of :mod:`.poses`
   (line contact at hyperbolic points, tangential contact elsewhere) or, where that pose buries the tool in
   the rotor, the tangential contact of another ruling direction or with the contact nearer the tip;
2. candidates: the seeds optimised by Phi1 (Eq. 25) or Phi3 (Eq. 31), by default in the hard non-overcutting
   mode (Eq. 30 style) with the tool's and shank's clearance from the whole rotor as constraints
   (:class:`.poses.RotorClearance`) and each seed's contact kept (``pin``);
3. global collision (§5.5, :mod:`collision`): tool and shank against every lobe of the rotor, exactly;
   colliding candidates are dropped and listed with where they collide;
4. coverage (:mod:`.strip_cover`): the flank interval each candidate's envelope holds within
   [-eps_over, eps], a minimum-cardinality interval cover, new seeds in its gaps (Bizzarri, Bo & Bartoň §6.1,
   as many as the tool's strip width says each gap needs) until the flank is covered or no gap gets a new
   seed; what stays is the next tool's target;
5. the plan (flank-plan/1) of the chosen strips (each with its tool when there are several), simulated with
   the :mod:`verify` engine so the reported errors are the machined ones; the verified share of the flank
   within tolerance and the uncovered ranges with their reasons (:mod:`.residual`) and, where the geometry
   proves that no tool of the catalogue can do better, the bound (:mod:`.reach`); the kink angles at the
   junctions of neighbouring strips (Bizzarri, Bo & Bartoň §7, Rajain et al. 2023's G1 idea).
"""
import math
import time
from dataclasses import dataclass, field

import numpy as np

from ...tooling.cone import ConeTool
from ...progress import reporter
from .poses import PoseEvaluator, RotorClearance, candidate_strips, clear_seeds, single_flank_plan


@dataclass
class SingleFlankResult:
    """plan: flank-plan/1 dict; strips: the chosen :class:`.poses.CandidateStrip` in flank
    order; candidates: every optimised candidate (collision-free or not); collisions: per colliding
    candidate {"u", "tool", "collisions": [...]}; uncovered: flank parameter ranges outside the tolerance
    band (verified); residual: one dict per uncovered range (index, parameter and arc-length range, kind,
    reason per tool, the bound where proven); covered_fraction: verified share of the flank's arc length
    within tolerance; junctions: per neighbouring pair the kink angles (degrees) where their envelopes meet;
    deviation: (u (N,), deviation (N,)) of the chosen strips along the flank profile (Bizzarri, Bo & Bartoň
    Fig. 11c); verify: the sweep simulation of the plan (:func:`verify.verify_plan`); tools: per tool its
    name, cone, strips chosen and seeds tried; timings in seconds."""
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
    residual: list = field(default_factory=list)
    covered_fraction: float = 0.0
    tools: list = field(default_factory=list)

    @property
    def complete(self):
        return not self.uncovered

    def no_strip_message(self, flank):
        """Why this plan has no strip: the seeds tried, how many candidates collided, the uncovered ranges and
        the reasons the residual analysis gives for them."""
        seeds = sum(int(t.get("seeds", 0)) for t in self.tools)
        reasons = sorted({str(r.get("reason")) for r in self.residual if r.get("reason")})
        ranges = ", ".join(f"[{a:.4g}, {b:.4g}]" for a, b in merge_ranges(self.uncovered))
        return (f"no collision-free strip on flank {flank}: {seeds} seeds tried, {len(self.collisions)} colliding"
                + ("; " + "; ".join(reasons) if reasons else "") + f" (uncovered {ranges})")


def _flank_index_ranges(surface, flank_ranges, n):
    per = surface.profile.period
    return [(int(round(a / per * n)), int(round(b / per * n))) for a, b in flank_ranges]


def merge_ranges(ranges):
    """Union of closed parameter ranges [(a, b)] as sorted disjoint ranges, overlapping or touching ones merged
    (the planner may list a range twice)."""
    out = []
    for a, b in sorted((float(a), float(b)) for a, b in ranges):
        if out and a <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], b))
        else:
            out.append((a, b))
    return out


def _polygon_sagitta(points):
    """Largest distance of a closed polygon's vertices from the chord of their neighbours, a quarter of it:
    about the distance between the polygon and the smooth profile it samples (the collision test's point in
    polygon decides inside / outside by the polygon)."""
    P = np.asarray(points, float)
    a, b = np.roll(P, 1, axis=0), np.roll(P, -1, axis=0)
    ab = b - a
    L = np.linalg.norm(ab, axis=1)
    cross = np.abs(ab[:, 0] * (P - a)[:, 1] - ab[:, 1] * (P - a)[:, 0])
    return 0.25 * float(np.max(cross / np.maximum(L, 1e-300)))


def _named_tools(tool, names=None):
    """[(name, ConeTool), ...] of one cone, a list of cones or of (name, cone) pairs."""
    items = tool if isinstance(tool, (list, tuple)) and not isinstance(tool, ConeTool) else [tool]
    out = []
    for k, it in enumerate(items):
        name, t = (it if isinstance(it, tuple) else (None, it))
        if not isinstance(t, ConeTool):
            raise ValueError(f"tool must be a ConeTool, got {type(t).__name__}")
        if names is not None and k < len(names):
            name = names[k]
        out.append((name or f"tool {k + 1}", t))
    if not out:
        raise ValueError("no tool given")
    return out


class _ToolRun:
    """Candidates of one tool on the flank, for :func:`.strip_cover.adaptive_cover`: seeds chosen with the
    clearance in view, optimised, collision-checked; every seed is logged with what became of it."""

    def __init__(self, index, name, tool, surface, u_range, flank, objective, mode, optimizer, clearance, pin,
                 check, collide_args, timings, report, stage):
        self.index, self.name, self.tool = index, name, tool
        clr = RotorClearance.for_tool(surface, u_range, tool) if clearance else None
        self.ev = PoseEvaluator(surface, u_range, tool, clearance=clr)
        self.surface, self.u_range, self.flank = surface, u_range, flank
        self.objective, self.mode, self.optimizer, self.pin = objective, mode, optimizer, pin
        self.check, self.collide_args = check, collide_args
        self.timings, self.report, self.stage = timings, report, stage
        self.candidates, self.collisions, self.log = [], [], []
        self.calls = 0
        self.buried = float("inf")
        self.flank_ranges = None
        self.room_slack = None
        self.split = None

    def __call__(self, us):
        from ...simulation.collision import check_collisions as collide

        lo, hi = self.stage
        self.report(lo + (hi - lo) * min(self.calls / 6.0, 1.0),
                    f"{self.name}: optimising {len(us)} candidate strips (round {self.calls + 1})")
        self.calls += 1
        ts = time.perf_counter()
        us = np.asarray(us, float)
        proven = np.zeros(len(us), bool)
        if self.room_slack is not None and len(us):
            # where the geometry proves that no ball of the tool's tip sphere can come within the tolerance
            # without entering the rotor (:mod:`.reach`), no pose of this tool can help: not even seeded
            from .reach import room_bound

            rb = room_bound(self.surface, us, self.tool.r1s, self.room_slack)
            proven = rb.proven
            for u, d in zip(us[proven], rb.depth[proven]):
                self.log.append({"tool": self.index, "u": float(u), "status": "unreachable", "seed": None,
                                 "depth": float(d), "radius": float(self.tool.r1s)})
            us = us[~proven]
        tang = self.split == "elliptic"
        seeds = clear_seeds(self.ev, us, tangential=tang) if self.ev.clearance is not None else [None] * len(us)
        if self.ev.clearance is None:
            from .poses import initial_positions
            per = initial_positions(self.surface, self.u_range, self.tool, u=np.asarray(us, float), feet=self.ev.feet,
                                    tangential=tang)
            seeds = [c[0] if c else None for c in per]
        entries = []
        for u, sd in zip(us, seeds):
            e = {"tool": self.index, "u": float(u), "status": "no pose" if sd is None else None, "seed": sd}
            if sd is not None and sd.blocked is not None and sd.clearance < 0:
                e.update(seed_depth=sd.blocked["depth"], seed_part=sd.blocked["part"], seed_u=sd.blocked["u"])
            entries.append(e)
        self.log += entries
        # a seed whose best pose is buried deeper than the tolerance cannot touch the flank here: the
        # optimiser would only lift it off (logged as such, not optimised)
        for e in entries:
            sd = e["seed"]
            if sd is not None and self.ev.clearance is not None and sd.clearance < -self.buried:
                f = _flank_of_u(sd.blocked["u"], self.flank_ranges, self.surface)
                e.update(status="held off", depth=sd.blocked["depth"], part=sd.blocked["part"], flank=f,
                         deviation=None)
                e["seed"] = None
                self.collisions.append({"u": e["u"], "tool": self.name, "collisions": [
                    {"part": sd.blocked["part"], "source": "clearance", "flank": int(f), "valley": int(f // 2),
                     "target": f == self.flank, "depth": float(sd.blocked["depth"]),
                     "orientations": int(sd.blocked["variants"])}]})
        live = [e for e in entries if e["seed"] is not None]
        cands = candidate_strips(self.surface, self.u_range, self.tool, seeds=[e["seed"] for e in live],
                                 objective=self.objective, mode=self.mode, evaluator=self.ev, flank=self.flank,
                                 optimizer=self.optimizer, pin_contact=self.pin and self.optimizer is None) \
            if live else []
        self.timings["candidates"] += time.perf_counter() - ts
        ts = time.perf_counter()
        out = []
        reps = collide([c.pose for c in cands], **self.collide_args) if (self.check and cands) else [None] * len(cands)
        for e, c, rep in zip(live, cands, reps):
            e["candidate"] = c
            c.tool_index = self.index
            if rep is not None and rep.collides:
                worst = max(rep.collisions, key=lambda x: x["depth"])
                e.update(status="collides", depth=float(worst["depth"]), part=worst["part"], flank=int(worst["flank"]))
                self.collisions.append({"u": float(c.seed.u), "tool": self.name, "collisions": rep.collisions})
            else:
                c.pose.candidate = c          # the cover hands poses back: keep the way to the strip
                e["pose"] = c.pose
                out.append(c.pose)
        self.timings["collision"] += time.perf_counter() - ts
        self.candidates += cands
        return out


def plan_single_flank(surface, flank_ranges, flank, tool, tolerance, overcut_tolerance=None, n_seeds=None,
                      objective="phi1", mode="hard", max_rounds=None, n_profile=2048, n_cover=500,
                      to_world=None, length_unit="R", check_collisions=True, z_range=None, g1=False,
                      g1_weight=1.0, g1_extra_strips=2, g1_target_deg=1.0, g1_rounds=2, optimizer=None,
                      progress=None, clearance=None, pin=True, targets=None, max_seeds=400, tool_names=None,
                      bound_radius=None, explain=True, select="order", max_tools=None, split=None):
    """Plan strips of the cone ``tool`` (:class:`cone.ConeTool`) -- or of several: a list of cones or of
    (name, cone) pairs, tried in that order, each on what the earlier ones left -- on flank index ``flank``
    so the machined flank stays within [-overcut_tolerance, tolerance] of the design (signed, + = stock).

    surface: :class:`HelicalSurface`; flank_ranges: the rotor's flank parameter ranges
    (``Rotor.flanks`` or ``RotorAnalysis`` flanks); n_seeds: first-round seeds (uniform along the flank
    profile; default 8, or the given count), later rounds seed the gaps as densely as the tool's strips
    need (:func:`.strip_cover.adaptive_cover`) for at most ``max_rounds`` rounds (default 10) and
    ``max_seeds`` seeds per tool; objective 'phi1' | 'phi3'; mode 'hard' (no overcut along the axis) |
    'weighted' (w = 100, Remark 5.1); overcut_tolerance defaults to 1e-6 R.  ``clearance`` (default: with
    the collision check) keeps tool and shank out of the whole rotor inside the optimisation (hard mode);
    ``pin`` keeps each seed's contact.  ``targets``: parameter ranges of the flank to cover (default all of
    it; e.g. one part of the hyperbolic / elliptic split).  z_range: the z slab the finite rotor
    occupies over the whole pass (None = an infinite rotor; a slab that is too short hides
    collisions, see :func:`collision.check_collisions`).  ``bound_radius``: the smallest tip sphere r1S the
    proven bound of an uncovered range is stated for (default the smallest of the given tools; pass the
    catalogue's smallest).  ``select``: 'order' (the tools in the order given) or 'auto' (a catalogue:
    :func:`_pick_tool` picks the largest tool admissible for what is still uncovered, then the next, at most
    ``max_tools`` runs).  ``split``: 'hyperbolic' | 'elliptic' plans only that part of the flank
    (:func:`curvature_parts`, unless ``targets`` are given), in its own run with its own initialisation: the
    §5.1 second-order line contacts on the hyperbolic part, the tangential contacts along the direction of the
    smallest principal curvature on the elliptic part (Examples 6.5, 6.6); the summary adds the part's ranges
    and its own verified share.  With ``g1`` (one tool, when the flank is covered):
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
    from .strip_cover import adaptive_cover, flank_samples, junction_kinks_chain, minimum_interval_cover
    from ...simulation.verify import verify_plan

    t0 = time.perf_counter()
    tools = _named_tools(tool, tool_names)
    R = float(surface.outer_radius)
    tol = float(tolerance)
    if not (math.isfinite(tol) and 0 < tol < 0.5 * R):
        raise ValueError(f"tolerance {tolerance} is outside the limits (0, {0.5 * R:g}) (half the outer radius)")
    eps_over = 1e-6 * R if overcut_tolerance is None else float(overcut_tolerance)
    if not (math.isfinite(eps_over) and 0 <= eps_over < 0.5 * R):
        raise ValueError(f"overcut tolerance {overcut_tolerance} is outside the limits [0, {0.5 * R:g})")
    if not 0 <= int(flank) < len(flank_ranges):
        raise ValueError(f"flank {flank} does not exist: the rotor has flanks 0..{len(flank_ranges) - 1}")
    if n_seeds is not None and not 1 <= int(n_seeds) <= 400:
        raise ValueError(f"seeds {n_seeds} is outside the limits 1..400")
    if max_rounds is not None and not 1 <= int(max_rounds) <= 100:
        raise ValueError(f"rounds {max_rounds} is outside the limits 1..100")
    if objective not in ("phi1", "phi3"):
        raise ValueError(f"objective {objective!r} is not one of phi1, phi3")
    if mode not in ("hard", "weighted"):
        raise ValueError(f"mode {mode!r} is not one of hard, weighted")
    if not 0 <= int(g1_extra_strips) <= 50:
        raise ValueError(f"g1 extra strips {g1_extra_strips} is outside the limits 0..50")
    if split not in (None, "hyperbolic", "elliptic"):
        raise ValueError(f"split {split!r} is not one of hyperbolic, elliptic")
    if select not in ("order", "auto"):
        raise ValueError(f"tool selection {select!r} is not one of order, auto")
    if max_tools is not None and not 1 <= int(max_tools) <= 50:
        raise ValueError(f"tools {max_tools} is outside the limits 1..50")
    flank = int(flank)
    n_seeds = 8 if n_seeds is None else int(n_seeds)
    max_rounds = 10 if max_rounds is None else int(max_rounds)
    clearance = bool(check_collisions) if clearance is None else bool(clearance)
    report = reporter(progress)
    report(0.0, "preparing the flank")
    u_range = tuple(float(v) for v in flank_ranges[flank])
    prof_pts = surface.profile.sample(n_profile)
    idx_ranges = _flank_index_ranges(surface, flank_ranges, n_profile)
    # the point-in-polygon part of the exact test decides by the polygon: a cone that only touches the
    # target flank may sit inside it by the polygon's sagitta (its real overcut is the coverage's business)
    collide_args = dict(profile_points=prof_pts, v0=surface.v0, handedness=surface.handedness, flanks=idx_ranges,
                        target_flanks=(flank,), tolerance=max(eps_over, 2.0 * _polygon_sagitta(prof_pts)),
                        z_range=z_range, model="spheres")
    timings = {"candidates": 0.0, "collision": 0.0}
    fs = flank_samples(surface, u_range, n_cover)
    if split is not None and targets is None:
        targets = curvature_parts(surface, u_range)[split]
        if not targets:
            raise ValueError(f"split {split}: flank {flank} has no {split} part")
    all_targets = [tuple(map(float, t)) for t in (targets or [u_range])]
    remaining = list(all_targets)
    chosen, chosen_cov, runs, rounds, covers = [], [], [], [], []
    cand_end = 0.6 if g1 else 0.75
    ts0 = time.perf_counter()
    pool = list(range(len(tools)))
    picks = []
    budget = len(tools) if max_tools is None else int(max_tools)
    while remaining and pool and len(runs) < budget:
        if select == "auto":
            ti, why = _pick_tool(surface, tools, pool, remaining, tol + eps_over, first=not runs)
            if ti is None:
                picks.append(why)
                break
            picks.append(why)
        else:
            ti = pool[0]
        pool.remove(ti)
        name, t = tools[ti]
        k = len(runs)
        share = (cand_end - 0.02) / max(1, min(budget, len(tools)))
        run = _ToolRun(ti, name, t, surface, u_range, flank, objective, mode, optimizer, clearance, pin,
                       check_collisions, collide_args, timings, report, (0.02 + k * share, 0.02 + (k + 1) * share))
        run.buried, run.flank_ranges = tol, flank_ranges
        run.room_slack = (tol + eps_over) if clearance else None
        run.split = split
        runs.append(run)
        cover = adaptive_cover(run, surface, u_range, tol, eps_over, n_seeds=n_seeds, max_rounds=max_rounds,
                               samples=fs, targets=remaining, max_seeds=max_seeds)
        covers.append(cover)
        rounds += [dict(r, tool=name) for r in cover.rounds]
        # what became of each seed: covered at its parameter, overcutting, leaving material there
        cov_of = {id(p): pc for p, pc in zip(cover.candidates, cover.coverage)}
        for e in run.log:
            if e["status"] is not None:
                continue
            pc = cov_of.get(id(e.get("pose")))
            if pc is None:
                continue
            dev = float(np.interp(e["u"], fs.u, np.where(np.isfinite(pc.deviation), pc.deviation, 1e300)))
            if not pc.admissible:
                e.update(status="overcuts", depth=pc.max_overcut)
            elif -eps_over <= dev <= tol:
                e.update(status="covers", deviation=dev)
            elif e.get("seed_depth") is not None:
                e.update(status="held off", deviation=dev if dev < 1e299 else None, depth=e["seed_depth"],
                         part=e["seed_part"], flank=_flank_of_u(e["seed_u"], flank_ranges, surface))
            else:
                e.update(status="leaves", deviation=dev if dev < 1e299 else None)
        for p, pc in zip(cover.poses, cover.chosen_coverage):
            chosen.append(p.candidate)
            chosen_cov.append(pc)
        flat = [iv for pc in chosen_cov for iv in pc.intervals]
        remaining = [g for a, b in all_targets for g in minimum_interval_cover(flat, a, b).gaps]
    timings["cover"] = time.perf_counter() - ts0 - timings["candidates"] - timings["collision"]
    for run in runs:
        for e in run.log:
            if e.get("flank") is not None:
                e["relation"] = _relation(e["flank"], flank)
    # flank order: by the start of each chosen pose's first covered interval
    order = sorted(range(len(chosen)), key=lambda i: min((iv[0] for iv in chosen_cov[i].intervals), default=math.inf))
    chosen = [chosen[i] for i in order]
    chosen_cov = [chosen_cov[i] for i in order]
    dev_union = np.min([pc.deviation for pc in chosen_cov], axis=0) if chosen_cov else np.full(len(fs.u), np.inf)

    def kinks(strips, deviations=None):
        chain = junction_kinks_chain([c.pose for c in strips], surface, u_range, samples=fs, deviations=deviations)
        return [[{"u": float(j.u), "kink_deg": float(j.kink_deg)} for j in js] for js in chain]

    report(cand_end, "junction kinks")
    ts = time.perf_counter()
    devs = np.array([pc.deviation for pc in chosen_cov]) if len(chosen) > 1 else None
    junctions = kinks(chosen, devs)
    timings["junctions"] = time.perf_counter() - ts
    g1_report = None
    selection = None
    used = sorted({c.tool_index for c in chosen})
    if g1 and len(chosen) > 1 and len(used) == 1 and len(runs) == 1:
        ts = time.perf_counter()
        chosen, junctions, selection = _smooth_selection(covers[0], chosen, junctions, runs[0], surface,
                                                         u_range, tol, eps_over, int(g1_extra_strips),
                                                         float(g1_target_deg), int(g1_rounds), kinks)
        timings["g1_selection"] = time.perf_counter() - ts
    if g1 and len(chosen) > 1 and len(used) == 1 and len(runs) == 1:
        report(0.7, "G1: tangency refinement")
        ts = time.perf_counter()
        chosen, junctions, g1_report = _apply_g1(chosen, junctions, runs[0].ev, fs, surface, tol, eps_over,
                                                 float(g1_weight), kinks)
        timings["g1"] = time.perf_counter() - ts

    used = sorted({c.tool_index for c in chosen})
    first = tools[used[0]][1] if used else tools[0][1]
    first_name = tools[used[0]][0] if used else tools[0][0]
    plan = single_flank_plan(surface, flank_ranges, flank, chosen, first, to_world=to_world,
                             length_unit=length_unit, n_profile=n_profile,
                             method=f"single-flank-cone-{objective}-{mode}")
    named = tool_names is not None or len(tools) > 1
    if named:
        plan["tool"]["name"] = first_name
    if len(used) > 1:          # several tools: each strip carries its own (same form as the plan's tool)
        for st, c in zip(plan["strips"], chosen):
            nm, t = tools[c.tool_index]
            st["tool"] = dict(t.as_dict(), name=nm)
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
    from .residual import explain_range, verified_coverage

    ts = time.perf_counter()
    per = float(surface.profile.period)
    frac, runs_unc = verified_coverage(plan, ver, flank, tol, eps_over, period=per)
    uncovered = []
    residual = []
    logs = [e for run in runs for e in run.log]
    margin = 0.5 * (u_range[1] - u_range[0]) / max(1, len(fs.u) - 1)
    r_bound = float(bound_radius) if bound_radius is not None else min(t.r1s for _, t in tools)
    pieces = []
    for ru in runs_unc:
        # the plan's profile index i is the parameter i * period / n_profile of the surface's profile
        a, b = ru["u_range"]
        a, b = _unwrap(a, u_range, per), _unwrap(b, u_range, per)
        ru["u_range"] = [a, b]
        if targets is None:
            pieces.append(ru)
            continue
        # a planned part only: the range's pieces inside it (the other part is its own run's business)
        from .residual import flank_points

        _, raw, arc, _ = flank_points(plan, flank)
        up = np.array([_unwrap(x * per / len(plan["rotor"]["profile"]), u_range, per) for x in raw])
        for ta, tb in all_targets:
            lo, hi = max(a, ta), min(b, tb)
            if hi >= lo:
                sa, sb = (float(np.interp(x, up, arc)) for x in (lo, hi))
                pieces.append(dict(ru, u_range=[lo, hi], arc_range=[sa, sb], length=sb - sa))
    for ru in pieces:
        a, b = ru["u_range"]
        uncovered.append((a, b))
        if explain:
            per_tool, text = explain_range(ru, logs, {run.index: run.name for run in runs}, tol, length_unit,
                                           margin, named=named)
            ru["tools"] = per_tool
            ru["reason"] = text
            ru["bound"] = _bound(surface, a, b, r_bound, tol + eps_over)
            if ru["bound"]["proven"]:
                bd = ru["bound"]
                ru["reason"] += (f"; proven: no tool whose smallest sphere has radius >= {r_bound:.4g} {length_unit} "
                                 f"can mill u in [{bd['u_range'][0]:.6g}, {bd['u_range'][1]:.6g}] within the "
                                 f"tolerance: each of its balls that comes within {tol + eps_over:.3g} of the flank "
                                 f"there enters the rotor by at least {bd['depth_min']:.3g} {length_unit}")
        residual.append(ru)
    timings["residual"] = time.perf_counter() - ts
    timings["total"] = time.perf_counter() - t0
    plan["summary"] = summarize(plan["strips"], timings["total"])
    fin = ver["max_undercut"], ver["max_overcut"]
    if fin[0] is not None:
        plan["summary"]["max_error"], plan["summary"]["min_error"] = fin[0], fin[1]
    plan["summary"]["covered_fraction"] = frac
    if targets is not None:
        part = _part_fraction(plan, ver, flank, tol, eps_over, per, all_targets, u_range)
        plan["summary"]["split" if split is not None else "targets"] = {
            "part": split, "u_ranges": [list(t) for t in all_targets], "covered_fraction": part}
    plan["summary"]["uncovered_ranges"] = [list(g) for g in uncovered]
    plan["summary"]["uncovered"] = [_json_range(ru) for ru in residual]
    plan["summary"]["junction_kinks_deg"] = [[j["kink_deg"] for j in js] for js in junctions]
    tool_rows = []
    for k, run in enumerate(runs):
        row = {"name": run.name, "tool": run.tool.as_dict(),
               "strips": sum(1 for c in chosen if c.tool_index == run.index), "seeds": len(run.log),
               "candidates": len(run.candidates), "collisions_excluded": len(run.collisions)}
        if select == "auto" and k < len(picks):
            row["picked"] = picks[k]
        tool_rows.append(row)
    if len(tools) > 1 or tool_names is not None:
        plan["summary"]["tools"] = [{k: v for k, v in row.items() if k != "tool"} for row in tool_rows]
        if select == "auto":
            plan["summary"]["tool_selection"] = {"catalogue": [nm for nm, _ in tools], "picks": picks}
    if g1_report is not None:
        g1_report["selection"] = selection
        plan["summary"]["g1"] = g1_report
    report(1.0, "done")
    return SingleFlankResult(plan=plan, strips=chosen, candidates=[c for run in runs for c in run.candidates],
                             collisions=[c for run in runs for c in run.collisions], uncovered=uncovered,
                             junctions=junctions, deviation=(fs.u, dev_union), verify=ver, rounds=rounds,
                             timings=timings, residual=residual, covered_fraction=frac, tools=tool_rows)


def curvature_parts(surface, u_range, n=2000, min_len=None):
    """The hyperbolic (K < 0) and elliptic (K >= 0, parabolic included) parts of a flank as parameter ranges
    (Bizzarri, Bo & Bartoň Fig. 3; Examples 6.5 and 6.6 plan each part in its own run): {"hyperbolic": [(a, b),
    ...], "elliptic": [...]} from :meth:`HelicalSurface.classify` at n points, runs shorter than ``min_len``
    (default 1 % of the flank) merged into their neighbours."""
    a, b = (float(x) for x in u_range)
    u = np.linspace(a, b, int(n))
    hyp = surface.classify(u) < 0
    edges = np.flatnonzero(np.diff(hyp.astype(int))) + 1
    starts, ends = np.r_[0, edges], np.r_[edges, len(u)]
    runs = [[bool(hyp[i]), float(u[i]), float(u[j - 1])] for i, j in zip(starts, ends)]
    min_len = 0.01 * (b - a) if min_len is None else float(min_len)
    merged = True
    while merged and len(runs) > 1:
        merged = False
        for k, r in enumerate(runs):
            if r[2] - r[1] < min_len:
                j = k - 1 if k > 0 else k + 1
                runs[j][0] = runs[j][0] if runs[j][2] - runs[j][1] >= r[2] - r[1] else r[0]
                runs[j][1], runs[j][2] = min(runs[j][1], r[1]), max(runs[j][2], r[2])
                runs.pop(k)
                merged = True
                break
    out = {"hyperbolic": [], "elliptic": []}
    for k, (h, lo, hi) in enumerate(runs):
        # neighbouring parts meet half way between their samples
        lo = a if k == 0 else 0.5 * (lo + runs[k - 1][2])
        hi = b if k == len(runs) - 1 else 0.5 * (hi + runs[k + 1][1])
        key = "hyperbolic" if h else "elliptic"
        if out[key] and abs(out[key][-1][1] - lo) < 1e-12:
            out[key][-1] = (out[key][-1][0], hi)
        else:
            out[key].append((lo, hi))
    return out


def _pick_tool(surface, tools, pool, remaining, slack, first, n=24):
    """The next tool of an automatic selection among ``pool`` (indices into ``tools``) for the parameter
    ranges ``remaining``: the largest (:func:`tooling.cutter_selection.tool_size_key`) that is admissible for
    them.  Admissible: its smallest sphere r1S is not proven unable to mill within the tolerance
    (:func:`.reach.room_bound`, slack = tolerance + overcut tolerance) at as many of n samples of the ranges
    as the best tool of the pool (after the first tool: it can finish the job as far as any can), or, for
    the first tool, at half as many (the largest tool that can mill most of what any tool can; the smaller
    ones come after it).  Returns (index or None, a record of the choice)."""
    from ...tooling.cutter_selection import tool_size_key
    from .reach import room_bound

    lens = np.array([b - a for a, b in remaining])
    m = np.maximum(1, np.round(n * lens / lens.sum()).astype(int))
    u = np.concatenate([a + (b - a) * (np.arange(k) + 0.5) / k for (a, b), k in zip(remaining, m)])
    # one bound per tip sphere, rounded down to 3 digits (a bound proven for a smaller ball holds for larger)
    key = {i: _floor3(tools[i][1].r1s) for i in pool}
    share = {}
    for r in sorted(set(key.values())):
        share[r] = float(1.0 - room_bound(surface, u, r, slack).proven.mean())
    best = max(share.values())
    rec = {"samples": int(len(u)), "share_by_tip_sphere": {f"{r:.6g}": v for r, v in share.items()}, "best": best}
    if best <= 0.0:
        rec["reason"] = "every tool left is proven unable to mill what remains within the tolerance"
        return None, rec
    need = (0.5 if first else 1.0) * best - 1e-12
    ok = [i for i in pool if share[key[i]] >= need]
    ti = max(ok, key=lambda i: tool_size_key(tools[i][1]))
    rec.update(tool=tools[ti][0], share=share[key[ti]])
    return ti, rec


def _floor3(x):
    """x rounded down to three significant digits."""
    e = 10.0 ** (math.floor(math.log10(x)) - 2)
    return math.floor(x / e * (1 + 1e-12)) * e


def _part_fraction(plan, ver, flank, tol, eps_over, per, ranges, u_range):
    """Verified share of the arc length of the flank's points whose parameter lies in ``ranges``."""
    from .residual import flank_points

    idx, raw, _, w = flank_points(plan, flank)
    n = len(plan["rotor"]["profile"])
    u = np.array([_unwrap(x * per / n, u_range, per) for x in raw])
    dev = np.full(n, np.nan)
    for i, _, _, d in ver["deviation_profile"]:
        dev[i] = np.inf if d is None else d
    d = dev[idx]
    inside = np.zeros(len(u), bool)
    for a, b in ranges:
        inside |= (u >= a) & (u <= b)
    ok = inside & np.isfinite(d) & (d <= tol) & (d >= -eps_over)
    tot = float(w[inside].sum())
    return float(w[ok].sum() / tot) if tot > 0 else 0.0


def _unwrap(u, u_range, per):
    """Profile parameter u moved by whole periods into (or nearest to) the flank's range."""
    a, b = u_range
    k = math.floor((a - u) / per + 0.5)
    v = u + k * per
    if v < a - 0.5 * per:
        v += per
    return float(v)


def _flank_of_u(u, flank_ranges, surface):
    from .residual import flank_index

    return flank_index(u, flank_ranges, float(surface.profile.period))


def _relation(f, target):
    from .residual import flank_relation

    return flank_relation(int(f), int(target))


def _bound(surface, a, b, radius, slack, n=9):
    """:func:`.reach.room_bound` at n samples of [a, b]: whether (and where) it proves the range unreachable."""
    from .reach import room_bound

    u = np.linspace(a, b, n) if b > a else np.array([a])
    rb = room_bound(surface, u, radius, slack)
    if not rb.proven.any():
        return {"proven": False, "radius": float(radius), "samples": int(len(u))}
    up = u[rb.proven]
    return {"proven": True, "radius": float(radius), "samples": int(len(u)), "proven_samples": int(rb.proven.sum()),
            "u_range": [float(up.min()), float(up.max())], "depth_min": float(rb.depth[rb.proven].min()),
            "depth_max": float(rb.depth[rb.proven].max())}


def _json_range(ru):
    out = {k: v for k, v in ru.items() if k != "tools"}
    if "tools" in ru:
        out["tools"] = [{k: v for k, v in t.items()} for t in ru["tools"]]
    return out


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
    p = np.asarray(point, float).reshape(3)
    if not np.isfinite(p).all():
        raise ValueError(f"flank point {point} must be three finite numbers")
    u, _ = surface.nearest_section_param(p)
    per = surface.profile.period
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
