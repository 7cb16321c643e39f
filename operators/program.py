# SPDX-License-Identifier: GPL-3.0-or-later
"""A run's machine program in the Blender layer's terms (no Blender data here): the post's inputs read from
operator values (plan in mm, lobes, cutting data, machine, post), the core's whole-rotor operation, program and
post (``flank_addon.machining``, ``flank_addon.posts``, the same calls as ``python -m flank_addon post``), and
from the program as read back by the dialect's reader: the tool tip's path relative to the rotor and the keys of
the program's animation.

Units: the plan is scaled to millimetres of the scene (``k`` mm per plan length unit = the run's length scale x
the scene's millimetres per unit), so the program machines the rotor as it is in the scene.  Every array here is
in the rotor frame in mm (or the fixed frame of the animation, also mm); the Blender objects carry the
rotor-frame placement scaled by 1 / k.

Animation frame: the rotor only turns about its own axis, by psi = sigma x (spin axis angle) (sigma = +-1 as the
spin axis points along or against the rotor's z), and the tool moves in the *fixed frame* R_z(psi) (rotor frame)
so that the tool relative to the rotor is exactly the program's pose.  For rotor-xa-b this fixed frame is the
machine frame turned back by the rotor mount.  During a joint-linear pass the tool's fixed-frame pose moves
linearly in time (the screw's turn cancels the spin), so keys at the block ends with LINEAR interpolation are
the exact relative motion at every frame; rapids that turn a rotary axis are keyed every ``STEP_DEG`` degrees.
"""
import math

import bpy
import numpy as np

STEP_DEG = 2.0                 # rotary step between keys / path samples of a move
MAX_SAMPLES = 720              # per move
TOOL_OUTLINE_POINTS = 120      # outline samples of a tool mesh along its axis
MIN_TOOL_CHANGE_S = 1e-3       # animation time of a tool change on a machine file that gives it none


def rounded(x):
    """The decimal a user typed, not the single-precision noise of a Blender float property (7 digits)."""
    return float("{:.7g}".format(float(x)))


def parse_lobes(text):
    """Lobe indices of a lobes text ('' or 'all' -> None = every lobe; '0,2,4') or an error message (str)."""
    t = str(text).strip().lower()
    if t in ("", "all"):
        return None
    try:
        vals = [int(x) for x in t.replace(" ", "").split(",")]
    except ValueError:
        return "lobes {!r} must be empty, 'all' or lobe indices like 0,2,4".format(str(text))
    if any(v < 0 for v in vals):
        return "lobes {!r}: lobe indices are >= 0".format(str(text))
    return vals


def cutting_data_of(flutes, vc, fz, max_rpm):
    """The core's CuttingData of these values: the default end mill or a tool preset's data when they are
    those (so the program names that source), else data from the Tool panel; an error message (str) for values
    the core refuses."""
    from ..flank_addon.machining.feeds import DEFAULT_END_MILL, PRESET_CUTTING_DATA, CuttingData

    try:
        vals = (int(flutes), rounded(vc), rounded(fz), rounded(max_rpm))
    except (TypeError, ValueError, OverflowError):
        return "cutting data {!r} must be numbers".format((flutes, vc, fz, max_rpm))
    for d in (DEFAULT_END_MILL, *PRESET_CUTTING_DATA.values()):
        if (d.flutes, d.vc_m_min, d.fz_mm, d.max_rpm) == vals:
            return d
    try:
        return CuttingData(*vals, source="Tool panel")
    except ValueError as ex:
        return "cutting data: {}".format(ex)


def plan_in_mm(plan, k):
    """The plan with its lengths in mm: k mm per plan length unit (as is when already mm and k = 1)."""
    from ..flank_addon.machining.rotor_body import scale_plan

    if plan.get("length_unit") == "mm" and k == 1.0:
        return plan
    return scale_plan(plan, k)


