# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.paraboloid_groove -- s002: helical groove of a paraboloid end mill, its section and overcut."""
import bpy

from .common import (RunMaterial, edge_mesh, iter_fcurves, new_mesh_from_arrays, remove_ids, replace_run,
                     results_parent, revolved_mesh, select_only, set_color_attr, set_float_attr, show_attribute_colors)
from .properties import paraboloid_props

COLLECTION = "Paraboloid Groove"     # the run's collection under "Flank Results" (a re-run replaces it)
RUN_KEY_PROP = "flank_groove_key"
RUN_KEY = "groove"
A_LIMIT = 1.0e30                       # |a| of the lens |h| <= b + a rho^2 (a = -1e6 is a tiny but real lens)
OVERCUT_ATTR = "overcut"
OVERCUT_COLOR_ATTR = "overcut_color"
# overcut colour ramp: 0 -> pale yellow, max -> red
RAMP_LOW = (1.00, 0.85, 0.35, 1.0)
RAMP_HIGH = (0.85, 0.08, 0.08, 1.0)


def _section_chains(np, x, y, closed_tol):
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


def _ramp(np, t):
    t = np.clip(np.asarray(t, dtype=np.float64), 0.0, 1.0)[:, None]
    return (1.0 - t) * np.asarray(RAMP_LOW) + t * np.asarray(RAMP_HIGH)


def tool_location(np, theta, R, v0):
    """Tool centre on the helix in the rotor frame (axis z, right-handed): (-R, 0, 0) at theta = pi."""
    theta = np.asarray(theta, dtype=np.float64)
    return np.stack([R * np.cos(theta), R * np.sin(theta), v0 * (theta - np.pi)], -1)


