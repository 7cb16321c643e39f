"""Fanuc-style ISO post: writer and reader.

Program: ``%``, ``O1000``; G21 (a block of its own); G17 G40 G49 G80 G90 G94 G54; per tool ``T<n> M06`` (from the
second tool on after ``G91 G28 Z0.`` ``G90`` ``G49``: the tool goes to the reference position before its length
compensation is cancelled, which on a control with parameter 5006#6 TOS = 0 moves the axis by the tool length),
``S<rpm> M03``, ``M08`` (``M07`` for mist, none for a dry cut);
the first linear positioning block of a tool (after its rotary block, on a machine without TCP) carries the
length compensation, ``G43 H<n>`` or, on a TCP machine,
``G43.4 H<n>`` (tool centre point control type 1: programmed X Y Z = tool tip in work coordinates, rotary
axes as positions); passes under ``G93`` (inverse time, F = 1 / block minutes in every block), ``G94``
after them; ``M05 M09 G91 G28 Z0. G90 G49 M30 %`` (Z: the machine's retract axis).  Coordinates always carry a
decimal point (X12.3456), comments are upper case in parentheses, reduced to letters, digits and
. , : = + - / [ ] # % *.  G43.5 (the tool vector I J K) is not written: the control would choose between the two
rotary solutions itself, and the read-back could not tell which it took.

Rapids are written as straight G00 moves; the link checks assume the control interpolates them linearly
(Fanuc parameter 1401#1 LRP = 1), otherwise each axis runs at its own rapid and the tool may leave the
checked path (docs/posts.md).
"""
import re

from .base import fixed, header_lines
from .gcode import COOLANT_ON, GcodePost, read_gcode


class FanucPost(GcodePost):
    name = "fanuc"
    extension = ".nc"
    description = "Fanuc-style ISO, inverse-time feed (G93), G43.4 on TCP machines"

    def _header(self, program):
        self.lines += ["%", "O1000 (FLANK TOOLPATH)"]
        for t in header_lines(program, self):
            self._comment(t)
        self._comment("rapids assume linear interpolation positioning, parameter 1401 bit 1 LRP = 1")
        self.lines += ["G21", "G17 G40 G49 G80 G90 G94 G54"]    # G21 alone, before the coordinate system, as Fanuc asks

    def _footer(self, program):
        self.lines += ["G94", "M05", "M09"]
        self._reference_return(program)
        self.lines += ["G49", "M30", "%"]

    def _reference_return(self, program):
        # G49 alone moves the axis by the tool length on a control with 5006#6 TOS = 0 (the default): only
        # at the reference position is that harmless, so the tool goes there first, straight up the retract
        # axis (checked clear by the toolpath), as the tool-change cycle would take it anyway
        self.lines += [f"G91 G28 {program.machine.retract_axis[0]}0.", "G90"]

    def _comment(self, text):
        t = str(text).upper().replace("(", "[").replace(")", "]").replace(";", ",")
        self.lines.append("(" + re.sub(r"[^A-Z0-9 .,:=+\-/\[\]#%*]", "", t) + ")")

    def _tool(self, op, program):
        self._mode("per_minute")
        if self.state.get("compensated"):  # the earlier tool's G43 / G43.4 off first: many controls refuse M06 under TCP
            self._reference_return(program)
            self.lines.append("G49")
        self._comment(op["text"])
        self.lines += [f"T{op['number']} M06", f"S{fixed(op['rpm'], 0)} M03"]
        if op["coolant"] != "off":
            self.lines.append(f"M{COOLANT_ON[op['coolant']]:02d}")
        self.state["comp"] = op["number"]

    def _tcp(self, on, program):
        pass                               # G43.4 comes with the first positioning block, G49 at the end

    def _rapid(self, words, program):
        self._mode("per_minute")
        comp = ""
        if self.state.get("comp") and any(n in "XYZ" for n, _, _ in words):    # with the first linear move
            comp = ("G43.4" if program.machine.tcp else "G43") + f" H{self.state['comp']} "
            self.state["comp"], self.state["compensated"] = None, True
        self.lines.append("G00 " + comp + self._axes(words))

    def _feed(self, words, F, program):
        self._mode("inverse_time")
        self.lines.append("G01 " + self._axes(words) + " F" + self.feed_text(F, program.machine))

    def read(self, text, machine):
        return read_gcode(text, machine, semicolon_comments=False, tcp_codes=True, reference_return=True)
