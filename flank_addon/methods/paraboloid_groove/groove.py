"""Doğrusadık: swept cross-section of a circular paraboloid end mill moving on a helix.

Paper frame: the screw axis is y, the section plane is z = 0 (a plane through the axis).
The tool is a lens of two circular paraboloids with its axis parallel to y; its upper half is

    y - y0 = a ((x - x0)^2 + (z - z0)^2) + b,   a < 0 < b,   y >= y0          (Doğrusadık Eq. 1)

(equator radius rho = sqrt(-b / a)).  Its centre runs on the helix of radius R and pitch p:
x0 = R cos(phi), z0 = R sin(phi), y0 = p/2 - p phi / (2 pi)  (Eqs. 2-4).  In z = 0 the
instantaneous section of the upper half is Eq. (6), valid above the equator line Eq. (7).

The machined upper section y_up(x) is the maximum over phi of Eq. (6) among the phi whose point
lies on the tool's upper half.  Where the unconstrained maximiser (Eq. 9) is admissible, y_up is
the envelope branch (Eq. 10); otherwise the maximum sits on the constraint, i.e. on the path of the
equator's intersection with the plane (Eq. 12).  A half turn about the x-axis maps the helix and
the tool onto themselves, so the lower section is the mirror image y_low = -y_up.

We work on the side x < 0 (tool centre at phi = pi), as the paper does:
- external groove (a shaft cut from outside): the part between the tool axis and the screw axis,
  x in [-R, -(R - rho)];
- internal groove (a bore cut from inside): the part beyond the tool axis, x in [-(R + rho), -R].
"""
from dataclasses import dataclass

import numpy as np


MAX_PITCH_RATIO = 1e4   # pitch / helix radius above which the helix is a straight line to the mesh's precision


class ParaboloidError(ValueError):
    """Bad tool or path parameters; the message names the value and the limit."""


@dataclass
class GrooveSection:
    x: np.ndarray          # (N,) abscissae, increasing, within [-(R + rho), -(R - rho)]
    y: np.ndarray          # (N,) upper section y_up(x)
    branch: np.ndarray     # (N,) 1 = envelope (Eq. 10), 0 = equator path (Eq. 12)
    tool_y: np.ndarray     # (N,) upper section of the tool itself at phi = pi (no helix)

    @property
    def overcut(self):
        """Material removed beyond the tool's own section, caused by the helical path (Doğrusadık Fig. 5)."""
        return self.y - self.tool_y


def _check(R, a, b, p):
    if not (np.isfinite(a) and a < 0):
        raise ParaboloidError(f"paraboloid constant a must be negative (concave tool), got {a}")
    if not (np.isfinite(b) and b > 0):
        raise ParaboloidError(f"paraboloid constant b must be positive, got {b}")
    rho = float(np.sqrt(-b / a))
    if not (np.isfinite(R) and R > rho):
        raise ParaboloidError(f"helix radius R = {R} must exceed the tool's equator radius {rho:.6g} "
                              "(the tool would cross the screw axis)")
    if not (np.isfinite(p) and p >= 0):
        raise ParaboloidError(f"pitch p must be >= 0, got {p}")
    if p > MAX_PITCH_RATIO * R:
        raise ParaboloidError(f"pitch p = {p:.6g} exceeds {MAX_PITCH_RATIO:g} x the helix radius R = {R:.6g}: "
                              "such a helix is a straight slot")
    return rho


def section_y(x, phi, R, a, b, p):
    """Doğrusadık Eq. (6): y of the tool's upper paraboloid in z = 0 for tool angle phi."""
    return a * x ** 2 - 2 * a * x * R * np.cos(phi) + a * R ** 2 + b + p / 2 - p * phi / (2 * np.pi)


def centre_y(phi, p):
    """Doğrusadık Eq. (7): height of the tool's equator plane."""
    return p / 2 - p * phi / (2 * np.pi)


