"""How a shot is cut into tasks, and how split frames are put back together bit for bit.

Frames are tasks.  When there are fewer frames than workers can share (`pieces`: about two tasks
per worker), every frame is also cut into pieces so that every worker has work:

* **tiles** first - rectangles of the kernels' 8x8 pixel tiles (`Renderer.render(window=)` renders
  one with the same bits as the whole frame) of about `MIN_TILE_PIXELS` pixels or more each.  A
  tile with all its samples returns its float32 pixels: a tiled frame costs no more bytes than a
  whole one.
* then **sample ranges** of each tile (or of the whole frame when it is too small to tile), when
  tiles alone are too few.  A sample-range task returns one film per sample (`worker.render_samples`
  / `worker.render_tile`), because a local render adds each pixel's samples to its sum one by one, in
  sample order: `FrameAssembly` adds the single-sample films in the same order (starting from zero,
  as the film does), so a split frame has the same bits as a frame rendered by one process.  The
  price is the size of the results (8 bytes x 3 channels per pixel per sample), so frames whose
  samples would exceed `MAX_SPLIT_BYTES` are not cut into sample ranges.

On a cluster, a frame whose float32 image exceeds `MAX_RESULT_BYTES` is tiled whatever the worker
count, so that no task result (one Dask message, held whole by the worker, the scheduler's
bookkeeping and the client) is larger than that.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..film import Film
from ...kernel.tiles import TILE

MAX_SPLIT_BYTES = 256 << 20          # per frame: the single-sample films of all its samples
# benchmarks/bench_shot.py `tiles` (512x384 4 spp, path; RESULTS.md "Shots and Dask"): time per pixel
# sample of a tile task (Renderer.render(window=): the tile's pixels only, host threads claiming
# kernel tiles) against the whole frame's, 2 threads / 1 thread, two runs: 16x16 1.63-1.58x /
# 1.12-1.11x, 32x32 1.32-1.15x / 1.03-1.02x, 64x64 1.11-1.09x / 1.08-1.03x, 128x128 1.06-1.04x /
# 1.03x (a pass over few kernel tiles leaves a thread idle at its end): the smallest tile within
# 10 % of the whole frame in both runs (64x64 is at the edge)
MIN_TILE_PIXELS = 128 * 128
MAX_RESULT_BYTES = 64 << 20          # per task result on a cluster (a 2336x2336 float32 RGB tile)
Box = tuple                          # (x0, y0, x1, y1) pixels, [x0, x1) x [y0, y1)


@dataclass(frozen=True)
class Task:
    frame: object                    # the frame number (a time code)
    s0: int = 0                      # sample range [s0, s1); whole = every sample, pixels back
    s1: int = 0
    whole: bool = True
    box: Box | None = None           # a tile of the frame; None: every pixel

    @property
    def key(self) -> str:
        tile = '' if self.box is None else '-tile-%d-%d-%d-%d' % self.box
        samples = '' if self.whole else f'-samples-{self.s0}-{self.s1}'
        return f'rtc-frame-{self.frame}{tile}{samples}'


@dataclass(frozen=True)
class Split:
    """How every frame of a shot is cut: its tiles (None: not tiled) and sample ranges per tile."""
    tiles: tuple = (None,)
    ranges: int = 1

    @property
    def pieces(self) -> int:
        return len(self.tiles) * self.ranges


def pieces_wanted(n_frames: int, n_workers: int) -> int:
    """Tasks per frame that keep every worker busy: 1 when the frames alone do, else enough for
    about two tasks per worker."""
    if n_workers <= 1 or n_frames >= n_workers:
        return 1
    return math.ceil(2 * n_workers / max(n_frames, 1))


def split_count(n_frames: int, n_workers: int, width: int, height: int, spp: int) -> int:
    """Sample ranges per untiled frame: `pieces_wanted`, at most spp, 1 if the frame's single-sample
    films would be too large."""
    if spp * width * height * 3 * 8 > MAX_SPLIT_BYTES:
        return 1
    return max(1, min(spp, pieces_wanted(n_frames, n_workers)))


def grid(width: int, height: int, n: int) -> tuple:
    """At least `n` (as many as the image has kernel tiles at most) near-square tiles covering the
    image, edges on the kernels' 8-pixel grid, row-major."""
    kx, ky = math.ceil(width / TILE), math.ceil(height / TILE)
    n = max(1, min(n, kx * ky))
    ny = max(1, min(ky, round(math.sqrt(n * height / width))))
    nx = min(kx, math.ceil(n / ny))
    ny = min(ky, max(ny, math.ceil(n / nx)))
    xs = [min(width, int(e) * TILE) for e in np.linspace(0, kx, nx + 1).round()]
    ys = [min(height, int(e) * TILE) for e in np.linspace(0, ky, ny + 1).round()]
    return tuple((x0, y0, x1, y1) for y0, y1 in zip(ys[:-1], ys[1:]) for x0, x1 in zip(xs[:-1], xs[1:]))


