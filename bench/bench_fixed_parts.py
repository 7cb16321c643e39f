"""The scipy calls that identical figures pin, replayed alone: how much of each click no faster arithmetic around
the same optimiser paths can take away.

A plan's figures stay the same to 1e-9 R only while its optimisers take the same steps, bit for bit
(``bench_rounding.py``: a change of the BLAS thread count moves them by up to 1.7e-7 R).  Among the calls on those
steps, two kinds are scipy's own work on inputs that the steps fix, and an implementation that keeps scipy's SLSQP
and the guard's tree pays them whatever else it changes:

- ``SLSQP``: every ``scipy.optimize.minimize(method="SLSQP")`` of the plan.  Its values and gradients are
  recorded in the click, and the same minimisations are replayed here with the recorded values (checked: the
  same iterates, the same end point), so only scipy's own work is timed;
- ``guard``: the warm starts' guard queries (``FlankFeet._guard_seeds``: the approximate, eps = 2, nearest table
  sample, whose answers depend on the tree and decide where a foot point may jump), every query that reaches a
  guard tree, replayed on trees built as the planner builds them (checked: the same answers).

A third kind is shown beside them but not counted as pinned: the cold starts' exact k-nearest queries
(``FlankFeet._exact_seeds``, on the planner's midpoint trees of 64 samples per leaf; checked: the same answers).
Their answers do not depend on the tree, so their time is free to shrink.

A fourth is the planner's own arithmetic on the same paths: the foot points' Newton runs
(``flank_feet._newton_rows``), whose every row must come out bit for bit as before, since the guard and the
optimiser read them.  They are recorded in the click (inputs and feet) and replayed alone in the recording process
with this code (checked: the same feet, bit for bit).  Each row's operations are fixed by the formulas; a faster
implementation could only spend less around them (numpy calls on the same rows), so the column says what they
cost now, not a bound.  ``left`` is what the goal leaves for everything else (the tool, its meridians, the
simulated errors, the cold seeds, the mesh's reading and analysis, the optimisers' evaluations around the feet)
once the pinned calls and the Newton runs are paid.

Each plan runs in fresh processes after the extension's warm-up, from cached bytecode (as
``bench_interactive.py --imported``): ``--runs`` times plain, for the click's time (the fastest), and once
recording.  The table gives the replays' minima over ``--repeat``, the pinned time against the click and its
goal, and the time that the rest of the click (everything but the pinned calls: the foot points' Newton runs and
the evaluations around them, the cold seeds, the tool, the simulated errors, the mesh's reading and analysis)
may take for the click to meet its goal, as a share of what it takes now.

    PYTHONPATH=. .venv/bin/python bench/bench_fixed_parts.py [--runs 3] [--repeat 5] [--only two-paths-f,...]
"""
import argparse
import json
import pickle
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(HERE / "bench"))
sys.path.insert(0, str(HERE))

from bench_interactive import GOALS, make_inputs, operations, run_runner  # noqa: E402

