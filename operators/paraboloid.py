# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.paraboloid_groove -- paraboloid groove (Doğrusadık): the helical groove machined by a circular
paraboloid (lens) end mill, its section and overcut, and the tool's motion on the helix.

Rotor frame (Blender world, screw axis = z): the paper frame (x, y, z) maps to (x, -z, y), a right-handed helix
of v0 = p / 2 pi with the tool centre at (-R, 0, 0) for phi = pi; the section plane of the paper (z = 0) is the
plane Y = 0 here, the section lies on its x < 0 side.  Objects in the collection "Paraboloid Groove" under
"Flank Results" (a re-run replaces the earlier groove): the groove surface, the lens tool (and an animated copy
along the helix), the swept section and the tool's own section in the plane through the axis (the paper's
Fig. 5), and the overcut band between them with the point attribute ``overcut``."""
import math
import time

import bpy
import numpy as np

from .common import count_limit_error, linear_keys, set_color_attr, set_float_attr, typed
from .modal import ModalPlannerMixin
from .properties import paraboloid_props
from .result_builder import COLOR_ENVELOPE, COLOR_TOOL, RunBuilder
from .shapes import revolved_mesh

COLLECTION = "Paraboloid Groove"     # the run's collection under "Flank Results" (a re-run replaces it)
RUN_KEY_PROP = "flank_groove_key"
RUN_KEY = "groove"
A_LIMIT = 1.0e30                       # |a| of the lens |h| <= b + a rho^2 (a = -1e6 is a tiny but real lens)
OVERCUT_ATTR = "overcut"
OVERCUT_COLOR_ATTR = "overcut_color"
# overcut colour ramp: 0 -> pale yellow, max -> red
RAMP_LOW = (1.00, 0.85, 0.35, 1.0)
RAMP_HIGH = (0.85, 0.08, 0.08, 1.0)
MAX_KEYS = 1000

__all__ = ["FLANK_OT_paraboloid_groove", "tool_location"]


def _section_chains(x, y, closed_tol):
    """Upper (x, 0, y) and mirrored lower (x, 0, -y) polylines in the rotor frame's plane Y = 0.

    Returns (chains, per-vertex index into x): one closed loop when both ends lie on the axis
    line y = 0 (the full section), else two open chains."""
    upper = np.c_[x, np.zeros_like(x), y]
    lower = np.c_[x, np.zeros_like(x), -y]
    idx = np.arange(len(x))
    if abs(y[0]) <= closed_tol and abs(y[-1]) <= closed_tol:
        loop = np.vstack([upper, lower[::-1][1:-1]])
        return [(loop, True)], np.r_[idx, idx[::-1][1:-1]]
    return [(upper, False), (lower, False)], np.r_[idx, idx]


def _ramp(t):
    t = np.clip(np.asarray(t, dtype=np.float64), 0.0, 1.0)[:, None]
    return (1.0 - t) * np.asarray(RAMP_LOW) + t * np.asarray(RAMP_HIGH)


def tool_location(theta, R, v0):
    """Tool centre on the helix in the rotor frame (axis z, right-handed): (-R, 0, 0) at theta = pi."""
    theta = np.asarray(theta, dtype=np.float64)
    return np.stack([R * np.cos(theta), R * np.sin(theta), v0 * (theta - np.pi)], -1)


def _lens_mesh(a, b, rho):
    """The tool lens |h| <= b + a rho^2 as a surface of revolution about its own axis (parallel to z)."""
    m = 24
    r_up = rho * np.arange(0, m + 1) / m
    h_up = np.maximum(b + a * r_up ** 2, 0.0)
    return revolved_mesh(np.vstack([np.c_[r_up, h_up], np.c_[r_up[::-1], -h_up[::-1]][1:]]), 64)


def _overcut_band(sec):
    """The band between the tool's own section and the swept section (the overcut), both halves."""
    x, y, ty = np.asarray(sec.x), np.asarray(sec.y), np.asarray(sec.tool_y)
    overcut = np.asarray(sec.overcut, dtype=np.float64)
    k = len(x)
    band_up = np.vstack([np.c_[x, np.zeros(k), ty], np.c_[x, np.zeros(k), y]])
    i = np.arange(k - 1)
    quads_up = np.vstack([np.c_[i, i + 1, k + i + 1], np.c_[i, k + i + 1, k + i]])
    return (np.vstack([band_up, band_up * np.array([1.0, 1.0, -1.0])]),
            np.vstack([quads_up, quads_up[:, ::-1] + 2 * k]), np.tile(np.r_[overcut, overcut], 2))


