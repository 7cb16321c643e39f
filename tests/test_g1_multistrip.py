"""Rajain et al. 2023 free-form planner: foot points, Jacobian, envelopes, exact cases, plan file, CLI.

References are independent of the code under test: brute force over all triangles, central finite
differences, closed-form geometry of a cylinder and of a translated cone, the swept-tool check.
"""
import contextlib
import io
import json
import math
import subprocess

import numpy as np
import pytest
import scipy.sparse as sp

from flank_addon.cli import main
from flank_addon.methods.freeform_g1 import guiding
from flank_addon.geometry.freeform_surfaces import bump, cylinder_patch, make_surface, parabolic_blade, plane_patch
from flank_addon.methods.freeform_g1.planner import (DEFAULT_WEIGHTS, Layout, Objective, assemble, envelope, envelope_normal,
                                       freeform_envelopes, freeform_kinks, plan_freeform, rail_derivative_matrix,
                                       sweep_deviation, verify_freeform)
from flank_addon.methods.freeform_g1.initial_rulings import initial_rulings
from flank_addon.geometry.mesh_distance import TriangleMesh, closest_on_triangles
from flank_addon.io.plan import PlanError, read_plan, validate_plan, write_plan


def brute_distance(V, F, P):
    out = np.empty(len(P))
    A, B, C = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    for i, p in enumerate(P):
        Q, _ = closest_on_triangles(np.repeat(p[None], len(F), 0), A, B, C)
        out[i] = np.sqrt(((Q - p) ** 2).sum(1)).min()
    return out


# ============================================================================ foot points
@pytest.mark.parametrize("name", ["cylinder", "bump", "saddle"])
def test_foot_points_equal_brute_force_and_sign_follows_the_normals(name):
    S = make_surface(name, size=1.0, resolution=24)
    mesh = TriangleMesh(S.vertices, S.faces)
    rng = np.random.default_rng(3)
    uv = S.uv[rng.choice(len(S.uv), 300)]
    h = rng.uniform(-0.08, 0.08, len(uv))
    P = S.point(uv) + h[:, None] * S.normal(uv)
    ref = brute_distance(S.vertices, S.faces, P)
    for exact in (False, True):
        fp = mesh.foot_points(P, exact=exact)
        assert np.abs(np.abs(fp["distance"]) - ref).max() < 1e-12
        assert (np.sign(fp["distance"]) == np.sign(h)).all()
        # the gradient is the unit vector from the foot point, and the foot lies on the mesh
        g = fp["gradient"]
        assert np.allclose(np.linalg.norm(g, axis=1), 1)
        assert np.allclose(fp["foot"] + fp["distance"][:, None] * g, P, atol=1e-12)


def test_exact_mode_finds_faces_the_vertex_candidates_miss():
    # a thin spike far from most vertices: the k nearest vertices' faces are not the closest face
    V = np.array([[0, 0, 0], [10, 0, 0], [0, 10, 0], [10, 10, 0], [5, 5, 0.0], [5.01, 5, 3.0]], float)
    F = np.array([[0, 1, 4], [1, 3, 4], [3, 2, 4], [2, 0, 4], [4, 1, 5]])
    mesh = TriangleMesh(V, F, k=1)
    P = np.array([[5.3, 5.0, 1.5], [1.0, 1.0, 2.0]])
    ref = brute_distance(V, F, P)
    assert np.allclose(np.abs(mesh.foot_points(P, exact=True)["distance"]), ref, atol=1e-12)


def test_pruned_candidates_give_the_closest_candidate_face():
    # a triangle soup with zero-area faces (a repeated corner) and slivers (a corner 1e-9 off the opposite
    # edge, whose computed normal is poor): the faces left out by the plane-and-disc bound never include the
    # closest one, which is the first closest in the row's candidate order, as brute force over all finds it
    rng = np.random.default_rng(5)
    V = rng.normal(size=(60, 3))
    V[50:60] = 0.5 * (V[30:40] + V[40:50]) + 1e-9 * rng.normal(size=(10, 3))
    F = np.concatenate([rng.integers(0, 50, size=(120, 3)),
                        np.c_[np.arange(30, 40), np.arange(40, 50), np.arange(50, 60)],
                        np.c_[np.arange(10), np.arange(10), np.arange(10, 20)]])
    mesh = TriangleMesh(V, F)
    P = np.concatenate([rng.normal(size=(200, 3)), 40 * rng.normal(size=(50, 3)),
                        V[50:60] + 1e-7 * rng.normal(size=(10, 3))])
    cand = np.tile(np.arange(len(F)), (len(P), 1))
    cand[rng.random(cand.shape) < 0.2] = -1               # rows of different candidate sets, padded with -1
    A, B, C = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]

    def check(P, face, d2):
        for i, p in enumerate(P):
            fi = cand[i][cand[i] >= 0]
            Q, _ = closest_on_triangles(np.repeat(p[None], len(fi), 0), A[fi], B[fi], C[fi])
            dd = ((p - Q) ** 2).sum(1)
            assert face[i] == fi[np.argmin(dd)] and d2[i] == dd.min()

    check(P, *mesh._project(P, cand)[2:4])
    # from any starting candidate (here the first), looking at all; then again after moves of 1e-6 .. 1e-1,
    # starting from the face found and passing on the slack, as an optimiser's next query does
    first = np.argmax(cand >= 0, axis=1)
    out = mesh._project(P, cand, start=first, slack=np.full(cand.shape, -np.inf), moved=np.zeros(len(P)))
    check(P, *out[2:4])
    for step in (1e-12, 1e-9, 1e-6, 1e-3, 1e-1):
        P2 = P + step * rng.normal(size=P.shape)
        out = mesh._project(P2, cand, start=out[4], slack=out[5], moved=np.linalg.norm(P2 - P, axis=1))
        check(P2, *out[2:4])
        P = P2


def test_faces_of_no_area_are_their_edges():
    # a repeated corner and three collinear corners: Ericson's region formulas divide 0 by 0 there; the closest
    # point is on an edge, checked against 20,001 samples of each edge (before, such rows came out as the origin)
    rng = np.random.default_rng(3)
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 2, 0], [3, 0, 1], [1.5, 0, 0.5]], float)
    F = np.array([[0, 1, 2], [3, 3, 4], [0, 4, 5]])       # a triangle, a repeated corner, collinear corners
    P = rng.uniform(-1, 4, size=(300, 3))
    t = np.linspace(0, 1, 20001)[:, None]
    nearest = []
    for f in F:
        A, B, C = (np.repeat(V[i][None], len(P), 0) for i in f)
        Q, bary = closest_on_triangles(P, A, B, C)
        got = np.linalg.norm(Q - P, axis=1)
        if f[0] == 0 and f[1] == 1:                       # the proper triangle: its closest points as they are
            nearest.append(got)
            continue
        X = V[f]
        edges = np.concatenate([X[i] + t * (X[(i + 1) % 3] - X[i]) for i in range(3)])
        dense = np.sqrt(((P[:, None, :] - edges[None]) ** 2).sum(2)).min(1)
        assert np.isfinite(Q).all() and np.allclose(bary.sum(1), 1.0) and np.allclose(bary @ X, Q)
        assert np.all(got <= dense + 1e-12) and np.all(got >= dense - 2e-4)
        nearest.append(dense)
    # the mesh's exact foot points are then the nearest of its faces' closest points
    fp = TriangleMesh(V, F).foot_points(P, exact=True)
    least = np.min(nearest, axis=0)
    assert np.all(np.abs(fp["distance"]) <= least + 1e-12) and np.all(np.abs(fp["distance"]) >= least - 2e-4)


