# SPDX-License-Identifier: GPL-3.0-or-later
"""Whole-flank coverage in Blender, for test_blender_coverage.py: flank.plan_single_flank with two shipped tool
presets in turn (Tool Presets = "Tapered 5deg D6 L20,Tapered 1deg D1 L10") on flank 1 of the asymmetric female of
outer radius 50 mm (a metric scene in mm), moved and turned; the same plan by the core in this process; the run's
coverage properties, the strips list's rows (each names its strip's tool) and their draw into a real layout, the
Results panel's covered fraction and uncovered ranges with reasons, the residual mesh on the flank (measured
against the profile here), the verify engine's ownership on the stored plan; bad preset names create nothing."""
import json
import math
import time

import driver
from scenario_sidebar import _UI, _Rec

TOOLS = "Tapered 5deg D6 L20,Tapered 1deg D1 L10"
R = 50.0
RUN_KW = dict(flank=1, tools=TOOLS, tolerance=0.025, seeds=4, rounds=1, envelope_rings=8, animate=False)


def _labels(calls):
    return [c[1] for c in calls if c[0] == "label"]


def _residual_facts(np, bpy, ob, rotor_obj, surface, flank_range):
    """The residual mesh in the rotor frame, each vertex measured against a dense sampling of the flank's
    profile after screwing it into z = 0: its distance from the profile and the parameter of its foot."""
    co = driver._mesh_co(np, ob)
    world = driver._world(np, ob, co)
    rw = np.array(rotor_obj.matrix_world, dtype=np.float64)
    local = (world - rw[:3, 3]) @ np.linalg.inv(rw[:3, :3]).T          # rotor frame (the rotor has no scale)
    v0, hand = float(surface.v0), float(surface.hand)
    t = local[:, 2] / v0
    c, s = np.cos(-hand * t), np.sin(-hand * t)                       # S_{-t}: back into the plane z = 0
    xy = np.c_[c * local[:, 0] - s * local[:, 1], s * local[:, 0] + c * local[:, 1]]
    a, b = flank_range
    uu = np.linspace(a, b, 40001)
    P = surface.profile.eval(uu)
    d = np.empty(len(xy))
    foot = np.empty(len(xy))
    for i0 in range(0, len(xy), 256):
        dd = np.linalg.norm(xy[i0:i0 + 256, None, :] - P[None, :, :], axis=2)
        j = dd.argmin(axis=1)
        d[i0:i0 + 256] = dd[np.arange(len(j)), j]
        foot[i0:i0 + 256] = uu[j]
    attr = ob.data.attributes.get("residual_range")
    which = np.empty(len(co), dtype=np.int32)
    attr.data.foreach_get("value", which)
    cols = driver._color_attr(np, ob.data, "error_color")
    per = {}
    for k in sorted(set(which.tolist())):
        m = which == k
        per[str(k)] = dict(u=[float(foot[m].min()), float(foot[m].max())], vertices=int(m.sum()),
                           colors=np.unique(np.round(cols[m], 6), axis=0).tolist())
    return dict(vertices=len(co), faces=len(ob.data.polygons), distance=[float(d.min()), float(d.max())],
                z=[float(local[:, 2].min()), float(local[:, 2].max())], ranges=per,
                attr=[attr.data_type, attr.domain], active_color=getattr(ob.data.color_attributes.active_color,
                                                                          "name", None),
                material=[m.name for m in ob.data.materials if m is not None], props=driver._obj_props(ob))


def _verify_shares(np, plan, flank, tol, over):
    """Per strip: first and last share of the flank's arc length where the verify engine makes it the owner of
    the machined flank within [-over, tol] (test-side arithmetic on the engine's output), and its share."""
    verify = driver._core("simulation.verify")
    ver = verify.verify_plan(plan, tolerance=over)
    prof = np.asarray(plan["rotor"]["profile"], float)
    n = len(prof)
    ia, ib = plan["rotor"]["flanks"][flank]
    idx = np.arange(ia, ib + 1) % n
    seg = np.linalg.norm(np.diff(prof[idx], axis=0), axis=1)
    arc = np.r_[0.0, np.cumsum(seg)]
    w = 0.5 * (np.r_[seg, 0.0] + np.r_[0.0, seg])
    dev = {int(i): d for i, _, _, d in ver["deviation_profile"]}
    pos = {int(i): j for j, i in enumerate(idx)}
    out = []
    for st in ver["strips"]:
        js = sorted(pos[i] for a, b in st["covered_ranges"] for i in range(a, b + 1)
                    if i in pos and dev.get(i) is not None and -over <= dev[i] <= tol)
        out.append([arc[js[0]] / arc[-1], arc[js[-1]] / arc[-1], float(w[js].sum() / w.sum())] if js else None)
    return out


