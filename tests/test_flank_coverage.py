"""Whole-flank coverage of the single-flank conical planner: adaptive strips, smaller tools never cover less."""
import math
import re

import numpy as np
import pytest

from flank_addon.methods.single_flank.planner import plan_single_flank
from flank_addon.tooling.cone import ConeTool
from flank_addon.tooling.presets import presets_by_name

R_MM = 30.0                    # the built-in rotors (outer radius 1) read as 30 mm rotors
TOL = 0.05 / R_MM


def shrunk(tool, d):
    """The cone whose inscribed spheres (and shank) are ``d`` thinner, same axis length: it fits inside ``tool``
    touching it wherever it is moved by d along a surface normal."""
    c = d * math.cos(tool.alpha)
    return ConeTool(tool.alpha, tool.r1c - c, tool.r2c - c, tool.shank_radius - d, tool.shank_length)


@pytest.fixture(scope="module")
def male_d4(asym_male):
    """Male flank 0 (tip to the valley's small bottom fillet) with the 3 deg D4 L20 end mill and the same cone
    1 mm thinner: plans with the planner's defaults."""
    r, s = asym_male
    big = presets_by_name(["Tapered 3deg D4 L20"])[0].tool(R_MM)
    small = shrunk(big, 1.0 / R_MM)
    return r, s, [plan_single_flank(s, r.flanks, 0, t, TOL) for t in (big, small)]


def test_a_smaller_tool_never_covers_less_male_bottom(male_d4):
    r, s, (big, small) = male_d4
    assert 0.5 < big.covered_fraction < 0.99            # the larger cone cannot reach the valley bottom
    assert small.covered_fraction >= big.covered_fraction
    # the thinner cone gets deeper into the valley: the uncovered bottom range starts later
    assert small.uncovered[-1][0] > big.uncovered[-1][0]
    for res in (big, small):
        assert not res.verify["gouge_points"] and res.verify["max_overcut"] >= -1e-6


def test_a_smaller_tool_never_covers_less_female(female_plan, female):
    """The female flank is covered completely by the test cone; a cone 0.02 R thinner (0.6 mm at R = 30 mm)
    needs more strips and still covers all of it (with a fixed count of seeds it did not)."""
    r, s = female
    _, big = female_plan
    tool = ConeTool(math.asin(0.1), 0.05, 0.08, 0.04, 0.6)
    small = plan_single_flank(s, r.flanks, 1, shrunk(tool, 0.02), 1e-3)
    assert big.covered_fraction == 1.0
    assert small.covered_fraction >= big.covered_fraction
    assert len(small.strips) > len(big.strips)
    assert not small.verify["gouge_points"]


# ---------------------------------------------------------------- the residual, stated
def test_covered_fraction_is_the_verified_share_of_the_arc_length(male_d4):
    """covered_fraction comes from the sweep simulation: recomputed here from an independent verify_plan run
    (arc-length weights of the plan's own profile) and from a 4x denser sweep of the flank."""
    from flank_addon.simulation.sweep import machined_deviation, tool_of
    from flank_addon.simulation.verify import verify_plan

    r, s, (big, _) = male_d4
    plan = big.plan
    assert plan["summary"]["covered_fraction"] == big.covered_fraction
    v = verify_plan(plan, tolerance=1e-6)
    prof = np.asarray(plan["rotor"]["profile"])
    a, b = plan["rotor"]["flanks"][0]
    idx = np.arange(a, b + 1) % len(prof)
    dev = {i: (np.inf if d is None else d) for i, _, _, d in v["deviation_profile"]}
    d = np.array([dev[i] for i in idx])
    mids = 0.5 * (prof[idx][1:] + prof[idx][:-1])
    seg = np.linalg.norm(np.diff(prof[idx], axis=0), axis=1)
    ok = (d <= TOL) & (d >= -plan["overcut_tolerance"])
    share = (np.sum(seg * 0.5 * (ok[1:].astype(float) + ok[:-1])) / seg.sum())
    assert big.covered_fraction == pytest.approx(share, abs=1e-12)
    # a denser independent sweep of the same strips agrees within a point
    u0, u1 = r.flanks[0]
    u = np.linspace(u0, u1, 4 * len(idx))
    pts, nrm = s.profile.eval(u), s.profile.outward_normal(u)
    dd = machined_deviation([tool_of(st, with_shank=True) for st in plan["strips"]], pts, nrm, s.v0, s.handedness,
                            max_deviation=0.1)
    arc = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))]
    okd = (dd <= TOL) & (dd >= -plan["overcut_tolerance"])
    dense = np.sum(np.diff(arc) * 0.5 * (okd[1:].astype(float) + okd[:-1])) / arc[-1]
    assert abs(dense - big.covered_fraction) < 0.01


