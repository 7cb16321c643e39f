"""Command line: ``python -m flank_addon <command> ...`` (public interface, see README)."""
import argparse
import io
import json
import math
import os
import re
import sys
import time

import numpy as np

from .io.files import atomic_write


class CommaList:
    """argparse type of a comma-separated list of ``n`` finite numbers, e.g. ``X,Y,Z``: returns a tuple of
    floats, or names the value and what it must be.  :func:`main` lets such a value start with a minus sign
    without ``=`` (``--flank-point -10,2,3``)."""

    def __init__(self, n, what):
        self.n, self.what = int(n), what

    def __call__(self, text):
        try:
            vals = tuple(float(x) for x in str(text).split(","))
        except ValueError:
            vals = ()
        if len(vals) != self.n or not all(math.isfinite(v) for v in vals):
            count = {2: "two", 3: "three", 5: "five"}.get(self.n, str(self.n))
            raise argparse.ArgumentTypeError(f"{text!r} must be {count} finite numbers {self.what}")
        return vals

    def __repr__(self):                      # argparse names the type in some messages
        return f"{self.n} numbers {self.what}"


_NUMBER_LIST = re.compile(r"^-[0-9.][0-9.eE+-]*(,[-+0-9.eE]*)*$")


def attach_negative_lists(argv):
    """``--option -1,2,3`` -> ``--option=-1,2,3``, ``--option -1e-3`` -> ``--option=-1e-3``.  argparse reads a
    token that starts with '-' as an option unless it is a plain negative number (no exponent); a number or a comma
    list of numbers is always the value of the option before it, and ``--option=value`` means the same to
    argparse."""
    out = []
    for tok in argv:
        if out and _NUMBER_LIST.match(tok) and out[-1].startswith("--") and "=" not in out[-1]:
            out[-1] = out[-1] + "=" + tok
        else:
            out.append(tok)
    return out


def _cmd_rotor(args):
    from .io.mesh_files import write_mesh
    from .geometry.profile import load_profile_csv
    from .geometry.rotors import builtin_rotor, helical_body_mesh

    t0 = time.perf_counter()
    if args.profile_csv:
        if args.lead is None or args.length is None:
            raise ValueError("--profile-csv needs --lead and --length")
        if args.lead == 0:
            raise ValueError("--lead must not be 0")
        prof = load_profile_csv(args.profile_csv, unit_scale=args.scale)
        # like the built-ins: a negative lead flips the hand (right by default)
        hand = args.handedness or "right"
        if args.lead < 0:
            hand = "left" if hand == "right" else "right"
        v0 = abs(args.lead) / (2 * np.pi)
        n_prof = args.resolution or 2048
        verts, faces = helical_body_mesh(prof, v0, hand, args.length, n_profile=n_prof, n_axial=args.axial)
        desc = f"profile {args.profile_csv}: {hand}-handed, v0 {v0:.6g}, length {args.length:g}"
    else:
        if not args.kind or not args.part:
            raise ValueError("give --kind and --part (or --profile-csv)")
        rotor = builtin_rotor(args.kind, args.part, scale=args.scale, lead=args.lead, length=args.length,
                              handedness=args.handedness)
        verts, faces = rotor.mesh(n_profile=args.resolution or 2048, n_axial=args.axial)
        desc = (f"{rotor.name}: {rotor.lobes} lobes, {rotor.handedness}-handed, lead {rotor.lead:.6g} "
                f"(v0 {rotor.v0:.6g}), length {rotor.length:g}, outer radius {args.scale:g}")
    write_mesh(args.out, verts, faces)
    print(f"{desc}; wrote {args.out} ({len(verts)} vertices, {len(faces)} triangles, "
          f"{time.perf_counter() - t0:.2f} s)")
    return 0


def _cmd_analyze(args):
    from .io.mesh_files import read_mesh
    from .geometry.rotor_analysis import analyze_mesh

    if args.profile_points < 720:
        raise ValueError(f"--profile-points {args.profile_points} is below the minimum 720 of flank-plan/1")
    if args.profile_points > MAX_PROFILE_POINTS:
        raise ValueError(f"--profile-points {args.profile_points} is over the maximum {MAX_PROFILE_POINTS}")
    t0 = time.perf_counter()
    verts, faces = read_mesh(args.path)
    t1 = time.perf_counter()
    a = analyze_mesh(verts, faces, n_profile=args.profile_points)
    t2 = time.perf_counter()
    d = a.to_dict()
    d["mesh"] = {"path": str(args.path), "vertices": int(len(verts)), "triangles": int(len(faces))}
    d["timing_s"] = {"read": t1 - t0, "analyze": t2 - t1}
    if args.profile_out:
        _write_csv(args.profile_out, a.profile, "x,y", fmt="%.18e")
    if args.json:
        d["profile"] = a.profile.tolist()
        print(json.dumps(d, indent=1))
    else:
        print(f"axis point      {np.array2string(a.axis_point, precision=6)}")
        print(f"axis direction  {np.array2string(a.axis_direction, precision=8)}")
        print(f"v0              {a.v0:.8g} (pitch {2 * np.pi * a.v0:.8g}), {a.handedness}-handed")
        print(f"residual        {a.residual:.3g} (threshold {a.threshold:.3g})")
        print(f"outer radius    {a.outer_radius:.6g}, {a.lobes} lobes, {len(a.flanks)} flanks")
        print(f"time            {t2 - t1:.2f} s analysis, {t1 - t0:.2f} s reading")
    return 0


def _cmd_check_plan(args):
    from .io.plan import read_plan

    plan = read_plan(args.path)
    s = plan["summary"]
    print(f"{args.path}: valid {plan['schema']} ({plan['method']}, {len(plan['strips'])} strips, "
          f"unit {plan['length_unit']}); max error {s['max_error']:.4g}, min error {s['min_error']:.4g}")
    return 0


# a tool (with its shank) longer or wider than this many times the part (a rotor's outer radius, a mesh's
# bounding-box diagonal) is in another unit than the part
MAX_TOOL_SCALE = 100.0
MIN_GROOVE_POINTS = 101
MAX_GROOVE_POINTS = 100000
# the largest profile resolution the commands take: a rotor profile sampled finer than every micrometre of a
# 10 mm rotor's rim says nothing more, and its mesh or analysis would not fit in memory
MAX_PROFILE_POINTS = 65536
# a screw rotor's lead is some times its outer radius; a disc cutter for a lead below a tenth of it would wind
# the profile round its axis tens of thousands of times (and run out of memory doing so)
MIN_CUTTER_LEAD = 0.1


def _cmd_paraboloid(args):
    from .methods.paraboloid_groove.groove import groove_section

    part = "full" if args.full else ("internal" if args.internal else "external")
    if args.points < MIN_GROOVE_POINTS:
        # the largest overcut is a maximum over these points: 101 hold it to 2e-4 of 4001's on the paper's example
        raise ValueError(f"--points {args.points} is below the minimum {MIN_GROOVE_POINTS} (the section and its "
                         "largest overcut are sampled at these points)")
    if args.points > MAX_GROOVE_POINTS:
        raise ValueError(f"--points {args.points} is over the maximum {MAX_GROOVE_POINTS}")
    t0 = time.perf_counter()
    sec = groove_section(args.radius, args.a, args.b, args.pitch, n=args.points, part=part)
    dt = time.perf_counter() - t0
    _write_csv(args.out, np.c_[sec.x, sec.y], "x,y")
    print(f"{part} groove section: x in [{sec.x[0]:.6g}, {sec.x[-1]:.6g}], max y {sec.y.max():.6g}, "
          f"max overcut of the helical path {sec.overcut.max():.6g}; {len(sec.x)} points in "
          f"{dt * 1e3:.2f} ms; wrote {args.out}")
    return 0


def _cmd_verify(args):
    from .io.plan import read_plan
    from .simulation.verify import verify_plan

    if args.program:
        return _cmd_verify_program(args)
    if len(args.plans) != 1:
        raise ValueError("verify takes one plan (several only with --program)")
    for opt in ("machine", "post", "mesh", "outer_radius_mm", "lobes", "cutting_data", "coolant", "flutes", "vc",
                "fz", "max_rpm"):
        if getattr(args, opt) is not None or args.flip_rotor or args.holder:
            opt = opt if getattr(args, opt) is not None else "flip_rotor" if args.flip_rotor else "holder"
            raise ValueError(f"--{opt.replace('_', '-')} applies to verify --program only")
    args.plan = args.plans[0]
    plan = read_plan(args.plan)
    if plan.get("surface") is not None:
        from .methods.freeform_g1.planner import verify_freeform
        res = verify_freeform(plan, tolerance=args.tolerance)
        if args.json:
            print(json.dumps(res, indent=1))
            return 0
        u = res["length_unit"]
        print(f"{args.plan}: free-form plan, {len(plan['strips'])} strips, checked in {res['elapsed_s']:.2f} s")
        print(f"  Eq. (19) at the ruling samples: max {res['eq19_max']:+.6g} {u}, min {res['eq19_min']:+.6g} {u}")
        print(f"  envelope points (exact distance): max {res['envelope_max']:+.6g} {u}, min "
              f"{res['envelope_min']:+.6g} {u} ({res['envelope_points']} points)")
        cov = res["sweep_max_covered"]
        print(f"  swept tool at {res['vertices']} surface vertices: gouge (min) {res['sweep_min']:+.6g} {u}; "
              f"{res['vertices_covered']} covered, material left there at most "
              f"{'n/a' if cov is None else format(cov, '+.6g')} {u}")
        print(f"  kink max {res['max_kink_deg']:.4g} deg, mean {res['mean_kink_deg']:.4g} deg")
        return 0
    res = verify_plan(plan, tolerance=args.tolerance)
    if args.json:
        print(json.dumps(res, indent=1))
        return 0
    u = res["length_unit"]
    fmt = lambda v: "n/a" if v is None else f"{v:+.6g} {u}"  # noqa: E731
    print(f"{args.plan}: simulated {len(plan['strips'])} strips against {len(res['deviation_profile'])} "
          f"target points in {res['elapsed_s']:.2f} s (tolerance {res['tolerance']:.3g} {u})")
    print(f"max undercut (material left) {fmt(res['max_undercut'])}, max overcut {fmt(res['max_overcut'])}")
    for f in res["flanks"]:
        print(f"  flank {f['flank']}: uncovered index ranges {f['uncovered_ranges'] or 'none'}")
    print(f"gouge points (deeper than the tolerance, whole rotor): {len(res['gouge_points'])}")
    return 0


