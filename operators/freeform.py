# SPDX-License-Identifier: GPL-3.0-or-later
"""s003 in Blender: flank.plan_freeform (G1 multi-strip flank milling of any triangle mesh with a conical tool),
the guiding-curve preview, guiding-direction picking and the built-in test surfaces.

The plan is made in the mesh object's local (model) coordinates, so a plan file lists the points of the model
that was loaded; the object may be moved, rotated and uniformly scaled (lengths in the sidebar are scene units,
divided by that scale for the core)."""
import bpy
from bpy.props import EnumProperty, FloatProperty, IntProperty, StringProperty

from .common import (PLAN_JSON_PROP, RunMaterial, edge_mesh, frame_along, new_mesh_from_arrays, remove_ids,
                     replace_run, results_parent, revolved_mesh, select_only, set_color_attr, set_float_attr,
                     show_attribute_colors, similarity_parts)
from .modal import ModalPlannerMixin
from .properties import freeform_props

PROP_PREFIX = "flank_ff_"
DEVIATION_ATTR = "deviation"            # FLOAT point attribute of the strips (scene units, + = material left, NaN =
DEVIATION_COLOR_ATTR = "error_color"    # nothing to machine there); FLOAT_COLOR (verify.deviation_colors)
KINK_ATTR = "kink_deg"                  # FLOAT point and edge attribute of the boundary curves (degrees)
PREVIEW_NAME = "Flank Guiding Preview"
PREVIEW_PROP = "flank_guiding_preview"
TOOL_SEGMENTS = 48
COLOR_TOOL = (0.90, 0.72, 0.20, 1.0)
COLOR_GUIDING = (0.20, 0.75, 0.95, 1.0)
COLOR_BOUNDARY = (0.95, 0.35, 0.85, 1.0)
MAX_VERTICES = 2_000_000
MAX_WEIGHT = 1.0e6                      # the objective's weights (only their ratios matter; the panel offers 0..100)

_preview_state = {"message": ""}        # the live preview's last outcome (shown in the panel)


def _decimal(v):
    """Blender float properties are single precision: the decimal value that was typed (7 digits)."""
    return float("{:.7g}".format(v))


# ================================================================================================ inputs
def _source_object(context):
    """The mesh to plan on: the active object, or the surface a free-form result object was made from."""
    obj = context.active_object
    if obj is not None and obj.get(PROP_PREFIX + "role") is not None:
        other = bpy.data.objects.get(str(obj.get(PROP_PREFIX + "source", "")))
        if other is not None:
            obj = other
    return obj


def surface_source(context, np, selected_only=False, field_attribute=""):
    """The active mesh object's triangles in its local coordinates -> dict(obj, V (n, 3), F (m, 3), to_world (4, 4)
    similarity, scale, field (n or m, 3) or None), or an error message (str)."""
    obj = _source_object(context)
    if obj is None or obj.type != 'MESH':
        return "select a mesh object: the surface to machine (active object: {})".format(
            "none" if obj is None else "'{}' ({})".format(obj.name, obj.type))
    if obj.get(PREVIEW_PROP) is not None:
        return "'{}' is the guiding-curve preview, not a surface".format(obj.name)
    if obj.mode == 'EDIT':
        obj.update_from_editmode()
    parts = similarity_parts(np, obj.matrix_world)
    if isinstance(parts, str):
        return "'{}': {}; apply its scale first".format(obj.name, parts)
    to_world, scale = parts
    mesh = obj.data
    n = len(mesh.vertices)
    if n == 0 or len(mesh.polygons) == 0:
        return "'{}' has no faces".format(obj.name)
    if n > MAX_VERTICES:
        return "'{}' has {} vertices, above the limit {}".format(obj.name, n, MAX_VERTICES)
    co = np.empty(3 * n, dtype=np.float64)
    mesh.vertices.foreach_get("co", co)
    co = co.reshape(n, 3)
    if not np.isfinite(co).all():
        return "'{}' has vertices that are not finite numbers (NaN or infinity)".format(obj.name)
    mesh.calc_loop_triangles()
    m = len(mesh.loop_triangles)
    tris = np.empty(3 * m, dtype=np.int64)
    mesh.loop_triangles.foreach_get("vertices", tris)
    tris = tris.reshape(m, 3)
    poly = np.empty(m, dtype=np.int64)
    mesh.loop_triangles.foreach_get("polygon_index", poly)
    keep = np.ones(m, dtype=bool)
    if selected_only:
        sel = np.zeros(len(mesh.polygons), dtype=bool)
        mesh.polygons.foreach_get("select", sel)
        keep = sel[poly]
        if not keep.any():
            return "'{}' has no selected faces (Selected Faces Only is on)".format(obj.name)
    tris, poly = tris[keep], poly[keep]
    used, F = np.unique(tris, return_inverse=True)
    F = F.reshape(-1, 3)
    field = None
    if field_attribute:
        attr = mesh.attributes.get(field_attribute)
        if attr is None:
            return "'{}' has no attribute '{}' (the guiding vector field)".format(obj.name, field_attribute)
        if attr.data_type != 'FLOAT_VECTOR' or attr.domain not in ('POINT', 'FACE'):
            return "attribute '{}' of '{}' is {} on {}: the guiding field must be FLOAT_VECTOR on POINT or FACE"\
                .format(field_attribute, obj.name, attr.data_type, attr.domain)
        vals = np.empty(3 * len(attr.data), dtype=np.float64)
        attr.data.foreach_get("vector", vals)
        vals = vals.reshape(-1, 3)
        field = vals[used] if attr.domain == 'POINT' else vals[poly]
        if not np.isfinite(field).all():
            return "attribute '{}' of '{}' holds values that are not finite numbers".format(field_attribute,
                                                                                            obj.name)
    return dict(obj=obj, V=co[used], F=F, to_world=to_world, scale=scale, field=field)


