"""Angles the same bit for bit from run to run: numpy's vectorised transcendental functions take another code path
(with other last bits) when it cannot rule out that an input shares memory with the output, and for a column of
a larger array that test depends on where the allocator put the output."""
import math

import numpy as np
import pytest

from flank_addon.geometry import angles
from flank_addon.geometry.freeform_surfaces import cylinder_patch, gear_flank
from flank_addon.geometry.rotors import KINDS, _star_shaped, _unit_profile, builtin_by_name
from flank_addon.methods.double_flank.planner import _contact_samples, _shrink_concave
from flank_addon.methods.formed_cutter import cutter_profile
from flank_addon.methods.single_flank.poses import axis_and_jacobian, mid_radius
from flank_addon.simulation.sweep import time_windows

# numpy's functions that have a vectorised (SVML) implementation beside the C library's
VECTORISED = ("sin", "cos", "tan", "arcsin", "arccos", "arctan", "arctan2", "sinh", "cosh", "tanh", "arcsinh",
              "arccosh", "arctanh", "exp", "exp2", "expm1", "log", "log2", "log10", "log1p", "cbrt", "power")


def _placed(values, buffer, offset):
    """``values`` copied into ``buffer`` at byte ``offset`` (a view)."""
    nbytes = values.nbytes
    view = buffer[offset:offset + nbytes].view(values.dtype).reshape(values.shape)
    view[...] = values
    return view


def test_a_column_angle_depends_on_the_output_placement_and_ours_does_not():
    rng = np.random.default_rng(7)
    c = rng.normal(size=(500, 13, 3))
    simd = np.arctan2(np.ascontiguousarray(c[..., 1]), np.ascontiguousarray(c[..., 0]))
    libm = np.vectorize(math.atan2)(c[..., 1], c[..., 0])
    buf = np.zeros(c.nbytes + simd.nbytes + 256, np.uint8)
    start = (-buf.ctypes.data) % 64
    placed = _placed(c, buf, start)
    results = []
    for gap in (0, 8, 16, 64):
        out = buf[start + c.nbytes + gap:start + c.nbytes + gap + simd.nbytes].view(float).reshape(simd.shape)
        np.arctan2(placed[..., 1], placed[..., 0], out=out)
        results.append(out.copy())
    assert all(np.array_equal(r, simd) or np.array_equal(r, libm) for r in results)
    if not np.array_equal(simd, libm):
        # this machine has the two implementations: an output right behind the column's array gets the C
        # library's bits, one farther away the vectorised ones
        assert np.array_equal(results[0], libm) and np.array_equal(results[-1], simd)
    assert np.array_equal(angles.atan2(placed[..., 1], placed[..., 0]), simd)
    steps = np.diff(np.unwrap(rng.uniform(-7, 7, 1000)))
    z = np.exp(1j * steps)
    assert np.array_equal(angles.wrapped(steps), np.arctan2(np.ascontiguousarray(z.imag), np.ascontiguousarray(z.real)))
    assert np.all(np.abs(angles.wrapped(steps)) <= np.pi)
    assert np.allclose(angles.wrapped(steps), np.angle(np.exp(1j * steps)), rtol=0, atol=1e-15)


@pytest.fixture
def strided_calls(monkeypatch):
    """Every call of numpy's vectorised functions with a non-contiguous array input, as (name, shape)."""
    import numpy.lib.function_base as function_base
    seen = []

    def watch(name, f):
        def call(*args, **kwargs):
            for a in args[:2]:
                if isinstance(a, np.ndarray) and a.size > 1 and not a.flags.c_contiguous:
                    seen.append((name, a.shape))
            return f(*args, **kwargs)
        return call
    for name in VECTORISED:
        monkeypatch.setattr(np, name, watch(name, getattr(np, name)))
    monkeypatch.setattr(function_base, "arctan2", watch("arctan2 in np.angle", function_base.arctan2))
    return seen


def test_the_planners_hand_numpy_contiguous_angles(strided_calls):
    """The functions that took angles of array columns (each did before): pose axes, time windows of the sweep,
    the double-flank meridian, the formed cutter's helix crossings and valley, the rotor reader's star test."""
    rng = np.random.default_rng(3)
    X = rng.normal(size=(7, 4))
    axis_and_jacobian(X, np.linspace(0.0, 1.0, 9), 2.0)
    mid_radius(X, 2.0)
    x = rng.normal(size=(40, 3))
    time_windows(x, rng.normal(size=(40, 5, 3)), np.abs(rng.normal(size=(40, 5))), 0.7, "right", 0.1)
    time_windows(x, rng.normal(size=(5, 3)), np.abs(rng.normal(size=5)), 0.7, "left", 0.1)
    t = np.linspace(0.0, 2.0 * np.pi, 200)
    mer = np.c_[t, 1.0 + 0.3 * np.sin(3.0 * t)]
    _shrink_concave(mer, 1e-3)
    _contact_samples(lambda s: (1.0 + 0.2 * np.sin(4.0 * s), 0.8 * np.cos(4.0 * s)), np.linspace(0.0, 1.0, 30),
                     1e-4, max_rounds=3)
    circle = np.c_[np.cos(t[:-1]), np.sin(t[:-1])]
    assert _star_shaped(circle)
    assert strided_calls == []
    # the formed cutter: its valley search and the helix crossings of its sections
    rotor = builtin_by_name("nilson-male")
    lo, hi = cutter_profile.default_tooth(rotor.profile)
    assert lo != hi
    setup = cutter_profile.CutterSetup(centre_distance=1.8, swivel=math.radians(20.0), lead=2.0 * np.pi * rotor.v0,
                                       handedness=rotor.handedness)
    cutter_profile._helix_crossings(rng.uniform(0.5, 1.0, size=(30, 2)), setup, np.linspace(-0.3, 0.3, 7))
    cutter_profile.contact_equation_profile(rotor.profile, setup, np.linspace(lo, lo + 0.1, 5), n_scan=31)
    assert cutter_profile.arc_tooth_section().outer_radius() > 0
    assert strided_calls == []
    # the built-in rotors' generation (past the cache) and the free-form test surfaces' points and feet
    for kind in KINDS:
        for part in ("male", "female"):
            _unit_profile.__wrapped__(kind, part, 48)
    for surface in (cylinder_patch(resolution=6), gear_flank(resolution=6)):
        assert np.allclose(surface.point(surface.uv[:5]), surface.vertices[:5], rtol=0, atol=1e-12)
        if surface.closest is not None:
            surface.closest(surface.vertices[:5] + 0.01)
    assert strided_calls == []
