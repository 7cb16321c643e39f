# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.post_program through the installed extension, in background mode, for test_blender_machine.py.

A mm scene, the tool preset "Tapered 2deg D3 L25" (dimensions and cutting data), a 4-lobe srm_a male rotor of
outer radius 30 mm and length 60 mm, single-flank plan of flank 0 (few seeds); then the Machine panel's Post
Program call (rotor-xa-b, LinuxCNC, lobes 0,2), animated.  Recorded: the written program and the plan (for the
command line's post in the test), the run's program properties and the panels' labels, the program path's
attributes, the animation at sampled frames against the core's reader (the program's poses by forward
kinematics), a post with holders, a re-post (Fanuc on xyzac-trt, not animated) replacing the first, and the
refusals."""
import glob
import json
import math
import os
import time

import driver

PRESET = "Tapered 2deg D3 L25"
HOLDERS = "low,100,40,150; high,80,30,150"      # mm: clear of the passes' run-out


def _blocks(bpy):
    return dict(objects=len(bpy.data.objects), meshes=len(bpy.data.meshes), actions=len(bpy.data.actions),
                collections=len(bpy.data.collections), curves=len(bpy.data.curves))


def _call(bpy, **kw):
    """(result, error, new data-blocks, seconds) of flank.post_program(**kw)."""
    before = _blocks(bpy)
    t0 = time.perf_counter()
    ret, err = driver._run_op(bpy.ops.flank.post_program, **kw)
    after = _blocks(bpy)
    return dict(result=ret, error=err, seconds=time.perf_counter() - t0,
                new={k: after[k] - before[k] for k in before})


def _path_facts(np, ob):
    me = ob.data
    motion = np.empty(len(me.edges), dtype=np.int32)
    me.attributes["motion"].data.foreach_get("value", motion)
    passes = np.empty(len(me.edges), dtype=np.int32)
    me.attributes["pass"].data.foreach_get("value", passes)
    ev = np.empty(2 * len(me.edges), dtype=np.int32)
    me.edges.foreach_get("vertices", ev)
    ev = ev.reshape(-1, 2)
    cut = ev[motion == 1]
    # chains of cutting edges: an edge starts a chain unless the previous cutting edge ends where it starts
    starts = int(np.sum(np.r_[True, cut[1:, 0] != cut[:-1, 1]])) if len(cut) else 0
    co = np.empty(3 * len(me.vertices))
    me.vertices.foreach_get("co", co)
    return dict(name=ob.name, edges=len(me.edges), vertices=len(me.vertices), motion_values=sorted(set(motion.tolist())),
                cutting_edges=int((motion == 1).sum()), rapid_edges=int((motion == 0).sum()),
                cutting_chains=starts, pass_values=sorted(set(passes[motion == 1].tolist())),
                rapid_pass_values=sorted(set(passes[motion == 0].tolist())),
                attr_domains={a.name: [a.domain, a.data_type] for a in me.attributes if a.name in ("motion", "pass")},
                max_radius=float(np.hypot(co[0::3], co[1::3]).max()),
                matrix=[list(r) for r in ob.matrix_world], hidden=ob.hide_get())


def _animation_check(bpy, np, coll, text, plan):
    """The tool relative to the turning rotor copy at frames of block ends and pass middles, against the poses
    the core's reader and forward kinematics give for the written program."""
    core = {m: driver._core(m) for m in ("posts", "machining.machine", "machining.cycle_time",
                                         "machining.rotor_body", "machining.operation")}
    machine = core["machining.machine"].load_machine("rotor-xa-b")
    read = core["posts"].get_post("linuxcnc").read(text, machine)
    op = core["machining.operation"].build_operation([plan], core["machining.rotor_body"].rotor_body(plan),
                                                     lobes=[0, 2], cutting_data=None)
    gauge = op.tools[0].gauge_length
    minutes = np.array(core["machining.cycle_time"].cycle_time(read, machine, {1: gauge})["block_minutes"])
    ends = 60.0 * np.cumsum(minutes)
    total = ends[-1]
    role = "flank_anim_role"
    spin = next(ob for ob in coll.objects if ob.get(role) == "spin")
    tool = next(ob for ob in coll.objects if ob.get(role) == "tool")
    copy = next(ob for ob in coll.objects if ob.get(role) == "rotor")
    frame = next(ob for ob in coll.objects if ob.get(role) == "frame")
    rotor = bpy.data.objects[copy.name.replace(" (program)", "")]
    fs, fe = (int(v) for v in coll["flank_prog_frames"])
    samples = []
    for i, mv in enumerate(read.moves):
        if not np.isfinite(mv.start).all():
            continue
        fracs = (0.5, 1.0) if mv.kind == "feed" else (1.0,)
        for u in fracs:
            samples.append((i, u, mv.kind, ends[i] - (1.0 - u) * 60.0 * minutes[i]))
    out = []
    for i, u, kind, t in samples:
        f = fs + (fe - fs) * t / total
        bpy.context.scene.frame_set(int(math.floor(f)), subframe=float(f - math.floor(f)))
        rel = np.linalg.inv(np.array(spin.matrix_world)) @ np.array(tool.matrix_world)
        mv = read.moves[i]
        row = (1.0 - u) * mv.start + u * mv.end
        P, A = machine.forward(row[None, :], gauge)
        axis = rel[:3, 2] / np.linalg.norm(rel[:3, 2])
        rotor_rel = np.linalg.inv(np.array(spin.matrix_world)) @ np.array(copy.matrix_world)
        rest = np.linalg.inv(np.array(frame.matrix_world)) @ np.array(rotor.matrix_world)
        out.append(dict(move=i, u=u, kind=kind, frame=f, tip_error=float(np.linalg.norm(rel[:3, 3] - P[0])),
                        axis_error=float(np.linalg.norm(axis - A[0])), rotor_error=float(np.abs(rotor_rel - rest).max()),
                        spin_deg=float(math.degrees(spin.matrix_world.to_euler()[2])), A=float(row[3])))
    bpy.context.scene.frame_set(fs)
    return dict(samples=out, moves=len(read.moves), total_s=float(total), gauge=gauge,
                animated_s=float(coll["flank_prog_animated_seconds"]),
                tool_fcurves=driver._fcurve_keys(tool.animation_data.action),
                spin_fcurves=driver._fcurve_keys(spin.animation_data.action))


