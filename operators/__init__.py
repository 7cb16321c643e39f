# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators of the Flank Toolpath extension (``bpy.ops.flank.*``).

Operators are thin: read properties, call the embedded planner
(``..flank_addon``, imported lazily inside ``execute``), build Blender data
with ``foreach_set`` and report.  Failures are reported with
``self.report({'ERROR'}, ...)`` and return ``{'CANCELLED'}`` without leaving
half-built data behind.
"""
from .properties import FLANK_PG_flank, FLANK_PG_settings
from .generate import FLANK_OT_generate_rotor
from .analyze import FLANK_OT_analyze_rotor
from .verify import FLANK_OT_verify_plan
from .paraboloid import FLANK_OT_paraboloid_groove
from .formed_cutter import FLANK_OT_formed_cutter
from .double_flank import FLANK_OT_plan_double_flank
from .single_flank import FLANK_OT_plan_single_flank
from .cutter_region import FLANK_OT_cutter_region
from . import render_report, export, animate, ui_ops, freeform, profile_plot

classes = (
    FLANK_PG_flank,          # item type of FLANK_PG_settings.flank_list: registered first
    FLANK_PG_settings,
    FLANK_OT_generate_rotor,
    FLANK_OT_analyze_rotor,
    FLANK_OT_verify_plan,
    FLANK_OT_paraboloid_groove,
    FLANK_OT_formed_cutter,
    FLANK_OT_plan_double_flank,
    FLANK_OT_plan_single_flank,
    FLANK_OT_cutter_region,
    *render_report.classes,
    *export.classes,
    *animate.classes,
    *ui_ops.classes,
    *freeform.classes,
    *profile_plot.classes,
)

__all__ = ["classes", "FLANK_PG_settings", "FLANK_OT_generate_rotor", "FLANK_OT_analyze_rotor",
           "FLANK_OT_verify_plan", "FLANK_OT_paraboloid_groove", "FLANK_OT_formed_cutter",
           "FLANK_OT_plan_double_flank", "FLANK_OT_plan_single_flank", "FLANK_OT_cutter_region"]
