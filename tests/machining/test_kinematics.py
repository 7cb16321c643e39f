"""Machine kinematics against independent references: the rotor-xa-b contract written out by hand and a
brute-force search of A and B, LinuxCNC's xyzac-trt-kins equations, and the machine file checks."""
import json
import math

import numpy as np
import pytest

from flank_addon.geometry.screw import screw_motion
from flank_addon.machining.machine import MachineError, builtin_machines, load_machine, parse_machine

pytestmark = pytest.mark.xdist_group("machining")     # shared session fixtures: one worker

RNG = np.random.default_rng(20260601)


def rx(deg):
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


M0 = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])     # rotor z -> +X, x -> +Y, y -> +Z


def random_pose():
    tip = RNG.uniform(-40, 40, 3)
    a = RNG.normal(size=3)
    return tip, a / np.linalg.norm(a)


@pytest.mark.parametrize("hand", [1, -1])
def test_rotor_xa_b_pass_is_the_contract(hand):
    """Every joint row of a pass puts the tool where the written contract says: rotor point p at machine
    Rx(A) M0 p, tool axis (sin B, 0, cos B), XYZ = the tip; Y, Z, B fixed, X and A linear in t."""
    m = load_machine("rotor-xa-b")
    v0 = 7.5
    for _ in range(20):
        tip, a = random_pose()
        t = np.sort(RNG.uniform(-3, 3, 6))
        J = m.pass_joints(tip, a, hand, v0, t, near_spin_deg=RNG.uniform(-1000, 1000))
        P = screw_motion(np.broadcast_to(tip, (len(t), 3)), -t, v0, hand)
        ax = screw_motion(np.broadcast_to(a, (len(t), 3)), -t, 0.0, hand)
        for k in range(len(t)):
            X, Y, Z, A, B = J[k]
            assert np.allclose(rx(A) @ M0 @ P[k], [X, Y, Z], atol=1e-9)
            assert np.allclose(rx(A) @ M0 @ ax[k], [math.sin(math.radians(B)), 0.0, math.cos(math.radians(B))],
                               atol=1e-12)
        assert np.ptp(J[:, 1]) < 1e-9 and np.ptp(J[:, 2]) < 1e-9 and np.ptp(J[:, 4]) < 1e-12
        assert np.allclose(np.diff(J[:, 3]), hand * np.degrees(np.diff(t)), atol=1e-9)    # A = A0 + hand t
        assert np.allclose(np.diff(J[:, 0]), -v0 * np.diff(t), atol=1e-9)                # X = X0 - v0 t
        assert abs(J[:, 4]).max() <= 90.0 + 1e-9                                            # cos B >= 0


def test_rotor_xa_b_angles_by_brute_force():
    """A0 and B of a rotor-frame axis found by scanning A in 0.01 deg steps for the turn that puts the axis
    in the machine's XZ plane on the +Z side (the derivation in docs/rotor-xa-b.md)."""
    m = load_machine("rotor-xa-b")
    grid = np.arange(0.0, 360.0, 0.01)
    c, s = np.cos(np.radians(grid)), np.sin(np.radians(grid))
    for _ in range(10):
        tip, a = random_pose()
        b = M0 @ a
        y = c * b[1] - s * b[2]
        z = s * b[1] + c * b[2]
        k = np.argmin(np.where(z > 0, np.abs(y), np.inf))
        J = m.pass_joints(tip, a, 1, 5.0, np.array([0.0]))
        assert abs(((J[0, 3] - grid[k]) + 180.0) % 360.0 - 180.0) < 0.011
        assert abs(J[0, 4] - math.degrees(math.atan2(b[0], z[k]))) < 0.02


def trt_kins_inverse(world, a_deg, c_deg, rot_point, y_off, z_off, tool_off=0.0):
    """LinuxCNC xyzac-trt-kins' inverse kinematics (trtfuncs.c, xyzacKinematicsInverse): world pose (tool tip
    in table coordinates, A, C) -> joint X, Y, Z."""
    a, c = math.radians(a_deg), math.radians(c_deg)
    x, y, z = np.asarray(world, float) - rot_point
    dy, dz = y_off, z_off + tool_off
    jx = math.cos(c) * x - math.sin(c) * y
    jy = (math.sin(c) * math.cos(a) * x + math.cos(c) * math.cos(a) * y - math.sin(a) * z
          - math.cos(a) * dy + math.sin(a) * dz + dy)
    jz = (math.sin(c) * math.sin(a) * x + math.cos(c) * math.sin(a) * y + math.cos(a) * z
          - math.sin(a) * dy - math.cos(a) * dz + dz)
    return np.array([jx, jy, jz]) + rot_point


