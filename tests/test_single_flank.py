"""Bizzarri, Bo & Bartoň single-flank conical milling: seeds, pose optimisation, hard mode, tool shape (Phi2)."""
import math

import numpy as np
import pytest

from flank_addon.methods.single_flank import poses as sf
from flank_addon.tooling.cone import ConePose, ConeTool
from flank_addon.geometry.helical_surface import HelicalSurface
from flank_addon.io.plan import validate_plan
from flank_addon.geometry.profile import SplineProfile
from flank_addon.geometry.screw import screw_to_plane
from flank_addon.simulation.verify import verify_plan

EX62_TOOL = ConeTool(math.asin(0.3), 0.1, 0.18)         # Bizzarri, Bo & Bartoň Ex. 6.2 (female X1)


# ------------------------------------------------------------------ an exact envelope as the flank
def eq11_characteristic(tip, a, tool, s, v0, hand, side):
    """Bizzarri, Bo & Bartoň Eq. (11) at t = 0, written independently of the module: the envelope point of the sphere
    family (y(s), r(s)) on the axis under the screw (first parameter along the axis, second the screw)."""
    L = tool.L
    y = tip + (L * s)[:, None] * a
    ys = np.broadcast_to(L * a, y.shape)
    yt = np.stack([-hand * y[:, 1], hand * y[:, 0], np.full(len(s), v0)], -1)
    r, rp = tool.radius(s), tool.r2s - tool.r1s
    E, F, G = L * L, np.einsum("ij,ij->i", ys, yt), np.einsum("ij,ij->i", yt, yt)
    root = np.sqrt((E - rp ** 2) * G - F ** 2)
    num = rp * (G[:, None] * ys - F[:, None] * yt) + side * np.cross(ys, yt) * root[:, None]
    return y - r[:, None] * num / (E * G - F ** 2)[:, None]


