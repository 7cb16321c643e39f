"""geometry/triangles: the per-face quantities shared by the rotor analysis, the mesh foot points and the guiding
field, against their plain definitions bit for bit."""
import numpy as np

from flank_addon.geometry.triangles import corner_angles, face_areas_normals, face_cross


def _soup(rng, n_faces=3000, scale=1.0, offset=0.0):
    V = rng.normal(size=(1000, 3)) * scale + offset
    F = rng.integers(0, 1000, (n_faces, 3))
    F[:20, 1] = F[:20, 0]                                     # faces of no area
    V[F[20:30, 2]] = 0.5 * (V[F[20:30, 0]] + V[F[20:30, 1]])  # flat faces (area 0 up to rounding)
    return V, F


def test_face_quantities_are_their_plain_definitions():
    rng = np.random.default_rng(7)
    for scale, offset in ((1.0, 0.0), (1e-6, 1e3), (1e6, -1e8)):
        V, F = _soup(rng, scale=scale, offset=offset)
        A, B, C = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
        cross = np.cross(B - A, C - A)
        assert np.array_equal(face_cross(V, F), cross)
        area, normal = face_areas_normals(V, F)
        n2 = np.linalg.norm(cross, axis=1)
        assert np.array_equal(area, 0.5 * n2)
        assert np.array_equal(normal[n2 > 0], cross[n2 > 0] / n2[n2 > 0, None])
        assert (normal[:20] == 0).all() and (area[:20] == 0).all()
        # faces of another integer type (a mesh reader's uint32 or uint64) give the same numbers
        for kind in (np.uint32, np.uint64, np.int32):
            a2, n2_ = face_areas_normals(V, F.astype(kind))
            assert np.array_equal(a2, area) and np.array_equal(n2_, normal)
        ang = corner_angles(V, F)
        for c in range(3):
            p, q, r = V[F[:, c]], V[F[:, (c + 1) % 3]], V[F[:, (c + 2) % 3]]
            u, w = q - p, r - p
            assert np.array_equal(ang[:, c], np.arctan2(np.linalg.norm(np.cross(u, w), axis=1), (u * w).sum(1)))


def test_corner_angles_of_a_right_triangle_and_their_sum():
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [5.0, 5.0, 1.0]])
    F = np.array([[0, 1, 2], [1, 3, 2]])
    ang = corner_angles(V, F)
    assert abs(ang[0, 0] - np.pi / 2) < 1e-15 and abs(ang[0, 1] - np.arctan(2.0)) < 1e-15
    np.testing.assert_allclose(ang.sum(axis=1), np.pi, rtol=0, atol=1e-14)
    area, normal = face_areas_normals(V, F)
    assert area[0] == 1.0 and np.array_equal(normal[0], [0.0, 0.0, 1.0])
