"""guiding (Rajain et al. 2023 §5): mesh operators against linear functions, the transported guiding field,
the guiding function's level sets on surfaces with known answers (plane, cylinder, parabolic
blade, gear flank, circles), spacing on curved surfaces (bump, saddle), base points (Fig. 10,
Remarks 1 and 3), the test surfaces themselves, and input validation."""
import math

import numpy as np
import pytest
import scipy.sparse as sp

from flank_addon.geometry import freeform_surfaces as fs
from flank_addon.methods.freeform_g1 import guiding as g

D = 0.1   # guiding-curve spacing used on the unit-size surfaces


def interior_mask(surface, margin):
    """Vertices at least ``margin`` (fraction of the parameter range) inside the parameter box."""
    lo, hi = surface.uv.min(0), surface.uv.max(0)
    m = margin * (hi - lo)
    return ((surface.uv - lo) > m).all(1) & ((hi - surface.uv) > m).all(1)


def spacing_errors(res, surface, margin=0.1):
    """Relative errors dist / d - 1 of the distance from the points of each guiding curve to the
    next one (nearest point on its polyline), for points whose nearest vertex lies inside the
    margin and whose nearest point is not an end of the next curve (there the next curve has
    left the surface).  Euclidean distance, i.e. a chord on a curved surface."""
    from scipy.spatial import cKDTree
    tree = cKDTree(surface.vertices)
    inside = interior_mask(surface, margin)
    out = []
    for c0, c1 in zip(res.curves[:-1], res.curves[1:]):
        P = c0.polylines[0].points
        dist, arc = g.polyline_distance(P, c1.polylines[0], return_arclength=True)
        ok = inside[tree.query(P)[1]] & (arc > 1e-9) & (arc < c1.polylines[0].length - 1e-9)
        out.append(dist[ok] / res.spacing - 1)
    return np.concatenate(out)


# ============================================================================ test surfaces
@pytest.mark.parametrize("name", sorted(fs.SURFACES))
def test_surfaces_exact_points_and_oriented_normals(name):
    s = fs.make_surface(name, size=1.0, resolution=24)
    assert np.abs(s.point(s.uv) - s.vertices).max() < 1e-14
    assert np.allclose(np.linalg.norm(s.normal(s.uv), axis=1), 1, atol=1e-14)
    _, n = g.face_areas_normals(s.vertices, s.faces)
    exact = s.normal(s.uv[s.faces].mean(1))
    assert (n * exact).sum(1).min() > 0.99          # faces oriented like the exact normal
    # exact normal is orthogonal to the exact tangents (finite differences of the exact map)
    h = 1e-6
    du = (s.point(s.uv + [h, 0]) - s.point(s.uv - [h, 0])) / (2 * h)
    dv = (s.point(s.uv + [0, h]) - s.point(s.uv - [0, h])) / (2 * h)
    nn = s.normal(s.uv)
    assert np.abs((du * nn).sum(1)).max() < 1e-7 and np.abs((dv * nn).sum(1)).max() < 1e-7
    g.validate_mesh(s.vertices, s.faces)


@pytest.mark.parametrize("name", ["plane", "cylinder", "parabolic_blade"])
def test_surfaces_closest_point(name):
    s = fs.make_surface(name, size=1.0, resolution=16)
    rng = np.random.default_rng(1)
    uv = s.uv + rng.uniform(-0.01, 0.01, s.uv.shape)
    for off in (0.05, -0.05, 0.3):
        q = s.point(uv) + off * s.normal(uv)
        foot, quv = s.closest(q)
        assert np.abs(foot - s.point(uv)).max() < 1e-12
        assert np.abs(quv - uv).max() < 1e-12


def test_parabolic_blade_closest_point_beyond_the_focal_axis():
    """Above the parabola's evolute there are three stationary points; the nearest must win
    (checked against dense sampling of the parabola)."""
    s = fs.parabolic_blade(size=1.0, rho=0.5)
    q = np.array([[0.01, 0.0, 1.5], [-0.3, 0.2, 2.0], [0.2, 0.0, 0.6], [0.0, 0.0, 3.0]])
    foot, _ = s.closest(q)
    x = np.linspace(-5, 5, 2_000_001)
    for p, f in zip(q, foot):
        d = np.sqrt((x - p[0]) ** 2 + (x * x / 1.0 - p[2]) ** 2).min()
        assert np.linalg.norm(f - p) <= d + 1e-9


