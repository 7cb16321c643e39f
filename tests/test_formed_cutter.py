"""Hu, Zhou & Li 2025 formed cutter: numerical method vs the contact equation, vs a brute-force plane section, flags, CLI."""
import contextlib
import io
import math
import subprocess

import numpy as np
import pytest

from flank_addon.methods.formed_cutter.cutter_profile import (FLAG_CONTACT_JUMP, FLAG_MAXIMUM_POINT, TABLE1, CutterSetup,
                                       FormedCutterError, Section, arc_tooth_profile, arc_tooth_section,
                                       contact_equation_profile, cutter_meridian, cutter_profile,
                                       section_from_profile, table2,
                                       _first_hits)
from flank_addon.cli import main
from flank_addon.geometry.profile import SplineProfile
from flank_addon.geometry.rotors import builtin_by_name
from flank_addon.geometry.screw import screw_to_plane

T = TABLE1


def run(sec, **kw):
    kw.setdefault("swivel_deg", T["swivel_deg"])
    return cutter_profile(sec, T["lead"], T["centre_distance"], **kw)


def brute_plane_min(profile, setup, z, n=40000, tooth=None):
    """Independent minimum distance from the cutter axis to the rotor in the plane Z_u = z.

    Every dense profile sample's helix is followed (Newton in the screw angle) to where it crosses
    the plane; for rotor radii below v0 / tan(phi) the crossing is unique.  Returns min distance.
    """
    u = profile.params(n)
    if tooth is not None:
        u = np.linspace(tooth[0], tooth[1], n)
    # corners (groove edges) must be sampled exactly: the distance grows linearly away from them
    br = np.asarray(getattr(profile, "breaks", []))
    lo, hi = (tooth if tooth is not None else (0.0, profile.period))
    u = np.r_[u, br[(br >= lo) & (br <= hi)]]
    p = profile.eval(u)
    r = np.hypot(p[:, 0], p[:, 1])
    a = np.arctan2(p[:, 1], p[:, 0])
    c, s, e, v0 = math.cos(setup.swivel), math.sin(setup.swivel), setup.eps, setup.v0
    assert r.max() < v0 / math.tan(abs(setup.swivel))    # monotone crossing condition
    out = []
    for zz in np.atleast_1d(z):
        th = np.full(len(u), zz / (c * v0))
        for _ in range(60):
            y = r * np.sin(a + e * th)
            f = -e * s * y + c * v0 * th - zz
            fp = -s * r * np.cos(a + e * th) + c * v0
            th, last = th - f / fp, th
            if np.max(np.abs(th - last)) <= 1e-14 * max(1.0, np.max(np.abs(th))):
                break                        # converged: the crossings to 1e-14 rad, the distances to ~1e-12
        x, y = r * np.cos(a + e * th), r * np.sin(a + e * th)
        Y = c * y + e * s * v0 * th
        out.append(np.min(np.hypot(x - setup.centre_distance, Y)))
    return np.array(out)


def brute_plane_min_all(profile, setup, z, n=20000):
    """Independent minimum distance from the cutter axis to the rotor surface in planes Z_u = z, for
    any swivel (a helix may cross a plane several times).

    Dense profile samples plus every segment break (corners) are turned into the working frame;
    each sample's helix g(th) = c v0 th - e s r sin(a + e th) - Z_u is monotone between its closed
    form critical points cos(a + e th) = c v0 / (s r), and all roots lie within
    |th - Z_u / (c v0)| <= |s| r / (c v0): every crossing is bracketed and bisected.  Every value
    is the distance of a real surface point, so the result is >= the true minimum."""
    u = np.r_[profile.params(n), np.asarray(getattr(profile, "breaks", []), float)]
    p = profile.eval(u)
    cph, sph = math.cos(setup.phase), math.sin(setup.phase)
    p = np.c_[cph * p[:, 0] + sph * p[:, 1], -sph * p[:, 0] + cph * p[:, 1]]
    r, a = np.hypot(p[:, 0], p[:, 1]), np.arctan2(p[:, 1], p[:, 0])
    c, s, e, v0, A = math.cos(setup.swivel), math.sin(setup.swivel), setup.eps, setup.v0, setup.centre_distance
    w = abs(s) * r / (c * v0)
    kappa = c * v0 / (s * r)
    ac = np.arccos(np.clip(kappa, -1, 1))
    nk = int(np.ceil(w.max() / np.pi)) + 1
    out = []
    for zz in np.atleast_1d(z):
        th0 = zz / (c * v0)
        lo, hi = th0 - w, th0 + w
        kc = np.round((a + e * th0) / (2 * np.pi))
        crit = [e * (sg * ac[:, None] + 2 * np.pi * (kc[:, None] + np.arange(-nk, nk + 1)) - a[:, None])
                for sg in (-1, 1)]
        T = np.where((np.abs(kappa) < 1)[:, None], np.hstack(crit), lo[:, None])
        T = np.sort(np.hstack([lo[:, None], np.clip(T, lo[:, None], hi[:, None]), hi[:, None]]), axis=1)
        gT = c * v0 * T - e * s * r[:, None] * np.sin(a[:, None] + e * T) - zz
        i, j = np.nonzero((gT[:, :-1] <= 0) != (gT[:, 1:] <= 0))
        ri, ai, ta, tb, neg = r[i], a[i], T[i, j], T[i, j + 1], gT[i, j] <= 0
        for _ in range(60):
            tm = 0.5 * (ta + tb)
            same = (c * v0 * tm - e * s * ri * np.sin(ai + e * tm) - zz <= 0) == neg
            ta, tb = np.where(same, tm, ta), np.where(same, tb, tm)
        th = 0.5 * (ta + tb)
        Y = c * ri * np.sin(ai + e * th) + e * s * v0 * th
        out.append(np.min(np.hypot(ri * np.cos(ai + e * th) - A, Y)))
    return np.array(out)


