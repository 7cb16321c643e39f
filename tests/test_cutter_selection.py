"""Tests of cutter_selection (Bizzarri, Bo & Bartoň §4): Dupin indicatrix along flanks, Eqs. (18)-(21), admissible
region, catalogue suggestion and the suggest-tool CLI.  References are computed independently here:
finite differences of surface.evaluate, brute-force support functions, the catalogue checked entry by
entry with the conditions written out again."""
import json
import math

import numpy as np
import pytest

from flank_addon.tooling import catalogue
from flank_addon.tooling import cutter_selection as cs
from flank_addon.cli import main
from flank_addon.tooling.cone import ConeTool
from flank_addon.geometry.rotors import builtin_by_name


@pytest.fixture(scope="module")
def female_bounds(female):
    from flank_addon.methods.double_flank.planner import custom_tool_bounds, plan_double_flank

    r, s = female
    res = plan_double_flank(s, r.flanks, valley=0, simulate=False, m=50)
    return res, custom_tool_bounds(s, r.flanks, 0, result=res)


# ---------------------------------------------------------------------------- independent references
def fd_shape_operator(surface, u, t, h=2e-4):
    """Principal curvatures/directions and outward normal from central differences of evaluate(u, t)."""
    X = lambda du, dt: surface.evaluate(u + du, t + dt)  # noqa: E731
    x0 = X(0, 0)
    xu = (X(h, 0) - X(-h, 0)) / (2 * h)
    xt = (X(0, h) - X(0, -h)) / (2 * h)
    xuu = (X(h, 0) - 2 * x0 + X(-h, 0)) / h ** 2
    xtt = (X(0, h) - 2 * x0 + X(0, -h)) / h ** 2
    xut = (X(h, h) - X(h, -h) - X(-h, h) + X(-h, -h)) / (4 * h * h)
    n = np.cross(xu, xt)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    # orient outward without the module's normal: a step along n must leave the rotor solid
    out = ~surface.contains(x0 + 1e-4 * n)
    n = np.where(out[:, None], n, -n)
    dot = lambda a, b: np.einsum("ij,ij->i", a, b)  # noqa: E731
    I = np.stack([np.stack([dot(xu, xu), dot(xu, xt)], -1), np.stack([dot(xu, xt), dot(xt, xt)], -1)], -2)
    II = np.stack([np.stack([dot(xuu, n), dot(xut, n)], -1), np.stack([dot(xut, n), dot(xtt, n)], -1)], -2)
    k, e = [], []
    for Ii, IIi, a, b in zip(I, II, xu, xt):
        w, v = np.linalg.eig(np.linalg.solve(Ii, IIi))
        w, v = np.real(w), np.real(v)
        order = np.argsort(w)[::-1]
        k.append(w[order])
        d = np.array([v[0, j] * a + v[1, j] * b for j in order])
        e.append(d / np.linalg.norm(d, axis=1, keepdims=True))
    return np.array(k), np.array(e), n


def fd_reliable(surface, u, t, h=2e-4, tol=1e-4):
    """fd_shape_operator at steps h and h/2 and where the two agree (the profile is smooth at the scale
    of the difference step there; built-in profiles join arcs with curvature jumps)."""
    k, e, n = fd_shape_operator(surface, u, t, h)
    k2, _, _ = fd_shape_operator(surface, u, t, 0.5 * h)
    scale = np.abs(k).max(axis=1)
    return k, e, n, np.abs(k - k2).max(axis=1) <= tol * scale


def conditions_by_hand(tool, a_min, b):
    """Eqs. (18)-(21) written out once more for the brute-force catalogue check."""
    r_mid = 0.5 * (tool.r1c + tool.r2c) / math.cos(tool.alpha)
    h = (tool.r2c - tool.r1c) / math.tan(tool.alpha)
    eps = 1e-12
    return (math.sqrt(r_mid) <= a_min + eps and tool.r1c <= b.c * b.d_min + eps and tool.r2c <= b.c * b.d_max + eps
            and h <= b.d_depth + eps and tool.alpha <= b.d_angle + eps)


