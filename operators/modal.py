# SPDX-License-Identifier: GPL-3.0-or-later
"""The modal side of the planning operators: progress bar, status text, ESC, planner off the UI thread.

An operator using :class:`ModalPlannerMixin` splits its work in three:

- ``_prepare(context)`` on the main thread: reads properties and Blender data, validates (reports
  and returns None on bad input) and returns a ``job`` dict of plain Python/numpy values;
- ``_compute(job, progress)``: the planner, pure numpy/scipy (``flank_addon``), no Blender data --
  it runs in a worker thread (:class:`jobs.PlannerJob`) when invoked from the UI;
- ``_build(context, job, result)`` on the main thread: creates the Blender data, reports, returns
  the operator's result set.

An operator whose work needs Blender in the middle (e.g. Blender's font for a chart's text, between drawing
the chart and encoding it) defines ``_next_stage(context, job, result)``: called on the main thread with a
worker's result, it returns the next worker's function ``(progress) -> result``, None when ``_build``
comes next, or False when it reported an error (nothing is built).  So the main thread does only the Blender
part, and each of its turns stays short.  Whatever Blender data a stage made for a later one, ``_discard(job)``
removes when the run ends without a build (Esc, closing, a failure).  A stage that needs no worker, only a
turn of the interface before the next part on the main thread (a render in tiles, a mesh built in two turns),
returns :func:`next_turn`: the timer then ticks every ``TURN_STEP`` until a real worker runs again, so such
turns follow each other as soon as Blender has handled its events and redrawn, not a timer step apart.

A planner whose analysed rotor must be analysed again (its mesh changed since Analyze Rotor) gets an
``AnalysisNeeded`` from ``rotor_source(..., defer=self._defer_analysis)``; its ``_prepare`` returns
``self._read_first(needed)``.  The analysis is then the first worker, and ``_prepare`` runs again on the
same object when it ends, now reading the rotor from the analysis cache: a second of analysis never blocks
Blender.  A run's long plan that is not kept parsed (a file opened again) is read the same way: ``run_plan(...,
defer=self._defer_analysis)`` gives a ``PlanNeeded``.  Either has ``run(progress)`` (the worker), ``resume(result)``
(main thread: None, or an error message), ``name`` (the object made active again for the second ``_prepare``;
None: no active object, as when it started) and ``doing`` (what the worker did, for the message when that object is gone).

``execute`` (scripts, ``bpy.app.background``, redo) runs the three in a row; after a file browser (the
operator's hidden ``modal_after_browser``, set by its ``invoke``) it starts the modal run instead.
``invoke`` from the UI starts the worker and returns RUNNING_MODAL; a 0.1 s timer updates the window
manager's progress (percent) and the status bar text; ESC cancels: the planner stops at its next progress
report and nothing is built, so the scene is exactly as before.  Under ``bpy.app.background`` invoke is
``execute``.
"""
import time

import bpy

from .jobs import PlannerJob

TIMER_STEP = 0.1
TURN_STEP = 0.01        # the timer while the next stage is only a turn of the interface (next_turn)
_READ_FIRST = "read_first"     # a job that reads its data in a worker before ``_prepare`` can run again


def next_turn(result=None):
    """The stage that gives Blender's interface a turn and passes ``result`` on to the next main-thread part
    (``_next_stage`` or ``_build``), without work in a thread."""
    def turn(progress):
        return result
    turn.interface_turn = True
    return turn


class _ActiveObject:
    """The context with the object the run was started on as its active object (the user may have selected
    another one while the rotor was analysed)."""

    def __init__(self, context, obj):
        self._context, self.active_object, self.object = context, obj, obj

    def __getattr__(self, name):
        return getattr(self._context, name)


