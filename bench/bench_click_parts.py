"""Where a double-flank click goes, and three ways of making it cheaper that were measured.

Each part runs the command line's ``plan double-flank --builtin asymmetric-female --valley 0`` as the first click
of a fresh process, after the warm-up that the extension's sidebar runs (``operators/jobs.py``: WarmUp), as
``bench_interactive.py --imported`` does.  It prints:

- ``parts``: the click's wall time and its parts (the axis optimisation, the tool and its path, the simulated
  errors, the built-in rotor, the valley's tables, writing the plan), minima and maxima over ``--runs`` processes;
- ``collector``: the time of Python's cyclic garbage collector during the click, its collections (young,
  middle, full) and what they freed: after the warm-up (which ends with a full collection), after the warm-up's
  imports alone (the full collection that their objects bring due comes in the click), and after its imports
  with the collector paused while the command runs (that collection then runs when the command returns, in
  the same click);
- ``guard``: the warm starts' guard queries of the click, recorded and replayed on the same trees -- the rough
  (approximate, eps = 2) query that the guard asks, against an exact query of the midpoint tree that could rule
  rows out first -- and how far the nearest table sample lies beyond each row's foot, against how far a row moves
  from one evaluation to the next (a bound carried over from one evaluation lasts while the second stays below
  the first); and each guarded run's warm Newton run with its guard query, in turn as the planner runs them,
  and with the query on a helper thread beside the Newton run (it does not depend on it);
- ``threads``: the plan's simulated errors (the sweep of its target points) in one call, in two halves on two
  threads and in two halves one after the other, and how far the halves' deviations are from the whole's.

    PYTHONPATH=. .venv/bin/python bench/bench_click_parts.py [--runs 5]
"""
import argparse
import json
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(HERE / "bench"))

from bench_interactive import run_runner  # noqa: E402

