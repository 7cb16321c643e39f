"""Feeds and speeds: spindle speed, chip load along the edge, top speeds of the joints; the preset table."""
import math
import re
from pathlib import Path

import numpy as np
import pytest

from flank_addon.machining.feeds import (DEFAULT_END_MILL, PRESET_CUTTING_DATA, PRESET_GEOMETRY, CuttingData,
                                         cutting_data_for, engaged_edge, engagement, largest_engaged_diameter,
                                         ring_max_rho, ring_min_rho)
from flank_addon.machining.machine import load_machine
from flank_addon.machining.operation import build_operation
from flank_addon.machining.rotor_body import rotor_body
from flank_addon.machining.toolpath import build_program

pytestmark = pytest.mark.xdist_group("machining")     # shared session fixtures: one worker

PRESETS = Path(__file__).resolve().parents[2] / "presets" / "flank_tool"


def test_spindle_speed_chip_load_and_surface_speed(single_flank_plan):
    """n = 1000 vc / (pi D_max) over the engaged edge, rounded down to the whole turns the posts write; the
    fastest point of the edge gets fz per tooth at that n, every other less; the surface speed runs from pi D_min n
    to pi D_max n <= vc, within a turn of vc."""
    rb = rotor_body(single_flank_plan)
    op = build_operation([single_flank_plan], rb, lobes=[0])
    data = cutting_data_for(single_flank_plan["tool"])
    assert data is PRESET_CUTTING_DATA["Tapered 2deg D3 L25"]
    prog = build_program(op, load_machine("rotor-xa-b"))
    tool = op.tools[0]
    D = max(engagement(tool.shape, p.tip, p.axis, rb).diameter for p in op.passes)
    assert tool.rpm == math.floor(1000 * data.vc_m_min / (math.pi * D)) and tool.rpm < 1000 * data.vc_m_min / (math.pi * D)
    for p in prog.passes:
        assert p["limited_by"] == "chip load"
        dmin, dmax = p["engaged_diameter_mm"]
        assert abs(p["chip_load_mm"][1] - data.fz_mm) < 1e-12 and 0 < p["chip_load_mm"][0] <= data.fz_mm
        assert p["surface_speed_m_min"][1] <= data.vc_m_min * (1 + 1e-9)
        assert abs(p["surface_speed_m_min"][0] / p["surface_speed_m_min"][1] - dmin / dmax) < 1e-12
        # feed = n z fz at the fastest engaged point, whose speed is omega sqrt(rho^2 + v0^2)
        assert abs(p["feed_mm_min"] - tool.rpm * data.flutes * data.fz_mm) < 1e-6
        assert abs(p["time_s"] - 60 * abs(p["t_range"][1] - p["t_range"][0]) / p["omega_rad_min"]) < 1e-9
    assert data.vc_m_min - math.pi * D / 1000 < max(p["surface_speed_m_min"][1] for p in prog.passes)


def test_a_tool_shorter_than_the_ring_spacing_engages_as_its_full_size_twin(single_flank_plan):
    """Geometric similarity: the plan scaled by 1/100 (rotor R = 0.3 mm, a cone 0.29 mm long, shorter than the
    0.5 mm ring spacing, which once sampled only its two poles of radius 0 and refused the program with "never
    enters the stock cylinder") has 1/100 of the engaged diameters of the full-size plan, sampled densely, to
    within the ring spacing's sagitta on the top sphere (0.1 mm at full size); its spindle runs at top speed."""
    from flank_addon.machining.rotor_body import scale_plan

    k = 0.01
    small = scale_plan(single_flank_plan, k)
    big_rb, small_rb = rotor_body(single_flank_plan), rotor_body(small)
    big_op, small_op = (build_operation([single_flank_plan], big_rb, lobes=[0]),
                        build_operation([small], small_rb, lobes=[0]))
    big_tool, small_tool = big_op.tools[0], small_op.tools[0]
    lo, hi = small_tool.shape.cutting_range()
    assert hi - lo < 0.5
    for pb, ps in zip(big_op.passes, small_op.passes):
        dense = engaged_edge(big_tool.shape, pb.tip, pb.axis, big_rb.outer_radius, spacing=0.01)[1].max()
        D = engaged_edge(small_tool.shape, ps.tip, ps.axis, small_rb.outer_radius)[1].max()
        assert abs(D / k - dense) < 0.1, (D / k, dense)
    prog = build_program(small_op, load_machine("rotor-xa-b"))
    assert small_tool.rpm == DEFAULT_END_MILL.max_rpm == 24000.0
    assert len(prog.passes) == len(small_op.passes)
    top = max(max(st["radii"]) for st in small["strips"])         # the largest sphere of the tool
    for p in prog.passes:
        assert 0.0 < p["engaged_diameter_mm"][1] <= 2.0 * top