@pytest.mark.parametrize("height", [0.0, 1e-12, 1e-8, 1e-5, 1e-3, 0.5])
def test_points_over_the_long_edge_of_a_sliver_are_as_far_as_the_plane(height):
    # C lies `height` off the long edge AB (length 112): a point over AB, off the plane by `off`, is exactly
    # `off` from the triangle.  Ericson's region tests put up to 31% of such points at the far corner by
    # rounding (wrong by up to 92 at height 1e-8); slivers are measured as their plane inside their edges
    rng = np.random.default_rng(0)
    A, B = np.array([85.71428571428571, 28.57142857142857, 4.540164689476524]), np.array([0.0, 100.0, 0.0])
    u = np.cross(B - A, [0.3, 0.1, 0.9])
    C = A + 0.33 * (B - A) + height * u / np.linalg.norm(u)
    n = np.cross(B - A, u)                                # the plane's normal, well defined at any height
    n /= np.linalg.norm(n)
    for off in (0.0, 1e-3, 1.0):
        P = A + rng.random(5000)[:, None] * (B - A) + off * n
        Q, bary = closest_on_triangles(P, *(np.repeat(X[None], len(P), 0) for X in (A, B, C)))
        assert np.abs(np.linalg.norm(P - Q, axis=1) - off).max() < 1e-12 * np.linalg.norm(B - A)
        assert (bary >= 0).all() and np.allclose(bary.sum(1), 1.0) and np.allclose(bary @ np.stack([A, B, C]), Q)
    # and a mesh of it answers the same
    mesh = TriangleMesh(np.stack([A, B, C]), np.array([[0, 1, 2]]))
    fp = mesh.foot_points(P, exact=True)
    assert np.abs(np.abs(fp["distance"]) - 1.0).max() < 1e-12 * np.linalg.norm(B - A)


def test_a_face_too_thin_for_a_unit_normal_is_still_found():
    # the sliver's cross product squared underflows, so its computed normal is not of length 1: the plane part
    # of the bound must not be used for it (the small triangle beside it has the nearer centroid)
    P = np.array([[2.0, 0.0, 10.0]])
    c1 = P[0] + [0.0, 10.08, 0.0]
    V = np.array([[0, 0, 0], [1, 0, 0], [0.5, 2.5e-162, 0],
                  c1 + [0.01, 0, 0], c1 + [-0.005, 0, 0.0087], c1 + [-0.005, 0, -0.0087]], float)
    F = np.array([[0, 1, 2], [3, 4, 5]])
    mesh = TriangleMesh(V, F)
    assert abs(np.linalg.norm(mesh.face_normals[0]) - 1) > 1e-3           # the case this test is about
    for exact in (False, True):
        fp = mesh.foot_points(P, exact=exact)
        assert fp["face"][0] == 0 and abs(abs(fp["distance"][0]) - brute_distance(V, F, P)[0]) < 1e-12


def test_vertices_of_no_face_are_not_candidates():
    # a vertex that belongs to no face cannot lead to one: the nearest vertices are looked for among the faces'
    rng = np.random.default_rng(0)
    V = np.r_[[[0, 0, 0], [1, 0, 0], [0, 1, 0], [5, 5, 0]], 10 + rng.normal(size=(10, 3))]
    F = np.array([[0, 1, 2], [1, 3, 2]])
    P = np.r_[[[0.2, 0.2, 1.0]], 10 + rng.normal(size=(99, 3))]
    fp = TriangleMesh(V, F).foot_points(P)
    assert np.abs(np.abs(fp["distance"]) - brute_distance(V, F, P)).max() < 1e-12


def test_a_mesh_asked_again_answers_as_a_new_one():
    # the remembered nearest vertices and candidates of the last query change nothing: moves from none to
    # larger than the triangles, every answer equal to that of a mesh asked for the first time
    S = make_surface("bump", size=1.0, resolution=24)
    mesh = TriangleMesh(S.vertices, S.faces)
    rng = np.random.default_rng(7)
    uv = S.uv[rng.choice(len(S.uv), 3000)]
    P = S.point(uv) + rng.uniform(-0.05, 0.05, len(uv))[:, None] * S.normal(uv)
    for step in (0.0, 1e-7, 1e-4, 1e-2, 0.2, 0.0):
        P = P + step * rng.normal(size=P.shape)
        got, ref = mesh.foot_points(P), TriangleMesh(S.vertices, S.faces).foot_points(P)
        for key in ref:
            assert np.array_equal(got[key], ref[key]), (step, key)


@pytest.mark.parametrize("offset", [0.0, 1e5])
def test_small_moves_leave_out_only_faces_that_stay_farther(offset):
    # an optimiser's late queries: every point moves by 1e-12 .. 1e-5 (less than the gaps between the closest
    # face and its neighbours), the faces left out by their remembered gaps are never the closest; near the
    # origin and 1e5 sizes away from it, where rounding of the coordinates is 1e-11 of the mesh
    S = make_surface("bump", size=1.0, resolution=24)
    V = S.vertices + offset
    mesh = TriangleMesh(V, S.faces)
    rng = np.random.default_rng(11)
    uv = S.uv[rng.choice(len(S.uv), 3000)]
    P = S.point(uv) + offset + rng.uniform(-0.05, 0.05, len(uv))[:, None] * S.normal(uv)
    looked = []
    for step in (0.0, 1e-12, 1e-9, 1e-7, 1e-5, 1e-5, 1e-9, 0.0):
        P = P + step * rng.normal(size=P.shape)
        projected = []
        exact = mesh._exact

        def counted(points, faces):
            projected.append(len(faces))
            return exact(points, faces)

        mesh._exact = counted
        got = mesh.foot_points(P)
        del mesh._exact
        ref = TriangleMesh(V, S.faces).foot_points(P)
        for key in ref:
            assert np.array_equal(got[key], ref[key]), (step, key)
        looked.append(sum(projected))
    # and the gaps do leave faces out: after moves of at most 1e-7, fewer than 75% of the faces of the first query
    # are projected again (90% by the plane-and-disc bound alone)
    assert max(looked[1:4] + looked[6:]) < 0.75 * looked[0]


def _asked_again_as_new(V, F, queries):
    """Whether a mesh that remembers its last query answers every query as a mesh asked for the first time."""
    mesh = TriangleMesh(V, F)
    for P in queries:
        got, ref = mesh.foot_points(P), TriangleMesh(V, F).foot_points(P)
        if not all(np.array_equal(got[key], ref[key]) for key in ref):
            return False
    return True


