"""python -m flank_addon render: the report PNG of a plan (needs Blender as a Python module; the project venv has it)."""
import json

import numpy as np
import pytest

from flank_addon.cli import main
from flank_addon.io.plan import write_plan
from flank_addon.io.png import read_png, read_png_text, write_png
from flank_addon.report.report_geometry import (BAR_SPLIT, REPORT_KEY, air_limit, bar_colors, bar_deviations,
                                                choose_view, display_strip, display_units, format_length,
                                                legend_colors, legend_layout, render_tiles, report_geometry,
                                                srgb_bytes, strip_part, tile_camera)
from flank_addon.simulation.verify import DEVIATION_COLORS, deviation_colors


@pytest.fixture(scope="module")
def plan_file(tmp_path_factory, female_plan):
    """The shared single-flank plan of the asymmetric female (conftest), written to a file: the report shows a
    real plan that covers its flank, without planning one more here."""
    _, res = female_plan
    p = tmp_path_factory.mktemp("render") / "plan.json"
    write_plan(p, res.plan)
    return p, res.plan


@pytest.fixture(scope="module")
def geo(plan_file):
    return report_geometry(plan_file[1])


def test_png_round_trip_text_and_srgb(tmp_path):
    a = np.random.default_rng(3).integers(0, 256, (7, 5, 4), dtype=np.uint8)
    write_png(tmp_path / "x.png", a, {"flank-report": '{"t": "±5 µm"}'})
    assert np.array_equal(read_png(tmp_path / "x.png"), a)
    assert read_png_text(tmp_path / "x.png") == {"flank-report": '{"t": "±5 µm"}'}
    assert srgb_bytes([0.0, 1.0, 0.0031308]).tolist() == [0, 255, 10]
    assert srgb_bytes([0.5])[0] == 188                      # 1.055 * 0.5 ** (1 / 2.4) - 0.055 = 0.7354
    assert format_length(0.0004, "mm") == "+0.4 µm" and format_length(-2.5, "mm") == "-2.5 mm"
    assert format_length(0.001, "R") == "+0.001 R" and format_length(float("nan"), "R") == "n/a"


def test_display_units_follow_the_scene():
    plan = {"length_unit": "mm", "rotor": {"to_world": np.diag([2.0, 2.0, 2.0, 1.0]).tolist()}}
    assert display_units(plan) == (1.0, "mm")                                   # command line: the plan's unit
    assert display_units(plan, "NONE", 0.001) == (1.0, "mm")
    f, u = display_units(plan, "METRIC", 0.001)                                 # 1 plan unit = 2 scene mm
    assert u == "mm" and f == pytest.approx(2.0)
    f, u = display_units(plan, "METRIC", 1.0)                                   # default scene: 1 unit = 1 m
    assert u == "mm" and f == pytest.approx(2000.0)
    f, u = display_units(plan, "IMPERIAL", 0.0254)
    assert u == "in" and f == pytest.approx(2.0)


def test_legend_bar_is_the_strip_colour_function():
    d = bar_deviations(200, 0.05)
    assert np.all(np.diff(d) > 0) and d[0] == pytest.approx(-0.5) and d[-1] == pytest.approx(0.5)
    a, b = (round(f * 200) for f in BAR_SPLIT)
    assert np.all(np.abs(d[a:b]) <= 0.05) and np.all(d[:a] < -0.05) and np.all(d[b:] > 0.05)
    cols = bar_colors(200, 0.05)
    assert np.array_equal(cols, srgb_bytes(deviation_colors(d, 0.05)[:, :3]))
    assert (cols[a:b] == legend_colors()["ok"]).all()
    assert (cols[a - 1] == legend_colors()["gouge"]).all() and (cols[b] == legend_colors()["stock"]).all()
    lay = legend_layout(640, 400)
    x0, y0, x1, y1 = lay["bar"]
    gx0, gy0, gx1, gy1 = lay["region"]
    assert 0 < x0 < x1 < 640 and gy1 < y0 < y1 < 400 and 0 < gy0 < gy1


