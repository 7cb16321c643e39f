# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.analyze_rotor -- recover axis, v0, handedness and flanks of the active mesh.

The analysis of a large mesh takes a second or more (1.3 s for 350k triangles), so from the UI it runs modal
(operators/modal.py): the mesh is read on the main thread, analysed in a worker thread with progress and Esc,
and the attributes and properties are written on the main thread at the end."""
import json
import time

import bpy
import numpy as np

from .common import (CLASS_COLORS, clear_flank_props, mesh_world_arrays, remove_attributes, set_color_attr,
                     set_float_attr)
from .modal import ModalPlannerMixin

CURVATURE_ATTR = "gaussian_curvature"
CLASS_ATTR = "curvature_class"


def _write_attributes(mesh, K, cls):
    set_float_attr(mesh, CURVATURE_ATTR, K)
    rgba = np.empty((len(cls), 4), dtype=np.float32)
    for value, color in CLASS_COLORS.items():
        rgba[cls == value] = color
    set_color_attr(mesh, CLASS_ATTR, rgba)
    mesh.update()


class FLANK_OT_analyze_rotor(ModalPlannerMixin, bpy.types.Operator):
    """Analyze the active mesh as a helical rotor: axis, v0, handedness, profile, flanks, curvature"""

    bl_idname = "flank.analyze_rotor"
    bl_label = "Analyze Rotor"
    bl_options = {'REGISTER', 'UNDO'}
    _title = "Rotor analysis"
    _object_name = ""

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        if obj is None or obj.type != 'MESH':
            return False
        if obj.mode != 'OBJECT':  # edit-mode geometry is stale and attribute writes would be lost
            cls.poll_message_set("Switch to Object Mode to analyze the rotor")
            return False
        return True

    def _compute_failed(self, ex):
        from ..flank_addon.geometry.rotor_analysis import NotHelicalError

        if isinstance(ex, NotHelicalError):
            return "'{}' is not a helical rotor: {}".format(self._object_name, ex)
        return "Rotor analysis failed: {}: {}".format(type(ex).__name__, ex)

    def _prepare(self, context):
        """The active mesh's world-space triangles (on the main thread: the worker never touches Blender data)."""
        obj = context.active_object
        if obj is None or obj.type != 'MESH':
            self.report({'ERROR'}, "Select a mesh object to analyze")
            return None
        if len(obj.data.vertices) < 4 or len(obj.data.polygons) < 2:
            self.report({'ERROR'}, "Mesh '{}' has too little geometry to analyze".format(obj.name))
            return None
        if obj.mode != 'OBJECT':
            self.report({'ERROR'}, "Switch '{}' to Object Mode before analyzing".format(obj.name))
            return None
        self._object_name = obj.name
        try:
            verts, faces = mesh_world_arrays(obj)
        except Exception as ex:
            self.report({'ERROR'}, "Rotor analysis failed: {}: {}".format(type(ex).__name__, ex))
            return None
        return dict(name=obj.name, verts=verts, faces=faces, vertex_count=len(obj.data.vertices),
                    matrix=[float(x) for row in obj.matrix_world for x in row], started=time.perf_counter())

    def _compute(self, job, progress):
        """The analysis, the curvature at every vertex and the summary: pure numpy/scipy (a worker thread)."""
        from ..flank_addon.geometry import rotor_analysis
        from ..flank_addon.progress import reporter

        report = reporter(progress)
        verts = job["verts"]
        # stage by stage, so Esc stops it within a stage (a few tenths of a second) instead of at its end
        res = rotor_analysis.analyze_mesh(verts, job["faces"], progress=reporter(progress, 0.0, 0.8))
        report(0.8, "curvature")
        K, cls = res.vertex_curvature(verts)
        K = np.asarray(K, dtype=np.float64).reshape(-1)
        cls = np.asarray(cls).reshape(-1).astype(np.int64)
        if len(K) != len(verts) or len(cls) != len(verts):
            raise ValueError("vertex_curvature returned {} / {} values for {} vertices".format(
                len(K), len(cls), len(verts)))
        summary_json = json.dumps(res.to_dict(), default=_json_default)
        # the whole analysis with the key of the mesh it belongs to: a planner in a later session takes it
        # instead of analysing the unchanged mesh again on the main thread (rotor_analysis.analyze_mesh, known=)
        record_json = json.dumps(res.to_record())
        report(1.0, "done")
        return dict(res=res, K=K, cls=cls, summary_json=summary_json, record_json=record_json)

    def _build(self, context, job, result):
        """Curvature attributes and the analysis on the object (the main thread)."""
        obj = bpy.data.objects.get(job["name"])
        if obj is None or obj.type != 'MESH' or len(obj.data.vertices) != job["vertex_count"] \
                or obj.mode != 'OBJECT':
            self.report({'ERROR'}, "Rotor analysis: '{}' was removed or edited while it was analysed; nothing "
                                   "was changed".format(job["name"]))
            return {'CANCELLED'}
        res, K, cls = result["res"], result["K"], result["cls"]
        dt = time.perf_counter() - job["started"]
        mesh = obj.data
        try:
            _write_attributes(mesh, K, cls)
        except Exception as ex:
            remove_attributes(mesh, (CURVATURE_ATTR, CLASS_ATTR))
            self.report({'ERROR'}, "Could not write curvature attributes: {}".format(ex))
            return {'CANCELLED'}

        hand = res.handedness if isinstance(res.handedness, str) else ("right" if res.handedness > 0 else "left")
        flanks = np.asarray(res.flanks, dtype=np.int64).reshape(-1, 2) if len(res.flanks) else np.zeros((0, 2), int)
        # keep what describes the generated rotor, replace everything the analysis owns
        keep = {k: obj[k] for k in ("flank_kind", "flank_part", "flank_lobes", "flank_scale", "flank_length")
                if k in obj}
        clear_flank_props(obj)
        for k, v in keep.items():
            obj[k] = v
        obj["flank_source"] = "analyzed"
        obj["flank_axis_point"] = [float(x) for x in np.ravel(res.axis_point)]
        obj["flank_axis"] = [float(x) for x in np.ravel(res.axis_direction)]
        obj["flank_v0"] = float(res.v0)
        obj["flank_lead"] = float(2.0 * np.pi * res.v0)
        obj["flank_handedness"] = hand
        obj["flank_residual"] = float(res.residual)
        obj["flank_threshold"] = float(res.threshold)
        obj["flank_outer_radius"] = float(res.outer_radius)
        obj["flank_flanks"] = [int(x) for x in flanks.ravel()]
        obj["flank_flank_count"] = int(len(flanks))
        obj["flank_to_world"] = [float(x) for x in np.asarray(res.to_world, dtype=np.float64).ravel()]
        obj["flank_analysis"] = result["summary_json"]
        obj["flank_analysis_record"] = result["record_json"]
        # where the object stood: moved or turned later, a planner moves this analysis with it (sources.py)
        obj["flank_analysis_matrix"] = job["matrix"]

        ignored = [m.name for m in obj.modifiers if m.show_viewport]
        if ignored:
            self.report({'WARNING'}, "Analyzed the base mesh of '{}'; modifiers ignored: {}".format(
                obj.name, ", ".join(ignored)))
        rep = res.mesh_repairs
        if any(rep.values()):
            self.report({'WARNING'}, "Mesh '{}' was repaired for the analysis (the object is unchanged): merged {} "
                                     "duplicate vertices, ignored {} collapsed or zero-area faces; {} edges are "
                                     "shared by more than two faces".format(
                                         obj.name, rep["merged_vertices"], rep["dropped_faces"],
                                         rep["nonmanifold_edges"]))
        counts = {name: int(np.count_nonzero(cls == value))
                  for name, value in (("elliptic", 1), ("parabolic", 0), ("hyperbolic", -1))}
        self.report({'INFO'}, "Analyzed '{}': v0={:.6g}, {}-handed, residual {:.3g} (threshold {:.3g}), "
                              "{} flanks, curvature classes {} in {:.2f}s".format(
                                  obj.name, res.v0, hand, res.residual, res.threshold, len(flanks), counts, dt))
        return {'FINISHED'}


def _json_default(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return str(value)


classes = (FLANK_OT_analyze_rotor,)
register, unregister = bpy.utils.register_classes_factory(classes)
