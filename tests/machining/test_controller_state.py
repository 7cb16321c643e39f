"""What the controller keeps besides the axes, in a program read back: the tool in the spindle, the spindle's
rotation and speed, the tool length compensation.  The readers follow them as the controller does (LinuxCNC's
own interpreter is the reference for rs274ngc), and the read-back names every feed move that would cut without
the spindle turning clockwise within its speeds and every move without its tool's length compensation."""
import math
import re

import numpy as np
import pytest

from flank_addon.machining.machine import builtin_machines, load_machine
from flank_addon.machining.operation import build_operation
from flank_addon.machining.rotor_body import rotor_body
from flank_addon.machining.toolpath import build_program
from flank_addon.posts import POSTS, get_post
from flank_addon.posts.readback import verify_program

pytestmark = pytest.mark.xdist_group("machining")     # shared session fixtures: one worker

CANON_SPINDLE = re.compile(r"(SET_SPINDLE_SPEED|START_SPINDLE_CLOCKWISE|START_SPINDLE_COUNTERCLOCKWISE|"
                           r"STOP_SPINDLE_TURNING|STRAIGHT_FEED)\(([^)]*)\)")


def rs274_feed_spindles(rs274, path):
    """(rotation, speed) of the spindle at every STRAIGHT_FEED of LinuxCNC's canonical output."""
    import subprocess

    out = subprocess.run([rs274, "-g", str(path)], capture_output=True, text=True, timeout=120,
                        cwd=path.parent).stdout
    assert "PROGRAM_END()" in out
    turn, speed, feeds = "off", 0.0, []
    for kind, args in CANON_SPINDLE.findall(out):
        if kind == "SET_SPINDLE_SPEED":
            speed = float(args.split(",")[1])
        elif kind == "START_SPINDLE_CLOCKWISE":
            turn = "cw"
        elif kind == "START_SPINDLE_COUNTERCLOCKWISE":
            turn = "ccw"
        elif kind == "STOP_SPINDLE_TURNING":
            turn = "off"
        else:
            feeds.append((turn, speed))
    return feeds


CANON_TOOLS = re.compile(r"(CHANGE_TOOL|USE_TOOL_LENGTH_OFFSET|STRAIGHT_FEED|STRAIGHT_TRAVERSE)\(([^)]*)\)")
INCH = 25.4


def rs274_move_tools(rs274, path, tool_table):
    """(tool in the spindle, tool whose length offset is active or None) at every move of LinuxCNC's canonical
    output; ``tool_table`` gives tool n the length n inches (rs274's tables are in inches), so the offset names
    its tool."""
    import subprocess

    out = subprocess.run([rs274, "-t", str(tool_table), "-g", str(path)], capture_output=True, text=True,
                         timeout=120, cwd=path.parent).stdout
    assert "PROGRAM_END()" in out
    tool, comp, moves = 0, None, []
    for kind, args in CANON_TOOLS.findall(out):
        if kind == "CHANGE_TOOL":
            tool = int(args)
        elif kind == "USE_TOOL_LENGTH_OFFSET":
            z = float(args.split(",")[0].split()[2])
            comp = int(round(z / INCH)) or None
        else:
            moves.append((tool, comp))
    return moves


def read_as_linuxcnc(rs274, tmp_path, table, name, lines, machine):
    """(text, our reading) of program lines, after checking that the reader's spindle rotation and speed at
    every cut and tool and length offset at every move are those of LinuxCNC's interpreter (tool ``table``)."""
    text = "\n".join(lines) + "\n"
    path = tmp_path / f"{name}.ngc"
    path.write_text(text)
    read = get_post("linuxcnc").read(text, machine)
    assert [(mv.spindle, mv.rpm) for mv in read.moves if mv.kind == "feed"] == rs274_feed_spindles(rs274, path), name
    assert [(mv.tool, mv.length_comp) for mv in read.moves] == rs274_move_tools(rs274, path, table), name
    return text, read


def tool_table(tmp_path, numbers):
    path = tmp_path / "tools.tbl"
    path.write_text("".join(f"T{n} P{n} Z{n:.1f} D0.1 ;tool {n}\n" for n in numbers))
    return path


def _before_passes(lines, marker, edits):
    """``lines`` with ``edits[k]`` (a line) inserted before the k-th pass's comment (1-based)."""
    out, k = [], 0
    for ln in lines:
        if marker in ln:
            k += 1
            if k in edits:
                out.append(edits[k])
        out.append(ln)
    return out


def test_linuxcnc_spindle_states_are_the_interpreters(posted, rs274, tmp_path):
    """M5 before pass 2, M3 again before pass 3, M4 before pass 4, S30000 M3 before pass 5, S0 before pass 6:
    the reader's rotation and speed at every feed move are LinuxCNC's, and each is a finding with its lines."""
    plan, rb, machine, prog = posted
    post = get_post("linuxcnc")
    lines = post.write(prog).splitlines()
    edits = {2: "M5", 3: "M3", 4: "M4", 5: "S30000 M3", 6: "S0"}
    text = "\n".join(_before_passes(lines, "(PASS ", edits)) + "\n"
    path = tmp_path / "spindle.ngc"
    path.write_text(text)
    read = post.read(text, machine)
    ours = [(mv.spindle, mv.rpm) for mv in read.moves if mv.kind == "feed"]
    assert ours == rs274_feed_spindles(rs274, path)
    assert [s for s, _ in ours[:6]] == ["cw", "off", "cw", "ccw", "cw", "cw"]
    res = verify_program(text, post, machine, [plan], rb)
    feeds = [mv for mv in read.moves if mv.kind == "feed"]
    sp = res["spindle"]
    assert sp["stopped"] == [feeds[1].line] and sp["counter_clockwise"] == [feeds[3].line]
    assert sp["no_speed"] == [mv.line for mv in feeds[5:]] and sp["over_top_speed"] == [feeds[4].line]
    assert sp["max_rpm"] == 30000.0 and machine.max_rpm < 30000.0
    found = [f for f in res["findings"] if "spindle" in f]
    assert found == [
        f"1 feed move(s) with the spindle stopped (lines {feeds[1].line}): M5, or not started again after a tool "
        "change",
        f"1 feed move(s) with the spindle turning counter-clockwise (M4; lines {feeds[3].line}): the tools cut "
        "right-hand, turned by M3",
        f"{len(feeds) - 5} feed move(s) without a spindle speed (S0 or none; lines "
        + ", ".join(str(mv.line) for mv in feeds[5:15]) + (", ..." if len(feeds) > 15 else "") + ")",
        f"1 feed move(s) at up to S30000, over the machine's top spindle speed {machine.max_rpm:g} /min (lines "
        f"{feeds[4].line})"]


def test_a_tool_change_stops_the_spindle_until_m3(posted, rs274, tmp_path):
    """The program as posted cuts with the spindle on; without its M3 after the tool change every cut is made
    with the spindle stopped, as LinuxCNC's interpreter has it (M6 stops the spindle)."""
    plan, rb, machine, prog = posted
    post = get_post("linuxcnc")
    text = post.write(prog)
    res = verify_program(text, post, machine, [plan], rb)
    assert not any(res["spindle"][k] for k in ("stopped", "counter_clockwise", "no_speed", "over_top_speed"))
    assert not any("spindle" in f for f in res["findings"])
    (i,) = [k for k, ln in enumerate(text.splitlines()) if ln.endswith(" M3")]
    lines = text.splitlines()
    lines[i] = lines[i][:-3]                                  # S<rpm> alone: the speed, no rotation
    edited = "\n".join(lines) + "\n"
    path = tmp_path / "no_m3.ngc"
    path.write_text(edited)
    read = post.read(edited, machine)
    ours = [(mv.spindle, mv.rpm) for mv in read.moves if mv.kind == "feed"]
    assert ours == rs274_feed_spindles(rs274, path) and {s for s, _ in ours} == {"off"}
    res = verify_program(edited, post, machine, [plan], rb)
    assert len(res["spindle"]["stopped"]) == res["passes"] > 0
    assert any(f.startswith(f"{res['passes']} feed move(s) with the spindle stopped") for f in res["findings"])


