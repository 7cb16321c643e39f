"""Synthetic free-form test surfaces for the Rajain et al. 2023 planner, as triangle meshes with exact geometry.

Rajain et al. 2023 §7 demonstrates its method on gear flanks, a blisk blade "close to a parabolic cylinder",
and free-form and convex/concave bump surfaces.  Those data sets are not public, so the tests
build stand-ins here, each a regular parameter grid triangulated into a mesh together with the
exact surface behind it:

=====================  ===================================================  ===============
generator              surface                                              Gaussian curv.
=====================  ===================================================  ===============
:func:`plane_patch`    square in z = 0 (optionally jittered interior)       0
:func:`cylinder_patch` circular cylinder patch, rulings along z             0 (developable)
:func:`parabolic_blade` parabolic cylinder z = x^2 / (2 rho), rulings || y  0 (developable)
:func:`gear_flank`     involute helicoid (flank of a helical involute gear) 0 (developable)
:func:`bump`           Gaussian bump z = A exp(-(x^2 + y^2) / (2 s^2))      both signs
:func:`saddle`         hyperbolic paraboloid z = (x^2 - y^2) / (2 R)        < 0
=====================  ===================================================  ===============

Every generator returns a :class:`FreeformSurface`: vertices (V, 3), faces (F, 3) oriented so that
the face normals agree with the exact unit normal, the vertices' parameters uv (V, 2), and the
exact ``point(uv)`` / ``normal(uv)`` maps (and ``closest(points)`` where it is cheap: plane,
cylinder, parabolic cylinder).  ``resolution`` is the number of grid cells along the longer
parameter side; the other side gets cells of about the same size, so a surface has about
2 * resolution^2 * (short side / long side) triangles.
"""
import math
from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np

from .angles import atan2, contiguous


@dataclass(frozen=True)
class FreeformSurface:
    """A test surface: its triangle mesh and the exact surface it samples.

    vertices (V, 3), faces (F, 3) int (counter-clockwise seen from the normal's side), uv (V, 2)
    parameters of the vertices; ``point(uv (n, 2)) -> (n, 3)`` and ``normal(uv (n, 2)) -> (n, 3)``
    unit normals, exact; ``closest(points (n, 3)) -> (feet (n, 3), uv (n, 2))`` the exact closest
    point on the untrimmed surface, or None; ``size`` the patch's longer extent.
    """
    name: str
    vertices: np.ndarray
    faces: np.ndarray
    uv: np.ndarray
    point: Callable
    normal: Callable
    closest: Optional[Callable]
    size: float


# ============================================================================ grid
def grid_counts(extent_u, extent_v, resolution):
    """(nu, nv) cells for a parameter rectangle extent_u x extent_v: ``resolution`` cells along
    the longer side, about square cells.  resolution may also be a pair (nu, nv)."""
    if np.ndim(resolution) == 1:
        nu, nv = (int(r) for r in resolution)
    else:
        r = int(resolution)
        if extent_u >= extent_v:
            nu, nv = r, max(1, int(round(r * extent_v / extent_u)))
        else:
            nu, nv = max(1, int(round(r * extent_u / extent_v))), r
    if nu < 1 or nv < 1 or nu * nv > 4_000_000:
        raise ValueError(f"grid of {nu} x {nv} cells is outside the limits 1 .. 4,000,000 cells")
    return nu, nv


def grid_faces(nu, nv, diagonals="alternate"):
    """Triangles (2 nu nv, 3) of an (nu + 1) x (nv + 1) vertex grid, vertex (i, j) = i (nv + 1) + j.

    Triangles are counter-clockwise in the (u, v) plane.  diagonals: 'alternate' flips the
    diagonal in a checkerboard pattern (no preferred direction), 'forward' always splits along
    (i, j)-(i+1, j+1).
    """
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    i, j = i.ravel(), j.ravel()
    v00 = i * (nv + 1) + j
    v10, v01, v11 = v00 + nv + 1, v00 + 1, v00 + nv + 2
    fwd = np.ones(len(v00), bool) if diagonals == "forward" else ((i + j) % 2 == 0)
    if diagonals not in ("forward", "alternate"):
        raise ValueError(f"diagonals must be 'alternate' or 'forward', got {diagonals!r}")
    t1 = np.where(fwd[:, None], np.c_[v00, v10, v11], np.c_[v00, v10, v01])
    t2 = np.where(fwd[:, None], np.c_[v00, v11, v01], np.c_[v10, v11, v01])
    return np.concatenate([t1, t2]).astype(np.int64)


