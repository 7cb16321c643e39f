# SPDX-License-Identifier: GPL-3.0-or-later
"""Analyze Rotor (flank.analyze_rotor), Generate Rotor (flank.generate_rotor), Preview Guiding Curves
(flank.preview_guiding), the flank list (flank.refresh_flanks), Paraboloid Groove (flank.paraboloid_groove) and
Export Results after its file browser (flank.export_results) through the modal Run path (operators/modal.py), for
test_blender_modal_tools.py.

Each operator's ``execute`` is replaced for one call by scenario_modal's driver (``_start_modal`` + ``modal()``
with TIMER / ESC events and a stand-in context), as in scenario_modal_checks: a synchronous run, ESC and closing
(a census of bpy.data and the scene before and after; not for Generate, the flank list and Paraboloid Groove,
whose workers are too quick to race ESC against), and a modal run to the end, whose result is compared with the
synchronous one.  The sizes are a user's: a rotor of 280,000 triangles (its analysis takes over a second) and a
free-form surface of 20,000.  The analysis cache is emptied before every run, so each one analyses."""
import os
import sys
import time

import driver
import scenario_modal as sm


def _digest_array(np, arr):
    return sm._digest(np.ascontiguousarray(arr).tobytes())


def _analysis_state(bpy, np, name):
    ob = bpy.data.objects[name]
    return dict(props={k: sm._plain(ob[k]) for k in ob.keys() if k.startswith("flank_")},
                curvature=_digest_array(np, driver._float_attr(np, ob.data, "gaussian_curvature")),
                attrs=sorted(a.name for a in ob.data.attributes))


def _rotor_state(bpy, np):
    obs = sorted((o for o in bpy.data.objects if o.get("flank_source") == "generated"), key=lambda o: o.name)
    if not obs:
        return None
    ob = obs[-1]                     # the newest rotor (names grow .001, .002 ...)
    return dict(count=len(obs), faces=len(ob.data.polygons), co=_digest_array(np, driver._mesh_co(np, ob)),
                props={k: sm._plain(ob[k]) for k in ob.keys() if k.startswith("flank_")},
                selected=ob.select_get(), active=bpy.context.view_layer.objects.active == ob)


def _preview_state(bpy, np):
    ob = next((o for o in bpy.data.objects if o.get("flank_guiding_preview") is not None), None)
    if ob is None:
        return None
    pts = []
    for sp in ob.data.splines:
        co = np.empty(4 * len(sp.points), dtype=np.float32)
        sp.points.foreach_get("co", co)
        pts.append(_digest_array(np, co))
    return dict(name=ob.name, splines=len(ob.data.splines), points=sm._digest(pts),
                props={k: sm._plain(ob[k]) for k in ob.keys()})


def _flank_list_state(bpy):
    s = bpy.context.scene.flank_settings
    return dict(rotor=s.flank_list_rotor, index=s.flank_index,
                rows=[[i.name, i.flank, i.valley, repr(i.u_start), repr(i.u_end), repr(i.hyperbolic_fraction),
                       repr(i.a_min)] for i in s.flank_list])


def _groove_state(bpy, np):
    coll = next((c for c in bpy.data.collections if c.get("flank_groove_key") == "groove"), None)
    if coll is None:
        return None
    meshes = {o.name.split(".")[0]: _digest_array(np, driver._mesh_co(np, o)) for o in coll.objects
              if o.type == 'MESH'}
    return dict(objects=sorted(o.name for o in coll.objects), meshes=meshes,
                props={k: sm._plain(coll[k]) for k in coll.keys() if k.startswith("flank_")})


