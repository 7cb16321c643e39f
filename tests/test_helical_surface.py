import numpy as np
import pytest

from flank_addon.geometry.helical_surface import HelicalSurface
from flank_addon.geometry.profile import SplineProfile
from flank_addon.geometry.screw import screw_motion, screw_to_plane, screw_velocity
from helpers import half_disk_profile, wavy_profile


def brute_force_distance(surface, points, n_u=3000, n_t=1200):
    """Unsigned distance by dense sampling: the same n_u x n_t samples S_t(p(u)) as the 3D-tree brute force the
    other test modules import (profile parameters x screw parameters over the same range), measured by turning
    the query instead of the samples.  With the query screwed into z = 0, |S_t(p) - q0|^2 = |p - R(-t) q0|^2 + (v0 t)^2:
    one 2D tree of the profile samples serves every t, and the t are taken by increasing |t| until (v0 t)^2
    exceeds every query's best (no farther sample can be nearer).  Agrees with the 3D-tree version to 1e-15, in
    a quarter of the time (the tree without compacted nodes prunes more for queries far from the profile)."""
    from scipy.spatial import cKDTree

    q0 = screw_to_plane(np.atleast_2d(points), surface.v0, surface.hand)
    tree = cKDTree(surface.profile.eval(surface.profile.params(n_u)), balanced_tree=False, compact_nodes=False)
    d_plane, _ = tree.query(q0)
    tmax = np.max(d_plane) / surface.v0
    t = np.linspace(-tmax, tmax, n_t)
    best = np.full(len(q0), np.inf)
    for tj in t[np.argsort(np.abs(t), kind="stable")]:
        z2 = (surface.v0 * tj) ** 2
        live = np.flatnonzero(best > z2)
        if not len(live):
            break
        c, s = np.cos(surface.hand * tj), np.sin(surface.hand * tj)
        qr = np.c_[c * q0[live, 0] + s * q0[live, 1], -s * q0[live, 0] + c * q0[live, 1]]
        d, _ = tree.query(qr)
        best[live] = np.minimum(best[live], d * d + z2)
    return np.sqrt(best)


def test_screw_motion_matches_eq1_both_hands():
    p = np.array([0.3, -0.7, 0.2])
    t, v0 = 0.9, 0.4
    right = screw_motion(p, t, v0, "right")
    left = screw_motion(p, t, v0, "left")
    c, s = np.cos(t), np.sin(t)
    # Bizzarri, Bo & Bartoň Eq. (1): right-handed turns by +t; left-handed is the proper motion turning by -t
    assert np.allclose(right, [p[0] * c - p[1] * s, p[0] * s + p[1] * c, t * v0 + p[2]], atol=1e-15)
    assert np.allclose(left, [p[0] * c + p[1] * s, -p[0] * s + p[1] * c, t * v0 + p[2]], atol=1e-15)
    # one full turn advances by the pitch 2*pi*v0
    full = screw_motion(p, 2 * np.pi, v0, "right")
    assert np.allclose(full[:2], p[:2]) and np.isclose(full[2] - p[2], 2 * np.pi * v0)
    # screw_to_plane lands on the same helix in z = 0
    q0 = screw_to_plane(p, v0, "left")
    back = screw_motion(np.r_[q0, 0.0], p[2] / v0, v0, "left")
    assert np.allclose(back, p, atol=1e-14)


@pytest.mark.parametrize("hand", ["right", "left"])
def test_screw_velocity_is_the_derivative_of_the_screw_and_the_general_screws(hand):
    """(-h y, h x, v0): the central difference of S_t at t = 0, and the general screw's velocity k d + d x (x - a)
    with the axis d = (0, 0, h) through the origin and k = v0 / h."""
    from flank_addon.geometry.rotor_analysis import axis_screw_velocity
    from flank_addon.geometry.screw import hand_sign

    h, v0 = hand_sign(hand), 0.37
    p = np.random.default_rng(3).normal(size=(50, 3))
    vel = screw_velocity(p, v0, h)
    dt = 1e-6
    fd = (screw_motion(p, dt, v0, hand) - screw_motion(p, -dt, v0, hand)) / (2 * dt)
    assert np.abs(vel - fd).max() < 1e-9
    assert np.abs(vel - axis_screw_velocity(p, np.array([0.0, 0.0, h]), np.zeros(3), v0 / h)).max() < 1e-15
    assert screw_velocity(p.reshape(5, 10, 3), v0, h).shape == (5, 10, 3)


