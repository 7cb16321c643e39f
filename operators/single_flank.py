# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.plan_single_flank -- single-flank conical milling (Bizzarri, Bo & Bartoň): several strips of a
truncated-cone tool on one flank of a rotor (optimised strips, global collision filter, minimum strip cover to
a tolerance).

Rotor: the active rotor made by Generate Rotor (rebuilt exactly from its custom properties) or an analysed
mesh (analysed again).  Tool lengths and tolerances are in scene units.  Objects in a new collection under
"Flank Results" (a collection of an earlier run on the same rotor and flank is replaced): per chosen strip its
envelope strip with the point attributes ``deviation`` (FLOAT, signed, scene units, > 0 material left) and
``error_color`` (shown by the shared material "Flank Attribute Colour"), and its tool (cone + shank, origin at
the tip sphere centre, local z along the axis); the error along the flank profile (the paper's Fig. 11c) as an
edge mesh in the rotor's start plane (offset along the profile normal = error x flank_sf_error_scale); with
Animate a "Tool Motion" empty with the moving tools; where the verified plan leaves part of the flank outside the
tolerance, a "Residual" mesh on the flank over those ranges (along the rotor body, just off the flank; point
attribute ``residual_range``, colours by kind).  Tool Presets plans with the shipped presets instead of the Tool
panel's cone ('auto', or names tried in turn): each strip's tool is named on its tool object and in the Results
rows.  Custom properties flank_sf_* (strips, candidates, errors, covered fraction, per strip the covered share of
the flank and the tool, uncovered ranges with their reasons, collisions, kinks, times) on the collection, the
tools and the rotor."""
import json
import math
import os
import time

import bpy
import numpy as np

from .common import count_limit_error, output_file_error, set_color_attr, set_float_attr, set_int_attr, typed
from .modal import ModalPlannerMixin
from .properties import single_flank_props
from .result_builder import COLOR_CHART, COLOR_TOOL, RunBuilder, finite_runs
from .runs import run_plan_fields
from .shapes import axis_frame, revolved_mesh
from .sources import AnalysisNeeded, own_frame, rotor_source, with_extent
from .strips import store_run_plan
from .units import mm_per_scene_unit

PROP_PREFIX = "flank_sf_"
ERROR_ATTR = "error"                   # FLOAT point attribute of the error chart (scene units, unscaled; 0 = baseline)
PARAM_ATTR = "u"                       # FLOAT point attribute of the error chart: profile parameter
CURVE_ATTR = "curve"                   # FLOAT point attribute of the error chart: 1 error curve, 0 baseline (profile)
CHART_COLOR_ATTR = "error_color"
ENVELOPE_SAMPLES = 60                  # characteristic points per strip (multi_strip.envelope_strip's n_s)
CHART_FRACTION = 0.1                   # largest |error| drawn as this fraction of the outer radius
TOOL_SEGMENTS = 48
COLOR_BASELINE = (0.35, 0.35, 0.35, 1.0)
MAX_STORED_COLLISIONS = 50
RESIDUAL_ATTR = "residual_range"       # INT point attribute of the residual mesh: index of its uncovered range
RESIDUAL_OFFSET = 0.004                # the residual mesh stands this many outer radii off the flank
RESIDUAL_RINGS = 24                    # rings of the residual mesh along the rotor body
COLOR_RESIDUAL = (0.85, 0.15, 0.75, 1.0)
COLOR_UNREACHED = (0.85, 0.15, 0.75, 1.0)   # no tool within verify's search range: magenta

__all__ = ["FLANK_OT_plan_single_flank"]


def _ranges_text(ranges):
    return ", ".join("[{:.4g}, {:.4g}]".format(a, b) for a, b in ranges)


def _check_inputs(op):
    """Checks that need no rotor -> error message (str) or None."""
    r1, r2 = typed(op.r1), typed(op.r2)
    if not math.isfinite(r1) or r1 < 0.0:
        return "tool radius r1 = {} must be a finite number >= 0".format(r1)
    if not math.isfinite(r2) or not r1 < r2:
        return "tool radii r1 = {} and r2 = {}: r1 must be below r2".format(r1, r2)
    if op.shape == "alpha":
        a = typed(op.alpha)
        if not math.isfinite(a) or not 0.0 < a < typed(0.5 * math.pi):   # 90 deg in single precision, typed
            return "opening angle alpha = {:.6g} deg is outside (0, 90) deg".format(
                math.degrees(a) if math.isfinite(a) else a)
    elif not (math.isfinite(typed(op.length)) and typed(op.length) > 0.0):
        return "cone length h = {} must be > 0".format(typed(op.length))
    for label, v in (("shank radius", op.shank_radius), ("shank length", op.shank_length)):
        if not math.isfinite(typed(v)) or typed(v) < 0.0:
            return "{} = {} must be a finite number >= 0".format(label, typed(v))
    tol, over = typed(op.tolerance), typed(op.overcut_tolerance)
    if not math.isfinite(tol) or tol <= 0.0:
        return "tolerance = {} must be > 0 (scene units)".format(tol)
    if not math.isfinite(over) or over < 0.0:
        return "overcut tolerance = {} must be >= 0 (scene units; 0 = 1e-6 x outer radius)".format(over)
    msg = (count_limit_error("seeds", op.seeds, 1, 400)
           or count_limit_error("G1 extra strips", op.g1_extra_strips, 0, 50)
           or count_limit_error("rounds", op.rounds, 1, 50)
           or count_limit_error("envelope rings", op.envelope_rings, 2, 4096))
    if msg is None and op.animate and int(op.frame_end) <= int(op.frame_start):
        msg = "end frame {} must be after the start frame {}".format(int(op.frame_end), int(op.frame_start))
    return msg


def _check_sizes(op, rotor_name, R, s):
    """Tolerances and tool sizes against the rotor -> error message or None (sizes beyond these mean a tool that
    cannot enter any valley, and sweeps that run for minutes)."""
    limit = 0.5 * R * s
    for label, v in (("tolerance", typed(op.tolerance)), ("overcut tolerance", typed(op.overcut_tolerance))):
        if not v < limit:
            return "{} = {} must be below half the outer radius of '{}', {:.6g} (scene units)".format(
                label, v, rotor_name, limit)
    for label, v, k in (("tool radius r2", op.r2, 2.0), ("tool radius r1", op.r1, 2.0),
                        ("cone length h", op.length if op.shape == "length" else 0.0, 20.0),
                        ("shank radius", op.shank_radius, 10.0), ("shank length", op.shank_length, 100.0)):
        if not typed(v) <= k * R * s:
            return "{} = {:g} exceeds the limit {:g} x the outer radius of '{}' = {:.6g} (scene units)".format(
                label, typed(v), k, rotor_name, k * R * s)
    return None


def _target_flank(op, src):
    """(flank index, the point in the rotor frame or None) -> or an error message."""
    from ..flank_addon.methods.single_flank import planner as ms

    flanks = src["flanks"]
    if not op.use_point:
        k = int(op.flank)
        if not 0 <= k < len(flanks):
            return "flank = {} is outside 0..{} (rotor '{}' has {} flanks)".format(
                k, len(flanks) - 1, src["obj"].name, len(flanks))
        return k, None
    p_local = np.array([typed(v) for v in op.point], dtype=np.float64)
    if not np.isfinite(p_local).all():
        return "point {} is not finite".format(p_local.tolist())
    mw = np.array(src["obj"].matrix_world, dtype=np.float64)
    p_h = np.linalg.solve(src["display"], np.r_[mw[:3, :3] @ p_local + mw[:3, 3], 1.0])
    point = p_h[:3] / p_h[3]
    surface, s = src["surface"], float(src["scale"])
    d, limit = surface.section_distance(point), surface.PICK_LIMIT * surface.outer_radius
    if not d <= limit:
        return ("point {} lies {:.4g} from rotor '{}', above the limit {:.4g} ({:g} of its outer radius; scene "
                "units)".format([round(float(v), 6) for v in p_local], d * s, src["obj"].name, limit * s,
                                surface.PICK_LIMIT))
    try:
        return int(ms.flank_of_point(src["surface"], flanks, point)), point
    except ValueError as ex:
        return str(ex)


def _cone_tool(op, s):
    """The ConeTool in rotor units -> tool, or an error message."""
    from ..flank_addon.tooling.cone import ConeTool

    r1, r2 = typed(op.r1) / s, typed(op.r2) / s
    shank = dict(shank_radius=typed(op.shank_radius) / s, shank_length=typed(op.shank_length) / s)
    try:
        if op.shape == "alpha":
            return ConeTool(typed(op.alpha), r1, r2, **shank)
        return ConeTool.from_length(r1, r2, typed(op.length) / s, **shank)
    except ValueError as ex:
        return str(ex)


def _preset_tools(op, mm_per_unit):
    """The Tool Presets setting -> (None, None) for the Tool panel's cone, ([(name, ConeTool in rotor units)],
    'auto' | 'order'), or an error message (str)."""
    from ..flank_addon.tooling.presets import load_presets, presets_by_name

    text = str(op.tools).strip()
    if not text:
        return None, None
    if not (math.isfinite(mm_per_unit) and mm_per_unit > 0.0):
        return "tool presets are in mm: {:g} mm per rotor unit gives no tool".format(mm_per_unit)
    auto = text.lower() == "auto"
    try:
        presets = load_presets() if auto else presets_by_name(text)
        return [(p.name, p.tool(mm_per_unit)) for p in presets], ("auto" if auto else "order")
    except ValueError as ex:
        return "tool presets {!r}: {}".format(text, ex)


def _error_chart(res, surface, u_range, z0):
    """The error along the flank profile (Fig. 11c of the paper) in the rotor's start plane: chains (baseline =
    the profile, curves = profile + normal x error x scale) and their point values."""
    from ..flank_addon.geometry.screw import screw_motion

    u_dev = np.asarray(res.deviation[0], dtype=np.float64)
    e_dev = np.asarray(res.deviation[1], dtype=np.float64)
    fin = np.isfinite(e_dev)
    R = float(surface.outer_radius)
    e_max = float(np.abs(e_dev[fin]).max()) if fin.any() else 0.0
    err_scale = CHART_FRACTION * R / e_max if e_max > 1e-12 * R else 1.0
    prof, t_start = surface.profile, z0 / float(surface.v0)

    def plane_points(xy):
        return screw_motion(np.c_[xy, np.zeros(len(xy))], t_start, surface.v0, surface.hand)

    u_base = np.linspace(u_range[0], u_range[1], max(64, len(u_dev)))
    chains = [(plane_points(prof.eval(u_base)), False)]
    err_v, u_v, curve_v = [np.zeros(len(u_base))], [u_base], [np.zeros(len(u_base))]
    for a, b in finite_runs(fin):
        if b - a < 2:
            continue
        uu, ee = u_dev[a:b], e_dev[a:b]
        chains.append((plane_points(prof.eval(uu) + prof.outward_normal(uu) * (err_scale * ee)[:, None]), False))
        err_v.append(ee)
        u_v.append(uu)
        curve_v.append(np.ones(b - a))
    return dict(chains=chains, error=np.concatenate(err_v), u=np.concatenate(u_v), curve=np.concatenate(curve_v),
                scale=float(err_scale), max_abs=e_max, u_dev=u_dev, e_dev=e_dev, finite=fin)


def _coverage(res, job):
    """What the verified plan covers (per strip: first, last share of the flank and its share) and leaves (the
    residual rows and the mesh marking them on the flank, rotor frame)."""
    from ..flank_addon.report.flank_coverage import residual_patches, residual_rows, residual_u_ranges, strip_shares

    plan, k, surface = res.plan, job["k_flank"], job["surface"]
    shares = strip_shares(plan, res.verify, k, plan["tolerance"], plan["overcut_tolerance"])
    rows = residual_rows(plan, k)
    spans = residual_u_ranges(rows, surface.profile.period, len(plan["rotor"]["profile"]), job["u_range"])
    mesh = residual_patches(surface, spans, (job["z0"], job["z1"]), RESIDUAL_OFFSET * job["R"], RESIDUAL_RINGS)
    return dict(shares=shares, rows=rows, spans=spans, mesh=mesh)


def _residual_colors(rows, which, s, tol_in):
    """Per residual vertex: verify's colour of its range's worst deviation (material left or overcut), magenta
    where no tool comes near."""
    from ..flank_addon.simulation.verify import deviation_colors

    per = []
    for r in rows:
        d = r["max_deviation"] if r["kind"] == "material" else r["min_deviation"]
        per.append(COLOR_UNREACHED if d is None or r["kind"] == "unreached" else
                   tuple(deviation_colors(np.array([float(d) * s]), tol_in)[0]))
    return np.asarray(per, dtype=np.float64)[np.asarray(which, dtype=np.int64)]


def _add_residual(run, job, out, tag):
    """The mesh marking the uncovered ranges on the flank (none when the plan covers it)."""
    cov = out["coverage"]
    verts, faces, which = cov["mesh"]
    if not len(faces):
        return None
    ob = run.add_mesh(tag + "Residual", verts, faces, COLOR_RESIDUAL, "residual", None, job["display"])
    me = ob.data
    set_int_attr(me, RESIDUAL_ATTR, which)
    set_color_attr(me, CHART_COLOR_ATTR, _residual_colors(cov["rows"], which, job["s"], job["tol_in"]))
    run.color_by_attribute(me)
    me.update()
    ob[PROP_PREFIX + "residual_u"] = [float(v) for sp in cov["spans"] if sp is not None for v in sp]
    return ob


def _fill_run(run, job, out, rotor, made):
    """Tools, envelope strips, the error chart, the motion and the plan file of the run."""
    from ..flank_addon.io.plan import write_plan

    res, s, display, tag = out["res"], job["s"], job["display"], "SF F{} ".format(job["k_flank"])
    rows = res.plan["strips"]
    made["tools"] = []
    for k, (cand, (ev, ef, ed), T) in enumerate(zip(res.strips, out["envs"], out["frames"])):
        ob = run.add_mesh("{}Tool {}".format(tag, k + 1), *out["tool_meshes"][k], COLOR_TOOL, "tool", k, display @ T)
        if out["strip_tools"][k]:
            ob[PROP_PREFIX + "tool_name"] = out["strip_tools"][k]
        ob[PROP_PREFIX + "tip"] = [float(v) for v in cand.pose.tip]          # rotor frame, rotor units
        ob[PROP_PREFIX + "axis"] = [float(v) for v in cand.pose.axis]
        ob[PROP_PREFIX + "params"] = [float(v) for v in np.ravel(cand.params)]
        ob[PROP_PREFIX + "strip_errors"] = [float(rows[k]["reported_max_error"]) * s,
                                            float(rows[k]["reported_min_error"]) * s]
        ob[PROP_PREFIX + "seed_u"] = float(cand.seed.u)
        made["tools"].append(ob)
        if len(ev) == 0 or len(ef) == 0:
            continue
        dev = np.asarray(ed, dtype=np.float64) * s
        eo = run.add_strip("{}Strip {}".format(tag, k + 1), ev, ef, dev, job["tol_in"], display, k)
        eo[PROP_PREFIX + "deviation_range"] = [float(dev.min()), float(dev.max())]
        eo[PROP_PREFIX + "sweep"] = [float(v) for v in out["sweeps"][k]]
        eo[PROP_PREFIX + "envelope_samples"] = ENVELOPE_SAMPLES
        eo[PROP_PREFIX + "envelope_rings"] = job["n_t"]
    _add_error_chart(run, out["chart"], s, job["tol_in"], display, tag)
    _add_residual(run, job, out, tag)
    if job["animate"]:
        surface, R = job["surface"], job["R"]
        v0, eps = float(surface.v0), (1 if surface.hand > 0 else -1)
        made["motion"] = [float((job["z0"] - R) / v0), float((job["z1"] + R) / v0)]
        motion = run.add_motion(tag + "Tool Motion", rotor, tuple(zip(job["frames"], made["motion"])), v0, eps,
                                0.25 * R, frame=own_frame(job["src"]))
        for k, tool in enumerate(made["tools"]):
            run.add_moving("{}Tool {} (moving)".format(tag, k + 1), motion, tool.data, out["frames"][k], index=k)
    if job["filepath"]:
        run.write(job["filepath"], lambda p: write_plan(p, res.plan))


def _add_error_chart(run, chart, s, tol_in, display, tag):
    from ..flank_addon.simulation.verify import deviation_colors

    me = run.edges(tag + "Error along profile", chart["chains"])
    co = run.add(tag + "Error along profile", me, COLOR_CHART, "error_chart", matrix=display)
    errs = chart["error"] * s
    set_float_attr(me, ERROR_ATTR, errs)
    set_float_attr(me, PARAM_ATTR, chart["u"])
    set_float_attr(me, CURVE_ATTR, chart["curve"])
    cols = deviation_colors(errs, tol_in)
    cols[chart["curve"] == 0] = COLOR_BASELINE
    set_color_attr(me, CHART_COLOR_ATTR, cols)
    run.color_by_attribute(me)
    co[PROP_PREFIX + "error_scale"] = chart["scale"]
    co[PROP_PREFIX + "max_abs_error"] = chart["max_abs"] * s


def _coverage_props(out, job, res):
    """The run's coverage properties: the verified covered fraction, per strip the covered shares of the flank
    (first, last; NaN where it machines none of it) and its share, the tools (JSON) and the residual (JSON:
    per uncovered range its shares of the flank, kind, length and deviations in scene units, reason)."""
    s, cov = job["s"], out["coverage"]
    nan = float("nan")
    shares = cov["shares"]
    residual = [dict(start=r["start"], end=r["end"], kind=r["kind"], length=r["length"] * s,
                     max_deviation=None if r["max_deviation"] is None else float(r["max_deviation"]) * s,
                     min_deviation=None if r["min_deviation"] is None else float(r["min_deviation"]) * s,
                     u_range=r["u_range"], reason=r["reason"], proven=r["proven"]) for r in cov["rows"]]
    return dict(covered_fraction=float(res.covered_fraction),
                strip_covered=[float(v) for sh in shares for v in ((sh[0], sh[1]) if sh else (nan, nan))],
                strip_share=[float(sh[2]) if sh else 0.0 for sh in shares],
                strip_tools=json.dumps(out["strip_tools"]),
                tools=json.dumps([{k: v for k, v in row.items() if k in ("name", "strips", "seeds", "candidates",
                                                                         "collisions_excluded")}
                                  for row in res.tools]),
                residual=json.dumps(residual), residual_length_unit=str(job["unit"]))


class FLANK_OT_plan_single_flank(ModalPlannerMixin, bpy.types.Operator):
    """Plan single-flank conical milling of one flank of the active rotor: strips of a tapered end mill that
    cover the flank to the tolerance, shown as tools and error-coloured strips"""

    bl_idname = "flank.plan_single_flank"
    bl_label = "Plan Single Flank"
    bl_options = {'REGISTER', 'UNDO'}
    _title = "Single flank"

    __annotations__ = single_flank_props()

    # ------------------------------------------------------------------ main thread: inputs
    def _prepare(self, context):
        """Properties, rotor and tool -> job dict, or None (error reported)."""
        t0 = time.perf_counter()
        msg = _check_inputs(self) or output_file_error(self.filepath, "plan file")
        src = rotor_source(context.active_object, PROP_PREFIX, defer=self._defer_analysis) if msg is None else msg
        if isinstance(src, AnalysisNeeded):
            return self._read_first(src)
        if isinstance(src, str):
            self.report({'ERROR'}, "Single flank: " + src)
            return None
        s, R = float(src["scale"]), float(src["surface"].outer_radius)      # s: scene units per rotor unit
        target = _check_sizes(self, src["obj"].name, R, s) or _target_flank(self, src)
        tool = _cone_tool(self, s) if not isinstance(target, str) else target
        presets = _preset_tools(self, typed(mm_per_scene_unit(context.scene) * s)) if not isinstance(tool, str) else tool
        if isinstance(presets, str):
            self.report({'ERROR'}, "Single flank: " + presets)
            return None
        k_flank, point_rotor = target
        tol_in, over_in = typed(self.tolerance), typed(self.overcut_tolerance)
        z0, z1 = (float(v) for v in src["z_range"])
        return dict(t0=t0, src=src, rotor_name=src["obj"].name, surface=src["surface"], flanks=src["flanks"],
                    s=s, R=R, display=src["display"], point_rotor=point_rotor, k_flank=k_flank,
                    u_range=tuple(float(v) for v in src["flanks"][k_flank]), tool=tool, tools=presets[0],
                    select=presets[1] or "order", tol_in=tol_in,
                    tol=tol_in / s, over=over_in / s if over_in > 0.0 else None, z0=z0, z1=z1,
                    n_t=int(self.envelope_rings), seeds=int(self.seeds), objective=str(self.objective),
                    mode=str(self.mode), rounds=int(self.rounds), collisions=bool(self.collisions),
                    g1=bool(self.g1), g1_extra_strips=int(self.g1_extra_strips), to_world=src["to_world"].tolist(),
                    unit=src["unit"], extent=src.get("extent"), animate=bool(self.animate),
                    frames=(int(self.frame_start), int(self.frame_end)),
                    filepath=bpy.path.abspath(self.filepath) if self.filepath else "")

    # ------------------------------------------------------------------ worker thread
    @staticmethod
    def _compute(job, progress):
        """The planner, envelope strips, tool frames, tool mesh and error chart (no Blender data)."""
        from ..flank_addon.io.plan import strip_tool
        from ..flank_addon.methods.single_flank import planner as ms
        from ..flank_addon.tooling.meridian import cone_tool_outline

        surface, k_flank, u_range, tool, tools = job["surface"], job["k_flank"], job["u_range"], job["tool"], \
            job["tools"]
        names = [name for name, _ in tools] if tools else None
        # collisions against the infinite rotor: a pass screws the whole body past the tool, so the finite
        # rotor's slab over the pass holds the tool entirely; z_range only places the strips
        res = ms.plan_single_flank(surface, job["flanks"], k_flank, tools if tools else tool, job["tol"],
                                   overcut_tolerance=job["over"], n_seeds=job["seeds"], objective=job["objective"],
                                   mode=job["mode"], max_rounds=job["rounds"], to_world=job["to_world"],
                                   length_unit=job["unit"], check_collisions=job["collisions"], g1=job["g1"],
                                   g1_extra_strips=job["g1_extra_strips"], progress=progress, tool_names=names,
                                   select=job["select"], bound_radius=min(t.r1s for _, t in tools) if tools else None)
        with_extent(res.plan, job["extent"])         # the finite rotor, for whole-rotor machine programs
        if not res.strips:
            raise ValueError(res.no_strip_message(k_flank))
        t_env = time.perf_counter()
        envs, sweeps = [], []
        for c in res.strips:
            zc = 0.5 * float(c.pose.tip[2] + c.pose.top[2])   # centre the swept strip on the rotor body
            sweeps.append((job["z0"] - zc, job["z1"] - zc))
            envs.append(ms.envelope_strip(c, surface, u_range, sweeps[-1], ENVELOPE_SAMPLES, job["n_t"]))
        env_elapsed = time.perf_counter() - t_env
        frames = [axis_frame(c.pose.tip, c.pose.top)[0] for c in res.strips]
        # each strip's tool (plans with several tools name it per strip): its index in the tools tried
        cones = [t for _, t in tools] if tools else [tool]
        which = [names.index(strip_tool(res.plan, k).get("name")) if names else 0 for k in range(len(res.strips))]
        meshes = {i: revolved_mesh(cone_tool_outline(cones[i]), TOOL_SEGMENTS) for i in sorted(set(which))}
        return dict(res=res, envs=envs, sweeps=sweeps, env_elapsed=env_elapsed, frames=frames,
                    tool_meshes=[meshes[i] for i in which], strip_tools=[names[i] if names else "" for i in which],
                    first_tool=cones[which[0]], chart=_error_chart(res, surface, u_range, job["z0"]),
                    coverage=_coverage(res, job), **run_plan_fields(res.plan))   # encoded off the main thread

    # ------------------------------------------------------------------ main thread: results
    def _build(self, context, job, out):
        """The run's collection, objects, attributes and properties from a finished plan."""
        rotor = bpy.data.objects.get(job["rotor_name"])
        if rotor is None:
            self.report({'ERROR'}, "Single flank: the rotor '{}' was removed while planning".format(job["rotor_name"]))
            return {'CANCELLED'}
        k = job["k_flank"]
        run = RunBuilder(context, PROP_PREFIX, "{}|{}".format(rotor.name, k),
                         "Single Flank ({}, flank {})".format(rotor.name, k), owner=("rotor", rotor.name))
        made = {}
        replaced = run.build(self, "single-flank results", lambda: _fill_run(run, job, out, rotor, made))
        if replaced is None:
            return {'CANCELLED'}
        from ..flank_addon.methods.single_flank.planner import merge_ranges

        res = out["res"]
        props = self._props(job, out, rotor, made)
        run.store(props, [run.collection, rotor] + made["tools"], clear=[rotor])
        # the run's plan (flank-plan/1) travels with its collection: exports, reports, posts and the strips list
        # read it from there
        store_run_plan(run.collection, out)
        run.show(made["tools"][0])
        unc = "covered {:.1f} %{}".format(100.0 * res.covered_fraction, "" if res.complete else ", uncovered " +
                                           _ranges_text(merge_ranges(res.uncovered)))
        self.report({'INFO'}, "Single flank {} flank {} ({}): {} strips of {} candidates ({} colliding excluded), "
                              "error {:.4g} .. {:.4g} scene units (tolerance {:.4g}), {}, largest kink {:.3g} deg, "
                              "{} round(s){}{}; core {:.2f}s, total {:.2f}s".format(
                                  rotor.name, k, props["method"], len(res.strips), len(res.candidates),
                                  len(res.collisions), props["min_error"], props["max_error"], job["tol_in"], unc,
                                  props["kink_max_deg"], len(res.rounds),
                                  ", replaced the earlier run" if replaced else "",
                                  ", wrote {}".format(os.path.basename(job["filepath"])) if job["filepath"] else "",
                                  props["elapsed"], props["total_elapsed"]))
        return {'FINISHED'}

    def _props(self, job, out, rotor, made):
        """The run's custom properties (lengths in scene units, angles in radians, flank ranges as profile
        parameters)."""
        from ..flank_addon.methods.single_flank.planner import merge_ranges

        res, s, tool, chart = out["res"], job["s"], out["first_tool"], out["chart"]
        summary, rows = res.plan.get("summary", {}), res.plan["strips"]
        kinks = [float(j["kink_deg"]) for js in res.junctions for j in js]
        timings = {k: float(v) for k, v in res.timings.items()}
        timings["envelopes"] = float(out["env_elapsed"])
        uncovered = merge_ranges(res.uncovered)
        e_dev, fin = chart["e_dev"], chart["finite"]

        def fl(v):
            return float(v) if v is not None else float("nan")

        props = dict(
            rotor=rotor.name, source=job["src"]["kind"], flank=int(job["k_flank"]), flank_range=list(job["u_range"]),
            flank_from_point=bool(self.use_point), method=str(res.plan.get("method", "")),
            length_unit=job["unit"], length_scale=s,
            tool_alpha=float(tool.alpha), tool_r1=float(tool.r1c) * s, tool_r2=float(tool.r2c) * s,
            tool_h=float(tool.h) * s, tool_shank_radius=float(tool.shank_radius) * s,
            tool_shank_length=float(tool.shank_length) * s,
            tolerance=float(job["tol_in"]), overcut_tolerance=float(res.plan["overcut_tolerance"]) * s,
            seeds=job["seeds"], objective=job["objective"], mode=job["mode"], rounds=job["rounds"],
            g1=job["g1"], g1_extra_strips=job["g1_extra_strips"],
            rounds_run=len(res.rounds), collisions_checked=job["collisions"],
            strips=len(res.strips), candidates=len(res.candidates), collisions=len(res.collisions),
            collision_u=[float(c["u"]) for c in res.collisions], complete=bool(res.complete),
            max_error=fl(summary.get("max_error")) * s, min_error=fl(summary.get("min_error")) * s,
            strip_max_error=[float(st["reported_max_error"]) * s for st in rows],
            strip_min_error=[float(st["reported_min_error"]) * s for st in rows],
            profile_max_error=float(np.nanmax(e_dev)) * s if fin.any() else float("nan"),
            profile_min_error=float(np.nanmin(e_dev)) * s if fin.any() else float("nan"),
            uncovered=[float(v) for g in uncovered for v in g], uncovered_count=len(uncovered),
            **_coverage_props(out, job, res),
            kinks_deg=kinks, kink_max_deg=max(kinks) if kinks else 0.0, error_scale=chart["scale"],
            elapsed=float(timings.get("total", float("nan"))), total_elapsed=float(time.perf_counter() - job["t0"]),
            summary=json.dumps(dict(summary, timings=timings, rounds=res.rounds,
                                    collisions=res.collisions[:MAX_STORED_COLLISIONS],
                                    junctions=res.junctions), default=str),
        )
        props.update({name + "_elapsed": timings[name] for name in ("candidates", "collision", "cover", "junctions",
                                                                    "verify", "envelopes") if name in timings})
        if job["point_rotor"] is not None:
            props.update(point=[float(v) for v in self.point], point_rotor=[float(v) for v in job["point_rotor"]])
        if "motion" in made:
            props.update(frames=list(job["frames"]), motion=made["motion"])
        if job["filepath"]:
            props["plan"] = job["filepath"]
        return props


classes = (FLANK_OT_plan_single_flank,)
register, unregister = bpy.utils.register_classes_factory(classes)
