# SPDX-License-Identifier: GPL-3.0-or-later
"""The modal path of the planning operators (operators/modal.py) driven headless, for test_blender_modal.py.

Under ``bpy.app.background`` Blender has no events, so ``INVOKE_DEFAULT`` runs ``execute`` and ``modal()`` is
never reached.  Here the operator's ``execute`` is replaced, for one call, by a driver that does what the UI
does: ``_start_modal`` (the body of ``invoke`` after the background check) with a stand-in context, then
``modal()`` with TIMER events every 0.1 s (ESC / a closing window where asked) until it ends.  The stand-in
forwards the timer, progress and status-text calls to the real window manager and workspace (they work in
background) and only records ``modal_handler_add`` (a handler in a window without an event loop would outlive
the operator).  Everything else -- ``_prepare``, the worker thread, ``_build``, the reports, the undo push
of bpy.ops -- is the real operator.

Recorded: per modal() call its event, result, main-thread milliseconds (wall clock, and the main thread's CPU
time), the job state, the percentage and the
status text; a census of bpy.data / the scene before and after; the result collection of a synchronous run
and of a modal run to compare."""
import hashlib
import json
import math
import threading
import time

import driver

TIMER_STEP = 0.1
MAX_SECONDS = 240.0
SF_ASIN = math.asin(0.1)
SF_KW = dict(shape="alpha", alpha=SF_ASIN, r1=0.05, r2=0.08, shank_radius=0.04, shank_length=0.6,
             tolerance=1e-3, envelope_rings=12, seeds=6, rounds=1, flank=1)
# a cone on the saddle, object scale 2 (local r 0.02 .. 0.03, L 0.12): about 100 optimiser evaluations, ~2 s
# a free-form run long enough for several of the driver's 0.1 s timer events (with 12 samples and 16 columns it
# took about 0.25 s and sometimes saw only two on this machine)
FF_KW = dict(r1=0.04, r2=0.06, length=0.24, samples=24, columns=24, max_evaluations=150, tolerance=0.002,
             direction=(0.0, 1.0, 0.0))


# ------------------------------------------------------------------------------------------ stand-ins

class Event:
    def __init__(self, type_, value='NOTHING'):
        self.type, self.value = type_, value


class WindowManager:
    """Forwards to the real window manager; records the calls.  modal_handler_add is recorded only."""

    def __init__(self, wm):
        self._wm = wm
        self.calls, self.timers, self.handlers, self.percent = [], [], [], []

    def event_timer_add(self, step, window=None):
        t = self._wm.event_timer_add(step, window=window)
        self.timers.append(t)
        self.calls.append(["event_timer_add", float(step), window is not None])
        return t

    def event_timer_remove(self, timer):
        self._wm.event_timer_remove(timer)
        self.timers = [t for t in self.timers if t != timer]
        self.calls.append(["event_timer_remove"])

    def progress_begin(self, lo, hi):
        self._wm.progress_begin(lo, hi)
        self.calls.append(["progress_begin", lo, hi])

    def progress_update(self, value):
        self._wm.progress_update(value)
        self.percent.append(value)

    def progress_end(self):
        self._wm.progress_end()
        self.calls.append(["progress_end"])

    def modal_handler_add(self, op):
        self.handlers.append(op)
        self.calls.append(["modal_handler_add"])
        return True

    def __getattr__(self, name):
        return getattr(self._wm, name)


class Workspace:
    def __init__(self, ws):
        self._ws = ws
        self.texts = []

    def status_text_set(self, text):
        if self._ws is not None:
            self._ws.status_text_set(text)
        self.texts.append(text)

    def __getattr__(self, name):
        return getattr(self._ws, name)


class Context:
    """The real context with window_manager, window and workspace replaced."""

    def __init__(self, ctx, wm, window, workspace):
        self._ctx, self.window_manager, self.window, self.workspace = ctx, wm, window, workspace

    def __getattr__(self, name):
        return getattr(self._ctx, name)


# ------------------------------------------------------------------------------------------ the driver

def _run_queue_ms(tids):
    """Milliseconds the threads ``tids`` (native ids) have spent runnable but waiting for a CPU (field 2 of Linux's
    /proc schedstat; a thread the kernel does not report counts 0).  Taken out of a modal() call's wall clock: on a
    loaded machine the call (or the worker holding the interpreter lock it waits for) waits for a core, which
    is not the operator's doing; a lock held by the worker's own work still counts."""
    total = 0.0
    for tid in tids:
        try:
            with open("/proc/self/task/{}/schedstat".format(tid)) as fh:
                total += int(fh.read().split()[1]) * 1e-6
        except (OSError, ValueError, IndexError, TypeError):
            pass
    return total


