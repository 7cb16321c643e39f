"""Holders (a chuck, a collet, a tailstock) as keep-out cylinders beyond the body's end faces: a pass that runs
out into one is refused by name, links keep clear of them, and the read-back finds a program that enters one.
The refusal threshold is checked against the posted passes sampled densely."""
import math

import numpy as np
import pytest

from flank_addon.cli import main
from flank_addon.io.plan import write_plan
from flank_addon.machining.machine import load_machine
from flank_addon.machining.operation import OperationError, build_operation
from flank_addon.machining.rotor_body import parse_holder, parse_holders, rotor_body, with_holders
from flank_addon.machining.tool_shape import place_points
from flank_addon.machining.toolpath import build_program
from flank_addon.posts import get_post
from flank_addon.posts.readback import verify_program

pytestmark = pytest.mark.xdist_group("machining")     # shared session fixtures: one worker


def _post(plan, rotor, machine="rotor-xa-b"):
    m = load_machine(machine)
    op = build_operation([plan], rotor, lobes=[0])
    text = get_post("linuxcnc").write(build_program(op, m))
    return m, op, text


def test_holders_are_given_by_side_size_and_gap(single_flank_plan):
    rb = rotor_body(single_flank_plan)
    z0, z1 = rb.z_range
    held = with_holders(rb, [parse_holder("low,100,60"), parse_holder(" high, 80, 40, 12.5 ")])
    assert held.holders == [(z0 - 60.0, z0, 50.0), (z1 + 12.5, z1 + 52.5, 40.0)]
    assert rb.holders == [] and held.shafts == rb.shafts             # a copy; the shafts stay
    assert held.safe_radius(5.0) == pytest.approx(55.0) and held.keep_out[-2:] == held.holders
    assert held.describe()["holders"][1] == {"z_range": [z1 + 12.5, z1 + 52.5], "radius": 40.0}
    for text, words in (("low,100", "must be SIDE,DIAMETER,LENGTH"), ("low,a,1", "must be numbers"),
                        ("low,1,2,3,4", "must be SIDE,DIAMETER,LENGTH")):
        with pytest.raises(ValueError, match=words):
            parse_holder(text)
    for holder, words in ((("left", 100.0, 60.0, 0.0), "holder 2: side 'left' must be one of low, high"),
                          (("low", 0.0, 60.0, 0.0), r"holder 2 \(low\): diameter 0.0 must be a number > 0"),
                          (("low", 100.0, math.inf, 0.0), "length inf must be a number > 0 and at most 100000 mm"),
                          (("high", 100.0, 60.0, -1.0), "gap -1.0 must be a number >= 0"),
                          (("high", math.nan, 60.0, 0.0), "diameter nan must be")):
        with pytest.raises(ValueError, match=words):
            with_holders(rb, [("low", 1.0, 1.0, 0.0), holder])
    assert parse_holders(" low,100,60 ;high,80,40,12.5;") == [("low", 100.0, 60.0, 0.0), ("high", 80.0, 40.0, 12.5)]
    assert parse_holders("  ") == [] and parse_holder("LOW,100,60") == ("low", 100.0, 60.0, 0.0)
    # which solid a point is in, for the messages
    assert held.solid_at([0.0, 0.0, z0 - 30.0]) == "holder 1 (at the low end, diameter 100 mm)"
    assert held.solid_at([0.0, 39.0, z1 + 20.0]) == "holder 2 (at the high end, diameter 80 mm)"
    assert held.solid_at([0.0, 0.0, 0.5 * (z0 + z1)]) == "the stock"
    assert held.solid_at([0.0, 60.0, z0 - 30.0]) is None and held.solid_at([0.0, 0.0, z1 + 5.0]) is None
    with pytest.raises(ValueError, match=r"holder 2 \(high\): length 0.0 must be a number > 0"):
        parse_holders("low,100,60; high,80,0")


def _lowest_near_axis(machine, op, text, radius, spacing=0.5, steps=400):
    """Lowest rotor-frame z that a tool point within ``radius`` of the axis reaches over the posted passes, the
    feed blocks sampled densely (a brute-force reference for the run-out check)."""
    read = get_post("linuxcnc").read(text, machine)
    tool = op.tools[0]
    local = tool.shape.local_points(spacing)
    lowest = math.inf
    for mv in read.moves:
        if mv.kind != "feed":
            continue
        u = np.linspace(0.0, 1.0, steps)[:, None]
        rows = (1.0 - u) * np.asarray(mv.start)[None] + u * np.asarray(mv.end)[None]
        tips, axes = machine.forward(rows, tool.gauge_length)
        pts = place_points(local, tips, axes).reshape(-1, 3)
        near = np.hypot(pts[:, 0], pts[:, 1]) < radius
        if near.any():
            lowest = min(lowest, float(pts[near, 2].min()))
    return lowest


