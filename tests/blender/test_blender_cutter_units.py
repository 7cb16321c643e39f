# SPDX-License-Identifier: GPL-3.0-or-later
"""The formed cutter's tolerance and deviations are in scene units: the same rotor scaled x2 gives twice the
deviations, and a tolerance of twice the value paints the same colours (scenario_cutter_units.py)."""
import numpy as np
import pytest

from blender_harness import run_scenario


@pytest.fixture(scope="module")
def cu(extension_zip, tmp_path_factory):
    return run_scenario(extension_zip, "cutter_units", tmp_path_factory.mktemp("cutter_units"))["cutter_units"]


def test_tolerance_and_deviation_follow_the_rotor_scale(cu):
    a, b = cu["unit"], cu["scaled"]
    assert a["result"] == ["FINISHED"] and b["result"] == ["FINISHED"], (a["error"], b["error"])
    assert a["scale"] == pytest.approx(1.0) and b["scale"] == pytest.approx(2.0, rel=1e-6)
    assert a["tolerance"] == pytest.approx(0.01) and b["tolerance"] == pytest.approx(0.02)
    assert a["max_abs"] > 0 and b["max_abs"] == pytest.approx(2.0 * a["max_abs"], rel=1e-5)
    assert b["max_over"] == pytest.approx(2.0 * a["max_over"], rel=1e-5, abs=1e-12)
    da, db = np.asarray(a["dev"]), np.asarray(b["dev"])
    on = da < 1e8                                          # 1e9 marks vertices off the tooth
    assert on.sum() > 10 and np.array_equal(on, db < 1e8)
    assert np.allclose(db[on], 2.0 * da[on], rtol=1e-5, atol=1e-9)
    assert np.array_equal(np.asarray(a["cols"]), np.asarray(b["cols"]))     # tolerance x2 on deviations x2


def test_a_generated_rotor_is_planned_in_millimetres_in_a_scene_of_metres(cu):
    """The same 50 mm rotor made in a scene of metres (outer radius 0.05) and in one of millimetres (50): both
    plans hold millimetres and the same axis; before, the metre scene's plan said 0.05 mm."""
    m, mm = cu["generated"]["metres"], cu["generated"]["millimetres"]
    assert m["result"] == ["FINISHED"] and mm["result"] == ["FINISHED"], (m["error"], mm["error"])
    for run, scale in ((m, 0.001), (mm, 1.0)):
        assert run["unit"] == "mm" and run["length_scale"] == pytest.approx(scale, rel=1e-9)
        assert run["outer_radius"] == pytest.approx(50.0, rel=1e-6)
        assert run["v0"] == pytest.approx(run["rotor_v0"] / scale, rel=1e-6)
    assert m["v0"] == pytest.approx(mm["v0"], rel=1e-6)
    assert m["alpha"] == pytest.approx(mm["alpha"], abs=1e-6)
    for run in (m, mm):     # the animated tool keeps the tool's size and distance from the axis (was 1000 x)
        assert run["moving"] == pytest.approx(run["tool"], rel=1e-5), run
