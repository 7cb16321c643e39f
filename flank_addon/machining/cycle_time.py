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


def cycle_time(read, machine, tool_lengths=None):
    """Cutting, rapid and tool-change seconds of a read-back program (:class:`..posts.base.ReadProgram`)."""
    per = block_times(read.moves, machine, tool_lengths)
    feed = np.array([mv.kind == "feed" for mv in read.moves], bool)
    cut, rapid = float(per[feed].sum()), float(per[~feed].sum())
    per_block = per.tolist()
    changes = len(read.tool_changes)
    tc = changes * machine.tool_change_s / 60.0
    return {"cutting_time_s": 60.0 * cut, "rapid_time_s": 60.0 * rapid, "tool_changes": changes,
            "tool_change_time_s": 60.0 * tc, "total_time_s": 60.0 * (cut + rapid + tc),
            "block_minutes": per_block}
