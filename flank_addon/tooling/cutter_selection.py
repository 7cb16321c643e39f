"""Local analysis of a helical flank and the choice of a conical cutter for it (Bizzarri, Bo & Bartoň §4).

Dupin indicatrix along a flank (Bizzarri, Bo & Bartoň §4.1)
------------------------------------------
The flank is sampled along its transverse profile at the centres of n cells of equal arc length
(the helical surface is screw invariant, so one profile curve carries all the local geometry).
At each sample we take the principal curvatures k1 >= k2 of :meth:`HelicalSurface.curvatures`
(outward normal n: positive = the surface bends towards the air side, where the tool is) and the
principal directions of :meth:`HelicalSurface.principal_directions`.  The class (hyperbolic K < 0,
elliptic K > 0, parabolic) is :meth:`HelicalSurface.classify`'s (Bizzarri, Bo & Bartoň Fig. 3).

At a hyperbolic point k1 > 0 > k2.  The machining-side indicatrix is the hyperbola
II(x) = k1 x1^2 + k2 x2^2 = 1 in the principal frame (Remark 4.1: of the pair of conics we keep
the one on the tool's side), with

    a = 1 / sqrt(k1)   the transverse semi-axis (the vertices lie on the e1 axis),
    b = 1 / sqrt(-k2)  the conjugate semi-axis,

and asymptotic directions cos(th) e1 +- sin(th) e2, tan(th) = b / a.  The paper calls a and b the
major and minor semi-axes; what matters for Eq. (18) is that a is the one on which the hyperbola's
vertices lie, whichever of the two is longer.

A cone's indicatrix at a point of a circle of sphere radius r^S is the pair of lines parallel to the
ruling at distance sqrt(r^S) from the point (Eqs. 15-16: curvature radii infinity and r^S).  A pair of
parallel lines touches the hyperbola iff their half distance is at most a (the support function of a
hyperbola takes every value in [0, a]), hence Eq. (18) on the middle circle of the tool:

    Omega_1:  sqrt((r1S + r2S) / 2) <= a_min = min_i a_i,   i.e.  (r1S + r2S) / 2 <= 1 / max_i k1_i.

Note the units: a is the square root of a length (sqrt(R) for the built-in rotors).

Valley bounds (Bizzarri, Bo & Bartoň §4.2, Eqs. 19-21)
-------------------------------------
The custom double-flank tool of the valley (Bizzarri & Bartoň 2021, :func:`methods.double_flank.planner.plan_double_flank`) is the
largest revolving tool that fits the valley.  We bound it by the truncated cone (Fig. 5b, yellow)
whose boundary spheres are the custom tool's spheres at the two ends of the part of its axis where
they touch *both* flanks (the one-flank tails do not measure the valley's width): with their radii
r1S, r2S and distance L, Eqs. (2), (3) and (7) give sin(a) = (r2S - r1S) / L, D_min = r1S cos(a),
D_max = r2S cos(a) and D_depth = h = L - (r2S - r1S) sin(a).  (The custom tool's own envelope
circles are no good here: near the valley bottom its spheres pivot about the bottom point, r' -> 1,
and the tip circle shrinks to that point.)  Then

    Eq. (19)  r1c <= c D_min,  r2c <= c D_max     (c = 0.9: room for coolant and run-out),
    Eq. (20)  Omega_2:  h = (r2c - r1c) / tan(alpha) <= D_depth   (distance of the two circles),
    Eq. (21)  alpha <= D_angle = pi / 4.

Admissible region and catalogue
-------------------------------
:func:`admissible_region` samples the box of (alpha, r1c, r2c) on a grid and records per point which
conditions fail; :func:`is_admissible` checks one :class:`cone.ConeTool` and names the failing
conditions with their values and limits; :func:`suggest_tool` returns the largest admissible tool of
a catalogue.  "Largest" orders tools by r2c, then r1c, then h (the biggest cross-section first: the
stiffest tool that removes the most material per pass; equal shapes then prefer longer flutes).

:data:`catalogue.TAPERED_END_MILLS_MM` is a small built-in catalogue of common tapered end mills (mm);
:func:`catalogue.catalogue_tools` turns it into ConeTools in mm or, given the rotor's outer radius in mm, in
units of R (the built-in rotors have R = 1).
"""
import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from .catalogue import CatalogueTool
from .cone import ConeTool

