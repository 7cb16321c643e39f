# SPDX-License-Identifier: GPL-3.0-or-later
"""Install the zip with Blender's installer, then disable/enable it 5x: nothing may leak."""
import os

import pytest

from blender_harness import run_scenario


@pytest.fixture(scope="module")
def lifecycle(extension_zip, tmp_path_factory):
    return run_scenario(extension_zip, "lifecycle", tmp_path_factory.mktemp("lifecycle"))


def test_runs_in_background_with_isolated_user_dir(lifecycle):
    assert lifecycle["background"] is True
    user = lifecycle["_user_dir"]
    ext_dir = lifecycle["install"]["extensions_dir"]
    assert os.path.commonpath([user, ext_dir]) == user, (user, ext_dir)
    assert os.path.isfile(os.path.join(lifecycle["install"]["installed_dir"], "blender_manifest.toml"))


def test_install_registers_everything(lifecycle):
    state = lifecycle["after_install"]
    assert state["enabled"]
    assert all(state["classes"].values()), state["classes"]
    assert state["scene_prop"] and state["scene_rna_props"] == ["flank_settings"]
    assert {"generate_rotor", "analyze_rotor", "verify_plan", "paraboloid_groove", "formed_cutter",
            "plan_double_flank", "plan_single_flank", "cutter_region", "post_program"} <= set(state["ops"])


def test_sidebar_panel_in_flank_tab(lifecycle):
    panel = lifecycle["panel"]
    assert panel["bl_category"] == "Flank"
    assert panel["bl_space_type"] == "VIEW_3D" and panel["bl_region_type"] == "UI"


def test_all_panels_in_flank_tab(lifecycle):
    panels = lifecycle["panels"]
    assert sorted(panels) == ["FLANK_PT_double_flank", "FLANK_PT_formed_cutter", "FLANK_PT_freeform",
                              "FLANK_PT_machine", "FLANK_PT_paraboloid", "FLANK_PT_results", "FLANK_PT_single_flank",
                              "FLANK_PT_verify", "FLANK_PT_workpiece"]
    for name, panel in panels.items():
        assert (panel["bl_category"], panel["bl_space_type"], panel["bl_region_type"]) == ("Flank", "VIEW_3D", "UI")


def test_scene_settings_hold_verify_groove_cutter_double_and_single_flank_properties(lifecycle):
    props = set(lifecycle["settings_props"])
    assert {"verify_filepath", "verify_tolerance", "verify_search", "verify_show_tools"} <= props
    assert {"groove_radius", "groove_a", "groove_b", "groove_pitch", "groove_turns", "groove_part",
            "groove_resolution"} <= props
    assert {"cutter_source", "cutter_lead", "cutter_centre_distance", "cutter_swivel", "cutter_handedness",
            "cutter_planes", "cutter_eps_b", "cutter_tolerance", "cutter_sample_points", "cutter_resolution",
            "cutter_animate", "cutter_frame_start", "cutter_frame_end", "cutter_filepath"} <= props
    assert {"df_valley", "df_variant", "df_tool", "df_cones", "df_two_paths", "df_radii", "df_rim", "df_samples",
            "df_simulate", "df_tolerance", "df_envelope_rings", "df_animate", "df_frame_start", "df_frame_end",
            "df_filepath", "df_tool_csv"} <= props
    assert {"sf_flank", "sf_use_point", "sf_point", "sf_shape", "sf_r1", "sf_r2", "sf_alpha", "sf_length",
            "sf_shank_radius", "sf_shank_length", "sf_tolerance", "sf_overcut_tolerance", "sf_seeds", "sf_objective",
            "sf_mode", "sf_rounds", "sf_collisions", "sf_envelope_rings", "sf_animate", "sf_frame_start",
            "sf_frame_end", "sf_filepath"} <= props
    assert {"tool_flutes", "tool_cutting_speed_m_min", "tool_feed_per_tooth_mm", "tool_max_rpm", "machine",
            "machine_file", "post", "clearance", "lobes", "flip_rotor", "program_filepath", "program_animate"} <= props


def test_panels_in_workflow_order(lifecycle):
    order = {name: p["bl_order"] for name, p in lifecycle["panels"].items()}
    assert order["FLANK_PT_workpiece"] < order["FLANK_PT_double_flank"] < order["FLANK_PT_single_flank"] \
        < order["FLANK_PT_formed_cutter"] < order["FLANK_PT_results"] < order["FLANK_PT_verify"] \
        < order["FLANK_PT_machine"]


def test_disable_enable_five_times_leaves_nothing_behind(lifecycle):
    cycles = lifecycle["cycles"]
    assert len(cycles) == 5
    for i, cycle in enumerate(cycles):
        off, on = cycle["disabled"], cycle["enabled"]
        assert not off["enabled"], i
        assert not any(off["classes"].values()), (i, off["classes"])
        assert not off["scene_prop"], i
        assert off["flank_types"] == [] and off["scene_rna_props"] == [], (i, off)
        assert on["enabled"] and all(on["classes"].values()) and on["scene_prop"], (i, on)
        assert cycle["generate_works"], i
    final = lifecycle["final_disabled"]
    assert not final["enabled"] and not any(final["classes"].values()) and not final["scene_prop"]
