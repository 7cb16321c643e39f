"""Full single-flank pipeline (multi_strip.plan_single_flank: seeds, optimised candidates, global
collision, adaptive cover, junction kinks, verify) with our optimiser vs the same pipeline with the
paper's optimiser (s000 Remark 5.1: finite-difference gradient descent on the weighted Phi1, w = 100).

    PYTHONPATH=. .venv/bin/python bench/bench_single_flank.py [repeats] [rotor] [flank] [n_seeds]

How the comparison is made (and why)
------------------------------------
* Same rotor, flank, tool (ConeTool(asin 0.1, 0.05, 0.08, 0.04, 0.6)), tolerance 1e-3, 18 first-round
  seeds, same collision / cover / junction / verify stages: only the pose optimiser differs
  (``candidate_strips(optimizer=...)``, patched into multi_strip for the baseline run; the
  pipeline's own argument for it is a proposal to the multi_strip owner).
* Ours: the pipeline's default, hard mode (no overcut along the axis, Eq. (30) style).
  Baseline: :func:`single_flank.fd_gradient_descent_poses` (the paper's descent, anchored at each
  seed's depth like ours) with two stopping rules: the paper's |x_(i+1) - x_i| < 1e-5 ("paper"),
  and a tight one (1e-9, up to 20000 iterations, "to convergence") so it is not judged by an early
  stop.  The paper's objective has no hard constraint, so its poses may overcut slightly; the cover
  stage rejects any pose that overcuts by more than 1e-6 R (then it reseeds, or reports gaps).
* Reported per run: stage timings, strips chosen, verify's max undercut / overcut (the machined
  errors, the figure of merit), uncovered ranges; the ratio is total baseline time / total ours.
  "Equal or lower max error" is checked on verify's max undercut with overcut >= -1e-6 R.
* Junctions: the pipeline samples the two tools of every pair again (2.9 s); the bench also runs the
  proposed multi_strip change (one ``junction_kinks_chain`` over the chosen strips fed with the
  cover's deviations, ``AdaptiveCover.chosen_coverage``) by patching, for both optimisers alike; the
  row "ours, junctions as-is" is the current multi_strip code.
* Amdahl: collision, cover and verify (~0.9 s here) are the same code in both pipelines, so the
  ratio of *totals* cannot reach 20x; the optimiser stage alone is compared in
  bench_single_flank_opt.py.
* Runs alternate (ours, baseline, ours, ...) ``repeats`` times; min and max are printed since the
  machine is shared.
"""
import functools
import math
import sys
import time

import numpy as np

from flank_addon import multi_strip, single_flank as sf, strip_cover
from flank_addon.cone import ConeTool
from flank_addon.rotors import builtin_by_name

TOOL = ConeTool(math.asin(0.1), 0.05, 0.08, 0.04, 0.6)


def _with_cover_deviations():
    """Patch strip_cover so the pipeline's per-pair junction_kinks calls are answered by one
    junction_kinks_chain over the chosen strips (in the pipeline's flank order) fed with the cover
    stage's deviations (the proposed multi_strip change).  Returns an undo function."""
    orig_cover, orig_junc = strip_cover.adaptive_cover, strip_cover.junction_kinks
    state = {}

    def cover(*a, **k):
        res = orig_cover(*a, **k)
        state.clear()
        state["cover"] = res
        return res

    def junc(a, b, surface, flank_range=None, **kw):
        cov = state.get("cover")
        if cov is None:
            return orig_junc(a, b, surface, flank_range, **kw)
        if "pairs" not in state:
            order = sorted(range(len(cov.poses)), key=lambda i: min((iv[0] for iv in cov.intervals[i]), default=math.inf))
            poses = [cov.poses[i] for i in order]
            devs = np.array([cov.chosen_coverage[i].deviation for i in order])
            ch = strip_cover.junction_kinks_chain(poses, surface, flank_range, samples=cov.samples, deviations=devs)
            state["pairs"] = {(id(p), id(q)): js for p, q, js in zip(poses, poses[1:], ch)}
        return state["pairs"][(id(a), id(b))]

    strip_cover.adaptive_cover, strip_cover.junction_kinks = cover, junc

    def undo():
        strip_cover.adaptive_cover, strip_cover.junction_kinks = orig_cover, orig_junc
    return undo


def run(surface, flanks, flank, n_seeds, optimizer=None, cover_devs=True):
    orig = multi_strip.candidate_strips
    if optimizer is not None:
        multi_strip.candidate_strips = functools.partial(sf.candidate_strips, optimizer=optimizer)
    undo = _with_cover_deviations() if cover_devs else (lambda: None)
    try:
        t = time.perf_counter()
        res = multi_strip.plan_single_flank(surface, flanks, flank, TOOL, 1e-3, n_seeds=n_seeds)
        total = time.perf_counter() - t
    finally:
        multi_strip.candidate_strips = orig
        undo()
    v = res.verify
    return dict(total=total, t=res.timings, strips=len(res.strips), cands=len(res.candidates),
                max_err=v["max_undercut"], min_err=v["max_overcut"], uncovered=res.uncovered,
                phi=np.array([c.convergence.phi_end for c in res.candidates]))


def main(repeats=3, name="asymmetric-female", flank=1, n_seeds=18):
    r = builtin_by_name(name)
    s = r.surface()
    runs = {"ours": [], "ours, junctions as-is": [], "paper (eps 1e-5)": [], "paper (to convergence)": []}
    opts = {"ours": None, "ours, junctions as-is": None,
            "paper (eps 1e-5)": sf.fd_gradient_descent_poses,
            "paper (to convergence)": functools.partial(sf.fd_gradient_descent_poses, eps=1e-9, fd_max_iter=20000)}
    for _ in range(repeats):
        for k in runs:
            runs[k].append(run(s, r.flanks, flank, n_seeds, opts[k], cover_devs=k != "ours, junctions as-is"))
    stages = ("candidates", "collision", "cover", "junctions", "verify")
    print(f"{name} flank {flank}, {n_seeds} seeds, tol 1e-3, {repeats} alternating runs (min-max seconds)")
    print(f"{'optimiser':24s} {'total':>13s} " + " ".join(f"{st:>13s}" for st in stages)
          + f" {'strips':>6s} {'max err':>9s} {'min err':>9s} uncovered")
    for k, rs in runs.items():
        rng = lambda v: f"{min(v):6.2f}-{max(v):<6.2f}"  # noqa: E731
        last = rs[-1]
        print(f"{k:24s} {rng([x['total'] for x in rs])} " + " ".join(rng([x['t'][st] for x in rs]) for st in stages)
              + f" {last['strips']:6d} {last['max_err']:9.3e} {last['min_err']:9.2e} {len(last['uncovered'])}")
    ours = [x["total"] for x in runs["ours"]]
    for k in ("paper (eps 1e-5)", "paper (to convergence)"):
        base = [x["total"] for x in runs[k]]
        ratios = [b / o for b, o in zip(base, ours)]
        eq = all(o["max_err"] <= b["max_err"] + 1e-12 and o["min_err"] >= -1e-6 for o, b in zip(runs["ours"], runs[k]))
        print(f"speed-up vs {k}: {min(ratios):.1f}-{max(ratios):.1f}x (pairwise per run); "
              f"ours max error <= baseline's: {eq}; baseline uncovered ranges: {len(runs[k][-1]['uncovered'])}")


if __name__ == "__main__":
    a = sys.argv[1:]
    main(int(a[0]) if a else 3, a[1] if len(a) > 1 else "asymmetric-female", int(a[2]) if len(a) > 2 else 1,
         int(a[3]) if len(a) > 3 else 18)