def dense_line_min(section, cp, Yb=100.0, n=8001):
    """Minimum of the first-crossing distance over a dense set of lines Y_u of each plane (``section``
    in the rotor frame)."""
    work = section.rotated(-cp.setup.phase)
    Y = np.linspace(-Yb, Yb, n)
    L = _first_hits(work, cp.setup, np.tile(Y, len(cp.z)), np.repeat(cp.z, n), 1e-12)["L"]
    return np.nanmin(L.reshape(len(cp.z), n), axis=1)


@pytest.mark.parametrize("swivel", [10.0, 50.0])
def test_radius_never_exceeds_the_nearest_material_flagged_setups(swivel):
    """In every plane R(Z) <= the distance of every rotor point in it (else the disc enters the rotor).

    At 50 deg a groove edge (the corner tooth / blank cylinder) pokes towards the disc in some planes
    and the first-crossing distance jumps there (lines just beside the edge miss the groove and hit
    deep); the grid of the subdivision search did not see it and R came out up to 2.1 mm too large.
    At 10 deg the minimum is a kink at the edge, found only to ~ slope x eps_b."""
    prof, tooth, _ = arc_tooth_profile()
    z = np.r_[np.linspace(-28.0, 28.0, 15), -4.7242, 4.7242]      # +-4.72: the plane of the 2.1 mm error
    cp = cutter_profile(prof, T["lead"], T["centre_distance"], swivel, tooth=tooth, z=z, eps_b=1e-3)
    assert cp.flags.any()                                         # a flagged (misaligned) set-up
    ref = np.minimum(brute_plane_min_all(prof, cp.setup, cp.z),
                     dense_line_min(section_from_profile(prof, tooth), cp))
    assert np.all(cp.r <= ref + 1e-9), np.max(cp.r - ref)
    assert np.all(cp.r >= ref - 1e-4), np.min(cp.r - ref)        # and not needlessly small


def test_radius_never_exceeds_the_nearest_material_builtin():
    rot = builtin_by_name("srm_a-male", scale=100.0)
    cp = cutter_profile(rot.profile, rot.lead, 180.0, 55.0, handedness=rot.handedness, planes=13, eps_b=1e-3)
    assert cp.flags.any()
    ref = np.minimum(brute_plane_min_all(rot.profile, cp.setup, cp.z, n=40000),
                     dense_line_min(section_from_profile(rot.profile, cp.tooth), cp, n=4001))
    assert np.all(cp.r <= ref + 1e-9), np.max(cp.r - ref)
    assert np.all(cp.r >= ref - 1e-3), np.min(cp.r - ref)


