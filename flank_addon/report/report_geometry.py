"""A report picture of a plan: the rotor, the envelope strips coloured by signed error, a legend and a title.

One code path for ``flank.render_report`` (Blender) and ``python -m flank_addon render PLAN --out PNG``: the
geometry and the numbers come from the plan alone (:func:`report_geometry`, numpy only), and so do the camera,
the legend's layout and labels and the pixels of the legend bar (:func:`paint_legend`).  The Blender scene
that renders the picture is built by the extension's ``operators/report_scene.py``, which removes everything
it made again.

Colours: a strip vertex at signed distance d from the rotor surface (positive = outside = material left,
negative = overcut) gets :func:`simulation.verify.deviation_colors` (d, tolerance), the colours of the strips that the
planning operators build.  The legend bar shows the same function over -10 .. +10 tolerances (its shade
saturates at 10 tolerances); the picture uses Blender's *Standard* view transform, so a linear colour c is
stored as its sRGB encoding (:func:`srgb_bytes`).  The PNG carries the title and the legend's numbers as an
``iTXt`` chunk ``flank-report`` (JSON; :func:`io.png.read_png_text`).
"""
import math

import numpy as np

LEGEND_KEYS = (("gouge", "overcut"), ("ok", "within tolerance"), ("stock", "material left"))
ENGINES = ("WORKBENCH", "CYCLES")
BAR_SPLIT = (0.35, 0.65)     # fractions of the legend bar where the 'within tolerance' band starts / ends
BAR_RANGE = 10.0             # the bar spans -10 .. +10 tolerances
REPORT_KEY = "flank-report"  # iTXt keyword of the report's metadata in the PNG
TEXT_RGBA = (0.08, 0.08, 0.10, 1.0)
# Workbench renders the picture in tiles of at most this many pixels, one per turn of Blender's main thread: a
# render call of 640 x 400 took 38-50 ms there, one of 1280 x 800 120-145 ms (more than its four quarters)
TILE_PIXELS = 256_000


# ------------------------------------------------------------------------------------------- numbers
def format_length(x, unit):
    """A length for people: millimetres below 1 mm in µm, else the unit."""
    if x is None or not math.isfinite(x):
        return "n/a"
    if unit == "mm" and abs(x) < 1.0:
        return "{:+.3g} µm".format(1000.0 * x).replace("+0 ", "0 ")
    return "{:+.3g} {}".format(x, unit).replace("+0 ", "0 ")


def plan_scale(plan):
    """Scene units per plan unit: the uniform scale of the plan's ``rotor.to_world`` (1 for a mesh plan, whose
    points are the model's own)."""
    if "rotor" not in plan:
        return 1.0
    A = np.asarray(plan["rotor"]["to_world"], float)[:3, :3]
    return float(np.cbrt(np.linalg.det(A)))


def display_units(plan, unit_system=None, scale_length=1.0, scale=None):
    """(factor, unit): a plan length x is shown as ``format_length(x * factor, unit)``.

    Without a unit system (the command line, or a Blender scene whose unit system is 'NONE') lengths are
    shown in the plan's own unit.  In a metric or imperial Blender scene they are shown in the scene's
    units: plan unit -> scene unit (the uniform scale of ``rotor.to_world``) -> metres (``scale_length``) ->
    mm (µm below 1 mm) or inches.  ``scale`` (scene units per plan unit) overrides :func:`plan_scale` (a mesh
    plan's object scale is known only to the scene)."""
    if unit_system in ("METRIC", "IMPERIAL"):
        sl = float(scale_length) if scale_length and math.isfinite(scale_length) and scale_length > 0 else 1.0
        metres = (plan_scale(plan) if scale is None else float(scale)) * sl
        return (1000.0 * metres, "mm") if unit_system == "METRIC" else (metres / 0.0254, "in")
    return 1.0, plan.get("length_unit", "R")


