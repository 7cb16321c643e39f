"""strip_cover: per-pose coverage vs the sweep engine, minimum interval cover vs exhaustive search,
adaptive seeding, junction kinks on an analytic case and against the envelopes' own sections."""
import itertools
import math

import numpy as np
import pytest

from cone_poses import surface_frame, tangent_pose
from flank_addon.tooling.cone import ConePose, ConeTool
from flank_addon.geometry.helical_surface import HelicalSurface
from flank_addon.geometry.profile import Line, SegmentProfile
from flank_addon.methods.single_flank.strip_cover import (FlankSamples, adaptive_cover, coverage_of,
                                                           covered_intervals, crossing_kinks, envelope_normals,
                                                           flank_samples, junction_kinks, minimum_interval_cover,
                                                           pose_deviations, smooth_cover)
from flank_addon.simulation.sweep import machined_deviation, tool_of

EPS = 1e-3
TOOL = ConeTool(math.asin(0.1), 0.05, 0.08, 0.04, 0.6)


def scanned_pose(S, fr, u, n_dir=8, eps=EPS):
    """The tangent pose at u (directions scanned about the normal) that overcuts the flank least,
    ties broken by the widest covered interval."""
    _, n, xu, _, _ = surface_frame(S, u)
    e1 = xu / np.linalg.norm(xu)
    e2 = np.cross(n, e1)
    th = np.linspace(0, np.pi, n_dir, endpoint=False)
    poses = [tangent_pose(S, TOOL, u, np.cos(a) * e1 + np.sin(a) * e2) for a in th]
    c = covered_intervals(poses, S, fr, eps, eps, n=120, search=0.02)
    key = [(pc.max_overcut, -sum(b - a for a, b in pc.intervals)) for pc in c.poses]
    return poses[min(range(len(poses)), key=key.__getitem__)]


@pytest.fixture(scope="module")
def mid_poses(female):
    r, S = female
    fr = (0.70, 0.80)
    return fr, [scanned_pose(S, fr, u) for u in np.linspace(0.705, 0.795, 6)]


# ---------------------------------------------------------------- covered intervals
def test_pose_deviations_match_machined_deviation(female, mid_poses):
    """The stacked per-(pose, point) root finding = machined_deviation with one tool at a time."""
    r, S = female
    fr, poses = mid_poses
    fs = flank_samples(S, fr, 80)
    tools = [tool_of(p) for p in poses]
    dev = pose_deviations(tools, fs.points, fs.normals, S.v0, S.handedness, 0.01)
    for k, t in enumerate(tools):
        ref = machined_deviation([t], fs.points, fs.normals, S.v0, S.handedness, max_deviation=0.01)
        fin = np.isfinite(ref)
        assert fin.sum() > 10
        np.testing.assert_allclose(dev[k][fin], ref[fin], atol=1e-10)
        # machined_deviation gives +inf for overcuts deeper than its search; here they are -inf
        assert np.all(np.isposinf(dev[k][~fin]) | np.isneginf(dev[k][~fin]))


def test_covered_intervals_are_where_the_deviation_is_in_band(female, mid_poses):
    r, S = female
    fr, poses = mid_poses
    c = covered_intervals(poses, S, fr, EPS, 0.5 * EPS, n=200)
    u = c.samples.u
    assert any(pc.intervals for pc in c.poses)
    for pc in c.poses:
        d = pc.deviation
        ok = (d >= -0.5 * EPS) & (d <= EPS)
        # index ranges are exactly the in-band runs
        mask = np.zeros(len(u), bool)
        for a, b in pc.index_ranges:
            mask[a:b + 1] = True
        assert np.array_equal(mask, ok)
        # parameter intervals contain their runs and end before the neighbouring out-of-band sample
        assert len(pc.intervals) == len(pc.index_ranges)
        for (ua, ub), (a, b) in zip(pc.intervals, pc.index_ranges):
            assert ua <= u[a] + 1e-15 and ub >= u[b] - 1e-15
            assert a == 0 or ua >= u[a - 1]
            assert b == len(u) - 1 or ub <= u[b + 1]
        assert pc.admissible == (not (d < -0.5 * EPS).any())


def test_deep_overcut_is_reported_not_hidden(female):
    """A cone pushed 3 mm-equivalents into the flank: deviation -inf (beyond search) or < -eps,
    never +inf, and the pose is not admissible."""
    r, S = female
    fr = (0.70, 0.80)
    q, n, xu, _, _ = surface_frame(S, 0.75)
    p = tangent_pose(S, TOOL, 0.75, xu / np.linalg.norm(xu), lift=-0.03)
    c = covered_intervals([p], S, fr, EPS, EPS, n=60, search=0.005)
    d = c.poses[0].deviation
    near = np.abs(c.samples.u - 0.75) < 0.01
    assert np.all(d[near] < -EPS)
    assert np.isneginf(d[near]).any()
    assert not c.poses[0].admissible


