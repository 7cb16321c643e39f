"""Built-in conjugate rotor pairs: geometry, meshing (conjugate action), parameters, meshes."""
import math

import numpy as np
import pytest

from flank_addon.geometry import rotors
from flank_addon.geometry.profile import segments_intersect_count, signed_area
from flank_addon.geometry.screw import screw_to_plane

KINDS = sorted(rotors.KINDS)


@pytest.fixture(scope="module")
def pairs():
    return {k: rotors.rotor_pair(k) for k in KINDS}


def test_builtin_names():
    assert set(rotors.BUILTIN_NAMES) == {f"{k}-{p}" for k in ("nilson", "srm_a", "asymmetric")
                                        for p in ("male", "female")}
    r = rotors.builtin_by_name("asymmetric-female", scale=2.0)
    assert (r.kind, r.part, r.lobes) == ("asymmetric", "female", 6)
    with pytest.raises(ValueError, match="unknown built-in rotor"):
        rotors.builtin_by_name("asymmetric-middle")
    with pytest.raises(ValueError, match="unknown rotor kind"):
        rotors.builtin_rotor("gerotor", "male")


@pytest.mark.parametrize("name", rotors.BUILTIN_NAMES)
def test_profile_closed_simple_ccw_outer_radius(name):
    r = rotors.builtin_by_name(name)
    prof = r.profile
    assert r.lobes == (4 if r.part == "male" else 6)
    assert np.allclose(prof.eval(0.0), prof.eval(prof.period), atol=1e-12)  # closed
    poly = prof.sample(3000)
    assert signed_area(poly) > 0  # CCW
    assert segments_intersect_count(poly) == 0  # simple
    rad = np.linalg.norm(prof.sample(20000), axis=1)
    assert abs(rad.max() - 1.0) < 1e-6  # outer radius == scale
    # tips are points of maximal radius, bottoms of minimal radius
    assert np.allclose(np.linalg.norm(prof.eval(r.tip_params), axis=1), 1.0, atol=1e-9)
    assert np.allclose(np.linalg.norm(prof.eval(r.bottom_params), axis=1), rad.min(), atol=1e-6)
    # the spline through the exact conjugate points is far below 1e-6 R off
    assert rotors.spline_error(r.kind, r.part, n_check=2000) < 1e-7


@pytest.mark.parametrize("name", ["nilson-male", "srm_a-female"])
def test_flanks_cover_both_sides_of_every_valley(name):
    r = rotors.builtin_by_name(name, scale=1.7)
    fl = np.asarray(r.flanks)
    assert fl.shape == (2 * r.lobes, 2)
    assert fl[0, 0] == 0.0 and abs(fl[-1, 1] - r.profile.period) < 1e-12
    assert np.all(fl[:, 1] > fl[:, 0])
    assert np.allclose(fl[1:, 0], fl[:-1, 1])  # contiguous
    rad = lambda u: np.linalg.norm(r.profile.eval(u), axis=-1)  # noqa: E731
    for a, b in fl:
        inner = rad(np.linspace(a, b, 400)[1:-1])
        assert inner.max() <= max(rad(a), rad(b)) + 1e-9
        assert inner.min() >= min(rad(a), rad(b)) - 1e-9
        # each flank runs between a tip (radius = scale) and a valley bottom
        assert abs(max(rad(a), rad(b)) - 1.7) < 1e-9


@pytest.mark.parametrize("kind", KINDS)
def test_conjugate_action(pairs, kind):
    male, female, A = pairs[kind]
    res = rotors.meshing_clearance(male, female, A, n_steps=48, n_samples=1500)
    # they touch in every position of a meshing cycle ...
    assert res["max_gap"] <= 1e-6
    # ... and never interfere
    assert res["max_interference"] <= 1e-6
    assert len(res["clearance"]) == 48


def test_conjugacy_check_detects_wrong_phase_and_distance(pairs):
    male, female, A = pairs["asymmetric"]
    wrong_phase = rotors.meshing_clearance(male, female, A, n_steps=12, n_samples=1500, phase=0.01)
    assert wrong_phase["max_interference"] > 1e-3
    too_far = rotors.meshing_clearance(male, female, A + 0.01, n_steps=12, n_samples=1500)
    assert too_far["max_gap"] > 5e-3


