"""The finite rotor a program must respect: helical body, stock cylinder, shafts and lobes, in the rotor frame.

Rotor frame (flank-plan/1): helical axis = z through the origin.  The *stock cylinder* is
rho = sqrt(x^2 + y^2) <= outer radius over the body's axial extent z0 <= z <= z1; every shaft is a coaxial
cylinder rho <= r over its own z range.  *Holders* (the chuck and the tailstock that hold the rotor by its
shafts, :func:`with_holders`) are coaxial cylinders beyond the body's end faces, given by the user.  Cutting
passes may enter the stock (that is what they cut); no other move may enter the stock, and no move at all may
enter a shaft or a holder (together the *keep-out* solids).

Where the extent comes from, in this order: the plan's optional ``rotor.extent`` (written by the planners
since it exists), the analysis of the rotor mesh the plan was made on (its body and shafts mapped into the
plan's rotor frame), or an explicit extent.  A plan in units of R has to be scaled to millimetres first
(:func:`scale_plan`).

Lobes: the number of lobe tips of the profile (:func:`..geometry.rotor_analysis.split_flanks`); lobe k is
the planned flank turned by 2 pi k / lobes about z.  ``symmetry_error`` is how far the profile turned by one
lobe pitch lies from itself (0 for an exactly symmetric rotor).
"""
import copy
import math
from dataclasses import dataclass, field

import numpy as np


class ExtentError(ValueError):
    """The rotor's axial extent is unknown or does not fit the plan; the message says what to pass."""


@dataclass
class RotorBody:
    v0: float                       # axial advance per radian (mm)
    hand: int                       # +1 right, -1 left
    outer_radius: float
    z_range: tuple                  # (z0, z1) axial extent of the helical body
    shafts: list = field(default_factory=list)     # [(z_a, z_b, radius), ...]
    lobes: int = 1
    symmetry_error: float = 0.0
    profile: np.ndarray = None      # (K, 2) transverse profile of the whole rotor
    holders: list = field(default_factory=list)    # [(z_a, z_b, radius), ...] chuck, tailstock (with_holders)

    @property
    def length(self):
        return float(self.z_range[1] - self.z_range[0])

    @property
    def keep_out(self):
        """The solids no move may enter, cutting or not: the shafts and the holders [(z_a, z_b, radius), ...]."""
        return list(self.shafts) + list(self.holders)

    @property
    def keep_out_names(self):
        """Names of the :attr:`keep_out` solids, in their order, for messages."""
        z0, z1 = self.z_range
        return ([f"shaft {k + 1}" for k in range(len(self.shafts))]
                + [f"holder {k + 1} (at the {'low' if b <= z0 else 'high'} end, diameter {2 * r:g} mm)"
                   for k, (a, b, r) in enumerate(self.holders)])

    @property
    def keep_out_words(self):
        """How messages name the keep-out solids."""
        return "a shaft or a holder" if self.holders else "a shaft"

    @property
    def solids_words(self):
        """How messages name the stock with the keep-out solids."""
        return "the stock, a shaft or a holder" if self.holders else "the stock or a shaft"

    def solid_at(self, point):
        """The name of the solid (the stock, a shaft, a holder) a rotor-frame point lies deepest in, or None
        outside them all."""
        p = np.asarray(point, float).reshape(3)
        rho = math.hypot(p[0], p[1])
        best, name = 0.0, None
        solids = [(self.z_range[0], self.z_range[1], self.outer_radius)] + self.keep_out
        for (a, b, r), n in zip(solids, ["the stock"] + self.keep_out_names):
            depth = min(r - rho, p[2] - a, b - p[2])
            if depth > best:
                best, name = depth, n
        return name

    def keep_out_clearance(self, rho, lo, hi):
        """(margin, index) of tool points over a pass: each point's distance ``rho`` from the axis (a screw motion
        keeps it) and the heights ``lo``..``hi`` it sweeps; margin = smallest rho - radius over the points whose
        heights meet a keep-out solid's z range, index = that solid in :attr:`keep_out`; (inf, None) when no
        point passes over one."""
        margin, worst = math.inf, None
        for k, (a, b, r) in enumerate(self.keep_out):
            over = (hi >= a) & (lo <= b)
            if over.any():
                m = float((rho[over] - r).min())
                if m < margin:
                    margin, worst = m, k
        return margin, worst

    def safe_radius(self, clearance):
        """Outer radius of everything (stock, shafts and holders) plus ``clearance``."""
        return max([self.outer_radius] + [s[2] for s in self.keep_out]) + float(clearance)

    def lobe_angle(self, k):
        """Turn (rad) about z that carries lobe 0 onto lobe k."""
        return 2.0 * math.pi * k / self.lobes

    def intrusion(self, points, stock=True, margin=0.0):
        """Depth (N,) by which rotor-frame points (N, 3) lie inside the stock cylinder (if ``stock``) or a
        keep-out solid, each grown by ``margin``: min(r - rho, z - z_a, z_b - z) of the deepest solid, 0 outside."""
        p = np.asarray(points, float).reshape(-1, 3)
        rho = np.hypot(p[:, 0], p[:, 1])
        z = p[:, 2]
        solids = self.keep_out
        if stock:
            solids.append((self.z_range[0], self.z_range[1], self.outer_radius))
        depth = np.zeros(len(p))
        for a, b, r in solids:
            a, b, r = a - margin, b + margin, r + margin
            d = np.minimum(np.minimum(r - rho, z - a), b - z)
            depth = np.maximum(depth, d)
        return depth

    def describe(self):
        return {"z_range": [float(z) for z in self.z_range], "outer_radius": self.outer_radius,
                "shafts": [{"z_range": [a, b], "radius": r} for a, b, r in self.shafts],
                "holders": [{"z_range": [a, b], "radius": r} for a, b, r in self.holders],
                "lobes": self.lobes, "symmetry_error": self.symmetry_error,
                "v0": self.v0, "handedness": "right" if self.hand > 0 else "left"}


