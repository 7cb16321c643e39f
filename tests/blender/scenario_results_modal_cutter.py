# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.formed_cutter through the modal Run path (operators/modal.py), for test_blender_results_modal_cutter.py.

The operator's ``execute`` is replaced for one call by scenario_modal's driver (``_start_modal`` + ``modal()``
with TIMER / ESC events, a stand-in context): ESC and closing leave a full census of bpy.data / the scene
unchanged, a modal run to the end makes the same cutter, rotor deviation and collection as the synchronous
run, and a core error in the worker is reported with the synchronous run's message and changes nothing."""
import hashlib
import time

import driver
import scenario_modal as sm

KW = dict(source="ACTIVE", sample_points=81, animate=True)


def _digest(np, a):
    return hashlib.sha1(np.ascontiguousarray(a, dtype=np.float32).tobytes()).hexdigest()[:16]


def _summary(bpy, np, rotor_name):
    """The run on the rotor: its collection, objects, the cutter's numbers, the rotor's deviation digest."""
    coll = next((c for c in bpy.data.collections if c.get("flank_cutter_key") == "rotor:" + rotor_name), None)
    if coll is None:
        return None
    cutter = next(o for o in coll.objects if "flank_cutter_r_range" in o)
    rotor = bpy.data.objects[rotor_name]
    dev = driver._float_attr(np, rotor.data, "machined_deviation")
    return dict(collection=coll.name, parents=[c.name for c in bpy.data.collections if coll.name in c.children],
                objects=sorted(o.name for o in coll.objects),
                r_range=list(cutter["flank_cutter_r_range"]), z_range=list(cutter["flank_cutter_z_range"]),
                max_abs_deviation=float(cutter["flank_cutter_max_abs_deviation"]),
                flagged_planes=int(cutter["flank_cutter_flagged_planes"]),
                reached_points=int(cutter["flank_cutter_reached_points"]), deviation=_digest(np, dev),
                cutter_vertices=_digest(np, driver._mesh_co(np, cutter)),
                materials=[m.name for m in cutter.data.materials if m is not None])


def scenario(bpy, res, args):
    import numpy as np

    fc_mod = __import__(driver.MODULE + ".operators.formed_cutter", fromlist=["x"])
    modal_mod = __import__(driver.MODULE + ".operators.modal", fromlist=["x"])
    cls, op = fc_mod.FLANK_OT_formed_cutter, bpy.ops.flank.formed_cutter
    res["mixin"] = issubclass(cls, modal_mod.ModalPlannerMixin)
    driver._run_op(bpy.ops.flank.generate_rotor, kind="srm_a", part="male", resolution=360, axial=24)
    rotor_name = bpy.context.active_object.name

    def select():
        sm.driver_select(bpy, bpy.data.objects[rotor_name])

    # background INVOKE_DEFAULT is execute: synchronous
    select()
    t0 = time.perf_counter()
    try:
        ret = sorted(op('INVOKE_DEFAULT', **KW))
    except RuntimeError as ex:
        ret = str(ex)
    res["sync"] = dict(result=ret, seconds=time.perf_counter() - t0, run=_summary(bpy, np, rotor_name))

    res.update(sm.cancelled_runs(bpy, np, op, cls, KW, select))

    select()
    rec = sm._call(bpy, op, cls, "finish", **KW)
    rec["run"] = _summary(bpy, np, rotor_name)
    res["finish"] = rec

    # a core error in the worker (centre distance below the rotor's radius): reported, nothing changed
    select()
    before = sm.census(bpy, np)
    rec = sm._call(bpy, op, cls, "finish", **dict(KW, centre_distance=0.5))
    rec["census_equal"] = before == sm.census(bpy, np)
    res["failed"] = rec
    select()
    ret, err = driver._run_op(op, **dict(KW, centre_distance=0.5))
    res["failed_sync"] = dict(result=ret, error=err)
    res["patched_left"] = "execute" in cls.__dict__
