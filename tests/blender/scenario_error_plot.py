# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.error_plot through the installed extension: failure paths first (no run, unknown run, broken stored
plan, missing PNG folder: an error and no image), then a small single-flank run (asymmetric female flank 1)
plotted at two sizes and in two scene units; the image is compared with the core rasteriser on the stored
plan (equal outside the text, which Blender's font draws into the boxes of the core's text items), its curve
pixels with verify's colours at the rows the errors map to, the PNG with the image, and the packed image
survives save + reload.  For test_blender_error_plot.py.

The operator is registered here when the add-on does not register it (yet)."""
import importlib
import json
import os
import time

import driver

TOOL = dict(shape="alpha", alpha=driver.SF_ASIN, r1=0.05, r2=0.08, shank_radius=0.04, shank_length=0.6,
            tolerance=1e-3)


def _images(bpy):
    return sorted(i.name for i in bpy.data.images)


def _attempt(bpy, tmp, **kw):
    """A call that must fail: result, message, images added, files added."""
    i0, f0 = _images(bpy), set(os.listdir(tmp))
    ret, err = driver._run_op(bpy.ops.flank.error_plot, **kw)
    return dict(result=ret, error=err, new_images=sorted(set(_images(bpy)) - set(i0)),
                new_files=sorted(set(os.listdir(tmp)) - f0))


def _pixels(np, img):
    w, h = img.size
    px = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    return px.reshape(h, w, 4)[::-1]                 # top row first, as the core draws


def _check_image(bpy, np, img, coll, plan, pp, units, tol_plan, w, h):
    """The image vs the core's plot of the stored plan, and its curve pixels vs verify's colours."""
    out = dict(name=img.name, size=list(img.size), packed=img.packed_file is not None,
               fake_user=bool(img.use_fake_user), props={k: (list(v) if hasattr(v, "__len__") and
                                                             not isinstance(v, str) else v)
                                                          for k, v in img.items() if k.startswith("flank_plot_")})
    got = _pixels(np, img)
    ref, info = pp.plan_error_plot(plan, units=units, width=w, height=h, tolerance=tol_plan,
                                   title="Error along profile: {}".format(coll.name))
    out["core_info"] = {k: v for k, v in info.items() if k not in ("layout", "texts")}
    out["core_layout"] = info["layout"]
    out["text"] = _text_check(np, got, ref, info["texts"])

    # every finite profile point: the curve colour (verify.deviation_colors at its error) within 1 px of the
    # row its error maps to, found from the image's own stored axes
    data = pp.error_profile(plan, tolerance=tol_plan)
    verify = driver._core("simulation.verify")
    x0, y0, x1, y1 = img["flank_plot_box"]
    xa, xb = img["flank_plot_x_range"]
    ya, yb = img["flank_plot_y_range"]
    f = img["flank_plot_y_factor"] * units[0]
    tol_shown = data["tolerance"] * units[0]
    dev = data["deviation"] * units[0]
    fin = np.isfinite(dev)
    expect = pp.srgb(verify.deviation_colors(dev[fin], tol_shown))
    cols = np.rint(x0 + (data["x"][fin] - xa) / (xb - xa) * (x1 - x0)).astype(int)
    rows = np.rint(y0 + (yb - dev[fin] * img["flank_plot_y_factor"]) / (yb - ya) * (y1 - y0)).astype(int)
    best = []
    for c, r, e in zip(cols, rows, expect):
        win = got[max(r - 1, 0):r + 2, c, :3]
        best.append(float(np.abs(win - e[:3]).max(axis=1).min()))
    best = np.array(best)
    out["curve_check"] = dict(points=int(fin.sum()), within_2_255=int((best <= 2.0 / 255).sum()),
                              within_8_255=int((best <= 8.0 / 255).sum()), worst=float(best.max()))
    band = {k: pp.srgb(np.array(verify.DEVIATION_COLORS[k]))[:3] for k in ("ok", "stock", "gouge")}
    flat = got[..., :3].reshape(-1, 3)
    out["band_pixels"] = {k: int((np.abs(flat - v).max(axis=1) < 0.5 / 255).sum()) for k, v in band.items()}
    out["extremes"] = [float(np.nanmin(dev)) * img["flank_plot_y_factor"], float(np.nanmax(dev)) *
                       img["flank_plot_y_factor"]]
    out["f"] = f
    return out


def _text_check(np, got, ref, texts):
    """The image against the core's picture: equal outside the boxes of the core's text items (where Blender's
    font draws them), and every item drawn (dark ink in its box, its box near its anchor)."""
    ct = importlib.import_module(driver.MODULE + ".operators.chart_text")
    if got.shape != ref.shape:
        return dict(shape=[list(got.shape), list(ref.shape)])
    changed = np.abs(got - ref).max(axis=-1) > 0.5 / 255
    inside = np.zeros(changed.shape, dtype=bool)
    items = []
    for t in texts:
        box = ct.text_box(ct.place(t), got.shape)
        if box is None:
            items.append(dict(text=t["text"], box=None))
            continue
        x0, y0, x1, y1 = box
        inside[y0:y1, x0:x1] = True
        luma = got[y0:y1, x0:x1, :3].mean(axis=-1)
        left = {"left": t["x"], "center": t["x"] - 0.5 * (x1 - x0), "right": t["x"] - (x1 - x0)}[t["align"]]
        items.append(dict(text=t["text"], role=t["role"], box=[x0, y0, x1, y1], changed=int(changed[y0:y1, x0:x1].sum()),
                          darkest=float(luma.min()), left_offset=float(x0 - left),
                          cap_top_offset=float(y0 - t["top"]), baseline_offset=float(y1 - t["baseline"])))
    return dict(outside_max_diff=float(np.abs(got - ref)[~inside].max()), changed_outside=int((changed & ~inside).sum()),
                changed_inside=int((changed & inside).sum()), items=items, count=len(texts))


def scenario(bpy, res, args):
    import numpy as np

    mod = importlib.import_module(driver.MODULE + ".operators.profile_plot")
    res["registered_by_addon"] = hasattr(bpy.types, "FLANK_OT_error_plot")
    if not res["registered_by_addon"]:
        bpy.utils.register_class(mod.FLANK_OT_error_plot)
    pp = driver._core("report.error_chart")
    rr = driver._core("report.report_geometry")
    png_io = driver._core("io.png")
    tmp = os.path.abspath(os.getcwd())
    scene = bpy.context.scene

    # ---------------------------------------------------------------- nothing planned yet
    res["no_run"] = _attempt(bpy, tmp)

    # ---------------------------------------------------------------- a small single-flank run
    driver._run_op(bpy.ops.flank.generate_rotor, kind="asymmetric", part="female", resolution=180, axial=16)
    t0 = time.perf_counter()
    ret, err = driver._run_op(bpy.ops.flank.plan_single_flank, flank=1, seeds=6, rounds=2, envelope_rings=8,
                              animate=False, **TOOL)
    res["plan"] = dict(result=ret, error=err, seconds=time.perf_counter() - t0)
    if ret is None:
        return
    coll = bpy.context.active_object.users_collection[0]
    run_name = coll.name
    plan = json.loads(coll["flank_plan_json"])
    tol_plan = mod.run_tolerance(coll, plan)
    res["run"] = dict(name=coll.name, strips=len(plan["strips"]), tolerance_plan=tol_plan,
                      plan_tolerance_field=plan.get("tolerance"), length_unit=plan["length_unit"])

    # ---------------------------------------------------------------- failures with a run present
    fails = {}
    fails["unknown_run"] = _attempt(bpy, tmp, collection="No Such Run")
    fails["missing_folder"] = _attempt(bpy, tmp, filepath=os.path.join(tmp, "no_dir", "plot.png"))
    os.makedirs(os.path.join(tmp, "plots"), exist_ok=True)
    fails["folder"] = _attempt(bpy, tmp, filepath=os.path.join(tmp, "plots"))   # not 'plots.png' beside it
    fails["folder"]["beside"] = os.path.exists(os.path.join(tmp, "plots.png"))
    fails["relative"] = _attempt(bpy, tmp, filepath="relative_plot.png")      # the .blend is not saved
    fails["relative"]["beside"] = os.path.exists("relative_plot.png")
    good = coll["flank_plan_json"]
    coll["flank_plan_json"] = "{broken"
    fails["broken_plan"] = _attempt(bpy, tmp, collection=coll.name)
    coll["flank_plan_json"] = good
    res["fails"] = fails

    # ---------------------------------------------------------------- plot: metres scene (mm / µm on the axis)
    us = scene.unit_settings
    res["unit_system"] = [us.system, float(us.scale_length)]
    n_img = len(bpy.data.images)
    t0 = time.perf_counter()
    png = os.path.join(tmp, "plot.png")
    ret, err = driver._run_op(bpy.ops.flank.error_plot, width=640, height=360, filepath=png)
    first = dict(result=ret, error=err, seconds=time.perf_counter() - t0, new_images=len(bpy.data.images) - n_img)
    res["first"] = first
    img = mod.plot_image(coll.name)
    first["found"] = img is not None
    if img is None:
        return
    units = rr.display_units(plan, us.system, us.scale_length)
    first.update(_check_image(bpy, np, img, coll, plan, pp, units, tol_plan, 640, 360))
    first["units"] = list(units)
    if os.path.exists(png):
        from_png = png_io.read_png(png).astype(np.float32) / 255.0
        first["png_shape"] = list(from_png.shape)
        first["png_vs_image"] = float(np.abs(from_png - _pixels(np, img)).max())

    # ---------------------------------------------------------------- again: millimetre scene, other size, no PNG
    us.scale_length = 0.001
    n_img = len(bpy.data.images)
    ret, err = driver._run_op(bpy.ops.flank.error_plot, width=800, height=450, per_strip=True)
    second = dict(result=ret, error=err, new_images=len(bpy.data.images) - n_img)
    img2 = mod.plot_image(coll.name)
    second["same_image"] = img2 is not None and img2 == img
    if img2 is not None:
        units = rr.display_units(plan, us.system, us.scale_length)
        second.update(_check_image(bpy, np, img2, coll, plan, pp, units, tol_plan, 800, 450))
        second["units"] = list(units)
    res["second"] = second

    # combined curve: one curve
    ret, err = driver._run_op(bpy.ops.flank.error_plot, width=800, height=450, per_strip=False)
    res["combined"] = dict(result=ret, error=err, curves=img2.get("flank_plot_curves") if img2 else None)
    driver._run_op(bpy.ops.flank.error_plot, width=800, height=450, per_strip=True)

    # ---------------------------------------------------------------- save + reload keeps the packed pixels
    before = _pixels(np, img2).copy()
    blend = os.path.join(tmp, "plot.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    bpy.ops.wm.open_mainfile(filepath=blend)
    img3 = mod.plot_image(run_name)
    reload = dict(found=img3 is not None)
    if img3 is not None:
        after = _pixels(np, img3)
        reload.update(size=list(img3.size), packed=img3.packed_file is not None,
                      max_diff=float(np.abs(after - before).max()) if after.shape == before.shape else None,
                      run=img3.get("flank_plot_run"))
    res["reload"] = reload
    # after the reload the operator still works and replaces the same image
    n_img = len(bpy.data.images)
    ret, err = driver._run_op(bpy.ops.flank.error_plot, width=640, height=360)
    res["after_reload"] = dict(result=ret, error=err, new_images=len(bpy.data.images) - n_img,
                               size=list(mod.plot_image(run_name).size))
    res["plans_kept"] = driver.plans_kept(bpy)     # after every operator that read a run's plan
