"""Double-flank milling of screw-rotor valleys with custom-shaped and conical tools (Bizzarri & Bartoň 2021).

One revolving tool, fixed in the rotor frame while the rotor screws, touches *both* flanks of a
valley (Bizzarri & Bartoň 2021 §1).  The tool is an envelope of spheres centred on its axis o' (Bizzarri & Bartoň 2021 §3): it is known
once the axis and the radial function r along it are known.

Frames and units
----------------
Everything is in the rotor frame of :mod:`screw` (helical axis = z, profile in z = 0) and in the
rotor's length unit.  The tool axis of a valley follows Bizzarri & Bartoň 2021 Eq. (10), turned about z so that the
start point (alpha, delta, phi) = (0, 0, 0) is the valley's reference line (the radial line through
the valley's mid direction; for a symmetric profile its symmetry line, Prop. 3.1):

    a(lam) = lam e_r(theta_v + phi) - delta e_t(theta_v + phi) + lam tan(alpha) e_z,

with e_r = (cos, sin, 0), e_t = (-sin, cos, 0).  With theta_v = pi/2 this is Eq. (10) verbatim.
``lam`` is the signed distance of the axis point's projection from the common perpendicular; the
tool's tip is at the small-``lam`` end (deep in the valley), the shank leaves the rotor at the
other end.

Distances
---------
r_k(a) is the distance from an axis point a to flank k of the valley (a profile parameter range
[u_start, u_end] screwed about z), found by :class:`FlankFeet`: the reduction of
:mod:`helical_surface` (f(u, tau) = |R(h tau) p(u) - q0|^2 + v0^2 tau^2) minimised by projected
Newton with the box u_start <= u <= u_end, seeded by a dense table of the flank and by warm starts.
A foot in the open range is an ordinary foot point (Bizzarri & Bartoň 2021 Eq. (2)); a foot on u = u_start or
u = u_end lies on the flank's boundary helix (the characteristic has run off that flank, end of
Bizzarri & Bartoň 2021 §4.2).  In both cases grad_a r_k = (a - b_k) / r_k, so for axis parameters x
dr_k/dx = ((a - b_k) / r_k) . da/dx exactly (no finite differences).

Optimisation (Bizzarri & Bartoň 2021 §4.2)
------------------------
Phi(alpha, delta, phi) = max_i |r1_i - r2_i| (Eq. (11)) over the axis samples whose feet are
interior on both flanks.  We minimise its epigraph form, minimise s subject to
-s <= r1_i - r2_i <= s, by SLSQP with the analytic Jacobian above, from (0, 0, 0) as the paper does
and from a few nearby starts; the best is kept.  Radial functions: minimum (Eq. (14), never
overcuts), average (Eq. (16)), one-sided (Eq. (17)); errors e_k = r_k - r (Eq. (15)).
Samples whose foot on one flank lies on that flank's boundary count only for the other flank (the
tail of the tool that mills one flank alone).

Two paths with one tool (Bizzarri & Bartoň 2021 §4.3, Eqs. (18)-(19)) and conical tools (Bizzarri & Bartoň 2021 §5, Eqs. (20)-(21),
Remark 5.3) are built on the same evaluator.  The errors a planner reports are checked against the
independent sweep simulation (:mod:`sweep`, :func:`verify.verify_plan`), the rotor-to-envelope
direction of Bizzarri & Bartoň 2021 Remark 4.5.
"""
import math
import time
from dataclasses import dataclass, field

import numpy as np

from ...geometry.angles import atan2, wrapped
from ...geometry.flank_feet import FlankFeet
from ...geometry.runs import ranks_in_runs

VARIANTS = ("min", "avg", "one-sided-1", "one-sided-2")


# ============================================================================ valleys
def _rim_param(profile, u_from, u_to, rho, n=4000):
    """First parameter walking from ``u_from`` (valley bottom) towards ``u_to`` at which |p(u)| = rho."""
    us = np.linspace(u_from, u_to, n)
    rad = np.linalg.norm(profile.eval(us), axis=1)
    above = np.flatnonzero(rad >= rho)
    if not len(above):
        return float(u_to)
    j = above[0]
    if j == 0:
        return float(u_from)
    a, b = us[j - 1], us[j]
    for _ in range(60):
        m = 0.5 * (a + b)
        if np.linalg.norm(profile.eval(m)) >= rho:
            b = m
        else:
            a = m
    return float(0.5 * (a + b))


class Valley:
    """The two flanks of valley k of a rotor, their trimmed ("rim") parts and restricted foot solvers.

    Args:
        surface: :class:`HelicalSurface` of the rotor.
        flank_ranges: all flank parameter ranges of the rotor, (tip, bottom), (bottom, next tip) per
            valley in CCW order (``Rotor.flanks``, or index ranges of a SplineProfile).
        k: valley index (flanks 2k and 2k + 1).
        rim: fraction of the valley depth (from the bottom radius to the outer radius) up to which the
            flanks are targeted.  Above it the lobe top turns away from every axis in the valley (its
            normals no longer meet the axis helicoid), so no sphere on the axis can touch it; the
            trimmed flank ends there (the "boundary of X_k" of Bizzarri & Bartoň 2021 §4.2).
    """

    def __init__(self, surface, flank_ranges, k, rim=0.85):
        nv = len(flank_ranges) // 2
        if not (0 <= k < nv):
            raise ValueError(f"valley {k} does not exist: this rotor has valleys 0..{nv - 1}")
        if not (0.2 <= rim <= 0.98):
            raise ValueError(f"rim {rim} is outside the limits 0.2..0.98 (fraction of the valley depth)")
        prof = surface.profile
        self.surface = surface
        self.k = int(k)
        self.flank_ids = (2 * k, 2 * k + 1)
        (u0, ub), (ub2, u1) = flank_ranges[2 * k], flank_ranges[2 * k + 1]
        self.full_ranges = ((u0, ub), (ub2, u1))
        self.outer_radius = R = surface.outer_radius
        self.r_bottom = float(np.linalg.norm(prof.eval(ub)))
        self.rim = float(rim)
        self.rho_rim = self.r_bottom + rim * (R - self.r_bottom)
        ur1 = _rim_param(prof, ub, u0, self.rho_rim)
        ur2 = _rim_param(prof, ub2, u1, self.rho_rim)
        self.ranges = ((ur1, ub), (ub2, ur2))
        pa, pc = prof.eval(u0), prof.eval(u1)
        mid = pa / np.linalg.norm(pa) + pc / np.linalg.norm(pc)
        self.theta = float(math.atan2(mid[1], mid[0]))
        self.feet = (FlankFeet.of(surface, *self.ranges[0]), FlankFeet.of(surface, *self.ranges[1]))
        self._full = None
        # axis samples of the optimisation: from below the bottom to beyond the outer radius
        self.lam_range = (0.9 * self.r_bottom, 1.6 * R)
        self.lobes = max(1, nv)

    @property
    def full_feet(self):
        if self._full is None:
            self._full = (FlankFeet.of(self.surface, *self.full_ranges[0]),
                          FlankFeet.of(self.surface, *self.full_ranges[1]))
        return self._full


def valley_of_point(surface, flank_ranges, point):
    """Valley index whose flanks hold the profile point nearest to a 3D point (rotor frame)."""
    u, _ = surface.nearest_section_param(point)
    per = surface.profile.period
    for i, (a, b) in enumerate(flank_ranges):
        if a <= u <= b or a <= u + per <= b:
            return i // 2
    raise ValueError(f"valley point {point} is not near any flank of the rotor")


# ============================================================================ axis (Bizzarri & Bartoň 2021 Eq. (10))
def axis_points(x, lam, theta, R=1.0):
    """Points a(lam) of the axis with parameters x = (alpha, delta, phi) (delta in units of R), and
    da/dx (N, 3, 3) (columns: d/dalpha, d/ddelta (per unit of delta/R), d/dphi).  Eq. (10) turned
    by theta - pi/2 about z."""
    al, de, ph = float(x[0]), float(x[1]) * R, float(x[2])
    lam = np.asarray(lam, float)
    c, s = math.cos(theta + ph), math.sin(theta + ph)
    er, et, ez = np.array([c, s, 0.0]), np.array([-s, c, 0.0]), np.array([0.0, 0.0, 1.0])
    ta = math.tan(al)
    a = lam[:, None] * er - de * et + (lam * ta)[:, None] * ez
    J = np.empty(lam.shape + (3, 3))
    J[..., 0] = (lam / math.cos(al) ** 2)[:, None] * ez
    J[..., 1] = -R * et
    J[..., 2] = lam[:, None] * et + de * er
    return a, J


# ============================================================================ distances along an axis
@dataclass
class AxisRadii:
    """Distances r_k (2, N) from axis samples to the two flanks, whether each foot is interior
    (2, N), gradients dr_k/dx (2, N, 3) and the feet themselves."""
    lam: np.ndarray
    points: np.ndarray
    r: np.ndarray
    interior: np.ndarray
    grad: np.ndarray
    feet: tuple


class AxisEvaluator:
    """r_1, r_2 and their exact gradients for axis parameters x = (alpha, delta / R, phi).

    Warm starts: the feet of the previous call with the same sample count seed the next one, so an
    optimiser that moves the axis a little pays a few Newton steps per evaluation."""

    def __init__(self, valley):
        self.valley = valley
        self.R = valley.outer_radius
        self._warm = {}
        self.calls = 0

    def __call__(self, x, lam, solvers=None, tag=0):
        return self.multi([(x, lam, solvers, tag)])[0]

    def multi(self, requests):
        """[self(x, lam, solvers, tag) for each request], every flank's feet found in one run (each row
        iterates on its own and warm-starts from its own key: the same values as one call at a time)."""
        v = self.valley
        prepared, solvers_all, points, warms, keys = [], [], [], [], []
        for x, lam, solvers, tag in requests:
            solvers = v.feet if solvers is None else solvers
            a, J = axis_points(x, lam, v.theta, self.R)
            ks = [(tag, j, len(lam)) for j in range(len(solvers))]
            prepared.append((lam, a, J, len(solvers)))
            solvers_all += list(solvers)
            points += [a] * len(solvers)
            warms += [self._warm.get(key) for key in ks]
            keys += ks
        if len(set(keys)) < len(keys):      # a request warm-starts from an earlier one: one at a time
            out = []
            for req in requests:
                out += self.multi([req])
            return out
        found = FlankFeet.many(solvers_all, points, warms)
        for key, ft in zip(keys, found):
            self._warm[key] = (ft.u, ft.tau)
        out, o = [], 0
        for lam, a, J, ns in prepared:
            feet = found[o:o + ns]
            o += ns
            out.append(AxisRadii(lam=np.asarray(lam, float), points=a, r=np.array([ft.distance for ft in feet]),
                                 interior=np.array([ft.interior for ft in feet]),
                                 grad=np.array([np.einsum("ni,nij->nj", ft.direction, J) for ft in feet]),
                                 feet=tuple(feet)))
            self.calls += 1
        return out