def check_numbers(op):
    """Checks of the numbers of flank.post_program that need no run -> error message or None."""
    c = float(op.clearance)
    if not (math.isfinite(c) and 0.0 < c <= 1000.0):
        return "clearance = {:g} mm must be a finite number in (0, 1000]".format(c)
    if op.animate and int(op.frame_end) <= int(op.frame_start):
        return "end frame {} must be after the start frame {}".format(int(op.frame_end), int(op.frame_start))
    data = cutting_data_of(op.tool_flutes, op.tool_cutting_speed_m_min, op.tool_feed_per_tooth_mm,
                           op.tool_max_rpm)
    if isinstance(data, str):
        return data
    holders = holders_of(op.holders)
    return holders if isinstance(holders, str) else None


def holders_of(text):
    """The holders of the Holders text (:func:`..flank_addon.machining.rotor_body.parse_holders`: side, diameter,
    length, gap in mm) or an error message naming the one that is wrong."""
    from ..flank_addon.machining.rotor_body import parse_holders

    try:
        return parse_holders(text)
    except ValueError as ex:
        return "Holders {!r}: {}".format(str(text), ex)


# ---------------------------------------------------------------------------------------------- the core
def post_program(job, progress=None):
    """Operation, program, text, read-back and cycle time of ``job`` (plan in mm, machine, post, lobes,
    clearance, holders, cutting data): the calls of the command line's ``post``; with ``read_back`` also what
    ``verify --program`` says of the program (:func:`read_back`).  ``progress(fraction, message)``: reports
    between the stages (:func:`..flank_addon.progress.reporter`)."""
    from ..flank_addon.machining.cycle_time import cycle_time
    from ..flank_addon.machining.operation import build_operation
    from ..flank_addon.machining.rotor_body import rotor_body, with_holders
    from ..flank_addon.machining.toolpath import build_program
    from ..flank_addon.progress import reporter, substage

    report = reporter(progress)
    report(0.0, "building the program")

    machine, post = job["machine"], job["post"]
    rotor = with_holders(rotor_body(job["plan"]), job.get("holders", []))
    op = build_operation([job["plan"]], rotor, lobes=job["lobes"], clearance=job["clearance"],
                         cutting_data=job["data"])
    prog = build_program(op, machine, coolant=job.get("coolant", "flood"))
    text = post.write(prog)
    read = post.read(text, machine)
    gauges = {t.number: t.gauge_length for t in op.tools}
    times = cycle_time(read, machine, gauges)
    minutes = times.pop("block_minutes")
    move_ends = move_rows(read, machine, gauges)    # the path and the animation share them
    check = (read_back(text, job, machine, post, rotor, op, substage(report, 0.3, 0.95)) if job.get("read_back")
             else None)
    times.update(passes=len(prog.passes), moves=len(read.moves), lobes=list(op.lobes),
                 cutting_length_mm=float(sum(p["cutting_length_mm"] for p in prog.passes)),
                 rpm=[float(t.rpm) for t in op.tools])
    return dict(text=text, times=times, per_pass=prog.passes, read=read, minutes=np.asarray(minutes, float),
                holders=[tuple(map(float, h)) for h in rotor.holders], check=check,
                gauges=gauges, shapes={t.number: t.shape for t in op.tools}, rotor=rotor,
                path=program_path(read, machine, gauges, move_ends),
                keys=program_keys(read, machine, gauges, minutes, move_ends))


def read_back(text, job, machine, post, rotor, op, progress=None):
    """What ``verify --program`` says of the written program (:func:`..flank_addon.posts.readback.verify_program`
    on the lobes it cuts): its findings (empty: it does what the plan says), how far the machined deviation and
    the tool poses are from the plan's (None where no lobe was compared), and the deepest link intrusion.  A
    check that fails gives ``error`` instead: the program is still posted (the command line's ``post`` writes it
    without a check), and the failure is said."""
    from ..flank_addon.posts.readback import verify_program
    from ..flank_addon.progress import Cancelled

    try:
        res = verify_program(text, post, machine, [job["plan"]], rotor, lobes=list(op.lobes), progress=progress,
                             cutting_data=job["data"], coolant=job.get("coolant", "flood"))
    except Cancelled:
        raise
    except Exception as ex:                  # the check, not the program: post it and say the check failed
        return dict(error="{}: {}".format(type(ex).__name__, ex))
    return dict(findings=list(res["findings"]), deviation_mm=res["max_deviation_difference_mm"],
                pose_mm=res["pose_difference_mm"], intrusion_mm=res["links"]["max_intrusion_mm"],
                gouge_points=int(res["gouge_points"]), seconds=float(res["elapsed_s"]))


