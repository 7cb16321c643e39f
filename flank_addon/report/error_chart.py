"""A chart of the signed machining error along the flank profile, rasterised with numpy alone.

x: the position along the target flank profile (share of its arc length, 0..100 %); y: the signed error
(positive = material left / undercut, negative = overcut / gouge) in a display unit, shown in µm when the unit
is millimetres and every value is below 1 mm.  The chart has the zero line, the +-tolerance band, one curve
per strip (or one combined curve), axis ticks with labels, a title and a legend.  Each curve pixel has the
colour :func:`verify.deviation_colors` gives the error at that pixel (red overcut, green within tolerance,
blue material left; the shade deepens with the distance from the band), encoded as sRGB like the report
picture (``report_render.srgb_bytes``), so that an 8-bit image or PNG holds exactly these values.

The chart's text is not drawn here: the picture comes with a list of text items (string, anchor pixel,
baseline, size, alignment, colour) that the caller draws in a real font (Blender's, in ``flank.error_plot``).
The layout reserves room for them with an estimate of their width (:func:`text_width`).

* :func:`error_profile` -- the data: the verify engine's deviation on the target flanks of a flank-plan/1
  (the same numbers as the error-profile CSV export), ordered along the profile, with the strip that forms
  the machined surface at each point.
* :func:`plot_layout` -- where the axes go for given data and image size (also used by the tests).
* :func:`render_error_plot` -- the (H, W, 4) float32 RGBA picture, top row first, and its text items.
* :func:`plan_error_plot` -- both for a plan, as the Blender operator ``flank.error_plot`` uses them.
"""
import math

import numpy as np

# ------------------------------------------------------------------------------------------- text
# The text items' metrics at font scale 1, in pixels: a font of size FONT_SIZE has capitals about CAP high; one
# line of text takes LINE; CHAR_ADVANCE per character is a generous estimate of the drawn width (digits of
# Blender's font at this size are 4.9 px wide), so the layout keeps room for any label.
FONT_SIZE = 10
CAP = 7
LINE = 10
CHAR_ADVANCE = 6


def text_width(text, scale=1):
    """Estimated width in pixels of one line of ``text`` at an integer ``scale`` (room the layout keeps)."""
    return max(0, len(text) * CHAR_ADVANCE - 1) * int(scale)


def text_item(text, x, y, rgba, scale=1, align="left", role="", max_width=None):
    """A text item for the caller to draw: ``text`` whose capitals fill the rows y .. y + CAP * scale (so its
    baseline is row ``baseline``), anchored at column ``x`` (``align`` 'left', 'center' or 'right': x is the
    left end, the middle or the right end), font size ``size`` pixels, colour ``color`` (RGBA, encoded as the
    picture's pixels), what it is (``role``), its estimated ``width`` and, if given, the ``max_width`` it may
    take (the caller shortens a longer text with an ellipsis)."""
    s = int(scale)
    return dict(text=str(text), x=float(x), baseline=float(y + CAP * s), top=float(y), size=float(FONT_SIZE * s),
                align=align, color=tuple(float(c) for c in rgba), role=role, width=float(text_width(text, s)),
                max_width=None if max_width is None else float(max_width))


# ------------------------------------------------------------------------------------------- colours
def srgb(rgba):
    """Linear RGBA (..., 4) -> the sRGB-encoded RGBA an 8-bit image stores, as floats k / 255 (alpha kept)."""
    from .report_geometry import srgb_bytes

    c = np.asarray(rgba, dtype=float)
    out = np.empty(c.shape, dtype=np.float32)
    out[..., :3] = srgb_bytes(c[..., :3]) / np.float32(255.0)
    out[..., 3] = np.clip(c[..., 3], 0.0, 1.0)
    return out


def _mix(a, b, t):
    return tuple((1.0 - t) * x + t * y for x, y in zip(a, b))


