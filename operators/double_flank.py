# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.plan_double_flank -- double-flank milling with a custom tool (Bizzarri & Bartoň 2021): both flanks of
one rotor valley in one pass of a custom-shaped tool (optimised axis, radial function min / average /
one-sided) or of conical tools.

Rotor: the active rotor made by Generate Rotor (rebuilt exactly from its custom properties; the mesh's local
frame is the rotor frame) or an analysed mesh (analysed again here, as the command line does with --mesh; the
rotor frame is the analysis's to_world, in scene units).  Objects in a collection under "Flank Results" (an
earlier run on the same rotor and valley is replaced): per tool path the tool (revolved outline + shank,
origin at the tip, local z along its axis), the two envelope strips with the point attributes ``deviation``
(FLOAT, signed, scene units = rotor units x object scale, > 0 material left) and ``error_color`` (shown by the
shared material "Flank Attribute Colour"), the error along the axis (the paper's Figs. 12, 14 and 17) as an
edge-mesh chart beside the tool (x offset = error x flank_df_error_scale), and with Animate a "Tool Motion"
empty parented to the rotor with linear keys along the screw motion and a moving tool.  Custom properties
flank_df_* (alpha, delta, phi, Phi, iterations, errors, Hausdorff, times) on the collection, the tools and the
rotor."""
import json
import math
import os
import time

import bpy
import numpy as np

from .common import count_limit_error, output_file_error, set_color_attr, set_float_attr, typed
from .modal import ModalPlannerMixin
from .properties import double_flank_props
from .result_builder import COLOR_CHART, COLOR_TOOL, RunBuilder, finite_runs
from .runs import run_plan_fields
from .shapes import axis_frame
from .sources import AnalysisNeeded, own_frame, rotor_source, with_extent
from .strips import store_run_plan

PROP_PREFIX = "flank_df_"
ERROR_ATTR = "error"                   # FLOAT point attribute of the error chart (scene units, unscaled)
FLANK_ATTR = "flank"                   # FLOAT point attribute of the error chart: 1, 2 (0 = baseline)
CHART_COLOR_ATTR = "flank_color"
# value of ``deviation`` where the core gives none (never expected: the strips hold milled nodes only)
UNTOUCHED = 1.0e9
TOOL_SEGMENTS = 48
TOOL_MAX_RINGS = 400
CHART_COLORS = {0: (0.35, 0.35, 0.35, 1.0), 1: (0.85, 0.15, 0.10, 1.0), 2: (0.10, 0.35, 0.85, 1.0)}

__all__ = ["FLANK_OT_plan_double_flank"]


def _tool_frame(path):
    """4x4 tool frame in the rotor frame: origin at the axis start (tip end), z along the axis."""
    T, length = axis_frame(path.plan_points[0], path.plan_points[-1])
    if T is None:
        raise ValueError("tool axis of zero length")
    return T, length


def _check_inputs(op):
    """Checks that need no rotor -> error message or None."""
    rim, tol_in = typed(op.rim), typed(op.tolerance)
    if not math.isfinite(rim) or not 0.0 < rim <= 1.0:
        return "rim = {} must be in (0, 1] (fraction of the valley depth)".format(rim)
    if not math.isfinite(tol_in) or tol_in < 0.0:
        return "tolerance = {} must be a finite number >= 0".format(tol_in)
    if int(op.radii) < 2:
        return "radii m = {} is below the minimum 2 (the plan needs m + 1 >= 3 radii per strip)".format(int(op.radii))
    msg = (count_limit_error("axis samples", op.samples, 4, 2000)
           or count_limit_error("envelope rings", op.envelope_rings, 2, 4096))
    if msg is not None:
        return msg
    if op.two_paths and op.tool != "custom":
        return ("Two Paths needs Tool = Custom (one custom tool on two axes, Bizzarri & Bartoň 2021 Sec. 4.3), "
                "got Tool = {}".format(op.tool))
    if op.animate and int(op.frame_end) <= int(op.frame_start):
        return "end frame {} must be after the start frame {}".format(int(op.frame_end), int(op.frame_start))
    return None


def _check_rotor(op, src):
    nv = len(src["flanks"]) // 2
    k_valley = int(op.valley)
    if not 0 <= k_valley < nv:
        return "valley = {} is outside 0..{} (rotor '{}' has {} valleys)".format(k_valley, nv - 1, src["obj"].name,
                                                                              nv)
    lim = 0.5 * float(src["surface"].outer_radius) * float(src["scale"])
    if not typed(op.tolerance) < lim:
        return "tolerance = {:g} must be below half the outer radius of '{}', {:.6g} (scene units)".format(
            typed(op.tolerance), src["obj"].name, lim)
    return None


def _axis_chart(path, T, chart, err_scale, s):
    """Chains of the error along the axis beside the tool (tool frame: z along the axis, x = offset + error x
    scale) and their per-point values."""
    s_ax, e1, e2 = chart
    z_loc = (np.asarray(path.points, dtype=np.float64) - path.plan_points[0]) @ T[:3, 2]
    x0 = 1.25 * float(np.nanmax(path.radii))
    chains, err_v, flank_v = [], [], []
    for fl, e in ((1, np.asarray(e1, dtype=np.float64)), (2, np.asarray(e2, dtype=np.float64))):
        for a, b in finite_runs(np.isfinite(e)):
            if b - a < 2:
                continue
            chains.append((np.c_[x0 + err_scale * e[a:b], np.zeros(b - a), z_loc[a:b]], False))
            err_v.append(e[a:b] * s)
            flank_v.append(np.full(b - a, fl))
    chains.append((np.array([[x0, 0.0, float(np.nanmin(z_loc))], [x0, 0.0, float(np.nanmax(z_loc))]]), False))
    err_v.append(np.zeros(2))
    flank_v.append(np.zeros(2, dtype=int))
    e_all = np.r_[e1, e2]
    max_abs = float(np.nanmax(np.abs(e_all))) * s if np.isfinite(e_all).any() else float("nan")
    return chains, np.concatenate(err_v), np.concatenate(flank_v), x0, max_abs


def _fill_run(run, job, out, rotor, made):
    """Tools, envelope strips, error charts, the motion and the files of the run."""
    res, s, display, R = out["res"], float(job["src"]["scale"]), job["src"]["display"], \
        float(job["surface"].outer_radius)
    tol = job["tol_in"] if job["tol_in"] > 0.0 else 1e-3 * R * s
    multi = len(res.paths) > 1

    def name(base, k):
        return "{} {}".format(base, k + 1) if multi else base

    e_all = np.concatenate([np.r_[c[1], c[2]] for c in out["charts"]])
    e_all = e_all[np.isfinite(e_all)]
    e_max = float(np.abs(e_all).max()) if len(e_all) else 0.0
    r_tool = max(float(np.nanmax(p.radii)) for p in res.paths)
    made.update(tools=[], tol=tol, err_scale=0.5 * r_tool / e_max if e_max > 1e-12 * R else 1.0, files=[])
    for k, path in enumerate(res.paths):
        T = out["frames"][k][0]
        verts, faces = out["tools"][k]
        Tinv = np.linalg.inv(T)
        local = np.asarray(verts, dtype=np.float64) @ Tinv[:3, :3].T + Tinv[:3, 3]
        ob = run.add_mesh(name("DF Tool", k), local, faces, COLOR_TOOL, "tool", k, display @ T)
        ob[PROP_PREFIX + "axis_start"] = [float(v) for v in path.plan_points[0]]
        ob[PROP_PREFIX + "axis_end"] = [float(v) for v in path.plan_points[-1]]
        ob[PROP_PREFIX + "radii_range"] = [float(np.nanmin(path.radii)) * s, float(np.nanmax(path.radii)) * s]
        made["tools"].append(ob)
        for f, (ev, ef, ed) in enumerate(out["env"][k]):
            if len(ev) == 0 or len(ef) == 0:
                continue
            dev = np.asarray(ed, dtype=np.float64) * s
            fin = np.isfinite(dev)
            eo = run.add_strip(name("DF Envelope", k) + " F{}".format(f + 1), ev, ef, dev, tol, display, k,
                               stored=np.where(fin, dev, UNTOUCHED))
            eo[PROP_PREFIX + "flank"] = f + 1
            eo[PROP_PREFIX + "deviation_range"] = ([float(dev[fin].min()), float(dev[fin].max())] if fin.any()
                                                  else [float("nan")] * 2)
        _add_error_chart(run, name("DF Error along axis", k), path, T, out["charts"][k], made["err_scale"], s,
                         display, k)
    if job["animate"]:
        _add_tool_motion(run, job, out, rotor, made, name)
    _write_files(run, job, res, made)


def _add_error_chart(run, label, path, T, chart, err_scale, s, display, k):
    chains, errs, flanks, x0, max_abs = _axis_chart(path, T, chart, err_scale, s)
    me = run.edges(label, chains)
    co = run.add(label, me, COLOR_CHART, "error_chart", k, display @ T)
    set_float_attr(me, ERROR_ATTR, errs)
    set_float_attr(me, FLANK_ATTR, flanks.astype(np.float64))
    set_color_attr(me, CHART_COLOR_ATTR, np.array([CHART_COLORS[int(v)] for v in flanks]))
    run.color_by_attribute(me)
    co[PROP_PREFIX + "error_scale"] = float(err_scale)
    co[PROP_PREFIX + "chart_offset"] = float(x0 * s)
    co[PROP_PREFIX + "max_abs_error"] = max_abs


def _add_tool_motion(run, job, out, rotor, made, name):
    surface, src = job["surface"], job["src"]
    R, v0, eps = float(surface.outer_radius), float(surface.v0), (1 if surface.hand > 0 else -1)
    z0, z1 = src["z_range"]
    made["motion"] = [float((z0 - R) / v0), float((z1 + R) / v0)]
    motion = run.add_motion("DF Tool Motion", rotor, tuple(zip(job["frames"], made["motion"])), v0, eps,
                            0.25 * R, frame=own_frame(src))
    for k, tool in enumerate(made["tools"]):
        run.add_moving(name("DF Tool", k) + " (moving)", motion, tool.data, out["frames"][k][0], index=k)


def _write_files(run, job, res, made):
    from ..flank_addon.io.plan import write_plan
    from ..flank_addon.methods.double_flank import planner as df

    if job["filepath"]:
        run.write(job["filepath"], lambda p: write_plan(p, res.plan))
    if job["tool_csv"]:
        base = job["tool_csv"]
        which = range(len(res.paths)) if job["tool"].startswith("cones") else [0]
        stem, ext = os.path.splitext(base)
        for k in which:
            p = base if len(which) == 1 else "{}_{}{}".format(stem, k + 1, ext or ".csv")
            made["files"].append(run.write(p, lambda q, k=k: df.write_tool_csv(q, res.paths[k])))


class FLANK_OT_plan_double_flank(ModalPlannerMixin, bpy.types.Operator):
    """Plan double-flank milling of one valley of the active rotor with a custom-shaped tool (or conical tools)
    that cuts both flanks in one pass, shown as tools, error-coloured strips and error charts"""

    bl_idname = "flank.plan_double_flank"
    bl_label = "Plan Double Flank"
    bl_options = {'REGISTER', 'UNDO'}
    _title = "Double flank"

    __annotations__ = double_flank_props()

    # ------------------------------------------------------------------ main thread: inputs
    def _prepare(self, context):
        """Properties and rotor -> job dict, or None (error reported)."""
        t0 = time.perf_counter()
        msg = (_check_inputs(self) or output_file_error(self.filepath, "plan file")
               or output_file_error(self.tool_csv, "tool CSV"))
        src = rotor_source(context.active_object, PROP_PREFIX, defer=self._defer_analysis) if msg is None else msg
        if isinstance(src, AnalysisNeeded):
            return self._read_first(src)
        msg = src if isinstance(src, str) else _check_rotor(self, src)
        if msg is not None:
            self.report({'ERROR'}, "Double flank: " + msg)
            return None
        tool = "cones:{}".format(int(self.cones)) if self.tool == "cones" else str(self.tool)
        return dict(t0=t0, src=src, rotor_name=src["obj"].name, surface=src["surface"], flanks=src["flanks"],
                    k_valley=int(self.valley), tool=tool, m=int(self.radii), rim=typed(self.rim),
                    tol_in=typed(self.tolerance), frames=(int(self.frame_start), int(self.frame_end)),
                    variant=str(self.variant), two_paths=bool(self.two_paths), samples=int(self.samples),
                    simulate=bool(self.simulate), rings=int(self.envelope_rings), to_world=src["to_world"].tolist(),
                    unit=src["unit"], z_range=tuple(float(v) for v in src["z_range"]), extent=src.get("extent"),
                    animate=bool(self.animate),
                    filepath=bpy.path.abspath(self.filepath) if self.filepath else "",
                    tool_csv=bpy.path.abspath(self.tool_csv) if self.tool_csv else "")

    # ------------------------------------------------------------------ worker thread
    @staticmethod
    def _compute(job, progress):
        """The planner, envelopes, tool meshes, frames and charts (no Blender data)."""
        from ..flank_addon.methods.double_flank import planner as df

        res = df.plan_double_flank(job["surface"], job["flanks"], valley=job["k_valley"], variant=job["variant"],
                                   tool=job["tool"], two_paths=job["two_paths"], m=job["m"], rim=job["rim"],
                                   n=job["samples"], to_world=job["to_world"], length_unit=job["unit"],
                                   simulate=job["simulate"], progress=progress)
        with_extent(res.plan, job["extent"])         # the finite rotor, for whole-rotor machine programs
        env = res.envelope_meshes(job["z_range"], job["rings"])
        tools = [res.tool_mesh(k, n_around=TOOL_SEGMENTS, max_rings=TOOL_MAX_RINGS) for k in range(len(res.paths))]
        frames = [_tool_frame(p) for p in res.paths]
        charts = [res.errors_along_axis(k) for k in range(len(res.paths))]
        # the plan as the run keeps it, encoded here: 25 ms off the main thread's build (a 1 MB plan)
        return dict(res=res, env=env, tools=tools, frames=frames, charts=charts, **run_plan_fields(res.plan))

    # ------------------------------------------------------------------ main thread: results
    def _build(self, context, job, out):
        """The run's collection, objects, attributes and properties from a finished plan."""
        rotor = bpy.data.objects.get(job["rotor_name"])
        if rotor is None:
            self.report({'ERROR'}, "Double flank: the rotor '{}' was removed while planning".format(job["rotor_name"]))
            return {'CANCELLED'}
        k = job["k_valley"]
        run = RunBuilder(context, PROP_PREFIX, "{}|{}".format(rotor.name, k),
                         "Double Flank ({}, valley {})".format(rotor.name, k), owner=("rotor", rotor.name),
                         index_key="path")
        made = {}
        replaced = run.build(self, "double-flank results", lambda: _fill_run(run, job, out, rotor, made))
        if replaced is None:
            return {'CANCELLED'}
        props = self._props(job, out, rotor, made)
        run.store(props, [run.collection, rotor] + made["tools"], clear=[rotor])
        # the run's plan (flank-plan/1) travels with its collection: exports, reports, posts and the strips list
        # read it from there
        store_run_plan(run.collection, out)
        run.show(made["tools"][0])
        self._report_done(job, out, rotor, props, made, replaced)
        return {'FINISHED'}

    def _props(self, job, out, rotor, made):
        """The run's custom properties (lengths in scene units, angles in radians)."""
        res, s = out["res"], float(job["src"]["scale"])

        def fl(v):
            return float(v) if v is not None else float("nan")

        fits, t2r, r2e = res.fits, res.tool_to_rotor, res.rotor_to_envelope
        props = dict(
            rotor=rotor.name, source=job["src"]["kind"], valley=job["k_valley"], variant=job["variant"],
            tool=job["tool"], method=str(res.plan.get("method", "")), two_paths=job["two_paths"], radii=job["m"],
            rim=job["rim"], samples=job["samples"], simulated=job["simulate"], length_unit=job["unit"],
            length_scale=s, tolerance=float(made["tol"]), paths=len(res.paths),
            alpha=[fl(f.x[0]) for f in fits], delta=[fl(f.x[1]) * s for f in fits], phi=[fl(f.x[2]) for f in fits],
            Phi=[fl(f.phi) * s for f in fits], iterations=[int(f.iterations) for f in fits],
            fit_elapsed=[fl(getattr(f, "elapsed_s", float("nan"))) for f in fits],
            tool_to_rotor_max=[fl(v[0]) * s for v in t2r], tool_to_rotor_min=[fl(v[1]) * s for v in t2r],
            rotor_to_envelope_max=[fl(v[0]) * s for v in r2e], rotor_to_envelope_min=[fl(v[1]) * s for v in r2e],
            hausdorff=[fl(v) * s for v in res.hausdorff], error_scale=float(made["err_scale"]),
            elapsed=fl(res.elapsed_s), optimize_elapsed=fl(res.optimize_s),
            total_elapsed=float(time.perf_counter() - job["t0"]),
            summary=json.dumps(dict(res.plan.get("summary", {}), fits=[dict(
                x=[float(v) for v in f.x], Phi=float(f.phi), iterations=int(f.iterations)) for f in fits]),
                default=str),
        )
        if "motion" in made:
            props.update(frames=list(job["frames"]), motion=made["motion"])
        if job["filepath"]:
            props["plan"] = job["filepath"]
        if made["files"]:
            props["tool_csv"] = made["files"]
        return props

    def _report_done(self, job, out, rotor, props, made, replaced):
        res = out["res"]
        f0, unit = res.fits[0], "scene units"

        def pair(v):
            return "{:.4g}/{:.4g}".format(v[0], v[1])

        extra = ""
        if len(res.fits) > 1:
            extra = "; {} further axes (alpha {} deg)".format(len(res.fits) - 1, ", ".join(
                "{:+.4f}".format(math.degrees(f.x[0])) for f in res.fits[1:]))
        sim = ("; rotor->envelope max F1/F2 {} min {}; Hausdorff {} {}".format(
            pair(props["rotor_to_envelope_max"]), pair(props["rotor_to_envelope_min"]), pair(props["hausdorff"]),
            unit) if job["simulate"] else "; not simulated")
        files_note = ", replaced the earlier run" if replaced else ""
        if job["filepath"]:
            files_note += ", wrote {}".format(os.path.basename(job["filepath"]))
        if made["files"]:
            files_note += ", wrote {}".format(", ".join(os.path.basename(p) for p in made["files"]))
        self.report({'INFO'}, "Double flank {} valley {} ({}, {}, {} path(s)): alpha {:+.5f} deg, delta {:+.6g} {}, "
                              "phi {:+.5f} deg, Phi {:.4g} {}, {} iterations{}; tool->rotor max F1/F2 {} min {} {}{}; "
                              "optimisation {:.2f}s, core {:.2f}s, total {:.2f}s{}".format(
                                  rotor.name, job["k_valley"], props["method"], job["variant"], len(res.paths),
                                  math.degrees(f0.x[0]), props["delta"][0], unit, math.degrees(f0.x[2]),
                                  props["Phi"][0], unit, int(f0.iterations), extra, pair(props["tool_to_rotor_max"]),
                                  pair(props["tool_to_rotor_min"]), unit, sim, res.optimize_s, res.elapsed_s,
                                  props["total_elapsed"], files_note))


classes = (FLANK_OT_plan_double_flank,)
register, unregister = bpy.utils.register_classes_factory(classes)