class FLANK_OT_paraboloid_groove(bpy.types.Operator):
    """s002: helical groove machined by a circular paraboloid (lens) end mill: groove surface, tool,
    swept section vs the tool's own section (overcut, paper Fig. 5) and the tool's motion on the helix.

    Rotor frame (Blender world, screw axis = z): the paper frame (x, y, z) maps to (x, -z, y), a
    right-handed helix of v0 = p / 2 pi with the tool centre at (-R, 0, 0) for phi = pi; the section
    plane of the paper (z = 0) is the plane Y = 0 here, the section lies on its x < 0 side.  The objects are
    in the collection "Paraboloid Groove" under "Flank Results"; a re-run replaces the earlier groove."""

    bl_idname = "flank.paraboloid_groove"
    bl_label = "Paraboloid Groove"
    bl_options = {'REGISTER', 'UNDO'}

    __annotations__ = paraboloid_props()

    def execute(self, context):
        import math
        import time

        import numpy as np

        from ..flank_addon.methods.paraboloid_groove.groove import ParaboloidError, groove_section, groove_surface

        t0 = time.perf_counter()
        # Blender float properties are single precision: recover the decimal value that was typed
        # (7 significant digits), so the paper case a = -0.05 gives the intercepts -8 / -32 exactly
        R, a, b, p = (float("{:.7g}".format(v)) for v in (self.radius, self.a, self.b, self.pitch))
        turns, n = float(self.turns), int(self.resolution)
        from .common import count_limit_error

        msg = count_limit_error("resolution", n, 16, 100000)
        if msg is None and not (math.isfinite(turns) and 0.0 < turns <= 1000.0):
            msg = "turns = {} is outside the limits (0, 1000]".format(turns)
        if msg is None and math.isfinite(a) and abs(a) >= A_LIMIT:   # infinity typed is held as -3.4e38
            msg = "constant a = {:g} is out of range (|a| < {:g}): the lens would have no width".format(a, A_LIMIT)
        if msg is not None:
            self.report({'ERROR'}, "Paraboloid groove: " + msg)
            return {'CANCELLED'}
        try:
            sec = groove_section(R, a, b, p, n=n, part=self.part)
            full = sec if self.part == "full" else groove_section(R, a, b, p, n=n, part="full")
            surf = groove_surface(R, a, b, p, n=n, handedness="right")
            n_u = int(min(max(64, 2 * n), 4096))
            n_t = int(max(8, math.ceil(96 * turns))) + 1
            g_verts, g_faces = surf.mesh(n_u=n_u, n_t=n_t, z0=-0.5 * turns * p, z1=0.5 * turns * p)
        except ParaboloidError as ex:
            self.report({'ERROR'}, "Paraboloid groove: {}".format(ex))
            return {'CANCELLED'}
        except Exception as ex:
            self.report({'ERROR'}, "Paraboloid groove failed: {}: {}".format(type(ex).__name__, ex))
            return {'CANCELLED'}
        # from_meridian puts the section at +x; a half turn about z (same helix) brings it to the tool at -x
        g_verts = np.asarray(g_verts, dtype=np.float64).copy()
        g_verts[:, :2] *= -1.0
        v0 = p / (2.0 * np.pi)
        rho = math.sqrt(-b / a)
        overcut = np.asarray(sec.overcut, dtype=np.float64)
        k_max = int(np.argmax(overcut))
        max_overcut = float(overcut[k_max])
        intercepts = [float(full.x[0]), float(full.x[-1])]

        # tool lens |h| <= b + a rho^2 as a surface of revolution about its own axis (parallel to z)
        m = 24
        r_up = rho * np.arange(0, m + 1) / m
        h_up = np.maximum(b + a * r_up ** 2, 0.0)
        lens_rh = np.vstack([np.c_[r_up, h_up], np.c_[r_up[::-1], -h_up[::-1]][1:]])
        l_verts, l_faces = revolved_mesh(np, lens_rh, 64)

        # section band between the tool's own section and the swept section (the overcut), both halves
        x, y, ty = np.asarray(sec.x), np.asarray(sec.y), np.asarray(sec.tool_y)
        k = len(x)
        band_up = np.vstack([np.c_[x, np.zeros(k), ty], np.c_[x, np.zeros(k), y]])
        band_lo = band_up * np.array([1.0, 1.0, -1.0])
        i = np.arange(k - 1)
        quads_up = np.vstack([np.c_[i, i + 1, k + i + 1], np.c_[i, k + i + 1, k + i]])
        band_verts = np.vstack([band_up, band_lo])
        band_faces = np.vstack([quads_up, quads_up[:, ::-1] + 2 * k])
        band_oc = np.tile(np.r_[overcut, overcut], 2)
        scale = max_overcut if max_overcut > 0 else 1.0

        objects, meshes, colls, names = [], [], [], []
        parent, parent_created = None, False
        run_mat = RunMaterial(bpy)
        moving = None
        try:
            parent, parent_created = results_parent(bpy, context)
            coll = bpy.data.collections.new(COLLECTION + " new")
            colls.append(coll)
            parent.children.link(coll)

            def add(name, mesh, color):
                if mesh not in meshes:
                    meshes.append(mesh)
                    names.append((mesh, name))
                ob = bpy.data.objects.new(name, mesh)
                objects.append(ob)
                names.append((ob, name))
                ob.color = color
                coll.objects.link(ob)
                return ob

            groove = add("Groove Surface", new_mesh_from_arrays(bpy, np, "Groove Surface", g_verts, g_faces),
                         (0.55, 0.62, 0.70, 1.0))
            tool = add("Paraboloid Tool", new_mesh_from_arrays(bpy, np, "Paraboloid Tool", l_verts, l_faces),
                       (0.90, 0.72, 0.20, 1.0))
            lens_mesh = tool.data
            tool.location = (-R, 0.0, 0.0)

            closed_tol = 1e-9 * max(1.0, R)
            chains, src = _section_chains(np, x, y, closed_tol)
            swept = add("Swept Section", edge_mesh(bpy, np, "Swept Section", chains), (0.85, 0.10, 0.10, 1.0))
            set_float_attr(np, swept.data, OVERCUT_ATTR, overcut[src])
            chains, _ = _section_chains(np, x, ty, closed_tol)
            add("Tool Section", edge_mesh(bpy, np, "Tool Section", chains), (0.10, 0.30, 0.85, 1.0))
            band = add("Overcut Band", new_mesh_from_arrays(bpy, np, "Overcut Band", band_verts, band_faces),
                       (0.95, 0.45, 0.10, 1.0))
            set_float_attr(np, band.data, OVERCUT_ATTR, band_oc)
            set_color_attr(np, band.data, OVERCUT_COLOR_ATTR, _ramp(np, band_oc / scale))
            run_mat.assign(band.data)

            # the tool moving along its helix: the lens is a solid of revolution whose axis stays parallel
            # to the screw axis, so a pure translation along the helix is the exact motion
            moving = add("Paraboloid Tool (moving)", lens_mesh, (0.90, 0.72, 0.20, 1.0))   # shares the mesh
            scene = context.scene
            fs, fe = int(scene.frame_start), int(scene.frame_end)
            if fe <= fs:
                fe = fs + 1
            frames = np.unique(np.round(np.linspace(fs, fe, min(fe - fs + 1, 1000))).astype(int))
            theta = np.pi + np.pi * turns * (2.0 * (frames - fs) / (fe - fs) - 1.0)
            locs = tool_location(np, theta, R, v0)
            for f, loc in zip(frames, locs):
                moving.location = [float(c) for c in loc]
                moving.keyframe_insert(data_path="location", frame=int(f))
            if moving.animation_data is not None and moving.animation_data.action is not None:
                for fc in iter_fcurves(moving.animation_data.action):
                    for kp in fc.keyframe_points:
                        kp.interpolation = 'LINEAR'

            props = dict(
                flank_groove_R=R, flank_groove_a=a, flank_groove_b=b, flank_groove_pitch=p, flank_groove_v0=v0,
                flank_groove_turns=turns, flank_groove_part=str(self.part), flank_groove_handedness="right",
                flank_groove_equator_radius=rho, flank_groove_intercepts=intercepts,
                flank_groove_max_overcut=max_overcut, flank_groove_max_overcut_x=float(x[k_max]),
                flank_groove_frames=[int(frames[0]), int(frames[-1])],
            )
            for target in (groove, coll):
                for key, value in props.items():
                    target[key] = value
            replaced = replace_run(bpy, parent, coll, RUN_KEY_PROP, RUN_KEY, COLLECTION, names)
        except Exception as ex:
            ad = getattr(moving, "animation_data", None) if moving is not None else None
            action = ad.action if ad is not None else None
            remove_ids(bpy, objects, meshes, colls + ([parent] if parent_created else []))
            if action is not None:
                try:
                    if action.users == 0:
                        bpy.data.actions.remove(action)
                except ReferenceError:
                    pass
            run_mat.discard()
            self.report({'ERROR'}, "Could not build the paraboloid groove objects: {}: {}".format(
                type(ex).__name__, ex))
            return {'CANCELLED'}

        try:
            select_only(context, groove)
        except RuntimeError:             # the results collection is excluded from the view layer
            pass
        show_attribute_colors(bpy, context)
        dt = time.perf_counter() - t0
        self.report({'INFO'}, "Paraboloid groove R={:.6g}, a={:.6g}, b={:.6g}, p={:.6g}: equator radius {:.6g}, "
                              "section intercepts x = {:.6g} and {:.6g}, max overcut {:.4g} at x = {:.6g} ({}), "
                              "{} keyframes{}, in {:.2f}s".format(
                                  R, a, b, p, rho, intercepts[0], intercepts[1], max_overcut, float(x[k_max]),
                                  self.part, len(frames), ", replaced the earlier groove" if replaced else "", dt))
        return {'FINISHED'}