def test_the_link_checks_see_the_cutting_part_of_a_tool_shorter_than_the_spacing(single_flank_plan):
    """The points the link and run-out checks place along a move (local_points at the operation's 1 mm spacing)
    hold rings over the whole cutting part of the 1/100 plan's 0.29 mm cone, as large as its spheres, and its
    axial extent reaches its top sphere: the cutting part is never sampled only at its poles of radius 0."""
    from flank_addon.machining.rotor_body import scale_plan

    small = scale_plan(single_flank_plan, 0.01)
    shape = build_operation([small], rotor_body(small), lobes=[0]).tools[0].shape
    lo, hi = shape.cutting_range()
    h, R, is_shank = shape.outline(1.0)
    top = max(max(st["radii"]) for st in small["strips"])
    assert (~is_shank).sum() > shape.MIN_CUTTING_RINGS and (R[~is_shank] > 0).sum() >= shape.MIN_CUTTING_RINGS - 1
    assert 0.95 * top < R[~is_shank].max() <= top * (1 + 1e-9)
    pts = shape.local_points(1.0)                       # every cutting ring of radius > 0 is among the points
    for hv, rv in zip(h[~is_shank], R[~is_shank]):
        if rv > 0:
            on = np.abs(pts[:, 2] - hv) < 1e-12
            assert np.isclose(np.hypot(pts[on, 0], pts[on, 1]), rv).sum() >= 8
    tips, axes = np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]])
    z0, z1 = shape.z_extent(tips, axes, spacing=1.0)
    assert z0[0] == pytest.approx(min(lo, shape.h_range()[0])) and z1[0] == pytest.approx(shape.h_range()[1])


def dense_engaged_diameter(shape, tip, axis, outer_radius):
    """Brute force: the largest 2 R(h) over rings along the whole cutting part 2 um apart, then 0.01 um apart
    within 4 um of the best, 3,600 points each, with a point at rho <= outer_radius."""
    from flank_addon.machining.tool_shape import perpendicular_frames

    e1, e2 = (np.reshape(e, 3) for e in perpendicular_frames(np.asarray(axis, float)))
    th = np.linspace(0.0, 2 * np.pi, 3600, endpoint=False)

    def best_of(h):
        R = shape._cutting_radius(h)
        best, at = 0.0, None
        for k in range(0, len(h), 256):
            hk, Rk = h[k:k + 256], R[k:k + 256]
            c = np.asarray(tip, float)[:2] + hk[:, None] * np.asarray(axis, float)[:2]
            x = c[:, None, 0] + Rk[:, None] * (np.cos(th) * e1[0] + np.sin(th) * e2[0])
            y = c[:, None, 1] + Rk[:, None] * (np.cos(th) * e1[1] + np.sin(th) * e2[1])
            inside = (np.hypot(x, y) <= outer_radius).any(axis=1)
            if inside.any() and 2 * Rk[inside].max() > best:
                best, at = float(2 * Rk[inside].max()), float(hk[inside][np.argmax(Rk[inside])])
        return best, at

    lo, hi = shape.cutting_range()
    best, at = best_of(np.arange(lo, hi + 0.002, 0.002))
    return best_of(np.linspace(at - 0.004, at + 0.004, 801))[0] if at is not None else 0.0


@pytest.mark.parametrize("which", ["single_flank_plan", "two_tool_plan", "double_flank_plan", "formed_cutter_plan"])
def test_the_largest_engaged_diameter_is_the_edge_s_own(which, request):
    """The largest engaged diameter (which sets the spindle speed) against brute force (rings 2 um apart, then
    0.01 um apart about the best, 3,600 points each): the same to 2e-6 of it, and never smaller by more than
    that (so pi D n stays at vc on the edge).  The 0.5 mm rings alone missed up to 0.7% (cones) and 2% (the
    double-flank tool) where the tool's wide end leaves the stock between two of them."""
    plan = request.getfixturevalue(which)
    rb = rotor_body(plan)
    op = build_operation([plan], rb, lobes=[0])
    missed = 0.0
    for p in op.passes:
        shape = next(t.shape for t in op.tools if t.number == p.tool)
        exact = engagement(shape, p.tip, p.axis, rb).diameter
        sampled = engaged_edge(shape, p.tip, p.axis, rb.outer_radius)[1].max()
        assert exact == max(largest_engaged_diameter(shape, p.tip, p.axis, rb.outer_radius), sampled)
        dense = dense_engaged_diameter(shape, p.tip, p.axis, rb.outer_radius)
        assert abs(exact / dense - 1.0) < 2e-6, (which, exact, dense)
        missed = max(missed, exact / sampled - 1.0)
    if which != "formed_cutter_plan":
        assert missed > 1e-3, missed