WHITE = (1.0, 1.0, 1.0, 1.0)
INK = (0.08, 0.08, 0.10, 1.0)            # text and frame (report_render.TEXT_RGBA)
GRID = (0.78, 0.78, 0.80, 1.0)
ZERO = (0.22, 0.22, 0.24, 1.0)
SEPARATOR = (0.45, 0.45, 0.48, 1.0)


def band_colors():
    """Linear RGBA of the tolerance band's fill and dashed edges: verify's 'within tolerance' colour, lighter
    (so that a curve running along an edge stays visible)."""
    from ..simulation.verify import DEVIATION_COLORS

    ok = DEVIATION_COLORS["ok"]
    return _mix(WHITE, ok, 0.12), _mix(WHITE, ok, 0.6)


def curve_colors(values, tolerance):
    """sRGB-encoded RGBA (N, 4) float32 of curve pixels whose error is ``values`` (verify.deviation_colors)."""
    from ..simulation.verify import deviation_colors

    return srgb(deviation_colors(values, tolerance))


# ------------------------------------------------------------------------------------------- axes
def nice_step(span, count):
    """1, 2 or 5 x 10^k: the smallest such step that cuts ``span`` into at most ~``count`` parts."""
    raw = float(span) / max(int(count), 1)
    if not raw > 0 or not math.isfinite(raw):
        raise ValueError("axis span must be positive and finite, got {!r}".format(span))
    k = math.floor(math.log10(raw))
    base = raw / 10.0 ** k
    m = next(v for v in (1.0, 2.0, 5.0, 10.0) if base <= v * (1 + 1e-9))
    return m * 10.0 ** k


def tick_values(lo, hi, step):
    """Multiples of ``step`` in [lo, hi]."""
    i0, i1 = math.ceil(lo / step - 1e-9), math.floor(hi / step + 1e-9)
    return [i * step for i in range(i0, i1 + 1)]


def tick_text(v, step):
    """A tick label: as many decimals as the step needs ('0' for zero, '1.5e-05'-style for tiny steps)."""
    if abs(v) < 1e-9 * step:
        return "0"
    if step >= 1e-4 and abs(v) < 1e6:
        dec = max(0, -int(math.floor(math.log10(step) + 1e-9)))
        return "{:.{}f}".format(v, dec)
    return "{:.3g}".format(v).replace("e-0", "e-").replace("e+0", "e+")


def axis_unit(unit, values):
    """(factor, label) for the y axis: millimetres become µm when every value is below 1 mm."""
    if unit == "mm" and max(abs(float(v)) for v in values) < 1.0:
        return 1000.0, "µm"
    return 1.0, unit


def _length_text(v, unit):
    """A length with its unit, µm below 1 mm (as report_render.format_length, unsigned)."""
    f, u = axis_unit(unit, [v])
    return "{:.3g} {}".format(v * f, u).strip()


