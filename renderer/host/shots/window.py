"""A window of a frame - a rectangle of the kernels' 8x8 pixel tiles - rendered alone, with the same
bits as in a render of the whole frame.

The kernels' entry points (`kernel.integrator.render_pass`, `kernel.path.render_pass_path`) run one
numba-parallel loop over every 8x8 tile of the image, and a tile's work depends only on the frame's
pass parameters and the tile: its pixels, their sample keys (pixel = y * width + x, sample index)
and film positions ((x + 0.5 + dx) / width).  `_cook_window` and `_path_window` run the same loop
body - the same tile functions on the same arguments - over the tiles of a window only, so every
sample of those pixels is the same number and each pixel's sum gets the same additions in the same
order.  (A crop through the camera - a smaller image whose screen window is shifted - would not:
the pixel keys and the film-position arithmetic both change with the image size.)

This module is a stand-in for a window parameter the kernels do not have (renderer/kernel/ is not
changed here).  What the kernels would take instead:

* `PassParams` (and the path integrator's `frame` tuple) gain the window in tiles,
  (tx0, ty0, tx1, ty1); `render_pass` / `render_pass_path` loop over its tiles (tile numbers, and
  so the counter rows, unchanged) instead of all of them - `n_tiles` and the scattered order over
  the window's tile count;
* and, so that a worker does not hold a whole frame's float64 accumulator for a window, an origin
  (x0, y0) subtracted where a sample is added (`integrator._accumulate`, `path.path_tile`):
  `accum[y - y0, x - x0] += ...`, the accumulator being the window's size.

Then `Renderer.render(options, window=...)` would replace this module.  Until then the worker keeps
a float64 accumulator of the whole frame (24 bytes per pixel, as a one-process render's film) and
only the window's pixels cross the network.
"""
from __future__ import annotations

import numba as nb
import numpy as np

from ...kernel.filters import FILTER_NAMES
from ...kernel.integrator import N_COUNTERS, TILE, _tile_pass, n_tiles
from ...kernel.path import STRATEGIES, new_path_scratch, path_tile
from ...kernel.samplers import SAMPLER_NAMES
from ...kernel.trace import new_ray_buffer

__all__ = ['TILE', 'aligned', 'kernel_tiles', 'render_window', 'counters_for']


def aligned(box, width: int, height: int) -> bool:
    """Is `box` = (x0, y0, x1, y1) a non-empty rectangle of whole kernel tiles inside the image
    (its right and bottom edges may be the image's)?"""
    x0, y0, x1, y1 = box
    return (0 <= x0 < x1 <= width and 0 <= y0 < y1 <= height and x0 % TILE == 0 and y0 % TILE == 0
            and (x1 % TILE == 0 or x1 == width) and (y1 % TILE == 0 or y1 == height))


def kernel_tiles(box, width: int, height: int) -> np.ndarray:
    """The kernels' tile numbers (row-major over the image) of an `aligned` box, in a scattered order
    (as `render_pass` visits them): numba's parallel loop gives each thread a contiguous block."""
    x0, y0, x1, y1 = box
    ntx = (width + TILE - 1) // TILE
    tx = np.arange(x0 // TILE, (x1 + TILE - 1) // TILE)
    ty = np.arange(y0 // TILE, (y1 + TILE - 1) // TILE)
    tiles = (ty[:, None] * ntx + tx[None, :]).ravel().astype(np.int64)
    stride = 7919 if len(tiles) % 7919 != 0 else 1
    return tiles[(np.arange(len(tiles)) * stride) % len(tiles)]


def counters_for(width: int, height: int) -> np.ndarray:
    """Ray counters of a frame: one row per kernel tile (as `Renderer.render` allocates them)."""
    return np.zeros((n_tiles(width, height), N_COUNTERS), np.int64)


@nb.njit(parallel=True, cache=True, nogil=True)
def _cook_window(S, scene, pp, tiles, accum, counters):
    """`integrator.render_pass` over `tiles` only."""
    for i in nb.prange(len(tiles)):
        _tile_pass(S, scene, pp, tiles[i], accum, counters, None)


@nb.njit(parallel=True, cache=True, nogil=True)
def _path_window(S, L, scene, cam, frame, opts, tiles, sums):
    """`path.render_pass_path` over `tiles` only (its loop body, tile by tile); sums = (accum, counters)."""
    accum, counters = sums
    width, height = frame[0], frame[1]
    ntx = (width + TILE - 1) // TILE
    for i in nb.prange(len(tiles)):
        tile = tiles[i]
        f, u = new_ray_buffer()
        lf, lu = new_ray_buffer()
        counts = np.zeros(N_COUNTERS, np.int64)
        packet, lanes = new_path_scratch()
        x0 = (tile % ntx) * TILE
        y0 = (tile // ntx) * TILE
        path_tile(S, L, scene, cam, (x0, y0, min(x0 + TILE, width), min(y0 + TILE, height)), frame, opts,
                  (f, u, np.empty((3, 4)), np.empty(12, np.float32), counts, packet, lanes, lf, lu), accum)
        for k in range(N_COUNTERS):
            counters[tile, k] += counts[k]


def render_window(renderer, o, camera, tiles: np.ndarray, s0: int, s1: int, accum: np.ndarray,
                  counters: np.ndarray) -> None:
    """Add samples [s0, s1) of the pixels of `tiles` to `accum` (the frame's (h, w, 3) float64), as
    `Renderer._pass` adds them for every pixel: `o` resolved options, `camera` = `renderer.camera(o)`."""
    ctab, use_lens, use_time = camera
    built = renderer.built
    if o.integrator == 'path':
        _path_window(built.data, renderer.path_lights(), built.handle, ctab, (o.width, o.height, s0, s1, o.spp),
                     (SAMPLER_NAMES[o.sampler], FILTER_NAMES[o.filter], o.seed, o.max_depth, use_lens, use_time,
                      STRATEGIES[o.strategy]), tiles, (accum, counters))
    else:
        _cook_window(built.data, built.handle, renderer.pass_params(o, s0, s1, ctab, use_lens, use_time), tiles, accum,
                     counters)
