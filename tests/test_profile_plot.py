"""The error-along-profile chart (flank_addon.report.error_chart): the text items it lists for a real font (and
draws none itself), axes, pixel positions and colours of the curve, the tolerance band, NaN gaps, strips,
degenerate input, and the data of a real single-flank plan against the error-profile CSV export."""
import math

import numpy as np
import pytest

from flank_addon.report import error_chart
from flank_addon.report.error_chart import (CAP, FONT_SIZE, INK, axis_unit, error_profile, nice_step,
                                            plan_error_plot, plot_layout, srgb, text_width, tick_text, tick_values,
                                            to_blender_pixels, to_png_bytes, _target_runs)
from flank_addon.simulation.verify import DEVIATION_COLORS, deviation_colors

TOL = 1.0e-3
OK = srgb(np.array(DEVIATION_COLORS["ok"]))
WHITE = srgb(np.array([1.0, 1.0, 1.0, 1.0]))


def expected_col(lay, x):
    """Column of x, from the layout's box and range (the mapping the module documents)."""
    x0, _, x1, _ = lay.box
    a, b = lay.x_range
    return int(round(x0 + (x - a) / (b - a) * (x1 - x0)))


def expected_row(lay, y):
    """Row of a value y given in the input unit."""
    _, y0, _, y1 = lay.box
    a, b = lay.y_range
    return int(round(y0 + (b - y * lay.y_factor) / (b - a) * (y1 - y0)))


def is_color(px, rgba, tol=0.5 / 255):
    return np.abs(np.asarray(px)[..., :3] - np.asarray(rgba)[:3]).max(axis=-1) <= tol


def render_error_plot(*args, **kw):
    """The picture alone (the text items are checked in their own tests)."""
    img, texts = error_chart.render_error_plot(*args, **kw)
    assert isinstance(texts, list) and all(isinstance(t, dict) for t in texts)
    return img


# ------------------------------------------------------------------------------------------- text and axes
def _text_case():
    x = np.linspace(0.0, 100.0, 201)
    y = 3 * TOL * np.sin(x / 8.0)
    y[(x > 40) & (x < 45)] = np.nan
    kw = dict(unit="mm", title="Error along profile: run", x_label="position", note="max +3 µm",
              groups=(x >= 50.0).astype(int), group_labels={0: "S1", 1: "S2"})
    return x, y, kw


def test_text_is_listed_for_a_real_font_and_not_drawn():
    x, y, kw = _text_case()
    W, H = 960, 540
    lay = plot_layout(x, y, TOL, W, H, unit="mm")
    img, texts = error_chart.render_error_plot(x, y, TOL, W, H, **kw)
    fs, (x0, y0, x1, y1), tk = lay.font_scale, lay.box, lay.tick_length
    by_role = {}
    for t in texts:
        by_role.setdefault(t["role"], []).append(t)
        assert t["color"] == tuple(float(c) for c in srgb(np.array(INK)))
        assert t["size"] in (FONT_SIZE * fs, FONT_SIZE * lay.title_scale) and t["baseline"] - t["top"] == CAP * (
            t["size"] / FONT_SIZE)
        assert t["align"] in ("left", "center", "right") and t["text"]
        width = t["width"] if t["max_width"] is None else t["max_width"]
        left = t["x"] - {"left": 0.0, "center": 0.5, "right": 1.0}[t["align"]] * width
        assert 0 <= left and left + width <= W and 0 <= t["top"] and t["baseline"] <= H, t
    assert [t["text"] for t in by_role["title"]] == ["Error along profile: run"]
    assert by_role["title"][0]["max_width"] == W - 2 * lay.pad              # the caller shortens a longer one
    assert all(t["max_width"] is None for t in texts if t["role"] != "title")
    assert [t["text"] for t in by_role["legend"]] == ["overcut", "within ±1 µm", "material left", "no tool"]
    assert by_role["caption"][0]["text"] == "error (µm), + = material left"
    assert by_role["note"][0]["text"] == "max +3 µm" and by_role["note"][0]["align"] == "right"
    assert by_role["note"][0]["x"] == x1 + 1
    assert [t["text"] for t in by_role["x_label"]] == ["position"]
    assert sorted(t["text"] for t in by_role["group"]) == ["S1", "S2"]
    # tick labels: right-aligned left of the y ticks, their capitals centred on the tick's row; centred under
    # the x ticks
    assert [t["text"] for t in by_role["y_tick"]] == lay.y_labels
    for t, v in zip(by_role["y_tick"], lay.y_ticks):
        assert t["align"] == "right" and t["x"] == x0 - 2 - tk - 2 * fs
        assert abs(0.5 * (t["top"] + t["baseline"]) - lay.row(v)) <= fs
    assert [t["text"] for t in by_role["x_tick"]] == lay.x_labels
    for t, v in zip(by_role["x_tick"], lay.x_ticks):
        assert t["align"] == "center" and abs(t["x"] - lay.col(v)) <= 0.5 and t["top"] > y1
    # the picture holds no text: ink only on the frame and the tick marks
    ink = is_color(img, srgb(np.array(INK)))
    allowed = np.zeros_like(ink)
    allowed[[y0 - 1, y1 + 1], x0 - 1:x1 + 2] = True
    allowed[y0 - 1:y1 + 2, [x0 - 1, x1 + 1]] = True
    allowed[y0:y1 + 1, x0 - 1 - tk:x0 - 1] = True
    allowed[y1 + 2:y1 + 2 + tk, x0:x1 + 1] = True
    assert ink.sum() > 2 * (x1 - x0) and not (ink & ~allowed).any()
    # the legend swatches are drawn, each left of its text
    sw = 7 * fs
    for t, cls in zip(by_role["legend"], ("gouge", "ok", "stock", "untouched")):
        want = srgb(np.array(DEVIATION_COLORS[cls]))
        assert is_color(img[int(t["top"]):int(t["top"]) + sw, int(t["x"]) - 3 * fs - sw:int(t["x"]) - 3 * fs],
                        want).all(), cls


