"""Exports of a plan: APT-style CL data, the verified error along the profile as CSV, and the envelope
strips as triangle meshes.  May use every layer below (methods, simulation, io, tooling, geometry)."""
from .cl_data import DEFAULT_STEPS, cl_data, cl_steps, strip_tip
from .error_csv import error_profile_csv
from .strip_mesh import strip_mesh, strip_meshes, write_meshes, write_strip_meshes

__all__ = ["DEFAULT_STEPS", "cl_data", "cl_steps", "strip_tip", "error_profile_csv", "strip_mesh",
           "strip_meshes", "write_meshes", "write_strip_meshes"]