@pytest.mark.parametrize("swivel", [31.0, 50.0])
def test_swept_cutter_never_overcuts_the_tooth(swivel):
    """Independent check by the sweep simulation: the 2000-plane meridian swept along the helix,
    deviation of tooth points along their normals (> 0 material left, < 0 overcut).  Points crowd
    towards the tooth's edges, where the 50 deg cutter used to cut 0.44 mm into the groove (u ~ 0.35)."""
    from flank_addon.simulation.sweep import MeridianPart, RevolvingTool, machined_deviation
    prof, tooth, _ = arc_tooth_profile()
    Z, R, setup = cutter_meridian(prof, T["lead"], T["centre_distance"], swivel, planes=2000, tooth=tooth)
    tool = RevolvingTool([MeridianPart(setup.axis_point, setup.axis_direction, np.c_[Z, R])])
    edge = np.linspace(0.1, 3.0, 8)
    u = np.r_[edge, np.linspace(tooth[0], tooth[1], 26)[1:-1], tooth[1] - edge]      # interior points only
    dev = machined_deviation([tool], prof.eval(u), prof.outward_normal(u), T["lead"] / (2 * np.pi), "right",
                             max_deviation=20.0)
    assert dev.min() >= -1e-3, (dev.min(), u[np.argmin(dev)])
    if swivel == T["swivel_deg"]:                                 # Table 1: no flags, the tooth is reproduced
        assert np.isfinite(dev).all() and np.abs(dev).max() <= 1e-3, np.abs(dev).max()


def test_corners_of_sections():
    pts, u, tg = arc_tooth_section("S3").corners()
    _, tooth, _ = arc_tooth_profile()
    assert len(pts) == 8                                          # 4 grooves x 2 edges
    assert np.allclose(np.hypot(pts[:, 0], pts[:, 1]), T["R2"])
    assert sorted(u[tg]) == pytest.approx([0.0, tooth[1]])        # the tooth's edges, on its side
    assert len(arc_tooth_section("S1").corners()[0]) == 8         # spline knots are not corners
    rot = builtin_by_name("nilson-male", scale=100.0)
    assert len(section_from_profile(rot.profile).corners()[0]) == 0


def test_multi_start_search_finds_a_narrow_deeper_minimum():
    """Two minima: a wide one whose grid samples are lowest and a narrow, deeper one between grid
    samples; the plain search (one start) refines the wrong one."""
    from flank_addon.methods.formed_cutter.cutter_profile import _search, _subdivide

    def f(Y, Z=None):
        return np.minimum(10 + 0.01 * (Y + 30) ** 2, 9.0 + 40.0 * np.abs(Y - 31.3))

    Yb = np.array([64.0])
    grid = np.linspace(-1, 1, 65)[None, :] * Yb[:, None]
    Lg = f(grid)
    assert Lg.min() > 9.5                                          # the grid does not see the deep one
    _, one = _subdivide(f, Yb, 1e-6, grid, Lg)
    y, best = _search(f, np.zeros(1), Yb, 1e-6, grid, Lg)
    assert one[0] > 9.9 and abs(best[0] - 9.0) < 1e-4 and abs(y[0] - 31.3) < 1e-5


def test_s3_matches_contact_equation_within_a_nanometre():
    """Hu, Zhou & Li 2025 Table 2, S3 at eps_b = 0.01 mm: the exact-intersection variant deviates <= 0.001 um."""
    prof, tooth, t_e = arc_tooth_profile()
    setup = CutterSetup(T["centre_distance"], math.radians(T["swivel_deg"]), T["lead"])
    t = np.linspace(-t_e, t_e, 223)
    Zr, Rr, _, ok = contact_equation_profile(prof, setup, T["R1"] * (t + t_e))
    assert ok.all()
    cp = run(arc_tooth_section("S3"), z=Zr, eps_b=0.01, phase=0.0)
    dev = np.abs(cp.r - Rr[np.argsort(Zr)])
    assert dev.max() <= 1e-6                                  # mm
    # and the coarse threshold really is coarse (the test can fail if eps_b were ignored)
    coarse = run(arc_tooth_section("S3"), z=Zr, eps_b=0.8, phase=0.0, analyse=False)
    assert np.abs(coarse.r - Rr[np.argsort(Zr)]).max() > 1e-4


def test_numerical_radius_is_the_global_minimum_brute_force():
    prof, tooth, _ = arc_tooth_profile()
    cp = run(arc_tooth_section("S3"), planes=25, eps_b=1e-3)
    ref = brute_plane_min(prof, cp.setup, cp.z)
    # dense sampling can only over-estimate the minimum (by ~ spacing^2 / R ~ 1e-5 mm)
    assert np.all(cp.r <= ref + 1e-9)
    assert np.max(ref - cp.r) < 2e-5


def test_found_minimum_survives_perturbation_and_dense_line_scan():
    sec = arc_tooth_section("S1")
    cp = run(sec, planes=9, eps_b=1e-4)
    for m in range(len(cp.z)):
        Y = np.r_[cp.y[m] + np.array([-1e-2, -1e-3, 1e-3, 1e-2]), np.linspace(-60, 60, 6001)]
        L = _first_hits(sec, cp.setup, Y, np.full(len(Y), cp.z[m]), 1e-12)["L"]
        # sampled minimum error: 0.5 L'' (eps_b / 2)^2 ~ 1e-11 mm
        assert np.all(L >= cp.r[m] - 1e-9)