def test_xyzac_trt_joints_are_linuxcnc_kinematics():
    """The non-TCP program holds joints = LinuxCNC's xyzac-trt inverse of the TCP program's world pose (tip in
    table coordinates + A, C), with the HAL pins the machine file documents; the spindle is vertical."""
    joint, tcp = load_machine("xyzac-trt"), load_machine("xyzac-trt-tcp")
    rot_point = joint.axes["C"].pivot
    y_off, z_off = (joint.axes["A"].pivot - rot_point)[1:]
    for _ in range(10):
        tip, a = random_pose()
        a[2] = abs(a[2]) + 0.3                                   # within the A limits
        a /= np.linalg.norm(a)
        t = np.linspace(-1.0, 1.5, 4)
        J = joint.pass_joints(tip, a, -1, 6.0, t, near_spin_deg=0.0)
        W = tcp.pass_joints(tip, a, -1, 6.0, t, near_spin_deg=0.0)
        assert np.allclose(J[:, 3:], W[:, 3:])
        P = screw_motion(np.broadcast_to(tip, (len(t), 3)), -t, 6.0, -1)
        assert np.allclose(W[:, :3], P, atol=1e-12)              # mount z -> +Z, x -> +X: work = rotor frame
        for k in range(len(t)):
            ref = trt_kins_inverse(W[k, :3], W[k, 3], W[k, 4], rot_point, y_off, z_off)
            assert np.allclose(J[k, :3], ref, atol=1e-9)
            ax = screw_motion(a, -t[k], 0.0, -1)
            R = rx(J[k, 3]) @ np.array([[math.cos(math.radians(J[k, 4])), -math.sin(math.radians(J[k, 4])), 0],
                                        [math.sin(math.radians(J[k, 4])), math.cos(math.radians(J[k, 4])), 0],
                                        [0, 0, 1]])
            assert np.allclose(R @ ax, [0.0, 0.0, 1.0], atol=1e-12)


@pytest.mark.parametrize("name", builtin_machines())
def test_forward_inverts_the_pass(name):
    m = load_machine(name)
    for hand in (1, -1):
        tip, a = random_pose()
        a[2] = abs(a[2]) + 0.3
        a /= np.linalg.norm(a)
        t = np.linspace(0.0, 2.0, 5)
        J = m.pass_joints(tip, a, hand, 4.0, t)
        P, A = m.forward(J)
        assert np.allclose(P, screw_motion(np.broadcast_to(tip, (5, 3)), -t, 4.0, hand), atol=1e-9)
        assert np.allclose(A, screw_motion(np.broadcast_to(a, (5, 3)), -t, 0.0, hand), atol=1e-12)


def _file():
    with open(load_machine("rotor-xa-b").source) as fh:
        return json.load(fh)


