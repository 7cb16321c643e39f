#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Render the README figures headless through the extension's operators (bpy as a module, Workbench).

    docs/groove_overcut.png    Doğrusadık paper case (R 20, a -0.05, b 7.2, p 20): the groove cut open along the
                               section plane through the screw axis, the lens tool at phi = pi, the swept
                               section (red) vs the tool's own section (blue), the overcut band between them
                               (yellow -> red), with a zoomed inset where the overcut is largest.
    docs/verify_deviation.png  built-in asymmetric female rotor painted by flank.verify_plan for a plan of
                               ball strips that gouge (red), cut within tolerance (green) and leave stock
                               (blue); grey = untouched.
    docs/formed_cutter.png     Hu, Zhou & Li 2025 Table-1 arc-tooth rotor (A 200, swivel 31 deg, lead 450) with the formed disc
                               cutter of flank.formed_cutter at its set-up (seen along the disc plane, sitting
                               in the groove), the rotor painted with the machined deviation of the sweep
                               simulation (green: within the tolerance on the cut tooth; grey: not cut).
    docs/walkthrough.png       's path through the panels: an STL of the asymmetric female rotor (R 50 mm)
                               imported and analysed (curvature colours), a single-flank run with a tapered end
                               mill (strips by signed error), the animation of strip 1 with the tool, CL export.
    docs/double_flank.png      Bizzarri & Bartoň 2021 built-in asymmetric male rotor, valley 0: the custom tool of
                               flank.plan_double_flank (min radial function) half-way along its screw motion,
                               the envelope strips coloured by their error (green within 1e-3 R, blue stock),
                               the error along the tool axis (flank 1 red, flank 2 blue) beside the tool.

    python tools/render_figures.py [--out docs] [--size 960x540] [--zip ZIP | --source]

By default the source tree is registered directly (fast; needs numpy + scipy in this interpreter);
``--zip`` installs a built extension with Blender's installer instead.  Workbench only: no GPU needed.
"""
import argparse
import json
import math
import shutil
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from demo import enable_extension, isolate_blender_user_dir  # noqa: E402  (tools/demo.py)


def log(msg):
    print("[figures] " + msg, flush=True)


# --------------------------------------------------------------------------- scene helpers

def reset_scene(bpy, width, height):
    """Empty the file between figures (no read_factory_settings: that would also reset the add-on)."""
    for datablocks in (bpy.data.objects, bpy.data.meshes, bpy.data.curves, bpy.data.cameras, bpy.data.lights,
                       bpy.data.collections, bpy.data.materials, bpy.data.images, bpy.data.actions,
                       bpy.data.worlds):
        for block in list(datablocks):
            datablocks.remove(block)
    scene = bpy.context.scene
    render = scene.render
    render.engine = 'BLENDER_WORKBENCH'
    render.resolution_x, render.resolution_y, render.resolution_percentage = width, height, 100
    render.image_settings.file_format = 'PNG'
    render.film_transparent = False
    shading = scene.display.shading
    shading.light = 'STUDIO'
    shading.color_type = 'VERTEX'  # active colour attribute of every mesh
    shading.show_cavity = False
    shading.show_object_outline = False
    shading.show_specular_highlight = True
    world = bpy.data.worlds.new("FiguresWorld")
    scene.world = world
    world.color = (0.94, 0.94, 0.95)
    scene.display.render_aa = '8'
    return scene


def paint(bpy, np, obj, rgba):
    """Constant FLOAT_COLOR point attribute (Workbench 'Attribute' colouring) unless one is active."""
    mesh = obj.data
    attr = mesh.color_attributes.new("figure_color", 'FLOAT_COLOR', 'POINT')
    attr.data.foreach_set("color", np.tile(np.asarray(rgba, dtype=np.float32), len(mesh.vertices)))
    mesh.color_attributes.active_color = attr
    try:
        mesh.color_attributes.render_color_index = mesh.color_attributes.active_color_index
    except (AttributeError, TypeError):
        pass


def curve_to_mesh_object(bpy, curve_obj, name):
    """Evaluated curve/text object -> plain mesh object (so it can carry a colour attribute)."""
    deps = bpy.context.evaluated_depsgraph_get()
    mesh = bpy.data.meshes.new_from_object(curve_obj.evaluated_get(deps))
    obj = bpy.data.objects.new(name, mesh)
    for coll in curve_obj.users_collection:
        coll.objects.link(obj)
    data = curve_obj.data
    bpy.data.objects.remove(curve_obj)
    bpy.data.curves.remove(data)
    return obj


def tube_from_edges(bpy, np, edge_obj, radius, offset, rgba):
    """Thick line along the polylines of an edge-only mesh (a bevelled poly curve, then a mesh)."""
    mesh = edge_obj.data
    co = np.empty(len(mesh.vertices) * 3)
    mesh.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3) + np.asarray(offset)
    ed = np.empty(len(mesh.edges) * 2, dtype=np.int64)
    mesh.edges.foreach_get("vertices", ed)
    ed = ed.reshape(-1, 2)
    # walk the chains (edges were created in order; a loop closes back to its first vertex)
    chains, cur = [], [int(ed[0, 0]), int(ed[0, 1])]
    for a, b in ed[1:]:
        if a == cur[-1]:
            cur.append(int(b))
        else:
            chains.append(cur)
            cur = [int(a), int(b)]
    chains.append(cur)
    cu = bpy.data.curves.new(edge_obj.name + " tube", 'CURVE')
    cu.dimensions = '3D'
    cu.bevel_depth = radius
    cu.bevel_resolution = 2
    for chain in chains:
        closed = chain[0] == chain[-1]
        pts = co[chain[:-1] if closed else chain]
        sp = cu.splines.new('POLY')
        sp.points.add(len(pts) - 1)
        sp.points.foreach_set("co", np.c_[pts, np.ones(len(pts))].ravel())
        sp.use_cyclic_u = closed
    ob = bpy.data.objects.new(edge_obj.name + " tube", cu)
    edge_obj.users_collection[0].objects.link(ob)
    ob = curve_to_mesh_object(bpy, ob, edge_obj.name + " tube")
    paint(bpy, np, ob, rgba)
    return ob


def bisect_keep_positive_y(bpy, obj):
    """Cut a mesh object open along the world plane Y = 0 and keep the Y >= 0 half (cut-away view)."""
    import bmesh
    from mathutils import Vector

    mw_inv = obj.matrix_world.inverted()
    co = mw_inv @ Vector((0.0, 0.0, 0.0))
    no = (mw_inv.to_3x3().transposed().inverted() @ Vector((0.0, 1.0, 0.0))).normalized()
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bmesh.ops.bisect_plane(bm, geom=bm.verts[:] + bm.edges[:] + bm.faces[:], plane_co=co, plane_no=no,
                           clear_inner=True)
    bm.to_mesh(obj.data)
    bm.free()
    obj.data.update()


def add_camera(bpy, location, target, lens=50.0, ortho_scale=None, name="FigCamera"):
    from mathutils import Vector

    data = bpy.data.cameras.new(name)
    data.lens = lens
    if ortho_scale is not None:
        data.type = 'ORTHO'
        data.ortho_scale = ortho_scale
    data.clip_end = 1e4
    cam = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(cam)
    cam.location = location
    cam.rotation_euler = (Vector(target) - Vector(location)).to_track_quat('-Z', 'Y').to_euler()
    return cam


def add_label(bpy, np, cam, text, x, y, size, rgba, distance=10.0):
    """Text facing the camera: (x, y) in the camera's view plane at ``distance`` (-1..1 ~ frame width/2)."""
    if cam.data.type == 'ORTHO':
        half_w = cam.data.ortho_scale / 2.0
    else:
        half_w = distance * cam.data.sensor_width / cam.data.lens / 2.0
        size *= distance / 10.0  # perspective sizes are given for a camera distance of 10
    cu = bpy.data.curves.new("Label", 'FONT')
    cu.body = text
    cu.size = size
    ob = bpy.data.objects.new("Label", cu)
    bpy.context.scene.collection.objects.link(ob)
    ob.parent = cam
    ob.location = (x * half_w, y * half_w, -distance)
    ob = curve_to_mesh_object(bpy, ob, "Label")
    ob.parent = cam
    ob.location = (x * half_w, y * half_w, -distance)
    paint(bpy, np, ob, rgba)
    return ob


