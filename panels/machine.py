# SPDX-License-Identifier: GPL-3.0-or-later
"""Machine panel (after Results and Verify): the machine and controller dialect, clearance, lobes, the tool's
cutting data and the program file; Post Program turns the run shown in Results into a whole-rotor machine
program (flank.post_program) and the panel shows its cycle time once posted; Check Program File reads a program
back and checks it against the run's plan (flank.check_program), by default the program file above."""
import bpy

from .common import CATEGORY, REGION, SPACE, draw_lines

CUTTING_DATA = ("tool_flutes", "tool_cutting_speed_m_min", "tool_feed_per_tooth_mm", "tool_max_rpm")
MACHINING = ("clearance", "lobes", "flip_rotor", "holders", "coolant")


def post_call(settings, scene):
    """The keyword arguments the Post Program button carries from the scene settings."""
    kw = {name: getattr(settings, name) for name in CUTTING_DATA + MACHINING}
    kw.update(filepath=settings.program_filepath, post=settings.post, animate=settings.program_animate,
              read_back=settings.program_read_back,
              machine=settings.machine_file if settings.machine == "FILE" else settings.machine,
              frame_start=scene.frame_start, frame_end=max(scene.frame_end, scene.frame_start + 1))
    return kw


def check_call(settings):
    """The keyword arguments the Check Program File button carries from the scene settings: the program file,
    machine, post, holders and cutting data as Post Program uses them (the lobes to sweep are those the program
    cuts)."""
    return dict(filepath=settings.program_filepath, post=settings.post, flip_rotor=settings.flip_rotor,
                holders=settings.holders, coolant=settings.coolant,
                machine=settings.machine_file if settings.machine == "FILE" else settings.machine,
                **{name: getattr(settings, name) for name in CUTTING_DATA})


class FLANK_PT_machine(bpy.types.Panel):
    bl_idname = "FLANK_PT_machine"
    bl_label = "Machine"
    bl_space_type = SPACE
    bl_region_type = REGION
    bl_category = CATEGORY
    bl_order = 40

    def draw(self, context):
        from ..operators.check_program import check_lines
        from ..operators.post_program import cycle_time_lines
        from ..operators.runs import find_run

        layout = self.layout
        settings = getattr(context.scene, "flank_settings", None)
        if settings is None:
            return
        col = layout.column(align=True)
        col.prop(settings, "machine")
        if settings.machine == "FILE":
            col.prop(settings, "machine_file")
        col.prop(settings, "post")
        col = layout.column(align=True)
        for name in MACHINING:
            col.prop(settings, name)
        box = layout.box()
        box.label(text="Cutting Data of the Tool", icon='TOOL_SETTINGS')
        col = box.column(align=True)
        for name in CUTTING_DATA:
            col.prop(settings, name)
        col = layout.column(align=True)
        col.prop(settings, "program_filepath")
        col.prop(settings, "program_animate")
        col.prop(settings, "program_read_back")
        coll = find_run(context)
        if isinstance(coll, str):
            layout.label(text="No planning run yet", icon='INFO')
            return
        op = layout.operator("flank.post_program", icon='EXPORT')
        for name, value in post_call(settings, context.scene).items():
            setattr(op, name, value)
        op.collection = coll.name
        lines = cycle_time_lines(coll)
        if lines:
            draw_lines(layout.box(), lines, {1: 'TIME'})
        op = layout.operator("flank.check_program", icon='VIEWZOOM')
        for name, value in check_call(settings).items():
            setattr(op, name, value)
        op.collection = coll.name
        lines = check_lines(coll)
        if lines:
            draw_lines(layout.box(), lines)


classes = (FLANK_PT_machine,)
register, unregister = bpy.utils.register_classes_factory(classes)
