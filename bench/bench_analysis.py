"""Mesh -> rotor analysis accuracy and time on every built-in rotor.

Each rotor is meshed with 6000 points around the profile (0.1 % R edge
length along it) and 60 axial rings, given end faces and two shaft
cylinders, moved by a random rigid motion and scaled to R = 40 mm; the
analysis must recover axis, pitch, handedness, profile and flanks.  Two
more rows use a CAD-like irregular tessellation (300k random exact surface
samples, Delaunay-triangulated in parameter space).

    .venv/bin/python bench/bench_analysis.py
"""
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))

import numpy as np  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402

from flank_addon.geometry.rotor_analysis import analyze_mesh  # noqa: E402
from flank_addon.geometry.rotors import BUILTIN_NAMES, builtin_by_name  # noqa: E402
from helpers import cad_like, irregular_mesh, profile_hausdorff  # noqa: E402


def main():
    mm = 40.0
    rng = np.random.default_rng(2026)
    cases = [(name, "rings") for name in BUILTIN_NAMES] + [("asymmetric-female", "irregular"),
                                                          ("nilson-male", "irregular")]
    print(f"{'rotor':20s} {'mesh':9s} {'triangles':>9s} {'axis deg':>9s} {'axis pos/R':>10s} {'v0 rel':>9s} "
          f"{'hand':>5s} {'Hausdorff/R':>11s} {'flanks':>6s} {'residual':>8s} {'time s':>6s}")
    worst = np.zeros(4)
    for name, kind in cases:
        rotor = builtin_by_name(name)
        v, f = cad_like(rotor) if kind == "rings" else irregular_mesh(rotor, n_points=300000)
        rot = Rotation.random(random_state=rng.integers(1 << 30)).as_matrix()
        shift = rng.uniform(-200, 200, 3)
        world = (v @ rot.T) * mm + shift
        t0 = time.perf_counter()
        a = analyze_mesh(world, f)
        dt = time.perf_counter() - t0
        d_true = rot @ [0.0, 0.0, 1.0]
        angle = np.degrees(np.arccos(min(1.0, abs(a.axis_direction @ d_true))))
        w = shift - a.axis_point
        pos = np.linalg.norm(w - (w @ a.axis_direction) * a.axis_direction) / mm
        v0_rel = abs(a.v0 / (rotor.v0 * mm) - 1)
        haus = profile_hausdorff(a, rotor, lambda p: (p @ rot.T) * mm + shift) / mm
        ok_hand = "ok" if a.handedness == rotor.handedness else "WRONG"
        ok_fl = f"{len(a.flanks)}/{2 * rotor.lobes}"
        worst = np.maximum(worst, [angle, pos, v0_rel, haus])
        print(f"{name:20s} {kind:9s} {len(f):9d} {angle:9.2e} {pos:10.2e} {v0_rel:9.2e} {ok_hand:>5s} {haus:11.2e} "
              f"{ok_fl:>6s} {a.residual:8.1e} {dt:6.2f}")
    print(f"worst: axis {worst[0]:.2e} deg (limit 0.01), position {worst[1]:.2e} R (1e-4), "
          f"v0 {worst[2]:.2e} (1e-4), profile {worst[3]:.2e} R (1e-4)")
    return 0 if (worst < [0.01, 1e-4, 1e-4, 1e-4]).all() else 1


if __name__ == "__main__":
    sys.exit(main())
