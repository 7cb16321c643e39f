"""A strip's tool solid in its own frame, so that a program's poses (tip point + unit axis) can carry it.

Tool frame: the programmed point (the tool tip of :func:`..exports.cl_data.strip_tip`) at h = 0, h along the
unit axis from tip to shank.  A flank-plan/1 strip is the same solid placed at the pose (T, a) of that
strip: axis_start = T + h_start a, axis_end = T + h_end a, shank from T + h_s0 a to T + h_s1 a.  Shapes
(as :mod:`..simulation.sweep` reads a strip):

- ``radii``:   spheres of radii r_0..r_m at equally spaced axis points; their hull is the union of the
               spheres with linearly interpolated centres and radii, so its radius in the plane h is
               R(h) = max_s sqrt(r(s)^2 - (h - c(s))^2);
- ``meridian``: R(h) piecewise linear through [[h, R], ...] (h from axis_start), flat end faces;
- ``paraboloid``: the lens |h - h_start| <= b + a R^2, i.e. R(h) = sqrt((b - |h - h_start|) / -a);
- the shank: a flat-ended cylinder of ``shank_radius``.

:meth:`ToolShape.outline` gives R(h) of the cutting part and the shank, :meth:`ToolShape.local_points` rings
of surface points (and the end faces) no farther apart than a given spacing, in the tool frame (x, y, h).
"""
import hashlib
import json
import math
from dataclasses import dataclass

import numpy as np


