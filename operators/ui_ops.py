# SPDX-License-Identifier: GPL-3.0-or-later
"""The sidebar's Run button: which planner the chosen strategy calls, with which of the scene settings (the
Tool panel's end mill turned into the planner's tool)."""
import math

import bpy

from .properties import (double_flank_props, formed_cutter_props, freeform_props, paraboloid_props,
                         single_flank_props)
from .tool_settings import CYLINDER_TAPER, freeform_tool

# strategy -> (operator, prefix of its scene settings, its property definitions)
PLANNERS = {
    "SINGLE": ("flank.plan_single_flank", "sf_", single_flank_props),
    "DOUBLE": ("flank.plan_double_flank", "df_", double_flank_props),
    "TWO_PATHS": ("flank.plan_double_flank", "df_", double_flank_props),
    "FORMED": ("flank.formed_cutter", "cutter_", formed_cutter_props),
    "GROOVE": ("flank.paraboloid_groove", "groove_", paraboloid_props),
    "FREEFORM": ("flank.plan_freeform", "ff_", freeform_props),
}
_NAMES = {}

__all__ = ["PLANNERS", "run_call"]


def _planner_names(strategy):
    if strategy not in _NAMES:
        _NAMES[strategy] = tuple(PLANNERS[strategy][2]().keys())
    return _NAMES[strategy]


def run_call(settings):
    """(operator idname, keyword arguments) of the chosen strategy's planner from the scene settings: what the
    Run button calls.  A cylinder runs as a cone of taper CYLINDER_TAPER (its radius grows h x 1e-4)."""
    strategy = settings.strategy
    idname, pre, _ = PLANNERS[strategy]
    kw = {}
    for name in _planner_names(strategy):
        v = getattr(settings, pre + name)
        kw[name] = tuple(v) if hasattr(v, "__len__") and not isinstance(v, (str, set)) else v
    if strategy == "SINGLE" and settings.tool_kind == "CYLINDER":
        h = float(settings.sf_length)
        kw.update(shape="alpha", alpha=CYLINDER_TAPER, r2=float(settings.sf_r1) + h * math.tan(CYLINDER_TAPER))
    elif strategy == "DOUBLE":
        kw["two_paths"] = False
    elif strategy == "TWO_PATHS":
        kw.update(two_paths=True, tool="custom")
    elif strategy == "FREEFORM":
        t = freeform_tool(settings)
        kw.update(r1=t.r1, r2=t.r2, length=t.length, shank_radius=t.shank_radius, shank_length=t.shank_length)
    return idname, kw


classes = ()
register, unregister = bpy.utils.register_classes_factory(classes)