# ---------------------------------------------------------------------------- Dupin indicatrix
def test_curvatures_and_directions_match_finite_differences(female):
    r, s = female
    d = cs.flank_dupin(s, r.flanks, 1, n=60)
    k_fd, e_fd, n_fd, good = fd_reliable(s, d.u, np.zeros(len(d.u)))
    assert good.sum() >= 50
    scale = np.abs(k_fd).max(axis=1)
    assert np.all((np.abs(d.k1 - k_fd[:, 0]) <= 3e-4 * scale)[good])
    assert np.all((np.abs(d.k2 - k_fd[:, 1]) <= 3e-4 * scale)[good])
    assert np.allclose(d.normal[good], n_fd[good], atol=1e-5)
    # directions: only well separated principal curvatures define them
    sep = (np.abs(k_fd[:, 0] - k_fd[:, 1]) > 0.05 * scale) & good
    assert sep.sum() > 40
    assert np.all(np.abs(np.einsum("ij,ij->i", d.e1, e_fd[:, 0]))[sep] > 1 - 1e-5)
    assert np.all(np.abs(np.einsum("ij,ij->i", d.e2, e_fd[:, 1]))[sep] > 1 - 1e-5)
    # the module's frame is orthonormal, tangent and right-handed with the outward normal
    assert np.allclose(np.cross(d.e1, d.e2), d.normal, atol=1e-9)


def test_curvatures_are_screw_invariant(female):
    r, s = female
    u = cs.flank_dupin(s, r.flanks, 0, n=20).u
    k0, _, _ = fd_shape_operator(s, u, np.zeros(len(u)))
    k1, _, _ = fd_shape_operator(s, u, np.full(len(u), 0.83))
    assert np.allclose(k0, k1, rtol=1e-4, atol=1e-5)


@pytest.mark.parametrize("name,flank", [("asymmetric-female", 1), ("asymmetric-male", 0), ("srm_a-male", 1)])
def test_classification_follows_sign_of_gaussian_curvature(name, flank, builtin):
    r, s = builtin(name)
    d = cs.flank_dupin(s, r.flanks, flank, n=120)
    k_fd, _, _, good = fd_reliable(s, d.u, np.zeros(len(d.u)))
    K = k_fd[:, 0] * k_fd[:, 1]
    clear = (np.abs(K) > 2e-3) & good   # outside the parabolic band |K| R^2 < 1e-3, with margin
    assert clear.sum() > 40
    assert np.array_equal(d.kind[clear], np.sign(K[clear]).astype(int))
    # a, b exist exactly at the hyperbolic samples and are the inverse square roots of |k|
    hyp = d.kind == -1
    assert np.array_equal(np.isfinite(d.a), hyp) and np.array_equal(np.isfinite(d.b), hyp)
    assert np.allclose(d.a[hyp & clear], 1 / np.sqrt(k_fd[hyp & clear, 0]), rtol=1e-3)
    assert np.allclose(d.b[hyp & clear], 1 / np.sqrt(-k_fd[hyp & clear, 1]), rtol=1e-3)
    assert d.hyperbolic_fraction == pytest.approx(np.mean(hyp))


