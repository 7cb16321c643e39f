"""Block times the way the controller computes them, from the moves read back from a posted program.

Feed blocks, by the dialect's feed mode (F as written, the rounded value):

* ``inverse_time`` (G93): T = 1 / F minutes;
* ``per_minute`` (G94, LinuxCNC's rule): T = |dXYZ| / F, or |dABC| / F (deg/min) when no linear axis moves;
* ``combined`` (Klartext without M116): T = sqrt(|dXYZ|^2 + |dABC|^2) / F, degrees counted as mm;
* ``tip_speed`` (Klartext FUNCTION TCPM F TCP): T = |d tip| / F, the tip given in work coordinates.

The controller never drives a joint faster than its top speed: T = max(T, max_j |dJ_j| / max_feed_j) over
the machine joints (for a TCP machine the joints of both ends by the machine's kinematics).  Rapid moves:
T = max_j |dJ_j| / rapid_j (every axis at its rapid rate, the slowest decides).  Accelerations are not
modelled; a tool change costs the machine file's ``tool_change_s``.

After a tool change the program cannot say where the machine stands.  When the machine file gives a
``tool_change_position`` the moves out of it are timed as rapids from there (the rotary axes it does not
name stay where the earlier tool left them); otherwise, or where a position stays unknown, the move is
counted in ``untimed_moves`` and takes 0.  A return to the reference position (Fanuc ``G91 G28``) is timed as
a rapid of its axis to the machine file's ``reference_position``, and leaves the axis there; without one it is
counted in ``untimed_returns`` and the axis is unknown after it.
"""
import numpy as np


def block_time(move, machine, tool_length=0.0):
    """Minutes of one :class:`..posts.base.Move` (module doc); 0 for a move from an unknown position."""
    if not np.isfinite(move.start).all():
        return 0.0
    J = machine.machine_joints(np.array([move.start, move.end]), tool_length)
    dj = np.abs(J[1] - J[0])
    names = machine.axis_names
    if move.kind == "rapid":
        return max(dj[i] / machine.axes[n].rapid for i, n in enumerate(names))
    d = np.abs(move.end - move.start)
    lin, rot = float(np.linalg.norm(d[:3])), float(np.linalg.norm(d[3:]))
    F = move.feed
    if move.feed_mode == "inverse_time":
        T = 1.0 / F
    elif move.feed_mode in ("per_minute", "tip_speed"):
        T = (lin if lin > 0 else rot) / F
    elif move.feed_mode == "combined":
        T = float(np.hypot(lin, rot)) / F
    else:
        raise ValueError(f"unknown feed mode {move.feed_mode!r}")
    return max(T, max(dj[i] / machine.axes[n].max_feed for i, n in enumerate(names)))


def block_times(moves, machine, tool_lengths=None):
    """Minutes (N,) of many moves at once (:func:`block_time`, vectorised)."""
    tool_lengths = tool_lengths or {}
    N = len(moves)
    if not N:
        return np.zeros(0)
    S = np.array([mv.start for mv in moves])
    E = np.array([mv.end for mv in moves])
    known = np.isfinite(S).all(axis=1)
    S = np.where(known[:, None], S, E)
    J0, J1 = np.empty_like(S), np.empty_like(E)
    tools = np.array([mv.tool for mv in moves])
    for t in np.unique(tools):
        k = tools == t
        J0[k] = machine.machine_joints(S[k], tool_lengths.get(int(t), 0.0))
        J1[k] = machine.machine_joints(E[k], tool_lengths.get(int(t), 0.0))
    dj = np.abs(J1 - J0)
    names = machine.axis_names
    rapid = np.array([machine.axes[n].rapid for n in names])
    top = np.array([machine.axes[n].max_feed for n in names])
    d = np.abs(E - S)
    lin, rot = np.linalg.norm(d[:, :3], axis=1), np.linalg.norm(d[:, 3:], axis=1)
    F = np.array([mv.feed if mv.kind == "feed" else 1.0 for mv in moves])
    mode = np.array([mv.feed_mode if mv.kind == "feed" else "" for mv in moves])
    bad = set(mode) - {"", "inverse_time", "per_minute", "tip_speed", "combined"}
    if bad:
        raise ValueError(f"unknown feed mode {sorted(bad)[0]!r}")
    T = np.select([mode == "inverse_time", np.isin(mode, ("per_minute", "tip_speed")), mode == "combined"],
                  [1.0 / F, np.where(lin > 0, lin, rot) / F, np.hypot(lin, rot) / F], 0.0)
    T = np.where(mode == "", (dj / rapid).max(axis=1), np.maximum(T, (dj / top).max(axis=1)))
    return np.where(known, T, 0.0)


