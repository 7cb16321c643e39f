# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.export_results and flank.animate_strip through the installed extension (scenario_export_animate.py):
the files equal the core writers' output on the run's stored plan, and the moving rotor follows the screw
motion S_t exactly while the tool stays put."""
import pytest

from blender_harness import run_scenario


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
    assert x["csv"]["equal"] is True and x["csv"]["rows"] > 100 and x["csv"]["header"] == "index,x,y,deviation"
    assert x["stl"]["faces"] == x["stl"]["core_faces"] > 0
    assert x["stl"]["max_diff"] < 1e-5                      # binary STL stores float32
    assert x["ply"]["files"] == ["all_{}.ply".format(k) for k in range(ea["run"]["strips"])]


def test_bad_exports_write_nothing(ea):
    x = ea["export"]
    assert x["bad_strip"]["result"] is None and "strip = 99 does not exist" in x["bad_strip"]["error"]
    assert not x["bad_strip"]["file"]
    assert x["bad_dir"]["result"] is None and "does not exist" in x["bad_dir"]["error"]
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
