"""How far a G1 weight can lower the kinks of conical strips on a curved surface (Rajain et al. 2023 §7.2).

Why the trade-off exists.  On strip i the envelope normal n of a cone (axis direction u_i, half
angle beta) satisfies n . u_i = sin(beta) everywhere (Eq. (6): n . y_s = dr with |y_s| = L), so
along a characteristic the normal can only turn *about* the axis.  Across the strips the axis lies
in the section plane, so to first order the envelope's section across a strip is a straight
segment: the surface's turning across the strips has to be taken by the kinks between them.
(A turn about the axis tilts the normal towards the feed direction and bends the section only to
second order in that tilt.)  Kinks below the section's own turning therefore cost accuracy,
whatever the optimiser: Rajain et al. 2023 makes the same remark for convex patches.

The bound.  Take a section z(y) of the surface across the strips (a graph over its chord, slopes
small).  A machined section made of straight pieces whose slope jumps at most theta at each of
n_junctions junctions has total slope variation T <= n_junctions * theta.  Relaxing "jumps at
n_junctions free places" to "total variation at most T anywhere" gives a linear programme whose
optimum is a lower bound on the largest |error| of *any* such plan (:func:`min_max_error`), and
the dual question, the least turning a plan within a tolerance needs (:func:`min_turning`).

Both are solved with ``scipy.optimize.linprog`` (HiGHS) on the section's samples: unknowns p_k
(machined heights) and the slope jumps split as s+ - s- >= 0; the least error adds the error bound E.
The least error is 0 without a programme where the section's own turning is within the allowance
(p = z is then feasible, and no E < 0 is).
"""
import numpy as np
import scipy.sparse as sp
from scipy.optimize import linprog


def _section(y, z):
    y = np.asarray(y, float)
    z = np.asarray(z, float)
    if y.ndim != 1 or y.shape != z.shape or len(y) < 3:
        raise ValueError(f"a section needs y and z of the same length >= 3, got shapes {y.shape} and {z.shape}")
    if not (np.isfinite(y).all() and np.isfinite(z).all()):
        raise ValueError("the section holds NaN or inf")
    if not (np.diff(y) > 0).all():
        raise ValueError("section abscissae y must increase strictly")
    return y, z


def _slope_jumps(y):
    """(n-2, n) sparse map from heights p to the slope jump at every interior sample."""
    h = np.diff(y)
    m = len(y) - 2
    rows = np.repeat(np.arange(m), 3)
    cols = (np.arange(m)[:, None] + np.arange(3)).ravel()
    vals = np.column_stack([1.0 / h[:-1], -1.0 / h[:-1] - 1.0 / h[1:], 1.0 / h[1:]]).ravel()
    return sp.csr_matrix((vals, (rows, cols)), shape=(m, len(y)))


def turning(y, z):
    """Total slope variation of the section (radians, small-slope model): sum |jump of dz/dy|."""
    y, z = _section(y, z)
    return float(np.abs(_slope_jumps(y) @ z).sum())


def _normalised(y, z):
    """(y', z', scale, line): the section from its first point over its span, less the chord between its
    ends.  Slope jumps do not see a straight line added or both axes scaled alike, and errors scale with the
    axes, so the programmes solve the section at unit span and near zero height, where the solver's absolute
    tolerances (1e-7) are small against it whatever the document's unit or the section's place."""
    scale = float(y[-1] - y[0])
    line = z[0] + (z[-1] - z[0]) * ((y - y[0]) / scale)
    return (y - y[0]) / scale, (z - line) / scale, scale, line


