# SPDX-License-Identifier: GPL-3.0-or-later
"""The Results panel's lists: the strips of a planning run with their numbers (max / min error, the share of the
flank each strip machines, its tool where the plan names tools, collision), picking a row to select its tool and
envelope, and the runs menu.  A single-flank run's rows also carry its verified covered fraction and the
uncovered ranges with their reasons (the Results panel draws them)."""
import json

import bpy
import numpy as np
from bpy.props import StringProperty

from .runs import PLAN_JSON_PROP, find_run, result_runs, store_plan, stored_plan
from .units import length_text

PREFIXES = ("flank_sf_", "flank_df_", "flank_ff_")
_ROWS_CACHE = {}
ROWS_PROP = "flank_strip_rows"      # the strips list's rows, stored by the planner's build (store_strip_rows)


def run_kind(coll):
    """('flank_sf_', 'strip') for a single-flank run, ('flank_df_', 'path') for a double-flank run,
    ('flank_ff_', 'strip') for a free-form run, else None."""
    if coll is None:
        return None
    if "flank_sf_strips" in coll or "flank_sf_tolerance" in coll:
        return "flank_sf_", "strip"
    if "flank_df_paths" in coll or "flank_df_tolerance" in coll:
        return "flank_df_", "path"
    if "flank_ff_strips" in coll:
        return "flank_ff_", "strip"
    return None


def object_prefix(ob):
    """The planner prefix of a result object ('' for other objects)."""
    for pre in PREFIXES:
        if pre + "role" in ob:
            return pre
    return ""


def strip_key(pre):
    """The custom property numbering the strips of a planner's objects: double flank numbers paths."""
    return pre + ("path" if pre == "flank_df_" else "strip")


def _arc_fraction(plan, flank, u_range):
    """Function u -> share (0..1) of the flank's profile arc length before profile parameter u."""
    prof = np.asarray(plan["rotor"]["profile"], dtype=np.float64)
    n = len(prof)
    ia, ib = (int(v) for v in plan["rotor"]["flanks"][flank])
    idx = np.arange(ia, ib + 1)
    pts = prof[idx % n]
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))]
    a, b = (float(v) for v in u_range)

    def frac(u):
        i = ia + (float(u) - a) / (b - a) * (ib - ia)
        return float(np.interp(i, idx, s) / s[-1]) if s[-1] > 0 else 0.0
    return frac


def _sf_covered(coll, plan, n):
    """Per strip of a single-flank run: (start, end) share of the flank's profile arc length where it forms the
    machined flank within the tolerance -- the verify engine's, stored by the planner (``flank_sf_strip_covered``;
    None for a strip that forms none of it); for runs made before it was stored, from the planner's junctions
    (where neighbouring strips cut equally deep) and its uncovered ranges -- and the uncovered ranges' shares."""
    stored = [float(v) for v in coll.get("flank_sf_strip_covered", [])]
    if len(stored) == 2 * n and coll.get("flank_sf_residual") is not None:
        try:
            residual = json.loads(coll["flank_sf_residual"])
            gaps = [(float(r["start"]), float(r["end"])) for r in residual]
        except (ValueError, KeyError, TypeError):
            gaps = []
        return [(a, b) if np.isfinite(a) and np.isfinite(b) else None
                for a, b in zip(stored[0::2], stored[1::2])], gaps
    try:
        summary = json.loads(coll.get("flank_sf_summary", "{}"))
        a, b = (float(v) for v in coll["flank_sf_flank_range"])
        junctions = [[float(j["u"]) for j in js] for js in summary.get("junctions", [])]
        unc = [float(v) for v in coll.get("flank_sf_uncovered", [])]
        frac = _arc_fraction(plan, int(coll["flank_sf_flank"]), (a, b))
    except (KeyError, ValueError, TypeError, IndexError):
        return [None] * n, []
    starts = [a] + [min(js) if js else None for js in junctions]
    ends = [max(js) if js else None for js in junctions] + [b]
    gaps = list(zip(unc[0::2], unc[1::2]))
    out = []
    for k in range(n):
        s0 = starts[k] if k < len(starts) else None
        s1 = ends[k] if k < len(ends) else None
        if s0 is None or s1 is None:
            out.append(None)
            continue
        for u0, u1 in gaps:                  # an end inside an uncovered range: the strip stops where it begins
            if u0 <= s0 <= u1:
                s0 = u1
            if u0 <= s1 <= u1:
                s1 = u0
        out.append((frac(s0), frac(max(s0, s1))))
    return out, [(frac(u0), frac(u1)) for u0, u1 in gaps]


