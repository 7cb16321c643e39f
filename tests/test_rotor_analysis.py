"""Mesh -> rotor analysis on built-in rotors in random placements, plus rejection of non-helical meshes."""
import zlib

from scipy.spatial import cKDTree

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from flank_addon.geometry.rotor_analysis import (NotHelicalError, _order_along, _weld, _within_of_polyline, analyze_mesh,
                                                 axis_screw_velocity, vertex_normals, weld_mesh)
from flank_addon.geometry.rotors import builtin_by_name
from helpers import cad_like, irregular_mesh, profile_hausdorff


def uv_sphere(n=48):
    th = np.linspace(0, np.pi, n)[1:-1]
    ph = np.linspace(0, 2 * np.pi, 2 * n, endpoint=False)
    T, P = np.meshgrid(th, ph, indexing="ij")
    v = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    m = 2 * n
    i = np.arange(len(th) - 1)[:, None] * m
    j = np.arange(m)[None, :]
    a, b = i + j, i + (j + 1) % m
    f = np.concatenate([np.stack([a, b, b + m], -1).reshape(-1, 3), np.stack([a, b + m, a + m], -1).reshape(-1, 3)])
    top, bot = len(v), len(v) + 1
    v = np.vstack([v, [[0, 0, 1], [0, 0, -1]]])
    f = np.vstack([f, np.stack([np.full(m, top), (np.arange(m) + 1) % m, np.arange(m)], -1),
                   np.stack([np.full(m, bot), (len(th) - 1) * m + np.arange(m),
                             (len(th) - 1) * m + (np.arange(m) + 1) % m], -1)])
    return v, f


# every profile kind, both hands and both lobe counts (males right-handed with 4 lobes, females left-handed
# with 6); the analysis takes the same path for the other two built-ins
@pytest.mark.parametrize("name", ["nilson-male", "srm_a-female", "asymmetric-male", "asymmetric-female"])
def test_recovers_builtin_rotor_in_random_placement(name):
    rotor = builtin_by_name(name)
    R = rotor.profile.outer_radius()
    # 3000 vertices a ring (more than the analysis' 2048 profile points, as a fine CAD export has): every
    # asserted figure below is measured >= 10x inside its bound here, as with the 6000 of cad_like's default
    v, f = cad_like(rotor, n_profile=3000, n_axial=40)
    rng = np.random.default_rng(zlib.crc32(name.encode()))      # the same placement in every process
    rot = Rotation.random(random_state=rng.integers(1 << 30)).as_matrix()
    shift = rng.uniform(-200, 200, 3)
    mm = 40.0  # scale R = 1 to 40 mm
    world = (v @ rot.T) * mm + shift
    a = analyze_mesh(world, f)
    d_true = rot @ [0.0, 0.0, 1.0]
    angle = np.degrees(np.arccos(min(1.0, abs(a.axis_direction @ d_true))))
    w = shift - a.axis_point
    offset = np.linalg.norm(w - (w @ a.axis_direction) * a.axis_direction) / (mm * R)
    assert angle < 0.01
    assert offset < 1e-4
    assert abs(a.v0 / (rotor.v0 * mm) - 1) < 1e-4
    assert a.handedness == rotor.handedness
    assert a.lobes == rotor.lobes and len(a.flanks) == 2 * rotor.lobes
    assert abs(a.outer_radius / (mm * R) - 1) < 1e-4
    # profile vs truth: true profile -> world -> analysis rotor frame -> screwed into z = 0
    hausdorff = profile_hausdorff(a, rotor, lambda p: (p @ rot.T) * mm + shift) / (mm * R)
    assert hausdorff < 1e-4
    # to_world is rigid and maps the rotor-frame axis onto the found axis
    T = np.asarray(a.to_world)
    assert np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-12)
    assert np.allclose(T[:3, 2], a.axis_direction)


