"""Per-face quantities of a triangle mesh (vertices (V, 3), faces (F, 3) vertex indices), shared by the rotor
analysis, the mesh foot points and the free-form guiding field, so that all three see the same numbers."""
import numpy as np


def face_cross(v, f):
    """(p1 - p0) x (p2 - p0) of every face: what ``np.cross`` gives, bit for bit (the same products and
    differences), with the corners gathered by ``take`` (about 4x faster for a million triangles)."""
    return corner_cross(v.take(f[:, 0], axis=0), v.take(f[:, 1], axis=0), v.take(f[:, 2], axis=0))


def corner_cross(p0, p1, p2):
    """:func:`face_cross` of faces given by their corners (F, 3) each, for a caller that has gathered them."""
    a, b = p1 - p0, p2 - p0
    out = np.empty_like(a)
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


def face_areas_normals(vertices, faces):
    """Areas (F,) and unit normals (F, 3) (right-hand rule on the corner order) of the faces; a face whose cross
    product is exactly 0 has the normal 0.  (On a face so small or so large that the squared length of its
    cross product under- or overflows, the "unit" normal is not of length 1: callers that need one test it,
    as :class:`.mesh_distance.TriangleMesh` does.)  Faces may be any integer type."""
    return areas_normals(face_cross(np.asarray(vertices, float), np.asarray(faces).astype(np.intp, copy=False)))


def areas_normals(cross):
    """:func:`face_areas_normals` from the faces' cross products (F, 3) (:func:`face_cross`, :func:`corner_cross`)."""
    n2 = np.linalg.norm(cross, axis=1)
    return 0.5 * n2, cross / np.where(n2 > 0, n2, 1.0)[:, None]


def corner_angles(vertices, faces):
    """Interior angles (F, 3) of the faces at their corners (the weights of angle-weighted vertex normals)."""
    return corners_angles(np.asarray(vertices, float)[np.asarray(faces)])


def corners_angles(x):
    """:func:`corner_angles` of faces given by their corners x (F, 3 corners, 3), for a caller that has them."""
    u = np.roll(x, -1, axis=1) - x
    w = np.roll(x, -2, axis=1) - x
    return np.arctan2(np.linalg.norm(np.cross(u, w), axis=-1), (u * w).sum(-1))
