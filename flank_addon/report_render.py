"""A report picture of a plan: the rotor, the envelope strips coloured by signed error, a legend and a title.

One code path for ``flank.render_report`` (Blender) and ``python -m flank_addon render PLAN --out PNG``: the
geometry and the numbers come from the plan alone (:func:`report_geometry`, numpy only); the picture is made by
:func:`render_plan_report`, which is *given* the ``bpy`` module (this module never imports it), builds a
temporary scene, renders it (Workbench by default, or Cycles on the CPU), removes everything it made, and
paints the legend bar into the pixels so that its colours are exact.

Colours: a strip vertex at signed distance d from the rotor surface (positive = outside = material left,
negative = overcut) gets :func:`verify.deviation_colors` (d, tolerance), the colours of the strips that the
planning operators build.  The legend bar shows the same function over -10 .. +10 tolerances (its shade
saturates at 10 tolerances); the picture uses Blender's *Standard* view transform, so a linear colour c is
stored as its sRGB encoding (:func:`srgb_bytes`).  The PNG carries the title and the legend's numbers as an
``iTXt`` chunk ``flank-report`` (JSON; :func:`read_png_text`).
"""
import json
import math
import os
import struct
import time
import zlib

import numpy as np

LEGEND_KEYS = (("gouge", "overcut"), ("ok", "within tolerance"), ("stock", "material left"))
ENGINES = ("WORKBENCH", "CYCLES")
BAR_SPLIT = (0.35, 0.65)     # fractions of the legend bar where the 'within tolerance' band starts / ends
BAR_RANGE = 10.0             # the bar spans -10 .. +10 tolerances
REPORT_KEY = "flank-report"  # iTXt keyword of the report's metadata in the PNG
TEXT_RGBA = (0.08, 0.08, 0.10, 1.0)


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
    from .verify import DEVIATION_COLORS

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
    from .verify import deviation_colors

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


# ------------------------------------------------------------------------------------------- PNG
def _chunk(tag, data):
    return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)


def write_png(path, rgba, text=None):
    """Write (H, W, 4) uint8, top row first, as an 8-bit RGBA PNG (every row with the 'Up' filter: the byte
    difference to the row above), atomically.  ``text``: dict keyword -> str, stored as uncompressed UTF-8
    iTXt chunks."""
    a = np.ascontiguousarray(rgba, dtype=np.uint8)
    h, w = a.shape[:2]
    rows = a.reshape(h, w * 4)
    up = rows - np.concatenate([np.zeros((1, w * 4), np.uint8), rows[:-1]])        # mod 256
    raw = np.concatenate([np.full((h, 1), 2, np.uint8), up], axis=1).tobytes()
    png = b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0))
    for key, value in (text or {}).items():
        png += _chunk(b"iTXt", key.encode("latin-1") + b"\x00\x00\x00\x00\x00" + value.encode("utf-8"))
    png += _chunk(b"IDAT", zlib.compress(raw, 6)) + _chunk(b"IEND", b"")
    tmp = "{}.tmp{}".format(path, os.getpid())
    try:
        with open(tmp, "wb") as fh:
            fh.write(png)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def _chunks(path):
    with open(path, "rb") as fh:
        data = fh.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG file")
    pos = 8
    while pos + 8 <= len(data):
        n, tag = struct.unpack(">I4s", data[pos:pos + 8])
        yield tag, data[pos + 8:pos + 8 + n]
        pos += 12 + n