def _drive(self, context, plan, rec):
    """The patched execute: start the modal run, feed it events, return its final result."""
    import bpy

    wm = WindowManager(context.window_manager)
    ws = Workspace(getattr(context, "workspace", None))
    windows = list(context.window_manager.windows)
    ctx = Context(context, wm, windows[0] if windows else None, ws)
    rec["driven"] = True
    rec["background"] = bool(bpy.app.background)
    t0, c0 = time.perf_counter(), time.thread_time()
    ret = self._start_modal(ctx)
    rec["start_ms"] = 1000.0 * (time.perf_counter() - t0)
    rec["start_cpu_ms"] = 1000.0 * (time.thread_time() - c0)     # the main thread's own work, whatever the load
    rec["start"] = sorted(ret)
    rec["wm_calls_start"] = list(wm.calls)
    rec["handlers"] = len(wm.handlers)
    rec["handler_is_self"] = bool(wm.handlers) and wm.handlers[0] is self
    rec["status_start"] = ws.texts[-1] if ws.texts else None
    if ret != {'RUNNING_MODAL'}:
        return ret
    job = self._job
    rec["has_job"] = job is not None
    calls = []
    t = time.perf_counter()
    r = self.modal(ctx, Event('MOUSEMOVE'))
    rec["mousemove"] = dict(result=sorted(r), ms=1000.0 * (time.perf_counter() - t))
    running_polls, esc_sent, t_start, first_job, workers = 0, False, time.perf_counter(), job, [job]
    while True:
        time.sleep(TIMER_STEP)
        job = self._job or job           # an operator with stages starts a new worker after each (see modal.py)
        if job is not workers[-1]:
            workers.append(job)
        state_before = job.poll()[0]
        if (plan == "close" and running_polls >= 1) or (plan == "close_next_stage" and job is not first_job
                                                         and state_before == "running"):
            t = time.perf_counter()
            self.cancel(ctx)
            calls.append(dict(event="cancel()", ms=1000.0 * (time.perf_counter() - t), state_before=state_before,
                              result=None))
            r = {'CANCELLED'}
            break
        if plan == "esc" and running_polls >= 1 and not esc_sent:
            ev, esc_sent = Event('ESC', 'PRESS'), True
        elif plan == "esc_next_stage" and job is not first_job and state_before == "running" and not esc_sent:
            ev, esc_sent = Event('ESC', 'PRESS'), True           # Esc while a later stage's worker runs
        else:
            ev = Event('TIMER')
        if running_polls >= 1 and "while_running" in rec:
            rec.pop("while_running")()     # what the user does while the worker runs (e.g. select another object)
        n_pct, n_txt = len(wm.percent), len(ws.texts)
        tids = (threading.get_native_id(), getattr(job._thread, "native_id", None))
        q = _run_queue_ms(tids)
        # what modal() is about to see, read last: the worker may end (or stop after Esc) while the driver does the
        # bookkeeping above, and a state read before it would then record the final call as made while running
        state_before = job.poll()[0]
        t, c = time.perf_counter(), time.thread_time()
        r = self.modal(ctx, ev)
        ms = 1000.0 * (time.perf_counter() - t)
        cpu_ms = 1000.0 * (time.thread_time() - c)      # the main thread's own work, whatever else loads the machine
        queue_ms = _run_queue_ms(tids) - q
        state_after = job.poll()[0]
        calls.append(dict(event=ev.type, ms=ms, cpu_ms=cpu_ms, queue_ms=queue_ms, held_ms=ms - queue_ms,
                          result=sorted(r), state_before=state_before,
                          state_after=state_after,
                          percent=wm.percent[-1] if len(wm.percent) > n_pct else None,
                          status=ws.texts[-1] if len(ws.texts) > n_txt else "<unchanged>"))
        if ev.type == 'TIMER' and r == {'RUNNING_MODAL'} and state_before == "running":
            running_polls += 1
        if r != {'RUNNING_MODAL'}:
            break
        if time.perf_counter() - t_start > MAX_SECONDS:
            self.cancel(ctx)
            rec["timed_out"] = True
            r = {'CANCELLED'}
            break
    job.wait(60)
    rec.update(calls=calls, final=sorted(r), thread_alive=job._thread.is_alive(), job_state=job.poll()[0],
               workers=len(workers),
               job_result_none=job.result is None, job_elapsed=job.elapsed,
               wm_calls=wm.calls, timers_left=len(wm.timers), status_last=ws.texts[-1] if ws.texts else "<none>",
               operator_job_cleared=self._job is None, percents=wm.percent)
    return r