def test_grid_sizes_and_limits():
    s = fs.cylinder_patch(size=1.0, resolution=30, angle=math.pi / 2)   # arc 1.57 x height 1
    assert len(s.faces) == 2 * 30 * 19
    assert len(fs.bump(resolution=100).faces) == 20_000
    with pytest.raises(ValueError, match="size"):
        fs.bump(size=float("nan"))
    with pytest.raises(ValueError, match="jitter"):
        fs.plane_patch(jitter=0.3)
    with pytest.raises(ValueError, match="4,000,000"):
        fs.saddle(resolution=5000)
    with pytest.raises(ValueError, match="unknown test surface"):
        fs.make_surface("torus")


# ============================================================================ mesh operators
@pytest.fixture(scope="module")
def jittered_plane():
    return fs.plane_patch(size=1.0, resolution=24, jitter=0.2, seed=3)


def test_gradient_exact_for_linear_functions():
    """Per-face gradient of f = a . x equals the projection of a into the face plane, on any mesh
    (flat or curved)."""
    a = np.array([0.3, -1.2, 0.7])
    for s in (fs.plane_patch(resolution=12, jitter=0.2), fs.bump(resolution=20), fs.gear_flank(resolution=16)):
        Dm = g.gradient_matrix(s.vertices, s.faces)
        grad = (Dm @ (s.vertices @ a)).reshape(-1, 3)
        _, n = g.face_areas_normals(s.vertices, s.faces)
        assert np.abs(grad - (a - (n @ a)[:, None] * n)).max() < 1e-12


def test_laplacian_of_linear_functions_vanishes_inside(jittered_plane):
    s = jittered_plane
    L = g.cotan_laplacian(s.vertices, s.faces)
    inner = ~g.boundary_vertices(s.faces, len(s.vertices))
    f = s.vertices @ [0.7, -0.4, 0.0] + 2.0
    assert np.abs((L @ f)[inner]).max() < 1e-12
    assert np.abs(L @ np.ones(len(f))).max() < 1e-12             # constants everywhere
    assert np.abs((L @ f)[~inner]).max() > 1e-3                  # (not on the boundary: natural BC)
    # on the developable cylinder mesh, z and the unrolled arc coordinate are linear intrinsically
    c = fs.cylinder_patch(resolution=30)
    Lc = g.cotan_laplacian(c.vertices, c.faces)
    ic = ~g.boundary_vertices(c.faces, len(c.vertices))
    assert np.abs((Lc @ c.vertices[:, 2])[ic]).max() < 1e-12


def test_laplacian_is_the_stiffness_matrix_and_psd():
    s = fs.bump(resolution=14)
    L = g.cotan_laplacian(s.vertices, s.faces)
    Dm = g.gradient_matrix(s.vertices, s.faces)
    area, _ = g.face_areas_normals(s.vertices, s.faces)
    K = Dm.T @ sp.diags(np.repeat(area, 3)) @ Dm
    assert abs(L - K).max() < 1e-12
    assert abs(L - L.T).max() < 1e-14
    assert np.linalg.eigvalsh(L.toarray()).min() > -1e-12


def test_areas_and_vertex_normals():
    s = fs.bump(resolution=40)
    area, _ = g.face_areas_normals(s.vertices, s.faces)
    assert np.isclose(g.vertex_areas(s.vertices, s.faces).sum(), area.sum(), rtol=1e-14)
    # bump surface area by fine quadrature of sqrt(1 + |grad h|^2): the mesh converges to it
    x = np.linspace(-0.5, 0.5, 801)
    X, Y = np.meshgrid(x, x)
    n = s.normal(np.c_[X.ravel(), Y.ravel()])
    exact = np.trapz(np.trapz((1 / n[:, 2]).reshape(X.shape), x), x)
    assert abs(area.sum() / exact - 1) < 2e-3
    N = g.vertex_normals(s.vertices, s.faces)
    assert np.allclose(np.linalg.norm(N, axis=1), 1)
    ang = np.degrees(np.arccos(np.clip((N * s.normal(s.uv)).sum(1), -1, 1)))
    assert ang.max() < 1.0                      # O(h^2) against the exact normal


