# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.formed_cutter -- s004: formed disc cutter for one tooth of a rotor, its set-up, motion and result."""
import bpy

from .common import (RunMaterial, builtin_from_props, edge_mesh, key_screw_motion, new_mesh_from_arrays, remove_ids,
                     replace_run, results_parent, revolved_mesh, screw_matrix, select_only, set_color_attr,
                     set_float_attr, show_attribute_colors)
from .modal import ModalPlannerMixin
from .properties import formed_cutter_props
from .verify import DEVIATION_ATTR, DEVIATION_COLOR_ATTR, UNTOUCHED

COLLECTION = "Formed Cutter"           # run collection "Formed Cutter (<rotor>)" under "Flank Results"
TABLE1_ROTOR = "Arc Tooth Rotor (s004)"
TABLE1_SOURCE = "s004_table1"          # flank_source of the Table-1 rotor objects made here
CUTTER = "Formed Cutter"
CUTTER_MOVING = "Formed Cutter (moving)"
MOTION = "Cutter Motion"
CONTACT = "Contact Points"
FLAGS_ATTR = "cutter_flags"            # FLOAT point attribute: the plane's flag bit mask (0 = clean)
FLAGS_COLOR_ATTR = "cutter_flags_color"
SIM_PLANES = 2000                      # planes of the dense meridian simulated by the sweep
RING_SEGMENTS = 96
TABLE1_AXIAL_RINGS = 96
# A of s004 Table 1 relative to its outer radius: the automatic centre distance of other rotors
A_RATIO = 200.0 / 111.69
# ring colours: clean planes (tool gold), interference (self occlusion, maximum point, overcut), other flags
COLOR_CLEAN = (0.85, 0.70, 0.25, 1.0)
COLOR_INTERFERENCE = (0.88, 0.10, 0.08, 1.0)
COLOR_OTHER_FLAG = (0.96, 0.62, 0.10, 1.0)
# every custom property this operator writes (cleared on the rotor before a new run)
PROP_PREFIX = "flank_cutter_"


def _decimal(v):
    """Blender float properties are single precision: the decimal value that was typed (7 digits)."""
    return float("{:.7g}".format(v))


def _ring_colors(np, fc, flags):
    interference = fc.FLAG_SELF_OCCLUSION | fc.FLAG_MAXIMUM_POINT | fc.FLAG_OVERCUT
    rgba = np.tile(np.asarray(COLOR_CLEAN), (len(flags), 1))
    rgba[flags != 0] = COLOR_OTHER_FLAG
    rgba[(flags & interference) != 0] = COLOR_INTERFERENCE
    return rgba


class _StageError(Exception):
    """A failed stage of the cutter's computation; its message is reported as it is."""


