"""Independent machining simulation of revolving tools on a helical relative motion.

Plan convention (flank-plan/1): a strip's tool is fixed in the rotor frame while the rotor screws by
S_t (s000 Eq. (1)).  A rotor point x is removed iff its helix S_t(x) enters the tool for some t, so

    D(x) = min_t  sd_tool(S_t(x))

is the signed distance to the swept (removed) region: exact outside it (D is then the Euclidean
distance from x to the union of S_{-t}(tool)), negative inside.  The machined surface is the zero
set of D; on a design profile point p with outward normal n the deviation is the root lambda* of
D(p + lambda n) = 0: positive = material left, negative = overcut.  Nothing here uses a planner's
own error formula: only the tool solid and the motion.

Tools are unions of sphere-swept frustums (inscribed spheres of radii r_0..r_m at equally spaced
axis points, flank-plan/1 "radii"), optionally with a flat-ended cylindrical shank.
"""
import numpy as np

from .screw import screw_motion

GOLDEN = 0.5 * (3.0 - np.sqrt(5.0))


def sd_sphere_frustum(q, c1, r1, c2, r2):
    """Signed distance from points q (N, 3) to the convex hull of two spheres (exact outside)."""
    q = np.asarray(q, float)
    axis = np.asarray(c2, float) - np.asarray(c1, float)
    L = float(np.linalg.norm(axis))
    if L <= abs(r2 - r1):  # one sphere contains the other
        c, r = (c2, r2) if r2 >= r1 else (c1, r1)
        return np.linalg.norm(q - c, axis=-1) - r
    a = axis / L
    w = q - c1
    h = w @ a
    rho = np.sqrt(np.maximum(np.einsum("...i,...i->...", w, w) - h * h, 0.0))
    nx = (r1 - r2) / L
    ny = np.sqrt(1.0 - nx * nx)
    tau = (h - r1 * nx) * ny - (rho - r1 * ny) * nx     # position along the tangent line from T1
    line = h * nx + rho * ny - r1
    cap1 = np.hypot(h, rho) - r1
    cap2 = np.hypot(h - L, rho) - r2
    return np.where(tau < 0, cap1, np.where(tau > L * ny, cap2, line))


def sd_cylinder(q, s0, s1, radius):
    """Signed distance from points q (N, 3) to a flat-ended cylinder from s0 to s1."""
    axis = np.asarray(s1, float) - np.asarray(s0, float)
    L = float(np.linalg.norm(axis))
    a = axis / L
    w = np.asarray(q, float) - s0
    h = w @ a
    rho = np.sqrt(np.maximum(np.einsum("...i,...i->...", w, w) - h * h, 0.0))
    dx = rho - radius
    dy = np.maximum(-h, h - L)
    return np.minimum(np.maximum(dx, dy), 0.0) + np.hypot(np.maximum(dx, 0.0), np.maximum(dy, 0.0))


class StripTool:
    """The solid of one strip's tool (and optional shank) in the rotor frame."""

    def __init__(self, axis_start, axis_end, radii, shank_start=None, shank_end=None, shank_radius=0.0):
        self.radii = np.asarray(radii, float)
        if self.radii.ndim != 1 or len(self.radii) < 2 or (self.radii < 0).any():
            raise ValueError(f"tool radii must be >= 2 non-negative values, got {radii!r}")
        s = np.linspace(0.0, 1.0, len(self.radii))[:, None]
        self.centres = (1 - s) * np.asarray(axis_start, float) + s * np.asarray(axis_end, float)
        self.shank = None
        if shank_start is not None and shank_radius > 0 and np.linalg.norm(
                np.subtract(shank_end, shank_start)) > 0:
            self.shank = (np.asarray(shank_start, float), np.asarray(shank_end, float), float(shank_radius))
        lo = (self.centres[:, 2] - self.radii).min()
        hi = (self.centres[:, 2] + self.radii).max()
        if self.shank is not None:
            ends = np.stack(self.shank[:2])
            lo = min(lo, ends[:, 2].min() - self.shank[2])
            hi = max(hi, ends[:, 2].max() + self.shank[2])
        self.z_range = (float(lo), float(hi))

    @classmethod
    def from_strip(cls, strip, with_shank=True):
        if with_shank:
            return cls(strip["axis_start"], strip["axis_end"], strip["radii"], strip.get("shank_start"),
                       strip.get("shank_end"), strip.get("shank_radius", 0.0))
        return cls(strip["axis_start"], strip["axis_end"], strip["radii"])

    def signed_distance(self, q):
        d = np.full(np.shape(q)[:-1], np.inf)
        for k in range(len(self.radii) - 1):
            d = np.minimum(d, sd_sphere_frustum(q, self.centres[k], self.radii[k], self.centres[k + 1],
                                                self.radii[k + 1]))
        if self.shank is not None:
            d = np.minimum(d, sd_cylinder(q, *self.shank))
        return d


