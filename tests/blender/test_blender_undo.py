# SPDX-License-Identifier: GPL-3.0-or-later
"""Undo and redo of every data-changing flank.* operator (all declare REGISTER and UNDO; the tests call them and
undo).

One scenario (scenario_undo.py) runs every operator of the installed extension on a small scene, pushing undo
steps around it as the UI does, and records snapshots of the data before the run, after it, after ``ed.undo``
and after ``ed.redo``.  Every registered operator must be listed below, either as data-changing (it must
declare REGISTER + UNDO, change the snapshot, and undo / redo must restore it exactly) or as one that only
writes files (it must leave the snapshot exactly as it was)."""
import pytest

from blender_harness import run_scenario

# operator -> what it changes in the .blend (so an undo step is owed)
DATA_CHANGING = {
    "flank.generate_rotor": "adds the rotor object and its mesh",
    "flank.analyze_rotor": "writes curvature attributes on the mesh and flank_* properties on the object",
    "flank.refresh_flanks": "fills scene.flank_settings.flank_list and sets the flank index",
    "flank.pick_flank_cursor": "sets flank index, single-flank flank and double-flank valley settings",
    "flank.pick_flank_faces": "the same settings, picked from selected faces in Edit Mode",
    "flank.tool_preset": "sets the tool settings (sf_r1, sf_r2, sf_alpha, shank ...)",
    "flank.preview_tool": "adds (replaces) the tool preview object and mesh",
    "flank.plan_single_flank": "adds a result collection with strips, tools, chart, animation; rotor properties",
    "flank.plan_double_flank": "adds a result collection with tool, envelopes, chart, animation; rotor properties",
    "flank.cutter_region": "adds the admissible-region cloud and marker; flank_cr_* on the rotor",
    "flank.formed_cutter": "adds cutter, contact points, motion; deviation attributes on the rotor mesh",
    "flank.paraboloid_groove": "adds the groove collection, its meshes and the moving tool's action",
    "flank.verify_plan": "writes deviation attributes and flank_verify_* on the rotor, adds the Verify Tools",
    "flank.select_run": "changes the active object, the selection and the results list row",
    "flank.animate_strip": "adds the moving rotor copies, empties and action; hides the rotor",
    "flank.post_program": "adds the program path, its animation (rotor copy, tool, empties, actions) replacing "
                          "the run's earlier one, flank_prog_* on the run; writes the program file",
    "flank.check_program": "adds (replaces) the checked program's path object and mesh, flank_check_* on the run",
    "flank.error_plot": "adds a packed image with flank_plot_* properties",
    "flank.add_test_surface": "adds a test-surface object and mesh",
    "flank.pick_guiding_direction": "sets the free-form direction and point settings",
    "flank.preview_guiding": "adds (replaces) the guiding-curve preview object and curve",
    "flank.clear_guiding_preview": "removes the guiding-curve preview and switches the live preview off",
    "flank.plan_freeform": "adds a free-form result collection with strips, tools and boundaries",
}
# operator -> why it needs no undo step: it writes files only; the scenario checks the data stays unchanged
FILES_ONLY = {
    "flank.export_results": "writes plan / CL / CSV / STL / PLY files from the stored plan; no Blender data",
    "flank.render_report": "renders a PNG in a temporary scene that it removes again; no Blender data",
    "flank.tool_preset_add": "Blender's AddPresetBase: writes (or removes) a preset .py file in the user's "
                             "scripts folder; no Blender data",
}
# files each of them wrote in the scenario
WRITTEN = {"flank.export_results": "undo_run.apt", "flank.render_report": "undo_report.png",
           "flank.tool_preset_add": "Undo_Test_Tool.py"}


@pytest.fixture(scope="module")
def undo(extension_zip, tmp_path_factory):
    return run_scenario(extension_zip, "undo", tmp_path_factory.mktemp("undo"))


