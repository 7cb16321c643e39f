# SPDX-License-Identifier: GPL-3.0-or-later
"""Sidebar helpers: the flank list of the workpiece and flank picking (3D cursor, selected faces), the tool
preview, tool presets (Blender's preset system), the strips list of a run with its rows' numbers, and the Run
button's call of the chosen strategy's planner."""
import os

import bpy
from bl_operators.presets import AddPresetBase
from bpy.props import FloatProperty, IntProperty, StringProperty

from .common import PLAN_JSON_PROP
from .properties import (CYLINDER_TAPER, double_flank_props, formed_cutter_props, freeform_props,
                         mm_per_scene_unit, paraboloid_props, single_flank_props)

PRESET_SUBDIR = "flank_tool"
SHIPPED_PRESETS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "presets", PRESET_SUBDIR)
# what a preset holds: kind, shape and the dimensions in mm (converted to scene units when set)
PRESET_VALUES = ("tool_kind", "sf_shape", "tool_taper_deg", "tool_tip_diameter_mm", "tool_flute_length_mm",
                 "tool_shank_diameter_mm", "tool_shank_length_mm")
RESULT_ROTOR_KEYS = ("flank_sf_rotor", "flank_df_rotor", "flank_cr_rotor", "flank_cutter_rotor", "flank_ff_source")
PREVIEW_PROP = "flank_tool_preview"
PREVIEW_NAME = "Flank Tool Preview"
PREVIEW_SEGMENTS = 48

__all__ = ["mm_per_scene_unit", "length_text", "run_call", "freeform_tool", "select_strip", "strip_rows",
           "workpiece_object"]


# ================================================================================================ helpers
def length_text(value, scene, unit="mm", scale=1.0, signed=False):
    """A length held in scene units, as people read it: µm below 1 mm, else mm in metric scenes; inches in
    imperial ones; in a unit-less scene the run's own unit (``value / scale`` in ``unit``, 'mm' or 'R') --
    the conventions of the report picture (flank_addon.report.report_geometry.display_units)."""
    import math

    try:
        v = float(value)
    except (TypeError, ValueError):
        return "n/a"
    if not math.isfinite(v):
        return "n/a"
    us = scene.unit_settings
    sl = float(us.scale_length) if us.scale_length > 0.0 else 1.0
    if us.system == 'METRIC':
        x, u = v * 1000.0 * sl, "mm"
    elif us.system == 'IMPERIAL':
        x, u = v * sl / 0.0254, "in"
    else:
        x, u = v / (scale or 1.0), unit or "mm"
    fmt = "{:+.3g} {}" if signed else "{:.3g} {}"
    if u == "mm" and abs(x) < 1.0:
        x, u = 1000.0 * x, "µm"
    elif u == "mm" and abs(x) >= 1000.0 and us.system == 'METRIC':
        x, u = 0.001 * x, "m"
    return fmt.format(x, u).replace("+0 ", "0 ")


def workpiece_object(context):
    """The rotor the sidebar works on: the active object, or the rotor a result object was made from."""
    obj = context.active_object
    if obj is None:
        return None
    if obj.get("flank_source") is None:
        for key in RESULT_ROTOR_KEYS:
            other = bpy.data.objects.get(str(obj.get(key, ""))) if key in obj else None
            if other is not None:
                return other
    return obj


class _AsObjectMode:
    """An object seen as if in Object Mode (its mesh was synced with update_from_editmode): lets the edit-mode
    face pick use common.rotor_source, which refuses edit-mode objects."""
    mode = 'OBJECT'

    def __init__(self, obj):
        object.__setattr__(self, "_obj", obj)

    def __getattr__(self, name):
        return getattr(self._obj, name)

    def __getitem__(self, key):
        return self._obj[key]

    def __contains__(self, key):
        return key in self._obj

    def get(self, key, default=None):
        return self._obj.get(key, default)


def _rotor(context, np, obj, edit=False):
    """common.rotor_source for ``obj`` (dict or an error message)."""
    import types

    from .common import rotor_source

    if obj is None:
        return "Select a rotor (made by Generate Rotor, or a mesh after Analyze Rotor)"
    return rotor_source(bpy, types.SimpleNamespace(active_object=_AsObjectMode(obj) if edit else obj), np,
                        "flank_ui_")


def _to_rotor(np, display, points_world):
    """World points (N, 3) -> rotor frame (N, 3) through the rotor's display matrix (rotor frame -> world)."""
    p = np.c_[np.asarray(points_world, dtype=np.float64).reshape(-1, 3), np.ones(len(points_world))]
    q = np.linalg.solve(display, p.T).T
    return q[:, :3] / q[:, 3:4]


