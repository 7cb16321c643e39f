"""A report picture of a plan: the rotor, the envelope strips coloured by signed error, a legend and a title.

One code path for ``flank.render_report`` (Blender) and ``python -m flank_addon render PLAN --out PNG``: the
geometry and the numbers come from the plan alone (:func:`report_geometry`, numpy only); the picture is made by
:func:`render_plan_report`, which is *given* the ``bpy`` module (this module never imports it), builds a
temporary scene, renders it with Workbench, removes everything it made, and paints the legend swatches into
the pixels so their colours are exact.

Colours: a strip vertex at signed distance d from the rotor surface (positive = outside = material left,
negative = overcut) gets :func:`verify.deviation_colors` (d, tolerance); the picture uses Blender's *Standard*
view transform, so a linear colour c appears as its sRGB encoding (:func:`srgb_bytes`).
"""
import math
import os
import struct
import zlib

import numpy as np

LEGEND_KEYS = (("gouge", "overcut"), ("ok", "within tolerance"), ("stock", "material left"))


# ------------------------------------------------------------------------------------------- numbers
def format_length(x, unit):
    """A length for people: mm plans in µm below 1 mm, else the plan unit."""
    if x is None or not math.isfinite(x):
        return "n/a"
    if unit == "mm" and abs(x) < 1.0:
        return "{:+.3g} µm".format(1000.0 * x).replace("+0 ", "0 ")
    return "{:+.3g} {}".format(x, unit).replace("+0 ", "0 ")


def srgb_bytes(rgb):
    """Linear RGB (..., 3) in [0, 1] -> sRGB-encoded bytes (..., 3) (what 'Standard' shows)."""
    c = np.clip(np.asarray(rgb, float), 0.0, 1.0)
    s = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)
    return np.round(255.0 * s).astype(np.uint8)


def legend_colors():
    """name -> sRGB bytes (3,) of the band colours at the band edge (verify.DEVIATION_COLORS)."""
    from .verify import DEVIATION_COLORS

    return {k: srgb_bytes(DEVIATION_COLORS[k][:3]) for k, _ in LEGEND_KEYS}


# ------------------------------------------------------------------------------------------- PNG
def write_png(path, rgba):
    """Write (H, W, 4) uint8, top row first, as an 8-bit RGBA PNG (filter 0), atomically."""
    a = np.ascontiguousarray(rgba, dtype=np.uint8)
    h, w = a.shape[:2]
    raw = b"".join(b"\x00" + a[y].tobytes() for y in range(h))

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0)) + \
        chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b"")
    tmp = "{}.tmp{}".format(path, os.getpid())
    with open(tmp, "wb") as fh:
        fh.write(png)
    os.replace(tmp, path)


def read_png(path):
    """(H, W, 4) uint8 of an 8-bit RGBA or RGB PNG written with filter 0 rows (as :func:`write_png`)."""
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG file")
    pos, idat, w = 8, b"", None
    while pos < len(data):
        n, tag = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if tag == b"IHDR":
            w, h, depth, ctype = struct.unpack(">IIBB", body[:10])
            if depth != 8 or ctype not in (2, 6):
                raise ValueError(f"{path}: only 8-bit RGB/RGBA PNGs are read here")
            ch = 4 if ctype == 6 else 3
        elif tag == b"IDAT":
            idat += body
        pos += 12 + n
    raw = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(h, 1 + w * ch)
    if raw[:, 0].any():
        raise ValueError(f"{path}: filtered rows (not written by write_png)")
    px = raw[:, 1:].reshape(h, w, ch)
    if ch == 3:
        px = np.concatenate([px, np.full((h, w, 1), 255, np.uint8)], axis=-1)
    return px


# ------------------------------------------------------------------------------------------- geometry
def report_geometry(plan, n_t=61, n_profile=720, tolerance=None):
    """What the report shows, from a flank-plan/1 dict (rotor frame, plan units):

    rotor: (verts, faces) of the helical body over one lead; strips: per strip (verts, faces, deviation)
    with the exact signed distance of each envelope vertex to the rotor surface (+ = outside = material
    left); tolerance: the plan's (or the given one); max_error / min_error: the plan's summary (its
    simulated errors) else the strips' vertex extremes."""
    from .exports import strip_mesh
    from .plan import plan_surface
    from .rotors import helical_body_mesh

    rot = plan["rotor"]
    surf = plan_surface(plan)
    v0, hand = float(rot["v0"]), rot["handedness"]
    lead = 2.0 * math.pi * v0
    rv, rf = helical_body_mesh(surf.profile, v0, hand, lead, n_profile=n_profile, n_axial=48)
    strips = []
    for k in range(len(plan["strips"])):
        v, f = strip_mesh(plan, k, n_t=n_t)
        d = surf.foot_points(v).distance if len(v) else np.zeros(0)
        strips.append((v, f, np.asarray(d, float)))
    tol = tolerance if tolerance is not None else plan.get("tolerance")
    R = float(rot.get("outer_radius") or np.max(np.linalg.norm(np.asarray(rot["profile"], float), axis=1)))
    if tol is None or not tol > 0:
        tol = 1e-3 * R
    summ = plan.get("summary") or {}
    allv = np.concatenate([d for _, _, d in strips]) if strips else np.zeros(0)
    mx = summ.get("max_error", float(allv.max()) if len(allv) else None)
    mn = summ.get("min_error", float(allv.min()) if len(allv) else None)
    return dict(rotor=(rv, rf), strips=strips, tolerance=float(tol), max_error=mx, min_error=mn,
                unit=plan.get("length_unit", "R"), method=plan.get("method", ""), outer_radius=R)