def test_pair_scale_and_centre_distance():
    m1, f1, a1 = rotors.rotor_pair("srm_a")
    m2, f2, a2 = rotors.rotor_pair("srm_a", scale=2.5)
    assert a1 == pytest.approx(1.5625) and a2 == pytest.approx(2.5 * 1.5625)
    assert m2.profile.outer_radius() == pytest.approx(2.5, abs=1e-6)
    assert f2.profile.outer_radius() == pytest.approx(2.5, abs=1e-6)
    assert np.allclose(m2.profile.sample(500), 2.5 * m1.profile.sample(500), atol=1e-12)
    assert m2.length == pytest.approx(2.5 * m1.length)
    res = rotors.meshing_clearance(m2, f2, a2, n_steps=16, n_samples=1500)
    assert res["max_gap"] <= 2.5e-6 and res["max_interference"] <= 2.5e-6


def test_lead_and_handedness_defaults_and_overrides():
    m, f, _ = rotors.rotor_pair("nilson")
    assert (m.handedness, f.handedness) == ("right", "left")
    assert m.length == pytest.approx(3.2)
    assert m.lead == pytest.approx(3.2 * 360 / 300)  # 300 degree wrap
    assert m.v0 == pytest.approx(m.lead / (2 * math.pi))
    assert f.lead == pytest.approx(m.lead * 6 / 4)  # consistent with the gear ratio
    # female alone gets the same defaults as in the pair
    fa = rotors.builtin_rotor("nilson", "female")
    assert (fa.lead, fa.handedness) == (pytest.approx(f.lead), "left")
    m2, f2, _ = rotors.rotor_pair("nilson", lead=5.0, length=2.0, male_handedness="left")
    assert (m2.handedness, f2.handedness) == ("left", "right")
    assert m2.v0 == pytest.approx(5.0 / (2 * math.pi)) and f2.lead == pytest.approx(7.5)
    assert m2.length == 2.0 and f2.length == 2.0
    r = rotors.builtin_rotor("srm_a", "male", lead=-4.0)
    assert r.handedness == "left" and r.lead == 4.0
    with pytest.raises(ValueError):
        rotors.builtin_rotor("srm_a", "male", scale=-1.0)
    with pytest.raises(ValueError):
        rotors.builtin_rotor("srm_a", "male", handedness="up")


def _edge_check(faces):
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    directed = {tuple(x) for x in e.tolist()}
    assert len(directed) == len(e), "a directed edge repeats: inconsistent orientation"
    for a, b in directed:
        assert (b, a) in directed, "boundary edge: mesh not closed"


def _volume(v, f):
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    return float(np.sum(np.einsum("ij,ij->i", a, np.cross(b, c)))) / 6.0


@pytest.mark.parametrize("name", ["asymmetric-male", "nilson-female"])
def test_mesh_closed_outward_and_on_the_helical_surface(name):
    r = rotors.builtin_by_name(name, scale=1.3, length=2.0)
    v, f = r.mesh(n_profile=300, n_axial=40)
    assert v.shape[1] == 3 and f.shape[1] == 3 and f.dtype.kind == "i"
    _edge_check(f)
    assert v[:, 2].min() == pytest.approx(0.0) and v[:, 2].max() == pytest.approx(2.0)
    area = signed_area(r.profile.sample(300))
    assert _volume(v, f) == pytest.approx(area * 2.0, rel=2e-3)  # positive: outward
    # every side vertex screws back onto the profile (Bizzarri, Bo & Bartoň Eq. 1)
    side = v[np.linalg.norm(v[:, :2], axis=1) > 0.3]
    back = screw_to_plane(side, r.v0, r.handedness)
    prof = r.profile.sample(300)
    d = np.min(np.linalg.norm(back[:, None, :] - prof[None, ::1, :], axis=2), axis=1)
    assert d.max() < 1e-9
    # wrong hand would not map back
    back_wrong = screw_to_plane(side[-200:], r.v0, "left" if r.handedness == "right" else "right")
    dw = np.min(np.linalg.norm(back_wrong[:, None, :] - prof[None], axis=2), axis=1)
    assert dw.max() > 1e-3


