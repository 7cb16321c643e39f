"""Read a posted program back and check it against its plans: poses, deviation, clearance, cycle time.

1. The dialect's reader (:meth:`base.Post.read`) turns the text into moves; the machine's forward kinematics
   (:meth:`machining.machine.Machine.forward`) turns every program row into a rotor-frame tool pose (tip P,
   axis a).
2. Passes are the runs of consecutive feed moves.  A pass is a screw motion when every pose maps back onto
   the first one: with dt_k = (P_0,z - P_k,z) / v0, S_dt_k(P_k) = P_0 and Rz(hand dt_k) a_k = a_0
   (``screw_error``: the program's rounding, or a pass that is not the rotor's screw, such as a wrong pitch);
   between the block ends the controller's interpolation is sampled the same way (``interpolation_error``: 0
   for joint-linear passes, the chord sagitta with TCP).  A pass whose block ends leave that screw by more
   than the matching tolerance (``MATCH_TOL_MM``) is not what any strip says, whatever its first pose: a
   finding names it; so does one whose interpolation leaves it by more (chords too long).
3. Each pass is matched to the plan strip and lobe whose pose it is, modulo the screw (no comment is
   trusted); every strip must appear once per lobe with the tool number the post gave its solid (a strip
   that repeats an earlier one, :func:`..machining.operation.repeats_earlier_strip`, is cut by that one's
   pass).  A pass that matches no strip still cuts: it is swept on the lobe of the strip it is nearest to.
4. Deviation: for every plan and lobe, the lobe's passes are turned back by -2 pi lobe / lobes and the plan
   is verified with them instead of its own strips (:func:`..simulation.verify.verify_plan`, the sweep
   simulation); the difference to the plan's own verified deviation, point by point, is what the program
   changes (points where the sweep's sampling is too coarse to tell are simulated again, finer:
   :func:`lobe_deviation`).  The sweep is the infinite screw motion through each pass's first pose, valid
   because the pass runs out beyond the body (5) and follows that screw (2).  ``pose_difference`` bounds the
   change without sampling the surface: how far a pass's first pose is from the plan's, plus how far its
   other poses leave the screw through it (2), so no tool point of the pass, and no point of the machined
   surface, is farther than that from where the plan puts it.
5. Run-out: at its first and last pose the whole tool (and shank) must be beyond the body's end faces.
6. Every other move (rapids, links) is checked against the stock cylinder, the shafts and the holders
   (:func:`machining.toolpath.segment_intrusion`); the passes against the shafts and the holders
   (:func:`keep_out_margin`); a return to the reference position (Fanuc G28) as the straight move of its axis
   to the machine file's ``reference_position``, or without one to the end of its travel.  The moves out of a tool change start where the machine
   file's ``tool_change_position`` leaves the machine (:func:`machining.cycle_time.move_joints`); without
   one their start is unknown and they are counted as ``unchecked``.
7. Cycle time from the moves as the controller times them (:mod:`machining.cycle_time`).  The spindle: every
   feed move must cut with it turning clockwise (M3, as the posts turn the tools, which cut right-hand) at a
   speed above 0 and within the machine's top speed (:func:`spindle_check`); every move of a tool that moves a
   linear axis, with the length compensation of that tool (G43 H<n>; a Klartext TOOL CALL gives it)
   (:func:`length_check`); every feed move with coolant, or without it in a program posted to cut dry
   (:func:`coolant_check`); one work offset throughout
   (:func:`work_offset_check`); every move within the machine's axis limits (:func:`axis_limit_check`: the
   block ends, and with TCP points between them, where the joints are not linear in the program's values).
8. Cutting conditions (:func:`cutting_check`): every feed move's chip load, surface speed and spindle speed
   from what the controller does with the program (its S, and the block's time as the controller computes it
   from F, :mod:`machining.cycle_time`), against the tool's cutting data (the same data the post is given;
   by default each tool's, :func:`..machining.feeds.cutting_data_for`).  A screw motion moves every rotor
   point q past the tool at omega |v(q)|, |v(q)| = sqrt(rho(q)^2 + v0^2) per radian of the screw parameter,
   and a block turns the screw by |dz| / v0 in its time T: chip load = (|dz| / v0 / T) max |v| / (n z) over
   the engaged edge (:mod:`..machining.feeds`), surface speed pi D_max n / 1000.
9. ``findings``: every way the program differs from its plans or cuts where it must not
   (:func:`program_findings`); the command exits with status 1 when there is any.
"""
import math
import re
import time

import numpy as np

from ..geometry.screw import screw_motion
from ..machining.cycle_time import block_times, cycle_time, move_joints
from ..machining.feeds import engagement
from ..machining.operation import checked_lobes, repeats_earlier_strip
from ..machining.tool_shape import ToolShape, place_points
from ..machining.toolpath import COOLANTS, lift_rows, segment_intrusion
from ..simulation.verify import profile_normals, verify_plan

# mm: a pass is a strip's when its first pose is this near the strip's (modulo the screw) and its other poses
# stay this near the screw through its first pose (the programs' own rounding is 0.0001 mm and 0.0001 deg)
MATCH_TOL_MM = 1e-2
# a chip load or surface speed this much (relative) over the cutting data is a finding, beyond the rounding of S
# to whole turns (half a turn: 0.5 / S relative; the posts round down) and of a block's screw advance (below)
CUTTING_TOL = 1e-3
# mm: what the rounding of a program's numbers (0.0001 mm, 0.0001 deg at up to a metre from a pivot) can move a
# block's screw advance |dz| by; a short TCP chord's chip load is judged on |dz| less this
ADVANCE_ROUNDING_MM = 1e-3


