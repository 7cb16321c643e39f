# SPDX-License-Identifier: GPL-3.0-or-later
"""Result runs share one attribute material and replace their own earlier run, for test_blender_results_material.py.

Small fast runs of every planner that makes result objects (single flank, double flank, free-form, formed cutter,
paraboloid groove), each run three times with the same key: the census of bpy.data after the 2nd and 3rd run
must be equal and exactly one collection per key must stay under "Flank Results".  Every strip / envelope
object must carry the one shared material "Flank Attribute Colour" in slot 0, whose node tree feeds the render
colour attribute (a Color Attribute node without a name) into the shader.  Then: a failed run that had built
its meshes leaves no material, undo of the first run removes the material it made, and removing all runs
leaves no material with 0 users."""
import time

import driver
from scenario_freeform import _select_only

CENSUS_KINDS = ("objects", "meshes", "collections", "materials", "actions", "curves", "images")
MATERIAL = "Flank Attribute Colour"
SF_KW = dict(shape="alpha", alpha=driver.SF_ASIN, r1=0.05, r2=0.08, shank_radius=0.04, shank_length=0.6,
             tolerance=1e-3, envelope_rings=8, flank=1, seeds=4, rounds=1, animate=False)
DF_KW = dict(radii=40, envelope_rings=12, simulate=False, animate=True, valley=0)
FF_KW = dict(r1=0.06, r2=0.06, length=0.5, samples=12, columns=8, max_evaluations=30, tolerance=0.002,
             direction=(0.0, 1.0, 0.0))
FC_KW = dict(source="ACTIVE", sample_points=16, planes=24, resolution=96, animate=True)
PG_KW = dict(turns=0.5, resolution=101)


def _census(bpy):
    return {k: len(getattr(bpy.data, k)) for k in CENSUS_KINDS}


_BASELINE = set()     # 0-user materials of the startup file (e.g. Grease Pencil's "Dots Stroke")


def _zero_user_materials(bpy):
    return sorted(m.name for m in bpy.data.materials if m.users == 0 and m.name not in _BASELINE)


def _node_tree(mat):
    """What the material's node tree feeds into its output: JSON-able."""
    nt = mat.node_tree
    if nt is None:
        return None
    nodes = [dict(name=n.name, type=n.bl_idname, layer_name=getattr(n, "layer_name", None)) for n in nt.nodes]
    links = [[l.from_node.bl_idname, l.from_socket.name, l.to_node.bl_idname, l.to_socket.name] for l in nt.links]
    return dict(nodes=nodes, links=links)


def _material_state(bpy, coll, role_key):
    """Per object of a run: (role, slot-0 material name, pointer, colour attributes, render colour name)."""
    out = []
    for ob in sorted(coll.all_objects, key=lambda o: o.name):
        if ob.type != 'MESH':
            continue
        me = ob.data
        mats = [m.name if m is not None else None for m in me.materials]
        ptr = me.materials[0].as_pointer() if len(me.materials) and me.materials[0] is not None else None
        cas = me.color_attributes
        render = None
        try:
            idx = cas.render_color_index
            render = cas[idx].name if 0 <= idx < len(cas) else None
        except (AttributeError, TypeError):
            pass
        out.append(dict(name=ob.name, role=ob.get(role_key), materials=mats, pointer=ptr,
                        deviation="deviation" in me.attributes, colors=[c.name for c in cas], render_color=render))
    return out


def _runs(bpy, key_prop):
    """The runs under "Flank Results" with the key of the active object's run."""
    ob = bpy.context.active_object
    coll = next((c for c in ob.users_collection if key_prop in c), None) if ob is not None else None
    if coll is None:
        return []
    key = coll[key_prop]
    parent = bpy.data.collections.get("Flank Results")
    kids = list(parent.children) if parent is not None else []
    return [dict(name=c.name, key=c.get(key_prop)) for c in kids if c.get(key_prop) == key]


def _three_runs(bpy, res_key, res, op, kw, select, key_prop, role_key):
    """Run ``op`` three times (``select()`` picks the input each time); census after every run."""
    out = dict(calls=[], census=[], runs=[], state=None)
    for i in range(3):
        select()
        t0 = time.perf_counter()
        ret, err = driver._run_op(op, **kw)
        out["calls"].append(dict(result=ret, error=err, seconds=time.perf_counter() - t0))
        out["census"].append(_census(bpy))
        out["runs"].append(_runs(bpy, key_prop))
        out["zero_user_materials"] = _zero_user_materials(bpy)
        if i == 0 and ret == ["FINISHED"]:
            ob = bpy.context.active_object
            coll = next((c for c in ob.users_collection if key_prop in c), None) if ob is not None else None
            if coll is not None:
                out["first_pointers"] = [s["pointer"] for s in _material_state(bpy, coll, role_key)]
    ob = bpy.context.active_object
    coll = next((c for c in ob.users_collection if key_prop in c), None) if ob is not None else None
    if coll is not None:
        out["collection"] = coll.name
        out["parents"] = [c.name for c in bpy.data.collections if coll.name in c.children]
        out["state"] = _material_state(bpy, coll, role_key)
    res[res_key] = out