def guiding_inputs(np, props, src):
    """Direction, point and field of the core's guiding_curves / plan_freeform in the object's local frame, from
    properties in world axes -> dict or an error message (str)."""
    A = src["to_world"][:3, :3]
    t = src["to_world"][:3, 3]
    if props.direction_mode == "FIELD":
        if src["field"] is None:
            return "Guide By = Vector Attribute needs the attribute's name"
        direction = None
    else:
        d = np.array([_decimal(v) for v in props.direction], dtype=np.float64)
        if not np.isfinite(d).all() or not np.linalg.norm(d) > 1e-12:
            return "guiding direction {} must be a finite non-zero vector".format(d.tolist())
        direction = A.T @ d                    # A = s R: A^T d is R^T d up to the factor s
        direction /= np.linalg.norm(direction)
    point = None
    if props.use_point:
        p = np.array([_decimal(v) for v in props.point], dtype=np.float64)
        if not np.isfinite(p).all():
            return "point {} is not finite".format(p.tolist())
        point = np.linalg.solve(A, p - t)
    return dict(direction=direction, point=point,
                field_vectors=src["field"] if props.direction_mode == "FIELD" else None)


def check_tool(math, props):
    """Tool, spacing and engagement checks -> error message or None (values in scene units)."""
    r1, r2, L = _decimal(props.r1), _decimal(props.r2), _decimal(props.length)
    for label, v in (("tip sphere radius r1", r1), ("base sphere radius r2", r2)):
        if not math.isfinite(v) or v < 0.0:
            return "{} = {} must be a finite number >= 0".format(label, v)
    if not math.isfinite(L) or not L > abs(r2 - r1):
        return "axis length L = {} must exceed |r2 - r1| = {:.7g}".format(L, abs(r2 - r1))
    if not max(r1, r2) > 0.0:
        return "tip sphere radius r1 = 0 and base sphere radius r2 = 0: the tool needs a radius > 0"
    for label, v in (("shank radius", props.shank_radius), ("shank length", props.shank_length),
                     ("strip spacing", props.spacing)):
        v = _decimal(v)
        if not math.isfinite(v) or v < 0.0:
            return "{} = {} must be a finite number >= 0".format(label, v)
    e = _decimal(props.engagement)
    if not (math.isfinite(e) and 0.05 <= e <= 1.0):
        return "engagement = {} is outside the limits 0.05 .. 1".format(e)
    return None