@pytest.mark.parametrize("mutate, message", [
    (lambda d: d.update(schema="flank-machine/0"), "schema must be 'flank-machine/1'"),
    (lambda d: d.pop("rotor_mount"), "missing key 'rotor_mount'"),
    (lambda d: d["linear_axes"]["Y"].update(max_feed=-5), "linear_axes.Y.max_feed must be > 0, got -5"),
    (lambda d: d["linear_axes"]["X"].pop("rapid"), "missing key linear_axes.X.rapid"),
    (lambda d: d["rotary_axes"]["A"].update(on="floor"), "rotary_axes.A.on must be 'table' or 'head'"),
    (lambda d: d["rotary_axes"]["A"].update(direction=[0, 1, 0]), "rotary_axes.A (the innermost table axis)"),
    (lambda d: d["rotary_axes"]["B"].update(min=200.0), "rotary_axes.B: min 200 must be below max 110"),
    (lambda d: d["rotor_mount"].update(z="+Q"), "rotor_mount.z must be one of"),
    (lambda d: d["controller"].update(tcp="yes"), "controller.tcp must be true or false, got 'yes'"),
    (lambda d: d["linear_axes"]["Z"].update(min="low"), "linear_axes.Z.min must be a finite number, got 'low'"),
    (lambda d: d.update(name="mill\nB"), "must be printable ASCII (no line breaks): the programs' comments"),
    (lambda d: d.update(name="Fr\u00e4se"), "name 'Fr\u00e4se' must be printable ASCII"),
    (lambda d: d.update(tool_axis=[0, 0, 1]), "tool_axis must be one of +X, -X, +Y, -Y, +Z, -Z, got "),
    (lambda d: d["rotor_mount"].update(x=None), "rotor_mount.x must be one of +X"),
    (lambda d: d["rotary_axes"]["A"].update(pivot=[1e300, 0, 0]), "A.pivot.0. = 1e+300 is outside -1e+06..1e+06"),
    (lambda d: d.update(pivot_length=1e300), "pivot_length = 1e+300 is outside 0..1e+06"),
    (lambda d: d["linear_axes"]["X"].update(max=1e308), "linear_axes.X.max = 1e+308 is outside -1e+06..1e+06"),
    (lambda d: d["rotary_axes"]["A"].update(min=-1e12), "rotary_axes.A.min = -1000000000000.0 is outside -1e+09..1e+09"),
])
def test_malformed_machine_is_refused_by_key(mutate, message):
    data = _file()
    mutate(data)
    with pytest.raises(MachineError, match=message.replace("(", r"\(").replace(")", r"\)").replace("+", r"\+")):
        parse_machine(data)


def test_unknown_machine_lists_the_valid_names(tmp_path):
    with pytest.raises(MachineError) as e:
        load_machine("mill-9000")
    assert all(n in str(e.value) for n in ("rotor-xa-b", "xyzac-trt", "xyzac-trt-tcp"))
    bad = tmp_path / "m.json"
    bad.write_text("{nope")
    with pytest.raises(MachineError, match="not valid JSON"):
        load_machine(str(bad))


def test_the_gauge_length_is_the_tools_own_length(single_flank_plan, two_tool_plan, formed_cutter_plan):
    """The gauge length (programmed tip to the end of the shank, where the spindle's gauge line is taken; on a head
    with tool_length_in_pivot it sets the program's XYZ) is the tool as built: flute length 25 + shank 45 = 70 mm
    for the fixture's cone, each preset's flute length plus its shank for the two-tool plan, the disc's width plus
    its arbor for the formed cutter.  The cone's model reaches 1.45 mm below its flat tip (the tip sphere) and
    once counted in the gauge length, which put the tip that far off on such a head."""
    from flank_addon.io.plan import strip_tool
    from flank_addon.machining.operation import build_operation
    from flank_addon.machining.rotor_body import rotor_body
    from flank_addon.posts.readback import tool_gauges, tool_table

    op = build_operation([single_flank_plan], rotor_body(single_flank_plan), lobes=[0])
    assert op.tools[0].gauge_length == pytest.approx(70.0, abs=1e-9)
    assert op.tools[0].shape.h_range()[0] == pytest.approx(-(1.5 / math.cos(math.radians(2)) - 1.5 * math.tan(
        math.radians(2))), abs=1e-9)
    assert tool_gauges(tool_table([single_flank_plan])[0]) == {1: op.tools[0].gauge_length}
    op = build_operation([two_tool_plan], rotor_body(two_tool_plan), lobes=[0])
    assert len(op.tools) == 2
    for t in op.tools:
        tool = next(strip_tool(two_tool_plan, s) for s in range(len(two_tool_plan["strips"]))
                    if t.name.startswith(f"T{t.number} {strip_tool(two_tool_plan, s)['name']} "))
        assert t.gauge_length == pytest.approx(tool["h"] + tool["shank_length"], abs=1e-9), t.name
    op = build_operation([formed_cutter_plan], rotor_body(formed_cutter_plan), lobes=[0])
    tool = formed_cutter_plan["tool"]
    assert op.tools[0].gauge_length == pytest.approx(tool["width"] + tool["arbor_length"], rel=1e-9)
