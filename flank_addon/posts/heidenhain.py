"""Heidenhain conversational (Klartext) post: writer and reader.

Program: numbered blocks ``0 BEGIN PGM FLANK MM`` ... ``END PGM FLANK MM``; comments ``; text``; a BLK FORM
around the stock; per tool ``TOOL CALL <n> Z S<rpm>``; straight moves ``L X+.. Y+.. A+.. R0 FMAX`` (rapid)
or ``L ... F<feed>``; signed coordinates with 4 decimals; the first move of a tool switches the spindle and
flood coolant on (``M13``; ``M3`` for a dry cut, and mist is refused: its M function is the machine builder's);
``M5 M9``, ``M30`` at the end.

Feed of simultaneous moves: Klartext has no inverse-time mode.  Without M116 the TNC reads F in a block that
moves linear and rotary axes as the feed along the combined axis vector, degrees counted like millimetres;
the post writes F = sqrt(sum dlinear^2 + sum drotary^2) / block minutes, so the block takes exactly its
planned time (what CAM posts call the DPM-combination feed).  On a TCP machine
``FUNCTION TCPM F TCP AXIS POS PATHCTRL AXIS`` is switched on after each TOOL CALL (tool tip programmed in work
coordinates, rotary axes as positions, F the speed of the tool tip relative to the workpiece, the axes
interpolated linearly) and F = |d tip| / block minutes; ``FUNCTION RESET TCPM`` before the next TOOL CALL (the
TNC's manuals ask for it there) and at the end.  The rotor's spin axis must count
continuously (no modulo display, M126 off).
"""
import re

import numpy as np

from .base import Move, Post, PostError, ReadProgram, fixed, header_lines

NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)"


# the TNC's spindle M functions: M3 / M4 (M13 / M14 with coolant) act at the start of their block, M5, the
# program's stops (M0, M1), the tool change M6 and the program's end (M2, M30) at its end
SPINDLE_AT_START = {"M3": "cw", "M13": "cw", "M4": "ccw", "M14": "ccw"}
SPINDLE_AT_END = {"M5": "off", "M0": "off", "M1": "off", "M6": "off", "M2": "off", "M30": "off"}
# and its coolant: M8 (M13 / M14 with the spindle) on from the start of its block; M9, the program's stops and
# its end off at the end of theirs (M5 and the tool change M6 leave it)
COOLANT_AT_START = {"M8": "flood", "M13": "flood", "M14": "flood"}
COOLANT_AT_END = {"M9": "off", "M0": "off", "M1": "off", "M2": "off", "M30": "off"}
# every M function the reader follows; any other (M116 changes what F means, M128 switches TCP on, M126 the
# rotaries' shortest path, M91 / M92 machine coordinates) would make the read-back wrong, so it is refused
KNOWN_M = set(SPINDLE_AT_START) | set(SPINDLE_AT_END) | set(COOLANT_AT_START) | set(COOLANT_AT_END)


def _m_words(toks, at_start, at_end):
    """(state from the block's start, state after it; None where the block does not change it) of one of the
    TNC's M-function tables."""
    ms = ["M{}".format(int(t[1:])) for t in toks if re.fullmatch(r"M\d+", t)]       # M03 is M3
    start = [at_start[m] for m in ms if m in at_start]
    end = [at_end[m] for m in ms if m in at_end]
    return (start[-1] if start else None), (end[-1] if end else None)


TCPM_ON = "FUNCTION TCPM F TCP AXIS POS PATHCTRL AXIS"


