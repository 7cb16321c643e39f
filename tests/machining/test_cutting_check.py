"""The read-back's cutting conditions: every feed move's chip load, surface speed and spindle speed as the
controller makes them (its S, and the block's time from its F) against the tool's cutting data.  References:
LinuxCNC's own interpreter (feed rates and spindle speeds of its canonical moves) with the chip load of a screw
motion in closed form, and the post's own per-pass figures."""
import contextlib
import io
import json
import math
import re
import subprocess

import numpy as np
import pytest

from flank_addon.machining.feeds import CuttingData
from flank_addon.machining.machine import builtin_machines, load_machine
from flank_addon.machining.operation import build_operation
from flank_addon.machining.rotor_body import rotor_body
from flank_addon.machining.toolpath import build_program
from flank_addon.posts import POSTS, get_post
from flank_addon.posts.readback import verify_program

pytestmark = pytest.mark.xdist_group("machining")     # shared session fixtures: one worker

CANON = re.compile(r"(SET_SPINDLE_SPEED|SET_FEED_RATE|STRAIGHT_FEED|STRAIGHT_TRAVERSE)\(([^)]*)\)")


def rs274_chip_loads(rs274, path, v0, outer_radius, flutes):
    """Chip load of every STRAIGHT_FEED of LinuxCNC's canonical output on rotor-xa-b (the rotor's axis on X, so
    a block turns the screw by |dX| / v0): its time is LinuxCNC's (XYZ distance, or ABC without XYZ, over the
    feed rate), and the fastest rotor point past the tool is on the stock's rim, sqrt(R^2 + v0^2) per radian."""
    out = subprocess.run([rs274, "-g", str(path)], capture_output=True, text=True, timeout=120,
                         cwd=path.parent).stdout
    assert "PROGRAM_END()" in out
    speed = feed = 0.0
    prev, loads = None, []
    for kind, args in CANON.findall(out):
        vals = [float(x) for x in args.split(",")]
        if kind == "SET_SPINDLE_SPEED":
            speed = vals[1]
        elif kind == "SET_FEED_RATE":
            feed = vals[0]
        else:
            pos = np.array(vals[:6])
            if kind == "STRAIGHT_FEED":
                d = pos - prev
                lin, rot = np.linalg.norm(d[:3]), np.linalg.norm(d[3:])
                minutes = (lin if lin > 0 else rot) / feed
                loads.append(abs(d[0]) / v0 / minutes * math.hypot(outer_radius, v0) / (speed * flutes))
            prev = pos
    return np.array(loads)


def test_a_faster_feed_is_found_where_linuxcnc_cuts_it(posted, rs274, tmp_path):
    """One pass's F raised by a quarter by hand: LinuxCNC's interpreter cuts that block at 1.25 times the chip
    load of the others, over the tool preset's fz; the read-back finds exactly that block, with LinuxCNC's
    chip load (the closed form on the stock's rim, which the tool reaches out of; rs274 prints the feed rates to
    4 decimals)."""
    plan, rb, machine, prog = posted
    post = get_post("linuxcnc")
    lines = post.write(prog).splitlines()
    feeds = [k for k, ln in enumerate(lines) if ln.startswith("G1 ")]
    n = len(feeds)
    assert n == len(prog.passes) >= 8                   # one joint-linear block per pass
    k = feeds[3]
    edited = list(lines)
    F = float(re.search(r"F([\d.]+)", lines[k]).group(1))
    edited[k] = re.sub(r"F[\d.]+", "F{:.6f}".format(1.25 * F), lines[k])
    data = prog.operation.tools[0].data               # the D3 L25 preset's: 3 flutes, fz 0.015 mm
    assert data.source == "Tapered 2deg D3 L25"
    fz = data.fz_mm
    for name, text in (("as_posted", lines), ("edited", edited)):
        path = tmp_path / (name + ".ngc")
        path.write_text("\n".join(text) + "\n")
        ref = rs274_chip_loads(rs274, path, rb.v0, rb.outer_radius, data.flutes)
        res = verify_program(path.read_text(), post, machine, [plan], rb)
        (t,) = res["cutting"]["tools"]
        assert t["cutting_data"] == data.as_dict()
        assert len(ref) == n and t["max_chip_load_mm"] == pytest.approx(ref.max(), rel=1e-5)
        if name == "as_posted":
            assert ref.max() == pytest.approx(fz, rel=1e-5) and res["findings"] == []
            assert res["cutting"]["over_chip_load"] == []
        else:
            assert ref[3] == pytest.approx(1.25 * ref[np.arange(n) != 3].max(), rel=1e-5)
            assert res["cutting"]["over_chip_load"] == [k + 1]
            assert t["moves_over"] == {"over_chip_load": 1, "over_surface_speed": 0, "over_tool_top_speed": 0}
            (finding,) = res["findings"]
            assert finding.startswith("1 feed move(s) load the tool over its feed per tooth (lines {}): T1 chip "
                                      "load up to".format(k + 1)) and "against fz 0.015 mm (Tapered 2deg D3 L25)" in finding