def _covered_text(pre, coll, k, st, covered):
    """The 'covered' column of a strip row."""
    if pre == "flank_sf_":
        c = covered[k]
        return "{:.0f}–{:.0f} %".format(100.0 * c[0], 100.0 * c[1]) if c else "none"
    if pre == "flank_ff_":
        kinks = [float(v) for v in st.get("kink_to_next_deg", [])]
        return "kink {:.2g}°".format(max(kinks)) if kinks else "last"
    valley = int(coll.get("flank_df_valley", 0))
    fl = sorted({int(ob.get("flank_df_flank", 0)) for ob in coll.objects
                 if ob.get("flank_df_role") == "envelope" and ob.get("flank_df_path") == k
                 and all(np.isfinite(list(ob.get("flank_df_deviation_range", [np.nan]))))})
    return "flank " + ", ".join(str(2 * valley + f - 1) for f in fl) if fl else "none"


def _tool_name(plan, k):
    """The name of strip k's tool where the plan names its tools (several tools, or presets), else ''."""
    from ..flank_addon.io.plan import strip_tool

    try:
        return str(strip_tool(plan, k).get("name") or "")
    except (KeyError, IndexError, TypeError, AttributeError):
        return ""


def _sf_residual(coll):
    """covered_fraction (None for runs made before it was stored), the residual rows (shares of the flank, kind,
    length and deviations in scene units, reason) and the unit of the reasons' lengths."""
    frac = coll.get("flank_sf_covered_fraction")
    try:
        residual = json.loads(coll.get("flank_sf_residual", "[]"))
    except (ValueError, TypeError):
        residual = []
    return dict(covered_fraction=float(frac) if frac is not None else None,
                residual=residual if isinstance(residual, list) else [],
                reason_unit=str(coll.get("flank_sf_residual_length_unit", "")))


def strip_rows(coll):
    """The numbers of a run's strips list: {strip: dict(max, min (scene units), collision, covered (text))} plus
    the run's unit and scale, worked out once per run (the plan text does not change): from the rows the
    planner's build stored (:func:`store_strip_rows`), else from the run's plan."""
    kind = run_kind(coll)
    if kind is None or PLAN_JSON_PROP not in coll:
        return None
    pre, key = kind
    # every row of the list asks at every redraw: the key does not read the plan text (a free-form run's holds its
    # surface: reading 11.7 MB of it took 1-8 ms a time); a new plan comes with a new planning time
    cache_key = (coll.name, coll.as_pointer(), str(coll.get(pre + "total_elapsed", "")))
    hit = _ROWS_CACHE.get(coll.name)
    if hit is not None and hit[0] == cache_key:
        return hit[1]
    text = coll.get(PLAN_JSON_PROP)
    if not text:
        return None
    out = _stored_rows(coll, pre, text)
    if out is None:
        # the plan, kept parsed since the planner's build; parsed here only for a run stored without its rows
        plan = stored_plan(coll)
        if isinstance(plan, str):
            return None
        out = _plan_rows(coll, pre, key, plan)
    _ROWS_CACHE.clear()
    _ROWS_CACHE[coll.name] = (cache_key, out)
    return out


def _plan_rows(coll, pre, key, plan):
    strips = plan["strips"]
    scale = float(coll.get(pre + "length_scale", 1.0) or 1.0)
    covered, uncovered = _sf_covered(coll, plan, len(strips)) if pre == "flank_sf_" else (None, [])
    rows = {k: dict(max=float(st["reported_max_error"]) * scale, min=float(st["reported_min_error"]) * scale,
                    collision=bool(st.get("collision")), covered=_covered_text(pre, coll, k, st, covered),
                    tool=_tool_name(plan, k))
            for k, st in enumerate(strips)}
    out = dict(pre=pre, key=key, rows=rows, uncovered=[list(u) for u in uncovered],
               unit=str(coll.get(pre + "length_unit", "mm")), scale=scale,
               tolerance=float(coll.get(pre + "tolerance", 0.0) or 0.0))
    if pre == "flank_sf_":
        out.update(_sf_residual(coll))
    return out


def _rows_key(coll, pre, text):
    """What the stored rows belong to: the plan text's length and the run's planning time."""
    return [len(text), str(coll.get(pre + "total_elapsed", ""))]


def _stored_rows(coll, pre, text):
    """The rows :func:`store_strip_rows` stored with the run, or None (none stored, or for another plan)."""
    raw = coll.get(ROWS_PROP)
    if not isinstance(raw, str):
        return None
    try:
        stored = json.loads(raw)
        if stored["key"] != _rows_key(coll, pre, text):
            return None
        out = dict(stored["rows"])
        out["rows"] = {int(k): row for k, row in out["rows"].items()}
    except (ValueError, KeyError, TypeError, AttributeError):
        return None
    return out


def store_run_plan(coll, fields):
    """A planner's build, after its objects and properties: store its plan on the run and keep it parsed
    (``runs.store_plan``, ``fields`` from ``runs.run_plan_fields``), then the strips list's rows
    (:func:`store_strip_rows`)."""
    store_plan(coll, fields)
    store_strip_rows(coll)