def test_heidenhain_spindle_words_act_where_the_tnc_acts(posted):
    """Klartext: M3 / M13 / M4 / M14 act at the start of their block, M5 at its end; TOOL CALL of another tool
    stops the spindle.  As posted (M13 on the first move of the tool) every cut turns clockwise; an M5 on a
    cut's own block still lets that cut run, and stops the next; M4 on a cut's block turns that cut
    counter-clockwise; without the M13 every cut is made with the spindle stopped."""
    plan, rb, machine, prog = posted
    post = get_post("heidenhain")
    text = post.write(prog)
    feeds = [mv for mv in post.read(text, machine).moves if mv.kind == "feed"]
    assert {mv.spindle for mv in feeds} == {"cw"}
    lines = text.splitlines()
    cut = [k for k, ln in enumerate(lines) if re.match(r"^\d+ L .* F[\d.]+", ln)]
    assert len(cut) == len(feeds)
    edited = list(lines)
    edited[cut[0]] += " M5"
    edited[cut[2]] += " M4"
    read = post.read("\n".join(edited) + "\n", machine)
    turns = [mv.spindle for mv in read.moves if mv.kind == "feed"]
    assert turns[:3] == ["cw", "off", "ccw"]
    res = verify_program("\n".join(edited) + "\n", post, machine, [plan], rb)
    assert res["spindle"]["counter_clockwise"][0] == feeds[2].line and feeds[1].line in res["spindle"]["stopped"]
    no_m13 = [ln.replace(" M13", "") for ln in lines]
    read = post.read("\n".join(no_m13) + "\n", machine)
    assert {mv.spindle for mv in read.moves if mv.kind == "feed"} == {"off"}


@pytest.mark.parametrize("post_name", list(POSTS))
@pytest.mark.parametrize("machine_name", builtin_machines())
def test_as_posted_every_cut_has_its_spindle_and_length_compensation(request, machine_name, post_name):
    """Every built-in machine and post: every move that moves a linear axis has its tool's length compensation
    and every cut the spindle turning clockwise at the tool's speed; no finding about either."""
    plan = request.getfixturevalue("single_flank_plan")
    rb = rotor_body(plan)
    op = build_operation([plan], rb, lobes=[0])
    machine = load_machine(machine_name)
    prog = build_program(op, machine)
    post = get_post(post_name)
    text = post.write(prog)
    res = verify_program(text, post, machine, [plan], rb)
    assert res["length_compensation"] == {"without": [], "other_tool": [], "first_other": None}
    sp = res["spindle"]
    assert not (sp["stopped"] or sp["counter_clockwise"] or sp["no_speed"] or sp["over_top_speed"])
    assert sp["min_rpm"] == sp["max_rpm"] == pytest.approx(op.tools[0].rpm, abs=0.5)
    assert res["work_offsets"] == {"offsets": [] if post_name == "heidenhain" else ["G54"], "changes_at": []}
    assert res["axis_limits"] == [] and res["findings"] == []
    assert res["coolant"] == {"expected": "flood", "off": [], "on": []}
    assert {mv.coolant for mv in post.read(text, machine).moves if mv.kind == "feed"} == {"flood"}


def test_linuxcnc_length_compensation_and_tool_are_the_interpreters(posted, rs274, tmp_path):
    """Without the G43 H1 after the tool change every move is made without length compensation; with H2 instead
    (another tool's) every move with the wrong one; a G43 without H takes the tool in the spindle, and a T word
    without M6 (the next tool selected ahead) changes neither the tool nor its compensation.  The reader's tool
    and compensation at every move are those of LinuxCNC's interpreter with a tool table."""
    plan, rb, machine, prog = posted
    post = get_post("linuxcnc")
    lines = post.write(prog).splitlines()
    table = tool_table(tmp_path, (1, 2, 3))
    (g43,) = [k for k, ln in enumerate(lines) if ln == "G43 H1"]
    cases = {"none": lines[:g43] + lines[g43 + 1:],
             "other": lines[:g43] + ["G43 H2"] + lines[g43 + 1:],
             "bare": lines[:g43] + ["G43"] + lines[g43 + 1:],
             "preselect": _before_passes(lines, "(PASS ", {2: "T3"})}
    found = {}
    for name, edited in cases.items():
        text, read = read_as_linuxcnc(rs274, tmp_path, table, name, edited, machine)
        res = verify_program(text, post, machine, [plan], rb)
        found[name] = (res["length_compensation"], [f for f in res["findings"] if "length compensation" in f])
    def moved(name):                # lines of the moves that move a linear axis
        return [mv.line for mv in post.read("\n".join(cases[name]) + "\n", machine).moves
                if mv.kind == "feed" or not np.array_equal(mv.start[:3], mv.end[:3], equal_nan=True)]

    lc, msgs = found["none"]
    assert lc["without"] == moved("none") and lc["other_tool"] == [] and len(msgs) == 1
    assert msgs[0].startswith(f"{len(moved('none'))} move(s) without tool length compensation (lines ")
    lc, msgs = found["other"]
    assert lc["other_tool"] == moved("other") and lc["without"] == []
    assert lc["first_other"] == [2, 1] and "H2 with T1" in msgs[0]
    for name in ("bare", "preselect"):
        assert found[name] == ({"without": [], "other_tool": [], "first_other": None}, []), name


@pytest.mark.parametrize("machine_name, post_name", [("rotor-xa-b", "linuxcnc"), ("xyzac-trt-tcp", "fanuc"),
                                                     ("xyzac-trt", "heidenhain")])
def test_an_axis_beyond_its_limit_is_found_where_the_move_ends(request, machine_name, post_name):
    """One rapid's Z written beyond the machine's upper limit: the read-back names the axis, the value the
    controller would be asked for (the joint: on the TCP machine the program's Z is the tip's, and the joint is
    the forward kinematics' control point) and the line; the program as posted stays inside."""
    plan = request.getfixturevalue("single_flank_plan")
    rb = rotor_body(plan)
    op = build_operation([plan], rb, lobes=[0])
    machine = load_machine(machine_name)
    post = get_post(post_name)
    lines = post.write(build_program(op, machine)).splitlines()
    zmax = machine.axes["Z"].max
    k = next(i for i, ln in enumerate(lines) if re.search(r"(G0*0|FMAX)", ln) and re.search(r"Z[+-]?\d", ln))
    for beyond in (100.0, 300.0, 1000.0):           # with TCP the joint is not the program's Z: push until it is out
        lines[k] = re.sub(r"Z([+-]?)[\d.]+", f"Z{'+' if post_name == 'heidenhain' else ''}{zmax + beyond:.4f}",
                          lines[k])
        text = "\n".join(lines) + "\n"
        read = post.read(text, machine)
        (mv,) = [m for m in read.moves if m.line == k + 1]
        joint_z = machine.machine_joints(mv.end[None], op.tools[0].gauge_length)[0, 2]
        if joint_z > zmax:
            break
    assert joint_z > zmax
    res = verify_program(text, post, machine, [plan], rb)
    (v,) = [x for x in res["axis_limits"] if x["axis"] == "Z"]
    assert v["line"] == k + 1 and v["value"] == pytest.approx(joint_z, abs=1e-9)
    assert v["min"] == machine.axes["Z"].min and v["max"] == zmax
    assert (f"axis Z reaches {joint_z:.6g} at line {k + 1}, outside its limits {machine.axes['Z'].min:g}..{zmax:g} "
            f"on machine {machine.name}: the controller stops there") in res["findings"]


