"""Hu, Zhou & Li 2025 cutter verified by the independent sweep simulation (part 1 engine): the disc cutter, swept
along the helix relative to the rotor, must reproduce the design tooth where no interference is
flagged, show the flagged (uncut) regions, and never overcut."""
import numpy as np
import pytest

from flank_addon.methods.formed_cutter import cutter_profile as fc
from flank_addon.simulation.sweep import MeridianPart, RevolvingTool, machined_deviation

LEAD, A = 450.0, 200.0
UM = 1e-3   # mm


def swept_deviation(swivel, n=41, planes=2000):
    prof, tooth, _ = fc.arc_tooth_profile()
    cp = fc.cutter_profile(prof, LEAD, A, swivel, tooth=tooth)
    Z, R, setup = fc.cutter_meridian(prof, LEAD, A, swivel, planes=planes, tooth=tooth)
    tool = RevolvingTool([MeridianPart(setup.axis_point, setup.axis_direction, np.c_[Z, R])])
    u = np.linspace(tooth[0], tooth[1], n + 2)[1:-1]          # tooth ends are corners: no normal
    dev = machined_deviation([tool], prof.eval(u), prof.outward_normal(u), LEAD / (2 * np.pi), "right",
                             max_deviation=20.0)
    flagged = np.zeros(n, bool)
    for r in cp.summary()["uncut"]:
        flagged |= (u >= r["u_start"]) & (u <= r["u_end"])
    return cp, u, dev, flagged


def test_table1_cutter_reproduces_the_tooth_within_1um():
    cp, u, dev, flagged = swept_deviation(31.0)
    assert not any(cp.summary()["flag_counts"].values()) and not flagged.any()
    assert np.isfinite(dev).all()
    assert np.abs(dev).max() <= 1 * UM, np.abs(dev).max()


@pytest.mark.parametrize("swivel", [50.0, 10.0])
def test_flagged_regions_show_in_the_sweep_and_nothing_is_overcut(swivel):
    cp, u, dev, flagged = swept_deviation(swivel)
    assert flagged.any()
    assert dev.min() >= -1 * UM, dev.min()                   # the cutter never enters the rotor
    assert np.abs(dev[~flagged]).max(initial=0.0) <= 1 * UM  # unflagged: on the design surface
    # flagged uncut ranges really are left standing (interior points; the range ends touch)
    assert np.mean(dev[flagged] > 10 * UM) > 0.8


def test_table1_tooth_corners_within_1um():
    """The tooth ends meet the blank cylinder at sharp corners, where the meridian curves most:
    measured along the tooth's own normal the swept cutter still meets them within 1 um."""
    prof, tooth, _ = fc.arc_tooth_profile()
    Z, R, setup = fc.cutter_meridian(prof, LEAD, A, 31.0, tooth=tooth)
    tool = RevolvingTool([MeridianPart(setup.axis_point, setup.axis_direction, np.c_[Z, R])])
    u = np.array([tooth[0], tooth[1]])
    inward = np.array([tooth[0] + 1e-9, tooth[1] - 1e-9])        # the tooth side of each corner
    dev = machined_deviation([tool], prof.eval(u), prof.outward_normal(inward), LEAD / (2 * np.pi), "right",
                             max_deviation=5.0)
    assert np.abs(dev).max() <= 1 * UM, dev