def _samples(kind, start, end, fine):
    """Rows (n + 1, axes) along a move from program row ``start`` to ``end``, linear in its program values: 1
    segment for a feed block unless ``fine`` (the path: every STEP_DEG of a rotary axis), for a rapid every
    STEP_DEG of a rotary axis."""
    turn = float(np.abs(end[3:] - start[3:]).max()) if len(end) > 3 else 0.0
    n = 1 if (kind == "feed" and not fine) else int(min(MAX_SAMPLES, max(1, math.ceil(turn / STEP_DEG))))
    u = np.linspace(0.0, 1.0, n + 1)[:, None]
    return (1.0 - u) * start[None, :] + u * end[None, :]


def move_rows(read, machine, gauges):
    """(start, end) program rows of every move, or None where the machine's position is unknown: a move out of a
    tool change starts where the machine file's tool_change_position leaves the machine (as the cycle time
    counts it, :func:`..flank_addon.machining.cycle_time.move_joints`)."""
    from ..flank_addon.machining.cycle_time import move_joints

    J0, J1 = move_joints(read, machine, gauges)
    out = []
    for mv, j0, j1 in zip(read.moves, J0, J1):
        if np.isfinite(mv.start).all() and np.isfinite(mv.end).all():
            out.append((np.asarray(mv.start, float), np.asarray(mv.end, float)))
        elif np.isfinite(j0).all() and np.isfinite(j1).all():
            out.append(tuple(machine.program_rows(np.array([j0, j1]), gauges.get(mv.tool, 0.0))))
        else:
            out.append(None)
    return out


def program_path(read, machine, gauges, move_ends):
    """The tool tip relative to the rotor along the program (rotor frame, mm): points (N, 3), edges (E, 2),
    per edge motion (1 cutting, 0 rapid) and pass number (1.. for cutting edges, 0 for links); a pass is a run
    of feed moves of one tool, as the read-back counts them.  ``move_ends``: :func:`move_rows`."""
    pts, edges, motion, passes = [], [], [], []
    n_pass, prev_feed, prev_tool, last = 0, False, None, None
    for mv, ends in zip(read.moves, move_ends):
        if ends is None:                              # from an unknown position (out of a tool change)
            last, prev_feed, prev_tool = None, False, mv.tool
            continue
        if not np.isfinite(mv.start).all():           # out of a tool change: from the tool-change position
            last = None
        feed = mv.kind == "feed"
        if feed and (not prev_feed or mv.tool != prev_tool):
            n_pass += 1
        tips = machine.forward(_samples(mv.kind, *ends, fine=True), gauges.get(mv.tool, 0.0))[0]
        start = len(pts) if last is None else last
        if last is None:
            pts.append(tips[0])
        for p in tips[1:]:
            pts.append(p)
            edges.append((start, len(pts) - 1))
            motion.append(1 if feed else 0)
            passes.append(n_pass if feed else 0)
            start = len(pts) - 1
        last, prev_feed, prev_tool = len(pts) - 1, feed, mv.tool
    return dict(points=np.array(pts, float).reshape(-1, 3), edges=np.array(edges, int).reshape(-1, 2),
                motion=np.array(motion, int), passes=np.array(passes, int), count=n_pass)


def _fixed_frame(machine, rows, tips, axes):
    """(psi (N,), fixed-frame tips (N, 3), fixed-frame axes (N, 3)) of program rows and their rotor-frame
    poses: psi = sigma x the spin axis angle (rad), the fixed frame R_z(psi) (rotor frame)."""
    ispin = 3 + machine.rotary_names.index(machine.spin)
    psi = machine.spin_sign * np.radians(rows[:, ispin])
    c, s = np.cos(psi), np.sin(psi)

    def turn(v):
        return np.c_[c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1], v[:, 2]]
    return psi, turn(tips), turn(axes)


