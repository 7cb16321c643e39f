# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.export_results and flank.animate_strip through the installed extension (scenario_export_animate.py):
the files equal the core writers' output on the run's stored plan, and the moving rotor follows the screw
motion S_t exactly while the tool stays put."""
import pytest

from blender_harness import assert_plans_kept, run_scenario


@pytest.fixture(scope="module")
def ea(extension_zip, tmp_path_factory):
    return run_scenario(extension_zip, "export_animate", tmp_path_factory.mktemp("export_animate"))


def test_nothing_to_export_or_animate_before_a_run(ea):
    assert ea["no_run"]["result"] is None and "no planning run" in ea["no_run"]["error"]
    assert not ea["no_run"]["file"]
    assert ea["no_run_anim"]["result"] is None and "no planning run" in ea["no_run_anim"]["error"]


def test_the_run_keeps_its_plan(ea):
    assert ea["plan"]["result"] == ["FINISHED"], ea["plan"]["error"]
    r = ea["run"]
    assert r["valid"] and r["strips"] == r["sf_strips"] >= 2


def test_exports_equal_the_core_writers(ea):
    x = ea["export"]
    for key in ("plan", "cl", "cl_strip1", "csv", "stl", "ply"):
        assert x[key]["result"] == ["FINISHED"], (key, x[key]["error"])
    assert x["plan"]["equal"] is True
    assert x["cl"]["equal"] is True and x["cl"]["gotos"] == x["cl"]["core_gotos"] == 41 * ea["run"]["strips"]
    assert x["cl"]["first"].startswith("GOTO/")
    assert x["cl_strip1"]["equal"] is True
    print("csv text equal:", x["csv"].get("text_equal"), x["csv"].get("differing_lines"), x["csv"].get("first_difference"))
    assert x["csv"]["equal"] is True and x["csv"]["rows"] > 100 and x["csv"]["header"] == "index,x,y,deviation"
    assert x["stl"]["faces"] == x["stl"]["core_faces"] > 0
    assert x["stl"]["max_diff"] < 1e-5                      # binary STL stores float32
    assert x["ply"]["files"] == ["all_{}.ply".format(k) for k in range(ea["run"]["strips"])]


def test_bad_exports_write_nothing(ea):
    x = ea["export"]
    assert x["bad_strip"]["result"] is None and "strip = 99 does not exist" in x["bad_strip"]["error"]
    assert not x["bad_strip"]["file"]
    assert x["bad_dir"]["result"] is None and "does not exist" in x["bad_dir"]["error"]
    assert x["is_dir"]["result"] is None and "is a folder: give a file name" in x["is_dir"]["error"]
    assert x["relative"]["result"] is None and "is a relative path" in x["relative"]["error"], x["relative"]
    assert not x["relative"]["file"]
    assert "Traceback" not in x["is_dir"]["error"] and "IsADirectoryError" not in x["is_dir"]["error"]
    assert x["leftovers"] == []


def test_animation_screws_the_rotor_past_the_fixed_tool(ea):
    a = ea["animate"]
    assert a["result"] == ["FINISHED"], a["error"]
    assert a["time"][0] < a["time"][1]
    assert max(a["diffs"]) < 1e-5 * a["scale"]                # Blender matrices are single precision
    assert a["tool_moved"] == 0.0
    assert a["rotor_hidden"] and a["shares_mesh"]
    # frame + motion empties, the moving rotor and strip (linked copies: no new mesh), one action
    assert a["new"] == {"objects": 4, "meshes": 0, "actions": 1, "collections": 0}
    assert ea["bl_options"] == ["REGISTER", "UNDO"]


def test_reanimating_replaces_and_leaves_no_orphans(ea):
    r = ea["reanimate"]
    assert r["result"] == ["FINISHED"], r["error"]
    assert r["new"] == {"objects": 0, "meshes": 0, "actions": 0, "collections": 0}
    assert r["orphan_actions"] == 0


@pytest.mark.parametrize("name, words", [("strip_0", "strip = 0 does not exist"),
                                         ("strip_99", "strip = 99 does not exist"),
                                         ("frames", "must be after the start frame"),
                                         ("no_coll", "no collection 'Nope'")])
def test_bad_animation_input_creates_nothing(ea, name, words):
    b = ea["animate_bad"][name]
    assert b["result"] is None and words in b["error"]
    assert b["new"] == {"objects": 0, "meshes": 0, "actions": 0, "collections": 0}


def test_render_report_writes_the_png_and_leaves_nothing(ea):
    r = ea["report"]
    assert r["result"] == ["FINISHED"], r["error"]
    assert r["shape"] == [400, 640, 4]
    assert all(n >= 144 for n in r["swatches"].values()), r["swatches"]
    assert all(v == 0 for v in r["new"].values()), r["new"]
    assert r["bad_dir"]["result"] is None and "does not exist" in r["bad_dir"]["error"]


def test_results_panel_list_and_legend(ea):
    ui = ea["ui"]
    panels = ui["panels"]
    assert all(isinstance(v, list) for v in panels.values()), panels
    res = panels["FLANK_PT_results"]
    lists = [c for c in res if c[0] == "template_list"]
    assert lists and lists[0][1] == "FLANK_UL_strips" and lists[0][2] == ea["run"]["name"]
    assert ["prop", "legend_gouge"] in res and ["prop", "legend_ok"] in res and ["prop", "legend_stock"] in res
    assert {"flank.animate_strip", "flank.export_results", "flank.render_report"} <= \
        {c[1] for c in res if c[0] == "operator"}
    # the Tool Presets menu is in the Tool panel (test_blender_sidebar.py)
    assert ui["legend_diff"] < 1e-6                       # the swatches are verify.DEVIATION_COLORS
    assert ui["list_rows"] == ea["run"]["strips"]
    # picking strip 2's row selects its tool and envelope and makes the tool active
    assert ui["selected"] == ["SF F1 Strip 2", "SF F1 Tool 2"] and ui["active"] == "SF F1 Tool 2"


def test_tool_presets_are_real_end_mills_in_mm(ea):
    import math

    ui = ea["ui"]
    assert len(ui["shipped"]) >= 8
    assert ui["preset_result"] == ["FINISHED"]
    shape, alpha, r1, r2, shank_r, shank_l = ui["tool_settings"]
    # scene in mm: tip D6 -> r1 = 3, r2 = 3 + 30 tan 3 deg, shank D10 -> 5, 80 - 30 = 50
    assert shape == "alpha" and alpha == pytest.approx(math.radians(3.0), rel=1e-6)
    assert (r1, r2, shank_r, shank_l) == pytest.approx((3.0, 3.0 + 30.0 * math.tan(math.radians(3.0)), 5.0, 50.0),
                                                       rel=1e-6)
    assert ui["tool_settings_cm"] == pytest.approx([0.3, (3.0 + 30.0 * math.tan(math.radians(3.0))) / 10, 0.5],
                                                   rel=1e-6)
    assert ui["bad_preset"]["result"] is None and "taper = 60" in ui["bad_preset"]["error"]


def test_the_kept_plans_are_the_stored_ones(ea):
    """Operators read a run's plan from the one the extension keeps parsed: after all of them ran, each kept plan
    is still its run's stored text parsed again, number for number (none of them changed the shared plan)."""
    assert_plans_kept(ea["plans_kept"])


def test_a_runs_plan_is_parsed_once_per_stored_text(ea):
    """The planner's worker parses its plan once more for the run; later reads share it while the stored text is
    the same, and a changed text is read afresh."""
    c = ea["plan_cache"]
    assert c["kept_at_build"] and c["read_the_kept"] and c["shared"] and c["equal"], c
    assert c["changed"] == 123.25 and c["restored"] == c["stored"] != 123.25, c
