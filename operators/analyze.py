# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.analyze_rotor -- recover axis, v0, handedness and flanks of the active mesh."""
import json
import time

import bpy
import numpy as np

from .common import (CLASS_COLORS, clear_flank_props, mesh_world_arrays, remove_attributes, set_color_attr,
                     set_float_attr)

CURVATURE_ATTR = "gaussian_curvature"
CLASS_ATTR = "curvature_class"


def _write_attributes(mesh, K, cls):
    set_float_attr(mesh, CURVATURE_ATTR, K)
    rgba = np.empty((len(cls), 4), dtype=np.float32)
    for value, color in CLASS_COLORS.items():
        rgba[cls == value] = color
    set_color_attr(mesh, CLASS_ATTR, rgba)
    mesh.update()


class FLANK_OT_analyze_rotor(bpy.types.Operator):
    """Analyze the active mesh as a helical rotor: axis, v0, handedness, profile, flanks, curvature"""

    bl_idname = "flank.analyze_rotor"
    bl_label = "Analyze Rotor"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        if obj is None or obj.type != 'MESH':
            return False
        if obj.mode != 'OBJECT':  # edit-mode geometry is stale and attribute writes would be lost
            cls.poll_message_set("Switch to Object Mode to analyze the rotor")
            return False
        return True

    def execute(self, context):
        from ..flank_addon.geometry import rotor_analysis

        obj = context.active_object
        if obj is None or obj.type != 'MESH':
            self.report({'ERROR'}, "Select a mesh object to analyze")
            return {'CANCELLED'}
        if len(obj.data.vertices) < 4 or len(obj.data.polygons) < 2:
            self.report({'ERROR'}, "Mesh '{}' has too little geometry to analyze".format(obj.name))
            return {'CANCELLED'}

        if obj.mode != 'OBJECT':
            self.report({'ERROR'}, "Switch '{}' to Object Mode before analyzing".format(obj.name))
            return {'CANCELLED'}
        t0 = time.perf_counter()
        try:
            verts, faces = mesh_world_arrays(obj)
            res = rotor_analysis.analyze_mesh(verts, faces)
            K, cls = res.vertex_curvature(verts)
            K = np.asarray(K, dtype=np.float64).reshape(-1)
            cls = np.asarray(cls).reshape(-1).astype(np.int64)
            if len(K) != len(verts) or len(cls) != len(verts):
                raise ValueError("vertex_curvature returned {} / {} values for {} vertices".format(
                    len(K), len(cls), len(verts)))
            summary = res.to_dict()
            summary_json = json.dumps(summary, default=_json_default)
        except rotor_analysis.NotHelicalError as ex:
            self.report({'ERROR'}, "'{}' is not a helical rotor: {}".format(obj.name, ex))
            return {'CANCELLED'}
        except Exception as ex:
            self.report({'ERROR'}, "Rotor analysis failed: {}: {}".format(type(ex).__name__, ex))
            return {'CANCELLED'}
        dt = time.perf_counter() - t0

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
        obj["flank_analysis"] = summary_json

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
