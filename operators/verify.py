# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.verify_plan -- simulate a flank-plan/1 file and paint the machined deviation on the rotor mesh.

Point attributes written on the mesh: ``machined_deviation`` (FLOAT, signed deviation in the plan's length unit:
> 0 material left, < 0 overcut; 1e9 where no tool reaches within the search range or the vertex is not on the
plan's rotor surface) and ``machined_deviation_color`` (FLOAT_COLOR, made the active and render colour: red
gouge, green within tolerance, blue stock, grey untouched).  The mesh is mapped into the plan's rotor frame with
matrix_world and the inverse of rotor.to_world (model frame = Blender world coordinates)."""
import json
import math
import os
import time

import bpy
import numpy as np

from .common import mesh_vertices, new_mesh_from_arrays, remove_attributes, remove_ids, set_color_attr, set_float_attr
from .modal import ModalPlannerMixin
from .properties import verify_props
from .shapes import axis_frame, revolved_mesh

DEVIATION_ATTR = "machined_deviation"
DEVIATION_COLOR_ATTR = "machined_deviation_color"
# Value of ``machined_deviation`` on vertices no tool reaches within the search range, and on
# vertices that do not lie on the plan's rotor surface (e.g. the centre vertices of end caps).
# A large finite positive number: physically "material left beyond the search range", so every
# comparison, clamp or colour ramp in shaders / Geometry Nodes treats it as stock, never as a
# gouge; NaN would silently fail every comparison.  Their colour is the grey "untouched" class.
UNTOUCHED = 1.0e9
VERIFY_PROP_KEYS = (
    "flank_verify_plan", "flank_verify_method", "flank_verify_unit", "flank_verify_tolerance",
    "flank_verify_search", "flank_verify_max_undercut", "flank_verify_max_overcut", "flank_verify_gouges",
    "flank_verify_elapsed", "flank_verify_reached", "flank_verify_untouched", "flank_verify_off_surface",
    "flank_verify_summary",
)
TOOLS_COLLECTION = "Verify Tools"
MAX_STORED_GOUGES = 500  # gouge points kept in the flank_verify_summary JSON property


def _write_attributes(mesh, values, rgba):
    set_float_attr(mesh, DEVIATION_ATTR, values)
    set_color_attr(mesh, DEVIATION_COLOR_ATTR, rgba)
    mesh.update()


def _tool_meshes(strip):
    """[(name, verts, faces)] of one strip in the rotor frame: cutter and shank (if any).

    The cutter is drawn from the strip's inscribed-sphere radii at equally spaced axis points
    (frustums between them; a ball when axis_start == axis_end): the envelope of the spheres is
    approximated, exact for cylinders and balls.
    """
    out = []
    a = np.asarray(strip["axis_start"], dtype=np.float64)
    radii = np.asarray(strip["radii"], dtype=np.float64)
    frame, length = axis_frame(a, strip["axis_end"])
    if frame is None:
        r = float(radii.max())
        t = np.linspace(0.0, np.pi, 17)
        verts, faces = revolved_mesh(np.c_[r * np.sin(t), r * np.cos(t)], 32)
        out.append(("cutter", verts + a, faces))
    else:
        h = np.linspace(0.0, length, len(radii))
        verts, faces = revolved_mesh(np.vstack([[0.0, length], np.c_[radii, h][::-1], [0.0, 0.0]]), 32)
        out.append(("cutter", verts @ frame[:3, :3].T + a, faces))
    shank_r = float(strip.get("shank_radius", 0.0))
    if shank_r > 0.0:
        s0 = np.asarray(strip["shank_start"], dtype=np.float64)
        frame, length = axis_frame(s0, strip["shank_end"])
        if frame is not None:
            verts, faces = revolved_mesh([[0.0, length], [shank_r, length], [shank_r, 0.0], [0.0, 0.0]], 32)
            out.append(("shank", verts @ frame[:3, :3].T + s0, faces))
    return out


def _read_plan(path):
    """The plan file -> plan dict, or an error message."""
    from ..flank_addon.io.plan import PlanError, read_plan

    if not path:
        return "No plan file given (filepath is empty)"
    if not os.path.isfile(path):
        return "Plan file not found: '{}'".format(path)
    try:
        return read_plan(path)
    except PlanError as ex:
        return "Invalid plan file '{}': {}".format(os.path.basename(path), ex)
    except (OSError, UnicodeDecodeError) as ex:
        return "Cannot read plan file '{}': {}".format(path, ex)


class _VerifyError(Exception):
    """A failure of the verify run with the message to report as it is."""


def _on_plan(co, mw, plan, res):
    """(deviation per vertex (NaN where none), on-surface mask, its distance limit) of the mesh vertices ``co``
    (N, 3) under ``mw`` (the object's matrix_world) mapped into the plan's rotor frame: vertices off the plan's
    rotor surface get no deviation (end-cap centres, or the wrong object / plan), measured from the vertex's
    helix to the nearest profile point."""
    from scipy.spatial import cKDTree

    from ..flank_addon.geometry.screw import screw_to_plane
    from ..flank_addon.simulation.verify import values_on_rotor, world_to_rotor

    rotor_pts = world_to_rotor(plan, co @ mw[:3, :3].T + mw[:3, 3])
    dev_all = np.array([np.nan if d is None else d for d in res["deviation_all"]], dtype=np.float64)
    values = values_on_rotor(plan, rotor_pts, dev_all)
    rotor = plan["rotor"]
    prof = np.asarray(rotor["profile"], dtype=np.float64)
    dist, _ = cKDTree(prof).query(screw_to_plane(rotor_pts, float(rotor["v0"]), rotor["handedness"]))
    spacing = float(np.linalg.norm(np.diff(np.vstack([prof, prof[:1]]), axis=0), axis=1).max())
    max_dist = max(2.0 * spacing, 1e-2 * float(rotor["outer_radius"]))
    return values, dist <= max_dist, max_dist


def _store_props(obj, path, plan, res, search, reached, on_surface):
    for key in VERIFY_PROP_KEYS:
        if key in obj:
            del obj[key]
    obj["flank_verify_plan"] = path
    obj["flank_verify_method"] = str(plan.get("method", ""))
    obj["flank_verify_unit"] = plan["length_unit"]
    obj["flank_verify_tolerance"] = float(res["tolerance"])
    obj["flank_verify_search"] = search if search > 0.0 else 0.1 * float(plan["rotor"]["outer_radius"])
    if res["max_undercut"] is not None:
        obj["flank_verify_max_undercut"] = float(res["max_undercut"])
    if res["max_overcut"] is not None:
        obj["flank_verify_max_overcut"] = float(res["max_overcut"])
    obj["flank_verify_gouges"] = len(res["gouge_points"])
    obj["flank_verify_elapsed"] = float(res["elapsed_s"])
    obj["flank_verify_reached"] = int(reached.sum())
    obj["flank_verify_untouched"] = int((~reached).sum())
    obj["flank_verify_off_surface"] = int((~on_surface).sum())
    summary = {k: v for k, v in res.items() if k not in ("deviation_all", "deviation_profile")}
    if len(summary["gouge_points"]) > MAX_STORED_GOUGES:  # keep the .blend small; the count is exact
        summary["gouge_points"] = summary["gouge_points"][:MAX_STORED_GOUGES]
        summary["gouge_points_truncated_to"] = MAX_STORED_GOUGES
    obj["flank_verify_summary"] = json.dumps(summary)


class FLANK_OT_verify_plan(ModalPlannerMixin, bpy.types.Operator):
    """Verify a flank-plan/1 file by sweep simulation and paint the machined deviation on the active rotor mesh
    (red overcut, green within tolerance, blue material left, grey not reached)"""

    bl_idname = "flank.verify_plan"
    bl_label = "Verify Plan"
    bl_options = {'REGISTER', 'UNDO'}
    _title = "Verify"

    __annotations__ = dict(
        verify_props(),
        filter_glob=bpy.props.StringProperty(default="*.json", options={'HIDDEN'}),
        modal_run=bpy.props.BoolProperty(default=False, options={'HIDDEN', 'SKIP_SAVE'}),
    )

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        if obj is None or obj.type != 'MESH':
            cls.poll_message_set("Select the rotor mesh to verify the plan on")
            return False
        if obj.mode != 'OBJECT':
            cls.poll_message_set("Switch to Object Mode to verify a plan")
            return False
        return True

    def invoke(self, context, event):
        if not self.filepath:
            # the file browser calls execute: from the UI that runs modal too
            self.modal_run = not bpy.app.background
            context.window_manager.fileselect_add(self)
            return {'RUNNING_MODAL'}
        return ModalPlannerMixin.invoke(self, context, event)

    def execute(self, context):
        if self.modal_run and not bpy.app.background and context.window is not None:
            self.modal_run = False
            return self._start_modal(context)
        return ModalPlannerMixin.execute(self, context)

    def _compute_failed(self, ex):
        if isinstance(ex, _VerifyError):
            return str(ex)
        return "Verification failed: {}: {}".format(type(ex).__name__, ex)

    def _target(self, context):
        """The mesh object to paint, or an error message."""
        obj = context.active_object
        if obj is None or obj.type != 'MESH':
            return "Select the rotor mesh object to verify the plan on"
        if obj.mode != 'OBJECT':
            return "Switch '{}' to Object Mode before verifying".format(obj.name)
        if len(obj.data.vertices) == 0:
            return "Mesh '{}' has no vertices".format(obj.name)
        return obj

    # ------------------------------------------------------------------ main thread: inputs
    def _prepare(self, context):
        """The target mesh (its vertices read here), the plan file and the settings -> job, or None."""
        obj = self._target(context)
        path = bpy.path.abspath(self.filepath) if self.filepath else ""
        plan = _read_plan(path) if not isinstance(obj, str) else obj
        if isinstance(plan, str):
            self.report({'ERROR'}, plan)
            return None
        mesh = obj.data
        co = mesh_vertices(mesh)
        # single-precision properties: recover the typed decimal (7 significant digits)
        tol_in, search_in = (float("{:.7g}".format(v)) for v in (self.tolerance, self.search))
        for label, v in (("tolerance", tol_in), ("search range", search_in)):
            if not math.isfinite(v):         # NaN would otherwise fall back to the default unseen
                self.report({'ERROR'}, "Verify: {} = {} must be a finite number >= 0 (0 = default)".format(label, v))
                return None
        return dict(t0=time.perf_counter(), obj_name=obj.name, path=path, plan=plan, co=co,
                    mw=np.array(obj.matrix_world, dtype=np.float64), tol_in=tol_in, search_in=search_in)

    # ------------------------------------------------------------------ worker thread
    @staticmethod
    def _compute(job, progress):
        """The sweep simulation and the deviation per vertex (no Blender data)."""
        from ..flank_addon.io.plan import PlanError
        from ..flank_addon.progress import Cancelled, reporter
        from ..flank_addon.simulation.verify import deviation_colors, verify_plan

        plan, path, tol_in, search_in = job["plan"], job["path"], job["tol_in"], job["search_in"]
        try:
            res = verify_plan(plan, tolerance=tol_in if tol_in > 0.0 else None,
                              search=search_in if search_in > 0.0 else None, all_points=True,
                              progress=reporter(progress, 0.0, 0.95))
        except (PlanError, ValueError) as ex:
            raise _VerifyError("Plan '{}' cannot be verified: {}".format(os.path.basename(path), ex))
        try:
            values, on_surface, max_dist = _on_plan(job["co"], job["mw"], plan, res)
        except Cancelled:
            raise
        except Exception as ex:
            raise _VerifyError("Could not map '{}' into the plan's rotor frame: {}: {}".format(
                job["obj_name"], type(ex).__name__, ex))
        n, unit = len(values), plan["length_unit"]
        if on_surface.mean() < 0.5:
            raise _VerifyError("Mesh '{}' does not lie on the plan's rotor: {} of {} vertices are farther than "
                               "{:.4g} {} from the rotor surface (limit: at least half must lie on it; wrong "
                               "object, plan or placement?)".format(job["obj_name"], int((~on_surface).sum()), n,
                                                                    max_dist, unit))
        values = np.where(on_surface, values, np.nan)
        reached = np.isfinite(values)
        return dict(res=res, on_surface=on_surface, reached=reached, stored=np.where(reached, values, UNTOUCHED),
                    rgba=deviation_colors(values, float(res["tolerance"])))

    # ------------------------------------------------------------------ main thread: results
    def _build(self, context, job, out):
        """The deviation attributes on the mesh, its properties, the tools if asked for, the report."""
        plan, path, res, reached = job["plan"], job["path"], out["res"], out["reached"]
        obj = bpy.data.objects.get(job["obj_name"])
        if obj is None or obj.type != 'MESH' or len(obj.data.vertices) != len(job["co"]):
            self.report({'ERROR'}, "Verify: the mesh '{}' was removed or changed while verifying".format(
                job["obj_name"]))
            return {'CANCELLED'}
        try:
            _write_attributes(obj.data, out["stored"], out["rgba"])
        except Exception as ex:
            remove_attributes(obj.data, (DEVIATION_ATTR, DEVIATION_COLOR_ATTR))
            self.report({'ERROR'}, "Could not write the deviation attributes: {}".format(ex))
            return {'CANCELLED'}
        tools_note = self._extras(context, plan, obj)
        _store_props(obj, path, plan, res, job["search_in"], reached, out["on_surface"])
        unit = plan["length_unit"]

        def fmt(v):
            return "n/a" if v is None else "{:.4g} {}".format(v, unit)

        self.report({'INFO'}, "Verified '{}' with {}: max undercut {}, max overcut {}, {} gouge points, "
                              "tolerance {}, {}/{} vertices reached{}; simulation {:.2f}s, total {:.2f}s".format(
                                  obj.name, os.path.basename(path), fmt(res["max_undercut"]),
                                  fmt(res["max_overcut"]), len(res["gouge_points"]), fmt(res["tolerance"]),
                                  int(reached.sum()), len(reached), tools_note, res["elapsed_s"],
                                  time.perf_counter() - job["t0"]))
        return {'FINISHED'}

    def _extras(self, context, plan, obj):
        """Warnings about ignored modifiers, and the tool objects when asked for -> note for the report."""
        ignored = [m.name for m in obj.modifiers if m.show_viewport]
        if ignored:
            self.report({'WARNING'}, "Painted the base mesh of '{}'; modifiers ignored: {}".format(
                obj.name, ", ".join(ignored)))
        if not self.show_tools:
            return ""
        try:
            return ", {} tool objects in '{}'".format(_add_tools(context, plan), TOOLS_COLLECTION)
        except Exception as ex:  # the deviation is written; the tools are an extra
            self.report({'WARNING'}, "Could not add the tool objects: {}".format(ex))
            return ""


def _add_tools(context, plan):
    """Strip tools as mesh objects (model = world frame) in a new collection; all or nothing."""
    T = np.asarray(plan["rotor"]["to_world"], dtype=np.float64)
    created_meshes, created_objects = [], []
    coll = bpy.data.collections.new(TOOLS_COLLECTION)
    try:
        for k, strip in enumerate(plan["strips"]):
            for part, verts, faces in _tool_meshes(strip):
                name = "Strip{:03d}_{}".format(k, part)
                me = new_mesh_from_arrays(name, verts @ T[:3, :3].T + T[:3, 3], faces)
                created_meshes.append(me)
                ob = bpy.data.objects.new(name, me)
                created_objects.append(ob)
                ob["flank_strip"] = k
                ob["flank_strip_flank"] = int(strip["flank"])
                ob.color = (0.9, 0.75, 0.2, 1.0) if part == "cutter" else (0.5, 0.5, 0.55, 1.0)
                coll.objects.link(ob)
        context.scene.collection.children.link(coll)
    except Exception:
        remove_ids(created_objects, created_meshes, [coll])
        raise
    return len(created_objects)


classes = (FLANK_OT_verify_plan,)
register, unregister = bpy.utils.register_classes_factory(classes)
