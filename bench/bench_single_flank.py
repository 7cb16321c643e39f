"""Full single-flank pipeline (methods.single_flank.planner.plan_single_flank: seeds, optimised candidates, global
collision, adaptive cover, junction kinks, verify) with our optimiser vs the same pipeline with the
paper's optimiser (Bizzarri, Bo & Bartoň Remark 5.1: finite-difference gradient descent on the weighted Phi1, w = 100).

    PYTHONPATH=. .venv/bin/python bench/bench_single_flank.py [repeats] [rotor] [flank] [n_seeds]

How the comparison is made (and why)
------------------------------------
* Same rotor, flank, tool (ConeTool(asin 0.1, 0.05, 0.08, 0.04, 0.6)), tolerance 1e-3, 18 first-round
  seeds, same collision / cover / junction / verify stages: only the pose optimiser differs
  (``plan_single_flank(optimizer=...)``).
* Ours: the pipeline's default, hard mode (no overcut along the axis, Eq. (30) style).
  Baseline: :func:`flank_addon.methods.single_flank.poses.fd_gradient_descent_poses` (the paper's descent, anchored at each
  seed's depth like ours) with two stopping rules: the paper's |x_(i+1) - x_i| < 1e-5 ("paper"),
  and a tight one (1e-9, up to 20000 iterations, "to convergence") so it is not judged by an early
  stop.  The paper's objective has no hard constraint, so its poses may overcut slightly; the cover
  stage rejects any pose that overcuts by more than 1e-6 R (then it reseeds, or reports gaps).
* Reported per run: stage timings, strips chosen, verify's max undercut / overcut (the machined
  errors, the figure of merit), uncovered ranges; the ratio is total baseline time / total ours.
  "Equal or lower max error" is checked on verify's max undercut with overcut >= -1e-6 R.
* Junctions: one ``junction_kinks_chain`` over the chosen strips, fed with the cover stage's
  deviations (the same for both optimisers).
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

from flank_addon.methods.single_flank import planner as multi_strip
from flank_addon.methods.single_flank import poses as sf
from flank_addon.tooling.cone import ConeTool
from flank_addon.geometry.rotors import builtin_by_name

TOOL = ConeTool(math.asin(0.1), 0.05, 0.08, 0.04, 0.6)


def run(surface, flanks, flank, n_seeds, optimizer=None):
    t = time.perf_counter()
    res = multi_strip.plan_single_flank(surface, flanks, flank, TOOL, 1e-3, n_seeds=n_seeds, optimizer=optimizer)
    total = time.perf_counter() - t
    v = res.verify
    return dict(total=total, t=res.timings, strips=len(res.strips), cands=len(res.candidates),
                max_err=v["max_undercut"], min_err=v["max_overcut"], uncovered=res.uncovered,
                phi=np.array([c.convergence.phi_end for c in res.candidates]))


def main(repeats=3, name="asymmetric-female", flank=1, n_seeds=18):
    r = builtin_by_name(name)
    s = r.surface()
    runs = {"ours": [], "paper (eps 1e-5)": [], "paper (to convergence)": []}
    opts = {"ours": None,
            "paper (eps 1e-5)": sf.fd_gradient_descent_poses,
            "paper (to convergence)": functools.partial(sf.fd_gradient_descent_poses, eps=1e-9, fd_max_iter=20000)}
    for _ in range(repeats):
        for k in runs:
            runs[k].append(run(s, r.flanks, flank, n_seeds, opts[k]))
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