class FLANK_OT_formed_cutter(ModalPlannerMixin, bpy.types.Operator):
    """s004: axial profile of a formed disc cutter for one tooth, placed at its set-up on the rotor, with
    the machinability flags, the helical motion and the machined-vs-design deviation of a sweep simulation.
    From the UI it runs modal (progress, status text, Esc cancels and changes nothing); in scripts and in
    background mode synchronously.

    Rotor: the paper's Table-1 arc-tooth rotor (built here, 0 <= z <= 2/3 lead, centred on the world
    origin) or the active rotor made by Generate Rotor (profile rebuilt from its custom properties; the
    mesh's local frame is the rotor frame).  The tooth cut is the valley facing +x (all teeth alike).
    Objects in a collection "Formed Cutter (<rotor>)" under "Flank Results" (an earlier run on the same
    rotor is replaced; the Table-1 rotor built here belongs to its run): the cutter (revolved meridian, one
    ring per plane, point attributes ``cutter_flags`` (FLOAT bit mask) and ``cutter_flags_color``), placed
    at its set-up moved along the helix to mid-length; the contact points (edge mesh, ``cutter_flags``);
    with Animate, an empty "Cutter Motion" parented to the rotor with linear keys on its rotation about and
    translation along the rotor axis (the inverse of the rotor's screw motion relative to the cutter, exact
    at every frame) and a moving cutter as its child.  The rotor mesh gets ``machined_deviation`` (FLOAT,
    scene units, > 0 material left, < 0 overcut, 1e9 off the tooth / not reached) and
    ``machined_deviation_color`` as flank.verify_plan.  The cutter and the rotor show their colour attribute
    through the shared material "Flank Attribute Colour" (a user's rotor only gets it when it has no material
    of its own)."""

    bl_idname = "flank.formed_cutter"
    bl_label = "Formed Cutter"
    bl_options = {'REGISTER', 'UNDO'}
    _title = "Formed cutter"

    __annotations__ = formed_cutter_props()

    # ------------------------------------------------------------------ inputs

    def _source(self, context, np, fc, rotors, lead_in):
        """The rotor to cut -> dict, or an error message (str)."""
        hand_in = None if self.handedness == "DEFAULT" else str(self.handedness)
        if self.source == "TABLE1":
            profile, tooth, _ = fc.arc_tooth_profile()
            lead = lead_in if lead_in != 0.0 else fc.TABLE1["lead"]
            return dict(profile=profile, tooth=tooth, lead=lead, hand=hand_in or "right",
                        length=2.0 * abs(lead) / 3.0, obj=None, name=TABLE1_ROTOR, r0=fc.TABLE1["R2"],
                        A_auto=fc.TABLE1["centre_distance"], kind="table1")
        obj = context.active_object
        if obj is not None and PROP_PREFIX + "rotor" in obj and obj.get("flank_source") is None:
            other = bpy.data.objects.get(obj[PROP_PREFIX + "rotor"])  # a cutter object: use its rotor
            if other is not None:
                obj = other
        if obj is None or obj.type != 'MESH':
            return "Select a rotor made by Generate Rotor (or a Table-1 rotor) for Rotor = Active Rotor"
        if obj.mode != 'OBJECT':
            return "Switch '{}' to Object Mode first".format(obj.name)
        src = obj.get("flank_source")
        if src == TABLE1_SOURCE:
            profile, tooth, _ = fc.arc_tooth_profile()
            lead, hand, length = float(obj["flank_lead"]), str(obj["flank_handedness"]), float(obj["flank_length"])
            r0, A_auto, kind = fc.TABLE1["R2"], fc.TABLE1["centre_distance"], "table1"
        elif src == "generated":
            try:
                rotor = builtin_from_props(rotors, obj)
            except (KeyError, ValueError) as ex:
                return "Cannot rebuild the rotor of '{}' from its custom properties: {}".format(obj.name, ex)
            profile, lead, hand, length = rotor.profile, rotor.lead, rotor.handedness, rotor.length
            tooth = fc.default_tooth(profile)
            r0 = float(np.linalg.norm(profile.sample(8192), axis=1).max())
            A_auto, kind = A_RATIO * r0, "{}-{}".format(rotor.kind, rotor.part)
        else:
            return ("'{}' is not a rotor made by Generate Rotor (flank_source = {!r}; analysed or foreign meshes "
                    "have no exact profile): use Rotor = s004 Table-1 Rotor or generate one".format(obj.name, src))
        if lead_in != 0.0 and abs(lead_in - lead) > 1e-6 * abs(lead):
            return ("lead = {:.7g} differs from the lead {:.7g} of rotor '{}': the cutter must follow the rotor's "
                    "helix (set Lead to 0)".format(lead_in, lead, obj.name))
        if hand_in is not None and hand_in != hand:
            return ("handedness '{}' differs from the rotor '{}' ({}-handed): set it to From Rotor".format(
                hand_in, obj.name, hand))
        return dict(profile=profile, tooth=tooth, lead=lead, hand=hand, length=length, obj=obj, name=obj.name,
                    r0=r0, A_auto=A_auto, kind=kind)

    # ------------------------------------------------------------------ run

    def _compute_failed(self, ex):
        """Message for an exception of _compute: a stage's own message (_StageError) as it is."""
        if isinstance(ex, _StageError):
            return str(ex)
        return ModalPlannerMixin._compute_failed(self, ex)

    def _prepare(self, context):
        """Main thread: properties, rotor (its mesh read here) -> job dict, or None (error reported)."""
        import math
        import time

        import numpy as np

        from ..flank_addon.methods.formed_cutter import cutter_profile as fc
        from ..flank_addon.geometry import rotors

        t0 = time.perf_counter()
        lead_in, A_in, swivel, eps_b_in, tol_in = (_decimal(v) for v in (
            self.lead, self.centre_distance, self.swivel, self.eps_b, self.tolerance))
        for label, value in (("lead", lead_in), ("centre distance A", A_in), ("swivel", swivel),
                             ("eps_b", eps_b_in), ("tolerance", tol_in)):
            if not math.isfinite(value):
                self.report({'ERROR'}, "Formed cutter: {} = {} is not a finite number".format(label, value))
                return None
        if not 0.0 < abs(swivel) < 90.0:
            self.report({'ERROR'}, "Formed cutter: swivel = {:g} deg must satisfy 0 < |swivel| < 90 deg (0: cutter "
                                   "axis parallel to the rotor axis, 90: perpendicular to it)".format(swivel))
            return None
        from .common import count_limit_error

        msg = (count_limit_error("planes", self.planes, 2, 20000)
               or count_limit_error("tooth points", self.sample_points, 3, 100000)
               or count_limit_error("resolution", self.resolution, 24, 65536))
        if msg is not None:
            self.report({'ERROR'}, "Formed cutter: " + msg)
            return None
        fs, fe = int(self.frame_start), int(self.frame_end)
        if self.animate and fe <= fs:
            self.report({'ERROR'}, "Formed cutter: end frame {} must be after the start frame {}".format(fe, fs))
            return None
        src = self._source(context, np, fc, rotors, lead_in)
        if isinstance(src, str):
            self.report({'ERROR'}, "Formed cutter: " + src)
            return None
        A = A_in if A_in != 0.0 else src["A_auto"]
        if abs(A) > 1000.0 * src["r0"]:
            self.report({'ERROR'}, "Formed cutter: centre distance A = {:g} exceeds the limit 1000 x the rotor's "
                                   "outer radius = {:g}".format(A, 1000.0 * src["r0"]))
            return None
        rotor_obj = src.pop("obj")            # the worker sees plain values only: the rotor's mesh is read here
        rotor_verts = rotor_world = None
        if rotor_obj is not None:
            me = rotor_obj.data
            rotor_verts = np.empty(len(me.vertices) * 3)
            me.vertices.foreach_get("co", rotor_verts)
            rotor_verts = rotor_verts.reshape(-1, 3)
            rotor_world = np.array(rotor_obj.matrix_world, dtype=np.float64)
        return dict(t0=t0, src=src, rotor_name=None if rotor_obj is None else rotor_obj.name,
                    rotor_verts=rotor_verts, rotor_world=rotor_world, A=A, swivel=swivel,
                    eps_b=eps_b_in if eps_b_in > 0.0 else None, tol_in=tol_in, planes=int(self.planes),
                    n_s=int(self.sample_points), resolution=int(self.resolution), fs=fs, fe=fe,
                    animate=bool(self.animate))

    @staticmethod
    def _compute(job, progress):
        """Cutter profile, sweep simulation, deviation per rotor vertex and the meshes (numpy / scipy only: the
        worker thread when invoked)."""
        import math
        import time

        import numpy as np
        from scipy.spatial import cKDTree

        from ..flank_addon.methods.formed_cutter import cutter_profile as fc
        from ..flank_addon.geometry import rotors
        from ..flank_addon.progress import Cancelled, reporter
        from ..flank_addon.geometry.screw import hand_sign, screw_motion, screw_to_plane
        from ..flank_addon.simulation.sweep import MeridianPart, RevolvingTool, machined_deviation
        from ..flank_addon.simulation.verify import deviation_colors

        report = reporter(progress)
        src = job["src"]
        profile, tooth, lead, hand, r0 = src["profile"], src["tooth"], src["lead"], src["hand"], src["r0"]
        A, swivel, eps_b = job["A"], job["swivel"], job["eps_b"]

        # ---- the core: cutter profile with flags, dense meridian for the simulation
        report(0.0, "cutter profile")
        cp = fc.cutter_profile(profile, lead, A, swivel, handedness=hand, tooth=tooth, planes=job["planes"],
                               eps_b=eps_b)     # FormedCutterError (a ValueError): "Formed cutter: <message>"
        # the core has no progress hook: Esc takes effect once a stage is done (the dense meridian is the
        # longest, ~2 s for a generated rotor)
        report(0.15, "dense meridian for the simulation")
        Zd, Rd, setup = fc.cutter_meridian(profile, lead, A, swivel, planes=SIM_PLANES, handedness=hand,
                                           tooth=tooth, eps_b=eps_b, phase=cp.setup.phase)
        v0 = lead / (2.0 * math.pi)
        eps = hand_sign(hand)
        period = float(profile.period)

        # ---- sweep simulation on tooth points (exclusive of the tooth's end corners: no normal there)
        report(0.4, "sweep simulation")
        t1 = time.perf_counter()
        a_t, b_t = float(tooth[0]), float(tooth[1])
        if b_t <= a_t:
            b_t += period
        n_s = job["n_s"]
        u_s = np.linspace(a_t, b_t, n_s + 2)[1:-1]
        try:
            tool = RevolvingTool([MeridianPart(setup.axis_point, setup.axis_direction, np.c_[Zd, Rd])])
            dev = machined_deviation([tool], profile.eval(u_s % period), profile.outward_normal(u_s % period),
                                     v0, hand, max_deviation=0.1 * r0)
        except Cancelled:
            raise
        except Exception as ex:
            raise _StageError("Formed cutter: sweep simulation failed: {}: {}".format(type(ex).__name__, ex))
        t_sim = time.perf_counter() - t1
        fin = np.isfinite(dev)

        # ---- rotor mesh (Table 1: built here) and the deviation per rotor vertex
        report(0.8, "deviation on the rotor")
        length = float(src["length"])
        r_verts, r_faces, rotor_world = job["rotor_verts"], None, job["rotor_world"]
        try:
            if r_verts is None:
                r_verts, r_faces = rotors.helical_body_mesh(profile, v0, hand, length,
                                                            n_profile=job["resolution"],
                                                            n_axial=TABLE1_AXIAL_RINGS)
                rotor_world = np.eye(4)
                rotor_world[2, 3] = -0.5 * length
            if len(r_verts) == 0:
                raise ValueError("the rotor mesh has no vertices")
            # each vertex: along its helix into z = 0, nearest point of a dense profile sample
            u_d = np.linspace(0.0, period, 16384, endpoint=False)
            p_d = profile.eval(u_d)
            spacing = float(np.linalg.norm(np.diff(np.vstack([p_d, p_d[:1]]), axis=0), axis=1).max())
            dist, idx = cKDTree(p_d).query(screw_to_plane(r_verts, v0, hand))
            s_v = (u_d[idx] - a_t) % period
            on_tooth = (s_v <= b_t - a_t) & (dist <= 2.0 * spacing + 1e-6 * r0)
            dev_n = np.where(fin, dev, np.nan)
            values = np.interp(s_v, u_s - a_t, dev_n)     # constant beyond the first / last sample
            values = np.where(on_tooth, values, np.nan)
        except Cancelled:
            raise
        except Exception as ex:
            raise _StageError("Formed cutter: could not map the deviation onto the rotor: {}: {}".format(
                type(ex).__name__, ex))
        # scene units per rotor unit (the rotor object's uniform scale; 1 for the Table-1 rotor built here): the
        # tolerance is typed and the deviation shown in scene units
        scale = float(np.cbrt(abs(np.linalg.det(rotor_world[:3, :3])))) or 1.0
        tol_in = job["tol_in"]
        tol = tol_in / scale if tol_in > 0.0 else 1e-5 * r0
        reached = np.isfinite(values)

        # ---- set-up moved along the helix to the rotor's mid-length (the rotor is screw-invariant)
        report(0.95, "meshes")
        t_mid = 0.5 * length / v0
        C = screw_matrix(np, t_mid, v0, eps) @ np.asarray(setup.cutter_to_rotor)
        z, r, flags = np.asarray(cp.z), np.asarray(cp.r), np.asarray(cp.flags, dtype=np.int64)
        rh = np.vstack([[0.0, z[-1]], np.c_[r[::-1], z[::-1]], [0.0, z[0]]])
        c_verts, c_faces = revolved_mesh(np, rh, RING_SEGMENTS)
        ring_flags = np.r_[np.repeat(flags[::-1], RING_SEGMENTS), 0, 0]
        r_max = float(r.max())
        report(1.0, "done")
        return dict(cp=cp, summary=cp.summary(), setup=setup, dev=dev, fin=fin, u_s=u_s, t_sim=t_sim, v0=v0,
                    eps=eps, length=length, r_verts=r_verts, r_faces=r_faces, rotor_world=rotor_world,
                    on_tooth=on_tooth, stored=np.where(reached, values * scale, UNTOUCHED),
                    rgba=deviation_colors(values, tol), scale=scale, tol=tol, t_mid=t_mid, C=C, z=z, r=r,
                    flags=flags, c_verts=c_verts, c_faces=c_faces, ring_flags=ring_flags,
                    ring_colors=_ring_colors(np, fc, ring_flags),
                    contact=screw_motion(np.asarray(cp.contact), t_mid, v0, hand), r_max=r_max,
                    s_m=(0.5 * length + r_max) / v0)      # the cutter starts and ends clear of the rotor

    def _build(self, context, job, out):
        """Main thread: the run's collection, objects, the rotor's attributes and properties."""
        import json
        import math
        import os
        import time

        import numpy as np
        from mathutils import Matrix

        from ..flank_addon.methods.formed_cutter import cutter_profile as fc

        src, fs, fe = job["src"], job["fs"], job["fe"]
        rotor_obj = None
        if job["rotor_name"] is not None:
            rotor_obj = bpy.data.objects.get(job["rotor_name"])
            if rotor_obj is None or rotor_obj.type != 'MESH' or len(rotor_obj.data.vertices) != len(out["stored"]):
                self.report({'ERROR'}, "Formed cutter: the rotor '{}' was removed or changed while planning".format(
                    job["rotor_name"]))
                return {'CANCELLED'}
        tooth, lead, hand, r0 = src["tooth"], src["lead"], src["hand"], src["r0"]
        A, swivel = job["A"], job["swivel"]
        cp, summary, setup, dev, fin, u_s = out["cp"], out["summary"], out["setup"], out["dev"], out["fin"], out["u_s"]
        v0, eps, length, rotor_world, scale, tol = (out[k] for k in ("v0", "eps", "length", "rotor_world", "scale",
                                                                     "tol"))
        z, r, flags, r_max, s_m, C = out["z"], out["r"], out["flags"], out["r_max"], out["s_m"], out["C"]
        n_s, t_sim, t_mid = job["n_s"], out["t_sim"], out["t_mid"]

        objects, meshes, colls, actions, names = [], [], [], [], []
        touched_rotor = rotor_mat_added = False
        csv_path = ""
        parent, parent_created = None, False
        run_mat = RunMaterial(bpy)
        # one run per rotor: the Table-1 rotor built here belongs to its run (key "table1"), a user's rotor
        # stays when its run is replaced
        run_key = "table1" if rotor_obj is None else "rotor:" + rotor_obj.name
        base_name = "{} ({})".format(COLLECTION, src["name"])
        try:
            parent, parent_created = results_parent(bpy, context)
            coll = bpy.data.collections.new(base_name + " new")
            colls.append(coll)
            parent.children.link(coll)

            def add(name, data, color=None):
                if data is not None and data not in meshes:
                    meshes.append(data)
                    names.append((data, name))
                ob = bpy.data.objects.new(name, data)
                objects.append(ob)
                names.append((ob, name))
                if color is not None:
                    ob.color = color
                coll.objects.link(ob)
                return ob

            if rotor_obj is None:
                rotor_obj = add(TABLE1_ROTOR, new_mesh_from_arrays(bpy, np, TABLE1_ROTOR, out["r_verts"],
                                                                   out["r_faces"]), (0.70, 0.72, 0.75, 1.0))
                rotor_obj.matrix_world = Matrix(rotor_world.tolist())
                for key, value in dict(flank_source=TABLE1_SOURCE, flank_kind="arc_tooth", flank_part="male",
                                       flank_lobes=int(fc.TABLE1["teeth"]), flank_scale=float(fc.TABLE1["R2"]),
                                       flank_outer_radius=float(fc.TABLE1["R2"]), flank_lead=float(lead),
                                       flank_length=length, flank_v0=v0, flank_handedness=hand,
                                       flank_axis_point=(0.0, 0.0, 0.0), flank_axis=(0.0, 0.0, 1.0)).items():
                    rotor_obj[key] = value
            cutter_mesh = new_mesh_from_arrays(bpy, np, CUTTER, out["c_verts"], out["c_faces"])
            cutter = add(CUTTER, cutter_mesh, (0.62, 0.66, 0.72, 1.0))
            set_float_attr(np, cutter_mesh, FLAGS_ATTR, out["ring_flags"])
            set_color_attr(np, cutter_mesh, FLAGS_COLOR_ATTR, out["ring_colors"])
            run_mat.assign(cutter_mesh)
            cutter.matrix_world = Matrix((rotor_world @ C).tolist())

            contact_mesh = edge_mesh(bpy, np, CONTACT, [(out["contact"], False)])
            contact_obj = add(CONTACT, contact_mesh, (0.10, 0.10, 0.10, 1.0))
            set_float_attr(np, contact_mesh, FLAGS_ATTR, flags)
            contact_obj.matrix_world = Matrix(rotor_world.tolist())

            if job["animate"]:
                motion = add(MOTION, None)
                motion.empty_display_type = 'ARROWS'
                motion.empty_display_size = 0.25 * r0
                motion.parent = rotor_obj
                motion.matrix_parent_inverse = Matrix.Identity(4)
                motion.matrix_basis = Matrix.Identity(4)
                action = key_screw_motion(motion, ((fs, -s_m), (fe, s_m)), v0, eps)
                if action is not None:
                    actions.append(action)
                moving = add(CUTTER_MOVING, cutter_mesh, (0.62, 0.66, 0.72, 1.0))
                moving.parent = motion
                moving.matrix_parent_inverse = Matrix.Identity(4)
                moving.matrix_basis = Matrix(C.tolist())

            mesh = rotor_obj.data
            touched_rotor = True
            set_float_attr(np, mesh, DEVIATION_ATTR, out["stored"])
            set_color_attr(np, mesh, DEVIATION_COLOR_ATTR, out["rgba"])
            # the shared attribute material: always on the rotor built here, on a user's rotor only when it
            # has no material of its own
            rotor_mat_added = run_mat.assign(mesh, only_if_none=job["rotor_name"] is not None)
            mesh.update()

            if self.filepath:
                csv_path = bpy.path.abspath(self.filepath)
                np.savetxt(csv_path, cp.meridian, delimiter=",", header="z,r", comments="", fmt="%.12g")
            replaced = replace_run(bpy, parent, coll, PROP_PREFIX + "key", run_key, base_name, names)
        except Exception as ex:
            user_rotor = bpy.data.objects.get(job["rotor_name"]) if job["rotor_name"] is not None else None
            if touched_rotor and user_rotor is not None:  # the user's rotor: no half-written attributes
                for name in (DEVIATION_ATTR, DEVIATION_COLOR_ATTR):
                    attr = user_rotor.data.attributes.get(name)
                    if attr is not None:
                        user_rotor.data.attributes.remove(attr)
                if rotor_mat_added:
                    user_rotor.data.materials.clear()
            for act in actions:
                try:
                    bpy.data.actions.remove(act)
                except (ReferenceError, RuntimeError):
                    pass
            remove_ids(bpy, objects, meshes, colls + ([parent] if parent_created else []))
            run_mat.discard()
            self.report({'ERROR'}, "Could not build the formed cutter objects: {}: {}".format(type(ex).__name__, ex))
            return {'CANCELLED'}

        dev_t = dev[fin]
        flag_counts = summary["flag_counts"]
        n_flagged = int(np.count_nonzero(flags))
        on_tooth = out["on_tooth"]
        elapsed = time.perf_counter() - job["t0"]
        props = dict(
            rotor=rotor_obj.name, source=src["kind"], lead=float(lead), centre_distance=float(A),
            swivel=float(swivel), handedness=hand, planes=int(len(z)), eps_b=float(cp.eps_b),
            tooth=[float(tooth[0]), float(tooth[1])],
            z_range=[float(z[0]), float(z[-1])], r_range=[float(r.min()), r_max],
            flag_counts={k: int(v) for k, v in flag_counts.items()}, flagged_planes=n_flagged,
            uncut=len(cp.uncut), axis_point=[float(v) for v in setup.axis_point],
            axis_direction=[float(v) for v in setup.axis_direction], setup_t=float(t_mid),
            tolerance=float(tol * scale), length_scale=scale, sample_points=int(n_s), reached_points=int(fin.sum()),
            max_abs_deviation=float(np.abs(dev_t).max() * scale) if len(dev_t) else float("nan"),
            max_overcut=float(max(0.0, -dev_t.min()) * scale) if len(dev_t) else 0.0,
            max_undercut=float(max(0.0, dev_t.max()) * scale) if len(dev_t) else 0.0,
            tooth_vertices=int(on_tooth.sum()), elapsed=float(cp.elapsed_s), sim_elapsed=float(t_sim),
            total_elapsed=float(elapsed), summary=json.dumps(dict(summary, deviation_tooth_u=u_s.tolist(),
                                                                  deviation_tooth=[None if not math.isfinite(d)
                                                                                   else float(d) for d in dev])),
        )
        if job["animate"]:
            props.update(frames=[fs, fe], motion=[-float(s_m), float(s_m)])
        if csv_path:
            props["csv"] = csv_path
        for key in [k for k in rotor_obj.keys() if k.startswith(PROP_PREFIX)]:
            del rotor_obj[key]
        for target in (cutter, coll, rotor_obj):
            for key, value in props.items():
                target[PROP_PREFIX + key] = value
        try:
            select_only(context, cutter)
        except RuntimeError:             # the results collection is excluded from the view layer
            pass
        show_attribute_colors(bpy, context)

        flagged = ", ".join("{} {}".format(k, v) for k, v in flag_counts.items() if v) or "none"
        self.report({'INFO'}, "Formed cutter for {} (A = {:.6g}, swivel {:.6g} deg, lead {:.6g}, {}-handed): {} planes, "
                              "R {:.6g}..{:.6g}, Z {:.6g}..{:.6g}; flagged planes: {}; uncut tooth ranges {}; "
                              "sweep: max |deviation| {:.3g} on {}/{} tooth points (max overcut {:.3g}, max stock "
                              "{:.3g}); cutter {:.2f}s, simulation {:.2f}s, total {:.2f}s{}{}".format(
                                  rotor_obj.name, A, swivel, lead, hand, len(z), r.min(), r_max, z[0], z[-1],
                                  flagged, len(cp.uncut), props["max_abs_deviation"], int(fin.sum()), n_s,
                                  props["max_overcut"], props["max_undercut"], cp.elapsed_s, t_sim, elapsed,
                                  ", wrote {}".format(os.path.basename(csv_path)) if csv_path else "",
                                  ", replaced the earlier run" if replaced else ""))
        return {'FINISHED'}
