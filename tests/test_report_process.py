"""A Cycles report rendered by a separate process (operators/report_process.py has no bpy import): the command,
the progress read from Blender's render statistics, the pixels read back, and a process that fails or is
cancelled.  Blender itself is stood in for by a small script that answers the same command line (the Blender
tests render with the real one: tests/blender/test_blender_render_report.py, test_blender_modal_tools.py)."""
import importlib.util
import os
import stat
import sys
import time
from pathlib import Path

import pytest

from flank_addon.progress import Cancelled, reporter

# the stand-in Blender is a script with a shebang line, and a killed process's exit code is minus its signal
posix_only = pytest.mark.skipif(os.name != "posix", reason="the stand-in Blender needs a POSIX shell")

_spec = importlib.util.spec_from_file_location(
    "flank_report_process", Path(__file__).resolve().parents[1] / "operators" / "report_process.py")
rp = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rp)

# answers Blender's command line: after "--" the .blend, the scene and the TGA to write; BEHAVE says how
FAKE_BLENDER = """#!{python}
import os, sys, time
args = sys.argv[1:]
assert args[:6] == ["--background", "--factory-startup", "-noaudio", "--python-exit-code", "1", "--python-expr"]
blend, scene, out = args[args.index("--") + 1:]
behave = os.environ.get("FAKE_BEHAVE", "ok")
print("Read blend:", blend, flush=True)
for i in range(0, 17, 4):
    print("flank-render-stats: Remaining: 00:{{:05.2f}} | Mem: 8M | Sample {{}}/16".format(16 - i, i), flush=True)
    time.sleep(0.15 if behave == "slow" else 0.01)
if behave == "fail":
    print("Traceback (most recent call last):", flush=True)
    print('  File "<string>", line 5, in <module>', flush=True)
    print("KeyError: 'bpy_prop_collection[key]: key \\"" + scene + "\\" not found'", flush=True)
    sys.exit(1)
if behave == "blender_fail":      # Blender's own executable: the error, the traceback, the script echoed back
    print("Error: Build without OpenImageDenoiser", flush=True)
    print("Error: Python: Traceback (most recent call last):", flush=True)
    print('  File "<string>", line 8, in <module>', flush=True)
    print("RuntimeError: Error: Build without OpenImageDenoiser", flush=True)
    print("", flush=True)
    print("Error: script failed, expr: 'import os", flush=True)
    print("import sys", flush=True)
    print("os._exit(0)", flush=True)
    print("', exiting.", flush=True)
    sys.exit(1)
if behave == "note":
    print("flank-render-note: rendered without denoising (Build without OpenImageDenoiser)", flush=True)
if behave != "no_file":
    with open(out, "wb") as fh:
        fh.write(b"pixels of " + scene.encode())
"""


@pytest.fixture()
def fake_blender(tmp_path):
    path = tmp_path / "blender"
    path.write_text(FAKE_BLENDER.format(python=sys.executable))
    path.chmod(path.stat().st_mode | stat.S_IXUSR)
    return str(path)


def _files(tmp_path):
    blend, out = tmp_path / "r.png.render1.blend", tmp_path / "r.png.render1.cycles.tga"
    blend.write_bytes(b"BLENDER")
    return str(blend), str(out)


def test_the_command_runs_blender_or_blender_as_a_python_module():
    cmd = rp.render_command("/x/s.blend", "Flank Report", "/x/o.tga", "/opt/blender/blender", "/usr/bin/python3")
    assert cmd[0] == "/opt/blender/blender" and cmd[1:3] == ["--background", "--factory-startup"]
    assert cmd[cmd.index("--python-expr") + 1] == rp.CHILD_SCRIPT
    assert cmd[-4:] == ["--", "/x/s.blend", "Flank Report", "/x/o.tga"]
    # the bpy wheel: binary_path is empty, its own Python imports bpy
    cmd = rp.render_command("/x/s.blend", "Flank Report", "/x/o.tga", "", "/venv/bin/python")
    assert cmd == ["/venv/bin/python", "-c", rp.CHILD_SCRIPT, "--", "/x/s.blend", "Flank Report", "/x/o.tga"]
    with pytest.raises(RuntimeError, match="no Blender executable"):
        rp.render_command("/x/s.blend", "S", "/x/o.tga", "", "")
    compile(rp.CHILD_SCRIPT, "child", "exec")


@pytest.mark.parametrize("line,seen", [
    ("flank-render-stats: Remaining: 00:22.20 | Mem: 83M | Sample 1/16", (1 / 16, "Cycles: sample 1 of 16", 22.2)),
    ("flank-render-stats: Remaining: 01:02:03.5 | Sample 2/16", (0.125, "Cycles: sample 2 of 16", 3723.5)),
    ("flank-render-stats: Mem: 13M | Sample 16/16", (1.0, "Cycles: sample 16 of 16", None)),
    ("flank-render-stats: Mem: 2M | Updating Scene BVH | Building BVH 0%", (None, "Cycles: Building BVH 0%", None)),
    ("flank-render-stats: Mem: 13M", None),
    ("Fra:1 Mem:8.31M | Time:00:00.00 | Scene, ViewLayer | Synchronizing object | Rotor",
     (None, "Cycles: Synchronizing object", None)),
    ("Read blend: /x/s.blend", None),
    # Blender's own executable prints its statistics itself
    ("Fra:1 Mem:40.14M (Peak 40.14M) | Time:00:00.18 | Remaining:00:01.14 | Mem:16.85M, Peak:16.85M | "
     "Flank Report (temporary), ViewLayer | Sample 1/16", (1 / 16, "Cycles: sample 1 of 16", 1.14)),
    ("Fra:1 Mem:8.75M (Peak 8.75M) | Time:00:00.03 | Mem:0.00M, Peak:0.00M | Flank Report (temporary), ViewLayer | "
     "Updating Lights", (None, "Cycles: Updating Lights", None)),
])
def test_progress_is_read_from_the_render_statistics(line, seen):
    assert rp.sample_progress(line) == seen