def test_uncovered_ranges_carry_their_reason_and_the_proven_bound(male_d4):
    """The valley bottom the D4 cone leaves: the reason names the collision, and the part where no cone of
    tip sphere >= 2 mm can come within the tolerance without entering the rotor is stated with its depth.
    The bound is checked by brute force: balls of that radius around the bottom points, centres on 20000
    directions, exact signed distances to the whole rotor (foot points): none has the room the bound denies."""
    from flank_addon.methods.single_flank.poses import RotorClearance
    from flank_addon.methods.single_flank.reach import room_bound

    r, s, (big, _) = male_d4
    summ = big.plan["summary"]["uncovered"]
    assert summ and all({"u_range", "arc_range", "index_range", "kind", "reason", "bound"} <= set(x) for x in summ)
    bottom = summ[-1]
    assert bottom["u_range"][1] == pytest.approx(r.flanks[0][1], abs=1e-3)
    assert "collides" in bottom["reason"] and "proven" in bottom["reason"]
    bd = bottom["bound"]
    assert bd["proven"] and bd["depth_min"] > 0
    tool = big.plan["tool"]
    r1s = tool["r1c"] / math.cos(tool["alpha"])
    assert bd["radius"] == pytest.approx(r1s)
    slack = TOL + big.plan["overcut_tolerance"]
    u = np.linspace(bd["u_range"][0], bd["u_range"][1], 4)
    rb = room_bound(s, u, r1s, slack)
    assert rb.proven.all()
    feet = RotorClearance.for_tool(s, r.flanks[0], ConeTool(tool["alpha"], tool["r1c"], tool["r2c"])).feet
    rng = np.random.default_rng(3)
    w = rng.normal(size=(20000, 3))
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    for ui, g_up in zip(u, rb.g_up):
        p = np.r_[s.profile.eval(np.array([ui]))[0], 0.0]
        c = p + r1s * w
        ft = feet(c)
        outside = np.einsum("ij,ij->i", c - ft.point, s.normal(ft.u, ft.t)) > 0
        sd = np.where(outside, ft.distance, -ft.distance)
        assert sd.max() <= g_up + 1e-9
        assert sd.max() < r1s - slack
    # not vacuous: where the plan mills the flank the bound proves nothing
    mid = 0.5 * (r.flanks[0][0] + bottom["u_range"][0])
    assert not room_bound(s, np.array([mid]), r1s, slack).proven.any()


# ---------------------------------------------------------------- several tools
def test_plan_files_carry_a_tool_per_strip(tmp_path, female_plan):
    """A strip may carry its own tool (same form as the plan's); old plans without one stay valid; a bad strip
    tool is refused by name."""
    import copy
    import json

    from flank_addon.io.plan import PlanError, plan_tools, read_plan, strip_tool, validate_plan, write_plan

    _, res = female_plan
    plan = copy.deepcopy(res.plan)
    assert all("tool" not in st for st in plan["strips"]) and plan_tools(plan) == [(plan["tool"],
                                                                                   list(range(len(plan["strips"]))))]
    other = dict(plan["tool"], r1c=0.03, name="thin")
    plan["strips"][1]["tool"] = other
    path = tmp_path / "p.json"
    write_plan(path, plan)
    back = read_plan(path)
    assert strip_tool(back, 1) == other and strip_tool(back, 0) == back["tool"]
    n = len(back["strips"])
    assert plan_tools(back) == [(back["tool"], [0] + list(range(2, n))), (other, [1])]
    for bad, msg in (({"kind": "drill"}, "strips[1].tool.kind must be one of"),
                     (dict(other, r1c=0.2), "strips[1].tool must have 0 < alpha < pi/2 and 0 <= r1c < r2c"),
                     (dict(other, name=3), "strips[1].tool.name must be a string")):
        plan["strips"][1]["tool"] = bad
        with pytest.raises(PlanError, match=re.escape(msg)):
            validate_plan(json.loads(json.dumps(plan)))


