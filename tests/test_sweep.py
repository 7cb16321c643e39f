"""Sweep simulation vs an independent brute force: rays against densely sampled, screwed tool spheres."""
import numpy as np
import pytest
from scipy.optimize import minimize, minimize_scalar

from flank_addon.geometry.screw import hand_sign, screw_motion
from flank_addon.simulation.sweep import (StripTool, helical_distance, helical_reach, machined_deviation,
                                         sd_sphere_frustum)


def ray_intervals(p, n, c1, r1, c2, r2, v0, hand, t, s):
    """lambda-intervals of the ray p + lambda n (plane z = 0) removed by spheres (s) at times (t)."""
    h = hand_sign(hand)
    T, S = np.meshgrid(t, s, indexing="ij")
    ct, st = np.cos(h * T), np.sin(h * T)
    o = np.stack([ct * p[0] - st * p[1], st * p[0] + ct * p[1], v0 * T], -1)   # S_t(p)
    d = np.stack([ct * n[0] - st * n[1], st * n[0] + ct * n[1], np.zeros_like(T)], -1)
    C = (1 - S)[..., None] * c1 + S[..., None] * c2
    r = (1 - S) * r1 + S * r2
    w = o - C
    b = np.einsum("...i,...i->...", w, d)
    c = np.einsum("...i,...i->...", w, w) - r * r
    disc = b * b - c
    ok = disc >= 0
    sq = np.sqrt(np.where(ok, disc, 0))
    return (-b - sq)[ok], (-b + sq)[ok], T[ok], S[ok]


def brute_deviation(p, n, c1, r1, c2, r2, v0, hand, n_t=1500, n_s=150):
    """Signed deviation along the ray: the grid of (t, s) spheres picks the removed interval, Nelder-Mead polishes
    its end.  The grid only chooses the start of the polish: on the cases below 1000 x 100 already gives the
    same values (within 5e-16) as 3000 x 300, and the same reached / unreached points."""
    z_lo = min(c1[2] - r1, c2[2] - r2)
    z_hi = max(c1[2] + r1, c2[2] + r2)
    t = np.linspace(z_lo / v0, z_hi / v0, n_t)
    s = np.linspace(0, 1, n_s)
    lo, hi, T, S = ray_intervals(p, n, c1, r1, c2, r2, v0, hand, t, s)
    if not len(lo):
        return np.inf
    inside = (lo <= 0) & (hi >= 0)
    if inside.any():   # overcut: lower end of the removed component containing lambda = 0
        order = np.argsort(lo)
        lo_s, hi_s = lo[order], hi[order]
        reach = np.maximum.accumulate(hi_s)
        comp_start = np.flatnonzero(np.r_[True, lo_s[1:] > reach[:-1]])
        k = comp_start[np.searchsorted(comp_start, np.flatnonzero(lo_s <= 0)[-1], side="right") - 1]
        cand = order[k]
        sign = -1
    else:              # material left: first removal along the ray
        pos = np.flatnonzero(lo > 0)
        cand = pos[np.argmin(lo[pos])]
        sign = 1

    def lower_end(x):
        tt, ss = x[0], np.clip(x[1], 0, 1)
        l_, _, _, _ = ray_intervals(p, n, c1, r1, c2, r2, v0, hand, np.array([tt]), np.array([ss]))
        return l_[0] if len(l_) else np.inf

    res = minimize(lower_end, [T[cand], S[cand]], method="Nelder-Mead",
                   options={"xatol": 1e-12, "fatol": 1e-14, "maxiter": 4000})
    val = min(res.fun, lo[cand])
    assert np.sign(val) in (sign, 0) or abs(val) < 1e-9
    return val


def test_sphere_frustum_distance_matches_union_of_spheres():
    rng = np.random.default_rng(0)
    c1, c2, r1, r2 = np.array([0.1, 0.2, 0.0]), np.array([0.3, -0.1, 0.5]), 0.05, 0.12
    q = rng.uniform(-0.5, 0.8, (1500, 3))
    d = sd_sphere_frustum(q, c1, r1, c2, r2)
    s = np.linspace(0, 1, 10001)[:, None]          # the union's sampling error here: 2.7e-9 (1.1e-9 at 20001)
    C, R = (1 - s) * c1 + s * c2, (1 - s[:, 0]) * r1 + s[:, 0] * r2
    best = np.full(len(q), np.inf)
    for i in range(0, len(C), 2000):
        best = np.minimum(best, (np.linalg.norm(q[:, None] - C[None, i:i + 2000], axis=2) - R[None, i:i + 2000]).min(1))
    out = best > 0
    assert np.max(np.abs(d[out] - best[out])) < 1e-8
    assert np.array_equal(d < 0, best < 0)