DEFAULT_C = 0.9                  # Eq. (19) buffer factor (Bizzarri, Bo & Bartoň §4.2)
DEFAULT_D_ANGLE = 0.25 * math.pi  # Eq. (21) limit of the opening angle
CONDITIONS = ("omega1", "r1", "r2", "omega2", "angle")
EQUATIONS = {"omega1": "Eq. (18)", "r1": "Eq. (19)", "r2": "Eq. (19)", "omega2": "Eq. (20)",
             "angle": "Eq. (21)"}
_REL_TOL = 1e-12   # equality in the conditions (<=) up to roundoff


# ============================================================================ Dupin indicatrix (§4.1)
@dataclass
class DupinAnalysis:
    """Dupin indicatrices at n samples of a flank's profile (Bizzarri, Bo & Bartoň §4.1, Fig. 5a).

    u, s: profile parameters and arc length from the flank start (samples at the centres of equal
    arc-length cells); point, normal (n, 3): profile point (t = 0) and unit outward normal;
    k1 >= k2, K: principal and Gaussian curvature (outward normal); kind: -1 hyperbolic, 0 parabolic,
    +1 elliptic (:meth:`HelicalSurface.classify`); e1, e2 (n, 3): unit principal directions of k1, k2;
    a, b: transverse and conjugate semi-axes of the indicatrix hyperbola at hyperbolic samples (nan
    elsewhere); asymptotic (n, 2, 3): the two asymptotic directions there (nan elsewhere);
    length: arc length of the flank profile; flank: flank index, if known."""
    u: np.ndarray
    s: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    k1: np.ndarray
    k2: np.ndarray
    K: np.ndarray
    kind: np.ndarray
    e1: np.ndarray
    e2: np.ndarray
    a: np.ndarray
    b: np.ndarray
    asymptotic: np.ndarray
    length: float
    u_range: tuple
    flank: int = None

    @property
    def hyperbolic(self):
        return self.kind == -1

    @property
    def hyperbolic_fraction(self):
        """Share of the flank profile's arc length that is hyperbolic (the samples are equally spaced)."""
        return float(np.mean(self.hyperbolic))

    @property
    def a_min(self):
        """Eq. (17): the smallest transverse semi-axis over the hyperbolic samples (nan if none)."""
        return float(np.nanmin(self.a)) if self.hyperbolic.any() else float("nan")

    @property
    def i_min(self):
        """Index of the sample where a_min is attained (None if no sample is hyperbolic)."""
        return int(np.nanargmin(self.a)) if self.hyperbolic.any() else None

    @property
    def a_max(self):
        return float(np.nanmax(self.a)) if self.hyperbolic.any() else float("nan")

    def hyperbolic_intervals(self):
        """[(s_start, s_end), ...]: arc-length intervals (cell edges) of consecutive hyperbolic samples."""
        h = self.hyperbolic.astype(int)
        d = np.diff(np.r_[0, h, 0])
        starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1
        cell = self.length / len(self.u)
        return [(float(self.s[i] - 0.5 * cell), float(self.s[j] + 0.5 * cell)) for i, j in zip(starts, ends)]

    def summary(self):
        i = self.i_min
        return {
            "flank": self.flank, "samples": int(len(self.u)), "profile_length": self.length,
            "u_range": [float(self.u_range[0]), float(self.u_range[1])],
            "hyperbolic_fraction": self.hyperbolic_fraction,
            "elliptic_fraction": float(np.mean(self.kind == 1)),
            "parabolic_fraction": float(np.mean(self.kind == 0)),
            "hyperbolic_intervals": self.hyperbolic_intervals(),
            "a_min": None if i is None else self.a_min,
            "a_max": None if i is None else self.a_max,
            "rho_min": None if i is None else self.a_min ** 2,
            "a_min_at": None if i is None else {"u": float(self.u[i]), "s": float(self.s[i]),
                                                "point": self.point[i].tolist()},
            "k1_range": [float(self.k1.min()), float(self.k1.max())],
            "k2_range": [float(self.k2.min()), float(self.k2.max())],
        }


