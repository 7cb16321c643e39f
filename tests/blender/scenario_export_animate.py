# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.export_results and flank.animate_strip on a single-flank run (asymmetric female flank 1, rotor scaled x2
and moved), against the core writers on the stored plan and the screw motion.  For test_blender_export_animate.py."""
import json
import os

import driver

S = 2.0


def _snap(bpy):
    return dict(objects=len(bpy.data.objects), meshes=len(bpy.data.meshes), actions=len(bpy.data.actions),
                collections=len(bpy.data.collections))


def scenario(bpy, res, args):
    import numpy as np
    from mathutils import Matrix

    exports, plan_mod, screw, mesh_io = (driver._core(m) for m in ("exports", "io.plan", "geometry.screw", "io.mesh_files"))
    tmp = os.path.abspath(os.getcwd())
    run_op = driver._run_op

    # ---------------------------------------------------------------- nothing planned yet
    res["no_run"] = dict(zip(("result", "error"), run_op(bpy.ops.flank.export_results, format="CL",
                                                          filepath=os.path.join(tmp, "none.apt"))))
    res["no_run"]["file"] = os.path.exists(os.path.join(tmp, "none.apt"))
    res["no_run_anim"] = dict(zip(("result", "error"), run_op(bpy.ops.flank.animate_strip)))

    run_op(bpy.ops.flank.generate_rotor, kind="asymmetric", part="female", resolution=360, axial=24)
    rotor = bpy.context.active_object
    M = np.eye(4)
    M[:3, :3] = S * np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    M[:3, 3] = (0.3, -0.2, 0.5)
    rotor.matrix_world = Matrix(M.tolist())
    bpy.context.view_layer.update()
    ret, err = run_op(bpy.ops.flank.plan_single_flank, flank=1, shape="alpha", alpha=0.1001674, r1=0.05 * S,
                      r2=0.08 * S, shank_radius=0.04 * S, shank_length=0.6 * S, tolerance=1e-3 * S, seeds=6,
                      rounds=1, envelope_rings=8, animate=False)
    res["plan"] = dict(result=ret, error=err)
    coll = next(c for c in bpy.data.collections["Flank Results"].children if "flank_plan_json" in c)
    plan = json.loads(coll["flank_plan_json"])
    res["run"] = dict(name=coll.name, strips=len(plan["strips"]), valid=bool(plan_mod.validate_plan(plan)),
                      sf_strips=coll.get("flank_sf_strips"))
    # the run's plan is kept parsed from the planner's worker on; a changed stored text is parsed again
    import importlib

    runs = importlib.import_module(driver.MODULE + ".operators.runs")
    kept_at_build = runs._PLANS[coll.name][1] if coll.name in runs._PLANS else None
    c1, p1 = runs.run_plan(bpy.context, coll.name)
    _, p2 = runs.run_plan(bpy.context, coll.name)
    text = coll["flank_plan_json"]
    changed = json.loads(text)
    changed["summary"]["elapsed_s"] = 123.25
    coll["flank_plan_json"] = json.dumps(changed)
    _, p3 = runs.run_plan(bpy.context, coll.name)
    coll["flank_plan_json"] = text
    _, p4 = runs.run_plan(bpy.context, coll.name)
    res["plan_cache"] = dict(kept_at_build=kept_at_build is not None, read_the_kept=p1 is kept_at_build,
                             shared=p1 is p2, equal=json.dumps(p1) == json.dumps(plan),
                             changed=p3["summary"]["elapsed_s"], restored=p4["summary"]["elapsed_s"],
                             stored=plan["summary"]["elapsed_s"])

    # ---------------------------------------------------------------- exports vs the core writers
    out = {}
    p = os.path.join(tmp, "run.json")
    out["plan"] = dict(zip(("result", "error"), run_op(bpy.ops.flank.export_results, format="PLAN", filepath=p)))
    out["plan"]["equal"] = json.loads(open(p).read()) == plan if os.path.exists(p) else None
    p = os.path.join(tmp, "run.apt")
    out["cl"] = dict(zip(("result", "error"), run_op(bpy.ops.flank.export_results, format="CL", filepath=p,
                                                      steps=40)))
    text = open(p).read() if os.path.exists(p) else ""
    core = exports.cl_data(plan, steps=40)
    out["cl"].update(equal=text == core, gotos=text.count("\nGOTO/"), core_gotos=core.count("\nGOTO/"),
                     first=next((ln for ln in text.splitlines() if ln.startswith("GOTO/")), None))
    p = os.path.join(tmp, "run1.apt")
    out["cl_strip1"] = dict(zip(("result", "error"), run_op(bpy.ops.flank.export_results, format="CL",
                                                             filepath=p, strip=1, steps=40)))
    out["cl_strip1"]["equal"] = os.path.exists(p) and open(p).read() == exports.cl_data(plan, strip=0, steps=40)
    p = os.path.join(tmp, "run.csv")
    out["csv"] = dict(zip(("result", "error"), run_op(bpy.ops.flank.export_results, format="CSV", filepath=p)))
    text = open(p).read() if os.path.exists(p) else ""
    core = exports.error_profile_csv(plan)

    def rows(t):
        return [[float(x) if x else None for x in ln.split(",")] for ln in t.splitlines()[1:]]

    def same(a, b):
        # the verify engine runs twice (operator, here): two runs could differ in the last bits (numpy's two
        # arctan2s, see geometry/angles.py), so values are compared to 1e-9 relative, not as text
        if len(a) != len(b):
            return False
        for ra, rb in zip(a, b):
            if len(ra) != len(rb) or any((x is None) != (y is None) for x, y in zip(ra, rb)):
                return False
            if any(x is not None and abs(x - y) > 1e-9 * max(1.0, abs(y)) for x, y in zip(ra, rb)):
                return False
        return True

    diff = [(a, b) for a, b in zip(text.splitlines(), core.splitlines()) if a != b]
    out["csv"].update(equal=same(rows(text), rows(core)) if text else False, text_equal=text == core,
                      differing_lines=len(diff), first_difference=diff[0] if diff else None,
                      rows=text.count("\n") - 1, header=text.splitlines()[0] if text else None)
    p = os.path.join(tmp, "strips.stl")
    out["stl"] = dict(zip(("result", "error"), run_op(bpy.ops.flank.export_results, format="STL", filepath=p,
                                                       strip=2, steps=30)))
    f = os.path.join(tmp, "strips_1.stl")
    if os.path.exists(f):
        v, fc = mesh_io.read_stl(f)
        cv, cf = exports.strip_mesh(plan, 1, n_t=31)
        out["stl"].update(faces=len(fc), core_faces=len(cf),
                          max_diff=float(np.abs(np.asarray(v, float)[np.asarray(fc)] -
                                                np.asarray(cv, float)[np.asarray(cf)]).max()))
    p = os.path.join(tmp, "all.ply")
    out["ply"] = dict(zip(("result", "error"), run_op(bpy.ops.flank.export_results, format="PLY", filepath=p,
                                                       steps=12)))
    out["ply"]["files"] = sorted(f for f in os.listdir(tmp) if f.startswith("all_") and f.endswith(".ply"))
    out["bad_strip"] = dict(zip(("result", "error"), run_op(bpy.ops.flank.export_results, format="CL",
                                                             filepath=os.path.join(tmp, "bad.apt"), strip=99)))
    out["bad_strip"]["file"] = os.path.exists(os.path.join(tmp, "bad.apt"))
    out["bad_dir"] = dict(zip(("result", "error"), run_op(bpy.ops.flank.export_results, format="PLAN",
                                                           filepath=os.path.join(tmp, "no", "x.json"))))
    out["is_dir"] = dict(zip(("result", "error"), run_op(bpy.ops.flank.export_results, format="PLAN",
                                                          filepath=tmp)))
    # the .blend is not saved: a relative path would land in Blender's working folder
    out["relative"] = dict(zip(("result", "error"), run_op(bpy.ops.flank.export_results, format="PLAN",
                                                            filepath="relative_plan.json")))
    out["relative"]["file"] = os.path.exists("relative_plan.json")
    out["leftovers"] = sorted(f for f in os.listdir(tmp) if f.startswith(".flank_export_"))
    res["export"] = out

    # ---------------------------------------------------------------- sidebar: results list, legend, presets
    ui = {}
    ui["panels"] = driver._draw_panels(bpy, bpy.context.active_object)
    settings = bpy.context.scene.flank_settings
    verify = driver._core("simulation.verify")
    ui["legend_diff"] = max(abs(a - b) for key in ("gouge", "ok", "stock")
                            for a, b in zip(getattr(settings, "legend_" + key), verify.DEVIATION_COLORS[key]))
    idx = next(i for i, ob in enumerate(coll.objects) if ob.get("flank_sf_role") == "tool"
               and ob.get("flank_sf_strip") == 1)
    settings.results_strip_index = idx                     # picking a row selects that strip's tool + envelope
    ui["selected"] = sorted(ob.name for ob in bpy.context.selected_objects)
    ui["active"] = bpy.context.view_layer.objects.active.name
    ul = bpy.types.FLANK_UL_strips
    flags, order = ul.filter_items(ul, bpy.context, coll, "objects")
    ui["list_rows"] = sum(1 for f in flags if f)
    # presets: a shipped real end mill (mm) in a metric scene measured in mm
    us = bpy.context.scene.unit_settings
    us.system, us.scale_length = 'METRIC', 0.001
    import glob
    ext_root = os.path.dirname(os.path.dirname(os.path.dirname(driver._core("io.plan").__file__)))
    shipped = sorted(glob.glob(os.path.join(ext_root, "presets", "flank_tool", "*.py")))
    ui["shipped"] = [os.path.basename(p) for p in shipped]
    pre = [p for p in shipped if os.path.basename(p) == "Tapered 3deg D6 L30.py"]
    if pre:
        ui["preset_result"] = sorted(bpy.ops.script.execute_preset(filepath=pre[0],
                                                                   menu_idname="FLANK_MT_tool_presets"))
    ui["tool_settings"] = [settings.sf_shape, settings.sf_alpha, settings.sf_r1, settings.sf_r2,
                           settings.sf_shank_radius, settings.sf_shank_length]
    us.scale_length = 0.01                                  # 1 unit = 1 cm: the same tool, other numbers
    bpy.ops.flank.tool_preset(taper_deg=3.0, tip_diameter_mm=6.0, flute_length_mm=30.0, shank_diameter_mm=10.0,
                              overall_length_mm=80.0)
    ui["tool_settings_cm"] = [settings.sf_r1, settings.sf_r2, settings.sf_shank_radius]
    ui["bad_preset"] = dict(zip(("result", "error"), run_op(bpy.ops.flank.tool_preset, taper_deg=60.0)))
    us.system, us.scale_length = 'NONE', 1.0
    res["ui"] = ui

    # ---------------------------------------------------------------- report picture (nothing left behind)
    rr = driver._core("report.report_geometry")
    png_io = driver._core("io.png")

    def blocks():
        return {k: len(getattr(bpy.data, k)) for k in ("objects", "meshes", "curves", "cameras", "worlds", "images",
                                                      "scenes", "materials", "collections")}
    b0 = blocks()
    p = os.path.join(tmp, "report.png")
    ret, err = run_op(bpy.ops.flank.render_report, filepath=p, width=640, height=400)
    rep = dict(result=ret, error=err, new={k: v - b0[k] for k, v in blocks().items()})
    if os.path.exists(p):
        px = png_io.read_png(p)
        flat = px[..., :3].reshape(-1, 3)
        rep.update(shape=list(px.shape), swatches={k: int((flat == c).all(axis=1).sum())
                                                   for k, c in rr.legend_colors().items()})
    r2, e2 = run_op(bpy.ops.flank.render_report, filepath=os.path.join(tmp, "no", "r.png"))
    rep["bad_dir"] = dict(result=r2, error=e2)
    res["report"] = rep

    # ---------------------------------------------------------------- animate strip 2: the rotor screws
    tool = next(ob for ob in coll.objects if ob.get("flank_sf_role") == "tool" and ob.get("flank_sf_strip") == 1)
    tool_before = np.array(tool.matrix_world, dtype=np.float64)
    s0 = _snap(bpy)
    ret, err = run_op(bpy.ops.flank.animate_strip, strip=2, frame_start=1, frame_end=21)
    s1 = _snap(bpy)
    anim = dict(result=ret, error=err, new={k: s1[k] - s0[k] for k in s0})
    moving = next((ob for ob in coll.objects if ob.get("flank_anim_role") == "rotor"), None)
    motion = next((ob for ob in coll.objects if ob.get("flank_anim_role") == "motion"), None)
    if moving is not None and motion is not None:
        t0, t1 = motion["flank_anim_time"]
        D = np.array(plan["rotor"]["to_world"], dtype=np.float64)
        v0 = float(plan["rotor"]["v0"])
        hand = plan["rotor"]["handedness"]
        W = np.array(rotor.matrix_world, dtype=np.float64)
        diffs = []
        for frame, t in ((1, t0), (11, 0.5 * (t0 + t1)), (21, t1)):
            bpy.context.scene.frame_set(frame)
            got = np.array(moving.matrix_world, dtype=np.float64)
            # a rotor point x (rotor frame) is at S_t(x) at time t: world = D S_t D^-1 W
            pts = np.array([[0.1, 0.2, 0.3], [0.7, -0.4, 1.1]])
            expect = screw.screw_motion(pts, t, v0, hand)
            loc = np.linalg.inv(W) @ D @ np.c_[pts, np.ones(2)].T          # rotor-frame points in mesh coords
            world = got @ loc
            diffs.append(float(np.abs(world[:3].T - (D @ np.c_[expect, np.ones(2)].T)[:3].T).max()))
        anim.update(time=[t0, t1], diffs=diffs, tool_moved=float(np.abs(np.array(tool.matrix_world) -
                                                                        tool_before).max()),
                    rotor_hidden=rotor.hide_get(), shares_mesh=moving.data == rotor.data,
                    scale=S)
    res["animate"] = anim
    s2 = _snap(bpy)
    ret, err = run_op(bpy.ops.flank.animate_strip, strip=1, frame_start=1, frame_end=41)
    s3 = _snap(bpy)
    res["reanimate"] = dict(result=ret, error=err, new={k: s3[k] - s2[k] for k in s2},
                            orphan_actions=sum(1 for a in bpy.data.actions if a.users == 0))
    bad = {}
    for name, kw in (("strip_0", dict(strip=0)), ("strip_99", dict(strip=99)),
                     ("frames", dict(frame_start=5, frame_end=5)), ("no_coll", dict(collection="Nope"))):
        b0 = _snap(bpy)
        r, e = run_op(bpy.ops.flank.animate_strip, **kw)
        b1 = _snap(bpy)
        bad[name] = dict(result=r, error=e, new={k: b1[k] - b0[k] for k in b0})
    res["animate_bad"] = bad
    res["bl_options"] = sorted(bpy.types.FLANK_OT_animate_strip.bl_options)
    res["plans_kept"] = driver.plans_kept(bpy)     # after every operator that read a run's plan
