# SPDX-License-Identifier: GPL-3.0-or-later
"""Edge anti-aliasing of a rendered picture after the render, in numpy (any thread).

The report's Workbench render used Blender's own single-pass anti-aliasing, which took longer than the render
itself (at 1280 x 800 the render call took 285-400 ms with it, 96-132 ms without) and runs on Blender's main
thread.  The render now comes without it and :func:`fxaa` smooths the edges in the worker that encodes the
PNG (the picture's text is drawn there afterwards, with its own coverage).

The method is fast approximate anti-aliasing (T. Lottes, "FXAA", NVIDIA white paper, 2009; here its
"quality" version 3.11 of 2011): a pixel whose neighbourhood has contrast lies on an edge, horizontal or vertical by the larger
second differences of luma; the edge's two ends are searched along it (in growing steps, at the middle
between the pixel's row and the one across the edge), and the pixel's colour is taken from a point moved
across the edge by how far it lies from the nearer end -- more near the end of a stair step, so a shallow
edge becomes a ramp.  Pixels alone on their edge (a thin line, a dot) are blended with their neighbours
(the sub-pixel part).  Pixels without contrast keep their colour exactly, so flat areas -- the report's
error bands -- keep their exact colours.
"""
import numpy as np

# the luma range below which a pixel keeps its colour: absolute, and relative to the brightest neighbour
EDGE_THRESHOLD_MIN = 0.0312
EDGE_THRESHOLD = 0.166
SUBPIX = 0.75                                          # how much a lone pixel is blended (0: never)
# the steps of the search for an edge's ends, in pixels (FXAA 3.11's quality preset 39)
STEPS = (1.0, 1.0, 1.0, 1.0, 1.0, 1.5, 2.0, 2.0, 2.0, 2.0, 4.0, 8.0)
LUMA = np.array([0.299, 0.587, 0.114], np.float32)     # Rec. 601 weights of the stored (display) values


def _bilinear(img, y, x):
    """Values of ``img`` (H, W) or (H, W, C), H, W >= 2, at the fractional pixel positions (y, x) (n,) (pixel
    centres at integers), clamped to the picture."""
    H, W = img.shape[:2]
    y = np.clip(y, 0.0, H - 1.0)
    x = np.clip(x, 0.0, W - 1.0)
    y0 = np.minimum(np.floor(y).astype(np.int64), H - 2)
    x0 = np.minimum(np.floor(x).astype(np.int64), W - 2)
    fy, fx = y - y0, x - x0
    if img.ndim == 3:
        fy, fx = fy[:, None], fx[:, None]
    top = img[y0, x0] * (1 - fx) + img[y0, x0 + 1] * fx
    bottom = img[y0 + 1, x0] * (1 - fx) + img[y0 + 1, x0 + 1] * fx
    return top * (1 - fy) + bottom * fy


def fxaa(rgba):
    """``rgba`` (H, W, 4) uint8 with its edges anti-aliased -> a new (H, W, 4) uint8 array (alpha kept)."""
    img = np.asarray(rgba)
    if img.ndim != 3 or img.shape[2] != 4 or img.dtype != np.uint8:
        raise ValueError("fxaa: expected an (H, W, 4) uint8 picture, got {} {}".format(img.dtype, img.shape))
    out = img.copy()
    H, W = img.shape[:2]
    if H < 2 or W < 2:
        return out
    rgb = img[..., :3].astype(np.float32) / 255.0
    luma = rgb @ LUMA
    pad = np.pad(luma, 1, mode="edge")
    n, s, w, e = pad[:-2, 1:-1], pad[2:, 1:-1], pad[1:-1, :-2], pad[1:-1, 2:]
    lo = np.minimum(np.minimum(np.minimum(n, s), np.minimum(w, e)), luma)
    hi = np.maximum(np.maximum(np.maximum(n, s), np.maximum(w, e)), luma)
    ys, xs = np.nonzero(hi - lo >= np.maximum(EDGE_THRESHOLD_MIN, hi * EDGE_THRESHOLD))
    if len(ys) == 0:
        return out
    m = luma[ys, xs]
    ln, ls, lw, le = n[ys, xs], s[ys, xs], w[ys, xs], e[ys, xs]
    nw, ne = pad[ys, xs], pad[ys, xs + 2]              # the diagonal neighbours (row - 1 is "north")
    sw, se = pad[ys + 2, xs], pad[ys + 2, xs + 2]
    rng = (hi - lo)[ys, xs]
    # an edge along x (luma changes across the rows) or along y, by the larger second differences
    along_x = (np.abs(ne + se - 2 * le) + 2 * np.abs(ln + ls - 2 * m) + np.abs(nw + sw - 2 * lw)
               >= np.abs(sw + se - 2 * ls) + 2 * np.abs(lw + le - 2 * m) + np.abs(nw + ne - 2 * ln))
    # the sub-pixel blend: how much the pixel stands out from its neighbourhood's low-pass average
    c = np.clip(np.abs((2 * (ln + ls + lw + le) + (nw + ne + sw + se)) / 12.0 - m) / rng, 0.0, 1.0)
    subpix = ((3.0 - 2.0 * c) * c * c) ** 2 * SUBPIX
    # across the edge: towards the neighbour with the larger luma step
    before, after = np.where(along_x, ln, lw), np.where(along_x, ls, le)
    toward_before = np.abs(before - m) >= np.abs(after - m)
    sign = np.where(toward_before, -1.0, 1.0).astype(np.float32)
    other = np.where(toward_before, before, after)
    gradient = np.maximum(np.abs(before - m), np.abs(after - m)) * 0.25
    mid = 0.5 * (m + other)                            # the luma halfway across the edge
    below = m - mid < 0
    # search both ends along the edge, on the line halfway between the pixel and its neighbour across it
    cy = ys.astype(np.float32) + np.where(along_x, 0.5 * sign, 0.0)
    cx = xs.astype(np.float32) + np.where(along_x, 0.0, 0.5 * sign)
    uy, ux = np.where(along_x, 0.0, 1.0).astype(np.float32), np.where(along_x, 1.0, 0.0).astype(np.float32)
    ends = []
    for direction in (-1.0, 1.0):
        dist = np.zeros(len(ys), np.float32)
        end = np.zeros(len(ys), np.float32)
        todo = np.arange(len(ys))
        for step in STEPS:
            dist[todo] += step
            end[todo] = _bilinear(luma, cy[todo] + direction * dist[todo] * uy[todo],
                                  cx[todo] + direction * dist[todo] * ux[todo]) - mid[todo]
            todo = todo[np.abs(end[todo]) < gradient[todo]]
            if len(todo) == 0:
                break
        ends.append((dist, end))
    (dist_n, end_n), (dist_p, end_p) = ends
    nearer_n = dist_n < dist_p
    dist = np.minimum(dist_n, dist_p)
    good = np.where(nearer_n, (end_n < 0) != below, (end_p < 0) != below)
    offset = np.where(good, 0.5 - dist / (dist_n + dist_p), 0.0)
    offset = np.maximum(offset, subpix) * sign
    colour = _bilinear(rgb, ys + np.where(along_x, offset, 0.0), xs + np.where(along_x, 0.0, offset))
    out[ys, xs, :3] = np.clip(np.rint(colour * 255.0), 0, 255).astype(np.uint8)
    return out
