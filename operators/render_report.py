# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.render_report -- a report picture (rotor, strips coloured by signed error, legend, title) of a
planning run, rendered headless from the run's stored plan by the same code as ``python -m flank_addon
render`` (``flank_addon.report.report_geometry``).  The render happens in a temporary scene that is removed again:
the file gains no data-block and the user's scenes are not touched."""
import os
import time

import bpy
from bpy.props import BoolProperty, EnumProperty, IntProperty, StringProperty

from .common import check_filepath
from .modal import ModalPlannerMixin, next_turn
from .runs import PlanNeeded, run_plan

ENGINE_ITEMS = (
    ("WORKBENCH", "Workbench", "Fast, flat studio lighting; the strips show their exact error colours", 0),
    ("CYCLES", "Cycles (CPU)", "Path traced on the CPU, 16 samples, denoised, by a second Blender in the "
                               "background (Esc stops it); slower", 1),
)


class FLANK_OT_render_report(ModalPlannerMixin, bpy.types.Operator):
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
    # set by invoke: after the file browser the geometry is computed in a worker thread (execute alone, from
    # scripts and in the background, runs all of it at once)
    modal_after_browser: BoolProperty(default=False, options={'HIDDEN', 'SKIP_SAVE'})
    _title = "Render report"
    _run_name = ""                   # the run, once _prepare has found it (a failure before names none)

    def invoke(self, context, event):
        if bpy.app.background or context.window is None:      # no file browser without a window
            return self.execute(context)
        self.modal_after_browser = True
        context.window_manager.fileselect_add(self)
        return {'RUNNING_MODAL'}

    def _compute_failed(self, ex):
        return "Render report of '{}' failed: {}".format(self._run_name, ex)

    def _prepare(self, context):
        """The run's plan, the checked size, engine and file, the units and title (the main thread)."""
        from ..flank_addon.io.plan import is_mesh_plan
        from ..flank_addon.io.png import check_output
        from ..flank_addon.report.report_geometry import check_render_args, display_units

        found = run_plan(context, self.collection, defer=self._defer_analysis)
        if isinstance(found, PlanNeeded):
            return self._read_first(found)           # a long plan not read yet: in a worker first
        if isinstance(found, str):
            self.report({'ERROR'}, "Render report: " + found)
            return None
        coll, plan = found
        self._run_name = coll.name
        if not self.filepath:
            self.report({'ERROR'}, "Render report: no file given (filepath is empty)")
            return None
        # a relative path (the default //flank_report.png in an unsaved file) and a folder are refused
        path, msg = check_filepath(self.filepath, "PNG file")
        if msg is not None:
            self.report({'ERROR'}, "Render report: " + msg)
            return None
        if not path.lower().endswith(".png"):
            path += ".png"
        try:
            engine = check_render_args(int(self.width), int(self.height), None, self.engine)
            path = check_output(path)
        except ValueError as ex:
            self.report({'ERROR'}, "Render report of '{}' failed: {}".format(coll.name, ex))
            return None
        us = context.scene.unit_settings
        mesh_plan = is_mesh_plan(plan)
        if mesh_plan:
            from ..flank_addon.report.freeform_geometry import freeform_title

            units = display_units(plan, us.system, us.scale_length,
                                  scale=float(coll.get("flank_ff_length_scale", 1.0) or 1.0))
            title = freeform_title(plan, coll.name)
        else:
            units = display_units(plan, us.system, us.scale_length)
            title = "{}: {}".format(coll.name, plan.get("method", ""))
        return dict(t0=time.perf_counter(), plan=plan, run=coll.name, path=path, width=int(self.width),
                    height=int(self.height), engine=engine, units=units, title=title, mesh_plan=mesh_plan)

    def _compute(self, job, progress):
        """The picture without Blender data: geometry, exact strip distances and colours, camera, legend (a
        worker thread when run from the UI)."""
        from ..flank_addon.progress import reporter
        from ..flank_addon.report import report_geometry as rg

        report = reporter(progress)
        report(0.0, "strip distances")
        plan = job["plan"]
        if job["mesh_plan"]:
            from ..flank_addon.report.freeform_geometry import freeform_geometry

            geo = freeform_geometry(plan, None)
        else:
            geo = rg.report_geometry(plan)
        report(0.8, "camera and legend")
        picture = rg.report_picture(geo, job["width"], job["height"], title=job["title"], units=job["units"],
                                    engine=job["engine"])
        report(1.0, "scene")
        return picture

    # ------------------------------------------------------------------ main thread: Blender's turns
    def _next_stage(self, context, job, out):
        """Blender's part in short turns of the main thread, back to the UI after each (``next_turn``): the
        temporary scene; the labels' layout in Blender's font; a render of 16 x 10 pixels that prepares the
        meshes for drawing; then one turn per tile of the picture (Workbench: at most 256,000 pixels each,
        ``report_scene.report_tiles``), each rendered and read back as raw pixels; after the last the scene is
        removed.  Cycles renders in a separate Blender instead (:meth:`_cycles_stage`).  The last worker puts the
        tiles together, smooths the edges, paints the legend, fills the labels in and encodes the PNG, so the
        build only writes the file.  A failure here is reported by the mixin (:meth:`_compute_failed`), which
        then discards the scene."""
        from .report_scene import (report_png, report_scene_labels, report_scene_prepare,
                                   report_scene_render, report_scene_start, report_tiles, tiled_pixels)

        if "picture" not in job:                          # the worker's picture: make its scene
            job["picture"] = out
            job["scene"] = report_scene_start(out, job["path"])          # removes what it made if it fails
            job["tiles"], job["pieces"] = report_tiles(out), []
            return next_turn()
        state = job.get("scene")
        if state is None:
            return None
        if "labels" not in state:                         # the labels' layout
            report_scene_labels(state, job["picture"])
            return next_turn()
        if job["picture"]["info"]["engine"] == "CYCLES":
            return self._cycles_stage(job, state)
        if not state.get("prepared"):
            report_scene_prepare(state)
            state["prepared"] = True
            return next_turn()
        tile = job["tiles"][len(job["pieces"])]
        job["pieces"].append((tile, report_scene_render(state, tile)))
        if len(job["pieces"]) < len(job["tiles"]):
            if self._timer is not None:                   # a modal run: the status bar says how far it is
                self._status(context, "{}: rendered {} of {} tiles  (Esc cancels)".format(
                    self._title, len(job["pieces"]), len(job["tiles"])))
            return next_turn()
        self._discard(job)
        picture, labels, pieces = job["picture"], state["labels"], job["pieces"]

        def finish(progress):
            rgba = tiled_pixels(pieces, picture["width"], picture["height"])
            return report_png(picture, rgba, labels)
        return finish

    def _cycles_stage(self, job, state):
        """Cycles: the scene goes to a .blend file and is removed at once; the last worker renders that file in
        a separate Blender (``report_process``: Esc kills it), then finishes the PNG as for Workbench."""
        import sys

        from .report_process import render_in_child
        from .report_scene import report_png, report_scene_file, tga_pixels
        from ..flank_addon.progress import reporter

        blend, scene = report_scene_file(state)
        out = state["tmp"][:-len(".tga")] + ".cycles.tga"
        self._discard(job)
        picture, labels = job["picture"], state["labels"]
        binary, python = bpy.app.binary_path, sys.executable

        notes = job.setdefault("notes", [])            # e.g. a Blender that cannot denoise renders without

        def finish(progress):
            data = render_in_child(blend, scene, out, reporter(progress), binary, python, notes=notes)
            return report_png(picture, tga_pixels(data, picture["width"], picture["height"]), labels)
        return finish

    def _discard(self, job):
        if job and job.get("scene") is not None:
            from .report_scene import report_scene_end

            report_scene_end(job["scene"])
            job["scene"] = None

    def _build(self, context, job, out):
        """Write the finished PNG (the scene is gone already)."""
        from ..flank_addon.io.files import atomic_write

        png, info = out
        try:
            atomic_write(job["path"], png)
        except OSError as ex:                         # reported, never a traceback
            self.report({'ERROR'}, self._compute_failed(ex))
            return {'CANCELLED'}
        self.report({'INFO'}, "Report of '{}' written to {} ({} x {}, {}, {:.1f} s): {}{}".format(
            job["run"], os.path.abspath(job["path"]), info["width"], info["height"], info["engine"].title(),
            time.perf_counter() - job["t0"], info["title"][1],
            "".join("; " + note for note in job.get("notes", ()))))
        return {'FINISHED'}


classes = (FLANK_OT_render_report,)
register, unregister = bpy.utils.register_classes_factory(classes)
