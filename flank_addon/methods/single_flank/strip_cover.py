"""Which part of a flank each candidate tool pose mills within tolerance, the fewest poses that
mill all of it, adaptive seeding of the gaps, and the kink between neighbouring envelopes.

Coverage (Bizzarri, Bo & Bartoň §3.3, §6.1 "Gaps between strips")
-------------------------------------------------
A pose's tool is fixed in the rotor frame while the rotor screws (Bizzarri, Bo & Bartoň Eq. (1)); its envelope is
a helical surface of the same screw motion as the flank, so the rotor-to-envelope deviation of a
flank point depends only on its profile point in z = 0: a 2D problem along the profile.  The
deviation of profile point p with outward normal n is the root lambda of D(p + lambda n) = 0,
D(x) = min_t sd_tool(S_t(x)) (the sweep engine of :mod:`sweep`, exact for the helical motion);
positive = material left, negative = overcut.  A pose *covers* the profile points where
-eps_over <= deviation <= eps_under.

For several strips the machined deviation is the minimum of the strips' deviations (the swept
regions are united).  Hence a set of poses none of which overcuts the flank by more than eps_over
anywhere ("admissible" poses) mills a point within tolerance exactly when one of them covers it,
and choosing strips becomes covering the flank's parameter range [u_start, u_end] by the covered
intervals: :func:`minimum_interval_cover`.  A pose that overcuts somewhere by more than eps_over
spoils the flank there whatever else is chosen, so it is not used for covering (its coverage is
still reported).

The per-pose evaluation is vectorised over poses and points: every (pose, point) pair is one row,
the rows' tools are stacked (:class:`sweep.StackedTools`) and the same sphere tracing + Illinois
root finding as :func:`sweep.machined_deviation` runs on all rows at once.

Junctions (Bizzarri, Bo & Bartoň §7, Rajain et al. 2023 Eq. (16))
----------------------------------
Where two envelopes overlap, the machined surface switches from one to the other at the profile
point where their deviation curves cross.  Both envelopes pass through the machined point x
there; the kink angle is the angle between their normals at x.  The normal of an envelope at x
is the tool's surface normal at the contact: with t* the minimising time of D(x),
grad D(x) = R(t*)^T grad sd_tool(S_t*(x)) (envelope theorem), a 3D vector; the envelope is a
helical surface, so this is its normal along the whole helix through x.  Rajain et al. 2023 measures G1 by the
angles of the tool axes with the reference normal (its Eq. (16)); here the kink itself is measured.
"""
import math
from dataclasses import dataclass, field

import numpy as np

from ...geometry.screw import screw_motion
from ...simulation.sweep import (StackedTools, false_position, helical_distance, illinois_roots, illinois_update,
                                 tool_of)

_ROW_CHUNK = 4096


# ============================================================================ flank samples
@dataclass
class FlankSamples:
    """Profile samples of one flank: parameters u (n,), points (n, 2), outward unit normals (n, 2)."""
    u: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    profile: object = None

    def at(self, u):
        """Points and normals at arbitrary parameters (exact on the profile, else interpolated)."""
        u = np.asarray(u, float)
        if self.profile is not None:
            return self.profile.eval(u), self.profile.outward_normal(u)
        p = np.stack([np.interp(u, self.u, self.points[:, k]) for k in (0, 1)], -1)
        n = np.stack([np.interp(u, self.u, self.normals[:, k]) for k in (0, 1)], -1)
        return p, n / np.linalg.norm(n, axis=-1, keepdims=True)


def flank_samples(surface, flank_range, n=500):
    """n equally spaced profile parameters over flank_range = (u_start, u_end) of ``surface``
    (a :class:`helical_surface.HelicalSurface`; only its profile is used)."""
    u0, u1 = (float(x) for x in flank_range)
    if not (u1 > u0 and n >= 2):
        raise ValueError(f"flank range must satisfy u_start < u_end and n >= 2, got ({u0}, {u1}), n = {n}")
    u = np.linspace(u0, u1, int(n))
    prof = surface.profile
    return FlankSamples(u, prof.eval(u), prof.outward_normal(u), prof)


# ============================================================================ per-pose deviation
def _layout(tool):
    return tuple(type(p) for p in tool.parts)


def pose_deviations(tools, points, normals, v0, handedness, search, tol=1e-12):
    """(K, N) deviation of each of N profile points (z = 0) under each of K tools *alone*.

    Same definition as :func:`sweep.machined_deviation` (root of D(p + lambda n) along the
    outward normal; + material left, - overcut, +inf: no machined surface within ``search``),
    evaluated for all (tool, point) pairs together: tools of one part layout are stacked and every
    pair is a row of one sphere-tracing / Illinois pass."""
    points = np.asarray(points, float)
    normals = np.asarray(normals, float)
    K, N = len(tools), len(points)
    out = np.full((K, N), np.inf)
    groups = {}
    for k, t in enumerate(tools):
        groups.setdefault(_layout(t), []).append(k)
    p1 = np.c_[points, np.zeros(N)]
    n1 = np.c_[normals, np.zeros(N)]
    for ks in groups.values():
        if len(ks) == 1 or not StackedTools.compatible([tools[k] for k in ks]):
            for k in ks:      # RevolvingTool.rows() is the tool itself
                out[k] = _row_roots(tools[k], np.zeros(N, int), p1, n1, v0, handedness, search, tol)
            continue
        stack = StackedTools([tools[k] for k in ks])
        which = np.repeat(np.arange(len(ks)), N)
        p = np.tile(p1, (len(ks), 1))
        n = np.tile(n1, (len(ks), 1))
        out[ks] = _row_roots(stack, which, p, n, v0, handedness, search, tol).reshape(len(ks), N)
    return out