def _two_tool_keys(np, plan):
    """The animation keys (the extension's ``program_keys``) of a two-tool program on rotor-xa-b: the plan, then
    a copy of it whose tool has a 1% thinner shank (another tool number), lobe 0."""
    import copy

    program = __import__(driver.MODULE + ".operators.program", fromlist=["x"])
    core = {m: driver._core(m) for m in ("posts", "machining.machine", "machining.cycle_time",
                                         "machining.rotor_body", "machining.operation", "machining.toolpath")}
    second = copy.deepcopy(plan)
    for strip in second["strips"]:
        strip["shank_radius"] *= 0.99
    machine = core["machining.machine"].load_machine("rotor-xa-b")
    op = core["machining.operation"].build_operation([plan, second], core["machining.rotor_body"].rotor_body(plan),
                                                     lobes=[0], cutting_data=None)
    post = core["posts"].get_post("linuxcnc")
    read = post.read(post.write(core["machining.toolpath"].build_program(op, machine)), machine)
    gauges = {t.number: t.gauge_length for t in op.tools}
    minutes = core["machining.cycle_time"].cycle_time(read, machine, gauges)["block_minutes"]
    keys = program.program_keys(read, machine, gauges, minutes, program.move_rows(read, machine, gauges))
    last_1 = int(np.flatnonzero(keys["tools"] == 1)[-1])
    first_2 = int(np.flatnonzero(keys["tools"] == 2)[0])
    frames = program.key_frames(keys["seconds"], keys["total"], 1, 250)
    spin_kept = __import__(driver.MODULE + ".operators.program_scene", fromlist=["x"]).strictly_increasing(frames)
    return dict(tools=len(op.tools), changes=len(read.tool_changes), tool_change_s=machine.tool_change_s,
                moves_s=60.0 * float(np.sum(minutes)), total=float(keys["total"]), keys=len(keys["seconds"]),
                increasing=bool(np.all(np.diff(keys["seconds"]) >= 0.0)), last_1=last_1, first_2=first_2,
                gap=float(keys["seconds"][first_2] - keys["seconds"][last_1]),
                spin_keeps_both=bool(last_1 in spin_kept and first_2 in spin_kept))


