"""The worker-thread job behind the modal Run operators (operators/jobs.py has no bpy import)."""
import importlib.util
import math
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


def test_job_finishes_with_the_same_plan_and_the_ui_thread_keeps_running(female, female_plan):
    """The planner runs in the worker while this (the 'UI') thread ticks every 5 ms: the longest gap
    between ticks stays below 100 ms (numpy/scipy release the GIL, Python code yields it every 5 ms),
    and the result equals a plain synchronous run."""
    job = jobs.PlannerJob(_compute(female), Cancelled)
    gaps, last, seen = [], time.perf_counter(), []
    while job.poll()[0] == "running":
        time.sleep(0.005)
        now = time.perf_counter()
        gaps.append(now - last)
        last = now
        seen.append(job.poll()[1])
    assert job.state == "finished" and job.error is None
    assert max(gaps) < 0.1, f"UI thread blocked {max(gaps) * 1000:.0f} ms"
    assert len(gaps) > 50 and seen == sorted(seen) and job.poll() == ("finished", 1.0, "done")
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