def test_indicatrix_geometry_at_hyperbolic_points(female):
    r, s = female
    d = cs.flank_dupin(s, r.flanks, 1, n=80)
    hyp = np.flatnonzero(d.hyperbolic)
    assert len(hyp) > 40
    k_fd, _, n_fd, good = fd_reliable(s, d.u[hyp], np.zeros(len(hyp)))
    hyp, k_fd, n_fd = hyp[good], k_fd[good], n_fd[good]
    assert len(hyp) > 35
    # II in 3D: II(v) = k1 (v.e1)^2 + k2 (v.e2)^2 with the finite-difference curvatures
    II = lambda v, i: k_fd[:, 0] * np.einsum("ij,ij->i", v, d.e1[i]) ** 2 + \
        k_fd[:, 1] * np.einsum("ij,ij->i", v, d.e2[i]) ** 2  # noqa: E731
    for j in (0, 1):
        v = d.asymptotic[hyp, j]
        assert np.allclose(np.linalg.norm(v, axis=1), 1.0)
        assert np.allclose(np.einsum("ij,ij->i", v, n_fd), 0.0, atol=1e-6)
        assert np.all(np.abs(II(v, hyp)) < 1e-3 * np.abs(k_fd).max(axis=1))
    # the vertex a e1 lies on the machining-side hyperbola II = 1
    assert np.allclose(II(d.a[hyp, None] * d.e1[hyp], hyp), 1.0, rtol=1e-3)
    # Eq. (18) as tangency of line pairs: the largest half distance of two parallel lines touching the
    # hyperbola (brute-force maximum of its support function over line normals) is a
    th = np.linspace(0, np.pi, 20001)
    for i in hyp[::7]:
        m1, m2 = np.cos(th), np.sin(th)
        h2 = m1 ** 2 / d.k1[i] + m2 ** 2 / d.k2[i]     # squared support function where >= 0
        assert math.sqrt(h2.max()) == pytest.approx(d.a[i], rel=1e-6)


def test_symmetric_rotor_has_mirror_flanks(builtin):
    r, s = builtin("nilson-male")
    d0, d1 = cs.flank_dupin(s, r.flanks, 0), cs.flank_dupin(s, r.flanks, 1)
    assert d0.hyperbolic_fraction == pytest.approx(d1.hyperbolic_fraction, abs=0.01)
    assert d0.a_min == pytest.approx(d1.a_min, rel=1e-3)
    assert np.allclose(d0.k1, d1.k1[::-1], rtol=1e-3, atol=1e-3)


def test_female_flanks_are_mostly_hyperbolic_male_flanks_mostly_not(female, asym_male):
    # Bizzarri, Bo & Bartoň Fig. 3: the female rotor is mainly hyperbolic, the male only near its valley bottom
    r, s = female
    m, ms = asym_male
    fem = [cs.flank_dupin(s, r.flanks, k).hyperbolic_fraction for k in (0, 1)]
    mal = [cs.flank_dupin(ms, m.flanks, k).hyperbolic_fraction for k in (0, 1)]
    assert min(fem) > 0.5 and max(mal) < 0.1


# ---------------------------------------------------------------------------- Eq. (18)
def test_omega1_rejects_a_tool_too_big_by_construction(female):
    r, s = female
    d = cs.flank_dupin(s, r.flanks, 1)
    roomy = cs.ValleyBounds(d_min=10.0, d_max=10.0, d_depth=10.0)   # only Eq. (18) can bite
    al = math.radians(3.0)
    rho = d.a_min ** 2
    for factor, expect in ((1.2, False), (0.8, True)):
        # middle sphere radius r_mid = factor * a_min^2
        r1 = 0.7 * factor * rho * math.cos(al)
        r2 = 1.3 * factor * rho * math.cos(al)
        t = ConeTool(al, r1, r2)
        res = cs.is_admissible(t, d, roomy)
        assert res.ok is expect
        if not expect:
            assert [f.name for f in res.failures] == ["omega1"]
            f = res.failures[0]
            assert f.value == pytest.approx(math.sqrt(factor) * d.a_min) and f.limit == d.a_min
            assert "Eq. (18)" in res.message and f"{f.value:.6g}" in res.message and f"{d.a_min:.6g}" in res.message
    # equivalently: at the sample of a_min no line pair at half distance sqrt(r_mid) touches the hyperbola
    i = d.i_min
    K = d.k1[i] * d.k2[i]
    for factor in (1.2, 0.8):
        c2 = (factor * rho * K - d.k2[i]) / (d.k1[i] - d.k2[i])   # cos^2 of the ruling angle
        assert bool(0 <= c2 <= 1) is (factor < 1)


