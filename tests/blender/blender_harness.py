# SPDX-License-Identifier: GPL-3.0-or-later
"""Run a driver.py scenario in a fresh process with an isolated Blender user directory."""
import json
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
DRIVER = HERE / "driver.py"
TIMEOUT = int(os.environ.get("FLANK_BLENDER_TEST_TIMEOUT", "900"))


def run_scenario(zip_path, scenario, tmp_dir, **options):
    """Run driver.py in a fresh process with an isolated Blender user directory; return its JSON."""
    tmp_dir = Path(tmp_dir)
    user = tmp_dir / "blender_user"
    user.mkdir(parents=True, exist_ok=True)
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
    out = tmp_dir / "{}.json".format(scenario)
    cmd = [sys.executable, str(DRIVER), "--zip", str(zip_path), "--scenario", scenario, "--out", str(out)]
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
