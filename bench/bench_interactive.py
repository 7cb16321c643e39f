"""Interactive speed: what a user's click costs, as the command line runs it.

Each operation runs in a fresh Python process: the time of ``import flank_addon.cli`` is measured and
left out, then ``cli.main([...])`` is timed (wall clock; the CPU time of the process, all its threads, is
printed beside it: on a shared machine the wall clock grows with the load, the CPU time much less).  Each
tree's ``flank_addon`` is byte-compiled first, as an installed extension is after its first run.  With
``--base DIR`` (a checkout of an earlier commit, e.g. ``git worktree add /tmp/base <commit>``) every
operation also runs on that tree, alternating with this one in the same loop, so both see the same machine
load; the figures are the minima over the repeats and the ratio of the minima.

    PYTHONPATH=. .venv/bin/python bench/bench_interactive.py [--base /tmp/base] [--repeat 3] [--only NAME,...]
        [--warm | --imported]

Operations (goals in brackets):
  double-flank   plan double-flank --builtin asymmetric-female --valley 0 (defaults, with the simulated
                 errors)                                                                      [0.6 s]
  verify         verify of that plan (each tree verifies the plan written by the current tree) [0.5 s]
  single-flank   plan single-flank --mesh of a 349k-triangle left-handed rotor mesh with shafts in an
                 arbitrary pose, tool D3 L25 2 deg, tolerance 0.05 mm (read + analysis + plan)   [2 s]
  freeform       plan freeform on the 20,000-triangle bump, 11 strips x 20 rulings x 30 samples  [2 s]
  two-paths-f / two-paths-m   plan double-flank --two-paths on the asymmetric female / male    [1.5 s]
  verify-two-paths, verify-two-paths-m, verify-freeform, verify-single-flank   verify of the two-paths (female
                 and male), free-form and single-flank plans above ("verify of any plan")     [0.5 s]
  three-cones    plan double-flank --builtin asymmetric-female --valley 0 --tool cones:3 (sharp-tipped
                 cones)                                                                           [-]
  disc-cutter    cutter --builtin nilson-male --scale 100 --center-distance 180 --swivel 20 --plan-out (the
                 formed disc cutter as a plan, in mm)                                             [-]
  verify-three-cones, verify-disc-cutter   verify of those two plans                            [0.5 s]
  analyze        analyze of the 349k-triangle rotor mesh: the reading and analysis that open the single-flank
                 mesh plan, without its planning noise                                            [-]
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]

RUNNER = r"""
import json, sys, time
t0 = time.perf_counter()
from flank_addon import cli
if sys.argv[2] == "imported":     # the Flank tab's warm-up before the click: the tree's operators/jobs.py WarmUp
    import importlib.util
    spec = importlib.util.spec_from_file_location("flank_jobs", "operators/jobs.py")
    jobs = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(jobs)
    if hasattr(jobs, "WarmUp"):
        jobs.WarmUp(None, json.loads(sys.argv[3])).wait()
    else:                           # a tree from before the warm-up: the same imports
        import importlib
        for name in json.loads(sys.argv[3]):
            try:
                importlib.import_module(name)
            except ImportError:
                pass
t1 = time.perf_counter()
c1 = time.process_time()
import contextlib, io
with contextlib.redirect_stdout(io.StringIO()) as out:
    rc = cli.main(json.loads(sys.argv[1]))
t2 = time.perf_counter()
c2 = time.process_time()
res = {"import_s": t1 - t0, "run_s": t2 - t1, "cpu_s": c2 - c1, "rc": rc, "out": out.getvalue()[-2000:]}
if sys.argv[2] == "warm":           # the same click again in this process (modules loaded, caches filled)
    with contextlib.redirect_stdout(io.StringIO()):
        rc = cli.main(json.loads(sys.argv[1]))
    res.update(run_s=time.perf_counter() - t2, cpu_s=time.process_time() - c2, rc=rc)
