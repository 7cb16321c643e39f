# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.plan_double_flank through the installed extension (Bizzarri & Bartoň 2021): nilson-male (symmetric: alpha = delta =
phi = 0, errors ~ 0), asymmetric-male (moved, rotated, scaled x2: the core's axis, deviations in scene
units), two cones, and bad input (nothing created)."""
import math

import pytest

from blender_harness import run_scenario

ROLES_ANIM = ["envelope", "error_chart", "motion", "moving", "tool"]


@pytest.fixture(scope="module")
def dfl(extension_zip, tmp_path_factory):
    return run_scenario(extension_zip, "double_flank", tmp_path_factory.mktemp("double_flank"))


# ------------------------------------------------------------------------------------------- nilson-male

def test_nilson_creates_collection_under_flank_results(dfl):
    n = dfl["nilson"]
    assert n["result"] == ["FINISHED"], n["error"]
    assert n["parents"] == ["Flank Results"] and n["parent_in_scene"]
    assert n["collection"].startswith("Double Flank (Rotor_nilson_male, valley 0)")
    assert sorted(n["roles"]) == ROLES_ANIM
    assert len(n["roles"]["envelope"]) == 2 and len(n["roles"]["tool"]) == 1
    # 6 objects (tool, 2 envelopes, chart, motion empty, moving tool), 4 meshes (the tools share one),
    # 2 collections (the new "Flank Results" and the run's), 1 action
    assert n["new"] == [6, 4, 2, 1]
    assert n["active"] == n["roles"]["tool"][0]
    assert "flank_df_summary" in n["coll_props"] and "flank_df_alpha" in n["rotor_props"]


def test_nilson_symmetric_axis_and_zero_errors(dfl):
    n = dfl["nilson"]
    p, c = n["props"], n["core"]
    assert p["flank_df_method"] == c["method"] == "double-flank-custom"
    # Prop. 3.1: the symmetry line is optimal
    for key in ("flank_df_alpha", "flank_df_delta", "flank_df_phi"):
        assert p[key] == pytest.approx([0.0], abs=1e-9), key
    assert [p["flank_df_alpha"][0], p["flank_df_delta"][0], p["flank_df_phi"][0]] == pytest.approx(c["x"][0], abs=1e-12)
    assert p["flank_df_iterations"] == c["iterations"]
    assert max(abs(v) for v in p["flank_df_tool_to_rotor_max"] + p["flank_df_tool_to_rotor_min"]) < 1e-9
    assert p["flank_df_length_scale"] == 1.0 and p["flank_df_length_unit"] == "R"
    assert p["flank_df_tolerance"] == pytest.approx(1e-3)        # 1e-3 x outer radius 1
    assert not p["flank_df_simulated"] and all(math.isnan(h) for h in p["flank_df_hausdorff"])
    assert p["flank_df_rim"] == 0.85 and p["flank_df_radii"] == 40 and p["flank_df_variant"] == "min"


def test_nilson_envelopes_match_the_core(dfl):
    strips = dfl["nilson"]["envelopes"]
    assert [(s["path"], s["flank"]) for s in strips] == [(0, 1), (0, 2)]
    for s in strips:
        assert s["domain"] == "POINT" and s["data_type"] == "FLOAT"
        assert s["vertices"] == s["core_vertices"] > 1000 and s["faces"] == s["core_faces"]
        assert s["dev_min"] == pytest.approx(s["core_min"], abs=1e-7)
        assert s["dev_max"] == pytest.approx(s["core_max"], abs=1e-7)
        assert abs(s["dev_max"]) < 1e-9 and abs(s["dev_min"]) < 1e-9      # exact on a symmetric valley
        assert s["max_abs_diff"] < 1e-7
        assert s["active_color"] == "error_color" and s["color_diff"] < 1e-6
        assert s["placement_diff"] < 1e-5


def test_nilson_tool_placement_and_chart(dfl):
    n = dfl["nilson"]
    (t,) = n["tools"]
    assert t["vertices"] == t["core_vertices"] and t["max_vertex_diff"] < 1e-5
    assert t["origin"] == pytest.approx(t["expect_origin"], abs=1e-6)
    assert t["axis_dot"] == pytest.approx(1.0, abs=1e-9) and t["object_scale"] == pytest.approx(1.0, abs=1e-6)
    (c,) = n["charts"]
    assert c["faces"] == 0 and c["edges"] > 0 and c["flanks"] == [0, 1, 2]
    assert c["max_abs"] == pytest.approx(c["core_max_abs"], abs=1e-9)
    assert c["offset_diff"] < 1e-4
    assert c["flank_vertices"][0] > 0 and c["flank_vertices"][1] > 0


def test_nilson_plan_file_and_tool_csv(dfl):
    n = dfl["nilson"]
    plan = n["plan"]
    assert plan["ok"], plan
    assert plan["method"] == "double-flank-custom" and plan["strips"] == 1 and plan["length_unit"] == "R"
    assert plan["to_world_diff"] < 1e-12 and plan["axis_start_diff"] < 1e-12
    assert n["props"]["flank_df_plan"].endswith("nilson_plan.json")
    csv = n["csv"]
    assert csv["header"] == "axial_position,radius" and csv["rows"] == csv["core_rows"] > 10
    # the CSV is the meridian decimated to <= 4000 rows: its largest radius within 1e-4 of the full one
    assert csv["r_max"] == pytest.approx(csv["core_r_max"], rel=1e-4) and csv["r_max"] <= csv["core_r_max"]


def test_nilson_animation_follows_the_screw(dfl):
    a = dfl["nilson"]["anim"]
    assert a["motions"] == 1 and a["movings"] == 1 and a["shares_mesh"]
    assert a["parent"][0] == "Rotor_nilson_male"
    assert a["fcurves"] == {"location[2]": {"keys": 2, "interpolation": ["LINEAR"]},
                            "rotation_euler[2]": {"keys": 2, "interpolation": ["LINEAR"]}}
    for smp in a["samples"]:
        assert smp["max_diff"] < 1e-4, smp


def test_nilson_again_from_the_tool(dfl):
    again = dfl["nilson"]["again"]
    assert again == {"result": ["FINISHED"], "error": None, "rotor": "Rotor_nilson_male",
                     "parents": ["Flank Results"]}


# ------------------------------------------------------------------------------------------- asymmetric-male

def test_asymmetric_axis_equals_the_core(dfl):
    a = dfl["asym"]
    assert a["result"] == ["FINISHED"], a["error"]
    assert sorted(a["roles"]) == ["envelope", "error_chart", "tool"]
    assert a["new"] == [4, 4, 1, 0]           # "Flank Results" exists already; no animation
    p, c = a["props"], a["core"]
    x = c["x"][0]
    assert p["flank_df_alpha"][0] == pytest.approx(x[0], abs=1e-12)
    assert p["flank_df_delta"][0] == pytest.approx(2.0 * x[1], abs=1e-12)     # scene units: object scale 2
    assert p["flank_df_phi"][0] == pytest.approx(x[2], abs=1e-12)
    assert p["flank_df_Phi"][0] == pytest.approx(2.0 * c["Phi"][0], abs=1e-12)
    assert p["flank_df_iterations"] == c["iterations"]
    assert abs(x[0]) > 1e-3 and abs(x[1]) > 1e-3 and abs(x[2]) > 1e-3   # asymmetric: off the reference line
    assert p["flank_df_tool_to_rotor_max"] == pytest.approx([2.0 * v[0] for v in c["tool_to_rotor"]], abs=1e-12)
    assert p["flank_df_length_scale"] == pytest.approx(2.0, rel=1e-6)
    assert p["flank_df_tolerance"] == pytest.approx(2e-3, rel=1e-6)
    assert p["flank_df_valley"] == 1


def test_asymmetric_deviation_in_scene_units(dfl):
    a = dfl["asym"]
    assert len(a["envelopes"]) == 2
    for s in a["envelopes"]:
        assert s["vertices"] == s["core_vertices"]
        assert s["dev_max"] == pytest.approx(s["core_max"], rel=1e-6, abs=1e-8)
        assert s["dev_min"] == pytest.approx(s["core_min"], rel=1e-6, abs=1e-8)
        assert s["core_max"] > 1e-4                                  # real errors on an asymmetric valley
        assert s["dev_min"] >= -1e-9                                # min radial function: never overcuts
        assert s["color_diff"] < 1e-6 and s["active_color"] == "error_color"
        assert s["placement_diff"] < 1e-4
    (t,) = a["tools"]
    assert t["max_vertex_diff"] < 1e-4
    assert t["origin"] == pytest.approx(t["expect_origin"], abs=1e-5)
    assert t["axis_dot"] == pytest.approx(1.0, abs=1e-6) and t["object_scale"] == pytest.approx(2.0, rel=1e-5)
    (c,) = a["charts"]
    assert c["max_abs"] == pytest.approx(c["core_max_abs"], rel=1e-6)
    assert c["offset_diff"] < 1e-4 and c["error_scale"] > 1.0


def test_asymmetric_plan_file_carries_the_placement(dfl):
    plan = dfl["asym"]["plan"]
    assert plan["ok"], plan
    assert plan["length_unit"] == "R" and plan["strips"] == 1
    assert plan["to_world_diff"] < 1e-6                     # float32 matrix_world, re-orthonormalised


def test_two_cones(dfl):
    c = dfl["cones"]
    assert c["result"] == ["FINISHED"], c["error"]
    assert c["props"]["flank_df_method"] == c["core"]["method"] == "double-flank-cones-2"
    assert len(c["roles"]["tool"]) == len(c["roles"]["moving"]) == len(c["roles"]["error_chart"]) == 2
    assert c["props"]["flank_df_paths"] == c["core"]["paths"] == 2
    assert len(c["props"]["flank_df_alpha"]) == len(c["core"]["x"]) == 3
    for got, want in zip(zip(c["props"]["flank_df_alpha"], c["props"]["flank_df_phi"]), c["core"]["x"]):
        assert got == pytest.approx((want[0], want[2]), abs=1e-12)
    for t in c["tools"]:
        assert t["max_vertex_diff"] < 1e-4 and t["axis_dot"] == pytest.approx(1.0, abs=1e-6)
    for s in c["envelopes"]:
        assert s["dev_max"] == pytest.approx(s["core_max"], rel=1e-6, abs=1e-8)
    assert c["csv_files"] == ["cones_1.csv", "cones_2.csv"]


# ------------------------------------------------------------------------------------------- bad input

@pytest.mark.parametrize("case,words", [
    ("valley_4", ["valley = 4", "0..3", "4 valleys"]),
    ("valley_neg", ["valley = -1", "0..3"]),
    ("rim_zero", ["rim = 0.0", "(0, 1]"]),
    ("rim_1_5", ["rim = 1.5", "(0, 1]"]),
    ("rim_nan", ["rim = nan", "(0, 1]"]),
    ("rim_0_1", ["rim 0.1", "0.2..0.98"]),
    ("radii_1", ["radii m = 1", "minimum 2"]),
    ("radii_big", ["m = 6000", "2..5000"]),
    ("cones_0", ["K = 0", "1..12"]),
    ("two_paths_cone", ["Two Paths needs Tool = Custom", "cone"]),
    ("frames", ["end frame 10", "start frame 10"]),
    ("plan_dir_missing", ["plan file", "no_such_dir/plan.json: the folder", "does not exist"]),
    ("cube", ["'Cube", "is not a rotor", "flank_source = None"]),
    ("empty", ["'Empty'", "EMPTY"]),
])
def test_bad_input_creates_nothing(dfl, case, words):
    bad = dfl["bad"][case]
    assert bad["result"] is None, bad
    for w in words:
        assert w in bad["error"], bad["error"]
    assert "Traceback" not in bad["error"]
    assert bad["new"] == [0, 0, 0, 0]
    if "results_collection" in bad:
        assert not bad["results_collection"]            # the parent collection is not left behind either
    if "rotor_props" in bad:
        assert bad["rotor_props"] == []


def test_panel_draws_double_flank_results(dfl):
    panels = dfl["panels"]
    for name, calls in panels.items():
        assert isinstance(calls, list), (name, calls)
    # a Strategy sub-panel: the tool shape is in the Tool panel, Run in the Run panel, two paths is a strategy
    calls = panels["FLANK_PT_double_flank"]
    for n in ("valley", "variant", "radii", "rim", "samples", "simulate", "tolerance", "envelope_rings", "animate",
              "frame_start", "frame_end", "filepath", "tool_csv"):
        assert ["prop", "df_" + n] in calls
    labels = [c[1] for c in calls if c[0] == "label"]
    assert any(lab.startswith("alpha +0.0000 deg, delta +0") for lab in labels), labels
    assert any(lab.startswith("Flank 1: error") for lab in labels), labels


# ------------------------------------------------------------------------------------------- analyzed mesh

def test_analyzed_mesh_is_planned_in_its_analysis_frame(dfl):
    assert dfl["analyzed_setup"]["result"] == ["FINISHED"] and dfl["analyzed_setup"]["source"] == "analyzed"
    a = dfl["analyzed"]
    assert a["result"] == ["FINISHED"], a["error"]
    assert a["new"] == [6, 4, 1, 1]
    p = a["props"]
    assert p["flank_df_source"] == "analyzed" and p["flank_df_length_unit"] == "mm"
    # a scene in metres: the plan is in millimetres, as its unit says (it held metres labelled mm before)
    mm = a["plan_mm"]
    assert mm["scene_unit"] == ["METRIC", 1.0] and mm["unit"] == "mm"
    assert p["flank_df_length_scale"] == 0.001
    assert mm["v0"] == pytest.approx(1000.0 * mm["scene_v0"], rel=1e-12)
    assert mm["outer_radius"] == pytest.approx(1000.0 * 1.0, rel=1e-4)     # the nilson male of R = 1 m
    # the analysed nilson profile is symmetric up to the analysis error: the axis stays on the symmetry line
    assert abs(p["flank_df_alpha"][0]) < 1e-4 and abs(p["flank_df_delta"][0]) < 1e-4
    assert abs(p["flank_df_phi"][0]) < 1e-2
    assert max(p["flank_df_tool_to_rotor_max"]) < 1e-5
    # the envelope (world) lies on the moved rotor's exact surface
    assert a["envelope_to_profile"]["max"] < 2e-4, a["envelope_to_profile"]
    # the motion's rotor frame is the analysis's to_world; the moving tool follows the screw about it
    assert a["motion_frame_vs_analysis"] < 1e-5 and a["moving_diff"] < 1e-4


def test_info_report_line_names_numbers_and_units(dfl):
    log = dfl["_log"]
    line = [ln for ln in log.splitlines() if ln.startswith("Info: Double flank Rotor_nilson_male valley 0")][0]
    for w in ("double-flank-custom", "alpha +0.00000 deg", "delta", "scene units", "phi +0.00000 deg", "Phi",
              "iterations", "tool->rotor max F1/F2", "not simulated", "optimisation", "wrote nilson_plan.json",
              "wrote nilson_tool.csv"):
        assert w in line, (w, line)