@pytest.mark.parametrize("hand", ["right", "left"])
def test_rays_within_the_helical_reach_stay_within_the_distance_of_the_points_helix(hand):
    """Every point of x + l d for l up to helical_reach lies within the radius of some S_s x (brute force over s),
    and the reach goes well beyond the radius for rays along the helix."""
    rng = np.random.default_rng(4 if hand == "right" else 5)
    v0, n = 0.3, 160
    x = np.c_[rng.uniform(-1, 1, (n, 2)), rng.uniform(-0.5, 0.5, n)]
    d = rng.normal(size=(n, 3))
    d[:n // 2, 2] = 0.0                                # half of them in a transverse plane, as profile normals
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    radius = 10.0 ** rng.uniform(-6, -0.5, n)
    reach = helical_reach(x, d, radius, v0, hand)
    assert (reach >= radius).all() and (reach <= 16 * radius).all()
    assert np.median(reach / radius) > 1.05
    # the distance from each ray point to the helix (its points within 3 reaches of x in time), sampled densely
    # and the least sample polished by Brent's method on its neighbouring interval
    ls = np.linspace(0.0, 1.0, 21)
    worst = 0.0
    for xi, di, ri, li in zip(x, d, radius, reach):
        q = xi + (ls * li)[:, None] * di
        s = np.linspace(-3 * li / v0, 3 * li / v0, 2001)
        dist = np.linalg.norm(screw_motion(xi, s, v0, hand)[None] - q[:, None], axis=2)
        for j, k in enumerate(np.argmin(dist, axis=1)):
            lo, hi = s[max(k - 1, 0)], s[min(k + 1, len(s) - 1)]
            res = minimize_scalar(lambda t: np.linalg.norm(screw_motion(xi, t, v0, hand) - q[j]), bounds=(lo, hi),
                                  method="bounded", options={"xatol": 1e-14 * (1 + abs(lo))})
            worst = max(worst, (min(dist[j, k], res.fun) - ri) / ri)
    assert worst <= 1e-9, worst
    # along the helix itself the tube reaches far: the ray x + l u / |u| at most 16 radii, limited by the bends
    h = hand_sign(hand)
    u = np.c_[-h * x[:, 1], h * x[:, 0], np.full(n, v0)]
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    along = helical_reach(x, u, np.full(n, 1e-4), v0, hand)
    assert np.median(along) > 10 * 1e-4


@pytest.mark.parametrize("hand", ["right", "left"])
@pytest.mark.parametrize("oblique", [False, True])
def test_deviation_matches_brute_force_on_random_cone_poses(hand, oblique):
    """Rays along the profile normals (radial here), and turned up to 0.9 rad off them: those cross the swept
    surface at a slant, where the march steps by the helical reach rather than the distance."""
    rng = np.random.default_rng((11 if hand == "right" else 12) + 10 * oblique)
    v0 = 0.45
    errors = []
    for _ in range(5):
        c1 = np.r_[rng.uniform(0.5, 0.7), rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1)]
        c2 = c1 + np.r_[rng.uniform(0.1, 0.3), rng.uniform(-0.2, 0.2), rng.uniform(0.2, 0.4)]
        r1, r2 = rng.uniform(0.04, 0.08), rng.uniform(0.09, 0.15)
        tool = StripTool(c1, c2, [r1, r2])
        # design points around the swept region, normals pointing roughly at it
        ang = rng.uniform(-0.6, 0.6, 6)
        rad = rng.uniform(0.35, 0.6, 6)
        pts = np.c_[rad * np.cos(ang), rad * np.sin(ang)]
        turn = ang + (rng.uniform(-0.9, 0.9, 6) if oblique else 0.0)
        nrm = np.c_[np.cos(turn), np.sin(turn)]
        dev = machined_deviation([tool], pts, nrm, v0, hand, max_deviation=1.0)
        for p, n, d in zip(pts, nrm, dev):
            ref = brute_deviation(p, n, c1, r1, c2, r2, v0, hand)
            assert np.isfinite(ref) == np.isfinite(d), (p, d, ref)   # both reach the surface or neither
            if np.isfinite(ref):
                errors.append(abs(d - ref))
    assert len(errors) >= 12
    assert max(errors) < 1e-7, max(errors)


