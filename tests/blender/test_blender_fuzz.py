# SPDX-License-Identifier: GPL-3.0-or-later
"""Fuzzing every flank.* operator (see scenario_fuzz.py): no Python traceback ever reaches the user, a failed
call leaves no data-block behind, and every failure says why -- wrong selections, non-manifold meshes,
degenerate tools and non-finite or huge numbers."""
import pytest

from blender_harness import run_scenario


NEED_ROTOR = {"flank.analyze_rotor", "flank.plan_single_flank", "flank.plan_double_flank", "flank.cutter_region"}
MESH_PLANNERS = NEED_ROTOR | {"flank.plan_freeform", "flank.preview_guiding"}
WRONG_SELECTIONS = {"nothing", "camera", "empty", "empty_mesh", "triangle", "loose_edges", "nan_vertices", "cube"}
NON_MANIFOLD = ("nm_fin", "nm_two_shells", "nm_degenerate")
ROTOR_NON_MANIFOLD = ("nm_rotor_fin", "nm_rotor_two_shells", "nm_rotor_dup_zero", "nm_rotor_unwelded")
# what the free-form planner (and its guiding preview) names for each non-manifold mesh
FREEFORM_REASON = {"nm_fin": "shared by 3 faces", "nm_two_shells": "2 connected pieces",
                   "nm_degenerate": "has area 0", "nm_rotor_fin": "shared by 3 faces",
                   "nm_rotor_two_shells": "2 connected pieces", "nm_rotor_dup_zero": "has area 0",
                   "nm_rotor_unwelded": "connected pieces"}


def _calls(fuzz, subject, op=None, case=None):
    return [c for c in fuzz["calls"] if c["subject"] == subject and (op is None or c["op"] == op)
            and (case is None or c.get("case") == case)]


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
    """Operators that need a rotor (the formed cutter with the source 'Active rotor', as the fuzz calls it for
    the selections) refuse nothing/camera/empty/empty mesh/triangle/loose edges/NaN/cube with an ERROR message
    (verify_plan and the stand-alone generators need no rotor and may succeed)."""
    for c in fuzz["calls"]:
        if c["subject"] in WRONG_SELECTIONS and c["op"] in NEED_ROTOR | {"flank.formed_cutter"}:
            assert c["result"] is None and c["error"], c
            assert len(c["error"].strip()) > 20, c


def test_non_finite_numbers_are_refused_by_the_planners(fuzz):
    """NaN or infinity in a tool size, angle, cone length, tolerance or rim never plans: an ERROR names the
    setting.  (The cone length is fuzzed with the shape 'length', the only one that reads it.)"""
    checked = 0
    for c in fuzz["calls"]:
        if c.get("value") in ("nan", "inf") and c["op"] in ("flank.plan_single_flank", "flank.plan_double_flank") \
                and c["prop"] in ("tolerance", "overcut_tolerance", "r1", "r2", "alpha", "length", "rim"):
            assert c["result"] is None and c["error"], c
            checked += 1
    assert checked >= 14


# infinity reaches an operator as 3.4e38, finite: these sizes were taken and made a rotor with v0 = 2e38, a groove
# with an overcut of 3.5e37 or a cutter searched without subdivision
INFINITE_SIZES = {("flank.generate_rotor", "scale"): "outer radius", ("flank.generate_rotor", "lead"): "lead",
                  ("flank.generate_rotor", "length"): "length", ("flank.paraboloid_groove", "pitch"): "pitch p",
                  ("flank.formed_cutter", "eps_b"): "eps_b", ("flank.formed_cutter", "tolerance"): "tolerance"}


@pytest.mark.parametrize("op, prop", sorted(INFINITE_SIZES))
def test_infinite_sizes_are_refused_by_name(fuzz, op, prop):
    (c,) = [c for c in fuzz["calls"] if c["op"] == op and c.get("prop") == prop and c.get("value") == "inf"]
    assert c["result"] is None and INFINITE_SIZES[op, prop] in c["error"], c
    assert not c["traceback"] and not c["leaked"], c


def test_the_fuzz_run_stays_quick(fuzz):
    """No accepted call ran away with a huge size (each is bounded by a limit check)."""
    slow = [(c["op"], c.get("prop"), c.get("value"), round(c["seconds"], 1)) for c in fuzz["calls"]
            if c["seconds"] > 20.0]
    assert not slow, slow


def test_the_non_manifold_meshes_are_what_they_claim(fuzz):
    sub = fuzz["subjects"]
    assert sub["nm_fin"] == dict(vertices=5, faces=3)
    assert sub["nm_two_shells"] == dict(vertices=8, faces=8)
    assert sub["nm_rotor_two_shells"]["faces"] == 2 * sub["nm_rotor_unwelded"]["faces"]
    assert sub["nm_rotor_unwelded"]["vertices"] == 3 * sub["nm_rotor_unwelded"]["faces"]
    assert sub["nm_rotor_fin"]["faces"] == sub["nm_rotor_unwelded"]["faces"] + 1


@pytest.mark.parametrize("subject", NON_MANIFOLD)
def test_non_manifold_meshes_are_refused_by_every_mesh_planner(fuzz, subject):
    """An edge shared by 3 faces, two disjoint shells, duplicate vertices with zero-area faces: the analyzer,
    the rotor planners, Check Tool, the free-form planner and its preview refuse with a message."""
    seen = set()
    for c in _calls(fuzz, subject):
        if c["op"] in MESH_PLANNERS:
            seen.add(c["op"])
            assert c["result"] is None and c["error"] and len(c["error"].strip()) > 20, c
            assert not c["traceback"] and not c["leaked"], c
    assert seen == MESH_PLANNERS


