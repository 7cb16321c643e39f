# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.formed_cutter runs modal from the UI like the planners (operators/modal.ModalPlannerMixin): driven
headless by scenario_results_modal_cutter.py with scenario_modal's driver (TIMER / ESC events, stand-in
context).  ESC and closing leave bpy.data and the scene exactly as before, a modal run to the end equals the
synchronous run, a core error in the worker is reported as the synchronous run reports it."""
import pytest

from blender_harness import assert_failure_reported_like_sync, run_scenario, running_polls


@pytest.fixture(scope="module")
def mc(extension_zip, tmp_path_factory):
    return run_scenario(extension_zip, "results_modal_cutter", tmp_path_factory.mktemp("results_modal_cutter"))


def test_formed_cutter_uses_the_modal_mixin_and_background_is_synchronous(mc):
    assert mc["mixin"] is True
    s = mc["sync"]
    assert s["result"] == ["FINISHED"], s
    run = s["run"]
    assert run["collection"] == "Formed Cutter (Rotor_srm_a_male)" and run["parents"] == ["Flank Results"]
    assert run["reached_points"] == 81 and run["materials"] == ["Flank Attribute Colour"]
    assert not mc["patched_left"]


@pytest.mark.parametrize("plan", ["esc", "close"])
def test_cancel_leaves_everything_as_before(mc, plan):
    rec = mc[plan]
    assert rec["driven"] and rec["start"] == ["RUNNING_MODAL"] and rec["has_job"], rec
    assert rec["final"] == ["CANCELLED"], rec
    assert rec["census_equal"], rec["census_diff"]
    assert rec["thread_alive"] is False and rec["timers_left"] == 0 and rec["operator_job_cleared"]
    assert rec["wm_calls"][-2:] == [["event_timer_remove"], ["progress_end"]]
    if plan == "esc":
        assert [c["event"] for c in rec["calls"]].count("ESC") == 1
        assert "cancelled" in (rec["op_error"] or "") or rec["op_result"] == ["CANCELLED"] or \
            rec["op_result"] is None, rec


def test_modal_run_to_the_end_equals_the_synchronous_run(mc):
    rec = mc["finish"]
    assert rec["final"] == ["FINISHED"], rec
    assert rec["op_result"] == ["FINISHED"], rec["op_error"]
    sync, run = mc["sync"]["run"], rec["run"]
    for key in ("collection", "parents", "objects", "r_range", "z_range", "max_abs_deviation", "flagged_planes",
                "reached_points", "deviation", "cutter_vertices", "materials"):
        assert run[key] == sync[key], key
    # progress: percentages reported while the worker ran, and no modal() call held the UI for 100 ms
    assert rec["percents"] and max(rec["percents"]) <= 100
    running = running_polls(rec)
    assert running and max(c["held_ms"] for c in running) < 100.0, running   # without waits for a core


def test_worker_error_is_reported_like_the_synchronous_run(mc):
    rec, sync = mc["failed"], mc["failed_sync"]
    assert_failure_reported_like_sync(rec, sync, "centre distance")