def lobe_count(profile):
    """(lobes, symmetry error): lobe tips of a closed profile (K, 2) and the distance by which the profile
    turned by one lobe pitch misses itself (largest over its points)."""
    from ..geometry.rotor_analysis import split_flanks
    from ..geometry.screw import rotate2d
    from ..simulation.collision import ProfileSolid

    prof = np.asarray(profile, float)
    _, lobes = split_flanks(prof)
    lobes = max(int(lobes), 1)
    if lobes == 1:
        return 1, 0.0
    dist, _ = ProfileSolid(prof).nearest(rotate2d(prof, 2.0 * math.pi / lobes))
    return lobes, float(dist.max())


def scale_plan(plan, factor, unit="mm"):
    """A copy of a rotor plan with every length multiplied by ``factor`` (a plan in units of R made
    millimetres by the rotor's outer radius in mm).  Angles, indices and flags are unchanged."""
    k = float(factor)
    if not (math.isfinite(k) and k > 0):
        raise ValueError(f"scale factor {factor!r} must be a finite number > 0")
    out = copy.deepcopy(plan)
    rot = out["rotor"]
    rot["profile"] = (np.asarray(rot["profile"], float) * k).tolist()
    rot["v0"] = rot["v0"] * k
    rot["outer_radius"] = rot["outer_radius"] * k
    T = np.asarray(rot["to_world"], float)
    T[:3, 3] *= k                             # the model frame is scaled alike (a rigid map stays rigid)
    rot["to_world"] = T.tolist()
    if rot.get("extent") is not None:
        from ..io.plan import scaled_extent

        rot["extent"] = scaled_extent(rot["extent"], k)
    for s in out["strips"]:
        for key in ("axis_start", "axis_end", "shank_start", "shank_end"):
            if key in s:
                s[key] = [x * k for x in s[key]]
        for key in ("radii",):
            s[key] = [x * k for x in s[key]]
        s["shank_radius"] = s["shank_radius"] * k
        s["reported_max_error"] *= k
        s["reported_min_error"] *= k
        if s.get("meridian") is not None:
            s["meridian"] = (np.asarray(s["meridian"], float) * k).tolist()
        if s.get("paraboloid") is not None:
            s["paraboloid"] = {"a": s["paraboloid"]["a"] / k, "b": s["paraboloid"]["b"] * k}
    for tool in [out.get("tool", {})] + [s["tool"] for s in out["strips"] if isinstance(s.get("tool"), dict)]:
        for key in ("r1", "r2", "length", "r1c", "r2c", "h", "shank_radius", "shank_length", "centre_distance",
                    "max_diameter", "width", "arbor_radius", "arbor_length"):
            if isinstance(tool.get(key), (int, float)) and not isinstance(tool.get(key), bool):
                tool[key] = tool[key] * k
    for key in ("max_error", "min_error"):
        out["summary"][key] *= k
    if isinstance(out.get("tolerance"), (int, float)):
        out["tolerance"] *= k
    if isinstance(out.get("overcut_tolerance"), (int, float)):
        out["overcut_tolerance"] *= k
    lengths = ("length", "max_deviation", "min_deviation", "radius", "depth_min", "depth_max", "proven_depth_min",
               "deviation_min")
    for ru in out["summary"].get("uncovered", []) or []:     # single-flank residual: lengths, not parameters
        if isinstance(ru.get("arc_range"), list):
            ru["arc_range"] = [x * k for x in ru["arc_range"]]
        for d in [ru, ru.get("bound") or {}] + list(ru.get("tools") or []):
            for key in lengths:
                if isinstance(d.get(key), (int, float)) and not isinstance(d.get(key), bool):
                    d[key] *= k
    out["length_unit"] = unit
    return out


