"""The rotor analysis is kept by the content of the mesh: the same mesh again gives an equal analysis (from memory,
or from FLANK_CACHE_DIR in another process), another mesh or option its own."""
import dataclasses

import numpy as np
import pytest

from flank_addon.geometry import rotor_analysis as ra
from flank_addon.geometry.rotors import builtin_by_name


def _mesh():
    v, f = builtin_by_name("srm_a-male").mesh(n_profile=900, n_axial=20)
    return v * 25.0, f


def _assert_equal(a, b):
    for fl in dataclasses.fields(a):
        x, y = getattr(a, fl.name), getattr(b, fl.name)
        if fl.name == "surface":
            assert np.array_equal(x.profile.points, y.profile.points) and x.v0 == y.v0 and x.hand == y.hand
            assert np.array_equal(x.profile._spline.c, y.profile._spline.c)
        elif isinstance(x, np.ndarray):
            assert np.array_equal(x, y), fl.name
        else:
            assert x == y, fl.name


def test_same_mesh_same_analysis_from_memory_and_disk(tmp_path, monkeypatch):
    monkeypatch.setattr(ra, "_CACHE", {})
    v, f = _mesh()
    monkeypatch.delenv(ra.CACHE_DIR_ENV, raising=False)
    first = ra.analyze_mesh(v, f)
    assert len(ra._CACHE) == 1
    again = ra.analyze_mesh(v.copy(), f.copy())
    _assert_equal(first, again)
    assert again is not first and again.profile is not first.profile      # a copy: callers may change theirs
    uncached = ra._analyze_mesh(np.asarray(v, float), np.asarray(f, int), 2048, ra.RESIDUAL_THRESHOLD)
    _assert_equal(first, uncached)
    # another process: a fresh memory, the directory of FLANK_CACHE_DIR
    monkeypatch.setenv(ra.CACHE_DIR_ENV, str(tmp_path / "cache"))
    ra.analyze_mesh(v, f, n_profile=1024)
    assert len(list((tmp_path / "cache").glob("analysis-*.npz"))) == 1
    monkeypatch.setattr(ra, "_CACHE", {})
    from_disk = ra.analyze_mesh(v, f, n_profile=1024)
    _assert_equal(ra._analyze_mesh(np.asarray(v, float), np.asarray(f, int), 1024, ra.RESIDUAL_THRESHOLD), from_disk)
    # a changed vertex or option is another mesh
    w = v.copy()
    w[0, 0] += 1e-9
    assert ra._cache_key(w, f, 2048, ra.RESIDUAL_THRESHOLD) != ra._cache_key(v, f, 2048, ra.RESIDUAL_THRESHOLD)
    assert ra._cache_key(v, f, 1024, ra.RESIDUAL_THRESHOLD) != ra._cache_key(v, f, 2048, ra.RESIDUAL_THRESHOLD)


def test_refusals_are_not_kept(monkeypatch):
    monkeypatch.setattr(ra, "_CACHE", {})
    th = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    v = np.r_[np.c_[np.cos(th), np.sin(th), np.zeros(40)], np.c_[np.cos(th), np.sin(th), np.ones(40)]]
    i = np.arange(40)
    f = np.r_[np.c_[i, (i + 1) % 40, 40 + i], np.c_[(i + 1) % 40, 40 + (i + 1) % 40, 40 + i]]
    for _ in range(2):
        with pytest.raises(ra.NotHelicalError):
            ra.analyze_mesh(v, f)
    assert ra._CACHE == {}
