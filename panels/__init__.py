# SPDX-License-Identifier: GPL-3.0-or-later
"""Sidebar UI of the Flank Toolpath extension (3D Viewport > Sidebar > "Flank")."""
from .workpiece import FLANK_PT_workpiece
from .verify import FLANK_PT_verify
from .paraboloid import FLANK_PT_paraboloid
from .formed_cutter import FLANK_PT_formed_cutter
from .double_flank import FLANK_PT_double_flank
from .single_flank import FLANK_PT_single_flank
from .results import FLANK_PT_results

classes = (
    FLANK_PT_workpiece,
    FLANK_PT_verify,
    FLANK_PT_paraboloid,
    FLANK_PT_formed_cutter,
    FLANK_PT_double_flank,
    FLANK_PT_single_flank,
    FLANK_PT_results,
)

__all__ = ["classes", "FLANK_PT_workpiece", "FLANK_PT_verify", "FLANK_PT_paraboloid", "FLANK_PT_formed_cutter",
           "FLANK_PT_double_flank", "FLANK_PT_single_flank", "FLANK_PT_results"]
