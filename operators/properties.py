# SPDX-License-Identifier: GPL-3.0-or-later
"""The properties of the operators and the scene settings the sidebar shows (``Scene.flank_settings``): each
planner's property definitions (``*_props()``, fresh on every call: the operator's own properties and the scene
settings with a prefix), the shared enum items, the Tool panel's dimensions in mm and the tool's cutting data,
flank.post_program's properties and the Machine panel's settings (machines and posts from the core), the flank
list and the Results legend.

Property update callbacks import the modules they drive (the guiding preview, the strips list) inside the
callback; none of those imports this module."""
import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, FloatVectorProperty, IntProperty, StringProperty

from .units import mm_per_scene_unit

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


GROOVE_PART_ITEMS = (
    ("full", "Full", "Whole swept section x in [-(R + rho), -(R - rho)]"),
    ("external", "External", "Shaft cut from outside: between the tool axis and the screw axis"),
    ("internal", "Internal", "Bore cut from inside: beyond the tool axis"),
)


def verify_props():
    """Fresh property definitions of flank.verify_plan (also the scene settings, prefixed 'verify_')."""
    return dict(
        filepath=StringProperty(name="Plan File", description="flank-plan/1 JSON file to verify",
                                subtype='FILE_PATH', default=""),
        tolerance=FloatProperty(name="Tolerance",
                                description="Deviation tolerance in the plan's length unit, "
                                            "0 = plan default (1e-3 x rotor outer radius)",
                                default=0.0, min=0.0, precision=5),
        search=FloatProperty(name="Search Range",
                             description="How far from the design surface a tool is looked for, in the plan's "
                                         "length unit; 0 = default (0.1 x rotor outer radius)",
                             default=0.0, min=0.0, precision=4),
        show_tools=BoolProperty(name="Show Tools",
                                description="Also add the strips' tools (cutter + shank) as mesh objects in a "
                                            "'Verify Tools' collection, placed at their contact position",
                                default=False),
    )


def paraboloid_props():
    """Fresh property definitions of flank.paraboloid_groove (also the scene settings, prefixed 'groove_').

    No hard limits on R, a, b, pitch: bad values must reach the core and be reported with its
    message (a hard limit would silently clamp them)."""
    return dict(
        radius=FloatProperty(name="Helix Radius R", description="Radius of the tool centre's helix (scene units)",
                             default=20.0, soft_min=0.0, soft_max=1000.0),
        a=FloatProperty(name="a", description="Paraboloid constant a (< 0): lens |h| <= b + a rho^2",
                        default=-0.05, soft_max=0.0, precision=4, step=1),
        b=FloatProperty(name="b", description="Paraboloid constant b (> 0): half height of the lens",
                        default=7.2, soft_min=0.0, precision=4),
        pitch=FloatProperty(name="Pitch p", description="Axial advance of the tool per turn (> 0)",
                            default=20.0, soft_min=0.0, soft_max=1000.0),
        turns=FloatProperty(name="Turns", description="Length of the groove in turns of the helix",
                            default=1.0, min=0.05, soft_max=20.0),
        part=EnumProperty(name="Section", items=GROOVE_PART_ITEMS, default="full"),
        resolution=IntProperty(name="Resolution", description="Samples along the swept section",
                               default=401, min=16, soft_max=4001),
    )


CUTTER_SOURCE_ITEMS = (
    ("TABLE1", "Table-1 Rotor", "The arc-tooth rotor of Hu, Zhou & Li 2025, Table 1 (R1 55.1, R2 111.69, G 125, "
                                "4 grooves, mm): built as a new mesh object"),
    ("ACTIVE", "Active Rotor", "The active rotor made by Generate Rotor (or a Table-1 rotor from an earlier run): "
                              "its profile is rebuilt from its custom properties and its mesh is painted"),
)


def formed_cutter_props():
    """Fresh property definitions of flank.formed_cutter (also the scene settings, prefixed 'cutter_').

    No hard limits on lead, centre distance, swivel: bad values (NaN included) must reach the
    operator's checks and the core and be reported with the value and the limit."""
    return dict(
        source=EnumProperty(name="Rotor", items=CUTTER_SOURCE_ITEMS, default="TABLE1"),
        lead=FloatProperty(name="Lead", description="Axial advance per turn of the rotor, 0 = the rotor's "
                                                    "(Table 1: 450); an active rotor accepts only its own lead",
                           default=0.0, soft_min=0.0, soft_max=10000.0),
        centre_distance=FloatProperty(name="Centre Distance A",
                                      description="Distance between the rotor axis and the cutter axis (> the "
                                                  "rotor's outer radius); 0 = automatic: Table 1 200, other "
                                                  "rotors 200 / 111.69 x their outer radius",
                                      default=0.0, soft_min=0.0, soft_max=10000.0),
        swivel=FloatProperty(name="Swivel", description="Angle phi between the rotor and cutter axes in degrees, "
                                                        "0 < |phi| < 90 (Table 1: 31)",
                             default=31.0, soft_min=-89.0, soft_max=89.0),
        handedness=EnumProperty(name="Handedness", items=(
            ("DEFAULT", "From Rotor", "The rotor's hand (Table 1: right)"),
            ("right", "Right", "Right-handed helix (Table-1 rotor only, or an active right-handed rotor)"),
            ("left", "Left", "Left-handed helix (Table-1 rotor only, or an active left-handed rotor)"),
        ), default="DEFAULT"),
        planes=IntProperty(name="Planes", description="Planes Z_u = const of the cutter profile (the paper: 119); "
                                                      "one ring of the cutter mesh each",
                           default=119, min=2, soft_max=2000),
        eps_b=FloatProperty(name="eps_b", description="Subdivision threshold of the radius search, "
                                                      "0 = default (1e-4 x outer radius)",
                            default=0.0, min=0.0, precision=5),
        tolerance=FloatProperty(name="Tolerance", description="Deviation colour band (green within) in scene "
                                                              "units, 0 = default (1e-5 x outer radius)",
                                default=0.0, min=0.0, precision=6, unit='LENGTH'),
        sample_points=IntProperty(name="Tooth Points", description="Tooth points simulated by the sweep "
                                                                   "(about 10 ms each)",
                                  default=161, min=8, soft_max=2000),
        resolution=IntProperty(name="Resolution", description="Profile samples of the Table-1 rotor mesh",
                               default=720, min=48, soft_max=8192),
        animate=BoolProperty(name="Animate", description="Add a cutter moving along the rotor (inverse screw "
                                                         "motion, rotor fixed)", default=True),
        frame_start=IntProperty(name="Start Frame", default=1),
        frame_end=IntProperty(name="End Frame", default=250),
        filepath=StringProperty(name="Profile CSV", description="Also write the cutter profile as z,r rows "
                                                                "(cutter frame); empty = no file",
                                subtype='FILE_PATH', default=""),
    )


