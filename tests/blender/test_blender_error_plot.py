# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.error_plot through the installed extension (scenario_error_plot.py): failures leave no image and no
file, the image of a single-flank run is exactly the core rasteriser's picture of the stored plan outside its
text, the text is drawn in Blender's font where the core's text items put it, the curve has verify's colours at
the rows the errors map to, the axis unit follows the scene (mm, µm below 1 mm), the image is reused, written
as PNG on request and survives save + reload."""
import pytest

from blender_harness import assert_plans_kept, run_scenario


@pytest.fixture(scope="module")
def ep(extension_zip, tmp_path_factory):
    return run_scenario(extension_zip, "error_plot", tmp_path_factory.mktemp("error_plot"))


def _failed(r, *words):
    assert r["result"] is None, r
    for w in words:
        assert w in r["error"], (w, r["error"])
    assert "Traceback" not in r["error"]
    assert r["new_images"] == [] and r["new_files"] == [], r


def test_without_a_run_it_fails_and_makes_no_image(ep):
    _failed(ep["no_run"], "no planning run", "Plan Single Flank")


@pytest.mark.parametrize("case, words", [("unknown_run", ("no collection", "No Such Run")),
                                         ("missing_folder", ("does not exist", "no_dir")),
                                         ("folder", ("is a folder: give a file name", "plots")),
                                         ("relative", ("'relative_plot.png' is a relative path",)),
                                         ("broken_plan", ("not valid",))])
def test_failures_with_a_run_leave_nothing(ep, case, words):
    _failed(ep["fails"][case], *words)
    assert not ep["fails"][case].get("beside"), "a folder path was written as '<folder>.png'"


def test_the_run(ep):
    assert ep["plan"]["result"] == ["FINISHED"], ep["plan"]["error"]
    assert ep["run"]["strips"] >= 2 and ep["run"]["length_unit"] == "R"
    assert ep["run"]["tolerance_plan"] == pytest.approx(1e-3, rel=1e-6)      # the planner's, in plan units
    assert ep["run"]["tolerance_plan"] == pytest.approx(ep["run"]["plan_tolerance_field"], rel=1e-6)


def _image_checks(r, w, h, unit):
    assert r["result"] == ["FINISHED"], r["error"]
    assert r["size"] == [w, h]
    assert r["packed"] and r["fake_user"]
    p = r["props"]
    assert p["flank_plot_unit"] == unit == r["core_info"]["unit"]
    # pixel for pixel the core rasteriser on the stored plan outside the text (8-bit image: k / 255 exactly, float
    # readback); every text item drawn in Blender's font inside its box: dark ink, where the item asks for it
    tx = r["text"]
    assert tx["outside_max_diff"] < 1e-6 and tx["changed_outside"] == 0, tx
    assert tx["count"] >= 15 and len(tx["items"]) == tx["count"] and tx["changed_inside"] > 2000
    roles = {i["role"] for i in tx["items"]}
    assert {"title", "legend", "caption", "note", "x_label", "x_tick", "y_tick", "group"} <= roles, roles
    for i in tx["items"]:
        assert i["box"] is not None and i["changed"] >= 5 and i["darkest"] < 0.45, i
        assert abs(i["left_offset"]) <= 2 and -2 <= i["cap_top_offset"] <= 2 and 0 <= i["baseline_offset"] <= 8, i
    # every one of the profile points is drawn in verify's colour within 1 px of its row (8-bit rounding)
    cc = r["curve_check"]
    assert cc["points"] == p["flank_plot_finite_points"] == p["flank_plot_points"] > 100
    assert cc["within_2_255"] == cc["points"], cc
    # the axes hold all the errors and the tolerance band
    ya, yb = p["flank_plot_y_range"]
    lo, hi = r["extremes"]
    assert ya <= min(lo, -p["flank_plot_tolerance"]) and yb >= max(hi, p["flank_plot_tolerance"])
    assert p["flank_plot_x_range"] == [0.0, 100.0]
    assert p["flank_plot_max_error"] == pytest.approx(hi, rel=1e-9)
    # blue pixels beyond the legend swatch exactly where the error reaches beyond the tolerance (the planner left
    # material at the flank ends before it seeded the flank's gaps; it now keeps the whole flank within it, largest
    # error 0.85 tolerances); no overcut in this run: red only in the legend swatch
    sw = 7                      # legend swatch side at font scale 1 (images below 960 x 540)
    assert (r["band_pixels"]["stock"] > sw * sw) == (hi > p["flank_plot_tolerance"])
    assert r["band_pixels"]["stock"] >= sw * sw and r["band_pixels"]["gouge"] == sw * sw
    assert r["band_pixels"]["ok"] > 1000
    assert r["band_pixels"]["ok"] > 1000


def test_plot_in_a_metre_scene_is_in_mm(ep):
    r = ep["first"]
    assert r["new_images"] == 1 and r["found"]
    full = "Flank Error Plot ({})".format(ep["run"]["name"])
    if len(full.encode("utf-8")) <= 63:        # bpy 4.2's ID name limit: longer run names are cut in the middle
        assert r["name"] == full
    else:
        head, tail = r["name"].split("…")
        assert full.startswith(head) and full.endswith(tail) and len(r["name"].encode("utf-8")) == 63, r["name"]
    assert r["units"] == [1000.0, "mm"]
    _image_checks(r, 640, 360, "mm")
    assert r["props"]["flank_plot_tolerance"] == pytest.approx(1.0)          # 1e-3 R = 1 mm
    # measured 0.846 mm: within the tolerance over the whole flank (7.51 mm of material at the flank ends before
    # the planner seeded the flank's gaps)
    assert 0.5 < r["props"]["flank_plot_max_error"] < 1.0


def test_png_file_is_the_image(ep):
    r = ep["first"]
    assert r["png_shape"] == [360, 640, 4]
    assert r["png_vs_image"] < 1e-6


def test_plot_in_a_millimetre_scene_is_in_micrometres_and_reuses_the_image(ep):
    r = ep["second"]
    assert r["new_images"] == 0 and r["same_image"]
    _image_checks(r, 800, 450, "µm")
    assert r["props"]["flank_plot_y_factor"] == 1000.0
    assert r["props"]["flank_plot_tolerance"] == pytest.approx(1.0, rel=1e-6)   # 1e-3 mm = 1 µm
    assert r["props"]["flank_plot_max_error"] == pytest.approx(ep["first"]["props"]["flank_plot_max_error"],
                                                               rel=1e-6)


def test_combined_curve(ep):
    assert ep["combined"]["result"] == ["FINISHED"], ep["combined"]["error"]
    assert ep["combined"]["curves"] == 1
    assert ep["first"]["props"]["flank_plot_curves"] == ep["run"]["strips"]


def test_packed_image_survives_save_and_reload(ep):
    r = ep["reload"]
    assert r["found"] and r["packed"] and r["size"] == [800, 450]
    assert r["max_diff"] == 0.0
    assert r["run"] == ep["run"]["name"]
    a = ep["after_reload"]
    assert a["result"] == ["FINISHED"], a["error"]
    assert a["new_images"] == 0 and a["size"] == [640, 360]


def test_the_kept_plans_are_the_stored_ones(ep):
    """Operators read a run's plan from the one the extension keeps parsed: after all of them ran, each kept plan
    is still its run's stored text parsed again, number for number (none of them changed the shared plan)."""
    assert_plans_kept(ep["plans_kept"])
