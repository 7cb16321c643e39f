# SPDX-License-Identifier: GPL-3.0-or-later
"""Fuzz every flank.* operator of the installed extension: wrong selections (nothing active, an empty, a
camera, an empty mesh, one triangle, loose edges, NaN vertices, a cube = non-helical), non-manifold meshes (an
edge shared by 3 faces, two disjoint shells, duplicate vertices with zero-area faces -- alone and on a rotor's
mesh -- and an unwelded rotor, STL style), degenerate tools of the free-form and paraboloid planners and, on a
generated rotor, every numeric property set to NaN, infinity, a negative and a huge value one at a time.

Recorded per call: the result, the message, whether a Python traceback reached the message, the seconds,
and the data-blocks that a *failed* call left behind (must be none).  Scenario for test_blender_fuzz.py."""
import math
import time

import driver

SPECIAL = (("nan", float("nan")), ("inf", float("inf")), ("neg", -1.0), ("huge", 1e9))
SURFACE_OPS = ("flank.plan_freeform", "flank.preview_guiding")   # numeric fuzz on a small blade, not the rotor
BUDGET = 3.0             # seconds a single accepted call may take before later sizes of that operator are skipped
ALWAYS = ("nan", "inf")  # never skipped: a non-finite number must be refused however slow an accepted call was
# Small sizes passed along with every call unless that property is the one being fuzzed: the fuzz checks
# refusals, messages and leaks, not the quality of a plan, so an accepted call need not be a full-size run.
CHEAP = {
    "flank.plan_single_flank": dict(seeds=2, rounds=1, envelope_rings=8),
    "flank.plan_double_flank": dict(radii=40, samples=20, envelope_rings=8),
    "flank.formed_cutter": dict(planes=24, sample_points=16, resolution=96),
    "flank.cutter_region": dict(grid=(8, 10, 10), samples=64),
    "flank.render_report": dict(width=320, height=200),
    "flank.error_plot": dict(width=320, height=200),
}


# Companions that make the property under test count: the single-flank cone length is only read with the
# shape 'length' (with the default 'alpha' every value of it would plan a full run that ignores it).
USED_WITH = {("flank.plan_single_flank", "length"): dict(shape="length")}
# ... and the settings that make an operator read the selection (the formed cutter's default source is the
# built-in Table 1 rotor: it would plan the same cutter for every wrong selection)
READS_SELECTION = {"flank.formed_cutter": dict(source="ACTIVE")}


def _cheap(idname, prop=None):
    """The small companion settings of ``idname`` without ``prop`` (the property under test), plus what makes
    ``prop`` count."""
    out = {k: v for k, v in CHEAP.get(idname, {}).items() if k != prop}
    out.update(USED_WITH.get((idname, prop), {}))
    return out


def _datablocks(bpy):
    return dict(objects=len(bpy.data.objects), meshes=len(bpy.data.meshes), collections=len(bpy.data.collections),
                actions=len(bpy.data.actions), images=len(bpy.data.images), materials=len(bpy.data.materials),
                texts=len(bpy.data.texts), curves=len(bpy.data.curves))


def _call(bpy, idname, **kw):
    op = getattr(bpy.ops.flank, idname.split(".", 1)[1])
    before = _datablocks(bpy)
    t0 = time.perf_counter()
    try:
        ret, err, other = sorted(op(**kw)), None, None
    except RuntimeError as ex:               # an ERROR report (or a traceback Blender turned into one)
        ret, err, other = None, str(ex), None
    except Exception as ex:                  # bad keyword etc.: a defect of the fuzzer, recorded too
        ret, err, other = None, str(ex), type(ex).__name__
    after = _datablocks(bpy)
    leak = {k: after[k] - before[k] for k in before if after[k] != before[k]}
    return dict(op=idname, kw={k: repr(v) for k, v in kw.items()}, result=ret, error=err, other=other,
                traceback=bool(err and "Traceback" in err), seconds=time.perf_counter() - t0,
                leaked=leak if ret != ["FINISHED"] else {})


def _operators(bpy):
    return sorted("flank." + name for name in dir(bpy.ops.flank) if not name.startswith("_"))


def _mesh_object(bpy, name, verts, edges, faces):
    me = bpy.data.meshes.new(name)
    me.from_pydata(verts, edges, faces)
    ob = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def _activate(bpy, ob):
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    bpy.context.view_layer.objects.active = ob
    if ob is not None:
        ob.select_set(True)


