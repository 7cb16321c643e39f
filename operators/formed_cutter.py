# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.formed_cutter -- formed disc cutter (Hu, Zhou & Li 2025): the axial profile of a disc cutter for one
tooth of a rotor, placed at its set-up, with the machinability flags, the helical motion and the
machined-vs-design deviation of a sweep simulation.  From the UI it runs modal (progress, status text, Esc
cancels and changes nothing); in scripts and in background mode synchronously.

Rotor: the paper's Table-1 arc-tooth rotor (built here, 0 <= z <= 2/3 lead, centred on the world origin) or the
active rotor made by Generate Rotor (profile rebuilt from its custom properties; the mesh's local frame is the
rotor frame).  The tooth cut is the valley facing +x (all teeth alike).  Objects in a collection
"Formed Cutter (<rotor>)" under "Flank Results" (an earlier run on the same rotor is replaced; the Table-1
rotor built here belongs to its run): the cutter (revolved outline, one ring per plane, point attributes
``cutter_flags`` (FLOAT bit mask) and ``cutter_flags_color``), placed at its set-up moved along the helix to
mid-length; the contact points (edge mesh, ``cutter_flags``); with Animate, an empty "Cutter Motion" parented
to the rotor with linear keys on its rotation about and translation along the rotor axis (the inverse of the
rotor's screw motion relative to the cutter, exact at every frame) and a moving cutter as its child.  The rotor
mesh gets ``machined_deviation`` (FLOAT, scene units, > 0 material left, < 0 overcut, 1e9 off the tooth / not
reached) and ``machined_deviation_color`` as flank.verify_plan.  The cutter and the rotor show their colour
attribute through the shared material "Flank Attribute Colour" (a user's rotor only gets it when it has no
material of its own)."""
import json
import math
import os
import time

import bpy
import numpy as np

from .common import (count_limit_error, mesh_vertices, output_file_error, remove_attributes, set_color_attr,
                     set_float_attr, typed)
from .modal import ModalPlannerMixin
from .properties import formed_cutter_props
from .result_builder import RunBuilder
from .shapes import revolved_mesh, screw_matrix
from .sources import builtin_from_props
from .verify import DEVIATION_ATTR, DEVIATION_COLOR_ATTR, UNTOUCHED

COLLECTION = "Formed Cutter"           # run collection "Formed Cutter (<rotor>)" under "Flank Results"
TABLE1_ROTOR = "Arc Tooth Rotor (Hu, Zhou & Li 2025)"
TABLE1_SOURCE = "table1_arc_tooth"     # flank_source of the Table-1 rotor objects made here
CUTTER = "Formed Cutter"
CUTTER_MOVING = "Formed Cutter (moving)"
MOTION = "Cutter Motion"
CONTACT = "Contact Points"
FLAGS_ATTR = "cutter_flags"            # FLOAT point attribute: the plane's flag bit mask (0 = clean)
FLAGS_COLOR_ATTR = "cutter_flags_color"
SIM_PLANES = 2000                      # planes of the dense outline simulated by the sweep
RING_SEGMENTS = 96
TABLE1_AXIAL_RINGS = 96
# A of Table 1 relative to its outer radius: the automatic centre distance of other rotors
A_RATIO = 200.0 / 111.69
# ring colours: clean planes (tool gold), interference (self occlusion, maximum point, overcut), other flags
COLOR_CLEAN = (0.85, 0.70, 0.25, 1.0)
COLOR_INTERFERENCE = (0.88, 0.10, 0.08, 1.0)
COLOR_OTHER_FLAG = (0.96, 0.62, 0.10, 1.0)
COLOR_CUTTER = (0.62, 0.66, 0.72, 1.0)
# every custom property this operator writes (cleared on the rotor before a new run)
PROP_PREFIX = "flank_cutter_"

__all__ = ["FLANK_OT_formed_cutter"]


def _ring_colors(fc, flags):
    interference = fc.FLAG_SELF_OCCLUSION | fc.FLAG_MAXIMUM_POINT | fc.FLAG_OVERCUT
    rgba = np.tile(np.asarray(COLOR_CLEAN), (len(flags), 1))
    rgba[flags != 0] = COLOR_OTHER_FLAG
    rgba[(flags & interference) != 0] = COLOR_INTERFERENCE
    return rgba


class _StageError(Exception):
    """A failed stage of the cutter's computation; its message is reported as it is."""


def _table1(fc, lead_in, hand_in):
    profile, tooth, _ = fc.arc_tooth_profile()
    lead = lead_in if lead_in != 0.0 else fc.TABLE1["lead"]
    return dict(profile=profile, tooth=tooth, lead=lead, hand=hand_in or "right", length=2.0 * abs(lead) / 3.0,
                obj=None, name=TABLE1_ROTOR, r0=fc.TABLE1["R2"], A_auto=fc.TABLE1["centre_distance"], kind="table1")


def _active_rotor(fc, obj):
    """(profile, tooth, lead, hand, length, r0, A_auto, kind) of an active rotor, or an error message."""
    src = obj.get("flank_source")
    if src == TABLE1_SOURCE:
        profile, tooth, _ = fc.arc_tooth_profile()
        return (profile, tooth, float(obj["flank_lead"]), str(obj["flank_handedness"]), float(obj["flank_length"]),
                fc.TABLE1["R2"], fc.TABLE1["centre_distance"], "table1")
    if src != "generated":
        return ("'{}' is not a rotor made by Generate Rotor (flank_source = {!r}; analysed or foreign meshes have no "
                "exact profile): use Rotor = Table-1 Rotor or generate one".format(obj.name, src))
    try:
        rotor = builtin_from_props(obj)
    except (KeyError, ValueError) as ex:
        return "Cannot rebuild the rotor of '{}' from its custom properties: {}".format(obj.name, ex)
    profile = rotor.profile
    r0 = float(np.linalg.norm(profile.sample(8192), axis=1).max())
    return (profile, fc.default_tooth(profile), rotor.lead, rotor.handedness, rotor.length, r0, A_RATIO * r0,
            "{}-{}".format(rotor.kind, rotor.part))


def rotor_to_cut(op, context, fc, lead_in):
    """The rotor to cut -> dict, or an error message (str)."""
    hand_in = None if op.handedness == "DEFAULT" else str(op.handedness)
    if op.source == "TABLE1":
        return _table1(fc, lead_in, hand_in)
    obj = context.active_object
    if obj is not None and PROP_PREFIX + "rotor" in obj and obj.get("flank_source") is None:
        other = bpy.data.objects.get(obj[PROP_PREFIX + "rotor"])  # a cutter object: use its rotor
        if other is not None:
            obj = other
    if obj is None or obj.type != 'MESH':
        return "Select a rotor made by Generate Rotor (or a Table-1 rotor) for Rotor = Active Rotor"
    if obj.mode != 'OBJECT':
        return "Switch '{}' to Object Mode first".format(obj.name)
    found = _active_rotor(fc, obj)
    if isinstance(found, str):
        return found
    profile, tooth, lead, hand, length, r0, A_auto, kind = found
    if lead_in != 0.0 and abs(lead_in - lead) > 1e-6 * abs(lead):
        return ("lead = {:.7g} differs from the lead {:.7g} of rotor '{}': the cutter must follow the rotor's "
                "helix (set Lead to 0)".format(lead_in, lead, obj.name))
    if hand_in is not None and hand_in != hand:
        return "handedness '{}' differs from the rotor '{}' ({}-handed): set it to From Rotor".format(
            hand_in, obj.name, hand)
    return dict(profile=profile, tooth=tooth, lead=lead, hand=hand, length=length, obj=obj, name=obj.name,
                r0=r0, A_auto=A_auto, kind=kind)


def _check_inputs(op, values):
    for label, value in zip(("lead", "centre distance A", "swivel", "eps_b", "tolerance"), values):
        if not math.isfinite(value):
            return "{} = {} is not a finite number".format(label, value)
    if not 0.0 < abs(values[2]) < 90.0:
        return ("swivel = {:g} deg must satisfy 0 < |swivel| < 90 deg (0: cutter axis parallel to the rotor axis, "
                "90: perpendicular to it)".format(values[2]))
    msg = (count_limit_error("planes", op.planes, 2, 20000)
           or count_limit_error("tooth points", op.sample_points, 3, 100000)
           or count_limit_error("resolution", op.resolution, 24, 65536))
    if msg is None and op.animate and int(op.frame_end) <= int(op.frame_start):
        msg = "end frame {} must be after the start frame {}".format(int(op.frame_end), int(op.frame_start))
    return msg


def _simulate(job, cp, fc, report):
    """The dense outline of the cutter and the sweep simulation on the tooth points -> (setup, u_s, dev, time)."""
    from ..flank_addon.progress import Cancelled
    from ..flank_addon.simulation.sweep import MeridianPart, RevolvingTool, machined_deviation

    src = job["src"]
    profile, tooth, lead, hand = src["profile"], src["tooth"], src["lead"], src["hand"]
    # the core has no progress hook: Esc takes effect once a stage is done (the dense outline is the longest,
    # ~2 s for a generated rotor)
    report(0.15, "dense outline for the simulation")
    Zd, Rd, setup = fc.cutter_meridian(profile, lead, job["A"], job["swivel"], planes=SIM_PLANES, handedness=hand,
                                       tooth=tooth, eps_b=job["eps_b"], phase=cp.setup.phase)
    report(0.4, "sweep simulation")
    t1 = time.perf_counter()
    period = float(profile.period)
    a_t, b_t = float(tooth[0]), float(tooth[1])
    if b_t <= a_t:
        b_t += period
    u_s = np.linspace(a_t, b_t, job["n_s"] + 2)[1:-1]     # exclusive of the tooth's end corners: no normal there
    try:
        tool = RevolvingTool([MeridianPart(setup.axis_point, setup.axis_direction, np.c_[Zd, Rd])])
        dev = machined_deviation([tool], profile.eval(u_s % period), profile.outward_normal(u_s % period),
                                 lead / (2.0 * math.pi), hand, max_deviation=0.1 * src["r0"])
    except Cancelled:
        raise
    except Exception as ex:
        raise _StageError("Formed cutter: sweep simulation failed: {}: {}".format(type(ex).__name__, ex))
    return setup, u_s, dev, time.perf_counter() - t1


def _deviation_on_rotor(job, u_s, dev, v0):
    """The rotor mesh (the Table-1 rotor: built here) and the deviation per rotor vertex (NaN off the tooth)."""
    from scipy.spatial import cKDTree

    from ..flank_addon.geometry import rotors
    from ..flank_addon.geometry.screw import screw_to_plane

    src = job["src"]
    profile, hand, r0, period = src["profile"], src["hand"], src["r0"], float(src["profile"].period)
    r_verts, r_faces, rotor_world = job["rotor_verts"], None, job["rotor_world"]
    if r_verts is None:
        r_verts, r_faces = rotors.helical_body_mesh(profile, v0, hand, float(src["length"]),
                                                    n_profile=job["resolution"], n_axial=TABLE1_AXIAL_RINGS)
        rotor_world = np.eye(4)
        rotor_world[2, 3] = -0.5 * float(src["length"])
    if len(r_verts) == 0:
        raise ValueError("the rotor mesh has no vertices")
    a_t, b_t = float(src["tooth"][0]), float(src["tooth"][1])
    if b_t <= a_t:
        b_t += period
    # each vertex: along its helix into z = 0, nearest point of a dense profile sample
    u_d = np.linspace(0.0, period, 16384, endpoint=False)
    p_d = profile.eval(u_d)
    spacing = float(np.linalg.norm(np.diff(np.vstack([p_d, p_d[:1]]), axis=0), axis=1).max())
    dist, idx = cKDTree(p_d).query(screw_to_plane(r_verts, v0, hand))
    s_v = (u_d[idx] - a_t) % period
    on_tooth = (s_v <= b_t - a_t) & (dist <= 2.0 * spacing + 1e-6 * r0)
    values = np.interp(s_v, u_s - a_t, np.where(np.isfinite(dev), dev, np.nan))  # constant beyond the ends
    return r_verts, r_faces, rotor_world, on_tooth, np.where(on_tooth, values, np.nan)


def _fill_run(run, job, out, made):
    """The Table-1 rotor (when built here), the cutter, the contact points, the motion, the rotor's deviation
    attributes and the profile CSV."""
    from ..flank_addon.methods.formed_cutter import cutter_profile as fc

    src, rotor_world = job["src"], out["rotor_world"]
    if made["rotor"] is None:
        made["rotor"] = run.add_mesh(TABLE1_ROTOR, out["r_verts"], out["r_faces"], (0.70, 0.72, 0.75, 1.0),
                                     matrix=rotor_world)
        for key, value in dict(
                flank_source=TABLE1_SOURCE, flank_kind="arc_tooth", flank_part="male",
                flank_lobes=int(fc.TABLE1["teeth"]), flank_scale=float(fc.TABLE1["R2"]),
                flank_outer_radius=float(fc.TABLE1["R2"]), flank_lead=float(src["lead"]),
                flank_length=out["length"], flank_v0=out["v0"], flank_handedness=src["hand"],
                flank_axis_point=(0.0, 0.0, 0.0), flank_axis=(0.0, 0.0, 1.0)).items():
            made["rotor"][key] = value
    rotor = made["rotor"]
    cutter = made["cutter"] = run.add_mesh(CUTTER, *out["cutter_mesh"], COLOR_CUTTER,
                                           matrix=rotor_world @ out["C"])
    set_float_attr(cutter.data, FLAGS_ATTR, out["ring_flags"])
    set_color_attr(cutter.data, FLAGS_COLOR_ATTR, out["ring_colors"])
    run.color_by_attribute(cutter.data)
    contact = run.add(CONTACT, run.edges(CONTACT, [(out["contact"], False)]), (0.10, 0.10, 0.10, 1.0),
                      matrix=rotor_world)
    set_float_attr(contact.data, FLAGS_ATTR, out["flags"])
    if job["animate"]:
        s_m = out["s_m"]
        motion = run.add_motion(MOTION, rotor, tuple(zip(job["frames"], (-s_m, s_m))), out["v0"], out["eps"],
                                0.25 * src["r0"], role=None)
        run.add_moving(CUTTER_MOVING, motion, cutter.data, out["C"], COLOR_CUTTER, role=None)
    _paint_rotor(run, job, out, rotor)
    if job["filepath"]:
        run.write(job["filepath"], lambda p: np.savetxt(p, out["cp"].meridian, delimiter=",", header="z,r",
                                                        comments="", fmt="%.12g"))


def _paint_rotor(run, job, out, rotor):
    """The machined deviation on the rotor mesh; a user's rotor gets the shared material only when it has
    none, and loses the attributes (and that material) again if the run fails."""
    mesh = rotor.data
    if job["rotor_name"] is not None:
        run.on_failure(lambda: remove_attributes(mesh, (DEVIATION_ATTR, DEVIATION_COLOR_ATTR)))
    set_float_attr(mesh, DEVIATION_ATTR, out["stored"])
    set_color_attr(mesh, DEVIATION_COLOR_ATTR, out["rgba"])
    if run.color_by_attribute(mesh, only_if_none=job["rotor_name"] is not None) and job["rotor_name"]:
        run.on_failure(mesh.materials.clear)
    mesh.update()


class FLANK_OT_formed_cutter(ModalPlannerMixin, bpy.types.Operator):
    """Derive the formed disc cutter for one tooth of a rotor, place it at its set-up with its machinability flags
    and helical motion, and paint the simulated machined deviation on the rotor"""

    bl_idname = "flank.formed_cutter"
    bl_label = "Formed Cutter"
    bl_options = {'REGISTER', 'UNDO'}
    _title = "Formed cutter"

    __annotations__ = formed_cutter_props()

    def _compute_failed(self, ex):
        """Message for an exception of _compute: a stage's own message (_StageError) as it is."""
        if isinstance(ex, _StageError):
            return str(ex)
        return ModalPlannerMixin._compute_failed(self, ex)

    # ------------------------------------------------------------------ main thread: inputs
    def _prepare(self, context):
        """Properties, rotor (its mesh read here) -> job dict, or None (error reported)."""
        from ..flank_addon.methods.formed_cutter import cutter_profile as fc

        t0 = time.perf_counter()
        values = [typed(v) for v in (self.lead, self.centre_distance, self.swivel, self.eps_b, self.tolerance)]
        lead_in, A_in, swivel, eps_b_in, tol_in = values
        msg = _check_inputs(self, values) or output_file_error(self.filepath, "plan file")
        src = rotor_to_cut(self, context, fc, lead_in) if msg is None else msg
        if not isinstance(src, str):
            A = A_in if A_in != 0.0 else src["A_auto"]
            if abs(A) > 1000.0 * src["r0"]:
                src = "centre distance A = {:g} exceeds the limit 1000 x the rotor's outer radius = {:g}".format(
                    A, 1000.0 * src["r0"])
        if not isinstance(src, str):
            # eps_b is in the rotor's units, the tolerance in scene units (the rotor object may be scaled)
            obj = src["obj"]
            scale = (float(np.cbrt(abs(np.linalg.det(np.array(obj.matrix_world)[:3, :3])))) if obj is not None
                     else 1.0) or 1.0
            for label, value, limit in (("eps_b", eps_b_in, src["r0"]), ("tolerance", tol_in, src["r0"] * scale)):
                if not isinstance(src, str) and value > limit:
                    src = "{} = {:g} exceeds the rotor's outer radius {:g} (0 = default)".format(label, value, limit)
        if isinstance(src, str):
            self.report({'ERROR'}, "Formed cutter: " + src)
            return None
        rotor_obj = src.pop("obj")            # the worker sees plain values only: the rotor's mesh is read here
        return dict(t0=t0, src=src, rotor_name=None if rotor_obj is None else rotor_obj.name,
                    rotor_verts=None if rotor_obj is None else mesh_vertices(rotor_obj.data),
                    rotor_world=None if rotor_obj is None else np.array(rotor_obj.matrix_world, dtype=np.float64),
                    A=A, swivel=swivel, eps_b=eps_b_in if eps_b_in > 0.0 else None, tol_in=tol_in,
                    planes=int(self.planes), n_s=int(self.sample_points), resolution=int(self.resolution),
                    frames=(int(self.frame_start), int(self.frame_end)), animate=bool(self.animate),
                    filepath=bpy.path.abspath(self.filepath) if self.filepath else "")

    # ------------------------------------------------------------------ worker thread
    @staticmethod
    def _compute(job, progress):
        """Cutter profile, sweep simulation, deviation per rotor vertex and the meshes (no Blender data)."""
        from ..flank_addon.geometry.screw import hand_sign, screw_motion
        from ..flank_addon.methods.formed_cutter import cutter_profile as fc
        from ..flank_addon.progress import Cancelled, reporter
        from ..flank_addon.simulation.verify import deviation_colors

        report = reporter(progress)
        src = job["src"]
        report(0.0, "cutter profile")
        cp = fc.cutter_profile(src["profile"], src["lead"], job["A"], job["swivel"], handedness=src["hand"],
                               tooth=src["tooth"], planes=job["planes"], eps_b=job["eps_b"])
        setup, u_s, dev, t_sim = _simulate(job, cp, fc, report)
        report(0.8, "deviation on the rotor")
        v0, eps, length = src["lead"] / (2.0 * math.pi), hand_sign(src["hand"]), float(src["length"])
        try:
            r_verts, r_faces, rotor_world, on_tooth, values = _deviation_on_rotor(job, u_s, dev, v0)
        except Cancelled:
            raise
        except Exception as ex:
            raise _StageError("Formed cutter: could not map the deviation onto the rotor: {}: {}".format(
                type(ex).__name__, ex))
        # scene units per rotor unit (the rotor object's uniform scale; 1 for the Table-1 rotor built here): the
        # tolerance is typed and the deviation shown in scene units
        scale = float(np.cbrt(abs(np.linalg.det(rotor_world[:3, :3])))) or 1.0
        tol = job["tol_in"] / scale if job["tol_in"] > 0.0 else 1e-5 * src["r0"]
        report(0.95, "meshes")
        t_mid = 0.5 * length / v0            # set-up moved along the helix to mid-length (the rotor is screw-invariant)
        z, r, flags = np.asarray(cp.z), np.asarray(cp.r), np.asarray(cp.flags, dtype=np.int64)
        rh = np.vstack([[0.0, z[-1]], np.c_[r[::-1], z[::-1]], [0.0, z[0]]])
        ring_flags = np.r_[np.repeat(flags[::-1], RING_SEGMENTS), 0, 0]
        report(1.0, "done")
        return dict(cp=cp, summary=cp.summary(), setup=setup, dev=dev, fin=np.isfinite(dev), u_s=u_s, t_sim=t_sim,
                    v0=v0, eps=eps, length=length, r_verts=r_verts, r_faces=r_faces, rotor_world=rotor_world,
                    on_tooth=on_tooth, stored=np.where(np.isfinite(values), values * scale, UNTOUCHED),
                    rgba=deviation_colors(values, tol), scale=scale, tol=tol, t_mid=t_mid,
                    C=screw_matrix(t_mid, v0, eps) @ np.asarray(setup.cutter_to_rotor), z=z, r=r, flags=flags,
                    cutter_mesh=revolved_mesh(rh, RING_SEGMENTS), ring_flags=ring_flags,
                    ring_colors=_ring_colors(fc, ring_flags),
                    contact=screw_motion(np.asarray(cp.contact), t_mid, v0, src["hand"]), r_max=float(r.max()),
                    s_m=(0.5 * length + float(r.max())) / v0)      # the cutter starts and ends clear of the rotor

    # ------------------------------------------------------------------ main thread: results
    def _build(self, context, job, out):
        """The run's collection, objects, the rotor's attributes and properties."""
        rotor = None
        if job["rotor_name"] is not None:
            rotor = bpy.data.objects.get(job["rotor_name"])
            if rotor is None or rotor.type != 'MESH' or len(rotor.data.vertices) != len(out["stored"]):
                self.report({'ERROR'}, "Formed cutter: the rotor '{}' was removed or changed while planning".format(
                    job["rotor_name"]))
                return {'CANCELLED'}
        # one run per rotor: the Table-1 rotor built here belongs to its run (key "table1"), a user's rotor stays
        # when its run is replaced
        run = RunBuilder(context, PROP_PREFIX, "table1" if rotor is None else "rotor:" + rotor.name,
                         "{} ({})".format(COLLECTION, job["src"]["name"]))
        made = dict(rotor=rotor)
        replaced = run.build(self, "formed cutter objects", lambda: _fill_run(run, job, out, made))
        if replaced is None:
            return {'CANCELLED'}
        rotor = made["rotor"]
        props = self._props(job, out, rotor, made)
        run.store(props, (made["cutter"], run.collection, rotor), clear=[rotor])
        run.show(made["cutter"])
        self._report_done(job, out, rotor, props, made, replaced)
        return {'FINISHED'}

    def _props(self, job, out, rotor, made):
        src, cp, summary, setup = job["src"], out["cp"], out["summary"], out["setup"]
        dev, fin, z, r, scale = out["dev"], out["fin"], out["z"], out["r"], out["scale"]
        dev_t = dev[fin]
        props = dict(
            rotor=rotor.name, source=src["kind"], lead=float(src["lead"]), centre_distance=float(job["A"]),
            swivel=float(job["swivel"]), handedness=src["hand"], planes=int(len(z)), eps_b=float(cp.eps_b),
            tooth=[float(src["tooth"][0]), float(src["tooth"][1])],
            z_range=[float(z[0]), float(z[-1])], r_range=[float(r.min()), out["r_max"]],
            flag_counts={k: int(v) for k, v in summary["flag_counts"].items()},
            flagged_planes=int(np.count_nonzero(out["flags"])), uncut=len(cp.uncut),
            axis_point=[float(v) for v in setup.axis_point], axis_direction=[float(v) for v in setup.axis_direction],
            setup_t=float(out["t_mid"]), tolerance=float(out["tol"] * scale), length_scale=scale,
            sample_points=int(job["n_s"]), reached_points=int(fin.sum()),
            max_abs_deviation=float(np.abs(dev_t).max() * scale) if len(dev_t) else float("nan"),
            max_overcut=float(max(0.0, -dev_t.min()) * scale) if len(dev_t) else 0.0,
            max_undercut=float(max(0.0, dev_t.max()) * scale) if len(dev_t) else 0.0,
            tooth_vertices=int(out["on_tooth"].sum()), elapsed=float(cp.elapsed_s), sim_elapsed=float(out["t_sim"]),
            total_elapsed=float(time.perf_counter() - job["t0"]),
            summary=json.dumps(dict(summary, deviation_tooth_u=out["u_s"].tolist(),
                                    deviation_tooth=[None if not math.isfinite(d) else float(d) for d in dev])),
        )
        if job["animate"]:
            props.update(frames=list(job["frames"]), motion=[-float(out["s_m"]), float(out["s_m"])])
        if job["filepath"]:
            props["csv"] = job["filepath"]
        return props

    def _report_done(self, job, out, rotor, props, made, replaced):
        src, cp, z, r = job["src"], out["cp"], out["z"], out["r"]
        flagged = ", ".join("{} {}".format(k, v) for k, v in out["summary"]["flag_counts"].items() if v) or "none"
        self.report({'INFO'}, "Formed cutter for {} (A = {:.6g}, swivel {:.6g} deg, lead {:.6g}, {}-handed): {} "
                              "planes, R {:.6g}..{:.6g}, Z {:.6g}..{:.6g}; flagged planes: {}; uncut tooth ranges {}; "
                              "sweep: max |deviation| {:.3g} on {}/{} tooth points (max overcut {:.3g}, max stock "
                              "{:.3g}); cutter {:.2f}s, simulation {:.2f}s, total {:.2f}s{}{}".format(
                                  rotor.name, job["A"], job["swivel"], src["lead"], src["hand"], len(z), r.min(),
                                  out["r_max"], z[0], z[-1], flagged, len(cp.uncut), props["max_abs_deviation"],
                                  int(out["fin"].sum()), job["n_s"], props["max_overcut"], props["max_undercut"],
                                  cp.elapsed_s, out["t_sim"], props["total_elapsed"],
                                  ", wrote {}".format(os.path.basename(job["filepath"])) if job["filepath"] else "",
                                  ", replaced the earlier run" if replaced else ""))


classes = (FLANK_OT_formed_cutter,)
register, unregister = bpy.utils.register_classes_factory(classes)
