"""How far the planners' reported figures move with rounding alone: each plan of ``bench_interactive.py`` is made
twice in fresh processes, once with the BLAS library's default threads and once with one thread.  Nothing else
changes (same code, inputs, machine), but a BLAS routine that splits a sum over threads rounds differently, and
an optimiser can carry that difference into its result.

For every plan the largest difference of a reported error figure (each strip's and the summary's largest and
smallest signed error) is printed in the plan's unit and, for rotor plans, in units of the outer radius R; the
free-form plan also shows its kink figures.  A figure that moves here is not defined more closely than that on
machines with another number of cores.

With ``--repeat N`` each plan is made N times in each mode (alternating); the table then also says whether the
repeats of a mode agree in every reported figure, bit for bit, and gives the planner's own time (the plan's
``summary.elapsed_s``, the fastest of the N) in each mode: the optimisers follow another path with one thread,
and may need more or fewer evaluations on it.

    PYTHONPATH=. .venv/bin/python bench/bench_rounding.py [--only NAME,...] [--repeat N]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_interactive import HERE, make_inputs, operations  # noqa: E402

ONE_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
PLANS = ("double-flank", "two-paths-f", "two-paths-m", "single-flank", "freeform")


def make_plan(argv, out, one_thread):
    env = dict(os.environ, PYTHONPATH=str(HERE), **(ONE_THREAD if one_thread else {}))
    if not one_thread:
        for k in ONE_THREAD:
            env.pop(k, None)
    argv = argv[:argv.index("--out") + 1] + [str(out)]
    p = subprocess.run([sys.executable, "-m", "flank_addon", *argv], env=env, cwd=str(HERE), capture_output=True,
                       text=True)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)} failed:\n{p.stderr[-3000:]}")
    return json.loads(out.read_text())


def figures(plan):
    """The reported error figures of a plan (name -> value) and its outer radius (None for a free-form plan)."""
    out = {}
    for i, s in enumerate(plan["strips"]):
        for k in ("reported_max_error", "reported_min_error"):
            if s.get(k) is not None:
                out[f"strip {i} {k}"] = s[k]
    for k in ("max_error", "min_error", "max_kink_deg", "mean_kink_deg"):
        if plan["summary"].get(k) is not None:
            out[f"summary {k}"] = plan["summary"][k]
    R = plan.get("rotor", {}).get("outer_radius")
    return out, R


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", default="", help="comma-separated plan names")
    ap.add_argument("--repeat", type=int, default=1, help="plans made per mode")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        info = make_inputs(d)
        (d / HERE.name).mkdir(exist_ok=True)
        ops = operations(d, info)
        names = [n for n in PLANS if not args.only or n in args.only.split(",")]
        print(f"{'plan':14s} {'largest change of an error figure':>36s}  {'where':30s} kinks (deg)"
              + ("   repeats equal   planner time, default / one thread" if args.repeat > 1 else ""))
        for name in names:
            runs = {False: [], True: []}
            for _ in range(max(1, args.repeat)):
                for one in (False, True):
                    plan = make_plan(ops[name], d / f"{name}_{'one' if one else 'default'}.json", one)
                    runs[one].append((figures(plan), plan["summary"].get("elapsed_s", float("nan"))))
            (a, R), _ = runs[False][0]
            (b, _), _ = runs[True][0]
            errors = [k for k in a if "kink" not in k]
            worst = max(errors, key=lambda k: abs(a[k] - b[k]))
            diff = abs(a[worst] - b[worst])
            text = f"{diff:.3g}" + (f" ({diff / R:.3g} R)" if R else " (document unit)")
            kinks = [k for k in a if "kink" in k]
            ktext = ", ".join(f"{k.split()[-1]} {abs(a[k] - b[k]):.3g}" for k in kinks)
            line = f"{name:14s} {text:>36s}  {worst:30s} {ktext}"
            if args.repeat > 1:
                same = all(r[0] == runs[one][0][0] for one in runs for r in runs[one])
                line += (f"   {'yes' if same else 'NO':13s}   {min(t for _, t in runs[False]):.3f} /"
                         f" {min(t for _, t in runs[True]):.3f} s")
            print(line, flush=True)


if __name__ == "__main__":
    main()
