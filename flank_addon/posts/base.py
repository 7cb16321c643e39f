"""The interface every post (dialect) implements: a writer from a :class:`machining.toolpath.Program` to text
and a reader from text back to moves, plus what they share (number formats, the write loop, atomic files).

Writer: the program's rows are rounded to the dialect's resolution *before* feeds are computed, so the feed
of a block describes the block the controller really runs.  Axis words are modal: a block names the axes
that change (all of them after a tool change).

Reader: a :class:`ReadProgram` of :class:`Move` s with full program rows at both ends, the feed mode and value
as written, the active tool, spindle speed, spindle rotation, length compensation, work offset and TCP state,
and the last comment before the move.
Anything the reader does not know is refused with the line number (:class:`PostError`).
"""
import math
import os
from dataclasses import dataclass, field

import numpy as np

from ..io.files import atomic_write as io_atomic_write


class PostError(ValueError):
    """An unknown post, a program the reader cannot follow (line named) or an output that cannot be written."""


# how far the rounding of a cutting block's axis words to the control's input increments may move the tool: half
# the 0.01 mm by which the read-back lets a pass leave its strip (readback.MATCH_TOL_MM), the other half left to
# the chords of TCP passes (toolpath.MAX_CHORD_TOLERANCE_MM)
MAX_ROUNDING_MM = 5e-3


@dataclass
class Move:
    kind: str                 # "rapid" | "feed"
    start: np.ndarray         # program row (X, Y, Z, rotaries) before the move
    end: np.ndarray
    feed_mode: str            # "inverse_time" | "per_minute" | "combined" | "tip_speed" ("" for rapids)
    feed: float
    line: int
    tool: int
    rpm: float
    tcp: bool
    comment: str = ""
    spindle: str = ""         # "cw" (M3), "ccw" (M4) or "off" during the move, as the reader follows it; "": not read
    length_comp: int = None   # the tool whose length compensation is active (G43 H<n>; TOOL CALL), None: none
    work_offset: str = ""     # the active work offset (G54 ... G59.3); "" where the dialect has none in its words
    coolant: str = ""         # "flood", "mist", "mist+flood" or "off" during the move, as the reader follows it


def coolant_state(mist, flood):
    """The :attr:`Move.coolant` text of the two coolants' states."""
    return "mist+flood" if mist and flood else "flood" if flood else "mist" if mist else "off"


@dataclass
class ReadProgram:
    moves: list = field(default_factory=list)
    tool_changes: list = field(default_factory=list)     # (tool number, line)
    comments: list = field(default_factory=list)
    axes: list = field(default_factory=list)
    end_line: int = 0            # line of the program's end (M2 / M30, END PGM); 0: the text ends without one
    # returns to the reference position (Fanuc G91 G28 Z0.): (line, program row before it, index of the axis, tool)
    reference_returns: list = field(default_factory=list)


def fixed(x, decimals):
    """``x`` with ``decimals`` decimals, never exponent notation, no negative zero."""
    s = f"{float(x):.{decimals}f}"
    return s[1:] if s.startswith("-") and float(s) == 0 else s


def feed_text(F, significant=7, max_decimals=6, down=False):
    """A positive feed with about ``significant`` digits in plain decimal notation; ``down``: cut to those digits
    rather than rounded (a control's input increment: the block may only get slower, never over its chip load)."""
    F = float(F)
    if not (math.isfinite(F) and F > 0):
        raise PostError(f"feed {F!r} must be a finite number > 0")
    dec = min(max_decimals, max(0, significant - 1 - int(math.floor(math.log10(F)))))
    text = fixed(math.floor(F * 10.0 ** dec) / 10.0 ** dec if down else F, dec)
    if not float(text) > 0:
        raise PostError(f"feed {F:.3g} {'is cut' if down else 'rounds'} to {text}: below the smallest feed the "
                        f"program writes ({10.0 ** -max_decimals:g}); raise the feed per tooth or the cutting speed")
    return text


