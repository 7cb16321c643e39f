"""How the double-flank axis optimisation depends on the order of its evaluations.

Each evaluation of Phi (Bizzarri & Bartoň 2021, Eq. (11)) at an axis x finds the feet of the 100 axis samples on
the valley's two flanks by Newton, starting from the feet of the previous evaluation (a warm start) and guarded by
an approximate kd-tree seed that restarts a row when the seed is nearer than the warm foot.  The five SLSQP starts
run one after the other and share that chain of warm starts.  For each built-in rotor (valley 0) this prints:

- ``planned``: each start's Phi (in R) as the planner runs them, and the best (the plan's axis);
- ``own``: the same starts, each warm-started from the axis (0, 0, 0) instead of from the start before (what
  running the starts side by side, or batching their evaluations, does);
- ``grid``: nine other starts (alpha in -0.2, 0, 0.2; delta / R = phi in -0.1, 0, 0.1), in the planner's order;
- ``history``: the evaluations of the planned run whose warm-started feet lie farther than the feet from 8 exact
  table seeds (a local minimum, up to how far, in R), and the largest difference between the Phi the optimiser saw
  there and the Phi at the same axis from those feet;
- ``ends``: the same comparison at each start's final axis, the one the plan reports.

Times are the optimisation's own (one process, after a first run that loads the modules).

    PYTHONPATH=. .venv/bin/python bench/bench_axis_paths.py [--rotors asymmetric-female,nilson-male,...]
"""
import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from flank_addon.geometry.flank_feet import FlankFeet  # noqa: E402
from flank_addon.geometry.rotors import builtin_by_name  # noqa: E402
from flank_addon.methods.double_flank import planner as dfp  # noqa: E402

GRID = [(a, d, d) for a in (-0.2, 0.0, 0.2) for d in (-0.1, 0.0, 0.1)]


def cold_phi(valley, x, n=100):
    """Phi / R at the axis x (evaluator coordinates) from the feet of 8 exact table seeds per sample."""
    lam = np.linspace(*valley.lam_range, n)
    points, _ = dfp.axis_points(np.asarray(x, float), lam, valley.theta, valley.outer_radius)
    feet = [FlankFeet.many([fs], [points], [None], k=8)[0] for fs in valley.feet]
    both = feet[0].interior & feet[1].interior
    gap = np.abs(feet[0].distance - feet[1].distance)[both]
    return float(gap.max()) / valley.outer_radius if len(gap) else 0.0


class WatchedEvaluator(dfp.AxisEvaluator):
    """The planner's evaluator, each answer compared with feet from 8 exact table seeds (no warm start)."""

    def __init__(self, valley):
        super().__init__(valley)
        self.evaluated = self.local = 0
        self.worst_foot = self.worst_phi = 0.0

    def multi(self, requests):
        out = super().multi(requests)
        for (x, lam, solvers, tag), ar in zip(requests, out):
            solvers = self.valley.feet if solvers is None else solvers
            cold = [FlankFeet.many([fs], [ar.points], [None], k=8)[0] for fs in solvers]
            r_cold = np.array([ft.distance for ft in cold])
            gap = (ar.r - r_cold) / self.R
            self.evaluated += 1
            if (gap > 1e-12).any():
                self.local += 1
                self.worst_foot = max(self.worst_foot, float(gap.max()))
                if len(solvers) == 2:
                    both = np.array([ft.interior for ft in cold]).all(axis=0)
                    seen = dfp.phi_value(ar)
                    true = float(np.max(np.abs(r_cold[0] - r_cold[1])[both])) if both.any() else 0.0
                    self.worst_phi = max(self.worst_phi, abs(seen - true) / self.R)
        return out


def run(valley, starts, on_their_own=False):
    """(best Phi / R, [Phi / R of each start], seconds)."""
    R = valley.outer_radius
    t0 = time.perf_counter()
    if on_their_own:
        fits = [dfp.optimize_axis(valley, starts=[s], evaluator=dfp.AxisEvaluator(valley)) for s in starts]
        per = [f.per_start[0][2] for f in fits]
    else:
        fit = dfp.optimize_axis(valley, starts=starts, evaluator=dfp.AxisEvaluator(valley))
        per = [p[2] for p in fit.per_start]
    dt = time.perf_counter() - t0
    return min(per) / R, [p / R for p in per], dt


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rotors", default="asymmetric-female,asymmetric-male,nilson-female,nilson-male,srm_a-female,"
                                        "srm_a-male")
    args = ap.parse_args()
    fmt = lambda v: " ".join(f"{p:.7f}" if np.isfinite(p) else "    left" for p in v)  # noqa: E731
    for name in args.rotors.split(","):
        rotor = builtin_by_name(name)
        valley = dfp.Valley(rotor.surface(), rotor.flanks, 0)
        starts = dfp.default_starts(valley)
        run(valley, starts)                       # modules loaded, seed tables made
        for label, st, own in (("planned", starts, False), ("own", starts, True), ("grid", GRID, False)):
            best, per, dt = run(valley, st, own)
            print(f"{name:18s} {label:8s} best {best:.7f}  starts {fmt(per)}  {dt:.2f} s", flush=True)
        ev = WatchedEvaluator(valley)
        fit = dfp.optimize_axis(valley, starts=starts, evaluator=ev)
        print(f"{name:18s} history  {ev.local} of {ev.evaluated} evaluations with a warm foot in a local minimum, "
              f"up to {ev.worst_foot:.3g} R farther; Phi seen off by up to {ev.worst_phi:.3g} R", flush=True)
        R = valley.outer_radius
        ends = [abs(p[2] / R - cold_phi(valley, p[1])) for p in fit.per_start if np.isfinite(p[2])]
        print(f"{name:18s} ends     Phi of the {len(ends)} final axes against exact seeds: largest difference "
              f"{max(ends):.3g} R", flush=True)


if __name__ == "__main__":
    main()