def move_joints(read, machine, tool_lengths=None):
    """Machine joints (N, axes) where every move starts and ends, as far as they are known.  A move's own rows
    where the program gives them; a move from an unknown position (the first after a tool change) starts where
    the machine stands: where the tool-change cycle leaves it (:meth:`..machine.Machine.after_tool_change`), NaN
    where that is unknown.  Without TCP a row the program gives only in part (the rotaries turned first) is
    completed from there too.  A return to the reference position (Fanuc G28) leaves its axis at the machine
    file's ``reference_position``, unknown when the file gives none."""
    return _follow(read, machine, tool_lengths)[:2]


def _follow(read, machine, tool_lengths=None):
    """(J0, J1) of :func:`move_joints` and the joints (R, axes) where each reference return starts, as far as
    they are known: the machine's state followed through the program, tool changes and returns included."""
    tool_lengths = tool_lengths or {}
    # what moves the machine where the program cannot see, in program order (M6 before the motion of its block)
    events = sorted([(line, 0, None, None) for _, line in read.tool_changes]
                    + [(line, 1, axis, r) for r, (line, _, axis, _) in enumerate(read.reference_returns)],
                    key=lambda e: e[:2])
    n, N = len(machine.axis_names), len(read.moves)
    S = np.array([mv.start for mv in read.moves], float).reshape(N, n)
    E = np.array([mv.end for mv in read.moves], float).reshape(N, n)
    tools = np.array([mv.tool for mv in read.moves], int)
    J0, J1 = np.full((N, n), np.nan), np.full((N, n), np.nan)
    for rows, out in ((S, J0), (E, J1)):          # the rows the program gives, all at once per tool
        known = np.isfinite(rows).all(axis=1)
        for t in np.unique(tools[known]):
            k = known & (tools == t)
            out[k] = machine.machine_joints(rows[k], tool_lengths.get(int(t), 0.0))
    starts = np.full((len(read.reference_returns), n), np.nan)
    here, k = np.full(n, np.nan), 0

    def apply(event, here):
        if event[2] is None:
            return machine.after_tool_change(here)
        starts[event[3]] = here
        here = here.copy()
        here[event[2]] = _reference_joint(machine, event[2])
        return here

    for i, mv in enumerate(read.moves):
        while k < len(events) and events[k][0] <= mv.line:
            here = apply(events[k], here)
            k += 1
        if np.isnan(J0[i, 0]):
            J0[i] = here
        if np.isnan(J1[i, 0]) and not machine.tcp:   # joint values: what the block does not name stays
            J1[i] = np.where(np.isfinite(E[i]), E[i], J0[i])
        here = J1[i]
    for event in events[k:]:                       # after the last move (the program's end)
        here = apply(event, here)
    return J0, J1, starts


def _reference_joint(machine, axis):
    """Joint value where a reference return leaves axis ``axis`` (an index into ``axis_names``): the machine
    file's ``reference_position``, NaN when it gives none."""
    ref = machine.reference_position or {}
    return float(ref.get(machine.axis_names[axis], np.nan))