def read_png(path):
    """(H, W, 4) uint8 of an 8-bit RGBA or RGB PNG whose rows use the filters None or Up (as :func:`write_png`;
    not every PNG: Sub, Average and Paeth rows are refused)."""
    idat, w = b"", None
    for tag, body in _chunks(path):
        if tag == b"IHDR":
            w, h, depth, ctype = struct.unpack(">IIBB", body[:10])
            if depth != 8 or ctype not in (2, 6):
                raise ValueError(f"{path}: only 8-bit RGB/RGBA PNGs are read here")
            ch = 4 if ctype == 6 else 3
        elif tag == b"IDAT":
            idat += body
    if w is None:
        raise ValueError(f"{path}: no IHDR chunk")
    raw = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(h, 1 + w * ch)
    if not np.isin(raw[:, 0], (0, 2)).all():
        raise ValueError(f"{path}: rows with the Sub, Average or Paeth filter (not written by write_png)")
    px = raw[:, 1:].copy()
    for y in np.flatnonzero(raw[:, 0] == 2):
        if y > 0:
            px[y] += px[y - 1]                                          # Up: add the decoded row above (mod 256)
    px = px.reshape(h, w, ch)
    if ch == 3:
        px = np.concatenate([px, np.full((h, w, 1), 255, np.uint8)], axis=-1)
    return px


def read_png_text(path):
    """keyword -> text of the PNG's uncompressed iTXt chunks (the report's metadata: ``flank-report``)."""
    out = {}
    for tag, body in _chunks(path):
        if tag == b"iTXt":
            key, rest = body.split(b"\x00", 1)
            if rest[:1] == b"\x00":                                  # not compressed
                rest = rest[2:]                                      # compression flag + method
                _lang, rest = rest.split(b"\x00", 1)
                _tkey, text = rest.split(b"\x00", 1)
                out[key.decode("latin-1")] = text.decode("utf-8")
    return out


# ------------------------------------------------------------------------------------------- geometry
def report_geometry(plan, n_t=61, n_profile=720, tolerance=None):
    """What the report shows, from a flank-plan/1 dict (rotor frame, plan units):

    rotor: (verts, faces) of the helical body over one lead; occluders: dense points of its surface (for
    :func:`choose_view`); strips: per strip (verts, faces, deviation,
    normal) with the exact signed distance of each envelope vertex to the rotor surface (+ = outside =
    material left) and the outward surface normal at its foot point; tolerance: the plan's (or the given
    one); max_error / min_error: the plan's summary (its simulated errors) else the strips' extremes."""
    from .exports import strip_mesh
    from .plan import plan_surface
    from .rotors import helical_body_mesh

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


def _title_lines(geo, units, title, n_strips):
    fac, unit = units
    tol = geo["tolerance"]

    def L(x):
        return format_length(None if x is None else x * fac, unit)

    head = title or "Flank plan: {}".format(geo["method"] or "strips")
    line2 = "tolerance ±{}   max error {}   min error {}   {} strip{}".format(
        L(tol).lstrip("+"), L(geo["max_error"]), L(geo["min_error"]), n_strips, "" if n_strips == 1 else "s")
    return [head, line2]


# ------------------------------------------------------------------------------------------- picture
def _mesh_object(bpy, sc, made, name, verts, faces, rgba, material=None, smooth=False):
    me = bpy.data.meshes.new(name)
    made["meshes"].append(me)
    me.vertices.add(len(verts))
    me.vertices.foreach_set("co", np.asarray(verts, np.float32).ravel())
    me.loops.add(3 * len(faces))
    me.loops.foreach_set("vertex_index", np.asarray(faces, np.int32).ravel())
    me.polygons.add(len(faces))
    me.polygons.foreach_set("loop_start", np.arange(0, 3 * len(faces), 3, dtype=np.int32))
    if smooth:
        me.polygons.foreach_set("use_smooth", np.ones(len(faces), bool))
    me.update()
    _paint(me, rgba)
    if material is not None:
        me.materials.append(material)
    ob = bpy.data.objects.new(name, me)
    made["objects"].append(ob)
    sc.collection.objects.link(ob)
    return ob


def _paint(me, rgba):
    col = np.asarray(rgba, np.float32)
    if col.ndim == 1:
        col = np.tile(col, (len(me.vertices), 1))
    attr = me.color_attributes.new("report_color", 'FLOAT_COLOR', 'POINT')
    attr.data.foreach_set("color", col.ravel())
    me.color_attributes.active_color = attr
    try:
        me.color_attributes.render_color_index = me.color_attributes.active_color_index
    except (AttributeError, TypeError):
        pass