def _least_error(y, z, total_turning):
    """min E over p (n), s+, s- (m each) >= 0: |p - z| <= E, D p = s+ - s-, sum(s+ + s-) <= T."""
    n, m = len(y), len(y) - 2
    eye_n, ones_n = sp.eye(n), sp.csr_matrix(np.ones((n, 1)))
    zeros_nm = sp.csr_matrix((n, 2 * m))
    a_eq = sp.hstack([_slope_jumps(y), -sp.eye(m), sp.eye(m), sp.csr_matrix((m, 1))]).tocsr()
    jumps_row = sp.hstack([sp.csr_matrix((1, n)), sp.csr_matrix(np.ones((1, 2 * m))), sp.csr_matrix((1, 1))])
    a_ub = sp.vstack([sp.hstack([eye_n, zeros_nm, -ones_n]), sp.hstack([-eye_n, zeros_nm, -ones_n]),
                      jumps_row]).tocsr()
    c = np.zeros(n + 2 * m + 1)
    c[-1] = 1.0
    res = linprog(c, A_ub=a_ub, b_ub=np.concatenate([z, -z, [total_turning]]), A_eq=a_eq, b_eq=np.zeros(m),
                  bounds=[(None, None)] * n + [(0, None)] * (2 * m + 1), method="highs")
    if res.status != 0:
        raise RuntimeError(f"the bound's linear programme did not solve: {res.message}")
    return max(float(res.x[-1]), 0.0), res.x[:n]          # no -0.0 from the solver


def _least_turning(y, z, max_error):
    """min sum(s+ + s-) over p (n) within z -+ max_error (bounds, not rows) and s+, s- (m each) >= 0
    with D p = s+ - s-."""
    n, m = len(y), len(y) - 2
    a_eq = sp.hstack([_slope_jumps(y), -sp.eye(m), sp.eye(m)]).tocsr()
    c = np.concatenate([np.zeros(n), np.ones(2 * m)])
    bounds = np.column_stack([np.concatenate([z - max_error, np.zeros(2 * m)]),
                              np.concatenate([z + max_error, np.full(2 * m, np.inf)])])
    res = linprog(c, A_eq=a_eq, b_eq=np.zeros(m), bounds=bounds, method="highs")
    if res.status != 0:
        raise RuntimeError(f"the bound's linear programme did not solve: {res.message}")
    return max(float(res.fun), 0.0)


def min_max_error(y, z, total_turning):
    """Least possible max |z - p| over machined sections p whose slope jumps add up to at most
    ``total_turning`` (radians).  y, z (n,): the surface section, y increasing.  -> (E, p (n,))."""
    y, z = _section(y, z)
    if not (np.isfinite(total_turning) and total_turning >= 0):
        raise ValueError(f"total turning must be a finite angle >= 0, got {total_turning!r}")
    if turning(y, z) <= total_turning:      # the section itself is such a p: nothing less than 0
        return 0.0, z.copy()
    yn, zn, scale, line = _normalised(y, z)
    e, p = _least_error(yn, zn, float(total_turning))
    return e * scale, p * scale + line


def min_turning(y, z, max_error):
    """Least total slope variation (radians) of a machined section within ``max_error`` of z(y)."""
    y, z = _section(y, z)
    if not (np.isfinite(max_error) and max_error >= 0):
        raise ValueError(f"max error must be a finite length >= 0, got {max_error!r}")
    yn, zn, scale, _ = _normalised(y, z)
    if 2.0 * max_error >= scale * np.ptp(zn):     # a straight section (the chord, shifted) is within the error
        return 0.0
    return _least_turning(yn, zn, float(max_error) / scale)


def kink_error_bound(y, z, max_kink_deg, n_junctions):
    """Lower bound on the max |error| of any conical multi-strip plan whose section z(y) crosses
    ``n_junctions`` strip boundaries, each kinked by at most ``max_kink_deg`` degrees."""
    if int(n_junctions) != n_junctions or n_junctions < 0:
        raise ValueError(f"n_junctions must be a whole number >= 0, got {n_junctions!r}")
    return min_max_error(y, z, np.radians(max_kink_deg) * int(n_junctions))[0]


def kink_floor_deg(y, z, max_error, n_junctions):
    """Least possible max kink (degrees) of a plan within ``max_error`` over ``n_junctions``
    junctions of the section: its least turning shared evenly."""
    if int(n_junctions) != n_junctions or n_junctions < 1:
        raise ValueError(f"n_junctions must be a whole number >= 1, got {n_junctions!r}")
    return float(np.degrees(min_turning(y, z, max_error) / int(n_junctions)))


