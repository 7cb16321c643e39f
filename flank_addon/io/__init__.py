"""File formats: the flank-plan/1 document (the public contract), triangle-mesh files and PNG.

Pure data: no planning, no simulation.  Imports only :mod:`..geometry` (to rebuild a plan's rotor surface)."""