def empty_program(text, name):
    """The message for a program ``name`` whose text has no block to read (blank lines and the tape's '%'
    markers only: a file that ends up so after a failed transfer is not a program that cuts nothing, but no
    program), else None."""
    if text.replace("%", "").strip():
        return None
    return f"{name} is empty" + (" but for '%' lines" if text.strip() else "") + ": no program to check"


# an axis word of the program (a Klartext word may carry its sign, a G-code word its minus) and an F word
_AXIS_WORD = re.compile(r"(?<![A-Z])([XYZABC])[-+]?[0-9]*\.([0-9]+)")
_FEED_WORD = re.compile(r"(?<![A-Z])F[0-9]*\.([0-9]+)")


def finer_than_increments(text, post, machine):
    """Lines (1-based) whose axis or F words carry more decimals than the machine file's least input increments
    (``controller.increment_mm`` / ``increment_deg``; F against the length increment): a program posted without
    them, whose extra digits the control may drop or refuse.  [] when the file gives no increment."""
    from ..machining.machine import increment_decimals

    lin = None if machine.increment_mm is None else increment_decimals(machine.increment_mm)
    rot = None if machine.increment_deg is None else increment_decimals(machine.increment_deg)
    if lin is None and rot is None:
        return []
    out = []
    for no, line in enumerate(text.splitlines(), 1):
        # the words of the block: comments out ('(...)' in G-code, ';' to the end in Klartext and LinuxCNC)
        code = re.sub(r"\([^)]*\)", "", line.split(";")[0]) if post.name != "heidenhain" else line.split(";")[0]
        too_fine = any(len(dec) > (lin if letter in "XYZ" else rot)
                       for letter, dec in _AXIS_WORD.findall(code) if (lin if letter in "XYZ" else rot) is not None)
        if too_fine or (lin is not None and any(len(dec) > lin for dec in _FEED_WORD.findall(code))):
            out.append(no)
    return out


def tool_table(plans):
    """{number: ToolShape} numbered as :func:`machining.operation.build_operation` numbers them, and
    {(plan, strip): number}."""
    table, by_sig, of_strip = {}, {}, {}
    for p, plan in enumerate(plans):
        for s in range(len(plan["strips"])):
            shape = ToolShape.from_strip(plan, s)
            sig = shape.signature()
            if sig not in by_sig:
                by_sig[sig] = len(by_sig) + 1
                table[by_sig[sig]] = shape
            of_strip[p, s] = by_sig[sig]
    return table, of_strip


def tool_cutting_data(plans, cutting_data=None):
    """{number: CuttingData} of the tools of :func:`tool_table`, as the post chose them: ``cutting_data`` for
    every tool when it is one CuttingData, each tool's own (:func:`..machining.feeds.cutting_data_for`) when
    None, or a function of the plan's tool dict (:func:`..machining.feeds.with_overrides`)."""
    from ..io.plan import strip_tool
    from ..machining.feeds import resolve_cutting_data

    _, of_strip = tool_table(plans)
    out = {}
    for (p, s), n in of_strip.items():
        if n not in out:
            out[n] = resolve_cutting_data(cutting_data, strip_tool(plans[p], s))
    return out


def tool_gauges(tools):
    """{number: gauge length} of a :func:`tool_table`: tip to gauge line (:meth:`ToolShape.gauge_length`)."""
    return {n: s.gauge_length() for n, s in tools.items()}


def _map_to_level(P, a, z, v0, hand):
    """The pose (P, a) screwed along the rotor's screw until its tip is at height z."""
    t = (z - P[..., 2]) / v0
    return screw_motion(P, t, v0, hand), screw_motion(a, t, 0.0, hand)


def read_passes(read, machine, tools, rotor, samples=8):
    """Passes of a read-back program: dicts with rows, poses (rotor-frame tips and axes at the block ends), tool,
    line, screw and interpolation error."""
    passes, cur = [], []
    for mv in read.moves + [None]:
        if mv is not None and mv.kind == "feed" and (not cur or cur[-1].tool == mv.tool):
            cur.append(mv)
            continue
        if cur:
            passes.append(cur)
        cur = [mv] if mv is not None and mv.kind == "feed" else []
    out = []
    for group in passes:
        tool = group[0].tool
        if tool == 0:
            raise ValueError(f"line {group[0].line}: a cut with no tool in the spindle (no T word before it)")
        if tool not in tools:
            raise ValueError(f"line {group[0].line}: tool T{tool} is not a tool of these plans "
                             f"(T{', T'.join(map(str, sorted(tools)))})")
        shape = tools[tool]
        gauge = shape.gauge_length()
        rows = np.array([group[0].start] + [mv.end for mv in group])
        if not np.isfinite(rows).all():
            raise ValueError(f"line {group[0].line}: a feed move starts from an unknown position")
        P, A = machine.forward(rows, gauge)
        reach = max(abs(shape.h_range()[0]), abs(shape.h_range()[1]))
        Q, B = _map_to_level(P, A, P[0, 2], rotor.v0, rotor.hand)
        screw_err = float(np.max(np.linalg.norm(Q - P[0], axis=1) + reach * np.linalg.norm(B - A[0], axis=1)))
        f = (np.arange(1, samples + 1) / (samples + 1))[:, None, None]
        inner = ((1 - f) * rows[None, :-1] + f * rows[None, 1:]).reshape(-1, rows.shape[1])
        Pi, Ai = machine.forward(inner, gauge)
        Qi, Bi = _map_to_level(Pi, Ai, P[0, 2], rotor.v0, rotor.hand)
        interp_err = float(np.max(np.linalg.norm(Qi - P[0], axis=1) + reach * np.linalg.norm(Bi - A[0], axis=1)))
        out.append({"tool": tool, "line": group[0].line, "rows": rows, "poses": (P, A), "tip": P[0], "axis": A[0],
                    "t_span": float((P[0, 2] - P[-1, 2]) / rotor.v0), "ends": (P[[0, -1]], A[[0, -1]]),
                    "screw_error": screw_err, "interpolation_error": interp_err, "moves": group})
    return out