def _row_roots(stack, which, p, n, v0, hand, search, tol):
    """Root of D_k(p + lambda n) per row (tool k = which[row]); the scheme of machined_deviation."""
    R = len(p)
    scale = float(np.max(np.abs(p)))
    cutoff = search + 1e-6 * scale
    eps = 1e-9 * scale

    def D(lam, idx, bound):
        res = np.empty(len(idx))
        for s in range(0, len(idx), _ROW_CHUNK):
            j = idx[s:s + _ROW_CHUNK]
            q = p[j] + lam[s:s + _ROW_CHUNK, None] * n[j]
            res[s:s + _ROW_CHUNK] = helical_distance(stack.rows(which[j]), q, v0, hand,
                                                     cutoff=np.broadcast_to(bound, (len(idx),))[s:s + _ROW_CHUNK])[0]
        return res

    allr = np.arange(R)
    d0 = D(np.zeros(R), allr, cutoff)
    lo, f_lo = np.zeros(R), d0.copy()
    hi, f_hi = lo.copy(), d0.copy()
    direction = np.where(d0 >= 0, 1.0, -1.0)
    # D is 1-Lipschitz along the ray: a tool farther than the search range never forms the surface in it
    active = (d0 != 0) & (d0 < cutoff)
    for _ in range(400):
        idx = np.flatnonzero(active)
        if not len(idx):
            break
        lam = lo[idx] + direction[idx] * (np.abs(f_lo[idx]) + eps)
        out = np.abs(lam) > search
        lam = np.clip(lam, -search, search)
        f_new = D(lam, idx, np.minimum(np.abs(f_lo[idx]) + np.abs(lam - lo[idx]) + eps, cutoff))
        crossed = np.sign(f_new) != np.sign(f_lo[idx])
        hi[idx], f_hi[idx] = lam, f_new
        keep = ~crossed & ~out
        lo[idx[keep]], f_lo[idx[keep]] = lam[keep], f_new[keep]
        active[idx[crossed | out]] = False
    found = (np.sign(f_hi) != np.sign(f_lo)) | (f_lo == 0)
    root = illinois_roots(D, lo, hi, f_lo, f_hi, found, tol, eps, cutoff)
    # inside the swept region with no exit within the search range: an overcut deeper than it
    return np.where(found, root, np.where(d0 < 0, -np.inf, np.inf))


# ============================================================================ covered intervals
def index_runs(mask):
    """Inclusive (start, end) index runs where ``mask`` is true."""
    idx = np.flatnonzero(mask)
    if not len(idx):
        return []
    br = np.flatnonzero(np.diff(idx) > 1)
    return [(int(a), int(b)) for a, b in zip(np.r_[idx[0], idx[br + 1]], np.r_[idx[br], idx[-1]])]


def _end_param(u, dev, i_in, i_out, eps_under, eps_over):
    """Parameter where the deviation leaves the band between sample i_in (inside) and i_out
    (outside), linear interpolation; the inside sample itself if the outside one is not reached."""
    d_out = dev[i_out]
    if not np.isfinite(d_out):
        return float(u[i_in])
    bound = eps_under if d_out > eps_under else -eps_over
    g_in, g_out = dev[i_in] - bound, d_out - bound
    w = g_in / (g_in - g_out) if g_in != g_out else 0.0
    return float(u[i_in] + np.clip(w, 0.0, 1.0) * (u[i_out] - u[i_in]))


@dataclass
class PoseCoverage:
    """One pose on one flank.  ``intervals``: parameter ranges [a, b] where the deviation is inside
    [-eps_over, eps_under] (ends interpolated linearly between the last sample inside and the first
    outside); ``index_ranges``: the same as inclusive sample index runs; ``admissible``: nowhere on
    the flank an overcut beyond eps_over (``overcut_ranges``: sample runs where there is)."""
    deviation: np.ndarray
    intervals: list
    index_ranges: list
    overcut_ranges: list
    admissible: bool
    max_overcut: float


@dataclass
class Coverage:
    samples: FlankSamples
    eps_under: float
    eps_over: float
    poses: list            # PoseCoverage per input pose

    @property
    def deviation(self):
        """(K, n) deviations of all poses."""
        return np.array([c.deviation for c in self.poses]).reshape(len(self.poses), len(self.samples.u))


