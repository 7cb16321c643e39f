"""Doğrusadık paraboloid end mill on a helix: analytic section vs direct numerical maximisation."""
import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from flank_addon.methods.paraboloid_groove.groove import ParaboloidError, groove_section, groove_surface, section_y

PAPER = dict(R=20.0, a=-0.05, b=7.2, p=20.0)   # Doğrusadık Table 1, mm


def numeric_upper(x, R, a, b, p, n_phi=4001):
    """max over phi of the tool's upper section in z = 0, restricted to phi where the plane cuts the tool.

    Independent of Eqs. (9)-(12): the admissible phi-interval comes from h(x, phi) >= 0 in closed form,
    the maximum from dense sampling polished by bounded Brent, endpoints included.
    """
    out = np.empty(len(x))
    for i, xi in enumerate(x):
        c = (a * xi ** 2 + a * R ** 2 + b) / (2 * a * xi * R)   # h(x, phi) = 0  <=>  cos(phi) = c
        half = np.arccos(np.clip(-c, -1, 1))                     # interval pi +- half (tool near x < 0)
        lo, hi = np.pi - half, np.pi + half
        phis = np.linspace(lo, hi, n_phi)
        ys = section_y(xi, phis, R, a, b, p)
        k = int(np.argmax(ys))
        best = max(ys[0], ys[-1], ys[k])
        a_, b_ = phis[max(k - 1, 0)], phis[min(k + 1, n_phi - 1)]
        if b_ > a_:
            r = minimize_scalar(lambda t: -section_y(xi, t, R, a, b, p), bounds=(a_, b_), method="bounded",
                                options={"xatol": 1e-13})
            best = max(best, -r.fun)
        out[i] = best
    return out