class _Patched:
    """``cls.execute`` replaced by the driver for the calls inside the with block."""

    def __init__(self, cls, plan):
        self.cls, self.plan, self.rec = cls, plan, {}

    def __enter__(self):
        plan, rec = self.plan, self.rec
        self.saved = self.cls.__dict__.get("execute")

        def execute(op, context):
            return _drive(op, context, plan, rec)

        self.cls.execute = execute
        return self.rec

    def __exit__(self, *exc):
        if self.saved is None:
            del self.cls.execute
        else:
            self.cls.execute = self.saved
        return False


# ------------------------------------------------------------------------------------------ census

def _digest(v):
    return hashlib.sha1(repr(v).encode()).hexdigest()[:16]


def _plain(v):
    if hasattr(v, "to_dict"):
        v = v.to_dict()
    elif hasattr(v, "to_list"):
        v = v.to_list()
    if isinstance(v, str) and len(v) > 200:
        return "sha1:" + _digest(v)
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, (int, bool)) or v is None:
        return v
    return repr(v)


def _idprops(idb):
    return {k: _plain(idb[k]) for k in idb.keys()}


def _rna_values(struct, depth=0):
    out = {}
    for p in struct.bl_rna.properties:
        k = p.identifier
        if k == "rna_type":
            continue
        v = getattr(struct, k)
        if p.type == 'COLLECTION':
            out[k] = [_rna_values(item, depth + 1) for item in v] if depth < 2 else len(v)
        elif p.type == 'POINTER':
            import bpy

            if v is None or isinstance(v, bpy.types.ID):
                out[k] = None if v is None else v.name
            else:
                out[k] = _rna_values(v, depth + 1) if depth < 2 else repr(v)
        elif p.type in ('FLOAT', 'INT', 'BOOLEAN') and getattr(p, "array_length", 0):
            out[k] = [repr(x) for x in v]
        elif p.type == 'ENUM' and p.is_enum_flag:
            out[k] = sorted(v)
        else:
            out[k] = repr(v)
    return out


def census(bpy, np):
    """Everything a run could change: the ID blocks by name, the objects (type, data, transform, collections,
    custom properties, selection), meshes (sizes, attribute digests), collections, scene custom properties,
    flank_settings, active object, frame, cursor."""
    d = bpy.data
    scene = bpy.context.scene
    out = {k: sorted(i.name for i in getattr(d, k)) for k in (
        "objects", "meshes", "collections", "materials", "actions", "images", "texts", "curves", "node_groups",
        "cameras", "lights", "worlds", "scenes", "textures")}
    objs = {}
    for ob in d.objects:
        objs[ob.name] = dict(type=ob.type, data=ob.data.name if ob.data else None,
                             matrix=[repr(x) for row in ob.matrix_world for x in row],
                             parent=ob.parent.name if ob.parent else None,
                             collections=sorted(c.name for c in ob.users_collection), props=_idprops(ob),
                             selected=ob.select_get(), hidden=ob.hide_get(), color=[repr(x) for x in ob.color],
                             anim=ob.animation_data.action.name if ob.animation_data and ob.animation_data.action
                             else None)
    out["object_state"] = objs
    meshes = {}
    for me in d.meshes:
        co = np.empty(3 * len(me.vertices), dtype=np.float64)
        me.vertices.foreach_get("co", co)
        meshes[me.name] = dict(users=me.users, v=len(me.vertices), e=len(me.edges), f=len(me.polygons),
                               co=_digest(co.tobytes()), attrs=sorted(a.name for a in me.attributes),
                               props=_idprops(me), materials=[m.name if m else None for m in me.materials])
    out["mesh_state"] = meshes
    out["collection_state"] = {c.name: dict(objects=sorted(o.name for o in c.objects),
                                            children=sorted(x.name for x in c.children), props=_idprops(c))
                               for c in d.collections}
    out["material_state"] = {m.name: dict(users=m.users, props=_idprops(m)) for m in d.materials}
    out["image_state"] = {i.name: dict(users=i.users, size=list(i.size), props=_idprops(i)) for i in d.images}
    # the settings first: on bpy 4.2 the first RNA read of scene.flank_settings creates its (empty) ID property
    # group, which the scene's custom properties then show -- a read, not a change of the run
    out["flank_settings"] = _rna_values(scene.flank_settings)
    out["scene_props"] = _idprops(scene)
    out["scene_root"] = sorted(c.name for c in scene.collection.children)
    out["active"] = bpy.context.view_layer.objects.active.name if bpy.context.view_layer.objects.active else None
    out["frame"] = [scene.frame_current, scene.frame_start, scene.frame_end]
    out["cursor"] = [repr(x) for x in scene.cursor.location]
    return out


