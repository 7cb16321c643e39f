# SPDX-License-Identifier: GPL-3.0-or-later
"""Text on charts shown inside Blender, in Blender's own font.

The planner draws a chart's axes, bands and curves with numpy and lists its text items (string, anchor pixel,
baseline, size, alignment, colour: ``flank_addon.report.error_chart.text_item``).  Each item becomes a temporary
text object: Blender lays the string out (its built-in font, kerning, alignment) and turns the glyphs into outline
polylines (``Object.to_mesh`` of the text curve without fill); the outlines are filled into the picture by their
even-odd coverage at 4 x 4 samples per pixel (anti-aliased).

Why not ``blf.bind_imbuf`` + ``blf.draw_buffer``: Blender 4.2 LTS (the oldest Blender this extension supports)
has neither (they came in 4.5), and an ImBuf's pixels can only be read back through a file.  Why not a render of
text objects: that needs a render engine with a GPU or Cycles and runs on the main thread, while this works in
background mode, fills the glyphs in any thread and gives the same pixels everywhere.  The report picture's
labels are drawn the same way, over its render."""
import bpy
import numpy as np

from .common import mesh_vertices

ALIGN = {"left": 'LEFT', "center": 'CENTER', "right": 'RIGHT'}
SAMPLES = 4                        # coverage samples per pixel along x and y


def text_outline(text, size, align="left"):
    """Blender's outline of one line of ``text`` at font size ``size`` (pixels): (E, 2, 2) segments in pixels
    relative to the anchor (x right, y up, baseline at y = 0); closed polylines, holes included."""
    cu = bpy.data.curves.new("Chart Text", 'FONT')
    ob = None
    try:
        cu.body = text
        cu.size = float(size)
        cu.align_x = ALIGN[align]
        cu.fill_mode = 'NONE'                  # the glyphs' outlines only, as edges
        ob = bpy.data.objects.new("Chart Text", cu)
        me = ob.to_mesh()
        try:
            co = mesh_vertices(me)
            ed = np.empty(len(me.edges) * 2, dtype=np.int64)
            me.edges.foreach_get("vertices", ed)
        finally:
            ob.to_mesh_clear()
    finally:
        if ob is not None:
            bpy.data.objects.remove(ob)
        bpy.data.curves.remove(cu)
    return co[:, :2][ed.reshape(-1, 2)]


def _coverage(seg, x0, y0, w, h):
    """Even-odd coverage (h, w) in [0, 1] of the closed outlines ``seg`` (E, 2, 2; picture pixels, y down) over
    the pixels x0 .. x0 + w - 1, y0 .. y0 + h - 1."""
    n = SAMPLES
    xs = x0 + (np.arange(w * n) + 0.5) / n
    inside = np.zeros((h * n, w * n), dtype=bool)
    ya, yb, xa, xb = seg[:, 0, 1], seg[:, 1, 1], seg[:, 0, 0], seg[:, 1, 0]
    for i, y in enumerate(y0 + (np.arange(h * n) + 0.5) / n):
        m = (ya <= y) != (yb <= y)                     # edges crossing this sample row (half-open)
        if m.any():
            xc = np.sort(xa[m] + (y - ya[m]) * (xb[m] - xa[m]) / (yb[m] - ya[m]))
            inside[i] = np.searchsorted(xc, xs) % 2 == 1
    return inside.reshape(h, n, w, n).mean(axis=(1, 3))


def text_box(seg, shape):
    """The pixel box (x0, y0, x1, y1), ends exclusive, that the drawn item covers, clipped to the picture
    (None when it lies outside); ``seg``: its outline placed in the picture."""
    if not len(seg):
        return None
    lo, hi = seg.reshape(-1, 2).min(axis=0), seg.reshape(-1, 2).max(axis=0)
    x0, y0 = max(int(np.floor(lo[0])), 0), max(int(np.floor(lo[1])), 0)
    x1, y1 = min(int(np.ceil(hi[0])) + 1, shape[1]), min(int(np.ceil(hi[1])) + 1, shape[0])
    return (x0, y0, x1, y1) if x1 > x0 and y1 > y0 else None


def _width(seg):
    return float(np.ptp(seg[..., 0])) if len(seg) else 0.0


def fitted_outline(item):
    """The item's outline relative to its anchor; a text wider than the item's ``max_width`` is shortened with
    an ellipsis to the longest head that fits (Blender's own measure of the glyphs)."""
    text, size, align = item["text"], item["size"], item.get("align", "left")
    seg = text_outline(text, size, align)
    limit = item.get("max_width")
    if limit is None or _width(seg) <= limit:
        return seg
    lo, hi = 0, len(text)                 # head lengths: lo fits (or is empty), hi does not
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if _width(text_outline(text[:mid].rstrip() + "…", size, align)) <= limit:
            lo = mid
        else:
            hi = mid
    return text_outline(text[:lo].rstrip() + "…", size, align)


def place(item):
    """The item's outline in picture pixels (x right, y down): anchor at (x, baseline)."""
    seg = fitted_outline(item) * np.array([1.0, -1.0])
    return seg + np.array([float(item["x"]), float(item["baseline"])])


def text_outlines(items):
    """Each item's outline placed in the picture (:func:`place`): Blender's part of drawing the text, for the main
    thread.  No data-block is left behind."""
    fonts_before = {f.as_pointer() for f in bpy.data.fonts}
    try:
        return [place(item) for item in items]
    finally:
        for font in list(bpy.data.fonts):           # the built-in font the text objects loaded
            if font.as_pointer() not in fonts_before and font.users == 0:
                bpy.data.fonts.remove(font)


def fill_text(rgba, items, outlines):
    """Fill the items' placed ``outlines`` into ``rgba`` (H, W, 4) float, top row first, in the items' colours;
    values are rounded to k / 255 again (an 8-bit image or PNG holds them exactly).  numpy only: any thread may
    run it.  Returns the boxes drawn, one per item (None for an item with no ink inside the picture)."""
    boxes = []
    for item, seg in zip(items, outlines):
        box = text_box(seg, rgba.shape)
        boxes.append(box)
        if box is None:
            continue
        x0, y0, x1, y1 = box
        a = _coverage(seg, x0, y0, x1 - x0, y1 - y0)[..., None] * float(item["color"][3])
        col = np.asarray(item["color"][:3], dtype=np.float64)
        rgba[y0:y1, x0:x1, :3] = rgba[y0:y1, x0:x1, :3] * (1.0 - a) + col * a
    rgba[..., :3] = np.rint(np.clip(rgba[..., :3], 0.0, 1.0) * 255.0) / 255.0
    return boxes


def draw_text_items(rgba, items):
    """Draw the text items into ``rgba`` (see :func:`fill_text`) on the main thread, in one go."""
    return fill_text(rgba, items, text_outlines(items))


classes = ()
register, unregister = bpy.utils.register_classes_factory(classes)