def envelope_branch(x, R, a, b, p):
    """Doğrusadık Eqs. (9)-(10): (y, phi, admissible) of the envelope of the upper paraboloids."""
    x = np.asarray(x, float)
    s = p / (4 * np.pi * a * R * x)
    ok = np.abs(s) <= 1
    s = np.clip(s, -1, 1)
    phi = np.pi - np.arcsin(s)
    y = a * x ** 2 + 2 * a * x * R * np.sqrt(1 - s ** 2) + a * R ** 2 + b + p / (2 * np.pi) * np.arcsin(s)
    # admissible only where the point lies on the upper half of the tool at that phi
    ok &= y >= centre_y(phi, p) - 1e-12 * max(1.0, abs(R))
    return y, phi, ok


def equator_branch(x, R, a, b, p):
    """Doğrusadık Eq. (12): path of the equator's intersection with z = 0 (phi from Eq. 11)."""
    x = np.asarray(x, float)
    c = -(a * x ** 2 + a * R ** 2 + b) / (2 * a * x * R)
    ok = np.abs(c) <= 1 + 1e-12
    return p / (2 * np.pi) * np.arccos(np.clip(c, -1, 1)), ok


def groove_section(R, a, b, p, n=401, part="full", x=None):
    """Upper cross-section of the helical groove machined by the paraboloid tool (paper frame).

    Args:
        R, a, b, p: helix radius, paraboloid constants, pitch (any consistent length unit).
        n: number of abscissae (ignored when ``x`` is given).
        part: "full" (x in [-(R + rho), -(R - rho)]), "external" or "internal" (see module doc).
    """
    rho = _check(R, a, b, p)
    lo, hi = {"full": (-(R + rho), -(R - rho)), "external": (-R, -(R - rho)),
              "internal": (-(R + rho), -R)}[part]
    if x is None:
        if not (isinstance(n, (int, np.integer)) and n >= 2):
            raise ParaboloidError(f"the section needs at least 2 abscissae, got n = {n!r}")
        # cosine spacing: the section is steep near both ends
        x = lo + (hi - lo) * 0.5 * (1 - np.cos(np.linspace(0, np.pi, n)))
    x = np.asarray(x, float)
    y_env, _, env_ok = envelope_branch(x, R, a, b, p)
    y_eq, eq_ok = equator_branch(x, R, a, b, p)
    y = np.where(env_ok, y_env, y_eq)
    if not np.all(env_ok | eq_ok):
        bad = x[~(env_ok | eq_ok)][0]
        raise ParaboloidError(f"x = {bad:.6g} lies outside the swept section [{lo:.6g}, {hi:.6g}]")
    tool_y = np.maximum(a * (x + R) ** 2 + b, 0.0)
    return GrooveSection(x=x, y=y, branch=env_ok.astype(int), tool_y=tool_y)


def groove_meridian(R, a, b, p, n=401):
    """Closed section (upper branch, then the mirrored lower branch) as (r, z) = (-x, y) points:
    a meridian for :meth:`HelicalSurface.from_meridian` with v0 = p / (2 pi)."""
    sec = groove_section(R, a, b, p, n=n)
    upper = np.c_[-sec.x, sec.y]                 # r from R + rho down to R - rho
    lower = np.c_[-sec.x[::-1], -sec.y[::-1]][1:-1]
    return np.vstack([upper, lower])


def groove_surface(R, a, b, p, n=401, handedness="right"):
    """The machined groove (the helical tube swept by the tool) as a HelicalSurface (axis z = paper y).

    Handedness: the paper's helix turns x -> z while descending in y; in a right-handed (x, y, z)
    frame with the axis renamed z that is a left-handed screw unless mirrored.  Pass the hand of the
    real machine set-up; the section itself does not depend on it.
    """
    from ...geometry.helical_surface import HelicalSurface

    if p <= 0:
        raise ParaboloidError("a groove surface needs a pitch p > 0")
    return HelicalSurface.from_meridian(groove_meridian(R, a, b, p, n), p / (2 * np.pi), handedness)