def render(bpy, np, path, camera=None):
    scene = bpy.context.scene
    if camera is not None:
        scene.camera = camera
    scene.render.filepath = str(path)
    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    return time.perf_counter() - t0


def load_rgba(bpy, np, path):
    img = bpy.data.images.load(str(path), check_existing=False)
    w, h = img.size
    px = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(h, w, 4)  # bottom row first


def save_rgba(bpy, np, arr, path):
    h, w = arr.shape[:2]
    img = bpy.data.images.new("composite", w, h, alpha=True)
    img.pixels.foreach_set(np.ascontiguousarray(arr, dtype=np.float32).ravel())
    img.filepath_raw = str(path)
    img.file_format = 'PNG'
    img.save()
    bpy.data.images.remove(img)


# --------------------------------------------------------------------------- figure (a)

def figure_groove(bpy, np, out, width, height):
    scene = reset_scene(bpy, width, height)
    R, a, b, p = 20.0, -0.05, 7.2, 20.0
    t0 = time.perf_counter()
    ret = bpy.ops.flank.paraboloid_groove(radius=R, a=a, b=b, pitch=p, turns=1.0, resolution=801)
    if ret != {'FINISHED'}:
        sys.exit("[figures] paraboloid_groove returned {}".format(ret))
    t_op = time.perf_counter() - t0
    objs = {o.name: o for o in bpy.data.collections["Paraboloid Groove"].objects}
    groove = objs["Groove Surface"]
    props = {k: (groove[k].to_list() if hasattr(groove[k], "to_list") else groove[k])
             for k in groove.keys() if k.startswith("flank_groove")}

    objs["Paraboloid Tool (moving)"].hide_render = True
    bisect_keep_positive_y(bpy, groove)
    paint(bpy, np, groove, (0.62, 0.68, 0.76, 1.0))
    tool = objs["Paraboloid Tool"]
    bisect_keep_positive_y(bpy, tool)
    paint(bpy, np, tool, (0.93, 0.74, 0.22, 1.0))
    band = objs["Overcut Band"]
    band.location = (0.0, -0.05, 0.0)  # just in front of the cut, towards the camera
    tube_from_edges(bpy, np, objs["Swept Section"], 0.035, (0.0, -0.12, 0.0), (0.80, 0.05, 0.05, 1.0))
    tube_from_edges(bpy, np, objs["Tool Section"], 0.035, (0.0, -0.10, 0.0), (0.08, 0.25, 0.85, 1.0))
    # the screw axis
    cu = bpy.data.curves.new("Axis", 'CURVE')
    cu.dimensions = '3D'
    cu.bevel_depth = 0.1
    sp = cu.splines.new('POLY')
    sp.points.add(1)
    sp.points.foreach_set("co", [0.0, 0.0, -16.0, 1.0, 0.0, 0.0, 16.0, 1.0])
    ax = bpy.data.objects.new("Axis", cu)
    scene.collection.objects.link(ax)
    paint(bpy, np, curve_to_mesh_object(bpy, ax, "Axis"), (0.2, 0.2, 0.2, 1.0))

    tmp = out / ".figures_tmp"
    tmp.mkdir(exist_ok=True)
    main_cam = add_camera(bpy, (-24.0, -84.0, 15.0), (-9.5, 0.0, -3.0), lens=50.0)
    dark = (0.12, 0.12, 0.12, 1.0)
    lines = ("Doğrusadık: paraboloid end mill on a helix, R = 20, a = -0.05, b = 7.2, p = 20",
             "groove and tool cut open along the section plane through the screw axis",
             "red: swept section   blue: tool section   band: overcut, max {:.3f} at x = {:.2f}".format(
                 props["flank_groove_max_overcut"], props["flank_groove_max_overcut_x"]))
    for k, line in enumerate(lines):
        add_label(bpy, np, main_cam, line, -0.97, -0.45 - 0.045 * k, 0.14 if k == 0 else 0.12, dark)
    t_main = render(bpy, np, tmp / "groove_main.png", main_cam)
    # inset: orthographic, straight along +Y at the section near x = -8 where the overcut is largest
    x_max = float(props["flank_groove_max_overcut_x"])
    inset_w, inset_h = width * 3 // 8, height * 3 // 8
    scene.render.resolution_x, scene.render.resolution_y = inset_w, inset_h
    inset_cam = add_camera(bpy, (x_max - 0.55, -40.0, 0.7), (x_max - 0.55, 0.0, 0.7), ortho_scale=2.6,
                           name="InsetCamera")
    for ob in bpy.data.objects:  # main-view labels off, inset label on
        if ob.name.startswith("Label"):
            ob.hide_render = True
    add_label(bpy, np, inset_cam, "zoom near x = {:.2f}, where the overcut is largest".format(x_max), -0.95, -0.50, 0.09,
              (0.95, 0.95, 0.95, 1.0), distance=5.0)
    t_inset = render(bpy, np, tmp / "groove_inset.png", inset_cam)

    main = load_rgba(bpy, np, tmp / "groove_main.png")
    inset = load_rgba(bpy, np, tmp / "groove_inset.png")
    frame = 3
    y0, x0 = height - inset_h - 12, width - inset_w - 12  # top right (rows are bottom-up)
    main[y0 - frame:y0 + inset_h + frame, x0 - frame:x0 + inset_w + frame] = (0.15, 0.15, 0.15, 1.0)
    main[y0:y0 + inset_h, x0:x0 + inset_w] = inset
    path = out / "groove_overcut.png"
    save_rgba(bpy, np, main, path)
    shutil.rmtree(tmp, ignore_errors=True)
    return dict(path=str(path), operator_s=round(t_op, 3), render_s=round(t_main + t_inset, 3),
                intercepts=props["flank_groove_intercepts"], max_overcut=props["flank_groove_max_overcut"],
                max_overcut_x=x_max)