def flank_arc_samples(surface, u_start, u_end, n, n_fine=4001):
    """(u (n,), s (n,), length): profile parameters at the centres of n equal arc-length cells of
    [u_start, u_end] (Bizzarri, Bo & Bartoň §4.1: uniformly arc-length distributed samples)."""
    uf = np.linspace(u_start, u_end, n_fine)
    sp = np.linalg.norm(surface.profile.eval(uf, 1), axis=1)
    arc = np.r_[0.0, np.cumsum(0.5 * (sp[1:] + sp[:-1]) * np.diff(uf))]
    s = (np.arange(n) + 0.5) / n * arc[-1]
    return np.interp(s, arc, uf), s, float(arc[-1])


def dupin_analysis(surface, u_range, n=400, flank=None, rel_tol=1e-3):
    """Dupin indicatrices along the profile range ``u_range`` = (u_start, u_end) of ``surface``
    (a :class:`helical_surface.HelicalSurface`), vectorised over ``n`` samples.  ``rel_tol``: the
    parabolic band |K| R^2 < rel_tol of :meth:`HelicalSurface.classify`.  Returns :class:`DupinAnalysis`."""
    try:
        u0, u1 = (float(v) for v in u_range)
    except (TypeError, ValueError):
        raise ValueError(f"u_range must be two numbers (u_start, u_end), got {u_range!r}") from None
    if not (math.isfinite(u0) and math.isfinite(u1) and u1 > u0):
        raise ValueError(f"u_range ({u0}, {u1}) must be finite with u_start < u_end")
    if not (isinstance(n, (int, np.integer)) and 8 <= n <= 100000):
        raise ValueError(f"n = {n!r} samples is outside the limits 8..100000")
    u, s, length = flank_arc_samples(surface, u0, u1, int(n))
    c = surface.curvatures(u)
    k1, k2, K = c["k1"], c["k2"], c["K"]
    kind = surface.classify(u, rel_tol=rel_tol)
    e1, e2 = surface.principal_directions(u)
    p = surface.profile.eval(u)
    point = np.c_[p, np.zeros(len(u))]
    normal = surface.normal(u, np.zeros(len(u)))
    hyp = (kind == -1) & (k1 > 0) & (k2 < 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(hyp, 1.0 / np.sqrt(np.where(hyp, k1, 1.0)), np.nan)
        b = np.where(hyp, 1.0 / np.sqrt(np.where(hyp, -k2, 1.0)), np.nan)
    th = np.arctan2(b, a)          # II(cos th e1 + sin th e2) = k1 cos^2 - |k2| sin^2 = 0
    ct, st = np.cos(th)[:, None], np.sin(th)[:, None]
    asym = np.stack([ct * e1 + st * e2, ct * e1 - st * e2], axis=1)
    return DupinAnalysis(u=u, s=s, point=point, normal=normal, k1=k1, k2=k2, K=K, kind=kind, e1=e1,
                         e2=e2, a=a, b=b, asymptotic=asym, length=length, u_range=(u0, u1), flank=flank)


def flank_dupin(surface, flank_ranges, flank, n=400, rel_tol=1e-3):
    """:func:`dupin_analysis` of flank ``flank`` (index into ``flank_ranges``, e.g. ``Rotor.flanks``)."""
    nf = len(flank_ranges)
    if not (isinstance(flank, (int, np.integer)) and 0 <= flank < nf):
        raise ValueError(f"flank {flank!r} does not exist: this rotor has flanks 0..{nf - 1}")
    return dupin_analysis(surface, flank_ranges[flank], n=n, flank=int(flank), rel_tol=rel_tol)


# ============================================================================ valley bounds (§4.2)
@dataclass(frozen=True)
class ValleyBounds:
    """Bounds of Eqs. (19)-(21) from the custom tool of a valley: D_min, D_max (radii of its tip-end
    and top-end boundary circles), D_depth (their distance), buffer c and angle limit D_angle."""
    d_min: float
    d_max: float
    d_depth: float
    c: float = DEFAULT_C
    d_angle: float = DEFAULT_D_ANGLE
    valley: int = None
    source: str = "given"

    def __post_init__(self):
        for name in ("d_min", "d_max", "d_depth", "c", "d_angle"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float, np.floating, np.integer)) and math.isfinite(v)):
                raise ValueError(f"valley bounds: {name} = {v!r} is not a finite number")
        if self.d_min < 0 or self.d_max <= 0 or self.d_depth <= 0:
            raise ValueError(f"valley bounds: need D_min >= 0, D_max > 0, D_depth > 0, got D_min = "
                             f"{self.d_min}, D_max = {self.d_max}, D_depth = {self.d_depth}")
        if not 0 < self.c <= 1:
            raise ValueError(f"valley bounds: buffer factor c = {self.c} is outside (0, 1]")
        if not 0 < self.d_angle < 0.5 * math.pi:
            raise ValueError(f"valley bounds: D_angle = {self.d_angle} rad is outside (0, pi/2)")

    @property
    def r1_max(self):
        return self.c * self.d_min

    @property
    def r2_max(self):
        return self.c * self.d_max

    def as_dict(self):
        return {"d_min": self.d_min, "d_max": self.d_max, "d_depth": self.d_depth, "c": self.c,
                "d_angle": self.d_angle, "r1c_max": self.r1_max, "r2c_max": self.r2_max,
                "valley": self.valley, "source": self.source}


