"""Mesh -> rotor analysis on built-in rotors in random placements, plus rejection of non-helical meshes."""
import zlib

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from flank_addon.geometry.rotor_analysis import NotHelicalError, analyze_mesh
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
