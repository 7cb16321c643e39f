"""Checks inside the planners and `verify`, each timed beside the way it was done before (in one process,
alternating, minima over the repeats), with the answers compared.

  sweep check      the free-form `verify`'s least |p - c| - r over the tool's spheres at the bump's vertices
                   (least_sphere_values) against the 24 nearest centres followed by a ball list for every vertex
  spline rows      SplineProfile.eval_all_xy / eval_xy gathering coefficient rows with take against fancy indexing
  strip errors     a double-flank plan's simulated errors (simulate_plan_errors): all strips in one sweep, as
                   verify runs it, against one sweep per strip with each point given to the strip that cuts
                   deepest; on the two-paths plans of the asymmetric female and male (valley 0)

    PYTHONPATH=. .venv/bin/python bench/bench_checks.py [--repeat 7] [--only sweep,spline,strips]

The inputs are those of bench_interactive.py (the 20,000-triangle bump).
"""
import argparse
import contextlib
import io
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE / "bench"))


def best(f, repeat):
    t_min, out = float("inf"), None
    for _ in range(repeat):
        t = time.perf_counter()
        out = f()
        t_min = min(t_min, time.perf_counter() - t)
    return t_min, out


def side_by_side(new, old, repeat):
    """Minimum times of new() and old(), run alternately, and their last answers."""
    tn, to, rn, ro = float("inf"), float("inf"), None, None
    for _ in range(repeat):
        t, rn = best(new, 1)
        tn = min(tn, t)
        t, ro = best(old, 1)
        to = min(to, t)
    return tn, to, rn, ro


def cli(argv):
    from flank_addon import cli as command_line
    with contextlib.redirect_stdout(io.StringIO()):
        command_line.main(argv)


def sweep_check(d, info, repeat):
    from scipy.spatial import cKDTree

    from flank_addon.io.plan import read_plan
    from flank_addon.methods.freeform_g1 import planner as ff
    from bench_interactive import operations

    cli(operations(d, info)["freeform"])
    plan = read_plan(d / "ff.json")
    mesh = ff.plan_mesh(plan)
    seen = {}
    real = ff.least_sphere_values

    def keep(P, C, Rr, k=24, cap=256):
        seen.update(P=P, C=C, Rr=Rr, k=k)
        return real(P, C, Rr, k, cap)

    ff.least_sphere_values = keep
    try:
        ff.sweep_deviation(plan, mesh=mesh)
    finally:
        ff.least_sphere_values = real
    P, C, Rr, k = seen["P"], seen["C"], seen["Rr"], seen["k"]

    def before():
        tree = cKDTree(C)
        dist, i = tree.query(P, k=k)
        val = dist - Rr[i]
        b = np.argmin(val, axis=1)
        rows = np.arange(len(P))
        out, idx = val[rows, b], i[rows, b]
        lists = tree.query_ball_point(P, out + Rr.max() + 1e-12)
        ff._least_in_balls(P, C, Rr, lists, k, out, idx)
        return out, idx

    tn, to, (on, jn), (oo, jo) = side_by_side(lambda: real(P, C, Rr, k), before, repeat)
    same = np.array_equal(on.view(np.int64), oo.view(np.int64)) and np.array_equal(jn, jo)
    print(f"sweep check ({len(P)} vertices, {len(C)} spheres): {to:.4f} s before, {tn:.4f} s now, "
          f"{to / tn:.2f}x; values and spheres the same bit for bit: {same}")
    tv, _ = best(lambda: ff.verify_freeform(plan), repeat)
    print(f"  verify_freeform of that plan (in process): {tv:.4f} s")