def _cmd_cutter(args):
    from .methods.formed_cutter.cutter_profile import cutter_profile
    from .geometry.profile import load_profile_csv
    from .geometry.rotors import builtin_by_name
    from .io.files import atomic_write_all
    from .io.plan import RELATIVE_RANGE, plan_text

    if (args.profile is None) == (args.builtin is None):
        raise ValueError("give exactly one of --profile CSV or --builtin NAME")
    hand = args.handedness
    if args.builtin:
        rotor = builtin_by_name(args.builtin, scale=args.scale)
        prof = rotor.profile
        hand = hand or rotor.handedness
        lead = rotor.lead if args.lead is None else args.lead
        src = f"{args.builtin} (outer radius {args.scale:g})"
    else:
        if args.lead is None:
            raise ValueError("--profile needs --lead")
        prof = load_profile_csv(args.profile, unit_scale=args.scale)
        lead = args.lead
        hand = hand or "right"
        src = str(args.profile)
    if not np.isfinite(lead) or lead == 0:
        raise ValueError(f"--lead must be a non-zero finite number, got {lead!r}")
    if lead < 0:  # as for the rotor command: a negative lead flips the hand
        lead = -lead
        hand = "left" if hand == "right" else "right"
    outer = prof.outer_radius()
    if lead < MIN_CUTTER_LEAD * outer:
        raise ValueError(f"--lead {lead:g} is below {MIN_CUTTER_LEAD:g} times the rotor's outer radius {outer:g}: a "
                         "screw rotor's lead is some times its radius")
    if lead > 2 * np.pi * RELATIVE_RANGE[1] * outer:       # a plan of it (v0 = lead / 2 pi) could not be read
        raise ValueError(f"--lead {lead:g} is over {2 * np.pi * RELATIVE_RANGE[1]:.4g} times the rotor's outer "
                         f"radius {outer:g}: no screw rotor")
    if args.planes < 2:
        raise ValueError(f"--planes {args.planes} is below the minimum 2")
    if args.planes > 10000:
        raise ValueError(f"--planes {args.planes} is over the maximum 10000")
    cp = cutter_profile(prof, lead, args.center_distance, args.swivel, handedness=hand, planes=args.planes,
                        eps_b=args.eps_b)
    s = cp.summary()
    if args.plan_out:
        # the plan is made and checked before either file is written; then both are written as one
        plan, s["plan"] = _cutter_plan(args, prof, lead, hand, cp, rotor if args.builtin else None)
        atomic_write_all([(args.out, _csv_text(cp.meridian, "z,r").encode()),
                          (args.plan_out, plan_text(plan).encode())])
    else:
        _write_csv(args.out, cp.meridian, "z,r")
    if args.json:
        s.update({"source": src, "out": str(args.out), "handedness": hand, "lead": lead})
        print(json.dumps(s, indent=1))
        return 0
    flagged = ", ".join(f"{k} {v}" for k, v in s["flag_counts"].items() if v) or "none"
    print(f"{src}: {s['planes']} planes, Z_u in [{s['z_range'][0]:.6g}, {s['z_range'][1]:.6g}], "
          f"R_u in [{s['r_range'][0]:.6g}, {s['r_range'][1]:.6g}]; flagged planes: {flagged}; "
          f"uncut tooth ranges {len(cp.uncut)}; {cp.elapsed_s * 1e3:.1f} ms; wrote {args.out}")
    if args.plan_out:
        p = s["plan"]
        print(f"  plan: formed disc cutter on flanks {p['target_flanks']}, machined deviation max "
              f"{p['max_error']:.4g} min {p['min_error']:.4g} {p['length_unit']}; wrote {args.plan_out}")
    return 0


def _cutter_plan(args, prof, lead, hand, cp, rotor):
    """--plan-out: the cutter as a flank-plan/1 plan (one strip, the disc's meridian) with the rotor's extent
    when it is a built-in, validated; and what the command reports of it."""
    from .geometry.rotor_analysis import split_flanks
    from .io.plan import validate_plan
    from .machining.disc_cutter_plan import disc_cutter_plan

    unit = args.length_unit or ("R" if args.builtin and args.scale == 1.0 else "mm")
    if rotor is not None:
        flanks, extent = rotor.flanks, rotor.extent()
    else:
        n = 4096
        idx, _ = split_flanks(prof.sample(n))
        flanks = [(a * prof.period / n, b * prof.period / n) for a, b in idx]
        extent = None
    plan = disc_cutter_plan(prof, lead / (2 * np.pi), hand, flanks, cp, length_unit=unit, extent=extent)
    outer = plan["rotor"]["outer_radius"]
    if unit == "R" and abs(outer - 1.0) > 1e-9:
        # the rotor is not in units of R: every length of the plan divided by its outer radius
        from .machining.rotor_body import scale_plan

        plan = scale_plan(plan, 1.0 / outer, "R")
    validate_plan(plan)
    return plan, {"out": str(args.plan_out), "target_flanks": plan["target_flanks"], "length_unit": unit,
                  "max_error": plan["summary"]["max_error"], "min_error": plan["summary"]["min_error"],
                  "extent": plan["rotor"].get("extent")}


def _load_rotor(args):
    """(surface, flank parameter ranges, to_world, length unit, source name) from --builtin / --mesh."""
    if (args.mesh is None) == (args.builtin is None):
        raise ValueError("give exactly one of --mesh PATH or --builtin NAME")
    to_world = None
    unit = "R"
    if args.builtin:
        from .geometry.rotors import builtin_by_name

        rotor = builtin_by_name(args.builtin)
        surface, flanks = rotor.surface(), rotor.flanks
        src = args.builtin
        args.rotor_extent = rotor.extent()
    else:
        from .io.mesh_files import read_mesh
        from .geometry.rotor_analysis import analyze_mesh

        verts, faces = read_mesh(args.mesh)
        a = analyze_mesh(verts, faces)
        surface, flanks = a.surface, a.flank_ranges()
        to_world = a.to_world
        unit = "mm"
        src = str(args.mesh)
        args.rotor_extent = a.extent()
    return surface, flanks, to_world, unit, src


def _with_extent(plan, args):
    """The plan with the rotor's axial extent (rotor.extent) when the planner knew the rotor."""
    ext = getattr(args, "rotor_extent", None)
    if ext is not None and plan.get("rotor") is not None:
        plan["rotor"]["extent"] = ext
    return plan


def _model_point_to_rotor(point, to_world):
    """A model-frame point (the mesh's frame) in the rotor frame of the analysis."""
    pt = np.asarray(point, float)
    if to_world is not None:
        inv = np.linalg.inv(np.asarray(to_world, float))
        pt = pt @ inv[:3, :3].T + inv[:3, 3]
    return pt


# the options of ``plan`` each planner reads (besides the rotor or mesh and --out); any other one given is refused.
# The two cone planners share the cone's radii, its shank and the JSON summary.
_CONE_PLANNERS = ("tool_r1", "tool_r2", "shank_radius", "shank_length", "json")
PLANNER_OPTIONS = {
    "double-flank": ("valley", "valley_point", "variant", "tool", "two_paths", "radii", "rim", "tool_csv"),
    "single-flank": _CONE_PLANNERS + ("flank", "flank_point", "tools", "outer_radius_mm", "max_tools", "split",
                                      "tool_alpha", "tool_h", "tolerance", "overcut_tolerance", "seeds", "objective",
                                      "mode", "rounds", "no_collisions", "g1", "g1_extra_strips", "profile_csv"),
    "freeform": _CONE_PLANNERS + ("tool_length", "direction", "field", "point", "weights", "spacing", "samples",
                                  "columns", "engagement", "optimize_tool", "slide", "max_evaluations",
                                  "flip_normals"),
}


def _foreign_plan_options(args, parser):
    """The message for an option of ``plan`` given a value that the chosen planner does not read, else None
    (``parser``: the one that read ``args``, asked for the defaults)."""
    if getattr(args, "command", None) != "plan":
        return None
    defaults = vars(parser.parse_args(["plan", args.planner, "--out", "-"]))
    mine = set(PLANNER_OPTIONS[args.planner])
    others = set().union(*PLANNER_OPTIONS.values()) - mine
    given = [k for k in sorted(others) if getattr(args, k, None) != defaults.get(k)]
    if given:
        users = [p for p, opts in PLANNER_OPTIONS.items() if given[0] in opts]
        return (f"--{given[0].replace('_', '-')} does not apply to plan {args.planner} (it is an option of plan "
                f"{' and '.join(users)})")
    return None


def _cmd_plan(args):
    if args.planner == "single-flank":
        return _cmd_plan_single_flank(args)
    if args.planner == "freeform":
        return _cmd_plan_freeform(args)
    from .methods.double_flank.planner import plan_double_flank, valley_of_point
    from .io.plan import write_plan

    if (args.valley is None) == (args.valley_point is None):
        raise ValueError("give exactly one of --valley K or --valley-point X,Y,Z")
    surface, flanks, to_world, unit, src = _load_rotor(args)
    nv = len(flanks) // 2
    if args.valley is not None:
        if not 0 <= args.valley < nv:
            raise ValueError(f"--valley {args.valley} is outside 0..{nv - 1} (this rotor has {nv} valleys)")
        k = args.valley
    else:
        k = valley_of_point(surface, flanks, _picked_point(surface, args.valley_point, to_world, "--valley-point", unit))
    if not 0.2 <= args.rim <= 0.98:
        raise ValueError(f"--rim {args.rim} is outside the limits 0.2..0.98")
    res = plan_double_flank(surface, flanks, valley=k, variant=args.variant, tool=args.tool,
                            two_paths=args.two_paths, m=args.radii, rim=args.rim, to_world=to_world,
                            length_unit=unit)
    write_plan(args.out, _with_extent(res.plan, args))
    if args.tool_csv:
        from .methods.double_flank.planner import write_tool_csv
        buf = io.StringIO()
        write_tool_csv(buf, res.paths[0])
        atomic_write(args.tool_csv, buf.getvalue())
    print(f"{src}: valley {k}, {res.plan['method']} ({args.variant}), {len(res.paths)} strip(s)")
    for j, f in enumerate(res.fits):
        print(f"  axis {j}: alpha {f.x[0]:+.5f}  delta {f.x[1]:+.5f}  phi {f.x[2]:+.5f}  "
              f"Phi {f.phi:.4g}  iterations {f.iterations}  {f.elapsed_s:.3f} s")
    for j, (t2r, r2e) in enumerate(zip(res.tool_to_rotor, res.rotor_to_envelope)):
        print(f"  flank {j + 1}: tool->rotor max {t2r[0]:.5g} min {t2r[1]:.3g}; rotor->envelope max "
              f"{r2e[0]:.5g} min {r2e[1]:.3g}; Hausdorff ~ {res.hausdorff[j]:.5g}")
    print(f"  time {res.elapsed_s:.2f} s (optimisation {res.optimize_s:.3f} s); wrote {args.out}")
    return 0