def _profile_distance(np, surface, p_rotor):
    """Distance (rotor units) of a rotor-frame point from the rotor surface, measured in its transverse section
    after screwing it into z = 0."""
    from ..flank_addon.geometry.screw import screw_to_plane

    q0 = screw_to_plane(np.asarray(p_rotor, float).reshape(1, 3), surface.v0, surface.hand)[0]
    prof = surface.profile
    return float(np.min(np.linalg.norm(prof.eval(prof.params(8192)) - q0[:2], axis=1)))


# ================================================================================================ flank list
class FLANK_UL_flanks(bpy.types.UIList):
    """Flanks of the workpiece: index, valley and the hyperbolic share of its profile (s000 Sec. 4.1)."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0, flt_flag=0):
        row = layout.row(align=True)
        row.label(text="Flank {}".format(item.flank), icon='MOD_SCREW')
        row.label(text="valley {}".format(item.valley))
        row.label(text="hyperbolic {:.0f} %".format(100.0 * item.hyperbolic_fraction))


class FLANK_OT_refresh_flanks(bpy.types.Operator):
    """Fill the flank list of the active rotor: every flank with its valley and the hyperbolic share of its
    profile (Dupin analysis, s000 Sec. 4.1)"""

    bl_idname = "flank.refresh_flanks"
    bl_label = "Refresh Flank List"
    bl_options = {'REGISTER', 'UNDO'}

    samples: IntProperty(name="Samples", description="Profile samples per flank of the Dupin analysis (8 .. 5000)",
                         default=200, soft_min=8, soft_max=5000)

    def execute(self, context):
        import numpy as np

        from ..flank_addon.tooling.cutter_selection import flank_dupin
        from .common import count_limit_error

        settings = getattr(context.scene, "flank_settings", None)
        if settings is None:
            self.report({'ERROR'}, "Flank list: the Flank settings are not registered")
            return {'CANCELLED'}
        msg = count_limit_error("samples", self.samples, 8, 5000)
        if msg is not None:
            self.report({'ERROR'}, "Flank list: " + msg)
            return {'CANCELLED'}
        src = _rotor(context, np, workpiece_object(context))
        if isinstance(src, str):
            self.report({'ERROR'}, "Flank list: " + src)
            return {'CANCELLED'}
        surface, flanks, s = src["surface"], src["flanks"], float(src["scale"])
        rows = []
        try:
            for k in range(len(flanks)):
                d = flank_dupin(surface, flanks, k, n=int(self.samples))
                a_min = d.a_min
                rows.append((k, tuple(float(v) for v in flanks[k]), float(d.hyperbolic_fraction),
                             float(a_min) * s if np.isfinite(a_min) else 0.0))
        except Exception as ex:
            self.report({'ERROR'}, "Flank list: Dupin analysis failed: {}: {}".format(type(ex).__name__, ex))
            return {'CANCELLED'}
        settings.flank_list.clear()
        for k, (u0, u1), frac, a_min in rows:
            item = settings.flank_list.add()
            item.name = "Flank {}".format(k)
            item.flank, item.valley, item.u_start, item.u_end = k, k // 2, u0, u1
            item.hyperbolic_fraction, item.a_min = frac, a_min
        settings.flank_list_rotor = src["obj"].name
        if not 0 <= settings.flank_index < len(rows):
            settings.flank_index = min(max(int(settings.sf_flank), 0), len(rows) - 1) if rows else -1
        self.report({'INFO'}, "Flank list of '{}': {} flanks, hyperbolic {}".format(
            src["obj"].name, len(rows), ", ".join("{:.0f} %".format(100.0 * r[2]) for r in rows)))
        return {'FINISHED'}


def _set_flank(settings, k):
    settings.flank_index = int(k)      # its update aims sf_flank and df_valley at it


class FLANK_OT_pick_flank_cursor(bpy.types.Operator):
    """Pick the flank nearest to the 3D cursor (the cursor is screwed along its helix into the rotor's
    transverse section; the flank holding the nearest profile point is taken)"""

    bl_idname = "flank.pick_flank_cursor"
    bl_label = "Flank at 3D Cursor"
    bl_options = {'REGISTER', 'UNDO'}

    def execute(self, context):
        import numpy as np

        from ..flank_addon.methods.single_flank.planner import flank_of_point

        settings = getattr(context.scene, "flank_settings", None)
        if settings is None:
            self.report({'ERROR'}, "Pick flank: the Flank settings are not registered")
            return {'CANCELLED'}
        src = _rotor(context, np, workpiece_object(context))
        if isinstance(src, str):
            self.report({'ERROR'}, "Pick flank: " + src)
            return {'CANCELLED'}
        cursor = np.array(context.scene.cursor.location, dtype=np.float64)
        if not np.isfinite(cursor).all():
            self.report({'ERROR'}, "Pick flank: the 3D cursor is not at a finite location")
            return {'CANCELLED'}
        p = _to_rotor(np, src["display"], cursor[None, :])[0]
        try:
            k = int(flank_of_point(src["surface"], src["flanks"], p))
        except ValueError as ex:
            self.report({'ERROR'}, "Pick flank: {}".format(ex))
            return {'CANCELLED'}
        _set_flank(settings, k)
        dist = _profile_distance(np, src["surface"], p) * float(src["scale"])
        R = float(src["surface"].outer_radius) * float(src["scale"])
        msg = "Flank {} (valley {}) of '{}': the 3D cursor is {} from the rotor surface".format(
            k, k // 2, src["obj"].name, length_text(dist, context.scene, src["unit"], float(src["scale"])))
        self.report({'WARNING'} if dist > 0.1 * R else {'INFO'}, msg)
        return {'FINISHED'}


class FLANK_OT_pick_flank_faces(bpy.types.Operator):
    """Pick the flank under the selected faces (Edit Mode): each selected face's centre votes for its nearest
    flank, the flank with most votes is taken"""

    bl_idname = "flank.pick_flank_faces"
    bl_label = "Flank of Selected Faces"
    bl_options = {'REGISTER', 'UNDO'}

    def execute(self, context):
        from collections import Counter

        import bmesh
        import numpy as np

        from ..flank_addon.methods.single_flank.planner import flank_of_point

        settings = getattr(context.scene, "flank_settings", None)
        if settings is None:
            self.report({'ERROR'}, "Pick flank: the Flank settings are not registered")
            return {'CANCELLED'}
        obj = context.active_object
        if obj is None or obj.type != 'MESH' or obj.mode != 'EDIT':
            self.report({'ERROR'}, "Pick flank: select faces of the rotor mesh in Edit Mode (active object: {})"
                        .format("none" if obj is None else "'{}' in {} mode".format(obj.name, obj.mode.title())))
            return {'CANCELLED'}
        bm = bmesh.from_edit_mesh(obj.data)
        centres = [tuple(f.calc_center_median()) for f in bm.faces if f.select]
        if not centres:
            self.report({'ERROR'}, "Pick flank: no face of '{}' is selected".format(obj.name))
            return {'CANCELLED'}
        if obj.get("flank_source") == "analyzed":
            obj.update_from_editmode()     # the analysis is run again on the mesh data
        src = _rotor(context, np, obj, edit=True)
        if isinstance(src, str):
            self.report({'ERROR'}, "Pick flank: " + src)
            return {'CANCELLED'}
        mw = np.array(obj.matrix_world, dtype=np.float64)
        local = np.array(centres, dtype=np.float64)
        world = local @ mw[:3, :3].T + mw[:3, 3]
        pts = _to_rotor(np, src["display"], world)
        votes = Counter()
        for p in pts:
            if not np.isfinite(p).all():
                continue
            try:
                votes[int(flank_of_point(src["surface"], src["flanks"], p))] += 1
            except ValueError:
                continue
        if not votes:
            self.report({'ERROR'}, "Pick flank: none of the {} selected faces lies near a flank".format(len(pts)))
            return {'CANCELLED'}
        k, n = votes.most_common(1)[0]
        _set_flank(settings, k)
        others = ", ".join("flank {}: {}".format(f, c) for f, c in sorted(votes.items()) if f != k)
        self.report({'INFO'}, "Flank {} (valley {}) of '{}': {} of {} selected faces{}".format(
            k, k // 2, obj.name, n, len(pts), " (" + others + ")" if others else ""))
        return {'FINISHED'}


# ================================================================================================ tool preview
def _newest(objects):
    return objects[-1] if objects else None


def _result_tool(kind):
    """The newest result object whose mesh is the tool of that kind: a double-flank tool or a formed cutter."""
    if kind == "CUSTOM":
        return _newest([ob for ob in bpy.data.objects if ob.get("flank_df_role") == "tool" and ob.type == 'MESH'
                        and ob.get("flank_df_path", 0) == 0])
    return _newest([ob for ob in bpy.data.objects if "flank_cutter_r_range" in ob and ob.type == 'MESH'
                    and ob.data is not None and len(ob.data.polygons)])


def tool_shape(settings):
    """(meridian [(radius, height)] in scene units, label) of the tool settings, or (None, message)."""
    import math

    from ..flank_addon.tooling.meridian import cone_outline

    kind = settings.tool_kind
    vals = [float(getattr(settings, n)) for n in ("sf_r1", "sf_r2", "sf_alpha", "sf_length", "sf_shank_radius",
                                                  "sf_shank_length", "groove_a", "groove_b")]
    if not all(math.isfinite(v) for v in vals):
        return None, "a tool setting is not a finite number"
    r1, r2, alpha, length, shank_r, shank_l, pa, pb = vals
    if min(shank_r, shank_l) < 0.0:
        return None, "shank radius and length must be >= 0"
    if kind == "CONE":
        if not 0.0 <= r1 < r2:
            return None, "tip radius r1 = {:g} must be >= 0 and below r2 = {:g}".format(r1, r2)
        if settings.sf_shape == "alpha":
            if not 0.0 < alpha < 0.5 * math.pi:
                return None, "opening angle {:g} deg is outside (0, 90) deg".format(math.degrees(alpha))
            h = (r2 - r1) / math.tan(alpha)
        else:
            h = length
        if not h > 0.0:
            return None, "cone length h = {:g} must be > 0".format(h)
        return cone_outline(r1, r2, 0.0, h, shank_r, shank_l).tolist(), "cone"
    if kind == "CYLINDER":
        if not (r1 > 0.0 and length > 0.0):
            return None, "cylinder radius {:g} and flute length {:g} must be > 0".format(r1, length)
        return (cone_outline(r1, r1 + length * math.tan(CYLINDER_TAPER), 0.0, length, shank_r, shank_l).tolist(),
                "cylinder")
    if kind == "PARABOLOID":
        if not (pa < 0.0 < pb):
            return None, "the paraboloid needs a < 0 < b (a = {:g}, b = {:g})".format(pa, pb)
        rho = math.sqrt(-pb / pa)
        rings = [(rho * math.sin(0.5 * math.pi * i / 24), 0.0) for i in range(1, 25)]
        top = [(r, pb + pa * r * r) for r, _ in rings]
        bottom = [(r, -(pb + pa * r * r)) for r, _ in reversed(rings[:-1])]
        return [(0.0, pb)] + top + bottom + [(0.0, -pb)], "paraboloid"
    return None, "the {} tool is made by its planner".format(kind.lower())


def _preview_objects():
    return [ob for ob in bpy.data.objects if ob.get(PREVIEW_PROP)]


def remove_preview():
    """Remove the tool preview object(s) and their meshes (no orphan data is left)."""
    for ob in _preview_objects():
        me = ob.data if ob.type == 'MESH' else None
        bpy.data.objects.remove(ob)
        if me is not None and me.users == 0:
            bpy.data.meshes.remove(me)


class FLANK_OT_preview_tool(bpy.types.Operator):
    """Show the tool of the Tool panel as a mesh beside the rotor (replaced on every run; a double-flank tool or
    a formed cutter is copied from the newest result)"""

    bl_idname = "flank.preview_tool"
    bl_label = "Preview Tool"
    bl_options = {'REGISTER', 'UNDO'}

    def execute(self, context):
        import numpy as np
        from mathutils import Matrix, Vector

        from .common import new_mesh_from_arrays, revolved_mesh

        settings = getattr(context.scene, "flank_settings", None)
        if settings is None:
            self.report({'ERROR'}, "Preview tool: the Flank settings are not registered")
            return {'CANCELLED'}
        kind = settings.tool_kind
        scale = 1.0
        if kind in ("CUSTOM", "DISC"):
            src = _result_tool(kind)
            if src is None:
                self.report({'ERROR'}, "Preview tool: no {} yet: run the {} strategy first".format(
                    "double-flank tool" if kind == "CUSTOM" else "formed disc cutter",
                    "double-flank" if kind == "CUSTOM" else "formed disc cutter"))
                return {'CANCELLED'}
            mesh = src.data.copy()
            mesh.name = PREVIEW_NAME
            scale = float(np.cbrt(abs(np.linalg.det(np.array(src.matrix_world)[:3, :3])))) or 1.0
            what = "copy of '{}'".format(src.name)
        else:
            rh, what = tool_shape(settings)
            if rh is None:
                self.report({'ERROR'}, "Preview tool: " + what)
                return {'CANCELLED'}
            size = max(max(abs(r), abs(z)) for r, z in rh)
            rotor = workpiece_object(context)
            limit = 1e6 if rotor is None or rotor.type != 'MESH' else 100.0 * max(rotor.dimensions) + 1e-9
            if size > limit:
                self.report({'ERROR'}, "Preview tool: the tool ({:g} scene units) is over 100 x the size of '{}'"
                            .format(size, rotor.name))
                return {'CANCELLED'}
            try:
                verts, faces = revolved_mesh(np, np.array(rh, dtype=np.float64), PREVIEW_SEGMENTS)
                mesh = new_mesh_from_arrays(bpy, np, PREVIEW_NAME, verts, faces)
            except ValueError as ex:
                self.report({'ERROR'}, "Preview tool: {}".format(ex))
                return {'CANCELLED'}
        # beside the rotor: +x of its bounding box, tool axis along world z from the rotor's lowest point
        co = np.empty(len(mesh.vertices) * 3)
        mesh.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3) * scale
        radius = float(np.max(np.linalg.norm(co[:, :2], axis=1))) if len(co) else 0.0
        rotor = workpiece_object(context)
        if rotor is not None and rotor.type == 'MESH' and rotor.get(PREVIEW_PROP) is None:
            box = np.array([rotor.matrix_world @ Vector(c) for c in rotor.bound_box])
            lo, hi = box.min(axis=0), box.max(axis=0)
            gap = 0.15 * float(max(hi - lo)) + radius
            loc = (hi[0] + gap, 0.5 * (lo[1] + hi[1]), lo[2] - float(co[:, 2].min()) if len(co) else lo[2])
        else:
            loc = tuple(context.scene.cursor.location)
        remove_preview()
        mesh.name = PREVIEW_NAME                # the name the replaced preview's mesh held
        ob = bpy.data.objects.new(PREVIEW_NAME, mesh)
        try:
            context.scene.collection.objects.link(ob)
        except Exception as ex:
            bpy.data.objects.remove(ob)
            bpy.data.meshes.remove(mesh)
            self.report({'ERROR'}, "Preview tool: {}".format(ex))
            return {'CANCELLED'}
        if ob.name != PREVIEW_NAME:
            ob.name = PREVIEW_NAME
        ob[PREVIEW_PROP] = kind
        ob.matrix_world = Matrix.Translation(loc) @ Matrix.Scale(scale, 4)
        ob.color = (0.90, 0.72, 0.20, 1.0)
        self.report({'INFO'}, "Tool preview ({}, {}): radius up to {} beside {}".format(
            kind.lower(), what, length_text(radius, context.scene),
            "'{}'".format(rotor.name) if rotor is not None else "the 3D cursor"))
        return {'FINISHED'}


# ================================================================================================ presets
class FLANK_OT_tool_preset(bpy.types.Operator):
    """Set the tool to a real tapered end mill given in mm (converted to scene units)"""

    bl_idname = "flank.tool_preset"
    bl_label = "Set Tool"
    bl_options = {'REGISTER', 'UNDO'}

    taper_deg: FloatProperty(name="Taper (half angle, deg)", default=3.0)
    tip_diameter_mm: FloatProperty(name="Tip Diameter (mm)", default=4.0)
    flute_length_mm: FloatProperty(name="Flute Length (mm)", default=20.0)
    shank_diameter_mm: FloatProperty(name="Shank Diameter (mm)", default=8.0)
    overall_length_mm: FloatProperty(name="Overall Length (mm)", default=65.0)

    def execute(self, context):
        import math

        s = getattr(context.scene, "flank_settings", None)
        if s is None:
            self.report({'ERROR'}, "Tool preset: the Flank settings are not registered")
            return {'CANCELLED'}
        a, d, L = float(self.taper_deg), float(self.tip_diameter_mm), float(self.flute_length_mm)
        sd, ol = float(self.shank_diameter_mm), float(self.overall_length_mm)
        for label, v, lo, hi in (("taper", a, 0.0, 45.0), ("tip diameter", d, 0.0, 1000.0),
                                 ("flute length", L, 0.0, 1000.0), ("shank diameter", sd, 0.0, 1000.0)):
            if not (math.isfinite(v) and lo < v <= hi):
                self.report({'ERROR'}, "Tool preset: {} = {:g} is outside ({:g}, {:g}]".format(label, v, lo, hi))
                return {'CANCELLED'}
        if not (math.isfinite(ol) and ol > L):
            self.report({'ERROR'}, "Tool preset: overall length {:g} mm must exceed the flute length {:g} mm".format(
                ol, L))
            return {'CANCELLED'}
        s.tool_kind = "CONE"
        s.sf_shape = "alpha"
        s.tool_taper_deg = a
        s.tool_tip_diameter_mm = d
        s.tool_flute_length_mm = L
        s.tool_shank_diameter_mm = sd
        s.tool_shank_length_mm = ol - L
        self.report({'INFO'}, "Tool: taper {:g} deg, tip D{:g}, flute {:g} mm, shank D{:g} mm (r1 = {:.4g}, "
                              "r2 = {:.4g} scene units)".format(a, d, L, sd, s.sf_r1, s.sf_r2))
        return {'FINISHED'}


class FLANK_MT_tool_presets(bpy.types.Menu):
    """Real tapered and cylindrical end mills shipped with the extension (mm), and your own saved tools"""

    bl_idname = "FLANK_MT_tool_presets"
    bl_label = "Tool Presets"
    preset_subdir = PRESET_SUBDIR
    preset_operator = "script.execute_preset"

    def draw(self, context):
        paths = [SHIPPED_PRESETS] + bpy.utils.preset_paths(PRESET_SUBDIR)
        self.path_menu([p for p in paths if os.path.isdir(p)], self.preset_operator,
                       props_default={"menu_idname": self.bl_idname}, filter_ext=lambda ext: ext.lower() == ".py")


class FLANK_OT_tool_preset_add(AddPresetBase, bpy.types.Operator):
    """Save the current tool as a preset (its dimensions in mm, so it fits any scene unit), or remove the
    last applied user preset"""

    bl_idname = "flank.tool_preset_add"
    bl_label = "Add Tool Preset"
    preset_menu = "FLANK_MT_tool_presets"
    preset_subdir = PRESET_SUBDIR
    preset_defines = ["settings = bpy.context.scene.flank_settings"]
    preset_values = ["settings." + name for name in PRESET_VALUES]


# ================================================================================================ results
_ROWS_CACHE = {}


def run_kind(coll):
    """('flank_sf_', 'strip') for a single-flank run, ('flank_df_', 'path') for a double-flank run, else None."""
    if coll is None:
        return None
    if "flank_sf_strips" in coll or "flank_sf_tolerance" in coll:
        return "flank_sf_", "strip"
    if "flank_df_paths" in coll or "flank_df_tolerance" in coll:
        return "flank_df_", "path"
    if "flank_ff_strips" in coll:
        return "flank_ff_", "strip"
    return None


def _prefix(ob):
    for pre in ("flank_sf_", "flank_df_", "flank_ff_"):
        if pre + "role" in ob:
            return pre
    return ""


def _strip_key(pre):
    return "path" if pre == "flank_df_" else "strip"


def _arc_fraction(np, plan, flank, u_range):
    """Function u -> share (0..1) of the flank's profile arc length before profile parameter u."""
    prof = np.asarray(plan["rotor"]["profile"], dtype=np.float64)
    n = len(prof)
    ia, ib = (int(v) for v in plan["rotor"]["flanks"][flank])
    idx = np.arange(ia, ib + 1)
    pts = prof[idx % n]
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))]
    a, b = (float(v) for v in u_range)

    def frac(u):
        i = ia + (float(u) - a) / (b - a) * (ib - ia)
        return float(np.interp(i, idx, s) / s[-1]) if s[-1] > 0 else 0.0
    return frac