def coverage_of(deviation, u, eps_under, eps_over):
    """:class:`PoseCoverage` from one deviation curve sampled at parameters u."""
    dev = np.asarray(deviation, float)
    ok = (dev >= -eps_over) & (dev <= eps_under)
    runs = index_runs(ok)
    iv = []
    last = len(u) - 1
    for a, b in runs:
        ua = float(u[a]) if a == 0 else _end_param(u, dev, a, a - 1, eps_under, eps_over)
        ub = float(u[b]) if b == last else _end_param(u, dev, b, b + 1, eps_under, eps_over)
        iv.append((ua, ub))
    over = dev < -eps_over
    return PoseCoverage(deviation=dev, intervals=iv, index_ranges=runs, overcut_ranges=index_runs(over),
                        admissible=not over.any(), max_overcut=float(max(0.0, -dev.min())) if len(dev) else 0.0)


def covered_intervals(poses, surface, flank_range, eps_under, eps_over, n=500, search=None, samples=None,
                      with_shank=False, refine=True):
    """Rotor-to-envelope deviation of a flank's profile points under each pose, and where each
    pose mills the flank within [-eps_over, +eps_under].

    Args:
        poses: :class:`cone.ConePose` objects or flank-plan/1 strip dicts (any mix).
        surface: the rotor's :class:`HelicalSurface` (profile, v0, handedness).
        flank_range: (u_start, u_end) profile parameters of the flank.
        eps_under, eps_over: allowed material left / overcut (>= 0, plan length unit).
        n: flank samples (ignored when ``samples`` (:class:`FlankSamples`) is given).
        search: deviation search range (default 10 max(eps) + 1e-3 R); beyond it: +inf.
        with_shank: include the shank in the tool (the global test is :mod:`collision`).
        refine: interval ends where the deviation leaves the band between the samples (:func:`refine_ends`)
            instead of the linear interpolation of :func:`coverage_of`.
    Returns:
        :class:`Coverage` (``.poses[k]``: deviation (n,), intervals, index_ranges, admissible ...).
    """
    if not (eps_under >= 0 and eps_over >= 0):
        raise ValueError(f"eps_under = {eps_under}, eps_over = {eps_over} must be >= 0")
    fs = samples if samples is not None else flank_samples(surface, flank_range, n)
    if search is None:
        search = 10.0 * max(eps_under, eps_over) + 1e-3 * float(np.max(np.linalg.norm(fs.points, axis=1)))
    tools = [tool_of(p, with_shank) for p in poses]
    dev = pose_deviations(tools, fs.points, fs.normals, surface.v0, surface.handedness, search) if tools \
        else np.zeros((0, len(fs.u)))
    cov = [coverage_of(d, fs.u, eps_under, eps_over) for d in dev]
    if refine and cov:
        refine_ends(cov, tools, fs, surface, eps_under, eps_over, search)
    return Coverage(fs, float(eps_under), float(eps_over), cov)


def refine_ends(coverages, tools, fs, surface, eps_under, eps_over, search, iters=7):
    """Move every interval end of the :class:`PoseCoverage` s from the linear interpolation of
    :func:`coverage_of` to where the pose's deviation really leaves [-eps_over, eps_under] between the two
    samples (bisection on the deviation itself, all ends in one :func:`deviations_rows` pass per step), so
    a gap narrower than the sample spacing is real, not an artefact of the interpolation."""
    u = fs.u
    last = len(u) - 1
    ends = []                                  # (pose, interval, side, u_in, u_out)
    for k, pc in enumerate(coverages):
        for j, (a, b) in enumerate(pc.index_ranges):
            if a > 0:
                ends.append((k, j, 0, float(u[a]), float(u[a - 1])))
            if b < last:
                ends.append((k, j, 1, float(u[b]), float(u[b + 1])))
    if not ends:
        return
    which = np.array([e[0] for e in ends])
    lo = np.array([e[3] for e in ends])      # inside the band
    hi = np.array([e[4] for e in ends])      # outside
    for _ in range(int(iters)):
        mid = 0.5 * (lo + hi)
        p, n = fs.at(mid)
        d = deviations_rows(tools, which, p, n, surface.v0, surface.handedness, search)
        inside = (d >= -eps_over) & (d <= eps_under)
        lo = np.where(inside, mid, lo)
        hi = np.where(inside, hi, mid)
    for (k, j, side, _, _), x in zip(ends, lo):
        a, b = coverages[k].intervals[j]
        coverages[k].intervals[j] = (float(x), b) if side == 0 else (a, float(x))


# ============================================================================ interval cover
@dataclass
class IntervalCover:
    """``chosen``: indices into the input intervals, in order along [lo, hi]; ``gaps``: maximal
    open parameter ranges (a, b) of [lo, hi] that no interval covers; ``complete``: no gaps."""
    chosen: list
    gaps: list
    complete: bool


