"""The shipped tool presets (``presets/flank_tool/<name>.py``) as cones, without Blender.

A preset file is a Blender preset script: lines ``settings.<field> = <literal>`` (Tool panel > Tool Presets).
Here they are read as text (each value by :func:`ast.literal_eval`, nothing is executed) into
:class:`ToolPreset` s, the catalogue the single-flank planner picks its tools from (``--tools auto`` or
``--tools NAME1,NAME2``).  Dimensions are in mm and degrees:

* ``CONE``: taper per side (deg), tip diameter, flute length, shank diameter and length.  The cone of
  Bizzarri, Bo & Bartoň Eqs. (2)-(5): r1c = tip diameter / 2, h = flute length, r2c = r1c + h tan(taper);
* ``CYLINDER``: diameter and flute length; planned as the cone of taper :data:`CYLINDER_TAPER` (its radius
  grows h x 1e-4 over the flutes), as the Blender layer does;
* the shank cylinder continues the axis beyond the top circle for the shank length.
"""
import ast
import math
import re
from dataclasses import dataclass
from pathlib import Path

from .catalogue import positive_number, scale_tool
from .cone import ConeTool

CYLINDER_TAPER = 1e-4          # rad: a cylinder is planned as a cone of this taper
PRESET_DIR = Path(__file__).resolve().parents[2] / "presets" / "flank_tool"
_LINE = re.compile(r"^\s*settings\.([A-Za-z_][A-Za-z0-9_]*)\s*=\s*(.+?)\s*$")
_FIELDS = ("tool_kind", "tool_tip_diameter_mm", "tool_flute_length_mm", "tool_shank_diameter_mm",
           "tool_shank_length_mm")


@dataclass(frozen=True)
class ToolPreset:
    """One shipped end mill (mm, degrees); :meth:`tool` is its cone in mm or scaled to another unit."""
    name: str
    kind: str                   # "CONE" | "CYLINDER"
    taper_deg: float
    tip_diameter_mm: float
    flute_length_mm: float
    shank_diameter_mm: float
    shank_length_mm: float

    def tool(self, mm_per_unit=1.0):
        """The :class:`cone.ConeTool` of the preset in a length unit of ``mm_per_unit`` mm (1: mm; a
        built-in rotor of outer radius R = 50 mm: 50, lengths in units of R)."""
        alpha = CYLINDER_TAPER if self.kind == "CYLINDER" else math.radians(self.taper_deg)
        r1 = 0.5 * self.tip_diameter_mm
        t = ConeTool(alpha, r1, r1 + self.flute_length_mm * math.tan(alpha), shank_radius=0.5 * self.shank_diameter_mm,
                     shank_length=self.shank_length_mm)
        k = positive_number(mm_per_unit, "mm per length unit")
        return t if k == 1.0 else scale_tool(t, 1.0 / k)

    def tool_dict(self, mm_per_unit=1.0):
        """The flank-plan/1 ``tool`` object of the preset (:meth:`cone.ConeTool.as_dict` plus its name)."""
        return dict(self.tool(mm_per_unit).as_dict(), name=self.name)


def read_preset(path):
    """:class:`ToolPreset` of one preset file; a file that is not a cone or cylinder preset raises ValueError
    naming the file and the field."""
    path = Path(path)
    values = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        m = _LINE.match(line)
        if m:
            try:
                values[m.group(1)] = ast.literal_eval(m.group(2))
            except (ValueError, SyntaxError):
                raise ValueError(f"tool preset {path.name}: {m.group(1)} = {m.group(2)!r} is not a literal") from None
    kind = values.get("tool_kind")
    if kind not in ("CONE", "CYLINDER"):
        raise ValueError(f"tool preset {path.name}: tool_kind {kind!r} is not CONE or CYLINDER")
    for key in _FIELDS[1:] + (("tool_taper_deg",) if kind == "CONE" else ()):
        v = values.get(key)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
            raise ValueError(f"tool preset {path.name}: {key} = {v!r} must be a finite number >= 0")
    taper = float(values.get("tool_taper_deg", 0.0)) if kind == "CONE" else 0.0
    if kind == "CONE" and not 0.0 < taper < 45.0:
        raise ValueError(f"tool preset {path.name}: taper {taper} deg is outside (0, 45)")
    if not (values["tool_tip_diameter_mm"] > 0 and values["tool_flute_length_mm"] > 0):
        raise ValueError(f"tool preset {path.name}: tip diameter and flute length must be > 0")
    return ToolPreset(path.stem, kind, taper, float(values["tool_tip_diameter_mm"]),
                      float(values["tool_flute_length_mm"]), float(values["tool_shank_diameter_mm"]),
                      float(values["tool_shank_length_mm"]))


def load_presets(directory=None):
    """Every preset of ``directory`` (default: the shipped ``presets/flank_tool``), sorted by name."""
    d = Path(directory) if directory is not None else PRESET_DIR
    if not d.is_dir():
        raise ValueError(f"tool preset folder {d} does not exist")
    out = [read_preset(p) for p in sorted(d.glob("*.py"))]
    if not out:
        raise ValueError(f"tool preset folder {d} holds no preset (*.py)")
    return out


def presets_by_name(names, directory=None):
    """The presets named in ``names`` (a list, or one comma-separated string), in that order; an unknown name
    raises ValueError listing the shipped ones."""
    if isinstance(names, str):
        names = [n.strip() for n in names.split(",") if n.strip()]
    if not names:
        raise ValueError("no tool preset named")
    known = {p.name: p for p in load_presets(directory)}
    out = []
    for n in names:
        if n not in known:
            raise ValueError(f"no tool preset {n!r}; presets: {', '.join(sorted(known))}")
        if known[n] in out:
            raise ValueError(f"tool preset {n!r} is named twice")
        out.append(known[n])
    return out
