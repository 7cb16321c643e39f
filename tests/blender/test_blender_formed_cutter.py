# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.formed_cutter through the installed extension: Hu, Zhou & Li 2025 Table-1 set-up (A 200, swivel 31 deg, lead 450),
a flagged set-up (swivel 50 deg), the active generated rotor, and bad input."""
import pytest

from blender_harness import run_scenario

T1_OBJECTS = ["Arc Tooth Rotor (Hu, Zhou & Li 2025)", "Contact Points", "Cutter Motion", "Formed Cutter", "Formed Cutter (moving)"]
FLAG_NAMES = ["contact_jump", "maximum_point", "off_tooth", "overcut", "self_occlusion"]


@pytest.fixture(scope="module")
def cut(extension_zip, tmp_path_factory):
    return run_scenario(extension_zip, "formed_cutter", tmp_path_factory.mktemp("formed_cutter"))


def test_table1_creates_collection_with_all_objects(cut):
    t = cut["table1"]
    assert t["result"] == ["FINISHED"], t["error"]
    # the run's collection under "Flank Results", named after its rotor
    assert t["objects"] == T1_OBJECTS and t["in_scene"]
    assert t["collection"] == "Formed Cutter (Arc Tooth Rotor (Hu, Zhou & Li 2025))"
    # 5 objects (the motion empty has no data), 3 meshes (the two cutters share one), 2 collections ("Flank
    # Results" and the run's), 1 action
    assert t["new"] == [5, 3, 2, 1]
    assert t["active"] == "Formed Cutter"
    assert t["rotor"]["in_collection"]
    assert {"flank_source", "flank_v0", "flank_lead", "flank_handedness", "flank_length"} <= set(t["rotor"]["props"])
    assert "flank_cutter_summary" in t["coll_props"]


def test_table1_radius_range_is_the_cores_and_no_flags(cut):
    t = cut["table1"]
    p, e = t["props"], t["expected"]
    assert e["r_max_formula"] == pytest.approx(130.1, abs=1e-12)          # A - (G - R1)
    assert p["flank_cutter_r_range"] == pytest.approx(e["r_range"], abs=1e-12)
    assert p["flank_cutter_r_range"][1] == pytest.approx(130.1, abs=1e-9)
    assert p["flank_cutter_z_range"] == pytest.approx(e["z_range"], abs=1e-12)
    assert p["flank_cutter_planes"] == e["planes"] == 119
    assert sorted(p["flank_cutter_flag_counts"]) == FLAG_NAMES
    assert not any(p["flank_cutter_flag_counts"].values()) and not any(e["flag_counts"].values())
    assert p["flank_cutter_flagged_planes"] == 0 and p["flank_cutter_uncut"] == 0
    assert (p["flank_cutter_centre_distance"], p["flank_cutter_swivel"], p["flank_cutter_lead"]) == (200.0, 31.0, 450.0)
    assert p["flank_cutter_handedness"] == "right"
    c = t["cutter"]
    assert c["vertices"] == 119 * 96 + 2 and c["flagged_vertices"] == 0 and c["red_vertices"] == 0
    assert c["active_color"] == "cutter_flags_color"


def test_table1_cutter_mesh_and_placement(cut):
    t = cut["table1"]
    # the cutter object sits at rotor_world @ S(t_mid) @ cutter_to_rotor (float32 matrices)
    assert t["placement"]["max_matrix_diff"] < 1e-4
    assert t["placement"]["rotor_location"] == pytest.approx([0.0, 0.0, -150.0])   # 2/3 lead long, centred
    assert t["placement"]["t_mid_z"] == pytest.approx(150.0)
    # its ring vertices reproduce the meridian R(Z) of the core in the cutter frame
    assert t["meridian"]["max_radius_error"] < 5e-5
    assert t["meridian"]["z_span"] == pytest.approx(t["expected"]["z_range"], abs=1e-5)
    # contact points lie on the tooth (the groove circle, after screwing back) and on the cutter
    assert t["contact"]["count"] == 119
    assert t["contact"]["max_off_groove"] < 1e-4 and t["contact"]["max_off_cutter"] < 1e-4


def test_table1_machined_deviation_within_1um_on_the_tooth(cut):
    d = cut["table1"]["rotor_dev"]
    assert d["active_color"] == "machined_deviation_color"
    assert d["tooth_vertices"] > 5000 and d["reached_is_tooth"]     # exactly the groove facing +x
    assert d["max_abs_tooth"] <= 1e-3                                # mm: the sweep reproduces the tooth
    assert d["off_tooth_untouched"] and d["grey_is_untouched"] and d["green_tooth"]
    p = cut["table1"]["props"]
    assert p["flank_cutter_max_abs_deviation"] <= 1e-3
    assert p["flank_cutter_reached_points"] == p["flank_cutter_sample_points"] == 161
    assert p["flank_cutter_tolerance"] == pytest.approx(1e-5 * 111.69)


def test_table1_profile_csv(cut):
    csv = cut["table1"]["csv"]
    assert csv["header"] == "z,r" and csv["rows"] == 119 and csv["max_diff"] < 1e-9


def test_animation_keys_follow_the_screw(cut):
    a = cut["table1"]["anim"]
    assert a["has_action"] and a["shares_mesh"]
    assert a["parent"] == ["Arc Tooth Rotor (Hu, Zhou & Li 2025)", "Cutter Motion"]
    assert a["fcurves"] == {"location[2]": {"keys": 2, "interpolation": ["LINEAR"]},
                            "rotation_euler[2]": {"keys": 2, "interpolation": ["LINEAR"]}}
    for smp in a["samples"]:
        # cutter vertices at frame f = rotor_world @ S(s(f)) @ S(t_mid) @ cutter_to_rotor @ vertex
        assert smp["max_diff"] < 5e-4, smp
    first, mid, last = a["samples"][0], a["samples"][2], a["samples"][-1]
    assert mid["s"] == pytest.approx(0.0, abs=1e-12) and mid["z_centre"] == pytest.approx(0.0, abs=1e-4)
    # it starts and ends clear of the rotor: half length 150 + the largest cutter radius 130.1
    assert first["z_centre"] == pytest.approx(-280.1, abs=1e-3) and last["z_centre"] == pytest.approx(280.1, abs=1e-3)


def test_flagged_setup_highlights_rings(cut):
    f = cut["flagged"]
    assert f["result"] == ["FINISHED"], f["error"]
    # a re-run on the Table-1 rotor replaces the Table-1 run: 3 objects, 3 meshes, no action instead of 5, 3, 1
    assert f["new"] == [-2, 0, 0, -1]
    assert f["collection"] == "Formed Cutter (Arc Tooth Rotor (Hu, Zhou & Li 2025))"
    p = f["props"]
    assert p["flank_cutter_flag_counts"] == f["expected_flag_counts"]
    assert sum(p["flank_cutter_flag_counts"].values()) > 0
    assert p["flank_cutter_flagged_planes"] == f["expected_flagged_planes"] > 0
    assert p["flank_cutter_uncut"] == f["expected_uncut"] > 0
    c = f["cutter"]
    assert c["flagged_vertices"] == 96 * f["expected_flagged_planes"]
    assert c["red_vertices"] + c["orange_vertices"] == c["flagged_vertices"] and c["red_vertices"] > 0
    assert c["red_is_flagged"] and c["plain_not_flagged"]
    # the uncut tooth ranges are left standing: stock (blue) on the rotor
    assert f["rotor_dev"]["max_stock"] > 1.0 and f["rotor_dev"]["blue_vertices"] == f["rotor_dev"]["stock_vertices"] > 0


def test_active_generated_rotor(cut):
    a = cut["active"]
    assert a["result"] == ["FINISHED"], a["error"]
    assert a["new"] == [2, 2, 1, 0]          # the rotor is painted in place: only cutter + contact points
    assert a["rotor"]["name"] == "Rotor_srm_a_male" and not a["rotor"]["in_collection"]
    p = a["props"]
    assert p["flank_cutter_source"] == "srm_a-male"
    assert p["flank_cutter_centre_distance"] == pytest.approx(200.0 / 111.69, rel=1e-9)   # automatic A
    assert p["flank_cutter_lead"] == pytest.approx(3.84) and p["flank_cutter_handedness"] == "right"
    assert 0 < a["rotor_reached"] < a["rotor_vertices"]
    assert a["again"] == {"result": ["FINISHED"], "error": None, "rotor": "Rotor_srm_a_male"}


@pytest.mark.parametrize("case,words", [
    ("wrong_lead", ["lead = 5", "3.84", "Rotor_srm_a_male"]),
    ("wrong_hand", ["handedness 'left'", "right-handed"]),
    ("cube", ["not a rotor made by Generate Rotor"]),
])
def test_active_rotor_mismatch_refused(cut, case, words):
    bad = cut["bad_active"][case]
    assert bad["result"] is None and bad["new_objects"] == 0
    for w in words:
        assert w in bad["error"], bad["error"]


@pytest.mark.parametrize("case,words", [
    ("A_below_radius", ["A = 100", "outer radius 111.69"]),
    ("swivel_zero", ["swivel = 0 deg", "0 < |swivel| < 90"]),
    ("swivel_90", ["swivel = 90 deg", "0 < |swivel| < 90"]),
    ("swivel_nan", ["swivel = nan", "finite"]),
    ("A_nan", ["centre distance A = nan", "finite"]),
    ("lead_nan", ["lead = nan", "finite"]),
    ("lead_negative", ["lead must be a positive", "-450"]),
    ("frames", ["end frame 10", "start frame 10"]),
])
def test_bad_input_creates_nothing(cut, case, words):
    bad = cut["bad"][case]
    assert bad["result"] is None, bad
    for w in words:
        assert w in bad["error"], bad["error"]
    assert "Traceback" not in bad["error"]
    assert bad["new"] == [0, 0, 0, 0]


def test_panel_draws_cutter_results(cut):
    panels = cut["panels"]
    for name, calls in panels.items():
        assert isinstance(calls, list), (name, calls)   # no exception in any draw()
    calls = panels["FLANK_PT_formed_cutter"]    # a Strategy sub-panel: its Run button is in the Run panel
    for n in ("source", "lead", "centre_distance", "swivel", "handedness", "planes", "eps_b", "frame_start",
              "frame_end", "filepath"):
        assert ["prop", "cutter_" + n] in calls
    labels = [c[1] for c in calls if c[0] == "label"]
    assert "Radius: 89.2124 .. 130.1" in labels, labels
    assert "Flagged planes: none" in labels, labels
