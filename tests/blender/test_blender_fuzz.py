# SPDX-License-Identifier: GPL-3.0-or-later
"""Fuzzing every flank.* operator (see scenario_fuzz.py): no Python traceback ever reaches the user, a failed
call leaves no data-block behind, and every failure says why."""
import pytest

from blender_harness import run_scenario


@pytest.fixture(scope="module")
def fuzz(extension_zip, tmp_path_factory):
    return run_scenario(extension_zip, "fuzz", tmp_path_factory.mktemp("fuzz"))


def test_every_operator_was_fuzzed(fuzz):
    ops = set(fuzz["operators"])
    assert {"flank.analyze_rotor", "flank.plan_single_flank", "flank.plan_double_flank", "flank.verify_plan",
            "flank.formed_cutter", "flank.paraboloid_groove", "flank.cutter_region", "flank.generate_rotor"} <= ops
    called = {c["op"] for c in fuzz["calls"]}
    assert called == ops
    assert len(fuzz["calls"]) >= 100


def test_no_traceback_reaches_the_user(fuzz):
    bad = [(c["op"], c["subject"], c.get("prop"), c.get("value"), c["error"][-300:])
           for c in fuzz["calls"] if c["traceback"] or c["other"]]
    assert not bad, bad


def test_failed_calls_leave_nothing_behind(fuzz):
    leaks = [(c["op"], c["subject"], c.get("prop"), c.get("value"), c["leaked"]) for c in fuzz["calls"] if c["leaked"]]
    assert not leaks, leaks


def test_wrong_selections_are_refused_with_a_message(fuzz):
    """Operators that need a rotor refuse nothing/camera/empty/empty mesh/triangle/loose edges/NaN/cube with an
    ERROR message (verify_plan and the stand-alone generators need no rotor and may succeed)."""
    need_rotor = {"flank.analyze_rotor", "flank.plan_single_flank", "flank.plan_double_flank",
                  "flank.cutter_region"}
    for c in fuzz["calls"]:
        if c["subject"] != "rotor" and c["op"] in need_rotor:
            assert c["result"] is None and c["error"], c
            assert len(c["error"].strip()) > 20, c


def test_non_finite_numbers_are_refused_by_the_planners(fuzz):
    """NaN or infinity in a tool size, angle, tolerance or rim never plans: an ERROR names the setting.  (The
    cone length is not used with the default shape 'alpha', so it is not among them.)"""
    checked = 0
    for c in fuzz["calls"]:
        if c.get("value") in ("nan", "inf") and c["op"] in ("flank.plan_single_flank", "flank.plan_double_flank") \
                and c["prop"] in ("tolerance", "overcut_tolerance", "r1", "r2", "alpha", "rim"):
            assert c["result"] is None and c["error"], c
            checked += 1
    assert checked >= 12


def test_the_fuzz_run_stays_quick(fuzz):
    """No accepted call ran away with a huge size (each is bounded by a limit check)."""
    slow = [(c["op"], c.get("prop"), c.get("value"), round(c["seconds"], 1)) for c in fuzz["calls"]
            if c["seconds"] > 20.0]
    assert not slow, slow