def test_an_edge_grazing_the_stock_between_two_rings_is_found():
    """A 4 mm cylinder lying across the rotor axis (along x, 12 mm - eps off it) whose rings come nearest to the axis at
    h = 10.25 mm, halfway between two of the 0.5 mm rings: its edge enters the 10 mm stock only within
    +-0.2 mm of there (eps = 2 um), so neither ring counts and the sampled edge is empty.  The largest engaged
    diameter is still found, as brute force finds it (rings 2 um apart, 3,600 points each); with the edge
    moved 0.3 mm further out it enters nowhere, and the diameter is 0."""
    from flank_addon.machining.tool_shape import ToolShape

    shape = ToolShape(kind="revolved", h_start=0.0, h_end=20.0, radii=np.array([2.0, 2.0]),
                      meridian=np.array([[0.0, 2.0], [20.0, 2.0]]))
    tip, axis = np.array([-10.25, 12.0 - 2e-3, 0.0]), np.array([1.0, 0.0, 0.0])
    assert len(engaged_edge(shape, tip, axis, 10.0)[1]) == 0
    found = largest_engaged_diameter(shape, tip, axis, 10.0)
    dense = dense_engaged_diameter(shape, tip, axis, 10.0)
    assert dense == 4.0 and abs(found / dense - 1.0) < 2e-6, (found, dense)
    assert largest_engaged_diameter(shape, tip + [0.0, 0.3, 0.0], axis, 10.0) == 0.0
    # the engagement the posts and the read-back use sees the graze too: its fastest point is on the stock's rim
    # (it used to say "never enters", the post refused the pass without naming it and the read-back counted 0)
    from types import SimpleNamespace

    from flank_addon.machining.feeds import pass_conditions

    rotor = SimpleNamespace(outer_radius=10.0, v0=8.0)
    eng = engagement(shape, tip, axis, rotor)
    assert eng.diameter == found and eng.speed == math.hypot(10.0, 8.0) and len(eng.points) == 0
    cond = pass_conditions(shape, tip, axis, rotor, DEFAULT_END_MILL, 1000.0, 1.0, [0.0], (["A"], [1e9]), eng)
    assert abs(cond.chip_load[1] - DEFAULT_END_MILL.fz_mm) < 1e-15 and cond.engaged_diameter == (found, found)
    away = engagement(shape, tip + [0.0, 0.3, 0.0], axis, rotor)
    assert away.diameter == 0.0 and away.speed == 0.0
    with pytest.raises(ValueError, match="never enters the stock cylinder"):
        pass_conditions(shape, tip + [0.0, 0.3, 0.0], axis, rotor, DEFAULT_END_MILL, 1000.0, 1.0, [0.0],
                        (["A"], [1e9]), away)


def test_cutting_data_beyond_any_milling_tool_is_refused():
    for kw, words in ((dict(vc_m_min=1e300), "vc_m_min 1e+300 is over 10000"), (dict(fz_mm=11.0), "fz_mm 11 is over 10"),
                      (dict(max_rpm=1e6), "max_rpm 1e+06 is over 500000"), (dict(flutes=501), "flutes 501 is over 500")):
        with pytest.raises(ValueError, match=re.escape(words)):
            CuttingData(**dict(DEFAULT_END_MILL.as_dict(), source="test", **kw))
    assert all(d.vc_m_min <= 10000 for d in PRESET_CUTTING_DATA.values())


@pytest.mark.parametrize("extreme, seed", [("min", 7), ("max", 8)])
def test_ring_rho_against_dense_circles(extreme, seed):
    """The nearest (ring_min_rho) and the farthest (ring_max_rho) point of a tilted circle from the z axis, against
    360,000 points of it, for random circles: never beyond the dense value, and within 1e-6 of it."""
    from flank_addon.machining.tool_shape import perpendicular_frames

    ring_rho, sign = (ring_min_rho, 1.0) if extreme == "min" else (ring_max_rho, -1.0)
    rng = np.random.default_rng(seed)
    th = np.linspace(0, 2 * np.pi, 360000, endpoint=False)
    for _ in range(50):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        tip = rng.normal(scale=20.0, size=3)
        h, R = rng.uniform(-5, 5, 4), rng.uniform(0, 15, 4)
        e1, e2 = (np.reshape(e, 3) for e in perpendicular_frames(axis))
        for hk, Rk, got in zip(h, R, ring_rho(tip, axis, h, R)):
            pts = tip + hk * axis + Rk * (np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2)
            rho = np.hypot(pts[:, 0], pts[:, 1])
            dense = rho.min() if extreme == "min" else rho.max()
            # got is at least as extreme as the dense sampling, and within 1e-6 of it
            assert sign * (got - dense) <= 1e-12 and sign * (dense - got) < 1e-6 * max(1.0, Rk), (got, dense)


