# SPDX-License-Identifier: GPL-3.0-or-later
"""Workpiece panel: import a mesh or generate a built-in rotor, analyse it, its helix data and its flanks."""
import bpy

from .common import CATEGORY, REGION, SPACE, settings_and_operator

GEN_PROPS = ("kind", "part", "scale", "lead", "length", "handedness", "resolution", "axial")
IMPORTERS = (("wm.stl_import", "STL"), ("wm.obj_import", "OBJ"), ("wm.ply_import", "PLY"))


class FLANK_PT_workpiece(bpy.types.Panel):
    bl_idname = "FLANK_PT_workpiece"
    bl_label = "Workpiece"
    bl_space_type = SPACE
    bl_region_type = REGION
    bl_category = CATEGORY
    bl_order = 0

    def draw(self, context):
        from ..operators.sources import workpiece_object

        layout = self.layout
        settings = getattr(context.scene, "flank_settings", None)

        row = layout.row(align=True)                # Blender's own importers (4.2+); Analyze makes it a rotor
        row.label(text="Import", icon='IMPORT')
        for idname, text in IMPORTERS:
            row.operator(idname, text=text)
        if settings is not None:
            show = settings.ui_show_generate
            layout.prop(settings, "ui_show_generate", icon='TRIA_DOWN' if show else 'TRIA_RIGHT', emboss=False)
            if show:
                settings_and_operator(layout.box(), context, "flank.generate_rotor", 'ADD', GEN_PROPS)

        obj = context.active_object
        rotor = workpiece_object(context)
        row = layout.row(align=True)
        row.operator("flank.analyze_rotor", icon='VIEWZOOM')
        if rotor is None or "flank_v0" not in rotor:
            layout.label(text="Active object has no helix data" if obj is not None else "No active object",
                         icon='INFO')
            return
        box = layout.box()
        box.label(text="{} ({})".format(rotor.name, rotor.get("flank_source", "?")), icon='OBJECT_DATA')
        col = box.column(align=True)
        axis = rotor.get("flank_axis")
        point = rotor.get("flank_axis_point")
        if axis is not None and point is not None:
            axis, point = list(axis)[:3], list(point)[:3]
            if rotor.get("flank_source") == "generated":      # stored in the object's frame: show it in the world's
                from mathutils import Vector

                mw = rotor.matrix_world
                axis = list((mw.to_3x3() @ Vector(axis)).normalized())
                point = list(mw @ Vector(point))
            col.label(text="Axis: ({:.4f}, {:.4f}, {:.4f})".format(*axis))
            col.label(text="Through: ({:.4g}, {:.4g}, {:.4g})".format(*point))
        col.label(text="v0: {:.6g} (lead {:.6g})".format(rotor["flank_v0"], rotor.get("flank_lead", float("nan"))))
        col.label(text="Handedness: {}".format(rotor.get("flank_handedness", "?")))
        if "flank_residual" in rotor:
            col.label(text="Residual: {:.3g} (threshold {:.3g})".format(
                rotor["flank_residual"], rotor.get("flank_threshold", float("nan"))))
        if "flank_flank_count" in rotor:
            col.label(text="Flanks: {}".format(rotor["flank_flank_count"]))
        if settings is None:
            return

        # ---- the flanks: list with the hyperbolic share, picked by row, 3D cursor or selected faces
        listed = settings.flank_list_rotor == rotor.name and len(settings.flank_list) > 0
        row = layout.row()
        if listed:
            row.template_list("FLANK_UL_flanks", "", settings, "flank_list", settings, "flank_index", rows=4)
        else:
            row.operator("flank.refresh_flanks", text="List Flanks", icon='FILE_REFRESH')
        col = row.column(align=True)
        if listed:
            col.operator("flank.refresh_flanks", text="", icon='FILE_REFRESH')
        col.operator("flank.pick_flank_cursor", text="", icon='PIVOT_CURSOR')
        sub = col.column(align=True)
        sub.enabled = obj is not None and obj.type == 'MESH' and obj.mode == 'EDIT'
        sub.operator("flank.pick_flank_faces", text="", icon='FACESEL')
        k = int(settings.sf_flank)            # what the planners get (also when typed in the strategy options)
        if listed and 0 <= k < len(settings.flank_list):
            item = settings.flank_list[k]
            layout.label(text="Target: flank {} (valley {}), {:.0f} % hyperbolic".format(
                item.flank, item.valley, 100.0 * item.hyperbolic_fraction), icon='RESTRICT_SELECT_OFF')
        else:
            layout.label(text="Target: flank {} (valley {})".format(settings.sf_flank, settings.df_valley),
                         icon='RESTRICT_SELECT_OFF')


classes = (FLANK_PT_workpiece,)
register, unregister = bpy.utils.register_classes_factory(classes)
