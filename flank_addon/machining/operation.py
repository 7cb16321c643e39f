"""Whole-rotor operation: every planned strip on every (chosen) lobe, each pass run out past the body.

A plan's strip k is a tool pose (T, a) (tip and axis, :func:`..exports.cl_data.strip_tip`) fixed in the
rotor frame while the rotor screws; relative to the rotor the tool is at S_-t(T, a) at screw parameter t.
On lobe j the pose is turned by 2 pi j / lobes about z (the same strip on the next lobe's flank).

Run-out (why a pass starts and ends clear of the body): at parameter t a tool point q (rotor frame at t = 0)
is at height q_z - v0 t.  With z_lo / z_hi the lowest / highest point of the tool and its shank and the body
z0 <= z <= z1, the pass runs over

    t_a = (z_lo - z1 - c) / v0  ...  t_b = (z_hi - z0 + c) / v0      (c: clearance)

so at t_a the whole tool is c above the body's end face z1 and at t_b c below z0: the pass is extended
along the screw motion past the body's axial extent by the tool's reach + clearance, and every body point
meets the tool exactly as in the infinite sweep of the plan's verification.  Beyond the body only the shafts
and the holders can be met: a tool point at distance rho from the axis whose height over the pass overlaps
such a solid's z range must stay outside it (rho >= its radius); otherwise the pass is refused by name.
"""
import math
from dataclasses import dataclass, field

import numpy as np

from .tool_shape import ToolShape, place_points


class OperationError(ValueError):
    """The plans cannot make one operation (different rotors, a pass into a shaft, bad lobes)."""


@dataclass
class ToolEntry:
    number: int
    shape: ToolShape
    data: object                   # feeds.CuttingData
    name: str
    gauge_length: float            # tip to the end of the shank (or of the cutting part): ToolShape.gauge_length
    rpm: float = 0.0


@dataclass
class Pass:
    plan: int
    strip: int
    lobe: int
    flank: int                     # the rotor flank this pass cuts (the strip's flank turned to the lobe)
    tool: int                      # tool number
    tip: np.ndarray                # pose at t = 0, rotor frame
    axis: np.ndarray
    t_range: tuple                 # (t_a, t_b), t_a < t_b: tool above the body at t_a, below it at t_b
    shaft_margin: float = math.inf  # smallest distance of the tool from a shaft or holder it passes over
    reverse: bool = False          # run from t_b to t_a

    @property
    def label(self):
        return f"plan {self.plan} strip {self.strip} lobe {self.lobe}"

    @property
    def t_start(self):
        return self.t_range[1] if self.reverse else self.t_range[0]

    @property
    def t_end(self):
        return self.t_range[0] if self.reverse else self.t_range[1]


@dataclass
class Operation:
    rotor: object                  # rotor_body.RotorBody
    tools: list
    passes: list
    clearance: float
    lobes: list
    plans: list = field(default_factory=list)

    def tool(self, number):
        return self.tools[number - 1]


def _same_rotor(plans):
    ref = plans[0]["rotor"]
    for i, p in enumerate(plans[1:], 1):
        r = p["rotor"]
        if (r["handedness"] != ref["handedness"] or abs(r["v0"] / ref["v0"] - 1) > 1e-9
                or abs(r["outer_radius"] / ref["outer_radius"] - 1) > 1e-9
                or not np.allclose(r["to_world"], ref["to_world"], atol=1e-9 * ref["outer_radius"])):
            raise OperationError(f"plan {i} is made for another rotor than plan 0 (pitch, hand, outer radius or "
                                 "placement differ): one operation needs plans of one rotor")