DF_VARIANT_ITEMS = (
    ("min", "Minimum", "Radial function r = min(r1, r2) (Bizzarri & Bartoň 2021, Eq. 14): never overcuts"),
    ("avg", "Average", "Radial function r = (r1 + r2) / 2 (Bizzarri & Bartoň 2021, Eq. 16)"),
    ("one-sided-1", "One-Sided 1", "r = r1: exact on flank 1 (Bizzarri & Bartoň 2021, Eq. 17)"),
    ("one-sided-2", "One-Sided 2", "r = r2: exact on flank 2 (Bizzarri & Bartoň 2021, Eq. 17)"),
)
DF_TOOL_ITEMS = (
    ("custom", "Custom", "Custom-shaped revolving tool (envelope of spheres on the optimised axis)"),
    ("cone", "Cone", "One conical tool"),
    ("cones", "Cones", "K conical segments along the axis (K = Cones)"),
)


def double_flank_props():
    """Fresh property definitions of flank.plan_double_flank (also the scene settings, prefixed 'df_').

    No hard limits on valley, radii, rim, cones: bad values (NaN included) must reach the operator's
    checks and the core and be reported with the value and the limit."""
    return dict(
        valley=IntProperty(name="Valley", description="Valley index K (flanks 2K and 2K+1 of the rotor)",
                           default=0, soft_min=0, soft_max=12),
        variant=EnumProperty(name="Radial Function", items=DF_VARIANT_ITEMS, default="min"),
        tool=EnumProperty(name="Tool", items=DF_TOOL_ITEMS, default="custom"),
        cones=IntProperty(name="Cones", description="Number K of conical segments for Tool = Cones (1..12)",
                          default=3, soft_min=1, soft_max=12),
        two_paths=BoolProperty(name="Two Paths", description="One custom tool on two axes, one per flank "
                                                             "(custom tool only)", default=False),
        radii=IntProperty(name="Radii m", description="Radii intervals per strip of the plan (m + 1 radii, "
                                                      "2..5000)", default=400, soft_min=2, soft_max=5000),
        rim=FloatProperty(name="Rim", description="Targeted fraction of the valley depth, from the valley "
                                                  "bottom to the outer radius (core limits 0.2..0.98)",
                          default=0.85, soft_min=0.2, soft_max=0.98, precision=3, step=1),
        samples=IntProperty(name="Axis Samples", description="Axis samples of the optimisation of Phi "
                                                             "(Bizzarri & Bartoň 2021, Eq. 11)", default=100,
                            soft_min=10,
                            soft_max=1000),
        simulate=BoolProperty(name="Simulate", description="Run the sweep simulation for the rotor-to-envelope "
                                                           "errors and the Hausdorff distance ("
                                                           "can take a minute)", default=False),
        tolerance=FloatProperty(name="Tolerance", description="Deviation colour band in scene units (green "
                                                              "within), 0 = 1e-3 x rotor outer radius",
                                default=0.0, min=0.0, precision=6, unit='LENGTH'),
        envelope_rings=IntProperty(name="Envelope Rings", description="Rings of the envelope strips along the "
                                                                      "rotor (screw positions)",
                                   default=48, min=2, soft_max=1000),
        animate=BoolProperty(name="Animate", description="Add a tool moving along the rotor (its screw motion "
                                                         "relative to the rotor)", default=True),
        frame_start=IntProperty(name="Start Frame", default=1),
        frame_end=IntProperty(name="End Frame", default=250),
        filepath=StringProperty(name="Plan File", description="Also write the flank-plan/1 JSON; empty = no "
                                                              "file", subtype='FILE_PATH', default=""),
        tool_csv=StringProperty(name="Tool CSV", description="Also write the tool profile as axial_position,"
                                                             "radius rows (cones: one file per cone, _k "
                                                             "suffix); empty = no file",
                                subtype='FILE_PATH', default=""),
    )


