"""Exports (flank_addon.exports): CL data, error profile CSV, strip envelopes and the export CLI."""
import math
import re

import numpy as np
import pytest

from flank_addon.cli import main
from flank_addon.tooling.cone import ConeTool
from flank_addon.exports import cl_data, error_profile_csv, strip_mesh, write_strip_meshes
from flank_addon.io.mesh_files import read_ply, read_stl
from flank_addon.geometry.screw import screw_motion, screw_to_plane
from flank_addon.simulation.sweep import StripTool, helical_distance
from flank_addon.simulation.verify import verify_plan

CONE = ConeTool(math.asin(0.1), 0.05, 0.08, 0.04, 0.6)
GOTO = re.compile(r"^GOTO/([^ ]+) \$\$ A=([^ ]+) FEED=([^ ]+)$")


@pytest.fixture(scope="module")
def single(female):
    from flank_addon.methods.single_flank.planner import plan_single_flank

    r, s = female
    return plan_single_flank(s, r.flanks, 1, CONE, 2e-3, n_seeds=6, max_rounds=1).plan


@pytest.fixture(scope="module")
def double(builtin):
    from flank_addon.methods.double_flank.planner import plan_double_flank

    r, s = builtin("nilson-male")
    return plan_double_flank(s, r.flanks, m=100, simulate=False).plan


def parse_cl(text):
    """{strip: (xyzijk (N, 6), angle_deg (N,), feed (N,))} from the CL text."""
    out, cur = {}, None
    for line in text.splitlines():
        m = re.match(r"^\$\$ STRIP (\d+) ", line)
        if m:
            cur = int(m.group(1))
            out[cur] = ([], [], [])
            continue
        m = GOTO.match(line)
        if m:
            assert cur is not None
            out[cur][0].append([float(v) for v in m.group(1).split(",")])
            out[cur][1].append(float(m.group(2)))
            out[cur][2].append(float(m.group(3)))
    return {k: tuple(np.array(v) for v in vals) for k, vals in out.items()}


def expected_tip(plan, strip):
    """Independent tip: the cone's tip circle centre (Bizzarri, Bo & Bartoň Eq. 2), or the meridian's first row."""
    p0, p1 = np.array(strip["axis_start"]), np.array(strip["axis_end"])
    a = (p1 - p0) / np.linalg.norm(p1 - p0)
    if strip.get("meridian") is not None:
        return p0 + strip["meridian"][0][0] * a, a
    assert plan["tool"]["kind"] == "cone"
    return p0 - CONE.r1c * math.tan(CONE.alpha) * a, a


@pytest.mark.parametrize("which", ["single", "double"])
@pytest.mark.usefixtures("single", "double")    # looked up by name below; listed so both run on one worker
def test_cl_steps_screw_back_to_the_plan_axis(which, request):
    plan = request.getfixturevalue(which)
    v0, hand = plan["rotor"]["v0"], {"right": 1, "left": -1}[plan["rotor"]["handedness"]]
    z0, z1, n = -0.3, 1.1, 12
    text = cl_data(plan, steps=n, z_range=(z0, z1))
    assert text.startswith("$$") and text.rstrip().endswith("FINI")
    cl = parse_cl(text)
    assert sorted(cl) == list(range(len(plan["strips"])))
    for k, strip in enumerate(plan["strips"]):
        xyzijk, ang, feed = cl[k]
        assert xyzijk.shape == (n + 1, 6)
        P, A = xyzijk[:, :3], xyzijk[:, 3:]
        T, a = expected_tip(plan, strip)
        # the tip's rotor-frame z runs from Z1 down to Z0 in equal steps
        assert np.allclose(P[:, 2], np.linspace(z1, z0, n + 1), atol=1e-9)
        t = (T[2] - P[:, 2]) / v0                        # the screw time of each step
        assert np.allclose(np.radians(ang), hand * t, atol=1e-9)
        assert np.allclose(feed, np.r_[0.0, v0 * np.diff(t)], atol=1e-9)
        assert np.allclose(feed[1:], (z1 - z0) / n, atol=1e-9)
        assert np.allclose(np.linalg.norm(A, axis=1), 1.0, atol=1e-9)
        # moved back by S_t (the rotor's motion in the plan), the tool is the plan's tool
        assert np.allclose(screw_motion(P, t, v0, plan["rotor"]["handedness"]), T, atol=1e-8)
        assert np.allclose(screw_motion(A, t, 0.0, plan["rotor"]["handedness"]), a, atol=1e-8)
        # rotor turned by A: the tip is at the plan's x, y, lowered by the accumulated feed
        c, s = np.cos(np.radians(ang)), np.sin(np.radians(ang))
        machine = np.c_[c * P[:, 0] - s * P[:, 1], s * P[:, 0] + c * P[:, 1], P[:, 2]]
        assert np.allclose(machine, T - np.c_[0 * t, 0 * t, np.cumsum(feed) + (T[2] - z1)], atol=1e-8)


