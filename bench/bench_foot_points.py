"""Foot points on a helical surface: exact global solver vs a KD-tree brute-force baseline.

Both run side by side on one core, on the same queries (points in the
rotor's cylinder of the built-in asymmetric female rotor).  The baseline
is what one would otherwise do: screw each query into z = 0 and look up
the nearest of a dense set of surface samples (its error is the sampling
error, so it is also printed).  Prints queries per second and the ratio.

    .venv/bin/python bench/bench_foot_points.py [--queries 100000]
"""
import argparse
import os
import sys
import time

for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")
sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

import numpy as np  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402

from flank_addon.geometry.rotors import builtin_by_name  # noqa: E402
from flank_addon.geometry.screw import screw_motion, screw_to_plane  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--queries", type=int, default=100_000)
    ap.add_argument("--rotor", default="asymmetric-female")
    ap.add_argument("--baseline-queries", type=int, default=5_000,
                    help="brute force is slow: it runs on the first N queries, rates are per query")
    args = ap.parse_args()
    rotor = builtin_by_name(args.rotor)
    surf = rotor.surface()
    rng = np.random.default_rng(0)
    n = args.queries
    r = np.sqrt(rng.uniform(0, 1.0, n)) * surf.outer_radius
    phi = rng.uniform(0, 2 * np.pi, n)
    q = np.c_[r * np.cos(phi), r * np.sin(phi), rng.uniform(0, rotor.length, n)]

    t0 = time.perf_counter()
    surf.foot_points(q[:10])  # builds the per-surface global-foot table once
    t_table = time.perf_counter() - t0
    t0 = time.perf_counter()
    fp = surf.foot_points(q)
    t_ours = time.perf_counter() - t0

    # baseline: dense samples of the surface band that can hold a foot point, one KD-tree query each
    m = min(n, args.baseline_queries)
    u = surf.profile.params(3000)
    p = np.c_[surf.profile.eval(u), np.zeros(len(u))]
    tmax = 1.05 * surf.outer_radius / surf.v0
    t = np.linspace(-tmax, tmax, int(2 * tmax / (2 * np.pi / 3000)))
    t0 = time.perf_counter()
    samples = screw_motion(p[:, None, :], t[None, :], surf.v0, surf.hand).reshape(-1, 3)
    tree = cKDTree(samples)
    t_build = time.perf_counter() - t0
    t0 = time.perf_counter()
    q0 = np.c_[screw_to_plane(q[:m], surf.v0, surf.hand), np.zeros(m)]
    d_bf, _ = tree.query(q0, workers=1)
    t_bf = time.perf_counter() - t0

    gap = np.abs(fp.distance[:m]) - d_bf
    print(f"rotor {args.rotor}, {n} queries, one core")
    print(f"exact global foot points : {n / t_ours:12,.0f} queries/s  ({t_ours:.3f} s; table {t_table:.2f} s once per surface)")
    print(f"KD-tree brute force      : {m / t_bf:12,.0f} queries/s  ({m} queries in {t_bf:.3f} s; {len(samples):,} samples, build {t_build:.2f} s)")
    print(f"ratio exact / brute force: {(n / t_ours) / (m / t_bf):.1f}x (queries per second)")
    print(f"exact minus brute-force distance: max {gap.max():.2e} (never worse), min {gap.min():.2e} (sampling error of the baseline)")
    return 0 if (gap.max() <= 1e-12 and n / t_ours >= 100_000) else 1


if __name__ == "__main__":
    sys.exit(main())
