"""The machine-level program of an operation: ordered passes, collision-free links, block times.

Order: tools in the order they first appear (one tool change each); within a tool the next pass is the one
whose start is the quickest rapid away from the current end (greedy nearest neighbour over the joint
rapid times; the spin axis turns to the nearest equivalent angle, it is never wrapped).  With direction
"zigzag" a pass may also run backwards (from below the body up) when that start is nearer.

Pass blocks: without TCP one joint-linear block per pass, the exact screw motion (:mod:`.machine`).  With TCP
the controller moves the tool tip on a straight line in work coordinates, so the tip's helix (radius rho
about the rotor axis) is cut into chords of rotor turn dphi = 2 acos(1 - e / rho), sagitta e =
``chord_tolerance``; the rotary axes still turn linearly, so the tool axis follows the screw exactly and the
pose is off by at most the sagitta, plus the rounding of the program's numbers (a pass' screw error on read-back:
a 0.001 mm chord read back as 0.0012 mm of interpolation error).

Links (all rapid): from a pass end the tool moves straight away from the rotor axis (along the tool axis'
component across the rotor axis, rotaries fixed) until every point of the tool and its shank is at least the
safe radius R_s = max(outer radius, shaft and holder radii) + clearance from the axis; there the rotary axes
turn to the next pass (turning the spin keeps every distance from the axis), then the linear axes move above the
next start and the tool approaches it the reverse way.  Every segment is checked against the stock cylinder, the
shafts and the holders (:mod:`.clearance`); when one is not clear the link is tried again with R_s + the tool's
length, then with an extra lift along the tool axis, and refused by name if none is.  A tool starts and ends at that lifted
position, from which it must be clear to lift straight along the retract axis (Z) to the end of its travel, as
a reference return (Fanuc G28) or the tool-change cycle takes it (:func:`lift_rows`).  The first move after a
tool change comes from where the tool-change cycle leaves the machine, which the program cannot know; when the
machine file gives it (``tool_change_position``) the moves out of it are checked as well, block by block as the
post writes them (:meth:`.machine.Machine.tool_change_groups`), and a program whose tool would enter the stock on
the way is refused by name.

Feeds: :func:`feeds.pass_conditions`; a pass' blocks share its screw rate, so a block's time is its share of
the screw parameter over the rate.
"""
import math
from dataclasses import dataclass, field

import numpy as np

from .clearance import move_intrusion, reach_of
from .feeds import engagement, pass_conditions, spindle_speed
from .machine import MachineError
from .operation import OperationError, nearest_keep_out
from .tool_shape import place_points

DIRECTIONS = ("forward", "reverse", "zigzag")
# coolant a program turns on with every tool: flood, mist, or none (a dry cut, as cast iron is often finished)
COOLANTS = ("flood", "mist", "off")
TCP_ROUNDING_MM = 1e-3     # the program's rounding of a TCP pass' tip and rotaries, as the read-back measures it
# the largest chord sagitta a TCP pass may have: with the rounding it stays well within the 0.01 mm by which the
# read-back lets a pass leave the plan's screw motion before it takes it for another (posts.readback.MATCH_TOL_MM)
MAX_CHORD_TOLERANCE_MM = 5e-3