SF_SHAPE_ITEMS = (
    ("alpha", "Opening Angle", "Cone given by r1, r2 and its opening angle alpha"),
    ("length", "Length", "Cone given by r1, r2 and the distance h of its boundary circles (tan alpha = "
                         "(r2 - r1) / h)"),
)
SF_OBJECTIVE_ITEMS = (
    ("phi1", "Phi1", "Distance of the tool to the flank along the axis (Bizzarri, Bo & Bartoň, Eq. 25)"),
    ("phi3", "Phi3", "Distance of the characteristic curve to the flank (Bizzarri, Bo & Bartoň, Eq. 31)"),
)
SF_MODE_ITEMS = (
    ("hard", "Hard", "No overcut along the axis"),
    ("weighted", "Weighted", "Overcut weighted w = 100"),
)


def single_flank_props():
    """Fresh property definitions of flank.plan_single_flank (also the scene settings, prefixed 'sf_').

    No hard limits on flank, radii, angle, tolerances, seeds, rounds: bad values (NaN included) must
    reach the operator's checks and the core and be reported with the value and the limit."""
    return dict(
        flank=IntProperty(name="Flank", description="Flank index of the rotor (0 .. flanks - 1)",
                          default=1, soft_min=0, soft_max=24),
        use_point=BoolProperty(name="Flank From Point", description="Plan the flank nearest to Point instead of "
                                                                    "the Flank index", default=False),
        point=FloatVectorProperty(name="Point", description="A point near the flank, in the rotor object's "
                                                            "local (model) coordinates", size=3,
                                  default=(0.0, 0.0, 0.0), subtype='XYZ'),
        shape=EnumProperty(name="Cone Given By", items=SF_SHAPE_ITEMS, default="alpha"),
        r1=FloatProperty(name="Tip Radius r1", description="Radius r1c of the cone's tip circle (scene units, "
                                                          ">= 0, below r2)",
                         default=0.05, soft_min=0.0, soft_max=100.0, precision=4, unit='LENGTH'),
        r2=FloatProperty(name="Top Radius r2", description="Radius r2c of the cone's top circle (scene units)",
                         default=0.08, soft_min=0.0, soft_max=100.0, precision=4, unit='LENGTH'),
        alpha=FloatProperty(name="Opening Angle", description="Opening angle alpha of the cone, 0 < alpha < 90 "
                                                              "deg (Cone Given By = Opening Angle)",
                            default=0.1001674211615598, soft_min=0.0, soft_max=1.5, subtype='ANGLE', precision=4),
        length=FloatProperty(name="Length h", description="Distance h of the boundary circles, > 0 (Cone Given "
                                                          "By = Length; scene units)",
                             default=0.3, soft_min=0.0, soft_max=1000.0, precision=4, unit='LENGTH'),
        shank_radius=FloatProperty(name="Shank Radius", description="Radius of the cylindrical shank beyond the "
                                                                    "top circle, 0 = no shank (scene units)",
                                   default=0.04, soft_min=0.0, soft_max=100.0, precision=4, unit='LENGTH'),
        shank_length=FloatProperty(name="Shank Length", description="Length of the shank, 0 = no shank "
                                                                    "(scene units)",
                                   default=0.6, soft_min=0.0, soft_max=1000.0, precision=4, unit='LENGTH'),
        tools=StringProperty(name="Tool Presets", description="Plan with the shipped tool presets instead of the "
                                                               "Tool panel's cone: empty = the Tool panel's cone; "
                                                               "'auto' = the largest preset that can mill the "
                                                               "flank, then smaller ones for what it leaves; or "
                                                               "preset names separated by commas, tried in that "
                                                               "order (presets are in mm)", default=""),
        tolerance=FloatProperty(name="Tolerance", description="Largest material left on the flank, > 0 "
                                                              "(scene units; core limit: below half the outer "
                                                              "radius)",
                                default=0.001, soft_min=0.0, precision=6, unit='LENGTH'),
        overcut_tolerance=FloatProperty(name="Overcut Tolerance", description="Largest overcut accepted, >= 0 "
                                                                              "(scene units); 0 = 1e-6 x outer "
                                                                              "radius",
                                        default=0.0, soft_min=0.0, precision=7, unit='LENGTH'),
        seeds=IntProperty(name="Seeds", description="First-round seeds along the flank profile (1..400)",
                          default=18, soft_min=1, soft_max=400),
        objective=EnumProperty(name="Objective", items=SF_OBJECTIVE_ITEMS, default="phi1"),
        mode=EnumProperty(name="Mode", items=SF_MODE_ITEMS, default="hard"),
        rounds=IntProperty(name="Rounds", description="Rounds of gap seeding of the cover (>= 1)",
                           default=4, soft_min=1, soft_max=20),
        collisions=BoolProperty(name="Collisions", description="Drop candidates whose tool or shank hits the "
                                                               "rotor anywhere", default=True),
        g1=BoolProperty(name="G1 Junctions", description="Smoother junctions: the smoothest cover with up to G1 "
                                                         "Extra Strips more strips, then a tangency refinement "
                                                         "(each kept only if the kinks drop within the tolerance)",
                        default=False),
        g1_extra_strips=IntProperty(name="G1 Extra Strips", description="Strips the G1 cover may add to the "
                                                                        "minimum (0..50)",
                                    default=2, soft_min=0, soft_max=50),
        envelope_rings=IntProperty(name="Envelope Rings", description="Rings of the envelope strips along the "
                                                                      "rotor (screw positions)",
                                   default=48, min=2, soft_max=1000),
        animate=BoolProperty(name="Animate", description="Add the strips' tools moving along the rotor (their "
                                                         "screw motion relative to the rotor)", default=True),
        frame_start=IntProperty(name="Start Frame", default=1),
        frame_end=IntProperty(name="End Frame", default=250),
        filepath=StringProperty(name="Plan File", description="Also write the flank-plan/1 JSON; empty = no "
                                                              "file", subtype='FILE_PATH', default=""),
    )


