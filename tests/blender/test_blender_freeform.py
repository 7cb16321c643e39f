# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.plan_freeform (Rajain et al. 2023) and its helpers through the installed extension (scenario_freeform.py): a parabolic
blade moved, rotated 90 deg and scaled x2, a cylindrical tool along the blade's rulings (exact), compared number for
number with the core run on the same local vertices; re-run, results list, exports, animation, the guiding-curve
preview (and its live update), direction picking, a vector-attribute field, selected faces and bad input."""
import numpy as np
import pytest

from blender_harness import assert_plans_kept, run_scenario

S = 2.0
NOTHING = {"objects": 0, "meshes": 0, "collections": 0, "curves": 0, "images": 0}


@pytest.fixture(scope="module")
def ff(extension_zip, tmp_path_factory):
    return run_scenario(extension_zip, "freeform", tmp_path_factory.mktemp("freeform"))["freeform"]


def test_run_builds_strips_tools_boundaries_and_guiding_curves(ff):
    assert ff["run"]["result"] == ["FINISHED"], ff["run"]["error"]
    st = ff["state"]
    n = ff["core"]["strips"]
    assert n >= 3
    assert st["name"] == "Free-form (Parabolic Blade)" and st["parent"] == ["Flank Results"]
    assert len(st["roles"]["envelope"]) == len(st["roles"]["tool"]) == n
    assert len(st["roles"]["boundary"]) == n - 1 and st["roles"]["guiding"] == ["FF Guiding Curves"]
    # per strip: tool + envelope mesh; per boundary one; guiding curves; the run's and the parent collection
    assert ff["run"]["new"] == dict(NOTHING, objects=3 * n, meshes=3 * n, collections=2)
    assert st["props"]["flank_ff_strips"] == n
    assert ff["active"] == "FF Tool 1"


def test_plan_is_the_core_plan_in_model_coordinates(ff):
    p, c = ff["plan"], ff["core"]
    assert p["is_mesh"] and p["method"] == "freeform-g1-cone" and p["vertices_equal"]
    # the world direction (0, 1, 0) of an object turned 90 deg about z is its local x
    assert np.allclose(p["direction"], [1.0, 0.0, 0.0], atol=1e-6)
    assert p["tool"]["r1"] == pytest.approx(0.03, rel=1e-6) and p["tool"]["length"] == pytest.approx(0.25, rel=1e-6)
    for key in ("max_error", "min_error", "max_kink_deg", "mean_kink_deg", "strips", "rulings"):
        assert p["summary"][key] == pytest.approx(c["summary"][key], rel=1e-9, abs=1e-15), key


def test_cylinder_along_the_rulings_is_exact_in_blender_too(ff):
    """Rajain et al. 2023 developable case: error <= 1e-6 of the patch size (1.5 model units, 3 scene units), kink <= 0.01 deg."""
    pr = ff["state"]["props"]
    size = 1.5 * S
    assert max(abs(pr["flank_ff_max_error"]), abs(pr["flank_ff_min_error"])) <= 1e-6 * size
    assert pr["flank_ff_max_kink_deg"] <= 0.01
    assert pr["flank_ff_colliding_rulings"] == 0 and pr["flank_ff_overhanging_samples"] == 0


def test_errors_are_in_scene_units(ff):
    pr, c = ff["state"]["props"], ff["core"]
    assert pr["flank_ff_length_scale"] == S
    assert pr["flank_ff_max_error"] == pytest.approx(S * c["summary"]["max_error"], rel=1e-9, abs=1e-15)
    assert pr["flank_ff_min_error"] == pytest.approx(S * c["summary"]["min_error"], rel=1e-9, abs=1e-15)
    for k, t in ff["state"]["tools"].items():
        k = int(k)
        assert t["errors"] == pytest.approx([S * c["strip_max"][k], S * c["strip_min"][k]], rel=1e-9, abs=1e-15)


def test_strip_attributes_equal_the_core_envelopes(ff):
    c = ff["core"]
    M = None
    for k, strip in ff["state"]["strips"].items():
        k = int(k)
        assert strip["domain"] == "POINT" and strip["colors"] == strip["n"]
        dev = np.asarray(strip["dev"], dtype=float)
        core_dev = np.asarray(c["env_dev"][k], dtype=float)
        core_pts = np.asarray(c["env_pts"][k], dtype=float)
        ok = np.isfinite(core_pts).all(axis=1)
        assert len(dev) == ok.sum()                    # every envelope point the core has, no NaN point
        # deviation: scene units (x S), float32 attribute
        fin = np.isfinite(core_dev[ok])
        assert np.array_equal(np.isfinite(dev), fin)
        assert np.allclose(dev[fin], S * core_dev[ok][fin], rtol=1e-6, atol=1e-12)
        # vertices in model coordinates; the object carries the blade's matrix
        co = np.asarray(strip["co"])
        assert np.allclose(co, core_pts[ok], atol=1e-6)
        M = np.asarray(strip["matrix"])
        assert np.allclose(M, np.asarray(ff["blade_matrix"]), atol=1e-6)
    assert M is not None


def test_boundary_curves_carry_the_kink_angles(ff):
    c = ff["core"]
    assert len(ff["state"]["boundaries"]) == len(c["kinks"])
    for k, b in ff["state"]["boundaries"].items():
        want = np.asarray(c["kinks"][int(k)])
        assert b["points"] == len(want) and b["edges"] == len(want) - 1
        assert np.allclose(b["kink"], want, rtol=1e-6, atol=1e-9)
        assert b["edge_domain"] == "EDGE" and b["edge_len"] == b["edges"]


def test_tools_stand_on_the_first_ruling(ff):
    c = ff["core"]
    M = np.asarray(ff["blade_matrix"])
    for k, t in ff["state"]["tools"].items():
        a, b = (np.asarray(v, dtype=float) for v in c["first_rulings"][int(k)])
        tip = M[:3, :3] @ a + M[:3, 3]
        ax = M[:3, :3] @ (b - a)
        assert np.allclose(t["origin"], tip, atol=1e-5)
        assert float(np.dot(t["axis"], ax / np.linalg.norm(ax))) > 1 - 1e-9
        assert t["scale"] == pytest.approx(S, rel=1e-6)


def test_rerun_replaces_the_run_without_orphans(ff):
    r = ff["rerun"]
    assert r["result"] == ["FINISHED"] and r["delta"] == NOTHING
    assert r["runs"] == ["Free-form (Parabolic Blade)"]
    assert ff["orphans"] == {"meshes": 0, "curves": 0}


def test_results_list_rows(ff):
    rows = ff["rows"]
    n = ff["core"]["strips"]
    assert sorted(rows) == [str(k) for k in range(n)]
    for k in range(n):
        row = rows[str(k)]
        assert row["max"] == pytest.approx(S * ff["core"]["strip_max"][k], rel=1e-9, abs=1e-15)
        assert not row["collision"]
        assert row["covered"] == ("last" if k == n - 1 else "kink {:.2g}°".format(max(ff["core"]["kinks"][k])))


def test_exports_and_animation_of_a_mesh_run(ff):
    ex = ff["exports"]
    assert all(e["result"] == ["FINISHED"] for e in ex.values()), ex
    assert ex["CL"]["goto"] == ff["plan"]["summary"]["rulings"]          # one GOTO per ruling
    assert sum(1 for f in ex["STL"]["files"] if f.endswith(".stl")) == ff["core"]["strips"]
    an = ff["animate"]
    assert an["result"] == ["FINISHED"], an["error"]
    assert an["new"] == dict(NOTHING, objects=1) and an["static_hidden"]
    for chk in an["checks"]:                # at its key frames the moving tool stands on the ruling
        assert chk["origin_err"] < 1e-5 and chk["axis_dot"] > 1 - 1e-9
    assert ff["animate_again"]["result"] == ["FINISHED"] and ff["animate_again"]["new"] == NOTHING
    rp = ff["report"]
    assert rp["result"] == ["FINISHED"], rp["error"]
    assert rp["size"] == [240, 160] and rp["colors"] > 8 and rp["new"] == NOTHING


def test_guiding_preview_equals_the_core_curves_and_follows_the_settings(ff):
    pv = ff["preview"]
    assert pv["result"] == ["FINISHED"] and pv["type"] == "CURVE" and pv["new"] == dict(NOTHING, objects=1, curves=1)
    assert pv["splines"] == pv["core_polylines"] == 5 and pv["max_point_diff"] < 1e-6 and pv["matrix_equal"]
    assert pv["spacing"] == pytest.approx(0.5, rel=1e-6)         # d = L for a cylinder, scene units
    assert ff["run_call"] == {"idname": "flank.plan_freeform", "r1": pytest.approx(0.06), "r2": pytest.approx(0.06),
                              "length": pytest.approx(0.5)}
    lv = ff["live"]
    assert lv["previews"] == 1 and lv["changed"] and not lv["message"][1]
    assert abs(lv["direction"][1]) > 0.999                   # the curves now run along the local y (the rulings)
    bad = ff["live_bad"]
    assert bad["message"][1] and "spacing" in bad["message"][0] and "limit" in bad["message"][0]
    assert ff["clear_preview"]["new"] == dict(NOTHING, objects=-1, curves=-1) and ff["orphans_after_clear"] == 0


def test_direction_picking(ff):
    p = ff["picks"]
    for key in ("empty", "cursor", "edge", "edge_edit"):
        assert p[key]["result"] == ["FINISHED"], (key, p[key]["error"])
        assert np.allclose(p[key]["direction"], p[key]["want"], atol=1e-5), key
    assert np.allclose(p["empty"]["point"], [0.3, 0.2, 0.1], atol=1e-6) and p["empty"]["use_point"]
    assert np.allclose(p["cursor"]["point"], [0.5, 0.5, 0.5], atol=1e-6)
    assert np.allclose(p["edge"]["point"], p["edge"]["want_point"], atol=1e-5)
    for key, words in (("edge_none", "one edge"), ("view", "3D Viewport"), ("empty_wrong", "not an Empty")):
        assert p[key]["result"] is None and words in p[key]["error"], (key, p[key])
        assert p[key]["new"] == NOTHING


def test_vector_attribute_field_and_selected_faces(ff):
    f = ff["field"]
    assert f["result"] == ["FINISHED"] and f["field"] is True and f["strips"] >= 3
    assert abs(f["max_error"]) < 1e-5
    assert ff["field_missing"]["result"] is None and "'nope'" in ff["field_missing"]["error"]
    s = ff["selected"]
    assert s["result"] == ["FINISHED"] and s["x_max"] <= 1e-9 and 0 < s["vertices"] < ff["surface"]["vertices"]
    assert "no selected faces" in ff["selected_none"]["error"] and ff["selected_none"]["new"] == NOTHING


@pytest.mark.parametrize("case,words", [
    ("r1_nan", "r1 = nan"), ("short_axis", "must exceed |r2 - r1|"), ("tool_too_large", "exceeds the limit"),
    ("zero_direction", "non-zero"), ("negative_weight", "w3 (G1) = -1.0"), ("engagement", "0.05 .. 1"),
    ("no_approximation", "weight w2 (approximation) = 0 must be > 0"),
    ("no_strip", "no strip"), ("empty_active", "select a mesh object"), ("non_uniform_scale", "not uniform")])
def test_bad_input_is_refused_with_a_message_and_nothing_is_made(ff, case, words):
    r = ff["bad"][case]
    assert r["result"] is None and words in r["error"] and "Traceback" not in r["error"], r
    assert r["new"] == NOTHING
    assert ff["no_object"]["result"] is None and ff["no_object"]["new"] == NOTHING


def test_test_surfaces(ff):
    assert all(v["result"] == ["FINISHED"] and v["new"] == dict(NOTHING, objects=1, meshes=1)
               for v in ff["test_surfaces"].values())
    assert ff["add_surface"]["result"] == ["FINISHED"]
    assert ff["bad_surface"]["result"] is None and "size = nan" in ff["bad_surface"]["error"]


def test_the_kept_plans_are_the_stored_ones(ff):
    """Operators read a run's plan from the one the extension keeps parsed: after all of them ran, each kept plan
    is still its run's stored text parsed again, number for number (none of them changed the shared plan)."""
    assert_plans_kept(ff["plans_kept"])


def test_a_scene_in_metres_plans_in_millimetres(ff):
    """The blade in a scene of metres: its plan holds millimetres (the mesh's numbers x 1000), as its unit says,
    and its error in scene units keeps the exact case's bound of the millimetre scene (the optimiser's
    tolerances are not exactly scale-free, so the figures agree only to that bound)."""
    m, first = ff["metre"], ff["state"]["props"]
    assert m["result"] == ["FINISHED"], m["error"]
    assert m["unit"] == "mm" and m["vertices_mm"]
    assert m["length_scale"] == pytest.approx(S / 1000.0, rel=1e-9)
    assert m["scene_max_error"] == pytest.approx(m["plan_max_error"] * S / 1000.0, rel=1e-12)
    assert abs(m["scene_max_error"]) <= 1e-6 * 3.0 and abs(first["flank_ff_max_error"]) <= 1e-6 * 3.0