def _cmd_plan_freeform(args):
    """Rajain et al. 2023: G1 multi-strip flank milling of a free-form triangle mesh with a conical tool."""
    from .methods.freeform_g1.planner import plan_freeform
    from .io.mesh_files import read_mesh
    from .io.plan import write_plan

    if args.mesh is None:
        raise ValueError("freeform needs --mesh PATH (the surface to machine, STL/PLY/OBJ)")
    for name in ("tool_r1", "tool_r2", "tool_length"):
        if getattr(args, name) is None:
            raise ValueError(f"freeform needs --{name.replace('_', '-')}")
        if not math.isfinite(getattr(args, name)):
            raise ValueError(f"--{name.replace('_', '-')} {getattr(args, name)} is not a finite number")
    if args.direction is None and args.field is None:
        raise ValueError("freeform needs a guiding direction: --direction X,Y,Z (at --point) or --field CSV")
    V, F = read_mesh(args.mesh)
    span = float(np.linalg.norm(np.ptp(np.asarray(V, float), axis=0)))
    for name in ("tool_r1", "tool_r2", "tool_length", "shank_radius", "shank_length"):
        v = getattr(args, name)
        if v is not None and not (math.isfinite(v) and abs(v) <= MAX_TOOL_SCALE * span):
            raise ValueError(f"--{name.replace('_', '-')} {v:g} is over {MAX_TOOL_SCALE:g} times the mesh's size "
                             f"{span:.6g} (its bounding box diagonal): are they in the same unit?")
    direction = list(args.direction) if args.direction else None
    point = list(args.point) if args.point else None
    field = None
    if args.field:
        try:
            field = np.loadtxt(args.field, delimiter=",", ndmin=2)
        except (ValueError, UnicodeDecodeError) as e:
            raise ValueError(f"--field {args.field}: not a CSV of numbers x,y,z ({e})") from None
        if field.ndim != 2 or field.shape[1] != 3 or not np.isfinite(field).all():
            raise ValueError(f"--field {args.field}: needs rows of 3 finite numbers x,y,z, got shape {field.shape}"
                             + ("" if np.isfinite(field).all() else " with NaN/inf"))
        if len(field) not in (len(V), len(F)):
            raise ValueError(f"--field {args.field} has {len(field)} rows; the mesh has {len(V)} vertices and "
                             f"{len(F)} faces")
    weights = list(args.weights) if args.weights else None
    free = tuple(x.strip() for x in args.optimize_tool.split(",") if x.strip())
    if args.spacing is not None and not math.isfinite(args.spacing):
        raise ValueError(f"--spacing {args.spacing} is not a finite number")
    plan = plan_freeform(V, F, direction=direction, point=point, field_vectors=field, r1=args.tool_r1,
                         r2=args.tool_r2, L=args.tool_length, spacing=args.spacing, weights=weights,
                         n_ruling_samples=args.samples, n_columns=args.columns, engagement=args.engagement,
                         optimize_tool=free, max_nfev=args.max_evaluations, slide=args.slide,
                         shank_radius=args.shank_radius if args.shank_radius else None,
                         shank_length=args.shank_length or 0.0, flip_normals=args.flip_normals)
    write_plan(args.out, plan)
    s = plan["summary"]
    if args.json:
        print(json.dumps(dict(s, out=args.out, optimization={k: v for k, v in plan["optimization"].items()})))
        return 0
    print(f"{args.mesh}: {len(F)} triangles, {s['strips']} strips, {s['rulings']} rulings x {args.samples} samples")
    print(f"  error (Eq. 19) max {s['max_error']:+.4g} min {s['min_error']:+.4g} (initial {s['initial_max_error']:+.4g} "
          f"/ {s['initial_min_error']:+.4g}); {s['overhanging_samples']} of {s['samples']} samples beyond the "
          f"surface's border (not counted)")
    print(f"  kink max {s['max_kink_deg']:.3f} deg, mean {s['mean_kink_deg']:.3f} deg (initial "
          f"{s['initial_max_kink_deg']:.3f} / {s['initial_mean_kink_deg']:.3f})")
    if s.get("kink_floor_deg") is not None:
        print(f"  straight strips on this surface: within this error no plan has a max kink below "
              f"{s['kink_floor_deg']:.3f} deg; at this max kink none has an error below {s['error_bound_at_kink']:.4g}")
    lo, hi = s["axis_length_range"]
    print(f"  axis length {lo:.6g} .. {hi:.6g}; colliding rulings {s['colliding_rulings']}; "
          f"time {s['elapsed_s']:.2f} s; wrote {args.out}")
    from .methods.freeform_g1.planner import axis_length_histogram
    h = axis_length_histogram(plan)
    print("  axis lengths (Fig. 11), bin from: initial / optimised rulings")
    for e, a, b in zip(h["edges"], h["initial"], h["optimised"]):
        print(f"    {e:12.6g}  {a:5d} / {b:5d}")
    return 0


def _single_flank_tools(args, unit):
    """[(name, ConeTool), ...] and the selection ('order' | 'auto') of --tools, or of the --tool-* cone."""
    from .tooling.cone import ConeTool

    cone_opts = ("tool_r1", "tool_r2", "tool_alpha", "tool_h")
    if args.tools is not None:
        given = [o for o in cone_opts + ("shank_radius", "shank_length") if getattr(args, o) not in (None, 0.0)]
        if given:
            raise ValueError(f"--tools takes the cones from the presets: drop --{given[0].replace('_', '-')}")
        from .tooling.presets import load_presets, presets_by_name

        if unit == "R":
            mm = args.outer_radius_mm if args.outer_radius_mm is not None else SUGGEST_DEFAULT_R_MM
            if not (math.isfinite(mm) and mm > 0):
                raise ValueError(f"--outer-radius-mm {mm} must be a finite number > 0")
        else:
            if args.outer_radius_mm is not None:
                raise ValueError("--outer-radius-mm applies to --builtin only (a mesh is read in mm)")
            mm = 1.0
        text = args.tools.strip()
        presets = load_presets() if text.lower() == "auto" else presets_by_name(text)
        return [(p.name, p.tool(mm)) for p in presets], ("auto" if text.lower() == "auto" else "order"), mm
    if args.outer_radius_mm is not None:
        raise ValueError("--outer-radius-mm applies to --tools (the presets are in mm)")
    if args.max_tools is not None:
        raise ValueError("--max-tools applies to --tools auto")
    if args.tool_r1 is None or args.tool_r2 is None:
        raise ValueError("single-flank needs --tools auto|NAME,... or --tool-r1 and --tool-r2 (radii of the cone's "
                         "tip and top circles)")
    if (args.tool_alpha is None) == (args.tool_h is None):
        raise ValueError("give exactly one of --tool-alpha RAD or --tool-h H")
    shank = dict(shank_radius=args.shank_radius or 0.0, shank_length=args.shank_length or 0.0)
    if args.tool_alpha is not None:
        tool = ConeTool(args.tool_alpha, args.tool_r1, args.tool_r2, **shank)
    else:
        tool = ConeTool.from_length(args.tool_r1, args.tool_r2, args.tool_h, **shank)
    return [(None, tool)], "order", None


