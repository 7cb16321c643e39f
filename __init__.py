# SPDX-License-Identifier: GPL-3.0-or-later
"""Flank Toolpath -- Blender extension entry point (register/unregister only).

Inside Blender this package is ``bl_ext.<repo>.flank_toolpath``; the planner
is the embedded pure numpy/scipy subpackage ``.flank_addon``.  Operators live
in ``.operators`` (``bpy.ops.flank.*``), UI in ``.panels`` (3D Viewport
sidebar tab "Flank").
"""
import bpy

from . import operators, panels

classes = (
    *operators.classes,
    *panels.classes,
)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.flank_settings = bpy.props.PointerProperty(type=operators.FLANK_PG_settings)


def unregister():
    if hasattr(bpy.types.Scene, "flank_settings"):
        del bpy.types.Scene.flank_settings
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