def font_scale(width, height):
    """Integer text scale for an image size: 1 up to ~640 x 360, 2 at 960 x 540, 4 at 1920 x 1080."""
    return max(1, min(int(width) // 480, int(height) // 270))


class PlotLayout:
    """Where the chart goes in a ``width`` x ``height`` image (pixel rows from the top).

    ``box`` = (x0, y0, x1, y1): inclusive pixel bounds of the plotting area; x = ``x_range[0]`` maps to
    column x0 and ``x_range[1]`` to x1, y = ``y_range[1]`` to row y0 and ``y_range[0]`` to y1 (linear, rounded
    to the nearest pixel).  ``y_range``, ``y_ticks`` and ``tolerance`` are in the displayed unit
    ``y_unit`` = the input unit x ``y_factor`` (1000 when mm became µm)."""

    def __init__(self, **kw):
        self.__dict__.update(kw)

    def col(self, x):
        x0, _, x1, _ = self.box
        a, b = self.x_range
        return x0 + (np.asarray(x, dtype=float) - a) / (b - a) * (x1 - x0)

    def row(self, y_display):
        _, y0, _, y1 = self.box
        a, b = self.y_range
        return y0 + (b - np.asarray(y_display, dtype=float)) / (b - a) * (y1 - y0)

    def as_dict(self):
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in self.__dict__.items()}


MIN_SIZE = (200, 150)
MAX_SIZE = 8192


def _check_inputs(x, y, tolerance, width, height):
    x = np.asarray(x, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    if x.shape != y.shape:
        raise ValueError("x and y differ in length ({} vs {})".format(len(x), len(y)))
    if not len(x):
        raise ValueError("nothing to plot: the error profile is empty")
    fin = np.isfinite(x) & np.isfinite(y)
    if not fin.any():
        raise ValueError("nothing to plot: no point of the error profile has a finite error "
                         "(no tool reaches the flank)")
    tol = float(tolerance) if tolerance is not None else float("nan")
    if not (math.isfinite(tol) and tol > 0.0):
        raise ValueError("the tolerance must be a positive finite number, got {!r}".format(tolerance))
    w, h = int(width), int(height)
    if not (MIN_SIZE[0] <= w <= MAX_SIZE and MIN_SIZE[1] <= h <= MAX_SIZE):
        raise ValueError("image size {} x {} is outside {} x {} .. {} x {} pixels".format(
            w, h, MIN_SIZE[0], MIN_SIZE[1], MAX_SIZE, MAX_SIZE))
    return x, y, fin, tol, w, h


def plot_layout(x, y, tolerance, width=960, height=540, unit="", x_range=None, fit_data=False):
    """The :class:`PlotLayout` of :func:`render_error_plot` for the same arguments.

    The y range holds every finite value, zero and the +-tolerance band (with ``fit_data`` only the values
    and zero, unless they are all zero), with a 4 % margin, widened to whole tick steps; the x range is
    ``x_range`` or the finite x values' range (+-0.5 when they are all equal)."""
    x, y, fin, tol, w, h = _check_inputs(x, y, tolerance, width, height)
    ys = y[fin]
    lo, hi = min(float(ys.min()), 0.0), max(float(ys.max()), 0.0)
    if not fit_data or not hi - lo > 1e-12 * tol:
        lo, hi = min(lo, -tol), max(hi, tol)
    fy, y_unit = axis_unit(unit, [lo, hi])
    lo, hi = lo * fy, hi * fy
    if x_range is not None:
        xa, xb = float(x_range[0]), float(x_range[1])
        if not (math.isfinite(xa) and math.isfinite(xb) and xb > xa):
            raise ValueError("x_range must be two finite numbers, the first the smaller, got {!r}".format(x_range))
    else:
        xa, xb = float(x[np.isfinite(x)].min()), float(x[np.isfinite(x)].max())
        if not xb > xa:
            xa, xb = xa - 0.5, xb + 0.5

    fs = font_scale(w, h)
    ts = fs + 1 if w >= 600 else fs
    pad = 6 * fs
    tick = 3 * fs
    top = pad + LINE * ts + 2 * fs + LINE * fs + 2 * fs + LINE * fs + 4 * fs
    bottom = tick + 3 * fs + LINE * fs + 2 * fs + LINE * fs + pad
    plot_h = h - top - bottom
    if plot_h < 40:
        raise ValueError("image height {} leaves no room for the chart".format(h))
    span = hi - lo
    margin = 0.04 * span
    step = nice_step(span + 2 * margin, max(2, min(10, plot_h // (28 * fs))))
    ya = math.floor((lo - margin) / step + 1e-9) * step
    yb = math.ceil((hi + margin) / step - 1e-9) * step
    y_ticks = tick_values(ya, yb, step)
    labels = [tick_text(v, step) for v in y_ticks]
    left = pad + max(text_width(t, fs) for t in labels) + 2 * fs + tick
    # x ticks: the plot width depends on the right margin, which depends on the last label: estimate first
    x_step = nice_step(xb - xa, max(2, min(12, (w - left - pad) // (56 * fs))))
    x_ticks = tick_values(xa, xb, x_step)
    x_labels = [tick_text(v, x_step) for v in x_ticks]
    right = pad + text_width(x_labels[-1], fs) // 2 if x_labels else pad
    box = (left, top, w - right - 1, h - bottom - 1)
    if box[2] - box[0] < 50:
        raise ValueError("image width {} leaves no room for the chart".format(w))
    return PlotLayout(width=w, height=h, box=box, x_range=(xa, xb), y_range=(ya, yb), y_factor=fy,
                      y_unit=y_unit, input_unit=unit, y_step=step, y_ticks=y_ticks, y_labels=labels,
                      x_step=x_step, x_ticks=x_ticks, x_labels=x_labels, tolerance=tol * fy, font_scale=fs,
                      title_scale=ts, pad=pad, tick_length=tick, data_range=(float(ys.min()) * fy,
                                                                            float(ys.max()) * fy))


# ------------------------------------------------------------------------------------------- drawing
def _hline(img, row, c0, c1, rgba, dash=None):
    cols = np.arange(int(c0), int(c1) + 1)
    if dash:
        cols = cols[(cols - int(c0)) % (dash[0] + dash[1]) < dash[0]]
    if 0 <= row < img.shape[0]:
        img[int(row), cols[(cols >= 0) & (cols < img.shape[1])]] = rgba


def _vline(img, col, r0, r1, rgba, dash=None):
    rows = np.arange(int(r0), int(r1) + 1)
    if dash:
        rows = rows[(rows - int(r0)) % (dash[0] + dash[1]) < dash[0]]
    if 0 <= col < img.shape[1]:
        img[rows[(rows >= 0) & (rows < img.shape[0])], int(col)] = rgba


def _stamp(img, rows, cols, colors, width, clip):
    """Square brushes of ``width`` pixels centred on (rows, cols), clipped to the box ``clip``."""
    x0, y0, x1, y1 = clip
    lo = -((width - 1) // 2)
    for dr in range(lo, lo + width):
        for dc in range(lo, lo + width):
            r, c = rows + dr, cols + dc
            keep = (r >= y0) & (r <= y1) & (c >= x0) & (c <= x1)
            img[r[keep], c[keep]] = colors[keep]


def _curve_pixels(cx, cy, values, groups):
    """Sample every drawable segment (both ends finite, same group) at half-pixel steps.
    Returns (rows, cols, values) of the samples and of the isolated points (no drawable neighbour)."""
    ok = np.isfinite(cx) & np.isfinite(cy) & np.isfinite(values)
    seg = ok[:-1] & ok[1:] & (groups[:-1] == groups[1:])
    i = np.flatnonzero(seg)
    lone = ok.copy()
    lone[i] = False
    lone[i + 1] = False
    if len(i):
        dx, dy, dv = cx[i + 1] - cx[i], cy[i + 1] - cy[i], values[i + 1] - values[i]
        n = (np.ceil(2.0 * np.maximum(np.abs(dx), np.abs(dy))).astype(np.int64) + 1)
        start = np.r_[0, np.cumsum(n)[:-1]]
        seg_of = np.repeat(np.arange(len(i)), n)
        t = (np.arange(int(n.sum())) - start[seg_of]) / np.maximum(n[seg_of] - 1, 1)
        px = cx[i][seg_of] + t * dx[seg_of]
        py = cy[i][seg_of] + t * dy[seg_of]
        pv = values[i][seg_of] + t * dv[seg_of]
    else:
        px = py = pv = np.zeros(0)
    return (np.rint(py).astype(np.int64), np.rint(px).astype(np.int64), pv,
            np.rint(cy[lone]).astype(np.int64), np.rint(cx[lone]).astype(np.int64), values[lone])


def render_error_plot(x, y, tolerance, width=960, height=540, unit="", title="", x_label="", x_range=None,
                      groups=None, group_labels=None, line_width=None, legend=True, note="", fit_data=False):
    """The error-along-profile chart -> (picture, text items): the picture is an (height, width, 4) float32 RGBA
    array, row 0 = top, values k/255 (sRGB-encoded: what an 8-bit image or PNG stores) without any text; the
    text items (:func:`text_item`) are the labels, title and legend for the caller to draw in a font.

    ``x`` (N,): position along the profile (e.g. % of arc length); ``y`` (N,): signed error in ``unit``
    (positive = material left); NaN in y = no error there (not drawn; a grey tick at the bottom of the chart
    marks it); ``tolerance`` > 0 in ``unit``.  ``groups`` (N,) ints: consecutive points are joined only
    within a group (one curve per strip; default one group); ``group_labels``: group -> text shown above
    each of its stretches when there is room; ``note``: text right-aligned above the chart; ``fit_data``:
    the y range fits the errors alone (see :func:`plot_layout`).  Raises ValueError for no finite point, a bad tolerance or an
    image size outside 200 x 150 .. 8192 x 8192."""
    lay = plot_layout(x, y, tolerance, width, height, unit, x_range, fit_data)
    x = np.asarray(x, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    g = np.zeros(len(x), dtype=np.int64) if groups is None else np.asarray(groups).ravel().astype(np.int64)
    if g.shape != x.shape:
        raise ValueError("groups must have one entry per point")
    w, h, fs = lay.width, lay.height, lay.font_scale
    x0, y0, x1, y1 = lay.box
    lw = int(line_width) if line_width is not None else max(2, fs + 1)
    fy, tol = lay.y_factor, lay.tolerance
    img = np.empty((h, w, 4), dtype=np.float32)
    img[:] = srgb(WHITE)
    ink, grid, zero, sep = srgb(INK), srgb(GRID), srgb(ZERO), srgb(SEPARATOR)
    fill_lin, edge_lin = band_colors()
    fill, edge = srgb(fill_lin), srgb(edge_lin)

    # tolerance band, grid, band edges, zero line
    rt, rb = int(np.rint(lay.row(tol))), int(np.rint(lay.row(-tol)))
    img[max(rt, y0):min(rb, y1) + 1, x0:x1 + 1] = fill
    for v in lay.y_ticks:
        r = int(np.rint(lay.row(v)))
        if y0 < r < y1 and abs(v) > 1e-9 * lay.y_step:
            _hline(img, r, x0, x1, grid)
    for v in lay.x_ticks:
        c = int(np.rint(lay.col(v)))
        if x0 < c < x1:
            _vline(img, c, y0, y1, grid)
    for r in (rt, rb):
        if y0 <= r <= y1:
            _hline(img, r, x0, x1, edge, dash=(6 * fs, 4 * fs))
    _hline(img, int(np.rint(lay.row(0.0))), x0, x1, zero)

    cx = lay.col(x)
    cy = lay.row(y * fy)
    # where the profile has no error value: grey ticks along the bottom of the chart
    from ..simulation.verify import DEVIATION_COLORS

    # (a bar over each run of such points, reaching half-way to the neighbouring points)
    has_x = np.isfinite(cx)
    miss = has_x & ~np.isfinite(y)
    if miss.any():
        grey = srgb(DEVIATION_COLORS["untouched"])
        xi = np.flatnonzero(has_x)
        m = miss[xi]
        edges = np.diff(np.r_[0, m.astype(np.int8), 0])
        for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1):
            ca, cb = cx[xi[a]], cx[xi[b]]
            if a > 0:
                ca = 0.5 * (ca + cx[xi[a - 1]])
            if b + 1 < len(xi):
                cb = 0.5 * (cb + cx[xi[b + 1]])
            c0, c1 = max(int(np.rint(min(ca, cb))), x0), min(int(np.rint(max(ca, cb))), x1)
            img[y1 - 4 * fs + 1:y1 + 1, c0:c1 + 1] = grey

    # separators where the group changes between two neighbouring finite points, and the group labels
    fin = np.isfinite(cx) & np.isfinite(y)
    idx = np.flatnonzero(fin)
    change = idx[:-1][g[idx[:-1]] != g[idx[1:]]] if len(idx) > 1 else np.zeros(0, dtype=np.int64)
    nxt = {int(a): int(b) for a, b in zip(idx[:-1], idx[1:])}
    for a in change:
        c = int(np.rint(0.5 * (cx[a] + cx[nxt[int(a)]])))
        _vline(img, c, y0, y1, sep, dash=(2 * fs, 3 * fs))

    # the curves
    rows, cols, vals, lr, lc, lv = _curve_pixels(cx, cy, y, g)
    if len(rows):
        _stamp(img, rows, cols, curve_colors(vals, tolerance), lw, lay.box)
    if len(lr):
        _stamp(img, lr, lc, curve_colors(lv, tolerance), lw + 2, lay.box)

    texts = []
    if group_labels:
        bounds = np.r_[0, np.flatnonzero(g[idx][1:] != g[idx][:-1]) + 1, len(idx)] if len(idx) else []
        for a, b in zip(bounds[:-1], bounds[1:]):
            text = group_labels.get(int(g[idx[a]]))
            if not text:
                continue
            ca, cb = cx[idx[a]], cx[idx[b - 1]]
            if cb - ca >= text_width(text, fs) + 2 * fs:
                texts.append(text_item(text, int(round(0.5 * (ca + cb))), y0 + 2 * fs, ink, fs, "center", "group"))

    # frame, ticks
    _hline(img, y0 - 1, x0 - 1, x1 + 1, ink)
    _hline(img, y1 + 1, x0 - 1, x1 + 1, ink)
    _vline(img, x0 - 1, y0 - 1, y1 + 1, ink)
    _vline(img, x1 + 1, y0 - 1, y1 + 1, ink)
    tk = lay.tick_length
    for v in lay.y_ticks:
        img[int(np.rint(lay.row(v))), x0 - 1 - tk:x0 - 1] = ink
    for v in lay.x_ticks:
        img[y1 + 2:y1 + 2 + tk, int(np.rint(lay.col(v)))] = ink
    legend_items = _legend_items(tol, lay.y_unit, miss.any()) if legend else []
    _legend_swatches(img, lay, legend_items)
    return img, texts + _axis_text(lay, ink, x_label, note, title, legend_items)


def _legend_items(tol, unit, missing):
    """[(linear RGBA of the swatch, text)] of the legend: verify's colour classes."""
    from ..simulation.verify import DEVIATION_COLORS

    tol_txt = "{:.3g} {}".format(tol, unit).strip()
    items = [(DEVIATION_COLORS["gouge"], "overcut"), (DEVIATION_COLORS["ok"], "within ±" + tol_txt),
             (DEVIATION_COLORS["stock"], "material left")]
    if missing:
        items.append((DEVIATION_COLORS["untouched"], "no tool"))
    return items


def _legend_positions(lay, items):
    """Top-left pixel of each legend swatch and of its text, in a row under the title."""
    fs, sw = lay.font_scale, 7 * lay.font_scale
    xl, yl = lay.pad, lay.pad + LINE * lay.title_scale + 2 * fs
    out = []
    for _, text in items:
        out.append(((xl, yl), (xl + sw + 3 * fs, yl)))
        xl += sw + 3 * fs + text_width(text, fs) + 12 * fs
    return out


def _legend_swatches(img, lay, items):
    sw = 7 * lay.font_scale
    for (rgba, _), ((xs, ys), _) in zip(items, _legend_positions(lay, items)):
        img[ys:ys + sw, xs:xs + sw] = srgb(rgba)


def _axis_text(lay, ink, x_label, note, title, legend_items):
    """Text items of the tick labels, the axis labels, the note, the title and the legend."""
    x0, y0, x1, y1 = lay.box
    fs, tk, pad, ts = lay.font_scale, lay.tick_length, lay.pad, lay.title_scale
    texts = [text_item(t, x0 - 2 - tk - 2 * fs, int(np.rint(lay.row(v))) - 3 * fs, ink, fs, "right", "y_tick")
             for v, t in zip(lay.y_ticks, lay.y_labels)]
    texts += [text_item(t, int(np.rint(lay.col(v))), y1 + 2 + tk + 2 * fs, ink, fs, "center", "x_tick")
              for v, t in zip(lay.x_ticks, lay.x_labels)]
    if x_label:
        texts.append(text_item(x_label, (x0 + x1) // 2, y1 + 2 + tk + 2 * fs + LINE * fs + fs, ink, fs, "center",
                               "x_label"))
    # y axis caption above the axis, title and legend at the top
    caption = "error ({}), + = material left".format(lay.y_unit) if lay.y_unit else "error, + = material left"
    texts.append(text_item(caption, pad, y0 - LINE * fs - 4 * fs, ink, fs, "left", "caption"))
    if note:
        texts.append(text_item(note, x1 + 1, y0 - LINE * fs - 4 * fs, ink, fs, "right", "note"))
    if title:
        texts.append(text_item(title, pad, pad, ink, ts, "left", "title", max_width=lay.width - 2 * pad))
    for (_, text), (_, (xt, yt)) in zip(legend_items, _legend_positions(lay, legend_items)):
        texts.append(text_item(text, xt, yt, ink, fs, "left", "legend"))
    return texts


def to_blender_pixels(rgba):
    """(H, W, 4) top row first -> the flat float32 array ``Image.pixels`` takes (bottom row first)."""
    return np.ascontiguousarray(np.asarray(rgba, dtype=np.float32)[::-1]).ravel()


def to_png_bytes(rgba):
    """(H, W, 4) floats k/255 -> uint8 for ``report_render.write_png``."""
    return np.clip(np.rint(np.asarray(rgba, dtype=float) * 255.0), 0, 255).astype(np.uint8)


# ------------------------------------------------------------------------------------------- the data
def _target_runs(mask):
    """Index runs (each an int array, in profile order) of the true entries of a cyclic mask; a run through
    the end of the profile continues at index 0."""
    n = len(mask)
    idx = np.flatnonzero(mask)
    if not len(idx):
        return []
    if len(idx) == n:
        return [np.arange(n)]
    breaks = np.flatnonzero(np.diff(idx) > 1)
    runs = np.split(idx, breaks + 1)
    if len(runs) > 1 and mask[0] and mask[-1]:
        runs = [np.r_[runs[-1], runs[0]]] + runs[1:-1]
    return sorted(runs, key=lambda r: int(r[0]))


def error_profile(plan, tolerance=None, verification=None):
    """The signed error along the target flanks of a flank-plan/1 (rotor plans only).

    The deviation is the verify engine's (:func:`verify.verify_plan` with ``tolerance``, default the plan's
    ``tolerance`` field -- as :func:`exports.error_profile_csv`), or that of a given ``verification``
    result.  Returns a dict of arrays in profile order along the target flanks: ``index`` (profile point),
    ``x`` (% of the target profile's arc length; a run of flanks that does not continue the previous one
    starts a new ``run``), ``deviation`` (plan units, NaN = no tool within verify's search range),
    ``strip`` (the strip forming the machined surface there, -1 none), ``run``; and ``tolerance`` (plan
    units), ``arc_length``, ``length_unit``, ``max_undercut``, ``max_overcut``, ``strips`` (count)."""
    if "rotor" not in plan:
        raise ValueError("a free-form plan has no flank profile to plot the error along (its error is per "
                         "strip on the surface mesh: export the error profile CSV)")
    if verification is None:
        from ..simulation.verify import verify_plan

        tol = tolerance if tolerance is not None else plan.get("tolerance")
        verification = verify_plan(plan, tolerance=tol)
    prof = np.asarray(plan["rotor"]["profile"], dtype=float)
    n = len(prof)
    rows = verification["deviation_profile"]
    if not rows:
        raise ValueError("the plan has no target flank points to plot")
    dev = np.full(n, np.nan)
    mask = np.zeros(n, dtype=bool)
    for i, _, _, d in rows:
        mask[int(i)] = True
        dev[int(i)] = np.nan if d is None else float(d)
    owner = np.full(n, -1, dtype=np.int64)
    for k, st in enumerate(verification.get("strips", [])):
        for a, b in st.get("covered_ranges", []):
            owner[int(a):int(b) + 1] = k
    runs = _target_runs(mask)
    index, run_of, arc = [], [], []
    total = 0.0
    for r, ids in enumerate(runs):
        p = prof[ids]
        seg = np.r_[0.0, np.linalg.norm(np.diff(p, axis=0), axis=1)]
        arc.append(total + np.cumsum(seg))
        total += float(seg.sum())
        index.append(ids)
        run_of.append(np.full(len(ids), r))
    index = np.concatenate(index)
    arc = np.concatenate(arc)
    x = 100.0 * arc / total if total > 0 else np.zeros(len(arc))
    return dict(index=index, x=x, deviation=dev[index], strip=owner[index], run=np.concatenate(run_of),
                tolerance=float(verification["tolerance"]), arc_length=total,
                length_unit=plan.get("length_unit", "R"), max_undercut=verification.get("max_undercut"),
                max_overcut=verification.get("max_overcut"), strips=len(plan.get("strips", [])))


X_LABEL = "position along the target flank profile (% of arc length)"


def plan_error_plot(plan, units=(1.0, None), width=960, height=540, per_strip=True, tolerance=None,
                    title=None, data=None, fit_data=False):
    """(rgba, info) of the error-along-profile chart of a plan.

    ``units`` = (factor, unit): a plan length x is shown as x * factor in unit (``report_render.
    display_units``; unit None = the plan's length unit).  ``tolerance`` (plan units) as in
    :func:`error_profile`; ``data`` = an :func:`error_profile` result to reuse.  ``per_strip``: one curve per
    strip (broken where the next strip forms the surface, labelled S1, S2, ...), else one combined curve per
    flank run.  ``info``: the layout (:meth:`PlotLayout.as_dict`), the unit, tolerance and extreme errors in
    the displayed unit, the point counts, the title and the text items to draw on the picture (``texts``)."""
    if data is None:
        data = error_profile(plan, tolerance=tolerance)
    factor, unit = float(units[0]), units[1] if units[1] is not None else data["length_unit"]
    if not (math.isfinite(factor) and factor > 0):
        raise ValueError("the display factor must be positive, got {!r}".format(units[0]))
    y = data["deviation"] * factor
    tol = data["tolerance"] * factor
    n_strips = max(int(data["strips"]), 1)
    if per_strip:
        groups = data["run"] * (n_strips + 1) + (data["strip"] + 1)
        labels = {int(gid): "S{}".format(int(gid) % (n_strips + 1)) for gid in np.unique(groups)
                  if int(gid) % (n_strips + 1) > 0}
    else:
        groups, labels = data["run"], None
    if title is None:
        title = "Error along profile ({})".format(plan.get("method", "plan"))
    lay = plot_layout(data["x"], y, tol, width, height, unit, (0.0, 100.0), fit_data)
    fin = np.isfinite(y)
    f, u = lay.y_factor, lay.y_unit
    hi, lo = float(np.nanmax(y)) * f, float(np.nanmin(y)) * f
    note = "max {:+.3g} {}, min {:+.3g} {}".format(hi, u, lo, u).replace("+0 ", "0 ")
    rgba, texts = render_error_plot(data["x"], y, tol, width=width, height=height, unit=unit, title=title,
                                    x_label=X_LABEL, x_range=(0.0, 100.0), groups=groups, group_labels=labels,
                                    note=note, fit_data=fit_data)
    info = dict(layout=lay.as_dict(), unit=u, tolerance=tol * f, title=title, note=note,
                points=int(len(y)), finite_points=int(fin.sum()), max_error=hi, min_error=lo,
                per_strip=bool(per_strip), curves=len(np.unique(groups[fin])), fit_data=bool(fit_data), texts=texts)
    return rgba, info
