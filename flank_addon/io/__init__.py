"""File formats: the flank-plan/1 document (the public contract), triangle-mesh files and PNG, and reading long
JSON in pieces (``json_pieces``: a stored plan read in a worker while Blender's interface runs).

Pure data: no planning, no simulation.  Imports only :mod:`..geometry` (to rebuild a plan's rotor surface)."""
