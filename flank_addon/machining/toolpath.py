"""The machine-level program of an operation: ordered passes, collision-free links, block times.

Order: tools in the order they first appear (one tool change each); within a tool the next pass is the one
whose start is the quickest rapid away from the current end (greedy nearest neighbour over the joint
rapid times; the spin axis turns to the nearest equivalent angle, it is never wrapped).  With direction
"zigzag" a pass may also run backwards (from below the body up) when that start is nearer.

Pass blocks: without TCP one joint-linear block per pass, the exact screw motion (:mod:`.machine`).  With TCP
the controller moves the tool tip on a straight line in work coordinates, so the tip's helix (radius rho
about the rotor axis) is cut into chords of rotor turn dphi = 2 acos(1 - e / rho), sagitta e =
``chord_tolerance``; the rotary axes still turn linearly, so the tool axis follows the screw exactly and the
pose is off by at most the sagitta.

Links (all rapid): from a pass end the tool moves straight away from the rotor axis (along the tool axis'
component across the rotor axis, rotaries fixed) until every point of the tool and its shank is at least the
safe radius R_s = max(outer radius, shaft radii) + clearance from the axis; there the rotary axes turn to the
next pass (turning the spin keeps every distance from the axis), then the linear axes move above the next
start and the tool approaches it the reverse way.  Every segment is checked against the stock cylinder and the
shafts (:mod:`.clearance`); when one is not clear the link is tried again with R_s + the tool's length, then
with an extra lift along the tool axis, and refused by name if none is.  A tool starts and ends at that lifted
position (the first move after a tool change comes from the tool-change position, which the program cannot
know).

Feeds: :func:`feeds.pass_conditions`; a pass' blocks share its screw rate, so a block's time is its share of
the screw parameter over the rate.
"""
import math
from dataclasses import dataclass, field

import numpy as np

from .clearance import move_intrusion, reach_of
from .feeds import engaged_edge, pass_conditions, spindle_speed
from .machine import MachineError
from .operation import OperationError
from .tool_shape import place_points

DIRECTIONS = ("forward", "reverse", "zigzag")


@dataclass
class Program:
    """Dialect-free program: ``ops`` is a list of dicts, each with ``op`` one of
    "comment" (text), "tool" (number, rpm, text), "tcp" (on), "rapid" (row), "feed" (row, time_min, pass),
    "end".  Rows hold program values in the machine's axis order (X, Y, Z, rotaries)."""
    machine: object
    operation: object
    ops: list
    passes: list
    report: dict = field(default_factory=dict)