def perpendicular_frames(axes):
    """Unit vectors e1, e2 (N, 3) with (e1, e2, a) right-handed for unit axes a (N, 3)."""
    a = np.atleast_2d(np.asarray(axes, float))
    ref = np.where(np.abs(a[:, :1]) < 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    e1 = np.cross(a, ref)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, np.cross(a, e1)


def facing_frames(tips, axes):
    """Unit vectors e1, e2 (N, 3) as :func:`perpendicular_frames`, with e1 across the tool axis towards the rotor
    axis (the z axis) from the tip: a frame that turns with the screw motion about z, so a tool's points placed in
    it at two poses of one screw motion are the same points of the tool, screwed, at the same distances from the
    rotor axis (the frame of :func:`perpendicular_frames` is fixed in space, and its samples of a round tool
    would fall elsewhere on it at each pose).  Where there is no such direction (the tip on the rotor axis, or
    the tool axis along the line from the tip to it), :func:`perpendicular_frames`."""
    tips, a = np.broadcast_arrays(np.atleast_2d(np.asarray(tips, float)), np.atleast_2d(np.asarray(axes, float)))
    tips, a = tips.copy(), a.copy()
    v = np.c_[-tips[:, :2], np.zeros(len(tips))]
    v -= np.einsum("ij,ij->i", v, a)[:, None] * a
    n = np.linalg.norm(v, axis=1)
    e1, _ = perpendicular_frames(a)
    ok = n > 1e-9 * (1.0 + np.linalg.norm(tips, axis=1))
    e1[ok] = v[ok] / n[ok, None]
    return e1, np.cross(a, e1)


def place_points(local, tips, axes, facing=False):
    """Tool-frame points (M, 3) (x, y, h) placed at poses: (N, M, 3) = tip + x e1 + y e2 + h a; ``facing``: e1
    towards the rotor axis (:func:`facing_frames`), else :func:`perpendicular_frames`."""
    tips = np.atleast_2d(np.asarray(tips, float))
    axes = np.atleast_2d(np.asarray(axes, float))
    if facing:
        tips, axes = (x.copy() for x in np.broadcast_arrays(tips, axes))
    e1, e2 = facing_frames(tips, axes) if facing else perpendicular_frames(axes)
    F = np.stack([e1, e2, axes], axis=1)                   # (N, 3, 3): rows e1, e2, a
    return np.matmul(np.asarray(local, float)[None], F) + tips[:, None, :]


@dataclass
class ToolShape:
    kind: str                   # the plan's tool kind
    h_start: float              # axis_start
    h_end: float                # axis_end
    radii: np.ndarray
    meridian: np.ndarray = None     # (K, 2) rows (h from axis_start, R)
    paraboloid: dict = None
    shank: tuple = None         # (h0, h1, radius) or None
    name: str = ""

    @classmethod
    def from_strip(cls, plan, k):
        """The solid of strip k of a rotor plan, in its tool frame (tip from :func:`cl_data.strip_tip`)."""
        from ..exports.cl_data import strip_tip

        s = plan["strips"][k]
        T, a, off = strip_tip(plan, k)
        L = float(np.linalg.norm(np.subtract(s["axis_end"], s["axis_start"])))
        shank = None
        if s.get("shank_radius", 0.0) > 0 and s.get("shank_start") is not None:
            hs = [float(np.dot(np.subtract(s[key], T), a)) for key in ("shank_start", "shank_end")]
            off_axis = max(float(np.linalg.norm(np.subtract(s[key], T) - h * a))
                           for key, h in zip(("shank_start", "shank_end"), hs))
            if off_axis > 1e-6 * max(1.0, L):
                raise ValueError(f"strip {k}: the shank lies {off_axis:.3g} off the tool axis")
            if abs(hs[1] - hs[0]) > 0:
                shank = (min(hs), max(hs), float(s["shank_radius"]))
        mer = np.asarray(s["meridian"], float) if s.get("meridian") is not None else None
        par = dict(s["paraboloid"]) if s.get("paraboloid") is not None else None
        from ..io.plan import strip_tool

        return cls(kind=str(strip_tool(plan, k).get("kind", "cone")), h_start=-off, h_end=-off + L,
                   radii=np.asarray(s["radii"], float), meridian=mer, paraboloid=par, shank=shank)

    def strip_at(self, tip, axis, extra=None):
        """A flank-plan/1 strip dict of this solid at the pose (tip, unit axis), plus ``extra`` fields."""
        tip, a = np.asarray(tip, float), np.asarray(axis, float)
        s = {"axis_start": (tip + self.h_start * a).tolist(), "axis_end": (tip + self.h_end * a).tolist(),
             "radii": self.radii.tolist(), "shank_radius": 0.0,
             "shank_start": (tip + self.h_end * a).tolist(), "shank_end": (tip + self.h_end * a).tolist()}
        if self.shank is not None:
            s.update(shank_start=(tip + self.shank[0] * a).tolist(), shank_end=(tip + self.shank[1] * a).tolist(),
                     shank_radius=self.shank[2])
        if self.meridian is not None:
            s["meridian"] = self.meridian.tolist()
        if self.paraboloid is not None:
            s["paraboloid"] = dict(self.paraboloid)
        s.update(extra or {})
        return s

    def signature(self):
        """A short digest of the solid (equal solids -> equal digests, to 1e-9 mm): one tool number each."""
        def r(x):
            return None if x is None else np.round(np.asarray(x, float), 9).tolist()
        data = [self.kind, round(self.h_start, 9), round(self.h_end, 9), r(self.radii), r(self.meridian),
                None if self.paraboloid is None else r([self.paraboloid["a"], self.paraboloid["b"]]), r(self.shank)]
        return hashlib.sha1(json.dumps(data).encode()).hexdigest()[:12]

    # ------------------------------------------------------------------ outline
    def _cutting_radius(self, h):
        """R(h) of the cutting part at tool-frame heights h (0 outside it)."""
        h = np.asarray(h, float)
        if self.meridian is not None:
            m = self.meridian
            hh = h - self.h_start
            R = np.interp(hh, m[:, 0], m[:, 1])
            return np.where((hh >= m[0, 0]) & (hh <= m[-1, 0]), R, 0.0)
        if self.paraboloid is not None:
            a, b = self.paraboloid["a"], self.paraboloid["b"]
            return np.sqrt(np.maximum((b - np.abs(h - self.h_start)) / -a, 0.0))
        r = self.radii
        m = len(r) - 1
        per = max(4, int(math.ceil(400 / m)))
        u = np.linspace(0.0, 1.0, m * per + 1)
        c = self.h_start + u * (self.h_end - self.h_start)
        rs = np.interp(u, np.linspace(0.0, 1.0, m + 1), r)
        out = np.zeros(h.shape)
        for lo in range(0, len(u), 512):
            d2 = rs[lo:lo + 512, None] ** 2 - (h[None, ...] - c[lo:lo + 512, None]) ** 2
            out = np.maximum(out, np.sqrt(np.maximum(d2, 0.0)).max(axis=0))
        return out

    def cutting_range(self):
        """(h_min, h_max) of the cutting part."""
        if self.meridian is not None:
            return self.h_start + self.meridian[0, 0], self.h_start + self.meridian[-1, 0]
        if self.paraboloid is not None:
            return self.h_start - self.paraboloid["b"], self.h_start + self.paraboloid["b"]
        return self.h_start - self.radii[0], self.h_end + self.radii[-1]

    def h_range(self):
        lo, hi = self.cutting_range()
        if self.shank is not None:
            lo, hi = min(lo, self.shank[0]), max(hi, self.shank[1])
        return lo, hi

    def gauge_length(self):
        """Distance from the programmed tip (h = 0) up the axis to the end of the shank (or of the cutting part),
        where the spindle's gauge line is taken.  Not the solid's whole length: a cone's tip sphere reaches below
        its flat tip (by up to r1), and that part of the model is no part of the tool's length."""
        return self.h_range()[1]

    MIN_CUTTING_RINGS = 16

    def outline(self, spacing):
        """(h, R, is_shank) samples of the cutting part and the shank, at most ``spacing`` apart along h, and at
        least MIN_CUTTING_RINGS over the cutting part (a tool shorter than the spacing -- a sub-millimetre cone
        -- would otherwise be sampled only at its poles, where its radius is 0)."""
        lo, hi = self.cutting_range()
        n = max(self.MIN_CUTTING_RINGS + 1, int(math.ceil((hi - lo) / spacing)) + 1)
        h = np.linspace(lo, hi, n)
        R = self._cutting_radius(h)
        if self.meridian is not None:     # a ring per grid height carrying the largest meridian radius around it
            mh, mr = self.h_start + self.meridian[:, 0], self.meridian[:, 1]
            k = np.clip(np.rint((mh - lo) / (hi - lo) * (n - 1)).astype(int), 0, n - 1)
            top = np.zeros(n)
            np.maximum.at(top, k, mr)
            R = np.maximum(R, top)
        out_h, out_r, out_s = [h], [R], [np.zeros(len(h), bool)]
        if self.shank is not None:
            a, b, rs = self.shank
            k = max(2, int(math.ceil((b - a) / spacing)) + 1)
            out_h.append(np.linspace(a, b, k))
            out_r.append(np.full(k, rs))
            out_s.append(np.ones(k, bool))
        return np.concatenate(out_h), np.concatenate(out_r), np.concatenate(out_s)

    def z_extent(self, tips, axes, spacing=0.5):
        """(z_min, z_max) (N,) of the tool and shank at poses (N, 3) x (N, 3), ring by ring exactly: a ring of
        radius R about a point c on the unit axis a spans c_z +- R sqrt(1 - a_z^2)."""
        h, R, _ = self.outline(spacing)
        tips, axes = np.atleast_2d(tips), np.atleast_2d(axes)
        cz = tips[:, 2:3] + h[None, :] * axes[:, 2:3]
        w = R[None, :] * np.sqrt(np.maximum(1.0 - axes[:, 2:3] ** 2, 0.0))
        return (cz - w).min(axis=1), (cz + w).max(axis=1)

    def local_points(self, spacing):
        """Surface points (M, 3) in the tool frame: a ring per outline height, the end faces of the cutting
        part and the shank as concentric rings; neighbours at most about ``spacing`` apart."""
        h, R, sh = self.outline(spacing)
        pts = [np.c_[np.zeros(1), np.zeros(1), [h.min()]], np.c_[np.zeros(1), np.zeros(1), [h.max()]]]

        def ring(hv, rv):
            m = max(8, int(math.ceil(2 * math.pi * rv / spacing)))
            th = np.arange(m) * (2 * math.pi / m)
            return np.c_[rv * np.cos(th), rv * np.sin(th), np.full(m, hv)]

        for hv, rv in zip(h, R):
            if rv > 0:
                pts.append(ring(hv, rv))
        for part in (~sh, sh):
            if not part.any():
                continue
            for end in (np.argmin(np.where(part, h, np.inf)), np.argmax(np.where(part, h, -np.inf))):
                for rr in np.arange(spacing, R[end], spacing):
                    pts.append(ring(h[end], rr))
        return np.vstack(pts)

    def describe(self):
        lo, hi = self.cutting_range()
        d = {"kind": self.kind, "cutting_h": [lo, hi], "max_cutting_diameter": 2 * float(
            self._cutting_radius(np.linspace(lo, hi, 200)).max())}
        if self.shank is not None:
            d["shank"] = {"h": [self.shank[0], self.shank[1]], "diameter": 2 * self.shank[2]}
        return d