RUNNER = r"""
import contextlib, io, json, pickle, sys, threading, time
sys.path.insert(0, sys.argv[1]); sys.path.insert(0, sys.argv[1] + "/bench")
import bench_interactive
from flank_addon import cli
bench_interactive.warm_up(sys.argv[1])
argv, record = json.loads(sys.argv[2]), sys.argv[3]
res = {}
if record:
    import numpy as np
    import scipy.optimize
    from flank_addon.geometry import flank_feet
    from scipy.spatial import cKDTree
    guard, seeds, tables, runs, lock = [], [], {}, [], threading.Lock()
    asked_seeds = flank_feet.FlankFeet._exact_seeds

    def table_key(points):
        # a table's key: the id of its array, which ``tables`` keeps alive (so the id is never reused)
        with lock:
            tables.setdefault(id(points), points)
        return id(points)

    class GuardTree(cKDTree):
        # a guard tree (``flank_feet`` builds its guard trees, and only those, with ``cKDTree``): every query that
        # reaches it is recorded with its answers (a repeated query that the guard answers itself never does)
        def __init__(self, points, *a, **kw):
            super().__init__(points, *a, **kw)
            self.table_key = table_key(points)

        def query(self, x, *a, **kw):
            d, idx = super().query(x, *a, **kw)
            with lock:
                guard.append((self.table_key, np.array(x, copy=True), idx.copy()))
            return d, idx

    def recorded_seeds(self, Q, k):
        idx = asked_seeds(self, Q, k)
        key = table_key(self._points)
        with lock:
            seeds.append((key, Q.copy(), k, idx.copy()))
        return idx

    minimize = scipy.optimize.minimize

    def logged(f, log):
        def g(x, *a):
            out = f(x, *a)
            log.append((np.array(x, copy=True), np.array(out, copy=True)))
            return out
        return g

    def recorded_minimize(fun, x0, args=(), method=None, jac=None, bounds=None, constraints=(), tol=None,
                          callback=None, options=None):
        # the planners' minimisations: SLSQP with analytic gradients of the objective and of every constraint
        constraints = [constraints] if isinstance(constraints, dict) else list(constraints)
        if (method != "SLSQP" or not callable(jac) or callback is not None
                or any(not callable(c.get("jac")) for c in constraints)):
            raise RuntimeError("a minimisation this bench does not replay")
        start = np.array(x0, copy=True)
        logs = {"fun": [], "jac": [], "cons": []}
        cons = []
        for c in constraints:
            lf, lj = [], []
            logs["cons"].append((c["type"], lf, lj))
            cons.append(dict(c, fun=logged(c["fun"], lf), jac=logged(c["jac"], lj)))
        r = minimize(logged(fun, logs["fun"]), x0, args=args, method=method, jac=logged(jac, logs["jac"]),
                     bounds=bounds, constraints=cons, tol=tol, callback=callback, options=options)
        with lock:
            runs.append({"x0": start, "method": method, "bounds": bounds, "tol": tol,
                         "options": options, "logs": logs, "x": r.x.copy()})
        return r

    newton_rows, newton = flank_feet._newton_rows, []

    def recorded_newton(s, u, tau, q0, lo, hi, span, iters=40):
        # the foot points' Newton runs (inputs copied before the run, which may write into them)
        args = (s,) + tuple(np.array(a, copy=True) for a in (u, tau, q0, lo, hi, span)) + (iters,)
        out = newton_rows(s, u, tau, q0, lo, hi, span, iters)
        with lock:
            newton.append((args, tuple(o.copy() for o in out)))
        return out

    flank_feet.FlankFeet._exact_seeds, flank_feet.cKDTree = recorded_seeds, GuardTree
    flank_feet._newton_rows = recorded_newton
    scipy.optimize.minimize = recorded_minimize
    with contextlib.redirect_stdout(io.StringIO()):
        rc = cli.main(argv)
    flank_feet._newton_rows = newton_rows
    with open(record, "wb") as fh:
        pickle.dump({"guard": guard, "seeds": seeds, "tables": tables, "runs": runs}, fh)
    # the Newton runs replayed here, in the recording process (their surfaces are live objects): the same
    # code on the same inputs, checked to give the same feet bit for bit; the fastest of the repeats
    newton_s = float("inf")
    for _ in range(int(sys.argv[4])):
        t0 = time.perf_counter()
        outs = [newton_rows(*args) for args, _ in newton]
        newton_s = min(newton_s, time.perf_counter() - t0)
        if not all(all(np.array_equal(a, b) for a, b in zip(o, ref)) for o, (_, ref) in zip(outs, newton)):
            raise AssertionError("a replayed Newton run gave other feet")
    res = {"guard": len(guard), "seeds": len(seeds), "minimize": len(runs),
           "evaluations": sum(len(r["logs"]["fun"]) for r in runs), "newton_s": newton_s,
           "newton_runs": len(newton), "newton_rows": sum(len(args[1]) for args, _ in newton)}
else:
    t0 = time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):
        rc = cli.main(argv)
    res["click_s"] = time.perf_counter() - t0
res["rc"] = rc
print(json.dumps(res))
"""

PLANS = ("double-flank", "two-paths-f", "two-paths-m", "single-flank")


def replayed(fun_log):
    """A callable that answers the recorded calls in order, and fails on a point the recorded run never asked
    (the recorded points' bytes are taken before the replay: the check costs a bytes comparison)."""
    answers = [(x.tobytes(), out) for x, out in fun_log]
    it = iter(answers)

    def f(x, *a):
        x_rec, out = next(it)
        if x.tobytes() != x_rec:
            raise AssertionError("the replayed minimisation left the recorded iterates")
        return out
    return f


def replay_minimize(runs):
    """Every recorded minimisation once, with its recorded values (checked: the same iterates, the same end
    points); seconds, the checks of the end points left out."""
    import numpy as np
    from scipy.optimize import minimize

    calls = [(r, [{"type": kind, "fun": replayed(lf), "jac": replayed(lj)} for kind, lf, lj in r["logs"]["cons"]],
              replayed(r["logs"]["fun"]), replayed(r["logs"]["jac"])) for r in runs]
    t0 = time.perf_counter()
    ends = [minimize(fun, r["x0"].copy(), method=r["method"], jac=jac, bounds=r["bounds"], constraints=cons,
                     tol=r["tol"], options=r["options"]).x for r, cons, fun, jac in calls]
    seconds = time.perf_counter() - t0
    if not all(np.array_equal(x, r["x"]) for x, r in zip(ends, runs)):
        raise AssertionError("a replayed minimisation ended elsewhere")
    return seconds