def envelope_flank(x_true, tool, v0=0.9, hand=1, side=1, s_ext=(-0.35, 1.35), n=600, depth=0.4):
    """Helical surface whose flank is the surface swept by the characteristic of the cone at pose
    x_true (extended along the infinite cone), closed by a polyline on the material side."""
    pose = sf.params_pose(x_true, tool)
    c = eq11_characteristic(pose.tip, pose.axis, tool, np.linspace(*s_ext, n), v0, hand, side)
    P = screw_to_plane(c, v0, hand)
    m0 = screw_to_plane(pose.tip + 0.5 * tool.L * pose.axis, v0, hand)
    t = P[-1] - P[0]
    nrm = np.array([t[1], -t[0]])
    if (m0 - P[n // 2]) @ nrm < 0:           # outward (right-hand) normal must face the tool
        P, nrm = P[::-1], -nrm
    left = -nrm / np.linalg.norm(nrm)
    k = 40
    back = [P[-1] + left * depth * (j / k) for j in range(1, k + 1)]
    back += [P[-1] + left * depth + (P[0] - P[-1]) * (j / k) for j in range(1, k)]
    back += [P[0] + left * depth * (1 - j / k) for j in range(0, k)]
    prof = SplineProfile(np.vstack([P, np.array(back)]))
    surf = HelicalSurface(prof, v0, "right" if hand > 0 else "left")
    return surf, (float(prof.knots[0]), float(prof.knots[n - 1])), pose


X_TRUE = np.array([0.08, 0.3, -0.35, 0.4])


@pytest.fixture(scope="module", params=[(1, 1), (-1, -1)], ids=["right", "left-other-branch"])
def envelope(request):
    hand, side = request.param
    surf, ur, pose = envelope_flank(X_TRUE, EX62_TOOL, hand=hand, side=side)
    return surf, ur, pose, hand, side


def test_envelope_pose_has_zero_error_and_matching_characteristic(envelope):
    surf, ur, pose, hand, side = envelope
    ev = sf.PoseEvaluator(surf, ur, EX62_TOOL)
    err = ev.axis_errors(X_TRUE)
    assert err.interior.all()
    assert np.abs(err.e).max() < 1e-9
    b = ev.branch(X_TRUE[None])
    c, _, real = ev.characteristic(X_TRUE[None], b)
    assert real.all()
    ref = eq11_characteristic(pose.tip, pose.axis, EX62_TOOL, ev.s, surf.v0, hand, side)
    assert np.abs(c[0] - ref).max() < 1e-12
    # the wrong branch is far from the flank
    f_wrong = ev.char_distances(X_TRUE[None], -b)[0]
    assert np.nanmax(np.abs(f_wrong)) > 1e-2


@pytest.mark.parametrize("objective", sf.OBJECTIVES)
def test_envelope_pose_recovered_from_a_nearby_seed(envelope, objective):
    surf, ur, pose, hand, side = envelope
    ev = sf.PoseEvaluator(surf, ur, EX62_TOOL)
    x0 = X_TRUE + np.array([0.01, -0.012, 0.008, -0.01])
    X, conv, _ = sf.optimize_poses(ev, x0[None], objective=objective, anchor=False)
    assert np.abs(X[0] - X_TRUE).max() < 1e-7
    assert conv[0].phi_end < 1e-8 < conv[0].phi_start
    assert np.abs(ev.axis_errors(X[0]).e).max() < 1e-9
    # the pose object is the same axis segment (Eq. (8) normal form is unique)
    p = sf.params_pose(X[0], EX62_TOOL)
    assert np.allclose(p.tip, pose.tip, atol=1e-7) and np.allclose(p.axis, pose.axis, atol=1e-7)


def test_closed_form_seed_reproduces_the_envelope_pose(envelope):
    """§5.1: at the contact point of the middle sphere, one second-order line-contact pose of the
    given cone is the generating pose itself (the envelope has exact line contact)."""
    surf, ur, pose, hand, side = envelope
    cm = eq11_characteristic(pose.tip, pose.axis, EX62_TOOL, np.array([0.5]), surf.v0, hand, side)
    q0 = screw_to_plane(cm, surf.v0, hand)[0]
    us = np.linspace(*ur, 40001)
    u = us[np.argmin(np.linalg.norm(surf.profile.eval(us) - q0, axis=1))]
    cands = sf.initial_positions(surf, ur, EX62_TOOL, u=[u], keep="all")[0]
    assert all(c.contact == 2 for c in cands) and len(cands) == 4
    best = cands[0]
    assert best.admissible and best.rank == 0
    assert np.abs(best.params - X_TRUE).max() < 5e-5
    assert best.phi < 1e-3 < min(c.phi for c in cands[1:])
    # Eq. (23) vanishes for every line near a helical surface (the distance is screw invariant)
    assert max(c.movability for c in cands) < 1e-20


# ------------------------------------------------------------------ geometry helpers
def test_pose_parameters_round_trip_and_screw_invariance(female):
    _, s = female
    rng = np.random.default_rng(1)
    for _ in range(5):
        x = np.r_[rng.uniform(-0.5, 0.5, 2), rng.uniform(-1.2, 1.2), rng.uniform(-3, 3)]
        p = sf.params_pose(x, EX62_TOOL)
        assert np.allclose(sf.pose_params(p, s), x, atol=1e-12)
        q = sf.screw_pose(p, rng.uniform(-2, 2), s)
        assert not np.allclose(q.tip, p.tip)
        assert np.allclose(sf.pose_params(q, s), x, atol=1e-10)


def test_exact_jacobians_match_finite_differences(female):
    r, s = female
    ev = sf.PoseEvaluator(s, r.flanks[1], EX62_TOOL, n=40)
    seed = sf.initial_positions(s, r.flanks[1], EX62_TOOL, n_samples=5)[2][0]
    x = seed.params + 0.003
    e, J, _ = ev.distances(x[None], key=None)
    b = ev.branch(x[None])
    f, Jf, _ = ev.char_distances(x[None], b, key=None)
    rm, gm = sf.mid_radius(x[None], EX62_TOOL.L)
    h = 1e-6
    for j in range(4):
        xp, xm = x.copy(), x.copy()
        xp[j] += h
        xm[j] -= h
        fd = (ev.distances(xp[None], key=None, jac=False)[0] - ev.distances(xm[None], key=None, jac=False)[0]) / (2 * h)
        assert np.abs(fd[0] - J[0, :, j]).max() < 1e-6
        fdf = (ev.char_distances(xp[None], b, key=None)[0] - ev.char_distances(xm[None], b, key=None)[0]) / (2 * h)
        ok = np.isfinite(fdf[0])
        assert ok.sum() > 20 and np.abs(fdf[0][ok] - Jf[0, ok, j]).max() < 1e-6
        fdm = (sf.mid_radius(xp[None], EX62_TOOL.L)[0] - sf.mid_radius(xm[None], EX62_TOOL.L)[0]) / (2 * h)
        assert abs(fdm[0] - gm[0, j]) < 1e-8


def test_flank_samples_profile_and_orthogonal_trajectory(asym_male):
    r, s = asym_male
    lo, hi = r.flanks[0]
    a = sf.flank_samples(s, lo, hi, 12)
    b = sf.flank_samples(s, lo, hi, 12, along="orthogonal")
    for u in (a, b):
        assert (np.diff(u) > 0).all() and lo < u[0] and u[-1] < hi
    # equal arc-length cells along the profile
    pts = s.profile.eval(np.linspace(lo, hi, 20001))
    arc = np.r_[0, np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))]
    at = np.interp(a, np.linspace(lo, hi, 20001), arc)
    assert np.allclose(np.diff(at), arc[-1] / 12, rtol=1e-3)
    assert np.abs(a - b).max() > 1e-3 * (hi - lo)
    with pytest.raises(ValueError):
        sf.flank_samples(s, lo, hi, 5, along="diagonal")