def scenario(bpy, res, args):
    import numpy as np

    strips_mod = __import__(driver.MODULE + ".operators.strips", fromlist=["strip_rows"])
    ms, rotors = driver._core("methods.single_flank.planner"), driver._core("geometry.rotors")
    presets, plan_mod = driver._core("tooling.presets"), driver._core("io.plan")
    scene = bpy.context.scene
    scene.unit_settings.system, scene.unit_settings.scale_length = 'METRIC', 0.001       # a scene unit is 1 mm
    ret, err = driver._run_op(bpy.ops.flank.generate_rotor, kind="asymmetric", part="female", scale=R,
                              resolution=360, axial=24)
    rotor_obj = bpy.context.active_object
    rotor_obj.location = (12.0, -7.0, 3.0)
    rotor_obj.rotation_euler = (0.3, -0.2, 0.5)
    bpy.context.view_layer.update()

    # ---------------------------------------------------------------- bad preset names: nothing is created
    res["bad"] = {}
    for name, text in (("unknown", "No Such Tool"), ("twice", "Tapered 5deg D6 L20, Tapered 5deg D6 L20")):
        s0 = driver._snapshot4(bpy)
        ret, err = driver._run_op(bpy.ops.flank.plan_single_flank, **dict(RUN_KW, tools=text))
        s1 = driver._snapshot4(bpy)
        res["bad"][name] = dict(result=ret, error=err, new=[s1[i] - s0[i] for i in range(4)])
        bpy.context.view_layer.objects.active = rotor_obj

    # ---------------------------------------------------------------- the run
    t0 = time.perf_counter()
    s0 = driver._snapshot4(bpy)
    ret, err = driver._run_op(bpy.ops.flank.plan_single_flank, **RUN_KW)
    s1 = driver._snapshot4(bpy)
    run = dict(result=ret, error=err, seconds=time.perf_counter() - t0, new=[s1[i] - s0[i] for i in range(4)])
    res["run"] = run
    if ret is None:
        return
    tool_ob = bpy.context.active_object
    coll = tool_ob.users_collection[0]
    run["collection"] = coll.name
    run["props"] = {k: driver._obj_props(coll)[k] for k in driver._obj_props(coll) if k.startswith("flank_sf_")
                    and k not in ("flank_sf_summary",)}
    roles = {}
    for ob in coll.objects:
        roles.setdefault(ob.get("flank_sf_role", "?"), []).append(ob.name)
    run["roles"] = {k: sorted(v) for k, v in roles.items()}
    run["tool_names"] = {str(ob["flank_sf_strip"]): ob.get("flank_sf_tool_name") for ob in coll.objects
                         if ob.get("flank_sf_role") == "tool"}
    plan = json.loads(coll[__import__(driver.MODULE + ".operators.runs", fromlist=["PLAN_JSON_PROP"]).PLAN_JSON_PROP])
    run["plan_strip_tools"] = [plan_mod.strip_tool(plan, k).get("name") for k in range(len(plan["strips"]))]
    run["plan_summary"] = dict(covered_fraction=plan["summary"].get("covered_fraction"),
                               uncovered=plan["summary"].get("uncovered"))

    # ---------------------------------------------------------------- the core's plan of the same inputs
    rotor = rotors.builtin_rotor("asymmetric", "female", scale=float(rotor_obj["flank_scale"]),
                                 lead=float(rotor_obj["flank_lead"]), length=float(rotor_obj["flank_length"]),
                                 handedness=str(rotor_obj["flank_handedness"]))
    surface, flanks = rotor.surface(), rotor.flanks
    tools = [(p.name, p.tool(1.0)) for p in presets.presets_by_name(TOOLS)]
    core = ms.plan_single_flank(surface, flanks, 1, tools, 0.025, n_seeds=4, max_rounds=1, length_unit="mm",
                                tool_names=[n for n, _ in tools], bound_radius=min(t.r1s for _, t in tools))
    res["core"] = dict(strips=len(core.strips), covered_fraction=core.covered_fraction,
                       strip_tools=[plan_mod.strip_tool(core.plan, k).get("name") for k in range(len(core.strips))],
                       uncovered=[dict(u_range=r["u_range"], index_range=r["index_range"], kind=r["kind"],
                                       reason=r["reason"], arc_range=r["arc_range"], length=r["length"])
                                  for r in core.residual],
                       tools=[dict(name=t["name"], strips=t["strips"]) for t in core.tools],
                       n_profile=len(core.plan["rotor"]["profile"]), period=float(surface.profile.period),
                       flank_range=list(flanks[1]), length=float(rotor.length))
    res["verify_shares"] = _verify_shares(np, plan, 1, float(plan["tolerance"]), float(plan["overcut_tolerance"]))

    # ---------------------------------------------------------------- the strips list and the Results panel
    info = strips_mod.strip_rows(coll)
    res["rows"] = {str(k): v for k, v in info["rows"].items()}
    res["info"] = {k: v for k, v in info.items() if k != "rows"}
    ui = _UI(bpy)
    ul = bpy.types.FLANK_UL_strips
    items = {}
    for i, ob in enumerate(coll.objects):
        if ob.get("flank_sf_role") != "tool":
            continue
        log = []
        with bpy.context.temp_override(area=ui.area, region=ui.region):
            ul.draw_item(ul, bpy.context, _Rec(ui.layout(), log), coll, ob, 0, scene.flank_settings,
                         "results_strip_index", i)
        items[str(ob["flank_sf_strip"])] = log
    res["draw_items"] = items
    bpy.context.view_layer.objects.active = tool_ob
    panel = ui.draw(bpy.types.FLANK_PT_results)
    res["results_panel"] = panel if isinstance(panel, str) else _labels(panel["calls"])
    sf_panel = ui.draw(bpy.types.FLANK_PT_single_flank)
    res["sf_panel_props"] = sf_panel if isinstance(sf_panel, str) else [c[1] for c in sf_panel["calls"]
                                                                        if c[0] == "prop"]

    # ---------------------------------------------------------------- the residual on the rotor
    resid = [ob for ob in coll.objects if ob.get("flank_sf_role") == "residual"]
    res["residual"] = _residual_facts(np, bpy, resid[0], rotor_obj, surface, flanks[1]) if resid else None
