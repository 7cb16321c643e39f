# SPDX-License-Identifier: GPL-3.0-or-later
"""The Blender scene of a report picture: rotor, envelope strips by signed error, camera, labels and legend.

Everything the picture shows is computed by the core without Blender (``flank_addon.report.report_geometry``:
the geometry, the camera, the legend's layout, labels and exact colours); this module only turns it into a
temporary scene, renders it (Workbench by default, or Cycles on the CPU), lays the labels out in Blender's font
and removes every data-block it made, whatever happens.  The rest is numpy, for any thread: the Workbench
render's edges are smoothed (``flank_addon.report.antialias``), the legend bar painted and the labels filled in
(``chart_text``).  ``flank.render_report`` and the command
``python -m flank_addon render`` both call :func:`render_plan_report`.
"""
import itertools
import json
import math
import os
import time

import bpy
import numpy as np
from mathutils import Matrix

from ..flank_addon.io.files import atomic_write
from ..flank_addon.io.png import check_output, png_bytes
from ..flank_addon.report import report_geometry as rg
from ..flank_addon.report.antialias import fxaa
from .chart_text import fill_text, text_outlines

_KINDS = ("objects", "meshes", "cameras", "lights", "materials", "worlds", "images", "scenes")
# numbers each report's temporary files: a Cycles report renders for tens of seconds in a second Blender while
# another report of the same picture may start
_RUNS = itertools.count(1)


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


def _link(sc, made, name, data, material=None):
    if material is not None:
        data.materials.append(material)
    ob = bpy.data.objects.new(name, data)
    made["objects"].append(ob)
    sc.collection.objects.link(ob)
    return ob


def _mesh_object(sc, made, name, verts, faces, rgba, material=None, smooth=False):
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
    return _link(sc, made, name, me, material)


def _attribute_material(made, name):
    """Cycles: a lit material showing the 'report_color' attribute."""
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


def _new_scene(made, width, height, engine):
    """The temporary scene with its render settings and world -> (scene, surface material); the material is
    None for Workbench, which shows the colour attribute directly."""
    sc = bpy.data.scenes.new("Flank Report (temporary)")
    made["scenes"].append(sc)
    r = sc.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = width, height, 100
    r.image_settings.file_format = 'TARGA_RAW'        # read back by tga_pixels, in any thread
    r.image_settings.color_mode = 'RGBA'
    r.film_transparent = False
    r.dither_intensity = 0.0           # no noise: exact flat colours, small PNGs
    sc.view_settings.view_transform = 'Standard'
    world = bpy.data.worlds.new("Flank Report World")
    made["worlds"].append(world)
    world.color = (0.93, 0.93, 0.94)
    sc.world = world
    if engine == "WORKBENCH":
        r.engine = 'BLENDER_WORKBENCH'
        sh = sc.display.shading
        sh.light, sh.color_type = 'STUDIO', 'VERTEX'
        sh.show_cavity = sh.show_object_outline = False
        # no anti-aliasing pass in Blender: its single-pass anti-aliasing took longer than the render itself on
        # the main thread (at 1280 x 800 the render call took 285-400 ms with it, 96-132 ms without); report_png
        # smooths the edges in numpy instead (any thread), and the text is drawn there with its own coverage
        sc.display.render_aa = 'OFF'
        r.use_compositing = r.use_sequencer = False
        return sc, None
    r.engine = 'CYCLES'
    if not hasattr(sc, "cycles"):
        raise ValueError("Cycles is not available in this Blender")
    sc.cycles.device = 'CPU'
    sc.cycles.samples = 16
    sc.cycles.use_denoising = True
    _cycles_world(world)
    return sc, _attribute_material(made, "Flank Report Surface")


def _add_geometry(sc, made, picture, surface_mat):
    """The rotor and the drawn strip parts of ``picture`` (:func:`report_geometry.report_picture`)."""
    rv, rf = picture["rotor"]
    _mesh_object(sc, made, "Report Rotor", rv, rf, (0.62, 0.62, 0.64, 1.0), surface_mat)
    for name, verts, faces, colors in picture["strips"]:
        _mesh_object(sc, made, name, verts, faces, colors, surface_mat, smooth=True)


def _add_camera(sc, made, M, ortho, clip_end, R):
    camd = bpy.data.cameras.new("Report Camera")
    made["cameras"].append(camd)
    camd.type = 'ORTHO'
    camd.sensor_fit = 'AUTO'
    camd.ortho_scale = ortho
    camd.clip_start, camd.clip_end = 0.01 * R, clip_end
    cam = _link(sc, made, "Report Camera", camd)
    cam.matrix_world = Matrix(M.tolist())
    sc.camera = cam


