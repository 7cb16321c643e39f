# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.render_report -- a report picture (rotor, strips coloured by signed error, legend, title) of a
planning run, rendered headless from the run's stored plan by the same code as ``python -m flank_addon
render`` (``flank_addon.report.report_geometry``).  The render happens in a temporary scene that is removed again:
the file gains no data-block and the user's scenes are not touched."""
import bpy
from bpy.props import EnumProperty, IntProperty, StringProperty

from .runs import run_plan

ENGINE_ITEMS = (
    ("WORKBENCH", "Workbench", "Fast, flat studio lighting; the strips show their exact error colours", 0),
    ("CYCLES", "Cycles (CPU)", "Path traced on the CPU, 16 samples, denoised; slower", 1),
)


class FLANK_OT_render_report(bpy.types.Operator):
    """Render a report PNG of a planning run: the rotor, its strips coloured by signed error, a legend and a
    title with the tolerance and the plan's max / min errors (works without a display; the scene is not
    changed)"""

    bl_idname = "flank.render_report"
    bl_label = "Render Report"
    bl_options = {'REGISTER'}

    filepath: StringProperty(name="PNG File", subtype='FILE_PATH', default="//flank_report.png")
    filter_glob: StringProperty(default="*.png", options={'HIDDEN'})
    collection: StringProperty(name="Run", description="Result collection; empty = the run of the active object, "
                                                       "else the newest run", default="")
    width: IntProperty(name="Width", description="Resolution X in pixels", default=1280, min=64, max=8192)
    height: IntProperty(name="Height", description="Resolution Y in pixels", default=800, min=64, max=8192)
    engine: EnumProperty(name="Engine", items=ENGINE_ITEMS, default="WORKBENCH",
                         description="Render engine (neither needs a GPU)")

    def invoke(self, context, event):
        if bpy.app.background or context.window is None:      # no file browser without a window
            return self.execute(context)
        context.window_manager.fileselect_add(self)
        return {'RUNNING_MODAL'}

    def execute(self, context):
        import os

        from ..flank_addon.io.plan import is_mesh_plan
        from ..flank_addon.report.report_geometry import display_units
        from .report_scene import render_freeform_report, render_plan_report

        found = run_plan(context, self.collection)
        if isinstance(found, str):
            self.report({'ERROR'}, "Render report: " + found)
            return {'CANCELLED'}
        coll, plan = found
        if not self.filepath:
            self.report({'ERROR'}, "Render report: no file given (filepath is empty)")
            return {'CANCELLED'}
        path = bpy.path.abspath(self.filepath)
        if not path.lower().endswith(".png"):
            path += ".png"
        us = context.scene.unit_settings
        try:
            if is_mesh_plan(plan):
                from ..flank_addon.report.freeform_geometry import freeform_title

                units = display_units(plan, us.system, us.scale_length,
                                      scale=float(coll.get("flank_ff_length_scale", 1.0) or 1.0))
                info = render_freeform_report(plan, path, width=int(self.width), height=int(self.height),
                                              engine=self.engine, units=units,
                                              title=freeform_title(plan, coll.name))
            else:
                units = display_units(plan, us.system, us.scale_length)
                info = render_plan_report(plan, path, width=int(self.width), height=int(self.height),
                                          engine=self.engine, units=units,
                                          title="{}: {}".format(coll.name, plan.get("method", "")))
        except Exception as ex:                     # reported, never a traceback; nothing is left behind
            self.report({'ERROR'}, "Render report of '{}' failed: {}".format(coll.name, ex))
            return {'CANCELLED'}
        self.report({'INFO'}, "Report of '{}' written to {} ({} x {}, {}, {:.1f} s): {}".format(
            coll.name, os.path.abspath(path), info["width"], info["height"], info["engine"].title(),
            info["seconds"], info["title"][1]))
        return {'FINISHED'}


classes = (FLANK_OT_render_report,)
register, unregister = bpy.utils.register_classes_factory(classes)