def grid_uv(u_range, v_range, nu, nv):
    """Parameters (V, 2) of the grid vertices, u-major as in :func:`grid_faces`."""
    u = np.linspace(*u_range, nu + 1)
    v = np.linspace(*v_range, nv + 1)
    U, W = np.meshgrid(u, v, indexing="ij")
    return np.c_[U.ravel(), W.ravel()]


def _positive(name, value):
    value = float(value)
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{name} = {value!r} must be a finite number > 0")
    return value


def _graph_surface(name, size, resolution, height, grad, jitter=0.0, seed=0, diagonals="alternate"):
    """Surface z = height(x, y) over the square [-size/2, size/2]^2; grad(x, y) -> (hx, hy)."""
    size = _positive("size", size)
    nu, nv = grid_counts(size, size, resolution)
    uv = grid_uv((-size / 2, size / 2), (-size / 2, size / 2), nu, nv)
    if jitter:
        h = size / max(nu, nv)
        inner = (np.abs(uv) < size / 2 - 1e-12 * size).all(axis=1)
        rng = np.random.default_rng(seed)
        uv = uv.copy()
        uv[inner] += rng.uniform(-jitter * h, jitter * h, (inner.sum(), 2))

    def point(q):
        q = np.atleast_2d(q)
        return np.c_[q[:, 0], q[:, 1], height(q[:, 0], q[:, 1])]

    def normal(q):
        q = np.atleast_2d(q)
        hx, hy = grad(q[:, 0], q[:, 1])
        n = np.c_[-hx, -hy, np.ones(len(q))]
        return n / np.linalg.norm(n, axis=1, keepdims=True)

    return uv, point, normal, grid_faces(nu, nv, diagonals)


# ============================================================================ surfaces
def plane_patch(size=1.0, resolution=20, jitter=0.0, seed=0):
    """Square [-size/2, size/2]^2 in z = 0, normal +z.  jitter > 0 moves the interior vertices by
    up to jitter x the cell size (uniformly random, reproducible by ``seed``): an irregular mesh
    of a plane, on which linear functions must still be reproduced exactly."""
    if not (0 <= jitter < 0.25):
        raise ValueError(f"jitter = {jitter!r} is outside the limits 0 <= jitter < 0.25 (cells could fold)")
    uv, point, normal, faces = _graph_surface("plane", size, resolution, lambda x, y: 0 * x,
                                              lambda x, y: (0 * x, 0 * y), jitter, seed)

    def closest(p):
        p = np.atleast_2d(np.asarray(p, float))
        return np.c_[p[:, :2], np.zeros(len(p))], p[:, :2].copy()

    return FreeformSurface("plane", point(uv), faces, uv, point, normal, closest, float(size))


def cylinder_patch(size=1.0, resolution=40, radius=None, angle=math.pi / 2):
    """Patch of the cylinder x^2 + y^2 = radius^2, outward normal, developable.

    uv = (arc length radius * theta, z) with theta in [-angle/2, angle/2] and z in
    [-size/2, size/2]; radius defaults to ``size``.  Its rulings are the lines theta = const
    (parallel to z).  The mesh's quads are planar, so the mesh itself is developable.
    """
    size = _positive("size", size)
    radius = size if radius is None else _positive("radius", radius)
    angle = _positive("angle", angle)
    if angle >= 2 * math.pi:
        raise ValueError(f"angle = {angle!r} must be below 2 pi (a patch, not a closed tube)")
    arc = radius * angle
    nu, nv = grid_counts(arc, size, resolution)
    uv = grid_uv((-arc / 2, arc / 2), (-size / 2, size / 2), nu, nv)

    def point(q):
        q = np.atleast_2d(q)
        th = q[:, 0] / radius
        return np.c_[radius * np.cos(th), radius * np.sin(th), q[:, 1]]

    def normal(q):
        q = np.atleast_2d(q)
        th = q[:, 0] / radius
        return np.c_[np.cos(th), np.sin(th), np.zeros(len(q))]

    def closest(p):
        p = np.atleast_2d(np.asarray(p, float))
        th = atan2(p[:, 1], p[:, 0])
        q = np.c_[radius * th, p[:, 2]]
        return point(q), q

    return FreeformSurface("cylinder", point(uv), grid_faces(nu, nv), uv, point, normal, closest,
                           float(max(arc, size)))