RUNNER = r"""
import contextlib, functools, gc, importlib, io, json, sys, time
sys.path.insert(0, sys.argv[1]); sys.path.insert(0, sys.argv[1] + "/bench")
import bench_interactive
from flank_addon import cli
mode, argv = sys.argv[2], json.loads(sys.argv[3])
if mode in ("collector-imports-only", "collector-paused"):    # the warm-up's imports only (its collection left out)
    for name in bench_interactive.warm_up_modules():
        try:
            importlib.import_module(name)
        except ImportError:
            pass
else:
    bench_interactive.warm_up(sys.argv[1])
res = {}
if mode == "parts":
    P = "flank_addon.methods.double_flank.planner"
    for spec in (P + ":optimize_axis", P + ":build_path", P + ":simulate_plan_errors", P + ":Valley",
                 "flank_addon.cli:_load_rotor", "flank_addon.io.plan:write_plan"):
        mod, fn = spec.split(":")
        m = importlib.import_module(mod)
        f = getattr(m, fn)
        def timed(*a, _f=f, _n=fn, **k):
            t = time.perf_counter()
            try:
                return _f(*a, **k)
            finally:
                res[_n] = res.get(_n, 0.0) + time.perf_counter() - t
        setattr(m, fn, timed)
if mode == "collector-paused":         # the collector off while the command runs, on again when it returns
    from flank_addon.collector import collector_paused
    command = cli._cmd_plan
    def paused(args):
        with collector_paused():
            return command(args)
    cli._cmd_plan = paused
if mode.startswith("collector"):
    state = {"t": 0.0, "n": 0, "full": 0, "freed": 0}
    def watch(phase, info):
        if phase == "start":
            state["t0"] = time.perf_counter()
        else:
            state["t"] += time.perf_counter() - state["t0"]
            state["n"] += 1
            state["full"] += info["generation"] == 2
            state["freed"] += info["collected"]
    gc.callbacks.append(watch)
if mode == "guard":
    from flank_addon.geometry.flank_feet import FlankFeet
    calls, many = [], FlankFeet.many
    def recorded(solvers, points, warms, k=2):
        out = many(solvers, points, warms, k)
        pts = points if isinstance(points, (list, tuple)) else [points] * len(solvers)
        for fs, p, w, ft in zip(solvers, pts, warms, out):
            if w is not None:
                calls.append((fs, p, ft.distance, w))
        return out
    FlankFeet.many = staticmethod(recorded)
t = time.perf_counter()
with contextlib.redirect_stdout(io.StringIO()):
    rc = cli.main(argv)
res["click"] = time.perf_counter() - t
if mode.startswith("collector"):
    gc.callbacks.remove(watch)
    res.update(gc_s=state["t"], collections=state["n"], full=state["full"], freed=state["freed"])
if mode == "guard":
    import numpy as np
    from flank_addon.geometry.flank_feet import GUARD_EPS
    from flank_addon.geometry.helical_surface import exact_tree
    from flank_addon.geometry.screw import screw_to_plane
    Qs = []
    for fs, p, dist, _ in calls:
        s = fs.surface
        Q = np.zeros((len(p), 3))
        Q[:, :2] = screw_to_plane(np.asarray(p, float), s.v0, s.hand)
        Qs.append(Q)
    solvers = {id(fs): fs for fs, _, _, _ in calls}
    for fs in solvers.values():
        fs._guard_seeds(np.zeros((1, 3)))                     # both trees built before the clock starts
    exact = {k: exact_tree(fs._points) for k, fs in solvers.items()}
    best = {}
    for rep in range(3):
        t = time.perf_counter()
        for (fs, _, _, _), Q in zip(calls, Qs):
            fs._guard_tree.query(Q, k=1, eps=GUARD_EPS)
        t1 = time.perf_counter()
        found = [exact[id(fs)].query(Q, k=1)[0] for (fs, _, _, _), Q in zip(calls, Qs)]
        t2 = time.perf_counter()
        best["rough"] = min(best.get("rough", 1e9), t1 - t)
        best["exact"] = min(best.get("exact", 1e9), t2 - t1)
    margin = np.concatenate([d - dist for d, (_, _, dist, _) in zip(found, calls)])
    last, moved = {}, []
    for (fs, _, _, _), Q in zip(calls, Qs):
        key = (id(fs), len(Q))
        if key in last:
            moved.append(np.linalg.norm(Q - last[key], axis=1))
        last[key] = Q
    moved = np.concatenate(moved)
    # the guard's query beside its call's warm Newton run, on a helper thread (the query does not depend on it)
    from concurrent.futures import ThreadPoolExecutor
    from flank_addon.geometry.flank_feet import _newton_rows
    helper = ThreadPoolExecutor(1)
    helper.submit(int).result()
    def newton(fs, Q, w):
        return _newton_rows(fs.surface, w[0], w[1], Q[:, :2], fs.lo, fs.hi, fs.hi - fs.lo)
    for rep in range(3):
        t = time.perf_counter()
        for (fs, _, _, w), Q in zip(calls, Qs):
            newton(fs, Q, w)
            fs._guard_tree.query(Q, k=1, eps=GUARD_EPS)
        t1 = time.perf_counter()
        for (fs, _, _, w), Q in zip(calls, Qs):
            asked = helper.submit(fs._guard_tree.query, Q, k=1, eps=GUARD_EPS)
            newton(fs, Q, w)
            asked.result()
        t2 = time.perf_counter()
        best["in_turn"] = min(best.get("in_turn", 1e9), t1 - t)
        best["beside"] = min(best.get("beside", 1e9), t2 - t1)
    helper.shutdown()
    res.update(in_turn_s=best["in_turn"], beside_s=best["beside"])
    R = next(iter(solvers.values())).surface.outer_radius
    res.update(runs=len(calls), rows=int(sum(len(Q) for Q in Qs)), rough_s=best["rough"], exact_s=best["exact"],
               margin_median_R=float(np.median(margin)) / R, margin_p05_R=float(np.quantile(margin, 0.05)) / R,
               margin_at_most_0=int((margin <= 0).sum()), moved_median_R=float(np.median(moved)) / R)
if mode == "threads":
    import threading
    import numpy as np
    from flank_addon.io.plan import read_plan
    from flank_addon.simulation.sweep import machined_deviation
    from flank_addon.simulation.verify import profile_normals, strip_solids
    plan = read_plan(argv[-1])
    rotor = plan["rotor"]
    prof, normals = profile_normals(rotor)
    R = float(rotor["outer_radius"])
    tools, _ = strip_solids(plan["strips"])
    target = np.zeros(len(prof), bool)
    for f in plan["target_flanks"]:
        a, b = rotor["flanks"][f]
        target[np.arange(a, b + 1) % len(prof)] = True
    ti = np.flatnonzero(target)
    def sweep(sel, out, k):
        out[k] = machined_deviation(tools, prof[sel], normals[sel], float(rotor["v0"]), rotor["handedness"],
                                    max_deviation=0.1 * R, owner_tie=1e-12 * R)[0]
    halves = [ti[0::2], ti[1::2]]
    times = {"one": [], "two_threads": [], "halves_in_turn": []}
    for rep in range(3):
        whole, parts = {}, {}
        t = time.perf_counter(); sweep(ti, whole, 0); times["one"].append(time.perf_counter() - t)
        t = time.perf_counter()
        th = [threading.Thread(target=sweep, args=(h, parts, k)) for k, h in enumerate(halves)]
        [x.start() for x in th]; [x.join() for x in th]
        times["two_threads"].append(time.perf_counter() - t)
        t = time.perf_counter(); sweep(halves[0], parts, 0); sweep(halves[1], parts, 1)
        times["halves_in_turn"].append(time.perf_counter() - t)
    joined = np.empty(len(ti))
    joined[0::2], joined[1::2] = parts[0], parts[1]
    ok = np.isfinite(joined) & np.isfinite(whole[0])
    res.update(points=len(ti), times=times, halves_differ_R=float(np.max(np.abs(joined - whole[0])[ok])) / R)
res["rc"] = rc
print(json.dumps(res))
"""


