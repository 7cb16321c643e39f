"""Feeds and speeds: cutting data per tool and the cutting conditions of a rotor pass.

Cutting data (:class:`CuttingData`, defaults and units in docs/feeds-and-speeds.md): flutes z, cutting speed
vc (m/min), feed per tooth fz (mm), the tool's top spindle speed.  Tool presets (``presets/flank_tool``) are
keyed by name in :data:`PRESET_CUTTING_DATA`; a plan's cone is matched to a preset by tip diameter and
taper, otherwise the defaults of its kind apply (end mill, or disc cutter for a formed cutter).

Conditions of a pass (the tool fixed in the rotor frame while the rotor screws, :mod:`..geometry.screw`):

* engaged edge: the tool's surface points inside the stock cylinder, rho <= outer radius (what can cut);
* spindle speed n = min(1000 vc / (pi D_max), tool top speed, machine top speed) with D_max the largest
  engaged diameter, rounded down to whole turns (the S the posts write), so the surface speed along the
  (tapered) edge runs from pi D_min n / 1000 to vc; D_max is exact where the edge leaves the stock between two
  sampled rings (:func:`largest_engaged_diameter`);
* feed: a rotor point q moves by dS_t/dt = hand (e_z x q) + v0 e_z per radian of the screw parameter t, so
  relative to the tool it moves at omega |v(q)|, |v(q)| = sqrt(rho(q)^2 + v0^2) (omega: screw rate, rad/min).
  The feed n z fz is given to the fastest engaged point: omega = n z fz / max |v| over the engaged edge (where
  the cutting part reaches out of the stock, at the stock's radius exactly: :func:`engagement`), so
  the largest chip load is fz (counted along the whole relative motion: conservative where part of it slides
  along the flutes); then omega is lowered until no joint of the pass exceeds its top speed (a joint-linear
  pass moves joint j at |dJ_j/dt| omega);
* chip load along the edge: fz(q) = omega |v(q)| / (n z); cutting time |t_end - t_start| / omega.
"""
import math
from dataclasses import dataclass

import numpy as np


# the largest cutting data taken: beyond them a value is a typing or unit slip (high-speed milling of aluminium
# reaches a few thousand m/min; a disc cutter has tens of teeth; spindles turn up to some 100,000 1/min)
MAX_CUTTING = {"flutes": 500, "vc_m_min": 10000.0, "fz_mm": 10.0, "max_rpm": 500000.0}


