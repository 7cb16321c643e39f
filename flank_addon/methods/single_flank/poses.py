"""Single-flank milling of a helical flank by a given conical tool (Bizzarri, Bo & Bartoň §5): initial poses,
pose optimisation and the candidate strips a cover / collision stage chooses from.

Frames, units, tool
-------------------
Rotor frame of :mod:`screw` (helical axis z, profile in z = 0), the rotor's length unit.  The tool is
a :class:`cone.ConeTool`; a pose is a :class:`cone.ConePose` (tip sphere centre x1S and the unit
axis towards the shank).  Because the flank is invariant under the screw, a pose and any screwed
copy of it mill the same strip, so the pose space has four parameters.  We use those of Eq. (8),

    o(s) = R_phi((delta, 0, 0) + (rho + L s)(0, cos beta, sin beta)),   s in [0, 1],

x = (delta, rho, beta, phi): the common perpendicular of the axis and z lies in z = 0 (that fixes the
screw), delta is the axis' distance from z, rho the position of x1S = o(0) along it.  Every pose is
screwed into this normal form before it is optimised (:func:`pose_params`).

Distances and errors
--------------------
d_i is the distance from the axis sample o(s_i) to the flank {S_t(p(u), 0): u_start <= u <= u_end}
(the flank as a closed patch, :class:`geometry.flank_feet.FlankFeet`), signed negative when the sample is
inside the rotor material over the open flank; e_i = d_i - r(s_i) is the tool-surface error of
Eq. (27) (> 0 material left, < 0 the sphere of the sample cuts into the flank).  Its gradient with
respect to the sample point is the unit vector from the foot to the point, chained through
do/dx of Eq. (8): no finite differences anywhere.

Objectives (all with the asymmetric weight w of Remark 5.1 on the overcutting samples)
-------------------------------------------------------------------------------------
* ``phi1``: Eq. (25), sum of e_i over I1 plus w times the sum of -e_i over I2.
* ``phi3``: Eq. (31), the same with f_i, the signed distance from the characteristic point of sample
  i (the point of the cone that touches the envelope of the helical motion, Eqs. (11)-(14)) to the
  flank.  The characteristic point of the sphere (o(s_i), r(s_i)) has the unit normal n with
  n . a = -sin(alpha) (envelope of the spheres along the axis, the cone) and n . V(o(s_i)) = 0
  (the sphere is stationary under the screw velocity field V); its derivative follows from
  differentiating these two equations and |n| = 1 (a 3 x 3 linear system per sample).
* hard mode (Eq. (30) style): minimise the mean of e_i (or f_i) subject to e_i >= 0 at every sample;
  after each solve the tools are checked on a dense axis grid and the refined local minima of e that
  still dip into the flank become constraints (exchange method, two rounds), then the dips left
  (~1e-9 R) are removed by the smallest LP step, so the final pose does not cut the flank anywhere
  along the axis (e >= -1e-12 R at the refined minima).

All poses are optimised together, with one foot-point solve per evaluation round for all of them:
stage 1 is scipy's SLSQP (quasi-Newton SQP, exact Jacobians), one ``scipy.optimize.minimize`` per pose,
run side by side in threads whose evaluations are batched (:func:`_slsqp_lockstep`); the
dense checks run on all poses in one call (:func:`_dense_minima`); the weighted objectives are
piecewise linear in the errors and are polished exactly by sequential LP in a trust region
(:func:`_slp_weighted_l1`, one sparse block LP for all poses per step).  The paper's own method
(finite-difference gradient descent, Remark 5.1) is :func:`optimize_fd_gradient_descent`, kept as the
benchmark baseline.

Initial poses (§5.1)
--------------------
Instead of integrating the field of "good directions" of Eq. (22) we place the given cone directly
in second-order line contact at each flank sample q (Fig. 5a): with principal curvatures k1 >= k2
(outward normal n, positive = bending towards the air side) the cone's middle sphere of radius r
touches X at q and its normal curvature perpendicular to the ruling g is 1/r.  The Dupin indicatrices
touch iff II_X(g) = r K, i.e. cos^2(gamma) = (r K - k2) / (k1 - k2) for g = cos(gamma) e1 +
sin(gamma) e2 (closed form; real iff r <= 1/k1, the condition of Eq. (18)).  Then the axis is
a = sin(alpha) n + cos(alpha) g.  At elliptic and parabolic points the ruling follows the principal
direction of the smallest |curvature| (tangential contact, Ex. 6.5).  Candidates are kept if they
satisfy Eq. (24) (tip nearer to z than the top) and ranked by their own Phi1; the tangential movability
F of Eq. (23) is reported but vanishes identically for a helical surface (see :class:`SeedPose`).
"""
import math
import threading
import time
from dataclasses import dataclass, field

import numpy as np

from ...tooling.cone import ConePose, ConeTool
from ...geometry.angles import contiguous
from ...geometry.flank_feet import FlankFeet
from ...geometry.screw import screw_velocity
from ...simulation.sweep import false_position, illinois_update

OBJECTIVES = ("phi1", "phi3")
MODES = ("weighted", "hard")
W_OVERCUT = 100.0
PIN_WEIGHT = 4.0      # weight of the contact sphere's error in the objective of a pinned pose (the mean is 1)


# ============================================================================ pose parameters (Eq. 8)
def screw_pose(pose, t, surface):
    """The pose moved by the screw S_t of the surface (same strip)."""
    h, v0 = surface.hand, surface.v0
    c, s = math.cos(h * t), math.sin(h * t)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return ConePose(pose.tool, rot @ pose.tip + np.array([0.0, 0.0, v0 * t]), rot @ pose.axis)


def pose_params(pose, surface):
    """(delta, rho, beta, phi) of Eq. (8) of the pose screwed so that the axis' common perpendicular
    with z lies in z = 0."""
    a, x1 = pose.axis, pose.tip
    axy = float(a[0] ** 2 + a[1] ** 2)
    if axy < 1e-20:
        raise ValueError("cone pose: an axis parallel to the helical axis has no Eq. (8) parameters")
    w = -float(x1[:2] @ a[:2]) / axy
    zc = x1[2] + w * a[2]
    p = screw_pose(pose, -zc / surface.v0, surface)
    a, x1 = p.axis, p.tip
    beta = math.asin(max(-1.0, min(1.0, float(a[2]))))
    phi = math.atan2(-a[0], a[1])
    er = np.array([math.cos(phi), math.sin(phi), 0.0])
    return np.array([float(x1 @ er), float(x1 @ a), beta, phi])


def params_pose(x, tool):
    """ConePose of Eq. (8) parameters x = (delta, rho, beta, phi): tip o(0), axis o'(s) / L."""
    de, rho, be, ph = (float(v) for v in x)
    cb, sb, cp, sp = math.cos(be), math.sin(be), math.cos(ph), math.sin(ph)
    d = np.array([-cb * sp, cb * cp, sb])
    return ConePose(tool, np.array([de * cp, de * sp, 0.0]) + rho * d, d)


def axis_and_jacobian(X, s, L):
    """Axis points o(s) (N, n, 3) of Eq. (8) for parameter rows X (N, 4), their derivatives
    do/dx (N, n, 3, 4), unit directions a (N, 3) and da/dx (N, 3, 4).  s: (n,) shared by all rows
    or (N, n), one row of axis parameters per pose."""
    X = np.atleast_2d(X)
    de, rho, be, ph = X.T
    # the angles as contiguous arrays: a column's cosine may otherwise differ in the last bit from run to run
    be, ph = contiguous(be), contiguous(ph)
    cb, sb, cp, sp = np.cos(be), np.sin(be), np.cos(ph), np.sin(ph)
    zero = np.zeros_like(de)
    er = np.stack([cp, sp, zero], -1)
    et = np.stack([-sp, cp, zero], -1)
    a = np.stack([-cb * sp, cb * cp, sb], -1)
    a_be = np.stack([sb * sp, -sb * cp, cb], -1)
    a_ph = -cb[:, None] * er
    s = np.asarray(s, float)
    w = rho[:, None] + L * (s if s.ndim == 2 else s[None, :])           # (N, n)
    pts = de[:, None, None] * er[:, None, :] + w[..., None] * a[:, None, :]
    J = np.empty(pts.shape + (4,))
    J[..., 0] = er[:, None, :]
    J[..., 1] = a[:, None, :]
    J[..., 2] = w[..., None] * a_be[:, None, :]
    J[..., 3] = de[:, None, None] * et[:, None, :] + w[..., None] * a_ph[:, None, :]
    da = np.zeros(a.shape + (4,))
    da[..., 2], da[..., 3] = a_be, a_ph
    return pts, J, a, da


def mid_radius(X, L, s=0.5):
    """Distance of the axis point o(s) (default the midpoint) from the helical axis (screw-invariant) and
    its gradient (N, 4) w.r.t. the Eq. (8) parameters: sqrt(delta^2 + (rho + s L)^2 cos^2 beta).  ``s``: one
    axis parameter or one per row."""
    X = np.atleast_2d(X)
    de, rho, be = X[:, 0], X[:, 1], contiguous(X[:, 2])
    w = rho + np.asarray(s, float) * L
    cb, sb = np.cos(be), np.sin(be)
    r = np.sqrt(de ** 2 + (w * cb) ** 2)
    g = np.stack([de / r, w * cb ** 2 / r, -w * w * cb * sb / r, np.zeros_like(r)], -1)
    return r, g


# ============================================================================ flank geometry
def flank_samples(surface, u_start, u_end, n, along="profile", n_fine=4001):
    """n profile parameters on [u_start, u_end], uniform in arc length of the profile (``profile``)
    or of the orthogonal trajectory of the helices through the flank (``orthogonal``, Remark 4.2).

    The orthogonal trajectory runs on X perpendicular to x_t; its screwed-back points are the profile
    points again, so only the spacing differs: |x_u|^2 - (x_u . x_t)^2 / |x_t|^2 per du^2."""
    if along not in ("profile", "orthogonal"):
        raise ValueError(f"along must be 'profile' or 'orthogonal', got {along!r}")
    if n < 1:
        raise ValueError(f"need at least one flank sample, got {n}")
    prof = surface.profile
    uf = np.linspace(u_start, u_end, n_fine)
    p, p1 = prof.eval(uf), prof.eval(uf, 1)
    speed2 = np.einsum("ij,ij->i", p1, p1)
    if along == "orthogonal":
        jp = np.stack([-p[:, 1], p[:, 0]], -1) * surface.hand
        speed2 = speed2 - np.einsum("ij,ij->i", p1, jp) ** 2 / (np.einsum("ij,ij->i", p, p) + surface.v0 ** 2)
    sp = np.sqrt(np.maximum(speed2, 0.0))
    arc = np.r_[0.0, np.cumsum(0.5 * (sp[1:] + sp[:-1]) * np.diff(uf))]
    # samples at the centres of n equal arc-length cells (the flank ends are shared with neighbours)
    target = (np.arange(n) + 0.5) / n * arc[-1]
    return np.interp(target, arc, uf)


@dataclass
class PrincipalFrame:
    """Surface point, outward normal, principal curvatures k1 >= k2 and unit principal directions
    (3D, at t = 0) at profile parameters u."""
    point: np.ndarray
    normal: np.ndarray
    k1: np.ndarray
    k2: np.ndarray
    e1: np.ndarray
    e2: np.ndarray


