"""Fixtures of the machining tests: LinuxCNC's interpreter (installed with apt where it is missing), small
rotors in mm and one plan of each kind (single-flank cone, double-flank, formed disc cutter)."""
import shutil

import numpy as np
import pytest

from flank_addon.geometry.rotors import builtin_by_name
from linuxcnc_install import wait_or_install


@pytest.fixture(scope="session")
def rs274():
    """Path of LinuxCNC's rs274 interpreter; installs linuxcnc-uspace with apt when it is missing (or waits
    for the install a parallel run started in the background) and fails (never skips) when that is impossible."""
    path = shutil.which("rs274")
    if path is None:
        why = wait_or_install()
        path = shutil.which("rs274")
        if path is None:
            pytest.fail("LinuxCNC's interpreter rs274 is missing and could not be installed "
                        f"(apt-get install -y --no-install-recommends linuxcnc-uspace): {why}")
    return path


@pytest.fixture(scope="session")
def female_rotor():
    """Left-handed 6-lobe female, outer radius 30 mm, 60 mm long."""
    return builtin_by_name("srm_a-female", scale=30.0, length=60.0)


@pytest.fixture(scope="session")
def male_rotor():
    """Right-handed 4-lobe male, outer radius 30 mm, 60 mm long."""
    return builtin_by_name("srm_a-male", scale=30.0, length=60.0)


@pytest.fixture(scope="session")
def single_flank_plan(male_rotor):
    """Single-flank conical plan (a D3 L25 2-deg tapered end mill) of the male's flank 0 (4 strips, tool axes
    45-54 deg from the rotor axis: every built-in machine reaches them), in mm, with the rotor extent."""
    from flank_addon.methods.single_flank.planner import plan_single_flank
    from flank_addon.tooling.cone import ConeTool

    r = male_rotor
    tool = ConeTool.from_length(1.5, 1.5 + 25.0 * np.tan(np.radians(2.0)), 25.0, shank_radius=3.0,
                                shank_length=45.0)
    res = plan_single_flank(r.surface(), r.flanks, 0, tool, 0.05, n_seeds=6, max_rounds=1, length_unit="mm",
                            n_profile=720)
    plan = res.plan
    plan["rotor"]["extent"] = r.extent()
    return plan


@pytest.fixture(scope="session")
def double_flank_plan(male_rotor):
    """Double-flank plan (cone on the valley's reference line) of valley 0, in mm, with the rotor extent."""
    from flank_addon.methods.double_flank.planner import plan_double_flank

    r = male_rotor
    res = plan_double_flank(r.surface(), r.flanks, valley=0, m=40, tool="cone", simulate=False, length_unit="mm")
    plan = res.plan
    plan["rotor"]["extent"] = r.extent()
    return plan


@pytest.fixture(scope="session")
def formed_cutter_plan(male_rotor):
    """Formed disc cutter (centre distance 54 mm, swivel 45 deg) as a flank-plan/1 plan, with the extent."""
    from flank_addon.machining.disc_cutter_plan import disc_cutter_plan
    from flank_addon.methods.formed_cutter.cutter_profile import cutter_profile

    r = male_rotor
    cp = cutter_profile(r.profile, r.lead, 54.0, 45.0, handedness=r.handedness, planes=24, analyse=False)
    return disc_cutter_plan(r.profile, r.v0, r.handedness, r.flanks, cp, extent=r.extent(), n_profile=720)


@pytest.fixture(scope="session")
def two_tool_plan(male_rotor):
    """Single-flank plan of the male's flank 0 with two tool presets in turn (the 2 deg D6 L35 end mill, then the
    1.5 deg D2 L20 one for what it leaves), one seeding round each: strips of both tools, in mm, with the extent."""
    from flank_addon.methods.single_flank.planner import plan_single_flank
    from flank_addon.tooling.presets import presets_by_name

    r = male_rotor
    tools = [(p.name, p.tool()) for p in presets_by_name(["Tapered 2deg D6 L35", "Tapered 1.5deg D2 L20"])]
    res = plan_single_flank(r.surface(), r.flanks, 0, tools, 0.05, n_seeds=4, max_rounds=1, length_unit="mm",
                            n_profile=720)
    plan = res.plan
    plan["rotor"]["extent"] = r.extent()
    return plan


@pytest.fixture(scope="session")
def posted(single_flank_plan):
    """The single-flank plan as a program for rotor-xa-b (lobes 0, 1): plan, rotor body, machine, program."""
    from flank_addon.machining.machine import load_machine
    from flank_addon.machining.operation import build_operation
    from flank_addon.machining.rotor_body import rotor_body
    from flank_addon.machining.toolpath import build_program

    rb = rotor_body(single_flank_plan)
    op = build_operation([single_flank_plan], rb, lobes=[0, 1])
    machine = load_machine("rotor-xa-b")
    return single_flank_plan, rb, machine, build_program(op, machine)
