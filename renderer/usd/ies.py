"""IES photometric profiles (ANSI/IES LM-63, the files UsdLux.ShapingAPI's `shaping:ies:file` names) -> `IesProfile`.

A file is a header of keyword lines, a TILT line, then numbers separated by blanks or commas: the lamps' count,
lumens and the candela multiplier, the counts of vertical and horizontal angles, the photometric type, units and
sizes, the ballast factors and watts, the vertical angles, the horizontal angles, and the candela values, each
horizontal angle's at every vertical angle.  rtc reads photometric type C (the type of architectural and
entertainment luminaires: vertical angle 0 at the nadir), as Pixar's hdEmbree and Blender's Cycles do: the
intensities times the multiplier and both ballast factors, in candela (UsdLux is photometric: no conversion to
watts).  The horizontal angles unfold the symmetries LM-63 defines: one angle (the same in every direction), 0-90
(a quadrant, mirrored twice), 0-180 (mirrored about the 0-180 plane), 90-270 (about the 90-270 plane), 0-360
(none; a last angle one step short of 360 is closed with the values at 0).  Lamp tilt (TILT=INCLUDE) changes the
lumens with the lamp's angle, not the shape: its block is skipped.

`mean_intensity` is the mean over the sphere, or the hemisphere when the vertical angles span no more than it,
computed as hdEmbree computes it (each patch between four angles, its centre's interpolated value times its
solid angle), so that `shaping:ies:normalize` divides by the same number there and here.

A file that cannot be read raises `IesError` naming the file and the line.
"""
from __future__ import annotations

import math
import os
import re
from functools import lru_cache

import numpy as np

from ..description import IesProfile

TYPE_C = 1
_TYPES = {1: 'C', 2: 'B', 3: 'A'}
_EPS = 1e-4                   # degrees: angles this close are equal


class IesError(ValueError):
    """An IES file rtc cannot use (the message names the file, and the line where there is one)."""


class _Numbers:
    """The numbers after the TILT line, each with its line, read one at a time."""

    def __init__(self, path: str, lines: list, first: int):
        self.path = path
        self.items = [(tok, n) for n, line in enumerate(lines[first:], first + 1)
                      for tok in re.split(r'[\s,]+', line.strip()) if tok]
        self.pos = 0
        self.last_line = len(lines)

    def take(self, what: str, integer: bool = False) -> float:
        if self.pos >= len(self.items):
            raise IesError(f'{self.path}:{self.last_line}: the file ends before {what}')
        tok, line = self.items[self.pos]
        self.pos += 1
        try:
            value = float(tok)
        except ValueError:
            raise IesError(f'{self.path}:{line}: {what}: "{tok}" is not a number') from None
        if not math.isfinite(value) or (integer and value != int(value)):
            raise IesError(f'{self.path}:{line}: {what}: "{tok}" is not {"a whole number" if integer else "finite"}')
        return value

    def many(self, n: int, what: str) -> np.ndarray:
        return np.array([self.take(what) for _ in range(n)], np.float64)

    def line(self) -> int:
        return self.items[min(self.pos, len(self.items)) - 1][1] if self.items else self.last_line


def _tilt_line(path: str, lines: list) -> int:
    for n, line in enumerate(lines):
        if line.strip().upper().startswith('TILT'):
            return n
    raise IesError(f'{path}: no TILT= line: not an IES LM-63 file')


def _horizontal(path: str, h: np.ndarray, c: np.ndarray, line: int) -> tuple[np.ndarray, np.ndarray]:
    """The horizontal angles (degrees) and candela rows over 0-360, the file's symmetry unfolded."""
    if len(h) == 1:                                              # the same in every direction
        return np.array([0.0, 360.0]), np.concatenate([c, c])
    if abs(h[0] - 90.0) < _EPS and abs(h[-1] - 270.0) < _EPS:     # mirrored about the 90-270 plane
        return _wrap(np.concatenate([h, np.mod(180.0 - h, 360.0)]), np.concatenate([c, c]))
    if abs(h[0]) > _EPS:
        raise IesError(f'{path}:{line}: horizontal angles from {h[0]:g} to {h[-1]:g}: type C angles start at 0 or 90')
    if abs(h[-1] - 90.0) < _EPS:                                 # a quadrant: mirrored to 180, then to 360
        h, c = np.concatenate([h, 180.0 - h[-2::-1]]), np.concatenate([c, c[-2::-1]])
    if abs(h[-1] - 180.0) < _EPS:                                # a half: mirrored to 360
        h, c = np.concatenate([h, 360.0 - h[-2::-1]]), np.concatenate([c, c[-2::-1]])
    if abs(h[-1] - 360.0) > _EPS:
        gap = 360.0 - h[-1]
        if not (gap > 0 and (abs(gap - (h[-1] - h[-2])) < _EPS or abs(gap - (h[1] - h[0])) < _EPS)):
            raise IesError(f'{path}:{line}: horizontal angles from 0 to {h[-1]:g}: not a range LM-63 defines '
                           f'(90, 180 or 360)')
        h, c = np.concatenate([h, [360.0]]), np.concatenate([c, c[:1]])
    return h, c