def bounds_from_tool_path(path, c=DEFAULT_C, d_angle=DEFAULT_D_ANGLE, valley=None):
    """:class:`ValleyBounds` of a custom tool given as a :class:`methods.double_flank.planner.ToolPath` (axis nodes
    ``points`` from the tip, sphere ``radii``, ``counted`` (2, N) flags): the truncated cone whose
    boundary spheres are the custom tool's spheres at the first and last node touching both flanks,
    through Eqs. (2), (3) and (7) (module docstring)."""
    pts = np.asarray(path.points, float)
    r = np.asarray(path.radii, float)
    both = np.asarray(path.counted, bool).all(axis=0)
    idx = np.flatnonzero(both & np.isfinite(r) & (r > 0))
    if len(idx) < 2:
        raise ValueError("the custom tool touches both flanks of the valley at fewer than two axis "
                         "nodes: it does not define the valley's width (Eqs. (19)-(20))")
    i, j = idx[0], idx[-1]
    L = float(np.linalg.norm(pts[j] - pts[i]))
    r1s, r2s = float(r[i]), float(r[j])
    if not (L > 0 and abs(r2s - r1s) < L):
        raise ValueError(f"the custom tool's end spheres (radii {r1s:.6g}, {r2s:.6g}, {L:.6g} apart) "
                         "do not bound a truncated cone")
    sin_a = (r2s - r1s) / L                       # Eq. (3), sphere form
    cos_a = math.sqrt(1.0 - sin_a * sin_a)
    return ValleyBounds(d_min=r1s * cos_a, d_max=r2s * cos_a,          # Eq. (2)
                        d_depth=L - (r2s - r1s) * sin_a,               # Eq. (7): h = L - (r2S - r1S) sin
                        c=c, d_angle=d_angle, valley=valley, source="custom tool (Bizzarri & Bartoň 2021)")


# ============================================================================ conditions (Eqs. 18-21)
def _a_min_of(dupin_or_a):
    if isinstance(dupin_or_a, DupinAnalysis):
        return dupin_or_a.a_min      # nan: no hyperbolic sample, Omega_1 cannot hold
    try:
        a = float(dupin_or_a)
    except (TypeError, ValueError):
        raise ValueError(f"a_min must be a DupinAnalysis or a number, got {dupin_or_a!r}") from None
    if not (math.isfinite(a) and a > 0):
        raise ValueError(f"a_min = {a} must be a finite number > 0 (sqrt of a curvature radius)")
    return a


