# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.cutter_region -- cutter selection for single-flank conical milling (Bizzarri, Bo & Bartoň, Sec. 4): the
admissible cones of one flank as a point cloud beside the rotor, and whether the user's cone is one of them.

The Dupin analysis (Eq. 18), the valley bounds from the valley's custom double-flank tool (Eqs. 19-21), the
admissible region of (alpha, r1c, r2c) as a point cloud beside the rotor and a marker at the given cone (green:
admissible, red: not; a WARNING names the failing equation, its value and its limit).

Rotor: as Plan Single Flank (generated rotor rebuilt from its custom properties, or an analysed mesh).  Flank and
cone default to the Single Flank settings of the scene (sf_flank, sf_r1, sf_r2, sf_alpha; with Cone Given By =
Length the angle follows from sf_length).  Radii in scene units.  Objects in a collection under "Flank Results"
(replaced when the same rotor and flank is checked again): the cloud "Cutter Region (flank k)" with the point
attributes ``admissible`` (FLOAT 1/0), ``failed`` (INT bit mask of the failing conditions, flank_cr_conditions
order) and ``admissible_color``, and the marker "Cutter Region (flank k) Tool".  Chart (cloud's local frame):
x = alpha / (pi/4) * size, y = r1c * k, z = r2c * k with k = size / (largest sampled r2c), size = the outer
radius (flank_cr_chart_* properties).  Summary in flank_cr_* custom properties on the collection, both objects
and the rotor."""
import json
import math
import time

import bpy
import numpy as np
from bpy.props import FloatProperty, IntProperty, IntVectorProperty
from mathutils import Matrix

from .common import point_mesh, set_color_attr, set_float_attr, set_int_attr, typed
from .modal import ModalPlannerMixin
from .result_builder import RunBuilder
from .sources import AnalysisNeeded, rotor_source

PROP_PREFIX = "flank_cr_"
ADMISSIBLE_ATTR = "admissible"          # FLOAT point attribute of the cloud and the marker: 1 admissible, 0 not
FAILED_ATTR = "failed"                  # INT point attribute of the cloud: bit i set = CONDITIONS[i] fails
COLOR_ATTR = "admissible_color"         # FLOAT_COLOR point attribute: green admissible, red not
GREEN = (0.15, 0.75, 0.25, 1.0)
RED = (0.85, 0.15, 0.10, 1.0)
MAX_OTHER_POINTS = 3000                 # non-admissible cone grid points shown (an even sample of them)
CHART_OFFSET = 1.5                      # chart origin: this many outer radii beside the rotor (world +x)
MARKER_SIZE = 0.03                      # marker half size, fraction of the chart size
SF_DEFAULTS = ("flank", "r1", "r2", "alpha")   # taken from the scene's sf_* settings when not given


def _octahedron(centre, size):
    v = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float) * size + centre
    f = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    return v, f


def _cloud(cs, region, s, size):
    """The chart points: every admissible grid cone plus an even sample of the other cones (r1c < r2c) ->
    (points (chart frame), admissible flags, failed-condition bits, the chart's scale per axis)."""
    A, R1, R2 = np.meshgrid(region.alpha, region.r1c, region.r2c, indexing="ij")
    other = region.cone & ~region.mask
    n_other = int(other.sum())
    step = max(1, -(-n_other // MAX_OTHER_POINTS))
    sparse = np.zeros_like(other)
    sparse[other] = (np.arange(n_other) % step) == 0
    keep = region.mask | sparse
    bits = np.zeros(int(keep.sum()), dtype=np.int32)
    for i, name in enumerate(cs.CONDITIONS):
        bits |= region.failed[name][keep].astype(np.int32) << i
    r_axis = float(region.r2c.max()) * s                   # largest sampled r2c (scene units)
    scale = np.array([size / (0.25 * math.pi), size / r_axis, size / r_axis])
    chart = np.stack([A[keep], R1[keep] * s, R2[keep] * s], -1) * scale
    return chart, region.mask[keep].astype(np.float64), bits, scale


class _RegionError(Exception):
    """A failure of the check with the message to report as it is."""


class FLANK_OT_cutter_region(ModalPlannerMixin, bpy.types.Operator):
    """Check a cone for single-flank conical milling of one flank: the admissible cones as a point cloud beside
    the rotor and a marker at the given cone (green: admissible, red: not, with the failing condition)"""

    bl_idname = "flank.cutter_region"
    bl_label = "Check Tool"
    bl_options = {'REGISTER', 'UNDO'}
    _title = "Check tool"
    _source_title = "Cutter region"

    flank: IntProperty(name="Flank", description="Flank index of the rotor (0 .. flanks - 1); default: the "
                                                 "Single Flank setting", default=1, soft_min=0, soft_max=24)
    r1: FloatProperty(name="Tip Radius r1", description="Radius r1c of the cone's tip circle (scene units); "
                                                        "default: the Single Flank setting",
                      default=0.05, soft_min=0.0, soft_max=100.0, precision=4, unit='LENGTH')
    r2: FloatProperty(name="Top Radius r2", description="Radius r2c of the cone's top circle (scene units); "
                                                        "default: the Single Flank setting",
                      default=0.08, soft_min=0.0, soft_max=100.0, precision=4, unit='LENGTH')
    alpha: FloatProperty(name="Opening Angle", description="Opening angle alpha of the cone, 0 < alpha < 90 deg; "
                                                           "default: the Single Flank setting",
                         default=0.1001674211615598, soft_min=0.0, soft_max=1.5, subtype='ANGLE', precision=4)
    grid: IntVectorProperty(name="Grid", description="Samples of alpha, r1c, r2c of the admissible region",
                            size=3, default=(24, 40, 40), soft_min=2, soft_max=100)
    samples: IntProperty(name="Dupin Samples", description="Samples of the flank profile of the Dupin analysis "
                                                           "(8 .. 100000)", default=400, soft_min=8, soft_max=5000)
    outer_radius_mm: FloatProperty(name="Outer Radius (mm)", description="Outer radius of a rotor in units of R "
                                                                         "in mm, for the catalogue suggestion; "
                                                                         "0 = from the scene units",
                                   default=0.0, soft_min=0.0, soft_max=1000.0, precision=3)

    # ------------------------------------------------------------------ inputs
    def _scene_defaults(self, context):
        """Take flank and cone from the scene's Single Flank settings where the caller gave none."""
        st = getattr(context.scene, "flank_settings", None)
        if st is None:
            return
        unset = [name for name in SF_DEFAULTS if not self.properties.is_property_set(name)]
        for name in unset:
            if hasattr(st, "sf_" + name):
                setattr(self, name, getattr(st, "sf_" + name))
        if "alpha" in unset and getattr(st, "sf_shape", "alpha") == "length":
            r1, r2, h = typed(self.r1), typed(self.r2), typed(getattr(st, "sf_length", 0.0))
            if math.isfinite(h) and h > 0.0 and math.isfinite(r2 - r1) and r2 > r1:
                self.alpha = math.atan2(r2 - r1, h)

    def _check_inputs(self):
        r1, r2, alpha = typed(self.r1), typed(self.r2), typed(self.alpha)
        if not math.isfinite(r1) or r1 < 0.0:
            return "tool radius r1 = {} must be a finite number >= 0".format(r1)
        if not math.isfinite(r2) or not r1 < r2:
            return "tool radii r1 = {} and r2 = {}: r1 must be below r2".format(r1, r2)
        if not math.isfinite(alpha) or not 0.0 < alpha < 0.5 * math.pi:
            return "opening angle alpha = {:.6g} deg is outside (0, 90) deg".format(
                math.degrees(alpha) if math.isfinite(alpha) else alpha)
        g = [int(v) for v in self.grid]
        if min(g) < 2 or g[0] * g[1] * g[2] > 1_000_000:
            return "grid {} must have >= 2 samples per axis and at most 1e6 points".format(g)
        if not 8 <= int(self.samples) <= 100000:
            return "Dupin samples = {} is outside 8..100000".format(int(self.samples))
        o = typed(self.outer_radius_mm)
        if not math.isfinite(o) or o < 0.0:
            return "outer radius = {} mm must be a finite number >= 0 (0 = from the scene units)".format(o)
        return None

    def _catalogue_scale(self, context, src, R):
        """(the catalogue's outer radius in mm or None, its description): mm for mm rotors, units of R for
        built-ins in R."""
        if src["unit"] != "R":
            return None, "mm"
        r_mm = typed(self.outer_radius_mm)
        if not r_mm > 0.0:
            us = context.scene.unit_settings
            s = float(src["scale"])
            if us.system == 'NONE':
                r_mm = R * s                                     # no unit system: one scene unit = 1 mm
            else:
                r_mm = R * s * float(us.scale_length) * 1000.0   # scene unit = scale_length metres
        return r_mm, "R (outer radius {:.6g} mm)".format(r_mm)

    def _compute_failed(self, ex):
        if isinstance(ex, _RegionError):
            return str(ex)
        return "Cutter region failed: {}: {}".format(type(ex).__name__, ex)

    # ------------------------------------------------------------------ main thread: inputs
    def _prepare(self, context):
        """Settings, the rotor (rebuilt or analysed here), the catalogue's scale -> job, or None."""
        t0 = time.perf_counter()
        self._scene_defaults(context)
        msg = self._check_inputs()
        src = rotor_source(context.active_object, PROP_PREFIX, defer=self._defer_analysis) if msg is None else msg
        if isinstance(src, AnalysisNeeded):
            return self._read_first(src)
        if not isinstance(src, str) and not 0 <= int(self.flank) < len(src["flanks"]):
            src = "flank = {} is outside 0..{} (rotor '{}' has {} flanks)".format(
                int(self.flank), len(src["flanks"]) - 1, src["obj"].name, len(src["flanks"]))
        if isinstance(src, str):
            self.report({'ERROR'}, "Cutter region: " + src)
            return None
        r_mm, cat_unit = self._catalogue_scale(context, src, float(src["surface"].outer_radius))
        rotor = src.pop("obj")
        return dict(t0=t0, src=src, rotor_name=rotor.name, k=int(self.flank), r_mm=r_mm, cat_unit=cat_unit,
                    cone=(typed(self.alpha), typed(self.r1), typed(self.r2)), samples=int(self.samples),
                    grid=tuple(int(v) for v in self.grid))

    # ------------------------------------------------------------------ worker thread
    @staticmethod
    def _compute(job, progress):
        """The planner's Dupin analysis, valley bounds, admissible region, the verdict on the cone and the
        catalogue's suggestion -> dict."""
        from ..flank_addon.methods.double_flank.planner import custom_tool_bounds
        from ..flank_addon.progress import Cancelled, reporter
        from ..flank_addon.tooling import catalogue as cat
        from ..flank_addon.tooling import cutter_selection as cs
        from ..flank_addon.tooling.cone import ConeTool

        src, k = job["src"], job["k"]
        s, surface, flanks = float(src["scale"]), src["surface"], src["flanks"]
        report = reporter(progress)
        try:
            alpha, r1, r2 = job["cone"]
            tool = ConeTool(alpha, r1 / s, r2 / s)
            t = [time.perf_counter()]
            report(0.0, "Dupin analysis")
            dup = cs.flank_dupin(surface, flanks, k, n=job["samples"])
            t.append(time.perf_counter())
            bounds = custom_tool_bounds(surface, flanks, k // 2, progress=reporter(progress, 0.1, 0.85))
            t.append(time.perf_counter())
            report(0.85, "admissible region")
            region = cs.admissible_region(dup, bounds, n=job["grid"])
            adm = cs.is_admissible(tool, dup, bounds)
            catalogue = cat.catalogue_tools(job["r_mm"])
            sugg = cs.suggest_tool(catalogue, dup, bounds)
            t.append(time.perf_counter())
        except Cancelled:
            raise
        except ValueError as ex:
            raise _RegionError("Cutter region: {}".format(ex))
        return dict(cs=cs, tool=tool, dup=dup, bounds=bounds, region=region, adm=adm, catalogue=catalogue,
                    cat_unit=job["cat_unit"], sugg=sugg, times=t)

    # ------------------------------------------------------------------ main thread: results
    def _build(self, context, job, found):
        """The run's collection, the point cloud, the marker, the properties and the report."""
        rotor, k = bpy.data.objects.get(job["rotor_name"]), job["k"]
        if rotor is None:
            self.report({'ERROR'}, "Cutter region: the rotor '{}' was removed while checking".format(
                job["rotor_name"]))
            return {'CANCELLED'}
        src = dict(job["src"], obj=rotor)
        run = RunBuilder(context, PROP_PREFIX, "{}|{}".format(rotor.name, k),
                         "Cutter Region ({}, flank {})".format(rotor.name, k))
        made = {}
        replaced = run.build(self, "cutter region", lambda: self._fill(run, src, found, made))
        if replaced is None:
            return {'CANCELLED'}
        level, text, props = self._props(src, found, made, job["t0"])
        run.store(props, (run.collection, made["cloud"], made["marker"], rotor), clear=[rotor])
        made["cloud"][PROP_PREFIX + "role"] = "region"
        made["marker"][PROP_PREFIX + "role"] = "tool"
        run.show(made["marker"])
        self.report({level}, text + "; {} of {} grid cones admissible; suggested catalogue tool: {}{}; {:.2f}s".format(
            props["admissible_points"], props["cone_points"], props["suggested"] or "none",
            ", replaced the earlier check" if replaced else "", props["total_elapsed"]))
        return {'FINISHED'}

    def _fill(self, run, src, found, made):
        """The point cloud and the marker at the user's cone, beside the rotor."""
        s, R, k = float(src["scale"]), float(src["surface"].outer_radius), int(self.flank)
        size = R * s                                           # chart size: the outer radius (scene units)
        chart, flag, bits, scale = _cloud(found["cs"], found["region"], s, size)
        tool, ok = found["tool"], found["adm"].ok
        origin = np.array(src["obj"].matrix_world.translation, dtype=np.float64) + np.array(
            [CHART_OFFSET * size, 0.0, 0.0])
        made.update(chart=chart, scale=scale, origin=origin, size=size)
        cloud_name = "Cutter Region (flank {})".format(k)
        me = run.own_mesh(point_mesh(cloud_name, chart), cloud_name)
        set_float_attr(me, ADMISSIBLE_ATTR, flag)
        set_int_attr(me, FAILED_ATTR, bits)
        set_color_attr(me, COLOR_ATTR, np.where(flag[:, None] > 0.5, GREEN, RED))
        made["cloud"] = run.add(cloud_name, me)
        made["cloud"].matrix_world = Matrix.Translation(origin.tolist())
        mv, mf = _octahedron(np.array([tool.alpha, tool.r1c * s, tool.r2c * s]) * scale, MARKER_SIZE * size)
        marker = made["marker"] = run.add_mesh(cloud_name + " Tool", mv, mf, GREEN if ok else RED)
        set_float_attr(marker.data, ADMISSIBLE_ATTR, np.full(len(mv), 1.0 if ok else 0.0))
        set_color_attr(marker.data, COLOR_ATTR, np.tile(GREEN if ok else RED, (len(mv), 1)))
        marker.matrix_world = Matrix.Translation(origin.tolist())

    def _props(self, src, found, made, t0):
        """(report level, text, custom properties): lengths in scene units, angles in radians, a_min in
        sqrt(scene units)."""
        cs, tool, dup, bounds, region, adm, sugg = (found[k] for k in ("cs", "tool", "dup", "bounds", "region",
                                                                        "adm", "sugg"))
        rotor, s, k, t = src["obj"], float(src["scale"]), int(self.flank), found["times"]
        summ, rng, bd = region.summary(), region.ranges(), bounds.as_dict()
        for name in ("d_min", "d_max", "d_depth", "r1c_max", "r2c_max"):
            bd[name] = float(bd[name]) * s
        if adm.ok:
            level, text = 'INFO', "Cutter region ({}, flank {}): tool inside the admissible region".format(
                rotor.name, k)
        else:
            level, text = 'WARNING', "Cutter region ({}, flank {}): {}".format(rotor.name, k, adm.message)
        props = dict(
            rotor=rotor.name, source=src["kind"], flank=k, flank_range=[float(v) for v in src["flanks"][k]],
            length_unit=src["unit"], length_scale=s, tool=[float(tool.alpha), float(tool.r1c) * s, float(tool.r2c) * s],
            admissible=bool(adm.ok), message=adm.message, failures=[c.name for c in adm.failures], report=text,
            report_level=level, hyperbolic_fraction=float(dup.hyperbolic_fraction),
            a_min=float(dup.a_min) * math.sqrt(s), rho_min=float(dup.a_min) ** 2 * s, dupin_samples=int(self.samples),
            bounds=json.dumps(bd), d_min=bd["d_min"], d_max=bd["d_max"], d_depth=bd["d_depth"],
            r1_max=bd["r1c_max"], r2_max=bd["r2c_max"], d_angle=float(bounds.d_angle), c=float(bounds.c),
            grid=[int(v) for v in self.grid], admissible_points=int(summ["admissible_points"]),
            cone_points=int(summ["cone_points"]), shown_points=int(len(made["chart"])),
            fraction=float(summ["fraction"]),
            ranges=[] if rng is None else [float(rng["alpha"][0]), float(rng["alpha"][1]),
                                           float(rng["r1c"][0]) * s, float(rng["r1c"][1]) * s,
                                           float(rng["r2c"][0]) * s, float(rng["r2c"][1]) * s],
            failing=json.dumps(summ["failing"]), conditions=list(cs.CONDITIONS),
            suggested="" if sugg.entry is None else str(sugg.entry.name),
            suggested_tool=[] if sugg.tool is None else [float(sugg.tool.alpha), float(sugg.tool.r1c) * s,
                                                         float(sugg.tool.r2c) * s],
            catalogue_unit=found["cat_unit"], catalogue_admissible=len(sugg.admissible),
            catalogue_size=len(found["catalogue"]), chart_origin=[float(v) for v in made["origin"]],
            chart_size=float(made["size"]), chart_scale=[float(v) for v in made["scale"]],
            chart_mapping="local x = alpha * chart_scale[0] (alpha = pi/4 at chart_size), y = r1c * chart_scale[1], "
                          "z = r2c * chart_scale[2] (r1c, r2c in scene units; largest sampled r2c at chart_size)",
            dupin_elapsed=t[1] - t[0], bounds_elapsed=t[2] - t[1], region_elapsed=t[3] - t[2],
            total_elapsed=time.perf_counter() - t0,
        )
        return level, text, props


classes = (FLANK_OT_cutter_region,)
register, unregister = bpy.utils.register_classes_factory(classes)