class _Planner:
    def __init__(self, op, machine, direction, chord_tolerance, step, spacing):
        self.op, self.m, self.rotor = op, machine, op.rotor
        self.direction, self.chord, self.step = direction, chord_tolerance, step
        self.local = {t.number: t.shape.local_points(spacing) for t in op.tools}
        self.lift = 2.0 * self.rotor.safe_radius(op.clearance)
        self.ispin = 3 + machine.rotary_names.index(machine.spin)

    # ---------------------------------------------------------------- pass rows
    def pass_ts(self, ps, reverse):
        t0, t1 = (ps.t_range[1], ps.t_range[0]) if reverse else ps.t_range
        if not self.m.tcp:
            return np.array([t0, t1])
        rho = math.hypot(ps.tip[0], ps.tip[1])
        dphi = 2.0 * math.acos(max(-1.0, 1.0 - self.chord / rho)) if rho > self.chord else math.pi
        n = max(1, int(math.ceil(abs(t1 - t0) / dphi)))
        return np.linspace(t0, t1, n + 1)

    def rows(self, ps, reverse, near_spin):
        ts = self.pass_ts(ps, reverse)
        tool = self.op.tool(ps.tool)
        rows = self.m.pass_joints(ps.tip, ps.axis, self.rotor.hand, self.rotor.v0, ts, near_spin,
                                  tool.gauge_length)
        return ts, rows

    # ---------------------------------------------------------------- links
    def up(self, tip, axis, R):
        """Rotor-frame tip of the point straight away from the rotor axis where the whole tool is >= R off it."""
        a = np.asarray(axis, float)
        r = np.array([a[0], a[1], 0.0])
        if np.linalg.norm(r) < 0.2:
            r = np.array([tip[0], tip[1], 0.0])
        n = float(np.linalg.norm(r))
        r = r / n if n > 0 else np.array([1.0, 0.0, 0.0])
        return r

    def retract_point(self, number, tip, axis, R):
        r = self.up(tip, axis, R)
        pts = place_points(self.local[number], tip, axis)[0]
        b = pts[:, :2] @ r[:2]
        c = np.einsum("ij,ij->i", pts[:, :2], pts[:, :2]) - R * R
        disc = b * b - c
        d = -b + np.sqrt(np.maximum(disc, 0.0))
        d = float(np.max(np.where(disc > 0, d, 0.0), initial=0.0))
        return np.asarray(tip, float) + max(d, 0.0) * r

    def row_at(self, tip, angles, number):
        return np.r_[self.m.control_points(tip, angles, self.op.tool(number).gauge_length)[0], angles]

    def state(self, number, row):
        tips, axes = self.m.forward(row, self.op.tool(number).gauge_length)
        return tips[0], axes[0]

    def candidates(self, number, end, start):
        """Candidate link row sequences (levels) from program row ``end`` to ``start`` (either may be None:
        tool start / tool end)."""
        R0 = self.rotor.safe_radius(self.op.clearance)
        gauge = self.op.tool(number).gauge_length
        out = []
        for level, R in enumerate((R0, R0 + gauge, R0 + gauge)):
            seq = []
            lift = level == 2 or end is None or start is None
            if end is not None:
                tip, axis = self.state(number, end)
                up = self.retract_point(number, tip, axis, R)
                seq += [end, self.row_at(up, end[3:], number)]
                if lift:
                    seq.append(self.row_at(up + self.lift * axis, end[3:], number))
            if start is not None:
                tip, axis = self.state(number, start)
                up = self.retract_point(number, tip, axis, R)
                tail = [self.row_at(up, start[3:], number), start]
                if lift:
                    tail.insert(0, self.row_at(up + self.lift * axis, start[3:], number))
                if seq:                                   # turn the rotaries where the tool is
                    turn = self._turn(number, seq[-1], start[3:])
                    if turn is not None:
                        seq.append(turn)
                seq += tail
            out.append(seq)
            if end is None or start is None:
                break
        return out

    def _turn(self, number, row, angles):
        if np.allclose(row[3:], angles, atol=1e-12):
            return None
        return np.r_[row[:3], angles]

    def check(self, number, seq, what):
        gauge = self.op.tool(number).gauge_length
        local = self.local[number]
        worst = (0.0, None)
        for r0, r1 in zip(seq[:-1], seq[1:]):
            if np.allclose(r0, r1, atol=1e-12):
                continue
            depth, _, pt = segment_intrusion(self.m, self.rotor, r0, r1, local, gauge, self.step)
            if depth > worst[0]:
                worst = (depth, pt)
        return worst

    def link(self, number, end, start, what):
        first = None
        for seq in self.candidates(number, end, start):
            depth, pt = self.check(number, seq, what)
            if depth <= 0:
                return [np.asarray(r, float) for r in seq]
            first = first or (depth, pt)
        raise OperationError(f"{what}: no link stays out of the rotor (the tool enters the stock or a shaft by "
                             f"{first[0]:.3g} mm at {np.round(first[1], 3).tolist()} in the rotor frame even "
                             "when lifted); raise --clearance or check the machine's rotary axes")


def segment_intrusion(machine, rotor, r0, r1, local, gauge, step):
    """:func:`clearance.move_intrusion` of one program segment; a segment that only turns the spin axis (no
    TCP) or only moves along the rotor axis keeps every tool point's distance from the axis, so its end
    points decide."""
    d = np.subtract(r1, r0)
    ispin = 3 + machine.rotary_names.index(machine.spin)
    moving = np.flatnonzero(np.abs(d) > 1e-12)
    if not machine.tcp:
        pure_spin = list(moving) == [ispin]
        axial = False
        if len(moving) and moving.max() < 3:
            ang = {n: np.radians([r0[3 + i]]) for i, n in enumerate(machine.rotary_names)}
            R, _ = machine.table_transform(ang)
            w = (R[0].T @ d[:3]) @ machine.mount                 # rotor-frame displacement
            axial = math.hypot(w[0], w[1]) <= 1e-9 * (1.0 + abs(w[2]))
        if pure_spin or axial:
            from .clearance import tool_points
            pts = tool_points(machine, np.array([r0, r1]), local, gauge)
            rho = np.hypot(pts[..., 0], pts[..., 1])
            solids = rotor.shafts + [(rotor.z_range[0], rotor.z_range[1], rotor.outer_radius)]
            r_all = max(s[2] for s in solids)
            if pure_spin or rho.min() >= r_all:
                depth = rotor.intrusion(pts.reshape(-1, 3)).reshape(pts.shape[:2])
                k = np.unravel_index(np.argmax(depth), depth.shape)
                return float(depth[k]), float(k[0]), pts[k].tolist()
    return move_intrusion(machine, rotor, r0, r1, local, gauge, step=step,
                          reach=reach_of(machine, [r0, r1], local, gauge))


def _rapid_time(machine, a, b):
    d = np.abs(np.subtract(machine.machine_joints(b), machine.machine_joints(a)))[0]
    return max(d[i] / machine.axes[n].rapid for i, n in enumerate(machine.axis_names))


