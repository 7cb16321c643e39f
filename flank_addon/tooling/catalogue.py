"""The catalogue of tapered end mills the cutter selection chooses from (Bizzarri, Bo & Bartoň, Section 4).

Lengths in mm unless a rotor's outer radius scales them to units of R.
"""
import dataclasses
import math
from dataclasses import dataclass

from .cone import ConeTool


@dataclass(frozen=True)
class CatalogueTool:
    """A named catalogue cutter (its :class:`cone.ConeTool` in some length unit)."""
    name: str
    tool: ConeTool
    unit: str = "mm"


# Common solid-carbide tapered end mills (taper per side, tip diameter, flute length, shank diameter,
# overall length; mm).  The cone: r1c = tip diameter / 2, h = flute length, r2c = r1c + h tan(taper);
# the shank cylinder carries on from the top circle for (overall - flute) length.
TAPERED_END_MILLS_MM = (
    # name,                       taper_deg, tip_d, flute_l, shank_d, overall_l
    ("taper 1.0deg D1.0 L10",       1.0,     1.0,   10.0,     4.0,    50.0),
    ("taper 1.0deg D2.0 L20",       1.0,     2.0,   20.0,     4.0,    60.0),
    ("taper 1.0deg D3.0 L30",       1.0,     3.0,   30.0,     6.0,    75.0),
    ("taper 1.0deg D6.0 L40",       1.0,     6.0,   40.0,     8.0,    90.0),
    ("taper 1.5deg D1.0 L15",       1.5,     1.0,   15.0,     4.0,    55.0),
    ("taper 1.5deg D2.0 L20",       1.5,     2.0,   20.0,     4.0,    60.0),
    ("taper 1.5deg D3.0 L30",       1.5,     3.0,   30.0,     6.0,    75.0),
    ("taper 1.5deg D4.0 L40",       1.5,     4.0,   40.0,     8.0,    90.0),
    ("taper 2.0deg D1.0 L10",       2.0,     1.0,   10.0,     4.0,    50.0),
    ("taper 2.0deg D2.0 L15",       2.0,     2.0,   15.0,     4.0,    55.0),
    ("taper 2.0deg D3.0 L25",       2.0,     3.0,   25.0,     6.0,    70.0),
    ("taper 2.0deg D6.0 L35",       2.0,     6.0,   35.0,    10.0,    90.0),
    ("taper 3.0deg D1.0 L10",       3.0,     1.0,   10.0,     4.0,    50.0),
    ("taper 3.0deg D2.0 L15",       3.0,     2.0,   15.0,     6.0,    55.0),
    ("taper 3.0deg D4.0 L20",       3.0,     4.0,   20.0,     8.0,    65.0),
    ("taper 3.0deg D6.0 L30",       3.0,     6.0,   30.0,    10.0,    80.0),
    ("taper 5.0deg D1.0 L8",        5.0,     1.0,    8.0,     4.0,    50.0),
    ("taper 5.0deg D2.0 L12",       5.0,     2.0,   12.0,     6.0,    55.0),
    ("taper 5.0deg D4.0 L16",       5.0,     4.0,   16.0,     8.0,    60.0),
    ("taper 5.0deg D6.0 L20",       5.0,     6.0,   20.0,    10.0,    70.0),
)


def catalogue_tools(outer_radius_mm=None, table=TAPERED_END_MILLS_MM):
    """The catalogue as :class:`CatalogueTool` s: in mm, or in units of R when the rotor's outer
    radius ``outer_radius_mm`` (mm) is given (every length divided by it; angles unchanged)."""
    out = []
    for name, taper_deg, tip_d, flute, shank_d, overall in table:
        al = math.radians(taper_deg)
        r1 = 0.5 * tip_d
        t = ConeTool(al, r1, r1 + flute * math.tan(al), shank_radius=0.5 * shank_d,
                     shank_length=overall - flute)
        out.append(CatalogueTool(name, t, "mm"))
    if outer_radius_mm is None:
        return out
    return [CatalogueTool(c.name, scale_tool(c.tool, 1.0 / positive_number(outer_radius_mm, "outer_radius_mm")), "R")
            for c in out]


def positive_number(v, name):
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise ValueError(f"{name} = {v!r} is not a number") from None
    if not (math.isfinite(f) and f > 0):
        raise ValueError(f"{name} = {v!r} must be a finite number > 0")
    return f


def scale_tool(tool, factor):
    """The cone ``tool`` with every length multiplied by ``factor`` (> 0); alpha is unchanged."""
    k = positive_number(factor, "scale factor")
    return dataclasses.replace(tool, r1c=tool.r1c * k, r2c=tool.r2c * k, shank_radius=tool.shank_radius * k,
                               shank_length=tool.shank_length * k)