# ---------------------------------------------------------------- minimum interval cover
def _merge(iv):
    out = []
    for a, b in sorted(iv):
        if out and a <= out[-1][1]:
            out[-1][1] = max(out[-1][1], b)
        else:
            out.append([a, b])
    return out


def _clip(iv, lo, hi):
    return [(max(a, lo), min(b, hi)) for a, b in iv if b >= lo and a <= hi]


def test_minimum_interval_cover_vs_exhaustive():
    rng = np.random.default_rng(7)
    n_full = n_gap = 0
    for trial in range(400):
        m = int(rng.integers(1, 8))
        a = rng.integers(0, 10, m).astype(float)
        w = rng.integers(0, 5, m).astype(float)
        iv = [(float(x), float(x + y)) for x, y in zip(a, w)]
        lo, hi = 1.0, float(rng.integers(2, 11))
        res = minimum_interval_cover(iv, lo, hi)
        target = _merge(_clip(iv, lo, hi))
        # exhaustive: smallest subset whose union on [lo, hi] equals that of all intervals
        best = None
        for k in range(0, m + 1):
            for sub in itertools.combinations(range(m), k):
                if _merge(_clip([iv[i] for i in sub], lo, hi)) == target:
                    best = k
                    break
            if best is not None:
                break
        assert len(res.chosen) == best, (iv, lo, hi, res)
        assert _merge(_clip([iv[i] for i in res.chosen], lo, hi)) == target
        full = target == [[lo, hi]]
        assert res.complete == full
        # the gaps are exactly the complement of the union in [lo, hi]
        pts = np.linspace(lo, hi, 241)
        cov = np.array([any(x <= p <= y for x, y in iv) for p in pts])
        in_gap = np.array([any(x < p < y or (p == x == lo and p < y and not c)
                               for x, y in res.gaps) for p, c in zip(pts, cov)])
        assert not (cov & in_gap).any()
        assert np.all(cov | in_gap | np.isin(pts, [g for gg in res.gaps for g in gg]))
        n_full += full
        n_gap += not full
    assert n_full > 50 and n_gap > 50


def test_minimum_interval_cover_edge_cases():
    assert minimum_interval_cover([(0, 1), (1, 2)], 0, 2).chosen == [0, 1]     # closed: touching covers
    r = minimum_interval_cover([(0.5, 1)], 0, 2)
    assert r.gaps == [(0.0, 0.5), (1.0, 2.0)] and not r.complete
    r = minimum_interval_cover([], 0, 1)
    assert r.gaps == [(0.0, 1.0)] and r.chosen == []
    assert minimum_interval_cover([(0, 3), (1, 2), (0, 1)], 1, 2).chosen == [0]


# ---------------------------------------------------------------- adaptive loop
def test_adaptive_cover_covers_or_reports_honestly(female):
    r, S = female
    fr = (0.70, 0.80)
    calls = []

    def make(us):
        calls.append(list(us))
        return [scanned_pose(S, fr, u) for u in us]

    res = adaptive_cover(make, S, fr, EPS, EPS, n_seeds=2, max_rounds=6, n=150)
    assert len(res.rounds) >= 2                        # 2 seeds are not enough: gaps were seeded
    assert res.rounds[1]["seeds"] and all(any(a < s < b for a, b in res.rounds[0]["gaps"])
                                         for s in res.rounds[1]["seeds"])
    # the sample-level truth agrees with the interval model wherever the model claims coverage
    u = res.samples.u
    ok = (res.deviation >= -EPS) & (res.deviation <= EPS)
    in_gap = np.array([any(a < x < b for a, b in res.gaps) for x in u])
    assert ok[~in_gap].all()
    assert not any(a <= x <= b for x in u[ok] for a, b in res.uncovered)
    # the union deviation is the real machined deviation of the chosen poses together
    ref = machined_deviation([tool_of(p) for p in res.poses], res.samples.points, res.samples.normals,
                             S.v0, S.handedness, max_deviation=0.01)
    fin = np.isfinite(ref) & (np.abs(ref) < 0.009)
    np.testing.assert_allclose(res.deviation[fin], ref[fin], atol=1e-9)
    if res.complete:
        assert ok.all()

    # a candidate generator that fails on [0.72, 0.78]: the middle must stay reported
    def make_holey(us):
        return [None if 0.72 <= u <= 0.78 else scanned_pose(S, fr, u) for u in us]

    res2 = adaptive_cover(make_holey, S, fr, EPS, EPS, seeds=[0.705, 0.795], max_rounds=3, n=150)
    assert not res2.complete
    assert any(a < 0.75 < b for a, b in res2.gaps)
    assert any(a <= 0.75 <= b for a, b in res2.uncovered)


