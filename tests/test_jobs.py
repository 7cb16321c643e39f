"""The worker-thread job behind the modal Run operators (operators/jobs.py has no bpy import)."""
import importlib.util
import math
import threading
import time
from pathlib import Path

import pytest

from flank_addon.tooling.cone import ConeTool
from flank_addon.methods.single_flank.planner import plan_single_flank
from flank_addon.progress import Cancelled

_spec = importlib.util.spec_from_file_location("flank_jobs", Path(__file__).resolve().parents[1] / "operators" / "jobs.py")
jobs = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(jobs)

TOOL = ConeTool(math.asin(0.1), 0.05, 0.08, 0.04, 0.6)


def _compute(female):
    r, s = female
    return lambda progress: plan_single_flank(s, r.flanks, 1, TOOL, 1e-3, n_seeds=18, progress=progress)


def _run_queue_seconds(tid):
    """Seconds thread ``tid`` (a native id) has spent runnable but waiting for a CPU -- field 2 of Linux's
    /proc schedstat -- or None where the kernel does not report it or the thread has ended."""
    try:
        with open(f"/proc/self/task/{tid}/schedstat") as f:
            return int(f.read().split()[1]) * 1e-9
    except (OSError, ValueError, IndexError):
        return None


def _tick_while_running(job):
    """Be the UI thread: tick every 5 ms until ``job`` ends. Returns, per tick, how long the worker held this
    thread up, and the progress fractions seen.

    A gap between ticks also holds the time either thread sat in the kernel's run queue, waiting for a core that
    other processes kept busy (the worker may wait there holding the interpreter lock). That time is the
    machine's, not the planner's, and is taken out of each gap where Linux reports it."""
    threads = (threading.get_native_id(), job._thread.native_id)
    held, seen, last = [], [], time.perf_counter()
    queued = [_run_queue_seconds(t) for t in threads]
    while job.poll()[0] == "running":
        time.sleep(0.005)
        now, queued_now = time.perf_counter(), [_run_queue_seconds(t) for t in threads]
        waited = sum(b - a for a, b in zip(queued, queued_now) if a is not None and b is not None)
        held.append(now - last - waited)
        last, queued = now, queued_now
        seen.append(job.poll()[1])
    return held, seen


def test_job_finishes_with_the_same_plan_and_the_ui_thread_keeps_running(female, female_plan):
    """The planner runs in the worker while this (the 'UI') thread ticks every 5 ms: the planner's code never holds
    the interpreter lock for 100 ms (numpy/scipy release it, Python code yields it every 5 ms), and the result
    equals a plain synchronous run."""
    job = jobs.PlannerJob(_compute(female), Cancelled)
    held, seen = _tick_while_running(job)
    assert job.state == "finished" and job.error is None
    assert max(held) < 0.1, f"the worker held the UI thread up {max(held) * 1000:.0f} ms"
    assert len(held) > 50 and seen == sorted(seen) and job.poll() == ("finished", 1.0, "done")
    ref = female_plan[1]                          # the same inputs planned synchronously (tests/conftest.py)
    assert len(job.result.strips) == len(ref.strips)
    assert job.result.plan["summary"]["max_error"] == pytest.approx(ref.plan["summary"]["max_error"], rel=1e-9)


def test_cancel_ends_the_job_without_a_result(female):
    """ESC: the planner stops at its next report (the first report after the request raises Cancelled) and the
    job ends at once, without a result."""
    r, s = female
    refused = []                                      # when the planner made a report the job refused

    def compute(progress):
        def spy(fraction, message):
            ok = progress(fraction, message)
            if ok is False:
                refused.append(time.perf_counter())
            return ok

        return plan_single_flank(s, r.flanks, 1, TOOL, 1e-3, n_seeds=18, progress=spy)

    job = jobs.PlannerJob(compute, Cancelled)
    while job.poll()[1] < 0.02:
        time.sleep(0.002)
    job.cancel()
    assert job.wait(120) == "cancelled"
    ended = time.perf_counter()
    assert job.result is None and job.error is None
    assert refused, "the planner finished without reporting again"
    assert ended - refused[0] < 1.0, f"ran on {ended - refused[0]:.1f} s after the refused report"