@dataclass
class Program:
    """Dialect-free program: ``ops`` is a list of dicts, each with ``op`` one of
    "comment" (text), "tool" (number, rpm, coolant, text), "tcp" (on), "rapid" (row), "feed" (row, time_min, pass),
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
    @staticmethod
    def radial_direction(tip, axis):
        """Unit direction across the rotor axis along which the tool retracts: the tool axis' component across
        the rotor axis (or, for a tool nearly along the rotor axis, the tip's radial direction)."""
        a = np.asarray(axis, float)
        r = np.array([a[0], a[1], 0.0])
        if np.linalg.norm(r) < 0.2:
            r = np.array([tip[0], tip[1], 0.0])
        n = float(np.linalg.norm(r))
        r = r / n if n > 0 else np.array([1.0, 0.0, 0.0])
        return r

    def retract_point(self, number, tip, axis, R):
        """Rotor-frame tip of the point straight away from the rotor axis where the whole tool is >= R off it:
        |q_xy + d r| >= R for every tool point q is d >= -q.r + sqrt((q.r)^2 - |q_xy|^2 + R^2)."""
        r = self.radial_direction(tip, axis)
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
        """Candidate link row sequences (levels, generated lazily) from program row ``end`` to ``start``
        (either may be None: tool start / tool end)."""
        R0 = self.rotor.safe_radius(self.op.clearance)
        gauge = self.op.tool(number).gauge_length
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
                if seq:                                   # turn the rotaries where the tool is: spin, then tilt
                    seq += self._turn(seq[-1], start[3:], number)
                seq += tail
            yield seq
            if end is None or start is None:
                break

    def _turn(self, row, angles, number):
        """Rows turning the rotaries from ``row`` to ``angles`` with the linear joints still: spin first, then
        tilt.  With TCP the controller would keep the tip on the workpiece instead, so the same joint motion
        is written as tip positions every <= 2 deg (the tip's chords then stay within R (1 - cos 1 deg))."""
        spun = row.copy()
        spun[self.ispin] = angles[self.ispin - 3]
        targets = [r for r, prev in ((spun, row), (np.r_[row[:3], angles], spun)) if not np.allclose(r[3:], prev[3:])]
        if not self.m.tcp:
            return targets
        gauge = self.op.tool(number).gauge_length
        out, J = [], self.m.machine_joints(row, gauge)[0]
        for target in targets:
            J1 = np.r_[J[:3], target[3:]]
            n = max(1, int(math.ceil(np.abs(J1[3:] - J[3:]).max() / 2.0)))
            for k in range(1, n + 1):
                Jk = J + (J1 - J) * (k / n)
                tip, _ = self.m.forward(Jk, gauge, tcp=False)
                out.append(np.r_[self.m.control_points(tip, Jk[3:], gauge)[0], Jk[3:]])
            J = J1
        return out

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
        first, limits = None, None
        gauge = self.op.tool(number).gauge_length
        for seq in self.candidates(number, end, start):
            bad = self.m.limit_violations(self.m.machine_joints(np.array(seq), gauge))
            if bad:
                limits = limits or bad[0]
                continue
            depth, pt = self.check(number, seq, what)
            if depth <= 0:
                return [np.asarray(r, float) for r in seq]
            first = first or (depth, pt)
        if first is None:
            n, v, lo, hi = limits
            widest = max((h[2] for h in self.rotor.holders), default=None)
            hint = (f" (links keep clear of the holders, {2 * widest:g} mm across)"
                    if widest is not None and widest == self.rotor.safe_radius(0.0) else "")
            raise MachineError(f"{what}: axis {n} would reach {v:.6g}, outside its limits {lo:g}..{hi:g} on machine "
                               f"{self.m.name}{hint}")
        solid = self.rotor.solid_at(first[1])
        advice = ("move the holder away from the body" if solid is not None and solid.startswith("holder")
                  else "raise --clearance or check the machine's rotary axes")
        raise OperationError(f"{what}: no link stays out of the rotor (the tool enters "
                             f"{solid or self.rotor.solids_words} by {first[0]:.3g} mm at "
                             f"{np.round(first[1], 3).tolist()} in the rotor frame even when lifted); {advice}")


def segment_intrusion(machine, rotor, r0, r1, local, gauge, step):
    """Deepest intrusion (depth, fraction, point) of one program segment into the stock or a keep-out solid
    (shafts and holders, :attr:`.rotor_body.RotorBody.keep_out`): a move of the linear axes alone is a
    translation in the rotor frame (:func:`clearance.translation_intrusion`, exact); one whose machine joints
    only turn the spin keeps every tool point's rho and z, so its end points decide (with TCP the control moves
    the tip on the chord instead of the arc: the solids are grown by the sagitta); any other is sampled
    (:func:`clearance.move_intrusion`)."""
    from .clearance import tool_points, translation_intrusion

    d = np.subtract(r1, r0)
    ispin = 3 + machine.rotary_names.index(machine.spin)
    moving = np.flatnonzero(np.abs(d) > 1e-12)
    if len(moving) and moving.max() < 3:                  # linear axes only: a translation in the rotor frame
        tips, axes = machine.forward(np.array([r0, r1]), gauge)
        pts = place_points(local, tips[0], axes[0])[0]
        depth, pt = translation_intrusion(rotor, pts, tips[1] - tips[0])
        return depth, 0.0, pt
    J = machine.machine_joints(np.array([r0, r1]), gauge)
    dj = np.flatnonzero(np.abs(J[1] - J[0]) > 1e-9)
    if list(dj) == [ispin]:              # the machine turns the spin alone: rho and z of every point stay
        pts = tool_points(machine, np.array([r0, r1]), local, gauge)
        margin = 0.0
        if machine.tcp:                  # a TCP control runs the tip on the chord: off the arc by the sagitta
            reach = float(np.hypot(pts[..., 0], pts[..., 1]).max())
            margin = reach * (1.0 - math.cos(math.radians(abs(J[1, ispin] - J[0, ispin])) / 2.0))
        depth = rotor.intrusion(pts.reshape(-1, 3), margin=margin).reshape(pts.shape[:2])
        k = np.unravel_index(np.argmax(depth), depth.shape)
        return float(depth[k]), float(k[0]), pts[k].tolist()
    return move_intrusion(machine, rotor, r0, r1, local, gauge, step=step,
                          reach=reach_of(machine, [r0, r1], local, gauge))


def _rapid_time(machine, a, b):
    d = np.abs(np.subtract(machine.machine_joints(b), machine.machine_joints(a)))[0]
    return max(d[i] / machine.axes[n].rapid for i, n in enumerate(machine.axis_names))


def _order(pl, passes, directions, spin=None):
    """Greedy nearest-neighbour order of one tool's passes: [(pass, reverse, ts, rows)].  ``spin``: where the spin
    axis stands before the first pass (the previous tool's last angle: a tool change leaves it there), so the
    first pass starts at the turn nearest to it instead of unwinding what the earlier tools turned."""
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
                at = spin if cur is None else cur[pl.ispin]
                shift = 0.0 if at is None else 360.0 * round((at - rows[0, pl.ispin]) / 360.0)
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


def _check_out_of_tool_change(pl, tool, stood, first, label):
    """Refuse the moves from where the tool-change cycle leaves the machine (``stood``: the joints where the
    previous tool ended, None before the first) to the program row ``first`` when the tool enters the stock or a
    shaft on the way; nothing to check without a ``tool_change_position``, or for a block whose start stays
    unknown (the first tool's rotaries, when the file does not give them)."""
    m = pl.m
    if m.tool_change_position is None:
        return
    here = m.after_tool_change(stood)
    row = m.program_rows(here, tool.gauge_length)[0] if np.isfinite(here).all() else here
    seq = [row]
    for group in m.tool_change_groups():       # the blocks the post writes, in their order
        row = row.copy()
        row[group] = first[group]
        seq.append(row)
    seq = [r for r in seq if np.isfinite(r).all()]      # from an unknown start: the blocks after it
    depth, pt = pl.check(tool.number, seq, label) if len(seq) > 1 else (0.0, None)
    if depth > 0:
        raise OperationError(f"the move of tool {tool.number} out of the tool-change position to {label} enters "
                             f"{pl.rotor.solid_at(pt) or pl.rotor.solids_words} by {depth:.3g} mm at "
                             f"{np.round(pt, 3).tolist()} in the rotor frame: move the machine file's "
                             "tool_change_position away from the rotor")


def lift_rows(machine, row, gauge, to=None):
    """Program rows (2, axes) of the straight move from program row ``row`` along the retract axis
    (:attr:`.machine.Machine.retract_axis`, Z on a vertical machine) to joint value ``to`` of that axis, rotaries
    fixed; by default to the end of its travel on the tool side (Z up): the way the tool-change cycle on most
    machines takes the tool, which the program does not see.  A reference return (Fanuc G28) moves it to the
    machine file's ``reference_position``, on that way or not."""
    name, end = machine.retract_axis
    J = machine.machine_joints(np.array([row], float), gauge)[0]
    J1 = J.copy()
    J1[machine.axis_names.index(name)] = end if to is None else to
    return machine.program_rows(np.array([J, J1]), gauge)


def _check_lift(pl, tool, row):
    """Refuse a program whose tool, where it ends, cannot be moved straight along the retract axis to the end of
    its travel (:func:`lift_rows`: the tool-change cycle's way) and, where the machine file gives it, to the
    reference position (a Fanuc G28 takes it there, whichever side it lies) without entering the stock, a shaft
    or a holder."""
    name, end = pl.m.retract_axis
    targets = [("the end of its travel", end, "the way the tool-change cycle takes it")]
    if pl.m.reference_position is not None:
        targets.append(("the reference position", pl.m.reference_position[name], "the way a reference return "
                                                                                  "takes it"))
    for what, to, way in targets:
        seq = list(lift_rows(pl.m, row, tool.gauge_length, to))
        depth, pt = pl.check(tool.number, seq, f"lift after tool {tool.number}")
        if depth > 0:
            solid = pl.rotor.solid_at(pt) or pl.rotor.solids_words
            raise OperationError(f"tool {tool.number} ends where moving it along {name} to {to:g} ({what}: {way}) "
                                 f"enters {solid} by {depth:.3g} mm at {np.round(pt, 3).tolist()} in the rotor "
                                 "frame: check the machine file's tool_axis, reference_position and rotary axes")


def build_program(op, machine, direction="forward", chord_tolerance=1e-3, step=1.0, spacing=1.5, coolant="flood"):
    """:class:`Program` of an :class:`operation.Operation` on ``machine`` (module doc).

    direction: "forward" (the plan's CL direction: tool from above the body down), "reverse" or "zigzag";
    chord_tolerance: TCP chord sagitta (mm); step / spacing: sampling of the link checks (mm); coolant: one of
    :data:`COOLANTS`, turned on with every tool ("off": a dry cut)."""
    if direction not in DIRECTIONS:
        raise ValueError(f"direction {direction!r} is not one of {', '.join(DIRECTIONS)}")
    if coolant not in COOLANTS:
        raise ValueError(f"coolant {coolant!r} is not one of {', '.join(COOLANTS)}")
    if not (math.isfinite(chord_tolerance) and 0 < chord_tolerance <= MAX_CHORD_TOLERANCE_MM):
        raise ValueError(f"chord tolerance {chord_tolerance!r} must be a number > 0 and at most "
                         f"{MAX_CHORD_TOLERANCE_MM:g} mm: a chord's sagitta moves the tool off the plan's screw motion")
    pl = _Planner(op, machine, direction, chord_tolerance, step, spacing)
    rotor = op.rotor
    dirs = {"forward": (False,), "reverse": (True,), "zigzag": (False, True)}[direction]
    names = machine.axis_names
    ops = [{"op": "comment", "text": f"machine {machine.name}, {len(op.passes)} passes on lobes "
                                     f"{','.join(map(str, op.lobes))}, clearance {op.clearance:g} mm"}]
    if machine.tcp:
        ops.append({"op": "tcp", "on": True})
    passes_out, spin, stood = [], None, None     # stood: the joints where the previous tool ended
    for tool in op.tools:
        mine = [p for p in op.passes if p.tool == tool.number]
        if not mine:
            continue
        engaged = {id(p): engagement(tool.shape, p.tip, p.axis, rotor) for p in mine}
        D = max(e.diameter for e in engaged.values())
        if not D > 0:
            raise OperationError(f"tool {tool.number} never enters the stock cylinder: nothing to cut")
        tool.rpm = spindle_speed(tool.data, D, machine.max_rpm)
        ops.append({"op": "tool", "number": tool.number, "rpm": tool.rpm, "coolant": coolant,
                    "text": f"{tool.name}; {tool.data.flutes} flutes, vc {tool.data.vc_m_min:g} m/min, "
                            f"fz {tool.data.fz_mm:g} mm ({tool.data.source})"})
        prev = None
        for ps, rev, ts, rows in _order(pl, mine, dirs, spin):
            ps.reverse = rev
            label = f"pass {len(passes_out) + 1} ({ps.label})"
            if machine.tcp and ps.shaft_margin < chord_tolerance + TCP_ROUNDING_MM:
                # the control runs the tip on chords, up to the sagitta off the helix (and the whole rigid tool
                # with it): the read-back counts that against the clearance of a shaft or holder the pass crosses
                hit, advice = nearest_keep_out(tool.shape, ps.tip, ps.axis, rotor, op.clearance,
                                               pl.local[tool.number])
                raise OperationError(f"{label}: the tool passes {ps.shaft_margin:.3g} mm outside {hit}, and on "
                                     f"this TCP machine its chords of {chord_tolerance:g} mm sagitta may come "
                                     f"nearer: lower the chord tolerance (post --chord-tolerance){advice}")
            mj = machine.machine_joints(rows, tool.gauge_length)
            for axis_name, value, lo, hi in machine.limit_violations(mj):
                hint = (" (the rotor mounted the other way round, --flip-rotor, may reach it)"
                        if axis_name == machine.tilt and "flipped" not in machine.name else "")
                raise MachineError(f"{label}: axis {axis_name} reaches {value:.6g}, outside its limits "
                                   f"{lo:g}..{hi:g} on machine {machine.name}{hint}")
            link = pl.link(tool.number, prev, rows[0], f"link to {label}")
            if prev is None:
                _check_out_of_tool_change(pl, tool, stood, link[0], label)
            for r in link[1:-1] if prev is not None else link[:-1]:
                ops.append({"op": "rapid", "row": r})
            ops.append({"op": "rapid", "row": rows[0]})
            span = float(ts[-1] - ts[0])
            rates = np.abs(mj[-1] - mj[0]) / abs(span)
            try:
                cond = pass_conditions(tool.shape, ps.tip, ps.axis, rotor, tool.data, tool.rpm, span, rates,
                                       (names, [machine.axes[n].max_feed for n in names]), engaged[id(ps)])
            except ValueError as e:                   # named by its pass
                raise OperationError(f"{label}: {e}") from None
            ops.append({"op": "comment", "text": f"PASS {len(passes_out) + 1} plan {ps.plan} strip {ps.strip} "
                                                 f"lobe {ps.lobe} flank {ps.flank} T{tool.number}"
                                                 f"{' reverse' if rev else ''}"})
            for k in range(1, len(rows)):
                ops.append({"op": "feed", "row": rows[k], "pass": len(passes_out),
                            "time_min": abs(float(ts[k] - ts[k - 1])) / cond.omega})
            passes_out.append({"pass": len(passes_out) + 1, "plan": ps.plan, "strip": ps.strip, "lobe": ps.lobe,
                               "flank": ps.flank, "tool": tool.number, "reverse": rev, "blocks": len(rows) - 1,
                               "t_range": [float(ts[0]), float(ts[-1])],
                               # null when the pass crosses no shaft or holder: strict JSON has no Infinity
                               "shaft_margin_mm": ps.shaft_margin if math.isfinite(ps.shaft_margin) else None,
                               "start": dict(zip(names, rows[0].tolist())), "end": dict(zip(names, rows[-1].tolist())),
                               **cond.as_dict()})
            prev = rows[-1]
        for r in pl.link(tool.number, prev, None, f"retract after tool {tool.number}")[1:]:
            ops.append({"op": "rapid", "row": r})
        _check_lift(pl, tool, ops[-1]["row"])
        spin = float(ops[-1]["row"][pl.ispin])      # where the tool change leaves the spin axis
        stood = machine.machine_joints(ops[-1]["row"], tool.gauge_length)[0]
    if machine.tcp:
        ops.append({"op": "tcp", "on": False})
    ops.append({"op": "end"})
    return Program(machine=machine, operation=op, ops=ops, passes=passes_out)
