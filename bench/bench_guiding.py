"""Rajain et al. 2023 §5 guiding curves: time per stage on ~20k-triangle test surfaces, and accuracy.

For each surface: the guiding field from one tangent vector at the centre (vector-heat transport),
the guiding function G (sparse least squares), the level sets at spacing d = 0.1 (unit-size
surfaces) and the Fig. 10 base points.  Accuracy: the angle between the curves and the field
(rms / max over faces), the range of |grad G|, and the spacing between neighbouring curves
measured in space (nearest point on the next curve, inner 80 % of the patch) relative to d.
Timings are not asserted (2 shared cores); best of ``REPEAT`` runs.

    PYTHONPATH=. .venv/bin/python bench/bench_guiding.py [triangles]
"""
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

import numpy as np  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402

from flank_addon.geometry import freeform_surfaces as fs  # noqa: E402
from flank_addon.methods.freeform_g1 import guiding as g  # noqa: E402

REPEAT = 3
D = 0.1


def spacing_errors(res, s, margin=0.1):
    tree = cKDTree(s.vertices)
    lo, hi = s.uv.min(0), s.uv.max(0)
    m = margin * (hi - lo)
    inside = ((s.uv - lo) > m).all(1) & ((hi - s.uv) > m).all(1)
    out = []
    for c0, c1 in zip(res.curves[:-1], res.curves[1:]):
        P = c0.polylines[0].points
        dist, arc = g.polyline_distance(P, c1.polylines[0], return_arclength=True)
        ok = inside[tree.query(P)[1]] & (arc > 1e-9) & (arc < c1.polylines[0].length - 1e-9)
        out.append(dist[ok] / res.spacing - 1)
    return np.concatenate(out) if out else np.zeros(1)


def sized(make, triangles):
    """The surface from make(resolution=...) with about ``triangles`` triangles."""
    n100 = len(make(resolution=100).faces)
    return make(resolution=int(round(100 * (triangles / n100) ** 0.5)))


def cases(triangles):
    yield "cylinder (along rulings)", sized(fs.cylinder_patch, triangles), [0, 0, 1]
    yield "parabolic blade (across rulings)", sized(fs.parabolic_blade, triangles), [1, 0, 0]
    gf = sized(fs.gear_flank, triangles)
    k = g.central_vertex(gf.vertices, gf.faces)
    yield "gear flank (along a ruling)", gf, fs.gear_ruling(gf.uv[k:k + 1], base_radius=2.0)[0]
    yield "bump", sized(fs.bump, triangles), [1, 0, 0]
    yield "saddle (diagonal)", sized(fs.saddle, triangles), [1, 1, 0]


def main():
    triangles = int(sys.argv[1]) if len(sys.argv) > 1 else 20_000
    print(f"about {triangles} triangles, spacing d = {D}, best of {REPEAT}; times in ms")
    print(f"{'surface':34s} {'tris':>6s} {'curves':>6s} {'strips':>6s} {'field':>6s} {'G':>6s} {'levels':>6s} "
          f"{'base':>6s} {'total':>6s}  {'angle rms/max (deg)':>20s} {'|grad G|':>15s} {'spacing error':>18s}")
    for name, s, d in cases(triangles):
        best = None
        for _ in range(REPEAT):
            t0 = time.perf_counter()
            res = g.guiding_curves(s.vertices, s.faces, direction=d, spacing=D)
            total = time.perf_counter() - t0
            if best is None or total < best[0]:
                best = (total, res)
        total, res = best
        t = res.timings
        f = res.function
        e = spacing_errors(res, s)
        print(f"{name:34s} {len(s.faces):6d} {len(res.curves):6d} {len(res.strips):6d} {t['field'] * 1e3:6.0f} "
              f"{t['function'] * 1e3:6.0f} {t['level_sets'] * 1e3:6.0f} {t['base_points'] * 1e3:6.0f} "
              f"{total * 1e3:6.0f}  {f.angle_rms:9.2e} / {f.angle_max:8.2e} {f.grad_min:7.4f}-{f.grad_max:6.4f} "
              f"{e.min() * 100:+7.2f}% {e.max() * 100:+7.2f}%")


if __name__ == "__main__":
    main()
