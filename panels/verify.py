# SPDX-License-Identifier: GPL-3.0-or-later
"""Verify panel: simulate a plan file on the active rotor mesh, show the deviation summary."""
import bpy

from .common import settings_and_operator

VERIFY_PROPS = ("filepath", "tolerance", "search", "show_tools")


class FLANK_PT_verify(bpy.types.Panel):
    bl_idname = "FLANK_PT_verify"
    bl_label = "Verify"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "Flank"
    bl_order = 30

    def draw(self, context):
        layout = self.layout
        settings_and_operator(layout, context, "flank.verify_plan", 'CHECKMARK', VERIFY_PROPS, "verify_")

        obj = context.active_object
        if obj is None or "flank_verify_plan" not in obj:
            layout.label(text="Active object has no verification", icon='INFO')
            return
        unit = obj.get("flank_verify_unit", "")
        box = layout.box()
        box.label(text="{}: {}".format(obj.name, bpy.path.basename(obj["flank_verify_plan"])), icon='FILE')
        col = box.column(align=True)
        for key, label in (("flank_verify_max_undercut", "Max undercut"), ("flank_verify_max_overcut", "Max overcut"),
                           ("flank_verify_tolerance", "Tolerance")):
            if key in obj:
                col.label(text="{}: {:.4g} {}".format(label, obj[key], unit))
        col.label(text="Gouge points: {}".format(obj.get("flank_verify_gouges", 0)),
                  icon='ERROR' if obj.get("flank_verify_gouges", 0) else 'NONE')
        col.label(text="Vertices reached: {} (untouched {})".format(
            obj.get("flank_verify_reached", 0), obj.get("flank_verify_untouched", 0)))
        col.label(text="Simulation: {:.2f} s".format(obj.get("flank_verify_elapsed", 0.0)))


classes = (FLANK_PT_verify,)
register, unregister = bpy.utils.register_classes_factory(classes)
