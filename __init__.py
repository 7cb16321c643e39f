# SPDX-License-Identifier: GPL-3.0-or-later
"""Flank Toolpath -- Blender extension entry point (register/unregister only).

Inside Blender this package is ``bl_ext.<repo>.flank_toolpath``; the planner is the embedded pure numpy/scipy
subpackage ``.flank_addon``.  Operators live in ``.operators`` (``bpy.ops.flank.*``), UI in ``.panels``
(3D Viewport sidebar tab "Flank"); each registers its own modules in order.
"""
from . import operators, panels


def register():
    operators.register()
    panels.register()


def unregister():
    panels.unregister()
    operators.unregister()