def test_mesh_fine_edge_length_is_fast_and_closed():
    r = rotors.builtin_by_name("srm_a-male")
    per = r.profile.period
    n = int(per / 1e-3)
    v, f = r.mesh(n_profile=n, n_axial=3)
    ring = v[:n]
    edge = np.linalg.norm(np.diff(ring, axis=0), axis=1)
    assert edge.max() < 1.2e-3 and edge.min() > 0.8e-3
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    assert np.all(counts == 2)


def test_triangulate_non_star_polygon():
    # a C-shaped polygon is not star-shaped from the origin: ear clipping path
    t = np.linspace(0.3, 2 * np.pi - 0.3, 60)
    outer = np.c_[np.cos(t), np.sin(t)]
    inner = 0.5 * np.c_[np.cos(t[::-1]), np.sin(t[::-1])]
    poly = np.vstack([outer, inner])
    tri = rotors.triangulate_polygon(poly)
    assert len(tri) == len(poly) - 2
    p = poly[tri]
    areas = 0.5 * ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                   - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0]))
    assert np.all(areas > 0)
    assert areas.sum() == pytest.approx(signed_area(poly), rel=1e-12)


def test_surface_is_helical_surface_of_the_rotor():
    hs = pytest.importorskip("flank_addon.geometry.helical_surface")
    r = rotors.builtin_rotor("nilson", "male")
    s = r.surface()
    assert isinstance(s, hs.HelicalSurface)
    np.testing.assert_array_equal(s.profile.points, r.profile.points)
    assert (s.v0, s.handedness) == (r.v0, r.handedness)
    # an equal rotor gets the same surface object (its foot-point table is built once), another one does not
    assert rotors.builtin_rotor("nilson", "male").surface() is s
    assert rotors.builtin_rotor("nilson", "female").surface() is not s


# --------------------------------------------------------------------------- nilson: male of four arcs

def _on_arc(pts, arc, tol_ang=1e-9):
    """Mask of points whose polar angle about the arc centre lies in the arc's angle range."""
    a0, a1 = arc["angles"]
    lo, hi = min(a0, a1), max(a0, a1)
    ang = np.arctan2(pts[:, 1] - arc["centre"][1], pts[:, 0] - arc["centre"][0])
    ang = lo - tol_ang + np.mod(ang - lo + tol_ang, 2 * np.pi)
    return ang <= hi + tol_ang


def test_nilson_male_is_four_tangent_circular_arcs_per_lobe():
    arcs = rotors.nilson_male_arcs()
    assert len(arcs) == 16
    assert [a["role"] for a in arcs[:4]] == ["tip", "flank", "root", "flank"]
    assert [a["convex"] for a in arcs[:4]] == [True, True, False, True]
    tip, flank, root, _ = arcs[:4]
    # tip arc and root arc centred on the male pitch circle (r1 = 0.64)
    assert np.allclose(tip["centre"], [0.64, 0.0]) and tip["radius"] == pytest.approx(0.36)
    assert np.linalg.norm(root["centre"]) == pytest.approx(0.64)
    assert root["radius"] == pytest.approx(0.04)
    # consecutive arcs meet with a common point and a common tangent (G1 chain)
    def end(a, which):
        ang = a["angles"][which]
        e = np.array([np.cos(ang), np.sin(ang)])
        return a["centre"] + a["radius"] * e, (e if a["convex"] else -e)
    for a, b in zip(arcs, arcs[1:] + arcs[:1]):
        (pa, na), (pb, nb) = end(a, 1), end(b, 0)
        assert np.allclose(pa, pb, atol=1e-12) and np.allclose(na, nb, atol=1e-12)

    male = rotors.builtin_rotor("nilson", "male")
    prof = male.profile

    def arc_distance(pts):
        d = np.full(len(pts), np.inf)
        owner = np.full(len(pts), -1)
        for k, a in enumerate(arcs):
            m = _on_arc(pts, a)
            dk = np.abs(np.linalg.norm(pts - a["centre"], axis=1) - a["radius"])
            better = m & (dk < d)
            d[better], owner[better] = dk[better], k
        return d, owner

    # every spline node and every dense sample of the profile lies on its arc
    d_nodes, owner = arc_distance(prof.points)
    assert d_nodes.max() <= 1e-9
    assert set(owner.tolist()) == set(range(16))  # all 16 arcs are used
    d_dense, _ = arc_distance(prof.sample(40000))
    assert d_dense.max() <= 1e-9
    # piecewise-constant curvature: 4 arcs per lobe, 3 distinct values
    # (tip 1/0.36, flank 1/0.518, root -1/0.04) away from the joints
    kappa = prof.curvature(prof.params(20000))
    targets = np.array([1 / tip["radius"], 1 / flank["radius"], -1 / root["radius"]])
    rel = np.min(np.abs(kappa[:, None] - targets[None]) / np.abs(targets[None]), axis=1)
    assert np.mean(rel < 1e-4) > 0.99


