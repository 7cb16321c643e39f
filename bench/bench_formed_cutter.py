"""Hu, Zhou & Li 2025 formed cutter: time for 119 planes beside the paper's Matlab figure, and Table 2 beside the paper's.

    .venv/bin/python bench/bench_formed_cutter.py [--repeat 7]
"""
import argparse
import os
import sys
import time

for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")
sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

import numpy as np  # noqa: E402

from flank_addon.methods.formed_cutter.cutter_profile import TABLE1, arc_tooth_section, cutter_profile, format_table2, table2  # noqa: E402
from flank_addon.geometry.rotors import builtin_by_name  # noqa: E402

PAPER_TIME_S = 1.213   # Hu, Zhou & Li 2025 Table 4, Matlab, numerical method, 119-point tooth


def best_time(fn, repeat):
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t0)
    return min(ts), float(np.median(ts)), out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    T = TABLE1
    print("119 planes, eps_b = 0.01 mm (one core); paper: %.3f s in Matlab" % PAPER_TIME_S)
    cases = [("arc tooth S3 (exact arcs)", arc_tooth_section("S3"), {}),
             ("arc tooth S1 (spline, 0.01 rad, %d spans)" % len(arc_tooth_section("S1").cubic_h),
              arc_tooth_section("S1"), {})]
    for name, sec, kw in cases:
        for analyse in (False, True):
            tb, tm, cp = best_time(lambda: cutter_profile(sec, T["lead"], T["centre_distance"], T["swivel_deg"],
                                                          planes=119, eps_b=0.01, analyse=analyse), args.repeat)
            print(f"  {name:<42} {'with §4 flags' if analyse else 'meridian only':<14} best {tb * 1e3:7.1f} ms, "
                  f"median {tm * 1e3:7.1f} ms   (paper {PAPER_TIME_S * 1e3:.0f} ms)")
    rot = builtin_by_name("nilson-male", scale=100.0)
    tb, tm, cp = best_time(lambda: cutter_profile(rot.profile, rot.lead, 180.0, 35.0, planes=119), 3)
    print(f"  {'built-in nilson-male (%d spline spans)' % len(rot.profile.knots):<42} {'with §4 flags':<14} "
          f"best {tb * 1e3:7.1f} ms, median {tm * 1e3:7.1f} ms")
    print()
    t0 = time.perf_counter()
    tab = table2()
    print(format_table2(tab))
    print(f"({time.perf_counter() - t0:.2f} s for the whole table)")


if __name__ == "__main__":
    main()
