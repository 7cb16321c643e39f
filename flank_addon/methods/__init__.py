"""The planning methods, one subpackage each:

- :mod:`.single_flank` -- single-flank conical multi-strip milling of screw rotors;
- :mod:`.double_flank` -- double-flank milling with a custom-shaped (or conical) tool;
- :mod:`.paraboloid_groove` -- the groove a paraboloid end mill cuts along a helix;
- :mod:`.freeform_g1` -- G1 multi-strip flank milling of free-form surfaces with a conical tool;
- :mod:`.formed_cutter` -- the axial profile of a formed disc cutter by a numerical method.

A method never imports another method: what two methods share lives in a lower layer."""
