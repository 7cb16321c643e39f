# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.animate_strip -- play one strip of a planning run as the machine does it: the rotor screws along and
about its axis past the tool, which stays where it is (a free-form run: the tool moves through its rulings)."""
import math

import bpy
import numpy as np
from bpy.props import IntProperty, StringProperty
from mathutils import Matrix

from .common import hide_objects, iter_fcurves, key_screw_motion, linear_keys, remove_ids
from .modal import ModalPlannerMixin
from .runs import ANIM_HID, ANIM_ROLE, PlanNeeded, remove_animation, run_plan, run_prop
from .shapes import axis_frame

# (role property, strip property) of the planners' result objects: single flank numbers strips, double
# flank numbers paths (plan strip k = path k)
STRIP_KEYS = (("flank_sf_role", "flank_sf_strip"), ("flank_df_role", "flank_df_path"))


def _strip_of(ob, role):
    """The 0-based plan strip of a result object with that role, else None."""
    for role_key, strip_key in STRIP_KEYS:
        if ob.get(role_key) == role and strip_key in ob:
            return int(ob[strip_key])
    return None


def _discard(made, actions, op, ex):
    remove_ids(made, (), ())
    for act in actions:
        if act.users == 0:
            bpy.data.actions.remove(act)
    op.report({'ERROR'}, "Animate strip failed: {}: {}".format(type(ex).__name__, ex))
    return {'CANCELLED'}


def _time_range(plan, k, rotor_obj, Dinv, v0):
    """Screw parameters (t0, t1) over which the whole rotor body passes the tool tip (plus an outer radius on
    either side)."""
    W = np.array(rotor_obj.matrix_world, dtype=np.float64)
    corners = np.array([list(c) + [1.0] for c in rotor_obj.bound_box]) @ (Dinv @ W).T
    z = corners[:, 2] / corners[:, 3]
    st = plan["strips"][k]
    z_tip = 0.5 * (float(st["axis_start"][2]) + float(st["axis_end"][2]))
    margin = float(plan["rotor"].get("outer_radius", 0.0))
    return (z_tip - z.max() - margin) / v0, (z_tip - z.min() + margin) / v0


class FLANK_OT_animate_strip(ModalPlannerMixin, bpy.types.Operator):
    """Animate one strip of a planning run: the rotor (a linked copy, with the strip's envelope) screws past the
    fixed tool and shank over the frame range, so playback shows the cut.  Re-running replaces the run's
    animation; the original rotor is hidden, not moved"""

    # The animation is made in one turn of the main thread (no worker); only a long plan that is not kept parsed
    # (a file opened again) is read first in a worker, as the other operators that read a run's plan do.
    _title = "Animate strip"

    bl_idname = "flank.animate_strip"
    bl_label = "Animate Strip"
    bl_options = {'REGISTER', 'UNDO'}

    collection: StringProperty(name="Run", description="Result collection; empty = the run of the active object, "
                                                       "else the newest run", default="")
    strip: IntProperty(name="Strip", description="Strip number as in the object names (1 = first)", default=1)
    frame_start: IntProperty(name="Start Frame", default=1)
    frame_end: IntProperty(name="End Frame", default=250)

    def invoke(self, context, event):
        # modal only while a long plan is read: otherwise the animation is made at once, as from a script
        if isinstance(run_plan(context, self.collection, defer=True), PlanNeeded):
            return ModalPlannerMixin.invoke(self, context, event)
        return self.execute(context)

    def _prepare(self, context):
        """The run, its plan and the strip -> job, or None (error reported)."""
        fs, fe = int(self.frame_start), int(self.frame_end)
        found = run_plan(context, self.collection, defer=self._defer_analysis) if fe > fs else \
            "end frame {} must be after the start frame {}".format(fe, fs)
        if isinstance(found, PlanNeeded):
            return self._read_first(found)           # a long plan not read yet: in a worker first
        if isinstance(found, str):
            self.report({'ERROR'}, "Animate strip: " + found)
            return None
        coll, plan = found
        n, k = len(plan["strips"]), int(self.strip) - 1
        if not 0 <= k < n:
            self.report({'ERROR'}, "Animate strip: strip = {} does not exist: run '{}' has strips 1..{}".format(
                int(self.strip), coll.name, n))
            return None
        return dict(coll=coll.name, plan=plan, k=k, fs=fs, fe=fe)

    @staticmethod
    def _compute(job, progress):
        return None                                  # nothing off the main thread: the animation is Blender data

    def _build(self, context, job, result):
        from ..flank_addon.io.plan import is_mesh_plan

        coll = bpy.data.collections.get(job["coll"])
        if coll is None:
            self.report({'ERROR'}, "Animate strip: run '{}' was removed".format(job["coll"]))
            return {'CANCELLED'}
        args = (coll, job["plan"], job["k"], job["fs"], job["fe"])
        return self._animate_tool(*args) if is_mesh_plan(job["plan"]) else self._animate_rotor(*args)

    def _animate_rotor(self, coll, plan, k, fs, fe):
        """A rotor plan: a linked copy of the rotor (and of the strip's envelopes) screws past the fixed tool."""
        rotor_name = run_prop(coll, "rotor")
        rotor_obj = bpy.data.objects.get(str(rotor_name)) if rotor_name is not None else None
        if rotor_obj is None or rotor_obj.type != 'MESH':
            self.report({'ERROR'}, "Animate strip: the rotor '{}' of run '{}' is gone".format(rotor_name, coll.name))
            return {'CANCELLED'}
        rot = plan["rotor"]
        D = np.array(rot["to_world"], dtype=np.float64)            # rotor frame -> world
        v0 = float(rot["v0"])
        eps = 1 if str(rot["handedness"]) == "right" else -1
        try:
            Dinv = np.linalg.inv(D)
        except np.linalg.LinAlgError:
            self.report({'ERROR'}, "Animate strip: the plan's rotor placement (to_world) is singular")
            return {'CANCELLED'}
        if not (math.isfinite(v0) and abs(v0) > 0.0):
            self.report({'ERROR'}, "Animate strip: the plan's v0 = {} gives no screw motion".format(v0))
            return {'CANCELLED'}
        t0, t1 = _time_range(plan, k, rotor_obj, Dinv, v0)
        tag = "{} strip {}".format(coll.name, k + 1)
        envelopes = [ob for ob in coll.objects if _strip_of(ob, "envelope") == k]   # double flank: F1 and F2
        removed = remove_animation(coll)
        made, actions = [], []
        try:
            frame = bpy.data.objects.new("Rotor Frame ({})".format(tag), None)
            made.append(frame)
            coll.objects.link(frame)
            frame.empty_display_type = 'PLAIN_AXES'
            frame.matrix_world = Matrix(D.tolist())
            motion = bpy.data.objects.new("Rotor Motion ({})".format(tag), None)
            made.append(motion)
            coll.objects.link(motion)
            motion.empty_display_type = 'ARROWS'
            motion.parent = frame
            motion.matrix_parent_inverse = Matrix.Identity(4)
            act = key_screw_motion(motion, ((fs, t0), (fe, t1)), v0, eps)
            if act is not None:
                actions.append(act)
            for src, role in [(rotor_obj, "rotor")] + [(ob, "strip") for ob in envelopes]:
                ob = bpy.data.objects.new("{} (moving)".format(src.name), src.data)    # linked copy: no new mesh
                made.append(ob)
                coll.objects.link(ob)
                ob.parent = motion
                ob.matrix_parent_inverse = Matrix.Identity(4)
                ob.matrix_basis = Matrix((Dinv @ np.array(src.matrix_world, dtype=np.float64)).tolist())
                ob.color = src.color
                ob[ANIM_ROLE] = role
            frame[ANIM_ROLE], motion[ANIM_ROLE] = "frame", "motion"
            for ob in made:
                ob["flank_anim_strip"] = k + 1
            motion["flank_anim_time"] = [float(t0), float(t1)]
            motion["flank_anim_frames"] = [fs, fe]
        except Exception as ex:
            return _discard(made, actions, self, ex)
        motion[ANIM_HID] = hide_objects([rotor_obj] + envelopes)
        fcurves = sum(1 for a in actions for _ in iter_fcurves(a))
        self.report({'INFO'}, "Animated strip {} of '{}': the rotor screws t = {:.4g} .. {:.4g} over frames {}..{} "
                              "({} F-curves); '{}' is hidden (Alt+H shows it){}".format(
                                  k + 1, coll.name, t0, t1, fs, fe, fcurves, rotor_obj.name,
                                  ", replaced the earlier animation" if removed else ""))
        return {'FINISHED'}

    def _animate_tool(self, coll, plan, k, fs, fe):
        """A free-form (mesh) plan: the surface stays, a linked copy of the strip's tool moves through its rulings
        (one key per ruling, linear in between; the static tool is hidden meanwhile)."""
        tools = [ob for ob in coll.objects if ob.get("flank_ff_role") == "tool" and ob.get("flank_ff_strip") == k]
        if not tools or tools[0].type != 'MESH':
            self.report({'ERROR'}, "Animate strip: run '{}' has no tool object for strip {}".format(coll.name, k + 1))
            return {'CANCELLED'}
        tool = tools[0]
        W = np.array(coll.get("flank_ff_to_world", np.eye(4).ravel().tolist()), dtype=np.float64).reshape(4, 4)
        R = np.asarray(plan["strips"][k]["rulings"], dtype=np.float64)
        frames = np.rint(np.linspace(fs, fe, len(R))).astype(int)
        if len(np.unique(frames)) < len(frames):
            self.report({'ERROR'}, "Animate strip: frames {}..{} are too few for the {} rulings of strip {}".format(
                fs, fe, len(R), k + 1))
            return {'CANCELLED'}
        removed = remove_animation(coll)
        made, actions = [], []
        try:
            ob = bpy.data.objects.new("{} (moving)".format(tool.name), tool.data)     # linked copy: no new mesh
            made.append(ob)
            coll.objects.link(ob)
            ob.color = tool.color
            ob.rotation_mode = 'QUATERNION'
            for f, (a, b) in zip(frames, R):
                ob.matrix_world = Matrix((W @ axis_frame(a, b)[0]).tolist())
                for path in ("location", "rotation_quaternion", "scale"):
                    ob.keyframe_insert(data_path=path, frame=int(f))
            act = linear_keys(ob)
            if act is not None:
                actions.append(act)
            ob[ANIM_ROLE] = "tool"
            ob["flank_anim_strip"] = k + 1
            ob["flank_anim_frames"] = [fs, fe]
        except Exception as ex:
            return _discard(made, actions, self, ex)
        ob[ANIM_HID] = hide_objects([tool])
        self.report({'INFO'}, "Animated strip {} of '{}': the tool moves through its {} rulings over frames {}..{}{}"
                    .format(k + 1, coll.name, len(R), fs, fe, ", replaced the earlier animation" if removed else ""))
        return {'FINISHED'}


classes = (FLANK_OT_animate_strip,)
register, unregister = bpy.utils.register_classes_factory(classes)