def _errors(bpy, tmp, coll_name, good):
    """Refusals: each leaves no data-block, no program file and no temporary file behind."""
    bad_machine = os.path.join(tmp, "tight_b.json")
    with open(os.path.join(os.path.dirname(driver._core("machining.machine").__file__), "machines",
                           "rotor-xa-b.json")) as fh:
        data = json.load(fh)
    data["name"] = "rotor-xa-b tight B"
    data["rotary_axes"]["B"].update(min=-5.0, max=5.0)
    with open(bad_machine, "w") as fh:
        json.dump(data, fh)
    target = os.path.join(tmp, "refused.ngc")
    cases = {
        "empty_path": dict(filepath=""),
        "relative_path": dict(filepath="relative_program.ngc"),
        "missing_folder": dict(filepath=os.path.join(tmp, "no_such_folder", "p.ngc")),
        "folder": dict(filepath=tmp),
        "unwritable": dict(filepath="/proc/flank_program.ngc"),
        "unknown_machine": dict(filepath=target, machine="mill-9000"),
        "unknown_post": dict(filepath=target, post="haas"),
        "unreachable": dict(filepath=target, machine=bad_machine),
        "clearance_nan": dict(filepath=target, clearance=float("nan")),
        "clearance_inf": dict(filepath=target, clearance=float("inf")),
        "clearance_neg": dict(filepath=target, clearance=-1.0),
        "clearance_huge": dict(filepath=target, clearance=1e9),
        "flutes_neg": dict(filepath=target, tool_flutes=-1),
        "fz_nan": dict(filepath=target, tool_feed_per_tooth_mm=float("nan")),
        "rpm_neg": dict(filepath=target, tool_max_rpm=-1.0),
        "lobes_text": dict(filepath=target, lobes="0,x"),
        "lobes_range": dict(filepath=target, lobes="9"),
        "frames": dict(filepath=target, frame_start=10, frame_end=10),
        "holders_text": dict(filepath=target, holders="low,80"),
        "holders_side": dict(filepath=target, holders="left,80,40"),
        "holder_in_run_out": dict(filepath=target, holders="low,100,40"),
        "mist_klartext": dict(filepath=os.path.join(tmp, "refused.h"), post="heidenhain", coolant="mist"),
    }
    out = {}
    for name, kw in cases.items():
        r = _call(bpy, **dict(good, collection=coll_name, **kw))
        r["file"] = any(os.path.exists(p) for p in (target, os.path.join(tmp, "refused.h"),
                                                    os.path.join(os.getcwd(), "relative_program.ngc")))
        r["temp_files"] = sorted(os.path.basename(p) for p in glob.glob(os.path.join(tmp, ".flank-*")))
        out[name] = r
    return out


def _check(bpy, coll, **kw):
    """(result, error, new data-blocks, the run's check properties, the checked program's path and the posted
    program's path objects) of flank.check_program(**kw)."""
    before = _blocks(bpy)
    t0 = time.perf_counter()
    ret, err = driver._run_op(bpy.ops.flank.check_program, **kw)
    after = _blocks(bpy)
    import numpy as np

    return dict(result=ret, error=err, seconds=time.perf_counter() - t0, new={k: after[k] - before[k] for k in before},
                props={k: v for k, v in driver._obj_props(coll).items() if k.startswith("flank_check_")},
                checked=[_path_facts(np, ob) for ob in coll.objects if ob.get("flank_prog_role") == "checked"],
                posted_paths=sorted(ob.name for ob in coll.objects if ob.get("flank_prog_role") == "path"))