def helical_distance(tool, points, v0, handedness="right", step=None, iters=30):
    """D(x) = min_t sd_tool(S_t(x)) for 3D points (N, 3): (D, t*).

    Only t with S_t(x) inside the tool's axial slab can matter; that range is sampled densely
    (points move at most ``step`` between samples) and the best sample is polished by golden-section
    search on its neighbouring interval.
    """
    x = np.atleast_2d(np.asarray(points, float))
    z0, z1 = tool.z_range
    t_lo = (z0 - x[:, 2]) / v0
    t_hi = (z1 - x[:, 2]) / v0
    speed = np.sqrt(np.einsum("ij,ij->i", x[:, :2], x[:, :2]) + v0 * v0)
    if step is None:
        step = 0.25 * max(float(tool.radii.min()), 1e-3 * (z1 - z0))
    n = int(np.clip(np.max((t_hi - t_lo) * speed / step), 8, 4000)) + 1
    s = np.linspace(0.0, 1.0, n)
    T = t_lo[:, None] + (t_hi - t_lo)[:, None] * s[None, :]
    D = tool.signed_distance(screw_motion(x[:, None, :], T, v0, handedness))
    k = np.argmin(D, axis=1)
    rows = np.arange(len(x))
    a = T[rows, np.maximum(k - 1, 0)]
    b = T[rows, np.minimum(k + 1, n - 1)]
    best_t, best = T[rows, k], D[rows, k]

    def f(t):
        return tool.signed_distance(screw_motion(x, t, v0, handedness))

    # golden-section search on [a, b] (vectorised over the points)
    c = a + GOLDEN * (b - a)
    d = b - GOLDEN * (b - a)
    fc, fd = f(c), f(d)
    for _ in range(iters):
        left = fc <= fd
        b = np.where(left, d, b)
        a = np.where(left, a, c)
        new_c = a + GOLDEN * (b - a)
        new_d = b - GOLDEN * (b - a)
        c_next = np.where(left, new_c, d)
        d_next = np.where(left, c, new_d)
        f_eval = f(np.where(left, new_c, new_d))
        fc, fd = np.where(left, f_eval, fd), np.where(left, fc, f_eval)
        c, d = c_next, d_next
    tm = 0.5 * (a + b)
    fm = f(tm)
    better = fm < best
    return np.where(better, fm, best), np.where(better, tm, best_t)


def machined_deviation(tools, points2d, normals2d, v0, handedness="right", max_deviation=None, tol=1e-12):
    """Signed deviation of design profile points (plane z = 0) from the simulated machined surface.

    Args:
        tools: list of :class:`StripTool` (all strips of a plan).
        points2d, normals2d: (N, 2) design points and unit outward normals of the profile.
        max_deviation: search limit; points with no machined surface within it get +inf (uncut).
    Returns:
        (N,) deviation: > 0 material left, < 0 overcut, +inf not reached by any tool.
    """
    p = np.c_[np.asarray(points2d, float), np.zeros(len(points2d))]
    n = np.c_[np.asarray(normals2d, float), np.zeros(len(points2d))]
    if max_deviation is None:
        max_deviation = 0.25 * float(np.max(np.linalg.norm(points2d, axis=1)))

    # D is 1-Lipschitz along the ray, so a tool farther than the search range at lambda = 0 can
    # never form the surface within it: each point only looks at its candidate tools
    d_tools = np.stack([helical_distance(t, p, v0, handedness)[0] for t in tools])
    relevant = d_tools <= max_deviation + 1e-12

    def D(lam, idx=None):
        idx = np.arange(len(p)) if idx is None else idx
        q = p[idx] + lam[:, None] * n[idx]
        out = np.full(len(idx), np.inf)
        for k, t in enumerate(tools):
            sel = np.flatnonzero(relevant[k, idx])
            if len(sel):
                out[sel] = np.minimum(out[sel], helical_distance(t, q[sel], v0, handedness)[0])
        return out

    d0 = np.min(d_tools, axis=0)
    scale = float(np.max(np.abs(points2d)))
    # sphere tracing: outside the swept region D is the exact distance, so a step of D cannot jump
    # over the first crossing (a brief pass through the region included); the extra 1e-9 lets the
    # march cross the surface instead of creeping up to it.  Inside, march outwards the same way.
    lo = np.zeros(len(p))
    f_lo = d0.copy()
    hi = lo.copy()
    f_hi = d0.copy()
    direction = np.where(d0 >= 0, 1.0, -1.0)
    active = d0 != 0
    for _ in range(400):
        idx = np.flatnonzero(active)
        if not len(idx):
            break
        step = direction[idx] * (np.abs(f_lo[idx]) + 1e-9 * scale)
        lam = lo[idx] + step
        out = np.abs(lam) > max_deviation
        lam = np.clip(lam, -max_deviation, max_deviation)
        f_new = D(lam, idx)
        crossed = np.sign(f_new) != np.sign(f_lo[idx])
        hi[idx], f_hi[idx] = lam, f_new
        keep = ~crossed & ~out
        lo[idx[keep]], f_lo[idx[keep]] = lam[keep], f_new[keep]
        active[idx[crossed | out]] = False
    found = (np.sign(f_hi) != np.sign(f_lo)) | (f_lo == 0)
    # Illinois (modified regula falsi) on the bracket, only for points not yet converged
    side = np.zeros(len(p))
    for _ in range(100):
        idx = np.flatnonzero(found & (np.abs(hi - lo) > tol) & (f_hi != 0))
        if not len(idx):
            break
        l, fl, h, fh = lo[idx], f_lo[idx], hi[idx], f_hi[idx]
        with np.errstate(invalid="ignore", divide="ignore"):   # rays never reached carry inf
            m = np.where(fh != fl, h - fh * (h - l) / (fh - fl), 0.5 * (l + h))
        m = np.where((m - l) * (m - h) < 0, m, 0.5 * (l + h))
        fm = D(m, idx)
        same_hi = np.sign(fm) == np.sign(fh)
        lo[idx] = np.where(same_hi, l, h)
        f_lo[idx] = np.where(same_hi, np.where(side[idx] == 1, 0.5 * fl, fl), fh)
        side[idx] = np.where(same_hi, 1, -1)
        hi[idx], f_hi[idx] = m, fm
    root = np.where(np.abs(f_hi) <= np.abs(f_lo), hi, lo)
    root = np.where(f_lo == 0, lo, root)
    return np.where(found, root, np.inf)