def _cmd_plan_single_flank(args):
    """Bizzarri, Bo & Bartoň: multi-strip single-flank milling of one flank with given cones, to a tolerance."""
    import json
    import math

    from .methods.single_flank.planner import flank_of_point, plan_single_flank
    from .io.plan import write_plan

    if (args.flank is None) == (args.flank_point is None):
        raise ValueError("give exactly one of --flank K or --flank-point X,Y,Z")
    if args.tolerance is None:
        raise ValueError("single-flank needs --tolerance EPS (largest material left, in the rotor's unit)")
    for name in ("tool_r1", "tool_r2", "tool_alpha", "tool_h", "shank_radius", "shank_length", "tolerance",
                 "outer_radius_mm"):
        v = getattr(args, name)
        if v is not None and not math.isfinite(v):
            raise ValueError(f"--{name.replace('_', '-')} {v} is not a finite number")
    if args.max_tools is not None and args.tools is None:
        raise ValueError("--max-tools applies to --tools auto")
    unit_guess = "R" if args.builtin else "mm"
    tools, select, mm = _single_flank_tools(args, unit_guess)
    if select == "order" and args.max_tools is not None:
        raise ValueError("--max-tools applies to --tools auto")
    surface, flanks, to_world, unit, src = _load_rotor(args)
    for _, tool in tools:
        size = max(tool.h + tool.shank_length, tool.r2c, tool.shank_radius)
        if size > MAX_TOOL_SCALE * surface.outer_radius:
            raise ValueError(f"the tool ({size:.6g} long or wide) is over {MAX_TOOL_SCALE:g} times the rotor's "
                             f"outer radius {surface.outer_radius:.6g}: are they in the same unit?")
    if args.flank is not None:
        if not 0 <= args.flank < len(flanks):
            raise ValueError(f"--flank {args.flank} is outside 0..{len(flanks) - 1} (this rotor has "
                             f"{len(flanks)} flanks)")
        k = args.flank
    else:
        k = flank_of_point(surface, flanks, _picked_point(surface, args.flank_point, to_world, "--flank-point", unit))
    targets = None
    if args.split is not None:
        from .methods.single_flank.planner import curvature_parts

        parts = curvature_parts(surface, flanks[k])
        targets = parts[args.split]
        if not targets:
            raise ValueError(f"--split {args.split}: flank {k} has no {args.split} part (all of it is "
                             f"{'hyperbolic' if parts['hyperbolic'] else 'elliptic'})")
    names = [nm for nm, _ in tools] if args.tools is not None else None
    res = plan_single_flank(surface, flanks, k, tools if names else tools[0][1], args.tolerance,
                            overcut_tolerance=args.overcut_tolerance, n_seeds=args.seeds, objective=args.objective,
                            mode=args.mode, max_rounds=args.rounds, to_world=to_world, length_unit=unit,
                            check_collisions=not args.no_collisions, g1=args.g1,
                            g1_extra_strips=args.g1_extra_strips, targets=targets, tool_names=names,
                            select=select, max_tools=args.max_tools,
                            bound_radius=min(t.r1s for _, t in tools) if names else None,
                            split=args.split)
    if not res.strips:                  # nothing to write: say why, and leave any earlier file as it was
        R = surface.outer_radius
        small = min(t.r1c for _, t in tools)
        hint = (f"; the tool's smallest radius {small:g} exceeds the rotor's outer radius {R:g} {unit}: are the tool's "
                "dimensions in the rotor's unit?" if small > R else "")
        raise ValueError(res.no_strip_message(k) + hint)
    if mm is not None:
        res.plan["summary"]["tools_mm_per_unit"] = mm
    write_plan(args.out, _with_extent(res.plan, args))
    if args.profile_csv:
        u, dev = res.deviation
        atomic_write(args.profile_csv, "u,deviation\n" + "".join(f"{a:.9g},{b:.9g}\n" for a, b in zip(u, dev)))
    v = res.verify
    summ = res.plan["summary"]
    tool0 = res.plan["tool"]
    summary = {
        "flank": k, "strips": len(res.strips), "candidates": len(res.candidates),
        "collisions_excluded": len(res.collisions), "uncovered_ranges": [list(g) for g in res.uncovered],
        "covered_fraction": res.covered_fraction, "uncovered": summ.get("uncovered", []),
        "max_error": v["max_undercut"], "min_error": v["max_overcut"], "gouge_points": len(v["gouge_points"]),
        "junction_kinks_deg": [[j["kink_deg"] for j in js] for js in res.junctions],
        "g1": summ.get("g1"), "split": summ.get("split"),
        "timings_s": res.timings, "tool": tool0, "length_unit": unit,
        "tools": summ.get("tools"), "tool_selection": summ.get("tool_selection"),
        "per_strip": [{"max_error": st["reported_max_error"], "min_error": st["reported_min_error"],
                       "collision": st["collision"], "tool": st.get("tool", tool0).get("name")}
                      for st in res.plan["strips"]],
    }
    if args.json:
        print(json.dumps(summary, indent=1))
        return 0
    if names:
        print(f"{src}: flank {k}, {res.plan['method']}, tools {'auto' if select == 'auto' else 'as named'} "
              f"({len(tools)} in the list); tolerance {args.tolerance:g} {unit}")
        for row in res.tools:
            print(f"  {row['name']}: {row['strips']} strip(s) of {row['candidates']} candidates, {row['seeds']} seeds "
                  f"({row['collisions_excluded']} excluded by collisions)")
    else:
        tool = tools[0][1]
        print(f"{src}: flank {k}, {res.plan['method']}, cone alpha {tool.alpha:.5f} rad, r1 {tool.r1c:g}, "
              f"r2 {tool.r2c:g}, h {tool.h:.5g} {unit}; tolerance {args.tolerance:g}")
        print(f"  {len(res.strips)} strip(s) chosen of {len(res.candidates)} candidates "
              f"({len(res.collisions)} excluded by collisions), {len(res.rounds)} round(s)")
    for j, st in enumerate(res.plan["strips"]):
        tn = f"  [{st['tool']['name']}]" if st.get("tool") else ""
        print(f"  strip {j}: max {st['reported_max_error']:.4g}  min {st['reported_min_error']:.3g}{tn}")
    kinks = [j["kink_deg"] for js in res.junctions for j in js]
    if kinks:
        print(f"  junction kinks: {min(kinks):.2f}..{max(kinks):.2f} deg")
    g1 = summ.get("g1")
    if g1 is not None:
        sel = g1.get("selection")
        if sel is not None and "strips_after" in sel:
            print(f"  G1 smooth cover {'kept' if sel['kept'] else 'not kept'}: {sel['strips_before']} -> "
                  f"{sel['strips_after']} strips, largest kink {sel['max_kink_before_deg']:.2f} -> "
                  f"{sel['max_kink_after_deg']:.2f} deg")
        print(f"  G1 refinement {'kept' if g1['accepted'] else 'not kept'}: rms kink "
              f"{g1['rms_kink_before_deg']:.2f} -> {g1['rms_kink_after_deg']:.2f} deg")
    print(f"  machined flank (verify): max {v['max_undercut']:.4g}, min {v['max_overcut']:.3g}, "
          f"gouges {len(v['gouge_points'])}; {100 * res.covered_fraction:.2f} % of the flank's arc length within "
          f"the tolerance")
    for ru in summ.get("uncovered", []):
        a, b = ru["u_range"]
        s0, s1 = ru["arc_range"]
        print(f"  NOT covered: u in [{a:.5g}, {b:.5g}] (arc {s0:.4g}..{s1:.4g} {unit}, {ru['kind']}): {ru['reason']}")
    print(f"  time {res.timings['total']:.2f} s; wrote {args.out}")
    return 0


SUGGEST_DEFAULT_R_MM = 50.0


def _cmd_suggest_tool(args):
    """Bizzarri, Bo & Bartoň §4: Dupin analysis of one flank, Eqs. (18)-(21) and the largest admissible catalogue tool."""
    from .methods.double_flank.planner import custom_tool_bounds
    from .tooling import catalogue as cat
    from .tooling import cutter_selection as cs

    if (args.mesh is None) == (args.builtin is None):
        raise ValueError("give exactly one of --mesh PATH or --builtin NAME")
    if args.builtin:
        from .geometry.rotors import builtin_by_name

        rotor = builtin_by_name(args.builtin)
        surface, flanks, src, unit = rotor.surface(), rotor.flanks, args.builtin, "R"
        r_mm = args.outer_radius_mm
        if not (np.isfinite(r_mm) and r_mm > 0):
            raise ValueError(f"--outer-radius-mm {r_mm} must be a finite number > 0")
        catalogue = cat.catalogue_tools(r_mm)
    else:
        if args.outer_radius_mm != SUGGEST_DEFAULT_R_MM:
            raise ValueError("--outer-radius-mm applies to --builtin only (a mesh is read in mm)")
        from .io.mesh_files import read_mesh
        from .geometry.rotor_analysis import analyze_mesh

        a = analyze_mesh(*read_mesh(args.mesh))
        surface, flanks = a.surface, a.flank_ranges()
        src, unit, r_mm = str(args.mesh), "mm", 1.0
        catalogue = cat.catalogue_tools()
    if not 0 <= args.flank < len(flanks):
        raise ValueError(f"--flank {args.flank} is outside 0..{len(flanks) - 1} (this rotor has {len(flanks)} flanks)")
    t0 = time.perf_counter()
    bounds = custom_tool_bounds(surface, flanks, args.flank // 2)
    dup, bounds, region, sug = cs.select_cutter(surface, flanks, args.flank, catalogue, bounds, n=args.samples)
    dt = time.perf_counter() - t0
    d = {"source": src, "unit": unit, "unit_mm": r_mm, "flank": args.flank, "valley": args.flank // 2,
         "dupin": dup.summary(), "bounds": bounds.as_dict(),
         "region": None if region is None else region.summary(),
         "suggested": None if sug.index is None else {"name": sug.entry.name, "tool": sug.tool.as_dict(),
                                                      "tool_mm": cat.scale_tool(sug.tool, r_mm).as_dict()},
         "catalogue": [{"name": e.name, "ok": r.ok, "failures": [f.message for f in r.failures]}
                       for e, r in zip(catalogue, sug.results)],
         "elapsed_s": dt}
    if args.json:
        print(json.dumps(d, indent=1))
        return 0
    s = d["dupin"]
    print(f"{src}: flank {args.flank} (valley {args.flank // 2}), lengths in {unit}"
          + (f" (R = {r_mm:g} mm)" if unit == "R" else ""))
    a_txt = ("no hyperbolic point" if s["a_min"] is None else
             f"a in [{s['a_min']:.5g}, {s['a_max']:.5g}] sqrt({unit}), a_min^2 = {s['rho_min']:.5g} {unit}")
    print(f"  Dupin ({s['samples']} samples): hyperbolic {100 * s['hyperbolic_fraction']:.1f} %, elliptic "
          f"{100 * s['elliptic_fraction']:.1f} %; {a_txt}")
    print(f"  custom tool bounds: D_min {bounds.d_min:.5g}, D_max {bounds.d_max:.5g}, D_depth {bounds.d_depth:.5g}"
          f" (c = {bounds.c:g}, D_angle = {bounds.d_angle:.4g} rad)")
    rg = None if region is None else region.ranges()
    if rg is None:
        print("  admissible region: empty")
    else:
        print(f"  admissible region ({100 * region.fraction:.1f} % of the sampled cones): alpha "
              f"[{rg['alpha'][0]:.4g}, {rg['alpha'][1]:.4g}] rad, r1c [{rg['r1c'][0]:.4g}, {rg['r1c'][1]:.4g}], "
              f"r2c [{rg['r2c'][0]:.4g}, {rg['r2c'][1]:.4g}]")
    n_ok = len(sug.admissible)
    if sug.index is None:
        big = max(range(len(catalogue)), key=lambda i: cs.tool_size_key(catalogue[i].tool))
        print(f"  suggested: none of the {len(catalogue)} catalogue tools is admissible; largest "
              f"({catalogue[big].name}) {sug.results[big].message}")
    else:
        t = cat.scale_tool(sug.tool, r_mm)
        print(f"  suggested: {sug.entry.name} (alpha {np.degrees(t.alpha):.2f} deg, r1c {t.r1c:.3f} mm, "
              f"r2c {t.r2c:.3f} mm, h {t.h:.2f} mm); {n_ok} of {len(catalogue)} catalogue tools admissible")
    print(f"  time {dt:.2f} s")
    return 0


def _cmd_builtins(args):
    from .geometry.rotors import BUILTIN_NAMES

    print("\n".join(BUILTIN_NAMES))
    return 0


# the most steps along the z range a strip mesh is made of
MAX_MESH_STEPS = 2000


def _cmd_export(args):
    from . import exports
    from .io.plan import read_plan

    plan = read_plan(args.plan)
    z_range = args.z_range
    # options that would change nothing are refused, not ignored
    given = [name for name, v in (("--strip", args.strip), ("--steps", args.steps), ("--z-range", args.z_range))
             if v is not None]
    if args.error_csv and given:
        raise ValueError(f"{', '.join(given)} {'applies' if len(given) == 1 else 'apply'} to --cl and the strip "
                         "meshes: --error-csv writes the verified deviation of the whole plan's target profile")
    if plan.get("surface") is not None and args.steps is not None:
        raise ValueError("--steps applies to rotor plans: a free-form plan's CL data and strip meshes follow its "
                         "own rulings")
    steps = 360 if args.steps is None else args.steps
    if (args.strips_stl or args.strips_ply) and steps > MAX_MESH_STEPS:
        raise ValueError(f"--steps {steps} is over {MAX_MESH_STEPS} for strip meshes (each step is a row of the "
                         "envelope's triangles)")
    if args.strip is not None:
        exports.strip_tip(plan, args.strip)          # names a missing strip before any work
    t0 = time.perf_counter()
    if args.cl:
        text = exports.cl_data(plan, strip=args.strip, steps=steps, z_range=z_range)
        atomic_write(args.cl, text)
        n = text.count("\nGOTO/")
        what = f"CL data, {n} GOTO steps, to {args.cl}"
    elif args.error_csv:
        text = exports.error_profile_csv(plan)
        atomic_write(args.error_csv, text)
        what = f"error profile, {text.count(chr(10)) - 1} points, to {args.error_csv}"
    else:
        fmt, prefix = ("stl", args.strips_stl) if args.strips_stl else ("ply", args.strips_ply)
        paths = exports.write_strip_meshes(plan, prefix, fmt, strip=args.strip, z_range=z_range,
                                           n_t=steps + 1)
        what = f"{len(paths)} strip envelope(s): {', '.join(paths)}"
    print(f"wrote {what} in {time.perf_counter() - t0:.2f} s")
    return 0


def positive_number(text):
    """argparse type of a length, speed or feed: a finite number > 0."""
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"{text} is not a finite number > 0")
    return v


