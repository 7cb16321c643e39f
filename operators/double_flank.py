# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.plan_double_flank -- s001: double-flank milling of one rotor valley with a custom-shaped or conical tool."""
import bpy

from .common import (PLAN_JSON_PROP, RunMaterial, edge_mesh, frame_along, key_screw_motion, new_mesh_from_arrays,
                     remove_ids, replace_run, results_parent, rotor_source, select_only, set_color_attr,
                     set_float_attr, show_attribute_colors)
from .modal import ModalPlannerMixin
from .properties import double_flank_props

PROP_PREFIX = "flank_df_"
DEVIATION_ATTR = "deviation"           # FLOAT point attribute of the envelope strips (scene units, + = stock)
DEVIATION_COLOR_ATTR = "error_color"   # FLOAT_COLOR of the envelope strips (flank_addon.simulation.verify.deviation_colors)
ERROR_ATTR = "error"                   # FLOAT point attribute of the error chart (scene units, unscaled)
FLANK_ATTR = "flank"                   # FLOAT point attribute of the error chart: 1, 2 (0 = baseline)
CHART_COLOR_ATTR = "flank_color"
# value of ``deviation`` where the core gives none (never expected: the strips hold milled nodes only)
UNTOUCHED = 1.0e9
TOOL_SEGMENTS = 48
TOOL_MAX_RINGS = 400
COLOR_TOOL = (0.90, 0.72, 0.20, 1.0)
COLOR_ENVELOPE = (0.55, 0.62, 0.70, 1.0)
CHART_COLORS = {0: (0.35, 0.35, 0.35, 1.0), 1: (0.85, 0.15, 0.10, 1.0), 2: (0.10, 0.35, 0.85, 1.0)}


def _decimal(v):
    """Blender float properties are single precision: the decimal value that was typed (7 digits)."""
    return float("{:.7g}".format(v))


def _finite_runs(np, mask):
    """[(start, stop)] of the runs of True in a boolean array (stop exclusive)."""
    m = np.r_[False, np.asarray(mask, dtype=bool), False]
    d = np.diff(m.astype(np.int8))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


def _tool_frame(np, path):
    """4x4 tool frame in the rotor frame: origin at the axis start (tip end), z along the axis."""
    a0 = np.asarray(path.plan_points[0], dtype=np.float64)
    rot, length = frame_along(np, a0, path.plan_points[-1])
    if rot is None:
        raise ValueError("tool axis of zero length")
    T = np.eye(4)
    T[:3, :3] = rot
    T[:3, 3] = a0
    return T, length


