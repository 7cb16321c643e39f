# SPDX-License-Identifier: GPL-3.0-or-later
"""Placements and tool shapes in Blender terms: the frame of a tool on its axis and the screw motion
(mathutils), and closed surfaces of revolution from a tool outline
(``flank_addon.tooling.meridian``)."""
import bpy
import numpy as np
from mathutils import Matrix, Vector


def axis_frame(start, end):
    """(4x4 float64 frame, length) of a tool on the axis ``start`` -> ``end``: origin at ``start``, local z along
    the axis; (None, 0.0) when the two points coincide.

    The rotation taking z to the axis is mathutils' track quaternion (``Vector.to_track_quat('Z', 'Y')``).
    mathutils works in single precision (its matrices are orthonormal to ~1e-6 only), so the frame is
    made orthonormal again in double precision with its z column exactly the axis: placements stay within
    1e-6 of the planner's."""
    a = np.asarray(start, dtype=np.float64)
    axis = np.asarray(end, dtype=np.float64) - a
    length = float(np.linalg.norm(axis))
    if length < 1e-12:
        return None, 0.0
    z = axis / length
    x = np.array(Vector(axis.tolist()).to_track_quat('Z', 'Y').to_matrix(), dtype=np.float64)[:, 0]
    x -= (x @ z) * z
    x /= np.linalg.norm(x)
    frame = np.eye(4)
    frame[:3, 0], frame[:3, 1], frame[:3, 2], frame[:3, 3] = x, np.cross(z, x), z, a
    return frame, length


def screw_matrix(t, v0, hand):
    """The screw motion S_t about the z axis (turn hand * t, advance v0 * t) as a 4x4 float64 array."""
    m = Matrix.Translation((0.0, 0.0, v0 * t)) @ Matrix.Rotation(hand * t, 4, 'Z')
    return np.array(m, dtype=np.float64)


def revolved_mesh(rh, n=48):
    """Closed surface of revolution about the local z-axis as (verts (V,3), faces (F,3)), outward oriented.

    ``rh`` (K, 2) outline points (radius, height) from the top pole to the bottom pole, both with radius 0
    (K >= 3); every inner point is revolved into a ring of ``n`` vertices: ring k is vertices k n .. k n + n - 1
    (the outline's point k + 1), the two poles are the last two vertices.

    numpy, not ``bmesh.ops.spin``: measured on outlines of 50-2000 points x 48-96 segments, spin (+ welding
    the pole copies) took 5-12 times as long (e.g. 0.37 s against 0.015 s for 52 x 96) and, rotating step by
    step in single precision, put vertices up to 1.9e-6 x the radius off the exact circle (a formed cutter of
    radius 130 mm: 2.5e-4 mm); its vertex order is step-major with the poles merged in between, while the
    formed cutter's per-ring flags need the rings in order."""
    rh = np.asarray(rh, dtype=np.float64)
    rings = rh[1:-1]
    m = len(rings)
    if m < 1 or n < 3:
        raise ValueError("a revolved mesh needs >= 3 outline points and >= 3 segments")
    ang = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    verts = np.empty((m * n + 2, 3))
    verts[:m * n, 0] = (rings[:, 0:1] * np.cos(ang)[None, :]).ravel()
    verts[:m * n, 1] = (rings[:, 0:1] * np.sin(ang)[None, :]).ravel()
    verts[:m * n, 2] = np.repeat(rings[:, 1], n)
    verts[m * n] = (0.0, 0.0, rh[0, 1])
    verts[m * n + 1] = (0.0, 0.0, rh[-1, 1])
    i = np.arange(n)
    j = (i + 1) % n
    a = (np.arange(m - 1)[:, None] * n + i[None, :]).ravel()          # ring k above ring k + 1: CCW from outside
    b = (np.arange(m - 1)[:, None] * n + j[None, :]).ravel()
    sides = np.vstack([np.c_[a, a + n, b + n], np.c_[a, b + n, b]]) if m > 1 else np.zeros((0, 3), dtype=int)
    top, bot = m * n, m * n + 1
    caps = np.vstack([np.c_[np.full(n, top), i, j], np.c_[np.full(n, bot), (m - 1) * n + j, (m - 1) * n + i]])
    return verts, np.vstack([_interleave(sides, m - 1, n), caps])


def _interleave(sides, rows, n):
    """The side triangles in the order ring by ring (two triangles of a quad band, then the next band)."""
    if rows < 1:
        return sides
    first, second = sides[:rows * n].reshape(rows, n, 3), sides[rows * n:].reshape(rows, n, 3)
    return np.concatenate([first, second], axis=1).reshape(-1, 3)


classes = ()
register, unregister = bpy.utils.register_classes_factory(classes)
