"""What a single-flank plan covers and leaves, as Blender shows it (flank_addon.report.flank_coverage): per strip
its verified share of the flank, the uncovered ranges as shares with their reasons, and the residual mesh on the
flank, against the planner's covered fraction, the verify engine and the profile itself."""
import numpy as np
import pytest

from flank_addon.geometry import rotors
from flank_addon.geometry.screw import screw_to_plane
from flank_addon.methods.single_flank.planner import plan_single_flank
from flank_addon.report.flank_coverage import (flank_arc, residual_patches, residual_rows, residual_u_ranges,
                                               strip_shares)
from flank_addon.simulation.verify import verify_plan
from flank_addon.tooling.presets import presets_by_name

pytestmark = pytest.mark.xdist_group("residual_display")


@pytest.fixture(scope="module")
def two_tools():
    """Flank 1 of the asymmetric female (R = 50 mm, plan in units of R) with two presets in turn: the first
    leaves ranges the second cannot reach without its shank hitting the rotor."""
    rotor = rotors.builtin_rotor("asymmetric", "female")
    surface, flanks = rotor.surface(), rotor.flanks
    tools = [(p.name, p.tool(50.0)) for p in presets_by_name("Tapered 5deg D6 L20,Tapered 1deg D1 L10")]
    res = plan_single_flank(surface, flanks, 1, tools, 5e-4, n_seeds=4, max_rounds=1,
                            tool_names=[n for n, _ in tools], bound_radius=min(t.r1s for _, t in tools))
    return rotor, surface, flanks, res


def test_strip_shares_add_up_to_the_covered_fraction(two_tools):
    _, _, _, res = two_tools
    plan = res.plan
    shares = strip_shares(plan, res.verify, 1, plan["tolerance"], plan["overcut_tolerance"])
    assert len(shares) == len(plan["strips"]) >= 2
    assert 0.2 < res.covered_fraction < 1.0
    assert sum(s[2] for s in shares if s) == pytest.approx(res.covered_fraction, abs=1e-12)
    # a fresh verification of the plan file (the strips' ownership) agrees; no strip's shares overlap another's
    ver = verify_plan(plan, tolerance=plan["overcut_tolerance"])
    assert strip_shares(plan, ver, 1, plan["tolerance"], plan["overcut_tolerance"]) == shares
    spans = sorted(s[:2] for s in shares if s)
    assert all(a0 <= b0 < a1 <= b1 for (a0, b0), (a1, b1) in zip(spans, spans[1:]))


def test_residual_rows_are_the_plans_uncovered_ranges_as_shares(two_tools):
    _, _, _, res = two_tools
    rows = residual_rows(res.plan, 1)
    unc = res.plan["summary"]["uncovered"]
    assert len(rows) == len(unc) >= 2
    _, arc, _ = flank_arc(res.plan, 1)
    for r, u in zip(rows, unc):
        assert (r["start"], r["end"]) == pytest.approx((u["arc_range"][0] / arc[-1], u["arc_range"][1] / arc[-1]),
                                                      abs=1e-15)
        assert r["reason"] == u["reason"] and r["kind"] == u["kind"] and r["u_range"] == u["u_range"]
    covered = 1.0 - sum(r["end"] - r["start"] for r in rows)
    assert covered == pytest.approx(res.covered_fraction, abs=1e-12)


def test_residual_mesh_lies_just_off_the_flank_over_the_uncovered_ranges(two_tools):
    rotor, surface, flanks, res = two_tools
    rows = residual_rows(res.plan, 1)
    n = len(res.plan["rotor"]["profile"])
    spans = residual_u_ranges(rows, surface.profile.period, n, flanks[1])
    off = 0.004
    verts, faces, which = residual_patches(surface, spans, (0.0, float(rotor.length)), off, n_z=16)
    assert faces.shape[1] == 3 and faces.max() == len(verts) - 1 and len(which) == len(verts)
    assert verts[:, 2].min() == pytest.approx(0.0, abs=1e-12) and verts[:, 2].max() == pytest.approx(rotor.length)
    # each vertex screwed into z = 0 stands `off` from the profile, its foot inside its range
    xy = screw_to_plane(verts, surface.v0, surface.handedness)
    uu = np.linspace(*flanks[1], 20001)
    P = surface.profile.eval(uu)
    d = np.linalg.norm(xy[:, None, :] - P[None, :, :], axis=2)
    j = d.argmin(axis=1)
    assert d[np.arange(len(j)), j] == pytest.approx(off, abs=1e-6)
    step = uu[1] - uu[0]
    half = 0.5 * surface.profile.period / n
    for k, (a, b) in enumerate(spans):
        foot = uu[j[which == k]]
        assert a == pytest.approx(max(flanks[1][0], rows[k]["u_range"][0] - half), abs=1e-12)
        assert (foot.min(), foot.max()) == pytest.approx((a, b), abs=step)