def condition_values(alpha, r1c, r2c, a_min, bounds):
    """{name: (value, limit)} of the conditions (value <= limit holds), broadcast over the arrays:
    omega1 (Eq. 18) sqrt((r1S + r2S)/2) vs a_min; r1, r2 (Eq. 19) r_ic vs c D; omega2 (Eq. 20)
    h = (r2c - r1c)/tan(alpha) vs D_depth; angle (Eq. 21) alpha vs D_angle."""
    al, r1, r2 = np.broadcast_arrays(*(np.asarray(v, float) for v in (alpha, r1c, r2c)))
    with np.errstate(divide="ignore", invalid="ignore"):
        ca = np.cos(al)
        mid = np.sqrt(np.maximum(0.5 * (r1 + r2) / ca, 0.0))
        h = (r2 - r1) / np.tan(al)
    full = lambda v: np.broadcast_to(np.float64(v), al.shape)  # noqa: E731
    return {"omega1": (mid, full(a_min)), "r1": (r1, full(bounds.r1_max)), "r2": (r2, full(bounds.r2_max)),
            "omega2": (h, full(bounds.d_depth)), "angle": (al, full(bounds.d_angle))}


def _holds(value, limit):
    with np.errstate(invalid="ignore"):
        return value <= limit + _REL_TOL * np.maximum(np.abs(limit), 1.0)


@dataclass
class Check:
    name: str
    equation: str
    ok: bool
    value: float
    limit: float
    message: str


@dataclass
class Admissibility:
    """Outcome of :func:`is_admissible`: ``ok`` and one :class:`Check` per condition."""
    tool: ConeTool
    ok: bool
    checks: list

    @property
    def failures(self):
        return [c for c in self.checks if not c.ok]

    @property
    def message(self):
        if self.ok:
            return "admissible: " + "; ".join(c.message for c in self.checks)
        return "not admissible: " + "; ".join(c.message for c in self.failures)

    def as_dict(self):
        return {"ok": self.ok, "tool": self.tool.as_dict(),
                "checks": [dataclasses.asdict(c) for c in self.checks]}


_LABELS = {"omega1": ("Omega_1", "sqrt((r1S + r2S)/2)", "a_min"),
           "r1": ("tip radius", "r1c", "c D_min"), "r2": ("top radius", "r2c", "c D_max"),
           "omega2": ("Omega_2", "tool length h", "D_depth"), "angle": ("opening angle", "alpha", "D_angle")}


def is_admissible(tool, dupin_or_a_min, bounds):
    """Whether the cone ``tool`` (:class:`cone.ConeTool`) lies in the admissible region of Eqs. (18)-(21)
    for a flank (its :class:`DupinAnalysis` or a_min) in a valley (:class:`ValleyBounds`).  Every
    failing condition is named with its value and limit in :attr:`Admissibility.message`."""
    if not isinstance(tool, ConeTool):
        raise ValueError(f"tool must be a cone.ConeTool, got {type(tool).__name__}")
    if not isinstance(bounds, ValleyBounds):
        raise ValueError(f"bounds must be ValleyBounds, got {type(bounds).__name__}")
    a_min = _a_min_of(dupin_or_a_min)
    vals = condition_values(tool.alpha, tool.r1c, tool.r2c, a_min, bounds)
    checks = []
    for name in CONDITIONS:
        v, lim = (float(x) for x in vals[name])
        ok = bool(_holds(v, lim))
        title, what, bound = _LABELS[name]
        if name == "omega1" and not math.isfinite(lim):
            msg = f"{title} ({EQUATIONS[name]}) fails: the flank has no hyperbolic point (no a_min)"
        else:
            rel = "<=" if ok else ">"
            msg = f"{title} ({EQUATIONS[name]}) {what} = {v:.6g} {rel} {bound} = {lim:.6g}"
        checks.append(Check(name, EQUATIONS[name], ok, v, lim, msg))
    return Admissibility(tool=tool, ok=all(c.ok for c in checks), checks=checks)


