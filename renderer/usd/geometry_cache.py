"""Converted gprims kept across reads of one stage at other time codes (the frames of a shot).

    cache = GeometryCache()
    for frame in frames:
        desc = read_stage(stage, time=frame, geometry=cache)      # static meshes converted once

A gprim is *static* when none of the attributes the converter reads can vary in time: no attribute
of the prim nor of its GeomSubset children `ValueMightBeTimeVarying()` (at most one time sample),
except its xformOps, whose effect is the gprim-to-container matrix, part of the key.  A static
gprim converted with the same matrix gives the same records at every time code, so they are
converted once and handed out again while its matrix stays the same (the records copied - the reader sets their material - the
arrays shared and made read-only).  The warnings its conversion gave are given again.  Anything
time-varying - animated points, an animated subset, a radius - is converted at every read, as
without the cache.  The verdict per prim is time-independent and kept too.

The cache belongs to one stage: given another (or the same one after an edit of its layers, which
the caller must not do between reads), it starts empty.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np
from pxr import Usd, UsdGeom

from .geometry import convert_gprim, points_box

_TRANSFORM = ('xformOp:', 'xformOpOrder')


def _attributes_static(prim: Usd.Prim) -> bool:
    return not any(a.ValueMightBeTimeVarying() for a in prim.GetAttributes()
                   if not a.GetName().startswith(_TRANSFORM))


def is_static(prim: Usd.Prim) -> bool:
    """Can nothing the geometry converter reads of `prim` change with the time code?"""
    if not _attributes_static(prim):
        return False
    return all(_attributes_static(child) for child in prim.GetChildren() if child.IsA(UsdGeom.Subset))


@dataclass
class _Kept:
    matrix: bytes                    # the gprim-to-container matrix it was converted with
    records: list
    warnings: list


@dataclass
class GeometryCache:
    stage: object = None
    kept: dict = field(default_factory=dict)        # path -> _Kept (the last matrix only)
    static: dict = field(default_factory=dict)      # path -> is_static
    boxes: dict = field(default_factory=dict)       # id of a kept points array -> its (lo, hi)
    hits: int = 0
    misses: int = 0                                 # static gprims converted (then kept)
    varying: int = 0                                # time-varying gprims converted (not kept)

    def use(self, stage) -> None:
        """Serve `stage` (emptied when it is another stage than the last one's)."""
        if stage is not self.stage:
            self.kept.clear()
            self.static.clear()
            self.boxes.clear()
            self.stage = stage

    def convert(self, prim: Usd.Prim, to_container: np.ndarray, time: Usd.TimeCode, warn, posed=None) -> list:
        """`convert_gprim(prim, to_container, time, warn, posed)`, from the cache when `prim` is static, not posed
        by a skeleton (whose animation the prim's attributes do not show), and was converted with the same matrix
        last time."""
        path = str(prim.GetPath())
        static = self.static.get(path)
        if static is None:
            static = self.static[path] = is_static(prim)
        if not static or posed is not None:
            self.varying += 1
            return convert_gprim(prim, to_container, time, warn, posed)
        matrix = np.ascontiguousarray(to_container, np.float64).tobytes()
        kept = self.kept.get(path)
        if kept is not None and kept.matrix == matrix:
            self.hits += 1
            for message in kept.warnings:
                warn(message)
        else:
            said: list[str] = []

            def note(message: str) -> None:
                said.append(message)
                warn(message)
            records = convert_gprim(prim, to_container, time, note)    # GeometryError: not kept
            self._forget(kept)
            for r in records:
                for value in vars(r).values():
                    if isinstance(value, np.ndarray):
                        value.flags.writeable = False
                if isinstance(getattr(r, 'points', None), np.ndarray):
                    self.boxes[id(r.points)] = points_box(r.points)     # kept alive by the records
            self.kept[path] = kept = _Kept(matrix, records, said)
            self.misses += 1
        return [copy.copy(r) for r in kept.records]

    def _forget(self, kept: _Kept | None) -> None:
        """A static gprim placed with another matrix (a moving one): only the last is kept."""
        if kept is not None:
            for r in kept.records:
                self.boxes.pop(id(getattr(r, 'points', None)), None)

    def box(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """`points_box(points)`, remembered for the points of kept records."""
        found = self.boxes.get(id(points))
        return found if found is not None else points_box(points)