def test_a_sliver_as_the_closest_face_is_no_reference_for_slacks():
    # every slack is measured against the row's closest face; a sliver's computed distance jumps by 1e-10 when the
    # point moves by 1e-15, so no slack can hold against it.  Here the sliver (1e-9 high) is the closest face and a
    # tiny proper face lies beside the point in its plane: the proper face's gap, remembered, left it out once the
    # sliver's distance had jumped above it, where a fresh mesh found it
    V = np.array([[0.0, 0.0, 0.0], [-0.10066704406773441, 0.680698397755312, 0.7256141106208012],
                  [-0.05033352284371452, 0.3403491985499396, 0.36280705550547826],
                  [-0.03177273000850973, 0.2148433640940704, 0.22901974953837176],
                  [-0.031772769201763175, 0.21484362911411814, 0.22902003204570084],
                  [-0.03177248543166471, 0.21484360350571088, 0.22901982715739092]])
    F = np.array([[0, 1, 2], [3, 5, 4]])
    path = np.array([[-0.0317727498134281, 0.2148434964501256, 0.2290198909075772],
                     [-0.03177274981342761, 0.21484349645012546, 0.22901989090757693],
                     [-0.03177274981343113, 0.21484349645012135, 0.22901989090755076],
                     [-0.0317727498134318, 0.21484349645012157, 0.22901989090754998]])
    assert _asked_again_as_new(V, F, [np.repeat(p[None], 64, axis=0) for p in path])
    # and random cases of the kind, a sliver under the point and a small proper face beside it in its plane or
    # just above it (before the fix, 14 and 5 of 200 of such cases answered differently)
    rng = np.random.default_rng(0)
    for _ in range(60):
        h, R, H, gap = 10 ** rng.uniform(-11, -8.5), 10 ** rng.uniform(-7, -3), 10 ** rng.uniform(-11, -7), \
            10 ** rng.uniform(-11.5, -7)
        xm = rng.uniform(0.1, 0.4)
        if rng.random() < 0.5:          # beside, in the sliver's plane
            small = [[xm - R, h * xm - gap, 0], [xm, h * xm - gap - 1.5 * R, 0], [xm + R, h * xm - gap, 0]]
        else:                           # above, parallel to it
            small = [[xm - R, -R, 2 * H + gap], [xm + R, -R, 2 * H + gap], [xm, R, 2 * H + gap]]
        turn = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        V = np.array([[0, 0, 0], [1, 0, 0], [0.5, h, 0]] + small, float) @ turn.T
        P = (np.array([xm, h * xm, 0.0]) + np.c_[np.zeros((64, 2)), rng.uniform(0.5, 1.5, 64) * H]) @ turn.T
        queries = [P]
        for step in (1e-15, 1e-14, 1e-15, 1e-14, 1e-13):
            queries.append(queries[-1] + step * rng.normal(size=P.shape))
        assert _asked_again_as_new(V, np.array([[0, 1, 2], [3, 4, 5]]), queries), (h, R, H, gap)


def test_a_sliver_keeps_its_bound_as_slack():
    # the face below the point is projected but farther than the face above it: a proper face's slack is its
    # gap (0.6325 - 0.51), a sliver's (1e-6 high) the plane-and-disc bound (0.49 off its plane, 0.1 outside the
    # disc of radius 0.5 around its centroid: 0.5001 - 0.51), as its computed distance may move by more than
    # the point does
    for height, slack in ((0.2, math.hypot(0.4, 0.49) - 0.51), (1e-6, math.hypot(0.49, 0.1) - 0.51)):
        V = np.array([[0, 0, 0], [1, 0, 0], [0.5, height, 0], [0, 0, 1], [1, 0, 1], [0.5, 1, 1]], float)
        mesh = TriangleMesh(V, np.array([[0, 1, 2], [3, 4, 5]]))
        out = mesh._project(np.array([[0.5, 0.6, 0.49]]), np.array([[0, 1]]), start=np.array([1]),
                            slack=np.full((1, 2), -np.inf), moved=np.zeros(1))
        assert out[2][0] == 1 and abs(out[3][0] - 0.51 ** 2) < 1e-15
        assert abs(out[5][0, 0] - slack) < 1e-5, (height, out[5])


def test_bad_queries_and_meshes_are_named():
    with pytest.raises(ValueError, match="vertices"):
        TriangleMesh(np.zeros((2, 3)), [[0, 1, 1]])
    with pytest.raises(ValueError, match="faces"):
        TriangleMesh(np.eye(3), [[0, 1, 3]])
    mesh = TriangleMesh(np.eye(3), [[0, 1, 2]])
    with pytest.raises(ValueError, match="NaN"):
        mesh.foot_points([[0, np.nan, 0]])


# ============================================================================ Jacobian of Eq. (18)
def small_problem(r1=0.02, r2=0.05, L=0.2):
    S = bump(size=1.0, resolution=30)
    gc = guiding.guiding_curves(S.vertices, S.faces, direction=[1.0, 0, 0], point=[0, 0, S.point(np.zeros((1, 2)))[0, 2]],
                                r1=r1, r2=r2, L=L, step=0.1)
    strips = [s for s in gc.strips if len(s.columns) >= 2]
    ini = initial_rulings(gc.bases, strips, r1, r2, L)
    lay = Layout(gc.bases, strips)
    return S, TriangleMesh(S.vertices, S.faces), lay, np.concatenate(ini.m), np.concatenate([b.normals for b in gc.bases])


@pytest.mark.parametrize("g1_term", ["envelope", "paper"])
@pytest.mark.parametrize("free", [(), ("L", "r1", "r2")])
def test_analytic_jacobian_equals_central_differences(g1_term, free):
    S, mesh, lay, m0, n0 = small_problem()
    obj = Objective(mesh, lay, n0, m0, 0.02, 0.05, 0.2, 5, [1, 1, 1, 1e-2, 0.1], free, None, g1_term)
    x = obj.pack(m0 + np.random.default_rng(1).normal(0, 0.003, m0.shape))
    Js = obj.jac(x).tocsc()
    # central differences along e_g = the sum of a group of columns no two of which share a row of J (Curtis,
    # Powell & Reid): every row of J e_g is one entry of J, so each entry is compared with a central difference
    # as column by column, and an entry J lacks or gets wrong shows in the difference along its group's e_g;
    # 15-75 groups instead of 180 columns
    rows = [set(Js.indices[Js.indptr[j]:Js.indptr[j + 1]]) for j in range(Js.shape[1])]
    groups, taken = [], []
    for j, rj in enumerate(rows):
        k = next((k for k, t in enumerate(taken) if not rj & t), len(groups))
        if k == len(groups):
            groups.append([])
            taken.append(set())
        groups[k].append(j)
        taken[k] |= rj
    assert sorted(j for g in groups for j in g) == list(range(len(x)))
    J = Js.toarray()
    JE, Jn = np.empty((J.shape[0], len(groups))), np.empty((J.shape[0], len(groups)))
    h = 1e-7
    for k, g in enumerate(groups):
        e = np.zeros(len(x))
        e[g] = 1.0
        JE[:, k] = J @ e
        Jn[:, k] = (obj.fun(x + h * e) - obj.fun(x - h * e)) / (2 * h)
    assert np.abs(JE - Jn).max() <= 1e-6 * np.abs(Jn).max()
    assert len(lay.g1_pairs) > 10 and len(x) > 100