def phi_value(ar):
    """Eq. (11): max |r1 - r2| over samples with interior feet on both flanks (0 if there are none)."""
    both = ar.interior[0] & ar.interior[1]
    return float(np.max(np.abs(ar.r[0] - ar.r[1])[both])) if both.any() else 0.0


@dataclass
class AxisFit:
    x: np.ndarray                 # (alpha, delta, phi), delta in the rotor's length unit
    x_unit: np.ndarray            # (alpha, delta / R, phi): what the evaluator takes
    phi: float                    # Eq. (11) (or (18), (20)) at x
    iterations: int               # SLSQP iterations of the winning start
    evaluations: int              # distance evaluations over all starts
    starts: int
    elapsed_s: float
    per_start: list = field(default_factory=list)   # [(start x, end x, Phi, iterations, seconds)]


def _slsqp(fun_jac, y0, bounds, n_ineq, objective):
    """Run SLSQP on 'minimise objective(y) s.t. g(y) >= 0' with g, dg/dy from fun_jac (cached)."""
    from scipy.optimize import minimize

    cache = {}

    def get(y):
        k = y.tobytes()
        if k not in cache:
            cache.clear()
            cache[k] = fun_jac(y)
        return cache[k]

    res = minimize(lambda y: objective(y)[0], y0, jac=lambda y: objective(y)[1], method="SLSQP",
                   bounds=bounds, constraints=[{"type": "ineq", "fun": lambda y: get(y)[0],
                                                "jac": lambda y: get(y)[1]}],
                   options={"maxiter": 100, "ftol": 1e-12})
    return res


def default_starts(valley):
    """(0, 0, 0) as in Bizzarri & Bartoň 2021 Ex. 4.3 plus a small symmetric set around it (alpha, delta/R, phi)."""
    return [(0.0, 0.0, 0.0), (0.1, 0.0, 0.0), (-0.1, 0.0, 0.0), (0.0, 0.1, 0.1), (0.0, -0.1, -0.1)]


def _bounds(valley):
    # phi is an angle (a turn about z maps the axis onto itself); alpha and delta stop short of
    # axes that lie along the rotor or far off the valley, which the interior-count check rejects anyway
    return [(-1.2, 1.2), (-0.8, 0.8), (-math.pi, math.pi)]


def optimize_axis(valley, n=100, starts=None, evaluator=None, report=None):
    """Minimise Phi of Eq. (11) over (alpha, delta, phi) by SLSQP on the epigraph form

        minimise s  subject to  -s <= r1_i - r2_i <= s  for samples interior on both flanks,

    with dr_k/dx = ((a_i - b_k) / r_k) . da_i/dx (exact).  Samples lie on lam in valley.lam_range
    (n of them, the paper's n = 100).  Returns the best :class:`AxisFit` over ``starts``; ``report``
    (a :func:`progress.reporter`) hears of every start."""
    t0 = time.perf_counter()
    ev = evaluator or AxisEvaluator(valley)
    lam = np.linspace(*valley.lam_range, n)
    R = valley.outer_radius

    seen = {}

    def fun_jac(y):
        ar = ev(y[:3], lam)
        both = ar.interior[0] & ar.interior[1]
        # SLSQP's line search may wander off after reaching the optimum (the interior sets change
        # in jumps): remember the best valid axis it evaluated
        if both.sum() >= need:
            val = phi_value(ar)
            if val < seen.get("phi", np.inf):
                seen.update(phi=val, x=y[:3].copy())
        w = both.astype(float)
        d = (ar.r[0] - ar.r[1]) / R * w
        Jd = (ar.grad[0] - ar.grad[1]) / R * w[:, None]
        g = np.r_[y[3] - d, y[3] + d]
        G = np.zeros((2 * n, 4))
        G[:n, :3], G[n:, :3] = -Jd, Jd
        G[:, 3] = 1.0
        return g, G

    obj = lambda y: (y[3], np.array([0.0, 0.0, 0.0, 1.0]))  # noqa: E731
    best, per = None, []
    calls0 = ev.calls
    ref = ev(np.zeros(3), lam)
    need = max(5, int(0.5 * np.sum(ref.interior[0] & ref.interior[1])))
    start_list = list(starts or default_starts(valley))
    for i_start, x0 in enumerate(start_list):
        if report is not None:
            report(i_start / len(start_list), "optimising the tool axis (start {} of {})".format(
                i_start + 1, len(start_list)))
        ts = time.perf_counter()
        x0 = np.asarray(x0, float)
        s0 = phi_value(ev(x0, lam)) / R
        seen.clear()
        res = _slsqp(fun_jac, np.r_[x0, s0], _bounds(valley) + [(0.0, None)], 2 * n, obj)
        x = res.x[:3]
        ar = ev(x, lam)
        val = phi_value(ar)
        # an axis that leaves the valley has few samples touching both flanks: Phi means nothing there
        valid = int(np.sum(ar.interior[0] & ar.interior[1])) >= need
        if "x" in seen and (not valid or seen["phi"] < val):
            x, val, valid = seen["x"], seen["phi"], True
        per.append((x0.tolist(), x.tolist(), val if valid else float("inf"), int(res.nit),
                    time.perf_counter() - ts))
        if valid and (best is None or val < best[1] - 1e-15):
            best = (x, val, int(res.nit))
    if best is None:
        raise ValueError("double-flank axis optimisation failed: every start left the valley")
    x, val, nit = best
    return AxisFit(x=np.array([x[0], x[1] * R, x[2]]), x_unit=np.array(x), phi=val, iterations=nit, evaluations=ev.calls - calls0,
                   starts=len(per), elapsed_s=time.perf_counter() - t0, per_start=per)


# ============================================================================ tools from an axis
@dataclass
class ToolPath:
    """One position (x = (alpha, delta, phi), delta in length units) of a revolving tool (one plan strip): axis nodes, radii and the errors along it.

    lam (m+1,) equally spaced axis parameters from the tip (lam[0]) to the shank end; points (m+1, 3)
    the axis nodes (rotor frame); radii (m+1,) the radial function r at the nodes (sphere radii of
    the envelope, Bizzarri & Bartoň 2021 §3); r (2, m+1) distances to the two trimmed flanks; counted (2, m+1) whether
    the node's foot on that flank is interior; errors (2, m+1) e_k = r_k - r (Eq. (15)), nan where the
    node does not count for flank k.
    """
    x: np.ndarray
    lam: np.ndarray
    points: np.ndarray
    radii: np.ndarray
    r: np.ndarray
    counted: np.ndarray
    errors: np.ndarray
    flanks: tuple = (0, 1)        # which of the valley's flanks this path mills (0, 1 or both)
    plan_points: np.ndarray = None   # (m+1, 3) equally spaced plan nodes (axis_start .. axis_end)
    plan_radii: np.ndarray = None    # (m+1,) radii there (flank-plan/1 "radii")
    meridian: np.ndarray = None      # (K, 2) exact tool meridian (h from axis_start, R), or None
    kind: str = "custom"
    dirs: np.ndarray = None          # (2, N, 3) unit (node - foot_k) / r_k
    # build_path(meridian="later"): makes the meridian when asked (a candidate that may lose to another
    # pays only for its errors); :func:`finish_meridians` sets it
    make_meridian: object = field(default=None, repr=False, compare=False)


def _counted(ev, x, lam, tag):
    ar = ev(x, np.atleast_1d(lam), tag=tag)
    return ar


def bisect_brackets(inside_at, brackets, tol, levels=5, max_steps=60):
    """The bisection of every bracket (inside, outside) of the predicate ``inside_at`` (an array of
    parameters -> bools) down to |inside - outside| < tol or ``max_steps`` halvings: the ends the plain
    loop (midpoint, test, keep the half with the change) reaches.

    Its midpoints are the plain loop's, bit for bit, but one call of ``inside_at`` asks for the next
    ``levels`` of them on every path the loop may take (2**levels - 1 per bracket): a handful of calls
    instead of one per halving, where a call costs far more than a row."""
    if int(levels) != levels or levels < 1:
        raise ValueError(f"levels must be a whole number >= 1, got {levels!r}")
    state = [[float(a), float(b), 0] for a, b in brackets]       # inside, outside, halvings so far
    open_ = list(state) if max_steps >= 1 else []
    while open_:
        trees, mids = [], []
        for s in open_:
            nodes, frontier = {}, [((), s[0], s[1])]
            for _ in range(levels):
                nxt = []
                for path, a, b in frontier:
                    m = 0.5 * (a + b)
                    nodes[path] = len(mids)
                    mids.append(m)
                    nxt += [(path + (True,), m, b), (path + (False,), a, m)]
                frontier = nxt
            trees.append(nodes)
        flags = inside_at(np.array(mids))
        still = []
        for s, nodes in zip(open_, trees):
            path = ()
            for _ in range(levels):
                m = 0.5 * (s[0] + s[1])
                ok = bool(flags[nodes[path]])
                s[0 if ok else 1] = m
                path += (ok,)
                s[2] += 1
                if abs(s[0] - s[1]) < tol or s[2] >= max_steps:
                    break
            else:
                still.append(s)
        open_ = still
    return [s[0] for s in state]