def test_a_faster_spindle_is_over_the_cutting_speed_and_the_tools_top_speed(posted, tmp_path):
    """S raised by hand before the second lobe's passes: the surface speed grows with S (pi D_max n / 1000, the
    post's own figure scaled), over vc; with cutting data whose top speed is under the new S, that is a finding
    too.  Half the speed instead loads the tool twice as much with the same feeds."""
    plan, rb, machine, prog = posted
    post = get_post("linuxcnc")
    text = post.write(prog)
    (s_word,) = set(re.findall(r"S(\d+)", text))
    S = int(s_word)
    lines = text.splitlines()
    feeds = [k for k, ln in enumerate(lines) if ln.startswith("G1 ")]
    edited = lines[:feeds[4]] + ["S{} M3".format(2 * S)] + lines[feeds[4]:]
    res = verify_program("\n".join(edited) + "\n", post, machine, [plan], rb)
    (t,) = res["cutting"]["tools"]
    vc_post = max(p["surface_speed_m_min"][1] for p in prog.passes)
    assert t["max_surface_speed_m_min"] == pytest.approx(vc_post * 2 * S / prog.operation.tools[0].rpm, rel=1e-9)
    assert res["cutting"]["over_surface_speed"] == [k + 2 for k in feeds[4:]]
    assert res["cutting"]["over_chip_load"] == [] and res["cutting"]["over_tool_top_speed"] == []
    assert any("cut faster than the tool's cutting speed" in f and "against vc 100 m/min" in f
               for f in res["findings"])
    # half the speed instead: the same feeds load the tool twice as much, and the surface speed halves
    halved = lines[:feeds[4]] + ["S{} M3".format(S // 2)] + lines[feeds[4]:]
    res_half = verify_program("\n".join(halved) + "\n", post, machine, [plan], rb)
    (h,) = res_half["cutting"]["tools"]
    assert res_half["cutting"]["over_chip_load"] == [k + 2 for k in feeds[4:]]
    assert h["max_chip_load_mm"] == pytest.approx(prog.operation.tools[0].data.fz_mm * S / (S // 2), rel=1e-6)
    assert h["max_surface_speed_m_min"] == pytest.approx(vc_post, rel=1e-9)      # lobe 0's, at S
    slow = CuttingData(3, 100.0, 0.015, 1.5 * S, "a slower spindle")
    res = verify_program("\n".join(edited) + "\n", post, machine, [plan], rb, cutting_data=slow)
    assert res["cutting"]["over_tool_top_speed"] == [k + 2 for k in feeds[4:]]
    assert any("turn the tool faster than its top speed" in f and "T1 at up to S{} against its {:g} /min "
               "(a slower spindle)".format(2 * S, 1.5 * S) in f for f in res["findings"])


@pytest.mark.parametrize("post_name", list(POSTS))
@pytest.mark.parametrize("machine_name", builtin_machines())
def test_as_posted_every_tool_cuts_at_the_posts_own_figures(two_tool_plan, machine_name, post_name):
    """Every built-in machine and post, two tools: the read-back's chip load and surface speed per tool are the
    post's own per-pass figures, up to the rounding of S, F and the axes (within CUTTING_TOL), and no finding."""
    from flank_addon.posts.readback import CUTTING_TOL

    rb = rotor_body(two_tool_plan)
    machine = load_machine(machine_name)
    prog = build_program(build_operation([two_tool_plan], rb, lobes=[0]), machine)
    post = get_post(post_name)
    res = verify_program(post.write(prog), post, machine, [two_tool_plan], rb)
    assert res["findings"] == []
    assert [t["tool"] for t in res["cutting"]["tools"]] == [1, 2]
    for t, tool in zip(res["cutting"]["tools"], prog.operation.tools):
        mine = [p for p in prog.passes if p["tool"] == tool.number]
        S = round(tool.rpm)
        rounding = max(tool.rpm / S, S / tool.rpm)
        assert t["max_rpm"] == S
        assert t["max_chip_load_mm"] == pytest.approx(max(p["chip_load_mm"][1] for p in mine),
                                                      rel=CUTTING_TOL + rounding - 1)
        assert t["max_surface_speed_m_min"] == pytest.approx(max(p["surface_speed_m_min"][1] for p in mine),
                                                             rel=rounding - 1 + 1e-12)
        assert t["cutting_data"] == tool.data.as_dict()


def test_the_command_line_checks_against_the_data_it_is_given(posted, tmp_path, capsys):
    """verify --program takes the post's cutting-data options: the data the program was posted with pass, a
    smaller fz is a finding naming the command line (exit status 1), and the options need --program."""
    from flank_addon.cli import main

    plan, rb, machine, prog = posted
    plan_path = tmp_path / "plan.json"
    plan_path.write_text(json.dumps(plan))
    prog_path = tmp_path / "prog.ngc"
    prog_path.write_text(get_post("linuxcnc").write(prog))

    def verify(*extra):
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            code = main(["verify", "--program", str(prog_path), str(plan_path), "--machine", "rotor-xa-b",
                         "--lobes", "0,1", *extra])
        return code, buf.getvalue()

    code, out = verify()
    assert code == 0 and "T1 cuts at chip loads up to 0.015" in out and "within its cutting data" in out
    code, out = verify("--cutting-data", "Tapered 2deg D3 L25", "--fz", "0.01")
    assert code == 1 and "OVER chip load" in out
    assert "against fz 0.01 mm (Tapered 2deg D3 L25 with fz_mm 0.01 from the command line)" in out
    assert "NOT AS PLANNED: {} feed move(s) load the tool".format(len(prog.passes)) in out
    capsys.readouterr()
    code = main(["verify", str(plan_path), "--fz", "0.02"])
    assert code == 2 and "--fz applies to verify --program only" in capsys.readouterr().err


def test_the_command_line_posts_and_checks_a_dry_cut(posted, tmp_path, capsys):
    """post --coolant off writes a program without M8 and says so in --json; verify --program checks it as dry
    with --coolant off (exit 0, "dry on every one") and finds every cut without coolant otherwise (exit 1); the
    option needs --program."""
    from flank_addon.cli import main

    plan, rb, machine, prog = posted
    plan_path = tmp_path / "plan.json"
    plan_path.write_text(json.dumps(plan))
    prog_path = tmp_path / "dry.ngc"

    def run(*args):
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            code = main(list(args))
        return code, buf.getvalue()

    code, out = run("post", str(plan_path), "--machine", "rotor-xa-b", "--post", "linuxcnc", "--lobes", "0,1",
                    "--coolant", "off", "-o", str(prog_path), "--json")
    assert code == 0 and json.loads(out)["coolant"] == "off"
    text = prog_path.read_text()
    assert "M8" not in text.split() and "M7" not in text.split() and "M9" in text.split()
    check = ("verify", "--program", str(prog_path), str(plan_path), "--machine", "rotor-xa-b", "--lobes", "0,1")
    code, out = run(*check, "--coolant", "off")
    assert code == 0 and "; dry on every one;" in out and "NOT AS PLANNED" not in out
    code, out = run(*check)
    assert code == 1 and f"; {len(prog.passes)} without coolant;" in out
    assert f"NOT AS PLANNED: {len(prog.passes)} feed move(s) without coolant" in out
    capsys.readouterr()
    assert main(["verify", str(plan_path), "--coolant", "off"]) == 2
    assert "--coolant applies to verify --program only" in capsys.readouterr().err
    assert main([*check, "--tolerance", "nan"]) == 2
    assert "--tolerance nan applies to verify without --program" in capsys.readouterr().err


def test_short_tcp_chords_and_a_plunge_into_the_stock(posted, tmp_path):
    """A TCP program posted with chords of 2e-5 mm sagitta (blocks whose screw advance the axes' rounding moves
    by a noticeable share): no finding, and the largest chip load of a block fz to 2e-3 (the rounding of a short
    chord's advance to 0.0001 mm shows in it).  A pass whose first block plunges into the stock from outside it
    (by hand, at 20000 /min): its cuts are still judged, over vc.  Without a spindle speed a move is counted as
    not checked."""
    from flank_addon.cli import main

    plan, rb, machine, prog = posted
    tcp = load_machine("xyzac-trt-tcp")
    fine = build_program(build_operation([plan], rb, lobes=[0]), tcp, chord_tolerance=2e-5)
    post = get_post("fanuc")
    res = verify_program(post.write(fine), post, tcp, [plan], rb)
    (t,) = res["cutting"]["tools"]
    assert res["findings"] == [] and len(fine.passes) < res["moves"] / 100
    assert t["max_chip_load_mm"] == pytest.approx(fine.operation.tools[0].data.fz_mm, rel=2e-3)

    post = get_post("linuxcnc")
    lines = post.write(prog).splitlines()
    first = next(k for k, ln in enumerate(lines) if ln.startswith("G1 "))
    approach = next(k for k in range(first, 0, -1) if re.fullmatch(r"G0 Z[-\d.]+", lines[k]))
    z = lines[approach].split("Z")[1]
    plunge = lines[:approach] + ["G0 Z20", "G1 Z{} F500".format(z)] + lines[approach + 1:]
    plunge = [re.sub(r"^S\d+ M3$", "S20000 M3", ln) for ln in plunge]
    res = verify_program("\n".join(plunge) + "\n", post, machine, [plan], rb)
    cut_lines = [k + 1 for k, ln in enumerate(plunge) if ln.startswith("G1 ")]
    assert res["cutting"]["over_surface_speed"] == cut_lines and len(cut_lines) == len(prog.passes) + 1
    assert res["passes_off_screw"] and res["passes_off_screw"][0]["line"] == cut_lines[0]
    plan_path, prog_path = tmp_path / "plan.json", tmp_path / "s0.ngc"
    plan_path.write_text(json.dumps(plan))
    prog_path.write_text("\n".join(re.sub(r"^S\d+ M3$", "S0 M3", ln) for ln in lines) + "\n")
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(["verify", "--program", str(prog_path), str(plan_path), "--machine", "rotor-xa-b"])
    assert code == 1 and "within its cutting data where it has a speed; {} feed move(s) without a spindle " \
        "speed not checked".format(len(prog.passes)) in buf.getvalue()
