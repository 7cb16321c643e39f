"""From a held-out-style rotor mesh to a LinuxCNC program and back, through the command line.

A left-handed 6-lobe rotor in mm with end shafts, in an arbitrary rigid pose; a single-flank plan of one
flank (plan single-flank --mesh --flank-point); ``post PLAN --machine rotor-xa-b --post linuxcnc --mesh M
--json -o P``.  Then: LinuxCNC's interpreter reads P without error; every strip appears once per lobe; read
back and swept, the program's deviation is the plan's within 2 um, without gouges; no rapid or link enters the
stock cylinder or a shaft (checked here independently: the interpreter's moves, the rotor-xa-b contract
written out, the flat-ended cone and shank of the plan's tool); every pass starts and ends clear of the body;
the --json cutting time agrees with the interpreter's feeds within 2 %."""
import json
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from flank_addon.cli import main
from flank_addon.geometry.rotors import builtin_by_name
from flank_addon.geometry.screw import screw_motion
from flank_addon.io.mesh_files import write_mesh
from flank_addon.io.plan import read_plan
from flank_addon.machining.machine import load_machine
from flank_addon.machining.rotor_body import rotor_body
from flank_addon.posts import get_post
from flank_addon.posts.readback import verify_program
from helpers import cad_like
from machining_helpers import rs274_times, run_rs274

pytestmark = pytest.mark.xdist_group("machining")     # shared session fixtures: one worker

R_MM, LENGTH = 30.0, 60.0


def _mesh(tmp_path):
    rotor = builtin_by_name("srm_a-female", scale=R_MM, length=LENGTH)         # left-handed, 6 lobes
    assert rotor.handedness == "left"
    v, f = cad_like(rotor, n_profile=900, n_axial=24)                        # shafts r 0.35 R, 0.8 R and 1.2 R long
    rot = Rotation.random(random_state=11).as_matrix()
    shift = np.array([40.0, -25.0, 60.0])
    path = tmp_path / "rotor.stl"
    write_mesh(path, v @ rot.T + shift, f)
    p = np.r_[rotor.profile.eval(np.array([0.45 * rotor.flanks[0][1]]))[0], 0.0]
    point = screw_motion(p, 30.0 / rotor.v0, rotor.v0, rotor.handedness) @ rot.T + shift   # on flank 0
    return rotor, path, point


def _contract_pose(row):
    """rotor-xa-b, written out: rotor point p at Rx(A) M0 p; tool axis (sin B, 0, cos B); XYZ = tool tip."""
    X, Y, Z, A, B = row
    c, s = math.cos(math.radians(A)), math.sin(math.radians(A))
    Rx = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    M0 = np.array([[0.0, 0, 1], [1, 0, 0], [0, 1, 0]])
    back = M0.T @ Rx.T
    return back @ [X, Y, Z], back @ [math.sin(math.radians(B)), 0.0, math.cos(math.radians(B))]


