# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.export_results -- write a result run (its stored flank-plan/1) as plan JSON, CL data, error CSV or
strip meshes, through the core writers of ``flank_addon.exports`` (the same files as ``python -m flank_addon
export``)."""
import math
import os
import shutil
import tempfile
import time

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatVectorProperty, IntProperty, StringProperty
from bpy_extras.io_utils import ExportHelper

from .common import check_filepath
from .modal import ModalPlannerMixin
from .runs import PlanNeeded, run_plan

FORMAT_ITEMS = (
    ("PLAN", "Plan (JSON)", "The run's flank-plan/1 file", 0),
    ("CL", "CL Data (APT)", "GOTO/x,y,z,i,j,k tool tip and axis per step in the rotor frame, with the rotor "
                            "angle A and the axial feed per step (see README)", 1),
    ("CSV", "Error Profile (CSV)", "Machined deviation along the target flanks' profile (verify engine)", 2),
    ("STL", "Strips (STL)", "Envelope strips as binary STL, one file per strip: <name>_<k>.stl", 3),
    ("PLY", "Strips (PLY)", "Envelope strips as PLY, one file per strip: <name>_<k>.ply", 4),
)
EXTENSIONS = {"PLAN": ".json", "CL": ".apt", "CSV": ".csv", "STL": ".stl", "PLY": ".ply"}


class FLANK_OT_export_results(ModalPlannerMixin, bpy.types.Operator, ExportHelper):
    """Export a planning run: its plan, CL data, error profile or envelope strips (rotor frame, plan units)"""

    bl_idname = "flank.export_results"
    bl_label = "Export Flank Results"
    bl_options = {'REGISTER'}
    _run_name = ""

    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json;*.apt;*.cl;*.csv;*.stl;*.ply", options={'HIDDEN'})
    format: EnumProperty(name="Format", items=FORMAT_ITEMS, default="CL")
    collection: StringProperty(name="Run", description="Result collection to export; empty = the run of the active "
                                                       "object, else the newest run", default="")
    strip: IntProperty(name="Strip", description="Strip number as in the object names (1 = first); 0 = all strips "
                                                 "(CL, STL, PLY)", default=0, min=0)
    steps: IntProperty(name="Steps", description="CL steps (and envelope rings) per strip over the z range "
                                                 "(1..100000)", default=360, min=1)
    use_z_range: BoolProperty(name="Z Range", description="Use the tool tip's rotor-frame z range below instead of "
                                                          "one lead [0, 2 pi v0] (CL, STL, PLY; as --z-range)",
                              default=False)
    z_range: FloatVectorProperty(name="Z0, Z1", description="Rotor-frame z range of the tool tip in the plan's "
                                                            "length unit, Z0 < Z1", size=2, default=(0.0, 1.0))

    # set by invoke: after the file browser the export runs modal like the planners (the error profile verifies
    # the plan: 0.35 s for a double-flank run); a script's call (execute) writes before it returns
    modal_after_browser: BoolProperty(default=False, options={'HIDDEN', 'SKIP_SAVE'})
    _title = "Export"

    def invoke(self, context, event):
        self.filename_ext = EXTENSIONS[self.format]
        self.modal_after_browser = True
        return ExportHelper.invoke(self, context, event)

    def check(self, context):
        self.filename_ext = EXTENSIONS[self.format]
        return ExportHelper.check(self, context)

    def _compute_failed(self, ex):
        return "Export of '{}' failed: {}: {}".format(self._run_name, type(ex).__name__, ex)

    def _prepare(self, context):
        """The run's plan and the checked options (the main thread)."""
        if not self.filepath:
            self.report({'ERROR'}, "Export: no file given (filepath is empty)")
            return None
        if not 1 <= int(self.steps) <= 100000:
            self.report({'ERROR'}, "Export: steps = {} is outside the limits 1..100000".format(int(self.steps)))
            return None
        z_range = None
        if self.use_z_range:
            # single-precision property: the decimals that were typed (7 digits)
            z_range = tuple(float("{:.7g}".format(v)) for v in self.z_range)
            if not all(math.isfinite(v) for v in z_range) or not z_range[1] > z_range[0]:
                self.report({'ERROR'}, "Export: the z range {:g} .. {:g} must be finite with Z0 < Z1".format(
                    *z_range))
                return None
        found = run_plan(context, self.collection, defer=self._defer_analysis)
        if isinstance(found, PlanNeeded):
            return self._read_first(found)           # a long plan not read yet: in a worker first
        if isinstance(found, str):
            self.report({'ERROR'}, "Export: " + found)
            return None
        coll, plan = found
        self._run_name = coll.name
        n = len(plan["strips"])
        strip = int(self.strip)
        if strip > n:
            self.report({'ERROR'}, "Export: strip = {} does not exist: run '{}' has strips 1..{}".format(
                strip, coll.name, n))
            return None
        path, msg = check_filepath(self.filepath, "export file")
        if msg is not None:
            self.report({'ERROR'}, "Export: " + msg)
            return None
        folder = os.path.dirname(path)
        return dict(t0=time.perf_counter(), plan=plan, run=coll.name, n=n, k=None if strip == 0 else strip - 1,
                    fmt=self.format, steps=int(self.steps), z_range=z_range, path=path, folder=folder)

    def _compute(self, job, progress):
        """The file's content: text, or the strips' meshes (a worker thread when run from the UI; nothing is
        written here, so a cancelled export leaves no file behind)."""
        from ..flank_addon import exports
        from ..flank_addon.io.plan import plan_text
        from ..flank_addon.progress import reporter

        report = reporter(progress)
        plan, fmt, k = job["plan"], job["fmt"], job["k"]
        report(0.0, {"PLAN": "plan", "CL": "CL data", "CSV": "verifying the plan"}.get(fmt, "envelope strips"))
        if fmt == "PLAN":
            return dict(text=plan_text(plan), what="plan, {} strips".format(job["n"]))
        if fmt == "CL":
            text = exports.cl_data(plan, strip=k, steps=job["steps"], z_range=job["z_range"])
            return dict(text=text, what="CL data, {} GOTO steps".format(text.count("\nGOTO/")))
        if fmt == "CSV":
            text = exports.error_profile_csv(plan)
            return dict(text=text, what="error profile, {} points".format(text.count("\n") - 1))
        meshes = exports.strip_meshes(plan, strip=k, z_range=job["z_range"], n_t=min(job["steps"], 2000) + 1)
        return dict(meshes=meshes, what="{} strip envelope(s) as {}".format(len(meshes), fmt))

    def _build(self, context, job, content):
        """Write the file(s): into a temporary folder first, moved into place only when all of it succeeded."""
        from ..flank_addon.exports import write_meshes

        path, folder, fmt = job["path"], job["folder"], job["fmt"]
        written = []
        try:
            tmp = tempfile.mkdtemp(prefix=".flank_export_", dir=folder)
        except OSError as ex:
            self.report({'ERROR'}, "Export: the folder '{}' is not writable: {}".format(folder, ex))
            return {'CANCELLED'}
        try:
            if "text" in content:
                staged = os.path.join(tmp, os.path.basename(path))
                with open(staged, "w", encoding="utf-8") as fh:
                    fh.write(content["text"])
                pairs = [(staged, path)]
            else:
                stem = os.path.splitext(os.path.basename(path))[0]
                staged = write_meshes(content["meshes"], os.path.join(tmp, stem), fmt.lower())
                pairs = [(p, os.path.join(folder, os.path.basename(p))) for p in staged]
            for src, dst in pairs:
                os.replace(src, dst)
                written.append(dst)
        except Exception as ex:              # core ValueError, OSError, ...: reported, never a traceback
            for p in written:
                try:
                    os.remove(p)
                except OSError:
                    pass
            self.report({'ERROR'}, "Export of '{}' failed: {}: {}".format(job["run"], type(ex).__name__, ex))
            return {'CANCELLED'}
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        self.report({'INFO'}, "Exported '{}': {} to {} ({:.2f} s)".format(
            job["run"], content["what"], ", ".join(os.path.basename(p) for p in written),
            time.perf_counter() - job["t0"]))
        return {'FINISHED'}


classes = (FLANK_OT_export_results,)
register, unregister = bpy.utils.register_classes_factory(classes)
