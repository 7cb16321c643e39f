# SPDX-License-Identifier: GPL-3.0-or-later
"""The sidebar against the installed zip: every panel drawn into a *real* UILayout (a popup menu's
layout, opened headless under a VIEW_3D / UI region override and never shown; a proxy records what each draw
asks for), the tool presets (shipped files in mm, user presets through AddPresetBase) in several scene units,
the flank list against the core's Dupin analysis, flank picking by 3D cursor and by selected faces against
multi_strip.flank_of_point, the tool preview, the Run button's calls (single flank with a cone and with a
cylinder, double flank with cones), the strips list rows and their selection, the legend colours against
verify.deviation_colors.  For test_blender_sidebar.py."""
import ast
import glob
import importlib
import os
import time
import traceback
import types

import driver


# ------------------------------------------------------------------------------------------- real layouts
def _plain(v):
    if isinstance(v, (bool, int, float, str)) or v is None:
        return v
    try:
        return [float(x) for x in v]
    except (TypeError, ValueError):
        return repr(v)


class _Op:
    """Operator properties of a button: forwards and records every property the draw code sets."""

    def __init__(self, real, log, idname):
        object.__setattr__(self, "_real", real)
        object.__setattr__(self, "_log", log)
        object.__setattr__(self, "_idname", idname)

    def __setattr__(self, key, value):
        setattr(self._real, key, value)           # AttributeError for a property the operator does not have
        self._log.append(["opset", self._idname, key, _plain(value)])

    def __getattr__(self, key):
        return getattr(self._real, key)


class _Rec:
    """A real bpy.types.UILayout that records the calls made on it (and on its sub-layouts)."""

    def __init__(self, real, log):
        object.__setattr__(self, "_real", real)
        object.__setattr__(self, "_log", log)

    def __setattr__(self, key, value):
        setattr(self._real, key, value)
        self._log.append(["set", key, _plain(value)])

    def __getattr__(self, name):
        import bpy

        attr = getattr(self._real, name)
        if not callable(attr):
            return attr

        def call(*a, **kw):
            out = attr(*a, **kw)
            if name == "label":
                self._log.append(["label", kw.get("text", a[0] if a else ""), kw.get("icon", "NONE")])
            elif name in ("prop", "prop_enum"):
                self._log.append([name, a[1]] + ([a[2]] if len(a) > 2 else []))
            elif name in ("operator", "menu"):
                self._log.append([name, a[0], kw.get("text")])
            elif name == "template_list":
                data, prop = a[2], a[3]
                self._log.append(["template_list", a[0], getattr(data, "name", ""), prop, len(getattr(data, prop))])
            else:
                self._log.append([name])
            if isinstance(out, bpy.types.UILayout):
                return _Rec(out, self._log)
            if name == "operator":
                if out is None:
                    raise AttributeError("unknown operator {!r}".format(a[0]))
                return _Op(out, self._log, a[0])
            return out
        return call


class _UI:
    def __init__(self, bpy):
        self.bpy = bpy
        screen = bpy.context.screen
        self.area = next(a for a in screen.areas if a.type == 'VIEW_3D')
        self.region = next(r for r in self.area.regions if r.type == 'UI')

    def layout(self, title="test"):
        """A fresh real layout (a popup menu that is never shown)."""
        return self.bpy.context.window_manager.popmenu_begin__internal(title, icon='NONE').layout

    def draw(self, cls):
        """(poll, [calls]) of a panel drawn into a real layout, or an error string."""
        bpy = self.bpy
        log = []
        try:
            with bpy.context.temp_override(area=self.area, region=self.region):
                poll = getattr(cls, "poll", None)
                polled = bool(poll(bpy.context)) if poll is not None else True
                cls.draw(types.SimpleNamespace(layout=_Rec(self.layout(cls.bl_label), log)), bpy.context)
        except Exception:
            return traceback.format_exc()
        return dict(poll=polled, calls=log)

    def draw_all(self, panels):
        return {cls.__name__: self.draw(cls) for cls in panels.classes}

    def draw_menu(self, cls):
        """The calls of a menu's draw into a real layout (its path_menu included)."""
        bpy = self.bpy
        log = []
        fake = types.SimpleNamespace(bl_idname=cls.bl_idname, preset_operator=getattr(cls, "preset_operator", ""),
                                     preset_subdir=getattr(cls, "preset_subdir", ""))
        try:
            with bpy.context.temp_override(area=self.area, region=self.region):
                fake.layout = _Rec(self.layout(cls.bl_label), log)
                fake.path_menu = lambda *a, **kw: bpy.types.Menu.path_menu(fake, *a, **kw)
                cls.draw(fake, bpy.context)
        except Exception:
            return traceback.format_exc()
        return log


def _datablocks(bpy):
    return dict(objects=len(bpy.data.objects), meshes=len(bpy.data.meshes), collections=len(bpy.data.collections))