def _reference_poses(plans, rotor):
    from ..exports.cl_data import strip_tip

    refs = []
    for p, plan in enumerate(plans):
        for s in range(len(plan["strips"])):
            T, a, _ = strip_tip(plan, s)
            for k in range(rotor.lobes):
                turn = rotor.lobe_angle(k)
                refs.append((p, s, k, screw_motion(T, turn, 0.0, "right"), screw_motion(a, turn, 0.0, "right")))
    return refs


def match_passes(passes, plans, rotor, tools, of_strip, tol=MATCH_TOL_MM):
    """Give every read pass its (plan, strip, lobe): the reference pose it equals modulo the screw."""
    refs = _reference_poses(plans, rotor)
    for ps in passes:
        best = None
        reach = max(abs(x) for x in tools[ps["tool"]].h_range())
        for p, s, k, T, a in refs:
            Q, B = _map_to_level(ps["tip"], ps["axis"], T[2], rotor.v0, rotor.hand)
            d = float(np.linalg.norm(Q - T) + reach * np.linalg.norm(B - a))
            if best is None or d < best[0]:
                best = (d, p, s, k)
        d, p, s, k = best
        ps["match"] = (p, s, k) if d <= tol and of_strip[p, s] == ps["tool"] else None
        ps["nearest"] = (p, s, k)
        ps["match_distance"] = d
    return passes


def run_out(ps, tools, rotor):
    """(start clearance, end clearance) in mm beyond the body's end faces (negative: inside the body)."""
    P, A = ps["ends"]
    lo, hi = tools[ps["tool"]].z_extent(P, A)
    z0, z1 = rotor.z_range
    if ps["t_span"] > 0:                                   # the tool runs down the rotor's z
        return float(lo[0] - z1), float(z0 - hi[1])
    return float(z0 - hi[0]), float(lo[1] - z1)


def keep_out_margin(ps, tools, rotor, spacing=1.0):
    """Smallest distance (mm) by which the tool of a read pass stays out of the shafts and holders it passes
    over (:attr:`..machining.rotor_body.RotorBody.keep_out`), negative inside one; inf when it passes over
    none.  The pass is a screw motion: every tool point keeps its distance rho from the axis while its height
    moves by -v0 t_span, so a point counts against a solid whose z range that height span meets (as the
    operation checks its passes, :func:`..machining.operation.run_out`); the controller's interpolation error
    (TCP chords) is taken off."""
    if not rotor.keep_out:
        return math.inf
    P, A = ps["ends"]
    pts = place_points(tools[ps["tool"]].local_points(spacing), P[0], A[0], facing=True)[0]
    z0, z1 = pts[:, 2], pts[:, 2] - rotor.v0 * ps["t_span"]
    margin, _ = rotor.keep_out_clearance(np.hypot(pts[:, 0], pts[:, 1]), np.minimum(z0, z1), np.maximum(z0, z1))
    return margin - ps["interpolation_error"]


def fine_deviation(plan, strips, idx, refine=16):
    """Deviation at profile points ``idx`` of the plan's rotor milled by ``strips``, by the sweep with its time
    sampling ``refine`` times denser (:func:`..simulation.sweep.machined_deviation`; the tools' feature size,
    which sets the step along each helix, divided by ``refine``)."""
    from ..simulation.sweep import machined_deviation, strip_solids

    rot = plan["rotor"]
    prof, normals = profile_normals(rot)
    tools, _ = strip_solids(strips)          # a strip repeated (a two-paths fallback) is swept once
    for t in tools:
        t.feature /= refine
    return machined_deviation(tools, prof[idx], normals[idx], float(rot["v0"]), rot["handedness"],
                              max_deviation=0.1 * float(rot["outer_radius"]))