def minimum_interval_cover(intervals, lo, hi):
    """Fewest closed intervals covering [lo, hi] (greedy: sort by start; from the current reach,
    take the interval that starts at or before it and reaches furthest).  Greedy is optimal: any
    cover must contain an interval covering the current reach, and the furthest-reaching one leaves
    the shortest remainder.  Where nothing covers the reach, the gap up to the next start is recorded
    and the scan continues there, so ``chosen`` is also a minimum cover of [lo, hi] ∩ union of the
    intervals (each connected piece is covered independently).

    intervals: sequence of (a, b) with a <= b (others, and empty ones, are ignored)."""
    lo, hi = float(lo), float(hi)
    if not hi >= lo:
        raise ValueError(f"cover range must satisfy lo <= hi, got [{lo}, {hi}]")
    iv = [(float(a), float(b), k) for k, (a, b) in enumerate(intervals)
          if a <= b and b >= lo and a <= hi and math.isfinite(a) and math.isfinite(b)]
    iv.sort()
    chosen, gaps = [], []
    reach = lo
    covered_reach = False        # is the point ``reach`` itself covered by a chosen interval?
    j = 0
    best = None
    while True:
        # candidates: start <= reach
        while j < len(iv) and iv[j][0] <= reach:
            if best is None or iv[j][1] > best[1]:
                best = iv[j]
            j += 1
        if best is not None and (best[1] > reach or (not covered_reach and best[1] >= reach)):
            chosen.append(best[2])
            reach = best[1]
            covered_reach = True
            best = None
            if reach >= hi:
                break
            continue
        # no interval extends the cover beyond reach: a gap up to the next start
        if j >= len(iv):
            gaps.append((reach, hi))
            break
        gaps.append((reach, iv[j][0]))
        reach = iv[j][0]
        covered_reach = False
        best = None
    return IntervalCover(chosen=chosen, gaps=gaps, complete=not gaps)


def crossing_kinks(dev_a, dev_b, arc, lo=-math.inf, hi=math.inf):
    """Estimated kink angles (degrees) where two tools' deviation curves cross on the flank.

    dev_a, dev_b: (n,) deviations at the flank samples; arc: (n,) arc length of the samples along
    the profile; only crossings with both sample ends inside [lo, hi] (arc values) count.  The
    machined section near a sample is p + d n, so its direction turns by atan(d') from the
    profile's (d' = dd/ds, the normal's own turning is common to both curves and cancels): the
    section kink is |atan d_a' - atan d_b'| at the crossing.  Returns one angle per sign change
    of d_a - d_b (empty: the curves never cross there)."""
    da, db = np.asarray(dev_a, float), np.asarray(dev_b, float)
    with np.errstate(invalid="ignore"):
        g = da - db
        fin = np.isfinite(g) & (arc >= lo) & (arc <= hi)
        i = np.flatnonzero(fin[:-1] & fin[1:] & (np.sign(g[:-1]) * np.sign(g[1:]) < 0))
    if not len(i):
        return np.zeros(0)
    h = arc[i + 1] - arc[i]                                 # the crossing lies in [i, i + 1]
    sa, sb = (da[i + 1] - da[i]) / h, (db[i + 1] - db[i]) / h
    return np.degrees(np.abs(np.arctan(sa) - np.arctan(sb)))


@dataclass
class SmoothCover:
    """``chosen``: indices of the chosen poses in flank order; ``kinks``: estimated largest kink
    (degrees) per neighbouring pair (0 across a gap); ``cost``: sum of their squares; ``minimum``: the fewest poses
    any cover needs (the count of :func:`minimum_interval_cover`)."""
    chosen: list
    kinks: list
    cost: float
    minimum: int


