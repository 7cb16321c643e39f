# SPDX-License-Identifier: GPL-3.0-or-later
"""Paraboloid groove panel (Doğrusadık): groove of a paraboloid end mill on a helix, section and overcut."""
import bpy

from .common import CATEGORY, REGION, SPACE, draw_settings, strategy_poll

GROOVE_GROUPS = (("radius", "pitch", "turns"), ("part", "resolution"))     # the lens a, b: Tool panel


class FLANK_PT_paraboloid(bpy.types.Panel):
    bl_idname = "FLANK_PT_paraboloid"
    bl_label = "Paraboloid Groove"
    bl_space_type = SPACE
    bl_region_type = REGION
    bl_category = CATEGORY
    bl_parent_id = "FLANK_PT_strategy"
    bl_order = 14

    @classmethod
    def poll(cls, context):
        return strategy_poll(context, "GROOVE")

    def draw(self, context):
        layout = self.layout
        settings = getattr(context.scene, "flank_settings", None)
        if settings is not None:
            draw_settings(layout, settings, "groove_", GROOVE_GROUPS)

        obj = context.active_object
        if obj is None or "flank_groove_max_overcut" not in obj:
            return
        box = layout.box()
        box.label(text=obj.name, icon='OBJECT_DATA')
        col = box.column(align=True)
        xs = list(obj.get("flank_groove_intercepts", ()))
        if len(xs) == 2:
            col.label(text="Intercepts: x = {:.6g}, {:.6g}".format(*xs))
        col.label(text="Equator radius: {:.6g}".format(obj.get("flank_groove_equator_radius", float("nan"))))
        col.label(text="Max overcut: {:.4g} at x = {:.6g}".format(
            obj["flank_groove_max_overcut"], obj.get("flank_groove_max_overcut_x", float("nan"))))


classes = (FLANK_PT_paraboloid,)
register, unregister = bpy.utils.register_classes_factory(classes)
