# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.post_program -- from plan to machine: the run's plan as a whole-rotor machine program (every strip on
every chosen lobe, run out past the rotor's end faces, collision-checked links, feeds and speeds) for a machine
and a controller dialect, written atomically, with the tool tip's path relative to the rotor, the cycle time and
an animation of the program in the scene.  The core does the work exactly as ``python -m flank_addon post``:
``flank_addon.machining`` (operation, program, kinematics, cycle time) and ``flank_addon.posts`` (writers and
readers); this module reads the inputs and builds the Blender data (``program``, ``program_scene``).

Nothing is written or built when anything is wrong: no run, a plan without the rotor's extent, an unknown
machine or post (the message lists the valid names), a pass the machine cannot reach (the core names the pass
and the axis), a path that cannot be written, bad numbers.  Under ``bpy.app.background`` (and from scripts) it
runs synchronously; from the UI the core runs off the UI thread (``modal``)."""
import json
import math
import os
import time

import bpy
import numpy as np

from ..flank_addon.machining.cycle_time import untimed_note, untimed_parts
from .common import check_filepath, hide_objects, remove_objects
from .modal import ModalPlannerMixin
from .program import (check_numbers, cutting_data_of, holders_of, key_frames, parse_lobes, plan_in_mm, rounded,
                      tool_outline)
from .program_scene import ANIM_ROLE, ProgramBuild, program_objects, store_program
from .properties import post_program_props
from .runs import PlanNeeded, remove_animation, run_plan, run_prop
from .units import mm_per_scene_unit

__all__ = ["FLANK_OT_post_program", "machine_and_post", "mm_per_unit", "plan_mm"]


def machine_and_post(machine_name, post_name, flip_rotor):
    """(machine, post) of their names (the machine flipped when the rotor is), or an error message."""
    from ..flank_addon.machining.machine import load_machine
    from ..flank_addon.posts import get_post

    name = str(machine_name).strip()
    try:
        post = get_post(str(post_name).strip())
        machine = load_machine(bpy.path.abspath(name) if name.startswith("//") else name)
    except ValueError as ex:                        # MachineError, PostError: names the valid ones
        return str(ex)
    return (machine.flipped() if flip_rotor else machine), post


def mm_per_unit(context, coll, plan):
    """k mm per plan length unit, or an error message (the scaling itself is the worker's, :func:`plan_mm`)."""
    if plan.get("surface") is not None:
        return "'{}' is a free-form run: whole-rotor machine programs are made from rotor plans".format(coll.name)
    if plan["rotor"].get("extent") is None:
        return ("the plan of '{}' records no rotor extent (the rotor body's axial range and shafts): plan it "
                "again, the planners record it".format(coll.name))
    s = run_prop(coll, "length_scale")
    k = rounded((float(s) if s else 1.0) * mm_per_scene_unit(context.scene))
    if not (math.isfinite(k) and k > 0.0):
        return "run '{}': its length scale {!r} gives no millimetres".format(coll.name, s)
    return k


def plan_mm(coll_name, plan, k):
    """The plan in mm (any thread: 30 ms for a double-flank plan on the 280,000-triangle rotor)."""
    try:
        return plan_in_mm(plan, k)
    except (ValueError, KeyError, TypeError) as ex:
        raise ValueError("the plan of '{}' cannot be scaled to mm: {}".format(coll_name, ex)) from None


def _time_text(seconds):
    s = float(seconds)
    return "{:.1f} s".format(s) if s < 60.0 else "{:.1f} s ({:d}:{:04.1f} min)".format(s, int(s // 60), s % 60)


def cycle_time_lines(coll):
    """Labels of a posted program's cycle time (the Machine and Results panels), [] before a posting."""
    p = "flank_prog_"
    if p + "total_time_s" not in coll:
        return []
    untimed = untimed_words(coll, p)
    return ["Program: {} passes, {} for {}".format(int(coll[p + "passes"]), coll.get(p + "post", "?"),
                                                   coll.get(p + "machine", "?")),
            "Cycle time: {}".format(_time_text(coll[p + "total_time_s"])),
            "Cutting {:.1f} s, rapid {:.1f} s, tool changes {:.1f} s".format(
                float(coll[p + "cutting_time_s"]), float(coll[p + "rapid_time_s"]),
                float(coll[p + "tool_change_time_s"]))] + (
        ["Not timed: " + untimed] if untimed else []) + read_back_lines(coll)


def untimed_words(coll, p):
    """What a stored cycle time leaves out ('' for nothing): moves out of a tool change, reference returns it
    could not time (a run stored before those were timed kept only their count: none was timed then)."""
    moves = int(coll.get(p + "untimed_moves", 0))
    returns = int(coll.get(p + "untimed_returns", coll.get(p + "reference_returns", 0)))
    return " and ".join(untimed_parts(moves, returns))


def read_back_lines(coll):
    """Labels of the program's read-back (Post Program with Read Back), [] without one."""
    p = "flank_prog_read_back_"
    if p + "error" in coll:
        return ["Read back failed: {}".format(coll[p + "error"])]
    if p + "findings" not in coll:
        return []
    findings = json.loads(coll[p + "findings"])
    if not findings:
        return ["Read back: as planned" + (" (machined deviation within {:.2g} mm of the plan's)".format(
            float(coll[p + "deviation_mm"])) if p + "deviation_mm" in coll else "")]
    return ["Read back: NOT AS PLANNED, {} finding(s):".format(len(findings))] + findings[:3]


class FLANK_OT_post_program(ModalPlannerMixin, bpy.types.Operator):
    """Post the run's plan as a whole-rotor machine program for a machine and a controller: written to the file,
    shown as the tool's path relative to the rotor with its cycle time, and animated (the rotor turns while the
    tool moves)"""

    bl_idname = "flank.post_program"
    bl_label = "Post Program"
    bl_options = {'REGISTER', 'UNDO'}
    _title = "Post program"

    __annotations__ = post_program_props()

    def invoke(self, context, event):
        if not str(self.filepath).strip() and not bpy.app.background and context.window_manager is not None:
            from ..flank_addon.posts import POSTS

            post = POSTS.get(str(self.post))
            self.filepath = "flank_program" + (post.extension if post is not None else ".nc")
            context.window_manager.fileselect_add(self)      # execute() runs once a file is chosen
            return {'RUNNING_MODAL'}
        return ModalPlannerMixin.invoke(self, context, event)

    # ------------------------------------------------------------------ main thread: inputs
    def _prepare(self, context):
        """Properties, run, machine and post -> job dict, or None (error reported)."""
        path, msg = check_filepath(self.filepath)
        msg = msg or check_numbers(self)
        lobes = parse_lobes(self.lobes) if msg is None else None
        msg = msg or (lobes if isinstance(lobes, str) else None)
        found = run_plan(context, self.collection, defer=self._defer_analysis) if msg is None else msg
        if isinstance(found, PlanNeeded):
            return self._read_first(found)           # a long plan not read yet: in a worker first
        mp = machine_and_post(self.machine, self.post, self.flip_rotor) if not isinstance(found, str) else found
        k = mm_per_unit(context, *found) if not isinstance(mp, str) else mp
        if isinstance(k, str):
            self.report({'ERROR'}, "Post program: " + k)
            return None
        (coll, plan), (machine, post) = found, mp
        rotor_name = run_prop(coll, "rotor")
        return dict(t0=time.perf_counter(), coll=coll.name, plan=plan, to_world=plan["rotor"]["to_world"], k=k,
                    machine=machine, post=post, lobes=lobes, clearance=float(self.clearance), filepath=path,
                    holders=holders_of(self.holders), coolant=self.coolant,
                    data=cutting_data_of(self.tool_flutes, self.tool_cutting_speed_m_min,
                                         self.tool_feed_per_tooth_mm, self.tool_max_rpm),
                    rotor=str(rotor_name) if rotor_name else "", animate=bool(self.animate),
                    read_back=bool(self.read_back),
                    frames=(int(self.frame_start), int(self.frame_end)))

    # ------------------------------------------------------------------ worker thread
    @staticmethod
    def _compute(job, progress):
        from ..flank_addon.machining.machine import MachineError
        from .program import post_program

        job = dict(job, plan=plan_mm(job["coll"], job["plan"], job["k"]))     # lengths in mm, here: not on the UI
        try:
            return post_program(job, progress)
        except MachineError as ex:                  # beyond an axis' travel: maybe the scene's unit
            if "outside its limits" not in str(ex):
                raise
            raise MachineError("{} (the rotor's outer radius is {:.4g} mm in this scene's unit)".format(
                ex, float(job["plan"]["rotor"]["outer_radius"]))) from None

    # ------------------------------------------------------------------ main thread: results
    def _build(self, context, job, out):
        coll = bpy.data.collections.get(job["coll"])
        if coll is None:
            self.report({'ERROR'}, "Post program: the run '{}' was removed meanwhile".format(job["coll"]))
            return {'CANCELLED'}
        rotor = bpy.data.objects.get(job["rotor"]) if job["rotor"] else None
        k = job["k"]
        M = np.asarray(job["to_world"], float) @ np.diag([1.0 / k, 1.0 / k, 1.0 / k, 1.0])
        build = ProgramBuild(coll, coll.name)
        try:
            path_ob = build.path(out["path"], M)
            build.holders(out["holders"], M)
            if job["animate"]:
                keys = out["keys"]
                frames = key_frames(keys["seconds"], keys["total"], *job["frames"])
                build.animation(keys, frames, M, rotor if rotor is not None and rotor.type == 'MESH' else None,
                                path_ob, out["shapes"], tool_outline)
            from ..flank_addon.posts import atomic_write

            atomic_write(job["filepath"], out["text"])
        except Exception as ex:                      # PostError (cannot write), Blender data: nothing stays
            build.discard()
            self.report({'ERROR'}, "Post program: {}".format(ex if isinstance(ex, ValueError) else
                                                             "{}: {}".format(type(ex).__name__, ex)))
            return {'CANCELLED'}
        self._replace(coll, build, rotor, path_ob, job)
        store_program(coll, self._props(job, out))
        self._report_done(coll, job, out)
        return {'FINISHED'}

    @staticmethod
    def _replace(coll, build, rotor, path_ob, job):
        """Remove the run's earlier program (and its animation, or any animation when this one is animated),
        then make the new animation the run's."""
        remove_objects([ob for ob in program_objects(coll) if ob not in build.objects])
        if job["animate"] or any(ob.get(ANIM_ROLE) == "spin" for ob in coll.objects if ob not in build.objects):
            remove_animation(coll)
        if job["animate"]:
            build.mark_animation(hide_objects([ob for ob in (rotor, path_ob) if ob is not None]))

    @staticmethod
    def _props(job, out):
        t, data = out["times"], job["data"]
        per = [{key: p[key] for key in ("pass", "plan", "strip", "lobe", "flank", "tool", "reverse", "rpm", "time_s",
                                        "feed_mm_min", "cutting_length_mm", "limited_by")} for p in out["per_pass"]]
        props = dict(file=job["filepath"], post=job["post"].name, machine=job["machine"].name,
                     machine_source=job["machine"].source, passes=int(t["passes"]), moves=int(t["moves"]),
                     lobes=[int(v) for v in t["lobes"]], clearance=job["clearance"], mm_per_unit=float(job["k"]),
                     holders=json.dumps(job["holders"]),
                     cutting_time_s=float(t["cutting_time_s"]), rapid_time_s=float(t["rapid_time_s"]),
                     tool_changes=int(t["tool_changes"]), tool_change_time_s=float(t["tool_change_time_s"]),
                     untimed_moves=int(t["untimed_moves"]), reference_returns=int(t["reference_returns"]),
                     untimed_returns=int(t["untimed_returns"]),
                     total_time_s=float(t["total_time_s"]), cutting_length_mm=float(t["cutting_length_mm"]),
                     rpm=[float(v) for v in t["rpm"]], cutting_data=json.dumps(data.as_dict()),
                     path_edges=int(len(out["path"]["edges"])), summary=json.dumps(per, default=float),
                     elapsed=float(time.perf_counter() - job["t0"]))
        if job["animate"]:
            props.update(frames=list(job["frames"]), animated_seconds=float(out["keys"]["total"]))
        check = out["check"]
        if check is not None and "error" in check:
            props.update(read_back_error=check["error"])
        elif check is not None:
            props.update(read_back_findings=json.dumps(check["findings"]),
                         read_back_intrusion_mm=float(check["intrusion_mm"]),
                         read_back_gouge_points=int(check["gouge_points"]))
            for key in ("deviation_mm", "pose_mm"):            # left out where no lobe was compared
                if check[key] is not None:
                    props["read_back_" + key] = float(check[key])
        return props

    def _report_done(self, coll, job, out):
        t, check = out["times"], out["check"]
        if check is None:
            read = ""
        elif "error" in check:                          # the program is written; its check could not be made
            self.report({'WARNING'}, "Post program: the read-back of the written program failed: {}".format(
                check["error"]))
            read = ", read back failed"
        elif check["findings"]:                         # the program does not do what the plan says: say so
            self.report({'WARNING'}, "Post program: the program read back is NOT AS PLANNED: " +
                        "; ".join(check["findings"]))
            read = ", read back NOT AS PLANNED"
        else:
            read = ", read back as planned" + ("" if check["deviation_mm"] is None else
                                               " (machined deviation within {:.2g} mm of the plan's)".format(
                                                   check["deviation_mm"]))
        self.report({'INFO'}, "Posted '{}': {} passes on lobes {}, {} for {}, cycle time {:.1f} s (cutting {:.1f} s, "
                              "rapid {:.1f} s, tool changes {:.1f} s{}); wrote {} ({} moves){}{}; {:.2f} s".format(
                                  coll.name, t["passes"], ",".join(map(str, t["lobes"])), job["post"].name,
                                  job["machine"].name, t["total_time_s"], t["cutting_time_s"], t["rapid_time_s"],
                                  t["tool_change_time_s"],
                                  untimed_note(t["untimed_moves"], job["machine"], t["untimed_returns"]),
                                  os.path.basename(job["filepath"]), t["moves"],
                                  ", animated over frames {}..{}".format(*job["frames"]) if job["animate"] else "",
                                  read, time.perf_counter() - job["t0"]))


classes = (FLANK_OT_post_program,)
register, unregister = bpy.utils.register_classes_factory(classes)
