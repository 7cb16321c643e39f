# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.generate_rotor -- built-in screw rotor as a mesh object with its helix data."""
import time

import bpy

from .common import count_limit_error, new_mesh_from_arrays, select_only
from .modal import ModalPlannerMixin
from .properties import generator_props


class FLANK_OT_generate_rotor(ModalPlannerMixin, bpy.types.Operator):
    """Generate a built-in screw rotor (closed helical mesh) and store its helix data on the object"""

    bl_idname = "flank.generate_rotor"
    bl_label = "Generate Rotor"
    bl_options = {'REGISTER', 'UNDO'}
    _title = "Rotor generation"

    __annotations__ = generator_props()

    def _compute_failed(self, ex):
        # core errors (RotorError, ProfileError, ...) are reported with their own message, never a traceback
        return "Rotor generation failed: {}".format(ex)

    def _prepare(self, context):
        msg = (count_limit_error("resolution", self.resolution, 24, 65536)
               or count_limit_error("axial rings", self.axial, 2, 16384)
               or count_limit_error("mesh vertices (resolution x axial rings)",
                                    int(self.resolution) * int(self.axial), 48, 4000000))
        if msg is not None:
            self.report({'ERROR'}, "Rotor generation: " + msg)
            return None
        return dict(kind=self.kind, part=self.part, scale=float(self.scale),
                    lead=self.lead if self.lead > 0.0 else None, length=self.length if self.length > 0.0 else None,
                    handedness=None if self.handedness == "DEFAULT" else self.handedness,
                    n_profile=int(self.resolution), n_axial=int(self.axial), started=time.perf_counter())

    def _compute(self, job, progress):
        """The rotor and its mesh arrays: pure numpy/scipy (a worker thread when run from the UI)."""
        from ..flank_addon.geometry import rotors
        from ..flank_addon.progress import reporter

        report = reporter(progress)
        report(0.0, "profile")
        rotor = rotors.builtin_rotor(job["kind"], job["part"], scale=job["scale"], lead=job["lead"],
                                     length=job["length"], handedness=job["handedness"])
        report(0.3, "mesh")
        verts, faces = rotor.mesh(n_profile=job["n_profile"], n_axial=job["n_axial"])
        report(1.0, "done")
        return rotor, verts, faces

    def _build(self, context, job, result):
        """The mesh object with the rotor's helix data (the main thread)."""
        rotor, verts, faces = result
        name = "Rotor_{}_{}".format(job["kind"], job["part"])
        try:
            mesh = new_mesh_from_arrays(name, verts, faces)
        except Exception as ex:
            self.report({'ERROR'}, "Could not build the rotor mesh: {}".format(ex))
            return {'CANCELLED'}

        obj = bpy.data.objects.new(name, mesh)
        try:
            context.collection.objects.link(obj)
            select_only(context, obj)
        except Exception as ex:  # e.g. a linked (read-only) active collection: leave nothing behind
            bpy.data.objects.remove(obj)
            bpy.data.meshes.remove(mesh)
            self.report({'ERROR'}, "Could not add the rotor to collection '{}': {}".format(
                context.collection.name, ex))
            return {'CANCELLED'}

        hand_name = rotor.handedness if isinstance(rotor.handedness, str) else (
            "right" if rotor.handedness > 0 else "left")
        obj["flank_source"] = "generated"
        obj["flank_kind"] = str(rotor.kind)
        obj["flank_part"] = str(rotor.part)
        obj["flank_lobes"] = int(rotor.lobes)
        obj["flank_scale"] = float(job["scale"])
        obj["flank_lead"] = float(rotor.lead)
        obj["flank_length"] = float(rotor.length)
        obj["flank_v0"] = float(rotor.v0)
        obj["flank_handedness"] = hand_name
        obj["flank_axis_point"] = (0.0, 0.0, 0.0)
        obj["flank_axis"] = (0.0, 0.0, 1.0)
        obj["flank_flank_count"] = len(rotor.flanks)

        dt = time.perf_counter() - job["started"]
        self.report({'INFO'}, "Generated {}: {} lobes, v0={:.6g}, {}-handed, {} vertices in {:.2f}s".format(
            name, rotor.lobes, rotor.v0, hand_name, len(verts), dt))
        return {'FINISHED'}


classes = (FLANK_OT_generate_rotor,)
register, unregister = bpy.utils.register_classes_factory(classes)