def test_flank_without_hyperbolic_points_fails_omega1(female):
    r, s = female
    d = cs.flank_dupin(s, r.flanks, 1)
    d.kind = np.ones_like(d.kind)          # pretend every sample is elliptic
    d.a = np.full_like(d.a, np.nan)
    res = cs.is_admissible(ConeTool(0.05, 0.001, 0.002), d, cs.ValleyBounds(1.0, 1.0, 1.0))
    assert not res.ok and "no hyperbolic point" in res.message
    assert cs.largest_cone(d, cs.ValleyBounds(1.0, 1.0, 1.0)) is None


# ---------------------------------------------------------------------------- Eqs. (19)-(21)
def test_custom_tool_bounds_are_the_cone_of_its_end_spheres(female_bounds):
    res, b = female_bounds
    p = res.paths[0]
    both = np.flatnonzero(p.counted.all(axis=0))
    i, j = both[0], both[-1]
    # the cone (D_min, D_max, D_depth) has boundary spheres = the custom tool's end spheres (cone.py Eqs. 2-7)
    cone = ConeTool.from_length(b.d_min, b.d_max, b.d_depth)
    assert cone.r1s == pytest.approx(p.radii[i], rel=1e-9)
    assert cone.r2s == pytest.approx(p.radii[j], rel=1e-9)
    assert cone.L == pytest.approx(np.linalg.norm(p.points[j] - p.points[i]), rel=1e-9)
    assert b.c == 0.9 and b.d_angle == pytest.approx(math.pi / 4)
    # the valley's width across its depth: the custom tool's radii grow from tip to top
    assert 0 < b.d_min < b.d_max < p.radii.max() + 1e-12


def test_tool_bigger_than_custom_tool_is_rejected(female_bounds):
    _, b = female_bounds
    roomy_a = 10.0
    al = math.atan2(b.d_max - b.d_min, b.d_depth)
    # the custom tool's own cone: it fails the buffer c = 0.9 of Eq. (19) on both radii
    res = cs.is_admissible(ConeTool(al, b.d_min, b.d_max), roomy_a, b)
    assert {f.name for f in res.failures} == {"r1", "r2"}
    f = {c.name: c for c in res.checks}
    assert f["r1"].value == pytest.approx(b.d_min) and f["r1"].limit == pytest.approx(0.9 * b.d_min)
    assert f["r2"].value == pytest.approx(b.d_max) and f["r2"].limit == pytest.approx(0.9 * b.d_max)
    assert "Eq. (19)" in res.message and f"{b.d_max:.6g}" in res.message
    # shrunk by 0.85 it fits (same angle, length 0.85 D_depth)
    assert cs.is_admissible(ConeTool(al, 0.85 * b.d_min, 0.85 * b.d_max), roomy_a, b).ok
    # too long (Eq. 20): a slender cone of length 1.5 D_depth
    t = ConeTool.from_length(0.1 * b.d_min, 0.2 * b.d_min, 1.5 * b.d_depth)
    res = cs.is_admissible(t, roomy_a, b)
    assert [c.name for c in res.failures] == ["omega2"] and res.failures[0].value == pytest.approx(1.5 * b.d_depth)
    # too open (Eq. 21)
    t = ConeTool(1.0, 0.1 * b.d_min, 0.2 * b.d_min)
    assert [c.name for c in cs.is_admissible(t, roomy_a, b).failures] == ["angle"]


def test_admissible_region_matches_pointwise_checks(female, female_bounds):
    r, s = female
    _, b = female_bounds
    d = cs.flank_dupin(s, r.flanks, 1)
    reg = cs.admissible_region(d, b, n=(12, 15, 15))
    assert 0 < reg.mask.sum() < reg.cone.sum()
    A, R1, R2 = np.meshgrid(reg.alpha, reg.r1c, reg.r2c, indexing="ij")
    for idx in np.ndindex(reg.mask.shape):
        if not reg.cone[idx]:
            assert R1[idx] >= R2[idx] and not reg.mask[idx]
            continue
        t = ConeTool(A[idx], R1[idx], R2[idx])
        assert reg.mask[idx] == conditions_by_hand(t, d.a_min, b)
        res = cs.is_admissible(t, d, b)
        assert reg.mask[idx] == res.ok
        assert {k for k, v in reg.failed.items() if v[idx]} == {f.name for f in res.failures}
    rg = reg.ranges()
    assert rg["r2c"][1] <= 0.9 * b.d_max and rg["r1c"][1] <= 0.9 * b.d_min and rg["alpha"][1] <= math.pi / 4
    # the closed-form largest cone is admissible and no grid point beats its r2c
    al, r1, r2 = cs.largest_cone(d, b)
    assert cs.is_admissible(ConeTool(al, r1, r2), d, b).ok
    assert reg.points()[:, 2].max() <= r2 + 1e-12
    assert cs.admissible_region(d, b, n=(200, 3, 400)).points()[:, 2].max() == pytest.approx(r2, rel=2e-2)