def _compare_csv(got, want):
    """Two CSV texts of a verification: the same rows and fields, the numbers equal to 1e-12 of their size
    (+1e-12 R) -- two verifications of one plan in one process may round the last bits of a deviation
    differently: a deviation near 0 is the difference of coordinates about R in size (seen: 1.09e-15 R).
    -> dict(rows, same, largest difference)."""
    if got is None or want is None:
        return dict(rows=None, same=False, largest=None)
    a, b = got.splitlines(), want.splitlines()
    same, largest = len(a) == len(b) and len(a) > 1, 0.0
    for x, y in zip(a, b):
        fx, fy = x.split(","), y.split(",")
        if len(fx) != len(fy):
            same = False
            continue
        for u, v in zip(fx, fy):
            try:
                fu, fv = float(u), float(v)
            except ValueError:
                same &= u == v
                continue
            diff = abs(fu - fv)
            largest = max(largest, diff)
            same &= diff <= 1e-12 * max(abs(fu), abs(fv)) + 1e-12
    return dict(rows=len(a), same=same, largest=largest)


def scenario(bpy, res, args):
    import numpy as np

    mods = {name: __import__(driver.MODULE + ".operators." + name, fromlist=["x"])
            for name in ("analyze", "generate", "guiding", "flank_list", "paraboloid", "export", "render_report",
                         "modal", "jobs", "sources")}
    analysis = __import__(driver.MODULE + ".flank_addon.geometry.rotor_analysis", fromlist=["x"])
    mixin = mods["modal"].ModalPlannerMixin
    classes = dict(analyze=mods["analyze"].FLANK_OT_analyze_rotor, generate=mods["generate"].FLANK_OT_generate_rotor,
                   preview=mods["guiding"].FLANK_OT_preview_guiding,
                   flank_list=mods["flank_list"].FLANK_OT_refresh_flanks,
                   paraboloid=mods["paraboloid"].FLANK_OT_paraboloid_groove,
                   export=mods["export"].FLANK_OT_export_results,
                   render=mods["render_report"].FLANK_OT_render_report)
    res["mixin"] = {k: issubclass(c, mixin) for k, c in classes.items()}
    res["timer_step"] = mods["modal"].TIMER_STEP
    empty = bpy.data.objects.new("Flank Selection Holder", None)       # something to select before a generate
    bpy.context.scene.collection.objects.link(empty)

    def select_empty():
        sm.driver_select(bpy, empty)

    # the defaults, 280k triangles: the worker needs only 20-40 ms, too little to race ESC against it (the mixin's
    # ESC and close are shown on the other two); the mesh is built on the main thread
    # the sidebar's warm-up (started when the tab is shown, never in the background): what a first click imports
    jobs = mods["jobs"]
    shown = [name for name in jobs.WARM_MODULES if (driver.MODULE + name if name[0] == "." else name) in sys.modules]
    warm = jobs.warm_up(driver.MODULE)
    res["warm_up"] = dict(loaded_before=shown, done=warm.wait(120), imported=list(warm.imported),
                          failed={k: repr(v) for k, v in warm.failed.items()}, names=list(jobs.WARM_MODULES),
                          seconds=warm.elapsed, collect_s=warm.collect_s,
                          once=jobs.warm_up(driver.MODULE) is warm)
    gen_kw = dict(kind="asymmetric", part="female")
    res["generate"] = sm.exercise_tool(bpy, np, bpy.ops.flank.generate_rotor, classes["generate"], gen_kw,
                                       select_empty, lambda: _rotor_state(bpy, np), cancel=False)
    rotor = sorted(o.name for o in bpy.data.objects if o.get("flank_source") == "generated")[0]
    t0, c0 = time.perf_counter(), time.thread_time()
    mods["sources"].rotor_source(bpy.data.objects[rotor])           # a planner's first read of the session
    res["warm_up"].update(first_read_ms=1000.0 * (time.perf_counter() - t0),
                          first_read_cpu_ms=1000.0 * (time.thread_time() - c0))
    res["rotor_faces"] = len(bpy.data.objects[rotor].data.polygons)

    def select_rotor():
        sm.driver_select(bpy, bpy.data.objects[rotor])

    res["analyze"] = sm.exercise_tool(bpy, np, bpy.ops.flank.analyze_rotor, classes["analyze"], {}, select_rotor,
                                      lambda: _analysis_state(bpy, np, rotor), before_each=analysis._CACHE.clear)
    # a planner reading the analysed rotor in a later session (nothing in memory): from the record Analyze Rotor kept
    # on the object, and, for comparison, without it (analysed again on the main thread)
    sources = __import__(driver.MODULE + ".operators.sources", fromlist=["x"])
    ob = bpy.data.objects[rotor]

    def source():
        analysis._CACHE.clear()
        t0 = time.perf_counter()
        src = sources.rotor_source(ob)
        return dict(seconds=time.perf_counter() - t0, flanks=[[repr(u) for u in f] for f in src["flanks"]],
                    v0=repr(src["surface"].v0), to_world=[repr(x) for x in np.ravel(src["to_world"])],
                    profile=_digest_array(np, src["surface"].profile.points))

    res["source_from_record"] = source()
    record = ob["flank_analysis_record"]
    del ob["flank_analysis_record"]
    res["source_analysed"] = source()
    ob["flank_analysis_record"] = record
    # the quick reads of a mesh (single precision widened; triangles from the corners where every face is one) give
    # Blender's own arrays: the rotor's triangles, and a cube's quads through Blender's triangulation
    # and meshes of quads (and triangles) through Blender's split of each quad: a 500,000-quad grid shaken until a
    # quarter of its quads are concave or folded, one whose corners sit on a half-unit lattice (many quads with
    # three corners in a line, split by rounding: read from Blender one by one), a cylinder with n-gon caps
    common = __import__(driver.MODULE + ".operators.common", fromlist=["x"])
    rng = np.random.default_rng(7)
    made = []

    def added(op, **kw):
        op(**kw)
        made.append(bpy.context.active_object)
        return made[-1].data

    def shaken(me, scale, lattice=None):
        co = common.mesh_vertices(me)
        co += rng.normal(scale=scale, size=co.shape)
        if lattice:
            co = np.round(co / lattice) * lattice
        me.attributes["position"].data.foreach_set("vector", co.astype(np.float32).ravel())
        me.update()
        return me

    meshes = (("rotor", ob.data), ("cube", added(bpy.ops.mesh.primitive_cube_add)),
              ("grid", shaken(added(bpy.ops.mesh.primitive_grid_add, x_subdivisions=708, y_subdivisions=708,
                                    size=2.0), 0.0012)),
              ("lattice", shaken(added(bpy.ops.mesh.primitive_grid_add, x_subdivisions=40, y_subdivisions=40,
                                       size=40.0), 0.5, lattice=0.5)),
              ("ngons", added(bpy.ops.mesh.primitive_cylinder_add, vertices=64, end_fill_type='NGON')))
    reads = {}
    for name, me in meshes:
        co = np.empty(3 * len(me.vertices))
        me.vertices.foreach_get("co", co)
        me.calc_loop_triangles()
        tris = np.empty(3 * len(me.loop_triangles), dtype=np.int32)
        faces = np.empty(len(me.loop_triangles), dtype=np.int32)
        c0 = time.thread_time()
        me.loop_triangles.foreach_get("vertices", tris)
        me.loop_triangles.foreach_get("polygon_index", faces)
        c1 = time.thread_time()
        quick, quick_faces = common.mesh_triangles(me, with_faces=True)
        c2 = time.thread_time()
        sizes = np.empty(len(me.polygons), dtype=np.int32)
        me.polygons.foreach_get("loop_total", sizes)
        corners = np.empty(len(me.loops), dtype=np.int32)
        me.loops.foreach_get("vertex_index", corners)
        split = dict(unsure=-1, flipped=-1)
        if sizes.max() <= 4:
            made_here, unsure, first = common.tris_and_quads(corners, sizes, common.mesh_vertices(me))
            quads = first[sizes == 4]
            split = dict(unsure=len(unsure), flipped=int((made_here[quads, 2] != made_here[quads + 1, 1]).sum()))
        reads[name] = dict(co=bool(np.array_equal(common.mesh_vertices(me), co.reshape(-1, 3))),
                           tris=bool(np.array_equal(quick, tris.reshape(-1, 3))),
                           tri_faces=bool(np.array_equal(quick_faces, faces)),
                           faces=len(me.polygons), triangles=len(tris) // 3, quads=int((sizes == 4).sum()),
                           largest_face=int(sizes.max()), **split,
                           ms=dict(loop_triangles=1000.0 * (c1 - c0), quick=1000.0 * (c2 - c1)))
    res["mesh_reads"] = reads
    for obj in made:
        me = obj.data
        bpy.data.objects.remove(obj)
        bpy.data.meshes.remove(me)
    # the rotor moved and turned after Analyze Rotor, in a later Blender session: the record moves with the object
    before = sources.rotor_source(ob)
    location, rotation = tuple(ob.location), tuple(ob.rotation_euler)
    ob.location = (0.3, -0.2, 0.15)
    ob.rotation_euler = (0.2, -0.5, 1.1)
    bpy.context.view_layer.update()
    analysis._CACHE.clear()
    t0, c0 = time.perf_counter(), time.thread_time()
    moved = sources.rotor_source(ob)
    seconds, cpu = time.perf_counter() - t0, time.thread_time() - c0
    motion = np.array(ob.matrix_world) @ np.linalg.inv(np.asarray(record_matrix := ob["flank_analysis_matrix"]).reshape(4, 4))
    res["source_moved"] = dict(
        seconds=seconds, cpu_seconds=cpu, record_matrix=[float(x) for x in record_matrix],
        flanks_same=[[repr(u) for u in f] for f in moved["flanks"]] == [[repr(u) for u in f] for f in before["flanks"]],
        profile_same=_digest_array(np, moved["surface"].profile.points) == _digest_array(np, before["surface"].profile.points),
        v0_same=moved["surface"].v0 == before["surface"].v0,
        to_world_gap=float(np.abs(np.asarray(moved["to_world"]) - motion @ np.asarray(before["to_world"])).max()))
    ob.location, ob.rotation_euler = location, rotation
    bpy.context.view_layer.update()
    # the flank list of the analysed rotor (the Dupin analysis of its 12 flanks) and the paraboloid groove, both at
    # their defaults: their workers need 10-60 ms, too little to race ESC against
    settings = bpy.context.scene.flank_settings
    settings.flank_list.clear()
    res["flank_list"] = sm.exercise_tool(bpy, np, bpy.ops.flank.refresh_flanks, classes["flank_list"], {},
                                         select_rotor, lambda: _flank_list_state(bpy), cancel=False)
    # scaled after Analyze Rotor, the rotor's mesh is no longer the record's: a planner analyses it again in its
    # first worker, then reads it on the main thread from the analysis cache.  The reference: the same rotor
    # analysed on the main thread, as before, and its flank list
    ob.scale = (2.0, 2.0, 2.0)
    bpy.context.view_layer.update()
    analysis._CACHE.clear()
    reference = sources.rotor_source(ob)
    scaled = dict(reference_flanks=[[repr(float(np.float32(u))) for u in f] for f in reference["flanks"]])  # as stored
    for plan in ("esc", "finish"):
        analysis._CACHE.clear()
        select_rotor()
        settings.flank_list.clear()
        bpy.context.view_layer.update()
        before = sm.census(bpy, np)
        rec = sm._call(bpy, bpy.ops.flank.refresh_flanks, classes["flank_list"], plan)
        rec["census_equal"] = before == sm.census(bpy, np)
        rec["cached_after"] = len(analysis._CACHE)
        rec["state"] = _flank_list_state(bpy)
        scaled[plan] = rec
    # the user selects another object while the rotor is analysed: the run still lists the rotor's flanks
    analysis._CACHE.clear()
    select_rotor()
    settings.flank_list.clear()
    bpy.ops.mesh.primitive_cube_add(location=(9.0, 0.0, 0.0))
    other = bpy.context.active_object
    select_rotor()
    with sm._Patched(classes["flank_list"], "finish") as rec:
        rec["while_running"] = lambda: sm.driver_select(bpy, other)
        ret, err = driver._run_op(bpy.ops.flank.refresh_flanks)
    scaled["other_selected"] = dict(final=rec["final"], workers=rec["workers"], op_error=err,
                                    active_after=bpy.context.active_object.name, state=_flank_list_state(bpy))
    other_mesh = other.data
    bpy.data.objects.remove(other)
    bpy.data.meshes.remove(other_mesh)
    # Flank at 3D Cursor on the scaled rotor: the same worker first; the flank the rotor analysed on the main
    # thread gives for the cursor
    flank_of_point = __import__(driver.MODULE + ".flank_addon.methods.single_flank.planner",
                                fromlist=["x"]).flank_of_point
    cursor = bpy.context.scene.cursor
    cursor.location = (0.4, 2.1, 1.3)
    p = sources.to_rotor_frame(reference["display"], np.array([tuple(cursor.location)]))[0]
    analysis._CACHE.clear()
    select_rotor()
    settings.flank_index = -1
    rec = sm._call(bpy, bpy.ops.flank.pick_flank_cursor, mods["flank_list"].FLANK_OT_pick_flank_cursor, "finish")
    scaled["pick"] = dict(final=rec["final"], workers=rec["workers"], op_error=rec["op_error"],
                          start_cpu_ms=rec["start_cpu_ms"], max_cpu_ms=max(c["cpu_ms"] for c in rec["calls"]),
                          flank=settings.flank_index,
                          reference=int(flank_of_point(reference["surface"], reference["flanks"], p)))
    cursor.location = (0.0, 0.0, 0.0)
    res["scaled"] = scaled
    analysis._CACHE.clear()
    ob.scale = (1.0, 1.0, 1.0)
    bpy.context.view_layer.update()
    res["paraboloid"] = sm.exercise_tool(bpy, np, bpy.ops.flank.paraboloid_groove, classes["paraboloid"], {},
                                         select_rotor, lambda: _groove_state(bpy, np), cancel=False)
    # Export Results after its file browser: the error profile of a double-flank run verifies the plan (0.35 s)
    select_rotor()
    driver._run_op(bpy.ops.flank.plan_double_flank)
    run = next(c.name for c in bpy.data.collections if "flank_plan_json" in c and c.get("flank_df_key"))
    folder = os.path.abspath("exports")
    os.makedirs(folder)
    exp = {}

    def exported(name):
        path = os.path.join(folder, name)
        return open(path).read() if os.path.isfile(path) else None

    t0 = time.perf_counter()
    ret, err = driver._run_op(bpy.ops.flank.export_results, format="CSV", collection=run,
                              filepath=os.path.join(folder, "sync.csv"))
    exp["sync"] = dict(result=ret, error=err, seconds=time.perf_counter() - t0)
    for plan in ("esc", "close", "finish"):
        before = sm.census(bpy, np)
        rec = sm._call(bpy, bpy.ops.flank.export_results, classes["export"], plan, format="CSV", collection=run,
                       filepath=os.path.join(folder, plan + ".csv"))
        after = sm.census(bpy, np)
        rec.update(census_equal=before == after, census_diff=sm._census_diff(before, after))
        exp[plan] = rec
    exp["files"] = sorted(os.listdir(folder))
    exp["compared"] = _compare_csv(exported("finish.csv"), exported("sync.csv"))
    res["export"] = exp
    # Render Report after its file browser: the worker computes the picture (the strips' exact distances to the
    # rotor, camera, legend); the main thread builds the temporary scene, then renders it in later turns, one
    # tile each (the default size, 1280 x 800: four tiles); a worker puts the pixels together and encodes the PNG
    rep, render_cls = {}, classes["render"]
    kw = dict(collection=run, width=1280, height=800)
    t0 = time.perf_counter()
    ret, err = driver._run_op(bpy.ops.flank.render_report, filepath=os.path.join(folder, "sync.png"), **kw)
    rep["sync"] = dict(result=ret, error=err, seconds=time.perf_counter() - t0)
    real_compute = render_cls._compute

    def slow_compute(op, job, progress):        # Esc and closing must land while the worker runs
        for _ in range(50):
            if progress is not None and progress(0.0, "waiting") is False:
                break
            time.sleep(0.01)
        return real_compute(op, job, progress)

    for plan in ("esc", "close", "finish"):
        render_cls._compute = slow_compute if plan != "finish" else real_compute
        try:
            before = sm.census(bpy, np)
            rec = sm._call(bpy, bpy.ops.flank.render_report, render_cls, plan,
                           filepath=os.path.join(folder, plan + ".png"), **kw)
            after = sm.census(bpy, np)
        finally:
            render_cls._compute = real_compute
        rec.update(census_equal=before == after, census_diff=sm._census_diff(before, after))
        rep[plan] = rec
    # Esc while the temporary scene stands between its build and the render (the next worker slowed down), and
    # Esc and closing after the first tile (the stage after it slowed down): the scene goes, nothing is written
    real_next = render_cls._next_stage

    def slowed_after(tiles):
        def slow_next(op, context, job, out):
            stage = real_next(op, context, job, out)
            if not stage or len(job.get("pieces", ())) < tiles:
                return stage
            job.setdefault("slowed_at_tiles", len(job["pieces"]))
            rep.setdefault("slowed_at_tiles", []).append(len(job["pieces"]))

            def slow(progress):
                for _ in range(10):
                    time.sleep(0.05)
                    if progress is not None and progress(0.5, "waiting") is False:
                        break
                return stage(progress)
            return slow
        return slow_next

    for name, plan, tiles in (("esc_next_stage", "esc_next_stage", 0), ("esc_after_tile", "esc_next_stage", 1),
                              ("close_after_tile", "close_next_stage", 1)):
        render_cls._next_stage = slowed_after(tiles)
        try:
            before = sm.census(bpy, np)
            rec = sm._call(bpy, bpy.ops.flank.render_report, render_cls, plan,
                           filepath=os.path.join(folder, name + ".png"), **kw)
            rec.update(census_equal=before == sm.census(bpy, np), temporary_files=sorted(
                f for f in os.listdir(folder) if ".render" in f))
        finally:
            render_cls._next_stage = real_next
        rep[name] = rec
    rep["files"] = sorted(f for f in os.listdir(folder) if f.endswith(".png"))
    png_io = driver._core("io.png")

    def picture(name):
        path = os.path.join(folder, name)
        if not os.path.isfile(path):
            return None
        return dict(pixels=_digest_array(np, png_io.read_png(path)), meta=png_io.read_png_text(path))

    rep["sync_picture"], rep["finish_picture"] = picture("sync.png"), picture("finish.png")
    # Cycles renders in a separate Blender: the main thread writes the scene's file, a worker waits for that
    # process, which Esc and closing kill; every process the runs start is recorded (the real one, observed)
    rp = __import__(driver.MODULE + ".operators.report_process", fromlist=["x"])
    children, real_child = [], rp.ChildRender.__init__

    def recorded_child(child, command, files=()):
        real_child(child, command, files)
        children.append(child.process)

    cyc, ckw = {}, dict(collection=run, width=320, height=200, engine='CYCLES')
    rp.ChildRender.__init__ = recorded_child
    try:
        ret, err = driver._run_op(bpy.ops.flank.render_report, filepath=os.path.join(folder, "cycles_sync.png"),
                                  **ckw)
        cyc["sync"] = dict(result=ret, error=err, children=[p.returncode for p in children])
        for plan in ("finish", "esc_next_stage", "close_next_stage"):
            n0 = len(children)
            before = sm.census(bpy, np)
            rec = sm._call(bpy, bpy.ops.flank.render_report, render_cls, plan,
                           filepath=os.path.join(folder, "cycles_{}.png".format(plan)), **ckw)
            rec.update(census_equal=before == sm.census(bpy, np), temporary_files=sorted(
                f for f in os.listdir(folder) if ".render" in f), children=[p.returncode for p in children[n0:]],
                running=len(rp.running()))
            cyc[plan] = rec
    finally:
        rp.ChildRender.__init__ = real_child
    cyc["files"] = sorted(f for f in os.listdir(folder) if f.startswith("cycles_"))
    cyc["sync_picture"], cyc["finish_picture"] = picture("cycles_sync.png"), picture("cycles_finish.png")
    rep["cycles"] = cyc
    res["render"] = rep
    # a mesh that is not a rotor: the worker's failure is reported as the synchronous run reports it
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32)
    sphere = bpy.context.active_object.name

    def select_sphere():
        sm.driver_select(bpy, bpy.data.objects[sphere])

    select_sphere()
    before = sm.census(bpy, np)
    rec = sm._call(bpy, bpy.ops.flank.analyze_rotor, classes["analyze"], "finish")
    rec["census_equal"] = before == sm.census(bpy, np)
    res["analyze_failed"] = rec
    select_sphere()
    ret, err = driver._run_op(bpy.ops.flank.analyze_rotor)
    res["analyze_failed_sync"] = dict(result=ret, error=err)

    # the guiding curves of a 53,200-triangle surface: 0.39 s in the synchronous run, several polls of the modal one
    # (20,000 triangles took 0.12 s, and a modal run once ended before its first poll, 0.1 s in)
    driver._run_op(bpy.ops.flank.add_test_surface, kind="parabolic_blade", size=1.0, resolution=200)
    surface = bpy.context.active_object.name

    def select_surface():
        sm.driver_select(bpy, bpy.data.objects[surface])

    res["surface_faces"] = len(bpy.data.objects[surface].data.polygons)
    res["preview"] = sm.exercise_tool(bpy, np, bpy.ops.flank.preview_guiding, classes["preview"], {},
                                      select_surface, lambda: _preview_state(bpy, np))
    # the live preview: a property update reads the settings and the surface, a worker computes the curves and a
    # timer draws them (driven here by hand: timers do not run without an interface); two quick changes draw once
    guiding = mods["guiding"]
    s = bpy.context.scene.flank_settings
    s.ff_live_preview = False
    select_surface()
    refs = []
    for d in ((1.0, 0.0, 0.0), (0.6, 0.8, 0.0)):
        s.ff_direction = d
        guiding.refresh_guiding_preview(bpy.context, background=True)
        refs.append(_preview_state(bpy, np))
    guiding.remove_guiding_preview()
    drawn = []
    real_show = guiding.show_guiding_preview
    guiding.show_guiding_preview = lambda *a: drawn.append(1) or real_show(*a)
    try:
        updates, ticks = [], []
        for d in ((1.0, 0.0, 0.0), (0.6, 0.8, 0.0)):
            s.ff_direction = d
            t0, c0 = time.perf_counter(), time.thread_time()
            guiding.refresh_guiding_preview(bpy.context, background=False)
            updates.append(dict(ms=1000.0 * (time.perf_counter() - t0), cpu_ms=1000.0 * (time.thread_time() - c0)))
        registered = bpy.app.timers.is_registered(guiding.live_preview_tick)
        t_start = time.perf_counter()
        while time.perf_counter() - t_start < 60.0:
            t0, c0 = time.perf_counter(), time.thread_time()
            nxt = guiding.live_preview_tick()
            ticks.append(dict(ms=1000.0 * (time.perf_counter() - t0), cpu_ms=1000.0 * (time.thread_time() - c0),
                              next=nxt))
            if nxt is None:
                break
            time.sleep(nxt)
        res["live"] = dict(updates=updates, ticks=ticks, registered=registered, drawn=len(drawn),
                           state=_preview_state(bpy, np), refs=refs, message=list(guiding.preview_message()))
    finally:
        guiding.show_guiding_preview = real_show
        guiding.stop_live_preview()
    res["live"]["timer_left"] = bpy.app.timers.is_registered(guiding.live_preview_tick)
    res["patched_left"] = ["__enter__" in c.execute.__qualname__ for c in classes.values()]
    res["plans_kept"] = driver.plans_kept(bpy)     # after every operator that read a run's plan
