"""Plan verification time (budget: 15 strips against a 2,000-point profile in <= 1 s).

Two plans, each with 15 cone strips and shanks, on a 2,000-point profile:
- "cylinder": cones tangent to a cylindrical rotor; every cone's sweep reaches every target point
  (the worst case for candidate pruning: all 1,001 target points see all 15 tools);
- "female flank": cones placed on the built-in asymmetric female's first flank, each touching the
  surface at one point with its axis along the surface's helix-orthogonal tangent (real deviations,
  material left between strips, gouges elsewhere).
The baseline is the same engine with the time windows switched off (search the whole axial slab of
the tool for every point) and one tool at a time instead of all strips stacked, run side by side.

    .venv/bin/python bench/bench_verify.py
"""
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

import numpy as np  # noqa: E402

from flank_addon.simulation import sweep  # noqa: E402
from flank_addon.io.plan import new_plan, rotor_section  # noqa: E402
from flank_addon.geometry.rotors import builtin_rotor  # noqa: E402
from flank_addon.simulation.verify import verify_plan  # noqa: E402


def strip(c1, c2, r1, r2, shank_len=0.3):
    a = (c2 - c1) / np.linalg.norm(c2 - c1)
    return {"axis_start": c1.tolist(), "axis_end": c2.tolist(), "radii": [r1, r2], "flank": 0,
            "shank_start": c2.tolist(), "shank_end": (c2 + shank_len * a).tolist(), "shank_radius": r2,
            "reported_max_error": 0.0, "reported_min_error": 0.0, "collision": False}


def cylinder_plan(n=2000, rc=0.8):
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    prof = rc * np.c_[np.cos(th), np.sin(th)]
    rotor = {"to_world": np.eye(4).tolist(), "v0": 0.4, "handedness": "right", "profile": prof.tolist(),
             "flanks": [[0, n // 2], [n // 2, n]], "outer_radius": rc}
    strips = []
    for k in range(15):
        a = np.pi * (k + 0.5) / 15
        d = np.array([np.cos(a), np.sin(a), 0.0])
        strips.append(strip((rc + 0.05) * d + [0, 0, -0.1], (rc + 0.09) * d + [0, 0, 0.2], 0.05, 0.09))
    return new_plan("bench-cylinder", rotor, {"kind": "cone"}, target_flanks=[0], strips=strips)


def female_plan(n=2000):
    rot = builtin_rotor("asymmetric", "female")
    surf = rot.surface()
    rotor = rotor_section(rot.profile, rot.v0, rot.handedness, rot.flanks, n_profile=n)
    u0, u1 = rot.flanks[0]
    strips = []
    for u in np.linspace(u0, u1, 17)[1:-1][:15]:
        p = surf.evaluate(np.array([u]), np.array([0.0]))[0]
        nrm = surf.normal(np.array([u]), np.array([0.0]))[0]
        helix = np.array([-p[1], p[0], rot.v0])          # right/left only flips the sign: any tangent
        helix -= (helix @ nrm) * nrm
        axis = np.cross(nrm, helix / np.linalg.norm(helix))
        r1, r2 = 0.03, 0.05
        # cone touching the surface at p: sphere centres offset along the normal by their radii
        c1 = p + r1 * nrm - 0.08 * axis
        c2 = p + r2 * nrm + 0.08 * axis
        strips.append(strip(c1, c2, r1, r2))
    return new_plan("bench-female", rotor, {"kind": "cone"}, target_flanks=[0], strips=strips)


def timed(plan, repeats=3):
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = verify_plan(plan)
        best = min(best, time.perf_counter() - t0)
    return best, res


def main():
    windows, compatible = sweep.time_windows, sweep.StackedTools.compatible

    def whole_slab(x, centres, radii, v0, handedness, margin):
        c = np.asarray(centres).reshape(-1, 3) if np.ndim(centres) == 2 else None
        if c is None:   # per-row spheres
            lo = np.where(np.isfinite(radii), centres[..., 2] - radii, np.inf).min(1)
            hi = np.where(np.isfinite(radii), centres[..., 2] + radii, -np.inf).max(1)
        else:
            lo, hi = (c[:, 2] - radii).min(), (c[:, 2] + radii).max()
        return (lo - x[:, 2]) / v0, (hi - x[:, 2]) / v0, np.ones(len(x), bool)

    print(f"{'plan':<14} {'targets':>7} {'engine':>13} {'baseline':>9} {'ratio':>6}  result")
    for name, plan in (("cylinder", cylinder_plan()), ("female flank", female_plan())):
        t_new, res = timed(plan)
        sweep.time_windows, sweep.StackedTools.compatible = whole_slab, staticmethod(lambda tools: False)
        try:
            t_old, ref = timed(plan, repeats=1)
        finally:
            sweep.time_windows, sweep.StackedTools.compatible = windows, compatible
        a = np.array([r[3] if r[3] is not None else np.inf for r in res["deviation_profile"]])
        b = np.array([r[3] if r[3] is not None else np.inf for r in ref["deviation_profile"]])
        fin = np.isfinite(a) & np.isfinite(b)
        assert np.array_equal(np.isfinite(a), np.isfinite(b))
        print(f"{name:<14} {len(a):>7} {t_new:>12.3f}s {t_old:>8.3f}s {t_old / t_new:>5.1f}x  "
              f"max undercut {res['max_undercut']:.3g}, max overcut {res['max_overcut']:.3g}, "
              f"{len(res['gouge_points'])} gouge points; |windows - baseline| <= {np.abs(a[fin] - b[fin]).max():.1e}")


if __name__ == "__main__":
    main()