def principal_frame(surface, u):
    """Principal curvatures and directions of the helical surface at (u, t = 0) (shape operator
    I^-1 II in the (x_u, x_t) basis; sign convention of :meth:`HelicalSurface.curvatures`)."""
    u = np.atleast_1d(np.asarray(u, float))
    h, v0 = surface.hand, surface.v0
    prof = surface.profile
    p, p1, p2 = (prof.eval(u, k) for k in range(3))
    z = np.zeros((len(u), 1))
    J = lambda v: np.stack([-v[:, 1], v[:, 0]], -1)  # noqa: E731
    xu = np.c_[p1, z]
    xt = np.c_[h * J(p), np.full((len(u), 1), v0)]
    xuu, xut, xtt = np.c_[p2, z], np.c_[h * J(p1), z], np.c_[-p, z]
    n = np.cross(xu, xt)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    dot = lambda a, b: np.einsum("ij,ij->i", a, b)  # noqa: E731
    E, F, G = dot(xu, xu), dot(xu, xt), dot(xt, xt)
    L, M, N = dot(xuu, n), dot(xut, n), dot(xtt, n)
    Ii = np.linalg.inv(np.stack([np.stack([E, F], -1), np.stack([F, G], -1)], -2))
    II = np.stack([np.stack([L, M], -1), np.stack([M, N], -1)], -2)
    S = Ii @ II
    # eigen-decomposition of the (self-adjoint w.r.t. I) shape operator
    tr, det = S[:, 0, 0] + S[:, 1, 1], S[:, 0, 0] * S[:, 1, 1] - S[:, 0, 1] * S[:, 1, 0]
    disc = np.sqrt(np.maximum(0.25 * tr * tr - det, 0.0))
    k1, k2 = 0.5 * tr + disc, 0.5 * tr - disc

    def direction(k):
        # (S - k I) v = 0: v = (S01, k - S00) or (k - S11, S10), whichever is longer
        va = np.stack([S[:, 0, 1], k - S[:, 0, 0]], -1)
        vb = np.stack([k - S[:, 1, 1], S[:, 1, 0]], -1)
        v = np.where((np.linalg.norm(va, axis=1) >= np.linalg.norm(vb, axis=1))[:, None], va, vb)
        d3 = v[:, :1] * xu + v[:, 1:] * xt
        nd = np.linalg.norm(d3, axis=1, keepdims=True)
        return d3 / np.maximum(nd, 1e-300), nd[:, 0]

    e1, n1 = direction(k1)
    e2 = np.cross(n, e1)           # orthonormal frame; e1 x e2 = n
    # umbilic points (n1 ~ 0): any frame is principal; keep the x_u direction
    umb = n1 < 1e-12
    if umb.any():
        e1[umb] = xu[umb] / np.linalg.norm(xu[umb], axis=1, keepdims=True)
        e2[umb] = np.cross(n[umb], e1[umb])
    pt = np.c_[p, z]
    return PrincipalFrame(point=pt, normal=n, k1=k1, k2=k2, e1=e1, e2=e2)


# ============================================================================ initial positions (§5.1)
@dataclass
class SeedPose:
    """An initial pose: the cone touches the flank at ``point`` (profile parameter ``u``, t = 0) with
    its middle sphere.  ``contact``: 2 = second-order line contact (hyperbolic point, Fig. 5a),
    1 = tangential contact (elliptic/parabolic point, or a hyperbolic point where the tool is too
    large for Eq. (18)); ``movability``: F(l) of Eq. (23); ``phi``: Phi1 (Eq. (25)) of the seed
    itself; ``rank``: 0 = best candidate at this sample.

    Note on Eq. (23): the distance to a helical surface is invariant under its own screw, so its
    gradient is orthogonal to the screw velocity at *every* point and F(l) vanishes identically
    (up to round-off) for every line.  It is still computed and reported, but candidates are ranked
    by ``phi``, the error of the seed along the whole axis, which is what F is meant to measure
    for a general motion (how well the axis keeps its distance profile while it moves)."""
    pose: ConePose
    params: np.ndarray
    u: float
    point: np.ndarray
    gauss: float
    contact: int
    movability: float
    admissible: bool
    phi: float = float("nan")
    rank: int = 0
    sample: int = 0
    contact_s: float = 0.5          # axis parameter of the sphere that touches the flank at ``point``
    clearance: float = float("nan")  # smallest clearance row of :func:`clear_seeds` (< 0: buried somewhere)
    blocked: dict = None             # where that row is: part ("cone" | "shank"), foot parameter u, depth


def _contact_axes(frame, r_mid, alpha, tangential=False):
    """Candidate axis directions (M, 4, 3) at each sample (4 = the two contact lines, each with both
    orientations) and a validity mask (M, 4) and contact order (M,).  ``tangential``: every sample as an
    elliptic one (the initialisation of the elliptic part, Examples 6.5, 6.6)."""
    k1, k2, n, e1, e2 = frame.k1, frame.k2, frame.normal, frame.e1, frame.e2
    K = k1 * k2
    hyper = (K < 0) & (not tangential)
    with np.errstate(divide="ignore", invalid="ignore"):
        c2 = (r_mid * K - k2) / (k1 - k2)
    second = hyper & (c2 >= 0) & (c2 <= 1)
    c2 = np.clip(np.nan_to_num(c2, nan=0.0), 0.0, 1.0)
    # elliptic / parabolic: ruling along the principal direction of the smallest |k|
    c2 = np.where(hyper, c2, np.where(np.abs(k1) <= np.abs(k2), 1.0, 0.0))
    cg, sg = np.sqrt(c2), np.sqrt(1.0 - c2)
    g1 = cg[:, None] * e1 + sg[:, None] * e2
    g2 = cg[:, None] * e1 - sg[:, None] * e2
    G = np.stack([g1, -g1, g2, -g2], 1)
    A = math.sin(alpha) * n[:, None, :] + math.cos(alpha) * G
    valid = np.ones(A.shape[:2], bool)
    # a single line (elliptic, parabolic, or a degenerate double root) has only 2 distinct axes
    single = ~hyper | (sg < 1e-12) | (cg < 1e-12)
    valid[single, 2:] = False
    return A, valid, np.where(second, 2, 1)


def movability(feet_fn, tips, axes, L, surface, n=25):
    """F(l) of Eq. (23) for axis segments tip + s L a, s in [0, 1] (rows of tips/axes): mean squared
    component of the normalised screw velocity along the distance gradient (0 = the axis moves
    tangentially to the flank everywhere)."""
    s = np.linspace(0.0, 1.0, n)
    pts = tips[:, None, :] + (L * s)[None, :, None] * axes[:, None, :]
    ft = feet_fn(pts.reshape(-1, 3))
    dirs = ft.direction.reshape(pts.shape)
    v = screw_velocity(pts, surface.v0, surface.hand)
    vmid = np.linalg.norm(screw_velocity(tips + 0.5 * L * axes, surface.v0, surface.hand), axis=1)
    proj = np.einsum("mni,mni->mn", v, dirs) / vmid[:, None]
    return np.mean(proj ** 2, axis=1)


def initial_positions(surface, u_range, tool, n_samples=18, along="profile", feet=None, u=None,
                      keep="admissible", n_rank=33, w=W_OVERCUT, tangential=False):
    """Initial poses of the given cone on one flank (Bizzarri, Bo & Bartoň §5.1, closed form, see module doc).

    surface: :class:`HelicalSurface`; u_range: the flank (u_start, u_end); tool: :class:`ConeTool`;
    n_samples flank samples (``along`` 'profile' or 'orthogonal', or explicit profile parameters
    ``u``).  Returns a list (per sample) of lists of :class:`SeedPose`, admissible ones (Eq. (24))
    first, each sorted by the seed's own Phi1 on ``n_rank`` axis samples (see :class:`SeedPose` on
    why not by F of Eq. (23), which is reported too); with ``keep='admissible'`` only admissible poses
    are listed, with ``keep='all'`` every candidate.  ``tangential``: tangential contact along the least curved
    principal direction at every sample (the elliptic part's own initialisation, Examples 6.5 and 6.6)."""
    if keep not in ("admissible", "all"):
        raise ValueError(f"keep must be 'admissible' or 'all', got {keep!r}")
    feet = feet or FlankFeet.of(surface, *u_range)
    us = flank_samples(surface, *u_range, n_samples, along=along) if u is None else np.atleast_1d(u)
    fr = principal_frame(surface, us)
    r_mid = float(tool.radius(0.5))
    L = tool.L
    A, valid, order = _contact_axes(fr, r_mid, tool.alpha, tangential)
    mid = fr.point + r_mid * fr.normal
    tips = mid[:, None, :] - 0.5 * L * A
    tops = tips + L * A
    # Eq. (24): the tip is nearer to the helical axis than the top (r1S < r2S holds for every cone)
    adm = np.linalg.norm(tips[..., :2], axis=-1) < np.linalg.norm(tops[..., :2], axis=-1)
    M = len(us)
    F = np.full((M, 4), np.inf)
    vi, vj = np.nonzero(valid)
    F[vi, vj] = movability(feet, tips[vi, vj], A[vi, vj], L, surface)
    P = np.full((M, 4), np.inf)
    if len(vi):
        ev = PoseEvaluator(surface, u_range, tool, n=n_rank, feet=feet)
        Xc = np.array([pose_params(ConePose(tool, tips[i, j], A[i, j]), surface) for i, j in zip(vi, vj)])
        P[vi, vj] = weighted_l1(ev.distances(Xc, key=None, jac=False)[0], w)
    K = fr.k1 * fr.k2
    out = []
    for i in range(M):
        cands = []
        for j in np.flatnonzero(valid[i]):
            if keep == "admissible" and not adm[i, j]:
                continue
            pose = ConePose(tool, tips[i, j], A[i, j])
            cands.append(SeedPose(pose=pose, params=pose_params(pose, surface), u=float(us[i]),
                                  point=fr.point[i], gauss=float(K[i]), contact=int(order[i]),
                                  movability=float(F[i, j]), admissible=bool(adm[i, j]), phi=float(P[i, j]),
                                  sample=i))
        cands.sort(key=lambda c: (not c.admissible, c.phi))
        for k, c in enumerate(cands):
            c.rank = k
        out.append(cands)
    return out


