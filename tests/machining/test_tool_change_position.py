"""The moves out of a tool change: unknown to the program, timed and checked from the machine file's
``tool_change_position`` when it gives one, counted as untimed and unchecked when it does not."""
import json

import numpy as np
import pytest

from flank_addon.machining.cycle_time import cycle_time
from flank_addon.machining.machine import MACHINE_DIR, MachineError, parse_machine
from flank_addon.machining.operation import OperationError, build_operation
from flank_addon.machining.rotor_body import rotor_body
from flank_addon.machining.toolpath import build_program
from flank_addon.posts import get_post, write_program
from flank_addon.posts.readback import verify_program


def _machine(**extra):
    with open(f"{MACHINE_DIR}/rotor-xa-b.json", encoding="utf-8") as fh:
        data = json.load(fh)
    data.update(extra)
    return parse_machine(data)


@pytest.fixture(scope="module")
def two_tools(two_tool_plan):
    rb = rotor_body(two_tool_plan)
    return two_tool_plan, rb, build_operation([two_tool_plan], rb, lobes=[0, 1])


def _posted(two_tools, machine, tmp_path, name):
    plan, rb, op = two_tools
    prog = build_program(op, machine)
    text = write_program(prog, "linuxcnc", tmp_path / name)
    return prog, text, get_post("linuxcnc").read(text, machine)


def test_the_field_is_checked_by_name():
    assert _machine().tool_change_position is None
    assert _machine(tool_change_position={"X": 0, "Y": 0, "Z": 300, "B": 0}).tool_change_position == \
        {"X": 0.0, "Y": 0.0, "Z": 300.0, "B": 0.0}
    for bad, words in (({"X": 0, "Y": 0}, "must give Z"), ({"X": 0, "Y": 0, "Z": 900}, "Z = 900 is outside -500..800"),
                       ({"X": 0, "Y": 0, "Z": 1, "C": 0}, "C: no such axis"), ([0, 0, 300], "must be an object"),
                       ({"X": 0, "Y": 0, "Z": float("nan")}, "Z must be a finite number")):
        with pytest.raises(MachineError, match=words):
            _machine(tool_change_position=bad)


def test_the_reference_position_is_checked_by_name():
    assert _machine().reference_position is None
    assert _machine(reference_position={"Z": 800}).reference_position == {"Z": 800.0}
    for bad, words in (({"Z": 900}, "reference_position.Z = 900 is outside -500..800"),
                       ({"X": 0, "Z": 700}, "reference_position.X: a reference return moves the retract axis Z alone"),
                       ({}, "must give Z, the retract axis"), (800, "must be an object such as"),
                       ({"Z": "top"}, "reference_position.Z must be a finite number")):
        with pytest.raises(MachineError, match=words):
            _machine(reference_position=bad)
    # the retract axis follows tool_axis: a machine whose tool points along X returns X
    with pytest.raises(MachineError, match="reference_position.Z: a reference return moves the retract axis X alone"):
        _machine(tool_axis="+X", reference_position={"Z": 800})


def test_the_reader_forgets_the_position_at_a_tool_change(two_tools, tmp_path):
    prog, text, read = _posted(two_tools, _machine(), tmp_path, "plain.ngc")
    changes = [line for _, line in read.tool_changes]
    assert len(changes) == 2
    for line in changes:
        after = [mv for mv in read.moves if mv.line > line][:2]
        # the rotaries turn first where the tool stands, then the linear axes move: both from unknown positions
        assert np.isnan(after[0].start).all() and np.isnan(after[0].end[:3]).all()
        assert np.isnan(after[1].start[:3]).all() and np.isfinite(after[1].end).all()


def test_without_a_position_the_moves_out_of_a_tool_change_are_counted_not_timed(two_tools, tmp_path):
    plan, rb, op = two_tools
    machine = _machine()
    prog, text, read = _posted(two_tools, machine, tmp_path, "plain.ngc")
    gauges = {t.number: t.gauge_length for t in op.tools}
    times = cycle_time(read, machine, gauges)
    unknown = [i for i, mv in enumerate(read.moves) if not np.isfinite(mv.start).all()]
    assert times["untimed_moves"] == len(unknown) == 4
    assert all(times["block_minutes"][i] == 0.0 for i in unknown)
    res = verify_program(text, get_post("linuxcnc"), machine, [plan], rb, lobes=[0, 1])
    assert res["links"]["moves_unchecked"] == 4 and res["untimed_moves"] == 4


