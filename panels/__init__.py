# SPDX-License-Identifier: GPL-3.0-or-later
"""Sidebar UI of the Flank Toolpath extension (3D Viewport > Sidebar > "Flank"), in workflow order:
Workpiece, Tool, Strategy (with one sub-panel per strategy, shown for the chosen one), Run, Results, Verify,
Machine.

Each module has a ``classes`` tuple and ``register, unregister = bpy.utils.register_classes_factory(classes)``;
:func:`register` calls them in the order of ``MODULES``: parent panels before their sub-panels."""
from . import (common, double_flank, formed_cutter, freeform, machine, paraboloid, results, single_flank, strategy,
               tool, verify, workpiece)

MODULES = (
    common, workpiece, tool,
    strategy,              # FLANK_PT_strategy and FLANK_PT_run: the strategy sub-panels' parent first
    single_flank, double_flank, formed_cutter, paraboloid, freeform,
    results, verify, machine,
)

classes = tuple(cls for module in MODULES for cls in module.classes)


def register():
    for module in MODULES:
        module.register()


def unregister():
    for module in reversed(MODULES):
        module.unregister()
