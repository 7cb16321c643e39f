# SPDX-License-Identifier: GPL-3.0-or-later
"""UI items  beside the modal run (scenario_modal_ui.py): Check Tool for a cylinder, the Results panel's
PLY export button, and the error plot's hand-over to an Image Editor with and without one (background)."""
import math

import pytest

from blender_harness import run_scenario


@pytest.fixture(scope="module")
def ui(extension_zip, tmp_path_factory):
    return run_scenario(extension_zip, "modal_ui", tmp_path_factory.mktemp("modal_ui"))


def test_check_tool_is_offered_for_a_cone_from_the_scene_settings(ui):
    cone = ui["check_tool"]["CONE"]
    assert cone["draw_error"] is None
    assert len(cone["buttons"]) == 1 and cone["buttons"][0]["text"] == "Check Tool"
    assert cone["buttons"][0]["props"] == {}           # flank and cone come from the sf_* settings
    assert cone["result"] == ["FINISHED"], cone


def test_check_tool_is_offered_for_a_cylinder_as_the_cone_it_is_planned_as(ui):
    ct = ui["check_tool"]
    cyl = ct["CYLINDER"]
    assert cyl["draw_error"] is None
    assert len(cyl["buttons"]) == 1 and cyl["buttons"][0]["text"] == "Check Tool"
    p = cyl["buttons"][0]["props"]
    taper = ct["taper"]
    assert p["alpha"] == pytest.approx(taper, rel=1e-6)
    assert p["r1"] == pytest.approx(0.05, rel=1e-6)
    assert p["r2"] == pytest.approx(0.05 + 0.2 * math.tan(taper), rel=1e-6)
    assert cyl["result"] == ["FINISHED"] and cyl["error"] is None, cyl
    cr = cyl["cr"]
    assert cr["flank"] == 1
    alpha, r1, r2 = cr["tool"]
    assert alpha == pytest.approx(taper, rel=1e-5)
    assert r1 == pytest.approx(0.05, rel=1e-6) and r2 == pytest.approx(0.05 + 0.2 * math.tan(taper), rel=1e-6)
    assert isinstance(cr["admissible"], int) and cr["message"]


def test_results_panel_offers_every_export_including_ply(ui):
    rp = ui["results_panel"]
    assert rp["draw_error"] is None
    assert [e[1] for e in rp["exports"]] == ["CL", "PLAN", "CSV", "STL", "PLY"]
    assert all(e[2] for e in rp["exports"])             # each names its run
    ply = rp["ply"]
    assert ply["result"] == ["FINISHED"], ply
    assert len(ply["files"]) >= 1 and ply["head"] == "ply"


def test_error_plot_without_an_image_editor(ui):
    ep = ui["error_plot"]
    assert "IMAGE_EDITOR" not in ep["areas"]            # the background screen: no Image Editor
    ne = ep["no_editor"]
    assert ne["result"] == ["FINISHED"] and ne["error"] is None and ne["image"], ne
    assert ne["shown"] == []
    assert ep["no_screen"] == ["None", "None"]          # no context window; a window without a screen; none


def test_error_plot_is_shown_in_an_image_editor_made_in_background(ui):
    ep = ui["error_plot"]
    ed = ep["editor"]
    assert ed["result"] == ["FINISHED"] and ed["area"] == "IMAGE_EDITOR"
    assert ed["shown"] == ep["no_editor"]["image"] and ed["images"] == [ed["shown"]]   # replaced in place
    ew = ep["editor_window"]
    assert ew["result"] == ["FINISHED"] and ew["shown"] == ed["shown"]
