#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""End-to-end demo through the real extension (run by ``make demo``).

1. build the host-platform zip with tools/build_extension.py (cached wheels),
2. install + enable it with Blender's own installer into a throw-away user
   directory (BLENDER_USER_* set before ``import bpy``),
3. ``bpy.ops.flank.generate_rotor`` (built-in asymmetric female rotor, R = 50 in a
   scene measured in millimetres), ``bpy.ops.flank.analyze_rotor`` on it,
4. write ``out/demo.blend``, ``out/demo.png`` (headless Workbench render coloured
   by the ``curvature_class`` attribute; Cycles CPU fallback/option),
5. ``bpy.ops.flank.plan_single_flank`` on flank 1 (cone alpha = asin 0.1, r1 = 0.05 R,
   r2 = 0.08 R, tolerance 1e-3 R), export CL data and the plan
   (``out/demo.apt``, ``out/demo_plan.json``) and ``bpy.ops.flank.render_report``
   -> ``out/report.png`` (rotor, strips by signed error, legend, title),
6. write ``out/report.json`` and print a summary.

    python tools/demo.py [--out out] [--engine workbench|cycles] [--resolution 1440] [--zip ZIP | --source]
"""
import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXT_ID = "flank_toolpath"
REPO = "user_default"
MODULE = "bl_ext.{}.{}".format(REPO, EXT_ID)


def log(msg):
    print("[demo] " + msg, flush=True)


def build_zip(out_dir):
    summary = out_dir / "build.json"
    cmd = [sys.executable, str(ROOT / "tools" / "build_extension.py"), "--platforms", "host",
           "--output-dir", str(ROOT / "dist"), "--json", str(summary)]
    proc = subprocess.run(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if proc.returncode != 0:
        sys.exit("[demo] building the extension failed:\n" + proc.stdout)
    info = json.loads(summary.read_text())
    summary.unlink()
    return Path(info["zips"][0]["path"])


def isolate_blender_user_dir():
    """Must run before ``import bpy``: keep the developer's Blender config untouched."""
    user = Path(tempfile.mkdtemp(prefix="flank-demo-blender-"))
    for var, sub in (("BLENDER_USER_RESOURCES", ""), ("BLENDER_USER_CONFIG", "config"),
                     ("BLENDER_USER_SCRIPTS", "scripts"), ("BLENDER_USER_DATAFILES", "datafiles"),
                     ("BLENDER_USER_EXTENSIONS", "extensions")):
        os.environ[var] = str(user / sub) if sub else str(user)
    return user


def enable_extension(bpy, zip_path):
    if zip_path is None:  # --source: register the repo package directly (no bundled wheels)
        import importlib

        parent = Path(tempfile.mkdtemp(prefix="flank-demo-src-"))
        (parent / EXT_ID).symlink_to(ROOT, target_is_directory=True)
        sys.path.insert(0, str(parent))
        pkg = importlib.import_module(EXT_ID)
        pkg.register()
        return "source tree {}".format(ROOT)
    bpy.ops.extensions.package_install_files(filepath=str(zip_path), repo=REPO, enable_on_install=True,
                                             overwrite=True)
    if MODULE not in bpy.context.preferences.addons:
        sys.exit("[demo] the extension did not enable after installing {}".format(zip_path))
    return str(zip_path)