def smooth_cover(coverage, samples, extra=2):
    """A cover of the whole flank by at most ``extra`` more poses than the minimum that makes the
    junctions as smooth as it can (Bizzarri, Bo & Bartoň §7 / Rajain et al. 2023's G1 goal as a selection problem).

    Every covered interval is a node; an edge a -> b joins intervals that overlap (b starts within
    a and reaches further) and costs the square of the largest estimated kink where the two poses'
    deviation curves cross (:func:`crossing_kinks`; an edge without a crossing is dropped: one of
    the two tools is deeper on the whole overlap, so it is not a junction).  Every chain from the
    flank start to its end is a cover (admissible poses only, see :func:`covered_intervals`), so
    a shortest path by count and cost (dynamic programme over (intervals used, node)) is the
    smoothest cover with that many strips; the cheapest over minimum .. minimum + extra strips is
    returned (fewer strips on ties).  Where no interval covers a part of the flank (a gap of
    :func:`minimum_interval_cover`), a chain may jump from an interval reaching the gap to one
    starting at its end at no cost, so the result covers what any cover can.  None when no chain
    exists (no admissible interval).

    coverage: :class:`PoseCoverage` list (deviations at ``samples``); samples: :class:`FlankSamples`."""
    u = np.asarray(samples.u, float)
    arc = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(samples.points, axis=0), axis=1))]
    u0, u1 = float(u[0]), float(u[-1])
    nodes = sorted((float(a), float(b), k) for k, pc in enumerate(coverage) if pc.admissible
                   for a, b in pc.intervals if b > a)
    if not nodes:
        return None
    cover = minimum_interval_cover([(a, b) for a, b, _ in nodes], u0, u1)
    n_min = len(cover.chosen)
    N = len(nodes)
    tiny = 1e-12 * max(1.0, abs(u1 - u0))
    gaps = list(cover.gaps)
    lo = gaps.pop(0)[1] if gaps and gaps[0][0] <= u0 + tiny else u0
    hi = gaps.pop()[0] if gaps and gaps[-1][1] >= u1 - tiny else u1
    s_of = np.interp                                          # parameter -> arc length
    edges = [[] for _ in range(N)]
    for i, (ai, bi, ki) in enumerate(nodes):
        for j, (aj, bj, kj) in enumerate(nodes):
            if kj == ki or not (aj <= bi + tiny and bj > bi + tiny and aj > ai - tiny):
                continue
            k = crossing_kinks(coverage[ki].deviation, coverage[kj].deviation, arc,
                               s_of(min(ai, aj), u, arc), s_of(max(bi, bj), u, arc))
            if len(k):
                edges[i].append((j, float(k.max())))
        for g0, g1 in gaps:                                   # jump a gap nothing covers
            if g0 - tiny <= bi <= g0 + tiny:
                edges[i] += [(j, 0.0) for j, (aj, bj, _) in enumerate(nodes)
                             if g1 - tiny <= aj <= g1 + tiny and bj > g1]
    C = n_min + int(extra)
    cost = np.full((C + 1, N), np.inf)
    prev = np.full((C + 1, N), -1)
    worst = np.zeros((C + 1, N))
    for i, (a, _, _) in enumerate(nodes):
        if a <= lo + tiny:
            cost[1, i] = 0.0
    for c in range(1, C):
        for i in np.flatnonzero(np.isfinite(cost[c])):
            for j, kink in edges[i]:
                v = cost[c, i] + kink * kink
                if v < cost[c + 1, j]:
                    cost[c + 1, j], prev[c + 1, j] = v, i
                    worst[c + 1, j] = kink
    ends = [i for i, (_, b, _) in enumerate(nodes) if b >= hi - tiny]
    best = None
    for c in range(1, C + 1):
        for i in ends:
            if np.isfinite(cost[c, i]) and (best is None or cost[c, i] < best[0] * (1 - 1e-9)):
                best = (cost[c, i], c, i)
    if best is None:
        return None
    v, c, i = best
    path = [i]
    while c > 1:
        i = prev[c, i]
        c -= 1
        path.append(int(i))
    path.reverse()
    chosen = [nodes[i][2] for i in path]
    kinks = [min(k for j, k in edges[a] if j == b) for a, b in zip(path, path[1:])]
    return SmoothCover(chosen=chosen, kinks=kinks, cost=float(v), minimum=n_min)


# ============================================================================ adaptive seeding
@dataclass
class AdaptiveCover:
    """Result of :func:`adaptive_cover`.

    poses / intervals: the chosen poses and their covered parameter intervals;
    gaps: parameter ranges no admissible candidate covers (interval model);
    deviation: the machined deviation of the chosen poses together at the flank samples (the minimum
    of their own deviations: exact for the union of the swept regions); uncovered: parameter ranges
    of the samples outside [-eps_over, eps_under] there (the sample-level answer, no interpolation); rounds: per round the seeds tried,
    candidates returned, admissible ones and the gaps left; chosen_coverage: the
    :class:`PoseCoverage` of each chosen pose (its deviation curve at ``samples``: pass them to
    :func:`junction_kinks_chain` instead of sampling the chosen tools again)."""
    poses: list
    intervals: list
    gaps: list
    deviation: np.ndarray
    uncovered: list
    samples: FlankSamples
    candidates: list = field(default_factory=list)
    coverage: list = field(default_factory=list)
    rounds: list = field(default_factory=list)
    chosen_coverage: list = field(default_factory=list)     # PoseCoverage of each chosen pose (as ``poses``)

    @property
    def complete(self):
        return not self.gaps and not self.uncovered


def _param_ranges(u, runs):
    return [(float(u[a]), float(u[b])) for a, b in runs]


def _overlaps(a, b, c, d):
    return min(b, d) > max(a, c)


def gap_seeds(gaps, width, tried, tries_of, spacing, max_per_gap=24, gap_tries=3):
    """Seeds for the gaps of a cover (Bizzarri, Bo & Bartoň §6.1: insert samples where the flank is not yet
    covered).  A gap (a, b) seen for the first time gets ceil((b - a) / (0.8 w)) seeds, w = ``width(a, b)``
    (how long a covered interval of this tool is next to the gap), a gap that overlaps one seeded k times
    before 2^k times as many (at most ``max_per_gap``), spread over its length; after ``gap_tries`` tries a
    gap is given up.  Seeds closer than ``spacing`` to one tried before (``tried``, sorted array) are
    dropped.  Returns (seeds, tries per gap)."""
    out, tries = [], []
    for a, b in gaps:
        k = tries_of(a, b)
        tries.append(k)
        if k >= gap_tries or b <= a:
            continue
        m = int(min(max_per_gap, max(1, math.ceil((b - a) / (0.8 * width(a, b)))) * 2 ** k))
        for x in a + (b - a) * (np.arange(m) + 0.5) / m:
            if not len(tried) or np.min(np.abs(tried - x)) >= spacing:
                out.append(float(x))
    return out, tries


