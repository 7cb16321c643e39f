# SPDX-License-Identifier: GPL-3.0-or-later
"""The guiding direction and guiding curves of free-form G1 planning (Rajain et al. 2023, Sec. 5): the checks of
the tool and the direction shared with flank.plan_freeform, the guiding-curve preview (flank.preview_guiding,
flank.clear_guiding_preview, and the live preview the free-form settings redraw) and the direction picker
(flank.pick_guiding_direction).

The plan is made in the mesh object's local (model) coordinates; the object may be moved, rotated and uniformly
scaled (lengths in the sidebar are scene units, divided by that scale for the planner)."""
import math
import types

import bpy
import numpy as np
from bpy.props import EnumProperty, StringProperty
from mathutils import Matrix

from .common import typed
from .jobs import PlannerJob
from .modal import ModalPlannerMixin
from .sources import surface_object, surface_source
from .tool_settings import freeform_tool
from .units import length_text

PREVIEW_NAME = "Flank Guiding Preview"
PREVIEW_PROP = "flank_guiding_preview"
COLOR_GUIDING = (0.20, 0.75, 0.95, 1.0)

_preview_state = {"message": ""}        # the live preview's last outcome (shown in the panel)


# ================================================================================================ checks
def check_tool(props):
    """Tool, spacing and engagement checks -> error message or None (values in scene units)."""
    r1, r2, L = typed(props.r1), typed(props.r2), typed(props.length)
    for label, v in (("tip sphere radius r1", r1), ("base sphere radius r2", r2)):
        if not math.isfinite(v) or v < 0.0:
            return "{} = {} must be a finite number >= 0".format(label, v)
    if not math.isfinite(L) or not L > abs(r2 - r1):
        return "axis length L = {} must exceed |r2 - r1| = {:.7g}".format(L, abs(r2 - r1))
    if not max(r1, r2) > 0.0:
        return "tip sphere radius r1 = 0 and base sphere radius r2 = 0: the tool needs a radius > 0"
    for label, v in (("shank radius", props.shank_radius), ("shank length", props.shank_length),
                     ("strip spacing", props.spacing)):
        v = typed(v)
        if not math.isfinite(v) or v < 0.0:
            return "{} = {} must be a finite number >= 0".format(label, v)
    e = typed(props.engagement)
    if not (math.isfinite(e) and 0.05 <= e <= 1.0):
        return "engagement = {} is outside the limits 0.05 .. 1".format(e)
    return None


def size_check(props, src):
    """Lengths beyond 10 x the surface's size mean a tool or spacing that cannot make a strip."""
    V = src["V"]
    diag = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) * src["scale"]
    if not diag > 0.0:
        return "the surface has no extent"
    for label, v in (("tip sphere radius r1", props.r1), ("base sphere radius r2", props.r2),
                     ("axis length L", props.length), ("strip spacing", props.spacing),
                     ("shank radius", props.shank_radius), ("shank length", props.shank_length)):
        if not typed(v) <= 10.0 * diag:
            return "{} = {:g} exceeds the limit 10 x the surface's diagonal = {:.6g} (scene units)".format(
                label, typed(v), 10.0 * diag)
    return None


def guiding_inputs(props, src):
    """Direction, point and field of the planner's guiding_curves / plan_freeform in the object's local frame,
    from properties in world axes -> dict or an error message (str)."""
    A = src["to_world"][:3, :3]
    t = src["to_world"][:3, 3]
    if props.direction_mode == "FIELD":
        if src["field"] is None:
            return "Guide By = Vector Attribute needs the attribute's name"
        direction = None
    else:
        d = np.array([typed(v) for v in props.direction], dtype=np.float64)
        if not np.isfinite(d).all() or not np.linalg.norm(d) > 1e-12:
            return "guiding direction {} must be a finite non-zero vector".format(d.tolist())
        direction = A.T @ d                    # A = s R: A^T d is R^T d up to the factor s
        direction /= np.linalg.norm(direction)
    point = None
    if props.use_point:
        p = np.array([typed(v) for v in props.point], dtype=np.float64)
        if not np.isfinite(p).all():
            return "point {} is not finite".format(p.tolist())
        point = np.linalg.solve(A, p - t)
    return dict(direction=direction, point=point,
                field_vectors=src["field"] if props.direction_mode == "FIELD" else None)