def _checks(bpy, tmp, coll, settings, prog_path):
    """Check Program File: the program Post Program wrote (the Machine panel's call), with the post told by the
    extension, the same program edited by hand (one pass's end turned 0.5 deg further), checked against half the
    Tool panel's feed per tooth, checked as a dry cut, checked with a chuck in the run-out, and the refusals (each
    leaves the run's earlier check as it was)."""
    machine_panel = __import__(driver.MODULE + ".panels.machine", fromlist=["x"])
    checker = __import__(driver.MODULE + ".operators.check_program", fromlist=["x"])
    call = dict(machine_panel.check_call(settings), collection=coll.name)
    out = dict(call={k: v for k, v in call.items()})
    out["as_posted"] = _check(bpy, coll, **call)
    out["as_posted"]["lines"] = checker.check_lines(coll)
    out["panel"] = driver._draw_panels(bpy, bpy.context.active_object)["FLANK_PT_machine"]
    out["by_extension"] = _check(bpy, coll, **dict(call, post=""))

    text = open(prog_path).read()
    lines = text.splitlines(keepends=True)
    k = next(i for i, line in enumerate(lines) if line.startswith("G1 ") and " A" in line)
    words = lines[k].split()
    j = next(i for i, w in enumerate(words) if w.startswith("A"))
    words[j] = "A{:.4f}".format(float(words[j][1:]) + 0.5)
    lines[k] = " ".join(words) + "\n"
    edited = os.path.join(tmp, "edited.ngc")
    with open(edited, "w") as fh:
        fh.write("".join(lines))
    out["edited_file"] = edited
    out["edited"] = _check(bpy, coll, **dict(call, filepath=edited))
    out["edited"]["lines"] = checker.check_lines(coll)
    out["edited"]["panel"] = driver._draw_panels(bpy, bpy.context.active_object)["FLANK_PT_machine"]
    half = dict(call, tool_feed_per_tooth_mm=call["tool_feed_per_tooth_mm"] / 2)
    out["half_fz"] = _check(bpy, coll, **half)
    out["half_fz"]["call"] = {k: v for k, v in half.items()}
    out["dry"] = _check(bpy, coll, **dict(call, coolant="off"))
    out["chuck"] = _check(bpy, coll, **dict(call, holders="low,100,40,2"))
    out["chuck"]["lines"] = checker.check_lines(coll)
    out["chuck"]["panel"] = driver._draw_panels(bpy, bpy.context.active_object)["FLANK_PT_machine"]

    for name, content in (("copy.nc", text), ("copy.txt", text), ("garbage.ngc", "G1 X1 Q\nhello\n"),
                          ("tape.ngc", "%\n\n%\n")):
        with open(os.path.join(tmp, name), "w") as fh:
            fh.write(content)
    cases = {
        "empty_path": dict(filepath=""),
        "relative_path": dict(filepath="relative_program.ngc"),
        "missing": dict(filepath=os.path.join(tmp, "no_such_program.ngc")),
        "folder": dict(filepath=tmp),
        "other_extension": dict(filepath=os.path.join(tmp, "copy.nc")),
        "unknown_extension": dict(filepath=os.path.join(tmp, "copy.txt"), post=""),
        "unknown_machine": dict(machine="mill-9000"),
        "unknown_post": dict(post="haas"),
        "lobes_text": dict(lobes="0,x"),
        "lobes_range": dict(lobes="9"),
        "holders_text": dict(holders="low,80"),
        "flutes": dict(tool_flutes=0),
        "feed_per_tooth": dict(tool_feed_per_tooth_mm=-0.01),
        "garbage": dict(filepath=os.path.join(tmp, "garbage.ngc")),
        "tape_only": dict(filepath=os.path.join(tmp, "tape.ngc")),
    }
    out["refused"] = {name: _check(bpy, coll, **dict(call, **kw)) for name, kw in cases.items()}
    return out


