# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators of the Flank Toolpath extension (``bpy.ops.flank.*``): a thin layer over the planner.

Operators read their properties and the Blender data they work on (``sources``), call the embedded planner
(``..flank_addon``, off the UI thread for the planners: ``modal``, ``jobs``) and turn its results into Blender
data through one shared builder (``result_builder``: the run's collection, objects, attributes, material,
properties -- all or nothing).  Failures are reported with ``self.report({'ERROR'}, ...)`` and return
``{'CANCELLED'}`` without leaving half-built data behind.

Modules, bottom up (a module imports only those listed before it):

- ``common`` (meshes, attributes, removal, F-curves), ``materials`` (the shared attribute material),
  ``units`` (lengths as people read them), ``shapes`` (tool frames, screw motion, surfaces of revolution),
  ``jobs`` / ``modal`` (the planner off the UI thread), ``report_process`` (a Cycles report rendered by
  a separate Blender), ``tool_settings`` (the Tool panel's end mill);
- ``runs`` (result runs in the scene), ``sources`` (rotor and surface read from Blender),
  ``result_builder`` (the shared builder), ``strips`` (the Results lists), ``guiding`` (free-form guiding
  direction and preview);
- ``properties`` (operator properties and the scene settings);
- the operators: ``generate``, ``analyze``, ``verify``, ``single_flank``, ``double_flank``, ``formed_cutter``,
  ``paraboloid``, ``freeform``, ``sample_surfaces``, ``cutter_region``, ``flank_list``, ``tool_preview``,
  ``export``, ``animate``, ``render_report`` (``report_scene``: the picture's scene), ``profile_plot``
  (``chart_text``: its text in Blender's font), ``ui_ops`` (the Run button's call), ``post_program`` (the
  machine program: ``program`` its inputs and the core's post, ``program_scene`` its path and animation),
  ``check_program`` (a program file read back and checked against the run's plan).

Each module has a ``classes`` tuple and ``register, unregister = bpy.utils.register_classes_factory(classes)``;
:func:`register` calls them in the order of ``MODULES`` (property groups before the operators that use them).
"""
import bpy

from . import (analyze, animate, chart_text, check_program, common, cutter_region, double_flank, export, flank_list,
               formed_cutter, freeform, generate, guiding, jobs, materials, modal, paraboloid, post_program,
               profile_plot, program, program_scene, properties, render_report, report_process, report_scene,
               result_builder, runs, sample_surfaces, shapes, single_flank, sources, strips, tool_preview,
               tool_settings, ui_ops, units, verify)

MODULES = (
    common, materials, units, shapes, jobs, report_process, modal, tool_settings, runs, sources, result_builder,
    chart_text,
    properties,            # FLANK_PG_flank, FLANK_PG_settings: before everything that uses them
    strips, guiding,
    generate, analyze, verify, single_flank, double_flank, formed_cutter, paraboloid, freeform, sample_surfaces,
    cutter_region, flank_list, tool_preview, export, animate, render_report, report_scene, profile_plot, ui_ops,
    program, program_scene, post_program, check_program,
)

classes = tuple(cls for module in MODULES for cls in module.classes)


def register():
    for module in MODULES:
        module.register()
    bpy.types.Scene.flank_settings = bpy.props.PointerProperty(type=properties.FLANK_PG_settings)


def unregister():
    if hasattr(bpy.types.Scene, "flank_settings"):
        del bpy.types.Scene.flank_settings
    for module in reversed(MODULES):
        module.unregister()