def srgb_bytes(rgb):
    """Linear RGB (..., 3) in [0, 1] -> sRGB-encoded bytes (..., 3) (what 'Standard' shows)."""
    c = np.clip(np.asarray(rgb, float), 0.0, 1.0)
    s = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)
    return np.round(255.0 * s).astype(np.uint8)


def legend_colors():
    """name -> sRGB bytes (3,) of the band colours at the band edge (verify.DEVIATION_COLORS)."""
    from ..simulation.verify import DEVIATION_COLORS

    return {k: srgb_bytes(DEVIATION_COLORS[k][:3]) for k, _ in LEGEND_KEYS}


def bar_deviations(n, tolerance):
    """Signed deviation shown by each of the ``n`` columns of the legend bar: -10 .. -1 tolerances over the
    first 35 %, -1 .. +1 over the middle 30 %, +1 .. +10 over the last 35 %.  The columns next to the
    'within tolerance' band lie just beyond it, so they show the band colours at full strength."""
    na, nb = round(BAR_SPLIT[0] * n), round(BAR_SPLIT[1] * n)
    if not 2 <= na < nb <= n - 2:
        raise ValueError(f"a legend bar of {n} columns is too short")
    out = 1.0 + 1e-9
    red = -(BAR_RANGE - (BAR_RANGE - 1.0) * np.arange(na) / (na - 1)) * out
    green = -1.0 + 2.0 * (np.arange(nb - na) + 0.5) / (nb - na)
    blue = (1.0 + (BAR_RANGE - 1.0) * np.arange(n - nb) / (n - nb - 1)) * out
    return np.concatenate([red, green, blue]) * float(tolerance)


def bar_colors(n, tolerance):
    """(n, 3) sRGB bytes of the legend bar's columns: the strips' colour function at :func:`bar_deviations`."""
    from ..simulation.verify import deviation_colors

    return srgb_bytes(deviation_colors(bar_deviations(n, tolerance), tolerance)[:, :3])


