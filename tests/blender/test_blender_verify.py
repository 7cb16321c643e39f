# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.verify_plan through the installed extension: deviation attributes vs the planner's own verify."""
import pytest

from blender_harness import run_scenario

UNTOUCHED = 1e9
F32 = 1e-6  # attribute values are float32


@pytest.fixture(scope="module")
def ver(extension_zip, tmp_path_factory):
    return run_scenario(extension_zip, "verify", tmp_path_factory.mktemp("verify"))


def test_verify_writes_deviation_and_colour_attributes(ver):
    v = ver["verify"]
    assert ver["generate"]["result"] == ["FINISHED"]
    assert v["result"] == ["FINISHED"], v["error"]
    assert {"machined_deviation", "machined_deviation_color"} <= set(v["attributes"])
    assert v["active_color"] == "machined_deviation_color"
    assert v["vertices"] == ver["generate"]["vertices"]


def test_verify_values_equal_direct_simulation_per_vertex(ver):
    v, d = ver["verify"], ver["plan"]["direct"]
    # every side vertex carries the deviation of its own profile point (the plan shares the mesh's samples)
    assert v["max_abs_diff"] is not None and v["max_abs_diff"] < F32, v["max_abs_diff"]
    assert v["untouched_match"] and v["extra_vertices_untouched"]  # cap centres: off the surface
    assert v["reached"] == v["expected_reached"] > 0
    assert abs(v["min"] - d["max_overcut"]) < F32


def test_verify_gouge_depth_and_red_colour(ver):
    v, plan = ver["verify"], ver["plan"]
    depth = plan["depth"]
    # the ball cuts `depth` into flank 0 where its normal is radial: deviation ~ -depth there
    assert abs(plan["direct"]["dev_gouge"] + depth) < 0.02 * depth, plan["direct"]
    assert abs(v["min"] + depth) < 0.02 * depth, v["min"]
    assert v["min_vertex_red"]
    assert v["gouge_vertices"] > 0 and v["red_vertices"] == v["gouge_vertices"]


def test_verify_stock_blue_and_untouched_grey(ver):
    v, plan = ver["verify"], ver["plan"]
    assert plan["direct"]["dev_stock"] > plan["direct"]["tolerance"]  # the second ball leaves material
    assert v["stock_vertices"] > 0 and v["blue_vertices"] == v["stock_vertices"]
    assert v["grey_is_untouched"] and v["grey_vertices"] > v["reached"]  # two balls touch little of the rotor
    assert 0 < v["max_stock"] < 0.1 * 1.0  # within the default search range (0.1 x outer radius)


def test_verify_summary_properties(ver):
    p, d = ver["verify"]["props"], ver["plan"]["direct"]
    assert p["flank_verify_plan"] == ver["plan"]["path"]
    assert p["flank_verify_unit"] == "R"
    assert abs(p["flank_verify_max_overcut"] - d["max_overcut"]) < 1e-12
    assert abs(p["flank_verify_max_undercut"] - d["max_undercut"]) < 1e-12
    assert p["flank_verify_gouges"] == d["gouges"] > 0
    assert abs(p["flank_verify_tolerance"] - d["tolerance"]) < 1e-15 and abs(d["tolerance"] - 1e-3) < 1e-9
    assert 0 < p["flank_verify_elapsed"] < 30
    assert p["flank_verify_reached"] == ver["verify"]["reached"]
    assert p["flank_verify_off_surface"] == 2  # the two end-cap centre vertices


def test_verify_uses_world_coordinates_and_rotor_to_world(ver):
    m = ver["moved"]
    assert m["result"] == ["FINISHED"], m["error"]
    assert m["max_abs_diff"] < F32 and m["reached"] == ver["verify"]["reached"]


def test_verify_refuses_mesh_not_on_plan_rotor(ver):
    mm = ver["mismatch"]
    assert mm["result"] is None and "does not lie on the plan's rotor" in mm["error"], mm
    assert mm["props_kept"] and mm["values_kept"]


def test_verify_tool_objects_and_explicit_tolerance(ver):
    t = ver["tools"]
    assert t["result"] == ["FINISHED"], t["error"]
    assert t["tolerance"] == 0.005  # the typed decimal, not its float32 neighbour
    assert t["new_objects"] == 3 and sorted(t["tools"]) == ["Strip000_cutter", "Strip001_cutter", "Strip001_shank"]
    ball = t["tools"]["Strip000_cutter"]
    assert all(abs(e - 0.06) < 1e-3 for e in ball["extent"]), ball
    assert all(abs(c - b) < 1e-3 for c, b in zip(ball["centre"], t["ball_centre"])), (ball, t["ball_centre"])
    assert t["active_object"] == t["rotor"]


def test_verify_refuses_edit_mode(ver):
    em = ver["edit_mode"]
    assert em["result"] is None and "Object Mode" in em["error"]


@pytest.mark.parametrize("case,words", [
    ("negative_v0", ["rotor.v0", "> 0"]),
    ("not_json", ["not valid JSON"]),
    ("wrong_schema", ["schema", "flank-plan/1"]),
    ("missing", ["not found"]),
])
def test_bad_plan_file_is_refused_and_changes_nothing(ver, case, words):
    bad = ver["bad"][case]
    assert bad["result"] is None, bad
    for w in words:
        assert w in bad["error"], bad["error"]
    assert "Traceback" not in bad["error"]
    assert "machined_deviation" not in bad["attributes"] and "machined_deviation_color" not in bad["attributes"]
    assert bad["props"] == {} and bad["new_objects"] == 0 and bad["new_meshes"] == 0


def test_panels_draw_verify_results(ver):
    panels = ver["panels"]
    for name, calls in panels.items():
        assert isinstance(calls, list), (name, calls)  # no exception in draw()
    calls = panels["FLANK_PT_verify"]
    assert ["operator", "flank.verify_plan"] in calls
    assert ["prop", "verify_filepath"] in calls and ["prop", "verify_tolerance"] in calls
    labels = [c[1] for c in calls if c[0] == "label"]
    assert any(t.startswith("Max overcut: -0.01005 R") for t in labels), labels
    assert any(t.startswith("Gouge points: ") for t in labels), labels