def test_flanks_cover_profile_in_order():
    a = analyze_mesh(*builtin_by_name("asymmetric-female").mesh(n_profile=3000, n_axial=30))
    n = len(a.profile)
    assert len(a.profile) >= 720
    starts = [s for s, _ in a.flanks]
    ends = [e for _, e in a.flanks]
    assert starts[0] == 0 and ends[-1] == n and all(e == s for e, s in zip(ends[:-1], starts[1:]))
    r = np.linalg.norm(a.profile, axis=1)
    for k, (s, e) in enumerate(a.flanks):
        # tip -> bottom flanks descend in radius, bottom -> tip flanks ascend
        ends_r = r[s % n], r[e % n]
        assert (ends_r[0] > ends_r[1]) if k % 2 == 0 else (ends_r[0] < ends_r[1])


def test_vertex_curvature_classes_match_the_true_surface(female):
    rotor, surf = female                            # the exact surface's foot-point tables are shared
    v, f = rotor.mesh(n_profile=1440, n_axial=96)   # Blender's default resolution
    a = analyze_mesh(v, f)
    K, cls = a.vertex_curvature(v)
    # truth: classify the exact surface at each side vertex's own profile parameter
    side = (v[:, 2] > 1e-9) & (v[:, 2] < rotor.length - 1e-9)
    u = surf.foot_points(v[side]).u
    true_cls, true_K = surf.classify(u), surf.curvatures(u)["K"]
    # where the exact surface is clearly curved the classes must agree; next to G1 joins of
    # cylindrical pieces (K = 0) a C2 spline through the vertices rings, so those are not judged
    clear = np.abs(true_K) > 1e-2
    agree = np.mean(cls[side][clear] == true_cls[clear])
    assert clear.mean() > 0.7 and agree > 0.995, f"{agree:.2%} of clearly curved vertices agree"
    close = np.abs(K[side][clear] - true_K[clear]) <= 0.05 * np.abs(true_K[clear])
    assert close.mean() > 0.98, f"Gaussian curvature within 5 % at only {close.mean():.1%} of vertices"
    # Bizzarri, Bo & Bartoň §3.1: the female flanks consist mainly of hyperbolic points
    assert np.mean(true_cls == -1) > 0.5


@pytest.mark.parametrize("n_profile, n_axial", [(1440, 96), (700, 40)])
def test_rings_smaller_than_profile_sampling(n_profile, n_axial):
    """Rings with fewer vertices than the analysis' profile points must not produce a zigzag profile."""
    rotor = builtin_by_name("asymmetric-female")
    a = analyze_mesh(*rotor.mesh(n_profile=n_profile, n_axial=n_axial))
    assert profile_hausdorff(a, rotor, lambda p: p) < 1e-4
    assert abs(a.v0 / rotor.v0 - 1) < 1e-5


def test_irregular_vertices_without_rings():
    """Every side vertex slid along its own helix by a random amount: still exact, but no ring structure."""
    from flank_addon.geometry.screw import screw_motion

    rotor = builtin_by_name("srm_a-male")
    # every side vertex leaves its ring's z plane (z moves by v0 times the slide): no ring is left at any
    # density; the bounds below hold >= 20x here (measured as at 6000 x 60)
    v, f = rotor.mesh(n_profile=3000, n_axial=40)
    side = (v[:, 2] > 1e-9) & (v[:, 2] < rotor.length - 1e-9)
    rng = np.random.default_rng(5)
    v = v.copy()
    v[side] = screw_motion(v[side], rng.uniform(-5e-4, 5e-4, side.sum()), rotor.v0, rotor.handedness)
    a = analyze_mesh(v, f)
    assert profile_hausdorff(a, rotor, lambda p: p) < 1e-4
    assert abs(a.v0 / rotor.v0 - 1) < 1e-5


def test_irregular_cad_like_tessellation():
    """Random surface samples, Delaunay-triangulated: normals are poor (tangency ~0.005), positions exact."""
    rotor = builtin_by_name("asymmetric-female")
    v, f = irregular_mesh(rotor, n_points=100000)
    a = analyze_mesh(v, f)
    assert a.tangency_residual > 1e-3  # such meshes defeat a normal-only criterion ...
    assert a.residual < 1e-4           # ... but not the positional one
    assert abs(a.v0 / rotor.v0 - 1) < 1e-5 and a.handedness == "left"
    assert np.degrees(np.arccos(min(1.0, abs(a.axis_direction[2])))) < 0.01
    assert profile_hausdorff(a, rotor, lambda p: p) < 1e-4
    assert len(a.flanks) == 12