def test_overcut_is_negative_and_uncut_is_inf():
    v0 = 0.5
    tool = StripTool([0.8, 0.0, 0.0], [0.8, 0.0, 0.3], [0.1, 0.1])
    # a point inside the swept region (on the tool axis at t = 0) is overcut; one far away is never reached
    dev = machined_deviation([tool], np.array([[0.8, 0.0], [-0.5, 0.0]]), np.array([[1.0, 0.0], [-1.0, 0.0]]),
                             v0, "right", max_deviation=0.3)
    assert dev[0] < 0 and np.isinf(dev[1])
    d, _ = helical_distance(tool, np.array([[0.8, 0.0, 0.0], [0.8, 0.0, 5.0]]), v0)
    assert d[0] < 0 and d[1] > 0


def test_meridian_part_is_exact_for_a_polyline_solid():
    """A rectangle meridian is a flat-ended cylinder; a trapezoid one a flat-ended cone frustum."""
    from flank_addon.simulation.sweep import MeridianPart, sd_cylinder

    rng = np.random.default_rng(5)
    o, axis = np.array([0.2, -0.1, 0.3]), np.array([1.0, 2.0, 0.5])
    a = axis / np.linalg.norm(axis)
    cyl = MeridianPart(o, axis, [[0.0, 0.4], [1.5, 0.4]])
    q = o + rng.uniform(-1.5, 2.5, (4000, 3))
    assert np.max(np.abs(cyl.signed_distance(q) - sd_cylinder(q, o, o + 1.5 * a, 0.4))) < 1e-12
    # frustum: compare with an independent 2D polygon distance in the meridian half-plane
    mer = np.array([[-0.2, 0.1], [0.3, 0.6], [0.9, 0.6], [1.2, 0.05]])
    part = MeridianPart(o, axis, mer)
    w = q - o
    h = w @ a
    rho = np.linalg.norm(w - h[:, None] * a, axis=1)
    poly = np.vstack([[mer[0, 0], 0.0], mer, [mer[-1, 0], 0.0]])
    P = np.c_[h, rho]
    best = np.full(len(q), np.inf)
    for i in range(len(poly) - 1):       # the axis itself is not boundary
        s0, s1 = poly[i], poly[i + 1]
        e = s1 - s0
        u = np.clip((P - s0) @ e / (e @ e), 0, 1)
        best = np.minimum(best, np.linalg.norm(P - s0 - u[:, None] * e, axis=1))
    inside = (h >= mer[0, 0]) & (h <= mer[-1, 0]) & (rho <= np.interp(h, mer[:, 0], mer[:, 1]))
    assert np.max(np.abs(part.signed_distance(q) - np.where(inside, -best, best))) < 1e-12


def test_meridian_tool_deviation_matches_dense_point_in_solid_brute_force():
    """Meridian (flat-ended cone) tool, left hand: the root of the simulation is where a dense
    point-in-solid sweep (fine t, points along the ray) first finds removed material."""
    from flank_addon.simulation.sweep import MeridianPart, RevolvingTool

    v0, hand = 0.45, "left"
    c1 = np.array([0.62, 0.05, -0.05])
    axis = np.array([0.2, 0.1, 0.35])
    L = np.linalg.norm(axis)
    a = axis / L
    tool = RevolvingTool([MeridianPart(c1, axis, [[0.0, 0.07], [L, 0.12]])])
    rng = np.random.default_rng(21)
    ang = rng.uniform(-0.5, 0.5, 12)
    rad = rng.uniform(0.4, 0.7, 12)
    pts = np.c_[rad * np.cos(ang), rad * np.sin(ang)]
    nrm = np.c_[np.cos(ang), np.sin(ang)]
    dev = machined_deviation([tool], pts, nrm, v0, hand, max_deviation=1.0)
    t = np.linspace(-2.5, 2.5, 20001)

    def removed(q):
        S = screw_motion(np.broadcast_to(q, (len(t), 3)), t, v0, hand)
        h = (S - c1) @ a
        rho = np.linalg.norm(S - c1 - h[:, None] * a, axis=1)
        return bool(((h >= 0) & (h <= L) & (rho <= 0.07 + 0.05 * h / L)).any())

    checked = 0
    for p, n, d in zip(pts, nrm, dev):
        if not np.isfinite(d):
            continue
        checked += 1
        assert not removed(np.r_[p + (d - 2e-4) * n, 0.0])    # material just below the surface
        assert removed(np.r_[p + (d + 2e-4) * n, 0.0])        # cut just above it
    assert checked >= 8 and (dev < 0).sum() >= 2 and (dev[np.isfinite(dev)] > 0).sum() >= 2


