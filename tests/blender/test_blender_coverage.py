# SPDX-License-Identifier: GPL-3.0-or-later
"""Whole-flank coverage in Blender (scenario_coverage.py): a single-flank run with two tool presets in turn
equals the core's plan of the same inputs (strips, each strip's tool, covered fraction, uncovered ranges and
their reasons); the strips list names each strip's tool and shows the share of the flank it machines as the
verify engine owns it; the Results panel states the covered fraction and every uncovered range with its reason;
the residual mesh lies on the flank (just off it) over exactly the uncovered ranges along the whole rotor body;
bad preset names create nothing."""
import json
import math

import pytest

from blender_harness import run_scenario

OFFSET = 0.004 * 50.0            # the residual mesh stands 0.004 outer radii off the flank (mm)


@pytest.fixture(scope="module")
def cov(extension_zip, tmp_path_factory):
    return run_scenario(extension_zip, "coverage", tmp_path_factory.mktemp("coverage"))


@pytest.mark.parametrize("case, words", [("unknown", ["tool presets 'No Such Tool'", "no tool preset",
                                                      "Tapered 1deg D1 L10"]),
                                         ("twice", ["is named twice"])])
def test_bad_preset_names_create_nothing(cov, case, words):
    bad = cov["bad"][case]
    assert bad["result"] is None and bad["error"].startswith("Error: Single flank: "), bad
    for w in words:
        assert w in bad["error"], (w, bad["error"])
    assert "Traceback" not in bad["error"] and bad["new"] == [0, 0, 0, 0]


def test_the_run_is_the_cores_plan_with_two_tools(cov):
    run, core = cov["run"], cov["core"]
    assert run["result"] == ["FINISHED"], run["error"]
    p = run["props"]
    assert p["flank_sf_strips"] == core["strips"] == len(run["plan_strip_tools"])
    # both presets milled: each strip's tool as the core names it, on the tool objects and in the plan
    assert run["plan_strip_tools"] == core["strip_tools"] == json.loads(p["flank_sf_strip_tools"])
    assert set(core["strip_tools"]) == {"Tapered 5deg D6 L20", "Tapered 1deg D1 L10"}
    assert run["tool_names"] == {str(k): name for k, name in enumerate(core["strip_tools"])}
    assert [(t["name"], t["strips"]) for t in json.loads(p["flank_sf_tools"])] == \
        [(t["name"], t["strips"]) for t in core["tools"]]
    # the first tool the plan uses is the run's tool (mm: a unit-less scene, rotor of outer radius 50)
    assert p["flank_sf_tool_r1"] == pytest.approx(3.0, rel=1e-9)
    assert p["flank_sf_tool_alpha"] == pytest.approx(math.radians(5.0), rel=1e-9)
    assert p["flank_sf_covered_fraction"] == pytest.approx(core["covered_fraction"], abs=1e-12)
    assert p["flank_sf_covered_fraction"] == pytest.approx(run["plan_summary"]["covered_fraction"], abs=1e-15)
    assert 0.2 < core["covered_fraction"] < 1.0 and core["uncovered"]


def test_strip_rows_name_the_tool_and_the_verified_share(cov):
    rows, run = cov["rows"], cov["run"]
    core = cov["core"]
    ver = cov["verify_shares"]
    assert len(rows) == len(ver) == core["strips"]
    total = 0.0
    for k, v in enumerate(ver):
        row = rows[str(k)]
        assert row["tool"] == core["strip_tools"][k]
        if v is None:
            assert row["covered"] == "none"
            continue
        a, b = (float(x) / 100 for x in row["covered"].rstrip(" %").split("–"))
        assert (a, b) == pytest.approx(v[:2], abs=0.006)          # the text's rounding to 1 %
        total += v[2]
    shares = run["props"]["flank_sf_strip_share"]
    assert shares == pytest.approx([v[2] if v else 0.0 for v in ver], abs=1e-12)
    # the strips' shares add up to the plan's covered fraction (computed by the planner's own code)
    assert total == pytest.approx(core["covered_fraction"], abs=1e-9)
    for k, log in cov["draw_items"].items():
        assert log[1] == ["label", "Strip {}".format(int(k) + 1), "MOD_SCREW"]
        assert ["label", core["strip_tools"][int(k)], "TOOL_SETTINGS"] in log
        assert log[-1][0] == "label" and log[-1][2] in ("CHECKMARK", "ERROR")