def parabolic_blade(size=1.0, resolution=40, rho=None, span=None):
    """Parabolic cylinder z = x^2 / (2 rho), x in [-size/2, size/2], y in [-span/2, span/2]
    (a stand-in for Rajain et al. 2023 Fig. 19's blisk blade, "close to a parabolic cylinder").

    rho (radius of curvature at x = 0) defaults to 0.6 size, span to 1.5 size.  uv = (x, y);
    rulings are parallel to y; the normal points to +z at x = 0.  ``closest`` is exact: the
    stationarity condition in x is the cubic x^3 / (2 rho^2) + (1 - p_z / rho) x - p_x = 0, solved in
    closed form for all its real roots, the nearest kept.
    """
    size = _positive("size", size)
    rho = 0.6 * size if rho is None else _positive("rho", rho)
    span = 1.5 * size if span is None else _positive("span", span)
    nu, nv = grid_counts(size, span, resolution)
    uv = grid_uv((-size / 2, size / 2), (-span / 2, span / 2), nu, nv)

    def point(q):
        q = np.atleast_2d(q)
        return np.c_[q[:, 0], q[:, 1], q[:, 0] ** 2 / (2 * rho)]

    def normal(q):
        q = np.atleast_2d(q)
        n = np.c_[-q[:, 0] / rho, np.zeros(len(q)), np.ones(len(q))]
        return n / np.linalg.norm(n, axis=1, keepdims=True)

    def closest(p):
        p = np.atleast_2d(np.asarray(p, float))
        roots = real_cubic_roots(np.full(len(p), 0.5 / rho ** 2), np.zeros(len(p)), 1 - p[:, 2] / rho, -p[:, 0])
        z = roots ** 2 / (2 * rho)
        d2 = (roots - p[:, :1]) ** 2 + (z - p[:, 2:3]) ** 2
        d2 = np.where(np.isfinite(roots), d2, np.inf)
        x = roots[np.arange(len(p)), np.argmin(d2, axis=1)]
        q = np.c_[x, p[:, 1]]
        return point(q), q

    return FreeformSurface("parabolic_blade", point(uv), grid_faces(nu, nv), uv, point, normal, closest,
                           float(max(size, span)))


def real_cubic_roots(a, b, c, d):
    """Real roots of a x^3 + b x^2 + c x + d = 0 (a != 0), arrays (n,) -> (n, 3), NaN-padded.

    Trigonometric form when there are three real roots, Cardano's otherwise; each root is polished
    by two Newton steps."""
    a, b, c, d = (np.asarray(x, float) for x in (a, b, c, d))
    b, c, d = b / a, c / a, d / a
    p = c - b * b / 3
    q = 2 * b ** 3 / 27 - b * c / 3 + d
    disc = (q / 2) ** 2 + (p / 3) ** 3
    out = np.full(a.shape + (3,), np.nan)
    one = disc >= 0
    s = np.sqrt(np.where(one, disc, 0.0))
    out[:, 0] = np.where(one, np.cbrt(-q / 2 + s) + np.cbrt(-q / 2 - s), np.nan)
    three = ~one
    m = 2 * np.sqrt(np.where(three, -p / 3, 0.0))
    arg = np.where(three, 3 * q / (np.where(three, p, -1.0) * np.where(m > 0, m, 1.0)), 0.0)
    th = np.arccos(np.clip(arg, -1, 1)) / 3
    for k in range(3):
        out[:, k] = np.where(three, m * np.cos(th - 2 * np.pi * k / 3), out[:, k])
    x = out - (b / 3)[:, None]
    for _ in range(2):
        f = ((x + b[:, None]) * x + c[:, None]) * x + d[:, None]
        df = (3 * x + 2 * b[:, None]) * x + c[:, None]
        x = np.where(np.abs(df) > 0, x - f / np.where(np.abs(df) > 0, df, 1.0), x)
    return x