print(json.dumps(res))
"""


def make_inputs(d):
    """The rotor mesh (with a point on its flank 0) and the bump mesh, written with this tree's code."""
    sys.path.insert(0, str(HERE))
    import numpy as np
    from scipy.spatial.transform import Rotation

    from flank_addon.geometry.freeform_surfaces import bump
    from flank_addon.geometry.rotors import builtin_by_name
    from flank_addon.geometry.screw import screw_motion
    from flank_addon.io.mesh_files import write_mesh

    rotor = builtin_by_name("srm_a-female", scale=30.0, length=60.0)
    v, f = rotor.mesh(n_profile=4140, n_axial=41)
    parts = [(v, f)]
    R = rotor.profile.outer_radius()
    th = np.linspace(0, 2 * np.pi, 96, endpoint=False)
    for z0, z1 in ((-0.8 * R, 0.0), (rotor.length, rotor.length + 1.2 * R)):
        zs = np.linspace(z0, z1, 4)
        cv = np.stack([np.tile(0.35 * R * np.cos(th), 4), np.tile(0.35 * R * np.sin(th), 4), np.repeat(zs, 96)], -1)
        i, j = np.arange(3)[:, None] * 96, np.arange(96)[None, :]
        a, b = i + j, i + (j + 1) % 96
        cf = np.concatenate([np.stack([a, b, b + 96], -1).reshape(-1, 3), np.stack([a, b + 96, a + 96], -1).reshape(-1, 3)])
        parts.append((cv, cf))
    off, V, F = 0, [], []
    for pv, pf in parts:
        V.append(pv)
        F.append(pf + off)
        off += len(pv)
    V, F = np.vstack(V), np.vstack(F)
    rot = Rotation.random(random_state=11).as_matrix()
    shift = np.array([40.0, -25.0, 60.0])
    write_mesh(d / "rotor.stl", V @ rot.T + shift, F)
    p = np.r_[rotor.profile.eval(np.array([0.45 * rotor.flanks[0][1]]))[0], 0.0]
    point = screw_motion(p, 30.0 / rotor.v0, rotor.v0, rotor.handedness) @ rot.T + shift
    S = bump(size=1.0, resolution=100)
    write_mesh(d / "bump.stl", S.vertices, S.faces)
    r1, r2, L = 0.01, 0.03, 0.09
    D = (L * L - (r2 - r1) ** 2) ** 0.5
    bp = S.point(np.array([[0.0, D / 2]]))[0]
    return {"rotor_triangles": len(F), "flank_point": ",".join(f"{x:.6f}" for x in point),
            "bump_triangles": len(S.faces), "bump_point": ",".join(f"{x:.9f}" for x in bp)}


# verify operations and the plan operation that writes the plan they read (this tree's plan, for every tree)
VERIFIED = {"verify": "double-flank", "verify-two-paths": "two-paths-f", "verify-two-paths-m": "two-paths-m",
            "verify-freeform": "freeform",
            "verify-single-flank": "single-flank", "verify-three-cones": "three-cones",
            "verify-disc-cutter": "disc-cutter"}


def operations(d, info):
    df = str(d / HERE.name / "df.json")       # verify reads the plan this tree wrote
    return {
        "double-flank": ["plan", "double-flank", "--builtin", "asymmetric-female", "--valley", "0", "--out", df],
        "verify": ["verify", df],
        "single-flank": ["plan", "single-flank", "--mesh", str(d / "rotor.stl"), "--flank-point", info["flank_point"],
                         "--tool-r1", "1.5", "--tool-r2", f"{1.5 + 25 * math.tan(math.radians(2)):.6f}",
                         "--tool-h", "25", "--shank-radius", "3", "--shank-length", "45", "--tolerance", "0.05",
                         "--out", str(d / "sf.json")],
        "freeform": ["plan", "freeform", "--mesh", str(d / "bump.stl"), "--direction", "1,0,0", "--point",
                     info["bump_point"], "--tool-r1", "0.01", "--tool-r2", "0.03", "--tool-length", "0.09",
                     "--columns", "20", "--samples", "30", "--out", str(d / "ff.json")],
        "two-paths-f": ["plan", "double-flank", "--builtin", "asymmetric-female", "--valley", "0", "--two-paths",
                        "--out", str(d / "tp_f.json")],
        "two-paths-m": ["plan", "double-flank", "--builtin", "asymmetric-male", "--valley", "0", "--two-paths",
                        "--out", str(d / "tp_m.json")],
        "verify-two-paths": ["verify", str(d / HERE.name / "tp_f.json")],
        "verify-two-paths-m": ["verify", str(d / HERE.name / "tp_m.json")],
        "verify-freeform": ["verify", str(d / HERE.name / "ff.json")],
        "verify-single-flank": ["verify", str(d / HERE.name / "sf.json")],
        "three-cones": ["plan", "double-flank", "--builtin", "asymmetric-female", "--valley", "0", "--tool",
                        "cones:3", "--out", str(d / HERE.name / "c3.json")],
        "disc-cutter": ["cutter", "--builtin", "nilson-male", "--scale", "100", "--center-distance", "180",
                        "--swivel", "20", "--out", str(d / "cutter.csv"),
                        "--plan-out", str(d / HERE.name / "disc.json")],
        "verify-three-cones": ["verify", str(d / HERE.name / "c3.json")],
        "analyze": ["analyze", str(d / "rotor.stl")],
        "verify-disc-cutter": ["verify", str(d / HERE.name / "disc.json")],
    }


GOALS = {"double-flank": 0.6, "verify": 0.5, "single-flank": 2.0, "freeform": 2.0, "two-paths-f": 1.5,
         "two-paths-m": 1.5, "verify-two-paths": 0.5, "verify-two-paths-m": 0.5, "verify-freeform": 0.5,
         "verify-single-flank": 0.5, "verify-three-cones": 0.5, "verify-disc-cutter": 0.5}