class FLANK_OT_plan_double_flank(ModalPlannerMixin, bpy.types.Operator):
    """s001: plan double-flank milling of one valley of the active rotor with a custom-shaped tool (optimised
    axis, radial function min / avg / one-sided) or conical tools, and show the result.

    Rotor: the active rotor made by Generate Rotor (rebuilt exactly from its custom properties; the mesh's
    local frame is the rotor frame) or an analyzed mesh (analysed again here, as the command line does with
    --mesh; the rotor frame is the analysis's to_world, in scene units).  Objects in a collection under
    "Flank Results" (an earlier run on the same rotor and valley is replaced): per tool path the tool (revolved
    meridian + shank, origin at the tip, local z along its axis), the two envelope strips with the point
    attributes ``deviation`` (FLOAT, signed, scene units = rotor units x object scale, > 0 material left) and
    ``error_color`` (shown by the shared material "Flank Attribute Colour"), the error along the axis (s001
    Figs. 12/14/17) as an edge-mesh chart beside the tool (x offset = error x flank_df_error_scale), and
    with Animate a "Tool Motion" empty parented to the rotor with linear keys along the screw motion and a
    moving tool.  Custom properties flank_df_* (alpha, delta, phi, Phi, iterations, errors, Hausdorff,
    times) on the collection, the tools and the rotor."""

    bl_idname = "flank.plan_double_flank"
    bl_label = "Plan Double Flank"
    bl_options = {'REGISTER', 'UNDO'}
    _title = "Double flank"

    __annotations__ = double_flank_props()

    # ------------------------------------------------------------------ inputs

    def _source(self, context, np):
        """The rotor to plan on -> dict, or an error message (str) (see common.rotor_source)."""
        return rotor_source(bpy, context, np, PROP_PREFIX)

    def _prepare(self, context):
        """Main thread: properties and rotor -> job dict, or None (error reported)."""
        import math
        import time

        import numpy as np

        t0 = time.perf_counter()
        rim, tol_in = _decimal(self.rim), _decimal(self.tolerance)
        k_valley, m, n_cones = int(self.valley), int(self.radii), int(self.cones)
        if not math.isfinite(rim) or not 0.0 < rim <= 1.0:
            self.report({'ERROR'}, "Double flank: rim = {} must be in (0, 1] (fraction of the valley depth)".format(
                rim))
            return None
        if not math.isfinite(tol_in) or tol_in < 0.0:
            self.report({'ERROR'}, "Double flank: tolerance = {} must be a finite number >= 0".format(tol_in))
            return None
        if m < 2:
            self.report({'ERROR'}, "Double flank: radii m = {} is below the minimum 2 (the plan needs m + 1 >= 3 "
                                   "radii per strip)".format(m))
            return None
        from .common import count_limit_error

        msg = (count_limit_error("axis samples", self.samples, 4, 2000)
               or count_limit_error("envelope rings", self.envelope_rings, 2, 4096))
        if msg is not None:
            self.report({'ERROR'}, "Double flank: " + msg)
            return None
        if self.two_paths and self.tool != "custom":
            self.report({'ERROR'}, "Double flank: Two Paths needs Tool = Custom (s001 Sec. 4.3), got Tool = "
                                   "{}".format(self.tool))
            return None
        fs, fe = int(self.frame_start), int(self.frame_end)
        if self.animate and fe <= fs:
            self.report({'ERROR'}, "Double flank: end frame {} must be after the start frame {}".format(fe, fs))
            return None
        src = self._source(context, np)
        if isinstance(src, str):
            self.report({'ERROR'}, "Double flank: " + src)
            return None
        rotor_obj, surface, flanks = src["obj"], src["surface"], src["flanks"]
        nv = len(flanks) // 2
        if not 0 <= k_valley < nv:
            self.report({'ERROR'}, "Double flank: valley = {} is outside 0..{} (rotor '{}' has {} valleys)".format(
                k_valley, nv - 1, rotor_obj.name, nv))
            return None
        tool = "cones:{}".format(n_cones) if self.tool == "cones" else str(self.tool)
        lim = 0.5 * float(surface.outer_radius) * float(src["scale"])
        if not tol_in < lim:
            self.report({'ERROR'}, "Double flank: tolerance = {:g} must be below half the outer radius of '{}', "
                                   "{:.6g} (scene units)".format(tol_in, rotor_obj.name, lim))
            return None

        return dict(t0=t0, src=src, rotor_name=rotor_obj.name, surface=surface, flanks=flanks, k_valley=k_valley,
                    tool=tool, m=m, rim=rim, tol_in=tol_in, fs=fs, fe=fe, variant=str(self.variant),
                    two_paths=bool(self.two_paths), samples=int(self.samples), simulate=bool(self.simulate),
                    rings=int(self.envelope_rings), to_world=src["to_world"].tolist(), unit=src["unit"],
                    z_range=tuple(float(v) for v in src["z_range"]))

    @staticmethod
    def _compute(job, progress):
        """The planner, envelopes, tool meshes and charts (numpy only: the worker thread when invoked)."""
        import numpy as np

        from ..flank_addon.methods.double_flank import planner as df

        res = df.plan_double_flank(job["surface"], job["flanks"], valley=job["k_valley"], variant=job["variant"],
                                   tool=job["tool"], two_paths=job["two_paths"], m=job["m"], rim=job["rim"],
                                   n=job["samples"], to_world=job["to_world"], length_unit=job["unit"],
                                   simulate=job["simulate"], progress=progress)
        env = res.envelope_meshes(job["z_range"], job["rings"])
        tools = [res.tool_mesh(k, n_around=TOOL_SEGMENTS, max_rings=TOOL_MAX_RINGS) for k in range(len(res.paths))]
        frames = [_tool_frame(np, p) for p in res.paths]
        charts = [res.errors_along_axis(k) for k in range(len(res.paths))]
        return dict(res=res, env=env, tools=tools, frames=frames, charts=charts)

    def _build(self, context, job, out):
        """Main thread: the result collection, objects, attributes and properties from a finished run."""
        import json
        import math
        import os
        import time

        import numpy as np
        from mathutils import Matrix

        from ..flank_addon.methods.double_flank import planner as df
        from ..flank_addon.simulation.verify import deviation_colors

        rotor_obj = bpy.data.objects.get(job["rotor_name"])
        if rotor_obj is None:
            self.report({'ERROR'}, "Double flank: the rotor '{}' was removed while planning".format(job["rotor_name"]))
            return {'CANCELLED'}
        t0, src, surface, k_valley, m, rim = job["t0"], job["src"], job["surface"], job["k_valley"], job["m"], job["rim"]
        tol_in, fs, fe, tool = job["tol_in"], job["fs"], job["fe"], job["tool"]
        res, env, tools, frames, charts = out["res"], out["env"], out["tools"], out["frames"], out["charts"]

        s = float(src["scale"])                       # scene units per rotor unit
        R = float(surface.outer_radius)
        tol = tol_in if tol_in > 0.0 else 1e-3 * R * s
        display = src["display"]
        v0, eps = float(surface.v0), (1 if surface.hand > 0 else -1)
        multi = len(res.paths) > 1

        def name(base, k):
            return "{} {}".format(base, k + 1) if multi else base

        # ---- error charts (tool frame: z along the axis, x = offset + error x scale)
        e_all = np.concatenate([np.r_[c[1], c[2]] for c in charts])
        e_all = e_all[np.isfinite(e_all)]
        e_max = float(np.abs(e_all).max()) if len(e_all) else 0.0
        r_tool = max(float(np.nanmax(p.radii)) for p in res.paths)
        err_scale = 0.5 * r_tool / e_max if e_max > 1e-12 * R else 1.0

        objects, meshes, colls, actions, files, names = [], [], [], [], [], []
        parent, parent_created = None, False
        dev_ranges = []
        key = "{}|{}".format(rotor_obj.name, k_valley)
        base_name = "Double Flank ({}, valley {})".format(rotor_obj.name, k_valley)
        run_mat = RunMaterial(bpy)
        try:
            parent, parent_created = results_parent(bpy, context)
            coll = bpy.data.collections.new(base_name + " new")
            colls.append(coll)
            parent.children.link(coll)

            def add(obj_name, data, color=None, role=None, k=None):
                if data is not None and data not in meshes:
                    meshes.append(data)
                    names.append((data, obj_name))
                ob = bpy.data.objects.new(obj_name, data)
                objects.append(ob)
                names.append((ob, obj_name))
                if color is not None:
                    ob.color = color
                coll.objects.link(ob)
                ob[PROP_PREFIX + "rotor"] = rotor_obj.name
                if role is not None:
                    ob[PROP_PREFIX + "role"] = role
                if k is not None:
                    ob[PROP_PREFIX + "path"] = int(k)
                return ob

            tool_objs, tool_meshes = [], []
            for k, path in enumerate(res.paths):
                T, _ = frames[k]
                Tinv = np.linalg.inv(T)
                verts, faces = tools[k]
                local = np.asarray(verts, dtype=np.float64) @ Tinv[:3, :3].T + Tinv[:3, 3]
                me = new_mesh_from_arrays(bpy, np, name("DF Tool", k), local, faces)
                ob = add(name("DF Tool", k), me, COLOR_TOOL, "tool", k)
                ob.matrix_world = Matrix((display @ T).tolist())
                ob[PROP_PREFIX + "axis_start"] = [float(v) for v in path.plan_points[0]]
                ob[PROP_PREFIX + "axis_end"] = [float(v) for v in path.plan_points[-1]]
                ob[PROP_PREFIX + "radii_range"] = [float(np.nanmin(path.radii)) * s, float(np.nanmax(path.radii)) * s]
                tool_objs.append(ob)
                tool_meshes.append(me)

                for f, (ev, ef, ed) in enumerate(env[k]):
                    if len(ev) == 0 or len(ef) == 0:
                        continue
                    label = name("DF Envelope", k) + " F{}".format(f + 1)
                    em = new_mesh_from_arrays(bpy, np, label, ev, ef)
                    eo = add(label, em, COLOR_ENVELOPE, "envelope", k)
                    eo[PROP_PREFIX + "flank"] = f + 1
                    eo.matrix_world = Matrix(display.tolist())
                    dev = np.asarray(ed, dtype=np.float64) * s
                    fin = np.isfinite(dev)
                    set_float_attr(np, em, DEVIATION_ATTR, np.where(fin, dev, UNTOUCHED))
                    set_color_attr(np, em, DEVIATION_COLOR_ATTR, deviation_colors(dev, tol))
                    run_mat.assign(em)
                    em.update()
                    rng = [float(dev[fin].min()), float(dev[fin].max())] if fin.any() else [float("nan")] * 2
                    eo[PROP_PREFIX + "deviation_range"] = rng
                    dev_ranges.append(rng)

                s_ax, e1, e2 = charts[k]
                z_loc = (np.asarray(path.points, dtype=np.float64) - path.plan_points[0]) @ T[:3, 2]
                x0 = 1.25 * float(np.nanmax(path.radii))
                chains, err_v, flank_v = [], [], []
                for fl, e in ((1, np.asarray(e1, dtype=np.float64)), (2, np.asarray(e2, dtype=np.float64))):
                    for a, b in _finite_runs(np, np.isfinite(e)):
                        if b - a < 2:
                            continue
                        chains.append((np.c_[x0 + err_scale * e[a:b], np.zeros(b - a), z_loc[a:b]], False))
                        err_v.append(e[a:b] * s)
                        flank_v.append(np.full(b - a, fl))
                zb = [float(np.nanmin(z_loc)), float(np.nanmax(z_loc))]
                chains.append((np.array([[x0, 0.0, zb[0]], [x0, 0.0, zb[1]]]), False))
                err_v.append(np.zeros(2))
                flank_v.append(np.zeros(2, dtype=int))
                cm = edge_mesh(bpy, np, name("DF Error along axis", k), chains)
                co = add(name("DF Error along axis", k), cm, (0.1, 0.1, 0.1, 1.0), "error_chart", k)
                co.matrix_world = Matrix((display @ T).tolist())
                fv = np.concatenate(flank_v)
                set_float_attr(np, cm, ERROR_ATTR, np.concatenate(err_v))
                set_float_attr(np, cm, FLANK_ATTR, fv.astype(np.float64))
                set_color_attr(np, cm, CHART_COLOR_ATTR, np.array([CHART_COLORS[int(v)] for v in fv]))
                run_mat.assign(cm)
                co[PROP_PREFIX + "error_scale"] = float(err_scale)
                co[PROP_PREFIX + "chart_offset"] = float(x0 * s)
                co[PROP_PREFIX + "max_abs_error"] = float(np.nanmax(np.abs(np.r_[e1, e2]))) * s \
                    if np.isfinite(np.r_[e1, e2]).any() else float("nan")

            motion_range = None
            if self.animate:
                z0, z1 = src["z_range"]
                s0, s1 = (z0 - R) / v0, (z1 + R) / v0
                motion_range = [float(s0), float(s1)]
                motion = add("DF Tool Motion", None, role="motion")
                motion.empty_display_type = 'ARROWS'
                motion.empty_display_size = 0.25 * R
                motion.parent = rotor_obj
                if src["kind"] == "analyzed":   # rotor frame = to_world, not the object's local frame
                    motion.matrix_parent_inverse = rotor_obj.matrix_world.inverted() @ Matrix(display.tolist())
                else:
                    motion.matrix_parent_inverse = Matrix.Identity(4)
                motion.matrix_basis = Matrix.Identity(4)
                action = key_screw_motion(motion, ((fs, s0), (fe, s1)), v0, eps)
                if action is not None:
                    actions.append(action)
                for k, me in enumerate(tool_meshes):
                    mv = add(name("DF Tool", k) + " (moving)", me, COLOR_TOOL, "moving", k)
                    mv.parent = motion
                    mv.matrix_parent_inverse = Matrix.Identity(4)
                    mv.matrix_basis = Matrix(frames[k][0].tolist())

            plan_path = csv_paths = None
            if self.filepath:
                from ..flank_addon.io.plan import write_plan

                plan_path = bpy.path.abspath(self.filepath)
                files.append(plan_path)
                write_plan(plan_path, res.plan)
            if self.tool_csv:
                base = bpy.path.abspath(self.tool_csv)
                which = range(len(res.paths)) if self.tool == "cones" else [0]
                stem, ext = os.path.splitext(base)
                csv_paths = []
                for k in which:
                    p = base if len(which) == 1 else "{}_{}{}".format(stem, k + 1, ext or ".csv")
                    files.append(p)
                    df.write_tool_csv(p, res.paths[k])
                    csv_paths.append(p)

            # replace the collection of an earlier run on this rotor and valley (only once this one is complete)
            replaced = replace_run(bpy, parent, coll, PROP_PREFIX + "key", key, base_name, names)
        except Exception as ex:
            for act in actions:
                try:
                    bpy.data.actions.remove(act)
                except (ReferenceError, RuntimeError):
                    pass
            remove_ids(bpy, objects, meshes, colls + ([parent] if parent_created else []))
            run_mat.discard()
            for p in files:
                try:
                    os.remove(p)
                except OSError:
                    pass
            self.report({'ERROR'}, "Could not build the double-flank results: {}: {}".format(type(ex).__name__, ex))
            return {'CANCELLED'}

        # ---- custom properties (lengths in scene units, angles in radians)
        def fl(v):
            return float(v) if v is not None else float("nan")

        fits = res.fits
        t2r, r2e = res.tool_to_rotor, res.rotor_to_envelope
        props = dict(
            rotor=rotor_obj.name, source=src["kind"], valley=k_valley, variant=str(self.variant), tool=tool,
            method=str(res.plan.get("method", "")), two_paths=bool(self.two_paths), radii=m, rim=rim,
            samples=int(self.samples), simulated=bool(self.simulate), length_unit=src["unit"],
            length_scale=s, tolerance=float(tol), paths=len(res.paths),
            alpha=[fl(f.x[0]) for f in fits], delta=[fl(f.x[1]) * s for f in fits], phi=[fl(f.x[2]) for f in fits],
            Phi=[fl(f.phi) * s for f in fits], iterations=[int(f.iterations) for f in fits],
            fit_elapsed=[fl(getattr(f, "elapsed_s", float("nan"))) for f in fits],
            tool_to_rotor_max=[fl(v[0]) * s for v in t2r], tool_to_rotor_min=[fl(v[1]) * s for v in t2r],
            rotor_to_envelope_max=[fl(v[0]) * s for v in r2e], rotor_to_envelope_min=[fl(v[1]) * s for v in r2e],
            hausdorff=[fl(v) * s for v in res.hausdorff], error_scale=float(err_scale),
            elapsed=fl(res.elapsed_s), optimize_elapsed=fl(res.optimize_s),
            total_elapsed=float(time.perf_counter() - t0),
            summary=json.dumps(dict(res.plan.get("summary", {}), fits=[dict(
                x=[float(v) for v in f.x], Phi=float(f.phi), iterations=int(f.iterations)) for f in fits]),
                default=str),
        )
        if motion_range is not None:
            props.update(frames=[fs, fe], motion=motion_range)
        if plan_path:
            props["plan"] = plan_path
        if csv_paths:
            props["tool_csv"] = csv_paths
        for key in [k for k in rotor_obj.keys() if k.startswith(PROP_PREFIX)]:
            del rotor_obj[key]
        for target in [coll, rotor_obj] + tool_objs:
            for key, value in props.items():
                target[PROP_PREFIX + key] = value
        # the run's plan (flank-plan/1) travels with its collection: exports and reports read it from there
        coll[PLAN_JSON_PROP] = json.dumps(res.plan)
        select_only(context, tool_objs[0])
        show_attribute_colors(bpy, context)

        f0 = fits[0]
        unit = "scene units"

        def pair(v):
            return "{:.4g}/{:.4g}".format(v[0], v[1])

        extra = ""
        if len(fits) > 1:
            extra = "; {} further axes (alpha {} deg)".format(len(fits) - 1, ", ".join(
                "{:+.4f}".format(math.degrees(f.x[0])) for f in fits[1:]))
        sim = ("; rotor->envelope max F1/F2 {} min {}; Hausdorff {} {}".format(
            pair(props["rotor_to_envelope_max"]), pair(props["rotor_to_envelope_min"]), pair(props["hausdorff"]),
            unit) if self.simulate else "; not simulated")
        files_note = ", replaced the earlier run" if replaced else ""
        if plan_path:
            files_note += ", wrote {}".format(os.path.basename(plan_path))
        if csv_paths:
            files_note += ", wrote {}".format(", ".join(os.path.basename(p) for p in csv_paths))
        self.report({'INFO'}, "Double flank {} valley {} ({}, {}, {} path(s)): alpha {:+.5f} deg, delta {:+.6g} {}, "
                              "phi {:+.5f} deg, Phi {:.4g} {}, {} iterations{}; tool->rotor max F1/F2 {} min {} {}{}; "
                              "optimisation {:.2f}s, core {:.2f}s, total {:.2f}s{}".format(
                                  rotor_obj.name, k_valley, props["method"], self.variant, len(res.paths),
                                  math.degrees(f0.x[0]), props["delta"][0], unit, math.degrees(f0.x[2]),
                                  props["Phi"][0], unit, int(f0.iterations), extra, pair(props["tool_to_rotor_max"]),
                                  pair(props["tool_to_rotor_min"]), unit, sim, res.optimize_s, res.elapsed_s,
                                  props["total_elapsed"], files_note))
        return {'FINISHED'}
