"""The tool solid against the stock cylinder, the shafts and the holders along any move of a program.

A move from program row r0 to r1 is interpolated the way the controller does it: linearly in the program's
coordinates (joint values without TCP; tool tip in work coordinates and rotary positions with TCP; rapid
moves assumed linear too, see docs/posts.md).  It is sampled so that no tool point moves more than ``step``
between samples: n = ceil((|dXYZ| + sum |d theta| * reach) / step) with ``reach`` bounding every tool point's
distance from the rotary axes.  At every sample the tool's surface points (:meth:`ToolShape.local_points`)
are carried into the rotor frame by the forward kinematics and tested with :meth:`RotorBody.intrusion`.

A move of the linear axes alone (rotaries fixed) translates the tool in the rotor frame, so it is checked in
closed form (:func:`translation_intrusion`): a point q + s d (0 <= s <= 1) is inside a coaxial cylinder
rho < r, a < z < b exactly when s lies in the window where a < z < b and the quadratic
rho^2(s) = |q_xy + s d_xy|^2 falls below r^2 there; its minimum on the window is at the clipped vertex.

With surface points ``spacing`` apart and samples ``step`` apart a solid thinner than both could slip
through; the shafts and the stock are far thicker, and the planner keeps a clearance larger than both.
"""
import math

import numpy as np

from .tool_shape import place_points


def tool_points(machine, rows, local, tool_length=0.0):
    """Rotor-frame surface points (N, M, 3) of the tool at program rows (N, axes)."""
    tips, axes = machine.forward(rows, tool_length)
    return place_points(local, tips, axes)


def move_rows(r0, r1, n):
    """n >= 2 program rows from r0 to r1, linear."""
    s = np.linspace(0.0, 1.0, max(int(n), 2))[:, None]
    return (1.0 - s) * np.asarray(r0, float) + s * np.asarray(r1, float)


def sample_count(machine, r0, r1, reach, step):
    d = np.abs(np.subtract(r1, r0))
    n = (float(np.linalg.norm(d[:3])) + float(np.radians(d[3:]).sum()) * reach) / step
    return int(min(max(math.ceil(n) + 1, 2), 5000))


def reach_of(machine, rows, local, tool_length=0.0):
    """Bound on the distance of any tool point from any rotary axis over the given rows."""
    pts = tool_points(machine, np.atleast_2d(rows), local, tool_length)
    piv = max(float(np.linalg.norm(machine.axes[n].pivot)) for n in machine.rotary_names)
    return float(np.linalg.norm(pts, axis=-1).max()) + piv + machine.pivot_length + tool_length


def translation_intrusion(rotor, points, delta, stock=True):
    """(depth, point) of tool surface points (M, 3) translated by ``delta`` (3,) in the rotor frame: the
    largest r - min rho of a point while it is inside a solid's z range (0 when none enters)."""
    q = np.asarray(points, float)
    d = np.asarray(delta, float)
    solids = rotor.keep_out + ([(rotor.z_range[0], rotor.z_range[1], rotor.outer_radius)] if stock else [])
    best, where = 0.0, None
    A = float(d[0] ** 2 + d[1] ** 2)
    B = 2.0 * (q[:, 0] * d[0] + q[:, 1] * d[1])
    C = q[:, 0] ** 2 + q[:, 1] ** 2
    for a, b, r in solids:
        if d[2] != 0:
            s1, s2 = (a - q[:, 2]) / d[2], (b - q[:, 2]) / d[2]
            lo, hi = np.maximum(np.minimum(s1, s2), 0.0), np.minimum(np.maximum(s1, s2), 1.0)
            ok = hi > lo
        else:
            lo, hi = np.zeros(len(q)), np.ones(len(q))
            ok = (q[:, 2] > a) & (q[:, 2] < b)
        s = np.clip(-B / (2.0 * A), lo, hi) if A > 0 else lo
        rho = np.sqrt(np.maximum(C + B * s + A * s * s, 0.0))
        depth = np.where(ok, r - rho, -np.inf)
        k = int(np.argmax(depth))
        if depth[k] > best:
            best, where = float(depth[k]), (q[k] + s[k] * d).tolist()
    return best, where


def move_intrusion(machine, rotor, r0, r1, local, tool_length=0.0, step=0.5, stock=True, reach=None):
    """(depth, fraction of the move, rotor-frame point): the deepest intrusion of the tool into the stock
    (if ``stock``) or a keep-out solid (shaft, holder) along the move r0 -> r1; depth 0 when the move stays
    clear."""
    if reach is None:
        reach = reach_of(machine, [r0, r1], local, tool_length)
    n = sample_count(machine, r0, r1, reach, step)
    rows = move_rows(r0, r1, n)
    best = (0.0, 0.0, None)
    chunk = max(1, int(2_000_000 // max(len(local), 1)))
    for lo in range(0, n, chunk):
        pts = tool_points(machine, rows[lo:lo + chunk], local, tool_length)
        depth = rotor.intrusion(pts.reshape(-1, 3), stock=stock).reshape(pts.shape[:2])
        k = np.unravel_index(np.argmax(depth), depth.shape)
        if depth[k] > best[0]:
            best = (float(depth[k]), (lo + k[0]) / (n - 1), pts[k].tolist())
    return best