def legend_layout(width, height):
    """Pixel layout (top-left origin) of the report: font size ``fs``, title baselines, the legend bar
    box [x0, y0, x1, y1), the rows [y0, y1) of the band lines above it (each band's full colour over its
    part of the bar) and the region [x0, y0, x1, y1) the geometry is fitted into."""
    fs = max(9, min(height // 40, width // 60))
    mx, my = round(0.03 * width), round(0.03 * height)
    title = [my + 1.5 * fs, my + 3.1 * fs]
    tick_base = height - my - 0.3 * fs
    y1 = int(round(tick_base - 1.5 * fs))
    y0 = y1 - int(round(1.1 * fs))
    x0 = mx + int(round(2.5 * fs))
    x1 = x0 + int(round(min(0.6 * width, 36 * fs)))
    gap, lh = max(2, round(0.2 * fs)), max(4, round(0.4 * fs))
    top = y0 - gap - lh
    return dict(fs=fs, margin=[mx, my], title=title, bar=[x0, y0, x1, y1], band_rows=[top, y0 - gap],
                tick_base=tick_base, names_base=top - 0.4 * fs,
                region=[mx, int(my + 4.0 * fs), width - mx, int(top - 1.9 * fs)])


# ------------------------------------------------------------------------------------------- geometry
def report_geometry(plan, n_t=61, n_profile=720, tolerance=None):
    """What the report shows, from a flank-plan/1 dict (rotor frame, plan units):

    rotor: (verts, faces) of the helical body over one lead; occluders: dense points of its surface (for
    :func:`choose_view`); strips: per strip (verts, faces, deviation,
    normal) with the exact signed distance of each envelope vertex to the rotor surface (+ = outside =
    material left) and the outward surface normal at its foot point; tolerance: the plan's (or the given
    one); max_error / min_error: the plan's summary (its simulated errors) else the strips' extremes."""
    from ..exports.strip_mesh import strip_mesh
    from ..io.plan import plan_surface
    from ..geometry.rotors import helical_body_mesh

    rot = plan["rotor"]
    surf = plan_surface(plan)
    v0, hand = float(rot["v0"]), rot["handedness"]
    lead = 2.0 * math.pi * v0
    rv, rf = helical_body_mesh(surf.profile, v0, hand, lead, n_profile=n_profile, n_axial=48)
    occ = helical_body_mesh(surf.profile, v0, hand, lead, n_profile=400, n_axial=200)[0]   # dense samples
    strips = []
    for k in range(len(plan["strips"])):
        v, f = strip_mesh(plan, k, n_t=n_t)
        if len(v):
            fp = surf.foot_points(v)
            d, n = np.asarray(fp.distance, float), np.asarray(fp.normal, float)
        else:
            d, n = np.zeros(0), np.zeros((0, 3))
        strips.append((v, f, d, n))
    tol = tolerance if tolerance is not None else plan.get("tolerance")
    R = float(rot.get("outer_radius") or np.max(np.linalg.norm(np.asarray(rot["profile"], float), axis=1)))
    if tol is None or not tol > 0:
        tol = 1e-3 * R
    summ = plan.get("summary") or {}
    allv = np.concatenate([s[2] for s in strips]) if strips else np.zeros(0)
    mx = summ.get("max_error", float(allv.max()) if len(allv) else None)
    mn = summ.get("min_error", float(allv.min()) if len(allv) else None)
    return dict(rotor=(rv, rf), occluders=occ, strips=strips, tolerance=float(tol), max_error=mx, min_error=mn,
                unit=plan.get("length_unit", "R"), method=plan.get("method", ""), outer_radius=R)


def air_limit(tolerance, R):
    """Envelope parts farther than this outside the rotor are the tool moving through air: not drawn (10
    tolerances, at least 1 % of the outer radius; the legend's shade saturates at 10 tolerances anyway)."""
    return max(BAR_RANGE * float(tolerance), 0.01 * float(R))


def strip_part(v, f, d, n, limit):
    """The part of a strip (verts, faces, d, normals) that is drawn: the faces with a vertex at most ``limit``
    outside the rotor (overcuts always count), with their vertices only."""
    f = np.asarray(f)
    if not len(f):
        return v[:0], f, d[:0], n[:0]
    f = f[d[f].min(axis=1) <= limit]
    used = np.unique(f)
    remap = np.full(len(v), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return v[used], remap[f], d[used], n[used]


def display_strip(v, d, n, R):
    """Strip vertices as drawn: on (never inside) the rotor, 0.2 % R above it, so that overcut parts are not
    hidden by the body; the colour still tells the signed distance d."""
    return v + n * (np.maximum(d, 0.0) - d + 2e-3 * R)[:, None]


def _view_basis(w):
    """(r, u): image right = the rotor axis (z) projected, image up = w x r."""
    r = np.array([0.0, 0.0, 1.0]) - w[2] * w
    r /= np.linalg.norm(r)
    return r, np.cross(w, r)


def choose_view(strips, R, occluders=None, limit=None):
    """Unit direction w (towards the camera) that shows the most strip area face-on.

    Candidates: azimuths every 10 deg at elevations -40 .. +40 deg; score = sum of area x max(0, n . w) over
    the strip faces lying on the rotor (a vertex at most ``limit``, default 2 % R, outside it).  The 12 best are scored again counting only faces that the rotor
    (``occluders``, surface sample points) does not hide: a depth buffer of the points on a 0.04 R grid."""
    C, N, A = [], [], []
    for v, f, d, n in strips:
        if not len(f):
            continue
        e = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
        nf = n[f].sum(axis=1)
        nf /= np.maximum(np.linalg.norm(nf, axis=1), 1e-12)[:, None]
        on = d[f].min(axis=1) <= (0.02 * R if limit is None else limit)
        C.append(v[f[on]].mean(axis=1) + 2e-3 * R * nf[on])
        N.append(nf[on])
        A.append(0.5 * np.linalg.norm(e[on], axis=1))
    if not N or not sum(len(a) for a in A):
        return np.array([math.cos(0.35), 0.0, math.sin(0.35)])
    C, N, A = np.concatenate(C), np.concatenate(N), np.concatenate(A)
    if len(A) > 8000:
        keep = np.linspace(0, len(A) - 1, 8000).astype(int)
        C, N, A = C[keep], N[keep], A[keep]
    phi = np.radians(np.arange(0.0, 360.0, 10.0))
    W = np.concatenate([np.stack([np.cos(phi) * math.cos(el), np.sin(phi) * math.cos(el),
                                  np.full_like(phi, math.sin(el))], 1) for el in np.radians([-40, -20, 0, 20, 40])])
    facing = np.maximum(N @ W.T, 0.0) * A[:, None]
    score = facing.sum(axis=0)
    if occluders is None or not len(occluders):
        return W[int(np.argmax(score))]
    P = np.asarray(occluders, float)
    h, depth_tol = 0.04 * R, 0.1 * R
    best, best_score = None, -1.0
    for i in np.argsort(score)[::-1][:12]:
        w = W[i]
        r, u = _view_basis(w)
        pa, pb, pc = P @ r, P @ u, P @ w
        a0, b0 = pa.min(), pb.min()
        na, nb = int((pa.max() - a0) / h) + 1, int((pb.max() - b0) / h) + 1
        zbuf = np.full((na, nb), -np.inf)
        np.maximum.at(zbuf, (((pa - a0) / h).astype(int), ((pb - b0) / h).astype(int)), pc)
        ca, cb, cc = C @ r, C @ u, C @ w
        ia, ib = np.floor((ca - a0) / h).astype(int), np.floor((cb - b0) / h).astype(int)
        inside = (ia >= 0) & (ia < na) & (ib >= 0) & (ib < nb)
        front = np.ones(len(C), bool)
        front[inside] = cc[inside] >= zbuf[ia[inside], ib[inside]] - depth_tol
        s = float(facing[front, i].sum())
        if s > best_score:
            best, best_score = w, s
    return best


def camera_frame(points, w, width, height, region, R):
    """Orthographic camera looking along -w with the rotor axis (z) horizontal, fitted so that ``points``
    fill the pixel ``region``.  -> (4x4 camera matrix, pixels per unit, ortho scale, clip_end)."""
    w = np.asarray(w, float) / np.linalg.norm(w)
    r, u = _view_basis(w)
    P = np.asarray(points, float)
    a, b, c = P @ r, P @ u, P @ w
    gx0, gy0, gx1, gy1 = region
    ppu = min((gx1 - gx0) / max(np.ptp(a), 1e-9 * R), (gy1 - gy0) / max(np.ptp(b), 1e-9 * R))
    ca = 0.5 * (a.min() + a.max()) - (0.5 * (gx0 + gx1) - 0.5 * width) / ppu
    cb = 0.5 * (b.min() + b.max()) + (0.5 * (gy0 + gy1) - 0.5 * height) / ppu
    cc = c.max() + 2.0 * R
    M = np.eye(4)
    M[:3, 0], M[:3, 1], M[:3, 2], M[:3, 3] = r, u, w, ca * r + cb * u + cc * w
    return M, ppu, max(width, height) / ppu, cc - c.min() + R


def title_lines(geo, units, title, n_strips):
    """The two title lines: the plan's name or method, then tolerance, max / min error and strip count."""
    fac, unit = units
    tol = geo["tolerance"]

    def L(x):
        return format_length(None if x is None else x * fac, unit)

    head = title or "Flank plan: {}".format(geo["method"] or "strips")
    line2 = "tolerance ±{}   max error {}   min error {}   {} strip{}".format(
        L(tol).lstrip("+"), L(geo["max_error"]), L(geo["min_error"]), n_strips, "" if n_strips == 1 else "s")
    return [head, line2]


# ------------------------------------------------------------------------------------------- picture
def check_render_args(width, height, tolerance, engine):
    """The engine's name in capitals, or ValueError naming the bad value and its limits."""
    if not (isinstance(width, int) and isinstance(height, int) and 64 <= width <= 8192 and 64 <= height <= 8192):
        raise ValueError(f"resolution {width} x {height} is outside the limits 64..8192")
    if tolerance is not None and not (isinstance(tolerance, (int, float)) and math.isfinite(tolerance)
                                      and tolerance > 0):
        raise ValueError(f"tolerance {tolerance!r} must be a positive number")
    engine = str(engine).upper()
    if engine not in ENGINES:
        raise ValueError(f"engine {engine!r} is not one of {', '.join(ENGINES)}")
    return engine


def render_tiles(width, height, limit=TILE_PIXELS):
    """The picture cut into tiles of at most ``limit`` pixels -> [(x0, y0, x1, y1)], pixel bounds with the
    origin top left, row by row.  The longer side of the tiles is halved, thirded, ... first, so that tiles stay
    near the picture's shape; tile sizes differ by at most one pixel."""
    width, height, limit = int(width), int(height), int(limit)
    if width < 1 or height < 1 or limit < 1:
        raise ValueError(f"tiles of a {width} x {height} picture with at most {limit} pixels each")
    nx = ny = 1
    while -(-width // nx) * -(-height // ny) > limit:     # ends by 1 x 1 pixel tiles at the latest
        if width / nx >= height / ny and nx < width:
            nx += 1
        else:                                             # here ny < height, or the tiles would be 1 pixel
            ny += 1
    xs = [round(i * width / nx) for i in range(nx + 1)]
    ys = [round(j * height / ny) for j in range(ny + 1)]
    return [(xs[i], ys[j], xs[i + 1], ys[j + 1]) for j in range(ny) for i in range(nx)]


def tile_camera(tile, width, height, ortho):
    """The orthographic camera of one tile of the picture: (resolution x, resolution y, ortho scale, shift x,
    shift y).  Blender fits the ortho scale to the larger side of the frame and measures the shift in that
    scale, so a tile keeps the picture's pixel size ``ortho / max(width, height)`` and its pixel centres."""
    x0, y0, x1, y1 = tile
    w, h = x1 - x0, y1 - y0
    side = max(w, h)
    pixel = float(ortho) / max(width, height)
    return w, h, side * pixel, (0.5 * (x0 + x1) - 0.5 * width) / side, (0.5 * height - 0.5 * (y0 + y1)) / side


def legend_labels(lay, tolerance, units):
    """(split, ticks, tick_text, names) of the legend in the layout ``lay`` (:func:`legend_layout`): the
    pixel columns where the 'within tolerance' band starts and ends, the ticks (x, deviation), their texts in
    ``units`` = (factor, unit) and the band names (x, text), shortened when the band is too narrow."""
    fs = lay["fs"]
    bx0, _, bx1, _ = lay["bar"]
    split = [bx0 + round(f * (bx1 - bx0)) for f in BAR_SPLIT]
    ticks = [(bx0, -BAR_RANGE * tolerance), (split[0], -tolerance), (round(0.5 * (bx0 + bx1)), 0.0),
             (split[1], tolerance), (bx1, BAR_RANGE * tolerance)]
    tick_text = [format_length(v * units[0], units[1]) for _, v in ticks]
    long = 0.9 * 0.5 * fs * len("within tolerance") < split[1] - split[0] - fs     # estimated text width
    names = [(round(0.5 * (bx0 + split[0])), "overcut"),
             (round(0.5 * (split[0] + split[1])), "within tolerance" if long else "within"),
             (round(0.5 * (split[1] + bx1)), "material left" if long else "left")]
    return split, ticks, tick_text, names


def paint_legend(rgba, lay, tolerance, split, ticks):
    """Paint the legend bar into the rendered pixels (H, W, 4) uint8, top row first, in place: the strips'
    colour function, exact; above it each band's full colour over its part; ticks and a thin frame outside
    the bar."""
    bx0, by0, bx1, by1 = lay["bar"]
    fs = lay["fs"]
    cols = legend_colors()
    ly0, ly1 = lay["band_rows"]
    for (key, _), a, b in zip(LEGEND_KEYS, (bx0, split[0] + 1, split[1] + 1), (split[0] - 1, split[1] - 1, bx1)):
        rgba[ly0:ly1, a:b, :3] = cols[key]
    rgba[by0:by1, bx0:bx1, :3] = bar_colors(bx1 - bx0, tolerance)[None, :, :]
    dark = 40
    rgba[by0 - 1, bx0 - 1:bx1 + 1, :3] = rgba[by1, bx0 - 1:bx1 + 1, :3] = dark
    rgba[by0 - 1:by1 + 1, bx0 - 1, :3] = rgba[by0 - 1:by1 + 1, bx1, :3] = dark
    tick_len = max(3, int(0.3 * fs))
    for x, _ in ticks:
        x = min(max(x, bx0), bx1 - 1)
        rgba[by1 + 1:by1 + 1 + tick_len, x, :3] = dark
    return rgba


def report_info(geo, lay, width, height, engine, lines, units, legend):
    """The report's numbers (stored in the PNG and returned to the caller): size, engine, title, tolerance,
    errors, units, strip count and the legend's layout."""
    split, ticks, tick_text, names = legend
    return dict(width=width, height=height, engine=engine, title=lines, tolerance=geo["tolerance"],
                max_error=geo["max_error"], min_error=geo["min_error"], units=list(units),
                strips=len(geo["strips"]),
                legend=dict(bar=list(lay["bar"]), split=split, range=BAR_RANGE, band_rows=list(lay["band_rows"]),
                            ticks=[dict(x=x, value=v, text=t) for (x, v), t in zip(ticks, tick_text)],
                            names=[t for _, t in names]))


def report_picture(geo, width, height, title=None, units=None, engine="WORKBENCH"):
    """Everything the report's scene shows, from :func:`report_geometry` (or a free-form ``geometry``) alone,
    without Blender: the rotor mesh, the drawn strip parts with their display vertices and exact colours, the
    view and camera, the legend's layout and labels, the title lines and the report's numbers (``info``).

    A scene builder (the extension's ``operators/report_scene.py``) only turns this into Blender data and
    renders it; the work here can run in a worker thread while Blender's main thread stays free."""
    from ..simulation.verify import deviation_colors

    units = tuple(units) if units is not None else (1.0, geo["unit"])
    tol, R = geo["tolerance"], geo["outer_radius"]
    lay = legend_layout(width, height)
    lines = title_lines(geo, units, title, len(geo["strips"]))
    legend = legend_labels(lay, tol, units)
    rv, rf = geo["rotor"]
    limit = air_limit(tol, R)
    parts = [strip_part(v, f, d, n, limit) for v, f, d, n in geo["strips"]]
    drawn, pts = [], [np.asarray(rv)[::7]]
    for k, (v, f, d, n) in enumerate(parts):
        if len(f):
            dv = display_strip(v, d, n, R)
            drawn.append(("Report Strip {}".format(k + 1), dv, f, deviation_colors(d, tol)))
            pts.append(dv)
    pts = np.concatenate(pts)
    w = choose_view(parts, R, geo.get("occluders"), limit)
    M, ppu, ortho, clip_end = camera_frame(pts, w, width, height, lay["region"], R)
    return dict(width=width, height=height, R=R, tolerance=tol, rotor=(rv, rf), strips=drawn, camera=M, ppu=ppu,
                ortho=ortho, clip_end=clip_end, layout=lay, lines=lines, legend=legend,
                info=report_info(geo, lay, width, height, engine, lines, units, legend))
