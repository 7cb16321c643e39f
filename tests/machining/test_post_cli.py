"""The post and verify --program commands: what they refuse and how, units, extents, atomic output."""
import copy
import json
import os

import numpy as np
import pytest

from flank_addon.cli import main
from flank_addon.io.plan import PlanError, validate_plan, write_plan
from flank_addon.machining.machine import load_machine
from flank_addon.machining.rotor_body import scale_plan
from flank_addon.posts import PostError, atomic_write

pytestmark = pytest.mark.xdist_group("machining")     # shared session fixtures: one worker


@pytest.fixture
def plan_file(tmp_path, double_flank_plan):
    path = tmp_path / "plan.json"
    write_plan(path, double_flank_plan)
    return path


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_unknown_post_and_machine_list_the_valid_names(capsys, tmp_path, plan_file):
    out = tmp_path / "p.nc"
    code, _, err = run(capsys, "post", plan_file, "--machine", "rotor-xa-b", "--post", "haas", "-o", out)
    assert code == 2 and "unknown post 'haas'; valid posts: linuxcnc, fanuc, heidenhain" in err
    code, _, err = run(capsys, "post", plan_file, "--machine", "mill-9000", "--post", "fanuc", "-o", out)
    assert code == 2 and "unknown machine 'mill-9000'" in err and "xyzac-trt-tcp" in err
    code, _, err = run(capsys, "post", plan_file, "--machine", tmp_path, "--post", "fanuc", "-o", out)
    assert code == 2 and f"machine '{tmp_path}' is a folder: give a machine file (flank-machine/1 JSON)" in err
    assert not out.exists()


def test_an_empty_output_and_a_plan_given_twice_are_named(capsys, tmp_path, plan_file):
    """An empty -o names the option (it was "cannot write : not a regular file"); the same plan twice would cut
    every strip twice: refused by file, for post and for verify --program alike."""
    code, _, err = run(capsys, "post", plan_file, "--machine", "rotor-xa-b", "--post", "fanuc", "-o", "")
    assert code == 2 and "--out is empty: give the file to write" in err
    copy_file = tmp_path / "copy.json"
    copy_file.write_text(plan_file.read_text())
    for argv in (("post", plan_file, copy_file, "--machine", "rotor-xa-b", "--post", "fanuc", "-o", tmp_path / "p.nc"),
                 ("verify", plan_file, plan_file, "--program", tmp_path / "p.nc", "--machine", "rotor-xa-b")):
        code, _, err = run(capsys, *argv)
        assert code == 2 and f"{argv[2]} is the same plan as {plan_file}: given twice" in err, err
    assert not (tmp_path / "p.nc").exists()


def test_malformed_machine_file_and_unreachable_pass_are_named(capsys, tmp_path, plan_file):
    with open(load_machine("rotor-xa-b").source) as fh:
        data = json.load(fh)
    data["rotary_axes"]["B"]["rapid"] = "fast"
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(data))
    code, _, err = run(capsys, "post", plan_file, "--machine", bad, "--post", "fanuc", "-o", tmp_path / "p.nc")
    assert code == 2 and "rotary_axes.B.rapid must be a finite number, got 'fast'" in err
    data["rotary_axes"]["B"].update(rapid=9000.0, min=-20.0, max=-10.0)
    bad.write_text(json.dumps(data))
    code, _, err = run(capsys, "post", plan_file, "--machine", bad, "--post", "fanuc", "-o", tmp_path / "p.nc")
    assert code == 2 and "pass 1 (plan 0 strip 0 lobe" in err and "axis B reaches 0, outside its limits -20..-10" in err


def test_unwritable_output_is_a_clear_error_and_no_file(capsys, tmp_path, plan_file):
    blocker = tmp_path / "file.txt"
    blocker.write_text("x")
    code, _, err = run(capsys, "post", plan_file, "--machine", "rotor-xa-b", "--post", "linuxcnc",
                       "-o", blocker / "p.ngc")
    # said before any work: the "folder" is a file
    assert code == 2 and err.strip() == f"error: --out {blocker / 'p.ngc'}: {blocker} is not a folder"
    assert "Traceback" not in err and blocker.read_text() == "x"


