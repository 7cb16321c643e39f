# SPDX-License-Identifier: GPL-3.0-or-later
"""Paraboloid Groove (s002) panel: groove of a paraboloid end mill on a helix, section and overcut."""
import bpy

from .common import settings_and_operator

GROOVE_PROPS = ("radius", "a", "b", "pitch", "turns", "part", "resolution")


class FLANK_PT_paraboloid(bpy.types.Panel):
    bl_idname = "FLANK_PT_paraboloid"
    bl_label = "Paraboloid Groove (s002)"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "Flank"
    bl_order = 14
    bl_options = {'DEFAULT_CLOSED'}

    def draw(self, context):
        layout = self.layout
        settings_and_operator(layout, context, "flank.paraboloid_groove", 'MOD_SCREW', GROOVE_PROPS, "groove_")

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