def test_cylinder_distance_is_exact():
    th = np.linspace(0, 2 * np.pi, 720, endpoint=False)
    surf = HelicalSurface(SplineProfile(0.8 * np.c_[np.cos(th), np.sin(th)]), 0.3, "left")
    rng = np.random.default_rng(1)
    q = rng.uniform(-1.2, 1.2, (3000, 3))
    fp = surf.foot_points(q)
    expected = np.hypot(q[:, 0], q[:, 1]) - 0.8
    # spline through 720 circle points: radius error ~1e-11
    assert np.max(np.abs(fp.distance - expected)) < 1e-9
    assert np.array_equal(surf.contains(q), expected < 0)


# both hands (the screw's sign enters the seed table and the Newton steps) and a steep and a flat helix; the
# surface's seed table dominates the cost, so the two other combinations would only repeat these code paths
@pytest.mark.parametrize("v0, hand", [(0.25, "right"), (0.8, "left")])
def test_foot_points_never_worse_than_brute_force(hand, v0):
    surf = HelicalSurface(wavy_profile(), v0, hand)
    rng = np.random.default_rng(7)
    # queries everywhere in the rotor's cylinder, near the axis (many competing valleys) and outside
    q = np.vstack([rng.uniform(-1.1, 1.1, (1500, 3)), rng.normal(0, 0.05, (300, 3)),
                   rng.uniform(-1.6, 1.6, (200, 3))])
    fp = surf.foot_points(q)
    bf = brute_force_distance(surf, q)
    gap = np.abs(fp.distance) - bf
    assert gap.max() <= 1e-12, f"worse than brute force by {gap.max():.3g}"
    # and brute force at this density is within its sampling error of the exact value
    assert gap.min() > -3e-3
    # foot is on the surface: screwed back it lies on the profile
    foot0 = screw_to_plane(fp.point, surf.v0, surf.hand)
    assert np.allclose(foot0, surf.profile.eval(fp.u), atol=1e-12)
    # q - foot is normal to the surface (first-order optimality)
    w = q - fp.point
    nrm = np.linalg.norm(w, axis=1)
    ok = nrm > 1e-6
    cos = np.abs(np.einsum("ij,ij->i", w[ok], fp.normal[ok])) / nrm[ok]
    assert np.min(cos) > 1 - 1e-9
    # sign: negative exactly for points inside the solid
    assert np.array_equal(fp.distance < 0, surf.contains(q))


@pytest.fixture(scope="module")
def wavy():
    """The wavy profile's right-handed surface, v0 = 0.5: its foot-point seed table is built once for the tests
    below."""
    return HelicalSurface(wavy_profile(), 0.5, "right")


def test_foot_is_a_minimum_under_perturbation(wavy):
    surf = wavy
    rng = np.random.default_rng(3)
    q = rng.uniform(-1, 1, (400, 3))
    fp = surf.foot_points(q)
    d = np.abs(fp.distance)
    for du, dt in [(1e-4, 0), (-1e-4, 0), (0, 1e-4), (0, -1e-4), (3e-3, -2e-3), (-0.05, 0.05)]:
        other = np.linalg.norm(q - surf.evaluate(fp.u + du, fp.t + dt), axis=1)
        assert np.all(other >= d - 1e-13)


def test_global_not_local_minimum(wavy):
    """A query whose nearest point on its own valley is only a local minimum (Hu, Zhou & Li 2025 §3.2 failure mode)."""
    surf = wavy
    # on the axis every valley bottom is nearly equidistant; a slight offset makes one valley win
    q = np.array([[0.02, 0.0, 0.0], [0.0, 0.03, 0.4], [-0.01, -0.02, -0.7]])
    fp = surf.foot_points(q)
    bf = brute_force_distance(surf, q, n_u=6000, n_t=1500)
    assert np.all(np.abs(fp.distance) <= bf + 1e-12)


@pytest.mark.parametrize("hand", ["right", "left"])
def test_point_and_normal_are_evaluate_and_normal(hand):
    """A point and its normal, made together or apart, must be those of screw_motion and of the normal's
    definition bit for bit (the planners' warm-started feet follow every rounding), for rows, grids that
    broadcast, and parameters beyond one period."""
    surf = HelicalSurface(wavy_profile(), 0.37, hand)
    rng = np.random.default_rng(8)
    per = surf.profile.period
    cases = [(rng.uniform(-per, 2 * per, 500), rng.normal(scale=3.0, size=500)),
             (rng.uniform(0, per, (7, 1)), rng.normal(size=(1, 5))),
             (np.array([0.0, per, -0.0]), np.array([-0.0, 0.0, 1e-300]))]
    for u, t in cases:
        # the references written out from screw_motion and the normal's definition, as the surface had them
        ub, tb = np.broadcast_arrays(u, t)
        p = surf.profile.eval(ub)
        ref_point = screw_motion(np.concatenate([p, np.zeros(p.shape[:-1] + (1,))], axis=-1), tb, surf.v0, hand)
        n0 = surf._normal_at_t0(p, surf.profile.eval(ub, 1))
        c, s = np.cos(surf.hand * tb), np.sin(surf.hand * tb)
        ref_normal = np.concatenate([np.stack([c * n0[..., 0] - s * n0[..., 1], s * n0[..., 0] + c * n0[..., 1]],
                                              axis=-1), n0[..., 2:]], axis=-1)
        point, normal = surf.point_and_normal(u, t)
        for got in (point, surf.evaluate(u, t)):
            assert np.array_equal(got, ref_point) and np.array_equal(np.signbit(got), np.signbit(ref_point))
        for got in (normal, surf.normal(u, t)):
            assert np.array_equal(got, ref_normal) and np.array_equal(np.signbit(got), np.signbit(ref_normal))


