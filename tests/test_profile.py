import numpy as np
import pytest

from flank_addon.geometry.profile import (Arc, Line, ProfileError, SegmentProfile, SplineProfile, load_profile_csv,
                                 points_in_polygon, segments_intersect_count)


def circle(n=400, r=1.0):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.c_[r * np.cos(t), r * np.sin(t)]


def write_csv(path, pts, header=True):
    with open(path, "w") as f:
        if header:
            f.write("x,y\n")
        for x, y in pts:
            f.write(f"{x!r},{y!r}\n")


def test_spline_through_circle_points_is_accurate_and_ccw():
    prof = SplineProfile(circle()[::-1])  # clockwise input is reversed
    u = prof.params(5000)
    p = prof.eval(u)
    assert np.max(np.abs(np.linalg.norm(p, axis=1) - 1)) < 1e-9
    assert np.allclose(prof.curvature(u), 1.0, atol=1e-4)  # CCW: convex -> positive; spline p" is O(h^2)
    p_, d1, d2 = prof.eval_all(u[:50])
    assert np.allclose(d1, prof.eval(u[:50], 1)) and np.allclose(d2, prof.eval(u[:50], 2))


def test_segment_profile_is_exact():
    prof = SegmentProfile([Line((-1, 0), (1, 0)), Arc((0, 0), 1.0, 0.0, np.pi)])
    assert np.isclose(prof.period, 2 + np.pi)
    assert np.allclose(prof.eval(np.array([0.5, 2 + np.pi / 2])), [[-0.5, 0], [0, 1]])
    with pytest.raises(ProfileError, match="do not join"):
        SegmentProfile([Line((-1, 0), (1, 0)), Arc((0, 0), 1.0, 0.0, np.pi / 2)])


def test_csv_round_trip(tmp_path):
    path = tmp_path / "p.csv"
    write_csv(path, circle(300, 25.0))
    prof = load_profile_csv(path)
    assert abs(prof.outer_radius() - 25.0) < 1e-6


@pytest.mark.parametrize("defect, message", [
    ("nan", r"row 6 is not a finite number pair"),
    ("duplicate", r"duplicate points"),
    ("open", r"curve is open"),
    ("self_intersection", r"self-intersecting"),
    ("too_few", r"at least 8"),
])
def test_csv_validation_names_the_defect(tmp_path, defect, message):
    pts = circle(200)
    if defect == "nan":
        pts[5, 1] = np.nan
    elif defect == "duplicate":
        pts = np.insert(pts, 10, pts[10], axis=0)
    elif defect == "open":
        pts = pts[:150]
    elif defect == "self_intersection":
        t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
        pts = np.c_[np.cos(t), np.sin(2 * t)]  # figure eight
    elif defect == "too_few":
        pts = pts[:5]
    path = tmp_path / "bad.csv"
    write_csv(path, pts)
    with pytest.raises(ProfileError, match=message):
        load_profile_csv(path)