def tool_extent(ev, x, flanks=(0, 1), n_scan=400, tag="extent"):
    """[lam_start, lam_end]: the first and last axis parameters whose foot on one of ``flanks`` is
    interior (bisection to 1e-12 R on both ends).  Beyond them every foot sits on a flank's
    boundary (valley bottom or rim) and the spheres no longer shape the target flanks.

    The interior test near an end is only as sharp as the feet, which start from the previous call's: on
    the axes of the built-in rotors' plans another warm start moved an end by up to 6e-11 R, so the ends
    are defined to that, not to the bisection's 1e-12 R; on axes far from an optimum, where a foot near an
    end can also lie in another basin, by up to 2e-3 R (random axes on the asymmetric female)."""
    v = ev.valley
    # scan beyond the optimisation's samples: a tilted axis can still touch a flank there
    lam = np.linspace(0.5 * v.lam_range[0], 1.25 * v.lam_range[1], n_scan)
    ar = ev(x, lam, tag=(tag, n_scan))
    ok = ar.interior[list(flanks)].any(axis=0)
    idx = np.flatnonzero(ok)
    if not len(idx):
        raise ValueError("the tool axis touches neither flank of the valley")

    def interior(lams):
        return ev(x, lams, tag=(tag, "bisect")).interior[list(flanks)].any(axis=0)

    i0, i1 = idx[0], idx[-1]
    brackets = [(lam[i0], lam[i0 - 1]) if i0 > 0 else None, (lam[i1], lam[i1 + 1]) if i1 < n_scan - 1 else None]
    ends = bisect_brackets(interior, [b for b in brackets if b is not None], 1e-12 * v.outer_radius)
    lo = ends.pop(0) if brackets[0] is not None else lam[0]
    hi = ends.pop(0) if brackets[1] is not None else lam[-1]
    return float(lo), float(hi)


def radial_function(r, counted, variant="min", cap=None):
    """Radii at axis nodes from the distances r (2, N) to the two flanks.

    variant: 'min' Eq. (14), 'avg' Eq. (16), 'one-sided-1' / 'one-sided-2' Eq. (17).  Where a node
    counts for one flank only (the tail, end of Bizzarri & Bartoň 2021 §4.2) it takes that flank's distance; where it
    counts for none it takes min(r1, r2).  ``cap`` (N,) (distance to the untrimmed flanks) bounds
    every radius that is not meant to overcut: all of them for 'min', the tail nodes otherwise.
    """
    if variant not in VARIANTS:
        raise ValueError(f"variant {variant!r} is not one of {', '.join(VARIANTS)}")
    r1, r2 = r
    c1, c2 = counted
    both = c1 & c2
    if variant == "min":
        rb = np.minimum(r1, r2)
    elif variant == "avg":
        rb = 0.5 * (r1 + r2)
    elif variant == "one-sided-1":
        rb = r1.copy()
    else:
        rb = r2.copy()
    out = np.where(both, rb, np.where(c1, r1, np.where(c2, r2, np.minimum(r1, r2))))
    if cap is not None:
        out = np.minimum(out, cap) if variant == "min" else np.where(both, out, np.minimum(out, cap))
    return out


def build_path(ev, x, m=400, variant="min", radii_fn=None, extent=None, flanks=(0, 1), tag="path",
               n_exact=1201, meridian=True, tol=5e-10):
    """One tool position: exact distances at ``n_exact`` equally spaced axis nodes (feet on the
    trimmed and on the untrimmed flanks, derivatives d r_k / d lam = (a - b_k)/r_k . da/dlam), cubic
    Hermite interpolation in between, radii by ``variant`` (or ``radii_fn(lam)``, point by point),
    ``m + 1`` plan radii and, if ``meridian``, the exact union-of-spheres meridian (h, R) sampled so
    that its chord error is ~ ``tol`` (``meridian="later"``: made by :func:`finish_meridians`)."""
    from scipy.interpolate import CubicHermiteSpline

    v = ev.valley
    lo, hi = extent or tool_extent(ev, x, flanks)
    # uniform nodes plus geometric clusters at both ends, where the feet leave the valley bottom or
    # reach the rim (r is only C1 there and Hermite interpolation needs short intervals)
    g = np.geomspace(1e-9, 0.02, 120) * (hi - lo)
    lam = np.unique(np.r_[np.linspace(lo, hi, n_exact), lo + g, hi - g])
    n_exact = len(lam)
    ar, full = ev.multi([(x, lam, None, (tag, "trim")), (x, lam, v.full_feet, (tag, "full"))])
    al = float(x[0])
    speed = 1.0 / math.cos(al)
    c, sn = math.cos(v.theta + x[2]), math.sin(v.theta + x[2])
    dadl = np.array([c, sn, math.tan(al)])
    s = (lam - lo) * speed
    counted = ar.interior.copy()
    for k in (0, 1):
        if k not in flanks:
            counted[k] = False

    # the radii between the nodes, every sample on its own (the radial functions and the splines work point
    # by point); at the nodes they are the nodes' own
    if radii_fn is None:
        def spl(dist, feet):
            return CubicHermiteSpline(s, dist, (feet.direction @ dadl) / speed)

        S1, S2 = spl(ar.r[0], ar.feet[0]), spl(ar.r[1], ar.feet[1])
        C1, C2 = spl(full.r[0], full.feet[0]), spl(full.r[1], full.feet[1])

        def radii_at(sq):
            idx = np.clip(np.searchsorted(s, sq, side="right") - 1, 0, n_exact - 1)
            # a node's counting holds up to the next node (the tool ends are bisected exactly)
            rr = np.array([S1(sq), S2(sq)])
            return radial_function(rr, counted[:, idx], variant, np.minimum(C1(sq), C2(sq)))

        node_r = radial_function(ar.r, counted, variant, np.minimum(full.r[0], full.r[1]))
    else:
        def radii_at(sq):
            return radii_fn(lo + sq / speed)

        node_r = radii_at(s)
    errors = np.where(counted, ar.r - node_r[None, :], np.nan)
    s_plan = np.linspace(0.0, s[-1], m + 1)
    plan_r = radii_at(s_plan)
    L = float(s[-1])
    eps = 1e-7 * L

    def r_and_dr(q):
        # r' by central differences of the Hermite pieces (exact for the selected branch away
        # from kinks: the radial functions are selections and averages of smooth distances);
        # the three abscissae in one evaluation, each point on its own as in three
        q = np.asarray(q, float)
        qp, qm = np.minimum(q + eps, L), np.maximum(q - eps, 0.0)
        r, rp, rm = np.split(radii_at(np.concatenate([q, qp, qm])), 3)
        return r, (rp - rm) / (qp - qm)

    def exact_meridian():
        sd, rd, drd = _contact_samples(r_and_dr, np.r_[s, s_plan], tol)
        mer = sphere_union_meridian(sd, rd, tol=tol, dr=drd, end_tol=1e-5 * v.outer_radius)
        return _shrink_concave(mer, tol)

    a_plan, _ = axis_points(x, lo + s_plan / speed, v.theta, v.outer_radius)
    path = ToolPath(x=np.array([x[0], x[1] * v.outer_radius, x[2]]), lam=lam, points=ar.points, radii=node_r,
                    r=ar.r, counted=counted, errors=errors, flanks=tuple(flanks), plan_points=a_plan,
                    plan_radii=plan_r, dirs=np.array([ar.feet[0].direction, ar.feet[1].direction]))
    if meridian == "later":
        path.make_meridian = exact_meridian
    elif meridian:
        path.meridian = exact_meridian()
    return path


# ============================================================================ exact tool meridian
def _upper_envelope(m, c):
    """(indices, breaks) of the lines y = m x + c (m non-decreasing) on their upper envelope, slopes
    increasing, and the x where each takes over from the one before.  Of lines with equal slopes the
    largest intercept counts (the first among equals).  Then every line whose take-over point does not come
    before its successor's is dropped, all such lines at once, until none is left: a run of dropped lines
    is convex from below, so the chord of its neighbours lies above it, and the chain only rises until it
    is the envelope (what the monotone convex-hull sweep keeps, without its Python loop)."""
    n = len(m)
    if n == 0:
        return np.zeros(0, int), np.zeros(0)
    start = np.r_[0, np.flatnonzero(m[1:] != m[:-1]) + 1]
    if len(start) < n:
        run = np.repeat(np.arange(len(start)), np.diff(np.r_[start, n]))
        best = np.full(len(start), -np.inf)
        np.maximum.at(best, run, c)
        first = np.flatnonzero(c == best[run])
        _, pos = np.unique(run[first], return_index=True)
        idx = first[pos]
    else:
        idx = np.arange(n)
    while len(idx) > 2:
        x = (c[idx[:-1]] - c[idx[1:]]) / (m[idx[1:]] - m[idx[:-1]])
        bad = x[1:] <= x[:-1]
        if not bad.any():
            break
        keep = np.ones(len(idx), bool)
        keep[1:-1] = ~bad
        idx = idx[keep]
    return idx, (c[idx[:-1]] - c[idx[1:]]) / (m[idx[1:]] - m[idx[:-1]])


class SphereUnion:
    """Exact meridian R(h) of the union of spheres centred at axial positions s_j with radii r_j.

    R(h)^2 = max_j (r_j^2 - (h - s_j)^2) = max_j (2 s_j h + r_j^2 - s_j^2) - h^2: the upper envelope
    of N lines in h (slopes 2 s_j), built once (:func:`_upper_envelope`), answers every
    query with one binary search -- the maximum over *all* spheres, not a window of neighbours."""

    def __init__(self, s, r):
        s = np.asarray(s, float)
        r = np.asarray(r, float)
        if not _ascending(s):            # (a meridian's samples come in order: no sort of 300k of them)
            order = np.argsort(s, kind="stable")
            s, r = s[order], r[order]
        m, c = 2.0 * s, r ** 2 - s ** 2
        self.s, self.r = s, r
        self.hull, self.breaks = _upper_envelope(m, c)
        self.m, self.c = m[self.hull], c[self.hull]

    def which(self, h):
        """Index (into the sorted spheres) of the sphere forming the union's boundary at h."""
        return self.hull[np.searchsorted(self.breaks, np.asarray(h, float), side="right")]

    def __call__(self, h):
        h = np.asarray(h, float)
        k = np.searchsorted(self.breaks, h, side="right")
        return np.sqrt(np.maximum(self.m[k] * h + self.c[k] - h * h, 0.0))


