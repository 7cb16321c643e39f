"""Sweep simulation vs an independent brute force: rays against densely sampled, screwed tool spheres."""
import numpy as np
import pytest
from scipy.optimize import minimize

from flank_addon.screw import hand_sign
from flank_addon.sweep import StripTool, helical_distance, machined_deviation, sd_sphere_frustum


def ray_intervals(p, n, c1, r1, c2, r2, v0, hand, t, s):
    """lambda-intervals of the ray p + lambda n (plane z = 0) removed by spheres (s) at times (t)."""
    h = hand_sign(hand)
    T, S = np.meshgrid(t, s, indexing="ij")
    ct, st = np.cos(h * T), np.sin(h * T)
    o = np.stack([ct * p[0] - st * p[1], st * p[0] + ct * p[1], v0 * T], -1)   # S_t(p)
    d = np.stack([ct * n[0] - st * n[1], st * n[0] + ct * n[1], np.zeros_like(T)], -1)
    C = (1 - S)[..., None] * c1 + S[..., None] * c2
    r = (1 - S) * r1 + S * r2
    w = o - C
    b = np.einsum("...i,...i->...", w, d)
    c = np.einsum("...i,...i->...", w, w) - r * r
    disc = b * b - c
    ok = disc >= 0
    sq = np.sqrt(np.where(ok, disc, 0))
    return (-b - sq)[ok], (-b + sq)[ok], T[ok], S[ok]


def brute_deviation(p, n, c1, r1, c2, r2, v0, hand, n_t=3000, n_s=300):
    z_lo = min(c1[2] - r1, c2[2] - r2)
    z_hi = max(c1[2] + r1, c2[2] + r2)
    t = np.linspace(z_lo / v0, z_hi / v0, n_t)
    s = np.linspace(0, 1, n_s)
    lo, hi, T, S = ray_intervals(p, n, c1, r1, c2, r2, v0, hand, t, s)
    if not len(lo):
        return np.inf
    inside = (lo <= 0) & (hi >= 0)
    if inside.any():   # overcut: lower end of the removed component containing lambda = 0
        order = np.argsort(lo)
        lo_s, hi_s = lo[order], hi[order]
        reach = np.maximum.accumulate(hi_s)
        comp_start = np.flatnonzero(np.r_[True, lo_s[1:] > reach[:-1]])
        k = comp_start[np.searchsorted(comp_start, np.flatnonzero(lo_s <= 0)[-1], side="right") - 1]
        cand = order[k]
        sign = -1
    else:              # material left: first removal along the ray
        pos = np.flatnonzero(lo > 0)
        cand = pos[np.argmin(lo[pos])]
        sign = 1

    def lower_end(x):
        tt, ss = x[0], np.clip(x[1], 0, 1)
        l_, _, _, _ = ray_intervals(p, n, c1, r1, c2, r2, v0, hand, np.array([tt]), np.array([ss]))
        return l_[0] if len(l_) else np.inf

    res = minimize(lower_end, [T[cand], S[cand]], method="Nelder-Mead",
                   options={"xatol": 1e-12, "fatol": 1e-14, "maxiter": 4000})
    val = min(res.fun, lo[cand])
    assert np.sign(val) in (sign, 0) or abs(val) < 1e-9
    return val


def test_sphere_frustum_distance_matches_union_of_spheres():
    rng = np.random.default_rng(0)
    c1, c2, r1, r2 = np.array([0.1, 0.2, 0.0]), np.array([0.3, -0.1, 0.5]), 0.05, 0.12
    q = rng.uniform(-0.5, 0.8, (1500, 3))
    d = sd_sphere_frustum(q, c1, r1, c2, r2)
    s = np.linspace(0, 1, 20001)[:, None]
    C, R = (1 - s) * c1 + s * c2, (1 - s[:, 0]) * r1 + s[:, 0] * r2
    best = np.full(len(q), np.inf)
    for i in range(0, len(C), 2000):
        best = np.minimum(best, (np.linalg.norm(q[:, None] - C[None, i:i + 2000], axis=2) - R[None, i:i + 2000]).min(1))
    out = best > 0
    assert np.max(np.abs(d[out] - best[out])) < 1e-8
    assert np.array_equal(d < 0, best < 0)


@pytest.mark.parametrize("hand", ["right", "left"])
def test_deviation_matches_brute_force_on_random_cone_poses(hand):
    rng = np.random.default_rng(11 if hand == "right" else 12)
    v0 = 0.45
    errors = []
    for _ in range(5):
        c1 = np.r_[rng.uniform(0.5, 0.7), rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1)]
        c2 = c1 + np.r_[rng.uniform(0.1, 0.3), rng.uniform(-0.2, 0.2), rng.uniform(0.2, 0.4)]
        r1, r2 = rng.uniform(0.04, 0.08), rng.uniform(0.09, 0.15)
        tool = StripTool(c1, c2, [r1, r2])
        # design points around the swept region, normals pointing roughly at it
        ang = rng.uniform(-0.6, 0.6, 6)
        rad = rng.uniform(0.35, 0.6, 6)
        pts = np.c_[rad * np.cos(ang), rad * np.sin(ang)]
        nrm = np.c_[np.cos(ang), np.sin(ang)]
        dev = machined_deviation([tool], pts, nrm, v0, hand, max_deviation=1.0)
        for p, n, d in zip(pts, nrm, dev):
            ref = brute_deviation(p, n, c1, r1, c2, r2, v0, hand)
            assert np.isfinite(ref) == np.isfinite(d), (p, d, ref)   # both reach the surface or neither
            if np.isfinite(ref):
                errors.append(abs(d - ref))
    assert len(errors) >= 12
    assert max(errors) < 1e-7, max(errors)


def test_overcut_is_negative_and_uncut_is_inf():
    v0 = 0.5
    tool = StripTool([0.8, 0.0, 0.0], [0.8, 0.0, 0.3], [0.1, 0.1])
    # a point inside the swept region (on the tool axis at t = 0) is overcut; one far away is never reached
    dev = machined_deviation([tool], np.array([[0.8, 0.0], [-0.5, 0.0]]), np.array([[1.0, 0.0], [-1.0, 0.0]]),
                             v0, "right", max_deviation=0.3)
    assert dev[0] < 0 and np.isinf(dev[1])
    d, _ = helical_distance(tool, np.array([[0.8, 0.0, 0.0], [0.8, 0.0, 5.0]]), v0)
    assert d[0] < 0 and d[1] > 0