def test_a_change_of_work_offset_is_found_as_linuxcnc_reads_it(posted, rs274, tmp_path):
    """G55 before pass 3 and G54 again before pass 5: the reader's work offset at every move is LinuxCNC's, and
    the two changes are a finding with the lines of the first moves made in the new offset."""
    plan, rb, machine, prog = posted
    post = get_post("linuxcnc")
    text = "\n".join(_before_passes(post.write(prog).splitlines(), "(PASS ", {3: "G55", 5: "G54"})) + "\n"
    path = tmp_path / "g55.ngc"
    path.write_text(text)
    import subprocess

    canon = subprocess.run([rs274, "-g", str(path)], capture_output=True, text=True, timeout=120,
                        cwd=path.parent).stdout
    names = {1: "G54", 2: "G55", 3: "G56", 4: "G57", 5: "G58", 6: "G59", 7: "G59.1", 8: "G59.2", 9: "G59.3"}
    active, theirs = "G54", []
    for kind, args in re.findall(r"(SET_G5X_OFFSET|STRAIGHT_FEED|STRAIGHT_TRAVERSE)\(([^)]*)\)", canon):
        if kind == "SET_G5X_OFFSET":
            active = names[int(args.split(",")[0])]
        else:
            theirs.append(active)
    read = post.read(text, machine)
    assert [mv.work_offset for mv in read.moves] == theirs
    wo = verify_program(text, post, machine, [plan], rb)["work_offsets"]
    firsts = [mv.line for a, mv in zip([None] + read.moves, read.moves) if a is not None
              and a.work_offset != mv.work_offset]
    assert wo == {"offsets": ["G54", "G55", "G54"], "changes_at": firsts} and len(firsts) == 2


# ------------------------------------------------------------------------------ two tools, block order, dialects
@pytest.fixture(scope="module")
def posted_two(two_tool_plan):
    """The two-tool single-flank plan on rotor-xa-b (lobe 0): plan, rotor body, machine, program."""
    rb = rotor_body(two_tool_plan)
    op = build_operation([two_tool_plan], rb, lobes=[0])
    machine = load_machine("rotor-xa-b")
    return two_tool_plan, rb, machine, build_program(op, machine)


def _feeds_of_tool(read, number):
    return [mv for mv in read.moves if mv.kind == "feed" and mv.tool == number]


def test_linuxcnc_tool_changes_and_block_order_are_the_interpreters(posted_two, rs274, tmp_path):
    """On a two-tool program, each edit read as LinuxCNC reads it (rotation, speed, tool and length offset at
    every move, with a tool table):
    - no M3 for the second tool: M6 stopped the spindle, so only the second tool's cuts are made stopped;
    - M3 in the M6 block: the change, then the start, so every cut turns;
    - the next tool selected (T3) before a bare G43: G43 takes the tool in the spindle, not the T word;
    - G43 H0: the tool in the spindle too."""
    plan, rb, machine, prog = posted_two
    post = get_post("linuxcnc")
    lines = post.write(prog).splitlines()
    table = tool_table(tmp_path, (1, 2, 3))
    m3 = [k for k, ln in enumerate(lines) if re.fullmatch(r"S\d+ M3", ln)]
    m6 = [k for k, ln in enumerate(lines) if ln.endswith(" M6")]
    g43 = [k for k, ln in enumerate(lines) if ln.startswith("G43 H")]
    assert len(m3) == len(m6) == len(g43) == 2
    speed2 = lines[m3[1]].split()[0]

    def edit(changes):
        out = list(lines)
        for k, new in sorted(changes.items(), reverse=True):
            out[k:k + 1] = new
        return out
    cases = {"no_m3_second": edit({m3[1]: [speed2]}),
             "m3_with_m6": edit({m6[1]: [lines[m6[1]] + " M3"], m3[1]: [speed2]}),
             "preselect_bare_g43": edit({g43[0]: ["T3", "G43"]}),
             "h0": edit({g43[1]: ["G43 H0"]})}
    results = {}
    for name, edited in cases.items():
        text, read = read_as_linuxcnc(rs274, tmp_path, table, name, edited, machine)
        results[name] = (read, verify_program(text, post, machine, [plan], rb))
    read, res = results["no_m3_second"]
    second = [mv.line for mv in _feeds_of_tool(read, 2)]
    assert second and res["spindle"]["stopped"] == second and _feeds_of_tool(read, 1)
    for name in ("m3_with_m6", "preselect_bare_g43", "h0"):
        read, res = results[name]
        assert not res["spindle"]["stopped"] and res["length_compensation"]["other_tool"] == [], name
        assert not any(f for f in res["findings"] if "spindle" in f or "compensation" in f), name


def test_linuxcnc_end_of_program_stops_the_spindle_after_its_motion_and_h_needs_g43(rs274, tmp_path):
    """M2 in a cutting block stops the spindle after that cut (LinuxCNC runs the program's end last); an H word
    without G43 is an error for LinuxCNC's interpreter and for the reader."""
    machine = load_machine("rotor-xa-b")
    post = get_post("linuxcnc")
    text = "%\nG21 G90 G94\nT1 M6\nS100 M3\nG43 H1\nG0 X0 Y0 Z10 A0 B0\nG1 X4 F100 M2\n%\n"
    path = tmp_path / "m2.ngc"
    path.write_text(text)
    read = post.read(text, machine)
    assert [(mv.spindle, mv.rpm) for mv in read.moves if mv.kind == "feed"] == rs274_feed_spindles(rs274, path) \
        == [("cw", 100.0)]
    import subprocess

    bad = text.replace("G43 H1\n", "H1\n")
    path.write_text(bad)
    r = subprocess.run([rs274, "-g", str(path)], capture_output=True, text=True, timeout=120,
                        cwd=path.parent)
    assert "H word with no G43" in r.stdout + r.stderr
    with pytest.raises(ValueError, match="line 5: H word with no G43 to use it"):
        post.read(bad, machine)


def test_heidenhain_tool_call_and_m6_stop_the_spindle(posted_two):
    """Klartext: without the M13 of the second tool only its cuts are made stopped (its TOOL CALL stopped the
    spindle); an M6 at the end of a cut's block stops it for the cuts after it."""
    plan, rb, machine, prog = posted_two
    post = get_post("heidenhain")
    lines = post.write(prog).splitlines()
    m13 = [k for k, ln in enumerate(lines) if " M13" in ln]
    assert len(m13) == 2
    edited = list(lines)
    edited[m13[1]] = edited[m13[1]].replace(" M13", "")
    read = post.read("\n".join(edited) + "\n", machine)
    assert {mv.spindle for mv in _feeds_of_tool(read, 1)} == {"cw"}
    assert {mv.spindle for mv in _feeds_of_tool(read, 2)} == {"off"}
    cuts = [k for k, ln in enumerate(lines) if re.match(r"^\d+ L .* F[\d.]+", ln)]
    edited = list(lines)
    edited[cuts[0]] += " M6"
    read = post.read("\n".join(edited) + "\n", machine)
    turns = [mv.spindle for mv in _feeds_of_tool(read, 1)]
    assert turns[0] == "cw" and set(turns[1:]) == {"off"}