# --------------------------------------------------------------------------- figure (b)

def ball_strip(np, point, normal, radius, depth, flank):
    c = [float(v) for v in np.r_[np.asarray(point) + (radius - depth) * np.asarray(normal), 0.0]]
    return {"axis_start": c, "axis_end": c, "radii": [radius, radius], "flank": int(flank),
            "shank_start": c, "shank_end": c, "shank_radius": 0.0,
            "reported_max_error": 0.0, "reported_min_error": 0.0, "collision": False}


def deviation_plan(np, core, n):
    """Ball strips along flanks 0 and 1 of the built-in asymmetric female rotor: gouge / ok / stock."""
    plan_mod, rotors, profile_mod = core("io.plan"), core("geometry.rotors"), core("geometry.profile")
    rotor = rotors.builtin_rotor("asymmetric", "female")
    section = plan_mod.rotor_section(rotor.profile, rotor.v0, rotor.handedness, rotor.flanks, n_profile=n)
    prof = np.asarray(section["profile"])
    spline = profile_mod.SplineProfile(prof)
    normals = spline.outward_normal(spline.knots[:-1])
    verify = core("simulation.verify")
    strips = []
    # flank 0: a dense row of balls just touching the design surface, one of them 0.006 too deep (gouge);
    # flank 1: a sparse row (stock left between the contact lines); plan unit R, tolerance 1e-3.
    # "Touching" = moved out by the ball's own helical-sweep overcut on the concave flank (one simulation
    # per ball, as a planner would compensate), so only the deliberate one gouges.
    for flank, count, deep in ((0, 14, 9), (1, 6, None)):
        a, b = section["flanks"][flank]
        for k, i in enumerate(np.linspace(a + 0.06 * (b - a), b - 0.06 * (b - a), count).astype(int) % n):
            strip = ball_strip(np, prof[i], normals[i], 0.05, 0.0, flank)
            single = plan_mod.new_plan("one-ball", section, {"kind": "revolved"}, target_flanks=[flank],
                                       strips=[strip])
            dev = [d for d in verify.verify_plan(single, all_points=True)["deviation_all"] if d is not None]
            lift = max(0.0, -min(dev)) if dev else 0.0
            strips.append(ball_strip(np, prof[i], normals[i], 0.05, (0.006 if k == deep else 0.0) - lift, flank))
    return plan_mod.new_plan("figure-balls", section, {"kind": "revolved"}, length_unit="R",
                             target_flanks=[0, 1], strips=strips)


