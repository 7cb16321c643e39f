# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.generate_rotor / flank.analyze_rotor through the installed extension (bundled scipy)."""
import importlib.util
import os

import pytest

from blender_harness import run_scenario

V0_RTOL = 1e-5  # the analysis refines the pitch from exact vertices


@pytest.fixture(scope="module")
def ops(extension_zip, tmp_path_factory):
    return run_scenario(extension_zip, "operators", tmp_path_factory.mktemp("operators"))


def test_generate_creates_active_mesh_with_helix_data(ops):
    gen = ops["generate"]
    assert gen["result"] == ["FINISHED"], gen["error"]
    assert gen["new_objects"] == 1 and gen["type"] == "MESH" and gen["in_scene"]
    assert gen["vertices"] > 1000 and gen["polygons"] > 1000
    props = gen["props"]
    assert props["flank_v0"] > 0
    assert props["flank_handedness"] in ("left", "right")
    assert props["flank_handedness"] == "left"  # built-in female default
    assert props["flank_axis"] == [0.0, 0.0, 1.0]
    assert props["flank_kind"] == "asymmetric" and props["flank_part"] == "female"


def test_analyze_recovers_helix_and_stores_results(ops):
    ana = ops["analyze"]
    assert ana["result"] == ["FINISHED"], ana["error"]
    assert ana["new_objects"] == 0
    gen, props = ops["generate"]["props"], ana["props"]
    assert props["flank_source"] == "analyzed"
    assert abs(props["flank_v0"] - gen["flank_v0"]) <= V0_RTOL * gen["flank_v0"], (props["flank_v0"], gen["flank_v0"])
    assert props["flank_handedness"] == gen["flank_handedness"]
    axis = props["flank_axis"]
    assert abs(abs(axis[2]) - 1.0) < 1e-6, axis
    assert props["flank_residual"] < props["flank_threshold"]
    assert props["flank_flank_count"] == gen["flank_flank_count"] == 12
    assert len(props["flank_flanks"]) == 2 * props["flank_flank_count"]


def test_analyze_refuses_edit_mode_and_keeps_results(ops):
    em = ops["edit_mode"]
    assert em["result"] is None and "Object Mode" in em["error"]
    assert em["v0_kept"] and {"gaussian_curvature", "curvature_class"} <= set(em["attributes"])


def test_analyze_works_in_world_coordinates(ops):
    sc, gen = ops["scaled"], ops["generate"]["props"]
    assert sc["result"] == ["FINISHED"], sc["error"]
    assert abs(sc["v0"] / (2.0 * gen["flank_v0"]) - 1) < V0_RTOL


def test_analyze_writes_point_attributes(ops):
    ana = ops["analyze"]
    attrs, n = ana["attributes"], ana["vertices"]
    k = attrs["gaussian_curvature"]
    assert (k["data_type"], k["domain"], k["length"]) == ("FLOAT", "POINT", n)
    assert k["finite"] == n
    c = attrs["curvature_class"]
    assert c["data_type"] in ("FLOAT_COLOR", "BYTE_COLOR") and c["domain"] == "POINT" and c["length"] == n
    assert c["distinct_colors"] >= 2  # a screw rotor has elliptic and hyperbolic regions


def test_bundled_scipy_wheel_installed(ops):
    assert ops["bundled_scipy_dirs"], "scipy wheel not extracted into the extension site-packages"
    assert ops["scipy_version"] == "1.17.1"
    if importlib.util.find_spec("scipy") is None:
        # compat venvs have no scipy of their own: the analysis must have used the bundled wheel
        ext_dir = ops["install"]["extensions_dir"]
        assert os.path.commonpath([ext_dir, ops["scipy_file"]]) == ext_dir, ops["scipy_file"]


@pytest.mark.parametrize("prim", ["uv_sphere", "cube", "cylinder"])
def test_analyze_refuses_non_helical_mesh(ops, prim):
    err = ops["errors"][prim]
    assert err["result"] is None, "operator did not fail: {}".format(err)
    msg = err["error"].lower()
    assert "residual" in msg and "threshold" in msg, err["error"]
    if prim == "cylinder":   # a 64-sided cylinder: its vertices fit a screw, its faces fit every pitch
        assert "cylinder or prism" in msg, err["error"]
    assert "traceback" not in msg
    assert err["new_objects"] == 0 and err["new_meshes"] == 0
    assert not err["props"], err["props"]
    assert "gaussian_curvature" not in err["attributes"] and "curvature_class" not in err["attributes"]


def test_all_builtin_rotors_generate(ops):
    for name, info in ops["builtins"].items():
        assert info["result"] == ["FINISHED"], (name, info["error"])
        assert info["v0"] > 0 and info["handedness"] in ("left", "right"), (name, info)