class ModalPlannerMixin:
    _job = None
    _timer = None
    _timer_step = None
    _prepared = None
    _shown = (0.0, "starting")           # the last progress shown, where a next stage's worker starts
    _title = "Planning"
    _source_title = None                 # how _prepare's rotor messages begin (None: _title)
    _defer_analysis = True               # rotor_source(..., defer=): False while _prepare runs after the analysis

    def _compute_failed(self, ex):
        """Message for an exception of _compute (ValueError: the planner's own message)."""
        if isinstance(ex, ValueError):
            return "{}: {}".format(self._title, ex)
        return "{} failed: {}: {}".format(self._title, type(ex).__name__, ex)

    def execute(self, context):
        from ..flank_addon.progress import Cancelled

        # an operator with a file browser sets its hidden ``modal_after_browser`` in invoke: Blender calls execute
        # when the file is chosen, and from the UI that run goes to the worker like a planner's
        if getattr(self, "modal_after_browser", False) and not bpy.app.background \
                and context.window_manager is not None and context.window is not None:
            self.modal_after_browser = False
            return self._start_modal(context)
        job = self._prepare(context)
        if job is None:
            return {'CANCELLED'}
        stage, built = self._first_stage(job), False
        try:
            while stage is not None:
                try:
                    result = stage(None)
                except Cancelled:
                    return {'CANCELLED'}
                except Exception as ex:                                    # never a traceback for the user
                    self.report({'ERROR'}, self._failure(ex))
                    return {'CANCELLED'}
                try:
                    stage = self._after_stage(context, job, result)
                except Exception as ex:                                    # never a traceback for the user
                    self.report({'ERROR'}, self._failure(ex))
                    return {'CANCELLED'}
                if stage is False:
                    return {'CANCELLED'}
            built = True
            return self._build(context, job, result)
        finally:
            if not built:
                self._discard(job)

    def _failure(self, ex):
        from .sources import RotorSourceError

        if isinstance(ex, RotorSourceError):           # the rotor's analysis in the first worker: as _prepare says it
            return "{}: {}".format(self._source_title or self._title, ex)
        return self._compute_failed(ex)

    def _read_first(self, needed):
        """The job of a run whose data is read in a worker first (``needed``: an ``AnalysisNeeded`` or a
        ``PlanNeeded``)."""
        return {_READ_FIRST: needed, "t0": time.perf_counter()}

    def _first_stage(self, job):
        needed = job.get(_READ_FIRST)
        if needed is not None:
            return needed.run
        return lambda progress: self._compute(job, progress)

    def _after_stage(self, context, job, result):
        """After a worker (main thread): the operator's own job once its data is read, else _next_stage."""
        needed = job.pop(_READ_FIRST, None)
        if needed is None:
            return self._next_stage(context, job, result)
        msg, obj = needed.resume(result), None
        if msg is None and needed.name is not None:
            obj = bpy.data.objects.get(needed.name)
            if obj is None:
                msg = "'{}' was removed while {}".format(needed.name, needed.doing)
        if msg is not None:
            self.report({'ERROR'}, "{}: {}".format(self._title, msg))
            return False
        self._defer_analysis = False     # the data is kept now (changed since: read here)
        # a run's plan was read: its run, whatever became the newest meanwhile (an empty ``collection`` means the
        # run of the active object, else the newest), for this _prepare only
        pinned = getattr(needed, "run_name", None) if getattr(self, "collection", None) == "" else None
        if pinned:
            self.collection = pinned
        try:
            prepared = self._prepare(_ActiveObject(context, obj))     # obj None: no active object, as at the start
        finally:
            self._defer_analysis = True
            if pinned:
                self.collection = ""
        if prepared is None:
            return False
        if "t0" in prepared:
            prepared["t0"] = job["t0"]   # the run's time includes the analysis
        self._shown = (0.0, "starting")  # the planner's bar starts afresh, not at the reading's last message
        job.clear()
        job.update(prepared)
        return lambda progress: self._compute(job, progress)

    def _next_stage(self, context, job, result):
        """The next worker's function after ``result`` (main thread), None: build now, False: the stage reported
        an error and nothing is built (see the module docstring)."""
        return None

    def _discard(self, job):
        """Remove what the stages made for later ones when the run ends without a build (main thread)."""

    def invoke(self, context, event):
        if bpy.app.background or context.window_manager is None or context.window is None:
            return self.execute(context)
        return self._start_modal(context)

    def _start_modal(self, context):
        """Prepare on the main thread, start the worker, the timer, the progress and the modal handler.

        Everything it needs from ``context`` is ``window_manager`` (event_timer_add/remove, progress_begin/
        update/end, modal_handler_add), ``window`` and ``workspace`` (status_text_set) besides what
        ``_prepare`` reads -- so tests drive this and :meth:`modal` headless with a stand-in for those."""
        from ..flank_addon.progress import Cancelled

        job = self._prepare(context)
        if job is None:
            return {'CANCELLED'}
        self._prepared = job
        self._job = PlannerJob(self._first_stage(job), Cancelled)
        wm = context.window_manager
        self._timer = wm.event_timer_add(TIMER_STEP, window=context.window)
        self._timer_step = TIMER_STEP
        wm.progress_begin(0, 100)
        wm.modal_handler_add(self)
        self._status(context, "{}: starting (Esc cancels)".format(self._title))
        return {'RUNNING_MODAL'}

    def _status(self, context, text):
        ws = getattr(context, "workspace", None)
        if ws is not None:
            try:
                ws.status_text_set(text)
            except (AttributeError, RuntimeError, TypeError):
                pass

    def _tick(self, context, step):
        """The timer at ``step`` seconds (one timer at a time)."""
        if self._timer is None or self._timer_step == step:
            return
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        self._timer = wm.event_timer_add(step, window=context.window)
        self._timer_step = step

    def _finish(self, context):
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()
        self._status(context, None)

    def modal(self, context, event):
        job = self._job
        if event.type == 'ESC' and event.value == 'PRESS':
            job.cancel()
            self._status(context, "{}: cancelling...".format(self._title))
            return {'RUNNING_MODAL'}
        if event.type != 'TIMER':
            return {'PASS_THROUGH'}
        state, fraction, message = job.poll()
        if state == "running":
            self._shown = (fraction, message)
            context.window_manager.progress_update(int(round(100 * fraction)))
            self._status(context, "{}: {:3.0f}%  {}  (Esc cancels)".format(self._title, 100 * fraction, message))
            return {'RUNNING_MODAL'}
        if state == "finished":
            from ..flank_addon.progress import Cancelled

            try:
                stage = self._after_stage(context, self._prepared, job.result)
            except Exception as ex:                                # never a traceback, never a running timer
                self.report({'ERROR'}, self._failure(ex))
                stage = False
            if stage:
                self._job = PlannerJob(stage, Cancelled, *self._shown)     # the bar goes on from where it was
                self._tick(context, TURN_STEP if getattr(stage, "interface_turn", False) else TIMER_STEP)
                return {'RUNNING_MODAL'}
            if stage is False:
                self._finish(context)
                self._discard(self._prepared)
                self._job = self._prepared = None
                return {'CANCELLED'}
        self._finish(context)
        self._job = None
        if state == "cancelled":
            self._discard(self._prepared)
            self._prepared = None
            self.report({'WARNING'}, "{}: cancelled; nothing was changed".format(self._title))
            return {'CANCELLED'}
        if state == "failed":
            self._discard(self._prepared)
            self._prepared = None
            self.report({'ERROR'}, self._failure(job.error))
            return {'CANCELLED'}
        try:
            return self._build(context, self._prepared, job.result)
        finally:
            self._prepared = None

    def cancel(self, context):
        """Blender closes the operator (e.g. the file is closed): stop the worker, drop the result."""
        if self._job is not None:
            self._job.cancel()
            self._job = None
        if self._prepared is not None:
            self._discard(self._prepared)
            self._prepared = None
        self._finish(context)


classes = ()
register, unregister = bpy.utils.register_classes_factory(classes)