def test_text_width_is_a_generous_estimate():
    # Blender's font draws digits 4.9 px wide at size 10: the estimate keeps 6 px per character
    assert text_width("12", 1) == 11 and text_width("12", 3) == 33 and text_width("", 2) == 0
    # the layout keeps room for the widest tick label left of the box
    x, y, _ = _text_case()
    lay = plot_layout(x, y, TOL, 960, 540, unit="mm")
    assert lay.box[0] >= lay.pad + max(text_width(t, lay.font_scale) for t in lay.y_labels) + lay.tick_length


def test_nice_steps_ticks_and_labels():
    assert nice_step(10.0, 5) == 2.0 and nice_step(1.0, 4) == 0.5 and nice_step(7e-6, 7) == 1e-6
    assert nice_step(100.0, 10) == 10.0
    assert tick_values(-0.002, 0.008, 0.002) == pytest.approx([-0.002, 0.0, 0.002, 0.004, 0.006, 0.008])
    assert tick_text(0.0015, 0.0005) == "0.0015" and tick_text(40.0, 10.0) == "40" and tick_text(-2.5, 0.5) == "-2.5"
    assert tick_text(1e-20, 1e-3) == "0" and tick_text(2e-5, 1e-5) == "2e-5" and tick_text(-5e-6, 5e-6) == "-5e-6"
    with pytest.raises(ValueError):
        nice_step(0.0, 5)


def test_axis_unit_micrometres_below_one_millimetre():
    assert axis_unit("mm", [0.2, -0.7]) == (1000.0, "µm")
    assert axis_unit("mm", [1.5, 0.1]) == (1.0, "mm")
    assert axis_unit("R", [1e-4]) == (1.0, "R") and axis_unit("in", [1e-4]) == (1.0, "in")


# ------------------------------------------------------------------------------------------- the picture
def sine_case(amplitude, n=201, phase=0.0):
    x = np.linspace(0.0, 100.0, n)
    return x, amplitude * np.sin(2 * np.pi * x / 50.0 + phase)


def test_output_format_and_blender_row_order():
    x, y = sine_case(0.5 * TOL)
    img = render_error_plot(x, y, TOL, 400, 240, unit="R", title="t", x_label="x")
    assert img.shape == (240, 400, 4) and img.dtype == np.float32
    assert img.min() >= 0.0 and img.max() <= 1.0 and (img[..., 3] == 1.0).all()
    # values are k / 255: an 8-bit image or PNG holds them exactly
    assert np.abs(img * 255 - np.rint(img * 255)).max() < 1e-4
    flat = to_blender_pixels(img)
    assert flat.shape == (240 * 400 * 4,) and flat.dtype == np.float32
    assert np.array_equal(flat[:4], img[-1, 0]) and np.array_equal(flat[-4:], img[0, -1])   # bottom row first
    b = to_png_bytes(img)
    assert b.dtype == np.uint8 and np.abs(b / 255.0 - img).max() < 1e-6


