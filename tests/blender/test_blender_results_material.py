# SPDX-License-Identifier: GPL-3.0-or-later
"""result strips carry ``deviation`` / ``error_color`` and one shared material that shows the colour in
Material Preview / Rendered / Cycles; one collection per run under "Flank Results", a re-run replaces that run
and leaves no orphan data (single flank, double flank, free-form, formed cutter, paraboloid groove)."""
import pytest

from blender_harness import run_scenario

MATERIAL = "Flank Attribute Colour"
PLANNERS = ("single", "double", "freeform", "formed_active", "formed_table1", "groove")


@pytest.fixture(scope="module")
def mat(extension_zip, tmp_path_factory):
    return run_scenario(extension_zip, "results_material", tmp_path_factory.mktemp("results_material"))


def test_material_node_tree_feeds_the_colour_attribute_into_the_shader(mat):
    m = mat["material"]
    assert m is not None and m["name"] == MATERIAL and m["marked"] == [MATERIAL]
    nodes = {n["type"]: n for n in m["tree"]["nodes"]}
    assert nodes["ShaderNodeVertexColor"]["layer_name"] == ""          # no name: the render colour attribute
    links = m["tree"]["links"]
    assert ["ShaderNodeVertexColor", "Color", "ShaderNodeBsdfPrincipled", "Base Color"] in links
    assert ["ShaderNodeBsdfPrincipled", "BSDF", "ShaderNodeOutputMaterial", "Surface"] in links


@pytest.mark.parametrize("planner", PLANNERS)
def test_every_run_succeeds_and_is_fast(mat, planner):
    for call in mat[planner]["calls"]:
        assert call["result"] == ["FINISHED"], call["error"]
        assert call["seconds"] < 60.0, call


@pytest.mark.parametrize("planner", PLANNERS)
def test_rerun_replaces_the_run_without_orphans(mat, planner):
    p = mat[planner]
    # the census of bpy.data is the same after the 2nd and the 3rd run: the earlier run is fully replaced
    assert p["census"][1] == p["census"][2], p["census"]
    assert p["census"][0] == p["census"][1], p["census"]
    runs = p["runs"]
    assert [len(r) for r in runs] == [1, 1, 1], runs          # exactly one collection for this key
    assert runs[0] == runs[1] == runs[2]                          # same name and key every time
    assert p["parents"] == ["Flank Results"]
    assert p["zero_user_materials"] == []


@pytest.mark.parametrize("planner,names", [
    ("single", ["Single Flank (Rotor_asymmetric_female, flank 1)"]),
    ("double", ["Double Flank (Rotor_nilson_male, valley 0)"]),
    ("freeform", ["Free-form (Parabolic Blade)"]),
    ("formed_active", ["Formed Cutter (Rotor_srm_a_male)"]),
    ("formed_table1", ["Formed Cutter (Arc Tooth Rotor (Hu, Zhou & Li 2025))"]),
    ("groove", ["Paraboloid Groove"]),
])
def test_run_collection_names(mat, planner, names):
    assert [r["name"] for r in mat[planner]["runs"][-1]] == names


@pytest.mark.parametrize("planner,roles", [
    ("single", {"envelope", "error_chart"}),
    ("double", {"envelope", "error_chart"}),
    ("freeform", {"envelope"}),
])
def test_strips_carry_attributes_and_the_shared_material(mat, planner, roles):
    state = mat[planner]["state"]
    strips = [s for s in state if s["role"] == "envelope"]
    assert strips
    for s in strips:
        assert s["deviation"] and "error_color" in s["colors"] and s["render_color"] == "error_color", s
    coloured = [s for s in state if s["role"] in roles]
    assert {s["role"] for s in coloured} == roles
    for s in coloured:
        assert s["materials"] == [MATERIAL], s
        assert s["pointer"] == mat["material"]["pointer"], s        # one datablock shared by all runs
    # tools and other objects without colour attributes keep no material
    for s in state:
        if not s["colors"]:
            assert s["materials"] == [], s


def test_material_is_the_same_datablock_across_runs_and_planners(mat):
    assert mat["shared"] == [MATERIAL]
    ptr = mat["material"]["pointer"]
    for planner in ("single", "double", "freeform"):
        assert set(mat[planner]["first_pointers"]) - {None} == {ptr}
    assert mat["material_users_all"] > 0


def test_formed_cutter_and_groove_colour_objects_get_the_material(mat):
    for planner, name in (("formed_active", "Formed Cutter"), ("formed_table1", "Formed Cutter"),
                          ("groove", "Overcut Band")):
        # (two formed-cutter runs hold objects of the same names: the later one's get a suffix)
        by_name = {s["name"].split(".")[0]: s for s in mat[planner]["state"]}
        assert by_name[name]["materials"] == [MATERIAL], by_name[name]
    t1 = {s["name"]: s for s in mat["formed_table1"]["state"]}
    assert t1["Arc Tooth Rotor (Hu, Zhou & Li 2025)"]["materials"] == [MATERIAL]     # the rotor built in the run
    assert mat["formed_active"]["rotor_materials"] == [MATERIAL]        # the user's rotor had none


def test_runs_live_under_flank_results_not_at_the_top(mat):
    assert sorted(mat["all_runs"]) == sorted(n for p in PLANNERS for n in [r["name"] for r in mat[p]["runs"][-1]])
    assert mat["scene_children"] == ["Collection", "Flank Results"]
    assert mat["solid_switched"] == 0                                  # background: no viewport to switch


def test_removing_every_run_leaves_no_zero_user_material(mat):
    a = mat["after_remove"]
    assert a["zero_user_materials"] == [] and a["orphan_meshes"] == 0 and a["orphan_actions"] == 0
    assert a["marked"] == [MATERIAL]       # still used by the user's rotor the formed cutter painted
    r = mat["after_release"]
    assert r["marked"] == [] and r["zero_user_materials"] == []


def test_failed_run_leaves_nothing_behind(mat):
    f = mat["failed"]
    assert f["result"] is None and "Traceback" not in f["error"]
    assert "Could not build the single-flank results" in f["error"], f["error"]
    assert f["after"] == f["before"] and f["zero_user_materials"] == []


def test_undo_removes_the_run_and_its_material(mat):
    u = mat["undo"]
    assert u["result"] == ["FINISHED"], u["error"]
    assert u["after_run"]["materials"] == u["before"]["materials"] + 1
    assert u["after_undo"] == u["before"]
    assert u["marked"] == [] and u["zero_user_materials"] == []