class Post:
    """One controller dialect.  Subclasses set ``name``, ``extension``, ``description``, the resolutions and
    implement the ``_header`` / ``_tool`` / ``_rapid`` / ``_feed`` / ... hooks and :meth:`read`."""
    name = ""
    extension = ""
    description = ""
    linear_decimals = 4
    rotary_decimals = 4

    # ------------------------------------------------------------------ writing
    def decimals(self, machine):
        """(linear, rotary) decimals of the program's axis words: the machine file's least input increments
        (``controller.increment_mm`` / ``increment_deg``) where it gives them, else the dialect's own."""
        from ..machining.machine import increment_decimals

        return tuple(self_dec if inc is None else increment_decimals(inc)
                     for self_dec, inc in ((self.linear_decimals, machine.increment_mm),
                                           (self.rotary_decimals, machine.increment_deg)))

    def feed_text(self, F, machine, significant=7, max_decimals=6):
        """The F word's value: :func:`feed_text` cut down to its digits, never rounded up (a block may only get
        slower than planned: rounded to nearest, the fastest point's chip load went over fz by up to half a unit
        of the last digit), with at most the decimals of the machine's length increment where its file gives
        one."""
        if machine.increment_mm is not None:
            max_decimals = min(max_decimals, self.decimals(machine)[0])
        return feed_text(F, significant, max_decimals, down=True)

    def round_row(self, row, machine):
        lin, rot = self.decimals(machine)
        r = np.asarray(row, float).copy()
        r[:3] = np.round(r[:3], lin)
        r[3:] = np.round(r[3:], rot)
        return r + 0.0

    def words(self, names, row, prev, force, machine):
        lin, rot = self.decimals(machine)
        out = []
        for i, n in enumerate(names):
            if force or prev is None or row[i] != prev[i]:
                out.append((n, row[i], lin if i < 3 else rot))
        return out

    def write(self, program):
        """The program text (the dialect's conventions, docs/posts.md)."""
        m = program.machine
        names = m.axis_names
        self.lines, self.state = [], {"mode": None, "tool": None}
        rounded = []          # (tool, exact row, rounded row, line) of every feed block
        self._header(program)
        cur, force = None, True
        for op in program.ops:
            kind = op["op"]
            if kind == "comment":
                self._comment(op["text"])
            elif kind == "tool":
                self._tool(op, program)
                force = True
                self.state["tool"] = op["number"]
            elif kind == "tcp":
                self._tcp(op["on"], program)
            elif kind in ("rapid", "feed"):
                row = self.round_row(op["row"], m)
                words = self.words(names, row, cur, force, m)
                if not words and not force:
                    continue
                if kind == "rapid" and force:
                    # out of the tool change, from where its cycle leaves the machine: the machine's blocks
                    for group in m.tool_change_groups():
                        axes = [names[i] for i in group]
                        self._rapid([w for w in words if w[0] in axes], program)
                elif kind == "rapid":
                    self._rapid(words, program)
                else:
                    self._feed(words, self.feed_value(cur, row, op["time_min"], m), program)
                    rounded.append((self.state["tool"], op["row"], row, len(self.lines)))
                cur, force = row, False
            elif kind == "end":
                self._footer(program)
        if m.increment_mm is not None or m.increment_deg is not None:
            self._check_rounding(program, rounded)
        return "\n".join(self.lines) + "\n"

    def _check_rounding(self, program, rounded):
        """:class:`PostError` when the axis words, rounded to the machine file's input increments, move a cutting
        pose by more than MAX_ROUNDING_MM: the tip's shift plus the axis' turn over the tool's gauge length, in the
        rotor frame.  (The dialects' own 4 decimals move it by well under a micrometre.)"""
        m, worst = program.machine, (0.0, 0)
        for number in sorted({t for t, _, _, _ in rounded}):
            mine = [r for r in rounded if r[0] == number]
            gauge = program.operation.tool(number).gauge_length
            exact, rows = (np.array([r[k] for r in mine], float) for k in (1, 2))
            (t0, a0), (t1, a1) = m.forward(exact, gauge), m.forward(rows, gauge)
            moved = np.linalg.norm(t1 - t0, axis=1) + gauge * np.linalg.norm(a1 - a0, axis=1)
            k = int(np.argmax(moved))
            if moved[k] > worst[0]:
                worst = (float(moved[k]), mine[k][3])
        if worst[0] > MAX_ROUNDING_MM:
            inc = ", ".join(f"{v:g} {u}" for v, u in ((m.increment_mm, "mm"), (m.increment_deg, "deg")) if v)
            raise PostError(f"the control's input increment ({inc}, machine {m.name}) moves the tool by up to "
                            f"{worst[0]:.4g} mm at line {worst[1]}, over the {MAX_ROUNDING_MM:g} mm a cutting block "
                            "may move when rounded: the passes would leave their strips; a control this coarse "
                            "cannot cut this plan as planned")

    def feed_value(self, start, end, time_min, machine):
        """The F word of a feed block taking ``time_min`` (default: inverse time, 1 / minutes)."""
        return 1.0 / time_min

    # hooks
    def _header(self, program):
        raise NotImplementedError

    def _footer(self, program):
        raise NotImplementedError

    def _comment(self, text):
        raise NotImplementedError

    def _tool(self, op, program):
        raise NotImplementedError

    def _tcp(self, on, program):
        raise NotImplementedError

    def _rapid(self, words, program):
        raise NotImplementedError

    def _feed(self, words, F, program):
        raise NotImplementedError

    # ------------------------------------------------------------------ reading
    def read(self, text, machine):
        raise NotImplementedError


