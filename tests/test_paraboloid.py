"""s002 paraboloid end mill on a helix: analytic section vs direct numerical maximisation."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from flank_addon.paraboloid import ParaboloidError, groove_section, groove_surface, section_y

PAPER = dict(R=20.0, a=-0.05, b=7.2, p=20.0)   # s002 Table 1, mm


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
    # s002 §IV: the overcut is higher for the external groove
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


def test_cli_writes_paper_section(tmp_path):
    out = tmp_path / "groove.csv"
    r = subprocess.run([sys.executable, "-m", "flank_addon", "paraboloid", "--radius", "20", "--a", "-0.05",
                        "--b", "7.2", "--pitch", "20", "--full", "--out", str(out)],
                       cwd=Path(__file__).resolve().parents[1], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    xy = np.loadtxt(out, delimiter=",", skiprows=1)
    assert xy[0, 0] == -32.0 and xy[-1, 0] == -8.0 and abs(xy[0, 1]) < 1e-12
    r = subprocess.run([sys.executable, "-m", "flank_addon", "paraboloid", "--radius", "5", "--a", "-0.05",
                        "--b", "7.2", "--pitch", "20", "--out", str(out)],
                       cwd=Path(__file__).resolve().parents[1], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and r.stderr.startswith("error:") and "equator radius" in r.stderr