def test_rejects_slightly_tapered_rotor_by_positional_residual():
    rotor = builtin_by_name("nilson-male")
    v, f = rotor.mesh(n_profile=1500, n_axial=30)
    v = v.copy()
    v[:, 0] *= 1 + 0.01 * v[:, 2] / rotor.length  # 1 % taper: normals alone cannot tell
    with pytest.raises(NotHelicalError, match=r"residual .* exceeds the threshold 0\.001"):
        analyze_mesh(v, f)


def test_rejects_sphere_with_pitch_message():
    v, f = uv_sphere()
    with pytest.raises(NotHelicalError, match=r"residual .*threshold") as err:
        analyze_mesh(v * 30, f)
    assert "not unique" in str(err.value) or "below" in str(err.value)


def test_rejects_cube_with_residual_message():
    v = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    f = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                  [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    with pytest.raises(NotHelicalError, match=r"tangency residual .*, threshold"):
        analyze_mesh(v, f)


def test_rejects_a_flat_plate_naming_it():
    n = 30
    x, y = np.meshgrid(np.linspace(0, 10, n), np.linspace(0, 10, n))
    v = np.c_[x.ravel(), y.ravel(), np.zeros(n * n)]
    a = (np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None, :]).ravel()
    f = np.concatenate([np.c_[a, a + 1, a + n + 1], np.c_[a, a + n + 1, a + n]])
    with pytest.raises(NotHelicalError, match=r"v0 = 0 is below .* surface of revolution, here a plane"):
        analyze_mesh(v, f)


def prism(sides, depth, rings, radius=20.0, centre_caps=False):
    """A regular prism (a polygonal cylinder as Blender's Add > Cylinder makes it): ``rings`` vertex rings,
    quads split in two, end caps as triangle fans from a rim vertex or from a centre vertex."""
    t = np.arange(sides) * 2 * np.pi / sides
    v = np.concatenate([np.c_[radius * np.cos(t), radius * np.sin(t), np.full(sides, z)]
                        for z in np.linspace(-depth / 2, depth / 2, rings)])
    i = np.arange(sides)
    j = (i + 1) % sides
    f = [np.concatenate([np.c_[r * sides + i, r * sides + j, (r + 1) * sides + j],
                         np.c_[r * sides + i, (r + 1) * sides + j, (r + 1) * sides + i]]) for r in range(rings - 1)]
    top = (rings - 1) * sides
    if centre_caps:
        v = np.vstack([v, [[0, 0, -depth / 2], [0, 0, depth / 2]]])
        f += [np.c_[np.full(sides, len(v) - 2), j, i], np.c_[np.full(sides, len(v) - 1), top + i, top + j]]
    else:
        k = np.arange(1, sides - 1)
        f += [np.c_[np.zeros_like(k), k + 1, k], np.c_[np.full_like(k, top), top + k, top + k + 1]]
    return v, np.concatenate(f)


# every one of these passed the analysis as a "rotor" with 12 to 256 lobes or none, before the faces' own
# normals were asked for the pitch: their vertices fit a screw whose turn between rings is a multiple of the
# polygon's angle, and their rim vertex normals lean towards the end caps
@pytest.mark.parametrize("sides, depth, rings, centre_caps",
                         [(64, 100, 2, False), (256, 100, 2, False), (12, 100, 20, False), (16, 10, 20, True),
                          (24, 100, 2, False), (32, 100, 20, False), (128, 10, 2, True), (256, 100, 20, True)])
def test_rejects_cylinders_and_prisms_whose_pitch_is_not_determined(sides, depth, rings, centre_caps):
    with pytest.raises(NotHelicalError, match=r"cylinder or prism"):
        analyze_mesh(*prism(sides, depth, rings, centre_caps=centre_caps))


