# SPDX-License-Identifier: GPL-3.0-or-later
"""Undo / redo of every data-changing flank.* operator, for test_blender_undo.py.

Under ``bpy.app.background`` an operator called from Python pushes no undo step of its own; the UI pushes one
after every operator whose bl_options hold 'UNDO'.  Each step here does what the UI does: push a step, take a
snapshot ("before"), run the operator, push a step named after it, snapshot ("after_run"), ``ed.undo``,
snapshot ("after_undo"), ``ed.redo``, snapshot ("after_redo").  The operators run one after another on one
small scene (a coarse built-in rotor, a second rotor for the analysis, a free-form test surface) so later
operators find the runs of earlier ones.  Python references to ID data die with every undo: everything is
looked up by name.

A snapshot is the data an operator may change, as plain JSON: the names of the data-blocks of every kind the
extension makes, per object its type, data, parent, collections, custom properties, visibility, colour and
(when not animated) transform, per mesh its sizes, attributes (with a digest of their values) and active
colour attribute, per collection its objects, children and custom properties, per action its F-curves and keys,
per image its size, packing and custom properties, every property of ``scene.flank_settings`` (the flank list
item by item), the 3D cursor, the active object, the selection and the mode.

Operators that declare no 'UNDO' (file writers) are run too, with before / after snapshots only: they must
leave the snapshot as it was."""
import hashlib
import math
import os
import time

import driver

ROTOR = "Rotor_asymmetric_female"
ANALYZED = "Rotor_nilson_male"
FRAMES = dict(frame_start=1, frame_end=21)
SF_TOOL = dict(shape="alpha", alpha=driver.SF_ASIN, r1=0.05, r2=0.08, shank_radius=0.04, shank_length=0.6,
               tolerance=1e-3)
FF_TOOL = dict(r1=0.03, r2=0.03, length=0.25, samples=12, columns=8, max_evaluations=30, tolerance=0.002)
ID_KINDS = ("objects", "meshes", "collections", "actions", "images", "materials", "curves", "texts", "cameras",
            "lights", "worlds", "node_groups", "scenes")
# numpy dtype and values per element of each attribute type (attribute.data.foreach_get)
ATTR_LAYOUT = {"FLOAT": ("value", "f4", 1), "INT": ("value", "i4", 1), "BOOLEAN": ("value", "?", 1),
               "INT8": ("value", "i1", 1), "FLOAT_VECTOR": ("vector", "f4", 3), "FLOAT2": ("vector", "f4", 2),
               "FLOAT_COLOR": ("color", "f4", 4), "BYTE_COLOR": ("color", "f4", 4),
               "INT32_2D": ("value", "i4", 2), "QUATERNION": ("value", "f4", 4), "FLOAT4X4": ("value", "f4", 16)}
LONG_TEXT = 160          # longer string properties (plans, summaries) are kept as a digest


# ============================================================================================== snapshot
def _plain(value):
    """A custom-property / RNA value as JSON that compares exactly (non-finite floats become text)."""
    if isinstance(value, bool) or value is None or isinstance(value, int):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else repr(value)
    if isinstance(value, str):
        if len(value) > LONG_TEXT:
            return "<{} chars sha1 {}>".format(len(value), hashlib.sha1(value.encode("utf-8")).hexdigest()[:16])
        return value
    if hasattr(value, "to_dict"):
        return {str(k): _plain(v) for k, v in value.to_dict().items()}
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (set, frozenset)):
        return sorted(str(v) for v in value)
    if hasattr(value, "to_list"):
        return [_plain(v) for v in value.to_list()]
    try:
        return [_plain(v) for v in value]
    except TypeError:
        return str(value)


def _custom(idb):
    return {k: _plain(idb[k]) for k in sorted(idb.keys())}


def _digest(np, attr):
    layout = ATTR_LAYOUT.get(attr.data_type)
    n = len(attr.data)
    if layout is None or n == 0:
        return None
    prop, dtype, width = layout
    buf = np.empty(n * width, dtype=dtype)
    try:
        attr.data.foreach_get(prop, buf)
    except (RuntimeError, TypeError, AttributeError):
        return None
    return hashlib.sha1(buf.tobytes()).hexdigest()[:16]