FF_DIRECTION_ITEMS = (
    ("VECTOR", "Direction", "One tangent vector (world axes) at Point, carried over the surface", 0),
    ("FIELD", "Vector Attribute", "A tangent vector field: a FLOAT_VECTOR attribute of the mesh on its points or "
                                  "faces (object axes)", 1),
)
FF_FREE_ITEMS = (
    ("L", "L", "Axis length L is a variable of the optimisation", 1),
    ("r1", "r1", "Tip sphere radius r1 is a variable", 2),
    ("r2", "r2", "Base sphere radius r2 is a variable", 4),
)


def freeform_props():
    """Fresh property definitions of flank.plan_freeform (also the scene settings, prefixed 'ff_').

    The tool is the family of spheres of Rajain et al. 2023 (Eqs. 1-2): tip and base sphere radii r1, r2 with
    centres L apart; the Run button derives them from the Tool panel's end mill.  Lengths in scene units,
    directions and points in world axes.  No hard limits: bad values reach the operator's checks and are reported
    with the limit."""
    return dict(
        r1=FloatProperty(name="Tip Sphere r1", description="Radius of the tool's tip sphere (scene units, >= 0)",
                         default=0.05, soft_min=0.0, soft_max=100.0, precision=4, unit='LENGTH'),
        r2=FloatProperty(name="Base Sphere r2", description="Radius of the tool's base sphere (scene units, >= 0; "
                                                            "r1 = r2: cylinder)",
                         default=0.05, soft_min=0.0, soft_max=100.0, precision=4, unit='LENGTH'),
        length=FloatProperty(name="Axis Length L", description="Distance of the sphere centres, > |r2 - r1| "
                                                               "(scene units)",
                             default=0.3, soft_min=0.0, soft_max=1000.0, precision=4, unit='LENGTH'),
        shank_radius=FloatProperty(name="Shank Radius", description="Shank beyond the base sphere for the collision "
                                                                    "check (scene units; 0 = r2)",
                                   default=0.0, soft_min=0.0, soft_max=100.0, precision=4, unit='LENGTH'),
        shank_length=FloatProperty(name="Shank Length", description="Shank length (scene units, 0 = no shank)",
                                   default=0.0, soft_min=0.0, soft_max=1000.0, precision=4, unit='LENGTH'),
        direction_mode=EnumProperty(name="Guide By", items=FF_DIRECTION_ITEMS, default="VECTOR",
                                    update=_ff_preview_update),
        direction=FloatVectorProperty(name="Direction", description="Guiding direction (world axes): the strips "
                                                                    "run along it", size=3,
                                      default=(0.0, 1.0, 0.0), subtype='XYZ', update=_ff_preview_update),
        use_point=BoolProperty(name="At Point", description="Start the direction at Point (else the mesh centre)",
                               default=False, update=_ff_preview_update),
        point=FloatVectorProperty(name="Point", description="Where the direction is given (world)", size=3,
                                  default=(0.0, 0.0, 0.0), subtype='XYZ', unit='LENGTH', update=_ff_preview_update),
        field_attribute=StringProperty(name="Vector Attribute", description="FLOAT_VECTOR point or face attribute "
                                                                            "of the mesh holding the guiding field "
                                                                            "(object axes)",
                                       default="", update=_ff_preview_update),
        selected_only=BoolProperty(name="Selected Faces Only", description="Plan on the mesh's selected faces only",
                                   default=False, update=_ff_preview_update),
        flip_normals=BoolProperty(name="Tool Behind Normals", description="The tool is on the side opposite to the "
                                                                          "face normals", default=False,
                                  update=_ff_preview_update),
        spacing=FloatProperty(name="Strip Spacing d", description="Distance of the guiding curves (scene units); "
                                                                  "0 = sqrt(L^2 - (r2 - r1)^2) of the engaged tool "
                                                                  "(Rajain et al. 2023, Sec. 5)",
                              default=0.0, soft_min=0.0, soft_max=1000.0, precision=4, unit='LENGTH',
                              update=_ff_preview_update),
        engagement=FloatProperty(name="Engagement", description="Share of the tool next to its base that cuts, "
                                                                "0.05..1",
                                 default=1.0, soft_min=0.05, soft_max=1.0, subtype='FACTOR',
                                 update=_ff_preview_update),
        w_rigid=FloatProperty(name="Rigidity w1", description="Weight of the constant axis length term (Eq. 18)",
                              default=1.0, soft_min=0.0, soft_max=100.0, precision=4),
        w_approx=FloatProperty(name="Approximation w2", description="Weight of the distance to the surface term",
                               default=1.0, soft_min=0.0, soft_max=100.0, precision=4),
        w_g1=FloatProperty(name="G1 w3", description="Weight of the tangent continuity of neighbouring strips",
                           default=0.01, soft_min=0.0, soft_max=100.0, precision=4),
        w_proximity=FloatProperty(name="Proximity w4", description="Weight keeping the rulings near their start",
                                  default=1e-4, soft_min=0.0, soft_max=100.0, precision=6),
        w_fair=FloatProperty(name="Fairness w5", description="Weight of the smooth motion term",
                             default=1e-3, soft_min=0.0, soft_max=100.0, precision=6),
        samples=IntProperty(name="Samples per Ruling", description="Points per ruling in the error terms, K "
                                                                   "(Eq. 11; 2..200)", default=30, soft_min=2,
                            soft_max=200),
        columns=IntProperty(name="Rulings per Strip", description="About this many rulings per strip (2..2000)",
                            default=20, soft_min=2, soft_max=200),
        max_evaluations=IntProperty(name="Max Evaluations", description="Function evaluations of the "
                                                                        "least-squares solver (1..10000)",
                                    default=100, soft_min=1, soft_max=1000),
        optimize_tool=EnumProperty(name="Free Tool Sizes", items=FF_FREE_ITEMS, options={'ENUM_FLAG'}, default=set()),
        slide=BoolProperty(name="Slide Along Curves", description="Let the m-grid points move along the guiding "
                                                                  "curves too (the paper's 3 unknowns per point)",
                           default=False),
        tolerance=FloatProperty(name="Tolerance", description="Error band of the colours, > 0 (scene units)",
                                default=0.001, soft_min=0.0, precision=6, unit='LENGTH'),
        envelope_samples=IntProperty(name="Envelope Samples", description="Envelope points across a strip "
                                                                          "(2..200)", default=9, soft_min=2,
                                     soft_max=100),
        filepath=StringProperty(name="Plan File", description="Also write the flank-plan/1 JSON; empty = no file",
                                subtype='FILE_PATH', default=""),
    )