# ---------------------------------------------------------------- junction kinks
def _line_rotor():
    """Flank = the straight top edge y = 0 of a rectangle (u = 2 - x on it); a huge v0 makes the
    screw motion a translation along z, so a cone with its axis in z = 0 sweeps the prism over its
    outline: the tangent line of its two inscribed discs."""
    prof = SegmentProfile([Line((2, 0), (-2, 0)), Line((-2, 0), (-2, -1)), Line((-2, -1), (2, -1)),
                           Line((2, -1), (2, 0))])
    return HelicalSurface(prof, 1e6, "right")


def _line_pose(theta, x_tip, toward, tool=ConeTool(math.asin(0.1), 0.05, 0.08)):
    """Cone whose outline in z = 0 is the line y = tan(theta) x, touching it from above; its tip
    disc touches at x = x_tip and the cone extends towards sign(toward) x."""
    d = np.array([math.cos(theta), math.sin(theta), 0.0]) * toward
    nu = np.array([-math.sin(theta), math.cos(theta), 0.0])
    P = np.array([x_tip, math.tan(theta) * x_tip, 0.0])
    a = math.cos(tool.alpha) * d + math.sin(tool.alpha) * nu
    return ConePose(tool, P + tool.r1s * nu, a)


@pytest.mark.parametrize("ta,tb", [(2.0, -3.0), (0.5, 0.0), (-1.0, 4.0)])
def test_junction_kink_analytic(ta, tb):
    S = _line_rotor()
    A = _line_pose(math.radians(ta), -0.2, +1)
    B = _line_pose(math.radians(tb), 0.2, -1)
    js = junction_kinks(A, B, S, (1.0, 3.0), n=200)
    j = min(js, key=lambda j: abs(j.u - 2.0))
    assert abs(j.u - 2.0) < 1e-7                      # the outlines cross at x = 0
    assert abs(j.deviation) < 1e-8
    assert abs(j.kink_deg - abs(ta - tb)) < 1e-4
    assert abs(j.section_kink_deg - abs(ta - tb)) < 1e-4


def test_junction_kink_of_identical_poses_is_zero():
    S = _line_rotor()
    A = _line_pose(math.radians(1.0), -0.2, +1)
    B = _line_pose(math.radians(1.0), -0.2, +1)
    S2 = _line_rotor()
    # identical deviation curves: every sample is a junction, all with zero kink
    js = junction_kinks(A, B, S2, (2.05, 2.15), n=5)
    assert js and all(abs(j.kink_deg) < 1e-6 for j in js)


def test_junction_kink_on_rotor_matches_envelope_sections(female, mid_poses):
    """On the female rotor: the kink from the tools' normals equals the kink of the two envelope
    sections x_k(u) = p(u) + d_k(u) n(u) (finite differences of the deviation curves), turned into
    helical-surface normals (x_u' x (h J x, v0))."""
    r, S = female
    fr, poses = mid_poses
    found = 0
    for A, B in zip(poses, poses[1:]):
        js = junction_kinks(A, B, S, fr, n=200)
        for j in js:
            if abs(j.deviation) > 5e-3:
                continue
            fs = flank_samples(S, fr, 3)
            ns = []
            for P in (A, B):
                du = 1e-5
                uu = np.array([j.u - du, j.u + du])
                p, n = fs.profile.eval(uu), fs.profile.outward_normal(uu)
                d = pose_deviations([tool_of(P)], p, n, S.v0, S.handedness, 0.02)[0]
                x = p + d[:, None] * n
                T = np.r_[x[1] - x[0], 0.0]
                xm = 0.5 * (x[0] + x[1])
                xt = np.r_[S.hand * np.array([-xm[1], xm[0]]), S.v0]
                N = np.cross(T, xt)
                ns.append(N / np.linalg.norm(N))
            ref = math.degrees(math.acos(np.clip(abs(ns[0] @ ns[1]), -1, 1)))
            assert abs(j.kink_deg - ref) < 2e-3 + 1e-2 * ref
            found += 1
    assert found >= 1


