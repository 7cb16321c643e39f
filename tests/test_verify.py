"""verify: exact cases with a ball tool beside a cylindrical rotor, sign conventions, gouges, CLI."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from flank_addon.io.plan import new_plan, write_plan
from flank_addon.simulation.verify import verify_plan

RC = 0.8   # cylinder rotor radius


def ball_plan(delta, r=0.1, shank=None, v0=0.4, hand="right", n=1440):
    """Cylinder rotor; a ball of radius r centred at distance RC + r - delta on the x-axis.

    The helical sweep of the ball is nearest to the facing profile point at t = 0, so the machined
    radius there is RC - delta: deviation exactly -delta (overcut for delta > 0)."""
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    prof = RC * np.c_[np.cos(th), np.sin(th)]
    rotor = {"to_world": np.eye(4).tolist(), "v0": v0, "handedness": hand, "profile": prof.tolist(),
             "flanks": [[0, n // 2], [n // 2, n]], "outer_radius": RC}
    c = [RC + r - delta, 0.0, 0.0]
    strip = {"axis_start": c, "axis_end": c, "radii": [r, r], "flank": 0,
             "shank_start": shank[0] if shank else c, "shank_end": shank[1] if shank else c,
             "shank_radius": shank[2] if shank else 0.0,
             "reported_max_error": 0.0, "reported_min_error": 0.0, "collision": False}
    return new_plan("test-ball", rotor, {"kind": "revolved"}, target_flanks=[0], strips=[strip])


@pytest.mark.parametrize("delta", [0.003, -0.002, 0.0])
@pytest.mark.parametrize("hand", ["right", "left"])
def test_ball_beside_cylinder_exact_deviation(delta, hand):
    res = verify_plan(ball_plan(delta, hand=hand), tolerance=1e-3)
    prof = {row[0]: row for row in res["deviation_profile"]}
    assert abs(prof[0][3] - (-delta)) < 1e-9   # facing point: exactly -delta
    if delta > 0:
        assert abs(res["max_overcut"] + delta) < 1e-9
        assert any(g["index"] == 0 and g["by"] == "tool" for g in res["gouge_points"])
    else:
        assert res["max_overcut"] > -1e-9 and not res["gouge_points"]
    # away from the ball the flank is uncut (material left beyond the tolerance)
    assert res["flanks"][0]["uncovered_ranges"]


def test_a_strip_given_twice_leaves_every_point_to_the_first():
    # the same tool on the same axis twice (what a two-paths plan falls back to): the two distances of a point
    # differ only by rounding (here: the second axis one unit of rounding deeper), so the first strip owns it,
    # in every run, and its gouges are the first's too
    plan = ball_plan(0.003)
    again = dict(plan["strips"][0])
    x = float(np.nextafter(again["axis_start"][0], 0.0))       # one unit of rounding deeper than the first
    again["axis_start"] = again["axis_end"] = again["shank_start"] = again["shank_end"] = [x, 0.0, 0.0]
    plan["strips"].append(again)
    res = verify_plan(plan, tolerance=1e-3)
    first, second = res["strips"]
    assert first["covered_ranges"] and first["max_error"] is not None
    assert second["covered_ranges"] == [] and second["max_error"] is None and second["gouge_points"] == 0
    assert all(g["strip"] == 0 for g in res["gouge_points"])


def test_a_strip_repeated_exactly_is_measured_once_and_its_first_owns_it():
    """A two-paths plan that falls back to the double-flank axis used twice holds the same strip twice: verify
    measures its solid once (strip_solids) and gives what the pair forms to the first of the two; the strips
    after it keep their own figures and gouges.  Strips A, A, B against A, B: strip 2 must get B's numbers,
    which it does not if an owner is left as the index of the measured solid (1, the repeat)."""
    from flank_addon.simulation.sweep import strip_solids

    a = ball_plan(0.003)["strips"][0]
    b = dict(ball_plan(0.002)["strips"][0])
    c = [0.0, RC + 0.1 - 0.002, 0.0]                  # the second ball a quarter turn on
    b["axis_start"] = b["axis_end"] = b["shank_start"] = b["shank_end"] = c
    twice = ball_plan(0.003)
    twice["strips"] = [a, dict(a, flank=0), b]
    once = ball_plan(0.003)
    once["strips"] = [a, b]
    tools, first = strip_solids(twice["strips"])
    assert len(tools) == 2 and first.tolist() == [0, 2]
    res, ref = verify_plan(twice, tolerance=1e-3), verify_plan(once, tolerance=1e-3)
    s0, s1, s2 = res["strips"]
    r0, r1 = ref["strips"]
    assert s1["covered_ranges"] == [] and s1["max_error"] is None and s1["gouge_points"] == 0
    for s, r in ((s0, r0), (s2, r1)):
        assert r["covered_ranges"] and r["gouge_points"] > 0
        assert (s["covered_ranges"], s["max_error"], s["min_error"], s["gouge_points"]) == \
            (r["covered_ranges"], r["max_error"], r["min_error"], r["gouge_points"])
    assert sorted((g["index"], g["strip"]) for g in res["gouge_points"]) == \
        sorted((g["index"], 2 * g["strip"]) for g in ref["gouge_points"])


def test_notes_in_a_paraboloid_strip_play_no_part_in_its_solid():
    """A plan may carry more fields than the reader needs ("more fields are welcome"), also inside a strip's
    paraboloid: the solid is a and b alone, so two strips that differ only in a note share it, and verify
    reads the note without trying to make a number of it."""
    from flank_addon.simulation.sweep import strip_solids

    plan = ball_plan(0.0)
    s = plan["strips"][0]
    s["axis_end"] = [s["axis_start"][0] + 0.1, 0.0, 0.0]
    s["paraboloid"] = {"a": -5.0, "b": 0.02, "source": "catalogue X"}
    plan["strips"].append(dict(s, paraboloid={"a": -5.0, "b": 0.02, "source": "catalogue Y"}))
    plan["strips"].append(dict(s, paraboloid={"a": -5.0, "b": 0.025}))
    tools, first = strip_solids(plan["strips"])
    assert first.tolist() == [0, 2]
    res = verify_plan(plan, tolerance=1e-3)
    assert res["strips"][1]["covered_ranges"] == [] and res["strips"][1]["max_error"] is None


def test_first_least_picks_the_first_of_near_equal_rows():
    from flank_addon.simulation.sweep import first_least

    d = np.array([[1.0, 2.0, 5.0, np.inf, np.nan, 1.0],
                  [1.0 - 1e-16, 1.0, 5.0 - 1e-9, np.inf, 3.0, np.nan]])
    assert first_least(d, 1e-12).tolist() == [0, 1, 1, 0, 0, 1]          # a NaN: where argmin puts it


def test_shank_collision_is_reported_on_the_other_flank():
    # a shank cylinder reaching deep into the rotor at 270 degrees, inside the non-target flank
    shank = ([0.0, -0.9, -0.05], [0.0, -0.6, 0.05], 0.05)
    res = verify_plan(ball_plan(0.0, shank=shank), tolerance=1e-3)
    hits = [g for g in res["gouge_points"] if g["by"] == "shank"]
    assert hits and all(not g["target"] for g in hits)
    assert res["strips"][0]["collision"]


def test_cli_verify_json(tmp_path):
    path = tmp_path / "plan.json"
    write_plan(path, ball_plan(0.004))
    r = subprocess.run([sys.executable, "-m", "flank_addon", "verify", str(path), "--tolerance", "0.001", "--json"],
                       cwd=Path(__file__).resolve().parents[1], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert abs(d["max_overcut"] + 0.004) < 1e-9 and d["gouge_points"] and "deviation_profile" in d
    assert {"max_undercut", "max_overcut", "gouge_points", "strips"} <= set(d)


@pytest.mark.parametrize("delta", [0.05, 0.15, 0.3])
def test_an_overcut_deeper_than_the_search_range_is_measured_whole(delta):
    """The sweep first searches 0.1 R (0.08 here) along each normal; a point still inside the swept region at
    its end is searched again over the whole radius, so the ball's exact overcut -delta is reported, never the
    end of the range nor "uncut"."""
    res = verify_plan(ball_plan(delta, r=0.4))
    assert abs(res["max_overcut"] + delta) < 1e-9
    (facing,) = [d for i, x, y, d in res["deviation_profile"] if i == 0]
    assert abs(facing + delta) < 1e-9


@pytest.mark.parametrize("kw, message", [
    (dict(tolerance=float("nan")), r"tolerance nan must be a finite number > 0"),
    (dict(tolerance=-0.001), r"tolerance -0.001 must be a finite number > 0"),
    (dict(tolerance=0.0), r"tolerance 0.0 must be a finite number > 0"),
    (dict(tolerance=float("inf")), r"tolerance inf must be a finite number > 0"),
    (dict(tolerance="tight"), r"tolerance 'tight' must be a finite number > 0"),
    (dict(tolerance=3.4e38), r"tolerance 3.4e\+38 is above the rotor's outer radius 0.8, its limit"),
    (dict(search=float("inf")), r"search range inf must be a finite number > 0"),
    (dict(search=5.0), r"search range 5.0 is above the rotor's outer radius 0.8, its limit"),
])
def test_verify_refuses_a_tolerance_or_search_range_out_of_its_limits(kw, message):
    """A NaN tolerance would count no gouge at all and a negative one every point; an endless search range
    never ends: all are refused by name."""
    with pytest.raises(ValueError, match=message):
        verify_plan(ball_plan(0.004), **kw)


def test_all_points_colours_and_transfer_to_3d():
    from flank_addon.geometry.screw import screw_motion
    from flank_addon.simulation.verify import deviation_colors, values_on_rotor, world_to_rotor

    plan = ball_plan(0.003)
    res = verify_plan(plan, tolerance=1e-3, all_points=True)
    dev = np.array([np.nan if d is None else d for d in res["deviation_all"]])
    assert len(dev) == len(plan["rotor"]["profile"])
    assert abs(dev[0] + 0.003) < 1e-9                 # the gouge at the facing point
    # the opposite side of the cylinder is never reached
    assert np.isnan(dev[len(dev) // 2])
    rgba = deviation_colors(dev, 1e-3)
    assert rgba.shape == (len(dev), 4)
    assert rgba[0, 0] > rgba[0, 1] and rgba[0, 0] > rgba[0, 2]          # gouge: red
    assert np.allclose(rgba[len(dev) // 2, :3], 0.6)                     # untouched: grey
    # 3D points on the rotor surface carry the value of the profile point on their helix
    prof = np.asarray(plan["rotor"]["profile"])
    t = np.linspace(-3, 3, 7)
    pts = screw_motion(np.c_[prof[[0, 5, 700]], np.zeros(3)][:, None, :], t[None, :], 0.4, "right").reshape(-1, 3)
    vals = values_on_rotor(plan, world_to_rotor(plan, pts), np.nan_to_num(dev, nan=9.0))
    assert np.allclose(vals.reshape(3, -1), np.nan_to_num(dev, nan=9.0)[[0, 5, 700]][:, None])


@pytest.mark.parametrize("kind", ["frustums", "meridians"])
def test_the_owner_of_a_machined_point_is_the_first_tool_nearest_to_it(kind):
    """The owners come from the evaluation of D at each root (no second pass): they must be those that the
    tools' own distances at the machined points give (first within the tie of the least), with the deviations
    unchanged.  Two cones side by side share part of the flank; a third is the first one rounding apart (the
    two-paths fallback), so wherever it forms the surface the first one must own the point."""
    from flank_addon.simulation.sweep import (MeridianPart, RevolvingTool, StripTool, first_least,
                                              machined_deviation, tool_distances)

    v0, hand, tie = 0.45, "right", 1e-12
    poses = [(np.array([0.72, -0.06, 0.0]), np.array([0.95, -0.02, 0.3]), 0.06, 0.1),
             (np.array([0.71, 0.07, 0.0]), np.array([0.97, 0.1, 0.28]), 0.05, 0.11)]
    poses.append((np.nextafter(poses[0][0], 0.0),) + poses[0][1:])

    def tool(c1, c2, r1, r2):
        if kind == "frustums":
            return StripTool(c1, c2, [r1, r2])
        L = float(np.linalg.norm(c2 - c1))
        return RevolvingTool([MeridianPart(c1, c2 - c1, np.c_[np.linspace(0, L, 400), np.linspace(r1, r2, 400)])])

    tools = [tool(*p) for p in poses]
    ang = np.linspace(-0.5, 0.5, 61)
    pts = 0.7 * np.c_[np.cos(ang), np.sin(ang)]
    nrm = np.c_[np.cos(ang), np.sin(ang)]
    # the distance at a surface point is found to about 1e-11 where the helix meets the meridian's polyline at a
    # kink (the time search's resolution), to rounding on the frustums (and the rounding of numpy's sums may
    # change from run to run with the memory layout); the owner only changes where two different tools come that
    # close to each other, which the points here stay clear of
    noise = 1e-13 if kind == "frustums" else 1e-10
    dev, owner, least = machined_deviation(tools, pts, nrm, v0, hand, max_deviation=0.2, owner_tie=tie)
    np.testing.assert_allclose(dev, machined_deviation(tools, pts, nrm, v0, hand, max_deviation=0.2), rtol=0,
                               atol=noise)
    ok = np.isfinite(dev)
    assert ok.sum() >= 40 and np.all(owner[~ok] == -1) and np.all(np.isinf(least[~ok]))
    machined = np.c_[pts[ok] + dev[ok, None] * nrm[ok], np.zeros(ok.sum())]
    d = tool_distances(tools, machined, v0, hand, 1e-3)
    assert np.all(np.abs(least[ok] - d.min(axis=0)) < noise) and np.all(np.abs(least[ok]) < noise)
    assert np.all(np.abs(d[0] - d[1]) > 10 * noise)
    np.testing.assert_array_equal(owner[ok], first_least(d, tie))
    assert set(owner[ok]) == {0, 1}                      # both cones form the flank; the copy never does