def lobe_deviation(plan, p, passes, tools, rotor, lobe, reference, recheck=1e-3):
    """Deviation of the plan's target flanks milled by this lobe's passes turned back onto lobe 0, compared
    with the plan's own (``reference`` = verify_plan of the plan).  Each pass' pose is screwed along its own
    orbit to the height of its plan strip (the infinite sweep is the same from any point of the orbit).

    The sweep samples every helix in steps of a quarter of the tool's smallest radius, so where a helix only
    grazes the tool (a narrow dip of the distance along it) a pose change far below the step can change the
    sampled minimum, and the deviation, by tens of micrometres.  Points whose two deviations differ by more
    than ``recheck`` (or where only one is covered) are therefore simulated again, plan and program alike,
    with 16 times denser sampling (:func:`fine_deviation`); the differences reported are those."""
    from ..exports.cl_data import strip_tip

    turn = -rotor.lobe_angle(lobe)
    strips, pose_diff, unmatched = [], 0.0, 0
    for ps in passes:
        # a pass that matches no strip still cuts: it is swept with the lobe of the strip it is nearest to
        mine = ps["match"] if ps.get("match") is not None else ps.get("nearest")
        if mine is None or mine[0] != p or mine[2] != lobe:
            continue
        unmatched += ps.get("match") is None
        k = mine[1]
        src = plan["strips"][k]
        tip = screw_motion(ps["tip"], turn, 0.0, "right")
        axis = screw_motion(ps["axis"], turn, 0.0, "right")
        T, a, _ = strip_tip(plan, k)
        tip, axis = _map_to_level(tip, axis, T[2], rotor.v0, rotor.hand)
        reach = max(abs(x) for x in tools[ps["tool"]].h_range())
        off_screw = max(ps["screw_error"], ps["interpolation_error"])      # the other poses, from the first's screw
        pose_diff = max(pose_diff, float(np.linalg.norm(tip - T) + reach * np.linalg.norm(axis - a)) + off_screw)
        extra = {key: src[key] for key in ("flank", "reported_max_error", "reported_min_error", "collision")}
        strips.append(tools[ps["tool"]].strip_at(tip, axis, extra))
    if not strips:
        return None
    prog = dict(plan, strips=strips)
    res = verify_plan(prog)
    ref = {i: d for i, _, _, d in reference["deviation_profile"]}
    got = {i: d for i, _, _, d in res["deviation_profile"]}
    diff, coarse, again = {}, 0.0, []
    for i, d in got.items():
        r = ref.get(i)
        if d is None and r is None:
            continue
        if d is None or r is None or abs(d - r) > recheck:
            again.append(i)
            coarse = max(coarse, math.inf if (d is None) != (r is None) else abs(d - r))
        else:
            diff[i] = abs(d - r)
    mismatch = 0
    if again:
        idx = np.array(sorted(again))
        a_plan, a_prog = fine_deviation(plan, plan["strips"], idx), fine_deviation(plan, strips, idx)
        for i, x, y in zip(idx, a_plan, a_prog):
            if np.isfinite(x) != np.isfinite(y):
                mismatch += 1
            elif np.isfinite(x):
                diff[int(i)] = abs(float(y - x))
    return {"lobe": lobe, "passes": len(strips), "unmatched_passes": unmatched,
            "max_deviation_difference_mm": max(diff.values(), default=0.0),
            "pose_difference_mm": pose_diff, "rechecked_points": len(again),
            "coarse_max_difference_mm": coarse, "coverage_mismatches": mismatch,
            "max_undercut_mm": res["max_undercut"], "max_overcut_mm": res["max_overcut"],
            "gouge_points": len(res["gouge_points"])}


def spindle_check(read, machine):
    """Feed moves that cut without the spindle as the posts turn it: stopped (M5, or not started again after a
    tool change), counter-clockwise (M4), at S0 or faster than the machine's top speed (lines; the slowest and
    fastest S).  The posts write S in whole turns per minute: half a turn over the top speed is their rounding."""
    feeds = [mv for mv in read.moves if mv.kind == "feed"]
    return {"stopped": [mv.line for mv in feeds if mv.spindle == "off"],
            "counter_clockwise": [mv.line for mv in feeds if mv.spindle == "ccw"],
            "no_speed": [mv.line for mv in feeds if not mv.rpm > 0],
            "over_top_speed": [mv.line for mv in feeds if mv.rpm > machine.max_rpm + 0.5],
            "min_rpm": min((mv.rpm for mv in feeds), default=None),
            "max_rpm": max((mv.rpm for mv in feeds), default=None), "machine_max_rpm": machine.max_rpm}


def cutting_check(passes, machine, rotor, tools, data):
    """Chip load, surface speed and spindle speed of every feed move of the read ``passes`` (module doc, 8)
    against the cutting data ``data`` ({tool number: CuttingData}): per tool the largest of each, and the lines
    of the moves over the tool's fz, vc or top speed (beyond half a turn of S, for posts that round it to the
    nearest turn, and :data:`CUTTING_TOL`).  A move
    without a spindle speed is :func:`spindle_check`'s finding, not one of these (it is counted as not checked).
    The engaged edge is taken at the pass's first pose in the stock (a screw motion keeps it).  A pass off the
    screw (a finding of its own) is not judged for its chip load: the screw's advance per block, which measures
    it, says nothing of a plunge or a turn of the rotary axes alone (read as none); its lines are listed in
    ``chip_load_not_judged``.  Its surface and spindle speeds are judged, over all its poses."""
    gauges = tool_gauges(tools)
    per_tool, over = {}, {"over_chip_load": [], "over_surface_speed": [], "over_tool_top_speed": []}
    not_judged = []
    for ps in passes:
        n, moves = ps["tool"], ps["moves"]
        d, shape = data[n], tools[n]
        P, A = ps["poses"]                      # rotor-frame poses at the block ends (:func:`read_passes`)
        v_max = d_max = 0.0                     # a pass that never enters the stock loads nothing
        on_screw = ps["screw_error"] <= MATCH_TOL_MM
        for k in range(len(P)):                 # on the screw one pose in the stock stands for all; else every one
            eng = engagement(shape, P[k], A[k], rotor)
            if eng.diameter > 0:                # engaged, if only by a graze between two sampled rings
                v_max, d_max = max(v_max, eng.speed), max(d_max, eng.diameter)
                if on_screw:
                    break
        turn = np.abs(np.diff(P[:, 2])) / rotor.v0                  # screw parameter of each block, rad
        minutes = block_times(moves, machine, gauges)
        rpm = np.array([mv.rpm for mv in moves], float)
        ok = (rpm > 0) & (minutes > 0)
        chip = np.where(ok, turn / np.where(ok, minutes, 1.0) * v_max / (np.where(ok, rpm, 1.0) * d.flutes), 0.0)
        vc = math.pi * d_max * rpm / 1000.0
        t = per_tool.setdefault(n, {"tool": n, "cutting_data": d.as_dict(), "max_chip_load_mm": 0.0,
                                    "max_surface_speed_m_min": 0.0, "max_rpm": 0.0, "moves_over": dict.fromkeys(over, 0),
                                    "moves_without_speed": 0, "moves_chip_load_not_judged": 0})
        if not on_screw:                        # the screw's advance measures no chip here: not judged
            chip = np.zeros_like(chip)
            not_judged += [mv.line for mv in moves]
            t["moves_chip_load_not_judged"] += len(moves)
        t["moves_without_speed"] += int(np.sum(~(rpm > 0)))
        t["max_chip_load_mm"] = max(t["max_chip_load_mm"], float(chip.max()))
        t["max_surface_speed_m_min"] = max(t["max_surface_speed_m_min"], float(vc.max()))
        t["max_rpm"] = max(t["max_rpm"], float(rpm.max()))
        lines = np.array([mv.line for mv in moves])
        # half a turn of S: a post that rounds S to the nearest turn gives F for the speed before rounding
        rounding = 1.0 + 0.5 / np.where(ok, rpm, 1.0)
        # the rounding allowance is never more than 1% of a block's advance: a tiny block is still judged
        surely = chip * np.maximum(turn - ADVANCE_ROUNDING_MM / rotor.v0, 0.99 * turn) / np.where(turn > 0, turn, 1.0)
        for key, bad in (("over_chip_load", surely > d.fz_mm * (1 + CUTTING_TOL) * rounding),
                         ("over_surface_speed", vc > d.vc_m_min * (1 + CUTTING_TOL) + math.pi * d_max * 0.5 / 1000.0),
                         ("over_tool_top_speed", rpm > d.max_rpm + 0.5)):
            over[key] += lines[bad].tolist()
            t["moves_over"][key] += int(bad.sum())
    return {"tools": [per_tool[n] for n in sorted(per_tool)], **{k: sorted(v) for k, v in over.items()},
            "chip_load_not_judged": sorted(not_judged)}