# the largest outer radius a rotor given in mm may have: 100 m (larger is a unit slip, and scaled plans overflow)
MAX_OUTER_RADIUS_MM = 1e5


def outer_radius_mm(text):
    """argparse type of --outer-radius-mm: a finite number > 0 and at most MAX_OUTER_RADIUS_MM."""
    v = positive_number(text)
    if v > MAX_OUTER_RADIUS_MM:
        raise argparse.ArgumentTypeError(f"{text} mm is over {MAX_OUTER_RADIUS_MM:g} mm: no rotor is that large "
                                         "(is it in micrometres?)")
    return v


def count_at_least(least, most=None):
    """argparse type of a count: a whole number >= ``least`` (and <= ``most``)."""
    def count(text):
        try:
            n = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text} is not a whole number") from None
        if n < least and most is None:
            raise argparse.ArgumentTypeError(f"{n} is below the minimum {least}")
        if n < least or (most is not None and n > most):
            raise argparse.ArgumentTypeError(f"{n} is outside the limits {least}..{most}")
        return n
    count.__name__ = "count"
    return count


# ---------------------------------------------------------------------------------------------- machining
def holder_spec(text):
    """argparse type of --holder: SIDE,DIAMETER,LENGTH[,GAP] (:func:`machining.rotor_body.parse_holder`)."""
    from .machining.rotor_body import check_holder, parse_holder

    try:
        return check_holder(parse_holder(text))
    except ValueError as ex:
        raise argparse.ArgumentTypeError(str(ex)) from None


def lobe_list(text):
    """argparse type of --lobes: 'all' or comma-separated lobe indices."""
    if str(text).strip().lower() == "all":
        return None
    try:
        vals = [int(x) for x in str(text).split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} must be 'all' or lobe indices like 0,2,4") from None
    if any(v < 0 for v in vals):
        raise argparse.ArgumentTypeError(f"{text!r}: lobe indices are >= 0")
    return vals


def _machining_inputs(args):
    """(plans in mm, rotor body) of --plans, --outer-radius-mm, --mesh and --holder."""
    from .io.plan import read_plan
    from .machining.rotor_body import extent_from_analysis, rotor_body, scale_plan, with_holders

    plans = []
    for path in args.plans:
        plan = read_plan(path)
        if plan.get("surface") is not None:
            raise ValueError(f"{path} is a free-form plan: whole-rotor programs are made from rotor plans")
        if plan["length_unit"] == "R":
            if args.outer_radius_mm is None:
                raise ValueError(f"{path} is in units of the outer radius R: pass --outer-radius-mm MM")
            plan = scale_plan(plan, args.outer_radius_mm / plan["rotor"]["outer_radius"])
        elif args.outer_radius_mm is not None:
            raise ValueError(f"--outer-radius-mm applies to plans in units of R; {path} is in mm")
        for k, earlier in enumerate(plans):
            if plan == earlier:
                raise ValueError(f"{path} is the same plan as {args.plans[k]}: given twice, every strip would be "
                                 "cut twice")
        plans.append(plan)
    extent = None
    if args.mesh:
        from .geometry.rotor_analysis import analyze_mesh
        from .io.mesh_files import read_mesh

        extent = extent_from_analysis(plans[0], analyze_mesh(*read_mesh(args.mesh)))
    return plans, with_holders(rotor_body(plans[0], extent), args.holder)


def _cutting_data(args):
    """The cutting data of --cutting-data / --flutes / --vc / --fz / --max-rpm: None (each tool's own), one
    CuttingData for every tool (--cutting-data), or each tool's own data, or --cutting-data's, with the fields
    given replaced (:func:`machining.feeds.with_overrides`: a disc cutter keeps its top speed under --fz)."""
    from .machining.feeds import preset_cutting_data, with_overrides

    base = preset_cutting_data(args.cutting_data) if args.cutting_data else None
    over = {k: v for k, v in (("flutes", args.flutes), ("vc_m_min", args.vc), ("fz_mm", args.fz),
                              ("max_rpm", args.max_rpm)) if v is not None}
    return with_overrides(over, base) if over else base


def _cmd_post(args):
    from .machining.operation import build_operation
    from .machining.toolpath import build_program
    from .machining.cycle_time import cycle_time, untimed_note
    from .posts import atomic_write, get_post

    t0 = time.perf_counter()
    post = get_post(args.post)
    machine = _machine(args)
    plans, rotor = _machining_inputs(args)
    op = build_operation(plans, rotor, lobes=args.lobes, clearance=args.clearance, cutting_data=_cutting_data(args))
    coolant = args.coolant or "flood"
    prog = build_program(op, machine, direction=args.direction, chord_tolerance=args.chord_tolerance,
                         coolant=coolant)
    text = post.write(prog)
    read = post.read(text, machine)         # the post's own reading first: a program it cannot read is not written
    atomic_write(args.out, text)
    times = cycle_time(read, machine, {t.number: t.gauge_length for t in op.tools})
    times.pop("block_minutes")
    out = {"out": str(args.out), "post": post.name, "machine": machine.name, "passes": len(prog.passes),
           "blocks": len(read.moves), "lines": text.count("\n"), "lobes": op.lobes,
           "coolant": coolant, **times,
           "cutting_length_mm": sum(p["cutting_length_mm"] for p in prog.passes),
           "tools": [{"number": t.number, "name": t.name, "rpm": t.rpm, "gauge_length_mm": t.gauge_length,
                      "shape": t.shape.describe(), "cutting_data": t.data.as_dict()} for t in op.tools],
           "rotor": rotor.describe(), "per_pass": prog.passes, "elapsed_s": time.perf_counter() - t0}
    if args.json:
        print(json.dumps(out, indent=1))
        return 0
    print(f"wrote {args.out}: {post.name} for {machine.name}, {len(prog.passes)} passes on lobes "
          f"{','.join(map(str, op.lobes))}, {len(op.tools)} tool(s), {len(read.moves)} moves")
    for t in op.tools:
        mine = [p for p in prog.passes if p["tool"] == t.number]
        chip = [x for p in mine for x in p["chip_load_mm"]]
        vc = [x for p in mine for x in p["surface_speed_m_min"]]
        print(f"  T{t.number}: S{t.rpm:.0f}, vc {min(vc):.4g}..{max(vc):.4g} m/min along the edge, chip load "
              f"{min(chip):.3g}..{max(chip):.3g} mm ({t.data.source})")
    print(f"  cutting {out['cutting_time_s']:.1f} s ({out['cutting_length_mm']:.0f} mm), rapid "
          f"{out['rapid_time_s']:.1f} s, tool changes {out['tool_change_time_s']:.0f} s, total "
          f"{out['total_time_s']:.1f} s{untimed_note(out['untimed_moves'], machine, out['untimed_returns'])}; "
          f"{out['elapsed_s']:.2f} s")
    return 0