def test_automatic_selection_takes_the_largest_admissible_then_what_finishes(male_d4):
    """On the male flank every preset can mill its upper part; the valley bottom admits only small tip spheres.
    First pick: the largest preset whose tip sphere the bound admits on at least half as much of the flank as
    the best one's (the D12 cylinder); for the bottom range: the largest that is admissible all along it."""
    from flank_addon.methods.single_flank.planner import _pick_tool
    from flank_addon.tooling.presets import load_presets

    r, s, _ = male_d4
    tools = [(p.name, p.tool(R_MM)) for p in load_presets()]
    pool = list(range(len(tools)))
    ti, rec = _pick_tool(s, tools, pool, [r.flanks[0]], TOL + 1e-6, first=True)
    assert tools[ti][0] == "Cylindrical D12 L26" and rec["best"] == 1.0 and 0.5 <= rec["share"] < 1.0
    bottom = [(0.75, r.flanks[0][1])]
    ti, rec = _pick_tool(s, tools, pool, bottom, TOL + 1e-6, first=False)
    assert rec["share"] == rec["best"] == 1.0
    shares = {k: v for k, v in rec["share_by_tip_sphere"].items()}
    assert tools[ti][1].r1s <= min(float(k) for k, v in shares.items() if v == 1.0) * 1.01
    assert all(v < 1.0 for k, v in shares.items() if float(k) > 2 * tools[ti][1].r1s)


def test_cli_named_tools(tmp_path, capsys, male_d4):
    """--tools NAME1,NAME2 on a built-in (its outer radius in mm): strips of both, each naming its tool, the
    plan's tool the first; the summary's covered fraction is the plan's and verify, export and check-plan read
    the file."""
    import json

    from flank_addon.cli import main
    from flank_addon.io.plan import read_plan

    out = tmp_path / "two.json"
    names = "Tapered 3deg D4 L20,Tapered 1deg D1 L10"
    assert main(["plan", "single-flank", "--builtin", "asymmetric-male", "--flank", "0", "--tools", names,
                 "--outer-radius-mm", str(R_MM), "--tolerance", f"{TOL:.12g}", "--out", str(out), "--json"]) == 0
    summ = json.loads(capsys.readouterr().out)
    plan = read_plan(out)
    used = {st["tool"]["name"] for st in plan["strips"]}
    assert used == set(names.split(",")) and plan["tool"]["name"] == "Tapered 3deg D4 L20"
    assert [row["name"] for row in summ["tools"]] == names.split(",")
    assert [p["tool"] for p in summ["per_strip"]] == [st["tool"]["name"] for st in plan["strips"]]
    assert summ["covered_fraction"] == plan["summary"]["covered_fraction"]
    _, _, (big, _) = male_d4
    assert summ["covered_fraction"] > big.covered_fraction + 0.05        # the D1 mills below the D4
    assert plan["tool"]["r1c"] == pytest.approx(2.0 / R_MM)
    assert main(["export", str(out), "--cl", str(tmp_path / "two.apt"), "--steps", "2"]) == 0
    assert (tmp_path / "two.apt").read_text().count("LOADTL/") >= 2
    capsys.readouterr()
    assert main(["verify", str(out), "--json"]) == 0
    v = json.loads(capsys.readouterr().out)
    assert not v["gouge_points"]
    assert [vs["tool"] for vs in v["strips"]] == [st["tool"]["name"] for st in plan["strips"]]