def test_cl_one_strip_default_range_and_header(single):
    text = cl_data(single, strip=2, steps=8)
    cl = parse_cl(text)
    assert list(cl) == [2]
    lead = 2 * math.pi * single["rotor"]["v0"]
    assert np.allclose(cl[2][0][[0, -1], 2], [lead, 0.0], atol=1e-9)
    assert "tolerance: 0.002" in text and "MULTAX/ON" in text and "alpha=" in text
    for bad in (dict(strip=5), dict(steps=0), dict(z_range=(1.0, 0.0))):
        with pytest.raises(ValueError):
            cl_data(single, **{"steps": 8, **bad})
    with pytest.raises(ValueError, match=r"z range 1e\+06,2e\+06 reaches beyond 1e4 x the outer radius"):
        cl_data(single, steps=8, z_range=(1e6, 2e6))


def test_cl_z_range_must_come_near_the_rotor_body(single):
    """With the rotor's extent known, a tool tip range that never comes within an outer radius of the body is
    refused; one that overlaps that margin is written."""
    plan = dict(single, rotor=dict(single["rotor"], extent={"z_range": [0.0, 3.0], "shafts": []}))
    R = plan["rotor"]["outer_radius"]
    with pytest.raises(ValueError, match=r"misses the rotor: its body spans z = 0 .. 3"):
        cl_data(plan, steps=8, z_range=(3.0 + 1.01 * R, 10.0))
    assert "GOTO" in cl_data(plan, steps=8, z_range=(3.0 + 0.99 * R, 10.0))
    # a range that overlaps the body but reaches a million outer radii is of no rotor either (it wrote GOTOs at 1e300)
    with pytest.raises(ValueError, match=r"reaches beyond 1e4 x the outer radius"):
        cl_data(plan, steps=8, z_range=(0.0, 1e300))


def test_error_csv_equals_verify_profile(single):
    ver = verify_plan(single, tolerance=single["tolerance"])
    for text in (error_profile_csv(ver), error_profile_csv(single)):
        lines = text.strip().splitlines()
        assert lines[0] == "index,x,y,deviation"
        rows = [ln.split(",") for ln in lines[1:]]
        assert len(rows) == len(ver["deviation_profile"]) > 100
        for row, (i, x, y, d) in zip(rows, ver["deviation_profile"]):
            assert int(row[0]) == i and float(row[1]) == x and float(row[2]) == y
            assert (row[3] == "") if d is None else float(row[3]) == pytest.approx(d, abs=1e-12)


@pytest.mark.parametrize("which", ["single", "double"])
@pytest.mark.usefixtures("single", "double")
def test_envelope_lies_on_the_swept_tool(which, request):
    plan = request.getfixturevalue(which)
    rot = plan["rotor"]
    v0, hand, R = rot["v0"], rot["handedness"], rot["outer_radius"]
    rng = np.random.default_rng(1)
    for k, strip in enumerate(plan["strips"][:3]):
        z_range = (0.2, 0.9)
        verts, faces = strip_mesh(plan, k, n_s=40, n_t=25, z_range=z_range)
        assert len(verts) and faces.max() < len(verts)
        tool = StripTool.from_strip(strip, with_shank=False)
        # the row of time samples: vertex (j, i) = S_{-t_i}(c_j), t_i the CL times of z_range
        T = verts.reshape(-1, 25, 3)
        tip_z = cl_data(plan, strip=k, steps=24, z_range=z_range)
        t = np.radians(parse_cl(tip_z)[k][1]) * (1 if hand == "right" else -1)
        back = screw_motion(T, t[None, :], v0, hand)            # S_t brings each vertex onto the tool
        assert np.abs(tool.signed_distance(back.reshape(-1, 3))).max() < 1e-9 * R
        assert np.allclose(back, back[:, :1], atol=1e-9)        # one characteristic point per row
        # tangency: no screw time takes a vertex inside the tool (it is on the envelope)
        sel = rng.choice(len(verts), 200, replace=False)
        D, _ = helical_distance(tool, verts[sel], v0, hand)
        assert np.abs(D).max() < 1e-6 * R
        # the chosen side faces the rotor: its characteristic reaches the profile
        xy = screw_to_plane(back[:, 0], v0, hand)
        prof = np.asarray(rot["profile"])
        d = np.linalg.norm(xy[:, None] - prof[None], axis=-1).min(axis=1)
        assert np.quantile(d, 0.25) < 0.01 * R


def test_both_branches_and_wrong_side(single):
    v1, _ = strip_mesh(single, 0, n_s=30, n_t=5, branch=1)
    v2, _ = strip_mesh(single, 0, n_s=30, n_t=5, branch=-1)
    va, _ = strip_mesh(single, 0, n_s=30, n_t=5)
    vb, fb = strip_mesh(single, 0, n_s=30, n_t=5, branch="both")
    assert len(vb) == len(v1) + len(v2) and fb.max() < len(vb)
    assert np.array_equal(va, v1) or np.array_equal(va, v2)       # auto: one side for a single flank
    with pytest.raises(ValueError):
        strip_mesh(single, 0, branch="left")


