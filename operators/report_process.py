# SPDX-License-Identifier: GPL-3.0-or-later
"""A report picture rendered by Cycles in a separate Blender process (no bpy here, so it is tested without
Blender).

Blender renders on its main thread, and Cycles on the CPU takes tens of seconds for a report (about 42 s at
1280 x 800 on two cores), so ``flank.render_report`` does not render Cycles in the user's Blender: the main
thread writes the temporary scene to a .blend file (a few milliseconds), and a worker thread starts a second
Blender on it (:func:`render_command`), follows its samples through Blender's render statistics, waits for it
and reads the pixels back (:func:`render_in_child`).  Esc kills that process.  Workbench needs none of this: its
tiles are short enough for the main thread (``report_scene.report_tiles``).

The second Blender is ``bpy.app.binary_path`` run in the background with factory settings; Blender as a Python
module (the ``bpy`` wheel, whose ``binary_path`` is empty) runs the same script in its own Python instead.  (On
Windows it opens no console window.)
"""
import atexit
import os
import re
import subprocess
import threading
import time
from collections import deque

# run by the second Blender: open the scene's file, render that scene, save the render as the TGA the caller
# reads (the paths and the scene's name follow "--"; the statistics lines give the progress).  It leaves at once
# when the file is saved: Blender 4.2 as a Python module crashed in its teardown after a Cycles render.
CHILD_SCRIPT = """\
import os
import sys
import bpy
blend, scene, out = sys.argv[sys.argv.index("--") + 1:][:3]
bpy.ops.wm.open_mainfile(filepath=blend, load_ui=False)
sc = bpy.data.scenes[scene]
bpy.app.handlers.render_stats.append(lambda text: print("flank-render-stats:", text, flush=True))
done = bpy.ops.render.render(write_still=False, scene=sc.name)
if "FINISHED" not in done:
    raise RuntimeError("the render ended " + ", ".join(sorted(done)))
bpy.data.images["Render Result"].save_render(filepath=out, scene=sc)
sys.stdout.flush()
os._exit(0)
"""

STATS_PREFIX = "flank-render-stats:"
_SAMPLE = re.compile(r"Sample (\d+)/(\d+)")
_REMAINING = re.compile(r"Remaining: ([\d:.]+)")
POLL_SECONDS = 0.05            # how often the waiting worker reports progress and sees Esc
_live = {}                     # running processes -> their temporary files (stopped on unregister and exit)
_live_lock = threading.Lock()


def render_command(blend, scene, out, binary_path, python):
    """The command that renders ``scene`` of the .blend ``blend`` into the TGA ``out``: Blender's own executable
    ``binary_path`` (``bpy.app.binary_path``) in the background with factory settings, or, where that is empty
    (Blender as a Python module), the interpreter ``python`` that imports it."""
    tail = ["--", os.fspath(blend), str(scene), os.fspath(out)]
    if binary_path:
        return [binary_path, "--background", "--factory-startup", "-noaudio", "--python-exit-code", "1",
                "--python-expr", CHILD_SCRIPT] + tail
    if not python:
        raise RuntimeError("no Blender executable and no Python to run a separate render in")
    return [python, "-c", CHILD_SCRIPT] + tail


def sample_progress(line):
    """(fraction, message, seconds left) of one output line of the child, or None: Cycles' statistics report
    samples as 'Sample 5/16', after the first with Cycles' estimate 'Remaining: 00:22.20'; the other statistics
    (kernels, BVH) are shown as they are."""
    if not line.startswith(STATS_PREFIX):
        return None
    text = line[len(STATS_PREFIX):].strip()
    m = _SAMPLE.search(text)
    if m:
        done, total = int(m.group(1)), int(m.group(2))
        left = _REMAINING.search(text)
        seconds = None if left is None else sum(float(v) * 60.0 ** i for i, v in
                                                enumerate(reversed(left.group(1).split(":"))))
        return (done / total if total > 0 else 0.0), "Cycles: sample {} of {}".format(done, total), seconds
    last = text.rsplit("|", 1)[-1].strip()
    return None if not last or last.startswith("Mem") else (None, "Cycles: " + last, None)


