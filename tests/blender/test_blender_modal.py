# SPDX-License-Identifier: GPL-3.0-or-later
"""The modal Run path (operators/modal.py) of flank.plan_single_flank and flank.plan_freeform, driven headless
by scenario_modal.py: ESC cancels and leaves bpy.data / the scene exactly as before, TIMER events move the
progress bar and the status text, a run to the end builds the same strips as the synchronous execute(), and no
modal() call while the planner runs holds the main thread for 100 ms or more."""
import importlib.util
from pathlib import Path

import pytest

from blender_harness import run_scenario

FRAME_MS = 100.0
OPS = ("single_flank", "freeform")


@pytest.fixture(scope="module")
def modal(extension_zip, tmp_path_factory):
    return run_scenario(extension_zip, "modal", tmp_path_factory.mktemp("modal"))


def _running_calls(rec):
    """modal() calls made while the worker was running (TIMER polls and the ESC key), not the final build."""
    return [c for c in rec["calls"] if c["state_before"] == "running" and c["event"] in ("TIMER", "ESC")
            and not (c["event"] == "TIMER" and c["result"] != ["RUNNING_MODAL"])]


def test_background_invoke_is_synchronous(modal):
    assert modal["background"] is True
    assert modal["mixin"] == dict(sf=True, ff=True)
    inv = modal["invoke_default"]
    assert inv["result"] == ["FINISHED"], inv
    assert inv["run"]["strips"] >= 1


@pytest.mark.parametrize("op", OPS)
def test_the_driver_ran_the_modal_path(modal, op):
    for plan in ("esc", "close", "finish"):
        rec = modal[op][plan]
        assert rec.get("driven") and rec["background"], (plan, rec)
        assert rec["start"] == ["RUNNING_MODAL"] and rec["has_job"], (plan, rec)
        # invoke's UI set-up: a 0.1 s timer in the window, progress 0..100, the operator as modal handler
        assert rec["wm_calls_start"] == [["event_timer_add", modal["timer_step"], True], ["progress_begin", 0, 100],
                                         ["modal_handler_add"]], rec["wm_calls_start"]
        assert rec["handler_is_self"]
        assert "Esc cancels" in rec["status_start"]
        assert rec["mousemove"]["result"] == ["PASS_THROUGH"]
        # the end: timer removed, progress ended, status text cleared, the job dropped, the worker gone
        assert rec["wm_calls"][-2:] == [["event_timer_remove"], ["progress_end"]], (plan, rec["wm_calls"])
        assert rec["timers_left"] == 0 and rec["status_last"] is None and rec["operator_job_cleared"]
        assert rec["thread_alive"] is False, (plan, rec)
        assert not rec.get("timed_out")
    assert modal["patched_left"] == [False, False]


@pytest.mark.parametrize("op", OPS)
def test_esc_cancels_and_leaves_the_scene_exactly_as_before(modal, op):
    rec = modal[op]["esc"]
    esc = [c for c in rec["calls"] if c["event"] == "ESC"]
    assert len(esc) == 1 and esc[0]["state_before"] == "running", rec["calls"]
    assert esc[0]["result"] == ["RUNNING_MODAL"] and "cancelling" in esc[0]["status"]
    last = rec["calls"][-1]
    assert last["event"] == "TIMER" and last["result"] == ["CANCELLED"] and last["state_before"] == "cancelled"
    assert rec["final"] == ["CANCELLED"] and rec["op_result"] == ["CANCELLED"] and rec["op_error"] is None
    assert rec["job_state"] == "cancelled" and rec["job_result_none"]
    assert rec["census_equal"], rec["census_diff"]
    sizes = rec["census_sizes"]
    assert sizes["objects"] >= 3 and sizes["meshes"] >= 3 and sizes["flank_settings"] > 50, sizes


@pytest.mark.parametrize("op", OPS)
def test_closing_the_operator_stops_the_worker(modal, op):
    """Blender's cancel() (file closed while planning): the worker stops, nothing is built."""
    rec = modal[op]["close"]
    assert rec["calls"][-1]["event"] == "cancel()" and rec["calls"][-1]["state_before"] == "running"
    assert rec["op_result"] == ["CANCELLED"] and rec["job_state"] == "cancelled"
    assert rec["census_equal"], rec["census_diff"]