def _text(bpy, sc, made, to_world, body, size, align='LEFT', material=None):
    """A text mesh of height ``size`` in the plane of the 4x4 ``to_world`` (baseline at its origin)."""
    from mathutils import Matrix

    cu = bpy.data.curves.new("Report Label", 'FONT')
    cu.body = body
    cu.size = size
    cu.align_x = align
    tmp = bpy.data.objects.new("Report Label", cu)
    try:
        sc.collection.objects.link(tmp)
        me = bpy.data.meshes.new_from_object(tmp)
    finally:
        bpy.data.objects.remove(tmp)
        bpy.data.curves.remove(cu)
    made["meshes"].append(me)
    _paint(me, TEXT_RGBA)
    if material is not None:
        me.materials.append(material)
    ob = bpy.data.objects.new("Report Label", me)
    made["objects"].append(ob)
    sc.collection.objects.link(ob)
    for ray in ("diffuse", "glossy", "transmission", "volume_scatter", "shadow"):   # Cycles: camera only
        if hasattr(ob, "visible_" + ray):
            setattr(ob, "visible_" + ray, False)
    ob.matrix_world = Matrix(np.asarray(to_world, float).tolist())
    return ob


def _attribute_material(bpy, made, name, emission):
    """Cycles: a material showing the 'report_color' attribute (lit, or as emission for the labels)."""
    mat = bpy.data.materials.new(name)
    made["materials"].append(mat)
    if mat.node_tree is None:
        mat.use_nodes = True
    nt = mat.node_tree
    for node in list(nt.nodes):
        nt.nodes.remove(node)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    attr = nt.nodes.new("ShaderNodeAttribute")
    attr.attribute_name = "report_color"
    if emission:
        sh = nt.nodes.new("ShaderNodeEmission")
        nt.links.new(attr.outputs["Color"], sh.inputs["Color"])
    else:
        sh = nt.nodes.new("ShaderNodeBsdfPrincipled")
        nt.links.new(attr.outputs["Color"], sh.inputs["Base Color"])
        sh.inputs["Roughness"].default_value = 0.5
    nt.links.new(sh.outputs[0], out.inputs["Surface"])
    return mat


def _cycles_world(world):
    """Cycles: the light grey background for camera rays, a dimmer ambient light for the shading."""
    if world.node_tree is None:
        world.use_nodes = True
    nt = world.node_tree
    for node in list(nt.nodes):
        nt.nodes.remove(node)
    out = nt.nodes.new("ShaderNodeOutputWorld")
    seen, light = nt.nodes.new("ShaderNodeBackground"), nt.nodes.new("ShaderNodeBackground")
    seen.inputs["Color"].default_value = (0.93, 0.93, 0.94, 1.0)
    seen.inputs["Strength"].default_value = 1.0
    light.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    light.inputs["Strength"].default_value = 0.35
    path, mix = nt.nodes.new("ShaderNodeLightPath"), nt.nodes.new("ShaderNodeMixShader")
    nt.links.new(path.outputs["Is Camera Ray"], mix.inputs[0])
    nt.links.new(light.outputs[0], mix.inputs[1])
    nt.links.new(seen.outputs[0], mix.inputs[2])
    nt.links.new(mix.outputs[0], out.inputs["Surface"])


def check_output(path):
    """Raise ValueError unless a PNG can be written at ``path`` (its folder exists and is writable)."""
    path = os.path.abspath(path)
    folder = os.path.dirname(path)
    if not os.path.isdir(folder):
        raise ValueError(f"the folder {folder!r} does not exist")
    if os.path.isdir(path):
        raise ValueError(f"{path!r} is a folder, not a file name")
    probe = "{}.probe{}".format(path, os.getpid())
    try:
        open(probe, "wb").close()
        os.remove(probe)
    except OSError as ex:
        raise ValueError(f"cannot write into the folder {folder!r}: {ex.strerror or ex}") from None
    return path