def _add_sun(sc, made, M):
    """Cycles: a sun from above-left of the camera."""
    ld = bpy.data.lights.new("Flank Report Light", type='SUN')
    made["lights"].append(ld)
    ld.energy = 3.0
    lamp = _link(sc, made, "Flank Report Light", ld)
    turn = Matrix.Rotation(math.radians(25.0), 3, 'Y') @ Matrix.Rotation(math.radians(-30.0), 3, 'X')
    L = Matrix(M.tolist())
    L = Matrix.Translation(L.translation) @ (L.to_3x3() @ turn).to_4x4()
    lamp.matrix_world = L


def _label_items(lay, lines, legend, width):
    """The picture's text -- title, subtitle, tick labels, band names, the bar's caption -- as chart text items
    (``chart_text``: anchor and baseline in pixels, font size in pixels, colour as the PNG stores it)."""
    fs = lay["fs"]
    mx = lay["margin"][0]
    _, ticks, tick_text, names = legend
    colour = tuple(float(c) / 255.0 for c in rg.srgb_bytes(rg.TEXT_RGBA[:3])) + (1.0,)

    def item(text, x, baseline, size, align="left"):
        return dict(text=str(text), x=float(x), baseline=float(baseline), size=float(size), align=align,
                    color=colour)

    items = [item(lines[0], mx, lay["title"][0], 1.5 * fs), item(lines[1], mx, lay["title"][1], fs)]
    items += [item(txt, x, lay["tick_base"], 0.85 * fs, "center") for (x, _), txt in zip(ticks, tick_text)]
    items += [item(txt, x, lay["names_base"], 0.9 * fs, "center") for x, txt in names]
    caption = "signed distance strip - rotor"
    bx0, by0, bx1, by1 = lay["bar"]
    if bx1 + 1.5 * fs + 0.5 * fs * len(caption) < width - mx:
        items.append(item(caption, bx1 + 1.5 * fs, 0.5 * (by0 + by1) + 0.35 * fs, 0.85 * fs))
    return items


def _remove_made(made, fonts_before, had_render_result, tmp):
    for key in _KINDS:
        coll = getattr(bpy.data, key)
        for block in made[key]:
            try:
                coll.remove(block)
            except (ReferenceError, RuntimeError):
                pass
    for font in list(bpy.data.fonts):           # a font the scene loaded (the labels' layout removes its own)
        if font.as_pointer() not in fonts_before and font.users == 0:
            bpy.data.fonts.remove(font)
    if not had_render_result:
        img = bpy.data.images.get("Render Result")
        if img is not None:
            try:
                bpy.data.images.remove(img)
            except (ReferenceError, RuntimeError):
                pass
    if os.path.exists(tmp):
        os.remove(tmp)


def report_scene_start(picture, path):
    """The temporary scene of ``picture`` (:func:`report_geometry.report_picture`), to be rendered into the PNG
    ``path`` -> its state for :func:`report_scene_render`; :func:`report_scene_end` removes it whatever
    happens (here, if building it fails)."""
    path = check_output(path)
    width, height, R, engine = picture["width"], picture["height"], picture["R"], picture["info"]["engine"]
    M, lay = picture["camera"], picture["layout"]
    state = dict(made={k: [] for k in _KINDS}, fonts_before={f.as_pointer() for f in bpy.data.fonts},
                 had_render_result=bpy.data.images.get("Render Result") is not None,
                 tmp="{}.render{}-{}.tga".format(path, os.getpid(), next(_RUNS)), scene=None, path=path,
                 width=width, height=height, ortho=picture["ortho"])
    try:
        sc, surface_mat = _new_scene(state["made"], width, height, engine)
        _add_geometry(sc, state["made"], picture, surface_mat)
        _add_camera(sc, state["made"], M, picture["ortho"], picture["clip_end"], R)
        if engine == "CYCLES":
            _add_sun(sc, state["made"], M)
    except BaseException:
        report_scene_end(state)
        raise
    state["scene"] = sc
    return state


def report_scene_labels(state, picture):
    """Lay the picture's labels out in Blender's font (``state["labels"]``, for :func:`report_png`, which fills
    them in from any thread): a turn of its own in ``flank.render_report``, about 15 ms."""
    items = _label_items(picture["layout"], picture["lines"], picture["legend"], picture["width"])
    state["labels"] = (items, text_outlines(items))


