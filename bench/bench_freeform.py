"""Rajain et al. 2023 free-form planner: time of the 11 x 20 x 30 size (11 strips x 20 rulings x 30 samples on a
20k-triangle surface), ours (analytic sparse Jacobian) beside a baseline run of the same problem
with scipy's finite-difference Jacobian (same sparsity pattern, '2-point'), and the paper's
figure (Table 1 sizes took "around 30 minutes", 65 min at worst, §7.1).

    PYTHONPATH=. .venv/bin/python bench/bench_freeform.py [--baseline-evals 15]
"""
import argparse
import time

import numpy as np
import scipy.sparse as sp
from scipy.optimize import least_squares

from flank_addon.methods.freeform_g1 import guiding
from flank_addon.geometry.freeform_surfaces import bump
from flank_addon.methods.freeform_g1.planner import DEFAULT_WEIGHTS, Layout, Objective, plan_freeform
from flank_addon.methods.freeform_g1.initial_rulings import initial_rulings
from flank_addon.geometry.mesh_distance import TriangleMesh

R1, R2, L = 0.01, 0.03, 0.09            # spacing d = sqrt(L^2 - (r2 - r1)^2): 11 strips on the unit bump
D = (L * L - (R2 - R1) ** 2) ** 0.5     # the central curve half a spacing off the bump's top: 12 curves


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--baseline-evals", type=int, default=5, help="evaluations of the finite-difference baseline")
    args = ap.parse_args()
    S = bump(size=1.0, resolution=100)
    print(f"surface: unit Gaussian bump, {len(S.faces)} triangles; tool r1 {R1}, r2 {R2}, L {L}")
    times = []
    for _ in range(3):
        t = time.perf_counter()
        plan = plan_freeform(S.vertices, S.faces, direction=[1, 0, 0], point=S.point(np.array([[0.0, D / 2]]))[0],
                             r1=R1, r2=R2, L=L, n_columns=20, n_ruling_samples=30)
        times.append(time.perf_counter() - t)
    s, o = plan["summary"], plan["optimization"]
    n = [len(st["rulings"]) for st in plan["strips"]]
    print(f"ours: {s['strips']} strips x {min(n)}..{max(n)} rulings x {o['samples_per_ruling']} samples, "
          f"{o['n_variables']} unknowns, {o['evaluations']} evaluations")
    print(f"  end to end {min(times):.2f} .. {max(times):.2f} s (3 runs), optimisation {o['elapsed_s']:.2f} s; "
          f"max error {s['max_error']:+.4g}, min {s['min_error']:+.4g}, kink max {s['max_kink_deg']:.3f} deg, "
          f"mean {s['mean_kink_deg']:.3f} deg")

    # baseline: the same least-squares problem with a finite-difference Jacobian
    mesh = TriangleMesh(S.vertices, S.faces)
    gc = guiding.guiding_curves(S.vertices, S.faces, direction=[1, 0, 0], point=S.point(np.array([[0.0, D / 2]]))[0],
                                r1=R1, r2=R2, L=L)
    lengths = [sum(pl.length for pl in c.polylines) for c in gc.curves]
    gc = guiding.guiding_curves(S.vertices, S.faces, direction=[1, 0, 0], point=S.point(np.array([[0.0, D / 2]]))[0],
                                r1=R1, r2=R2, L=L, step=float(np.median(lengths)) / 19)
    strips = [st for st in gc.strips if len(st.columns) >= 2]
    ini = initial_rulings(gc.bases, strips, R1, R2, L)
    lay = Layout(gc.bases, strips)
    m0 = np.concatenate(ini.m)
    n0 = np.concatenate([b.normals for b in gc.bases])
    obj = Objective(mesh, lay, n0, m0, R1, R2, L, 30, DEFAULT_WEIGHTS)
    x0 = obj.pack(m0)
    pattern = sp.csr_matrix(obj.jac(x0) != 0)
    for label, jac, kw in (("analytic", obj.jac, {}), ("finite differences", "2-point", {"jac_sparsity": pattern})):
        t = time.perf_counter()
        sol = least_squares(obj.fun, x0, jac=jac, method="trf", tr_solver="lsmr", x_scale="jac",
                            max_nfev=args.baseline_evals, **kw)
        dt = time.perf_counter() - t
        print(f"  {label:18s}: {sol.nfev} iterations in {dt:.2f} s ({dt / sol.nfev:.3f} s each), cost {sol.cost:.4g}")
        if label == "analytic":
            base = dt / sol.nfev
        else:
            print(f"  ratio finite differences / analytic per iteration: {dt / sol.nfev / base:.1f}x")
    print(f"paper (Rajain et al. 2023 7.1, Python + TensorFlow, laptop): about 30 min per example, 65 min at worst -> "
          f"{30 * 60 / min(times):.0f}x the paper's typical time")


if __name__ == "__main__":
    main()
