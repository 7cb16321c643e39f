# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.generate_rotor -- built-in screw rotor as a mesh object with its helix data."""
import math
import time

import bpy

from .common import count_limit_error, finish_mesh, mesh_without_edges, select_only
from .modal import ModalPlannerMixin, next_turn
from .properties import generator_props

# Blender keeps vertex coordinates in single precision (7 digits): a rotor larger than this keeps less than a
# tenth of a scene unit of its shape
MAX_SCENE_LENGTH = 1e6


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
        for label, value in (("outer radius", self.scale), ("lead", self.lead), ("length", self.length)):
            if msg is None and not (math.isfinite(value) and value <= MAX_SCENE_LENGTH):
                msg = "{} = {:g} must be a finite number of at most {:g} scene units{}".format(
                    label, value, MAX_SCENE_LENGTH, "" if label == "outer radius" else " (0 = automatic)")
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

    # ------------------------------------------------------------------ main thread: two turns
    def _next_stage(self, context, job, result):
        """The mesh's vertices and triangles in one turn of the main thread, its edges and the object in the next
        (:meth:`_build`): for the default 280,000 triangles about 27 and 35 ms instead of 63 ms in one."""
        if "mesh" in job:
            return None
        rotor, verts, faces = result
        try:
            mesh, suspect = mesh_without_edges("Rotor_{}_{}".format(job["kind"], job["part"]), verts, faces)
        except Exception as ex:
            self.report({'ERROR'}, "Could not build the rotor mesh: {}".format(ex))
            return False
        job.update(mesh=mesh.name, suspect=suspect, rotor=rotor, n_verts=len(verts))
        return next_turn(result)                     # back to the interface, then the build

    def _discard(self, job):
        mesh = bpy.data.meshes.get(job.get("mesh", "")) if job else None
        if mesh is not None and mesh.users == 0:
            bpy.data.meshes.remove(mesh)

    def _build(self, context, job, result):
        """The mesh's edges and the object with the rotor's helix data (the main thread)."""
        rotor = job["rotor"]
        name = "Rotor_{}_{}".format(job["kind"], job["part"])
        mesh = bpy.data.meshes.get(job["mesh"])
        try:
            if mesh is None:
                raise RuntimeError("its data was removed while it was built")
            finish_mesh(mesh, job["suspect"])
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
            name, rotor.lobes, rotor.v0, hand_name, job["n_verts"], dt))
        return {'FINISHED'}


classes = (FLANK_OT_generate_rotor,)
register, unregister = bpy.utils.register_classes_factory(classes)