def test_fanuc_length_compensation_follows_fanucs_modal_h_and_g43_ends_tcp(two_tool_plan):
    """Fanuc (TCP machine): the program as posted switches G43.4 off before the second tool change and on again
    with that tool's H; G43 without H takes the latest H word (so the second tool would take the first's offset);
    an H word under G43 changes the offset; G43 after G43.4 ends TCP (the same modal group)."""
    rb = rotor_body(two_tool_plan)
    machine = load_machine("xyzac-trt-tcp")
    prog = build_program(build_operation([two_tool_plan], rb, lobes=[0]), machine)
    post = get_post("fanuc")
    lines = post.write(prog).splitlines()
    m6 = [k for k, ln in enumerate(lines) if ln.endswith(" M06")]
    assert len(m6) == 2 and lines[m6[1] - 2] == "G49" and lines[m6[0] - 2] != "G49"     # G49, the tool's comment
    read = post.read("\n".join(lines) + "\n", machine)
    assert all(mv.length_comp == mv.tool and mv.tcp for mv in read.moves if mv.kind == "feed")
    res = verify_program("\n".join(lines) + "\n", post, machine, [two_tool_plan], rb)
    assert res["findings"] == []
    (k,) = [k for k, ln in enumerate(lines) if "G43.4 H2 " in ln]
    bare = list(lines)
    bare[k] = bare[k].replace("G43.4 H2 ", "G43.4 ")
    read = post.read("\n".join(bare) + "\n", machine)
    assert {mv.length_comp for mv in _feeds_of_tool(read, 2)} == {1}
    res = verify_program("\n".join(bare) + "\n", post, machine, [two_tool_plan], rb)
    assert res["length_compensation"]["first_other"] == [1, 2]
    changed = list(bare)
    changed[k + 1:k + 1] = ["H2"]
    read = post.read("\n".join(changed) + "\n", machine)
    assert {mv.length_comp for mv in _feeds_of_tool(read, 2)} == {2}
    (first,) = [k for k, ln in enumerate(lines) if "G43.4 H1 " in ln]
    off = list(lines)
    off[first + 1:first + 1] = ["G43 H1"]
    read = post.read("\n".join(off) + "\n", machine)
    assert not any(mv.tcp for mv in _feeds_of_tool(read, 1)) and all(mv.tcp for mv in _feeds_of_tool(read, 2))


def test_tcp_axis_limits_are_checked_between_the_block_ends():
    """A TCP rapid tilting A from 60 to 120 deg with the tip 650 mm from the A pivot: its ends stay inside Y's
    limits (-562.9 mm) but the joints between them swing to -650 mm at A = 90 deg (dense samples of the
    machine's kinematics); the check finds Y out at that line, at the nearest of its samples."""
    from flank_addon.posts.readback import axis_limit_check

    machine = load_machine("xyzac-trt-tcp")
    text = "%\nG21 G90 G94\nT1 M6\nG43 H1\nS1000 M3\nG0 X0 Y0 Z550 A60 C0\nG0 A120\nM2\n%\n"
    read = get_post("linuxcnc").read(text, machine)
    mv = read.moves[-1]
    f = np.linspace(0.0, 1.0, 2001)[:, None]
    J = machine.machine_joints((1 - f) * mv.start[None] + f * mv.end[None], 0.0)
    lo = machine.axes["Y"].min
    assert J[0, 1] > lo and J[-1, 1] > lo and J[:, 1].min() == pytest.approx(-650.0, abs=1e-3)
    (v,) = axis_limit_check(read, machine, {1: 0.0})
    assert v["axis"] == "Y" and v["line"] == 7 and -650.0 <= v["value"] < lo
    assert v["value"] == pytest.approx(-650.0 * math.cos(math.radians(30.0 / 9.0)), abs=1e-6)   # A at 90 +- 60/18


def test_the_posts_rounding_of_a_capped_spindle_speed_is_not_over_the_top_speed(single_flank_plan):
    """A machine whose top speed is 1000.6 /min caps the tool there, and the posts write S1000 (whole turns,
    rounded down); a post that rounds to the nearest turn writes S1001: half a turn of rounding, not a finding;
    S1002 written by hand is over the top speed."""
    import dataclasses

    rb = rotor_body(single_flank_plan)
    machine = dataclasses.replace(load_machine("rotor-xa-b"), max_rpm=1000.6)
    prog = build_program(build_operation([single_flank_plan], rb, lobes=[0]), machine)
    for name in ("linuxcnc", "heidenhain"):
        post = get_post(name)
        text = post.write(prog)
        assert "S1000" in text and "S1001" not in text
        res = verify_program(text, post, machine, [single_flank_plan], rb)
        assert res["spindle"]["over_top_speed"] == [] and res["findings"] == [], name
        res = verify_program(text.replace("S1000", "S1001"), post, machine, [single_flank_plan], rb)
        assert res["spindle"]["over_top_speed"] == [] and res["spindle"]["max_rpm"] == 1001.0, name
        res = verify_program(text.replace("S1000", "S1002"), post, machine, [single_flank_plan], rb)
        assert res["spindle"]["over_top_speed"] and res["spindle"]["max_rpm"] == 1002.0, name


def test_before_the_first_tool_change_no_tool_is_in_the_spindle(rs274, tmp_path):
    """A program with an M6 cuts with no tool (and no offset) before its first M6, as LinuxCNC reads it, and the
    read-back refuses such a cut by name; a program without any M6 cuts with the tool its T word names."""
    machine = load_machine("rotor-xa-b")
    table = tool_table(tmp_path, (1, 2))
    early = ["%", "G21 G90 G94", "T2", "S100 M3", "G43", "G0 X0 Y0 Z10 A0 B0", "G1 X1 F100", "T1 M6", "G43 H1",
             "S100 M3", "G1 X2 F100", "M2", "%"]
    _, read = read_as_linuxcnc(rs274, tmp_path, table, "early", early, machine)
    assert [(mv.tool, mv.length_comp) for mv in read.moves] == [(0, None), (0, None), (1, 1)]
    never = [ln for ln in early if ln not in ("T1 M6", "G43 H1")]
    read = get_post("linuxcnc").read("\n".join(never) + "\n", machine)
    assert {(mv.tool, mv.length_comp) for mv in read.moves} == {(2, 2)}


def test_tcp_axis_limits_take_each_tools_own_gauge_length():
    """On a TCP head machine whose B pivot sits at the spindle nose (rotor-xa-b with TCP and
    ``tool_length_in_pivot``), B = 90 deg swings the nose a gauge length along +X past the tip: a tip at
    X 1980 puts the X joint at 1980 for a tool of gauge 0, inside the 2000 mm limit, and at 2040 for one of
    gauge 60.  The check takes each move's own tool's gauge, so the finding follows the long tool."""
    import json

    from flank_addon.machining.machine import MACHINE_DIR, parse_machine
    from flank_addon.posts.readback import axis_limit_check

    with open(f"{MACHINE_DIR}/rotor-xa-b.json", encoding="utf-8") as fh:
        data = json.load(fh)
    data["controller"] = {"tcp": True}
    data["tool_length_in_pivot"] = True
    machine = parse_machine(data)
    text = ("%\nG21 G90 G94\nT1 M6\nG43\nS1000 M3\nG0 X1980 Y0 Z0 A0 B90\n"
            "T2 M6\nG43\nG0 X1980 Y0 Z0 A0 B90\nM2\n%\n")
    read = get_post("linuxcnc").read(text, machine)
    assert [mv.tool for mv in read.moves] == [1, 2]
    assert machine.machine_joints([[1980.0, 0.0, 0.0, 0.0, 90.0]], 60.0)[0, 0] == pytest.approx(2040.0)
    assert axis_limit_check(read, machine, {1: 0.0, 2: 0.0}) == []
    (v,) = axis_limit_check(read, machine, {1: 0.0, 2: 60.0})
    assert v["axis"] == "X" and v["line"] == 9 and v["value"] == pytest.approx(2040.0)
    (v,) = axis_limit_check(read, machine, {1: 60.0, 2: 0.0})
    assert v["axis"] == "X" and v["line"] == 6 and v["value"] == pytest.approx(2040.0)