def program_keys(read, machine, gauges, minutes, move_ends):
    """Keys of the program's animation: seconds (K,) from the first pose, tool number (K,), program rows
    (K, axes), psi (K,), fixed-frame tips and axes (K, 3) and rotor-frame tips and axes (K, 3); block ends and,
    for rapids that turn a rotary axis, every STEP_DEG between (a move's block time shared evenly: its program
    values move linearly).  Time counts the moves' block times and, between two tools, the machine's time of a
    tool change (at least MIN_TOOL_CHANGE_S): the next tool's first key then comes after the last key of the one
    before, which would otherwise share its time (and the spin's keys at one time would be merged).  ``move_ends``:
    :func:`move_rows`."""
    seconds, tools, rows, clock = [], [], [], 0.0
    changes, k = sorted(line for _, line in read.tool_changes), 0
    for mv, m, ends in zip(read.moves, minutes, move_ends):
        while k < len(changes) and changes[k] <= mv.line:     # M6 runs before the motion of its block
            clock += max(machine.tool_change_s, MIN_TOOL_CHANGE_S) if seconds else 0.0    # none before the first key
            k += 1
        known = ends is not None
        if not known and not np.isfinite(mv.end).all():
            continue                                  # where the machine stands is not known yet
        samples = _samples(mv.kind, *ends, fine=False)[1:] if known else mv.end[None, :]
        if known and not np.isfinite(mv.start).all():    # out of a tool change: key where it starts, too
            seconds.append(clock)
            tools.append(mv.tool)
            rows.append(ends[0])
        dt = 60.0 * float(m) / len(samples)
        if known and not dt > 0.0:                    # a block that moves nothing
            continue
        for r in samples:
            clock += dt if known else 0.0
            seconds.append(clock)
            tools.append(mv.tool)
            rows.append(r)
    seconds, tools = np.array(seconds, float), np.array(tools, int)
    rows = np.array(rows, float).reshape(len(seconds), -1)
    tips, axes = np.zeros((len(rows), 3)), np.zeros((len(rows), 3))
    for t in np.unique(tools):
        k = tools == t
        tips[k], axes[k] = machine.forward(rows[k], gauges.get(int(t), 0.0))
    psi, ftips, faxes = _fixed_frame(machine, rows, tips, axes)
    return dict(seconds=seconds, tools=tools, rows=rows, psi=psi, tips=ftips, axes=faxes, rotor_tips=tips,
                rotor_axes=axes, total=clock)


def key_frames(seconds, total, frame_start, frame_end):
    """Frames (float) of key times: the moves' total time spread over frame_start..frame_end."""
    total = total if total > 0 else 1.0
    return frame_start + (frame_end - frame_start) * np.asarray(seconds, float) / total


def tool_outline(shape):
    """(radius, height) outline of a program tool (cutting part and shank, tip at height 0, tool axis +z) from
    the top pole to the bottom pole, for :func:`shapes.revolved_mesh`."""
    lo, hi = shape.h_range()
    h, R, _ = shape.outline(max((hi - lo) / TOOL_OUTLINE_POINTS, 1e-6))
    order = np.argsort(-h, kind="stable")
    h, R = h[order], R[order]
    keep = np.r_[True, np.abs(np.diff(h)) > 1e-9 * max(1.0, hi - lo)]
    hh, rr = h[keep], R[keep]
    for i, hv in enumerate(hh):                       # the cutting part and the shank meet: the larger radius
        rr[i] = R[np.abs(h - hv) <= 1e-9 * max(1.0, hi - lo)].max()
    inner = rr > 1e-9
    return np.r_[[[0.0, hh[0]]], np.c_[rr[inner], hh[inner]], [[0.0, hh[-1]]]]


classes = ()
register, unregister = bpy.utils.register_classes_factory(classes)