def test_results_panel_states_the_covered_fraction_and_the_reasons(cov):
    labels = cov["results_panel"]
    assert isinstance(labels, list), labels
    core = cov["core"]
    head = "Covered {:.1f} % of the flank within tolerance".format(100.0 * core["covered_fraction"])
    assert head in labels
    text = " ".join(lab.strip() for lab in labels)
    residual = cov["info"]["residual"]
    assert [r["reason"] for r in residual] == [r["reason"] for r in core["uncovered"]]
    for r, c in zip(residual[:6], core["uncovered"]):
        line = "{:.1f}–{:.1f} %: ".format(100.0 * r["start"], 100.0 * r["end"])
        assert any(lab.startswith(line) for lab in labels), (line, labels)
        # the reason, wrapped into lines, is all there (up to 4 lines of 52 characters)
        words = c["reason"].split()
        assert " ".join(words[:8]) in text, (c["reason"], text)
        assert r["length"] == pytest.approx(c["length"], rel=1e-12)     # mm, scale 1
        assert r["kind"] == c["kind"]
    # the shares of the ranges are their arc lengths over the flank's (one flank length for all of them)
    flank = [(c["arc_range"][1] - c["arc_range"][0]) / (r["end"] - r["start"])
             for r, c in zip(residual, core["uncovered"]) if r["end"] > r["start"]]
    assert max(flank) == pytest.approx(min(flank), rel=1e-9)
    assert "sf_tools" in cov["sf_panel_props"]          # the Tool Presets setting in the Single-Flank panel


def test_residual_mesh_marks_the_uncovered_ranges_on_the_flank(cov):
    rsd, core, run = cov["residual"], cov["core"], cov["run"]
    assert run["roles"]["residual"] == ["SF F1 Residual"]
    assert rsd["attr"] == ["INT", "POINT"] and rsd["active_color"] == "error_color"
    assert rsd["material"] == ["Flank Attribute Colour"]
    # every vertex stands OFFSET off the flank profile (measured here against 40k profile samples)
    assert rsd["distance"][0] == pytest.approx(OFFSET, abs=2e-3) and rsd["distance"][1] == pytest.approx(OFFSET,
                                                                                                       abs=2e-3)
    # along the whole rotor body
    assert rsd["z"] == pytest.approx([0.0, core["length"]], abs=1e-4)
    # each uncovered range: its profile points, half a profile step wider each side (inside the flank)
    half = 0.5 * core["period"] / core["n_profile"]
    a0, b0 = core["flank_range"]
    step = (b0 - a0) / 40000
    assert sorted(rsd["ranges"]) == [str(k) for k in range(len(core["uncovered"]))]
    for k, c in enumerate(core["uncovered"]):
        lo = max(a0, c["u_range"][0] - half)
        hi = min(b0, c["u_range"][1] + half)
        got = rsd["ranges"][str(k)]["u"]
        assert got == pytest.approx([lo, hi], abs=2 * step + 1e-9), (k, got, lo, hi)
        # material left beyond the tolerance: verify's colours of the range, one per range
        assert len(rsd["ranges"][str(k)]["colors"]) == 1
    assert rsd["props"]["flank_sf_residual_u"] == pytest.approx(
        [v for c in core["uncovered"] for v in (max(a0, c["u_range"][0] - half), min(b0, c["u_range"][1] + half))],
        abs=1e-12)
    # the run: per strip its tool and envelope, the chart and the residual (no animation); "Flank Results" and
    # the run's collection
    n = run["props"]["flank_sf_strips"]
    assert run["new"] == [2 * n + 2, 2 * n + 2, 2, 0]
    assert sorted(run["roles"]) == ["envelope", "error_chart", "residual", "tool"]
