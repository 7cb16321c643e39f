# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.cutter_region -- s000 §4: the admissible cones of one flank as a point cloud beside the rotor, and
whether the user's cone is one of them."""
import bpy
from bpy.props import FloatProperty, IntProperty, IntVectorProperty

from .common import new_mesh_from_arrays, remove_ids, results_parent, rotor_source, replace_run, select_only, \
    set_color_attr, set_float_attr

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


def _decimal(v):
    """Blender float properties are single precision: the decimal value that was typed (7 digits)."""
    return float("{:.7g}".format(v))


def _octahedron(np, centre, size):
    v = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float) * size + centre
    f = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    return v, f


class FLANK_OT_cutter_region(bpy.types.Operator):
    """s000 §4 cutter selection on one flank of the active rotor: Dupin analysis (Eq. 18), the valley bounds
    from its custom double-flank tool (Eqs. 19-21), the admissible region of (alpha, r1c, r2c) as a point cloud
    beside the rotor and a marker at the given cone (green: admissible, red: not; a WARNING names the failing
    equation, its value and its limit).

    Rotor: as Plan Single Flank (generated rotor rebuilt from its custom properties, or an analysed mesh).
    Flank and cone default to the Single Flank settings of the scene (sf_flank, sf_r1, sf_r2, sf_alpha; with
    Cone Given By = Length the angle follows from sf_length).  Radii in scene units.  Objects in a collection
    under "Flank Results" (replaced when the same rotor and flank is checked again): the cloud "Cutter Region
    (flank k)" with the point attributes ``admissible`` (FLOAT 1/0), ``failed`` (INT bit mask of the failing
    conditions, flank_cr_conditions order) and ``admissible_color``, and the marker "Cutter Region (flank k)
    Tool".  Chart (cloud's local frame): x = alpha / (pi/4) * size, y = r1c * k, z = r2c * k with
    k = size / (largest sampled r2c), size = the outer radius (flank_cr_chart_* properties).  Summary in
    flank_cr_* custom properties on the collection, both objects and the rotor."""

    bl_idname = "flank.cutter_region"
    bl_label = "Check Tool"
    bl_options = {'REGISTER', 'UNDO'}

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

    def _scene_defaults(self, context, math):
        """Take flank and cone from the scene's Single Flank settings where the caller gave none."""
        st = getattr(context.scene, "flank_settings", None)
        if st is None:
            return
        unset = [name for name in SF_DEFAULTS if not self.properties.is_property_set(name)]
        for name in unset:
            if hasattr(st, "sf_" + name):
                setattr(self, name, getattr(st, "sf_" + name))
        if "alpha" in unset and getattr(st, "sf_shape", "alpha") == "length":
            r1, r2, h = _decimal(self.r1), _decimal(self.r2), _decimal(getattr(st, "sf_length", 0.0))
            if math.isfinite(h) and h > 0.0 and math.isfinite(r2 - r1) and r2 > r1:
                self.alpha = math.atan2(r2 - r1, h)

    def _check_inputs(self, math):
        r1, r2, alpha = _decimal(self.r1), _decimal(self.r2), _decimal(self.alpha)
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
        o = _decimal(self.outer_radius_mm)
        if not math.isfinite(o) or o < 0.0:
            return "outer radius = {} mm must be a finite number >= 0 (0 = from the scene units)".format(o)
        return None

    def _catalogue(self, context, cat, src, R):
        """(catalogue in rotor units, description): mm for mm rotors, units of R for built-ins in R."""
        if src["unit"] != "R":
            return cat.catalogue_tools(None), "mm"
        r_mm = _decimal(self.outer_radius_mm)
        if not r_mm > 0.0:
            us = context.scene.unit_settings
            s = float(src["scale"])
            if us.system == 'NONE':
                r_mm = R * s                                     # no unit system: one scene unit = 1 mm
            else:
                r_mm = R * s * float(us.scale_length) * 1000.0   # scene unit = scale_length metres
        return cat.catalogue_tools(r_mm), "R (outer radius {:.6g} mm)".format(r_mm)

    # ------------------------------------------------------------------ run

    def execute(self, context):
        import json
        import math
        import time

        import numpy as np
        from mathutils import Matrix

        t0 = time.perf_counter()
        self._scene_defaults(context, math)
        msg = self._check_inputs(math)
        if msg is not None:
            self.report({'ERROR'}, "Cutter region: " + msg)
            return {'CANCELLED'}
        src = rotor_source(bpy, context, np, PROP_PREFIX)
        if isinstance(src, str):
            self.report({'ERROR'}, "Cutter region: " + src)
            return {'CANCELLED'}
        rotor_obj, surface, flanks = src["obj"], src["surface"], src["flanks"]
        s = float(src["scale"])                       # scene units per rotor unit
        R = float(surface.outer_radius)
        k = int(self.flank)
        if not 0 <= k < len(flanks):
            self.report({'ERROR'}, "Cutter region: flank = {} is outside 0..{} (rotor '{}' has {} flanks)".format(
                k, len(flanks) - 1, rotor_obj.name, len(flanks)))
            return {'CANCELLED'}

        from ..flank_addon.methods.double_flank.planner import custom_tool_bounds
        from ..flank_addon.tooling import catalogue as cat
        from ..flank_addon.tooling import cutter_selection as cs
        from ..flank_addon.tooling.cone import ConeTool

        grid = tuple(int(v) for v in self.grid)
        try:
            tool = ConeTool(_decimal(self.alpha), _decimal(self.r1) / s, _decimal(self.r2) / s)
            t_core = time.perf_counter()
            dup = cs.flank_dupin(surface, flanks, k, n=int(self.samples))
            t_dupin = time.perf_counter()
            bounds = custom_tool_bounds(surface, flanks, k // 2)
            t_bounds = time.perf_counter()
            region = cs.admissible_region(dup, bounds, n=grid)
            adm = cs.is_admissible(tool, dup, bounds)
            catalogue, cat_unit = self._catalogue(context, cat, src, R)
            sugg = cs.suggest_tool(catalogue, dup, bounds)
            t_region = time.perf_counter()
        except ValueError as ex:
            self.report({'ERROR'}, "Cutter region: {}".format(ex))
            return {'CANCELLED'}
        except Exception as ex:
            self.report({'ERROR'}, "Cutter region failed: {}: {}".format(type(ex).__name__, ex))
            return {'CANCELLED'}

        # ---- the cloud: every admissible grid cone plus an even sample of the other cones (r1c < r2c)
        A, R1, R2 = np.meshgrid(region.alpha, region.r1c, region.r2c, indexing="ij")
        other = region.cone & ~region.mask
        n_other = int(other.sum())
        step = max(1, -(-n_other // MAX_OTHER_POINTS))
        sparse = np.zeros_like(other)
        sparse[other] = (np.arange(n_other) % step) == 0
        keep = region.mask | sparse
        flag = region.mask[keep].astype(np.float64)
        bits = np.zeros(int(keep.sum()), dtype=np.int32)
        for i, name in enumerate(cs.CONDITIONS):
            bits |= region.failed[name][keep].astype(np.int32) << i
        size = R * s                                           # chart size: the outer radius (scene units)
        r_axis = float(region.r2c.max()) * s                   # largest sampled r2c (scene units)
        scale = np.array([size / (0.25 * math.pi), size / r_axis, size / r_axis])
        chart = np.stack([A[keep], R1[keep] * s, R2[keep] * s], -1) * scale
        marker_at = np.array([tool.alpha, tool.r1c * s, tool.r2c * s]) * scale
        origin = np.array(rotor_obj.matrix_world.translation, dtype=np.float64) + np.array(
            [CHART_OFFSET * size, 0.0, 0.0])

        key = "{}|{}".format(rotor_obj.name, k)
        coll_name = "Cutter Region ({}, flank {})".format(rotor_obj.name, k)
        cloud_name = "Cutter Region (flank {})".format(k)
        marker_name = cloud_name + " Tool"
        objects, meshes, colls, names = [], [], [], []
        parent, parent_created = None, False
        try:
            parent, parent_created = results_parent(bpy, context)
            coll = bpy.data.collections.new(coll_name + " new")
            colls.append(coll)
            parent.children.link(coll)

            me = bpy.data.meshes.new(cloud_name)
            meshes.append(me)
            me.vertices.add(len(chart))
            me.vertices.foreach_set("co", np.ascontiguousarray(chart, dtype=np.float32).ravel())
            me.update()
            set_float_attr(np, me, ADMISSIBLE_ATTR, flag)
            fa = me.attributes.new(FAILED_ATTR, 'INT', 'POINT')
            fa.data.foreach_set("value", bits)
            set_color_attr(np, me, COLOR_ATTR, np.where(flag[:, None] > 0.5, GREEN, RED))
            cloud = bpy.data.objects.new(cloud_name, me)
            objects.append(cloud)
            coll.objects.link(cloud)
            cloud.matrix_world = Matrix.Translation(origin.tolist())

            mv, mf = _octahedron(np, marker_at, MARKER_SIZE * size)
            mme = new_mesh_from_arrays(bpy, np, marker_name, mv, mf)
            meshes.append(mme)
            set_float_attr(np, mme, ADMISSIBLE_ATTR, np.full(len(mv), 1.0 if adm.ok else 0.0))
            set_color_attr(np, mme, COLOR_ATTR, np.tile(GREEN if adm.ok else RED, (len(mv), 1)))
            marker = bpy.data.objects.new(marker_name, mme)
            objects.append(marker)
            coll.objects.link(marker)
            marker.color = GREEN if adm.ok else RED
            marker.matrix_world = Matrix.Translation(origin.tolist())
            names += [(me, cloud_name), (cloud, cloud_name), (mme, marker_name), (marker, marker_name)]

            # replace the collection of an earlier check of this rotor and flank (only once this one is built)
            replaced = replace_run(bpy, parent, coll, PROP_PREFIX + "key", key, coll_name, names)
        except Exception as ex:
            remove_ids(bpy, objects, meshes, colls + ([parent] if parent_created else []))
            self.report({'ERROR'}, "Could not build the cutter region: {}: {}".format(type(ex).__name__, ex))
            return {'CANCELLED'}

        # ---- custom properties: lengths in scene units, angles in radians, a_min in sqrt(scene units)
        summ = region.summary()
        rng = region.ranges()
        sq = math.sqrt(s)
        bd = bounds.as_dict()
        for name in ("d_min", "d_max", "d_depth", "r1c_max", "r2c_max"):
            bd[name] = float(bd[name]) * s
        sugg_tool = sugg.tool
        if adm.ok:
            level, text = 'INFO', "Cutter region ({}, flank {}): tool inside the admissible region".format(
                rotor_obj.name, k)
        else:
            level, text = 'WARNING', "Cutter region ({}, flank {}): {}".format(rotor_obj.name, k, adm.message)
        props = dict(
            rotor=rotor_obj.name, source=src["kind"], flank=k, flank_range=[float(v) for v in flanks[k]],
            length_unit=src["unit"], length_scale=s,
            tool=[float(tool.alpha), float(tool.r1c) * s, float(tool.r2c) * s],
            admissible=bool(adm.ok), message=adm.message,
            failures=[c.name for c in adm.failures], report=text, report_level=level,
            hyperbolic_fraction=float(dup.hyperbolic_fraction),
            a_min=float(dup.a_min) * sq, rho_min=float(dup.a_min) ** 2 * s,
            dupin_samples=int(self.samples),
            bounds=json.dumps(bd), d_min=bd["d_min"], d_max=bd["d_max"], d_depth=bd["d_depth"],
            r1_max=bd["r1c_max"], r2_max=bd["r2c_max"], d_angle=float(bounds.d_angle), c=float(bounds.c),
            grid=list(grid), admissible_points=int(summ["admissible_points"]), cone_points=int(summ["cone_points"]),
            shown_points=int(len(chart)), fraction=float(summ["fraction"]),
            ranges=[] if rng is None else [float(rng["alpha"][0]), float(rng["alpha"][1]),
                                           float(rng["r1c"][0]) * s, float(rng["r1c"][1]) * s,
                                           float(rng["r2c"][0]) * s, float(rng["r2c"][1]) * s],
            failing=json.dumps(summ["failing"]), conditions=list(cs.CONDITIONS),
            suggested="" if sugg.entry is None else str(sugg.entry.name),
            suggested_tool=[] if sugg_tool is None else [float(sugg_tool.alpha), float(sugg_tool.r1c) * s,
                                                         float(sugg_tool.r2c) * s],
            catalogue_unit=cat_unit, catalogue_admissible=len(sugg.admissible), catalogue_size=len(catalogue),
            chart_origin=[float(v) for v in origin], chart_size=float(size), chart_scale=[float(v) for v in scale],
            chart_mapping="local x = alpha * chart_scale[0] (alpha = pi/4 at chart_size), y = r1c * chart_scale[1], "
                          "z = r2c * chart_scale[2] (r1c, r2c in scene units; largest sampled r2c at chart_size)",
            dupin_elapsed=t_dupin - t_core, bounds_elapsed=t_bounds - t_dupin, region_elapsed=t_region - t_bounds,
            total_elapsed=time.perf_counter() - t0,
        )
        for key_ in [kk for kk in rotor_obj.keys() if kk.startswith(PROP_PREFIX)]:
            del rotor_obj[key_]
        for target in (coll, cloud, marker, rotor_obj):
            for name, value in props.items():
                target[PROP_PREFIX + name] = value
        cloud[PROP_PREFIX + "role"] = "region"
        marker[PROP_PREFIX + "role"] = "tool"
        select_only(context, marker)

        extra = "; {} of {} grid cones admissible; suggested catalogue tool: {}{}; {:.2f}s".format(
            props["admissible_points"], props["cone_points"], props["suggested"] or "none",
            ", replaced the earlier check" if replaced else "", props["total_elapsed"])
        self.report({level}, text + extra)
        return {'FINISHED'}
