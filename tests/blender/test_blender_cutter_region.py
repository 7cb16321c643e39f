# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.cutter_region through the installed extension (s000 §4): the admissible-cone cloud and the tool marker
against the core run in the same process (built-in asymmetric female, flank 1, 8^3 grid); bad input creates
nothing."""
import pytest

from blender_harness import run_scenario


@pytest.fixture(scope="module")
def cr(extension_zip, tmp_path_factory):
    out = run_scenario(extension_zip, "cutter_region", tmp_path_factory.mktemp("cutter_region"))
    return out["cutter_region"]


def test_cloud_holds_every_admissible_grid_cone(cr):
    h = cr["small"]
    assert h["result"] == ["FINISHED"], h["error"]
    assert h["collection"] and h["new"] == [2, 2, 2, 0]     # cloud + marker; its collection + "Flank Results"
    assert h["core_mask_sum"] > 0
    assert h["flag_sum"] == h["core_mask_sum"]          # every admissible grid point, flagged 1
    assert h["n_points"] > h["flag_sum"]                  # plus a sample of the others, flagged 0


def test_marker_agrees_with_the_core(cr):
    for name in ("small", "large"):
        h = cr[name]
        assert h["prop_admissible"] == h["core_ok"]
        assert h["prop_message"] == h["core_message"]
    assert cr["small"]["core_ok"] and not cr["large"]["core_ok"]
    assert "not admissible" in cr["large"]["prop_message"]


def test_rerun_replaces_the_collection(cr):
    assert cr["large"]["new"] == [0, 0, 0, 0]          # same flank: old objects out, new in


@pytest.mark.parametrize("name, text", [("bad_radii", "r1 = 0.08 and r2 = 0.05"), ("bad_flank", "flank 99")])
def test_bad_input_reports_and_creates_nothing(cr, name, text):
    h = cr[name]
    assert h["result"] is None and text in h["error"]
    assert h["new"] == [0, 0, 0, 0]
