# SPDX-License-Identifier: GPL-3.0-or-later
"""Lengths as people read them in the scene's unit system (µm, mm, m, inches, or the run's own unit)."""
import math

import bpy


def mm_per_scene_unit(scene):
    """Millimetres per Blender unit: with a unit system (metric or imperial) a Blender unit is scale_length
    metres; a unit-less scene is taken as millimetres (the convention of analysed meshes and scaled
    built-in rotors)."""
    us = getattr(scene, "unit_settings", None)
    if us is not None and us.system in ('METRIC', 'IMPERIAL'):
        sl = float(us.scale_length)
        return 1000.0 * sl if sl > 0.0 else 1000.0
    return 1.0


def length_text(value, scene, unit="mm", scale=1.0, signed=False):
    """A length held in scene units, as people read it: µm below 1 mm, else mm in metric scenes; inches in
    imperial ones; in a unit-less scene the run's own unit (``value / scale`` in ``unit``, 'mm' or 'R') --
    the conventions of the report picture (flank_addon.report.report_geometry.display_units)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        return "n/a"
    if not math.isfinite(v):
        return "n/a"
    us = scene.unit_settings
    sl = float(us.scale_length) if us.scale_length > 0.0 else 1.0
    if us.system == 'METRIC':
        x, u = v * 1000.0 * sl, "mm"
    elif us.system == 'IMPERIAL':
        x, u = v * sl / 0.0254, "in"
    else:
        x, u = v / (scale or 1.0), unit or "mm"
    fmt = "{:+.3g} {}" if signed else "{:.3g} {}"
    if u == "mm" and abs(x) < 1.0:
        x, u = 1000.0 * x, "µm"
    elif u == "mm" and abs(x) >= 1000.0 and us.system == 'METRIC':
        x, u = 0.001 * x, "m"
    return fmt.format(x, u).replace("+0 ", "0 ")


classes = ()
register, unregister = bpy.utils.register_classes_factory(classes)
