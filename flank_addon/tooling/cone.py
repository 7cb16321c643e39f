"""Truncated-cone tools and their poses (Bizzarri, Bo & Bartoň §3.2, Eqs. 2-10): the shared model of the
single-flank conical planner, its cutter selection, collision test and plan strips.

A tapered end mill is the truncated cone T with boundary circles c1 (tip) and c2 of radii
r1c < r2c, opening angle alpha and length h = |x2c - x1c|.  For flank milling it is replaced by
the one-parameter family of spheres inscribed in T (the envelope of the family is T's side):
centres on the axis, radii linear along it (Eq. 9), which is exactly what a flank-plan/1 "cone"
strip stores (axis_start/axis_end = the boundary sphere centres, radii = [r1S, r2S]).
"""
import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ConeTool:
    """Truncated cone (alpha, r1c, r2c) (Bizzarri, Bo & Bartoň's independent shape triplet) plus a cylindrical shank.

    alpha: opening angle (rad), 0 < alpha < pi/2; r1c < r2c radii of the tip and top circles;
    shank_radius / shank_length: the holder cylinder that continues the axis beyond c2
    (0 = no shank).  All lengths in the plan's length unit."""
    alpha: float
    r1c: float
    r2c: float
    shank_radius: float = 0.0
    shank_length: float = 0.0

    def __post_init__(self):
        a, r1, r2 = self.alpha, self.r1c, self.r2c
        for name, v in (("alpha", a), ("r1c", r1), ("r2c", r2), ("shank_radius", self.shank_radius),
                        ("shank_length", self.shank_length)):
            if not (isinstance(v, (int, float)) and math.isfinite(v)):
                raise ValueError(f"cone tool: {name} = {v!r} is not a finite number")
        if not 0.0 < a < 0.5 * math.pi:
            raise ValueError(f"cone tool: opening angle alpha = {a} rad is outside (0, pi/2)")
        if not 0.0 <= r1 < r2:
            raise ValueError(f"cone tool: radii must satisfy 0 <= r1 < r2, got r1 = {r1}, r2 = {r2}")
        if 0.0 < r1 < 1e-6 * r2:
            # a tip circle a millionth of the top's is a sharp tip to any tolerance, and its sphere would set the
            # sampling of the checks a millionth apart
            raise ValueError(f"cone tool: tip radius r1 = {r1:g} is under a millionth of r2 = {r2:g}: give 0 for a "
                             "sharp tip")
        if self.shank_radius < 0 or self.shank_length < 0:
            raise ValueError(f"cone tool: shank radius {self.shank_radius} and length "
                             f"{self.shank_length} must be >= 0")

    @classmethod
    def from_length(cls, r1c, r2c, h, **shank):
        """The cone with circle radii r1c < r2c a distance h apart (Eq. 3: tan alpha = (r2 - r1) / h)."""
        if not (math.isfinite(h) and h > 0):
            raise ValueError(f"cone tool: length h = {h} must be > 0")
        return cls(math.atan2(r2c - r1c, h), r1c, r2c, **shank)

    @property
    def h(self):
        """Distance of the boundary circles' centres (Eq. 5)."""
        return (self.r2c - self.r1c) / math.tan(self.alpha)

    @property
    def r1s(self):
        """Radius of the inscribed sphere touching T along c1 (Eq. 2)."""
        return self.r1c / math.cos(self.alpha)

    @property
    def r2s(self):
        return self.r2c / math.cos(self.alpha)

    @property
    def L(self):
        """Distance of the boundary spheres' centres (Eqs. 6-7)."""
        return self.h + (self.r2c - self.r1c) * math.tan(self.alpha)

    @property
    def c1_offset(self):
        """Axial offset of the tip sphere centre x1S from the tip circle centre x1c (Eq. 2)."""
        return self.r1c * math.tan(self.alpha)

    def radius(self, s):
        """Inscribed-sphere radius r(s) = (1 - s) r1S + s r2S, s in [0, 1] along x1S -> x2S (Eq. 9)."""
        s = np.asarray(s, float)
        return (1.0 - s) * self.r1s + s * self.r2s

    def as_dict(self):
        return {"kind": "cone", "alpha": self.alpha, "r1c": self.r1c, "r2c": self.r2c, "h": self.h,
                "shank_radius": self.shank_radius, "shank_length": self.shank_length}


def axis_segment(beta, phi, delta, rho, L, s):
    """Points o(s) (N, 3) of the tool axis segment of Eq. (8) for s (N,) in [0, 1].

    beta: angle of the axis with the plane z = 0; phi: turn about z; delta: distance of the axis
    from the z axis; rho: signed distance from x1S = o(0) to the axis' crossing with z = 0;
    L: length of the segment x1S -> x2S."""
    s = np.asarray(s, float)
    w = rho + L * s
    cb, sb, cp, sp = math.cos(beta), math.sin(beta), math.cos(phi), math.sin(phi)
    return np.stack([delta * cp - w * cb * sp, w * cb * cp + delta * sp, w * sb], axis=-1)


@dataclass
class ConePose:
    """A cone tool fixed in the rotor frame while the rotor screws: the tip sphere centre x1S
    (``tip``, (3,)) and the unit axis direction ``axis`` (3,) from the tip towards the shank."""
    tool: ConeTool
    tip: np.ndarray
    axis: np.ndarray

    def __post_init__(self):
        self.tip = np.asarray(self.tip, float).reshape(3)
        a = np.asarray(self.axis, float).reshape(3)
        n = float(np.linalg.norm(a))
        if not (np.isfinite(self.tip).all() and math.isfinite(n) and n > 0):
            raise ValueError(f"cone pose: tip {self.tip} / axis {a} must be finite with a non-zero axis")
        self.axis = a / n

    @property
    def top(self):
        """x2S, the centre of the top boundary sphere."""
        return self.tip + self.tool.L * self.axis

    def sphere_centres(self, s):
        """Centres of the inscribed spheres at s (N,) in [0, 1]; radii: ``tool.radius(s)``."""
        return self.tip + np.asarray(s, float)[:, None] * (self.tool.L * self.axis)

    @property
    def shank(self):
        """(start, end, radius) of the shank cylinder, starting at the top circle c2, or None."""
        t = self.tool
        if t.shank_radius <= 0 or t.shank_length <= 0:
            return None
        c2 = self.top - t.r2c * math.tan(t.alpha) * self.axis
        return c2, c2 + t.shank_length * self.axis, t.shank_radius

    def strip(self, flank, max_error=0.0, min_error=0.0, collision=False, **extra):
        """The flank-plan/1 strip of this pose (cone: radii at the two boundary spheres)."""
        d = {"axis_start": self.tip.tolist(), "axis_end": self.top.tolist(),
             "radii": [self.tool.r1s, self.tool.r2s], "flank": int(flank),
             "reported_max_error": float(max_error), "reported_min_error": float(min_error),
             "collision": bool(collision)}
        sh = self.shank
        if sh is None:       # flank-plan/1 always carries the shank fields: a zero-radius one
            sh = (self.top, self.top, 0.0)
        d.update(shank_start=np.asarray(sh[0]).tolist(), shank_end=np.asarray(sh[1]).tolist(),
                 shank_radius=float(sh[2]))
        d.update(extra)
        return d
