# SPDX-License-Identifier: GPL-3.0-or-later
"""Double-flank custom tool panel (Bizzarri & Bartoň 2021): plan one valley with a custom-shaped or conical tool,
show the axis and errors."""
import math

import bpy

from .common import CATEGORY, REGION, SPACE, draw_settings, list_prop as _list, strategy_poll

# the strategy's own settings (tool shape in the Tool panel, two paths = the strategy "Two Paths, One Tool")
DF_GROUPS = (("valley", "variant"), ("tolerance",), ("radii", "rim", "samples", "simulate"),
             ("envelope_rings", "animate", "frame_start", "frame_end"), ("filepath", "tool_csv"))


class FLANK_PT_double_flank(bpy.types.Panel):
    bl_idname = "FLANK_PT_double_flank"
    bl_label = "Double-Flank Custom Tool"
    bl_space_type = SPACE
    bl_region_type = REGION
    bl_category = CATEGORY
    bl_parent_id = "FLANK_PT_strategy"
    bl_order = 11

    @classmethod
    def poll(cls, context):
        return strategy_poll(context, "DOUBLE", "TWO_PATHS")

    def draw(self, context):
        layout = self.layout
        settings = getattr(context.scene, "flank_settings", None)
        if settings is not None:
            draw_settings(layout, settings, "df_", DF_GROUPS,
                          active=dict(frame_start=settings.df_animate, frame_end=settings.df_animate))

        obj = context.active_object
        if obj is None or "flank_df_alpha" not in obj:
            return
        box = layout.box()
        box.label(text="{}: valley {} ({})".format(obj.get("flank_df_rotor", obj.name), obj.get("flank_df_valley", "?"),
                                                   obj.get("flank_df_method", "?")), icon='OBJECT_DATA')
        col = box.column(align=True)
        alpha, delta, phi = _list(obj, "flank_df_alpha"), _list(obj, "flank_df_delta"), _list(obj, "flank_df_phi")
        Phi, its = _list(obj, "flank_df_Phi"), _list(obj, "flank_df_iterations")
        if alpha and delta and phi:
            col.label(text="alpha {:+.4f} deg, delta {:+.5g}, phi {:+.4f} deg".format(
                math.degrees(alpha[0]), delta[0], math.degrees(phi[0])))
        if Phi and its:
            col.label(text="Phi {:.4g} ({} iterations)".format(Phi[0], its[0]))
        t_max, t_min = _list(obj, "flank_df_tool_to_rotor_max"), _list(obj, "flank_df_tool_to_rotor_min")
        for j in range(min(len(t_max), len(t_min))):
            col.label(text="Flank {}: error {:.4g} .. {:.4g}".format(j + 1, t_min[j], t_max[j]))
        haus = _list(obj, "flank_df_hausdorff")
        if obj.get("flank_df_simulated") and haus:
            col.label(text="Hausdorff: {}".format(", ".join("{:.4g}".format(h) for h in haus)))
        col.label(text="Optimisation {:.2f} s, total {:.2f} s".format(
            obj.get("flank_df_optimize_elapsed", 0.0), obj.get("flank_df_total_elapsed", 0.0)))


classes = (FLANK_PT_double_flank,)
register, unregister = bpy.utils.register_classes_factory(classes)