def test_seed_is_second_order_along_the_axis(female):
    """At a hyperbolic sample the seed's error e(s) = d - r vanishes to second order at the middle
    sphere (Eq. (22): d is linear in the direction of the axis), unlike a tilted axis."""
    r, s = female
    per = sf.initial_positions(s, r.flanks[1], EX62_TOOL, n_samples=6)
    ev = sf.PoseEvaluator(s, r.flanks[1], EX62_TOOL)
    h = 0.01
    sm = 0.5 + np.array([-h, 0.0, h])
    checked = 0
    for cands in per:
        c = cands[0]
        if c.contact != 2:
            continue
        e = ev.distances(c.params[None], sm, key=None, jac=False)[0][0]
        d2 = (e[0] - 2 * e[1] + e[2]) / h ** 2
        tilted = c.params + np.array([0.0, 0.0, 0.05, 0.0])
        e_t = ev.distances(tilted[None], sm, key=None, jac=False)[0][0]
        d2_t = (e_t[0] - 2 * e_t[1] + e_t[2]) / h ** 2
        assert abs(e[1]) < 1e-9
        assert abs(d2) < 2e-3 * max(abs(d2_t), 1e-3) + 1e-4
        checked += 1
    assert checked >= 3


# ------------------------------------------------------------------ optimisation on a rotor flank
@pytest.fixture(scope="module")
def free_candidates(female):
    r, s = female
    return sf.candidate_strips(s, r.flanks[1], EX62_TOOL, n_seeds=5, anchor=False, flank=1)


def test_optimised_poses_are_local_minima(female, free_candidates):
    r, s = female
    ev = sf.PoseEvaluator(s, r.flanks[1], EX62_TOOL)
    assert len(free_candidates) == 5
    for c in free_candidates:
        phi = sf.phi_value(ev, c.params)
        assert phi == pytest.approx(c.convergence.phi_end, abs=1e-12)
        assert phi <= c.convergence.phi_start + 1e-12
        for j in range(4):
            for sign in (-1, 1):
                x = c.params.copy()
                x[j] += sign * 1e-4
                assert sf.phi_value(ev, x) >= phi - 1e-12, (c.seed.u, j, sign)


def _lockstep_problems(n, m=12, seed=3):
    """n small constrained problems (a quartic bowl, m linear inequalities each) as one batch function."""
    rng = np.random.default_rng(seed)
    A, b, C = rng.normal(size=(n, m, 4)), rng.normal(size=(n, m)) - 3.0, rng.normal(size=(n, 4))
    calls = []

    def batch(X, ids):
        calls.append(np.array(ids))
        if np.isnan(X).any():
            raise FloatingPointError(f"NaN pose in rows {ids.tolist()}")
        D = X - C[ids]
        return (np.sum(D ** 4, axis=1) + np.sum(X ** 2, axis=1), 4 * D ** 3 + 2 * X,
                np.einsum("kmi,ki->km", A[ids], X) - b[ids], A[ids])
    return batch, calls