def figure_deviation(bpy, np, out, width, height, core):
    from mathutils import Vector

    scene = reset_scene(bpy, width, height)
    n = 1440
    ret = bpy.ops.flank.generate_rotor(kind="asymmetric", part="female", resolution=n, axial=192)
    if ret != {'FINISHED'}:
        sys.exit("[figures] generate_rotor returned {}".format(ret))
    rotor = bpy.context.active_object
    plan = deviation_plan(np, core, n)
    tmp = out / ".figures_tmp"
    tmp.mkdir(exist_ok=True)
    plan_path = tmp / "figure_plan.json"
    core("io.plan").write_plan(str(plan_path), plan)
    t0 = time.perf_counter()
    ret = bpy.ops.flank.verify_plan(filepath=str(plan_path), show_tools=True)
    t_op = time.perf_counter() - t0
    if ret != {'FINISHED'}:
        sys.exit("[figures] verify_plan returned {}".format(ret))
    summary = {k: rotor[k] for k in ("flank_verify_max_undercut", "flank_verify_max_overcut", "flank_verify_gouges",
                                     "flank_verify_tolerance", "flank_verify_reached", "flank_verify_untouched")
               if k in rotor}
    for ob in bpy.data.collections["Verify Tools"].objects:
        paint(bpy, np, ob, (0.93, 0.74, 0.22, 1.0))

    corners = [rotor.matrix_world @ Vector(c) for c in rotor.bound_box]
    lo = Vector([min(c[i] for c in corners) for i in range(3)])
    hi = Vector([max(c[i] for c in corners) for i in range(3)])
    centre = (lo + hi) / 2
    size = (hi - lo).length
    # look at the painted flanks: from outside, in the direction of their mean profile point
    prof = np.asarray(plan["rotor"]["profile"])
    idx = np.r_[tuple(np.arange(a, b + 1) % len(prof) for a, b in (plan["rotor"]["flanks"][f]
                                                                   for f in plan["target_flanks"]))]
    d = prof[idx].mean(axis=0)
    d = d / np.linalg.norm(d)
    view = Vector((float(d[0]), float(d[1]), -0.35)).normalized()  # slightly from below: tools at z = 0
    data = bpy.data.cameras.new("DevCamera")
    data.lens = 50
    cam = bpy.data.objects.new("DevCamera", data)
    scene.collection.objects.link(cam)
    data.shift_y = -0.07  # rotor in the upper part of the frame, legend below it
    cam.location = centre + view * size * 2.0
    cam.rotation_euler = (centre - cam.location).to_track_quat('-Z', 'X').to_euler()
    colours = core("simulation.verify").DEVIATION_COLORS
    lines = (("flank.verify_plan: ball strips on two flanks of the built-in asymmetric female rotor",
              (0.12, 0.12, 0.12, 1.0)),
             ("red: gouge (deeper than the tolerance {:g} R)".format(summary["flank_verify_tolerance"]),
              colours["gouge"]),
             ("green: within the tolerance", colours["ok"]),
             ("blue: stock left (max undercut {:.4f} R)".format(summary["flank_verify_max_undercut"]),
              colours["stock"]),
             ("grey: no tool within the search range", (0.35, 0.35, 0.35, 1.0)))
    for k, (line, rgba) in enumerate(lines):
        add_label(bpy, np, cam, line, -0.97, -0.48 - 0.045 * k, 0.13 if k == 0 else 0.12, rgba, distance=1.0)
    path = out / "verify_deviation.png"
    t_render = render(bpy, np, path, cam)
    shutil.rmtree(tmp, ignore_errors=True)
    return dict(path=str(path), operator_s=round(t_op, 3), render_s=round(t_render, 3),
                vertices=len(rotor.data.vertices), strips=len(plan["strips"]), **summary)


# --------------------------------------------------------------------------- figure (c)