def adaptive_cover(make_candidates, surface, flank_range, eps_under, eps_over, seeds=None, n_seeds=5,
                   max_rounds=6, n=500, search=None, with_shank=False, targets=None, samples=None,
                   max_seeds=None, gap_tries=3, on_round=None):
    """Cover a flank with candidate poses, seeding new candidates where it is not yet covered
    (Bizzarri, Bo & Bartoň §6.1: start coarse, insert samples where the flank is not covered).

    make_candidates(param_values) -> poses: a callback (e.g. the single-flank optimiser) that turns
    profile parameters of the flank into candidate poses (any number; None entries are skipped).
    Round 1 uses ``seeds`` (default: ``n_seeds`` parameters spread over the targets); every further
    round seeds the gaps of the minimum cover (:func:`gap_seeds`: as many as the typical covered width of
    the tool says the gap needs, twice as many each time a gap stays) until the cover is complete, no gap
    gets a new seed, ``max_rounds`` rounds or ``max_seeds`` seeds are spent, or the first round (or two
    rounds running) gave no admissible candidate.  ``targets``: the parameter
    ranges to cover (default the whole flank; e.g. what a larger tool left); each is covered by its own
    minimum cover (:func:`minimum_interval_cover`).  The chosen poses are then simulated together and what
    stays outside the tolerance band is reported as parameter ranges (whole flank).  ``on_round(record)``
    is called after every round."""
    fs = samples if samples is not None else flank_samples(surface, flank_range, n)
    u0, u1 = float(fs.u[0]), float(fs.u[-1])
    targets = [(u0, u1)] if targets is None else [(max(u0, float(a)), min(u1, float(b))) for a, b in targets]
    targets = [(a, b) for a, b in targets if b > a]
    total = sum(b - a for a, b in targets)
    if seeds is None:
        seeds = []
        for a, b in targets:
            m = max(1, int(round(n_seeds * (b - a) / total))) if total > 0 else 1
            seeds += list(a + (b - a) * (np.arange(m) + 0.5) / m)
    spacing = 0.5 * (u1 - u0) / max(1, len(fs.u) - 1)
    cands, cov = [], []
    rounds = []
    seeds = [float(x) for x in seeds]
    tried = np.zeros(0)
    gap_history = []                  # (a, b, tries) of the gaps seeded so far

    def tries_of(a, b):
        k = [t + 1 for (c, d, t) in gap_history if _overlaps(a, b, c, d)]
        return max(k) if k else 0

    chosen_k, gaps = [], list(targets)
    for r in range(max(1, int(max_rounds))):
        if not seeds:
            break
        tried = np.sort(np.r_[tried, seeds])
        new = [p for p in make_candidates(np.asarray(seeds, float)) if p is not None]
        c = covered_intervals(new, surface, flank_range, eps_under, eps_over, search=search, samples=fs,
                              with_shank=with_shank) if new else None
        cands += new
        if c is not None:
            cov += c.poses
        flat = [(iv, k) for k, pc in enumerate(cov) if pc.admissible for iv in pc.intervals]
        chosen_k, gaps = [], []
        for a, b in targets:
            cover = minimum_interval_cover([iv for iv, _ in flat], a, b)
            for i in cover.chosen:
                if flat[i][1] not in chosen_k:
                    chosen_k.append(flat[i][1])
            gaps += list(cover.gaps)
        rec = {"round": r + 1, "seeds": [float(x) for x in seeds], "candidates": len(new),
               "admissible": sum(pc.admissible for pc in (c.poses if c else [])),
               "gaps": [tuple(g) for g in gaps]}
        rounds.append(rec)
        if on_round is not None:
            on_round(rec)
        if not gaps or r + 1 >= max_rounds or (max_seeds is not None and len(tried) >= max_seeds):
            break
        # no admissible candidate from the first round, or from two rounds running: denser seeds of the
        # same tool will not do better
        if rec["admissible"] == 0 and (r == 0 or rounds[-2]["admissible"] == 0):
            break
        ivs = [iv for iv, _ in flat if iv[1] > iv[0]]
        typical = float(np.median([b - a for a, b in ivs])) if ivs else None

        def width(a, b, ivs=ivs, typical=typical):
            # the strips that end at the gap's start or begin at its end: how wide this tool mills there
            near = [d - c for c, d in ivs if abs(d - a) <= spacing or abs(c - b) <= spacing]
            w = min(near) if near else (typical if typical is not None else 0.5 * (b - a))
            return max(w, 2.0 * spacing)

        seeds, tries = gap_seeds(gaps, width, tried, tries_of, spacing, gap_tries=gap_tries)
        gap_history += [(a, b, t) for (a, b), t in zip(gaps, tries)]
        if max_seeds is not None:
            seeds = seeds[:max(0, int(max_seeds) - len(tried))]
    poses = [cands[k] for k in chosen_k]
    # union of swept regions: along each normal ray the first crossing of the union is the first
    # crossing of one of the tools, so the machined deviation is the minimum of the tools' own
    dev = np.min([cov[k].deviation for k in chosen_k], axis=0) if chosen_k else np.full(len(fs.u), np.inf)
    bad = ~((dev >= -eps_over) & (dev <= eps_under))
    return AdaptiveCover(poses=poses, intervals=[cov[k].intervals for k in chosen_k], gaps=list(gaps),
                         deviation=dev, uncovered=_param_ranges(fs.u, index_runs(bad)), samples=fs,
                         candidates=cands, coverage=cov, rounds=rounds, chosen_coverage=[cov[k] for k in chosen_k])


