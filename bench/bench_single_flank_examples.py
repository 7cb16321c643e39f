"""Bizzarri, Bo & Bartoň Examples 6.2-6.6 analogues: multi-strip single-flank plans on the built-in asymmetric rotors.

    python bench/bench_single_flank_examples.py [--seeds 18] [--cases NAME,...]

For each case: the paper's cone (alpha, r1c, r2c in units of the outer radius R = 1) and error
threshold on one flank of our built-in asymmetric rotors (valley 0: flank 0 = X1, tip to bottom;
flank 1 = X2, bottom to the next tip), the full pipeline of methods.single_flank.planner.plan_single_flank (seeds,
hard-mode optimisation, global collisions, minimum cover with adaptive seeding, simulation), and
the outcome: strips chosen of the candidates, the simulated max error and overcut, uncovered flank
ranges, time.  The paper's rows are printed beside them for context; its 'N' rotors differ from ours.
"""
import argparse
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from flank_addon.tooling.cone import ConeTool  # noqa: E402
from flank_addon.methods.single_flank.planner import plan_single_flank  # noqa: E402
from flank_addon.geometry.rotors import builtin_by_name  # noqa: E402

# name: (rotor, flank, alpha, r1c, r2c, tolerance, paper row)
CASES = {
    "ex6.2-female-X1": ("asymmetric-female", 0, math.sin(0.3), 0.10, 0.18, 0.004,
                        "one strip 0.01653; more strips (threshold not given)"),
    "ex6.3-female-X2": ("asymmetric-female", 1, math.sin(0.1), 0.129, 0.18, 0.004,
                        "14 of 18 positions, eps_max 0.00143"),
    "ex6.4-female-X2-large": ("asymmetric-female", 1, math.sin(0.2), 0.07, 0.20, 0.01, "3 of 6 positions"),
    "ex6.5-male-X1": ("asymmetric-male", 0, math.sin(0.1), 0.12, 0.14, 0.003,
                      "7 of 12 (hyperbolic part) + 7 of 12 (elliptic)"),
    "ex6.6-male-X2": ("asymmetric-male", 1, math.sin(0.1), 0.11, 0.13, 0.002,
                      "11 positions, eps_max 0.00136; elliptic 5 of 6"),
}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=18)
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--shank", type=float, nargs=2, default=(0.0, 0.0), metavar=("RADIUS", "LENGTH"))
    args = ap.parse_args()
    print(f"{'case':24s} {'tool (alpha, r1c, r2c)':24s} {'eps':>6s} {'strips':>9s} {'max err':>9s} "
          f"{'overcut':>9s} {'gouges':>6s} {'uncovered':>9s} {'time s':>7s}   paper")
    for name in args.cases.split(","):
        rotor, flank, alpha, r1, r2, tol, paper = CASES[name]
        r = builtin_by_name(rotor)
        tool = ConeTool(alpha, r1, r2, *args.shank)
        t0 = time.perf_counter()
        res = plan_single_flank(r.surface(), r.flanks, flank, tool, tol, n_seeds=args.seeds)
        dt = time.perf_counter() - t0
        v = res.verify
        unc = sum(b - a for a, b in res.uncovered) / (r.flanks[flank][1] - r.flanks[flank][0])
        print(f"{name:24s} ({alpha:.4f}, {r1:.3f}, {r2:.3f})  {tol:6.3g} "
              f"{len(res.strips):3d} of {len(res.candidates):3d} {v['max_undercut']:9.2e} {v['max_overcut']:+9.1e} "
              f"{len(v['gouge_points']):6d} {unc:8.1%} {dt:7.2f}   {paper}", flush=True)


if __name__ == "__main__":
    main()
