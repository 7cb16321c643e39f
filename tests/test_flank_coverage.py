"""Whole-flank coverage of the single-flank conical planner: adaptive strips, smaller tools never cover less."""
import math

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
def male_d4():
    """Male flank 0 (tip to the valley's small bottom fillet) with the 3 deg D4 L20 end mill and the same cone
    1 mm thinner: plans with the planner's defaults."""
    from flank_addon.geometry.rotors import builtin_by_name

    r = builtin_by_name("asymmetric-male")
    s = r.surface()
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