def test_curve_within_tolerance_is_green_at_its_row():
    x, y = sine_case(0.6 * TOL)
    W, H = 960, 540
    lay = plot_layout(x, y, TOL, W, H, unit="R")
    img = render_error_plot(x, y, TOL, W, H, unit="R")
    assert lay.y_unit == "R" and lay.y_factor == 1.0
    rows = [expected_row(lay, v) for v in y]
    for i, (xi, yi) in enumerate(zip(x, y)):
        c, r = expected_col(lay, xi), rows[i]
        window = img[r - 1:r + 2, c]
        assert is_color(window, OK).any(), (xi, yi, c, r)
        # and nowhere else in this column than between the neighbours' rows (the curve is a function of x)
        near = rows[max(i - 1, 0):i + 2]
        far = np.r_[lay.box[1]:min(near) - 2, max(near) + 3:lay.box[3] + 1]
        assert not is_color(img[far, c], OK).any(), (i, c)


def test_curve_colour_follows_deviation_colors_beyond_the_band():
    x, y = sine_case(6 * TOL, n=401)
    lay = plot_layout(x, y, TOL, 960, 540, unit="R")
    img = render_error_plot(x, y, TOL, 960, 540, unit="R")
    worst = 0.0
    classes = {"gouge": 0, "ok": 0, "stock": 0}
    for xi, yi in zip(x, y):
        c, r = expected_col(lay, xi), expected_row(lay, yi)
        want = srgb(deviation_colors(np.array([yi]), TOL))[0]
        d = np.abs(img[r - 1:r + 2, c, :3] - want[:3]).max(axis=1).min()
        worst = max(worst, float(d))
        classes["gouge" if yi < -TOL else "stock" if yi > TOL else "ok"] += 1
    assert worst <= 3.0 / 255          # the shade at a neighbouring pixel differs by at most a few levels
    assert min(classes.values()) > 20  # all three colours were checked


def test_axis_range_holds_the_data_zero_and_the_band():
    rng = np.random.default_rng(3)
    for lo, hi in ((-3e-3, 9e-3), (2e-3, 5e-3), (-4e-4, 1e-4), (-8.0, -7.0)):
        y = rng.uniform(lo, hi, 50)
        y[0], y[1] = lo, hi
        lay = plot_layout(np.arange(50.0), y, TOL, 640, 360, unit="R")
        a, b = lay.y_range
        assert a <= min(lo, -TOL, 0.0) and b >= max(hi, TOL, 0.0)
        assert (b - a) <= 1.6 * (max(hi, TOL, 0) - min(lo, -TOL, 0)) + 2 * lay.y_step
        assert a == pytest.approx(round(a / lay.y_step) * lay.y_step) and lay.y_ticks[0] == pytest.approx(a)
        assert lay.y_ticks[-1] == pytest.approx(b)
        assert lay.x_range == (0.0, 49.0)
    # fit_data: the errors alone (the band may leave the chart), zero still shown
    y = np.linspace(2e-6, 7e-6, 30)
    lay = plot_layout(np.arange(30.0), y, TOL, 640, 360, unit="R", fit_data=True)
    assert lay.y_range[0] <= 0.0 and 7e-6 <= lay.y_range[1] < 1e-5