def test_fixed_pattern_assembly_is_scipys_matrix_bit_for_bit():
    # entries with up to 6 repeats of a (row, column) pair: the sum of 3 or more depends on the order of adding
    rng = np.random.default_rng(7)
    shape = (300, 40)
    rows = rng.integers(0, shape[0], 5000)
    cols = rng.integers(0, 8, 5000) * 5
    pattern = None
    for trial in range(4):
        vals = rng.normal(size=len(rows)) * 10.0 ** rng.integers(-8, 8, len(rows))
        J, pattern = assemble(pattern, vals, rows, cols, shape)
        ref = sp.csr_matrix((vals, (rows, cols)), shape=shape)
        assert J.indices.dtype == ref.indices.dtype and np.array_equal(J.indptr, ref.indptr)
        assert np.array_equal(J.indices, ref.indices)
        assert np.array_equal(J.data.view(np.int64), ref.data.view(np.int64))
    assert max(len(g) for g, _ in pattern.repeats) > 0 and len(pattern.repeats) >= 3
    # a changed pattern is noticed and assembled afresh
    cols2 = cols.copy()
    cols2[0] += 1
    J2, pattern2 = assemble(pattern, vals, rows, cols2, shape)
    assert pattern2 is not pattern
    assert np.array_equal(J2.toarray(), sp.csr_matrix((vals, (rows, cols2)), shape=shape).toarray())


def test_rail_derivative_matrix_is_the_spline_derivative():
    tau = np.linspace(0, 1, 7)
    f = np.c_[np.sin(3 * tau), tau ** 3, np.cos(tau)]
    from scipy.interpolate import CubicSpline
    assert np.allclose(rail_derivative_matrix(tau) @ f, CubicSpline(tau, f, bc_type="natural")(tau, 1), atol=1e-12)


# ============================================================================ envelopes, Eqs. (5)-(6)
def test_envelope_of_a_translated_cone_is_its_two_tangent_lines():
    # cone axis along x from (0,0,r1) to (L,0,r2), translated along y: the envelope is the cone's
    # contact line with the plane z = 0 (and its mirror); the lower branch must lie in z = 0
    r1, r2, L = 0.3, 1.0, 2.5
    N = 6
    t = np.linspace(0, 1, N)[:, None]
    dz = r2 - r1
    ax = np.array([math.sqrt(L * L - dz * dz), 0.0, dz])
    a = np.c_[np.zeros(N), 4 * t[:, 0], np.full(N, r1)]
    b = a + ax
    env = envelope(a, b, r1, r2, n_s=7, n_t=11, side_hint=np.tile([0, 0, 1.0], (11, 1)))
    assert env["valid"].all()
    assert np.abs(env["points"][..., 2]).max() < 1e-12
    assert np.allclose(env["normals"], [0, 0, 1], atol=1e-12)
    # every envelope point is on its sphere: |x - y(s)| = r(s)
    s = env["s"]
    d = np.linalg.norm(env["points"] - env["axis_points"], axis=2)
    assert np.allclose(d, (1 - s) * r1 + s * r2, atol=1e-12)


def test_envelope_normal_satisfies_the_characteristic_conditions():
    rng = np.random.default_rng(0)
    ys = rng.normal(size=(50, 3)) * 2
    yt = rng.normal(size=(50, 3))
    n, ok = envelope_normal(ys, yt, 0.4, np.tile([0, 0, 1.0], (50, 1)))
    assert ok.sum() > 30
    n = n[ok]
    assert np.allclose(np.linalg.norm(n, axis=1), 1, atol=1e-12)
    assert np.allclose((n * ys[ok]).sum(1), 0.4, atol=1e-12)
    assert np.allclose((n * yt[ok]).sum(1), 0, atol=1e-12)


# ============================================================================ exact cases
def test_cylinder_patch_with_a_cylindrical_tool_is_exact():
    """Tool axes along the rulings (guiding curves = the circles): the plan is exact."""
    S = cylinder_patch(size=1.0, resolution=60)
    plan = plan_freeform(S.vertices, S.faces, direction=[0, 1, 0], point=[1, 0, 0], r1=0.05, r2=0.05, L=0.2)
    s = plan["summary"]
    size = S.size
    # Eq. (19) against the mesh
    assert s["strips"] >= 4
    assert max(abs(s["max_error"]), abs(s["min_error"])) <= 1e-6 * size
    assert s["max_kink_deg"] <= 0.01
    assert abs(s["axis_length_range"][0] - 0.2) < 1e-6 and abs(s["axis_length_range"][1] - 0.2) < 1e-6
    # against the exact cylinder: sphere centres at radius R + r (less at most the mesh's chord
    # sagitta h^2 / 8R, h = the arc per mesh cell), axes parallel to z
    h = (math.pi / 2) / 60
    for st in plan["strips"]:
        R = np.asarray(st["rulings"])
        rad = np.linalg.norm(R[..., :2], axis=2)
        assert np.abs(rad - 1.05).max() <= 1.01 * h * h / 8
        assert np.abs(R[:, 1, :2] - R[:, 0, :2]).max() < 1e-6
    assert s["colliding_rulings"] == 0


def test_parabolic_blade_guided_across_its_rulings_is_exact_and_verified_by_the_sweep():
    S = parabolic_blade(size=1.0, resolution=60)
    plan = plan_freeform(S.vertices, S.faces, direction=[1, 0, 0], point=[0, 0, 0], r1=0.03, r2=0.1, L=0.25)
    s = plan["summary"]
    assert max(abs(s["max_error"]), abs(s["min_error"])) < 5e-5
    assert s["max_kink_deg"] < 0.1
    v = verify_freeform(plan, tolerance=1e-3)
    # the swept tool never gouges the blade by more than the mesh's chord error, and leaves at most
    # a scallop between instants on the covered vertices
    assert v["sweep_min"] > -5e-5
    assert v["sweep_max_covered"] < 2e-3
    assert v["vertices_covered"] > 0.8 * v["vertices"]


def _least_in_balls_one_at_a_time(P, C, Rr, lists, k, out, idx):
    """The sweep check's search for a better sphere, one point at a time (what the vectorised search replaced)."""
    for n, cand in enumerate(lists):
        if len(cand) > k:
            cand = np.asarray(cand)
            v = np.linalg.norm(C[cand] - P[n], axis=1) - Rr[cand]
            j = int(np.argmin(v))
            if v[j] < out[n]:
                out[n], idx[n] = v[j], cand[j]


def _k_nearest_spheres_and_balls(tree, P, Rr, k):
    """The least |p - c| - r over each point's k nearest centres, that sphere, and the ball list of every centre
    that could still beat it (within the value + the largest radius)."""
    d, i = tree.query(P, k=k)
    val = d - Rr[i]
    best = np.argmin(val, axis=1)
    rows = np.arange(len(P))
    out, idx = val[rows, best], i[rows, best]
    return out, idx, tree.query_ball_point(P, out + Rr.max() + 1e-12)


