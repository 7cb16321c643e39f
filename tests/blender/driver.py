# SPDX-License-Identifier: GPL-3.0-or-later
"""Run one Blender scenario against the *installed* extension zip and write JSON results.

Executed by tests/blender/conftest.py in a fresh subprocess (the venv's python,
bpy imported as a module, background mode).  BLENDER_USER_RESOURCES & co. point
to a temporary directory (set by the caller before this process starts, i.e.
before ``import bpy``) so the developer's Blender configuration is untouched.
Also used by tools/demo.py (``install_extension``).

    python driver.py --zip flank_toolpath-...zip --scenario lifecycle --out result.json
"""
import argparse
import json
import os
import sys
import time
import traceback

EXT_ID = "flank_toolpath"
REPO = "user_default"
MODULE = "bl_ext.{}.{}".format(REPO, EXT_ID)
CLASS_NAMES = ("FLANK_OT_generate_rotor", "FLANK_OT_analyze_rotor", "FLANK_PT_workpiece")


def install_extension(bpy, zip_path):
    """Install + enable the zip with Blender's own installer; return info (raises on failure)."""
    zip_path = os.path.abspath(zip_path)
    t0 = time.perf_counter()
    result = bpy.ops.extensions.package_install_files(
        filepath=zip_path, repo=REPO, enable_on_install=True, overwrite=True)
    dt = time.perf_counter() - t0
    # the installer reports some failures only as messages: check the real state
    if MODULE not in bpy.context.preferences.addons:
        raise RuntimeError("extension not enabled after install (operator returned {})".format(sorted(result)))
    ext_dir = bpy.utils.user_resource('EXTENSIONS')
    return dict(result=sorted(result), seconds=dt, extensions_dir=ext_dir,
                installed_dir=os.path.join(ext_dir, REPO, EXT_ID))


def _addon_state(bpy):
    return dict(
        enabled=MODULE in bpy.context.preferences.addons,
        classes={name: hasattr(bpy.types, name) for name in CLASS_NAMES},
        scene_prop=hasattr(bpy.types.Scene, "flank_settings"),
        flank_types=sorted(name for name in dir(bpy.types) if name.startswith("FLANK_")),
        scene_rna_props=sorted(p.identifier for p in bpy.types.Scene.bl_rna.properties
                               if p.identifier.startswith("flank")),
        ops=sorted(name for name in dir(bpy.ops.flank) if not name.startswith("_")),
    )


def _site_packages_with(ext_dir, name):
    local = os.path.join(ext_dir, ".local")
    hits = []
    for dirpath, dirnames, _ in os.walk(local):
        if name in dirnames and dirpath.endswith("site-packages"):
            hits.append(os.path.join(dirpath, name))
        if dirpath.count(os.sep) - local.count(os.sep) > 4:
            dirnames[:] = []
    return hits


# --------------------------------------------------------------------------- scenarios

def scenario_lifecycle(bpy, res, args):
    res["after_install"] = _addon_state(bpy)
    panel = getattr(bpy.types, "FLANK_PT_workpiece", None)
    if panel is not None:
        res["panel"] = dict(bl_category=panel.bl_category, bl_space_type=panel.bl_space_type,
                            bl_region_type=panel.bl_region_type, bl_label=panel.bl_label)
    cycles = []
    for i in range(5):
        bpy.ops.preferences.addon_disable(module=MODULE)
        disabled = _addon_state(bpy)
        bpy.ops.preferences.addon_enable(module=MODULE)
        enabled = _addon_state(bpy)
        # the operator must still work after every re-registration
        n_before = len(bpy.data.objects)
        ret = bpy.ops.flank.generate_rotor(kind="nilson", part="male", resolution=48)
        works = ret == {"FINISHED"} and len(bpy.data.objects) == n_before + 1
        cycles.append(dict(disabled=disabled, enabled=enabled, generate_works=works))
    res["cycles"] = cycles
    bpy.ops.preferences.addon_disable(module=MODULE)
    res["final_disabled"] = _addon_state(bpy)


def _obj_props(obj):
    out = {}
    for key in obj.keys():
        if not key.startswith("flank_"):
            continue
        val = obj[key]
        if hasattr(val, "to_list"):
            val = val.to_list()
        elif hasattr(val, "to_dict"):
            val = val.to_dict()
        out[key] = val
    return out


def _attributes(np, mesh):
    out = {}
    for attr in mesh.attributes:
        if attr.name.startswith("."):
            continue
        info = dict(data_type=attr.data_type, domain=attr.domain, length=len(attr.data))
        if attr.name == "gaussian_curvature":
            vals = np.empty(len(attr.data), dtype=np.float32)
            attr.data.foreach_get("value", vals)
            finite = np.isfinite(vals)
            info.update(finite=int(finite.sum()), min=float(vals[finite].min()) if finite.any() else None,
                        max=float(vals[finite].max()) if finite.any() else None)
        elif attr.name == "curvature_class":
            cols = np.empty(len(attr.data) * 4, dtype=np.float32)
            attr.data.foreach_get("color", cols)
            cols = cols.reshape(-1, 4)
            uniq = np.unique(np.round(cols, 3), axis=0)
            info.update(distinct_colors=len(uniq))
        out[attr.name] = info
    return out