def setup_scene(bpy, obj, engine, width, height):
    from mathutils import Vector

    scene = bpy.context.scene
    # bounding box of the rotor in world space
    corners = [obj.matrix_world @ Vector(c) for c in obj.bound_box]
    lo = Vector([min(c[i] for c in corners) for i in range(3)])
    hi = Vector([max(c[i] for c in corners) for i in range(3)])
    centre = (lo + hi) / 2
    size = max((hi - lo).length, 1e-6)

    cam_data = bpy.data.cameras.new("DemoCamera")
    cam_data.lens = 50
    cam = bpy.data.objects.new("DemoCamera", cam_data)
    scene.collection.objects.link(cam)
    view_dir = Vector((1.0, -1.15, 0.55)).normalized()
    cam.location = centre + view_dir * size * 1.7
    # camera X along the rotor axis -> the rotor lies horizontally in the 16:9 frame
    cam.rotation_euler = (centre - cam.location).to_track_quat('-Z', 'X').to_euler()
    scene.camera = cam

    sun_data = bpy.data.lights.new("DemoSun", type='SUN')
    sun_data.energy = 3.0
    sun = bpy.data.objects.new("DemoSun", sun_data)
    sun.rotation_euler = (math.radians(40), math.radians(10), math.radians(35))
    scene.collection.objects.link(sun)

    # material showing the curvature_class colour attribute (used by Cycles and Workbench 'MATERIAL')
    mat = bpy.data.materials.new("CurvatureClass")
    if mat.node_tree is None:
        mat.use_nodes = True
    nodes = mat.node_tree.nodes
    bsdf = next(n for n in nodes if n.type == 'BSDF_PRINCIPLED')
    attr = nodes.new("ShaderNodeAttribute")
    attr.attribute_name = "curvature_class"
    mat.node_tree.links.new(attr.outputs["Color"], bsdf.inputs["Base Color"])
    bsdf.inputs["Roughness"].default_value = 0.45
    obj.data.materials.clear()
    obj.data.materials.append(mat)

    render = scene.render
    render.resolution_x, render.resolution_y, render.resolution_percentage = width, height, 100
    render.image_settings.file_format = 'PNG'
    render.film_transparent = False
    world = scene.world or bpy.data.worlds.new("DemoWorld")
    scene.world = world
    world.color = (0.06, 0.06, 0.07)
    if engine == "workbench":
        render.engine = 'BLENDER_WORKBENCH'
        shading = scene.display.shading
        shading.light = 'STUDIO'
        shading.color_type = 'VERTEX'  # "Attribute": the active colour attribute = curvature_class
        shading.show_cavity = True
        shading.show_object_outline = False
    else:
        render.engine = 'CYCLES'
        scene.cycles.device = 'CPU'
        scene.cycles.samples = 24
        scene.cycles.use_denoising = False
        if world.node_tree is None:
            world.use_nodes = True
        bg = world.node_tree.nodes.get("Background")
        if bg is not None:
            bg.inputs["Color"].default_value = (0.05, 0.05, 0.06, 1.0)
            bg.inputs["Strength"].default_value = 1.0


def render_png(bpy, path, engine):
    scene = bpy.context.scene
    scene.render.filepath = str(path)
    t0 = time.perf_counter()
    try:
        bpy.ops.render.render(write_still=True)
    except Exception as ex:
        if engine != "workbench":
            raise
        log("Workbench render failed ({}); falling back to Cycles CPU".format(ex))
        return None, time.perf_counter() - t0
    return engine, time.perf_counter() - t0


def report_picture_info(path):
    """The title, numbers and legend layout that flank.render_report stored in the PNG (iTXt 'flank-report')."""
    import struct

    data = Path(path).read_bytes()
    pos = 8
    while pos + 8 <= len(data):
        n, tag = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if tag == b"iTXt" and body.startswith(b"flank-report\x00"):
            return json.loads(body.split(b"\x00", 5)[5].decode("utf-8"))
        pos += 12 + n
    sys.exit("[demo] {} carries no report metadata".format(path))


