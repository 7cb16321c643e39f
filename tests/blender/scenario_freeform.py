# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.plan_freeform and its helpers (Rajain et al. 2023) through the installed extension, for test_blender_freeform.py.

A parabolic blade (the built-in test surface) is moved, rotated 90 deg about z and scaled x2; the guiding
direction is given in world axes.  The run is compared with the core planner on the very same local
vertices (read back from Blender), then: re-run replaces, preview of the guiding curves (and its live update),
picking the direction from an Empty / the 3D cursor / an edge / the view, a vector-attribute field, selected
faces only, exports and the report of the run, and bad input (nothing created)."""
import json
import math
import time

import driver

S = 2.0
TOOL = dict(r1=0.06, r2=0.06, length=0.5)            # cylinder, scene units (object scale 2 -> 0.03 / 0.25 local)
PLAN_KW = dict(TOOL, samples=12, columns=8, max_evaluations=30, tolerance=0.002)


def _datablocks(bpy):
    return dict(objects=len(bpy.data.objects), meshes=len(bpy.data.meshes), collections=len(bpy.data.collections),
                curves=len(bpy.data.curves), images=len(bpy.data.images))


def _select_only(bpy, ob):
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    if ob is not None:
        ob.select_set(True)
    bpy.context.view_layer.objects.active = ob


def _edit_select(bpy, ob, edges=(), faces=()):
    """Select exactly these edges / faces of ``ob`` the way a user does (Edit Mode), back in Object Mode."""
    import bmesh

    _select_only(bpy, ob)
    bpy.ops.object.mode_set(mode='EDIT')
    bm = bmesh.from_edit_mesh(ob.data)
    for seq in (bm.verts, bm.edges, bm.faces):
        for el in seq:
            el.select = False
    bm.edges.ensure_lookup_table()
    bm.faces.ensure_lookup_table()
    for k in edges:
        bm.edges[k].select = True
    for k in faces:
        bm.faces[k].select = True
    bm.select_flush_mode()
    bmesh.update_edit_mesh(ob.data)
    bpy.ops.object.mode_set(mode='OBJECT')


def _local_arrays(np, obj):
    me = obj.data
    co = np.empty(3 * len(me.vertices), dtype=np.float64)
    me.vertices.foreach_get("co", co)
    me.calc_loop_triangles()
    tris = np.empty(3 * len(me.loop_triangles), dtype=np.int64)
    me.loop_triangles.foreach_get("vertices", tris)
    return co.reshape(-1, 3), tris.reshape(-1, 3)


def _call(bpy, op, *args, **kw):
    before = _datablocks(bpy)
    t0 = time.perf_counter()
    ret, err = driver._run_op(op, *args, **kw) if not args else _run_args(op, *args, **kw)
    return dict(result=ret, error=err, seconds=time.perf_counter() - t0,
                new={k: _datablocks(bpy)[k] - before[k] for k in before})


def _run_args(op, *args, **kw):
    try:
        return sorted(op(*args, **kw)), None
    except RuntimeError as ex:
        return None, str(ex)


def _run_state(bpy, np, coll):
    """What a run made: roles, names, attributes, properties."""
    out = dict(name=coll.name, parent=[c.name for c in bpy.data.collections if coll.name in c.children],
               props={k: (coll[k].to_list() if hasattr(coll[k], "to_list") else coll[k]) for k in coll.keys()
                      if k.startswith("flank_ff_") and k != "flank_ff_summary"},
               roles={}, strips={}, boundaries={}, tools={})
    for ob in coll.objects:
        role = ob.get("flank_ff_role")
        out["roles"].setdefault(role, []).append(ob.name)
        k = ob.get("flank_ff_strip")
        if role == "envelope":
            dev = driver._float_attr(np, ob.data, "deviation")
            col = driver._color_attr(np, ob.data, "error_color")
            co = np.empty(3 * len(ob.data.vertices), dtype=np.float64)
            ob.data.vertices.foreach_get("co", co)
            fin = np.isfinite(dev)
            out["strips"][k] = dict(n=len(dev), finite=int(fin.sum()), max=float(dev[fin].max()),
                                    min=float(dev[fin].min()), colors=len(col), domain=ob.data.attributes[
                                        "deviation"].domain,
                                    co=co.reshape(-1, 3).tolist(), dev=[float(v) for v in dev],
                                    matrix=[list(r) for r in ob.matrix_world])
        elif role == "boundary":
            kp = driver._float_attr(np, ob.data, "kink_deg")
            ke = ob.data.attributes.get("kink_deg_edge")
            out["boundaries"][k] = dict(points=len(ob.data.vertices), edges=len(ob.data.edges),
                                        kink=[float(v) for v in kp], edge_domain=ke.domain if ke else None,
                                        edge_len=len(ke.data) if ke else 0)
        elif role == "tool":
            mw = np.array(ob.matrix_world)
            out["tools"][k] = dict(origin=mw[:3, 3].tolist(), axis=(mw[:3, 2] / np.linalg.norm(mw[:3, 2])).tolist(),
                                   scale=float(np.linalg.norm(mw[:3, 0])), verts=len(ob.data.vertices),
                                   errors=list(ob["flank_ff_strip_errors"]))
    return out


def scenario(bpy, res, args):
    import numpy as np
    from mathutils import Matrix

    g1 = driver._core("methods.freeform_g1.planner")
    plan_mod = driver._core("io.plan")
    ff = __import__(driver.MODULE + ".operators.guiding", fromlist=["x"])
    surfaces = __import__(driver.MODULE + ".operators.sample_surfaces", fromlist=["x"])
    strips = __import__(driver.MODULE + ".operators.strips", fromlist=["x"])
    ui_ops = __import__(driver.MODULE + ".operators.ui_ops", fromlist=["x"])
    scene = bpy.context.scene
    s = scene.flank_settings
    out = {}
    # a millimetre scene: plans are in the model's own numbers (a scene of metres is checked at the end)
    scene.unit_settings.system, scene.unit_settings.scale_length = 'METRIC', 0.001

    # ---------------------------------------------------------------- nothing selected: refused, nothing made
    _select_only(bpy, None)
    out["no_object"] = _call(bpy, bpy.ops.flank.plan_freeform, **PLAN_KW)

    # ---------------------------------------------------------------- the blade, moved / rotated / scaled
    out["add_surface"] = _call(bpy, bpy.ops.flank.add_test_surface, kind="parabolic_blade", size=1.0, resolution=24)
    blade = bpy.context.active_object
    blade.matrix_world = Matrix.Translation((1.0, -2.0, 0.5)) @ Matrix.Rotation(math.pi / 2, 4, 'Z') @ \
        Matrix.Scale(S, 4)
    bpy.context.view_layer.update()
    V, F = _local_arrays(np, blade)
    out["surface"] = dict(name=blade.name, vertices=len(V), triangles=len(F))
    # the blade's rulings run along its local y: strips along local x (world R_z(90) (1, 0, 0) = (0, 1, 0)) put
    # the tool axes on the rulings, which is exact
    t0 = time.perf_counter()
    run = _call(bpy, bpy.ops.flank.plan_freeform, direction=(0.0, 1.0, 0.0), **PLAN_KW)
    run["seconds"] = time.perf_counter() - t0
    out["run"] = run
    coll = next((c for c in bpy.data.collections if c.get("flank_ff_key") == blade.name), None)
    out["state"] = _run_state(bpy, np, coll) if coll else None
    out["active"] = bpy.context.active_object.name if bpy.context.active_object else None
    plan = json.loads(coll["flank_plan_json"]) if coll else None
    if plan is not None:
        plan_mod.validate_plan(plan)
        out["plan"] = dict(is_mesh=plan_mod.is_mesh_plan(plan), direction=plan["guiding"]["direction"],
                           vertices_equal=bool(np.array_equal(np.asarray(plan["surface"]["vertices"]), V)),
                           tool=plan["tool"], summary=plan["summary"], strips=len(plan["strips"]),
                           method=plan["method"])
    # the core on the same local arrays, the same parameters in local units
    t0 = time.perf_counter()
    core = g1.plan_freeform(V, F, direction=plan["guiding"]["direction"], r1=TOOL["r1"] / S, r2=TOOL["r2"] / S,
                            L=TOOL["length"] / S, n_ruling_samples=12, n_columns=8, max_nfev=30, length_unit="mm")
    core_s = time.perf_counter() - t0
    envs = g1.freeform_envelopes(core, n_s=9)
    kinks = g1.freeform_kinks(core)
    out["core"] = dict(summary=core["summary"], seconds=core_s, strips=len(core["strips"]),
                       strip_max=[st["reported_max_error"] for st in core["strips"]],
                       strip_min=[st["reported_min_error"] for st in core["strips"]],
                       first_rulings=[st["rulings"][0] for st in core["strips"]],
                       env_dev=[[float(v) for v in e["deviation"]] for e in envs],
                       env_pts=[np.asarray(e["vertices"]).tolist() for e in envs],
                       kinks=[[float(v) for v in k["kink_deg"]] for k in kinks])
    out["blade_matrix"] = [list(r) for r in blade.matrix_world]

    # ---------------------------------------------------------------- re-run replaces the run, no orphans
    before = _datablocks(bpy)
    _select_only(bpy, bpy.data.objects[out["state"]["roles"]["envelope"][0]] if out["state"] else blade)
    out["rerun"] = _call(bpy, bpy.ops.flank.plan_freeform, direction=(0.0, 1.0, 0.0), **PLAN_KW)
    out["rerun"]["delta"] = {k: _datablocks(bpy)[k] - before[k] for k in before}
    out["rerun"]["runs"] = [c.name for c in bpy.data.collections if c.get("flank_ff_key") == blade.name]
    out["orphans"] = dict(meshes=sum(1 for m in bpy.data.meshes if m.users == 0),
                          curves=sum(1 for c in bpy.data.curves if c.users == 0))

    # ---------------------------------------------------------------- results list and exports of the run
    coll = bpy.data.collections[out["rerun"]["runs"][0]]
    info = strips.strip_rows(coll)
    out["rows"] = {str(k): v for k, v in (info["rows"].items() if info else [])}
    _select_only(bpy, blade)
    tmp = args.out.rsplit("/", 1)[0]
    exports = {}
    for fmt, ext in (("CL", "apt"), ("CSV", "csv"), ("PLAN", "json"), ("STL", "stl")):
        path = "{}/ff_export.{}".format(tmp, ext)
        c = _call(bpy, bpy.ops.flank.export_results, filepath=path, format=fmt, collection=coll.name)
        import glob
        files = sorted(glob.glob("{}/ff_export*".format(tmp)))
        c["files"] = [f.rsplit("/", 1)[1] for f in files]
        if fmt == "CL" and c["result"] == ["FINISHED"]:
            lines = open(path).read().splitlines()
            c["goto"] = sum(1 for ln in lines if ln.startswith("GOTO/"))
        exports[fmt] = c
    out["exports"] = exports
    out["animate"] = _call(bpy, bpy.ops.flank.animate_strip, collection=coll.name, strip=2, frame_start=1,
                           frame_end=71)
    mv = next((o for o in coll.objects if o.get("flank_anim_role") == "tool"), None)
    if mv is not None:
        st = json.loads(coll["flank_plan_json"])["strips"][1]
        R = np.asarray(st["rulings"])
        W = np.array(coll["flank_ff_to_world"]).reshape(4, 4)
        checks = []
        for i in (0, len(R) // 2, len(R) - 1):
            f = int(round(1 + 70 * i / (len(R) - 1)))
            scene.frame_set(f)
            mw = np.array(mv.matrix_world)
            tip = W @ np.r_[R[i, 0], 1.0]
            base = W @ np.r_[R[i, 1], 1.0]
            ax = (base - tip)[:3] / np.linalg.norm((base - tip)[:3])
            checks.append(dict(frame=f, origin_err=float(np.linalg.norm(mw[:3, 3] - tip[:3])),
                               axis_dot=float(np.dot(mw[:3, 2] / np.linalg.norm(mw[:3, 2]), ax))))
        scene.frame_set(1)
        out["animate"].update(moving=mv.name, checks=checks, rulings=len(R),
                              static_hidden=bpy.data.objects["FF Tool 2"].hide_get())
    png = "{}/ff_report.png".format(tmp)
    out["report"] = _call(bpy, bpy.ops.flank.render_report, collection=coll.name, filepath=png, width=240, height=160)
    import os
    if os.path.isfile(png):
        img = bpy.data.images.load(png)
        px = np.empty(img.size[0] * img.size[1] * 4, dtype=np.float32)
        img.pixels.foreach_get(px)
        px = px.reshape(-1, 4)[:, :3]
        out["report"].update(size=list(img.size), colors=len(np.unique(np.round(px, 2), axis=0)))
        bpy.data.images.remove(img)
    out["animate_again"] = _call(bpy, bpy.ops.flank.animate_strip, collection=coll.name, strip=2)

    # ---------------------------------------------------------------- guiding preview (scene settings + Tool panel)
    s.strategy = "FREEFORM"
    s.tool_kind = "CYLINDER"
    s.sf_r1, s.sf_length = TOOL["r1"], TOOL["length"]
    s.sf_shank_radius, s.sf_shank_length = 0.0, 0.0
    s.ff_direction = (0.0, 1.0, 0.0)
    s.ff_use_point = False
    _select_only(bpy, blade)
    idname, kw = ui_ops.run_call(s)
    out["run_call"] = dict(idname=idname, r1=kw["r1"], r2=kw["r2"], length=kw["length"])
    out["preview"] = _call(bpy, bpy.ops.flank.preview_guiding)
    prev = next((o for o in bpy.data.objects if o.get(ff.PREVIEW_PROP) is not None), None)

    def preview_points(p):
        return [[list(pt.co)[:3] for pt in sp.points] for sp in p.data.splines]
    guid = driver._core("methods.freeform_g1.guiding")
    gc = guid.guiding_curves(V, F, direction=plan["guiding"]["direction"], r1=TOOL["r1"] / S, r2=TOOL["r1"] / S,
                             L=TOOL["length"] / S)
    core_pls = [pl.points.tolist() for c in gc.curves for pl in c.polylines if len(pl.points) >= 2]
    out["preview"].update(type=prev.type if prev else None, splines=len(prev.data.splines) if prev else 0,
                          core_polylines=len(core_pls), spacing=prev.get(ff.PREVIEW_PROP + "_spacing") if prev else None,
                          max_point_diff=float(max(np.abs(np.asarray(a) - np.asarray(b)).max()
                                                   for a, b in zip(preview_points(prev), core_pls)))
                          if prev and len(preview_points(prev)) == len(core_pls) else None,
                          matrix_equal=bool(np.allclose(np.array(prev.matrix_world), np.array(blade.matrix_world),
                                                        atol=1e-6)) if prev else False)
    # live: changing the direction redraws the preview (along the rulings now)
    s.ff_live_preview = True
    first = preview_points(prev)[0] if prev else None
    s.ff_direction = (-1.0, 0.0, 0.0)
    prev2 = next((o for o in bpy.data.objects if o.get(ff.PREVIEW_PROP) is not None), None)
    pts2 = preview_points(prev2)[0] if prev2 else None
    # local direction of world -x = R_z(-90) (-1, 0, 0) = (0, 1, 0): the new curves run along local y
    d2 = np.asarray(pts2[-1]) - np.asarray(pts2[0]) if pts2 else np.zeros(3)
    out["live"] = dict(previews=sum(1 for o in bpy.data.objects if o.get(ff.PREVIEW_PROP) is not None),
                       changed=first != pts2, direction=(d2 / (np.linalg.norm(d2) or 1.0)).tolist(),
                       message=list(ff.preview_message()))
    s.ff_spacing = 1e9                                    # bad value: the live preview keeps the message, no traceback
    out["live_bad"] = dict(message=list(ff.preview_message()),
                           previews=sum(1 for o in bpy.data.objects if o.get(ff.PREVIEW_PROP) is not None))
    s.ff_spacing = 0.0
    s.ff_live_preview = False
    out["clear_preview"] = _call(bpy, bpy.ops.flank.clear_guiding_preview)
    out["orphans_after_clear"] = sum(1 for c in bpy.data.curves if c.users == 0)

    # ---------------------------------------------------------------- picking the direction
    picks = {}
    emp = bpy.data.objects.new("Guide Empty", None)
    scene.collection.objects.link(emp)
    emp.matrix_world = Matrix.Translation((0.3, 0.2, 0.1)) @ Matrix.Rotation(math.radians(30), 4, 'X')
    bpy.context.view_layer.update()
    _select_only(bpy, emp)
    picks["empty"] = _call(bpy, bpy.ops.flank.pick_guiding_direction, source="EMPTY", axis="Y")
    picks["empty"].update(direction=list(s.ff_direction), point=list(s.ff_point), use_point=s.ff_use_point,
                          want=[0.0, math.cos(math.radians(30)), math.sin(math.radians(30))])
    scene.cursor.location = (0.5, 0.5, 0.5)
    scene.cursor.rotation_mode = 'XYZ'
    scene.cursor.rotation_euler = (0.0, 0.0, math.radians(45))
    picks["cursor"] = _call(bpy, bpy.ops.flank.pick_guiding_direction, source="CURSOR", axis="-X")
    picks["cursor"].update(direction=list(s.ff_direction), point=list(s.ff_point),
                           want=[-math.cos(math.radians(45)), -math.sin(math.radians(45)), 0.0])
    # one selected edge of the blade (picked in Edit Mode; the pick runs in Object Mode from the stored flags)
    me = blade.data
    _select_only(bpy, blade)
    _edit_select(bpy, blade, edges=[0])
    e0 = me.edges[0]
    a, b = (np.array(blade.matrix_world) @ np.r_[np.array(me.vertices[i].co), 1.0] for i in e0.vertices)
    picks["edge"] = _call(bpy, bpy.ops.flank.pick_guiding_direction, source="EDGE")
    picks["edge"].update(direction=list(s.ff_direction), point=list(s.ff_point),
                         want=((b - a)[:3] / np.linalg.norm((b - a)[:3])).tolist(),
                         want_point=(0.5 * (a + b))[:3].tolist())
    # in Edit Mode the active edge of the selection history counts
    bpy.ops.object.mode_set(mode='EDIT')
    import bmesh
    bm = bmesh.from_edit_mesh(me)
    bm.edges.ensure_lookup_table()
    for e in bm.edges:
        e.select = False
    for k in (3, 7):
        bm.edges[k].select = True
    bm.select_history.add(bm.edges[7])
    bmesh.update_edit_mesh(me)
    va, vb = (np.array(blade.matrix_world) @ np.r_[np.array(v.co), 1.0] for v in bm.edges[7].verts)
    picks["edge_edit"] = _call(bpy, bpy.ops.flank.pick_guiding_direction, source="EDGE")
    picks["edge_edit"].update(direction=list(s.ff_direction),
                              want=((vb - va)[:3] / np.linalg.norm((vb - va)[:3])).tolist())
    bpy.ops.object.mode_set(mode='OBJECT')
    _edit_select(bpy, blade)
    picks["edge_none"] = _call(bpy, bpy.ops.flank.pick_guiding_direction, source="EDGE")
    picks["view"] = _call(bpy, bpy.ops.flank.pick_guiding_direction, source="VIEW")
    _select_only(bpy, blade)
    picks["empty_wrong"] = _call(bpy, bpy.ops.flank.pick_guiding_direction, source="EMPTY")
    out["picks"] = picks

    # ---------------------------------------------------------------- a vector attribute as the guiding field
    attr = me.attributes.new("guide", 'FLOAT_VECTOR', 'POINT')
    attr.data.foreach_set("vector", np.tile([1.0, 0.0, 0.0], len(me.vertices)).astype(np.float32))
    _select_only(bpy, blade)
    out["field"] = _call(bpy, bpy.ops.flank.plan_freeform, direction_mode="FIELD", field_attribute="guide", **PLAN_KW)
    coll = next((c for c in bpy.data.collections if c.get("flank_ff_key") == blade.name), None)
    fplan = json.loads(coll["flank_plan_json"]) if coll else None
    out["field"].update(strips=len(fplan["strips"]) if fplan else 0, field=fplan["guiding"]["field"] if fplan else None,
                        max_error=fplan["summary"]["max_error"] if fplan else None)
    out["field_missing"] = _call(bpy, bpy.ops.flank.plan_freeform, direction_mode="FIELD", field_attribute="nope",
                                 **PLAN_KW)

    # ---------------------------------------------------------------- selected faces only (the half x < 0)
    n_poly = len(me.polygons)
    cen = np.empty(3 * n_poly)
    me.polygons.foreach_get("center", cen)
    pick = cen.reshape(-1, 3)[:, 0] < 0.0
    _edit_select(bpy, blade, faces=np.flatnonzero(pick).tolist())
    out["selected"] = _call(bpy, bpy.ops.flank.plan_freeform, direction=(0.0, 1.0, 0.0), selected_only=True,
                            **PLAN_KW)
    coll = next((c for c in bpy.data.collections if c.get("flank_ff_key") == blade.name), None)
    splan = json.loads(coll["flank_plan_json"]) if coll else None
    sv = np.asarray(splan["surface"]["vertices"]) if splan else np.zeros((0, 3))
    out["selected"].update(vertices=len(sv), x_max=float(sv[:, 0].max()) if len(sv) else None,
                           selected_faces=int(pick.sum()))
    _edit_select(bpy, blade)
    out["selected_none"] = _call(bpy, bpy.ops.flank.plan_freeform, direction=(0.0, 1.0, 0.0), selected_only=True,
                                 **PLAN_KW)

    # ---------------------------------------------------------------- bad input: message, nothing created
    bad = {}
    _select_only(bpy, blade)
    for label, kw in (("r1_nan", dict(PLAN_KW, r1=float("nan"))),
                      ("short_axis", dict(PLAN_KW, r1=0.02, r2=0.3, length=0.2)),
                      ("tool_too_large", dict(PLAN_KW, length=500.0)),
                      ("zero_direction", dict(PLAN_KW, direction=(0.0, 0.0, 0.0))),
                      ("negative_weight", dict(PLAN_KW, w_g1=-1.0)),
                      ("no_approximation", dict(PLAN_KW, w_approx=0.0)),
                      ("engagement", dict(PLAN_KW, engagement=0.01)),
                      ("no_strip", dict(PLAN_KW, spacing=3.0))):
        bad[label] = _call(bpy, bpy.ops.flank.plan_freeform, **kw)
    _select_only(bpy, emp)
    bad["empty_active"] = _call(bpy, bpy.ops.flank.plan_freeform, **PLAN_KW)
    # the same blade in a scene of metres: the plan is in millimetres, as its unit says
    scene.unit_settings.scale_length = 1.0
    _select_only(bpy, blade)
    metre = _call(bpy, bpy.ops.flank.plan_freeform, direction=(0.0, 1.0, 0.0), **PLAN_KW)
    mcoll = next((c for c in bpy.data.collections if c.get("flank_ff_key") == blade.name), None)
    if metre["result"] == ["FINISHED"] and mcoll is not None:
        mplan = json.loads(mcoll["flank_plan_json"])
        metre.update(unit=mplan["length_unit"], length_scale=float(mcoll["flank_ff_length_scale"]),
                     vertices_mm=bool(np.allclose(np.asarray(mplan["surface"]["vertices"]), 1000.0 * V,
                                                  rtol=1e-12, atol=0.0)),
                     plan_max_error=float(mplan["summary"]["max_error"]),
                     scene_max_error=float(mcoll["flank_ff_max_error"]))
    out["metre"] = metre
    scene.unit_settings.scale_length = 0.001
    blade.scale = (1.0, 2.0, 1.0)
    _select_only(bpy, blade)
    bad["non_uniform_scale"] = _call(bpy, bpy.ops.flank.plan_freeform, **PLAN_KW)
    out["bad"] = bad
    out["test_surfaces"] = {k: _call(bpy, bpy.ops.flank.add_test_surface, kind=k, size=1.0, resolution=8)
                            for k, _, _ in surfaces.SURFACE_ITEMS}
    out["bad_surface"] = _call(bpy, bpy.ops.flank.add_test_surface, kind="bump", size=float("nan"))
    out["plans_kept"] = driver.plans_kept(bpy)     # after every operator that read a run's plan
    res["freeform"] = out