def test_tolerance_band_rows_and_zero_line():
    # a curve only over x in [0, 30]: the columns at x = 75 and 85 show the chart's background
    x = np.linspace(0.0, 100.0, 101)
    y = np.where(x <= 30.0, 4 * TOL, np.nan)
    W, H = 960, 540
    lay = plot_layout(x, y, TOL, W, H, unit="R")
    img = render_error_plot(x, y, TOL, W, H, unit="R")
    from flank_addon.report.error_chart import band_colors

    fill, edge = (srgb(np.array(c)) for c in band_colors())
    r_top, r_bot, r_zero = expected_row(lay, TOL), expected_row(lay, -TOL), expected_row(lay, 0.0)
    grid_rows = {expected_row(lay, v / lay.y_factor) for v in lay.y_ticks}
    assert r_top < r_zero < r_bot and r_bot - r_top > 20
    for xc in (75.0, 85.0):
        c = expected_col(lay, xc)
        for r in range(lay.box[1], lay.box[3] - 4 * lay.font_scale):         # above the grey no-tool ticks
            px = img[r, c]
            if r in grid_rows and r != r_zero:
                continue
            if r == r_zero:
                assert not is_color(px, fill) and not is_color(px, WHITE)
            elif r in (r_top, r_bot):
                assert is_color(px, edge) or is_color(px, fill)
            elif r_top < r < r_bot:
                assert is_color(px, fill), (r, px)
            else:
                assert is_color(px, WHITE), (r, px)
    # the dashed band edges: the edge colour on a good share of their rows
    for r in (r_top, r_bot):
        row = img[r, lay.box[0]:lay.box[2] + 1]
        assert 0.4 < is_color(row, edge).mean() < 0.8


def test_nan_gaps_are_not_drawn_but_marked():
    x = np.linspace(0.0, 100.0, 201)
    y = 0.5 * TOL * np.cos(x / 9.0)
    gap = (x > 40.0) & (x < 60.0)
    y[gap] = np.nan
    W, H = 960, 540
    lay = plot_layout(x, y, TOL, W, H, unit="R")
    img = render_error_plot(x, y, TOL, W, H, unit="R")
    x0, y0, x1, y1 = lay.box
    fs = lay.font_scale
    c_a = expected_col(lay, x[~gap & (x <= 40.0)].max())
    c_b = expected_col(lay, x[~gap & (x >= 60.0)].min())
    inner = img[y0:y1 + 1 - 4 * fs, c_a + 3:c_b - 2]
    assert inner.shape[1] > 100
    assert not is_color(inner, OK).any()                                      # no curve in the gap
    assert is_color(img[y0:y1 + 1, x0:c_a + 1], OK).sum() > 500               # but left of it
    assert is_color(img[y0:y1 + 1, c_b:x1 + 1], OK).sum() > 500               # and right of it
    grey = srgb(np.array(DEVIATION_COLORS["untouched"]))
    marks = is_color(img[y1 - 4 * fs + 1:y1 + 1, c_a + 3:c_b - 2], grey).any(axis=0)
    assert marks.mean() > 0.9                                                  # the gap is marked at the bottom
    assert not is_color(img[y0:y1 - 4 * fs, x0:x1 + 1], grey).any()          # and only there


def test_groups_are_separate_curves_and_lone_points_are_dots():
    x = np.linspace(0.0, 100.0, 101)
    y = np.where(x < 50.0, 0.7 * TOL, -0.7 * TOL)
    W, H = 960, 540
    lay = plot_layout(x, y, TOL, W, H, unit="R")
    c_a, c_b = expected_col(lay, 49.0), expected_col(lay, 50.0)
    r_hi, r_lo = expected_row(lay, 0.7 * TOL), expected_row(lay, -0.7 * TOL)
    between = (slice(r_hi + 3, r_lo - 2), slice(c_a + 1, c_b))
    joined = render_error_plot(x, y, TOL, W, H, unit="R")
    split = render_error_plot(x, y, TOL, W, H, unit="R", groups=(x >= 50.0).astype(int),
                              group_labels={0: "S1", 1: "S2"})
    assert is_color(joined[between], OK).sum() > 20                # one curve: the jump is drawn
    assert not is_color(split[between], OK).any()                  # two curves: it is not
    from flank_addon.report.error_chart import SEPARATOR

    sep = srgb(np.array(SEPARATOR))
    c_mid = int(round(0.5 * (lay.col(49.0) + lay.col(50.0))))
    assert is_color(split[lay.box[1]:lay.box[3] + 1, c_mid], sep).sum() > 20   # dashed strip boundary
    # a finite point between NaNs is still shown (a dot), in its colour
    y2 = np.full(101, np.nan)
    y2[30] = 0.2 * TOL
    lay2 = plot_layout(x, y2, TOL, W, H, unit="R")
    dot = render_error_plot(x, y2, TOL, W, H, unit="R")
    c, r = expected_col(lay2, 30.0), expected_row(lay2, 0.2 * TOL)
    assert is_color(dot[r - 1:r + 2, c - 1:c + 2], OK).all()


