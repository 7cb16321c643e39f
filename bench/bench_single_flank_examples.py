"""Bizzarri, Bo & Bartoň Examples 6.2-6.6 analogues: multi-strip single-flank plans on the built-in asymmetric rotors.

    python bench/bench_single_flank_examples.py [--cases NAME,...] [--adaptive-only | --paper-only]

For each case: the paper's cone (alpha, r1c, r2c in units of the outer radius R = 1), error threshold and number of
initial positions on one flank of our built-in asymmetric rotors (valley 0: flank 0 = X1, tip to bottom; flank 1 =
X2, bottom to the next tip).  Examples 6.5 and 6.6 plan the hyperbolic and the elliptic part of the flank each in
its own run (``split``), with the paper's counts per part.  Two runs per case and part:

* ``paper``: the paper's initial positions only (uniform along the profile, one round: no seeds added);
* ``adaptive``: the planner's defaults (8 first seeds, then seeds where the flank is not yet covered).

Printed: strips chosen of the candidates, the simulated max error and overcut, gouges, the verified share of the
flank (or part) within the threshold, time.  The paper's row (its Table 1 maximum errors and the positions that
met its requirements) is printed beside it for context; its 'N' rotors differ from ours.
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

# name: (rotor, flank, alpha, r1c, r2c, threshold, {part: initial positions}, paper row)
CASES = {
    "ex6.2-female-X1": ("asymmetric-female", 0, math.sin(0.3), 0.10, 0.18, 0.002, {None: 18},
                        "15 of 18 positions; eps_max 0.00143 (Table 1, Fig. 11)"),
    "ex6.3-female-X2": ("asymmetric-female", 1, math.sin(0.1), 0.129, 0.18, 0.004, {None: 18},
                        "14 of 18 positions; eps_max 0.00357 (Table 1, Fig. 12)"),
    "ex6.4-female-X2-large": ("asymmetric-female", 1, math.sin(0.2), 0.07, 0.20, 0.01, {None: 6},
                              "3 of 6 positions; eps_max 0.00489 (Table 1, Fig. 13)"),
    "ex6.5-male-X1": ("asymmetric-male", 0, math.sin(0.1), 0.12, 0.14, 0.003, {"hyperbolic": 12, "elliptic": 12},
                      "hyperbolic 7 of 12, elliptic 7 of 12; eps_max 0.00294 (Table 1, Fig. 14)"),
    "ex6.6-male-X2": ("asymmetric-male", 1, math.sin(0.1), 0.11, 0.13, 0.002, {"hyperbolic": 11, "elliptic": 6},
                      "hyperbolic 11 of 11, elliptic 5 of 6; eps_max 0.00136 (Table 1, Fig. 14)"),
}


def run(r, flank, tool, tol, part, seeds, adaptive):
    kw = dict(n_seeds=seeds, split=part)
    if not adaptive:
        kw.update(max_rounds=1)
    t0 = time.perf_counter()
    res = plan_single_flank(r.surface(), r.flanks, flank, tool, tol, **kw)
    dt = time.perf_counter() - t0
    summ = res.plan["summary"]
    share = summ["split"]["covered_fraction"] if part is not None else res.covered_fraction
    return res, share, dt


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--shank", type=float, nargs=2, default=(0.0, 0.0), metavar=("RADIUS", "LENGTH"))
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--adaptive-only", action="store_true")
    mode.add_argument("--paper-only", action="store_true")
    args = ap.parse_args()
    modes = [m for m in (("paper", False), ("adaptive", True))
             if not (args.adaptive_only and not m[1]) and not (args.paper_only and m[1])]
    print(f"{'case':22s} {'part':10s} {'run':8s} {'tool (alpha, r1c, r2c)':24s} {'eps':>6s} {'seeds':>5s} "
          f"{'strips':>10s} {'max err':>9s} {'overcut':>9s} {'gouges':>6s} {'within':>7s} {'time s':>7s}   paper")
    for name in args.cases.split(","):
        rotor, flank, alpha, r1, r2, tol, parts, paper = CASES[name]
        r = builtin_by_name(rotor)
        tool = ConeTool(alpha, r1, r2, *args.shank)
        for part, seeds in parts.items():
            for label, adaptive in modes:
                res, share, dt = run(r, flank, tool, tol, part, seeds, adaptive)
                v = res.verify
                n_seeds = sum(t["seeds"] for t in res.tools)
                mx = "n/a" if v["max_undercut"] is None else f"{v['max_undercut']:.2e}"
                mn = "n/a" if v["max_overcut"] is None else f"{v['max_overcut']:+.1e}"
                print(f"{name:22s} {part or 'whole':10s} {label:8s} ({alpha:.4f}, {r1:.3f}, {r2:.3f})  {tol:6.3g} "
                      f"{n_seeds:5d} {len(res.strips):3d} of {len(res.candidates):3d} {mx:>9s} {mn:>9s} "
                      f"{len(v['gouge_points']):6d} {share:7.1%} {dt:7.2f}   {paper}", flush=True)
                for ru in res.plan["summary"].get("uncovered", []) if share < 1.0 else []:
                    print(f"{'':22s}   uncovered u {ru['u_range'][0]:.4f}..{ru['u_range'][1]:.4f}: {ru['reason'][:150]}")


if __name__ == "__main__":
    main()