def test_nilson_female_is_the_envelope_of_the_male():
    male, female, A = rotors.rotor_pair("nilson")
    assert A == pytest.approx(1.6)
    assert (male.lobes, female.lobes) == (4, 6)
    assert male.pitch_radius == pytest.approx(0.64) and female.pitch_radius == pytest.approx(0.96)
    for r in (male, female):
        rad = np.linalg.norm(r.profile.sample(20000), axis=1)
        assert abs(rad.max() - 1.0) < 1e-9 and abs(rad.min() - 0.6) < 1e-9
        poly = r.profile.sample(3000)
        assert signed_area(poly) > 0 and segments_intersect_count(poly) == 0
        assert rotors._star_shaped(r.profile.points)
    # the male tip arc generates the female valley: the same circle (radius
    # 0.36) centred on the female pitch circle; the male root arc the female
    # tip: radius 0.04 centred on the female pitch circle
    # (at theta1 = 0 the male tip arc lies in the female valley, at theta1 =
    # -45 deg the male root arc on the female tip: the same circle arcs)
    pts = female.profile.points
    valley_c = 0.96 * np.array([-1.0, 0.0])
    tip_c = 0.96 * np.array([np.cos(5 * np.pi / 6), np.sin(5 * np.pi / 6)])
    for c, rho, (a0, a1) in ((valley_c, 0.36, (-40.0, 40.0)),  # facing the female axis
                             (tip_c, 0.04, (150.0 - 51.8, 150.0 + 51.8))):  # facing outwards
        sel = _on_arc(pts, dict(centre=c, angles=np.radians([a0, a1])))
        sel &= np.linalg.norm(pts - c, axis=1) < 2 * rho
        d = np.abs(np.linalg.norm(pts - c, axis=1) - rho)
        assert sel.sum() > 20 and d[sel].max() < 1e-9
    # conjugate action over a whole male lobe pitch: touching, no interference (at 100 positions, twice as
    # dense as test_conjugate_action's 48, with more profile samples)
    res = rotors.meshing_clearance(male, female, A, n_steps=100)
    assert res["max_gap"] <= 1e-6
    assert res["max_interference"] <= 1e-6
    assert rotors.spline_error("nilson", "male") < 1e-9
    assert rotors.spline_error("nilson", "female") < 1e-9


def test_builtin_rotor_sizes_out_of_range_are_named():
    """A lead or length a float property holds for infinity (3.4e38) is finite: refused by its ratio to the
    outer radius, as are leads that make a surface of revolution."""
    with pytest.raises(rotors.RotorError, match=r"lead = 3.4e\+38 is outside the limits 0.0628319 .. 100000 for "
                                                r"the outer radius 10"):
        rotors.builtin_rotor("nilson", "male", scale=10.0, lead=3.4e38)
    with pytest.raises(rotors.RotorError, match=r"lead = 1e-06 is outside"):
        rotors.builtin_rotor("nilson", "male", scale=10.0, lead=1e-6)
    with pytest.raises(rotors.RotorError, match=r"length = 3.4e\+38 exceeds 10000 x the outer radius 10"):
        rotors.builtin_rotor("nilson", "male", scale=10.0, length=3.4e38)
    r = rotors.builtin_rotor("nilson", "male", scale=10.0, lead=-100.0)    # a negative lead: the other hand
    assert r.handedness == "left" and r.v0 == pytest.approx(100.0 / (2 * math.pi))