@pytest.mark.parametrize("op", OPS)
def test_timer_events_update_progress_and_status(modal, op):
    rec = modal[op]["finish"]
    running = [c for c in rec["calls"] if c["event"] == "TIMER" and c["result"] == ["RUNNING_MODAL"]]
    assert len(running) >= 3, rec["calls"]
    for c in running:
        assert c["percent"] is not None and 0 <= c["percent"] <= 100
        assert c["status"].startswith({"single_flank": "Single flank", "freeform": "Free-form"}[op])
        assert "{:3.0f}%".format(c["percent"]) in c["status"] and "(Esc cancels)" in c["status"]
    pct = [c["percent"] for c in running]
    assert pct == sorted(pct) and pct[-1] > pct[0], pct
    assert len({c["status"] for c in running}) >= 2


@pytest.mark.parametrize("op", OPS)
def test_modal_run_to_the_end_equals_the_synchronous_run(modal, op):
    sync, rec = modal[op]["sync"], modal[op]["finish"]
    assert sync["result"] == ["FINISHED"], sync
    assert rec["final"] == ["FINISHED"] and rec["op_result"] == ["FINISHED"], rec
    assert rec["calls"][-1]["state_before"] == "finished"
    a, b = sync["run"], rec["run"]
    assert a["name"] == b["name"] and a["objects"] == b["objects"]   # the modal run replaced the synchronous one
    assert a["strips"] == b["strips"] == a["plan_strips"] == b["plan_strips"] >= 1
    for key in ("max_error", "min_error", "plan_max_error"):
        assert b[key] == pytest.approx(a[key], rel=1e-9, abs=1e-15), key
    if "strip_max_error" in a:
        assert b["strip_max_error"] == pytest.approx(a["strip_max_error"], rel=1e-9, abs=1e-15)


@pytest.mark.parametrize("op", OPS)
def test_no_frame_is_blocked_while_the_planner_runs(modal, op):
    """Each modal() call while the worker runs (progress polls, ESC) returns within 100 ms: its wall clock less the
    time the main thread and the worker spent waiting for a core (the other test worker's Blender loads both cores;
    a worker holding the interpreter lock while it computes still counts)."""
    worst = 0.0
    for plan in ("esc", "close", "finish"):
        calls = _running_calls(modal[op][plan])
        assert calls, plan
        worst = max([worst] + [c["held_ms"] for c in calls])
    assert worst < FRAME_MS, "modal() held the main thread {:.1f} ms".format(worst)


def test_a_planner_failure_in_the_worker_is_reported_and_builds_nothing(modal):
    rec = modal["single_flank"]["failed"]
    assert rec["start"] == ["RUNNING_MODAL"]
    assert rec["calls"][-1]["state_before"] == "failed" and rec["final"] == ["CANCELLED"]
    assert rec["op_result"] is None and "Single flank" in rec["op_error"], rec
    assert "no collision-free strip" in rec["op_error"] and "Traceback" not in rec["op_error"]
    assert rec["census_equal"] and rec["thread_alive"] is False


def test_bad_input_is_refused_before_any_job_starts(modal):
    rec = modal["single_flank"]["bad_input"]
    assert rec["start"] == ["CANCELLED"] and rec["wm_calls_start"] == [] and rec["handlers"] == 0
    assert rec["op_result"] is None and "r1 must be below r2" in rec["op_error"]
    assert rec["census_equal"]


def _jobs_module():
    path = Path(__file__).resolve().parents[2] / "operators" / "jobs.py"
    spec = importlib.util.spec_from_file_location("flank_jobs_modal_test", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_esc_after_the_worker_finished_still_builds_nothing():
    """ESC pressed between the worker's end and the next TIMER poll: the result is dropped (no bpy needed)."""
    jobs = _jobs_module()
    job = jobs.PlannerJob(lambda progress: "result")
    assert job.wait(5) == "finished" and job.result == "result"
    job.cancel()
    assert job.poll()[0] == "cancelled" and job.result is None