def test_connection_laplacian_parallel_field_in_kernel():
    """On the developable cylinder mesh the parallel field along the rulings is in the kernel of
    the connection Laplacian; the operator is Hermitian PSD."""
    c = fs.cylinder_patch(resolution=20)
    L, e1, e2 = g.connection_laplacian(c.vertices, c.faces)
    assert abs(L - L.conj().T).max() < 1e-14
    z = np.array([0, 0, 1.0])
    zc = (e1 @ z) + 1j * (e2 @ z)
    assert np.abs(L @ zc).max() < 1e-12
    assert np.linalg.eigvalsh(L.toarray()).min() > -1e-12


# ============================================================================ guiding field
@pytest.mark.parametrize("name", sorted(fs.SURFACES))
def test_guiding_field_is_unit_and_tangent(name):
    s = fs.make_surface(name, size=1.0, resolution=30)
    c = g.central_vertex(s.vertices, s.faces)
    N = g.vertex_normals(s.vertices, s.faces)
    d = np.cross(N[c], [0.3, 0.5, 0.8])
    for method in ("transport", "projection"):
        f = g.propagate_direction(s.vertices, s.faces, d, method=method)
        assert np.allclose(np.linalg.norm(f.vertex, axis=1), 1, atol=1e-12)
        assert np.abs((f.vertex * N).sum(1)).max() < 1e-12
        _, fn = g.face_areas_normals(s.vertices, s.faces)
        assert np.allclose(np.linalg.norm(f.face, axis=1), 1, atol=1e-12)
        assert np.abs((f.face * fn).sum(1)).max() < 1e-12
        t0 = d - (d @ N[c]) * N[c]
        assert np.allclose(f.vertex[c], t0 / np.linalg.norm(t0), atol=1e-12)   # the given vector at the centre


def test_transport_is_the_parallel_field_on_developables():
    """Cylinder (direction along the rulings) and parabolic blade (across them): the transported
    field is the parallel field exactly."""
    c = fs.cylinder_patch(resolution=30)
    f = g.propagate_direction(c.vertices, c.faces, [0, 0, 1])
    assert np.abs(f.vertex - [0, 0, 1]).max() < 1e-12
    b = fs.parabolic_blade(resolution=30)
    f = g.propagate_direction(b.vertices, b.faces, [1, 0, 0])
    N = g.vertex_normals(b.vertices, b.faces)
    expect = np.cross([0, 1.0, 0], N)           # the parabola's unit tangent in each tangent plane
    assert np.abs(f.vertex - expect).max() < 1e-12
    # point selects the central vertex
    f2 = g.propagate_direction(b.vertices, b.faces, [1, 0, 0], point=b.vertices[5] + [0, 0, 1e-3])
    assert f2.source == 5


def test_user_field_per_vertex_and_per_face(jittered_plane):
    s = jittered_plane
    v = np.tile([1.0, 1.0, 0.5], (len(s.vertices), 1))        # leans out of the plane: projected
    fv = g.field_from_vectors(s.vertices, s.faces, v)
    assert np.allclose(fv.vertex, [2 ** -0.5, 2 ** -0.5, 0])
    fface = g.field_from_vectors(s.vertices, s.faces, np.tile([0, 2.0, 0], (len(s.faces), 1)))
    assert np.allclose(fface.face, [0, 1, 0]) and np.allclose(fface.vertex, [0, 1, 0])


# ============================================================================ level sets
def line_fit_deviation(P):
    """Largest distance of points (n, 3) from the line through their first and last point."""
    d = (P[-1] - P[0]) / np.linalg.norm(P[-1] - P[0])
    r = P - P[0]
    return np.linalg.norm(r - (r @ d)[:, None] * d, axis=1).max(), d


