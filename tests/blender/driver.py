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
CLASS_NAMES = ("FLANK_OT_generate_rotor", "FLANK_OT_analyze_rotor", "FLANK_OT_verify_plan",
               "FLANK_OT_paraboloid_groove", "FLANK_OT_formed_cutter", "FLANK_PT_workpiece", "FLANK_PT_verify",
               "FLANK_PT_paraboloid", "FLANK_PT_formed_cutter", "FLANK_OT_plan_double_flank", "FLANK_PT_double_flank",
               "FLANK_OT_plan_single_flank", "FLANK_PT_single_flank", "FLANK_OT_cutter_region",
               "FLANK_OT_plan_freeform", "FLANK_PT_freeform", "FLANK_OT_post_program", "FLANK_PT_machine")
PANEL_NAMES = ("FLANK_PT_workpiece", "FLANK_PT_verify", "FLANK_PT_paraboloid", "FLANK_PT_formed_cutter",
               "FLANK_PT_double_flank", "FLANK_PT_single_flank", "FLANK_PT_results", "FLANK_PT_freeform",
               "FLANK_PT_machine")


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


def enable_installed(bpy):
    """Enable the extension that an earlier run of :func:`install_extension` left in this process's user
    repository (a copy of that run's user directory); return info as :func:`install_extension` does."""
    t0 = time.perf_counter()
    result = bpy.ops.preferences.addon_enable(module=MODULE)
    dt = time.perf_counter() - t0
    if MODULE not in bpy.context.preferences.addons:
        raise RuntimeError("installed extension not enabled (operator returned {})".format(sorted(result)))
    ext_dir = bpy.utils.user_resource('EXTENSIONS')
    return dict(result=sorted(result), seconds=dt, extensions_dir=ext_dir, preinstalled=True,
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
    res["panels"] = {}
    for name in PANEL_NAMES:
        panel = getattr(bpy.types, name, None)
        if panel is not None:
            res["panels"][name] = dict(bl_category=panel.bl_category, bl_space_type=panel.bl_space_type,
                                       bl_region_type=panel.bl_region_type, bl_label=panel.bl_label,
                                       bl_order=getattr(panel, "bl_order", 0))
    settings = bpy.context.scene.flank_settings
    res["settings_props"] = sorted(p.identifier for p in settings.bl_rna.properties if p.identifier != "rna_type")
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
    for prim, size in (("uv_sphere", {}), ("cube", {}), ("cylinder", dict(vertices=64, radius=20.0, depth=100.0))):
        getattr(bpy.ops.mesh, "primitive_{}_add".format(prim))(location=(5.0, 0.0, 0.0), **size)
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


def _core(name):
    """A module of the planner embedded in the *installed* extension (same code the operators run)."""
    import importlib

    return importlib.import_module("{}.flank_addon.{}".format(MODULE, name))


def plans_kept(bpy):
    """The runs' plans the extension keeps parsed (``operators/runs.py``), checked against their stored text after
    whatever the scenario ran on them: {run: dict(current (the kept text is the stored one), equal (the kept plan
    is the text parsed and checked again, number for number))}.  A caller that changed a shared plan shows here."""
    import importlib

    runs = importlib.import_module("{}.operators.runs".format(MODULE))
    validate_plan = _core("io.plan").validate_plan
    out = {}
    for name, (key, plan) in list(runs._PLANS.items()):
        coll = bpy.data.collections.get(name)
        text = coll.get(runs.PLAN_JSON_PROP) if coll is not None else None
        if text is None:
            out[name] = dict(current=False, equal=None, removed=True)
            continue
        fresh = validate_plan(json.loads(text))
        out[name] = dict(current=key == runs._text_key(text), equal=json.dumps(fresh) == json.dumps(plan))
    return out


def _float_attr(np, mesh, name):
    attr = mesh.attributes.get(name)
    if attr is None:
        return None
    vals = np.empty(len(attr.data), dtype=np.float32)
    attr.data.foreach_get("value", vals)
    return vals


def _color_attr(np, mesh, name):
    attr = mesh.color_attributes.get(name)
    if attr is None:
        return None
    cols = np.empty(len(attr.data) * 4, dtype=np.float32)
    attr.data.foreach_get("color", cols)
    return cols.reshape(-1, 4)


def _ball_strip(np, point, normal, radius, depth, flank, shank=None):
    """A ball tool touching the profile point: centre at point + (radius - depth) * normal (z = 0).
    depth > 0 cuts into the rotor (overcut), depth < 0 stays away (stock)."""
    c = [float(v) for v in np.r_[np.asarray(point) + (radius - depth) * np.asarray(normal), 0.0]]
    strip = {"axis_start": c, "axis_end": c, "radii": [radius, radius], "flank": int(flank),
             "shank_start": c, "shank_end": c, "shank_radius": 0.0,
             "reported_max_error": 0.0, "reported_min_error": 0.0, "collision": False}
    if shank is not None:
        strip.update(shank_start=shank[0], shank_end=shank[1], shank_radius=shank[2])
    return strip


def _verify_state(np, obj):
    mesh = obj.data
    dev = _float_attr(np, mesh, "machined_deviation")
    cols = _color_attr(np, mesh, "machined_deviation_color")
    active = mesh.color_attributes.active_color
    return dict(attributes=sorted(a.name for a in mesh.attributes if not a.name.startswith(".")),
                active_color=active.name if active is not None else None,
                props={k: v for k, v in _obj_props(obj).items() if k.startswith("flank_verify")},
                dev=dev, cols=cols)


def scenario_verify(bpy, res, args):
    """flank.verify_plan on a generated rotor with a plan built here from the installed planner."""
    import numpy as np

    plan_mod, verify_mod, rotors = _core("io.plan"), _core("simulation.verify"), _core("geometry.rotors")
    profile_mod = _core("geometry.profile")
    tmp = os.path.abspath(os.getcwd())
    n = 1440           # the plan's profile = the mesh's profile samples (exact comparison per vertex)
    depth, stock, radius = 0.01, 0.02, 0.03

    ret, err = _run_op(bpy.ops.flank.generate_rotor, kind="asymmetric", part="female", resolution=n, axial=48)
    obj = bpy.context.active_object
    res["generate"] = dict(result=ret, error=err, vertices=len(obj.data.vertices))
    rotor = rotors.builtin_rotor("asymmetric", "female")
    section = plan_mod.rotor_section(rotor.profile, rotor.v0, rotor.handedness, rotor.flanks, n_profile=n)
    prof = np.asarray(section["profile"], dtype=np.float64)
    spline = profile_mod.SplineProfile(prof)
    normals = spline.outward_normal(spline.knots[:-1])
    # gouge on flank 0 where its normal is most nearly radial (the facing-point deviation is then ~ -depth)
    a0, b0 = section["flanks"][0]
    cand = np.arange(a0 + 5, b0 - 4) % n
    radial = np.abs(np.einsum("ij,ij->i", normals[cand], prof[cand])) / np.linalg.norm(prof[cand], axis=1)
    i_gouge = int(cand[np.argmax(radial)])
    a3, b3 = section["flanks"][3]
    i_stock = int(((a3 + b3) // 2) % n)
    strips = [_ball_strip(np, prof[i_gouge], normals[i_gouge], radius, depth, 0),
              _ball_strip(np, prof[i_stock], normals[i_stock], radius, -stock, 3)]
    plan = plan_mod.new_plan("test-balls", section, {"kind": "revolved"}, length_unit="R",
                             target_flanks=[0, 3], strips=strips)
    plan_path = os.path.join(tmp, "plan.json")
    plan_mod.write_plan(plan_path, plan)
    direct = verify_mod.verify_plan(plan, tolerance=None, all_points=True)
    dev_all = np.array([np.nan if d is None else d for d in direct["deviation_all"]])
    res["plan"] = dict(path=plan_path, i_gouge=i_gouge, i_stock=i_stock, depth=depth, stock=stock, n=n,
                       direct=dict(max_overcut=direct["max_overcut"], max_undercut=direct["max_undercut"],
                                   gouges=len(direct["gouge_points"]), tolerance=direct["tolerance"],
                                   dev_gouge=dev_all[i_gouge], dev_stock=dev_all[i_stock],
                                   reached_profile_points=int(np.isfinite(dev_all).sum())))

    def compare(state):
        """Per vertex: side vertex v lies on profile point v % n -> expected dev_all[v % n]."""
        dev, cols = state.pop("dev"), state.pop("cols")
        if dev is None:
            return state
        nv = len(dev)
        side = (nv // n) * n
        expect = dev_all[np.arange(side) % n]
        fin = np.isfinite(expect)
        tol = direct["tolerance"]
        reached = dev < 1e8
        grey = np.all(np.abs(cols[:, :3] - 0.6) < 1e-6, axis=1)
        red = (cols[:, 0] > 2 * cols[:, 1]) & (cols[:, 0] > 2 * cols[:, 2])
        blue = (cols[:, 2] > 2 * cols[:, 0]) & (cols[:, 2] > 2 * cols[:, 1])
        k_min = int(np.argmin(dev))
        state.update(
            vertices=nv, side_vertices=side,
            max_abs_diff=float(np.max(np.abs(dev[:side][fin] - expect[fin]))) if fin.any() else None,
            untouched_match=bool(np.all(dev[:side][~fin] == np.float32(1e9))),
            extra_vertices_untouched=bool(np.all(dev[side:] == np.float32(1e9))),
            reached=int(reached.sum()), expected_reached=int(fin.sum()),
            min=float(dev.min()), min_vertex_red=bool(red[k_min]),
            gouge_vertices=int((reached & (dev < -tol)).sum()), red_vertices=int(red.sum()),
            stock_vertices=int((reached & (dev > tol)).sum()), blue_vertices=int(blue.sum()),
            grey_vertices=int(grey.sum()), grey_is_untouched=bool(np.array_equal(grey, ~reached)),
            max_stock=float(dev[reached].max()),
        )
        return state

    t0 = time.perf_counter()
    ret, err = _run_op(bpy.ops.flank.verify_plan, filepath=plan_path)
    res["verify"] = compare(dict(result=ret, error=err, seconds=time.perf_counter() - t0,
                                 **_verify_state(np, obj)))

    # a moved + rotated object with the matching rotor.to_world gives the same values
    from mathutils import Matrix

    # exact float64 rotation for the plan (validation wants orthogonality to 1e-9); Blender keeps float32
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    M = np.eye(4)
    M[:3, :3] = np.eye(3) + np.sin(0.9) * K + (1 - np.cos(0.9)) * K @ K
    M[:3, 3] = (0.4, -0.3, 0.7)
    obj.matrix_world = Matrix(M.tolist())
    bpy.context.view_layer.update()
    moved = dict(plan, rotor=dict(section, to_world=M.tolist()))
    moved_path = os.path.join(tmp, "plan_moved.json")
    plan_mod.write_plan(moved_path, moved)
    ret, err = _run_op(bpy.ops.flank.verify_plan, filepath=moved_path)
    res["moved"] = compare(dict(result=ret, error=err, **_verify_state(np, obj)))
    # ... and the identity plan on the moved object is refused; the previous results stay
    before = _verify_state(np, obj)
    ret, err = _run_op(bpy.ops.flank.verify_plan, filepath=plan_path)
    after = _verify_state(np, obj)
    res["mismatch"] = dict(result=ret, error=err, props_kept=before["props"] == after["props"],
                           values_kept=bool(np.array_equal(before["dev"], after["dev"])))
    obj.matrix_world = Matrix.Identity(4)
    bpy.context.view_layer.update()

    # tolerance given explicitly, tools as objects (one strip with a shank)
    c = prof[i_stock] + (radius + stock) * normals[i_stock]
    shank = ([float(v) for v in np.r_[c + 0.05 * normals[i_stock], 0.0]],
             [float(v) for v in np.r_[c + 0.3 * normals[i_stock], 0.0]], 0.01)
    strips_sh = [strips[0], _ball_strip(np, prof[i_stock], normals[i_stock], radius, -stock, 3, shank=shank)]
    tools_path = os.path.join(tmp, "plan_tools.json")
    plan_mod.write_plan(tools_path, dict(plan, strips=strips_sh))
    n_obj = len(bpy.data.objects)
    ret, err = _run_op(bpy.ops.flank.verify_plan, filepath=tools_path, tolerance=0.005, show_tools=True)
    coll = bpy.data.collections.get("Verify Tools")
    tools = {}
    if coll is not None:
        for ob in coll.objects:
            co = np.empty(len(ob.data.vertices) * 3)
            ob.data.vertices.foreach_get("co", co)
            co = co.reshape(-1, 3)
            tools[ob.name] = dict(strip=ob.get("flank_strip"), centre=co.mean(axis=0).tolist(),
                                  extent=(co.max(axis=0) - co.min(axis=0)).tolist())
    st = _verify_state(np, obj)
    st.pop("dev"), st.pop("cols")
    res["tools"] = dict(result=ret, error=err, new_objects=len(bpy.data.objects) - n_obj, tools=tools,
                        tolerance=st["props"].get("flank_verify_tolerance"), ball_centre=strips[0]["axis_start"],
                        active_object=bpy.context.active_object.name, rotor=obj.name)
    bpy.context.view_layer.objects.active = obj

    # Edit Mode: refused by poll with a message
    bpy.ops.object.mode_set(mode='EDIT')
    ret, err = _run_op(bpy.ops.flank.verify_plan, filepath=plan_path)
    bpy.ops.object.mode_set(mode='OBJECT')
    res["edit_mode"] = dict(result=ret, error=err)

    # bad plan files on a fresh rotor: nothing may change on the object
    bad = {}
    broken = json.loads(open(plan_path).read())
    broken["rotor"]["v0"] = -1.0
    cases = {
        "negative_v0": json.dumps(broken),
        "not_json": "{ this is not json",
        "wrong_schema": json.dumps(dict(json.loads(open(plan_path).read()), schema="flank-plan/0")),
    }
    ret, err = _run_op(bpy.ops.flank.generate_rotor, kind="asymmetric", part="female", resolution=720, axial=8)
    fresh = bpy.context.active_object
    for name, text in cases.items():
        path = os.path.join(tmp, name + ".json")
        with open(path, "w") as fh:
            fh.write(text)
        bad[name] = path
    bad["missing"] = os.path.join(tmp, "does_not_exist.json")
    res["bad"] = {}
    for name, path in bad.items():
        n_obj, n_me = len(bpy.data.objects), len(bpy.data.meshes)
        ret, err = _run_op(bpy.ops.flank.verify_plan, filepath=path)
        st = _verify_state(np, fresh)
        res["bad"][name] = dict(result=ret, error=err, attributes=st["attributes"], props=st["props"],
                                new_objects=len(bpy.data.objects) - n_obj, new_meshes=len(bpy.data.meshes) - n_me)
    res["panels"] = _draw_panels(bpy, obj)


class _Layout:
    """Records what a panel's draw() asks for (no UI in background mode); checks property names."""

    def __init__(self, log):
        self.log = log

    def box(self):
        return _Layout(self.log)

    def column(self, **kw):
        return _Layout(self.log)

    row = column

    def label(self, text="", icon='NONE'):
        self.log.append(["label", text])

    def prop(self, data, name, **kw):
        if name not in data.bl_rna.properties:
            raise AttributeError("panel draws unknown property {!r}".format(name))
        self.log.append(["prop", name])

    def operator(self, idname, **kw):
        import types

        self.log.append(["operator", idname])
        return types.SimpleNamespace()

    def menu(self, idname, **kw):
        import bpy

        if getattr(bpy.types, idname, None) is None:
            raise AttributeError("panel draws unknown menu {!r}".format(idname))
        self.log.append(["menu", idname])

    def template_list(self, listtype, list_id, data, propname, active_data, active_propname, **kw):
        import bpy

        if getattr(bpy.types, listtype, None) is None:
            raise AttributeError("panel draws unknown UIList {!r}".format(listtype))
        if active_propname not in active_data.bl_rna.properties:
            raise AttributeError("panel's list index {!r} is unknown".format(active_propname))
        self.log.append(["template_list", listtype, getattr(data, "name", ""), propname,
                         len(getattr(data, propname))])


def _draw_panels(bpy, active):
    """Call every panel's draw() with a recording layout and the real scene: [calls] or an error string."""
    import types

    out = {}
    ctx = types.SimpleNamespace(scene=bpy.context.scene, active_object=active)
    for name in PANEL_NAMES:
        log = []
        try:
            getattr(bpy.types, name).draw(types.SimpleNamespace(layout=_Layout(log)), ctx)
            out[name] = log
        except Exception as ex:
            out[name] = "{}: {}".format(type(ex).__name__, ex)
    return out


def _fcurve_keys(action):
    counts = {}
    layers = getattr(action, "layers", None)
    if layers:
        fcurves = [fc for layer in layers for strip in layer.strips
                   for bag in getattr(strip, "channelbags", ()) for fc in bag.fcurves]
    else:
        fcurves = list(action.fcurves)
    for fc in fcurves:
        counts["{}[{}]".format(fc.data_path, fc.array_index)] = dict(
            keys=len(fc.keyframe_points),
            interpolation=sorted({kp.interpolation for kp in fc.keyframe_points}))
    return counts


def scenario_paraboloid(bpy, res, args):
    """flank.paraboloid_groove: the Doğrusadık paper case, its section and the tool motion."""
    import numpy as np
    from scipy.spatial import cKDTree

    par, screw = _core("methods.paraboloid_groove.groove"), _core("geometry.screw")
    scene = bpy.context.scene
    R, a, b, p = 20.0, -0.05, 7.2, 20.0

    def snapshot():
        return len(bpy.data.objects), len(bpy.data.meshes), len(bpy.data.collections)

    s0 = snapshot()
    t0 = time.perf_counter()
    ret, err = _run_op(bpy.ops.flank.paraboloid_groove, radius=R, a=a, b=b, pitch=p, turns=1.0, resolution=401)
    s1 = snapshot()
    out = dict(result=ret, error=err, seconds=time.perf_counter() - t0,
               new=[s1[i] - s0[i] for i in range(3)])
    coll = bpy.data.collections.get("Paraboloid Groove")
    out["objects"] = sorted(o.name for o in coll.objects) if coll else []
    results = bpy.data.collections.get("Flank Results")     # the run's collection lives under "Flank Results"
    out["in_scene"] = bool(coll is not None and results is not None and coll.name in results.children
                           and results.name in scene.collection.children)
    groove = bpy.data.objects.get("Groove Surface")
    out["active"] = bpy.context.active_object.name if bpy.context.active_object else None
    out["props"] = _obj_props(groove) if groove else {}
    sec = par.groove_section(R, a, b, p, n=401)
    out["expected_max_overcut"] = float(sec.overcut.max())
    out["expected_intercepts"] = [float(sec.x[0]), float(sec.x[-1])]
    swept = bpy.data.objects.get("Swept Section")
    tool_sec = bpy.data.objects.get("Tool Section")
    if swept is not None:
        oc = _float_attr(np, swept.data, "overcut")
        co = np.empty(len(swept.data.vertices) * 3)
        swept.data.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3)
        out["swept"] = dict(vertices=len(co), edges=len(swept.data.edges), faces=len(swept.data.polygons),
                            overcut_max=float(oc.max()), overcut_min=float(oc.min()),
                            x_range=[float(co[:, 0].min()), float(co[:, 0].max())],
                            y_abs_max=float(np.abs(co[:, 1]).max()), z_max=float(co[:, 2].max()))
        # the swept section lies on the groove surface: screw both into z = 0 and compare
        gm = groove.data
        g = np.empty(len(gm.vertices) * 3)
        gm.vertices.foreach_get("co", g)
        g = g.reshape(-1, 3)
        v0 = p / (2 * np.pi)
        ring = screw.screw_to_plane(g, v0, "right")
        d, _ = cKDTree(ring).query(screw.screw_to_plane(co, v0, "right"))
        n_u = int(np.count_nonzero(g[:, 2] == g[0, 2]))  # first ring of the sheet: z = z0
        spacing = np.linalg.norm(np.diff(ring[:n_u], axis=0), axis=1).max()
        out["swept_on_groove"] = dict(max_distance=float(d.max()), spacing=float(spacing))
        # the static tool (phi = pi) lies inside the groove and touches it
        tool = bpy.data.objects.get("Paraboloid Tool")
        tv = np.empty(len(tool.data.vertices) * 3)
        tool.data.vertices.foreach_get("co", tv)
        tv = tv.reshape(-1, 3) + np.array(tool.location)
        out["tool"] = dict(location=list(tool.location), z_extent=float(tv[:, 2].max() - tv[:, 2].min()),
                           r_extent=float(np.linalg.norm(tv[:, :2] - np.array(tool.location)[:2], axis=1).max()))
    if tool_sec is not None:
        co = np.empty(len(tool_sec.data.vertices) * 3)
        tool_sec.data.vertices.foreach_get("co", co)
        out["tool_section_z_max"] = float(co[2::3].max())
    band = bpy.data.objects.get("Overcut Band")
    if band is not None:
        out["band"] = dict(faces=len(band.data.polygons),
                           active_color=band.data.color_attributes.active_color.name
                           if band.data.color_attributes.active_color else None,
                           overcut_max=float(_float_attr(np, band.data, "overcut").max()))
    moving = bpy.data.objects.get("Paraboloid Tool (moving)")
    if moving is not None:
        ad = moving.animation_data
        out["anim"] = dict(has_action=bool(ad and ad.action), shares_mesh=moving.data == bpy.data.objects[
            "Paraboloid Tool"].data, fcurves=_fcurve_keys(ad.action) if ad and ad.action else {},
            frame_start=scene.frame_start, frame_end=scene.frame_end)
        samples = []
        for f in (scene.frame_start, (scene.frame_start + scene.frame_end) // 2, scene.frame_end - 7):
            scene.frame_set(f)
            loc = np.array(moving.matrix_world.translation)
            rot = np.array(moving.matrix_world.to_3x3())
            samples.append(dict(frame=f, location=loc.tolist(), radius=float(np.linalg.norm(loc[:2])),
                                rotation_identity=bool(np.allclose(rot, np.eye(3)))))
        out["anim"]["samples"] = samples
    res["paper"] = out

    # the external part of the section only
    ret, err = _run_op(bpy.ops.flank.paraboloid_groove, radius=R, a=a, b=b, pitch=p, part="external",
                       resolution=201)
    g2 = bpy.context.active_object
    ext = par.groove_section(R, a, b, p, n=201, part="external")
    res["panels"] = _draw_panels(bpy, g2)
    res["external"] = dict(result=ret, error=err, props=_obj_props(g2),
                           expected_max_overcut=float(ext.overcut.max()),
                           collection=[c.name for c in g2.users_collection])

    # bad parameters: the core's message, nothing created
    res["bad"] = {}
    for name, kw in (("a_positive", dict(a=0.05)), ("a_zero", dict(a=0.0)), ("R_too_small", dict(radius=10.0)),
                     ("b_negative", dict(b=-1.0)), ("pitch_zero", dict(pitch=0.0))):
        s0 = snapshot()
        ret, err = _run_op(bpy.ops.flank.paraboloid_groove, **kw)
        s1 = snapshot()
        res["bad"][name] = dict(result=ret, error=err, new=[s1[i] - s0[i] for i in range(3)])


def _mesh_co(np, obj):
    co = np.empty(len(obj.data.vertices) * 3)
    obj.data.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def _world(np, obj, co):
    mw = np.array(obj.matrix_world, dtype=np.float64)
    return co @ mw[:3, :3].T + mw[:3, 3]


def _screw4(np, t, v0, hand):
    """Independent 4x4 of S_t (rotation hand * t about z, advance v0 t)."""
    c, s = np.cos(hand * t), np.sin(hand * t)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, v0 * t], [0, 0, 0, 1.0]])


def _cutter_run(bpy, np, fc, screw, **kw):
    """Run flank.formed_cutter; collect objects, props, attributes and independent checks (JSON-able)."""
    def snapshot():
        return (len(bpy.data.objects), len(bpy.data.meshes), len(bpy.data.collections), len(bpy.data.actions))

    s0 = snapshot()
    t0 = time.perf_counter()
    ret, err = _run_op(bpy.ops.flank.formed_cutter, **kw)
    s1 = snapshot()
    out = dict(result=ret, error=err, seconds=time.perf_counter() - t0, new=[s1[i] - s0[i] for i in range(4)])
    if ret is None:
        return out, None
    cutter = bpy.context.active_object
    coll = cutter.users_collection[0]
    results = bpy.data.collections.get("Flank Results")     # the run's collection lives under "Flank Results"
    out.update(active=cutter.name, collection=coll.name,
               in_scene=bool(results is not None and coll.name in results.children
                             and results.name in bpy.context.scene.collection.children),
               objects=sorted(o.name for o in coll.objects), props=_obj_props(cutter),
               coll_props=sorted(k for k in coll.keys() if k.startswith("flank_cutter_")))
    props = out["props"]
    rotor = bpy.data.objects[props["flank_cutter_rotor"]]
    out["rotor"] = dict(name=rotor.name, in_collection=rotor.name in coll.objects,
                        props=sorted(k for k in rotor.keys() if k.startswith("flank_")))
    # cutter mesh: flags per ring + colours; geometry against the core's meridian in its own frame
    flags = _float_attr(np, cutter.data, "cutter_flags")
    cols = _color_attr(np, cutter.data, "cutter_flags_color")
    red = (cols[:, 0] > 0.8) & (cols[:, 1] < 0.2) & (cols[:, 2] < 0.2)
    orange = (cols[:, 0] > 0.9) & (cols[:, 1] > 0.5) & (cols[:, 1] < 0.7) & (cols[:, 2] < 0.2)
    active = cutter.data.color_attributes.active_color
    out["cutter"] = dict(vertices=len(cutter.data.vertices), flagged_vertices=int((flags != 0).sum()),
                         red_vertices=int(red.sum()), orange_vertices=int(orange.sum()),
                         red_is_flagged=bool(np.all(flags[red] != 0)), plain_not_flagged=bool(
                             np.all(flags[~red & ~orange] == 0)),
                         active_color=active.name if active is not None else None)
    return out, dict(cutter=cutter, rotor=rotor, flags=flags, coll=coll)


def scenario_formed_cutter(bpy, res, args):
    """flank.formed_cutter: the Hu, Zhou & Li 2025 Table-1 set-up, a flagged set-up, the active rotor, bad input."""
    import numpy as np

    fc, screw = _core("methods.formed_cutter.cutter_profile"), _core("geometry.screw")
    scene = bpy.context.scene
    tmp = os.path.abspath(os.getcwd())
    T = fc.TABLE1
    csv = os.path.join(tmp, "cutter.csv")

    # ---------------------------------------------------------------- Table 1 (31 deg, A 200, lead 450)
    out, objs = _cutter_run(bpy, np, fc, screw, filepath=csv, frame_start=1, frame_end=101)
    res["table1"] = out
    if objs is None:
        return
    cutter, rotor = objs["cutter"], objs["rotor"]
    props = out["props"]
    prof, tooth, _ = fc.arc_tooth_profile()
    cp = fc.cutter_profile(prof, T["lead"], T["centre_distance"], T["swivel_deg"], tooth=tooth)
    s = cp.summary()
    out["expected"] = dict(r_range=s["r_range"], z_range=s["z_range"], flag_counts=s["flag_counts"],
                           planes=s["planes"], r_max_formula=T["centre_distance"] - (T["G"] - T["R1"]))
    v0 = T["lead"] / (2 * np.pi)
    # the static cutter: world = rotor_world @ S(t_mid) @ cutter_to_rotor (set-up moved along the helix)
    rw = np.array(rotor.matrix_world, dtype=np.float64)
    t_mid = props["flank_cutter_setup_t"]
    C = _screw4(np, t_mid, v0, 1) @ cp.setup.cutter_to_rotor
    out["placement"] = dict(max_matrix_diff=float(np.abs(np.array(cutter.matrix_world) - rw @ C).max()),
                            rotor_location=list(rotor.location), t_mid_z=float(v0 * t_mid))
    # cutter vertices in the cutter frame reproduce the meridian R(Z)
    co = _mesh_co(np, cutter)
    loc = co[:-2]                                  # ring vertices (the two poles last)
    rad = np.hypot(loc[:, 0], loc[:, 1])
    out["meridian"] = dict(max_radius_error=float(np.abs(rad - np.interp(loc[:, 2], cp.z, cp.r)).max()),
                           z_span=[float(loc[:, 2].min()), float(loc[:, 2].max())])
    # contact points: on the rotor's groove circle after screwing back, and on the cutter surface
    cc = _world(np, bpy.data.objects["Contact Points"], _mesh_co(np, bpy.data.objects["Contact Points"]))
    cc_rotor = (cc - rw[:3, 3]) @ rw[:3, :3]
    q = screw.screw_to_plane(cc_rotor, v0, "right")
    on_groove = np.abs(np.hypot(q[:, 0] - T["G"], q[:, 1]) - T["R1"])
    cw = np.array(cutter.matrix_world, dtype=np.float64)
    c_loc = (cc - cw[:3, 3]) @ cw[:3, :3]
    out["contact"] = dict(count=len(cc), max_off_groove=float(on_groove.max()),
                          max_off_cutter=float(np.abs(np.hypot(c_loc[:, 0], c_loc[:, 1]) - cp.r).max()))
    # rotor: machined deviation on the tooth vertices (the groove circle facing +x), untouched elsewhere
    dev = _float_attr(np, rotor.data, "machined_deviation")
    rcols = _color_attr(np, rotor.data, "machined_deviation_color")
    rq = screw.screw_to_plane(_mesh_co(np, rotor), v0, "right")
    tooth_v = (np.abs(np.hypot(rq[:, 0] - T["G"], rq[:, 1]) - T["R1"]) < 1e-3) & (rq[:, 0] > 0)
    reached = dev < 1e8
    grey = np.all(np.abs(rcols[:, :3] - 0.6) < 1e-6, axis=1)
    green = (rcols[:, 1] > rcols[:, 0]) & (rcols[:, 1] > rcols[:, 2])
    ract = rotor.data.color_attributes.active_color
    out["rotor_dev"] = dict(vertices=len(dev), tooth_vertices=int(tooth_v.sum()), reached=int(reached.sum()),
                            reached_is_tooth=bool(np.array_equal(reached, tooth_v)),
                            max_abs_tooth=float(np.abs(dev[tooth_v]).max()) if tooth_v.any() else None,
                            off_tooth_untouched=bool(np.all(dev[~tooth_v] == np.float32(1e9))),
                            grey_is_untouched=bool(np.array_equal(grey, ~reached)),
                            green_tooth=bool(np.all(green[tooth_v])),
                            active_color=ract.name if ract is not None else None)
    # CSV: z,r of the cutter profile
    if os.path.isfile(csv):
        with open(csv) as fh:
            header = fh.readline().strip()
        data = np.loadtxt(csv, delimiter=",", skiprows=1)
        out["csv"] = dict(header=header, rows=len(data), max_diff=float(np.abs(data - cp.meridian).max()))
    # animation: linear keys on the motion empty; moving cutter = rotor_world @ S(s(f)) @ C
    motion = bpy.data.objects.get("Cutter Motion")
    moving = bpy.data.objects.get("Formed Cutter (moving)")
    anim = dict(has_action=bool(motion and motion.animation_data and motion.animation_data.action),
                shares_mesh=bool(moving and moving.data == cutter.data),
                parent=[motion.parent.name if motion and motion.parent else None,
                        moving.parent.name if moving and moving.parent else None])
    if anim["has_action"]:
        anim["fcurves"] = _fcurve_keys(motion.animation_data.action)
        fs, fe = props["flank_cutter_frames"]
        s0, s1 = props["flank_cutter_motion"]
        pick = np.array([0, 40 * 96 + 5, 100 * 96 + 50, len(co) - 1])    # some cutter vertices
        samples = []
        for f in (fs, 26, (fs + fe) // 2, fe - 7, fe):
            scene.frame_set(f)
            sf = s0 + (s1 - s0) * (f - fs) / (fe - fs)
            expect = (rw @ _screw4(np, sf, v0, 1) @ C) @ np.c_[co[pick], np.ones(len(pick))].T
            got = _world(np, moving, co[pick])
            samples.append(dict(frame=f, s=sf, max_diff=float(np.abs(got - expect[:3].T).max()),
                                z_centre=float(np.array(moving.matrix_world)[2, 3])))
        anim["samples"] = samples
        scene.frame_set(fs)
    out["anim"] = anim
    res["panels"] = _draw_panels(bpy, cutter)

    # ---------------------------------------------------------------- flagged set-up: swivel 50 deg
    out, objs = _cutter_run(bpy, np, fc, screw, swivel=50.0, animate=False)
    res["flagged"] = out
    if objs is not None:
        cp50 = fc.cutter_profile(prof, T["lead"], T["centre_distance"], 50.0, tooth=tooth)
        out["expected_flag_counts"] = cp50.summary()["flag_counts"]
        out["expected_flagged_planes"] = int(np.count_nonzero(cp50.flags))
        out["expected_uncut"] = len(cp50.uncut)
        dev = _float_attr(np, objs["rotor"].data, "machined_deviation")
        rcols = _color_attr(np, objs["rotor"].data, "machined_deviation_color")
        blue = (rcols[:, 2] > 2 * rcols[:, 0]) & (rcols[:, 2] > 2 * rcols[:, 1])
        out["rotor_dev"] = dict(max_stock=float(dev[dev < 1e8].max()), blue_vertices=int(blue.sum()),
                                stock_vertices=int(((dev < 1e8) & (dev > out["props"]["flank_cutter_tolerance"])).sum()))

    # ---------------------------------------------------------------- the active generated rotor
    ret, err = _run_op(bpy.ops.flank.generate_rotor, kind="srm_a", part="male", resolution=360, axial=24)
    gen = bpy.context.active_object
    out, objs = _cutter_run(bpy, np, fc, screw, source="ACTIVE", sample_points=41, animate=False)
    res["active"] = out
    if objs is not None:
        dev = _float_attr(np, gen.data, "machined_deviation")
        out["rotor_reached"] = int((dev < 1e8).sum())
        out["rotor_vertices"] = len(dev)
        out["outer_radius"] = 1.0
        # again with the cutter selected: the operator finds the rotor through flank_cutter_rotor
        again, _ = _cutter_run(bpy, np, fc, screw, source="ACTIVE", sample_points=41, animate=False)
        out["again"] = dict(result=again["result"], error=again["error"],
                            rotor=again.get("props", {}).get("flank_cutter_rotor"))
    bad_active = {}
    bpy.context.view_layer.objects.active = gen
    s0 = len(bpy.data.objects)
    ret, err = _run_op(bpy.ops.flank.formed_cutter, source="ACTIVE", lead=5.0)
    bad_active["wrong_lead"] = dict(result=ret, error=err, new_objects=len(bpy.data.objects) - s0)
    ret, err = _run_op(bpy.ops.flank.formed_cutter, source="ACTIVE", handedness="left")
    bad_active["wrong_hand"] = dict(result=ret, error=err, new_objects=len(bpy.data.objects) - s0)
    bpy.ops.mesh.primitive_cube_add(location=(5.0, 0.0, 0.0))
    s0 = len(bpy.data.objects)
    ret, err = _run_op(bpy.ops.flank.formed_cutter, source="ACTIVE")
    bad_active["cube"] = dict(result=ret, error=err, new_objects=len(bpy.data.objects) - s0)
    res["bad_active"] = bad_active

    # ---------------------------------------------------------------- bad input: nothing created
    res["bad"] = {}
    nan = float("nan")
    for name, kw in (("A_below_radius", dict(centre_distance=100.0)), ("swivel_zero", dict(swivel=0.0)),
                     ("swivel_90", dict(swivel=90.0)), ("swivel_nan", dict(swivel=nan)),
                     ("A_nan", dict(centre_distance=nan)), ("lead_nan", dict(lead=nan)),
                     ("lead_negative", dict(lead=-450.0)), ("frames", dict(frame_start=10, frame_end=10))):
        s0 = (len(bpy.data.objects), len(bpy.data.meshes), len(bpy.data.collections), len(bpy.data.actions))
        ret, err = _run_op(bpy.ops.flank.formed_cutter, **kw)
        s1 = (len(bpy.data.objects), len(bpy.data.meshes), len(bpy.data.collections), len(bpy.data.actions))
        res["bad"][name] = dict(result=ret, error=err, new=[s1[i] - s0[i] for i in range(4)])


# --------------------------------------------------------------------------- double flank (Bizzarri & Bartoň 2021)

def _snapshot4(bpy):
    return (len(bpy.data.objects), len(bpy.data.meshes), len(bpy.data.collections), len(bpy.data.actions))


def _df_run(bpy, np, **kw):
    """Run flank.plan_double_flank; collect the result objects by role (JSON-able) and the live objects."""
    s0 = _snapshot4(bpy)
    t0 = time.perf_counter()
    ret, err = _run_op(bpy.ops.flank.plan_double_flank, **kw)
    s1 = _snapshot4(bpy)
    out = dict(result=ret, error=err, seconds=time.perf_counter() - t0, new=[s1[i] - s0[i] for i in range(4)])
    if ret is None:
        return out, None
    tool = bpy.context.active_object
    coll = tool.users_collection[0]
    parents = [c.name for c in bpy.data.collections if coll.name in c.children]
    roles = {}
    for ob in coll.objects:
        roles.setdefault(ob.get("flank_df_role", "?"), []).append(ob.name)
    out.update(active=tool.name, collection=coll.name, parents=parents,
               parent_in_scene="Flank Results" in bpy.context.scene.collection.children,
               roles={k: sorted(v) for k, v in roles.items()}, props=_obj_props(tool),
               coll_props=sorted(k for k in coll.keys() if k.startswith("flank_df_")), log=err)
    rotor = bpy.data.objects[out["props"]["flank_df_rotor"]]
    out["rotor_props"] = sorted(k for k in rotor.keys() if k.startswith("flank_df_"))
    return out, dict(tool=tool, coll=coll, rotor=rotor)


def _df_compare(bpy, np, out, objs, res, rotor_world, scale, z_range, n_t, tol):
    """Compare the Blender objects of one run against the core's result ``res`` (rotor frame)."""
    verify = _core("simulation.verify")
    coll = objs["coll"]
    by_role = {}
    for ob in coll.objects:
        by_role.setdefault(ob.get("flank_df_role"), []).append(ob)
    # envelope strips: deviation min/max, colours, placement
    env = res.envelope_meshes(z_range, n_t)
    strips = []
    for ob in sorted(by_role.get("envelope", []), key=lambda o: (o["flank_df_path"], o["flank_df_flank"])):
        k, f = ob["flank_df_path"], ob["flank_df_flank"] - 1
        ev, ef, ed = env[k][f]
        dev = _float_attr(np, ob.data, "deviation")
        cols = _color_attr(np, ob.data, "error_color")
        expect_cols = verify.deviation_colors(dev.astype(np.float64), tol)
        world = _world(np, ob, _mesh_co(np, ob))
        core_world = ev @ rotor_world[:3, :3].T + rotor_world[:3, 3]
        active = ob.data.color_attributes.active_color
        strips.append(dict(
            path=k, flank=f + 1, vertices=len(dev), core_vertices=len(ev), faces=len(ob.data.polygons),
            core_faces=len(ef), dev_min=float(dev.min()), dev_max=float(dev.max()),
            core_min=float(np.nanmin(ed)) * scale, core_max=float(np.nanmax(ed)) * scale,
            max_abs_diff=float(np.abs(dev - ed * scale).max()),
            color_diff=float(np.abs(cols - expect_cols).max()), active_color=active.name if active else None,
            placement_diff=float(np.abs(world - core_world).max()),
            domain=ob.data.attributes["deviation"].domain, data_type=ob.data.attributes["deviation"].data_type))
    out["envelopes"] = strips
    # tools: vertices in world = rotor world @ core tool mesh; the origin at the axis start
    tools = []
    for ob in sorted(by_role.get("tool", []), key=lambda o: o["flank_df_path"]):
        k = ob["flank_df_path"]
        tv, _ = res.tool_mesh(k, n_around=48, max_rings=400)
        world = _world(np, ob, _mesh_co(np, ob))
        core_world = tv @ rotor_world[:3, :3].T + rotor_world[:3, 3]
        a0 = np.asarray(res.paths[k].plan_points[0], dtype=np.float64)
        a1 = np.asarray(res.paths[k].plan_points[-1], dtype=np.float64)
        mw = np.array(ob.matrix_world, dtype=np.float64)
        axis_dir = mw[:3, 2] / np.linalg.norm(mw[:3, 2])
        expect_dir = rotor_world[:3, :3] @ (a1 - a0)
        expect_dir /= np.linalg.norm(expect_dir)
        tools.append(dict(path=k, vertices=len(world), core_vertices=len(tv),
                          max_vertex_diff=float(np.abs(world - core_world).max()),
                          origin=mw[:3, 3].tolist(), expect_origin=(rotor_world[:3, :3] @ a0 + rotor_world[:3, 3]).tolist(),
                          axis_dot=float(axis_dir @ expect_dir), object_scale=float(np.cbrt(np.linalg.det(mw[:3, :3])))))
    out["tools"] = tools
    # error charts: max |error| (scene units) vs the core, x offset = error x scale
    charts = []
    for ob in sorted(by_role.get("error_chart", []), key=lambda o: o["flank_df_path"]):
        k = ob["flank_df_path"]
        s_ax, e1, e2 = res.errors_along_axis(k)
        err = _float_attr(np, ob.data, "error")
        flank = _float_attr(np, ob.data, "flank")
        co = _mesh_co(np, ob)
        x0 = ob["flank_df_chart_offset"] / scale
        k_vis = ob["flank_df_error_scale"]
        e_core = np.r_[e1, e2]
        charts.append(dict(path=k, vertices=len(co), edges=len(ob.data.edges), faces=len(ob.data.polygons),
                           max_abs=float(np.abs(err).max()),
                           core_max_abs=float(np.nanmax(np.abs(e_core))) * scale,
                           offset_diff=float(np.abs((co[:, 0] - x0) - k_vis * err / scale).max()),
                           flanks=sorted(set(int(v) for v in flank)), error_scale=k_vis,
                           finite_core=[int(np.isfinite(e1).sum()), int(np.isfinite(e2).sum())],
                           flank_vertices=[int((flank == 1).sum()), int((flank == 2).sum())]))
    out["charts"] = charts


def scenario_double_flank(bpy, res, args):
    """flank.plan_double_flank: nilson-male (symmetric), asymmetric-male (moved, scaled), cone, bad input."""
    import numpy as np
    from mathutils import Matrix

    df, rotors, plan_mod = _core("methods.double_flank.planner"), _core("geometry.rotors"), _core("io.plan")
    scene = bpy.context.scene
    tmp = os.path.abspath(os.getcwd())
    M_RADII, N_T = 40, 12
    opts = dict(radii=M_RADII, envelope_rings=N_T, simulate=False)

    # ---------------------------------------------------------------- bad input first: nothing at all created
    ret, err = _run_op(bpy.ops.flank.generate_rotor, kind="nilson", part="male", resolution=360, axial=24)
    nilson = bpy.context.active_object
    res["bad"] = {}
    nan = float("nan")
    for name, kw in (("valley_4", dict(valley=4)), ("valley_neg", dict(valley=-1)), ("rim_zero", dict(rim=0.0)),
                     ("rim_1_5", dict(rim=1.5)), ("rim_nan", dict(rim=nan)), ("rim_0_1", dict(rim=0.1)),
                     ("radii_1", dict(radii=1)), ("radii_big", dict(radii=6000)), ("cones_0", dict(tool="cones", cones=0)),
                     ("two_paths_cone", dict(tool="cone", two_paths=True)),
                     ("frames", dict(frame_start=10, frame_end=10)),
                     ("plan_dir_missing", dict(filepath=os.path.join(tmp, "no_such_dir", "plan.json")))):
        bpy.context.view_layer.objects.active = nilson
        s0 = _snapshot4(bpy)
        ret, err = _run_op(bpy.ops.flank.plan_double_flank, **dict(opts, **kw))
        s1 = _snapshot4(bpy)
        res["bad"][name] = dict(result=ret, error=err, new=[s1[i] - s0[i] for i in range(4)],
                                results_collection=bpy.data.collections.get("Flank Results") is not None,
                                rotor_props=sorted(k for k in nilson.keys() if k.startswith("flank_df_")))
    bpy.ops.mesh.primitive_cube_add(location=(5.0, 0.0, 0.0))
    s0 = _snapshot4(bpy)
    ret, err = _run_op(bpy.ops.flank.plan_double_flank, **opts)
    s1 = _snapshot4(bpy)
    res["bad"]["cube"] = dict(result=ret, error=err, new=[s1[i] - s0[i] for i in range(4)],
                              results_collection=bpy.data.collections.get("Flank Results") is not None)
    bpy.ops.object.empty_add()
    s0 = _snapshot4(bpy)
    ret, err = _run_op(bpy.ops.flank.plan_double_flank, **opts)
    s1 = _snapshot4(bpy)
    res["bad"]["empty"] = dict(result=ret, error=err, new=[s1[i] - s0[i] for i in range(4)])

    # ---------------------------------------------------------------- nilson-male: symmetric, errors ~ 0
    bpy.context.view_layer.objects.active = nilson
    plan_path = os.path.join(tmp, "nilson_plan.json")
    csv_path = os.path.join(tmp, "nilson_tool.csv")
    out, objs = _df_run(bpy, np, filepath=plan_path, tool_csv=csv_path, frame_start=1, frame_end=101, **opts)
    res["nilson"] = out
    if objs is not None:
        rotor = rotors.builtin_rotor("nilson", "male")
        t0 = time.perf_counter()
        core = df.plan_double_flank(rotor.surface(), rotor.flanks, valley=0, m=M_RADII, simulate=False)
        out["core_seconds"] = time.perf_counter() - t0
        out["core"] = dict(x=[[float(v) for v in f.x] for f in core.fits], Phi=[float(f.phi) for f in core.fits],
                           iterations=[int(f.iterations) for f in core.fits],
                           tool_to_rotor=[list(v) for v in core.tool_to_rotor], method=core.plan["method"])
        rw = np.array(nilson.matrix_world, dtype=np.float64)
        _df_compare(bpy, np, out, objs, core, rw, 1.0, (0.0, rotor.length), N_T, out["props"]["flank_df_tolerance"])
        # plan file valid and carrying the rotor's placement
        try:
            plan = plan_mod.read_plan(plan_path)
            out["plan"] = dict(ok=True, method=plan["method"], strips=len(plan["strips"]),
                               length_unit=plan["length_unit"], target_flanks=plan["target_flanks"],
                               to_world_diff=float(np.abs(np.array(plan["rotor"]["to_world"]) - rw).max()),
                               axis_start_diff=float(np.abs(np.array(plan["strips"][0]["axis_start"])
                                                            - core.plan["strips"][0]["axis_start"]).max()))
        except Exception as ex:
            out["plan"] = dict(ok=False, error="{}: {}".format(type(ex).__name__, ex))
        if os.path.isfile(csv_path):
            with open(csv_path) as fh:
                header = fh.readline().strip()
            data = np.loadtxt(csv_path, delimiter=",", skiprows=1, ndmin=2)
            out["csv"] = dict(header=header, rows=len(data), r_max=float(data[:, 1].max()),
                              core_r_max=float(np.max(core.paths[0].meridian[:, 1])
                                               if core.paths[0].meridian is not None
                                               else np.max(core.paths[0].plan_radii)),
                              core_rows=min(4000, len(core.paths[0].meridian))
                              if core.paths[0].meridian is not None else 2)
        # animation: the moving tool = rotor world @ S(s(f)) @ tool frame
        motion = [o for o in objs["coll"].objects if o.get("flank_df_role") == "motion"]
        moving = [o for o in objs["coll"].objects if o.get("flank_df_role") == "moving"]
        anim = dict(motions=len(motion), movings=len(moving))
        if motion and moving and motion[0].animation_data and motion[0].animation_data.action:
            anim["fcurves"] = _fcurve_keys(motion[0].animation_data.action)
            anim["parent"] = [motion[0].parent.name if motion[0].parent else None,
                              moving[0].parent.name if moving[0].parent else None]
            anim["shares_mesh"] = moving[0].data == objs["tool"].data
            fs, fe = out["props"]["flank_df_frames"]
            s_lo, s_hi = out["props"]["flank_df_motion"]
            T = np.array(objs["tool"].matrix_world, dtype=np.float64)       # rotor world @ tool frame
            co = _mesh_co(np, moving[0])[[0, 100, -1]]
            samples = []
            for f in (fs, (fs + fe) // 2, fe):
                scene.frame_set(f)
                sf = s_lo + (s_hi - s_lo) * (f - fs) / (fe - fs)
                expect = (rw @ _screw4(np, sf, rotor.v0, 1) @ np.linalg.inv(rw) @ T) @ np.c_[co, np.ones(3)].T
                samples.append(dict(frame=f, s=sf, max_diff=float(np.abs(_world(np, moving[0], co) - expect[:3].T).max())))
            scene.frame_set(fs)
            anim["samples"] = samples
        out["anim"] = anim
        res["panels"] = _draw_panels(bpy, objs["tool"])
        # again with the tool selected: the operator finds the rotor through flank_df_rotor
        again, _ = _df_run(bpy, np, animate=False, **opts)
        out["again"] = dict(result=again["result"], error=again["error"],
                            rotor=again.get("props", {}).get("flank_df_rotor"), parents=again.get("parents"))

    # ---------------------------------------------------------------- asymmetric-male, moved, rotated, scaled x2
    ret, err = _run_op(bpy.ops.flank.generate_rotor, kind="asymmetric", part="male", resolution=360, axial=24)
    asym = bpy.context.active_object
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    M = np.eye(4)
    M[:3, :3] = 2.0 * (np.eye(3) + np.sin(0.9) * K + (1 - np.cos(0.9)) * K @ K)
    M[:3, 3] = (0.4, -0.3, 0.7)
    asym.matrix_world = Matrix(M.tolist())
    bpy.context.view_layer.update()
    plan_path = os.path.join(tmp, "asym_plan.json")
    out, objs = _df_run(bpy, np, valley=1, filepath=plan_path, animate=False, **opts)
    res["asym"] = out
    if objs is not None:
        rotor = rotors.builtin_rotor("asymmetric", "male")
        core = df.plan_double_flank(rotor.surface(), rotor.flanks, valley=1, m=M_RADII, simulate=False)
        out["core"] = dict(x=[[float(v) for v in f.x] for f in core.fits], Phi=[float(f.phi) for f in core.fits],
                           iterations=[int(f.iterations) for f in core.fits],
                           tool_to_rotor=[list(v) for v in core.tool_to_rotor], method=core.plan["method"])
        rw = np.array(asym.matrix_world, dtype=np.float64)
        _df_compare(bpy, np, out, objs, core, rw, 2.0, (0.0, rotor.length), N_T, out["props"]["flank_df_tolerance"])
        try:
            plan = plan_mod.read_plan(plan_path)
            out["plan"] = dict(ok=True, method=plan["method"], strips=len(plan["strips"]),
                               length_unit=plan["length_unit"],
                               to_world_diff=float(np.abs(np.array(plan["rotor"]["to_world"]) - rw).max()))
        except Exception as ex:
            out["plan"] = dict(ok=False, error="{}: {}".format(type(ex).__name__, ex))

    # ---------------------------------------------------------------- cones:2 (one tool object per cone)
    bpy.context.view_layer.objects.active = asym
    csv_path = os.path.join(tmp, "cones.csv")
    out, objs = _df_run(bpy, np, tool="cones", cones=2, tool_csv=csv_path, animate=True, **opts)
    res["cones"] = out
    if objs is not None:
        rotor = rotors.builtin_rotor("asymmetric", "male")
        core = df.plan_double_flank(rotor.surface(), rotor.flanks, valley=0, tool="cones:2", m=M_RADII,
                                    simulate=False)
        out["core"] = dict(x=[[float(v) for v in f.x] for f in core.fits], paths=len(core.paths),
                           tool_to_rotor=[list(v) for v in core.tool_to_rotor], method=core.plan["method"])
        _df_compare(bpy, np, out, objs, core, np.array(asym.matrix_world, dtype=np.float64), 2.0,
                    (0.0, rotor.length), N_T, out["props"]["flank_df_tolerance"])
        out["csv_files"] = sorted(f for f in os.listdir(tmp) if f.startswith("cones"))

    # ---------------------------------------------------------------- an analyzed mesh (analysed again, as --mesh)
    ret, err = _run_op(bpy.ops.flank.generate_rotor, kind="nilson", part="male", resolution=720, axial=48)
    mesh_rotor = bpy.context.active_object
    mesh_rotor.location = (3.0, 0.0, 0.0)
    bpy.context.view_layer.update()
    t0 = time.perf_counter()
    ret, err = _run_op(bpy.ops.flank.analyze_rotor)
    res["analyzed_setup"] = dict(result=ret, error=err, seconds=time.perf_counter() - t0,
                                 source=mesh_rotor.get("flank_source"))
    out, objs = _df_run(bpy, np, animate=True, **opts)
    res["analyzed"] = out
    if objs is not None:
        tool = objs["tool"]
        env = [o for o in objs["coll"].objects if o.get("flank_df_role") == "envelope"]
        co = _world(np, env[0], _mesh_co(np, env[0]))
        # the envelope lies on the rotor (nilson: exact envelope = rotor): screw its world points, taken into
        # the object's local frame (= the generated rotor's frame), into z = 0 and measure to the exact profile
        from scipy.spatial import cKDTree

        nil = rotors.builtin_rotor("nilson", "male")
        local = co - np.array(mesh_rotor.location)
        q = _core("geometry.screw").screw_to_plane(local, nil.v0, nil.handedness)
        dense = nil.profile.sample(200000)
        d, _ = cKDTree(dense).query(q)
        out["envelope_to_profile"] = dict(median=float(np.median(d)), max=float(d.max()),
                                          spacing=float(np.linalg.norm(dense[1] - dense[0])))
        out["tool_origin"] = list(tool.matrix_world.translation)
        plan = json.loads(objs["coll"]["flank_plan_json"])
        out["plan_mm"] = dict(outer_radius=plan["rotor"]["outer_radius"], v0=plan["rotor"]["v0"],
                              unit=plan["length_unit"], scene_v0=float(mesh_rotor["flank_v0"]),
                              scene_unit=[scene.unit_settings.system, float(scene.unit_settings.scale_length)])
        motion = [o for o in objs["coll"].objects if o.get("flank_df_role") == "motion"]
        moving = [o for o in objs["coll"].objects if o.get("flank_df_role") == "moving"]
        if motion and moving:
            fs = out["props"]["flank_df_frames"][0]
            s_lo = out["props"]["flank_df_motion"][0]
            scene.frame_set(fs)
            # at the first frame the moving tool = static tool screwed by s_lo about the rotor axis (world)
            # the run is in mm (length_scale scene units per mm): its rotor frame is the analysis' to_world
            # (scene units) scaled by length_scale, its v0 the analysed one in mm
            ls = out["props"]["flank_df_length_scale"]
            v0_run = mesh_rotor["flank_v0"] / ls
            T = np.array(tool.matrix_world, dtype=np.float64)
            W = np.array(motion[0].matrix_world, dtype=np.float64) @ np.linalg.inv(_screw4(np, s_lo, v0_run, 1))
            stored = np.array(list(mesh_rotor["flank_to_world"]), dtype=np.float64).reshape(4, 4)
            out["motion_frame_vs_analysis"] = float(np.abs(W - stored @ np.diag([ls, ls, ls, 1.0])).max())
            expect = W @ _screw4(np, s_lo, v0_run, 1) @ np.linalg.inv(W) @ T
            out["moving_diff"] = float(np.abs(np.array(moving[0].matrix_world, dtype=np.float64) - expect).max())


# --------------------------------------------------------------------------- single flank (Bizzarri, Bo & Bartoň)

SF_ASIN = 0.1001674211615598          # asin(0.1)


def _sf_run(bpy, np, **kw):
    """Run flank.plan_single_flank; collect the result objects by role (JSON-able) and the live objects."""
    s0 = _snapshot4(bpy)
    t0 = time.perf_counter()
    ret, err = _run_op(bpy.ops.flank.plan_single_flank, **kw)
    s1 = _snapshot4(bpy)
    out = dict(result=ret, error=err, seconds=time.perf_counter() - t0, new=[s1[i] - s0[i] for i in range(4)])
    if ret is None:
        return out, None
    tool = bpy.context.active_object
    coll = tool.users_collection[0]
    parents = [c.name for c in bpy.data.collections if coll.name in c.children]
    roles = {}
    for ob in coll.objects:
        roles.setdefault(ob.get("flank_sf_role", "?"), []).append(ob.name)
    out.update(active=tool.name, collection=coll.name, parents=parents,
               parent_in_scene="Flank Results" in bpy.context.scene.collection.children,
               roles={k: sorted(v) for k, v in roles.items()}, props=_obj_props(tool),
               coll_props=sorted(k for k in coll.keys() if k.startswith("flank_sf_")),
               orphans=dict(meshes=sum(1 for m in bpy.data.meshes if m.users == 0),
                            actions=sum(1 for a in bpy.data.actions if a.users == 0),
                            collections=sorted(c.name for c in bpy.data.collections
                                               if c.name.startswith("Single Flank"))))
    rotor = bpy.data.objects[out["props"]["flank_sf_rotor"]]
    out["rotor_props"] = sorted(k for k in rotor.keys() if k.startswith("flank_sf_"))
    return out, dict(tool=tool, coll=coll, rotor=rotor)


def scenario_single_flank(bpy, res, args):
    """flank.plan_single_flank: asymmetric-female flank 1 (moved, rotated, scaled x2; tool asin(0.1), 0.05,
    0.08 R, tolerance 1e-3 R) vs the core run here; a re-run from a point replaces the collection; undo; bad
    input creates nothing."""

    import numpy as np
    from mathutils import Matrix

    ms, cone, rotors, verify = _core("methods.single_flank.planner"), _core("tooling.cone"), _core("geometry.rotors"), _core("simulation.verify")
    plan_mod, screw = _core("io.plan"), _core("geometry.screw")
    scene = bpy.context.scene
    tmp = os.path.abspath(os.getcwd())
    S = 2.0                                       # object scale: scene units per rotor unit
    N_T, SEEDS, ROUNDS = 12, 6, 4
    tool_kw = dict(shape="alpha", alpha=SF_ASIN, r1=0.05 * S, r2=0.08 * S, shank_radius=0.04 * S,
                   shank_length=0.6 * S, tolerance=1e-3 * S)
    opts = dict(tool_kw, envelope_rings=N_T)

    ret, err = _run_op(bpy.ops.flank.generate_rotor, kind="asymmetric", part="female", resolution=360, axial=24)
    rotor_obj = bpy.context.active_object
    rotor_name = rotor_obj.name
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    M = np.eye(4)
    M[:3, :3] = S * (np.eye(3) + np.sin(0.9) * K + (1 - np.cos(0.9)) * K @ K)
    M[:3, 3] = (0.4, -0.3, 0.7)
    rotor_obj.matrix_world = Matrix(M.tolist())
    bpy.context.view_layer.update()

    # ---------------------------------------------------------------- bad input first: nothing at all created
    res["bad"] = {}
    nan = float("nan")
    for name, kw in (("r1_ge_r2", dict(r1=0.2, r2=0.1)), ("r1_eq_r2", dict(r1=0.1, r2=0.1)),
                     ("r1_neg", dict(r1=-0.1)), ("alpha_95", dict(alpha=1.6580628)), ("alpha_0", dict(alpha=0.0)),
                     ("length_0", dict(shape="length", length=0.0)), ("tolerance_0", dict(tolerance=0.0)),
                     ("tolerance_nan", dict(tolerance=nan)), ("tolerance_big", dict(tolerance=1.5)),
                     ("overcut_neg", dict(overcut_tolerance=-1e-3)), ("flank_99", dict(flank=99)),
                     ("flank_neg", dict(flank=-1)), ("seeds_0", dict(seeds=0)), ("rounds_0", dict(rounds=0)),
                     ("frames", dict(frame_start=10, frame_end=10)),
                     ("point_nan", dict(use_point=True, point=(nan, 0.0, 0.0))),
                     ("point_far", dict(use_point=True, point=(1e9, 0.0, 0.0))),
                     ("all_colliding", dict(shank_radius=1.0 * S, shank_length=1.0 * S, seeds=2, rounds=1)),
                     ("plan_dir_missing", dict(seeds=1, rounds=1, filepath=os.path.join(tmp, "no_dir", "p.json"))),
                     ("plan_relative", dict(seeds=1, rounds=1, filepath="relative_plan.json"))):
        bpy.context.view_layer.objects.active = rotor_obj
        s0 = _snapshot4(bpy)
        ret, err = _run_op(bpy.ops.flank.plan_single_flank, **dict(opts, **kw))
        s1 = _snapshot4(bpy)
        res["bad"][name] = dict(result=ret, error=err, new=[s1[i] - s0[i] for i in range(4)],
                                results_collection=bpy.data.collections.get("Flank Results") is not None,
                                rotor_props=sorted(k for k in rotor_obj.keys() if k.startswith("flank_sf_")))
    bpy.ops.mesh.primitive_cube_add(location=(5.0, 0.0, 0.0))
    cube = bpy.context.active_object
    for name, tag in (("cube", None), ("cube_analyzed", "analyzed")):
        if tag is not None:
            cube["flank_source"] = tag            # claims to be analyzed: analysed again, refused as non-helical
        s0 = _snapshot4(bpy)
        ret, err = _run_op(bpy.ops.flank.plan_single_flank, **opts)
        s1 = _snapshot4(bpy)
        res["bad"][name] = dict(result=ret, error=err, new=[s1[i] - s0[i] for i in range(4)],
                                results_collection=bpy.data.collections.get("Flank Results") is not None)
    cube_mesh = cube.data
    bpy.data.objects.remove(cube)
    bpy.data.meshes.remove(cube_mesh)

    # ---------------------------------------------------------------- the happy path: flank 1
    bpy.context.view_layer.objects.active = rotor_obj
    plan_path = os.path.join(tmp, "sf_plan.json")
    out, objs = _sf_run(bpy, np, flank=1, seeds=SEEDS, rounds=ROUNDS, animate=True, frame_start=1, frame_end=101,
                        filepath=plan_path, **opts)
    res["happy"] = out
    if objs is None:
        return
    p = out["props"]
    rw = np.array(rotor_obj.matrix_world, dtype=np.float64)
    rotor = rotors.builtin_rotor("asymmetric", "female")
    surface = rotor.surface()
    tool = cone.ConeTool(p["flank_sf_tool_alpha"], 0.05, 0.08, 0.04, 0.6)
    out["tool_in_rotor_units"] = [p["flank_sf_tool_alpha"], p["flank_sf_tool_r1"] / S, p["flank_sf_tool_r2"] / S,
                                  p["flank_sf_tool_shank_radius"] / S, p["flank_sf_tool_shank_length"] / S]
    try:
        to_world = plan_mod.read_plan(plan_path)["rotor"]["to_world"]
        out["plan_file"] = dict(ok=True, to_world_diff=float(np.abs(np.array(to_world) - rw).max()))
    except Exception as ex:
        to_world = None
        out["plan_file"] = dict(ok=False, error="{}: {}".format(type(ex).__name__, ex))
    t0 = time.perf_counter()
    core = ms.plan_single_flank(surface, rotor.flanks, 1, tool, 1e-3, n_seeds=SEEDS, max_rounds=ROUNDS,
                                to_world=to_world)
    out["core_seconds"] = time.perf_counter() - t0
    out["core"] = dict(strips=len(core.strips), candidates=len(core.candidates), collisions=len(core.collisions),
                       max_error=core.plan["summary"]["max_error"], min_error=core.plan["summary"]["min_error"],
                       uncovered=[list(g) for g in core.uncovered], covered_fraction=core.covered_fraction,
                       kinks=[j["kink_deg"] for js in core.junctions for j in js],
                       strip_max=[st["reported_max_error"] for st in core.plan["strips"]],
                       method=core.plan["method"], dev_max=float(np.nanmax(core.deviation[1])),
                       dev_min=float(np.nanmin(core.deviation[1])))
    coll = objs["coll"]
    by_role = {}
    for ob in coll.objects:
        by_role.setdefault(ob.get("flank_sf_role"), []).append(ob)
    u_range = rotor.flanks[1]
    strips = []
    for ob in sorted(by_role.get("envelope", []), key=lambda o: o["flank_sf_strip"]):
        k = ob["flank_sf_strip"]
        cand = core.strips[k]
        sweep = list(ob["flank_sf_sweep"])
        ev, ef, ed = ms.envelope_strip(cand, surface, u_range, sweep, ob["flank_sf_envelope_samples"],
                                       ob["flank_sf_envelope_rings"])
        dev = _float_attr(np, ob.data, "deviation")
        cols = _color_attr(np, ob.data, "error_color")
        world = _world(np, ob, _mesh_co(np, ob))
        core_world = ev @ rw[:3, :3].T + rw[:3, 3]
        active = ob.data.color_attributes.active_color
        n_ok = len(dev) == len(ed)
        strips.append(dict(
            strip=k, vertices=len(dev), core_vertices=len(ev), faces=len(ob.data.polygons), core_faces=len(ef),
            max_abs_diff=float(np.abs(dev - ed * S).max()) if n_ok else None,
            rel_diff=float(np.abs(dev - ed * S).max() / max(np.abs(ed * S).max(), 1e-30)) if n_ok else None,
            dev_max=float(dev.max()), core_dev_max=float(ed.max()) * S,
            color_diff=float(np.abs(cols - verify.deviation_colors(dev.astype(np.float64), 2e-3)).max()),
            active_color=active.name if active else None,
            placement_diff=float(np.abs(world - core_world).max()) if n_ok else None,
            domain=ob.data.attributes["deviation"].domain, data_type=ob.data.attributes["deviation"].data_type,
            sweep=sweep))
    out["envelopes"] = strips
    tools = []
    for ob in sorted(by_role.get("tool", []), key=lambda o: o["flank_sf_strip"]):
        k = ob["flank_sf_strip"]
        pose = core.strips[k].pose
        mw = np.array(ob.matrix_world, dtype=np.float64)
        ax = mw[:3, 2] / np.linalg.norm(mw[:3, 2])
        expect_ax = rw[:3, :3] @ pose.axis
        expect_ax /= np.linalg.norm(expect_ax)
        co = _mesh_co(np, ob)
        r_xy = np.linalg.norm(co[:, :2], axis=1)
        tools.append(dict(strip=k, origin_diff=float(np.abs(mw[:3, 3] - (rw[:3, :3] @ pose.tip + rw[:3, 3])).max()),
                          axis_dot=float(ax @ expect_ax), object_scale=float(np.cbrt(np.linalg.det(mw[:3, :3]))),
                          params_diff=float(np.abs(np.array(list(ob["flank_sf_params"]))
                                                   - np.ravel(core.strips[k].params)).max()),
                          strip_max_diff=abs(ob["flank_sf_strip_errors"][0]
                                             - S * core.plan["strips"][k]["reported_max_error"]),
                          z_extent=[float(co[:, 2].min()), float(co[:, 2].max())],
                          max_radius=float(r_xy.max()), vertices=len(co)))
    out["tools"] = tools
    out["tool_expect"] = dict(z_tip=-0.05 * np.tan(tool.alpha), z_top=-0.05 * np.tan(tool.alpha) + tool.h + 0.6,
                              max_radius=0.08)
    charts = []
    prof = surface.profile
    for ob in by_role.get("error_chart", []):
        err = _float_attr(np, ob.data, "error").astype(np.float64)
        uu = _float_attr(np, ob.data, "u").astype(np.float64)
        curve = _float_attr(np, ob.data, "curve")
        co = _mesh_co(np, ob)
        k_vis = ob["flank_sf_error_scale"]
        on = curve == 1
        # the curve is the profile offset along its outward normal by error x scale (rotor frame, z = 0)
        expect = prof.eval(uu) + prof.outward_normal(uu) * (k_vis * err / S)[:, None]
        charts.append(dict(vertices=len(co), edges=len(ob.data.edges), faces=len(ob.data.polygons),
                           curve_vertices=int(on.sum()), base_vertices=int((~on).sum()),
                           max_abs=float(np.abs(err).max()), core_max_abs=float(np.nanmax(np.abs(core.deviation[1]))) * S,
                           offset_diff=float(np.abs(co[:, :2] - expect).max()), z_max=float(np.abs(co[:, 2]).max()),
                           error_scale=k_vis, base_max_error=float(np.abs(err[~on]).max())))
    out["charts"] = charts
    # animation: moving tool k = rotor world @ S(s(f)) @ tool frame k (rotor frame)
    motion = by_role.get("motion", [])
    moving = sorted(by_role.get("moving", []), key=lambda o: o["flank_sf_strip"])
    anim = dict(motions=len(motion), movings=len(moving))
    if motion and moving and motion[0].animation_data and motion[0].animation_data.action:
        anim["fcurves"] = _fcurve_keys(motion[0].animation_data.action)
        anim["parent"] = motion[0].parent.name if motion[0].parent else None
        tool0 = [o for o in by_role["tool"] if o["flank_sf_strip"] == moving[0]["flank_sf_strip"]][0]
        anim["shares_mesh"] = moving[0].data == tool0.data
        fs, fe = p["flank_sf_frames"]
        s_lo, s_hi = p["flank_sf_motion"]
        T = np.array(tool0.matrix_world, dtype=np.float64)
        co = _mesh_co(np, moving[0])[[0, 50, -1]]
        samples = []
        for f in (fs, (fs + fe) // 2, fe):
            scene.frame_set(f)
            sf = s_lo + (s_hi - s_lo) * (f - fs) / (fe - fs)
            expect = (rw @ _screw4(np, sf, rotor.v0, surface.hand) @ np.linalg.inv(rw) @ T) @ np.c_[co, np.ones(3)].T
            samples.append(dict(frame=f, max_diff=float(np.abs(_world(np, moving[0], co) - expect[:3].T).max())))
        scene.frame_set(fs)
        anim["samples"] = samples
    out["anim"] = anim
    res["panels"] = _draw_panels(bpy, objs["tool"])

    # ---------------------------------------------------------------- re-run from the tool, flank from a point
    u_mid = 0.5 * (u_range[0] + u_range[1])
    t_pt = 1.0 / rotor.v0
    q = surface.evaluate(u_mid, t_pt) + 0.01 * surface.normal(u_mid, t_pt)     # local = rotor frame (unit rotor)
    before = dict(collection=coll.name, meshes=len(bpy.data.meshes), actions=len(bpy.data.actions))
    bpy.context.view_layer.objects.active = objs["tool"]
    out2, objs2 = _sf_run(bpy, np, use_point=True, point=[float(v) for v in q], flank=7, seeds=4, rounds=1,
                          animate=False, **opts)
    out2["before"] = before
    res["rerun"] = out2
    if objs2 is not None:
        out2["single_flank_collections"] = sorted(c.name for c in bpy.data.collections
                                                  if c.get("flank_sf_key") is not None)
        out2["mesh_users"] = sorted({m.users for m in bpy.data.meshes if m.name.startswith("SF F")})

    # ---------------------------------------------------------------- G1 option, called as the UI does
    # ('INVOKE_DEFAULT': under bpy.app.background the modal planner runs synchronously).  Tolerance 2e-3 R: the
    # core's G1 plan of these settings is made once per test run (tests/conftest.py female_g1_plans) and the
    # test compares against it.
    bpy.context.view_layer.objects.active = bpy.data.objects[rotor_name]
    g1_kw = dict(opts, flank=1, seeds=12, rounds=4, g1=True, g1_extra_strips=3, animate=False, tolerance=2e-3 * S)
    try:
        g1_ret, g1_err = sorted(bpy.ops.flank.plan_single_flank('INVOKE_DEFAULT', **g1_kw)), None
    except RuntimeError as ex:
        g1_ret, g1_err = None, str(ex)
    rot = bpy.data.objects[rotor_name]
    summ = json.loads(rot.get("flank_sf_summary", "{}"))
    res["g1"] = dict(result=g1_ret, error=g1_err, strips=rot.get("flank_sf_strips"),
                     g1=rot.get("flank_sf_g1"), g1_extra=rot.get("flank_sf_g1_extra_strips"),
                     kink_max=rot.get("flank_sf_kink_max_deg"), selection=(summ.get("g1") or {}).get("selection"),
                     tool_alpha=rot.get("flank_sf_tool_alpha"))

    # ---------------------------------------------------------------- undo: back to before the last run
    # In background mode operators called from Python push no undo steps themselves (the UI does, for
    # bl_options UNDO): push around the run as the UI would, then undo and redo the memfile steps.
    def state():
        return dict(objects=sorted(o.name for o in bpy.data.objects),
                    collections=sorted(c.name for c in bpy.data.collections),
                    meshes=len(bpy.data.meshes))

    bpy.context.view_layer.objects.active = bpy.data.objects[rotor_name]
    undo = dict(bl_options=sorted(bpy.types.FLANK_OT_plan_single_flank.bl_options))
    bpy.ops.ed.undo_push(message="before single flank")
    undo["before"] = state()
    out3, _ = _sf_run(bpy, np, flank=3, seeds=2, rounds=1, animate=False, **opts)
    bpy.ops.ed.undo_push(message="Plan Single Flank")
    undo["run"] = dict(result=out3["result"], error=out3["error"], new=out3["new"],
                       collection=out3.get("collection"))
    undo["after_run"] = state()
    try:
        bpy.ops.ed.undo()
        undo["undo_error"] = None
    except Exception as ex:
        undo["undo_error"] = "{}: {}".format(type(ex).__name__, ex)
    undo["after_undo"] = state()
    rot = bpy.data.objects.get(rotor_name)
    undo["rotor_flank_after_undo"] = rot.get("flank_sf_flank") if rot is not None else None
    try:
        bpy.ops.ed.redo()
        undo["redo_error"] = None
    except Exception as ex:
        undo["redo_error"] = "{}: {}".format(type(ex).__name__, ex)
    undo["after_redo"] = state()
    strip = bpy.data.objects.get("SF F3 Strip 1")
    undo["redo_strip_attrs"] = sorted(a.name for a in strip.data.attributes if not a.name.startswith(".")) \
        if strip is not None else None
    rot = bpy.data.objects.get(rotor_name)
    undo["rotor_flank_after_redo"] = rot.get("flank_sf_flank") if rot is not None else None
    res["undo"] = undo


def _cr_run(bpy, np, rotor_obj, active=None, **kw):
    """Run flank.cutter_region with ``active`` (default the rotor) active; the cloud and marker as facts."""
    bpy.context.view_layer.objects.active = rotor_obj if active is None else active
    s0 = _snapshot4(bpy)
    t0 = time.perf_counter()
    ret, err = _run_op(bpy.ops.flank.cutter_region, **kw)
    out = dict(result=ret, error=err, seconds=time.perf_counter() - t0,
               new=[_snapshot4(bpy)[i] - s0[i] for i in range(4)])
    k = kw.get("flank", bpy.context.scene.flank_settings.sf_flank)
    cloud = bpy.data.objects.get("Cutter Region (flank {})".format(k))
    marker = bpy.data.objects.get("Cutter Region (flank {}) Tool".format(k))
    if ret is None or cloud is None or marker is None:
        return out, None
    coll = cloud.users_collection[0]
    flags = _float_attr(np, cloud.data, "admissible")
    fa = cloud.data.attributes.get("failed")
    bits = np.empty(len(fa.data), dtype=np.int32) if fa is not None else None
    if fa is not None:
        fa.data.foreach_get("value", bits)
    cols = _color_attr(np, cloud.data, "admissible_color")
    mflags = _float_attr(np, marker.data, "admissible")
    props = _obj_props(cloud)
    out.update(collection=coll.name, parent=[c.name for c in bpy.data.collections if coll.name in c.children],
               cloud=cloud.name, marker=marker.name, active=bpy.context.active_object.name,
               n_points=len(cloud.data.vertices), n_edges=len(cloud.data.edges), n_faces=len(cloud.data.polygons),
               attrs=sorted(a.name for a in cloud.data.attributes if not a.name.startswith(".")),
               flag_sum=int(round(float(flags.sum()))), flag_values=sorted(set(float(v) for v in flags)),
               green=int(np.all(np.abs(cols - [0.15, 0.75, 0.25, 1.0]) < 1e-6, axis=1).sum()),
               red=int(np.all(np.abs(cols - [0.85, 0.15, 0.10, 1.0]) < 1e-6, axis=1).sum()),
               bits_of_admissible=sorted(set(int(v) for v in bits[flags > 0.5])),
               zero_bits_of_other=int((bits[flags < 0.5] == 0).sum()),
               marker_flags=sorted(set(float(v) for v in mflags)), marker_color=list(marker.color),
               props=props, marker_props=_obj_props(marker), coll_props=_obj_props(coll),
               rotor_props={k_: v for k_, v in _obj_props(rotor_obj).items() if k_.startswith("flank_cr_")})
    return out, dict(cloud=cloud, marker=marker, flags=flags, bits=bits)


def scenario_cutter_region(bpy, res, args):
    """flank.cutter_region on flank 1 of the generated asymmetric female against the core run here (default
    (24, 40, 40) grid): flank and cone from the Single Flank scene settings, the cloud's admissible points
    decoded from the chart equal the core's, the marker's flag equals is_admissible; a too-large cone
    (r2 = 0.5 R) is a WARNING with the core's message; object scale 2; cone by length; bad input creates
    nothing."""
    import math

    import numpy as np

    cs, cone, rotors = _core("tooling.cutter_selection"), _core("tooling.cone"), _core("geometry.rotors")
    double_flank = _core("methods.double_flank.planner")
    ret, err = _run_op(bpy.ops.flank.generate_rotor, kind="asymmetric", part="female", resolution=360, axial=24)
    rotor_obj = bpy.context.active_object
    r = rotors.builtin_by_name("asymmetric-female")
    t0 = time.perf_counter()
    dup = cs.flank_dupin(r.surface(), r.flanks, 1)
    bounds = double_flank.custom_tool_bounds(r.surface(), r.flanks, 0)
    region = cs.admissible_region(dup, bounds)
    core_seconds = time.perf_counter() - t0
    core_points = region.points()
    out = dict(rotor=rotor_obj.name, core_seconds=core_seconds, core_mask_sum=int(region.mask.sum()),
               core_cone_sum=int(region.cone.sum()), core_a_min=float(dup.a_min),
               core_hyperbolic_fraction=float(dup.hyperbolic_fraction), core_bounds=bounds.as_dict(),
               core_ranges=region.ranges())

    def core_check(alpha, r1, r2):
        adm = cs.is_admissible(cone.ConeTool(alpha, r1, r2), dup, bounds)
        return dict(core_ok=bool(adm.ok), core_message=adm.message)

    def decode(objs, props, s=1.0):
        """Cloud vertices back to (alpha, r1c, r2c) in rotor units through the documented chart mapping."""
        co = _mesh_co(np, objs["cloud"]).astype(np.float64) / np.array(props["flank_cr_chart_scale"])
        co[:, 1:] /= s
        return co

    def same_points(p, q):
        if len(p) != len(q):
            return False
        p, q = p[np.lexsort(p.T[::-1])], q[np.lexsort(q.T[::-1])]
        return float(np.abs(p - q).max())

    # flank and cone from the Single Flank settings (no operator arguments)
    st = bpy.context.scene.flank_settings
    st.sf_flank, st.sf_r1, st.sf_r2, st.sf_alpha = 1, 0.02, 0.04, 0.1
    h, objs = _cr_run(bpy, np, rotor_obj)
    h.update(core_check(0.1, 0.02, 0.04))
    if objs is not None:
        h["decoded_max_diff"] = same_points(decode(objs, h["props"])[objs["flags"] > 0.5], core_points)
        h["marker_centre"] = [float(v) for v in _mesh_co(np, objs["marker"]).mean(axis=0)]
        h["cloud_location"] = [float(v) for v in objs["cloud"].matrix_world.translation]
    res["panels"] = _draw_panels(bpy, bpy.context.active_object)
    out["small"] = h

    # too large (r2 = 0.5 R), run with the marker of the last run active (the rotor found through flank_cr_rotor)
    marker = bpy.data.objects.get("Cutter Region (flank 1) Tool")
    h, objs = _cr_run(bpy, np, rotor_obj, active=marker, flank=1, r1=0.1, r2=0.5, alpha=0.3)
    h.update(core_check(0.3, 0.1, 0.5))
    out["large"] = h

    # object scale 2: radii in scene units are twice the rotor's
    rotor_obj.scale = (2.0, 2.0, 2.0)
    bpy.context.view_layer.update()
    h, objs = _cr_run(bpy, np, rotor_obj, flank=1, r1=0.04, r2=0.08, alpha=0.1)
    h.update(core_check(0.1, 0.02, 0.04))
    if objs is not None:
        h["decoded_max_diff"] = same_points(decode(objs, h["props"], 2.0)[objs["flags"] > 0.5], core_points)
    out["scaled"] = h
    rotor_obj.scale = (1.0, 1.0, 1.0)
    bpy.context.view_layer.update()

    # cone given by length in the Single Flank settings: alpha = atan((r2 - r1) / h)
    st.sf_shape, st.sf_length, st.sf_flank = "length", 0.2, 2
    h, objs = _cr_run(bpy, np, rotor_obj)
    h.update(core_check(math.atan2(0.02, 0.2), 0.02, 0.04))
    h["expected_alpha"] = math.atan2(0.02, 0.2)
    out["by_length"] = h
    st.sf_shape, st.sf_flank = "alpha", 1

    for name, kw in (("bad_radii", dict(flank=1, r1=0.08, r2=0.05)), ("bad_flank", dict(flank=99)),
                     ("bad_alpha", dict(flank=1, alpha=2.0)), ("bad_grid", dict(flank=1, grid=(1, 40, 40)))):
        before = {k_: v for k_, v in _obj_props(rotor_obj).items() if k_.startswith("flank_cr_")}
        h, _ = _cr_run(bpy, np, rotor_obj, **kw)
        h["rotor_props_unchanged"] = before == {k_: v for k_, v in _obj_props(rotor_obj).items()
                                                if k_.startswith("flank_cr_")}
        out[name] = h

    # undo / redo (pushed around the run as the UI does for bl_options UNDO; see scenario_single_flank)
    def state():
        return dict(objects=sorted(o.name for o in bpy.data.objects),
                    collections=sorted(c.name for c in bpy.data.collections), meshes=len(bpy.data.meshes))

    undo = dict(bl_options=sorted(bpy.types.FLANK_OT_cutter_region.bl_options))
    bpy.context.view_layer.objects.active = rotor_obj
    bpy.ops.ed.undo_push(message="before cutter region")
    undo["before"] = state()
    h, _ = _cr_run(bpy, np, rotor_obj, flank=3)
    bpy.ops.ed.undo_push(message="Check Tool")
    undo.update(result=h["result"], error=h["error"], after_run=state())
    try:
        bpy.ops.ed.undo()
        undo["after_undo"] = state()
        bpy.ops.ed.redo()
        undo["after_redo"] = state()
        cloud = bpy.data.objects.get("Cutter Region (flank 3)")
        undo["redo_attrs"] = sorted(a.name for a in cloud.data.attributes if not a.name.startswith(".")) \
            if cloud is not None else None
    except Exception as ex:
        undo["error"] = "{}: {}".format(type(ex).__name__, ex)
    out["undo"] = undo
    res["cutter_region"] = out


SCENARIOS = {"lifecycle": scenario_lifecycle, "operators": scenario_operators, "verify": scenario_verify,
             "paraboloid": scenario_paraboloid, "formed_cutter": scenario_formed_cutter,
             "double_flank": scenario_double_flank, "single_flank": scenario_single_flank,
             "cutter_region": scenario_cutter_region}


def plugin_scenarios():
    """Scenarios in their own files: tests/blender/scenario_<name>.py defining ``scenario(bpy, res, args)``
    (they may ``import driver`` for the helpers here).  name -> path."""
    import glob

    here = os.path.dirname(os.path.abspath(__file__))
    return {os.path.basename(p)[len("scenario_"):-3]: p
            for p in sorted(glob.glob(os.path.join(here, "scenario_*.py")))}


def _load_plugin(path):
    import importlib.util

    spec = importlib.util.spec_from_file_location(os.path.basename(path)[:-3], path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.scenario


def main():
    plugins = plugin_scenarios()
    ap = argparse.ArgumentParser()
    ap.add_argument("--zip", required=True)
    ap.add_argument("--scenario", required=True, choices=sorted(set(SCENARIOS) | set(plugins)))
    ap.add_argument("--out", required=True)
    ap.add_argument("--resolution", type=int, default=360)
    ap.add_argument("--preinstalled", action="store_true",
                    help="the user directory already holds the installed zip: enable it instead of installing")
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
        res["install"] = enable_installed(bpy) if args.preinstalled else install_extension(bpy, args.zip)
        args.ext_dir = res["install"]["extensions_dir"]
        run = SCENARIOS.get(args.scenario) or _load_plugin(plugins[args.scenario])
        run(bpy, res, args)
        res["ok"] = True
    except Exception:
        res["exception"] = traceback.format_exc()
    res["seconds"] = time.perf_counter() - t0
    with open(args.out, "w", encoding="utf-8") as fh:
        json.dump(res, fh, indent=1, default=str)
    return 0


if __name__ == "__main__":
    sys.exit(main())
