# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.animate_strip -- play one strip of a planning run as the machine does it: the rotor screws along and
about its axis past the tool, which stays where it is."""
import bpy
from bpy.props import IntProperty, StringProperty

from .common import iter_fcurves, key_screw_motion, remove_ids, remove_objects
from .export import run_plan

ROLE = "flank_anim_role"       # objects made here: "frame", "motion", "rotor", "strip"
HID = "flank_anim_hid"         # on the motion empty: names of the objects this animation hid (shown again on removal)


def _run_prop(coll, name):
    """A run's custom property under any planner's prefix (flank_sf_<name>, flank_df_<name>)."""
    for key in coll.keys():
        if key.startswith("flank_") and key.endswith("_" + name) and key.count("_") == 2 + name.count("_"):
            return coll[key]
    return None


# (role property, strip property) of the planners' result objects: single flank numbers strips, double
# flank numbers paths (plan strip k = path k)
STRIP_KEYS = (("flank_sf_role", "flank_sf_strip"), ("flank_df_role", "flank_df_path"))


def _strip_of(ob, role):
    """The 0-based plan strip of a result object with that role, else None."""
    for role_key, strip_key in STRIP_KEYS:
        if ob.get(role_key) == role and strip_key in ob:
            return int(ob[strip_key])
    return None


def remove_animation(coll):
    """Remove an earlier animation of this run (objects, their actions) and show again what it hid (the rotor,
    the strip's envelopes); the rotor's own data stays.  Also called by the planners when they replace a run.
    Returns the number of objects removed."""
    objs = [ob for ob in coll.objects if ROLE in ob]
    hid = [str(name) for ob in objs for name in ob.get(HID, ())]
    remove_objects(bpy, objs)
    for name in hid:
        ob = bpy.data.objects.get(name)
        if ob is not None:
            try:
                ob.hide_set(False)
            except RuntimeError:            # not in the current view layer
                pass
    return len(objs)


class FLANK_OT_animate_strip(bpy.types.Operator):
    """Animate one strip of a planning run: the rotor (a linked copy, with the strip's envelope) screws past the
    fixed tool and shank over the frame range, so playback shows the cut.  Re-running replaces the run's
    animation; the original rotor is hidden, not moved"""

    bl_idname = "flank.animate_strip"
    bl_label = "Animate Strip"
    bl_options = {'REGISTER', 'UNDO'}

    collection: StringProperty(name="Run", description="Result collection; empty = the run of the active object, "
                                                       "else the newest run", default="")
    strip: IntProperty(name="Strip", description="Strip number as in the object names (1 = first)", default=1)
    frame_start: IntProperty(name="Start Frame", default=1)
    frame_end: IntProperty(name="End Frame", default=250)

    def execute(self, context):
        import math

        import numpy as np
        from mathutils import Matrix

        fs, fe = int(self.frame_start), int(self.frame_end)
        if fe <= fs:
            self.report({'ERROR'}, "Animate strip: end frame {} must be after the start frame {}".format(fe, fs))
            return {'CANCELLED'}
        found = run_plan(context, self.collection)
        if isinstance(found, str):
            self.report({'ERROR'}, "Animate strip: " + found)
            return {'CANCELLED'}
        coll, plan = found
        n = len(plan["strips"])
        k = int(self.strip) - 1
        if not 0 <= k < n:
            self.report({'ERROR'}, "Animate strip: strip = {} does not exist: run '{}' has strips 1..{}".format(
                int(self.strip), coll.name, n))
            return {'CANCELLED'}
        from ..flank_addon.io.plan import is_mesh_plan

        if is_mesh_plan(plan):
            return self._animate_tool(context, coll, plan, k, fs, fe)
        rotor_name = _run_prop(coll, "rotor")
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
        # time range: the whole rotor body passes the tool tip (plus an outer radius on either side)
        W = np.array(rotor_obj.matrix_world, dtype=np.float64)
        corners = np.array([list(c) + [1.0] for c in rotor_obj.bound_box]) @ (Dinv @ W).T
        z = corners[:, 2] / corners[:, 3]
        st = plan["strips"][k]
        z_tip = 0.5 * (float(st["axis_start"][2]) + float(st["axis_end"][2]))
        margin = float(rot.get("outer_radius", 0.0))
        if not (math.isfinite(v0) and abs(v0) > 0.0):
            self.report({'ERROR'}, "Animate strip: the plan's v0 = {} gives no screw motion".format(v0))
            return {'CANCELLED'}
        t0, t1 = (z_tip - z.max() - margin) / v0, (z_tip - z.min() + margin) / v0
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
            moving = [(rotor_obj, "rotor")] + [(ob, "strip") for ob in envelopes]
            for src, role in moving:
                ob = bpy.data.objects.new("{} (moving)".format(src.name), src.data)    # linked copy: no new mesh
                made.append(ob)
                coll.objects.link(ob)
                ob.parent = motion
                ob.matrix_parent_inverse = Matrix.Identity(4)
                ob.matrix_basis = Matrix((Dinv @ np.array(src.matrix_world, dtype=np.float64)).tolist())
                ob.color = src.color
                ob[ROLE] = role
            frame[ROLE], motion[ROLE] = "frame", "motion"
            for ob in made:
                ob["flank_anim_strip"] = k + 1
            motion["flank_anim_time"] = [float(t0), float(t1)]
            motion["flank_anim_frames"] = [fs, fe]
        except Exception as ex:
            remove_ids(bpy, made, (), ())
            for act in actions:
                if act.users == 0:
                    bpy.data.actions.remove(act)
            self.report({'ERROR'}, "Animate strip failed: {}: {}".format(type(ex).__name__, ex))
            return {'CANCELLED'}
        hid = []
        for ob in [rotor_obj] + envelopes:      # the moving copies stand in for them; shown again on removal
            try:
                if not ob.hide_get():
                    ob.hide_set(True)
                    hid.append(ob.name)
            except RuntimeError:                 # not in the current view layer: nothing to hide
                pass
        motion[HID] = hid
        fcurves = sum(1 for a in actions for _ in iter_fcurves(a))
        self.report({'INFO'}, "Animated strip {} of '{}': the rotor screws t = {:.4g} .. {:.4g} over frames {}..{} "
                              "({} F-curves); '{}' is hidden (Alt+H shows it){}".format(
                                  k + 1, coll.name, t0, t1, fs, fe, fcurves, rotor_obj.name,
                                  ", replaced the earlier animation" if removed else ""))
        return {'FINISHED'}

    def _animate_tool(self, context, coll, plan, k, fs, fe):
        """A free-form (mesh) plan: the surface stays, a linked copy of the strip's tool moves through its rulings
        (one key per ruling, linear in between; the static tool is hidden meanwhile)."""
        import numpy as np
        from mathutils import Matrix

        from .common import frame_along

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
                rot, _ = frame_along(np, a, b)
                T = np.eye(4)
                T[:3, :3], T[:3, 3] = rot, a
                ob.matrix_world = Matrix((W @ T).tolist())
                for path in ("location", "rotation_quaternion", "scale"):
                    ob.keyframe_insert(data_path=path, frame=int(f))
            act = ob.animation_data.action if ob.animation_data else None
            if act is not None:
                actions.append(act)
                for fcu in iter_fcurves(act):
                    for kp in fcu.keyframe_points:
                        kp.interpolation = 'LINEAR'
            ob[ROLE] = "tool"
            ob["flank_anim_strip"] = k + 1
            ob["flank_anim_frames"] = [fs, fe]
        except Exception as ex:
            remove_ids(bpy, made, (), ())
            for act in actions:
                if act.users == 0:
                    bpy.data.actions.remove(act)
            self.report({'ERROR'}, "Animate strip failed: {}: {}".format(type(ex).__name__, ex))
            return {'CANCELLED'}
        hid = []
        try:
            if not tool.hide_get():
                tool.hide_set(True)
                hid.append(tool.name)
        except RuntimeError:
            pass
        ob[HID] = hid
        self.report({'INFO'}, "Animated strip {} of '{}': the tool moves through its {} rulings over frames {}..{}{}"
                    .format(k + 1, coll.name, len(R), fs, fe, ", replaced the earlier animation" if removed else ""))
        return {'FINISHED'}


classes = (FLANK_OT_animate_strip,)
