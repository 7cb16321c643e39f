# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.plan_freeform -- free-form G1 multi-strip flank milling (Rajain et al. 2023) of any triangle mesh (or
its selected faces) with a conical tool along a guiding direction.

Tool: spheres of radius r1 .. r2 with centres L apart (scene units); guiding direction in world axes at Point,
or a vector attribute.  The plan is made in the mesh object's local (model) coordinates, so a plan file lists
the points of the model that was loaded; the object may be moved, rotated and uniformly scaled.  Objects in a
new collection under "Flank Results" (an earlier run on the same object is replaced): per strip its envelope
with the point attributes ``deviation`` (FLOAT, signed exact distance to the mesh in scene units, > 0 material
left, NaN where the tool hangs over the surface's border) and ``error_color`` (shown by the shared material
"Flank Attribute Colour"), and the tool at its first ruling; per shared boundary a polyline with the
``kink_deg`` point and edge attributes (angle between the neighbouring strips' normals); the guiding curves.
The plan (flank-plan/1, surface kind "mesh", model coordinates) is stored on the collection."""
import json
import math
import time

import bpy
import numpy as np

from ..flank_addon.geometry.rows import used_vertices
from .common import count_limit_error, output_file_error, set_float_attr, typed
from .guiding import COLOR_GUIDING, check_tool, guiding_inputs, planning_surface, size_check
from .modal import ModalPlannerMixin
from .properties import freeform_props
from .result_builder import COLOR_TOOL, RunBuilder
from .runs import run_plan_fields
from .shapes import axis_frame, revolved_mesh
from .strips import store_run_plan
from .units import length_text

PROP_PREFIX = "flank_ff_"
KINK_ATTR = "kink_deg"                  # FLOAT point and edge attribute of the boundary curves (degrees)
TOOL_SEGMENTS = 48
COLOR_BOUNDARY = (0.95, 0.35, 0.85, 1.0)
MAX_WEIGHT = 1.0e6                      # the objective's weights: the panel offers 0..100, and only their ratios
                                        # matter, so a larger one (infinity typed is FLT_MAX) is a typing error

__all__ = ["FLANK_OT_plan_freeform"]


def quad_triangles(quads, valid_vertices):
    """Triangles (two per quad) of the quads whose four corners are valid."""
    q = np.asarray(quads, dtype=np.int64)
    q = q[valid_vertices[q].all(axis=1)]
    return np.vstack([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])


def _check_inputs(op):
    msg = check_tool(op)
    if msg is not None:
        return msg
    for label, v in (("w1 (rigidity)", op.w_rigid), ("w2 (approximation)", op.w_approx),
                     ("w3 (G1)", op.w_g1), ("w4 (proximity)", op.w_proximity), ("w5 (fairness)", op.w_fair)):
        v = typed(v)
        if not math.isfinite(v) or v < 0.0:
            return "weight {} = {} must be a finite number >= 0".format(label, v)
        if v > MAX_WEIGHT:
            return "weight {} = {:g} exceeds the limit {:g}".format(label, v, MAX_WEIGHT)
    if not typed(op.w_approx) > 0.0:              # the planner's own rule, said before its worker starts
        return "weight w2 (approximation) = 0 must be > 0: without it nothing holds the tool to the surface"
    tol = typed(op.tolerance)
    if not math.isfinite(tol) or tol <= 0.0:
        return "tolerance = {} must be > 0 (scene units)".format(tol)
    return (count_limit_error("samples per ruling", op.samples, 2, 200)
            or count_limit_error("rulings per strip", op.columns, 2, 2000)
            or count_limit_error("max evaluations", op.max_evaluations, 1, 10000)
            or count_limit_error("envelope samples", op.envelope_samples, 2, 200))


def _check_surface(op, src):
    msg = size_check(op, src)
    if msg is not None:
        return msg
    V = src["V"]
    half_diag = 0.5 * float(np.linalg.norm(V.max(axis=0) - V.min(axis=0))) * src["scale"]
    if not typed(op.tolerance) < half_diag:
        return "tolerance = {:g} must be below half the surface's diagonal, {:.6g} (scene units)".format(
            typed(op.tolerance), half_diag)
    return None


def _tool_meshes(g1, plan):
    """Per strip: (tool mesh (verts, faces) in its frame, frame at its first ruling)."""
    from ..flank_addon.tooling.meridian import sphere_cone_outline

    tool, tools = plan["tool"], []
    for st in plan["strips"]:
        a, b = g1.strip_rulings(st)
        r1e, r2e = float(st["radii"][0]), float(st["radii"][-1])
        Le = float(np.linalg.norm(b[0] - a[0]))
        below = max(float(tool["length"]) - Le, 0.0)
        rh = sphere_cone_outline(r1e, r2e, Le, below, float(tool["shank_radius"]), float(tool["shank_length"]))
        tools.append((revolved_mesh(rh, TOOL_SEGMENTS), axis_frame(a[0], b[0])[0]))
    return tools


def _fill_run(run, job, out, made):
    """Tools, envelope strips, boundary kink curves, guiding curves and the plan file of the run."""
    from ..flank_addon.io.plan import write_plan

    plan, s, to_world = out["plan"], job["s"], job["to_world"]
    made["tools"] = []
    for k, (env, ((tv, tf), T), st) in enumerate(zip(out["envs"], out["tools"], plan["strips"])):
        ob = run.add_mesh("FF Tool {}".format(k + 1), tv, tf, COLOR_TOOL, "tool", k, to_world @ T)
        ob[PROP_PREFIX + "strip_errors"] = [float(st["reported_max_error"]) * s,
                                            float(st["reported_min_error"]) * s]
        ob[PROP_PREFIX + "collision"] = bool(st["collision"])
        made["tools"].append(ob)
        V = np.asarray(env["vertices"], dtype=np.float64)
        tris = quad_triangles(env["faces"], np.isfinite(V).all(axis=1))
        if len(tris) == 0:
            continue
        used, F = used_vertices(tris, len(V))
        dev = np.asarray(env["deviation"], dtype=np.float64)[used] * s
        eo = run.add_strip("FF Strip {}".format(k + 1), V[used], F, dev, job["tol_in"],
                           to_world, k)
        fin = dev[np.isfinite(dev)]
        eo[PROP_PREFIX + "deviation_range"] = [float(fin.min()), float(fin.max())] if len(fin) else []
        eo[PROP_PREFIX + "overhanging_points"] = int(len(dev) - len(fin))
    for k, kk in enumerate(out["kinks"]):
        pts = np.asarray(kk["points"], dtype=np.float64)
        if len(pts) < 2:
            continue
        label = "FF Boundary {}|{}".format(k + 1, k + 2)
        bo = run.add(label, run.edges(label, [(pts, False)]), COLOR_BOUNDARY, "boundary", k, to_world)
        kd = np.asarray(kk["kink_deg"], dtype=np.float64)
        set_float_attr(bo.data, KINK_ATTR, kd)
        set_float_attr(bo.data, KINK_ATTR + "_edge", np.maximum(kd[:-1], kd[1:]), domain='EDGE')
        bo[PROP_PREFIX + "max_kink_deg"] = float(kd.max())
        bo[PROP_PREFIX + "mean_kink_deg"] = float(kd.mean())
    chains = [(np.asarray(pl, dtype=np.float64), False) for c in plan["guiding"]["curves"] for pl in c
              if len(pl) >= 2]
    if chains:
        run.add("FF Guiding Curves", run.edges("FF Guiding Curves", chains), COLOR_GUIDING, "guiding",
                matrix=to_world)
    if job["filepath"]:
        run.write(job["filepath"], lambda p: write_plan(p, plan))


class FLANK_OT_plan_freeform(ModalPlannerMixin, bpy.types.Operator):
    """Plan free-form G1 flank milling of the active mesh (or its selected faces): strips of a conical tool along
    a guiding direction, tangent-continuous between neighbours, shown as tools, error-coloured strips and kink
    curves"""

    bl_idname = "flank.plan_freeform"
    bl_label = "Plan Free-form (G1)"
    bl_options = {'REGISTER', 'UNDO'}
    _title = "Free-form"

    __annotations__ = freeform_props()

    # ------------------------------------------------------------------ main thread: inputs
    def _prepare(self, context):
        t0 = time.perf_counter()
        msg = _check_inputs(self) or output_file_error(self.filepath, "plan file")
        src = planning_surface(context, self) if msg is None else msg
        msg = src if isinstance(src, str) else _check_surface(self, src)
        gi = guiding_inputs(self, src) if msg is None else msg
        if isinstance(gi, str):
            self.report({'ERROR'}, "Free-form: " + gi)
            return None
        s, spacing = src["scale"], typed(self.spacing)
        core = dict(r1=typed(self.r1) / s, r2=typed(self.r2) / s, L=typed(self.length) / s,
                    spacing=spacing / s if spacing > 0.0 else None,
                    weights=[typed(v) for v in (self.w_rigid, self.w_approx, self.w_g1, self.w_proximity,
                                                self.w_fair)],
                    n_ruling_samples=int(self.samples), n_columns=int(self.columns),
                    engagement=typed(self.engagement), optimize_tool=tuple(sorted(self.optimize_tool)),
                    max_nfev=int(self.max_evaluations),
                    shank_radius=typed(self.shank_radius) / s if typed(self.shank_radius) > 0.0 else None,
                    shank_length=typed(self.shank_length) / s, slide=bool(self.slide),
                    flip_normals=bool(self.flip_normals), length_unit="mm", **gi)
        return dict(t0=t0, obj_name=src["obj"].name, V=src["V"], F=src["F"], to_world=src["to_world"], s=s,
                    core=core, tol_in=typed(self.tolerance), n_s=int(self.envelope_samples),
                    filepath=bpy.path.abspath(self.filepath) if self.filepath else "")

    # ------------------------------------------------------------------ worker thread
    @staticmethod
    def _compute(job, progress):
        """The planner, envelopes, kinks and tool meshes (no Blender data)."""
        from ..flank_addon.methods.freeform_g1 import planner as g1
        from ..flank_addon.progress import reporter, substage

        report = reporter(progress)
        plan = g1.plan_freeform(job["V"], job["F"], progress=substage(report, 0.0, 0.9), **job["core"])
        report(0.9, "envelopes")
        mesh = g1.plan_mesh(plan)
        envs = g1.freeform_envelopes(plan, n_s=job["n_s"], mesh=mesh)
        report(0.96, "kink angles")
        kinks = g1.freeform_kinks(plan, mesh=mesh)
        tools = _tool_meshes(g1, plan)
        report(1.0, "done")
        fields = run_plan_fields(plan)        # off the main thread
        # the build reads the run's kept plan (the same numbers): the planner's own, with its surface, is freed
        # here rather than on the main thread after the build (a million objects for 200,000 triangles)
        return dict(fields, plan=fields["plan_checked"], envs=envs, kinks=kinks, tools=tools)

    # ------------------------------------------------------------------ main thread: results
    def _build(self, context, job, out):
        src_obj = bpy.data.objects.get(job["obj_name"])
        if src_obj is None:
            self.report({'ERROR'}, "Free-form: the surface '{}' was removed while planning".format(job["obj_name"]))
            return {'CANCELLED'}
        plan, s = out["plan"], job["s"]
        summary = plan["summary"]
        run = RunBuilder(context, PROP_PREFIX, src_obj.name, "Free-form ({})".format(src_obj.name),
                         owner=("source", src_obj.name))
        made = {}
        replaced = run.build(self, "free-form results", lambda: _fill_run(run, job, out, made))
        if replaced is None:
            return {'CANCELLED'}
        run.store(dict(source=src_obj.name, strips=len(plan["strips"]), max_error=float(summary["max_error"]) * s,
                       min_error=float(summary["min_error"]) * s, max_kink_deg=float(summary["max_kink_deg"]),
                       mean_kink_deg=float(summary["mean_kink_deg"]),
                       colliding_rulings=int(summary["colliding_rulings"]),
                       overhanging_samples=int(summary["overhanging_samples"]), tolerance=job["tol_in"],
                       to_world=[float(v) for v in job["to_world"].ravel()],       # model -> world at planning
                       length_scale=float(s), length_unit=plan["length_unit"], elapsed=float(summary["elapsed_s"]),
                       total_elapsed=time.perf_counter() - job["t0"], summary=json.dumps(dict(summary))),
                  [run.collection])
        store_run_plan(run.collection, out)   # read by exports, reports, posts and the strips list
        run.show(made["tools"][0] if made["tools"] else None)

        def L(v):
            return length_text(v, context.scene, signed=True)
        self.report({'INFO'}, "Free-form on '{}': {} strips, error {} .. {}, kink max {:.3g} deg (mean {:.3g}), "
                              "{} colliding rulings, {:.1f} s{}".format(
                                  src_obj.name, len(plan["strips"]), L(summary["min_error"] * s),
                                  L(summary["max_error"] * s), summary["max_kink_deg"], summary["mean_kink_deg"],
                                  summary["colliding_rulings"], summary["elapsed_s"],
                                  ", replaced the earlier run" if replaced else ""))
        return {'FINISHED'}


classes = (FLANK_OT_plan_freeform,)
register, unregister = bpy.utils.register_classes_factory(classes)