def test_a_post_that_fails_leaves_the_old_program(capsys, tmp_path, plan_file):
    """The post reads its program back before writing it: a feed that rounds to F0 (an absurd --fz) is refused by
    name and the program already in place stays as it was."""
    path = tmp_path / "p.ngc"
    path.write_text("old program\n")
    code, _, err = run(capsys, "post", plan_file, "--machine", "rotor-xa-b", "--post", "linuxcnc", "--fz", "1e-300",
                       "-o", path)
    assert code == 2 and "is cut to 0.000000: below the smallest feed the program writes (1e-06)" in err, err
    assert "Traceback" not in err and path.read_text() == "old program\n" and os.listdir(tmp_path) == ["plan.json",
                                                                                                        "p.ngc"]


def test_single_cutting_values_override_each_tools_own_data(capsys, tmp_path, formed_cutter_plan):
    """--vc (or --fz, --flutes, --max-rpm) alone replaces that value of each tool's own data: a formed disc keeps
    its 16 flutes and its top speed of 3000 1/min.  (It used to get the default end mill's data around the value
    given: 4 flutes and 24000 1/min, and under --vc 1000 a spindle speed over the disc's own top speed.)  With
    --cutting-data the values replace the preset's."""
    from flank_addon.machining.feeds import DEFAULT_DISC_CUTTER, PRESET_CUTTING_DATA

    plan = tmp_path / "disc.json"
    write_plan(plan, formed_cutter_plan)
    out = tmp_path / "d.ngc"
    code, text, err = run(capsys, "post", plan, "--machine", "rotor-xa-b", "--post", "linuxcnc", "--vc", "1000",
                          "--lobes", "0", "-o", out, "--json")
    assert code == 0, err
    tool = json.loads(text)["tools"][0]
    data = tool["cutting_data"]
    assert (data["flutes"], data["max_rpm"], data["vc_m_min"], data["fz_mm"]) == (
        DEFAULT_DISC_CUTTER.flutes, DEFAULT_DISC_CUTTER.max_rpm, 1000.0, DEFAULT_DISC_CUTTER.fz_mm)
    assert data["source"] == "default disc cutter with vc_m_min 1000 from the command line"
    assert 0 < tool["rpm"] <= DEFAULT_DISC_CUTTER.max_rpm
    # the program reads back within that data when verify is given the same option
    code, text, _ = run(capsys, "verify", plan, "--program", out, "--machine", "rotor-xa-b", "--vc", "1000")
    assert code == 0 and "within its cutting data" in text
    # on top of --cutting-data: the preset's flutes and speeds, the fz given
    preset = PRESET_CUTTING_DATA["Tapered 2deg D3 L25"]
    code, text, err = run(capsys, "post", plan, "--machine", "rotor-xa-b", "--post", "linuxcnc", "--lobes", "0",
                          "--cutting-data", "Tapered 2deg D3 L25", "--fz", "0.02", "-o", out, "--json")
    data = json.loads(text)["tools"][0]["cutting_data"]
    assert code == 0 and (data["flutes"], data["vc_m_min"], data["fz_mm"]) == (preset.flutes, preset.vc_m_min, 0.02)


def test_a_plan_scaled_beyond_any_tool_is_refused_before_it_is_sampled(capsys, tmp_path, double_flank_plan):
    """A plan in units of R given an outer radius of 10 m or 100 m has a tool metres long: refused by
    name before its surface is sampled every millimetre (which took minutes and tens of gigabytes, or ran out of
    memory), with the tool's length and width as the plan gives them; 2000 mm is the largest tool taken."""
    from flank_addon.machining.operation import MAX_TOOL_MM, OperationError, _check_tool_size
    from flank_addon.machining.tool_shape import ToolShape

    r = tmp_path / "r.json"
    write_plan(r, scale_plan(double_flank_plan, 1 / 30.0, "R"))
    shape = ToolShape.from_strip(double_flank_plan, 0)
    lo, hi = shape.h_range()
    for radius in (1e4, 1e5):
        code, _, err = run(capsys, "post", r, "--machine", "rotor-xa-b", "--post", "linuxcnc", "--outer-radius-mm",
                           radius, "-o", tmp_path / "p.ngc")
        length = (hi - lo) * radius / 30.0
        assert code == 2 and f"plan 0 strip 0: its tool is {length:.6g} mm long and " in err, err
        assert "over the 2000 mm of any milling tool" in err and not (tmp_path / "p.ngc").exists()
    # beyond 100 m the outer radius itself is refused, before the plan is read
    code, _, err = run(capsys, "post", r, "--machine", "rotor-xa-b", "--post", "linuxcnc", "--outer-radius-mm", "1e9",
                       "-o", tmp_path / "p.ngc")
    assert code == 2 and "--outer-radius-mm: 1e9 mm is over 100000 mm: no rotor is that large" in err, err
    k = MAX_TOOL_MM / (hi - lo)             # the tool is longer than it is wide
    _check_tool_size(ToolShape.from_strip(scale_plan(double_flank_plan, 0.999 * k), 0), "under the limit")
    with pytest.raises(OperationError, match="over: its tool is 2002 mm long .* over the 2000 mm"):
        _check_tool_size(ToolShape.from_strip(scale_plan(double_flank_plan, 1.001 * k), 0), "over")


