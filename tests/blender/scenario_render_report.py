# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.render_report through the installed extension (for test_blender_render_report.py): a single-flank run
of the asymmetric female (flank 1, cone alpha = asin 0.1, r1 = 0.05, r2 = 0.08, tolerance 1e-3), rendered
in three unit settings and with Cycles; the PNG's size, legend bar and title numbers, and a full census of
bpy.data before / after every call (nothing may be left behind, nothing removed)."""
import json
import os
import time

import driver

# every ID collection of bpy.data that a render could touch (window managers, screens and workspaces are UI)
SKIP = {"window_managers", "screens", "workspaces", "batch_remove", "bl_rna", "rna_type"}


def census(bpy):
    out = {}
    for key in dir(bpy.data):
        if key.startswith("_") or key in SKIP:
            continue
        coll = getattr(bpy.data, key, None)
        if isinstance(coll, bpy.types.bpy_prop_collection):
            try:
                out[key] = sorted(block.name for block in coll)
            except (TypeError, AttributeError):
                pass
    return out


def diff(before, after):
    return {k: dict(new=sorted(set(after.get(k, [])) - set(v)), gone=sorted(set(v) - set(after.get(k, []))))
            for k, v in before.items() if after.get(k, []) != v}


def png_facts(np, rr, path, bar_tol):
    """Size, exactness of the legend bar, pixels of the strip colour families outside the legend."""
    png_io = driver._core("io.png")
    px = png_io.read_png(path)
    meta = json.loads(png_io.read_png_text(path)[rr.REPORT_KEY])
    x0, y0, x1, y1 = meta["legend"]["bar"]
    bar = px[y0:y1, x0:x1, :3].astype(int)
    want = rr.bar_colors(x1 - x0, bar_tol).astype(int)
    flat = px[..., :3].reshape(-1, 3)
    band = {}
    for key, rgb in rr.legend_colors().items():
        band[key] = int((flat == rgb).all(axis=1).sum())
    # strips in the picture: greenish pixels (the 'within tolerance' family, lit) above the legend
    top = px[:meta["legend"]["bar"][1] - 10, :, :3].astype(int)
    green = int(((top[..., 1] > top[..., 0] + 30) & (top[..., 1] > top[..., 2] + 20)).sum())
    return dict(shape=list(px.shape), bar_max_diff=int(np.abs(bar - want[None]).max()), band_pixels=band,
                strip_green_pixels=green, meta=meta)


def scenario(bpy, res, args):
    import numpy as np

    rr = driver._core("report.report_geometry")
    run_op = driver._run_op
    tmp = os.path.abspath(os.getcwd())
    scene = bpy.context.scene
    us = scene.unit_settings

    # ---------------------------------------------------------------- nothing planned yet
    c0 = census(bpy)
    p = os.path.join(tmp, "none.png")
    ret, err = run_op(bpy.ops.flank.render_report, filepath=p)
    res["no_run"] = dict(result=ret, error=err, file=os.path.exists(p), changed=diff(c0, census(bpy)))

    # ---------------------------------------------------------------- a single-flank run
    run_op(bpy.ops.flank.generate_rotor, kind="asymmetric", part="female", resolution=360, axial=24)
    t0 = time.perf_counter()
    ret, err = run_op(bpy.ops.flank.plan_single_flank, flank=1, shape="alpha", alpha=0.1001674, r1=0.05, r2=0.08,
                      shank_radius=0.04, shank_length=0.6, tolerance=1e-3, seeds=6, rounds=1, envelope_rings=8,
                      animate=False)
    res["plan"] = dict(result=ret, error=err, seconds=time.perf_counter() - t0)
    coll = next(c for c in bpy.data.collections["Flank Results"].children if "flank_plan_json" in c)
    plan = json.loads(coll["flank_plan_json"])
    res["run"] = dict(name=coll.name, strips=len(plan["strips"]), summary=plan["summary"],
                      tolerance=plan["tolerance"], length_unit=plan["length_unit"], method=plan["method"])

    # ---------------------------------------------------------------- three unit settings, Workbench
    renders = {}
    for label, system, scale in (("metric_m", 'METRIC', 1.0), ("metric_mm", 'METRIC', 0.001), ("none", 'NONE', 1.0)):
        us.system, us.scale_length = system, scale
        scene_name, active = bpy.context.scene.name, bpy.context.view_layer.objects.active
        c0 = census(bpy)
        p = os.path.join(tmp, "report_{}.png".format(label))
        t0 = time.perf_counter()
        ret, err = run_op(bpy.ops.flank.render_report, filepath=p, width=640, height=400)
        out = dict(result=ret, error=err, seconds=time.perf_counter() - t0, changed=diff(c0, census(bpy)),
                   same_scene=bpy.context.scene.name == scene_name,
                   same_active=bpy.context.view_layer.objects.active == active)
        if os.path.exists(p):
            out.update(png_facts(np, rr, p, plan["tolerance"]))
        renders[label] = out
    res["renders"] = renders

    # ---------------------------------------------------------------- tiles against the picture in one piece
    # Workbench renders the picture in tiles, each with the camera narrowed and shifted onto its pixels; rendered
    # whole by the same scene, the pixels must be the same but for rounding (shading within a level or two, and
    # now and then a pixel whose centre lies on a silhouette edge within rounding, which flips)
    import importlib

    rs = importlib.import_module(driver.MODULE + ".operators.report_scene")
    geo = rr.report_geometry(plan)
    tiled = {}
    for width, height, limit in ((1281, 799, 100000), (401, 803, 40000), (1280, 800, rr.TILE_PIXELS),
                                 (800, 1280, rr.TILE_PIXELS)):
        picture = rr.report_picture(geo, width, height)
        c0 = census(bpy)
        state = rs.report_scene_start(picture, os.path.join(tmp, "tiles.png"))
        try:
            whole = rs.tga_pixels(rs.report_scene_render(state), width, height)
            tiles = rr.render_tiles(width, height, limit)
            pieces = [(t, rs.report_scene_render(state, t)) for t in tiles]
        finally:
            rs.report_scene_end(state)
        d = np.abs(rs.tiled_pixels(pieces, width, height).astype(int) - whole.astype(int)).max(axis=-1)
        tiled["{}x{}".format(width, height)] = dict(
            tiles=len(tiles), sizes=sorted({(t[2] - t[0], t[3] - t[1]) for t in tiles}), differing=int((d > 0).sum()),
            over_2=int((d > 2).sum()), pixels=int(d.size), surface=int((whole[..., :3] < 200).any(axis=-1).sum()),
            changed=diff(c0, census(bpy)))
    res["tiled"] = tiled

    # ---------------------------------------------------------------- INVOKE_DEFAULT without a window: runs
    p = os.path.join(tmp, "report_invoke.png")
    try:
        ret, err = sorted(bpy.ops.flank.render_report('INVOKE_DEFAULT', filepath=p, width=200, height=120)), None
    except RuntimeError as ex:
        ret, err = None, str(ex)
    res["invoke"] = dict(result=ret, error=err, file=os.path.exists(p))

    # ---------------------------------------------------------------- Cycles on the CPU (small)
    us.system, us.scale_length = 'METRIC', 0.001
    c0 = census(bpy)
    p = os.path.join(tmp, "report_cycles.png")
    t0 = time.perf_counter()
    ret, err = run_op(bpy.ops.flank.render_report, filepath=p, width=320, height=200, engine='CYCLES')
    out = dict(result=ret, error=err, seconds=time.perf_counter() - t0, changed=diff(c0, census(bpy)))
    if os.path.exists(p):
        out.update(png_facts(np, rr, p, plan["tolerance"]))
        # the operator's Cycles render ran in a separate Blender; the same picture rendered in this one
        png_io = driver._core("io.png")
        here = os.path.join(tmp, "cycles_here.png")
        rs.render_plan_report(plan, here, 320, 200, title="{}: {}".format(coll.name, plan["method"]),
                              engine="CYCLES", units=rr.display_units(plan, us.system, us.scale_length))
        a, b = png_io.read_png(p).astype(int), png_io.read_png(here).astype(int)
        d = np.abs(a - b).max(axis=-1)
        out.update(here_differing=int((d > 0).sum()), here_max_diff=int(d.max()),
                   surface=int((a[..., :3] < 200).any(axis=-1).sum()))
        os.remove(here)
    res["cycles"] = out

    # ---------------------------------------------------------------- bad input: an error, no file, no data
    os.makedirs(os.path.join(tmp, "a_folder.png"), exist_ok=True)
    bad = {}
    for label, kw in (("missing_folder", dict(filepath=os.path.join(tmp, "no", "r.png"))),
                      ("folder", dict(filepath=os.path.join(tmp, "a_folder.png"))),
                      ("folder_no_png", dict(filepath=tmp)),        # not written as '<tmp>.png' beside it
                      ("relative", dict(filepath="relative_report.png")),      # the .blend is not saved
                      ("empty_path", dict(filepath="")),
                      ("no_such_run", dict(filepath=os.path.join(tmp, "x.png"), collection="No Such Run"))):
        c0 = census(bpy)
        ret, err = run_op(bpy.ops.flank.render_report, **kw)
        bad[label] = dict(result=ret, error=err, changed=diff(c0, census(bpy)))
    bad["files"] = sorted(f for f in os.listdir(tmp) if f.startswith(("x.", "r.")) or ".tmp" in f
                          or ".render" in f or ".probe" in f)
    bad["beside"] = os.path.exists(tmp.rstrip(os.sep) + ".png")
    res["bad"] = bad