def clear_seeds(ev, u, contacts=(0.5, 0.25, 0.0), n_turns=12, w=W_OVERCUT, n_rank=33, prefer_paper=True,
                tangential=False):
    """One initial pose per profile parameter u (M,), chosen with the tool's clearance from the whole rotor
    (:class:`RotorClearance` of ``ev``) in view: Bizzarri, Bo & Bartoň §5.1 places the middle sphere in
    second-order line contact, which in a narrow valley or with a shank wider than the cone can bury the
    tool in the opposite flank or the shank in its own flank.  Candidates at each sample: the §5.1 seeds of
    :func:`initial_positions`, then tangential contacts (the cone's sphere at axis parameter s_c touches the
    flank at the sample, the axis a = sin(alpha) n + cos(alpha) g for ``n_turns`` ruling directions g of the
    tangent plane) for every s_c in ``contacts`` (0: the tip circle touches, the flutes and shank lean out of
    the valley), all kept only if they satisfy Eq. (24).  Clearance of a candidate: the smallest value of
    the clearance rows away from the cone's own contact with the target flank (the optimisation removes an
    overcut of the target flank, not a tool buried in another one).  Chosen: the first §5.1 seed that is
    clear (``prefer_paper``), else the clear candidate of smallest Phi1 (Eq. (25) on ``n_rank`` axis samples),
    else the one of largest clearance.  ``tangential``: the §5.1 seeds in tangential contact everywhere
    (:func:`initial_positions`).  Returns a list (M,) of :class:`SeedPose` or None (no candidate)."""
    surface, tool = ev.surface, ev.tool
    us = np.atleast_1d(np.asarray(u, float))
    if not len(us):
        return []
    paper = initial_positions(surface, ev.u_range, tool, u=us, feet=ev.feet, n_rank=n_rank, w=w, tangential=tangential)
    if ev.clearance is None:
        return [c[0] if c else None for c in paper]
    fr = principal_frame(surface, us)
    L, sa, ca = tool.L, math.sin(tool.alpha), math.cos(tool.alpha)
    th = np.arange(int(n_turns)) * (2.0 * math.pi / int(n_turns))
    rows = []                       # (sample, pose, paper rank or -1, contact parameter)
    for i in range(len(us)):
        for c in paper[i]:
            rows.append((i, c.pose, c.rank, 0.5))
        g = np.cos(th)[:, None] * fr.e1[i] + np.sin(th)[:, None] * fr.e2[i]
        A = sa * fr.normal[i] + ca * g
        for sc in contacts:
            mid = fr.point[i] + float(tool.radius(sc)) * fr.normal[i]
            tips = mid - sc * L * A
            tops = tips + L * A
            keep = np.linalg.norm(tips[:, :2], axis=1) < np.linalg.norm(tops[:, :2], axis=1)      # Eq. (24)
            for tip, a in zip(tips[keep], A[keep]):
                rows.append((i, ConePose(tool, tip, a), -1, float(sc)))
    if not rows:
        return [None] * len(us)
    X = np.array([pose_params(p, surface) for _, p, _, _ in rows])
    c = ev.clearance
    pts, _, _, _ = axis_and_jacobian(X, c.s, ev.L)
    d, _, uf, _, _ = ev._feet(pts, None, feet=c.feet)
    cone_on_target = c.on_target(uf) & (c.margin_target[None, :] == 0.0)
    val = d - c.r[None, :] - np.where(c.on_target(uf), c.margin_target[None, :], c.margin[None, :])
    masked = np.where(cone_on_target, np.inf, val)
    worst = np.argmin(masked, axis=1)
    clear = masked[np.arange(len(X)), worst]
    n_cone = int(np.count_nonzero(c.margin_target == 0.0))
    ev_rank = PoseEvaluator(surface, ev.u_range, tool, n=n_rank, feet=ev.feet)
    phi = weighted_l1(ev_rank.distances(X, key=None, jac=False)[0], w)
    K = fr.k1 * fr.k2
    out = []
    sample = np.array([r[0] for r in rows])
    rank = np.array([r[2] for r in rows])
    for i in range(len(us)):
        idx = np.flatnonzero(sample == i)
        if not len(idx):
            out.append(None)
            continue
        ok = idx[clear[idx] >= 0.0]
        pap = [j for j in ok if rank[j] >= 0]
        if prefer_paper and pap:
            j = min(pap, key=lambda j: rank[j])
        elif len(ok):
            j = ok[int(np.argmin(phi[ok]))]
        else:
            j = idx[int(np.argmax(clear[idx]))]
        pose = rows[j][1]
        out.append(SeedPose(pose=pose, params=X[j], u=float(us[i]), point=fr.point[i], gauss=float(K[i]),
                            contact=paper[i][rank[j]].contact if rank[j] >= 0 else 1, movability=float("nan"),
                            admissible=True, phi=float(phi[j]), rank=int(rank[j]), sample=i,
                            contact_s=rows[j][3], clearance=float(clear[j]),
                            blocked={"part": "cone" if worst[j] < n_cone else "shank", "u": float(uf[j, worst[j]]),
                                     "depth": float(max(0.0, -clear[j])), "variants": int(len(idx))}))
    return out


# ============================================================================ errors along the axis
@dataclass
class AxisErrors:
    """Per-sample errors of one pose: s (n,) along x1S -> x2S, axis points (n, 3), signed distances
    d (n,) to the flank, radii r (n,), e = d - r (Eq. (27)), the feet' profile parameters u (n,) and
    screw parameters t (n,), and whether each foot is interior to the flank (not on its boundary
    helices).  For Phi3 poses also f (n,): signed distances of the characteristic points to the flank
    (nan where the characteristic is not real)."""
    s: np.ndarray
    points: np.ndarray
    d: np.ndarray
    r: np.ndarray
    e: np.ndarray
    u: np.ndarray
    t: np.ndarray
    interior: np.ndarray
    f: np.ndarray = None

    @property
    def max_error(self):
        return float(np.max(self.e))

    @property
    def min_error(self):
        return float(np.min(self.e))


@dataclass
class RotorClearance:
    """Clearance of the tool and its shank from the whole rotor, as hard constraints of the pose optimisation:
    Bizzarri, Bo & Bartoň §5.5 filter colliding poses afterwards ("conceptually a better solution would incorporate
    the collision avoidance as a part of the optimization", §6.1); here the optimiser keeps every sphere of a
    sample of the axis out of the rotor, so a pose does not roll into the opposite flank or bury its shank in
    its own flank.

    feet: foot points on the whole rotor surface (a :class:`FlankFeet` over one full profile period, its seam
    opposite the target flank); s (m,): axis parameters (Eq. (8); beyond 1: the shank's axis); r (m,): the
    radius of the ball there (the cone's inscribed sphere r(s) of Eq. (9), the shank's radius: the balls
    cover the flat-ended shank, so the constraint is on the safe side by at most its end caps); margin: kept
    from surfaces other than the target flank (samples are discrete); margin_target: from the target flank
    (0 for the cone: it touches it, its own constraint is the dense one of the hard mode)."""
    feet: object
    s: np.ndarray
    r: np.ndarray
    margin: np.ndarray
    margin_target: np.ndarray
    target: tuple
    period: float

    @classmethod
    def for_tool(cls, surface, u_range, tool, sag=None, max_rows=48, feet=None):
        """The clearance model of ``tool`` (cone and shank) on the flank ``u_range`` of ``surface``.

        Between two balls of radius r a distance D apart the cone (or shank) bulges past their union by the
        sagitta D^2 / (8 r): the samples are spaced so that it stays below ``sag`` (default 1e-3 R; at most
        ``max_rows`` per part) and each row keeps its own sagitta as margin (from the target flank too for
        the shank; the cone's contact with the target flank is the dense constraint of the hard mode)."""
        R = float(surface.outer_radius)
        per = float(surface.profile.period)
        if feet is None:
            mid = 0.5 * (float(u_range[0]) + float(u_range[1]))
            lo = mid + 0.5 * per
            flank_len = max(float(u_range[1]) - float(u_range[0]), 1e-9 * per)
            feet = FlankFeet.of(surface, lo, lo + per, n_u=int(min(2400, max(320, 160 * per / flank_len))))
        sag = 1e-3 * R if sag is None else float(sag)
        L = tool.L

        def rows(length, r_min):
            step = math.sqrt(8.0 * max(r_min, 1e-9 * R) * sag)
            return int(min(max_rows, max(4, math.ceil(length / step) + 1)))

        s_c = np.linspace(0.0, 1.0, rows(L, tool.r1s))
        parts = [(s_c, tool.radius(s_c), L / (len(s_c) - 1), True)]
        if tool.shank_radius > 0 and tool.shank_length > 0:
            s0 = 1.0 - tool.r2c * math.tan(tool.alpha) / L          # the top circle c2, where the shank starts
            n_s = rows(tool.shank_length, tool.shank_radius)
            s_s = s0 + np.linspace(0.0, tool.shank_length / L, n_s)
            parts.append((s_s, np.full(n_s, tool.shank_radius), tool.shank_length / (n_s - 1), False))
        s_all, r_all, m_all, mt_all = [], [], [], []
        for sv, rv, D, cone in parts:
            sagitta = D * D / (8.0 * rv) + 1e-6 * R
            s_all.append(sv)
            r_all.append(rv)
            m_all.append(sagitta)
            mt_all.append(np.zeros(len(sv)) if cone else sagitta)
        return cls(feet=feet, s=np.concatenate(s_all), r=np.concatenate(r_all), margin=np.concatenate(m_all),
                   margin_target=np.concatenate(mt_all), target=(float(u_range[0]), float(u_range[1])), period=per)

    def on_target(self, u):
        """Feet (profile parameters u) that lie on the target flank."""
        a, b = self.target
        w = np.mod(np.asarray(u, float) - a, self.period)
        return w <= (b - a)


