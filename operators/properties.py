# SPDX-License-Identifier: GPL-3.0-or-later
"""Scene-level settings shown in the sidebar and shared enum items."""
import bpy
from bpy.props import EnumProperty, FloatProperty, IntProperty

KIND_ITEMS = (
    ("nilson", "Nilson", "Classic Nilson (4+6) rotor pair"),
    ("srm_a", "SRM A", "SRM 'A' profile rotor pair"),
    ("asymmetric", "Asymmetric", "Asymmetric rotor pair"),
)
PART_ITEMS = (
    ("male", "Male", "Male (main) rotor"),
    ("female", "Female", "Female (gate) rotor"),
)
HAND_ITEMS = (
    ("DEFAULT", "Default", "Male right-handed, female left-handed"),
    ("right", "Right", "Right-handed helix"),
    ("left", "Left", "Left-handed helix"),
)


def generator_props():
    """Fresh property definitions shared by the operator and the scene settings."""
    return dict(
        kind=EnumProperty(name="Kind", items=KIND_ITEMS, default="asymmetric"),
        part=EnumProperty(name="Part", items=PART_ITEMS, default="female"),
        scale=FloatProperty(name="Outer Radius", description="Rotor outer radius (scale)",
                            default=1.0, min=1e-4, soft_max=1000.0, unit='LENGTH'),
        lead=FloatProperty(name="Lead", description="Axial advance per turn, 0 = automatic",
                           default=0.0, min=0.0, unit='LENGTH'),
        length=FloatProperty(name="Length", description="Rotor length, 0 = automatic",
                             default=0.0, min=0.0, unit='LENGTH'),
        handedness=EnumProperty(name="Handedness", items=HAND_ITEMS, default="DEFAULT"),
        resolution=IntProperty(name="Resolution", description="Samples around the transverse profile",
                               default=1440, min=24, soft_max=8192),
        axial=IntProperty(name="Axial Rings", description="Rings along the rotor axis",
                          default=96, min=2, soft_max=1024),
    )


class FLANK_PG_settings(bpy.types.PropertyGroup):
    __annotations__ = generator_props()
