"""python -m flank_addon render: the report PNG of a plan (needs bpy; the project venv has it)."""
import math

import numpy as np
import pytest

from flank_addon.cli import main
from flank_addon.cone import ConeTool
from flank_addon.multi_strip import plan_single_flank
from flank_addon.plan import write_plan
from flank_addon.report_render import format_length, legend_colors, read_png, report_geometry, srgb_bytes, write_png
from flank_addon.rotors import builtin_by_name
from flank_addon.verify import DEVIATION_COLORS


@pytest.fixture(scope="module")
def plan_file(tmp_path_factory):
    r = builtin_by_name("asymmetric-female")
    res = plan_single_flank(r.surface(), r.flanks, 1, ConeTool(math.asin(0.1), 0.05, 0.08), 2e-3, n_seeds=6,
                            max_rounds=2)
    p = tmp_path_factory.mktemp("render") / "plan.json"
    write_plan(p, res.plan)
    return p, res.plan


def test_png_round_trip_and_srgb(tmp_path):
    a = np.random.default_rng(3).integers(0, 256, (7, 5, 4), dtype=np.uint8)
    write_png(tmp_path / "x.png", a)
    assert np.array_equal(read_png(tmp_path / "x.png"), a)
    assert srgb_bytes([0.0, 1.0, 0.0031308]).tolist() == [0, 255, 10]
    assert srgb_bytes([0.5])[0] == 188                      # 1.055 * 0.5 ** (1 / 2.4) - 0.055 = 0.7354
    assert format_length(0.0004, "mm") == "+0.4 µm" and format_length(-2.5, "mm") == "-2.5 mm"
    assert format_length(0.001, "R") == "+0.001 R" and format_length(float("nan"), "R") == "n/a"


def test_report_geometry_errors_are_signed_distances(plan_file):
    _, plan = plan_file
    geo = report_geometry(plan)
    assert len(geo["strips"]) == len(plan["strips"])
    d = np.concatenate([s[2] for s in geo["strips"]])
    # collision-free hard-mode strips: the envelopes lie on or outside the whole rotor, and on it where they cut
    # (1e-5 R: the report measures against the spline through the plan's 2048 profile samples)
    assert d.min() > -1e-5 and np.quantile(d, 0.1) < 2e-3
    assert geo["tolerance"] == plan["tolerance"] and geo["max_error"] == plan["summary"]["max_error"]


def test_render_cli_writes_the_report(plan_file, tmp_path, capsys):
    pytest.importorskip("bpy")
    p, plan = plan_file
    out = tmp_path / "report.png"
    assert main(["render", str(p), "--out", str(out), "--resolution", "640", "400"]) == 0
    msg = capsys.readouterr().out
    assert "640 x 400" in msg and "max error" in msg
    px = read_png(out)
    assert px.shape == (400, 640, 4)
    flat = px[..., :3].reshape(-1, 3)
    for key, rgb in legend_colors().items():          # each legend swatch: at least a 12 x 12 px block
        assert np.all(rgb == srgb_bytes(DEVIATION_COLORS[key][:3]))
        assert (flat == rgb).all(axis=1).sum() >= 144, key
    # the strips show up: pixels of the 'within tolerance' green family beyond the swatch
    g = legend_colors()["ok"].astype(int)
    near = (np.abs(flat.astype(int) - g).max(axis=1) < 60).sum()
    assert near > (flat == g).all(axis=1).sum() + 200


def test_render_cli_bad_input(plan_file, tmp_path, capsys):
    p, _ = plan_file
    assert main(["render", str(p), "--out", str(tmp_path / "no" / "r.png")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main(["render", str(p), "--out", str(tmp_path / "r.png"), "--resolution", "10", "10"]) == 2
    assert "outside the limits 64..8192" in capsys.readouterr().err
