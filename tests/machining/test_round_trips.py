"""Post -> read back -> forward kinematics, for every built-in machine and post and the three kinds of plan.

References: the plan's own strip poses screwed by the rotor's motion (cl_data.strip_tip, screw_motion),
LinuxCNC's interpreter for rs274ngc (canonical moves and feeds), the sweep simulation for the deviation."""
import math

import numpy as np
import pytest

from machining_helpers import rs274_times, run_rs274
from flank_addon.exports.cl_data import strip_tip
from flank_addon.geometry.screw import screw_motion
from flank_addon.machining.cycle_time import cycle_time
from flank_addon.machining.machine import builtin_machines, load_machine
from flank_addon.machining.operation import build_operation
from flank_addon.machining.rotor_body import rotor_body
from flank_addon.machining.toolpath import build_program
from flank_addon.posts import POSTS, get_post, write_program
from flank_addon.posts.readback import match_passes, read_passes, tool_table, verify_program

pytestmark = pytest.mark.xdist_group("machining")     # shared session fixtures: one worker

KINDS = ("single_flank_plan", "double_flank_plan", "formed_cutter_plan")
_programs, _references = {}, {}


def plan_reference(plan):
    """The plan's own sweep verification (once per plan)."""
    from flank_addon.simulation.verify import verify_plan

    if id(plan) not in _references:
        _references[id(plan)] = verify_plan(plan)
    return _references[id(plan)]


def expected_rows(prog, post):
    """The rows a program's moves end at, as read back, and their kinds: the program's rows to the dialect's
    resolution, where on a machine without TCP the first move of each tool is preceded by the rotary axes' turn
    alone (the linear axes where the tool change left them: NaN before the program has placed them)."""
    m = prog.machine
    rows, kinds, cur, first = [], [], np.full(len(m.axis_names), np.nan), False
    for o in prog.ops:
        if o["op"] == "tool":
            first = not m.tcp and len(m.axis_names) > 3
        if o["op"] not in ("rapid", "feed"):
            continue
        row = post.round_row(o["row"], m)
        if first:
            turn = cur.copy()
            turn[3:] = row[3:]
            rows.append(turn)
            kinds.append("rapid")
            first = False
        rows.append(row)
        kinds.append(o["op"])
        cur = row
    return np.array(rows), kinds


def program_of(request, kind, machine_name):
    key = (kind, machine_name)
    if key not in _programs:
        plan = request.getfixturevalue(kind)
        rb = rotor_body(plan)
        op = build_operation([plan], rb)
        _programs[key] = (plan, rb, op, build_program(op, load_machine(machine_name)))
    return _programs[key]


def reference_pose(plan, rb, strip, lobe, z):
    """The plan's strip turned to the lobe and screwed along the rotor's motion until its tip is at height z."""
    T, a, _ = strip_tip(plan, strip)
    turn = rb.lobe_angle(lobe)
    T, a = screw_motion(T, turn, 0.0, "right"), screw_motion(a, turn, 0.0, "right")
    t = (z - T[2]) / rb.v0
    return screw_motion(T, t, rb.v0, rb.hand), screw_motion(a, t, 0.0, rb.hand)