def _cmd_verify_program(args):
    from .machining.cycle_time import untimed_note
    from .posts import get_post, post_for_file
    from .posts.readback import empty_program, verify_program

    if args.machine is None:
        raise ValueError("verify --program needs --machine NAME|FILE (the machine it was posted for)")
    if args.tolerance is not None:
        raise ValueError(f"--tolerance {args.tolerance:g} applies to verify without --program (the read-back "
                         "compares the program with its plans' own deviation)")
    post = get_post(args.post) if args.post else post_for_file(args.program)
    if post is None:
        raise ValueError(f"cannot tell the dialect of {args.program} from its extension: pass --post")
    machine = _machine(args)
    plans, rotor = _machining_inputs(args)
    with open(args.program, encoding="ascii", errors="replace") as fh:
        text = fh.read()
    empty = empty_program(text, args.program)
    if empty:
        raise ValueError(empty)
    res = verify_program(text, post, machine, plans, rotor, lobes=args.lobes, cutting_data=_cutting_data(args),
                         coolant=args.coolant or "flood")
    res["program"] = str(args.program)
    status = 1 if res["findings"] else 0        # the program does not do what its plans say: a script must see it
    if args.json:
        print(json.dumps(res, indent=1))
        return status
    print(f"{args.program}: {post.name} for {machine.name}, {res['moves']} moves, {res['passes']} passes "
          f"({res['matched_passes']} matched to plan strips), lobes {','.join(map(str, res['lobes_cut']))}")
    if res["missing_strips"] or res["repeated_strips"] or res["unmatched_passes"]:
        def some(items):
            return str(items[:10])[:-1] + (f", ... ({len(items)})]" if len(items) > 10 else "]")
        print(f"  missing strips {some(res['missing_strips'])}, repeated {some(res['repeated_strips'])}, unmatched "
              f"passes {some([u['line'] for u in res['unmatched_passes']])}")
    sp = res["spindle"]
    if sp["max_rpm"] is not None:
        bad = len({ln for k in ("stopped", "counter_clockwise", "no_speed", "over_top_speed") for ln in sp[k]})
        speeds = f"S{sp['min_rpm']:g}" + ("" if sp["min_rpm"] == sp["max_rpm"] else f"..S{sp['max_rpm']:g}")
        lc, cool = res["length_compensation"], res["coolant"]
        coolant = (("; dry on every one" if not cool["on"] else f"; {len(cool['on'])} with coolant, posted dry")
                   if cool["expected"] == "off" else
                   "; coolant on every one" if not cool["off"] else f"; {len(cool['off'])} without coolant")
        print(f"  spindle on the cuts: {speeds} (machine top {sp['machine_max_rpm']:g}), "
              + ("clockwise within its speeds on every one" if not bad else f"{bad} not turning clockwise within "
                                                                             "its speeds")
              + coolant
              + "; tool length compensation " + ("of its tool on every move" if not (lc["without"] or lc["other_tool"])
                                                 else f"missing on {len(lc['without'])} move(s), another tool's on "
                                                      f"{len(lc['other_tool'])}"))
    for t in res["cutting"]["tools"]:
        d = t["cutting_data"]
        over = [k for k, n in t["moves_over"].items() if n]
        bare = t["moves_without_speed"]
        verdict = ("OVER " + ", ".join(k[5:].replace("_", " ") for k in over) if over else
                   "within its cutting data" + (" where it has a speed" if bare else "")
                   + (" where judged" if t["moves_chip_load_not_judged"] else ""))
        print(f"  T{t['tool']} cuts at chip loads up to {t['max_chip_load_mm']:.4g} mm (fz {d['fz_mm']:g}), "
              f"{t['max_surface_speed_m_min']:.4g} m/min (vc {d['vc_m_min']:g}), S{t['max_rpm']:g} (top "
              f"{d['max_rpm']:g}; {d['source']}): " + verdict
              + (f"; {bare} feed move(s) without a spindle speed not checked" if bare else "")
              + (f"; chip load not judged on {t['moves_chip_load_not_judged']} feed move(s) off the rotor's screw"
                 if t["moves_chip_load_not_judged"] else ""))
    print(f"  poses: screw error {res['screw_error_mm']:.3g} mm, interpolation error "
          f"{res['interpolation_error_mm']:.3g} mm")
    for pl in res["plans"]:
        print(f"  plan {pl['plan']}: plan deviation max {pl['plan_max_undercut_mm']:.4g} min "
              f"{pl['plan_max_overcut_mm']:.4g} mm")
        for lo in pl["lobes"]:
            extra = f" ({lo['unmatched_passes']} matching no strip)" if lo.get("unmatched_passes") else ""
            print(f"    lobe {lo['lobe']}: {lo['passes']} passes{extra}, deviation differs by at most "
                  f"{lo['max_deviation_difference_mm']:.3g} mm (tool poses by {lo['pose_difference_mm']:.3g} mm; "
                  f"{lo['rechecked_points']} point(s) swept again finer), gouge points {lo['gouge_points']}")
    ro = res["run_out"]
    run_out = ("no pass" if ro["min_start_clearance_mm"] is None else
               f"start >= {ro['min_start_clearance_mm']:.3g} mm, end >= {ro['min_end_clearance_mm']:.3g} mm")
    print(f"  run-out beyond the end faces: {run_out}; links: {res['links']['moves_checked']} checked"
          + (f" ({res['links']['moves_unchecked']} out of a tool change from an unknown position not)"
             if res['links']['moves_unchecked'] else "")
          + f", deepest intrusion into the stock{', shafts or holders' if res['holders'] else ' or shafts'} "
            f"{res['links']['max_intrusion_mm']:.3g} mm")
    margin = ro["min_keep_out_margin_mm"]
    if margin is not None:
        print(f"  passes over shafts{' or holders' if res['holders'] else ''}: the tool "
              + (f"stays {margin:.3g} mm from them" if margin >= 0 else f"enters them by {-margin:.3g} mm"))
    print(f"  cutting {res['cutting_time_s']:.1f} s, rapid {res['rapid_time_s']:.1f} s, total "
          f"{res['total_time_s']:.1f} s{untimed_note(res['untimed_moves'], machine, res['untimed_returns'])}")
    for f in res["findings"]:
        print(f"  NOT AS PLANNED: {f}")
    return status


def _machine(args):
    from .machining.machine import load_machine

    m = load_machine(args.machine)
    return m.flipped() if args.flip_rotor else m


def _cmd_machines(args):
    from .machining.machine import builtin_machines, load_machine
    from .posts import POSTS

    for name in builtin_machines():
        m = load_machine(name)
        print(f"{name}: {' '.join(m.axis_names)}, spin {m.spin}, tilt {m.tilt}, "
              f"{'TCP' if m.tcp else 'no TCP'} -- {m.description}")
    print("posts: " + ", ".join(f"{p.name} ({p.description})" for p in POSTS.values()))
    return 0


def _add_machining_inputs(p):
    p.add_argument("--mesh", help="the rotor mesh the plans were made on: its axial extent and shafts (for plans "
                                  "that do not record rotor.extent)")
    p.add_argument("--outer-radius-mm", type=outer_radius_mm,
                   help="plans in units of R: the rotor's outer radius in mm")
    p.add_argument("--lobes", type=lobe_list, help="post: lobes to cut, all (default) or indices like 0,2,4; "
                                                    "verify --program: lobes to check, every strip due on each (default: "
                                                    "the lobes the program cuts)")
    p.add_argument("--flip-rotor", action="store_true",
                   help="the rotor is mounted the other way round (turned 180 deg about its x axis) on the machine")
    p.add_argument("--holder", type=holder_spec, action="append", default=[], metavar="SIDE,DIAMETER,LENGTH[,GAP]",
                   help="a chuck, collet or tailstock holding the rotor (repeatable; mm): a cylinder of DIAMETER "
                        "and LENGTH beyond the body's end face at SIDE (low or high: the end at the smaller or "
                        "larger rotor-frame z), GAP (default 0) away from it. No move may enter it")


def _add_cutting_data(p, note=""):
    from .machining.toolpath import COOLANTS

    p.add_argument("--cutting-data", metavar="PRESET", help="cutting data of a tool preset for every tool "
                                                             "(default: the preset matching each plan's tool)" + note)
    p.add_argument("--coolant", choices=COOLANTS,
                   help="coolant turned on with every tool: flood (M8; Klartext M13), mist (M7; G-code posts) or "
                        "off (a dry cut) (default flood)")
    p.add_argument("--flutes", type=count_at_least(1), help="override: flutes (of each tool's own data, or of --cutting-data)")
    p.add_argument("--vc", type=positive_number, help="override: cutting speed, m/min (of each tool's own data, or of --cutting-data)")
    p.add_argument("--fz", type=positive_number, help="override: feed per tooth, mm (of each tool's own data, or of --cutting-data)")
    p.add_argument("--max-rpm", type=positive_number, help="override: the tool's top spindle speed (of each tool's own data, or of --cutting-data)")


def report_scene():
    """The extension's report scene builder (``operators/report_scene.py``), which runs Blender.

    Inside Blender the planner is a subpackage of the installed extension and the builder is its sibling.
    From a source tree the tree's root is made the package ``flank_toolpath`` without running its
    ``__init__`` (which only registers classes), so that the builder's relative imports resolve."""
    import importlib
    import importlib.util
    import os

    parent = (__package__ or "").rpartition(".")[0]
    if not parent:
        parent = "flank_toolpath"
        if parent not in sys.modules:
            root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
            spec = importlib.util.spec_from_file_location(parent, os.path.join(root, "__init__.py"),
                                                          submodule_search_locations=[root])
            sys.modules[parent] = importlib.util.module_from_spec(spec)
    try:
        return importlib.import_module(parent + ".operators.report_scene")
    except ImportError as ex:
        raise ValueError(f"render needs Blender as a Python module ({ex}); the virtualenv that `make demo` "
                         "creates has it") from None


def _cmd_render(args):
    import os

    from .io.plan import read_plan

    plan = read_plan(args.plan)
    scene = report_scene()
    w, h = args.resolution
    try:
        if plan.get("surface") is not None:
            from .report.freeform_geometry import freeform_title
            info = scene.render_freeform_report(plan, args.out, width=w, height=h, tolerance=args.tolerance,
                                                engine=args.engine,
                                                title=freeform_title(plan, os.path.basename(args.plan)))
        else:
            info = scene.render_plan_report(plan, args.out, width=w, height=h, tolerance=args.tolerance,
                                            engine=args.engine, title="{}: {}".format(os.path.basename(args.plan),
                                                                                      plan.get("method", "")))
    except RuntimeError as ex:          # Blender's own failures: one line, no traceback
        raise ValueError(f"rendering failed: {ex}") from None
    if args.json:
        print(json.dumps(info, ensure_ascii=False, indent=1))
    else:
        print(f"wrote {args.out} ({w} x {h}, {info['engine'].lower()}) in {info['seconds']:.2f} s: "
              f"{info['title'][1]}")
    return 0


