# SPDX-License-Identifier: GPL-3.0-or-later
"""Blender test fixtures: build the host-platform zip once, run scenarios in subprocesses.

Every scenario runs ``driver.py`` with this interpreter (the venv with bpy) in a
fresh process whose BLENDER_USER_* variables point into a temporary directory,
so the extension is installed with Blender's own installer into a throw-away
user repository and the developer's Blender configuration is never touched.
"""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
BUILD_TOOL = ROOT / "tools" / "build_extension.py"
TIMEOUT = int(os.environ.get("FLANK_BLENDER_TEST_TIMEOUT", "900"))


def pytest_collection_modifyitems(config, items):
    for item in items:
        if HERE in Path(str(item.fspath)).resolve().parents:
            item.add_marker(pytest.mark.blender)


def _require_bpy():
    import importlib.util

    if importlib.util.find_spec("bpy") is None:
        pytest.skip("bpy is not installed in this interpreter ({}) -- use `make test`".format(sys.executable))


@pytest.fixture(scope="session")
def extension_zip(tmp_path_factory):
    """Installable zip for this machine's platform, built + validated by tools/build_extension.py."""
    _require_bpy()
    out = tmp_path_factory.mktemp("dist")
    summary_path = out / "build.json"
    proc = subprocess.run(
        [sys.executable, str(BUILD_TOOL), "--platforms", "host", "--output-dir", str(out), "--json",
         str(summary_path)],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=TIMEOUT)
    if proc.returncode != 0 and "unknown platform" in proc.stdout:
        pytest.skip("no bundled scipy wheels for this platform: " + proc.stdout.strip().splitlines()[-1])
    assert proc.returncode == 0, "build_extension.py failed:\n" + proc.stdout
    summary = json.loads(summary_path.read_text())
    assert len(summary["zips"]) == 1, summary
    return Path(summary["zips"][0]["path"])