def replay_guard(guard, tables):
    """The guard's queries on scipy's default trees of their tables (each built when first asked, as the
    planner builds it, and timed with the queries; checked: the same answers); seconds."""
    import numpy as np
    from scipy.spatial import cKDTree

    from flank_addon.geometry.flank_feet import GUARD_EPS, _workers

    t0 = time.perf_counter()
    trees, got = {}, []
    for key, Q, _ in guard:
        tree = trees.get(key)
        if tree is None:
            tree = trees[key] = cKDTree(tables[key])
        got.append(tree.query(Q, k=1, eps=GUARD_EPS, workers=_workers(len(Q)))[1])
    seconds = time.perf_counter() - t0
    if not all(np.array_equal(a, idx) for a, (_, _, idx) in zip(got, guard)):
        raise AssertionError("a replayed guard query answered otherwise")
    return seconds


def replay_seeds(seeds, tables):
    """The cold seeds' exact queries on the planner's midpoint trees (built and timed with them; checked: the
    same answers); seconds."""
    import numpy as np

    from flank_addon.geometry.flank_feet import SEED_TREE_LEAFSIZE, _workers
    from flank_addon.geometry.helical_surface import exact_tree

    t0 = time.perf_counter()
    trees, got = {}, []
    for key, Q, k, _ in seeds:
        tree = trees.get(key)
        if tree is None:
            tree = trees[key] = exact_tree(tables[key], leafsize=SEED_TREE_LEAFSIZE)
        got.append(tree.query(Q, k=k, workers=_workers(len(Q)))[1])
    seconds = time.perf_counter() - t0
    if not all(np.array_equal(a.reshape(len(Q), -1), idx) for a, (_, Q, _, idx) in zip(got, seeds)):
        raise AssertionError("a replayed cold-seed query answered otherwise")
    return seconds


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=3, help="plain clicks per plan (the fastest is kept)")
    ap.add_argument("--repeat", type=int, default=5, help="replays of the recorded calls (minima)")
    ap.add_argument("--only", default="", help="comma-separated plans of " + ", ".join(PLANS))
    args = ap.parse_args()
    plans = [p for p in PLANS if not args.only or p in args.only.split(",")]
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        (d / HERE.name).mkdir()
        ops = operations(d, make_inputs(d))
        # from cached bytecode, as an installed extension runs after its first use (bench_interactive.py)
        subprocess.run([sys.executable, "-m", "compileall", "-q", str(HERE / "flank_addon")], check=True,
                       stdout=subprocess.DEVNULL)
        print("pinned = SLSQP + guard; the cold seeds are shown, not pinned; rest = click - pinned, and what it "
              "may take at the goal (share of now); Newton = the foot points' Newton runs replayed alone (this code); "
              "left = what the goal leaves for everything else once the pinned calls and the Newton runs are paid")
        print(f"{'plan':<14} {'click':>7} {'SLSQP':>7} {'guard':>7} {'pinned':>7} {'seeds':>7} {'goal':>6} "
              f"{'rest now':>9} {'rest at goal':>15} {'Newton':>7} {'left':>7}   calls: minimize (objective "
              f"evaluations) / guard / seeds / Newton runs (rows)")
        for name in plans:
            click = min(run_runner(RUNNER, [str(HERE), json.dumps(ops[name]), "", "0"], name, cwd=str(HERE))["click_s"]
                        for _ in range(args.runs))
            rec = d / f"{name}.pkl"
            counts = run_runner(RUNNER, [str(HERE), json.dumps(ops[name]), str(rec), str(args.repeat)], name,
                                cwd=str(HERE))
            with open(rec, "rb") as fh:
                data = pickle.load(fh)
            t_min = min(replay_minimize(data["runs"]) for _ in range(args.repeat))
            t_guard = min(replay_guard(data["guard"], data["tables"]) for _ in range(args.repeat))
            t_seeds = min(replay_seeds(data["seeds"], data["tables"]) for _ in range(args.repeat))
            pinned = t_min + t_guard
            goal = GOALS[name]
            rest, room = click - pinned, goal - pinned
            at_goal = f"{room:.3f} s ({room / rest:.0%})" if room > 0 else "none"
            left = goal - pinned - counts["newton_s"]
            print(f"{name:<14} {click:7.3f} {t_min:7.3f} {t_guard:7.3f} {pinned:7.3f} {t_seeds:7.3f} {goal:6.2f} "
                  f"{rest:9.3f} {at_goal:>15} {counts['newton_s']:7.3f} {left:7.3f}   {counts['minimize']} "
                  f"({counts['evaluations']}) / {counts['guard']} / {counts['seeds']} / {counts['newton_runs']} "
                  f"({counts['newton_rows']})")

if __name__ == "__main__":
    main()
