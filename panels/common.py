# SPDX-License-Identifier: GPL-3.0-or-later
"""Drawing helpers shared by the panels.

The panels draw with box / column / row / label / prop / operator / menu / template_list only and read only
``context.scene`` and ``context.active_object`` (the headless tests call ``draw`` with those)."""
import textwrap

import bpy

SPACE, REGION, CATEGORY = 'VIEW_3D', 'UI', "Flank"
LABEL_WIDTH = 52               # characters per label line: the sidebar at its usual width cuts longer ones off
CONTINUED = "    "             # the indent of a wrapped label's further lines


def warm_up_when_shown():
    """The sidebar tab is shown: import what a first click needs in a worker thread, once (in the background
    there is no interface to keep free, and a script imports what it uses)."""
    if not bpy.app.background:
        from ..operators.jobs import warm_up

        warm_up(__package__.rpartition(".")[0])


def label_lines(text):
    """A label's text as lines of at most ``LABEL_WIDTH`` characters, broken between words (a longer word keeps
    a line of its own), the further lines indented by ``CONTINUED``: a read-back finding or a cycle time note
    is shown whole instead of cut off at the sidebar's edge."""
    return textwrap.wrap(str(text), LABEL_WIDTH, subsequent_indent=CONTINUED, break_long_words=False,
                         break_on_hyphens=False) or [""]


def draw_lines(layout, lines, icons=None):
    """Labels of ``lines``, each wrapped by :func:`label_lines`; ``icons`` maps a line's index to the icon of
    its first label."""
    icons = icons or {}
    for k, text in enumerate(lines):
        for j, part in enumerate(label_lines(text)):
            layout.label(text=part, icon=icons.get(k, 'NONE') if j == 0 else 'NONE')


def settings_and_operator(layout, context, operator, icon, names, prefix=""):
    """Draw the scene settings ``prefix + name`` and a button for ``operator`` that carries them.

    The operator's own properties have the unprefixed names; the scene settings keep the user's
    last values between runs.  Returns the operator properties (or None without settings)."""
    settings = getattr(context.scene, "flank_settings", None)
    if settings is not None:
        col = layout.column(align=True)
        for name in names:
            col.prop(settings, prefix + name)
    op = layout.operator(operator, icon=icon)
    if settings is not None:
        for name in names:
            setattr(op, name, getattr(settings, prefix + name))
    return op


def draw_settings(layout, settings, prefix, groups, active=None):
    """Draw the settings ``prefix + name`` in aligned columns, one per group of names; ``active`` maps a name
    to False where that setting does not apply (drawn greyed out)."""
    active = active or {}
    for names in groups:
        col = layout.column(align=True)
        for name in names:
            if active.get(name, True):
                col.prop(settings, prefix + name)
            else:
                sub = col.column(align=True)
                sub.active = False
                sub.prop(settings, prefix + name)


def strategy_poll(context, *strategies):
    settings = getattr(context.scene, "flank_settings", None)
    return settings is not None and settings.strategy in strategies


def list_prop(obj, key):
    val = obj.get(key)
    if val is None:
        return []
    return list(val.to_list() if hasattr(val, "to_list") else val)


classes = ()
register, unregister = bpy.utils.register_classes_factory(classes)