def test_paper_case_intercepts_are_exact():
    sec = groove_section(**PAPER, n=801)
    assert sec.x[0] == -32.0 and sec.x[-1] == -8.0
    assert abs(sec.y[0]) < 1e-12 and abs(sec.y[-1]) < 1e-12
    # both ends lie on the equator branch (Eq. 12), the middle on the envelope (Eq. 10)
    assert sec.branch[0] == 0 and sec.branch[-1] == 0 and sec.branch[len(sec.x) // 2] == 1


@pytest.mark.parametrize("params", [PAPER, dict(R=30.0, a=-0.02, b=5.0, p=12.0), dict(R=15.0, a=-0.1, b=9.0, p=35.0)])
def test_analytic_section_matches_numerical_maximisation(params):
    sec = groove_section(**params, n=301)
    ref = numeric_upper(sec.x, **params)
    assert np.max(np.abs(sec.y - ref)) < 1e-9


def test_circular_path_has_no_overcut_and_helix_does():
    flat = groove_section(R=20.0, a=-0.05, b=7.2, p=0.0, n=201)
    assert np.max(np.abs(flat.overcut)) < 1e-12
    ext = groove_section(**PAPER, part="external")
    inn = groove_section(**PAPER, part="internal")
    assert ext.overcut.min() >= -1e-12 and inn.overcut.min() >= -1e-12
    # Doğrusadık §IV: the overcut is higher for the external groove
    assert ext.overcut.max() > inn.overcut.max() > 0


def test_groove_surface_passes_through_the_section():
    surf = groove_surface(**PAPER, n=301)
    sec = groove_section(**PAPER, n=301)
    pts = np.c_[-sec.x, np.zeros(len(sec.x)), sec.y]   # paper (x, y) -> (r, 0, z)
    assert np.max(np.abs(surf.signed_distance(pts))) < 1e-6


def test_bad_parameters_are_named():
    with pytest.raises(ParaboloidError, match="a must be negative"):
        groove_section(R=20, a=0.05, b=7.2, p=20)
    with pytest.raises(ParaboloidError, match="must exceed the tool's equator radius 12"):
        groove_section(R=10, a=-0.05, b=7.2, p=20)
    with pytest.raises(ParaboloidError, match=r"pitch p = 3.4e\+38 exceeds 10000 x the helix radius R = 20"):
        groove_surface(R=20, a=-0.05, b=7.2, p=3.4e38)              # a float property's infinity
    groove_section(R=20, a=-0.05, b=7.2, p=2e5)                     # the limit itself is taken


def test_cli_writes_paper_section(tmp_path, capsys):
    from flank_addon.cli import main

    out = tmp_path / "groove.csv"
    assert main(["paraboloid", "--radius", "20", "--a", "-0.05", "--b", "7.2", "--pitch", "20", "--full",
                 "--out", str(out)]) == 0, capsys.readouterr().err
    xy = np.loadtxt(out, delimiter=",", skiprows=1)
    assert xy[0, 0] == -32.0 and xy[-1, 0] == -8.0 and abs(xy[0, 1]) < 1e-12
    capsys.readouterr()
    assert main(["paraboloid", "--radius", "5", "--a", "-0.05", "--b", "7.2", "--pitch", "20",
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error:") and "equator radius" in err
    before = out.read_bytes()
    for n in ("0", "1", "100"):
        assert main(["paraboloid", "--radius", "20", "--a", "-0.05", "--b", "7.2", "--pitch", "20", "--points", n,
                     "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"error: --points {n} is below the minimum 101") and out.read_bytes() == before
    with pytest.raises(ParaboloidError, match="at least 2 abscissae, got n = 1"):
        groove_section(R=20, a=-0.05, b=7.2, p=20, n=1)


def section_normals(x, y):
    """Unit normals of the upper section pointing into the groove (out of the material above it)."""
    dx, dy = np.gradient(x), np.gradient(y)
    n = np.c_[dy, -dx]
    return n / np.linalg.norm(n, axis=1, keepdims=True)


@pytest.mark.parametrize("params", [PAPER, dict(R=15.0, a=-0.08, b=5.0, p=35.0)])
def test_sweep_simulation_reproduces_the_analytic_section(params):
    """Part 1's sweep engine, knowing only the lens and the helix, cuts the analytic groove.

    Paper frame -> rotor frame: (x, y, z) -> (x, -z, y) is a proper rotation taking the tool centre's
    helix (R cos phi, p/2 - p phi / 2pi, R sin phi) to a right-handed helix of v0 = p / 2pi about z;
    at phi = pi the centre sits at (-R, 0, 0) and the section plane z = 0 becomes y = 0."""
    from flank_addon.simulation.sweep import ParaboloidPart, RevolvingTool, machined_deviation

    R, a, b, p = params["R"], params["a"], params["b"], params["p"]
    sec = groove_section(R, a, b, p, n=301)
    nrm = section_normals(sec.x, sec.y)
    pts = np.c_[sec.x, np.zeros_like(sec.x), sec.y]
    nrm3 = np.c_[nrm[:, 0], np.zeros_like(sec.x), nrm[:, 1]]
    tool = RevolvingTool([ParaboloidPart([-R, 0.0, 0.0], [0.0, 0.0, 1.0], a, b)])
    v0 = p / (2 * np.pi)
    dev = machined_deviation([tool], pts, nrm3, v0, "right", max_deviation=1.0)
    assert np.abs(dev).max() < 1e-7          # mm; the target is 0.1 um = 1e-4 mm
    # and the simulation is not blind: a section shifted 2 um into the groove is 2 um short of it
    dev2 = machined_deviation([tool], pts + 2e-3 * nrm3, nrm3, v0, "right", max_deviation=1.0)
    assert np.allclose(dev2, -2e-3, atol=1e-7)
    # the helix cuts more than the tool's own section (Doğrusadık Fig. 5): a point on the tool's section
    # where the overcut is largest lies strictly inside the simulated groove
    k = int(np.argmax(sec.overcut))
    tool_pt = np.array([[sec.x[k], 0.0, sec.tool_y[k]]])
    d = machined_deviation([tool], tool_pt, nrm3[k:k + 1], v0, "right", max_deviation=1.0)
    assert d[0] < -0.5 * sec.overcut[k] * abs(nrm[k, 1])


def test_paraboloid_lens_distance_matches_dense_sampling():
    from flank_addon.simulation.sweep import ParaboloidPart

    a, b = -0.05, 7.2
    part = ParaboloidPart([1.0, 2.0, 3.0], [0.3, -0.2, 1.0], a, b)
    rng = np.random.default_rng(4)
    q = part.centre + rng.uniform(-20, 20, (3000, 3))
    d = part.signed_distance(q)
    # brute force in the meridian half-plane: dense samples of both parabola arcs
    w = q - part.centre
    h = w @ part.axis
    rho = np.linalg.norm(w - h[:, None] * part.axis, axis=1)
    u = np.linspace(0, part.rho_e, 200001)
    arc = np.c_[b + a * u * u, u]
    from scipy.spatial import cKDTree
    # exact nearest samples; without compacted nodes the tree's boxes stay wide enough that the far queries
    # prune (8x faster here, the same distances)
    dist, _ = cKDTree(np.vstack([arc, arc * [-1, 1]]), compact_nodes=False).query(np.c_[h, rho])
    inside = (np.abs(h) <= b + a * rho ** 2) & (rho <= part.rho_e)
    assert np.array_equal(d < 0, inside)
    assert np.max(np.abs(np.abs(d) - dist)) < 1e-4     # sampling spacing 6e-5
    assert np.all(np.abs(d) <= dist + 1e-12)           # exact foot points are never worse