def coolant_check(read, coolant="flood"):
    """Feed moves against the coolant the program was posted with (lines), as the reader follows it.  With coolant
    (flood or mist: the posts turn it on with every tool, M8 / M7, Klartext M13), a cut without any is an M9, a
    program stop or an M2 / M30 before it ("off"; mist where flood was posted, or the other way round, is coolant
    too: a shop's choice).  Posted dry, a cut with coolant on is a finding as well ("on")."""
    feeds = [mv for mv in read.moves if mv.kind == "feed"]
    dry = coolant == "off"
    return {"expected": coolant, "off": [] if dry else [mv.line for mv in feeds if mv.coolant == "off"],
            "on": [mv.line for mv in feeds if mv.coolant not in ("off", "")] if dry else []}


def length_check(read):
    """Moves of a tool that move a linear axis (every cut, and rapids that are not a rotary turn alone) without
    that tool's length compensation: none active, or another tool's (lines; the first (H, T) of those)."""
    none, other = [], []
    for mv in read.moves:
        if mv.tool <= 0:
            continue                # before any tool: nothing to compensate
        start, end = np.asarray(mv.start[:3], float), np.asarray(mv.end[:3], float)
        linear = mv.kind == "feed" or not np.array_equal(start, end, equal_nan=True)
        if not linear or mv.length_comp == mv.tool:
            continue
        (none if mv.length_comp is None else other).append(mv)
    return {"without": [mv.line for mv in none], "other_tool": [mv.line for mv in other],
            "first_other": [other[0].length_comp, other[0].tool] if other else None}


def tcp_check(read, machine):
    """Moves made in the other TCP mode than the machine's (lines): with TCP on (Fanuc G43.4, Klartext FUNCTION
    TCPM) on a machine without it, or off on a machine with it.  The control then reads the program's joint
    values as tool-tip positions, or the other way round, and the tool goes elsewhere than the read-back, which
    maps every move through the machine file's kinematics, puts it.  (rs274ngc has no TCP word: a LinuxCNC
    program's moves are in the machine's mode.)"""
    return {"machine_tcp": machine.tcp, "other_mode": [mv.line for mv in read.moves if mv.tcp != machine.tcp]}


def work_offset_check(read):
    """Where the program's zero changes: the work offsets its moves are made in, in order, and the line of each
    change (a program posted for one offset, G54 at the rotor-frame origin, never changes it)."""
    offsets, changes = [], []
    for mv in read.moves:
        if mv.work_offset and (not offsets or offsets[-1] != mv.work_offset):
            if offsets:
                changes.append(mv.line)
            offsets.append(mv.work_offset)
    return {"offsets": offsets, "changes_at": changes}


def axis_limit_check(read, machine, gauges, samples=8):
    """Where the program takes an axis beyond the machine's limits: per axis its farthest value out and the
    line, [] when every move stays inside.  Joint values at the block ends (as the machine stands, known or
    not: :func:`..machining.cycle_time.move_joints`), and on a TCP machine at ``samples`` points between them."""
    J0, J1 = move_joints(read, machine, gauges)
    rows, lines = [J1, J0], [np.array([mv.line for mv in read.moves], int)] * 2      # a value where a move ends it
    if machine.tcp and read.moves:
        f = (np.arange(1, samples + 1) / (samples + 1))[None, :, None]
        S = np.array([mv.start for mv in read.moves], float)
        E = np.array([mv.end for mv in read.moves], float)
        tools = np.array([mv.tool for mv in read.moves], int)
        known = np.isfinite(S).all(axis=1) & np.isfinite(E).all(axis=1)
        for t in np.unique(tools[known]):                  # one kinematics call per tool
            k = np.flatnonzero(known & (tools == t))
            inner = ((1 - f) * S[k, None, :] + f * E[k, None, :]).reshape(-1, S.shape[1])
            rows.append(machine.machine_joints(inner, gauges.get(int(t), 0.0)))
            lines.append(np.repeat([read.moves[i].line for i in k], samples))
    J, at = np.concatenate(rows), np.concatenate(lines)
    out = []
    for i, n in enumerate(machine.axis_names):
        ax, col = machine.axes[n], J[:, i]
        known = np.isfinite(col)
        over = np.where(known, np.maximum(ax.min - col, col - ax.max), -np.inf)
        k = int(np.argmax(over)) if len(col) else 0
        if len(col) and over[k] > 1e-9:
            out.append({"axis": n, "value": float(col[k]), "min": ax.min, "max": ax.max, "line": int(at[k])})
    return out