def test_plane_level_sets_straight_along_direction_at_spacing_d(jittered_plane):
    s = jittered_plane
    X0 = np.array([math.cos(0.5), math.sin(0.5), 0.0])
    Y0 = np.cross([0, 0, 1.0], X0)
    res = g.guiding_curves(s.vertices, s.faces, direction=X0, spacing=D)
    c = res.function.source
    assert res.function.angle_max < 1e-8 and abs(res.function.grad_min - 1) < 1e-10
    offsets = []
    for cur in res.curves:
        assert len(cur.polylines) == 1
        P = cur.polylines[0].points
        dev, d = line_fit_deviation(P)
        assert dev < 1e-6 * 1.0
        assert d @ X0 > 1 - 1e-12                         # oriented along the guiding direction
        off = (P - s.vertices[c]) @ Y0
        assert np.ptp(off) < 1e-6
        offsets.append(off.mean())
    assert np.abs(np.diff(offsets) - D).max() < 1e-6
    assert len(res.curves) == len(g.level_values(res.function.values, D))
    # levels are k d through the central vertex; the curves end on the boundary
    assert np.allclose([cur.level for cur in res.curves], np.round(np.array(offsets) / D) * D, atol=1e-9)


def cylinder_mesh_arc(c, P, radius, nu, arc):
    """Arc coordinate of points P (n, 3) on the polygonal cylinder mesh (unrolled polygon)."""
    th = np.arctan2(P[:, 1], P[:, 0])
    dth = arc / radius / nu
    k = np.clip(np.floor((th + arc / radius / 2) / dth + 1e-9), 0, nu - 1)
    th_k = -arc / radius / 2 + k * dth
    chord = 2 * radius * math.sin(dth / 2)
    base = np.c_[radius * np.cos(th_k), radius * np.sin(th_k)]
    return k * chord + np.linalg.norm(P[:, :2] - base, axis=1)


def test_cylinder_level_sets_are_rulings_spaced_d():
    R, ang, res_ = 1.0, math.pi / 2, 40
    c = fs.cylinder_patch(size=1.0, resolution=res_, radius=R, angle=ang)
    nu = res_                                                # arc 1.57 > height 1: nu along the arc
    res = g.guiding_curves(c.vertices, c.faces, direction=[0, 0, 1], point=[R, 0, 0], spacing=D)
    assert len(res.curves) == 15
    arcs, true_arcs = [], []
    for cur in res.curves:
        P = cur.polylines[0].points
        assert np.abs(P[:, :2] - P[:, :2].mean(0)).max() < 1e-6 * c.size     # a ruling (z-parallel line)
        assert np.ptp(P[:, 2]) > 0.999                                       # over the whole height
        a = cylinder_mesh_arc(c, P, R, nu, R * ang)
        arcs.append(a.mean())
        true_arcs.append(R * np.arctan2(P[:, 1], P[:, 0]).mean())
    assert np.abs(np.abs(np.diff(arcs)) - D).max() < 1e-9   # exact on the (developable) mesh
    assert np.abs(np.abs(np.diff(true_arcs)) - D).max() < 1e-4 * D   # O(h^2) from the exact cylinder


def test_parabolic_blade_level_sets_are_sections():
    """Direction across the rulings: the guiding curves are the parabolas y = const, d apart."""
    b = fs.parabolic_blade(size=1.0, resolution=40)
    res = g.guiding_curves(b.vertices, b.faces, direction=[1, 0, 0], spacing=D)
    ys = []
    for cur in res.curves:
        P = cur.polylines[0].points
        assert np.ptp(P[:, 1]) < 1e-9
        assert np.abs(P[:, 2] - P[:, 0] ** 2 / (2 * 0.6)).max() < 5e-4     # on the parabola (chord sag)
        ys.append(P[0, 1])
    assert np.abs(np.diff(ys) - D).max() < 1e-9
    assert len(res.curves) == 15


