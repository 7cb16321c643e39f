# SPDX-License-Identifier: GPL-3.0-or-later
"""The README's scripted console example (tools/console_example.py, bpy module + the installed zip): it plans,
exports, verifies and renders, and its numbers are the core's for the same plan file."""
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def test_console_example_plans_verifies_and_renders(extension_zip, tmp_path):
    out = tmp_path / "console"
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)                     # the installed extension, not the source tree
    proc = subprocess.run([sys.executable, str(ROOT / "tools" / "console_example.py"), "--zip", str(extension_zip),
                           "--out", str(out)], cwd=str(tmp_path), env=env, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, text=True, timeout=900)
    assert proc.returncode == 0, proc.stdout[-4000:]
    numbers = json.loads((out / "example.json").read_text())
    assert {"plan.json", "rotor.apt", "report.png", "example.json"} <= set(numbers["outputs"] + ["example.json"])
    assert "Traceback" not in proc.stdout

    # the plan file the example exported (plain JSON: the compat venvs hold no scipy for flank_addon)
    plan = json.loads((out / "plan.json").read_text())
    assert plan["schema"] == "flank-plan/1" and len(plan["strips"]) == numbers["strips"] >= 5
    # the planner's own error figures are the plan's, in mm (tolerance 0.05 mm: the strips are within it)
    assert numbers["planned_max_error"] == max(s["reported_max_error"] for s in plan["strips"])
    assert 0 <= numbers["planned_max_error"] <= 0.05
    # verify_plan's sweep simulation is independent of the planner's error model: both agree on the
    # largest undercut, and the simulation finds no overcut and no gouge
    assert np.isclose(numbers["verified_max_undercut"], numbers["planned_max_error"], rtol=1e-6, atol=1e-9)
    assert numbers["gouges"] == 0 and numbers["verified_max_overcut"] > -1e-6
    # the CL file holds one GOTO per step and strip; the report is a 1280 x 800 PNG
    goto = [ln for ln in (out / "rotor.apt").read_text().splitlines() if ln.startswith("GOTO/")]
    assert len(goto) >= numbers["strips"] * 100
    png = (out / "report.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert int.from_bytes(png[16:20], "big") == 1280 and int.from_bytes(png[20:24], "big") == 800
