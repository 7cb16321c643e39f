# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.add_test_surface and its menu: the built-in free-form surfaces (the ones the tests and the README use)
as mesh objects at the 3D cursor."""
import math

import bpy
from bpy.props import EnumProperty, FloatProperty, IntProperty
from mathutils import Matrix

from .common import new_mesh_from_arrays, remove_ids, select_only, typed

SURFACE_ITEMS = (
    ("cylinder", "Cylinder Patch", "Developable: a cylindrical tool along the rulings machines it exactly"),
    ("parabolic_blade", "Parabolic Blade", "Parabolic cylinder, close to a blisk blade (Rajain et al. 2023, Fig. 19)"),
    ("gear_flank", "Gear Flank", "Involute helicoid: the flank of a helical gear"),
    ("bump", "Bump", "Gaussian bump: elliptic top, hyperbolic rim (Rajain et al. 2023, Figs. 15-17)"),
    ("saddle", "Saddle", "Hyperbolic paraboloid"),
    ("plane", "Plane", "Flat square"),
)


class FLANK_OT_add_test_surface(bpy.types.Operator):
    """Add one of the built-in free-form test surfaces at the 3D cursor"""

    bl_idname = "flank.add_test_surface"
    bl_label = "Add Test Surface"
    bl_options = {'REGISTER', 'UNDO'}

    kind: EnumProperty(name="Surface", items=SURFACE_ITEMS, default="parabolic_blade")
    size: FloatProperty(name="Size", description="Longer side of the patch (scene units)", default=1.0,
                        soft_min=0.001, soft_max=1000.0, unit='LENGTH')
    resolution: IntProperty(name="Resolution", description="Grid cells along the longer side (2..400)", default=40,
                            soft_min=2, soft_max=400)

    def execute(self, context):
        from ..flank_addon.geometry.freeform_surfaces import make_surface

        size = typed(self.size)
        if not (math.isfinite(size) and 1e-6 <= size <= 1e6):
            self.report({'ERROR'}, "Test surface: size = {} is outside the limits 1e-06 .. 1e+06".format(size))
            return {'CANCELLED'}
        if not 2 <= int(self.resolution) <= 400:
            self.report({'ERROR'}, "Test surface: resolution = {} is outside the limits 2 .. 400".format(
                int(self.resolution)))
            return {'CANCELLED'}
        try:
            surf = make_surface(self.kind, size=size, resolution=int(self.resolution))
            name = dict((i[0], i[1]) for i in SURFACE_ITEMS)[self.kind]
            me = new_mesh_from_arrays(name, surf.vertices, surf.faces)
        except ValueError as ex:
            self.report({'ERROR'}, "Test surface: {}".format(ex))
            return {'CANCELLED'}
        ob = bpy.data.objects.new(name, me)
        try:
            context.collection.objects.link(ob)
        except Exception as ex:
            remove_ids([ob], [me])
            self.report({'ERROR'}, "Test surface: {}".format(ex))
            return {'CANCELLED'}
        ob.matrix_world = Matrix.Translation(context.scene.cursor.location)
        ob["flank_test_surface"] = self.kind
        select_only(context, ob)
        self.report({'INFO'}, "Added '{}': {} vertices, {} triangles".format(ob.name, len(surf.vertices),
                                                                           len(surf.faces)))
        return {'FINISHED'}


class FLANK_MT_test_surfaces(bpy.types.Menu):
    """Built-in free-form test surfaces"""

    bl_idname = "FLANK_MT_test_surfaces"
    bl_label = "Add Test Surface"

    def draw(self, context):
        for kind, label, _ in SURFACE_ITEMS:
            self.layout.operator("flank.add_test_surface", text=label).kind = kind


classes = (FLANK_OT_add_test_surface, FLANK_MT_test_surfaces)
register, unregister = bpy.utils.register_classes_factory(classes)