def sphere_union_meridian(s, r, tol=2e-10, dr=None, end_tol=None, grade=None):
    """Meridian (h, R) of the union of spheres centred at axial positions s (increasing) with radii r.

    The boundary of a union of spheres on an axis is R(h) = max_j sqrt(r_j^2 - (h - s_j)^2).  Where r
    is smooth it is the envelope (contact circle h = s - r r', R = r sqrt(1 - r'^2), Bizzarri & Bartoň 2021 §3); at
    kinks of r it is a spherical zone (concave kink) or a crease (convex kink), and the end caps are
    sphere caps.  Candidates: the contact points of every sphere (``dr`` = r' if known exactly, else
    finite differences), the exposed parts of the two end caps (from the tip to the first sphere's
    contact circle, from the last sphere's contact circle to the end) and arc points of any sphere
    whose visible zone is wider than the chord allowance; each candidate's R is the exact maximum over
    *all* spheres (:class:`SphereUnion`), so every vertex lies on the union's boundary.  The cap
    at the shank end (beyond the last contact circle: it mills nothing) may be coarser, ``end_tol``
    (its chords stay inside the sphere).  ``grade`` (e.g. 1.3) limits the ratio of neighbouring
    segment lengths (fewer all-edge fallbacks in :class:`sweep.MeridianPart`, more vertices).
    ``s`` must be dense enough that consecutive contact points are within sqrt(8 tol / curvature).
    Returns (K, 2) rows (h, R), h strictly increasing, R >= 0, first and last R = 0.
    """
    s = np.asarray(s, float)
    r = np.asarray(r, float)
    dr = np.gradient(r, s) if dr is None else np.asarray(dr, float)
    end_tol = tol if end_tol is None else float(end_tol)
    U = SphereUnion(s, r)
    ok = np.abs(dr) < 1.0
    h_c = (s - r * dr)[ok]
    # exposed end caps: sphere 0 from its tip (angle 0) to its contact circle (cos = r'_0), the last
    # sphere from its contact circle (cos = -r'_N) to its end; chord error below tol
    caps = []
    for j, sign, cosc, ctol in ((0, -1.0, dr[0], tol), (len(s) - 1, 1.0, -dr[-1], end_tol)):
        if r[j] <= 0:
            continue
        phi_c = math.acos(float(np.clip(cosc, -1.0, 1.0)))
        step = math.sqrt(8 * max(ctol, tol) / r[j])
        n = int(min(max(8, phi_c / step), 200000))
        ph = np.linspace(0.0, phi_c, n)
        caps.append(s[j] + sign * r[j] * np.cos(ph))
    # zones: spheres whose visible h-interval is wide (kinks of r) get arc points
    j_vis = U.hull
    lo_h = np.r_[s[0] - r[0], U.breaks]
    hi_h = np.r_[U.breaks, s[-1] + r[-1]]
    # (a visible interval without a contact point in its middle half: where r has a kink the union is
    # that sphere's arc between the neighbouring contact circles, not an envelope)
    zones = []
    # the contact points come in a few hundred monotone runs (mostly falling): a merge sort takes them in 1 ms
    # where the default sort takes 16 (300k points); sorted floats are the same array either way
    hs = np.sort(h_c, kind="stable")
    inner = (j_vis != 0) & (j_vis != len(s) - 1)      # the end spheres' exposed parts are the caps above
    jj = j_vis[inner]
    a_all = np.maximum(lo_h[inner], s[jj] - r[jj])
    b_all = np.minimum(hi_h[inner], s[jj] + r[jj])
    step_all = np.sqrt(8 * tol * np.maximum(r[jj], 1e-300))
    wide = b_all - a_all > step_all
    a_w, b_w, step_w = a_all[wide], b_all[wide], step_all[wide]
    q_w = 0.25 * (b_w - a_w)
    bare = np.searchsorted(hs, b_w - q_w) <= np.searchsorted(hs, a_w + q_w)
    for a, b, step in zip(a_w[bare], b_w[bare], step_w[bare]):
        n = int(min(np.ceil((b - a) / step) + 1, 200000))
        zones.append(np.linspace(a, b, n))
    h = _sorted_union(h_c, hs, np.concatenate(caps + zones + [[s[0] - r[0], s[-1] + r[-1]]]))
    h = h[(h >= s[0] - r[0]) & (h <= s[-1] + r[-1])]
    keep = np.r_[True, np.diff(h) > 1e-13 * max(1.0, float(np.ptp(h)))]
    h = h[keep]
    R = U(h)
    R[0] = R[-1] = 0.0
    # thin clusters far below the chord-error spacing (contact points crowd at the tool tip)
    d_min = 0.25 * math.sqrt(8 * tol * max(float(r.min()), 1e-3 * float(r.max())))
    P = np.c_[h, R]
    keep = np.zeros(len(P), bool)
    keep[[0, -1]] = True
    arc = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))]
    keep[_first_at_or_after(arc, d_min)] = True
    return _graded_polyline(P[keep], ratio=grade) if grade else P[keep]


def _ascending(a):
    """Whether the float array a is sorted (non-decreasing, no NaN)."""
    return bool(len(a) < 2 or (a[1:] >= a[:-1]).all())


def _sorted_union(values, ordered, extra):
    """``np.unique(np.concatenate([values, extra]))`` for many ``values`` already sorted as ``ordered`` and a few
    ``extra``: the extra values merged in instead of a sort of all (the same array).  Zeros of both signs
    (which of them np.unique keeps depends on the order its sort meets them) or a NaN take np.unique itself."""
    zeros = np.signbit(np.r_[ordered[ordered == 0], extra[extra == 0]])
    if not len(ordered) or not (np.isfinite(ordered).all() and np.isfinite(extra).all()) \
            or (zeros.any() and not zeros.all()):
        return np.unique(np.concatenate([values, extra]))
    first = np.r_[True, ordered[1:] != ordered[:-1]]
    base = ordered[first]
    extra = np.unique(extra)
    at = np.searchsorted(base, extra)
    new = base[np.minimum(at, len(base) - 1)] != extra
    return np.insert(base, at[new], extra[new])


def _first_at_or_after(arc, step):
    """Indices np.unique(np.searchsorted(arc, np.arange(0.0, arc[-1], step))) for a non-decreasing ``arc``
    starting at 0, without the grid: vertex i (> 0) is one iff a grid value k step (0 <= k < the grid's
    length) lies in (arc[i - 1], arc[i]]."""
    arc = np.asarray(arc, float)
    if len(arc) < 2 or not arc[-1] > 0:
        return np.zeros(0 if not len(arc) or not arc[-1] > 0 else 1, int)
    prev = arc[:-1]
    k = np.maximum(np.floor(prev / step) - 1.0, 0.0)
    for _ in range(4):          # the least k with k step > arc[i - 1] (floor may be off by one either way)
        k = np.where(k * step <= prev, k + 1.0, k)
    g = k * step
    hit = (g <= arc[1:]) & (k < math.ceil(float(arc[-1]) / step))     # np.arange's length
    return np.r_[0, 1 + np.flatnonzero(hit)]


def _graded_polyline(P, ratio=1.1):
    """Resample a polyline (along its own chords) so that neighbouring segment lengths differ by at
    most ``ratio``: nearest-vertex searches (:class:`sweep.MeridianPart` looks at the 4 nearest
    vertices) then always see the segment that holds the nearest point."""
    seg = np.linalg.norm(np.diff(P, axis=0), axis=1)
    seg = np.maximum(seg, 1e-15)
    sig = seg.copy()
    # grading by cumulative minima in log space: sig_i <= sig_j * ratio^|i-j|
    lr = math.log(ratio)
    idx = np.arange(len(sig))
    ls = np.log(sig)
    fwd = np.minimum.accumulate(ls - idx * lr) + idx * lr
    bwd = (np.minimum.accumulate((ls + idx * lr)[::-1]))[::-1] - idx * lr
    sig = np.exp(np.minimum(fwd, bwd))
    L = np.r_[0.0, np.cumsum(seg)]
    # split every segment into pieces no longer than its graded target spacing
    k = np.maximum(np.ceil(seg / sig - 1e-9).astype(int), 1)
    start = np.repeat(L[:-1], k)
    frac = ranks_in_runs(k)
    pos = np.r_[start + frac * np.repeat(seg / k, k), L[-1]]
    out = np.c_[np.interp(pos, L, P[:, 0]), np.interp(pos, L, P[:, 1])]
    keep = np.r_[True, np.diff(out[:, 0]) > 0]
    return out[keep]


def _graded_samples(s0, s1, r_of, tol=2e-10, n_min=400, n_max=60000):
    """Axial positions with spacing ~ sqrt(8 tol r) (meridian chord error ~ tol where its curvature
    is ~ 1/r), between s0 and s1."""
    probe = np.linspace(s0, s1, 2001)
    rp = np.maximum(r_of(probe), 1e-2 * (s1 - s0))
    density = 1.0 / np.sqrt(8 * tol * rp)            # samples per unit length
    cum = np.r_[0.0, np.cumsum(0.5 * (density[1:] + density[:-1]) * np.diff(probe))]
    n = int(np.clip(cum[-1], n_min, n_max))
    return np.interp(np.linspace(0.0, cum[-1], n + 1), cum, probe)


def _contact_points(s, r):
    dr = np.clip(np.gradient(r, s), -1.0, 1.0)
    return s - r * dr, r * np.sqrt(1.0 - dr * dr)


def _refine_samples(s, r_of, tol, n_max=60000):
    """Subdivide the axial samples so that every piece of the contact curve (meridian) turns by at
    most what a chord error of ``tol`` allows: a piece of length L turning by dtheta has chord error
    ~ L dtheta / 8, split into k = sqrt(L dtheta / (8 tol)) parts."""
    h, R = _contact_points(s, r_of(s))
    dh, dR = np.diff(h), np.diff(R)
    L = np.hypot(dh, dR)
    ang = np.arctan2(dR, dh)
    turn = np.abs(np.r_[0.0, np.diff(ang)])
    turn = np.maximum(turn, np.r_[np.diff(ang), 0.0].__abs__())
    k = np.ceil(np.sqrt(L * turn / (8 * tol))).astype(int)
    k = np.clip(k, 1, None)
    scale = min(1.0, n_max / max(int(k.sum()), 1))
    k = np.maximum((k * scale).astype(int), 1)
    ds = np.diff(s)
    frac = ranks_in_runs(k)
    return np.r_[np.repeat(s[:-1], k) + frac * np.repeat(ds / k, k), s[-1]]


