# SPDX-License-Identifier: GPL-3.0-or-later
"""Free-form G1 panel (Rajain et al. 2023): the guiding direction (typed, picked from an edge / the view / an
Empty / the 3D cursor, or a vector attribute), the guiding-curve preview, the weights of Eq. (18) and the run's
numbers."""
import bpy

from .common import CATEGORY, REGION, SPACE, draw_settings, strategy_poll

FF_GROUPS = (("selected_only", "flip_normals", "spacing", "engagement"),
             ("w_rigid", "w_approx", "w_g1", "w_proximity", "w_fair"),
             ("samples", "columns", "max_evaluations", "slide"),
             ("tolerance", "envelope_samples"), ("filepath",))


class FLANK_PT_freeform(bpy.types.Panel):
    bl_idname = "FLANK_PT_freeform"
    bl_label = "Free-form G1"
    bl_space_type = SPACE
    bl_region_type = REGION
    bl_category = CATEGORY
    bl_parent_id = "FLANK_PT_strategy"
    bl_order = 15

    @classmethod
    def poll(cls, context):
        return strategy_poll(context, "FREEFORM")

    def draw(self, context):
        from ..operators.guiding import preview_message

        layout = self.layout
        settings = getattr(context.scene, "flank_settings", None)
        if settings is None:
            return
        layout.menu("FLANK_MT_test_surfaces", icon='MESH_GRID')
        box = layout.box()
        box.label(text="Guiding direction", icon='ORIENTATION_GIMBAL')
        box.prop(settings, "ff_direction_mode", text="")
        if settings.ff_direction_mode == "FIELD":
            box.prop(settings, "ff_field_attribute")
        else:
            box.prop(settings, "ff_direction", text="")
            row = box.row(align=True)
            for source, text, icon in (("EDGE", "Edge", 'EDGESEL'), ("VIEW", "View", 'VIEW_CAMERA'),
                                       ("EMPTY", "Empty", 'EMPTY_AXIS'), ("CURSOR", "Cursor", 'PIVOT_CURSOR')):
                row.operator("flank.pick_guiding_direction", text=text, icon=icon).source = source
        row = box.row(align=True)
        row.prop(settings, "ff_use_point")
        sub = row.row(align=True)
        sub.active = settings.ff_use_point
        sub.prop(settings, "ff_point", text="")
        row = box.row(align=True)
        row.operator("flank.preview_guiding", icon='CURVE_PATH')
        row.prop(settings, "ff_live_preview", text="", icon='FILE_REFRESH')
        row.operator("flank.clear_guiding_preview", text="", icon='X')
        text, error = preview_message()
        if text:
            box.label(text=text, icon='ERROR' if error else 'INFO')
        draw_settings(layout, settings, "ff_", FF_GROUPS)
        layout.prop(settings, "ff_optimize_tool")

        coll = None
        obj = context.active_object
        if obj is not None:
            for c in obj.users_collection:
                if "flank_ff_strips" in c:
                    coll = c
        if coll is None:
            return
        box = layout.box()
        box.label(text=coll.name, icon='OUTLINER_COLLECTION')
        col = box.column(align=True)
        col.label(text="{} strips, error {:.4g} .. {:.4g}".format(coll.get("flank_ff_strips", 0),
                                                                   coll.get("flank_ff_min_error", float("nan")),
                                                                   coll.get("flank_ff_max_error", float("nan"))))
        col.label(text="Kink max {:.3g} deg, mean {:.3g} deg".format(coll.get("flank_ff_max_kink_deg", 0.0),
                                                                     coll.get("flank_ff_mean_kink_deg", 0.0)))
        col.label(text="{} colliding rulings, {} samples over the border".format(
            coll.get("flank_ff_colliding_rulings", 0), coll.get("flank_ff_overhanging_samples", 0)))
        col.label(text="Core {:.2f} s, total {:.2f} s".format(coll.get("flank_ff_elapsed", 0.0),
                                                              coll.get("flank_ff_total_elapsed", 0.0)))


classes = (FLANK_PT_freeform,)
register, unregister = bpy.utils.register_classes_factory(classes)
