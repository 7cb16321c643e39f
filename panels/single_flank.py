# SPDX-License-Identifier: GPL-3.0-or-later
"""Single Flank (s000) panel: plan one flank with strips of a conical tool, show the strips and errors."""
import bpy

from .common import settings_and_operator

SF_PROPS = ("flank", "use_point", "point", "shape", "r1", "r2", "alpha", "length", "shank_radius", "shank_length",
            "tolerance", "overcut_tolerance", "seeds", "objective", "mode", "rounds", "collisions", "g1", "g1_extra_strips",
            "envelope_rings",
            "animate", "frame_start", "frame_end", "filepath")


def _list(obj, key):
    val = obj.get(key)
    if val is None:
        return []
    return list(val.to_list() if hasattr(val, "to_list") else val)


class FLANK_PT_single_flank(bpy.types.Panel):
    bl_idname = "FLANK_PT_single_flank"
    bl_label = "Single Flank (s000)"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "Flank"
    bl_order = 12
    bl_options = {'DEFAULT_CLOSED'}

    def draw(self, context):
        layout = self.layout
        row = layout.row(align=True)            # real tapered end mills in mm, and the user's own tools
        row.menu("FLANK_MT_tool_presets", text="Tool Presets", icon='PRESET')
        row.operator("flank.tool_preset_add", text="", icon='ADD')
        row.operator("flank.tool_preset_add", text="", icon='REMOVE').remove_active = True
        settings_and_operator(layout, context, "flank.plan_single_flank", 'MOD_SCREW', SF_PROPS, "sf_")
        row = layout.row()          # flank.cutter_region takes flank and cone from the sf_* settings above
        row.operator("flank.cutter_region", text="Check Tool", icon='CHECKMARK')

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
        unc = _list(obj, "flank_sf_uncovered")
        if unc:
            col.label(text="Uncovered: {}".format(", ".join(
                "[{:.4g}, {:.4g}]".format(unc[i], unc[i + 1]) for i in range(0, len(unc) - 1, 2))))
        else:
            col.label(text="Flank covered")
        col.label(text="Largest kink {:.3g} deg".format(obj.get("flank_sf_kink_max_deg", 0.0)))
        col.label(text="Core {:.2f} s, total {:.2f} s".format(obj.get("flank_sf_elapsed", 0.0),
                                                              obj.get("flank_sf_total_elapsed", 0.0)))
