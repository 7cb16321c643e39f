# SPDX-License-Identifier: GPL-3.0-or-later
"""Verify, Error Plot and Check Tool run modal from the UI like the planners (operators/modal.ModalPlannerMixin):
driven headless by scenario_modal_checks.py with scenario_modal's driver (TIMER / ESC events, a stand-in context).
Progress is shown while the worker runs, no modal() call holds Blender's main thread for 100 ms or more, ESC and
closing leave bpy.data and the scene exactly as before, a modal run to the end makes what the synchronous run
makes, and a failure in the worker is reported as the synchronous run reports it."""
import pytest

from blender_harness import assert_cancelled_cleanly, run_scenario

FRAME_MS = 100.0
OPS = ("verify", "error_plot", "cutter_region")


@pytest.fixture(scope="module")
def mc(extension_zip, tmp_path_factory):
    return run_scenario(extension_zip, "modal_checks", tmp_path_factory.mktemp("modal_checks"))


def test_the_three_operators_use_the_modal_mixin(mc):
    assert mc["mixin"] == dict(verify=True, error_plot=True, cutter_region=True)
    assert mc["run"]["result"] == ["FINISHED"], mc["run"]
    assert mc["patched_left"] == [False, False, False]


@pytest.mark.parametrize("op", OPS)
def test_background_run_is_synchronous_and_finishes(mc, op):
    s = mc[op]["sync"]
    assert s["result"] == ["FINISHED"], s
    assert s["state"] is not None


@pytest.mark.parametrize("op", OPS)
@pytest.mark.parametrize("plan", ["esc", "close"])
def test_cancel_leaves_everything_as_before(mc, op, plan):
    assert_cancelled_cleanly(mc[op][plan], mc["timer_step"], plan)


@pytest.mark.parametrize("op", OPS)
def test_modal_run_to_the_end_equals_the_synchronous_run_and_never_blocks(mc, op):
    rec = mc[op]["finish"]
    assert rec["final"] == ["FINISHED"] and rec["op_result"] == ["FINISHED"], (rec["final"], rec["op_error"])
    assert rec["state"] == mc[op]["sync"]["state"]
    running = [c for c in rec["calls"] if c["state_before"] == "running" and c["result"] == ["RUNNING_MODAL"]]
    assert running, rec["calls"]
    assert max(c["ms"] for c in running) < FRAME_MS, running
    # reading the inputs on the main thread, in its own CPU time (the wall clock doubles under the parallel run)
    assert rec["start_cpu_ms"] < FRAME_MS + 150.0, (rec["start_cpu_ms"], rec["start_ms"])
    assert rec["percents"] and max(rec["percents"]) <= 100
    assert any("%" in (c["status"] or "") for c in running if c["status"] != "<unchanged>")


def test_worker_failure_is_reported_like_the_synchronous_run(mc):
    rec, sync = mc["verify_failed"], mc["verify_failed_sync"]
    assert rec["final"] == ["CANCELLED"] and rec["census_equal"], rec
    assert sync["result"] is None and "does not lie on the plan's rotor" in sync["error"], sync
    assert rec["op_error"] == sync["error"], (rec["op_error"], sync["error"])
    assert "Traceback" not in rec["op_error"]
