"""flank_addon: the 5-axis flank-milling planner of the Flank Toolpath extension (pure numpy/scipy).

Importable standalone (``python -m flank_addon``) and inside Blender as a subpackage of the
``flank_toolpath`` extension; it never uses Blender.  Layers, bottom to top (a module imports only
from its own layer and those below; ``docs/architecture.md`` draws them):

- :mod:`.geometry` -- screw motion, profiles, helical surfaces and foot points, rotors, mesh analysis;
- :mod:`.tooling` -- cone tools, tool outlines, the end-mill catalogue, cutter selection;
- :mod:`.io` -- the flank-plan/1 document, mesh files, PNG;
- :mod:`.simulation` -- the sweep of a tool along the screw motion, plan verification, collisions;
- :mod:`.methods` -- the five planners, one subpackage each;
- :mod:`.exports` -- CL data, error CSV, strip meshes;
- :mod:`.machining` -- whole-rotor operations, machine files and kinematics, feeds and speeds, cycle time;
- :mod:`.posts` -- one module per controller dialect (writer and reader) and the read-back of a program;
- :mod:`.report` -- report and chart content;
- :mod:`.cli` -- ``python -m flank_addon``.

:mod:`.progress` (progress callbacks and cancellation) imports nothing and serves every layer.
"""
__version__ = "0.1.0"
