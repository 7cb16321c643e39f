# SPDX-License-Identifier: GPL-3.0-or-later
"""Results panel: the strips of the current planning run, the error legend, export / animate / report."""
import bpy


def _length(v, mm_per_unit):
    """A scene length as people read it: µm below 1 mm, else mm (unit-less scenes count as mm)."""
    mm = v * mm_per_unit
    return "{:.3g} µm".format(1000.0 * mm) if abs(mm) < 1.0 else "{:.4g} mm".format(mm)


class FLANK_PT_results(bpy.types.Panel):
    bl_idname = "FLANK_PT_results"
    bl_label = "Results"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "Flank"
    bl_order = 20

    def draw(self, context):
        from ..operators.export import find_run
        from ..operators.ui_ops import mm_per_scene_unit

        layout = self.layout
        settings = getattr(context.scene, "flank_settings", None)
        coll = find_run(context)
        if isinstance(coll, str):
            layout.label(text="No planning run yet", icon='INFO')
            return
        layout.label(text=coll.name, icon='OUTLINER_COLLECTION')
        if settings is not None:
            layout.template_list("FLANK_UL_strips", "", coll, "objects", settings, "results_strip_index", rows=4)
        pre = "flank_sf_" if "flank_sf_tolerance" in coll else "flank_df_"
        tol = float(coll.get(pre + "tolerance", 0.0) or 0.0)
        k = mm_per_scene_unit(context.scene)
        box = layout.box()
        box.label(text="Signed error (+ = material left)")
        if settings is not None:
            for key, text in (("gouge", "overcut  < -{}"), ("ok", "within  ±{}"), ("stock", "material left  > +{}")):
                row = box.row()
                row.scale_x = 0.3
                row.prop(settings, "legend_" + key, text="")
                row.scale_x = 1.0
                row.label(text=text.format(_length(tol, k)) if tol > 0 else text.format("tol"))
        mx, mn = coll.get(pre + "max_error"), coll.get(pre + "min_error")
        if mx is not None and mn is not None:
            box.label(text="max {}  min {}".format(_length(float(mx), k), _length(float(mn), k)))
        col = layout.column(align=True)
        op = col.operator("flank.animate_strip", icon='PLAY')
        op.collection = coll.name
        idx = int(settings.results_strip_index) if settings is not None else -1
        ob = coll.objects[idx] if 0 <= idx < len(coll.objects) else None
        op.strip = int(ob.get(pre + "strip", 0)) + 1 if ob is not None else 1
        row = col.row(align=True)
        for fmt, label in (("CL", "CL"), ("PLAN", "Plan"), ("CSV", "CSV"), ("STL", "STL")):
            e = row.operator("flank.export_results", text=label, icon='EXPORT' if fmt == "CL" else 'NONE')
            e.format, e.collection = fmt, coll.name
        col.operator("flank.render_report", icon='RENDER_STILL').collection = coll.name