def test_helicoid_and_cylinder_curvature():
    v0 = 0.4
    prof = half_disk_profile(1.0)
    surf = HelicalSurface(prof, v0, "right")
    # line part (u in (0, 2)) is a helicoid through the axis: K = -v0^2 / (rho^2 + v0^2)^2, H = 0
    u = np.linspace(0.05, 1.95, 25)
    rho = np.abs(prof.eval(u)[:, 0])
    c = surf.curvatures(u)
    assert np.allclose(c["K"], -v0 ** 2 / (rho ** 2 + v0 ** 2) ** 2, rtol=1e-12)
    assert np.allclose(c["H"], 0.0, atol=1e-12)
    assert np.all(surf.classify(u) == -1)
    # arc part is the cylinder of radius 1: K = 0, principal curvatures 0 and -1 (outward normal)
    ua = np.linspace(2.1, 2 + np.pi - 0.1, 25)
    ca = surf.curvatures(ua)
    assert np.allclose(ca["K"], 0.0, atol=1e-12)
    assert np.allclose(ca["k2"], -1.0, atol=1e-12) and np.allclose(ca["k1"], 0.0, atol=1e-12)
    assert np.all(surf.classify(ua) == 0)


def test_wavy_profile_has_elliptic_and_hyperbolic_parts():
    surf = HelicalSurface(wavy_profile(), 0.5, "right")
    cls = surf.classify(surf.profile.params(2000))
    # convex lobe tips are elliptic, concave valleys hyperbolic (Bizzarri, Bo & Bartoň Fig. 3)
    assert (cls == 1).mean() > 0.1 and (cls == -1).mean() > 0.1


def test_rejects_bad_input():
    with pytest.raises(ValueError, match="v0"):
        HelicalSurface(wavy_profile(), -1.0)
    surf = HelicalSurface(wavy_profile(), 0.5)
    with pytest.raises(ValueError, match="NaN"):
        surf.foot_points(np.array([[0.0, np.nan, 0.0]]))


def test_builtin_female_rotor_thin_lobe_tips_match_brute_force(female):
    """Queries just inside thin lobe tips, where global-foot basins are narrower than the seed table."""
    rotor, surf = female
    rng = np.random.default_rng(0)
    n = 4000
    r = surf.outer_radius * rng.uniform(0.9, 1.0, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    q = np.c_[r * np.cos(phi), r * np.sin(phi), rng.uniform(0, rotor.length, n)]
    fp = surf.foot_points(q)
    bf = brute_force_distance(surf, q, n_u=4000, n_t=600)
    gap = np.abs(fp.distance) - bf
    assert gap.max() <= 1e-12, f"worse than brute force by {gap.max():.3g}"
    assert np.array_equal(fp.distance < 0, surf.contains(q))


@pytest.mark.parametrize("hand", ["right", "left"])
def test_surface_from_meridian_contains_the_meridian(hand):
    """A closed thread-like meridian (r, z): the swept surface passes through every meridian point."""
    s = np.linspace(0, 2 * np.pi, 600, endpoint=False)
    meridian = np.c_[0.7 + 0.2 * np.cos(s), 0.25 * np.sin(s)]  # ellipse in the (r, z) half plane
    v0 = 0.3
    surf = HelicalSurface.from_meridian(meridian, v0, hand)
    on = np.c_[meridian[:, 0], np.zeros(len(s)), meridian[:, 1]]
    assert np.max(np.abs(surf.signed_distance(on))) < 1e-8
    # the meridian's interior is inside the solid, its exterior outside
    assert surf.contains(np.array([[0.7, 0.0, 0.0], [0.75, 0.0, 0.1]])).all()
    assert not surf.contains(np.array([[0.95, 0.0, 0.0], [0.7, 0.0, 0.3]])).any()
    # and the whole helical tube: the same points screwed by any t stay on the surface
    from flank_addon.geometry.screw import screw_motion
    moved = screw_motion(on[::20], 1.3, v0, hand)
    assert np.max(np.abs(surf.signed_distance(moved))) < 1e-8