def figure_formed_cutter(bpy, np, out, width, height):
    from mathutils import Vector

    scene = reset_scene(bpy, width, height)
    t0 = time.perf_counter()
    ret = bpy.ops.flank.formed_cutter(source="TABLE1", animate=False, resolution=1440)
    t_op = time.perf_counter() - t0
    if ret != {'FINISHED'}:
        sys.exit("[figures] formed_cutter returned {}".format(ret))
    cutter = bpy.context.active_object
    p = {k: (cutter[k].to_list() if hasattr(cutter[k], "to_list") else cutter[k]) for k in cutter.keys()
         if k.startswith("flank_cutter_") and k != "flank_cutter_summary"}
    rotor = bpy.data.objects[p["flank_cutter_rotor"]]
    bpy.data.objects["Contact Points"].hide_render = True   # inside the disc in this view

    # look along the disc plane (the disc nearly edge-on, sitting in the groove), a little from outside
    o = Vector(cutter.matrix_world.translation)
    d = Vector((o.x, o.y, 0.0)).normalized()
    a = Vector(cutter.matrix_world.col[2][:3]).normalized()   # the cutter axis
    view = (a.cross(d).normalized() + 0.45 * d).normalized()
    target = d * 70.0
    cam = add_camera(bpy, target + view * 1250.0, target, lens=50.0)
    cam.data.shift_y = -0.09
    colours = (0.12, 0.12, 0.12, 1.0)
    green = (0.15, 0.55, 0.20, 1.0)
    lines = (("Hu, Zhou & Li 2025 formed disc cutter, Table-1 arc-tooth rotor: A = {:g}, swivel {:g} deg, lead {:g} mm".format(
                 p["flank_cutter_centre_distance"], p["flank_cutter_swivel"], p["flank_cutter_lead"]), colours),
             ("cutter radius {:.2f} .. {:.2f} mm over {} planes, no flagged plane".format(
                 p["flank_cutter_r_range"][0], p["flank_cutter_r_range"][1], p["flank_cutter_planes"]), colours),
             ("green: sweep-simulated machined surface within {:.2g} um of the tooth (max {:.2g} um); "
              "grey: not cut".format(p["flank_cutter_tolerance"] * 1e3, p["flank_cutter_max_abs_deviation"] * 1e3),
              green))
    for k, (line, rgba) in enumerate(lines):
        add_label(bpy, np, cam, line, -0.97, -0.47 - 0.045 * k, 0.13 if k == 0 else 0.12, rgba, distance=1.0)
    path = out / "formed_cutter.png"
    t_render = render(bpy, np, path, cam)
    return dict(path=str(path), operator_s=round(t_op, 3), render_s=round(t_render, 3),
                rotor_vertices=len(rotor.data.vertices), r_range=p["flank_cutter_r_range"],
                max_abs_deviation=p["flank_cutter_max_abs_deviation"], flagged_planes=p["flank_cutter_flagged_planes"])


def figure_double_flank(bpy, np, out, width, height):
    """Bizzarri & Bartoň 2021: asymmetric male rotor, valley 0, custom tool (min radial function) of flank.plan_double_flank."""
    from mathutils import Matrix, Vector

    scene = reset_scene(bpy, width, height)
    ret = bpy.ops.flank.generate_rotor(kind="asymmetric", part="male", resolution=1440, axial=160)
    if ret != {'FINISHED'}:
        sys.exit("[figures] generate_rotor returned {}".format(ret))
    rotor = bpy.context.active_object
    paint(bpy, np, rotor, (0.62, 0.64, 0.67, 1.0))
    rotor.hide_render = True      # the envelope strips are the valley's flanks: shown instead of the rotor
    t0 = time.perf_counter()
    ret = bpy.ops.flank.plan_double_flank(valley=0, radii=400, simulate=False, envelope_rings=96, animate=True,
                                          frame_start=1, frame_end=201)
    t_op = time.perf_counter() - t0
    if ret != {'FINISHED'}:
        sys.exit("[figures] plan_double_flank returned {}".format(ret))
    tool = bpy.context.active_object
    p = {k: (tool[k].to_list() if hasattr(tool[k], "to_list") else tool[k]) for k in tool.keys()
         if k.startswith("flank_df_") and k != "flank_df_summary"}
    coll = tool.users_collection[0]
    by_role = {}
    for ob in coll.objects:
        by_role.setdefault(ob.get("flank_df_role"), []).append(ob)
    # the moving tool half-way along the rotor; the static tool (at the rotor's end) and the empty hidden
    scene.frame_set(101)
    for ob in by_role.get("tool", []) + by_role.get("motion", []):
        ob.hide_render = True
    moving = by_role["moving"][0]
    paint(bpy, np, moving, (0.90, 0.72, 0.20, 1.0))
    # the error chart beside the moving tool, drawn as tubes (flank 1 red, flank 2 blue, baseline grey)
    chart = by_role["error_chart"][0]
    chart.hide_render = True
    mw = Matrix(moving.matrix_world)
    attr = chart.data.attributes["flank"]
    fl = np.empty(len(attr.data), dtype=np.float32)
    attr.data.foreach_get("value", fl)
    co = np.empty(len(chart.data.vertices) * 3)
    chart.data.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    ed = np.empty(len(chart.data.edges) * 2, dtype=np.int64)
    chart.data.edges.foreach_get("vertices", ed)
    ed = ed.reshape(-1, 2)
    r_tool = p["flank_df_radii_range"][1]
    tubes = []
    for value, rgba in ((1, (0.85, 0.15, 0.10, 1.0)), (2, (0.10, 0.35, 0.85, 1.0)), (0, (0.3, 0.3, 0.3, 1.0))):
        keep = ed[(fl[ed[:, 0]] == value) & (fl[ed[:, 1]] == value)]
        if not len(keep):
            continue
        idx = np.unique(keep)
        remap = -np.ones(len(co), dtype=np.int64)
        remap[idx] = np.arange(len(idx))
        me = bpy.data.meshes.new("chart{}".format(value))
        me.vertices.add(len(idx))
        me.vertices.foreach_set("co", co[idx].astype(np.float32).ravel())
        me.edges.add(len(keep))
        me.edges.foreach_set("vertices", remap[keep].astype(np.int32).ravel())
        me.update()
        ob = bpy.data.objects.new("chart{}".format(value), me)
        coll.objects.link(ob)
        tubes.append(tube_from_edges(bpy, np, ob, 0.02 * r_tool, (0.0, 0.0, 0.0), rgba))
        ob.hide_render = True
    # camera: beside the tool, looking at it across the valley (perpendicular to its axis, a little above)
    o = mw.translation
    axis = Vector(mw.col[2][:3]).normalized()
    side = axis.cross(Vector((0.0, 0.0, 1.0))).normalized()
    view = (side * 1.0 + axis * 0.9 + Vector((0.0, 0.0, 0.35))).normalized()
    # the chart stands beside the tool, in the plane of the tool axis facing the camera
    right = axis.cross(view).normalized()     # in the image: below the tool axis
    frame = Matrix.Identity(4)
    for i, col in enumerate((right, axis.cross(right), axis)):
        for j in range(3):
            frame[j][i] = col[j]
    frame.translation = o + right * 0.1
    for ob in tubes:
        ob.matrix_world = frame
    centre = o + axis * 0.45
    cam = add_camera(bpy, centre + view * 5.0, centre, lens=50.0)
    cam.data.shift_x = -0.14   # the scene to the right, the labels top left
    ink = (0.12, 0.12, 0.12, 1.0)
    deg = math.degrees
    lines = (("Bizzarri & Bartoň 2021 double-flank milling, built-in asymmetric male rotor, valley 0: custom tool, min radial function",
              ink),
             ("axis alpha {:+.3f} deg, delta {:+.4f} R, phi {:+.3f} deg (Phi {:.3g} R, {} iterations)".format(
                 deg(p["flank_df_alpha"][0]), p["flank_df_delta"][0], deg(p["flank_df_phi"][0]), p["flank_df_Phi"][0],
                 p["flank_df_iterations"][0]), ink),
             ("envelope: green within {:.0e} R, blue stock; max error flank 1 {:.2e} R, flank 2 {:.2e} R".format(
                 p["flank_df_tolerance"], p["flank_df_tool_to_rotor_max"][0], p["flank_df_tool_to_rotor_max"][1]),
              (0.10, 0.40, 0.20, 1.0)),
             ("error along the tool axis x {:.0f}: flank 1 red, flank 2 blue".format(
                 chart["flank_df_error_scale"]), (0.45, 0.12, 0.10, 1.0)))
    for k, (line, rgba) in enumerate(lines):
        add_label(bpy, np, cam, line, -1.25, 0.53 - 0.04 * k, 0.11 if k == 0 else 0.10, rgba, distance=1.0)
    path = out / "double_flank.png"
    t_render = render(bpy, np, path, cam)
    return dict(path=str(path), operator_s=round(t_op, 3), render_s=round(t_render, 3),
                alpha=p["flank_df_alpha"][0], delta=p["flank_df_delta"][0], phi=p["flank_df_phi"][0],
                max_error=p["flank_df_tool_to_rotor_max"])


