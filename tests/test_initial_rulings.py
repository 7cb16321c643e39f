"""initial_rulings (Rajain et al. 2023 Eqs. (7)-(11), Remark 2) on guiding curves of the test surfaces."""
import math

import numpy as np
import pytest

from flank_addon.geometry import freeform_surfaces as fs
from flank_addon.methods.freeform_g1 import guiding as g
from flank_addon.methods.freeform_g1.initial_rulings import initial_rulings, rails_from_m, ruling_samples

R1, R2, L = 0.03, 0.1, 0.15


def test_plane_axes_are_rigid_and_m_grid_round_trips():
    """On a plane with the curves d = sqrt(L^2 - dr^2) apart, every initial axis has length L
    exactly; Eq. (10) recovers Eq. (7)'s a and b from the m-grid."""
    s = fs.plane_patch(size=1.0, resolution=24, jitter=0.2, seed=3)
    res = g.guiding_curves(s.vertices, s.faces, direction=[math.cos(0.5), math.sin(0.5), 0], r1=R1, r2=R2, L=L)
    ini = initial_rulings(res.bases, res.strips, R1, R2, L)
    assert len(ini.strips) == len(res.strips) > 5
    lo, hi = ini.length_defect()
    assert max(abs(lo), abs(hi)) < 1e-12
    for st, rs in zip(res.strips, ini.strips):
        b0, b1 = res.bases[st.index], res.bases[st.index + 1]
        assert np.allclose(rs.a - b0.points[st.lower], [0, 0, R1], atol=1e-15)
        assert np.allclose(rs.b - b1.points[st.upper], [0, 0, R2], atol=1e-15)
        a, b = rails_from_m(ini.m[st.index][st.lower], b0.normals[st.lower], ini.m[st.index + 1][st.upper],
                            b1.normals[st.upper], R1, R2)
        assert np.abs(a - rs.a).max() < 1e-15 and np.abs(b - rs.b).max() < 1e-15
    for bc, m in zip(res.bases, ini.m):
        assert np.allclose(m - bc.points, [0, 0, (R1 + R2) / 2])   # Eqs. (8)-(9): offset by the mean radius


def test_cylinder_axes_are_longer_than_L():
    """Remark 2 on a convex cylinder (R = 1): the rails are offsets by r1 and r2 along the radial
    normals at equal height, so |b - a|^2 = (R + r1)^2 + (R + r2)^2 - 2 (R + r1)(R + r2) cos(dtheta),
    longer than L."""
    c = fs.cylinder_patch(size=1.0, resolution=60)
    res = g.guiding_curves(c.vertices, c.faces, direction=[0, 0, 1], r1=R1, r2=R2, L=L)
    ini = initial_rulings(res.bases, res.strips, R1, R2, L)
    for st, rs in zip(res.strips, ini.strips):
        p0 = res.bases[st.index].points[st.lower]
        p1 = res.bases[st.index + 1].points[st.upper]
        dth = np.arctan2(p1[:, 1], p1[:, 0]) - np.arctan2(p0[:, 1], p0[:, 0])
        rad = np.hypot(p0[:, 0], p0[:, 1])            # the mesh's chords sit slightly inside R = 1
        expect = np.sqrt((rad + R1) ** 2 + (rad + R2) ** 2 - 2 * (rad + R1) * (rad + R2) * np.cos(dth))
        assert np.abs(rs.lengths - expect).max() < 2e-4 * L
    lo, hi = ini.length_defect()
    assert 0.03 * L < lo <= hi < 0.06 * L


def test_ruling_samples_and_validation():
    a = np.array([[0.0, 0, 0], [1, 1, 1]])
    b = np.array([[0.0, 0, 2], [1, 1, 3]])
    y, r = ruling_samples(a, b, R1, R2, 5)
    assert y.shape == (2, 5, 3) and np.allclose(y[:, 0], a) and np.allclose(y[:, -1], b)
    assert np.allclose(y[0, :, 2], [0, 0.5, 1, 1.5, 2]) and np.allclose(r, np.linspace(R1, R2, 5))
    with pytest.raises(ValueError, match="minimum 2"):
        ruling_samples(a, b, R1, R2, 1)
    with pytest.raises(ValueError, match="must be finite and exceed"):
        initial_rulings([], [], 0.1, 0.5, 0.3)
    with pytest.raises(ValueError, match="r1"):
        initial_rulings([], [], float("nan"), 0.5, 1.0)