def run(mode, argv):
    return run_runner(RUNNER, [str(HERE), mode, json.dumps(argv)], mode)


def span(values, unit="s", fmt="{:.3f}"):
    lo, hi = min(values), max(values)
    return (fmt.format(lo) if lo == hi else (fmt + "-" + fmt).format(lo, hi)) + " " + unit


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5, help="fresh processes per measurement")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        plan = str(Path(d) / "df.json")
        argv = ["plan", "double-flank", "--builtin", "asymmetric-female", "--valley", "0", "--out", plan]
        parts = [run("parts", argv) for _ in range(args.runs)]
        print(f"parts ({args.runs} fresh processes, first click):")
        for key, name in (("click", "the click"), ("optimize_axis", "axis optimisation"),
                          ("simulate_plan_errors", "simulated errors"), ("build_path", "the tool and its path"),
                          ("_load_rotor", "the built-in rotor"), ("Valley", "the valley and its tables"),
                          ("write_plan", "writing the plan")):
            print(f"  {name:28s} {span([p[key] for p in parts])}")
        print("collector:")
        for mode, name in (("collector", "after the warm-up"), ("collector-imports-only", "after its imports only"),
                           ("collector-paused", "paused for the command")):
            rs = [run(mode, argv) for _ in range(args.runs)]
            print(f"  {name:28s} click {span([r['click'] for r in rs])}, collector {span([1e3 * r['gc_s'] for r in rs], 'ms', '{:.1f}')}"
                  f" in {span([r['collections'] for r in rs], 'collections', '{}')}"
                  f" ({span([r['full'] for r in rs], 'full', '{}')}), freed {span([r['freed'] for r in rs], 'objects', '{}')}")
        g = run("guard", argv)
        print(f"guard: {g['runs']} guarded runs, {g['rows']} rows, replayed (minimum of 3): rough query {g['rough_s']:.3f} s,"
              f" exact query of the midpoint tree {g['exact_s']:.3f} s")
        print(f"  nearest sample beyond the foot: median {g['margin_median_R']:.2e} R, 5% {g['margin_p05_R']:.2e} R,"
              f" {g['margin_at_most_0']} rows at or inside it; a row moves a median {g['moved_median_R']:.2e} R"
              " between evaluations")
        print(f"  each guarded run's Newton and its guard query (replayed, minimum of 3): in turn {g['in_turn_s']:.3f} s,"
              f" the query on a helper thread beside the Newton run {g['beside_s']:.3f} s")
        t = run("threads", argv)
        times = t["times"]
        print(f"threads: {t['points']} target points: one call {span(times['one'])}, two halves on two threads"
              f" {span(times['two_threads'])}, the halves in turn {span(times['halves_in_turn'])};"
              f" the halves differ from the whole by up to {t['halves_differ_R']:.1e} R")


if __name__ == "__main__":
    main()