def _order(pl, passes, directions):
    """Greedy nearest-neighbour order of one tool's passes: [(pass, reverse, ts, rows)]."""
    m = pl.m
    left = list(range(len(passes)))
    cache = {}
    for i in left:
        for rev in directions:
            cache[i, rev] = pl.rows(passes[i], rev, 0.0)
    out, cur = [], None
    while left:
        best = None
        for i in left:
            for rev in directions:
                ts, rows = cache[i, rev]
                shift = 0.0 if cur is None else 360.0 * round((cur[pl.ispin] - rows[0, pl.ispin]) / 360.0)
                start = rows[0].copy()
                start[pl.ispin] += shift
                cost = 0.0 if cur is None else _rapid_time(m, cur, start)
                if best is None or cost < best[0] - 1e-12:
                    best = (cost, i, rev, shift)
        _, i, rev, shift = best
        ts, rows = cache[i, rev]
        rows = rows.copy()
        rows[:, pl.ispin] += shift
        out.append((passes[i], rev, ts, rows))
        cur = rows[-1]
        left.remove(i)
    return out


def build_program(op, machine, direction="forward", chord_tolerance=1e-3, step=1.0, spacing=1.5):
    """:class:`Program` of an :class:`operation.Operation` on ``machine`` (module doc).

    direction: "forward" (the plan's CL direction: tool from above the body down), "reverse" or "zigzag";
    chord_tolerance: TCP chord sagitta (mm); step / spacing: sampling of the link checks (mm)."""
    if direction not in DIRECTIONS:
        raise ValueError(f"direction {direction!r} is not one of {', '.join(DIRECTIONS)}")
    if not (math.isfinite(chord_tolerance) and chord_tolerance > 0):
        raise ValueError(f"chord tolerance {chord_tolerance!r} must be a finite number > 0 (mm)")
    pl = _Planner(op, machine, direction, chord_tolerance, step, spacing)
    rotor = op.rotor
    dirs = {"forward": (False,), "reverse": (True,), "zigzag": (False, True)}[direction]
    names = machine.axis_names
    ops = [{"op": "comment", "text": f"machine {machine.name}, {len(op.passes)} passes on lobes "
                                     f"{','.join(map(str, op.lobes))}, clearance {op.clearance:g} mm"}]
    if machine.tcp:
        ops.append({"op": "tcp", "on": True})
    passes_out = []
    for tool in op.tools:
        mine = [p for p in op.passes if p.tool == tool.number]
        if not mine:
            continue
        D = max(engaged_edge(tool.shape, p.tip, p.axis, rotor.outer_radius)[1].max(initial=0.0) for p in mine)
        if not D > 0:
            raise OperationError(f"tool {tool.number} never enters the stock cylinder: nothing to cut")
        tool.rpm = spindle_speed(tool.data, D, machine.max_rpm)
        ops.append({"op": "tool", "number": tool.number, "rpm": tool.rpm,
                    "text": f"{tool.name}; {tool.data.flutes} flutes, vc {tool.data.vc_m_min:g} m/min, "
                            f"fz {tool.data.fz_mm:g} mm ({tool.data.source})"})
        prev = None
        for ps, rev, ts, rows in _order(pl, mine, dirs):
            ps.reverse = rev
            label = f"pass {len(passes_out) + 1} ({ps.label})"
            mj = machine.machine_joints(rows, tool.gauge_length)
            for axis_name, value, lo, hi in machine.limit_violations(mj):
                raise MachineError(f"{label}: axis {axis_name} reaches {value:.6g}, outside its limits "
                                   f"{lo:g}..{hi:g} on machine {machine.name}")
            link = pl.link(tool.number, prev, rows[0], f"link to {label}")
            for r in link[1:-1] if prev is not None else link[:-1]:
                ops.append({"op": "rapid", "row": r})
            ops.append({"op": "rapid", "row": rows[0]})
            span = float(ts[-1] - ts[0])
            rates = np.abs(mj[-1] - mj[0]) / abs(span)
            cond = pass_conditions(tool.shape, ps.tip, ps.axis, rotor, tool.data, tool.rpm, span, rates,
                                   (names, [machine.axes[n].max_feed for n in names]))
            ops.append({"op": "comment", "text": f"PASS {len(passes_out) + 1} plan {ps.plan} strip {ps.strip} "
                                                 f"lobe {ps.lobe} flank {ps.flank} T{tool.number}"
                                                 f"{' reverse' if rev else ''}"})
            for k in range(1, len(rows)):
                ops.append({"op": "feed", "row": rows[k], "pass": len(passes_out),
                            "time_min": abs(float(ts[k] - ts[k - 1])) / cond.omega})
            passes_out.append({"pass": len(passes_out) + 1, "plan": ps.plan, "strip": ps.strip, "lobe": ps.lobe,
                               "flank": ps.flank, "tool": tool.number, "reverse": rev, "blocks": len(rows) - 1,
                               "t_range": [float(ts[0]), float(ts[-1])], "shaft_margin_mm": ps.shaft_margin,
                               "start": dict(zip(names, rows[0].tolist())), "end": dict(zip(names, rows[-1].tolist())),
                               **cond.as_dict()})
            prev = rows[-1]
        for r in pl.link(tool.number, prev, None, f"retract after tool {tool.number}")[1:]:
            ops.append({"op": "rapid", "row": r})
    if machine.tcp:
        ops.append({"op": "tcp", "on": False})
    ops.append({"op": "end"})
    return Program(machine=machine, operation=op, ops=ops, passes=passes_out)
