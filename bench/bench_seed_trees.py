"""The foot points' cold seeds: their exact kd-tree queries replayed on trees of several leaf sizes.

A foot-point query without a warm start seeds Newton from the k nearest samples of the flank's (u, tau) table
(``FlankFeet._exact_seeds``, a midpoint-split tree).  An exact query has one answer whatever the tree, so the
tree's leaf size is free to choose.  This bench runs four plans in fresh processes (the double-flank plan, the
two-paths plans of the asymmetric female and male, the single-flank plan of the 349k-triangle mesh of
``bench_interactive.py``), records every cold-seed query (the table and the planar points), and replays them
here on midpoint trees with 16 (scipy's default), 32, 48 and 64 samples per leaf: the trees' build time, the
queries' time (minima over ``--repeat`` replays, the queries' own thread counts) and whether every answer is
the same as the 16-sample tree's.

    PYTHONPATH=. .venv/bin/python bench/bench_seed_trees.py [--repeat 7]
"""
import argparse
import json
import pickle
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(HERE / "bench"))
sys.path.insert(0, str(HERE))

from bench_interactive import make_inputs, operations, run_runner  # noqa: E402

RUNNER = r"""
import contextlib, io, json, pickle, sys
sys.path.insert(0, sys.argv[1])
from flank_addon import cli
from flank_addon.geometry import flank_feet
queries, tables = [], {}
asked = flank_feet.FlankFeet._exact_seeds
def recorded(self, Q, k):
    tables[id(self)] = self._points
    queries.append((id(self), Q.copy(), k))
    return asked(self, Q, k)
flank_feet.FlankFeet._exact_seeds = recorded
with contextlib.redirect_stdout(io.StringIO()):
    rc = cli.main(json.loads(sys.argv[2]))
with open(sys.argv[3], "wb") as fh:
    pickle.dump({"queries": queries, "tables": tables}, fh)
print(json.dumps({"rc": rc, "queries": len(queries), "rows": sum(len(q) for _, q, _ in queries)}))
"""

LEAF_SIZES = (16, 32, 48, 64)


def replay(queries, tables, repeat):
    """{leaf size: (build s, query s, same answers as 16)} over ``repeat`` replays (minima)."""
    import numpy as np
    from scipy.spatial import cKDTree

    from flank_addon.geometry.flank_feet import _workers

    best, answers = {}, {}
    for _ in range(repeat):
        for leaf in LEAF_SIZES:
            t0 = time.perf_counter()
            trees = {key: cKDTree(p, leafsize=leaf, balanced_tree=False, compact_nodes=False)
                     for key, p in tables.items()}
            t1 = time.perf_counter()
            out = [trees[key].query(Q, k=k, workers=_workers(len(Q)))[1] for key, Q, k in queries]
            t2 = time.perf_counter()
            b = best.setdefault(leaf, [np.inf, np.inf])
            b[0], b[1] = min(b[0], t1 - t0), min(b[1], t2 - t1)
            answers[leaf] = out
    ref = answers[LEAF_SIZES[0]]
    return {leaf: (b[0], b[1], all(np.array_equal(a, r) for a, r in zip(answers[leaf], ref)))
            for leaf, b in best.items()}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        (d / HERE.name).mkdir()
        ops = operations(d, make_inputs(d))
        print(f"{'plan':<14} {'queries':>8} {'rows':>8}  " +
              "  ".join(f"leaf {leaf}: build / query (s)" for leaf in LEAF_SIZES))
        for name in ("double-flank", "two-paths-f", "two-paths-m", "single-flank"):
            rec = d / f"{name}.pkl"
            res = run_runner(RUNNER, [str(HERE), json.dumps(ops[name]), str(rec)], name, cwd=str(HERE))
            with open(rec, "rb") as fh:
                data = pickle.load(fh)
            times = replay(data["queries"], data["tables"], args.repeat)
            cells = "  ".join(f"{b:.4f} / {q:.4f}{'' if same else ' DIFFERENT'}" + " " * 13
                              for b, q, same in times.values())
            print(f"{name:<14} {res['queries']:>8} {res['rows']:>8}  {cells}")


if __name__ == "__main__":
    main()