def extent_from_analysis(plan, analysis):
    """The extent of a mesh's :class:`RotorAnalysis` mapped into the plan's rotor frame.

    Both frames put z on the same screw axis (the plan was made on the mesh); the analysis' z becomes
    the plan's by z_plan = s z + c.  Refused, naming the mismatch, when the axes differ."""
    T = np.asarray(plan["rotor"]["to_world"], float)
    Ti = np.linalg.inv(T)
    A = np.asarray(analysis.to_world, float)
    R = float(plan["rotor"]["outer_radius"])
    o = (Ti @ A[:, 3])[:3]
    d = Ti[:3, :3] @ A[:3, 2]
    s = float(np.linalg.norm(d))
    d = d / s
    if abs(abs(d[2]) - 1.0) > 1e-6 or math.hypot(o[0], o[1]) > 1e-3 * R:
        raise ExtentError("the mesh's screw axis is not the plan's rotor axis (axis off by "
                          f"{math.degrees(math.acos(min(1.0, abs(d[2])))):.3g} deg, "
                          f"{math.hypot(o[0], o[1]):.3g} {plan['length_unit']}): pass the mesh the plan was made on")
    sign = 1.0 if d[2] > 0 else -1.0

    def zmap(z0, z1):
        a, b = sorted((o[2] + sign * s * z0, o[2] + sign * s * z1))
        return [a, b]

    ext = {"z_range": zmap(*analysis.body_z), "shafts": []}
    for sh in analysis.shafts:
        ext["shafts"].append({"z_range": zmap(*sh["z_range"]), "radius": s * sh["radius"]})
    return ext


def rotor_body(plan, extent=None):
    """The :class:`RotorBody` of a rotor plan in mm: its extent from ``extent`` (dict as rotor.extent) or
    the plan's ``rotor.extent``; :class:`ExtentError` saying what to pass when neither is there."""
    from ..geometry.screw import hand_sign

    if plan.get("surface") is not None:
        raise ExtentError("a free-form plan has no rotor: whole-rotor programs are made from rotor plans")
    if plan["length_unit"] != "mm":
        raise ExtentError(f"the plan's lengths are in {plan['length_unit']!r}; machine programs are in mm: "
                          "pass --outer-radius-mm (the rotor's outer radius in mm) to scale it")
    rot = plan["rotor"]
    ext = extent if extent is not None else rot.get("extent")
    if ext is None:
        raise ExtentError("the plan records no rotor extent (rotor.extent: the body's axial range and shafts): "
                          "pass --mesh ROTOR_MESH (the rotor mesh it was planned on) or plan it again, the "
                          "planners record the extent")
    from ..io.plan import rotor_extent
    ext = rotor_extent(ext["z_range"], ext.get("shafts", []))
    prof = np.asarray(rot["profile"], float)
    lobes, sym = lobe_count(prof)
    return RotorBody(v0=float(rot["v0"]), hand=hand_sign(rot["handedness"]),
                     outer_radius=float(rot["outer_radius"]), z_range=tuple(ext["z_range"]),
                     shafts=[(s["z_range"][0], s["z_range"][1], s["radius"]) for s in ext["shafts"]],
                     lobes=lobes, symmetry_error=sym, profile=prof)


