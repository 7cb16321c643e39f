# SPDX-License-Identifier: GPL-3.0-or-later
"""Runs keep their plan; flank.export_results and flank.animate_strip against an independent core run of the
same inputs (built-in asymmetric female flank 1, cone alpha = asin(0.1), r1 = 0.05, r2 = 0.08, tolerance 1e-3,
rotor turned and moved), a double-flank run (nilson male), failure paths (no run, empty / directory / missing
folder paths, NaN and broken stored plans), undo / redo of an animation, a planning re-run that replaces an
animated run, and save + reload.  For test_blender_run_exports.py."""
import json
import math
import os
import time

import driver

SF_ASIN = driver.SF_ASIN                 # asin(0.1)
SEEDS, ROUNDS = 6, 1
TOOL = dict(shape="alpha", alpha=SF_ASIN, r1=0.05, r2=0.08, shank_radius=0.04, shank_length=0.6, tolerance=1e-3)
SKIP = ("elapsed", "timings", "seconds")    # wall-clock figures differ between two runs of the same plan


def _blocks(bpy):
    return {k: len(getattr(bpy.data, k)) for k in ("objects", "meshes", "actions", "collections", "texts")}


def _diff(a, b):
    return {k: b[k] - a[k] for k in a}


def _compare(a, b, path=""):
    """(largest |difference| of numbers, list of structural mismatches) between two JSON trees."""
    if isinstance(a, dict) and isinstance(b, dict):
        worst, bad = 0.0, []
        if set(a) != set(b):
            bad.append("{}: keys {} vs {}".format(path, sorted(set(a) ^ set(b)), ""))
        for k in set(a) & set(b):
            if any(s in k for s in SKIP):
                continue
            w, m = _compare(a[k], b[k], path + "." + k)
            worst, bad = max(worst, w), bad + m
        return worst, bad
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return 0.0, ["{}: length {} vs {}".format(path, len(a), len(b))]
        worst, bad = 0.0, []
        for i, (x, y) in enumerate(zip(a, b)):
            w, m = _compare(x, y, "{}[{}]".format(path, i))
            worst, bad = max(worst, w), bad + m
        return worst, bad
    num = (int, float)
    if isinstance(a, num) and isinstance(b, num) and not isinstance(a, bool) and not isinstance(b, bool):
        if math.isnan(a) and math.isnan(b):
            return 0.0, []
        return abs(float(a) - float(b)), []
    return 0.0, ([] if a == b else ["{}: {!r} vs {!r}".format(path, a, b)])


def _gotos(text):
    """[[x, y, z, i, j, k], ...] of the GOTO lines of a CL text."""
    out = []
    for ln in text.splitlines():
        if ln.startswith("GOTO/"):
            out.append([float(v) for v in ln[5:].split("$$")[0].split(",")])
    return out


def _read(path, mode="r"):
    if not os.path.exists(path):
        return None
    with open(path, mode) as fh:
        return fh.read()


def _screw4(np, screw, t, v0, hand):
    """4x4 of S_t built from the core's screw_motion (images of the origin and the unit vectors)."""
    pts = screw.screw_motion(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]), t, v0, hand)
    m = np.eye(4)
    m[:3, 3] = pts[0]
    m[:3, :3] = (pts[1:] - pts[0]).T
    return m


def _listing(tmp):
    return sorted(os.listdir(tmp))


