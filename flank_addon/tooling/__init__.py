"""Tools: the truncated cone of conical flank milling, tool outlines (meridians), the catalogue of end mills
and the admissibility of a cone on a flank (cutter selection).  Imports only :mod:`..geometry`."""