def test_lockstep_runs_are_the_independent_slsqp_runs():
    """Every lockstep run's iterates are those of its own scipy SLSQP call, bit for bit, and every round
    asks once for every run still going."""
    from scipy.optimize import minimize
    n = 9
    batch, calls = _lockstep_problems(n)
    X0 = np.linspace(-1.0, 1.0, 4 * n).reshape(n, 4)
    X, iters, rounds, status, _ = sf._slsqp_lockstep(batch, X0, 12, 0)
    assert rounds == len(calls) and rounds >= iters.max() and (status == 0).all()
    for i in range(n):
        one = np.array([i])
        cons = [{"type": "ineq", "fun": lambda x: batch(x[None], one)[2][0],
                 "jac": lambda x: batch(x[None], one)[3][0]}]
        ref = minimize(lambda x: batch(x[None], one)[0][0], X0[i].copy(), jac=lambda x: batch(x[None], one)[1][0],
                       method="SLSQP", constraints=cons, options={"maxiter": 60, "ftol": 1e-13})
        assert np.array_equal(ref.x, X[i]) and ref.nit == iters[i]
    # a round holds every run that has not finished: the sizes never grow
    sizes = [len(c) for c in calls[:rounds]]
    assert sizes[0] == n and all(a >= b for a, b in zip(sizes, sizes[1:]))


def test_lockstep_stops_every_run_on_an_error_and_runs_none():
    batch, _ = _lockstep_problems(4)
    X0 = np.zeros((4, 4))
    X0[2, 1] = np.nan
    with pytest.raises(FloatingPointError, match=r"NaN pose in rows \[0, 1, 2, 3\]"):
        sf._slsqp_lockstep(batch, X0, 12, 0)
    X, iters, rounds, status, messages = sf._slsqp_lockstep(batch, np.zeros((0, 4)), 12, 0)
    assert X.shape[0] == 0 and rounds == 0 and messages == []


def test_anchored_candidates_keep_their_depth_and_cover_the_flank(female):
    r, s = female
    cands = sf.candidate_strips(s, r.flanks[1], EX62_TOOL, n_seeds=8, flank=1)
    assert len(cands) == 8
    L = EX62_TOOL.L
    rad0 = sf.mid_radius(np.array([c.seed.params for c in cands]), L)[0]
    rad1 = sf.mid_radius(np.array([c.params for c in cands]), L)[0]
    assert np.abs(rad1 - rad0).max() < 1e-9
    for c in cands:
        assert c.convergence.phi_end <= c.convergence.phi_start + 1e-12
        assert len(c.errors.e) == 100 and c.max_error == c.errors.e.max()
        # pose is a valid ConePose of the given tool and its strip is flank-plan/1
        assert isinstance(c.pose, ConePose) and c.pose.tool is EX62_TOOL
        assert np.allclose(c.pose.tip, c.errors.points[0]) and np.allclose(c.pose.top, c.errors.points[-1])
    # the contact depth follows the seeds: feet of the middle spheres spread over the flank
    u_mid = np.array([c.errors.u[50] for c in cands])
    lo, hi = r.flanks[1]
    assert np.ptp(u_mid) > 0.5 * (hi - lo)
    plan = sf.single_flank_plan(s, r.flanks, 1, cands, EX62_TOOL)
    validate_plan(plan)
    assert plan["target_flanks"] == [1] and len(plan["strips"]) == 8


def test_phi3_weighted_small_errors(female):
    r, s = female
    cands = sf.candidate_strips(s, r.flanks[1], EX62_TOOL, n_seeds=4, objective="phi3", flank=1)
    for c in cands:
        cv = c.convergence
        assert cv.objective == "phi3" and cv.phi_end <= cv.phi_start + 1e-12
        assert c.errors.f is not None and np.isfinite(c.errors.f).sum() > 50
    assert min(c.max_error for c in cands) < 5e-3


def test_hard_mode_never_overcuts(female):
    r, s = female
    cands = sf.candidate_strips(s, r.flanks[1], EX62_TOOL, n_seeds=3, mode="hard", flank=1)
    ev = sf.PoseEvaluator(s, r.flanks[1], EX62_TOOL)
    dense = np.linspace(0, 1, 2001)
    for c in cands:
        assert c.convergence.mode == "hard"
        assert c.min_error >= -1e-12
        e = ev.distances(c.params[None], dense, key=None, jac=False)[0][0]
        assert e.min() >= -1e-10
    # independent reference: the sweep simulation of the strips finds no overcut on the flank
    plan = sf.single_flank_plan(s, r.flanks, 1, cands, EX62_TOOL)
    ver = verify_plan(plan)
    assert ver["max_overcut"] is not None and ver["max_overcut"] >= -1e-6
    # ... whereas the weighted mode may leave tiny overcuts; the hard poses are never better in Phi1
    weighted = sf.candidate_strips(s, r.flanks[1], EX62_TOOL, n_seeds=3, flank=1)
    for h, w in zip(cands, weighted):
        assert sf.phi_value(ev, h.params) >= sf.phi_value(ev, w.params) - 1e-9


