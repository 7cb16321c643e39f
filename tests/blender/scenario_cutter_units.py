# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.formed_cutter in scene units (test_blender_cutter_units.py): the Table-1 rotor at scale 1, then the same
rotor object scaled x2 -- the tolerance is typed and the deviation reported in scene units."""
import driver

KW = dict(planes=40, sample_points=16, resolution=240, animate=False)


def _facts(bpy, np, rotor):
    cutter = bpy.context.active_object
    dev = driver._float_attr(np, rotor.data, "machined_deviation")
    cols = driver._color_attr(np, rotor.data, "machined_deviation_color")
    return dict(tolerance=cutter["flank_cutter_tolerance"], scale=cutter.get("flank_cutter_length_scale"),
                max_abs=cutter["flank_cutter_max_abs_deviation"], max_over=cutter["flank_cutter_max_overcut"],
                dev=[float(v) for v in dev], cols=cols[:, :3].round(5).tolist())


def scenario(bpy, res, args):
    import numpy as np
    from mathutils import Matrix

    out = {}
    ret, err = driver._run_op(bpy.ops.flank.formed_cutter, source="TABLE1", tolerance=0.01, **KW)
    out["unit"] = dict(result=ret, error=err)
    if ret is None:
        res["cutter_units"] = out
        return
    rotor = bpy.data.objects[bpy.context.active_object["flank_cutter_rotor"]]
    out["unit"].update(_facts(bpy, np, rotor))
    rotor.matrix_world = Matrix.Scale(2.0, 4) @ rotor.matrix_world
    bpy.context.view_layer.update()
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    rotor.select_set(True)
    bpy.context.view_layer.objects.active = rotor
    ret, err = driver._run_op(bpy.ops.flank.formed_cutter, source="ACTIVE", tolerance=0.02, **KW)
    out["scaled"] = dict(result=ret, error=err)
    if ret is not None:
        out["scaled"].update(_facts(bpy, np, rotor))
    res["cutter_units"] = out