def report_tiles(picture):
    """The pieces the picture is rendered in, (x0, y0, x1, y1) with the origin top left: Workbench renders
    tiles of at most ``report_geometry.TILE_PIXELS`` pixels, each in a short turn of the main thread (they meet
    without seams: every edge pixel is smoothed afterwards, on the whole picture); Cycles renders the whole
    picture at once (its denoiser looks across tile borders)."""
    width, height = picture["width"], picture["height"]
    if picture["info"]["engine"] == "WORKBENCH":
        return rg.render_tiles(width, height)
    return [(0, 0, width, height)]


def report_scene_prepare(state):
    """Render the scene once at 16 x 10 pixels: Blender prepares the meshes for drawing (and, the first time in
    a session, its renderer), so that the tiles' turns only draw.  About 25 ms with the 69,000-triangle rotor.
    Cycles, which renders the picture in one piece, is left alone."""
    sc = state["scene"]
    if sc.render.engine != 'BLENDER_WORKBENCH':
        return
    r = sc.render
    size = r.resolution_x, r.resolution_y
    r.resolution_x, r.resolution_y = 16, 10
    try:
        bpy.ops.render.render(write_still=False, scene=sc.name)
    finally:
        r.resolution_x, r.resolution_y = size


def report_scene_render(state, tile=None):
    """Render the scene, or only the pixels ``tile`` = (x0, y0, x1, y1) of its picture (:func:`report_tiles`)
    -> the pixels as the bytes of an uncompressed TGA file (:func:`tga_pixels` reads them, in any thread:
    Blender only renders and writes the file here)."""
    sc = state["scene"]
    if tile is not None and tuple(tile) != (0, 0, state["width"], state["height"]):   # else the scene's own camera
        r, cam = sc.render, sc.camera.data
        r.resolution_x, r.resolution_y, cam.ortho_scale, cam.shift_x, cam.shift_y = rg.tile_camera(
            tile, state["width"], state["height"], state["ortho"])
    done = bpy.ops.render.render(write_still=False, scene=sc.name)
    if 'FINISHED' not in done:        # else save_render would save the previous tile's pixels again
        raise RuntimeError("Blender's render of the report ended {}".format(", ".join(sorted(done))))
    img = bpy.data.images.get("Render Result")
    if img is None:
        raise RuntimeError("the render produced no image")
    img.save_render(filepath=state["tmp"], scene=sc)
    try:
        with open(state["tmp"], "rb") as fh:
            return fh.read()
    finally:
        os.remove(state["tmp"])           # nothing beside the report between the turns


def report_scene_file(state):
    """Write the scene (with its objects, meshes, materials, camera, light and world) to a .blend file beside the
    report, for a separate Blender to render (``report_process``) -> (the file's path, the scene's name).  A few
    milliseconds on the main thread; the caller removes the file."""
    sc = state["scene"]
    blend = state["tmp"][:-len(".tga")] + ".blend"
    # Blender 5.2 crashed writing a scene whose view layer was never evaluated (a new scene that no window shows)
    sc.view_layers[0].update()
    try:
        bpy.data.libraries.write(blend, {sc}, path_remap='NONE', fake_user=False, compress=False)
    except BaseException:
        if os.path.exists(blend):
            os.remove(blend)
        raise
    return blend, sc.name


def report_scene_end(state):
    """Remove everything :func:`report_scene_start` made (the scene, its objects and data, the loaded font, the
    render result if there was none before, the temporary file)."""
    _remove_made(state["made"], state["fonts_before"], state["had_render_result"], state["tmp"])
    state["scene"] = None


def tga_pixels(data, width, height):
    """(H, W, 4) uint8, top row first, of an uncompressed 32-bit TGA file's bytes (as Blender's TARGA_RAW writes:
    blue, green, red, alpha; rows from the bottom unless the header says from the top); alpha set to 255."""
    head = np.frombuffer(data[:18], np.uint8)
    w, h = int(head[12]) | int(head[13]) << 8, int(head[14]) | int(head[15]) << 8
    if head[2] != 2 or head[16] != 32:
        raise RuntimeError(f"the render was not saved as an uncompressed 32-bit TGA (type {head[2]}, {head[16]} bits)")
    if (w, h) != (width, height):
        raise RuntimeError(f"the render is {w} x {h}, not {width} x {height}")
    start = 18 + int(head[0])
    px = np.frombuffer(data[start:start + 4 * w * h], np.uint8).reshape(h, w, 4)
    if not head[17] & 0x20:                    # bottom-left origin
        px = px[::-1]
    rgba = np.ascontiguousarray(px[..., [2, 1, 0, 3]])
    rgba[..., 3] = 255
    return rgba