def size_check(np, props, src):
    """Lengths beyond 10 x the surface's size mean a tool or spacing that cannot make a strip."""
    V = src["V"]
    diag = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) * src["scale"]
    if not diag > 0.0:
        return "the surface has no extent"
    for label, v in (("tip sphere radius r1", props.r1), ("base sphere radius r2", props.r2),
                     ("axis length L", props.length), ("strip spacing", props.spacing),
                     ("shank radius", props.shank_radius), ("shank length", props.shank_length)):
        if not _decimal(v) <= 10.0 * diag:
            return "{} = {:g} exceeds the limit 10 x the surface's diagonal = {:.6g} (scene units)".format(
                label, _decimal(v), 10.0 * diag)
    return None


def quad_triangles(np, quads, valid_vertices):
    """Triangles (two per quad) of the quads whose four corners are valid."""
    q = np.asarray(quads, dtype=np.int64)
    q = q[valid_vertices[q].all(axis=1)]
    return np.vstack([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])


# ================================================================================================ preview
def _preview_objects():
    return [ob for ob in bpy.data.objects if ob.get(PREVIEW_PROP) is not None]


def remove_guiding_preview():
    for ob in _preview_objects():
        cu = ob.data
        bpy.data.objects.remove(ob)
        if cu is not None and cu.users == 0:
            bpy.data.curves.remove(cu)


def build_guiding_preview(context, props, run_tool):
    """Compute the guiding curves for ``props`` (scene settings or an operator) on the active mesh and show them
    as the curve object PREVIEW_NAME (replacing the earlier one) -> message (str) of what was drawn; raises
    ValueError with a clear message on bad input."""
    import math

    import numpy as np
    from mathutils import Matrix

    from ..flank_addon.methods.freeform_g1.planner import engaged_cone
    from ..flank_addon.methods.freeform_g1.guiding import guiding_curves

    import types

    run_tool = types.SimpleNamespace(**vars(run_tool), spacing=props.spacing, engagement=props.engagement)
    msg = check_tool(math, run_tool)
    if msg is not None:
        raise ValueError(msg)
    src = surface_source(context, np, bool(props.selected_only),
                         str(props.field_attribute) if props.direction_mode == "FIELD" else "")
    if isinstance(src, str):
        raise ValueError(src)
    msg = size_check(np, run_tool, src)
    if msg is not None:
        raise ValueError(msg)
    gi = guiding_inputs(np, props, src)
    if isinstance(gi, str):
        raise ValueError(gi)
    s = src["scale"]
    r1e, r2e, Le = engaged_cone(_decimal(run_tool.r1) / s, _decimal(run_tool.r2) / s, _decimal(run_tool.length) / s,
                                _decimal(props.engagement))
    spacing = _decimal(props.spacing) / s if _decimal(props.spacing) > 0.0 else None
    F = src["F"][:, ::-1] if props.flip_normals else src["F"]
    gc = guiding_curves(src["V"], F, r1=r1e, r2=r2e, L=Le, spacing=spacing, **gi)
    polylines = [pl.points for c in gc.curves for pl in c.polylines if len(pl.points) >= 2]
    if not polylines:
        raise ValueError("no guiding curve at spacing d = {:.6g} on '{}' (a smaller tool or spacing)".format(
            gc.spacing * s, src["obj"].name))
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
    ob[PREVIEW_PROP] = src["obj"].name
    ob[PREVIEW_PROP + "_spacing"] = float(gc.spacing * s)
    ob[PREVIEW_PROP + "_curves"] = len(gc.curves)
    ob.matrix_world = Matrix(src["to_world"].tolist())
    ob.color = COLOR_GUIDING
    return "{} guiding curves ({} polylines) {} apart on '{}'".format(
        len(gc.curves), len(polylines), _length(context, gc.spacing * s), src["obj"].name)


def _length(context, v):
    from .ui_ops import length_text

    return length_text(v, context.scene)


def refresh_guiding_preview(context):
    """The live preview: redraw from the scene settings; errors are kept for the panel, never raised."""
    settings = getattr(context.scene, "flank_settings", None)
    if settings is None:
        return
    from .ui_ops import freeform_tool

    try:
        _preview_state["message"] = build_guiding_preview(context, _SettingsView(settings), freeform_tool(settings))
        _preview_state["error"] = False
    except Exception as ex:                  # shown in the panel; a property update must not raise
        _preview_state["message"] = str(ex) if isinstance(ex, ValueError) else "{}: {}".format(type(ex).__name__, ex)
        _preview_state["error"] = True