def test_a_pass_that_runs_out_into_a_holder_is_refused_at_the_gap_the_sampled_passes_give(single_flank_plan):
    rb = rotor_body(single_flank_plan)
    radius = rb.outer_radius + 10.0                   # a chuck larger than the rotor, at the low end
    machine, op, text = _post(single_flank_plan, rb)
    needed = rb.z_range[0] - _lowest_near_axis(machine, op, text, radius)
    assert needed > 5.0                               # the passes run out beyond the clearance
    with pytest.raises(OperationError, match=r"running out past the body the tool enters holder 1 \(at the low "
                                             r"end, diameter 80 mm\) by .* move the holder away from the body"):
        build_operation([single_flank_plan], with_holders(rb, [("low", 2 * radius, 50.0, needed - 1.5)]), lobes=[0])
    held = with_holders(rb, [("low", 2 * radius, 50.0, needed + 1.5)])
    machine, op, text = _post(single_flank_plan, held)
    res = verify_program(text, get_post("linuxcnc"), machine, [single_flank_plan], held, lobes=[0])
    assert res["findings"] == [] and res["links"]["max_intrusion_mm"] == 0.0
    assert res["holders"] == held.describe()["holders"]
    # the program names the setup it was checked against, for the machine's operator
    a, b, r = held.holders[0]
    assert (f"(holder 1: diameter {2 * r:.4f} over {a:.4f}..{b:.4f} along the rotor axis, kept clear of; mount it "
            "no nearer the body)") in text.splitlines()
    # the links keep their clearance from the holder: the tool tip retreats beyond its radius
    read = get_post("linuxcnc").read(text, machine)
    rapids = np.array([mv.end for mv in read.moves if mv.kind == "rapid" and np.isfinite(mv.end).all()])
    tips, _ = machine.forward(rapids, op.tools[0].gauge_length)
    assert np.hypot(tips[:, 0], tips[:, 1]).max() >= held.safe_radius(op.clearance) - 1e-6


def test_the_read_back_finds_a_program_that_runs_into_a_holder(single_flank_plan):
    rb = rotor_body(single_flank_plan)
    machine, op, text = _post(single_flank_plan, rb)  # posted without knowing the chuck
    held = with_holders(rb, [("low", 2 * rb.outer_radius + 20.0, 50.0, 1.0)])
    res = verify_program(text, get_post("linuxcnc"), machine, [single_flank_plan], held, lobes=[0])
    ro = res["run_out"]
    assert ro["min_keep_out_margin_mm"] < 0 and len(ro["passes_into_keep_out"]) == res["passes"]
    assert any("enter a shaft or a holder by up to" in f for f in res["findings"])
    plain = verify_program(text, get_post("linuxcnc"), machine, [single_flank_plan], rb, lobes=[0])
    assert plain["findings"] == [] and plain["run_out"]["passes_into_keep_out"] == []


def test_the_command_line_takes_holders_for_post_and_verify(capsys, tmp_path, single_flank_plan):
    plan = tmp_path / "plan.json"
    write_plan(plan, single_flank_plan)
    out = tmp_path / "p.ngc"
    code = main(["post", str(plan), "--machine", "rotor-xa-b", "--post", "linuxcnc", "-o", str(out), "--lobes", "0",
                 "--holder", "low,80,50,1"])
    err = capsys.readouterr().err
    assert code == 2 and "enters holder 1 (at the low end, diameter 80 mm)" in err and not out.exists()
    code = main(["post", str(plan), "--machine", "rotor-xa-b", "--post", "linuxcnc", "-o", str(out), "--holder", "low"])
    assert code == 2 and "argument --holder: holder 'low' must be SIDE,DIAMETER,LENGTH[,GAP]" in capsys.readouterr().err
    code = main(["post", str(plan), "--machine", "rotor-xa-b", "--post", "linuxcnc", "-o", str(out), "--lobes", "0",
                 "--holder", "high,80,50,200", "--json"])
    js = __import__("json").loads(capsys.readouterr().out)
    z1 = rotor_body(single_flank_plan).z_range[1]
    assert code == 0 and js["rotor"]["holders"] == [{"z_range": [z1 + 200.0, z1 + 250.0], "radius": 40.0}]
    code = main(["verify", "--program", str(out), str(plan), "--machine", "rotor-xa-b", "--lobes", "0",
                 "--holder", "high,80,50,200"])
    text = capsys.readouterr().out
    assert code == 0 and "deepest intrusion into the stock, shafts or holders 0 mm" in text
    code = main(["verify", str(plan), "--holder", "high,80,50,200"])          # a plan's own check has no holders
    assert code == 2 and "--holder applies to verify --program only" in capsys.readouterr().err