def _groove(part, R, a, b, p, turns, n):
    """The core's section(s), groove surface mesh and lens -> dict, or raises the core's errors."""
    from ..flank_addon.methods.paraboloid_groove.groove import groove_section, groove_surface

    sec = groove_section(R, a, b, p, n=n, part=part)
    full = sec if part == "full" else groove_section(R, a, b, p, n=n, part="full")
    surf = groove_surface(R, a, b, p, n=n, handedness="right")
    n_u = int(min(max(64, 2 * n), 4096))
    n_t = int(max(8, math.ceil(96 * turns))) + 1
    g_verts, g_faces = surf.mesh(n_u=n_u, n_t=n_t, z0=-0.5 * turns * p, z1=0.5 * turns * p)
    # from_meridian puts the section at +x; a half turn about z (same helix) brings it to the tool at -x
    g_verts = np.asarray(g_verts, dtype=np.float64).copy()
    g_verts[:, :2] *= -1.0
    rho = math.sqrt(-b / a)
    overcut = np.asarray(sec.overcut, dtype=np.float64)
    return dict(sec=sec, groove=(g_verts, g_faces), lens=_lens_mesh(a, b, rho), rho=rho,
                band=_overcut_band(sec), k_max=int(np.argmax(overcut)), max_overcut=float(overcut.max()),
                intercepts=[float(full.x[0]), float(full.x[-1])])


def _animate_tool(run, context, lens_mesh, R, v0, turns):
    """The tool moving along its helix: the lens is a solid of revolution whose axis stays parallel to the
    screw axis, so a pure translation along the helix is the exact motion (one key per frame, linear)."""
    moving = run.add("Paraboloid Tool (moving)", lens_mesh, COLOR_TOOL)    # shares the mesh
    run.on_failure(lambda: run.own_action(moving.animation_data.action if moving.animation_data else None))
    scene = context.scene
    fs, fe = int(scene.frame_start), int(scene.frame_end)
    if fe <= fs:
        fe = fs + 1
    frames = np.unique(np.round(np.linspace(fs, fe, min(fe - fs + 1, MAX_KEYS))).astype(int))
    theta = np.pi + np.pi * turns * (2.0 * (frames - fs) / (fe - fs) - 1.0)
    for f, loc in zip(frames, tool_location(theta, R, v0)):
        moving.location = [float(c) for c in loc]
        moving.keyframe_insert(data_path="location", frame=int(f))
    linear_keys(moving)
    return frames