def test_heidenhain_m1_stops_the_spindle_for_the_cuts_after_it(posted):
    """Klartext M1 (optional stop) stops the spindle at the end of its block, like M0 and M5: the cuts after it
    until the next M3 / M13 run stopped, a finding naming them."""
    plan, rb, machine, prog = posted
    post = get_post("heidenhain")
    lines = post.write(prog).splitlines()
    cuts = [k for k, ln in enumerate(lines) if re.match(r"^\d+ L .* F[\d.]+", ln)]
    assert len(cuts) > 2
    edited = list(lines)
    edited[cuts[0]] += " M1"
    read = post.read("\n".join(edited) + "\n", machine)
    turns = [mv.spindle for mv in read.moves if mv.kind == "feed"]
    assert turns[0] == "cw" and set(turns[1:]) == {"off"}
    res = verify_program("\n".join(edited) + "\n", post, machine, [plan], rb)
    assert res["spindle"]["stopped"] and res["findings"]
    res = verify_program("\n".join(lines) + "\n", post, machine, [plan], rb)
    assert res["spindle"]["stopped"] == [] and res["findings"] == []


def test_fanuc_g49_ends_tcp_and_the_length_offset(two_tool_plan):
    """Fanuc: G49 cancels G43.4 (one modal group), so the moves after it are neither under TCP nor under a
    length offset, a finding; as posted, G49 stands only before the second tool change."""
    rb = rotor_body(two_tool_plan)
    machine = load_machine("xyzac-trt-tcp")
    prog = build_program(build_operation([two_tool_plan], rb, lobes=[0]), machine)
    post = get_post("fanuc")
    lines = post.write(prog).splitlines()
    (first,) = [k for k, ln in enumerate(lines) if "G43.4 H1 " in ln]
    off = list(lines)
    off[first + 1:first + 1] = ["G49"]
    read = post.read("\n".join(off) + "\n", machine)
    one = _feeds_of_tool(read, 1)
    assert one and not any(mv.tcp for mv in one) and {mv.length_comp for mv in one} == {None}
    assert all(mv.tcp and mv.length_comp == 2 for mv in _feeds_of_tool(read, 2))
    res = verify_program("\n".join(off) + "\n", post, machine, [two_tool_plan], rb)
    assert res["findings"] and res["length_compensation"]["without"]


CANON_COOLANT = re.compile(r"(FLOOD_ON|FLOOD_OFF|MIST_ON|MIST_OFF|STRAIGHT_FEED)\(")


def rs274_feed_coolants(rs274, path):
    """The coolant at every STRAIGHT_FEED of LinuxCNC's canonical output, as the reader names it."""
    import subprocess

    r = subprocess.run([rs274, "-g", str(path)], capture_output=True, text=True, timeout=120, cwd=path.parent)
    assert "PROGRAM_END()" in r.stdout and "modal group" not in r.stdout + r.stderr
    mist = flood = False
    out = []
    for kind in CANON_COOLANT.findall(r.stdout):
        if kind == "STRAIGHT_FEED":
            out.append("mist+flood" if mist and flood else "flood" if flood else "mist" if mist else "off")
        elif kind.startswith("FLOOD"):
            flood = kind == "FLOOD_ON"
        else:
            mist = kind == "MIST_ON"
    return out


def test_linuxcnc_coolant_is_the_interpreters(posted, posted_two, rs274, tmp_path):
    """M9 before pass 2, M7 before pass 3 (mist alone), M8 before pass 4 (mist and flood), M9 and then M8 before
    pass 6; and in the two-tool program without its second M8 (M6 leaves the coolant on): the reader's coolant
    at every feed move is LinuxCNC's, and only the cut without any is a finding."""
    plan, rb, machine, prog = posted
    post = get_post("linuxcnc")
    lines = post.write(prog).splitlines()
    text = "\n".join(_before_passes(lines, "(PASS ", {2: "M9", 3: "M7", 4: "M8", 6: "M9\nM8"})) + "\n"
    path = tmp_path / "coolant.ngc"
    path.write_text(text)
    read = post.read(text, machine)
    ours = [mv.coolant for mv in read.moves if mv.kind == "feed"]
    assert ours == rs274_feed_coolants(rs274, path)
    assert ours[:6] == ["flood", "off", "mist", "mist+flood", "mist+flood", "flood"]
    feeds = [mv for mv in read.moves if mv.kind == "feed"]
    res = verify_program(text, post, machine, [plan], rb)
    assert res["coolant"] == {"expected": "flood", "off": [feeds[1].line], "on": []}
    assert f"1 feed move(s) without coolant (lines {feeds[1].line}): M9, a program stop or the end before them, " \
           "and no M8 / M7 (Klartext M8 / M13) after it (or none at all: a program posted to cut dry is checked " \
           "with coolant off)" in res["findings"]
    two = get_post("linuxcnc").write(posted_two[3]).splitlines()
    m8 = [k for k, ln in enumerate(two) if ln == "M8"]
    assert len(m8) == 2
    path = tmp_path / "second_m8.ngc"
    path.write_text("\n".join(two[:m8[1]] + two[m8[1] + 1:]) + "\n")
    read = post.read(path.read_text(), posted_two[2])
    assert [mv.coolant for mv in read.moves if mv.kind == "feed"] == rs274_feed_coolants(rs274, path)
    assert {mv.coolant for mv in _feeds_of_tool(read, 2)} == {"flood"}
    with pytest.raises(Exception, match="line 3: two of M7, M8 and M9 in one block"):
        post.read("%\nG21 G90\nM7 M8\nM2\n%\n", machine)


def test_dry_and_mist_programs_are_posted_and_read_back_as_such(posted_two, rs274, tmp_path):
    """--coolant off writes no word that turns coolant on (Klartext: M3 instead of M13; M9 still ends the program)
    and mist writes M7 (Fanuc M07) with every tool: LinuxCNC's interpreter cuts dry / with mist at every feed
    move, the reader agrees, and the read-back finds nothing when told the coolant the program was posted with.
    Told otherwise it names every cut: a dry program checked for coolant, a flooded one checked as dry.  Mist on a
    TNC is refused (its M function is the machine builder's) and leaves no file; an unknown coolant is refused by
    name."""
    from flank_addon.posts import PostError, write_program

    plan, rb, machine, prog = posted_two
    for coolant, name, words in (("off", "linuxcnc", set()), ("mist", "linuxcnc", {"M7"}), ("off", "fanuc", set()),
                                 ("mist", "fanuc", {"M07"}), ("off", "heidenhain", set())):
        post = get_post(name)
        text = post.write(build_program(prog.operation, machine, coolant=coolant))
        assert {w for ln in text.splitlines() for w in re.findall(r"\bM0?[78]\b|\bM1[34]\b", ln)} == words, \
            (coolant, name)
        read = post.read(text, machine)
        feeds = [mv for mv in read.moves if mv.kind == "feed"]
        assert len({mv.tool for mv in feeds}) == 2 and {mv.coolant for mv in feeds} == {coolant}, (coolant, name)
        if name == "linuxcnc":
            path = tmp_path / f"{coolant}.ngc"
            path.write_text(text)
            assert rs274_feed_coolants(rs274, path) == [coolant] * len(feeds)
        if name == "heidenhain":
            assert re.search(r" R0 FMAX M3$", text, re.M) and " M13" not in text
        res = verify_program(text, post, machine, [plan], rb, coolant=coolant)
        assert res["coolant"] == {"expected": coolant, "off": [], "on": []} and not res["findings"], res["findings"]
        if coolant == "off":
            res = verify_program(text, post, machine, [plan], rb)
            assert res["coolant"]["off"] == [mv.line for mv in feeds] and res["findings"]
        else:           # mist where flood is the default: coolant all the same
            assert not verify_program(text, post, machine, [plan], rb)["findings"]
    text = get_post("linuxcnc").write(prog)
    feeds = [mv for mv in get_post("linuxcnc").read(text, machine).moves if mv.kind == "feed"]
    res = verify_program(text, get_post("linuxcnc"), machine, [plan], rb, coolant="off")
    assert res["coolant"] == {"expected": "off", "off": [], "on": [mv.line for mv in feeds]}
    assert len(feeds) == 8 and res["findings"] == [
        f"8 feed move(s) with coolant on (lines {', '.join(str(mv.line) for mv in feeds)}) in a program posted to cut "
        "dry: an M8 / M7 (Klartext M8 / M13) before them"]
    with pytest.raises(PostError, match="coolant 'mist': the Klartext post turns on flood coolant"):
        write_program(build_program(prog.operation, machine, coolant="mist"), "heidenhain", tmp_path / "mist.h")
    assert not (tmp_path / "mist.h").exists()
    with pytest.raises(ValueError, match="coolant 'wet' is not one of flood, mist, off"):
        build_program(prog.operation, machine, coolant="wet")
    with pytest.raises(ValueError, match="coolant 'wet' is not one of flood, mist, off"):
        verify_program(text, get_post("linuxcnc"), machine, [plan], rb, coolant="wet")