@pytest.mark.parametrize("chunk", [7, 500, 1_000_000])
def test_sphere_search_of_all_points_at_once_is_the_search_of_one_at_a_time(chunk):
    from scipy.spatial import cKDTree

    from flank_addon.methods.freeform_g1.planner import _least_in_balls

    rng = np.random.default_rng(3)
    C = rng.uniform(-1, 1, (2000, 3))
    Rr = rng.uniform(0.01, 0.4, 2000)
    C[1200:1220], Rr[1200:1220] = C[100:120], Rr[100:120]    # duplicated spheres
    P = np.r_[rng.uniform(-1.2, 1.2, (300, 3)), C[100:120] + 1e-3]
    tree = cKDTree(C)
    out0, idx0, lists = _k_nearest_spheres_and_balls(tree, P, Rr, 5)
    assert 100 < sum(len(c) > 5 for c in lists) < len(P)     # both kinds of row
    ref_out, ref_idx = out0.copy(), idx0.copy()
    _least_in_balls_one_at_a_time(P, C, Rr, lists, 5, ref_out, ref_idx)
    out, idx = out0.copy(), idx0.copy()
    _least_in_balls(P, C, Rr, lists, 5, out, idx, chunk=chunk)
    assert np.array_equal(out.view(np.int64), ref_out.view(np.int64)) and np.array_equal(idx, ref_idx)
    assert (out < out0).sum() > 50
    # a tie: two equal big spheres (centres 5 and 50) beat the small one nearest to the point; the first wins
    C2 = np.zeros((60, 3))
    C2[:, 0] = 5.0 + np.arange(60)
    Rr2 = np.full(60, 0.001)
    C2[7] = (0.1, 0, 0)
    C2[5] = C2[50] = (0, 0.5, 0)
    Rr2[5] = Rr2[50] = 0.45
    tree2 = cKDTree(C2)
    P2 = np.zeros((1, 3))
    d2, i2 = tree2.query(P2, k=1)
    o2, j2 = np.atleast_1d(d2 - Rr2[i2]), np.atleast_1d(i2)
    assert j2[0] == 7
    lists2 = tree2.query_ball_point(P2, o2 + Rr2.max() + 1e-12)
    assert sorted(lists2[0]) == [5, 7, 50]
    _least_in_balls(P2, C2, Rr2, lists2, 1, o2, j2, chunk=chunk)
    assert j2[0] == 5 and abs(o2[0] - 0.05) < 1e-15
    # and against every sphere: the least |p - c| - r (the k nearest centres' values come from the kd-tree's
    # own arithmetic, so they may differ in the last bit)
    brute = (np.linalg.norm(P[:, None, :] - C[None, :, :], axis=2) - Rr).min(axis=1)
    assert np.abs(out - brute).max() <= 1e-15
    # a NaN radius leaves its rows alone (as one at a time), no rows and k = 0 are no special cases
    Rr3 = Rr.copy()
    Rr3[::7] = np.nan
    for kk in (0, 5):
        ref_out, ref_idx, out, idx = out0.copy(), idx0.copy(), out0.copy(), idx0.copy()
        _least_in_balls_one_at_a_time(P, C, Rr3, lists, kk, ref_out, ref_idx)
        _least_in_balls(P, C, Rr3, lists, kk, out, idx, chunk=chunk)
        assert np.array_equal(out.view(np.int64), ref_out.view(np.int64)) and np.array_equal(idx, ref_idx)
    empty_out, empty_idx = np.zeros(0), np.zeros(0, np.int64)
    _least_in_balls(np.zeros((0, 3)), C, Rr, [], 5, empty_out, empty_idx, chunk=chunk)


@pytest.mark.parametrize("cap", [5, 40, 256])
def test_least_sphere_values_are_those_of_every_sphere(cap):
    """The sweep check's least |p - c| - r: the nearest centres first, ball lists only where they may miss one.
    The same values as the k nearest followed by a ball list for every point, bit for bit, and as all spheres."""
    from scipy.spatial import cKDTree

    from flank_addon.methods.freeform_g1.planner import _centres_to_ask, _least_in_balls, least_sphere_values

    rng = np.random.default_rng(11)
    C = rng.uniform(-1, 1, (3000, 3))
    Rr = rng.uniform(0.01, 0.05, 3000)
    Rr[::97] = 0.6                                  # a few big spheres that reach past many nearer small ones
    C[2000:2010], Rr[2000:2010] = C[10:20], Rr[10:20]   # duplicated spheres
    P = np.r_[rng.uniform(-1.1, 1.1, (700, 3)), C[10:20] + 1e-3]
    out, idx = least_sphere_values(P, C, Rr, k=5, cap=cap)
    # the search before: the k nearest, then every point's ball list
    tree = cKDTree(C)
    ref_out, ref_idx, lists = _k_nearest_spheres_and_balls(tree, P, Rr, 5)
    rows = np.arange(len(P))
    _least_in_balls(P, C, Rr, lists, 5, ref_out, ref_idx)
    assert np.array_equal(out.view(np.int64), ref_out.view(np.int64))
    brute = np.linalg.norm(P[:, None, :] - C[None, :, :], axis=2) - Rr
    assert np.abs(out - brute.min(axis=1)).max() <= 1e-15
    # the sphere named gives the value; between equal spheres the kd-tree's order decides, as it did before
    assert np.abs(brute[rows, idx] - out).max() <= 1e-15
    tie = idx != ref_idx
    assert set(idx[tie]) | set(ref_idx[tie]) <= set(range(10, 20)) | set(range(2000, 2010))
    assert np.array_equal(idx, ref_idx) or np.array_equal(C[idx], C[ref_idx]) and np.array_equal(Rr[idx], Rr[ref_idx])
    assert (idx % 97 == 0).sum() > 100                 # the big spheres do win
    # how many nearest centres it asked for: at least k, at most the cap, and about what most points need
    kk = _centres_to_ask(tree, P, Rr, 5, Rr.max() + 1e-12, cap=cap)
    need = tree.query_ball_point(P, out + Rr.max() + 1e-12, return_length=True)
    assert 5 <= kk <= cap and (kk == cap or 0.85 <= (need <= kk).mean() < 1.0)
    # fewer spheres than k, one sphere, no points
    o2, j2 = least_sphere_values(P[:4], C[:3], Rr[:3], k=24)
    assert np.allclose(o2, brute[:4, :3].min(axis=1), rtol=0, atol=1e-15)
    assert np.array_equal(j2, np.argmin(brute[:4, :3], axis=1))
    o1, j1 = least_sphere_values(P[:4], C[:1], Rr[:1], k=24)
    assert np.allclose(o1, brute[:4, 0], rtol=0, atol=1e-15) and (j1 == 0).all()
    o0, j0 = least_sphere_values(np.zeros((0, 3)), C, Rr)
    assert o0.shape == (0,) and j0.shape == (0,)
    # a cap below k, or of nothing: one centre at least, the rest by ball lists, the same values
    for k_, cap_ in ((500, 3), (0, 0), (5, 0)):
        oc, jc = least_sphere_values(P[:50], C, Rr, k=k_, cap=cap_)
        assert np.array_equal(oc.view(np.int64), out[:50].view(np.int64))


def test_optimum_is_a_local_minimum_of_eq_18():
    S, mesh, lay, m0, n0 = small_problem()
    from flank_addon.methods.freeform_g1.planner import optimize
    t = None
    res = optimize(mesh, lay, m0, n0, 0.02, 0.05, 0.2, 8, [1, 1, 0.1, 1e-4, 0.01], (), 1, 200, tangents=t)
    obj = Objective(mesh, lay, res["normals"], m0, 0.02, 0.05, 0.2, 8, [1, 1, 0.1, 1e-4, 0.01])
    f0 = (obj.fun(obj.pack(res["m"])) ** 2).sum()
    rng = np.random.default_rng(5)
    for _ in range(20):
        dm = rng.normal(0, 1e-4, res["m"].shape)
        assert (obj.fun(obj.pack(res["m"] + dm)) ** 2).sum() >= f0 * (1 - 1e-9)
    # and the optimiser lowered Eq. (18) from the start
    assert f0 < (obj.fun(obj.pack(m0)) ** 2).sum()