def _rotor_arrays(bpy, np):
    """Vertices and faces of a small generated rotor (the object itself is removed again)."""
    driver._run_op(bpy.ops.flank.generate_rotor, kind="asymmetric", part="female", resolution=120, axial=12)
    ob = bpy.context.active_object
    me = ob.data
    V = np.empty(3 * len(me.vertices))
    me.vertices.foreach_get("co", V)
    F = [list(p.vertices) for p in me.polygons]
    bpy.data.objects.remove(ob)
    bpy.data.meshes.remove(me)
    return V.reshape(-1, 3), F


def _non_manifold(bpy, np):
    """label -> mesh object: non-manifold meshes, alone and made from a rotor's mesh (no custom properties)."""
    out = {}
    out["nm_fin"] = _mesh_object(bpy, "Fuzz Fin", [(0, 0, 0), (1, 0, 0), (0.5, 1, 0), (0.5, -1, 0), (0.5, 0, 1)], [],
                                 [(0, 1, 2), (1, 0, 3), (0, 1, 4)])            # edge 0-1 shared by 3 faces
    tet = np.array([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)], float)
    tf = [(0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)]
    out["nm_two_shells"] = _mesh_object(bpy, "Fuzz Two Shells", [tuple(v) for v in np.vstack([tet, tet + 3.0])], [],
                                        tf + [tuple(i + 4 for i in f) for f in tf])
    grid = [(x, y, 0.0) for y in range(3) for x in range(3)]
    gf = [(0, 1, 4, 3), (1, 2, 5, 4), (3, 4, 7, 6), (4, 5, 8, 7)]
    out["nm_degenerate"] = _mesh_object(bpy, "Fuzz Degenerate", grid + [(0.0, 0.0, 0.0), (0.5, 0.0, 0.0)], [],
                                        gf + [(0, 9, 10), (0, 1, 10)])         # vertex 9 duplicates 0; zero areas
    V, F = _rotor_arrays(bpy, np)
    n = len(V)
    R = float(np.abs(V[:, :2]).max())
    a, b = F[0][:2]
    fin_tip = [V[a][0] * 1.5, V[a][1] * 1.5, V[a][2]]
    out["nm_rotor_fin"] = _mesh_object(bpy, "Fuzz Rotor Fin", [tuple(v) for v in np.vstack([V, [fin_tip]])], [],
                                       F + [(a, b, n)])
    out["nm_rotor_two_shells"] = _mesh_object(bpy, "Fuzz Rotor Two Shells",
                                              [tuple(v) for v in np.vstack([V, V + [3.0 * R, 0.0, 0.0]])], [],
                                              F + [[i + n for i in f] for f in F])
    extra = np.vstack([V[:3], V[0] + [1e-3, 0.0, 0.0]])                       # duplicates of 0, 1, 2 and a point
    out["nm_rotor_dup_zero"] = _mesh_object(bpy, "Fuzz Rotor Duplicates", [tuple(v) for v in np.vstack([V, extra])],
                                            [], F + [(n, n + 1, n + 2), (0, n + 3, n)])
    VV, FF = [], []
    for f in F:                                                                # every face its own vertices
        FF.append(list(range(len(VV), len(VV) + len(f))))
        VV += [tuple(V[i]) for i in f]
    out["nm_rotor_unwelded"] = _mesh_object(bpy, "Fuzz Rotor STL", VV, [], FF)
    return out


FF_TOOLS = (("r1_r2_0", dict(r1=0.0, r2=0.0, length=0.5)), ("L_eq_dr", dict(r1=0.02, r2=0.07, length=0.05)),
            ("L_lt_dr", dict(r1=0.1, r2=0.01, length=0.05)), ("L_0", dict(r1=0.05, r2=0.05, length=0.0)),
            ("all_0", dict(r1=0.0, r2=0.0, length=0.0)), ("r1_nan", dict(r1=float("nan"))),
            ("r2_nan", dict(r2=float("nan"))), ("L_nan", dict(length=float("nan"))),
            ("r1_neg", dict(r1=-0.01)), ("r2_inf", dict(r2=float("inf"))))
GROOVE_TOOLS = (("a_0", dict(a=0.0)), ("b_0", dict(b=0.0)), ("a_b_0", dict(a=0.0, b=0.0)), ("a_pos", dict(a=0.05)),
                ("b_neg", dict(b=-7.2)), ("a_nan", dict(a=float("nan"))), ("b_nan", dict(b=float("nan"))),
                ("lens_gt_R", dict(a=-0.001)), ("lens_eq_R", dict(a=-0.018)), ("R_0", dict(radius=0.0)),
                ("pitch_0", dict(pitch=0.0)), ("b_inf", dict(b=float("inf"))), ("a_minus_inf", dict(a=float("-inf"))),
                ("tiny_lens", dict(a=-1e6, b=1e-9)))


