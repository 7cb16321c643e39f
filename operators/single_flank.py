# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.plan_single_flank -- s000: multi-strip single-flank milling of one rotor flank with a conical tool."""
import bpy

from .common import (PLAN_JSON_PROP, RunMaterial, edge_mesh, frame_along, key_screw_motion, new_mesh_from_arrays,
                     remove_ids, replace_run, results_parent, revolved_mesh, rotor_source,
                     select_only, set_color_attr, set_float_attr, show_attribute_colors)
from .modal import ModalPlannerMixin
from .properties import single_flank_props

PROP_PREFIX = "flank_sf_"
DEVIATION_ATTR = "deviation"           # FLOAT point attribute of the envelope strips (scene units, + = stock)
DEVIATION_COLOR_ATTR = "error_color"   # FLOAT_COLOR of the envelope strips and the chart (verify.deviation_colors)
ERROR_ATTR = "error"                   # FLOAT point attribute of the error chart (scene units, unscaled; 0 = baseline)
PARAM_ATTR = "u"                       # FLOAT point attribute of the error chart: profile parameter
CURVE_ATTR = "curve"                   # FLOAT point attribute of the error chart: 1 error curve, 0 baseline (profile)
ENVELOPE_SAMPLES = 60                  # characteristic points per strip (multi_strip.envelope_strip's n_s)
CHART_FRACTION = 0.1                   # largest |error| drawn as this fraction of the outer radius
TOOL_SEGMENTS = 48
COLOR_TOOL = (0.90, 0.72, 0.20, 1.0)
COLOR_ENVELOPE = (0.55, 0.62, 0.70, 1.0)
COLOR_BASELINE = (0.35, 0.35, 0.35, 1.0)
MAX_STORED_COLLISIONS = 50


def _decimal(v):
    """Blender float properties are single precision: the decimal value that was typed (7 digits)."""
    return float("{:.7g}".format(v))


def _finite_runs(np, mask):
    """[(start, stop)] of the runs of True in a boolean array (stop exclusive)."""
    m = np.r_[False, np.asarray(mask, dtype=bool), False]
    d = np.diff(m.astype(np.int8))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


def _merge_ranges(ranges):
    """Union of parameter ranges [(a, b)] as sorted disjoint ranges (the core may list a range twice)."""
    out = []
    for a, b in sorted((float(a), float(b)) for a, b in ranges):
        if out and a <= out[-1][1]:
            out[-1][1] = max(out[-1][1], b)
        else:
            out.append([a, b])
    return [tuple(r) for r in out]


