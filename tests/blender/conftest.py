# SPDX-License-Identifier: GPL-3.0-or-later
"""Blender test fixtures: build the host-platform zip once, run scenarios in subprocesses.

Every scenario runs ``driver.py`` with this interpreter (the venv with bpy) in a
fresh process whose BLENDER_USER_* variables point into a temporary directory,
so the extension is installed with Blender's own installer into a throw-away
user repository and the developer's Blender configuration is never touched.
"""
import contextlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from blender_harness import installed_template

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


@contextlib.contextmanager
def _file_lock(path):
    """Exclusive lock on ``path`` across processes (the xdist workers of one run)."""
    with open(path, "a+b") as fh:
        if os.name == "nt":
            import msvcrt

            fh.seek(0)
            while True:
                try:
                    msvcrt.locking(fh.fileno(), msvcrt.LK_LOCK, 1)
                    break
                except OSError:          # LK_LOCK gives up after 10 s: keep waiting
                    continue
        else:
            import fcntl

            fcntl.flock(fh.fileno(), fcntl.LOCK_EX)
        try:
            yield
        finally:
            if os.name == "nt":
                fh.seek(0)
                msvcrt.locking(fh.fileno(), msvcrt.LK_UNLCK, 1)
            else:
                fcntl.flock(fh.fileno(), fcntl.LOCK_UN)


@pytest.fixture(scope="session")
def extension_zip(tmp_path_factory):
    """Installable zip for this machine's platform, built + validated by tools/build_extension.py.

    Built once per test run: under pytest-xdist the first worker that needs it builds it into the run's
    shared base directory while holding a lock, the others wait for it and reuse it (a build also
    downloads the scipy wheels into wheels/, which must not happen twice at the same time).  Under the same
    lock Blender's installer puts it into a template user directory once (blender_harness.installed_template),
    which the scenarios copy."""
    _require_bpy()
    base = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        base = base.parent                  # .../pytest-N, shared by the workers .../pytest-N/popen-gwK
    out = base / "extension_dist"
    summary_path = out / "build.json"
    with _file_lock(base / "extension_dist.lock"):
        if not summary_path.is_file():
            out.mkdir(exist_ok=True)
            proc = subprocess.run(
                [sys.executable, str(BUILD_TOOL), "--platforms", "host", "--output-dir", str(out), "--json",
                 str(summary_path) + ".part"],
                cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=TIMEOUT)
            if proc.returncode != 0 and "unknown platform" in proc.stdout:
                pytest.skip("no bundled scipy wheels for this platform: " + proc.stdout.strip().splitlines()[-1])
            assert proc.returncode == 0, "build_extension.py failed:\n" + proc.stdout
            os.replace(str(summary_path) + ".part", summary_path)
        summary = json.loads(summary_path.read_text())
        assert len(summary["zips"]) == 1, summary
        zip_path = Path(summary["zips"][0]["path"])
        installed_template(zip_path)        # Blender's installer, once: the scenarios copy what it made
    return zip_path
