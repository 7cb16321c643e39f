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
# reads (the paths and the scene's name follow "--").  Progress: Blender's own executable prints its render
# statistics in the background ('Fra:1 Mem:... | Sample 5/16'); Blender as a Python module does not, but passes
# them to the render_stats handlers.  A Blender whose build or CPU cannot denoise (Debian's 3.4: "Build without
# OpenImageDenoiser") renders without the denoiser and says so.  The script leaves at once when the file is
# saved: Blender 4.2 as a Python module crashed in its teardown after a Cycles render.
CHILD_SCRIPT = """\
import os
import sys
import bpy
blend, scene, out = sys.argv[sys.argv.index("--") + 1:][:3]
bpy.ops.wm.open_mainfile(filepath=blend, load_ui=False)
sc = bpy.data.scenes[scene]
bpy.app.handlers.render_stats.append(
    lambda *args: isinstance(args[0] if args else None, str) and print("flank-render-stats:", args[0], flush=True))
try:
    done = bpy.ops.render.render(write_still=False, scene=sc.name)
except RuntimeError as ex:
    if not (sc.render.engine == "CYCLES" and sc.cycles.use_denoising and "denois" in str(ex).lower()):
        raise
    print("flank-render-note: rendered without denoising (" + " ".join(str(ex).replace("Error: ", "").split())
          + ")", flush=True)
    sc.cycles.use_denoising = False
    done = bpy.ops.render.render(write_still=False, scene=sc.name)
if "FINISHED" not in done:
    raise RuntimeError("the render ended " + ", ".join(sorted(done)))
bpy.data.images["Render Result"].save_render(filepath=out, scene=sc)
sys.stdout.flush()
os._exit(0)
"""

STATS_PREFIX = "flank-render-stats:"
NOTE_PREFIX = "flank-render-note:"
_SAMPLE = re.compile(r"Sample (\d+)/(\d+)")
_REMAINING = re.compile(r"Remaining:\s*([\d:.]+)")
_EXCEPTION = re.compile(r"^\s*(?:Error: )?(?:Python: )?([A-Za-z_][\w.]*(?:Error|Exception)): (.+)$")
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
    """(fraction, message, seconds left) of one output line of the child, or None where it is no statistics
    line.  Statistics lines are Blender's own ('Fra:1 Mem:8.2M ... | Remaining:00:22.20 | ... | Sample 5/16') or
    the script's ('flank-render-stats: ...'): Cycles reports its samples as 'Sample 5/16' (after the first with
    its estimate of the time left), the other statistics (kernels, BVH) are shown as they are."""
    if line.startswith(STATS_PREFIX):
        text = line[len(STATS_PREFIX):].strip()
    elif line.startswith("Fra:"):
        text = line.strip()
    else:
        return None
    m = _SAMPLE.search(text)
    if m:
        done, total = int(m.group(1)), int(m.group(2))
        left = _REMAINING.search(text)
        seconds = None if left is None else sum(float(v) * 60.0 ** i for i, v in
                                                enumerate(reversed(left.group(1).split(":"))))
        return (done / total if total > 0 else 0.0), "Cycles: sample {} of {}".format(done, total), seconds
    parts = [p.strip() for p in text.split("|")]
    last = parts[-1]
    if len(parts) > 1 and parts[-2].startswith("Synchronizing"):    # '... | Synchronizing object | <its name>'
        last = parts[-2]
    return None if not last or last.startswith(("Mem", "Fra:")) else (None, "Cycles: " + last, None)


class ChildRender:
    """One render process: started by the constructor, its output read by a thread (the last lines kept for
    an error message, the progress parsed by :func:`sample_progress`)."""

    def __init__(self, command, files=()):
        self.fraction, self.message, self.done_at = 0.0, "Cycles: starting Blender", None
        self.lines = deque(maxlen=60)
        self.notes = []
        try:
            self.process = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                            stderr=subprocess.STDOUT, text=True, encoding="utf-8",
                                            errors="replace", bufsize=1,
                                            creationflags=getattr(subprocess, "CREATE_NO_WINDOW", 0))
        except OSError as ex:
            raise RuntimeError("could not start Blender for the Cycles render ({}): {}".format(command[0], ex)) \
                from None
        with _live_lock:
            _live[self.process] = tuple(files)
        self._reader = threading.Thread(target=self._read, name="flank-render-output", daemon=True)
        self._reader.start()

    def _read(self):
        # the pipe is drained to its end whatever a line holds: a child blocked on a full pipe would hang
        for line in self.process.stdout:
            line = line.rstrip("\n")
            if line.startswith(NOTE_PREFIX):
                self.notes.append(line[len(NOTE_PREFIX):].strip())
                continue
            try:
                seen = sample_progress(line)
            except ValueError:                # a statistics line of an unexpected form: no progress from it
                continue
            if seen is None:
                if line.strip() and not line.startswith((STATS_PREFIX, "Fra:")):
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
            if not self._reader.is_alive():
                self.process.stdout.close()
        return code

    def failure(self, code):
        """The error message of a process that ended with ``code``: the last exception it printed, else its last
        'Error: ' line, else its last lines (Blender's notes on reading the file, a traceback's frames and the
        script Blender echoes are left out)."""
        lines = [ln.strip() for ln in self.lines]
        said = next((m.group(1) + ": " + m.group(2).replace("Error: ", "") for m in
                     (_EXCEPTION.match(ln) for ln in reversed(lines)) if m), None)
        if said is None:
            said = next((ln[len("Error: "):] for ln in reversed(lines) if ln.startswith("Error: ")
                         and not ln.startswith(("Error: script failed", "Error: Python: Traceback"))), None)
        if said is None:
            rest = [ln for ln in lines if ln and not ln.startswith(("Warning: Library file", "Read blend",
                                                                     "Traceback", "File "))
                    and "| Read blend" not in ln]
            said = " / ".join(rest[-3:]) if rest else "no output"
        return "the Cycles render in a separate Blender ended with exit code {}: {}".format(code, said)


def _stop(process):
    if process.poll() is None:
        process.kill()
        process.wait()
    with _live_lock:
        _live.pop(process, None)


def render_in_child(blend, scene, out, report, binary_path, python, notes=None):
    """Render ``scene`` of the .blend file ``blend`` in a separate Blender (:func:`render_command`) -> the bytes
    of the TGA it saved to ``out``.  ``report(fraction, message)`` is called while it runs and cancels it by
    raising; the child's notes (a render without the denoiser) are appended to the list ``notes``.  Both files
    are removed whatever happens."""
    files = (os.fspath(blend), os.fspath(out))
    try:
        report(0.0, "Cycles: starting Blender")         # a cancel already asked for starts no Blender
        child = ChildRender(render_command(blend, scene, out, binary_path, python), files)
        code = child.wait(report)
        if notes is not None:
            notes.extend(child.notes)
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
        except OSError:        # gone already, or held open by another program: a leftover, never the report
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