def spline_rows(repeat):
    from flank_addon.geometry.rotors import builtin_by_name

    prof = builtin_by_name("asymmetric-female").profile
    rng = np.random.default_rng(1)
    for n in (200, 740):
        u = rng.uniform(0.0, prof.period, n)

        def all_before():
            i, s = prof._interval(u, wrap_end=False)
            return prof._components_xy(prof._all_xy[i], s)

        def xy_before():
            i, s = prof._interval(u)
            s2 = s * s
            s3 = s2 * s
            g = prof._all_xy[i]
            return (g[..., 3] + g[..., 2] * s + g[..., 1] * s2 + g[..., 0] * s3,
                    g[..., 10] + g[..., 9] * s + g[..., 8] * s2 + g[..., 7] * s3)

        def per_call(f):
            return lambda: [f() for _ in range(2000)]

        ta, tb, ra, rb = side_by_side(per_call(lambda: prof.eval_all_xy(u)), per_call(all_before), repeat)
        tc, td, rc, rd = side_by_side(per_call(lambda: prof.eval_xy(u)), per_call(xy_before), repeat)
        same = all(np.array_equal(a, b) for a, b in zip(ra[-1] + rc[-1], rb[-1] + rd[-1]))
        print(f"spline rows, {n} parameters: eval_all_xy {tb / 2000 * 1e6:.1f} -> {ta / 2000 * 1e6:.1f} us, "
              f"eval_xy {td / 2000 * 1e6:.1f} -> {tc / 2000 * 1e6:.1f} us per call; the same numbers: {same}")


def strip_errors(repeat):
    from flank_addon.geometry.rotors import builtin_by_name
    from flank_addon.methods.double_flank.planner import plan_double_flank, simulate_plan_errors
    from flank_addon.simulation.sweep import StripTool, first_least, machined_deviation
    from flank_addon.simulation.verify import profile_normals, verify_plan

    for name in ("asymmetric-female", "asymmetric-male"):
        r = builtin_by_name(name)
        plan = plan_double_flank(r.surface(), r.flanks, valley=0, two_paths=True, simulate=False).plan
        rot = plan["rotor"]
        prof, normals = profile_normals(rot)
        idx = np.unique(np.concatenate([np.arange(a, b + 1) % len(prof)
                                        for a, b in (rot["flanks"][f] for f in plan["target_flanks"])]))
        R = float(rot["outer_radius"])

        def one_sweep_per_strip():
            devs = np.array([machined_deviation([StripTool.from_strip(s)], prof[idx], normals[idx], rot["v0"],
                                                rot["handedness"], max_deviation=0.1 * R) for s in plan["strips"]])
            owner = first_least(devs, 1e-12 * R)
            return devs[owner, np.arange(len(idx))], owner

        tn, to, (_, dn, on, per), (do, oo) = side_by_side(lambda: simulate_plan_errors(plan),
                                                          one_sweep_per_strip, repeat)
        # (a strip that forms no point of the flanks, as the second of a two-paths plan that fell back to the
        # double-flank axis used twice, reports 0 where verify has no figure)
        ver = [(v["max_error"], v["min_error"]) for v in verify_plan(plan)["strips"]]
        as_verify = per == [(0.0, 0.0) if v == (None, None) else v for v in ver]
        print(f"strip errors, two paths, {name} ({len(plan['strips'])} strips, {len(idx)} points): {to:.4f} s "
              f"one sweep per strip, {tn:.4f} s one sweep, {to / tn:.2f}x; the same owners: "
              f"{np.array_equal(on, oo)}, largest change {np.nanmax(np.abs(dn - do)) / R:.1e} R; the strips' "
              f"figures those of verify bit for bit: {as_verify}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--only", default="sweep,spline,strips")
    args = ap.parse_args()
    only = set(args.only.split(","))
    if "spline" in only:
        spline_rows(args.repeat)
    if "strips" in only:
        strip_errors(args.repeat)
    if "sweep" in only:
        from bench_interactive import make_inputs
        with tempfile.TemporaryDirectory() as tmp:
            d = Path(tmp)
            (d / HERE.name).mkdir()
            info = make_inputs(d)
            sweep_check(d, info, args.repeat)


if __name__ == "__main__":
    main()