# ============================================================================ G1 against accuracy
def test_g1_weight_lowers_kinks_on_a_bump():
    S = bump(size=1.0, resolution=60, height=0.06, width=0.25)
    common = dict(direction=[1, 0, 0], point=S.point(np.zeros((1, 2)))[0], r1=0.01, r2=0.03, L=0.1, n_columns=12,
                  n_ruling_samples=12)
    plain = plan_freeform(S.vertices, S.faces, weights=[1, 1, 0, 1e-4, 0.01], **common)
    g1 = plan_freeform(S.vertices, S.faces, weights=[1, 1, 1, 1e-4, 0.01], **common)
    assert g1["summary"]["max_kink_deg"] < 0.8 * plain["summary"]["max_kink_deg"]
    assert g1["summary"]["mean_kink_deg"] < 0.8 * plain["summary"]["mean_kink_deg"]
    # the kinks reported are the envelope normals' angles: recompute them from the plan file
    k = np.concatenate([x["kink_deg"] for x in freeform_kinks(g1)])
    assert abs(k.max() - g1["summary"]["max_kink_deg"]) < 1e-9


# ============================================================================ plan file and CLI
def test_plan_file_round_trip_and_validation(tmp_path):
    S = plane_patch(size=1.0, resolution=16)
    plan = plan_freeform(S.vertices, S.faces, direction=[1, 0, 0], r1=0.02, r2=0.06, L=0.2, n_columns=6,
                         n_ruling_samples=6)
    p = tmp_path / "plan.json"
    write_plan(p, plan)
    back = read_plan(p)
    assert back["surface"]["kind"] == "mesh" and back["method"] == "freeform-g1-cone"
    st = back["strips"][0]
    assert np.asarray(st["rulings"]).shape[1:] == (2, 3) and len(st["radii"]) == 2
    assert {"max_kink_deg", "mean_kink_deg"} <= set(back["summary"])
    # a plane is machined exactly by a cone lying on it
    assert max(abs(back["summary"]["max_error"]), abs(back["summary"]["min_error"])) < 1e-9
    bad = json.loads(json.dumps(plan))
    bad["strips"][0]["rulings"][0][0][1] = float("nan")
    with pytest.raises(PlanError, match="rulings"):
        validate_plan(bad)
    bad = json.loads(json.dumps(plan))
    bad["surface"]["faces"][0][0] = 10 ** 6
    with pytest.raises(PlanError, match="faces"):
        validate_plan(bad)
    bad = json.loads(json.dumps(plan))
    del bad["strips"][1]["columns"]
    with pytest.raises(PlanError, match=r"strips\[1\].columns must hold one guiding-curve index >= 0 per ruling"):
        validate_plan(bad)
    bad = json.loads(json.dumps(plan))
    bad["summary"]["max_error"] = bad["summary"]["min_error"] - 1.0
    with pytest.raises(PlanError, match="summary.max_error .* is below summary.min_error"):
        validate_plan(bad)
    env = freeform_envelopes(back)
    assert len(env) == len(back["strips"]) and np.isfinite(env[0]["deviation"]).all()
    dev, strip, inside = sweep_deviation(back)
    assert dev[inside].min() > -1e-9


_SMALL_PLAN = {}


def _small_freeform_plan():
    if not _SMALL_PLAN:
        S = plane_patch(size=1.0, resolution=12)
        _SMALL_PLAN["plan"] = json.loads(json.dumps(plan_freeform(S.vertices, S.faces, direction=[1, 0, 0], r1=0.02,
                                                                  r2=0.06, L=0.2, n_columns=5, n_ruling_samples=5)))
    return json.loads(json.dumps(_SMALL_PLAN["plan"]))


@pytest.mark.parametrize("mutate, message", [
    (lambda p: p["strips"][0]["rulings"][0][1].__setitem__(0, 1e300),
     r"strips\[0\].rulings reach 1e\+300 from the surface, over 1e\+06 times its size"),
    (lambda p: p["strips"][0]["rulings"][0][1].__setitem__(0, "1"), r"strips\[0\].rulings must hold numbers only"),
    (lambda p: p["surface"]["vertices"][0].__setitem__(0, 1e300), r"surface.vertices reach 1e\+300, over 1e\+12"),
    (lambda p: p.update(strips=[]), r"strips must be a list of at least one strip"),
    (lambda p: p["surface"].update(vertices=[[0.0, 0.0, 0.0]] * len(p["surface"]["vertices"])),
     r"surface.faces have no area"),
    (lambda p: p["strips"][0].update(radii=[0.0, 0.0]), r"strips\[0\].radii are both 0"),
    (lambda p: p["strips"][0].update(shank_radius=-1.0), r"strips\[0\].shank_radius must be >= 0"),
    (lambda p: p["strips"][0].update(axis_end=[0.0, 0.0, 1e300]), r"strips\[0\].axis_end .* is over 1e\+06 times "
                                                                  r"the surface's size"),
])
def test_freeform_plan_validation_names_the_field(mutate, message):
    """A free-form plan's fields are bounded by its surface's size, as a rotor plan's by its outer radius: a
    ruling at 1e300 passed and made verify and the exports fail with a traceback, degenerate faces ran verify for
    minutes, and strings in a field passed as numbers."""
    plan = _small_freeform_plan()
    validate_plan(plan)
    mutate(plan)
    with pytest.raises(PlanError, match=message):
        validate_plan(plan)


@pytest.mark.parametrize("kw, msg", [
    (dict(r1=-0.1, r2=0.05, L=0.2), "must be >= 0"),
    (dict(r1=float("nan"), r2=0.05, L=0.2), "r1"),
    (dict(r1=0.01, r2=0.05, L=0.03), "L = 0.03 must exceed"),
    (dict(r1=0.01, r2=0.05, L=0.2, engagement=0.0), "engagement"),
    (dict(r1=0.01, r2=0.05, L=0.2, weights=[1, 1, -1, 0, 0]), "weights"),
    (dict(r1=0.01, r2=0.05, L=0.2, weights=[0, 0, 0, 0, 0]), r"approximation weight w2 = 0 must be > 0"),
    (dict(r1=0.01, r2=0.05, L=0.2, weights=[1, 0, 1, 1e-4, 1e-3]), r"approximation weight w2 = 0 must be > 0"),
    (dict(r1=0.01, r2=0.05, L=5.0), "no strip"),
])
def test_bad_input_is_named(kw, msg):
    S = plane_patch(size=1.0, resolution=10)
    with pytest.raises(ValueError, match=msg):
        plan_freeform(S.vertices, S.faces, direction=[1, 0, 0], **kw)


