"""A formed disc cutter (Hu, Zhou & Li 2025, :mod:`..methods.formed_cutter`) as a flank-plan/1 plan.

The formed-cutter method computes the cutter's axial profile (meridian (Z_u, R_u)) and its pose (axis point O
and direction e_z in the rotor frame) but writes no plan.  Its pass is the flank-plan/1 model exactly: the
disc turns on a fixed axis while the rotor screws.  So the plan has one strip:

    axis_start = O + Z_0 e_z,  axis_end = O + Z_M e_z,  meridian = [[Z_m - Z_0, R_m], ...],
    radii = [R_0, R_M] (unused beside the meridian), tool kind "disc",

the arbor as the strip's shank (a cylinder on the axis beyond the disc's Z_M face, radius below the gap
A - outer radius so it clears the rotor), the target flanks those of the cutter's tooth (the valley it forms),
and the reported errors those of the sweep simulation (:func:`..simulation.verify.verify_plan`).  One strip per
valley; the operation indexes it to every lobe.
"""
import numpy as np


def disc_cutter_plan(profile, v0, handedness, flanks, cutter, length_unit="mm", to_world=None, extent=None,
                     arbor_radius=None, arbor_length=None, n_profile=2048):
    """The flank-plan/1 plan of a :class:`..methods.formed_cutter.cutter_profile.CutterProfile` ``cutter`` cut
    into the rotor (``profile``: :class:`SplineProfile`; ``flanks``: its parameter ranges, as
    ``Rotor.flanks``)."""
    from ..io.plan import new_plan, rotor_section, summarize
    from ..simulation.verify import verify_plan

    rotor = rotor_section(profile, v0, handedness, flanks, to_world=to_world, n_profile=n_profile)
    if extent is not None:
        rotor["extent"] = extent
    Z, R = np.asarray(cutter.z, float), np.asarray(cutter.r, float)
    keep = np.r_[True, np.diff(Z) > 0]
    Z, R = Z[keep], np.maximum(R[keep], 0.0)
    o, d = np.asarray(cutter.setup.axis_point, float), np.asarray(cutter.setup.axis_direction, float)
    gap = cutter.setup.centre_distance - rotor["outer_radius"]
    ra = float(arbor_radius) if arbor_radius is not None else min(0.5 * gap, 0.3 * float(R.max()))
    if not 0 < ra < gap:
        raise ValueError(f"arbor radius {ra:g} must lie in (0, {gap:g}): the gap between the cutter axis and "
                         "the rotor's outer radius")
    la = float(arbor_length) if arbor_length is not None else 2.0 * float(Z[-1] - Z[0])
    a0, a1 = o + Z[0] * d, o + Z[-1] * d
    period = profile.period
    u0, u1 = cutter.tooth
    span = (u1 - u0) % period or period
    targets = [k for k, (a, b) in enumerate(flanks) if ((0.5 * (a + b) - u0) % period) < span]
    if not targets:
        raise ValueError(f"no flank lies in the cutter's tooth u in [{u0:g}, {u1:g}]")
    strip = {"axis_start": a0.tolist(), "axis_end": a1.tolist(), "radii": [float(R[0]), float(R[-1])],
             "meridian": np.c_[Z - Z[0], R].tolist(), "shank_start": a1.tolist(),
             "shank_end": (a1 + la * d).tolist(), "shank_radius": ra, "flank": int(targets[0]),
             "reported_max_error": 0.0, "reported_min_error": 0.0, "collision": False}
    tool = {"kind": "disc", "centre_distance": float(cutter.setup.centre_distance),
            "swivel_deg": float(np.degrees(cutter.setup.swivel)), "planes": int(len(Z)),
            "max_diameter": 2.0 * float(R.max()), "width": float(Z[-1] - Z[0]),
            "arbor_radius": ra, "arbor_length": la}
    plan = new_plan("formed-disc-cutter", rotor, tool, length_unit=length_unit, target_flanks=targets,
                    strips=[strip], elapsed_s=float(getattr(cutter, "elapsed_s", 0.0) or 0.0))
    res = verify_plan(plan)
    fin = [d for _, _, _, d in res["deviation_profile"] if d is not None]
    if fin:
        plan["strips"][0]["reported_max_error"] = float(max(fin))
        plan["strips"][0]["reported_min_error"] = float(min(fin))
        plan["strips"][0]["collision"] = bool(any(not g["target"] for g in res["gouge_points"]))
    plan["summary"] = summarize(plan["strips"], plan["summary"]["elapsed_s"])
    return plan
