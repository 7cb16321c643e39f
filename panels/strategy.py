# SPDX-License-Identifier: GPL-3.0-or-later
"""Strategy panel (the machining strategy; its options are the sub-panels of each planner) and the Run panel
(one big button that runs the chosen strategy's planner with the Tool and Strategy settings)."""
import bpy

from .common import CATEGORY, REGION, SPACE, warm_up_when_shown

STRATEGY_TOOL_TEXT = {"SINGLE": "a tapered or cylindrical end mill", "DOUBLE": "the custom (double-flank) tool",
                      "TWO_PATHS": "the custom (double-flank) tool", "FORMED": "a formed disc cutter",
                      "GROOVE": "a paraboloid end mill", "FREEFORM": "a tapered or cylindrical end mill"}


class FLANK_PT_strategy(bpy.types.Panel):
    bl_idname = "FLANK_PT_strategy"
    bl_label = "Strategy"
    bl_space_type = SPACE
    bl_region_type = REGION
    bl_category = CATEGORY
    bl_order = 8

    def draw(self, context):
        from ..operators.properties import STRATEGY_TOOLS

        layout = self.layout
        settings = getattr(context.scene, "flank_settings", None)
        if settings is None:
            return
        col = layout.column(align=True)
        col.prop(settings, "strategy", expand=True)
        if settings.tool_kind not in STRATEGY_TOOLS.get(settings.strategy, ()):
            row = layout.row()
            row.alert = True
            row.label(text="Needs {}".format(STRATEGY_TOOL_TEXT[settings.strategy]), icon='ERROR')


class FLANK_PT_run(bpy.types.Panel):
    bl_idname = "FLANK_PT_run"
    bl_label = "Run"
    bl_space_type = SPACE
    bl_region_type = REGION
    bl_category = CATEGORY
    bl_order = 15
    bl_options = {'HIDE_HEADER'}

    def draw(self, context):
        from ..operators.properties import STRATEGY_ITEMS, STRATEGY_TOOLS
        from ..operators.sources import surface_object, workpiece_object
        from ..operators.ui_ops import run_call

        warm_up_when_shown()                        # this panel has no header: drawn whenever the tab is
        layout = self.layout
        settings = getattr(context.scene, "flank_settings", None)
        if settings is None:
            return
        idname, kw = run_call(settings)
        name = {item[0]: item[1] for item in STRATEGY_ITEMS}[settings.strategy]
        col = layout.column()
        if settings.strategy in ("SINGLE", "DOUBLE", "TWO_PATHS"):
            rotor = workpiece_object(context)
            what = ("flank {}".format(kw["flank"]) if settings.strategy == "SINGLE" and not kw["use_point"] else
                    "flank at the point" if settings.strategy == "SINGLE" else "valley {}".format(kw["valley"]))
            col.label(text="{} of '{}'".format(what, rotor.name) if rotor is not None else "Select a rotor",
                      icon='OBJECT_DATA' if rotor is not None else 'ERROR')
        elif settings.strategy == "FREEFORM":
            obj = surface_object(context)
            ok = obj is not None and obj.type == 'MESH'
            col.label(text="{}'{}'".format("selected faces of " if kw["selected_only"] else "", obj.name) if ok
                      else "Select the surface mesh", icon='OBJECT_DATA' if ok else 'ERROR')
        row = col.row()
        row.scale_y = 1.8
        row.enabled = settings.tool_kind in STRATEGY_TOOLS.get(settings.strategy, ())
        row.operator_context = 'INVOKE_DEFAULT'     # the planners run modal (progress, Esc) when invoked
        op = row.operator(idname, text="Run " + name, icon='PLAY')
        for key, value in kw.items():
            setattr(op, key, value)


classes = (FLANK_PT_strategy, FLANK_PT_run)
register, unregister = bpy.utils.register_classes_factory(classes)
