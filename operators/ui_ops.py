# SPDX-License-Identifier: GPL-3.0-or-later
"""Sidebar helpers: tool presets (Blender's preset system), the strips list of a run, the legend colours."""
import os

import bpy
from bl_operators.presets import AddPresetBase
from bpy.props import FloatProperty

from .common import PLAN_JSON_PROP

PRESET_SUBDIR = "flank_tool"
SHIPPED_PRESETS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "presets", PRESET_SUBDIR)
TOOL_SETTINGS = ("sf_shape", "sf_alpha", "sf_r1", "sf_r2", "sf_length", "sf_shank_radius", "sf_shank_length")


def mm_per_scene_unit(scene):
    """Millimetres per Blender unit: with a unit system (metric or imperial) a Blender unit is scale_length
    metres; a unit-less scene is taken as millimetres (the convention of analysed meshes and scaled
    built-in rotors)."""
    us = scene.unit_settings
    if us.system in ('METRIC', 'IMPERIAL'):
        return 1000.0 * float(us.scale_length or 1.0)
    return 1.0


class FLANK_OT_tool_preset(bpy.types.Operator):
    """Set the single-flank tool from a real tapered end mill given in mm (converted to scene units)"""

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
        k = 1.0 / mm_per_scene_unit(context.scene)            # scene units per mm
        r1 = 0.5 * d
        s.sf_shape = "alpha"
        s.sf_alpha = math.radians(a)
        s.sf_r1 = r1 * k
        s.sf_r2 = (r1 + L * math.tan(math.radians(a))) * k
        s.sf_length = L * k
        s.sf_shank_radius = 0.5 * sd * k
        s.sf_shank_length = (ol - L) * k
        self.report({'INFO'}, "Tool: taper {:g} deg, tip D{:g}, flute {:g} mm, shank D{:g} mm (r1 = {:.4g}, "
                              "r2 = {:.4g} scene units)".format(a, d, L, sd, s.sf_r1, s.sf_r2))
        return {'FINISHED'}


class FLANK_MT_tool_presets(bpy.types.Menu):
    """Real tapered end mills shipped with the extension, and your own saved tools"""

    bl_idname = "FLANK_MT_tool_presets"
    bl_label = "Tool Presets"
    preset_subdir = PRESET_SUBDIR
    preset_operator = "script.execute_preset"

    def draw(self, context):
        paths = [SHIPPED_PRESETS] + bpy.utils.preset_paths(PRESET_SUBDIR)
        self.path_menu([p for p in paths if os.path.isdir(p)], self.preset_operator,
                       props_default={"menu_idname": self.bl_idname}, filter_ext=lambda ext: ext.lower() == ".py",
                       display_name=lambda path: os.path.splitext(os.path.basename(path))[0].replace("_", "."))


class FLANK_OT_tool_preset_add(AddPresetBase, bpy.types.Operator):
    """Save the current single-flank tool as a preset (scene units), or remove one"""

    bl_idname = "flank.tool_preset_add"
    bl_label = "Add Tool Preset"
    preset_menu = "FLANK_MT_tool_presets"
    preset_subdir = PRESET_SUBDIR
    preset_defines = ["settings = bpy.context.scene.flank_settings"]
    preset_values = ["settings." + name for name in TOOL_SETTINGS]


class FLANK_UL_strips(bpy.types.UIList):
    """Strips of a planning run: one row per tool object (strip number, max / min error, collision)."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0, flt_flag=0):
        pre = _prefix(item)
        k = int(item.get(pre + "strip", -1))
        errs = list(item.get(pre + "strip_errors", [])) or [float("nan"), float("nan")]
        row = layout.row(align=True)
        row.label(text="Strip {}".format(k + 1), icon='MOD_SCREW')
        row.label(text="max {:.3g}".format(errs[0]))
        row.label(text="min {:.3g}".format(errs[1]))
        coll = _plan_strip(data, k)
        if coll is not None and coll.get("collision"):
            row.label(text="", icon='ERROR')

    def filter_items(self, context, data, propname):
        items = getattr(data, propname)
        show = getattr(self, "bitflag_filter_item", 1 << 30)      # UIList.bitflag_filter_item
        flags, order = [], []
        for ob in items:
            pre = _prefix(ob)
            flags.append(show if pre and ob.get(pre + "role") == "tool" else 0)
            order.append(int(ob.get(pre + "strip", 0)) if pre else 0)
        srt = sorted(range(len(order)), key=lambda i: order[i])
        neworder = [0] * len(order)
        for rank, i in enumerate(srt):
            neworder[i] = rank
        return flags, neworder


_PLAN_CACHE = {}


def _prefix(ob):
    for pre in ("flank_sf_", "flank_df_"):
        if pre + "role" in ob:
            return pre
    return ""


def _plan_strip(coll, k):
    """The plan strip k of a run (parsed once per run and plan text)."""
    import json

    text = coll.get(PLAN_JSON_PROP) if hasattr(coll, "get") else None
    if not text:
        return None
    key = (coll.name, len(text))
    if key not in _PLAN_CACHE:
        _PLAN_CACHE.clear()
        try:
            _PLAN_CACHE[key] = json.loads(text)["strips"]
        except (ValueError, KeyError):
            _PLAN_CACHE[key] = []
    strips = _PLAN_CACHE[key]
    return strips[k] if 0 <= k < len(strips) else None


def select_strip(context, coll, index):
    """Select the tool and envelope objects of the strip shown at ``index`` of ``coll.objects``."""
    if coll is None or not 0 <= index < len(coll.objects):
        return []
    ob = coll.objects[index]
    pre = _prefix(ob)
    if not pre:
        return []
    k = ob.get(pre + "strip")
    picked = [o for o in coll.objects if o.get(pre + "strip") == k and o.get(pre + "role") in ("tool", "envelope")]
    for o in context.view_layer.objects:
        o.select_set(False)
    for o in picked:
        if o.name in context.view_layer.objects:
            o.select_set(True)
    if ob.name in context.view_layer.objects:
        context.view_layer.objects.active = ob
    return picked


classes = (FLANK_OT_tool_preset, FLANK_MT_tool_presets, FLANK_OT_tool_preset_add, FLANK_UL_strips)