def scenario(bpy, res, args):
    from mathutils import Matrix

    materials = __import__(driver.MODULE + ".operators.materials", fromlist=["x"])
    runs = __import__(driver.MODULE + ".operators.runs", fromlist=["x"])
    _BASELINE.update(m.name for m in bpy.data.materials if m.users == 0)
    res["baseline_zero_user_materials"] = sorted(_BASELINE)
    res["census_start"] = _census(bpy)
    res["materials_start"] = sorted(m.name for m in bpy.data.materials)

    # ---------------------------------------------------------------- single flank on asymmetric-female flank 1
    driver._run_op(bpy.ops.flank.generate_rotor, kind="asymmetric", part="female", resolution=180, axial=16)
    asym = bpy.context.active_object
    _three_runs(bpy, "single", res, bpy.ops.flank.plan_single_flank, SF_KW, lambda: _select_only(bpy, asym),
                "flank_sf_key", "flank_sf_role")
    mat = next((m for m in bpy.data.materials if m.get(materials.ATTRIBUTE_MATERIAL_PROP) is not None), None)
    res["material"] = None if mat is None else dict(
        name=mat.name, users=mat.users, pointer=mat.as_pointer(), tree=_node_tree(mat),
        marked=[m.name for m in bpy.data.materials if m.get(materials.ATTRIBUTE_MATERIAL_PROP) is not None])

    # ---------------------------------------------------------------- double flank on nilson-male valley 0
    driver._run_op(bpy.ops.flank.generate_rotor, kind="nilson", part="male", resolution=180, axial=16)
    nilson = bpy.context.active_object
    _three_runs(bpy, "double", res, bpy.ops.flank.plan_double_flank, DF_KW, lambda: _select_only(bpy, nilson),
                "flank_df_key", "flank_df_role")

    # ---------------------------------------------------------------- free-form on the parabolic blade
    driver._run_op(bpy.ops.flank.add_test_surface, kind="parabolic_blade", size=1.0, resolution=24)
    blade = bpy.context.active_object
    blade.matrix_world = Matrix.Scale(2.0, 4)
    bpy.context.view_layer.update()
    _three_runs(bpy, "freeform", res, bpy.ops.flank.plan_freeform, FF_KW, lambda: _select_only(bpy, blade),
                "flank_ff_key", "flank_ff_role")

    # ---------------------------------------------------------------- formed cutter: active rotor, then Table 1
    driver._run_op(bpy.ops.flank.generate_rotor, kind="srm_a", part="male", resolution=180, axial=16)
    srm = bpy.context.active_object
    _three_runs(bpy, "formed_active", res, bpy.ops.flank.formed_cutter, FC_KW, lambda: _select_only(bpy, srm),
                "flank_cutter_key", "flank_cutter_role")
    res["formed_active"]["rotor_materials"] = [m.name if m else None for m in srm.data.materials]
    _three_runs(bpy, "formed_table1", res, bpy.ops.flank.formed_cutter,
                dict(source="TABLE1", sample_points=16, planes=24, resolution=96, animate=True),
                lambda: _select_only(bpy, None), "flank_cutter_key", "flank_cutter_role")
    # ---------------------------------------------------------------- paraboloid groove
    _three_runs(bpy, "groove", res, bpy.ops.flank.paraboloid_groove, PG_KW, lambda: _select_only(bpy, None),
                "flank_groove_key", "flank_groove_role")
    res["all_runs"] = [c.name for c in bpy.data.collections["Flank Results"].children]
    res["scene_children"] = [c.name for c in bpy.context.scene.collection.children]
    res["shared"] = sorted({m.name for ob in bpy.data.objects if ob.type == 'MESH' for m in ob.data.materials
                            if m is not None and m.get(materials.ATTRIBUTE_MATERIAL_PROP) is not None})
    res["material_users_all"] = mat.users if mat is not None else None
    res["solid_switched"] = materials.show_attribute_colors(bpy.context)   # background: nothing to do

    # ---------------------------------------------------------------- removing every run: no 0-user material
    parent = bpy.data.collections["Flank Results"]
    for coll in list(parent.children):
        runs.remove_result_collection(coll)
    # the formed cutter painted the user's rotor (it had no material): that use stays with the rotor
    res["after_remove"] = dict(census=_census(bpy), zero_user_materials=_zero_user_materials(bpy),
                               marked=[m.name for m in bpy.data.materials
                                       if m.get(materials.ATTRIBUTE_MATERIAL_PROP) is not None],
                               orphan_meshes=sum(1 for m in bpy.data.meshes if m.users == 0),
                               orphan_actions=sum(1 for a in bpy.data.actions if a.users == 0))
    srm.data.materials.clear()
    materials.release_attribute_material()
    res["after_release"] = dict(marked=[m.name for m in bpy.data.materials
                                        if m.get(materials.ATTRIBUTE_MATERIAL_PROP) is not None],
                                zero_user_materials=_zero_user_materials(bpy))

    # ---------------------------------------------------------------- a failed run (a plan file name too long
    # for the file system: its folder exists, so the write fails after the meshes and the material were made)
    # leaves nothing behind
    import os

    _select_only(bpy, asym)
    before = _census(bpy)
    ret, err = driver._run_op(bpy.ops.flank.plan_single_flank,
                              **dict(SF_KW, filepath=os.path.join(os.getcwd(), "p" * 300 + ".json")))
    res["failed"] = dict(result=ret, error=err, before=before, after=_census(bpy),
                         zero_user_materials=_zero_user_materials(bpy))

    # ---------------------------------------------------------------- undo of a run removes its material
    _select_only(bpy, asym)
    bpy.ops.ed.undo_push(message="before single flank")
    before = _census(bpy)
    ret, err = driver._run_op(bpy.ops.flank.plan_single_flank, **SF_KW)
    bpy.ops.ed.undo_push(message="flank.plan_single_flank")
    after_run = _census(bpy)
    bpy.ops.ed.undo()
    res["undo"] = dict(result=ret, error=err, before=before, after_run=after_run, after_undo=_census(bpy),
                       zero_user_materials=_zero_user_materials(bpy),
                       marked=[m.name for m in bpy.data.materials
                               if m.get(materials.ATTRIBUTE_MATERIAL_PROP) is not None])
