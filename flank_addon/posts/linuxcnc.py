"""LinuxCNC (rs274ngc) post: writer and reader.

Program: ``%`` ... ``%``; G21 G90 G17 G40 G49 G80 G94 G54 G64 P0.001; per tool ``T<n> M6``, ``G43 H<n>``,
``S<rpm> M3``, ``M8`` (``M7`` for mist, none for a dry cut); rapids ``G0``; each pass under ``G93`` (inverse
time: F = 1 / block minutes, in every block, as LinuxCNC requires) and ``G94`` after it; ``M5 M9``, ``M2``.
Comments in parentheses.

TCP: rs274ngc has no TCP word; a TCP machine's program (tool tip in work coordinates plus rotary positions)
needs a kinematics module doing TCP (e.g. xyzac-trt-kins, switchkins type 0), a program for a machine
without TCP needs identity kinematics (joint values).  The header says which.  LinuxCNC's own interpreter
(``rs274 -g``) reads these programs: tests/machining checks that it does without error, that its canonical
moves equal :meth:`LinuxCNCPost.read`'s and that its feeds give the same cycle time.
"""
from .base import fixed, header_lines
from .gcode import COOLANT_ON, GcodePost, read_gcode


class LinuxCNCPost(GcodePost):
    name = "linuxcnc"
    extension = ".ngc"
    description = "LinuxCNC rs274ngc, inverse-time feed (G93) for simultaneous moves"

    def _header(self, program):
        self.lines.append("%")
        for t in header_lines(program, self):
            self._comment(t)
        m = program.machine
        self._comment("kinematics: " + ("TCP module active (program = tool tip in work coordinates)" if m.tcp
                                        else "identity (program = joint values)"))
        self.lines.append("G21 G90 G17 G40 G49 G80 G94 G54 G64 P0.001")

    def _footer(self, program):
        self.lines += ["G94", "M5", "M9", "G49", "M2", "%"]

    def _comment(self, text):
        self.lines.append("(" + str(text).replace("(", "[").replace(")", "]") + ")")

    def _tool(self, op, program):
        self._mode("per_minute")
        self._comment(op["text"])
        self.lines += [f"T{op['number']} M6", f"G43 H{op['number']}", f"S{fixed(op['rpm'], 0)} M3"]
        if op["coolant"] != "off":
            self.lines.append(f"M{COOLANT_ON[op['coolant']]}")

    def _tcp(self, on, program):
        pass

    def _rapid(self, words, program):
        self._mode("per_minute")
        self.lines.append("G0 " + self._axes(words))

    def _feed(self, words, F, program):
        self._mode("inverse_time")
        self.lines.append("G1 " + self._axes(words) + " F" + self.feed_text(F, program.machine))

    def read(self, text, machine):
        return read_gcode(text, machine, semicolon_comments=True, tcp_codes=False)
