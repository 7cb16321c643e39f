# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.paraboloid_groove through the installed extension: the Doğrusadık paper case (R 20, a -0.05, b 7.2, p 20)."""
import math

import pytest

from blender_harness import run_scenario

OBJECTS = ["Groove Surface", "Overcut Band", "Paraboloid Tool", "Paraboloid Tool (moving)", "Swept Section",
           "Tool Section"]


@pytest.fixture(scope="module")
def par(extension_zip, tmp_path_factory):
    return run_scenario(extension_zip, "paraboloid", tmp_path_factory.mktemp("paraboloid"))


def test_creates_collection_with_all_objects(par):
    p = par["paper"]
    assert p["result"] == ["FINISHED"], p["error"]
    assert p["objects"] == OBJECTS and p["in_scene"]
    # 6 objects, 5 meshes (the two tools share one), 2 collections ("Flank Results" and the run's under it)
    assert p["new"] == [6, 5, 2]
    assert p["active"] == "Groove Surface"


def test_paper_intercepts_and_max_overcut(par):
    p = par["paper"]
    props = p["props"]
    assert props["flank_groove_intercepts"] == pytest.approx([-32.0, -8.0], abs=1e-12)
    assert p["expected_intercepts"] == pytest.approx([-32.0, -8.0], abs=1e-12)
    assert props["flank_groove_equator_radius"] == pytest.approx(12.0, abs=1e-12)
    assert props["flank_groove_max_overcut"] == pytest.approx(p["expected_max_overcut"], abs=1e-12)
    assert 0.2 < props["flank_groove_max_overcut"] < 0.5
    assert -32.0 <= props["flank_groove_max_overcut_x"] <= -8.0
    assert props["flank_groove_v0"] == pytest.approx(20.0 / (2 * math.pi), rel=1e-12)
    assert (props["flank_groove_a"], props["flank_groove_b"], props["flank_groove_pitch"]) == (-0.05, 7.2, 20.0)


def test_swept_section_overcut_attribute(par):
    p = par["paper"]
    s = p["swept"]
    assert s["edges"] == s["vertices"] > 700 and s["faces"] == 0  # one closed loop (upper + mirrored lower)
    assert s["overcut_max"] == pytest.approx(p["expected_max_overcut"], abs=1e-6)  # float32 attribute
    assert s["overcut_min"] >= -1e-6
    assert s["x_range"] == pytest.approx([-32.0, -8.0], abs=1e-5)
    assert s["y_abs_max"] == 0.0  # the section plane through the axis (paper z = 0 -> Y = 0)
    assert s["z_max"] > 7.2  # the swept section rises above the tool's own section (b = 7.2)
    assert p["tool_section_z_max"] == pytest.approx(7.2, abs=1e-5)
    assert p["band"]["active_color"] == "overcut_color"
    assert p["band"]["overcut_max"] == pytest.approx(p["expected_max_overcut"], abs=1e-6)


def test_groove_surface_and_tool_line_up(par):
    p = par["paper"]
    on = p["swept_on_groove"]
    # the section curve lies on the helical groove surface (within the mesh's sampling), not p/2 away
    assert on["max_distance"] < on["spacing"], on
    assert p["tool"]["location"] == pytest.approx([-20.0, 0.0, 0.0], abs=1e-6)
    assert p["tool"]["z_extent"] == pytest.approx(14.4, abs=1e-4)
    assert p["tool"]["r_extent"] == pytest.approx(12.0, abs=1e-4)


def test_tool_animation_follows_the_helix(par):
    anim = par["paper"]["anim"]
    assert anim["has_action"] and anim["shares_mesh"]
    frames = anim["frame_end"] - anim["frame_start"] + 1
    assert sorted(anim["fcurves"]) == ["location[0]", "location[1]", "location[2]"]
    for fc in anim["fcurves"].values():
        assert fc["keys"] == frames and fc["interpolation"] == ["LINEAR"]
    v0 = 20.0 / (2 * math.pi)
    for smp in anim["samples"]:
        x, y, z = smp["location"]
        assert smp["radius"] == pytest.approx(20.0, abs=1e-4)
        assert smp["rotation_identity"]
        # right-handed helix through (-20, 0, 0): z = v0 (theta - pi), theta = atan2(y, x) unwrapped near pi
        theta = math.atan2(y, x) % (2 * math.pi)
        assert z == pytest.approx(v0 * (theta - math.pi), abs=1e-3) or \
            z == pytest.approx(v0 * (theta - math.pi) + math.copysign(20.0, z), abs=1e-3)
    first, last = anim["samples"][0]["location"], anim["samples"][-1]["location"]
    assert first[2] == pytest.approx(-10.0, abs=1e-4)  # one turn centred on the section plane
    assert last[2] > 0


def test_external_part(par):
    e = par["external"]
    assert e["result"] == ["FINISHED"], e["error"]
    assert e["props"]["flank_groove_part"] == "external"
    assert e["props"]["flank_groove_max_overcut"] == pytest.approx(e["expected_max_overcut"], abs=1e-12)
    assert e["props"]["flank_groove_intercepts"] == pytest.approx([-32.0, -8.0], abs=1e-12)
    assert e["collection"] == ["Paraboloid Groove"]  # a second run replaces the first (under "Flank Results")


@pytest.mark.parametrize("case,words", [
    ("a_positive", ["a must be negative", "0.05"]),
    ("a_zero", ["a must be negative"]),
    ("R_too_small", ["R = 10", "equator radius 12"]),
    ("b_negative", ["b must be positive"]),
    ("pitch_zero", ["pitch p > 0"]),
])
def test_bad_parameters_create_nothing(par, case, words):
    bad = par["bad"][case]
    assert bad["result"] is None, bad
    for w in words:
        assert w in bad["error"], bad["error"]
    assert "Traceback" not in bad["error"]
    assert bad["new"] == [0, 0, 0]


def test_panels_draw_groove_results(par):
    panels = par["panels"]
    for name, calls in panels.items():
        assert isinstance(calls, list), (name, calls)  # no exception in draw()
    calls = panels["FLANK_PT_paraboloid"]   # a Strategy sub-panel: Run button and lens a, b in the Run / Tool panels
    assert all(["prop", "groove_" + n] in calls for n in ("radius", "pitch", "turns", "part", "resolution"))
    labels = [c[1] for c in calls if c[0] == "label"]
    assert "Intercepts: x = -32, -8" in labels, labels
    assert any(t.startswith("Max overcut: 0.3") for t in labels), labels
