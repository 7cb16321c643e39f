# SPDX-License-Identifier: GPL-3.0-or-later
"""Run a planner off Blender's UI thread: :class:`PlannerJob` (no bpy here, so it is tested without
Blender).

The planner (pure numpy/scipy, no Blender data) runs in a worker thread and reports through
``progress(fraction, message)``; the modal operator polls :meth:`PlannerJob.poll` on a timer,
shows the fraction and message, and calls :meth:`PlannerJob.cancel` on ESC.  The planner then
raises ``Cancelled`` at its next report and the job ends without a result, so the operator, which
builds Blender data only from a finished result on the main thread, leaves the scene as it was.
"""
import gc
import threading
import time


class PlannerJob:
    """``compute(progress)`` in a daemon thread.  States: 'running', 'finished' (``result``),
    'cancelled', 'failed' (``error``: the exception)."""

    def __init__(self, compute, cancelled_type=None, fraction=0.0, message="starting"):
        self._compute = compute
        self._cancelled_type = cancelled_type
        self._lock = threading.Lock()
        self._cancel = threading.Event()
        self.fraction, self.message = float(fraction), str(message)     # a later stage starts where the last ended
        self.state, self.result, self.error = "running", None, None
        self.started = time.perf_counter()
        self.elapsed = None
        self._thread = threading.Thread(target=self._run, name="flank-planner", daemon=True)
        self._thread.start()

    def _progress(self, fraction, message):
        with self._lock:
            self.fraction, self.message = float(fraction), str(message)
        return not self._cancel.is_set()

    def _run(self):
        try:
            result = self._compute(self._progress)
        except BaseException as ex:          # reported by the operator on the main thread
            cancelled = self._cancel.is_set() and (self._cancelled_type is None
                                                   or isinstance(ex, self._cancelled_type))
            with self._lock:
                self.state = "cancelled" if cancelled else "failed"
                self.error = None if cancelled else ex
        else:
            with self._lock:
                if self._cancel.is_set():    # finished before it saw the request: still discard it
                    self.state = "cancelled"
                else:
                    self.state, self.result, self.fraction, self.message = "finished", result, 1.0, "done"
        self.elapsed = time.perf_counter() - self.started

    def cancel(self):
        """Ask the planner to stop.  A result that is already there is dropped too: after ESC the operator
        never builds, however the race between the worker's end and the key press went."""
        with self._lock:
            self._cancel.set()
            if self.state == "finished":
                self.state, self.result = "cancelled", None

    def poll(self):
        """(state, fraction, message) -- safe to call from the UI thread at any time."""
        with self._lock:
            return self.state, self.fraction, self.message

    def wait(self, timeout=None):
        self._thread.join(timeout)
        return self.poll()[0]


# what a first click imports: the rotor reader on the main thread (scipy.spatial through helical_surface,
# 0.2 s), the planners and their scipy parts in the worker, the machine and post modules on Post Program's main
# thread (and the mesh foot points' thread pool, 16 ms, which the free-form planner makes at its first query);
# names with a leading dot are in the extension
WARM_MODULES = (".flank_addon.geometry.helical_surface", ".flank_addon.geometry.rotor_analysis",
                ".flank_addon.simulation.verify", ".flank_addon.methods.single_flank.planner",
                ".flank_addon.methods.double_flank.planner", ".flank_addon.methods.freeform_g1.planner",
                ".flank_addon.methods.formed_cutter.cutter_profile", ".flank_addon.machining.machine",
                ".flank_addon.posts", "scipy.optimize", "scipy.interpolate", "concurrent.futures")

_warm_up = None
_warm_up_lock = threading.Lock()


class WarmUp:
    """Imports ``names`` (relative to ``package`` where they start with a dot) in a daemon thread, so that the
    first click of a session does not import them on Blender's main thread.  ``imported``: the names done;
    ``failed``: {name: exception} -- kept, never raised (the click that needs the module reports it).

    Then it runs one full collection of Python's garbage collector.  The imports leave tens of thousands of new
    objects in the collector's young generations, which brings a full collection due: without this one it
    came within the first click, walking every object of the process (14-24 ms of a double-flank click in the
    command line's process), and afterwards a click's own objects are too few to bring the next one due
    (``bench/bench_click_parts.py``, ``collector``).  ``collect_s``: how long it took; it holds the interpreter
    lock, so Blender's interface waits that long, once (the Blender tests print it)."""

    def __init__(self, package, names):
        self.names, self.imported, self.failed = tuple(names), [], {}
        self.collect_s = None
        self.started = time.perf_counter()
        self.elapsed = None
        self._thread = threading.Thread(target=self._run, args=(package,), name="flank-warm-up", daemon=True)
        self._thread.start()

    def _run(self, package):
        import importlib

        for name in self.names:
            try:
                importlib.import_module(name, package if name.startswith(".") else None)
            except BaseException as ex:      # a broken install shows when an operator imports it
                self.failed[name] = ex
            else:
                self.imported.append(name)
        t = time.perf_counter()
        gc.collect()
        self.collect_s = time.perf_counter() - t
        self.elapsed = time.perf_counter() - self.started

    def wait(self, timeout=None):
        self._thread.join(timeout)
        return not self._thread.is_alive()


def warm_up(package, names=WARM_MODULES):
    """Start the one :class:`WarmUp` of this process (the extension's ``package``); later calls return it."""
    global _warm_up
    with _warm_up_lock:
        if _warm_up is None:
            _warm_up = WarmUp(package, names)
        return _warm_up


# No classes, and no bpy on purpose (tests/test_jobs.py loads this file without Blender): nothing to register.
classes = ()


def register():
    pass


def unregister():
    pass