@pytest.mark.parametrize("post_name", list(POSTS))
@pytest.mark.parametrize("machine_name", builtin_machines())
@pytest.mark.parametrize("kind", KINDS)
def test_round_trip(request, tmp_path, kind, machine_name, post_name, rs274):
    plan, rb, op, prog = program_of(request, kind, machine_name)
    m, post = prog.machine, get_post(post_name)
    path = tmp_path / f"p{post.extension}"
    text = write_program(prog, post, path)
    read = post.read(path.read_text(), m)
    # 1. the rows read back are the program's rows to the dialect's resolution
    moves = [o for o in prog.ops if o["op"] in ("rapid", "feed")]
    want, kinds = expected_rows(prog, post)
    kept = [0] + [i for i in range(1, len(want)) if not np.array_equal(want[i], want[i - 1], equal_nan=True)]
    got = np.array([mv.end for mv in read.moves])
    assert got.shape == want[kept].shape and np.allclose(got, want[kept], rtol=0, atol=1e-9, equal_nan=True)
    assert [mv.kind for mv in read.moves] == [kinds[i] for i in kept]
    # 2. every feed block end is the plan's strip on its lobe, screwed: the pose to the program's rounding
    tools, of_strip = tool_table([plan])
    passes = match_passes(read_passes(read, m, tools, rb), [plan], rb, tools, of_strip)
    assert len(passes) == len(op.passes) == len(plan["strips"]) * rb.lobes
    assert sorted(ps["match"] for ps in passes) == sorted((0, s, k) for s in range(len(plan["strips"]))
                                                          for k in range(rb.lobes))
    for ps in passes:
        gauge = tools[ps["tool"]].gauge_length()
        P, A = m.forward(ps["rows"], gauge)
        for p, a in zip(P, A):
            T, b = reference_pose(plan, rb, ps["match"][1], ps["match"][2], p[2])
            assert np.linalg.norm(p - T) < 2e-3 and np.linalg.norm(a - b) < 2e-5
        assert ps["interpolation_error"] < (2e-3 if m.tcp else 1e-3)
    # 3. block times: as planned (to the F word's rounding) and within every joint's top speed
    ct = cycle_time(read, m, {n: s.h_range()[1] - s.h_range()[0] for n, s in tools.items()})
    planned = sum(o["time_min"] for o in moves if o["op"] == "feed")
    assert abs(ct["cutting_time_s"] / (60 * planned) - 1) < 1e-5
    feeds = [k for k, mv in enumerate(read.moves) if mv.kind == "feed"]
    J = m.machine_joints(np.array([read.moves[k].start for k in feeds]))
    J1 = m.machine_joints(np.array([read.moves[k].end for k in feeds]))
    T = np.array(ct["block_minutes"])[feeds]
    top = np.array([m.axes[n].max_feed for n in m.axis_names])
    assert (np.abs(J1 - J) / T[:, None] <= top * (1 + 1e-6)).all()
    # 4. LinuxCNC's own interpreter reads the rs274ngc program: same moves, same cutting time
    if post_name == "linuxcnc":
        canon = run_rs274(rs274, path)
        pos = np.array([c[1][:3].tolist() + [c[1][3 + "ABC".index(n)] for n in m.rotary_names] for c in canon])
        known = np.isfinite(got)        # the interpreter starts at 0, the machine where the tool change left it
        assert len(canon) == len(read.moves) and np.abs(pos - got)[known].max() < 2e-4
        turned_first = len(m.axis_names) > 3 and not m.tcp      # only the first move's linear axes are unknown
        assert known[1 if turned_first else 0:].all()
        assert abs(rs274_times(canon) * 60 / ct["cutting_time_s"] - 1) < 0.02


@pytest.mark.parametrize("kind, machine_name, post_name", [
    ("single_flank_plan", "xyzac-trt", "heidenhain"),
    ("formed_cutter_plan", "xyzac-trt-tcp", "fanuc"),
])
def test_program_mills_what_the_plan_mills(request, kind, machine_name, post_name):
    """Read back and swept (lobe 1), the program's deviation is the plan's to 2 um (+ the TCP chord); the
    acceptance test sweeps every lobe of a rotor-xa-b program."""
    plan, rb, op, prog = program_of(request, kind, machine_name)
    post = get_post(post_name)
    res = verify_program(post.write(prog), post, prog.machine, [plan], rb, lobes=[1],
                         references=[plan_reference(plan)])
    assert res["matched_passes"] == res["passes"] and not res["missing_strips"] and not res["repeated_strips"]
    assert res["findings"] == [] and res["program_end_line"] > 0
    (lobe,) = res["plans"][0]["lobes"]
    assert lobe["lobe"] == 1 and lobe["coverage_mismatches"] == 0
    assert lobe["max_deviation_difference_mm"] < 2e-3 + (1e-3 if prog.machine.tcp else 0.0)
    assert lobe["pose_difference_mm"] < 2e-3
    assert lobe["gouge_points"] == res["plans"][0]["plan_gouge_points"]
    assert res["links"]["max_intrusion_mm"] == 0.0 and res["links"]["moves_checked"] > 3 * len(op.passes)
    assert min(res["run_out"]["min_start_clearance_mm"], res["run_out"]["min_end_clearance_mm"]) > 4.999