def planning_surface(context, props):
    """The surface the free-form settings ``props`` plan on -> surface_source dict, or an error message."""
    return surface_source(surface_object(context), bool(props.selected_only),
                          str(props.field_attribute) if props.direction_mode == "FIELD" else "", PREVIEW_PROP)


# ================================================================================================ preview
def _preview_objects():
    return [ob for ob in bpy.data.objects if ob.get(PREVIEW_PROP) is not None]


def remove_guiding_preview():
    for ob in _preview_objects():
        cu = ob.data
        bpy.data.objects.remove(ob)
        if cu is not None and cu.users == 0:
            bpy.data.curves.remove(cu)


def guiding_job(context, props, run_tool):
    """What the guiding curves for the settings ``props`` and the tool need, read from Blender on the main thread:
    a dict of plain values (the surface source keeps its object only for names and the transform); raises
    ValueError with a clear message on bad input."""
    from ..flank_addon.methods.freeform_g1.planner import engaged_cone

    run_tool = types.SimpleNamespace(**vars(run_tool), spacing=props.spacing, engagement=props.engagement)
    msg = check_tool(run_tool)
    src = planning_surface(context, props) if msg is None else msg
    msg = src if isinstance(src, str) else size_check(run_tool, src)
    gi = guiding_inputs(props, src) if msg is None else msg
    if isinstance(gi, str):
        raise ValueError(gi)
    s = src["scale"]
    r1e, r2e, Le = engaged_cone(typed(run_tool.r1) / s, typed(run_tool.r2) / s, typed(run_tool.length) / s,
                                typed(props.engagement))
    spacing = typed(props.spacing) / s if typed(props.spacing) > 0.0 else None
    F = src["F"][:, ::-1] if props.flip_normals else src["F"]
    return dict(src=src, name=src["obj"].name, V=src["V"], F=F, kwargs=dict(r1=r1e, r2=r2e, L=Le, spacing=spacing,
                                                                           **gi))


def compute_guiding(job):
    """(guiding curves, polylines) of a :func:`guiding_job`: pure numpy/scipy, no Blender data (a worker thread
    may run it); raises ValueError when there is no curve."""
    from ..flank_addon.methods.freeform_g1.guiding import guiding_curves

    gc = guiding_curves(job["V"], job["F"], **job["kwargs"])
    polylines = [pl.points for c in gc.curves for pl in c.polylines if len(pl.points) >= 2]
    if not polylines:
        raise ValueError("no guiding curve at spacing d = {:.6g} on '{}' (a smaller tool or spacing)".format(
            gc.spacing * job["src"]["scale"], job["name"]))
    return gc, polylines


def show_guiding_preview(context, job, gc, polylines):
    """The curve object PREVIEW_NAME (replacing the earlier one) for computed guiding curves -> message (str)."""
    src = job["src"]
    s = src["scale"]
    cu = bpy.data.curves.new(PREVIEW_NAME, 'CURVE')
    try:
        cu.dimensions = '3D'
        for pts in polylines:
            sp = cu.splines.new('POLY')
            sp.points.add(len(pts) - 1)
            sp.points.foreach_set("co", np.c_[pts, np.ones(len(pts))].astype(np.float32).ravel())
            sp.use_cyclic_u = bool(np.linalg.norm(pts[0] - pts[-1]) < 1e-9 * (1.0 + np.abs(pts).max()))
        remove_guiding_preview()
        cu.name = PREVIEW_NAME
        ob = bpy.data.objects.new(PREVIEW_NAME, cu)
        context.scene.collection.objects.link(ob)
    except Exception:
        bpy.data.curves.remove(cu)
        raise
    if ob.name != PREVIEW_NAME:
        ob.name = PREVIEW_NAME
    ob[PREVIEW_PROP] = job["name"]
    ob[PREVIEW_PROP + "_spacing"] = float(gc.spacing * s)
    ob[PREVIEW_PROP + "_curves"] = len(gc.curves)
    ob.matrix_world = Matrix(src["to_world"].tolist())
    ob.color = COLOR_GUIDING
    return "{} guiding curves ({} polylines) {} apart on '{}'".format(
        len(gc.curves), len(polylines), length_text(gc.spacing * s, context.scene), job["name"])