def test_a_failed_write_keeps_the_old_file_whole(tmp_path):
    path = tmp_path / "p.ngc"
    path.write_text("old program\n")
    with pytest.raises(PostError, match="cannot write"):
        atomic_write(path, "G0 X1\n(caf\u00e9)\n")                        # not ASCII: fails while writing
    assert path.read_text() == "old program\n" and os.listdir(tmp_path) == ["p.ngc"]
    atomic_write(path, "G0 X1\n")
    assert path.read_text() == "G0 X1\n" and os.listdir(tmp_path) == ["p.ngc"]


def test_a_plan_without_extent_needs_the_mesh(capsys, tmp_path, double_flank_plan):
    old = copy.deepcopy(double_flank_plan)
    del old["rotor"]["extent"]
    validate_plan(old)                                            # old plans stay valid
    path = tmp_path / "old.json"
    write_plan(path, old)
    code, _, err = run(capsys, "post", path, "--machine", "rotor-xa-b", "--post", "linuxcnc", "-o", tmp_path / "p")
    assert code == 2 and "records no rotor extent" in err and "pass --mesh ROTOR_MESH" in err
    bad = copy.deepcopy(double_flank_plan)
    bad["rotor"]["extent"]["shafts"] = [{"z_range": [5.0, 1.0], "radius": 3.0}]
    with pytest.raises(PlanError, match=r"rotor.extent.shafts\[0\].z_range"):
        validate_plan(bad)


def test_a_plan_in_units_of_r_is_scaled_to_the_same_program(capsys, tmp_path, double_flank_plan):
    mm = tmp_path / "mm.json"
    r = tmp_path / "r.json"
    write_plan(mm, double_flank_plan)
    write_plan(r, scale_plan(double_flank_plan, 1 / 30.0, "R"))
    code, _, err = run(capsys, "post", r, "--machine", "xyzac-trt", "--post", "heidenhain", "-o", tmp_path / "r.h")
    assert code == 2 and "pass --outer-radius-mm" in err
    assert run(capsys, "post", r, "--machine", "xyzac-trt", "--post", "heidenhain", "--outer-radius-mm", "30",
               "-o", tmp_path / "r.h")[0] == 0
    assert run(capsys, "post", mm, "--machine", "xyzac-trt", "--post", "heidenhain", "-o", tmp_path / "mm.h")[0] == 0
    a = (tmp_path / "r.h").read_text().splitlines()
    b = (tmp_path / "mm.h").read_text().splitlines()
    assert len(a) == len(b)
    nums = lambda lines: np.array([float(w[1:]) for ln in lines if " L " in ln for w in ln.split()  # noqa: E731
                                   if w[0] in "XYZAC" and w[1:2] in "+-"])
    assert np.abs(nums(a) - nums(b)).max() <= 2e-4