def check_links(read, machine, tools, rotor, step=1.0, spacing=1.5):
    """Intrusion of every non-cutting move into the stock, the shafts or the holders, and of every return to the
    reference position (:func:`..machining.toolpath.lift_rows`)."""
    segments, unchecked = [], 0             # (line, tool, start row, end row) of every move to check
    gauges = tool_gauges(tools)
    J0, J1 = move_joints(read, machine, gauges)
    for i, mv in enumerate(read.moves):
        if mv.kind == "feed" or mv.tool not in tools:
            continue
        start, end = np.asarray(mv.start, float), np.asarray(mv.end, float)
        if not (np.isfinite(start).all() and np.isfinite(end).all()):
            # out of a tool change: from where the machine stands, as joints (program rows of them)
            if not (np.isfinite(J0[i]).all() and np.isfinite(J1[i]).all()):
                unchecked += 1
                continue
            start, end = machine.program_rows(np.array([J0[i], J1[i]]), gauges[mv.tool])
        if not np.allclose(start, end):
            segments.append((mv.line, mv.tool, start, end))
    ref = (machine.reference_position or {}).get(machine.retract_axis[0])
    for line, row, _, tool in read.reference_returns:
        # straight along the retract axis to the reference position where the machine file gives it, else to the
        # end of the axis' travel on the tool side (the reference position is then taken to be on that way)
        if tool not in tools:
            continue
        if not np.isfinite(row).all():
            unchecked += 1
            continue
        segments.append((line, tool, *lift_rows(machine, row, gauges[tool], ref)))
    local = {n: s.local_points(spacing) for n, s in tools.items()}
    worst, bad = 0.0, []
    for line, tool, start, end in segments:
        depth, _, pt = segment_intrusion(machine, rotor, start, end, local[tool], gauges[tool], step)
        worst = max(worst, depth)
        if depth > 0:
            bad.append({"line": line, "depth_mm": depth, "point": pt})
    return {"moves_checked": len(segments), "moves_unchecked": unchecked, "max_intrusion_mm": worst,
            "intrusions": bad[:20]}


def verify_program(text, post, machine, plans, rotor, lobes=None, references=None, progress=None, read=None,
                   cutting_data=None, coolant="flood"):
    """The read-back report of a posted program (module doc); ``lobes``: lobes to sweep (default all
    the program cuts); ``references``: verify_plan of each plan when already known; ``progress(fraction,
    message)``: reports before each plan's and lobe's sweep, and stops the check when it asks to
    (:mod:`..progress`); ``read``: ``post.read(text, machine)`` when the caller has it already;
    ``cutting_data``: one CuttingData for every tool, as the post was given it (default: each tool's own);
    ``coolant``: the coolant it was posted with (:data:`..machining.toolpath.COOLANTS`)."""
    from ..progress import reporter

    report = reporter(progress)
    t0 = time.perf_counter()
    if lobes is not None:
        lobes = checked_lobes(lobes, rotor)
    if coolant not in COOLANTS:
        raise ValueError(f"coolant {coolant!r} is not one of {', '.join(COOLANTS)}")
    read = post.read(text, machine) if read is None else read
    tools, of_strip = tool_table(plans)
    passes = match_passes(read_passes(read, machine, tools, rotor), plans, rotor, tools, of_strip)
    seen = {}
    for ps in passes:
        if ps["match"] is not None:
            seen.setdefault(ps["match"], []).append(ps["line"])
    # the lobes the program cuts: those of its matched passes and those its other passes come nearest to
    cut_lobes = sorted({m[2] for m in seen} | {ps["nearest"][2] for ps in passes if ps["match"] is None})
    # every strip is due on every lobe asked for; without ``lobes``, on those cut (all of them if none is)
    due = lobes if lobes is not None else (cut_lobes or list(range(rotor.lobes)))
    expected = {(p, s, k) for p, plan in enumerate(plans) for s in range(len(plan["strips"]))
                if not repeats_earlier_strip(plan, s) for k in due}
    clear = [run_out(ps, tools, rotor) for ps in passes]
    kept_out = [keep_out_margin(ps, tools, rotor) for ps in passes]
    plans_out = []
    for p, plan in enumerate(plans):
        swept = cut_lobes if lobes is None else [k for k in lobes if k in cut_lobes]
        steps = len(plans) * (len(swept) + 1)
        report(p * (len(swept) + 1) / steps, f"plan {p}: its own deviation")
        ref = references[p] if references is not None else verify_plan(plan)
        lobes_out = []
        for i, k in enumerate(swept):
            report((p * (len(swept) + 1) + i + 1) / steps, f"plan {p}: the program's passes on lobe {k}")
            lobes_out.append(lobe_deviation(plan, p, passes, tools, rotor, k, ref))
        plans_out.append({"plan": p, "plan_max_undercut_mm": ref["max_undercut"],
                          "plan_max_overcut_mm": ref["max_overcut"], "plan_gouge_points": len(ref["gouge_points"]),
                          "lobes": [x for x in lobes_out if x is not None]})
    diffs = [lo["max_deviation_difference_mm"] for pl in plans_out for lo in pl["lobes"]]
    gauges = tool_gauges(tools)
    times = cycle_time(read, machine, gauges)
    times.pop("block_minutes")
    res = {
        "schema": "flank-program-check/1", "post": post.name, "machine": machine.name,
        "moves": len(read.moves), "passes": len(passes),
        "matched_passes": sum(1 for ps in passes if ps["match"] is not None),
        "unmatched_passes": [{"line": ps["line"], "distance_mm": ps["match_distance"]} for ps in passes
                             if ps["match"] is None],
        "missing_strips": sorted(list(x) for x in expected - set(seen)),
        "repeated_strips": sorted([list(k), v] for k, v in seen.items() if len(v) > 1),
        "lobes_cut": cut_lobes,
        "program_end_line": read.end_line,
        "screw_error_mm": max((ps["screw_error"] for ps in passes), default=0.0),
        "passes_off_screw": [{"line": ps["line"], "screw_error_mm": ps["screw_error"]} for ps in passes
                             if ps["screw_error"] > MATCH_TOL_MM],
        "interpolation_error_mm": max((ps["interpolation_error"] for ps in passes), default=0.0),
        "passes_off_screw_between": [{"line": ps["line"], "interpolation_error_mm": ps["interpolation_error"]}
                                     # the passes whose block ends are on it: the others are named already
                                     for ps in passes if ps["interpolation_error"] > MATCH_TOL_MM
                                     and ps["screw_error"] <= MATCH_TOL_MM],
        # null without any pass: strict JSON has no Infinity
        "run_out": {"min_start_clearance_mm": min((c[0] for c in clear), default=None),
                    "min_end_clearance_mm": min((c[1] for c in clear), default=None),
                    "passes_not_clear": [ps["line"] for ps, c in zip(passes, clear) if min(c) <= 0],
                    # null when no pass crosses a shaft or a holder: strict JSON has no Infinity
                    "min_keep_out_margin_mm": min(kept_out) if kept_out and math.isfinite(min(kept_out)) else None,
                    "passes_into_keep_out": [ps["line"] for ps, m in zip(passes, kept_out) if m < 0]},
        "plans": plans_out,
        "max_deviation_difference_mm": max(diffs, default=None),
        "pose_difference_mm": max((lo["pose_difference_mm"] for pl in plans_out for lo in pl["lobes"]), default=None),
        "gouge_points": sum(lo["gouge_points"] for pl in plans_out for lo in pl["lobes"]),
        "links": check_links(read, machine, tools, rotor),
        "spindle": spindle_check(read, machine),
        "coolant": coolant_check(read, coolant),
        "cutting": cutting_check(passes, machine, rotor, tools, tool_cutting_data(plans, cutting_data)),
        "length_compensation": length_check(read),
        "axis_limits": axis_limit_check(read, machine, gauges),
        "work_offsets": work_offset_check(read),
        "tcp": tcp_check(read, machine),
        "finer_than_increments": finer_than_increments(text, post, machine),
        "holders": [{"z_range": [a, b], "radius": r} for a, b, r in rotor.holders],
        **times,
    }
    res["findings"] = program_findings(res)
    res["elapsed_s"] = time.perf_counter() - t0
    return res