def _sf_covered(np, coll, plan, n):
    """Per strip of a single-flank run: (start, end) share of the flank's profile arc length where it forms the
    machined flank -- from the planner's junctions (where neighbouring strips cut equally deep) and its
    uncovered ranges."""
    import json

    try:
        summary = json.loads(coll.get("flank_sf_summary", "{}"))
        a, b = (float(v) for v in coll["flank_sf_flank_range"])
        flank = int(coll["flank_sf_flank"])
        junctions = [[float(j["u"]) for j in js] for js in summary.get("junctions", [])]
        unc = [float(v) for v in coll.get("flank_sf_uncovered", [])]
        frac = _arc_fraction(np, plan, flank, (a, b))
    except (KeyError, ValueError, TypeError, IndexError):
        return [None] * n, []
    starts, ends = [a] + [min(js) if js else None for js in junctions], \
        [max(js) if js else None for js in junctions] + [b]
    gaps = list(zip(unc[0::2], unc[1::2]))
    out = []
    for k in range(n):
        s0 = starts[k] if k < len(starts) else None
        s1 = ends[k] if k < len(ends) else None
        if s0 is None or s1 is None:
            out.append(None)
            continue
        for u0, u1 in gaps:                  # an end inside an uncovered range: the strip stops where it begins
            if u0 <= s0 <= u1:
                s0 = u1
            if u0 <= s1 <= u1:
                s1 = u0
        out.append((frac(s0), frac(max(s0, s1))))
    return out, [(frac(u0), frac(u1)) for u0, u1 in zip(unc[0::2], unc[1::2])]


