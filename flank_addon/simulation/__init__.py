"""Simulation of a tool moving along the screw motion of a rotor: the sweep engine (signed distance of
points to the surface a revolving tool leaves behind), the verification of a plan by it, and the global
collision test of tool and shank.  Imports geometry, tooling and io."""