def test_contact_points_lie_on_the_rotor_and_on_the_cutter():
    rot = builtin_by_name("srm_a-male", scale=100.0)
    cp = cutter_profile(rot.profile, rot.lead, 180.0, 35.0, handedness=rot.handedness, planes=15)
    assert abs(cp.setup.phase) > 0.1                   # the tooth is not at +x: the pose is really turned
    # on the rotor surface: screw back into z = 0 and measure the distance to the exact spline
    q0 = screw_to_plane(cp.contact, rot.v0, rot.handedness)
    u = cp.contact_u
    assert np.max(np.linalg.norm(q0 - rot.profile.eval(u), axis=1)) < 1e-8
    # on the cutter: via the published pose (axis point and direction in the rotor frame)
    rel = cp.contact - cp.setup.axis_point
    zc = rel @ cp.setup.axis_direction
    rc = np.linalg.norm(rel - zc[:, None] * cp.setup.axis_direction, axis=1)
    assert np.allclose(zc, cp.z, atol=1e-9) and np.allclose(rc, cp.r, atol=1e-9)
    m = cp.setup.cutter_to_rotor
    assert np.allclose(m[:3, :3].T @ m[:3, :3], np.eye(3), atol=1e-14)
    assert np.allclose(cp.setup.to_cutter(cp.contact)[:, 2], cp.z, atol=1e-9)


def test_swivel_sign_aligns_disc_with_helix_for_both_hands():
    for hand in ("right", "left"):
        st = CutterSetup(200.0, math.radians(31.0), 450.0, hand)
        r = st.v0 / math.tan(st.swivel)
        eps = st.eps
        tangent = np.array([0.0, eps * r, st.v0])             # helix tangent at (r, 0, 0)
        assert abs(tangent @ st.axis_direction) < 1e-12


def test_left_hand_mirror_gives_the_same_cutter():
    """The arc-tooth rotor is symmetric in y = 0; the mirror image swaps the hand and keeps (Z, R)."""
    sec = arc_tooth_section("S3")
    a = run(sec, planes=31, eps_b=1e-3, analyse=False)
    b = cutter_profile(sec, T["lead"], T["centre_distance"], T["swivel_deg"], handedness="left", planes=31,
                       eps_b=1e-3, analyse=False)
    assert np.allclose(a.z, b.z, atol=1e-9)
    assert np.max(np.abs(a.r - b.r)) < 1e-6


def test_spline_tooth_close_to_exact_and_line_spline_newton():
    s1 = run(arc_tooth_section("S1"), planes=41, eps_b=1e-3, analyse=False)
    s3 = run(arc_tooth_section("S3"), planes=41, eps_b=1e-3, analyse=False)
    assert np.max(np.abs(s1.r - s3.r)) < 1e-4
    # crossings of a closed spline circle vs the exact line-circle intersection
    th = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    prof = SplineProfile(np.c_[np.cos(th), np.sin(th)] * 10)
    from flank_addon.methods.formed_cutter.cutter_profile import section_from_profile
    sec = section_from_profile(prof)
    q = np.c_[np.zeros(7), np.linspace(-9, 9, 7)]
    d = np.tile([1.0, 0.0], (7, 1))
    cr = sec.crossings(q, d)
    assert len(cr["s"]) == 14
    exact = np.sqrt(100 - q[cr["line"], 1] ** 2) * np.where(cr["entering"], 1, -1)
    assert np.max(np.abs(cr["s"] - exact)) < 1e-6                 # spline interpolation error of the circle


def test_table2_reproduction():
    tab = table2(eps_b_values=(0.8, 0.1, 0.01), schemes=("S2", "S3"))
    assert tab["S3"][-1] <= 0.001                                 # um
    for sch in ("S2", "S3"):
        assert tab[sch][0] > 10 * tab[sch][-1]                    # refinement matters
        assert tab[sch][0] < 2.0                                  # within the paper's order (0.8 um)


def test_table1_case_has_no_flags_and_full_coverage():
    cp = run(arc_tooth_section("S3"), planes=119, eps_b=0.01)
    assert cp.flags.max() == 0 and cp.uncut == [] and cp.on_tooth.all()
    _, tooth, _ = arc_tooth_profile()
    assert cp.contact_u.min() < 1e-6 and cp.contact_u.max() > tooth[1] - 1e-6    # whole tooth touched
    # the radius is the distance to the groove bottom in the middle plane: A - (G - R1)
    assert abs(cp.r.max() - (T["centre_distance"] - (T["G"] - T["R1"]))) < 1e-6