def test_post_json_and_verify_program_text(capsys, tmp_path, single_flank_plan):
    plan_file = tmp_path / "single.json"
    write_plan(plan_file, single_flank_plan)
    out = tmp_path / "p.nc"
    code, text, _ = run(capsys, "post", plan_file, "--machine", "rotor-xa-b", "--post", "fanuc", "--lobes", "0,2",
                        "--json", "-o", out)

    def not_json(constant):
        raise AssertionError(f"--json printed {constant}, which strict JSON readers reject")

    d = json.loads(text, parse_constant=not_json)
    n = len(single_flank_plan["strips"])
    assert code == 0 and d["passes"] == 2 * n and d["lobes"] == [0, 2]
    assert {"passes", "cutting_time_s", "rapid_time_s", "total_time_s", "per_pass", "tools"} <= set(d)
    p = d["per_pass"][0]
    assert all(q["shaft_margin_mm"] is None or q["shaft_margin_mm"] > 0 for q in d["per_pass"])
    assert p["chip_load_mm"][1] <= d["tools"][0]["cutting_data"]["fz_mm"] * (1 + 1e-9)
    code, text, err = run(capsys, "verify", plan_file, "--program", out, "--machine", "rotor-xa-b", "--lobes", "2")
    assert code == 0, err
    assert f"{2 * n} passes ({2 * n} matched to plan strips)" in text and f"lobe 2: {n} passes" in text
    code, _, err = run(capsys, "verify", plan_file, "--program", out)
    assert code == 2 and "needs --machine" in err
    code, _, err = run(capsys, "verify", plan_file, "--program", out, "--machine", "rotor-xa-b", "--lobes", "0,9")
    assert code == 2 and "lobes [9] are not lobes of this rotor (0..3)" in err
    code, _, err = run(capsys, "verify", plan_file, plan_file)
    assert code == 2 and "several only with --program" in err
    empty = tmp_path / "empty.nc"
    empty.write_text("\n  \n")
    code, _, err = run(capsys, "verify", plan_file, "--program", empty, "--machine", "rotor-xa-b")
    assert code == 2 and f"{empty} is empty: no program to check" in err
    empty.write_text("%\n\n%\n")                   # a tape's markers and nothing between them
    code, _, err = run(capsys, "verify", plan_file, "--program", empty, "--machine", "rotor-xa-b")
    assert code == 2 and f"{empty} is empty but for '%' lines: no program to check" in err


def test_machines_command_lists_machines_and_posts(capsys):
    code, text, _ = run(capsys, "machines")
    assert code == 0
    assert all(f"{n}:" in text for n in ("rotor-xa-b", "xyzac-trt", "xyzac-trt-tcp"))
    assert "posts: linuxcnc" in text and "heidenhain" in text


def test_cutter_plan_out_is_a_plan_the_post_takes(capsys, tmp_path):
    from flank_addon.io.plan import read_plan

    plan = tmp_path / "disc.json"
    code, text, err = run(capsys, "cutter", "--builtin", "srm_a-male", "--scale", "30", "--center-distance", "54",
                          "--swivel", "45", "--planes", "16", "--out", tmp_path / "c.csv", "--plan-out", plan)
    assert code == 0, err
    assert "plan: formed disc cutter on flanks" in text
    p = read_plan(plan)
    assert p["tool"]["kind"] == "disc" and p["length_unit"] == "mm" and len(p["strips"]) == 1
    assert p["rotor"]["extent"] == {"z_range": [0.0, 96.0], "shafts": []}
    assert len(p["strips"][0]["meridian"]) == 16 and p["strips"][0]["shank_radius"] < 54 - 30
    code, text, err = run(capsys, "post", plan, "--machine", "xyzac-trt", "--post", "heidenhain", "--lobes", "0",
                          "--json", "-o", tmp_path / "disc.h")
    assert code == 0, err
    d = json.loads(text)
    assert d["passes"] == 1 and d["tools"][0]["cutting_data"]["flutes"] == 16 and d["tools"][0]["rpm"] < 1000


def test_a_link_beyond_the_travel_is_refused_by_axis(capsys, tmp_path, plan_file):
    with open(load_machine("rotor-xa-b").source) as fh:
        data = json.load(fh)
    data["linear_axes"]["Z"]["max"] = 20.0                    # the tool cannot lift above the rotor
    short = tmp_path / "short.json"
    short.write_text(json.dumps(data))
    code, _, err = run(capsys, "post", plan_file, "--machine", short, "--post", "linuxcnc", "-o", tmp_path / "p")
    assert code == 2 and "axis Z would reach" in err and "outside its limits -500..20" in err