def strip_rows(coll):
    """The numbers of a run's strips list: {strip: dict(max, min (scene units), collision, covered (text))} plus
    the run's unit and scale, parsed once per run (the plan text does not change)."""
    import json

    import numpy as np

    kind = run_kind(coll)
    text = coll.get(PLAN_JSON_PROP) if coll is not None else None
    if kind is None or not text:
        return None
    pre, key = kind
    cache_key = (coll.name, len(text), str(coll.get(pre + "total_elapsed", "")))
    hit = _ROWS_CACHE.get(coll.name)
    if hit is not None and hit[0] == cache_key:
        return hit[1]
    try:
        plan = json.loads(text)
        strips = plan["strips"]
    except (ValueError, KeyError, TypeError):
        return None
    scale = float(coll.get(pre + "length_scale", 1.0) or 1.0)
    rows, uncovered = {}, []
    if pre == "flank_sf_":
        covered, uncovered = _sf_covered(np, coll, plan, len(strips))
        for k, st in enumerate(strips):
            c = covered[k]
            rows[k] = dict(max=float(st["reported_max_error"]) * scale, min=float(st["reported_min_error"]) * scale,
                           collision=bool(st.get("collision")),
                           covered="{:.0f}–{:.0f} %".format(100.0 * c[0], 100.0 * c[1]) if c else "?")
    elif pre == "flank_ff_":
        for k, st in enumerate(strips):
            kinks = [float(v) for v in st.get("kink_to_next_deg", [])]
            rows[k] = dict(max=float(st["reported_max_error"]) * scale, min=float(st["reported_min_error"]) * scale,
                           collision=bool(st.get("collision")),
                           covered="kink {:.2g}°".format(max(kinks)) if kinks else "last")
    else:
        valley = int(coll.get("flank_df_valley", 0))
        for k, st in enumerate(strips):
            fl = sorted({int(ob.get("flank_df_flank", 0)) for ob in coll.objects
                         if ob.get("flank_df_role") == "envelope" and ob.get("flank_df_path") == k
                         and all(np.isfinite(list(ob.get("flank_df_deviation_range", [np.nan]))))})
            rows[k] = dict(max=float(st["reported_max_error"]) * scale, min=float(st["reported_min_error"]) * scale,
                           collision=bool(st.get("collision")),
                           covered="flank " + ", ".join(str(2 * valley + f - 1) for f in fl) if fl else "none")
    out = dict(pre=pre, key=key, rows=rows, uncovered=uncovered, unit=str(coll.get(pre + "length_unit", "mm")),
               scale=scale,
               tolerance=float(coll.get(pre + "tolerance", 0.0) or 0.0))
    _ROWS_CACHE.clear()
    _ROWS_CACHE[coll.name] = (cache_key, out)
    return out