class PoseEvaluator:
    """Errors and exact Jacobians of many poses of one tool on one flank at once.

    The foot points of all axis samples of all poses are found in one vectorised call of
    :class:`FlankFeet`, warm-started from the previous call with the same shape."""

    def __init__(self, surface, u_range, tool, n=100, feet=None, clearance=None):
        if n < 4:
            raise ValueError(f"need at least 4 axis samples, got {n}")
        self.surface, self.tool = surface, tool
        self.u_range = (float(u_range[0]), float(u_range[1]))
        self.feet = feet or FlankFeet.of(surface, *u_range)
        self.s = np.linspace(0.0, 1.0, n)
        self.L = tool.L
        self._warm = {}
        self.calls = 0
        self.points_solved = 0
        self.last_feet = None
        self.clearance = clearance

    @property
    def n_clearance(self):
        """Rows of the clearance constraints (:class:`RotorClearance`) per pose (0 without them)."""
        return 0 if self.clearance is None else len(self.clearance.s)

    def _clearance_from_feet(self, feet, J):
        """Clearance constraints (N, m) >= 0 of :class:`RotorClearance` and their Jacobian (N, m, 4) from the
        feet of its axis samples (:meth:`_feet`) and the samples' Jacobian J."""
        c = self.clearance
        d, g, u, _, _ = feet
        on_target = c.on_target(u)
        val = d - c.r[None, :] - np.where(on_target, c.margin_target[None, :], c.margin[None, :])
        return val, np.einsum("Nni,Nnij->Nnj", g, J)

    def _feet(self, pts, key, idx=None, warm=None, feet=None):
        """Signed distances, their gradients, feet u, t and interior flags of points (k, n, 3) of
        poses ``idx`` (k,) (default 0..k-1); warm-started per pose from the last call with ``key``, or
        from ``warm`` = (u, tau) arrays (k, n) when given.  The feet's (u, tau) are kept in
        ``last_feet`` for warm starts of the caller's own.  ``feet``: another foot-point solver than the
        flank's (the whole rotor of :class:`RotorClearance`)."""
        solver, flat, w, finish = self._feet_query(pts, key, idx, warm, feet)
        return finish(solver(flat, warm=w))

    def _feet_query(self, pts, key, idx=None, warm=None, feet=None):
        """:meth:`_feet` in two halves, so that several queries share one :meth:`FlankFeet.many` run:
        (solver, flat points, warm start, finish), where ``finish(feet of the flat points)`` keeps the warm
        starts and returns what :meth:`_feet` returns."""
        feet = self.feet if feet is None else feet
        k, n = pts.shape[:2]
        idx = np.arange(k) if idx is None else np.asarray(idx)
        flat = pts.reshape(-1, 3)
        store = self._warm.setdefault((key, n), {}) if key is not None else {}
        w = None
        if warm is not None:
            w = (np.asarray(warm[0], float).ravel(), np.asarray(warm[1], float).ravel())
        elif len(store) and all(int(i) in store for i in idx):
            w = (np.concatenate([store[int(i)][0] for i in idx]), np.concatenate([store[int(i)][1] for i in idx]))

        def finish(ft):
            uu, tt = ft.u.reshape(k, n), ft.tau.reshape(k, n)
            self.last_feet = (uu, tt)
            if key is not None:
                for j, i in enumerate(idx):
                    store[int(i)] = (uu[j], tt[j])
            self.calls += 1
            self.points_solved += len(flat)
            lo, hi = feet.lo + feet.eps_u, feet.hi - feet.eps_u
            in_range = (ft.u > lo) & (ft.u < hi)
            # in range but not interior = the point is inside the material over the open flank
            sign = np.where(in_range & ~ft.interior, -1.0, 1.0)
            sh = pts.shape[:-1]
            return (sign * ft.distance).reshape(sh), (sign[:, None] * ft.direction).reshape(sh + (3,)), \
                ft.u.reshape(sh), ft.t.reshape(sh), ft.interior.reshape(sh)

        return feet, flat, w, finish

    def distances(self, X, s=None, key="d", jac=True, idx=None, warm=None):
        """e = d - r (N, n), de/dx (N, n, 4) and the feet data for parameter rows X (N, 4) (of poses
        ``idx``, for the warm starts; or explicit ``warm`` = (u, tau) (N, n), see :meth:`_feet`);
        s (n,) or one row per pose (N, n).  The feet data hold the gradient ``g`` (N, n, 3) of the
        signed distance at the axis points (de/ds = L g . a - (r2S - r1S)) and (u, tau) for warm starts."""
        s = self.s if s is None else np.asarray(s, float)
        pts, J, _, _ = axis_and_jacobian(X, s, self.L)
        return self._distances_from_feet(s, pts, J, self._feet(pts, key, idx, warm), jac)

    def _distances_from_feet(self, s, pts, J, feet, jac=True):
        d, g, u, t, inter = feet
        e = d - (self.tool.radius(s) if s.ndim == 2 else self.tool.radius(s)[None, :])
        de = np.einsum("Nni,Nnij->Nnj", g, J) if jac else None
        return e, de, dict(points=pts, d=d, u=u, t=t, interior=inter, g=g, warm=self.last_feet)

    def distances_and_clearance(self, X, s, key, idx=None, clear_key=None):
        """``distances(X, s, key, idx=idx)`` and the clearance constraints (N, m) >= 0 of :class:`RotorClearance`
        with their Jacobian (N, m, 4) (warm starts under ``clear_key``), the foot points of both solved in one
        :meth:`FlankFeet.many` run (every point iterates on its own).  The optimisation asks for both at every
        step; one run instead of two halves numpy's per-call overhead."""
        c = self.clearance
        s = np.asarray(s, float)
        pts, J, _, _ = axis_and_jacobian(X, s, self.L)
        cpts, cJ, _, _ = axis_and_jacobian(X, c.s, self.L)
        qd = self._feet_query(pts, key, idx)
        qc = self._feet_query(cpts, ("clear", key if clear_key is None else clear_key), idx, feet=c.feet)
        fd, fc = FlankFeet.many([qd[0], qc[0]], [qd[1], qc[1]], [qd[2], qc[2]])
        dist = self._distances_from_feet(s, pts, J, qd[3](fd))
        return dist, self._clearance_from_feet(qc[3](fc), cJ)

    def characteristic(self, X, branch, s=None):
        """Characteristic points c (N, n, 3) of the cones at X under the screw (Eqs. (11)-(14)),
        dc/dx (N, n, 3, 4), and a mask of samples where the characteristic is real.  ``branch``
        (N,) = +-1 selects the side of the axis."""
        s = self.s if s is None else np.asarray(s, float)
        m, Jm, a, da = axis_and_jacobian(X, s, self.L)
        tool = self.tool
        sa, ca = math.sin(tool.alpha), math.cos(tool.alpha)
        r = tool.radius(s)
        V = screw_velocity(m, self.surface.v0, self.surface.hand)
        A = np.broadcast_to(a[:, None, :], m.shape)
        va = np.einsum("Nni,Nni->Nn", V, A)
        vperp = V - va[..., None] * A
        nv = np.linalg.norm(vperp, axis=-1)
        e1 = vperp / np.maximum(nv, 1e-300)[..., None]
        e2 = np.cross(A, e1)
        cth = math.tan(tool.alpha) * va / np.maximum(nv, 1e-300)
        real = (np.abs(cth) < 1.0 - 1e-9) & (nv > 1e-12)
        cth = np.clip(cth, -1.0, 1.0)
        sth = np.sqrt(1.0 - cth ** 2) * np.asarray(branch, float)[:, None]
        nrm = -sa * A + ca * (cth[..., None] * e1 + sth[..., None] * e2)
        r = r if r.ndim == 2 else np.broadcast_to(r[None, :], m.shape[:2])
        c = m + r[..., None] * nrm
        # derivative of n from a.n = -sin(alpha), V.n = 0, n.n = 1
        h = self.surface.hand
        ez = np.array([0.0, 0.0, 1.0])
        dV = h * np.cross(ez[None, None, :, None], Jm, axisa=2, axisb=2, axisc=2)   # (N, n, 3, 4)
        Mx = np.stack([A, V, nrm], -2)                                               # (N, n, 3, 3)
        rhs = np.stack([-np.einsum("Nni,Nij->Nnj", nrm, da),
                        -np.einsum("Nni,Nnij->Nnj", nrm, dV),
                        np.zeros(m.shape[:2] + (4,))], -2)                           # (N, n, 3, 4)
        det = np.linalg.det(Mx)
        ok = real & (np.abs(det) > 1e-12)
        Mx = np.where(ok[..., None, None], Mx, np.eye(3))
        dn = np.linalg.solve(Mx, rhs)
        dc = Jm + r[..., None, None] * dn
        return c, dc, ok

    def char_distances(self, X, branch, s=None, key="f", idx=None):
        """Signed distances f (N, n) of the characteristic points to the flank and df/dx; nan and a
        zero gradient where the characteristic is not real."""
        c, dc, ok = self.characteristic(X, branch, s)
        f, g, u, t, inter = self._feet(c, key, idx)
        df = np.einsum("Nni,Nnij->Nnj", g, dc)
        f = np.where(ok, f, np.nan)
        df = np.where(ok[..., None], df, 0.0)
        return f, df, dict(points=c, u=u, t=t, interior=inter, real=ok)

    def branch(self, X):
        """Side of the characteristic (+-1 per pose) that faces the flank."""
        m, _, a, _ = axis_and_jacobian(X, self.s, self.L)
        _, g, _, _, _ = self._feet(m, None)
        V = screw_velocity(m, self.surface.v0, self.surface.hand)
        A = np.broadcast_to(a[:, None, :], m.shape)
        va = np.einsum("Nni,Nni->Nn", V, A)
        e1 = V - va[..., None] * A
        e2 = np.cross(A, e1)
        # g points from the flank to the axis; the characteristic lies on the opposite side
        side = -np.einsum("Nni,Nni->N", e2, g)
        return np.where(side >= 0, 1.0, -1.0)

    def axis_errors(self, x, s=None, branch=None):
        """:class:`AxisErrors` of one pose (parameters x)."""
        s = self.s if s is None else np.asarray(s, float)
        e, _, info = self.distances(np.atleast_2d(x), s, key=None, jac=False)
        f = None
        if branch is not None:
            f = self.char_distances(np.atleast_2d(x), np.atleast_1d(branch), s, key=None)[0][0]
        return AxisErrors(s=s, points=info["points"][0], d=info["d"][0], r=self.tool.radius(s), e=e[0],
                          u=info["u"][0], t=info["t"][0], interior=info["interior"][0], f=f)


def weighted_l1(e, w=W_OVERCUT):
    """Eq. (25) / (31) for error rows e (..., n): sum of e >= 0 plus w times sum of -e over e < 0
    (nan entries, e.g. non-real characteristic points, are skipped)."""
    e = np.nan_to_num(np.asarray(e, float), nan=0.0)
    return np.sum(np.where(e >= 0, e, -w * e), axis=-1)


def phi_value(ev, x, objective="phi1", w=W_OVERCUT, branch=None):
    """Phi1 (Eq. (25)) or Phi3 (Eq. (31)) of one pose x with evaluator ``ev``."""
    X = np.atleast_2d(x)
    if objective == "phi1":
        e = ev.distances(X, key=None, jac=False)[0]
    else:
        if branch is None:
            branch = ev.branch(X)
        e = ev.char_distances(X, np.atleast_1d(branch), key=None)[0]
    return float(weighted_l1(e, w)[0])


# ============================================================================ optimisation
@dataclass
class Convergence:
    """How one pose optimisation went: objective and mode, Phi at the start and end, iterations,
    foot-point evaluations (batched calls count once per pose), the Phi history per accepted step,
    a status string and the wall time (shared batched time split evenly over the poses)."""
    objective: str
    mode: str
    phi_start: float
    phi_end: float
    iterations: int
    evaluations: int
    converged: bool
    status: str
    seconds: float
    history: list = field(default_factory=list)


@dataclass
class CandidateStrip:
    """An optimised pose of the tool on the flank: ``pose`` (:class:`ConePose`), its Eq. (8)
    parameters, the seed it came from, the errors along the axis and the convergence record."""
    pose: ConePose
    params: np.ndarray
    seed: SeedPose
    errors: AxisErrors
    convergence: Convergence
    flank: int = -1
    tool_index: int = 0          # which of the planner's tools (several: the largest first)

    @property
    def max_error(self):
        return self.errors.max_error

    @property
    def min_error(self):
        return self.errors.min_error

    def strip(self, flank=None, **extra):
        """flank-plan/1 strip dict (reported errors = the axis errors of Eq. (27))."""
        f = self.flank if flank is None else flank
        return self.pose.strip(f, max_error=self.max_error, min_error=self.min_error, **extra)


def _lp_steps(e, J, delta, w, eq=None):
    """Minimisers dx (k, 4) of the linearised weighted L1 objectives sum rho(e_i + J_i dx),
    rho(a) = max(a, -w a), over the boxes |dx_j| <= delta_k (one sparse block LP for all k rows, HiGHS),
    and the model values there."""
    import scipy.sparse as sp
    from scipy.optimize import linprog

    k, n = e.shape
    blocks, rhs, bounds = [], [], []
    eye = sp.identity(n, format="csr")
    for i in range(k):
        Ji = sp.csr_matrix(J[i])
        blocks.append(sp.bmat([[Ji, -eye], [-w * Ji, -eye]], format="csr"))
        rhs.append(np.r_[-e[i], w * e[i]])
        bounds += [(-delta[i], delta[i])] * 4 + [(None, None)] * n
    c = np.tile(np.r_[np.zeros(4), np.ones(n)], k)
    A_eq = b_eq = None
    if eq is not None:
        # one linear equation g . dx = b per pose (the anchor of the contact depth)
        g, b = eq
        A_eq = sp.block_diag([sp.csr_matrix(np.r_[g[i], np.zeros(n)][None, :]) for i in range(k)], format="csr")
        b_eq = b
    res = linprog(c, A_ub=sp.block_diag(blocks, format="csr"), b_ub=np.concatenate(rhs), A_eq=A_eq, b_eq=b_eq,
                  bounds=bounds, method="highs")
    if res.status != 0:
        return np.zeros((k, 4)), None
    z = res.x.reshape(k, 4 + n)
    dx = z[:, :4]
    a = e + np.einsum("kni,ki->kn", J, dx)
    return dx, np.sum(np.where(a >= 0, a, -w * a), axis=1)