def _brief(x, y):
    """What differs between two census values, short."""
    if isinstance(x, dict) and isinstance(y, dict):
        return {k: [repr(x.get(k))[:80], repr(y.get(k))[:80]] for k in sorted(set(x) | set(y))
                if x.get(k) != y.get(k)}
    return [repr(x)[:160], repr(y)[:160]]


def _census_diff(a, b):
    diff = []
    for k in sorted(set(a) | set(b)):
        if a.get(k) != b.get(k):
            if isinstance(a.get(k), dict) and isinstance(b.get(k), dict):
                sub = [kk for kk in sorted(set(a[k]) | set(b[k])) if a[k].get(kk) != b[k].get(kk)]
                diff.append([k, [[kk, _brief(a[k].get(kk), b[k].get(kk))] for kk in sub[:20]]])
            else:
                diff.append([k, None])
    return diff


# ------------------------------------------------------------------------------------------ runs

def _call(bpy, op, cls, plan, **kw):
    """One call of ``op`` with ``cls.execute`` replaced by the modal driver; the call's record."""
    with _Patched(cls, plan) as rec:
        ret, err = driver._run_op(op, **kw)
    rec.update(op_result=ret, op_error=err)
    return rec


def _run_summary(coll, pre):
    if coll is None:
        return None
    out = dict(name=coll.name, objects=sorted(o.name for o in coll.objects), strips=int(coll[pre + "strips"]),
               max_error=float(coll[pre + "max_error"]), min_error=float(coll[pre + "min_error"]))
    if pre + "strip_max_error" in coll:
        out["strip_max_error"] = [float(v) for v in coll[pre + "strip_max_error"]]
    plan = json.loads(coll["flank_plan_json"])
    out["plan_strips"] = len(plan["strips"])
    out["plan_max_error"] = float(plan["summary"]["max_error"])
    return out


def _find_run(bpy, pre, key):
    return next((c for c in bpy.data.collections if c.get(pre + "key") == key), None)


def cancelled_runs(bpy, np, op, cls, kw, select, before_each=lambda: None):
    """{"esc": record, "close": record}: the modal run ended by Esc and by closing, each with the census of
    bpy.data before and after it (equal: the cancelled run left nothing)."""
    out = {}
    for plan in ("esc", "close"):
        select()
        before_each()
        bpy.context.view_layer.update()
        before = census(bpy, np)
        rec = _call(bpy, op, cls, plan, **kw)
        after = census(bpy, np)
        rec.update(census_equal=before == after, census_diff=_census_diff(before, after),
                   census_sizes={k: len(v) for k, v in before.items() if isinstance(v, (list, dict))})
        out[plan] = rec
    return out


def exercise_tool(bpy, np, op, cls, kw, select, state, before_each=lambda: None, cancel=True, field="state"):
    """A synchronous run, then (with ``cancel``) ESC / close with the census around them, and a modal run to the
    end; ``state()`` describes the result of each finished run (kept as ``field``), ``before_each()`` runs before
    every run (e.g. to empty a cache)."""
    out = {}
    select()
    before_each()
    t0 = time.perf_counter()
    ret, err = driver._run_op(op, **kw)
    out["sync"] = {"result": ret, "error": err, "seconds": time.perf_counter() - t0, field: state()}
    if cancel:
        out.update(cancelled_runs(bpy, np, op, cls, kw, select, before_each))
    select()
    before_each()
    rec = _call(bpy, op, cls, "finish", **kw)
    rec[field] = state()
    out["finish"] = rec
    return out


def _exercise(bpy, np, op, cls, kw, pre, key, select):
    """sync run, then ESC / close / modal-to-the-end; census around the cancelled ones; each finished run's result
    collection as ``run``."""
    return exercise_tool(bpy, np, op, cls, kw, select, lambda: _run_summary(_find_run(bpy, pre, key), pre),
                         field="run")