@dataclass(frozen=True)
class CuttingData:
    flutes: int
    vc_m_min: float          # cutting speed, m/min
    fz_mm: float             # feed per tooth, mm
    max_rpm: float           # the tool's top spindle speed, 1/min
    source: str = "default"

    def __post_init__(self):
        if isinstance(self.flutes, bool) or not isinstance(self.flutes, int) or self.flutes < 1:
            raise ValueError(f"flutes must be an integer >= 1, got {self.flutes!r}")
        if self.flutes > MAX_CUTTING["flutes"]:
            raise ValueError(f"flutes {self.flutes} is over {MAX_CUTTING['flutes']}: no milling tool has as many")
        for name in ("vc_m_min", "fz_mm", "max_rpm"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {v!r}")
            if v > MAX_CUTTING[name]:
                raise ValueError(f"{name} {v:g} is over {MAX_CUTTING[name]:g}: no cutting data of a milling tool "
                                 "(a unit slip?)")

    def as_dict(self):
        return {"flutes": self.flutes, "vc_m_min": self.vc_m_min, "fz_mm": self.fz_mm,
                "max_rpm": self.max_rpm, "source": self.source}


# Finishing a steel or cast-iron rotor flank with solid carbide (documented in docs/feeds-and-speeds.md).
DEFAULT_END_MILL = CuttingData(4, 120.0, 0.03, 24000.0, "default end mill")
DEFAULT_DISC_CUTTER = CuttingData(16, 150.0, 0.05, 3000.0, "default disc cutter")

# Cutting data of the Blender tool presets (presets/flank_tool/<name>.py), finishing in steel.
PRESET_CUTTING_DATA = {
    "Tapered 1deg D1 L10": CuttingData(2, 80.0, 0.006, 30000.0, "Tapered 1deg D1 L10"),
    "Tapered 1.5deg D2 L20": CuttingData(3, 90.0, 0.010, 30000.0, "Tapered 1.5deg D2 L20"),
    "Tapered 2deg D3 L25": CuttingData(3, 100.0, 0.015, 24000.0, "Tapered 2deg D3 L25"),
    "Tapered 3deg D4 L20": CuttingData(4, 110.0, 0.020, 24000.0, "Tapered 3deg D4 L20"),
    "Tapered 1.5deg D4 L40": CuttingData(4, 100.0, 0.018, 20000.0, "Tapered 1.5deg D4 L40"),
    "Tapered 5deg D4 L16": CuttingData(4, 110.0, 0.020, 24000.0, "Tapered 5deg D4 L16"),
    "Tapered 1deg D6 L40": CuttingData(4, 110.0, 0.025, 16000.0, "Tapered 1deg D6 L40"),
    "Tapered 2deg D6 L35": CuttingData(4, 120.0, 0.030, 16000.0, "Tapered 2deg D6 L35"),
    "Tapered 3deg D6 L30": CuttingData(4, 120.0, 0.030, 16000.0, "Tapered 3deg D6 L30"),
    "Tapered 5deg D6 L20": CuttingData(4, 120.0, 0.030, 16000.0, "Tapered 5deg D6 L20"),
    "Cylindrical D6 L13": CuttingData(4, 120.0, 0.030, 20000.0, "Cylindrical D6 L13"),
    "Cylindrical D8 L19": CuttingData(4, 120.0, 0.040, 16000.0, "Cylindrical D8 L19"),
    "Cylindrical D10 L22": CuttingData(4, 120.0, 0.045, 14000.0, "Cylindrical D10 L22"),
    "Cylindrical D12 L26": CuttingData(4, 120.0, 0.050, 12000.0, "Cylindrical D12 L26"),
}
# (taper deg, tip diameter mm, flute length mm) of each preset, to recognise a plan's cone
PRESET_GEOMETRY = {
    "Tapered 1deg D1 L10": (1.0, 1.0, 10.0), "Tapered 1.5deg D2 L20": (1.5, 2.0, 20.0),
    "Tapered 2deg D3 L25": (2.0, 3.0, 25.0), "Tapered 3deg D4 L20": (3.0, 4.0, 20.0),
    "Tapered 1.5deg D4 L40": (1.5, 4.0, 40.0), "Tapered 5deg D4 L16": (5.0, 4.0, 16.0),
    "Tapered 1deg D6 L40": (1.0, 6.0, 40.0), "Tapered 2deg D6 L35": (2.0, 6.0, 35.0),
    "Tapered 3deg D6 L30": (3.0, 6.0, 30.0), "Tapered 5deg D6 L20": (5.0, 6.0, 20.0),
    "Cylindrical D6 L13": (0.0, 6.0, 13.0), "Cylindrical D8 L19": (0.0, 8.0, 19.0),
    "Cylindrical D10 L22": (0.0, 10.0, 22.0), "Cylindrical D12 L26": (0.0, 12.0, 26.0),
}


def preset_cutting_data(name):
    try:
        return PRESET_CUTTING_DATA[name]
    except KeyError:
        raise ValueError(f"no cutting data for tool preset {name!r}; presets: "
                         f"{', '.join(sorted(PRESET_CUTTING_DATA))}") from None


def cutting_data_for(tool):
    """Cutting data for a plan's ``tool`` dict (mm): the preset with the same cone (taper within 0.05 deg,
    tip diameter and flute length within 1 %), else the default of its kind."""
    if tool.get("kind") == "disc":
        return DEFAULT_DISC_CUTTER
    if tool.get("kind") == "cone" and all(k in tool for k in ("alpha", "r1c", "h")):
        taper, d, L = math.degrees(tool["alpha"]), 2.0 * tool["r1c"], tool["h"]
        for name, (tp, dp, lp) in PRESET_GEOMETRY.items():
            if abs(taper - tp) < 0.05 + (0.01 if tp == 0 else 0) and abs(d - dp) <= 0.01 * dp and abs(L - lp) <= 0.01 * lp:
                return PRESET_CUTTING_DATA[name]
    return DEFAULT_END_MILL


def resolve_cutting_data(spec, tool):
    """The cutting data of a plan's ``tool`` dict under ``spec``: None -> the tool's own
    (:func:`cutting_data_for`); a :class:`CuttingData` -> that, for every tool; a callable -> ``spec(tool)``
    (e.g. :func:`with_overrides` on each tool's own data)."""
    if spec is None:
        return cutting_data_for(tool)
    if isinstance(spec, CuttingData):
        return spec
    return spec(tool)


def with_overrides(overrides, base=None):
    """A cutting-data spec for :func:`resolve_cutting_data`: each tool's own data (``base``: one CuttingData for
    every tool instead) with the fields of ``overrides`` ({"flutes": .., "vc_m_min": .., "fz_mm": .., "max_rpm":
    ..}, any of them) replaced, so a disc cutter keeps its own top speed when only fz is given.  The data names its
    source: "<the tool's own> with fz_mm 0.02 from the command line", or "command line" when all four are given."""
    import dataclasses

    dataclasses.replace(base or DEFAULT_END_MILL, **overrides)        # a value the data refuses is named at once

    def spec(tool):
        own = base if base is not None else cutting_data_for(tool)
        if set(overrides) == {"flutes", "vc_m_min", "fz_mm", "max_rpm"}:        # nothing of its own is left
            return dataclasses.replace(own, source="command line", **overrides)
        return dataclasses.replace(own, source=f"{own.source} with " + ", ".join(
            f"{k} {v:g}" for k, v in overrides.items()) + " from the command line", **overrides)
    return spec


@dataclass
class PassConditions:
    rpm: float
    omega: float                 # screw rate, rad/min
    time_min: float
    chip_load: tuple             # (min, max) mm over the engaged edge
    surface_speed: tuple         # (min, max) m/min over the engaged edge
    engaged_diameter: tuple      # (min, max) mm
    limited_by: str              # "chip load" or the joint whose top speed capped the feed
    cutting_length: float        # length of the tool tip's path relative to the rotor, mm
    feed_mm_min: float           # fastest relative speed of the engaged edge, mm/min

    def as_dict(self):
        return {"rpm": self.rpm, "omega_rad_min": self.omega, "time_s": 60.0 * self.time_min,
                "chip_load_mm": list(self.chip_load), "surface_speed_m_min": list(self.surface_speed),
                "engaged_diameter_mm": list(self.engaged_diameter), "limited_by": self.limited_by,
                "cutting_length_mm": self.cutting_length, "feed_mm_min": self.feed_mm_min}


# rings on the cutting part at least: a tool shorter than the spacing would otherwise be sampled at its two
# poles only, where the radius is 0 (a 0.3 mm cone on a 1 mm rotor "never entered" the stock)
MIN_RINGS = 32


def engaged_edge(shape, tip, axis, outer_radius, spacing=0.5):
    """Surface samples of the cutting part inside the stock radius at the pose (tip, axis): points (K, 3)
    and their diameters (K,).  Rings at most ``spacing`` (mm) apart along the axis and at least
    :data:`MIN_RINGS` of them over the cutting part, whatever its length."""
    pts, D, rho = _edge_samples(shape, tip, axis, _cutting_rings(shape, spacing))
    inside = rho <= outer_radius
    return pts[inside], D[inside]


def _cutting_rings(shape, spacing):
    """Heights and radii (h, R) of the cutting part's rings: at most ``spacing`` apart, at least
    :data:`MIN_RINGS` of them."""
    lo, hi = shape.cutting_range()
    h, R, sh = shape.outline(min(float(spacing), (hi - lo) / MIN_RINGS))
    return h[~sh], R[~sh]


def _edge_samples(shape, tip, axis, rings):
    """Every surface sample of the cutting part's ``rings`` (:func:`_cutting_rings`) at the pose
    (:func:`engaged_edge`): points (rings, m, 3), their diameters and their distances rho from the rotor axis
    (rings, m)."""
    from .tool_shape import perpendicular_frames

    h, R = rings
    m = 48
    th = np.arange(m) * (2 * math.pi / m)
    e1, e2 = perpendicular_frames(axis)
    ring = np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2              # (m, 3)
    pts = np.asarray(tip, float) + h[:, None, None] * np.asarray(axis, float) + R[:, None, None] * ring[None]
    rho = np.hypot(pts[..., 0], pts[..., 1])
    return pts, np.broadcast_to(2.0 * R[:, None], rho.shape), rho


@dataclass(frozen=True)
class Engagement:
    """What the cutting part at one pose can cut (:func:`engagement`)."""
    speed: float                 # largest |v(q)| = sqrt(rho^2 + v0^2) over the engaged edge, per radian of t
    diameter: float              # largest engaged diameter, mm
    points: np.ndarray           # sampled engaged points (K, 3)
    diameters: np.ndarray        # their diameters (K,)


def engagement(shape, tip, axis, rotor, spacing=0.5):
    """:class:`Engagement` of the cutting part at the pose (tip, axis) in the stock cylinder of ``rotor``.

    Fastest point: where the cutting part reaches out of the stock, its surface (connected, partly inside) crosses
    the cylinder, so the largest rho is the stock's radius exactly, whatever the sampling; otherwise the largest
    sampled.  Largest diameter: :func:`largest_engaged_diameter` (exact where the edge leaves the stock between
    two rings).  Points and diameters: the samples of :func:`engaged_edge`."""
    rings = _cutting_rings(shape, spacing)              # sampled once for both
    pts, D, rho = _edge_samples(shape, tip, axis, rings)
    inside = rho <= rotor.outer_radius
    if not inside.any():
        # no sample inside, yet the edge may graze the stock between two rings: then it crosses the stock's
        # cylinder, and its fastest engaged point is on the rim, as where it reaches out of the stock
        graze = largest_engaged_diameter(shape, tip, axis, rotor.outer_radius, rings=rings)
        speed = math.hypot(rotor.outer_radius, rotor.v0) if graze > 0 else 0.0
        return Engagement(speed, graze, pts[inside], D[inside])
    top = rotor.outer_radius if not inside.all() else max(float(rho.max()), _largest_rho(shape, tip, axis, rings))
    d_max = max(largest_engaged_diameter(shape, tip, axis, rotor.outer_radius, rings=rings), float(D[inside].max()))
    return Engagement(math.hypot(top, rotor.v0), d_max, pts[inside], D[inside])


def _largest_rho(shape, tip, axis, rings, zooms=4, n=32):
    """The largest distance from the rotor axis over the cutting part at the pose: each ring's exactly
    (:func:`ring_max_rho`), then between the neighbours of the farthest ring on finer rings, ``zooms`` times,
    each ``n`` times finer (48 samples a ring 0.5 mm apart fell short by up to 1.6e-4 of it, and a block's chip
    load went as much over fz)."""
    tip, axis = np.asarray(tip, float), np.asarray(axis, float)
    frame = _frame(axis)
    h, R = rings
    r = ring_max_rho(tip, axis, h, R, frame)
    i = int(np.argmax(r))
    best, lo, hi = float(r[i]), h[max(i - 1, 0)], h[min(i + 1, len(h) - 1)]
    for _ in range(zooms):
        hs = np.linspace(lo, hi, n + 1)
        rs = ring_max_rho(tip, axis, hs, shape._cutting_radius(hs), frame)
        j = int(np.argmax(rs))
        best = max(best, float(rs[j]))
        lo, hi = hs[max(j - 1, 0)], hs[min(j + 1, n)]
    return best


def ring_min_rho(tip, axis, h, R, frame=None):
    """Smallest distance from the rotor axis (the z axis) over each circle of radius R (n,) about tip + h axis,
    perpendicular to the unit ``axis``: exact to rounding (48 samples, then Newton steps on rho^2(theta), a
    trigonometric polynomial of degree 2 with at most two minima, so the best sample lies in the global one's
    basin).  ``frame``: the axis' (e1, e2) of :func:`_frame`, when the caller has it."""
    return _ring_rho(tip, axis, h, R, frame, 1.0)


def ring_max_rho(tip, axis, h, R, frame=None):
    """Largest distance from the rotor axis over each circle (:func:`ring_min_rho`'s circles), exact to rounding
    the same way: the fastest point of a ring under the screw motion, |v| = sqrt(rho^2 + v0^2)."""
    return _ring_rho(tip, axis, h, R, frame, -1.0)


def _ring_rho(tip, axis, h, R, frame, sign):
    """:func:`ring_min_rho` (``sign`` 1) or :func:`ring_max_rho` (-1): Newton on sign * rho^2(theta)."""
    e1, e2 = _frame(axis) if frame is None else frame
    h, R = np.asarray(h, float), np.asarray(R, float)
    cx, cy = tip[0] + h * axis[0], tip[1] + h * axis[1]          # ring centres and axes, projected on xy
    px, py, qx, qy = R * e1[0], R * e1[1], R * e2[0], R * e2[1]
    m = 48
    th = np.arange(m) * (2 * math.pi / m)
    cs, sn = np.cos(th), np.sin(th)
    g = sign * ((cx[:, None] + px[:, None] * cs + qx[:, None] * sn) ** 2
                + (cy[:, None] + py[:, None] * cs + qy[:, None] * sn) ** 2)
    t = th[np.argmin(g, axis=1)]
    best = g.min(axis=1)
    for _ in range(8):
        cs, sn = np.cos(t), np.sin(t)
        ux, uy = px * cs + qx * sn, py * cs + qy * sn                # w - c
        wx, wy = cx + ux, cy + uy
        dx, dy = qx * cs - px * sn, qy * cs - py * sn                # dw / dtheta
        g1 = sign * 2.0 * (wx * dx + wy * dy)
        g2 = sign * 2.0 * (dx * dx + dy * dy - wx * ux - wy * uy)
        step = np.clip(np.where(g2 > 0, -g1 / np.where(g2 > 0, g2, 1.0), -np.sign(g1) * (math.pi / m)),
                       -math.pi / m, math.pi / m)
        t = t + step
        cs, sn = np.cos(t), np.sin(t)
        best = np.minimum(best, sign * ((cx + px * cs + qx * sn) ** 2 + (cy + py * cs + qy * sn) ** 2))
        if not np.abs(step).max(initial=0.0) > 1e-13:         # Newton has converged (quadratically)
            break
    return np.sqrt(sign * best)


def _frame(axis):
    """Two unit vectors (3,) completing the unit ``axis`` to a right-handed frame."""
    from .tool_shape import perpendicular_frames

    return tuple(np.reshape(e, 3) for e in perpendicular_frames(np.asarray(axis, float)))


def _radius_knots(shape):
    """Heights at which the cutting part's radius R(h) may have its largest values, so that between two
    neighbouring sample heights the largest R is at one of them or where the edge leaves the stock: the knots of
    a meridian where R is largest among its neighbours (R is linear between knots); the centres of a cone's
    spheres (R(h) = max_s sqrt(r_s^2 - (h - c_s)^2) is at most the largest radius, reached at its centre); a
    paraboloid's axis start (its widest)."""
    if shape.meridian is not None:
        R = shape.meridian[:, 1]
        up = np.r_[True, R[1:] >= R[:-1]] & np.r_[R[:-1] >= R[1:], True]
        return shape.h_start + shape.meridian[up, 0]
    if shape.paraboloid is not None:
        return np.array([shape.h_start])
    return np.linspace(shape.h_start, shape.h_end, len(shape.radii))


def _crossing(f, a, b):
    """A height in [a, b] where f changes sign from <= 0 (inside) to > 0: where |f| is at most 1e-12 of its
    change over [a, b], else the inside end of the last bracket, 1e-12 of b - a wide (the Illinois variant of
    regula falsi: superlinear on a smooth f, never leaving the bracket).  None when f does not change sign over
    [a, b] (a meridian ring that carries the largest radius of its cell counted where the meridian itself does
    not)."""
    fa, fb = f(a), f(b)
    if (fa <= 0) == (fb <= 0):
        return None
    if fa > 0:                                    # keep a inside
        a, b, fa, fb = b, a, fb, fa
    tol, ftol, side = 1e-12 * abs(b - a), 1e-12 * (fb - fa), 0
    for _ in range(100):
        if abs(b - a) <= tol:
            break
        c = (a * fb - b * fa) / (fb - fa)
        if not min(a, b) < c < max(a, b):
            c = 0.5 * (a + b)
        fc = f(c)
        if abs(fc) <= ftol:                       # on the stock's surface, to rounding
            return c
        if fc <= 0:
            a, fa = c, fc
            if side == -1:
                fb *= 0.5
            side = -1
        else:
            b, fb = c, fc
            if side == 1:
                fa *= 0.5
            side = 1
    return a


def largest_engaged_diameter(shape, tip, axis, outer_radius, spacing=0.5, rings=None):
    """Largest diameter of the cutting part at the pose (tip, axis) with a point inside the stock cylinder
    (rho <= ``outer_radius``), 0 where none is.  Rings at the heights of :func:`engaged_edge` and at
    :func:`_radius_knots`; a ring counts when its nearest point to the rotor axis
    (:func:`ring_min_rho`) is inside.  Between two neighbouring rings of which one counts and the other does
    not, the height where the edge crosses the stock's surface is found (:func:`_crossing`), and its diameter
    taken: the surface speed pi D n is then the largest on the edge, not the largest sampled (where a tool's wide
    end leaves the stock between two rings the sampled one was up to 0.7% smaller on the test plans' cones, 2% on
    the double-flank tool).  Where the edge may dip into the stock and out again between two neighbouring rings
    (grazing), the stretch is searched (:func:`_grazing_diameter`).  ``rings``: :func:`_cutting_rings` of
    ``spacing``, when the caller has them."""
    h, R = _cutting_rings(shape, spacing) if rings is None else rings
    knots = _radius_knots(shape)
    h, R = np.concatenate([h, knots]), np.concatenate([R, shape._cutting_radius(knots)])
    order = np.argsort(h, kind="stable")
    h, R = h[order], R[order]
    frame = _frame(axis)
    rho = ring_min_rho(tip, axis, h, R, frame)
    counts = rho <= outer_radius
    best = float(2.0 * R[counts].max(initial=0.0))

    def outside(hv):            # > 0 where the ring at height hv lies wholly outside the stock
        hv = np.array([hv])
        return float(ring_min_rho(tip, axis, hv, shape._cutting_radius(hv), frame)[0]) - outer_radius

    # (a, b, g(a), g(b)) of the stretches between two heights outside the stock: g = rho_min - outer radius
    out = rho - outer_radius
    both_out = np.flatnonzero(~counts[:-1] & ~counts[1:])
    spans = [(h[both_out], h[both_out + 1], out[both_out], out[both_out + 1])]
    for k in np.flatnonzero(counts[:-1] != counts[1:]):
        cross = _crossing(outside, h[k], h[k + 1])
        if cross is not None:
            best = max(best, float(2.0 * shape._cutting_radius(np.array([cross]))[0]))
            # beyond the crossing, up to the neighbour outside, the edge may come back in: examined too
            k_out = k + 1 if counts[k] else k
            a, b = sorted((cross, h[k_out]))
            spans.append((np.array([a]), np.array([b]), np.array([0.0]), np.array([out[k_out]])))
    return _grazing_diameter(shape, tip, axis, outer_radius, frame, best, *map(np.concatenate, zip(*spans)))


def _grazing_diameter(shape, tip, axis, outer_radius, frame, best, a, b, ga, gb, levels=10, n_var=9):
    """``best`` or the diameter of a ring inside the stock on a stretch [a, b] whose ends are outside it (g =
    rho_min - outer radius > 0, or 0 at a crossing), where the edge may dip in and out between two rings.

    Moving a ring by dh along the axis and changing its radius by dR moves each of its points by at most
    |dh| + |dR|, so |g(h) - g(a)| <= |h - a| + |R(h) - R(a)|: a stretch can hold a ring inside only when
    g(a) - V_a + g(b) - V_b <= b - a, V_a (V_b) the largest change of R from its value at a (b) over the stretch
    (from R at ``n_var`` points).  Such a stretch, if it could carry a diameter over ``best``, is halved and
    its midpoint's ring examined, ``levels`` times: at most 2^-levels of the ring spacing is left unseen."""
    for _ in range(levels):
        if not len(a):
            break
        u = np.linspace(0.0, 1.0, n_var)
        hs = a[:, None] + (b - a)[:, None] * u[None, :]
        Rs = shape._cutting_radius(hs.ravel()).reshape(hs.shape)
        va = np.abs(Rs - Rs[:, :1]).max(axis=1)
        vb = np.abs(Rs - Rs[:, -1:]).max(axis=1)
        keep = (2.0 * Rs.max(axis=1) > best) & (ga - va + gb - vb <= b - a)
        a, b, ga, gb = a[keep], b[keep], ga[keep], gb[keep]
        if not len(a):
            break
        mid, Rm = hs[keep, n_var // 2], Rs[keep, n_var // 2]       # the samples' middle ones (n_var odd)
        gm = ring_min_rho(tip, axis, mid, Rm, frame) - outer_radius
        if (gm <= 0).any():
            best = max(best, float(2.0 * Rm[gm <= 0].max()))
        a, b = np.r_[a, mid], np.r_[mid, b]
        ga, gb = np.r_[ga, gm], np.r_[gm, gb]
    return best


def spindle_speed(data, max_diameter, machine_max_rpm):
    """n = min(1000 vc / (pi D_max), tool top speed, machine top speed), 1/min, rounded down to whole turns: the
    posts write S in whole turns, and the feeds are computed for the S the machine runs, so the chip load is fz
    and the surface speed at most vc (at D_max, :func:`largest_engaged_diameter`) as the machine cuts.  Below
    1 /min there is no S to write: refused."""
    n = min(1000.0 * data.vc_m_min / (math.pi * max_diameter), data.max_rpm, machine_max_rpm)
    if not n >= 1.0:
        raise ValueError(f"spindle speed {n:.3g} /min is below 1 /min (vc {data.vc_m_min:g} m/min, engaged "
                         f"diameter {max_diameter:.4g} mm, tool top speed {data.max_rpm:g}, machine top speed "
                         f"{machine_max_rpm:g}): a program's S counts whole turns")
    return float(math.floor(n))


def pass_conditions(shape, tip, axis, rotor, data, rpm, t_span, joint_rates, joint_limits, eng=None):
    """:class:`PassConditions` of a pass (module doc).  ``joint_rates``: |dJ/dt| per joint (per radian of
    t), ``joint_limits``: their top speeds (same order) and ``names``; ``eng``: the pose's :func:`engagement`,
    when the caller has it."""
    eng = engagement(shape, tip, axis, rotor) if eng is None else eng
    v_max, pts, D = eng.speed, eng.points, eng.diameters
    if not eng.diameter > 0:
        raise ValueError("the tool never enters the stock cylinder: nothing to cut")
    if not len(pts):                    # a graze between two rings (:func:`engagement`): its rim point alone
        pts, D = np.array([[rotor.outer_radius, 0.0, 0.0]]), np.array([eng.diameter])
    speed = np.hypot(np.hypot(pts[:, 0], pts[:, 1]), rotor.v0)          # |v| per radian of t
    z = data.flutes
    omega = rpm * z * data.fz_mm / v_max
    limited = "chip load"
    for name, rate, vmax in zip(joint_limits[0], joint_rates, joint_limits[1]):
        if rate > 0 and omega * rate > vmax:
            omega, limited = vmax / rate, f"{name} top speed"
    chip = omega * speed / (rpm * z)
    rho_tip = math.hypot(tip[0], tip[1])
    return PassConditions(rpm=rpm, omega=omega, time_min=abs(t_span) / omega,
                          chip_load=(float(chip.min()), omega * v_max / (rpm * z)),
                          surface_speed=(math.pi * float(D.min()) * rpm / 1000.0,
                                         math.pi * eng.diameter * rpm / 1000.0),
                          engaged_diameter=(float(D.min()), eng.diameter), limited_by=limited,
                          cutting_length=abs(t_span) * math.hypot(rho_tip, rotor.v0),
                          feed_mm_min=omega * v_max)