def _slp_weighted_l1(fun, X0, w=W_OVERCUT, max_iter=40, delta0=0.05, scale=1.0, tol=1e-13, anchor=None):
    """Minimise the weighted L1 objective sum_i rho(e_i(x)), rho(a) = max(a, -w a) (Eqs. (25), (31))
    for every row of X0 (N, 4) at once by sequential linear programming in a box trust region: each
    step minimises the objective of the linearised errors e + J dx exactly (an LP), the step is taken
    when the true objective falls, the box grows or shrinks with the ratio of true to predicted
    decrease.  Near a minimum the LP picks the samples where the error vanishes and the steps become
    Newton steps on them.  ``fun(X, idx)`` returns e (k, n) and de/dx (k, n, 4) for rows X (k, 4) of
    poses idx (nan errors are ignored).  Returns X, iterations (N,), evaluations, histories,
    converged (N,).  ``anchor`` = (function X -> (values, gradients), targets (N,)): one equality kept
    (linearised) in every step."""
    X = np.array(X0, float)
    N = len(X)
    delta = np.full(N, delta0 * scale)
    active = np.ones(N, bool)
    converged = np.zeros(N, bool)
    iters = np.zeros(N, int)
    clean = lambda e, J: (np.nan_to_num(e, nan=0.0), np.where(np.isnan(e)[..., None], 0.0, J))  # noqa: E731
    e, J = clean(*fun(X, np.arange(N)))
    phi = weighted_l1(e, w)
    hist = [[float(v)] for v in phi]
    evals = 1
    for _ in range(max_iter):
        ia = np.flatnonzero(active)
        if not len(ia):
            break
        eq = None
        if anchor is not None:
            rv, gv = anchor[0](X[ia], ia)
            eq = (gv, anchor[1][ia] - rv)
        dx, model = _lp_steps(e[ia], J[ia], delta[ia], w, eq)
        if model is None:           # LP failure (should not happen): stop these poses where they are
            active[ia] = False
            break
        pred = phi[ia] - model
        done = pred <= tol * (1.0 + phi[ia])
        for k in np.flatnonzero(done):
            active[ia[k]] = False
            converged[ia[k]] = True
        go = np.flatnonzero(~done)
        if not len(go):
            continue
        ib = ia[go]
        Xt = X[ib] + dx[go]
        et, Jt = clean(*fun(Xt, ib))
        evals += 1
        pt = weighted_l1(et, w)
        ratio = (phi[ib] - pt) / pred[go]
        step = np.max(np.abs(dx[go]), axis=1)
        for k, i in enumerate(ib):
            iters[i] += 1
            if ratio[k] > 1e-4:
                X[i], e[i], J[i], phi[i] = Xt[k], et[k], Jt[k], pt[k]
                hist[i].append(float(pt[k]))
            if ratio[k] < 0.25:
                delta[i] = 0.25 * step[k]
            elif ratio[k] > 0.75 and step[k] > 0.99 * delta[i]:
                delta[i] = min(2.0 * delta[i], 0.5 * scale)
            if delta[i] < 1e-13 * scale:
                active[i] = False
                converged[i] = True
    return X, iters, evals, hist, converged


class _Lockstep:
    """Batches the evaluations of N optimisations that run side by side, one thread each.

    Every run asks for the values at its next point and waits; when every run that is still going
    has asked, the calling thread evaluates all the points together by ``batch(X (k, n), ids (k,))``
    and the runs go on.  So N independent SLSQP runs cost one vectorised foot-point call per round
    instead of N, and each run's iterates are exactly those of its own ``scipy.optimize.minimize``
    call wherever ``batch`` gives a run the values it would give it alone.  The pose optimiser's batch
    does not quite: a round pads its poses' sample rows to the longest among them and keys their warm
    starts by that width, so which runs share a round is part of its numerical path.

    Each run waits at its own gate (a lock the server opens with its answer) and the server at another
    that the last run to ask opens: one thread woken per hand-over.  A shared condition woke every
    waiting run at every answer and every question, 2.4 ms per round for 18 runs."""

    def __init__(self, batch, n_runs):
        self.batch = batch
        self.running = n_runs
        self.asked = {}
        self.answers = {}
        self.error = None
        self.evaluations = 0
        self.mutex = threading.Lock()
        self.gates = [threading.Lock() for _ in range(n_runs)]
        for gate in self.gates:
            gate.acquire()
        self.server_gate = threading.Semaphore(0 if n_runs else 1)

    def _round_ready(self):
        """Under the mutex: every run still going has asked (or none is left): the server's turn."""
        return len(self.asked) == self.running

    def values(self, i, x):
        """Called by run ``i``: its values at ``x`` once the round is evaluated."""
        with self.mutex:
            if self.error is not None:
                raise self.error
            self.asked[i] = np.array(x, float)
            ready = self._round_ready()
        if ready:
            self.server_gate.release()
        self.gates[i].acquire()
        with self.mutex:
            if self.error is not None:
                raise self.error
            return self.answers.pop(i)

    def finished(self):
        with self.mutex:
            self.running -= 1
            ready = self._round_ready()
        if ready:
            self.server_gate.release()

    def serve(self):
        """Evaluate rounds until every run has finished (in the calling thread, so that all numerics run
        where a single-pose call would)."""
        while True:
            self.server_gate.acquire()
            with self.mutex:
                if not self.running:
                    return
                ids = np.array(sorted(self.asked))
                X = np.array([self.asked[i] for i in ids])
                self.asked = {}
            try:
                f, g, c, dc = self.batch(X, ids)
            except BaseException as ex:       # every waiting run stops with the same error
                with self.mutex:
                    self.error = ex
                for i in ids:
                    self.gates[int(i)].release()
                return
            with self.mutex:
                self.evaluations += 1
                for k, i in enumerate(ids):
                    self.answers[int(i)] = (f[k], g[k], c[k], dc[k])
            for i in ids:
                self.gates[int(i)].release()


def _slsqp_lockstep(batch, X0, m, meq, maxiter=60, ftol=1e-13):
    """``scipy.optimize.minimize(method="SLSQP")`` on N independent problems at once: every round, the
    poses that ask for an evaluation are evaluated together by ``batch(X (k, 4), ids (k,))`` ->
    (f (k,), grad (k, 4), cons (k, m), dcons (k, m, 4)) (the first ``meq`` constraints are equalities,
    the rest must be >= 0), so the foot points of all poses are solved in one vectorised call
    (:class:`_Lockstep`).  m: constraint count per pose (int or (N,)).  Returns X, iterations (N,),
    evaluation rounds, exit statuses (N,) (scipy's SLSQP exit modes: 0 = converged) and messages."""
    from scipy.optimize import minimize

    X0 = np.atleast_2d(np.asarray(X0, float))
    N = len(X0)
    ms = np.broadcast_to(np.asarray(m, int), (N,))
    step = _Lockstep(batch, N)
    results, errors = [None] * N, []

    def run(i):
        mi = int(ms[i])
        last = {}

        def get(x):
            key = x.tobytes()
            if key not in last:
                last.clear()
                f, g, c, dc = step.values(i, x)
                last[key] = (f, g, np.asarray(c[:mi], float), np.asarray(dc[:mi], float))
            return last[key]

        cons = []
        if meq:
            cons.append({"type": "eq", "fun": lambda x: get(x)[2][:meq], "jac": lambda x: get(x)[3][:meq]})
        if mi > meq:
            cons.append({"type": "ineq", "fun": lambda x: get(x)[2][meq:], "jac": lambda x: get(x)[3][meq:]})
        try:
            results[i] = minimize(lambda x: get(x)[0], X0[i].copy(), jac=lambda x: get(x)[1], method="SLSQP",
                                  constraints=cons, options={"maxiter": int(maxiter), "ftol": ftol})
        except BaseException as ex:
            errors.append(ex)
        finally:
            step.finished()

    threads = [threading.Thread(target=run, args=(i,), daemon=True) for i in range(N)]
    for t in threads:
        t.start()
    step.serve()
    for t in threads:
        t.join()
    if step.error is not None:
        raise step.error
    if errors:
        raise errors[0]
    X = np.array([r.x for r in results])
    return (X, np.array([r.nit for r in results]), step.evaluations, np.array([r.status for r in results]),
            [str(r.message) for r in results])


def _dense_minima(ev, X, n_dense=801, warm_from=None, near=None, iters=40, branch=None):
    """Local minima of the error along the axis of every pose at once: e(s) (or, with ``branch``,
    the characteristic distance f(s)) on a dense grid of n_dense axis parameters for all poses in
    one foot-point call (warm-started by interpolating ``warm_from`` = (s, (u, tau) (N, n)) of a
    coarser evaluation), then every grid local minimum below ``near`` (default 1e-7 R) refined by
    Illinois regula falsi on de/ds = L g . a - (r2S - r1S) in its grid bracket (all brackets of all
    poses in one call per iteration, each warm-started from its previous foot).

    Returns (minima, dense_min): per pose an array (k, 2) of (s, e) at the refined minima, and the
    smallest e per pose (grid and refined)."""
    X = np.atleast_2d(np.asarray(X, float))
    N = len(X)
    R = ev.surface.outer_radius
    near = 1e-7 * R if near is None else near
    sd = np.linspace(0.0, 1.0, n_dense)
    warm = None
    if warm_from is not None and warm_from[1] is not None:
        sb, (ub, tb) = warm_from
        warm = (np.array([np.interp(sd, sb, ub[i]) for i in range(N)]),
                np.array([np.interp(sd, sb, tb[i]) for i in range(N)]))
    tool = ev.tool
    rp = tool.r2s - tool.r1s
    if branch is not None:
        raise NotImplementedError("dense minima of the characteristic distance")
    e, _, info = ev.distances(X, sd, key=None, jac=False, warm=warm)
    a_ax = axis_and_jacobian(X, sd[:1], ev.L)[2]                       # (N, 3)
    h = ev.L * np.einsum("Nni,Ni->Nn", info["g"], a_ax) - rp           # de/ds on the grid
    left = np.c_[np.ones((N, 1), bool), e[:, 1:] <= e[:, :-1]]
    right = np.c_[e[:, :-1] <= e[:, 1:], np.ones((N, 1), bool)]
    pi, ki = np.nonzero((e < near) & left & right)
    out = [np.zeros((0, 2)) for _ in range(N)]
    emin = e.min(axis=1)
    if not len(pi):
        return out, emin
    # brackets [s_(k-1), s_(k+1)]; at the axis ends the end itself when e rises into the axis
    ka, kb = np.maximum(ki - 1, 0), np.minimum(ki + 1, n_dense - 1)
    a, b = sd[ka].copy(), sd[kb].copy()
    ha, hb = h[pi, ka].copy(), h[pi, kb].copy()
    best_s, best_e = sd[ki].copy(), e[pi, ki].copy()
    wu, wt = info["warm"]
    fu, ft = wu[pi, ki].copy(), wt[pi, ki].copy()
    end0 = (ki == 0) & (h[pi, 0] >= 0)
    end1 = (ki == n_dense - 1) & (h[pi, -1] <= 0)
    todo = ~end0 & ~end1 & (ha < 0) & (hb > 0)
    side = np.zeros(len(pi))
    s_tol = 1e-13
    for _ in range(iters):
        act = np.flatnonzero(todo & (b - a > s_tol))
        if not len(act):
            break
        m = false_position(a[act], b[act], ha[act], hb[act])
        em, _, inf2 = ev.distances(X[pi[act]], m[:, None], key=None, jac=False,
                                   warm=(fu[act, None], ft[act, None]))
        em = em[:, 0]
        hm = ev.L * np.einsum("ki,ki->k", inf2["g"][:, 0], a_ax[pi[act]]) - rp
        fu[act], ft[act] = inf2["warm"][0][:, 0], inf2["warm"][1][:, 0]
        better = em < best_e[act]
        best_s[act[better]], best_e[act[better]] = m[better], em[better]
        # Illinois on h: keep the sign change bracketed
        a[act], ha[act], b[act], hb[act], side[act] = illinois_update(a[act], ha[act], b[act], hb[act], m, hm,
                                                                      side[act])
        todo[act[hm == 0]] = False
    for i in range(N):
        sel = pi == i
        if sel.any():
            out[i] = np.unique(np.c_[best_s[sel], best_e[sel]], axis=0)
            emin[i] = min(emin[i], float(best_e[sel].min()))
    return out, emin