def _contact_samples(r_and_dr, s_init, tol, max_rounds=40, n_max=400000):
    """Axial samples whose envelope contact points (h, R) = (s - r r', r sqrt(1 - r'^2)) are close
    enough that every chord of the contact polyline is within ~``tol`` of the envelope: a segment of
    length L between directions turning by dtheta at its ends has sagitta ~ L dtheta / 8; segments
    above ``tol`` (and segments next to a point where |r'| >= 1) are bisected in s until none is
    left (or the s spacing reaches 1e-12 of the extent).  Returns the samples and r, r' there."""
    s = np.unique(np.asarray(s_init, float))
    span = float(s[-1] - s[0])
    r, dr = r_and_dr(s)
    for _ in range(max_rounds):
        bad = np.abs(dr) >= 1.0
        d = np.clip(dr, -1.0, 1.0)
        h, R = s - r * d, r * np.sqrt(1.0 - d * d)
        dh, dR = np.diff(h), np.diff(R)
        Lseg = np.hypot(dh, dR)
        ang = np.arctan2(dR, dh)
        turn = np.abs(wrapped(np.diff(ang)))
        t_seg = np.maximum(np.r_[0.0, turn], np.r_[turn, 0.0])
        sag = Lseg * t_seg / 8.0
        # backwards or jumping contact points (hidden parts, kinks): refine them too
        sag = np.where((dh < 0) | bad[:-1] | bad[1:], np.maximum(sag, Lseg), sag)
        split = (sag > tol) & (np.diff(s) > 1e-12 * span)
        if not split.any() or len(s) + split.sum() > n_max:
            break
        # r_and_dr works point by point: only the new midpoints are evaluated, then merged in order
        mid = 0.5 * (s[:-1] + s[1:])[split]
        rm, drm = r_and_dr(mid)
        order = np.argsort(np.r_[s, mid], kind="stable")
        s, r, dr = np.r_[s, mid][order], np.r_[r, rm][order], np.r_[dr, drm][order]
    return s, r, dr


def _shrink_concave(mer, tol):
    """Pull the vertices of concave stretches of a meridian polyline (R'' > 0, where its chords lie
    outside the smooth tool by up to their sagitta) inwards by that sagitta (at most ``tol``);
    convex stretches keep their exact vertices (chords inside the tool)."""
    P = mer.copy()
    if len(P) < 3:
        return P
    d = np.diff(P, axis=0)
    L = np.hypot(d[:, 0], d[:, 1])
    ang = atan2(d[:, 1], d[:, 0])
    turn = wrapped(np.diff(ang))          # > 0: turning left = concave for R(h)
    sag = np.zeros(len(P))
    conc = np.maximum(turn, 0.0)
    # a vertex next to a concave turn: the adjacent chords overshoot by ~ L * turn / 8
    sag[1:-1] = np.minimum(np.maximum(L[:-1], L[1:]) * conc / 4.0, tol)
    sag[1:-1] = np.maximum(sag[1:-1], np.r_[0.0, sag[1:-2]] * 0.0)
    P[1:-1, 1] = np.maximum(P[1:-1, 1] - sag[1:-1], 0.0)
    return P


# ============================================================================ two paths, cones
def eval_at_tool_coordinate(ev, x, t, solvers=None, tag=0):
    """:class:`AxisEvaluator` at tool coordinates t (arc length along the axis from its common
    perpendicular with z, lam = t cos(alpha)), with the gradients d r / d x at fixed t: the
    alpha-derivative gains (a - b)/r . da/dlam * dlam/dalpha = ... * (-t sin(alpha)).  One tool
    placed on two axes with different alpha is the same tool only in this coordinate."""
    return eval_at_tool_coordinates(ev, [(x, t, solvers, tag)])[0]


def eval_at_tool_coordinates(ev, requests):
    """:func:`eval_at_tool_coordinate` of several (x, t, solvers, tag) requests in one evaluator run."""
    reqs = [(x, np.asarray(t, float), solvers, tag) for x, t, solvers, tag in requests]
    found = ev.multi([(x, t * math.cos(float(x[0])), solvers, tag) for x, t, solvers, tag in reqs])
    for (x, t, _, _), ar in zip(reqs, found):
        al = float(x[0])
        c, s = math.cos(ev.valley.theta + x[2]), math.sin(ev.valley.theta + x[2])
        dadl = np.array([c, s, math.tan(al)])
        for k, ft in enumerate(ar.feet):
            ar.grad[k][:, 0] += (ft.direction @ dadl) * (-t * math.sin(al))
    return found


def _two_path_terms(ev, y, t, gradients=True):
    """Errors of one tool on two axes (Bizzarri & Bartoň 2021 §4.3) at tool coordinates t, as rows e >= 0 with their
    gradients d e / d (x1, x2) (M, 6) (None without ``gradients``) and the counted masks.

    Axis p mills its flank (own_p: distance to the trimmed flank p, counted where the foot is
    interior).  The tool's radius r(t) must stay below every counted own_q (Eq. (19) with (14)) and
    below the distances G_p,k of *both* axes to both untrimmed flanks (a tool on axis 1 must not cut
    flank 2; this is what Eq. (18) leaves out and why its optimum can be a worse tool).  With
    r = the minimum of all of them, the error of axis p is own_p - r = the largest of own_p - own_q,
    own_p - G_p,k, own_p - G_q,k: every such difference is a row (where own_p counts).

    The rows come in ten blocks of len(t): axis 1 against own_2, G_1,1, G_1,2, G_2,1, G_2,2, then axis 2
    against own_1 and the same four; a row that does not count is 0 with a zero gradient."""
    v = ev.valley
    x1, x2 = y[:3], y[3:6]
    A, B = eval_at_tool_coordinates(ev, [(x1, t, (v.feet[0],) + tuple(v.full_feet), "tp1"),
                                         (x2, t, (v.feet[1],) + tuple(v.full_feet), "tp2")])
    n = len(t)
    own_a, own_b = A.interior[0], B.interior[0]
    both = own_a & own_b
    counted = np.stack([both, own_a, own_a, own_a, own_a, both, own_b, own_b, own_b, own_b])
    own = np.repeat(np.stack([A.r[0], B.r[0]]), 5, axis=0)
    other = np.stack([B.r[0], A.r[1], A.r[2], B.r[1], B.r[2], A.r[0], A.r[1], A.r[2], B.r[1], B.r[2]])
    rows = np.where(counted, own - other, 0.0).ravel()
    owners = np.repeat([0, 1], 5 * n)
    if not gradients:
        return rows, None, owners, (A, B)
    # d(own_p - other)/d(x1, x2): own_p's gradient in axis p's columns, minus the other distance's in its own
    # axis' columns (0 - g where the axes differ, as the difference of the zero-padded gradients gives it)
    gA, gB = A.grad, B.grad
    G = np.zeros((2, 5, n, 6))
    G[0, :, :, :3] = gA[0]
    G[0, 0, :, 3:] = 0.0 - gB[0]
    G[0, 1:3, :, :3] = gA[0] - gA[1:3]
    G[0, 3:5, :, 3:] = 0.0 - gB[1:3]
    G[1, :, :, 3:] = gB[0]
    G[1, 0, :, :3] = 0.0 - gA[0]
    G[1, 1:3, :, :3] = 0.0 - gA[1:3]
    G[1, 3:5, :, 3:] = gB[0] - gB[1:3]
    grads = np.where(counted[:, :, None], G.reshape(10, n, 6), 0.0).reshape(-1, 6)
    return rows, grads, owners, (A, B)


def _coverage_gap(valley, k, feet):
    """Largest gap (fraction of the trimmed flank k's parameter range) between the interior feet of
    axis samples on that flank and its ends: 0 = every sample spacing reaches the whole flank."""
    lo, hi = valley.ranges[k]
    u = np.sort(np.r_[lo, feet.u[feet.interior], hi])
    return float(np.diff(u).max() / (hi - lo))


