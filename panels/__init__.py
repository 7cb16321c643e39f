# SPDX-License-Identifier: GPL-3.0-or-later
"""Sidebar UI of the Flank Toolpath extension (3D Viewport > Sidebar > "Flank"), in workflow order:
Workpiece, Tool, Strategy (with one sub-panel per strategy, shown for the chosen one), Run, Results, Verify.
Parents are registered before their sub-panels."""
from .workpiece import FLANK_PT_workpiece
from .tool import FLANK_PT_tool
from .strategy import FLANK_PT_strategy, FLANK_PT_run
from .single_flank import FLANK_PT_single_flank
from .double_flank import FLANK_PT_double_flank
from .formed_cutter import FLANK_PT_formed_cutter
from .paraboloid import FLANK_PT_paraboloid
from .freeform import FLANK_PT_freeform
from .results import FLANK_PT_results
from .verify import FLANK_PT_verify

classes = (
    FLANK_PT_workpiece,
    FLANK_PT_tool,
    FLANK_PT_strategy,
    FLANK_PT_single_flank,
    FLANK_PT_double_flank,
    FLANK_PT_formed_cutter,
    FLANK_PT_paraboloid,
    FLANK_PT_freeform,
    FLANK_PT_run,
    FLANK_PT_results,
    FLANK_PT_verify,
)

__all__ = ["classes", "FLANK_PT_workpiece", "FLANK_PT_tool", "FLANK_PT_strategy", "FLANK_PT_run",
           "FLANK_PT_single_flank", "FLANK_PT_double_flank", "FLANK_PT_formed_cutter", "FLANK_PT_paraboloid",
           "FLANK_PT_freeform", "FLANK_PT_results", "FLANK_PT_verify"]