def _wrap(h: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows at angles within [0, 360) sorted over [0, 360] (one row an angle; 360 closed with 0's row)."""
    order = np.argsort(h, kind='stable')
    h, c = h[order], c[order]
    keep = np.concatenate([[True], np.diff(h) > _EPS])
    h, c = h[keep], c[keep]
    if h[0] > _EPS:                          # a row at 0, between the last row and the first across 360
        t = (360.0 - h[-1]) / (360.0 - h[-1] + h[0])
        h, c = np.concatenate([[0.0], h]), np.concatenate([c[-1:] + t * (c[:1] - c[-1:]), c])
    return np.concatenate([h, [360.0]]), np.concatenate([c, c[:1]])


def mean_intensity(vertical: np.ndarray, horizontal: np.ndarray, candela: np.ndarray) -> float:
    """The profile's mean intensity over the sphere (the hemisphere, if its vertical angles span no more than pi / 2
    and a little): the integral of the interpolated intensity over solid angle, patch by patch (the patch's centre
    value times dh dv sin(v + dv / 2)), over 4 pi (2 pi), as Pixar's hdEmbree normalises profiles."""
    dv, dh = np.diff(vertical), np.diff(horizontal)
    centre = 0.25 * (candela[:-1, :-1] + candela[:-1, 1:] + candela[1:, :-1] + candela[1:, 1:])
    total = float(np.sum(centre * dh[:, None] * dv[None, :] * np.sin(vertical[:-1] + dv / 2)[None, :]))
    sphere = vertical[-1] - vertical[0] > math.pi / 2 + 0.1
    return total / (math.pi * (4.0 if sphere else 2.0))


def parse_ies(path: str, text: str) -> IesProfile:
    """The profile of an IES file's text (`path` names it in errors)."""
    lines = text.splitlines()
    tilt = _tilt_line(path, lines)
    numbers = _Numbers(path, lines, tilt + 1)
    if lines[tilt].split('=', 1)[-1].strip().upper() == 'INCLUDE':
        numbers.take('the lamp-to-luminaire geometry')
        n_tilt = int(numbers.take('the number of tilt angles', integer=True))
        numbers.many(2 * max(n_tilt, 0), 'a tilt angle or factor')
    numbers.take('the number of lamps')
    numbers.take('the lumens per lamp')
    factor = numbers.take('the candela multiplier')
    nv = int(numbers.take('the number of vertical angles', integer=True))
    nh = int(numbers.take('the number of horizontal angles', integer=True))
    kind = int(numbers.take('the photometric type', integer=True))
    if kind != TYPE_C:
        raise IesError(f'{path}:{numbers.line()}: photometric type {_TYPES.get(kind, kind)} is not supported '
                       f'(type C is)')
    if nv < 2 or nh < 1:
        raise IesError(f'{path}:{numbers.line()}: {nv} vertical and {nh} horizontal angles (at least 2 and 1)')
    numbers.many(4, 'the units and sizes')
    factor *= numbers.take('the ballast factor') * numbers.take('the ballast-lamp photometric factor')
    numbers.take('the input watts')
    v = numbers.many(nv, 'a vertical angle')
    v_line = numbers.line()
    h = numbers.many(nh, 'a horizontal angle')
    h_line = numbers.line()
    c = numbers.many(nv * nh, 'a candela value').reshape(nh, nv) * factor
    for name, a, line in (('vertical', v, v_line), ('horizontal', h, h_line)):
        if np.any(np.diff(a) <= 0.0):
            raise IesError(f'{path}:{line}: the {name} angles do not increase')
    if not (abs(v[0]) < _EPS or abs(v[0] - 90.0) < _EPS) or v[-1] > 180.0 + _EPS:
        raise IesError(f'{path}:{v_line}: vertical angles from {v[0]:g} to {v[-1]:g}: type C spans 0-90, 0-180 or '
                       f'90-180')
    if np.any(c < 0.0):
        raise IesError(f'{path}:{numbers.line()}: a negative candela value ({c.min():g})')
    h, c = _horizontal(path, h, c, h_line)
    vertical, horizontal = np.radians(np.minimum(v, 180.0)), np.radians(h)
    horizontal[-1] = 2 * math.pi
    return IesProfile(path=path, vertical=vertical, horizontal=horizontal, candela=np.ascontiguousarray(c),
                      mean=mean_intensity(vertical, horizontal, c))


@lru_cache(maxsize=64)
def _read(path: str, mtime: float) -> IesProfile:
    try:
        with open(path, 'rb') as f:
            text = f.read().decode('latin-1')
    except OSError as e:
        raise IesError(f'{path}: cannot be read ({e.strerror})') from None
    return parse_ies(path, text)


def read_ies(path: str) -> IesProfile:
    """The profile in the IES file `path` (read once while it is unchanged: many lights share a profile)."""
    try:
        mtime = os.stat(path).st_mtime
    except OSError as e:
        raise IesError(f'{path}: cannot be read ({e.strerror})') from None
    return _read(path, mtime)
