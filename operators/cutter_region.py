# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.cutter_region -- s000 §4: the admissible cones of one flank as a point cloud, and whether the user's cone
is one of them."""
import bpy
from bpy.props import FloatProperty, IntProperty

from .common import new_mesh_from_arrays, remove_ids, results_parent, rotor_source, set_color_attr, set_float_attr

PROP_PREFIX = "flank_cr_"
ADMISSIBLE_ATTR = "admissible"          # FLOAT point attribute of the region cloud: 1 admissible, 0 not
COLOR_ATTR = "admissible_color"
GREEN = (0.15, 0.75, 0.25, 1.0)
RED = (0.85, 0.15, 0.10, 1.0)


def _decimal(v):
    return float("{:.7g}".format(v))


def _octahedron(np, centre, size):
    v = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float) * size + centre
    f = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    return v, f


class FLANK_OT_cutter_region(bpy.types.Operator):
    """s000 §4 cutter selection on one flank of the active rotor: the Dupin analysis, the valley bounds from the
    custom double-flank tool, the admissible region in (alpha, r1c, r2c) as a point cloud beside the rotor
    (point attribute ``admissible``, colour ``admissible_color``; chart axes x = alpha / alpha_max,
    y = r1c / r1_max, z = r2c / r2_max times the chart size) and a marker at the given cone, green when it is
    admissible.  A cone outside the region is reported as a WARNING naming the failing condition, its value
    and its limit.  Custom properties flank_cr_* on the collection and the cloud."""

    bl_idname = "flank.cutter_region"
    bl_label = "Check Tool (Admissible Cones)"
    bl_options = {'REGISTER', 'UNDO'}

    flank: IntProperty(name="Flank", default=1, min=-1000, max=1000, description="Flank index")
    r1: FloatProperty(name="r1", default=0.05, description="Tip circle radius (scene units)")
    r2: FloatProperty(name="r2", default=0.08, description="Top circle radius (scene units)")
    alpha: FloatProperty(name="Opening Angle", default=0.1001674, subtype='ANGLE',
                         description="Half opening angle of the cone")
    grid: IntProperty(name="Grid", default=20, min=-1000, max=1000,
                      description="Samples per axis of the (alpha, r1c, r2c) grid")

    def execute(self, context):
        import json
        import math

        import numpy as np

        r1, r2, alpha, g = _decimal(self.r1), _decimal(self.r2), _decimal(self.alpha), int(self.grid)
        if not (math.isfinite(r1) and math.isfinite(r2) and 0.0 <= r1 < r2):
            self.report({'ERROR'}, "Cutter region: tool radii r1 = {} and r2 = {} must satisfy 0 <= r1 < r2".format(
                r1, r2))
            return {'CANCELLED'}
        if not (math.isfinite(alpha) and 0.0 < alpha < 0.5 * math.pi):
            self.report({'ERROR'}, "Cutter region: opening angle {} rad is outside (0, pi/2)".format(alpha))
            return {'CANCELLED'}
        if not 2 <= g <= 60:
            self.report({'ERROR'}, "Cutter region: grid = {} is outside 2..60".format(g))
            return {'CANCELLED'}
        src = rotor_source(bpy, context, np, PROP_PREFIX)
        if isinstance(src, str):
            self.report({'ERROR'}, "Cutter region: " + src)
            return {'CANCELLED'}
        flanks = src["flanks"]
        k = int(self.flank)
        if not 0 <= k < len(flanks):
            self.report({'ERROR'}, "Cutter region: flank {} is outside 0..{}".format(k, len(flanks) - 1))
            return {'CANCELLED'}
        from ..flank_addon import cutter_selection as cs
        from ..flank_addon.cone import ConeTool

        s = float(src["scale"])
        try:
            tool = ConeTool(alpha, r1 / s, r2 / s)
            dup = cs.flank_dupin(src["surface"], flanks, k)
            bounds = cs.custom_tool_bounds(src["surface"], flanks, k // 2)
            if not dup.hyperbolic.any():
                raise ValueError("flank {} has no hyperbolic points: Eq. (18) does not bound the cone".format(k))
            region = cs.admissible_region(dup, bounds, n=(g, g, g))
            adm = cs.is_admissible(tool, dup, bounds)
            cat = cs.catalogue_tools(None if src["unit"] == "mm" else 50.0)
            sugg = cs.suggest_tool(cat, dup, bounds)
        except ValueError as ex:
            self.report({'ERROR'}, "Cutter region: {}".format(ex))
            return {'CANCELLED'}

        # the cloud: every admissible grid point, every third of the other cone points
        A, R1, R2 = np.meshgrid(region.alpha, region.r1c, region.r2c, indexing="ij")
        other = region.cone & ~region.mask
        sparse = np.zeros_like(other)
        sparse[other] = (np.arange(int(other.sum())) % 3) == 0
        keep = region.mask | sparse
        pts = np.stack([A[keep], R1[keep], R2[keep]], -1)
        flag = region.mask[keep].astype(np.float64)
        lim = np.array([region.alpha.max(), region.r1c.max(), region.r2c.max()])
        R = float(src["surface"].outer_radius) * s
        size = R                                          # chart edge length in scene units
        chart = pts / lim * size
        marker_at = np.array([tool.alpha, tool.r1c, tool.r2c]) / lim * size
        origin = np.array(src["display"])[:3, 3] + np.array([1.5 * R, 0.0, 0.0])

        name = "Cutter Region ({}, flank {})".format(src["obj"].name, k)
        objs, meshes, colls = [], [], []
        parent = created = None
        try:
            parent, created = results_parent(bpy, context)
            old = bpy.data.collections.get(name)
            coll = bpy.data.collections.new(name)
            colls.append(coll)
            me = bpy.data.meshes.new(name)
            meshes.append(me)
            me.vertices.add(len(chart))
            me.vertices.foreach_set("co", np.ascontiguousarray(chart, dtype=np.float32).ravel())
            me.update()
            set_float_attr(np, me, ADMISSIBLE_ATTR, flag)
            set_color_attr(np, me, COLOR_ATTR, np.where(flag[:, None] > 0.5, GREEN, RED))
            cloud = bpy.data.objects.new(name, me)
            objs.append(cloud)
            cloud.location = origin.tolist()
            mv, mf = _octahedron(np, marker_at, 0.03 * size)
            mme = new_mesh_from_arrays(bpy, np, name + " tool", mv, mf)
            meshes.append(mme)
            set_color_attr(np, mme, COLOR_ATTR, np.tile(GREEN if adm.ok else RED, (len(mv), 1)))
            marker = bpy.data.objects.new(name + " tool", mme)
            objs.append(marker)
            marker.location = origin.tolist()
            for ob in objs:
                coll.objects.link(ob)
            parent.children.link(coll)
        except Exception as ex:
            remove_ids(bpy, objs, meshes, colls + ([parent] if created else []))
            self.report({'ERROR'}, "Cutter region: could not build the result: {}: {}".format(type(ex).__name__, ex))
            return {'CANCELLED'}
        if old is not None:                               # replace the previous run on this flank
            remove_ids(bpy, list(old.objects), [o.data for o in old.objects if o.type == 'MESH'], [old])
            coll.name = name
            cloud.name, marker.name = name, name + " tool"

        summ = region.summary()
        props = {
            "rotor": src["obj"].name, "flank": k, "admissible": bool(adm.ok), "message": adm.message,
            "hyperbolic_fraction": float(dup.hyperbolic_fraction), "a_min": float(region.a_min),
            "bounds": json.dumps(bounds.as_dict()), "ranges": json.dumps(summ["ranges"]),
            "admissible_points": int(summ["admissible_points"]), "cone_points": int(summ["cone_points"]),
            "grid": g, "chart_size": size, "chart_limits": [float(v) for v in lim],
            "tool": [tool.alpha, tool.r1c, tool.r2c], "length_unit": src["unit"],
            "suggested": "" if sugg.tool is None else json.dumps(sugg.tool.as_dict()),
        }
        for target in (coll, cloud):
            for key, val in props.items():
                target[PROP_PREFIX + key] = val
        if adm.ok:
            self.report({'INFO'}, "Cutter region: tool inside the admissible region ({} of {} grid cones "
                                  "admissible)".format(summ["admissible_points"], summ["cone_points"]))
        else:
            self.report({'WARNING'}, "Cutter region: tool {}".format(adm.message))
        return {'FINISHED'}