# what :func:`spindle_check` finds, as the findings say it (after "N feed move(s) ")
SPINDLE_FINDINGS = (
    ("stopped", "with the spindle stopped (lines {lines}): M5, or not started again after a tool change"),
    ("counter_clockwise", "with the spindle turning counter-clockwise (M4; lines {lines}): the tools cut "
                          "right-hand, turned by M3"),
    ("no_speed", "without a spindle speed (S0 or none; lines {lines})"),
    ("over_top_speed", "at up to S{max_rpm:g}, over the machine's top spindle speed {machine_max_rpm:g} /min "
                       "(lines {lines})"),
)


# what :func:`cutting_check` finds, as the findings say it (after "N feed move(s) "), and the figures
CUTTING_FINDINGS = (
    ("over_chip_load", "load the tool over its feed per tooth"),
    ("over_surface_speed", "cut faster than the tool's cutting speed"),
    ("over_tool_top_speed", "turn the tool faster than its top speed"),
)


def _cutting_text(t, key):
    """One tool's figure of a cutting finding: its largest value against its data, or '' when within."""
    d = t["cutting_data"]
    if not t["moves_over"][key]:
        return ""
    if key == "over_chip_load":
        return f"T{t['tool']} chip load up to {t['max_chip_load_mm']:.4g} mm against fz {d['fz_mm']:g} mm ({d['source']})"
    if key == "over_surface_speed":
        return (f"T{t['tool']} up to {t['max_surface_speed_m_min']:.4g} m/min against vc {d['vc_m_min']:g} m/min "
                f"({d['source']})")
    return f"T{t['tool']} at up to S{t['max_rpm']:g} against its {d['max_rpm']:g} /min ({d['source']})"


def _some(lines):
    """Up to ten line numbers of a finding, '...' for more."""
    return ", ".join(map(str, lines[:10])) + (", ..." if len(lines) > 10 else "")