class FLANK_OT_plan_single_flank(ModalPlannerMixin, bpy.types.Operator):
    """s000: plan multi-strip single-flank milling of one flank of the active rotor with a truncated-cone tool
    (optimised strips, global collision filter, minimum strip cover to a tolerance) and show the result.

    Rotor: the active rotor made by Generate Rotor (rebuilt exactly from its custom properties) or an analyzed
    mesh (analysed again).  Tool lengths and tolerances are in scene units.  Objects in a new collection under
    "Flank Results" (a collection of an earlier run on the same rotor and flank is replaced): per chosen strip
    its envelope strip with the point attributes ``deviation`` (FLOAT, signed, scene units, > 0 material left)
    and ``error_color`` (shown by the shared material "Flank Attribute Colour"), and its tool (cone + shank,
    origin at the tip sphere centre, local z along the axis); the error along the flank profile (s000 Fig. 11c)
    as an edge mesh in the rotor's start plane (offset along the profile normal = error x flank_sf_error_scale);
    with Animate a "Tool Motion" empty with the moving
    tools.  Custom properties flank_sf_* (strips, candidates, errors, uncovered ranges, collisions, kinks,
    times) on the collection, the tools and the rotor."""

    bl_idname = "flank.plan_single_flank"
    bl_label = "Plan Single Flank"
    bl_options = {'REGISTER', 'UNDO'}
    _title = "Single flank"

    __annotations__ = single_flank_props()

    # ------------------------------------------------------------------ inputs

    def _source(self, context, np):
        """The rotor to plan on -> dict, or an error message (str) (see common.rotor_source)."""
        return rotor_source(bpy, context, np, PROP_PREFIX)

    def _check_inputs(self, math):
        """Checks that need no rotor -> error message (str) or None."""
        r1, r2 = _decimal(self.r1), _decimal(self.r2)
        if not math.isfinite(r1) or r1 < 0.0:
            return "tool radius r1 = {} must be a finite number >= 0".format(r1)
        if not math.isfinite(r2) or not r1 < r2:
            return "tool radii r1 = {} and r2 = {}: r1 must be below r2".format(r1, r2)
        if self.shape == "alpha":
            a = _decimal(self.alpha)
            if not math.isfinite(a) or not 0.0 < a < 0.5 * math.pi:
                return "opening angle alpha = {:.6g} deg is outside (0, 90) deg".format(
                    math.degrees(a) if math.isfinite(a) else a)
        else:
            h = _decimal(self.length)
            if not math.isfinite(h) or h <= 0.0:
                return "cone length h = {} must be > 0".format(h)
        for label, v in (("shank radius", self.shank_radius), ("shank length", self.shank_length)):
            v = _decimal(v)
            if not math.isfinite(v) or v < 0.0:
                return "{} = {} must be a finite number >= 0".format(label, v)
        tol = _decimal(self.tolerance)
        if not math.isfinite(tol) or tol <= 0.0:
            return "tolerance = {} must be > 0 (scene units)".format(tol)
        over = _decimal(self.overcut_tolerance)
        if not math.isfinite(over) or over < 0.0:
            return "overcut tolerance = {} must be >= 0 (scene units; 0 = 1e-6 x outer radius)".format(over)
        if not 1 <= int(self.seeds) <= 400:
            return "seeds = {} is outside 1..400".format(int(self.seeds))
        if not 0 <= int(self.g1_extra_strips) <= 50:
            return "G1 extra strips = {} is outside 0..50".format(int(self.g1_extra_strips))
        from .common import count_limit_error

        msg = (count_limit_error("rounds", self.rounds, 1, 50)
               or count_limit_error("envelope rings", self.envelope_rings, 2, 4096))
        if msg is not None:
            return msg
        if self.animate and int(self.frame_end) <= int(self.frame_start):
            return "end frame {} must be after the start frame {}".format(int(self.frame_end), int(self.frame_start))
        return None

    # ------------------------------------------------------------------ run

    def _prepare(self, context):
        """Main thread: properties, rotor and tool -> job dict, or None (error reported)."""
        import math
        import time

        import numpy as np

        t0 = time.perf_counter()
        msg = self._check_inputs(math)
        if msg is not None:
            self.report({'ERROR'}, "Single flank: " + msg)
            return None
        src = self._source(context, np)
        if isinstance(src, str):
            self.report({'ERROR'}, "Single flank: " + src)
            return None
        rotor_obj, surface, flanks = src["obj"], src["surface"], src["flanks"]
        s = float(src["scale"])                       # scene units per rotor unit
        R = float(surface.outer_radius)
        display = src["display"]
        limit = 0.5 * R * s
        for label, v in (("tolerance", _decimal(self.tolerance)), ("overcut tolerance",
                                                                    _decimal(self.overcut_tolerance))):
            if not v < limit:
                self.report({'ERROR'}, "Single flank: {} = {} must be below half the outer radius of '{}', {:.6g} "
                                       "(scene units)".format(label, v, rotor_obj.name, limit))
                return None
        # sizes beyond these mean a tool that cannot enter any valley (and sweeps that run for minutes)
        for label, v, k in (("tool radius r2", self.r2, 2.0), ("tool radius r1", self.r1, 2.0),
                            ("cone length h", self.length if self.shape == "length" else 0.0, 20.0),
                            ("shank radius", self.shank_radius, 10.0), ("shank length", self.shank_length, 100.0)):
            if not _decimal(v) <= k * R * s:
                self.report({'ERROR'}, "Single flank: {} = {:g} exceeds the limit {:g} x the outer radius of '{}' = "
                                       "{:.6g} (scene units)".format(label, _decimal(v), k, rotor_obj.name, k * R * s))
                return None

        from ..flank_addon.methods.single_flank import planner as ms
        from ..flank_addon.tooling.cone import ConeTool

        # ---- the flank
        point_rotor = None
        if self.use_point:
            p_local = np.array([_decimal(v) for v in self.point], dtype=np.float64)
            if not np.isfinite(p_local).all():
                self.report({'ERROR'}, "Single flank: point {} is not finite".format(p_local.tolist()))
                return None
            mw = np.array(rotor_obj.matrix_world, dtype=np.float64)
            p_world = mw[:3, :3] @ p_local + mw[:3, 3]
            p_h = np.linalg.solve(display, np.r_[p_world, 1.0])
            point_rotor = p_h[:3] / p_h[3]
            try:
                k_flank = int(ms.flank_of_point(surface, flanks, point_rotor))
            except ValueError as ex:
                self.report({'ERROR'}, "Single flank: {}".format(ex))
                return None
        else:
            k_flank = int(self.flank)
            if not 0 <= k_flank < len(flanks):
                self.report({'ERROR'}, "Single flank: flank = {} is outside 0..{} (rotor '{}' has {} flanks)".format(
                    k_flank, len(flanks) - 1, rotor_obj.name, len(flanks)))
                return None
        u_range = tuple(float(v) for v in flanks[k_flank])

        # ---- the tool (rotor units)
        r1, r2 = _decimal(self.r1) / s, _decimal(self.r2) / s
        shank = dict(shank_radius=_decimal(self.shank_radius) / s, shank_length=_decimal(self.shank_length) / s)
        try:
            if self.shape == "alpha":
                tool = ConeTool(_decimal(self.alpha), r1, r2, **shank)
            else:
                tool = ConeTool.from_length(r1, r2, _decimal(self.length) / s, **shank)
        except ValueError as ex:
            self.report({'ERROR'}, "Single flank: {}".format(ex))
            return None
        tol_in, over_in = _decimal(self.tolerance), _decimal(self.overcut_tolerance)
        tol = tol_in / s
        over = over_in / s if over_in > 0.0 else None

        z0, z1 = (float(v) for v in src["z_range"])
        return dict(t0=t0, src=src, rotor_name=rotor_obj.name, surface=surface, flanks=flanks, s=s, R=R,
                    display=display, point_rotor=point_rotor, k_flank=k_flank, u_range=u_range, tool=tool,
                    tol_in=tol_in, tol=tol, over=over, z0=z0, z1=z1, n_t=int(self.envelope_rings),
                    seeds=int(self.seeds), objective=str(self.objective), mode=str(self.mode),
                    rounds=int(self.rounds), collisions=bool(self.collisions), g1=bool(self.g1),
                    g1_extra_strips=int(self.g1_extra_strips), to_world=src["to_world"].tolist(), unit=src["unit"])

    @staticmethod
    def _compute(job, progress):
        """The planner and the envelope strips (numpy only: runs in the worker thread when invoked)."""
        import time

        import numpy as np

        from ..flank_addon.methods.single_flank import planner as ms
        from ..flank_addon.tooling.meridian import cone_tool_outline

        surface, flanks, k_flank, u_range = job["surface"], job["flanks"], job["k_flank"], job["u_range"]
        tool, z0, z1, n_t = job["tool"], job["z0"], job["z1"], job["n_t"]
        # collisions against the infinite rotor: a pass screws the whole body past the tool, so the finite
        # rotor's slab over the pass holds the tool entirely; z_range only places the strips
        res = ms.plan_single_flank(surface, flanks, k_flank, tool, job["tol"], overcut_tolerance=job["over"],
                                   n_seeds=job["seeds"], objective=job["objective"], mode=job["mode"],
                                   max_rounds=job["rounds"], to_world=job["to_world"], length_unit=job["unit"],
                                   check_collisions=job["collisions"], g1=job["g1"],
                                   g1_extra_strips=job["g1_extra_strips"], progress=progress)
        if not res.strips:
            raise ValueError("no collision-free strip on flank {}: {} candidates, {} colliding (uncovered {})"
                             .format(k_flank, len(res.candidates), len(res.collisions),
                                     ", ".join("[{:.4g}, {:.4g}]".format(a, b)
                                               for a, b in _merge_ranges(res.uncovered))))
        t_env = time.perf_counter()
        envs, sweeps = [], []
        for c in res.strips:
            zc = 0.5 * float(c.pose.tip[2] + c.pose.top[2])   # centre the swept strip on the rotor body
            sweep = (z0 - zc, z1 - zc)
            sweeps.append(sweep)
            envs.append(ms.envelope_strip(c, surface, u_range, sweep, ENVELOPE_SAMPLES, n_t))
        env_elapsed = time.perf_counter() - t_env
        frames = []
        for c in res.strips:
            rot, _ = frame_along(np, c.pose.tip, c.pose.top)
            T = np.eye(4)
            T[:3, :3] = rot
            T[:3, 3] = c.pose.tip
            frames.append(T)
        tool_verts, tool_faces = revolved_mesh(np, cone_tool_outline(tool), TOOL_SEGMENTS)
        return dict(res=res, envs=envs, sweeps=sweeps, env_elapsed=env_elapsed, frames=frames,
                    tool_verts=tool_verts, tool_faces=tool_faces)

    def _build(self, context, job, out):
        """Main thread: the result collection, objects, attributes and properties from a finished run."""
        import json
        import os
        import time

        import numpy as np
        from mathutils import Matrix

        from ..flank_addon.geometry.screw import screw_motion
        from ..flank_addon.simulation.verify import deviation_colors

        rotor_obj = bpy.data.objects.get(job["rotor_name"])
        if rotor_obj is None:
            self.report({'ERROR'}, "Single flank: the rotor '{}' was removed while planning".format(job["rotor_name"]))
            return {'CANCELLED'}
        src, surface, s, R, display = job["src"], job["surface"], job["s"], job["R"], job["display"]
        k_flank, u_range, point_rotor, tool = job["k_flank"], job["u_range"], job["point_rotor"], job["tool"]
        tol_in, z0, z1, n_t, t0 = job["tol_in"], job["z0"], job["z1"], job["n_t"], job["t0"]
        res, envs, sweeps, frames = out["res"], out["envs"], out["sweeps"], out["frames"]
        env_elapsed, tool_verts, tool_faces = out["env_elapsed"], out["tool_verts"], out["tool_faces"]

        uncovered = _merge_ranges(res.uncovered)

        # ---- error along the profile (s000 Fig. 11c): offset along the profile's outward normal, start plane
        u_dev = np.asarray(res.deviation[0], dtype=np.float64)
        e_dev = np.asarray(res.deviation[1], dtype=np.float64)
        fin = np.isfinite(e_dev)
        e_max = float(np.abs(e_dev[fin]).max()) if fin.any() else 0.0
        err_scale = CHART_FRACTION * R / e_max if e_max > 1e-12 * R else 1.0
        prof = surface.profile
        t_start = z0 / float(surface.v0)

        def plane_points(xy):
            p3 = np.c_[xy, np.zeros(len(xy))]
            return screw_motion(p3, t_start, surface.v0, surface.hand)

        v0, eps = float(surface.v0), (1 if surface.hand > 0 else -1)
        key = "{}|{}".format(rotor_obj.name, k_flank)
        base_name = "Single Flank ({}, flank {})".format(rotor_obj.name, k_flank)
        n_strips = len(res.strips)

        objects, meshes, colls, actions, files, names = [], [], [], [], [], []
        tag = "SF F{} ".format(k_flank)          # object name prefix: flank k's results
        parent, parent_created = None, False
        strip_rows = res.plan["strips"]
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
                    ob[PROP_PREFIX + "strip"] = int(k)
                return ob

            tool_objs, tool_meshes = [], []
            for k, (cand, (ev, ef, ed), T) in enumerate(zip(res.strips, envs, frames)):
                label = "{}Tool {}".format(tag, k + 1)
                me = new_mesh_from_arrays(bpy, np, label, tool_verts, tool_faces)
                ob = add(label, me, COLOR_TOOL, "tool", k)
                ob.matrix_world = Matrix((display @ T).tolist())
                ob[PROP_PREFIX + "tip"] = [float(v) for v in cand.pose.tip]          # rotor frame, rotor units
                ob[PROP_PREFIX + "axis"] = [float(v) for v in cand.pose.axis]
                ob[PROP_PREFIX + "params"] = [float(v) for v in np.ravel(cand.params)]
                ob[PROP_PREFIX + "strip_errors"] = [float(strip_rows[k]["reported_max_error"]) * s,
                                                    float(strip_rows[k]["reported_min_error"]) * s]
                ob[PROP_PREFIX + "seed_u"] = float(cand.seed.u)
                tool_objs.append(ob)
                tool_meshes.append(me)

                if len(ev) == 0 or len(ef) == 0:
                    continue
                label = "{}Strip {}".format(tag, k + 1)
                em = new_mesh_from_arrays(bpy, np, label, ev, ef)
                eo = add(label, em, COLOR_ENVELOPE, "envelope", k)
                eo.matrix_world = Matrix(display.tolist())
                dev = np.asarray(ed, dtype=np.float64) * s
                set_float_attr(np, em, DEVIATION_ATTR, dev)
                set_color_attr(np, em, DEVIATION_COLOR_ATTR, deviation_colors(dev, tol_in))
                run_mat.assign(em)
                em.update()
                rng = [float(dev.min()), float(dev.max())]
                eo[PROP_PREFIX + "deviation_range"] = rng
                eo[PROP_PREFIX + "sweep"] = [float(v) for v in sweeps[k]]
                eo[PROP_PREFIX + "envelope_samples"] = ENVELOPE_SAMPLES
                eo[PROP_PREFIX + "envelope_rings"] = n_t

            # chart: baseline = the flank profile, curve = profile + normal x error x scale
            u_base = np.linspace(u_range[0], u_range[1], max(64, len(u_dev)))
            chains = [(plane_points(prof.eval(u_base)), False)]
            err_v, u_v, curve_v = [np.zeros(len(u_base))], [u_base], [np.zeros(len(u_base))]
            for a, b in _finite_runs(np, fin):
                if b - a < 2:
                    continue
                uu, ee = u_dev[a:b], e_dev[a:b]
                xy = prof.eval(uu) + prof.outward_normal(uu) * (err_scale * ee)[:, None]
                chains.append((plane_points(xy), False))
                err_v.append(ee * s)
                u_v.append(uu)
                curve_v.append(np.ones(b - a))
            cm = edge_mesh(bpy, np, tag + "Error along profile", chains)
            co = add(tag + "Error along profile", cm, (0.1, 0.1, 0.1, 1.0), "error_chart")
            co.matrix_world = Matrix(display.tolist())
            errs, curves = np.concatenate(err_v), np.concatenate(curve_v)
            set_float_attr(np, cm, ERROR_ATTR, errs)
            set_float_attr(np, cm, PARAM_ATTR, np.concatenate(u_v))
            set_float_attr(np, cm, CURVE_ATTR, curves)
            cols = deviation_colors(errs, tol_in)
            cols[curves == 0] = COLOR_BASELINE
            set_color_attr(np, cm, DEVIATION_COLOR_ATTR, cols)
            run_mat.assign(cm)
            co[PROP_PREFIX + "error_scale"] = float(err_scale)
            co[PROP_PREFIX + "max_abs_error"] = e_max * s

            motion_range = None
            fs, fe = int(self.frame_start), int(self.frame_end)
            if self.animate:
                s0, s1 = (z0 - R) / v0, (z1 + R) / v0
                motion_range = [float(s0), float(s1)]
                motion = add(tag + "Tool Motion", None, role="motion")
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
                    mv = add("{}Tool {} (moving)".format(tag, k + 1), me, COLOR_TOOL, "moving", k)
                    mv.parent = motion
                    mv.matrix_parent_inverse = Matrix.Identity(4)
                    mv.matrix_basis = Matrix(frames[k].tolist())

            plan_path = None
            if self.filepath:
                from ..flank_addon.io.plan import write_plan

                plan_path = bpy.path.abspath(self.filepath)
                files.append(plan_path)
                write_plan(plan_path, res.plan)

            # replace the collection of an earlier run on this rotor and flank (only once this one is complete)
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
            self.report({'ERROR'}, "Could not build the single-flank results: {}: {}".format(type(ex).__name__, ex))
            return {'CANCELLED'}

        # ---- custom properties (lengths in scene units, angles in radians, flank ranges as profile parameters)
        summary = res.plan.get("summary", {})
        kinks = [float(j["kink_deg"]) for js in res.junctions for j in js]
        timings = {k: float(v) for k, v in res.timings.items()}
        timings["envelopes"] = float(env_elapsed)

        def fl(v):
            return float(v) if v is not None else float("nan")

        props = dict(
            rotor=rotor_obj.name, source=src["kind"], flank=int(k_flank), flank_range=list(u_range),
            flank_from_point=bool(self.use_point), method=str(res.plan.get("method", "")),
            length_unit=src["unit"], length_scale=s,
            tool_alpha=float(tool.alpha), tool_r1=float(tool.r1c) * s, tool_r2=float(tool.r2c) * s,
            tool_h=float(tool.h) * s, tool_shank_radius=float(tool.shank_radius) * s,
            tool_shank_length=float(tool.shank_length) * s,
            tolerance=float(tol_in), overcut_tolerance=float(res.plan["overcut_tolerance"]) * s,
            seeds=int(self.seeds), objective=str(self.objective), mode=str(self.mode), rounds=int(self.rounds),
            g1=bool(job["g1"]), g1_extra_strips=int(job["g1_extra_strips"]),
            rounds_run=len(res.rounds), collisions_checked=bool(self.collisions),
            strips=n_strips, candidates=len(res.candidates), collisions=len(res.collisions),
            collision_u=[float(c["u"]) for c in res.collisions],
            complete=bool(res.complete),
            max_error=fl(summary.get("max_error")) * s, min_error=fl(summary.get("min_error")) * s,
            strip_max_error=[float(st["reported_max_error"]) * s for st in strip_rows],
            strip_min_error=[float(st["reported_min_error"]) * s for st in strip_rows],
            profile_max_error=float(np.nanmax(e_dev)) * s if fin.any() else float("nan"),
            profile_min_error=float(np.nanmin(e_dev)) * s if fin.any() else float("nan"),
            uncovered=[float(v) for g in uncovered for v in g], uncovered_count=len(uncovered),
            kinks_deg=kinks, kink_max_deg=max(kinks) if kinks else 0.0,
            error_scale=float(err_scale),
            elapsed=float(timings.get("total", float("nan"))), total_elapsed=float(time.perf_counter() - t0),
            summary=json.dumps(dict(summary, timings=timings, rounds=res.rounds,
                                    collisions=res.collisions[:MAX_STORED_COLLISIONS],
                                    junctions=res.junctions), default=str),
        )
        for name in ("candidates", "collision", "cover", "junctions", "verify", "envelopes"):
            if name in timings:
                props[name + "_elapsed"] = timings[name]
        if point_rotor is not None:
            props.update(point=[float(v) for v in self.point], point_rotor=[float(v) for v in point_rotor])
        if motion_range is not None:
            props.update(frames=[fs, fe], motion=motion_range)
        if plan_path:
            props["plan"] = plan_path
        for key_ in [k for k in rotor_obj.keys() if k.startswith(PROP_PREFIX)]:
            del rotor_obj[key_]
        for target in [coll, rotor_obj] + tool_objs:
            for name, value in props.items():
                target[PROP_PREFIX + name] = value
        # the run's plan (flank-plan/1) travels with its collection: exports and reports read it from there
        coll[PLAN_JSON_PROP] = json.dumps(res.plan)
        select_only(context, tool_objs[0])
        show_attribute_colors(bpy, context)

        unit = "scene units"
        unc = ("complete" if res.complete else "uncovered {}".format(", ".join(
            "[{:.4g}, {:.4g}]".format(a, b) for a, b in uncovered)))
        self.report({'INFO'}, "Single flank {} flank {} ({}): {} strips of {} candidates ({} colliding excluded), "
                              "error {:.4g} .. {:.4g} {} (tolerance {:.4g}), {}, largest kink {:.3g} deg, "
                              "{} round(s){}{}; core {:.2f}s, total {:.2f}s".format(
                                  rotor_obj.name, k_flank, props["method"], n_strips, len(res.candidates),
                                  len(res.collisions), props["min_error"], props["max_error"], unit, tol_in, unc,
                                  props["kink_max_deg"], len(res.rounds),
                                  ", replaced the earlier run" if replaced else "",
                                  ", wrote {}".format(os.path.basename(plan_path)) if plan_path else "",
                                  props["elapsed"], props["total_elapsed"]))
        return {'FINISHED'}