def build_guiding_preview(context, props, run_tool):
    """Compute the guiding curves for ``props`` (scene settings or an operator) on the active mesh and show them
    as the curve object PREVIEW_NAME (replacing the earlier one) -> message (str) of what was drawn; raises
    ValueError with a clear message on bad input."""
    job = guiding_job(context, props, run_tool)
    return show_guiding_preview(context, job, *compute_guiding(job))


class SettingsView:
    """The scene settings' ff_* values under the operator's property names."""

    def __init__(self, settings):
        object.__setattr__(self, "_s", settings)

    def __getattr__(self, name):
        return getattr(self._s, "ff_" + name)


def _error_text(ex):
    return str(ex) if isinstance(ex, ValueError) else "{}: {}".format(type(ex).__name__, ex)


# the live preview off the UI thread: the settings of the newest change (read on the main thread, not started
# yet), and the worker running on an earlier change with the settings it was given
_live = {"pending": None, "job": None, "inputs": None}
LIVE_STEP = 0.1


def refresh_guiding_preview(context, background=None):
    """The live preview: redraw from the scene settings; errors are kept for the panel, never raised.

    With an interface (``background`` False; default: not ``bpy.app.background``) a property update only reads
    the settings and the surface (10-20 ms for 20,000 triangles); the curves are computed in a worker thread and
    drawn by a timer (:func:`live_preview_tick`).  Changes that come while a worker runs (a dragged slider) are
    taken together: the running one's result is dropped and only the newest settings are computed next.  Without
    an interface (no event loop runs timers) the preview is drawn at once."""
    settings = getattr(context.scene, "flank_settings", None)
    if settings is None:
        return
    background = bpy.app.background if background is None else background
    if background:
        try:
            _preview_state["message"] = build_guiding_preview(context, SettingsView(settings),
                                                              freeform_tool(settings))
            _preview_state["error"] = False
        except Exception as ex:              # shown in the panel; a property update must not raise
            _preview_state.update(message=_error_text(ex), error=True)
        return
    if _live["job"] is not None:
        _live["job"].cancel()                # its settings are out of date: nothing of it is drawn
    try:
        _live["pending"] = guiding_job(context, SettingsView(settings), freeform_tool(settings))
    except Exception as ex:
        _live["pending"] = None
        _preview_state.update(message=_error_text(ex), error=True)
        return
    _preview_state.update(message="computing the guiding curves ...", error=False)
    if not bpy.app.timers.is_registered(live_preview_tick):
        bpy.app.timers.register(live_preview_tick, first_interval=0.0)


def live_preview_tick():
    """The live preview's timer: start a worker on the newest settings, draw its curves when it is done ->
    seconds to the next call, or None when there is nothing left to do."""
    job = _live["job"]
    if job is not None:
        state = job.poll()[0]
        if state == "running":
            return LIVE_STEP
        inputs = _live["inputs"]
        _live.update(job=None, inputs=None)
        if state == "finished" and _live["pending"] is None:
            if bpy.data.objects.get(inputs["name"]) is None:
                _preview_state.update(message="'{}' was removed".format(inputs["name"]), error=True)
            else:
                try:
                    _preview_state.update(message=show_guiding_preview(bpy.context, inputs, *job.result), error=False)
                except Exception as ex:
                    _preview_state.update(message=_error_text(ex), error=True)
        elif state == "failed" and _live["pending"] is None:
            _preview_state.update(message=_error_text(job.error), error=True)
        _redraw_sidebars()
    inputs = _live["pending"]
    if inputs is not None:
        _live.update(pending=None, inputs=inputs,
                     job=PlannerJob(lambda progress, inputs=inputs: compute_guiding(inputs)))
        return LIVE_STEP
    return None


def stop_live_preview():
    """Drop a live preview that is waiting or computing (nothing of it is drawn) and its timer."""
    if _live["job"] is not None:
        _live["job"].cancel()
    _live.update(pending=None, job=None, inputs=None)
    if bpy.app.timers.is_registered(live_preview_tick):
        bpy.app.timers.unregister(live_preview_tick)


def _redraw_sidebars():
    """The panel shows the preview's message: redraw the 3D views' sidebars once the timer changed it."""
    wm = getattr(bpy.context, "window_manager", None)
    for window in (wm.windows if wm is not None else ()):
        for area in window.screen.areas:
            if area.type == 'VIEW_3D':
                area.tag_redraw()


