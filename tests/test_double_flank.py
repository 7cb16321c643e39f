"""Bizzarri & Bartoň 2021 double-flank milling: restricted feet, symmetric exactness, optimum, variants, plans, CLI."""

import numpy as np
import pytest

from flank_addon.cli import main
from flank_addon.methods.double_flank.planner import (AxisEvaluator, Valley, bisect_brackets, build_path,
                                      optimize_axis, phi_value, plan_double_flank, radial_function,
                                      write_tool_csv)
from flank_addon.io.plan import read_plan
from flank_addon.geometry.screw import screw_motion, screw_to_plane
from flank_addon.simulation.verify import verify_plan


def _valley(builtin, name, k=0):
    r, s = builtin(name)
    return r, Valley(s, r.flanks, k)


def _brute_flank_distance(surface, lo, hi, q, n_u=1500, n_t=1201, tmax=1.2):
    """Distance from 3D points to the flank u in [lo, hi] by dense sampling (upper bound of the truth)."""
    u = np.linspace(lo, hi, n_u)
    p3 = np.c_[surface.profile.eval(u), np.zeros(n_u)]
    q0 = np.c_[screw_to_plane(q, surface.v0, surface.hand), np.zeros(len(q))]
    best = np.full(len(q), np.inf)
    for ch in np.array_split(np.linspace(-tmax, tmax, n_t), 40):
        pts = screw_motion(p3[:, None, :], ch[None, :], surface.v0, surface.hand).reshape(-1, 3)
        d = np.linalg.norm(pts[None, :, :] - q0[:, None, :], axis=-1).min(axis=1)
        best = np.minimum(best, d)
    return best


def test_restricted_feet_match_dense_sampling(builtin):
    r, v = _valley(builtin, "asymmetric-female")
    rng = np.random.default_rng(3)
    lam = rng.uniform(0.55, 1.2, 16)
    q = np.c_[lam * np.cos(v.theta) + 0.05 * rng.normal(size=16), lam * np.sin(v.theta) + 0.05 * rng.normal(size=16),
              0.3 * rng.normal(size=16)]
    for j, (lo, hi) in enumerate(v.ranges):
        ft = v.feet[j](q)
        ref = _brute_flank_distance(v.surface, lo, hi, q, n_u=1000, n_t=801)
        # the sampled reference is an upper bound, measured at most 2e-5 above the truth at this density (1e-5
        # at 1500 x 1201); a missed basin costs 1e-2
        assert np.all(ft.distance <= ref + 1e-12)
        assert np.max(ref - ft.distance) < 2e-4
        assert np.all((ft.u >= lo) & (ft.u <= hi))


def test_a_solvers_feet_do_not_depend_on_the_solvers_beside_it(builtin):
    """The two-paths tool reads how far an axis sweeps its own flank from the feet of a run that also asked the
    untrimmed flanks: a solver's feet must be those of a run of it alone, bit for bit, cold and warm-started,
    with more rows than a thread-shared guard query takes (2,048)."""
    from flank_addon.geometry.flank_feet import FlankFeet

    r, v = _valley(builtin, "asymmetric-female")
    rng = np.random.default_rng(5)
    n = 3001
    lam = rng.uniform(0.5, 1.6, n)
    q = np.c_[lam * np.cos(v.theta), lam * np.sin(v.theta), 0.4 * rng.normal(size=n)]
    moved = q + 1e-3 * rng.normal(size=q.shape)
    fields = ("u", "t", "point", "distance", "direction", "interior", "tau")
    for j in (0, 1):
        solvers = [v.feet[j]] + list(v.full_feet)
        together = FlankFeet.many(solvers, q, [None] * 3)
        alone = FlankFeet.many([v.feet[j]], q, [None])[0]
        for name in fields:
            assert np.array_equal(getattr(together[0], name), getattr(alone, name)), name
        warm_together = FlankFeet.many(solvers, moved, [(ft.u, ft.tau) for ft in together])
        warm_alone = FlankFeet.many([v.feet[j]], moved, [(alone.u, alone.tau)])[0]
        for name in fields:
            assert np.array_equal(getattr(warm_together[0], name), getattr(warm_alone, name)), name