def _hard_lift(ev, X, ids, S, anchor, cons_fun, delta, margin=0.0, scale=None):
    """Batched feasibility restoration for the hard mode: the smallest step (L1 norm of dx / delta)
    that makes the linearised constraints >= margin at each pose's samples S (base samples + refined
    local minima of the error along the axis), with the anchor (if any) linearised and |dx_j| <= delta_i;
    one sparse block LP (HiGHS) for all poses.  Elastic: one slack t_i >= 0 per pose relaxes its
    constraints at a high price, so a box too small for one pose never makes the whole LP infeasible.
    The rows are scaled by ``scale`` (k,) (the dip depths) and the unknowns by delta, so HiGHS's 1e-7
    feasibility tolerance means 1e-7 of the dip depth.  The dips left after the exchange rounds are
    ~1e-9 R, so the step and its linearisation error (~1e-16 R) are negligible for the objective.
    Returns dx (k, 4) and the slacks (k,) (> 0: the box was too small for that pose)."""
    import scipy.sparse as sp
    from scipy.optimize import linprog

    k = len(ids)
    delta = np.asarray(delta, float)
    _, _, c, dc, mask = cons_fun(X, ids, S)
    sc = np.ones(k) if scale is None else np.asarray(scale, float)
    blocks, rhs, bounds, eq_rows, eq_b = [], [], [], [], []
    for j in range(k):
        Aj = dc[j][mask[j]] * (delta[j] / sc[j])
        blocks.append(sp.csr_matrix(np.c_[-Aj, Aj, -np.ones(len(Aj))]))    # y = p - q; e + J dx + t >= margin
        rhs.append((c[j][mask[j]] - margin) / sc[j])
        bounds += [(0.0, 1.0)] * 8 + [(0.0, None)]
        if anchor is not None:
            rv, gv = anchor[0](X[j:j + 1], ids[j:j + 1])
            gj = gv[0] * delta[j] / sc[j]
            eq_rows.append(np.r_[gj, -gj, 0.0])
            eq_b.append((anchor[1][ids[j]] - rv[0]) / sc[j])
    A_eq = b_eq = None
    if anchor is not None:
        A_eq = sp.block_diag([sp.csr_matrix(r[None, :]) for r in eq_rows], format="csr")
        b_eq = np.array(eq_b)
    cost = np.tile(np.r_[np.ones(8), 1e4], k)
    res = linprog(cost, A_ub=sp.block_diag(blocks, format="csr"), b_ub=np.concatenate(rhs),
                  A_eq=A_eq, b_eq=b_eq, bounds=bounds, method="highs")
    if res.status != 0:
        return np.zeros((k, 4)), np.full(k, np.inf)
    z = res.x.reshape(k, 9)
    return (z[:, :4] - z[:, 4:8]) * delta[:, None], z[:, 8]


def anchor_parameters(anchor, N):
    """Axis parameters (N,) of the anchored points of N poses (:func:`optimize_poses`): None for no anchor,
    the midpoints (0.5) for True, else one value per pose (the seeds' contact parameters)."""
    if anchor is None or anchor is False:
        return None
    if anchor is True:
        return np.full(N, 0.5)
    a = np.broadcast_to(np.asarray(anchor, float), (N,)).copy()
    if not np.all(np.isfinite(a)):
        raise ValueError(f"anchor axis parameters must be finite, got {a}")
    return a


def optimize_poses(ev, X0, objective="phi1", mode="weighted", w=W_OVERCUT, max_iter=40, anchor=True,
                   exchange_rounds=2, max_rounds=4, n_dense=801, pin_contact=False):
    """Optimise the poses X0 (N, 4) (Eq. (8) parameters) of ``ev``'s tool on its flank.

    objective 'phi1' (Eq. (25)) or 'phi3' (Eq. (31)); mode 'weighted' (overcut weight w) or 'hard'
    (no point of the tool axis' spheres inside the flank, Eq. (30) style, checked densely).  With
    ``anchor`` the distance of the axis midpoint from z stays that of X0 (the pose may not slide to
    another depth of the flank, so the seeds keep covering the flank); without it the poses are free
    local minima of Phi.  ``anchor`` may also give one axis parameter per pose (the point whose distance
    from z is kept: a seed's contact sphere, :attr:`SeedPose.contact_s`).  ``pin_contact`` (hard mode, with
    an anchor): that sphere's error joins the objective with weight :data:`PIN_WEIGHT` (four times the
    mean of all the others), so the strip keeps touching the flank at its seed unless that costs more than
    the rest of the axis gains (what a seed placed in a gap of the cover is for; an equality here would
    make the constraints near the contact degenerate and SLSQP slow).
    Returns (X (N, 4), [Convergence], branches (N,) or None).

    All poses are optimised together: stage 1 is scipy's SLSQP run on every pose in lockstep
    (:func:`_slsqp_lockstep`: one foot-point call per evaluation round for all poses), minimising the
    mean error subject to error >= 0 at the axis samples.  Hard mode then checks every pose on a dense
    grid of ``n_dense`` axis parameters (one call for all poses, local minima refined on de/ds,
    :func:`_dense_minima`) and removes what dips below the flank by batched LP steps with the near-active
    minima as extra constraints (:func:`_hard_lift`), at most ``max_rounds`` times.  Weighted mode
    polishes the weighted L1 objective itself by sequential LP (:func:`_slp_weighted_l1`)."""
    if objective not in OBJECTIVES:
        raise ValueError(f"objective {objective!r} is not one of {', '.join(OBJECTIVES)}")
    if mode not in MODES:
        raise ValueError(f"mode {mode!r} is not one of {', '.join(MODES)}")
    t0 = time.perf_counter()
    X0 = np.atleast_2d(np.asarray(X0, float))
    N = len(X0)
    R = ev.surface.outer_radius
    branch = ev.branch(X0) if objective == "phi3" else None
    a_s = anchor_parameters(anchor, N)
    rho0 = None if a_s is None else mid_radius(X0, ev.L, a_s)[0]
    anc = None if rho0 is None else (lambda Xa, idx: mid_radius(Xa, ev.L, a_s[idx]), rho0)
    n = len(ev.s)
    pin = bool(pin_contact) and a_s is not None and mode == "hard"
    meq = 0 if a_s is None else 1
    constrain = "e" if (mode == "hard" or objective == "phi1") else "f"
    extra = [np.zeros(0) for _ in range(N)]          # hard mode: axis parameters added to the constraints
    nc = ev.n_clearance if mode == "hard" else 0     # rows keeping tool and shank out of the whole rotor

    def samples(ids):
        """Per-pose sample rows (k, M): the base samples, then the pose's extra ones (padded by
        repeating the last; ``mask`` marks the real ones)."""
        M = n + max((len(extra[i]) for i in ids), default=0)
        S = np.empty((len(ids), M))
        mask = np.zeros((len(ids), M), bool)
        for j, i in enumerate(ids):
            row = np.r_[ev.s, extra[i]]
            S[j, :len(row)], S[j, len(row):] = row, row[-1]
            mask[j, :len(row)] = True
        return S, mask

    def cons_fun(Xb, ids, S=None):
        """Objective (mean over the base samples), its gradient, the hard constraints and theirs."""
        if S is None:
            S, mask = samples(ids)
        else:
            S, mask = S
        # the pinned contact sphere rides along as one more column of the same foot-point call, and the whole
        # rotor's clearance rows are solved with them
        S_d = np.c_[S, a_s[ids]] if pin else S
        if nc:
            (e, de, _), (cc, dcc) = ev.distances_and_clearance(Xb, S_d, key=("opt", S_d.shape[1]), idx=ids,
                                                               clear_key=("opt", S.shape[1]))
        else:
            e, de, _ = ev.distances(Xb, S_d, key=("opt", S_d.shape[1]), idx=ids)
        if pin:
            pin_e, pin_de = e[:, -1], de[:, -1]
            e, de = e[:, :-1], de[:, :-1]
        if objective == "phi3":
            f, df, _ = ev.char_distances(Xb, branch[ids], S, key=("opt-f", S.shape[1]), idx=ids)
            real = np.isfinite(f)
            f0, df0 = np.where(real, f, 0.0), np.where(real[..., None], df, 0.0)
            val, grad = f0[:, :n].mean(axis=1), df0[:, :n].mean(axis=1)
            if constrain == "f":
                e, de = np.where(real, f0, 1.0), df0
        else:
            val, grad = e[:, :n].mean(axis=1), de[:, :n].mean(axis=1)
        if pin:
            val = val + PIN_WEIGHT * pin_e
            grad = grad + PIN_WEIGHT * pin_de
        if nc:
            # the whole rotor's clearance rows first (fixed count; the padded samples stay last)
            e, de = np.concatenate([cc, e], axis=1), np.concatenate([dcc, de], axis=1)
            mask = np.concatenate([np.ones(cc.shape, bool), mask], axis=1)
        return val, grad, e, de, mask

    def batch(Xb, ids):
        S, mask = samples(ids)
        val, grad, c, dc, _ = cons_fun(Xb, ids, (S, mask))
        if anc is not None:
            rv, gv = anc[0](Xb, ids)
            c = np.c_[(rv - anc[1][ids])[:, None], c]
            dc = np.concatenate([gv[:, None, :], dc], axis=1)
        return val, grad, c, dc

    phi0 = [phi_value(ev, X0[i], objective, w, None if branch is None else branch[i]) for i in range(N)]
    hist = [[p] for p in phi0]
    iters = np.zeros(N, int)
    status = [""] * N
    conv = np.zeros(N, bool)
    # stage 1 (both modes): SLSQP on the smooth constrained form, which follows the curved valley of
    # Phi (a pose that rolls along the flank) with its quasi-Newton Hessian
    X, nit, evals, modes, msgs = _slsqp_lockstep(batch, X0, n + nc + meq, meq, maxiter=60, ftol=1e-13)
    ok = modes == 0
    bad_x = ~np.all(np.isfinite(X), axis=1)
    X[bad_x] = X0[bad_x]
    iters += nit
    dips_left = np.zeros(N, bool)
    emin = np.zeros(N)
    if mode == "hard":
        tol = 1e-12 * R
        near = 1e-7 * R
        # exchange: every pose is checked on a dense axis grid (one call for all), the refined local
        # minima of its error below 1e-7 R join its constraints and SLSQP runs again (lockstep) on the
        # poses that dip; after ``exchange_rounds`` the dips left (~1e-9 R) are removed by the smallest
        # LP step (:func:`_hard_lift`), checked densely again
        active = np.arange(N)
        delta, grow = np.zeros(N), np.ones(N)
        for rnd in range(exchange_rounds + max_rounds + 1):
            Xa = X[active]
            _, _, inf0 = ev.distances(Xa, key=None, jac=False)
            mins, emin_a = _dense_minima(ev, Xa, n_dense, warm_from=(ev.s, inf0["warm"]), near=near)
            emin[active] = emin_a
            dipping = emin_a < -tol
            for j, i in enumerate(active):
                if dipping[j]:
                    mj = mins[j]
                    extra[i] = np.unique(np.r_[extra[i], mj[mj[:, 1] < near, 0]])
            if not dipping.any() or rnd == exchange_rounds + max_rounds:
                dips_left[active] = dipping
                break
            active = active[dipping]
            ids = active
            if rnd < exchange_rounds:
                ms = [n + nc + meq + len(extra[i]) for i in ids]
                Xs, nit2, ev2, _, _ = _slsqp_lockstep(lambda Xb, kk: batch(Xb, ids[kk]), X[ids], ms, meq,
                                                        maxiter=60, ftol=1e-13)
                good = np.all(np.isfinite(Xs), axis=1)
                X[ids[good]] = Xs[good]
                iters[ids] += nit2
                evals += ev2
                continue
            dip = -emin[ids]
            delta[ids] = np.minimum(100.0 * dip * grow[ids], 1e-2 * R)
            dx, slack = _hard_lift(ev, X[ids], ids, samples(ids), anc, cons_fun, delta[ids], margin=0.2 * tol,
                                   scale=dip)
            grow[ids] = np.where(slack > 1e-9, 10.0 * grow[ids], 1.0)
            X[ids] += dx
            iters[ids] += 1
            evals += 1
    for i in range(N):
        conv[i] = bool(ok[i]) and not dips_left[i]
        status[i] = "slsqp: " + msgs[i] + ("" if not dips_left[i] else
                                           f"; dips below the flank remain (min e {emin[i]:.2e})")
        if mode == "hard" and len(extra[i]) and not dips_left[i]:
            status[i] += f"; {len(extra[i])} dense minima constrained"
    times = np.full(N, (time.perf_counter() - t0) / N)
    for i in range(N):
        hist[i].append(phi_value(ev, X[i], objective, w, None if branch is None else branch[i]))
    if mode == "weighted":
        # stage 2: the weighted L1 objective itself, exactly (sequential LP, batched over the poses)
        th = time.perf_counter()
        if objective == "phi1":
            def fun(Xa, idx):
                e, de, _ = ev.distances(Xa, key="lm", idx=idx)
                return e, de
        else:
            def fun(Xa, idx):
                f, df, _ = ev.char_distances(Xa, branch[idx], key="lm", idx=idx)
                return f, df
        X, it2, ev2, hist2, conv2 = _slp_weighted_l1(fun, X, w, max_iter=max_iter, scale=R, delta0=1e-3,
                                                     anchor=anc)
        for i in range(N):
            iters[i] += it2[i]
            hist[i] += hist2[i][1:]
            conv[i] = bool(conv2[i])
            status[i] += "; lp polish: " + ("converged" if conv2[i] else "iteration limit")
        evals += ev2 * N
        times += (time.perf_counter() - th) / N
    out = []
    for i in range(N):
        phi_end = phi_value(ev, X[i], objective, w, None if branch is None else branch[i])
        out.append(Convergence(objective=objective, mode=mode, phi_start=phi0[i], phi_end=phi_end,
                               iterations=int(iters[i]), evaluations=int(evals), converged=bool(conv[i]),
                               status=status[i], seconds=float(times[i]), history=[float(v) for v in hist[i]]))
    return X, out, branch


