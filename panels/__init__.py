# SPDX-License-Identifier: GPL-3.0-or-later
"""Sidebar UI of the Flank Toolpath extension (3D Viewport > Sidebar > "Flank")."""
from .workpiece import FLANK_PT_workpiece

classes = (
    FLANK_PT_workpiece,
)

__all__ = ["classes", "FLANK_PT_workpiece"]