def reference_return_minutes(read, machine, tool_lengths=None):
    """Minutes of each return to the reference position (Fanuc ``G91 G28``) of a read-back program, NaN where
    untimed: the axis goes at its rapid rate from where the machine stands when the return starts (followed
    through the program as :func:`move_joints` follows it) straight to the machine file's
    ``reference_position``, as the program's other rapid moves are timed.  Untimed when the file gives no
    reference position, or where the machine stands is unknown (a return right after a tool change whose
    position the file does not give)."""
    starts = _follow(read, machine, tool_lengths)[2]
    out = np.full(len(read.reference_returns), np.nan)
    for k, (_, _, axis, _) in enumerate(read.reference_returns):
        ref = _reference_joint(machine, axis)
        if np.isfinite(ref) and np.isfinite(starts[k, axis]):
            out[k] = abs(ref - starts[k, axis]) / machine.axes[machine.axis_names[axis]].rapid
    return out


def cycle_time(read, machine, tool_lengths=None):
    """Cutting, rapid and tool-change seconds of a read-back program (:class:`..posts.base.ReadProgram`); the
    rapid seconds include the returns to the reference position that the machine file lets it time."""
    per = block_times(read.moves, machine, tool_lengths)
    feed = np.array([mv.kind == "feed" for mv in read.moves], bool)
    unknown = np.array([not np.isfinite(mv.start).all() for mv in read.moves], bool)
    untimed = 0
    if unknown.any():
        J0, J1 = move_joints(read, machine, tool_lengths)
        rapid_rate = np.array([machine.axes[n].rapid for n in machine.axis_names])
        for i in np.flatnonzero(unknown):
            if feed[i] or not (np.isfinite(J0[i]).all() and np.isfinite(J1[i]).all()):
                untimed += 1            # a cut from an unknown position has no length to time
                continue
            per[i] = float((np.abs(J1[i] - J0[i]) / rapid_rate).max())
    returns = reference_return_minutes(read, machine, tool_lengths)
    timed = np.isfinite(returns)
    cut, rapid = float(per[feed].sum()), float(per[~feed].sum()) + float(returns[timed].sum())
    per_block = per.tolist()
    changes = len(read.tool_changes)
    tc = changes * machine.tool_change_s / 60.0
    return {"cutting_time_s": 60.0 * cut, "rapid_time_s": 60.0 * rapid, "tool_changes": changes,
            "tool_change_time_s": 60.0 * tc, "total_time_s": 60.0 * (cut + rapid + tc),
            "untimed_moves": untimed, "reference_returns": len(read.reference_returns),
            "untimed_returns": int((~timed).sum()), "reference_return_time_s": 60.0 * float(returns[timed].sum()),
            "block_minutes": per_block}


def untimed_parts(count, returns=0, machine=None):
    """What a cycle time leaves out, as phrases: ``count`` moves out of a tool change whose start is unknown and
    ``returns`` to the reference position (Fanuc G28) it cannot time; with ``machine``, each says why (the
    machine file's missing keys).  The command line's note and Blender's panel word them alike."""
    parts = []
    if count:
        why = "" if machine is None else (
            " (the machine file gives no tool_change_position" if machine.tool_change_position is None
            else " (the rotary axes the tool_change_position does not name are unknown before the first tool") + ")"
        parts.append(f"{count} move(s) out of a tool change{why}")
    if returns:
        why = "" if machine is None else (" (G28; the machine file gives no reference_position)"
                                          if machine.reference_position is None else
                                          " (G28 from where the program does not know the machine stands)")
        parts.append(f"{returns} return(s) to the reference position{why}")
    return parts


def untimed_note(count, machine, returns=0):
    """``", not counting ..."`` of what the cycle time leaves out, with the reasons (:func:`untimed_parts`), or
    "" when it times everything."""
    parts = untimed_parts(count, returns, machine)
    return ", not counting " + " and ".join(parts) if parts else ""
