# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.generate_rotor -- built-in screw rotor as a mesh object with its helix data."""
import time

import bpy

from .common import count_limit_error, new_mesh_from_arrays, select_only
from .properties import generator_props


class FLANK_OT_generate_rotor(bpy.types.Operator):
    """Generate a built-in screw rotor (closed helical mesh) and store its helix data on the object"""

    bl_idname = "flank.generate_rotor"
    bl_label = "Generate Rotor"
    bl_options = {'REGISTER', 'UNDO'}

    __annotations__ = generator_props()

    def execute(self, context):
        from ..flank_addon.geometry import rotors

        t0 = time.perf_counter()
        msg = (count_limit_error("resolution", self.resolution, 24, 65536)
               or count_limit_error("axial rings", self.axial, 2, 16384)
               or count_limit_error("mesh vertices (resolution x axial rings)",
                                    int(self.resolution) * int(self.axial), 48, 4000000))
        if msg is not None:
            self.report({'ERROR'}, "Rotor generation: " + msg)
            return {'CANCELLED'}
        hand = None if self.handedness == "DEFAULT" else self.handedness
        try:
            rotor = rotors.builtin_rotor(
                self.kind, self.part, scale=self.scale,
                lead=self.lead if self.lead > 0.0 else None,
                length=self.length if self.length > 0.0 else None,
                handedness=hand,
            )
            verts, faces = rotor.mesh(n_profile=int(self.resolution), n_axial=int(self.axial))
        except Exception as ex:  # core errors (RotorError, ProfileError, ...) -> report, no traceback
            self.report({'ERROR'}, "Rotor generation failed: {}".format(ex))
            return {'CANCELLED'}

        name = "Rotor_{}_{}".format(self.kind, self.part)
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
        obj["flank_scale"] = float(self.scale)
        obj["flank_lead"] = float(rotor.lead)
        obj["flank_length"] = float(rotor.length)
        obj["flank_v0"] = float(rotor.v0)
        obj["flank_handedness"] = hand_name
        obj["flank_axis_point"] = (0.0, 0.0, 0.0)
        obj["flank_axis"] = (0.0, 0.0, 1.0)
        obj["flank_flank_count"] = len(rotor.flanks)

        dt = time.perf_counter() - t0
        self.report({'INFO'}, "Generated {}: {} lobes, v0={:.6g}, {}-handed, {} vertices in {:.2f}s".format(
            name, rotor.lobes, rotor.v0, hand_name, len(verts), dt))
        return {'FINISHED'}


classes = (FLANK_OT_generate_rotor,)
register, unregister = bpy.utils.register_classes_factory(classes)