# ------------------------------------------------------------------------------------------- picture
def _mesh_object(bpy, sc, made, name, verts, faces, rgba):
    me = bpy.data.meshes.new(name)
    made["meshes"].append(me)
    me.vertices.add(len(verts))
    me.vertices.foreach_set("co", np.asarray(verts, np.float32).ravel())
    me.loops.add(3 * len(faces))
    me.loops.foreach_set("vertex_index", np.asarray(faces, np.int32).ravel())
    me.polygons.add(len(faces))
    me.polygons.foreach_set("loop_start", np.arange(0, 3 * len(faces), 3, dtype=np.int32))
    me.update()
    _paint(me, rgba)
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


def _text(bpy, sc, made, cam, body, x, y, size, rgba=(0.08, 0.08, 0.1, 1.0)):
    """Text in the camera's view plane: (x, y) in camera units from the frame centre, left-bottom aligned."""
    cu = bpy.data.curves.new("Report Label", 'FONT')
    cu.body = body
    cu.size = size
    tmp = bpy.data.objects.new("Report Label", cu)
    sc.collection.objects.link(tmp)
    me = bpy.data.meshes.new_from_object(tmp)
    bpy.data.objects.remove(tmp)
    bpy.data.curves.remove(cu)
    made["meshes"].append(me)
    _paint(me, rgba)
    ob = bpy.data.objects.new("Report Label", me)
    made["objects"].append(ob)
    sc.collection.objects.link(ob)
    ob.parent = cam
    ob.location = (x, y, -1.0)
    return ob


def _look_at(eye, target, up=(0.0, 0.0, 1.0)):
    """4x4 camera matrix at eye looking at target (-Z forward, Y up)."""
    f = np.asarray(target, float) - eye
    f /= np.linalg.norm(f)
    r = np.cross(f, up)
    if np.linalg.norm(r) < 1e-9:
        r = np.cross(f, (1.0, 0.0, 0.0))
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    M = np.eye(4)
    M[:3, 0], M[:3, 1], M[:3, 2], M[:3, 3] = r, u, -f, eye
    return M


