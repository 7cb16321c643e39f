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


def _turn(deg, axis, shift):
    """A rigid motion (4 x 4): a turn by ``deg`` about the unit ``axis`` through the origin, then ``shift``."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    t = np.radians(deg)
    m = np.eye(4)
    m[:3, :3] = np.eye(3) + np.sin(t) * k + (1 - np.cos(t)) * (k @ k)
    m[:3, 3] = shift
    return m


def test_a_record_moves_with_a_turned_and_shifted_mesh_instead_of_being_made_again(monkeypatch):
    monkeypatch.setattr(ra, "_CACHE", {})
    monkeypatch.delenv(ra.CACHE_DIR_ENV, raising=False)
    v, f = _mesh()
    record = json.loads(json.dumps(ra.analyze_mesh(v, f).to_record()))
    m = _turn(37.0, (0.3, -1.0, 0.4), (12.5, -40.0, 7.25))
    moved = v @ m[:3, :3].T + m[:3, 3]
    reference = ra._analyze_mesh(moved, np.asarray(f, int), 2048, ra.RESIDUAL_THRESHOLD)   # analysed where it is now

    monkeypatch.setattr(ra, "_CACHE", {})
    calls = []
    real = ra._analyze_mesh
    monkeypatch.setattr(ra, "_analyze_mesh", lambda *a: calls.append(1) or real(*a))
    got = ra.analyze_mesh(moved, f, known=record, known_at=(v, m))
    assert calls == []
    assert got.content_key == ra._cache_key(moved, f, 2048, ra.RESIDUAL_THRESHOLD)
    # never kept under the moved mesh's key: an analysis of that mesh without the record is its own
    assert ra._CACHE == {}
    _assert_equal(reference, ra.analyze_mesh(moved, f))
    assert calls == [1]
    assert ra.analyze_mesh(moved, f, known=record, known_at=(v, m)).to_record() == got.to_record()
    calls.clear()
    # the rotor frame's numbers are the record's; the placement is the moved mesh's own analysis to rounding
    assert np.array_equal(got.profile, np.asarray(record["profile"])) and got.flanks == record["flanks"]
    assert got.v0 == record["v0"] and got.outer_radius == record["outer_radius"] and got.handedness == record["handedness"]
    # the same rotor where it stands now as its own analysis there, to rounding.  That analysis picks its rotor
    # frame's x axis (and so the profile's first point and the flanks' numbers) from the axis direction alone, so
    # here (a turn that keeps the axis' orientation rule) the two frames differ by a turn about the axis: they
    # share the axis and the origin, and the profile turned by that angle lies on the other's
    R = reference.outer_radius
    assert abs(got.v0 - reference.v0) < 1e-9 * R and abs(got.outer_radius - reference.outer_radius) < 1e-9 * R
    assert np.abs(np.subtract(got.body_z, reference.body_z)).max() < 1e-9 * R
    turn = np.linalg.solve(reference.to_world, got.to_world)              # got's rotor frame -> reference's
    assert np.abs(turn[:3, 2] - [0.0, 0.0, 1.0]).max() < 1e-9 and np.abs(turn[:3, 3]).max() < 1e-9 * R
    assert np.abs(turn[2, :3] - [0.0, 0.0, 1.0]).max() < 1e-9
    p = got.profile @ turn[:2, :2].T
    q0, q1 = reference.profile, np.roll(reference.profile, -1, axis=0)
    e = q1 - q0
    t = np.clip(np.einsum("pqk,qk->pq", p[:, None, :] - q0[None], e) / np.einsum("qk,qk->q", e, e), 0.0, 1.0)
    gap = np.linalg.norm(p[:, None, :] - (q0[None] + t[..., None] * e[None]), axis=2).min(axis=1)
    assert gap.max() < 1e-5 * R, gap.max() / R
    # every mesh vertex has the same rotor-frame coordinates in the moved analysis as in the record
    back = np.linalg.solve(got.to_world, np.c_[moved, np.ones(len(moved))].T).T[:, :3]
    before = np.linalg.solve(np.asarray(record["to_world"]), np.c_[v, np.ones(len(v))].T).T[:, :3]
    assert np.abs(back - before).max() < 1e-9 * R

    # turned end for end: the moved record keeps its frame (the vertices' rotor-frame coordinates), where an
    # analysis of the turned mesh reverses the axis and starts at the other end
    flip = _turn(180.0, (1.0, 0.0, 0.0), (0.0, 0.0, 5.0))
    flipped = v @ flip[:3, :3].T + flip[:3, 3]
    monkeypatch.setattr(ra, "_CACHE", {})
    kept = ra.analyze_mesh(flipped, f, known=record, known_at=(v, flip))
    assert calls == []
    back = np.linalg.solve(kept.to_world, np.c_[flipped, np.ones(len(v))].T).T[:, :3]
    assert np.abs(back - before).max() < 1e-9 * R
    fresh = ra.analyze_mesh(flipped, f)
    assert calls == [1] and float(fresh.axis_direction @ kept.axis_direction) < -0.999999
    # an analysis from the other end samples its profile at another ring of vertices: the pitch differs by 4e-8 of
    # 15.3 and the outer radius by 2.7e-5 of 25 (1.1e-6 R), what the mesh's facets leave open; the moved record
    # keeps the numbers the plans were made with
    assert abs(fresh.v0 - kept.v0) < 1e-8 * R and abs(fresh.outer_radius - kept.outer_radius) < 1e-5 * R
    calls.clear()

    # not taken: a motion that scales or mirrors, or vertices that are not the record's (an edited mesh)
    for motion, then in ((np.diag([2.0, 2.0, 2.0, 1.0]) @ m, v), (np.diag([-1.0, 1.0, 1.0, 1.0]) @ m, v)):
        monkeypatch.setattr(ra, "_CACHE", {})
        ra.analyze_mesh(v @ motion[:3, :3].T + motion[:3, 3], f, known=record, known_at=(then, motion))
    assert calls == [1, 1]
    edited = v.copy()
    edited[5, 2] += 1e-6
    monkeypatch.setattr(ra, "_CACHE", {})
    ra.analyze_mesh(moved, f, known=record, known_at=(edited, m))
    assert calls == [1, 1, 1]
    assert ra.rigid_motion(np.diag([1.0, 1.0, 1.0 + 1e-5, 1.0])) is None
    # a turn through single precision (Blender's object matrices) is taken, made orthonormal
    single = ra.rigid_motion(m.astype(np.float32))
    rot = single[:3, :3]
    assert np.abs(rot.T @ rot - np.eye(3)).max() < 1e-14 and np.abs(single - m).max() < 1e-6 * np.abs(m).max()


def test_the_analysis_reports_its_stages_and_a_cancel_keeps_nothing(monkeypatch):
    from flank_addon.progress import Cancelled, reporter

    monkeypatch.setattr(ra, "_CACHE", {})
    monkeypatch.delenv(ra.CACHE_DIR_ENV, raising=False)
    v, f = _mesh()
    seen = []
    done = ra.analyze_mesh(v, f, progress=reporter(lambda x, msg: seen.append((x, msg))))
    fractions = [x for x, _ in seen]
    assert len(seen) >= 6 and fractions == sorted(fractions) and fractions[0] == 0.0 and fractions[-1] < 1.0
    _assert_equal(done, ra._analyze_mesh(np.asarray(v, float), np.asarray(f, int), 2048, ra.RESIDUAL_THRESHOLD))
    # the caller says stop at the third stage: the analysis ends there, and neither memory nor disk keeps anything
    monkeypatch.setattr(ra, "_CACHE", {})
    calls = []

    def stop_at_third(x, msg):
        calls.append(msg)
        return len(calls) < 3

    w = v.copy()
    w[0, 0] += 1e-9
    with pytest.raises(Cancelled):
        ra.analyze_mesh(w, f, progress=reporter(stop_at_third))
    assert len(calls) == 3 and ra._CACHE == {}


def test_what_is_at_hand_never_analyses(tmp_path, monkeypatch):
    """``analysis_at_hand`` (what a user interface asks on its main thread) gives the analysis that memory, the
    mesh's record, a record moved with the mesh or the disk cache hold, equal to ``analyze_mesh``'s, and None
    -- without analysing -- when none does."""
    monkeypatch.setattr(ra, "_CACHE", {})
    monkeypatch.delenv(ra.CACHE_DIR_ENV, raising=False)
    v, f = _mesh()
    calls = []
    real = ra._analyze_mesh
    monkeypatch.setattr(ra, "_analyze_mesh", lambda *a: calls.append(1) or real(*a))
    assert ra.analysis_at_hand(v, f) is None and calls == [] and ra._CACHE == {}
    analysed = ra.analyze_mesh(v, f)
    assert calls == [1]
    _assert_equal(analysed, ra.analysis_at_hand(v, f))                                     # memory
    record = json.loads(json.dumps(analysed.to_record()))
    monkeypatch.setattr(ra, "_CACHE", {})
    _assert_equal(analysed, ra.analysis_at_hand(v, f, known=record))                       # the mesh's record
    monkeypatch.setattr(ra, "_CACHE", {})
    m = _turn(20.0, (1.0, 0.5, 0.0), (3.0, 0.0, -2.0))
    moved = v @ m[:3, :3].T + m[:3, 3]
    _assert_equal(ra.analyze_mesh(moved, f, known=record, known_at=(v, m)),
                  ra.analysis_at_hand(moved, f, known=record, known_at=(v, m)))           # moved with the mesh
    assert ra.analysis_at_hand(2.0 * v, f, known=record, known_at=(v, np.diag([2.0, 2, 2, 1]))) is None  # scaled
    monkeypatch.setenv(ra.CACHE_DIR_ENV, str(tmp_path / "cache"))
    ra.analyze_mesh(v, f, n_profile=1024)
    monkeypatch.setattr(ra, "_CACHE", {})
    _assert_equal(ra.analyze_mesh(v, f, n_profile=1024), ra.analysis_at_hand(v, f, n_profile=1024))   # disk
    assert calls == [1, 1]