def preview_message():
    return _preview_state.get("message", ""), bool(_preview_state.get("error", False))


class FLANK_OT_preview_guiding(ModalPlannerMixin, bpy.types.Operator):
    """Show the guiding curves the free-form planner would use as a curve object on the active mesh (replaced on
    every run), from the Free-form G1 settings and the Tool panel's end mill"""

    bl_idname = "flank.preview_guiding"
    bl_label = "Preview Guiding Curves"
    bl_options = {'REGISTER', 'UNDO'}
    _title = "Guiding preview"

    def _prepare(self, context):
        settings = getattr(context.scene, "flank_settings", None)
        if settings is None:
            self.report({'ERROR'}, "Guiding preview: the Flank settings are not registered")
            return None
        try:
            return guiding_job(context, SettingsView(settings), freeform_tool(settings))
        except ValueError as ex:
            self.report({'ERROR'}, "Guiding preview: {}".format(ex))
        except Exception as ex:
            self.report({'ERROR'}, "Guiding preview failed: {}: {}".format(type(ex).__name__, ex))
        return None

    def _compute(self, job, progress):
        from ..flank_addon.progress import reporter

        report = reporter(progress)
        report(0.0, "guiding field and curves")
        out = compute_guiding(job)
        report(1.0, "done")
        return out

    def _build(self, context, job, result):
        if bpy.data.objects.get(job["name"]) is None:
            self.report({'ERROR'}, "Guiding preview: '{}' was removed while the curves were computed; nothing was "
                                   "changed".format(job["name"]))
            return {'CANCELLED'}
        try:
            text = show_guiding_preview(context, job, *result)
        except Exception as ex:
            self.report({'ERROR'}, "Guiding preview failed: {}: {}".format(type(ex).__name__, ex))
            return {'CANCELLED'}
        _preview_state.update(message=text, error=False)
        self.report({'INFO'}, "Guiding preview: " + text)
        return {'FINISHED'}


class FLANK_OT_clear_guiding_preview(bpy.types.Operator):
    """Remove the guiding-curve preview"""

    bl_idname = "flank.clear_guiding_preview"
    bl_label = "Clear Guiding Preview"
    bl_options = {'REGISTER', 'UNDO'}

    def execute(self, context):
        stop_live_preview()
        n = len(_preview_objects())
        remove_guiding_preview()
        settings = getattr(context.scene, "flank_settings", None)
        if settings is not None:
            settings.ff_live_preview = False
        _preview_state.update(message="", error=False)
        self.report({'INFO'}, "Removed {} guiding preview object(s)".format(n))
        return {'FINISHED'}


# ================================================================================================ direction
PICK_ITEMS = (
    ("EDGE", "Active Edge", "The active (or only selected) edge of the mesh, from its first to its second vertex"),
    ("VIEW", "View", "An axis of the 3D Viewport's view (Y = up on the screen)"),
    ("EMPTY", "Empty", "An axis of the active (or named) Empty; its location becomes Point"),
    ("CURSOR", "3D Cursor", "An axis of the 3D cursor's orientation; its location becomes Point"),
)
AXIS_ITEMS = (("X", "X", ""), ("Y", "Y", ""), ("Z", "Z", ""), ("-X", "-X", ""), ("-Y", "-Y", ""),
              ("-Z", "-Z", ""))


def axis_of(matrix3, axis):
    """World direction of a signed local axis ('X', '-Z', ...) of a 3x3 rotation (columns = local axes)."""
    sign = -1.0 if axis.startswith("-") else 1.0
    v = sign * np.asarray(matrix3, dtype=np.float64)[:, "XYZ".index(axis[-1])]
    return v / np.linalg.norm(v)


def _active_edge(obj):
    """(start, end) world points of the active edge of ``obj`` (edit mode: the selection history; else the only
    selected edge) or an error message."""
    mw = np.array(obj.matrix_world, dtype=np.float64)
    if obj.mode == 'EDIT':
        import bmesh

        bm = bmesh.from_edit_mesh(obj.data)
        act = bm.select_history.active
        if isinstance(act, bmesh.types.BMEdge):
            ends = [np.array(v.co) for v in act.verts]
        else:
            sel = [e for e in bm.edges if e.select]
            if len(sel) != 1:
                return "select one edge (or make one active) in Edit Mode; {} edges are selected".format(len(sel))
            ends = [np.array(v.co) for v in sel[0].verts]
    else:
        me = obj.data
        sel = np.zeros(len(me.edges), dtype=bool)
        me.edges.foreach_get("select", sel)
        idx = np.flatnonzero(sel)
        if len(idx) != 1:
            return "select exactly one edge of '{}' in Edit Mode ({} are selected)".format(obj.name, len(idx))
        ends = [np.array(me.vertices[i].co) for i in me.edges[int(idx[0])].vertices]
    p = [mw[:3, :3] @ e + mw[:3, 3] for e in ends]
    return p[0], p[1]