def figure_walkthrough(bpy, np, out, width, height, core):
    """'s path through the panels, headless: an STL of a rotor -> Analyze -> tool -> Run (single flank) ->
    coloured strips -> Error Plot -> Animate -> Render Report -> CL export.  Six captioned panels of
    ``width`` x ``height`` in a 2 x 3 grid, docs/walkthrough.png; every step calls the operator the panel's
    button calls, with the values the panel passes."""
    import importlib
    import tempfile

    from mathutils import Vector

    pkg = core("geometry.rotors").__name__.rsplit(".", 3)[0]
    ui_ops = importlib.import_module(pkg + ".operators.ui_ops")
    text = importlib.import_module(pkg + ".operators.chart_text")       # Blender's font for the captions
    plot = core("report.error_chart")
    scene = reset_scene(bpy, width, height)
    us = scene.unit_settings
    us.system, us.scale_length, us.length_unit = 'METRIC', 0.001, 'MILLIMETERS'
    tmp = Path(tempfile.mkdtemp(prefix="flank-walkthrough-"))
    rotor_core = core("geometry.rotors").builtin_by_name("asymmetric-female", scale=50.0)
    v, f = rotor_core.mesh(n_profile=1440, n_axial=96)
    core("io.mesh_files").write_stl(str(tmp / "rotor.stl"), v, f)
    facts = {}
    panels = []                                  # (top-row-first float RGBA, caption lines)
    t0 = time.perf_counter()

    def rendered(path):
        render(bpy, np, path, cam)
        return load_rgba(bpy, np, path)[::-1]

    # 1. Workpiece: Blender's STL importer, Analyze Rotor, List Flanks, pick flank 1
    if "FINISHED" not in bpy.ops.wm.stl_import(filepath=str(tmp / "rotor.stl")):
        sys.exit("[figures] STL import failed")
    rotor = bpy.context.active_object
    for op in (bpy.ops.flank.analyze_rotor, bpy.ops.flank.refresh_flanks):
        if op() != {'FINISHED'}:
            sys.exit("[figures] {} failed".format(op))
    s = scene.flank_settings
    s.flank_index = next(i for i, row in enumerate(s.flank_list) if row.flank == 1)
    facts["analysis"] = dict(v0=float(rotor["flank_v0"]), residual=float(rotor["flank_residual"]),
                             flanks=int(rotor["flank_flank_count"]))
    co = np.empty(3 * len(rotor.data.vertices))
    rotor.data.vertices.foreach_get("co", co)
    mw = np.array(rotor.matrix_world)
    world = co.reshape(-1, 3) @ mw[:3, :3].T + mw[:3, 3]
    mid = world.mean(axis=0)
    r_out = float(np.linalg.norm(world[:, :2] - mid[:2], axis=1).max())
    cam = add_camera(bpy, Vector(mid) + Vector((1.0, -1.0, 0.35)).normalized() * 10.0 * r_out, Vector(mid), lens=50.0)
    panels.append((rendered(tmp / "w1.png"),
                   ["1 Import STL, Analyze, pick flank 1",
                    "v0 {:.3f} mm, residual {:.1e} mm, {} flanks".format(
                        facts["analysis"]["v0"], facts["analysis"]["residual"], facts["analysis"]["flanks"])]))
    # 2. Tool panel in mm (the demo's tapered end mill), Strategy single flank, Run
    s.tool_kind = 'CONE'
    s.sf_shape = 'alpha'
    s.tool_tip_diameter_mm, s.tool_taper_deg, s.tool_flute_length_mm = 5.0, math.degrees(math.asin(0.1)), 15.0
    s.tool_shank_diameter_mm, s.tool_shank_length_mm = 4.0, 30.0
    s.strategy = "SINGLE"
    s.sf_tolerance = 0.05                                  # mm (scene units)
    s.sf_animate = False
    idname, kw = ui_ops.run_call(s)
    t1 = time.perf_counter()
    ret = getattr(bpy.ops.flank, idname.split(".")[1])(**kw)
    facts["plan_s"] = round(time.perf_counter() - t1, 2)
    if ret != {'FINISHED'}:
        sys.exit("[figures] {} returned {}".format(idname, ret))
    tool = bpy.context.active_object
    coll = tool.users_collection[0]
    paint(bpy, np, rotor, (0.62, 0.64, 0.67, 1.0))
    for ob in coll.objects:
        role = ob.get("flank_sf_role")
        if role == "tool":
            paint(bpy, np, ob, (0.90, 0.72, 0.20, 1.0))
        elif role != "envelope":
            ob.hide_render = True
    env = [ob for ob in coll.objects if ob.get("flank_sf_role") == "envelope"]
    pts = np.vstack([np.array([ob.matrix_world @ p.co for p in ob.data.vertices]) for ob in env])
    nrm = np.vstack([np.array([ob.matrix_world.to_3x3() @ p.normal for p in ob.data.polygons]) for ob in env])
    target = pts.mean(axis=0)
    n = nrm.mean(axis=0)
    n /= np.linalg.norm(n)
    cam.location = Vector(target) + Vector(n) * 4.2 * r_out
    cam.rotation_euler = (Vector(target) - cam.location).to_track_quat('-Z', 'Y').to_euler()
    facts["run"] = dict(strips=int(coll["flank_sf_strips"]), max_error_mm=float(coll["flank_sf_max_error"]),
                        min_error_mm=float(coll["flank_sf_min_error"]), tolerance_mm=0.05)
    panels.append((rendered(tmp / "w2.png"),
                   ["2 Tool D5, 5.7 deg; Single Flank; Run",
                    "tolerance 50 um: {} strips, error {:+.1f} .. {:+.1f} um (green)".format(
                        facts["run"]["strips"], 1000 * facts["run"]["min_error_mm"],
                        1000 * facts["run"]["max_error_mm"])]))
    # 3. Results: Error Plot (the verified error along the flank, one curve per strip)
    if bpy.ops.flank.error_plot(width=width, height=height, filepath=str(tmp / "plot.png")) != {'FINISHED'}:
        sys.exit("[figures] error_plot failed")
    panels.append((load_rgba(bpy, np, tmp / "plot.png")[::-1],
                   ["3 Results: Error Plot along the flank", "verified by the sweep simulation, in um"]))
    # 4. Animate strip 1 (the rotor screws past the fixed tool)
    if bpy.ops.flank.animate_strip(strip=1, frame_start=1, frame_end=100) != {'FINISHED'}:
        sys.exit("[figures] animate_strip failed")
    for ob in coll.objects:
        if ob.get("flank_anim_role") == "rotor":
            paint(bpy, np, ob, (0.62, 0.64, 0.67, 1.0))
        if ob.get("flank_sf_role") == "tool" and ob.get("flank_sf_strip") != 0:
            ob.hide_render = True
    scene.frame_set(50)
    t1w = next(ob for ob in coll.objects if ob.get("flank_sf_role") == "tool" and ob.get("flank_sf_strip") == 0)
    aim = t1w.matrix_world.translation + t1w.matrix_world.to_3x3() @ Vector((0.0, 0.0, 7.5))
    radial = Vector((aim.x - mid[0], aim.y - mid[1], 0.0)).normalized()
    cam.location = aim + (radial + Vector((0.0, 0.0, 0.3))).normalized() * 3.5 * r_out
    cam.rotation_euler = (aim - cam.location).to_track_quat('-Z', 'Y').to_euler()
    panels.append((rendered(tmp / "w4.png"),
                   ["4 Animate Strip 1 (frame 50 of 100)", "the rotor screws past the fixed tool"]))
    scene.frame_set(1)
    # 5. Render Report (its own temporary scene): strips by signed error, legend, title
    if bpy.ops.flank.render_report(filepath=str(tmp / "report.png"), width=width, height=height) != {'FINISHED'}:
        sys.exit("[figures] render_report failed")
    panels.append((load_rgba(bpy, np, tmp / "report.png")[::-1],
                   ["5 Render Report: legend in um, title", "rendered headless, no window needed"]))
    # 6. Export CL data
    cl = tmp / "rotor.apt"
    if bpy.ops.flank.export_results(format='CL', filepath=str(cl), steps=120) != {'FINISHED'}:
        sys.exit("[figures] export failed")
    lines = cl.read_text().splitlines()
    gotos = [ln for ln in lines if ln.startswith("GOTO/")]
    facts["cl_steps"] = len(gotos)
    page = np.ones((height, width, 4), np.float32)
    scale = 2
    fit = (width - 20) // (plot.CHAR_ADVANCE * scale)       # characters per line at scale 2
    shown = [ln if len(ln) <= fit else ln[:fit - 3] + "..." for ln in
             [ln for ln in lines if not ln.startswith("GOTO/")][:6] + gotos[:11]] + ["..."]
    text.draw_text_items(page, [plot.text_item(ln, 10, 12 + k * (plot.LINE + 4) * scale, (0.1, 0.1, 0.1, 1.0),
                                               scale=scale, max_width=width - 20) for k, ln in enumerate(shown)])
    panels.append((page, ["6 Export CL: {} GOTO steps (APT)".format(len(gotos)),
                          "tool tip and axis per step, rotor frame, mm"]))

    # captions in a band above every panel; 2 columns x 3 rows
    cap_scale = 3
    band = 2 * (plot.LINE + 3) * cap_scale + 14
    tiles = []
    for img, caption in panels:
        tile = np.ones((band + height, width, 4), np.float32)
        tile[band:, :, :] = img[:height, :width]
        text.draw_text_items(tile, [plot.text_item(t, 10, 8 + k * (plot.LINE + 3) * cap_scale, (0.1, 0.1, 0.1, 1.0),
                                                   scale=cap_scale if k == 0 else cap_scale - 1,
                                                   max_width=width - 20) for k, t in enumerate(caption)])
        tile[band - 2:band, :, :3] = 0.7
        tiles.append(tile)
    gap = np.ones((band + height, 8, 4), np.float32)
    rows = [np.concatenate([tiles[i], gap, tiles[i + 1]], axis=1) for i in range(0, len(tiles), 2)]
    hgap = np.ones((8, rows[0].shape[1], 4), np.float32)
    grid = np.concatenate(sum(([r, hgap] for r in rows), [])[:-1], axis=0)
    path = out / "walkthrough.png"
    # the project's own PNG writer ('Up' filter rows): 25 % smaller than Blender's save of this picture
    core("io.png").write_png(str(path), (np.clip(grid, 0.0, 1.0) * 255 + 0.5).astype(np.uint8))
    shutil.rmtree(tmp, ignore_errors=True)
    us.system, us.scale_length = 'NONE', 1.0
    facts.update(path=str(path), total_s=round(time.perf_counter() - t0, 2))
    return facts


