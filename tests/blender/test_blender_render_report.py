# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.render_report through the installed extension (scenario_render_report.py): the PNG has the requested
size, its legend bar is exactly the strips' colour function, its title carries the plan's tolerance and
max / min errors in the scene's unit, and no call leaves a data-block behind (or removes one)."""
import pytest

from blender_harness import run_scenario
from flank_addon.report.report_geometry import BAR_SPLIT, format_length


@pytest.fixture(scope="module")
def rep(extension_zip, tmp_path_factory):
    return run_scenario(extension_zip, "render_report", tmp_path_factory.mktemp("render_report"))


def test_no_run_is_an_error_and_changes_nothing(rep):
    r = rep["no_run"]
    assert r["result"] is None and "no planning run" in r["error"]
    assert not r["file"] and r["changed"] == {}


def test_the_run_to_report(rep):
    assert rep["plan"]["result"] == ["FINISHED"], rep["plan"]["error"]
    assert rep["run"]["strips"] >= 2 and rep["run"]["length_unit"] == "R"


# label -> (display factor per plan unit, unit, tolerance text) for a plan in R units on an unscaled rotor
UNITS = {"metric_m": (1000.0, "mm", "±1 mm"), "metric_mm": (1.0, "mm", "±1 µm"), "none": (1.0, "R", "±0.001 R")}


@pytest.mark.parametrize("label", sorted(UNITS))
def test_report_png_size_legend_and_title(rep, label):
    r = rep["renders"][label]
    assert r["result"] == ["FINISHED"], r["error"]
    assert r["shape"] == [400, 640, 4]
    assert r["bar_max_diff"] == 0                                  # the legend is the colour function itself
    x0, y0, x1, y1 = r["meta"]["legend"]["bar"]
    h = y1 - y0
    assert h >= 10 and x1 - x0 >= 300
    # each band's full colour: the line above its part of the bar (and, for 'within', the bar itself)
    ly0, ly1 = r["meta"]["legend"]["band_rows"]
    outer = (ly1 - ly0) * int(BAR_SPLIT[0] * (x1 - x0) - 2)
    assert ly1 - ly0 >= 4 and r["band_pixels"]["gouge"] >= outer and r["band_pixels"]["stock"] >= outer
    assert r["band_pixels"]["ok"] >= (h + ly1 - ly0) * int((BAR_SPLIT[1] - BAR_SPLIT[0]) * (x1 - x0) - 2)
    assert r["strip_green_pixels"] > 500                          # the strips are in the picture
    factor, unit, tol_text = UNITS[label]
    meta, summ = r["meta"], rep["run"]["summary"]
    assert meta["units"][1] == unit and meta["units"][0] == pytest.approx(factor, rel=1e-6)
    assert meta["tolerance"] == rep["run"]["tolerance"] == 1e-3
    assert meta["max_error"] == summ["max_error"] and meta["min_error"] == summ["min_error"]
    line = meta["title"][1]
    assert "tolerance " + tol_text in line
    assert "max error " + format_length(summ["max_error"] * meta["units"][0], unit) in line
    assert "min error " + format_length(summ["min_error"] * meta["units"][0], unit) in line
    assert "{} strips".format(rep["run"]["strips"]) in line
    assert meta["title"][0].startswith(rep["run"]["name"])
    ticks = [t["text"] for t in meta["legend"]["ticks"]]
    assert ticks[1] == "-" + tol_text[1:] and ticks[3] == "+" + tol_text[1:]


@pytest.mark.parametrize("label", sorted(UNITS))
def test_report_leaves_nothing_behind(rep, label):
    r = rep["renders"][label]
    assert r["changed"] == {}, r["changed"]
    assert r["same_scene"] and r["same_active"]


def test_tiles_make_the_picture_rendered_in_one_piece(rep):
    """Workbench renders the report in tiles, one per turn of Blender's main thread: put together they are the
    picture rendered whole, but for rounding -- shading within two levels, and a few pixels whose centre lies on
    a silhouette edge (up to 5 of about a million found; a tile one pixel off would move every edge)."""
    t = rep["tiled"]
    assert t["1280x800"]["tiles"] == 4 and t["1280x800"]["sizes"] == [[640, 400]], t
    assert t["1281x799"]["tiles"] == 12 and t["401x803"]["tiles"] == 10, t
    assert t["800x1280"]["tiles"] == 4 and t["800x1280"]["sizes"] == [[400, 640]], t     # tiles taller than wide
    for size, r in t.items():
        assert r["changed"] == {}, (size, r["changed"])
        assert r["surface"] > 0.1 * r["pixels"], (size, r)        # the rotor fills the picture, not background
        assert r["differing"] < 0.002 * r["pixels"] and r["over_2"] < 1e-4 * r["pixels"], (size, r)


def test_invoke_without_a_window_renders(rep):
    assert rep["invoke"]["result"] == ["FINISHED"] and rep["invoke"]["file"], rep["invoke"]


def test_cycles_report(rep):
    """Cycles renders in a separate Blender (the main thread would be held for the whole render): its picture is
    the one this Blender renders of the same scene, pixel for pixel, and nothing stays behind."""
    r = rep["cycles"]
    assert r["result"] == ["FINISHED"], r["error"]
    assert r["shape"] == [200, 320, 4] and r["bar_max_diff"] == 0
    assert r["meta"]["engine"] == "CYCLES" and "±1 µm" in r["meta"]["title"][1]
    assert r["changed"] == {}, r["changed"]
    assert r["surface"] > 5000, r                  # the rotor is in the picture, not only the background
    assert r["here_differing"] == 0, (r["here_differing"], r["here_max_diff"])


@pytest.mark.parametrize("label,words", [("missing_folder", "does not exist"), ("folder", "is a folder"),
                                         ("folder_no_png", "is a folder: give a file name"),
                                         ("relative", "'relative_report.png' is a relative path"),
                                         ("empty_path", "no file given"), ("no_such_run", "no collection")])
def test_bad_input_is_a_clear_error(rep, label, words):
    b = rep["bad"][label]
    assert b["result"] is None and words in b["error"], b
    assert b["changed"] == {}, b["changed"]
    assert "Traceback" not in b["error"]


def test_bad_input_writes_no_file(rep):
    assert rep["bad"]["files"] == [] and not rep["bad"]["beside"]
