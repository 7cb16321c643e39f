# SPDX-License-Identifier: GPL-3.0-or-later
"""Tool panel: presets of real end mills, the tool kind and its dimensions (scene units), a preview mesh
beside the rotor and the admissibility check of a cone (a cylinder is checked as the cone of taper CYLINDER_TAPER
that the single-flank planner plans it as)."""
import math

import bpy

from .common import CATEGORY, REGION, SPACE, list_prop


def _newest(pred):
    found = [ob for ob in bpy.data.objects if pred(ob)]
    return found[-1] if found else None


class FLANK_PT_tool(bpy.types.Panel):
    bl_idname = "FLANK_PT_tool"
    bl_label = "Tool"
    bl_space_type = SPACE
    bl_region_type = REGION
    bl_category = CATEGORY
    bl_order = 5

    def draw(self, context):
        from ..operators.tool_settings import CYLINDER_TAPER
        from ..operators.units import length_text

        layout = self.layout
        settings = getattr(context.scene, "flank_settings", None)
        if settings is None:
            return
        scene = context.scene
        row = layout.row(align=True)            # real end mills in mm, and the user's own tools
        row.menu("FLANK_MT_tool_presets", text=bpy.types.FLANK_MT_tool_presets.bl_label, icon='PRESET')
        row.operator("flank.tool_preset_add", text="", icon='ADD')
        row.operator("flank.tool_preset_add", text="", icon='REMOVE').remove_active = True
        layout.prop(settings, "tool_kind", text="")

        kind = settings.tool_kind
        layout.use_property_split = True
        layout.use_property_decorate = False
        if kind == "CONE":
            layout.row().prop(settings, "sf_shape", expand=True)
            col = layout.column(align=True)
            col.prop(settings, "sf_r1", text="Tip Radius r1")
            col.prop(settings, "sf_r2", text="Top Radius r2")
            if settings.sf_shape == "alpha":
                col.prop(settings, "sf_alpha", text="Taper (Half Angle)")
            else:
                col.prop(settings, "sf_length", text="Flute Length h")
            r1, r2 = settings.sf_r1, settings.sf_r2
            if settings.sf_shape == "alpha" and 0.0 < settings.sf_alpha < 0.5 * math.pi and r2 > r1:
                layout.label(text="Flute length {}".format(length_text((r2 - r1) / math.tan(settings.sf_alpha),
                                                                      scene)), icon='INFO')
            elif settings.sf_shape == "length" and settings.sf_length > 0.0 and r2 > r1:
                layout.label(text="Taper {:.3f} deg".format(math.degrees(math.atan2(r2 - r1, settings.sf_length))),
                             icon='INFO')
        elif kind == "CYLINDER":
            col = layout.column(align=True)
            col.prop(settings, "sf_r1", text="Radius")
            col.prop(settings, "sf_length", text="Flute Length")
            layout.label(text="Planned as a cone of taper {:.4f} deg (r + {})".format(
                math.degrees(CYLINDER_TAPER), length_text(settings.sf_length * math.tan(CYLINDER_TAPER), scene)),
                icon='INFO')
        elif kind == "CUSTOM":
            if settings.strategy == "TWO_PATHS":
                layout.label(text="Two paths: one custom tool", icon='INFO')
            else:
                layout.row().prop(settings, "df_tool", expand=True)
                if settings.df_tool == "cones":
                    layout.prop(settings, "df_cones")
            tool = _newest(lambda ob: ob.get("flank_df_role") == "tool")
            if tool is not None:
                rr = list_prop(tool, "flank_df_radii_range")
                if len(rr) == 2:
                    layout.label(text="Newest: {} .. {} ({})".format(length_text(rr[0], scene),
                                                                     length_text(rr[1], scene), tool.name))
            layout.label(text="Shaped by the double-flank planner", icon='INFO')
        elif kind == "DISC":
            cutter = _newest(lambda ob: "flank_cutter_r_range" in ob)
            if cutter is not None:
                rr = list_prop(cutter, "flank_cutter_r_range")
                if len(rr) == 2:
                    layout.label(text="Newest: radius {:.6g} .. {:.6g} ({})".format(rr[0], rr[1], cutter.name))
            layout.label(text="Profile from the formed disc cutter planner", icon='INFO')
        elif kind == "PARABOLOID":
            col = layout.column(align=True)
            col.prop(settings, "groove_a")
            col.prop(settings, "groove_b")
            a, b = settings.groove_a, settings.groove_b
            if a < 0.0 < b:
                layout.label(text="Lens radius {:.4g}, height {:.4g}".format(math.sqrt(-b / a), 2.0 * b),
                             icon='INFO')
        if kind in ("CONE", "CYLINDER"):
            col = layout.column(align=True)
            col.prop(settings, "sf_shank_radius")
            col.prop(settings, "sf_shank_length")

        layout.use_property_split = False
        row = layout.row(align=True)
        row.operator("flank.preview_tool", icon='HIDE_OFF')
        if kind == "CONE":                      # Bizzarri, Bo & Bartoň Sec. 4: flank and cone from the sf_* settings
            row.operator("flank.cutter_region", text="Check Tool", icon='CHECKMARK')
        elif kind == "CYLINDER":                # checked as the cone it is planned as (see ui_ops.run_call)
            op = row.operator("flank.cutter_region", text="Check Tool", icon='CHECKMARK')
            r, h = settings.sf_r1, settings.sf_length
            op.r1, op.r2, op.alpha = r, r + h * math.tan(CYLINDER_TAPER), CYLINDER_TAPER


classes = (FLANK_PT_tool,)
register, unregister = bpy.utils.register_classes_factory(classes)
