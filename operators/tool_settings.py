# SPDX-License-Identifier: GPL-3.0-or-later
"""The Tool panel's end mill read from the scene settings: its outline for the preview, and the sphere family the
free-form G1 planner takes.  Reads settings only (no property definitions here)."""
import math
import types

import bpy

CYLINDER_TAPER = 1e-4      # rad: a cylinder is planned as a cone whose radius grows h * 1e-4 over its flutes


def _cone_outline(settings, r1, r2, alpha, length, shank_r, shank_l):
    from ..flank_addon.tooling.meridian import cone_outline

    if not 0.0 <= r1 < r2:
        return None, "tip radius r1 = {:g} must be >= 0 and below r2 = {:g}".format(r1, r2)
    if settings.sf_shape == "alpha":
        if not 0.0 < alpha < 0.5 * math.pi:
            return None, "opening angle {:g} deg is outside (0, 90) deg".format(math.degrees(alpha))
        h = (r2 - r1) / math.tan(alpha)
    else:
        h = length
    if not h > 0.0:
        return None, "cone length h = {:g} must be > 0".format(h)
    return cone_outline(r1, r2, 0.0, h, shank_r, shank_l).tolist(), "cone"


def _lens_outline(pa, pb):
    if not (pa < 0.0 < pb):
        return None, "the paraboloid needs a < 0 < b (a = {:g}, b = {:g})".format(pa, pb)
    rho = math.sqrt(-pb / pa)
    rings = [rho * math.sin(0.5 * math.pi * i / 24) for i in range(1, 25)]
    top = [(r, pb + pa * r * r) for r in rings]
    bottom = [(r, -(pb + pa * r * r)) for r in reversed(rings[:-1])]
    return [(0.0, pb)] + top + bottom + [(0.0, -pb)], "paraboloid"


def tool_outline(settings):
    """(outline [(radius, height)] in scene units, label) of the tool settings, or (None, message)."""
    from ..flank_addon.tooling.meridian import cone_outline

    kind = settings.tool_kind
    vals = [float(getattr(settings, n)) for n in ("sf_r1", "sf_r2", "sf_alpha", "sf_length", "sf_shank_radius",
                                                  "sf_shank_length", "groove_a", "groove_b")]
    if not all(math.isfinite(v) for v in vals):
        return None, "a tool setting is not a finite number"
    r1, r2, alpha, length, shank_r, shank_l, pa, pb = vals
    if min(shank_r, shank_l) < 0.0:
        return None, "shank radius and length must be >= 0"
    if kind == "CONE":
        return _cone_outline(settings, r1, r2, alpha, length, shank_r, shank_l)
    if kind == "CYLINDER":
        if not (r1 > 0.0 and length > 0.0):
            return None, "cylinder radius {:g} and flute length {:g} must be > 0".format(r1, length)
        return (cone_outline(r1, r1 + length * math.tan(CYLINDER_TAPER), 0.0, length, shank_r, shank_l).tolist(),
                "cylinder")
    if kind == "PARABOLOID":
        return _lens_outline(pa, pb)
    return None, "the {} tool is made by its planner".format(kind.lower())


def freeform_tool(settings):
    """The Tool panel's end mill as the free-form planner's sphere family (scene units): namespace(r1, r2,
    length, shank_radius, shank_length) -- a cone's circles r1c < r2c become the inscribed spheres r / cos(alpha),
    the flute length h the distance of their centres h + (r2c - r1c) tan(alpha) (Bizzarri, Bo & Bartoň, Eqs. 2
    and 6); a cylinder is itself.  Values that make no cone pass through unchanged, for the planner to report."""
    r1, r2, h = float(settings.sf_r1), float(settings.sf_r2), float(settings.sf_length)
    out = types.SimpleNamespace(r1=r1, r2=r2, length=h, shank_radius=float(settings.sf_shank_radius),
                                shank_length=float(settings.sf_shank_length))
    if settings.tool_kind == "CYLINDER":
        out.r2 = r1
        return out
    alpha = float(settings.sf_alpha)
    try:
        if settings.sf_shape == "alpha":
            h = (r2 - r1) / math.tan(alpha)
        else:
            alpha = math.atan2(r2 - r1, h)
        if not (0.0 < alpha < 0.5 * math.pi and h > 0.0 and math.isfinite(h)):
            return out
        c = math.cos(alpha)
        out.r1, out.r2, out.length = r1 / c, r2 / c, h + (r2 - r1) * math.tan(alpha)
    except (ValueError, ZeroDivisionError, OverflowError):
        pass
    return out


classes = ()
register, unregister = bpy.utils.register_classes_factory(classes)