def test_gear_flank_developable_spacing():
    """The gear flank is developable but its mesh is not quite: transported along a ruling at the
    centre, the guiding curves are (nearly) parallel straight lines of the development, d apart."""
    s = fs.gear_flank(size=1.0, resolution=50)
    c = g.central_vertex(s.vertices, s.faces)
    T = fs.gear_ruling(s.uv[c:c + 1], base_radius=2.0)[0]
    res = g.guiding_curves(s.vertices, s.faces, direction=T, spacing=D)
    assert res.function.angle_rms < 1e-3 and res.function.grad_max - res.function.grad_min < 1e-4
    e = spacing_errors(res, s, margin=0.05)
    assert np.abs(e).max() < 2e-3
    mid = min(res.curves, key=lambda cur: abs(cur.level)).polylines[0]
    assert np.degrees(np.arccos(abs(line_fit_deviation(mid.points)[1] @ T))) < 1.0   # the central curve ~ ruling


def test_circular_field_gives_concentric_arcs(jittered_plane):
    """A user field tangent to circles about a centre outside the patch: G is the distance to that
    centre (grad G orthogonal to X, |grad G| = 1), so the curves are arcs d apart (O(h^2))."""
    s = jittered_plane
    ctr = np.array([-1.5, -0.2, 0.0])
    r = s.vertices - ctr
    X = np.cross([0, 0, 1.0], r)
    res = g.guiding_curves(s.vertices, s.faces, field_vectors=X, spacing=D)
    radii = []
    for cur in res.curves:
        rad = np.linalg.norm(cur.polylines[0].points - ctr, axis=1)
        assert np.ptp(rad) < 2e-3
        radii.append(rad.mean())
    assert np.abs(np.abs(np.diff(radii)) - D).max() < 1e-3


@pytest.mark.parametrize("name,direction,limits", [
    ("bump", [1, 0, 0], (-0.03, 0.06)), ("bump", [1, 1, 0], (-0.03, 0.06)),
    ("saddle", [1, 0, 0], (-0.012, 0.012)), ("saddle", [1, 1, 0], (-0.012, 0.012))])
def test_curved_surfaces_spacing_within_a_few_percent(name, direction, limits):
    s = fs.make_surface(name, size=1.0, resolution=60)
    res = g.guiding_curves(s.vertices, s.faces, direction=direction, spacing=D)
    e = spacing_errors(res, s)
    assert limits[0] < e.min() and e.max() < limits[1]
    assert res.function.angle_max < 2.0
    assert all(len(cur.polylines) == 1 for cur in res.curves)


def test_min_scaling_never_wider_than_d():
    s = fs.bump(size=1.0, resolution=60)
    res = g.guiding_curves(s.vertices, s.faces, direction=[1, 0, 0], spacing=D, scaling="min")
    e = spacing_errors(res, s, margin=0.02)
    assert e.max() < 0.005 and e.min() > -0.12


def test_level_set_components_and_closed_loops():
    s = fs.plane_patch(size=1.0, resolution=40, jitter=0.2, seed=5)
    V, F = s.vertices, s.faces
    hyp = V[:, 0] ** 2 - V[:, 1] ** 2
    pls = g.level_set(V, F, hyp, 0.04)
    assert len(pls) == 2 and not any(p.closed for p in pls)
    assert {np.sign(p.points[:, 0]).mean() for p in pls} == {-1.0, 1.0}
    circ = V[:, 0] ** 2 + V[:, 1] ** 2
    (loop,) = g.level_set(V, F, circ, 0.09)
    assert loop.closed and np.allclose(loop.points[0], loop.points[-1])
    assert abs(loop.length - 2 * math.pi * 0.3) < 2e-3
    edges, face_edges, _ = g.mesh_edges(F, len(V))
    for pl in pls + [loop]:
        # each point is on its mesh edge at the interpolated level; consecutive points share a face
        a, b = pl.edges[:, 0], pl.edges[:, 1]
        assert np.allclose(V[a] + pl.t[:, None] * (V[b] - V[a]), pl.points)
        vals = (hyp if pl is not loop else circ)
        assert np.allclose(vals[a] + pl.t * (vals[b] - vals[a]), pl.level)
        for k, f in enumerate(pl.faces):
            assert set(pl.edges[k]) <= set(F[f]) and set(pl.edges[k + 1]) <= set(F[f])