def test_meridian_part_is_exact_with_clustered_vertices():
    """Tiny segments next to long ones (e.g. a graded tool tip): the nearest vertices need not touch
    the nearest edge; the distance must still be exact."""
    from flank_addon.simulation.sweep import MeridianPart

    h = np.r_[np.linspace(0.0, 0.01, 60), 0.5, 1.0]
    r = np.r_[0.02 + 0.3 * h[:60], 0.4, 0.05]
    mer = np.c_[h, r]
    part = MeridianPart([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], mer, spacing=0.2)
    rng = np.random.default_rng(9)
    q = np.c_[rng.uniform(-0.3, 0.3, (5000, 2)), rng.uniform(-0.2, 1.2, 5000)]
    P = np.c_[q[:, 2], np.hypot(q[:, 0], q[:, 1])]
    poly = np.vstack([[h[0], 0.0], mer, [h[-1], 0.0]])
    # independent reference: dense points on every boundary edge
    dense = np.vstack([poly[i] + np.linspace(0, 1, 4001)[:, None] * (poly[i + 1] - poly[i])
                       for i in range(len(poly) - 1)])
    from scipy.spatial import cKDTree
    ref, _ = cKDTree(dense).query(P)
    d = part.signed_distance(q)
    assert np.max(np.abs(np.abs(d) - ref)) < 2e-4      # reference spacing <= 1.3e-4
    assert np.all(np.abs(d) <= ref + 1e-12)             # never worse than any boundary sample


def test_cutoff_sees_helices_through_the_end_caps_only():
    """A helix that meets only a rounded end cap of a frustum (beyond the sphere centres) must not
    be pruned by the bounding spheres when a cutoff is given (it was: the cutoff came back)."""
    import numpy as np
    from flank_addon.simulation.sweep import StripTool, helical_distance

    tool = StripTool([0.5, 0.0, 0.0], [0.5, 0.3, 0.0], [0.05, 0.08])
    pts = np.array([[0.5, 0.379, 0.0], [0.5, -0.045, 0.0]])     # inside the top / tip caps only
    for v0 in (5.0, 50.0):
        free, _ = helical_distance(tool, pts, v0)
        cut, _ = helical_distance(tool, pts, v0, cutoff=1e-3)
        assert np.all(free < 0)
        np.testing.assert_allclose(cut, free, atol=1e-12)


def test_the_lower_of_two_close_minima_along_the_helix_is_found():
    """A long tool almost parallel to the rotor axis: each helix passes it twice, one turn apart, and the two
    closest approaches differ by less than the time samples resolve.  The distance must be the lower one
    (brute force: 20,001 samples over the tool's z range, then two rounds of 2,001 around every local
    minimum).  Refining only the least sample's neighbourhood answered the other pass for about 45% of
    these points, up to 1.3e-5 too far."""
    v0 = 0.3
    tool = StripTool((1.0, 0.0, -0.4), (1.0 + 1e-6, 0.0, 3.2), [0.05, 0.05])
    rng = np.random.default_rng(7)
    n = 60
    rho, th = 1.0 + rng.uniform(0.055, 0.09, n), rng.uniform(-np.pi, np.pi, n)
    x = np.c_[rho * np.cos(th), rho * np.sin(th), np.zeros(n)]
    d, t = helical_distance(tool, x, v0)
    for i in range(n):
        ts = np.linspace(-0.5 / v0, 3.3 / v0, 20001)
        sd = tool.signed_distance(screw_motion(x[i][None], ts, v0))
        best = np.inf
        for j in np.flatnonzero((sd[1:-1] <= sd[:-2]) & (sd[1:-1] <= sd[2:])) + 1:
            lo, hi = ts[j - 1], ts[j + 1]
            for _ in range(2):
                tt = np.linspace(lo, hi, 2001)
                s2 = tool.signed_distance(screw_motion(x[i][None], tt, v0))
                k = int(np.argmin(s2))
                lo, hi = tt[max(k - 1, 0)], tt[min(k + 1, 2000)]
            best = min(best, float(s2[k]))
        assert d[i] <= best + 1e-12 and d[i] >= best - 1e-9
        assert tool.signed_distance(screw_motion(x[i][None], t[i], v0))[0] == pytest.approx(d[i], abs=1e-15)