def _mesh(np, me):
    attrs = {}
    for a in me.attributes:
        if a.name.startswith("."):
            continue                                   # selection / hide flags of the editor
        attrs[a.name] = [a.data_type, a.domain, len(a.data), _digest(np, a)]
    active = me.color_attributes.active_color
    return dict(vertices=len(me.vertices), edges=len(me.edges), faces=len(me.polygons), attributes=attrs,
                active_color=active.name if active is not None else None, props=_custom(me), users=me.users)


def _hidden(ob):
    try:
        return ob.hide_get()
    except RuntimeError:                               # not in the view layer
        return None


def _object(ob):
    anim = ob.animation_data
    action = anim.action.name if anim is not None and anim.action is not None else None
    out = dict(type=ob.type, data=ob.data.name if ob.data is not None else None,
               parent=ob.parent.name if ob.parent is not None else None,
               collections=sorted(c.name for c in ob.users_collection), props=_custom(ob), hidden=_hidden(ob),
               hide_viewport=ob.hide_viewport, color=[round(float(c), 6) for c in ob.color], action=action,
               mode=ob.mode)
    if action is None:                                 # animated transforms follow the evaluated frame
        out["matrix"] = [[round(float(v), 6) for v in row] for row in ob.matrix_basis]
    return out


def _action(act, fcurves):
    curves = list(fcurves(act))
    return dict(fcurves=len(curves), keys=sum(len(fc.keyframe_points) for fc in curves),
                paths=sorted({fc.data_path for fc in curves}), users=act.users, props=_custom(act))


def _image(np, img):
    return dict(size=list(img.size), packed=img.packed_file is not None, fake_user=bool(img.use_fake_user),
                source=img.source, props=_custom(img))


def _rna_value(holder, prop):
    if prop.type == 'POINTER':
        return None
    if prop.type == 'COLLECTION':
        items = []
        for item in getattr(holder, prop.identifier):
            items.append({p.identifier: _rna_value(item, p) for p in item.bl_rna.properties
                          if p.identifier != "rna_type"})
        return items
    return _plain(getattr(holder, prop.identifier))


def _settings(scene):
    s = scene.flank_settings
    return {p.identifier: _rna_value(s, p) for p in s.bl_rna.properties if p.identifier != "rna_type"}


def snapshot(bpy, np, fcurves):
    """Everything an operator of the extension may change, as plain JSON (see the module text)."""
    data = bpy.data
    scene = bpy.context.scene
    view_layer = bpy.context.view_layer
    active = view_layer.objects.active
    return dict(
        names={kind: sorted(idb.name for idb in getattr(data, kind)) for kind in ID_KINDS},
        objects={ob.name: _object(ob) for ob in data.objects},
        meshes={me.name: _mesh(np, me) for me in data.meshes},
        collections={c.name: dict(objects=sorted(o.name for o in c.objects),
                                  children=sorted(ch.name for ch in c.children), props=_custom(c))
                     for c in data.collections},
        scene_children=sorted(c.name for c in scene.collection.children),
        scene_objects=sorted(o.name for o in scene.collection.objects),
        actions={a.name: _action(a, fcurves) for a in data.actions},
        images={i.name: _image(np, i) for i in data.images},
        curves={c.name: dict(splines=len(c.splines), users=c.users, props=_custom(c)) for c in data.curves},
        settings=_settings(scene),
        cursor=[round(float(v), 6) for v in scene.cursor.location],
        cursor_rotation=[round(float(v), 6) for v in scene.cursor.rotation_euler],
        frame=[scene.frame_start, scene.frame_end, scene.frame_current],
        active=active.name if active is not None else None,
        selected=sorted(o.name for o in view_layer.objects if o.select_get()),
        mode=bpy.context.mode,
    )


# ============================================================================================== steps
def _op(bpy, idname):
    return getattr(bpy.ops.flank, idname.split(".", 1)[1])