def test_millimetres_below_one_are_plotted_in_micrometres():
    x, y = sine_case(0.004)                                                  # +-4 µm, tolerance 1 µm
    lay = plot_layout(x, y, 0.001, 960, 540, unit="mm")
    assert lay.y_unit == "µm" and lay.y_factor == 1000.0 and lay.tolerance == pytest.approx(1.0)
    assert lay.y_range[0] <= -4.0 and lay.y_range[1] >= 4.0 and lay.y_range[1] < 10.0
    img = render_error_plot(x, y, 0.001, 960, 540, unit="mm")
    i = int(np.argmax(y))
    c, r = expected_col(lay, x[i]), expected_row(lay, y[i])
    want = srgb(deviation_colors(np.array([y[i]]), 0.001))[0]
    assert (np.abs(img[r - 1:r + 2, c, :3] - want[:3]).max(axis=1) <= 1.0 / 255).any()
    # above 1 mm the unit stays
    assert plot_layout(x, 300 * y, 0.001, 960, 540, unit="mm").y_unit == "mm"


def test_degenerate_input():
    with pytest.raises(ValueError, match="empty"):
        render_error_plot([], [], TOL)
    with pytest.raises(ValueError, match="no point .* finite"):
        render_error_plot([1.0, 2.0, 3.0], [np.nan, np.inf, np.nan], TOL)
    with pytest.raises(ValueError, match="differ in length"):
        render_error_plot([1.0, 2.0], [1.0], TOL)
    for bad in (0.0, -1.0, np.nan, np.inf, None):
        with pytest.raises(ValueError, match="tolerance"):
            render_error_plot([1.0, 2.0], [0.0, 0.0], bad)
    for size in ((100, 300), (400, 100), (9000, 500)):
        with pytest.raises(ValueError, match="outside"):
            render_error_plot([1.0, 2.0], [0.0, 0.0], TOL, *size)
    with pytest.raises(ValueError, match="groups"):
        render_error_plot([1.0, 2.0], [0.0, 0.0], TOL, groups=[1, 2, 3])
    with pytest.raises(ValueError, match="x_range"):
        plot_layout([1.0, 2.0], [0.0, 0.0], TOL, x_range=(5.0, 5.0))
    # constant zero: a flat chart, the band symmetric about the zero line, the curve on it
    x = np.linspace(0.0, 100.0, 11)
    lay = plot_layout(x, np.zeros(11), TOL, 640, 360, unit="R")
    assert lay.y_range[0] == pytest.approx(-lay.y_range[1]) and lay.y_range[1] >= TOL
    img = render_error_plot(x, np.zeros(11), TOL, 640, 360, unit="R")
    r0 = expected_row(lay, 0.0)
    cols = [expected_col(lay, v) for v in (5.0, 33.0, 77.0)]
    assert all(is_color(img[r0, c], OK) for c in cols)
    # a single point: the x range is widened around it
    lay1 = plot_layout([42.0], [0.5 * TOL], TOL, 640, 360)
    assert lay1.x_range == (41.5, 42.5)
    # fit_data with all-zero errors falls back to the band
    assert plot_layout(x, np.zeros(11), TOL, 640, 360, fit_data=True).y_range == lay.y_range


# ------------------------------------------------------------------------------------------- plan data
def test_target_runs_follow_the_profile_through_index_zero():
    m = np.zeros(20, bool)
    m[[17, 18, 19, 0, 1, 2]] = True
    m[[8, 9]] = True
    runs = _target_runs(m)
    assert [r.tolist() for r in runs] == [[8, 9], [17, 18, 19, 0, 1, 2]]
    assert [r.tolist() for r in _target_runs(np.ones(4, bool))] == [[0, 1, 2, 3]]
    assert _target_runs(np.zeros(4, bool)) == []


@pytest.fixture(scope="module")
def single():
    from flank_addon.tooling.cone import ConeTool
    from flank_addon.methods.single_flank.planner import plan_single_flank
    from flank_addon.geometry.rotors import builtin_by_name

    r = builtin_by_name("asymmetric-female")
    tool = ConeTool(math.asin(0.1), 0.05, 0.08, 0.04, 0.6)
    return plan_single_flank(r.surface(), r.flanks, 1, tool, 2e-3, n_seeds=6, max_rounds=1).plan


