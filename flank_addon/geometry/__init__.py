"""Geometry of helical parts: screw motion, transverse profiles, helical surfaces and their exact foot
points, the built-in rotors, the analysis of a rotor mesh, free-form test surfaces and triangle-mesh distances.

The bottom layer: imports nothing else of the planner."""