def test_a_repeated_strip_is_cut_once_and_a_missing_pass_fails_the_check(capsys, tmp_path, double_flank_plan):
    """A strip with the motion of an earlier one (a two-paths plan that kept the double-flank axis for both
    paths) is posted once and counts as cut; a program with a pass taken out exits with status 1."""
    plan = copy.deepcopy(double_flank_plan)
    n = len(plan["strips"])
    twin = copy.deepcopy(plan["strips"][0])
    twin["flank"] = (twin["flank"] + 1) % len(plan["rotor"]["flanks"])
    plan["strips"].append(twin)
    path = tmp_path / "twin.json"
    write_plan(path, plan)
    prog = tmp_path / "twin.ngc"
    code, text, err = run(capsys, "post", path, "--machine", "rotor-xa-b", "--post", "linuxcnc", "--lobes", "0",
                          "--json", "-o", prog)
    assert code == 0, err
    assert json.loads(text)["passes"] == n
    code, text, err = run(capsys, "verify", path, "--program", prog, "--machine", "rotor-xa-b")
    assert code == 0, err
    assert f"{n} passes ({n} matched to plan strips)" in text and "NOT AS PLANNED" not in text
    lines = prog.read_text().splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith("(PASS 1 "))
    end = next(i for i in range(start, len(lines)) if lines[i] == "G94")
    cut = tmp_path / "cut.ngc"
    cut.write_text("\n".join(lines[:start] + lines[end + 1:]) + "\n")
    code, text, err = run(capsys, "verify", path, "--program", cut, "--machine", "rotor-xa-b", "--lobes", "0")
    assert code == 1, err
    assert "NOT AS PLANNED: 1 strip(s) never cut, as [plan, strip, lobe]: [[0, 0, 0]]" in text
    short = tmp_path / "short.ngc"
    short.write_text("\n".join(lines[:lines.index("M2")]) + "\n")
    code, text, err = run(capsys, "verify", path, "--program", short, "--machine", "rotor-xa-b", "--lobes", "0")
    assert code == 1 and "NOT AS PLANNED: the program has no end (M2 / M30, END PGM)" in text


def test_a_cutter_plan_in_units_of_r_is_the_mm_plan_divided_by_the_radius(capsys, tmp_path):
    """--length-unit R on a rotor of outer radius 30 divides every length by 30 (the plan used to keep the mm
    numbers under the label R); posted back at 30 mm it is the mm plan's program."""
    from flank_addon.io.plan import read_plan

    argv = ["cutter", "--builtin", "srm_a-male", "--scale", "30", "--center-distance", "54", "--swivel", "45",
            "--planes", "16", "--out", tmp_path / "c.csv"]
    assert run(capsys, *argv, "--plan-out", tmp_path / "mm.json")[0] == 0
    code, text, err = run(capsys, *argv, "--plan-out", tmp_path / "r.json", "--length-unit", "R")
    assert code == 0, err
    mm, r = read_plan(tmp_path / "mm.json"), read_plan(tmp_path / "r.json")
    assert mm["length_unit"] == "mm" and r["length_unit"] == "R" and abs(r["rotor"]["outer_radius"] - 1) < 1e-12
    for key in ("max_error", "min_error"):
        assert abs(r["summary"][key] * 30 - mm["summary"][key]) <= 1e-12 * 30
    for key in ("max_diameter", "width", "centre_distance"):
        assert abs(r["tool"][key] * 30 - mm["tool"][key]) <= 1e-9 * mm["tool"][key]
    programs = []
    for name, extra in (("mm", []), ("r", ["--outer-radius-mm", "30"])):
        out = tmp_path / f"{name}.ngc"
        assert run(capsys, "post", tmp_path / f"{name}.json", "--machine", "rotor-xa-b", "--post", "linuxcnc",
                   *extra, "-o", out)[0] == 0
        programs.append([ln for ln in out.read_text().splitlines() if not ln.startswith("(")])
    assert programs[0] == programs[1]


def test_every_lobe_names_the_rotor_flank_it_cuts(capsys, tmp_path, plan_file, double_flank_plan):
    """A double-flank plan adds its valley's trimmed flanks after the rotor's; a pass on lobe k names the
    rotor's own flank 2k + f on every lobe, lobe 0 included."""
    code, text, err = run(capsys, "post", plan_file, "--machine", "rotor-xa-b", "--post", "linuxcnc", "--json",
                          "-o", tmp_path / "p.ngc")
    assert code == 0, err
    per = json.loads(text)["per_pass"]
    lobes = 1 + max(p["lobe"] for p in per)
    assert len(double_flank_plan["rotor"]["flanks"]) > 2 * lobes            # the trimmed flanks are there
    first = {p["lobe"]: p["flank"] for p in per if p["strip"] == 0}
    assert first == {k: (first[0] + 2 * k) % (2 * lobes) for k in range(lobes)} and first[0] < 2 * lobes