# ============================================================================ junction kinks
def _grad_sd(tool, q, h):
    """Central-difference gradient of the tool's signed distance at points q (N, 3)."""
    g = np.empty_like(q)
    for k in range(3):
        e = np.zeros(3)
        e[k] = h
        g[:, k] = (tool.signed_distance(q + e) - tool.signed_distance(q - e)) / (2 * h)
    return g


def envelope_normals(tool, x, v0, handedness, cutoff=None):
    """Unit normals (N, 3) of the tool's envelope at points x (N, 3) on (or next to) it:
    R(t*)^T grad sd_tool(S_t*(x)), pointing away from the swept region (into the material)."""
    x = np.atleast_2d(np.asarray(x, float))
    scale = max(float(np.max(np.abs(x))), float(np.max(np.abs(tool.bound_centres)) + tool.bound_radii.max()))
    cutoff = 1e-3 * scale if cutoff is None else cutoff
    _, t = helical_distance(tool, x, v0, handedness, cutoff=cutoff)
    if np.isnan(t).any():
        raise ValueError("envelope_normals: a point is farther than the cutoff from the envelope")
    q = screw_motion(x, t, v0, handedness)
    g = _grad_sd(tool, q, 1e-6 * scale)
    N = screw_motion(g, -t, 0.0, handedness)          # rotation part only: R(t*)^T g
    return N / np.linalg.norm(N, axis=1, keepdims=True)


@dataclass
class Junction:
    """A switch of the machined surface between two envelopes on the flank profile.

    u: profile parameter; point: machined point (3,) in z = 0 (on both envelopes);
    deviation: its deviation from the design profile; kink_deg: angle between the envelopes' normals
    (3D); section_kink_deg: angle between the envelopes' sections in z = 0; normals: (2, 3)."""
    u: float
    point: np.ndarray
    deviation: float
    kink_deg: float
    section_kink_deg: float
    normals: np.ndarray


def deviations_rows(tools, which, points, normals, v0, handedness, search, tol=1e-12):
    """Deviation (R,) of profile point ``points[r]`` (z = 0, outward normal ``normals[r]``) under tool
    ``tools[which[r]]`` alone, for R rows at once (same definition and root finding as
    :func:`pose_deviations`, which evaluates every tool at every point): rows of tools with one part
    layout share a :class:`sweep.StackedTools` pass."""
    which = np.asarray(which, int)
    points = np.asarray(points, float)
    normals = np.asarray(normals, float)
    R = len(which)
    out = np.full(R, np.inf)
    p1 = np.c_[points, np.zeros(R)]
    n1 = np.c_[normals, np.zeros(R)]
    groups = {}
    for k in np.unique(which):
        groups.setdefault(_layout(tools[k]), []).append(int(k))
    for ks in groups.values():
        rows = np.flatnonzero(np.isin(which, ks))
        if len(ks) == 1 or not StackedTools.compatible([tools[k] for k in ks]):
            for k in ks:
                rk = rows[which[rows] == k]
                out[rk] = _row_roots(tools[k], np.zeros(len(rk), int), p1[rk], n1[rk], v0, handedness, search, tol)
            continue
        local = {k: j for j, k in enumerate(ks)}
        stack = StackedTools([tools[k] for k in ks])
        wl = np.array([local[int(k)] for k in which[rows]])
        out[rows] = _row_roots(stack, wl, p1[rows], n1[rows], v0, handedness, search, tol)
    return out


def junction_kinks(strip_a, strip_b, surface, flank_range=None, n=500, search=None, samples=None, u_tol=None,
                   deviations=None):
    """Kink angles where the envelopes of two poses (ConePose or strip dicts) meet on a flank.

    The deviation curves d_a(u), d_b(u) of the two tools alone are sampled on the flank; every sign
    change of d_a - d_b (both finite) is refined by regula falsi (Illinois) in u to ``u_tol``
    (default 1e-9 of the flank length); there x = p(u) + d n(u) lies on both envelopes and the kink
    is the angle between the envelope normals (:func:`envelope_normals`).  Returns a list of
    :class:`Junction` (empty: the envelopes never switch, e.g. disjoint or one always deeper).

    ``deviations``: optional (2, n) deviations of the two tools at ``samples`` already computed (e.g.
    ``PoseCoverage.deviation`` of the cover stage, :attr:`AdaptiveCover.chosen_coverage`), which skips
    sampling them again; values beyond the search range the caller used are +inf there, so crossings
    farther than it from the flank are not found (those are no machined junctions of a cover within
    tolerance).  See :func:`junction_kinks_chain` for all neighbouring pairs of a strip list at once."""
    devs = None if deviations is None else np.asarray(deviations, float)
    return junction_kinks_chain([strip_a, strip_b], surface, flank_range, n=n, search=search, samples=samples,
                                u_tol=u_tol, deviations=devs)[0]


