"""Hu, Zhou & Li 2025: axial profile of a formed disc cutter for a helical surface, with machinability flags.

Frames and conventions
----------------------
Rotor frame: the helical axis is z through the origin; the surface is the union over t of
S_t(profile) with the screw motion of :mod:`.screw` (hand ``eps = +1`` right, ``-1`` left,
``v0 = lead / (2 pi)``).  Internally the profile is first turned about z by ``-phase`` so that the
tooth being cut faces +x (the *working frame*, Hu, Zhou & Li 2025 Fig. 2); every pose returned is converted back
to the caller's rotor frame.

Cutter frame (Hu, Zhou & Li 2025 §2.2, Eq. 2): origin ``O`` on the cutter axis at the foot of the common
perpendicular with the rotor axis, ``e_x`` from the rotor axis towards the cutter axis, ``e_z``
along the cutter axis, ``e_y = e_z x e_x``.  In the working frame

    O = (A, 0, 0),  e_x = (1, 0, 0),  e_y = (0, cos phi, eps sin phi),  e_z = (0, -eps sin phi, cos phi)

so a rotor point (x, y, z) has  X_u = x - A,  Y_u = y cos phi + eps z sin phi,
Z_u = -eps y sin phi + z cos phi.  The sign of the swivel is tied to the hand so that a positive
swivel turns the disc plane towards the helix: the disc is tangent to the helices of radius
``v0 / tan(phi)``.  The cutter meridian is ``R(Z)``: the cutter is the solid
``{Z_u in [Z_0, Z_1], sqrt(X_u^2 + Y_u^2) <= R(Z_u)}``.  Lengths are in the profile's unit.

Numerical method (Hu, Zhou & Li 2025 §2.3-2.6)
--------------------------------
Planes Gamma_m: Z_u = const.  In a plane, each line Y_u = const (parallel to X_u) is followed from the
cutter axis towards the rotor; its first crossing with the rotor section at the line's height z is the
point of the helical surface nearest the axis on that line (Eqs. 3-4).  The section at height z is
the profile turned by eps z / v0 (Eq. 1), so the crossing is a line-curve intersection in the profile
plane: cubic spline pieces by safeguarded Newton (§2.5, threshold ``eps_a``), exact circular arcs in
closed form (the "S3" variant of §3.1).  The radius ``R_u`` of the plane is the minimum over Y_u of
the distance sqrt(X_u^2 + Y_u^2) (Eqs. 5-6), found by the subdivision search of §2.4 (grid of
``n_init`` sections, then the three best neighbours are halved until their spacing is <= ``eps_b``).
The Y_u search range of a plane is Eq. (15) made per plane: sqrt(L(0)^2 - (A - r_0)^2), where L(0) is
the distance found on the line Y_u = 0 and r_0 the rotor's outer radius; no point beyond it can be
nearer.  The Z_u range is §2.6 (Eqs. 12-14): where the helices of the tooth's two end points cross
the cutter's axial plane Y_u = 0.

Unlike the paper, which intersects only the tooth curve, every line is intersected with the whole
rotor section (all teeth and the blank cylinder), and the radius of a plane is the minimum of

* the subdivision search, started from *every* local minimum of the plane's initial grid (the four
  lowest), not only from the lowest sample, so a second minimum is refined too (Fig. 10e,f); and
* the exact distances of the section's *corners* (tangent discontinuities, e.g. the groove edges of
  the arc tooth, plus the tooth's end points): each corner's helix is crossed with the plane at all
  its crossings (:func:`_helix_crossings`).  Where the nearest material of a plane is a corner, the
  first-crossing distance L(Y_u) has a kink there (found only to ~ slope x eps_b) or a jump (lines just
  beside an edge miss the groove behind it and hit deep), which the grid does not see at all: at
  swivel 50 deg on the Table-1 tooth the search alone came out up to 2.1 mm too large and the swept
  cutter cut 0.44 mm into the groove.

The nearest material of a plane is either such a corner or a smooth boundary point where L(Y_u) has a
smooth local minimum (a silhouette end of a visible branch is never a minimum: L falls into the
branch).  So R(Z_u) <= the true minimum distance to all rotor material in the plane, to the search
accuracy ~ L'' eps_b^2 / 8 of smooth minima, provided every smooth minimum's visible branch is wider
than the grid spacing 2 Yb / n_init (tested against an independent brute force of all helix-plane
crossings, tests/test_formed_cutter.py).  A disc of each plane therefore does not enter the rotor,
and by the screw invariance of the rotor neither does the swept cutter: no overcut, only uncut
regions.  This holds at the planes computed; a caller interpolating R between planes (e.g. the
piecewise-linear :class:`sweep.MeridianPart`) adds its own chord error R'' dZ^2 / 8 where R(Z) is
convex -- largest at the ends of the range, where the radius falls steeply (Table 1, 2000 planes:
1.4 um in radius at the two tooth edges).  The tooth-only radius (the paper's) is computed too, for
the overcut check below.

Contact-equation method (classical, for comparison): for each profile point solve
N . ((P - O) x e_z) = 0 for the screw angle (the surface normal meets the cutter axis), see
:func:`contact_equation_profile`.
"""
from dataclasses import dataclass, field
import math

import numpy as np
from scipy.interpolate import CubicSpline

from ...geometry.angles import atan2
from ...geometry.profile import Arc, Line, SegmentProfile, SplineProfile
from ...geometry.screw import hand_name, hand_sign

__all__ = ["FormedCutterError", "Section", "CutterSetup", "CutterProfile", "FLAG_NAMES",
           "section_from_profile", "arc_tooth_profile", "arc_tooth_section", "default_tooth",
           "cutter_profile", "cutter_meridian", "contact_equation_profile", "table2", "format_table2",
           "PAPER_TABLE2", "TABLE1"]


class FormedCutterError(ValueError):
    """Invalid cutter set-up or profile; the message names the value and the limit."""


# per-plane flags (bit mask), Hu, Zhou & Li 2025 §4
FLAG_SELF_OCCLUSION = 1   # a line of the plane meets the tooth again behind material (Fig. 10c,d)
FLAG_MAXIMUM_POINT = 2    # the distance curve has two separated minima with a maximum between (Fig. 10e,f)
FLAG_OFF_TOOTH = 4        # the nearest material of the plane is not on the tooth (blank, other teeth)
FLAG_CONTACT_JUMP = 8     # the contact point jumps along the tooth between this plane and the next
FLAG_OVERCUT = 16         # a cutter following the tooth alone would enter other material here
FLAG_NAMES = {FLAG_SELF_OCCLUSION: "self_occlusion", FLAG_MAXIMUM_POINT: "maximum_point",
              FLAG_OFF_TOOTH: "off_tooth", FLAG_CONTACT_JUMP: "contact_jump", FLAG_OVERCUT: "overcut"}

# Hu, Zhou & Li 2025 Table 1 (arc tooth) and Table 2 (maximum deviation in micrometres)
TABLE1 = dict(R1=55.1, R2=111.69, G=125.0, lead=450.0, teeth=4, swivel_deg=31.0, centre_distance=200.0)
PAPER_TABLE2 = {
    "eps_b": (0.8, 0.4, 0.1, 0.04, 0.01),
    "S1": (0.7741, 0.1896, 0.0652, 0.0558, 0.0558),
    "S2": (0.7737, 0.1943, 0.0131, 0.0031, 0.0016),
    "S3": (0.8212, 0.1934, 0.0130, 0.0026, 0.0004),
}


def _rot(xy, a):
    c, s = np.cos(a), np.sin(a)
    x, y = xy[..., 0], xy[..., 1]
    return np.stack([c * x - s * y, s * x + c * y], axis=-1)


# --------------------------------------------------------------------------- rotor section

