"""A single-flank plan with several tools: each strip carries its tool; exports, operation, post and read-back
change tools where the strips do.

References: the presets' own dimensions (presets/flank_tool), LinuxCNC's interpreter for the tool changes and
moves, the read-back sweep for the milled deviation."""
import math

import numpy as np
import pytest

from machining_helpers import run_rs274
from flank_addon.exports.cl_data import cl_data, strip_tip
from flank_addon.io.plan import plan_tools, strip_tool, validate_plan
from flank_addon.machining.feeds import PRESET_CUTTING_DATA
from flank_addon.machining.machine import load_machine
from flank_addon.machining.operation import build_operation
from flank_addon.machining.rotor_body import rotor_body
from flank_addon.machining.toolpath import build_program
from flank_addon.posts import get_post, write_program
from flank_addon.posts.readback import verify_program

pytestmark = pytest.mark.xdist_group("machining")     # shared session fixtures: one worker

NAMES = ("Tapered 2deg D6 L35", "Tapered 1.5deg D2 L20")


def test_each_strip_carries_its_tool(two_tool_plan):
    plan = validate_plan(two_tool_plan)
    names = [st["tool"]["name"] for st in plan["strips"]]
    assert set(names) == set(NAMES)
    # the plan's own tool stays the first tool of the list (the largest): a reader that knows no strip tools
    # sees that tool
    assert {k: v for k, v in plan["tool"].items() if k != "name"} == \
        {k: v for k, v in plan_tools(plan)[[t["name"] for t, _ in plan_tools(plan)].index(NAMES[0])][0].items()
         if k != "name"} and plan["tool"]["name"] == NAMES[0]
    for k, st in enumerate(plan["strips"]):
        t = strip_tool(plan, k)
        # the strip's spheres are its own cone's: r1S = r1c / cos(alpha), the axis L apart
        assert st["radii"][0] == pytest.approx(t["r1c"] / math.cos(t["alpha"]), rel=1e-12)
        L = t["h"] + (t["r2c"] - t["r1c"]) * math.tan(t["alpha"])
        assert np.linalg.norm(np.subtract(st["axis_end"], st["axis_start"])) == pytest.approx(L, rel=1e-9)
        # the programmed tip is the tip circle's centre of that cone (Eq. 2: r1c tan(alpha) below x1S)
        T, a, off = strip_tip(plan, k)
        assert off == pytest.approx(-t["r1c"] * math.tan(t["alpha"]), rel=1e-12)
    # the plan's figures: tip diameters and tapers of the presets
    by = {t["name"]: t for t, _ in plan_tools(plan)}
    assert 2 * by[NAMES[0]]["r1c"] == pytest.approx(6.0) and math.degrees(by[NAMES[0]]["alpha"]) == pytest.approx(2.0)
    assert 2 * by[NAMES[1]]["r1c"] == pytest.approx(2.0) and math.degrees(by[NAMES[1]]["alpha"]) == pytest.approx(1.5)


def test_cl_data_loads_a_tool_where_the_strips_change_it(two_tool_plan):
    text = cl_data(two_tool_plan, steps=4)
    lines = text.splitlines()
    loads = [ln for ln in lines if ln.startswith("LOADTL/")]
    strips = [ln for ln in lines if ln.startswith("$$ STRIP ")]
    names = [st["tool"]["name"] for st in two_tool_plan["strips"]]
    changes = 1 + sum(a != b for a, b in zip(names, names[1:]))
    assert len(loads) == changes and len(strips) == len(names)
    # every strip runs under the tool LOADTL last named, and CUTTER gives that preset's tip and taper
    dims = {NAMES[0]: (6.0, 2.0, 35.0), NAMES[1]: (2.0, 1.5, 20.0)}        # tip diameter, taper, flute length
    first_use = [t["name"] for t, _ in plan_tools(two_tool_plan)]          # tool n is the n-th one used
    current = None
    for ln in lines:
        if ln.startswith("LOADTL/"):
            current = int(ln.split("/")[1])
        if ln.startswith("CUTTER/"):
            d, _, _, _, taper, _, h = (float(x) for x in ln.split("/")[1].split(","))
            assert (d, taper, h) == pytest.approx(dims[first_use[current - 1]])
        if ln.startswith("$$ STRIP "):
            assert first_use[current - 1] == names[int(ln.split()[2])]


def test_post_changes_tools_and_mills_what_the_plan_mills(two_tool_plan, tmp_path, rs274):
    plan = two_tool_plan
    rb = rotor_body(plan)
    op = build_operation([plan], rb, lobes=[0, 1])
    first_use = [t["name"] for t, _ in plan_tools(plan)]
    assert [t.name.split(" (")[0] for t in op.tools] == [f"T{n} {nm}" for n, nm in enumerate(first_use, 1)]
    for t, nm in zip(op.tools, first_use):    # each tool's cutting data is its preset's
        assert t.data == PRESET_CUTTING_DATA[nm]
    prog = build_program(op, load_machine("rotor-xa-b"))
    path = tmp_path / "two.ngc"
    text = write_program(prog, "linuxcnc", path)
    assert [ln for ln in text.splitlines() if ln.endswith(" M6")] == ["T1 M6", "T2 M6"]
    canon = run_rs274(rs274, path)
    assert len(canon) == len(get_post("linuxcnc").read(text, prog.machine).moves)
    res = verify_program(text, get_post("linuxcnc"), prog.machine, [plan], rb, lobes=[0, 1])
    assert res["matched_passes"] == res["passes"] == 2 * len(plan["strips"])
    assert not res["missing_strips"] and not res["repeated_strips"]
    for lo in res["plans"][0]["lobes"]:
        assert lo["max_deviation_difference_mm"] < 2e-3 and lo["pose_difference_mm"] < 2e-3
        assert lo["coverage_mismatches"] == 0
    assert res["gouge_points"] == 0 and res["links"]["max_intrusion_mm"] == 0.0


def test_the_program_header_lists_each_tool_as_it_was_checked(two_tool_plan):
    """Every post's header names each tool's shank (diameter, from and to along the axis from the tip) and its
    gauge length, beyond which nothing was checked: flute length + shank of each preset (35 + its shank, 20 +
    its shank), as the plan's tools give them."""
    from flank_addon.io.plan import strip_tool

    rb = rotor_body(two_tool_plan)
    op = build_operation([two_tool_plan], rb, lobes=[0])
    prog = build_program(op, load_machine("rotor-xa-b"))
    for name in ("linuxcnc", "fanuc", "heidenhain"):
        text = get_post(name).write(prog)
        head = text[:text.index("PASS 1")]
        for t in op.tools:
            tool = next(strip_tool(two_tool_plan, s) for s in range(len(two_tool_plan["strips"]))
                        if t.name.startswith(f"T{t.number} {strip_tool(two_tool_plan, s)['name']} "))
            g = tool["h"] + tool["shank_length"]
            lines = [f"T{t.number} shank: diameter {2 * tool['shank_radius']:.4f} over {tool['h']:.4f}..{g:.4f} mm "
                     "from the tip",
                     f"T{t.number} checked up to {g:.4f} mm from the tip (gauge length): keep its holder beyond"]
            for line in lines:
                if name != "heidenhain":        # G-code comments are in parentheses
                    line = line.replace("(", "[").replace(")", "]")
                if name == "fanuc":
                    line = line.upper()
                assert line in head, (name, line)
