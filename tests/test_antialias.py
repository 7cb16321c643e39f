# SPDX-License-Identifier: GPL-3.0-or-later
"""The report's edge anti-aliasing (flank_addon.report.antialias.fxaa) against the exact coverage of the shapes,
measured by dense sampling: it must bring a stair-stepped edge close to the true area shares and leave flat
areas untouched."""
import numpy as np
import pytest

from flank_addon.report.antialias import fxaa

H, W = 120, 160
INK, PAPER = np.array([230, 60, 40]), np.array([30, 200, 90])


def _coverage(samples):
    """The share (H, W) of each pixel inside a shallow half-plane or a disc, from samples x samples points."""
    yy, xx = np.mgrid[0:H * samples, 0:W * samples]
    yy, xx = (yy + 0.5) / samples, (xx + 0.5) / samples
    inside = (yy - 0.37 * xx - 20.3 > 0) | ((xx - 80.2) ** 2 + (yy - 60.4) ** 2 < 30.3 ** 2)
    return inside.reshape(H, samples, W, samples).mean(axis=(1, 3))


def _picture(share):
    rgb = share[..., None] * INK + (1 - share[..., None]) * PAPER
    return np.dstack([np.rint(rgb).astype(np.uint8), np.full((H, W), 255, np.uint8)])


def _share(picture):
    """The ink share a pixel's colour stands for (its red channel between paper and ink)."""
    return (picture[..., 0].astype(float) - PAPER[0]) / (INK[0] - PAPER[0])


def test_edges_come_close_to_the_exact_area_shares_and_flat_areas_keep_their_colour():
    exact = _coverage(16)                          # 256 samples per pixel: the reference
    aliased = _picture(_coverage(1))               # one sample per pixel, as a render without anti-aliasing
    smooth = fxaa(aliased)
    edge = (exact > 0.02) & (exact < 0.98)
    before = np.abs(_share(aliased) - exact)[edge].mean()
    after = np.abs(_share(smooth) - exact)[edge].mean()
    # measured: 0.230 -> 0.084 of a pixel's area on the 201 edge pixels
    assert before > 0.2 and after < 0.4 * before, (before, after)
    # two pixels away from every edge nothing changes, and alpha never does
    near = np.zeros((H, W), bool)
    for dy in range(-2, 3):
        for dx in range(-2, 3):
            near |= np.roll(np.roll(edge, dy, 0), dx, 1)
    assert np.array_equal(smooth[~near], aliased[~near])
    assert (smooth[..., 3] == 255).all()


def test_a_flat_picture_is_returned_unchanged_and_bad_input_is_refused():
    flat = np.zeros((50, 60, 4), np.uint8)
    flat[..., 1], flat[..., 3] = 120, 255
    out = fxaa(flat)
    assert np.array_equal(out, flat) and out is not flat
    with pytest.raises(ValueError, match="uint8"):
        fxaa(flat.astype(np.float32))
    with pytest.raises(ValueError, match=r"\(50, 60, 3\)"):
        fxaa(flat[..., :3])
    assert np.array_equal(fxaa(flat[:1]), flat[:1])          # a single row: nothing to smooth
