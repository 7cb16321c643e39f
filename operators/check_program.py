# SPDX-License-Identifier: GPL-3.0-or-later
"""flank.check_program -- read a machine program file back and check it against the run's plan, exactly as
``python -m flank_addon verify PLAN --program FILE`` does (``flank_addon.posts.readback.verify_program``): the
program's moves through the machine's kinematics, its passes matched to the plan's strips, every lobe it cuts
swept again, its links and passes checked against the stock, shafts and holders, its chip loads and speeds
against the Tool panel's cutting data (as Post Program gives them to the post), and its cycle time.  For a
program posted elsewhere, or edited by hand after Post Program wrote it.

What the check finds is stored on the run (``flank_check_*``) and shown in the Machine panel; a program that
does not do what the plan says gives a warning naming the findings.  The program's tool tip path relative to
the rotor is drawn as ``<run>: Checked Program`` (``program_scene``: the posted program's path, in another
colour), replacing the one of the check before; nothing else in the scene changes.  Refused
before any work, by name: no run, a free-form run, a plan without the rotor's extent, no such file, an unknown
machine or post, a file whose extension names another post than the one chosen, bad lobes, holders or cutting
data.  Under
``bpy.app.background`` (and from scripts) it runs synchronously; from the UI the check runs off the UI thread
(``modal``), with progress and Esc."""
import json
import os
import time

import bpy
import numpy as np

from .common import remove_objects
from .modal import ModalPlannerMixin
from .post_program import machine_and_post, mm_per_unit, plan_mm, untimed_words
from .program import cutting_data_of, holders_of, move_rows, parse_lobes, program_path
from .program_scene import COLOR_CHECKED, ProgramBuild, checked_objects
from .properties import check_program_props
from .runs import PlanNeeded, run_plan

__all__ = ["FLANK_OT_check_program", "check_lines"]

CHECK_PREFIX = "flank_check_"


def _program_path(filepath):
    """(absolute path, None) of an existing program file, or (None, error message)."""
    if not str(filepath).strip():
        return None, "no program file given (filepath is empty)"
    path = bpy.path.abspath(filepath)
    if not os.path.isabs(path):
        return None, "the program file '{}' is relative, and there is no saved .blend file it is relative " \
                     "to: give an absolute path".format(filepath)
    path = os.path.normpath(path)
    if not os.path.isfile(path):
        return None, "no program file '{}'".format(path)
    return path, None


def _post_name(post, path):
    """The post the program is read with: the one chosen, else the one of the file's extension; or an error
    message when the two disagree (a LinuxCNC reader on a Heidenhain program would only report nonsense)."""
    from ..flank_addon.posts import POSTS, post_for_file

    by_extension = post_for_file(path)
    chosen = str(post).strip()
    if not chosen:
        if by_extension is None:
            return None, "cannot tell the dialect of '{}' from its extension: choose the post".format(
                os.path.basename(path))
        return by_extension.name, None
    if by_extension is not None and by_extension.name != chosen and chosen in POSTS:   # else: unknown, named later
        return None, "'{}' has the extension of {} programs, but the post is {}: choose the post the program " \
                     "was written by".format(os.path.basename(path), by_extension.name, chosen)
    return chosen, None


def check_lines(coll):
    """Labels of the latest program check of the run (the Machine panel), [] before one."""
    p = CHECK_PREFIX
    if p + "findings" not in coll:
        return []
    findings = json.loads(coll[p + "findings"])
    head = "Checked {}: {} moves, {} passes ({} matched)".format(
        os.path.basename(str(coll.get(p + "file", "?"))), int(coll[p + "moves"]), int(coll[p + "passes"]),
        int(coll[p + "matched_passes"]))
    untimed = untimed_words(coll, p)
    time_line = "Its cycle time: {:.1f} s".format(float(coll[p + "total_time_s"])) + (
        " (not counting {})".format(untimed) if untimed else "")
    tools = ["T{}: chip load up to {:.4g} mm (fz {:g}), {:.4g} m/min (vc {:g}){}".format(
        t["tool"], t["max_chip_load_mm"], t["cutting_data"]["fz_mm"], t["max_surface_speed_m_min"],
        t["cutting_data"]["vc_m_min"], "; chip load not judged on {} move(s) off the screw".format(
            t["moves_chip_load_not_judged"]) if t.get("moves_chip_load_not_judged") else "")
        for t in json.loads(coll.get(p + "cutting", "[]"))]
    if not findings:
        verdict = ["As planned" + ("" if p + "deviation_mm" not in coll else
                                   " (machined deviation within {:.2g} mm of the plan's)".format(
                                       float(coll[p + "deviation_mm"])))]
    else:
        verdict = ["NOT AS PLANNED, {} finding(s):".format(len(findings))] + findings[:3]
    return [head, time_line] + tools + verdict