def test_non_numeric_row(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("x,y\n0,1\n1,abc\n")
    with pytest.raises(ProfileError, match="line 3 is not numeric"):
        load_profile_csv(path)


def test_intersection_count_and_point_in_polygon():
    t = np.linspace(0, 2 * np.pi, 300, endpoint=False)
    assert segments_intersect_count(np.c_[np.cos(t), np.sin(t)]) == 0
    assert segments_intersect_count(np.c_[np.cos(t), np.sin(2 * t)]) == 1
    inside = points_in_polygon(np.array([[0, 0], [0.99, 0], [1.01, 0], [0, -1.2]]), circle(2000))
    assert inside.tolist() == [True, True, False, False]


def test_periodic_spline_coefficients_equal_scipy_bit_for_bit():
    """The profile spline is computed without scipy.interpolate (an import of ~0.25 s per command); its
    coefficients must be scipy's own, also where the periodic system needs LAPACK's row interchanges (uneven
    knots, as on every asymmetric built-in rotor)."""
    from scipy.interpolate import CubicSpline

    from flank_addon.geometry.profile import PeriodicCubic, _periodic_coefficients
    from flank_addon.geometry.rotors import BUILTIN_NAMES, builtin_by_name

    rng = np.random.default_rng(1)
    cases = []
    for _ in range(60):
        n = int(rng.integers(5, 300))
        dx = rng.exponential(1.0, n - 1) ** rng.uniform(0, 4) + 1e-6
        y = rng.normal(size=(n, 2))
        y[-1] = y[0]
        cases.append((np.r_[0.0, np.cumsum(dx)], y))
    for name in BUILTIN_NAMES:
        prof = builtin_by_name(name).profile
        cases.append((prof.knots, np.vstack([prof.points, prof.points[:1]])))
    for knots, closed in cases:
        ref = np.asarray(CubicSpline(knots, closed, bc_type="periodic").c)
        assert np.array_equal(_periodic_coefficients(knots, closed), ref)
        assert np.array_equal(PeriodicCubic(knots, closed).c, ref)


def test_periodic_spline_takes_scipy_once_imported_and_its_own_steps_before(monkeypatch):
    """Without scipy.interpolate in the process the coefficients come from the steps here (and the module is
    not imported for them); once it is imported, from scipy.  Both are scipy's numbers bit for bit."""
    import subprocess
    import sys

    from scipy.interpolate import CubicSpline

    from flank_addon.geometry import profile as P
    from flank_addon.geometry.rotors import builtin_by_name

    prof = builtin_by_name("asymmetric-female").profile
    # scaled, so that no earlier test has left these coefficients in the spline's memory
    knots, closed = prof.knots * 1.25, np.vstack([prof.points, prof.points[:1]]) * 1.25
    ref = np.asarray(CubicSpline(knots, closed, bc_type="periodic").c)
    steps = []
    monkeypatch.setattr(P, "_periodic_coefficients", lambda k, y: steps.append(len(k)))
    assert np.array_equal(P.PeriodicCubic(knots, closed).c, ref)
    assert steps == []
    monkeypatch.undo()
    code = ("import sys, numpy as np\n"
            "from flank_addon.geometry import profile as P\n"
            "steps = []\n"
            "own = P._periodic_coefficients\n"
            "P._periodic_coefficients = lambda k, y: steps.append(len(k)) or own(k, y)\n"
            "k, y = np.load(sys.argv[1])['k'], np.load(sys.argv[1])['y']\n"
            "c = P.PeriodicCubic(k, y).c\n"
            "assert 'scipy.interpolate' not in sys.modules, 'scipy.interpolate imported'\n"
            "assert steps == [len(k)], steps\n"
            "np.save(sys.argv[2], c)\n")
    import os
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        src, out = os.path.join(tmp, "in.npz"), os.path.join(tmp, "c.npy")
        np.savez(src, k=knots, y=closed)
        root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        subprocess.run([sys.executable, "-c", code, src, out], check=True, cwd=root,
                       env={**os.environ, "PYTHONPATH": root})
        assert np.array_equal(np.load(out), ref)


def test_periodic_spline_refuses_what_scipy_refuses_with_or_without_scipy_loaded():
    """Input that scipy's periodic spline refuses (a knot that is not finite, slopes that overflow, points that do not
    close) gets scipy's error in a process with scipy.interpolate loaded and in one without it (the steps here
    would have returned NaN or meaningless coefficients)."""
    import os
    import subprocess
    import sys

    code = ("import sys, numpy as np\n"
            "if sys.argv[1] == 'scipy':\n"
            "    import scipy.interpolate\n"
            "from flank_addon.geometry.profile import PeriodicCubic\n"
            "a = np.arange(6) * np.pi / 3\n"
            "ring = np.c_[np.cos(a), np.sin(a)]\n"
            "ring[-1] = ring[0]\n"
            "cases = [(np.arange(6) * 1e-310, ring), (np.array([0.0, 1, 2, 3, 4, np.inf]), ring),\n"
            "         (np.arange(6.0), np.c_[np.arange(6.0), np.arange(6.0) ** 2])]\n"
            "for k, y in cases:\n"
            "    try:\n"
            "        with np.errstate(all='ignore'):\n"
            "            PeriodicCubic(k, y)\n"
            "        print('coefficients')\n"
            "    except ValueError as e:\n"
            "        print('ValueError', str(e)[:30])\n")
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    outs = [subprocess.run([sys.executable, "-c", code, which], check=True, cwd=root, capture_output=True, text=True,
                           env={**os.environ, "PYTHONPATH": root}).stdout.splitlines() for which in ("", "scipy")]
    assert outs[0] == outs[1]
    assert len(outs[0]) == 3 and all(line.startswith("ValueError") for line in outs[0]), outs


def test_spline_interval_search_is_the_clipped_search_and_scipy_evaluates_the_same():
    """The interval of a parameter comes from one search in the inner knots; it must be the clipped search in
    all knots for every u (knots themselves, the ends, the period, beyond, NaN), and the points scipy's spline."""
    from scipy.interpolate import CubicSpline

    rng = np.random.default_rng(7)
    th = np.sort(rng.uniform(0, 2 * np.pi, 40))
    prof = SplineProfile(np.c_[np.cos(th), 0.6 * np.sin(th)] * rng.uniform(0.9, 1.1, (40, 1)))
    k = prof.knots
    u = np.r_[k, np.nextafter(k, -np.inf), np.nextafter(k, np.inf), -1.0, -0.0, prof.period, 2 * prof.period,
              rng.uniform(-3, 3, 500) * prof.period, np.nan]
    old = np.clip(np.searchsorted(k, u, side="right") - 1, 0, len(k) - 2)
    assert np.array_equal(np.searchsorted(prof._inner_knots, u, side="right"), old)
    for wrap in (True, False):
        w = np.mod(u[:-1], prof.period)
        if wrap:
            w = np.mod(w, prof.period)
        i, s = prof._interval(u[:-1], wrap_end=wrap)
        ref = np.clip(np.searchsorted(k, w, side="right") - 1, 0, len(k) - 2)
        assert np.array_equal(i, ref) and np.array_equal(s, w - k[ref])
    spline = CubicSpline(k, np.vstack([prof.points, prof.points[:1]]), bc_type="periodic")
    v = u[np.isfinite(u)]
    assert np.array_equal(prof.eval(v), spline(np.mod(v, prof.period)))


def test_spline_coordinate_evaluations_are_eval_and_eval_all_bit_for_bit():
    """eval_xy, eval_all_xy and eval_and_tangent (what the foot points' Newton runs and their feet use) give the
    numbers of eval and eval_all, at knots, next to them, at the period and far outside it."""
    rng = np.random.default_rng(11)
    th = np.sort(rng.uniform(0, 2 * np.pi, 60))
    prof = SplineProfile(np.c_[np.cos(th), 0.7 * np.sin(th)] * rng.uniform(0.9, 1.1, (60, 1)))
    k = prof.knots
    u = np.r_[k, np.nextafter(k, -np.inf), np.nextafter(k, np.inf), -0.0, prof.period,
              rng.uniform(-3, 3, 700) * prof.period]
    x, y = prof.eval_xy(u)
    p = prof.eval(u)
    assert np.array_equal(x, p[:, 0]) and np.array_equal(y, p[:, 1])
    inside = u[(u >= 0) & (u < prof.period)]
    parts = prof.eval_all_xy(inside)
    p0, p1, p2 = prof.eval_all(inside)
    for got, want in zip(parts, (p0[:, 0], p0[:, 1], p1[:, 0], p1[:, 1], p2[:, 0], p2[:, 1])):
        assert np.array_equal(got, want)
    # the point and its tangent from one interval search (a foot point's position and normal)
    point, tangent = prof.eval_and_tangent(u)
    assert point.tobytes() == p.tobytes() and tangent.tobytes() == prof.eval(u, 1).tobytes()
    grid = u[:700].reshape(35, 20)
    assert all(got.tobytes() == want.tobytes()
               for got, want in zip(prof.eval_and_tangent(grid), (prof.eval(grid), prof.eval(grid, 1))))