def render_plan_report(bpy, plan, path, width=1280, height=800, tolerance=None, title=None, geometry=None):
    """Render the report picture of ``plan`` to the PNG ``path`` with the given ``bpy`` module.

    Nothing stays behind in Blender: a temporary scene with its objects, meshes, camera and world is made,
    rendered and removed.  Returns dict(seconds, width, height, legend (name -> [x0, y0, x1, y1] pixel box,
    top-left origin, and the sRGB bytes), title, max_error, min_error, tolerance)."""
    import time

    if not (isinstance(width, int) and isinstance(height, int) and 64 <= width <= 8192 and 64 <= height <= 8192):
        raise ValueError(f"resolution {width} x {height} is outside the limits 64..8192")
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise ValueError(f"the folder {folder!r} does not exist")
    t0 = time.perf_counter()
    geo = geometry if geometry is not None else report_geometry(plan, tolerance=tolerance)
    from .verify import deviation_colors

    tol, unit = geo["tolerance"], geo["unit"]
    made = {"objects": [], "meshes": [], "cameras": [], "worlds": [], "scenes": [], "images": []}
    tmp_png = "{}.render{}.png".format(os.path.abspath(path), os.getpid())
    try:
        sc = bpy.data.scenes.new("Flank Report (temporary)")
        made["scenes"].append(sc)
        r = sc.render
        r.engine = 'BLENDER_WORKBENCH'
        r.resolution_x, r.resolution_y, r.resolution_percentage = width, height, 100
        r.image_settings.file_format = 'PNG'
        r.image_settings.color_mode = 'RGBA'
        r.film_transparent = False
        sc.view_settings.view_transform = 'Standard'
        sh = sc.display.shading
        sh.light, sh.color_type = 'STUDIO', 'VERTEX'
        sh.show_cavity = sh.show_object_outline = False
        world = bpy.data.worlds.new("Flank Report World")
        made["worlds"].append(world)
        world.color = (0.93, 0.93, 0.94)
        sc.world = world

        rv, rf = geo["rotor"]
        # the strips lie on the rotor where they machine it: the body is drawn 0.4 % thinner (picture only)
        _mesh_object(bpy, sc, made, "Report Rotor", np.asarray(rv) * [0.996, 0.996, 1.0], rf,
                     (0.62, 0.62, 0.64, 1.0))
        pts = []
        for k, (v, f, d) in enumerate(geo["strips"]):
            if len(f):
                _mesh_object(bpy, sc, made, "Report Strip {}".format(k + 1), v, f, deviation_colors(d, tol))
                pts.append(v)
        P = np.concatenate(pts) if pts else np.asarray(rv)
        lo, hi = P.min(axis=0), P.max(axis=0)
        target = 0.5 * (lo + hi)
        radial = np.array([target[0], target[1], 0.0])
        radial = radial / np.linalg.norm(radial) if np.linalg.norm(radial) > 1e-9 else np.array([1.0, 0.0, 0.0])
        view = radial + np.array([0.0, 0.0, 0.35])
        view /= np.linalg.norm(view)
        Rr = geo["outer_radius"]
        eye = target + view * 6.0 * Rr
        camd = bpy.data.cameras.new("Report Camera")
        made["cameras"].append(camd)
        camd.type = 'ORTHO'
        extent = float(np.max(hi - lo))
        camd.ortho_scale = 1.35 * max(extent, 0.2 * Rr) * max(1.0, width / height) * 1.1
        camd.clip_start, camd.clip_end = 0.01 * Rr, 20.0 * Rr
        cam = bpy.data.objects.new("Report Camera", camd)
        made["objects"].append(cam)
        sc.collection.objects.link(cam)
        from mathutils import Matrix

        cam.matrix_world = Matrix(_look_at(eye, target).tolist())
        sc.camera = cam

        # frame coordinates: the ortho scale spans the larger side
        half_w = 0.5 * camd.ortho_scale * (1.0 if width >= height else width / height)
        half_h = half_w * height / width

        def to_cam(px, py):          # pixel (top-left origin) -> camera plane coordinates
            return (px / width - 0.5) * 2.0 * half_w, (0.5 - py / height) * 2.0 * half_h

        px_per = width / (2.0 * half_w)
        fs = max(12, height // 40)                                # label height in pixels
        mx, mn = geo["max_error"], geo["min_error"]
        head = title or "Flank plan: {}".format(geo["method"] or "strips")
        line2 = "tolerance {}   max error {}   min error {}   {} strip(s)".format(
            format_length(tol, unit).lstrip("+"), format_length(mx, unit), format_length(mn, unit),
            len(geo["strips"]))
        x0, y0 = to_cam(0.03 * width, 0.03 * height + 1.6 * fs)
        _text(bpy, sc, made, cam, head, x0, y0, 1.5 * fs / px_per)
        x0, y0 = to_cam(0.03 * width, 0.03 * height + 3.2 * fs)
        _text(bpy, sc, made, cam, line2, x0, y0, fs / px_per)
        boxes = {}
        names = {"gouge": "overcut  d < {}".format(format_length(-tol, unit)),
                 "ok": "within tolerance  |d| <= {}".format(format_length(tol, unit).lstrip("+")),
                 "stock": "material left  d > {}".format(format_length(tol, unit))}
        sw = int(1.4 * fs)
        for i, (key, _) in enumerate(LEGEND_KEYS):
            bx, by = int(0.03 * width), int(height - 0.04 * height - (3 - i) * 1.8 * fs)
            boxes[key] = [bx, by, bx + sw, by + sw]
            tx, ty = to_cam(bx + sw + 0.6 * fs, by + sw - 0.2 * fs)
            _text(bpy, sc, made, cam, names[key], tx, ty, fs / px_per)

        bpy.ops.render.render(write_still=False, scene=sc.name)
        img = bpy.data.images.get("Render Result")
        sc.render.filepath = tmp_png
        img.save_render(filepath=tmp_png, scene=sc)
        loaded = bpy.data.images.load(tmp_png, check_existing=False)
        made["images"].append(loaded)
        w, h = loaded.size
        px = np.empty(w * h * 4, np.float32)
        loaded.pixels.foreach_get(px)
        rgba = np.round(255.0 * px.reshape(h, w, 4)[::-1]).astype(np.uint8)      # top row first
        cols = legend_colors()
        for key, (a0, b0, a1, b1) in boxes.items():
            rgba[b0:b1, a0:a1, :3] = cols[key]
            rgba[b0:b1, a0:a1, 3] = 255
            rgba[b0:b1, [a0, a1 - 1], :3] = rgba[[b0, b1 - 1], a0:a1, :3] = 40      # thin frame
        write_png(path, rgba)
    finally:
        for key, coll in (("objects", bpy.data.objects), ("meshes", bpy.data.meshes),
                          ("cameras", bpy.data.cameras), ("worlds", bpy.data.worlds),
                          ("images", bpy.data.images), ("scenes", bpy.data.scenes)):
            for block in made[key]:
                try:
                    coll.remove(block)
                except (ReferenceError, RuntimeError):
                    pass
        if os.path.exists(tmp_png):
            os.remove(tmp_png)
    cols = legend_colors()
    return dict(seconds=time.perf_counter() - t0, width=width, height=height,
                legend={k: dict(box=boxes[k], rgb=[int(c) for c in cols[k]]) for k in boxes},
                title=[head, line2], max_error=mx, min_error=mn, tolerance=tol, unit=unit)
