# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.render_report -- a report picture (rotor, strips coloured by signed error, legend, title) of a
planning run, rendered headless from the run's stored plan by the same code as ``python -m flank_addon
render`` (``flank_addon.report_render``)."""
import bpy
from bpy.props import IntProperty, StringProperty

from .export import run_plan


class FLANK_OT_render_report(bpy.types.Operator):
    """Render a report PNG of a planning run (Workbench, works without a display); the scene is not changed"""

    bl_idname = "flank.render_report"
    bl_label = "Render Report"
    bl_options = {'REGISTER'}

    filepath: StringProperty(name="PNG File", subtype='FILE_PATH', default="//flank_report.png")
    collection: StringProperty(name="Run", description="Result collection; empty = the run of the active object, "
                                                       "else the newest run", default="")
    width: IntProperty(name="Width", default=1280, min=64, max=8192)
    height: IntProperty(name="Height", default=800, min=64, max=8192)

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {'RUNNING_MODAL'}

    def execute(self, context):
        import os

        from ..flank_addon.report_render import render_plan_report

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
        try:
            info = render_plan_report(bpy, plan, path, width=int(self.width), height=int(self.height))
        except Exception as ex:                     # reported, never a traceback; nothing is left behind
            self.report({'ERROR'}, "Render report of '{}' failed: {}: {}".format(coll.name, type(ex).__name__, ex))
            return {'CANCELLED'}
        self.report({'INFO'}, "Report of '{}' written to {} ({} x {}, {:.1f} s): {}".format(
            coll.name, os.path.basename(path), info["width"], info["height"], info["seconds"], info["title"][1]))
        return {'FINISHED'}


classes = (FLANK_OT_render_report,)