def program_findings(res):
    """What makes the program differ from its plans or cut where it must not, one sentence each (empty: the
    program does what the plans say): a text without the program's end, passes that match no strip, passes
    that leave the rotor's screw motion, strips never cut or cut twice, more gouge points on a lobe than the
    plan itself has, passes that start or end inside the body or enter a shaft or a holder, links that enter
    the stock, a shaft or a holder, feed moves without the spindle turning clockwise within its speeds, axes
    beyond the machine's limits, moves without their tool's length compensation, a change of work offset,
    points that one side covers and the other does not."""
    out = []
    if not res["program_end_line"]:
        out.append("the program has no end (M2 / M30, END PGM): was it cut short?")
    un = res["unmatched_passes"]
    if un:
        lines = ", ".join(str(u["line"]) for u in un[:10]) + (", ..." if len(un) > 10 else "")
        out.append(f"{len(un)} of {res['passes']} passes match no plan strip (lines {lines}; nearest strip "
                   f"{min(u['distance_mm'] for u in un):.3g} mm away)")
        if un and not res["matched_passes"]:
            out.append("no pass matches any plan strip: were the program and this check given the same plans and "
                       "the same --outer-radius-mm?")
    off = res.get("passes_off_screw", [])
    if off:
        out.append(f"{len(off)} pass(es) leave the rotor's screw motion by up to "
                   f"{max(o['screw_error_mm'] for o in off):.3g} mm (lines {_some([o['line'] for o in off])}): "
                   "not the plan's pitch or rotary angles; the deviation figures sweep each pass along the screw "
                   "through its first pose and do not show it")
    between = res.get("passes_off_screw_between", [])
    if between:
        out.append(f"{len(between)} pass(es) leave the rotor's screw motion between their block ends by up to "
                   f"{max(b['interpolation_error_mm'] for b in between):.3g} mm (lines "
                   f"{_some([b['line'] for b in between])}): the controller's straight moves between them (TCP "
                   "chords) are too long for the plan's tolerance; post with a lower --chord-tolerance; the "
                   "deviation figures do not show it")
    if res["missing_strips"]:
        out.append(f"{len(res['missing_strips'])} strip(s) never cut, as [plan, strip, lobe]: "
                   f"{res['missing_strips'][:10]}")
    if res["repeated_strips"]:
        out.append(f"{len(res['repeated_strips'])} strip(s) cut more than once: "
                   f"{[k for k, _ in res['repeated_strips'][:10]]}")
    for pl in res["plans"]:
        for lo in pl["lobes"]:
            if lo["gouge_points"] > pl["plan_gouge_points"]:
                out.append(f"plan {pl['plan']} lobe {lo['lobe']}: {lo['gouge_points']} gouge points against the "
                           f"plan's {pl['plan_gouge_points']} (deepest overcut {lo['max_overcut_mm']:.4g} mm)")
            if lo["coverage_mismatches"]:
                out.append(f"plan {pl['plan']} lobe {lo['lobe']}: {lo['coverage_mismatches']} point(s) that only "
                           "one of program and plan mills")
    if res["run_out"]["passes_not_clear"]:
        out.append(f"passes at lines {res['run_out']['passes_not_clear'][:10]} start or end inside the body")
    keep_out = "a shaft or a holder" if res.get("holders") else "a shaft"
    stock_or = "the stock, a shaft or a holder" if res.get("holders") else "the stock or a shaft"
    into = res["run_out"].get("passes_into_keep_out")
    if into:
        out.append(f"passes at lines {into[:10]} enter {keep_out} by up to "
                   f"{-res['run_out']['min_keep_out_margin_mm']:.3g} mm")
    sp = res.get("spindle")
    for key, text in SPINDLE_FINDINGS if sp is not None else ():
        if sp[key]:
            out.append(f"{len(sp[key])} feed move(s) " + text.format(lines=_some(sp[key]), **sp))
    cool = res.get("coolant")
    if cool is not None and cool["off"]:
        out.append(f"{len(cool['off'])} feed move(s) without coolant (lines {_some(cool['off'])}): M9, a program "
                   "stop or the end before them, and no M8 / M7 (Klartext M8 / M13) after it (or none at all: a "
                   "program posted to cut dry is checked with coolant off)")
    if cool is not None and cool.get("on"):
        out.append(f"{len(cool['on'])} feed move(s) with coolant on (lines {_some(cool['on'])}) in a program "
                   "posted to cut dry: an M8 / M7 (Klartext M8 / M13) before them")
    cut = res.get("cutting")
    for key, what in CUTTING_FINDINGS if cut is not None else ():
        if cut[key]:
            out.append(f"{len(cut[key])} feed move(s) " + what + f" (lines {_some(cut[key])}): "
                       + "; ".join(_cutting_text(t, key) for t in cut["tools"] if _cutting_text(t, key)))
    for v in res.get("axis_limits", []):
        out.append(f"axis {v['axis']} reaches {v['value']:.6g} at line {v['line']}, outside its limits "
                   f"{v['min']:g}..{v['max']:g} on machine {res['machine']}: the controller stops there")
    tc = res.get("tcp")
    if tc is not None and tc["other_mode"]:
        mode = ("without TCP on a machine with it: the control reads their tool-tip positions as joint values"
                if tc["machine_tcp"] else "with TCP on (G43.4 / FUNCTION TCPM) on a machine without it: the "
                "control reads their joint values as tool-tip positions")
        out.append(f"{len(tc['other_mode'])} move(s) {mode} (lines {_some(tc['other_mode'])})")
    wo = res.get("work_offsets")
    if wo is not None and wo["changes_at"]:
        out.append(f"the work offset changes {len(wo['changes_at'])} time(s) (lines {_some(wo['changes_at'])}; "
                   f"{' -> '.join(wo['offsets'][:6])}): the program's zero moves under the part")
    lc = res.get("length_compensation")
    if lc is not None and lc["without"]:
        out.append(f"{len(lc['without'])} move(s) without tool length compensation (lines {_some(lc['without'])}): "
                   "no G43 H<tool> active, so the tool tip is off by the tool's length")
    if lc is not None and lc["other_tool"]:
        h, t = lc["first_other"]
        out.append(f"{len(lc['other_tool'])} move(s) with another tool's length compensation (lines "
                   f"{_some(lc['other_tool'])}; H{h} with T{t}): the tool tip is off by the difference of their "
                   "lengths")
    if res["links"]["max_intrusion_mm"] > 0:
        out.append(f"{len(res['links']['intrusions'])} link move(s) enter {stock_or}, deepest "
                   f"{res['links']['max_intrusion_mm']:.3g} mm")
    fine = res.get("finer_than_increments") or []
    if fine:
        out.append(f"{len(fine)} block(s) give axis or F words finer than the control's input increments of the "
                   f"machine file (lines {_some(fine)}): the control may drop the extra digits or refuse them, "
                   "and this check reads them as written; post the program for this machine file")
    return out