def _degenerate_tools(bpy, calls):
    """Degenerate tools of the free-form planner (on the parabolic blade) and of the paraboloid groove."""
    driver._run_op(bpy.ops.flank.add_test_surface, kind="parabolic_blade", size=1.0, resolution=16)
    blade = bpy.context.active_object
    for tag, kw in FF_TOOLS:
        _activate(bpy, blade)
        c = _call(bpy, "flank.plan_freeform", samples=8, columns=6, max_evaluations=20, **kw)
        c.update(subject="ff_tool", case=tag)
        calls.append(c)
    for tag, kw in GROOVE_TOOLS:
        _activate(bpy, None)
        c = _call(bpy, "flank.paraboloid_groove", resolution=64, **kw)
        c.update(subject="groove_tool", case=tag)
        calls.append(c)
    me = blade.data
    bpy.data.objects.remove(blade)
    bpy.data.meshes.remove(me)


def scenario(bpy, res, args):
    import numpy as np

    ops = _operators(bpy)
    res["operators"] = ops
    calls = []
    nan = float("nan")
    # ---------------------------------------------------------------- wrong selections, default properties
    cam = bpy.data.objects.new("Fuzz Camera", bpy.data.cameras.new("Fuzz Camera"))
    emp = bpy.data.objects.new("Fuzz Empty", None)
    for ob in (cam, emp):
        bpy.context.scene.collection.objects.link(ob)
    subjects = {
        "nothing": None, "camera": cam, "empty": emp,
        "empty_mesh": _mesh_object(bpy, "Fuzz Empty Mesh", [], [], []),
        "triangle": _mesh_object(bpy, "Fuzz Triangle", [(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)]),
        "loose_edges": _mesh_object(bpy, "Fuzz Edges", [(0, 0, 0), (1, 0, 0), (1, 1, 0)], [(0, 1), (1, 2)], []),
        "nan_vertices": _mesh_object(bpy, "Fuzz NaN", [(nan, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)]),
    }
    bpy.ops.mesh.primitive_cube_add(size=2.0, location=(6.0, 0.0, 0.0))
    subjects["cube"] = bpy.context.active_object
    subjects.update(_non_manifold(bpy, np))
    res["subjects"] = {k: dict(vertices=len(ob.data.vertices), faces=len(ob.data.polygons))
                       for k, ob in subjects.items() if ob is not None and ob.type == 'MESH'}
    for label, ob in subjects.items():
        for idname in ops:
            if idname == "flank.generate_rotor":
                continue                          # makes its own rotor: fuzzed by properties below
            _activate(bpy, ob)
            c = _call(bpy, idname, **_cheap(idname), **READS_SELECTION.get(idname, {}))
            c["subject"] = label
            calls.append(c)
    _degenerate_tools(bpy, calls)
    # ---------------------------------------------------------------- every numeric property, one at a time
    driver._run_op(bpy.ops.flank.generate_rotor, kind="asymmetric", part="female", resolution=180, axial=16)
    rotor = bpy.context.active_object
    # the free-form operators plan on any surface: a small one (on the rotor's 5760 faces one accepted run with
    # default sizes takes minutes, which is the planner's honest time, not a runaway value)
    driver._run_op(bpy.ops.flank.add_test_surface, kind="parabolic_blade", size=1.0, resolution=12)
    blade = bpy.context.active_object
    props = {}
    for idname in ops:
        rna = getattr(bpy.ops.flank, idname.split(".", 1)[1]).get_rna_type()
        props[idname] = [p.identifier for p in rna.properties
                         if p.type in ('FLOAT', 'INT') and not p.is_readonly and getattr(p, "array_length", 0) == 0]
    res["numeric_props"] = props
    skipped = []
    for idname in ops:
        slow = False
        for prop in props[idname]:
            for tag, value in SPECIAL:
                if slow and tag not in ALWAYS:
                    skipped.append([idname, prop, tag])
                    continue
                rna = getattr(bpy.ops.flank, idname.split(".", 1)[1]).get_rna_type().properties[prop]
                v = value
                if rna.type == 'INT':
                    if not math.isfinite(v):
                        continue                  # an int property cannot hold NaN/inf
                    v = int(max(-2 ** 31, min(2 ** 31 - 1, v)))
                subject = blade if idname in SURFACE_OPS else bpy.data.objects.get(rotor.name)
                _activate(bpy, subject)
                c = _call(bpy, idname, **_cheap(idname, prop), **{prop: v})
                c["subject"] = "blade" if idname in SURFACE_OPS else "rotor"
                c["prop"], c["value"] = prop, tag
                calls.append(c)
                if c["result"] == ["FINISHED"] and c["seconds"] > BUDGET:
                    slow = True
    res["calls"] = calls
    res["skipped"] = skipped
