"""From plan to machine: whole-rotor operations, machine definitions and kinematics, feeds and speeds, cycle time.

A flank-plan/1 plan holds strips of one flank (or valley) of one lobe: a tool fixed in the rotor frame while
the rotor screws by S_t (turn hand*t about z, advance v0*t; :mod:`..geometry.screw`).  This layer makes a
machine program's content out of it, independent of any controller dialect (:mod:`..posts` writes and reads
the dialects):

- :mod:`.rotor_body`   the finite rotor: helical body, stock cylinder, shafts, lobes (from the plan's
                       ``rotor.extent``, a mesh's analysis or a built-in);
- :mod:`.tool_shape`   a strip's tool solid in its own frame (tip at h = 0, axis towards the shank):
                       placed at any pose, sampled for clearance checks;
- :mod:`.operation`    passes on every lobe, each run out past the body's end faces;
- :mod:`.machine`      versioned machine files (``machines/*.json``) and their kinematics;
- :mod:`.feeds`        cutting data per tool (flutes, vc, fz, top spindle speed) and per-pass conditions;
- :mod:`.clearance`    the tool solid against the stock cylinder and the shafts along any move;
- :mod:`.toolpath`     the machine-level program: ordered passes, links, block times;
- :mod:`.cycle_time`   block times the way a controller computes them;
- :mod:`.disc_cutter_plan` a formed disc cutter's meridian as a flank-plan/1 plan.

Lengths are millimetres, angles degrees at the machine, radians inside the geometry.
"""