def _picked(op, context):
    """(direction, point or None) from the chosen source, or an error message."""
    if op.source == "EDGE":
        obj = context.active_object
        if obj is None or obj.type != 'MESH':
            return "the active object must be a mesh with one selected edge"
        ends = _active_edge(obj)
        if isinstance(ends, str):
            return ends
        return ends[1] - ends[0], 0.5 * (ends[0] + ends[1])
    if op.source == "VIEW":
        rv3d = getattr(context, "region_data", None)
        if rv3d is None or not hasattr(rv3d, "view_rotation"):
            return "the view direction needs a 3D Viewport (run it from the sidebar of one)"
        return axis_of(np.array(rv3d.view_rotation.to_matrix()), op.axis), None
    if op.source == "EMPTY":
        ob = bpy.data.objects.get(op.empty) if op.empty else context.active_object
        if ob is None or ob.type != 'EMPTY':
            return "{} is not an Empty".format("'{}'".format(op.empty) if op.empty else "the active object")
        mw = np.array(ob.matrix_world, dtype=np.float64)
        return axis_of(mw[:3, :3] / np.linalg.norm(mw[:3, :3], axis=0), op.axis), mw[:3, 3]
    cur = context.scene.cursor
    return axis_of(np.array(cur.matrix, dtype=np.float64)[:3, :3], op.axis), np.array(cur.location, dtype=np.float64)


class FLANK_OT_pick_guiding_direction(bpy.types.Operator):
    """Set the free-form guiding direction (and Point) from the active edge, the view, an Empty or the 3D cursor"""

    bl_idname = "flank.pick_guiding_direction"
    bl_label = "Pick Guiding Direction"
    bl_options = {'REGISTER', 'UNDO'}

    source: EnumProperty(name="From", items=PICK_ITEMS, default="EDGE")
    axis: EnumProperty(name="Axis", items=AXIS_ITEMS, default="Y",
                       description="Axis of the view, Empty or cursor (not used for an edge)")
    empty: StringProperty(name="Empty", description="Empty object; empty = the active object", default="")

    def execute(self, context):
        settings = getattr(context.scene, "flank_settings", None)
        if settings is None:
            self.report({'ERROR'}, "Pick direction: the Flank settings are not registered")
            return {'CANCELLED'}
        picked = _picked(self, context)
        if isinstance(picked, str):
            self.report({'ERROR'}, "Pick direction: " + picked)
            return {'CANCELLED'}
        d, point = picked
        n = float(np.linalg.norm(d))
        if not (np.isfinite(d).all() and n > 1e-12):
            self.report({'ERROR'}, "Pick direction: the {} gives no direction (length {:.3g})".format(
                self.source.lower(), n))
            return {'CANCELLED'}
        settings.ff_direction_mode = "VECTOR"
        settings.ff_direction = tuple(float(v) for v in d / n)
        if point is not None:
            settings.ff_point = tuple(float(v) for v in point)
            settings.ff_use_point = True
        if _preview_objects() and not settings.ff_live_preview:
            refresh_guiding_preview(context)
        self.report({'INFO'}, "Guiding direction ({:.4f}, {:.4f}, {:.4f}) from the {}".format(
            *settings.ff_direction, dict((i[0], i[1]) for i in PICK_ITEMS)[self.source].lower()))
        return {'FINISHED'}


classes = (FLANK_OT_preview_guiding, FLANK_OT_clear_guiding_preview, FLANK_OT_pick_guiding_direction)
_register_classes, _unregister_classes = bpy.utils.register_classes_factory(classes)


def register():
    _register_classes()


def unregister():
    stop_live_preview()          # a live preview still computing: its timer must not call into an unloaded module
    _unregister_classes()