@pytest.mark.parametrize("kind", ["nilson", "srm_a", "asymmetric"])
def test_coarse_rotor_meshes_keep_their_pitch_check(kind):
    """A 48 x 8 male mesh: its face normals are off by the chord angle (sines 0.08 to 0.17), far beyond the vertex
    normals' tangency bound, and must still count for the faces' own pitch (they did not when faces had to meet
    the vertex bound: 20 of 24 such meshes were refused as cylinders)."""
    from flank_addon.geometry.rotors import builtin_rotor

    rotor = builtin_rotor(kind, "male", scale=40.0)
    a = analyze_mesh(*rotor.mesh(n_profile=48, n_axial=8))
    assert abs(a.v0 / rotor.v0 - 1) < 0.02 and a.lobes == rotor.lobes


@pytest.mark.parametrize("kind", ["nilson", "asymmetric"])
def test_short_lead_rotors_keep_their_pitch_check(kind):
    """Lead = length = outer radius: an end face's normal makes only sin 0.16 with the screw's normal plane at the
    rim, and counted as tangent it pulled the faces' pitch to 0.79 of the true one; end faces are left out."""
    from flank_addon.geometry.rotors import builtin_rotor

    from flank_addon.geometry.rotor_analysis import face_advance

    rotor = builtin_rotor(kind, "male", scale=40.0, lead=40.0, length=40.0)
    v, f = rotor.mesh(n_profile=720, n_axial=24)
    a = analyze_mesh(v, f)
    assert abs(a.v0 / rotor.v0 - 1) < 1e-6 and a.lobes == rotor.lobes
    v, f, _, cross = _weld(v, f)
    k = rotor.v0 * (1 if rotor.handedness == "right" else -1)
    _, face_k = face_advance(v / 40.0, f, cross, np.array([0.0, 0.0, 1.0]), np.zeros(3), k / 40.0)
    assert abs(face_k / (k / 40.0) - 1) < 0.05


@pytest.mark.parametrize("name", ["nilson-male", "srm_a-female"])
@pytest.mark.parametrize("n_profile, n_axial", [(700, 40), (200, 10)])
def test_faces_give_a_screw_rotors_own_pitch(name, n_profile, n_axial):
    """The faces' own advance agrees with the fitted one: within 7 % on a 200 x 10 mesh, 0.5 % on 700 x 40."""
    from flank_addon.geometry.rotor_analysis import face_advance

    rotor = builtin_by_name(name)
    v, f = rotor.mesh(n_profile=n_profile, n_axial=n_axial)
    v, f, _, cross = _weld(v, f)
    k = rotor.v0 * (1 if rotor.handedness == "right" else -1)
    axial, face_k = face_advance(v, f, cross, np.array([0.0, 0.0, 1.0]), np.zeros(3), k)
    assert axial > 0.4
    assert abs(face_k / k - 1) < (0.07 if n_axial == 10 else 0.005)


def test_rejects_distorted_rotor():
    rotor = builtin_by_name("nilson-male")
    v, f = rotor.mesh(n_profile=1500, n_axial=30)
    v = v.copy()
    v[:, 0] *= 1 + 0.2 * v[:, 2] / rotor.length  # tapering breaks the screw symmetry
    with pytest.raises(NotHelicalError, match=r"tangency residual .*, threshold"):
        analyze_mesh(v, f)


def test_rejects_nan_and_tiny_meshes():
    with pytest.raises(NotHelicalError, match="NaN"):
        analyze_mesh(np.array([[0, 0, 0], [1, 0, 0], [0, np.nan, 0], [0, 0, 1]]),
                     np.array([[0, 1, 2], [0, 1, 3], [1, 2, 3], [0, 2, 3]]))
    with pytest.raises(NotHelicalError, match="at least 4"):
        analyze_mesh(np.zeros((3, 3)), np.array([[0, 1, 2]]))