# ----------------------------------------------------------------------------------------- machining
def _machine_items():
    """The built-in machine files of the core (name, name, description), then a machine file of one's own."""
    from ..flank_addon.machining.machine import builtin_machines, load_machine

    items = []
    for k, name in enumerate(builtin_machines()):
        try:
            text = load_machine(name).description
        except ValueError as ex:                 # a broken built-in is the core tests' business: say so here
            text = "cannot be read: {}".format(ex)
        items.append((name, name, text, k))
    items.append(("FILE", "Machine File", "A machine file (flank-machine/1 JSON) of your own", len(items)))
    return tuple(items)


def _post_items():
    from ..flank_addon.posts import POSTS

    return tuple((p.name, p.name, "{} ({} files)".format(p.description, p.extension), k)
                 for k, p in enumerate(POSTS.values()))


MACHINE_ITEMS = _machine_items()
POST_ITEMS = _post_items()


def cutting_data_props():
    """Fresh property definitions of the tool's cutting data (the Tool panel's end mill; the tool presets set
    them): defaults are the core's default end mill (docs/feeds-and-speeds.md).  The same names on
    flank.post_program.  No hard limits: bad values reach the operator's checks and are reported."""
    from ..flank_addon.machining.feeds import DEFAULT_END_MILL as d

    return dict(
        tool_flutes=IntProperty(name="Flutes", description="Number of flutes z of the tool",
                                default=d.flutes, soft_min=1, soft_max=16),
        tool_cutting_speed_m_min=FloatProperty(name="Cutting Speed (m/min)", description="Cutting speed vc: the "
                                                                                         "spindle speed follows it "
                                                                                         "at the largest engaged "
                                                                                         "diameter",
                                               default=d.vc_m_min, soft_min=1.0, soft_max=1000.0, precision=1),
        tool_feed_per_tooth_mm=FloatProperty(name="Feed per Tooth (mm)", description="Chip load fz at the "
                                                                                     "fastest engaged point of the "
                                                                                     "edge",
                                             default=d.fz_mm, soft_min=0.001, soft_max=1.0, precision=4,
                                             step=0.1),
        tool_max_rpm=FloatProperty(name="Top Speed (1/min)", description="The tool's top spindle speed (the "
                                                                         "machine's own top speed caps it too)",
                                   default=d.max_rpm, soft_min=100.0, soft_max=100000.0, precision=0),
    )


COOLANT_ITEMS = (
    ("flood", "Flood", "Flood coolant with every tool (M8; Klartext M13)"),
    ("mist", "Mist", "Mist coolant with every tool (M7; the G-code posts: on a TNC its M function is the machine "
                     "builder's)"),
    ("off", "Off (Dry)", "No coolant: a dry cut (the program turns none on)"),
)


def machining_props():
    """Fresh property definitions shared by flank.post_program and the Machine panel's settings."""
    return dict(
        clearance=FloatProperty(name="Clearance (mm)", description="Run-out beyond the rotor's end faces and "
                                                                   "margin of every link between passes, mm (> 0)",
                                default=5.0, soft_min=0.1, soft_max=100.0, precision=2),
        lobes=StringProperty(name="Lobes", description="Lobes to cut: empty or 'all' = every lobe, else indices "
                                                       "like 0,2,4", default=""),
        flip_rotor=BoolProperty(name="Flip Rotor", description="The rotor is mounted the other way round (turned "
                                                               "180 deg about its x axis), which helps when the "
                                                               "tool axes point down the rotor's z",
                                default=False),
        holders=StringProperty(name="Holders (mm)",
                               description="What holds the rotor beyond its end faces (a chuck, a collet, a "
                                           "tailstock), in mm: SIDE,DIAMETER,LENGTH[,GAP], several separated by ';'. "
                                           "SIDE low or high is the end at the smaller or larger z of the rotor's "
                                           "axis, GAP (default 0) its distance from that end face; e.g. "
                                           "'low,100,60,20; high,60,40'. No move may enter them, and a pass that "
                                           "runs out into one is refused", default=""),
        coolant=EnumProperty(name="Coolant", items=COOLANT_ITEMS, default="flood",
                             description="Coolant turned on with every tool; the read-back checks the program "
                                         "against it"),
    )