def test_guard_answers_are_the_trees_whether_repeated_or_not(builtin):
    """The warm starts' guard asks a rough (approximate) kd-tree query, whose answers depend on the tree; a query
    that repeats the latest one bit for bit takes that one's answers.  Those must be the tree's own answers
    (a changed row, or another row count, is asked again), and the feet the same as a fresh solver's.  The
    table's two trees are made when first needed: a solver whose feet only start cold never makes the guard's."""
    from scipy.spatial import cKDTree

    from flank_addon.geometry.flank_feet import FlankFeet

    r, v = _valley(builtin, "asymmetric-female")
    lo, hi = v.ranges[0]
    fs, fresh = FlankFeet(v.surface, lo, hi), FlankFeet(v.surface, lo, hi)
    assert fs._guard_tree is None and fs._exact_tree is None
    rng = np.random.default_rng(8)
    lam = rng.uniform(0.5, 1.6, 300)
    q = np.c_[lam * np.cos(v.theta), lam * np.sin(v.theta), 0.4 * rng.normal(size=300)]
    cold = fs(q)
    assert fs._exact_tree is not None and fs._guard_tree is None
    reference = cKDTree(fs._points)
    Q = np.c_[screw_to_plane(q, v.surface.v0, v.surface.hand), np.zeros(len(q))]
    changed = Q.copy()
    changed[17, 0] += 0.05
    for points in (Q, Q, changed, Q[:200], changed, Q):
        expected = reference.query(points, k=1, eps=2.0)[1]
        assert np.array_equal(fs._guard_seeds(points), expected)
    assert fs._guard_seeds(Q) is fs._guard_seeds(Q.copy())         # the repeat is answered from the latest
    moved = q + 1e-3 * rng.normal(size=q.shape)
    for _ in range(2):                                              # the second time from the latest answers
        warm = fs(moved, warm=(cold.u, cold.tau))
        ref = fresh(moved, warm=(cold.u, cold.tau))
        for name in ("u", "t", "point", "distance", "direction", "interior", "tau"):
            assert np.array_equal(getattr(warm, name), getattr(ref, name)), name


def test_cold_seeds_are_the_nearest_table_samples(builtin):
    """A cold foot point starts from the k nearest samples of the flank's table, whatever tree answers the query
    (its leaf size is chosen for speed): checked against every sample's distance, for points on the valley's
    axes and far off the flank, in small and in threaded (>= 2048 rows) queries."""
    from flank_addon.geometry.flank_feet import FlankFeet

    r, v = _valley(builtin, "asymmetric-female")
    lo, hi = v.ranges[0]
    fs = FlankFeet(v.surface, lo, hi)
    rng = np.random.default_rng(9)
    for n, spread in ((300, 1.0), (2500, 3.0)):
        lam = rng.uniform(0.2, 1.6, n) * spread
        q = np.c_[lam * np.cos(v.theta), lam * np.sin(v.theta), 0.5 * rng.normal(size=n)]
        Q = np.c_[screw_to_plane(q, v.surface.v0, v.surface.hand), np.zeros(n)]
        seeds = fs._exact_seeds(Q, 3)
        d2 = np.concatenate([((c[:, None, :] - fs._points[None]) ** 2).sum(-1).argsort(axis=1)[:, :3]
                             for c in np.array_split(Q, 25)])
        assert np.array_equal(seeds, d2)