class _SettingsView:
    """The scene settings' ff_* values under the operator's property names."""

    def __init__(self, settings):
        object.__setattr__(self, "_s", settings)

    def __getattr__(self, name):
        return getattr(self._s, "ff_" + name)


def preview_message():
    return _preview_state.get("message", ""), bool(_preview_state.get("error", False))


class FLANK_OT_preview_guiding(bpy.types.Operator):
    """Show the guiding curves (s003 Sec. 5) that the free-form planner would use, as a curve object on the active
    mesh (replaced on every run).  Uses the Free-form settings and the Tool panel's end mill"""

    bl_idname = "flank.preview_guiding"
    bl_label = "Preview Guiding Curves"
    bl_options = {'REGISTER', 'UNDO'}

    def execute(self, context):
        settings = getattr(context.scene, "flank_settings", None)
        if settings is None:
            self.report({'ERROR'}, "Guiding preview: the Flank settings are not registered")
            return {'CANCELLED'}
        from .ui_ops import freeform_tool

        try:
            text = build_guiding_preview(context, _SettingsView(settings), freeform_tool(settings))
        except ValueError as ex:
            self.report({'ERROR'}, "Guiding preview: {}".format(ex))
            return {'CANCELLED'}
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


def axis_of(np, matrix3, axis):
    """World direction of a signed local axis ('X', '-Z', ...) of a 3x3 rotation (columns = local axes)."""
    sign = -1.0 if axis.startswith("-") else 1.0
    col = "XYZ".index(axis[-1])
    v = sign * np.asarray(matrix3, dtype=np.float64)[:, col]
    return v / np.linalg.norm(v)


def _active_edge(np, obj):
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
        import numpy as np

        settings = getattr(context.scene, "flank_settings", None)
        if settings is None:
            self.report({'ERROR'}, "Pick direction: the Flank settings are not registered")
            return {'CANCELLED'}
        point = None
        if self.source == "EDGE":
            obj = context.active_object
            if obj is None or obj.type != 'MESH':
                self.report({'ERROR'}, "Pick direction: the active object must be a mesh with one selected edge")
                return {'CANCELLED'}
            ends = _active_edge(np, obj)
            if isinstance(ends, str):
                self.report({'ERROR'}, "Pick direction: " + ends)
                return {'CANCELLED'}
            d = ends[1] - ends[0]
            point = 0.5 * (ends[0] + ends[1])
        elif self.source == "VIEW":
            rv3d = getattr(context, "region_data", None)
            if rv3d is None or not hasattr(rv3d, "view_rotation"):
                self.report({'ERROR'}, "Pick direction: the view direction needs a 3D Viewport (run it from the "
                                       "sidebar of one)")
                return {'CANCELLED'}
            d = axis_of(np, np.array(rv3d.view_rotation.to_matrix()), self.axis)
        elif self.source == "EMPTY":
            ob = bpy.data.objects.get(self.empty) if self.empty else context.active_object
            if ob is None or ob.type != 'EMPTY':
                self.report({'ERROR'}, "Pick direction: {} is not an Empty".format(
                    "'{}'".format(self.empty) if self.empty else "the active object"))
                return {'CANCELLED'}
            mw = np.array(ob.matrix_world, dtype=np.float64)
            d = axis_of(np, mw[:3, :3] / np.linalg.norm(mw[:3, :3], axis=0), self.axis)
            point = mw[:3, 3]
        else:
            cur = context.scene.cursor
            d = axis_of(np, np.array(cur.matrix, dtype=np.float64)[:3, :3], self.axis)
            point = np.array(cur.location, dtype=np.float64)
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


# ================================================================================================ test surfaces
SURFACE_ITEMS = (
    ("cylinder", "Cylinder Patch", "Developable: a cylindrical tool along the rulings machines it exactly"),
    ("parabolic_blade", "Parabolic Blade", "Parabolic cylinder, close to a blisk blade (s003 Fig. 19)"),
    ("gear_flank", "Gear Flank", "Involute helicoid: the flank of a helical gear"),
    ("bump", "Bump", "Gaussian bump: elliptic top, hyperbolic rim (s003 Figs. 15-17)"),
    ("saddle", "Saddle", "Hyperbolic paraboloid"),
    ("plane", "Plane", "Flat square"),
)


