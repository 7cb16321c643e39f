"""collision: a shank through a lobe, a tangent cone with its shank out of the rotor, buried tools,
finite rotor ends, and agreement with an independent brute force (tool volume samples tested
against the slices of the rotor mesh helical_body_mesh)."""
import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from cone_poses import surface_frame, tangent_pose
from flank_addon.simulation.collision import (ProfileSolid, check_rotor_collisions, rotor_profile,
                                   sd_flat_cone)
from flank_addon.tooling.cone import ConePose, ConeTool
from flank_addon.geometry.profile import points_in_polygon
from flank_addon.geometry.rotors import helical_body_mesh
from flank_addon.geometry.screw import screw_motion
from flank_addon.methods.single_flank.strip_cover import covered_intervals

TOOL = ConeTool(math.asin(0.1), 0.05, 0.08, 0.04, 0.6)


@pytest.fixture
def female_solid(female):
    """The asymmetric female rotor, its surface and its profile solid (cheap)."""
    r, s = female
    return r, s, ProfileSolid(*rotor_profile(r))


def good_pose(S, fr, u=0.695):
    """Tangent cone on flank 1 at u, the direction about the normal that does not overcut the flank."""
    _, n, xu, _, _ = surface_frame(S, u)
    e1 = xu / np.linalg.norm(xu)
    e2 = np.cross(n, e1)
    th = np.linspace(0, np.pi, 12, endpoint=False)
    poses = [tangent_pose(S, TOOL, u, np.cos(a) * e1 + np.sin(a) * e2) for a in th]
    c = covered_intervals(poses, S, fr, 1e-4, 1e-4, n=150, search=0.02)
    ok = [k for k, pc in enumerate(c.poses) if pc.max_overcut == 0.0 and pc.intervals]
    return poses[ok[0]]


def shank_through_lobe(r, lobe=2):
    """Cone outside the rotor at radius 1.1-1.4, pointing at the axis: the shank runs through lobe k."""
    p = r.profile.eval(r.tip_params[lobe])
    rad = np.r_[p / np.linalg.norm(p), 0.0]
    return ConePose(TOOL, 1.4 * rad, -rad)