def test_level_through_a_vertex_has_no_zero_length_segments():
    s = fs.plane_patch(size=1.0, resolution=10)
    vals = s.vertices[:, 0].copy()             # level 0 runs exactly through a vertex column
    (pl,) = g.level_set(s.vertices, s.faces, vals, 0.0)
    assert np.linalg.norm(np.diff(pl.points, axis=0), axis=1).min() > 1e-6
    assert np.abs(pl.points[:, 0]).max() < 1e-15


# ============================================================================ base points
def test_base_points_fig10_on_the_plane_with_strips_of_varying_length(jittered_plane):
    """Diagonal direction on a square: curves of different lengths.  Paired base points lie in the
    normal plane of the lower curve and are d apart; strips differ in length (Remark 3); curves
    that reach past their neighbour get added base points (Remark 1); steps <= h."""
    s = jittered_plane
    X0 = np.array([math.cos(0.5), math.sin(0.5), 0.0])
    res = g.guiding_curves(s.vertices, s.faces, direction=X0, spacing=D)
    h = res.step
    assert abs(h - np.linalg.norm(np.ptp(s.vertices, axis=0)) / 100) < 1e-15
    assert len(res.bases) == len(res.curves) and len(res.strips) == len(res.curves) - 1
    for b in res.bases:
        assert np.diff(b.arclength).max() <= h * (1 + 1e-9)
        assert np.allclose(b.normals, [0, 0, 1])
        assert np.allclose(np.abs(b.tangents @ X0), 1)
    lengths = [len(st.columns) for st in res.strips]
    assert len(set(lengths)) > 3
    assert any(b.added.any() for b in res.bases[1:])
    for st in res.strips:
        lo, hi = res.bases[st.index], res.bases[st.index + 1]
        gap = hi.points[st.upper] - lo.points[st.lower]
        assert np.abs(np.linalg.norm(gap, axis=1) - D).max() < 1e-9
        assert np.abs((gap * lo.tangents[st.lower]).sum(1)).max() < 1e-9
        assert np.all(np.diff(lo.arclength[st.lower]) > 0) and np.all(np.diff(hi.arclength[st.upper]) > 0)
    # every base point column is unique within a curve
    for b in res.bases:
        assert len(np.unique(b.columns)) == len(b.columns)


def test_base_points_on_cylinder_pair_at_equal_height():
    c = fs.cylinder_patch(size=1.0, resolution=40)
    res = g.guiding_curves(c.vertices, c.faces, direction=[0, 0, 1], spacing=D)
    n = {len(st.columns) for st in res.strips}
    assert len(n) == 1                                   # all strips equally long
    for st in res.strips:
        lo, hi = res.bases[st.index], res.bases[st.index + 1]
        assert np.abs(lo.points[st.lower, 2] - hi.points[st.upper, 2]).max() < 1e-9
        # Eq. (7)'s normals are the (radial) cylinder normals at the base points
        P = lo.points[st.lower]
        radial = np.c_[P[:, :2], np.zeros(len(P))]
        radial /= np.linalg.norm(radial, axis=1, keepdims=True)
        assert np.degrees(np.arccos(np.clip((lo.normals[st.lower] * radial).sum(1), -1, 1))).max() < 1.5


def test_base_points_start_curve_and_missed_planes():
    """Seeding from the middle curve propagates both ways; a too small max_gap drops all rulings."""
    s = fs.saddle(size=1.0, resolution=40)
    res = g.guiding_curves(s.vertices, s.faces, direction=[1, 1, 0], spacing=D, start=5)
    assert all(len(b.points) for b in res.bases)
    assert not res.bases[5].added.any()
    bases, strips = g.base_points(res.curves, res.step, max_gap=1e-3)
    assert all(len(st.columns) == 0 for st in strips)
    assert all(b.added.all() for b in bases[1:])