@pytest.mark.parametrize("shape", ["kink", "smooth", "linear"])
def test_the_last_crossings_are_found_to_the_tolerance_in_few_calls(monkeypatch, shape):
    """The open crossings, a few at a time, are cut into parts (and at the secant's point) and found to the
    tolerance: on a kink at the root (slopes 1 and 1/40, where secant steps only creep) in far fewer calls than
    Illinois alone needs, where D is smooth or linear in about as many; many at once go by Illinois."""
    from flank_addon.simulation import sweep

    def solve(rows, few, flip=False):
        monkeypatch.setattr(sweep, "FEW_CROSSINGS", few)
        root = np.random.default_rng(rows).uniform(0.1, 0.9, rows)
        calls = []

        def D(lam, idx, bound):
            calls.append(len(lam))
            x = lam - root[idx]
            if shape == "kink":
                f = np.where(x < 0, -x, -x / 40.0)       # + before the crossing, - after; 1-Lipschitz as D is
            elif shape == "smooth":
                f = -0.5 * np.sin(x) - 0.3 * x * x
            else:
                f = -0.7 * x
            assert (np.abs(f) <= bound + 1e-15).all()    # the bound handed on holds
            return f

        lo, hi = np.full(rows, 0.05), np.full(rows, 0.95)
        if flip:                                        # a bracket's ends come in either order
            lo, hi = hi, lo
        f_lo, f_hi = D(lo, np.arange(rows), np.full(rows, 1e9)), D(hi, np.arange(rows), np.full(rows, 1e9))
        calls.clear()
        r = sweep.illinois_roots(D, lo, hi, f_lo, f_hi, np.ones(rows, bool), 1e-12, 0.0, 1e9)
        # a crossing stops when the secant puts it within tol / 2 of the bracket's end; on the kink the secant
        # is off by up to the slopes' ratio: 40 * tol / 2
        assert np.abs(r - root).max() <= 20e-12, (rows, few, np.abs(r - root).max())
        return calls

    few = sweep.FEW_CROSSINGS
    for rows in (1, few):
        for flip in (False, True):
            split, illinois = solve(rows, few, flip), solve(rows, 0, flip)
            assert max(split) <= sweep.SPLIT_POINTS, split
            if shape == "kink":
                assert len(split) < 0.4 * len(illinois), (rows, split, illinois)
            else:
                assert len(split) <= len(illinois) + 1, (rows, split, illinois)
    many = solve(3 * few, few)
    assert many[0] == 3 * few                           # Illinois: one point per open crossing