class FLANK_UL_strips(bpy.types.UIList):
    """Strips of a planning run: one row per tool (strip number, max / min error in the scene's unit, the share
    of the flank it machines, collision)."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0, flt_flag=0):
        pre = _prefix(item)
        k = int(item.get(pre + _strip_key(pre), -1))
        info = strip_rows(data) if hasattr(data, "get") else None
        row_info = info["rows"].get(k) if info else None
        row = layout.row(align=True)
        row.label(text="{} {}".format("Path" if pre == "flank_df_" else "Strip", k + 1), icon='MOD_SCREW')
        if row_info is None:
            errs = list(item.get(pre + "strip_errors", [])) or [float("nan"), float("nan")]
            row.label(text="{:.3g} / {:.3g}".format(errs[0], errs[1]))
            return
        unit, scale = info["unit"], info["scale"]
        row.label(text="{} / {}".format(length_text(row_info["max"], context.scene, unit, scale, signed=True),
                                        length_text(row_info["min"], context.scene, unit, scale, signed=True)))
        row.label(text=row_info["covered"])
        row.label(text="", icon='ERROR' if row_info["collision"] else 'CHECKMARK')

    def filter_items(self, context, data, propname):
        items = getattr(data, propname)
        show = getattr(self, "bitflag_filter_item", 1 << 30)      # UIList.bitflag_filter_item
        flags, order = [], []
        for ob in items:
            pre = _prefix(ob)
            flags.append(show if pre and ob.get(pre + "role") == "tool" else 0)
            order.append(int(ob.get(pre + _strip_key(pre), 0)) if pre else 0)
        srt = sorted(range(len(order)), key=lambda i: order[i])
        neworder = [0] * len(order)
        for rank, i in enumerate(srt):
            neworder[i] = rank
        return flags, neworder


def select_strip(context, coll, index):
    """Select the tool and envelope objects of the strip (single flank) or path (double flank) shown at
    ``index`` of ``coll.objects`` and make the tool active."""
    if coll is None or not 0 <= index < len(coll.objects):
        return []
    ob = coll.objects[index]
    pre = _prefix(ob)
    if not pre:
        return []
    key = pre + _strip_key(pre)
    k = ob.get(key)
    picked = [o for o in coll.objects if o.get(key) == k and o.get(pre + "role") in ("tool", "envelope")]
    for o in context.view_layer.objects:
        if o.select_get():
            o.select_set(False)
    for o in picked:
        if o.name in context.view_layer.objects:
            o.select_set(True)
    if ob.name in context.view_layer.objects:
        context.view_layer.objects.active = ob
    return picked


class FLANK_OT_select_run(bpy.types.Operator):
    """Show this planning run in the Results panel (selects its first strip)"""

    bl_idname = "flank.select_run"
    bl_label = "Select Run"
    bl_options = {'REGISTER', 'UNDO'}

    collection: StringProperty(name="Run", description="Result collection of the run", default="")

    def execute(self, context):
        from .export import find_run

        coll = find_run(context, self.collection) if self.collection else "no run given"
        if isinstance(coll, str):
            self.report({'ERROR'}, "Select run: " + coll)
            return {'CANCELLED'}
        pre = _prefix(next(iter(coll.objects), {})) if len(coll.objects) else ""
        tools = [(int(ob.get(pre + _strip_key(pre), 0)), i) for i, ob in enumerate(coll.objects)
                 if pre and ob.get(pre + "role") == "tool"]
        if not tools:
            self.report({'ERROR'}, "Select run: '{}' has no tool objects".format(coll.name))
            return {'CANCELLED'}
        i = min(tools)[1]
        tool = coll.objects[i]
        if tool.name not in context.view_layer.objects:
            self.report({'ERROR'}, "Select run: '{}' is not in the view layer".format(tool.name))
            return {'CANCELLED'}
        context.view_layer.objects.active = tool
        context.scene.flank_settings.results_strip_index = i
        return {'FINISHED'}


class FLANK_MT_runs(bpy.types.Menu):
    """Planning runs under "Flank Results" (newest last)"""

    bl_idname = "FLANK_MT_runs"
    bl_label = "Runs"

    def draw(self, context):
        from .export import result_runs

        runs = result_runs()
        if not runs:
            self.layout.label(text="No planning run yet")
        for coll in runs:
            self.layout.operator("flank.select_run", text=coll.name, icon='OUTLINER_COLLECTION').collection = coll.name


# ================================================================================================ run
PLANNERS = {
    "SINGLE": ("flank.plan_single_flank", "sf_", single_flank_props),
    "DOUBLE": ("flank.plan_double_flank", "df_", double_flank_props),
    "TWO_PATHS": ("flank.plan_double_flank", "df_", double_flank_props),
    "FORMED": ("flank.formed_cutter", "cutter_", formed_cutter_props),
    "GROOVE": ("flank.paraboloid_groove", "groove_", paraboloid_props),
    "FREEFORM": ("flank.plan_freeform", "ff_", freeform_props),
}
_NAMES = {}


def _planner_names(strategy):
    if strategy not in _NAMES:
        _NAMES[strategy] = tuple(PLANNERS[strategy][2]().keys())
    return _NAMES[strategy]


def run_call(settings):
    """(operator idname, keyword arguments) of the chosen strategy's planner from the scene settings: what the
    Run button calls.  A cylinder runs as a cone of taper CYLINDER_TAPER (its radius grows h x 1e-4)."""
    import math

    strategy = settings.strategy
    idname, pre, _ = PLANNERS[strategy]
    kw = {}
    for name in _planner_names(strategy):
        v = getattr(settings, pre + name)
        kw[name] = tuple(v) if hasattr(v, "__len__") and not isinstance(v, (str, set)) else v
    if strategy == "SINGLE" and settings.tool_kind == "CYLINDER":
        h = float(settings.sf_length)
        kw.update(shape="alpha", alpha=CYLINDER_TAPER, r2=float(settings.sf_r1) + h * math.tan(CYLINDER_TAPER))
    elif strategy == "DOUBLE":
        kw["two_paths"] = False
    elif strategy == "TWO_PATHS":
        kw.update(two_paths=True, tool="custom")
    elif strategy == "FREEFORM":
        t = freeform_tool(settings)
        kw.update(r1=t.r1, r2=t.r2, length=t.length, shank_radius=t.shank_radius, shank_length=t.shank_length)
    return idname, kw


def freeform_tool(settings):
    """The Tool panel's end mill as s003's sphere family (scene units): namespace(r1, r2, length, shank_radius,
    shank_length) -- a cone's circles r1c < r2c become the inscribed spheres r / cos(alpha), the flute length h the
    distance of their centres h + (r2c - r1c) tan(alpha) (s000 Eqs. 2, 6); a cylinder is itself.  Values that
    make no cone pass through unchanged, for the planner to report."""
    import math
    import types

    r1, r2, h = float(settings.sf_r1), float(settings.sf_r2), float(settings.sf_length)
    out = types.SimpleNamespace(r1=r1, r2=r2, length=h, shank_radius=float(settings.sf_shank_radius),
                                shank_length=float(settings.sf_shank_length))
    if settings.tool_kind == "CYLINDER":
        out.r2 = r1
        return out
    alpha = float(settings.sf_alpha)
    try:
        if settings.sf_shape == "alpha":
            h = (r2 - r1) / math.tan(alpha)
        else:
            alpha = math.atan2(r2 - r1, h)
        if not (0.0 < alpha < 0.5 * math.pi and h > 0.0 and math.isfinite(h)):
            return out
        c = math.cos(alpha)
        out.r1, out.r2, out.length = r1 / c, r2 / c, h + (r2 - r1) * math.tan(alpha)
    except (ValueError, ZeroDivisionError, OverflowError):
        pass
    return out


classes = (FLANK_UL_flanks, FLANK_OT_refresh_flanks, FLANK_OT_pick_flank_cursor, FLANK_OT_pick_flank_faces,
           FLANK_OT_preview_tool, FLANK_OT_tool_preset, FLANK_MT_tool_presets, FLANK_OT_tool_preset_add,
           FLANK_UL_strips, FLANK_OT_select_run, FLANK_MT_runs)
