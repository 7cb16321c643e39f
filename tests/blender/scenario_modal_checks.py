# SPDX-License-Identifier: GPL-3.0-or-later
"""Verify (flank.verify_plan), Error Plot (flank.error_plot), Check Tool (flank.cutter_region), Post Program
(flank.post_program) and Check Program File (flank.check_program) through the modal Run path (operators/modal.py), for test_blender_modal_checks.py.

Each operator's ``execute`` is replaced for one call by scenario_modal's driver (``_start_modal`` + ``modal()``
with TIMER / ESC events and a stand-in context): ESC and closing leave a full census of bpy.data and the scene
unchanged, a modal run to the end makes what the synchronous run makes, and the driver records how long every
``modal()`` call held the main thread."""
import json
import os
import sys
import time

import driver
import scenario_modal as sm


def _verify_state(bpy, np, name):
    ob = bpy.data.objects[name]
    dev = driver._float_attr(np, ob.data, "machined_deviation")
    # the values themselves: a verification in another thread may round the last bit of a deviation differently
    return dict(deviation=None if dev is None else [float(v) for v in dev],
                props={k: sm._plain(ob[k]) for k in ob.keys() if k.startswith("flank_verify_")
                       and k not in ("flank_verify_elapsed", "flank_verify_summary")},
                summary={k: v for k, v in json.loads(ob["flank_verify_summary"]).items() if k != "elapsed_s"}
                if "flank_verify_summary" in ob else None)