@posix_only
def test_the_pixels_come_back_and_both_files_go(fake_blender, tmp_path, monkeypatch):
    # samples over 0.75 s, 15 polls: the waiting worker sees them even on a busy machine (at 0.05 s in all, one
    # poll, it once saw none while the other test worker ran Blender)
    monkeypatch.setenv("FAKE_BEHAVE", "slow")
    blend, out = _files(tmp_path)
    seen = []
    data = rp.render_in_child(blend, "Flank Report", out, lambda f, m: seen.append((f, m)), fake_blender, None)
    assert data == b"pixels of Flank Report"
    assert not os.path.exists(blend) and not os.path.exists(out)
    assert rp.running() == []
    fractions = [f for f, _ in seen]
    assert fractions == sorted(fractions) and max(fractions) <= 1.0, seen
    # Cycles' estimate of the time left, counted down between its reports
    assert any(m.startswith("Cycles: sample ") and m.endswith(" s left") for _, m in seen), seen


@posix_only
@pytest.mark.parametrize("behave,words", [
    ("fail", "exit code 1: KeyError: 'bpy_prop_collection[key]: key \"Flank Report\" not found'"),
    ("no_file", "exit code 0: no output"),
    ("blender_fail", "exit code 1: RuntimeError: Build without OpenImageDenoiser"),
])
def test_a_failed_render_is_a_clear_error_and_leaves_no_file(fake_blender, tmp_path, monkeypatch, behave, words):
    monkeypatch.setenv("FAKE_BEHAVE", behave)
    blend, out = _files(tmp_path)
    with pytest.raises(RuntimeError) as err:
        rp.render_in_child(blend, "Flank Report", out, lambda f, m: None, fake_blender, None)
    assert str(err.value).startswith("the Cycles render in a separate Blender ended with ") and words in str(err.value)
    text = str(err.value)
    assert "Read blend" not in text and "Traceback" not in text and "File" not in text and "exiting" not in text
    assert os.listdir(tmp_path) == ["blender"]


@posix_only
def test_the_childs_notes_reach_the_caller(fake_blender, tmp_path, monkeypatch):
    """A Blender that cannot denoise renders without the denoiser and says so; the operator reports it."""
    monkeypatch.setenv("FAKE_BEHAVE", "note")
    blend, out = _files(tmp_path)
    notes = []
    assert rp.render_in_child(blend, "S", out, lambda f, m: None, fake_blender, None, notes=notes) == b"pixels of S"
    assert notes == ["rendered without denoising (Build without OpenImageDenoiser)"]


def test_a_cancel_asked_for_before_the_start_starts_no_blender(tmp_path, monkeypatch):
    blend, out = _files(tmp_path)
    started = []
    monkeypatch.setattr(rp, "ChildRender", lambda *a, **k: started.append(a))

    def stop(fraction, message):
        raise Cancelled(message)

    with pytest.raises(Cancelled):
        rp.render_in_child(blend, "S", out, stop, "/no/blender", None)
    assert started == [] and os.listdir(tmp_path) == []


def test_a_missing_blender_is_a_clear_error(tmp_path):
    blend, out = _files(tmp_path)
    with pytest.raises(RuntimeError, match="could not start Blender for the Cycles render .*no_such_blender"):
        rp.render_in_child(blend, "S", out, lambda f, m: None, str(tmp_path / "no_such_blender"), None)
    assert os.listdir(tmp_path) == []


@posix_only
def test_cancelling_kills_the_process_at_once(fake_blender, tmp_path, monkeypatch):
    """Esc: the progress call raises Cancelled; the process is killed within a poll, not left to finish."""
    monkeypatch.setenv("FAKE_BEHAVE", "slow")               # 0.75 s of samples
    blend, out = _files(tmp_path)
    made = []
    real = rp.ChildRender.__init__

    def record(child, command, files=()):
        real(child, command, files)
        made.append(child.process)

    monkeypatch.setattr(rp.ChildRender, "__init__", record)
    calls = []

    def progress(fraction, message):
        calls.append(fraction)
        return len(calls) < 3                  # the third report asks to stop

    t0 = time.perf_counter()
    with pytest.raises(Cancelled):
        rp.render_in_child(blend, "S", out, reporter(progress), fake_blender, None)
    assert time.perf_counter() - t0 < 2.0               # not the 0.75 s of samples left (and a loaded CI machine)
    assert len(made) == 1 and made[0].returncode is not None and made[0].returncode < 0, made
    assert rp.running() == [] and os.listdir(tmp_path) == ["blender"]


@posix_only
def test_stop_all_kills_what_still_runs(fake_blender, tmp_path, monkeypatch):
    """On unregister and at exit: every running render is killed and its files removed."""
    monkeypatch.setenv("FAKE_BEHAVE", "slow")
    blend, out = _files(tmp_path)
    child = rp.ChildRender(rp.render_command(blend, "S", out, fake_blender, None), (blend, out))
    assert rp.running() == [child.process]
    rp.stop_all()
    assert child.process.returncode is not None and child.process.returncode < 0
    assert rp.running() == [] and os.listdir(tmp_path) == ["blender"]