def build_parser():
    p = _Parser(prog="python -m flank_addon",
                                description="5-axis flank-milling planner for screw rotors and free-form surfaces: single-flank conical, "
                                            "double-flank custom tool, paraboloid groove, formed disc cutter and free-form G1 "
                                            "(references: docs/references.md)")
    sub = p.add_subparsers(dest="command", required=True)

    r = sub.add_parser("rotor", help="write a built-in rotor (or a rotor from a CSV profile) as a mesh")
    r.add_argument("--kind", choices=["nilson", "srm_a", "asymmetric"])
    r.add_argument("--part", choices=["male", "female"])
    r.add_argument("--profile-csv", help="transverse profile as x,y rows instead of a built-in")
    r.add_argument("--scale", type=float, default=1.0, help="outer radius (built-ins) or CSV unit factor")
    r.add_argument("--lead", type=float, help="axial advance per turn (default: 300 deg wrap)")
    r.add_argument("--length", type=float, help="rotor length")
    r.add_argument("--handedness", choices=["right", "left"])
    r.add_argument("--resolution", type=count_at_least(8, MAX_PROFILE_POINTS),
                   help=f"points around the profile (default 2048, at most {MAX_PROFILE_POINTS})")
    r.add_argument("--axial", type=count_at_least(1, 20000), default=120,
                   help="rings along the axis (default 120, at most 20000)")
    r.add_argument("--out", required=True, help="PATH.stl | PATH.ply | PATH.obj")
    r.set_defaults(func=_cmd_rotor)

    a = sub.add_parser("analyze", help="helical axis, v0, handedness, profile and flanks of a rotor mesh")
    a.add_argument("path", help="STL, PLY or OBJ mesh in any placement and unit")
    a.add_argument("--json", action="store_true", help="print JSON (includes the profile)")
    a.add_argument("--profile-out", help="write the transverse profile as x,y CSV")
    a.add_argument("--profile-points", type=int, default=2048, help="resampled profile points (>= 720)")
    a.set_defaults(func=_cmd_analyze)

    c = sub.add_parser("check-plan", help="validate a flank-plan/1 file")
    c.add_argument("path")
    c.set_defaults(func=_cmd_check_plan)

    g = sub.add_parser("paraboloid", help="paraboloid groove: the section a paraboloid end mill cuts along a helix (Doğrusadık)")
    g.add_argument("--radius", type=float, required=True, help="helix radius R")
    g.add_argument("--a", type=float, required=True, help="paraboloid constant a (< 0)")
    g.add_argument("--b", type=float, required=True, help="paraboloid constant b (> 0)")
    g.add_argument("--pitch", type=float, required=True, help="helix pitch p")
    side = g.add_mutually_exclusive_group()
    side.add_argument("--internal", action="store_true", help="internal groove (bore side), default external")
    side.add_argument("--full", action="store_true", help="whole section, both sides of the tool axis")
    g.add_argument("--points", type=int, default=401, help="abscissae of the section (at least 101; default 401)")
    g.add_argument("--out", required=True, help="CSV of x,y rows (paper frame: screw axis y, plane z = 0)")
    g.set_defaults(func=_cmd_paraboloid)

    v = sub.add_parser("verify", help="simulate a plan's tool motion and report the machined deviation; with --program: "
                                      "read a posted program back and check it against its plans")
    v.add_argument("plans", nargs="+", metavar="PLAN", help="flank-plan/1 JSON (with --program: the plans it was "
                                                            "posted from, in the same order)")
    v.add_argument("--tolerance", type=float, help="in the plan's length unit (default 1e-3 x outer radius)")
    v.add_argument("--json", action="store_true")
    v.add_argument("--program", help="a program written by the post command: read it back, map it through the "
                                     "machine's kinematics and sweep it")
    v.add_argument("--machine", help="with --program: built-in machine NAME or machine FILE")
    v.add_argument("--post", help="with --program: linuxcnc | fanuc | heidenhain (default: from the extension)")
    _add_machining_inputs(v)
    _add_cutting_data(v, " (with --program: the data the program was posted with; its chip loads, cutting and "
                         "spindle speeds are checked against them)")
    v.set_defaults(func=_cmd_verify)

    k = sub.add_parser("cutter", help="formed disc cutter: the axial profile for one tooth of a rotor (Hu, Zhou & Li 2025)")
    src = k.add_mutually_exclusive_group()
    src.add_argument("--profile", help="closed transverse profile as x,y CSV rows (rotor axis at the origin)")
    src.add_argument("--builtin", help="built-in rotor NAME (see the builtins command)")
    k.add_argument("--scale", type=float, default=1.0, help="outer radius (built-ins) or CSV unit factor")
    k.add_argument("--lead", type=float, help="axial advance per turn (built-ins: their own by default)")
    k.add_argument("--handedness", choices=["right", "left"], help="default: right (CSV) or the built-in's")
    k.add_argument("--center-distance", type=float, required=True, help="A: rotor axis to cutter axis")
    k.add_argument("--swivel", type=float, required=True, help="phi: angle between the axes, degrees")
    k.add_argument("--planes", type=int, default=119, help="planes perpendicular to the cutter axis")
    k.add_argument("--eps-b", type=float, help="subdivision threshold (default 1e-4 x outer radius)")
    k.add_argument("--out", required=True, help="CSV of z,r rows (cutter frame)")
    k.add_argument("--json", action="store_true", help="print a JSON summary (flags, Z ranges, axis pose)")
    k.add_argument("--plan-out", metavar="PLAN.json",
                   help="also write the cutter as a flank-plan/1 plan (one strip: the disc on its axis while the "
                        "rotor screws), for post and verify")
    k.add_argument("--length-unit", choices=["mm", "R"],
                   help="the plan's length unit (default: R for a built-in at scale 1, else mm)")
    k.set_defaults(func=_cmd_cutter)

    pl = sub.add_parser("plan", help="plan a tool path: double-flank custom tool, single-flank conical or free-form G1 "
                                     "multi-strip")
    pl.add_argument("planner", choices=["double-flank", "single-flank", "freeform"])
    src = pl.add_mutually_exclusive_group()
    src.add_argument("--mesh", help="rotor mesh (STL, PLY, OBJ), analysed for axis, pitch and flanks")
    src.add_argument("--builtin", help="built-in rotor NAME (see the builtins command)")
    val = pl.add_mutually_exclusive_group()
    val.add_argument("--valley", type=int, help="valley index K (flanks 2K and 2K+1)")
    val.add_argument("--valley-point", metavar="X,Y,Z", type=CommaList(3, "X,Y,Z"), help="a point X,Y,Z (model frame) near the valley")
    pl.add_argument("--variant", default="min", choices=["min", "avg", "one-sided-1", "one-sided-2"])
    pl.add_argument("--tool", default="custom", help="custom | cone | cones:K")
    pl.add_argument("--two-paths", action="store_true", help="one custom tool on two axes (Bizzarri & Bartoň 2021, Section 4.3)")
    pl.add_argument("--radii", type=int, default=400, help="radii intervals per strip (default 400)")
    pl.add_argument("--rim", type=float, default=0.85, help="targeted fraction of the valley depth")
    pl.add_argument("--tool-csv", help="write the tool profile (axial position, radius) as CSV")
    pl.add_argument("--out", required=True, help="PLAN.json")
    sf = pl.add_argument_group("single-flank conical (Bizzarri, Bo & Bartoň)")
    fsel = sf.add_mutually_exclusive_group()
    fsel.add_argument("--flank", type=int, help="flank index K")
    fsel.add_argument("--flank-point", metavar="X,Y,Z", type=CommaList(3, "X,Y,Z"), help="a point X,Y,Z (model frame) near the flank")
    sf.add_argument("--tools", metavar="auto|NAME,...",
                    help="cones from the shipped tool presets instead of --tool-*: 'auto' picks the largest preset "
                         "admissible for the flank, then smaller ones for what it leaves; or preset names, tried "
                         "in that order (see docs/cli.md)")
    sf.add_argument("--outer-radius-mm", type=outer_radius_mm,
                    help="with --tools on a built-in rotor (units of R): its outer radius in mm (default 50)")
    sf.add_argument("--max-tools", type=count_at_least(1, 50), help="with --tools auto: at most this many tools (default: as needed)")
    sf.add_argument("--split", choices=["hyperbolic", "elliptic"],
                    help="plan only the hyperbolic (K < 0) or the elliptic (K >= 0) part of the flank, each with "
                         "its own initialisation (Bizzarri, Bo & Bartoň Examples 6.5, 6.6)")
    sf.add_argument("--tool-r1", type=float, help="cone: tip circle radius")
    sf.add_argument("--tool-r2", type=float, help="cone: top circle radius (> r1)")
    sf.add_argument("--tool-alpha", type=float, help="cone: opening angle (rad)")
    sf.add_argument("--tool-h", type=float, help="cone: length between the circles (instead of --tool-alpha)")
    sf.add_argument("--shank-radius", type=float)
    sf.add_argument("--shank-length", type=float)
    sf.add_argument("--tolerance", type=float, help="largest material left (rotor unit)")
    sf.add_argument("--overcut-tolerance", type=float, help="largest overcut (default 1e-6 R)")
    sf.add_argument("--seeds", type=int, help="first-round seeds along the flank (default 8; later rounds seed "
                                                 "what is still uncovered)")
    sf.add_argument("--objective", default="phi1", choices=["phi1", "phi3"])
    sf.add_argument("--mode", default="hard", choices=["hard", "weighted"],
                    help="hard: no overcut along the tool; weighted: overcut weight 100 (Remark 5.1)")
    sf.add_argument("--rounds", type=int, help="at most this many seeding rounds per tool (default 10)")
    sf.add_argument("--no-collisions", action="store_true", help="skip the global collision test")
    sf.add_argument("--g1", action="store_true",
                    help="smoother junctions: choose the smoothest cover (up to --g1-extra-strips more strips), "
                         "then re-optimise with a tangency term (each stage kept only if the kinks drop and the "
                         "tolerance still holds)")
    sf.add_argument("--g1-extra-strips", type=int, default=2,
                    help="with --g1: strips the smooth cover may add to the minimum (default 2)")
    sf.add_argument("--profile-csv", help="write the machined deviation along the flank profile (u, deviation)")
    sf.add_argument("--json", action="store_true", help="print a JSON summary")
    ff = pl.add_argument_group("free-form G1 (Rajain et al. 2023): --mesh is any triangle surface; the tool is on the side its "
                               "face normals point to; --tool-r1/--tool-r2 are the radii of the spheres "
                               "inscribed at the tip and base ends of the axis (Eq. (2)), --tool-length the "
                               "axis length L between their centres")
    ff.add_argument("--tool-length", type=float, help="freeform: axis length L")
    gd = ff.add_mutually_exclusive_group()
    gd.add_argument("--direction", metavar="X,Y,Z", type=CommaList(3, "X,Y,Z"), help="freeform: guiding direction X,Y,Z (a tangent vector at --point)")
    gd.add_argument("--field", help="freeform: CSV of one guiding vector x,y,z per mesh vertex (or face)")
    ff.add_argument("--point", metavar="X,Y,Z", type=CommaList(3, "X,Y,Z"), help="freeform: central point X,Y,Z of the direction (default: mesh centre)")
    ff.add_argument("--weights", metavar="W1,...,W5", type=CommaList(5, "w1,w2,w3,w4,w5"), help="freeform: w1,w2,w3,w4,w5 of Eq. (18): rigidity, approximation, G1, "
                                      "proximity, fairness (default 1,1,0.01,0.0001,0.001); only their ratios count, and w2 must be > 0")
    ff.add_argument("--spacing", type=float, help="freeform: guiding-curve spacing d (default sqrt(L^2 - (r2-r1)^2))")
    ff.add_argument("--samples", type=count_at_least(2, 200), default=30,
                    help="freeform: samples K per ruling (Eq. (11), default 30, at most 200)")
    ff.add_argument("--columns", type=count_at_least(2, 2000), default=20,
                    help="freeform: rulings N per strip (default 20, at most 2000)")
    ff.add_argument("--engagement", type=float, default=1.0,
                    help="freeform: cutting fraction of the tool next to its base (Fig. 18, default 1 = full)")
    ff.add_argument("--optimize-tool", default="", help="freeform: tool variables among L,r1,r2 (Rajain et al. 2023, Section 7.2)")
    ff.add_argument("--slide", action="store_true",
                    help="freeform: let the m-grid also slide along the guiding curves (the paper's 3 unknowns "
                         "per point; default: 2, normal to the curve)")
    ff.add_argument("--max-evaluations", type=count_at_least(1), default=100, help="freeform: optimiser evaluations (default 100)")
    ff.add_argument("--flip-normals", action="store_true",
                    help="freeform: the tool is on the side opposite to the mesh's face normals")
    pl.set_defaults(func=_cmd_plan)

    st = sub.add_parser("suggest-tool", help="single-flank conical: Dupin analysis of a flank and the largest admissible "
                                             "catalogue cone")
    src = st.add_mutually_exclusive_group()
    src.add_argument("--mesh", help="rotor mesh (STL, PLY, OBJ) in mm, analysed for axis, pitch and flanks")
    src.add_argument("--builtin", help="built-in rotor NAME (see the builtins command)")
    st.add_argument("--flank", type=int, required=True, help="flank index K (valley K // 2)")
    st.add_argument("--outer-radius-mm", type=outer_radius_mm, default=SUGGEST_DEFAULT_R_MM,
                    help="built-ins: outer radius in mm the catalogue is scaled to (default 50)")
    st.add_argument("--samples", type=int, default=400, help="flank profile samples (default 400)")
    st.add_argument("--json", action="store_true")
    st.set_defaults(func=_cmd_suggest_tool)

    ex = sub.add_parser("export", help="export a plan: APT CL data, error profile CSV, strip envelopes")
    ex.add_argument("plan", help="flank-plan/1 JSON")
    out = ex.add_mutually_exclusive_group(required=True)
    out.add_argument("--cl", metavar="OUT.apt", help="APT-style CL data (GOTO/x,y,z,i,j,k + rotor angle, feed)")
    out.add_argument("--error-csv", metavar="OUT.csv", help="verified deviation per target profile point")
    out.add_argument("--strips-stl", metavar="PREFIX", help="strip envelopes as PREFIX_<k>.stl")
    out.add_argument("--strips-ply", metavar="PREFIX", help="strip envelopes as PREFIX_<k>.ply")
    ex.add_argument("--strip", type=int, help="only strip K (default: all)")
    ex.add_argument("--steps", type=int, help=f"steps over the z range of a rotor plan (default 360; strip meshes: "
                                               f"at most {MAX_MESH_STEPS})")
    ex.add_argument("--z-range", metavar="Z0,Z1", type=CommaList(2, "Z0,Z1"), help="Z0,Z1 rotor-frame range of the tool tip (default 0,lead)")
    ex.set_defaults(func=_cmd_export)

    rr = sub.add_parser("render", help="render a report picture of a plan (rotor, strips by signed error, legend; "
                                       "needs Blender as a Python module)")
    rr.add_argument("plan", help="flank-plan/1 JSON")
    rr.add_argument("--out", required=True, metavar="OUT.png")
    rr.add_argument("--resolution", type=int, nargs=2, default=(1280, 800), metavar=("W", "H"))
    rr.add_argument("--tolerance", type=float, help="colour band (default: the plan's tolerance, else 1e-3 R)")
    rr.add_argument("--engine", choices=("workbench", "cycles"), default="workbench",
                    help="Workbench (default, fast) or Cycles on the CPU; neither needs a GPU")
    rr.add_argument("--json", action="store_true", help="print the report's numbers and legend layout as JSON")
    rr.set_defaults(func=_cmd_render)

    po = sub.add_parser("post", help="whole-rotor machine program from plans: every strip on every lobe, run out past "
                                     "the body, collision-free links, feeds and speeds, cycle time")
    po.add_argument("plans", nargs="+", metavar="PLAN", help="flank-plan/1 JSON of one rotor (rotor plans)")
    po.add_argument("--machine", required=True, help="built-in machine NAME (see the machines command) or FILE")
    po.add_argument("--post", required=True, help="linuxcnc | fanuc | heidenhain")
    po.add_argument("-o", "--out", required=True, help="program file to write")
    _add_machining_inputs(po)
    po.add_argument("--clearance", type=float, default=5.0,
                    help="run-out beyond the end faces and margin of every link, mm (default 5)")
    po.add_argument("--direction", choices=["forward", "reverse", "zigzag"], default="forward",
                    help="pass direction: forward (tool from above the body down, as the CL data), reverse, or "
                         "zigzag (whichever start is nearer)")
    po.add_argument("--chord-tolerance", type=float, default=1e-3,
                    help="TCP machines: chord sagitta of the tip's helix, mm (default 0.001, at most 0.005)")
    _add_cutting_data(po)
    po.add_argument("--json", action="store_true", help="print passes, times, tools and per-pass cutting data")
    po.set_defaults(func=_cmd_post)

    mc = sub.add_parser("machines", help="list the built-in machines and the posts")
    mc.set_defaults(func=_cmd_machines)

    b = sub.add_parser("builtins", help="list built-in rotor names (KIND-PART)")
    b.set_defaults(func=_cmd_builtins)
    return p