def _anim_check(bpy, np, screw, coll, plan, rotor, prefix, strip_k):
    """Frames start / middle / end: the moving rotor's world matrix vs D S_t D^-1 W; the strip's tool and the
    original rotor do not move."""
    scene = bpy.context.scene
    motion = next(ob for ob in coll.objects if ob.get("flank_anim_role") == "motion")
    moving = next(ob for ob in coll.objects if ob.get("flank_anim_role") == "rotor")
    strip_key = prefix + ("strip" if prefix == "flank_sf_" else "path")     # double flank numbers paths
    tool = next(ob for ob in coll.objects if ob.get(prefix + "role") == "tool" and ob.get(strip_key) == strip_k)
    envelopes = [ob for ob in coll.objects if ob.get(prefix + "role") == "envelope" and ob.get(strip_key) == strip_k]
    moving_strips = [ob for ob in coll.objects if ob.get("flank_anim_role") == "strip"]
    fs, fe = list(motion["flank_anim_frames"])
    t0, t1 = list(motion["flank_anim_time"])
    D = np.array(plan["rotor"]["to_world"], dtype=np.float64)
    v0, hand = float(plan["rotor"]["v0"]), plan["rotor"]["handedness"]
    scene.frame_set(fs)
    W = np.array(rotor.matrix_world, dtype=np.float64)
    tool_ref = np.array(tool.matrix_world, dtype=np.float64)
    out = dict(frames=[fs, fe], time=[t0, t1], samples=[], tool_moved=0.0, rotor_moved=0.0,
               rotor_animated=rotor.animation_data is not None and rotor.animation_data.action is not None,
               rotor_hidden=rotor.hide_get(), shares_mesh=moving.data == rotor.data,
               moving_parent=moving.parent.name if moving.parent else None, motion_name=motion.name,
               envelopes=len(envelopes), envelopes_hidden=all(ob.hide_get() for ob in envelopes),
               moving_strips=sorted(ob.data.name for ob in moving_strips),
               strip_meshes=sorted(ob.data.name for ob in envelopes),
               moving_strips_parent=sorted({ob.parent.name for ob in moving_strips if ob.parent}),
               interpolations=sorted({kp.interpolation for fc in _fcurves(motion.animation_data.action)
                                      for kp in fc.keyframe_points}))
    for f in (fs, (fs + fe) // 2, fe):
        scene.frame_set(f)
        t = t0 if f == fs else t1 if f == fe else t0 + (t1 - t0) * (f - fs) / (fe - fs)
        expect = D @ _screw4(np, screw, t, v0, hand) @ np.linalg.inv(D) @ W
        got = np.array(moving.matrix_world, dtype=np.float64)
        out["samples"].append(dict(frame=f, t=t, max_diff=float(np.abs(got - expect).max()),
                                   translation=float(np.linalg.norm(got[:3, 3] - W[:3, 3]))))
        out["tool_moved"] = max(out["tool_moved"], float(np.abs(np.array(tool.matrix_world) - tool_ref).max()))
        out["rotor_moved"] = max(out["rotor_moved"], float(np.abs(np.array(rotor.matrix_world) - W).max()))
    scene.frame_set(fs)
    return out


def _fcurves(action):
    layers = getattr(action, "layers", None)
    if layers:
        return [fc for layer in layers for st in layer.strips for bag in getattr(st, "channelbags", ())
                for fc in bag.fcurves]
    return list(getattr(action, "fcurves", ()))


def _attempt(bpy, tmp, op, **kw):
    """Run an operator that must fail: result, message, new data-blocks, new files."""
    b0, l0 = _blocks(bpy), _listing(tmp)
    ret, err = driver._run_op(op, **kw)
    return dict(result=ret, error=err, new=_diff(b0, _blocks(bpy)),
                new_files=sorted(set(_listing(tmp)) - set(l0)))


def scenario(bpy, res, args):
    import numpy as np
    from mathutils import Matrix

    exports, plan_mod, ms, cone, rotors, mesh_io, screw = (driver._core(m) for m in (
        "exports", "io.plan", "methods.single_flank.planner", "tooling.cone", "geometry.rotors", "io.mesh_files", "geometry.screw"))
    tmp = os.path.abspath(os.getcwd())
    run_op = driver._run_op
    ex_op, an_op = bpy.ops.flank.export_results, bpy.ops.flank.animate_strip

    # ---------------------------------------------------------------- nothing planned yet
    pre = {}
    for fmt in ("PLAN", "CL", "CSV", "STL", "PLY"):
        pre[fmt] = _attempt(bpy, tmp, ex_op, format=fmt, filepath=os.path.join(tmp, "none." + fmt.lower()))
    pre["animate"] = _attempt(bpy, tmp, an_op)
    res["before_any_run"] = pre

    # ---------------------------------------------------------------- single-flank run (rotor turned and moved)
    run_op(bpy.ops.flank.generate_rotor, kind="asymmetric", part="female", resolution=360, axial=24)
    rotor = bpy.context.active_object
    rotor_name = rotor.name
    c, s = math.cos(0.7), math.sin(0.7)
    rotor.matrix_world = Matrix(((c, -s, 0.0, 0.3), (s, c, 0.0, -0.2), (0.0, 0.0, 1.0, 0.5), (0.0, 0.0, 0.0, 1.0)))
    bpy.context.view_layer.update()
    rest = np.array(rotor.matrix_world, dtype=np.float64)
    plan_file = os.path.join(tmp, "sf_plan.json")
    b0 = _blocks(bpy)
    t_start = time.perf_counter()
    ret, err = run_op(bpy.ops.flank.plan_single_flank, flank=1, seeds=SEEDS, rounds=ROUNDS, envelope_rings=8,
                      animate=False, filepath=plan_file, **TOOL)
    sf = dict(result=ret, error=err, seconds=time.perf_counter() - t_start, new=_diff(b0, _blocks(bpy)))
    res["sf"] = sf
    if ret is None:
        return
    coll = bpy.context.active_object.users_collection[0]
    stored_text = coll["flank_plan_json"]
    stored = json.loads(stored_text)
    sf.update(collection=coll.name, prop_type=type(coll["flank_plan_json"]).__name__,
              stored_valid=bool(plan_mod.validate_plan(stored)), strips=len(stored["strips"]),
              equals_plan_file=stored == plan_mod.read_plan(plan_file),
              parent=[c_.name for c_ in bpy.data.collections if coll.name in c_.children])

    # the core, run here on the same inputs (rotor frame = the plan's; placement = the stored to_world)
    t_start = time.perf_counter()
    builtin = rotors.builtin_rotor("asymmetric", "female")
    # the tool the operator used: its float properties are read back as the decimals typed (7 digits), so alpha
    # is 0.1001674, not asin(0.1) to 16 digits -- a 2e-8 difference the optimiser turns into 3e-6
    tool = cone.ConeTool(coll["flank_sf_tool_alpha"], coll["flank_sf_tool_r1"], coll["flank_sf_tool_r2"],
                         coll["flank_sf_tool_shank_radius"], coll["flank_sf_tool_shank_length"])
    sf["tool"] = [coll["flank_sf_tool_alpha"], coll["flank_sf_tool_r1"], coll["flank_sf_tool_r2"],
                  coll["flank_sf_tool_shank_radius"], coll["flank_sf_tool_shank_length"]]
    core = ms.plan_single_flank(builtin.surface(), builtin.flanks, 1, tool, 1e-3, n_seeds=SEEDS,
                                max_rounds=ROUNDS, to_world=stored["rotor"]["to_world"])
    core.plan["rotor"]["extent"] = builtin.extent()     # the planners record the rotor's extent, as the CLI does
    core_plan = json.loads(json.dumps(core.plan))
    worst, bad = _compare(stored, core_plan)
    to_world_diff = float(np.abs(np.array(stored["rotor"]["to_world"]) - np.array(rotor.matrix_world)).max())
    sf["core"] = dict(seconds=time.perf_counter() - t_start, max_diff=worst, mismatches=bad[:10],
                      strips=len(core_plan["strips"]), to_world_vs_object=to_world_diff)

    # ---------------------------------------------------------------- exports (active object = a tool of the run)
    x = {}
    p = os.path.join(tmp, "plan_export.json")
    x["plan"] = dict(zip(("result", "error"), run_op(ex_op, format="PLAN", filepath=p)))
    x["plan"]["same_bytes_as_write_plan"] = _read(p, "rb") == _read(plan_file, "rb")
    got = json.loads(_read(p)) if os.path.exists(p) else None
    x["plan"]["vs_core"] = list(_compare(got, core_plan)) if got is not None else None

    p = os.path.join(tmp, "cl_export.apt")
    x["cl"] = dict(zip(("result", "error"), run_op(ex_op, format="CL", filepath=p, steps=40)))
    text = _read(p) or ""
    core_cl = exports.cl_data(core_plan, steps=40)
    g, cg = _gotos(text), _gotos(core_cl)
    x["cl"].update(gotos=len(g), core_gotos=len(cg), first=g[0] if g else None, core_first=cg[0] if cg else None,
                   first_diff=float(np.abs(np.subtract(g[0], cg[0])).max()) if g and cg else None,
                   all_diff=float(np.abs(np.subtract(g, cg)).max()) if g and len(g) == len(cg) else None,
                   same_as_core_writer_on_stored=text == exports.cl_data(stored, steps=40))

    p = os.path.join(tmp, "profile.csv")
    x["csv"] = dict(zip(("result", "error"), run_op(ex_op, format="CSV", filepath=p)))
    text = _read(p) or ""
    core_csv = exports.error_profile_csv(core_plan)
    lines, clines = text.splitlines(), core_csv.splitlines()
    x["csv"].update(header=lines[0] if lines else None, core_header=clines[0], rows=len(lines) - 1,
                    core_rows=len(clines) - 1)
    if lines and len(lines) == len(clines):
        ga = np.genfromtxt(lines[1:], delimiter=",")
        gb = np.genfromtxt(clines[1:], delimiter=",")
        x["csv"].update(nan_pattern_equal=bool((np.isnan(ga) == np.isnan(gb)).all()),
                        max_diff=float(np.nanmax(np.abs(ga - gb))))

    meshes = {}
    for fmt, strip, steps in (("STL", 2, 30), ("PLY", 2, 30), ("PLY", 0, 12)):
        stem = "mesh_{}_{}".format(fmt.lower(), strip)
        r = dict(zip(("result", "error"), run_op(ex_op, format=fmt, filepath=os.path.join(tmp, stem + "." +
                                                                                           fmt.lower()),
                                                 strip=strip, steps=steps)))
        r["files"] = sorted(f for f in _listing(tmp) if f.startswith(stem + "_"))
        counts = []
        for f in r["files"]:
            k = int(f[len(stem) + 1:].split(".")[0])
            cv, cf = exports.strip_mesh(core_plan, k, n_t=min(steps, 2000) + 1)
            v, fc = (mesh_io.read_stl if fmt == "STL" else mesh_io.read_ply)(os.path.join(tmp, f))
            counts.append(dict(file=f, vertices=len(v), core_vertices=len(cv), faces=len(fc), core_faces=len(cf),
                               max_diff=float(np.abs(np.asarray(v, float)[np.asarray(fc)]
                                                     - np.asarray(cv, float)[np.asarray(cf)]).max())
                               if len(fc) == len(cf) else None))
        r["counts"] = counts
        meshes["{}_{}".format(fmt, strip)] = r
    x["meshes"] = meshes

    # a z range instead of one lead (the CLI's --z-range): CL and a strip mesh
    zr = (0.5, 2.25)
    p = os.path.join(tmp, "cl_zr.apt")
    x["cl_zr"] = dict(zip(("result", "error"), run_op(ex_op, format="CL", filepath=p, strip=1, steps=20,
                                                       use_z_range=True, z_range=zr)))
    text = _read(p) or ""
    g = _gotos(text)
    x["cl_zr"].update(equal=text == exports.cl_data(stored, strip=0, steps=20, z_range=zr), gotos=len(g),
                      z_first_last=[g[0][2], g[-1][2]] if g else None)
    p = os.path.join(tmp, "zr.stl")
    x["stl_zr"] = dict(zip(("result", "error"), run_op(ex_op, format="STL", filepath=p, strip=1, steps=20,
                                                        use_z_range=True, z_range=zr)))
    f = os.path.join(tmp, "zr_0.stl")
    if os.path.exists(f):
        v, fc = mesh_io.read_stl(f)
        cv, cf = exports.strip_mesh(stored, 0, n_t=21, z_range=zr)
        x["stl_zr"].update(faces=len(fc), core_faces=len(cf),
                           max_diff=float(np.abs(np.asarray(v, float)[np.asarray(fc)] -
                                                 np.asarray(cv, float)[np.asarray(cf)]).max())
                           if len(fc) == len(cf) else None)

    # by name, with an object of no run active (the rotor)
    bpy.context.view_layer.objects.active = rotor
    p = os.path.join(tmp, "by_name.json")
    x["by_name"] = dict(zip(("result", "error"), run_op(ex_op, format="PLAN", filepath=p, collection=coll.name)))
    x["by_name"]["same"] = _read(p, "rb") == _read(plan_file, "rb")

    # failure paths: a message, no data-block, no file (no staging folder either)
    bad = {}
    bad["empty_path"] = _attempt(bpy, tmp, ex_op, format="CL", filepath="")
    bad["directory"] = _attempt(bpy, tmp, ex_op, format="PLAN", filepath=tmp)
    bad["missing_folder"] = _attempt(bpy, tmp, ex_op, format="CSV", filepath=os.path.join(tmp, "nope", "x.csv"))
    bad["under_a_file"] = _attempt(bpy, tmp, ex_op, format="CL", filepath=os.path.join(plan_file, "x.apt"))
    bad["strip_99"] = _attempt(bpy, tmp, ex_op, format="STL", filepath=os.path.join(tmp, "s.stl"), strip=99)
    bad["no_collection"] = _attempt(bpy, tmp, ex_op, format="CL", filepath=os.path.join(tmp, "n.apt"),
                                    collection="Nope")
    bad["not_a_run"] = _attempt(bpy, tmp, ex_op, format="CL", filepath=os.path.join(tmp, "n.apt"),
                                collection="Flank Results")
    bad["steps_big"] = _attempt(bpy, tmp, ex_op, format="CL", filepath=os.path.join(tmp, "n.apt"), steps=200000)
    bad["z_nan"] = _attempt(bpy, tmp, ex_op, format="CL", filepath=os.path.join(tmp, "z.apt"), use_z_range=True,
                            z_range=(float("nan"), 1.0))
    bad["z_reversed"] = _attempt(bpy, tmp, ex_op, format="STL", filepath=os.path.join(tmp, "z.stl"),
                                 use_z_range=True, z_range=(2.0, 1.0))
    nan_plan = json.loads(stored_text)
    nan_plan["strips"][0]["axis_start"][0] = float("nan")
    coll["flank_plan_json"] = json.dumps(nan_plan)                  # NaN: json writes it as the token NaN
    bad["nan_plan"] = _attempt(bpy, tmp, ex_op, format="CL", filepath=os.path.join(tmp, "nan.apt"),
                               collection=coll.name)
    bad["nan_plan_animate"] = _attempt(bpy, tmp, an_op, collection=coll.name)
    coll["flank_plan_json"] = "{\"schema\": \"flank-plan/1\", "
    bad["broken_json"] = _attempt(bpy, tmp, ex_op, format="PLAN", filepath=os.path.join(tmp, "broken.json"),
                                  collection=coll.name)
    coll["flank_plan_json"] = stored_text
    x["bad"] = bad
    res["export"] = x

    # ---------------------------------------------------------------- animate strip 1: numbers, undo, redo
    a = {}
    bpy.context.view_layer.objects.active = rotor
    bpy.ops.ed.undo_push(message="before animate")        # the UI pushes these around an UNDO operator
    b0 = _blocks(bpy)
    names0 = sorted(o.name for o in bpy.data.objects)
    ret, err = run_op(an_op, collection=coll.name, strip=1, frame_start=1, frame_end=49)
    a["run"] = dict(result=ret, error=err, new=_diff(b0, _blocks(bpy)))
    bpy.ops.ed.undo_push(message="Animate Strip")
    if ret is not None:
        a["check"] = _anim_check(bpy, np, screw, coll, stored, rotor, "flank_sf_", 0)
    try:
        bpy.ops.ed.undo()
        a["undo_error"] = None
    except Exception as ex_:
        a["undo_error"] = "{}: {}".format(type(ex_).__name__, ex_)
    rot = bpy.data.objects.get(rotor_name)
    a["after_undo"] = dict(new=_diff(b0, _blocks(bpy)), same_objects=sorted(o.name for o in bpy.data.objects) == names0,
                           rotor_hidden=rot.hide_get() if rot else None,
                           anim_objects=sum(1 for o in bpy.data.objects if "flank_anim_role" in o),
                           rotor_matrix_diff=float(np.abs(np.array(rot.matrix_world) - rest).max()))
    try:
        bpy.ops.ed.redo()
        a["redo_error"] = None
    except Exception as ex_:
        a["redo_error"] = "{}: {}".format(type(ex_).__name__, ex_)
    rotor = bpy.data.objects[rotor_name]
    coll = bpy.data.collections[sf["collection"]]
    a["after_redo"] = dict(new=_diff(b0, _blocks(bpy)),
                           anim_objects=sum(1 for o in bpy.data.objects if "flank_anim_role" in o))
    if a["after_redo"]["anim_objects"]:
        a["redo_check"] = _anim_check(bpy, np, screw, coll, stored, rotor, "flank_sf_", 0)

    # re-run on another strip and frame range: replaces, no orphan action
    b1 = _blocks(bpy)
    ret, err = run_op(an_op, collection=coll.name, strip=2, frame_start=10, frame_end=30)
    a["rerun"] = dict(result=ret, error=err, new=_diff(b1, _blocks(bpy)),
                      orphan_actions=sum(1 for act in bpy.data.actions if act.users == 0),
                      anim_strips=sorted({o["flank_anim_strip"] for o in coll.objects if "flank_anim_role" in o}),
                      strip1_envelope_hidden=[o.hide_get() for o in coll.objects
                                              if o.get("flank_sf_role") == "envelope" and o["flank_sf_strip"] == 0])
    if ret is not None:
        a["rerun_check"] = _anim_check(bpy, np, screw, coll, stored, rotor, "flank_sf_", 1)
    a["bl_options"] = sorted(bpy.types.FLANK_OT_animate_strip.bl_options)
    a["export_bl_options"] = sorted(bpy.types.FLANK_OT_export_results.bl_options)
    # something the user hid before stays hidden when the animation goes (only what the operator hid returns)
    env3 = next(o for o in coll.objects if o.get("flank_sf_role") == "envelope" and o["flank_sf_strip"] == 2)
    env3.hide_set(True)
    run_op(an_op, collection=coll.name, strip=3, frame_start=1, frame_end=11)
    motion = next(o for o in coll.objects if o.get("flank_anim_role") == "motion")
    a["user_hidden"] = dict(hid=list(motion.get("flank_anim_hid", [])))
    run_op(an_op, collection=coll.name, strip=2, frame_start=10, frame_end=30)
    a["user_hidden"].update(env3_hidden=env3.hide_get(), rotor_hidden=rotor.hide_get())
    env3.hide_set(False)
    res["animate"] = a

    # ---------------------------------------------------------------- double-flank run (nilson male)
    d = {}
    run_op(bpy.ops.flank.generate_rotor, kind="nilson", part="male", resolution=360, axial=24)
    nil = bpy.context.active_object
    nil.location = (3.0, 0.0, 0.0)
    bpy.context.view_layer.update()
    df_file = os.path.join(tmp, "df_plan.json")
    b0 = _blocks(bpy)
    t_start = time.perf_counter()
    ret, err = run_op(bpy.ops.flank.plan_double_flank, radii=40, envelope_rings=12, simulate=False, animate=False,
                      filepath=df_file)
    d["run"] = dict(result=ret, error=err, seconds=time.perf_counter() - t_start, new=_diff(b0, _blocks(bpy)))
    if ret is not None:
        dcoll = bpy.context.active_object.users_collection[0]
        dplan = json.loads(dcoll["flank_plan_json"])
        d.update(collection=dcoll.name, equals_plan_file=dplan == plan_mod.read_plan(df_file),
                 strips=len(dplan["strips"]))
        p = os.path.join(tmp, "df_export.json")
        d["plan"] = dict(zip(("result", "error"), run_op(ex_op, format="PLAN", filepath=p)))
        d["plan"]["same_bytes_as_write_plan"] = _read(p, "rb") == _read(df_file, "rb")
        p = os.path.join(tmp, "df.apt")
        d["cl"] = dict(zip(("result", "error"), run_op(ex_op, format="CL", filepath=p, steps=24)))
        d["cl"]["equal"] = _read(p) == exports.cl_data(dplan, steps=24)
        p = os.path.join(tmp, "df_strips.ply")
        d["ply"] = dict(zip(("result", "error"), run_op(ex_op, format="PLY", filepath=p, steps=24)))
        d["ply"]["files"] = sorted(f for f in _listing(tmp) if f.startswith("df_strips_"))
        # the active object is a DF tool: the double-flank run is found without a name
        b2 = _blocks(bpy)
        ret, err = run_op(an_op, strip=1, frame_start=1, frame_end=25)
        d["animate"] = dict(result=ret, error=err, new=_diff(b2, _blocks(bpy)))
        if ret is not None:
            d["animate"]["check"] = _anim_check(bpy, np, screw, dcoll, dplan, nil, "flank_df_", 0)
            d["animate"]["single_flank_run_untouched"] = sorted(
                o["flank_anim_strip"] for o in bpy.data.collections[sf["collection"]].objects
                if o.get("flank_anim_role") == "motion")
    res["double"] = d

    # ---------------------------------------------------------------- re-planning replaces the animated run
    r = {}
    bpy.context.view_layer.objects.active = rotor
    b0 = _blocks(bpy)
    ret, err = run_op(bpy.ops.flank.plan_single_flank, flank=1, seeds=SEEDS, rounds=ROUNDS, envelope_rings=8,
                      animate=False, **TOOL)
    coll = bpy.context.active_object.users_collection[0] if ret is not None else None
    r.update(result=ret, error=err, new=_diff(b0, _blocks(bpy)),
             collection=coll.name if coll is not None else None,
             has_plan="flank_plan_json" in coll if coll is not None else None,
             plan_equal=(_compare(json.loads(coll["flank_plan_json"]), stored)[1] == []) if coll is not None
             else None,
             sf_anim_objects=sum(1 for o in bpy.data.objects if o.get("flank_anim_role") and
                                 o.get("flank_anim_strip") is not None and o.users_collection and
                                 o.users_collection[0].name.startswith("Single Flank")),
             orphan_actions=sum(1 for act in bpy.data.actions if act.users == 0),
             orphan_meshes=sum(1 for me in bpy.data.meshes if me.users == 0),
             rotor_hidden=bpy.data.objects[rotor_name].hide_get())
    res["replan"] = r

    # ---------------------------------------------------------------- save + reload: plan and animation survive
    sv = {}
    blend = os.path.join(tmp, "runs.blend")
    names = {c_.name: c_["flank_plan_json"] for c_ in bpy.data.collections if "flank_plan_json" in c_}
    dname = d.get("collection")
    strips_mod = __import__(driver.MODULE + ".operators.strips", fromlist=["x"])
    runs_mod = __import__(driver.MODULE + ".operators.runs", fromlist=["x"])
    rows_before = {n: json.dumps(strips_mod.strip_rows(bpy.data.collections[n]), sort_keys=True) for n in names}
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    bpy.ops.wm.open_mainfile(filepath=blend)
    sv["plans_kept"] = {n: (bpy.data.collections.get(n) is not None
                            and bpy.data.collections[n].get("flank_plan_json") == text_)
                        for n, text_ in names.items()}
    # the strips list of a later session (nothing kept parsed): the rows the build stored, no plan parsed; and
    # for a run stored without them (an older file), from its plan
    rows = {}
    for n in names:
        runs_mod._PLANS.clear()
        strips_mod._ROWS_CACHE.clear()
        coll_ = bpy.data.collections[n]
        info = strips_mod.strip_rows(coll_)
        got = json.dumps(info, sort_keys=True)
        rows[n] = dict(stored=strips_mod.ROWS_PROP in coll_, same=got == rows_before[n], parsed=len(runs_mod._PLANS),
                       strips=len(info["rows"]), int_keys=all(isinstance(k, int) for k in info["rows"]))
        stored = coll_[strips_mod.ROWS_PROP]
        del coll_[strips_mod.ROWS_PROP]
        strips_mod._ROWS_CACHE.clear()
        rows[n].update(without_same=json.dumps(strips_mod.strip_rows(coll_), sort_keys=True) == rows_before[n],
                       without_parsed=len(runs_mod._PLANS))
        coll_[strips_mod.ROWS_PROP] = stored
    sv["strip_rows"] = rows
    if dname:
        p = os.path.join(tmp, "df_after_reload.json")
        # nothing kept parsed, and the plan counts as long: Export reads it first (as its worker would), then exports
        runs_mod._PLANS.clear()
        real_defer, runs_mod.DEFER_CHARS = runs_mod.DEFER_CHARS, 100_000
        try:
            sv["export"] = dict(zip(("result", "error"), run_op(bpy.ops.flank.export_results, format="PLAN",
                                                                filepath=p, collection=dname)))
        finally:
            runs_mod.DEFER_CHARS = real_defer
        sv["export"]["same_bytes"] = _read(p, "rb") == _read(df_file, "rb")
        sv["export"]["read_first"] = len(bpy.data.collections[dname]["flank_plan_json"]) > 100_000
        sv["export"]["kept"] = dname in runs_mod._PLANS
        dcoll = bpy.data.collections[dname]
        if any(o.get("flank_anim_role") == "motion" for o in dcoll.objects):
            sv["animation"] = _anim_check(bpy, np, screw, dcoll, json.loads(dcoll["flank_plan_json"]),
                                          bpy.data.objects[dcoll["flank_df_rotor"]], "flank_df_", 0)
    res["reload"] = sv
    res["leftover_staging"] = [f for f in _listing(tmp) if f.startswith(".flank_export_")]
    res["plans_kept"] = driver.plans_kept(bpy)     # after every operator that read a run's plan