def fixed_junction_error(y, z, junctions, max_kink_deg):
    """Least max |z - p| over continuous sections p that are straight between the given junction
    abscissae (the strips' boundaries, first and last = the section's ends) and bend at most
    ``max_kink_deg`` at each inner one: what straight strips on fixed boundaries can reach.

    Unlike :func:`kink_error_bound` this is not a bound for every plan (junctions may move, strips
    may overlap), but it is reachable in the section model, so it tells how close an optimiser's
    trade-off comes.  -> (E, heights at the junctions)."""
    y, z = _section(y, z)
    knots = np.asarray(junctions, float)
    if knots.ndim != 1 or len(knots) < 2 or not (np.diff(knots) > 0).all():
        raise ValueError("junctions must be at least 2 strictly increasing abscissae")
    if knots[0] > y[0] or knots[-1] < y[-1]:
        raise ValueError(f"junctions span {knots[0]:.6g} .. {knots[-1]:.6g} but the section spans "
                         f"{y[0]:.6g} .. {y[-1]:.6g}")
    if not (np.isfinite(max_kink_deg) and max_kink_deg >= 0):
        raise ValueError(f"max kink must be a finite angle >= 0, got {max_kink_deg!r}")
    k = len(knots)
    seg = np.clip(np.searchsorted(knots, y, side="right") - 1, 0, k - 2)
    t = (y - knots[seg]) / (knots[seg + 1] - knots[seg])
    rows = np.arange(len(y))
    interp = sp.csr_matrix((np.concatenate([1.0 - t, t]), (np.concatenate([rows, rows]), np.concatenate([seg, seg + 1]))),
                           shape=(len(y), k))
    jumps = _slope_jumps(knots)
    ones = sp.csr_matrix(np.ones((len(y), 1)))
    zero = sp.csr_matrix((jumps.shape[0], 1))
    a_ub = sp.vstack([sp.hstack([interp, -ones]), sp.hstack([-interp, -ones]),
                      sp.hstack([jumps, zero]), sp.hstack([-jumps, zero])]).tocsr()
    theta = np.radians(float(max_kink_deg))
    b_ub = np.concatenate([z, -z, np.full(2 * jumps.shape[0], theta)])
    c = np.zeros(k + 1)
    c[-1] = 1.0
    res = linprog(c, A_ub=a_ub, b_ub=b_ub, bounds=[(None, None)] * k + [(0, None)], method="highs")
    if res.status != 0:
        raise RuntimeError(f"the section's linear programme did not solve: {res.message}")
    return float(res.x[-1]), res.x[:k]


def section_graph(points, normals):
    """A section of a surface, (n, 3) points in order across the strips with their unit surface
    normals (n, 3), as a graph z(y) over its chord in the plane of the chord and the mean normal.
    -> (y (n,), z (n,)), or None where the section folds back over its chord (the small-slope
    model of the bound does not hold there)."""
    P = np.asarray(points, float)
    N = np.asarray(normals, float)
    chord = P[-1] - P[0]
    length = np.linalg.norm(chord)
    if length <= 0:
        return None
    e1 = chord / length
    up = N.mean(axis=0)
    up = up - (up @ e1) * e1
    if np.linalg.norm(up) < 1e-9:
        return None
    e2 = up / np.linalg.norm(up)
    y, z = (P - P[0]) @ e1, (P - P[0]) @ e2
    if not (np.diff(y) > 0).all():
        return None
    return y, z


def plan_section_bounds(sections, max_kink_deg, max_error):
    """Bounds of a plan over its sections across the strips.

    sections: list of (y (n,), z (n,), n_junctions).  -> dict with ``error_bound`` (the largest
    over the sections of the least max |error| possible at ``max_kink_deg``) and
    ``kink_floor_deg`` (the largest least max kink possible within ``max_error``), None without
    a section."""
    usable = [(y, z, nj) for y, z, nj in sections if nj >= 1]
    if not usable:
        return {"error_bound": None, "kink_floor_deg": None, "sections": 0}
    return {"error_bound": max(kink_error_bound(y, z, max_kink_deg, nj) for y, z, nj in usable),
            "kink_floor_deg": max(kink_floor_deg(y, z, max_error, nj) for y, z, nj in usable),
            "sections": len(usable)}