def _tool_rings(tool, tips, axes):
    """Surface points of the flat-ended cone (r1c at the tip, r2c after h) and its shank at every pose."""
    h = np.r_[np.linspace(0.0, tool["h"], 26), np.linspace(tool["h"], tool["h"] + tool["shank_length"], 46)]
    r = np.r_[np.linspace(tool["r1c"], tool["r2c"], 26), np.full(46, tool["shank_radius"])]
    th = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    pts = []
    for P, a in zip(tips, axes):
        e1 = np.cross(a, [1.0, 0, 0] if abs(a[0]) < 0.9 else [0, 1.0, 0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(a, e1)
        ring = np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2
        pts.append((P + h[:, None, None] * a + r[:, None, None] * ring[None]).reshape(-1, 3))
    return np.array(pts)


def test_mesh_to_linuxcnc_program_and_back(tmp_path, capsys, rs274):
    rotor, mesh, point = _mesh(tmp_path)
    plan_path, prog_path = tmp_path / "plan.json", tmp_path / "rotor.ngc"
    assert main(["plan", "single-flank", "--mesh", str(mesh), "--flank-point", ",".join(f"{x:.6f}" for x in point),
                 "--tool-r1", "1.5", "--tool-r2", f"{1.5 + 25 * math.tan(math.radians(2)):.6f}", "--tool-h", "25",
                 "--shank-radius", "3", "--shank-length", "45", "--tolerance", "0.05", "--seeds", "6",
                 "--rounds", "1", "--out", str(plan_path)]) == 0
    capsys.readouterr()
    plan = read_plan(plan_path)
    # the planner recorded the rotor's extent: the body and both shafts, as built (to the STL's float32)
    ext = plan["rotor"]["extent"]
    assert abs(np.diff(ext["z_range"])[0] - LENGTH) < 1e-4
    assert np.allclose([np.diff(s["z_range"])[0] for s in ext["shafts"]], [0.8 * R_MM, 1.2 * R_MM], atol=1e-4)
    assert all(abs(s["radius"] - 0.35 * R_MM) < 1e-4 for s in ext["shafts"])
    assert main(["post", str(plan_path), "--machine", "rotor-xa-b", "--post", "linuxcnc", "--mesh", str(mesh),
                 "--json", "-o", str(prog_path)]) == 0
    out = json.loads(capsys.readouterr().out)
    n_strips = len(plan["strips"])
    assert out["passes"] == 6 * n_strips and out["lobes"] == list(range(6))
    assert out["cutting_time_s"] > 0 and out["total_time_s"] >= out["cutting_time_s"] + out["rapid_time_s"]
    # LinuxCNC's interpreter reads it; its feeds give the same cutting time
    canon = run_rs274(rs274, prog_path)
    assert abs(rs274_times(canon) * 60.0 / out["cutting_time_s"] - 1.0) < 0.02
    # read back, matched and swept: the plan's deviation within 2 um, no gouge, links clear, passes run out
    text = prog_path.read_text()
    machine = load_machine("rotor-xa-b")
    res = verify_program(text, get_post("linuxcnc"), machine, [plan], rotor_body(plan))
    assert res["passes"] == res["matched_passes"] == 6 * n_strips
    assert not res["missing_strips"] and not res["repeated_strips"] and res["lobes_cut"] == list(range(6))
    lobes = res["plans"][0]["lobes"]
    assert len(lobes) == 6 and max(lo["max_deviation_difference_mm"] for lo in lobes) < 2e-3
    assert res["pose_difference_mm"] < 2e-3
    assert res["plans"][0]["plan_gouge_points"] == 0 and res["gouge_points"] == 0
    assert all(lo["coverage_mismatches"] == 0 for lo in lobes)
    assert res["links"]["max_intrusion_mm"] == 0.0
    assert min(res["run_out"]["min_start_clearance_mm"], res["run_out"]["min_end_clearance_mm"]) > 4.999
    # independently: every rapid of the interpreter, sampled, keeps the real tool out of the stock and shafts
    z0, z1 = ext["z_range"]
    solids = [(z0, z1, R_MM)] + [(s["z_range"][0], s["z_range"][1], s["radius"]) for s in ext["shafts"]]
    # the interpreter starts at 0, where the machine is at its tool-change position: the moves out of it (the
    # rotary turn, then the linear move) come from where the program cannot know, and are not sampled
    prev, worst, placed = None, -np.inf, False
    for kind, pos, _ in canon:
        row = pos[:5]
        if not placed:
            placed = prev is not None and not np.allclose(prev[:3], row[:3])
            prev = row
            continue
        if kind == "STRAIGHT_TRAVERSE" and not np.allclose(prev, row):
            rows = prev + np.linspace(0, 1, 60)[:, None] * (row - prev)
            tips, axes = zip(*(_contract_pose(r) for r in rows))
            pts = _tool_rings(plan["tool"], tips, axes).reshape(-1, 3)
            rho = np.hypot(pts[:, 0], pts[:, 1])
            for a, b, r in solids:
                inside = (pts[:, 2] > a) & (pts[:, 2] < b)
                if inside.any():
                    worst = max(worst, float((r - rho[inside]).max()))
        prev = row
    assert worst < 0.0, f"a rapid enters the stock or a shaft by {worst:.3g} mm"
    # and every pass (G1) starts and ends with the whole tool beyond the body's end faces
    prev = None
    for kind, pos, _ in canon:
        row = pos[:5]
        if kind == "STRAIGHT_FEED":
            ends = [_contract_pose(prev), _contract_pose(row)]
            pts = _tool_rings(plan["tool"], [e[0] for e in ends], [e[1] for e in ends])
            z = pts[..., 2]
            assert (z[0].min() > z1 + 4.9 and z[1].max() < z0 - 4.9) or (z[0].max() < z0 - 4.9 and z[1].min() > z1 + 4.9)
        prev = row
