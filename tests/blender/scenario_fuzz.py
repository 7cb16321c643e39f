# SPDX-License-Identifier: GPL-3.0-or-later
"""Fuzz every flank.* operator of the installed extension: wrong selections (nothing active, an empty, a
camera, an empty mesh, one triangle, loose edges, NaN vertices, a cube = non-helical) and, on a generated
rotor, every numeric property set to NaN, infinity, a negative and a huge value one at a time.

Recorded per call: the result, the message, whether a Python traceback reached the message, the seconds,
and the data-blocks that a *failed* call left behind (must be none).  Scenario for test_blender_fuzz.py."""
import math
import time

import driver

SPECIAL = (("nan", float("nan")), ("inf", float("inf")), ("neg", -1.0), ("huge", 1e9))
BUDGET = 6.0             # seconds a single accepted call may take before later values of that operator are skipped


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


def scenario(bpy, res, args):
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
    for label, ob in subjects.items():
        for idname in ops:
            if idname == "flank.generate_rotor":
                continue                          # makes its own rotor: fuzzed by properties below
            _activate(bpy, ob)
            c = _call(bpy, idname)
            c["subject"] = label
            calls.append(c)
    # ---------------------------------------------------------------- every numeric property, one at a time
    driver._run_op(bpy.ops.flank.generate_rotor, kind="asymmetric", part="female", resolution=180, axial=16)
    rotor = bpy.context.active_object
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
                if slow:
                    skipped.append([idname, prop, tag])
                    continue
                rna = getattr(bpy.ops.flank, idname.split(".", 1)[1]).get_rna_type().properties[prop]
                v = value
                if rna.type == 'INT':
                    if not math.isfinite(v):
                        continue                  # an int property cannot hold NaN/inf
                    v = int(max(-2 ** 31, min(2 ** 31 - 1, v)))
                _activate(bpy, bpy.data.objects.get(rotor.name))
                c = _call(bpy, idname, **{prop: v})
                c["subject"] = "rotor"
                c["prop"], c["value"] = prop, tag
                calls.append(c)
                if c["result"] == ["FINISHED"] and c["seconds"] > BUDGET:
                    slow = True
    res["calls"] = calls
    res["skipped"] = skipped