def post_program_props():
    """Fresh property definitions of flank.post_program.  The machine and the post are names (a machine may
    also be a file path), so that a wrong one is reported with the valid names rather than refused by an
    enum."""
    return dict(
        filepath=StringProperty(name="Program File", description="The machine program to write (absolute path, "
                                                                 "or relative to the saved .blend file)",
                                subtype='FILE_PATH', default=""),
        collection=StringProperty(name="Run", description="Result collection whose plan is posted; empty = the run "
                                                          "of the active object, else the newest run", default=""),
        machine=StringProperty(name="Machine", description="A built-in machine name or a machine file",
                               default="rotor-xa-b"),
        post=StringProperty(name="Post", description="Controller dialect: linuxcnc, fanuc or heidenhain",
                            default="linuxcnc"),
        animate=BoolProperty(name="Animate", description="Animate the program: the rotor (a linked copy) turns "
                                                         "about its axis while the tool moves", default=True),
        read_back=BoolProperty(name="Read Back", description="Read the written program back through the machine's "
                                                             "kinematics and sweep it again against the plan, as "
                                                             "verify --program does: what differs from the plan, "
                                                             "and by how much", default=True),
        frame_start=IntProperty(name="Start Frame", default=1),
        frame_end=IntProperty(name="End Frame", default=250),
        **machining_props(),
        **cutting_data_props(),
    )


def check_program_props():
    """Fresh property definitions of flank.check_program: the program file to read back, the run whose plan it
    is checked against, and the machine, post, holders and cutting data it was posted with (names, as
    flank.post_program)."""
    return dict(
        filepath=StringProperty(name="Program File", description="The machine program to read back (absolute "
                                                                 "path, or relative to the saved .blend file)",
                                subtype='FILE_PATH', default=""),
        collection=StringProperty(name="Run", description="Result collection whose plan the program is checked "
                                                          "against; empty = the run of the active object, else "
                                                          "the newest run", default=""),
        machine=StringProperty(name="Machine", description="The machine the program was posted for: a built-in "
                                                           "machine name or a machine file", default="rotor-xa-b"),
        post=StringProperty(name="Post", description="The controller dialect the program is written in: linuxcnc, "
                                                     "fanuc or heidenhain; empty = by the file's extension",
                            default=""),
        lobes=StringProperty(name="Lobes", description="Lobes to sweep again: empty or 'all' = those the program "
                                                       "cuts, else indices like 0,2,4", default=""),
        flip_rotor=machining_props()["flip_rotor"],
        holders=machining_props()["holders"],
        coolant=machining_props()["coolant"],
        **cutting_data_props(),
        # set by invoke when it opens the file browser: the check then runs modal like the planners
        modal_after_browser=BoolProperty(default=False, options={'HIDDEN', 'SKIP_SAVE'}),
    )


def machine_settings_props():
    """The Machine panel's settings: machine, post, program file, clearance, lobes (the cutting data are the
    Tool panel's, cutting_data_props)."""
    return dict(
        machine=EnumProperty(name="Machine", items=MACHINE_ITEMS, default="rotor-xa-b"),
        machine_file=StringProperty(name="Machine File", description="flank-machine/1 JSON of your own machine "
                                                                     "(Machine = Machine File)",
                                    subtype='FILE_PATH', default=""),
        post=EnumProperty(name="Post", items=POST_ITEMS, default="linuxcnc"),
        program_filepath=StringProperty(name="Program File", description="The machine program to write; empty = "
                                                                         "choose one when posting",
                                        subtype='FILE_PATH', default=""),
        program_animate=BoolProperty(name="Animate", description="Animate the program over the scene's frame "
                                                                 "range", default=True),
        program_read_back=BoolProperty(name="Read Back", description="Read the program back and sweep it again "
                                                                     "against the plan (verify --program)",
                                       default=True),
        **machining_props(),
    )


def _ff_preview_update(self, context):
    """A setting that moves the guiding curves changed: redraw the live preview if the user has one."""
    if getattr(self, "ff_live_preview", False) and context is not None:
        from .guiding import refresh_guiding_preview

        refresh_guiding_preview(context)


def _prefixed(prefix, props):
    return {prefix + name: prop for name, prop in props.items()}


# ----------------------------------------------------------------------------------------------- sidebar
TOOL_KIND_ITEMS = (
    ("CONE", "Tapered End Mill", "Truncated cone r1 < r2 with a taper (opening) angle and a cylindrical shank: "
                                 "the single-flank conical tool", 'MESH_CONE', 0),
    ("CYLINDER", "Cylindrical End Mill", "Cylinder of radius r1 and flute length h with a shank; the single-flank "
                                         "planner takes it as a cone of taper 0.0057 deg (1e-4 rad)", 'MESH_CYLINDER',
     1),
    ("CUSTOM", "Custom (Double Flank)", "Revolved tool shaped by the double-flank planner for one valley: "
                                        "custom radial function, one cone or K cones", 'MOD_SCREW', 2),
    ("DISC", "Formed Disc Cutter", "Disc cutter whose profile the formed disc cutter planner derives from the "
                                   "rotor and its set-up", 'MESH_TORUS', 3),
    ("PARABOLOID", "Paraboloid End Mill", "Lens |h| <= b + a rho^2 of the paraboloid groove", 'SPHERECURVE',
     4),
)
STRATEGY_ITEMS = (
    ("SINGLE", "Single-Flank Conical", "One flank with several strips of a tapered (or cylindrical) end mill",
     'MOD_SCREW', 0),
    ("DOUBLE", "Double-Flank Custom Tool", "Both flanks of one valley in one pass of a custom-shaped or conical tool "
                               "(radial function min / average / one-sided)", 'MOD_MIRROR', 1),
    ("TWO_PATHS", "Two Paths, One Tool", "One custom tool on two axes, one per flank of the valley",
     'ARROW_LEFTRIGHT', 2),
    ("FORMED", "Formed Disc Cutter", "Disc cutter formed to the tooth space, one pass per groove", 'MESH_TORUS',
     3),
    ("GROOVE", "Paraboloid Groove", "Groove of a paraboloid end mill moved along a helix", 'SPHERECURVE', 4),
    ("FREEFORM", "Free-form G1", "Any triangle-mesh surface, strips of a conical tool along a guiding "
                                 "direction, G1 between neighbours", 'MOD_SMOOTH', 5),
)
# tool kinds each strategy can use (the first one is taken when the strategy is chosen with another kind)
STRATEGY_TOOLS = {"SINGLE": ("CONE", "CYLINDER"), "DOUBLE": ("CUSTOM",), "TWO_PATHS": ("CUSTOM",),
                  "FORMED": ("DISC",), "GROOVE": ("PARABOLOID",), "FREEFORM": ("CONE", "CYLINDER")}