def test_envelope_normal_is_tool_normal_at_contact():
    """On the line rotor the envelope normal of a cone is the outline's normal (analytic)."""
    S = _line_rotor()
    th = math.radians(3.0)
    A = _line_pose(th, -0.2, +1)
    x = np.array([[0.0, 0.0, 0.0], [-0.1, math.tan(th) * -0.1, 0.0]])
    N = envelope_normals(tool_of(A), x, S.v0, S.handedness)
    # pointing away from the swept region (the tool is above the line): downwards
    ref = np.array([math.sin(th), -math.cos(th), 0.0])
    np.testing.assert_allclose(N, np.tile(ref, (2, 1)), atol=1e-6)


def test_cap_safe_bounds_cover_the_end_caps():
    """A helix that passes only through the top sphere's cap beyond c2: sweep.FrustumPart's bounding
    spheres miss it under a finite cutoff; the cap-safe tool used here does not."""
    from flank_addon.simulation.sweep import cap_safe
    from flank_addon.simulation.sweep import StripTool, helical_distance
    raw = StripTool([0.5, 0.0, 0.0], [0.5, 0.3, 0.0], [0.05, 0.08])
    x = np.array([[0.5, 0.3 + 0.079, 0.0], [0.5, -0.045, 0.0]])
    exact = helical_distance(raw, x, 1e6, "right")[0]          # no cutoff: no culling
    np.testing.assert_allclose(exact, [-0.001, -0.005], atol=1e-9)
    np.testing.assert_allclose(helical_distance(cap_safe(raw), x, 1e6, "right", cutoff=1e-3)[0], exact,
                               atol=1e-9)


def test_junction_kinks_chain_and_precomputed_deviations_match_pairwise(female, mid_poses):
    """junction_kinks_chain (all neighbouring pairs refined together) and junction_kinks with the
    deviations of the cover stage give the same junctions as the pairwise default."""
    from flank_addon.methods.single_flank.strip_cover import junction_kinks_chain
    r, S = female
    fr, poses = mid_poses
    fs = flank_samples(S, fr, 200)
    search = 0.05 * float(np.max(np.linalg.norm(fs.points, axis=1)))
    dev = pose_deviations([tool_of(p) for p in poses], fs.points, fs.normals, S.v0, S.handedness, search)
    chain = junction_kinks_chain(poses, S, fr, samples=fs)
    chain_dev = junction_kinks_chain(poses, S, fr, samples=fs, deviations=dev)
    assert len(chain) == len(poses) - 1
    found = 0
    for k, (A, B) in enumerate(zip(poses, poses[1:])):
        ref = junction_kinks(A, B, S, fr, samples=fs)
        pre = junction_kinks(A, B, S, fr, samples=fs, deviations=dev[k:k + 2])
        for js in (chain[k], chain_dev[k], pre):
            assert len(js) == len(ref)
            for j, jr in zip(js, ref):
                assert abs(j.u - jr.u) < 1e-9 and abs(j.kink_deg - jr.kink_deg) < 1e-6
                np.testing.assert_allclose(j.normals, jr.normals, atol=1e-9)
        found += len(ref)
    assert found >= 1
    with pytest.raises(ValueError, match="deviations must have shape"):
        junction_kinks(poses[0], poses[1], S, fr, samples=fs, deviations=dev)


def test_adaptive_cover_reports_the_chosen_coverage(female, mid_poses):
    r, S = female
    fr, poses = mid_poses
    cov = adaptive_cover(lambda us: poses, S, fr, 5e-3, 1e-6, seeds=[0.5 * (fr[0] + fr[1])], max_rounds=1, n=200)
    assert len(cov.chosen_coverage) == len(cov.poses)
    for p, pc in zip(cov.poses, cov.chosen_coverage):
        k = next(k for k, c in enumerate(cov.candidates) if c is p)
        assert pc is cov.coverage[k]


# ------------------------------------------------------------------------------------------- G1 selection
def test_crossing_kinks_of_two_lines():
    """Deviation lines with slopes tan 10 deg and -tan 20 deg cross once at 30 deg; arc length, not the
    parameter, sets the slope (the samples are spaced 2 apart in arc length)."""
    s = np.linspace(0.0, 2.0, 101)
    da, db = math.tan(math.radians(10)) * (s - 0.7), -math.tan(math.radians(20)) * (s - 0.7)
    assert crossing_kinks(da, db, s) == pytest.approx([30.0], abs=1e-9)
    assert crossing_kinks(da, db, 2 * s) == pytest.approx(
        [math.degrees(math.atan(math.tan(math.radians(10)) / 2) + math.atan(math.tan(math.radians(20)) / 2))])
    assert len(crossing_kinks(da, db, s, lo=1.0)) == 0          # the crossing lies before lo
    assert len(crossing_kinks(da, da + 1e-3, s)) == 0           # parallel: no junction


