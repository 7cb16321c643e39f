# SPDX-License-Identifier: GPL-3.0-or-later
"""Drawing helpers shared by the panels."""


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