def _picked_point(surface, point, to_world, option, unit):
    """A picked point (model coordinates) in the rotor frame, refused by name when it lies farther from the
    rotor surface than the surface's ``PICK_LIMIT`` outer radii."""
    p = _model_point_to_rotor(point, to_world)
    d, limit = surface.section_distance(p), surface.PICK_LIMIT * surface.outer_radius
    if not d <= limit:
        raise ValueError(f"{option} {','.join(f'{x:g}' for x in point)} lies {d:.4g} {unit} from the rotor surface, "
                         f"above the limit {limit:.4g} {unit} ({surface.PICK_LIMIT:g} of the outer radius): a point "
                         "in another unit or frame?")
    return p


def _csv_text(rows, header, fmt="%.12g"):
    """Rows as comma-separated text under a one-line header."""
    buf = io.StringIO()
    np.savetxt(buf, rows, delimiter=",", header=header, comments="", fmt=fmt)
    return buf.getvalue()


def _write_csv(path, rows, header, fmt="%.12g"):
    """Rows as comma-separated text under a one-line header, written whole or not at all."""
    atomic_write(path, _csv_text(rows, header, fmt))


class UsageError(ValueError):
    """A command line argparse cannot parse (printed by :func:`main` as one line)."""


class _Parser(argparse.ArgumentParser):
    """argparse with usage errors as one line ``error: ...`` (no usage block), like every other bad input."""

    def error(self, message):
        raise UsageError(f"{message} (see {self.prog} --help)")


# options that name a file the command writes (plan's --profile-csv too; rotor's --profile-csv is read)
_OUTPUT_OPTIONS = ("out", "plan_out", "tool_csv", "profile_out", "cl", "error_csv")


def _output_options(args):
    """The options of ``args`` that name single files the command writes."""
    return _OUTPUT_OPTIONS + (("profile_csv",) if getattr(args, "command", None) == "plan" else ())


def _missing_output_folder(args):
    """The message for an output file (--out, --plan-out, --tool-csv, ...) that cannot be written (a folder, or
    its folder missing or not writable; :func:`io.files.output_path_error`), else None."""
    from .io.files import output_path_error

    for name in _output_options(args) + ("strips_stl", "strips_ply"):
        path = getattr(args, name, None)
        if isinstance(path, str) and not path.strip():
            return f"--{name.replace('_', '-')} is empty: give the file to write"
        if isinstance(path, str) and path:
            msg = output_path_error(path, prefix=name in ("strips_stl", "strips_ply"))
            if msg:
                return f"--{name.replace('_', '-')} {path}: {msg}"
    return None


def _output_clash(args):
    """The message for an output file that is also an input of the command, or that two outputs share, else None:
    writing it would destroy the input (a plan turned into G-code, a mesh into a plan) or one output the other."""
    names = _output_options(args)
    outputs = [(n, getattr(args, n)) for n in names if isinstance(getattr(args, n, None), str) and getattr(args, n)]
    inputs = []
    for n, v in vars(args).items():
        if n in names or n in ("command", "func"):
            continue
        inputs += [(n, x) for x in (v if isinstance(v, list) else [v]) if isinstance(x, str) and os.path.isfile(x)]

    def same(a, b):
        try:
            return os.path.samefile(a, b)
        except OSError:                 # one of them does not exist yet
            return os.path.realpath(a) == os.path.realpath(b)

    def option(n):
        return "the input" if n in ("path", "plans", "plan") else "--" + n.replace("_", "-")

    for i, (n, path) in enumerate(outputs):
        for m, x in inputs:
            if same(path, x):
                return (f"--{n.replace('_', '-')} {path} is also {option(m)} {x}: writing it would destroy that "
                        "file; choose another output path")
        for m, other in outputs[:i]:
            if same(path, other):
                return f"--{m.replace('_', '-')} and --{n.replace('_', '-')} name the same file {path}"
    return None


def main(argv=None):
    parser = build_parser()
    try:
        args = parser.parse_args(attach_negative_lists(sys.argv[1:] if argv is None else list(argv)))
    except SystemExit as ex:            # --help and --version: argparse has printed them
        return ex.code
    except UsageError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    missing = _missing_output_folder(args) or _output_clash(args) or _foreign_plan_options(args, parser)
    if missing:                         # before minutes of planning, not after
        print(f"error: {missing}", file=sys.stderr)
        return 2
    try:
        return args.func(args)
    except OSError as e:  # missing or unreadable files: say which and why
        print(f"error: {e.filename or ''}: {e.strerror or e}", file=sys.stderr)
        return 2
    except ValueError as e:  # bad input: one clear line, no traceback
        print(f"error: {e}", file=sys.stderr)
        return 2
