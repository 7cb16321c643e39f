"""Report picture of a free-form (Rajain et al. 2023) plan: the surface, the envelope strips coloured by their exact
signed distance to it, legend and title with the kink angles.

The picture itself is rendered by the extension's report scene (one code path with the rotor reports); this
module only supplies its geometry from a ``surface`` plan.
"""
import numpy as np

from ..methods.freeform_g1.planner import freeform_envelopes, plan_mesh


def freeform_geometry(plan, tolerance=None, n_s=9):
    """The ``geometry`` dict of the report scene's ``render_plan_report`` for a free-form plan.

    strips: per strip (verts, triangles, deviation, surface normal at the foot point); tolerance:
    the given one, else the plan's ``tolerance``, else 1e-3 of the surface's bounding-box diagonal."""
    mesh = plan_mesh(plan)
    strips = []
    for env in freeform_envelopes(plan, n_s=n_s, mesh=mesh):
        q = env["faces"]
        tri = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
        d = env["deviation"]
        tri = tri[np.isfinite(d)[tri].all(1)]
        v = env["vertices"]
        ok = np.isfinite(v).all(1)
        vv = np.where(ok[:, None], v, 0.0)
        n = mesh.foot_points(vv)["normal"]
        strips.append((vv, tri, np.where(np.isfinite(d), d, 0.0), n))
    size = mesh.size
    tol = tolerance if tolerance is not None else plan.get("tolerance")
    if tol is None or not tol > 0:
        tol = 1e-3 * size
    s = plan["summary"]
    return dict(rotor=(mesh.vertices, mesh.faces), occluders=mesh.vertices, strips=strips, tolerance=float(tol),
                max_error=s.get("max_error"), min_error=s.get("min_error"), unit=plan.get("length_unit", "mm"),
                method=plan.get("method", ""), outer_radius=0.5 * size)


def freeform_title(plan, name=None):
    """First title line: what was planned and its kink angles."""
    s = plan["summary"]
    head = name or "Free-form G1 plan"
    return "{}: {} strips, max kink {:.3g}°, mean {:.3g}°".format(head, len(plan["strips"]), s.get("max_kink_deg", 0.0),
                                                               s.get("mean_kink_deg", 0.0))