def load_jobs(tree=HERE):
    """A tree's ``operators/jobs.py`` (no bpy in it), loaded as a module of its own."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("flank_jobs", Path(tree) / "operators" / "jobs.py")
    jobs = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(jobs)
    return jobs


def warm_up_modules():
    """The modules the Blender extension imports in a worker thread when its sidebar tab is shown
    (``operators/jobs.py``: WARM_MODULES, its own names relative to the extension), as the command line names
    them."""
    return [name[1:] if name.startswith(".") else name for name in load_jobs().WARM_MODULES]


def warm_up(tree=HERE):
    """What the extension does when its sidebar tab is shown, before a first click: the tree's
    ``operators/jobs.py`` WarmUp (its imports, then whatever else it does), in its thread, waited for."""
    load_jobs(tree).WarmUp(None, warm_up_modules()).wait()


def run(tree, argv, out_dir, warm=False, imported=False):
    env = dict(os.environ, PYTHONPATH=str(tree))
    if argv[0] == "plan":       # each tree writes its own plans
        argv = argv[:-1] + [str(out_dir / tree.name / Path(argv[-1]).name)]
    mode = "warm" if warm else "imported" if imported else "cold"
    return run_runner(RUNNER, [json.dumps(argv), mode, json.dumps(warm_up_modules())], f"{tree}: {' '.join(argv)}",
                      env=env, cwd=str(tree))


def run_runner(runner, args, label, **kw):
    """The JSON line a runner script (``python -c runner *args``) prints last, its command's return code 0 (else
    RuntimeError naming ``label``, with the runner's error output or the command's output)."""
    p = subprocess.run([sys.executable, "-c", runner, *args], capture_output=True, text=True, **kw)
    if p.returncode != 0:
        raise RuntimeError(f"{label} failed:\n{p.stderr[-3000:]}")
    res = json.loads(p.stdout.strip().splitlines()[-1])
    if res["rc"] != 0:
        raise RuntimeError(f"{label} returned {res['rc']}:\n{res.get('out', '')}")
    return res


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--base", help="checkout of the previous implementation, run side by side")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", default="", help="comma-separated operation names")
    ap.add_argument("--show", action="store_true", help="print each run's output (last lines)")
    ap.add_argument("--warm", action="store_true", help="time the second click in one process (what a click "
                                                        "costs in a Blender session: modules loaded, a mesh's "
                                                        "analysis kept)")
    ap.add_argument("--imported", action="store_true", help="time the first click after the warm-up that the "
                                                            "Blender extension runs when its sidebar tab is "
                                                            "shown (each tree's operators/jobs.py WarmUp: its "
                                                            "imports and what follows them; what a first click "
                                                            "costs in Blender)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        info = make_inputs(d)
        print(f"rotor mesh {info['rotor_triangles']} triangles; bump {info['bump_triangles']} triangles")
        trees = [HERE] + ([Path(args.base).resolve()] if args.base else [])
        for t in trees:
            (d / t.name).mkdir(exist_ok=True)
            # an installed extension runs from cached bytecode after its first import (Python writes the
            # caches unless PYTHONDONTWRITEBYTECODE forbids it, as on some CI machines): time that, not
            # the compiler
            subprocess.run([sys.executable, "-m", "compileall", "-q", str(t / "flank_addon")], check=True,
                           stdout=subprocess.DEVNULL)
        ops = operations(d, info)
        names = [n for n in ops if not args.only or n in args.only.split(",")]
        for name in names:                  # a verified plan is the current tree's, written before it is read
            if name in VERIFIED and VERIFIED[name] not in names:
                run(HERE, ops[VERIFIED[name]], d)
        print(f"{'operation':20s} {'this tree (s)':>22s} {'import':>7s}" + (f" {'base (s)':>22s} {'ratio':>19s}"
                                                                          if args.base else "") + "  goal")
        for name in names:
            times = {t: [] for t in trees}
            cpus = {t: [] for t in trees}
            imports = []
            for _ in range(args.repeat):
                for t in trees:
                    r = run(t, ops[name], d, args.warm, args.imported)
                    times[t].append(r["run_s"])
                    cpus[t].append(r["cpu_s"])
                    if t == HERE:
                        imports.append(r["import_s"])
                        if args.show:
                            print(r["out"])
            cur = times[HERE]
            line = f"{name:20s} {min(cur):8.3f} ({min(cpus[HERE]):6.3f} cpu) {min(imports):7.3f}"
            if args.base:
                b = times[trees[1]]
                line += (f" {min(b):8.3f} ({min(cpus[trees[1]]):6.3f} cpu) {min(b) / min(cur):5.1f}x"
                         f" ({min(cpus[trees[1]]) / min(cpus[HERE]):4.1f}x cpu)")
            print(line + (f"  {GOALS[name]:.1f}" if GOALS.get(name) else "  -"), flush=True)


if __name__ == "__main__":
    main()