def optimize_two_paths(valley, n=100, x0=None, evaluator=None, starts=None, rounds=4, n_dense=3000):
    """Bizzarri & Bartoň 2021 §4.3: one tool, two axes.  Minimise the largest error of the shared tool on either axis
    (Eq. (18) plus the one-flank tails and the other-flank clearance, see :func:`_two_path_terms`)
    over (x1, x2) by SLSQP on the epigraph form with exact gradients, from the double-flank optimum
    ``x0`` on both axes and a few starts that move the two axes apart in delta and phi (the paper
    starts from zeros).

    The errors have narrow spikes (a foot jumping across a flank's corner) that a fixed sample set
    misses and the optimiser then exploits, so the samples are exchanged as in semi-infinite
    programming: after each round the errors are evaluated at ``n_dense`` tool coordinates, the
    local maxima above the sampled optimum join the samples, and SLSQP restarts from the best pair.
    Pairs are compared by the dense error; a pair whose axes leave part of their flank unswept
    (coverage gap larger than the double-flank axis has) is never kept."""
    t0 = time.perf_counter()
    ev = evaluator or AxisEvaluator(valley)
    R = valley.outer_radius
    x0 = np.zeros(3) if x0 is None else np.asarray(x0, float)
    # tool coordinates over the double-flank tool's whole extent (its tip may reach below the
    # optimisation samples of Eq. (11))
    ext = tool_extent(ev, x0)
    t_lo = (ext[0] - 0.02 * R) / math.cos(float(x0[0]))
    t_hi = max(ext[1], valley.lam_range[1]) / math.cos(float(x0[0]))
    t_dense = np.linspace(t_lo, t_hi, n_dense)
    samples = {"t": np.linspace(t_lo, t_hi, 2 * n)}

    def gaps(A, B):
        return _coverage_gap(valley, 0, A.feet[0]), _coverage_gap(valley, 1, B.feet[0])

    def dense(y):
        """Largest error over the dense coordinates (and per coordinate), coverage gaps."""
        e, _, _, (A, B) = _two_path_terms(ev, y, t_dense, gradients=False)
        per_t = e.reshape(-1, n_dense).max(axis=0)
        return float(per_t.max()), per_t, gaps(A, B)

    seen = {}

    def fun_jac(y):
        e, G, _, (A, B) = _two_path_terms(ev, y, samples["t"])
        # keep the best axis pair SLSQP evaluated that still sweeps both whole flanks: coverage
        # is not smooth enough for a constraint, and the final iterate may have lost part of a flank
        val = float(e.max())
        if val < seen.get("phi", np.inf) and covers(gaps(A, B)):
            seen.update(phi=val, y=y[:6].copy())
        J = np.zeros((len(e), 7))
        J[:, :6] = -G / R
        J[:, 6] = 1.0
        return y[6] - e / R, J

    obj = lambda y: (y[6], np.r_[np.zeros(6), 1.0])  # noqa: E731
    p_ref, per_ref, need = dense(np.r_[x0, x0])

    def covers(g):
        return g[0] <= need[0] + 0.01 and g[1] <= need[1] + 0.01

    box = [(max(lo, c - 0.2), min(hi, c + 0.2)) for (lo, hi), c in zip(_bounds(valley), x0)]
    lo_b, hi_b = [b_[0] for b_ in box * 2], [b_[1] for b_ in box * 2]
    starts = starts or [(0.0, 0.0, 0.0, 0.0), (0.0, 0.05, 0.0, -0.05)]
    best = (np.r_[x0, x0], p_ref, per_ref)
    per, nit = [], 0
    y_starts = [np.clip(np.r_[x0 + [0.0, d1, f1_], x0 + [0.0, d2, f2_]], lo_b, hi_b)
                for d1, f1_, d2, f2_ in starts]
    for rnd in range(rounds):
        improved = False
        for y0 in y_starts:
            ts = time.perf_counter()
            e0, _, _, _ = _two_path_terms(ev, y0, samples["t"], gradients=False)
            seen.clear()
            res = _slsqp(fun_jac, np.r_[y0, float(e0.max()) / R], box * 2 + [(0.0, None)], 0, obj)
            cands = [res.x[:6].copy()] + ([seen["y"]] if "y" in seen else [])
            for y_end in cands:
                val, per_t, g = dense(y_end)
                ok = covers(g)
                per.append((y0.tolist(), y_end.tolist(), val if ok else float("inf"), int(res.nit),
                            time.perf_counter() - ts))
                if ok and val < best[1] - 1e-12 * R:
                    best, nit, improved = (y_end, val, per_t), int(res.nit), True
        # exchange: dense local maxima of the best pair that the samples do not hold yet
        per_t = best[2]
        peak = np.r_[False, (per_t[1:-1] >= per_t[:-2]) & (per_t[1:-1] >= per_t[2:]), False]
        peak |= np.r_[per_t[0] >= per_t[1], np.zeros(n_dense - 2, bool), per_t[-1] >= per_t[-2]]
        idx = np.flatnonzero(peak & (per_t > 0.5 * best[1]))
        idx = idx[np.argsort(per_t[idx])[::-1][:40]]
        new_t = t_dense[idx]
        near = np.min(np.abs(new_t[:, None] - samples["t"][None, :]), axis=1) < 0.25 * (t_hi - t_lo) / n_dense
        if not len(new_t) or near.all() or (rnd and not improved):
            break
        samples["t"] = np.sort(np.r_[samples["t"], new_t[~near]])
        y_starts = [best[0]]
    y, val = best[0], best[1]
    x1, x2 = y[:3], y[3:6]
    el = time.perf_counter() - t0
    mk = lambda xx: AxisFit(x=np.array([xx[0], xx[1] * R, xx[2]]), x_unit=xx, phi=val, iterations=nit,  # noqa: E731
                            evaluations=0, starts=len(per), elapsed_s=el, per_start=per)
    return mk(x1), mk(x2)


def optimize_cone_axis(valley, lam, x0=None, evaluator=None):
    """Bizzarri & Bartoň 2021 Eq. (20): Phi = max|r1 - r2| + (1/(n-2)) (sum |D2 r1| + sum |D2 r2|) (D2 = second
    differences along the axis samples ``lam``), minimised by SLSQP on its epigraph form with slack
    variables for the absolute values; gradients exact (D2 is linear in r)."""
    t0 = time.perf_counter()
    ev = evaluator or AxisEvaluator(valley)
    lam = np.asarray(lam, float)
    n = len(lam)
    R = valley.outer_radius
    x0 = np.zeros(3) if x0 is None else np.asarray(x0, float)
    D2 = np.zeros((n - 2, n))
    i = np.arange(n - 2)
    D2[i, i], D2[i, i + 1], D2[i, i + 2] = 1.0, -2.0, 1.0
    tag = ("cone", float(lam[0]), float(lam[-1]))

    def fun_jac(y):
        ar = ev(y[:3], lam, tag=tag)
        c = ar.interior
        w = (c[0] & c[1]).astype(float)
        d = (ar.r[0] - ar.r[1]) / R * w
        Jd = (ar.grad[0] - ar.grad[1]) / R * w[:, None]
        # second differences of each flank's distances, only over triples counted on that flank
        rows, jac = [], []
        for k in (0, 1):
            t = (c[k][:-2] & c[k][1:-1] & c[k][2:]).astype(float)
            rows.append(t * (D2 @ ar.r[k]) / R)
            jac.append(t[:, None] * (D2 @ ar.grad[k]) / R)
        m = n - 2
        nv = 4 + 2 * m
        g = np.r_[y[3] - d, y[3] + d, y[4:4 + m] - rows[0], y[4:4 + m] + rows[0],
                  y[4 + m:] - rows[1], y[4 + m:] + rows[1]]
        G = np.zeros((len(g), nv))
        G[:n, :3], G[n:2 * n, :3] = -Jd, Jd
        G[:2 * n, 3] = 1.0
        o = 2 * n
        eye = np.eye(m)
        for k in (0, 1):
            G[o:o + m, :3], G[o + m:o + 2 * m, :3] = -jac[k], jac[k]
            G[o:o + m, 4 + k * m:4 + (k + 1) * m] = eye
            G[o + m:o + 2 * m, 4 + k * m:4 + (k + 1) * m] = eye
            o += 2 * m
        return g, G

    m = n - 2
    grad_obj = np.r_[0.0, 0.0, 0.0, 1.0, np.full(2 * m, 1.0 / m)]
    obj = lambda y: (y[3] + np.sum(y[4:]) / m, grad_obj)  # noqa: E731
    g0, _ = fun_jac(np.r_[x0, np.zeros(1 + 2 * m)])
    # feasible start: every slack at the absolute value it bounds (g = slack -/+ value with slack 0)
    y0 = np.r_[x0, np.abs(g0[:n]).max(), np.abs(g0[2 * n:2 * n + m]), np.abs(g0[2 * n + 2 * m:2 * n + 3 * m])]
    res = _slsqp(fun_jac, y0, _bounds(valley) + [(0.0, None)] * (1 + 2 * m), len(g0), obj)
    x = res.x[:3]
    return AxisFit(x=np.array([x[0], x[1] * R, x[2]]), x_unit=x, phi=float(obj(res.x)[0] * R),
                   iterations=int(res.nit), evaluations=0, starts=1, elapsed_s=time.perf_counter() - t0)


def fit_cone_below(t, rmin):
    """Bizzarri & Bartoň 2021 Eq. (21) with the overcut set I2 empty by construction: the line r(t) = a + b t with
    r(t_i) <= rmin_i maximising sum r(t_i) (= minimising sum of rmin_i - r(t_i)), by linprog."""
    from scipy.optimize import linprog

    t = np.asarray(t, float)
    A = np.c_[np.ones_like(t), t]
    ends = -A[[0, -1]]          # and r >= 0 at both ends: a tool has no negative radius
    res = linprog(c=-A.sum(axis=0), A_ub=np.r_[A, ends], b_ub=np.r_[np.asarray(rmin, float), 0.0, 0.0],
                  bounds=[(None, None)] * 2, method="highs")
    if not res.success:
        raise ValueError(f"cone fit failed: {res.message}")
    return float(res.x[0]), float(res.x[1])


def build_cone(ev, x, extent, n=200, tag="cone"):
    """A cone on axis x between lam in ``extent``: distances at n nodes, the LP fit of Eq. (21) below
    min(r1, r2) over the counted nodes (the tail counts for its own flank), errors e_k = r_k - r."""
    v = ev.valley
    lo, hi = extent
    lam = np.linspace(lo, hi, n)
    ar, full = ev.multi([(x, lam, None, (tag, lo, hi)), (x, lam, v.full_feet, (tag, "full", lo, hi))])
    cap = np.minimum(full.r[0], full.r[1])
    counted = ar.interior
    rmin = np.minimum(radial_function(ar.r, counted, "min", cap), cap)
    speed = 1.0 / math.cos(float(x[0]))
    s = (lam - lo) * speed
    a, b = fit_cone_below(s, rmin)
    radii = a + b * s
    errors = np.where(counted, ar.r - radii[None, :], np.nan)
    return ToolPath(x=np.array([x[0], x[1] * v.outer_radius, x[2]]), lam=lam, points=ar.points, radii=radii,
                    r=ar.r, counted=counted, errors=errors, plan_points=ar.points[[0, -1]],
                    plan_radii=radii[[0, -1]], meridian=None, kind="cone",
                    dirs=np.array([ar.feet[0].direction, ar.feet[1].direction]))


