"""Kinks against accuracy on the README's bump (Rajain et al. 2023 Figs. 15-17, ), beside the lower bound.

Plans the 100 mm bump (6 mm high, width 25 mm) with the tool r1 = 1, r2 = 3, L = 10 mm for a row
of G1 weights w3 at w2 = 0.005 and prints, per plan, the max kink, the max |error| and the least
max |error| any conical plan with that max kink can have across the bump's central section
(:func:`flank_addon.methods.freeform_g1.kink_bound.kink_error_bound`), the max |error| straight strips on the plan's
own boundaries reach at that kink (:func:`flank_addon.methods.freeform_g1.kink_bound.fixed_junction_error`), and the
least max kink possible within twice the w3 = 0 error.

    PYTHONPATH=. .venv/bin/python tools/g1_tradeoff.py [--w3 0,0.001,0.01,0.1,1]
"""
import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from flank_addon.geometry.freeform_surfaces import bump  # noqa: E402
from flank_addon.methods.freeform_g1.planner import plan_freeform  # noqa: E402
from flank_addon.methods.freeform_g1.kink_bound import fixed_junction_error, kink_error_bound, kink_floor_deg  # noqa: E402

BUMP = dict(size=100.0, resolution=100, height=6.0, width=25.0)
TOOL = dict(r1=1.0, r2=3.0, L=10.0)


def plan_bump(S, w3, w2=0.005):
    return plan_freeform(S.vertices, S.faces, direction=[1, 0, 0], point=S.point(np.zeros((1, 2)))[0],
                         n_columns=20, n_ruling_samples=30, weights=[1, w2, w3, 1e-4, 1e-3], **TOOL)


def central_section(S, plan, n=801):
    """The bump's section x = 0 between the first and last guiding curve -> (y, z, curve abscissae)."""
    ys = []
    for curve in plan["guiding"]["curves"]:
        for pts in curve:
            p = np.asarray(pts)
            o = np.argsort(p[:, 0])
            if p[o[0], 0] <= 0.0 <= p[o[-1], 0]:
                ys.append(float(np.interp(0.0, p[o, 0], p[o, 1])))
    ys = np.sort(ys)
    y = np.linspace(ys[0], ys[-1], n)
    z = S.point(np.column_stack([np.zeros(n), y]))[:, 2]
    return y, z, ys


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--w3", default="0,0.0003,0.001,0.003,0.01,0.03,0.1,1")
    args = ap.parse_args()
    S = bump(**BUMP)
    print("| w3 | max kink (deg) | mean kink (deg) | error max / min (mm) | max abs error (mm) | "
          "least possible at that kink (mm) | straight strips on these boundaries (mm) | time (s) |")
    print("|---|---|---|---|---|---|---|---|")
    e0 = None
    for w3 in (float(v) for v in args.w3.split(",")):
        t = time.perf_counter()
        plan = plan_bump(S, w3)
        s = plan["summary"]
        y, z, ys = central_section(S, plan)
        nj = len(ys) - 2
        e = max(s["max_error"], -s["min_error"])
        e0 = e if e0 is None else e0
        bound = kink_error_bound(y, z, s["max_kink_deg"], nj)
        print(f"| {w3:g} | {s['max_kink_deg']:.3g} | {s['mean_kink_deg']:.3g} | {s['max_error']:+.3g} / "
              f"{s['min_error']:+.3g} | {e:.3g} | {bound:.3g} | {fixed_junction_error(y, z, ys, s['max_kink_deg'])[0]:.3g} | "
              f"{time.perf_counter() - t:.1f} |", flush=True)
        if w3 == 0.0:
            print(f"<!-- section x = 0: {nj} junctions; least max kink within 2 x {e:.3g} mm: "
                  f"{kink_floor_deg(y, z, 2 * e, nj):.3g} deg; the target 1/5 of {s['max_kink_deg']:.3g} deg "
                  f"needs >= {kink_error_bound(y, z, s['max_kink_deg'] / 5, nj):.3g} mm -->", flush=True)


if __name__ == "__main__":
    main()