def test_a_tcp_machine_keeps_its_chords_off_a_holder(single_flank_plan):
    """On a TCP machine the tip runs on chords of the helix and the whole tool with it, so a pass that clears a
    holder by less than the chords' sagitta is refused when posting -- the read-back would find it inside."""
    rb = rotor_body(single_flank_plan)
    probe = with_holders(rb, [("low", 2.0, 50.0, 0.0)])         # radius 1 mm at the low end face
    m0 = min(p.shaft_margin for p in build_operation([single_flank_plan], probe, lobes=[0]).passes)
    assert math.isfinite(m0) and m0 > 1.0
    held = with_holders(rb, [("low", 2.0 * (1.0 + m0 - 5e-4), 50.0, 0.0)])    # cleared by 0.5 um
    op = build_operation([single_flank_plan], held, lobes=[0])
    assert min(p.shaft_margin for p in op.passes) == pytest.approx(5e-4, abs=1e-9)
    build_program(op, load_machine("rotor-xa-b"))              # joint-linear passes: the exact screw motion
    with pytest.raises(OperationError, match=r"the tool passes 0.0005 mm outside holder 1 \(at the low end, .*\), "
                                             r"and on this TCP machine its chords of 0.001 mm sagitta may come "
                                             r"nearer: lower the chord tolerance \(post --chord-tolerance\); move "
                                             r"the holder away from the body"):
        build_program(op, load_machine("xyzac-trt-tcp"))
    # posted without the holder, the program's read-back against it finds the passes inside
    tcp = load_machine("xyzac-trt-tcp")
    text = get_post("linuxcnc").write(build_program(build_operation([single_flank_plan], rb, lobes=[0]), tcp))
    res = verify_program(text, get_post("linuxcnc"), tcp, [single_flank_plan], held, lobes=[0])
    assert res["run_out"]["min_keep_out_margin_mm"] < 0 and res["run_out"]["passes_into_keep_out"]
    # cleared by 10 um: posted on the TCP machine, and its read-back keeps the passes outside
    clear = with_holders(rb, [("low", 2.0 * (1.0 + m0 - 1e-2), 50.0, 0.0)])
    text = get_post("linuxcnc").write(build_program(build_operation([single_flank_plan], clear, lobes=[0]), tcp))
    res = verify_program(text, get_post("linuxcnc"), tcp, [single_flank_plan], clear, lobes=[0])
    assert 0.0 < res["run_out"]["min_keep_out_margin_mm"] < 1e-2 and res["findings"] == []


def test_the_facing_frame_turns_with_the_screw(single_flank_plan):
    """Placed in the facing frame, a tool's points at two poses of one screw motion are the same points, screwed:
    the same distances from the rotor axis, heights shifted alike (what lets the operation and the read-back
    sample a pass alike); in the fixed frame they are not."""
    from flank_addon.exports.cl_data import strip_tip
    from flank_addon.geometry.screw import screw_motion
    from flank_addon.machining.tool_shape import ToolShape

    shape = ToolShape.from_strip(single_flank_plan, 0)
    T, a, _ = strip_tip(single_flank_plan, 0)
    v0 = single_flank_plan["rotor"]["v0"]
    local = shape.local_points(1.0)
    for t in (0.3, -2.0):
        T2 = screw_motion(T, t, v0, single_flank_plan["rotor"]["handedness"])
        a2 = screw_motion(a, t, 0.0, single_flank_plan["rotor"]["handedness"])
        for facing, same in ((True, True), (False, False)):
            p1, p2 = place_points(local, T, a, facing)[0], place_points(local, T2, a2, facing)[0]
            rho1, rho2 = np.hypot(p1[:, 0], p1[:, 1]), np.hypot(p2[:, 0], p2[:, 1])
            assert np.allclose(rho1, rho2, rtol=0, atol=1e-9) == same
            if same:
                dz = p2[:, 2] - p1[:, 2]
                assert np.ptp(dz) < 1e-9 and dz[0] == pytest.approx(T2[2] - T[2], abs=1e-9)


def test_the_read_back_reports_progress_and_stops_when_asked(single_flank_plan):
    """verify_program reports before each plan's own sweep and each lobe's, and a progress callback that answers
    False stops it there (Blender's Esc while Post Program reads its program back)."""
    from flank_addon.progress import Cancelled

    rb = rotor_body(single_flank_plan)
    machine = load_machine("rotor-xa-b")
    text = get_post("linuxcnc").write(build_program(build_operation([single_flank_plan], rb, lobes=[0, 2]), machine))
    seen = []
    res = verify_program(text, get_post("linuxcnc"), machine, [single_flank_plan], rb,
                         progress=lambda f, m: seen.append((round(f, 6), m)))
    assert seen == [(0.0, "plan 0: its own deviation"), (round(1 / 3, 6), "plan 0: the program's passes on lobe 0"),
                    (round(2 / 3, 6), "plan 0: the program's passes on lobe 2")]
    assert res["findings"] == []
    with pytest.raises(Cancelled):
        verify_program(text, get_post("linuxcnc"), machine, [single_flank_plan], rb,
                       progress=lambda f, m: "lobe 2" not in m)