class FLANK_OT_check_program(ModalPlannerMixin, bpy.types.Operator):
    """Read a machine program file back and check it against the run's plan, as verify --program does: its
    passes matched to the strips, the lobes it cuts swept again, its links and passes checked against the stock,
    shafts and holders, and its cycle time"""

    bl_idname = "flank.check_program"
    bl_label = "Check Program File"
    bl_options = {'REGISTER', 'UNDO'}       # the run's checked path and flank_check_* change
    _title = "Check program"

    __annotations__ = check_program_props()

    def invoke(self, context, event):
        if not str(self.filepath).strip() and not bpy.app.background and context.window_manager is not None:
            self.modal_after_browser = True
            context.window_manager.fileselect_add(self)      # execute() starts the check once a file is chosen
            return {'RUNNING_MODAL'}
        return ModalPlannerMixin.invoke(self, context, event)

    # ------------------------------------------------------------------ main thread: inputs
    def _prepare(self, context):
        """Properties, run, machine and post -> job dict, or None (error reported)."""
        path, msg = _program_path(self.filepath)
        post, msg = _post_name(self.post, path) if msg is None else (None, msg)
        lobes = parse_lobes(self.lobes) if msg is None else None
        msg = msg or (lobes if isinstance(lobes, str) else None)
        holders = holders_of(self.holders) if msg is None else None
        msg = msg or (holders if isinstance(holders, str) else None)
        data = cutting_data_of(self.tool_flutes, self.tool_cutting_speed_m_min, self.tool_feed_per_tooth_mm,
                               self.tool_max_rpm) if msg is None else None
        msg = msg or (data if isinstance(data, str) else None)
        found = run_plan(context, self.collection, defer=self._defer_analysis) if msg is None else msg
        if isinstance(found, PlanNeeded):
            return self._read_first(found)           # a long plan not read yet: in a worker first
        mp = machine_and_post(self.machine, post, self.flip_rotor) if not isinstance(found, str) else found
        k = mm_per_unit(context, *found) if not isinstance(mp, str) else mp
        if isinstance(k, str):
            self.report({'ERROR'}, "Check program: " + k)
            return None
        (coll, plan), (machine, post) = found, mp
        return dict(t0=time.perf_counter(), coll=coll.name, plan=plan, to_world=plan["rotor"]["to_world"], k=k,
                    machine=machine, post=post, lobes=lobes, holders=holders, data=data, filepath=path,
                    coolant=self.coolant)

    # ------------------------------------------------------------------ worker thread
    @staticmethod
    def _compute(job, progress):
        from ..flank_addon.machining.rotor_body import rotor_body, with_holders
        from ..flank_addon.posts.readback import empty_program, tool_gauges, tool_table, verify_program
        from ..flank_addon.progress import reporter, substage

        try:
            with open(job["filepath"], encoding="ascii", errors="replace") as fh:     # as the command line reads it
                text = fh.read()
        except OSError as ex:
            raise ValueError("cannot read '{}': {}".format(job["filepath"], ex.strerror or ex)) from None
        empty = empty_program(text, "'{}'".format(job["filepath"]))
        if empty:
            raise ValueError(empty)
        plan = plan_mm(job["coll"], job["plan"], job["k"])
        rotor = with_holders(rotor_body(plan), job["holders"])
        report = reporter(progress)
        machine, read = job["machine"], job["post"].read(text, job["machine"])
        res = verify_program(text, job["post"], machine, [plan], rotor, lobes=job["lobes"],
                             progress=substage(report, 0.0, 0.95), read=read, cutting_data=job["data"],
                             coolant=job["coolant"])
        report(0.95, "the program's path")              # Esc stops here too
        # the path as the read-back reads the program: the plan's tools and their gauge lengths
        gauges = tool_gauges(tool_table([plan])[0])
        return dict(res=res, path=program_path(read, machine, gauges, move_rows(read, machine, gauges)))

    # ------------------------------------------------------------------ main thread: results
    def _build(self, context, job, out):
        coll = bpy.data.collections.get(job["coll"])
        if coll is None:
            self.report({'ERROR'}, "Check program: the run '{}' was removed meanwhile".format(job["coll"]))
            return {'CANCELLED'}
        res, k = out["res"], job["k"]
        build = ProgramBuild(coll, coll.name)
        if len(out["path"]["edges"]):                 # a program without a move has no path to draw
            try:
                build.path(out["path"], np.asarray(job["to_world"], float) @ np.diag([1.0 / k, 1.0 / k, 1.0 / k, 1.0]),
                           label="Checked Program", role="checked", color=COLOR_CHECKED)
            except Exception as ex:                   # Blender data: nothing stays
                build.discard()
                self.report({'ERROR'}, "Check program: {}: {}".format(type(ex).__name__, ex))
                return {'CANCELLED'}
        remove_objects([ob for ob in checked_objects(coll) if ob not in build.objects])
        for ob in build.objects:                      # the name the one before had, now free
            ob.name = ob.data.name = "{}: Checked Program".format(coll.name)
        for key in [name for name in coll.keys() if name.startswith(CHECK_PREFIX)]:
            del coll[key]
        props = dict(file=job["filepath"], post=job["post"].name, machine=job["machine"].name,
                     holders=json.dumps(job["holders"]), findings=json.dumps(list(res["findings"])),
                     moves=int(res["moves"]), passes=int(res["passes"]), matched_passes=int(res["matched_passes"]),
                     lobes_cut=[int(v) for v in res["lobes_cut"]],
                     intrusion_mm=float(res["links"]["max_intrusion_mm"]), gouge_points=int(res["gouge_points"]),
                     cutting_time_s=float(res["cutting_time_s"]), rapid_time_s=float(res["rapid_time_s"]),
                     total_time_s=float(res["total_time_s"]), untimed_moves=int(res["untimed_moves"]),
                     reference_returns=int(res["reference_returns"]), untimed_returns=int(res["untimed_returns"]),
                     cutting=json.dumps(res["cutting"]["tools"]), elapsed=float(time.perf_counter() - job["t0"]))
        for key, prop in (("max_deviation_difference_mm", "deviation_mm"), ("pose_difference_mm", "pose_mm")):
            if res[key] is not None:                  # None where no lobe was compared
                props[prop] = float(res[key])
        for name, value in props.items():
            coll[CHECK_PREFIX + name] = value
        name = os.path.basename(job["filepath"])
        if res["findings"]:
            self.report({'WARNING'}, "Check program: {} is NOT AS PLANNED for '{}': {}".format(
                name, coll.name, "; ".join(res["findings"])))
        else:
            self.report({'INFO'}, "Check program: {} does what the plan of '{}' says: {} moves, {} passes on lobes "
                                  "{}{}, cycle time {:.1f} s; {:.2f} s".format(
                                      name, coll.name, res["moves"], res["passes"],
                                      ",".join(map(str, res["lobes_cut"])),
                                      "" if res["max_deviation_difference_mm"] is None else
                                      ", machined deviation within {:.2g} mm of the plan's".format(
                                          res["max_deviation_difference_mm"]),
                                      res["total_time_s"], props["elapsed"]))
        return {'FINISHED'}


classes = (FLANK_OT_check_program,)
register, unregister = bpy.utils.register_classes_factory(classes)