TOOL_STRATEGY = {"CONE": "SINGLE", "CYLINDER": "SINGLE", "CUSTOM": "DOUBLE", "DISC": "FORMED",
                 "PARABOLOID": "GROOVE"}


def _tool_kind_changed(self, context):
    if self.tool_kind not in STRATEGY_TOOLS.get(self.strategy, ()):
        self.strategy = TOOL_STRATEGY[self.tool_kind]


def _strategy_changed(self, context):
    kinds = STRATEGY_TOOLS.get(self.strategy, ())
    if kinds and self.tool_kind not in kinds:
        self.tool_kind = kinds[0]


def _flank_index_changed(self, context):
    """Picking a row of the flank list (or a pick operator) aims the planners at that flank / its valley."""
    k = int(self.flank_index)
    if k < 0:
        return
    if self.sf_flank != k:
        self.sf_flank = k
    if self.df_valley != k // 2:
        self.df_valley = k // 2
    if self.sf_use_point:
        self.sf_use_point = False


# ---- tool dimensions in millimetres (what the presets set): converted to the sf_* scene-unit settings
def _rounded(x):
    """The decimal a user typed, not the single-precision noise of the scene-unit setting (7 digits)."""
    return float("{:.7g}".format(x))


def _mm(self):
    return mm_per_scene_unit(self.id_data)


def _flute(self):
    """The cone's flute length h (scene units): sf_length for a cylinder or a cone given by its length, else
    (r2 - r1) / tan(alpha)."""
    import math

    if self.tool_kind == "CYLINDER" or self.sf_shape == "length" or not 0.0 < self.sf_alpha < 0.5 * math.pi:
        return float(self.sf_length)
    return (float(self.sf_r2) - float(self.sf_r1)) / math.tan(float(self.sf_alpha))


def _set_flute(self, h):
    """Keep r1 and alpha, make the flute length h: r2 = r1 + h tan(alpha) and sf_length = h."""
    import math

    self.sf_length = h
    if 0.0 < self.sf_alpha < 0.5 * math.pi:
        self.sf_r2 = float(self.sf_r1) + h * math.tan(float(self.sf_alpha))


def _get_tip_mm(self):
    return _rounded(2.0 * float(self.sf_r1) * _mm(self))


def _usable_mm(value):
    """A millimetre field's new value is taken only when it is a finite number >= 0: the field keeps its value
    otherwise, as Blender's own fields do beyond their limits (NaN would pass the clamp to min)."""
    import math

    return math.isfinite(value) and value >= 0.0


def _set_tip_mm(self, value):
    if not _usable_mm(value):
        return
    h = _flute(self)
    self.sf_r1 = 0.5 * value / _mm(self)
    _set_flute(self, h)


def _get_taper_deg(self):
    import math

    return _rounded(math.degrees(float(self.sf_alpha)))


def _set_taper_deg(self, value):
    import math

    if not (math.isfinite(value) and 0.0 < value < 90.0):
        return
    h = _flute(self)
    self.sf_alpha = math.radians(value)
    _set_flute(self, h)


def _get_flute_mm(self):
    return _rounded(_flute(self) * _mm(self))


def _set_flute_mm(self, value):
    if not _usable_mm(value):
        return
    _set_flute(self, value / _mm(self))


def _get_shank_d_mm(self):
    return _rounded(2.0 * float(self.sf_shank_radius) * _mm(self))


def _set_shank_d_mm(self, value):
    if not _usable_mm(value):
        return
    self.sf_shank_radius = 0.5 * value / _mm(self)


def _get_shank_l_mm(self):
    return _rounded(float(self.sf_shank_length) * _mm(self))


def _set_shank_l_mm(self, value):
    if not _usable_mm(value):
        return
    self.sf_shank_length = value / _mm(self)


def tool_mm_props():
    """Tool dimensions in mm (not stored: they read and write the sf_* settings in scene units), so a preset
    of a 6 mm end mill gives a 6 mm tool whatever the scene's unit and unit scale."""
    return dict(
        tool_tip_diameter_mm=FloatProperty(name="Tip Diameter (mm)", description="2 x r1 in millimetres",
                                           get=_get_tip_mm, set=_set_tip_mm, precision=4, min=0.0),
        tool_taper_deg=FloatProperty(name="Taper (deg)", description="Taper half angle = opening angle alpha in "
                                                                     "degrees", get=_get_taper_deg,
                                     set=_set_taper_deg, precision=4, min=0.0, max=90.0),
        tool_flute_length_mm=FloatProperty(name="Flute Length (mm)", description="Flute length h in millimetres "
                                                                                 "(r2 follows from r1, taper and h)",
                                           get=_get_flute_mm, set=_set_flute_mm, precision=4, min=0.0),
        tool_shank_diameter_mm=FloatProperty(name="Shank Diameter (mm)", description="2 x shank radius in mm",
                                             get=_get_shank_d_mm, set=_set_shank_d_mm, precision=4, min=0.0),
        tool_shank_length_mm=FloatProperty(name="Shank Length (mm)", description="Shank length beyond the flutes "
                                                                                 "in mm", get=_get_shank_l_mm,
                                           set=_set_shank_l_mm, precision=4, min=0.0),
    )


