"""Bizzarri & Bartoň 2021 double-flank milling on the built-in rotors: iterations, max errors on both flanks, time.

    python bench/bench_double_flank.py [--verify]

Errors are the tool-to-rotor errors of Eq. (15) (max over the axis nodes, as the paper reports them),
in units of the outer radius R = 1.  With --verify every plan is also simulated by verify_plan
(rotor-to-envelope: max undercut / max overcut over the target flanks, gouge count).  The paper's
figures are for its 'N' (Stosic) and SRM 'D' profiles, which differ from our built-ins; they are
printed for context only.
"""
import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from flank_addon.methods.double_flank.planner import plan_double_flank  # noqa: E402
from flank_addon.geometry.rotors import builtin_by_name  # noqa: E402

PAPER = {
    ("male", "custom-min"): "N 0.00362 / 0.00358; SRM D 0.00556 / 0.00606",
    ("female", "custom-min"): "N 0.01774 / 0.01685; SRM D 0.00965 / 0.00912",
    ("male", "two-paths"): "N 0.00312 / 0.00315",
    ("female", "two-paths"): "N 0.00573 / 0.00575",
    ("male", "cone"): "N 0.03439 / 0.03614",
    ("female", "cone"): "N 0.10488 / 0.10992",
    ("male", "cones:3"): "N max 0.00374 / 0.00693",
    ("female", "cones:3"): "N max 0.05223 / 0.03528",
}

CASES = [("custom-min", dict(variant="min")), ("custom-avg", dict(variant="avg")),
         ("custom-one-sided-1", dict(variant="one-sided-1")), ("two-paths", dict(two_paths=True)),
         ("cone", dict(tool="cone")), ("cones:3", dict(tool="cones:3"))]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--verify", action="store_true", help="also simulate every plan (slow: ~5-30 s each)")
    ap.add_argument("--rotors", default="nilson,srm_a,asymmetric")
    args = ap.parse_args()
    hdr = (f"{'rotor':18s} {'case':19s} {'alpha':>8s} {'delta':>8s} {'phi':>8s} {'iter':>4s} "
           f"{'e1 max':>9s} {'e2 max':>9s} {'min e':>9s} {'opt s':>6s} {'total s':>7s}")
    if args.verify:
        hdr += f" {'verify max':>10s} {'overcut':>9s} {'gouges':>6s}"
    print(hdr + "   paper (e1 / e2)")
    for kind in args.rotors.split(","):
        for part in ("male", "female"):
            name = f"{kind}-{part}"
            r = builtin_by_name(name)
            surf = r.surface()
            for label, kw in CASES:
                t0 = time.perf_counter()
                res = plan_double_flank(surf, r.flanks, m=200, simulate=False, **kw)
                dt = time.perf_counter() - t0
                fit = res.fits[1] if label == "two-paths" else res.fits[-1]
                x = fit.x
                (e1, m1), (e2, m2) = res.tool_to_rotor
                line = (f"{name:18s} {label:19s} {x[0]:+8.4f} {x[1]:+8.4f} {x[2]:+8.4f} {fit.iterations:4d} "
                        f"{e1:9.5f} {e2:9.5f} {min(m1, m2):+9.2e} {res.optimize_s:6.3f} {dt:7.2f}")
                if args.verify:
                    from flank_addon.simulation.verify import verify_plan
                    v = verify_plan(res.plan)
                    line += f" {v['max_undercut']:10.3e} {v['max_overcut']:+9.1e} {len(v['gouge_points']):6d}"
                paper = PAPER.get((part, label), "")
                print(line + (f"   {paper}" if paper else ""), flush=True)


if __name__ == "__main__":
    main()