# ---------------------------------------------------------------------------- catalogue
def test_catalogue_data_and_scaling():
    mm = catalogue.catalogue_tools()
    assert len(mm) == len(catalogue.TAPERED_END_MILLS_MM) >= 15
    degs = {round(math.degrees(c.tool.alpha), 6) for c in mm}
    assert {1.0, 1.5, 2.0, 3.0, 5.0} <= degs
    for c, row in zip(mm, catalogue.TAPERED_END_MILLS_MM):
        _, taper, tip_d, flute, shank_d, overall = row
        assert c.tool.r1c == pytest.approx(tip_d / 2) and c.tool.h == pytest.approx(flute)
        assert c.tool.shank_radius >= c.tool.r2c and c.tool.shank_length == pytest.approx(overall - flute)
    unit = catalogue.catalogue_tools(40.0)
    for a, b in zip(mm, unit):
        assert b.unit == "R" and b.tool.alpha == a.tool.alpha
        for k in ("r1c", "r2c", "shank_radius", "shank_length", "h"):
            assert getattr(b.tool, k) == pytest.approx(getattr(a.tool, k) / 40.0)


@pytest.mark.parametrize("r_mm", [40.0, 60.0, 120.0])
def test_suggest_tool_is_largest_admissible_by_brute_force(female, female_bounds, r_mm):
    r, s = female
    _, b = female_bounds
    d = cs.flank_dupin(s, r.flanks, 1)
    cat = catalogue.catalogue_tools(r_mm)
    sug = cs.suggest_tool(cat, d, b)
    ok = [i for i, c in enumerate(cat) if conditions_by_hand(c.tool, d.a_min, b)]
    assert 0 < len(ok) < len(cat)            # the case can distinguish right from wrong
    assert sug.admissible == ok
    best = max(ok, key=lambda i: (cat[i].tool.r2c, cat[i].tool.r1c, cat[i].tool.h))
    assert sug.index == best and sug.tool is cat[best].tool and sug.entry is cat[best]
    # plain ConeTools in any order give the same tool
    perm = np.random.default_rng(7).permutation(len(cat))
    shuffled = [cat[i].tool for i in perm]
    assert cs.suggest_tool(shuffled, d.a_min, b).tool is cat[best].tool


def test_suggest_tool_none_admissible_and_ties(female_bounds):
    _, b = female_bounds
    big = ConeTool(0.05, 0.9 * b.d_max, 0.95 * b.d_max)
    sug = cs.suggest_tool([big], 10.0, b)
    assert sug.index is None and sug.tool is None and not sug.results[0].ok
    small = ConeTool(0.05, 0.01 * b.d_min, 0.02 * b.d_min)
    twin = ConeTool(0.05, 0.01 * b.d_min, 0.02 * b.d_min)
    assert cs.suggest_tool([big, small, twin], 10.0, b).index == 1   # first listed on ties
    # "largest" = top radius first: a slimmer tip with a bigger top beats a bigger tip with a smaller top
    wide_top = ConeTool.from_length(0.01 * b.d_min, 0.5 * b.d_max, 0.9 * b.d_depth)
    wide_tip = ConeTool.from_length(0.5 * b.d_min, 0.45 * b.d_max, 0.9 * b.d_depth)
    assert cs.is_admissible(wide_top, 10.0, b).ok and cs.is_admissible(wide_tip, 10.0, b).ok
    assert cs.suggest_tool([wide_tip, wide_top], 10.0, b).tool is wide_top
    # a tool exactly on a limit is admissible (the conditions are <=), just beyond it is not
    on = ConeTool.from_length(0.5 * b.d_min, b.c * b.d_max, 0.98 * b.d_depth)
    assert cs.is_admissible(on, 10.0, b).ok
    off = ConeTool.from_length(0.5 * b.d_min, b.c * b.d_max * (1 + 1e-9), 0.98 * b.d_depth)
    assert [f.name for f in cs.is_admissible(off, 10.0, b).failures] == ["r2"]