@pytest.mark.parametrize("hand", ["right", "left"])
def test_the_helical_march_finds_the_crossings_that_the_march_by_balls_finds(monkeypatch, hand):
    """Thin tools (radii 4-6 thousandths), 3D points off the plane z = 0 and rays close to the tangent of the
    mirrored helix (where a step with the wrong hand would be too long): the march by the helix's tube gives the
    deviations of the march by balls alone (the classic sphere tracing), the same first crossings.  A reach with
    the hand flipped jumps over the thin swept sheet on some of these rays."""
    from flank_addon.simulation import sweep

    h = hand_sign(hand)
    rng = np.random.default_rng(3 if hand == "right" else 4)
    ball_only = lambda points, directions, radius, v0, handedness="right", most=16.0: radius   # noqa: E731
    worst, reached, longer = 0.0, 0, 0
    for _ in range(6):
        v0 = rng.uniform(0.05, 0.3)
        c1 = np.r_[rng.uniform(0.5, 0.7), rng.uniform(-0.1, 0.1), 0.0]
        c2 = c1 + np.r_[rng.uniform(-0.05, 0.05), rng.uniform(-0.05, 0.05), rng.uniform(0.05, 0.2)]
        tool = StripTool(c1, c2, [0.004, 0.006])
        n = 60
        rad, ang = rng.uniform(0.3, 0.9, n), rng.uniform(-np.pi, np.pi, n)
        p = np.c_[rad * np.cos(ang), rad * np.sin(ang), rng.uniform(-0.3, 0.3, n)]
        d = np.c_[h * p[:, 1], -h * p[:, 0], np.full(n, v0)] + 0.3 * rng.normal(size=(n, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        new = machined_deviation([tool], p, d, v0, hand, max_deviation=0.5)
        monkeypatch.setattr(sweep, "helical_reach", ball_only)
        old = machined_deviation([tool], p, d, v0, hand, max_deviation=0.5)
        monkeypatch.undo()
        assert np.array_equal(np.isfinite(new), np.isfinite(old))
        fin = np.isfinite(new)
        worst = max(worst, float(np.abs(new[fin] - old[fin]).max(initial=0.0)))
        reached += int(fin.sum())
        longer += int((helical_reach(p, d, np.full(n, 0.01), v0, hand) > 0.0105).sum())
    assert worst < 1e-9 and reached > 15 and longer > 100, (worst, reached, longer)


def test_grid_bounds_hold_the_exact_distances_and_measure_only_the_cells_asked_for():
    """The signed-distance grid that prunes time samples is measured node by node as cells are asked for: the
    bounds must be those of the whole grid measured at once (bit for bit, in any order of the queries), hold
    the exact signed distances, and leave the nodes of cells never asked for unmeasured."""
    from flank_addon.simulation.sweep import MeridianPart

    rng = np.random.default_rng(17)
    h = np.linspace(0.0, 1.0, 3001)
    mer = np.c_[h, 0.1 + 0.05 * np.sin(7 * h) + 0.2 * h]
    part = MeridianPart([0.1, 0.2, 0.0], [0.3, 0.1, 1.0], mer)
    P = np.c_[rng.uniform(-0.2, 1.2, 6000), rng.uniform(0.0, 0.6, 6000)]
    P[:1000] = np.c_[rng.uniform(0.4, 0.5, 1000), rng.uniform(0.15, 0.3, 1000)]     # a patch asked for first
    low, high = part._grid_bounds(P[:1000])
    lo, g, n, sd = part._grid
    assert 0 < np.isfinite(sd).sum() < 0.05 * len(sd)
    bounds = [(low, high)] + [part._grid_bounds(P[k:k + 700]) for k in range(1000, 6000, 700)]
    low, high = (np.concatenate(b) for b in zip(*bounds))
    # the reference: every node at once
    i, j = np.divmod(np.arange(len(sd)), n[1])
    nodes = np.c_[lo[0] + g * i.astype(float), lo[1] + g * j.astype(float)]
    d, _ = part.polyline.distance(nodes)
    every = np.where(nodes[:, 1] <= part.radius_at(nodes[:, 0]), -d, d)
    known = np.isfinite(sd)
    np.testing.assert_array_equal(sd[known], every[known])
    f = (P - lo) / g
    c = np.floor(f).astype(int)
    inside = (c[:, 0] >= 0) & (c[:, 1] >= 0) & (c[:, 0] < n[0] - 1) & (c[:, 1] < n[1] - 1)
    ref_low, ref_high = np.full(len(P), -np.inf), np.full(len(P), np.inf)
    for a in (0, 1):
        for b in (0, 1):
            v = every[(c[inside, 0] + a) * n[1] + c[inside, 1] + b]
            r = g * np.hypot(f[inside, 0] - c[inside, 0] - a, f[inside, 1] - c[inside, 1] - b) * (1 + 1e-12)
            ref_low[inside] = np.maximum(ref_low[inside], v - r)
            ref_high[inside] = np.minimum(ref_high[inside], v + r)
    slack = 1e-12 * part.polyline.scale
    np.testing.assert_array_equal(low[inside], ref_low[inside] - slack)
    np.testing.assert_array_equal(high[inside], ref_high[inside] + slack)
    assert np.all(np.isinf(low[~inside])) and np.all(np.isinf(high[~inside])) and inside.mean() > 0.9
    exact = part.sd_plane(P[:, 0], P[:, 1])[0]
    assert np.all(low <= exact) and np.all(exact <= high)
    assert not known.all()                     # cells no query fell in stay unmeasured


def test_grid_bounds_of_a_call_read_the_grid_it_measured_into():
    """Two threads that ask a new meridian part at once may both set up its grid; each call must then read the
    nodes from the grid it measured them into (it did not: the second grid replaced the first in between, and
    the first call's bounds came out NaN, so the tool looked absent).  The interleaving is forced here: while
    the first call measures its nodes, a second call sets up the grid anew."""
    from flank_addon.simulation.sweep import MeridianPart

    h = np.linspace(0.0, 1.0, 500)
    part = MeridianPart([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], np.c_[h, 0.2 + 0.1 * h])
    P = np.c_[np.linspace(-0.1, 1.1, 200), np.linspace(0.0, 0.5, 200)]
    reference = MeridianPart([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], np.c_[h, 0.2 + 0.1 * h])._grid_bounds(P)
    measure = part._measure_nodes
    calls = []

    def interleaved(*args):
        if not calls:
            calls.append(1)
            part._grid = None                   # as if another thread had set it up at the same moment
            part._grid_bounds(P[:7])
        return measure(*args)

    part._measure_nodes = interleaved
    low, high = part._grid_bounds(P)
    assert calls and not np.isnan(low).any() and not np.isnan(high).any()
    np.testing.assert_array_equal(low, reference[0])
    np.testing.assert_array_equal(high, reference[1])


@pytest.mark.parametrize("stacked", [False, True])
def test_cheap_tools_measure_only_the_samples_the_search_uses(monkeypatch, stacked):
    """Frustum tools (cheap distances) no longer have every time sample measured, only those within half a
    chord of the least, with their neighbours (and, without times, none beyond the cap of points that answer
    the cutoff).  The answers must be those of measuring every sample: distances, times, cutoffs, on cones with
    sharp tips (4,001 samples per helix) and on the long tool a helix passes twice, with and without a cutoff."""
    from flank_addon.simulation import sweep

    def every_sample(tool, x, time_of, n, v0, handedness, cap=None):
        r, c = np.repeat(np.arange(len(x)), n), np.tile(np.arange(n), len(x))
        v = tool.rows(r).signed_distance(screw_motion(x[r], time_of(r, c), v0, handedness))
        return sweep._Samples(r, c, v, n)

    rng = np.random.default_rng(31)
    v0 = 0.45
    sharp = [StripTool(c, c + rng.uniform([0.1, -0.2, 0.2], [0.3, 0.2, 0.4]), [0.0, rng.uniform(0.05, 0.12)],
                       c + [0.0, 0.0, 0.5], c + [0.0, 0.0, 0.9], 0.04)
             for c in rng.uniform([0.55, -0.1, -0.1], [0.7, 0.1, 0.1], (3, 3))]
    twice = StripTool((1.0, 0.0, -0.4), (1.0 + 1e-6, 0.0, 3.2), [0.05, 0.05])
    th = rng.uniform(-0.7, 0.7, 40)
    rho = rng.uniform(0.45, 0.75, 40)
    x = np.c_[rho * np.cos(th), rho * np.sin(th), rng.uniform(-0.05, 0.05, 40)]
    rho2, th2 = 1.0 + rng.uniform(0.055, 0.09, 20), rng.uniform(-np.pi, np.pi, 20)
    x2 = np.c_[rho2 * np.cos(th2), rho2 * np.sin(th2), np.zeros(20)]
    cases = [(sharp, x), ([twice], x2)]
    measured = []
    real = sweep._near_least_samples

    def counting(tool, xx, time_of, n, *args):
        samples = real(tool, xx, time_of, n, *args)
        measured.append((len(samples.r), len(xx) * n))
        return samples

    for tools, pts in cases:
        for cutoff in (np.inf, 0.02, 0.0):
            for times in (True, False):
                if stacked and len(tools) > 1:
                    which = np.repeat(np.arange(len(tools)), len(pts))
                    tool, q = sweep.StackedTools(tools).rows(which), np.tile(pts, (len(tools), 1))
                else:
                    tool, q = tools[0], pts
                monkeypatch.setattr(sweep, "_near_least_samples", counting)
                d, t = helical_distance(tool, q, v0, cutoff=cutoff, times=times)
                monkeypatch.setattr(sweep, "_near_least_samples", every_sample)
                d_all, t_all = helical_distance(tool, q, v0, cutoff=cutoff, times=times)
                np.testing.assert_allclose(d, d_all, rtol=0, atol=1e-15)
                if times:
                    np.testing.assert_array_equal(np.isnan(t), np.isnan(t_all))
                    np.testing.assert_allclose(t[~np.isnan(t)], t_all[~np.isnan(t_all)], rtol=0, atol=1e-12)
    done, total = np.sum(measured, axis=0)
    assert done < 0.25 * total


@pytest.mark.parametrize("capped", [False, True])
def test_near_least_samples_keeps_every_sample_within_half_a_chord_and_its_neighbours(capped):
    """The contract of the pruned sampling, against every sample measured: on helices past unions of balls (a
    1-Lipschitz distance whose value changes at nearly the full speed of the point away from its minima, so the
    gap bounds are nearly tight, and whose several minima along a helix come close to each other), every
    sample within half a chord of its row's least value is measured with its exact value, and so are both its
    neighbours; with a cap, that holds on the rows whose least value lies below their cap, and a row above its
    cap has nothing measured below it."""
    from flank_addon.simulation.sweep import _near_least_samples

    class Balls:
        def __init__(self, centres, radii):
            self.centres, self.radii = centres, radii

        def rows(self, idx):
            return self

        def signed_distance(self, q):
            return np.min(np.linalg.norm(q[:, None, :] - self.centres[None], axis=2) - self.radii[None], axis=1)

    rng = np.random.default_rng(41)
    v0, hand = 0.3, "left"
    kept_pairs, measured, total = 0, 0, 0
    for trial in range(12):
        t_ball = rng.uniform(-2.0, 2.0, 6)
        r_ball = rng.uniform(0.6, 0.9, 6)
        centres = np.c_[r_ball * np.cos(-t_ball), r_ball * np.sin(-t_ball), v0 * t_ball + rng.uniform(-0.02, 0.02, 6)]
        tool = Balls(centres, rng.uniform(0.01, 0.05, 6))
        N, n = 30, int(rng.choice([9, 70, 257, 1500, 4001]))
        x = np.c_[rng.uniform(0.55, 0.95, N), np.zeros(N), rng.uniform(-0.05, 0.05, N)]
        T = np.linspace(-2.5, 2.5, n)[None, :] + rng.uniform(-0.01, 0.01, (N, 1))
        full = tool.signed_distance(screw_motion(np.repeat(x, n, axis=0), T.ravel(), v0, hand)).reshape(N, n)
        chord = np.linalg.norm(screw_motion(x, T[:, 1], v0, hand) - screw_motion(x, T[:, 0], v0, hand), axis=1)
        least = full.min(axis=1)
        cap = least + rng.uniform(-0.05, 0.05, N) if capped else None
        samples = _near_least_samples(tool, x, lambda r, c: T[r, c], n, v0, hand, cap)
        D = np.full((N, n), np.inf)
        D[samples.r, samples.c] = samples.v
        assert np.all(np.diff(samples.r * n + samples.c) > 0)         # sorted, each sample once
        seen = np.isfinite(D)
        np.testing.assert_array_equal(D[seen], full[seen])
        rows = np.arange(N) if cap is None else np.flatnonzero(least < cap)
        near = full[rows] <= (least[rows] + 0.5 * chord[rows])[:, None]
        beside = near.copy()
        beside[:, 1:] |= near[:, :-1]
        beside[:, :-1] |= near[:, 1:]
        assert seen[rows][beside].all(), (trial, n)
        kept_pairs += int((near.sum(axis=1) > 1).sum())
        measured, total = measured + seen.sum(), total + seen.size
        if capped:
            above = np.flatnonzero(least >= cap)
            assert np.all(np.where(seen[above], D[above], np.inf).min(axis=1) >= cap[above])
    assert kept_pairs > 50            # rows with more than one sample that close to their least value
    assert measured < 0.5 * total


def test_sparse_samples_answer_as_the_dense_array_does():
    """The measured samples kept sparse (rows, columns, values): the least sample of each row and the lookups
    are those of the dense array with +inf elsewhere, under np.argmin's rules (the first of equal values, the
    first NaN, column 0 for a row with nothing measured); a selection of rows is renumbered."""
    from flank_addon.simulation.sweep import _Samples

    rng = np.random.default_rng(3)
    N, n = 40, 25
    D = np.full((N, n), np.inf)
    seen = rng.random((N, n)) < 0.3
    D[seen] = rng.integers(0, 4, seen.sum()).astype(float)          # many ties
    D[5, [3, 9]] = np.nan
    D[7] = np.inf                                                  # nothing measured
    D[8, 0] = -np.inf
    r, c = np.nonzero(~(D == np.inf))
    samples = _Samples(r, c, D[r, c], n)
    k, best = samples.least(N)
    np.testing.assert_array_equal(k, np.argmin(D, axis=1))
    np.testing.assert_array_equal(best, D[np.arange(N), np.argmin(D, axis=1)])
    qr, qc = rng.integers(0, N, 500), rng.integers(0, n, 500)
    np.testing.assert_array_equal(samples.at(qr, qc), D[qr, qc])
    keep = np.array([1, 5, 7, 8, 30])
    sub = samples.rows(keep)
    D2 = np.full((len(keep), n), np.inf)
    D2[sub.r, sub.c] = sub.v
    np.testing.assert_array_equal(D2, D[keep])
    empty = _Samples(np.zeros(0, int), np.zeros(0, int), np.zeros(0), n)
    assert empty.least(3)[0].tolist() == [0, 0, 0] and np.isinf(empty.at([0, 2], [1, 1])).all()