def test_heidenhain_coolant_words_act_where_the_tnc_acts(posted):
    """Klartext: M9 at the end of a cut's block, or M0 (a program stop), leaves the cuts after it without coolant
    until M8 (on from the start of its block); M5 and M6 leave it on; as posted, M13 turns it on with the
    spindle."""
    plan, rb, machine, prog = posted
    post = get_post("heidenhain")
    lines = post.write(prog).splitlines()
    cuts = [k for k, ln in enumerate(lines) if re.match(r"^\d+ L .* F[\d.]+", ln)]
    read = post.read("\n".join(lines) + "\n", machine)
    assert {mv.coolant for mv in read.moves if mv.kind == "feed"} == {"flood"}
    for word, after in (("M9", "off"), ("M0", "off"), ("M5", "flood"), ("M6", "flood")):
        edited = list(lines)
        edited[cuts[0]] += " " + word
        read = post.read("\n".join(edited) + "\n", machine)
        cool = [mv.coolant for mv in read.moves if mv.kind == "feed"]
        assert cool[0] == "flood" and set(cool[1:]) == {after}, word
    edited = list(lines)
    edited[cuts[0]] += " M9"
    edited[cuts[2]] += " M8"
    read = post.read("\n".join(edited) + "\n", machine)
    feeds = [mv for mv in read.moves if mv.kind == "feed"]
    assert [mv.coolant for mv in feeds[:4]] == ["flood", "off", "flood", "flood"]
    res = verify_program("\n".join(edited) + "\n", post, machine, [plan], rb)
    assert res["coolant"]["off"] == [feeds[1].line] and feeds[1].line == cuts[1] + 1
    for word in ("M128", "M116", "M126", "M91", "M999"):        # would change what the blocks mean: refused
        edited = list(lines)
        edited[cuts[1]] += " " + word
        with pytest.raises(Exception, match=f"line {cuts[1] + 1}: {word} is not supported by the reader"):
            post.read("\n".join(edited) + "\n", machine)


def test_the_gcode_reader_stops_at_the_end_and_refuses_control_flow(rs274, tmp_path):
    """rs274ngc stops at M2 / M30: a move after it never runs, and the reader has none either (LinuxCNC's
    interpreter gives one feed); O-word control flow is refused by line, a Fanuc program number is read past."""
    machine = load_machine("rotor-xa-b")
    post = get_post("linuxcnc")
    lines = ["%", "G21 G90 G94", "T1 M6", "G43", "S1000 M3", "M8", "G1 X1 F100", "M30", "G1 X2 F100", "%"]
    _, read = read_as_linuxcnc(rs274, tmp_path, tool_table(tmp_path, [1]), "end", lines, machine)
    assert [mv.coolant for mv in read.moves] == rs274_feed_coolants(rs274, tmp_path / "end.ngc") == ["flood"]
    with pytest.raises(Exception, match="line 3: O-word control flow"):
        post.read("%\nG21 G90\nO100 if [0]\nM9\nO100 endif\nM2\n%\n", machine)
    assert post.read("O1234\nG21 G90\nG0 X1\nM30\n", machine).moves[0].line == 3


def test_a_spindle_speed_below_one_turn_is_refused():
    from flank_addon.machining.feeds import DEFAULT_END_MILL, spindle_speed

    assert spindle_speed(DEFAULT_END_MILL, 6.0, 24000.0) == math.floor(120000.0 / (math.pi * 6.0))
    with pytest.raises(ValueError, match="spindle speed 0.4 /min is below 1 /min"):
        spindle_speed(DEFAULT_END_MILL, 6.0, 0.4)


def test_moves_in_the_other_tcp_mode_are_named(single_flank_plan):
    """A Fanuc program for a machine without TCP whose G43 became G43.4, and a Klartext program for a TCP machine
    without its FUNCTION TCPM lines, move the tool elsewhere than the machine file's kinematics say: every move
    made in the other mode is named; as posted, none is."""
    rb = rotor_body(single_flank_plan)
    op = build_operation([single_flank_plan], rb, lobes=[0])
    for machine_name, post_name, edit, mode in (
            ("xyzac-trt", "fanuc", lambda t: t.replace("G43 H1", "G43.4 H1"), "with TCP on (G43.4 / FUNCTION TCPM)"),
            ("xyzac-trt-tcp", "heidenhain", lambda t: "\n".join(ln for ln in t.splitlines() if "TCPM" not in ln),
             "without TCP on a machine with it")):
        machine, post = load_machine(machine_name), get_post(post_name)
        text = post.write(build_program(op, machine))
        res = verify_program(text, post, machine, [single_flank_plan], rb)
        assert res["tcp"] == {"machine_tcp": machine.tcp, "other_mode": []} and not res["findings"]
        edited = edit(text)
        assert edited != text
        read = post.read(edited, machine)
        res = verify_program(edited, post, machine, [single_flank_plan], rb)
        other = [mv.line for mv in read.moves if mv.tcp != machine.tcp]
        assert len(other) >= len(read.moves) - 1 and res["tcp"]["other_mode"] == other
        assert any(f.startswith(f"{len(other)} move(s) {mode}") for f in res["findings"]), res["findings"]