def _undo_step(bpy, np, fcurves, idname, kw, steps):
    """Push / run / push / undo / redo as the UI does for an UNDO operator, with a snapshot at every stage."""
    bpy.ops.ed.undo_push(message="before " + idname)
    rec = dict(op=idname, kw={k: _plain(v) for k, v in kw.items()}, before=snapshot(bpy, np, fcurves))
    t0 = time.perf_counter()
    rec["result"], rec["error"] = driver._run_op(_op(bpy, idname), **kw)
    rec["seconds"] = time.perf_counter() - t0
    bpy.ops.ed.undo_push(message=idname)
    rec["after_run"] = snapshot(bpy, np, fcurves)
    for stage, call in (("after_undo", bpy.ops.ed.undo), ("after_redo", bpy.ops.ed.redo)):
        try:
            ret = call()
            rec[stage + "_result"] = sorted(ret)
            rec[stage + "_error"] = None
        except Exception as ex:                         # noqa: BLE001 -- recorded for the test
            rec[stage + "_result"] = None
            rec[stage + "_error"] = "{}: {}".format(type(ex).__name__, ex)
        rec[stage] = snapshot(bpy, np, fcurves)
    steps[idname] = rec
    return rec


def _plain_step(bpy, np, fcurves, idname, kw, steps):
    """An operator without UNDO: it must not change the snapshot at all."""
    rec = dict(op=idname, kw={k: _plain(v) for k, v in kw.items()}, before=snapshot(bpy, np, fcurves))
    t0 = time.perf_counter()
    rec["result"], rec["error"] = driver._run_op(_op(bpy, idname), **kw)
    rec["seconds"] = time.perf_counter() - t0
    rec["after_run"] = snapshot(bpy, np, fcurves)
    steps[idname] = rec
    return rec


def _activate(bpy, name, select=True):
    view_layer = bpy.context.view_layer
    for o in view_layer.objects:
        if o.select_get():
            o.select_set(False)
    ob = bpy.data.objects.get(name) if name else None
    view_layer.objects.active = ob
    if ob is not None and select:
        ob.select_set(True)
    return ob


def _flank_point(np, surface, flanks, k):
    """A point on the middle of flank k in the rotor frame (t = 0: the transverse section z = 0)."""
    a, b = flanks[k]
    xy = surface.profile.eval(np.array([0.5 * (a + b)]))[0]
    return (float(xy[0]), float(xy[1]), 0.0)


def _faces_of_flank(np, screw, surface, flanks, mesh, k):
    """Indices of faces whose centre lies well inside flank k (centres screwed into z = 0, nearest profile
    parameter within the inner 60 % of the flank's range)."""
    n = len(mesh.polygons)
    centres = np.empty(3 * n)
    mesh.polygons.foreach_get("center", centres)
    q = screw.screw_to_plane(centres.reshape(-1, 3), surface.v0, surface.hand)[:, :2]
    us = surface.profile.params(2048)
    pts = surface.profile.eval(us)
    near = us[np.argmin(((q[:, None, :] - pts[None, :, :]) ** 2).sum(axis=2), axis=1)]
    a, b = flanks[k]
    lo, hi = a + 0.2 * (b - a), b - 0.2 * (b - a)
    return [int(i) for i in np.flatnonzero((near > lo) & (near < hi))]


def _result_run(bpy, prefix):
    """Name of the newest result collection holding a plan whose keys start with ``prefix``."""
    parent = bpy.data.collections.get("Flank Results")
    runs = [c.name for c in parent.children if "flank_plan_json" in c and any(k.startswith(prefix) for k in c.keys())] \
        if parent is not None else []
    return runs[-1] if runs else None


