"""How a shot is cut into tasks, and how split frames are put back together bit for bit.

Frames are tasks.  When there are fewer frames than workers can share, every frame is also cut
into sample ranges (`split` ranges per frame) so that every worker has work.  A sample-range task
returns one film per sample (`worker.render_samples`), because a local render adds each pixel's
samples to its sum one by one, in sample order: `FrameAssembly` adds the single-sample films in
the same order (starting from zero, as the film does), so a split frame has the same bits as a
frame rendered by one process.  The price is the size of the results (8 bytes x 3 channels per
pixel per sample), so frames whose samples would exceed `MAX_SPLIT_BYTES` stay whole.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..film import Film

MAX_SPLIT_BYTES = 256 << 20          # per frame: the single-sample films of all its samples


@dataclass(frozen=True)
class Task:
    frame: object                    # the frame number (a time code)
    s0: int = 0                      # sample range [s0, s1); whole = every sample, one image back
    s1: int = 0
    whole: bool = True

    @property
    def key(self) -> str:
        return f'rtc-frame-{self.frame}' if self.whole else f'rtc-frame-{self.frame}-samples-{self.s0}-{self.s1}'


def split_count(n_frames: int, n_workers: int, width: int, height: int, spp: int) -> int:
    """Sample ranges per frame: 1 when the frames alone keep every worker busy (or the frame's
    single-sample films would be too large), else enough for about two tasks per worker."""
    if n_workers <= 1 or n_frames >= n_workers:
        return 1
    if spp * width * height * 3 * 8 > MAX_SPLIT_BYTES:
        return 1
    return max(1, min(spp, math.ceil(2 * n_workers / max(n_frames, 1))))


def plan(frames: list, spp: int, split: int) -> list[Task]:
    """The tasks of a shot: whole frames (split 1), or `split` near-equal sample ranges of each."""
    if split <= 1:
        return [Task(f, 0, spp, True) for f in frames]
    edges = np.linspace(0, spp, min(split, spp) + 1).round().astype(int)
    return [Task(f, int(a), int(b), False) for f in frames for a, b in zip(edges[:-1], edges[1:]) if b > a]


class FrameAssembly:
    """The sample ranges of one frame, added in sample order as they arrive (out of order is fine:
    a range waits until the ranges before it are in)."""

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