def flank_on_lobe(plan, flank, turn, solid=None):
    """Index of the plan's rotor flank that flank ``flank`` turned by ``turn`` (rad) about z lands on
    (``solid``: the plan's :class:`..simulation.collision.ProfileSolid`, made here if not given).  Where ranges
    overlap (a double-flank plan adds its valley's trimmed flanks after the rotor's), the first range holding
    the point: the rotor's own flank, so every lobe is labelled alike."""
    from ..geometry.screw import rotate2d
    from ..simulation.collision import ProfileSolid

    rot = plan["rotor"]
    prof = np.asarray(rot["profile"], float)
    a, b = rot["flanks"][flank]
    mid = prof[((a + b) // 2) % len(prof)]
    solid = solid or ProfileSolid(prof, rot["flanks"])
    _, idx = solid.nearest(rotate2d(mid[None], turn))
    i, n = int(idx[0]), len(prof)
    for k, (a, b) in enumerate(rot["flanks"]):
        if a <= i <= b or a <= i + n <= b:
            return k
    return int(solid.flank_of[i])


# no milling tool, end mill or disc cutter, is longer or wider than this (mm): a larger one is a plan of the wrong
# size, and its surface sampled every millimetre for the checks would not fit in memory
MAX_TOOL_MM = 2000.0


def _check_tool_size(shape, what):
    lo, hi = shape.h_range()
    _, R, _ = shape.outline(max((hi - lo) / 64.0, 1e-9))
    length, width = float(hi - lo), 2.0 * float(R.max())
    if not (length <= MAX_TOOL_MM and width <= MAX_TOOL_MM):
        raise OperationError(f"{what}: its tool is {length:.6g} mm long and {width:.6g} mm across, over the "
                             f"{MAX_TOOL_MM:g} mm of any milling tool: is the plan's size right? (a plan in units of "
                             "R is scaled by --outer-radius-mm)")


def run_out(shape, tip, axis, rotor, clearance, spacing=1.0, local=None, detail=False):
    """(t_a, t_b, shaft margin) of the pose (module doc); margin = smallest rho - radius over the tool points
    that pass over a shaft or a holder (inf when none does); with ``detail`` also the name of that solid.
    ``local``: the shape's surface points if known."""
    # in the frame that turns with the screw: the read-back samples the same points at its own pose of the pass
    pts = place_points(shape.local_points(spacing) if local is None else local, tip, axis, facing=True)[0]
    z0, z1 = rotor.z_range
    lo, hi = shape.z_extent(tip, axis)
    t_a = (float(lo[0]) - z1 - clearance) / rotor.v0
    t_b = (float(hi[0]) - z0 + clearance) / rotor.v0
    # each point's heights over the pass
    margin, worst = rotor.keep_out_clearance(np.hypot(pts[:, 0], pts[:, 1]), pts[:, 2] - rotor.v0 * t_b,
                                             pts[:, 2] - rotor.v0 * t_a)
    if detail:
        return float(t_a), float(t_b), margin, (None if worst is None else rotor.keep_out_names[worst])
    return float(t_a), float(t_b), margin


def nearest_keep_out(shape, tip, axis, rotor, clearance, local=None):
    """(name, advice) of the shaft or holder a pass of the pose comes nearest to, for messages: the advice is
    "; move the holder away from the body" for a holder, "" for a shaft (:func:`run_out`)."""
    hit = run_out(shape, tip, axis, rotor, clearance, local=local, detail=True)[3]
    return hit, ("; move the holder away from the body" if hit is not None and hit.startswith("holder") else "")


def repeats_earlier_strip(plan, s):
    """Whether strip ``s`` moves the same tool solid along the same axis as an earlier strip of the plan (a
    two-paths plan that kept the double-flank axis for both paths): the earlier strip's pass has cut all it
    cuts, so it is cut once, as the verification sweeps it once (:func:`..simulation.sweep.strip_solids`)."""
    from ..io.plan import strip_tool
    from ..simulation.sweep import solid_key

    key = solid_key(plan["strips"][s])
    tool = strip_tool(plan, s)
    return any(solid_key(plan["strips"][j]) == key and strip_tool(plan, j) == tool for j in range(s))


def checked_lobes(lobes, rotor):
    """``lobes`` (indices, or None for all) as a sorted list of the rotor's lobes; OperationError naming any that
    the rotor does not have, or an empty list."""
    lobes = list(range(rotor.lobes)) if lobes is None else sorted(set(int(k) for k in lobes))
    bad = [k for k in lobes if not 0 <= k < rotor.lobes]
    if bad or not lobes:
        raise OperationError(f"lobes {bad or lobes} are not lobes of this rotor (0..{rotor.lobes - 1})")
    return lobes


def build_operation(plans, rotor, lobes=None, clearance=5.0, cutting_data=None):
    """The :class:`Operation` of rotor ``plans`` (mm) on ``rotor`` (:class:`RotorBody`).

    A strip that repeats an earlier one (:func:`repeats_earlier_strip`) gets no passes of its own.
    lobes: lobe indices to cut (default all); clearance: run-out beyond the body's end faces and the
    margin of every link (mm); cutting_data: one :class:`feeds.CuttingData` for every tool, or a function of the
    plan's tool dict (:func:`feeds.with_overrides`) (default: per tool, :func:`feeds.cutting_data_for`)."""
    from .feeds import resolve_cutting_data

    if not plans:
        raise OperationError("no plan given")
    _same_rotor(plans)
    if not (isinstance(clearance, (int, float)) and math.isfinite(clearance) and clearance > 0):
        raise OperationError(f"clearance {clearance!r} must be a finite number > 0 (mm)")
    lobes = checked_lobes(lobes, rotor)
    from ..exports.cl_data import strip_tip
    from ..io.plan import strip_tool
    from ..geometry.screw import screw_motion
    from ..simulation.collision import ProfileSolid

    tools, by_sig, passes, local = [], {}, [], {}
    for p, plan in enumerate(plans):
        if not plan["strips"]:
            raise OperationError(f"plan {p} has no strips")
        solid = ProfileSolid(np.asarray(plan["rotor"]["profile"], float), plan["rotor"]["flanks"])
        for s in range(len(plan["strips"])):
            shape = ToolShape.from_strip(plan, s)
            sig = shape.signature()
            if repeats_earlier_strip(plan, s):
                continue
            if sig not in by_sig:
                _check_tool_size(shape, f"plan {p} strip {s}")       # before its surface is sampled, below
                stool = strip_tool(plan, s)          # the strip's own tool in a plan with several
                data = resolve_cutting_data(cutting_data, stool)
                label = stool.get("name") or stool.get("kind", "tool")
                shape.name = f"T{len(tools) + 1} {label} ({plan.get('method', '?')})"
                tools.append(ToolEntry(len(tools) + 1, shape, data, shape.name, shape.gauge_length()))
                by_sig[sig] = len(tools)
                local[len(tools)] = shape.local_points(1.0)
            number = by_sig[sig]
            T, a, _ = strip_tip(plan, s)
            for k in lobes:
                turn = rotor.lobe_angle(k)
                tip = screw_motion(T, turn, 0.0, "right")
                axis = screw_motion(a, turn, 0.0, "right")
                t_a, t_b, margin = run_out(tools[number - 1].shape, tip, axis, rotor, clearance, local=local[number])
                ps = Pass(p, s, k, flank_on_lobe(plan, plan["strips"][s]["flank"], turn, solid), number, tip, axis,
                          (t_a, t_b), margin)
                if margin < 0:
                    hit, advice = nearest_keep_out(tools[number - 1].shape, tip, axis, rotor, clearance,
                                                   local[number])
                    raise OperationError(f"pass {ps.label}: running out past the body the tool enters {hit} by "
                                         f"{-margin:.3g} mm (it comes closer to the rotor axis than its radius); "
                                         f"such a strip cannot run out beyond the end faces{advice}")
                passes.append(ps)
    return Operation(rotor=rotor, tools=tools, passes=passes, clearance=float(clearance), lobes=lobes,
                     plans=list(plans))