def scenario(bpy, res, args):
    import numpy as np

    common = __import__(driver.MODULE + ".operators.common", fromlist=["iter_fcurves"])
    fcurves = common.iter_fcurves
    rotors, screw = driver._core("geometry.rotors"), driver._core("geometry.screw")
    tmp = os.path.abspath(os.getcwd())
    t_start = time.perf_counter()

    ops = sorted("flank." + name for name in dir(bpy.ops.flank) if not name.startswith("_"))
    res["operators"] = ops
    opts = {}
    for idname in ops:
        cls = getattr(bpy.types, "FLANK_OT_" + idname.split(".", 1)[1], None)
        opts[idname] = sorted(cls.bl_options) if cls is not None and hasattr(cls, "bl_options") else None
    res["bl_options"] = opts
    # the Tool Presets menu applies a preset with Blender's own script.execute_preset (not a flank.* operator)
    preset_cls = getattr(bpy.types, "SCRIPT_OT_execute_preset", None)
    res["execute_preset_bl_options"] = sorted(getattr(preset_cls, "bl_options", {'REGISTER'})) \
        if preset_cls is not None else None

    steps = {}
    res["steps"] = steps
    timing = {}
    res["timing"] = timing
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 21

    # ------------------------------------------------------------------------------- rotors
    _undo_step(bpy, np, fcurves, "flank.generate_rotor",
               dict(kind="asymmetric", part="female", resolution=180, axial=16), steps)
    driver._run_op(bpy.ops.flank.generate_rotor, kind="nilson", part="male", resolution=96, axial=12)
    bpy.data.objects[ANALYZED].location = (0.0, 4.0, 0.0)
    _activate(bpy, ANALYZED)
    _undo_step(bpy, np, fcurves, "flank.analyze_rotor", {}, steps)

    # ------------------------------------------------------------------------------- flank list and picking
    rotor = rotors.builtin_rotor("asymmetric", "female")
    surface, flanks = rotor.surface(), rotor.flanks
    _activate(bpy, ROTOR)
    _undo_step(bpy, np, fcurves, "flank.refresh_flanks", dict(samples=24), steps)

    scene = bpy.context.scene
    scene.flank_settings.flank_index = 0
    scene.cursor.location = _flank_point(np, surface, flanks, 4)      # the rotor sits at the origin unscaled
    _activate(bpy, ROTOR)
    _undo_step(bpy, np, fcurves, "flank.pick_flank_cursor", {}, steps)

    scene = bpy.context.scene
    scene.flank_settings.flank_index = 0
    ob = _activate(bpy, ROTOR)
    faces = _faces_of_flank(np, screw, surface, flanks, ob.data, 6)
    mask = np.zeros(len(ob.data.polygons), dtype=bool)
    mask[faces] = True
    ob.data.polygons.foreach_set("select", mask)
    scene.tool_settings.mesh_select_mode = (False, False, True)
    bpy.ops.object.mode_set(mode='EDIT')
    res["pick_faces_selected"] = len(faces)
    _undo_step(bpy, np, fcurves, "flank.pick_flank_faces", {}, steps)
    # control, no operator: the same kind of change typed into the setting in Edit Mode, pushed and undone as
    # the UI does -- tells a fault of the operator from what Blender's Edit-Mode undo (mesh steps) covers
    control = dict(mode=bpy.context.mode)
    bpy.ops.ed.undo_push(message="before edit-mode control")
    control["before"] = bpy.context.scene.flank_settings.flank_index
    bpy.context.scene.flank_settings.flank_index = 2
    bpy.ops.ed.undo_push(message="edit-mode control")
    control["after_set"] = bpy.context.scene.flank_settings.flank_index
    bpy.ops.ed.undo()
    control["after_undo"] = bpy.context.scene.flank_settings.flank_index
    bpy.ops.ed.redo()
    control["after_redo"] = bpy.context.scene.flank_settings.flank_index
    res["edit_mode_control"] = control
    bpy.ops.object.mode_set(mode='OBJECT')

    # ------------------------------------------------------------------------------- the tool
    _activate(bpy, ROTOR)
    _undo_step(bpy, np, fcurves, "flank.tool_preset",
               dict(taper_deg=3.0, tip_diameter_mm=0.1, flute_length_mm=1.0, shank_diameter_mm=0.2,
                    overall_length_mm=3.0), steps)
    _activate(bpy, ROTOR)
    _undo_step(bpy, np, fcurves, "flank.preview_tool", {}, steps)
    timing["setup_and_small_ops"] = time.perf_counter() - t_start

    # ------------------------------------------------------------------------------- planners
    plan_path = os.path.join(tmp, "undo_sf_plan.json")
    _activate(bpy, ROTOR)
    _undo_step(bpy, np, fcurves, "flank.plan_single_flank",
               dict(SF_TOOL, flank=1, seeds=4, rounds=1, envelope_rings=8, animate=True, filepath=plan_path,
                    **FRAMES), steps)
    _activate(bpy, ROTOR)
    _undo_step(bpy, np, fcurves, "flank.plan_double_flank",
               dict(valley=0, radii=40, samples=30, envelope_rings=8, simulate=False, animate=True, **FRAMES),
               steps)
    _activate(bpy, ROTOR)
    _undo_step(bpy, np, fcurves, "flank.cutter_region",
               dict(flank=1, r1=0.02, r2=0.04, alpha=0.1, grid=(6, 8, 8), samples=64), steps)
    _activate(bpy, ROTOR)
    _undo_step(bpy, np, fcurves, "flank.formed_cutter",
               dict(source="ACTIVE", planes=20, sample_points=8, animate=True, **FRAMES), steps)
    _undo_step(bpy, np, fcurves, "flank.paraboloid_groove", dict(turns=0.5, resolution=101), steps)
    _activate(bpy, ROTOR)
    _undo_step(bpy, np, fcurves, "flank.verify_plan", dict(filepath=plan_path, show_tools=True), steps)
    timing["planners"] = time.perf_counter() - t_start

    # ------------------------------------------------------------------------------- the single-flank run
    sf_run = _result_run(bpy, "flank_sf_")
    res["sf_run"] = sf_run
    bpy.context.scene.flank_settings.results_strip_index = 0
    _activate(bpy, ROTOR)
    _undo_step(bpy, np, fcurves, "flank.select_run", dict(collection=sf_run or ""), steps)
    _activate(bpy, ROTOR)
    _undo_step(bpy, np, fcurves, "flank.animate_strip", dict(collection=sf_run or "", strip=1, **FRAMES), steps)
    _undo_step(bpy, np, fcurves, "flank.error_plot", dict(collection=sf_run or "", width=320, height=200), steps)
    _activate(bpy, ROTOR)                               # replaces the strip's animation with the program's
    us = bpy.context.scene.unit_settings
    units = us.system, us.scale_length
    us.system, us.scale_length = 'METRIC', 0.001        # the program in mm of the scene: the rotor is R = 1 mm
    _undo_step(bpy, np, fcurves, "flank.post_program",
               dict(collection=sf_run or "", lobes="0", filepath=os.path.join(tmp, "undo_program.ngc"), **FRAMES),
               steps)
    _undo_step(bpy, np, fcurves, "flank.check_program",
               dict(collection=sf_run or "", post="linuxcnc", filepath=os.path.join(tmp, "undo_program.ngc")), steps)
    us = bpy.context.scene.unit_settings
    us.system, us.scale_length = units

    # ------------------------------------------------------------------------------- free-form
    scene = bpy.context.scene
    scene.cursor.location = (4.0, 0.0, 0.0)
    scene.cursor.rotation_euler = (0.0, 0.0, 0.0)
    _undo_step(bpy, np, fcurves, "flank.add_test_surface",
               dict(kind="parabolic_blade", size=1.0, resolution=12), steps)
    surface_name = bpy.context.active_object.name if bpy.context.active_object is not None else None
    res["test_surface"] = surface_name
    _activate(bpy, surface_name)
    _undo_step(bpy, np, fcurves, "flank.pick_guiding_direction", dict(source="CURSOR", axis="X"), steps)
    s = bpy.context.scene.flank_settings
    s.ff_spacing = 0.2
    _activate(bpy, surface_name)
    _undo_step(bpy, np, fcurves, "flank.preview_guiding", {}, steps)
    bpy.context.scene.flank_settings.ff_live_preview = True
    _activate(bpy, surface_name)
    _undo_step(bpy, np, fcurves, "flank.clear_guiding_preview", {}, steps)
    _activate(bpy, surface_name)
    _undo_step(bpy, np, fcurves, "flank.plan_freeform", dict(FF_TOOL, direction=(1.0, 0.0, 0.0)), steps)
    timing["undo_steps"] = time.perf_counter() - t_start

    # ------------------------------------------------------------------------------- no UNDO: files only
    _activate(bpy, ROTOR)
    _plain_step(bpy, np, fcurves, "flank.export_results",
                dict(collection=sf_run or "", format="CL", steps=10, filepath=os.path.join(tmp, "undo_run.apt")),
                steps)
    _plain_step(bpy, np, fcurves, "flank.render_report",
                dict(collection=sf_run or "", filepath=os.path.join(tmp, "undo_report.png"), width=64, height=64),
                steps)
    _plain_step(bpy, np, fcurves, "flank.tool_preset_add", dict(name="Undo Test Tool"), steps)
    res["files"] = sorted(f for f in os.listdir(tmp) if f.startswith("undo_"))
    presets = bpy.utils.preset_paths("flank_tool")
    res["user_presets"] = sorted(f for p in presets if os.path.isdir(p) for f in os.listdir(p))
    timing["total"] = time.perf_counter() - t_start