def gear_flank(size=1.0, resolution=40, helix_angle=math.radians(25.0), base_radius=None, depth=None):
    """Flank of a helical involute gear tooth: a patch of an involute helicoid, developable.

    Base circle radius r_b (default 2 size), base helix angle ``helix_angle``, lead parameter
    p = r_b / tan(helix_angle).  The transverse section z = 0 is the involute
    I(phi) = r_b (cos phi + phi sin phi, sin phi - phi cos phi); the flank is that involute screwed
    along z: x(phi, z) = Rot_z(z / p) I(phi) + (0, 0, z).  uv = (phi, z) with z over the face width
    [-size/2, size/2] and phi from the root radius 1.02 r_b to the tip radius 1.02 r_b + depth
    (default 0.5 size).  The surface is ruled by the tangents of the base helix: the point (phi, z)
    lies on the ruling with direction T(t) = (-r_b sin t, r_b cos t, p) / c, t = phi + z / p,
    c = sqrt(r_b^2 + p^2) (:func:`gear_ruling`), and its unit normal is constant along the ruling,
    n = (p sin t, -p cos t, r_b) / c.
    """
    size = _positive("size", size)
    if not (0 < helix_angle < math.pi / 2):
        raise ValueError(f"helix_angle = {helix_angle!r} is outside the limits 0 < angle < pi/2")
    rb = 2.0 * size if base_radius is None else _positive("base_radius", base_radius)
    depth = 0.5 * size if depth is None else _positive("depth", depth)
    p = rb / math.tan(helix_angle)
    c = math.hypot(rb, p)
    r0, r1 = 1.02 * rb, 1.02 * rb + depth
    phi_range = (math.sqrt((r0 / rb) ** 2 - 1), math.sqrt((r1 / rb) ** 2 - 1))
    # arc length of the involute is r_b phi^2 / 2: size the grid by it
    ext_phi = rb * (phi_range[1] ** 2 - phi_range[0] ** 2) / 2
    nu, nv = grid_counts(ext_phi, size, resolution)
    # cells of equal involute arc length: uniform in phi^2
    q = np.linspace(phi_range[0] ** 2, phi_range[1] ** 2, nu + 1)
    U, W = np.meshgrid(np.sqrt(q), np.linspace(-size / 2, size / 2, nv + 1), indexing="ij")
    uv = np.c_[U.ravel(), W.ravel()]

    def point(q):
        q = np.atleast_2d(q)
        phi, z = contiguous(q[:, 0]), q[:, 1]
        ix = rb * (np.cos(phi) + phi * np.sin(phi))
        iy = rb * (np.sin(phi) - phi * np.cos(phi))
        a = z / p
        return np.c_[np.cos(a) * ix - np.sin(a) * iy, np.sin(a) * ix + np.cos(a) * iy, z]

    def normal(q):
        q = np.atleast_2d(q)
        t = q[:, 0] + q[:, 1] / p
        return np.c_[p * np.sin(t), -p * np.cos(t), np.full(len(t), rb)] / c

    return FreeformSurface("gear_flank", point(uv), grid_faces(nu, nv), uv, point, normal, None,
                           float(max(ext_phi, size)))


def gear_ruling(surface_uv, helix_angle=math.radians(25.0), base_radius=1.0):
    """Unit ruling directions (n, 3) of :func:`gear_flank` at parameters uv (n, 2) (same
    helix_angle and base_radius as the surface; the default size 1 has base_radius 2)."""
    q = np.atleast_2d(surface_uv)
    rb = float(base_radius)
    p = rb / math.tan(helix_angle)
    t = q[:, 0] + q[:, 1] / p
    return np.c_[-rb * np.sin(t), rb * np.cos(t), np.full(len(t), p)] / math.hypot(rb, p)


def bump(size=1.0, resolution=40, height=None, width=None):
    """Gaussian bump z = height exp(-(x^2 + y^2) / (2 width^2)) over [-size/2, size/2]^2.

    height defaults to 0.15 size, width to 0.2 size: elliptic on top, hyperbolic on the flanks
    (K changes sign at radius = width).  uv = (x, y), normal towards +z."""
    size = _positive("size", size)
    a = 0.15 * size if height is None else float(height)
    s = 0.2 * size if width is None else _positive("width", width)
    if not math.isfinite(a):
        raise ValueError(f"height = {a!r} must be finite")

    def h(x, y):
        return a * np.exp(-(x * x + y * y) / (2 * s * s))

    def g(x, y):
        e = h(x, y) / (s * s)
        return -x * e, -y * e

    uv, point, normal, faces = _graph_surface("bump", size, resolution, h, g)
    return FreeformSurface("bump", point(uv), faces, uv, point, normal, None, float(size))


def saddle(size=1.0, resolution=40, radius=None):
    """Hyperbolic paraboloid z = (x^2 - y^2) / (2 radius) over [-size/2, size/2]^2; radius (the
    principal curvature radius at the origin) defaults to 1.5 size.  uv = (x, y), normal to +z."""
    size = _positive("size", size)
    R = 1.5 * size if radius is None else _positive("radius", radius)
    uv, point, normal, faces = _graph_surface("saddle", size, resolution, lambda x, y: (x * x - y * y) / (2 * R),
                                              lambda x, y: (x / R, -y / R))
    return FreeformSurface("saddle", point(uv), faces, uv, point, normal, None, float(size))


SURFACES = {"plane": plane_patch, "cylinder": cylinder_patch, "parabolic_blade": parabolic_blade,
            "gear_flank": gear_flank, "bump": bump, "saddle": saddle}


def make_surface(name, size=1.0, resolution=40, **kwargs):
    """One of :data:`SURFACES` by name."""
    if name not in SURFACES:
        raise ValueError(f"unknown test surface {name!r}; choose one of {', '.join(SURFACES)}")
    return SURFACES[name](size=size, resolution=resolution, **kwargs)