def test_report_geometry_errors_are_signed_distances(plan_file, geo):
    _, plan = plan_file
    assert len(geo["strips"]) == len(plan["strips"])
    d = np.concatenate([s[2] for s in geo["strips"]])
    # collision-free hard-mode strips: the envelopes lie on or outside the whole rotor, and on it where they cut
    # (1e-5 R: the report measures against the spline through the plan's 2048 profile samples)
    assert d.min() > -1e-5 and np.quantile(d, 0.1) < 1e-3
    assert geo["tolerance"] == plan["tolerance"] and geo["max_error"] == plan["summary"]["max_error"]
    # drawn strips: on the surface (never inside), 0.2 % R above it
    v, f, d, n = geo["strips"][0]
    from flank_addon.io.plan import plan_surface

    shown = plan_surface(plan).foot_points(display_strip(v, d, n, 1.0)[:300]).distance
    assert np.allclose(shown, np.maximum(d[:300], 0.0) + 2e-3, atol=1e-6)


def test_view_faces_the_strips(geo):
    w = choose_view(geo["strips"], geo["outer_radius"], geo["occluders"])
    assert abs(np.linalg.norm(w) - 1.0) < 1e-12
    N = np.concatenate([s[3] for s in geo["strips"]])
    assert np.mean(N @ w > 0.2) > 0.4                                         # most of the strip area faces us