def test_failure_is_kept_for_the_operator_to_report():
    def boom(progress):
        progress(0.1, "about to fail")
        raise ValueError("tool r1 = -1 is below the limit 0")
    job = jobs.PlannerJob(boom, Cancelled)
    assert job.wait(5) == "failed"
    assert isinstance(job.error, ValueError) and "r1 = -1" in str(job.error)
    assert job.result is None


def test_the_tick_measure_sees_a_worker_that_holds_the_lock():
    """The measure above can fail: one C call that keeps the interpreter lock for ~0.5 s shows in full, whatever
    the machine's load, since the worker runs (on a core) for all of it."""
    def hog(progress):
        progress(0.1, "started")
        time.sleep(0.05)                              # let the UI thread start ticking
        sum(range(3 * 10**7))                         # one C call, the lock held throughout
        return "done"

    job = jobs.PlannerJob(hog, Cancelled)
    held, _ = _tick_while_running(job)
    assert job.state == "finished" and max(held) > 0.1, f"the longest hold seen was {max(held) * 1000:.0f} ms"


def test_warm_up_imports_in_a_thread_once_and_keeps_a_failure():
    """The sidebar's warm-up: relative names are the extension's, a module that fails to import is kept (the
    click that needs it reports it), and the process has one warm-up however often the tab is drawn."""
    w = jobs.WarmUp("flank_addon", (".progress", "json", "flank_no_such_module"))
    assert w.wait(60)
    assert w.imported == [".progress", "json"] and list(w.failed) == ["flank_no_such_module"]
    assert isinstance(w.failed["flank_no_such_module"], ImportError) and w.elapsed >= 0
    first = jobs.warm_up("flank_addon", (".progress",))
    assert jobs.warm_up("flank_addon", ("json",)) is first and first.wait(60) and first.imported == [".progress"]


_CLICK_AFTER_WARM_UP = r"""
import contextlib, gc, importlib.util, io, json, sys, tempfile
spec = importlib.util.spec_from_file_location("flank_jobs", sys.argv[1])
jobs = importlib.util.module_from_spec(spec)
spec.loader.exec_module(jobs)
names = [n[1:] if n.startswith(".") else n for n in jobs.WARM_MODULES]
if sys.argv[2] == "warm-up":
    jobs.WarmUp(None, names).wait()
else:                                   # the same imports, and nothing after them
    for name in names:
        importlib.import_module(name)
from flank_addon import cli
full = []
gc.callbacks.append(lambda phase, info: full.append(1) if phase == "stop" and info["generation"] == 2 else None)
with tempfile.TemporaryDirectory() as d, contextlib.redirect_stdout(io.StringIO()):
    rc = cli.main(["plan", "double-flank", "--builtin", "asymmetric-female", "--valley", "0", "--out", d + "/p.json"])
print(json.dumps({"rc": rc, "full": len(full)}))
"""


def test_the_first_click_after_the_warm_up_makes_no_full_collection():
    """The warm-up ends with a full collection: the objects its imports leave in the collector's young
    generations would otherwise bring one due within the first click (a double-flank plan, in a fresh process,
    as ``bench/bench_click_parts.py`` measures it)."""
    import json
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[1]
    out = {}
    for mode in ("warm-up", "imports-only"):
        p = subprocess.run([sys.executable, "-c", _CLICK_AFTER_WARM_UP, str(root / "operators" / "jobs.py"), mode],
                           capture_output=True, text=True, cwd=root, timeout=600)
        assert p.returncode == 0, p.stderr[-2000:]
        out[mode] = json.loads(p.stdout.strip().splitlines()[-1])
        assert out[mode]["rc"] == 0
    assert out["warm-up"]["full"] == 0
    assert out["imports-only"]["full"] >= 1       # what the warm-up's collection takes out of the click
