"""Reading a long stored plan with Blender's interface running: what the main thread waits for.

A file opened again keeps no parsed plans, and a free-form plan holds its surface.  The plan here is the
free-form benchmark plan (``bench_interactive.py``'s bump, 11 strips x 20 rulings x 30 samples) with its surface
replaced by the same bump at 200,000 triangles, as a user's finer surface gives.  Each run is a fresh Python
process that reads the text one of three ways while its main thread ticks every millisecond, as Blender's
timers and redraws would, and records the longest wait between two ticks (and the garbage collector's full
collections, which hold the interpreter lock too, for a time that grows with everything Python holds):

  main thread   ``validate_plan(json.loads(text))`` in the operator's ``_prepare`` (how a run's plan was read)
  worker, whole the same in a worker thread: the C scanner holds the interpreter lock for the whole text
  worker, pieces ``runs.PlanNeeded``'s read: ``parse_plan_text(text, loads_in_pieces)`` in a worker (the plan
                 checked, its surface rows as tuples, the garbage collector paused meanwhile)
  store, whole   a planner's worker making the run's text and its checked plan (``runs.run_plan_fields``) as
                 it did: ``validate_plan(json.loads(json.dumps(plan)))``
  store, pieces  as it does now: the text ``dumps_in_pieces(plan)``, then ``parse_plan_text(text,
                 loads_in_pieces)``

and then, with the plan read (kept, as Blender keeps the last runs' plans), what a full collection of the garbage
collector takes (the least of three).

    PYTHONPATH=. .venv/bin/python bench/bench_plan_read.py [--repeat 3] [--resolution 316]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]

RUNNER = r"""
import gc, json, sys, threading, time
from flank_addon.io.json_pieces import dumps_in_pieces, loads_in_pieces
from flank_addon.io.plan import parse_plan_text, validate_plan

text, mode = open(sys.argv[1]).read(), sys.argv[2]
full_before = gc.get_stats()[2]["collections"]     # counted, not timed: a gc callback is Python code, and running
                                                    # it lets the interpreter switch threads inside the C scanner


def ticking(work):
    done, longest = [], 0.0
    th = threading.Thread(target=lambda: done.append(work()))
    last = time.perf_counter()
    th.start()
    while not done:
        time.sleep(0.001)
        now = time.perf_counter()
        longest, last = max(longest, now - last), now
    th.join()
    return longest, done[0]


plan = json.loads(text) if mode.startswith("store") else None
t = time.perf_counter()
if mode == "store-whole":                           # a planner's worker: the run's text, read back and checked
    wait, checked = ticking(lambda: validate_plan(json.loads(json.dumps(plan))))
elif mode == "store-pieces":
    wait, checked = ticking(lambda: parse_plan_text(dumps_in_pieces(plan), loads_in_pieces))
elif mode == "main":
    plan = validate_plan(json.loads(text))
    wait = time.perf_counter() - t
elif mode == "whole":
    wait, plan = ticking(lambda: validate_plan(json.loads(text)))
else:
    wait, plan = ticking(lambda: parse_plan_text(text, lambda t: loads_in_pieces(t, progress=lambda f: None)))
took = time.perf_counter() - t
full = gc.get_stats()[2]["collections"] - full_before
kept_gc = []
for _ in range(3):
    t = time.perf_counter()
    gc.collect()
    kept_gc.append(time.perf_counter() - t)
if mode == "pieces":
    same = json.dumps(plan) == json.dumps(json.loads(text))
elif mode == "store-pieces":
    same = json.dumps(checked) == json.dumps(plan)
else:
    same = True
print(json.dumps({"chars": len(text), "wait_s": wait, "took_s": took, "full_gc": full, "same": same,
                  "kept_gc_s": min(kept_gc)}))
"""


def make_plan(d, resolution):
    """The benchmark free-form plan, with the bump's surface at ``resolution`` (2 resolution^2 triangles)."""
    sys.path.insert(0, str(HERE))
    import numpy as np

    from flank_addon import cli
    from flank_addon.geometry.freeform_surfaces import bump
    from flank_addon.io.mesh_files import write_mesh
    from flank_addon.io.plan import read_plan

    S = bump(size=1.0, resolution=100)
    write_mesh(d / "bump.stl", S.vertices, S.faces)
    r1, r2, L = 0.01, 0.03, 0.09
    point = S.point(np.array([[0.0, ((L * L - (r2 - r1) ** 2) ** 0.5) / 2]]))[0]
    rc = cli.main(["plan", "freeform", "--mesh", str(d / "bump.stl"), "--direction", "1,0,0", "--point",
                   ",".join(f"{x:.9f}" for x in point), "--tool-r1", str(r1), "--tool-r2", str(r2),
                   "--tool-length", str(L), "--columns", "20", "--samples", "30", "--out", str(d / "ff.json")])
    if rc != 0:
        raise SystemExit("the free-form plan failed")
    plan = read_plan(d / "ff.json")
    fine = bump(size=1.0, resolution=resolution)
    plan["surface"] = {"kind": "mesh", "vertices": fine.vertices.tolist(), "faces": fine.faces.tolist()}
    text = json.dumps(plan)                      # as a run stores it (runs.run_plan_fields)
    (d / "plan.json").write_text(text)
    return len(fine.faces), len(text)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--resolution", type=int, default=316)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        import contextlib
        import io
        with contextlib.redirect_stdout(io.StringIO()):
            tris, chars = make_plan(d, args.resolution)
        print(f"plan text {chars / 1e6:.1f} MB (surface {tris} triangles)")
        env = dict(os.environ, PYTHONPATH=str(HERE))
        runs = {mode: [] for mode in ("main", "whole", "pieces", "store-whole", "store-pieces")}
        for _ in range(args.repeat):
            for mode in runs:                    # alternating, so that each sees the same machine load
                p = subprocess.run([sys.executable, "-c", RUNNER, str(d / "plan.json"), mode], env=env,
                                   capture_output=True, text=True, check=True)
                runs[mode].append(json.loads(p.stdout.strip().splitlines()[-1]))
    print("                  longest wait of the main thread (s)   time (s)          full collections  then one (ms)")
    for mode, label in (("main", "main thread"), ("whole", "worker, whole"), ("pieces", "worker, pieces"),
                        ("store-whole", "store, whole"), ("store-pieces", "store, pieces")):
        waits, took = [r["wait_s"] for r in runs[mode]], [r["took_s"] for r in runs[mode]]
        full = [r["full_gc"] for r in runs[mode]]
        print(f"  {label:16s}  {min(waits):7.3f} .. {max(waits):7.3f}                  "
              f"{min(took):6.3f} .. {max(took):6.3f}    {min(full)} .. {max(full)}            "
              f"{1e3 * min(r['kept_gc_s'] for r in runs[mode]):5.1f} .. {1e3 * max(r['kept_gc_s'] for r in runs[mode]):5.1f}")
    print("the pieces read the same plan:", all(r["same"] for r in runs["pieces"] + runs["store-pieces"]))


if __name__ == "__main__":
    main()
