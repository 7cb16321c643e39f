# SPDX-License-Identifier: GPL-3.0-or-later
"""Verify, Error Plot, Check Tool, Post Program and Check Program File run modal from the UI like the planners (operators/modal.ModalPlannerMixin):
driven headless by scenario_modal_checks.py with scenario_modal's driver (TIMER / ESC events, a stand-in context).
Progress is shown while the worker runs, no modal() call holds Blender's main thread for 100 ms or more, ESC and
closing leave bpy.data and the scene exactly as before, a modal run to the end makes what the synchronous run
makes, and a failure in the worker is reported as the synchronous run reports it."""
import numpy as np
import pytest

from blender_harness import assert_cancelled_cleanly, assert_failure_reported_like_sync, run_scenario, running_polls

FRAME_MS = 100.0
OPS = ("verify", "error_plot", "cutter_region", "post", "check")


def _numbers(v):
    """Every number in a state (the scenario keeps floats as their repr), in order, and the rest as it is."""
    if isinstance(v, dict):
        return {k: _numbers(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_numbers(x) for x in v]
    if isinstance(v, str):
        try:
            return float(v)
        except ValueError:
            return v
    return v


def _assert_same_verification(got, want):
    """The same verification up to the last bit of a sum: the sweep's deviations of two runs of the same plan in
    one process differed by a few 1e-16 R (seen: 2.5e-16 R, in every fourth run of a loop: numpy took its
    vectorised or its C library's arctan2 by where an output landed, see ``geometry/angles.py``); numbers agree to
    1e-12 of their size (+1e-15), a margin kept for other numpy builds; the float32 attribute to one unit in its
    last place."""
    g, w = _numbers(got), _numbers(want)
    assert g.keys() == w.keys()
    assert len(g["deviation"]) == len(w["deviation"]) > 0
    dg, dw = (np.asarray(x["deviation"], dtype=np.float32) for x in (g, w))
    assert np.allclose(dg, dw, rtol=2.0 ** -22, atol=1e-12, equal_nan=True), np.max(np.abs(dg - dw))
    for key in ("props", "summary"):
        _assert_close(g[key], w[key], key)


def _assert_close(a, b, where):
    if isinstance(b, dict):
        assert isinstance(a, dict) and a.keys() == b.keys(), where
        for k in b:
            _assert_close(a[k], b[k], "{}/{}".format(where, k))
    elif isinstance(b, list):
        assert isinstance(a, list) and len(a) == len(b), where
        for k, (x, y) in enumerate(zip(a, b)):
            _assert_close(x, y, "{}/{}".format(where, k))
    elif isinstance(b, float) and not isinstance(a, bool):
        assert a == pytest.approx(b, rel=1e-12, abs=1e-15, nan_ok=True), (where, a, b)
    else:
        assert a == b, (where, a, b)


@pytest.fixture(scope="module")
def mc(extension_zip, tmp_path_factory):
    return run_scenario(extension_zip, "modal_checks", tmp_path_factory.mktemp("modal_checks"))


def test_the_five_operators_use_the_modal_mixin(mc):
    assert mc["mixin"] == dict(verify=True, error_plot=True, cutter_region=True, post=True, check=True)
    assert mc["run"]["result"] == ["FINISHED"], mc["run"]
    assert mc["patched_left"] == [False] * 5


def test_post_program_writes_its_file_only_when_it_finishes(mc):
    """The program file appears with the synchronous run and the modal run to the end, never with Esc or
    closing; the program posted is a whole-rotor one (every lobe) with its path and animation."""
    assert mc["post_files"] == [False, True, True, False, False, True], mc["post_files"]
    state = mc["post"]["finish"]["state"]
    assert state["file"] is not None and state["lines"] > 30 and state["path"]["edges"] > 100, state
    assert state["props"]["flank_prog_lobes"] == list(range(6)) and state["props"]["flank_prog_passes"] == 6, state


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
    if op == "verify":
        _assert_same_verification(rec["state"], mc[op]["sync"]["state"])
    elif op == "error_plot":
        # the same pixels; the chart's largest error comes from the same sweep as Verify's and may differ in its
        # last bits between two runs in one process (seen: 2.214528919263072 and 2.2145289192631123 mm)
        _assert_close(_numbers(rec["state"]), _numbers(mc[op]["sync"]["state"]), "error_plot")
        assert rec["state"]["pixels"] == mc[op]["sync"]["state"]["pixels"]
    elif op == "check":
        # the read-back's deviations come from the sweep, as Verify's: the same to the last bits of a sum
        assert rec["state"]["flank_check_findings"] == repr("[]") and rec["state"]["flank_check_passes"] == 6
        _assert_close(_numbers(rec["state"]), _numbers(mc[op]["sync"]["state"]), "check")
    else:
        assert rec["state"] == mc[op]["sync"]["state"]
    running = running_polls(rec)
    assert running, rec["calls"]
    assert max(c["held_ms"] for c in running) < FRAME_MS, running   # wall clock without waits for a core
    # the main thread's turns after the worker (Error Plot: its text in Blender's font between two workers, then
    # storing the PNG as the image) stay under a frame too, in the main thread's CPU time (at 1920 x 1080 the
    # plot's text, PNG and image took 226 ms in one turn when the main thread drew and encoded them)
    after = [c for c in rec["calls"] if c["state_before"] != "running"]
    assert after and max(c["cpu_ms"] for c in after) < FRAME_MS, after
    # reading the inputs on the main thread, in its own CPU time (the wall clock doubles under the parallel run)
    assert rec["start_cpu_ms"] < FRAME_MS + 150.0, (rec["start_cpu_ms"], rec["start_ms"])
    assert rec["percents"] and max(rec["percents"]) <= 100
    assert any("%" in (c["status"] or "") for c in running if c["status"] != "<unchanged>")


def test_worker_failure_is_reported_like_the_synchronous_run(mc):
    rec, sync = mc["verify_failed"], mc["verify_failed_sync"]
    assert_failure_reported_like_sync(rec, sync, "does not lie on the plan's rotor")


def test_error_plot_stages_cancel_and_fail_without_leaving_anything(mc):
    """Esc while Error Plot's second worker (text and PNG) runs, and a failure of the text's layout on the main
    thread between its two workers: each ends CANCELLED, stops the timer and the progress, leaves bpy.data as it
    was and writes no PNG."""
    esc, failed = mc["error_plot_stages"]["esc_next_stage"], mc["error_plot_stages"]["text_fails"]
    for rec in (esc, failed):
        assert rec["final"] == ["CANCELLED"] and rec["census_equal"] and not rec["png_written"], rec
        assert rec["timers_left"] == 0 and rec["wm_calls"][-2:] == [["event_timer_remove"], ["progress_end"]]
        assert rec["operator_job_cleared"] and rec["status_last"] is None
    assert esc["workers"] == 2 and [c["event"] for c in esc["calls"]].count("ESC") == 1
    esc_call = next(c for c in esc["calls"] if c["event"] == "ESC")
    assert esc_call["state_before"] == "running" and esc["job_state"] == "cancelled"
    assert failed["workers"] == 1 and "no font for the chart's text" in (failed["op_error"] or ""), failed
    assert "Traceback" not in (failed["op_error"] or "")


def test_a_long_plan_not_kept_parsed_is_read_in_a_worker_first(mc):
    """A file opened again keeps no parsed plans: a long plan text is read in a worker, in pieces, before Error
    Plot's own stages (the run's 0.9 MB plan, with the limit lowered to 100,000 characters for the test).  The
    modal run shows the reading, never holds the main thread for a frame and draws what the synchronous run
    draws; both keep the plan parsed for the next operator.  A stored text that is not valid JSON is reported and
    changes nothing."""
    pr = mc["plan_read"]
    assert pr["text_chars"] > 100_000
    rec, sync = pr["modal"], pr["sync"]
    assert sync["op_result"] == ["FINISHED"] and sync["kept"], sync
    assert rec["final"] == ["FINISHED"] and rec["op_result"] == ["FINISHED"] and rec["kept"], rec["op_error"]
    for got in (rec["state"], sync["state"]):      # numbers to 1e-12 (see the test above), pixels exactly
        _assert_close(_numbers(got), _numbers(mc["error_plot"]["sync"]["state"]), "error_plot")
        assert got["pixels"] == mc["error_plot"]["sync"]["state"]["pixels"]
    assert rec["workers"] == 3, rec["workers"]            # the plan, then the chart's two workers
    statuses = [c["status"] for c in rec["calls"]] + [rec["status_start"]]
    assert any("reading the plan of '{}'".format(mc["run"]["name"]) in (s or "") for s in statuses), statuses
    assert max(c["held_ms"] for c in running_polls(rec)) < FRAME_MS
    after = [c for c in rec["calls"] if c["state_before"] != "running"]
    assert after and max(c["cpu_ms"] for c in after) < FRAME_MS, after
    # Animate Strip reads it first too, then makes the animation the synchronous run makes (one strip's motion)
    anim, anim_sync = pr["animate_modal"], pr["animate_sync"]
    assert anim_sync["op_result"] == ["FINISHED"] and anim_sync["kept"] and len(anim_sync["motion"]) == 1, anim_sync
    assert anim["final"] == ["FINISHED"] and anim["op_result"] == ["FINISHED"] and anim["kept"], anim["op_error"]
    assert anim["motion"] == anim_sync["motion"] and anim["workers"] == 2, (anim["motion"], anim["workers"])
    assert max(c["held_ms"] for c in running_polls(anim)) < FRAME_MS
    pinned = pr["animate_pinned"]
    assert pinned["final"] == ["FINISHED"] and pinned["workers"] == 2 and pinned["newer_made"], pinned
    assert pinned["animated"] == [mc["run"]["name"]], pinned      # not "A Newer Run"
    assert pinned["collection_after"] == "", pinned
    broken = pr["broken"]
    assert broken["final"] == ["CANCELLED"] and broken["census_equal"] and not broken["kept"], broken
    assert "the plan stored on '{}' is not valid".format(mc["run"]["name"]) in (broken["op_error"] or ""), broken
    assert "Traceback" not in (broken["op_error"] or "")