def _orphan_meshes(bpy):
    return sorted(m.name for m in bpy.data.meshes if m.users == 0)


def _set_units(bpy, system, scale):
    us = bpy.context.scene.unit_settings
    us.system = system
    us.scale_length = scale


UNITS = (("mm", 'METRIC', 0.001), ("cm", 'METRIC', 0.01), ("m", 'METRIC', 1.0), ("inch", 'IMPERIAL', 0.0254),
         ("none", 'NONE', 1.0))
TOOL_KEYS = ("tool_kind", "sf_shape", "sf_r1", "sf_r2", "sf_alpha", "sf_length", "sf_shank_radius", "sf_shank_length")


def _tool(s):
    return {k: _plain(getattr(s, k)) for k in TOOL_KEYS}


def _preset_values(path):
    out = {}
    with open(path, encoding="utf-8") as fh:
        for line in fh:
            line = line.strip()
            if line.startswith("settings.") and "=" in line:
                key, value = (t.strip() for t in line[len("settings."):].split("=", 1))
                out[key] = ast.literal_eval(value)
    return out


def _select_only(bpy, obj):
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    if obj is not None:
        obj.select_set(True)
    bpy.context.view_layer.objects.active = obj


# ------------------------------------------------------------------------------------------- scenario
def scenario(bpy, res, args):
    import numpy as np
    from mathutils import Matrix

    t_start = time.perf_counter()
    mod = driver.MODULE
    ui_ops = importlib.import_module(mod + ".operators.ui_ops")
    presets = importlib.import_module(mod + ".operators.tool_preview")
    strips = importlib.import_module(mod + ".operators.strips")
    sources = importlib.import_module(mod + ".operators.sources")
    props = importlib.import_module(mod + ".operators.properties")
    panels = importlib.import_module(mod + ".panels")
    ms, rotors, verify, cs, screw, mesh_io = (driver._core(m) for m in (
        "methods.single_flank.planner", "geometry.rotors", "simulation.verify", "tooling.cutter_selection", "geometry.screw", "io.mesh_files"))
    run_op = driver._run_op
    scene = bpy.context.scene
    s = scene.flank_settings
    tmp = os.path.abspath(os.getcwd())
    ui = _UI(bpy)
    res["timing"] = {}

    # ---------------------------------------------------------------- registration, importers, empty scene
    res["panel_classes"] = [dict(name=c.__name__, label=c.bl_label, parent=getattr(c, "bl_parent_id", ""),
                                 order=getattr(c, "bl_order", 0), options=sorted(getattr(c, "bl_options", ())),
                                 category=c.bl_category, space=c.bl_space_type, region=c.bl_region_type)
                            for c in panels.classes]
    importers = {}
    for idname in ("wm.stl_import", "wm.obj_import", "wm.ply_import"):
        cat, name = idname.split(".")
        try:
            getattr(getattr(bpy.ops, cat), name).get_rna_type()
            importers[idname] = True
        except (KeyError, AttributeError):
            importers[idname] = False
    res["importers"] = importers
    res["draw_empty"] = ui.draw_all(panels)

    # ---------------------------------------------------------------- presets: shipped files in every unit
    t0 = time.perf_counter()
    shipped = sorted(glob.glob(os.path.join(presets.SHIPPED_PRESETS, "*.py")))
    pres = {}
    for path in shipped:
        name = os.path.basename(path)
        entry = dict(file=_preset_values(path), units={})
        for tag, system, scale in UNITS:
            _set_units(bpy, system, scale)
            ret, err = run_op(bpy.ops.script.execute_preset, filepath=path, menu_idname="FLANK_MT_tool_presets")
            entry["units"][tag] = dict(result=ret, error=err, tool=_tool(s), strategy=s.strategy,
                                       menu_label=bpy.types.FLANK_MT_tool_presets.bl_label,
                                       mm=dict(tip=s.tool_tip_diameter_mm, taper=s.tool_taper_deg,
                                               flute=s.tool_flute_length_mm, shank_d=s.tool_shank_diameter_mm,
                                               shank_l=s.tool_shank_length_mm))
        pres[name] = entry
    res["presets"] = pres
    res["preset_dir"] = presets.SHIPPED_PRESETS
    _set_units(bpy, 'METRIC', 0.001)
    res["preset_menu"] = ui.draw_menu(bpy.types.FLANK_MT_tool_presets)
    # a user preset (AddPresetBase): saved in mm, loaded into a cm scene gives the same tool
    run_op(bpy.ops.script.execute_preset, filepath=os.path.join(presets.SHIPPED_PRESETS, "Tapered 2deg D3 L25.py"),
           menu_idname="FLANK_MT_tool_presets")
    s.tool_shank_length_mm = 41.5
    user = {}
    user["add"] = run_op(bpy.ops.flank.tool_preset_add, name="Shop Tool 7")
    user_dir = bpy.utils.user_resource('SCRIPTS', path=os.path.join("presets", presets.PRESET_SUBDIR))
    files = sorted(glob.glob(os.path.join(user_dir, "*.py")))
    user["files"] = [os.path.basename(f) for f in files]
    user["text"] = open(files[0], encoding="utf-8").read() if files else ""
    user["menu_lists_it"] = any(c[0] == "operator" and c[2] == "Shop Tool 7" for c in ui.draw_menu(
        bpy.types.FLANK_MT_tool_presets) if isinstance(c, list))
    user["before"] = _tool(s)
    s.tool_kind = "CYLINDER"
    s.sf_r1 = 0.123
    _set_units(bpy, 'METRIC', 0.01)
    user["apply"] = run_op(bpy.ops.script.execute_preset, filepath=files[0] if files else "",
                           menu_idname="FLANK_MT_tool_presets")
    user["after_cm"] = _tool(s)
    user["after_cm_mm"] = [s.tool_tip_diameter_mm, s.tool_taper_deg, s.tool_flute_length_mm,
                           s.tool_shank_diameter_mm, s.tool_shank_length_mm]
    # values a millimetre field cannot take leave the tool as it was (NaN passes Blender's clamp to min)
    kept = _tool(s)
    for field, bad in (("tool_tip_diameter_mm", float("nan")), ("tool_tip_diameter_mm", -1.0),
                       ("tool_taper_deg", float("nan")), ("tool_flute_length_mm", -5.0),
                       ("tool_shank_diameter_mm", float("inf")), ("tool_shank_length_mm", float("nan"))):
        setattr(s, field, bad)
    user["bad_mm_kept"] = _tool(s) == kept
    user["remove"] = run_op(bpy.ops.flank.tool_preset_add, remove_active=True)
    user["refused"] = [run_op(bpy.ops.flank.tool_preset_add, name=""), run_op(bpy.ops.flank.tool_preset_add, name=".."),
                       run_op(bpy.ops.flank.tool_preset_add, name="No Such Tool", remove_name=True),
                       run_op(bpy.ops.flank.tool_preset_add, remove_active=True)]
    user["files_after_remove"] = sorted(os.path.basename(f) for f in glob.glob(os.path.join(user_dir, "*.py")))
    res["user_preset"] = user
    # the operator form (scripts): same numbers, bad input refused
    _set_units(bpy, 'METRIC', 0.001)
    res["tool_preset_op"] = dict(result=run_op(bpy.ops.flank.tool_preset, taper_deg=3.0, tip_diameter_mm=6.0,
                                               flute_length_mm=30.0, shank_diameter_mm=10.0,
                                               overall_length_mm=80.0), tool=_tool(s),
                                 bad=run_op(bpy.ops.flank.tool_preset, taper_deg=60.0))
    res["timing"]["presets"] = time.perf_counter() - t0

    # ---------------------------------------------------------------- rotor, flank list (mm scene, R = 50 mm)
    t0 = time.perf_counter()
    _set_units(bpy, 'METRIC', 0.001)
    run_op(bpy.ops.flank.generate_rotor, kind="asymmetric", part="female", scale=50.0, resolution=360, axial=24)
    rotor = bpy.context.active_object
    ax = np.array([0.2, 0.4, 0.9]) / np.linalg.norm([0.2, 0.4, 0.9])
    K = np.array([[0, -ax[2], ax[1]], [ax[2], 0, -ax[0]], [-ax[1], ax[0], 0]])
    M = np.eye(4)
    M[:3, :3] = np.eye(3) + np.sin(0.7) * K + (1 - np.cos(0.7)) * K @ K
    M[:3, 3] = (120.0, -40.0, 15.0)
    rotor.matrix_world = Matrix(M.tolist())
    bpy.context.view_layer.update()
    res["draw_rotor_unlisted"] = ui.draw(bpy.types.FLANK_PT_workpiece)
    core_rotor = rotors.builtin_rotor("asymmetric", "female", scale=50.0)
    surface, flanks = core_rotor.surface(), list(core_rotor.flanks)
    ret = run_op(bpy.ops.flank.refresh_flanks)
    core_rows = []
    for k in range(len(flanks)):
        d = cs.flank_dupin(surface, flanks, k, n=200)
        core_rows.append([k, k // 2, float(d.hyperbolic_fraction), float(d.a_min) if np.isfinite(d.a_min) else 0.0])
    res["flank_list"] = dict(result=ret, rotor=s.flank_list_rotor, index=s.flank_index,
                             rows=[[i.flank, i.valley, i.hyperbolic_fraction, i.a_min, i.u_start, i.u_end]
                                   for i in s.flank_list],
                             core=core_rows, core_ranges=[list(map(float, f)) for f in flanks])
    res["draw_rotor_listed"] = ui.draw(bpy.types.FLANK_PT_workpiece)
    # a row of the list aims both planners
    s.flank_index = 5
    res["list_pick"] = dict(sf_flank=s.sf_flank, df_valley=s.df_valley, use_point=s.sf_use_point)
    res["timing"]["flank_list"] = time.perf_counter() - t0

    # ---------------------------------------------------------------- pick by 3D cursor (vs core flank_of_point)
    t0 = time.perf_counter()
    Minv = np.linalg.inv(M)
    picks = []
    rng = np.random.default_rng(7)
    for k in (0, 3, 4, 7, 10, 11):
        a, b = flanks[k]
        u = a + (0.25 + 0.5 * rng.random()) * (b - a)
        xy = surface.profile.eval(np.array([u]))[0]
        nrm = surface.profile.outward_normal(np.array([u]))[0]
        off = float(rng.choice([-1.0, 1.0])) * 0.5              # 0.5 mm off the surface, either side
        t = float(rng.uniform(-1.0, 1.0))
        p_rot = screw.screw_motion(np.array([[xy[0] + off * nrm[0], xy[1] + off * nrm[1], 0.0]]), t, surface.v0,
                                   surface.hand)[0]
        world = M[:3, :3] @ p_rot + M[:3, 3]
        scene.cursor.location = tuple(world)
        s.flank_index = (k + 6) % len(flanks)                   # something else first
        _select_only(bpy, rotor)
        ret = run_op(bpy.ops.flank.pick_flank_cursor)
        cur = np.array(scene.cursor.location, dtype=np.float64)  # single precision, as the operator read it
        p_back = Minv[:3, :3] @ cur + Minv[:3, 3]
        picks.append(dict(intended=k, result=ret, sf_flank=s.sf_flank, flank_index=s.flank_index,
                          df_valley=s.df_valley, core=int(ms.flank_of_point(surface, flanks, p_back))))
    # from a result object of the rotor (its tool is active): the same rotor is used
    res["cursor_picks"] = picks
    scene.cursor.location = (5000.0, 0.0, 0.0)
    res["far_cursor"] = dict(result=run_op(bpy.ops.flank.pick_flank_cursor), sf_flank=s.sf_flank)
    scene.cursor.location = (0.0, 0.0, 0.0)
    bpy.ops.object.empty_add(location=(0.0, 0.0, 0.0))
    empty = bpy.context.active_object
    before = _datablocks(bpy)
    res["cursor_no_rotor"] = dict(result=run_op(bpy.ops.flank.pick_flank_cursor))
    res["cursor_no_rotor"]["new"] = {k: _datablocks(bpy)[k] - before[k] for k in before}
    bpy.data.objects.remove(empty)

    # ---------------------------------------------------------------- pick by selected faces (Edit Mode)
    _select_only(bpy, rotor)
    mesh = rotor.data
    n_poly = len(mesh.polygons)
    centres = np.empty(n_poly * 3)
    mesh.polygons.foreach_get("center", centres)
    centres = centres.reshape(-1, 3)                          # local = rotor frame (generated rotor)
    q0 = screw.screw_to_plane(centres, surface.v0, surface.hand)
    us = surface.profile.params(4096)
    pts = surface.profile.eval(us)
    near = np.array([us[np.argmin(np.linalg.norm(pts - q[:2], axis=1))] for q in q0[:, :2]])

    def faces_inside(k, count):
        a, b = flanks[k]
        inside = np.flatnonzero((near > a + 0.2 * (b - a)) & (near < b - 0.2 * (b - a)))
        inside = inside[np.linspace(0, len(inside) - 1, min(count, len(inside))).astype(int)]
        return [int(i) for i in inside]

    face_picks = []
    for label, parts in (("flank 2", ((2, 12),)), ("flank 9", ((9, 8),)), ("mixed 6+1", ((6, 10), (1, 4)))):
        sel = []
        for k, count in parts:
            sel += faces_inside(k, count)
        core = [int(ms.flank_of_point(surface, flanks, centres[i])) for i in sel]
        mask = np.zeros(n_poly, dtype=bool)
        mask[sel] = True
        bpy.ops.object.mode_set(mode='OBJECT')
        mesh.polygons.foreach_set("select", mask)
        scene.tool_settings.mesh_select_mode = (False, False, True)
        bpy.ops.object.mode_set(mode='EDIT')
        s.flank_index = 0
        ret = run_op(bpy.ops.flank.pick_flank_faces)
        face_picks.append(dict(label=label, selected=len(sel), core=core, result=ret, sf_flank=s.sf_flank,
                               mode=rotor.mode))
    bpy.ops.mesh.select_all(action='DESELECT')
    res["face_none"] = dict(result=run_op(bpy.ops.flank.pick_flank_faces))
    bpy.ops.object.mode_set(mode='OBJECT')
    res["face_object_mode"] = dict(result=run_op(bpy.ops.flank.pick_flank_faces))
    res["face_picks"] = face_picks
    res["timing"]["picks"] = time.perf_counter() - t0

    # ---------------------------------------------------------------- an imported STL: import, analyze, pick
    t0 = time.perf_counter()
    nil = rotors.builtin_rotor("nilson", "male", scale=40.0)
    verts, faces = nil.mesh(n_profile=720, n_axial=48)
    stl = os.path.join(tmp, "nilson_male.stl")
    mesh_io.write_stl(stl, verts, faces)
    n_before = len(bpy.data.objects)
    imp = dict(result=run_op(bpy.ops.wm.stl_import, filepath=stl))
    imported = bpy.context.active_object
    imp["new_objects"] = len(bpy.data.objects) - n_before
    imported.location = (0.0, 150.0, 0.0)
    bpy.context.view_layer.update()
    imp["analyze"] = run_op(bpy.ops.flank.analyze_rotor)
    imp["source"] = imported.get("flank_source")
    imp["refresh"] = run_op(bpy.ops.flank.refresh_flanks)
    imp["listed"] = [s.flank_list_rotor == imported.name, len(s.flank_list)]
    # the core on the same mesh (what sources.rotor_source does for analysed meshes)
    ra, feet_mod, prof_mod, hs = (driver._core(m) for m in (
        "geometry.rotor_analysis", "geometry.flank_feet", "geometry.profile", "geometry.helical_surface"))
    mw = np.array(imported.matrix_world)
    co = np.empty(len(imported.data.vertices) * 3)
    imported.data.vertices.foreach_get("co", co)
    wv = co.reshape(-1, 3) @ mw[:3, :3].T + mw[:3, 3]
    imported.data.calc_loop_triangles()
    tri = np.empty(len(imported.data.loop_triangles) * 3, dtype=np.int32)
    imported.data.loop_triangles.foreach_get("vertices", tri)
    an = ra.analyze_mesh(wv, tri.reshape(-1, 3))
    sp = prof_mod.SplineProfile(an.profile)
    a_surf = hs.HelicalSurface(sp, an.v0, an.handedness)
    a_flanks = feet_mod.flank_u_ranges(sp, [(int(i), int(j)) for i, j in an.flanks])
    Tw = np.asarray(an.to_world, dtype=np.float64)
    a_picks = []
    for vi in (0, 37, 211, 503, 1000, 1777):
        scene.cursor.location = tuple(wv[vi])
        _select_only(bpy, imported)
        ret = run_op(bpy.ops.flank.pick_flank_cursor)
        cur = np.array(scene.cursor.location, dtype=np.float64)
        p = np.linalg.solve(Tw, np.r_[cur, 1.0])
        a_picks.append(dict(vertex=vi, result=ret, sf_flank=s.sf_flank,
                            core=int(ms.flank_of_point(a_surf, a_flanks, p[:3] / p[3]))))
    imp["picks"] = a_picks
    imp["hyperbolic"] = [[i.hyperbolic_fraction for i in s.flank_list],
                         [float(cs.flank_dupin(a_surf, a_flanks, k, n=200).hyperbolic_fraction)
                          for k in range(len(a_flanks))]]
    res["imported"] = imp
    imported_mesh = imported.data
    bpy.data.objects.remove(imported)
    bpy.data.meshes.remove(imported_mesh)
    res["timing"]["import_analyze"] = time.perf_counter() - t0

    # ---------------------------------------------------------------- tool kinds and the preview
    t0 = time.perf_counter()
    _select_only(bpy, rotor)
    run_op(bpy.ops.script.execute_preset, filepath=os.path.join(presets.SHIPPED_PRESETS, "Tapered 3deg D6 L30.py"),
           menu_idname="FLANK_MT_tool_presets")
    s.groove_a, s.groove_b = -0.05, 7.2
    previews = {}
    rb = np.array([rotor.matrix_world @ __import__("mathutils").Vector(c) for c in rotor.bound_box])
    for kind in ("CONE", "CYLINDER", "PARABOLOID", "CONE", "CUSTOM", "DISC"):
        s.tool_kind = kind
        if kind == "CYLINDER":
            run_op(bpy.ops.script.execute_preset, filepath=os.path.join(presets.SHIPPED_PRESETS,
                                                                         "Cylindrical D6 L13.py"),
                   menu_idname="FLANK_MT_tool_presets")
        elif kind == "CONE":
            run_op(bpy.ops.script.execute_preset, filepath=os.path.join(presets.SHIPPED_PRESETS,
                                                                         "Tapered 3deg D6 L30.py"),
                   menu_idname="FLANK_MT_tool_presets")
        before = _datablocks(bpy)
        ret = run_op(bpy.ops.flank.preview_tool)
        obs = [o for o in bpy.data.objects if o.get(presets.PREVIEW_PROP)]
        entry = dict(result=ret, strategy=s.strategy, previews=len(obs), orphans=_orphan_meshes(bpy),
                     new={k: _datablocks(bpy)[k] - before[k] for k in before},
                     active=bpy.context.view_layer.objects.active.name, draw=ui.draw(bpy.types.FLANK_PT_tool))
        if obs:
            ob = obs[0]
            v = np.empty(len(ob.data.vertices) * 3)
            ob.data.vertices.foreach_get("co", v)
            v = v.reshape(-1, 3)
            r = np.linalg.norm(v[:, :2], axis=1)
            entry.update(name=ob.name, mesh=ob.data.name, kind=ob[presets.PREVIEW_PROP], radius_max=float(r.max()),
                         z=[float(v[:, 2].min()), float(v[:, 2].max())],
                         radius_at_tip=float(r[np.abs(v[:, 2] - v[:, 2].min()) < 1e-6].max()),
                         location=list(ob.matrix_world.translation), rotor_box=[rb.min(axis=0).tolist(),
                                                                               rb.max(axis=0).tolist()],
                         vertices=len(ob.data.vertices))
        previews["{}#{}".format(kind, len(previews))] = entry
    res["previews"] = previews
    res["timing"]["previews"] = time.perf_counter() - t0

    # ---------------------------------------------------------------- Run: single flank, cone preset (mm scene)
    t0 = time.perf_counter()
    _select_only(bpy, rotor)
    s.tool_kind = "CONE"
    run_op(bpy.ops.script.execute_preset, filepath=os.path.join(presets.SHIPPED_PRESETS, "Tapered 3deg D6 L30.py"),
           menu_idname="FLANK_MT_tool_presets")
    s.flank_index = 1
    s.sf_tolerance, s.sf_seeds, s.sf_rounds, s.sf_envelope_rings, s.sf_animate = 0.05, 6, 2, 12, False
    runs = {}
    idname, kw = ui_ops.run_call(s)
    res["run_panel_single"] = ui.draw(bpy.types.FLANK_PT_run)
    try:
        ret = (sorted(getattr(bpy.ops.flank, idname.split(".")[1])('INVOKE_DEFAULT', **kw)), None)
    except RuntimeError as ex:
        ret = (None, str(ex))
    export = importlib.import_module(mod + ".operators.runs")
    coll = export.find_run(bpy.context)
    runs["single"] = dict(idname=idname, kw={k: _plain(v) for k, v in kw.items()}, result=ret,
                          coll=getattr(coll, "name", coll), seconds=time.perf_counter() - t0)
    res["timing"]["run_single"] = time.perf_counter() - t0

    def run_facts(coll, pre, key):
        import json

        plan = json.loads(coll[driver_plan_prop])
        info = strips.strip_rows(coll)
        tools = sorted(((int(o[pre + key]), i, o.name) for i, o in enumerate(coll.objects)
                        if o.get(pre + "role") == "tool"))
        facts = dict(props={k[len(pre):]: _plain(coll[k]) for k in coll.keys() if k.startswith(pre)
                            and k[len(pre):] in ("tool_r1", "tool_r2", "tool_alpha", "tool_h", "tool_shank_radius",
                                                 "tool_shank_length", "flank", "valley", "tolerance", "length_scale",
                                                 "tool", "two_paths", "paths", "strips", "length_unit")},
                     rows={str(k): v for k, v in (info or {}).get("rows", {}).items()},
                     uncovered=(info or {}).get("uncovered"),
                     plan_errors=[[st["reported_max_error"], st["reported_min_error"], st["collision"]]
                                  for st in plan["strips"]], tools=[t[2] for t in tools],
                     residual=sum(1 for o in coll.objects if o.get(pre + "role") == "residual"))
        sel = {}
        for k, i, name in tools:
            s.results_strip_index = i
            sel[str(k)] = dict(selected=sorted(o.name for o in bpy.context.selected_objects),
                               active=bpy.context.view_layer.objects.active.name,
                               expected=sorted(o.name for o in coll.objects if o.get(pre + key) == k
                                               and o.get(pre + "role") in ("tool", "envelope")))
        facts["selection"] = sel
        ul = bpy.types.FLANK_UL_strips
        flags, order = ul.filter_items(ul, bpy.context, coll, "objects")
        facts["list_rows"] = sum(1 for f in flags if f)
        # draw_item of every tool row into a real layout
        items = []
        for k, i, name in tools:
            log = []
            with bpy.context.temp_override(area=ui.area, region=ui.region):
                ul.draw_item(ul, bpy.context, _Rec(ui.layout(), log), coll, coll.objects[i], 0, s,
                             "results_strip_index", i)
            items.append(log)
        facts["draw_items"] = items
        return plan, facts

    driver_plan_prop = importlib.import_module(mod + ".operators.runs").PLAN_JSON_PROP
    if not isinstance(coll, str):
        plan, facts = run_facts(coll, "flank_sf_", "strip")
        # exact ownership from the verify engine, as a share of the flank's profile arc length
        ver = verify.verify_plan(plan, tolerance=float(plan["overcut_tolerance"]))
        prof = np.asarray(plan["rotor"]["profile"], float)
        n = len(prof)
        ia, ib = plan["rotor"]["flanks"][int(coll["flank_sf_flank"])]
        arc = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(prof[np.arange(ia, ib + 1) % n], axis=0), axis=1))]

        def share(i):
            j = i - ia if i >= ia else i + n - ia            # position of profile index i along the flank
            return float(arc[min(max(j, 0), len(arc) - 1)] / arc[-1])
        facts["verify_covered"] = [[[share(a), share(b)] for a, b in st["covered_ranges"]] for st in ver["strips"]]
        # the panel with this run: list, legend, buttons; draw_item calls made by Blender itself
        calls = []
        orig = bpy.types.FLANK_UL_strips.draw_item

        def counting(self, *a, **kw):
            calls.append(1)
            return orig(self, *a, **kw)
        bpy.types.FLANK_UL_strips.draw_item = counting
        try:
            facts["panel"] = ui.draw(bpy.types.FLANK_PT_results)
        finally:
            bpy.types.FLANK_UL_strips.draw_item = orig
        facts["draw_item_calls_by_blender"] = len(calls)
        runs["single"].update(facts)
    sf_coll = coll

    # ---------------------------------------------------------------- Run: single flank, cylinder preset
    t0 = time.perf_counter()
    _select_only(bpy, rotor)
    run_op(bpy.ops.script.execute_preset, filepath=os.path.join(presets.SHIPPED_PRESETS, "Cylindrical D6 L13.py"),
           menu_idname="FLANK_MT_tool_presets")
    s.flank_index = 2
    s.sf_seeds, s.sf_rounds = 4, 1               # the run is checked for the tool it used, not for its cover
    idname, kw = ui_ops.run_call(s)
    try:
        ret = (sorted(bpy.ops.flank.plan_single_flank('INVOKE_DEFAULT', **kw)), None)
    except RuntimeError as ex:
        ret = (None, str(ex))
    coll = export.find_run(bpy.context)
    runs["cylinder"] = dict(idname=idname, kw={k: _plain(v) for k, v in kw.items()}, result=ret,
                            coll=getattr(coll, "name", coll), tool=_tool(s))
    if not isinstance(coll, str):
        runs["cylinder"].update(run_facts(coll, "flank_sf_", "strip")[1])
    res["timing"]["run_cylinder"] = time.perf_counter() - t0

    # ---------------------------------------------------------------- Run: double flank with 3 cones
    t0 = time.perf_counter()
    _select_only(bpy, rotor)
    s.strategy = "DOUBLE"
    res["after_double"] = dict(tool_kind=s.tool_kind)
    s.df_tool, s.df_cones = "cones", 3
    s.flank_index = 3                                        # valley 1
    s.df_radii, s.df_samples, s.df_envelope_rings, s.df_animate, s.df_simulate = 40, 30, 12, False, False
    res["run_panel_double"] = ui.draw(bpy.types.FLANK_PT_run)
    idname, kw = ui_ops.run_call(s)
    try:
        ret = (sorted(bpy.ops.flank.plan_double_flank('INVOKE_DEFAULT', **kw)), None)
    except RuntimeError as ex:
        ret = (None, str(ex))
    coll = export.find_run(bpy.context)
    runs["double"] = dict(idname=idname, kw={k: _plain(v) for k, v in kw.items()}, result=ret,
                          coll=getattr(coll, "name", coll))
    if not isinstance(coll, str):
        runs["double"].update(run_facts(coll, "flank_df_", "path")[1])
        runs["double"]["panel"] = ui.draw(bpy.types.FLANK_PT_results)
    s.strategy = "TWO_PATHS"
    runs["two_paths_call"] = {k: _plain(v) for k, v in ui_ops.run_call(s)[1].items() if k in ("two_paths", "tool")}
    s.strategy = "DOUBLE"
    runs["double_call"] = {k: _plain(v) for k, v in ui_ops.run_call(s)[1].items() if k in ("two_paths", "tool")}
    res["timing"]["run_double"] = time.perf_counter() - t0
    # CUSTOM preview copies the newest double-flank tool now
    s.tool_kind = "CUSTOM"
    before = _datablocks(bpy)
    runs["custom_preview"] = dict(result=run_op(bpy.ops.flank.preview_tool), orphans=_orphan_meshes(bpy),
                                  previews=sum(1 for o in bpy.data.objects if o.get(presets.PREVIEW_PROP)),
                                  new={k: _datablocks(bpy)[k] - before[k] for k in before})
    prev = next((o for o in bpy.data.objects if o.get(presets.PREVIEW_PROP)), None)
    src_tool = [o for o in bpy.data.objects if o.get("flank_df_role") == "tool" and o.get("flank_df_path") == 0]
    runs["custom_preview"]["vertices"] = [len(prev.data.vertices) if prev else 0,
                                          len(src_tool[-1].data.vertices) if src_tool else -1]
    # Run with the formed disc cutter (the Hu, Zhou & Li 2025 Table-1 rotor) and the paraboloid groove, then the DISC preview
    t0 = time.perf_counter()
    for strategy, extra in (("FORMED", dict(cutter_source="TABLE1", cutter_planes=40, cutter_sample_points=16,
                                            cutter_resolution=240, cutter_animate=False)),
                            ("GROOVE", dict(groove_turns=0.5, groove_resolution=101))):
        s.strategy = strategy
        for key, value in extra.items():
            setattr(s, key, value)
        idname, kw = ui_ops.run_call(s)
        before = _datablocks(bpy)
        try:
            ret = (sorted(getattr(bpy.ops.flank, idname.split(".")[1])('INVOKE_DEFAULT', **kw)), None)
        except RuntimeError as ex:
            ret = (None, str(ex))
        runs[strategy.lower()] = dict(idname=idname, result=ret, tool_kind=s.tool_kind,
                                      new={k: _datablocks(bpy)[k] - before[k] for k in before})
    s.strategy = "FORMED"
    runs["disc_preview"] = dict(result=run_op(bpy.ops.flank.preview_tool), orphans=_orphan_meshes(bpy),
                                previews=sum(1 for o in bpy.data.objects if o.get(presets.PREVIEW_PROP)),
                                kind=next((o[presets.PREVIEW_PROP] for o in bpy.data.objects
                                           if o.get(presets.PREVIEW_PROP)), None),
                                draw=ui.draw(bpy.types.FLANK_PT_tool))
    s.strategy = "DOUBLE"
    res["timing"]["run_formed_groove"] = time.perf_counter() - t0
    # switching the shown run
    runs["select_run"] = dict(result=run_op(bpy.ops.flank.select_run, collection=sf_coll.name),
                              shown=getattr(export.find_run(bpy.context), "name", None), want=sf_coll.name)
    runs["select_run_bad"] = dict(result=run_op(bpy.ops.flank.select_run, collection="No Such Run"))
    runs["runs_menu"] = ui.draw_menu(bpy.types.FLANK_MT_runs)
    res["runs"] = runs

    # ---------------------------------------------------------------- legend: colours and the scale's unit
    res["legend"] = {k: dict(prop=list(getattr(s, "legend_" + k)),
                             core=[float(c) for c in verify.deviation_colors([t], 1.0)[0][:3]],
                             core_tol=[float(c) for c in verify.deviation_colors([t * 0.05], 0.05)[0][:3]],
                             band=list(verify.DEVIATION_COLORS.get(k, (0, 0, 0, 0))[:3]))
                     for k, t in props.LEGEND_STEPS}
    s.legend_ok = (1.0, 0.0, 1.0)                             # the swatches cannot be edited away from the core
    res["legend_after_write"] = list(s.legend_ok)
    _select_only(bpy, bpy.data.objects[runs["single"]["tools"][0]] if runs["single"].get("tools") else rotor)
    legend_units = {}
    for tag, system, scale in UNITS:
        _set_units(bpy, system, scale)
        d = ui.draw(bpy.types.FLANK_PT_results)
        legend_units[tag] = [c[1] for c in d["calls"] if c[0] == "label"] if isinstance(d, dict) else d
    res["legend_units"] = legend_units
    _set_units(bpy, 'METRIC', 0.001)

    # ---------------------------------------------------------------- every panel, every strategy, real layouts
    _select_only(bpy, rotor)
    by_strategy = {}
    for strategy in ("SINGLE", "DOUBLE", "TWO_PATHS", "FORMED", "GROOVE", "FREEFORM"):
        s.strategy = strategy
        by_strategy[strategy] = dict(tool_kind=s.tool_kind, call=ui_ops.run_call(s)[0], panels=ui.draw_all(panels))
    res["by_strategy"] = by_strategy
    # in edit mode and with a result object active, too
    bpy.ops.object.mode_set(mode='EDIT')
    res["draw_edit_mode"] = ui.draw_all(panels)
    bpy.ops.object.mode_set(mode='OBJECT')
    _select_only(bpy, bpy.data.objects.get(runs["double"].get("tools", [rotor.name])[0]))
    res["draw_result_active"] = ui.draw_all(panels)
    res["draw_result_active_rotor"] = sources.workpiece_object(bpy.context).name
    # the recording stub of driver.py (used by the other scenarios) accepts every panel of its list too
    res["driver_stub"] = driver._draw_panels(bpy, rotor)
    res["timing"]["total"] = time.perf_counter() - t_start