@pytest.mark.parametrize("extra, msg", [
    (["--tools", "Tapered 9deg D1 L1"], "no tool preset 'Tapered 9deg D1 L1'; presets: Cylindrical D10 L22"),
    (["--tools", "auto", "--tool-r1", "0.02"], "--tools takes the cones from the presets: drop --tool-r1"),
    (["--tools", "Tapered 3deg D4 L20,Tapered 3deg D4 L20"], "tool preset 'Tapered 3deg D4 L20' is named twice"),
    (["--tools", "auto", "--outer-radius-mm", "-5"], "argument --outer-radius-mm: -5 is not a finite number > 0"),
    (["--tool-r1", "0.05", "--tool-r2", "0.08", "--tool-alpha", "0.1", "--max-tools", "2"],
     "--max-tools applies to --tools auto"),
    (["--tool-r1", "0.05", "--tool-r2", "0.08", "--tool-alpha", "0.1", "--outer-radius-mm", "30"],
     "--outer-radius-mm applies to --tools"),
])
def test_cli_tool_errors(tmp_path, capsys, extra, msg):
    from flank_addon.cli import main

    rc = main(["plan", "single-flank", "--builtin", "asymmetric-male", "--flank", "0", "--tolerance", "1e-3",
               "--out", str(tmp_path / "x.json")] + extra)
    err = capsys.readouterr().err
    assert rc == 2 and err.startswith("error: ") and msg in err, err
    assert not (tmp_path / "x.json").exists()


# ---------------------------------------------------------------- acceptance from a rotor mesh
def test_auto_tools_from_a_rotor_mesh_cover_the_flank(tmp_path, capsys):
    """A right-handed male (30 mm, 60 mm long) with end shafts in a random pose, as STL; plan single-flank --mesh
    --flank-point --tools auto --tolerance 0.05.  The true flank (the built-in's exact profile carried through the
    pose into the plan's frame), swept by the plan's strips: >= 95 % of its arc length within [-1 um, 0.05 mm],
    nothing deeper; the plan's covered_fraction within a point of it; verify finds no gouge on the whole rotor."""
    import json

    from scipy.spatial.transform import Rotation

    from flank_addon.cli import main
    from flank_addon.geometry.rotors import builtin_by_name
    from flank_addon.geometry.screw import screw_motion, screw_to_plane
    from flank_addon.io.mesh_files import write_mesh
    from flank_addon.io.plan import read_plan
    from flank_addon.simulation.sweep import StripTool, machined_deviation
    from flank_addon.simulation.verify import verify_plan
    from helpers import cad_like

    rotor = builtin_by_name("srm_a-male", scale=30.0, length=60.0)
    assert rotor.handedness == "right"
    v, f = cad_like(rotor, n_profile=1500, n_axial=40)
    rot, shift = Rotation.random(random_state=5).as_matrix(), np.array([-20.0, 35.0, 15.0])
    write_mesh(tmp_path / "m.stl", v @ rot.T + shift, f)
    a, b = rotor.flanks[1]
    p = np.r_[rotor.profile.eval(np.array([a + 0.4 * (b - a)]))[0], 0.0]
    point = screw_motion(p, 17.0 / rotor.v0, rotor.v0, rotor.handedness) @ rot.T + shift
    out = tmp_path / "plan.json"
    assert main(["plan", "single-flank", "--mesh", str(tmp_path / "m.stl"), "--flank-point=" + ",".join(
        f"{x:.6f}" for x in point), "--tools", "auto", "--tolerance", "0.05", "--out", str(out), "--json"]) == 0
    summ = json.loads(capsys.readouterr().out)
    plan = read_plan(out)
    assert summ["covered_fraction"] >= 0.95 and summ["gouge_points"] == 0
    assert not verify_plan(plan, tolerance=0.05)["gouge_points"]
    u = np.linspace(a, b, 1500)
    model = np.c_[rotor.profile.eval(u), np.zeros(len(u))] @ rot.T + shift
    T = np.linalg.inv(np.asarray(plan["rotor"]["to_world"]))
    r = plan["rotor"]
    q0 = screw_to_plane(model @ T[:3, :3].T + T[:3, 3], r["v0"], r["handedness"])
    t = np.gradient(q0, axis=0)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    d = machined_deviation([StripTool.from_strip(s) for s in plan["strips"]], q0, np.c_[t[:, 1], -t[:, 0]],
                           r["v0"], r["handedness"], max_deviation=3.0)
    seg = np.linalg.norm(np.diff(q0, axis=0), axis=1)
    ok = (d <= 0.05) & (d >= -1e-3)
    share = np.sum(seg * 0.5 * (ok[1:].astype(float) + ok[:-1])) / seg.sum()
    assert share >= 0.95 and d.min() >= -1e-3
    assert abs(share - summ["covered_fraction"]) <= 0.01