def _chain_cost(dev, order, iv, arc, u):
    """The largest kink estimate of each neighbouring pair of a chain, None if it is no cover."""
    ks = []
    for a, b in zip(order, order[1:]):
        (aa, ab), (ba, bb) = iv[a], iv[b]
        if not (ba <= ab and bb > ab and ba > aa):
            return None
        k = crossing_kinks(dev[a], dev[b], arc, np.interp(min(aa, ba), u, arc), np.interp(max(ab, bb), u, arc))
        if not len(k):
            return None
        ks.append(k.max())
    return ks


def test_smooth_cover_is_the_cheapest_chain_by_exhaustive_search():
    """Parabolic deviation curves d_k = q_k (u - c_k)^2 (no overcut) on a straight flank: the dynamic
    programme's cover equals the cheapest of all chains of n_min .. n_min + extra poses that cover [0, 1]
    (sum of squared kink estimates), found by enumerating every subset; and it is never worse than the
    minimum cover's chain."""
    u = np.linspace(0.0, 1.0, 401)
    fs = FlankSamples(u, np.stack([3.0 * u, np.zeros_like(u)], -1), np.tile([0.0, 1.0], (len(u), 1)))
    arc = 3.0 * u
    rng = np.random.default_rng(11)
    eps, checked, improved = 1e-2, 0, 0
    for trial in range(40):
        K = int(rng.integers(5, 10))
        c = np.sort(rng.uniform(-0.05, 1.05, K))
        q = rng.uniform(0.02, 0.4, K)
        dev = q[:, None] * (u[None, :] - c[:, None]) ** 2
        cov = [coverage_of(d, u, eps, 0.0) for d in dev]
        iv = [pc.intervals[0] if pc.intervals else (1.0, 0.0) for pc in cov]
        minimum = minimum_interval_cover([p for p in iv if p[1] > p[0]], 0.0, 1.0)
        sel = smooth_cover(cov, fs, extra=2)
        if not minimum.complete:            # jumps the gaps: still as few poses as the minimum cover allows
            assert sel is not None and len(minimum.chosen) <= len(sel.chosen) <= len(minimum.chosen) + 2
            continue
        n_min = len(minimum.chosen)
        best = None
        for m in range(n_min, n_min + 3):
            for sub in itertools.combinations(range(K), m):
                order = sorted(sub, key=lambda k: iv[k])
                if iv[order[0]][0] > 0.0 or iv[order[-1]][1] < 1.0:
                    continue
                ks = _chain_cost(dev, order, iv, arc, u)
                if ks is not None:
                    cost = float(np.sum(np.square(ks)))
                    if best is None or cost < best[0] * (1 - 1e-9):
                        best = (cost, m)
        if best is None:
            assert sel is None
            continue
        assert sel is not None and sel.minimum == n_min
        assert sel.cost == pytest.approx(best[0], rel=1e-9, abs=1e-12)
        assert len(sel.chosen) <= n_min + 2
        assert _chain_cost(dev, sel.chosen, iv, arc, u) == pytest.approx(sel.kinks, rel=1e-12)
        # a valid cover: together the chosen poses hold [0, 1] in the band
        d = dev[sel.chosen].min(axis=0)
        assert np.all(d <= eps + 1e-15)
        checked += 1
        improved += sel.cost < 0.999 * sum(
            k ** 2 for k in (_chain_cost(dev, sorted(minimum.chosen, key=lambda k: iv[k]), iv, arc, u) or [np.inf]))
    assert checked >= 15 and improved >= 3


def test_smooth_cover_jumps_gaps_nothing_covers():
    u = np.linspace(0.0, 1.0, 201)
    fs = FlankSamples(u, np.stack([u, np.zeros_like(u)], -1), np.tile([0.0, 1.0], (len(u), 1)))
    dev = np.array([(u - c) ** 2 for c in (0.1, 0.25, 0.8)])
    cov = [coverage_of(d, u, 0.02, 0.0) for d in dev]        # [0, 0.24], [0.11, 0.39], [0.66, 0.94]
    sel = smooth_cover(cov, fs, extra=1)
    assert sel.chosen == [0, 1, 2] and sel.minimum == 3
    assert sel.kinks[1] == 0.0 and sel.kinks[0] > 0.0
    assert sel.cost == pytest.approx(sel.kinks[0] ** 2)
    assert smooth_cover([coverage_of(-np.ones_like(u), u, 0.02, 0.0)], fs) is None     # overcuts: none