def scenario(bpy, res, args):
    import numpy as np

    tmp = os.path.abspath(os.getcwd())
    machine_panel = __import__(driver.MODULE + ".panels.machine", fromlist=["x"])
    ui_ops = __import__(driver.MODULE + ".operators.ui_ops", fromlist=["x"])
    presets = __import__(driver.MODULE + ".operators.tool_preview", fromlist=["x"])
    feeds = driver._core("machining.feeds")
    scene = bpy.context.scene
    s = scene.flank_settings
    t_start = time.perf_counter()

    # ---------------------------------------------------------------- defaults, nothing planned yet
    res["defaults"] = dict(tool=[s.tool_flutes, s.tool_cutting_speed_m_min, s.tool_feed_per_tooth_mm, s.tool_max_rpm],
                           core=[feeds.DEFAULT_END_MILL.flutes, feeds.DEFAULT_END_MILL.vc_m_min,
                                 feeds.DEFAULT_END_MILL.fz_mm, feeds.DEFAULT_END_MILL.max_rpm],
                           machine=s.machine, post=s.post, clearance=s.clearance, lobes=s.lobes,
                           machines=[i.identifier for i in s.bl_rna.properties["machine"].enum_items],
                           posts=[i.identifier for i in s.bl_rna.properties["post"].enum_items],
                           coolants=[[i.identifier, i.name] for i in s.bl_rna.properties["coolant"].enum_items],
                           coolant=s.coolant,
                           builtin_machines=driver._core("machining.machine").builtin_machines())
    res["no_run"] = _call(bpy, filepath=os.path.join(tmp, "none.ngc"))
    res["no_run"]["file"] = os.path.exists(os.path.join(tmp, "none.ngc"))
    res["no_run_default"] = _call(bpy)

    # ---------------------------------------------------------------- the preset, the rotor, the plan
    us = scene.unit_settings
    us.system, us.scale_length = 'METRIC', 0.001
    path = os.path.join(presets.SHIPPED_PRESETS, PRESET + ".py")
    res["preset"] = driver._run_op(bpy.ops.script.execute_preset, filepath=path, menu_idname="FLANK_MT_tool_presets")
    d = feeds.PRESET_CUTTING_DATA[PRESET]
    res["preset_cutting"] = dict(settings=[s.tool_flutes, s.tool_cutting_speed_m_min, s.tool_feed_per_tooth_mm,
                                           s.tool_max_rpm], core=[d.flutes, d.vc_m_min, d.fz_mm, d.max_rpm])
    driver._run_op(bpy.ops.flank.generate_rotor, kind="srm_a", part="male", scale=30.0, length=60.0, resolution=360,
                   axial=24)
    rotor = bpy.context.active_object
    idname, kw = ui_ops.run_call(s)
    kw.update(flank=0, tolerance=0.05, seeds=4, rounds=1, envelope_rings=8, animate=False)
    t0 = time.perf_counter()
    res["plan"] = dict(zip(("result", "error"), driver._run_op(bpy.ops.flank.plan_single_flank, **kw)))
    res["plan"]["seconds"] = time.perf_counter() - t0
    coll = next(c for c in bpy.data.collections["Flank Results"].children if "flank_plan_json" in c)
    plan = json.loads(coll["flank_plan_json"])
    res["plan"].update(strips=len(plan["strips"]), unit=plan["length_unit"], extent=plan["rotor"].get("extent"),
                       tool=plan["tool"], rotor=rotor.name)
    plan_path = os.path.join(tmp, "plan.json")
    with open(plan_path, "w") as fh:
        json.dump(plan, fh)
    res["plan_file"] = plan_path

    # ---------------------------------------------------------------- Post Program from the Machine panel
    prog_path = os.path.join(tmp, "program.ngc")
    s.program_filepath, s.lobes = prog_path, "0,2"
    scene.frame_start, scene.frame_end = 1, 250
    call = machine_panel.post_call(s, scene)
    res["panel_call"] = {k: (v if isinstance(v, (bool, int, float, str)) else repr(v)) for k, v in call.items()}
    bpy.context.view_layer.objects.active = rotor
    res["post"] = _call(bpy, **call)
    res["post"]["file"] = prog_path if os.path.exists(prog_path) else None
    res["post"]["text"] = open(prog_path).read() if os.path.exists(prog_path) else ""
    res["post"]["props"] = driver._obj_props(coll)
    path_ob = next((ob for ob in coll.objects if ob.get("flank_prog_role") == "path"), None)
    res["post"]["path"] = _path_facts(np, path_ob) if path_ob is not None else None
    res["post"]["rotor_hidden"] = rotor.hide_get()
    res["post"]["anim_roles"] = sorted(ob.get("flank_anim_role") for ob in coll.objects if "flank_anim_role" in ob)
    res["post"]["temp_files"] = sorted(os.path.basename(p) for p in glob.glob(os.path.join(tmp, ".flank-*")))
    res["panels"] = driver._draw_panels(bpy, bpy.context.active_object)
    res["animation"] = _animation_check(bpy, np, coll, res["post"]["text"], plan)

    res["two_tools"] = _two_tool_keys(np, plan)

    # ---------------------------------------------------------------- refusals
    good = dict(call, filepath=prog_path)
    before = res["post"]["text"]
    res["errors"] = _errors(bpy, tmp, coll.name, good)
    res["program_unchanged"] = open(prog_path).read() == before

    # ---------------------------------------------------------------- held by a chuck and a tailstock, far enough
    held = os.path.join(tmp, "held.ngc")
    res["held"] = _call(bpy, **dict(call, filepath=held, animate=False, collection=coll.name,
                                    holders=HOLDERS))
    path_ob = next((ob for ob in coll.objects if ob.get("flank_prog_role") == "path"), None)
    res["held"].update(props=driver._obj_props(coll), path=_path_facts(np, path_ob) if path_ob else None,
                       text=open(held).read() if os.path.exists(held) else "")
    holders_ob = next((ob for ob in coll.objects if ob.get("flank_prog_role") == "holders"), None)
    if holders_ob is not None:          # its vertices in the rotor frame, mm (the path's placement)
        M = np.array(holders_ob.matrix_world)
        co = np.empty(3 * len(holders_ob.data.vertices))
        holders_ob.data.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3)
        rotor_mm = (np.linalg.inv(np.array(path_ob.matrix_world)) @ M @ np.c_[co, np.ones(len(co))].T).T[:, :3]
        rho = np.hypot(rotor_mm[:, 0], rotor_mm[:, 1])
        res["held"]["holders_object"] = dict(
            name=holders_ob.name, same_matrix=bool(np.allclose(M, np.array(path_ob.matrix_world))),
            z=[float(rotor_mm[:, 2].min()), float(rotor_mm[:, 2].max())], max_rho=float(rho.max()),
            extent=plan["rotor"]["extent"]["z_range"])

    # ---------------------------------------------------------------- Check Program File
    res["checks"] = _checks(bpy, tmp, coll, s, prog_path)

    # ---------------------------------------------------------------- Read Back off, and a read-back that fails
    post_mod = __import__(driver.MODULE + ".operators.post_program", fromlist=["x"])
    quiet = os.path.join(tmp, "no_read_back.ngc")
    res["no_read_back"] = _call(bpy, **dict(call, filepath=quiet, animate=False, collection=coll.name,
                                            read_back=False))
    res["no_read_back"].update(keys=sorted(k for k in coll.keys() if k.startswith("flank_prog_read_back_")),
                               lines=post_mod.read_back_lines(coll), file=os.path.exists(quiet))
    checker = __import__(driver.MODULE + ".flank_addon.posts.readback", fromlist=["x"])
    real = checker.verify_program

    def broken(*args, **kwargs):
        raise ValueError("the check broke")
    checker.verify_program = broken
    try:
        failing = os.path.join(tmp, "read_back_fails.ngc")
        res["read_back_fails"] = _call(bpy, **dict(call, filepath=failing, animate=False, collection=coll.name))
    finally:
        checker.verify_program = real
    res["read_back_fails"].update(keys=sorted(k for k in coll.keys() if k.startswith("flank_prog_read_back_")),
                                  error_prop=coll.get("flank_prog_read_back_error"),
                                  lines=post_mod.read_back_lines(coll),
                                  same_text=os.path.exists(failing) and open(failing).read() == open(quiet).read())

    # ---------------------------------------------------------------- re-post: Fanuc on xyzac-trt, no animation
    nc = os.path.join(tmp, "program.nc")
    res["repost"] = _call(bpy, **dict(call, filepath=nc, machine="xyzac-trt", post="fanuc", animate=False,
                                      collection=coll.name))
    text = open(nc).read() if os.path.exists(nc) else ""
    core = driver._core("posts")
    mach = driver._core("machining.machine").load_machine("xyzac-trt")
    read = core.get_post("fanuc").read(text, mach) if text else None
    feeds_runs = 0
    prev = "rapid"
    for mv in (read.moves if read else []):
        feeds_runs += mv.kind == "feed" and prev != "feed"
        prev = mv.kind
    res["repost"].update(props=driver._obj_props(coll), read_passes=feeds_runs, moves=len(read.moves) if read else 0,
                         returns=[r[0] for r in read.reference_returns] if read else None,
                         time_lines=post_mod.cycle_time_lines(coll),
                         path_objects=sorted(ob.name for ob in coll.objects if ob.get("flank_prog_role") == "path"),
                         anim_objects=sorted(ob.name for ob in coll.objects if "flank_anim_role" in ob),
                         rotor_hidden=rotor.hide_get(),
                         orphans=dict(meshes=sum(1 for m in bpy.data.meshes if m.users == 0),
                                      actions=sum(1 for a in bpy.data.actions if a.users == 0)))

    # ---------------------------------------------------------------- an analysed mesh knows its extent too
    copy = bpy.data.objects.new("Analysed Copy", rotor.data.copy())
    scene.collection.objects.link(copy)
    bpy.context.view_layer.objects.active = copy
    t0 = time.perf_counter()
    ret = driver._run_op(bpy.ops.flank.analyze_rotor)
    sources = __import__(driver.MODULE + ".operators.sources", fromlist=["x"])
    src = sources.rotor_source(copy)
    res["analysed"] = dict(result=ret, kind=src.get("kind") if isinstance(src, dict) else src,
                           extent=src.get("extent") if isinstance(src, dict) else None,
                           seconds=time.perf_counter() - t0)
    res["seconds_total"] = time.perf_counter() - t_start
    res["plans_kept"] = driver.plans_kept(bpy)     # after every operator that read a run's plan
