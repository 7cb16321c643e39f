# SPDX-License-Identifier: GPL-3.0-or-later
"""For bench/bench_main_loop_waits.py (not a test): the free-form planner's modal run on a bump of
2 x resolution^2 triangles, with the main thread run as Blender's main loop runs it -- turns of 1 ms (events,
redraws) and a poll of the operator every 0.1 s -- recording the longest waits between two turns: the time the
interface would not answer because a worker held Python's interpreter lock."""
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


def scenario(bpy, res, args):
    import numpy as np

    ff_mod = __import__(driver.MODULE + ".operators.freeform", fromlist=["x"])
    ob, res["triangles"] = _surface_object(bpy, np, int(args.resolution))
    sm.driver_select(bpy, ob)
    cls = ff_mod.FLANK_OT_plan_freeform
    rec = {}

    def execute(op, context):
        wm = sm.WindowManager(context.window_manager)
        ws = sm.Workspace(getattr(context, "workspace", None))
        windows = list(context.window_manager.windows)
        ctx = sm.Context(context, wm, windows[0] if windows else None, ws)
        t0 = time.perf_counter()
        r = op._start_modal(ctx)
        rec["start_ms"] = 1e3 * (time.perf_counter() - t0)
        last = next_poll = time.perf_counter()
        waits, polls = [], []
        while r == {'RUNNING_MODAL'}:
            time.sleep(0.001)
            now = time.perf_counter()
            waits.append((now - last, ws.texts[-1] if ws.texts else None))
            if now >= next_poll:
                next_poll = now + 0.1
                t = time.perf_counter()
                r = op.modal(ctx, sm.Event('TIMER'))
                polls.append(1e3 * (time.perf_counter() - t))
            last = time.perf_counter()
        rec.update(final=sorted(r), wall_s=time.perf_counter() - t0, polls=len(polls), longest_poll_ms=max(polls),
                   waits=sorted(((1e3 * w, m) for w, m in waits), key=lambda x: -x[0])[:8])
        return r

    cls.execute = execute
    try:
        ret, err = driver._run_op(bpy.ops.flank.plan_freeform, r1=0.01, r2=0.03, length=0.09, samples=30,
                                  columns=20, direction=(1.0, 0.0, 0.0))
    finally:
        del cls.execute
    rec.update(op_result=ret, op_error=err)
    res["freeform"] = rec