def test_the_fastest_point_of_an_edge_wholly_in_the_stock_is_exact(single_flank_plan):
    """A pass whose cutting part lies wholly inside the stock cylinder: its fastest point is the largest rho over
    the cutting part, against a dense sampling of the surface (720 points on rings 0.05 mm apart).  With 48 points
    a ring it fell short by up to 1.2e-4 of itself, and a block's chip load went as much over fz."""
    rb = rotor_body(single_flank_plan)
    op = build_operation([single_flank_plan], rb, lobes=[0])
    shape = op.tools[0].shape
    lo, hi = shape.cutting_range()
    h, R, sh = shape.outline((hi - lo) / 2000)
    h, R = h[~sh], R[~sh]
    from flank_addon.machining.tool_shape import perpendicular_frames

    th = np.linspace(0, 2 * np.pi, 720, endpoint=False)
    for p in op.passes:
        e1, e2 = (np.reshape(e, 3) for e in perpendicular_frames(p.axis))
        ring = (np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2)[None]
        # the pass's pose moved towards the rotor axis until its cutting part is wholly in the stock
        tip = np.array(p.tip, float)
        for _ in range(60):
            rho = np.hypot(*(tip + h[:, None, None] * p.axis + R[:, None, None] * ring)[..., :2].transpose(2, 0, 1))
            if rho.max() < 0.98 * rb.outer_radius:
                break
            tip[:2] *= 0.97
        assert rho.max() < rb.outer_radius
        eng = engagement(shape, tip, p.axis, rb)
        dense = math.hypot(rho.max(), rb.v0)
        assert dense * (1 - 1e-12) <= eng.speed <= dense * (1 + 1e-6), (eng.speed, dense)


def test_a_slow_rotary_axis_caps_the_feed(single_flank_plan):
    """With A limited to 100 deg/min the pass takes its A travel / 100 minutes and the chip gets thinner."""
    m = load_machine("rotor-xa-b")
    m.axes["A"].max_feed = 100.0
    rb = rotor_body(single_flank_plan)
    prog = build_program(build_operation([single_flank_plan], rb, lobes=[1]), m)
    for p in prog.passes:
        dA = abs(p["end"]["A"] - p["start"]["A"])
        assert p["limited_by"] == "A top speed"
        assert abs(p["time_s"] / 60 - dA / 100.0) < 1e-9
        assert p["chip_load_mm"][1] < PRESET_CUTTING_DATA["Tapered 2deg D3 L25"].fz_mm


def test_every_tool_preset_has_cutting_data_and_its_geometry():
    names = sorted(p.stem for p in PRESETS.glob("*.py"))
    assert names and names == sorted(PRESET_CUTTING_DATA) == sorted(PRESET_GEOMETRY)
    for name in names:
        text = (PRESETS / f"{name}.py").read_text()
        val = {k: float(v) for k, v in re.findall(r"settings\.(\w+) = ([0-9.]+)", text)}
        taper, d, L = PRESET_GEOMETRY[name]
        assert val.get("tool_taper_deg", 0.0) == taper and val["tool_tip_diameter_mm"] == d
        assert val["tool_flute_length_mm"] == L
        assert PRESET_CUTTING_DATA[name].source == name


@pytest.mark.parametrize("kw, message", [
    (dict(flutes=0), "flutes must be an integer >= 1"),
    (dict(vc_m_min=-1.0), "vc_m_min must be a finite number > 0"),
    (dict(fz_mm=float("nan")), "fz_mm must be a finite number > 0"),
])
def test_bad_cutting_data_is_refused(kw, message):
    args = dict(flutes=4, vc_m_min=100.0, fz_mm=0.02, max_rpm=10000.0)
    args.update(kw)
    with pytest.raises(ValueError, match=message):
        CuttingData(**args)


def test_unmatched_tools_get_the_defaults(double_flank_plan, formed_cutter_plan):
    assert cutting_data_for(double_flank_plan["tool"]) is DEFAULT_END_MILL
    assert cutting_data_for(formed_cutter_plan["tool"]).flutes == 16
    assert np.isfinite(formed_cutter_plan["tool"]["max_diameter"])