def test_a_pose_error_shows_in_the_deviation(request):
    """The read-back is no tautology: a program whose passes sit 0.05 mm off deviates by about that."""
    plan, rb, op, prog = program_of(request, "single_flank_plan", "rotor-xa-b")
    post = get_post("linuxcnc")
    bad = post.write(prog).replace("\nG1 ", "\nG1 ")
    lines = bad.splitlines()
    yz = [i for i, ln in enumerate(lines) if ln.startswith("G0 ") and " Z" in ln and "X" not in ln]
    i = yz[0]                                   # the first approach: lower it by 0.05 mm
    z = float(lines[i].split("Z")[1].split()[0])
    lines[i] = lines[i].replace(f"Z{z:.4f}", f"Z{z - 0.05:.4f}")
    res = verify_program("\n".join(lines) + "\n", post, prog.machine, [plan], rb, lobes=[0, 1, 2, 3],
                         references=[plan_reference(plan)])
    worst = max(lo["max_deviation_difference_mm"] for lo in res["plans"][0]["lobes"])
    assert len(res["unmatched_passes"]) == 1 and 0.01 < res["unmatched_passes"][0]["distance_mm"] < 0.2
    # the pass that matches no strip is swept where the program puts it: the deviation moves by a good part of
    # the shift, never by more than the pose bound
    bound = max(lo["pose_difference_mm"] for lo in res["plans"][0]["lobes"])
    assert len(res["missing_strips"]) == 1 and 0.01 < worst <= bound + 1e-6 and 0.04 < bound < 0.2
    assert res["findings"][0].startswith(f"1 of {res['passes']} passes match no plan strip")
    assert "1 strip(s) never cut" in res["findings"][1]


@pytest.mark.parametrize("turn_deg, finding", [(0.5, True), (0.002, False)])
def test_a_pass_off_the_rotors_screw_is_found(request, turn_deg, finding):
    """The first pass's end turned further by hand: the pass starts where its strip does, but it is no longer
    the rotor's screw (a wrong pitch).  Its block ends leave the screw through its first pose by the turn at
    the tool's farthest point, 2 sin(turn / 2) (rho_tip + reach |a_xy|) at the end pose (an extra rotation
    about the rotor axis); beyond the 0.01 mm a pass may be off its strip that is a finding, below it the pose
    bound grows by it."""
    plan, rb, op, prog = program_of(request, "single_flank_plan", "rotor-xa-b")
    post = get_post("linuxcnc")
    lines = post.write(prog).splitlines()
    i = next(k for k, ln in enumerate(lines) if ln.startswith("G1 ") and " A" in ln)
    a = float(lines[i].split(" A")[1].split()[0])
    lines[i] = lines[i].replace(f"A{a:.4f}", f"A{a + turn_deg:.4f}")
    res = verify_program("\n".join(lines) + "\n", post, prog.machine, [plan], rb, lobes=[0],
                         references=[plan_reference(plan)])
    tools, _ = tool_table([plan])
    first = read_passes(post.read(post.write(prog), prog.machine), prog.machine, tools, rb)[0]   # as posted
    T, ax = first["tip"], first["axis"]             # rho and |a_xy| are the same anywhere along the screw
    reach = max(abs(x) for x in tools[first["tool"]].h_range())
    expected = 2 * math.sin(math.radians(turn_deg) / 2) * (math.hypot(T[0], T[1]) + reach * math.hypot(ax[0], ax[1]))
    assert res["screw_error_mm"] == pytest.approx(expected, rel=0.02, abs=3e-4)     # the program's rounding
    (lobe,) = res["plans"][0]["lobes"]
    assert lobe["pose_difference_mm"] >= expected - 3e-4
    off = res["passes_off_screw"]
    if finding:
        assert [o["line"] for o in off] == [i + 1] and res["matched_passes"] == res["passes"]
        assert res["findings"] == [f"1 pass(es) leave the rotor's screw motion by up to {off[0]['screw_error_mm']:.3g} "
                                   f"mm (lines {i + 1}): not the plan's pitch or rotary angles; the deviation figures "
                                   f"sweep each pass along the screw through its first pose and do not show it"]
        # its chip load is not judged (the screw's advance measures it), and said so, not read as within fz
        cut = res["cutting"]
        assert cut["chip_load_not_judged"] and min(cut["chip_load_not_judged"]) <= i + 1 <= max(cut["chip_load_not_judged"])
        assert cut["tools"][0]["moves_chip_load_not_judged"] == len(cut["chip_load_not_judged"])
    else:
        assert off == [] and res["findings"] == [] and res["cutting"]["chip_load_not_judged"] == []


def test_a_pass_moved_into_the_flank_shows_as_gouges(request):
    """The first pass moved 1 mm one way or the other along Y: it matches no strip, yet it is swept where it
    runs, and one of the two directions cuts into the flank; a finding names it."""
    plan, rb, op, prog = program_of(request, "single_flank_plan", "rotor-xa-b")
    post = get_post("linuxcnc")
    lines = post.write(prog).splitlines()
    i = next(k for k, ln in enumerate(lines) if ln.startswith("G0 ") and " Y" in ln)
    y = float(lines[i].split(" Y")[1].split()[0])
    deepest = []
    for dy in (-1.0, 1.0):
        moved = lines[:i] + [lines[i].replace(f"Y{y:.4f}", f"Y{y + dy:.4f}")] + lines[i + 1:]
        res = verify_program("\n".join(moved) + "\n", post, prog.machine, [plan], rb, lobes=[0],
                             references=[plan_reference(plan)])
        (lobe,) = res["plans"][0]["lobes"]
        assert lobe["unmatched_passes"] == 1 and len(res["unmatched_passes"]) == 1
        if lobe["gouge_points"] > res["plans"][0]["plan_gouge_points"]:
            assert any(f"{lobe['gouge_points']} gouge points" in f for f in res["findings"])
            deepest.append(lobe["max_overcut_mm"])
    assert len(deepest) == 1 and deepest[0] < -0.5