@dataclass
class Section:
    """Closed rotor section as pieces that a straight line can be intersected with exactly.

    ``cubic_*``: cubic pieces p(x) = c0 x^3 + c1 x^2 + c2 x + c3, 0 <= x <= h (spline spans, lines);
    ``arc_*``: exact circular arcs (centre, radius, start angle, signed sweep).  Each piece carries
    the profile parameter of its start (``*_u0``; pieces are parametrised by arc length or by the
    spline's own parameter) and whether it belongs to the tooth being cut (``*_target``).
    The section is counter-clockwise with the rotor on its left (as :mod:`.profile`).
    """
    cubic_c: np.ndarray        # (P, 4, 2)
    cubic_h: np.ndarray        # (P,)
    cubic_u0: np.ndarray       # (P,)
    cubic_target: np.ndarray   # (P,) bool
    arc_c: np.ndarray          # (Q, 2)
    arc_r: np.ndarray          # (Q,)
    arc_a0: np.ndarray         # (Q,)
    arc_sweep: np.ndarray      # (Q,)
    arc_u0: np.ndarray         # (Q,)
    arc_target: np.ndarray     # (Q,) bool
    period: float = float("nan")

    @staticmethod
    def empty():
        z = np.zeros(0)
        return Section(np.zeros((0, 4, 2)), z, z, z.astype(bool), np.zeros((0, 2)), z, z, z, z, z.astype(bool))

    def __add__(self, other):
        cat = np.concatenate
        return Section(cat([self.cubic_c, other.cubic_c]), cat([self.cubic_h, other.cubic_h]),
                       cat([self.cubic_u0, other.cubic_u0]), cat([self.cubic_target, other.cubic_target]),
                       cat([self.arc_c, other.arc_c]), cat([self.arc_r, other.arc_r]),
                       cat([self.arc_a0, other.arc_a0]), cat([self.arc_sweep, other.arc_sweep]),
                       cat([self.arc_u0, other.arc_u0]), cat([self.arc_target, other.arc_target]),
                       self.period if math.isfinite(self.period) else other.period)

    def rotated(self, angle):
        """The section turned by ``angle`` about the origin (all cubic coefficients are vectors)."""
        from dataclasses import fields
        out = Section(**{f.name: np.array(getattr(self, f.name), copy=True)
                         if isinstance(getattr(self, f.name), np.ndarray) else getattr(self, f.name)
                         for f in fields(self)})
        out.cubic_c = _rot(self.cubic_c, angle)
        out.arc_c = _rot(self.arc_c, angle)
        out.arc_a0 = self.arc_a0 + angle
        return out

    def sample(self, n_per_piece=16, target=None):
        """Points on the pieces (optionally only tooth / non-tooth pieces) -> (K, 2)."""
        x = np.linspace(0.0, 1.0, n_per_piece)
        out = []
        m = np.ones(len(self.cubic_h), bool) if target is None else self.cubic_target == target
        if m.any():
            xx = x[None, :] * self.cubic_h[m, None]
            c = self.cubic_c[m]
            p = ((c[:, None, 0] * xx[..., None] + c[:, None, 1]) * xx[..., None] + c[:, None, 2]) * xx[..., None] \
                + c[:, None, 3]
            out.append(p.reshape(-1, 2))
        m = np.ones(len(self.arc_r), bool) if target is None else self.arc_target == target
        if m.any():
            a = self.arc_a0[m, None] + x[None, :] * self.arc_sweep[m, None]
            p = self.arc_c[m, None, :] + self.arc_r[m, None, None] * np.stack([np.cos(a), np.sin(a)], -1)
            out.append(p.reshape(-1, 2))
        return np.vstack(out) if out else np.zeros((0, 2))

    def outer_radius(self):
        """Upper bound of the distance of the section from the origin (exact for arcs, dense for cubics)."""
        r = float(np.max(np.linalg.norm(self.sample(64), axis=1)))
        if len(self.arc_r):  # an arc may bulge beyond its samples: add the exact farthest point if inside the arc
            d = np.linalg.norm(self.arc_c, axis=1)
            r = max(r, float(np.max(np.where(self._arc_contains(atan2(self.arc_c[:, 1], self.arc_c[:, 0]))
                                             | (d == 0), d + self.arc_r, 0.0))))
        return r * (1 + 1e-9)

    def _cubic_ends(self):
        """Distinct end points of the cubic pieces and each piece's start / end index into them
        (neighbouring spline spans share a knot, so the sign test evaluates it once)."""
        key = (id(self.cubic_c), len(self.cubic_c))
        cached = getattr(self, "_ends_cache", None)
        if cached is not None and cached[0] == key:
            return cached[1]
        c, h = self.cubic_c, self.cubic_h
        p_start = c[:, 3]
        p_end = ((c[:, 0] * h[:, None] + c[:, 1]) * h[:, None] + c[:, 2]) * h[:, None] + c[:, 3]
        P = len(h)
        i0 = np.arange(P)
        i1 = np.arange(P) + P
        # an end that is the next piece's start (to rounding) reuses it: one sign per shared knot
        nxt = np.r_[np.arange(1, P), 0]
        tol = 1e-12 * max(1.0, float(np.abs(p_start).max()))
        same = np.all(np.abs(p_end - p_start[nxt]) <= tol, axis=1)
        i1[same] = nxt[same]
        used = np.unique(np.r_[i0, i1])
        allp = np.vstack([p_start, p_end])
        remap = np.full(2 * P, -1)
        remap[used] = np.arange(len(used))
        res = (allp[used], remap[i0], remap[i1])
        self._ends_cache = (key, res)
        return res

    def _cubic_blocks(self, size=None):
        """Spans grouped in blocks of ``size`` consecutive pieces with a bounding circle each.

        Returns (ends, i0, i1, centres (B, 2), radii (B,), pieces (B, size) with -1 padding).  The
        circle encloses dense samples of its spans with a 2 % + chord/8 margin, far more than a
        cubic span bulges between samples 1/32 of its length apart."""
        if size is None:   # ~ sqrt(spans / crossings per line) balances block tests and span tests
            size = int(min(128, max(16, np.sqrt(len(self.cubic_h) / 3.0))))
        cached = getattr(self, "_block_cache", None)
        if cached is not None and cached[0] == (id(self.cubic_c), size):
            return cached[1]
        ends, i0, i1 = self._cubic_ends()
        P = len(self.cubic_h)
        nb = (P + size - 1) // size
        pieces = np.full((nb, size), -1)
        flat = np.arange(P)
        pieces.reshape(-1)[:P] = flat
        x = np.linspace(0.0, 1.0, 33)
        xx = x[None, :] * self.cubic_h[:, None]
        c = self.cubic_c
        pts = ((c[:, None, 0] * xx[..., None] + c[:, None, 1]) * xx[..., None] + c[:, None, 2]) * xx[..., None] \
            + c[:, None, 3]                                                  # (P, 33, 2)
        pad = np.full((nb * size - P, 33, 2), np.nan)
        blk = np.concatenate([pts, pad]).reshape(nb, size * 33, 2)
        lo, hi = np.nanmin(blk, axis=1), np.nanmax(blk, axis=1)
        centres = 0.5 * (lo + hi)
        rad = np.nanmax(np.linalg.norm(blk - centres[:, None, :], axis=2), axis=1)
        chord = np.nanmax(np.linalg.norm(np.diff(blk, axis=1), axis=2), axis=1)
        rad = rad * 1.02 + chord / 8 + 1e-12 * max(1.0, float(np.nanmax(np.abs(blk))))
        res = (ends, i0, i1, centres, rad, pieces)
        self._block_cache = ((id(self.cubic_c), size), res)
        return res

    def corners(self, angle_tol=1e-7):
        """Points where the section's tangent turns abruptly (or a piece end is unmatched) -> (pts (K, 2),
        u (K,), target (K,)).

        A corner belongs to two pieces; it is a tooth point if either is a tooth piece, and its
        parameter is then taken on the tooth side.  Smooth joins (spline knots, tangent arcs) are
        not corners.  The first-crossing distance of a plane is discontinuous or kinked at the lines
        through a corner's helix, so the subdivision search cannot locate a minimum there to better
        than its spacing (or at all, Hu, Zhou & Li 2025 §2.4): :func:`cutter_profile` adds the corners exactly."""
        cached = getattr(self, "_corner_cache", None)
        key = (id(self.cubic_c), id(self.arc_c), len(self.cubic_h), len(self.arc_r))
        if cached is not None and cached[0] == key:
            return cached[1]
        c, h = self.cubic_c, self.cubic_h
        p0 = [c[:, 3]]
        t0 = [c[:, 2]]
        p1 = [((c[:, 0] * h[:, None] + c[:, 1]) * h[:, None] + c[:, 2]) * h[:, None] + c[:, 3]]
        t1 = [(3 * c[:, 0] * h[:, None] + 2 * c[:, 1]) * h[:, None] + c[:, 2]]
        u0 = [self.cubic_u0]
        u1 = [self.cubic_u0 + h]
        tg = [self.cubic_target]
        if len(self.arc_r):
            a0, a1, sg = self.arc_a0, self.arc_a0 + self.arc_sweep, np.sign(self.arc_sweep)
            rr = self.arc_r[:, None]
            p0.append(self.arc_c + rr * np.stack([np.cos(a0), np.sin(a0)], -1))
            p1.append(self.arc_c + rr * np.stack([np.cos(a1), np.sin(a1)], -1))
            t0.append(sg[:, None] * np.stack([-np.sin(a0), np.cos(a0)], -1))
            t1.append(sg[:, None] * np.stack([-np.sin(a1), np.cos(a1)], -1))
            u0.append(self.arc_u0)
            u1.append(self.arc_u0 + np.abs(self.arc_sweep) * self.arc_r)
            tg.append(self.arc_target)
        p0, p1, t0, t1 = (np.concatenate(x) for x in (p0, p1, t0, t1))
        u0, u1, tg = np.concatenate(u0), np.concatenate(u1), np.concatenate(tg)
        if len(p0) == 0:
            res = (np.zeros((0, 2)), np.zeros(0), np.zeros(0, bool))
            self._corner_cache = (key, res)
            return res
        from scipy.spatial import cKDTree
        scale = max(1.0, float(np.abs(np.r_[p0.ravel(), p1.ravel()]).max()))
        tol = 1e-9 * scale
        unit = lambda v: v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-300)  # noqa: E731
        t0, t1 = unit(t0), unit(t1)
        dist, j = cKDTree(p0).query(p1)               # the piece starting where piece i ends
        matched = dist <= tol
        cosang = np.einsum("ij,ij->i", t1, t0[j])
        turn = ~matched | (cosang < math.cos(angle_tol))
        nxt_tooth = matched & tg[j]                   # the corner's other piece is a tooth piece
        i = np.flatnonzero(turn)
        pts, us, tgt = [p1[i]], [np.where(~tg[i] & nxt_tooth[i], u0[j[i]], u1[i])], [tg[i] | nxt_tooth[i]]
        # piece starts that no piece ends at
        dist2, _ = cKDTree(p1).query(p0)
        free = dist2 > tol
        pts.append(p0[free])
        us.append(u0[free])
        tgt.append(tg[free])
        res = (np.concatenate(pts), np.concatenate(us), np.concatenate(tgt))
        self._corner_cache = (key, res)
        return res

    def _arc_contains(self, ang, idx=None):
        a0 = self.arc_a0 if idx is None else self.arc_a0[idx]
        sw = self.arc_sweep if idx is None else self.arc_sweep[idx]
        rel = np.mod((ang - a0) * np.sign(sw), 2 * np.pi)
        tol = 1e-12
        return (rel <= np.abs(sw) + tol) | (rel >= 2 * np.pi - tol)

    def _arc_rel(self, ang, idx):
        sw = self.arc_sweep[idx]
        rel = np.mod((ang - self.arc_a0[idx]) * np.sign(sw) + 1e-12, 2 * np.pi) - 1e-12
        return rel

    # ---------------------------------------------------------------- line intersection (Hu, Zhou & Li 2025 §2.5)

    def crossings(self, q, d, eps_a=1e-10, s_min=None, chunk=1 << 20):
        """All crossings of lines q + s d (unit d) with the section, with s >= s_min (per line).

        Returns a dict of flat arrays over crossings: ``line`` (index into q), ``s`` (line
        parameter), ``u`` (profile parameter), ``target`` (on the tooth), ``entering`` (moving
        along -d the line enters the rotor there).  Cubic pieces: blocks of spans whose bounding
        circle the line misses (or that lie wholly below s_min) are skipped; in the others a sign
        change of the signed distance at a span's ends marks a crossing, refined by Newton safeguarded
        by bisection until |dx| < eps_a (Hu, Zhou & Li 2025 §2.5; a line touching a span twice without a sign change
        is a tangency and is ignored).  Arcs: the quadratic in closed form.
        """
        q = np.asarray(q, float)
        d = np.asarray(d, float)
        nrm = np.stack([-d[:, 1], d[:, 0]], -1)
        s_min = np.full(len(q), -np.inf) if s_min is None else np.broadcast_to(np.asarray(s_min, float), (len(q),))
        out = {k: [] for k in ("line", "s", "u", "target", "entering")}
        P = len(self.cubic_h)
        if P:
            c = self.cubic_c
            h = self.cubic_h
            ends, i0, i1, bc, br, bpieces = self._cubic_blocks()
            step = max(1, chunk // max(1, len(bc)))
            for s0 in range(0, len(q), step):
                sl = slice(s0, s0 + step)
                rel = bc[None, :, :] - q[sl, None, :]                       # (l, B, 2)
                near = (np.abs(np.einsum("lbk,lk->lb", rel, nrm[sl])) <= br[None, :]) & \
                       (np.einsum("lbk,lk->lb", rel, d[sl]) + br[None, :] >= s_min[sl, None])
                lb, bb = np.nonzero(near)
                if len(lb) == 0:
                    continue
                lg = lb + s0
                pcs = bpieces[bb]                                            # (pairs, K), -1 = padding
                valid = pcs >= 0
                pcs_c = np.where(valid, pcs, 0)
                off = np.einsum("ij,ij->i", nrm[lg], q[lg])
                g0 = np.einsum("pkj,pj->pk", ends[i0[pcs_c]], nrm[lg]) - off[:, None]
                g1 = np.einsum("pkj,pj->pk", ends[i1[pcs_c]], nrm[lg]) - off[:, None]
                pp, kk = np.nonzero(valid & ((g0 > 0) != (g1 > 0)))
                if len(pp) == 0:
                    continue
                li_g = lg[pp]
                pi = pcs[pp, kk]
                x = self._newton(c[pi], h[pi], nrm[li_g], q[li_g], g0[pp, kk], g1[pp, kk], eps_a)
                cc = c[pi]
                pt = ((cc[:, 0] * x[:, None] + cc[:, 1]) * x[:, None] + cc[:, 2]) * x[:, None] + cc[:, 3]
                tg = (3 * cc[:, 0] * x[:, None] + 2 * cc[:, 1]) * x[:, None] + cc[:, 2]
                dd = d[li_g]
                sv = np.einsum("ij,ij->i", pt - q[li_g], dd)
                keep = sv >= s_min[li_g]
                out["line"].append(li_g[keep])
                out["s"].append(sv[keep])
                out["u"].append((self.cubic_u0[pi] + x)[keep])
                out["target"].append(self.cubic_target[pi][keep])
                out["entering"].append((dd[:, 0] * tg[:, 1] - dd[:, 1] * tg[:, 0] > 0)[keep])
        Q = len(self.arc_r)
        if Q:
            w = q[:, None, :] - self.arc_c[None, :, :]                      # (L, Q, 2)
            b = np.einsum("lqk,lk->lq", w, d)
            cq = np.einsum("lqk,lqk->lq", w, w) - self.arc_r[None, :] ** 2
            disc = b * b - cq
            for sgn in (-1.0, 1.0):
                with np.errstate(invalid="ignore"):
                    s = -b + sgn * np.sqrt(disc)
                li, ai = np.nonzero((disc > 0) & (s >= s_min[:, None]))
                s = s[li, ai]
                pt = q[li] + s[:, None] * d[li]
                ang = np.arctan2(pt[:, 1] - self.arc_c[ai, 1], pt[:, 0] - self.arc_c[ai, 0])
                rel = self._arc_rel(ang, ai)
                ok = rel <= np.abs(self.arc_sweep[ai]) + 1e-12
                li, ai, s, ang, rel = li[ok], ai[ok], s[ok], ang[ok], rel[ok]
                sg = np.sign(self.arc_sweep[ai])
                tg = sg[:, None] * np.stack([-np.sin(ang), np.cos(ang)], -1)
                dd = d[li]
                out["line"].append(li)
                out["s"].append(s)
                out["u"].append(self.arc_u0[ai] + rel * self.arc_r[ai])
                out["target"].append(self.arc_target[ai])
                out["entering"].append(dd[:, 0] * tg[:, 1] - dd[:, 1] * tg[:, 0] > 0)
        if not out["line"]:
            return {"line": np.zeros(0, int), "s": np.zeros(0), "u": np.zeros(0),
                    "target": np.zeros(0, bool), "entering": np.zeros(0, bool)}
        return {k: np.concatenate(v) for k, v in out.items()}

    @staticmethod
    def _newton(c, h, nrm, q, g0, g1, eps_a, max_iter=60):
        """Root of nrm . (p(x) - q) on [0, h] with a sign change; Newton kept inside a shrinking bracket."""
        a3 = np.einsum("ij,ij->i", c[:, 0], nrm)
        a2 = np.einsum("ij,ij->i", c[:, 1], nrm)
        a1 = np.einsum("ij,ij->i", c[:, 2], nrm)
        a0 = np.einsum("ij,ij->i", c[:, 3] - q, nrm)
        lo = np.zeros_like(h)
        hi = h.copy()
        neg_at_lo = g0 <= 0
        with np.errstate(divide="ignore", invalid="ignore"):
            x = h * g0 / (g0 - g1)                  # regula falsi start
        x = np.where(np.isfinite(x), np.clip(x, 0, h), 0.5 * h)
        idx = np.arange(len(h))                     # still iterating (compacted each step)
        for _ in range(max_iter):
            xi, a3i, a2i, a1i = x[idx], a3[idx], a2[idx], a1[idx]
            f = ((a3i * xi + a2i) * xi + a1i) * xi + a0[idx]
            fp = (3 * a3i * xi + 2 * a2i) * xi + a1i
            below = (f <= 0) == neg_at_lo[idx]      # the root lies above x
            loi = np.where(below, xi, lo[idx])
            hii = np.where(below, hi[idx], xi)
            lo[idx], hi[idx] = loi, hii
            with np.errstate(divide="ignore", invalid="ignore"):
                xn = xi - f / fp
            bad = ~np.isfinite(xn) | (xn <= loi) | (xn >= hii)
            xn = np.where(bad, 0.5 * (loi + hii), xn)
            x[idx] = xn
            idx = idx[np.abs(xn - xi) >= eps_a]
            if len(idx) == 0:
                break
        return x


def section_from_profile(profile, tooth=None):
    """:class:`Section` of a closed :class:`SplineProfile` or :class:`SegmentProfile`.

    ``tooth = (u_start, u_end)``: profile-parameter range of the tooth to cut (wrapping through 0 if
    u_start > u_end); pieces whose middle lies in it are flagged as tooth pieces (give the range at
    knots / segment breaks, e.g. from :func:`default_tooth`).  ``None``: the whole profile.
    """
    period = float(profile.period)

    def in_tooth(um):
        if tooth is None:
            return np.ones(len(um), bool)
        a, b = float(tooth[0]) % period, float(tooth[1]) % period
        if b == 0 and tooth[1] > 0:
            b = period
        um = np.mod(um, period)
        return (um >= a) & (um <= b) if a < b else (um >= a) | (um <= b)

    if isinstance(profile, SplineProfile):
        sp = profile._spline
        c = np.moveaxis(np.asarray(sp.c), 0, 1)                 # (n, 4, 2)
        kn = profile.knots
        h = np.diff(kn)
        sec = Section.empty()
        sec.cubic_c, sec.cubic_h, sec.cubic_u0 = c, h, kn[:-1]
        sec.cubic_target = in_tooth(kn[:-1] + 0.5 * h)
        sec.period = period
        return sec
    if isinstance(profile, SegmentProfile):
        cub, arcs = [], []
        for k, seg in enumerate(profile.segments):
            u0 = profile.breaks[k]
            if isinstance(seg, Line):
                cub.append((np.array([[0, 0], [0, 0], seg.dir, seg.p0], float), seg.length, u0))
            elif isinstance(seg, Arc):
                arcs.append((seg.c, seg.r, seg.a0, seg.sweep, u0))
            else:
                raise FormedCutterError(f"unsupported profile segment {type(seg).__name__}")
        sec = Section.empty()
        if cub:
            sec.cubic_c = np.array([x[0] for x in cub])
            sec.cubic_h = np.array([x[1] for x in cub])
            sec.cubic_u0 = np.array([x[2] for x in cub])
            sec.cubic_target = in_tooth(sec.cubic_u0 + 0.5 * sec.cubic_h)
        if arcs:
            sec.arc_c = np.array([x[0] for x in arcs])
            sec.arc_r = np.array([x[1] for x in arcs], float)
            sec.arc_a0 = np.array([x[2] for x in arcs], float)
            sec.arc_sweep = np.array([x[3] for x in arcs], float)
            sec.arc_u0 = np.array([x[4] for x in arcs], float)
            sec.arc_target = in_tooth(sec.arc_u0 + 0.5 * np.abs(sec.arc_sweep) * sec.arc_r)
        sec.period = period
        return sec
    raise FormedCutterError(f"profile must be a SplineProfile or SegmentProfile, got {type(profile).__name__}")


def default_tooth(profile, n=8192):
    """Tooth (valley between two lobe tips) whose bottom faces +x most closely -> (u_start, u_end).

    The valley bottom is the radius minimum nearest to polar angle 0; the tooth runs back and
    forward from it to the neighbouring radius maxima (plateaus such as a blank cylinder stop it),
    snapped to the profile's knots or segment breaks.
    """
    u = profile.params(n)
    p = profile.eval(u)
    r = np.linalg.norm(p, axis=1)
    lo = np.flatnonzero((r <= np.roll(r, 1)) & (r < np.roll(r, -1)))
    if len(lo) == 0:
        raise FormedCutterError("profile has no valley (radius minimum): nothing for a formed cutter to cut")
    ang = np.abs(atan2(p[lo, 1], p[lo, 0]))
    ib = lo[np.argmin(ang)]
    i0 = ib
    while r[(i0 - 1) % n] > r[i0 % n] and (ib - i0) < n:
        i0 -= 1
    i1 = ib
    while r[(i1 + 1) % n] > r[i1 % n] and (i1 - ib) < n:
        i1 += 1
    u0, u1 = u[i0 % n], u[i1 % n]
    grid = profile.knots if isinstance(profile, SplineProfile) else getattr(profile, "breaks", None)
    if grid is not None:
        u0 = float(grid[np.argmin(np.abs(grid - u0))])
        u1 = float(grid[np.argmin(np.abs(grid - u1))])
    return float(u0 % profile.period), float(u1 if u1 == profile.period else u1 % profile.period)


# --------------------------------------------------------------------------- the arc tooth (Hu, Zhou & Li 2025 §3.1)

def _arc_tooth_half_angle(R1, R2, G):
    c = (G * G + R1 * R1 - R2 * R2) / (2 * G * R1)
    if not (-1 < c < 1):
        raise FormedCutterError(f"arc tooth: circle R1 = {R1} about distance G = {G} does not cut the blank "
                                f"cylinder R2 = {R2} (need |G - R1| < R2 < G + R1)")
    return math.acos(c)


def arc_tooth_profile(R1=TABLE1["R1"], R2=TABLE1["R2"], G=TABLE1["G"], teeth=TABLE1["teeth"]):
    """Exact rotor of Hu, Zhou & Li 2025 §3.1 / Table 1: ``teeth`` grooves x = G - R1 cos t, y = R1 sin t (Eq. 16) cut
    into a blank cylinder of radius R2.  Returns ``(profile, tooth, t_e)``: a :class:`SegmentProfile`
    (groove arc of the tooth facing +x first, parameter = arc length, so t = u / R1 - t_e on it), the
    tooth range ``(0, 2 R1 t_e)`` and the half angle ``t_e`` of the groove arc.
    """
    t_e = _arc_tooth_half_angle(R1, R2, G)
    beta = math.atan2(R1 * math.sin(t_e), G - R1 * math.cos(t_e))
    gap = 2 * math.pi / teeth - 2 * beta
    if gap <= 0:
        raise FormedCutterError(f"arc tooth: {teeth} grooves of half width {math.degrees(beta):.4g} deg overlap")
    segs = []
    for k in range(teeth):
        a = 2 * math.pi * k / teeth
        segs.append(Arc((G * math.cos(a), G * math.sin(a)), R1, math.pi + t_e + a, -2 * t_e))
        segs.append(Arc((0.0, 0.0), R2, beta + a, gap))
    return SegmentProfile(segs), (0.0, 2 * R1 * t_e), t_e


def arc_tooth_section(scheme="S3", dt=None, R1=TABLE1["R1"], R2=TABLE1["R2"], G=TABLE1["G"],
                      teeth=TABLE1["teeth"]):
    """Section of the Table-1 rotor for the schemes of Hu, Zhou & Li 2025 §3.1.

    ``S3``: everything exact (line-circle intersection, no interpolation).  ``S1`` / ``S2``: the tooth
    is replaced by a cubic B-spline (multiple end knots, not-a-knot interpolation,
    same function as scipy's not-a-knot ``CubicSpline``) through points sampled at equal angle ``dt`` (0.01 / 0.002 rad by default)
    plus both end points; the rest of the rotor stays exact.  The spline is parametrised by chord
    length, which differs from the arc length u of the exact tooth by < 1e-5 relative.
    """
    prof, tooth, t_e = arc_tooth_profile(R1, R2, G, teeth)
    exact = section_from_profile(prof, tooth)
    if scheme == "S3":
        return exact
    if scheme not in ("S1", "S2"):
        raise FormedCutterError(f"scheme must be 'S1', 'S2' or 'S3', got {scheme!r}")
    dt = float(dt if dt is not None else (0.01 if scheme == "S1" else 0.002))
    t = np.arange(-t_e, t_e, dt)
    if t_e - t[-1] < 0.25 * dt:
        t = t[:-1]
    t = np.append(t, t_e)
    pts = np.c_[G - R1 * np.cos(t), R1 * np.sin(t)]
    chord = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    # the not-a-knot cubic B-spline interpolant with multiple end knots (make_interp_spline(k=3)) is the
    # same function as scipy's not-a-knot CubicSpline, which hands out the piece coefficients directly
    pp = CubicSpline(chord, pts)
    spl = Section.empty()
    spl.cubic_c = np.moveaxis(pp.c, 0, 1)
    spl.cubic_h = np.diff(pp.x)
    spl.cubic_u0 = pp.x[:-1]
    spl.cubic_target = np.ones(len(spl.cubic_h), bool)
    rest = Section(exact.cubic_c, exact.cubic_h, exact.cubic_u0, exact.cubic_target,
                   exact.arc_c[~exact.arc_target], exact.arc_r[~exact.arc_target],
                   exact.arc_a0[~exact.arc_target], exact.arc_sweep[~exact.arc_target],
                   exact.arc_u0[~exact.arc_target], exact.arc_target[~exact.arc_target], exact.period)
    return spl + rest


# --------------------------------------------------------------------------- set-up (Hu, Zhou & Li 2025 §2.2)

@dataclass
class CutterSetup:
    """Cutter pose relative to the rotor (Hu, Zhou & Li 2025 Eq. 2), see the module docstring for the frames.

    ``phase``: angle (rad) by which the caller's rotor frame is turned relative to the working frame
    (the tooth faces the direction ``phase``).  All public poses are in the caller's rotor frame.
    """
    centre_distance: float
    swivel: float           # radians
    lead: float
    handedness: str = "right"
    phase: float = 0.0

    @property
    def eps(self):
        return hand_sign(self.handedness)

    @property
    def v0(self):
        return self.lead / (2 * math.pi)

    def _frame_working(self):
        c, s, e = math.cos(self.swivel), math.sin(self.swivel), self.eps
        return (np.array([self.centre_distance, 0.0, 0.0]), np.array([1.0, 0.0, 0.0]),
                np.array([0.0, c, e * s]), np.array([0.0, -e * s, c]))

    def _to_rotor(self, v):
        cp, sp = math.cos(self.phase), math.sin(self.phase)
        v = np.asarray(v, float)
        return np.stack([cp * v[..., 0] - sp * v[..., 1], sp * v[..., 0] + cp * v[..., 1], v[..., 2]], -1)

    @property
    def axis_point(self):
        """Cutter frame origin O (Z_u = 0 on the cutter axis) in the rotor frame."""
        return self._to_rotor(self._frame_working()[0])

    @property
    def axis_direction(self):
        """Unit cutter axis e_z (direction of increasing Z_u) in the rotor frame."""
        return self._to_rotor(self._frame_working()[3])

    @property
    def cutter_to_rotor(self):
        """4x4 homogeneous matrix mapping cutter-frame points (X_u, Y_u, Z_u, 1) to the rotor frame."""
        o, ex, ey, ez = self._frame_working()
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = (self._to_rotor(v) for v in (ex, ey, ez, o))
        return m

    def to_cutter(self, pts):
        """Rotor-frame points (..., 3) -> cutter frame (X_u, Y_u, Z_u)."""
        m = self.cutter_to_rotor
        return (np.asarray(pts, float) - m[:3, 3]) @ m[:3, :3]


def _check_setup(setup, r_outer):
    A, phi, lead = setup.centre_distance, setup.swivel, setup.lead
    if not math.isfinite(lead) or lead <= 0:
        raise FormedCutterError(f"lead must be a positive finite number (use handedness for the hand), got {lead!r}")
    if not math.isfinite(phi) or not abs(phi) < math.pi / 2:
        raise FormedCutterError(f"swivel angle {math.degrees(phi) if math.isfinite(phi) else phi!r} deg must lie "
                                "strictly between -90 and 90 deg")
    if not math.isfinite(A) or not A > r_outer:
        raise FormedCutterError(f"centre distance A = {A!r} must exceed the rotor's outer radius {r_outer:.6g}: "
                                "otherwise the cutter axis passes through the rotor")
    if A > 100.0 * r_outer:
        # a disc cutter a hundred rotor radii across is no cutter (and its arithmetic overflows far beyond)
        raise FormedCutterError(f"centre distance A = {A!r} is over 100 times the rotor's outer radius "
                                f"{r_outer:.6g}")


# --------------------------------------------------------------------------- the numerical method

def _lines(setup, Y, Z):
    """Lines of the planes in the profile plane: q + s d with s = rotor x (working frame)."""
    c, s, e = math.cos(setup.swivel), math.sin(setup.swivel), setup.eps
    y = c * Y - e * s * Z
    z = e * s * Y + c * Z
    alpha = -e * z / setup.v0                 # turn the section at height z back into the profile plane
    ca, sa = np.cos(alpha), np.sin(alpha)
    q = np.stack([-sa * y, ca * y], -1)
    d = np.stack([ca, sa], -1)
    return q, d, y, z


def _first_hits(section, setup, Y, Z, eps_a, reach=None):
    """For lines (Y, Z) (same shape): distance to the first rotor crossing and to the first tooth crossing.

    Returns dict of arrays shaped like Y: L (all material), s, u, target (of the first crossing),
    Lt, st, ut (first tooth crossing, ignoring other material), hidden (a tooth crossing that
    enters the rotor behind material: its distance, inf if none).
    """
    shape = np.shape(Y)
    Yf, Zf = np.ravel(Y), np.ravel(Z)
    q, d, _, _ = _lines(setup, Yf, Zf)
    A = setup.centre_distance
    cr = section.crossings(q, d, eps_a, s_min=None if reach is None else A - reach)
    n = len(Yf)
    A = setup.centre_distance
    res = {"s": np.full(n, -np.inf), "u": np.full(n, np.nan), "target": np.zeros(n, bool),
           "st": np.full(n, -np.inf), "ut": np.full(n, np.nan), "hidden": np.full(n, np.inf)}
    if len(cr["line"]):
        order = np.lexsort((-cr["s"], cr["line"]))
        line, s, u, tg, ent = (cr[k][order] for k in ("line", "s", "u", "target", "entering"))
        first = np.r_[True, line[1:] != line[:-1]]
        res["s"][line[first]] = s[first]
        res["u"][line[first]] = u[first]
        res["target"][line[first]] = tg[first]
        # first tooth crossing per line (lines sorted by s descending within each line)
        tl = np.flatnonzero(tg)
        if len(tl):
            ft = tl[np.r_[True, line[tl][1:] != line[tl][:-1]]]
            res["st"][line[ft]] = s[ft]
            res["ut"][line[ft]] = u[ft]
        # tooth surface behind material: an entering tooth crossing that is not the first crossing
        hid = tg & ent & ~first
        if hid.any():
            dist = np.hypot(s[hid] - A, Yf[line[hid]])
            np.minimum.at(res["hidden"], line[hid], dist)
    res["L"] = np.hypot(res["s"] - A, Yf)
    res["Lt"] = np.hypot(res["st"] - A, Yf)
    return {k: v.reshape(shape) for k, v in res.items()}


def _subdivide(fun, Yb, eps_b, grid, Lg, start=None):
    """Subdivision search of Hu, Zhou & Li 2025 §2.4 for the minimum of fun(Y) per row on [-Yb, Yb].

    ``grid`` (M, n_init + 1): the initial equally spaced Y_u of each row, ``Lg`` the distances
    there; ``fun(Y)`` maps an (M, 2) array to distances.  Step (5)-(6): around the best sample (or
    the grid index ``start``) the two mid points are inserted, the best of the five is kept and its
    spacing halved, until the spacing is <= eps_b; the result is the best sample (step 7).
    Returns (Y*, L*).
    """
    M = len(Yb)
    n_init = grid.shape[1] - 1
    i = np.argmin(Lg, axis=1) if start is None else np.asarray(start)
    rows = np.arange(M)
    h = 2 * Yb / n_init
    b = grid[rows, i]
    Lb = Lg[rows, i]
    Lm = np.where(i > 0, Lg[rows, np.maximum(i - 1, 0)], np.inf)       # neighbours; outside the range: inf
    Lp = np.where(i < n_init, Lg[rows, np.minimum(i + 1, n_init)], np.inf)
    while True:
        active = h > eps_b
        if not active.any():
            break
        hh = 0.5 * h
        Y2 = np.stack([b - hh, b + hh], 1)
        L2 = fun(Y2)
        L2[:, 0] = np.where(b - hh >= -Yb, L2[:, 0], np.inf)     # stay inside the search range
        L2[:, 1] = np.where(b + hh <= Yb, L2[:, 1], np.inf)
        five_L = np.stack([Lm, L2[:, 0], Lb, L2[:, 1], Lp], 1)
        five_Y = np.stack([b - h, b - hh, b, b + hh, b + h], 1)
        k = np.argmin(five_L, axis=1)
        nb = five_Y[rows, k]
        nL = five_L[rows, k]
        nLm = np.where(k > 0, five_L[rows, np.maximum(k - 1, 0)], np.inf)
        nLp = np.where(k < 4, five_L[rows, np.minimum(k + 1, 4)], np.inf)
        b = np.where(active, nb, b)
        Lb = np.where(active, nL, Lb)
        Lm = np.where(active, nLm, Lm)
        Lp = np.where(active, nLp, Lp)
        h = np.where(active, hh, h)
    return b, Lb


def _search(fun, z, Yb, eps_b, grid, Lg, max_starts=4):
    """Minimum of fun(Y, Z) per plane: the subdivision search (:func:`_subdivide`) started from every
    local minimum of the plane's initial grid (the ``max_starts`` lowest), not only from the lowest
    sample: a second minimum whose grid samples are not the lowest (Fig. 10e,f) is refined too.
    Returns (Y*, L*) per plane."""
    M, n1 = Lg.shape
    v = np.where(np.isfinite(Lg), Lg, np.inf)
    inf = np.full((M, 1), np.inf)
    left, right = np.hstack([inf, v[:, :-1]]), np.hstack([v[:, 1:], inf])
    cand = np.isfinite(v) & (v < left) & (v <= right)
    cand[np.arange(M), np.argmin(v, axis=1)] = True
    key = np.where(cand, v, np.inf)
    order = np.argsort(key, axis=1, kind="stable")[:, :max_starts]
    ok = np.isfinite(np.take_along_axis(key, order, 1))
    ok[:, 0] = True
    pm, col = np.nonzero(ok)
    st = order[pm, col]
    zz = np.asarray(z, float)[pm][:, None]
    b, Lb = _subdivide(lambda Y: fun(Y, np.broadcast_to(zz, Y.shape)), Yb[pm], eps_b, grid[pm], Lg[pm], st)
    Lb = np.where(np.isfinite(Lb), Lb, np.inf)
    best = np.full(M, np.inf)
    np.minimum.at(best, pm, Lb)
    win = np.flatnonzero(Lb == best[pm])
    yb = np.zeros(M)
    yb[pm[win]] = b[win]
    return yb, np.where(np.isfinite(best), best, Lg[np.arange(M), np.argmin(v, axis=1)])


def _boundary_z(section_pts, setup):
    """Hu, Zhou & Li 2025 §2.6: Z_u where the helix of each point crosses the cutter's axial plane Y_u = 0,
    taking the crossing nearest the cutter (point turned towards +x)."""
    c, s, e, v0 = math.cos(setup.swivel), math.sin(setup.swivel), setup.eps, setup.v0
    out = []
    for p in section_pts:
        r = float(np.hypot(*p))
        a = math.atan2(p[1], p[0])
        th = np.linspace(-math.pi, math.pi, 4001) * e - a * e   # theta with the point turned within +-pi of +x

        def f(t):
            return c * r * np.sin(a + e * t) + e * s * v0 * t

        ft = f(th)
        idx = np.flatnonzero(np.sign(ft[:-1]) != np.sign(ft[1:]))
        if len(idx) == 0:
            raise FormedCutterError("tooth end point's helix does not cross the cutter's axial plane near the "
                                    "cutter: check the swivel angle")
        # the crossing whose point is nearest +x (largest x)
        xs = r * np.cos(a + e * th[idx])
        j = idx[np.argmax(xs)]
        t0, t1 = th[j], th[j + 1]
        for _ in range(80):
            tm = 0.5 * (t0 + t1)
            if np.sign(f(tm)) == np.sign(f(t0)):
                t0 = tm
            else:
                t1 = tm
        t = 0.5 * (t0 + t1)
        y = r * math.sin(a + e * t)
        out.append(-e * s * y + c * v0 * t)
    return np.array(out)


def _helix_crossings(pts, setup, z):
    """Every crossing of the helices of section points ``pts`` (K, 2, working frame, at rotor height 0)
    with the planes Z_u = z (M,); for each plane and point the crossing nearest the cutter axis.

    On the helix theta -> (r cos(a + e theta), r sin(a + e theta), v0 theta) the plane equation is
    g(theta) = c v0 theta - e s r sin(a + e theta) - Z_u = 0.  All roots lie within
    |theta - Z_u / (c v0)| <= |s| r / (c v0), and g is monotone between its critical points
    cos(a + e theta) = c v0 / (s r), known in closed form; so every root is bracketed and refined by
    bisection to rounding (a helix that only touches the plane is kept if g vanishes there to
    rounding).  Returns (L, x, Y), each (M, K): distance from the cutter axis, rotor x (working
    frame) and Y_u of that crossing (inf / nan where the helix misses the plane, i.e. never)."""
    pts = np.asarray(pts, float).reshape(-1, 2)
    z = np.asarray(z, float)
    M, K = len(z), len(pts)
    c, s, e, v0, A = math.cos(setup.swivel), math.sin(setup.swivel), setup.eps, setup.v0, setup.centre_distance
    if K == 0:
        return np.full((M, 0), np.inf), np.full((M, 0), np.nan), np.full((M, 0), np.nan)
    r = np.hypot(pts[:, 0], pts[:, 1])
    a = atan2(pts[:, 1], pts[:, 0])
    th0 = (z / (c * v0))[:, None]                                   # (M, 1)
    w = abs(s) * r / (c * v0)                                       # (K,)
    lo = np.broadcast_to(th0 - w, (M, K))
    hi = np.broadcast_to(th0 + w, (M, K))
    ends = [lo[..., None], hi[..., None]]
    sr = s * r
    with np.errstate(divide="ignore", invalid="ignore"):
        kappa = np.where(sr != 0, c * v0 / np.where(sr != 0, sr, 1.0), np.inf)
    bend = np.abs(kappa) < 1
    if bend.any():
        ac = np.arccos(np.clip(kappa, -1.0, 1.0))
        nk = int(math.ceil(float(w.max()) / math.pi)) + 1
        ks = np.arange(-nk, nk + 1)
        kc = np.round((a[None, :] + e * th0) / (2 * math.pi))            # (M, K): turn of the window centre
        for sg in (-1.0, 1.0):
            psi = sg * ac[None, :, None] + 2 * math.pi * (kc[..., None] + ks)   # (M, K, 2 nk + 1)
            T = e * (psi - a[None, :, None])
            T = np.where(bend[None, :, None], T, lo[..., None])
            ends.append(np.clip(T, lo[..., None], hi[..., None]))
    T = np.sort(np.concatenate(ends, -1), axis=-1)                   # (M, K, n) monotone pieces of g
    zz = z[:, None, None]
    rr, aa = r[None, :, None], a[None, :, None]

    def g(th, rr=rr, aa=aa, zz=zz):
        return c * v0 * th - e * s * rr * np.sin(aa + e * th) - zz

    gT = g(T)
    tol = 1e-13 * (A + float(r.max()) + float(np.abs(z).max()))
    ta, tb, ga, gb = T[..., :-1], T[..., 1:], gT[..., :-1], gT[..., 1:]
    root = ((ga < 0) != (gb < 0)) & (np.abs(ga) > tol) & (np.abs(gb) > tol)
    m_i, k_i, j_i = np.nonzero(root)
    a0, b0, f0 = ta[m_i, k_i, j_i], tb[m_i, k_i, j_i], ga[m_i, k_i, j_i]
    r1, a1, z1 = r[k_i], a[k_i], z[m_i]
    for _ in range(64):
        mid = 0.5 * (a0 + b0)
        fm = g(mid, r1, a1, z1)
        left = (fm < 0) == (f0 < 0)
        a0 = np.where(left, mid, a0)
        f0 = np.where(left, fm, f0)
        b0 = np.where(left, b0, mid)
        if not len(mid) or np.max(b0 - a0) <= 4e-16 * max(1.0, float(np.abs(mid).max())):
            break
    th_b = 0.5 * (a0 + b0)
    # exact (or grazing) zeros at the piece ends
    zero = np.abs(gT) <= tol
    m_z, k_z, j_z = np.nonzero(zero)
    th = np.r_[th_b, T[m_z, k_z, j_z]]
    mm, kk = np.r_[m_i, m_z], np.r_[k_i, k_z]
    psi = a[kk] + e * th
    x = r[kk] * np.cos(psi)
    Y = c * r[kk] * np.sin(psi) + e * s * v0 * th
    L = np.hypot(x - A, Y)
    out_L = np.full((M, K), np.inf)
    out_x = np.full((M, K), np.nan)
    out_Y = np.full((M, K), np.nan)
    if len(L):
        order = np.lexsort((L, kk, mm))
        mm, kk, L, x, Y = mm[order], kk[order], L[order], x[order], Y[order]
        first = np.r_[True, (mm[1:] != mm[:-1]) | (kk[1:] != kk[:-1])]
        out_L[mm[first], kk[first]] = L[first]
        out_x[mm[first], kk[first]] = x[first]
        out_Y[mm[first], kk[first]] = Y[first]
    return out_L, out_x, out_Y


def _corner_points(section):
    """Candidate points whose helices are intersected with the planes exactly: the section's corners
    and the tooth's two end points (edges of the tooth-only surface) -> (pts, u, target)."""
    pts, u, tg = section.corners()
    (u0, p0), (u1, p1) = _tooth_ends(section)
    return (np.vstack([pts, np.asarray(p0, float)[None], np.asarray(p1, float)[None]]),
            np.r_[u, u0, u1], np.r_[tg, True, True])


def _tooth_param_range(section):
    """(u_min, u_max) of the tooth pieces' parameters."""
    lo, hi = [], []
    if section.cubic_target.any():
        lo.append(section.cubic_u0[section.cubic_target].min())
        hi.append((section.cubic_u0 + section.cubic_h)[section.cubic_target].max())
    if section.arc_target.any():
        m = section.arc_target
        lo.append(section.arc_u0[m].min())
        hi.append((section.arc_u0 + np.abs(section.arc_sweep) * section.arc_r)[m].max())
    return float(min(lo)), float(max(hi))


def _tooth_ends(section):
    """End points of the tooth pieces (first point of the first, last point of the last by parameter)."""
    ends = []
    if section.cubic_target.any():
        i = np.flatnonzero(section.cubic_target)
        c, h, u0 = section.cubic_c[i], section.cubic_h[i], section.cubic_u0[i]
        k0, k1 = np.argmin(u0), np.argmax(u0 + h)
        x = h[k1]
        ends.append((u0[k0], c[k0, 3]))
        ends.append((u0[k1] + x, ((c[k1, 0] * x + c[k1, 1]) * x + c[k1, 2]) * x + c[k1, 3]))
    if section.arc_target.any():
        i = np.flatnonzero(section.arc_target)
        a0, sw, r, cc, u0 = (section.arc_a0[i], section.arc_sweep[i], section.arc_r[i], section.arc_c[i],
                             section.arc_u0[i])
        k0, k1 = np.argmin(u0), np.argmax(u0 + np.abs(sw) * r)
        ends.append((u0[k0], cc[k0] + r[k0] * np.array([np.cos(a0[k0]), np.sin(a0[k0])])))
        a1 = a0[k1] + sw[k1]
        ends.append((u0[k1] + abs(sw[k1]) * r[k1], cc[k1] + r[k1] * np.array([np.cos(a1), np.sin(a1)])))
    if not ends:
        raise FormedCutterError("the section has no tooth pieces: give a tooth range")
    ends.sort(key=lambda e: e[0])
    return ends[0], ends[-1]


@dataclass
class CutterProfile:
    """Result of :func:`cutter_profile` (Hu, Zhou & Li 2025 §2.3-2.6 and §4).  Per plane m (arrays of length M):

    ``z``, ``r``: the cutter meridian (Z_u, R_u), Z_u increasing, cutter frame, profile units.
    ``y``: Y_u of the contact point; ``contact``: contact point D* in the rotor frame (M, 3);
    ``contact_u``: its profile parameter; ``on_tooth``: D* lies on the tooth.
    ``r_tooth``: the paper's tooth-only radius (distance to the tooth surface alone, inf if the plane
    misses the tooth); ``overcut``: max(0, r_tooth - r), the depth by which a cutter following the tooth
    alone would enter other material.  ``flags``: bit mask (``FLAG_NAMES``).  ``uncut``: tooth parameter
    ranges never touched, as dicts (u_start, u_end, z_start, z_end, reason).
    """
    setup: CutterSetup
    z: np.ndarray
    r: np.ndarray
    y: np.ndarray
    contact: np.ndarray
    contact_u: np.ndarray
    on_tooth: np.ndarray
    r_tooth: np.ndarray
    overcut: np.ndarray
    flags: np.ndarray
    tooth: tuple
    uncut: list = field(default_factory=list)
    eps_b: float = float("nan")
    elapsed_s: float = float("nan")

    @property
    def meridian(self):
        """(M, 2) rows (Z_u, R_u): :class:`sweep.MeridianPart` input with origin ``setup.axis_point`` and
        direction ``setup.axis_direction``."""
        return np.c_[self.z, self.r]

    def flag_ranges(self):
        """Flagged planes merged into Z ranges: [{"flag": name, "z_min", "z_max", "planes": count}, ...]."""
        out = []
        for bit, name in FLAG_NAMES.items():
            m = (self.flags & bit) != 0
            if not m.any():
                continue
            idx = np.flatnonzero(m)
            runs = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
            for run in runs:
                out.append({"flag": name, "z_min": float(self.z[run[0]]), "z_max": float(self.z[run[-1]]),
                            "planes": int(len(run))})
        return out

    def summary(self):
        counts = {name: int(np.count_nonzero(self.flags & bit)) for bit, name in FLAG_NAMES.items()}
        return {"planes": int(len(self.z)), "z_range": [float(self.z[0]), float(self.z[-1])],
                "r_range": [float(self.r.min()), float(self.r.max())], "flag_counts": counts,
                "flag_ranges": self.flag_ranges(), "uncut": self.uncut,
                "max_overcut_tooth_only": float(np.max(self.overcut, initial=0.0)),
                "axis_point": self.setup.axis_point.tolist(), "axis_direction": self.setup.axis_direction.tolist(),
                "eps_b": self.eps_b, "elapsed_s": self.elapsed_s}


def _as_section(profile, tooth):
    if isinstance(profile, Section):
        return profile
    if tooth is None:
        tooth = default_tooth(profile)
    return section_from_profile(profile, tooth)


def cutter_profile(profile, lead, centre_distance, swivel_deg, handedness="right", tooth=None, planes=119,
                   z=None, eps_b=None, eps_a=None, n_init=64, phase=None, analyse=True):
    """Formed-cutter axial profile by the numerical method of Hu, Zhou & Li 2025 §2.3-2.6, with the §4 analysis.

    Args:
        profile: closed :class:`SplineProfile` / :class:`SegmentProfile` in the rotor frame, or a
            prepared :class:`Section` (e.g. :func:`arc_tooth_section`).
        lead: axial advance per turn (> 0); ``handedness`` 'right' / 'left'.
        centre_distance: A, distance between rotor and cutter axes (> the rotor's outer radius).
        swivel_deg: phi, angle between the axes in degrees (|phi| < 90).
        tooth: (u_start, u_end) tooth range for a profile (default :func:`default_tooth`).
        planes: number M of planes Z_u = const, equally spaced over the §2.6 range; or ``z``: explicit
            Z_u values (any order, returned sorted).
        eps_b: subdivision threshold (default 1e-4 x outer radius); eps_a: Newton threshold of the
            line-spline intersection (default 1e-12 x outer radius); n_init: initial sections per plane.
        phase: direction (rad) the tooth faces in the rotor frame (default: the direction of the mid
            point of the tooth's end points).
        analyse: run the tooth-only pass and the §4 flags (False: meridian only, faster).
    """
    import time
    t_start = time.perf_counter()
    section = _as_section(profile, tooth)
    tooth_range = tooth if tooth is not None else (None if isinstance(profile, Section) else default_tooth(profile))
    e0, e1 = _tooth_ends(section)
    if phase is None:
        mid = 0.5 * (np.asarray(e0[1]) + np.asarray(e1[1]))
        phase = math.atan2(mid[1], mid[0]) if np.hypot(*mid) > 0 else 0.0
    setup = CutterSetup(float(centre_distance), math.radians(float(swivel_deg)), float(lead),
                        hand_name(hand_sign(handedness)), float(phase))
    r0 = section.outer_radius()
    _check_setup(setup, r0)
    work = section.rotated(-setup.phase) if setup.phase else section
    scale = r0
    eps_b = 1e-4 * scale if eps_b is None else float(eps_b)
    eps_a = 1e-12 * scale if eps_a is None else float(eps_a)
    if not 0 < eps_b <= r0:
        raise FormedCutterError(f"eps_b = {eps_b!r} must be > 0 and at most the rotor's outer radius {r0:.6g} "
                                "(the radius search's subdivision threshold)")
    if int(n_init) < 4:
        raise FormedCutterError(f"n_init must be >= 4, got {n_init!r}")
    if z is None:
        if int(planes) < 2:
            raise FormedCutterError(f"planes must be >= 2, got {planes!r}")
        zb = _boundary_z([_rot(np.asarray(e0[1]), -setup.phase), _rot(np.asarray(e1[1]), -setup.phase)], setup)
        z = np.linspace(zb.min(), zb.max(), int(planes))
    else:
        z = np.sort(np.asarray(z, float).ravel())
        if len(z) == 0 or not np.isfinite(z).all():
            raise FormedCutterError("z: plane positions must be finite numbers")
    A = setup.centre_distance
    M = len(z)

    # per-plane Y_u range (Eq. 15, per plane): no point with |Y_u| > Yb is nearer than the line Y_u = 0
    h0 = _first_hits(work, setup, np.zeros(M), z, eps_a)
    L0 = h0["L"]
    ok0 = np.isfinite(L0)
    r_m = float(L0[ok0].max()) if ok0.any() else A + r0
    Lcap = np.where(ok0, L0, r_m)
    Yb = np.sqrt(np.maximum(Lcap ** 2 - (A - r0) ** 2, 0.0)) * (1 + 1e-9) + 1e-12 * scale
    # crossings farther than this from the cutter axis are never needed (the radius of every plane is
    # <= r_m; the tooth-only radius is reported as inf beyond it)
    reach = 1.5 * r_m

    Zcol = z[:, None]
    grid = np.linspace(-1.0, 1.0, int(n_init) + 1)[None, :] * Yb[:, None]
    G = _first_hits(work, setup, grid, np.broadcast_to(Zcol, grid.shape), eps_a, reach)
    yb, rb = _search(lambda Y, Zb: _first_hits(work, setup, Y, Zb, eps_a, reach)["L"], z, Yb, eps_b, grid, G["L"])
    if not np.isfinite(rb).all():
        bad = int(np.flatnonzero(~np.isfinite(rb))[0])
        raise FormedCutterError(f"plane Z_u = {z[bad]:.6g} does not meet the rotor within the search range: "
                                "the Z range lies beyond the rotor")
    hit = _first_hits(work, setup, yb, z, eps_a, reach)
    # the corners' helices, crossed with every plane exactly: the distance is kinked or jumps there
    cpts, cu, ctg = _corner_points(work)
    Lc, xc, Yc = _helix_crossings(cpts, setup, z)
    rows = np.arange(M)
    kc = np.argmin(Lc, axis=1)
    use = Lc[rows, kc] < rb
    if use.any():
        rb = np.where(use, Lc[rows, kc], rb)
        yb = np.where(use, Yc[rows, kc], yb)
        hit["s"] = np.where(use, xc[rows, kc], hit["s"])
        hit["u"] = np.where(use, cu[kc], hit["u"])
        hit["target"] = np.where(use, ctg[kc], hit["target"])
    _, yw, zw = _lines(setup, yb, z)[1:]
    xw = hit["s"]
    contact_w = np.c_[xw, yw, zw]
    contact = setup._to_rotor(contact_w)
    flags = np.zeros(M, np.int64)
    r_tooth = np.full(M, np.inf)
    uncut = []
    if analyse:
        r_corner_tooth = np.min(np.where(ctg[None, :], Lc, np.inf), axis=1, initial=np.inf)
        flags, r_tooth, uncut = _analyse(work, setup, z, rb, hit, grid, G, Yb, eps_b, eps_a, reach, r_corner_tooth)
    overcut = np.where(np.isfinite(r_tooth), np.maximum(r_tooth - rb, 0.0), 0.0)
    return CutterProfile(setup=setup, z=z, r=rb, y=yb, contact=contact, contact_u=hit["u"],
                         on_tooth=hit["target"], r_tooth=r_tooth, overcut=overcut, flags=flags,
                         tooth=tuple(tooth_range) if tooth_range is not None else None, uncut=uncut, eps_b=eps_b,
                         elapsed_s=time.perf_counter() - t_start)


def _local_minima(Lg, rel_tol):
    """Number of separated local minima of each row (finite part), separation: a bump > rel_tol."""
    M = Lg.shape[0]
    counts = np.zeros(M, int)
    for m in range(M):
        v = Lg[m]
        tol = rel_tol * max(1.0, float(np.abs(v).max()))
        # walk the sequence counting descents that follow a rise by more than tol
        n, low, rising, peak = 0, v[0], False, v[0]
        n = 1
        for x in v[1:]:
            if rising:
                if x > peak:
                    peak = x
                elif peak - x > tol and peak - low > tol:
                    n += 1
                    rising = False
                    low = x
            else:
                if x < low:
                    low = x
                elif x - low > tol:
                    rising = True
                    peak = x
        counts[m] = n
    return counts


def _analyse(work, setup, z, rb, hit, grid, full, Yb, eps_b, eps_a, reach, r_corner_tooth):
    """Machinability flags of Hu, Zhou & Li 2025 §4 per plane, and the uncut tooth ranges (``full``: the first-hit
    data on the initial grid of every plane; ``r_corner_tooth``: the nearest crossing of a tooth
    corner's or tooth end point's helix with each plane)."""
    M = len(z)
    flags = np.zeros(M, np.int64)
    # the paper's tooth-only radius, by the same subdivision
    r_tooth = np.full(M, np.inf)
    has = np.isfinite(full["Lt"]).any(axis=1)
    if has.any():
        _, rt = _search(lambda Y, Zb: _first_hits(work, setup, Y, Zb, eps_a, reach)["Lt"], z[has], Yb[has],
                        eps_b, grid[has], full["Lt"][has])
        r_tooth[has] = rt
    # the tooth-only distance is discontinuous next to the tooth's end edges, where its minimum often
    # lies: add the end points' (and the tooth's corners') own crossings with each plane exactly
    r_tooth = np.minimum(r_tooth, r_corner_tooth)
    # Fig. 10c,d: tooth surface hidden behind material within the cutter's largest radius
    r_max = float(rb.max())
    occl = np.any(full["hidden"] <= r_max, axis=1)
    flags[occl] |= FLAG_SELF_OCCLUSION
    # Fig. 10e,f: a maximum between two separated minima of the plane's distance curve
    Lc = full["L"]
    big = 10.0 * float(np.max(Lc[np.isfinite(Lc)], initial=1.0))
    nmin = _local_minima(np.where(np.isfinite(Lc), Lc, big), 1e-9)
    flags[nmin >= 2] |= FLAG_MAXIMUM_POINT
    flags[~hit["target"]] |= FLAG_OFF_TOOTH
    scale = work.outer_radius()
    over = np.isfinite(r_tooth) & (r_tooth - rb > 1e-9 * scale + 2 * eps_b ** 2 / scale)
    flags[over] |= FLAG_OVERCUT
    # contact jumps: the tooth parameter moves between neighbouring planes far more than typically
    uncut = []
    u = hit["u"]
    on = hit["target"]
    du = np.abs(np.diff(u))
    both = on[:-1] & on[1:]
    lo, hi = _tooth_param_range(work)
    if not on.any():
        uncut.append({"u_start": lo, "u_end": hi, "z_start": float("nan"), "z_end": float("nan"),
                      "reason": "no plane touches the tooth"})
    else:
        typical = float(np.median(du[both])) if both.sum() >= 3 else (hi - lo) / M
        typical = max(typical, 1e-12 * scale)
        jump = both & (du > 8 * typical)
        flags[:-1][jump] |= FLAG_CONTACT_JUMP
        flags[1:][jump] |= FLAG_CONTACT_JUMP
        # uncut tooth ranges: gaps in the set of contact parameters (ends of the tooth included)
        uo, zo = u[on], z[on]
        k = np.argsort(uo)
        uo, zo = uo[k], zo[k]
        edges_u = np.r_[lo, uo, hi]
        edges_z = np.r_[np.nan, zo, np.nan]
        gaps = np.flatnonzero(np.diff(edges_u) > 8 * typical)
        for g in gaps:
            uncut.append({"u_start": float(edges_u[g]), "u_end": float(edges_u[g + 1]),
                          "z_start": float(edges_z[g]), "z_end": float(edges_z[g + 1]),
                          "reason": "tooth end not reached" if g == 0 or g == len(edges_u) - 2
                          else "contact jumps over it"})
    return flags, r_tooth, uncut


def cutter_meridian(profile, lead, centre_distance, swivel_deg, planes=2000, **kw):
    """Dense cutter meridian for simulation -> (Z, R, setup): (Z_u, R_u) arrays of ``planes`` samples
    (Z increasing) and the :class:`CutterSetup` whose ``axis_point`` / ``axis_direction`` place it in
    the rotor frame.  Same arguments as :func:`cutter_profile` (no machinability pass).  R is exact
    (to eps_b) at the samples; linear interpolation between them overestimates by up to
    R'' dZ^2 / 8 where R(Z) is convex, mostly near the ends of the range (see the module docstring),
    so unless ``z`` is given the planes are cosine-spaced over the section 2.6 range: on the Table-1
    set-up that takes the swept tooth corners from -0.73 um (uniform, 2000 planes) to -0.012 um."""
    kw.setdefault("analyse", False)
    if kw.get("z") is None:
        ends = cutter_profile(profile, lead, centre_distance, swivel_deg, planes=2, **kw).z
        kw["z"] = ends[0] + (ends[-1] - ends[0]) * 0.5 * (1.0 - np.cos(np.linspace(0.0, np.pi, planes)))
    cp = cutter_profile(profile, lead, centre_distance, swivel_deg, planes=planes, **kw)
    return cp.z, cp.r, cp.setup


# --------------------------------------------------------------------------- contact-equation method

def contact_equation_profile(profile, setup, u, window=0.5 * math.pi, n_scan=721, tol=1e-14):
    """Classical envelope method: cutter profile from the contact equation (for comparison with Hu, Zhou & Li 2025).

    For each profile parameter ``u`` the screw angle theta of the contact is the root of

        f(theta) = N . ((P - O) x e_z),   P = S_theta(p(u)),  N = dP/du x dP/dtheta,

    i.e. the surface normal meets the cutter axis.  Roots are bracketed on a scan of
    ``theta_c +- window`` (theta_c turns the point towards the cutter) and refined by bisection to
    ``tol``; of several roots the one nearest the cutter origin O is taken (the classical method finds
    one local solution and cannot tell whether the cutter really touches there, see Hu, Zhou & Li 2025 §3.2).

    ``profile``: object with ``eval(u, der)`` in the rotor frame (exact SegmentProfile or a spline);
    ``setup``: :class:`CutterSetup` (its phase is honoured).  Returns (Z_u, R_u, theta, ok) arrays;
    ok = False where no root was bracketed (Z, R NaN).
    """
    u = np.atleast_1d(np.asarray(u, float))
    p = _rot(profile.eval(u), -setup.phase)
    tg = _rot(profile.eval(u, 1), -setup.phase)
    e, v0 = setup.eps, setup.v0
    O, _, _, w = setup._frame_working()

    def f(th):
        th = np.asarray(th, float)
        P2 = _rot(p[:, None, :] if th.ndim == 2 else p, e * th)
        T2 = _rot(tg[:, None, :] if th.ndim == 2 else tg, e * th)
        Jp = np.stack([-P2[..., 1], P2[..., 0]], -1)           # d/dtheta of the turned point, per unit e
        Pu = np.concatenate([T2, np.zeros(T2.shape[:-1] + (1,))], -1)
        Pt = np.concatenate([e * Jp, np.full(Jp.shape[:-1] + (1,), v0)], -1)
        N = np.cross(Pu, Pt)
        rel = np.concatenate([P2, (v0 * th)[..., None]], -1) - O
        return np.einsum("...k,...k->...", N, np.cross(rel, w)), rel

    thc = -e * atan2(p[:, 1], p[:, 0])
    grid = thc[:, None] + np.linspace(-window, window, n_scan)[None, :]
    fg, rel = f(grid)
    sc = np.sign(fg[:, :-1]) != np.sign(fg[:, 1:])
    dist = np.linalg.norm(rel, axis=-1)
    cand = np.where(sc, 0.5 * (dist[:, :-1] + dist[:, 1:]), np.inf)
    j = np.argmin(cand, axis=1)
    ok = np.isfinite(cand[np.arange(len(u)), j])
    rows = np.arange(len(u))
    a, b = grid[rows, j], grid[rows, j + 1]
    fa = fg[rows, j]
    for _ in range(200):
        m = 0.5 * (a + b)
        fm, _ = f(m)
        left = np.sign(fm) == np.sign(fa)
        a = np.where(left, m, a)
        fa = np.where(left, fm, fa)
        b = np.where(left, b, m)
        if np.max(np.abs(b - a)) < tol:
            break
    th = 0.5 * (a + b)
    _, rel = f(th)
    Z = rel @ w
    R = np.linalg.norm(rel - Z[:, None] * w, axis=1)
    Z = np.where(ok, Z, np.nan)
    R = np.where(ok, R, np.nan)
    return Z, R, np.where(ok, th, np.nan), ok


# --------------------------------------------------------------------------- Hu, Zhou & Li 2025 Table 2

def table2(eps_b_values=PAPER_TABLE2["eps_b"], schemes=("S1", "S2", "S3"), dt_ref=0.01, n_init=64):
    """Reproduce Hu, Zhou & Li 2025 Table 2 on the Table-1 arc tooth.

    Reference: the exact (error-free) cutter profile of the contact-equation method on the exact arc,
    at tooth angles t spaced ``dt_ref`` over the whole groove arc.  For each scheme and threshold
    eps_b the numerical method is evaluated on the planes Z_u of those reference points and the
    maximum |R_num - R_ref| is reported in micrometres (1 mm = 1000 um).
    Returns {"eps_b": [...], "S1": [...], ..., "paper": PAPER_TABLE2, "planes": n, "ref_t": t}.
    """
    T = TABLE1
    prof, tooth, t_e = arc_tooth_profile(T["R1"], T["R2"], T["G"], T["teeth"])
    setup = CutterSetup(T["centre_distance"], math.radians(T["swivel_deg"]), T["lead"], "right", 0.0)
    t = np.linspace(-t_e, t_e, int(round(2 * t_e / dt_ref)) + 1)
    Zr, Rr, _, ok = contact_equation_profile(prof, setup, T["R1"] * (t + t_e))
    if not ok.all():
        raise FormedCutterError("contact equation has no root for some reference points")
    out = {"eps_b": list(eps_b_values), "paper": PAPER_TABLE2, "planes": int(len(Zr)), "ref_t": t}
    order = np.argsort(Zr)
    for sch in schemes:
        sec = arc_tooth_section(sch)
        row = []
        for eb in eps_b_values:
            cp = cutter_profile(sec, T["lead"], T["centre_distance"], T["swivel_deg"], z=Zr, eps_b=eb,
                                n_init=n_init, phase=0.0, analyse=False)
            row.append(float(np.max(np.abs(cp.r - Rr[order]))) * 1e3)
        out[sch] = row
    return out


def format_table2(tab):
    """Text table: ours beside the paper's (um)."""
    eb = tab["eps_b"]
    lines = ["max |R_num - R_analytic| (um) on the Hu, Zhou & Li 2025 Table-1 arc tooth, "
             f"{tab['planes']} planes; ours / paper",
             "eps_b (mm)  " + "".join(f"{x:>20g}" for x in eb)]
    for sch in ("S1", "S2", "S3"):
        if sch not in tab:
            continue
        paper = dict(zip(PAPER_TABLE2["eps_b"], PAPER_TABLE2[sch]))
        cells = []
        for x, v in zip(eb, tab[sch]):
            p = paper.get(x)
            cells.append(f"{v:9.4f} / {p:.4f}" if p is not None else f"{v:9.4f} /    -  ")
        lines.append(f"{sch:<12}" + "".join(f"{c:>20}" for c in cells))
    return "\n".join(lines)