HOLDER_SIDES = ("low", "high")
MAX_HOLDER_MM = 1e5          # largest diameter, length or gap of a holder (100 m: beyond any machine)


def parse_holder(text):
    """(side, diameter, length, gap) of a holder given as ``SIDE,DIAMETER,LENGTH[,GAP]`` (mm); ValueError
    naming the value otherwise (the limits of :func:`with_holders`)."""
    parts = [x.strip() for x in str(text).split(",")]
    if len(parts) not in (3, 4):
        raise ValueError(f"holder {text!r} must be SIDE,DIAMETER,LENGTH[,GAP] (mm), e.g. low,160,80,20")
    try:
        numbers = [float(x) for x in parts[1:]]
    except ValueError:
        raise ValueError(f"holder {text!r}: DIAMETER, LENGTH and GAP must be numbers (mm)") from None
    return (parts[0].lower(), *numbers, *([0.0] if len(numbers) == 2 else []))


def check_holder(holder, k=None):
    """``holder`` (side, diameter, length, gap) as floats, or ValueError naming holder k + 1 (or just "holder"),
    the value and its limit."""
    side, diameter, length, gap = holder
    what = "holder" if k is None else f"holder {k + 1}"
    if side not in HOLDER_SIDES:
        raise ValueError(f"{what}: side {side!r} must be one of {', '.join(HOLDER_SIDES)} (the end of the "
                         "body at the smaller or the larger rotor-frame z)")
    for name, value, least in (("diameter", diameter, "> 0"), ("length", length, "> 0"), ("gap", gap, ">= 0")):
        value = float(value)
        if not (math.isfinite(value) and (value > 0.0 if least == "> 0" else value >= 0.0)
                and value <= MAX_HOLDER_MM):
            raise ValueError(f"{what} ({side}): {name} {value!r} must be a number {least} and at most "
                             f"{MAX_HOLDER_MM:g} mm")
    return side, float(diameter), float(length), float(gap)


def parse_holders(text):
    """The holders of a text of ``SIDE,DIAMETER,LENGTH[,GAP]`` separated by ';' (mm; empty: none), checked
    (:func:`check_holder`); ValueError naming the one that is not."""
    items = [x for x in str(text).split(";") if x.strip()]
    return [check_holder(parse_holder(x), k) for k, x in enumerate(items)]


def with_holders(rotor, holders):
    """A copy of ``rotor`` holding it between ``holders`` [(side, diameter, length, gap), ...] (mm): coaxial
    cylinders of the given diameter beyond an end face of the body, ``gap`` away from it.  Side "low" is the end
    at the body's smaller rotor-frame z (z0): the holder spans z0 - gap - length .. z0 - gap; "high" the other:
    z1 + gap .. z1 + gap + length.  They usually grip a shaft (a chuck, a collet, a tailstock's centre and
    driver): no move may enter them, so a pass that runs out into one is refused and every link keeps its
    clearance from the largest of them."""
    import dataclasses

    out = []
    for k, h in enumerate(holders):
        side, diameter, length, gap = check_holder(h, k)
        z0, z1 = rotor.z_range
        za, zb = (z0 - gap - length, z0 - gap) if side == "low" else (z1 + gap, z1 + gap + length)
        out.append((float(za), float(zb), 0.5 * float(diameter)))
    return dataclasses.replace(rotor, holders=list(rotor.holders) + out)
