# SPDX-License-Identifier: GPL-3.0-or-later
"""For bench/bench_main_loop_waits.py (not a test): modal runs with the main thread run as Blender's main loop
runs it -- turns of 1 ms (events, redraws) and a poll of the operator every 0.1 s -- recording the longest waits
between two turns: the time the interface would not answer because a worker held Python's interpreter lock.
The free-form planner on a bump of 2 x resolution^2 triangles; on the built-in rotor at Generate Rotor's defaults:
Analyze Rotor, the double-flank and single-flank planners, Error Plot and Verify of the double-flank run, and its
whole-rotor program for the default machine and post."""
import os
import time

import driver
import scenario_modal as sm


def _surface_object(bpy, np, resolution):
    bump = __import__(driver.MODULE + ".flank_addon.geometry.freeform_surfaces", fromlist=["x"]).bump
    S = bump(size=1.0, resolution=resolution)
    V, F = np.asarray(S.vertices), np.asarray(S.faces)
    me = bpy.data.meshes.new("bump")
    me.vertices.add(len(V))
    me.vertices.foreach_set("co", V.astype(np.float32).ravel())
    me.loops.add(3 * len(F))
    me.loops.foreach_set("vertex_index", F.astype(np.int32).ravel())
    me.polygons.add(len(F))
    me.polygons.foreach_set("loop_start", np.arange(0, 3 * len(F), 3, dtype=np.int32))
    me.update()
    ob = bpy.data.objects.new("bump", me)
    bpy.context.scene.collection.objects.link(ob)
    return ob, len(F)


def _main_loop(cls, op, kw):
    """Run ``op(**kw)`` with ``cls.execute`` replaced by a main loop of 1 ms turns polling the modal run every
    0.1 s -> the record: the longest waits between turns (with the status then), the longest poll, the run."""
    rec = {}

    def execute(self, context):
        wm = sm.WindowManager(context.window_manager)
        ws = sm.Workspace(getattr(context, "workspace", None))
        windows = list(context.window_manager.windows)
        ctx = sm.Context(context, wm, windows[0] if windows else None, ws)
        t0 = time.perf_counter()
        r = self._start_modal(ctx)
        rec["start_ms"] = 1e3 * (time.perf_counter() - t0)
        last = next_poll = time.perf_counter()
        waits, polls = [], [0.0]
        while r == {'RUNNING_MODAL'}:
            time.sleep(0.001)
            now = time.perf_counter()
            waits.append((now - last, ws.texts[-1] if ws.texts else None))
            if now >= next_poll:
                next_poll = now + 0.1
                t = time.perf_counter()
                r = self.modal(ctx, sm.Event('TIMER'))
                polls.append(1e3 * (time.perf_counter() - t))
            last = time.perf_counter()
        rec.update(final=sorted(r), wall_s=time.perf_counter() - t0, polls=len(polls) - 1,
                   longest_poll_ms=max(polls),
                   waits=sorted(((1e3 * w, m) for w, m in waits), key=lambda x: -x[0])[:8] or [(0.0, None)] * 2)
        return r

    cls.execute = execute
    try:
        ret, err = driver._run_op(op, **kw)
    finally:
        del cls.execute
    rec.update(op_result=ret, op_error=err)
    return rec


def scenario(bpy, res, args):
    import numpy as np

    mods = {name: __import__(driver.MODULE + ".operators." + name, fromlist=["x"])
            for name in ("freeform", "double_flank", "single_flank", "profile_plot", "analyze", "verify",
                         "post_program")}
    out = res["operators"] = {}
    ob, res["triangles"] = _surface_object(bpy, np, int(args.resolution))
    sm.driver_select(bpy, ob)
    out["free-form, bump"] = _main_loop(mods["freeform"].FLANK_OT_plan_freeform, bpy.ops.flank.plan_freeform,
                                        dict(r1=0.01, r2=0.03, length=0.09, samples=30, columns=20,
                                             direction=(1.0, 0.0, 0.0)))
    # the built-in rotor at the Generate Rotor defaults (279,360 triangles), each planner at its defaults
    driver._run_op(bpy.ops.flank.generate_rotor)
    rotor = bpy.context.active_object
    res["rotor_triangles"] = sum(len(p.vertices) - 2 for p in rotor.data.polygons)
    sm.driver_select(bpy, rotor)
    out["analyze rotor"] = _main_loop(mods["analyze"].FLANK_OT_analyze_rotor, bpy.ops.flank.analyze_rotor, {})
    sm.driver_select(bpy, rotor)
    out["double-flank"] = _main_loop(mods["double_flank"].FLANK_OT_plan_double_flank,
                                     bpy.ops.flank.plan_double_flank, {})
    run = next((c.name for c in bpy.data.collections if "flank_plan_json" in c
                and c.name.startswith("Double Flank")), "")
    sm.driver_select(bpy, rotor)
    out["single-flank"] = _main_loop(mods["single_flank"].FLANK_OT_plan_single_flank,
                                     bpy.ops.flank.plan_single_flank, {})
    out["error plot, double-flank run"] = _main_loop(mods["profile_plot"].FLANK_OT_error_plot,
                                                     bpy.ops.flank.error_plot, dict(collection=run))
    if run:
        plan_path = os.path.join(os.path.abspath(os.getcwd()), "df_plan.json")
        with open(plan_path, "w") as fh:
            fh.write(bpy.data.collections[run]["flank_plan_json"])
        sm.driver_select(bpy, rotor)
        out["verify, double-flank plan"] = _main_loop(mods["verify"].FLANK_OT_verify_plan, bpy.ops.flank.verify_plan,
                                                      dict(filepath=plan_path))
        us = bpy.context.scene.unit_settings
        us.system, us.scale_length = 'METRIC', 0.001
        out["post program, whole rotor"] = _main_loop(
            mods["post_program"].FLANK_OT_post_program, bpy.ops.flank.post_program,
            dict(collection=run, filepath=os.path.join(os.path.abspath(os.getcwd()), "rotor.ngc")))
    # what one full collection of the garbage collector costs now, with everything these runs left (the kept
    # plans among it), and how many objects it goes through
    import gc
    gc.collect()
    t = time.perf_counter()
    gc.collect()
    res["full_collection_ms"] = 1e3 * (time.perf_counter() - t)
    res["tracked_objects"] = len(gc.get_objects())