# ---------------------------------------------------------------------------- degenerate inputs
def test_degenerate_inputs_raise_clear_errors(female):
    r, s = female
    with pytest.raises(ValueError, match="not a finite number"):
        ConeTool(float("nan"), 0.1, 0.2)
    with pytest.raises(ValueError, match="r1 < r2"):
        ConeTool(0.1, 0.3, 0.2)
    with pytest.raises(ValueError, match="u_start < u_end"):
        cs.dupin_analysis(s, (float("nan"), 0.5))
    with pytest.raises(ValueError, match="u_start < u_end"):
        cs.dupin_analysis(s, (0.5, 0.2))
    with pytest.raises(ValueError, match="flanks 0..11"):
        cs.flank_dupin(s, r.flanks, 12)
    with pytest.raises(ValueError, match="d_max = nan"):
        cs.ValleyBounds(0.1, float("nan"), 0.3)
    with pytest.raises(ValueError, match="D_min >= 0"):
        cs.ValleyBounds(-0.1, 0.2, 0.3)
    b = cs.ValleyBounds(0.1, 0.2, 0.3)
    with pytest.raises(ValueError, match="a_min = nan"):
        cs.is_admissible(ConeTool(0.1, 0.01, 0.02), float("nan"), b)
    with pytest.raises(ValueError, match="a_min = -1"):
        cs.admissible_region(-1.0, b)
    with pytest.raises(ValueError, match="cone.ConeTool"):
        cs.is_admissible((0.1, 0.01, 0.02), 1.0, b)
    with pytest.raises(ValueError, match="empty"):
        cs.suggest_tool([], 1.0, b)
    with pytest.raises(ValueError, match="catalogue entry 1"):
        cs.suggest_tool([ConeTool(0.1, 0.01, 0.02), "end mill"], 1.0, b)
    with pytest.raises(ValueError, match="outer_radius_mm"):
        catalogue.catalogue_tools(0.0)
    with pytest.raises(ValueError, match="fewer than two"):
        p = type("P", (), {})()
        p.points, p.radii, p.counted = np.zeros((3, 3)), np.ones(3), np.zeros((2, 3), bool)
        cs.bounds_from_tool_path(p)