def test_unwelded_duplicated_and_finned_meshes_analyse_like_the_clean_rotor():
    """An STL stores every triangle with its own vertices; a mesh may carry duplicate vertices, zero-area
    faces or a stray fin face.  The analysis welds exact duplicates, drops collapsed faces, counts the
    non-manifold edges, and recovers the clean rotor's helix exactly."""
    rotor = builtin_by_name("asymmetric-female")
    v, f = rotor.mesh(n_profile=720, n_axial=24)
    clean = analyze_mesh(v, f)
    assert clean.mesh_repairs == {"merged_vertices": 0, "dropped_faces": 0, "nonmanifold_edges": 0}
    unwelded_v = v[f.reshape(-1)]
    unwelded_f = np.arange(3 * len(f)).reshape(-1, 3)
    n = len(v)
    a, b = f[0][:2]
    cases = {
        "unwelded": (unwelded_v, unwelded_f, dict(merged_vertices=len(unwelded_v) - n, dropped_faces=0,
                                                   nonmanifold_edges=0)),
        "duplicates": (np.vstack([v, v[:3]]), np.vstack([f, [[n, n + 1, n + 2], [0, n, 1], [0, 1, 0]]]),
                       dict(merged_vertices=3, dropped_faces=2, nonmanifold_edges=0)),
        "fin": (np.vstack([v, [v[a] * [1.5, 1.5, 1.0]]]), np.vstack([f, [[a, b, n]]]),
                dict(merged_vertices=0, dropped_faces=0, nonmanifold_edges=1)),
    }
    for name, (vv, ff, repairs) in cases.items():
        got = analyze_mesh(vv, ff)
        # (n, n+1, n+2) welds onto (0, 1, 2): a duplicate face, so edge 0-1 is shared 3 times there too
        if name == "duplicates":
            repairs["nonmanifold_edges"] = got.mesh_repairs["nonmanifold_edges"]
            assert got.mesh_repairs["nonmanifold_edges"] >= 1
        assert got.mesh_repairs == repairs, name
        assert got.v0 == pytest.approx(clean.v0, rel=1e-9), name
        assert np.allclose(got.to_world, clean.to_world, atol=1e-9), name
        assert got.residual == pytest.approx(clean.residual, rel=1e-6, abs=1e-12), name


def test_weld_counts_edges_of_more_than_two_faces_as_a_brute_force_count():
    """weld_mesh against the plain definitions: unique vertex rows, faces without a repeated vertex or area
    kept, every undirected edge counted over the kept faces; on random soups with repeated vertices, repeated
    and collapsed faces and edges of up to six faces.  Its face cross products are numpy's.  Vertex normals from the weld's cross products equal
    those computed afresh."""
    rng = np.random.default_rng(3)
    for case in range(40):
        grid = rng.integers(0, 4, (rng.integers(4, 40), 3)).astype(float)
        if case % 2:
            grid = (grid + rng.normal(0, 0.3, grid.shape)) * 10 ** rng.uniform(-3, 3)    # products that round
        v = grid[rng.integers(0, len(grid), rng.integers(4, 60))]          # exact duplicates
        f = rng.integers(0, len(v), (rng.integers(1, 80), 3))
        f = np.vstack([f, f[: rng.integers(0, 5)]])                           # repeated faces
        if case % 3 == 0:
            f[::7, 2] = f[::7, 0]                                              # collapsed faces
        wv, wf, repairs = weld_mesh(v, f)
        ref_v, inv = np.unique(v, axis=0, return_inverse=True)
        ref_f = inv.reshape(-1)[f]
        cross = np.cross(ref_v[ref_f[:, 1]] - ref_v[ref_f[:, 0]], ref_v[ref_f[:, 2]] - ref_v[ref_f[:, 0]])
        area = np.linalg.norm(cross, axis=1)
        keep = (ref_f[:, 0] != ref_f[:, 1]) & (ref_f[:, 1] != ref_f[:, 2]) & (ref_f[:, 0] != ref_f[:, 2]) & (area > 0)
        count = {}
        for tri in ref_f[keep]:
            for i, j in ((0, 1), (1, 2), (2, 0)):
                e = (min(tri[i], tri[j]), max(tri[i], tri[j]))
                count[e] = count.get(e, 0) + 1
        assert np.array_equal(wv, ref_v) and np.array_equal(wf, ref_f[keep])
        assert repairs == {"merged_vertices": len(v) - len(ref_v), "dropped_faces": int((~keep).sum()),
                           "nonmanifold_edges": sum(c > 2 for c in count.values())}
        assert np.array_equal(_weld(v, f)[3], cross[keep])       # numpy's cross product, bit for bit
        if len(wf):
            shared = vertex_normals(wv, wf, _weld(v, f)[3])
            fresh = vertex_normals(wv, wf)
            assert all(np.array_equal(a, b) for a, b in zip(shared, fresh))
    quads, square = np.array([[0, 1, 2, 3]]), np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.0]])
    for verts, faces in ((square, quads), (np.c_[square, np.ones(4)], quads[:, :3])):
        for call in (weld_mesh, vertex_normals):
            with pytest.raises(ValueError, match=r"vertices \(N, 3\) and faces \(M, 3\), got \(4, [34]\)"):
                call(verts, faces)