@pytest.mark.parametrize("subject", NON_MANIFOLD + ROTOR_NON_MANIFOLD)
def test_the_free_form_planner_names_the_non_manifold_defect(fuzz, subject):
    for op in ("flank.plan_freeform", "flank.preview_guiding"):
        (c,) = _calls(fuzz, subject, op)
        assert c["result"] is None and FREEFORM_REASON[subject] in c["error"], c


def test_a_rotor_in_two_shells_is_refused_by_the_analyzer(fuzz):
    (c,) = _calls(fuzz, "nm_rotor_two_shells", "flank.analyze_rotor")
    assert c["result"] is None and c["error"] and len(c["error"].strip()) > 20, c


@pytest.mark.parametrize("subject", ["nm_rotor_fin", "nm_rotor_dup_zero", "nm_rotor_unwelded"])
def test_repairable_rotor_meshes_are_analyzed(fuzz, subject):
    """An STL-style unwelded rotor, duplicate vertices with zero-area faces, or one fin face: the analysis welds
    exact duplicates and drops collapsed faces (a warning says what; tests/test_rotor_analysis.py checks the
    helix equals the clean rotor's to 1e-9)."""
    (c,) = _calls(fuzz, subject, "flank.analyze_rotor")
    assert c["result"] == ["FINISHED"] and not c["traceback"], c


@pytest.mark.parametrize("subject", ROTOR_NON_MANIFOLD)
def test_non_manifold_rotor_meshes_never_show_a_traceback_or_leave_data(fuzz, subject):
    calls = _calls(fuzz, subject)
    assert len(calls) >= 20
    for c in calls:
        assert not c["traceback"] and not c["other"] and not c["leaked"], c
        if c["result"] is None and c["op"] in MESH_PLANNERS:
            assert len(c["error"].strip()) > 20, c


FF_EXPECT = {"L_eq_dr": "axis length L", "L_lt_dr": "axis length L", "L_0": "axis length L", "all_0": "axis length L",
             "r1_nan": "tip sphere radius r1 = nan", "r2_nan": "base sphere radius r2 = nan",
             "L_nan": "axis length L = nan", "r1_neg": "tip sphere radius r1 = -0.01", "r2_inf": "|r2 - r1|"}


@pytest.mark.parametrize("case", sorted(FF_EXPECT) + ["r1_r2_0"])
def test_degenerate_free_form_tools_are_refused(fuzz, case):
    (c,) = _calls(fuzz, "ff_tool", "flank.plan_freeform", case)
    assert c["result"] is None and c["error"].startswith("Error: Free-form:"), c
    assert not c["traceback"] and not c["leaked"], c
    if case in FF_EXPECT:
        assert FF_EXPECT[case] in c["error"], c


def test_a_free_form_tool_without_radius_is_refused_up_front_by_name(fuzz):
    (c,) = _calls(fuzz, "ff_tool", "flank.plan_freeform", "r1_r2_0")
    assert "r1" in c["error"] and "r2" in c["error"] and c["seconds"] < 0.1, c


GROOVE_EXPECT = {"a_0": "constant a must be negative", "a_b_0": "constant a must be negative",
                 "a_pos": "constant a must be negative", "a_nan": "constant a must be negative",
                 "b_0": "constant b must be positive", "b_neg": "constant b must be positive",
                 "b_nan": "constant b must be positive", "lens_gt_R": "equator radius 84.85",
                 "lens_eq_R": "equator radius 20", "R_0": "helix radius R = 0", "pitch_0": "pitch p > 0",
                 "b_inf": "equator radius", "a_minus_inf": ""}


@pytest.mark.parametrize("case", sorted(GROOVE_EXPECT))
def test_degenerate_paraboloid_tools_are_refused(fuzz, case):
    (c,) = _calls(fuzz, "groove_tool", "flank.paraboloid_groove", case)
    assert c["result"] is None and c["error"].startswith("Error: Paraboloid groove"), c
    assert not c["traceback"] and not c["leaked"], c
    assert GROOVE_EXPECT[case] in c["error"], c


def test_an_infinitely_flat_lens_is_refused_by_name(fuzz):
    (c,) = _calls(fuzz, "groove_tool", "flank.paraboloid_groove", "a_minus_inf")
    assert "ProfileError" not in c["error"] and "constant a" in c["error"], c


def test_a_tiny_but_valid_lens_is_planned(fuzz):
    """a = -1e6, b = 1e-9: a lens of radius 3e-8 is a real (if useless) tool: planned, not refused."""
    (c,) = _calls(fuzz, "groove_tool", "flank.paraboloid_groove", "tiny_lens")
    assert c["result"] == ["FINISHED"], c


def test_an_infinite_free_form_tolerance_is_refused(fuzz):
    """tolerance = inf is held as 3.4e38 by the float property (finite, > 0): refused by a bound on the surface's
    size, as the single-flank planner bounds it by half the outer radius."""
    (c,) = [c for c in fuzz["calls"] if c["op"] == "flank.plan_freeform" and c.get("prop") == "tolerance"
            and c.get("value") == "inf"]
    assert c["result"] is None and "tolerance" in c["error"], c