# ============================================================================ admissible region
@dataclass
class AdmissibleRegion:
    """Grid samples of the (alpha, r1c, r2c) box.  alpha, r1c, r2c: the 1D axes; mask (na, n1, n2):
    admissible points; failed: {condition: bool array} where that condition fails; cone: where
    (alpha, r1c, r2c) is a truncated cone at all (0 <= r1c < r2c, 0 < alpha < pi/2)."""
    alpha: np.ndarray
    r1c: np.ndarray
    r2c: np.ndarray
    mask: np.ndarray
    failed: dict
    cone: np.ndarray
    a_min: float
    bounds: ValleyBounds

    def points(self, which=None):
        """(M, 3) rows (alpha, r1c, r2c) of the admissible grid points (or of a boolean ``which``)."""
        A, R1, R2 = np.meshgrid(self.alpha, self.r1c, self.r2c, indexing="ij")
        m = self.mask if which is None else which
        return np.stack([A[m], R1[m], R2[m]], -1)

    @property
    def fraction(self):
        """Admissible share of the grid's cone points."""
        return float(self.mask.sum() / max(1, self.cone.sum()))

    def ranges(self):
        """{'alpha'|'r1c'|'r2c': (min, max)} over the admissible grid points, None if there are none."""
        p = self.points()
        if not len(p):
            return None
        return {k: (float(p[:, j].min()), float(p[:, j].max())) for j, k in enumerate(("alpha", "r1c", "r2c"))}

    def reasons(self):
        """{condition: number of cone grid points failing it} (a point can fail several)."""
        return {k: int((v & self.cone).sum()) for k, v in self.failed.items()}

    def summary(self):
        return {"grid": list(self.mask.shape), "admissible_points": int(self.mask.sum()),
                "cone_points": int(self.cone.sum()), "fraction": self.fraction, "ranges": self.ranges(),
                "failing": self.reasons(), "a_min": self.a_min, "bounds": self.bounds.as_dict(),
                "largest_cone": largest_cone(self.a_min, self.bounds)}


def admissible_region(dupin_or_a_min, bounds, n=(24, 40, 40), alpha_max=None, r1_max=None, r2_max=None):
    """Sample the admissible region of Eqs. (18)-(21) (Bizzarri, Bo & Bartoň Fig. 5c) on an n = (n_alpha, n_r1, n_r2)
    grid of alpha in (0, alpha_max], r1c in [0, r1_max], r2c in (0, r2_max].  The defaults reach 10 %
    beyond the box of Eqs. (19) and (21) so that the trimming faces show.  Returns
    :class:`AdmissibleRegion`."""
    if not isinstance(bounds, ValleyBounds):
        raise ValueError(f"bounds must be ValleyBounds, got {type(bounds).__name__}")
    a_min = _a_min_of(dupin_or_a_min)
    try:
        na, n1, n2 = (int(v) for v in n)
    except (TypeError, ValueError):
        raise ValueError(f"n must be three grid sizes (n_alpha, n_r1, n_r2), got {n!r}") from None
    if min(na, n1, n2) < 2 or na * n1 * n2 > 5_000_000:
        raise ValueError(f"grid {n} must have >= 2 points per axis and at most 5e6 points")
    al_max = min(1.1 * bounds.d_angle, 0.499 * math.pi) if alpha_max is None else alpha_max
    r1m = 1.1 * bounds.r1_max if r1_max is None else r1_max
    r2m = 1.1 * bounds.r2_max if r2_max is None else r2_max
    if r1m == 0:                 # D_min = 0: only pointed cones fit the tip; still sample a little
        r1m = 0.1 * r2m
    for name, v in (("alpha_max", al_max), ("r1_max", r1m), ("r2_max", r2m)):
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"{name} = {v} must be a finite number > 0")
    if al_max >= 0.5 * math.pi:
        raise ValueError(f"alpha_max = {al_max} must be below pi/2")
    alpha = np.linspace(al_max / na, al_max, na)
    r1 = np.linspace(0.0, r1m, n1)
    r2 = np.linspace(r2m / n2, r2m, n2)
    A, R1, R2 = np.meshgrid(alpha, r1, r2, indexing="ij")
    vals = condition_values(A, R1, R2, a_min, bounds)
    failed = {k: ~_holds(*vals[k]) for k in CONDITIONS}
    cone = R1 < R2
    mask = cone.copy()
    for k in CONDITIONS:
        mask &= ~failed[k]
    return AdmissibleRegion(alpha=alpha, r1c=r1, r2c=r2, mask=mask, failed=failed, cone=cone,
                            a_min=a_min, bounds=bounds)