# ============================================================================ candidate strips
def flank_range(surface_or_rotor_flanks, flank):
    """(u_start, u_end) of flank index ``flank`` from a rotor's flank list."""
    fl = list(surface_or_rotor_flanks)
    if not (0 <= int(flank) < len(fl)):
        raise ValueError(f"flank {flank} does not exist: the rotor has flanks 0..{len(fl) - 1}")
    return tuple(float(v) for v in fl[int(flank)])


def candidate_strips(surface, u_range, tool, n_seeds=18, objective="phi1", mode="weighted", w=W_OVERCUT,
                     n=100, along="profile", flank=-1, evaluator=None, max_iter=40, seeds=None, anchor=True,
                     optimizer=None, pin_contact=False):
    """Optimised candidate poses ("candidate strips") of a given cone on one flank.

    surface: :class:`HelicalSurface`; u_range: the flank's (u_start, u_end) (``Rotor.flanks[k]``);
    tool: :class:`ConeTool`; n_seeds flank samples (§5.1, ``along`` 'profile' | 'orthogonal'), the
    best admissible seed (Eq. (24), smallest seed Phi1) of each is optimised; objective 'phi1'
    (Eq. (25)) | 'phi3' (Eq. (31)); mode 'weighted' (overcut weight w, Remark 5.1) | 'hard' (Eq. (30)
    style: no overcut along the axis); n axis samples (the paper's 100); ``anchor``: keep each pose at
    its seed's depth on the flank (see :func:`optimize_poses`).  ``seeds``: explicit
    :class:`SeedPose` list instead of §5.1.  ``optimizer``: a function with the signature and result of
    :func:`optimize_poses` (default), e.g. :func:`fd_gradient_descent_poses` (the paper's optimiser) for
    benchmarks.  Returns a list of :class:`CandidateStrip` in flank order
    (samples without an admissible seed are skipped); each has ``pose`` (:class:`ConePose`), the
    errors along its axis (Eq. (27)) and a :class:`Convergence` record."""
    ev = evaluator or PoseEvaluator(surface, u_range, tool, n=n)
    if seeds is None:
        per = initial_positions(surface, u_range, tool, n_seeds, along=along, feet=ev.feet)
        seeds = [c[0] for c in per if c]
    if not seeds:
        return []
    X0 = np.array([sd.params for sd in seeds])
    if anchor is True:          # each pose keeps the depth of its seed's contact
        anchor = np.array([getattr(sd, "contact_s", 0.5) for sd in seeds])
    kw = {"pin_contact": True} if pin_contact else {}
    X, conv, branch = (optimizer or optimize_poses)(ev, X0, objective, mode, w, max_iter=max_iter, anchor=anchor,
                                                    **kw)
    out = []
    for i, sd in enumerate(seeds):
        errs = ev.axis_errors(X[i], branch=None if branch is None else branch[i])
        out.append(CandidateStrip(pose=params_pose(X[i], tool), params=X[i].copy(), seed=sd, errors=errs,
                                  convergence=conv[i], flank=int(flank)))
    return out


def single_flank_plan(surface, flank_ranges, flank, strips, tool, to_world=None, length_unit="R",
                      method=None, n_profile=2048, elapsed_s=0.0):
    """flank-plan/1 dict with the given :class:`CandidateStrip` list on target flank ``flank``
    (reported errors = the axis errors; verify with :func:`verify.verify_plan`)."""
    from ...io.plan import new_plan, rotor_section

    rot = rotor_section(surface.profile, surface.v0, surface.handedness, flank_ranges, to_world=to_world,
                        n_profile=n_profile)
    desc = tool.as_dict()
    mth = method or "single-flank-cone"
    return new_plan(mth, rot, desc, length_unit=length_unit, target_flanks=[int(flank)],
                    strips=[c.strip(int(flank)) for c in strips], elapsed_s=elapsed_s)


# ============================================================================ tool shape (§5.3)
@dataclass
class ToolFit:
    """Result of the tool-shape optimisation (§5.3): the fitted cone (same axis length L as the
    start tool), its pose, the distances d (n,) along the axis, the linear radial function
    r(s) = r1S + (r2S - r1S) s fitted below them (Eqs. (29)-(30)), errors e = d - r >= 0, Phi2 at the
    start and the end, and the convergence of the axis optimisation."""
    tool: ConeTool
    pose: ConePose
    params: np.ndarray
    s: np.ndarray
    d: np.ndarray
    r: np.ndarray
    e: np.ndarray
    phi2_start: float
    phi2_end: float
    r1s: float
    r2s: float
    iterations: int
    seconds: float
    seed: SeedPose = None
    constraints: list = field(default_factory=list)    # per admissibility row: value, limit, slack, active
    active: list = field(default_factory=list)         # names of the active rows at the optimum
    limits: dict = None                                # the limits used (and where they come from)
    rejected: list = field(default_factory=list)       # seeds whose fit was no cone or collided
    admissibility: str = None                          # the fitted cone against Eqs. (18)-(21), when bounds

    @property
    def max_error(self):
        return float(np.max(self.e))

    def summary(self):
        """JSON-ready: the cone, Phi2 start and end, error, constraints (which are active) and rejections."""
        return {"tool": self.tool.as_dict(), "r1s": self.r1s, "r2s": self.r2s, "max_error": self.max_error,
                "phi2_start": self.phi2_start, "phi2_end": self.phi2_end, "iterations": self.iterations,
                "constraints": self.constraints, "active": self.active,
                "limits": None if self.limits is None else dict(self.limits), "rejected": self.rejected,
                "admissibility": self.admissibility, "seconds": self.seconds}


def linear_fit_below(s, d):
    """The line r(s) = c0 + c1 s minimising sum (d_i - r(s_i)) subject to r(s_i) <= d_i (Eqs. (29)-(30);
    the absolute values of Eq. (29) equal d_i - r(s_i) under the constraint) and c0 >= 0 (a sphere radius):
    a 2-variable LP."""
    from scipy.optimize import linprog

    s, d = np.asarray(s, float), np.asarray(d, float)
    n = len(s)
    res = linprog(c=[-n, -float(s.sum())], A_ub=np.c_[np.ones(n), s], b_ub=d, bounds=[(0.0, None), (None, None)],
                  method="highs")
    if not res.success:
        raise ValueError(f"linear fit below the distances failed: {res.message}")
    c0, c1 = res.x
    # the LP's vertex touches two samples; make r <= d hold exactly in floating point
    c0 -= max(0.0, float(np.max(c0 + c1 * s - d)))
    return float(c0), float(c1)


def second_differences(n):
    """(n - 2, n) matrix of the second differences d_i - 2 d_(i+1) + d_(i+2) (Eq. (28))."""
    D = np.zeros((n - 2, n))
    i = np.arange(n - 2)
    D[i, i], D[i, i + 1], D[i, i + 2] = 1.0, -2.0, 1.0
    return D


def shape_constraints(d, J, L, a_min2, limits):
    """The admissibility rows (value >= 0 holds) of a tool made from the distances d (n,) along an axis of
    length L, and their Jacobians from J = dd/dx (n, 4): the spheres at the ends are the tool's r1S ~ d_0 and
    r2S ~ d_(n-1) (the fitted line lies below them, Eqs. (29)-(30)), so r1c <= r1S <= d_0 and the opening
    sin(alpha) = (d_(n-1) - d_0) / L (Eq. (3)).  ``limits``: r1_max, r2_max (Eq. (19)), d_depth (Eq. (20), or
    None), d_angle (Eq. (21)); a_min2: a_min^2 of Eq. (18) (None: no hyperbolic point).  Returns
    [(name, equation, value, limit, row, jac_row)]: row = the constraint's slack."""
    d0, d1 = float(d[0]), float(d[-1])
    g0, g1 = J[0], J[-1]
    rise = d1 - d0
    out = []
    if a_min2 is not None:
        out.append(("omega1", "Eq. (18)", 0.5 * (d0 + d1), a_min2, a_min2 - 0.5 * (d0 + d1), -0.5 * (g0 + g1)))
    out.append(("r1", "Eq. (19)", d0, limits["r1_max"], limits["r1_max"] - d0, -g0))
    out.append(("r2", "Eq. (19)", d1, limits["r2_max"], limits["r2_max"] - d1, -g1))
    if limits.get("d_depth") is not None and L > limits["d_depth"]:
        need = L * (L - limits["d_depth"])          # h = L - (r2S - r1S)^2 / L <= D_depth (Eqs. (7), (20))
        out.append(("omega2", "Eq. (20)", L - rise * rise / L, limits["d_depth"], rise * rise - need,
                    2.0 * rise * (g1 - g0)))
    sa = math.sin(limits["d_angle"])
    out.append(("angle", "Eq. (21)", rise / L, sa, sa * L - rise, g0 - g1))
    out.append(("cone", "Eq. (3), r1S < r2S", rise, 1e-6 * L, rise - 1e-6 * L, g1 - g0))
    # the tool outside the rotor (Eq. (30) with r >= 0, §5.5): an axis through the material also has linear
    # distances, a degenerate optimum of Phi2
    out.append(("outside", "Eq. (30), §5.5", d0, 0.0, d0, g0))
    return out


