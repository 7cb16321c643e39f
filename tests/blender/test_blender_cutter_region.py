# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.cutter_region through the installed extension (Bizzarri, Bo & Bartoň §4): the admissible-cone cloud and the tool marker
against the core run in the same process (built-in asymmetric female, flank 1, default (24, 40, 40) grid);
flank and cone from the Single Flank settings; a too-large cone is a WARNING with the core's message; object
scale; bad input creates nothing."""
import math

import pytest

from blender_harness import run_scenario


@pytest.fixture(scope="module")
def cr(extension_zip, tmp_path_factory):
    out = run_scenario(extension_zip, "cutter_region", tmp_path_factory.mktemp("cutter_region"))
    out["cutter_region"]["panels"] = out["panels"]
    return out["cutter_region"]


def test_cloud_holds_exactly_the_core_admissible_grid_cones(cr):
    h = cr["small"]
    assert h["result"] == ["FINISHED"], h["error"]
    assert h["new"] == [2, 2, 2, 0]                      # cloud + marker; their collection + "Flank Results"
    assert h["cloud"] == "Cutter Region (flank 1)" and h["marker"] == "Cutter Region (flank 1) Tool"
    assert h["collection"] == "Cutter Region ({}, flank 1)".format(cr["rotor"])
    assert h["parent"] == ["Flank Results"]
    assert {"admissible", "failed", "admissible_color"} <= set(h["attrs"])
    assert h["n_edges"] == 0 and h["n_faces"] == 0          # a point cloud
    assert cr["core_mask_sum"] > 0
    assert h["flag_sum"] == cr["core_mask_sum"] == h["props"]["flank_cr_admissible_points"]
    assert h["flag_values"] == [0.0, 1.0]
    assert h["green"] == h["flag_sum"] and h["red"] == h["n_points"] - h["flag_sum"]
    assert cr["core_mask_sum"] < h["n_points"] <= cr["core_mask_sum"] + 3000      # + a sample of the others
    assert h["decoded_max_diff"] is not False and h["decoded_max_diff"] < 1e-5    # chart mapping -> core points
    assert h["bits_of_admissible"] == [0] and h["zero_bits_of_other"] == 0
    assert h["props"]["flank_cr_grid"] == [24, 40, 40]


def test_flank_and_cone_default_to_the_single_flank_settings(cr):
    p = cr["small"]["props"]
    assert p["flank_cr_flank"] == 1
    assert p["flank_cr_tool"] == pytest.approx([0.1, 0.02, 0.04], abs=1e-7)
    h = cr["by_length"]                      # Cone Given By = Length: alpha = atan((r2 - r1) / h), flank 2
    assert h["result"] == ["FINISHED"], h["error"]
    assert h["props"]["flank_cr_flank"] == 2 and h["new"] == [2, 2, 1, 0]
    assert h["props"]["flank_cr_tool"][0] == pytest.approx(h["expected_alpha"], abs=1e-6)
    assert h["props"]["flank_cr_admissible"] == h["core_ok"]


def test_summary_properties_against_the_core(cr):
    p = cr["small"]["props"]
    assert p["flank_cr_hyperbolic_fraction"] == pytest.approx(cr["core_hyperbolic_fraction"])
    assert p["flank_cr_a_min"] == pytest.approx(cr["core_a_min"])
    b = cr["core_bounds"]
    for key in ("d_min", "d_max", "d_depth"):
        assert p["flank_cr_" + key] == pytest.approx(b[key])
    rng = cr["core_ranges"]
    assert p["flank_cr_ranges"] == pytest.approx(rng["alpha"] + rng["r1c"] + rng["r2c"])
    assert p["flank_cr_chart_scale"][0] == pytest.approx(p["flank_cr_chart_size"] / (math.pi / 4))
    assert p["flank_cr_catalogue_unit"].startswith("R (outer radius 1000 mm)")   # 1 m per scene unit
    assert p["flank_cr_suggested"] and len(p["flank_cr_suggested_tool"]) == 3
    for target in ("marker_props", "coll_props", "rotor_props"):
        assert cr["small"][target]["flank_cr_admissible_points"] == p["flank_cr_admissible_points"]


def test_marker_agrees_with_the_core(cr):
    h = cr["small"]
    assert h["core_ok"] and h["props"]["flank_cr_admissible"]
    assert h["marker_flags"] == [1.0] and h["marker_color"] == pytest.approx([0.15, 0.75, 0.25, 1.0])
    assert h["props"]["flank_cr_report_level"] == "INFO"
    assert "tool inside the admissible region" in h["props"]["flank_cr_report"]
    assert h["props"]["flank_cr_message"] == h["core_message"]
    # marker at the documented chart position of (alpha, r1c, r2c)
    sc = h["props"]["flank_cr_chart_scale"]
    assert h["marker_centre"] == pytest.approx([0.1 * sc[0], 0.02 * sc[1], 0.04 * sc[2]], abs=1e-5)
    assert h["cloud_location"] == pytest.approx(h["props"]["flank_cr_chart_origin"])


def test_too_large_tool_is_a_warning_with_the_core_message(cr):
    h = cr["large"]
    assert h["result"] == ["FINISHED"], h["error"]
    assert not h["core_ok"] and not h["props"]["flank_cr_admissible"]
    assert h["props"]["flank_cr_message"] == h["core_message"]
    assert h["props"]["flank_cr_report_level"] == "WARNING"
    assert h["core_message"] in h["props"]["flank_cr_report"]
    assert "Eq. (19)" in h["core_message"] and "r2c = 0.5 > c D_max" in h["core_message"]
    assert h["marker_flags"] == [0.0] and h["marker_color"] == pytest.approx([0.85, 0.15, 0.10, 1.0])
    assert h["new"] == [0, 0, 0, 0]                  # same rotor and flank: the earlier check is replaced
    assert h["cloud"] == "Cutter Region (flank 1)" and h["flag_sum"] == cr["core_mask_sum"]


def test_object_scale_divides_the_scene_units(cr):
    h = cr["scaled"]
    assert h["result"] == ["FINISHED"], h["error"]
    p = h["props"]
    assert p["flank_cr_length_scale"] == pytest.approx(2.0)
    assert p["flank_cr_admissible"] == h["core_ok"] and p["flank_cr_message"] == h["core_message"]
    assert h["flag_sum"] == cr["core_mask_sum"] and h["decoded_max_diff"] < 1e-5
    assert p["flank_cr_d_depth"] == pytest.approx(2.0 * cr["core_bounds"]["d_depth"])
    assert p["flank_cr_chart_size"] == pytest.approx(2.0)


@pytest.mark.parametrize("name, text", [("bad_radii", "r1 = 0.08 and r2 = 0.05: r1 must be below r2"),
                                        ("bad_flank", "flank = 99 is outside 0..11"),
                                        ("bad_alpha", "is outside (0, 90) deg"),
                                        ("bad_grid", "grid [1, 40, 40]")])
def test_bad_input_reports_and_creates_nothing(cr, name, text):
    h = cr[name]
    assert h["result"] is None and text in h["error"], h["error"]
    assert h["new"] == [0, 0, 0, 0]
    assert h["rotor_props_unchanged"]


def test_single_flank_panel_has_the_check_tool_button(cr):
    calls = cr["panels"]["FLANK_PT_single_flank"]
    assert isinstance(calls, list), calls      # "Check Tool" is in the Tool panel (test_blender_sidebar.py)


def test_undo_removes_and_redo_restores_the_check(cr):
    u = cr["undo"]
    assert u["bl_options"] == ["REGISTER", "UNDO"]
    assert u["result"] == ["FINISHED"], u["error"]
    assert "Cutter Region (flank 3)" in u["after_run"]["objects"]
    assert u["after_undo"] == u["before"]
    assert u["after_redo"] == u["after_run"]
    assert {"admissible", "failed", "admissible_color"} <= set(u["redo_attrs"])
