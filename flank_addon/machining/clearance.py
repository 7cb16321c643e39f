"""The tool solid against the stock cylinder and the shafts along any move of a program.

A move from program row r0 to r1 is interpolated the way the controller does it: linearly in the program's
coordinates (joint values without TCP; tool tip in work coordinates and rotary positions with TCP; rapid
moves assumed linear too, see docs/posts.md).  It is sampled so that no tool point moves more than ``step``
between samples: n = ceil((|dXYZ| + sum |d theta| * reach) / step) with ``reach`` bounding every tool point's
distance from the rotary axes.  At every sample the tool's surface points (:meth:`ToolShape.local_points`)
are carried into the rotor frame by the forward kinematics and tested with :meth:`RotorBody.intrusion`.

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


def move_intrusion(machine, rotor, r0, r1, local, tool_length=0.0, step=0.5, stock=True, reach=None):
    """(depth, fraction of the move, rotor-frame point): the deepest intrusion of the tool into the stock
    (if ``stock``) or a shaft along the move r0 -> r1; depth 0 when the move stays clear."""
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