class ChildRender:
    """One render process: started by the constructor, its output read by a thread (the last lines kept for
    an error message, the progress parsed by :func:`sample_progress`)."""

    def __init__(self, command, files=()):
        self.fraction, self.message, self.done_at = 0.0, "Cycles: starting Blender", None
        self.lines = deque(maxlen=30)
        try:
            self.process = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                            stderr=subprocess.STDOUT, text=True, errors="replace", bufsize=1,
                                            creationflags=getattr(subprocess, "CREATE_NO_WINDOW", 0))
        except OSError as ex:
            raise RuntimeError("could not start Blender for the Cycles render ({}): {}".format(command[0], ex)) \
                from None
        with _live_lock:
            _live[self.process] = tuple(files)
        self._reader = threading.Thread(target=self._read, name="flank-render-output", daemon=True)
        self._reader.start()

    def _read(self):
        for line in self.process.stdout:
            line = line.rstrip("\n")
            seen = sample_progress(line)
            if seen is None:
                if line.strip() and not line.startswith(STATS_PREFIX):
                    self.lines.append(line)
                continue
            fraction, message, seconds = seen
            if fraction is not None:
                self.fraction = fraction
            self.message = message
            self.done_at = None if seconds is None else time.monotonic() + seconds

    def progress(self):
        """(fraction, message) now: the last statistics, with Cycles' estimate of the time left counted down."""
        message, done_at = self.message, self.done_at
        if done_at is not None:
            message += ", about {:.0f} s left".format(max(done_at - time.monotonic(), 0.0))
        return self.fraction, message

    def wait(self, report, poll=POLL_SECONDS):
        """Wait for the process, calling ``report(fraction, message)`` every ``poll`` seconds (it raises to
        cancel: the process is then killed) -> its exit code."""
        try:
            while True:
                try:
                    code = self.process.wait(poll)
                    break
                except subprocess.TimeoutExpired:
                    report(*self.progress())
        finally:
            _stop(self.process)
            self._reader.join(1.0)
        return code

    def failure(self, code):
        """The error message of a process that ended with ``code`` (the last lines it wrote)."""
        # Blender's own notes on reading the file and a traceback's frames say nothing to the user; the
        # exception's line does
        said = [ln.strip() for ln in self.lines if not ln.startswith(("Warning: Library file", "Read blend",
                                                                      "Traceback", " ", "\t"))
                and "| Read blend" not in ln]
        tail = " / ".join(said[-3:]) if said else "no output"
        return "the Cycles render in a separate Blender ended with exit code {}: {}".format(code, tail)


def _stop(process):
    if process.poll() is None:
        process.kill()
        process.wait()
    with _live_lock:
        _live.pop(process, None)


def render_in_child(blend, scene, out, report, binary_path, python):
    """Render ``scene`` of the .blend file ``blend`` in a separate Blender (:func:`render_command`) -> the bytes
    of the TGA it saved to ``out``.  ``report(fraction, message)`` is called while it runs and cancels it by
    raising.  Both files are removed whatever happens."""
    files = (os.fspath(blend), os.fspath(out))
    try:
        child = ChildRender(render_command(blend, scene, out, binary_path, python), files)
        code = child.wait(report)
        if code != 0 or not os.path.isfile(out):
            raise RuntimeError(child.failure(code))
        with open(out, "rb") as fh:
            return fh.read()
    finally:
        _remove(files)


def _remove(files):
    for path in files:
        try:
            os.remove(path)
        except FileNotFoundError:
            pass
        except OSError:        # a file another program holds open: it is only a leftover, never the report
            pass


def running():
    """The render processes that are running now (their Popen objects)."""
    with _live_lock:
        return [p for p in _live if p.poll() is None]


def stop_all():
    """Kill every render process that still runs and remove its files (the extension unregisters, Blender
    quits)."""
    with _live_lock:
        live = list(_live.items())
    for process, files in live:
        _stop(process)
        _remove(files)


atexit.register(stop_all)

# No classes, and no bpy on purpose (tests/test_report_process.py loads this file without Blender).
classes = ()


def register():
    pass


def unregister():
    stop_all()