class HeidenhainPost(Post):
    name = "heidenhain"
    extension = ".h"
    description = "Heidenhain Klartext, combined-vector feed (no M116), FUNCTION TCPM on TCP machines"

    def _line(self, text):
        self.lines.append(f"{len(self.lines)} {text}")

    def _header(self, program):
        self._line("BEGIN PGM FLANK MM")
        for t in header_lines(program, self):
            self._comment(t)
        if program.machine.tcp:
            self._comment("F of simultaneous blocks: speed of the tool tip on the workpiece (FUNCTION TCPM F TCP)")
        else:
            self._comment("F of simultaneous blocks: combined axis vector, degrees counted as mm (no M116)")
        rb = program.operation.rotor
        m = program.machine
        ext = np.array([[rb.outer_radius, rb.outer_radius, rb.z_range[1]],
                        [-rb.outer_radius, -rb.outer_radius, rb.z_range[0]]])
        corners = np.array([[x, y, z] for x in ext[:, 0] for y in ext[:, 1] for z in ext[:, 2]]) @ m.mount.T
        lo, hi = corners.min(axis=0), corners.max(axis=0)
        d = self.decimals(m)[0]                       # the blank (graphics only) to the axis words' resolution
        self._line("BLK FORM 0.1 Z " + " ".join(f"{n}{self._num(v, d)}" for n, v in zip("XYZ", lo)))
        self._line("BLK FORM 0.2 " + " ".join(f"{n}{self._num(v, d)}" for n, v in zip("XYZ", hi)))

    def _footer(self, program):
        self._line("M5")
        self._line("M9")
        self._line("M30")
        self._line("END PGM FLANK MM")

    def _comment(self, text):
        self._line("; " + str(text).replace(";", ","))

    def _num(self, v, d):
        s = fixed(v, d)
        return s if s.startswith("-") else "+" + s

    def _tool(self, op, program):
        self._comment(op["text"])
        if op["coolant"] not in ("flood", "off"):
            raise PostError(f"coolant {op['coolant']!r}: the Klartext post turns on flood coolant (M13: spindle "
                            "and coolant) or none (M3, a dry cut); which M function turns on mist is the machine "
                            "builder's choice on a TNC")
        if self.state.get("tcpm_active"):           # the TNC wants TCPM reset before a TOOL CALL
            self._line("FUNCTION RESET TCPM")
        self._line(f"TOOL CALL {op['number']} Z S{fixed(op['rpm'], 0)}")
        self.state["spindle_on"] = "M13" if op["coolant"] == "flood" else "M3"
        self.state["tcpm_active"] = bool(self.state.get("tcpm"))
        if self.state["tcpm_active"]:
            self._line(TCPM_ON)

    def _tcp(self, on, program):
        """TCP on: FUNCTION TCPM after each TOOL CALL (reset before the next); off: reset it."""
        self.state["tcpm"] = on
        if not on and self.state.get("tcpm_active"):
            self._line("FUNCTION RESET TCPM")
            self.state["tcpm_active"] = False

    def _axes(self, words):
        return " ".join(f"{n}{self._num(v, d)}" for n, v, d in words)

    def _rapid(self, words, program):
        on = self.state.pop("spindle_on", None)
        m = f" {on}" if on else ""
        self._line("L " + self._axes(words) + " R0 FMAX" + m)

    def _feed(self, words, F, program):
        self._line("L " + self._axes(words) + " F" + self.feed_text(F, program.machine, 8, 4))

    def feed_value(self, start, end, time_min, machine):
        d = np.abs(np.subtract(end, start))
        if machine.tcp:
            dist = float(np.linalg.norm(d[:3])) or float(np.linalg.norm(d[3:]))
        else:
            dist = float(np.linalg.norm(d))
        return dist / time_min

    # ------------------------------------------------------------------ reading
    def read(self, text, machine):
        names = machine.axis_names
        out = ReadProgram(axes=list(names))
        row = np.full(len(names), np.nan)
        F, tool, rpm, tcp, comment, spindle, coolant = None, 0, 0.0, False, "", "off", "off"
        axis_word = re.compile(r"^([XYZABC])(" + NUMBER + r")$")
        for no, raw in enumerate(text.splitlines(), 1):
            line = raw.strip()
            if not line:
                continue
            m = re.match(r"^(\d+)\s*(.*)$", line)
            if not m:
                raise PostError(f"line {no}: a Klartext block starts with its number: {line!r}")
            body = m.group(2).strip()
            if body.startswith(";"):
                comment = body[1:].strip()
                out.comments.append((no, comment))
                continue
            if ";" in body:
                body, c = body.split(";", 1)
                comment = c.strip()
                out.comments.append((no, comment))
            toks = body.split()
            if not toks:
                continue
            if toks[:2] in (["BEGIN", "PGM"], ["END", "PGM"]) or toks[:2] == ["BLK", "FORM"]:
                if toks[2:3] and toks[0] == "BEGIN" and toks[-1] != "MM":
                    raise PostError(f"line {no}: only MM programs are read, got {toks[-1]!r}")
                if toks[:2] == ["END", "PGM"]:
                    out.end_line = out.end_line or no
                continue
            if toks[:2] == ["TOOL", "CALL"]:
                if int(toks[2]) != tool:
                    spindle = "off"                 # a tool change stops the spindle
                tool = int(toks[2])
                for t in toks[3:]:
                    if t.startswith("S"):
                        rpm = float(t[1:])
                out.tool_changes.append((tool, no))
                row = np.full(len(names), np.nan)   # the tool-change cycle moves the machine unseen
                continue
            if toks[:2] == ["FUNCTION", "TCPM"]:
                tcp = True
                continue
            if toks[:3] == ["FUNCTION", "RESET", "TCPM"]:
                tcp = False
                continue
            for t in toks:
                if re.fullmatch(r"M\d+", t) and f"M{int(t[1:])}" not in KNOWN_M:
                    raise PostError(f"line {no}: {t} is not supported by the reader (it follows "
                                    f"{', '.join(sorted(KNOWN_M, key=lambda m: int(m[1:])))})")
            at_start, at_end = _m_words(toks, SPINDLE_AT_START, SPINDLE_AT_END)
            cool_start, cool_end = _m_words(toks, COOLANT_AT_START, COOLANT_AT_END)
            spindle, coolant = at_start or spindle, cool_start or coolant
            if toks[0] != "L":
                if all(re.fullmatch(r"M\d+", t) for t in toks):
                    spindle, coolant = at_end or spindle, cool_end or coolant
                    continue
                raise PostError(f"line {no}: {toks[0]!r} blocks are not supported by the reader")
            new, rapid, moved = row.copy(), False, False
            for t in toks[1:]:
                am = axis_word.match(t)
                if am and am.group(1) in names:
                    new[names.index(am.group(1))] = float(am.group(2))
                    moved = True
                elif t == "FMAX":
                    rapid = True
                elif re.fullmatch(r"F" + NUMBER, t):
                    F = float(t[1:])
                elif t in ("R0",) or re.fullmatch(r"M\d+", t):
                    pass
                else:
                    raise PostError(f"line {no}: {t!r} is not supported by the reader"
                                    f" (axes of machine {machine.name}: {' '.join(names)})")
            if not moved:
                spindle, coolant = at_end or spindle, cool_end or coolant
                continue
            if not rapid and not (F is not None and F > 0):
                raise PostError(f"line {no}: L block without a feed (F or FMAX)")
            mode = "" if rapid else ("tip_speed" if tcp else "combined")
            out.moves.append(Move("rapid" if rapid else "feed", row.copy(), new.copy(), mode,
                                  0.0 if rapid else F, no, tool, rpm, tcp, comment, spindle,
                                  tool or None, coolant=coolant))   # TOOL CALL compensates the tool's length
            row = new
            spindle, coolant = at_end or spindle, cool_end or coolant
        return out