@pytest.mark.parametrize("name", ["nilson-male", "srm_a-female"])
def test_symmetric_profile_is_exact(name, builtin):
    """Prop. 3.1: on the symmetry line (0, 0, 0) both flanks are at the same distance from every axis point."""
    r, v = _valley(builtin, name)
    fit = optimize_axis(v, starts=[(0.0, 0.0, 0.0)])
    assert fit.phi < 1e-12 and np.all(np.abs(fit.x) < 1e-9)
    ev = AxisEvaluator(v)
    p = build_path(ev, np.zeros(3), m=100, meridian=False)
    both = p.counted[0] & p.counted[1]
    assert both.mean() > 0.9
    assert np.nanmax(np.abs(p.errors)) < 1e-12 * v.outer_radius
    # rotor -> envelope, independent: profile points of both flanks against the swept node spheres
    lam = np.linspace(p.lam[0], p.lam[-1], 2001)
    rad = np.interp(lam, p.lam, p.radii)
    A = p.points[0] + (lam - p.lam[0])[:, None] * (p.points[-1] - p.points[0]) / (p.lam[-1] - p.lam[0])
    for (lo, hi) in v.ranges:
        for u in np.linspace(lo, hi, 5)[1:-1]:
            x = np.r_[r.profile.eval(u), 0.0]
            X = screw_motion(x[None], np.linspace(-0.6, 0.6, 801), r.v0, r.handedness)
            d = min((np.linalg.norm(X[c][:, None] - A[None], axis=-1) - rad).min()
                    for c in np.array_split(np.arange(len(X)), 12))
            # sampling resolution of this brute force (t step 1.5e-3, lam step 4e-4): measured 1.4e-6
            assert abs(d) < 5e-6


# each kind of symmetric profile and each hand (males right-handed with 4 lobes, females left-handed with 6)
@pytest.mark.parametrize("name", ["nilson-male", "srm_a-female"])
def test_symmetric_plan_is_exact_by_verify(name, builtin):
    """the plan's custom tool mills both flanks within 1e-9 R, as the
    independent sweep simulation sees it (rotor -> envelope at every design point of both flanks),
    and the reported errors are what verify finds."""
    r, s = builtin(name)
    res = plan_double_flank(s, r.flanks, valley=0, m=200)
    R = res.valley.outer_radius
    ver = verify_plan(res.plan)
    assert ver["gouge_points"] == []
    assert ver["max_undercut"] <= 1e-9 * R and ver["max_overcut"] >= -1e-9 * R
    assert all(f["uncovered_ranges"] == [] for f in ver["flanks"])
    for st, vs in zip(res.plan["strips"], ver["strips"]):
        assert st["reported_max_error"] == pytest.approx(vs["max_error"], abs=1e-6 * R)


def test_analytic_gradient_matches_finite_differences(builtin):
    _, v = _valley(builtin, "asymmetric-male")
    ev = AxisEvaluator(v)
    lam = np.linspace(*v.lam_range, 60)
    x = np.array([-0.05, -0.15, -0.25])
    ar = ev(x, lam)
    h = 1e-6
    for j in range(3):
        e = np.zeros(3)
        e[j] = h
        rp, rm = ev(x + e, lam).r, ev(x - e, lam).r
        fd = (rp - rm) / (2 * h)
        ok = ar.interior
        assert np.max(np.abs(fd[ok] - ar.grad[..., j][ok])) < 1e-6


@pytest.fixture(scope="module")
def asym_fit(builtin):
    _, v = _valley(builtin, "asymmetric-male")
    return v, optimize_axis(v)


def test_asymmetric_optimum_is_a_local_minimum(asym_fit):
    v, fit = asym_fit
    assert 1e-4 < fit.phi < 1e-2
    ev = AxisEvaluator(v)
    lam = np.linspace(*v.lam_range, 100)
    base = phi_value(ev(fit.x_unit, lam))
    assert base == pytest.approx(fit.phi, abs=1e-12)
    for j in range(3):
        for sgn in (1, -1):
            y = fit.x_unit.copy()
            y[j] += sgn * 1e-4
            assert phi_value(ev(y, lam)) >= base - 1e-10
    # and it beats the paper's start (0, 0, 0) by a wide margin
    assert base < 0.5 * phi_value(ev(np.zeros(3), lam))


def test_tail_covers_the_whole_valley(asym_fit):
    """Unequal characteristics: nodes counting for one flank only continue the tool; together the
    feet sweep both trimmed flanks from the bottom to the rim."""
    v, fit = asym_fit
    ev = AxisEvaluator(v)
    p = build_path(ev, fit.x_unit, m=100, meridian=False)
    one = p.counted[0] ^ p.counted[1]
    assert one.any() and (p.counted[0] | p.counted[1]).mean() > 0.98
    ar = ev(fit.x_unit, p.lam)
    def worst_gap(mask):
        return max(np.diff(np.sort(np.r_[lo, ar.feet[k].u[mask[k]], hi])).max() / (hi - lo)
                   for k, (lo, hi) in enumerate(v.ranges))

    # the largest remaining gap is next to the valley bottom, where the foot on the short flank jumps
    # from the bottom helix onto the flank (measured 0.023 of the flank's range)
    g_tail = worst_gap(p.counted)
    both = p.counted[0] & p.counted[1]
    g_both = worst_gap(np.array([both, both]))
    assert g_tail < 0.05
    assert g_both > g_tail + 0.01      # without the tail part of a flank would stay unreached