def _projections_onto_all_candidates(loop, pts):
    """The projection of every point onto each of the 8 segments whose midpoints are nearest, the nearest
    kept (the first on a tie): what the analysis' ordering along a profile means, without shortcuts."""
    seg = np.roll(loop, -1, axis=0) - loop
    L = np.linalg.norm(seg, axis=1)
    cum = np.r_[0.0, np.cumsum(L)]
    _, cand = cKDTree(0.5 * (loop + np.roll(loop, -1, axis=0))).query(pts, k=min(8, len(loop)))
    cand = cand.reshape(len(pts), -1)
    best_d, best_s = np.full(len(pts), np.inf), np.zeros(len(pts))
    for j in range(cand.shape[1]):
        i = cand[:, j]
        t = np.clip(np.einsum("ij,ij->i", pts - loop[i], seg[i]) / np.maximum(L[i] ** 2, 1e-300), 0, 1)
        d = np.linalg.norm(pts - (loop[i] + t[:, None] * seg[i]), axis=1)
        better = d < best_d
        best_d[better], best_s[better] = d[better], cum[i[better]] + t[better] * L[i[better]]
    return best_s, cum[-1], best_d


def test_ordering_along_a_profile_skips_only_candidates_that_cannot_win():
    """_order_along leaves out the candidate segments whose midpoints are too far to win, and
    _within_of_polyline stops at the first candidate within the tolerance: both must answer as the
    projection onto all candidates, bit for bit; on fine and coarse closed polylines at scales 1e-3 to 1e3,
    with repeated vertices (segments of no length), points on, near and far from them."""
    rng = np.random.default_rng(5)
    for case in range(40):
        n = int(rng.integers(3, 3000))
        th = np.sort(rng.uniform(0, 2 * np.pi, n))
        r = 1 + 0.3 * np.sin(rng.integers(1, 6) * th)
        loop = np.c_[r * np.cos(th), r * np.sin(th)] * 10 ** rng.uniform(-3, 3)
        if case % 5 == 0:
            loop[rng.integers(0, n)] = loop[rng.integers(0, n)]
        m = int(rng.integers(1, 5000))
        pts = loop[rng.integers(0, n, m)] * (1 + rng.normal(0, 10 ** rng.uniform(-9, -1), (m, 1)))
        if case % 3 == 0:
            pts += rng.normal(0, 1e-3, (m, 2)) * np.abs(loop).max()
        want = _projections_onto_all_candidates(loop, pts)
        got = _order_along(loop, pts)
        assert np.array_equal(got[0], want[0]) and got[1] == want[1] and np.array_equal(got[2], want[2])
        for tol in (0.0, float(np.median(want[2])), float(want[2].max())):
            assert np.array_equal(_within_of_polyline(loop, pts, tol), want[2] <= tol)


def test_axis_screw_velocity_is_numpys_cross_product():
    """The analysis' screw velocity written out component by component must be numpy's k d + d x (x - a) bit for
    bit (the reweighted fit follows every rounding), at scales from 1e-6 to 1e6."""
    rng = np.random.default_rng(11)
    for _ in range(30):
        scale = 10 ** rng.uniform(-6, 6)
        x = rng.normal(size=(int(rng.integers(1, 2000)), 3)) * scale
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        a, k = rng.normal(size=3) * scale, float(rng.normal()) * scale
        assert np.array_equal(axis_screw_velocity(x, d, a, k), k * d + np.cross(d, x - a))