def junction_kinks_chain(strips, surface, flank_range=None, n=500, search=None, samples=None, u_tol=None,
                         deviations=None):
    """:func:`junction_kinks` of every neighbouring pair (strips[k], strips[k + 1]) of a strip list,
    refined together (each regula-falsi iteration evaluates the deviations of all open brackets of all
    pairs in one sphere-tracing pass).  ``deviations``: optional (K, n) deviations of the K strips at
    ``samples`` (see :func:`junction_kinks`).  Returns one :class:`Junction` list per pair (K - 1)."""
    fs = samples if samples is not None else flank_samples(surface, flank_range, n)
    v0, hand = surface.v0, surface.handedness
    scale = float(np.max(np.linalg.norm(fs.points, axis=1)))
    if search is None:
        search = 0.05 * scale
    K = len(strips)
    if K < 2:
        return []
    tools = [tool_of(s) for s in strips]
    if deviations is None:
        dev = pose_deviations(tools, fs.points, fs.normals, v0, hand, search)
    else:
        dev = np.asarray(deviations, float)
        if dev.shape != (K, len(fs.u)):
            raise ValueError(f"deviations must have shape ({K}, {len(fs.u)}) (strips x flank samples), "
                             f"got {dev.shape}")
    u_tol = 1e-9 * abs(fs.u[-1] - fs.u[0]) if u_tol is None else u_tol
    # brackets of sign changes of d_a - d_b over all pairs
    P, I, EX = [], [], []
    for k in range(K - 1):
        fin = np.isfinite(dev[k]) & np.isfinite(dev[k + 1])
        with np.errstate(invalid="ignore"):
            g = np.where(fin, dev[k] - dev[k + 1], 0.0)
        s = np.sign(g)
        i = np.flatnonzero(fin[:-1] & fin[1:] & (s[:-1] * s[1:] < 0))
        P.append(np.full(len(i), k))
        I.append(i)
        EX.append(np.flatnonzero(fin & (g == 0)))
    pair = np.concatenate(P).astype(int)
    i = np.concatenate(I).astype(int)
    with np.errstate(invalid="ignore"):
        gfull = dev[pair] - dev[pair + 1] if len(pair) else np.zeros((0, len(fs.u)))

    def gap(u, pr):
        p, nn = fs.at(u)
        m = len(u)
        d = deviations_rows(tools, np.r_[pr, pr + 1], np.r_[p, p], np.r_[nn, nn], v0, hand, search).reshape(2, m)
        return d[0] - d[1], d

    a, b = fs.u[i].copy(), fs.u[i + 1].copy()
    ga, gb = gfull[np.arange(len(i)), i].copy(), gfull[np.arange(len(i)), i + 1].copy()
    side = np.zeros(len(i))
    for _ in range(80):
        act = np.flatnonzero(np.abs(b - a) > u_tol)
        if not len(act):
            break
        m = false_position(a[act], b[act], ga[act], gb[act])
        gm, _ = gap(m, pair[act])
        bad = ~np.isfinite(gm)
        gm = np.where(bad, 0.0, gm)
        a[act], ga[act], b[act], gb[act], side[act] = illinois_update(a[act], ga[act], b[act], gb[act], m, gm,
                                                                      side[act])
        if bad.any():
            a[act[bad]] = b[act[bad]]
    uj = np.concatenate([np.where(np.abs(gb) <= np.abs(ga), b, a)] + [fs.u[e] for e in EX])
    pj = np.concatenate([pair] + [np.full(len(e), k) for k, e in enumerate(EX)]).astype(int)
    out = [[] for _ in range(K - 1)]
    if not len(uj):
        return out
    order = np.lexsort((uj, pj))
    uj, pj = uj[order], pj[order]
    p, nn = fs.at(uj)
    gj, d = gap(uj, pj)
    # a sign change across a jump of one curve (an envelope ending) is no junction: both envelopes
    # must pass through the same machined point
    keep = np.isfinite(gj) & (np.abs(gj) <= 1e-7 * scale)
    uj, pj, p, nn, d = uj[keep], pj[keep], p[keep], nn[keep], d[:, keep]
    if not len(uj):
        return out
    dj = 0.5 * (d[0] + d[1])
    x = np.c_[p + dj[:, None] * nn, np.zeros(len(uj))]
    Na, Nb = np.empty_like(x), np.empty_like(x)
    for k in np.unique(np.r_[pj, pj + 1]):
        ra, rb = np.flatnonzero(pj == k), np.flatnonzero(pj + 1 == k)
        rows = np.r_[ra, rb]
        Nk = envelope_normals(tools[k], x[rows], v0, hand)
        Na[ra], Nb[rb] = Nk[:len(ra)], Nk[len(ra):]
    kink = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", Na, Nb), -1.0, 1.0)))
    pa = Na[:, :2] / np.linalg.norm(Na[:, :2], axis=1, keepdims=True)
    pb = Nb[:, :2] / np.linalg.norm(Nb[:, :2], axis=1, keepdims=True)
    sk = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", pa, pb), -1.0, 1.0)))
    for r in range(len(uj)):
        out[pj[r]].append(Junction(u=float(uj[r]), point=x[r], deviation=float(dj[r]), kink_deg=float(kink[r]),
                                   section_kink_deg=float(sk[r]), normals=np.stack([Na[r], Nb[r]])))
    return out