# ---------------------------------------------------------------- hyperbolic / elliptic split
def test_split_plans_each_part_with_its_own_initialisation(female):
    """Examples 6.5/6.6: the elliptic part of the female flank 1 (towards the lobe tip) planned in its own run:
    the parts follow the sign of the Gaussian curvature, every seed lies in the part and starts in tangential
    contact along the least curved principal direction, and the summary's share of the part is the verified one."""
    from flank_addon.methods.single_flank.planner import curvature_parts
    from flank_addon.methods.single_flank.poses import principal_frame
    from flank_addon.simulation.verify import verify_plan

    r, s = female
    ur = r.flanks[1]
    parts = curvature_parts(s, ur)
    (ea, eb), = parts["elliptic"]
    assert parts["hyperbolic"] == [(ur[0], ea)] and eb == ur[1]
    u = np.linspace(ur[0], ur[1], 400)[1:-1]
    K = s.curvatures(u)["K"]
    assert (K[u < ea - 0.01] < 0).all() and (K[u > ea + 0.01] >= -1e-3).all()
    tool = ConeTool(math.asin(0.1), 0.05, 0.08, 0.04, 0.6)
    res = plan_single_flank(s, r.flanks, 1, tool, 1e-3, split="elliptic")
    seeds = [c.seed for c in res.candidates]
    assert seeds and all(ea - 1e-9 <= sd.u <= eb + 1e-9 for sd in seeds)
    for sd in seeds:
        if sd.rank >= 0:                       # a seed of Section 5.1: tangential, along the least curved direction
            fr = principal_frame(s, np.array([sd.u]))
            k = np.array([fr.k1[0], fr.k2[0]])
            e = (fr.e1[0], fr.e2[0])[int(np.argmin(np.abs(k)))]
            g = sd.pose.axis - math.sin(tool.alpha) * fr.normal[0]
            assert sd.contact == 1 and abs(abs(g @ e) / np.linalg.norm(g) - 1.0) < 1e-9
    sp = res.plan["summary"]["split"]
    assert sp["part"] == "elliptic" and sp["u_ranges"] == [[ea, eb]]
    v = verify_plan(res.plan, tolerance=1e-6)
    prof = np.asarray(res.plan["rotor"]["profile"])
    a, b = res.plan["rotor"]["flanks"][1]
    n, per = len(prof), s.profile.period
    dev = {i: (np.inf if d is None else d) for i, _, _, d in v["deviation_profile"]}
    idx = np.arange(a, b + 1)
    inside = (idx * per / n >= ea) & (idx * per / n <= eb)
    seg = np.linalg.norm(np.diff(prof[idx % n], axis=0), axis=1)
    w = 0.5 * (np.r_[seg, 0] + np.r_[0, seg])
    ok = np.array([-1e-6 <= dev[i % n] <= 1e-3 for i in idx])
    assert sp["covered_fraction"] == pytest.approx(w[inside & ok].sum() / w[inside].sum(), abs=1e-12)
    assert sp["covered_fraction"] > 0.95


def test_scaling_a_plan_scales_its_tools_and_residual(male_d4):
    """Plans in units of R go to mm for the machine (machining.rotor_body.scale_plan): strip tools, the residual's
    lengths and its bound scale with the rotor; parameters and fractions do not."""
    import copy

    from flank_addon.machining.rotor_body import scale_plan

    _, _, (big, _) = male_d4
    plan = copy.deepcopy(big.plan)
    plan["strips"][0]["tool"] = dict(plan["tool"], name="again")
    mm = scale_plan(plan, R_MM)
    assert mm["strips"][0]["tool"]["r1c"] == pytest.approx(2.0) and mm["tool"]["h"] == pytest.approx(20.0)
    a, b = plan["summary"]["uncovered"][-1], mm["summary"]["uncovered"][-1]
    assert b["u_range"] == a["u_range"] and mm["summary"]["covered_fraction"] == plan["summary"]["covered_fraction"]
    assert b["arc_range"] == pytest.approx([x * R_MM for x in a["arc_range"]])
    assert b["bound"]["radius"] == pytest.approx(a["bound"]["radius"] * R_MM)
    assert b["bound"]["depth_min"] == pytest.approx(a["bound"]["depth_min"] * R_MM)
    assert plan["strips"][0]["tool"]["r1c"] == pytest.approx(2.0 / R_MM)          # the original is untouched