def store_strip_rows(coll):
    """Store the strips list's rows on the run (a few hundred bytes a strip), so that the Results panel of a later
    session draws them without parsing the plan, whose text holds a free-form run's whole surface (11.7 MB for
    200,000 triangles: 0.3 s)."""
    info = strip_rows(coll)                  # from the plan the build keeps parsed: no parse here
    if info is None:
        return
    pre = info["pre"]
    coll[ROWS_PROP] = json.dumps(dict(key=_rows_key(coll, pre, coll[PLAN_JSON_PROP]), rows=info))


class FLANK_UL_strips(bpy.types.UIList):
    """Strips of a planning run: one row per tool (strip number, max / min error in the scene's unit, the share
    of the flank it machines, its tool's name where the plan names tools, collision)."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0, flt_flag=0):
        pre = object_prefix(item)
        k = int(item.get(strip_key(pre), -1))
        info = strip_rows(data) if hasattr(data, "get") else None
        row_info = info["rows"].get(k) if info else None
        row = layout.row(align=True)
        row.label(text="{} {}".format("Path" if pre == "flank_df_" else "Strip", k + 1), icon='MOD_SCREW')
        if row_info is None:
            errs = list(item.get(pre + "strip_errors", [])) or [float("nan"), float("nan")]
            row.label(text="{:.3g} / {:.3g}".format(errs[0], errs[1]))
            return
        unit, scale = info["unit"], info["scale"]
        row.label(text="{} / {}".format(length_text(row_info["max"], context.scene, unit, scale, signed=True),
                                        length_text(row_info["min"], context.scene, unit, scale, signed=True)))
        row.label(text=row_info["covered"])
        if row_info.get("tool"):
            row.label(text=row_info["tool"], icon='TOOL_SETTINGS')
        row.label(text="", icon='ERROR' if row_info["collision"] else 'CHECKMARK')

    def filter_items(self, context, data, propname):
        items = getattr(data, propname)
        show = getattr(self, "bitflag_filter_item", 1 << 30)      # UIList.bitflag_filter_item
        flags, order = [], []
        for ob in items:
            pre = object_prefix(ob)
            flags.append(show if pre and ob.get(pre + "role") == "tool" else 0)
            order.append(int(ob.get(strip_key(pre), 0)) if pre else 0)
        srt = sorted(range(len(order)), key=lambda i: order[i])
        neworder = [0] * len(order)
        for rank, i in enumerate(srt):
            neworder[i] = rank
        return flags, neworder


def select_strip(context, coll, index):
    """Select the tool and envelope objects of the strip (or double-flank path) shown at ``index`` of
    ``coll.objects`` and make the tool active."""
    if coll is None or not 0 <= index < len(coll.objects):
        return []
    ob = coll.objects[index]
    pre = object_prefix(ob)
    if not pre:
        return []
    key = strip_key(pre)
    k = ob.get(key)
    picked = [o for o in coll.objects if o.get(key) == k and o.get(pre + "role") in ("tool", "envelope")]
    for o in context.view_layer.objects:
        if o.select_get():
            o.select_set(False)
    for o in picked:
        if o.name in context.view_layer.objects:
            o.select_set(True)
    if ob.name in context.view_layer.objects:
        context.view_layer.objects.active = ob
    return picked


class FLANK_OT_select_run(bpy.types.Operator):
    """Show this planning run in the Results panel (selects its first strip)"""

    bl_idname = "flank.select_run"
    bl_label = "Select Run"
    bl_options = {'REGISTER', 'UNDO'}

    collection: StringProperty(name="Run", description="Result collection of the run", default="")

    def execute(self, context):
        coll = find_run(context, self.collection) if self.collection else "no run given"
        if isinstance(coll, str):
            self.report({'ERROR'}, "Select run: " + coll)
            return {'CANCELLED'}
        pre = object_prefix(next(iter(coll.objects), {})) if len(coll.objects) else ""
        tools = [(int(ob.get(strip_key(pre), 0)), i) for i, ob in enumerate(coll.objects)
                 if pre and ob.get(pre + "role") == "tool"]
        if not tools:
            self.report({'ERROR'}, "Select run: '{}' has no tool objects".format(coll.name))
            return {'CANCELLED'}
        i = min(tools)[1]
        tool = coll.objects[i]
        if tool.name not in context.view_layer.objects:
            self.report({'ERROR'}, "Select run: '{}' is not in the view layer".format(tool.name))
            return {'CANCELLED'}
        context.view_layer.objects.active = tool
        context.scene.flank_settings.results_strip_index = i
        return {'FINISHED'}


class FLANK_MT_runs(bpy.types.Menu):
    """Planning runs under "Flank Results" (newest last)"""

    bl_idname = "FLANK_MT_runs"
    bl_label = "Runs"

    def draw(self, context):
        runs = result_runs()
        if not runs:
            self.layout.label(text="No planning run yet")
        for coll in runs:
            self.layout.operator("flank.select_run", text=coll.name, icon='OUTLINER_COLLECTION').collection = coll.name


classes = (FLANK_UL_strips, FLANK_OT_select_run, FLANK_MT_runs)
register, unregister = bpy.utils.register_classes_factory(classes)
