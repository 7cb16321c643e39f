"""Render Report on Blender's main thread: how long each of its turns holds the interface.

Each run is a fresh Python process with Blender as a module (the project venv's bpy).  It builds the report
picture of the benchmark double-flank plan (the built-in asymmetric female, written by this tree), then runs
the main-thread steps of ``flank.render_report`` one after the other, as the operator's turns do, and times
each (wall clock, and the main thread's CPU time): the temporary scene, the labels' layout, the render
(in one piece, or -- where the tree has them -- the preparing render and the tiles).  Each process renders
the picture ``--renders`` times: the first render of a session is slower (Blender prepares its renderer).
With ``--base DIR`` (a checkout of an earlier commit, ``git worktree add /tmp/base <commit>``) the same runs
alternate with that tree's, so both see the same machine load.

    PYTHONPATH=. .venv/bin/python bench/bench_report_turns.py [--base /tmp/base] [--repeat 3]
        [--resolution 1280 800] [--renders 3] [--engine workbench|cycles]
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
import importlib, json, os, sys, time
from flank_addon import cli
rs = cli.report_scene()
rg = rs.rg
plan = json.load(open(sys.argv[1]))
width, height, renders, engine = int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), sys.argv[6]
picture = rg.report_picture(rg.report_geometry(plan), width, height, engine=engine)
in_child = engine == "CYCLES" and hasattr(rs, "report_scene_file")     # a second Blender renders Cycles


def timed(f):
    t, c = time.perf_counter(), time.thread_time()
    out = f()
    return out, 1e3 * (time.perf_counter() - t), 1e3 * (time.thread_time() - c)


runs = []
for _ in range(renders):
    turns = []
    state, ms, cpu = timed(lambda: rs.report_scene_start(picture, sys.argv[5]))
    turns.append(["scene", ms, cpu])
    try:
        _, ms, cpu = timed(lambda: rs.report_scene_labels(state, picture))
        turns.append(["labels", ms, cpu])
        if in_child:
            (blend, scene), ms, cpu = timed(lambda: rs.report_scene_file(state))
            turns.append(["file", ms, cpu])
        elif hasattr(rs, "report_tiles") and engine == "WORKBENCH":
            _, ms, cpu = timed(lambda: rs.report_scene_prepare(state))
            turns.append(["prepare", ms, cpu])
            for tile in rs.report_tiles(picture):
                _, ms, cpu = timed(lambda: rs.report_scene_render(state, tile))
                turns.append(["tile", ms, cpu])
        else:
            _, ms, cpu = timed(lambda: rs.report_scene_render(state))
            turns.append(["render", ms, cpu])
    finally:
        rs.report_scene_end(state)
    if in_child:        # not a turn of this Blender: the worker waits while the other process renders
        rp = importlib.import_module(rs.__package__ + ".report_process")
        out = state["tmp"][:-len(".tga")] + ".cycles.tga"
        _, ms, cpu = timed(lambda: rp.render_in_child(blend, scene, out, lambda f, m: None, "", sys.executable))
        turns.append(["other process", ms, cpu])
    runs.append(turns)
print("RESULT " + json.dumps(runs))
"""


def run(tree, plan, width, height, renders, out_dir, engine):
    env = dict(os.environ, PYTHONPATH=str(tree))
    script = Path(out_dir) / "runner.py"
    script.write_text(RUNNER)
    proc = subprocess.run([sys.executable, str(script), str(plan), str(width), str(height), str(renders),
                           str(Path(out_dir) / "report.png"), engine], cwd=str(tree), env=env,
                          capture_output=True, text=True, timeout=3600)
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")]
    if proc.returncode != 0 or not lines:
        raise SystemExit("{} failed (exit {}):\n{}".format(tree, proc.returncode, proc.stderr[-3000:]))
    return json.loads(lines[-1][len("RESULT "):])


def summary(runs_of_processes):
    """(first render of a session, later renders): the longest turn (ms, its CPU ms) and the render's turns
    summed (the preparing render and tiles, or the one render)."""
    def part(runs):
        longest = max((t for turns in runs for t in turns if t[0] != "other process"), key=lambda t: t[1])
        render = [sum(t[1] for t in turns if t[0] in ("prepare", "tile", "render", "file")) for turns in runs]
        other = [t[1] for turns in runs for t in turns if t[0] == "other process"]
        return dict(longest=longest, render_ms=(min(render), max(render)),
                    other_ms=(min(other), max(other)) if other else None)
    first = [p[0] for p in runs_of_processes]
    later = [turns for p in runs_of_processes for turns in p[1:]]
    return part(first), (part(later) if later else None)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--base", help="checkout of the previous implementation, run side by side")
    ap.add_argument("--repeat", type=int, default=3, help="fresh processes per tree")
    ap.add_argument("--renders", type=int, default=3, help="renders per process (the first is a session's first)")
    ap.add_argument("--resolution", type=int, nargs=2, default=(1280, 800), metavar=("W", "H"))
    ap.add_argument("--engine", choices=("workbench", "cycles"), default="workbench",
                    help="cycles: where the tree renders Cycles in a second Blender, its turns are the scene, the "
                         "labels and writing the scene's file; that process's render is timed apart")
    args = ap.parse_args()
    trees = [("this tree", HERE)] + ([("base", Path(args.base).resolve())] if args.base else [])
    with tempfile.TemporaryDirectory() as d:
        plan = Path(d) / "df.json"
        subprocess.run([sys.executable, "-m", "flank_addon", "plan", "double-flank", "--builtin", "asymmetric-female",
                        "--valley", "0", "--out", str(plan)], cwd=str(HERE), check=True, capture_output=True,
                       env=dict(os.environ, PYTHONPATH=str(HERE)))
        results = {name: [] for name, _ in trees}
        for _ in range(args.repeat):
            for name, tree in trees:
                results[name].append(run(tree, plan, *args.resolution, args.renders, d, args.engine.upper()))
    print("Render Report's main-thread turns at {} x {}, {} ({} processes per tree, {} renders each)".format(
        *args.resolution, args.engine.title(), args.repeat, args.renders))
    for name, _ in trees:
        first, later = summary(results[name])
        for label, s in (("first render", first), ("later renders", later)):
            if s is None:
                continue
            kind, ms, cpu = s["longest"]
            print("  {:10s} {:14s} longest turn {:6.1f} ms ({:5.1f} ms CPU, {}); render turns together {:.0f}-{:.0f} ms"
                  .format(name, label, ms, cpu, kind, *s["render_ms"])
                  + ("; the other process {:.1f}-{:.1f} s".format(*(v / 1e3 for v in s["other_ms"]))
                     if s["other_ms"] else ""))


if __name__ == "__main__":
    main()
