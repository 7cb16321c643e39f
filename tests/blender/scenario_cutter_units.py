# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.formed_cutter in scene units (test_blender_cutter_units.py): the Table-1 rotor at scale 1, then the same
rotor object scaled x2 -- the tolerance is typed and the deviation reported in scene units; then a rotor made by
Generate Rotor in millimetres, planned in a scene of metres and in one of millimetres."""
import json

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
    out["generated"] = _generated_in_two_scenes(bpy)
    res["cutter_units"] = out


def _generated_in_two_scenes(bpy):
    """An outer radius of 0.05 scene units in a scene of metres (50 mm) and of 50 in one of millimetres: the same
    50 mm rotor, whose double-flank plans must both be in millimetres."""
    us = bpy.context.scene.unit_settings
    got = {}
    for label, system, unit_scale, radius in (("metres", 'METRIC', 1.0, 0.05), ("millimetres", 'METRIC', 0.001, 50.0)):
        us.system, us.scale_length = system, unit_scale
        ret, err = driver._run_op(bpy.ops.flank.generate_rotor, kind="asymmetric", part="female", scale=radius,
                                  resolution=360, axial=24)
        rotor = bpy.context.active_object
        ret, err = driver._run_op(bpy.ops.flank.plan_double_flank, valley=0, radii=40, envelope_rings=12,
                                  simulate=False, animate=True, frame_start=1, frame_end=20) if ret else (ret, err)
        run = dict(result=ret, error=err)
        coll = next((c for c in bpy.data.collections if c.get("flank_df_rotor") == rotor.name
                     and "flank_plan_json" in c), None)
        if ret is not None and coll is not None:
            plan = json.loads(coll["flank_plan_json"])
            run.update(unit=plan["length_unit"], outer_radius=plan["rotor"]["outer_radius"], v0=plan["rotor"]["v0"],
                       length_scale=float(coll["flank_df_length_scale"]), rotor_v0=float(rotor["flank_v0"]),
                       alpha=[float(v) for v in coll["flank_df_alpha"]])
            # the moving tool rides the screw: at any frame the same size as the tool and as far from the axis
            bpy.context.scene.frame_set(1)
            bpy.context.view_layer.update()
            role = {ob.get("flank_df_role"): ob for ob in coll.objects}

            def size_and_rho(ob):
                m = [list(r) for r in ob.matrix_world]
                det = (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] *
                       m[2][0]) + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))
                return [abs(det) ** (1.0 / 3.0), (m[0][3] ** 2 + m[1][3] ** 2) ** 0.5]
            if "tool" in role and "moving" in role:
                run.update(tool=size_and_rho(role["tool"]), moving=size_and_rho(role["moving"]))
        got[label] = run
    return got