def optimize_tool_shape(surface, u_range, tool0, n=100, n_seeds=18, along="profile", top=4, max_nfev=200,
                        bounds=None, a_min=None, flank_ranges=None, flank=None):
    """Tool-shape optimisation of §5.3 on one flank, starting from cone ``tool0`` (Ex. 6.1: alpha = 0.25,
    r1c = 0.25, r2c = 0.5): initial poses of tool0 (§5.1), then for the ``top`` best-ranked seeds the axis
    (length L of tool0) minimising Phi2, the sum of squared second differences of the distances d_i along it
    (Eq. (28), squared: as printed the sum telescopes), by SLSQP with the exact gradient, then the linear
    radial function below the distances (Eqs. (29)-(30)).

    Phi2 alone is degenerate (an axis far from the flank sees almost linear distances); the only constraints
    are the paper's admissibility of the tool being made (§4, :func:`shape_constraints`): Eq. (18) with the
    a_min where the seed touches (the smallest transverse semi-axis of the Dupin hyperbolas between the feet
    of its axis samples, :func:`tooling.cutter_selection.dupin_analysis`: second-order line contact along
    the tool's contact, none where that part is elliptic; ``a_min``: one value for all), Eqs. (19)-(21) with the valley's bounds (``bounds``,
    :class:`tooling.cutter_selection.ValleyBounds`, e.g. from the custom double-flank tool; without them the
    start tool's circles stand in for c D_min, c D_max and Eq. (20) is left out) -- and collision (§5.5):
    with ``flank_ranges`` and ``flank`` every fitted tool is checked against the whole rotor and a colliding
    one is dropped, as the paper filters colliding positions.  The fit reports each constraint's value and
    limit and which are active (:attr:`ToolFit.constraints`, :attr:`ToolFit.active`).  Returns the
    :class:`ToolFit` with the smallest maximal error."""
    from ...tooling.cutter_selection import DEFAULT_D_ANGLE, dupin_analysis, is_admissible

    t0 = time.perf_counter()
    ev = PoseEvaluator(surface, u_range, tool0, n=n)
    per = initial_positions(surface, u_range, tool0, n_seeds, along=along, feet=ev.feet)
    seeds = sorted((c[0] for c in per if c), key=lambda c: c.phi)[:top]
    if not seeds:
        raise ValueError("no admissible initial pose of the start tool on this flank")
    from scipy.optimize import minimize

    dup = dupin_analysis(surface, u_range) if a_min is None else None

    def a_min_at(x):
        """a_min of Eq. (18) where the axis x touches: over the hyperbolic samples between the feet of its
        axis samples (a number given as ``a_min`` instead: that one); None where they are all elliptic."""
        if dup is None:
            return float(a_min) if math.isfinite(float(a_min)) else None
        _, _, info = ev.distances(x[None, :], key=None, jac=False)
        lo, hi = float(np.min(info["u"][0])), float(np.max(info["u"][0]))
        sel = dup.hyperbolic & (dup.u >= lo) & (dup.u <= hi)
        return float(np.nanmin(dup.a[sel])) if sel.any() else None
    if bounds is not None:
        limits = {"r1_max": bounds.r1_max, "r2_max": bounds.r2_max, "d_depth": bounds.d_depth,
                  "d_angle": bounds.d_angle, "source": getattr(bounds, "source", "given")}
    else:
        limits = {"r1_max": tool0.r1c, "r2_max": tool0.r2c, "d_depth": None, "d_angle": DEFAULT_D_ANGLE,
                  "source": "the start tool's circles (no valley bounds given)"}
    L = tool0.L
    D = second_differences(n) * (n - 1) ** 2          # d'' at the inner samples
    best, rejected = None, []
    for k, sd in enumerate(seeds):
        cache = {}
        am = a_min_at(sd.params)
        a_min2 = None if am is None else am * am

        def get(x, a_min2=a_min2):
            key = x.tobytes()
            if key not in cache:
                cache.clear()
                e, de, info = ev.distances(x[None, :], key="phi2", idx=[k])
                d, J = info["d"][0], de[0]
                q = D @ d / n
                rows = shape_constraints(d, J, L, a_min2, limits)
                cache[key] = (float(q @ q), 2.0 * (D @ J).T @ q / n, np.array([r[4] for r in rows]),
                              np.array([r[5] for r in rows]))
            return cache[key]

        cons = [{"type": "ineq", "fun": lambda x: get(x)[2], "jac": lambda x: get(x)[3]}]
        p0 = get(sd.params)[0]
        res = minimize(lambda x: get(x)[0], sd.params, jac=lambda x: get(x)[1], method="SLSQP",
                       constraints=cons, options={"maxiter": max_nfev, "ftol": 1e-16})
        x = res.x if np.all(np.isfinite(res.x)) else sd.params
        e, de, info = ev.distances(x[None, :], key=None, jac=True)
        d = info["d"][0]
        rows = shape_constraints(d, de[0], L, a_min2, limits)
        bad = [r for r in rows if r[4] < -1e-9 * max(1.0, abs(r[3]))]
        if bad:
            rejected.append({"seed_u": float(sd.u), "reason": "no admissible axis found: " + "; ".join(
                f"{nm} ({eq}) {v:.4g} against the limit {lim:.4g}" for nm, eq, v, lim, _, _ in bad)})
            continue
        try:
            c0, c1 = linear_fit_below(ev.s, d)
        except ValueError as ex:
            rejected.append({"seed_u": float(sd.u), "reason": str(ex)})
            continue
        if not c1 > 0:
            rejected.append({"seed_u": float(sd.u), "reason": "no cone: the fitted radii do not grow towards "
                                                               "the shank"})
            continue
        fit = (x, d, c0, c1, p0, get(x)[0], int(res.nit), sd, rows, am)
        if flank_ranges is not None and flank is not None:
            alpha = math.asin(min(1.0, c1 / L))
            cand = ConeTool(alpha, c0 * math.cos(alpha), (c0 + c1) * math.cos(alpha), tool0.shank_radius,
                            tool0.shank_length)
            from ...simulation.collision import check_collisions

            per_ = surface.profile.period
            nprof = 2048
            idx = [(int(round(a / per_ * nprof)), int(round(b / per_ * nprof))) for a, b in flank_ranges]
            rep = check_collisions([params_pose(x, cand)], surface.profile.sample(nprof), surface.v0,
                                   surface.handedness, idx, target_flanks=(int(flank),), tolerance=1e-6 *
                                   surface.outer_radius, model="spheres",
                                   spacing=max(0.25 * cand.r1c, 0.05 * cand.r2c, 1e-4 * surface.outer_radius))[0]
            if rep.collides:
                rejected.append({"seed_u": float(sd.u), "reason": "collides: " + ", ".join(
                    f"{c['part']} with flank {c['flank']} by {c['depth']:.3g}" for c in rep.collisions)})
                continue
        if best is None or np.max(d - c0 - c1 * ev.s) < np.max(best[1] - best[2] - best[3] * ev.s):
            best = fit
    if best is None:
        raise ValueError("tool-shape optimisation: no seed gave an admissible, collision-free cone ("
                         + "; ".join(r["reason"] for r in rejected) + ")")
    x, d, c0, c1, p0, p1, nfev, sd, rows, am = best
    r1s, r2s = c0, c0 + c1
    alpha = math.asin(min(1.0, c1 / L))                     # Eq. (3)
    tool = ConeTool(alpha, r1s * math.cos(alpha), r2s * math.cos(alpha), tool0.shank_radius, tool0.shank_length)
    r = c0 + c1 * ev.s
    scale = max(1e-9 * float(surface.outer_radius), 1e-9)
    cons = [{"name": nm, "equation": eq, "value": float(v), "limit": float(lim), "slack": float(sl),
             "active": bool(abs(sl) <= 1e-6 * max(abs(lim), scale))} for nm, eq, v, lim, sl, _ in rows]
    adm = None
    if bounds is not None and am is not None:
        adm = is_admissible(tool, am, bounds)
    if limits is not None:
        limits = dict(limits, a_min=am)
    return ToolFit(tool=tool, pose=params_pose(x, tool), params=x, s=ev.s.copy(), d=d, r=r, e=d - r,
                   phi2_start=p0, phi2_end=p1, r1s=r1s, r2s=r2s, iterations=nfev,
                   seconds=time.perf_counter() - t0, seed=sd, constraints=cons,
                   active=[c["name"] for c in cons if c["active"]], limits=limits, rejected=rejected,
                   admissibility=None if adm is None else adm.message)


# ============================================================================ the paper's optimiser (baseline)
def optimize_fd_gradient_descent(ev, x0, objective="phi1", w=W_OVERCUT, h=1e-6, eps=1e-5, step0=1e-3,
                                 max_iter=5000, branch=None, anchor=None, anchor_s=0.5):
    """Remark 5.1's optimiser, for benchmarks: gradient descent on Phi1 (or Phi3) with the gradient by
    forward finite differences (step h), stopped when two subsequent iterates differ by less than
    eps = 1e-5.  The step length adapts (x1.2 on success, /2 with a retry on failure).  ``anchor``: a
    radius (see :func:`mid_radius`) of the axis point o(``anchor_s``) to keep, by eliminating delta (the descent
    then runs on (rho, beta, phi)).  Returns (x, iterations, evaluations)."""
    x = np.asarray(x0, float).copy()
    if objective == "phi3" and branch is None:
        branch = ev.branch(x[None, :])[0]
    key = ("fd", objective)
    if anchor is not None:
        full0, sgn = x.copy(), (1.0 if x[0] >= 0 else -1.0)

        def full(y):
            q = anchor ** 2 - ((y[0] + anchor_s * ev.L) * math.cos(y[1])) ** 2
            return np.r_[sgn * math.sqrt(max(q, 0.0)), y]
        x = full0[1:].copy()
    else:
        full = lambda y: y  # noqa: E731
    nv = len(x)

    def phi(yy):
        X = full(yy)[None, :]
        if objective == "phi1":
            e = ev.distances(X, key=key, jac=False)[0]
        else:
            e = ev.char_distances(X, np.atleast_1d(branch), key=key)[0]
        return float(weighted_l1(e, w)[0])

    f = phi(x)
    evals, step, it = 1, step0, 0
    for it in range(1, max_iter + 1):
        g = np.empty(nv)
        for j in range(nv):
            xp = x.copy()
            xp[j] += h
            g[j] = (phi(xp) - f) / h
        evals += 4
        gn = float(np.linalg.norm(g))
        if gn == 0:
            break
        while True:
            xn = x - step * g / gn
            fn = phi(xn)
            evals += 1
            if fn < f or step < 1e-12:
                break
            step *= 0.5
        moved = float(np.linalg.norm(xn - x))
        if fn < f:
            x, f = xn, fn
            step *= 1.2
        if moved < eps:
            break
    return full(x), it, evals


def fd_gradient_descent_poses(ev, X0, objective="phi1", mode="weighted", w=W_OVERCUT, max_iter=40, anchor=True,
                              eps=1e-5, fd_max_iter=5000, pin_contact=False):
    """The paper's optimiser (:func:`optimize_fd_gradient_descent`, Remark 5.1: FD gradient descent on
    the weighted Phi1 / Phi3, stopped at |x_(i+1) - x_i| < eps) on every pose, one after the other,
    with the signature and result of :func:`optimize_poses`, for ``candidate_strips(optimizer=...)``.
    ``mode`` is ignored (the paper's objective has no hard constraint; its weight w = 100 is the only
    guard against overcuts); ``anchor`` keeps each pose's mid radius (delta eliminated); ``pin_contact`` and the
    clearance rows of the evaluator are not part of the paper's method and are ignored."""
    X0 = np.atleast_2d(np.asarray(X0, float))
    branch = ev.branch(X0) if objective == "phi3" else None
    a_s = anchor_parameters(anchor, len(X0))
    rho0 = None if a_s is None else mid_radius(X0, ev.L, a_s)[0]
    X = X0.copy()
    out = []
    for i in range(len(X0)):
        th = time.perf_counter()
        br = None if branch is None else branch[i]
        p0 = phi_value(ev, X0[i], objective, w, br)
        x, it, nev = optimize_fd_gradient_descent(ev, X0[i], objective, w, eps=eps, max_iter=fd_max_iter, branch=br,
                                                  anchor=None if rho0 is None else float(rho0[i]),
                                                  anchor_s=0.5 if a_s is None else float(a_s[i]))
        X[i] = x
        p1 = phi_value(ev, x, objective, w, br)
        out.append(Convergence(objective=objective, mode="weighted", phi_start=p0, phi_end=p1, iterations=int(it),
                               evaluations=int(nev), converged=it < fd_max_iter,
                               status=f"fd gradient descent (Remark 5.1, eps {eps:g})",
                               seconds=time.perf_counter() - th, history=[p0, p1]))
    return X, out, branch
