# SPDX-License-Identifier: GPL-3.0-or-later
"""Formed disc cutter panel (Hu, Zhou & Li 2025): disc cutter for one tooth, its flags, motion and machined
deviation."""
import bpy

from .common import CATEGORY, REGION, SPACE, draw_settings, strategy_poll

CUTTER_GROUPS = (("source", "lead", "handedness"), ("centre_distance", "swivel"),
                 ("planes", "eps_b", "tolerance", "sample_points", "resolution"),
                 ("animate", "frame_start", "frame_end"), ("filepath",))


class FLANK_PT_formed_cutter(bpy.types.Panel):
    bl_idname = "FLANK_PT_formed_cutter"
    bl_label = "Formed Disc Cutter"
    bl_space_type = SPACE
    bl_region_type = REGION
    bl_category = CATEGORY
    bl_parent_id = "FLANK_PT_strategy"
    bl_order = 13

    @classmethod
    def poll(cls, context):
        return strategy_poll(context, "FORMED")

    def draw(self, context):
        layout = self.layout
        settings = getattr(context.scene, "flank_settings", None)
        if settings is not None:
            draw_settings(layout, settings, "cutter_", CUTTER_GROUPS,
                          active=dict(frame_start=settings.cutter_animate, frame_end=settings.cutter_animate))

        obj = context.active_object
        if obj is None or "flank_cutter_r_range" not in obj:
            return
        box = layout.box()
        box.label(text="{} on {}".format(obj.name, obj.get("flank_cutter_rotor", "?")), icon='OBJECT_DATA')
        col = box.column(align=True)
        col.label(text="A {:.6g}, swivel {:.6g} deg, lead {:.6g} ({})".format(
            obj.get("flank_cutter_centre_distance", float("nan")), obj.get("flank_cutter_swivel", float("nan")),
            obj.get("flank_cutter_lead", float("nan")), obj.get("flank_cutter_handedness", "?")))
        rr = list(obj["flank_cutter_r_range"])
        col.label(text="Radius: {:.6g} .. {:.6g}".format(rr[0], rr[1]))
        counts = obj.get("flank_cutter_flag_counts")
        counts = counts.to_dict() if hasattr(counts, "to_dict") else dict(counts or {})
        flagged = ", ".join("{} {}".format(k, v) for k, v in counts.items() if v) or "none"
        col.label(text="Flagged planes: {}".format(flagged),
                  icon='ERROR' if obj.get("flank_cutter_flagged_planes", 0) else 'NONE')
        col.label(text="Uncut tooth ranges: {}".format(obj.get("flank_cutter_uncut", 0)))
        col.label(text="Max |deviation|: {:.3g} (tolerance {:.3g})".format(
            obj.get("flank_cutter_max_abs_deviation", float("nan")), obj.get("flank_cutter_tolerance", float("nan"))))
        col.label(text="Cutter {:.2f} s, simulation {:.2f} s".format(
            obj.get("flank_cutter_elapsed", 0.0), obj.get("flank_cutter_sim_elapsed", 0.0)))


classes = (FLANK_PT_formed_cutter,)
register, unregister = bpy.utils.register_classes_factory(classes)
