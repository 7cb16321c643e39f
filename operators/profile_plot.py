# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.error_plot -- the signed machining error along the flank profile of a planning run as an image.

The data are the verify engine's deviation on the run's target flanks (the numbers of the error-profile CSV
export: ``flank_addon.report.error_chart.error_profile``), drawn by ``flank_addon.report.error_chart`` (numpy:
axes, bands, curves) with its text in Blender's font (``chart_text``) into the image "Flank Error Plot (<run>)"
-- packed into the .blend, kept with a fake user, replaced in place by the next plot of the same run -- and
shown in an Image Editor when the screen has one."""
import math
import os
import time

import bpy
from bpy.props import BoolProperty, IntProperty, StringProperty

from .chart_text import fill_text, text_outlines
from .common import check_filepath
from .modal import ModalPlannerMixin
from .runs import PlanNeeded, run_plan

IMAGE_PREFIX = "Flank Error Plot"
RUN_PROP = "flank_plot_run"            # image custom property: the run (collection name) the plot shows
PROP_PREFIX = "flank_plot_"
TOLERANCE_PROPS = ("flank_sf_tolerance", "flank_df_tolerance")   # run collection, scene units


MAX_NAME_BYTES = 63                   # longest ID name of bpy 4.2 (5.x allows 255): the same name everywhere


def image_name(run_name):
    """'Flank Error Plot (<run>)'; a run name too long for an ID name is shortened in its middle ('…')."""
    name = "{} ({})".format(IMAGE_PREFIX, run_name)
    if len(name.encode("utf-8")) <= MAX_NAME_BYTES:
        return name
    room = MAX_NAME_BYTES - len("{} (…)".format(IMAGE_PREFIX).encode("utf-8"))
    head, tail = run_name[:(room + 1) // 2], run_name[len(run_name) - room // 2:]
    while len("{} ({}…{})".format(IMAGE_PREFIX, head, tail).encode("utf-8")) > MAX_NAME_BYTES:
        if len(head) >= len(tail):
            head = head[:-1]
        else:
            tail = tail[1:]
    return "{} ({}…{})".format(IMAGE_PREFIX, head, tail)


def plot_image(run_name):
    """The image an earlier plot of the run made (found by its custom property, else by its name), or None."""
    for img in bpy.data.images:
        if img.get(RUN_PROP) == run_name:
            return img
    return bpy.data.images.get(image_name(run_name))


def run_tolerance(coll, plan):
    """The run's tolerance in plan units (the planner's, kept on the collection in scene units), or None
    (then the plan's own ``tolerance`` field or verify's default)."""
    from ..flank_addon.report.report_geometry import plan_scale

    for key in TOLERANCE_PROPS:
        v = coll.get(key)
        try:
            v = float(v)
        except (TypeError, ValueError):
            continue
        if math.isfinite(v) and v > 0.0:
            return v / plan_scale(plan)
    return None


def show_in_image_editor(context, img):
    """Show ``img`` in the first Image Editor of the active window, else of any window; the area or None."""
    wm = context.window_manager
    windows = [context.window] if context.window is not None else []
    windows += [w for w in wm.windows if w not in windows]
    for win in windows:
        screen = win.screen
        if screen is None:
            continue
        for area in screen.areas:
            if area.type == 'IMAGE_EDITOR':
                area.spaces.active.image = img
                area.tag_redraw()
                return area
    return None


class _PlotError(Exception):
    """A failure of the plot with the message to report as it is."""


class FLANK_OT_error_plot(ModalPlannerMixin, bpy.types.Operator):
    """Plot the signed error along the target flank profile of a planning run (simulated by the verify
    engine from the run's plan; + = material left, - = overcut) with the tolerance band, one curve per strip,
    into an image shown in an Image Editor"""

    bl_idname = "flank.error_plot"
    bl_label = "Error Plot"
    bl_options = {'REGISTER', 'UNDO'}
    _title = "Error plot"

    # a dict, not class annotations: the same properties, and pyflakes does not read their strings as types
    __annotations__ = dict(
        collection=StringProperty(name="Run", description="Result collection; empty = the run of the active "
                                                          "object, else the newest run", default=""),
        width=IntProperty(name="Width", description="Image width in pixels", default=960, min=320, max=4096),
        height=IntProperty(name="Height", description="Image height in pixels", default=540, min=200, max=4096),
        per_strip=BoolProperty(name="Per Strip", description="One curve per strip, broken where the next strip "
                                                             "forms the surface; off: one combined curve",
                               default=True),
        fit_data=BoolProperty(name="Fit Errors", description="Scale the error axis to the errors alone (the "
                                                             "tolerance band may leave the chart)", default=False),
        filepath=StringProperty(name="PNG File", description="Also write the plot to this PNG (empty: no file)",
                                subtype='FILE_PATH', default=""),
    )

    def _png_path(self):
        """(the PNG to write or None, error message or None)."""
        if not self.filepath:
            return None, None
        path, msg = check_filepath(self.filepath, "PNG file")     # a folder is refused, not '<folder>.png'
        if msg is not None:
            return None, msg
        return (path if path.lower().endswith(".png") else path + ".png"), None

    def _inputs(self, context):
        """(collection, plan, PNG path or None), or an error message."""
        w, h = int(self.width), int(self.height)
        if not (320 <= w <= 4096 and 200 <= h <= 4096):
            return "size {} x {} is outside 320 x 200 .. 4096 x 4096".format(w, h)
        found = run_plan(context, self.collection, defer=self._defer_analysis)
        if isinstance(found, (str, PlanNeeded)):
            return found
        coll, plan = found
        if "rotor" not in plan:
            return ("'{}' is a free-form run: it has no flank profile to plot the error along (export its error "
                    "CSV instead)".format(coll.name))
        path, msg = self._png_path()
        return msg if msg is not None else (coll, plan, path)

    def _compute_failed(self, ex):
        if isinstance(ex, _PlotError):
            return str(ex)
        return ModalPlannerMixin._compute_failed(self, ex)

    # ------------------------------------------------------------------ main thread: inputs
    def _prepare(self, context):
        """The run, its plan, the units and the PNG path -> job, or None (error reported)."""
        from ..flank_addon.report.report_geometry import display_units

        t0 = time.perf_counter()
        found = self._inputs(context)
        if isinstance(found, PlanNeeded):
            return self._read_first(found)           # a long plan not read yet: in a worker first
        if isinstance(found, str):
            self.report({'ERROR'}, "Error plot: " + found)
            return None
        coll, plan, path = found
        us = context.scene.unit_settings
        try:
            units = display_units(plan, us.system, us.scale_length)
            tolerance = run_tolerance(coll, plan)
        except Exception as ex:             # core ValueError: reported, never a traceback
            self.report({'ERROR'}, "Error plot of '{}' failed: {}".format(coll.name, ex))
            return None
        return dict(t0=t0, coll_name=coll.name, plan=plan, path=path, units=units, tolerance=tolerance,
                    width=int(self.width), height=int(self.height), per_strip=bool(self.per_strip),
                    fit_data=bool(self.fit_data), title="Error along profile: {}".format(coll.name))

    # ------------------------------------------------------------------ worker thread
    @staticmethod
    def _compute(job, progress):
        """The verify engine's deviation along the target flanks and the chart's pixels (no Blender data)."""
        from ..flank_addon.progress import Cancelled, reporter
        from ..flank_addon.report.error_chart import error_profile, plan_error_plot
        from ..flank_addon.simulation.verify import verify_plan

        plan, tol = job["plan"], job["tolerance"]
        try:
            if "rotor" in plan:      # error_profile refuses free-form plans with its own message
                verification = verify_plan(plan, tolerance=tol if tol is not None else plan.get("tolerance"),
                                           progress=reporter(progress, 0.0, 0.9))
            else:
                verification = None
            data = error_profile(plan, tolerance=tol, verification=verification)
            reporter(progress)(0.9, "drawing")
            return plan_error_plot(plan, units=job["units"], width=job["width"], height=job["height"],
                                   per_strip=job["per_strip"], tolerance=tol, fit_data=job["fit_data"],
                                   title=job["title"], data=data)
        except Cancelled:
            raise
        except Exception as ex:             # core ValueError (no finite error, ...): reported, never a traceback
            raise _PlotError("Error plot of '{}' failed: {}".format(job["coll_name"], ex))

    # ------------------------------------------------------------------ main thread: the text's outlines
    def _next_stage(self, context, job, out):
        """After the chart: Blender lays out its text (the main thread's part, a few ms per item); a second worker
        fills the glyphs in and encodes the PNG, so the build only stores it."""
        if job.get("outlined"):
            return None
        job["outlined"] = True
        rgba, info = out
        try:
            outlines = text_outlines(info["texts"])
        except Exception as ex:            # Blender's text layout failed: reported, nothing made
            self.report({'ERROR'}, "Error plot of '{}' failed: {}: {}".format(job["coll_name"], type(ex).__name__, ex))
            return False

        def finish_png(progress):
            from ..flank_addon.io.png import png_bytes
            from ..flank_addon.progress import reporter
            from ..flank_addon.report.error_chart import to_png_bytes

            reporter(progress)(0.95, "text and PNG")
            fill_text(rgba, info["texts"], outlines)
            return info, png_bytes(to_png_bytes(rgba))

        return finish_png

    # ------------------------------------------------------------------ main thread: results
    def _build(self, context, job, out):
        """The image and the PNG of the finished chart; the image shown; the report."""
        info, png = out
        w, h, path = job["width"], job["height"], job["path"]
        coll = bpy.data.collections.get(job["coll_name"])
        if coll is None:
            self.report({'ERROR'}, "Error plot: the run '{}' was removed while plotting".format(job["coll_name"]))
            return {'CANCELLED'}
        img = self._store(coll, info, png, path)
        if img is None:
            return {'CANCELLED'}
        area = show_in_image_editor(context, img)
        where = ("shown in the Image Editor" if area is not None else
                 "open an Image Editor and pick the image '{}'".format(img.name))
        self.report({'INFO'}, "Error plot of '{}' ({} x {} px, {}): {}; tolerance ±{:.3g} {}; {}{} ({:.2f} s)".format(
            coll.name, w, h, "{} curve(s)".format(info["curves"]), info["note"], info["tolerance"], info["unit"],
            where, ", wrote {}".format(os.path.basename(path)) if path else "", time.perf_counter() - job["t0"]))
        return {'FINISHED'}

    def _store(self, coll, info, png, path):
        """The PNG file, then the image (made or reused) holding the same PNG, packed -> image, or None (error
        reported, nothing left behind)."""
        from ..flank_addon.io.files import atomic_write

        wrote = False
        img = plot_image(coll.name)
        created = img is None
        try:
            if path is not None:
                atomic_write(path, png)
                wrote = True
            if created:       # 1 x 1: its size and pixels come from the PNG packed next
                img = bpy.data.images.new(image_name(coll.name), 1, 1, alpha=True)
            # the image is the worker's PNG, packed into the .blend as it is: Blender reads its pixels from there
            # (as from a packed image file) when they are drawn.  Packing pixels set here instead would encode them
            # again on the main thread (0.09-0.16 s at 1920 x 1080).  Switching the source to generated and back
            # makes a reused image read the new PNG (reload() would first look for a file on disk and complain)
            img.pack(data=png, data_len=len(png))
            img.source = 'GENERATED'
            img.source = 'FILE'
            img.use_fake_user = True
            lay = info["layout"]
            props = dict(run=coll.name, unit=info["unit"], tolerance=float(info["tolerance"]),
                         max_error=float(info["max_error"]), min_error=float(info["min_error"]),
                         points=int(info["points"]), finite_points=int(info["finite_points"]),
                         curves=int(info["curves"]), per_strip=bool(self.per_strip),
                         box=[int(v) for v in lay["box"]], x_range=[float(v) for v in lay["x_range"]],
                         y_range=[float(v) for v in lay["y_range"]], y_factor=float(lay["y_factor"]))
            for key, value in props.items():
                img[PROP_PREFIX + key] = value
        except Exception as ex:
            if created and img is not None:
                bpy.data.images.remove(img)
            if wrote:
                try:
                    os.remove(path)
                except OSError:
                    pass
            self.report({'ERROR'}, "Error plot of '{}' failed: {}: {}".format(coll.name, type(ex).__name__, ex))
            return None
        return img


classes = (FLANK_OT_error_plot,)
register, unregister = bpy.utils.register_classes_factory(classes)