# ============================================================================ meshes, CSV
def tool_mesh(path, n_around=48, max_rings=400, shank=None):
    """Revolved triangle mesh of a path's tool in the rotor frame: (verts (V, 3), faces (F, 3)).

    The custom tool revolves its exact meridian (decimated to ``max_rings`` rings), a cone its two
    radii (plus the sphere caps of the envelope are omitted: flat ends).  ``shank`` = (start, end,
    radius) adds a closed cylinder."""
    a0, a1 = path.plan_points[0], path.plan_points[-1]
    d = (a1 - a0) / np.linalg.norm(a1 - a0)
    if path.meridian is not None:
        mer = path.meridian
        if len(mer) > max_rings:
            mer = mer[np.unique(np.r_[np.linspace(0, len(mer) - 1, max_rings).astype(int), len(mer) - 1])]
    else:
        L = float(np.linalg.norm(a1 - a0))
        mer = np.array([[0.0, 0.0], [0.0, path.plan_radii[0]], [L, path.plan_radii[-1]], [L, 0.0]])
    e1 = np.cross(d, [0.0, 0.0, 1.0] if abs(d[2]) < 0.9 else [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    parts = [(a0, mer)]
    if shank is not None:
        s0, s1, rs = (np.asarray(shank[0], float), np.asarray(shank[1], float), float(shank[2]))
        Ls = float(np.linalg.norm(s1 - s0))
        off = float((s0 - a0) @ d)
        parts.append((a0, np.array([[off, 0.0], [off, rs], [off + Ls, rs], [off + Ls, 0.0]])))
    th = np.linspace(0, 2 * np.pi, n_around, endpoint=False)
    ring = np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2
    verts, faces, base = [], [], 0
    for origin, m in parts:
        v = origin + m[:, 0][:, None, None] * d + m[:, 1][:, None, None] * ring
        v = v.reshape(-1, 3)
        K = len(m)
        i = np.arange(K - 1)[:, None] * n_around
        j = np.arange(n_around)[None, :]
        a, b = i + j, i + (j + 1) % n_around
        f = np.concatenate([np.stack([a, b, b + n_around], -1).reshape(-1, 3),
                            np.stack([a, b + n_around, a + n_around], -1).reshape(-1, 3)]) + base
        verts.append(v)
        faces.append(f)
        base += len(v)
    return np.vstack(verts), np.vstack(faces)


def envelope_meshes(path, surface, z_range=(0.0, 1.0), n_t=48):
    """The two branches of the tool's envelope (Bizzarri & Bartoň 2021 Eqs. (5)-(9)): the characteristic points
    c_k = a + r (b_k - a)/|b_k - a| on the tool toward the feet b_k, screwed by the helical motion
    over ``z_range``.  Returns [(verts (N*n_t, 3), faces, deviation (N*n_t,)) per flank]; the
    per-vertex deviation is the tool-to-rotor error e_k of its axis node (constant along helices,
    Bizzarri & Bartoň 2021 §4.2), nan where the node does not mill that flank."""
    from ...geometry.screw import screw_motion

    out = []
    for k in (0, 1):
        sel = path.counted[k]
        if sel.sum() < 2:
            out.append((np.zeros((0, 3)), np.zeros((0, 3), int), np.zeros(0)))
            continue
        a = path.points[sel]
        c = a - path_feet_dirs(path, k)[sel] * path.radii[sel][:, None]
        ts = np.linspace(z_range[0], z_range[1], n_t) / surface.v0
        V = screw_motion(c[:, None, :], ts[None, :], surface.v0, surface.hand)   # (N, n_t, 3)
        N = len(c)
        i = np.arange(N - 1)[:, None] * n_t
        j = np.arange(n_t - 1)[None, :]
        q = i + j
        f = np.concatenate([np.stack([q, q + n_t, q + n_t + 1], -1).reshape(-1, 3),
                            np.stack([q, q + n_t + 1, q + 1], -1).reshape(-1, 3)])
        dev = np.repeat(path.errors[k][sel], n_t)
        out.append((V.reshape(-1, 3), f, dev))
    return out


def path_feet_dirs(path, k):
    """Unit vectors (N, 3) from the foot on flank k to the axis node (stored when the path was built)."""
    return path.dirs[k]


def write_tool_csv(path_or_file, tool_path, max_rows=4000):
    """The tool grinder's data: the revolved profile as (axial position from the tip, radius) rows."""
    mer = tool_path.meridian
    if mer is None:
        L = float(np.linalg.norm(tool_path.plan_points[-1] - tool_path.plan_points[0]))
        mer = np.array([[0.0, tool_path.plan_radii[0]], [L, tool_path.plan_radii[-1]]])
    if len(mer) > max_rows:
        mer = mer[np.unique(np.r_[np.linspace(0, len(mer) - 1, max_rows).astype(int), len(mer) - 1])]
    np.savetxt(path_or_file, mer, delimiter=",", header="axial_position,radius", comments="", fmt="%.12g")


# ============================================================================ plans
@dataclass
class DoubleFlankResult:
    """Everything an operator needs: the plan dict, the tool paths (axis nodes, radii, errors along
    the axis), the axis fits and the one-sided distances of Bizzarri & Bartoň 2021 Remark 4.5 per target flank."""
    plan: dict
    paths: list
    fits: list
    valley: Valley
    tool_to_rotor: list        # per target flank: (max e_k, min e_k) over its paths' nodes (Eq. (15))
    rotor_to_envelope: list    # per target flank: (max, min) simulated deviation of its profile points
    hausdorff: list            # per target flank: max(|tool_to_rotor|, |rotor_to_envelope|)
    elapsed_s: float
    optimize_s: float

    def tool_mesh(self, k=0, **kw):
        st = self.plan["strips"][k]
        return tool_mesh(self.paths[k], shank=(st["shank_start"], st["shank_end"], st["shank_radius"]), **kw)

    def envelope_meshes(self, z_range=(0.0, 1.0), n_t=48):
        surf = self.valley.surface
        return [envelope_meshes(p, surf, z_range, n_t) for p in self.paths]

    def errors_along_axis(self, k=0):
        """(s (N,), e1 (N,), e2 (N,)): axial position from the tip and the errors of Eq. (15), nan where
        a node does not mill that flank."""
        p = self.paths[k]
        s = np.linalg.norm(p.points - p.points[0], axis=1)
        return s, p.errors[0], p.errors[1]


def _strip(path, flank, shank_len):
    a0, a1 = path.plan_points[0], path.plan_points[-1]
    d = (a1 - a0) / np.linalg.norm(a1 - a0)
    st = {"axis_start": a0.tolist(), "axis_end": a1.tolist(), "radii": [float(x) for x in path.plan_radii],
          "shank_start": a1.tolist(), "shank_end": (a1 + shank_len * d).tolist(),
          "shank_radius": float(0.5 * path.plan_radii[-1]), "flank": int(flank),
          "reported_max_error": 0.0, "reported_min_error": 0.0, "collision": False,
          "axis_params": {"alpha": float(path.x[0]), "delta": float(path.x[1]), "phi": float(path.x[2])}}
    if path.meridian is not None:
        st["meridian"] = path.meridian.tolist()
    return st


def simulate_plan_errors(plan, search=None):
    """Rotor-to-envelope deviations of a plan's target flank points by the sweep simulation
    (:mod:`sweep`, signed: + material left, - overcut), each point owned by the strip that forms the
    machined surface there (the first within 1e-12 R of the least distance): the sweep ``verify`` runs
    (:func:`simulation.verify.sweep_targets`), so the plan reports ``verify``'s numbers.
    Returns (indices, deviation, owner, per-strip (max, min))."""
    from ...simulation.verify import sweep_targets

    swept = sweep_targets(plan, search)
    idx = np.flatnonzero(swept.target)
    dev, owner = swept.deviation[idx], swept.owner[idx]
    per = []
    for k in range(len(plan["strips"])):
        d = dev[(owner == k) & np.isfinite(dev)]
        per.append((float(d.max()), float(d.min())) if len(d) else (0.0, 0.0))
    return idx, dev, owner, per


def finish_meridians(paths):
    """Make the meridians that :func:`build_path` left for later (``meridian="later"``)."""
    for p in paths:
        if p.make_meridian is not None:
            p.meridian, p.make_meridian = p.make_meridian(), None


def _max_err(paths):
    return max(float(np.nanmax(p.errors)) for p in paths)


def _two_paths(ev, f1, f2, m, n_dense=3001, tol=2e-8):
    """Eqs. (19) + (14): one tool on two axes.  Its radial function, in the tool coordinate t
    (:func:`eval_at_tool_coordinate`), is the minimum of the counted distances of the axes to their
    own flanks and of both axes' distances to both untrimmed flanks (no axis cuts the other flank),
    exact at ``n_dense`` samples over the union of the two tools' extents, linear in between; both
    strips carry the same meridian in h = t - t_start."""
    v = ev.valley
    xs = [f1.x_unit, f2.x_unit]
    ext = [tool_extent(ev, xs[0], flanks=(0,)), tool_extent(ev, xs[1], flanks=(1,))]
    T0 = min(e[0] / math.cos(x[0]) for e, x in zip(ext, xs))
    T1 = max(e[1] / math.cos(x[0]) for e, x in zip(ext, xs))
    t = np.linspace(T0, T1, n_dense)
    shared = np.full(n_dense, np.inf)
    found = eval_at_tool_coordinates(ev, [(x, t, (v.feet[p],) + tuple(v.full_feet), ("tp", p))
                                          for p, x in enumerate(xs)])
    for ar in found:
        shared = np.minimum(shared, np.where(ar.interior[0], ar.r[0], np.inf))
        # an axis point inside the rotor (past the valley bottom) leaves no room for the tool there
        inside = ~(ar.feet[1].interior | ar.feet[2].interior) & (np.minimum(ar.r[1], ar.r[2]) < ar.r[0] - 1e-12)
        shared = np.minimum(shared, np.where(inside, 0.0, np.minimum(ar.r[1], ar.r[2])))
    shared = np.maximum(np.where(np.isfinite(shared), shared, 0.0), 0.0)
    # how far each axis sweeps its own flank: the trimmed flank's feet of the same samples, feet[0] above (a
    # run of that solver alone on the same points, cold or warm-started from its own earlier run, found
    # these feet bit for bit: every row iterates on its own and its guard query answers it alone)
    gaps = [_coverage_gap(v, p, ar.feet[0]) for p, ar in enumerate(found)]
    from scipy.interpolate import PchipInterpolator
    spline = PchipInterpolator(t, shared)      # C1, no overshoot: a smooth contact curve
    paths = []
    for p, x in enumerate(xs):
        c = math.cos(x[0])

        def fn(lq, c=c):
            return spline(np.clip(lq / c, T0, T1))

        paths.append(build_path(ev, x, m=m, extent=(T0 * c, T1 * c), flanks=(p,), radii_fn=fn, tag=("q", p),
                                tol=tol * v.outer_radius, meridian="later"))
    if np.array_equal(xs[0], xs[1]):
        # the double-flank axis used twice: both meridians come from the same numbers (the axis, its extent and
        # the shared radii; not the feet, which differ by flank), so the second is the first, made once when
        # asked (0.15-0.2 s).  Two different axes sample the same tool at parameters that differ in the last
        # bits, and their contact sampling then places other vertices (12,109 against 11,757 on the asymmetric
        # female): each keeps its own
        made = []

        def one_meridian(make=paths[0].make_meridian):
            if not made:
                made.append(make())
            return made[0].copy()

        for path in paths:
            path.make_meridian = one_meridian
    return paths, gaps


def plan_double_flank(surface, flank_ranges, valley=0, variant="min", tool="custom", two_paths=False, m=400,
                      rim=0.85, n=100, to_world=None, length_unit="R", simulate=True, starts=None, progress=None):
    """Plan double-flank milling of one valley (Bizzarri & Bartoň 2021).  Returns :class:`DoubleFlankResult`.

    surface: :class:`HelicalSurface` (rotor frame); flank_ranges: the rotor's flank parameter ranges
    (``Rotor.flanks``); valley: valley index; variant: 'min' | 'avg' | 'one-sided-1' | 'one-sided-2'
    (custom tool); tool: 'custom' | 'cone' | 'cones:K'; two_paths: one custom tool on two axes
    (Bizzarri & Bartoň 2021 §4.3); m: the plan's strip carries m + 1 radii; rim: targeted fraction of the valley depth.
    The plan's rotor section lists the rotor's flanks followed by the valley's two trimmed flanks,
    which are the plan's target flanks.  With ``simulate`` the strips' reported errors are the
    sweep simulation's (what verify_plan finds); otherwise they are the tool-to-rotor errors.
    ``progress``: None or ``progress(fraction, message)``; returning False cancels
    (:class:`progress.Cancelled` is raised, nothing is returned).
    """
    from ...io.plan import new_plan, rotor_section
    from ...progress import reporter, substage

    report = reporter(progress)

    t0 = time.perf_counter()
    if variant not in VARIANTS:
        raise ValueError(f"variant {variant!r} is not one of {', '.join(VARIANTS)}")
    if not (isinstance(m, (int, np.integer)) and 2 <= m <= 5000):
        raise ValueError(f"m = {m!r} radii intervals is outside the limits 2..5000")
    kind, n_cones = tool, 1
    if tool.startswith("cones:"):
        try:
            n_cones = int(tool.split(":", 1)[1])
        except ValueError:
            raise ValueError(f"tool {tool!r}: K in cones:K must be an integer") from None
        if not 1 <= n_cones <= 12:
            raise ValueError(f"tool {tool!r}: K = {n_cones} is outside the limits 1..12")
        kind = "cones"
    elif tool not in ("custom", "cone"):
        raise ValueError(f"tool {tool!r} is not one of custom, cone, cones:K")
    if two_paths and kind != "custom":
        raise ValueError("--two-paths needs the custom tool (Bizzarri & Bartoň 2021 §4.3)")
    report(0.0, "preparing the valley")
    v = Valley(surface, flank_ranges, valley, rim=rim)
    ev = AxisEvaluator(v)
    report(0.05, "optimising the tool axis")
    fit = optimize_axis(v, n=n, starts=starts, evaluator=ev, report=substage(report, 0.05, 0.4))
    fits, paths = [fit], []
    report(0.4, "building the tool")
    if kind == "custom" and not two_paths:
        paths.append(build_path(ev, fit.x_unit, m=m, variant=variant))
        method = "double-flank-custom"
    elif kind == "custom":
        report(0.4, "optimising two axes")
        f1, f2 = optimize_two_paths(v, n=n, x0=fit.x_unit, evaluator=ev)
        fits = [fit, f1, f2]
        paths, gaps = _two_paths(ev, f1, f2, m)
        # keep the two-axis tool only if it is better and still sweeps both flanks as completely as
        # the double-flank axis used twice; otherwise report that pair (fits[1:] = that axis)
        ref, ref_gaps = _two_paths(ev, fit, fit, m)
        if _max_err(paths) >= _max_err(ref) or max(gaps) > max(ref_gaps) + 0.01:
            paths, fits = ref, [fit, fit, fit]
        finish_meridians(paths)          # the winner's only: each pair's meridians cost 0.2-0.3 s
        method = "double-flank-custom-two-paths"
    else:
        ext = tool_extent(ev, fit.x_unit)
        edges = np.linspace(ext[0], ext[1], n_cones + 1) if kind == "cones" else np.array(ext)
        fits = [fit]
        for j in range(len(edges) - 1):
            report(0.4 + 0.3 * j / (len(edges) - 1), f"optimising cone {j + 1} of {len(edges) - 1}")
            lam = np.linspace(edges[j], edges[j + 1], n if kind == "cone" else max(20, n // n_cones))
            cf = optimize_cone_axis(v, lam, x0=fit.x_unit, evaluator=ev)
            fits.append(cf)
            e = (edges[j], edges[j + 1]) if kind == "cones" else tool_extent(ev, cf.x_unit)
            path = build_cone(ev, cf.x_unit, e, tag=("cone", j))
            if not np.isfinite(path.errors).any():
                # the optimised axis lost every contact on this part of the valley (a tail that
                # touches one flank only): the double-flank axis still reaches it
                cf = AxisFit(x=fit.x, x_unit=fit.x_unit, phi=float("nan"), iterations=cf.iterations,
                             evaluations=0, starts=1, elapsed_s=cf.elapsed_s)
                fits[-1] = cf
                path = build_cone(ev, fit.x_unit, e, tag=("cone-dfa", j))
            paths.append(path)
        method = "double-flank-cone" if kind == "cone" else f"double-flank-cones-{n_cones}"
    if method.endswith("two-paths"):       # f1 and f2 come from one run (their elapsed_s is shared)
        t_opt = fit.elapsed_s + f1.elapsed_s
    else:
        t_opt = sum(f.elapsed_s for f in fits)
    # plan: the rotor's flanks plus the two trimmed flanks of the valley (targets)
    prof = surface.profile
    per = prof.period
    npts = 2048
    half = 0.5 * per / npts
    (ur1, ub), (ub2, ur2) = v.ranges
    fl = list(flank_ranges) + [(ur1 + half, ub), (ub2, ur2 - half)]
    rot = rotor_section(prof, surface.v0, surface.handedness, fl, to_world=to_world, n_profile=npts)
    nf = len(flank_ranges)
    if method.endswith("two-paths"):
        flank_of = [nf, nf + 1]
    else:
        flank_of = [nf] * len(paths)
    R = v.outer_radius
    strips = [_strip(p, f, 0.6 * R) for p, f in zip(paths, flank_of)]
    for st in strips:
        st["target_flanks"] = [nf, nf + 1]
    tool_desc = {"kind": "revolved" if kind == "custom" else "cone", "variant": variant,
                 "valley": int(valley), "rim": rim}
    plan = new_plan(method, rot, tool_desc, length_unit=length_unit, target_flanks=[nf, nf + 1], strips=strips)
    t2r = []
    for k in (0, 1):
        e = np.concatenate([p.errors[k][p.counted[k]] for p in paths])
        t2r.append((float(e.max()), float(e.min())) if len(e) else (float("nan"), float("nan")))
    r2e, haus = [(float("nan"), float("nan"))] * 2, [float("nan")] * 2
    if simulate:
        report(0.75, "simulating the sweep")
        idx, dev, owner, per_strip = simulate_plan_errors(plan)
        for st, (mx, mn) in zip(plan["strips"], per_strip):
            st["reported_max_error"], st["reported_min_error"] = mx, mn
        n_prof = len(rot["profile"])
        r2e, haus = [], []
        for k, f in enumerate((nf, nf + 1)):
            a, b = rot["flanks"][f]
            sel = np.isin(idx, np.arange(a, b + 1) % n_prof) & np.isfinite(dev)
            d = dev[sel]
            r2e.append((float(d.max()), float(d.min())) if len(d) else (float("nan"), float("nan")))
            haus.append(max(abs(t2r[k][0]), abs(t2r[k][1]), abs(r2e[k][0]), abs(r2e[k][1])))
    else:
        for st, p in zip(plan["strips"], paths):
            e = p.errors[np.isfinite(p.errors)]
            st["reported_max_error"], st["reported_min_error"] = float(e.max()), float(e.min())
    from ...io.plan import summarize
    plan["summary"] = summarize(plan["strips"], time.perf_counter() - t0)
    report(1.0, "done")
    return DoubleFlankResult(plan=plan, paths=paths, fits=fits, valley=v, tool_to_rotor=t2r,
                             rotor_to_envelope=r2e, hausdorff=haus, elapsed_s=time.perf_counter() - t0,
                             optimize_s=t_opt)


def custom_tool_bounds(surface, flank_ranges, valley, c=None, d_angle=None, result=None, **plan_kw):
    """The bounds of Bizzarri, Bo & Bartoň, Eqs. (19)-(21), that the custom tool of valley ``valley`` sets
    for a conical cutter (:class:`tooling.cutter_selection.ValleyBounds`).  ``result``: a
    :class:`DoubleFlankResult` (or :class:`ToolPath`) already planned for this valley; otherwise
    :func:`plan_double_flank` runs without the sweep simulation (``plan_kw`` go to it)."""
    from ...tooling.cutter_selection import DEFAULT_C, DEFAULT_D_ANGLE, bounds_from_tool_path

    if result is None:
        kw = {"simulate": False, "m": 50}
        kw.update(plan_kw)
        result = plan_double_flank(surface, flank_ranges, valley=valley, **kw)
    path = result.paths[0] if hasattr(result, "paths") else result
    return bounds_from_tool_path(path, c=DEFAULT_C if c is None else c,
                                 d_angle=DEFAULT_D_ANGLE if d_angle is None else d_angle, valley=valley)
