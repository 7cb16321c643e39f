# SPDX-License-Identifier: GPL-3.0-or-later
"""Workpiece panel: generate a built-in rotor or analyze the active mesh, show the helix data."""
import bpy

from .common import settings_and_operator

GEN_PROPS = ("kind", "part", "scale", "lead", "length", "handedness", "resolution", "axial")


class FLANK_PT_workpiece(bpy.types.Panel):
    bl_idname = "FLANK_PT_workpiece"
    bl_label = "Workpiece"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "Flank"

    def draw(self, context):
        layout = self.layout
        box = layout.box()
        box.label(text="Built-in Rotor", icon='MESH_CYLINDER')
        settings_and_operator(box, context, "flank.generate_rotor", 'ADD', GEN_PROPS)

        layout.operator("flank.analyze_rotor", icon='VIEWZOOM')

        obj = context.active_object
        if obj is None or "flank_v0" not in obj:
            layout.label(text="Active object has no helix data", icon='INFO')
            return
        box = layout.box()
        box.label(text="{} ({})".format(obj.name, obj.get("flank_source", "?")), icon='OBJECT_DATA')
        col = box.column(align=True)
        axis = obj.get("flank_axis")
        point = obj.get("flank_axis_point")
        if axis is not None:
            col.label(text="Axis: ({:.4f}, {:.4f}, {:.4f})".format(*list(axis)[:3]))
        if point is not None:
            col.label(text="Through: ({:.4g}, {:.4g}, {:.4g})".format(*list(point)[:3]))
        col.label(text="v0: {:.6g}".format(obj["flank_v0"]))
        col.label(text="Handedness: {}".format(obj.get("flank_handedness", "?")))
        if "flank_residual" in obj:
            col.label(text="Residual: {:.3g} (threshold {:.3g})".format(
                obj["flank_residual"], obj.get("flank_threshold", float("nan"))))
        if "flank_flank_count" in obj:
            col.label(text="Flanks: {}".format(obj["flank_flank_count"]))
