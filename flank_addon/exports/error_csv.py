"""The verified error along the target flanks of a plan as CSV (one row per profile point, or per envelope
vertex of a free-form plan)."""
import math

from ..io.plan import is_mesh_plan


def error_profile_csv(source, tolerance=None):
    """CSV text ``index,x,y,deviation`` per target-flank profile point (verify's ``deviation_profile``).

    ``source``: a :func:`verify.verify_plan` result, or a plan (then verified here with ``tolerance``,
    default the plan's ``tolerance`` field or verify's default).  An empty deviation field = no tool
    reaches the point within verify's search range."""
    if is_mesh_plan(source):
        from ..methods.freeform_g1.planner import freeform_envelopes
        rows = ["strip,i_t,j_s,x,y,z,deviation"]
        for k, env in enumerate(freeform_envelopes(source)):
            ns = env["shape"][1]
            for idx, (p, d) in enumerate(zip(env["vertices"], env["deviation"])):
                rows.append(f"{k},{idx // ns},{idx % ns},{float(p[0])!r},{float(p[1])!r},{float(p[2])!r},"
                            f"{'' if not math.isfinite(d) else repr(float(d))}")
        return "\n".join(rows) + "\n"
    if "deviation_profile" not in source:
        from ..simulation.verify import verify_plan
        tol = tolerance if tolerance is not None else source.get("tolerance")
        source = verify_plan(source, tolerance=tol)
    rows = ["index,x,y,deviation"]
    for i, x, y, d in source["deviation_profile"]:
        rows.append(f"{int(i)},{float(x)!r},{float(y)!r},{'' if d is None else repr(float(d))}")
    return "\n".join(rows) + "\n"
