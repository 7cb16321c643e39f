"""README pictures and numbers of the free-form planner (Rajain et al. 2023, ), rendered headless.

* Rajain et al. 2023 Fig. 19 analogue: a blade close to a parabolic cylinder (47 x 37 mm, 12 mm deep, like the
  paper's blisk blade of Table 1) machined along three guiding directions -- vertical (across the
  rulings), horizontal (along them) and diagonal -- with the paper's tool (r1 = 1, r2 = 0.3 mm,
  L = 2.46 mm), N = 10 rulings per strip, K = 30 samples, default weights (the paper's w2 = 0.001,
  w3 = 1 of Fig. 19 trade millimetres of error for the kinks with our measured kink, see README).
* Rajain et al. 2023 Figs. 15-17 analogue: a bump planned with w3 = 0 and with w3 = 1, w2 = 0.005.

Writes docs/freeform_blade.png, docs/freeform_bump.png and prints a Markdown table.

    PYTHONPATH=. .venv/bin/python tools/freeform_figures.py [--out docs]
"""
import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from flank_addon.cli import report_scene  # noqa: E402
from flank_addon.geometry.freeform_surfaces import bump, parabolic_blade  # noqa: E402
from flank_addon.methods.freeform_g1.planner import plan_freeform  # noqa: E402
from flank_addon.io.png import read_png, write_png  # noqa: E402

BLADE_DIRECTIONS = (("vertical", (1.0, 0.0, 0.0)), ("horizontal", (0.0, 1.0, 0.0)),
                    ("diagonal", (1.0, 1.0, 0.0)))


def blade():
    # curved direction x (47 mm, 12 mm deep: rho = 23.5^2 / 24), rulings along y (37 mm)
    return parabolic_blade(size=47.0, resolution=(120, 94), rho=23.5 ** 2 / 24.0, span=37.0)


def row(name, plan, mesh_mm):
    s, o = plan["summary"], plan["optimization"]
    n = [len(st["rulings"]) for st in plan["strips"]]
    t = plan["tool"]
    return ("| {} | {:.3g} | {:.3g} | {:.3g} | {} x {} x {} | {:+.3g} / {:+.3g} | {:.3g} / {:.3g} | {:.3g} / {:.3g} | "
            "{} | {:.1f} |".format(name, t["length"], t["r1"], t["r2"], int(np.median(n)), s["strips"],
                                   o["samples_per_ruling"], s["max_error"], s["min_error"], s["initial_max_kink_deg"],
                                   s["max_kink_deg"], s["initial_mean_kink_deg"], s["mean_kink_deg"], mesh_mm,
                                   s["elapsed_s"]))


def side_by_side(paths, out):
    imgs = [read_png(p) for p in paths]
    h = max(i.shape[0] for i in imgs)
    canvas = np.concatenate([np.pad(i, ((0, h - i.shape[0]), (0, 0), (0, 0)), constant_values=255) for i in imgs],
                            axis=1)
    write_png(out, canvas)
    for p in paths:
        os.remove(p)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="docs")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=560)
    args = ap.parse_args()
    render_freeform_report = report_scene().render_freeform_report

    os.makedirs(args.out, exist_ok=True)
    rows = ["| example | L | r1 | r2 | N x M x K | error max / min (mm) | kink max initial / optimised (deg) | "
            "kink mean initial / optimised (deg) | mesh size (mm) | time (s) |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    B = blade()
    ext = np.ptp(B.vertices, axis=0)
    mesh_mm = " x ".join("{:.0f}".format(e) for e in sorted(ext))
    parts = []
    for name, d in BLADE_DIRECTIONS:
        plan = plan_freeform(B.vertices, B.faces, direction=d, point=[0, 0, 0], r1=1.0, r2=0.3, L=2.46, n_columns=10,
                             n_ruling_samples=30)
        rows.append(row("blade, " + name, plan, mesh_mm))
        p = os.path.join(args.out, "_blade_{}.png".format(name))
        render_freeform_report(plan, p, args.width, args.height, tolerance=0.025,
                               title="{}: {} strips, kink max {:.2f}°".format(name, len(plan["strips"]),
                                                                             plan["summary"]["max_kink_deg"]))
        parts.append(p)
    side_by_side(parts, os.path.join(args.out, "freeform_blade.png"))

    S = bump(size=100.0, resolution=100, height=6.0, width=25.0)
    parts = []
    for w3 in (0.0, 1.0):
        t = time.perf_counter()
        plan = plan_freeform(S.vertices, S.faces, direction=[1, 0, 0], point=S.point(np.zeros((1, 2)))[0], r1=1.0,
                             r2=3.0, L=10.0, n_columns=20, n_ruling_samples=30, weights=[1, 0.005, w3, 1e-4, 0.01])
        rows.append(row("bump, w3 = {:g}, w2 = 0.005".format(w3), plan,
                        " x ".join("{:.0f}".format(e) for e in sorted(np.ptp(S.vertices, axis=0)))))
        p = os.path.join(args.out, "_bump_{}.png".format(int(w3)))
        render_freeform_report(plan, p, args.width, args.height, tolerance=0.05,
                               title="w3 = {:g}: kink max {:.2f}°, mean {:.2f}°".format(
                                   w3, plan["summary"]["max_kink_deg"], plan["summary"]["mean_kink_deg"]))
        parts.append(p)
        print("bump w3 = {:g}: {:.1f} s".format(w3, time.perf_counter() - t), file=sys.stderr)
    side_by_side(parts, os.path.join(args.out, "freeform_bump.png"))
    print("\n".join(rows))


if __name__ == "__main__":
    main()
