"""Blender's main loop while the planners run on large inputs: the longest time the interface does not answer.

The modal operators plan in a worker thread, but a worker that holds Python's interpreter lock for long (a
single call of the json module or numpy on a large list, a garbage collection over a large heap) stops every
Python part of Blender's interface meanwhile.  This runs ``tests/blender/scenario_main_loop_waits.py``: Blender
as a module with the extension installed from its zip; the main thread turns every millisecond and polls the
operator every 0.1 s, as Blender's main loop does, during: the free-form planner on a bump of 2 x resolution^2
triangles (default 316: 199,712 triangles); on the built-in rotor at Generate Rotor's defaults (279,360
triangles): Analyze Rotor, the double-flank and single-flank planners, Error Plot and Verify of the double-flank
run, and its whole-rotor program (Post Program, the default machine and post).  It prints the longest waits between two turns with the
status shown then, and the longest poll (the build of the results included).  With ``--base DIR`` (an earlier
checkout, e.g. ``git archive <commit> | tar -x -C DIR``) that tree's extension runs too, alternating.

    PYTHONPATH=. .venv/bin/python bench/bench_main_loop_waits.py [--base DIR] [--repeat 2] [--resolution 316]
"""
import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(HERE / "tests" / "blender"))


def build_zip(tree, out):
    """The tree's extension zip for this machine (its scipy wheels taken from this tree's wheels/)."""
    tree = Path(tree)
    if tree != HERE and (HERE / "wheels").is_dir():
        (tree / "wheels").mkdir(exist_ok=True)
        for w in (HERE / "wheels").glob("*.whl"):
            if not (tree / "wheels" / w.name).exists():
                shutil.copy2(w, tree / "wheels" / w.name)
    subprocess.run([sys.executable, str(tree / "tools" / "build_extension.py"), "--platforms", "host",
                    "--output-dir", str(out)], cwd=str(tree), check=True, capture_output=True, text=True)
    return next(Path(out).glob("*.zip"))


def main():
    from blender_harness import run_scenario

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--base")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--resolution", type=int, default=316)
    args = ap.parse_args()
    trees = {"this tree": HERE}
    if args.base:
        trees["base"] = Path(args.base).resolve()
    with tempfile.TemporaryDirectory() as tmp:
        zips = {name: build_zip(tree, Path(tmp) / "zip" / str(i)) for i, (name, tree) in enumerate(trees.items())}
        runs = {name: [] for name in trees}
        for r in range(args.repeat):
            for name, z in zips.items():
                d = Path(tmp) / "run{}_{}".format(r, len(runs[name]) + 10 * list(trees).index(name))
                d.mkdir(parents=True)
                res = run_scenario(z, "main_loop_waits", d, resolution=args.resolution)
                runs[name].append(res)
    first = next(iter(runs.values()))[0]
    print("bump {} triangles, rotor {} triangles, {} run(s) each".format(first["triangles"],
                                                                        first.get("rotor_triangles"), args.repeat))
    for op in first["operators"]:
        print(op)
        for name, rs in runs.items():
            for res in rs:
                f = res["operators"].get(op)
                if f is None:
                    continue
                top = f["waits"][0]
                print("  {:9s} {}  {:5.1f} s   longest wait {:6.1f} ms ({})   next {:6.1f} ms   longest poll {:5.1f} ms"
                      "   start {:5.1f} ms".format(name, f["op_result"], f["wall_s"], top[0], top[1],
                                                   f["waits"][1][0], f["longest_poll_ms"], f["start_ms"]))
    print("then one full garbage collection")
    for name, rs in runs.items():
        for res in rs:
            if "full_collection_ms" in res:
                print("  {:9s} {:6.1f} ms over {} objects".format(name, res["full_collection_ms"],
                                                                 res["tracked_objects"]))

if __name__ == "__main__":
    os.environ.setdefault("PYTHONDONTWRITEBYTECODE", "1")
    main()