def largest_cone(dupin_or_a_min, bounds, n_alpha=4001):
    """An admissible (alpha, r1c, r2c) with the largest top radius r2c (the supremum of r2c over the
    region, up to the alpha sampling), or None.  Closed form per alpha: Omega_1 reads
    r1c + r2c <= 2 a_min^2 cos(alpha), Omega_2 r2c - r1c <= D_depth tan(alpha); for fixed alpha the
    best r1c balances the two caps, clipped to [0, c D_min], and r2c is the smallest of the three
    upper bounds.  alpha runs over n_alpha values in (0, D_angle]; ties go to the smallest alpha."""
    a_min = _a_min_of(dupin_or_a_min)
    if not math.isfinite(a_min):
        return None
    al = np.linspace(bounds.d_angle / n_alpha, bounds.d_angle, int(n_alpha))
    cap1 = 2.0 * a_min ** 2 * np.cos(al)          # Omega_1: bound on r1c + r2c
    cap2 = bounds.d_depth * np.tan(al)            # Omega_2: bound on r2c - r1c
    r1 = np.clip(0.5 * (cap1 - cap2), 0.0, bounds.r1_max)
    r2 = np.minimum(np.minimum(cap1 - r1, r1 + cap2), bounds.r2_max)
    ok = r2 > r1
    if not ok.any():
        return None
    i = int(np.argmax(np.where(ok, r2, -np.inf)))
    return float(al[i]), float(r1[i]), float(r2[i])


def tool_size_key(tool):
    """Sort key of "largest": r2c, then r1c, then the length h (module docstring)."""
    return (tool.r2c, tool.r1c, tool.h)


@dataclass
class Suggestion:
    """Outcome of :func:`suggest_tool`: ``index`` / ``entry`` / ``tool`` of the largest admissible
    catalogue tool (None if none is admissible) and the :class:`Admissibility` of every entry."""
    index: int
    entry: object
    tool: ConeTool
    results: list = field(default_factory=list)

    @property
    def admissible(self):
        return [i for i, r in enumerate(self.results) if r.ok]


def suggest_tool(catalogue, dupin_or_a_min, bounds):
    """The largest (:func:`tool_size_key`; first listed on ties) admissible tool of ``catalogue``
    (ConeTools or :class:`CatalogueTool` s, all in the rotor's length unit).  Returns :class:`Suggestion`."""
    entries = list(catalogue)
    if not entries:
        raise ValueError("the tool catalogue is empty")
    tools = []
    for i, e in enumerate(entries):
        t = e.tool if isinstance(e, CatalogueTool) else e
        if not isinstance(t, ConeTool):
            raise ValueError(f"catalogue entry {i} is a {type(e).__name__}, not a ConeTool or CatalogueTool")
        tools.append(t)
    results = [is_admissible(t, dupin_or_a_min, bounds) for t in tools]
    best = None
    for i, (t, r) in enumerate(zip(tools, results)):
        if r.ok and (best is None or tool_size_key(t) > tool_size_key(tools[best])):
            best = i
    if best is None:
        return Suggestion(None, None, None, results)
    return Suggestion(best, entries[best], tools[best], results)


def select_cutter(surface, flank_ranges, flank, catalogue, bounds, n=400, grid=(24, 40, 40)):
    """The whole §4 procedure for one flank: Dupin analysis, the sampled admissible region and the
    suggested catalogue tool.  ``bounds``: the :class:`ValleyBounds` of the flank's valley (flank // 2),
    from its custom double-flank tool (:func:`bounds_from_tool_path`).  Returns (DupinAnalysis,
    ValleyBounds, AdmissibleRegion, Suggestion)."""
    dup = flank_dupin(surface, flank_ranges, flank, n=n)
    if dup.hyperbolic.any():
        region = admissible_region(dup, bounds, n=grid)
    else:
        region = None
    return dup, bounds, region, suggest_tool(catalogue, dup, bounds)