def test_only_the_weights_ratios_matter():
    # Eq. (18)'s optimum depends on the weights' ratios alone: the defaults scaled by 1e-12 or 1e300 plan as the
    # defaults do (they used to stop at the start, or overflow, and return the unoptimised layout unremarked)
    S = bump(size=1.0, resolution=30, height=0.06, width=0.25)
    common = dict(direction=[1, 0, 0], point=S.point(np.zeros((1, 2)))[0], r1=0.01, r2=0.03, L=0.1, n_columns=6,
                  n_ruling_samples=8)
    base = np.array(DEFAULT_WEIGHTS)
    ref = plan_freeform(S.vertices, S.faces, weights=base, **common)["summary"]
    # the optimiser moved the layout: the overcut is at least a fifth smaller than the start's
    assert ref["min_error"] > 0.8 * ref["initial_min_error"]
    for scale in (1e-12, 1e300):
        plan = plan_freeform(S.vertices, S.faces, weights=base * scale, **common)
        got = plan["summary"]
        assert plan["optimization"]["weights"]["approx"] == scale        # the plan keeps the weights as given
        for key in ("max_error", "min_error", "max_kink_deg", "mean_kink_deg"):
            assert abs(got[key] - ref[key]) <= 1e-6 * max(abs(ref[key]), 1e-3), (scale, key, got[key], ref[key])


def test_a_plan_in_other_units_is_the_same_plan():
    # Eq. (18)'s terms are dimensionless and its unknowns lengths: the same bump and tool 1000 times larger (metres
    # -> millimetres) take as many evaluations and give the same figures.  scipy's gtol test reads the gradient
    # unscaled, so a fixed gtol stopped the larger plan after 9 evaluations while the smaller one ran 100
    S = bump(size=1.0, resolution=40, height=0.06, width=0.25)
    P0 = S.point(np.zeros((1, 2)))[0]
    plans = [plan_freeform(S.vertices * k, S.faces, direction=[1, 0, 0], point=P0 * k, r1=0.01 * k, r2=0.03 * k,
                           L=0.1 * k, n_columns=8, n_ruling_samples=10) for k in (1.0, 1000.0)]
    assert plans[0]["optimization"]["evaluations"] == plans[1]["optimization"]["evaluations"]
    small, large = plans[0]["summary"], plans[1]["summary"]
    for key in ("max_error", "min_error"):
        assert abs(large[key] / 1000.0 - small[key]) <= 1e-4 * abs(small[key]), key
    assert abs(large["max_kink_deg"] - small["max_kink_deg"]) <= 1e-4 * small["max_kink_deg"]


def test_direction_along_the_normal_is_refused():
    S = plane_patch(size=1.0, resolution=10)
    with pytest.raises(ValueError):
        plan_freeform(S.vertices, S.faces, direction=[0, 0, 1], r1=0.01, r2=0.05, L=0.2)


def test_cli_plan_freeform_verify_and_export(tmp_path):
    from flank_addon.io.mesh_files import write_stl
    S = parabolic_blade(size=10.0, resolution=30)
    mesh = tmp_path / "blade.stl"
    write_stl(str(mesh), S.vertices, S.faces)
    out = tmp_path / "plan.json"
    def run(*a):
        """The CLI's main() in this process: its exit code and what it printed (test_plan_cli runs the
        ``python -m flank_addon`` entry point itself)."""
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(list(a))
        return subprocess.CompletedProcess(a, code, out.getvalue(), err.getvalue())

    r = run("plan", "freeform", "--mesh", str(mesh), "--direction", "1,0,0", "--point", "0,0,0", "--tool-r1", "0.3",
            "--tool-r2", "1", "--tool-length", "2.5", "--weights", "1,1,0.1,0.0001,0.01", "--columns", "10",
            "--samples", "10", "--out", str(out), "--json")
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    plan = read_plan(out)
    assert summary["max_kink_deg"] == plan["summary"]["max_kink_deg"]
    span = float(np.linalg.norm(np.ptp(S.vertices, axis=0)))
    for option in ("--tool-length", "--shank-length"):      # 1e300 overflowed, or raised an IndexError
        r = run("plan", "freeform", "--mesh", str(mesh), "--direction", "1,0,0", "--point", "0,0,0", "--tool-r1",
                "0.3", "--tool-r2", "1", "--tool-length", "2.5", option, "1e300", "--out", str(tmp_path / "x.json"))
        assert r.returncode == 2 and f"{option} 1e+300 is over 100 times the mesh's size {span:.6g}" in r.stderr
    assert not (tmp_path / "x.json").exists()
    r = run("verify", str(out), "--json")
    assert r.returncode == 0, r.stderr
    v = json.loads(r.stdout)
    assert abs(v["eq19_max"] - plan["summary"]["max_error"]) < 1e-12
    cl = tmp_path / "p.apt"
    r = run("export", str(out), "--cl", str(cl))
    assert r.returncode == 0, r.stderr
    gotos = [ln for ln in cl.read_text().splitlines() if ln.startswith("GOTO/")]
    assert len(gotos) == sum(len(s["rulings"]) for s in plan["strips"])
    # the tip point lies on the axis behind the tip sphere's centre by r1 * (r2 - r1) / L
    x = np.array([float(v) for v in gotos[0][5:].split(",")])
    a, b = np.asarray(plan["strips"][0]["rulings"][0])
    u = (b - a) / np.linalg.norm(b - a)
    assert np.allclose(x[3:], u, atol=1e-9)
    assert np.allclose(x[:3], a - 0.3 * 0.7 / 2.5 * u, atol=1e-9)
    r = run("plan", "freeform", "--mesh", str(mesh), "--direction", "1,0,nan", "--tool-r1", "0.3", "--tool-r2", "1",
            "--tool-length", "2.5", "--out", str(out))
    assert r.returncode == 2 and "--direction" in r.stderr and "Traceback" not in r.stderr


# ============================================================================ planner options and §7.2
def test_partial_engagement_plans_narrower_strips_and_checks_the_idle_tip():
    S = plane_patch(size=1.0, resolution=16)
    full = plan_freeform(S.vertices, S.faces, direction=[1, 0, 0], r1=0.02, r2=0.06, L=0.2, n_columns=6,
                         n_ruling_samples=6)
    half = plan_freeform(S.vertices, S.faces, direction=[1, 0, 0], r1=0.02, r2=0.06, L=0.2, n_columns=6,
                         n_ruling_samples=6, engagement=0.5)
    # Fig. 18: the upper half of the tool (r 0.04 .. 0.06 over L/2) cuts, so the spacing halves
    assert half["guiding"]["spacing"] == pytest.approx(math.sqrt(0.1 ** 2 - 0.02 ** 2), rel=1e-12)
    assert half["summary"]["strips"] >= 2 * full["summary"]["strips"] - 1
    assert half["strips"][0]["radii"][0] == pytest.approx(0.04, rel=1e-9)
    assert half["tool"]["length"] == pytest.approx(0.2, rel=1e-9) and half["tool"]["engagement"] == 0.5
    # on a plane the idle tip (a cone tapering away from it) never touches it
    assert half["summary"]["colliding_rulings"] == 0