# ---------------------------------------------------------------- brute force reference
def tool_volume_samples(pose, spacing=0.008):
    """Points filling the flat-ended cone and the shank (grid in the tool frame), tagged by part."""
    t, a = pose.tool, pose.axis
    e1 = np.cross(a, [1.0, 0, 0] if abs(a[0]) < 0.9 else [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    c1 = pose.tip - t.c1_offset * a
    out, tags = [], []
    for name, h0, h1, rf in (("cone", 0.0, t.h, lambda h: t.r1c + (t.r2c - t.r1c) * h / t.h),
                             ("shank", t.h, t.h + t.shank_length, lambda h: t.shank_radius)):
        R = max(rf(h0), rf(h1))
        g = np.arange(-R, R + 1e-12, spacing)
        X, Y = np.meshgrid(g, g)
        for h in np.arange(h0, h1 + 1e-12, spacing):
            m = X ** 2 + Y ** 2 <= rf(h) ** 2
            pts = c1 + h * a + X[m][:, None] * e1 + Y[m][:, None] * e2
            out.append(pts)
            tags += [name] * len(pts)
    return np.vstack(out), np.array(tags)


class MeshSlices:
    """The rotor body from helical_body_mesh: each vertex ring is the rotor's section at its z."""

    def __init__(self, r, z0, z1, n_profile=720):
        L = z1 - z0
        v, _ = helical_body_mesh(r.profile, r.v0, r.handedness, L, n_profile=n_profile,
                                 n_axial=int(math.ceil(L / 0.002)))
        n = n_profile
        rings = v[: (len(v) // n) * n].reshape(-1, n, 3)
        # shift the body z in [0, L] to [z0, z1] by the rotor's own screw motion
        self.rings = screw_motion(rings, z0 / r.v0, r.v0, r.handedness)
        self.z = self.rings[:, 0, 2]
        self.n = n

    def inside(self, X):
        """(inside, in-slice distance to the section, profile index of the nearest section vertex)."""
        k = np.clip(np.searchsorted(self.z, X[:, 2]), 0, len(self.z) - 1)
        ins = np.zeros(len(X), bool)
        dist = np.zeros(len(X))
        near = np.zeros(len(X), int)
        for kk in np.unique(k):
            m = k == kk
            poly = self.rings[kk, :, :2]
            ins[m] = points_in_polygon(X[m, :2], poly)
            d, j = cKDTree(poly).query(X[m, :2])
            dist[m], near[m] = d, j
        return ins, dist, near


def brute_force(r, solid, pose, spacing=0.008, depth_min=3e-3):
    """Lobes hit by tool samples deeper than depth_min inside the rotor (per part)."""
    X, tags = tool_volume_samples(pose, spacing)
    ms = MeshSlices(r, X[:, 2].min() - 0.01, X[:, 2].max() + 0.01)
    ins, dist, near = ms.inside(X)
    deep = ins & (dist > depth_min)
    idx2048 = np.round(near * (len(solid.points) / ms.n)).astype(int) % len(solid.points)
    lobes = {(str(t), solid.lobe(int(solid.flank_of[i]))) for t, i in zip(tags[deep], idx2048[deep])}
    return lobes, ins, dist


# ---------------------------------------------------------------- tests
def test_flat_cone_signed_distance_exact():
    rng = np.random.default_rng(3)
    c1, c2, r1, r2 = np.array([0.1, 0.2, 0.3]), np.array([0.4, 0.0, 0.5]), 0.05, 0.12
    q = c1 + rng.uniform(-0.25, 0.25, (4000, 3))
    d = sd_flat_cone(q, c1, c2, r1, r2)
    # reference: dense sampling of the boundary (side + both discs), sign by the trapezoid test
    a = (c2 - c1) / np.linalg.norm(c2 - c1)
    H = np.linalg.norm(c2 - c1)
    e1 = np.cross(a, [1, 0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    th = np.linspace(0, 2 * np.pi, 360, endpoint=False)
    ring = np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2
    B = [c1 + h * a + (r1 + (r2 - r1) * h / H) * ring for h in np.linspace(0, H, 400)]
    B += [c + rr * ring for c, R in ((c1, r1), (c2, r2)) for rr in np.linspace(0, R, 60)]
    ref, _ = cKDTree(np.vstack(B)).query(q)
    w = q - c1
    h = w @ a
    rho = np.linalg.norm(w - h[:, None] * a, axis=1)
    inside = (h >= 0) & (h <= H) & (rho <= r1 + (r2 - r1) * h / H)
    assert inside.sum() > 50
    np.testing.assert_array_equal(d < 0, inside)
    np.testing.assert_allclose(np.abs(d), ref, atol=1.2e-3)      # sample spacing of the reference


def test_shank_through_lobe_is_caught(female_solid):
    r, S, solid = female_solid
    rep = check_rotor_collisions([shank_through_lobe(r, 2)], r)[0]
    assert rep.collides
    shank = [c for c in rep.collisions if c["part"] == "shank"]
    assert shank and not [c for c in rep.collisions if c["part"] == "cone"]
    assert {c["lobe"] for c in shank} == {2}
    assert {c["flank"] for c in shank} <= {3, 4}
    assert max(c["depth"] for c in shank) > 0.03            # nearly the shank radius 0.04
    # the reported point is on the rotor surface and inside the shank
    for c in shank:
        x = np.array(c["point"])
        assert solid.nearest(screw_motion(x, -x[2] / r.v0, r.v0, r.handedness)[None, :2])[0][0] < 1e-4
        sh0, sh1, rad = shank_through_lobe(r, 2).shank
        ax = (sh1 - sh0) / np.linalg.norm(sh1 - sh0)
        w = x - sh0
        assert np.linalg.norm(w - (w @ ax) * ax) < rad


def test_tangent_cone_with_shank_out_is_free(female_solid):
    r, S, solid = female_solid
    fr = r.flanks[1]
    pose = good_pose(S, fr)
    rep = check_rotor_collisions([pose], r, target_flanks=[1], tolerance=1e-4)[0]
    assert not rep.collides, rep.collisions
    # the same cone pushed 5e-3 into its flank: a cone collision on the target flank
    _, n, *_ = surface_frame(S, 0.695)
    pushed = ConePose(pose.tool, pose.tip - 5e-3 * n, pose.axis)
    rep = check_rotor_collisions([pushed], r, target_flanks=[1], tolerance=1e-4)[0]
    assert rep.collides
    hit = [c for c in rep.collisions if c["part"] == "cone" and c["flank"] == 1]
    assert hit and hit[0]["target"] and 4e-3 < max(c["depth"] for c in hit) < 6e-3
    # without declaring flank 1 the target, even the touching pose's contact is within numerical zero
    rep = check_rotor_collisions([pose], r, target_flanks=[], tolerance=0.0)[0]
    assert all(c["depth"] < 1e-6 for c in rep.collisions)


def test_buried_tool_and_finite_ends(female_solid):
    r, S, solid = female_solid
    small = ConeTool(math.asin(0.1), 0.02, 0.03, 0.02, 0.05)
    # a point deep inside lobe 0; the tool axis along its helix stays inside the lobe
    p = 0.8 * r.profile.eval(r.tip_params[0])
    h = 1 if r.handedness == "right" else -1
    helix = np.r_[h * np.array([-p[1], p[0]]), r.v0]
    for z in (1.0, -2.0):
        X = screw_motion(np.r_[p, 0.0], z / r.v0, r.v0, r.handedness)
        ax = screw_motion(helix, z / r.v0, 0.0, r.handedness)
        pose = ConePose(small, X, ax)
        rep = check_rotor_collisions([pose], r)[0]
        assert rep.collides
        assert {c["source"] for c in rep.collisions} == {"solid"}     # no surface enters the tool
        assert {c["lobe"] for c in rep.collisions} == {0}
    # beyond the end of the finite rotor z in [0, 3.2]: free there, colliding for the infinite one
    X = screw_motion(np.r_[p, 0.0], 3.4 / r.v0, r.v0, r.handedness)
    pose = ConePose(small, X, [0.0, 0.0, 1.0])
    assert check_rotor_collisions([pose], r)[0].collides
    assert not check_rotor_collisions([pose], r, z_range=(0.0, 3.2))[0].collides
    # the tip poking 0.03 into the end face z = 3.2 from above
    X = screw_motion(np.r_[p, 0.0], (3.2 - 0.03 + small.c1_offset) / r.v0, r.v0, r.handedness)
    rep = check_rotor_collisions([ConePose(small, X, [0.0, 0.0, 1.0])], r, z_range=(0.0, 3.2))[0]
    assert rep.collides
    assert max(c["depth"] for c in rep.collisions) == pytest.approx(0.03, abs=2e-3)
    # a shank crossing lobe 2 only above the end face is free, crossing it below is not
    pose = shank_through_lobe(r, 2)
    assert check_rotor_collisions([pose], r, z_range=(-1.0, 1.0))[0].collides
    assert not check_rotor_collisions([pose], r, z_range=(0.2, 1.0))[0].collides


def test_agrees_with_brute_force(female_solid):
    r, S, solid = female_solid
    rng = np.random.default_rng(11)
    poses = [good_pose(S, r.flanks[1]), shank_through_lobe(r, 2), shank_through_lobe(r, 5)]
    while len(poses) < 14:
        ang = rng.uniform(0, 2 * np.pi)
        rho = rng.uniform(0.5, 1.3)
        tip = np.array([rho * math.cos(ang), rho * math.sin(ang), rng.uniform(-0.2, 0.2)])
        ax = rng.normal(size=3)
        poses.append(ConePose(TOOL, tip, ax))
    reps = check_rotor_collisions(poses, r, target_flanks=[], tolerance=0.0)
    n_hit = n_free = 0
    for pose, rep in zip(poses, reps):
        lobes_bf, ins, dist = brute_force(r, solid, pose)
        depth = max((c["depth"] for c in rep.collisions), default=0.0)
        if depth > 8e-3:
            assert lobes_bf, rep.collisions
            reported = {(c["part"], c["lobe"]) for c in rep.collisions if c["depth"] > 1e-3}
            assert lobes_bf <= reported, (lobes_bf, reported)
            n_hit += 1
        elif not rep.collides:
            assert not (ins & (dist > 2e-3)).any()
            n_free += 1
    assert n_hit >= 3 and n_free >= 2


def test_depth_agrees_with_dense_time_sampling(female_solid):
    """The reported depth -D(p) against a dense scan of sd_part(S_t(p)) over t (no time windows)."""
    r, S, solid = female_solid
    pose = shank_through_lobe(r, 2)
    rep = check_rotor_collisions([pose], r)[0]
    sh0, sh1, rad = pose.shank
    from flank_addon.simulation.sweep import sd_cylinder
    P, _ = rotor_profile(r)
    for c in rep.collisions:
        p = np.r_[P[c["profile_index"]], 0.0]
        t = np.linspace(-1.0, 1.0, 200001)
        d = sd_cylinder(screw_motion(p[None, :], t[:, None], r.v0, r.handedness), sh0, sh1, rad)
        assert c["depth"] == pytest.approx(-d.min(), abs=1e-6)


def test_batch_equals_single(female_solid):
    r, S, solid = female_solid
    poses = [good_pose(S, r.flanks[1]), shank_through_lobe(r, 2), shank_through_lobe(r, 4)]
    batch = check_rotor_collisions(poses, r, target_flanks=[1], tolerance=1e-4)
    for p, b in zip(poses, batch):
        s = check_rotor_collisions([p], r, target_flanks=[1], tolerance=1e-4)[0]
        assert s.collides == b.collides
        assert [(c["part"], c["flank"], round(c["depth"], 9)) for c in s.collisions] == \
               [(c["part"], c["flank"], round(c["depth"], 9)) for c in b.collisions]


def test_binned_point_in_polygon_equals_plain(female_solid):
    r, S, solid = female_solid
    rng = np.random.default_rng(5)
    q = np.vstack([rng.uniform(-1.05, 1.05, (3000, 2)), solid.points + 1e-7 * rng.normal(size=solid.points.shape)])
    np.testing.assert_array_equal(solid.contains(q), points_in_polygon(q, solid.points))