class FLANK_OT_paraboloid_groove(ModalPlannerMixin, bpy.types.Operator):
    """Machine a helical groove with a paraboloid (lens) end mill: the groove surface, the tool and its motion,
    and the swept section against the tool's own section with the overcut between them"""

    bl_idname = "flank.paraboloid_groove"
    bl_label = "Paraboloid Groove"
    bl_options = {'REGISTER', 'UNDO'}
    _title = "Paraboloid groove"

    __annotations__ = paraboloid_props()

    def _check(self, a, turns, n):
        msg = count_limit_error("resolution", n, 16, 100000)
        if msg is None and not (math.isfinite(turns) and 0.0 < turns <= 1000.0):
            msg = "turns = {} is outside the limits (0, 1000]".format(turns)
        if msg is None and math.isfinite(a) and abs(a) >= A_LIMIT:   # infinity typed is held as -3.4e38
            msg = "constant a = {:g} is out of range (|a| < {:g}): the lens would have no width".format(a, A_LIMIT)
        return msg

    def _compute_failed(self, ex):
        from ..flank_addon.methods.paraboloid_groove.groove import ParaboloidError

        if isinstance(ex, ParaboloidError):
            return "Paraboloid groove: {}".format(ex)
        return "Paraboloid groove failed: {}: {}".format(type(ex).__name__, ex)

    def _prepare(self, context):
        # single precision: the paper case a = -0.05 gives the intercepts -8 / -32 exactly from the typed decimals
        R, a, b, p = (typed(v) for v in (self.radius, self.a, self.b, self.pitch))
        turns, n = float(self.turns), int(self.resolution)
        msg = self._check(a, turns, n)
        if msg is not None:
            self.report({'ERROR'}, "Paraboloid groove: " + msg)
            return None
        return dict(params=(R, a, b, p, turns), n=n, part=str(self.part), started=time.perf_counter())

    def _compute(self, job, progress):
        """Sections, groove surface and lens: pure numpy (a worker thread when run from the UI)."""
        from ..flank_addon.progress import reporter

        report = reporter(progress)
        report(0.0, "swept section and groove surface")
        R, a, b, p, turns = job["params"]
        g = _groove(job["part"], R, a, b, p, turns, job["n"])
        report(1.0, "done")
        return g

    def _build(self, context, job, g):
        R, a, b, p, turns = job["params"]
        run = RunBuilder(context, "flank_groove_", RUN_KEY, COLLECTION, key_prop=RUN_KEY_PROP)
        made = {}
        replaced = run.build(self, "paraboloid groove objects",
                             lambda: self._fill(run, context, g, job["params"], made, job["part"]))
        if replaced is None:
            return {'CANCELLED'}
        run.show(made["groove"])
        x, k_max = np.asarray(g["sec"].x), g["k_max"]
        self.report({'INFO'}, "Paraboloid groove R={:.6g}, a={:.6g}, b={:.6g}, p={:.6g}: equator radius {:.6g}, "
                              "section intercepts x = {:.6g} and {:.6g}, max overcut {:.4g} at x = {:.6g} ({}), "
                              "{} keyframes{}, in {:.2f}s".format(
                                  R, a, b, p, g["rho"], g["intercepts"][0], g["intercepts"][1], g["max_overcut"],
                                  float(x[k_max]), job["part"], made["keys"],
                                  ", replaced the earlier groove" if replaced else "",
                                  time.perf_counter() - job["started"]))
        return {'FINISHED'}

    def _fill(self, run, context, g, params, made, part):
        """Groove surface, lens tool, sections, overcut band, the moving tool and the properties."""
        R, a, b, p, turns = params
        sec, x = g["sec"], np.asarray(g["sec"].x)
        groove = made["groove"] = run.add_mesh("Groove Surface", *g["groove"], COLOR_ENVELOPE)
        tool = run.add_mesh("Paraboloid Tool", *g["lens"], COLOR_TOOL)
        tool.location = (-R, 0.0, 0.0)
        closed_tol = 1e-9 * max(1.0, R)
        chains, src = _section_chains(x, np.asarray(sec.y), closed_tol)
        swept = run.add("Swept Section", run.edges("Swept Section", chains), (0.85, 0.10, 0.10, 1.0))
        set_float_attr(swept.data, OVERCUT_ATTR, np.asarray(sec.overcut, dtype=np.float64)[src])
        chains, _ = _section_chains(x, np.asarray(sec.tool_y), closed_tol)
        run.add("Tool Section", run.edges("Tool Section", chains), (0.10, 0.30, 0.85, 1.0))
        band_verts, band_faces, band_oc = g["band"]
        band = run.add_mesh("Overcut Band", band_verts, band_faces, (0.95, 0.45, 0.10, 1.0))
        set_float_attr(band.data, OVERCUT_ATTR, band_oc)
        set_color_attr(band.data, OVERCUT_COLOR_ATTR, _ramp(band_oc / (g["max_overcut"] if g["max_overcut"] > 0
                                                                         else 1.0)))
        run.color_by_attribute(band.data)
        frames = _animate_tool(run, context, tool.data, R, p / (2.0 * np.pi), turns)
        made["keys"] = len(frames)
        props = dict(R=R, a=a, b=b, pitch=p, v0=p / (2.0 * np.pi), turns=turns, part=part,
                     handedness="right", equator_radius=g["rho"], intercepts=g["intercepts"],
                     max_overcut=g["max_overcut"], max_overcut_x=float(x[g["k_max"]]),
                     frames=[int(frames[0]), int(frames[-1])])
        run.store(props, (groove, run.collection))


classes = (FLANK_OT_paraboloid_groove,)
register, unregister = bpy.utils.register_classes_factory(classes)
