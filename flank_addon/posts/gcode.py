"""What the ISO G-code dialects (LinuxCNC rs274ngc, Fanuc) share: the block reader.

The reader follows the modal state a controller keeps (motion G0/G1, feed mode G93/G94, axis values, F, the
selected tool T and the tool in the spindle, spindle speed, spindle rotation M3/M4/M5, coolant M7/M8/M9, tool
length compensation G43 [H<n>] ... G49, work offset G54 ... G59.3, TCP G43.4/G43.5 ... G49) and turns every
block that moves into a :class:`base.Move`.  Within a block it keeps rs274ngc's order of execution: the tool
change (M6 puts the selected tool in the spindle, stops the spindle and leaves the coolant and the length
compensation as they were), then the spindle words, then the coolant (M7 mist and M8 flood each on, M9 both
off; one of them per block), then the length compensation, then the motion; the program's end (M2, M30) comes
after the motion, and nothing after it is read (the controller never runs it).  It knows the words the posts write and the usual preamble codes;
anything else (incremental G91 but for a Fanuc reference return, inch G20, arcs, canned cycles, subprograms,
expressions, Q and D words, P but with G64) is refused with its line number, and so is what the controls refuse:
a word twice in one block (G and M aside), two spindle or two coolant words in one block, a fractional T or H.
"""
import re

import numpy as np

from .base import Move, Post, PostError, ReadProgram, coolant_state, fixed

WORD = re.compile(r"([A-Z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")
IGNORED_G = {"17", "21", "40", "61", "61.1", "64", "80", "90"}
WORK_OFFSETS = {"54", "55", "56", "57", "58", "59", "59.1", "59.2", "59.3"}
IGNORED_M = {"0", "1", "2", "30"}
# the M word that turns on a program's coolant (:data:`..machining.toolpath.COOLANTS`; "off": none)
COOLANT_ON = {"flood": 8, "mist": 7}


def strip_comments(line, semicolon):
    comments = re.findall(r"\(([^)]*)\)", line)
    code = re.sub(r"\([^)]*\)", " ", line)
    if semicolon and ";" in code:
        code, rest = code.split(";", 1)
        comments.append(rest.strip())
    return code, [c.strip() for c in comments]


