"""The control's least input increment (``controller.increment_mm`` / ``increment_deg`` of a machine file): the
posts write every axis word to it and cut every F word down to it, the read-back names the blocks of a program
posted without it, a control too coarse for the plan is refused, and a machine file without them gets the
dialect's own resolution, as before."""
import json
import re

import numpy as np
import pytest

from machining_helpers import run_rs274
from flank_addon.machining.cycle_time import cycle_time
from flank_addon.machining.machine import INCREMENTS, MACHINE_DIR, MachineError, parse_machine
from flank_addon.machining.operation import build_operation
from flank_addon.machining.rotor_body import rotor_body
from flank_addon.machining.toolpath import build_program
from flank_addon.posts import POSTS, get_post, write_program
from flank_addon.posts.base import MAX_ROUNDING_MM, PostError
from flank_addon.posts.readback import tool_gauges, tool_table, verify_program

pytestmark = pytest.mark.xdist_group("machining")     # shared session fixtures: one worker

AXIS_WORD = re.compile(r"(?<![A-Z])([XYZABC])([-+]?[0-9]*\.?[0-9]*)")
FEED_WORD = re.compile(r"(?<![A-Z])F([0-9][0-9.]*)")


def _machine(**controller):
    with open(f"{MACHINE_DIR}/rotor-xa-b.json", encoding="utf-8") as fh:
        data = json.load(fh)
    data["controller"].update(controller)
    return parse_machine(data)


def _decimals(number):
    return len(number.split(".")[1]) if "." in number else 0


def _blocks(text, post_name):
    """The program's blocks without comments (parentheses, or a Klartext ';' line)."""
    out = []
    for line in text.splitlines():
        if post_name == "heidenhain":
            line = line.split(";")[0]
            line = re.sub(r"^\d+ ", "", line)      # the block number
        else:
            line = re.sub(r"\([^)]*\)", "", line)
        if line.strip() and "PGM" not in line and "TOOL CALL" not in line and "FUNCTION" not in line:
            out.append(line)
    return out


def test_increments_are_checked_by_name():
    plain = _machine()
    assert plain.increment_mm is None and plain.increment_deg is None
    m = _machine(increment_mm=0.001, increment_deg=0.0001)
    assert (m.increment_mm, m.increment_deg) == (0.001, 0.0001)
    assert INCREMENTS[2] == 0.001
    for key, bad in (("increment_mm", 0.002), ("increment_mm", "0.001"), ("increment_deg", True),
                     ("increment_deg", -0.001), ("increment_mm", 1.0), ("increment_mm", float("nan"))):
        with pytest.raises(MachineError, match=f"controller.{key} must be the control's least input increment, "
                                               r"one of 0.1, 0.01, 0.001, 0.0001, 1e-05, 1e-06, got"):
            _machine(**{key: bad})


@pytest.mark.parametrize("post_name", list(POSTS))
def test_programs_keep_to_the_controls_increment(single_flank_plan, post_name, tmp_path, rs274):
    rb = rotor_body(single_flank_plan)
    op = build_operation([single_flank_plan], rb, lobes=[0, 1])
    post = get_post(post_name)
    plain_machine, machine = _machine(), _machine(increment_mm=0.001, increment_deg=0.001)
    plain = write_program(build_program(op, plain_machine), post, tmp_path / f"plain{post.extension}")
    path = tmp_path / f"isb{post.extension}"
    prog = build_program(op, machine)
    text = write_program(prog, post, path)
    assert "input increment" not in plain.lower()
    assert "input increment: 0.001 mm, 0.001 deg" in text.lower()     # the header says so
    # every axis word and every F word has at most the increment's 3 decimals; the plain program has 4
    words = [w for b in _blocks(text, post_name) for w in AXIS_WORD.findall(b) if w[1] not in ("", "+", "-")]
    assert len(words) > 50 and max(_decimals(v) for _, v in words) == 3
    assert max(_decimals(v) for b in _blocks(plain, post_name) for _, v in AXIS_WORD.findall(b)) == 4
    feeds = [f for b in _blocks(text, post_name) for f in FEED_WORD.findall(b)]
    assert len(feeds) >= 8 and max(_decimals(f) for f in feeds) <= 3
    # cut down, never rounded up: as the control times them, every feed block takes at least its planned time
    # (its chip load at most the planned one), and longer by under one increment of F
    read = post.read(text, machine)
    times = cycle_time(read, machine, tool_gauges(tool_table([single_flank_plan])[0]))
    taken = np.array([t for t, mv in zip(times["block_minutes"], read.moves) if mv.kind == "feed"])
    planned = np.array([o["time_min"] for o in prog.ops if o["op"] == "feed"])
    F = np.array([float(f) for f in feeds])
    assert len(taken) == len(planned) == len(F)
    assert (taken >= planned * (1 - 1e-12)).all() and (taken <= planned * (1 + 1.001e-3 / F)).all()
    assert (taken > planned * (1 + 1e-7)).any()
    # the read-back of what the control runs: every strip cut as planned, no chip load over the tool's fz
    res = verify_program(text, post, machine, [single_flank_plan], rb)
    assert res["findings"] == [] and res["finer_than_increments"] == [], res["findings"]
    # the plain program (4 decimals) checked against this machine file: every block with a finer word is named
    fine = verify_program(plain, post, machine, [single_flank_plan], rb)
    lines = plain.splitlines()
    assert len(fine["finer_than_increments"]) >= len(words) // 3
    assert all(re.search(r"[XYZABCF][-+]?[0-9]*\.[0-9]{4}", lines[no - 1]) for no in fine["finer_than_increments"])
    assert [f for f in fine["findings"] if "finer than the control's input increments" in f]
    assert res["screw_error_mm"] < 5e-3
    if post_name == "linuxcnc":                       # LinuxCNC's own interpreter reads the same numbers
        canon = run_rs274(rs274, path)
        got = np.array([mv.end for mv in read.moves])
        pos = np.array([c[1][:3].tolist() + [c[1][3 + "ABC".index(n)] for n in machine.rotary_names]
                        for c in canon])
        known = np.isfinite(got)
        assert len(canon) == len(read.moves) and np.abs(pos - got)[known].max() < 1e-9


