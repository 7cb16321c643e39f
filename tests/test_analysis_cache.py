"""The rotor analysis is kept by the content of the mesh: the same mesh again gives an equal analysis (from memory,
from FLANK_CACHE_DIR in another process, or from a record kept with the mesh), another mesh or option its own."""
import dataclasses
import json

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
        if fl.name == "content_key":        # which mesh it was made from (None: made without the cache)
            continue
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


def test_a_record_kept_with_the_mesh_stands_for_its_analysis(monkeypatch):
    monkeypatch.setattr(ra, "_CACHE", {})
    monkeypatch.delenv(ra.CACHE_DIR_ENV, raising=False)
    v, f = _mesh()
    first = ra.analyze_mesh(v, f)
    assert first.content_key == ra._cache_key(v, f, 2048, ra.RESIDUAL_THRESHOLD)
    record = json.loads(json.dumps(first.to_record()))        # as Blender keeps it: a JSON string on the object

    # a new session: nothing in memory, and analysing is not allowed -- the record is the analysis, number for number
    monkeypatch.setattr(ra, "_CACHE", {})
    calls = []
    real = ra._analyze_mesh
    monkeypatch.setattr(ra, "_analyze_mesh", lambda *a: calls.append(1) or real(*a))
    again = ra.analyze_mesh(v.copy(), f.copy(), known=record)
    assert calls == []
    _assert_equal(first, again)
    assert again.content_key == first.content_key and len(ra._CACHE) == 1
    assert again.flank_ranges() == first.flank_ranges()

    # the record of another mesh (one vertex moved by 1e-9), or of other options, is not taken
    monkeypatch.setattr(ra, "_CACHE", {})
    w = v.copy()
    w[0, 0] += 1e-9
    other = ra.analyze_mesh(w, f, known=record)
    assert calls == [1] and other.content_key != record["key"]
    ra.analyze_mesh(v, f, n_profile=1024, known=record)
    assert calls == [1, 1]
    # a damaged record with the right key is analysed again, not trusted
    monkeypatch.setattr(ra, "_CACHE", {})
    broken = dict(record, profile="not numbers")
    _assert_equal(first, ra.analyze_mesh(v, f, known=broken))
    assert calls == [1, 1, 1]
    with pytest.raises(ValueError, match="flank-rotor-analysis/1"):
        ra.RotorAnalysis.from_record({"record": "something else"})