def test_with_a_position_they_are_timed_from_it_as_rapids(two_tools, tmp_path):
    plan, rb, op = two_tools
    tc = {"X": 10.0, "Y": -20.0, "Z": 400.0}
    machine = _machine(tool_change_position=tc)
    prog, text, read = _posted(two_tools, machine, tmp_path, "tc.ngc")
    times = cycle_time(read, machine, {t.number: t.gauge_length for t in op.tools})
    rapid = np.array([machine.axes[n].rapid for n in machine.axis_names])
    first, second = [line for _, line in read.tool_changes]
    # tool 1: nothing says where the rotaries stood before the program; its linear move is timed from tc
    t1 = [i for i, mv in enumerate(read.moves) if mv.line > first][:2]
    assert times["untimed_moves"] == 1 and times["block_minutes"][t1[0]] == 0.0
    end = read.moves[t1[1]].end
    assert times["block_minutes"][t1[1]] == pytest.approx(
        max(abs(end[k] - tc[n]) / rapid[k] for k, n in enumerate("XYZ")), rel=1e-12)
    # tool 2: the rotaries turn from where tool 1 left them, at tc's X, Y, Z; then the linear move
    before = [mv for mv in read.moves if mv.line < second][-1].end
    t2 = [i for i, mv in enumerate(read.moves) if mv.line > second][:2]
    turn = read.moves[t2[0]].end
    assert times["block_minutes"][t2[0]] == pytest.approx(float(np.max(np.abs(turn[3:] - before[3:]) / rapid[3:])),
                                                          rel=1e-12)
    end = read.moves[t2[1]].end
    assert times["block_minutes"][t2[1]] == pytest.approx(
        max(abs(end[k] - tc[n]) / rapid[k] for k, n in enumerate("XYZ")), rel=1e-12)
    plain = cycle_time(get_post("linuxcnc").read(text, _machine()), _machine(),
                       {t.number: t.gauge_length for t in op.tools})
    added = sum(times["block_minutes"][i] for i in t1 + t2) * 60.0
    assert times["rapid_time_s"] == pytest.approx(plain["rapid_time_s"] + added, rel=1e-12)
    res = verify_program(text, get_post("linuxcnc"), machine, [plan], rb, lobes=[0, 1])
    assert res["links"]["moves_unchecked"] == 1 and res["links"]["max_intrusion_mm"] == 0.0


def test_a_position_inside_the_rotor_is_refused_before_posting(two_tools):
    plan, rb, op = two_tools
    with pytest.raises(OperationError, match=r"move of tool 1 out of the tool-change position to pass 1 .* enters "
                                             r"the stock by [0-9.]+ mm at"):
        build_program(op, _machine(tool_change_position={"X": 0.0, "Y": 0.0, "Z": 0.0}))


@pytest.mark.parametrize("name, tc", [("rotor-xa-b", {"X": 10.0, "Y": -20.0, "Z": 400.0, "B": 0.0}),
                                      ("xyzac-trt", {"X": 0.0, "Y": 0.0, "Z": 550.0, "A": 0.0, "C": 0.0}),
                                      ("xyzac-trt-tcp", {"X": 0.0, "Y": 0.0, "Z": 550.0, "A": 0.0, "C": 0.0})])
def test_the_checked_moves_are_the_blocks_the_post_writes(two_tools, tmp_path, monkeypatch, name, tc):
    """The moves out of a tool change that the program builder checks against the stock are the blocks the post
    writes and the reader reads back (:meth:`Machine.tool_change_groups`: without TCP the rotaries first, then
    the linear axes; with TCP one block)."""
    from flank_addon.machining import toolpath
    from flank_addon.machining.cycle_time import move_joints

    with open(f"{MACHINE_DIR}/{name}.json", encoding="utf-8") as fh:
        data = json.load(fh)
    data["tool_change_position"] = tc
    machine = parse_machine(data)
    groups = machine.tool_change_groups()
    assert groups == ([[0, 1, 2, 3, 4]] if machine.tcp else [[3, 4], [0, 1, 2]])
    checked, inside = [], [False]
    check, out_of_change = toolpath._Planner.check, toolpath._check_out_of_tool_change

    def recording_check(self, number, seq, what):
        if inside[0]:
            checked.append(np.array(seq, float))
        return check(self, number, seq, what)

    def recording_out_of_change(*args):
        inside[0] = True
        try:
            return out_of_change(*args)
        finally:
            inside[0] = False
    monkeypatch.setattr(toolpath._Planner, "check", recording_check)
    monkeypatch.setattr(toolpath, "_check_out_of_tool_change", recording_out_of_change)
    plan, rb, op = two_tools
    prog, text, read = _posted(two_tools, machine, tmp_path, name + ".ngc")
    gauges = {t.number: t.gauge_length for t in op.tools}
    J0, J1 = move_joints(read, machine, gauges)
    changes = [line for _, line in read.tool_changes]
    assert len(changes) == len(checked) == 2
    for line, seq in zip(changes, checked):
        after = [i for i, mv in enumerate(read.moves) if mv.line > line][:len(groups)]
        named = set()
        for i, group in zip(after, groups):        # each block names its group's axes, and only those are known
            named |= set(group)
            assert set(np.flatnonzero(np.isfinite(read.moves[i].end))) == named
        tool = read.moves[after[0]].tool
        joints = np.r_[J0[after[:1]], J1[after]]
        rows = machine.program_rows(joints[np.isfinite(joints).all(axis=1)], gauges[tool])
        assert seq.shape == rows.shape
        np.testing.assert_allclose(seq, rows, atol=2e-3)