def _run_op(op, **kw):
    """Call an operator; return (result set or None, error message or None)."""
    try:
        return sorted(op(**kw)), None
    except RuntimeError as ex:  # ERROR reports are raised as RuntimeError when called from Python
        return None, str(ex)


def scenario_operators(bpy, res, args):
    import numpy as np

    scene = bpy.context.scene
    n0 = len(bpy.data.objects)
    t0 = time.perf_counter()
    ret, err = _run_op(bpy.ops.flank.generate_rotor, kind="asymmetric", part="female", resolution=args.resolution)
    res["generate"] = dict(result=ret, error=err, seconds=time.perf_counter() - t0,
                           new_objects=len(bpy.data.objects) - n0)
    obj = bpy.context.active_object
    if obj is None or ret is None:
        return
    res["generate"].update(name=obj.name, type=obj.type, in_scene=obj.name in scene.objects,
                           vertices=len(obj.data.vertices), polygons=len(obj.data.polygons),
                           props=_obj_props(obj))

    n1 = len(bpy.data.objects)
    t0 = time.perf_counter()
    ret, err = _run_op(bpy.ops.flank.analyze_rotor)
    res["analyze"] = dict(result=ret, error=err, seconds=time.perf_counter() - t0,
                          new_objects=len(bpy.data.objects) - n1, props=_obj_props(obj),
                          attributes=_attributes(np, obj.data), vertices=len(obj.data.vertices))
    # Edit Mode: refused by poll with a message; the earlier results stay on the object
    v0_before = obj.get("flank_v0")
    bpy.ops.object.mode_set(mode='EDIT')
    ret, err = _run_op(bpy.ops.flank.analyze_rotor)
    bpy.ops.object.mode_set(mode='OBJECT')
    res["edit_mode"] = dict(result=ret, error=err, v0_kept=obj.get("flank_v0") == v0_before,
                            attributes=sorted(_attributes(np, obj.data)))
    # a scaled object is analyzed in world coordinates: v0 scales with it
    obj.scale = (2.0, 2.0, 2.0)
    bpy.context.view_layer.update()
    ret, err = _run_op(bpy.ops.flank.analyze_rotor)
    res["scaled"] = dict(result=ret, error=err, v0=obj.get("flank_v0"))
    obj.scale = (1.0, 1.0, 1.0)
    bpy.context.view_layer.update()
    if args.ext_dir:
        res["bundled_scipy_dirs"] = _site_packages_with(args.ext_dir, "scipy")
    mod = sys.modules.get("scipy")
    res["scipy_file"] = getattr(mod, "__file__", None)
    res["scipy_version"] = getattr(mod, "__version__", None)
    res["numpy_version"] = np.__version__

    # error path: non-helical meshes must be refused without creating anything
    errors = {}
    for prim in ("uv_sphere", "cube"):
        getattr(bpy.ops.mesh, "primitive_{}_add".format(prim))(location=(5.0, 0.0, 0.0))
        target = bpy.context.active_object
        n_before = len(bpy.data.objects)
        m_before = len(bpy.data.meshes)
        ret, err = _run_op(bpy.ops.flank.analyze_rotor)
        errors[prim] = dict(result=ret, error=err, new_objects=len(bpy.data.objects) - n_before,
                            new_meshes=len(bpy.data.meshes) - m_before, props=_obj_props(target),
                            attributes=sorted(_attributes(np, target.data)))
    res["errors"] = errors

    # all built-in rotors generate (coarse)
    kinds = {}
    for kind in ("nilson", "srm_a", "asymmetric"):
        for part in ("male", "female"):
            ret, err = _run_op(bpy.ops.flank.generate_rotor, kind=kind, part=part, resolution=96)
            o = bpy.context.active_object
            kinds["{}-{}".format(kind, part)] = dict(
                result=ret, error=err, v0=o.get("flank_v0") if o else None,
                handedness=o.get("flank_handedness") if o else None,
                lobes=o.get("flank_lobes") if o else None)
    res["builtins"] = kinds


SCENARIOS = {"lifecycle": scenario_lifecycle, "operators": scenario_operators}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--zip", required=True)
    ap.add_argument("--scenario", required=True, choices=sorted(SCENARIOS))
    ap.add_argument("--out", required=True)
    ap.add_argument("--resolution", type=int, default=360)
    args = ap.parse_args()
    args.ext_dir = None

    res = dict(scenario=args.scenario, ok=False, python=sys.version.split()[0],
               env={k: os.environ.get(k) for k in ("BLENDER_USER_RESOURCES", "BLENDER_USER_CONFIG",
                                                  "BLENDER_USER_SCRIPTS", "BLENDER_USER_EXTENSIONS")})
    t0 = time.perf_counter()
    try:
        import bpy

        res["blender_version"] = list(bpy.app.version)
        res["background"] = bool(bpy.app.background)
        res["install"] = install_extension(bpy, args.zip)
        args.ext_dir = res["install"]["extensions_dir"]
        SCENARIOS[args.scenario](bpy, res, args)
        res["ok"] = True
    except Exception:
        res["exception"] = traceback.format_exc()
    res["seconds"] = time.perf_counter() - t0
    with open(args.out, "w", encoding="utf-8") as fh:
        json.dump(res, fh, indent=1, default=str)
    return 0


if __name__ == "__main__":
    sys.exit(main())