# ============================================================================ validation
def test_default_spacing():
    assert g.default_spacing(0.3, 1.0, 2.71) == pytest.approx(math.sqrt(2.71 ** 2 - 0.49))
    assert g.default_spacing(1.0, 0.3, 2.46) == pytest.approx(math.sqrt(2.46 ** 2 - 0.49))   # blisk, r1 > r2
    assert g.default_spacing(4, 4, 18.67) == 18.67                                               # cylinder
    for bad, msg in [((0.3, 1.0, 0.5), "must exceed"), ((float("nan"), 1, 2), "not finite"),
                     ((-1, 1, 2), ">= 0"), (("a", 1, 2), "not a number")]:
        with pytest.raises(ValueError, match=msg):
            g.default_spacing(*bad)
    s = fs.plane_patch(resolution=10)
    res = g.guiding_curves(s.vertices, s.faces, direction=[1, 0, 0], r1=0.03, r2=0.1, L=0.2)
    assert res.spacing == pytest.approx(math.sqrt(0.04 - 0.0049))


def test_validation_messages():
    s = fs.plane_patch(resolution=6)
    V, F = s.vertices, s.faces
    bad = V.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match=r"vertices\[3\].*not finite"):
        g.validate_mesh(bad, F)
    flat = V.copy()
    flat[F[0, 2]] = flat[F[0, 0]] + 0.5 * (flat[F[0, 1]] - flat[F[0, 0]])    # collinear corners
    with pytest.raises(ValueError, match="area .* at or below the limit"):
        g.validate_mesh(flat, F)
    with pytest.raises(ValueError, match="no faces"):
        g.validate_mesh(V, np.zeros((0, 3), int))
    with pytest.raises(ValueError, match="outside 0.."):
        g.validate_mesh(V, F + 1000)
    with pytest.raises(ValueError, match="repeats a vertex"):
        g.validate_mesh(V, np.r_[F, [[0, 0, 1]]])
    with pytest.raises(ValueError, match="oriented oppositely"):
        g.validate_mesh(V, np.r_[F[:1, ::-1], F[1:]])
    edges, _, on_boundary = g.mesh_edges(F, len(V))
    a, b = edges[~on_boundary][0]
    with pytest.raises(ValueError, match="shared by 3 faces"):
        g.validate_mesh(np.r_[V, [[0, 0, 1.0]]], np.r_[F, [[a, b, len(V)]]])
    with pytest.raises(ValueError, match="2 connected pieces"):
        g.validate_mesh(np.r_[V, V + 5], np.r_[F, F + len(V)])
    with pytest.raises(ValueError, match="not used by any face"):
        g.validate_mesh(np.r_[V, [[9, 9, 9.0]]], F)
    for d, msg in [([0, 0, 0], "length 0"), ([np.nan, 1, 0], "not finite"), ([1, 0], "3-vector"),
                   ([0, 0, 1], "central vertex 24 makes 90.00 deg with the tangent plane.*limit 85")]:
        with pytest.raises(ValueError, match=msg):
            g.guiding_curves(V, F, direction=d, spacing=0.1)
    with pytest.raises(ValueError, match="limit 85"):
        g.guiding_curves(V, F, direction=[0.01, 0, 1], spacing=0.1)       # 89.4 deg out of the plane
    with pytest.raises(ValueError, match="from the nearest mesh vertex"):
        g.guiding_curves(V, F, direction=[1, 0, 0], point=[0, 0, 5], spacing=0.1)
    with pytest.raises(ValueError, match="exactly one of direction"):
        g.guiding_curves(V, F, spacing=0.1)
    with pytest.raises(ValueError, match="give spacing"):
        g.guiding_curves(V, F, direction=[1, 0, 0])
    for sp_, msg in [(0.0, "> 0"), (float("nan"), "> 0"), (1e-9, "below the limit"), (1e-5, "above the limit")]:
        with pytest.raises(ValueError, match=msg):
            g.guiding_curves(V, F, direction=[1, 0, 0], spacing=sp_)
    with pytest.raises(ValueError, match="field has 3 rows"):
        g.guiding_curves(V, F, field_vectors=np.ones((3, 3)), spacing=0.1)
    with pytest.raises(ValueError, match="zero vector"):
        g.field_from_vectors(V, F, np.zeros((len(V), 3)))
    with pytest.raises(ValueError, match="method"):
        g.propagate_direction(V, F, [1, 0, 0], method="magic")
    with pytest.raises(ValueError, match="w_unit must be > 0"):
        g.guiding_curves(V, F, direction=[1, 0, 0], spacing=0.1, w_unit=0)
