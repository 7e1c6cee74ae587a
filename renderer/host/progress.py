"""Progress reporting for the render loop.

``Progress`` shows a tqdm bar on stderr (samples per pixel done, pass number, Mrays/s) when the
stream is a terminal, and stays silent otherwise or when ``quiet``; ``summary_line`` formats the
one-line result printed after a render:

    rendered 640x480 at 64 spp in 3.21 s: 19.7 M rays, 6.13 Mrays/s
"""
from __future__ import annotations

import sys
import time


def _sig3(x: float) -> str:
    """Three significant digits without exponent notation (19.7, 6.13, 123, 0.0412)."""
    ax = abs(x)
    if ax >= 100:
        return '%.0f' % x
    if ax >= 10:
        return '%.1f' % x
    if ax >= 1 or ax == 0:
        return '%.2f' % x
    return '%.3g' % x


def summary_line(seconds: float, spp: int, rays: int, width: int | None = None,
                 height: int | None = None) -> str:
    """``rendered WxH at N spp in S s: R M rays, T Mrays/s`` (the size part only when given)."""
    size = ' %dx%d' % (width, height) if width is not None and height is not None else ''
    rate = rays / seconds / 1e6 if seconds > 0 else float('inf')
    rate_s = _sig3(rate) if rate != float('inf') else 'inf'
    return 'rendered%s at %d spp in %.2f s: %s M rays, %s Mrays/s' % (
        size, spp, seconds, _sig3(rays / 1e6), rate_s)


def _is_tty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


class Progress:
    """Tracks samples per pixel and rays of a progressive render; draws a tqdm bar on a TTY.

    Use as a context manager; call ``update(spp, rays)`` after each pass with the samples per pixel
    and rays that pass added.  ``summary()`` gives the ``summary_line`` of what was done."""

    def __init__(self, width: int, height: int, spp: int, passes: int | None = None,
                 quiet: bool = False, stream=None, desc: str = 'render', mininterval: float = 0.1):
        self.width, self.height, self.spp_total = width, height, spp
        self.passes_total = passes
        self.stream = sys.stderr if stream is None else stream
        self.spp = 0
        self.rays = 0
        self.passes = 0
        self.start = time.perf_counter()
        self.bar = None
        if not quiet and _is_tty(self.stream):
            from tqdm import tqdm
            self.bar = tqdm(total=spp, desc=desc, unit='spp', file=self.stream, leave=False,
                            dynamic_ncols=True, mininterval=mininterval, bar_format='{l_bar}{bar}| {n_fmt}/{total_fmt} spp '
                                                           '[{elapsed}<{remaining}{postfix}]')

    @property
    def enabled(self) -> bool:
        return self.bar is not None

    @property
    def elapsed(self) -> float:
        return time.perf_counter() - self.start

    def mrays_per_second(self) -> float:
        t = self.elapsed
        return self.rays / t / 1e6 if t > 0 else 0.0

    def update(self, spp: int, rays: int = 0) -> None:
        """Record one finished pass of ``spp`` samples per pixel that traced ``rays`` rays."""
        self.spp += spp
        self.rays += rays
        self.passes += 1
        if self.bar is not None:
            of = '/%d' % self.passes_total if self.passes_total else ''
            self.bar.set_postfix_str('pass %d%s, %s Mrays/s' % (self.passes, of, _sig3(self.mrays_per_second())),
                                     refresh=False)
            self.bar.update(spp)

    def summary(self, seconds: float | None = None) -> str:
        return summary_line(self.elapsed if seconds is None else seconds, self.spp, self.rays,
                            self.width, self.height)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def __enter__(self) -> 'Progress':
        return self

    def __exit__(self, *exc) -> None:
        self.close()