def test_shank_collision_on_a_concave_surface_matches_a_direct_check():
    """Inside a tube: axes along the tube (a neck thinner than the tool) never collide; axes across it
    (chords) run their shank straight into the curved wall."""
    S = cylinder_patch(size=1.0, resolution=40, radius=0.3, angle=math.pi)
    V, F = S.vertices, S.faces[:, ::-1]                 # normals inwards: the tool is inside the tube
    mesh = TriangleMesh(V, F)
    counts = {}
    for label, direction in (("along", [0, 1, 0]), ("across", [0, 0, 1])):
        plan = plan_freeform(V, F, direction=direction, point=[0.3, 0, 0], r1=0.02, r2=0.02, L=0.15, n_columns=8,
                             n_ruling_samples=6, shank_length=0.1, shank_radius=0.015)
        for st in plan["strips"]:
            R = np.asarray(st["rulings"])
            u = (R[:, 1] - R[:, 0]) / np.linalg.norm(R[:, 1] - R[:, 0], axis=1, keepdims=True)
            pts = R[:, 1][:, None, :] + np.linspace(0, 0.1, 200)[None, 1:, None] * u[:, None, :]
            d = mesh.foot_points(pts.reshape(-1, 3), exact=True)["distance"].reshape(len(R), -1)
            direct = np.flatnonzero((d < 0.015 - 1e-6).any(1))
            assert set(direct) == set(st["colliding_rulings"])
        counts[label] = plan["summary"]["colliding_rulings"]
    assert counts["along"] == 0 and counts["across"] > 0


def test_tool_length_as_a_variable_makes_the_axes_rigid_at_the_new_length():
    S = bump(size=1.0, resolution=40, height=0.06, width=0.25)
    plan = plan_freeform(S.vertices, S.faces, direction=[1, 0, 0], r1=0.01, r2=0.03, L=0.1, n_columns=8,
                         n_ruling_samples=8, optimize_tool=("L",))
    L_new = plan["tool"]["length"]
    lo, hi = plan["summary"]["axis_length_range"]
    assert hi - lo < 1e-3 * L_new and abs(0.5 * (lo + hi) - L_new) < 1e-3 * L_new
    assert plan["optimization"]["free_tool_variables"] == ["L"]


# error bounds: the gear flank is developable (1 % of L); on the saddle (principal radii 1.5) a straight
# axis of length L spans a normal section of sagitta L^2 / (8 R) = 1.2e-3
@pytest.mark.parametrize("name, direction, bound", [("gear_flank", None, 0.01 * 0.12),
                                                    ("saddle", [1, 0, 0], 1.5 * 0.12 ** 2 / (8 * 1.5))])
def test_gear_flank_and_saddle_plan_with_small_errors(name, direction, bound):
    S = make_surface(name, size=1.0, resolution=40)
    c = S.point(S.uv.mean(0, keepdims=True))[0]
    if direction is None:                        # across the central ruling, in the tangent plane
        from flank_addon.geometry.freeform_surfaces import gear_ruling
        rul = gear_ruling(S.uv.mean(0, keepdims=True), base_radius=2.0)[0]
        direction = np.cross(S.normal(S.uv.mean(0, keepdims=True))[0], rul)
    plan = plan_freeform(S.vertices, S.faces, direction=direction, point=c, r1=0.01, r2=0.03, L=0.12, n_columns=10,
                         n_ruling_samples=10)
    s = plan["summary"]
    assert s["strips"] >= 3
    assert max(abs(s["max_error"]), abs(s["min_error"])) < bound
    v = verify_freeform(plan)
    assert v["sweep_min"] > -2 * bound
    assert abs(v["eq19_max"] - s["max_error"]) < 1e-12


def test_a_constant_vector_field_plans_like_the_single_direction():
    S = plane_patch(size=1.0, resolution=16)
    kw = dict(r1=0.02, r2=0.06, L=0.2, n_columns=6, n_ruling_samples=6)
    one = plan_freeform(S.vertices, S.faces, direction=[1, 0, 0], point=[0, 0, 0], **kw)
    fld = plan_freeform(S.vertices, S.faces, field_vectors=np.tile([1.0, 0, 0], (len(S.vertices), 1)), point=[0, 0, 0],
                        **kw)
    assert len(one["strips"]) == len(fld["strips"])
    for a, b in zip(one["strips"], fld["strips"]):
        assert np.allclose(a["rulings"], b["rulings"], atol=1e-9)


def test_points_beyond_the_border_are_marked_and_left_out_of_eq_19():
    S = plane_patch(size=1.0, resolution=8)
    mesh = TriangleMesh(S.vertices, S.faces)
    P = np.array([[0.1, 0.2, 0.3], [0.5, 0.0, 0.05], [0.7, 0.2, 0.01], [0.49, 0.49, 0.3]])
    fp = mesh.foot_points(P)
    assert fp["off_surface"].tolist() == [False, False, True, False]
    from flank_addon.methods.freeform_g1.planner import ruling_errors
    a = np.array([[0.0, 0.0, 0.05], [0.3, 0.0, 0.05]])
    b = a + [0.45, 0.0, 0.0]                   # the second axis ends 0.25 beyond the edge x = 0.5
    e = ruling_errors(mesh, a, b, 0.05, 0.05, K=10)
    assert np.isfinite(e[0]).all() and np.abs(e[0]).max() < 1e-12
    x = 0.3 + 0.45 * np.linspace(0, 1, 10)
    assert (np.isnan(e[1]) == (x > 0.5 + 1e-12)).all()


def test_flip_normals_machines_the_other_side():
    S = parabolic_blade(size=1.0, resolution=30)
    kw = dict(direction=[1, 0, 0], point=[0, 0, 0], r1=0.03, r2=0.1, L=0.25, n_columns=8, n_ruling_samples=8)
    top = plan_freeform(S.vertices, S.faces, **kw)
    under = plan_freeform(S.vertices, S.faces, flip_normals=True, **kw)
    zt = np.asarray(top["strips"][0]["rulings"])[..., 2]
    zu = np.asarray(under["strips"][0]["rulings"])[..., 2]
    x = np.asarray(top["strips"][0]["rulings"])[..., 0]
    surf = x ** 2 / (2 * 0.6)
    assert (zt > surf).all() and (np.asarray(under["strips"][0]["rulings"])[..., 2]
                                  < np.asarray(under["strips"][0]["rulings"])[..., 0] ** 2 / 1.2).all()
    assert zu.mean() < zt.mean()


def test_measured_kinks_at_the_rulings_are_the_g1_residuals_of_the_optimiser():
    from flank_addon.methods.freeform_g1.planner import kinks_at_rulings, rails
    S, mesh, lay, m0, n0 = small_problem()
    obj = Objective(mesh, lay, n0, m0, 0.02, 0.05, 0.2, 5, [1, 1, 1, 1e-4, 0.01])
    f = obj.fun(obj.pack(m0))
    R, K = lay.n_rulings, 5
    g1 = f[R + R * K:R + R * K + 3 * len(lay.g1_pairs)].reshape(-1, 3) / obj.c[2]
    angle = np.degrees(2 * np.arcsin(np.linalg.norm(g1, axis=1) / 2))
    a, b = rails(m0, n0, lay, 0.02, 0.05)
    ab = [(a[lay.ruling_start[k]:lay.ruling_start[k + 1]], b[lay.ruling_start[k]:lay.ruling_start[k + 1]])
          for k in range(len(lay.strip_a))]
    kinks = kinks_at_rulings(mesh, ab, lay.strip_columns, 0.02, 0.05, sub=3)
    measured = np.concatenate([k["kink_deg"][k["at_ruling"]] for k in kinks])
    assert len(measured) == len(angle)
    assert np.allclose(np.sort(measured), np.sort(angle), atol=1e-7)
    # between the rulings the boundary is sampled too, and the kink there is of the same size
    between = np.concatenate([k["kink_deg"][~k["at_ruling"]] for k in kinks])
    assert len(between) >= len(measured) and between.max() < 2 * measured.max() + 1.0