class FLANK_OT_add_test_surface(bpy.types.Operator):
    """Add one of the built-in free-form test surfaces (the ones the tests and README use) at the 3D cursor"""

    bl_idname = "flank.add_test_surface"
    bl_label = "Add Test Surface"
    bl_options = {'REGISTER', 'UNDO'}

    kind: EnumProperty(name="Surface", items=SURFACE_ITEMS, default="parabolic_blade")
    size: FloatProperty(name="Size", description="Longer side of the patch (scene units)", default=1.0,
                        soft_min=0.001, soft_max=1000.0, unit='LENGTH')
    resolution: IntProperty(name="Resolution", description="Grid cells along the longer side (2..400)", default=40,
                            soft_min=2, soft_max=400)

    def execute(self, context):
        import math

        import numpy as np
        from mathutils import Matrix

        from ..flank_addon.geometry.freeform_surfaces import make_surface

        size = _decimal(self.size)
        if not (math.isfinite(size) and 1e-6 <= size <= 1e6):
            self.report({'ERROR'}, "Test surface: size = {} is outside the limits 1e-06 .. 1e+06".format(size))
            return {'CANCELLED'}
        if not 2 <= int(self.resolution) <= 400:
            self.report({'ERROR'}, "Test surface: resolution = {} is outside the limits 2 .. 400".format(
                int(self.resolution)))
            return {'CANCELLED'}
        try:
            surf = make_surface(self.kind, size=size, resolution=int(self.resolution))
            name = dict((i[0], i[1]) for i in SURFACE_ITEMS)[self.kind]
            me = new_mesh_from_arrays(bpy, np, name, surf.vertices, surf.faces)
        except ValueError as ex:
            self.report({'ERROR'}, "Test surface: {}".format(ex))
            return {'CANCELLED'}
        ob = bpy.data.objects.new(name, me)
        try:
            context.collection.objects.link(ob)
        except Exception as ex:
            remove_ids(bpy, [ob], [me])
            self.report({'ERROR'}, "Test surface: {}".format(ex))
            return {'CANCELLED'}
        ob.matrix_world = Matrix.Translation(context.scene.cursor.location)
        ob["flank_test_surface"] = self.kind
        select_only(context, ob)
        self.report({'INFO'}, "Added '{}': {} vertices, {} triangles".format(ob.name, len(surf.vertices),
                                                                           len(surf.faces)))
        return {'FINISHED'}


class FLANK_MT_test_surfaces(bpy.types.Menu):
    """Built-in free-form test surfaces"""

    bl_idname = "FLANK_MT_test_surfaces"
    bl_label = "Add Test Surface"

    def draw(self, context):
        for kind, label, _ in SURFACE_ITEMS:
            self.layout.operator("flank.add_test_surface", text=label).kind = kind


