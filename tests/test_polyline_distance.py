"""Exact distances to long polylines (geometry/polyline_distance.py) against brute force over every edge."""
import numpy as np
import pytest

from flank_addon.geometry.polyline_distance import PolylineDistance


def segment_distance(P, q, edge):
    """Distance from each point q[i] to the edge edge[i] of P (its own closest point, clipped to the edge)."""
    a, e = P[edge], P[edge + 1] - P[edge]
    w = q - a
    u = np.clip(np.einsum("nj,nj->n", w, e) / np.einsum("nj,nj->n", e, e), 0.0, 1.0)
    return np.linalg.norm(w - u[:, None] * e, axis=1)


def brute(P, q, chunk=128):
    """Distance from each point to the polyline: the least over every edge.  Rows of ``chunk`` points keep the
    (points x edges) arrays in the cache; the result is the same bit for bit as in one block."""
    a, e = P[:-1], np.diff(P, axis=0)
    ee = np.einsum("kj,kj->k", e, e)
    out = np.empty(len(q))
    for i in range(0, len(q), chunk):
        w = q[i:i + chunk, None, :] - a[None]
        u = np.clip(np.einsum("nkj,kj->nk", w, e) / ee, 0.0, 1.0)
        r = w - u[..., None] * e[None]
        out[i:i + chunk] = np.sqrt(np.min(r[..., 0] * r[..., 0] + r[..., 1] * r[..., 1], axis=1))
    return out


def polylines():
    rng = np.random.default_rng(3)
    out = {}
    # a dense meridian-like graph R(h) with a rounded tip, a kink and end faces
    h = np.r_[0.0, np.sort(rng.uniform(0, 1, 6000)), 1.0]
    R = 0.3 * np.sqrt(np.clip(h * (1.2 - h), 0, None)) + 0.05 * (h > 0.6)
    out["meridian"] = np.c_[np.r_[0.0, h, 1.0], np.r_[0.0, R, 0.0]]
    # a spiral (h not monotone), with clusters of tiny edges
    t = np.sort(np.r_[rng.uniform(0, 12, 3000), 5 + 1e-7 * np.arange(200)])
    out["spiral"] = np.c_[(0.2 + 0.05 * t) * np.cos(t), (0.2 + 0.05 * t) * np.sin(t)]
    # a few long edges
    out["coarse"] = np.c_[np.linspace(0, 1, 7), rng.uniform(0, 1, 7)]
    for k, P in out.items():            # no edge of zero length
        out[k] = P[np.r_[True, np.any(np.diff(P, axis=0) != 0, axis=1)]]
    return out


@pytest.mark.parametrize("name", ["meridian", "spiral", "coarse"])
def test_distance_equals_brute_force(name):
    P = polylines()[name]
    pl = PolylineDistance(P)
    rng = np.random.default_rng(7)
    span = np.ptp(P, axis=0).max()
    lo, hi = P.min(axis=0) - span, P.max(axis=0) + span
    near = P[rng.integers(0, len(P), 600)] + rng.normal(0, 1e-4 * span, (600, 2))
    q = np.r_[rng.uniform(lo, hi, (600, 2)), near, P[::97], 30 * span * rng.normal(size=(50, 2))]
    ref = brute(P, q)
    d, edge = pl.distance(q)
    assert np.max(np.abs(d - ref)) <= 1e-15 * span
    assert np.max(np.abs(segment_distance(P, q, edge) - ref)) <= 1e-15 * span
    # upper bounds and hints (right, wrong or far off) change nothing but the work
    d2, _ = pl.distance(q, ub=ref * 1.5 + 1e-9, hint=rng.integers(0, len(P) - 1, len(q)))
    assert np.max(np.abs(d2 - ref)) <= 1e-15 * span
    d3, _ = pl.distance(q, hint=edge)
    assert np.max(np.abs(d3 - ref)) <= 1e-15 * span


@pytest.mark.parametrize("name", ["meridian", "spiral"])
def test_signed_minimum_keeps_each_groups_least_value(name):
    P = polylines()[name]
    pl = PolylineDistance(P)
    rng = np.random.default_rng(11)
    span = np.ptp(P, axis=0).max()
    G, n = 80, 60
    # each group: samples along a random curve through the polyline's region
    c = P[rng.integers(0, len(P), G)]
    t = np.linspace(-1, 1, n)
    dirs = rng.normal(size=(G, 2))
    q = (c[:, None, :] + 0.3 * span * t[None, :, None] * dirs[:, None, :]
         + 0.05 * span * np.sin(7 * t)[None, :, None]).reshape(-1, 2)
    group = np.repeat(np.arange(G), n)
    inside = rng.random(len(q)) < 0.3
    ref = brute(P, q)
    s_ref = np.where(inside, -ref, ref)
    least = s_ref.reshape(G, n).min(axis=1)
    for thr0 in (np.full(G, np.inf), least + 1e-3 * span):
        thr = thr0.copy()
        s, exact = pl.signed_minimum(q, inside, group, thr, batch=1000)
        # exact rows are exact; the others lie above their group's least value and s bounds them from below
        assert np.max(np.abs(s[exact] - s_ref[exact])) <= 1e-15 * span
        assert np.all(s[~exact] <= s_ref[~exact] + 1e-15 * span)
        assert np.all(s[~exact] > least[group[~exact]])
        got = np.where(exact, s, np.inf).reshape(G, n).min(axis=1)
        assert np.max(np.abs(got - least)) <= 1e-15 * span
        assert np.all(thr >= least - 1e-15 * span)
        assert exact.sum() < len(q)


@pytest.mark.parametrize("n", [2, 3, 8, 9, 10, 64, 65, 513, 6203])
def test_every_run_of_edges_lies_within_its_chords_bound(n):
    """The hierarchy's pruning rests on each run of edges lying within ``fat`` of its chord (first to last
    vertex of the run) and its representative vertex lying on the run: checked vertex by vertex on every level,
    for lengths that end a run exactly, one vertex past it and in between."""
    P = polylines()["spiral"][:n] if n <= 3203 else polylines()["meridian"][:n]
    pd = PolylineDistance(P)
    ne = len(P) - 1
    size = 8
    for ax, ay, cx, cy, cc, fat, rx, ry in pd.levels:
        starts = np.arange(0, ne, size)
        assert len(ax) == len(starts)
        for k, s in enumerate(starts):
            e = min(s + size, ne)
            run = P[s:e + 1]
            np.testing.assert_array_equal([ax[k], ay[k], cx[k], cy[k]],
                                          [run[0, 0], run[0, 1], P[e, 0] - run[0, 0], P[e, 1] - run[0, 1]])
            chord = np.r_[P[s:s + 1], P[e:e + 1]]
            d = segment_distance(chord, run, np.zeros(len(run), int))
            assert d.max() <= fat[k] and fat[k] <= d.max() * (1 + 2e-9) + 1e-300
            assert any(np.array_equal([rx[k], ry[k]], v) for v in run)
        size *= 8
    assert len(pd.levels[-1][0]) <= 8