def _diff(a, b, path="", out=None, limit=15):
    """Paths where two snapshots differ (for the assertion messages)."""
    out = [] if out is None else out
    if len(out) >= limit:
        return out
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            if key not in a:
                out.append("{}/{}: added".format(path, key))
            elif key not in b:
                out.append("{}/{}: removed".format(path, key))
            else:
                _diff(a[key], b[key], "{}/{}".format(path, key), out, limit)
    elif a != b:
        out.append("{}: {!r:.120} -> {!r:.120}".format(path, a, b))
    return out


def _step(undo, op):
    step = undo["steps"].get(op)
    assert step is not None, "the scenario did not run {}".format(op)
    return step


# ------------------------------------------------------------------------------------------- classification

def test_every_registered_operator_is_classified(undo):
    ops = set(undo["operators"])
    assert not set(DATA_CHANGING) & set(FILES_ONLY)
    assert ops - set(DATA_CHANGING) - set(FILES_ONLY) == set(), "operators nobody classified for undo"
    assert set(DATA_CHANGING) | set(FILES_ONLY) <= ops, "classified operators that are not registered"


@pytest.mark.parametrize("op", sorted(DATA_CHANGING))
def test_data_changing_operator_declares_register_and_undo(undo, op):
    opts = undo["bl_options"].get(op)
    assert opts is not None, "no FLANK_OT_ class found for {}".format(op)
    assert "UNDO" in opts and "REGISTER" in opts, "{}: bl_options = {} ({})".format(op, opts, DATA_CHANGING[op])


# ------------------------------------------------------------------------------------------- undo / redo

@pytest.mark.parametrize("op", sorted(DATA_CHANGING))
def test_operator_runs_and_changes_data(undo, op):
    s = _step(undo, op)
    assert s["result"] == ["FINISHED"], s["error"]
    assert s["after_run"] != s["before"], "{} changed nothing the snapshot holds (expected: {})".format(
        op, DATA_CHANGING[op])


@pytest.mark.parametrize("op", sorted(DATA_CHANGING))
def test_undo_restores_the_data_before_the_run(undo, op):
    s = _step(undo, op)
    assert s["result"] == ["FINISHED"], s["error"]
    assert s["after_undo_error"] is None, s["after_undo_error"]
    if s["after_undo"] != s["before"] and op == "flank.pick_flank_faces":
        c = undo["edit_mode_control"]
        if c["mode"] == "EDIT_MESH" and c["after_undo"] == c["after_set"] != c["before"]:
            pytest.xfail("Blender limitation, not this operator: in Edit Mode the undo steps are mesh steps, so a "
                         "scene-setting change is not undone -- the same flank_index change typed in Edit Mode "
                         "without any operator stayed {} after undo (was {}). Undo leaves: {}".format(
                             c["after_undo"], c["before"], _diff(s["before"], s["after_undo"])))
    assert s["after_undo"] == s["before"], "undo of {} left: {}".format(op, _diff(s["before"], s["after_undo"]))


@pytest.mark.parametrize("op", sorted(DATA_CHANGING))
def test_redo_restores_the_data_after_the_run(undo, op):
    s = _step(undo, op)
    assert s["result"] == ["FINISHED"], s["error"]
    assert s["after_redo_error"] is None, s["after_redo_error"]
    assert s["after_redo"] == s["after_run"], "redo of {} differs: {}".format(
        op, _diff(s["after_run"], s["after_redo"]))


# ------------------------------------------------------------------------------------------- files only

@pytest.mark.parametrize("op", sorted(FILES_ONLY))
def test_file_writing_operator_leaves_the_data_unchanged(undo, op):
    s = _step(undo, op)
    assert s["result"] == ["FINISHED"], s["error"]
    assert s["after_run"] == s["before"], "{} ({}) changed: {}".format(
        op, FILES_ONLY[op], _diff(s["before"], s["after_run"]))
    assert WRITTEN[op] in undo["files"] + undo["user_presets"], "{} wrote no {}".format(op, WRITTEN[op])


def test_the_scenario_is_quick(undo):
    assert undo["timing"]["total"] < 120.0, undo["timing"]