def render_plan_report(bpy, plan, path, width=1280, height=800, tolerance=None, title=None, geometry=None,
                       engine="WORKBENCH", units=None):
    """Render the report picture of ``plan`` to the PNG ``path`` with the given ``bpy`` module.

    engine: 'WORKBENCH' (default) or 'CYCLES' (CPU, 16 samples); units: (factor, unit) from
    :func:`display_units` (default: the plan's unit).  Nothing stays behind in Blender: a temporary scene
    with its objects, meshes, camera, world (and for Cycles materials and a light) is made, rendered and
    removed, and so is the builtin font if the file had none.  Returns dict(seconds, width, height, engine,
    legend (bar box [x0, y0, x1, y1) top-left origin, tick labels and positions, band names), title (two
    lines), max_error, min_error, tolerance (plan units), units); the same dict is stored in the PNG."""
    if not (isinstance(width, int) and isinstance(height, int) and 64 <= width <= 8192 and 64 <= height <= 8192):
        raise ValueError(f"resolution {width} x {height} is outside the limits 64..8192")
    if tolerance is not None and not (isinstance(tolerance, (int, float)) and math.isfinite(tolerance)
                                      and tolerance > 0):
        raise ValueError(f"tolerance {tolerance!r} must be a positive number")
    engine = str(engine).upper()
    if engine not in ENGINES:
        raise ValueError(f"engine {engine!r} is not one of {', '.join(ENGINES)}")
    path = check_output(path)
    t0 = time.perf_counter()
    geo = geometry if geometry is not None else report_geometry(plan, tolerance=tolerance)
    from .verify import deviation_colors

    units = tuple(units) if units is not None else (1.0, geo["unit"])
    tol, R = geo["tolerance"], geo["outer_radius"]
    lay = legend_layout(width, height)
    fs = lay["fs"]
    lines = _title_lines(geo, units, title, len(geo["strips"]))
    bx0, by0, bx1, by1 = lay["bar"]
    split = [bx0 + round(f * (bx1 - bx0)) for f in BAR_SPLIT]
    ticks = [(bx0, -BAR_RANGE * tol), (split[0], -tol), (round(0.5 * (bx0 + bx1)), 0.0), (split[1], tol),
             (bx1, BAR_RANGE * tol)]
    tick_text = [format_length(v * units[0], units[1]) for _, v in ticks]
    long = 0.9 * 0.5 * fs * len("within tolerance") < split[1] - split[0] - fs     # estimated text width
    names = [(round(0.5 * (bx0 + split[0])), "overcut"),
             (round(0.5 * (split[0] + split[1])), "within tolerance" if long else "within"),
             (round(0.5 * (split[1] + bx1)), "material left" if long else "left")]

    made = {k: [] for k in ("objects", "meshes", "cameras", "lights", "materials", "worlds", "images", "scenes")}
    fonts_before = {f.as_pointer() for f in bpy.data.fonts}
    had_render_result = bpy.data.images.get("Render Result") is not None
    tmp_png = "{}.render{}.png".format(path, os.getpid())
    try:
        sc = bpy.data.scenes.new("Flank Report (temporary)")
        made["scenes"].append(sc)
        r = sc.render
        r.resolution_x, r.resolution_y, r.resolution_percentage = width, height, 100
        r.image_settings.file_format = 'PNG'
        r.image_settings.color_mode = 'RGBA'
        r.film_transparent = False
        r.dither_intensity = 0.0           # no noise: exact flat colours, small PNGs
        sc.view_settings.view_transform = 'Standard'
        world = bpy.data.worlds.new("Flank Report World")
        made["worlds"].append(world)
        world.color = (0.93, 0.93, 0.94)
        sc.world = world
        surface_mat = label_mat = None
        if engine == "WORKBENCH":
            r.engine = 'BLENDER_WORKBENCH'
            sh = sc.display.shading
            sh.light, sh.color_type = 'STUDIO', 'VERTEX'
            sh.show_cavity = sh.show_object_outline = False
            sc.display.render_aa = 'FXAA'      # as smooth as 8 samples here, at less than half the time
        else:
            r.engine = 'CYCLES'
            if not hasattr(sc, "cycles"):
                raise ValueError("Cycles is not available in this Blender")
            sc.cycles.device = 'CPU'
            sc.cycles.samples = 16
            sc.cycles.use_denoising = True
            _cycles_world(world)
            surface_mat = _attribute_material(bpy, made, "Flank Report Surface", emission=False)
            label_mat = _attribute_material(bpy, made, "Flank Report Label", emission=True)

        rv, rf = geo["rotor"]
        _mesh_object(bpy, sc, made, "Report Rotor", rv, rf, (0.62, 0.62, 0.64, 1.0), surface_mat)
        pts = [np.asarray(rv)[::7]]
        limit = air_limit(tol, R)
        parts = [strip_part(v, f, d, n, limit) for v, f, d, n in geo["strips"]]
        for k, (v, f, d, n) in enumerate(parts):
            if len(f):
                dv = display_strip(v, d, n, R)
                _mesh_object(bpy, sc, made, "Report Strip {}".format(k + 1), dv, f, deviation_colors(d, tol),
                             surface_mat, smooth=True)
                pts.append(dv)
        w = choose_view(parts, R, geo.get("occluders"), limit)
        M, ppu, ortho, clip_end = camera_frame(np.concatenate(pts), w, width, height, lay["region"], R)
        camd = bpy.data.cameras.new("Report Camera")
        made["cameras"].append(camd)
        camd.type = 'ORTHO'
        camd.sensor_fit = 'AUTO'
        camd.ortho_scale = ortho
        camd.clip_start, camd.clip_end = 0.01 * R, clip_end
        cam = bpy.data.objects.new("Report Camera", camd)
        made["objects"].append(cam)
        sc.collection.objects.link(cam)
        from mathutils import Matrix

        cam.matrix_world = Matrix(M.tolist())
        sc.camera = cam
        if engine == "CYCLES":
            ld = bpy.data.lights.new("Flank Report Light", type='SUN')
            made["lights"].append(ld)
            ld.energy = 3.0
            lamp = bpy.data.objects.new("Flank Report Light", ld)
            made["objects"].append(lamp)
            sc.collection.objects.link(lamp)
            a, b = math.radians(-30.0), math.radians(25.0)       # from above-left of the camera
            rx = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(a), -math.sin(a)], [0.0, math.sin(a), math.cos(a)]])
            ry = np.array([[math.cos(b), 0.0, math.sin(b)], [0.0, 1.0, 0.0], [-math.sin(b), 0.0, math.cos(b)]])
            L = M.copy()
            L[:3, :3] = M[:3, :3] @ ry @ rx
            lamp.matrix_world = Matrix(L.tolist())

        def at(px, py):      # pixel (top-left origin) -> 4x4 in the camera's view plane, R in front of it
            T = M.copy()
            T[:3, 3] = M[:3, 3] + M[:3, :3] @ [(px - 0.5 * width) / ppu, (0.5 * height - py) / ppu, -R]
            return T

        mx = lay["margin"][0]
        _text(bpy, sc, made, at(mx, lay["title"][0]), lines[0], 1.5 * fs / ppu, material=label_mat)
        _text(bpy, sc, made, at(mx, lay["title"][1]), lines[1], fs / ppu, material=label_mat)
        for (x, _), txt in zip(ticks, tick_text):
            _text(bpy, sc, made, at(x, lay["tick_base"]), txt, 0.85 * fs / ppu, 'CENTER', label_mat)
        for x, txt in names:
            _text(bpy, sc, made, at(x, lay["names_base"]), txt, 0.9 * fs / ppu, 'CENTER', label_mat)
        caption = "signed distance strip - rotor"
        if bx1 + 1.5 * fs + 0.5 * fs * len(caption) < width - mx:
            _text(bpy, sc, made, at(bx1 + 1.5 * fs, 0.5 * (by0 + by1) + 0.35 * fs), caption, 0.85 * fs / ppu,
                  material=label_mat)

        bpy.ops.render.render(write_still=False, scene=sc.name)
        img = bpy.data.images.get("Render Result")
        if img is None:
            raise RuntimeError("the render produced no image")
        img.save_render(filepath=tmp_png, scene=sc)
        loaded = bpy.data.images.load(tmp_png, check_existing=False)
        made["images"].append(loaded)
        iw, ih = loaded.size
        if (iw, ih) != (width, height):
            raise RuntimeError(f"the render is {iw} x {ih}, not {width} x {height}")
        px = np.empty(iw * ih * 4, np.float32)
        loaded.pixels.foreach_get(px)
        rgba = np.round(255.0 * px.reshape(ih, iw, 4)[::-1]).astype(np.uint8)      # top row first
        rgba[..., 3] = 255
        # the legend bar: the strips' colour function, exact; above it each band's full colour over its part;
        # ticks and a thin frame outside the bar
        cols = legend_colors()
        ly0, ly1 = lay["band_rows"]
        for (key, _), a, b in zip(LEGEND_KEYS, (bx0, split[0] + 1, split[1] + 1), (split[0] - 1, split[1] - 1, bx1)):
            rgba[ly0:ly1, a:b, :3] = cols[key]
        rgba[by0:by1, bx0:bx1, :3] = bar_colors(bx1 - bx0, tol)[None, :, :]
        dark = 40
        rgba[by0 - 1, bx0 - 1:bx1 + 1, :3] = rgba[by1, bx0 - 1:bx1 + 1, :3] = dark
        rgba[by0 - 1:by1 + 1, bx0 - 1, :3] = rgba[by0 - 1:by1 + 1, bx1, :3] = dark
        tick_len = max(3, int(0.3 * fs))
        for x, _ in ticks:
            x = min(max(x, bx0), bx1 - 1)
            rgba[by1 + 1:by1 + 1 + tick_len, x, :3] = dark
        info = dict(width=width, height=height, engine=engine, title=lines, tolerance=tol,
                    max_error=geo["max_error"], min_error=geo["min_error"], units=list(units),
                    strips=len(geo["strips"]),
                    legend=dict(bar=[bx0, by0, bx1, by1], split=split, range=BAR_RANGE, band_rows=[ly0, ly1],
                                ticks=[dict(x=x, value=v, text=t) for (x, v), t in zip(ticks, tick_text)],
                                names=[t for _, t in names]))
        write_png(path, rgba, {REPORT_KEY: json.dumps(info, ensure_ascii=False)})
    finally:
        for key, coll in (("objects", bpy.data.objects), ("meshes", bpy.data.meshes),
                          ("cameras", bpy.data.cameras), ("lights", bpy.data.lights),
                          ("materials", bpy.data.materials), ("worlds", bpy.data.worlds),
                          ("images", bpy.data.images), ("scenes", bpy.data.scenes)):
            for block in made[key]:
                try:
                    coll.remove(block)
                except (ReferenceError, RuntimeError):
                    pass
        for font in list(bpy.data.fonts):           # the builtin font the labels loaded
            if font.as_pointer() not in fonts_before and font.users == 0:
                bpy.data.fonts.remove(font)
        if not had_render_result:
            img = bpy.data.images.get("Render Result")
            if img is not None:
                try:
                    bpy.data.images.remove(img)
                except (ReferenceError, RuntimeError):
                    pass
        if os.path.exists(tmp_png):
            os.remove(tmp_png)
    info["seconds"] = time.perf_counter() - t0
    return info