@pytest.mark.parametrize("fmt,reader", [("stl", read_stl), ("ply", read_ply)])
def test_strip_meshes_round_trip(single, tmp_path, fmt, reader):
    paths = write_strip_meshes(single, str(tmp_path / "s"), fmt, n_s=20, n_t=9)
    assert len(paths) == len(single["strips"])
    v, f = strip_mesh(single, len(paths) - 1, n_s=20, n_t=9)
    rv, rf = reader(paths[-1])
    assert len(rf) == len(f)
    if fmt == "ply":
        assert np.array_equal(rv, v) and np.array_equal(rf, f)
    else:
        assert np.array_equal(rv[rf], v[f].astype(np.float32).astype(float))


def test_strip_meshes_are_written_all_or_none(single, tmp_path, capsys):
    """A folder in the way of the last file leaves the set as it was (no file of the new set, no temporary
    file), and the command names the file."""
    import json

    pj = tmp_path / "p.json"
    pj.write_text(json.dumps(single))
    out = tmp_path / "out"
    out.mkdir()
    (out / "s_0.stl").write_bytes(b"old")
    last = len(single["strips"]) - 1
    (out / f"s_{last}.stl").mkdir()
    capsys.readouterr()
    assert main(["export", str(pj), "--strips-stl", str(out / "s"), "--steps", "6"]) == 2
    assert f"s_{last}.stl" in capsys.readouterr().err
    assert (out / "s_0.stl").read_bytes() == b"old"
    assert sorted(p.name for p in out.iterdir()) == sorted(["s_0.stl", f"s_{last}.stl"])


def test_cli_export(single, tmp_path, capsys):
    import json

    pj = tmp_path / "p.json"
    pj.write_text(json.dumps(single))
    assert main(["export", str(pj), "--cl", str(tmp_path / "o.apt"), "--steps", "6", "--strip", "1"]) == 0
    assert (tmp_path / "o.apt").read_text() == cl_data(single, strip=1, steps=6)
    assert main(["export", str(pj), "--cl", str(tmp_path / "z.apt"), "--steps", "4", "--z-range=-0.5,0.5"]) == 0
    assert parse_cl((tmp_path / "z.apt").read_text())[0][0][0, 2] == pytest.approx(0.5)
    assert main(["export", str(pj), "--error-csv", str(tmp_path / "e.csv")]) == 0
    assert (tmp_path / "e.csv").read_text() == error_profile_csv(single)
    assert main(["export", str(pj), "--strips-ply", str(tmp_path / "m"), "--strip", "0", "--steps", "10"]) == 0
    v, f = read_ply(str(tmp_path / "m_0.ply"))
    assert len(v) == 80 * 11 and not (tmp_path / "m_1.ply").exists()
    assert main(["export", str(pj), "--strips-stl", str(tmp_path / "m")]) == 0
    assert all((tmp_path / f"m_{k}.stl").exists() for k in range(len(single["strips"])))
    capsys.readouterr()
    for bad in (["--cl", "x.apt", "--strip", "99"], ["--cl", "x.apt", "--z-range", "1"],
                ["--cl", "x.apt", "--z-range", "2,1"], ["--cl", "x.apt", "--steps", "0"]):
        assert main(["export", str(pj), *bad]) == 2
        err = capsys.readouterr().err
        assert err.startswith("error: ") and err.count("\n") == 1
    assert main(["export", str(tmp_path / "missing.json"), "--cl", "x.apt"]) == 2


def test_paraboloid_strip_envelope_and_tip(single):
    """A paraboloid lens (Doğrusadık) on a radial axis: envelope on the swept lens, tip at the lower apex."""
    import copy

    plan = copy.deepcopy(single)
    s = plan["strips"][0]
    s.update(axis_start=[0.9, 0.05, 0.1], axis_end=[1.2, 0.1, 0.15], paraboloid={"a": -8.0, "b": 0.03})
    rot = plan["rotor"]
    verts, faces = strip_mesh(plan, 0, n_s=60, n_t=9, branch="both")
    assert len(verts) > 60 * 9 and faces.max() < len(verts)
    D, _ = helical_distance(StripTool.from_strip(s, with_shank=False), verts[::3], rot["v0"], rot["handedness"])
    assert np.abs(D).max() < 1e-6 * rot["outer_radius"]
    xyz = parse_cl(cl_data(plan, strip=0, steps=3))[0][0]
    a = np.subtract(s["axis_end"], s["axis_start"]) / np.linalg.norm(np.subtract(s["axis_end"], s["axis_start"]))
    t = (s["axis_start"][2] - 0.03 * a[2] - xyz[:, 2]) / rot["v0"]
    assert np.allclose(screw_motion(xyz[:, :3], t, rot["v0"], rot["handedness"]),
                       np.asarray(s["axis_start"]) - 0.03 * a, atol=1e-8)
