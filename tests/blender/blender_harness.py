# SPDX-License-Identifier: GPL-3.0-or-later
"""Run a driver.py scenario in a fresh process with an isolated Blender user directory.

The zip is installed with Blender's own installer once per test run (:func:`installed_template`, next to the
zip); the scenarios get a hard-linked copy of that user repository and only enable the extension (0.13 s
instead of 0.86 s and 180 MB written per scenario).  The scenarios about installing itself install the zip
into their empty user directory as a user would (``INSTALLING``)."""
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
DRIVER = HERE / "driver.py"
TIMEOUT = int(os.environ.get("FLANK_BLENDER_TEST_TIMEOUT", "900"))
INSTALLING = {"lifecycle", "operators"}      # scenarios that install the zip themselves
TEMPLATE = "installed_user"                  # the installed user directory, next to the zip


def _user_env(user):
    env = dict(os.environ)
    env.update(
        BLENDER_USER_RESOURCES=str(user),
        BLENDER_USER_CONFIG=str(user / "config"),
        BLENDER_USER_SCRIPTS=str(user / "scripts"),
        BLENDER_USER_DATAFILES=str(user / "datafiles"),
        BLENDER_USER_EXTENSIONS=str(user / "extensions"),
        PYTHONNOUSERSITE="1",
    )
    env.pop("PYTHONPATH", None)  # the installed extension must not see the source tree
    return env


def installed_template(zip_path):
    """The user directory into which Blender's installer put ``zip_path`` (made on the first call; callers
    hold the zip's build lock)."""
    zip_path = Path(zip_path)
    template = zip_path.parent / TEMPLATE
    if not (template / "extensions").is_dir():
        part = zip_path.parent / (TEMPLATE + ".part")
        shutil.rmtree(part, ignore_errors=True)
        part.mkdir()
        code = ("import sys; sys.path.insert(0, {!r}); import bpy, driver; "
                "driver.install_extension(bpy, {!r})").format(str(HERE), str(zip_path))
        proc = subprocess.run([sys.executable, "-c", code], cwd=str(part), env=_user_env(part),
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=TIMEOUT)
        assert proc.returncode == 0, "installing {} failed:\n{}".format(zip_path, proc.stdout[-6000:])
        # byte-compile what the installer unpacked (the add-on and its bundled scipy): Blender writes these
        # caches on first import, but a test run may forbid it (PYTHONDONTWRITEBYTECODE), and then every
        # scenario would compile scipy and the add-on again (~0.9 s each)
        proc = subprocess.run([sys.executable, "-m", "compileall", "-q", str(part / "extensions")],
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=TIMEOUT)
        assert proc.returncode == 0, "byte-compiling the installed extension failed:\n" + proc.stdout[-6000:]
        os.replace(part, template)
    return template


def _copy_installed(template, user):
    """Hard-linked copy of the template's extensions (a file the scenario writes is replaced, not changed in
    place: Python writes its caches by rename); a plain copy where links are not possible."""
    try:
        shutil.copytree(template / "extensions", user / "extensions", copy_function=os.link)
    except OSError:
        shutil.rmtree(user / "extensions", ignore_errors=True)
        shutil.copytree(template / "extensions", user / "extensions")


def run_scenario(zip_path, scenario, tmp_dir, **options):
    """Run driver.py in a fresh process with an isolated Blender user directory; return its JSON."""
    tmp_dir = Path(tmp_dir)
    user = tmp_dir / "blender_user"
    user.mkdir(parents=True, exist_ok=True)
    env = _user_env(user)
    out = tmp_dir / "{}.json".format(scenario)
    cmd = [sys.executable, str(DRIVER), "--zip", str(zip_path), "--scenario", scenario, "--out", str(out)]
    template = Path(zip_path).parent / TEMPLATE
    if scenario not in INSTALLING and (template / "extensions").is_dir():
        _copy_installed(template, user)
        cmd.append("--preinstalled")
    for key, value in options.items():
        cmd += ["--" + key.replace("_", "-"), str(value)]
    proc = subprocess.run(cmd, cwd=str(tmp_dir), env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True, timeout=TIMEOUT)
    assert out.is_file(), "driver produced no result (exit {}):\n{}".format(proc.returncode, proc.stdout[-6000:])
    res = json.loads(out.read_text())
    res["_log"] = proc.stdout
    res["_user_dir"] = str(user)
    assert res.get("ok"), "scenario {} failed:\n{}\n--- log ---\n{}".format(
        scenario, res.get("exception"), proc.stdout[-6000:])
    return res


def running_polls(rec):
    """The modal() calls of a driven run (scenario_modal's record) made while the worker was running that kept the
    run going: the progress polls and the ESC key, not the final build."""
    return [c for c in rec["calls"] if c["state_before"] == "running" and c["result"] == ["RUNNING_MODAL"]]


def assert_failure_reported_like_sync(rec, sync, phrase):
    """A modal run whose worker failed (``rec``) ended CANCELLED with bpy.data as before and reported exactly what
    the synchronous run of the same input (``sync``: its result and error) reports, which names ``phrase``, and
    no traceback."""
    assert rec["final"] == ["CANCELLED"] and rec["census_equal"], rec
    assert sync["result"] is None and phrase in sync["error"], sync
    assert rec["op_error"] == sync["error"], (rec["op_error"], sync["error"])
    assert "Traceback" not in rec["op_error"]


def assert_cancelled_cleanly(rec, timer_step, plan):
    """A modal run (scenario_modal's driver) ended by ESC (``plan`` "esc") or by closing ("close"): it started
    like the UI starts it, ended CANCELLED with bpy.data and the scene as before, and left no worker, timer,
    progress or status text behind."""
    assert rec["driven"] and rec["start"] == ["RUNNING_MODAL"] and rec["has_job"], rec
    assert rec["wm_calls_start"] == [["event_timer_add", timer_step, True], ["progress_begin", 0, 100],
                                     ["modal_handler_add"]], rec["wm_calls_start"]
    assert "Esc cancels" in rec["status_start"]
    assert rec["final"] == ["CANCELLED"], rec
    assert rec["census_equal"], rec["census_diff"]
    assert rec["thread_alive"] is False and rec["timers_left"] == 0 and rec["operator_job_cleared"]
    assert rec["wm_calls"][-2:] == [["event_timer_remove"], ["progress_end"]]
    assert rec["status_last"] is None and not rec.get("timed_out")
    if plan == "esc":
        esc = [c for c in rec["calls"] if c["event"] == "ESC"]
        assert len(esc) == 1 and esc[0]["result"] == ["RUNNING_MODAL"] and "cancelling" in esc[0]["status"]
        assert rec["job_state"] == "cancelled" and rec["job_result_none"]


def assert_plans_kept(kept, at_least=1):
    """Every run plan the extension keeps parsed (``driver.plans_kept``) is still its run's stored text, parsed
    and checked again, number for number: no operator changed the shared plan it read."""
    live = {name: k for name, k in kept.items() if not k.get("removed")}
    assert len(live) >= at_least, kept
    for name, k in live.items():
        assert k["current"] and k["equal"], (name, k)


CONTINUED = "    "       # panels/common.py: the indent of a wrapped label's further lines


def panel_labels(calls):
    """The label texts a panel drew (recorded calls), each wrapped label joined back into one line."""
    out = []
    for call in calls:
        if call[0] != "label":
            continue
        if out and call[1].startswith(CONTINUED) and call[1].strip():
            out[-1] += " " + call[1][len(CONTINUED):]
        else:
            out.append(call[1])
    return out