# ------------------------------------------------------------------------------ Fanuc: the reference return
def test_fanuc_returns_to_the_reference_position_before_each_g49(two_tool_plan):
    """A Fanuc control with 5006#6 TOS = 0 (its default) moves the axis by the tool length when G49 cancels the
    offset.  Every G49 after a cut (before the second tool change and at the end) comes right after
    ``G91 G28 Z0.`` and ``G90``, which take Z straight to the reference position first.  The reader keeps each
    return, its axis is unknown after it (the move after it is not timed), each is checked as the straight lift
    to Z's end of travel, and the cycle time says it leaves them out.  With and without TCP."""
    from dataclasses import replace

    from flank_addon.machining.cycle_time import cycle_time, untimed_note
    from flank_addon.posts.readback import check_links, tool_gauges, tool_table

    rb = rotor_body(two_tool_plan)
    op = build_operation([two_tool_plan], rb, lobes=[0])
    post = get_post("fanuc")
    tools, _ = tool_table([two_tool_plan])
    for name in ("rotor-xa-b", "xyzac-trt-tcp"):
        machine = load_machine(name)
        text = post.write(build_program(op, machine))
        lines = text.splitlines()
        g49 = [k for k, ln in enumerate(lines) if ln == "G49" and k > 5]
        assert len(g49) == 2 and all(lines[k - 2:k] == ["G91 G28 Z0.", "G90"] for k in g49)
        read = post.read(text, machine)
        assert [(line, axis, tool) for line, _, axis, tool in read.reference_returns] == [(g49[0] - 1, 2, 1),
                                                                                          (g49[1] - 1, 2, 2)]
        assert all(np.isfinite(row).all() for _, row, _, _ in read.reference_returns)
        res = verify_program(text, post, machine, [two_tool_plan], rb)
        assert res["findings"] == [] and res["reference_returns"] == 2
        without = check_links(replace(read, reference_returns=[]), machine, tools, rb)
        assert res["links"]["moves_checked"] == without["moves_checked"] + 2
        times = cycle_time(read, machine, tool_gauges(tools))
        assert times["reference_returns"] == times["untimed_returns"] == 2 and times["reference_return_time_s"] == 0
        assert untimed_note(0, machine, times["untimed_returns"]) == \
            ", not counting 2 return(s) to the reference position (G28; the machine file gives no reference_position)"
        # with the reference position in the machine file each return is a rapid of Z up to it, timed as the
        # program's other rapids: from the Z the return starts at (rotor-xa-b without TCP: the Z word in force)
        if name == "rotor-xa-b":
            top = machine.axes["Z"].max
            placed = replace(machine, reference_position={"Z": top})
            timed = cycle_time(read, placed, tool_gauges(tools))
            z, expect = None, 0.0
            for ln in lines:
                if ln == "G91 G28 Z0.":
                    expect += abs(top - z) / machine.axes["Z"].rapid * 60.0
                if not ln.startswith(("(", "G91")):             # a block's Z word (comments and G28 aside)
                    z = next((float(w[1:]) for w in ln.split() if re.fullmatch(r"Z-?[0-9.]+", w)), z)
            assert expect > 1.0 and timed["untimed_returns"] == 0
            assert abs(timed["reference_return_time_s"] - expect) < 1e-9
            assert abs(timed["rapid_time_s"] - times["rapid_time_s"] - expect) < 1e-9
            assert abs(timed["total_time_s"] - times["total_time_s"] - expect) < 1e-9
            assert untimed_note(0, placed, timed["untimed_returns"]) == ""
    # a hand-made return from under the rotor, mid-body: its lift goes through the stock, a finding at its line
    machine = load_machine("rotor-xa-b")
    lines = post.write(build_program(op, machine)).splitlines()
    first_cut = next(k for k, ln in enumerate(lines) if ln.startswith("G01 "))
    mid = 0.5 * (rb.z_range[0] + rb.z_range[1])
    below = ["G94", f"G00 X{mid:.4f} Y0. Z{-rb.outer_radius - 30.0:.4f}", "G91 G28 Z0.", "G90"]
    edited = lines[:first_cut + 1] + below + lines[first_cut + 1:]
    res = verify_program("\n".join(edited) + "\n", post, machine, [two_tool_plan], rb)
    depths = [b["depth_mm"] for b in res["links"]["intrusions"] if b["line"] == first_cut + 4]
    assert depths and max(depths) > 0.9 * rb.outer_radius


def test_a_return_is_timed_from_where_the_machine_stands(two_tool_plan):
    """A return the program makes right after a tool change (its program row unknown) starts where the tool-change
    cycle left the machine: with the file's tool_change_position it is timed from there, without it it is
    counted as untimed, and the note says why (not: no reference_position).  On a TCP machine the returns are
    timed from the joints of the program rows before them."""
    from dataclasses import replace

    from flank_addon.machining.cycle_time import cycle_time, untimed_note
    from flank_addon.posts.readback import tool_gauges, tool_table

    rb = rotor_body(two_tool_plan)
    op = build_operation([two_tool_plan], rb, lobes=[0])
    post = get_post("fanuc")
    gauges = tool_gauges(tool_table([two_tool_plan])[0])
    plain = load_machine("rotor-xa-b")
    lines = post.write(build_program(op, plain)).splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.startswith("T2 M06"))
    edited = "\n".join(lines[:k + 2] + ["G91 G28 Z0.", "G90"] + lines[k + 2:]) + "\n"
    at = replace(plain, reference_position={"Z": 800.0}, tool_change_position={"X": 0.0, "Y": 0.0, "Z": 700.0})
    read = post.read(edited, at)
    assert len(read.reference_returns) == 3 and not np.isfinite(read.reference_returns[1][1]).all()
    timed = cycle_time(read, at, gauges)
    assert timed["untimed_returns"] == 0
    without_it = cycle_time(replace(read, reference_returns=[r for j, r in enumerate(read.reference_returns)
                                                             if j != 1]), at, gauges)
    # from the tool-change position's Z 700 up to 800 at Z's rapid rate
    assert abs(timed["reference_return_time_s"] - without_it["reference_return_time_s"]
               - 100.0 / plain.axes["Z"].rapid * 60.0) < 1e-9
    unknown = replace(plain, reference_position={"Z": 800.0})
    times = cycle_time(post.read(edited, unknown), unknown, gauges)
    assert times["untimed_returns"] == 1
    assert untimed_note(0, unknown, 1) == (", not counting 1 return(s) to the reference position (G28 from where "
                                           "the program does not know the machine stands)")
    # TCP: the joints of the row before each return, through the kinematics with the tool's gauge length
    tcp = load_machine("xyzac-trt-tcp")
    tcp_ref = replace(tcp, reference_position={"Z": tcp.axes["Z"].max})
    text = post.write(build_program(op, tcp_ref))
    read = post.read(text, tcp_ref)
    t = cycle_time(read, tcp_ref, gauges)
    z = [tcp.machine_joints(np.array([row]), gauges[tool])[0][2] for _, row, _, tool in read.reference_returns]
    expect = sum(abs(tcp.axes["Z"].max - v) for v in z) / tcp.axes["Z"].rapid * 60.0
    assert t["untimed_returns"] == 0 and expect > 0.1 and abs(t["reference_return_time_s"] - expect) < 1e-9


def test_a_reference_position_down_the_retract_axis_is_checked_that_way(two_tool_plan):
    """A machine file whose reference position lies at the far end of Z's travel: a G28 takes the tool there,
    straight down through the rotor.  The post refuses by name; the read-back of a program posted without the key
    finds the return's move into the stock at its line."""
    from dataclasses import replace

    from flank_addon.machining.operation import OperationError

    rb = rotor_body(two_tool_plan)
    op = build_operation([two_tool_plan], rb, lobes=[0])
    plain = load_machine("rotor-xa-b")
    low = replace(plain, reference_position={"Z": plain.axes["Z"].min})
    with pytest.raises(OperationError, match=r"moving it along Z to -500 \(the reference position: the way a "
                                             r"reference return takes it\) enters"):
        build_program(op, low)
    post = get_post("fanuc")
    text = post.write(build_program(op, plain))
    res = verify_program(text, post, low, [two_tool_plan], rb)
    returns = [line for line, _, _, _ in post.read(text, low).reference_returns]
    assert res["links"]["max_intrusion_mm"] > 1.0
    assert {b["line"] for b in res["links"]["intrusions"]} & set(returns)
    assert verify_program(text, post, plain, [two_tool_plan], rb)["links"]["max_intrusion_mm"] == 0


