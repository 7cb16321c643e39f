"""Feeds and speeds: cutting data per tool and the cutting conditions of a rotor pass.

Cutting data (:class:`CuttingData`, defaults and units in docs/feeds-and-speeds.md): flutes z, cutting speed
vc (m/min), feed per tooth fz (mm), the tool's top spindle speed.  Tool presets (``presets/flank_tool``) are
keyed by name in :data:`PRESET_CUTTING_DATA`; a plan's cone is matched to a preset by tip diameter and
taper, otherwise the defaults of its kind apply (end mill, or disc cutter for a formed cutter).

Conditions of a pass (the tool fixed in the rotor frame while the rotor screws, :mod:`..geometry.screw`):

* engaged edge: the tool's surface points inside the stock cylinder, rho <= outer radius (what can cut);
* spindle speed n = min(1000 vc / (pi D_max), tool top speed, machine top speed) with D_max the largest
  engaged diameter, rounded down to whole turns (the S the posts write), so the surface speed along the
  (tapered) edge runs from pi D_min n / 1000 to vc (D_max as sampled: rings 0.5 mm apart, so up to a ring's
  growth of the diameter, about 0.3% of vc, more where a tapered tool leaves the stock between two rings);
* feed: a rotor point q moves by dS_t/dt = hand (e_z x q) + v0 e_z per radian of the screw parameter t, so
  relative to the tool it moves at omega |v(q)|, |v(q)| = sqrt(rho(q)^2 + v0^2) (omega: screw rate, rad/min).
  The feed n z fz is given to the fastest engaged point: omega = n z fz / max |v| over the engaged edge (where
  the cutting part reaches out of the stock, at the stock's radius exactly: :func:`fastest_engaged_speed`), so
  the largest chip load is fz (counted along the whole relative motion: conservative where part of it slides
  along the flutes); then omega is lowered until no joint of the pass exceeds its top speed (a joint-linear
  pass moves joint j at |dJ_j/dt| omega);
* chip load along the edge: fz(q) = omega |v(q)| / (n z); cutting time |t_end - t_start| / omega.
"""
import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CuttingData:
    flutes: int
    vc_m_min: float          # cutting speed, m/min
    fz_mm: float             # feed per tooth, mm
    max_rpm: float           # the tool's top spindle speed, 1/min
    source: str = "default"

    def __post_init__(self):
        if isinstance(self.flutes, bool) or not isinstance(self.flutes, int) or self.flutes < 1:
            raise ValueError(f"flutes must be an integer >= 1, got {self.flutes!r}")
        for name in ("vc_m_min", "fz_mm", "max_rpm"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {v!r}")

    def as_dict(self):
        return {"flutes": self.flutes, "vc_m_min": self.vc_m_min, "fz_mm": self.fz_mm,
                "max_rpm": self.max_rpm, "source": self.source}


# Finishing a steel or cast-iron rotor flank with solid carbide (documented in docs/feeds-and-speeds.md).
DEFAULT_END_MILL = CuttingData(4, 120.0, 0.03, 24000.0, "default end mill")
DEFAULT_DISC_CUTTER = CuttingData(16, 150.0, 0.05, 3000.0, "default disc cutter")

# Cutting data of the Blender tool presets (presets/flank_tool/<name>.py), finishing in steel.
PRESET_CUTTING_DATA = {
    "Tapered 1deg D1 L10": CuttingData(2, 80.0, 0.006, 30000.0, "Tapered 1deg D1 L10"),
    "Tapered 1.5deg D2 L20": CuttingData(3, 90.0, 0.010, 30000.0, "Tapered 1.5deg D2 L20"),
    "Tapered 2deg D3 L25": CuttingData(3, 100.0, 0.015, 24000.0, "Tapered 2deg D3 L25"),
    "Tapered 3deg D4 L20": CuttingData(4, 110.0, 0.020, 24000.0, "Tapered 3deg D4 L20"),
    "Tapered 1.5deg D4 L40": CuttingData(4, 100.0, 0.018, 20000.0, "Tapered 1.5deg D4 L40"),
    "Tapered 5deg D4 L16": CuttingData(4, 110.0, 0.020, 24000.0, "Tapered 5deg D4 L16"),
    "Tapered 1deg D6 L40": CuttingData(4, 110.0, 0.025, 16000.0, "Tapered 1deg D6 L40"),
    "Tapered 2deg D6 L35": CuttingData(4, 120.0, 0.030, 16000.0, "Tapered 2deg D6 L35"),
    "Tapered 3deg D6 L30": CuttingData(4, 120.0, 0.030, 16000.0, "Tapered 3deg D6 L30"),
    "Tapered 5deg D6 L20": CuttingData(4, 120.0, 0.030, 16000.0, "Tapered 5deg D6 L20"),
    "Cylindrical D6 L13": CuttingData(4, 120.0, 0.030, 20000.0, "Cylindrical D6 L13"),
    "Cylindrical D8 L19": CuttingData(4, 120.0, 0.040, 16000.0, "Cylindrical D8 L19"),
    "Cylindrical D10 L22": CuttingData(4, 120.0, 0.045, 14000.0, "Cylindrical D10 L22"),
    "Cylindrical D12 L26": CuttingData(4, 120.0, 0.050, 12000.0, "Cylindrical D12 L26"),
}
# (taper deg, tip diameter mm, flute length mm) of each preset, to recognise a plan's cone
PRESET_GEOMETRY = {
    "Tapered 1deg D1 L10": (1.0, 1.0, 10.0), "Tapered 1.5deg D2 L20": (1.5, 2.0, 20.0),
    "Tapered 2deg D3 L25": (2.0, 3.0, 25.0), "Tapered 3deg D4 L20": (3.0, 4.0, 20.0),
    "Tapered 1.5deg D4 L40": (1.5, 4.0, 40.0), "Tapered 5deg D4 L16": (5.0, 4.0, 16.0),
    "Tapered 1deg D6 L40": (1.0, 6.0, 40.0), "Tapered 2deg D6 L35": (2.0, 6.0, 35.0),
    "Tapered 3deg D6 L30": (3.0, 6.0, 30.0), "Tapered 5deg D6 L20": (5.0, 6.0, 20.0),
    "Cylindrical D6 L13": (0.0, 6.0, 13.0), "Cylindrical D8 L19": (0.0, 8.0, 19.0),
    "Cylindrical D10 L22": (0.0, 10.0, 22.0), "Cylindrical D12 L26": (0.0, 12.0, 26.0),
}


def preset_cutting_data(name):
    try:
        return PRESET_CUTTING_DATA[name]
    except KeyError:
        raise ValueError(f"no cutting data for tool preset {name!r}; presets: "
                         f"{', '.join(sorted(PRESET_CUTTING_DATA))}") from None


def cutting_data_for(tool):
    """Cutting data for a plan's ``tool`` dict (mm): the preset with the same cone (taper within 0.05 deg,
    tip diameter and flute length within 1 %), else the default of its kind."""
    if tool.get("kind") == "disc":
        return DEFAULT_DISC_CUTTER
    if tool.get("kind") == "cone" and all(k in tool for k in ("alpha", "r1c", "h")):
        taper, d, L = math.degrees(tool["alpha"]), 2.0 * tool["r1c"], tool["h"]
        for name, (tp, dp, lp) in PRESET_GEOMETRY.items():
            if abs(taper - tp) < 0.05 + (0.01 if tp == 0 else 0) and abs(d - dp) <= 0.01 * dp and abs(L - lp) <= 0.01 * lp:
                return PRESET_CUTTING_DATA[name]
    return DEFAULT_END_MILL


@dataclass
class PassConditions:
    rpm: float
    omega: float                 # screw rate, rad/min
    time_min: float
    chip_load: tuple             # (min, max) mm over the engaged edge
    surface_speed: tuple         # (min, max) m/min over the engaged edge
    engaged_diameter: tuple      # (min, max) mm
    limited_by: str              # "chip load" or the joint whose top speed capped the feed
    cutting_length: float        # length of the tool tip's path relative to the rotor, mm
    feed_mm_min: float           # fastest relative speed of the engaged edge, mm/min

    def as_dict(self):
        return {"rpm": self.rpm, "omega_rad_min": self.omega, "time_s": 60.0 * self.time_min,
                "chip_load_mm": list(self.chip_load), "surface_speed_m_min": list(self.surface_speed),
                "engaged_diameter_mm": list(self.engaged_diameter), "limited_by": self.limited_by,
                "cutting_length_mm": self.cutting_length, "feed_mm_min": self.feed_mm_min}


# rings on the cutting part at least: a tool shorter than the spacing would otherwise be sampled at its two
# poles only, where the radius is 0 (a 0.3 mm cone on a 1 mm rotor "never entered" the stock)
MIN_RINGS = 32


def engaged_edge(shape, tip, axis, outer_radius, spacing=0.5):
    """Surface samples of the cutting part inside the stock radius at the pose (tip, axis): points (K, 3)
    and their diameters (K,).  Rings at most ``spacing`` (mm) apart along the axis and at least
    :data:`MIN_RINGS` of them over the cutting part, whatever its length."""
    pts, D, rho = _edge_samples(shape, tip, axis, spacing)
    inside = rho <= outer_radius
    return pts[inside], D[inside]


def _edge_samples(shape, tip, axis, spacing):
    """Every surface sample of the cutting part at the pose (:func:`engaged_edge`): points (rings, m, 3), their
    diameters and their distances rho from the rotor axis (rings, m)."""
    from .tool_shape import perpendicular_frames

    lo, hi = shape.cutting_range()
    h, R, sh = shape.outline(min(float(spacing), (hi - lo) / MIN_RINGS))
    h, R = h[~sh], R[~sh]
    m = 48
    th = np.arange(m) * (2 * math.pi / m)
    e1, e2 = perpendicular_frames(axis)
    ring = np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2              # (m, 3)
    pts = np.asarray(tip, float) + h[:, None, None] * np.asarray(axis, float) + R[:, None, None] * ring[None]
    rho = np.hypot(pts[..., 0], pts[..., 1])
    return pts, np.broadcast_to(2.0 * R[:, None], rho.shape), rho


def fastest_engaged_speed(shape, tip, axis, rotor, spacing=0.5):
    """Largest |v(q)| = sqrt(rho(q)^2 + v0^2) (per radian of the screw parameter) over the engaged edge at the
    pose (tip, axis), with the engaged points (K, 3) and diameters (K,) of :func:`engaged_edge`.  Where the
    cutting part reaches out of the stock cylinder, its surface (connected, partly inside) crosses the cylinder,
    so the largest rho is the stock's radius exactly, whatever the sampling; otherwise the largest sampled."""
    pts, D, rho = _edge_samples(shape, tip, axis, spacing)
    inside = rho <= rotor.outer_radius
    if not inside.any():
        return 0.0, pts[inside], D[inside]
    top = rotor.outer_radius if not inside.all() else float(rho.max())
    return math.hypot(top, rotor.v0), pts[inside], D[inside]


def spindle_speed(data, max_diameter, machine_max_rpm):
    """n = min(1000 vc / (pi D_max), tool top speed, machine top speed), 1/min, rounded down to whole turns: the
    posts write S in whole turns, and the feeds are computed for the S the machine runs, so the chip load is fz
    and the surface speed vc (at the sampled D_max) as the machine cuts.  Below 1 /min there is no S to write: refused."""
    n = min(1000.0 * data.vc_m_min / (math.pi * max_diameter), data.max_rpm, machine_max_rpm)
    if not n >= 1.0:
        raise ValueError(f"spindle speed {n:.3g} /min is below 1 /min (vc {data.vc_m_min:g} m/min, engaged "
                         f"diameter {max_diameter:.4g} mm, tool top speed {data.max_rpm:g}, machine top speed "
                         f"{machine_max_rpm:g}): a program's S counts whole turns")
    return float(math.floor(n))


def pass_conditions(shape, tip, axis, rotor, data, rpm, t_span, joint_rates, joint_limits):
    """:class:`PassConditions` of a pass (module doc).  ``joint_rates``: |dJ/dt| per joint (per radian of
    t), ``joint_limits``: their top speeds (same order) and ``names``."""
    v_max, pts, D = fastest_engaged_speed(shape, tip, axis, rotor)
    if not len(pts):
        raise ValueError("the tool never enters the stock cylinder: nothing to cut")
    speed = np.hypot(np.hypot(pts[:, 0], pts[:, 1]), rotor.v0)          # |v| per radian of t
    z = data.flutes
    omega = rpm * z * data.fz_mm / v_max
    limited = "chip load"
    for name, rate, vmax in zip(joint_limits[0], joint_rates, joint_limits[1]):
        if rate > 0 and omega * rate > vmax:
            omega, limited = vmax / rate, f"{name} top speed"
    chip = omega * speed / (rpm * z)
    rho_tip = math.hypot(tip[0], tip[1])
    return PassConditions(rpm=rpm, omega=omega, time_min=abs(t_span) / omega,
                          chip_load=(float(chip.min()), omega * v_max / (rpm * z)),
                          surface_speed=(math.pi * float(D.min()) * rpm / 1000.0, math.pi * float(D.max()) * rpm / 1000.0),
                          engaged_diameter=(float(D.min()), float(D.max())), limited_by=limited,
                          cutting_length=abs(t_span) * math.hypot(rho_tip, rotor.v0),
                          feed_mm_min=omega * v_max)