# ================================================================================================ planner
class FLANK_OT_plan_freeform(ModalPlannerMixin, bpy.types.Operator):
    """s003: plan G1-continuous multi-strip flank milling of the active mesh (or its selected faces) with a conical
    tool along a guiding direction, and show the result.

    Tool: spheres of radius r1 .. r2 with centres L apart (scene units); guiding direction in world axes at Point,
    or a vector attribute.  Objects in a new collection under "Flank Results" (an earlier run on the same object
    is replaced): per strip its envelope with the point attributes ``deviation`` (FLOAT, signed exact distance to
    the mesh in scene units, > 0 material left, NaN where the tool hangs over the surface's border) and
    ``error_color`` (shown by the shared material "Flank Attribute Colour"), and the tool at its first ruling;
    per shared boundary a polyline with the ``kink_deg`` point and edge attributes (angle between the
    neighbouring strips' normals); the guiding curves.  The plan (flank-plan/1, surface kind "mesh", model
    coordinates) is stored on the collection."""

    bl_idname = "flank.plan_freeform"
    bl_label = "Plan Free-form (G1)"
    bl_options = {'REGISTER', 'UNDO'}
    _title = "Free-form"

    __annotations__ = freeform_props()

    def _check_inputs(self, math):
        msg = check_tool(math, self)
        if msg is not None:
            return msg
        for label, v in (("w1 (rigidity)", self.w_rigid), ("w2 (approximation)", self.w_approx),
                         ("w3 (G1)", self.w_g1), ("w4 (proximity)", self.w_proximity), ("w5 (fairness)", self.w_fair)):
            v = _decimal(v)
            if not math.isfinite(v) or v < 0.0:
                return "weight {} = {} must be a finite number >= 0".format(label, v)
            if v > MAX_WEIGHT:      # infinity typed is FLT_MAX: the optimiser would crawl for minutes
                return "weight {} = {:g} exceeds the limit {:g}".format(label, v, MAX_WEIGHT)
        tol = _decimal(self.tolerance)
        if not math.isfinite(tol) or tol <= 0.0:
            return "tolerance = {} must be > 0 (scene units)".format(tol)
        from .common import count_limit_error

        return (count_limit_error("samples per ruling", self.samples, 2, 200)
                or count_limit_error("rulings per strip", self.columns, 2, 2000)
                or count_limit_error("max evaluations", self.max_evaluations, 1, 10000)
                or count_limit_error("envelope samples", self.envelope_samples, 2, 200))

    def _prepare(self, context):
        import math
        import time

        import numpy as np

        t0 = time.perf_counter()
        msg = self._check_inputs(math)
        if msg is not None:
            self.report({'ERROR'}, "Free-form: " + msg)
            return None
        src = surface_source(context, np, bool(self.selected_only),
                             str(self.field_attribute) if self.direction_mode == "FIELD" else "")
        if isinstance(src, str):
            self.report({'ERROR'}, "Free-form: " + src)
            return None
        msg = size_check(np, self, src)
        if msg is not None:
            self.report({'ERROR'}, "Free-form: " + msg)
            return None
        V = src["V"]
        half_diag = 0.5 * float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) * src["scale"]
        if not _decimal(self.tolerance) < half_diag:
            self.report({'ERROR'}, "Free-form: tolerance = {:g} must be below half the surface's diagonal, {:.6g} "
                                   "(scene units)".format(_decimal(self.tolerance), half_diag))
            return None
        gi = guiding_inputs(np, self, src)
        if isinstance(gi, str):
            self.report({'ERROR'}, "Free-form: " + gi)
            return None
        s = src["scale"]
        spacing = _decimal(self.spacing)
        core = dict(r1=_decimal(self.r1) / s, r2=_decimal(self.r2) / s, L=_decimal(self.length) / s,
                    spacing=spacing / s if spacing > 0.0 else None,
                    weights=[_decimal(v) for v in (self.w_rigid, self.w_approx, self.w_g1, self.w_proximity,
                                                   self.w_fair)],
                    n_ruling_samples=int(self.samples), n_columns=int(self.columns),
                    engagement=_decimal(self.engagement), optimize_tool=tuple(sorted(self.optimize_tool)),
                    max_nfev=int(self.max_evaluations),
                    shank_radius=_decimal(self.shank_radius) / s if _decimal(self.shank_radius) > 0.0 else None,
                    shank_length=_decimal(self.shank_length) / s, slide=bool(self.slide),
                    flip_normals=bool(self.flip_normals), length_unit="mm", **gi)
        return dict(t0=t0, obj_name=src["obj"].name, V=src["V"], F=src["F"], to_world=src["to_world"], s=s,
                    core=core, tol_in=_decimal(self.tolerance), n_s=int(self.envelope_samples))

    @staticmethod
    def _compute(job, progress):
        """The planner, envelopes, kinks and tool meshes (numpy only: the worker thread when invoked)."""
        import numpy as np

        from ..flank_addon.methods.freeform_g1 import planner as g1
        from ..flank_addon.progress import reporter, substage
        from ..flank_addon.tooling.meridian import sphere_cone_outline

        report = reporter(progress)
        plan = g1.plan_freeform(job["V"], job["F"], progress=substage(report, 0.0, 0.9), **job["core"])
        report(0.9, "envelopes")
        mesh = g1.plan_mesh(plan)
        envs = g1.freeform_envelopes(plan, n_s=job["n_s"], mesh=mesh)
        report(0.96, "kink angles")
        kinks = g1.freeform_kinks(plan, mesh=mesh)
        tool = plan["tool"]
        tools = []
        for st in plan["strips"]:
            a, b = g1.strip_rulings(st)
            r1e, r2e = float(st["radii"][0]), float(st["radii"][-1])
            Le = float(np.linalg.norm(b[0] - a[0]))
            below = max(float(tool["length"]) - Le, 0.0)
            rh = sphere_cone_outline(r1e, r2e, Le, below, float(tool["shank_radius"]), float(tool["shank_length"]))
            rot, _ = frame_along(np, a[0], b[0])
            T = np.eye(4)
            T[:3, :3] = rot
            T[:3, 3] = a[0]
            tools.append((revolved_mesh(np, rh, TOOL_SEGMENTS), T))
        report(1.0, "done")
        return dict(plan=plan, envs=envs, kinks=kinks, tools=tools)

    def _build(self, context, job, out):
        import json
        import os
        import time

        import numpy as np
        from mathutils import Matrix

        from ..flank_addon.simulation.verify import deviation_colors

        src_obj = bpy.data.objects.get(job["obj_name"])
        if src_obj is None:
            self.report({'ERROR'}, "Free-form: the surface '{}' was removed while planning".format(job["obj_name"]))
            return {'CANCELLED'}
        plan, envs, kinks, tools = out["plan"], out["envs"], out["kinks"], out["tools"]
        s, tol_in, to_world = job["s"], job["tol_in"], Matrix(job["to_world"].tolist())
        summary = plan["summary"]
        base_name = "Free-form ({})".format(src_obj.name)
        key = src_obj.name
        objects, meshes, colls, files, names = [], [], [], [], []
        parent, parent_created = None, False
        run_mat = RunMaterial(bpy)
        try:
            parent, parent_created = results_parent(bpy, context)
            coll = bpy.data.collections.new(base_name + " new")
            colls.append(coll)
            parent.children.link(coll)

            def add(obj_name, data, color, role, k=None):
                meshes.append(data)
                names.append((data, obj_name))
                ob = bpy.data.objects.new(obj_name, data)
                objects.append(ob)
                names.append((ob, obj_name))
                ob.color = color
                coll.objects.link(ob)
                ob[PROP_PREFIX + "source"] = src_obj.name
                ob[PROP_PREFIX + "role"] = role
                if k is not None:
                    ob[PROP_PREFIX + "strip"] = int(k)
                return ob

            first_tool = None
            for k, (env, ((tv, tf), T), st) in enumerate(zip(envs, tools, plan["strips"])):
                label = "FF Tool {}".format(k + 1)
                ob = add(label, new_mesh_from_arrays(bpy, np, label, tv, tf), COLOR_TOOL, "tool", k)
                ob.matrix_world = to_world @ Matrix(T.tolist())
                ob[PROP_PREFIX + "strip_errors"] = [float(st["reported_max_error"]) * s,
                                                    float(st["reported_min_error"]) * s]
                ob[PROP_PREFIX + "collision"] = bool(st["collision"])
                first_tool = first_tool or ob
                V = np.asarray(env["vertices"], dtype=np.float64)
                ok = np.isfinite(V).all(axis=1)
                tris = quad_triangles(np, env["faces"], ok)
                if len(tris) == 0:
                    continue
                used, inv = np.unique(tris, return_inverse=True)
                label = "FF Strip {}".format(k + 1)
                me = new_mesh_from_arrays(bpy, np, label, V[used], inv.reshape(-1, 3))
                eo = add(label, me, (0.55, 0.62, 0.70, 1.0), "envelope", k)
                eo.matrix_world = to_world
                dev = np.asarray(env["deviation"], dtype=np.float64)[used] * s
                set_float_attr(np, me, DEVIATION_ATTR, dev)
                set_color_attr(np, me, DEVIATION_COLOR_ATTR, deviation_colors(dev, tol_in))
                run_mat.assign(me)
                me.update()
                fin = dev[np.isfinite(dev)]
                eo[PROP_PREFIX + "deviation_range"] = [float(fin.min()), float(fin.max())] if len(fin) else []
                eo[PROP_PREFIX + "overhanging_points"] = int(len(dev) - len(fin))
            for k, kk in enumerate(kinks):
                pts = np.asarray(kk["points"], dtype=np.float64)
                if len(pts) < 2:
                    continue
                label = "FF Boundary {}|{}".format(k + 1, k + 2)
                me = edge_mesh(bpy, np, label, [(pts, False)])
                bo = add(label, me, COLOR_BOUNDARY, "boundary", k)
                bo.matrix_world = to_world
                kd = np.asarray(kk["kink_deg"], dtype=np.float64)
                set_float_attr(np, me, KINK_ATTR, kd)
                set_float_attr(np, me, KINK_ATTR + "_edge", np.maximum(kd[:-1], kd[1:]), domain='EDGE')
                bo[PROP_PREFIX + "max_kink_deg"] = float(kd.max())
                bo[PROP_PREFIX + "mean_kink_deg"] = float(kd.mean())
            chains = [(np.asarray(pl, dtype=np.float64), False) for c in plan["guiding"]["curves"] for pl in c
                      if len(pl) >= 2]
            if chains:
                me = edge_mesh(bpy, np, "FF Guiding Curves", chains)
                go = add("FF Guiding Curves", me, COLOR_GUIDING, "guiding")
                go.matrix_world = to_world

            if self.filepath:
                from ..flank_addon.io.plan import write_plan

                path = bpy.path.abspath(self.filepath)
                files.append(path)
                write_plan(path, plan)

            replace_run(bpy, parent, coll, PROP_PREFIX + "key", key, base_name, names)
            c = coll
            c[PROP_PREFIX + "source"] = src_obj.name
            c[PROP_PREFIX + "strips"] = len(plan["strips"])
            c[PROP_PREFIX + "max_error"] = float(summary["max_error"]) * s
            c[PROP_PREFIX + "min_error"] = float(summary["min_error"]) * s
            c[PROP_PREFIX + "max_kink_deg"] = float(summary["max_kink_deg"])
            c[PROP_PREFIX + "mean_kink_deg"] = float(summary["mean_kink_deg"])
            c[PROP_PREFIX + "colliding_rulings"] = int(summary["colliding_rulings"])
            c[PROP_PREFIX + "overhanging_samples"] = int(summary["overhanging_samples"])
            c[PROP_PREFIX + "tolerance"] = tol_in
            c[PROP_PREFIX + "to_world"] = [float(v) for v in job["to_world"].ravel()]   # model -> world at planning
            c[PROP_PREFIX + "length_scale"] = float(s)
            c[PROP_PREFIX + "length_unit"] = plan["length_unit"]
            c[PROP_PREFIX + "elapsed"] = float(summary["elapsed_s"])
            c[PROP_PREFIX + "total_elapsed"] = time.perf_counter() - job["t0"]
            c[PROP_PREFIX + "summary"] = json.dumps({k: v for k, v in summary.items()})
            c[PLAN_JSON_PROP] = json.dumps(plan)
        except Exception as ex:
            remove_ids(bpy, objects, meshes, colls + ([parent] if parent_created else []))
            run_mat.discard()
            for p in files:
                try:
                    os.remove(p)
                except OSError:
                    pass
            self.report({'ERROR'}, "Could not build the free-form results: {}: {}".format(type(ex).__name__, ex))
            return {'CANCELLED'}
        if first_tool is not None:
            try:
                select_only(context, first_tool)
            except RuntimeError:             # the results collection is excluded from the view layer
                pass
        show_attribute_colors(bpy, context)
        from .ui_ops import length_text

        def L(v):
            return length_text(v, context.scene, signed=True)
        self.report({'INFO'}, "Free-form on '{}': {} strips, error {} .. {}, kink max {:.3g} deg (mean {:.3g}), "
                              "{} colliding rulings, {:.1f} s".format(
                                  src_obj.name, len(plan["strips"]), L(summary["min_error"] * s),
                                  L(summary["max_error"] * s), summary["max_kink_deg"], summary["mean_kink_deg"],
                                  summary["colliding_rulings"], summary["elapsed_s"]))
        return {'FINISHED'}


classes = (FLANK_OT_plan_freeform, FLANK_OT_preview_guiding, FLANK_OT_clear_guiding_preview,
           FLANK_OT_pick_guiding_direction, FLANK_OT_add_test_surface, FLANK_MT_test_surfaces)