def scenario(bpy, res, args):
    import numpy as np
    from mathutils import Matrix

    sf_mod = __import__(driver.MODULE + ".operators.single_flank", fromlist=["x"])
    ff_mod = __import__(driver.MODULE + ".operators.freeform", fromlist=["x"])
    modal_mod = __import__(driver.MODULE + ".operators.modal", fromlist=["x"])
    res["timer_step"] = modal_mod.TIMER_STEP
    res["mixin"] = dict(sf=issubclass(sf_mod.FLANK_OT_plan_single_flank, modal_mod.ModalPlannerMixin),
                        ff=issubclass(ff_mod.FLANK_OT_plan_freeform, modal_mod.ModalPlannerMixin))
    # background: INVOKE_DEFAULT is execute (no modal handler, no timer): the run is synchronous
    driver._run_op(bpy.ops.flank.generate_rotor, kind="asymmetric", part="female", resolution=360, axial=24)
    rotor = bpy.context.active_object
    rotor.matrix_world = Matrix.Translation((0.4, -0.3, 0.7)) @ Matrix.Rotation(0.5, 4, 'Z')
    bpy.context.view_layer.update()
    rotor_name = rotor.name

    def select_rotor():
        driver_select(bpy, bpy.data.objects[rotor_name])

    select_rotor()
    t0 = time.perf_counter()
    try:
        ret = sorted(bpy.ops.flank.plan_single_flank('INVOKE_DEFAULT', **SF_KW))
    except RuntimeError as ex:
        ret = str(ex)
    res["invoke_default"] = dict(result=ret, seconds=time.perf_counter() - t0,
                                 run=_run_summary(_find_run(bpy, "flank_sf_", "{}|1".format(rotor_name)),
                                                  "flank_sf_"))

    res["single_flank"] = _exercise(bpy, np, bpy.ops.flank.plan_single_flank, sf_mod.FLANK_OT_plan_single_flank,
                                    SF_KW, "flank_sf_", "{}|1".format(rotor_name), select_rotor)
    # a planner failure in the worker: reported (ERROR) from modal(), nothing built
    select_rotor()
    before = census(bpy, np)
    rec = _call(bpy, bpy.ops.flank.plan_single_flank, sf_mod.FLANK_OT_plan_single_flank, "finish",
                **dict(SF_KW, shank_radius=1.0, shank_length=1.0, seeds=2, rounds=1))
    rec["census_equal"] = before == census(bpy, np)
    res["single_flank"]["failed"] = rec
    # bad input: refused by _prepare in _start_modal, no job, no timer
    before = census(bpy, np)
    rec = _call(bpy, bpy.ops.flank.plan_single_flank, sf_mod.FLANK_OT_plan_single_flank, "finish",
                **dict(SF_KW, r1=0.2, r2=0.1))
    rec["census_equal"] = before == census(bpy, np)
    res["single_flank"]["bad_input"] = rec

    # ---------------------------------------------------------------- free-form on the saddle (moved, turned, x2)
    driver._run_op(bpy.ops.flank.add_test_surface, kind="saddle", size=1.0, resolution=40)
    blade = bpy.context.active_object
    blade.matrix_world = Matrix.Translation((1.0, -2.0, 0.5)) @ Matrix.Rotation(math.pi / 2, 4, 'Z') @ \
        Matrix.Scale(2.0, 4)
    bpy.context.view_layer.update()
    blade_name = blade.name

    def select_blade():
        driver_select(bpy, bpy.data.objects[blade_name])

    # a millimetre scene: the blade's own numbers are the plan's (in metres it would plan 1000 times larger)
    bpy.context.scene.unit_settings.system, bpy.context.scene.unit_settings.scale_length = 'METRIC', 0.001
    res["freeform"] = _exercise(bpy, np, bpy.ops.flank.plan_freeform, ff_mod.FLANK_OT_plan_freeform, FF_KW,
                                "flank_ff_", blade_name, select_blade)
    res["patched_left"] = ["execute" in cls.__dict__ for cls in (sf_mod.FLANK_OT_plan_single_flank,
                                                                 ff_mod.FLANK_OT_plan_freeform)]


def driver_select(bpy, ob):
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    ob.select_set(True)
    bpy.context.view_layer.objects.active = ob