def test_radial_function_variants():
    r = np.array([[1.0, 2.0, 3.0, 4.0], [1.5, 1.0, 5.0, 0.5]])
    c = np.array([[True, True, False, True], [True, True, True, False]])
    assert radial_function(r, c, "min").tolist() == [1.0, 1.0, 5.0, 4.0]
    assert radial_function(r, c, "avg").tolist() == [1.25, 1.5, 5.0, 4.0]
    assert radial_function(r, c, "one-sided-2").tolist() == [1.5, 1.0, 5.0, 4.0]
    assert radial_function(r, c, "min", cap=np.full(4, 2.5)).tolist() == [1.0, 1.0, 2.5, 2.5]
    with pytest.raises(ValueError, match="variant 'max'"):
        radial_function(r, c, "max")


def _plain_bisection(inside_at, inside, outside, tol, max_steps=60):
    calls = 0
    for _ in range(max_steps):
        m = 0.5 * (inside + outside)
        calls += 1
        if inside_at(np.array([m]))[0]:
            inside = m
        else:
            outside = m
        if abs(inside - outside) < tol:
            break
    return inside, calls


@pytest.mark.parametrize("levels", [1, 3, 5])
def test_batched_bisection_ends_where_the_plain_loop_does(levels):
    """bisect_brackets asks for several halvings per call; its ends must be the plain loop's bit for bit, on
    predicates with one change, several changes inside the bracket, brackets either way round, a tolerance
    the halvings cannot reach (the step cap) and a bracket already below the tolerance."""
    rng = np.random.default_rng(7)
    for case in range(60):
        edges = np.sort(rng.uniform(0, 1, rng.integers(1, 6)))

        def inside_at(t, edges=edges):
            return (np.searchsorted(edges, t) % 2 == 0) if case % 2 else (np.searchsorted(edges, t) % 2 == 1)

        brackets = []
        for _ in range(rng.integers(1, 4)):
            a, b = rng.uniform(-0.2, 1.2, 2)
            if inside_at(np.array([a]))[0] == inside_at(np.array([b]))[0]:
                continue
            if not inside_at(np.array([a]))[0]:
                a, b = b, a
            brackets.append((a, b))
        tol = [1e-12, 1e-3, 0.0, 10.0][case % 4]
        calls = []

        def counted(t):
            calls.append(len(t))
            return inside_at(t)

        got = bisect_brackets(counted, brackets, tol, levels=levels)
        want = [_plain_bisection(inside_at, a, b, tol) for a, b in brackets]
        steps = int(rng.integers(-1, 4))                  # a cap below one halving leaves the brackets as they are
        assert bisect_brackets(inside_at, brackets, tol, levels=levels, max_steps=steps) == \
            [_plain_bisection(inside_at, a, b, tol, max_steps=steps)[0] for a, b in brackets]
        assert got == [w for w, _ in want]
        if brackets:
            halvings = max(n for _, n in want)
            assert len(calls) == -(-halvings // levels)        # one call per `levels` halvings
            assert max(calls) <= len(brackets) * (2 ** levels - 1)
    with pytest.raises(ValueError, match="levels must be a whole number >= 1, got 0"):
        bisect_brackets(lambda t: t < 0.5, [(0.0, 1.0)], 1e-3, levels=0)


@pytest.fixture(scope="module")
def asym_plan(asym_male):
    r, s = asym_male
    res = plan_double_flank(s, r.flanks, m=200)
    return res, verify_plan(res.plan)


def test_min_variant_never_overcuts_and_reports_what_verify_finds(asym_plan):
    res, ver = asym_plan
    R = res.valley.outer_radius
    assert ver["gouge_points"] == []
    # the meridian polyline is shrunk by its chord tolerance, so it never cuts deeper than the design;
    # what remains (measured -1.19e-9 R) is the resolution of the simulation and of the Hermite radii
    assert ver["max_overcut"] >= -2e-9 * R
    for st, vs in zip(res.plan["strips"], ver["strips"]):
        assert st["reported_max_error"] == pytest.approx(vs["max_error"], abs=1e-6 * R)
        assert st["reported_min_error"] == pytest.approx(vs["min_error"], abs=1e-6 * R)
    # Remark 4.5: both one-sided distances are close (tool->rotor at nodes, rotor->envelope at points)
    for (t_max, _), (e_max, _) in zip(res.tool_to_rotor, res.rotor_to_envelope):
        assert abs(t_max - e_max) < 0.5 * t_max


def test_tool_mesh_and_csv(asym_plan, tmp_path):
    res, _ = asym_plan
    v, f = res.tool_mesh()
    assert f.max() < len(v) and len(f) > 1000
    p = res.paths[0]
    d = (p.plan_points[-1] - p.plan_points[0]) / np.linalg.norm(p.plan_points[-1] - p.plan_points[0])
    w = v - p.plan_points[0]
    rho = np.linalg.norm(w - (w @ d)[:, None] * d, axis=1)
    assert rho.max() <= max(p.radii.max(), res.plan["strips"][0]["shank_radius"]) + 1e-9
    write_tool_csv(tmp_path / "t.csv", p)
    rows = np.loadtxt(tmp_path / "t.csv", delimiter=",", skiprows=1)
    assert np.all(np.diff(rows[:, 0]) > 0) and rows[0, 1] == 0.0
    env = res.envelope_meshes(z_range=(0.0, 0.5), n_t=8)[0]
    assert len(env) == 2 and env[0][0].shape[1] == 3 and len(env[0][2]) == len(env[0][0])


def test_cli_errors(tmp_path, capsys):
    """Bad options are refused with one line naming them, before any planning (the successful cone plan and
    its file: test_cli_mesh_input)."""
    for argv, msg in ((["--valley", "7"], "--valley 7 is outside 0..3"),
                      (["--valley", "0", "--tool", "cones:40"], "K = 40 is outside the limits 1..12"),
                      (["--valley", "0", "--rim", "1.5"], "--rim 1.5 is outside the limits 0.2..0.98"),
                      (["--valley-point", "1,2"], "must be three finite numbers")):
        assert main(["plan", "double-flank", "--builtin", "nilson-male", *argv, "--out", str(tmp_path / "x.json")]) == 2
        assert msg in capsys.readouterr().err
    assert not (tmp_path / "x.json").exists()


def test_cli_mesh_input(tmp_path, capsys):
    """--mesh: the rotor is analysed from a mesh file (axis, pitch, flanks), the plan is in the mesh's
    frame and unit, and a valley point picks the valley it lies in; the cone plan's report and file (one strip,
    two radii).  One run shows all of it."""
    from flank_addon.io.mesh_files import write_mesh
    from flank_addon.geometry.rotors import builtin_rotor

    rot = builtin_rotor("nilson", "male")
    v, f = rot.mesh(n_axial=40)          # 720 x 40 vertices: rings are what the analysis reads
    write_mesh(tmp_path / "rotor.stl", v, f)
    out = tmp_path / "m.json"
    point = v[5000]                      # a mesh vertex in the middle of a flank, not on a lobe tip
    assert main(["plan", "double-flank", "--mesh", str(tmp_path / "rotor.stl"), "--valley-point",
                 ",".join(str(c) for c in point), "--tool", "cone", "--radii", "50", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "rotor->envelope" in text and "alpha" in text and "iterations" in text and "valley" in text
    plan = read_plan(out)
    assert plan["method"] == "double-flank-cone" and plan["length_unit"] == "mm" and len(plan["strips"]) == 1
    st = plan["strips"][0]
    assert len(st["radii"]) == 2
    assert st["reported_max_error"] > 0 and np.isfinite(st["reported_max_error"])
    # the point, carried into the plan's rotor frame and screwed into z = 0, lies in the planned valley: the
    # flank pair of the analysed rotor that holds the two trimmed target flanks
    rr = plan["rotor"]
    T = np.linalg.inv(np.asarray(rr["to_world"]))
    q0 = screw_to_plane((point @ T[:3, :3].T + T[:3, 3])[None], rr["v0"], rr["handedness"])
    prof = np.asarray(rr["profile"])
    near = int(np.argmin(np.linalg.norm(prof - q0, axis=1)))
    assert np.linalg.norm(prof[near] - q0) < 0.01
    a, b = plan["target_flanks"]
    fl = rr["flanks"]                    # the rotor's flanks, then the trimmed targets a, b appended
    lo, hi = fl[a][0], fl[b][1]
    pairs = [(fl[2 * k][0], fl[2 * k + 1][1]) for k in range(a // 2) if fl[2 * k][0] <= lo and hi <= fl[2 * k + 1][1]]
    assert len(pairs) == 1 and pairs[0][0] < near < pairs[0][1]


def test_cli_two_paths(tmp_path, capsys):
    out = tmp_path / "two.json"
    assert main(["plan", "double-flank", "--builtin", "nilson-male", "--valley", "0", "--two-paths",
                 "--radii", "100", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "axis 1" in text and "axis 2" in text
    plan = read_plan(out)
    assert plan["method"] == "double-flank-custom-two-paths" and len(plan["strips"]) == 2
    a, b = plan["strips"]
    # one tool on two axes: the same meridian on both strips, one strip per flank
    assert a["meridian"] == b["meridian"] and a["flank"] != b["flank"]
    ver = verify_plan(plan)
    assert ver["max_undercut"] <= 1e-6 and ver["max_overcut"] >= -1e-6 and ver["gouge_points"] == []
    assert main(["plan", "double-flank", "--builtin", "nilson-male", "--valley", "0", "--two-paths",
                 "--tool", "cone", "--out", str(tmp_path / "x.json")]) == 2
    assert "--two-paths needs the custom tool" in capsys.readouterr().err


def test_two_paths_beat_one_axis_on_asymmetric_female(female):
    """Bizzarri & Bartoň 2021 §4.3: one tool on two axes mills the asymmetric female valley better than the
    double-flank axis; its plan's reported errors are the simulated ones (rotor -> envelope)."""
    r, s = female
    one = plan_double_flank(s, r.flanks, m=200, simulate=False)
    two = plan_double_flank(s, r.flanks, m=200, two_paths=True)
    e_one = max(e for e, _ in one.tool_to_rotor)
    e_two = max(e for e, _ in two.tool_to_rotor)
    assert e_two < 0.96 * e_one
    x1, x2 = two.fits[1].x, two.fits[2].x
    assert np.linalg.norm(x1 - x2) > 1e-3                # really two different axes
    # nothing of the valley is left unswept (that would leave ~0.1 R of stock), no overcut
    sim_max = max(e for e, _ in two.rotor_to_envelope)
    sim_min = min(m for _, m in two.rotor_to_envelope)
    assert sim_max < 1.5 * e_one and sim_min > -1e-6
    strips = two.plan["strips"]
    assert max(s["reported_max_error"] for s in strips) == pytest.approx(sim_max, abs=1e-12)
    # and they are verify's, bit for bit: both strips in one sweep, as verify simulates them (one sweep per
    # strip gives the roots near a junction of the two strips other last bits)
    ver = verify_plan(two.plan)["strips"]
    assert [(s["reported_max_error"], s["reported_min_error"]) for s in strips] == \
        [(v["max_error"], v["min_error"]) for v in ver]


def test_two_path_error_rows_and_their_gradients(builtin):
    """The two-path epigraph's rows (Bizzarri & Bartoň 2021 §4.3): each block is an axis' own distance less one
    other distance where the axis' foot counts, 0 elsewhere; the gradients are those of finite differences of
    the rows, and the rows without gradients are the same numbers."""
    from flank_addon.methods.double_flank.planner import _two_path_terms, eval_at_tool_coordinates

    _, v = _valley(builtin, "asymmetric-male")
    x1, x2 = np.array([-0.05, -0.15, -0.25]), np.array([-0.07, -0.2, -0.32])
    y = np.r_[x1, x2]
    t = np.linspace(*v.lam_range, 40)
    e, G, owners, _ = _two_path_terms(AxisEvaluator(v), y, t)
    A, B = eval_at_tool_coordinates(AxisEvaluator(v), [(x1, t, (v.feet[0],) + tuple(v.full_feet), "a"),
                                                        (x2, t, (v.feet[1],) + tuple(v.full_feet), "b")])
    blocks = e.reshape(10, -1)
    others = [B.r[0], A.r[1], A.r[2], B.r[1], B.r[2], A.r[0], A.r[1], A.r[2], B.r[1], B.r[2]]
    for k, other in enumerate(others):
        own, counts = (A.r[0], A.interior[0]) if k < 5 else (B.r[0], B.interior[0])
        if k % 5 == 0:
            counts = A.interior[0] & B.interior[0]
        assert np.array_equal(blocks[k], np.where(counts, own - other, 0.0))
        assert not G.reshape(10, -1, 6)[k][~counts].any()
    assert np.array_equal(owners, np.repeat([0, 1], 5 * len(t)))
    assert 0 < np.count_nonzero(e) < len(e)
    e_only, no_grad, _, _ = _two_path_terms(AxisEvaluator(v), y, t, gradients=False)
    assert no_grad is None and e_only.tobytes() == e.tobytes()
    h = 1e-6
    for j in range(6):
        step = np.zeros(6)
        step[j] = h
        ep, Gp, _, _ = _two_path_terms(AxisEvaluator(v), y + step, t)
        em, Gm, _, _ = _two_path_terms(AxisEvaluator(v), y - step, t)
        same = (ep != 0) & (em != 0) & (e != 0)          # rows counted at all three points
        assert same.sum() > 50
        fd = (ep - em) / (2 * h)
        assert np.max(np.abs(fd[same] - G[same, j])) < 1e-5


def test_meridian_merges_give_np_uniques_array():
    """The meridian's vertices merge a few cap and zone abscissae into the sorted contact points instead of
    sorting all of them: the same array as np.unique, byte for byte, with repeats, zeros of either sign,
    NaN and values beyond either end; the union of spheres answers the same in any order of its spheres."""
    from flank_addon.methods.double_flank.planner import SphereUnion, _sorted_union

    rng = np.random.default_rng(11)
    for _ in range(3000):
        base = np.sort(np.round(rng.normal(size=rng.integers(0, 300)), rng.integers(1, 4)))
        extra = np.round(rng.normal(size=rng.integers(0, 40)), rng.integers(1, 4))
        if len(base) and rng.random() < 0.3:
            extra = np.r_[extra, base[rng.integers(0, len(base), 3)], base[0] - 1.0, base[-1] + 1.0, base[-1]]
        extra = np.r_[extra, [0.0, -0.0, np.nan][rng.integers(0, 3)]] if rng.random() < 0.2 else extra
        values = rng.permutation(np.r_[base, [0.0, -0.0][rng.integers(0, 2)]] if rng.random() < 0.2 else base)
        merged = _sorted_union(values, np.sort(values, kind="stable"), extra)
        assert merged.tobytes() == np.unique(np.concatenate([values, extra])).tobytes()
    s = np.cumsum(rng.uniform(0.01, 0.1, 500))
    r = 0.2 + 0.05 * np.sin(7 * s)
    h = np.linspace(s[0] - 0.3, s[-1] + 0.3, 2001)
    shuffled = rng.permutation(len(s))
    assert np.array_equal(SphereUnion(s, r)(h), SphereUnion(s[shuffled], r[shuffled])(h))
    # R^2 = max_j (2 s_j h + r_j^2 - s_j^2) - h^2 cancels terms of size s^2: compare the squares to that size
    brute2 = np.maximum(r[None, :] ** 2 - (h[:, None] - s[None, :]) ** 2, 0.0).max(axis=1)
    assert np.abs(SphereUnion(s, r)(h) ** 2 - brute2).max() < 1e-13 * (s[-1] + 0.3) ** 2