def read_gcode(text, machine, semicolon_comments=True, tcp_codes=False, reference_return=False):
    """:class:`ReadProgram` of ISO G-code ``text`` for ``machine`` (rows in its axis order).

    ``tcp_codes`` False, rs274ngc (LinuxCNC): TCP is the machine's; G43 takes the offset of tool H, of the tool
    in the spindle without H or with H0; an H word needs a G43 in its block.  ``tcp_codes`` True, Fanuc: G43.4 /
    G43.5 switch TCP on, G43 and G49 (the same modal group) off; H is modal, G43 without H takes the latest H
    (H0: no offset), and an H word while G43 is on changes the offset.

    ``reference_return`` True (Fanuc): ``G91 G28 Z0.`` (the machine's retract axis, :attr:`..machining.machine.
    Machine.retract_axis`) returns that axis straight to its reference position, which the program does not
    know: the axis is unknown after it (with TCP on, every linear program axis), and the return is kept in
    :attr:`ReadProgram.reference_returns` for the link checks.  G91 is followed only for that block; an axis
    word under it elsewhere is refused, and so is G28 in G90 (its axis words would be a point to pass first)."""
    names = machine.axis_names
    out = ReadProgram(axes=list(names))
    row = np.full(len(names), np.nan)
    # ``tool``: the latest T word (selected); ``loaded``: the tool in the spindle, changed in by M6 (a program
    # without any M6 is taken to cut with the tool its T word names)
    changes = any(re.search(r"M0*6(?![\d.])", re.sub(r"\s", "", strip_comments(ln, semicolon_comments)[0].upper()))
                  for ln in text.splitlines())
    motion, mode, F, tool, rpm, spindle, comp = None, "per_minute", None, 0, 0.0, "off", None
    mist = flood = False            # the coolants: off at power-on
    loaded = 0 if changes else None     # with an M6 in the program, no tool is in the spindle before the first
    h_modal, comp_on = 0, False     # Fanuc: the latest H word; whether G43 / G43.4 / G43.5 is on
    work = "G54"                    # the controllers' power-on work offset
    tcp = machine.tcp and not tcp_codes
    incremental = False             # G91 (only with reference_return, for G28)
    up = machine.retract_axis[0]
    comment = ""
    started = False
    for no, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if line.startswith("%"):
            if started:
                break
            started = True
            continue
        code, comments = strip_comments(line, semicolon_comments)
        for c in comments:
            out.comments.append((no, c))
            comment = c
        code = re.sub(r"\s", "", code.upper())      # spaces and tabs mean nothing between words
        if not code:
            continue
        if re.fullmatch(r"[O:]\d+", code):        # a program number
            continue
        if code.startswith("O"):
            raise PostError(f"line {no}: O-word control flow ({raw.strip()!r}) is not supported by the reader")
        pos, words = 0, []
        for mt in WORD.finditer(code):
            if mt.start() != pos:
                raise PostError(f"line {no}: cannot read {code[pos:mt.start()]!r} in {raw.strip()!r}")
            words.append((mt.group(1), mt.group(2)))
            pos = mt.end()
        if pos != len(code):
            raise PostError(f"line {no}: cannot read {code[pos:]!r} in {raw.strip()!r}")
        new = row.copy()
        moved, f_here, tool_change, named, turn, length, h_word = False, None, False, [], None, None, None
        end_stop = False                # M2 / M30: the program ends after the block's motion
        cool = set()                    # the block's coolant words
        turns = set()                   # the block's spindle words (one modal group)
        ret, distance = False, None     # G28 in the block; G90 / G91 in the block
        once = {}                       # words a block may hold once (all but G and M)
        for letter, value in words:
            if letter not in "GM":
                if letter in once:
                    raise PostError(f"line {no}: two {letter} words in one block ({letter}{once[letter]}, "
                                    f"{letter}{value}): the control refuses it")
                once[letter] = value
            if letter in "THD" and float(value) != int(float(value)):
                raise PostError(f"line {no}: {letter}{value} is not a whole number")
            if letter in "FSTHN" and float(value) < 0:
                raise PostError(f"line {no}: {letter}{value} is negative")
            if letter == "G":
                g = value.lstrip("0") or "0"
                g = g[:-2] if g.endswith(".0") else g
                if g in ("0", "1"):
                    motion = int(g)
                elif g == "93":
                    mode = "inverse_time"
                elif g == "94":
                    mode = "per_minute"
                elif g in ("43.4", "43.5") and tcp_codes:
                    tcp, length = True, "on"
                elif g == "43":
                    tcp, length = (False if tcp_codes else tcp), "on"
                elif g in WORK_OFFSETS:
                    work = "G" + g
                elif g == "49":
                    tcp, length = (False if tcp_codes else tcp), "off"
                elif g == "28" and reference_return:
                    ret = True
                elif g in ("90", "91") and reference_return:
                    distance = g
                elif g not in IGNORED_G:
                    raise PostError(f"line {no}: G{value} is not supported by the reader")
            elif letter in names:
                new[names.index(letter)] = float(value)
                named.append(names.index(letter))
                moved = True
            elif letter == "F":
                f_here = float(value)
            elif letter == "T":
                tool = int(float(value))
            elif letter == "S":
                rpm = float(value)
            elif letter == "M":
                mcode = value.lstrip("0") or "0"
                if mcode == "6":
                    tool_change = True
                elif mcode in ("3", "4", "5"):
                    turn = {"3": "cw", "4": "ccw", "5": "off"}[mcode]
                    turns.add(mcode)
                elif mcode in ("7", "8", "9"):
                    cool.add(mcode)
                elif mcode in ("2", "30"):
                    out.end_line = out.end_line or no
                    end_stop = True
                elif mcode not in IGNORED_M:
                    raise PostError(f"line {no}: M{value} is not supported by the reader")
            elif letter == "H":
                h_word = int(float(value))
            elif letter == "N":
                pass
            elif letter == "P" and "64" in [v.lstrip("0") for k, v in words if k == "G"]:
                pass                    # LinuxCNC's G64 P<tolerance>: path blending, which the header sets
            else:
                raise PostError(f"line {no}: word {letter}{value} is not supported by the reader"
                                f" (axes of machine {machine.name}: {' '.join(names)})")
        if len(turns) > 1:
            raise PostError(f"line {no}: two of M3, M4 and M5 in one block (one modal group)")
        if distance is not None:
            incremental = distance == "91"
        if ret:
            values = {names[i]: float(once[names[i]]) for i in named}
            if not incremental:
                raise PostError(f"line {no}: G28 under G90 passes its axis words as a point first; the reader "
                                f"follows G91 G28 {up}0. (straight to the reference position)")
            if list(values) != [up] or values[up] != 0.0:
                raise PostError(f"line {no}: the reader follows a reference return of the retract axis alone, "
                                f"G91 G28 {up}0. (machine {machine.name}), not {raw.strip()!r}")
        elif incremental and moved:
            raise PostError(f"line {no}: incremental axis words (G91) are not supported by the reader: G90 first")
        if f_here is not None:
            F = f_here
        if h_word is not None and length != "on" and not tcp_codes:
            raise PostError(f"line {no}: H word with no G43 to use it")
        if tool_change:
            loaded = tool
            out.tool_changes.append((tool, no))
            # the tool-change cycle moves the machine where the program cannot see: every axis is unknown
            # until the program names it again (a word in this block still counts: M6 runs before motion)
            unnamed = np.ones(len(names), bool)
            unnamed[named] = False
            new[unnamed] = np.nan
            row = np.full(len(names), np.nan)
            spindle = "off"
        if turn is not None:
            spindle = turn
        if len(cool) > 1:
            raise PostError(f"line {no}: two of M7, M8 and M9 in one block (one modal group)")
        mist, flood = ("7" in cool or mist) and "9" not in cool, ("8" in cool or flood) and "9" not in cool
        in_spindle = tool if loaded is None else loaded
        if tcp_codes:
            h_modal = h_modal if h_word is None else h_word
            comp_on = {"on": True, "off": False}.get(length, comp_on)
            comp = (h_modal or None) if comp_on else None
        elif length == "on":
            comp = h_word or in_spindle or None         # G43, G43 H0: the tool in the spindle
        elif length == "off":
            comp = None
        if ret:
            # straight up to where the control keeps its reference position, which the program does not know;
            # with TCP on, that moves the tool tip in every linear program axis of a tilted table
            out.reference_returns.append((no, row.copy(), names.index(up), in_spindle))
            row = row.copy()
            row[[0, 1, 2] if tcp else [names.index(up)]] = np.nan
            moved = False
        if moved:
            if motion is None:
                raise PostError(f"line {no}: axis words without G0 or G1")
            if motion == 1:
                if mode == "inverse_time" and f_here is None:
                    raise PostError(f"line {no}: a G93 (inverse time) block needs its own F word")
                if F is None or not F > 0:
                    raise PostError(f"line {no}: G1 without a feed (F)")
            out.moves.append(Move("rapid" if motion == 0 else "feed", row.copy(), new.copy(),
                                  "" if motion == 0 else mode, 0.0 if motion == 0 else F, no, in_spindle, rpm, tcp,
                                  comment, spindle, comp, work, coolant_state(mist, flood)))
            row = new
        if end_stop:                # the controller stops here: nothing after the program's end runs
            break
    return out


class GcodePost(Post):
    """What the ISO G-code dialects share: the feed mode words (G93 inverse time for cuts, G94 for the rest;
    G94 is the power-on default, so it is written only to leave G93) and the axis words."""

    def _mode(self, mode):
        if self.state["mode"] != mode:
            if self.state["mode"] is not None or mode == "inverse_time":
                self.lines.append("G93" if mode == "inverse_time" else "G94")
            self.state["mode"] = mode

    def _axes(self, words):
        return " ".join(f"{n}{fixed(v, d)}" for n, v, d in words)