def test_render_cli_writes_the_report(plan_file, tmp_path, capsys):
    pytest.importorskip("bpy")
    p, plan = plan_file
    out = tmp_path / "report.png"
    assert main(["render", str(p), "--out", str(out), "--resolution", "640", "400", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    px = read_png(out)
    assert px.shape == (400, 640, 4)
    assert json.loads(read_png_text(out)[REPORT_KEY])["title"] == info["title"]
    # the legend bar: exactly the strips' colour function over -10 .. +10 tolerances
    x0, y0, x1, y1 = info["legend"]["bar"]
    assert np.array_equal(px[y0:y1, x0:x1, :3], np.broadcast_to(bar_colors(x1 - x0, 1e-3), (y1 - y0, x1 - x0, 3)))
    # above it, each band's full colour over its part of the bar
    ly0, ly1 = info["legend"]["band_rows"]
    s0, s1 = info["legend"]["split"]
    assert ly1 - ly0 >= 4 and ly1 < y0
    cols = legend_colors()
    for key, a, b in (("gouge", x0, s0 - 1), ("ok", s0 + 1, s1 - 1), ("stock", s1 + 1, x1)):
        assert np.all(cols[key] == srgb_bytes(DEVIATION_COLORS[key][:3]))
        assert (px[ly0:ly1, a:b, :3] == cols[key]).all(), key
    # the strips show up above the legend: lit pixels of the green family
    top = px[:y0 - 10, :, :3].astype(int)
    assert ((top[..., 1] > top[..., 0] + 30) & (top[..., 1] > top[..., 2] + 20)).sum() > 500
    # the title: the plan's tolerance and its max / min errors, in the plan's unit
    assert info["max_error"] == plan["summary"]["max_error"] and info["min_error"] == plan["summary"]["min_error"]
    line = info["title"][1]
    assert "tolerance ±0.001 R" in line and "{} strips".format(len(plan["strips"])) in line
    assert "max error " + format_length(plan["summary"]["max_error"], "R") in line
    assert "min error " + format_length(plan["summary"]["min_error"], "R") in line
    assert [t["text"] for t in info["legend"]["ticks"]] == ["-0.01 R", "-0.001 R", "0 R", "+0.001 R", "+0.01 R"]
    assert info["title"][0] == "plan.json: " + plan["method"]


def test_overcut_strips_are_red_and_drawn(plan_file, tmp_path, capsys):
    """Tools 5 tolerances too fat overcut the flank: the report must show it (red, never hidden in the body)."""
    pytest.importorskip("bpy")
    _, plan = plan_file
    fat = json.loads(json.dumps(plan))
    for s in fat["strips"]:
        s["radii"] = [r + 5e-3 for r in s["radii"]]
    d = np.concatenate([s[2] for s in report_geometry(fat)["strips"]])
    assert d.min() < -4e-3                                                    # the envelopes cut into the rotor
    p, out = tmp_path / "fat.json", tmp_path / "fat.png"
    write_plan(p, fat)
    assert main(["render", str(p), "--out", str(out), "--resolution", "480", "300", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    top = read_png(out)[:info["legend"]["band_rows"][0] - 10, :, :3].astype(int)
    red = (top[..., 0] > top[..., 1] + 40) & (top[..., 0] > top[..., 2] + 40)
    assert red.sum() > 300


@pytest.mark.parametrize("width,height,limit", [(1280, 800, 256000), (1281, 799, 100000), (401, 803, 40000),
                                                (64, 8192, 100000), (97, 61, 1), (640, 400, 256000)])
def test_render_tiles_cover_the_picture_once(width, height, limit):
    tiles = render_tiles(width, height, limit)
    count = np.zeros((height, width), int)
    for x0, y0, x1, y1 in tiles:
        assert 0 <= x0 < x1 <= width and 0 <= y0 < y1 <= height
        assert (x1 - x0) * (y1 - y0) <= limit
        count[y0:y1, x0:x1] += 1
    assert (count == 1).all()
    w = {x1 - x0 for x0, _, x1, _ in tiles}
    h = {y1 - y0 for _, y0, _, y1 in tiles}
    assert max(w) - min(w) <= 1 and max(h) - min(h) <= 1, (w, h)
    # no more tiles than needed: a grid with one column or one row fewer would exceed the limit
    nx, ny = len({t[0] for t in tiles}), len({t[1] for t in tiles})
    assert len(tiles) == nx * ny

    def fits(columns, rows):
        return -(-width // columns) * -(-height // rows) <= limit
    assert (nx == 1 or not fits(nx - 1, ny)) and (ny == 1 or not fits(nx, ny - 1)), (nx, ny)


def test_tile_camera_keeps_every_pixel_centre():
    """Blender's orthographic frame: the larger side spans the ortho scale, the shift is measured in it.  Each
    tile's pixel centres, placed by its own camera, are the picture's pixel centres."""
    width, height, ortho = 1281, 799, 3.7

    def centre(i, j, w, h, scale, sx, sy):        # pixel (column i, row j from the top) -> view-plane point
        p = scale / max(w, h)
        return sx * scale + (i + 0.5 - 0.5 * w) * p, sy * scale + (0.5 * h - j - 0.5) * p

    for tile in render_tiles(width, height, 40000) + [(0, 0, width, height)]:
        w, h, scale, sx, sy = tile_camera(tile, width, height, ortho)
        x0, y0, x1, y1 = tile
        assert (w, h) == (x1 - x0, y1 - y0)
        for i, j in ((0, 0), (w - 1, h - 1), (w // 2, 0), (0, h - 1)):
            a = centre(i, j, w, h, scale, sx, sy)
            b = centre(x0 + i, y0 + j, width, height, ortho, 0.0, 0.0)
            assert abs(a[0] - b[0]) < 1e-12 and abs(a[1] - b[1]) < 1e-12, (tile, i, j, a, b)
    assert tile_camera((0, 0, width, height), width, height, ortho) == (width, height, ortho, 0.0, 0.0)
    with pytest.raises(ValueError, match="0 x 10"):
        render_tiles(0, 10)


def test_air_parts_are_not_drawn():
    v = np.zeros((5, 3))
    n = np.tile([0.0, 0.0, 1.0], (5, 1))
    d = np.array([0.0, 0.5, 0.5, -0.3, 0.5])
    f = np.array([[0, 1, 2], [1, 2, 4], [3, 1, 4]])
    pv, pf, pd, pn = strip_part(v, f, d, n, air_limit(1e-3, 1.0))                 # limit 0.01
    assert air_limit(1e-3, 1.0) == pytest.approx(0.01) and air_limit(0.01, 1.0) == pytest.approx(0.1)
    assert pf.tolist() == [[0, 1, 2], [3, 1, 4]] and pd.tolist() == [0.0, 0.5, 0.5, -0.3, 0.5]
    pv, pf, pd, pn = strip_part(v, f[1:2], d, n, 0.01)                            # all vertices in the air
    assert len(pf) == 0 and len(pv) == 0


def test_render_cli_bad_input(plan_file, tmp_path, capsys):
    p, _ = plan_file
    assert main(["render", str(p), "--out", str(tmp_path / "no" / "r.png")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main(["render", str(p), "--out", str(tmp_path / "r.png"), "--resolution", "10", "10"]) == 2
    assert "outside the limits 64..8192" in capsys.readouterr().err
    assert main(["render", str(p), "--out", str(tmp_path)]) == 2
    assert "is a folder" in capsys.readouterr().err
    assert main(["render", str(p), "--out", str(tmp_path / "r.png"), "--tolerance", "nan"]) == 2
    assert "must be a positive number" in capsys.readouterr().err
    assert main(["render", str(tmp_path / "missing.json"), "--out", str(tmp_path / "r.png")]) == 2
    assert "missing.json" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