def test_a_tool_that_cannot_be_lifted_straight_up_is_refused(two_tool_plan):
    """Where a tool ends, the toolpath checks the straight lift of Z to its end of travel (the way G28 and the
    tool-change cycle take it): with TCP as program rows whose machine joints differ in Z alone; the posted
    program's ends are clear, the same tool under the rotor mid-body is refused by name."""
    from flank_addon.machining.operation import OperationError
    from flank_addon.machining.toolpath import _check_lift, _Planner, lift_rows

    rb = rotor_body(two_tool_plan)
    op = build_operation([two_tool_plan], rb, lobes=[0])
    for name in ("xyzac-trt-tcp", "rotor-xa-b"):          # the last one's end is moved under the rotor below
        machine = load_machine(name)
        prog = build_program(op, machine)
        k = next(i for i, o in enumerate(prog.ops) if o["op"] == "tool" and o["number"] == 2)
        end = next(o["row"] for o in reversed(prog.ops[:k]) if o["op"] == "rapid")
        tool = op.tool(1)
        rows = lift_rows(machine, end, tool.gauge_length)
        J = machine.machine_joints(rows, tool.gauge_length)
        assert np.allclose(rows[0], end) and J[1, 2] == machine.axes["Z"].max
        assert np.allclose(np.delete(J[1], 2), np.delete(J[0], 2))
        pl = _Planner(op, machine, "forward", 1e-3, 1.0, 1.5)
        _check_lift(pl, tool, end)
    below = np.array(end, float)
    below[:3] = [0.5 * (rb.z_range[0] + rb.z_range[1]), 0.0, -rb.outer_radius - 30.0]
    with pytest.raises(OperationError, match=r"tool 1 ends where moving it along Z to 800 \(the end of its travel: "
                                             r"the way the tool-change cycle takes it\) enters the stock"):
        _check_lift(pl, tool, below)


def test_the_fanuc_reader_follows_only_a_straight_reference_return():
    """G28 with G91 and Z0. alone is followed (Z unknown after it, until the program names it); G28 under G90
    (its words are a point it passes first), another axis, a nonzero word and axis words under G91 elsewhere are
    refused by line.  The readers also refuse what the controls refuse: a word twice in one block, two spindle
    words in one block, a tool number with a fraction, and the words they do not follow (Q, D, and P but with
    LinuxCNC's G64).  LinuxCNC's reader follows no G28 (its G28 goes to a
    stored position)."""
    from flank_addon.posts.base import PostError

    machine = load_machine("rotor-xa-b")
    post = get_post("fanuc")
    head = ["%", "O1000", "G21", "G17 G40 G49 G80 G90 G94 G54", "T1 M06", "S1000 M03", "G00 G43 H1 X0. Y0. Z100."]
    read = post.read("\n".join(head + ["G91 G28 Z0.", "G90", "G00 X5.", "G00 Z50.", "M30", "%"]), machine)
    assert [r[0] for r in read.reference_returns] == [8]
    assert np.isnan(read.moves[1].start[2]) and np.isnan(read.moves[1].end[2]) and read.moves[1].end[0] == 5.0
    assert np.isnan(read.moves[2].start[2]) and read.moves[2].end[2] == 50.0
    for extra, message in ((["G28 Z0."], "line 8: G28 under G90"),
                           (["G91 G28 X0."], "line 8: the reader follows a reference return of the retract axis"),
                           (["G91 G28 Z5."], "line 8: the reader follows a reference return of the retract axis"),
                           (["G91 G00 Z5."], r"line 8: incremental axis words \(G91\)"),
                           (["G91 G28 Z0.", "G00 Z5."], r"line 9: incremental axis words \(G91\)"),
                           (["G00 X1. X2."], "line 8: two X words in one block"),
                           (["M03 M04"], "line 8: two of M3, M4 and M5 in one block"),
                           (["T1.5"], "line 8: T1.5 is not a whole number"),
                           (["G00 X1. Q2"], "line 8: word Q2 is not supported by the reader"),
                           (["G00 X1. D2"], "line 8: word D2 is not supported by the reader"),
                           (["G00 X1. P5"], "line 8: word P5 is not supported by the reader"),
                           (["S-5 M03"], "line 8: S-5 is negative"),
                           (["G01 X1. F-3"], "line 8: F-3 is negative")):
        with pytest.raises(PostError, match=message):
            post.read("\n".join(head + extra + ["M30", "%"]), machine)
    linuxcnc = get_post("linuxcnc")
    assert len(linuxcnc.read("%\nG21 G90 G64 P0.001\nG0 X1\nM2\n%\n", machine).moves) == 1   # G64's P: blending
    tabs = linuxcnc.read("%\nG21\tG90\nT1\tM6\nG0\tX1\nM2\n%\n", machine)               # tabs are spaces
    assert tabs.tool_changes == [(1, 3)] and tabs.moves[0].end[0] == 1.0
    for block in ("G91 G28 Z0", "G28 Z0"):
        with pytest.raises(PostError, match="line 4: G(91|28) is not supported by the reader"):
            linuxcnc.read("%\nG21 G90\nG0 X1\n" + block + "\nM2\n%\n", machine)


def test_tcp_chords_too_long_are_refused_when_posting_and_a_finding_on_read_back(single_flank_plan):
    """A TCP pass runs on chords of the tip's helix, off the plan's screw motion by their sagitta: the post refuses
    a chord tolerance over 0.005 mm, and at 0.005 mm the read-back's interpolation error stays under its 0.01 mm
    match tolerance (no finding).  The same program with three of every four blocks of each pass left out (chords
    four times as long, sagitta about 16 times) is a finding, by line, with the error the sampling measures."""
    from flank_addon.machining.toolpath import MAX_CHORD_TOLERANCE_MM
    from flank_addon.posts.readback import MATCH_TOL_MM

    rb = rotor_body(single_flank_plan)
    op = build_operation([single_flank_plan], rb, lobes=[0])
    tcp, post = load_machine("xyzac-trt-tcp"), get_post("linuxcnc")
    with pytest.raises(ValueError, match=r"chord tolerance 0.0051 must be a number > 0 and at most 0.005 mm"):
        build_program(op, tcp, chord_tolerance=0.0051)
    text = post.write(build_program(op, tcp, chord_tolerance=MAX_CHORD_TOLERANCE_MM))
    res = verify_program(text, post, tcp, [single_flank_plan], rb)
    assert res["findings"] == [] and 0.8 * MAX_CHORD_TOLERANCE_MM < res["interpolation_error_mm"] < MATCH_TOL_MM
    lines, kept, run = text.splitlines(), [], []
    for ln in lines + [""]:
        if ln.startswith("G1 "):
            run.append(ln)
            continue
        kept += [b for i, b in enumerate(run) if i % 4 == 3 or i == len(run) - 1]
        run = []
        kept.append(ln)
    edited = "\n".join(kept[:-1]) + "\n"
    res = verify_program(edited, post, tcp, [single_flank_plan], rb)
    between = res["passes_off_screw_between"]
    read = post.read(edited, tcp)
    firsts = [mv.line for a, mv in zip([None] + read.moves, read.moves) if mv.kind == "feed"
              and (a is None or a.kind != "feed")]
    assert [b["line"] for b in between] == firsts and len(firsts) == res["passes"] > 1
    worst = max(b["interpolation_error_mm"] for b in between)
    assert 10 * MAX_CHORD_TOLERANCE_MM < worst < 20 * MAX_CHORD_TOLERANCE_MM
    assert any(f.startswith(f"{len(firsts)} pass(es) leave the rotor's screw motion between their block ends by "
                            f"up to {worst:.3g} mm") for f in res["findings"]), res["findings"]
