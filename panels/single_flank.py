# SPDX-License-Identifier: GPL-3.0-or-later
"""Single-flank conical panel (Bizzarri, Bo & Bartoň): plan one flank with strips of a conical tool, show the
strips and errors."""
import bpy

from .common import CATEGORY, REGION, SPACE, draw_settings, list_prop as _list, strategy_poll

# the strategy's own settings (the tool's are in the Tool panel, unless Tool Presets names shipped presets; Run
# passes all of them to the planner)
SF_GROUPS = (("flank", "use_point", "point"), ("tools",), ("tolerance", "overcut_tolerance"),
             ("seeds", "objective", "mode", "rounds", "collisions", "g1", "g1_extra_strips"),
             ("envelope_rings", "animate", "frame_start", "frame_end"), ("filepath",))


class FLANK_PT_single_flank(bpy.types.Panel):
    bl_idname = "FLANK_PT_single_flank"
    bl_label = "Single-Flank Conical"
    bl_space_type = SPACE
    bl_region_type = REGION
    bl_category = CATEGORY
    bl_parent_id = "FLANK_PT_strategy"
    bl_order = 12

    @classmethod
    def poll(cls, context):
        return strategy_poll(context, "SINGLE")

    def draw(self, context):
        layout = self.layout
        settings = getattr(context.scene, "flank_settings", None)
        if settings is not None:
            draw_settings(layout, settings, "sf_", SF_GROUPS,
                          active=dict(point=settings.sf_use_point, g1_extra_strips=settings.sf_g1,
                                      frame_start=settings.sf_animate, frame_end=settings.sf_animate))

        obj = context.active_object
        if obj is None or "flank_sf_strips" not in obj:
            return
        box = layout.box()
        box.label(text="{}: flank {} ({})".format(obj.get("flank_sf_rotor", obj.name), obj.get("flank_sf_flank", "?"),
                                                  obj.get("flank_sf_method", "?")), icon='OBJECT_DATA')
        col = box.column(align=True)
        col.label(text="{} strips of {} candidates, {} colliding excluded".format(
            obj.get("flank_sf_strips", 0), obj.get("flank_sf_candidates", 0), obj.get("flank_sf_collisions", 0)))
        col.label(text="Error {:.4g} .. {:.4g} (tolerance {:.4g})".format(
            obj.get("flank_sf_min_error", float("nan")), obj.get("flank_sf_max_error", float("nan")),
            obj.get("flank_sf_tolerance", float("nan"))))
        if obj.get("flank_sf_covered_fraction") is not None:
            col.label(text="Covered {:.1f} % of the flank within tolerance".format(
                100.0 * float(obj["flank_sf_covered_fraction"])))
        unc = _list(obj, "flank_sf_uncovered")
        if unc:
            col.label(text="Uncovered: {}".format(", ".join(
                "[{:.4g}, {:.4g}]".format(unc[i], unc[i + 1]) for i in range(0, len(unc) - 1, 2))))
        else:
            col.label(text="Flank covered")
        col.label(text="Largest kink {:.3g} deg".format(obj.get("flank_sf_kink_max_deg", 0.0)))
        col.label(text="Core {:.2f} s, total {:.2f} s".format(obj.get("flank_sf_elapsed", 0.0),
                                                              obj.get("flank_sf_total_elapsed", 0.0)))


classes = (FLANK_PT_single_flank,)
register, unregister = bpy.utils.register_classes_factory(classes)