def _plot_state(bpy, np, run_name):
    img = next((i for i in bpy.data.images if i.get("flank_plot_run") == run_name), None)
    if img is None:
        return None
    px = np.empty(img.size[0] * img.size[1] * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    return dict(name=img.name, size=list(img.size), pixels=sm._digest(px.tobytes()),
                props={k: sm._plain(img[k]) for k in img.keys() if k.startswith("flank_plot_")})


def _post_state(bpy, np, run_name, path):
    """The run's program: its properties (but the time the posting took), the file, the path mesh and the
    animation's data-blocks."""
    coll = bpy.data.collections[run_name]
    props = {k: sm._plain(coll[k]) for k in coll.keys() if k.startswith("flank_prog_") and k != "flank_prog_elapsed"}
    if not props:
        return None
    text = open(path).read() if os.path.isfile(path) else None
    path_ob = next((o for o in coll.all_objects if o.type == 'MESH' and "motion" in o.data.attributes), None)
    return dict(props=props, file=None if text is None else sm._digest(text), lines=None if text is None else
                len(text.splitlines()), path=None if path_ob is None else dict(
                    edges=len(path_ob.data.edges), co=sm._digest(driver._mesh_co(np, path_ob).tobytes())),
                objects=len(coll.all_objects), actions=len(bpy.data.actions))


def _check_state(bpy, run_name):
    """The run's program check: its properties but the time it took."""
    coll = bpy.data.collections[run_name]
    return {k: sm._plain(coll[k]) for k in coll.keys() if k.startswith("flank_check_") and k != "flank_check_elapsed"}


def _exercise_check(bpy, np, check_cls, kw, select):
    def no_check():
        coll = bpy.data.collections[kw["collection"]]
        for key in [k for k in coll.keys() if k.startswith("flank_check_")]:
            del coll[key]

    out = sm.exercise_tool(bpy, np, bpy.ops.flank.check_program, check_cls, kw, select,
                           lambda: _check_state(bpy, kw["collection"]), before_each=no_check, cancel=False)
    real_compute, real_attr = check_cls._compute, check_cls.__dict__["_compute"]       # a static method

    def slow_compute(job, progress):
        for _ in range(50):
            if progress is not None and progress(0.0, "waiting") is False:
                break
            time.sleep(0.01)
        return real_compute(job, progress)

    check_cls._compute = staticmethod(slow_compute)
    try:
        out.update(sm.cancelled_runs(bpy, np, bpy.ops.flank.check_program, check_cls, kw, select, no_check))
        select()
        no_check()
        rec = sm._call(bpy, bpy.ops.flank.check_program, check_cls, "finish", **kw)
        rec["state"] = _check_state(bpy, kw["collection"])
        out["finish"] = rec
    finally:
        check_cls._compute = real_attr
    return out


def _region_state(bpy, np, key):
    coll = next((c for c in bpy.data.collections if c.get("flank_cr_key") == key), None)
    if coll is None:
        return None
    cloud = next(o for o in coll.objects if o.get("flank_cr_role") == "region")
    skip = ("flank_cr_total_elapsed", "flank_cr_dupin_elapsed", "flank_cr_bounds_elapsed", "flank_cr_region_elapsed")
    return dict(collection=coll.name, objects=sorted(o.name for o in coll.objects),
                cloud=sm._digest(driver._mesh_co(np, cloud).tobytes()),
                props={k: sm._plain(coll[k]) for k in coll.keys() if k.startswith("flank_cr_") and k not in skip})


def scenario(bpy, res, args):
    import numpy as np

    mods = {name: __import__(driver.MODULE + ".operators." + name, fromlist=["x"])
            for name in ("verify", "profile_plot", "cutter_region", "post_program", "check_program", "modal")}
    mixin = mods["modal"].ModalPlannerMixin
    classes = dict(verify=mods["verify"].FLANK_OT_verify_plan, error_plot=mods["profile_plot"].FLANK_OT_error_plot,
                   cutter_region=mods["cutter_region"].FLANK_OT_cutter_region,
                   post=mods["post_program"].FLANK_OT_post_program,
                   check=mods["check_program"].FLANK_OT_check_program)
    res["mixin"] = {k: issubclass(c, mixin) for k, c in classes.items()}
    res["timer_step"] = mods["modal"].TIMER_STEP

    driver._run_op(bpy.ops.flank.generate_rotor, kind="asymmetric", part="female", resolution=720, axial=24)
    rotor_name = bpy.context.active_object.name

    def select():
        sm.driver_select(bpy, bpy.data.objects[rotor_name])

    # a double-flank run on valley 0: its plan is what Error Plot draws and what Verify checks
    select()
    ret, err = driver._run_op(bpy.ops.flank.plan_double_flank, radii=40, envelope_rings=12, simulate=False)
    run = next((c for c in bpy.data.collections if c.get("flank_df_key") == "{}|0".format(rotor_name)
                and "flank_plan_json" in c), None)
    res["run"] = dict(result=ret, error=err, name=None if run is None else run.name)
    if run is None:
        return
    plan_path = os.path.join(os.path.abspath(os.getcwd()), "df_plan.json")
    with open(plan_path, "w") as fh:
        fh.write(run["flank_plan_json"])
    run_name = run.name

    res["verify"] = sm.exercise_tool(bpy, np, bpy.ops.flank.verify_plan, classes["verify"],
                                     dict(filepath=plan_path), select, lambda: _verify_state(bpy, np, rotor_name))
    res["error_plot"] = sm.exercise_tool(bpy, np, bpy.ops.flank.error_plot, classes["error_plot"],
                                         dict(collection=run_name, width=1920, height=1080), select,   # a full-HD plot
                                         lambda: _plot_state(bpy, np, run_name))
    res["cutter_region"] = sm.exercise_tool(bpy, np, bpy.ops.flank.cutter_region, classes["cutter_region"],
                                            dict(flank=1, r1=0.05, r2=0.08, alpha=0.1001674211615598,
                                                 grid=(12, 16, 16)),
                                            select, lambda: _region_state(bpy, np, "{}|1".format(rotor_name)))
    # Post Program: that run as a whole-rotor program (every lobe) for the default machine and post, with its path
    # and animation; before each run the program file the run before left is noted and removed
    program = os.path.join(os.path.abspath(os.getcwd()), "modal_program.ngc")
    program_seen = []

    def no_program():
        program_seen.append(os.path.exists(program))
        if program_seen[-1]:
            os.remove(program)

    us = bpy.context.scene.unit_settings
    units = us.system, us.scale_length
    us.system, us.scale_length = 'METRIC', 0.001              # the rotor's outer radius is 1 mm
    post_cls, post_kw = classes["post"], dict(collection=run_name, filepath=program)
    real_compute, real_attr = post_cls._compute, post_cls.__dict__["_compute"]       # a static method

    def slow_compute(job, progress):            # Esc and closing must land while the worker runs (0.1 s alone)
        for _ in range(50):
            if progress is not None and progress(0.0, "waiting") is False:
                break
            time.sleep(0.01)
        return real_compute(job, progress)

    try:
        # the synchronous run, then Esc, closing and the modal run to the end with the worker slowed down (its
        # progress is shown while it runs; alone it ends before the first poll)
        res["post"] = sm.exercise_tool(bpy, np, bpy.ops.flank.post_program, post_cls, post_kw, select,
                                       lambda: _post_state(bpy, np, run_name, program), before_each=no_program,
                                       cancel=False)
        post_cls._compute = staticmethod(slow_compute)
        res["post"].update(sm.cancelled_runs(bpy, np, bpy.ops.flank.post_program, post_cls, post_kw, select,
                                             no_program))
        select()
        no_program()
        rec = sm._call(bpy, bpy.ops.flank.post_program, post_cls, "finish", **post_kw)
        rec["state"] = _post_state(bpy, np, run_name, program)
        res["post"]["finish"] = rec
        # Check Program File on that program, in the same unit: the synchronous run, then Esc, closing and the
        # modal run to the end with its worker slowed down as the post's (each run starts without a check)
        res["check"] = _exercise_check(bpy, np, classes["check"], dict(collection=run_name, filepath=program), select)
    finally:
        post_cls._compute = real_attr
        us.system, us.scale_length = units
    # before the synchronous run, its modal run to the end (not kept), Esc, closing, the modal run to the end; after
    res["post_files"] = program_seen + [os.path.exists(program)]
    # Error Plot's stages: Esc while the second worker (text and PNG) runs, and a failure of the text's layout on
    # the main thread between the workers; either leaves bpy.data as it was and writes no file
    plot_cls = classes["error_plot"]
    real_next = plot_cls._next_stage
    png = os.path.join(os.path.abspath(os.getcwd()), "staged_plot.png")

    def slow_second_stage(op, context, job, out):
        stage = real_next(op, context, job, out)
        if not stage:
            return stage

        def slow(progress):
            for _ in range(10):                    # Esc must land while this worker runs
                time.sleep(0.05)
                progress(0.95, "text and PNG")
            return stage(progress)
        return slow

    def no_font(items):
        raise RuntimeError("no font for the chart's text")

    staged = {}
    for name, patch in (("esc_next_stage", ("_next_stage", slow_second_stage)), ("text_fails", None)):
        select()
        before = sm.census(bpy, np)
        mod = sys.modules[plot_cls.__module__]
        if patch:
            setattr(plot_cls, *patch)
        else:
            real_outlines, mod.text_outlines = mod.text_outlines, no_font
        try:
            rec = sm._call(bpy, bpy.ops.flank.error_plot, plot_cls, "esc_next_stage" if patch else "finish",
                           collection=run_name, width=640, height=400, filepath=png)
        finally:
            if patch:
                plot_cls._next_stage = real_next
            else:
                mod.text_outlines = real_outlines
        rec.update(census_equal=before == sm.census(bpy, np), png_written=os.path.exists(png))
        staged[name] = rec
    res["error_plot_stages"] = staged
    # a long plan that is not kept parsed (a file opened again) is read in a worker before Error Plot's own stages:
    # with the limit below this run's plan (0.9 MB), the modal run and the synchronous run start from an empty
    # cache; then a stored text that is not valid JSON is reported, changing nothing
    runs_mod = sys.modules[driver.MODULE + ".operators.runs"]
    real_defer, real_read = runs_mod.DEFER_CHARS, runs_mod.PlanNeeded.run
    runs_mod.DEFER_CHARS = 100_000

    def slow_read(needed, progress):               # alone it ends before the first poll: its status is shown
        out = real_read(needed, progress)
        for _ in range(30):
            if progress is not None:
                progress(0.95, "reading the plan of '{}'".format(needed.run_name))
            time.sleep(0.01)
        return out

    runs_mod.PlanNeeded.run = slow_read
    plan_read = dict(text_chars=len(run["flank_plan_json"]))
    try:
        kw = dict(collection=run_name, width=1920, height=1080)
        for how in ("modal", "sync"):
            select()
            runs_mod._PLANS.clear()
            if how == "modal":
                rec = sm._call(bpy, bpy.ops.flank.error_plot, plot_cls, "finish", **kw)
            else:
                ret, err = driver._run_op(bpy.ops.flank.error_plot, **kw)
                rec = dict(op_result=ret, op_error=err)
            rec.update(state=_plot_state(bpy, np, run_name), kept=run_name in runs_mod._PLANS)
            plan_read[how] = rec
        # Animate Strip, which has no worker of its own: the reading first, then the animation in one turn
        anim_cls = sys.modules[driver.MODULE + ".operators.animate"].FLANK_OT_animate_strip
        for how in ("modal", "sync"):
            select()
            runs_mod._PLANS.clear()
            if how == "modal":
                rec = sm._call(bpy, bpy.ops.flank.animate_strip, anim_cls, "finish", collection=run_name, strip=1,
                               frame_start=1, frame_end=40)
            else:
                ret, err = driver._run_op(bpy.ops.flank.animate_strip, collection=run_name, strip=1, frame_start=1,
                                          frame_end=40)
                rec = dict(op_result=ret, op_error=err)
            motion = [o for o in bpy.data.collections[run_name].objects if o.get("flank_anim_role") == "motion"]
            rec.update(kept=run_name in runs_mod._PLANS, motion=[(o.name, sm._plain(o["flank_anim_time"]))
                                                                 for o in motion])
            plan_read["animate_" + how] = rec
        # with no run named and the rotor active (in no run), the newest run is read; a newer run that appears
        # while the plan is read does not change which run is animated (nor does the run's name stay pinned)
        select()
        runs_mod._PLANS.clear()
        parent = bpy.data.collections[runs_mod.RESULTS_COLLECTION]

        def newer_run():
            newer = bpy.data.collections.new("A Newer Run")
            parent.children.link(newer)
            newer["flank_plan_json"] = run["flank_plan_json"]

        with sm._Patched(anim_cls, "finish") as rec:
            rec["while_running"] = newer_run
            ret, err = driver._run_op(bpy.ops.flank.animate_strip, strip=1, frame_start=1, frame_end=40)
        newer = bpy.data.collections.get("A Newer Run")
        plan_read["animate_pinned"] = dict(
            final=rec["final"], op_error=err, workers=rec["workers"], newer_made=newer is not None,
            animated=sorted(c.name for c in bpy.data.collections
                            if any(o.get("flank_anim_role") == "motion" for o in c.objects)),
            collection_after=bpy.context.window_manager.operator_properties_last("flank.animate_strip").collection)
        if newer is not None:
            bpy.data.collections.remove(newer)
        good = run["flank_plan_json"]
        run["flank_plan_json"] = good[:-200_000]
        try:
            select()
            runs_mod._PLANS.clear()
            before = sm.census(bpy, np)
            rec = sm._call(bpy, bpy.ops.flank.error_plot, plot_cls, "finish", **kw)
            rec.update(census_equal=before == sm.census(bpy, np), kept=run_name in runs_mod._PLANS)
            plan_read["broken"] = rec
        finally:
            run["flank_plan_json"] = good
    finally:
        runs_mod.DEFER_CHARS, runs_mod.PlanNeeded.run = real_defer, real_read
    res["plan_read"] = plan_read
    # a failure in the worker is reported as the synchronous run reports it, and changes nothing
    select()
    bad = os.path.join(os.path.abspath(os.getcwd()), "bad_plan.json")
    plan = json.loads(run["flank_plan_json"])
    plan["rotor"]["to_world"] = [[1, 0, 0, 5.0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]   # not on this mesh
    with open(bad, "w") as fh:
        json.dump(plan, fh)
    before = sm.census(bpy, np)
    rec = sm._call(bpy, bpy.ops.flank.verify_plan, classes["verify"], "finish", filepath=bad)
    rec["census_equal"] = before == sm.census(bpy, np)
    res["verify_failed"] = rec
    select()
    ret, err = driver._run_op(bpy.ops.flank.verify_plan, filepath=bad)
    res["verify_failed_sync"] = dict(result=ret, error=err)
    res["patched_left"] = ["__enter__" in c.execute.__qualname__ for c in classes.values()]