def test_a_control_too_coarse_for_the_plan_is_refused(single_flank_plan):
    """Rounded to 0.01 mm the tool moves by several micrometres, to 0.1 mm by tens: more than a cutting block may
    move (MAX_ROUNDING_MM, half the read-back's match tolerance), and the post refuses by name, naming the
    increment and the block's line.  The rounding it measures is the rotor-frame pose change of the line's
    block, checked here through the kinematics from the written words."""
    rb = rotor_body(single_flank_plan)
    op = build_operation([single_flank_plan], rb, lobes=[0])
    post = get_post("fanuc")
    coarse = _machine(increment_mm=0.1)
    prog = build_program(op, coarse)
    with pytest.raises(PostError, match=r"input increment \(0.1 mm, machine rotor-xa-b\) moves the tool by up to "
                                        r"[0-9.]+ mm at line [0-9]+, over the 0.005 mm") as e:
        post.write(prog)
    moved, line = (float(x) for x in re.search(r"up to ([0-9.e-]+) mm at line ([0-9]+)", str(e.value)).groups())
    # the block at that line, written without the check, as the control would read it: its pose against the exact one
    text = post.write(build_program(op, _machine()))      # 4 decimals: the exact rows to 5e-5
    fine, plain = post.read(text, _machine()), post.read(post_unchecked(post, prog), coarse)
    gauge = op.tool(1).gauge_length
    k = next(i for i, mv in enumerate(plain.moves) if mv.line == int(line))
    (t0, a0), (t1, a1) = (coarse.forward(np.array([mv.end]), gauge) for mv in (fine.moves[k], plain.moves[k]))
    assert moved > MAX_ROUNDING_MM and abs(np.linalg.norm(t1 - t0) + gauge * np.linalg.norm(a1 - a0) - moved) < 1e-3
    # IS-B (0.001 mm, 0.001 deg) stays well within it: the same plan posts
    assert "G01" in post.write(build_program(op, _machine(increment_mm=0.001, increment_deg=0.001)))


def post_unchecked(post, prog):
    """The program text as the post writes it, without the rounding check."""
    check, post._check_rounding = post._check_rounding, lambda *a: None
    try:
        return post.write(prog)
    finally:
        del post._check_rounding
        assert post._check_rounding.__func__ is check.__func__


@pytest.mark.parametrize("post_name", ["linuxcnc", "fanuc"])
def test_f_words_are_cut_down_never_rounded_up(two_tool_plan, post_name):
    """Inverse-time F = 1 / planned minutes, written to about 7 digits: cut down, so no block runs faster than
    planned and no chip load goes over fz (rounded to nearest, about half of the F words went up by up to half a
    unit of their last digit, and the fastest point's chip load over fz with them)."""
    rb = rotor_body(two_tool_plan)
    op = build_operation([two_tool_plan], rb, lobes=[0, 1])
    prog = build_program(op, _machine())
    text = get_post(post_name).write(prog)
    feeds = np.array([float(f) for b in _blocks(text, post_name) for f in FEED_WORD.findall(b)])
    exact = np.array([1.0 / o["time_min"] for o in prog.ops if o["op"] == "feed"])
    assert len(feeds) == len(exact) >= 16
    assert (feeds <= exact).all()
    assert (exact - feeds <= 1e-6 * exact + 1e-6).all() and (exact - feeds > 0).mean() > 0.9
