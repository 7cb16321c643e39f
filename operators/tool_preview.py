# SPDX-License-Identifier: GPL-3.0-or-later
"""The Tool panel's operators: the tool preview mesh beside the rotor, and tool presets (real end mills in mm,
through Blender's preset system, plus the user's own saved tools)."""
import math
import os

import bpy
import numpy as np
from bl_operators.presets import AddPresetBase
from bpy.props import FloatProperty
from mathutils import Matrix, Vector

from .common import mesh_vertices, new_mesh_from_arrays
from .result_builder import COLOR_TOOL
from .shapes import revolved_mesh
from .sources import workpiece_object
from .tool_settings import tool_outline
from .units import length_text

PRESET_SUBDIR = "flank_tool"
SHIPPED_PRESETS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "presets", PRESET_SUBDIR)
# what a preset holds: kind, shape and the dimensions in mm (converted to scene units when set), and the cutting
# data of the tool (flutes, cutting speed, feed per tooth, top speed: the Machine panel posts with them)
PRESET_VALUES = ("tool_kind", "sf_shape", "tool_taper_deg", "tool_tip_diameter_mm", "tool_flute_length_mm",
                 "tool_shank_diameter_mm", "tool_shank_length_mm", "tool_flutes", "tool_cutting_speed_m_min",
                 "tool_feed_per_tooth_mm", "tool_max_rpm")
PREVIEW_PROP = "flank_tool_preview"
PREVIEW_NAME = "Flank Tool Preview"
PREVIEW_SEGMENTS = 48


def _newest(objects):
    return objects[-1] if objects else None


def result_tool(kind):
    """The newest result object whose mesh is the tool of that kind: a double-flank tool or a formed cutter."""
    if kind == "CUSTOM":
        return _newest([ob for ob in bpy.data.objects if ob.get("flank_df_role") == "tool" and ob.type == 'MESH'
                        and ob.get("flank_df_path", 0) == 0])
    return _newest([ob for ob in bpy.data.objects if "flank_cutter_r_range" in ob and ob.type == 'MESH'
                    and ob.data is not None and len(ob.data.polygons)])


def _preview_objects():
    return [ob for ob in bpy.data.objects if ob.get(PREVIEW_PROP)]


def remove_preview():
    """Remove the tool preview object(s) and their meshes (no orphan data is left)."""
    for ob in _preview_objects():
        me = ob.data if ob.type == 'MESH' else None
        bpy.data.objects.remove(ob)
        if me is not None and me.users == 0:
            bpy.data.meshes.remove(me)


def _preview_mesh(settings, context):
    """(mesh, scale, description) of the tool to preview, or an error message."""
    kind = settings.tool_kind
    if kind in ("CUSTOM", "DISC"):
        src = result_tool(kind)
        if src is None:
            what = "double-flank tool" if kind == "CUSTOM" else "formed disc cutter"
            return "no {} yet: run the {} strategy first".format(what, "double-flank" if kind == "CUSTOM" else what)
        mesh = src.data.copy()
        mesh.name = PREVIEW_NAME
        scale = float(np.cbrt(abs(np.linalg.det(np.array(src.matrix_world)[:3, :3])))) or 1.0
        return mesh, scale, "copy of '{}'".format(src.name)
    rh, what = tool_outline(settings)
    if rh is None:
        return what
    size = max(max(abs(r), abs(z)) for r, z in rh)
    rotor = workpiece_object(context)
    limit = 1e6 if rotor is None or rotor.type != 'MESH' else 100.0 * max(rotor.dimensions) + 1e-9
    if size > limit:
        return "the tool ({:g} scene units) is over 100 x the size of '{}'".format(size, rotor.name)
    try:
        return new_mesh_from_arrays(PREVIEW_NAME, *revolved_mesh(np.array(rh, dtype=np.float64),
                                                                  PREVIEW_SEGMENTS)), 1.0, what
    except ValueError as ex:
        return str(ex)


def _beside_rotor(context, co, radius):
    """Where the preview goes: +x of the rotor's bounding box, tool axis along world z from the rotor's lowest
    point; the 3D cursor without a rotor."""
    rotor = workpiece_object(context)
    if rotor is None or rotor.type != 'MESH' or rotor.get(PREVIEW_PROP) is not None:
        return tuple(context.scene.cursor.location)
    box = np.array([rotor.matrix_world @ Vector(c) for c in rotor.bound_box])
    lo, hi = box.min(axis=0), box.max(axis=0)
    gap = 0.15 * float(max(hi - lo)) + radius
    return hi[0] + gap, 0.5 * (lo[1] + hi[1]), lo[2] - float(co[:, 2].min()) if len(co) else lo[2]


class FLANK_OT_preview_tool(bpy.types.Operator):
    """Show the tool of the Tool panel as a mesh beside the rotor (replaced on every run; a double-flank tool or
    a formed cutter is copied from the newest result)"""

    bl_idname = "flank.preview_tool"
    bl_label = "Preview Tool"
    bl_options = {'REGISTER', 'UNDO'}

    def execute(self, context):
        settings = getattr(context.scene, "flank_settings", None)
        if settings is None:
            self.report({'ERROR'}, "Preview tool: the Flank settings are not registered")
            return {'CANCELLED'}
        made = _preview_mesh(settings, context)
        if isinstance(made, str):
            self.report({'ERROR'}, "Preview tool: " + made)
            return {'CANCELLED'}
        mesh, scale, what = made
        co = mesh_vertices(mesh) * scale
        radius = float(np.max(np.linalg.norm(co[:, :2], axis=1))) if len(co) else 0.0
        loc = _beside_rotor(context, co, radius)
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
        ob[PREVIEW_PROP] = settings.tool_kind
        ob.matrix_world = Matrix.Translation(loc) @ Matrix.Scale(scale, 4)
        ob.color = COLOR_TOOL
        rotor = workpiece_object(context)
        self.report({'INFO'}, "Tool preview ({}, {}): radius up to {} beside {}".format(
            settings.tool_kind.lower(), what, length_text(radius, context.scene),
            "'{}'".format(rotor.name) if rotor is not None else "the 3D cursor"))
        return {'FINISHED'}


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

    def execute(self, context):
        # Blender's own operator ends silently here: a name that makes no file name, a preset that is not there
        if not (self.remove_name or self.remove_active):
            if not self.as_filename(self.name.strip()):
                self.report({'ERROR'}, "Tool preset: the name {!r} has no letter or digit to make a file name "
                                       "of".format(self.name))
                return {'CANCELLED'}
        else:
            name = self.name if self.remove_name else getattr(bpy.types, self.preset_menu).bl_label
            if not (bpy.utils.preset_find(name, self.preset_subdir, ext=".py")
                    or bpy.utils.preset_find(name, self.preset_subdir, display_name=True, ext=".py")):
                self.report({'ERROR'}, "Tool preset: there is no user preset named {!r} to remove{}".format(
                    name, "" if self.remove_name else " (apply the preset to remove first)"))
                return {'CANCELLED'}
        return super().execute(context)


classes = (FLANK_OT_preview_tool, FLANK_OT_tool_preset, FLANK_MT_tool_presets, FLANK_OT_tool_preset_add)
register, unregister = bpy.utils.register_classes_factory(classes)