def header_lines(program, post):
    """Comment lines every dialect starts with (plain text; the dialect wraps them)."""
    m, op = program.machine, program.operation
    rb = op.rotor
    # only where the machine file gives the control's increments: a program without them stays as it was
    increments = [f"{v:g} {unit}" for v, unit in ((m.increment_mm, "mm"), (m.increment_deg, "deg")) if v]
    return [f"Flank Toolpath program, post {post.name}, machine {m.name} version {m.version}"
            + (" with TCP" if m.tcp else ""),
            "units mm and degrees; program zero = the plan's rotor-frame origin"] + (
        [f"axis words{' and feeds' if m.increment_mm else ''} to the control's input increment: "
         f"{', '.join(increments)}"] if increments else []) + [
            f"rotor: {'right' if rb.hand > 0 else 'left'}-handed, v0 {rb.v0:.6f} mm/rad, lobes {rb.lobes}, "
            f"outer radius {rb.outer_radius:.4f}, body z {rb.z_range[0]:.4f}..{rb.z_range[1]:.4f}"] + [
        # the setup the program was checked against: the machine operator has to keep to it
        f"holder {k + 1}: diameter {2 * r:.4f} over {a:.4f}..{b:.4f} along the rotor axis, kept clear of; mount it "
        "no nearer the body"
        for k, (a, b, r) in enumerate(rb.holders)] + [
        line for tool in op.tools if any(p.tool == tool.number for p in op.passes) for line in tool_lines(tool)]


def tool_lines(tool):
    """Comment lines of a tool as the program was checked with it: its shank along its axis from the programmed
    tip, and how far from the tip its holder must stay (nothing beyond the shank's end was part of the checks of
    links and passes: a holder nearer the tip may hit what they kept the tool clear of)."""
    shank = tool.shape.shank
    return ([f"T{tool.number} shank: diameter {2 * shank[2]:.4f} over {shank[0]:.4f}..{shank[1]:.4f} mm from the tip"]
            if shank is not None else []) + [
        f"T{tool.number} checked up to {tool.gauge_length:.4f} mm from the tip (gauge length): keep its holder beyond"]


def atomic_write(path, text):
    """Write a program as ASCII with \\n line ends, whole or not at all (:func:`..io.files.atomic_write`);
    :class:`PostError` with the reason when it cannot be."""
    try:
        io_atomic_write(path, text, encoding="ascii", newline="\n")
    except (OSError, UnicodeEncodeError) as e:
        raise PostError(f"cannot write {os.fspath(path)}: {getattr(e, 'strerror', None) or e}") from None
