# SPDX-License-Identifier: GPL-3.0-or-later
"""Results panel: the strips of a planning run (pick a row to select its tool and envelope; each row names its
tool where the plan names tools), the error legend in the scene's unit, a single-flank run's verified covered
fraction and uncovered ranges with their reasons, the cycle time of its posted program, export / animate /
report."""
import textwrap

import bpy

from .common import CATEGORY, REGION, SPACE, draw_lines

# legend swatch -> (multiple of the tolerance it shows, band name under it)
LEGEND = (("gouge_deep", -10.0), ("gouge", -1.0), ("ok", 0.0), ("stock", 1.0), ("stock_deep", 10.0))
KIND_TEXT = {"material": "material left", "overcut": "overcut", "unreached": "no tool reaches it"}
REASON_WIDTH = 52              # characters per line of a reason
REASON_LINES = 4               # lines of one reason at most (the run's summary keeps all of it)
RESIDUAL_ROWS = 6              # uncovered ranges listed at most


def draw_coverage(layout, info, ln):
    """A single-flank run's verified covered fraction and its uncovered ranges (share of the flank, kind, worst
    deviation, the reason wrapped into a few lines).  ``ln``: a length in scene units -> text."""
    frac = info.get("covered_fraction")
    residual = info.get("residual") or []
    if frac is None:                                          # a run made before the residual was stored
        if info["uncovered"]:
            layout.label(text="Uncovered: " + ", ".join("{:.0f}–{:.0f} %".format(100.0 * a, 100.0 * b)
                                                        for a, b in info["uncovered"]) + " of the flank",
                         icon='ERROR')
        return
    layout.label(text="Covered {:.1f} % of the flank within tolerance".format(100.0 * frac),
                 icon='CHECKMARK' if not residual else 'ERROR')
    for r in residual[:RESIDUAL_ROWS]:
        col = layout.column(align=True)
        worst = r.get("max_deviation") if r.get("kind") == "material" else r.get("min_deviation")
        col.label(text="{:.1f}–{:.1f} %: {}{}".format(100.0 * float(r["start"]), 100.0 * float(r["end"]),
                                                     KIND_TEXT.get(r.get("kind"), str(r.get("kind"))),
                                                     ", {}".format(ln(float(worst))) if worst is not None else ""),
                  icon='DOT')
        lines = textwrap.wrap(str(r.get("reason", "")), REASON_WIDTH) or ["(no reason recorded)"]
        if len(lines) > REASON_LINES:
            lines = lines[:REASON_LINES - 1] + [lines[REASON_LINES - 1] + " …"]
        for line in lines:
            col.label(text="    " + line)
    if len(residual) > RESIDUAL_ROWS:
        layout.label(text="… {} more uncovered ranges (the run's summary lists all)".format(
            len(residual) - RESIDUAL_ROWS))


class FLANK_PT_results(bpy.types.Panel):
    bl_idname = "FLANK_PT_results"
    bl_label = "Results"
    bl_space_type = SPACE
    bl_region_type = REGION
    bl_category = CATEGORY
    bl_order = 20

    def draw(self, context):
        from ..operators.post_program import cycle_time_lines
        from ..operators.runs import find_run
        from ..operators.strips import strip_rows
        from ..operators.units import length_text

        layout = self.layout
        settings = getattr(context.scene, "flank_settings", None)
        coll = find_run(context)
        if isinstance(coll, str):
            layout.label(text="No planning run yet", icon='INFO')
            return
        layout.menu("FLANK_MT_runs", text=coll.name, icon='OUTLINER_COLLECTION')
        if settings is not None:
            layout.template_list("FLANK_UL_strips", "", coll, "objects", settings, "results_strip_index", rows=4)
        info = strip_rows(coll)
        pre = info["pre"] if info else ("flank_sf_" if "flank_sf_tolerance" in coll else "flank_df_")
        unit, scale = (info["unit"], info["scale"]) if info else ("mm", 1.0)
        tol = float(coll.get(pre + "tolerance", 0.0) or 0.0)
        scene = context.scene

        def ln(v, signed=True):
            return length_text(v, scene, unit, scale, signed=signed)

        box = layout.box()
        box.label(text="Signed error, + = material left (tolerance {})".format(ln(tol, False) if tol > 0 else "?"),
                  icon='COLOR')
        if settings is not None:
            row = box.row(align=True)
            for key, k in LEGEND:
                col = row.column(align=True)
                col.prop(settings, "legend_" + key, text="")
                col.label(text=("≤ " if k < -1 else "≥ " if k > 1 else "") + (ln(k * tol) if tol > 0 else
                                                                             "{:+g} tol".format(k)))
            row = box.row(align=True)
            row.label(text="overcut")
            row.label(text="within tolerance")
            row.label(text="material left")
        if info and info["pre"] == "flank_sf_":
            draw_coverage(box, info, ln)
        mx, mn = coll.get(pre + "max_error"), coll.get(pre + "min_error")
        if mx is not None and mn is not None:
            box.label(text="Run: max {}  min {}".format(ln(float(mx)), ln(float(mn))))
        if pre == "flank_ff_":
            box.label(text="Kinks between strips: max {:.3g}°, mean {:.3g}°".format(
                float(coll.get(pre + "max_kink_deg", 0.0)), float(coll.get(pre + "mean_kink_deg", 0.0))),
                icon='MOD_SMOOTH')
        draw_lines(box, cycle_time_lines(coll), {1: 'TIME'})      # after Post Program (Machine panel)
        col = layout.column(align=True)
        op = col.operator("flank.animate_strip", icon='PLAY')
        op.collection = coll.name
        idx = int(settings.results_strip_index) if settings is not None else -1
        ob = coll.objects[idx] if 0 <= idx < len(coll.objects) else None
        key = pre + ("path" if pre == "flank_df_" else "strip")
        op.strip = int(ob.get(key, 0)) + 1 if ob is not None else 1
        row = col.row(align=True)
        for fmt, label in (("CL", "CL"), ("PLAN", "Plan"), ("CSV", "CSV"), ("STL", "STL"), ("PLY", "PLY")):
            e = row.operator("flank.export_results", text=label, icon='EXPORT' if fmt == "CL" else 'NONE')
            e.format, e.collection = fmt, coll.name
        col.operator("flank.render_report", icon='RENDER_STILL').collection = coll.name
        if pre != "flank_ff_":                  # a free-form run has no flank profile
            col.operator("flank.error_plot", icon='GRAPH').collection = coll.name


classes = (FLANK_PT_results,)
register, unregister = bpy.utils.register_classes_factory(classes)
