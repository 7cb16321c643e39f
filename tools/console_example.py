#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""A complete scripted example: generate a rotor, plan, export, verify the plan, render the report.

The body of :func:`console_example` is the README's console example: paste it into Blender's Python console
(with ``bpy`` imported and ``out`` set to a folder), or run this file headless:

    blender -b --python tools/console_example.py -- [--out DIR]          # extension installed in Blender
    python tools/console_example.py --zip dist/flank_toolpath-...zip [--out DIR]    # the bpy module

With the ``bpy`` module the zip is installed by Blender's own installer into a throw-away user
folder first.  Prints the numbers as JSON (also written to DIR/example.json).
"""
import argparse
import json
import os
import shutil
import sys
from pathlib import Path


def console_example(bpy, out):
    # --- README: console example -------------------------------------------------------------------
    units = bpy.context.scene.unit_settings                         # 1 Blender unit = 1 mm
    units.system, units.scale_length, units.length_unit = 'METRIC', 0.001, 'MILLIMETERS'
    bpy.ops.flank.generate_rotor(kind='asymmetric', part='female', scale=50.0, resolution=1440, axial=96)
    rotor = bpy.context.active_object                               # R = 50 mm
    bpy.ops.flank.analyze_rotor()                                   # axis, v0, handedness, flanks
    bpy.ops.flank.plan_single_flank(flank=1, shape='alpha', alpha=0.1001674, r1=2.5, r2=4.0,
                                    shank_radius=2.0, shank_length=30.0, tolerance=0.05)   # mm
    plan = os.path.join(out, "plan.json")
    bpy.ops.flank.export_results(format='PLAN', filepath=plan)
    bpy.ops.flank.export_results(format='CL', filepath=os.path.join(out, "rotor.apt"))
    bpy.context.view_layer.objects.active = rotor                   # verify simulates on the rotor mesh
    bpy.ops.flank.verify_plan(filepath=plan, tolerance=0.05)
    bpy.ops.flank.render_report(filepath=os.path.join(out, "report.png"), width=1280, height=800)
    print("strips", rotor["flank_sf_strips"], "planned error", rotor["flank_sf_min_error"], "..",
          rotor["flank_sf_max_error"], "simulated undercut", rotor["flank_verify_max_undercut"],
          "overcut", rotor["flank_verify_max_overcut"], "gouges", rotor["flank_verify_gouges"])
    # --- end of the console example ----------------------------------------------------------------
    return dict(strips=int(rotor["flank_sf_strips"]), planned_max_error=float(rotor["flank_sf_max_error"]),
                planned_min_error=float(rotor["flank_sf_min_error"]),
                verified_max_undercut=float(rotor["flank_verify_max_undercut"]),
                verified_max_overcut=float(rotor["flank_verify_max_overcut"]),
                gouges=int(rotor["flank_verify_gouges"]), residual=float(rotor["flank_residual"]),
                outputs=sorted(os.listdir(out)))


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/console")
    ap.add_argument("--zip", help="bpy module: install this extension zip first (isolated user folder)")
    args = ap.parse_args(argv)
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    user_dir = None
    if args.zip:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from demo import enable_extension, isolate_blender_user_dir

        user_dir = isolate_blender_user_dir()          # before ``import bpy``
    try:
        import bpy

        if args.zip:
            enable_extension(bpy, Path(args.zip).resolve())
        if not hasattr(bpy.ops, "flank") or not hasattr(bpy.ops.flank, "plan_single_flank"):
            sys.exit("the Flank Toolpath extension is not enabled: install its zip in Blender, or pass --zip")
        try:
            numbers = console_example(bpy, out)
        except RuntimeError as ex:                     # an operator's error report
            sys.exit("console example failed: {}".format(ex))
    finally:
        if user_dir is not None:
            shutil.rmtree(user_dir, ignore_errors=True)
    text = json.dumps(numbers, indent=2)
    Path(out, "example.json").write_text(text, encoding="utf-8")
    print(text, flush=True)
    if args.zip:
        # the bpy module's own teardown after a Workbench render can crash bpy 4.2 (EGL_BAD_MATCH, SIGSEGV)
        # once everything is written; nothing is left to clean up, so leave without it
        sys.stderr.flush()
        os._exit(0)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]))