def test_misaligned_swivel_is_flagged_and_tooth_only_radius_checked():
    prof, tooth, _ = arc_tooth_profile()
    cp = run(arc_tooth_section("S3"), swivel_deg=10.0, planes=61, eps_b=1e-3)
    assert np.any(cp.flags & FLAG_MAXIMUM_POINT)
    assert np.any(cp.flags & FLAG_CONTACT_JUMP)
    assert cp.uncut and cp.uncut[0]["u_end"] - cp.uncut[0]["u_start"] > 50
    # independent check of the tooth-only radius (the paper's) and of the all-material radius on the
    # planes where the nearest material is off the tooth (at its edge)
    m = np.flatnonzero(~cp.on_tooth)[::7][:4]
    ref_tooth = brute_plane_min(prof, cp.setup, cp.z[m], tooth=tooth, n=20000)
    ref_all = brute_plane_min(prof, cp.setup, cp.z[m])
    assert np.max(np.abs(cp.r_tooth[m] - ref_tooth)) < 1e-4
    assert np.max(np.abs(cp.r[m] - ref_all)) < 1e-4
    # a steeper swivel: a cutter following the tooth alone would gouge other material
    cp = run(arc_tooth_section("S3"), swivel_deg=50.0, planes=61, eps_b=1e-3)
    assert cp.overcut.max() > 0.1 and np.all(cp.r_tooth >= cp.r - 1e-9)


def test_bad_input_messages():
    sec = arc_tooth_section("S3")
    with pytest.raises(FormedCutterError, match=r"centre distance A = 100.0 must exceed .* 111.69"):
        cutter_profile(sec, 450.0, 100.0, 31.0)
    with pytest.raises(FormedCutterError, match="swivel"):
        cutter_profile(sec, 450.0, 200.0, 90.0)
    with pytest.raises(FormedCutterError, match="lead"):
        cutter_profile(sec, float("nan"), 200.0, 31.0)
    with pytest.raises(FormedCutterError, match="eps_b"):
        cutter_profile(sec, 450.0, 200.0, 31.0, eps_b=0.0)
    with pytest.raises(FormedCutterError, match=r"eps_b = 3.4e\+38 must be > 0 and at most the rotor's outer radius "
                                                r"111.69"):
        cutter_profile(sec, 450.0, 200.0, 31.0, eps_b=3.4e38)      # a float property's infinity
    assert issubclass(FormedCutterError, ValueError)
    assert isinstance(sec, Section)


def cli(*args):
    """``flank_addon cutter ARGS`` through the CLI's main() in this process: its exit code and what it printed
    (test_plan_cli runs the ``python -m flank_addon`` entry point itself)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["cutter", *args])
    return subprocess.CompletedProcess(args, code, out.getvalue(), err.getvalue())


def test_cli_round_trip_and_errors(tmp_path):
    rot = builtin_by_name("nilson-male", scale=100.0)
    csv = tmp_path / "p.csv"
    np.savetxt(csv, rot.profile.points, delimiter=",", header="x,y", comments="")
    out = tmp_path / "c.csv"
    r = cli("--profile", str(csv), "--lead", str(rot.lead), "--center-distance", "180", "--swivel", "35",
            "--planes", "30", "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert "30 planes" in r.stdout and "flagged planes" in r.stdout
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert data.shape == (30, 2) and np.all(np.diff(data[:, 0]) > 0)
    ref = cutter_profile(rot.profile, rot.lead, 180.0, 35.0, planes=30, analyse=False)
    assert np.max(np.abs(data[:, 1] - ref.r)) < 1e-6              # same profile from the CSV points
    bad = tmp_path / "bad.csv"
    bad.write_text("x,y\n" + "\n".join(f"{x},{y}" for x, y in rot.profile.points[:50]) + "\nnan,1\n")
    r = cli("--profile", str(bad), "--lead", "10", "--center-distance", "180", "--swivel", "35", "--out", str(out))
    assert r.returncode == 2 and "not a finite number" in r.stderr
    r = cli("--builtin", "nilson-male", "--scale", "100", "--center-distance", "50", "--swivel", "35",
            "--out", str(out))
    assert r.returncode == 2 and "centre distance A = 50.0 must exceed" in r.stderr
    r = cli("--builtin", "nilson-male", "--scale", "100", "--center-distance", "1e300", "--swivel", "35",
            "--out", str(out))                                      # it overflowed with a traceback
    assert r.returncode == 2 and "centre distance A = 1e+300 is over 100 times the rotor's outer radius 100" in r.stderr