def test_whole_rotor_from_three_plans_changes_tools_three_times(single_flank_plan, double_flank_plan,
                                                               formed_cutter_plan, tmp_path, rs274):
    plans = [single_flank_plan, double_flank_plan, formed_cutter_plan]
    rb = rotor_body(plans[0])
    op = build_operation(plans, rb, lobes=[0, 2])
    prog = build_program(op, load_machine("rotor-xa-b"), direction="zigzag")
    path = tmp_path / "all.ngc"
    text = write_program(prog, "linuxcnc", path)
    assert [ln for ln in text.splitlines() if ln.endswith(" M6")] == ["T1 M6", "T2 M6", "T3 M6"]
    # a tool change leaves the spin axis where it is: the next tool starts at the turn nearest to it
    spins, changes = [], []
    for ln in text.splitlines():
        if ln.endswith(" M6"):
            changes.append(len(spins))
        spins += [float(w[1:]) for w in ln.split() if w.startswith("A")]
    assert all(abs(spins[k] - spins[k - 1]) <= 180.0 for k in changes[1:])
    assert max(abs(spins[k] - spins[k - 1]) for k in changes[1:]) > 0.0
    assert [p["tool"] for p in prog.passes] == sorted(p["tool"] for p in prog.passes)
    assert {p["lobe"] for p in prog.passes} == {0, 2}
    assert any(p["reverse"] for p in prog.passes) and not all(p["reverse"] for p in prog.passes)
    canon = run_rs274(rs274, path)
    read = get_post("linuxcnc").read(text, prog.machine)
    assert len(canon) == len(read.moves)
    ct = cycle_time(read, prog.machine)
    assert ct["tool_changes"] == 3 and abs(rs274_times(canon) * 60 / ct["cutting_time_s"] - 1) < 0.02
    disc = [p for p in prog.passes if p["tool"] == 3]
    assert max(p["rpm"] for p in disc) < 1000 < min(p["rpm"] for p in prog.passes if p["tool"] == 1)


@pytest.mark.parametrize("machine_name, meaning", [("xyzac-trt", "combined axis vector"),
                                                   ("xyzac-trt-tcp", "speed of the tool tip")])
def test_heidenhain_header_says_what_its_feeds_mean(request, machine_name, meaning):
    """With FUNCTION TCPM the TNC reads F as the tip's speed; without it, along the combined axis vector."""
    plan, rb, op, prog = program_of(request, "single_flank_plan", machine_name)
    lines = get_post("heidenhain").write(prog).splitlines()
    (said,) = [ln for ln in lines if "F of simultaneous blocks" in ln]
    assert meaning in said
    assert any("FUNCTION TCPM F TCP" in ln for ln in lines) == prog.machine.tcp


def test_klartext_resets_tcpm_before_every_tool_call(request):
    """The TNC's manuals ask for FUNCTION RESET TCPM before a TOOL CALL: on a TCP machine with two tools every
    TOOL CALL finds TCPM off and switches it on in the next block, the program ends with it reset, and every move
    is read under TCPM (F as the tip's speed)."""
    plan, rb, op, prog = program_of(request, "two_tool_plan", "xyzac-trt-tcp")
    machine = prog.machine
    post = get_post("heidenhain")
    text = post.write(prog)
    blocks = [ln.split(" ", 1)[1] for ln in text.splitlines()[1:-1]]
    calls = [k for k, b in enumerate(blocks) if b.startswith("TOOL CALL")]
    assert len(calls) == 2
    on = False
    for k, b in enumerate(blocks):
        if b.startswith("FUNCTION TCPM"):
            on = True
        elif b == "FUNCTION RESET TCPM":
            on = False
        elif b.startswith("TOOL CALL"):
            assert not on, k
            assert blocks[k + 1].startswith("FUNCTION TCPM F TCP"), blocks[k + 1]
    assert not on
    read = post.read(text, machine)
    assert read.moves and all(mv.tcp for mv in read.moves)
