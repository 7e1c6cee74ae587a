"""Frame ranges and output names of a shot.

    parse_frames('1:24')      -> [1, 2, ..., 24]        (both ends included)
    parse_frames('0:100:10')  -> [0, 10, ..., 100]
    output_name('out/shot.####.exr', 7)   -> 'out/shot.0007.exr'
    output_name('out/shot.%04d.exr', 7)   -> 'out/shot.0007.exr'

A pattern holds one frame placeholder: a run of `#` (as many digits, zero-padded) or a printf
`%d` / `%0Nd`.  Frames are integers (USD time codes of whole frames); a single `--frame T` may be
any finite time code when the output names no frame.
"""
from __future__ import annotations

import math
import re

MAX_FRAMES = 1_000_000
_PLACEHOLDER = re.compile(r'#+|%0?(\d*)d')


class ShotError(Exception):
    """A shot cannot be rendered as asked (bad frame range, output pattern, scheduler, worker...)."""


def _integer(text: str, what: str) -> int:
    try:
        return int(text.strip())
    except ValueError:
        raise ShotError(f"--frames: {what} '{text}' is not an integer frame number") from None


def parse_frames(spec: str) -> list[int]:
    """The frames of 'A:B' or 'A:B:STEP' (A <= B, STEP >= 1, both ends included)."""
    parts = spec.split(':')
    if len(parts) not in (2, 3):
        raise ShotError(f"--frames '{spec}': expected A:B or A:B:STEP (e.g. 1:24 or 1:100:5)")
    a, b = _integer(parts[0], 'start'), _integer(parts[1], 'end')
    step = _integer(parts[2], 'step') if len(parts) == 3 else 1
    if step < 1:
        raise ShotError(f"--frames '{spec}': step must be at least 1, got {step}")
    if b < a:
        raise ShotError(f"--frames '{spec}': end {b} is before start {a}")
    n = (b - a) // step + 1
    if n > MAX_FRAMES:
        raise ShotError(f"--frames '{spec}': {n} frames, more than {MAX_FRAMES}")
    return list(range(a, b + 1, step))


def parse_time(text: str) -> float | int:
    """`--frame T`: an integer frame, or any finite time code."""
    try:
        t = float(text)
    except ValueError:
        raise ShotError(f"--frame '{text}' is not a number") from None
    if not math.isfinite(t):
        raise ShotError(f"--frame '{text}' is not a finite time code")
    return int(t) if t == int(t) and abs(t) < 2 ** 53 else t


def has_placeholder(pattern: str) -> bool:
    return _PLACEHOLDER.search(pattern) is not None


def check_pattern(pattern: str, n_frames: int) -> None:
    """An output pattern fit for `n_frames` frames: one placeholder, or none for a single frame."""
    found = _PLACEHOLDER.findall(pattern)
    if len(found) > 1:
        raise ShotError(f"{pattern}: more than one frame placeholder (use one '####' or '%04d')")
    if not found and n_frames > 1:
        raise ShotError(f"{pattern}: {n_frames} frames need a frame number in the output name "
                        f"(e.g. shot.####.exr or shot.%04d.exr)")


def output_name(pattern: str, frame) -> str:
    """`pattern` with its placeholder replaced by `frame` (unchanged without a placeholder)."""
    m = _PLACEHOLDER.search(pattern)
    if m is None:
        return pattern
    if frame != int(frame):
        raise ShotError(f"{pattern}: time code {frame} is not a whole frame number")
    digits = len(m.group(0)) if m.group(0).startswith('#') else int(m.group(1) or 1)
    return pattern[:m.start()] + f'{int(frame):0{digits}d}' + pattern[m.end():]