def main(argv=None):
    ap = argparse.ArgumentParser(description="Flank Toolpath end-to-end demo")
    ap.add_argument("--out", default=str(ROOT / "out"))
    ap.add_argument("--engine", choices=("workbench", "cycles"), default="workbench")
    ap.add_argument("--resolution", type=int, default=1440, help="profile samples of the rotor mesh")
    ap.add_argument("--size", default="960x540")
    src = ap.add_mutually_exclusive_group()
    src.add_argument("--zip", help="install this extension zip instead of building one")
    src.add_argument("--source", action="store_true", help="register the source tree instead of installing a zip")
    args = ap.parse_args(argv)
    width, height = (int(v) for v in args.size.lower().split("x"))

    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    timings = {}
    t_all = time.perf_counter()

    zip_path = None
    if not args.source:
        t0 = time.perf_counter()
        zip_path = Path(args.zip).resolve() if args.zip else build_zip(out)
        timings["build_zip_s"] = time.perf_counter() - t0

    user_dir = isolate_blender_user_dir()
    try:
        t0 = time.perf_counter()
        import bpy
        import numpy as np

        timings["import_bpy_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        bpy.ops.wm.read_factory_settings(use_empty=True)
        units = bpy.context.scene.unit_settings              # 1 Blender unit = 1 mm: the rotor is R = 50 mm
        units.system, units.scale_length, units.length_unit = 'METRIC', 0.001, 'MILLIMETERS'
        installed_from = enable_extension(bpy, zip_path)
        timings["install_s"] = time.perf_counter() - t0

        params = dict(kind="asymmetric", part="female", resolution=args.resolution, scale=50.0)   # R = 50 mm
        t0 = time.perf_counter()
        ret = bpy.ops.flank.generate_rotor(**params)
        timings["generate_s"] = time.perf_counter() - t0
        if ret != {'FINISHED'}:
            sys.exit("[demo] generate_rotor returned {}".format(ret))
        obj = bpy.context.active_object
        generated = {k: (obj[k].to_list() if hasattr(obj[k], "to_list") else obj[k])
                     for k in obj.keys() if k.startswith("flank_")}

        t0 = time.perf_counter()
        try:
            ret = bpy.ops.flank.analyze_rotor()
        except RuntimeError as ex:
            sys.exit("[demo] analyze_rotor failed: {}".format(ex))
        timings["analyze_s"] = time.perf_counter() - t0
        analysis = json.loads(obj["flank_analysis"])

        mesh = obj.data
        K = np.empty(len(mesh.vertices), dtype=np.float32)
        mesh.attributes["gaussian_curvature"].data.foreach_get("value", K)
        cols = np.empty(len(mesh.vertices) * 4, dtype=np.float32)
        mesh.color_attributes["curvature_class"].data.foreach_get("color", cols)
        palette = np.array([(0.90, 0.25, 0.15), (0.85, 0.85, 0.80), (0.15, 0.40, 0.90)])
        names = ("elliptic", "parabolic", "hyperbolic")
        nearest = np.argmin(((cols.reshape(-1, 4)[:, None, :3] - palette[None]) ** 2).sum(-1), axis=1)
        class_counts = {n: int(np.count_nonzero(nearest == i)) for i, n in enumerate(names)}

        setup_scene(bpy, obj, args.engine, width, height)
        t0 = time.perf_counter()
        bpy.ops.wm.save_as_mainfile(filepath=str(out / "demo.blend"), check_existing=False)
        timings["save_blend_s"] = time.perf_counter() - t0

        png = out / "demo.png"
        engine_used, timings["render_s"] = render_png(bpy, png, args.engine)
        if engine_used is None:
            setup_scene(bpy, obj, "cycles", width, height)
            engine_used, dt = render_png(bpy, png, "cycles")
            timings["render_s"] += dt

        # the core job: single-flank strips on flank 1 (Bizzarri, Bo & Bartoň tool of the benchmark), CL data, report picture
        sc = float(generated.get("flank_scale", 1.0))
        bpy.context.view_layer.objects.active = obj
        t0 = time.perf_counter()
        try:
            bpy.ops.flank.plan_single_flank(flank=1, shape="alpha", alpha=0.1001674, r1=0.05 * sc, r2=0.08 * sc,
                                            shank_radius=0.04 * sc, shank_length=0.6 * sc, tolerance=1e-3 * sc,
                                            animate=False)
        except RuntimeError as ex:
            sys.exit("[demo] plan_single_flank failed: {}".format(ex))
        timings["plan_single_flank_s"] = time.perf_counter() - t0
        plan_info = {k[len("flank_sf_"):]: obj[k] for k in ("flank_sf_strips", "flank_sf_candidates",
                                                          "flank_sf_max_error", "flank_sf_min_error",
                                                          "flank_sf_kink_max_deg", "flank_sf_complete")}
        t0 = time.perf_counter()
        bpy.ops.flank.export_results(format='CL', filepath=str(out / "demo.apt"))
        bpy.ops.flank.export_results(format='PLAN', filepath=str(out / "demo_plan.json"))
        timings["export_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        try:
            bpy.ops.flank.render_report(filepath=str(out / "report.png"), width=1280, height=800)
        except RuntimeError as ex:
            sys.exit("[demo] render_report failed: {}".format(ex))
        timings["report_s"] = time.perf_counter() - t0
        picture = report_picture_info(out / "report.png")
        timings["total_s"] = time.perf_counter() - t_all

        import scipy

        v0_gen, v0_ana = generated["flank_v0"], obj["flank_v0"]
        report = dict(
            rotor=dict(params, scale=generated.get("flank_scale"), lead=generated.get("flank_lead"),
                       length=generated.get("flank_length"), lobes=generated.get("flank_lobes"),
                       v0=v0_gen, handedness=generated.get("flank_handedness"),
                       vertices=len(mesh.vertices), triangles=len(mesh.polygons)),
            analysis=dict(axis_point=list(obj["flank_axis_point"]), axis_direction=list(obj["flank_axis"]),
                          v0=v0_ana, v0_relative_error=abs(v0_ana - v0_gen) / v0_gen,
                          handedness=obj["flank_handedness"], residual=obj["flank_residual"],
                          threshold=obj["flank_threshold"], flank_count=obj["flank_flank_count"],
                          outer_radius=obj["flank_outer_radius"], details=analysis),
            curvature=dict(gaussian_min=float(K.min()), gaussian_max=float(K.max()), classes=class_counts),
            outputs=dict(blend=str(out / "demo.blend"), png=str(png), render_engine=engine_used,
                         size=[width, height]),
            single_flank=plan_info,
            report_picture=picture,
            timings={k: round(v, 3) for k, v in timings.items()},
            versions=dict(blender=bpy.app.version_string, python=sys.version.split()[0], numpy=np.__version__,
                          scipy=scipy.__version__, scipy_from=os.path.dirname(scipy.__file__)),
            extension=dict(installed_from=installed_from),
        )
        (out / "report.json").write_text(json.dumps(report, indent=2, default=str), encoding="utf-8")
    finally:
        shutil.rmtree(user_dir, ignore_errors=True)

    a = report["analysis"]
    print()
    print("Flank Toolpath demo -- built-in asymmetric female rotor")
    print("  rotor      : {lobes} lobes, {vertices} vertices, v0 = {v0:.6f}, {handedness}-handed".format(
        **report["rotor"]))
    print("  analysis   : axis {} through {}".format(
        ", ".join("{:+.4f}".format(x) for x in a["axis_direction"]),
        ", ".join("{:+.4f}".format(x) for x in a["axis_point"])))
    print("               v0 = {:.6f} (rel. error {:.1e}), {}-handed, residual {:.3g} < {:.3g}, {} flanks".format(
        a["v0"], a["v0_relative_error"], a["handedness"], a["residual"], a["threshold"], a["flank_count"]))
    print("  curvature  : {}".format(report["curvature"]["classes"]))
    print("  timings    : " + ", ".join("{} {:.2f}s".format(k[:-2], v) for k, v in report["timings"].items()))
    sf = report["single_flank"]
    print("  flank 1    : {} strips of {} candidates, error {:.3g} .. {:.3g}, largest kink {:.3g} deg, {}".format(
        sf["strips"], sf["candidates"], sf["min_error"], sf["max_error"], sf["kink_max_deg"],
        "covered" if sf["complete"] else "NOT fully covered"))
    print("  report.png : {} ({} x {})".format(report["report_picture"]["title"][1],
                                               report["report_picture"]["width"], report["report_picture"]["height"]))
    print("  outputs    : {}/demo.blend, demo.png ({}), report.json, report.png, demo.apt, demo_plan.json".format(
        out, engine_used))
    return 0


if __name__ == "__main__":
    sys.exit(main())