def main(argv=None):
    ap = argparse.ArgumentParser(description="Render the README figures (Workbench, headless)")
    ap.add_argument("--out", default=str(ROOT / "docs"))
    ap.add_argument("--size", default="960x540")
    ap.add_argument("--only", choices=("groove", "deviation", "cutter", "double_flank", "walkthrough"))
    src = ap.add_mutually_exclusive_group()
    src.add_argument("--zip", help="install this extension zip with Blender's installer")
    src.add_argument("--source", action="store_true", help="register the source tree (default)")
    args = ap.parse_args(argv)
    width, height = (int(v) for v in args.size.lower().split("x"))
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)

    user_dir = isolate_blender_user_dir()
    results = {}
    try:
        import importlib

        import bpy
        import numpy as np

        bpy.ops.wm.read_factory_settings(use_empty=True)
        installed = enable_extension(bpy, Path(args.zip).resolve() if args.zip else None)
        package = "bl_ext.user_default.flank_toolpath" if args.zip else "flank_toolpath"

        def core(name):
            return importlib.import_module("{}.flank_addon.{}".format(package, name))


        if args.only in (None, "groove"):
            results["groove_overcut"] = figure_groove(bpy, np, out, width, height)
            log("groove_overcut: {}".format(json.dumps(results["groove_overcut"])))
        if args.only in (None, "deviation"):
            results["verify_deviation"] = figure_deviation(bpy, np, out, width, height, core)
            log("verify_deviation: {}".format(json.dumps(results["verify_deviation"])))
        if args.only in (None, "cutter"):
            results["formed_cutter"] = figure_formed_cutter(bpy, np, out, width, height)
            log("formed_cutter: {}".format(json.dumps(results["formed_cutter"])))
        if args.only in (None, "double_flank"):
            results["double_flank"] = figure_double_flank(bpy, np, out, width, height)
            log("double_flank: {}".format(json.dumps(results["double_flank"])))
        if args.only in (None, "walkthrough"):
            results["walkthrough"] = figure_walkthrough(bpy, np, out, 800, 450, core)
            log("walkthrough: {}".format(json.dumps(results["walkthrough"])))
        results["extension"] = installed
    finally:
        shutil.rmtree(user_dir, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