def tiled_pixels(pieces, width, height):
    """The picture's (H, W, 4) uint8 pixels from its rendered tiles: ``pieces`` = [(tile, TGA bytes)] as
    :func:`report_tiles` and :func:`report_scene_render` give them.  numpy only: any thread."""
    rgba = np.zeros((height, width, 4), np.uint8)
    covered = np.zeros((height, width), bool)
    for (x0, y0, x1, y1), data in pieces:
        rgba[y0:y1, x0:x1] = tga_pixels(data, x1 - x0, y1 - y0)
        covered[y0:y1, x0:x1] = True
    if not covered.all():
        raise RuntimeError("the rendered tiles leave {} of {} pixels empty".format(int((~covered).sum()), covered.size))
    return rgba


def report_png(picture, rgba, labels):
    """The finished report: the render's edges smoothed (Workbench), the legend bar painted and the text filled
    into the render's pixels -> (PNG bytes with the report's numbers in a text chunk, info).  ``labels``: the
    state's ``labels`` (:func:`report_scene_labels`).  numpy only: any thread."""
    lay, legend = picture["layout"], picture["legend"]
    if picture["info"]["engine"] == "WORKBENCH":                # rendered without anti-aliasing (_new_scene)
        rgba = fxaa(rgba)
    rgba = rg.paint_legend(rgba, lay, picture["tolerance"], legend[0], legend[1])
    ink = rgba.astype(np.float64) / 255.0
    fill_text(ink, *labels)
    rgba = np.rint(ink * 255.0).astype(np.uint8)
    info = dict(picture["info"])
    return png_bytes(rgba, {rg.REPORT_KEY: json.dumps(info, ensure_ascii=False)}), info


def draw_report(picture, path):
    """Render ``picture`` (:func:`report_geometry.report_picture`) to the PNG ``path`` -> its ``info`` dict.

    Nothing stays behind in Blender: a temporary scene with its objects, meshes, camera, world (and for Cycles
    materials and a light) is made, rendered and removed, and so is the builtin font if the file had none.
    (``flank.render_report`` runs the same steps, the Blender ones in separate turns of the main thread, one
    per tile.)"""
    state = report_scene_start(picture, path)
    try:
        report_scene_labels(state, picture)
        pieces = [(tile, report_scene_render(state, tile)) for tile in report_tiles(picture)]
    finally:
        report_scene_end(state)
    png, info = report_png(picture, tiled_pixels(pieces, picture["width"], picture["height"]), state["labels"])
    atomic_write(state["path"], png)
    return info


def render_plan_report(plan, path, width=1280, height=800, tolerance=None, title=None, geometry=None,
                       engine="WORKBENCH", units=None):
    """Render the report picture of ``plan`` (or of the given ``geometry``) to the PNG ``path``:
    :func:`report_geometry.report_picture`, then :func:`draw_report`.

    engine: 'WORKBENCH' (default) or 'CYCLES' (CPU, 16 samples); units: (factor, unit) from
    ``report_geometry.display_units`` (default: the plan's unit).  Returns dict(seconds, width, height, engine,
    legend (bar box [x0, y0, x1, y1) top-left origin, tick labels and positions, band names), title (two
    lines), max_error, min_error, tolerance (plan units), units); the same dict is stored in the PNG."""
    t0 = time.perf_counter()
    engine = rg.check_render_args(width, height, tolerance, engine)
    check_output(path)
    geo = geometry if geometry is not None else rg.report_geometry(plan, tolerance=tolerance)
    info = draw_report(rg.report_picture(geo, width, height, title=title, units=units, engine=engine), path)
    info["seconds"] = time.perf_counter() - t0
    return info


def render_freeform_report(plan, path, width=1280, height=800, tolerance=None, title=None, engine="WORKBENCH",
                           units=None):
    """Render the report of a free-form plan to the PNG ``path`` (see :func:`render_plan_report`): the surface,
    the envelope strips by their exact signed distance to it, and the kink angles in the title."""
    from ..flank_addon.report.freeform_geometry import freeform_geometry, freeform_title

    geo = freeform_geometry(plan, tolerance)
    return render_plan_report(plan, path, width=width, height=height, tolerance=tolerance,
                              title=title or freeform_title(plan), geometry=geo, engine=engine, units=units)


classes = ()
register, unregister = bpy.utils.register_classes_factory(classes)