def split_for(n_frames: int, n_workers: int, width: int, height: int, spp: int, cluster: bool = True) -> Split:
    """The split of a shot's frames: tiles of at least MIN_TILE_PIXELS while more pieces are wanted
    (and, on a cluster, as many as keep each result under MAX_RESULT_BYTES), then sample ranges of
    each tile for the pieces still wanted."""
    wanted = pieces_wanted(n_frames, n_workers) if cluster else 1
    pixels = width * height
    large = math.ceil(pixels * 3 * 4 / MAX_RESULT_BYTES) if cluster else 1
    n_tiles = max(large, min(wanted, pixels // MIN_TILE_PIXELS), 1)
    tiles = grid(width, height, n_tiles) if n_tiles > 1 else (None,)
    while cluster and tiles != (None,) and max((x1 - x0) * (y1 - y0) for x0, y0, x1, y1 in tiles) * 12 > MAX_RESULT_BYTES:
        n_tiles += max(1, n_tiles // 8)              # the 8-pixel grid made some tiles larger than the mean
        tiles = grid(width, height, n_tiles)
    ranges = 1
    if wanted > len(tiles) and spp * pixels * 3 * 8 <= MAX_SPLIT_BYTES:
        ranges = max(1, min(spp, math.ceil(wanted / len(tiles))))
    return Split(tiles, ranges)


def plan(frames: list, spp: int, split) -> list[Task]:
    """The tasks of a shot: per frame, each tile (or the whole image) with all its samples, or cut
    into `split.ranges` near-equal sample ranges.  `split`: a `Split`, or an int (sample ranges of
    untiled frames)."""
    if not isinstance(split, Split):
        split = Split((None,), max(1, int(split)))
    if split.ranges <= 1:
        return [Task(f, 0, spp, True, box) for f in frames for box in split.tiles]
    edges = np.linspace(0, spp, min(split.ranges, spp) + 1).round().astype(int)
    return [Task(f, int(a), int(b), False, box) for f in frames for box in split.tiles
            for a, b in zip(edges[:-1], edges[1:]) if b > a]


class _Ranges:
    """The sample ranges of one tile (or frame), added in sample order as they arrive (out of order
    is fine: a range waits until the ranges before it are in)."""

    def __init__(self, width: int, height: int, spp: int):
        self.film = Film(width, height)
        self.spp = spp
        self.next = 0
        self.pending: dict[int, np.ndarray] = {}

    def add(self, s0: int, samples: np.ndarray) -> None:
        self.pending[s0] = samples
        while self.next in self.pending:
            chunk = self.pending.pop(self.next)
            for k in range(len(chunk)):              # one sample at a time, as the kernel adds them
                self.film.sum += chunk[k]
            self.next += len(chunk)

    @property
    def complete(self) -> bool:
        return self.next >= self.spp

    def image(self) -> np.ndarray:
        self.film.count[...] = self.spp
        return self.film.image()


class FrameAssembly:
    """The pieces of one frame - tiles and sample ranges, in any order - put together into its
    float32 image, with the same bits as a one-process render."""

    def __init__(self, width: int, height: int, spp: int, tiles=(None,)):
        self.width, self.height, self.spp = width, height, spp
        self.pixels = np.zeros((height, width, 3), np.float32)
        self.left = len(tiles)                       # tiles not complete yet
        self.ranges: dict = {}

    def _place(self, box, pixels: np.ndarray) -> None:
        x0, y0, x1, y1 = box if box is not None else (0, 0, self.width, self.height)
        if pixels.shape != (y1 - y0, x1 - x0, 3):
            raise ValueError(f'tile {box} of a {self.width}x{self.height} frame: {pixels.shape} pixels')
        self.pixels[y0:y1, x0:x1] = pixels
        self.left -= 1

    def add(self, task: Task, out: dict) -> None:
        """A task's result: its pixels (`task.whole`) or its single-sample films."""
        if task.whole:
            self._place(task.box, np.asarray(out['image'], np.float32))
            return
        x0, y0, x1, y1 = task.box if task.box is not None else (0, 0, self.width, self.height)
        r = self.ranges.setdefault(task.box, _Ranges(x1 - x0, y1 - y0, self.spp))
        r.add(task.s0, out['samples'])
        if r.complete:
            self._place(task.box, self.ranges.pop(task.box).image())

    @property
    def complete(self) -> bool:
        return self.left <= 0

    def image(self) -> np.ndarray:
        return self.pixels