# ---- the legend: swatches of verify.deviation_colors at multiples of the tolerance (read from the core)
LEGEND_STEPS = (("gouge_deep", -10.0), ("gouge", -(1.0 + 1e-9)), ("ok", 0.0), ("stock", 1.0 + 1e-9),
                ("stock_deep", 10.0))
_LEGEND_RGB = {}


def legend_rgb(key):
    """Linear RGB of the legend swatch ``key``: flank_addon.simulation.verify.deviation_colors at LEGEND_STEPS[key] x
    tolerance (the colours do not depend on the tolerance itself, only on deviation / tolerance)."""
    rgb = _LEGEND_RGB.get(key)
    if rgb is None:
        from ..flank_addon.simulation.verify import deviation_colors

        t = dict(LEGEND_STEPS)[key]
        rgb = _LEGEND_RGB[key] = tuple(float(c) for c in deviation_colors([t], 1.0)[0][:3])
    return rgb


def _legend_prop(key):
    return FloatVectorProperty(name=key.replace("_", " ").title(), subtype='COLOR', size=3, min=0.0, max=1.0,
                               description="Colour of the strips' error attribute here (fixed)",
                               get=lambda self: legend_rgb(key), set=lambda self, value: None)


def _strip_index_changed(self, context):
    from .runs import find_run
    from .strips import select_strip

    coll = find_run(context)
    if not isinstance(coll, str):
        select_strip(context, coll, int(self.results_strip_index))


def results_props():
    """The Results panel: the strips list's active row and the legend swatches."""
    return dict(
        results_strip_index=IntProperty(name="Strip", default=0, update=_strip_index_changed),
        **{"legend_" + k: _legend_prop(k) for k, _ in LEGEND_STEPS},
    )


class FLANK_PG_flank(bpy.types.PropertyGroup):
    """One flank of the workpiece's rotor in the sidebar's flank list (filled by flank.refresh_flanks)."""

    flank: IntProperty(name="Flank", description="Flank index of the rotor", default=0)
    valley: IntProperty(name="Valley", description="Valley K of the flank (flanks 2K and 2K + 1)", default=0)
    u_start: FloatProperty(name="Start", description="Start of the flank's profile parameter range", default=0.0)
    u_end: FloatProperty(name="End", description="End of the flank's profile parameter range", default=0.0)
    hyperbolic_fraction: FloatProperty(name="Hyperbolic", description="Share of the flank's profile arc length "
                                                                      "where the surface is hyperbolic (where a cone "
                                                                      "can touch it along a curve)",
                                       default=0.0, min=0.0, max=1.0, subtype='FACTOR')
    a_min: FloatProperty(name="a_min", description="Smallest transverse semi-axis of the Dupin indicatrix over the "
                                                   "hyperbolic part (Bizzarri, Bo & Bartoň, Eq. 17; scene units; "
                                                   "0 = none)",
                         default=0.0, unit='LENGTH')


def ui_props():
    """Workflow state of the sidebar: tool kind, strategy, the flank list and its active row."""
    return dict(
        tool_kind=EnumProperty(name="Tool", items=TOOL_KIND_ITEMS, default="CONE", update=_tool_kind_changed),
        strategy=EnumProperty(name="Strategy", items=STRATEGY_ITEMS, default="SINGLE", update=_strategy_changed),
        flank_list=bpy.props.CollectionProperty(type=FLANK_PG_flank),
        flank_index=IntProperty(name="Flank", description="The flank the planners work on (single flank: this "
                                                          "flank; double flank: its valley)",
                                default=-1, update=_flank_index_changed),
        flank_list_rotor=StringProperty(name="Flank List Rotor", description="Rotor object the flank list was "
                                                                              "made for", default=""),
        ui_show_generate=BoolProperty(name="Built-in Rotor", description="Show the built-in rotor generator",
                                      default=False),
        ff_live_preview=BoolProperty(name="Live Preview", description="Redraw the guiding-curve preview whenever "
                                                                      "the direction, spacing or surface settings "
                                                                      "change", default=False),
        **tool_mm_props(),
    )


class FLANK_PG_settings(bpy.types.PropertyGroup):
    """The Flank Toolpath settings of a scene: the values the sidebar shows and the Run button passes on"""

    __annotations__ = {**generator_props(), **_prefixed("verify_", verify_props()),
                       **_prefixed("groove_", paraboloid_props()), **_prefixed("cutter_", formed_cutter_props()),
                       **_prefixed("df_", double_flank_props()),
                       **_prefixed("sf_", single_flank_props()), **_prefixed("ff_", freeform_props()),
                       **results_props(), **ui_props(), **cutting_data_props(), **machine_settings_props()}


classes = (
    FLANK_PG_flank,          # item type of FLANK_PG_settings.flank_list: registered first
    FLANK_PG_settings,
)
register, unregister = bpy.utils.register_classes_factory(classes)