# ---------------------------------------------------------------------------- CLI
def test_cli_suggest_tool_builtin(capsys, female):
    assert main(["suggest-tool", "--builtin", "asymmetric-female", "--flank", "1", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    r, s = female
    dup = cs.flank_dupin(s, r.flanks, 1)
    assert d["dupin"]["a_min"] == pytest.approx(dup.a_min)
    assert d["dupin"]["hyperbolic_fraction"] == pytest.approx(dup.hyperbolic_fraction)
    b = cs.ValleyBounds(**{k: d["bounds"][k] for k in ("d_min", "d_max", "d_depth", "c", "d_angle")})
    cat = catalogue.catalogue_tools(50.0)
    ok = [c.name for c in cat if conditions_by_hand(c.tool, dup.a_min, b)]
    assert [c["name"] for c in d["catalogue"] if c["ok"]] == ok
    assert d["suggested"]["name"] == max((c for c in cat if c.name in ok), key=lambda c: cs.tool_size_key(c.tool)).name
    assert d["suggested"]["tool_mm"]["r2c"] == pytest.approx(50.0 * d["suggested"]["tool"]["r2c"])
    lo, hi = d["region"]["ranges"]["r2c"]
    assert 0 < lo < hi <= 0.9 * b.d_max


def test_cli_suggest_tool_text_and_errors(capsys):
    assert main(["suggest-tool", "--builtin", "asymmetric-male", "--flank", "0"]) == 0
    out = capsys.readouterr().out
    assert "hyperbolic" in out and "a in [" in out and "admissible region" in out and "suggested:" in out
    assert main(["suggest-tool", "--builtin", "asymmetric-male", "--flank", "8"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "0..7" in err and len(err.strip().splitlines()) == 1
    assert main(["suggest-tool", "--flank", "0"]) == 2
    assert "exactly one of --mesh" in capsys.readouterr().err
    assert main(["suggest-tool", "--builtin", "nope", "--flank", "0"]) == 2
    assert "unknown built-in" in capsys.readouterr().err
    assert main(["suggest-tool", "--builtin", "asymmetric-male", "--flank", "0", "--outer-radius-mm", "-5"]) == 2
    assert "--outer-radius-mm" in capsys.readouterr().err


@pytest.mark.parametrize("a_min,bounds", [
    (0.3, (0.2, 0.3, 0.1)),       # Omega_1 and Omega_2 both bind, the tip bound does not
    (0.6, (0.05, 0.5, 0.2)),      # tip bound and Omega_2 bind
    (0.45, (0.2013, 0.2935, 0.2657)),   # the asymmetric female valley: c D_max binds
])
def test_largest_cone_matches_brute_force_grid(a_min, bounds):
    b = cs.ValleyBounds(*bounds)
    al, r1, r2 = cs.largest_cone(a_min, b)
    assert cs.is_admissible(ConeTool(al, r1, r2), a_min, b).ok
    n = 150
    A, R1, R2 = np.meshgrid(np.linspace(1e-3, b.d_angle, n), np.linspace(0, b.c * b.d_min, n),
                            np.linspace(1e-4, b.c * b.d_max, n), indexing="ij")
    ok = ((np.sqrt(0.5 * (R1 + R2) / np.cos(A)) <= a_min) & ((R2 - R1) / np.tan(A) <= b.d_depth)
          & (R1 < R2))
    best = R2[ok].max()
    assert best <= r2 + 1e-12                       # nothing on the grid beats the closed form
    assert r2 - best <= 3 * b.c * b.d_max / n       # and the grid gets within a few steps of it


def test_cli_suggest_tool_mesh_in_mm(tmp_path, capsys, female):
    from flank_addon.io.mesh_files import write_mesh

    r50 = builtin_by_name("asymmetric-female", scale=50.0)
    path = tmp_path / "female.stl"
    write_mesh(path, *r50.mesh(n_profile=720, n_axial=30))
    assert main(["suggest-tool", "--mesh", str(path), "--flank", "1", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["unit"] == "mm" and d["unit_mm"] == 1.0
    # the same surface as the built-in with R = 1: a_min^2 scales with the length unit (both flank kinds of
    # this rotor reach a_min at the shared valley bottom, so the mesh's flank numbering does not matter)
    r1, s1 = female
    ref = cs.flank_dupin(s1, r1.flanks, 1).a_min ** 2
    assert d["dupin"]["rho_min"] == pytest.approx(50.0 * ref, rel=5e-3)
    b = cs.ValleyBounds(**{k: d["bounds"][k] for k in ("d_min", "d_max", "d_depth", "c", "d_angle")})
    cat = catalogue.catalogue_tools()
    ok = [c.name for c in cat if conditions_by_hand(c.tool, d["dupin"]["a_min"], b)]
    assert [c["name"] for c in d["catalogue"] if c["ok"]] == ok and ok
    assert d["suggested"]["tool_mm"] == d["suggested"]["tool"]
    assert main(["suggest-tool", "--mesh", str(path), "--flank", "1", "--outer-radius-mm", "60"]) == 2
    assert "--builtin only" in capsys.readouterr().err
    assert main(["suggest-tool", "--mesh", str(tmp_path / "none.stl"), "--flank", "1"]) == 2
    assert capsys.readouterr().err.startswith("error: ")