def test_invalid_options(female):
    r, s = female
    ev = sf.PoseEvaluator(s, r.flanks[1], EX62_TOOL)
    with pytest.raises(ValueError):
        sf.optimize_poses(ev, np.zeros((1, 4)), objective="phi9")
    with pytest.raises(ValueError):
        sf.optimize_poses(ev, np.zeros((1, 4)), mode="soft")
    with pytest.raises(ValueError):
        sf.initial_positions(s, r.flanks[1], EX62_TOOL, 3, keep="some")


# ------------------------------------------------------------------ Phi2: the tool shape (Ex. 6.1)
EX61_TOOL = ConeTool(0.25, 0.25, 0.5)


@pytest.mark.parametrize("name,flank", [("asymmetric-male", 0), ("asymmetric-male", 1),
                                        ("asymmetric-female", 0), ("asymmetric-female", 1)])
def test_tool_shape_fit_is_non_overcutting(name, flank, record_property, builtin):
    """Phi2 (Eq. 28) with only admissibility (Eqs. 18-21, the tool outside the rotor) and collision: either a
    fitted cone whose constraint report is true (recomputed here from its distances) and which the exact
    collision test passes, or a refusal naming what failed."""
    from flank_addon.simulation.collision import check_rotor_collisions

    r, s = builtin(name)
    try:
        fit = sf.optimize_tool_shape(s, r.flanks[flank], EX61_TOOL, n_seeds=12, top=2, flank_ranges=r.flanks,
                                     flank=flank)
    except ValueError as ex:
        assert "no seed gave an admissible, collision-free cone" in str(ex)
        assert "collides: cone with flank" in str(ex) or "against the limit" in str(ex)
        record_property("tool_shape", f"{name} X{flank + 1}: {ex}")
        return
    assert fit.e.min() >= -1e-12                  # Eq. (30): the fitted line stays below d
    assert 0 <= fit.r1s < fit.r2s
    assert fit.tool.L == pytest.approx(EX61_TOOL.L, rel=1e-9)
    assert fit.tool.r1s == pytest.approx(fit.r1s, abs=1e-12) and fit.tool.r2s == pytest.approx(fit.r2s, rel=1e-9)
    assert fit.phi2_end <= fit.phi2_start
    # the fit touches the distances (an LP vertex): it cannot be lifted
    assert fit.e.min() < 1e-9
    # the constraint report, recomputed from the distances: every row holds, "active" means it binds
    d0, d1, L = fit.d[0], fit.d[-1], EX61_TOOL.L
    lim = fit.limits
    want = {"r1": (d0, lim["r1_max"]), "r2": (d1, lim["r2_max"]), "angle": ((d1 - d0) / L, math.sin(lim["d_angle"])),
            "outside": (0.0, d0)}
    if lim["a_min"] is not None:
        want["omega1"] = (0.5 * (d0 + d1), lim["a_min"] ** 2)
    rows = {c["name"]: c for c in fit.constraints}
    assert set(want) <= set(rows)
    for nm, (v, limit) in want.items():
        assert v <= limit + 1e-9
        if nm != "outside":
            assert rows[nm]["value"] == pytest.approx(v, abs=1e-12) and rows[nm]["limit"] == pytest.approx(limit)
    assert set(fit.active) == {c["name"] for c in fit.constraints if abs(c["slack"]) <= 1e-6 * max(abs(c["limit"]),
                                                                                                     1e-9)}
    assert not check_rotor_collisions([fit.pose], r, target_flanks=(flank,), tolerance=1e-6, model="spheres",
                                      spacing=max(0.25 * fit.tool.r1c, 0.05 * fit.tool.r2c, 1e-4))[0].collides
    line = (f"{name} X{flank + 1}: r(s) = {fit.r2s - fit.r1s:.3f} s + {fit.r1s:.3f}, max error {fit.max_error:.5f}, "
            f"active {fit.active}")
    print(line)
    record_property("tool_shape", line)