def test_error_profile_is_the_csv_export_in_profile_order(single):
    from flank_addon.exports import error_profile_csv
    from flank_addon.simulation.verify import verify_plan

    # one simulation for both: two runs of verify can differ in the last bit (BLAS threads)
    v = verify_plan(single, tolerance=single["tolerance"])
    d = error_profile(single, verification=v)
    rows = [ln.split(",") for ln in error_profile_csv(v).splitlines()[1:]]
    csv = {int(r[0]): (float(r[3]) if r[3] else np.nan) for r in rows}
    assert sorted(d["index"].tolist()) == sorted(csv)
    got = dict(zip(d["index"].tolist(), d["deviation"].tolist()))
    assert all((math.isnan(csv[i]) and math.isnan(got[i])) or csv[i] == got[i] for i in csv)
    a, b = single["rotor"]["flanks"][single["target_flanks"][0]]
    assert d["index"].tolist() == list(range(a, b + 1))                      # one flank, in profile order
    assert d["x"][0] == 0.0 and d["x"][-1] == pytest.approx(100.0) and (np.diff(d["x"]) > 0).all()
    prof = np.asarray(single["rotor"]["profile"])
    assert d["arc_length"] == pytest.approx(np.linalg.norm(np.diff(prof[a:b + 1], axis=0), axis=1).sum())
    assert d["tolerance"] == pytest.approx(single["tolerance"]) and d["length_unit"] == single["length_unit"]
    # every point with an error is formed by one of the strips, and each strip forms a part; the points no
    # tool reaches (this coarse one-round plan leaves the flank end open) have neither
    fin = np.isfinite(d["deviation"])
    assert 0 < (~fin).sum() < 20 and (d["strip"][~fin] == -1).all()
    assert (d["strip"][fin] >= 0).all() and set(d["strip"][fin].tolist()) == set(range(len(single["strips"])))
    assert float(np.nanmax(d["deviation"])) == pytest.approx(d["max_undercut"])
    with pytest.raises(ValueError, match="free-form"):
        error_profile({"surface": {"kind": "mesh"}, "strips": []})


def test_plan_error_plot_per_strip_and_combined(single):
    d = error_profile(single)
    rgba, info = plan_error_plot(single, units=(1000.0, "mm"), width=640, height=360, data=d)
    assert rgba.shape == (360, 640, 4)
    texts = {t["role"]: t["text"] for t in info["texts"]}
    assert texts["title"] == "Error along profile ({})".format(single["method"]) and texts["note"] == info["note"]
    assert {t["text"] for t in info["texts"] if t["role"] == "group"} == {
        "S{}".format(k + 1) for k in range(len(single["strips"]))}
    assert info["curves"] == len(single["strips"]) and info["points"] == len(d["x"])
    assert info["unit"] == "mm" and info["tolerance"] == pytest.approx(2.0)           # 2e-3 R at 1000 mm / R
    assert info["max_error"] == pytest.approx(1000.0 * np.nanmax(d["deviation"]))
    lay = info["layout"]
    assert lay["y_range"][0] <= min(info["min_error"], -2.0) and lay["y_range"][1] >= info["max_error"]
    _, info1 = plan_error_plot(single, units=(1000.0, "mm"), width=640, height=360, data=d, per_strip=False)
    assert info1["curves"] == 1
    # the largest error is drawn in verify's colour at its row
    i = int(np.nanargmax(d["deviation"]))
    x0, y0, x1, y1 = lay["box"]
    c = int(round(x0 + d["x"][i] / 100.0 * (x1 - x0)))
    ya, yb = lay["y_range"]
    r = int(round(y0 + (yb - 1000.0 * d["deviation"][i]) / (yb - ya) * (y1 - y0)))
    want = srgb(deviation_colors(np.array([d["deviation"][i]]), d["tolerance"]))[0]
    assert (np.abs(rgba[r - 1:r + 2, c, :3] - want[:3]).max(axis=1) <= 2.0 / 255).any()
    with pytest.raises(ValueError, match="display factor"):
        plan_error_plot(single, units=(0.0, "mm"), data=d)
