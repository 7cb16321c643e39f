"""Whole-flank coverage of the single-flank planner with --tools auto, from held-out-style rotor meshes.

    PYTHONPATH=. .venv/bin/python bench/bench_flank_coverage.py [--quick] [--builtins]

Each case: a built-in rotor made right-handed (outer radius 30 mm, 60 mm long) with end shafts, in a random rigid
pose, written as STL; ``python -m flank_addon plan single-flank --mesh M --flank-point=P --tools auto --tolerance
0.05 --out PLAN`` in a fresh process (wall time, import included); then two sweep simulations of the plan:

* ``verify``: the plan's own verification (its analysed profile, the points the plan's covered_fraction uses);
* ``truth``: the true flank (the built-in's exact profile, 2000 points), carried through the mesh's pose into the
  plan's rotor frame and screwed into z = 0, swept by the plan's strips (:func:`simulation.sweep.machined_deviation`):
  the share of its arc length within [-0.001 mm, tolerance] and the deepest overcut.

``--builtins``: the built-in male rotors in units of R (``--builtin NAME --tools auto --outer-radius-mm 50``, tolerance
0.05 mm), both flanks of valley 0.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

R_MM, LENGTH, TOL = 30.0, 60.0, 0.05
CASES = [("asymmetric-male", 0), ("asymmetric-male", 1), ("srm_a-male", 0), ("nilson-male", 1),
         ("srm_a-female", 1), ("asymmetric-female", 0)]


def mesh_case(name, flank, folder, seed=11):
    from scipy.spatial.transform import Rotation

    from flank_addon.geometry.rotors import builtin_by_name
    from flank_addon.geometry.screw import screw_motion
    from flank_addon.io.mesh_files import write_mesh
    from helpers import cad_like

    rotor = builtin_by_name(name, scale=R_MM, length=LENGTH, handedness="right")
    v, f = cad_like(rotor, n_profile=1500, n_axial=40)
    rot = Rotation.random(random_state=seed).as_matrix()
    shift = np.array([40.0, -25.0, 60.0])
    path = Path(folder) / f"{name}.stl"
    write_mesh(path, v @ rot.T + shift, f)
    a, b = rotor.flanks[flank]
    p = np.r_[rotor.profile.eval(np.array([a + 0.45 * (b - a)]))[0], 0.0]
    point = screw_motion(p, 0.3 * LENGTH / rotor.v0, rotor.v0, rotor.handedness) @ rot.T + shift
    return rotor, path, point, (rot, shift)


def run_cli(args):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "flank_addon"] + args, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    if r.returncode != 0:
        raise SystemExit(f"flank_addon {' '.join(args)} failed: {r.stderr.strip()}")
    return json.loads(r.stdout), wall


def truth_share(rotor, flank, plan, pose, n=2000):
    """Share of the true flank's arc length within [-0.001, TOL] mm under the plan's strips, and the least
    deviation (module doc)."""
    from flank_addon.geometry.screw import screw_to_plane
    from flank_addon.simulation.sweep import StripTool, machined_deviation

    rot, shift = pose
    a, b = rotor.flanks[flank]
    u = np.linspace(a, b, n)
    p = np.c_[rotor.profile.eval(u), np.zeros(n)]
    model = p @ rot.T + shift
    T = np.linalg.inv(np.asarray(plan["rotor"]["to_world"], float))
    q = model @ T[:3, :3].T + T[:3, 3]
    r = plan["rotor"]
    q0 = screw_to_plane(q, r["v0"], r["handedness"])
    t = np.gradient(q0, axis=0)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    nrm = np.c_[t[:, 1], -t[:, 0]]                 # the profile runs CCW with the solid on its left
    tools = [StripTool.from_strip(s) for s in plan["strips"]]
    d = machined_deviation(tools, q0, nrm, r["v0"], r["handedness"], max_deviation=3.0)
    seg = np.linalg.norm(np.diff(q0, axis=0), axis=1)
    ok = (d <= TOL) & (d >= -1e-3)
    share = float(np.sum(seg * 0.5 * (ok[1:].astype(float) + ok[:-1])) / seg.sum())
    return share, float(np.min(d))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="the first two mesh cases only")
    ap.add_argument("--builtins", action="store_true", help="the built-in male rotors (units of R) instead")
    args = ap.parse_args()
    from flank_addon.io.plan import read_plan
    from flank_addon.simulation.verify import verify_plan

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        if args.builtins:
            for name in ("asymmetric-male", "srm_a-male", "nilson-male"):
                for flank in (0, 1):
                    out = Path(tmp) / f"{name}-{flank}.json"
                    s, wall = run_cli(["plan", "single-flank", "--builtin", name, "--flank", str(flank), "--tools",
                                       "auto", "--outer-radius-mm", "50", "--tolerance", f"{TOL / 50:.12g}",
                                       "--out", str(out), "--json"])
                    rows.append({"case": f"{name} flank {flank} (R = 50 mm)", "wall_s": wall,
                                 "covered_fraction": s["covered_fraction"], "gouges": s["gouge_points"],
                                 "tools": [(t["name"], t["strips"]) for t in s["tools"]]})
                    print(json.dumps(rows[-1]), flush=True)
            return
        for name, flank in CASES[:2] if args.quick else CASES:
            rotor, mesh, point, pose = mesh_case(name, flank, tmp)
            out = Path(tmp) / f"{name}.json"
            s, wall = run_cli(["plan", "single-flank", "--mesh", str(mesh), "--flank-point=" + ",".join(
                f"{x:.6f}" for x in point), "--tools", "auto", "--tolerance", str(TOL), "--out", str(out), "--json"])
            plan = read_plan(out)
            v = verify_plan(plan, tolerance=TOL)
            share, worst = truth_share(rotor, flank, plan, pose)
            rows.append({"case": f"{name} (right-handed) flank {flank}", "wall_s": round(wall, 2),
                         "planner_s": round(s["timings_s"]["total"], 2),
                         "covered_fraction": round(s["covered_fraction"], 4), "truth_share": round(share, 4),
                         "truth_min_deviation_mm": round(worst, 5), "verify_gouges": len(v["gouge_points"]),
                         "tools": [(t["name"], t["strips"]) for t in s["tools"]],
                         "uncovered": [u["reason"][:160] for u in s["uncovered"]]})
            print(json.dumps(rows[-1]), flush=True)


if __name__ == "__main__":
    main()
